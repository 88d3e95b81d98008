//! Studies of several tests and targets on the `function` test: two tests whose lab values are
//! met together at one known point (a = 0.6615, b = 0.2308), calibrated by desirability through a
//! response surface and by a weighted objective through Bayesian optimisation; each target's
//! validation is reported; a changed weight makes the stored runs stale; bad files get one-line
//! errors naming the key.

use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::sync::Arc;
use test_support::summary;

use study::{RunOptions, Study};

/// Test `stiff` gives 10 + 5a + 3b (lab 14), test `soft` 10 + 2a - 4b (lab 10.4): both match
/// at a = 0.2 + 2b, 13b = 3, so b = 3/13 and a = 0.2 + 6/13.
const A: f64 = 0.2 + 6.0 / 13.0;
const B: f64 = 3.0 / 13.0;

fn two_tests(plan: &str, objective: &str, stiff_extra: &str) -> String {
    format!(
        r#"
name = "two tests"
seed = 3
plan = {plan}

[[test]]
name = "stiff"
test = "function"
[test.function]
expression = "10 + 5*a + 3*b"
variables = {{ a = 0.5, b = 0.5 }}
noise = 0.01

[[test]]
name = "soft"
test = "function"
[test.function]
expression = "10 + 2*a - 4*b"
variables = {{ a = 0.5, b = 0.5 }}
noise = 0.01

[[parameter]]
name = "a"
path = "function.variables.a"
min = 0.0
max = 1.0

[[parameter]]
name = "b"
path = "function.variables.b"
min = 0.0
max = 1.0

[objective]
{objective}

[[target]]
test = "stiff"
response = "value"
replicates = [13.9, 14.1, 14.0]
{stiff_extra}

[[target]]
test = "soft"
response = "value"
value = 10.4
"#
    )
}

fn fresh_dir(name: &str) -> PathBuf {
    test_support::fresh_dir("multi", name)
}

fn run_study(dir: &Path, text: &str) -> Result<String, String> {
    let p = dir.join("study.toml");
    std::fs::write(&p, text).unwrap();
    study::run(
        &p,
        &RunOptions {
            jobs: 2,
            ..Default::default()
        },
        Arc::new(AtomicBool::new(false)),
    )
    .map_err(|e| e.to_string())
}

