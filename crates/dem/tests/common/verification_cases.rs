// Verification cases V1-V6 and V8 of docs/physics.md, with the tolerances given there,
// included by `verification.rs` (CPU back end) and by `crates/gpu/tests/verification.rs` (GPU
// back end). The including file provides `mod common` and `fn backend() -> &'static str`.

use common::*;
use dem::contact::RollingModel;
use dem::particles::Particles;
use glam::DVec3;

/// `common::simulation` on the including file's back end.
fn simulation(
    particles: Particles,
    table: dem::material::MaterialTable,
    geometries: Vec<dem::geometry::Geometry>,
    dt: f64,
    gravity: DVec3,
    rolling: RollingModel,
) -> dem::Simulation {
    let mut sim = common::simulation(particles, table, geometries, dt, gravity, rolling);
    sim.use_backend(backend())
        .expect("the back end of the verification cases");
    sim
}

const CDT: RollingModel = RollingModel::ConstantDirectionalTorque;

/// Peak force, largest overlap and contact duration of a head-on collision of two equal spheres.
fn head_on(youngs: f64, poisson: f64, density: f64) -> (f64, f64, f64) {
    let r = 0.01;
    let m = material("m", youngs, poisson, density);
    let t = table(m.clone(), m, interaction(1.0, 0.0, 0.0));
    let mut p = Particles::default();
    p.push(
        DVec3::new(-r - 1e-6, 0.0, 0.0),
        DVec3::new(10.0, 0.0, 0.0),
        r,
        density,
        0,
    );
    p.push(
        DVec3::new(r + 1e-6, 0.0, 0.0),
        DVec3::new(-10.0, 0.0, 0.0),
        r,
        density,
        0,
    );
    let dt = 1e-8;
    let mut sim = simulation(p, t, vec![], dt, DVec3::ZERO, CDT);
    let (mut peak, mut deepest, mut steps_in_contact) = (0.0f64, 0.0f64, 0u64);
    for _ in 0..20_000 {
        sim.step().unwrap();
        let x = &sim.particles.position;
        let overlap = 2.0 * r - (x[0] - x[1]).length();
        if overlap > 0.0 {
            steps_in_contact += 1;
            peak = peak.max(sim.particles.force[0].length());
            deepest = deepest.max(overlap);
        } else if steps_in_contact > 0 {
            // Apart again, and moving apart (restitution 1): the impact is over.
            break;
        }
    }
    (peak, deepest, steps_in_contact as f64 * dt)
}

#[test]
fn v1_glass_spheres_head_on() {
    let (f, d, t) = head_on(48e9, 0.2, 2800.0);
    eprintln!(
        "V1 glass: peak {f:.1} N, overlap {:.2} um, contact {:.2} us",
        d * 1e6,
        t * 1e6
    );
    assert!(rel_err(f, 10.70e3) < 0.01, "peak force {f}");
    assert!(rel_err(d, 274.1e-6) < 0.01, "max overlap {d}");
    assert!(rel_err(t, 40.3e-6) < 0.01, "contact time {t}");
}

/// A sphere dropped onto a wall: peak force, largest overlap, contact time and rebound speed.
fn wall_impact(
    r: f64,
    speed: f64,
    youngs: f64,
    poisson: f64,
    density: f64,
    e: f64,
    dt: f64,
) -> (f64, f64, f64, f64) {
    let m = material("m", youngs, poisson, density);
    // The wall is a million times stiffer: rigid to six digits.
    let wall = material("wall", youngs * 1e6, poisson, density);
    let t = table(m, wall, interaction(e, 0.0, 0.0));
    let mut p = Particles::default();
    p.push(
        DVec3::new(0.0, 0.0, r * 1.0001),
        DVec3::new(0.0, 0.0, -speed),
        r,
        density,
        0,
    );
    let mut sim = simulation(p, t, vec![floor(1)], dt, DVec3::ZERO, CDT);
    let (mut peak, mut deepest, mut steps, mut was_in) = (0.0f64, 0.0f64, 0u64, false);
    loop {
        sim.step().unwrap();
        let overlap = r - sim.particles.position[0].z;
        if overlap > 0.0 {
            was_in = true;
            steps += 1;
            peak = peak.max(sim.particles.force[0].length());
            deepest = deepest.max(overlap);
        } else if was_in {
            break;
        }
        assert!(sim.steps < 10_000_000, "no rebound");
    }
    (
        peak,
        deepest,
        steps as f64 * dt,
        sim.particles.velocity[0].z / speed,
    )
}

