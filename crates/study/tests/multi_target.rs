//! Studies of several tests and targets on the `function` test: two tests whose lab values are
//! met together at one known point (a = 0.6615, b = 0.2308), calibrated by desirability through a
//! response surface and by a weighted objective through Bayesian optimisation; each target's
//! validation is reported; a changed lab value or weight scores the stored runs again without
//! simulating; a run whose second test fails keeps the first test's values; each curve target has
//! its curve section; bad files get one-line errors naming the key.

use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use test_support::summary;

use study::Study;

mod common;
use common::run_study;

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
fn a_weighted_study_is_calibrated_by_bayesian_optimisation_and_a_changed_weight_moves_its_rounds() {
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
    // Another weight scores the stored runs again, which moves the GP and so the points of the
    // rounds after the hypercube: those stored runs no longer match, and the error says why.
    let changed = two_tests(
        r#"[{ stage = "bayesopt", initial = 8, batch = 2, iterations = 8 }, { stage = "validate", replicates = 2 }]"#,
        "combine = \"weighted\"",
        "weight = 3",
    );
    let e = run_study(&dir, &changed).unwrap_err();
    assert!(
        e.contains("stage 1 (bayesopt) run 9 was simulated with")
            && e.contains("asks for other runs when a lab value, weight or limit changed"),
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
    bad(
        &|j| j.tests[1].name = "stiff".into(),
        "tests[1].name: \"stiff\" names an earlier test too",
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

/// `report/results.csv` as a header and rows of cells.
fn results_csv(dir: &Path) -> (Vec<String>, Vec<Vec<String>>) {
    let mut r = csv::Reader::from_path(dir.join("report/results.csv")).unwrap();
    let head = r.headers().unwrap().iter().map(str::to_string).collect();
    let rows = r
        .records()
        .map(|x| x.unwrap().iter().map(str::to_string).collect())
        .collect();
    (head, rows)
}

fn column(head: &[String], name: &str) -> usize {
    head.iter()
        .position(|h| h == name)
        .unwrap_or_else(|| panic!("no column {name} in {head:?}"))
}

/// Derringer-Suich desirability of `y` against `lab` with the default limits, lab ± 50 %.
fn d(y: f64, lab: f64) -> f64 {
    (1.0 - (y - lab).abs() / (0.5 * lab)).max(0.0)
}

/// Issue 41: a run's fingerprint holds only what was simulated, so a new lab value keeps every
/// stored run and scores it again; stores whose fingerprints still end in the objective's terms
/// are kept too.
#[test]
fn a_changed_lab_value_scores_the_stored_runs_again_without_simulating() {
    let dir = fresh_dir("rescore");
    let plan = r#"[{ stage = "rsm", design = "ccd", alpha = "face" }, "optimize"]"#;
    let text = two_tests(plan, "combine = \"desirability\"", "importance = 4");
    run_study(&dir, &text).unwrap();
    let db = dir.join("study.db");
    let before = study::Store::open(&db, false).unwrap().runs().unwrap();
    assert_eq!(
        before.len(),
        8 + 5,
        "a face-centred CCD of 2 factors, 5 centre points"
    );
    // soft's lab value 10.4 -> 10.6: both targets are met at 5a + 3b = 4, 2a - 4b = 0.6.
    let changed = text.replace("value = 10.4", "value = 10.6");
    run_study(&dir, &changed).unwrap();
    let after = study::Store::open(&db, false).unwrap().runs().unwrap();
    assert_eq!(after, before, "nothing simulated, nothing rewritten");
    let s = summary(&dir);
    assert_eq!(s["state"], "complete");
    let (a, b) = (89.0 / 130.0, 5.0 / 26.0);
    let ca = s["calibrated"]["a"].as_f64().unwrap();
    let cb = s["calibrated"]["b"].as_f64().unwrap();
    assert!(
        (ca - a).abs() < 0.02 && (cb - b).abs() < 0.02,
        "a {ca} b {cb}"
    );
    assert!(
        (ca - A).abs() > 0.01,
        "the optimum moved with the lab value"
    );
    assert_eq!(s["objective"]["targets"][1]["value"], 10.6);
    // Each run's objective is its stored values scored with the new lab value (importance 4
    // and 3): 1 - (d1^4 d2^3)^(1/7).
    let (head, rows) = results_csv(&dir);
    let (u, stiff, soft) = (
        column(&head, "undesirability"),
        column(&head, "stiff.value"),
        column(&head, "soft.value"),
    );
    assert_eq!(rows.len(), before.len());
    for row in &rows {
        let num = |i: usize| row[i].parse::<f64>().unwrap();
        let (y1, y2) = (num(stiff), num(soft));
        let want = 1.0 - (d(y1, 14.0).powi(4) * d(y2, 10.6).powi(3)).powf(1.0 / 7.0);
        let old = 1.0 - (d(y1, 14.0).powi(4) * d(y2, 10.4).powi(3)).powf(1.0 / 7.0);
        assert!((num(u) - want).abs() < 1e-9, "{row:?}: want {want}");
        if want < 1.0 {
            assert!(
                (want - old).abs() > 1e-3,
                "{row:?}: the new lab value tells"
            );
        }
    }
    // A store from before: each fingerprint ended in the objective's terms.
    let mut store = study::Store::open(&db, false).unwrap();
    for mut r in after.clone() {
        r.fingerprint
            .push_str("# objective = Desirability [{\"test\":0,\"lab\":14.0}]\n");
        store.insert(&r).unwrap();
    }
    drop(store);
    run_study(&dir, &changed).unwrap();
    let again = study::Store::open(&db, false).unwrap().runs().unwrap();
    assert_eq!(
        again.len(),
        before.len(),
        "the old fingerprints are accepted"
    );
    assert!(again
        .iter()
        .zip(&after)
        .all(|(x, y)| x.finished_at == y.finished_at && x.outputs == y.outputs));
    let s2 = summary(&dir);
    assert_eq!(s2["calibrated"], s["calibrated"]);
    let _ = std::fs::remove_dir_all(&dir);
}

/// Issue 41: a run whose second test fails is failed, and keeps what its first test gave, in the
/// store, `results.csv` and the report's runs table.
#[test]
fn a_run_whose_second_test_fails_keeps_the_first_tests_values() {
    let dir = fresh_dir("kept");
    let text = two_tests(
        r#"[{ stage = "rsm", design = "ccd", alpha = "face" }]"#,
        "combine = \"weighted\"",
        "",
    )
    .replace(
        "expression = \"10 + 2*a - 4*b\"",
        "expression = \"10 + 2*a - 4*b\"\nfail_when = \"b - 0.8\"",
    );
    // The runs at b = 1 fail, the study may stop for them; the report is written either way.
    let _ = run_study(&dir, &text);
    let runs = study::Store::open(&dir.join("study.db"), false)
        .unwrap()
        .runs()
        .unwrap();
    let failed: Vec<_> = runs
        .iter()
        .filter(|r| r.status == study::store::Status::Failed)
        .collect();
    assert_eq!(failed.len(), 3, "(-1, +1), (0, +1), (+1, +1)");
    let (head, rows) = results_csv(&dir);
    let (stiff, soft, combined) = (
        column(&head, "stiff.value"),
        column(&head, "soft.value"),
        column(&head, "combined_error_percent"),
    );
    let html = std::fs::read_to_string(dir.join("report/index.html")).unwrap();
    for r in failed {
        let a = r.inputs["a"].as_f64().unwrap();
        assert_eq!(r.inputs["b"].as_f64(), Some(1.0));
        let e = r.error.clone().unwrap();
        assert!(
            e.starts_with("test soft: ") && e.contains("fail_when"),
            "{e}"
        );
        // stiff gives 10 + 5a + 3b with noise 0.01.
        let y = r.outputs["tests"]["stiff"]["value"].as_f64().unwrap();
        assert!((y - (13.0 + 5.0 * a)).abs() < 0.05, "{y} at a = {a}");
        assert_eq!(r.outputs["targets"][0]["simulated"].as_f64(), Some(y));
        assert!(r.outputs["targets"][1]["simulated"].is_null());
        assert!(r.outputs["tests"].get("soft").is_none());
        assert!(r.response.is_none());
        let row = rows
            .iter()
            .find(|row| row[2] == (r.index + 1).to_string())
            .unwrap();
        assert_eq!(row[stiff].parse::<f64>().unwrap(), y);
        assert_eq!(row[soft], "");
        assert_eq!(row[combined], "");
        let kept = format!("kept: stiff value = {}", study::stages::sig(y));
        assert!(html.contains(&kept), "{kept} in the runs table");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// Issue 41: each test of a run of several names itself in the progress it reports.
#[test]
fn progress_names_the_test_a_run_is_in() {
    let dir = fresh_dir("progress");
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
    let heard = std::sync::Mutex::new(Vec::<String>::new());
    let rec = study::Job::new(&s, &spec)
        .execute(&AtomicBool::new(false), &|phase, _| {
            heard.lock().unwrap().push(phase.to_string())
        })
        .unwrap();
    assert_eq!(rec.status, study::store::Status::Done);
    let heard = heard.into_inner().unwrap();
    assert_eq!(
        heard,
        [
            "test stiff (1/2): starting",
            "test stiff (1/2): evaluate",
            "test soft (2/2): starting",
            "test soft (2/2): evaluate"
        ]
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// Issue 41: with two curve targets (one per test) the report has a curve section for each,
/// naming the run with each test's smallest curve MSE.
#[test]
fn each_curve_target_among_several_has_its_curve_section() {
    let dir = fresh_dir("two-curves");
    std::fs::create_dir_all(dir.join("lab")).unwrap();
    let mut first = String::from("displacement_m,force_n\n");
    let mut second = first.clone();
    for i in 0..=100 {
        let x = 1e-4 * i as f64;
        first.push_str(&format!("{x},{}\n", 5000.0 * x - 2e5 * x * x));
        second.push_str(&format!("{x},{}\n", 2.0 * 5000.0 * x));
    }
    std::fs::write(dir.join("lab/first.csv"), first).unwrap();
    std::fs::write(dir.join("lab/second.csv"), second).unwrap();
    let text = r#"
name = "two curves"
seed = 4
plan = [{ stage = "rsm", design = "ccd", alpha = "face" }, "optimize"]

[[test]]
name = "first"
test = "function"
[test.function]
expression = "k / 1000"
variables = { k = 6000, q = 2.5e5 }
curve = { expression = "k*x - q*x^2", x_max = 0.01, points = 101 }

[[test]]
name = "second"
test = "function"
[test.function]
expression = "k / 1000"
variables = { k = 6000 }
curve = { expression = "2*k*x", x_max = 0.01, points = 101 }

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
test = "first"
curve = "force_displacement"
lab_curves = "lab/first.csv"
normalisation = "none"

[[target]]
test = "second"
curve = "force_displacement"
lab_curves = "lab/second.csv"
normalisation = "none"
"#;
    run_study(&dir, text).unwrap();
    let html = std::fs::read_to_string(dir.join("report/index.html")).unwrap();
    assert_eq!(html.matches(">Curves</h2>").count(), 1);
    let runs = study::Store::open(&dir.join("study.db"), false)
        .unwrap()
        .runs()
        .unwrap();
    for test in ["first", "second"] {
        assert!(
            html.contains(&format!("<h3>test {test}: force_displacement</h3>")),
            "{test}"
        );
        let (i, mse) = runs
            .iter()
            .map(|r| {
                (
                    r.index,
                    r.outputs["tests"][test]["curve_mse"].as_f64().unwrap(),
                )
            })
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .unwrap();
        let line = format!(
            "The run with the smallest {test} curve_mse is stage 1 run {}: {}.",
            i + 1,
            study::stages::sig(mse)
        );
        assert!(html.contains(&line), "{line}");
    }
    // The second test's curve, 2kx against the lab's 10 000x, depends on k alone: its best runs
    // are at k = 4000 and 6000 (the design's levels nearest 5000), with an MSE of
    // (2 * 1000 x)^2 averaged over the comparison's 1000 points on 0 .. 0.01 m.
    let n = 1000.0;
    let mean_x2 = 1e-4 * (2.0 * n - 1.0) / (6.0 * (n - 1.0));
    let best = runs
        .iter()
        .map(|r| r.outputs["tests"]["second"]["curve_mse"].as_f64().unwrap())
        .fold(f64::INFINITY, f64::min);
    assert!(
        (best - 4e6 * mean_x2).abs() < 1e-6 * best,
        "{best} against {}",
        4e6 * mean_x2
    );
    let figures: Vec<String> = std::fs::read_dir(dir.join("report/figures"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    for stem in ["curves-first.svg", "curves-second.svg"] {
        assert!(
            figures.iter().any(|f| f.ends_with(stem)),
            "{stem} in {figures:?}"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// With one target the stored runs are read again too: a target that now names another outcome
/// of the test (`exact` for `value`) takes it from each run's stored outcome, without simulating.
#[test]
fn a_single_target_that_names_another_outcome_reads_it_from_the_stored_runs() {
    let dir = fresh_dir("one-target");
    let text = r#"
name = "one target"
seed = 3
plan = [{ stage = "rsm", design = "ccd", alpha = "face" }, "optimize"]

[test]
test = "function"
[test.function]
expression = "10 + 5*a + 3*b"
variables = { a = 0.5, b = 0.5 }
noise = 0.5

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

[target]
response = "value"
value = 14.0
"#;
    run_study(&dir, text).unwrap();
    let db = dir.join("study.db");
    let before = study::Store::open(&db, false).unwrap().runs().unwrap();
    run_study(
        &dir,
        &text.replace("response = \"value\"", "response = \"exact\""),
    )
    .unwrap();
    let after = study::Store::open(&db, false).unwrap().runs().unwrap();
    assert_eq!(after, before, "nothing simulated");
    let (head, rows) = results_csv(&dir);
    let exact = column(&head, "exact");
    for (row, r) in rows.iter().zip(&after) {
        let a = r.inputs["a"].as_f64().unwrap();
        let b = r.inputs["b"].as_f64().unwrap();
        let y: f64 = row[exact].parse().unwrap();
        // The noise-free outcome, where `value` is 0.5 off on average.
        assert!((y - (10.0 + 5.0 * a + 3.0 * b)).abs() < 1e-9, "{row:?}");
        assert_eq!(Some(y), r.outputs["exact"].as_f64());
    }
    let _ = std::fs::remove_dir_all(&dir);
}
