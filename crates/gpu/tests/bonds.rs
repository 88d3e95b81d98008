//! Bonds on the device (issue 42, point 1): bonded scenes run as segments with the bonds resident
//! on the GPU give the CPU's results within round-off (positions, velocities, forces, the tool's
//! load, and the same breakages in the same order at the same steps), alone and in a batch with
//! other worlds, bonded or not. On lavapipe in CI (`DEMCAL_REQUIRE_GPU=1`).

use dem::bond::{BondParams, BondRadius, Bonds, BreakMode, Breakage, ContactRadius};
use dem::contact::RollingModel;
use dem::geometry::{Element, Geometry, Motion};
use dem::material::{Interaction, MaterialTable};
use dem::particles::Particles;
use dem::sim::{Simulation, SimulationParams};
use dem_gpu::GpuStages;
use glam::DVec3;

mod common;
use common::{gpu, material, together, uniform};

const R: f64 = 0.001;
const DENSITY: f64 = 1000.0;

fn bond(k_n: f64, k_t: f64, sigma_c: f64, tau_c: f64, damping: f64) -> BondParams {
    BondParams {
        normal_stiffness: k_n,
        shear_stiffness: k_t,
        critical_normal_stress: sigma_c,
        critical_shear_stress: tau_c,
        radius: BondRadius::DiskScale(1.0),
        contact_radius: ContactRadius::Scale(1.05),
        formation_time: 0.0,
        stiffness_range: 0.0,
        damping,
    }
}

fn table() -> MaterialTable {
    let mut t = MaterialTable::new();
    let a = t.add_material(material("stalk", 1e8, DENSITY));
    let b = t.add_material(material("steel", 2e11, 7800.0));
    let i = Interaction {
        restitution: 0.5,
        static_friction: 0.3,
        rolling_friction: 0.0,
        surface_energy: 0.0,
    };
    t.set_interaction(a, a, i.clone());
    t.set_interaction(a, b, i.clone());
    t.set_interaction(b, b, i);
    t
}

/// `p` bonded with `b` (formed now), with the bonds' safe time step and `gravity`.
fn bonded(p: Particles, b: BondParams, geometries: Vec<Geometry>, gravity: DVec3) -> Simulation {
    let mut bonds = Bonds::new(2, &[([0, 0], b)]);
    bonds.form_due(&p, 0.0, 1.0).unwrap();
    let dt = bonds.safe_time_step(&p).unwrap();
    let mut sim = Simulation::new(
        p,
        table(),
        geometries,
        SimulationParams {
            time_step: dt,
            gravity,
            rolling_model: RollingModel::ConstantDirectionalTorque,
            skin: 0.2 * R,
            ..Default::default()
        },
    );
    sim.add_extension(Box::new(bonds));
    sim
}

/// Sphere `id`'s index now.
fn index(sim: &Simulation, id: u32) -> usize {
    sim.particles.id.iter().position(|&i| i == id).unwrap()
}

/// Holds sphere `id` in place (and against turning when `clamped`).
fn hold(sim: &mut Simulation, id: u32, clamped: bool) {
    let k = index(sim, id);
    sim.particles.inv_mass[k] = 0.0;
    if clamped {
        sim.particles.inv_inertia[k] = 0.0;
    }
}

/// A straight chain of `n` touching spheres along x.
fn chain(n: usize) -> Particles {
    let mut p = Particles::default();
    for k in 0..n {
        p.push(DVec3::X * (2.0 * R * k as f64), DVec3::ZERO, R, DENSITY, 0);
    }
    p
}

/// V7's cantilever: a bonded bar of 21 spheres clamped at one end, bending under its weight
/// (scaled up to a deflection of a few diameters), with local damping.
fn cantilever() -> Simulation {
    let mut sim = bonded(
        chain(21),
        bond(1e10, 1e10 / 40.0, 1e15, 1e15, 0.7),
        vec![],
        DVec3::Z * -2e3,
    );
    hold(&mut sim, 0, true);
    sim
}

