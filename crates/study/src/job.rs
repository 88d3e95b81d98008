//! A run as a self-contained unit of work: [`Job`] carries everything one simulation of a study
//! needs (the test with the run's values written in, the seed, where to write, the response to
//! read, the time limit) and serialises to JSON. The local executor runs jobs in threads;
//! `demcal run-one JOB.json` runs one in its own process and writes its [`RunRecord`] as JSON,
//! which is the seam a cluster executor uses: write job files, run them anywhere, read the records
//! back and store them.
//!
//! A run that does not give a number ends in a typed [`RunError`]; its kind is stored with the
//! message, so reports and a retry policy can tell a diverged simulation from a bad setting.

use std::panic::AssertUnwindSafe;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use serde::{Deserialize, Serialize};

use crate::curve::Comparison;
use crate::record::RunSpec;
use crate::run_error::{RunError, RunErrorKind};
use crate::spec::{Combine, Study, Term};
use crate::store::{now_utc, RunRecord, Status};

/// The folder a run writes its pictures and result into: `<study>.runs/stageN-kind/runNNN`.
pub fn run_dir(study: &Study, spec: &RunSpec) -> PathBuf {
    study
        .runs_dir()
        .join(format!("stage{}-{}", spec.stage + 1, spec.stage_kind))
        .join(format!("run{:03}", spec.index + 1))
}

/// Whether `dir` is a run folder (`run` and digits, no `..` in the path): the only kind of
/// folder a job clears before it runs, so a job file cannot point it at anything else.
fn is_run_dir(dir: &Path) -> bool {
    let name = dir.file_name().and_then(|n| n.to_str()).unwrap_or("");
    name.len() > 3
        && name.starts_with("run")
        && name[3..].bytes().all(|b| b.is_ascii_digit())
        && !dir
            .components()
            .any(|c| matches!(c, std::path::Component::ParentDir))
}

/// One test of a job: the test file with the run's values written in.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct JobTest {
    /// The test's name in the study (its folder in the run's folder when there are several).
    pub name: String,
    /// Names the test in error messages (its file, or the study's inline `[test]`).
    pub label: String,
    /// The test file as TOML, with the run's parameter values written in.
    pub test: toml::Table,
    /// The folder relative paths in the test (STL files) are taken from.
    pub dir: PathBuf,
    pub seed: u64,
    /// The lab curve the test's curve is compared with, when a target is a curve: the run
    /// adds `curve_mse`, `curve_peak`, `curve_mean`, `curve_stiffness` and `curve_simulated`
    /// to the test's outputs.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub curve: Option<Comparison>,
}

/// One run of a study, ready to execute anywhere.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Job {
    /// The tests the run makes, one after another (most studies have one).
    pub tests: Vec<JobTest>,
    /// The run's seed (the first test's; the others' follow from it).
    pub seed: u64,
    pub stage: usize,
    pub stage_kind: String,
    pub index: usize,
    /// What the point is (factorial, centre, axial, step 3, ...).
    pub label: String,
    /// Every parameter's value by name.
    pub inputs: serde_json::Value,
    /// The outcome the study calibrates against: the test's, or the combined objective.
    pub response: String,
    /// With several targets, each target's term and how they make `response`.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub terms: Vec<Term>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub combine: Option<Combine>,
    /// Seconds of wall time after which the run stops and fails.
    pub run_time_limit_s: Option<f64>,
    /// The back end the tests run on; none means the CPU.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub backend: Option<String>,
    /// Where the run writes its pictures and result.
    pub out_dir: PathBuf,
    /// The exact tests and seed; a stored record is reused only while it matches.
    pub fingerprint: String,
}

/// The seed of test `k` of a run with seed `seed`: the run's own for the first test.
pub fn test_seed(seed: u64, k: usize) -> u64 {
    if k == 0 {
        seed
    } else {
        crate::record::run_seed(seed, k, 0)
    }
}