#[test]
fn v2_aluminium_sphere_on_rigid_wall() {
    let (f, d, t, _) = wall_impact(0.1, 0.2, 70e9, 0.33, 2700.0, 1.0, 2e-7);
    eprintln!(
        "V2 Al: peak {f:.1} N, overlap {:.2} um, contact {:.2} us",
        d * 1e6,
        t * 1e6
    );
    assert!(rel_err(f, 11.47e3) < 0.01, "peak force {f}");
    assert!(rel_err(d, 49.31e-6) < 0.01, "max overlap {d}");
    assert!(rel_err(t, 725.6e-6) < 0.01, "contact time {t}");
}

#[test]
fn v3_restitution_equals_input_at_every_level() {
    for k in 1..=10 {
        let e = k as f64 / 10.0;
        let (_, _, _, ratio) = wall_impact(2.5e-3, 3.9, 380e9, 0.23, 4000.0, e, 2e-9);
        eprintln!("V3 e = {e}: rebound/incident {ratio:.5}");
        assert!(rel_err(ratio, e) < 0.005, "e = {e}: measured {ratio}");
    }
}

/// A sphere resting (at its equilibrium overlap) on a floor, with gravity tilted by `theta`
/// so the floor is an incline; returns the simulation and the sphere radius.
fn on_incline(theta_deg: f64, mu_s: f64, mu_r: f64) -> (dem::Simulation, f64) {
    let (r, rho, youngs, nu) = (0.01, 2500.0, 1e8, 0.3);
    let th = theta_deg.to_radians();
    let g = DVec3::new(9.81 * th.sin(), 0.0, -9.81 * th.cos());
    let m = material("m", youngs, nu, rho);
    let t = table(m.clone(), m, interaction(0.5, mu_s, mu_r));
    let mut p = Particles::default();
    p.push(DVec3::ZERO, DVec3::ZERO, r, rho, 0);
    let weight = p.mass[0] * 9.81 * th.cos();
    let e_star = t.pair(0, 1).e_star;
    p.position[0] = DVec3::new(0.0, 0.0, r - resting_overlap(weight, e_star, r));
    (simulation(p, t, vec![floor(1)], 2e-5, g, CDT), r)
}

#[test]
fn v4_sphere_held_by_rolling_and_static_friction_stays_put() {
    // tan(10 deg) = 0.176 < mu_r = 0.3 and < mu_s = 0.5.
    let (mut sim, r) = on_incline(10.0, 0.5, 0.3);
    let start = sim.particles.position[0];
    sim.run(50_000).unwrap(); // 1 s
    let drift = (sim.particles.position[0] - start).length();
    eprintln!("V4 held: drift {:.3e} R", drift / r);
    assert!(drift < 1e-3 * r, "drift {drift} m");
}

/// Mean acceleration along the incline between 0.2 s and 0.6 s.
fn incline_acceleration(theta: f64, mu_s: f64) -> (f64, dem::Simulation) {
    let (mut sim, _) = on_incline(theta, mu_s, 0.0);
    sim.run(10_000).unwrap();
    let v0 = sim.particles.velocity[0].x;
    sim.run(20_000).unwrap();
    let v1 = sim.particles.velocity[0].x;
    ((v1 - v0) / 0.4, sim)
}

