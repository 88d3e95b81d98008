//! Whole studies on the `function` test: the plan recovers a known optimum, failed runs are kept
//! with their reason, too many failures stop the study with a clear message, and a changed study
//! is noticed before stored runs are reused.

use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::sync::Arc;

use study::{RunOptions, Study};

/// A bowl with its only minimum, 30, at a = 0.6, b = 0.3; c and d barely matter. The runs with
/// c + d > 1.7 fail, as a simulation that explodes would.
pub const BOWL: &str = r#"
name = "bowl"
seed = 3
plan = ["screening", "steepest", "rsm", "optimize", "validate"]

[test]
test = "function"
[test.function]
expression = "30 + 10*((a - 0.6)^2 + (b - 0.3)^2) + 0.01*c + 0.01*d"
variables = { a = 0.8, b = 0.5, c = 0.5, d = 0.5 }
noise = 0.02
fail_when = "c + d - 1.7"

[[parameter]]
name = "a"
path = "function.variables.a"
min = 0.4
max = 1.2

[[parameter]]
name = "b"
path = "function.variables.b"
min = 0.1
max = 0.9

[[parameter]]
name = "c"
path = "function.variables.c"
min = 0.0
max = 1.0

[[parameter]]
name = "d"
path = "function.variables.d"
min = 0.0
max = 1.0

[target]
value = 30.0
"#;

fn fresh_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("demcal-study-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn write_study(dir: &Path, text: &str) -> PathBuf {
    let p = dir.join("study.toml");
    std::fs::write(&p, text).unwrap();
    p
}

fn run(path: &Path, jobs: usize) -> Result<String, String> {
    study::run(
        path,
        &RunOptions {
            jobs,
            ..Default::default()
        },
        Arc::new(AtomicBool::new(false)),
    )
}

fn summary(dir: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(dir.join("report/summary.json")).unwrap())
        .unwrap()
}

