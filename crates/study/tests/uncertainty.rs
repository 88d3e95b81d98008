//! The calibrated values' intervals cover the truth at about their stated rate: function-test
//! studies whose lab replicates are drawn around a known parameter value, over many seeds, on
//! each route (response surface, sweep, Bayesian optimisation, GA-BP, SMC); and the flags say
//! which parameters are not identified.

mod common;
use common::run_study;

use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use test_support::summary;

/// `n` lab replicates around `mean` with standard deviation `sd` (Box-Muller), and their mean.
fn replicates(seed: u64, mean: f64, sd: f64, n: usize) -> (Vec<f64>, f64) {
    let mut rng = Pcg64::seed_from_u64(seed ^ 0x5eed);
    let v: Vec<f64> = (0..n)
        .map(|_| {
            let (u1, u2): (f64, f64) = (rng.gen::<f64>().max(1e-300), rng.gen());
            // Rounded as a lab sheet would be, and so that the study file reads them back exactly.
            let x = mean + sd * (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos();
            (x * 1e6).round() / 1e6
        })
        .collect();
    let m = v.iter().sum::<f64>() / n as f64;
    (v, m)
}

/// A function study of `plan` over a (which matters) and b (which hardly does): value =
/// 20 + 8 a + 0.02 b with run noise 0.3; the lab is five replicates around the value at
/// a = 0.55, b = 0.5 (24.41) with SD 0.5.
fn linear_study(seed: u64, plan: &str) -> String {
    let (reps, mean) = replicates(seed, 20.0 + 8.0 * 0.55 + 0.01, 0.5, 5);
    format!(
        r#"
name = "coverage"
seed = {seed}
plan = {plan}

[test]
test = "function"
[test.function]
expression = "20 + 8*a + 0.02*b"
variables = {{ a = 0.5, b = 0.5 }}
noise = 0.3

[[parameter]]
name = "a"
path = "function.variables.a"
min = 0.0
max = 1.0
symbol = "mu_r"

[[parameter]]
name = "b"
path = "function.variables.b"
min = 0.0
max = 1.0

[target]
response = "value"
value = {mean}
replicates = {reps:?}
"#
    )
}

/// Runs `plan` over `seeds`, and counts the seeds whose interval of a holds 0.55; each summary's
/// entry for a is also handed to `check`.
fn coverage(
    name: &str,
    plan: &str,
    seeds: std::ops::Range<u64>,
    check: &dyn Fn(&serde_json::Value),
) -> (usize, usize, f64) {
    let (mut covered, mut total, mut width) = (0, 0, 0.0);
    for seed in seeds {
        let dir = test_support::fresh_dir("uncertainty", &format!("{name}-{seed}"));
        run_study(&dir, &linear_study(seed, plan)).unwrap();
        let s = summary(&dir);
        let a = &s["uncertainty"]["parameters"]["a"];
        check(&s);
        let iv = a["interval_95"]
            .as_array()
            .unwrap_or_else(|| panic!("seed {seed}: {a}"));
        let (lo, hi) = (iv[0].as_f64().unwrap(), iv[1].as_f64().unwrap());
        total += 1;
        width += hi - lo;
        if lo <= 0.55 && 0.55 <= hi {
            covered += 1;
        }
        let _ = std::fs::remove_dir_all(&dir);
    }
    (covered, total, width / total as f64)
}

/// The response surface's inverse-prediction interval of a covers the truth in about 95 % of
/// 40 seeds (at least 34: a binomial 95 % rate falls below that about once in 100); b, which the
/// response hardly depends on, is flagged and not reported as calibrated.
#[test]
fn response_surface_intervals_cover_the_truth_at_their_rate() {
    let check = |s: &serde_json::Value| {
        let b = &s["uncertainty"]["parameters"]["b"];
        assert_eq!(b["identified"], false, "{b}");
        assert!(
            b["flags"]
                .as_array()
                .unwrap()
                .iter()
                .any(|f| f["kind"] == "insensitive"),
            "{b}"
        );
        let pb = s["parameters"]
            .as_array()
            .unwrap()
            .iter()
            .find(|p| p["name"] == "b")
            .unwrap()
            .clone();
        assert_eq!(pb["status"], "undetermined", "{pb}");
        // The validation says whether it agrees with the lab, with its interval.
        let v = &s["validation"];
        assert!(v["mean_interval_95"].is_array(), "{v}");
        assert!(v["statement"].as_str().unwrap().contains("the lab"), "{v}");
    };
    let (covered, total, width) = coverage(
        "rsm",
        r#"["rsm", { stage = "optimize", solutions = 1 }, { stage = "validate", replicates = 3 }]"#,
        0..40,
        &check,
    );
    eprintln!("response surface: {covered} of {total} cover a = 0.55; mean width {width:.4}");
    assert!(covered >= 34, "{covered} of {total}");
    // Half-width about 1.96 √(0.5²/5 + the model's variance) / 8 ≈ 0.06.
    assert!((0.06..0.25).contains(&width), "{width}");
}

/// The sweep's delta-method interval, on the same function with b held.
#[test]
fn sweep_intervals_cover_the_truth_at_their_rate() {
    let (covered, total, width) = coverage(
        "sweep",
        r#"[{ stage = "sweep", parameter = "a", from = 0.3, to = 0.8, step = 0.1, repeats = 2 }]"#,
        0..40,
        &|_| {},
    );
    eprintln!("sweep: {covered} of {total} cover a = 0.55; mean width {width:.4}");
    assert!(covered >= 34, "{covered} of {total}");
    assert!((0.06..0.25).contains(&width), "{width}");
}

/// Bayesian optimisation's interval (the GP's band within noise of the best) covers the truth
/// in most seeds; b is flagged.
#[test]
fn bayesopt_intervals_cover_the_truth() {
    let check = |s: &serde_json::Value| {
        let b = &s["uncertainty"]["parameters"]["b"];
        assert_eq!(b["identified"], false, "{b}");
    };
    let (covered, total, width) = coverage(
        "bo",
        r#"[{ stage = "bayesopt", initial = 10, iterations = 4, batch = 2, restarts = 1 }]"#,
        0..20,
        &check,
    );
    eprintln!("bayesopt: {covered} of {total} cover a = 0.55; mean width {width:.4}");
    assert!(covered >= 17, "{covered} of {total}");
    assert!(width < 0.5, "{width}");
}

/// GA-BP-GA's interval (the spread of the network ensemble) covers the truth in most seeds.
#[test]
fn ga_bp_intervals_cover_the_truth() {
    let (covered, total, width) = coverage(
        "gabp",
        r#"[{ stage = "ga_bp", runs = 30, generations = 10, population = 10, search_generations = 30, search_population = 20, max_epochs = 100 }]"#,
        0..10,
        &|_| {},
    );
    eprintln!("ga_bp: {covered} of {total} cover a = 0.55; mean width {width:.4}");
    assert!(covered >= 8, "{covered} of {total}");
    assert!(width < 0.5, "{width}");
}

/// SMC's credible interval covers the truth in most seeds.
#[test]
fn smc_intervals_cover_the_truth() {
    let (covered, total, width) = coverage(
        "smc",
        r#"[{ stage = "smc", samples = 30, iterations = 3 }]"#,
        0..20,
        &|_| {},
    );
    eprintln!("smc: {covered} of {total} cover a = 0.55; mean width {width:.4}");
    assert!(covered >= 17, "{covered} of {total}");
    assert!(width < 0.5, "{width}");
}