#[test]
fn v4_sphere_rolls_without_slipping_below_the_slip_angle() {
    // tan(20 deg) = 0.364 < 3.5 mu_s = 1.05.
    let th = 20f64.to_radians();
    let (a, sim) = incline_acceleration(20.0, 0.3);
    let want = 5.0 / 7.0 * 9.81 * th.sin();
    eprintln!("V4 rolling: a = {a:.5}, want {want:.5}");
    assert!(rel_err(a, want) < 0.01, "a = {a}, want {want}");
    // Rolling without slipping: v = w R.
    let (v, w) = (
        sim.particles.velocity[0].x,
        sim.particles.angular_velocity[0].y,
    );
    assert!(rel_err(w * 0.01, v) < 0.01, "v = {v}, w R = {}", w * 0.01);
}

#[test]
fn v4_sphere_slides_above_the_slip_angle() {
    // tan(30 deg) = 0.577 > 3.5 mu_s = 0.35.
    let th = 30f64.to_radians();
    let (a, _) = incline_acceleration(30.0, 0.1);
    let want = 9.81 * (th.sin() - 0.1 * th.cos());
    eprintln!("V4 sliding: a = {a:.5}, want {want:.5}");
    assert!(rel_err(a, want) < 0.01, "a = {a}, want {want}");
}

#[test]
fn v5_rolling_friction_decelerates_at_five_sevenths_mu_r_g() {
    let mu_r = 0.1;
    let (mut sim, r) = on_incline(0.0, 0.5, mu_r);
    sim.particles.velocity[0] = DVec3::new(1.0, 0.0, 0.0);
    sim.particles.angular_velocity[0] = DVec3::new(0.0, 1.0 / r, 0.0);
    sim.run(5_000).unwrap(); // let the tangential spring settle
    let v0 = sim.particles.velocity[0].x;
    sim.run(40_000).unwrap(); // 0.8 s
    let v1 = sim.particles.velocity[0].x;
    let decel = (v0 - v1) / 0.8;
    let want = 5.0 / 7.0 * mu_r * 9.81;
    eprintln!("V5: deceleration {decel:.5}, want {want:.5}");
    assert!(
        rel_err(decel, want) < 0.02,
        "deceleration {decel}, want {want}"
    );
}

/// V6: two spheres pulled apart quasi-statically (displacement control: their velocities are
/// reset to +-v/2 before every step) feel at most 3 pi gamma R* of attraction, within 1 %; the
/// attraction ends at the cut-off overlap d_c.
#[test]
fn v6_jkr_pull_off_force_is_three_pi_gamma_r() {
    // Dense spheres, so a half kick of the contact force is negligible against the imposed speed.
    let (r, e, nu, rho, gamma) = (0.005, 1e7, 0.3, 1e7, 0.5);
    let mut inter = interaction(1.0, 0.5, 0.0);
    inter.surface_energy = gamma;
    let t = table(
        material("soft", e, nu, rho),
        material("wall", e, nu, rho),
        inter,
    );
    let e_star = t.pair(0, 0).e_star;
    let r_eff = 0.5 * r;
    let d_c = dem::contact::jkr_cutoff_overlap(gamma, e_star, r_eff);
    assert!(d_c < 0.0);
    let mut p = Particles::default();
    let start_overlap = 2e-6;
    let x0 = r - 0.5 * start_overlap;
    p.push(DVec3::new(-x0, 0.0, 0.0), DVec3::ZERO, r, rho, 0);
    p.push(DVec3::new(x0, 0.0, 0.0), DVec3::ZERO, r, rho, 0);
    let dt = 1e-5;
    let mut sim = simulation(
        p,
        t,
        vec![],
        dt,
        DVec3::ZERO,
        RollingModel::ConstantDirectionalTorque,
    );
    let v = 1e-4;
    let (mut most_attractive, mut last_overlap_with_force) = (0.0f64, f64::NAN);
    for _ in 0..20_000 {
        for k in 0..2 {
            let sign = if sim.particles.id[k] == 0 { -1.0 } else { 1.0 };
            sim.particles.velocity[k] = DVec3::new(sign * 0.5 * v, 0.0, 0.0);
        }
        sim.step().unwrap();
        let k0 = sim.particles.id.iter().position(|&id| id == 0).unwrap();
        let k1 = 1 - k0;
        let overlap = 2.0 * r - (sim.particles.position[k1] - sim.particles.position[k0]).length();
        // Force on sphere 0 along +x (towards sphere 1) is attraction.
        let pull = sim.particles.force[k0].x;
        most_attractive = most_attractive.max(pull);
        if pull != 0.0 {
            last_overlap_with_force = overlap;
        }
    }
    let want = 3.0 * std::f64::consts::PI * gamma * r_eff;
    eprintln!(
        "V6: most attractive force {most_attractive:.6e} N, 3 pi gamma R* = {want:.6e} N; last overlap with force {last_overlap_with_force:.4e}, d_c = {d_c:.4e}"
    );
    assert!(rel_err(most_attractive, want) < 0.01);
    // The attraction lasts until the cut-off, to within one step of separation.
    assert!((last_overlap_with_force - d_c).abs() <= 2.0 * v * dt + 1e-12);
}

