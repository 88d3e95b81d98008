//! Verification case V7 (docs/physics.md): bonded spheres. A straight chain bends as an
//! Euler-Bernoulli cantilever with E = k_n x bond length and I = pi R_B^4 / 4 where its shear
//! springs are stiff, and as the exact discrete chain (dem::bond::chain) where they are not
//! (k_t = k_n / 40, the stalk bonds), a simply supported
//! chain deflects as the three-point-bending beam formula, and a bond breaks in tension at exactly
//! sigma_c A and in shear at tau_c A (to the step). Plus: same results for any thread count.

mod common;

use common::*;
use dem::bond::chain::{Chain, ChainEnd};
use dem::bond::{BondParams, BondRadius, Bonds, BreakMode, ContactRadius};
use dem::contact::RollingModel;
use dem::particles::Particles;
use dem::sim::{Simulation, StepExtension};
use glam::DVec3;
use std::any::Any;
use std::f64::consts::PI;

/// A constant force on one sphere (by stable id).
struct PointLoad {
    id: u32,
    force: DVec3,
}

impl StepExtension for PointLoad {
    fn name(&self) -> &str {
        "point load"
    }
    fn on_device(&self) -> dem::sim::OnDevice {
        dem::sim::OnDevice::EveryStep
    }
    fn adds_forces(&self) -> bool {
        true
    }
    fn add_forces(&mut self, p: &mut Particles, index_of: &[u32], _time: f64, _dt: f64) {
        p.force[index_of[self.id as usize] as usize] += self.force;
    }
    fn as_any(&self) -> &dyn Any {
        self
    }
}

const R: f64 = 0.001;
const DENSITY: f64 = 1000.0;

