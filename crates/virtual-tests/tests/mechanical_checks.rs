//! The mechanical tests' own checks (issue 37): the tool force of a damped specimen against the
//! exact discrete chain (dem::bond::chain), density scaling, the energy guard, a study's view of a
//! run that was not quasi-static, and a shear run ended by `stop_force_fraction`.

use dem::bond::chain::{Chain, ChainEnd};
use virtual_tests::{run_file, TestError, TestFile};

/// A chain of 19 spheres of 1 mm at 2.1 mm spacing (no contacts between them), bonded; the
/// grips hold the end spheres, so 18 bonds work. No breakage.
fn chain_file(test: &str, k_n: f64, k_t: f64, damping: f64, extra: &str) -> TestFile {
    let text = format!(
        r#"test = "{test}"
seed = 1
[[material]]
name = "stalk"
density = 1000
poisson_ratio = 0.3
shear_modulus = 1e8
[[material]]
name = "steel"
density = 7850
poisson_ratio = 0.3
shear_modulus = 7.9e10
[[interaction]]
materials = ["stalk", "stalk"]
restitution = 0.5
static_friction = 0.3
rolling_friction = 0.0
[[interaction]]
materials = ["stalk", "steel"]
restitution = 0.5
static_friction = 0.3
rolling_friction = 0.0
[[interaction]]
materials = ["steel", "steel"]
restitution = 0.5
static_friction = 0.2
rolling_friction = 0.0
[[bond]]
materials = ["stalk", "stalk"]
normal_stiffness = {k_n:e}
shear_stiffness = {k_t:e}
critical_normal_stress = 1e15
critical_shear_stress = 1e15
bonded_disk_scale = 1.0
contact_radius_scale = 1.1
damping = {damping}
[{test}]
specimen = {{ material = "stalk", radius = 0.001, length = 0.042, diameter = 0.002, spacing = 0.0021 }}
fixture_material = "steel"
grip_length = 0.004
{extra}
"#
    );
    TestFile::parse("chain.toml", &text).unwrap()
}

fn the_chain(k_n: f64, k_t: f64) -> Chain {
    Chain {
        bonds: 18,
        length: 0.0021,
        radius: 0.001,
        normal_stiffness: k_n,
        shear_stiffness: k_t,
    }
}

fn stiffness(f: &TestFile) -> (f64, serde_json::Value) {
    let done = run_file(f, None, None, &mut |_, _| Ok(())).unwrap();
    assert_eq!(
        done.json["particles"].as_u64(),
        Some(19),
        "{}",
        done.summary
    );
    assert_eq!(done.json["bonds"].as_u64(), Some(18), "{}", done.summary);
    (done.json["stiffness_n_per_m"].as_f64().unwrap(), done.json)
}

/// Damping acts on the free spheres only: the grip reads the chain's stiffness, not (1 + damping)
/// times it (1.70x at 0.7 before the fix).
#[test]
fn a_damped_chain_pulled_apart_reads_the_exact_axial_stiffness() {
    let (k_n, k_t) = (1e10, 2.5e8);
    let exact = the_chain(k_n, k_t).axial_stiffness();
    for damping in [0.3, 0.7] {
        let f = chain_file(
            "tension",
            k_n,
            k_t,
            damping,
            "speed = 0.0002\nmax_displacement = 0.00001",
        );
        let (k, _) = stiffness(&f);
        eprintln!(
            "tension, damping {damping}: {k:.2} N/m, exact chain {exact:.2} N/m ({:+.2} %)",
            100.0 * (k / exact - 1.0)
        );
        assert!((k / exact - 1.0).abs() < 0.01, "{k} vs {exact}");
    }
}

/// A damped chain with k_t = k_n / 40 bent by a guided grip: within 1 % of the exact discrete
/// chain (bending joints and shear springs), while Euler-Bernoulli without the shear springs is
/// over 5 % too stiff.
#[test]
fn a_damped_chain_bent_by_a_grip_reads_the_exact_discrete_chain() {
    let (k_n, k_t) = (1e12, 2.5e10);
    let chain = the_chain(k_n, k_t);
    let exact = 1.0 / chain.transverse_compliance(ChainEnd::Guided);
    let beam = chain.beam_stiffness(ChainEnd::Guided);
    assert!(beam / exact > 1.05, "the shear springs matter here");
    for damping in [0.3, 0.7] {
        let f = chain_file(
            "cantilever",
            k_n,
            k_t,
            damping,
            "speed = 0.001\nmax_displacement = 0.00005\ntime_step_percent = 2",
        );
        let (k, _) = stiffness(&f);
        eprintln!(
            "cantilever, damping {damping}: {k:.2} N/m, exact chain {exact:.2} N/m ({:+.2} %), beam formula {beam:.2} N/m",
            100.0 * (k / exact - 1.0)
        );
        assert!((k / exact - 1.0).abs() < 0.01, "{k} vs {exact}");
    }
}

