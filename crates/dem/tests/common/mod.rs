//! Helpers to build small verification scenes in code.
#![allow(dead_code)]

use dem::contact::RollingModel;
use dem::geometry::{Element, Geometry};
use dem::material::{Interaction, Material, MaterialTable};
use dem::particles::Particles;
use dem::sim::{Simulation, SimulationParams};
use glam::DVec3;

pub fn material(name: &str, youngs: f64, poisson: f64, density: f64) -> Material {
    Material {
        name: name.into(),
        density,
        poisson_ratio: poisson,
        shear_modulus: youngs / (2.0 * (1.0 + poisson)),
    }
}

/// A table with a particle material (id 0) and a wall material (id 1), one interaction for every pair.
pub fn table(particle: Material, wall: Material, inter: Interaction) -> MaterialTable {
    let mut t = MaterialTable::new();
    let a = t.add_material(particle);
    let b = t.add_material(wall);
    t.set_interaction(a, a, inter.clone());
    t.set_interaction(a, b, inter.clone());
    t.set_interaction(b, b, inter);
    t
}

pub fn interaction(restitution: f64, static_friction: f64, rolling_friction: f64) -> Interaction {
    Interaction {
        restitution,
        static_friction,
        rolling_friction,
        surface_energy: 0.0,
    }
}

pub fn floor(material: usize) -> Geometry {
    Geometry::new(
        "floor",
        material,
        vec![Element::Plane {
            point: DVec3::ZERO,
            normal: DVec3::Z,
        }],
    )
}

pub fn simulation(
    particles: Particles,
    table: MaterialTable,
    geometries: Vec<Geometry>,
    dt: f64,
    gravity: DVec3,
    rolling: RollingModel,
) -> Simulation {
    let min_r = particles
        .radius
        .iter()
        .cloned()
        .fold(f64::INFINITY, f64::min);
    Simulation::new(
        particles,
        table,
        geometries,
        SimulationParams {
            time_step: dt,
            gravity,
            rolling_model: rolling,
            skin: 0.2 * min_r,
            ..Default::default()
        },
    )
}

/// Overlap at which a sphere rests on a wall under weight `w` (Hertz: w = 4/3 E* sqrt(R) d^1.5).
pub fn resting_overlap(weight: f64, e_star: f64, r: f64) -> f64 {
    (weight / (4.0 / 3.0 * e_star * r.sqrt())).powf(2.0 / 3.0)
}

pub fn rel_err(got: f64, want: f64) -> f64 {
    ((got - want) / want).abs()
}
