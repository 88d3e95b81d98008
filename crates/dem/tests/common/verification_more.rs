// More verification cases, included by `verification.rs` (CPU back end) after
// `verification_cases.rs`, whose helpers they use: the second material of V1 and V2, and the
// elastic-plastic spring-dashpot (epsd) rolling model. The GPU back end runs the cases of
// `verification_cases.rs` only, to keep lavapipe's share of the default test run in bounds; its
// epsd kernels are checked against the CPU to round-off in `crates/gpu/tests/agreement.rs`.

#[test]
fn v1_limestone_spheres_head_on() {
    let (f, d, t) = head_on(20e9, 0.25, 2500.0);
    eprintln!(
        "V1 limestone: peak {f:.1} N, overlap {:.2} um, contact {:.2} us",
        d * 1e6,
        t * 1e6
    );
    assert!(rel_err(f, 7.11e3) < 0.01, "peak force {f}");
    assert!(rel_err(d, 368.3e-6) < 0.01, "max overlap {d}");
    assert!(rel_err(t, 54.2e-6) < 0.01, "contact time {t}");
}

#[test]
fn v2_magnesium_sphere_on_rigid_wall() {
    let (f, d, t, _) = wall_impact(0.1, 0.2, 40e9, 0.35, 1800.0, 1.0, 2e-7);
    eprintln!(
        "V2 Mg: peak {f:.1} N, overlap {:.2} um, contact {:.2} us",
        d * 1e6,
        t * 1e6
    );
    assert!(rel_err(f, 7.23e3) < 0.01, "peak force {f}");
    assert!(rel_err(d, 52.12e-6) < 0.01, "max overlap {d}");
    assert!(rel_err(t, 767.1e-6) < 0.01, "contact time {t}");
}

#[test]
fn epsd_rolling_resistance_decelerates_at_five_sevenths_mu_r_g_once_plastic() {
    // With the epsd model the rolling moment saturates at mu_r R* |F_n| (R* = R against a wall), so a
    // sphere rolling on a flat wall decelerates like the cdt model once the spring is at its limit.
    let mu_r = 0.1;
    let (mut sim, r) = on_incline(0.0, 0.5, mu_r);
    sim.params.rolling_model = RollingModel::Epsd {
        viscous_damping: 0.3,
    };
    sim.particles.velocity[0] = DVec3::new(1.0, 0.0, 0.0);
    sim.particles.angular_velocity[0] = DVec3::new(0.0, 1.0 / r, 0.0);
    sim.run(5_000).unwrap();
    let v0 = sim.particles.velocity[0].x;
    sim.run(40_000).unwrap();
    let v1 = sim.particles.velocity[0].x;
    let decel = (v0 - v1) / 0.8;
    let want = 5.0 / 7.0 * mu_r * 9.81;
    eprintln!("epsd: deceleration {decel:.5}, want {want:.5}");
    assert!(
        rel_err(decel, want) < 0.02,
        "deceleration {decel}, want {want}"
    );
}

#[test]
fn epsd_holds_a_sphere_on_an_incline_below_the_rolling_limit() {
    // tan(10 deg) = 0.176 < mu_r = 0.3: the rolling spring takes up the load and the sphere stops.
    let (mut sim, r) = on_incline(10.0, 0.5, 0.3);
    sim.params.rolling_model = RollingModel::Epsd {
        viscous_damping: 0.3,
    };
    sim.run(25_000).unwrap();
    let mid = sim.particles.position[0];
    sim.run(25_000).unwrap();
    let drift = (sim.particles.position[0] - mid).length();
    eprintln!("epsd held: drift over the last 0.5 s {:.3e} R", drift / r);
    assert!(drift < 1e-3 * r, "drift {drift}");
}
