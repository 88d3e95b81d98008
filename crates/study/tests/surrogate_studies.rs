//! Whole studies with the surrogate stages (bayesopt, smc, ga_bp) on the `function` test: each
//! recovers a known optimum, and a study whose store lost its last runs (as a kill leaves it)
//! resumes to the same runs and the same result.

use std::path::{Path, PathBuf};
use test_support::summary;

mod common;
use common::run_study;

/// A bowl whose lowest value, 30, is at a = 0.6, b = 0.3, c = 0 (the end of c's range).
fn bowl(plan: &str, extra_target: &str) -> String {
    format!(
        r#"
name = "bowl"
seed = 5
plan = {plan}

[test]
test = "function"
[test.function]
expression = "30 + 10*((a - 0.6)^2 + (b - 0.3)^2) + 0.5*c"
variables = {{ a = 0.8, b = 0.5, c = 0.5 }}
noise = 0.02

[[parameter]]
name = "a"
path = "function.variables.a"
min = 0.2
max = 1.2

[[parameter]]
name = "b"
path = "function.variables.b"
min = 0.0
max = 0.9

[[parameter]]
name = "c"
path = "function.variables.c"
min = 0.0
max = 1.0

[target]
{extra_target}
"#
    )
}

fn fresh_dir(name: &str) -> PathBuf {
    test_support::fresh_dir("surrogate", name)
}

fn calibrated(s: &serde_json::Value, name: &str) -> f64 {
    s["calibrated"][name].as_f64().unwrap()
}

/// The results table without its timing columns, sorted by stage and run.
fn runs_without_times(dir: &Path) -> Vec<String> {
    let csv = std::fs::read_to_string(dir.join("report/results.csv")).unwrap();
    let mut rows: Vec<String> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').take(10).collect::<Vec<_>>().join(","))
        .collect();
    rows.sort();
    rows
}

const BAYESOPT_PLAN: &str = r#"[{ stage = "bayesopt", initial = 12, iterations = 8, batch = 2 }, { stage = "validate", replicates = 2 }]"#;

#[test]
fn bayesopt_finds_the_bowls_bottom_and_resumes_to_the_same_result() {
    let dir = fresh_dir("bo");
    let text = bowl(BAYESOPT_PLAN, "value = 30.0");
    let out = run_study(&dir, &text).unwrap();
    assert!(out.contains("state: complete"), "{out}");
    let s = summary(&dir);
    let (a, b, c) = (
        calibrated(&s, "a"),
        calibrated(&s, "b"),
        calibrated(&s, "c"),
    );
    assert!(
        (a - 0.6).abs() < 0.12 && (b - 0.3).abs() < 0.12 && c < 0.15,
        "a = {a}, b = {b}, c = {c}"
    );
    // 12 hypercube runs and 8 rounds of 2, unless patience stopped it (it has none here).
    assert_eq!(s["stages"][0]["runs"], 12 + 8 * 2);
    let err = s["relative_error_percent"].as_f64().unwrap();
    assert!(err < 1.0, "validation error {err} %");
    let html = std::fs::read_to_string(dir.join("report/index.html")).unwrap();
    assert!(
        html.contains("Bayesian optimisation"),
        "report lacks the stage"
    );

    // As a kill mid-study leaves it: the store lost the last rounds and the validation.
    let full = runs_without_times(&dir);
    let cut = fresh_dir("bo-cut");
    std::fs::copy(dir.join("study.db"), cut.join("study.db")).unwrap();
    let db = rusqlite::Connection::open(cut.join("study.db")).unwrap();
    let removed = db
        .execute(
            "DELETE FROM runs WHERE stage = 1 OR (stage = 0 AND idx >= 17)",
            [],
        )
        .unwrap();
    assert_eq!(removed, 2 + 11);
    drop(db);
    let out = run_study(&cut, &text).unwrap();
    assert!(out.contains("state: complete"), "{out}");
    assert_eq!(runs_without_times(&cut), full);
    assert_eq!(summary(&cut)["calibrated"], s["calibrated"]);
    for d in [dir, cut] {
        std::fs::remove_dir_all(d).unwrap();
    }
}

