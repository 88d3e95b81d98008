//! Calibration studies from Python: what `demcal run`, `status` and `report` do, and the
//! stored runs as data.

use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::sync::Arc;

use pyo3::prelude::*;
use serde_json::json;
use study::{RunStudyError, Store, Study};

use crate::{check_count, input, interruptible, to_json, DemcalError, Pool, StudyError};

pub(crate) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(study_info, m)?)?;
    m.add_function(wrap_pyfunction!(study_run, m)?)?;
    m.add_function(wrap_pyfunction!(study_status, m)?)?;
    m.add_function(wrap_pyfunction!(study_results, m)?)?;
    m.add_function(wrap_pyfunction!(study_report, m)?)?;
    Ok(())
}

fn load(path: &Path) -> PyResult<Study> {
    Study::load(path).map_err(input)
}

/// The study as read: its name, parameters with their ranges, plan, tests and where it keeps
/// its results and report. Nothing is built or run.
#[pyfunction]
fn study_info(path: PathBuf) -> PyResult<String> {
    let s = load(&path)?;
    let parameters: Vec<_> = s
        .parameters
        .iter()
        .map(|p| {
            json!({
                "name": p.name,
                "display_name": p.display_name(),
                "min": p.min,
                "max": p.max,
                "paths": p.paths.iter().map(|(path, _)| path.text.clone()).collect::<Vec<_>>(),
            })
        })
        .collect();
    Ok(to_json(&json!({
        "name": s.name,
        "path": s.path,
        "seed": s.seed,
        "parameters": parameters,
        "plan": s.plan.iter().map(|st| st.kind().to_string()).collect::<Vec<_>>(),
        "tests": s.tests.iter().map(|t| t.name.clone()).collect::<Vec<_>>(),
        "test_files": s.tests.iter().map(|t| t.source.clone()).collect::<Vec<_>>(),
        "response": s.target.response,
        "targets": s.targets.iter().map(|t| json!({
            "test": s.tests[t.test].name,
            "response": t.response,
            "value": t.value,
            "replicates": t.replicates,
            "unit": t.unit,
            "minimised": t.minimised,
            "weight": t.weight,
        })).collect::<Vec<_>>(),
        "store": s.store_path(),
        "report_dir": s.report_dir(),
        "backend": s.backend,
    })))
}

/// `demcal run`: runs (or resumes) the study on this machine with `jobs` runs at once, writes
/// its report, and returns what the binary prints. Ctrl-C keeps every finished run and raises
/// `KeyboardInterrupt`; the same call goes on from them.
#[pyfunction]
#[pyo3(signature = (path, jobs=1, restart=false, retry_failed=false, backend=None))]
fn study_run(
    py: Python<'_>,
    path: PathBuf,
    jobs: usize,
    restart: bool,
    retry_failed: bool,
    backend: Option<String>,
) -> PyResult<String> {
    check_count("jobs", jobs)?;
    load(&path)?;
    // The runs are made in this process, on this machine's cores (a study written for Slurm is
    // submitted with `demcal run`).
    let opts = study::RunOptions {
        jobs,
        jobs_given: true,
        restart,
        retry_failed,
        backend,
        executor: Some("local".into()),
    };
    let stop = Arc::new(AtomicBool::new(false));
    let flag = stop.clone();
    // The study's runs share the machine's cores, `jobs` at a time (as `demcal run --jobs`).
    let result = interruptible(py, Pool::Own, stop, move || study::run(&path, &opts, flag))?;
    result.map_err(|e| match e {
        RunStudyError::StudyFile(m) => input(m),
        RunStudyError::Locked(m) => crate::StudyLockedError::new_err(m),
        RunStudyError::Interrupted(m) => crate::interrupted(&m),
        RunStudyError::Stopped(m) => StudyError::new_err(m),
        RunStudyError::Other(m) => DemcalError::new_err(m),
    })
}

/// `demcal status`.
#[pyfunction]
fn study_status(py: Python<'_>, path: PathBuf) -> PyResult<String> {
    py.detach(|| study::status(&path)).map_err(input)
}

/// Every stored run as JSON (a list of records: stage, kind, index, inputs, seed, status,
/// response, outputs, error, error_kind, wall_s, ...), scored against the targets as the study
/// is written now. An empty list when the study has not run.
#[pyfunction]
fn study_results(py: Python<'_>, path: PathBuf) -> PyResult<String> {
    let s = load(&path)?;
    if !s.store_path().exists() {
        return Ok("[]".into());
    }
    py.detach(|| {
        let store = Store::open(&s.store_path(), false)?;
        let runs = study::job::rescored_all(&s, store.runs()?);
        serde_json::to_string(&runs).map_err(|e| e.to_string())
    })
    .map_err(DemcalError::new_err)
}

/// `demcal report`: writes the report (into `out`, or the study's `report/`) and returns its
/// folder.
#[pyfunction]
#[pyo3(signature = (path, out=None))]
fn study_report(py: Python<'_>, path: PathBuf, out: Option<PathBuf>) -> PyResult<PathBuf> {
    // As `status`: what stops a report is the study file or its store as they are now.
    py.detach(|| study::report(&path, out.as_deref()))
        .map_err(input)
}