/// V7's simply supported chain: held at both ends, free to turn, under its weight.
fn simply_supported() -> Simulation {
    let mut sim = bonded(
        chain(21),
        bond(1e10, 1e10, 1e15, 1e15, 0.3),
        vec![],
        DVec3::Z * -5e3,
    );
    hold(&mut sim, 0, false);
    hold(&mut sim, 20, false);
    sim
}

/// V7's pulls: two bonded spheres, the first held, the second driven at `velocity` (held
/// against turning) until the bond breaks.
fn pull(velocity: DVec3, sigma_c: f64, tau_c: f64) -> Simulation {
    let mut sim = bonded(
        chain(2),
        bond(1e11, 5e10, sigma_c, tau_c, 0.0),
        vec![],
        DVec3::ZERO,
    );
    hold(&mut sim, 0, true);
    hold(&mut sim, 1, true);
    let k = index(&sim, 1);
    sim.particles.velocity[k] = velocity;
    sim
}

fn tension() -> Simulation {
    pull(DVec3::X * 0.01, 2e6, 1e15)
}

fn shear() -> Simulation {
    pull(DVec3::Z * 0.01, 1e15, 1e6)
}

/// A bonded chain shaken about (the CPU's thread-count test): bonds break in both modes.
fn shaken() -> Simulation {
    let mut sim = bonded(
        chain(60),
        bond(1e10, 5e9, 1e3, 1e3, 0.0),
        vec![],
        DVec3::ZERO,
    );
    for k in 0..sim.particles.len() {
        let x = sim.particles.position[k].x;
        sim.particles.velocity[k] = DVec3::new(0.0, (x * 3000.0).sin(), (x * 1700.0).cos()) * 0.05;
    }
    sim
}

/// A bonded chain driven together from both ends at up to 3 m/s: its bonds break and its
/// spheres pile up, so their neighbour rows grow as the run goes.
fn crumpled() -> Simulation {
    let mut sim = bonded(
        chain(60),
        bond(1e10, 5e9, 1e3, 1e3, 0.0),
        vec![],
        DVec3::ZERO,
    );
    let mid = 59.0 * R;
    for k in 0..sim.particles.len() {
        let x = sim.particles.position[k].x - mid;
        sim.particles.velocity[k] = DVec3::new(
            -x * 50.0,
            (x * 3000.0).sin() * 0.3,
            (x * 1700.0).cos() * 0.3,
        );
    }
    sim
}

/// A chain whose bonds form 200 steps into the run, while its spheres move apart and together:
/// the device runs up to the formation, the host forms the bonds, the device runs on with them.
fn late() -> Simulation {
    let p = chain(40);
    let b = bond(1e10, 5e9, 2e3, 2e3, 0.0);
    let mut formed = Bonds::new(2, &[([0, 0], b)]);
    formed.form_due(&p, 0.0, 1.0).unwrap();
    let dt = formed.safe_time_step(&p).unwrap();
    let bonds = Bonds::new(
        2,
        &[(
            [0, 0],
            BondParams {
                formation_time: 200.0 * dt,
                ..b
            },
        )],
    );
    let mut sim = Simulation::new(
        p,
        table(),
        vec![],
        SimulationParams {
            time_step: dt,
            rolling_model: RollingModel::ConstantDirectionalTorque,
            skin: 0.2 * R,
            ..Default::default()
        },
    );
    sim.add_extension(Box::new(bonds));
    for k in 0..sim.particles.len() {
        let x = sim.particles.position[k].x;
        sim.particles.velocity[k] =
            DVec3::new((x * 2100.0).sin() * 0.02, (x * 3000.0).sin(), 0.0) * 0.05;
    }
    sim
}

