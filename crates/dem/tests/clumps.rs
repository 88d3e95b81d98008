//! Clumps inside the simulation: free rotation through the engine's step, and a dumbbell coming to
//! rest on the floor with its weight carried by both spheres.

mod common;

use common::*;
use dem::clump::{Bodies, ClumpTemplate};
use dem::contact::RollingModel;
use dem::particles::Particles;
use glam::{DQuat, DVec3};

#[test]
fn v8_free_clump_in_the_engine_conserves_energy_and_momentum() {
    let t = ClumpTemplate::new(vec![
        (DVec3::new(0.0, 0.0, 0.0), 0.004),
        (DVec3::new(0.006, 0.0, 0.0), 0.003),
        (DVec3::new(0.0, 0.005, 0.001), 0.0025),
    ])
    .unwrap();
    let props = t.mass_properties();
    let mut p = Particles::default();
    let mut bodies = Bodies::default();
    bodies.add(
        &mut p,
        &t,
        &props,
        1000.0,
        0,
        DVec3::ZERO,
        DQuat::IDENTITY,
        DVec3::new(0.01, 0.0, 0.0),
    );
    let i = bodies.rotation[0].principal_inertia;
    bodies.rotation[0].angular_momentum = DVec3::new(0.05 * i.x, 20.0 * i.y, 0.05 * i.z);
    let table = table(
        material("m", 1e7, 0.3, 1000.0),
        material("w", 1e7, 0.3, 1000.0),
        interaction(0.5, 0.5, 0.0),
    );
    let mut sim = simulation(
        p,
        table,
        vec![],
        1e-4,
        DVec3::ZERO,
        RollingModel::ConstantDirectionalTorque,
    )
    .with_bodies(bodies);
    let e0 = sim.kinetic_energy();
    let l0 = sim.bodies.rotation[0].angular_momentum;
    let mut largest = 0.0f64;
    for _ in 0..100_000 {
        sim.step().unwrap();
        largest = largest.max(rel_err(sim.kinetic_energy(), e0));
    }
    let l1 = sim.bodies.rotation[0].angular_momentum;
    eprintln!("V8 engine: largest relative energy change {largest:.2e} over 1e5 steps");
    assert!(largest < 1e-3);
    assert!((l1 - l0).length() < 1e-9 * l0.length());
    // Members follow the body rigidly: their distances to the centre of mass stay as built.
    let com = sim.bodies.position[0];
    assert!(
        (com.x - 0.01 * 10.0).abs() < 1e-9,
        "drifted at constant velocity: {com}"
    );
    for k in 0..3 {
        let d = (sim.particles.position[k] - com).length();
        assert!((d - sim.particles.body_offset[k].length()).abs() < 1e-12);
    }
}

#[test]
fn dumbbell_comes_to_rest_lying_on_the_floor() {
    let r = 0.005;
    let t = ClumpTemplate::rod(0.03, 2.0 * r, 2).unwrap();
    let props = t.mass_properties();
    let mut p = Particles::default();
    let mut bodies = Bodies::default();
    // Tilted 30 degrees, dropped from a few millimetres.
    let q = DQuat::from_rotation_y(30f64.to_radians());
    bodies.add(
        &mut p,
        &t,
        &props,
        1000.0,
        0,
        DVec3::new(0.0, 0.0, 0.02),
        q,
        DVec3::ZERO,
    );
    let mass = bodies.mass[0];
    let table = table(
        material("m", 1e7, 0.3, 1000.0),
        material("steel", 2e11, 0.3, 7800.0),
        interaction(0.3, 0.5, 0.05),
    );
    let e_star = table.pair(0, 1).e_star;
    let mut sim = simulation(
        p,
        table,
        vec![floor(1)],
        2e-6,
        DVec3::new(0.0, 0.0, -9.81),
        RollingModel::ConstantDirectionalTorque,
    )
    .with_bodies(bodies);
    sim.run(300_000).unwrap(); // 0.6 s
    let zs: Vec<f64> = sim.particles.position.iter().map(|x| x.z).collect();
    let rest = r - resting_overlap(0.5 * mass * 9.81, e_star, r);
    eprintln!(
        "dumbbell: member heights {zs:?}, expected {rest:.6e}; floor load {:.6e} N vs weight {:.6e} N; KE {:.2e} J",
        sim.geometries[0].load.force.z,
        mass * 9.81,
        sim.kinetic_energy()
    );
    for z in &zs {
        assert!(
            (z - rest).abs() < 1e-3 * r,
            "member at {z}, expected {rest}"
        );
    }
    // The load is the force on the floor: the weight, pointing down.
    assert!(rel_err(-sim.geometries[0].load.force.z, mass * 9.81) < 1e-3);
    assert!(sim.kinetic_energy() < 1e-9);
}