/// JKR against a wall: a pull slightly below the pull-off force leaves the sphere stuck, slightly
/// above it tears the sphere off.
#[test]
fn v6_jkr_sphere_hangs_on_a_wall_until_the_pull_exceeds_pull_off() {
    let (r, e, nu, rho, gamma) = (0.005, 1e7, 0.3, 1000.0, 0.5);
    let run = |fraction: f64| -> (f64, f64, f64) {
        let mut inter = interaction(0.1, 0.5, 0.0);
        inter.surface_energy = gamma;
        // A wall 1e6 times stiffer: R* = R, E* = E / (1 - nu^2).
        let t = table(
            material("soft", e, nu, rho),
            material("wall", 1e6 * e, nu, rho),
            inter,
        );
        let mut p = Particles::default();
        p.push(DVec3::new(0.0, 0.0, r), DVec3::ZERO, r, rho, 0);
        let mass = p.mass[0];
        let pull_off = 3.0 * std::f64::consts::PI * gamma * r;
        // Gravity pointing away from the floor, ramped in so the load is quasi-static.
        let mut sim = simulation(
            p,
            t,
            vec![floor(1)],
            2e-5,
            DVec3::ZERO,
            RollingModel::ConstantDirectionalTorque,
        );
        // In 100 stairs of 200 steps, then held as long again.
        for stair in 1..=100 {
            let ramp = stair as f64 / 100.0;
            sim.params.gravity = DVec3::new(0.0, 0.0, ramp * fraction * pull_off / mass);
            sim.run(200).unwrap();
        }
        sim.run(20_000).unwrap();
        let e_star = sim.materials.pair(0, 1).e_star;
        let d_c = dem::contact::jkr_cutoff_overlap(gamma, e_star, r);
        (
            sim.particles.position[0].z - r,
            sim.particles.velocity[0].length(),
            d_c,
        )
    };
    let (held, speed, d_c) = run(0.97);
    let (torn, _, _) = run(1.03);
    eprintln!(
        "V6 wall: gap at 0.97 pull-off {held:.3e} m (speed {speed:.1e} m/s), at 1.03 pull-off {torn:.3e} m; cut-off gap {:.3e} m",
        -d_c
    );
    assert!(
        held < -d_c && speed < 1e-6,
        "held gap {held}, speed {speed}"
    );
    assert!(torn > r, "torn gap {torn}");
}