/// A bonded chain under gravity, held at both ends, with dumbbell clumps falling onto it: a world
/// with both bonds and clumps (the bond sums leave the clumps' members to their bodies).
fn chain_and_clumps() -> Simulation {
    use dem::clump::{Bodies, ClumpTemplate};
    let mut p = chain(24);
    let mut bodies = Bodies::default();
    let dumbbell =
        ClumpTemplate::new(vec![(DVec3::ZERO, R), (DVec3::new(1.5 * R, 0.0, 0.0), R)]).unwrap();
    let props = dumbbell.mass_properties();
    for k in 0..5 {
        let at = DVec3::new((6.0 + 8.0 * k as f64) * R, 0.2 * R * k as f64, 3.0 * R);
        let turn = glam::DQuat::from_rotation_z(0.4 * k as f64);
        bodies.add(
            &mut p,
            &dumbbell,
            &props,
            DENSITY,
            0,
            at,
            turn,
            DVec3::Z * -0.5,
        );
    }
    let mut sim = bonded(
        p,
        bond(1e9, 2.5e8, 1e15, 1e15, 0.1),
        vec![],
        DVec3::Z * -9.81,
    )
    .with_bodies(bodies);
    hold(&mut sim, 0, false);
    hold(&mut sim, 23, false);
    sim
}

/// A small shear specimen: a block of 8 x 4 x 4 touching spheres (slightly jittered) on two
/// supports, cut in the middle by a blade coming down at 1 m/s; bonds break under it.
fn specimen() -> Simulation {
    let (p, geometries) = block();
    bonded(
        p,
        bond(2e10, 5e9, 1e6, 5e5, 0.2),
        geometries,
        DVec3::Z * -9.81,
    )
}

/// The same block without bonds: the blade pushes loose spheres aside (a world without bonds for
/// the batch).
fn loose() -> Simulation {
    let (p, geometries) = block();
    Simulation::new(
        p,
        table(),
        geometries,
        SimulationParams {
            time_step: 1e-6,
            gravity: DVec3::Z * -9.81,
            rolling_model: RollingModel::ConstantDirectionalTorque,
            skin: 0.2 * R,
            ..Default::default()
        },
    )
}

/// The spheres and geometries of the shear specimen.
fn block() -> (Particles, Vec<Geometry>) {
    let mut p = Particles::default();
    let mut jitter = uniform(7);
    for ix in 0..8 {
        for iy in 0..4 {
            for iz in 0..4 {
                let x = DVec3::new(ix as f64, iy as f64, iz as f64) * (2.0 * R)
                    + DVec3::new(jitter(), jitter(), jitter()) * (0.02 * R);
                p.push(x, DVec3::ZERO, R, DENSITY, 0);
            }
        }
    }
    let rect = |center: DVec3, normal: DVec3, u: DVec3, half_u: f64, half_v: f64| Element::Rect {
        center,
        normal,
        u,
        v: normal.cross(u),
        half_u,
        half_v,
    };
    let (y_mid, x_mid) = (3.0 * R, 7.0 * R);
    let supports = Geometry::new(
        "supports",
        1,
        vec![
            rect(
                DVec3::new(1.0 * R, y_mid, -R),
                DVec3::Z,
                DVec3::X,
                2.0 * R,
                6.0 * R,
            ),
            rect(
                DVec3::new(13.0 * R, y_mid, -R),
                DVec3::Z,
                DVec3::X,
                2.0 * R,
                6.0 * R,
            ),
        ],
    );
    let blade = Geometry::new(
        "blade",
        1,
        vec![rect(
            DVec3::new(x_mid, y_mid, 7.2 * R),
            DVec3::Z,
            DVec3::X,
            0.5 * R,
            6.0 * R,
        )],
    )
    .with_motion(vec![Motion::Translation {
        velocity: DVec3::Z * -1.0,
        start: 0.0,
        end: 1.0,
    }]);
    (p, vec![supports, blade])
}

