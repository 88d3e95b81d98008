//! Batches: simulations that run at the same time in one batch group share kernel launches, and
//! each ends exactly as it would alone, whatever its neighbours (their parameters, time steps,
//! particle counts, moving walls, numbers of steps, or a failure among them).

use dem::contact::RollingModel;
use dem::material::{Interaction, MaterialTable};
use dem::particles::Particles;
use dem::sim::{Simulation, SimulationParams};
use dem_gpu::batch::batch_stats;
use dem_gpu::GpuStages;
use glam::DVec3;

mod common;
use common::{gpu, heap, material, together, Heap};

/// A scene and the steps it runs, in calls to `run`.
struct Case {
    name: &'static str,
    make: fn() -> Simulation,
    runs: &'static [u64],
}

fn heap_a() -> Simulation {
    heap(&Heap::default())
}

fn heap_b() -> Simulation {
    heap(&Heap {
        seed: 7,
        spheres: 80,
        time_step: 8e-6,
        friction: 0.3,
    })
}

fn heap_c() -> Simulation {
    let mut s = heap(&Heap {
        seed: 3,
        spheres: 150,
        time_step: 1.2e-5,
        friction: 0.9,
    });
    s.params.rolling_model = RollingModel::Epsd {
        viscous_damping: 0.3,
    };
    s.params.gravity = DVec3::new(0.5, 0.0, -9.81);
    s
}

/// A heap with one sphere thrown sideways at 100 m/s: it bounces off the cylinder and leaves the
/// domain within a few hundred steps.
fn escaping() -> Simulation {
    let mut s = heap(&Heap {
        seed: 11,
        spheres: 40,
        ..Heap::default()
    });
    s.params.domain = Some((DVec3::splat(-0.05), DVec3::splat(0.3)));
    s.particles.velocity[0] = DVec3::new(100.0, 0.0, 0.0);
    s
}

/// 64 overlapping spheres of one cohesive (JKR) material, with no walls and no gravity.
fn sticky_cloud() -> Simulation {
    let mut t = MaterialTable::new();
    let a = t.add_material(material("clay", 1e7, 1800.0));
    t.set_interaction(
        a,
        a,
        Interaction {
            restitution: 0.3,
            static_friction: 0.7,
            rolling_friction: 0.05,
            surface_energy: 0.5,
        },
    );
    let mut p = Particles::default();
    for k in 0..64 {
        let (x, y, z) = ((k % 4) as f64, ((k / 4) % 4) as f64, (k / 16) as f64);
        let v = DVec3::new(
            (k % 3) as f64 - 1.0,
            (k % 5) as f64 - 2.0,
            (k % 7) as f64 - 3.0,
        );
        p.push(DVec3::new(x, y, z) * 0.0019, v * 0.05, 0.001, 1800.0, 0);
    }
    Simulation::new(
        p,
        t,
        vec![],
        SimulationParams {
            time_step: 2e-6,
            skin: 0.0002,
            gravity: DVec3::ZERO,
            ..Default::default()
        },
    )
}

/// The sticky cloud with one sphere of infinite inverse mass: its first kick is not finite, so the
/// world is not finite after one step (and its NaN sits in the batch's buffers from then on).
fn exploding() -> Simulation {
    let mut s = sticky_cloud();
    s.particles.inv_mass[5] = f64::INFINITY;
    s
}

const CASES: &[Case] = &[
    Case {
        name: "heap a",
        make: heap_a,
        runs: &[1500, 1500],
    },
    Case {
        name: "heap b (80 spheres, dt 8e-6)",
        make: heap_b,
        runs: &[700, 2100],
    },
    Case {
        name: "heap c (150 spheres, epsd, tilted gravity)",
        make: heap_c,
        runs: &[2500],
    },
    Case {
        name: "escaping sphere",
        make: escaping,
        runs: &[1000],
    },
    Case {
        name: "sticky cloud (JKR, one material, no walls)",
        make: sticky_cloud,
        runs: &[1200, 600],
    },
    Case {
        name: "exploding spheres",
        make: exploding,
        runs: &[2000],
    },
    Case {
        name: "tumbling clumps",
        make: common::tumbling_clumps,
        runs: &[1000, 1000],
    },
];

/// What a case ended with: the state, the geometry loads, and the error of a failed run.
#[derive(Debug)]
struct End {
    position: Vec<DVec3>,
    velocity: Vec<DVec3>,
    angular_velocity: Vec<DVec3>,
    force: Vec<DVec3>,
    loads: Vec<DVec3>,
    steps: u64,
    error: Option<String>,
}