fn params(k_n: f64, k_t: f64, sigma_c: f64, tau_c: f64, damping: f64) -> BondParams {
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

/// A straight chain of `n` touching spheres along x from the origin, bonded, no gravity, with the
/// time step the bonds take.
fn chain(n: usize, bond: BondParams, load: Option<(u32, DVec3)>) -> Simulation {
    let mut p = Particles::default();
    for k in 0..n {
        p.push(DVec3::X * (2.0 * R * k as f64), DVec3::ZERO, R, DENSITY, 0);
    }
    let m = material("stalk", 1e8, 0.3, DENSITY);
    let t = table(m.clone(), m, interaction(0.5, 0.3, 0.0));
    let mut bonds = Bonds::new(2, &[([0, 0], bond)]);
    bonds.form_due(&p, 0.0, 1.0).unwrap();
    assert_eq!(bonds.len(), n - 1, "a chain has one bond per gap");
    let dt = bonds.safe_time_step(&p).unwrap();
    let mut sim = simulation(
        p,
        t,
        vec![],
        dt,
        DVec3::ZERO,
        RollingModel::ConstantDirectionalTorque,
    );
    // A load comes before the bonds, so that their local damping sees the whole force.
    if let Some((id, force)) = load {
        sim.add_extension(Box::new(PointLoad { id, force }));
    }
    sim.add_extension(Box::new(bonds));
    sim
}

/// Pins sphere `id` in place (and, when `clamped`, against turning).
fn pin(sim: &mut Simulation, id: usize, clamped: bool) {
    let p = &mut sim.particles;
    let k = p.id.iter().position(|&i| i as usize == id).unwrap();
    p.inv_mass[k] = 0.0;
    if clamped {
        p.inv_inertia[k] = 0.0;
    }
}

fn position_of(sim: &Simulation, id: u32) -> DVec3 {
    let p = &sim.particles;
    p.position[p.id.iter().position(|&i| i == id).unwrap()]
}

/// Runs until the largest speed is tiny (damped to static equilibrium).
fn run_to_rest(sim: &mut Simulation, max_steps: u64) {
    for _ in 0..max_steps / 1000 {
        sim.run(1000).unwrap();
        let vmax = sim
            .particles
            .velocity
            .iter()
            .map(|v| v.length())
            .fold(0.0, f64::max);
        if vmax < 1e-9 {
            return;
        }
        if std::env::var("BOND_DEBUG").is_ok() {
            let last = sim.particles.len() as u32 - 1;
            let tip = position_of(sim, last);
            eprintln!(
                "t {:.4e} vmax {vmax:.3e} tip {tip:?} mid {:?}",
                sim.time,
                position_of(sim, last / 2)
            );
        }
    }
    panic!("the beam did not come to rest in {max_steps} steps");
}

#[test]
fn v7_cantilever_deflects_as_euler_bernoulli() {
    // 21 spheres: 20 segments of length l = 2R from the clamped first sphere to the loaded last.
    let n = 21;
    let k_n = 1e10;
    let length = 2.0 * R * (n - 1) as f64;
    let e_beam = k_n * 2.0 * R;
    let inertia = PI * R.powi(4) / 4.0;
    // A load giving a tip deflection of 0.5 % of the length (small-deflection theory).
    let expected = 0.005 * length;
    let force = 3.0 * e_beam * inertia * expected / length.powi(3);
    let load = ((n - 1) as u32, -DVec3::Z * force);
    let mut sim = chain(n, params(k_n, k_n, 1e15, 1e15, 0.7), Some(load));
    pin(&mut sim, 0, true);
    run_to_rest(&mut sim, 2_000_000);
    let tip = -position_of(&sim, (n - 1) as u32).z;
    eprintln!(
        "cantilever: tip deflection {tip:.6e} m, Euler-Bernoulli {expected:.6e} m ({:+.2} %)",
        100.0 * (tip / expected - 1.0)
    );
    assert!(rel_err(tip, expected) < 0.05, "{tip} vs {expected}");
    // The discrete chain: joints of stiffness k_n I at the gaps give (1 - 1/(4 m^2)) of it.
    assert!(rel_err(tip, expected * (1.0 - 1.0 / 1600.0)) < 0.01);
    let bonds = sim.bonds().unwrap();
    assert_eq!(bonds.broken_count(), 0);
}

/// With k_t = k_n / 40, as in the stalk bonds, the shear springs soften the chain: the beam
/// formula (EI = k_n I l) is several per cent too stiff, and the exact discrete chain (bending
/// joints k_n I, shear springs k_t A at the bond mid-points) is what the engine gives.
#[test]
fn v7_cantilever_with_soft_shear_springs_matches_the_exact_discrete_chain() {
    let n = 21;
    let (k_n, k_t) = (1e10, 1e10 / 40.0);
    let c = Chain {
        bonds: n - 1,
        length: 2.0 * R,
        radius: R,
        normal_stiffness: k_n,
        shear_stiffness: k_t,
    };
    let compliance = c.transverse_compliance(ChainEnd::Free);
    let force = 0.005 * 2.0 * R * (n - 1) as f64 / compliance;
    let load = ((n - 1) as u32, -DVec3::Z * force);
    let mut sim = chain(n, params(k_n, k_t, 1e15, 1e15, 0.7), Some(load));
    pin(&mut sim, 0, true);
    run_to_rest(&mut sim, 4_000_000);
    let tip = -position_of(&sim, (n - 1) as u32).z;
    let exact = force * compliance;
    let beam = force / c.beam_stiffness(ChainEnd::Free);
    eprintln!(
        "cantilever, k_t = k_n/40: tip {tip:.6e} m, exact chain {exact:.6e} m ({:+.2} %), beam formula {beam:.6e} m ({:+.2} %)",
        100.0 * (tip / exact - 1.0),
        100.0 * (tip / beam - 1.0)
    );
    assert!(rel_err(tip, exact) < 0.004, "{tip} vs {exact}");
    assert!(
        tip / beam > 1.015,
        "the shear springs add to the beam formula's deflection"
    );
}

#[test]
fn v7_simply_supported_chain_matches_three_point_bending() {
    // 21 spheres, supports under the end spheres (pinned, free to turn), load on the middle one.
    let n = 21;
    let k_n = 1e10;
    let span = 2.0 * R * (n - 1) as f64;
    let ei = k_n * 2.0 * R * PI * R.powi(4) / 4.0;
    let expected = 0.002 * span;
    let force = 48.0 * ei * expected / span.powi(3);
    let load = ((n / 2) as u32, -DVec3::Z * force);
    let mut sim = chain(n, params(k_n, k_n, 1e15, 1e15, 0.7), Some(load));
    pin(&mut sim, 0, false);
    pin(&mut sim, n - 1, false);
    run_to_rest(&mut sim, 2_000_000);
    let mid = -position_of(&sim, (n / 2) as u32).z;
    eprintln!(
        "three-point bending: mid-span deflection {mid:.6e} m, beam formula {expected:.6e} m ({:+.2} %)",
        100.0 * (mid / expected - 1.0)
    );
    assert!(rel_err(mid, expected) < 0.05, "{mid} vs {expected}");
}

/// Two bonded spheres, the first held, the second driven at `velocity` (held against turning):
/// the time and force at which the bond breaks.
fn pull(velocity: DVec3, sigma_c: f64, tau_c: f64) -> (Simulation, f64, f64) {
    let (k_n, k_t) = (1e11, 5e10);
    let mut sim = chain(2, params(k_n, k_t, sigma_c, tau_c, 0.0), None);
    pin(&mut sim, 0, true);
    pin(&mut sim, 1, true);
    let k = sim.particles.id.iter().position(|&i| i == 1).unwrap();
    sim.particles.velocity[k] = velocity;
    let mut largest: f64 = 0.0;
    for _ in 0..1_000_000 {
        sim.step().unwrap();
        if sim.bonds().unwrap().broken_count() > 0 {
            break;
        }
        let k0 = sim.particles.id.iter().position(|&i| i == 0).unwrap();
        largest = largest.max(sim.particles.force[k0].length());
    }
    let t = sim.bonds().unwrap().breakages()[0].time;
    (sim, t, largest)
}

#[test]
fn v7_bond_breaks_in_tension_at_sigma_c_a() {
    let sigma_c = 2e6;
    let speed = 0.01;
    let (sim, t, largest) = pull(DVec3::X * speed, sigma_c, 1e15);
    let area = PI * R * R;
    let dt = sim.params.time_step;
    // F_n grows by k_n A v dt per step: it breaks at the first step where k_n v t >= sigma_c.
    let k_n = 1e11;
    let analytic = sigma_c / (k_n * speed);
    eprintln!(
        "tension: broke at t = {t:.6e} s (analytic {analytic:.6e} s, dt {dt:.2e}); largest force {largest:.6} N, sigma_c A = {:.6} N",
        sigma_c * area
    );
    assert!(t >= analytic - 1e-9 * dt && t < analytic + dt * (1.0 + 1e-9));
    let step = k_n * area * speed * dt;
    assert!(largest <= sigma_c * area && largest > sigma_c * area - step * 1.000001);
    let b = sim.bonds().unwrap();
    assert_eq!(b.breakages()[0].mode, BreakMode::Tension);
    assert_eq!(b.breakages()[0].ids, [0, 1]);
    assert_eq!((b.intact_count(), b.broken_count()), (0, 1));
    // The log's position is the bond's mid-point.
    let mid = b.breakages()[0].position;
    assert!((mid.x - (R + 0.5 * speed * t)).abs() < 2.0 * speed * dt);
}

#[test]
fn v7_bond_breaks_in_shear_at_tau_c_a() {
    let tau_c = 1e6;
    let speed = 0.01;
    let (sim, t, largest) = pull(DVec3::Z * speed, 1e15, tau_c);
    let area = PI * R * R;
    let k_t = 5e10;
    let analytic = tau_c / (k_t * speed);
    eprintln!(
        "shear: broke at t = {t:.6e} s (analytic {analytic:.6e} s); largest force {largest:.6} N, tau_c A = {:.6} N",
        tau_c * area
    );
    // The bond turns as the second sphere passes sideways: the shear share is cos of a tiny angle.
    assert!(rel_err(t, analytic) < 1e-3, "{t} vs {analytic}");
    assert!(rel_err(largest, tau_c * area) < 1e-3);
    assert_eq!(sim.bonds().unwrap().breakages()[0].mode, BreakMode::Shear);
}

/// A bonded chain shaken about: the same state bit for bit with one thread or two.
#[test]
fn bonded_chain_is_the_same_for_any_thread_count() {
    let run = |threads: usize| -> Vec<DVec3> {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let mut sim = chain(600, params(1e10, 5e9, 1e3, 1e3, 0.0), None);
            for k in 0..sim.particles.len() {
                let x = sim.particles.position[k].x;
                sim.particles.velocity[k] =
                    DVec3::new(0.0, (x * 3000.0).sin(), (x * 1700.0).cos()) * 0.05;
            }
            sim.run(3000).unwrap();
            let b = sim.bonds().unwrap();
            assert!(
                b.broken_count() > 0 && b.intact_count() > 0,
                "some bonds break: {}",
                b.broken_count()
            );
            let mut by_id: Vec<(u32, DVec3)> = sim
                .particles
                .id
                .iter()
                .cloned()
                .zip(sim.particles.position.iter().cloned())
                .collect();
            by_id.sort_by_key(|a| a.0);
            by_id.into_iter().map(|a| a.1).collect()
        })
    };
    assert_eq!(run(1), run(2));
}