/// What a run ended with.
#[derive(Debug)]
struct End {
    position: Vec<DVec3>,
    velocity: Vec<DVec3>,
    angular_velocity: Vec<DVec3>,
    force: Vec<DVec3>,
    torque: Vec<DVec3>,
    /// Every geometry's load after each run.
    loads: Vec<DVec3>,
    breakages: Vec<Breakage>,
    history: Vec<(f64, usize, usize)>,
    bond_forces: Vec<(f64, f64)>,
    time: f64,
}

/// Runs `sim` for `steps` steps in runs of `chunk`, and what it ended with, the particles in
/// stable-id order.
fn run(mut sim: Simulation, steps: u64, chunk: u64) -> End {
    let mut done = 0;
    let mut loads = Vec::new();
    while done < steps {
        let k = chunk.min(steps - done);
        sim.run(k).unwrap();
        done += k;
        loads.extend(sim.geometries.iter().map(|g| g.load.force));
    }
    let p = &sim.particles;
    let mut order: Vec<usize> = (0..p.len()).collect();
    order.sort_by_key(|&k| p.id[k]);
    let by_id = |v: &[DVec3]| order.iter().map(|&k| v[k]).collect::<Vec<_>>();
    let none = Bonds::new(0, &[]);
    let b = sim.bonds().unwrap_or(&none);
    // Bond order follows the particles' (each run reorders them at its own rebuilds): by ids.
    let mut bond_forces: Vec<([u32; 2], (f64, f64))> = (0..b.len())
        .map(|k| (b.bond(k).0, b.bond_forces(k)))
        .collect();
    bond_forces.sort_by_key(|x| x.0);
    End {
        position: by_id(&p.position),
        velocity: by_id(&p.velocity),
        angular_velocity: by_id(&p.angular_velocity),
        force: by_id(&p.force),
        torque: by_id(&p.torque),
        loads,
        breakages: b.breakages().to_vec(),
        history: b.history().to_vec(),
        bond_forces: bond_forces.into_iter().map(|x| x.1).collect(),
        time: sim.time,
    }
}

fn largest(a: &[DVec3], b: &[DVec3]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (*x - *y).length())
        .fold(0.0, f64::max)
}

fn scale(a: &[DVec3]) -> f64 {
    a.iter().map(|x| x.length()).fold(0.0, f64::max)
}

/// `gpu` is `cpu` within round-off: `rel` of each quantity's largest magnitude (positions
/// within `rel` of the sphere radius), the same breakages (ids, modes, steps) and log.
fn assert_agree(name: &str, cpu: &End, gpu: &End, rel: f64) {
    let dx = largest(&cpu.position, &gpu.position);
    let dv = largest(&cpu.velocity, &gpu.velocity);
    let dw = largest(&cpu.angular_velocity, &gpu.angular_velocity);
    let df = largest(&cpu.force, &gpu.force);
    let dt = largest(&cpu.torque, &gpu.torque);
    let dl = largest(&cpu.loads, &gpu.loads);
    eprintln!(
        "{name}: {} breakages by {:.3e} s; largest differences: position {dx:.2e} m, velocity {dv:.2e} of {:.2e} m/s, spin {dw:.2e} of {:.2e} 1/s, force {df:.2e} of {:.2e} N, torque {dt:.2e} of {:.2e} N m, loads {dl:.2e} of {:.2e} N",
        cpu.breakages.len(),
        cpu.time,
        scale(&cpu.velocity),
        scale(&cpu.angular_velocity),
        scale(&cpu.force),
        scale(&cpu.torque),
        scale(&cpu.loads),
    );
    assert!(dx <= rel * R, "{name}: positions differ by {dx:e} m");
    let pairs = [
        ("velocities", dv, scale(&cpu.velocity)),
        ("spins", dw, scale(&cpu.angular_velocity)),
        ("forces", df, scale(&cpu.force)),
        ("torques", dt, scale(&cpu.torque)),
        ("loads", dl, scale(&cpu.loads)),
    ];
    for (what, d, s) in pairs {
        assert!(
            d <= rel * s.max(1e-30),
            "{name}: {what} differ by {d:e} of {s:e}"
        );
    }
    assert_eq!(cpu.bond_forces.len(), gpu.bond_forces.len());
    let f_scale = cpu
        .bond_forces
        .iter()
        .map(|f| f.0.abs().max(f.1))
        .fold(0.0, f64::max);
    for (a, b) in cpu.bond_forces.iter().zip(&gpu.bond_forces) {
        assert!(
            (a.0 - b.0).abs().max((a.1 - b.1).abs()) <= rel * f_scale.max(1e-30),
            "{name}: bond forces {a:?} against {b:?}"
        );
    }
    assert_eq!(
        cpu.breakages.len(),
        gpu.breakages.len(),
        "{name}: breakages"
    );
    for (a, b) in cpu.breakages.iter().zip(&gpu.breakages) {
        assert_eq!((a.ids, a.mode), (b.ids, b.mode), "{name}");
        assert_eq!(a.time, b.time, "{name}: {:?} broke at another step", a.ids);
        assert!((a.position - b.position).length() <= rel * R, "{name}");
        assert!(
            (a.normal_stress - b.normal_stress).abs() <= 1e-6 * a.normal_stress.abs().max(1.0)
                && (a.shear_stress - b.shear_stress).abs() <= 1e-6 * a.shear_stress.abs().max(1.0),
            "{name}: stresses {a:?} against {b:?}"
        );
    }
    assert_eq!(cpu.history, gpu.history, "{name}: the intact/broken log");
}

