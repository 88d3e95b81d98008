//! Virtual lab tests from Python: read a test file (or a dict), set parameters by the paths a
//! study uses, run it, and hand back the outcome, the responses and the curves.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Instant;

use pyo3::prelude::*;
use pyo3::types::PyDict;
use serde_json::{json, Value};
use study::paths::ParamPath;
use virtual_tests::{Response, TestError, TestFile};

use crate::{input, interruptible, to_json, Pool};

pub(crate) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(read_table, m)?)?;
    m.add_function(wrap_pyfunction!(test_info, m)?)?;
    m.add_function(wrap_pyfunction!(test_run, m)?)?;
    Ok(())
}

/// A TOML table from file text (`format` "toml") or from JSON text (`"json"`: a dict from
/// Python), for messages called `name`.
pub(crate) fn table_from(text: &str, format: &str, name: &str) -> PyResult<toml::Table> {
    match format {
        "toml" => toml::from_str(text)
            .map_err(|e| input(format!("{name}: {}", virtual_tests::file::one_line(&e.to_string())))),
        "json" => serde_json::from_str::<toml::Table>(text).map_err(|e| {
            input(format!(
                "{name}: expected a dict of TOML values (strings, numbers, booleans, lists, dicts; no None): {e}"
            ))
        }),
        other => Err(input(format!("format \"{other}\": expected toml or json"))),
    }
}

/// A file's text, read with the engine's size limit.
fn read_text(path: &str) -> PyResult<String> {
    dem::files::read_text(Path::new(path), dem::files::MAX_TEXT_BYTES)
        .map_err(|e| input(format!("{path}: cannot read: {e}")))
}

/// Reads a TOML file into JSON text (what `Test.load` and `Scene.load` keep, so a loaded file
/// can be changed as a dict before it runs).
#[pyfunction]
fn read_table(path: &str) -> PyResult<String> {
    let table = table_from(&read_text(path)?, "toml", path)?;
    serde_json::to_string(&table).map_err(|e| input(format!("{path}: {e}")))
}

/// The test file as a run reads it, with `params` set; errors name the file and the key.
fn test_file(
    table_json: &str,
    name: &str,
    folder: &str,
    params: Option<&Bound<'_, PyDict>>,
) -> PyResult<TestFile> {
    let mut table = table_from(table_json, "json", name)?;
    if let Some(params) = params {
        for (key, value) in params.iter() {
            let key: String = key.extract().map_err(|_| {
                input(format!(
                    "{name}: params: the keys are parameter paths (str)"
                ))
            })?;
            let path = ParamPath::parse(&key).map_err(|e| input(format!("{name}: params: {e}")))?;
            let v = if value.is_instance_of::<pyo3::types::PyBool>() {
                return Err(input(format!(
                    "{name}: params[\"{key}\"]: expected a number or a quantity such as \"29 MPa\", got a bool"
                )));
            } else if let Some(i) = (!value.is_instance_of::<pyo3::types::PyFloat>())
                .then(|| value.extract::<i64>().ok())
                .flatten()
            {
                // A whole number (a Python or numpy integer) stays one: counts (`fill.count`)
                // take no 150.0.
                toml::Value::Integer(i)
            } else if let Ok(x) = value.extract::<f64>() {
                if !x.is_finite() {
                    return Err(input(format!(
                        "{name}: params[\"{key}\"]: expected a finite number, got {x}"
                    )));
                }
                toml::Value::Float(x)
            } else if let Ok(s) = value.extract::<String>() {
                toml::Value::String(s)
            } else {
                return Err(input(format!(
                    "{name}: params[\"{key}\"]: expected a number or a quantity such as \"29 MPa\""
                )));
            };
            path.check(&table)
                .and_then(|_| path.set_value(&mut table, v))
                .map_err(|e| input(format!("{name}: params[\"{key}\"]: {e}")))?;
        }
    }
    TestFile::from_table_in(name, &table, Path::new(folder)).map_err(input)
}

