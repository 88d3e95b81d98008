//! The GPU stages against the CPU back end on the same scenes: the same trajectories to
//! round-off, and the same numbers from run to run. On a machine without a GPU the tests run on
//! Mesa's lavapipe (`apt-get install mesa-vulkan-drivers`); with no adapter at all they say so and
//! pass, unless `DEMCAL_REQUIRE_GPU=1` (as CI sets) makes that a failure.

use dem::contact::RollingModel;
use dem::geometry::{Element, Geometry};
use dem::material::{Interaction, MaterialTable};
use dem::particles::Particles;
use dem::sim::{Simulation, SimulationParams};
use dem_gpu::GpuStages;
use glam::DVec3;

mod common;
use common::{gpu, material, uniform};

fn table(restitution: f64, friction: f64, rolling: f64, surface_energy: f64) -> MaterialTable {
    let mut t = MaterialTable::new();
    let a = t.add_material(material("grain", 1e7, 2500.0));
    let b = t.add_material(material("steel", 2e9, 7800.0));
    let i = Interaction {
        restitution,
        static_friction: friction,
        rolling_friction: rolling,
        surface_energy,
    };
    t.set_interaction(a, a, i.clone());
    t.set_interaction(a, b, i.clone());
    t.set_interaction(b, b, i);
    t
}

fn sim(
    p: Particles,
    geometries: Vec<Geometry>,
    rolling: RollingModel,
    gravity: DVec3,
) -> Simulation {
    sim_with(p, geometries, rolling, gravity, 0.0)
}

fn sim_with(
    p: Particles,
    geometries: Vec<Geometry>,
    rolling: RollingModel,
    gravity: DVec3,
    surface_energy: f64,
) -> Simulation {
    let min_r = p.radius.iter().cloned().fold(f64::INFINITY, f64::min);
    Simulation::new(
        p,
        table(0.5, 0.5, 0.1, surface_energy),
        geometries,
        SimulationParams {
            time_step: 1e-5,
            gravity,
            rolling_model: rolling,
            skin: 0.2 * min_r,
            ..Default::default()
        },
    )
}