/// A scene, how long it runs and in what runs, and what it must show.
struct Case {
    name: &'static str,
    make: fn() -> Simulation,
    steps: u64,
    chunk: u64,
    /// Fewest bonds that break.
    breaks: usize,
}

const CASES: &[Case] = &[
    Case {
        name: "cantilever",
        make: cantilever,
        steps: 3000,
        chunk: 1000,
        breaks: 0,
    },
    Case {
        name: "simply supported",
        make: simply_supported,
        steps: 2000,
        chunk: 700,
        breaks: 0,
    },
    Case {
        name: "tension",
        make: tension,
        steps: 3200,
        chunk: 1300,
        breaks: 1,
    },
    Case {
        name: "shear",
        make: shear,
        steps: 3200,
        chunk: 3200,
        breaks: 1,
    },
    Case {
        name: "shaken chain",
        make: shaken,
        steps: 1500,
        chunk: 500,
        breaks: 5,
    },
    Case {
        name: "shear specimen",
        make: specimen,
        steps: 3000,
        chunk: 250,
        breaks: 3,
    },
    Case {
        name: "late bonds",
        make: late,
        steps: 1500,
        chunk: 750,
        breaks: 1,
    },
    Case {
        name: "chain and clumps",
        make: chain_and_clumps,
        // The clumps' collisions grow round-off: within 6e-11 of the force's scale at 1 000
        // steps, 2e-9 at 2 000 (a sum in another order, then a chaotic flow).
        steps: 1000,
        chunk: 500,
        breaks: 0,
    },
    Case {
        name: "loose block",
        make: loose,
        steps: 2000,
        chunk: 500,
        breaks: 0,
    },
];

/// Runs a case on the GPU back end `stages`; checks that it ran as segments.
fn run_gpu(case: &Case, stages: GpuStages) -> End {
    let sim = (case.make)().with_backend(Box::new(stages.clone()));
    let end = run(sim, case.steps, case.chunk);
    let (segments, declined, _) = stages.segments();
    assert!(
        segments > 0 && declined == 0 && stages.handed_to_cpu() == 0,
        "{}: {segments} segments, {declined} declined, {} stages on the CPU",
        case.name,
        stages.handed_to_cpu()
    );
    end
}

