//! Issue 41: a model of an error never reports a predicted error below zero. Bayesian
//! optimisation fits a GP to the objective (a relative or combined error, never negative), and
//! a GP of values that fall to near zero dips below it; the GP's predicted minimum and mean are
//! reported clamped at 0 (`target::non_negative`, which the optimise and ga_bp stages also apply
//! to a minimised response).

mod common;

use std::path::Path;

use study::Study;

fn study_text(plan: &str, objective: &str) -> String {
    format!(
        r#"
name = "predicted errors"
seed = 5
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

{objective}

[[target]]
test = "stiff"
response = "value"
value = 14.0

[[target]]
test = "soft"
response = "value"
value = 10.4
"#
    )
}

fn run(dir: &Path, text: &str) -> study::Replay {
    common::run_study(dir, text).unwrap();
    let p = dir.join("study.toml");
    let s = Study::load(&p).unwrap();
    let stored = study::Store::open(&s.store_path(), false)
        .unwrap()
        .runs()
        .unwrap();
    study::replay(&s, &stored, None).unwrap()
}

#[test]
fn bayesian_optimisation_reports_no_predicted_error_below_zero() {
    let dir = test_support::fresh_dir("predicted-errors", "bayesopt");
    let r = run(
        &dir,
        &study_text(
            r#"[{ stage = "bayesopt", initial = 8, batch = 2, iterations = 6 }]"#,
            "[objective]\ncombine = \"weighted\"",
        ),
    );
    let Some(study::stages::SurrogateOutcome::BayesOpt(bo)) = r.stages[0].surrogate() else {
        panic!("no bayesopt outcome");
    };
    assert_eq!(bo.history.len(), 7, "the hypercube's round and 6 more");
    for h in &bo.history {
        assert!(h.predicted_minimum >= 0.0, "{h:?}");
        assert!(h.best_observed >= 0.0, "{h:?}");
    }
    // After round 5 (18 runs, the best 0.092 %) the GP dipped below zero: a GP mean of exactly
    // 0 is the clamp's.
    let clamped: Vec<usize> = bo
        .history
        .iter()
        .filter(|h| h.predicted_minimum == 0.0)
        .map(|h| h.iteration)
        .collect();
    assert_eq!(clamped, [5], "{:?}", bo.history);
    assert!((bo.history[5].best_observed - 0.0918).abs() < 5e-4);
    let note = r.stages[0]
        .notes
        .iter()
        .find(|n| n.contains("GP mean of the objective"))
        .unwrap();
    assert!(!note.contains("GP mean of the objective -"), "{note}");
    let _ = std::fs::remove_dir_all(&dir);
}
