//! Calibration studies: one file describes a whole calibration, one command runs it.
//!
//! A study ([`spec`]) names a virtual test, the parameters to calibrate (each a path into the
//! test's TOML, [`paths`]) with their ranges, the lab value, and a plan of stages: screening,
//! steepest path, response surface, optimisation, validation ([`stages`]). [`run`] replays the
//! plan against the results store ([`store`], SQLite next to the study) and runs what is missing
//! on this machine ([`runner`]); [`status`] and [`report`] replay without running. The report
//! ([`report`]) is one self-contained HTML page plus `results.csv` and `summary.json`. A target
//! may be a curve: the lab's curves ([`lab_curve`]) against the test's, compared as
//! [`curve`] says. A study may have several tests and targets, combined into one objective per
//! run by a weighted error or a desirability ([`target`]).

pub mod curve;
pub mod curve_compare;
mod curve_report;
mod design_stages;
pub mod error;
pub mod executor;
pub mod file;
pub mod job;
pub mod lab_curve;
pub mod limits;
pub mod load;
pub mod paths;
pub mod plan;
pub mod record;
pub mod report;
mod report_data;
mod report_figures;
mod report_model;
mod report_settings;
mod report_validation;
pub mod run_error;
pub mod runner;
pub mod slurm;
pub mod spec;
pub mod stage;
pub mod stages;
pub mod store;
mod surrogate_report;
pub mod surrogate_stages;
pub mod target;
mod targets_report;
pub mod text;
pub mod uncertainty;
mod uncertainty_report;
mod uncertainty_routes;

use std::fmt::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::sync::Arc;

pub use error::{LockError, RunStudyError};
pub use job::Job;
pub use run_error::{RunError, RunErrorKind};
pub use spec::Study;
pub use stages::{replay, Replay, State};
pub use store::Store;

/// Options of `demcal run`.
#[derive(Clone, Debug, Default)]
pub struct RunOptions {
    /// `--jobs`, or the default for this machine when not given: what the executor makes of it
    /// ([`executor::Executor::with_jobs`]; on this machine, runs at once).
    pub jobs: usize,
    /// Whether `--jobs` was given: an executor elsewhere keeps its own setting otherwise.
    pub jobs_given: bool,
    /// Move the old store aside and start over.
    pub restart: bool,
    /// Forget failed runs so that they run again.
    pub retry_failed: bool,
    /// The back end in place of the study's `backend` ("cpu" or "gpu").
    pub backend: Option<String>,
    /// The executor in place of the study's `[executor]` (`--executor`).
    pub executor: Option<String>,
}

