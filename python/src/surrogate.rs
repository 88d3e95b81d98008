//! Surrogates from Python: `demcal surrogate fit | optimize` on a table, and a fitted model kept
//! to predict with (a GP's mean and variance, a network's mean and its ensemble's spread).

use std::path::PathBuf;

use pyo3::prelude::*;
use surrogate::commands::{ErrorOf, FitRequest, Fitted, Goal, Model};

use crate::design::table;
use crate::{input, to_json};

pub(crate) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<NativeSurrogate>()?;
    m.add_function(wrap_pyfunction!(surrogate_fit, m)?)?;
    m.add_function(wrap_pyfunction!(surrogate_optimize, m)?)?;
    Ok(())
}

/// A fitted surrogate (wrapped by `demcal.surrogate.Surrogate`).
#[pyclass(module = "demcal._demcal", frozen)]
pub struct NativeSurrogate {
    fitted: Fitted,
    summary: String,
}

#[pymethods]
impl NativeSurrogate {
    /// The factor columns, in the order `predict` takes them.
    #[getter]
    fn factors(&self) -> Vec<String> {
        self.fitted.factors.clone()
    }

    /// Each factor's observed minimum and maximum (the box the model is fitted in).
    #[getter]
    fn ranges(&self) -> Vec<(f64, f64)> {
        self.fitted.ranges.clone()
    }

    /// Metrics, rows and model facts as JSON text (what `surrogate fit --json` prints).
    #[getter]
    fn summary_json(&self) -> String {
        self.summary.clone()
    }

    /// Mean and variance at each row of `x` (actual units, one column per factor); the variance
    /// is None for a single network.
    fn predict(&self, py: Python<'_>, x: Vec<Vec<f64>>) -> PyResult<Vec<(f64, Option<f64>)>> {
        let k = self.fitted.factors.len();
        if let Some((i, row)) = x.iter().enumerate().find(|(_, r)| r.len() != k) {
            return Err(input(format!(
                "x[{i}]: {} values, expected {k} (one per factor: {})",
                row.len(),
                self.fitted.factors.join(", ")
            )));
        }
        let fitted = &self.fitted;
        Ok(py.detach(|| x.iter().map(|r| fitted.predict_actual(r)).collect()))
    }
}

/// The table (a file, or CSV text named `source`) and the fit asked of it, both checked.
#[allow(clippy::too_many_arguments)]
fn table_and_request(
    path: Option<PathBuf>,
    csv: Option<&str>,
    source: &str,
    response: String,
    factors: Option<Vec<String>>,
    model: &str,
    kernel: Option<&str>,
    seed: u64,
    train_fraction: f64,
) -> PyResult<(doe::DataTable, FitRequest)> {
    if !(train_fraction > 0.0 && train_fraction < 1.0) {
        return Err(input(format!(
            "train_fraction={train_fraction}: expected a share between 0 and 1 (0.8 trains on 80 % of the rows)"
        )));
    }
    let t = table(path.clone(), csv, source)?;
    let req = FitRequest {
        // Messages name the data: the file, or what the Python side calls the table.
        data: path.unwrap_or_else(|| PathBuf::from(source)),
        response,
        factors,
        model: Model::parse(model, kernel).map_err(input)?,
        seed,
        train_fraction,
    };
    Ok((t, req))
}

/// Fits a surrogate of `response` (a GP, a BP or a GA-BP network).
#[pyfunction]
#[pyo3(signature = (response, path=None, csv=None, source="data", factors=None, model="gp",
                    kernel=None, seed=1, train_fraction=0.8))]
#[allow(clippy::too_many_arguments)]
fn surrogate_fit(
    py: Python<'_>,
    response: String,
    path: Option<PathBuf>,
    csv: Option<&str>,
    source: &str,
    factors: Option<Vec<String>>,
    model: &str,
    kernel: Option<&str>,
    seed: u64,
    train_fraction: f64,
) -> PyResult<NativeSurrogate> {
    let (t, req) = table_and_request(
        path,
        csv,
        source,
        response,
        factors,
        model,
        kernel,
        seed,
        train_fraction,
    )?;
    let fitted = py
        .detach(|| surrogate::commands::fit_table(&req, &t))
        .map_err(input)?;
    let summary = to_json(&surrogate::commands::fitted_json(&fitted, &req));
    Ok(NativeSurrogate { fitted, summary })
}

/// `demcal surrogate optimize --json`: fits, then searches the model with a genetic algorithm
/// inside the table's ranges (GA-BP-GA for a GA-BP network).
#[pyfunction]
#[pyo3(signature = (response, goal, path=None, csv=None, source="data", factors=None,
                    model="gp", kernel=None, seed=1, train_fraction=0.8, target_of=None,
                    value=None))]
#[allow(clippy::too_many_arguments)]
fn surrogate_optimize(
    py: Python<'_>,
    response: String,
    goal: &str,
    path: Option<PathBuf>,
    csv: Option<&str>,
    source: &str,
    factors: Option<Vec<String>>,
    model: &str,
    kernel: Option<&str>,
    seed: u64,
    train_fraction: f64,
    target_of: Option<String>,
    value: Option<f64>,
) -> PyResult<String> {
    let (t, req) = table_and_request(
        path,
        csv,
        source,
        response,
        factors,
        model,
        kernel,
        seed,
        train_fraction,
    )?;
    let goal = Goal::parse(goal).map_err(input)?;
    let error_of = match (target_of, value) {
        (Some(response), Some(lab)) => Some(ErrorOf { response, lab }),
        (None, None) => None,
        _ => {
            return Err(input(
                "target_of and value go together: the response column and its lab value",
            ))
        }
    };
    py.detach(|| surrogate::commands::optimize_table(&req, &t, goal, error_of.as_ref(), true))
        .map_err(input)
}