#[test]
fn bonded_scenes_on_the_device_match_the_cpu() {
    let Some(ctx) = gpu() else {
        return;
    };
    for case in &CASES[..8] {
        let cpu = run((case.make)(), case.steps, case.chunk);
        assert!(
            cpu.breakages.len() >= case.breaks,
            "{}: {} breakages on the CPU",
            case.name,
            cpu.breakages.len()
        );
        let gpu = run_gpu(case, GpuStages::with_context(ctx.clone()));
        assert_agree(case.name, &cpu, &gpu, 1e-9);
    }
}

/// With lists that start with no room to spare, rows overflow in the first chunk (the segment
/// runs again) and later (the segment ends at that chunk's start and the next goes on): the
/// bonds, their breakages and the clumps come back from the copies taken at the chunk's start,
/// and the results are the CPU's all the same.
#[test]
fn bonded_scenes_whose_lists_overflow_mid_segment_match_the_cpu() {
    let Some(ctx) = gpu() else {
        return;
    };
    let crumpled = Case {
        name: "crumpled chain",
        make: crumpled,
        steps: 3000,
        chunk: 1000,
        breaks: 20,
    };
    let mut early = 0;
    for case in [&CASES[7], &crumpled] {
        let cpu = run((case.make)(), case.steps, case.chunk);
        let stages = GpuStages::with_context(ctx.clone()).with_tight_lists();
        let gpu = run_gpu(case, stages.clone());
        let (segments, _, retried) = stages.segments();
        eprintln!(
            "{}: {segments} segments, {retried} tries again, {} ended early, {} breakages",
            case.name,
            stages.segments_ended_early(),
            gpu.breakages.len()
        );
        early += stages.segments_ended_early();
        assert_agree(case.name, &cpu, &gpu, 1e-9);
    }
    assert!(early > 0, "no segment ended early");
}

/// The V7 pulls on the device break where the analytic answer says: at the first step where
/// k_n v t >= sigma_c (tension), and within 0.1 % of tau_c / (k_t v) (shear).
#[test]
fn the_device_breaks_v7_bonds_at_the_analytic_time() {
    let Some(ctx) = gpu() else {
        return;
    };
    for (case, mode, analytic) in [
        (&CASES[2], BreakMode::Tension, 2e6 / (1e11 * 0.01)),
        (&CASES[3], BreakMode::Shear, 1e6 / (5e10 * 0.01)),
    ] {
        let end = run_gpu(case, GpuStages::with_context(ctx.clone()));
        let b = end.breakages[0];
        eprintln!(
            "{}: broke at {:.6e} s in {:?}, analytic {analytic:.6e} s",
            case.name, b.time, b.mode
        );
        assert_eq!(b.mode, mode);
        assert!((b.time - analytic).abs() < 1e-3 * analytic);
        assert_eq!(b.ids, [0, 1]);
    }
}

/// Bonded worlds batched with each other and with a world without bonds give each the bits it
/// gets alone.
#[test]
fn a_batch_of_bonded_worlds_gives_each_its_own_result() {
    let Some(ctx) = gpu() else {
        return;
    };
    let cases: Vec<&Case> = [0, 2, 4, 5, 6, 7, 8].iter().map(|&k| &CASES[k]).collect();
    let alone: Vec<End> = cases
        .iter()
        .map(|case| run_gpu(case, GpuStages::with_context(ctx.clone())))
        .collect();
    let before = dem_gpu::batch::batch_stats();
    let batched = together(&ctx, &cases, |case, stages| run_gpu(case, stages));
    let after = dem_gpu::batch::batch_stats();
    eprintln!(
        "{} batches of {} worlds (largest {})",
        after.batches - before.batches,
        after.worlds - before.worlds,
        after.largest
    );
    assert!(after.batches > before.batches && after.largest >= 2);
    for ((case, a), b) in cases.iter().zip(&alone).zip(&batched) {
        assert_agree(case.name, a, b, 0.0);
    }
}
