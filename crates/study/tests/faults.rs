//! Faults of the machine, not of the parameters: a run whose files cannot be written is stored
//! as `output_failed`, the study's advice says to fix the machine (not to narrow the ranges),
//! and the next `demcal run` makes those runs again without `--retry-failed`.

use study::{RunErrorKind, Store, Study};

mod common;
use common::run_path;

/// A fast study on the `function` test: one screening stage of 13 runs.
const SCREEN: &str = r#"
name = "screen"
seed = 5
plan = ["screening"]

[test]
test = "function"
[test.function]
expression = "30 + 10*a + 2*b"
variables = { a = 0.5, b = 0.5 }

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
value = 35.0
"#;

#[test]
fn runs_whose_files_cannot_be_written_are_made_again_once_fixed() {
    let dir = test_support::fresh_dir("study", "unwritable");
    let path = dir.join("study.toml");
    std::fs::write(&path, SCREEN).unwrap();
    let study = Study::load(&path).unwrap();
    // A plain file where the stage's run folders go: every run's result.json fails to be
    // written (as a read-only folder or a full disk would make it; the tests run as root, for
    // whom permissions do not fail).
    let runs = study.runs_dir();
    std::fs::create_dir_all(&runs).unwrap();
    let blocker = runs.join("stage1-screening");
    std::fs::write(&blocker, "not a folder").unwrap();

    let e = run_path(&path, 1).unwrap_err();
    assert!(e.contains("0 of "), "{e}");
    assert!(
        e.contains("The machine failed them, not their parameters") && !e.contains("narrow"),
        "{e}"
    );
    let stored = Store::open(&study.store_path(), false)
        .unwrap()
        .runs()
        .unwrap();
    assert!(!stored.is_empty());
    for r in &stored {
        assert_eq!(r.error_kind, Some(RunErrorKind::OutputFailed), "{r:?}");
        assert!(
            r.error
                .as_deref()
                .unwrap_or("")
                .contains("stage1-screening"),
            "{:?}",
            r.error
        );
    }
    let n = stored.len();
    let st = study::status(&path).unwrap();
    assert!(
        st.contains(&format!(
            "{n} failed ({n} for the machine, made again by the next run)"
        )),
        "{st}"
    );

    // Fixed: the next run makes every one of them again, without --retry-failed.
    std::fs::remove_file(&blocker).unwrap();
    run_path(&path, 1).unwrap();
    let stored = Store::open(&study.store_path(), false)
        .unwrap()
        .runs()
        .unwrap();
    assert_eq!(stored.len(), n);
    assert!(stored
        .iter()
        .all(|r| r.error_kind.is_none() && r.response.is_some()));
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_failure_of_the_parameters_is_kept_but_one_of_the_machine_is_not() {
    let dir = test_support::fresh_dir("study", "kept-failures");
    let path = dir.join("study.toml");
    // Runs with a > 0.5 fail as a diverged simulation would: a verdict on their parameters.
    std::fs::write(
        &path,
        SCREEN.replace(
            "variables = { a = 0.5, b = 0.5 }",
            "variables = { a = 0.5, b = 0.5 }\nfail_when = \"a - 0.5\"",
        ),
    )
    .unwrap();
    let study = Study::load(&path).unwrap();
    let _ = run_path(&path, 1);
    let mut store = Store::open(&study.store_path(), true).unwrap();
    let failed = |s: &Store| {
        s.runs()
            .unwrap()
            .iter()
            .filter(|r| r.error_kind.is_some())
            .count()
    };
    let before = failed(&store);
    assert!(before > 0);
    assert_eq!(store.delete_transient().unwrap(), 0);
    assert_eq!(failed(&store), before);
    assert!(RunErrorKind::Cluster.is_transient() && RunErrorKind::OutputFailed.is_transient());
    assert!(!RunErrorKind::Diverged.is_transient() && !RunErrorKind::TimeLimit.is_transient());
    std::fs::remove_dir_all(&dir).unwrap();
}
