//! Engine behaviour beyond the verification cases of docs/physics.md: meshes, geometry loads,
//! moving walls, contact history across neighbour-list rebuilds, and determinism.

mod common;

use common::*;
use dem::contact::RollingModel;
use dem::geometry::{read_stl, Element, Geometry, Motion};
use dem::particles::Particles;
use dem::scene::Scene;
use glam::DVec3;
use std::io::Write;
use std::path::Path;

const CDT: RollingModel = RollingModel::ConstantDirectionalTorque;

/// A flat square [-h, h]^2 at z = 0 split into 2 n^2 triangles.
fn flat_patch(h: f64, n: usize) -> Vec<[DVec3; 3]> {
    let mut tris = Vec::new();
    let s = 2.0 * h / n as f64;
    for i in 0..n {
        for j in 0..n {
            let p = |a: usize, b: usize| DVec3::new(-h + a as f64 * s, -h + b as f64 * s, 0.0);
            tris.push([p(i, j), p(i + 1, j), p(i + 1, j + 1)]);
            tris.push([p(i, j), p(i + 1, j + 1), p(i, j + 1)]);
        }
    }
    tris
}

fn write_binary_stl(path: &Path, tris: &[[DVec3; 3]]) {
    let mut f = std::fs::File::create(path).unwrap();
    f.write_all(&[0u8; 80]).unwrap();
    f.write_all(&(tris.len() as u32).to_le_bytes()).unwrap();
    for t in tris {
        let n = (t[1] - t[0]).cross(t[2] - t[0]).normalize();
        for v in std::iter::once(n).chain(t.iter().cloned()) {
            for c in [v.x, v.y, v.z] {
                f.write_all(&(c as f32).to_le_bytes()).unwrap();
            }
        }
        f.write_all(&[0u8; 2]).unwrap();
    }
}

fn write_ascii_stl(path: &Path, tris: &[[DVec3; 3]]) {
    let mut s = String::from("solid patch\n");
    for t in tris {
        s += "facet normal 0 0 1\nouter loop\n";
        for v in t {
            s += &format!("vertex {} {} {}\n", v.x, v.y, v.z);
        }
        s += "endloop\nendfacet\n";
    }
    s += "endsolid patch\n";
    std::fs::write(path, s).unwrap();
}

