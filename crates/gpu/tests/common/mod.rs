//! Shared by the GPU test binaries: the device, and scenes.

#![allow(dead_code)]

use std::sync::{Arc, OnceLock};

use dem::geometry::{Element, Geometry};
use dem::material::{Interaction, Material, MaterialTable};
use dem::particles::Particles;
use dem::sim::{Simulation, SimulationParams};
use dem_gpu::{GpuContext, GpuStages};
use glam::DVec3;

/// One context per test binary: compiling the kernels on lavapipe takes a moment.
pub fn gpu() -> Option<Arc<GpuContext>> {
    static CTX: OnceLock<Result<Arc<GpuContext>, String>> = OnceLock::new();
    match CTX.get_or_init(|| GpuContext::new().map(Arc::new)) {
        Ok(c) => {
            eprintln!("GPU: {}", c.adapter());
            Some(c.clone())
        }
        Err(e) if std::env::var_os("DEMCAL_REQUIRE_GPU").is_some() => {
            panic!("DEMCAL_REQUIRE_GPU is set and there is no GPU: {e}")
        }
        Err(e) => {
            eprintln!("skipped: {e}");
            None
        }
    }
}

/// Runs each of `cases` on a thread of its own, all in one new batch group on `ctx`, by `run`
/// (which gets the case and its back end); their results in the cases' order.
pub fn together<C: Sync, E: Send>(
    ctx: &Arc<GpuContext>,
    cases: &[C],
    run: impl Fn(&C, GpuStages) -> E + Sync,
) -> Vec<E> {
    let group = dem::sim::new_batch_group();
    let run = &run;
    std::thread::scope(|scope| {
        let threads: Vec<_> = cases
            .iter()
            .map(|case| {
                let stages = GpuStages::with_context(ctx.clone()).in_batch_group(group);
                scope.spawn(move || run(case, stages))
            })
            .collect();
        threads.into_iter().map(|t| t.join().unwrap()).collect()
    })
}

pub fn material(name: &str, youngs: f64, density: f64) -> Material {
    Material {
        name: name.into(),
        density,
        poisson_ratio: 0.3,
        shear_modulus: youngs / 2.6,
    }
}

/// Uniform numbers in [0, 1) from a 64-bit LCG: the scenes' jitter, the same on every machine.
pub fn uniform(mut seed: u64) -> impl FnMut() -> f64 {
    move || {
        seed = seed
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (seed >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// A heap poured into a cylinder standing on a plate, which is lifted after 0.02 s.
pub struct Heap {
    pub seed: u64,
    pub spheres: usize,
    pub time_step: f64,
    /// Sphere-sphere static friction.
    pub friction: f64,
}

impl Default for Heap {
    fn default() -> Heap {
        Heap {
            seed: 99,
            spheres: 120,
            time_step: 1e-5,
            friction: 0.6,
        }
    }
}

pub fn heap(h: &Heap) -> Simulation {
    use dem::geometry::Motion;
    let mut t = MaterialTable::new();
    let a = t.add_material(material("bead", 5e6 * 2.6, 1500.0));
    let b = t.add_material(material("steel", 7e10 * 2.6, 7850.0));
    let law = |restitution, friction, rolling| Interaction {
        restitution,
        static_friction: friction,
        rolling_friction: rolling,
        surface_energy: 0.0,
    };
    t.set_interaction(a, a, law(0.4, h.friction, 0.15));
    t.set_interaction(a, b, law(0.5, 0.3, 0.05));
    t.set_interaction(b, b, law(0.5, 0.3, 0.05));
    let mut rnd = uniform(h.seed);
    let mut p = Particles::default();
    for k in 0..h.spheres {
        let (ang, rad) = (rnd() * std::f64::consts::TAU, rnd().sqrt() * 0.006);
        let x = DVec3::new(rad * ang.cos(), rad * ang.sin(), 0.0012 + 0.0011 * k as f64);
        p.push(x, DVec3::new(0.0, 0.0, -0.3), 0.001, 1500.0, 0);
    }
    let plate = Geometry::new(
        "plate",
        1,
        vec![Element::Plane {
            point: DVec3::ZERO,
            normal: DVec3::Z,
        }],
    );
    let cylinder = Geometry::new(
        "cylinder",
        1,
        vec![Element::CylinderShell {
            base: DVec3::ZERO,
            axis: DVec3::Z,
            radius: 0.0075,
            length: 0.2,
        }],
    )
    .with_motion(vec![Motion::Translation {
        velocity: DVec3::new(0.0, 0.0, 0.1),
        start: 0.02,
        end: 1.0,
    }]);
    Simulation::new(
        p,
        t,
        vec![plate, cylinder],
        SimulationParams {
            time_step: h.time_step,
            gravity: DVec3::new(0.0, 0.0, -9.81),
            skin: 0.0002,
            ..Default::default()
        },
    )
}

/// 24 clumps (dumbbells and triples) falling onto a floor, tumbling (the GPU agreement and batch
/// tests' clump scene).
pub fn tumbling_clumps() -> Simulation {
    use dem::clump::{Bodies, ClumpTemplate};
    use glam::DQuat;
    let dumbbell = ClumpTemplate::new(vec![
        (DVec3::ZERO, 0.001),
        (DVec3::new(0.0015, 0.0, 0.0), 0.001),
    ])
    .unwrap();
    let triple = ClumpTemplate::new(vec![
        (DVec3::ZERO, 0.001),
        (DVec3::new(0.0012, 0.0, 0.0), 0.0008),
        (DVec3::new(0.0, 0.0012, 0.0005), 0.0009),
    ])
    .unwrap();
    let mut p = Particles::default();
    let mut bodies = Bodies::default();
    for k in 0..24 {
        let t = if k % 2 == 0 { &dumbbell } else { &triple };
        let props = t.mass_properties();
        let at = DVec3::new(
            0.002 * (k % 3) as f64 - 0.002,
            0.002 * ((k / 3) % 2) as f64,
            0.003 + 0.0035 * (k / 6) as f64,
        );
        let turn = DQuat::from_rotation_z(0.7 * k as f64) * DQuat::from_rotation_x(0.3 * k as f64);
        bodies.add(
            &mut p,
            t,
            &props,
            2500.0,
            0,
            at,
            turn,
            DVec3::new(0.0, 0.0, -0.2),
        );
    }
    let floor = Geometry::new(
        "floor",
        1,
        vec![Element::Plane {
            point: DVec3::ZERO,
            normal: DVec3::Z,
        }],
    );
    let mut t = MaterialTable::new();
    let a = t.add_material(material("grain", 1e7, 2500.0));
    let b = t.add_material(material("steel", 2e9, 7800.0));
    let i = Interaction {
        restitution: 0.5,
        static_friction: 0.5,
        rolling_friction: 0.1,
        surface_energy: 0.0,
    };
    t.set_interaction(a, a, i.clone());
    t.set_interaction(a, b, i.clone());
    t.set_interaction(b, b, i);
    let min_r = p.radius.iter().cloned().fold(f64::INFINITY, f64::min);
    Simulation::new(
        p,
        t,
        vec![floor],
        SimulationParams {
            time_step: 1e-5,
            gravity: DVec3::new(0.0, 0.0, -9.81),
            rolling_model: dem::contact::RollingModel::ConstantDirectionalTorque,
            skin: 0.2 * min_r,
            ..Default::default()
        },
    )
    .with_bodies(bodies)
}