/// 20 spheres dropped in a slightly staggered column onto a floor.
fn column(rolling: RollingModel) -> Simulation {
    let mut p = Particles::default();
    for k in 0..20 {
        p.push(
            DVec3::new(1e-4 * (k % 3) as f64, 0.0, 0.0011 + 0.0021 * k as f64),
            DVec3::ZERO,
            0.001,
            2500.0,
            0,
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
    sim(p, vec![floor], rolling, DVec3::new(0.0, 0.0, -9.81))
}

/// 343 spheres of mixed sizes on a jittered lattice, overlapping their neighbours a little, with
/// random velocities and spins and no gravity: every pair and history path is exercised.
fn cloud(rolling: RollingModel) -> Simulation {
    cloud_with(rolling, 0.0)
}

fn cloud_with(rolling: RollingModel, surface_energy: f64) -> Simulation {
    let mut uniform_12345 = uniform(12345);
    let mut rnd = move || uniform_12345() * 2.0 - 1.0;
    let mut p = Particles::default();
    for a in 0..7 {
        for b in 0..7 {
            for c in 0..7 {
                let x = DVec3::new(a as f64, b as f64, c as f64) * 0.0019
                    + DVec3::new(rnd(), rnd(), rnd()) * 1e-4;
                let r = 0.001 * (1.0 + 0.05 * rnd());
                let v = DVec3::new(rnd(), rnd(), rnd()) * 0.05;
                p.push(x, v, r, 2500.0, 0);
            }
        }
    }
    for k in 0..p.len() {
        p.angular_velocity[k] = DVec3::new(rnd(), rnd(), rnd()) * 20.0;
    }
    sim_with(p, vec![], rolling, DVec3::ZERO, surface_energy)
}

/// The largest difference of a per-particle quantity between two simulations of the same
/// particles, matched by id (each orders its particles by cell at its own list rebuilds).
fn largest_difference(
    a: &Simulation,
    b: &Simulation,
    quantity: impl Fn(&Particles) -> &[DVec3],
) -> f64 {
    let mut at = vec![0; b.particles.len()];
    for (k, &id) in b.particles.id.iter().enumerate() {
        at[id as usize] = k;
    }
    let (qa, qb) = (quantity(&a.particles), quantity(&b.particles));
    a.particles
        .id
        .iter()
        .enumerate()
        .map(|(k, &id)| (qa[k] - qb[at[id as usize]]).length())
        .fold(0.0, f64::max)
}

/// Runs the scene on the CPU and on the GPU stages for `steps` steps and compares the particles,
/// and every 100 steps the geometries' loads; returns each geometry's largest load on the way.
fn compare(name: &str, make: impl Fn() -> Simulation, steps: u64, tolerance: f64) -> Vec<f64> {
    let Some(ctx) = gpu() else {
        return Vec::new();
    };
    let mut cpu = make();
    let stages = GpuStages::with_context(ctx);
    let mut gpu = make().with_backend(Box::new(stages.clone()));
    assert_eq!(gpu.backend_name(), "gpu");
    let mut largest = vec![0.0f64; cpu.geometries.len()];
    let mut done = 0;
    while done < steps {
        let k = (steps - done).min(100);
        cpu.run(k).unwrap();
        gpu.run(k).unwrap();
        done += k;
        for (g, (a, b)) in cpu.geometries.iter().zip(&gpu.geometries).enumerate() {
            let d = (a.load.force - b.load.force).length();
            assert!(
                d <= 1e-9 * a.load.force.length().max(1e-12),
                "{name}: {} load differs by {d:e} N after {done} steps",
                a.name
            );
            largest[g] = largest[g].max(a.load.force.length());
        }
    }
    let dx = largest_difference(&cpu, &gpu, |p| &p.position);
    let dv = largest_difference(&cpu, &gpu, |p| &p.velocity);
    let dw = largest_difference(&cpu, &gpu, |p| &p.angular_velocity);
    let df = largest_difference(&cpu, &gpu, |p| &p.force);
    let f_scale = cpu
        .particles
        .force
        .iter()
        .map(|f| f.length())
        .fold(0.0, f64::max);
    eprintln!(
        "{name}: {} stage calls handed to the CPU",
        stages.handed_to_cpu()
    );
    // Every stage of these scenes runs on the GPU, cohesive ones included.
    assert_eq!(stages.handed_to_cpu(), 0, "{name}");
    // Every scene, clumps included, runs as segments with the state on the device.
    let (segments, declined, _) = stages.segments();
    eprintln!("{name}: {segments} segments on the device, {declined} declined");
    assert_eq!(declined, 0, "{name}");
    assert!(segments > 0, "{name}");
    eprintln!(
        "{name}: {steps} steps, largest difference: position {dx:.3e} m, velocity {dv:.3e} m/s, spin {dw:.3e} 1/s, force {df:.3e} N of {f_scale:.3e}; largest geometry loads {largest:?} N"
    );
    assert!(dx < tolerance, "{name}: positions differ by {dx:e} m");
    assert!(dv < 1e-10, "{name}: velocities differ by {dv:e} m/s");
    assert!(dw < 1e-7, "{name}: spins differ by {dw:e} 1/s");
    assert!(
        df <= 1e-6 * f_scale.max(1e-12),
        "{name}: forces differ by {df:e} N"
    );
    largest
}

#[test]
fn a_falling_column_matches_the_cpu() {
    compare(
        "column, cdt",
        || column(RollingModel::ConstantDirectionalTorque),
        3000,
        1e-9,
    );
}

/// Each segment after the first takes its buffers from those the one before left (the context's
/// pool) and writes its data over them: on a context of its own, the first of four segments
/// reuses none and each later one every buffer of its try, with the CPU's results all the same.
#[test]
fn segments_reuse_the_buffers_the_last_one_left() {
    if gpu().is_none() {
        return;
    }
    let ctx = std::sync::Arc::new(dem_gpu::GpuContext::new().expect("a GPU"));
    let stages = GpuStages::with_context(ctx.clone());
    let epsd = RollingModel::Epsd {
        viscous_damping: 0.3,
    };
    let mut cpu = column(epsd);
    let mut gpu = column(epsd).with_backend(Box::new(stages));
    let mut reused = Vec::new();
    for _ in 0..4 {
        cpu.run(100).unwrap();
        let before = ctx.buffers_reused();
        gpu.run(100).unwrap();
        reused.push(ctx.buffers_reused() - before);
    }
    eprintln!("buffers reused per segment: {reused:?}");
    // A try makes some forty buffers (the particles, lists, walls, cells, control words).
    assert_eq!(reused[0], 0);
    assert!(reused[1..].iter().all(|&r| r >= 40), "{reused:?}");
    let dx = largest_difference(&cpu, &gpu, |p| &p.position);
    let dw = largest_difference(&cpu, &gpu, |p| &p.angular_velocity);
    assert!(dx < 1e-12 && dw < 1e-9, "{dx:e} m, {dw:e} rad/s");
}

#[test]
fn a_cloud_of_colliding_spheres_matches_the_cpu_with_both_rolling_models() {
    // After 30 steps the spheres still press on each other; by 300 they have flown apart.
    for steps in [30, 300] {
        compare(
            "cloud, cdt",
            || cloud(RollingModel::ConstantDirectionalTorque),
            steps,
            1e-10,
        );
        compare(
            "cloud, epsd",
            || {
                cloud(RollingModel::Epsd {
                    viscous_damping: 0.3,
                })
            },
            steps,
            1e-10,
        );
    }
}

#[test]
fn two_gpu_runs_give_the_same_bits() {
    let Some(ctx) = gpu() else { return };
    let run = || {
        let mut s = cloud(RollingModel::Epsd {
            viscous_damping: 0.3,
        })
        .with_backend(Box::new(GpuStages::with_context(ctx.clone())));
        s.run(200).unwrap();
        (
            s.particles.position.clone(),
            s.particles.angular_velocity.clone(),
        )
    };
    assert_eq!(run(), run());
}

/// A cohesive (JKR) cloud: pairs attract down to the law's cut-off. The GPU's cube root (Newton
/// from the f32 root) may differ from the CPU's in the last bit, hence a tolerance.
#[test]
fn a_cohesive_cloud_matches_the_cpu() {
    compare(
        "cloud, JKR",
        || cloud_with(RollingModel::ConstantDirectionalTorque, 0.05),
        100,
        1e-10,
    );
}

/// 150 spheres poured into a cylinder shell onto a floor of two tilted triangles sharing an edge
/// (face contacts on both sides of the edge, edge and vertex contacts), stirred by a rotating
/// rectangular paddle with a disc on top: every element kind, a moving geometry's velocity
/// field, and the face-before-edge rule.
fn bucket(rolling: RollingModel) -> Simulation {
    bucket_with(rolling, 0.0)
}

fn bucket_with(rolling: RollingModel, surface_energy: f64) -> Simulation {
    use dem::geometry::Motion;
    let mut rnd = uniform(777);
    let mut p = Particles::default();
    for k in 0..150 {
        let (a, b) = (rnd() * std::f64::consts::TAU, rnd().sqrt() * 0.006);
        let x = DVec3::new(b * a.cos(), b * a.sin(), 0.004 + 0.0011 * k as f64);
        // Thrown down, so that the whole column reaches the floor within the test's steps.
        p.push(
            x,
            DVec3::new(0.0, 0.0, -0.6),
            0.001 * (0.9 + 0.2 * rnd()),
            2500.0,
            0,
        );
    }
    let s = 0.012;
    let tilt = 0.0015;
    let corners = [
        DVec3::new(-s, -s, -tilt),
        DVec3::new(s, -s, tilt),
        DVec3::new(s, s, tilt),
        DVec3::new(-s, s, -tilt),
    ];
    let floor = Geometry::new(
        "floor",
        1,
        vec![
            Element::Triangle {
                a: corners[0],
                b: corners[1],
                c: corners[2],
            },
            Element::Triangle {
                a: corners[0],
                b: corners[2],
                c: corners[3],
            },
        ],
    );
    let wall = Geometry::new(
        "wall",
        1,
        vec![Element::CylinderShell {
            base: DVec3::new(0.0, 0.0, -0.005),
            axis: DVec3::Z,
            radius: 0.009,
            length: 0.2,
        }],
    );
    let paddle = Geometry::new(
        "paddle",
        1,
        vec![
            Element::Rect {
                center: DVec3::new(0.0, 0.0, 0.006),
                normal: DVec3::Y,
                u: DVec3::X,
                v: DVec3::Z,
                half_u: 0.005,
                half_v: 0.003,
            },
            Element::Disc {
                center: DVec3::new(0.0, 0.0, 0.009),
                normal: DVec3::Z,
                radius: 0.002,
            },
        ],
    )
    .with_motion(vec![Motion::Rotation {
        axis_point: DVec3::ZERO,
        axis: DVec3::Z,
        angular_velocity: 20.0,
        start: 0.0,
        end: 1.0,
    }]);
    sim_with(
        p,
        vec![floor, wall, paddle],
        rolling,
        DVec3::new(0.0, 0.0, -9.81),
        surface_energy,
    )
}

#[test]
fn spheres_in_a_stirred_bucket_match_the_cpu_on_every_element_kind() {
    let loads = compare(
        "bucket, cdt",
        || bucket(RollingModel::ConstantDirectionalTorque),
        3000,
        1e-9,
    );
    // The floor, the wall and the paddle were all hit on the way.
    assert!(
        loads.is_empty() || loads.iter().all(|l| *l > 0.0),
        "{loads:?}"
    );
    compare(
        "bucket, epsd",
        || {
            bucket(RollingModel::Epsd {
                viscous_damping: 0.3,
            })
        },
        3000,
        1e-9,
    );
}

/// Cohesive spheres stick to the bucket's walls and paddle: a wall contact reaches down to the JKR
/// cut-off.
#[test]
fn cohesive_spheres_in_a_stirred_bucket_match_the_cpu() {
    compare(
        "bucket, JKR",
        || bucket_with(RollingModel::ConstantDirectionalTorque, 0.05),
        1500,
        1e-9,
    );
}

/// Dumbbells and three-sphere clumps tumbling onto a floor and onto each other: clump members
/// skip each other and are moved by their bodies, on the device with their contacts.
#[test]
fn tumbling_clumps_match_the_cpu() {
    let loads = compare("clumps, cdt", common::tumbling_clumps, 3000, 1e-9);
    assert!(loads.is_empty() || loads[0] > 0.0, "{loads:?}");
}

/// One large sphere among many small ones, all drawn towards it; with `floor`, a plane under
/// them rising at 1 m/s that pushes into them.
fn crowded(floor: bool) -> Simulation {
    let mut p = Particles::default();
    p.push(DVec3::ZERO, DVec3::ZERO, 0.006, 2500.0, 0);
    let mut k = 0;
    for a in -4..=4 {
        for b in -4..=4 {
            for c in -4..=4 {
                let x = DVec3::new(a as f64, b as f64, c as f64) * 0.0016;
                if x.length() < 0.0075 {
                    continue;
                }
                k += 1;
                // Each drawn towards the large sphere.
                p.push(x, -x * 40.0, 0.0006 + 1e-6 * (k % 7) as f64, 2500.0, 0);
            }
        }
    }
    let geometries = if floor {
        vec![Geometry::new(
            "floor",
            1,
            vec![Element::Plane {
                point: DVec3::new(0.0, 0.0, -0.0085),
                normal: DVec3::Z,
            }],
        )
        .with_motion(vec![dem::geometry::Motion::Translation {
            velocity: DVec3::new(0.0, 0.0, 1.0),
            start: 0.0,
            end: 1.0,
        }])]
    } else {
        vec![]
    };
    sim(
        p,
        geometries,
        RollingModel::ConstantDirectionalTorque,
        DVec3::ZERO,
    )
}

/// The small spheres crowd the large one's cells and its row, so the buckets and rows of the
/// first try overflow and the segment runs again with more room, then overflow again later,
/// which ends the segment at the start of that chunk (the next goes on from there with more
/// room), giving the CPU's numbers all the same.
#[test]
fn crowded_lists_grow_and_still_match_the_cpu() {
    let Some(ctx) = gpu() else { return };
    let mut cpu = crowded(false);
    let stages = GpuStages::with_context(ctx);
    let mut gpu = crowded(false).with_backend(Box::new(stages.clone()));
    cpu.run(600).unwrap();
    gpu.run(600).unwrap();
    let (segments, declined, retried) = stages.segments();
    let early = stages.segments_ended_early();
    eprintln!(
        "crowded: {segments} segments, {declined} declined, {retried} tries again, {early} ended early"
    );
    // An overflow in the first chunk runs the segment again with more room; a later one ends
    // the segment at its chunk's start, and the next goes on from there.
    assert_eq!((segments, declined), (1 + early, 0));
    assert!(
        retried > 0 && early > 0,
        "the lists did not overflow in the first chunk and later"
    );
    // Without gravity a force comes from a contact: the small spheres reached the large one.
    let touching = cpu
        .particles
        .force
        .iter()
        .filter(|f| f.length() > 0.0)
        .count();
    assert!(touching > 50, "{touching} spheres in contact");
    let dx = largest_difference(&cpu, &gpu, |p| &p.position);
    let dv = largest_difference(&cpu, &gpu, |p| &p.velocity);
    eprintln!("crowded: position {dx:.3e} m, velocity {dv:.3e} m/s");
    assert!(dx < 1e-12 && dv < 1e-9, "{dx:e} m, {dv:e} m/s");
    // The same stages start the same scene again from the capacities that sufficed: no retry.
    let mut again = crowded(false).with_backend(Box::new(stages.clone()));
    again.run(600).unwrap();
    assert_eq!(
        (stages.segments(), stages.segments_ended_early()),
        ((segments + 1, 0, retried), early),
        "the second run tried again"
    );
    assert_eq!(again.particles.position, gpu.particles.position);
}

/// A segment ended early by an overflow puts a moving geometry back to its pose at that step:
/// the rising floor meets the crowded spheres at the same time and with the same load as on the
/// CPU.
#[test]
fn a_segment_ended_early_keeps_a_moving_floor_in_step() {
    let Some(ctx) = gpu() else { return };
    let mut cpu = crowded(true);
    let stages = GpuStages::with_context(ctx);
    let mut gpu = crowded(true).with_backend(Box::new(stages.clone()));
    // The CPU step by step, for the floor's largest load (the spheres it meets bounce off it).
    let mut most = 0.0f64;
    for _ in 0..600 {
        cpu.run(1).unwrap();
        most = most.max(cpu.geometries[0].load.force.z);
    }
    gpu.run(600).unwrap();
    let (segments, declined, _) = stages.segments();
    let early = stages.segments_ended_early();
    eprintln!(
        "crowded with a floor: {segments} segments, {declined} declined, {early} ended early"
    );
    assert!(early > 0 && declined == 0, "no segment ended early");
    assert!(
        most > 0.1,
        "the floor did not push into the spheres: {most} N at most"
    );
    let (load_cpu, load_gpu) = (cpu.geometries[0].load.force, gpu.geometries[0].load.force);
    assert_eq!(cpu.geometries[0].translation, gpu.geometries[0].translation);
    assert!(
        (load_cpu - load_gpu).length() <= 1e-9 * most,
        "{load_cpu} vs {load_gpu}"
    );
    let dx = largest_difference(&cpu, &gpu, |p| &p.position);
    let dv = largest_difference(&cpu, &gpu, |p| &p.velocity);
    eprintln!(
        "crowded with a floor: position {dx:.3e} m, velocity {dv:.3e} m/s; the floor's load {most:.3} N at most"
    );
    assert!(dx < 1e-12 && dv < 1e-9, "{dx:e} m, {dv:e} m/s");
}

/// A crowded scene in a box, one sphere thrown out of it at five speeds: with tight lists,
/// segments end early at chunk starts through the run, and the run still fails where the CPU's
/// does, with its message and its count of steps (a failing step is not counted on either).
#[test]
fn a_run_that_fails_among_early_ended_segments_fails_as_on_the_cpu() {
    let Some(ctx) = gpu() else { return };
    let mut early = 0;
    for speed in [8.0, 11.0, 14.0, 17.0, 20.0] {
        let make = || {
            let mut s = crowded(false);
            s.params.domain = Some((DVec3::splat(-0.03), DVec3::splat(0.03)));
            let x = s.particles.position[1];
            s.particles.velocity[1] = x.normalize() * speed;
            s
        };
        let run = |mut sim: Simulation| {
            let error = sim.run(600).err().map(|e| e.to_string());
            (error, sim.steps)
        };
        let cpu = run(make());
        let stages = GpuStages::with_context(ctx.clone()).with_tight_lists();
        let gpu = run(make().with_backend(Box::new(stages.clone())));
        early += stages.segments_ended_early();
        eprintln!(
            "thrown at {speed} m/s: {} ended early; CPU {cpu:?}; GPU {gpu:?}",
            stages.segments_ended_early()
        );
        assert!(cpu.0.as_deref().unwrap_or("").contains("domain"), "{cpu:?}");
        assert_eq!(cpu, gpu, "thrown at {speed} m/s");
    }
    assert!(early > 0, "no segment ended early");
}

/// The lifted-cylinder heap in small: spheres in a cylinder on a plate, the cylinder lifted, with
/// different laws between the spheres and against the steel (so each material pair reads its own
/// row of the table).
fn lifted_cylinder() -> Simulation {
    common::heap(&common::Heap::default())
}

#[test]
fn a_lifted_cylinder_heap_matches_the_cpu() {
    compare("lifted cylinder", lifted_cylinder, 4000, 1e-9);
}

/// Runs `make`'s scene for `steps` steps on the usual context and on one that binds at most
/// `limit` bytes; asserts the same bits, the CPU's numbers to round-off (a wrong part read on
/// both contexts alike would give the same bits) and that no segment was declined; returns the
/// most parts a split list took and the stages of the small context.
fn same_bits_in_parts(
    ctx: std::sync::Arc<dem_gpu::GpuContext>,
    make: impl Fn() -> Simulation,
    steps: u64,
    limit: u64,
) -> (usize, GpuStages) {
    let mut whole = make().with_backend(Box::new(GpuStages::with_context(ctx)));
    whole.run(steps).unwrap();
    let small = std::sync::Arc::new(dem_gpu::GpuContext::with_binding_limit(limit).expect("a GPU"));
    let split = GpuStages::with_context(small.clone());
    let mut parts = make().with_backend(Box::new(split.clone()));
    parts.run(steps).unwrap();
    let (segments, declined, retried) = split.segments();
    eprintln!(
        "{limit} B: lists in up to {} parts; {segments} segments, {declined} declined, {retried} tries again",
        small.parts_used()
    );
    assert_eq!(declined, 0);
    assert_eq!(whole.particles.position, parts.particles.position);
    assert_eq!(
        whole.particles.angular_velocity,
        parts.particles.angular_velocity
    );
    for (a, b) in whole.geometries.iter().zip(&parts.geometries) {
        assert_eq!(a.load.force, b.load.force, "{}", a.name);
    }
    let mut cpu = make();
    cpu.run(steps).unwrap();
    let dx = largest_difference(&cpu, &parts, |p| &p.position);
    let dv = largest_difference(&cpu, &parts, |p| &p.velocity);
    assert!(dx < 1e-12 && dv < 1e-9, "{dx:e} m, {dv:e} m/s");
    (small.parts_used(), split)
}

/// A device that binds fewer bytes than a segment's largest lists take gets them in parts
/// (`kernels::PARTS`, `Split`), with the same bits as bound whole.
/// - The crowded spheres' pair rows grow from 4 slots to 128 (their histories from 56 kB to
///   1.8 MB) while their largest other lists, the pair slots and the cell buckets, stay at or
///   under 300 kB: at 500 kB their
///   histories end in all four parts (300 kB in the fourth), through every overflow, retry and
///   early end.
/// - The falling column's wall outputs (8 kB) and pair and wall histories (4.8 kB each) pass
///   4.2 kB while its buckets (4.1 kB) do not: all three are split in two, and the floor, which
///   its lowest sphere reaches, carries the same load.
/// - At 400 kB the crowded spheres' last rows would need five parts: those segments are
///   declined, and their steps run stage by stage, with the CPU's numbers.
#[test]
fn lists_split_across_bindings_give_the_same_bits() {
    let Some(ctx) = gpu() else { return };
    let (parts, split) = same_bits_in_parts(ctx.clone(), || crowded(false), 600, 500_000);
    assert_eq!(parts, 4);
    assert!(split.segments().2 > 0 && split.segments_ended_early() > 0);
    let column = || column(RollingModel::ConstantDirectionalTorque);
    let (parts, _) = same_bits_in_parts(ctx, column, 1000, 4_200);
    assert_eq!(parts, 2);
    let mut floor = column();
    floor.run(1000).unwrap();
    assert!(
        floor.geometries[0].load.force.z < 0.0,
        "the column did not reach the floor"
    );

    let mut cpu = crowded(false);
    cpu.run(600).unwrap();
    let tiny =
        std::sync::Arc::new(dem_gpu::GpuContext::with_binding_limit(400_000).expect("a GPU"));
    let declines = GpuStages::with_context(tiny);
    let mut mixed = crowded(false).with_backend(Box::new(declines.clone()));
    mixed.run(600).unwrap();
    let (segments, declined, _) = declines.segments();
    eprintln!("400 kB: {segments} segments, {declined} declined");
    assert!(
        segments > 0 && declined > 0,
        "{segments} segments, {declined} declined"
    );
    let dx = largest_difference(&cpu, &mixed, |p| &p.position);
    let dv = largest_difference(&cpu, &mixed, |p| &p.velocity);
    assert!(dx < 1e-12 && dv < 1e-9, "{dx:e} m, {dv:e} m/s");
}