impl Job {
    /// The job for one planned run of `study`.
    pub fn new(study: &Study, spec: &RunSpec) -> Job {
        let tests = study
            .tests
            .iter()
            .enumerate()
            .map(|(k, t)| JobTest {
                name: t.name.clone(),
                label: if t.source == "inline" {
                    study.test_label(k)
                } else {
                    t.source.clone()
                },
                test: study.test_with(k, &spec.values),
                // Absolute, so that `demcal run-one` finds them from any working folder.
                dir: absolute(&t.dir),
                seed: test_seed(spec.seed, k),
                // At most one target of a test has a curve (checked when the study is read).
                curve: study
                    .targets
                    .iter()
                    .filter(|x| x.test == k)
                    .find_map(|x| x.curve.as_ref())
                    .map(|c| c.comparison()),
            })
            .collect();
        Job {
            tests,
            seed: spec.seed,
            stage: spec.stage,
            stage_kind: spec.stage_kind.to_string(),
            index: spec.index,
            label: spec.label.clone(),
            inputs: spec.inputs(study),
            response: study.target.response.clone(),
            terms: if study.combine.is_some() {
                study.terms()
            } else {
                Vec::new()
            },
            combine: study.combine,
            run_time_limit_s: study.run_time_limit_s,
            backend: (study.backend != "cpu").then(|| study.backend.clone()),
            out_dir: absolute(&run_dir(study, spec)),
            fingerprint: spec.fingerprint(study),
        }
    }

    /// Reads a job file; errors name the file and the key.
    pub fn load(path: &Path) -> Result<Job, String> {
        let text = dem::files::read_text(path, dem::files::MAX_TEXT_BYTES)
            .map_err(|e| format!("{}: cannot read the job file: {e}", path.display()))?;
        Job::parse(&path.display().to_string(), &text)
    }

    /// Reads a job file's text; `name` heads the errors.
    pub fn parse(name: &str, text: &str) -> Result<Job, String> {
        let de = &mut serde_json::Deserializer::from_str(text);
        let job: Job = serde_path_to_error::deserialize(&mut *de).map_err(|e| {
            let key = e.path().to_string();
            // A key or a value from the file may hold line breaks.
            virtual_tests::file::one_line(&format!("{name}: {key}: {}", e.into_inner()))
        })?;
        // One job per file: anything after it is a damaged or concatenated file.
        de.end()
            .map_err(|e| format!("{name}: after the job: {e}"))?;
        job.check().map_err(|e| format!("{name}: {e}"))?;
        if !is_run_dir(&job.out_dir) {
            return Err(format!(
                "{name}: out_dir: expected a run folder named run<digits> (it is cleared before the run), got \"{}\"",
                job.out_dir.display()
            ));
        }
        Ok(job)
    }