/// V8, mass properties: a two-sphere dumbbell against the lens-volume result. The union is two
/// spheres less the lens, and the lens is two caps of height h = R - s/2, whose volume and axial
/// inertia are known in closed form.
#[test]
fn v8_dumbbell_mass_and_inertia_match_the_lens_result() {
    use dem::clump::ClumpTemplate;
    use std::f64::consts::PI;
    let (r, s) = (0.01, 0.012);
    let t = ClumpTemplate::new(vec![
        (DVec3::new(-0.5 * s, 0.0, 0.0), r),
        (DVec3::new(0.5 * s, 0.0, 0.0), r),
    ])
    .unwrap();
    let m = t.mass_properties();
    assert!(m.exact);
    let lens = PI / 12.0 * (4.0 * r + s) * (2.0 * r - s).powi(2);
    let volume = 2.0 * 4.0 / 3.0 * PI * r.powi(3) - lens;
    let h = r - 0.5 * s;
    let cap_axial = PI * h.powi(3) * (20.0 * r * r - 15.0 * r * h + 3.0 * h * h) / 30.0;
    let axial = 2.0 * 8.0 / 15.0 * PI * r.powi(5) - 2.0 * cap_axial;
    eprintln!(
        "V8 dumbbell: volume {:.6e} (lens formula {volume:.6e}), axial inertia {:.6e} (caps {axial:.6e}), transverse {:.6e}",
        m.volume, m.principal_inertia.x, m.principal_inertia.y
    );
    assert!(rel_err(m.volume, volume) < 1e-10);
    assert!(rel_err(m.principal_inertia.x, axial) < 1e-10);
    assert!(m.centroid.length() < 1e-15);
    // The transverse moment against an independent estimate (stratified sampling), 0.1 %.
    let sampled = t.sampled_properties(128, 7);
    eprintln!(
        "V8 dumbbell sampled: volume {:.6e}, inertia {:?}",
        sampled.volume, sampled.principal_inertia
    );
    assert!(rel_err(sampled.volume, volume) < 1e-3);
    assert!(rel_err(sampled.principal_inertia.y, m.principal_inertia.y) < 1e-3);
    assert!(rel_err(sampled.principal_inertia.z, m.principal_inertia.z) < 1e-3);
}

/// V8, integration: a freely spinning asymmetric clump keeps its angular momentum and kinetic
/// energy to 0.1 % over 1e5 steps of the Richardson orientation update.
#[test]
fn v8_free_asymmetric_clump_conserves_momentum_and_energy() {
    use dem::clump::ClumpTemplate;
    let t = ClumpTemplate::new(vec![
        (DVec3::new(0.0, 0.0, 0.0), 0.004),
        (DVec3::new(0.006, 0.0, 0.0), 0.003),
        (DVec3::new(0.0, 0.005, 0.001), 0.0025),
    ])
    .unwrap();
    let m = t.mass_properties();
    assert!(!m.exact);
    let i = m.principal_inertia * 1000.0; // density 1000
    assert!(i.x < i.y && i.y < i.z, "asymmetric: {i:?}");
    // Spin mostly about the intermediate axis: the unstable case, which tumbles.
    let mut body = dem::clump::RigidRotation {
        orientation: glam::DQuat::IDENTITY,
        angular_momentum: glam::DVec3::new(0.05 * i.x, 20.0 * i.y, 0.05 * i.z),
        principal_inertia: i,
    };
    let (l0, e0) = (body.angular_momentum, body.kinetic_energy());
    let w_max = body.angular_velocity().length();
    let dt = 0.002 / w_max;
    let (mut largest, mut least_on_axis) = (0.0f64, 1.0f64);
    for _ in 0..100_000 {
        body.advance_orientation(dt);
        largest = largest.max(rel_err(body.kinetic_energy(), e0));
        let lb = body.orientation.inverse() * body.angular_momentum;
        least_on_axis = least_on_axis.min(lb.y.abs() / lb.length());
    }
    let l_body = body.orientation.inverse() * body.angular_momentum;
    eprintln!(
        "V8 free clump: 1e5 steps of {dt:.3e} s (omega dt = 0.002), largest relative energy change {largest:.2e}, body-frame L now {l_body:?}, smallest share on the intermediate axis {least_on_axis:.3}"
    );
    assert!(largest < 1e-3);
    assert!((body.angular_momentum - l0).length() < 1e-12 * l0.length());
    // It did tumble: the momentum left the intermediate axis in the body frame on the way.
    assert!(least_on_axis < 0.5, "{least_on_axis}");
}