/// Runs (or resumes) a study, then writes its report. Returns what to print; the error says
/// why it ended without finishing, typed as the caller may act on it ([`RunStudyError`]).
pub fn run(
    path: &Path,
    opts: &RunOptions,
    interrupted: Arc<AtomicBool>,
) -> Result<String, RunStudyError> {
    let mut study = Study::load(path).map_err(RunStudyError::StudyFile)?;
    let executor = executor::chosen(&study, opts.executor.as_deref())?;
    let (executor, jobs) = if opts.jobs_given || executor.on_this_machine() {
        executor.with_jobs(opts.jobs)?
    } else {
        (executor, 1)
    };
    let wanted = opts.backend.clone().unwrap_or(study.backend.clone());
    if executor.on_this_machine() {
        // A back end this machine lacks falls back to the CPU, said once here.
        let (chosen, why) = dem::sim::resolve_backend(&wanted)?;
        if let Some(why) = why {
            eprintln!("warning: backend \"{wanted}\": {why}");
        }
        study.backend = chosen.to_string();
    } else {
        // The nodes have the GPUs, not necessarily the machine that submits.
        study.backend = wanted;
    }
    // Before anything is written: a machine that cannot reach the executor gets nothing but the
    // error.
    executor.preflight()?;
    let db = study.store_path();
    // One `demcal run` per study at a time, held until the report is written.
    let _lock = store::StoreLock::acquire(&db)?;
    // The first run's scene, built now: a test that cannot even be set up fails before any
    // store or run exists.
    study.check_scene().map_err(RunStudyError::StudyFile)?;
    if opts.restart && db.exists() {
        // Work of the old results still out (Slurm tasks) would go on writing into the run
        // folders.
        // A store that cannot be read (empty, damaged) has no tasks to find: it is moved aside
        // all the same, which is what --restart is for.
        match Store::open(&db, false) {
            Ok(old) => {
                for (name, cancelled) in executor::withdraw_all(&old)? {
                    eprintln!(
                        "cancelled {cancelled} {} task(s) of the old results",
                        text::capitalised(name)
                    );
                }
            }
            Err(e) => eprintln!("warning: the old results cannot be read ({e}); moving them aside"),
        }
        let aside = db.with_extension(format!(
            "db.old-{}",
            store::now_utc().replace([' ', ':'], "-")
        ));
        std::fs::rename(&db, &aside)
            .map_err(|e| format!("{}: cannot move aside: {e}", db.display()))?;
        eprintln!("moved the old results to {}", aside.display());
    }
    let mut store = Store::open(&db, true)?;
    if store.meta("created")?.is_none() {
        store.set_meta("created", &store::now_utc())?;
        store.set_meta("first_study_text", &study.text)?;
    }
    store.set_meta("demcal_version", env!("CARGO_PKG_VERSION"))?;
    if opts.retry_failed {
        let n = store.delete_failed()?;
        if n > 0 {
            eprintln!("{n} failed run(s) will run again");
        }
    } else {
        // A run that failed for the machine (its files not written, its task ended by the
        // cluster) says nothing about its parameters: it is made again without being asked.
        let n = store.delete_transient()?;
        if n > 0 {
            eprintln!(
                "{n} run(s) that failed for the machine, not their parameters (files not written, tasks ended by the cluster), will run again"
            );
        }
    }
    let stored = store.runs()?;
    let started = std::time::Instant::now();
    // An executor stops on Ctrl-C with the number of runs it kept; that is no failure of the
    // study.
    let ended = |e: String| {
        if interrupted.load(std::sync::atomic::Ordering::SeqCst) {
            RunStudyError::Interrupted(e)
        } else {
            RunStudyError::Other(e)
        }
    };
    let (outcome, closing) = executor
        .run(&study, &mut store, &stored, jobs, interrupted.clone())
        .map_err(ended)?;
    if let Some(line) = closing {
        eprintln!("{line}");
    }
    let replay = outcome.map_err(ended)?;
    store.set_meta("last_study_text", &study.text)?;
    let stored = job::rescored_all(&study, store.runs()?);
    let dir = report::write(&study, &replay, &stored, None)?;
    let mut out = status_text(&study, &replay);
    writeln!(
        out,
        "ran for {:.0} s; report: {}",
        started.elapsed().as_secs_f64(),
        dir.join("index.html").display()
    )
    .unwrap();
    match &replay.state {
        State::Stopped(why) => Err(RunStudyError::Stopped(format!(
            "{out}{}: {why}",
            study.path.display()
        ))),
        _ => Ok(out),
    }
}

fn load_replay(path: &Path) -> Result<(Study, Replay, Vec<store::RunRecord>), String> {
    let study = Study::load(path)?;
    let store = Store::open(&study.store_path(), false)?;
    let stored = job::rescored_all(&study, store.runs()?);
    let r = replay(&study, &stored, None)?;
    Ok((study, r, stored))
}

/// `demcal status`: the stages, their runs, and the best so far.
pub fn status(path: &Path) -> Result<String, String> {
    let study = Study::load(path)?;
    if !study.store_path().exists() {
        let mut s = format!(
            "{}: not started (no {}); {} stages planned: {}\n",
            study.name,
            study.store_path().display(),
            study.plan.len(),
            study
                .plan
                .iter()
                .map(|s| s.kind())
                .collect::<Vec<_>>()
                .join(", ")
        );
        s.push_str("start it with: demcal run ");
        s.push_str(&study.path.display().to_string());
        s.push('\n');
        return Ok(s);
    }
    let (study, r, _) = load_replay(path)?;
    let store = Store::open(&study.store_path(), false)?;
    Ok(status_text(&study, &r) + &executor::status_lines(&study, &store)?)
}

/// `demcal report`: writes the report; returns its folder.
pub fn report(path: &Path, out: Option<&Path>) -> Result<PathBuf, String> {
    let (study, r, stored) = load_replay(path)?;
    report::write(&study, &r, &stored, out)
}