    /// The tests and targets must make sense together: at least one test, names that are plain
    /// folder names (they are joined onto the run folder), and terms exactly when the targets are
    /// combined, each naming a test the job has.
    fn check(&self) -> Result<(), String> {
        if self.tests.is_empty() {
            return Err("tests: expected at least one test".into());
        }
        // A study has a few stages of at most 100 000 runs each; larger numbers are a damaged
        // file (and would wrap when shown counting from 1).
        if self.stage >= 1000 {
            return Err(format!(
                "stage: expected a stage number below 1000, got {}",
                self.stage
            ));
        }
        if self.index >= 10_000_000 {
            return Err(format!(
                "index: expected a run number below 10000000, got {}",
                self.index
            ));
        }
        for (i, t) in self.tests.iter().enumerate() {
            if t.name.is_empty()
                || !t
                    .name
                    .chars()
                    .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
            {
                return Err(format!(
                    "tests[{i}].name: expected letters, digits, _ and - (it names a folder), got \"{}\"",
                    t.name
                ));
            }
            // The run's outcome keeps each test's under its name.
            if self.tests[..i].iter().any(|u| u.name == t.name) {
                return Err(format!(
                    "tests[{i}].name: \"{}\" names an earlier test too (each test has its own folder and outcome)",
                    t.name
                ));
            }
        }
        match (self.combine, self.terms.is_empty()) {
            (None, false) => return Err("terms: given without combine".into()),
            (Some(_), true) => {
                return Err("terms: missing (combine needs each target's term)".into())
            }
            (None, true) if self.tests.len() > 1 => return Err(
                "combine: missing (a job of several tests scores them by combining its targets)"
                    .into(),
            ),
            _ => {}
        }
        if let Some((i, t)) = self
            .terms
            .iter()
            .enumerate()
            .find(|(_, t)| t.test >= self.tests.len())
        {
            return Err(format!(
                "terms[{i}].test: {} is not a test of the job (it has {})",
                t.test,
                self.tests.len()
            ));
        }
        if let Some(t) = self.run_time_limit_s {
            if !(t > 0.0 && t.is_finite()) {
                return Err(format!("run_time_limit_s: expected seconds > 0, got {t}"));
            }
        }
        if let Some(b) = &self.backend {
            if !dem::sim::BACKEND_NAMES.contains(&b.as_str()) {
                return Err(format!(
                    "backend: expected {}, got \"{b}\"",
                    dem::sim::backend_choices()
                ));
            }
        }
        Ok(())
    }