/// What the test is: its kind, its responses (the usual one first), its seed; the file checked
/// as a run would read it (nothing is built).
#[pyfunction]
#[pyo3(signature = (table_json, name, folder))]
fn test_info(table_json: &str, name: &str, folder: &str) -> PyResult<String> {
    let file = test_file(table_json, name, folder, None)?;
    virtual_tests::check_file(&file).map_err(input)?;
    Ok(to_json(&json!({
        "test": file.test,
        "responses": virtual_tests::responses(&file.test),
        "seed": file.seed,
        "warnings": file.parts.warnings,
    })))
}

/// Runs the test with `params` set and returns the outcome as JSON text: `ok`, `responses`
/// (numbers), `curves` (x, y and their names and units), `outcome` (everything the test
/// measured, as `demcal test --json`), `summary`, `wall_s`, and when it failed `error` and
/// `error_kind` (the kinds a study stores). Bad input raises `InputError` before anything runs;
/// Ctrl-C raises `KeyboardInterrupt`.
#[pyfunction]
#[pyo3(signature = (table_json, name, folder, params=None, seed=None, threads=None, out=None))]
#[allow(clippy::too_many_arguments)]
fn test_run(
    py: Python<'_>,
    table_json: &str,
    name: &str,
    folder: &str,
    params: Option<&Bound<'_, PyDict>>,
    seed: Option<u64>,
    threads: Option<usize>,
    out: Option<PathBuf>,
) -> PyResult<String> {
    let file = test_file(table_json, name, folder, params)?;
    virtual_tests::check_file(&file).map_err(input)?;
    if let Some(dir) = &out {
        dem::files::check_writable(dir).map_err(input)?;
    }
    let stop = Arc::new(AtomicBool::new(false));
    let flag = stop.clone();
    let result = interruptible(py, Pool::One(threads), stop.clone(), move || {
        let start = Instant::now();
        let mut progress = |_: &str, _: f64| -> Result<(), String> {
            if flag.load(Ordering::Relaxed) {
                return Err("interrupted".into());
            }
            Ok(())
        };
        let done = virtual_tests::run_file(&file, seed, out.as_deref(), &mut progress);
        (done, start.elapsed().as_secs_f64())
    })?;
    let (done, wall_s) = result;
    if stop.load(Ordering::SeqCst) {
        return Err(crate::interrupted("interrupted"));
    }
    Ok(to_json(&outcome_json(done, wall_s)))
}

/// The answer of a run, done or failed.
fn outcome_json(done: Result<virtual_tests::Finished, TestError>, wall_s: f64) -> Value {
    let done = match done {
        Ok(d) => d,
        Err(e) => {
            let e = study::RunError::from(e);
            return json!({
                "ok": false,
                "responses": {},
                "curves": {},
                "outcome": null,
                "summary": "",
                "wall_s": wall_s,
                "error": e.message,
                "error_kind": e.kind.as_str(),
            });
        }
    };
    let mut responses = serde_json::Map::new();
    let mut curves = serde_json::Map::new();
    for (name, r) in &done.responses {
        match r {
            Response::Scalar(y) => {
                responses.insert(name.to_string(), json!(y));
            }
            Response::Curve {
                x_name,
                x_unit,
                y_name,
                y_unit,
                x,
                y,
            } => {
                curves.insert(
                    name.to_string(),
                    json!({"x_name": x_name, "x_unit": x_unit, "y_name": y_name,
                           "y_unit": y_unit, "x": x, "y": y}),
                );
            }
        }
    }
    // A mechanical run whose specimen was not quasi-static gives numbers a study refuses.
    let (ok, error, kind) = match &done.rejected {
        Some(why) => (false, Some(why.clone()), Some("not_quasi_static")),
        None => (true, None, None),
    };
    json!({
        "ok": ok,
        "responses": responses,
        "curves": curves,
        "outcome": done.json,
        "summary": done.summary,
        "wall_s": wall_s,
        "error": error,
        "error_kind": kind,
    })
}