impl End {
    /// The same bits (a failed run's state may hold NaN, which `==` never matches).
    fn same(&self, other: &End) -> bool {
        let bits = |e: &End| -> Vec<u64> {
            [
                &e.position,
                &e.velocity,
                &e.angular_velocity,
                &e.force,
                &e.loads,
            ]
            .iter()
            .flat_map(|v| v.iter().flat_map(|x| x.to_array().map(f64::to_bits)))
            .collect()
        };
        bits(self) == bits(other) && self.steps == other.steps && self.error == other.error
    }
}

fn run(case: &Case, stages: GpuStages) -> End {
    let mut sim = (case.make)().with_backend(Box::new(stages.clone()));
    let mut error = None;
    for &steps in case.runs {
        if let Err(e) = sim.run(steps) {
            error = Some(e.to_string());
            break;
        }
    }
    let (segments, declined, retried) = stages.segments();
    eprintln!(
        "{}: {segments} segments, {declined} declined, {retried} retried",
        case.name
    );
    assert!(
        segments > 0 && declined == 0,
        "{}: {segments} segments, {declined} declined",
        case.name
    );
    let p = &sim.particles;
    End {
        position: p.position.clone(),
        velocity: p.velocity.clone(),
        angular_velocity: p.angular_velocity.clone(),
        force: p.force.clone(),
        loads: sim.geometries.iter().map(|g| g.load.force).collect(),
        steps: sim.steps,
        error,
    }
}

#[test]
fn a_batch_gives_each_simulation_the_bits_it_gets_alone() {
    let Some(ctx) = gpu() else {
        return;
    };
    let t = std::time::Instant::now();
    let alone: Vec<End> = CASES
        .iter()
        .map(|case| run(case, GpuStages::with_context(ctx.clone())))
        .collect();
    let alone_s = t.elapsed().as_secs_f64();
    let before = batch_stats();
    let t = std::time::Instant::now();
    let batched = together(&ctx, CASES, run);
    let together_s = t.elapsed().as_secs_f64();
    let after = batch_stats();
    eprintln!(
        "alone one after another {alone_s:.1} s, batched {together_s:.1} s; {} batches of {} worlds (largest {})",
        after.batches - before.batches,
        after.worlds - before.worlds,
        after.largest
    );
    assert!(
        after.batches > before.batches && after.largest >= 3 && after.split == before.split,
        "the simulations did not share launches: {before:?} -> {after:?}"
    );
    for ((case, a), b) in CASES.iter().zip(&alone).zip(&batched) {
        let differs = |x: &[DVec3], y: &[DVec3]| {
            x.iter()
                .zip(y)
                .map(|(p, q)| (*p - *q).abs().max_element())
                .fold(0.0, f64::max)
        };
        assert!(
            a.same(b),
            "{}: batched differs from alone: steps {} vs {}, errors {:?} vs {:?}, largest differences: position {:e}, velocity {:e}, force {:e}, loads {:?} vs {:?}",
            case.name,
            a.steps,
            b.steps,
            a.error,
            b.error,
            differs(&a.position, &b.position),
            differs(&a.velocity, &b.velocity),
            differs(&a.force, &b.force),
            a.loads, b.loads
        );
    }
    // The escaping sphere fails in the batch as alone, and the others run to their ends.
    let failed = alone[3].error.as_deref().unwrap_or("");
    assert!(failed.contains("domain"), "{failed}");
    assert!(
        alone[3].steps < 1000,
        "failed after {} steps",
        alone[3].steps
    );
    for k in [0, 1, 2, 4, 6] {
        let (case, a) = (&CASES[k], &alone[k]);
        assert_eq!(a.error, None, "{}", case.name);
        assert_eq!(a.steps, case.runs.iter().sum::<u64>(), "{}", case.name);
    }
    // The exploding spheres stop once they are not finite; their NaN does not reach the others.
    let exploded = alone[5].error.as_deref().unwrap_or("");
    assert!(exploded.contains("non-finite"), "{exploded}");
    // The recorded loads compared above are not all zero (spheres touch a wall in the last step).
    assert!(
        alone[..3]
            .iter()
            .any(|a| a.loads.iter().any(|l| l.length() > 1e-4)),
        "no geometry load in any heap"
    );
}