    /// The job as JSON.
    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).expect("a job is plain data")
    }

    /// Runs the simulation. `None` when `interrupted` stopped it (nothing is to be stored);
    /// otherwise the record, done or failed with its reason. `report` hears the phase and the
    /// simulated time every few hundred steps.
    pub fn execute(
        &self,
        interrupted: &AtomicBool,
        report: &dyn Fn(&str, f64),
    ) -> Option<RunRecord> {
        let start = Instant::now();
        // A run killed before may have left pictures behind; only a run folder is cleared.
        if is_run_dir(&self.out_dir) {
            let _ = std::fs::remove_dir_all(&self.out_dir);
        }
        let result = self.simulate(interrupted, start, report);
        let (status, response, outputs, error) = match result {
            Err((_, e)) if e.kind == RunErrorKind::Interrupted => return None,
            Ok(json) => match json.get(&self.response).and_then(|v| v.as_f64()) {
                Some(y) if y.is_finite() => (Status::Done, Some(y), json, None),
                _ => (
                    Status::Failed,
                    None,
                    json,
                    Some(RunError::new(
                        RunErrorKind::MeasurementFailed,
                        format!("the test gave no finite number for {}", self.response),
                    )),
                ),
            },
            // With several tests, what the tests before the failed one gave is kept.
            Err((kept, e)) => (Status::Failed, None, kept, Some(e)),
        };
        let mut rec = self.record(error, start.elapsed().as_secs_f64());
        rec.status = status;
        rec.response = response;
        rec.outputs = outputs;
        Some(rec)
    }

    /// The run's record, failed with `error` (or, without one, to be filled in), made on this
    /// machine by the local executor; a cluster executor overwrites `executor`.
    pub fn record(&self, error: Option<RunError>, wall_s: f64) -> RunRecord {
        RunRecord {
            stage: self.stage,
            stage_kind: self.stage_kind.clone(),
            index: self.index,
            inputs: self.inputs.clone(),
            seed: self.seed,
            status: Status::Failed,
            response: None,
            outputs: serde_json::Value::Null,
            error_kind: error.as_ref().map(|e| e.kind),
            error: error.map(|e| e.message),
            wall_s,
            finished_at: now_utc(),
            version: env!("CARGO_PKG_VERSION").to_string(),
            out_dir: self.out_dir.display().to_string(),
            fingerprint: self.fingerprint.clone(),
            host: hostname(),
            executor: "local".into(),
        }
    }

    /// Makes every test and, with several targets, scores the run. A failure comes with what
    /// the run gave before it: with several targets, the outcomes of the tests that finished and
    /// each target's row ([`score`]), so that a run whose second test fails keeps its first
    /// test's values; null otherwise.
    fn simulate(
        &self,
        interrupted: &AtomicBool,
        start: Instant,
        report: &dyn Fn(&str, f64),
    ) -> Result<serde_json::Value, (serde_json::Value, RunError)> {
        let null = serde_json::Value::Null;
        if self.tests.is_empty() {
            return Err((
                null,
                RunError::new(RunErrorKind::BadSettings, "the job has no test".to_string()),
            ));
        }
        let several = self.tests.len() > 1;
        let mut outcomes = serde_json::Map::new();
        let mut failed = None;
        for (k, t) in self.tests.iter().enumerate() {
            let dir = if several {
                self.out_dir.join(&t.name)
            } else {
                self.out_dir.clone()
            };
            // Progress names the test a run of several is in ("test heap (2/2): settle").
            let head = format!("test {} ({}/{})", t.name, k + 1, self.tests.len());
            let named = |phase: &str, time: f64| {
                if several {
                    report(&format!("{head}: {phase}"), time);
                } else {
                    report(phase, time);
                }
            };
            if several {
                // The line changes as the test starts, not a few hundred steps into it.
                named("starting", 0.0);
            }
            match self.simulate_test(t, &dir, interrupted, start, &named) {
                Ok(json) => {
                    outcomes.insert(t.name.clone(), json);
                }
                Err(mut e) => {
                    if several && e.kind != RunErrorKind::Interrupted {
                        e.message = format!("test {}: {}", t.name, e.message);
                    }
                    failed = Some(e);
                    break;
                }
            }
        }
        let Some(combine) = self.combine else {
            // One test: `check` refuses several without a combination.
            return match failed {
                Some(e) => Err((null, e)),
                None => Ok(outcomes.into_iter().next().map_or(null, |(_, o)| o)),
            };
        };
        let names: Vec<String> = self.tests.iter().map(|t| t.name.clone()).collect();
        let (out, unscored) = score(&self.response, combine, &self.terms, &names, outcomes);
        match failed.or(unscored) {
            Some(e) => Err((out, e)),
            None => Ok(out),
        }
    }

    fn simulate_test(
        &self,
        t: &JobTest,
        out_dir: &Path,
        interrupted: &AtomicBool,
        start: Instant,
        report: &dyn Fn(&str, f64),
    ) -> Result<serde_json::Value, RunError> {
        let limit = self.run_time_limit_s;
        // Why the progress callback stopped the run, which the test hands back as a plain stop.
        let stopped = std::cell::Cell::new(None::<RunError>);
        let result = std::panic::catch_unwind(AssertUnwindSafe(|| {
            let mut file = virtual_tests::TestFile::from_table_in(&t.label, &t.test, &t.dir)
                .map_err(|e| RunError::new(RunErrorKind::BadSettings, e))?;
            if self.backend.is_some() {
                file.backend.clone_from(&self.backend);
            }
            let mut progress = |phase: &str, time: f64| -> Result<(), String> {
                if interrupted.load(Ordering::Relaxed) {
                    stopped.set(Some(RunError::new(RunErrorKind::Interrupted, "interrupted")));
                    return Err("interrupted".into());
                }
                if let Some(l) = limit {
                    if start.elapsed().as_secs_f64() > l {
                        let why = format!(
                            "stopped: the run took longer than run_time_limit_s = {l} s (in {phase} at t = {time:.3} s)"
                        );
                        stopped.set(Some(RunError::new(RunErrorKind::TimeLimit, why.clone())));
                        return Err(why);
                    }
                }
                report(phase, time);
                Ok(())
            };
            let done = virtual_tests::run_file(&file, Some(t.seed), Some(out_dir), &mut progress)
                .map_err(RunError::from)?;
            if let Some(why) = &done.rejected {
                return Err(RunError::new(
                    RunErrorKind::NotQuasiStatic,
                    format!("{}: {why}", t.label),
                ));
            }
            with_curve(t.curve.as_ref(), done)
        }))
        .unwrap_or_else(|panic| {
            let msg = panic
                .downcast_ref::<String>()
                .cloned()
                .or_else(|| panic.downcast_ref::<&str>().map(|s| s.to_string()))
                .unwrap_or_default();
            Err(RunError::new(
                RunErrorKind::Panic,
                format!("the simulation panicked: {msg}"),
            ))
        });
        match (result, stopped.into_inner()) {
            (Err(_), Some(why)) => Err(why),
            (result, _) => result,
        }
    }
}