#[test]
fn a_desirability_study_meets_both_targets_through_a_response_surface() {
    let dir = fresh_dir("desirability");
    let text = two_tests(
        r#"[{ stage = "rsm", design = "ccd", alpha = "face" }, "optimize", { stage = "validate", replicates = 3 }]"#,
        "combine = \"desirability\"",
        "importance = 4",
    );
    run_study(&dir, &text).unwrap();
    let s = summary(&dir);
    assert_eq!(s["state"], "complete");
    let a = s["calibrated"]["a"].as_f64().unwrap();
    let b = s["calibrated"]["b"].as_f64().unwrap();
    // Each target's linear model is exact to the noise (0.01 on values near 12), so the
    // optimum is the crossing point to within a few hundredths.
    assert!((a - A).abs() < 0.02 && (b - B).abs() < 0.02, "a {a} b {b}");
    let targets = s["objective"]["targets"].as_array().unwrap();
    assert_eq!(targets.len(), 2);
    for t in targets {
        let e = t["relative_error_percent"].as_f64().unwrap();
        assert!(e < 0.5, "{t}");
        assert_eq!(t["validation_runs"], 3);
    }
    assert_eq!(s["objective"]["combine"], "desirability");
    assert_eq!(targets[0]["importance"], 4);
    // The optimise stage models each target and reaches a desirability near 1.
    let opt = &s["stages"][1];
    assert!(
        opt["solutions"][0]["desirability"].as_f64().unwrap() > 0.97,
        "{opt}"
    );
    assert_eq!(
        opt["solutions"][0]["responses"].as_array().unwrap().len(),
        2
    );
    // Each run made both tests, in its own folder, and the results table has both targets.
    let csv = std::fs::read_to_string(dir.join("report/results.csv")).unwrap();
    let head = csv.lines().next().unwrap();
    assert!(head.contains("undesirability"), "{head}");
    assert!(
        head.contains("stiff.value") && head.contains("soft.value"),
        "{head}"
    );
    let html = std::fs::read_to_string(dir.join("report/index.html")).unwrap();
    assert!(
        html.contains("predicted value of soft (d)"),
        "the per-target optimum table"
    );
    assert!(html.contains("desirability is 1 at the lab value"));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_weighted_study_is_calibrated_by_bayesian_optimisation_and_a_changed_weight_is_stale() {
    let dir = fresh_dir("weighted");
    let text = two_tests(
        r#"[{ stage = "bayesopt", initial = 8, batch = 2, iterations = 8 }, { stage = "validate", replicates = 2 }]"#,
        "combine = \"weighted\"",
        "weight = 2",
    );
    run_study(&dir, &text).unwrap();
    let s = summary(&dir);
    assert_eq!(s["state"], "complete");
    let a = s["calibrated"]["a"].as_f64().unwrap();
    let b = s["calibrated"]["b"].as_f64().unwrap();
    assert!((a - A).abs() < 0.1 && (b - B).abs() < 0.1, "a {a} b {b}");
    let combined = s["validation_mean"].as_f64().unwrap();
    assert!(combined < 2.0, "combined error {combined} %");
    for t in s["objective"]["targets"].as_array().unwrap() {
        assert!(t["relative_error_percent"].as_f64().unwrap() < 3.0, "{t}");
    }
    // The combined objective is what the runs store: check one run against its targets.
    let db = study::Store::open(&dir.join("study.db"), false).unwrap();
    let r = db.runs().unwrap().into_iter().next().unwrap();
    let ys = study::stages::target_values(&r).unwrap();
    let e1 = (ys[0] - 14.0) / 14.0;
    let e2 = (ys[1] - 10.4) / 10.4;
    let want = 100.0 * ((2.0 * e1 * e1 + e2 * e2) / 3.0).sqrt();
    assert!((r.response.unwrap() - want).abs() < 1e-9 * want.max(1.0));
    // Another weight scores the stored runs differently: they are stale, and the error says so.
    let changed = two_tests(
        r#"[{ stage = "bayesopt", initial = 8, batch = 2, iterations = 8 }, { stage = "validate", replicates = 2 }]"#,
        "combine = \"weighted\"",
        "weight = 3",
    );
    let e = run_study(&dir, &changed).unwrap_err();
    assert!(
        e.contains("scored with other targets, weights or limits"),
        "{e}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bad_multi_target_files_name_the_key() {
    let dir = fresh_dir("errors");
    let p = dir.join("study.toml");
    let base = two_tests("[\"rsm\"]", "combine = \"weighted\"", "");
    let cases: Vec<(String, &str)> = vec![
        (
            base.replace("[objective]\ncombine = \"weighted\"", ""),
            "objective: missing: the study has 2 targets",
        ),
        (
            base.replace("test = \"stiff\"\nresponse", "response"),
            "target[0].test: missing: the study has 2 tests",
        ),
        (
            base.replace("test = \"stiff\"\nresponse", "test = \"hard\"\nresponse"),
            "target[0].test: \"hard\" is not a test of the study (expected stiff, soft)",
        ),
        (
            base.replace("combine = \"weighted\"", "combine = \"pareto\""),
            "objective.combine: expected \"weighted\" or \"desirability\"",
        ),
        (
            two_tests("[\"rsm\"]", "combine = \"weighted\"", "importance = 2"),
            "target[0].importance: only with [objective] combine = \"desirability\"",
        ),
        (
            two_tests("[\"rsm\"]", "combine = \"desirability\"", "low = 15"),
            "target[0].low: expected low < lab value < high",
        ),
        (
            base.replace("name = \"soft\"", "name = \"stiff\""),
            "test[1].name: two tests are named \"stiff\"",
        ),
        (
            base.replace(
                "path = \"function.variables.b\"",
                "path = \"function.variables.c\"",
            ),
            "parameter[1].path: \"function.variables.c\": in none of the tests",
        ),
        (
            base.replace(
                "test = \"soft\"\nresponse = \"value\"\nvalue = 10.4",
                "test = \"stiff\"\nresponse = \"exact\"\nvalue = 10.4",
            ),
            "target: no target is measured in test soft",
        ),
    ];
    for (text, want) in cases {
        std::fs::write(&p, &text).unwrap();
        let e = Study::load(&p).unwrap_err();
        assert!(e.contains(want), "expected \"{want}\" in: {e}");
        assert!(!e.contains('\n'), "one line: {e}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_parameter_goes_into_every_test_that_has_its_path() {
    let dir = fresh_dir("paths");
    let p = dir.join("study.toml");
    // `c` only exists in the soft test.
    let text = two_tests("[\"rsm\"]", "combine = \"weighted\"", "").replace(
        "expression = \"10 + 2*a - 4*b\"\nvariables = { a = 0.5, b = 0.5 }",
        "expression = \"10 + 2*a - 4*b + c\"\nvariables = { a = 0.5, b = 0.5, c = 0.0 }",
    )
        + "\n[[parameter]]\nname = \"c\"\npath = \"function.variables.c\"\nmin = 0.0\nmax = 0.1\n";
    std::fs::write(&p, &text).unwrap();
    let s = Study::load(&p).unwrap();
    assert_eq!(s.tests.len(), 2);
    assert_eq!(s.parameters[0].paths[0].1, vec![0, 1]);
    assert_eq!(s.parameters[2].paths[0].1, vec![1]);
    let soft = s.test_with(1, &[0.1, 0.2, 0.05]);
    assert_eq!(soft["function"]["variables"]["c"].as_float(), Some(0.05));
    let stiff = s.test_with(0, &[0.1, 0.2, 0.05]);
    assert!(stiff["function"]["variables"].get("c").is_none());
    assert_eq!(s.target.response, "combined_error_percent");
    assert!(s.target.minimised());
    let _ = std::fs::remove_dir_all(&dir);
}

/// A scalar and a curve of one test: the scalar target comes first, so the curve comparison must
/// still reach the job; the curve's relative error is the root of its MSE over the lab curve's
/// mean square.
#[test]
fn a_scalar_and_a_curve_of_one_test_are_matched_together() {
    let dir = fresh_dir("curve");
    std::fs::create_dir_all(dir.join("lab")).unwrap();
    let mut lab = String::from("displacement_m,force_n\n");
    for i in 0..=100 {
        let x = 1e-4 * i as f64;
        lab.push_str(&format!("{x},{}\n", 5000.0 * x - 2e5 * x * x));
    }
    std::fs::write(dir.join("lab/curve.csv"), lab).unwrap();
    let text = r#"
name = "scalar and curve"
seed = 2
plan = [{ stage = "bayesopt", initial = 10, batch = 2, iterations = 8 }, { stage = "validate", replicates = 2 }]

[test]
test = "function"
[test.function]
expression = "k / 1000"
variables = { k = 6000, q = 2.5e5 }
noise = 0.01
curve = { expression = "k*x - q*x^2", x_max = 0.01, points = 101 }

[[parameter]]
name = "k"
path = "function.variables.k"
min = 4000
max = 8000

[[parameter]]
name = "q"
path = "function.variables.q"
min = 1e5
max = 4e5

[objective]
combine = "weighted"

[[target]]
response = "value"
value = 5.0

[[target]]
curve = "force_displacement"
lab_curves = "lab/curve.csv"
normalisation = "none"
"#;
    run_study(&dir, text).unwrap();
    let s = summary(&dir);
    assert_eq!(s["state"], "complete", "{}", s["state"]);
    let k = s["calibrated"]["k"].as_f64().unwrap();
    let q = s["calibrated"]["q"].as_f64().unwrap();
    assert!(
        (k - 5000.0).abs() < 250.0 && (q - 2e5).abs() < 5e4,
        "k {k} q {q}"
    );
    let db = study::Store::open(&dir.join("study.db"), false).unwrap();
    for r in db.runs().unwrap() {
        assert!(
            r.outputs["tests"]["function"]["curve_mse"].is_f64(),
            "{}",
            r.outputs
        );
    }
    let targets = s["objective"]["targets"].as_array().unwrap();
    assert_eq!(targets[1]["response"], "curve_mse");
    assert!(
        targets[1]["relative_error_percent"].as_f64().unwrap() < 5.0,
        "{}",
        targets[1]
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn the_multi_test_example_reads() {
    let root =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/maize-kernel-multi/study.toml");
    let s = Study::load(&root).unwrap();
    assert_eq!(s.tests.len(), 2);
    assert_eq!(s.targets.len(), 2);
    // The kernel-steel friction goes into both tests (the heap stands on steel).
    assert_eq!(s.parameters[0].paths[0].1, vec![0, 1]);
}

/// With narrow limits every design point has a target beyond them, so the combined
/// undesirability is 1 everywhere and cannot be modelled; the response surface stage goes on and
/// the optimiser still finds the point from each target's own model.
#[test]
fn a_desirability_study_whose_design_sits_beyond_the_limits_still_optimises() {
    let dir = fresh_dir("plateau");
    let text = two_tests(
        r#"[{ stage = "rsm", design = "ccd", alpha = "face" }, "optimize"]"#,
        "combine = \"desirability\"",
        "low = 13.999\nhigh = 14.001",
    );
    run_study(&dir, &text).unwrap();
    let s = summary(&dir);
    assert_eq!(s["state"], "complete", "{}", s["state"]);
    let notes = s["stages"][0]["notes"].to_string();
    assert!(notes.contains("cannot be modelled"), "{notes}");
    let a = s["calibrated"]["a"].as_f64().unwrap();
    let b = s["calibrated"]["b"].as_f64().unwrap();
    assert!((a - A).abs() < 0.03 && (b - B).abs() < 0.03, "a {a} b {b}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_job_file_of_several_tests_is_checked_when_read() {
    let dir = fresh_dir("job");
    let p = dir.join("study.toml");
    std::fs::write(&p, two_tests("[\"rsm\"]", "combine = \"weighted\"", "")).unwrap();
    let s = Study::load(&p).unwrap();
    let spec = study::stages::RunSpec {
        stage: 0,
        stage_kind: "rsm",
        index: 0,
        point: 0,
        label: "center".into(),
        coded: vec![0.0, 0.0],
        values: vec![0.5, 0.5],
        seed: 7,
    };
    let job = study::Job::new(&s, &spec);
    assert_eq!(job.tests.len(), 2);
    assert_ne!(job.tests[0].seed, job.tests[1].seed);
    let file = dir.join("job.json");
    let bad = |edit: &dyn Fn(&mut study::Job), want: &str| {
        let mut j = job.clone();
        edit(&mut j);
        std::fs::write(&file, j.to_json()).unwrap();
        let e = study::Job::load(&file).unwrap_err();
        assert!(e.contains(want), "expected \"{want}\" in: {e}");
    };
    bad(
        &|j| j.tests[1].name = "../x".into(),
        "tests[1].name: expected letters",
    );
    bad(&|j| j.terms.clear(), "terms: missing");
    bad(&|j| j.combine = None, "terms: given without combine");
    bad(
        &|j| j.terms[1].test = 5,
        "terms[1].test: 5 is not a test of the job",
    );
    bad(&|j| j.tests.clear(), "tests: expected at least one test");
    // Issue 40: these were accepted.
    bad(
        &|j| j.backend = Some("quantum".into()),
        "backend: expected \"cpu\" or \"gpu\", got \"quantum\"",
    );
    bad(
        &|j| j.run_time_limit_s = Some(-5.0),
        "run_time_limit_s: expected seconds > 0, got -5",
    );
    std::fs::write(&file, job.to_json() + "\n{\"more\": 1}").unwrap();
    let e = study::Job::load(&file).unwrap_err();
    assert!(e.contains("after the job: trailing characters"), "{e}");
    // A key holding line breaks (found by tests/hostile_files.rs): still one line.
    std::fs::write(&file, job.to_json().replacen("\"seed\"", "\"se\\ned\"", 1)).unwrap();
    let e = study::Job::load(&file).unwrap_err();
    assert!(e.contains("unknown field") && !e.contains('\n'), "{e}");
    // The job as written reads back the same.
    std::fs::write(&file, job.to_json()).unwrap();
    let mut back = study::Job::load(&file).unwrap();
    back.out_dir = job.out_dir.clone();
    assert_eq!(back, job);
    let _ = std::fs::remove_dir_all(&dir);
}
