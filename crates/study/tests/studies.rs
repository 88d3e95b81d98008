//! Whole studies on the `function` test: the plan recovers a known optimum, failed runs are kept
//! with their reason, too many failures stop the study with a clear message, and a changed study
//! is noticed before stored runs are reused.

use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::sync::Arc;
use test_support::summary;

use study::{RunOptions, Study};

mod common;
use common::{run_path as run, write_study};

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
    test_support::fresh_dir("study", name)
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
    // A fail_when stands for a simulation that blew up: stored as diverged.
    assert_eq!(csv.matches(",diverged,").count(), 3);
    let html = std::fs::read_to_string(dir.join("report/index.html")).unwrap();
    for part in [
        "Pareto chart",
        "Steepest path",
        "contours",
        "Reduced model",
        "Validation",
        "failed (",
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
        // Read through serde (`study::file`): its messages in the same words.
        (
            BOWL.replace(
                "path = \"function.variables.b\"",
                "path = \"function.variables.a\"",
            ),
            "parameter[1].path: \"function.variables.a\" is also where parameter[0] (\"a\") goes",
        ),
        // Each at its maximum, both together ran silent for minutes (issue 40).
        (
            BOWL.replace(
                "plan = [\"screening\", \"steepest\", \"rsm\", \"optimize\", \"validate\"]",
                "plan = [\"rsm\", { stage = \"ga_bp\", generations = 100000, population = 100000 }]",
            ),
            "plan[1].population: generations × population = 100000 × 100000 evaluations, at most 1000000",
        ),
        (
            BOWL.replace("name = \"d\"", &format!("name = \"{}\"", "d".repeat(1_000_000))),
            "parameter[3].name: expected 1 to 100 characters, got 1000000",
        ),
        (
            BOWL.replace("seed = 3", "seed = -3"),
            "seed: expected a whole number >= 0, got -3",
        ),
        (
            BOWL.replace("min = 0.1\nmax = 0.9", "minimum = 0.1\nmax = 0.9"),
            "parameter[1].minimum: unknown key (expected name, path, paths, min, max, scale, unit, label, symbol)",
        ),
        (
            BOWL.replace("min = 0.1\nmax = 0.9", "max = 0.9"),
            "parameter[1].min: missing",
        ),
        (
            BOWL.replace("min = 0.1\nmax = 0.9", "min = true\nmax = 0.9"),
            "parameter[1].min: expected a number, or a string with a unit such as \"3 mm\", got boolean true",
        ),
        (
            BOWL.replace(
                "name = \"d\"\npath = \"function.variables.d\"",
                "name = \"d\"\npath = \"function.variables.d\"\nscale = \"logarithmic\"",
            ),
            "parameter[3].scale: expected \"linear\" or \"log\", got \"logarithmic\"",
        ),
        (
            BOWL.replace("[target]\nvalue = 30.0", "[target]\nvalue = \"thirty\""),
            "target.value: expected a number, got string \"thirty\"",
        ),
        (
            BOWL.replace("[target]\nvalue = 30.0", "[target]\nvalu = 30.0"),
            "target.valu: unknown key (expected response, value, replicates, unit, test, weight, importance, low, high, curve, lab_curves, normalisation, area_m2, length_m)",
        ),
        (
            BOWL.replace(
                "plan = [\"screening\",",
                "plan = [{ stage = \"screening\", center_points = 1000000000 },",
            ),
            "plan[0].center_points: expected a whole number from 0 to 1000",
        ),
        (
            BOWL.replace(
                "\"optimize\", \"validate\"]",
                "\"optimize\", { stage = \"validate\", replicates = 1000000000 }]",
            ),
            "plan[4].replicates: expected a whole number from 1 to 1000",
        ),
        (
            BOWL.replace(
                "\"optimize\", \"validate\"]",
                "{ stage = \"optimize\", starts = 100000000 }, \"validate\"]",
            ),
            "plan[3].starts: expected a whole number from 1 to 10000",
        ),
        (
            BOWL.replace(
                "\"steepest\", \"rsm\"",
                "{ stage = \"steepest\", steps = 100000000 }, \"rsm\"",
            ),
            "plan[1].steps: expected a whole number from 3 to 1000",
        ),
        (
            BOWL.replace("\"rsm\",", "{ stage = \"rsm\", alpha = \"nan\" },"),
            "plan[2].alpha: \"nan\": expected rotatable, face, spherical, orthogonal or a positive number",
        ),
        (
            BOWL.replace("\"rsm\",", "{ stage = \"rsm\", alpha = inf },"),
            "plan[2].alpha: inf: expected rotatable, face, spherical, orthogonal or a positive number",
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
    // Typed, so that the command line exits 130 and a script can tell it from a failure.
    assert!(matches!(e, study::RunStudyError::Interrupted(_)), "{e:?}");
    assert!(
        e.to_string().contains("interrupted: 0 finished runs"),
        "{e}"
    );
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
    // Stored with their kind, which the results table carries too.
    let stored = study::Store::open(&dir.join("study.db"), false)
        .unwrap()
        .runs()
        .unwrap();
    assert!(stored
        .iter()
        .all(|r| r.error_kind == Some(study::RunErrorKind::TimeLimit)));
    let csv = std::fs::read_to_string(dir.join("report/results.csv")).unwrap();
    assert_eq!(csv.matches(",time_limit,").count(), 2, "{csv}");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The quickstart study read with another plan (its test file sits beside it).
fn quickstart_with_plan(plan: &str) -> Study {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/quickstart/study.toml");
    let text = std::fs::read_to_string(&path).unwrap().replace(
        "plan = [\"screening\", \"steepest\", \"rsm\", \"optimize\", \"validate\"]",
        plan,
    );
    Study::parse(&path, &text).unwrap()
}

/// An rsm stage without a steepest path before it starts from the parameters' whole ranges: a
/// rotatable CCD of four factors (alpha 2) must shrink every range to a quarter each side of the
/// middle so that its axial points land on min and max (this used to panic in a clamp).
#[test]
fn rsm_first_shrinks_the_region_to_keep_axial_points_inside() {
    let study = quickstart_with_plan("plan = [\"rsm\"]");
    let r = study::replay(&study, &[], None).unwrap();
    assert_eq!(r.state, study::State::Pending { stage: 0 });
    let st = &r.stages[0];
    assert_eq!(st.runs.len(), 16 + 8 + 6);
    let want = [(0.35, 0.65), (0.065, 0.155), (0.3, 0.5), (0.4, 0.6)];
    for (f, (lo, hi)) in st.factors.iter().zip(want) {
        assert!(
            (f.low - lo).abs() < 1e-12 && (f.high - hi).abs() < 1e-12,
            "{}: {} .. {}",
            f.name,
            f.low,
            f.high
        );
    }
    // Every run stays within min .. max, and the axial points reach both ends.
    for (j, p) in study.parameters.iter().enumerate() {
        let v: Vec<f64> = st.runs.iter().map(|s| s.values[j]).collect();
        let lo = v.iter().cloned().fold(f64::MAX, f64::min);
        let hi = v.iter().cloned().fold(f64::MIN, f64::max);
        assert!(
            (lo - p.min).abs() < 1e-12 && (hi - p.max).abs() < 1e-12,
            "{}: {lo} .. {hi}",
            p.name
        );
    }
    assert_eq!(st.notes.len(), 4, "{:?}", st.notes);
    assert_eq!(
        st.notes[0],
        "static_friction: the design's axial points (coded −2.000 and +2.000) would leave 0.2000 .. 0.8000; its coded range −1 to +1 is now 0.3500 .. 0.6500"
    );
}

/// The same plan end to end on the bowl: rsm over the whole ranges, then the optimum.
#[test]
fn a_plan_starting_with_rsm_finds_the_optimum() {
    let dir = fresh_dir("rsm-first");
    let path = write_study(
        &dir,
        &BOWL
            .replace(
                "plan = [\"screening\", \"steepest\", \"rsm\", \"optimize\", \"validate\"]",
                "plan = [{ stage = \"rsm\", design = \"ccd\", alpha = 1.5 }, \"optimize\", \"validate\"]",
            )
            .replace("fail_when = \"c + d - 1.7\"", ""),
    );
    let out = run(&path, 2).unwrap();
    assert!(out.contains("state: complete"), "{out}");
    let s = summary(&dir);
    let (a, b) = (
        s["calibrated"]["a"].as_f64().unwrap(),
        s["calibrated"]["b"].as_f64().unwrap(),
    );
    assert!(
        (a - 0.6).abs() < 0.05 && (b - 0.3).abs() < 0.05,
        "a = {a}, b = {b}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A steepest path along the coefficients leaves a parameter without effect where it was: the
/// next stage keeps its range instead of a range of nothing (this used to panic in
/// `Parameter::factor`).
#[test]
fn a_parameter_the_path_does_not_move_keeps_its_range() {
    let dir = fresh_dir("unmoved");
    let text = BOWL
        .replace(
            "plan = [\"screening\", \"steepest\", \"rsm\", \"optimize\", \"validate\"]",
            "plan = [{ stage = \"screening\", min_factors = 4 }, { stage = \"steepest\", direction = \"coefficients\" }, { stage = \"rsm\", design = \"ccd\", alpha = \"face\" }]",
        )
        .replace("fail_when = \"c + d - 1.7\"", "")
        .replace("noise = 0.02", "noise = 0.0")
        // d has no effect at all: its coefficient is zero up to rounding.
        .replace(" + 0.01*d\"", "\"");
    let path = write_study(&dir, &text);
    let out = run(&path, 2).unwrap();
    assert!(out.contains("state: complete"), "{out}");
    let study = Study::load(&path).unwrap();
    let stored = study::Store::open(&study.store_path(), false)
        .unwrap()
        .runs()
        .unwrap();
    let r = study::replay(&study, &stored, None).unwrap();
    let d = &r.stages[2].factors[3];
    assert_eq!((d.name.as_str(), d.low, d.high), ("d", 0.0, 1.0));
    assert!(
        r.stages[1]
            .notes
            .iter()
            .any(|n| n.starts_with("d: the path does not move it")),
        "{:?}",
        r.stages[1].notes
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A range too narrow to tell its ends apart once values are kept to 12 significant digits is
/// refused when the study is read.
#[test]
fn a_range_narrower_than_the_stored_digits_is_refused() {
    let dir = fresh_dir("narrow");
    let path = write_study(
        &dir,
        &BOWL.replace("min = 0.0\nmax = 1.0", "min = 1.0\nmax = 1.000000000001"),
    );
    let e = Study::load(&path).unwrap_err();
    assert_eq!(
        e,
        format!(
            "{}: parameter[2].max: the range 1 .. 1.000000000001 is too narrow: values are kept to 12 significant digits, so give a range wider than a millionth of its values",
            path.display()
        )
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

/// An executor that hands back a run the stage never asked for.
struct WrongRuns;

impl study::stages::Execute for WrongRuns {
    fn execute(
        &mut self,
        study: &Study,
        stage: &study::stages::StageResult,
        runs: &[study::stages::RunSpec],
    ) -> Result<Vec<study::store::RunRecord>, String> {
        let spec = &runs[0];
        Ok(vec![study::store::RunRecord {
            stage: stage.index,
            stage_kind: stage.kind.into(),
            index: stage.runs.len() + 5,
            inputs: spec.inputs(study),
            seed: spec.seed,
            status: study::store::Status::Done,
            response: Some(1.0),
            outputs: serde_json::Value::Null,
            error: None,
            error_kind: None,
            wall_s: 0.0,
            finished_at: String::new(),
            version: String::new(),
            out_dir: String::new(),
            fingerprint: spec.fingerprint(study),
            host: String::new(),
            executor: String::new(),
        }])
    }
}

#[test]
fn an_executor_returning_other_runs_is_an_error() {
    let dir = fresh_dir("executor");
    let path = write_study(
        &dir,
        &BOWL.replace(
            "plan = [\"screening\", \"steepest\", \"rsm\", \"optimize\", \"validate\"]",
            "plan = [{ stage = \"validate\", replicates = 2 }]",
        ),
    );
    let study = Study::load(&path).unwrap();
    let e = study::replay(&study, &[], Some(&mut WrongRuns))
        .err()
        .expect("an error, not a replay");
    assert_eq!(
        e,
        "stage 1 (validate): the executor returned run 8, which the stage does not have (it has runs 1 to 2)"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Stored runs marked done without a response (a store written by hand or by another version)
/// do not count as results: validation stops saying so rather than reporting NaN.
#[test]
fn done_runs_without_a_response_do_not_count() {
    let dir = fresh_dir("no-response");
    let path = write_study(
        &dir,
        &BOWL.replace(
            "plan = [\"screening\", \"steepest\", \"rsm\", \"optimize\", \"validate\"]",
            "plan = [{ stage = \"validate\", replicates = 2 }]",
        ),
    );
    let study = Study::load(&path).unwrap();
    let pending = study::replay(&study, &[], None).unwrap();
    let stored: Vec<study::store::RunRecord> = pending.stages[0]
        .runs
        .iter()
        .map(|spec| study::store::RunRecord {
            stage: 0,
            stage_kind: "validate".into(),
            index: spec.index,
            inputs: spec.inputs(&study),
            seed: spec.seed,
            status: study::store::Status::Done,
            response: None,
            outputs: serde_json::Value::Null,
            error: None,
            error_kind: None,
            wall_s: 0.0,
            finished_at: String::new(),
            version: String::new(),
            out_dir: String::new(),
            fingerprint: spec.fingerprint(&study),
            host: String::new(),
            executor: String::new(),
        })
        .collect();
    let r = study::replay(&study, &stored, None).unwrap();
    assert!(r.stages[0].validation().is_none());
    match &r.state {
        study::State::Stopped(why) => assert!(
            why.starts_with("stage 1 (validate): 0 of 2 runs finished with a response")
                && why.contains("validation needs at least 1"),
            "{why}"
        ),
        s => panic!("expected a stop, got {s:?}"),
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// One `demcal run` at a time per study: the store's lock names the process holding it, is let
/// go when the run ends, and a lock left by a process that no longer exists is taken over.
#[test]
fn the_store_is_locked_while_a_study_runs() {
    let dir = fresh_dir("lock");
    let path = write_study(
        &dir,
        &BOWL.replace(
            "plan = [\"screening\", \"steepest\", \"rsm\", \"optimize\", \"validate\"]",
            "plan = [{ stage = \"validate\", replicates = 2 }]",
        ),
    );
    let db = dir.join("study.db");
    let lock_file = dir.join("study.db.lock");
    let held = study::store::StoreLock::acquire(&db).unwrap();
    assert_eq!(
        std::fs::read_to_string(&lock_file).unwrap().lines().next(),
        Some(std::process::id().to_string().as_str())
    );
    let busy = format!(
        "{}: the study is being run by process {} (lock file {}); wait for it to end, or stop it",
        db.display(),
        std::process::id(),
        lock_file.display()
    );
    assert_eq!(
        study::store::StoreLock::acquire(&db).unwrap_err(),
        study::LockError::Held(busy.clone())
    );
    // `demcal run` takes the same lock before anything else; nothing is stored.
    assert_eq!(run(&path, 1).unwrap_err(), busy);
    assert!(!db.exists());
    drop(held);
    assert!(!lock_file.exists());
    run(&path, 1).unwrap();
    assert!(!lock_file.exists());
    // A lock whose process has ended (killed, power cut) is stale and taken over.
    let mut gone = std::process::Command::new("true").spawn().unwrap();
    let pid = gone.id();
    gone.wait().unwrap();
    std::fs::write(&lock_file, format!("{pid}\n")).unwrap();
    let lock = study::store::StoreLock::acquire(&db).unwrap();
    assert_eq!(
        std::fs::read_to_string(&lock_file).unwrap().lines().next(),
        Some(std::process::id().to_string().as_str())
    );
    drop(lock);
    // A lock taken on another machine (a login node sharing the file system) is never taken
    // over from here: its process cannot be checked.
    std::fs::write(&lock_file, format!("{pid}\nanother-login-node\n")).unwrap();
    assert_eq!(
        study::store::StoreLock::acquire(&db).unwrap_err(),
        study::LockError::Held(format!(
            "{}: the study is being run by process {pid} on another-login-node (lock file {}); stop it there, or if it no longer runs, remove that file",
            db.display(),
            lock_file.display()
        ))
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A store cut to no bytes is refused with what happened and how to go on, not taken as new
/// (every run silently redone); --restart moves it aside.
#[test]
fn an_empty_store_is_refused_and_restart_moves_it_aside() {
    let dir = fresh_dir("empty-store");
    let path = write_study(
        &dir,
        &BOWL.replace(
            "plan = [\"screening\", \"steepest\", \"rsm\", \"optimize\", \"validate\"]",
            "plan = [{ stage = \"validate\", replicates = 2 }]",
        ),
    );
    std::fs::write(dir.join("study.db"), "").unwrap();
    let e = run(&path, 1).unwrap_err();
    assert!(
        e.contains("study.db: the results store is empty (0 bytes)") && e.contains("--restart"),
        "{e}"
    );
    let out = study::run(
        &path,
        &RunOptions {
            jobs: 1,
            restart: true,
            ..Default::default()
        },
        Arc::new(AtomicBool::new(false)),
    )
    .unwrap();
    assert!(out.contains("state: complete"), "{out}");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The CCD's axial distance is read once into its typed form: a name, a number or a number
/// written as text.
#[test]
fn the_ccd_alpha_is_typed_when_read() {
    use doe::design::CcdAlpha;
    use study::plan::RsmDesign;
    use study::stage::rsm::Rsm;
    let dir = fresh_dir("alpha");
    for (given, want) in [
        ("\"rotatable\"", CcdAlpha::Rotatable),
        ("\"Face\"", CcdAlpha::FaceCentred),
        ("1.5", CcdAlpha::Custom(1.5)),
        ("\"1.25\"", CcdAlpha::Custom(1.25)),
        ("2", CcdAlpha::Custom(2.0)),
    ] {
        let path = write_study(
            &dir,
            &BOWL.replace(
                "\"rsm\",",
                &format!("{{ stage = \"rsm\", alpha = {given} }},"),
            ),
        );
        let s = Study::load(&path).unwrap();
        match s.plan[2].as_any().downcast_ref::<Rsm>() {
            Some(Rsm {
                design: RsmDesign::CentralComposite { alpha },
                ..
            }) => assert_eq!(*alpha, want, "{given}"),
            other => panic!("{other:?}"),
        }
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A range the test would refuse is found when the study is read, naming the parameter and the
/// end, before any run (issue 11: a restitution up to 1.6 used to fail six simulations first).
#[test]
fn a_range_the_test_refuses_is_found_before_the_first_run() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/quickstart/study.toml");
    let text = std::fs::read_to_string(&path).unwrap();
    let bad = text.replacen("min = 0.2\nmax = 0.6", "min = 0.2\nmax = 1.6", 1);
    assert_ne!(bad, text);
    let e = Study::parse(&path, &bad).unwrap_err();
    assert!(
        e.contains("parameter[2].max: restitution = 1.6 is refused by the test:")
            && e.contains("restitution: expected a value in (0, 1], got 1.6"),
        "{e}"
    );
    assert_eq!(e.lines().count(), 1, "{e}");
    let bad = text.replacen("min = 0.3\nmax = 0.7", "min = -0.5\nmax = 0.7", 1);
    let e = Study::parse(&path, &bad).unwrap_err();
    assert!(
        e.contains("parameter[3].min: wall_friction = -0.5 is refused by the test:")
            && e.contains("static_friction: expected a number >= 0, got -0.5"),
        "{e}"
    );
}

/// `check_scene` builds the first run's scene (particles placed, overlaps checked) without
/// simulating: a test whose particles cannot fit its cylinder fails before a store exists.
#[test]
fn the_scene_is_built_before_a_study_runs() {
    let quick = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/quickstart");
    let dir = fresh_dir("scene-check");
    let repose = std::fs::read_to_string(quick.join("repose.toml"))
        .unwrap()
        .replace("fill = { count = 500 }", "fill = { count = 500000 }");
    std::fs::write(dir.join("repose.toml"), repose).unwrap();
    let study = std::fs::read_to_string(quick.join("study.toml")).unwrap();
    let path = write_study(&dir, &study);
    let s = Study::load(&path).unwrap();
    let e = s.check_scene().unwrap_err();
    assert!(e.contains("angle_of_repose.fill"), "{e}");
    let t = std::time::Instant::now();
    let e2 = run(&path, 1).unwrap_err();
    assert_eq!(e, e2);
    assert!(t.elapsed().as_secs_f64() < 30.0);
    assert!(!dir.join("study.db").exists(), "nothing stored");
    // The quickstart itself builds.
    Study::load(&quick.join("study.toml"))
        .unwrap()
        .check_scene()
        .unwrap();
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A validation of several candidates replicates each of the optimisation's best solutions (all
/// their runs go to the executor at once) and calibrates the one whose runs come nearest the lab
/// value.
#[test]
fn a_validation_of_several_candidates_calibrates_the_nearest() {
    let dir = fresh_dir("candidates");
    let path = write_study(
        &dir,
        &BOWL
            .replace(
                "plan = [\"screening\", \"steepest\", \"rsm\", \"optimize\", \"validate\"]",
                "plan = [{ stage = \"rsm\", design = \"ccd\", alpha = 1.5 }, { stage = \"optimize\", solutions = 3 }, { stage = \"validate\", replicates = 2, candidates = 3 }, { stage = \"validate\", replicates = 2, candidates = 3 }]",
            )
            .replace("fail_when = \"c + d - 1.7\"", ""),
    );
    let out = run(&path, 2).unwrap();
    assert!(out.contains("state: complete"), "{out}");
    let study = Study::load(&path).unwrap();
    let stored = study::store::Store::open(&study.store_path(), false)
        .unwrap()
        .runs()
        .unwrap();
    let r = study::replay(&study, &stored, None).unwrap();
    let optimum = &r.stages[1];
    let validation = &r.stages[2];
    assert_eq!(optimum.solutions().len(), 3);
    assert_eq!(validation.runs.len(), 6);
    assert_eq!(validation.runs[3].label, "solution 2 replicate 2");
    // Each candidate's mean, the one nearest 30 chosen, and its point calibrated.
    let means: Vec<f64> = (0..3)
        .map(|c| {
            let ys: Vec<f64> = validation
                .records
                .iter()
                .skip(2 * c)
                .take(2)
                .map(|r| r.as_ref().unwrap().response.unwrap())
                .collect();
            (ys[0] + ys[1]) / 2.0
        })
        .collect();
    let chosen = (0..3)
        .min_by(|&a, &b| (means[a] - 30.0).abs().total_cmp(&(means[b] - 30.0).abs()))
        .unwrap();
    let v = validation.validation().unwrap();
    assert_eq!(v.runs, 2);
    assert!(
        (v.mean - means[chosen]).abs() < 1e-12,
        "{} vs {means:?}",
        v.mean
    );
    assert_eq!(
        validation.calibrated.as_ref(),
        Some(&validation.runs[2 * chosen].values)
    );
    let verdict = format!(
        "solution {} validates nearest the lab value: it is the calibrated point",
        chosen + 1
    );
    assert!(
        validation.notes.contains(&verdict),
        "{:?}",
        validation.notes
    );
    assert!(
        validation.notes[0].starts_with("solution 1: value = "),
        "{:?}",
        validation.notes
    );
    let s = summary(&dir);
    let a = s["calibrated"]["a"].as_f64().unwrap();
    let a_index = study.parameters.iter().position(|p| p.name == "a").unwrap();
    assert_eq!(s["validation_solution"], serde_json::json!(chosen + 1));
    // A second validation replicates the chosen point alone, with new seeds, and says why.
    let again = &r.stages[3];
    assert_eq!(again.runs.len(), 2);
    assert!(again
        .runs
        .iter()
        .all(|s| s.values == validation.runs[2 * chosen].values));
    assert_ne!(again.runs[0].seed, validation.runs[0].seed);
    assert!(
        again.notes[0].contains("no optimisation since the last validation"),
        "{:?}",
        again.notes
    );
    assert_eq!(a, validation.runs[2 * chosen].values[a_index]);
    assert_eq!(s["validation_runs"], 2);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A bonded bar pulled with so much density scaling that its inertia shows: the run finishes,
/// but a study stores it as failed, not quasi-static, with the reason (issue 37).
#[test]
fn a_run_that_is_not_quasi_static_is_stored_as_failed() {
    let dir = fresh_dir("inertia");
    let bar = test_support::bonded_bar_tension("density_scaling = 1e7", "");
    std::fs::write(dir.join("bar.toml"), bar).unwrap();
    let path = write_study(
        &dir,
        r#"name = "inertia"
seed = 1
test = "bar.toml"
plan = [{ stage = "validate", replicates = 1 }]

[[parameter]]
name = "k_n"
path = "bond[stalk,stalk].normal_stiffness"
min = 0.9e9
max = 1.1e9

[target]
response = "peak_force_n"
value = 6.0
"#,
    );
    let e = run(&path, 1).unwrap_err();
    assert!(e.contains("not quasi-static"), "{e}");
    let stored = study::Store::open(&dir.join("study.db"), false)
        .unwrap()
        .runs()
        .unwrap();
    assert_eq!(stored.len(), 1);
    assert_eq!(
        stored[0].error_kind,
        Some(study::RunErrorKind::NotQuasiStatic)
    );
    let csv = std::fs::read_to_string(dir.join("report/results.csv")).unwrap();
    assert_eq!(csv.matches(",not_quasi_static,").count(), 1, "{csv}");
    std::fs::remove_dir_all(&dir).unwrap();
}