#[test]
fn smc_puts_the_posterior_on_the_bowls_bottom() {
    let dir = fresh_dir("smc");
    // c held at 0 (its range's end), so the posterior of a and b is the bowl's.
    let text = bowl(
        r#"[{ stage = "smc", samples = 40, iterations = 4 }, { stage = "validate", replicates = 2 }]"#,
        "replicates = [30.0, 30.1, 29.95]",
    )
    .replace("max = 1.0\n", "max = 0.001\n");
    let out = run_study(&dir, &text).unwrap();
    assert!(out.contains("state: complete"), "{out}");
    let s = summary(&dir);
    let (a, b) = (calibrated(&s, "a"), calibrated(&s, "b"));
    assert!(
        (a - 0.6).abs() < 0.1 && (b - 0.3).abs() < 0.1,
        "a = {a}, b = {b}"
    );
    let post = &s["stages"][0]["posterior"];
    for name in ["a", "b"] {
        let lo = post[name]["credible_low"].as_f64().unwrap();
        let hi = post[name]["credible_high"].as_f64().unwrap();
        let truth = if name == "a" { 0.6 } else { 0.3 };
        assert!(lo < truth && truth < hi, "{name}: {lo} .. {hi}");
    }
    let err = s["relative_error_percent"].as_f64().unwrap();
    assert!(err < 1.0, "validation error {err} %");
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn ga_bp_trained_on_a_ccd_hits_the_lab_value() {
    let dir = fresh_dir("gabp");
    let text = bowl(
        r#"["rsm", { stage = "ga_bp", generations = 40, population = 40 }, { stage = "validate", replicates = 2 }]"#,
        "value = 32.0",
    );
    let out = run_study(&dir, &text).unwrap();
    assert!(out.contains("state: complete"), "{out}");
    let s = summary(&dir);
    let net = &s["stages"][1]["network"];
    // 20 noisy CCD runs of which 4 test the network: its fit over all of them is the stable
    // measure (0.88 measured; test rows 0.80).
    assert!(net["r2_all"].as_f64().unwrap() > 0.8, "{net}");
    assert!(net["r2_test"].as_f64().unwrap() > 0.5, "{net}");
    let predicted = net["predicted"].as_f64().unwrap();
    assert!((predicted - 32.0).abs() < 0.05, "predicted {predicted}");
    let err = s["relative_error_percent"].as_f64().unwrap();
    assert!(err < 2.0, "validation error {err} %");
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn a_study_imports_the_value_another_study_calibrated() {
    let root = fresh_dir("chain");
    let (first, second) = (root.join("first"), root.join("second"));
    std::fs::create_dir_all(&first).unwrap();
    std::fs::create_dir_all(&second).unwrap();
    // The second study fixes `a` to what the first calibrated and varies only `b`.
    let chained = bowl(
        r#"[{ stage = "bayesopt", initial = 6, iterations = 2, batch = 2 }]"#,
        "value = 30.0",
    )
    .replace(
        "[[parameter]]\nname = \"a\"\npath = \"function.variables.a\"\nmin = 0.2\nmax = 1.2\n",
        "[[import]]\nstudy = \"../first/study.toml\"\nparameter = \"a\"\npath = \"function.variables.a\"\n",
    );
    assert!(chained.contains("[[import]]"));
    // Before the first study has run, the second names the summary it needs.
    let e = run_study(&second, &chained).unwrap_err();
    assert!(
        e.contains("import[0].study") && e.contains("run that study first"),
        "{e}"
    );
    run_study(&first, &bowl(BAYESOPT_PLAN, "value = 30.0")).unwrap();
    let a = calibrated(&summary(&first), "a");
    run_study(&second, &chained).unwrap();
    let s = summary(&second);
    assert_eq!(s["imports"][0]["value"].as_f64().unwrap(), a);
    assert!(s["calibrated"].get("a").is_none());
    // Every run of the second study simulated the imported value.
    let db = rusqlite::Connection::open(second.join("study.db")).unwrap();
    let mut q = db.prepare("SELECT fingerprint FROM runs").unwrap();
    let prints: Vec<String> = q
        .query_map([], |r| r.get(0))
        .unwrap()
        .map(|r| r.unwrap())
        .collect();
    assert_eq!(prints.len(), 6 + 2 * 2);
    for p in &prints {
        assert!(p.contains(&format!("a = {a}")), "{p}");
    }
    std::fs::remove_dir_all(root).unwrap();
}

/// The report maps the GP's predicted objective over every pair of parameters (seed 000 draws
/// all six pairs of its four bond parameters), not a few of them.
#[test]
fn the_objective_is_mapped_over_every_pair_of_parameters() {
    let dir = fresh_dir("pairs");
    let text = bowl(
        r#"[{ stage = "bayesopt", initial = 10, iterations = 1, batch = 2 }]"#,
        "value = 30.0",
    )
    .replace(
        "variables = { a = 0.8, b = 0.5, c = 0.5 }",
        "variables = { a = 0.8, b = 0.5, c = 0.5, d = 0.5 }",
    )
    .replace(
        "[target]",
        "[[parameter]]\nname = \"d\"\npath = \"function.variables.d\"\nmin = 0.0\nmax = 1.0\n\n[target]",
    );
    let out = run_study(&dir, &text).unwrap();
    assert!(out.contains("state: complete"), "{out}");
    // Each map's caption names its pair: "... over a and b, the other parameters held ...".
    let html = std::fs::read_to_string(dir.join("report/index.html")).unwrap();
    let mut maps: Vec<String> = html
        .split("the GP's predicted objective")
        .skip(1)
        .filter_map(|rest| {
            let at = rest.find(" over ")?;
            let pair = &rest[at + 6..rest.find(", the other parameters held")?];
            let (a, b) = pair.split_once(" and ")?;
            Some(format!("{a} x {b}"))
        })
        .collect();
    maps.dedup();
    maps.sort();
    assert_eq!(
        maps,
        ["a x b", "a x c", "a x d", "b x c", "b x d", "c x d"],
        "{maps:?}"
    );
    std::fs::remove_dir_all(dir).unwrap();
}