/// Stages with their runs done / failed / pending, and the best values so far.
pub fn status_text(study: &Study, r: &Replay) -> String {
    let mut s = String::new();
    let t = &study.target;
    if let Some(c) = study.combine {
        let targets: Vec<String> = study
            .targets
            .iter()
            .map(|x| {
                let lab = if x.minimised() {
                    "lab curves".to_string()
                } else {
                    crate::text::sig(x.value)
                };
                format!("{} {} = {lab}", study.tests[x.test].name, x.response)
            })
            .collect();
        writeln!(
            s,
            "{}: {} calibrated against {} (combined: {})",
            study.name,
            study.test_kind(),
            targets.join(", "),
            c.response()
        )
        .unwrap();
    } else if t.minimised() {
        writeln!(
            s,
            "{}: {} calibrated by minimising {} (the test's {} against the lab curves)",
            study.name,
            study.test_kind(),
            t.response,
            t.curve
                .as_ref()
                .map(|c| c.curve.as_str())
                .unwrap_or("curve"),
        )
        .unwrap();
    } else {
        writeln!(
            s,
            "{}: {} calibrated against {} = {}{}",
            study.name,
            study.test_kind(),
            t.response,
            crate::text::sig(t.value),
            if t.unit.is_empty() {
                String::new()
            } else {
                format!(" {}", t.unit)
            }
        )
        .unwrap();
    }
    for (i, stage) in study.plan.iter().enumerate() {
        let line = match r.stages.get(i) {
            Some(st) if stage.runs_simulations() => format!(
                "{} runs: {} done, {} failed{}, {} pending{}",
                st.runs.len(),
                st.done(),
                st.failed(),
                match st.failed_transiently() {
                    0 => String::new(),
                    n => format!(" ({n} for the machine, made again by the next run)"),
                },
                st.pending(),
                if st.complete { "" } else { " (in progress)" }
            ),
            Some(st) if st.complete => format!("{} solution(s)", st.solutions().len()),
            _ => "waiting for the stages before it".to_string(),
        };
        writeln!(s, "  {}. {:<10} {line}", i + 1, stage.kind()).unwrap();
        if let Some(st) = r.stages.get(i) {
            if !st.selected().is_empty() {
                let names: Vec<&str> = st
                    .selected()
                    .iter()
                    .map(|&p| study.parameters[p].name.as_str())
                    .collect();
                writeln!(s, "     going on: {}", names.join(", ")).unwrap();
            }
            if let Some(v) = st.validation() {
                writeln!(
                    s,
                    "     validation: {} = {}{} over {} runs{}",
                    t.response,
                    crate::text::sig(v.mean),
                    v.std
                        .map(|d| format!(" ± {} (SD)", crate::text::sig(d)))
                        .unwrap_or_default(),
                    v.runs,
                    v.relative_error_percent
                        .map(|e| format!(", relative error {e:.2} %"))
                        .unwrap_or_default()
                )
                .unwrap();
                if let Some(words) = crate::uncertainty_report::validation_words(v, t) {
                    writeln!(s, "     {words}").unwrap();
                }
            }
        }
    }
    if let Some((spec, y)) = stages::best_run(study, &r.stages) {
        writeln!(
            s,
            "best run so far: stage {} run {}: {} = {}{}",
            spec.stage + 1,
            spec.index + 1,
            t.response,
            crate::text::sig(y),
            t.relative_error_percent(y)
                .map(|e| format!(" (relative error {e:.2} %)"))
                .unwrap_or_default()
        )
        .unwrap();
    }
    if let Some(values) = stages::calibrated(study, &r.stages) {
        // Each value to the digits its interval supports, where it has one.
        let intervals = crate::uncertainty_report::per_parameter(study, &r.stages);
        let parts: Vec<String> = study
            .parameters
            .iter()
            .zip(&values)
            .zip(&intervals)
            .map(|((p, v), iv)| match iv {
                Some((_, iv)) => {
                    format!("{} = {}", p.name, crate::uncertainty_report::value_text(iv))
                }
                None => format!("{} = {}", p.name, crate::text::sig(*v)),
            })
            .collect();
        let what = if r.stages.iter().any(|s| s.calibrated.is_some()) {
            "calibrated"
        } else {
            "best so far"
        };
        writeln!(s, "{what}: {}", parts.join(", ")).unwrap();
        let lines = crate::uncertainty_report::status_lines(study, &r.stages);
        if !lines.is_empty() {
            writeln!(s, "uncertainty (95 %):").unwrap();
            for l in lines {
                writeln!(s, "{l}").unwrap();
            }
        }
    }
    match &r.state {
        State::Complete => writeln!(s, "state: complete").unwrap(),
        State::Pending { stage } => writeln!(
            s,
            "state: stage {} ({}) has runs to make; `demcal run {}` goes on",
            stage + 1,
            study.plan[*stage].kind(),
            study.path.display()
        )
        .unwrap(),
        State::Stopped(why) => writeln!(s, "state: stopped: {why}").unwrap(),
    }
    s
}