#[test]
fn the_plan_recovers_a_known_optimum_and_keeps_failed_runs() {
    let dir = fresh_dir("bowl");
    let path = write_study(&dir, BOWL);
    let out = run(&path, 2).unwrap();
    assert!(out.contains("state: complete"), "{out}");
    let s = summary(&dir);
    let cal = &s["calibrated"];
    let (a, b) = (cal["a"].as_f64().unwrap(), cal["b"].as_f64().unwrap());
    assert!(
        (a - 0.6).abs() < 0.02 && (b - 0.3).abs() < 0.02,
        "a = {a}, b = {b}"
    );
    // Screening drops c and d and holds them at the middle of their ranges.
    assert_eq!(s["stages"][0]["selected"], serde_json::json!(["a", "b"]));
    assert_eq!(cal["c"].as_f64().unwrap(), 0.5);
    assert_eq!(cal["d"].as_f64().unwrap(), 0.5);
    let err = s["relative_error_percent"].as_f64().unwrap();
    assert!(err < 0.3, "validation error {err} %");
    assert_eq!(s["validation_runs"], 3);
    // The screening runs with c and d high failed, were stored with the reason, and the stage
    // went on with the others.
    assert_eq!(s["stages"][0]["failed"], 3);
    assert_eq!(s["runs_failed"], 3);
    let csv = std::fs::read_to_string(dir.join("report/results.csv")).unwrap();
    assert_eq!(csv.lines().count(), 1 + 13 + 5 + 13 + 3);
    assert_eq!(csv.matches("fail_when").count(), 3);
    let html = std::fs::read_to_string(dir.join("report/index.html")).unwrap();
    for part in [
        "Pareto chart",
        "Steepest path",
        "contours",
        "Reduced model",
        "Validation",
        "failed: ",
    ] {
        assert!(html.contains(part), "report lacks {part}");
    }
    // A second run changes nothing and simulates nothing.
    let csv_before = csv.clone();
    let again = run(&path, 2).unwrap();
    assert!(again.contains("state: complete"));
    assert_eq!(
        std::fs::read_to_string(dir.join("report/results.csv")).unwrap(),
        csv_before
    );
    // Status replays without running.
    let st = study::status(&path).unwrap();
    assert!(st.contains("13 runs: 10 done, 3 failed, 0 pending"), "{st}");
    assert!(st.contains("calibrated: a = "), "{st}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn too_many_failures_stop_the_stage_with_the_reason() {
    let dir = fresh_dir("fail");
    let path = write_study(
        &dir,
        &BOWL.replace("fail_when = \"c + d - 1.7\"", "fail_when = \"c - 0.3\""),
    );
    let e = run(&path, 1).unwrap_err();
    assert!(
        e.contains("stage 1 (screening): 7 of 13 runs failed") && e.contains("fail_when"),
        "{e}"
    );
    // With every run failing, the stage says how many it needed.
    let path = write_study(
        &dir,
        &BOWL.replace("fail_when = \"c + d - 1.7\"", "fail_when = \"1\""),
    );
    std::fs::remove_file(dir.join("study.db")).unwrap();
    let e = run(&path, 1).unwrap_err();
    assert!(
        e.contains("0 of 13 runs finished (13 failed") && e.contains("needs at least 6"),
        "{e}"
    );
    // The failures are stored; status says the study stopped.
    let st = study::status(&path).unwrap();
    assert!(st.contains("state: stopped"), "{st}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_changed_study_is_noticed_before_stored_runs_are_reused() {
    let dir = fresh_dir("changed");
    let path = write_study(&dir, BOWL);
    run(&path, 2).unwrap();
    write_study(
        &dir,
        &BOWL.replace("min = 0.4\nmax = 1.2", "min = 0.45\nmax = 1.2"),
    );
    let e = run(&path, 2).unwrap_err();
    assert!(
        e.contains("no longer match") && e.contains("a = ") && e.contains("--restart"),
        "{e}"
    );
    // A changed fixed setting of the test is noticed too.
    write_study(&dir, &BOWL.replace("noise = 0.02", "noise = 0.05"));
    let e = study::status(&path).unwrap_err();
    assert!(e.contains("other test settings"), "{e}");
    // Only the target changed: screening and steepest runs are still valid, so nothing is
    // reported for them, and --restart starts over keeping the old store aside.
    let out = study::run(
        &path,
        &RunOptions {
            jobs: 2,
            restart: true,
            ..Default::default()
        },
        Arc::new(AtomicBool::new(false)),
    )
    .unwrap();
    assert!(out.contains("state: complete"));
    let kept = std::fs::read_dir(&dir)
        .unwrap()
        .filter(|e| {
            e.as_ref()
                .unwrap()
                .file_name()
                .to_string_lossy()
                .contains(".db.old-")
        })
        .count();
    assert_eq!(kept, 1);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Each broken study gives one line naming the file and the key.
#[test]
fn invalid_study_files_name_the_key() {
    let dir = fresh_dir("invalid");
    let cases: Vec<(String, &str)> = vec![
        (
            BOWL.replace("\"optimize\", \"validate\"]", "\"optimise\", \"validate\"]"),
            "plan[3].stage: unknown stage \"optimise\"",
        ),
        (
            BOWL.replace(
                "path = \"function.variables.b\"",
                "path = \"function.variable.b\"",
            ),
            "parameter[1].path: \"function.variable.b\": the test has no \"function.variable\"",
        ),
        (
            BOWL.replace("min = 0.1\nmax = 0.9", "min = 0.9\nmax = 0.9"),
            "parameter[1].min: expected min < max, got min = 0.9 and max = 0.9",
        ),
        (
            BOWL.replace("[target]\nvalue = 30.0\n", ""),
            "target: missing",
        ),
        (
            BOWL.replace("[target]\nvalue = 30.0", "[target]\nunit = \"deg\""),
            "target.value: missing",
        ),
        (
            BOWL.replace(
                "[target]\nvalue = 30.0",
                "[target]\nvalue = 30.0\nresponse = \"angle\"",
            ),
            "target.response: \"angle\" is not an outcome of function",
        ),
        (
            BOWL.replace(
                "plan = [\"screening\", \"steepest\"",
                "plan = [\"steepest\"",
            ),
            "plan[0]: steepest follows the effects of a screening stage",
        ),
        (
            BOWL.replace(
                "plan = [\"screening\",",
                "plan = [{ stage = \"screening\", alpha = 2 },",
            ),
            "plan[0].alpha: expected a number between 0 and 1",
        ),
        (
            BOWL.replace(
                "name = \"d\"\npath = \"function.variables.d\"",
                "name = \"d\"\npath = \"function.variables.d\"\nscale = \"log\"",
            ),
            "parameter[3].min: a log-scale parameter needs min > 0",
        ),
        (
            BOWL.replace("seed = 3", "seed = 3\njobs = 2"),
            "jobs: unknown key",
        ),
    ];
    for (text, expected) in cases {
        let path = write_study(&dir, &text);
        let e = Study::load(&path).unwrap_err();
        assert!(e.contains(expected), "expected '{expected}' in: {e}");
        assert!(e.starts_with(&path.display().to_string()), "{e}");
        assert!(!e.contains('\n'), "one line: {e}");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn runs_over_the_time_limit_fail_and_an_interrupt_stores_nothing() {
    let dir = fresh_dir("limits");
    let text = BOWL
        .replace(
            "plan = [\"screening\", \"steepest\", \"rsm\", \"optimize\", \"validate\"]",
            "plan = [{ stage = \"validate\", replicates = 2 }]\nrun_time_limit_s = 0.05",
        )
        .replace("noise = 0.02", "noise = 0.02\nduration_s = 5.0");
    let path = write_study(&dir, &text);
    // Ctrl-C before anything ran: nothing is stored, and the message says how to go on.
    let e = study::run(
        &path,
        &RunOptions {
            jobs: 2,
            ..Default::default()
        },
        Arc::new(AtomicBool::new(true)),
    )
    .unwrap_err();
    assert!(e.contains("interrupted: 0 finished runs"), "{e}");
    assert!(study::status(&path)
        .unwrap()
        .contains("2 runs: 0 done, 0 failed, 2 pending"));
    // Each run passes its 0.05 s limit long before its 5 s are up and is stored as failed.
    let t = std::time::Instant::now();
    let e = run(&path, 2).unwrap_err();
    assert!(t.elapsed().as_secs_f64() < 2.0);
    assert!(
        e.contains("run_time_limit_s = 0.05 s") && e.contains("validation needs at least 1"),
        "{e}"
    );
    assert!(study::status(&path)
        .unwrap()
        .contains("2 runs: 0 done, 2 failed, 0 pending"));
    std::fs::remove_dir_all(&dir).unwrap();
}