/// The shared bonded bar (test_support), its bonds' k_n and k_t set to `k_n`.
fn bar(top: &str, k_n: &str, extra: &str) -> TestFile {
    let text = test_support::bonded_bar_tension(top, extra)
        .replace("stiffness = 1e9", &format!("stiffness = {k_n}"));
    TestFile::parse("bar.toml", &text).unwrap()
}

/// Density scaling F: the step sqrt(F) longer, F in the outcome, and at a quasi-static speed the
/// same curve: the peak within 2 % and the stiffness within 2 % of the unscaled run.
#[test]
fn density_scaling_lengthens_the_step_and_keeps_a_quasi_static_curve() {
    let run = |top: &str| run_file(&bar(top, "1e9", ""), None, None, &mut |_, _| Ok(())).unwrap();
    let (plain, scaled) = (run(""), run("density_scaling = 100"));
    let get = |d: &virtual_tests::Finished, k: &str| d.json[k].as_f64().unwrap();
    eprintln!("unscaled: {}\nF = 100: {}", plain.summary, scaled.summary);
    assert_eq!(get(&plain, "density_scaling"), 1.0);
    assert_eq!(get(&scaled, "density_scaling"), 100.0);
    let steps = get(&scaled, "time_step_s") / get(&plain, "time_step_s");
    assert!((steps - 10.0).abs() < 1e-9, "{steps}");
    for key in ["peak_force_n", "stiffness_n_per_m"] {
        let (a, b) = (get(&plain, key), get(&scaled, key));
        assert!(
            (b / a - 1.0).abs() < 0.02,
            "{key}: {a} unscaled, {b} at F = 100"
        );
    }
    assert!(scaled.json["quasi_static"].as_bool().unwrap());
    assert!(scaled.rejected.is_none());
    // Scaled too far, the same loading is all inertia: marked, and rejected as a measurement.
    let far = run("density_scaling = 1e7");
    assert!(
        !far.json["quasi_static"].as_bool().unwrap(),
        "{}",
        far.summary
    );
    let why = far
        .rejected
        .expect("a run that was not quasi-static is rejected");
    assert!(
        why.contains("not quasi-static") && why.contains("density_scaling"),
        "{why}"
    );
    // Only the mechanical tests take it, and only from 1 up.
    for (top, expected) in [
        (
            "density_scaling = 0.5",
            "density_scaling: expected a number from 1",
        ),
        (
            "density_scaling = \"big\"",
            "density_scaling: expected a number from 1",
        ),
    ] {
        let text = test_support::bonded_bar_tension(top, "");
        let e = TestFile::parse("bar.toml", &text).unwrap_err();
        assert!(e.contains(expected), "{e}");
    }
}

/// Bonds far too stiff for the step: the specimen explodes, and the energy guard stops the run
/// as diverged at once (before, it left the domain or ended with a "peak force" of noise).
#[test]
fn an_exploding_specimen_stops_as_diverged() {
    let f = bar("", "1e11", "time_step_percent = 20");
    let e = run_file(&f, None, None, &mut |_, _| Ok(())).unwrap_err();
    match &e {
        TestError::Diverged(m) => {
            assert!(
                m.contains("kinetic energy") && m.contains("exceeds the work"),
                "{m}"
            );
            // With the bonds' own warning, which says by how much the step is too long.
            assert!(m.contains("too long for the bond stiffness"), "{m}");
        }
        other => panic!("expected a divergence, got {other:?}"),
    }
    // The same bar at a step its bonds take runs through.
    let f = bar("", "1e11", "time_step_percent = 2");
    let done = run_file(&f, None, None, &mut |_, _| Ok(())).unwrap();
    assert!(
        done.json["bonds_broken"].as_u64().unwrap() > 0,
        "{}",
        done.summary
    );
}

/// `stop_force_fraction` ends a shear run once the cut specimen's force has fallen, as it ends
/// compression and tension.
#[test]
fn a_shear_run_stops_once_the_specimen_is_cut() {
    let text = std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../examples/stalks/twin/shear.toml"),
    )
    .unwrap()
    .replace(
        "max_displacement = 0.0016",
        "max_displacement = 0.004\nstop_force_fraction = 0.3",
    );
    let f = TestFile::parse("shear.toml", &text).unwrap();
    let done = run_file(&f, None, None, &mut |_, _| Ok(())).unwrap();
    let get = |k: &str| done.json[k].as_f64().unwrap();
    eprintln!("{}", done.summary);
    assert!(get("displacement_m") < 0.0035, "{}", done.summary);
    assert!(get("bonds_broken") > 0.0);
    assert!(get("displacement_at_peak_m") < get("displacement_m"));
}
