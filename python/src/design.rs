//! Designed experiments from Python: `demcal doe design | analyze | optimize` on tables the
//! Python half hands over as CSV text (a data frame, a dict of columns) or as a file's path.

use std::path::PathBuf;

use doe::commands::{DesignRequest, ModelRequest, OptimizeRequest};
use doe::DataTable;
use pyo3::prelude::*;
use serde_json::json;

use crate::{input, to_json};

pub(crate) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(doe_design, m)?)?;
    m.add_function(wrap_pyfunction!(doe_analyze, m)?)?;
    m.add_function(wrap_pyfunction!(doe_optimize, m)?)?;
    Ok(())
}

/// The table from a file (`path`) or from CSV text (`csv`, named `source` in messages).
pub(crate) fn table(path: Option<PathBuf>, csv: Option<&str>, source: &str) -> PyResult<DataTable> {
    match (path, csv) {
        (Some(p), None) => DataTable::read(&p).map_err(input),
        (None, Some(text)) => {
            if text.len() as u64 > doe::data::MAX_TABLE_BYTES {
                return Err(input(format!(
                    "{source}: {} bytes, at most {}",
                    text.len(),
                    doe::data::MAX_TABLE_BYTES
                )));
            }
            DataTable::parse(source, text).map_err(input)
        }
        _ => Err(input("give the data as a path or as CSV text, not both")),
    }
}

/// `demcal doe design`: the design as CSV text (standard order, run order, point type, coded
/// and actual columns) with the summary the binary prints.
#[pyfunction]
#[pyo3(signature = (kind, factors, center_points=None, alpha=None, runs=None, resolution=None,
                    fraction=None, half_fraction=None, lhs=None, direction=None, step=None, seed=1))]
#[allow(clippy::too_many_arguments)]
fn doe_design(
    py: Python<'_>,
    kind: String,
    factors: String,
    center_points: Option<usize>,
    alpha: Option<String>,
    runs: Option<usize>,
    resolution: Option<usize>,
    fraction: Option<usize>,
    half_fraction: Option<bool>,
    lhs: Option<String>,
    direction: Option<String>,
    step: Option<f64>,
    seed: u64,
) -> PyResult<String> {
    let req = DesignRequest {
        kind,
        factors,
        center_points,
        alpha,
        runs,
        resolution,
        fraction,
        half_fraction,
        lhs,
        direction,
        step,
        seed,
    };
    let (d, f) = py
        .detach(|| doe::commands::make_design(&req))
        .map_err(input)?;
    Ok(to_json(&json!({
        "csv": doe::commands::design_csv(&d, &f, seed),
        "summary": doe::commands::design_summary(&d, &f, seed),
    })))
}

#[allow(clippy::too_many_arguments)]
fn model_request(
    responses: Vec<String>,
    factors: Option<String>,
    model: Option<String>,
    reduce: bool,
    alpha_out: f64,
    no_hierarchy: bool,
    no_curvature: bool,
) -> ModelRequest {
    ModelRequest {
        // Read by the functions that take a path; these take the table itself.
        data: PathBuf::new(),
        responses,
        factors,
        model,
        reduce,
        alpha_out,
        no_hierarchy,
        no_curvature,
    }
}

/// `demcal doe analyze --json`: each response's fit (ANOVA rows, coefficients, fit statistics,
/// diagnostics) as JSON text; with `plots`, the plots written into that folder.
#[pyfunction]
#[pyo3(signature = (responses, path=None, csv=None, source="data", factors=None, model=None,
                    reduce=false, alpha_out=0.1, no_hierarchy=false, no_curvature=false, plots=None))]
#[allow(clippy::too_many_arguments)]
fn doe_analyze(
    py: Python<'_>,
    responses: Vec<String>,
    path: Option<PathBuf>,
    csv: Option<&str>,
    source: &str,
    factors: Option<String>,
    model: Option<String>,
    reduce: bool,
    alpha_out: f64,
    no_hierarchy: bool,
    no_curvature: bool,
    plots: Option<PathBuf>,
) -> PyResult<String> {
    let t = table(path, csv, source)?;
    let req = model_request(
        responses,
        factors,
        model,
        reduce,
        alpha_out,
        no_hierarchy,
        no_curvature,
    );
    py.detach(|| doe::commands::analyze_table(&req, &t, true, plots.as_deref()))
        .map_err(input)
}

/// `demcal doe optimize --json`: the desirability search over the fitted models.
#[pyfunction]
#[pyo3(signature = (responses, goals, path=None, csv=None, source="data", factors=None,
                    model=None, reduce=false, alpha_out=0.1, solutions=10, starts=100, seed=1))]
#[allow(clippy::too_many_arguments)]
fn doe_optimize(
    py: Python<'_>,
    responses: Vec<String>,
    goals: Vec<String>,
    path: Option<PathBuf>,
    csv: Option<&str>,
    source: &str,
    factors: Option<String>,
    model: Option<String>,
    reduce: bool,
    alpha_out: f64,
    solutions: usize,
    starts: usize,
    seed: u64,
) -> PyResult<String> {
    let t = table(path, csv, source)?;
    let req = model_request(responses, factors, model, reduce, alpha_out, false, false);
    let opt = OptimizeRequest {
        goals,
        solutions,
        starts,
        seed,
    };
    py.detach(|| doe::commands::optimize_table(&req, &t, &opt, true))
        .map_err(input)
}