fn temp_dir(name: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("demcal-test-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Settles one sphere on a geometry and returns the vertical load the geometry carries / weight.
fn resting_load_ratio(elements: Vec<Element>, at: DVec3) -> f64 {
    let (r, rho) = (0.005, 2500.0);
    let m = material("m", 1e8, 0.3, rho);
    let t = table(m.clone(), m, interaction(0.3, 0.5, 0.0));
    let mut p = Particles::default();
    p.push(at + DVec3::new(0.0, 0.0, r * 0.999), DVec3::ZERO, r, rho, 0);
    let weight = p.mass[0] * 9.81;
    let g = Geometry::new("patch", 1, elements);
    let mut sim = simulation(p, t, vec![g], 1e-5, DVec3::new(0.0, 0.0, -9.81), CDT);
    sim.run(30_000).unwrap();
    -sim.geometries[0].load.force.z / weight
}

#[test]
fn sphere_on_a_triangulated_patch_is_pushed_once() {
    let dir = temp_dir("mesh");
    let tris = flat_patch(0.05, 10);
    write_binary_stl(&dir.join("patch.stl"), &tris);
    write_ascii_stl(&dir.join("patch_ascii.stl"), &tris);
    let binary = read_stl(&dir.join("patch.stl"), 1.0, DVec3::ZERO).unwrap();
    let ascii = read_stl(&dir.join("patch_ascii.stl"), 1.0, DVec3::ZERO).unwrap();
    assert_eq!(binary.len(), 200);
    assert_eq!(ascii.len(), 200);
    // Over a face, over a shared edge (diagonal and grid line), and over a vertex where 6 triangles meet.
    for at in [
        DVec3::new(0.003, 0.001, 0.0),
        DVec3::new(0.002, 0.002, 0.0),
        DVec3::new(0.0, 0.004, 0.0),
        DVec3::new(0.0, 0.0, 0.0),
    ] {
        let ratio = resting_load_ratio(binary.clone(), at);
        assert!(
            (ratio - 1.0).abs() < 1e-3,
            "load / weight = {ratio} at {at}"
        );
    }
}

#[test]
fn stl_scale_converts_millimetres() {
    let dir = temp_dir("scale");
    let tris: Vec<[DVec3; 3]> = flat_patch(50.0, 2);
    write_binary_stl(&dir.join("mm.stl"), &tris);
    let els = read_stl(&dir.join("mm.stl"), 0.001, DVec3::new(0.0, 0.0, 0.01)).unwrap();
    let (lo, hi) = els
        .iter()
        .map(|e| e.bounds())
        .fold((DVec3::splat(1e9), DVec3::splat(-1e9)), |(a, b), (c, d)| {
            (a.min(c), b.max(d))
        });
    assert!((lo - DVec3::new(-0.05, -0.05, 0.01)).length() < 1e-6);
    assert!((hi - DVec3::new(0.05, 0.05, 0.01)).length() < 1e-6);
}

#[test]
fn a_rising_plate_lifts_a_sphere_at_its_speed() {
    let (r, rho) = (0.005, 2500.0);
    let m = material("m", 1e8, 0.3, rho);
    let t = table(m.clone(), m, interaction(0.3, 0.5, 0.0));
    let mut p = Particles::default();
    p.push(DVec3::new(0.0, 0.0, r * 0.999), DVec3::ZERO, r, rho, 0);
    let plate = Geometry::new(
        "plate",
        1,
        vec![Element::Rect {
            center: DVec3::ZERO,
            normal: DVec3::Z,
            u: DVec3::X,
            v: DVec3::Y,
            half_u: 0.05,
            half_v: 0.05,
        }],
    )
    .with_motion(vec![Motion::Translation {
        velocity: DVec3::new(0.0, 0.0, 0.1),
        start: 0.1,
        end: 0.3,
    }]);
    let mut sim = simulation(p, t, vec![plate], 1e-5, DVec3::new(0.0, 0.0, -9.81), CDT);
    sim.run(40_000).unwrap(); // 0.4 s: rest, 0.2 s of lift by 20 mm, rest
    let z = sim.particles.position[0].z;
    assert!((z - (r + 0.02)).abs() < 2e-4, "z = {z}");
    assert!((sim.geometries[0].translation.z - 0.02).abs() < 1e-9);
}

#[test]
fn rotating_drum_carries_load_torque() {
    // A sphere resting at the bottom of a slowly turning cylinder is dragged along; the drum
    // records a torque about its axis opposing the rotation.
    let (r, rho) = (0.005, 2500.0);
    let m = material("m", 1e8, 0.3, rho);
    let t = table(m.clone(), m, interaction(0.3, 0.8, 0.0));
    let mut p = Particles::default();
    p.push(
        DVec3::new(0.0, 0.0, -0.05 + r * 0.999),
        DVec3::ZERO,
        r,
        rho,
        0,
    );
    let mut drum = Geometry::new(
        "drum",
        1,
        dem::geometry::shapes::cylinder(
            DVec3::new(-0.05, 0.0, 0.0),
            DVec3::X,
            0.05,
            0.1,
            false,
            false,
        ),
    )
    .with_motion(vec![Motion::Rotation {
        axis_point: DVec3::ZERO,
        axis: DVec3::X,
        angular_velocity: 1.0,
        start: 0.0,
        end: f64::INFINITY,
    }]);
    drum.torque_point = DVec3::ZERO;
    let mut sim = simulation(p, t, vec![drum], 1e-5, DVec3::new(0.0, 0.0, -9.81), CDT);
    sim.run(20_000).unwrap();
    let torque = sim.geometries[0].load.torque.x;
    assert!(torque < 0.0, "torque {torque}");
    // The sphere has moved with the wall in the rotation direction (+x rotation moves the bottom to +y... -y).
    assert!(sim.particles.position[0].y.abs() > 1e-4);
}

#[test]
fn wall_history_survives_neighbour_rebuilds() {
    // A sphere held on a 20 deg incline by static friction alone (mu_r = 0 would let it roll, so use
    // rolling friction to stop the spin) while a second particle falls far away and forces frequent
    // list rebuilds: losing the tangential spring at each rebuild would let the held sphere creep.
    let (r, rho) = (0.01, 2500.0);
    let th = 10f64.to_radians();
    let m = material("m", 1e8, 0.3, rho);
    let t = table(m.clone(), m, interaction(0.5, 0.5, 0.3));
    let mut p = Particles::default();
    p.push(DVec3::ZERO, DVec3::ZERO, r, rho, 0);
    p.push(
        DVec3::new(5.0, 0.0, 5.0),
        DVec3::new(0.0, 0.0, 3.0),
        r,
        rho,
        0,
    );
    let weight = p.mass[0] * 9.81 * th.cos();
    let e_star = t.pair(0, 1).e_star;
    p.position[0].z = r - resting_overlap(weight, e_star, r);
    let g = DVec3::new(9.81 * th.sin(), 0.0, -9.81 * th.cos());
    let mut sim = simulation(p, t, vec![floor(1)], 2e-5, g, CDT);
    let start = sim
        .particles
        .position
        .iter()
        .cloned()
        .find(|x| x.x < 1.0)
        .unwrap();
    sim.run(50_000).unwrap();
    assert!(
        sim.neighbour_rebuilds() > 100,
        "rebuilds {}",
        sim.neighbour_rebuilds()
    );
    let held = sim
        .particles
        .position
        .iter()
        .cloned()
        .find(|x| x.x < 1.0)
        .unwrap();
    assert!(
        (held - start).length() < 1e-3 * r,
        "drift {}",
        (held - start).length()
    );
}

fn settle_positions(threads: usize) -> Vec<DVec3> {
    settle_state(threads, true).0
}

fn settle_state(threads: usize, whole_run: bool) -> (Vec<DVec3>, Vec<DVec3>) {
    settle_state_with(DETERMINISM_SCENE, threads, whole_run, None).0
}

/// Positions and velocities by stable id after `scene`, run with `run` (which does each next
/// step's integration in the step before's last pass) or step by step (which does not), and the
/// pair passes over every pair and over the near pairs; with `near_margin`, that fraction of
/// the skin for the near list.
fn settle_state_with(
    scene: &str,
    threads: usize,
    whole_run: bool,
    near_margin: Option<f64>,
) -> ((Vec<DVec3>, Vec<DVec3>), (u64, u64)) {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    pool.install(|| {
        let mut s = Scene::from_toml(scene, "det.toml", Path::new(".")).unwrap();
        if let Some(m) = near_margin {
            s.simulation.params.near_margin_fraction = m;
        }
        if whole_run {
            s.simulation.run(s.steps).unwrap();
        } else {
            for _ in 0..s.steps {
                s.simulation.step().unwrap();
            }
        }
        let p = &s.simulation.particles;
        let mut x = vec![DVec3::ZERO; p.len()];
        let mut v = vec![DVec3::ZERO; p.len()];
        for k in 0..p.len() {
            x[p.id[k] as usize] = p.position[k];
            v[p.id[k] as usize] = p.velocity[k];
        }
        ((x, v), s.simulation.pair_passes())
    })
}

/// 1 500 spheres poured into a cylinder.
const DETERMINISM_SCENE: &str = r#"
        [simulation]
        steps = 1500
        time_step_percent = 20
        [[material]]
        name = "m"
        density = 2500
        poisson_ratio = 0.3
        shear_modulus = 1e7
        [[interaction]]
        materials = ["m", "m"]
        restitution = 0.4
        static_friction = 0.5
        dynamic_friction = 0.1
        [[geometry]]
        type = "cylinder"
        material = "m"
        base = [0.0, 0.0, 0.0]
        radius = 0.03
        length = 0.1
        caps = "bottom"
        [[particles]]
        material = "m"
        size = { type = "uniform", min = 0.0015, max = 0.0025 }
        region = { type = "cylinder", base = [0.0, 0.0, 0.0], radius = 0.03, length = 0.1 }
        fill = { type = "random", count = 1500, seed = 3 }
    "#;

/// The near list is an optimisation only: the pairs it leaves out cannot touch until it is
/// scanned again, so the run without it (every pair visited at every step) gives the same bits,
/// whatever its margin.
#[test]
fn the_near_list_changes_nothing() {
    // The spheres of the determinism scene; the same with JKR cohesion (pairs attract beyond
    // touching, so the margin is beyond the law's reach); three-sphere rods (clumps, whose
    // members are placed by their bodies and integrated apart from the gather).
    let cohesive = DETERMINISM_SCENE.replace(
        "dynamic_friction = 0.1",
        "dynamic_friction = 0.1\nsurface_energy = 0.5",
    );
    let rods = DETERMINISM_SCENE
        .replace(
            "size = { type = \"uniform\", min = 0.0015, max = 0.0025 }",
            "shape = { type = \"rod\", length = 0.005, diameter = 0.0025, count = 3 }",
        )
        .replace("count = 1500", "count = 400");
    assert_ne!(cohesive, DETERMINISM_SCENE);
    assert_ne!(rods, DETERMINISM_SCENE);
    let mut references = Vec::new();
    for (name, scene) in [
        ("spheres", DETERMINISM_SCENE),
        ("cohesive", &cohesive),
        ("rods", &rods),
    ] {
        let (reference, (full, near)) = settle_state_with(scene, 2, true, Some(0.0));
        references.push(reference.clone());
        assert_eq!(near, 0, "{name}: no near list without a margin");
        assert!(full > 1000, "{name}: {full} full passes");
        for margin in [0.125, 0.5] {
            let (state, (full, near)) = settle_state_with(scene, 2, true, Some(margin));
            assert_eq!(state, reference, "{name}: margin {margin} of the skin");
            eprintln!("{name}, margin {margin}: {full} full passes, {near} near ones");
            assert!(
                near > 100,
                "{name}, margin {margin}: the near list was used ({near} passes)"
            );
        }
    }
    // Cohesion did change the run.
    assert_ne!(references[0], references[1]);
}

/// Doing the next step's half kick and drift in the last pass of a step (what `run` does) is the
/// same arithmetic in the same order as a separate integration stage: the states agree bit for
/// bit.
#[test]
fn integrating_ahead_in_the_gather_changes_nothing() {
    let fused = settle_state(2, true);
    let stepped = settle_state(2, false);
    assert_eq!(fused, stepped);
    assert!(
        fused.1.iter().any(|v| v.length() > 0.01),
        "the spheres moved"
    );
}

#[test]
fn results_are_identical_run_to_run_and_across_thread_counts() {
    let a = settle_positions(2);
    let b = settle_positions(2);
    let c = settle_positions(1);
    assert_eq!(a, b);
    assert_eq!(a, c);
    // The particles really did fall and collide.
    assert!(a.iter().any(|x| x.z < 0.01));
}

#[test]
fn geometry_torque_is_reported_about_its_torque_point() {
    // A sphere resting 30 mm from the torque point along x presses on the floor with its weight:
    // torque = r x F = (0.03, 0, -z0) x (0, 0, -m g) = (0, 0.03 m g, 0).
    let (r, rho) = (0.005, 2500.0);
    let m = material("m", 1e8, 0.3, rho);
    let t = table(m.clone(), m, interaction(0.3, 0.5, 0.0));
    let mut p = Particles::default();
    p.push(DVec3::new(0.03, 0.0, r * 0.999), DVec3::ZERO, r, rho, 0);
    let weight = p.mass[0] * 9.81;
    let mut plate = floor(1);
    plate.torque_point = DVec3::new(0.0, 0.0, -0.01);
    let mut sim = simulation(p, t, vec![plate], 1e-5, DVec3::new(0.0, 0.0, -9.81), CDT);
    sim.run(30_000).unwrap();
    let load = sim.geometries[0].load;
    assert!(rel_err(-load.force.z, weight) < 1e-3, "{:?}", load.force);
    assert!(
        rel_err(load.torque.y, 0.03 * weight) < 1e-3,
        "{:?}",
        load.torque
    );
    assert!(load.torque.x.abs() < 1e-6 * weight && load.torque.z.abs() < 1e-6 * weight);
}