/// The outcome of a run with several targets, from its tests' outcomes (by test name): the
/// outcomes under `tests`; each target's row under `targets`, in the order of `terms` (its
/// simulated value, lab value, relative error and desirability, the first and the last two
/// null when its test did not finish or gave no number); and the combined objective under
/// `response` when every target has a number. The error names the first target without one.
///
/// A run just made is scored so, and a stored run again with the targets as they are now
/// ([`rescored`]): each target's value is a simulated one, so a new lab value, weight or limit
/// needs no simulation.
pub(crate) fn score(
    response: &str,
    combine: Combine,
    terms: &[Term],
    test_names: &[String],
    outcomes: serde_json::Map<String, serde_json::Value>,
) -> (serde_json::Value, Option<RunError>) {
    let mut ys = Vec::new();
    let mut rows = Vec::new();
    let mut missing = None;
    for term in terms {
        let test = test_names.get(term.test);
        let outcome = test.and_then(|name| outcomes.get(name));
        let y = outcome
            .and_then(|o| o.get(&term.response))
            .and_then(|v| v.as_f64())
            .filter(|y| y.is_finite());
        if y.is_none() && missing.is_none() {
            missing = Some(match (test, outcome) {
                (None, _) => RunError::new(
                    RunErrorKind::BadSettings,
                    format!(
                        "a target names test {}, the run has {}",
                        term.test + 1,
                        test_names.len()
                    ),
                ),
                (Some(name), None) => RunError::new(
                    RunErrorKind::MeasurementFailed,
                    format!("test {name} did not finish"),
                ),
                (Some(name), Some(_)) => RunError::new(
                    RunErrorKind::MeasurementFailed,
                    format!("test {name} gave no finite number for {}", term.response),
                ),
            });
        }
        rows.push(serde_json::json!({
            "test": test.cloned().unwrap_or_default(),
            "response": term.response,
            "simulated": y,
            "lab": term.lab,
            "relative_error_percent": y.map(|y| 100.0 * term.relative_error(y)),
            "desirability": y.map(|y| term.desirability(y)),
        }));
        ys.extend(y);
    }
    let mut out = serde_json::Map::new();
    if missing.is_none() {
        let objective = combine.combine(terms, &ys);
        if objective.is_finite() {
            out.insert(response.to_string(), serde_json::json!(objective));
        } else {
            missing = Some(RunError::new(
                RunErrorKind::MeasurementFailed,
                format!("the combined objective {response} is {objective}"),
            ));
        }
    }
    out.insert("targets".into(), serde_json::Value::Array(rows));
    out.insert("tests".into(), serde_json::Value::Object(outcomes));
    (serde_json::Value::Object(out), missing)
}

/// A stored run of a study with several targets, scored again from its tests' stored outcomes
/// with the study's targets as they are now (lab values, weights, limits, importance, the
/// combination): the run's fingerprint holds only what was simulated, so such a change keeps
/// the runs and this gives each its new objective, exactly what simulating it again would.
/// A run that failed in a test stays failed (its targets' rows are scored again); a run whose
/// tests all finished is done or failed as its targets now score it. A run of a study with one
/// target takes its response from its test's outcome again (a target may now name another of
/// the test's outcomes); a run stored before its tests' outcomes were kept comes back as it was.
pub fn rescored(study: &Study, mut r: RunRecord) -> RunRecord {
    let Some(combine) = study.combine else {
        // A failed run without an outcome failed in its test.
        if r.outputs.is_object() {
            let response = &study.target.response;
            match r.outputs[response].as_f64().filter(|y| y.is_finite()) {
                Some(y) => {
                    r.status = Status::Done;
                    r.response = Some(y);
                    r.error = None;
                    r.error_kind = None;
                }
                None => {
                    r.status = Status::Failed;
                    r.response = None;
                    r.error = Some(format!("the test gave no finite number for {response}"));
                    r.error_kind = Some(RunErrorKind::MeasurementFailed);
                }
            }
        }
        return r;
    };
    let outcomes = match r.outputs.get_mut("tests") {
        Some(serde_json::Value::Object(m)) => std::mem::take(m),
        _ => return r,
    };
    let names: Vec<String> = study.tests.iter().map(|t| t.name.clone()).collect();
    let finished = names.iter().all(|n| outcomes.contains_key(n));
    let response = study.target.response.as_str();
    let (out, unscored) = score(response, combine, &study.terms(), &names, outcomes);
    if finished {
        match unscored {
            None => {
                r.status = Status::Done;
                r.response = out.get(response).and_then(|v| v.as_f64());
                r.error = None;
                r.error_kind = None;
            }
            Some(e) => {
                r.status = Status::Failed;
                r.response = None;
                r.error = Some(e.message);
                r.error_kind = Some(e.kind);
            }
        }
    }
    r.outputs = out;
    r
}

/// Every stored run [`rescored`]: what the report's tables and files show.
pub fn rescored_all(study: &Study, runs: Vec<RunRecord>) -> Vec<RunRecord> {
    runs.into_iter().map(|r| rescored(study, r)).collect()
}

/// A test's outcome as JSON, with the curve measures added when the study compares a curve. A
/// missing curve, one in other units, or one that does not overlap the lab's is a failed
/// measurement.
fn with_curve(
    cmp: Option<&Comparison>,
    done: virtual_tests::Finished,
) -> Result<serde_json::Value, RunError> {
    {
        let mut json = done.json;
        let Some(cmp) = cmp else {
            return Ok(json);
        };
        let fail = |m: String| RunError::new(RunErrorKind::MeasurementFailed, m);
        let names: Vec<&str> = done.responses.iter().map(|r| r.0).collect();
        let (x, y) = match done.responses.iter().find(|r| r.0 == cmp.curve) {
            Some((
                _,
                virtual_tests::Response::Curve {
                    x,
                    y,
                    x_unit,
                    y_unit,
                    ..
                },
            )) => {
                if x_unit != "m" || y_unit != "N" {
                    return Err(fail(format!(
                        "the test's {} curve is in {x_unit} and {y_unit}; the comparison needs m and N",
                        cmp.curve
                    )));
                }
                (x, y)
            }
            Some(_) => {
                return Err(fail(format!(
                    "the test's {} is a number, not a curve",
                    cmp.curve
                )))
            }
            None => {
                return Err(fail(format!(
                    "the test gave no {} curve (it gave: {})",
                    cmp.curve,
                    names.join(", ")
                )))
            }
        };
        let measures = cmp.evaluate(x, y).map_err(fail)?;
        match &mut json {
            serde_json::Value::Object(m) => m.extend(measures),
            _ => return Err(fail("the test's outcome is not a JSON object".into())),
        }
        Ok(json)
    }
}

/// This machine's name as a run records it: Slurm's name for the node inside a job, else the
/// kernel's.
pub fn hostname() -> String {
    std::env::var("SLURMD_NODENAME")
        .ok()
        .filter(|h| !h.is_empty())
        .unwrap_or_else(crate::store::machine_name)
}

fn absolute(p: &Path) -> PathBuf {
    std::path::absolute(p).unwrap_or_else(|_| p.to_path_buf())
}
