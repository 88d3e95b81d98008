//! `demcal surrogate fit` and `demcal surrogate optimize`: a surrogate trained on a user's own
//! result table (an EDEM design's CSV), as `demcal doe analyze` fits a polynomial to one.
//!
//! Factor columns are mapped onto [-1, 1] by their observed minimum and maximum (what MATLAB's
//! `mapminmax` does before a BP network, and the box a GP's length scales are read in), so the
//! search stays inside the ranges the table covers.
//!
//! An error (|sim - lab| / lab, an MSE) cannot be negative, but a smooth model of one can: its
//! kink at zero is smoothed into a dip below it, and a network extrapolates the error's slopes
//! below zero at a corner of the box, where minimising it then lands. So `optimize` of a
//! column whose every observed value is >= 0 reports predictions clamped at 0 and says when it
//! clamped, and `--target-of RESPONSE --value LAB` ([`ErrorOf`]) models the response instead,
//! whose prediction gives the error: never below zero, and smallest where the model meets the lab
//! value.

use std::fmt::Write;
use std::path::PathBuf;

use doe::DataTable;
use serde_json::json;

use crate::genetic::{self, GaOptions};
use crate::gp::{Gp, GpOptions, Kernel};
use crate::metrics::{split_stratified, FitMetrics};
use crate::network::{self, BpOptions};

/// Which surrogate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Model {
    Gp(Kernel),
    /// BP network, Levenberg-Marquardt from seeded random weights.
    Bp,
    /// BP network whose starting weights a genetic algorithm chose.
    GaBp,
}

impl Model {
    pub fn parse(s: &str, kernel: Option<&str>) -> Result<Model, String> {
        match s.to_ascii_lowercase().as_str() {
            "gp" => Ok(Model::Gp(Kernel::parse(kernel.unwrap_or("matern52"))?)),
            _ if kernel.is_some() => {
                Err("--kernel: only a GP (--model gp) has a kernel".to_string())
            }
            "bp" => Ok(Model::Bp),
            "ga-bp" | "gabp" | "ga_bp" => Ok(Model::GaBp),
            other => Err(format!("--model '{other}': expected gp, bp or ga-bp")),
        }
    }

    pub fn name(&self) -> String {
        match self {
            Model::Gp(k) => format!("gp ({})", k.name()),
            Model::Bp => "bp".into(),
            Model::GaBp => "ga-bp".into(),
        }
    }
}

/// What to fit.
#[derive(Clone, Debug)]
pub struct FitRequest {
    pub data: PathBuf,
    pub response: String,
    /// Factor columns; None: every column but the response and bookkeeping ones.
    pub factors: Option<Vec<String>>,
    pub model: Model,
    pub seed: u64,
    /// Share of the rows trained on; the rest test the model (the papers' 80/20).
    pub train_fraction: f64,
}

/// What `optimize` looks for.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Goal {
    Target(f64),
    Minimize,
    Maximize,
}

impl Goal {
    pub fn parse(s: &str) -> Result<Goal, String> {
        let t = s.trim().to_ascii_lowercase();
        match t.as_str() {
            "minimize" | "minimise" | "min" => return Ok(Goal::Minimize),
            "maximize" | "maximise" | "max" => return Ok(Goal::Maximize),
            _ => {}
        }
        t.strip_prefix("target=")
            .and_then(|v| v.trim().parse::<f64>().ok())
            .filter(|v| v.is_finite())
            .map(Goal::Target)
            .ok_or_else(|| {
                format!(
                    "--goal '{s}': expected target=VALUE (e.g. target=38.65), minimize or maximize"
                )
            })
    }
}

/// `demcal surrogate optimize --target-of RESPONSE --value LAB`: the column minimised is the
/// relative error of the response column against the lab value, |response - lab| / |lab|, as a
/// fraction or in % (checked against the table). The surrogate models the response and the
/// error is computed from its prediction.
#[derive(Clone, Debug, PartialEq)]
pub struct ErrorOf {
    pub response: String,
    pub lab: f64,
}

/// A fitted surrogate over the table's factors.
pub struct Fitted {
    pub factors: Vec<String>,
    /// Each factor column's observed minimum and maximum: coded -1 and +1.
    pub ranges: Vec<(f64, f64)>,
    pub model: Model,
    predictor: Predictor,
    pub train: Vec<usize>,
    /// Rows a network's early stopping watched (none for a GP).
    pub validation: Vec<usize>,
    pub test: Vec<usize>,
    pub metrics_train: FitMetrics,
    pub metrics_validation: FitMetrics,
    pub metrics_test: FitMetrics,
    pub metrics_all: FitMetrics,
    /// Facts about the model for people (length scales, noise, epochs).
    pub details: serde_json::Value,
    /// The response's smallest observed value: at 0 or above, a prediction below 0 is the
    /// model's, not the data's.
    pub observed_min: f64,
}

enum Predictor {
    Gp(Box<Gp>),
    Network(Box<network::Network>),
}

impl Fitted {
    /// The prediction at coded inputs.
    pub fn predict_coded(&self, c: &[f64]) -> f64 {
        match &self.predictor {
            Predictor::Gp(g) => g.predict_mean(c),
            Predictor::Network(n) => n.predict(c),
        }
    }

    /// The prediction at actual (uncoded) inputs with its variance: a GP's posterior variance
    /// of the mean (noise not included), a network ensemble's variance across its members, and
    /// `None` for a single network, which has none.
    pub fn predict_actual(&self, actual: &[f64]) -> (f64, Option<f64>) {
        let c = self.to_coded(actual);
        match &self.predictor {
            Predictor::Gp(g) => {
                let (m, v) = g.predict(&c);
                (m, Some(v))
            }
            Predictor::Network(n) => {
                let members = n.member_predictions(&c);
                let mean = n.predict(&c);
                if members.len() < 2 {
                    return (mean, None);
                }
                let k = members.len() as f64;
                let mu = members.iter().sum::<f64>() / k;
                let var = members.iter().map(|y| (y - mu).powi(2)).sum::<f64>() / (k - 1.0);
                (mean, Some(var))
            }
        }
    }

    /// Actual inputs mapped onto the coded box (the observed minimum -1, maximum +1).
    pub fn to_coded(&self, actual: &[f64]) -> Vec<f64> {
        actual
            .iter()
            .zip(&self.ranges)
            .map(|(v, (lo, hi))| {
                if hi > lo {
                    (v - 0.5 * (lo + hi)) / (0.5 * (hi - lo))
                } else {
                    0.0
                }
            })
            .collect()
    }

    pub fn to_actual(&self, c: &[f64]) -> Vec<f64> {
        c.iter()
            .zip(&self.ranges)
            .map(|(v, (lo, hi))| 0.5 * (lo + hi) + v * 0.5 * (hi - lo))
            .collect()
    }
}

/// Reads the table and fits the model.
pub fn fit_model(req: &FitRequest) -> Result<Fitted, String> {
    fit_table(req, &DataTable::read(&req.data)?)
}

/// Fits the model on a table already read (the Python API's data frames); `req.data` is not
/// read.
pub fn fit_table(req: &FitRequest, table: &DataTable) -> Result<Fitted, String> {
    fit_on(req, table, &[])
}

/// Fits the model of `req.response` on `table`; `not_factors` are columns that are not factors
/// by default either (an error column computed from the response).
fn fit_on(req: &FitRequest, table: &DataTable, not_factors: &[String]) -> Result<Fitted, String> {
    let source = req.data.display().to_string();
    let y = table.column(&req.response)?;
    let factors = match &req.factors {
        Some(f) if !f.is_empty() => f.clone(),
        _ => {
            let mut responses = vec![req.response.clone()];
            responses.extend(not_factors.iter().cloned());
            table.default_factor_columns(&responses)
        }
    };
    if factors.is_empty() {
        return Err(format!(
            "{source}: no factor columns besides '{}'; name them with --factors A,B,...",
            req.response
        ));
    }
    if factors.contains(&req.response) {
        return Err(format!(
            "--factors: '{}' is the response; a factor cannot be the response",
            req.response
        ));
    }
    let mut ranges = Vec::new();
    let mut cols = Vec::new();
    for f in &factors {
        let c = table.column(f)?;
        let (lo, hi) = c
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
                (a.min(*v), b.max(*v))
            });
        if hi - lo <= 0.0 {
            return Err(format!(
                "{source}: column '{f}' has one value ({lo}) in every row; it cannot be a factor"
            ));
        }
        ranges.push((lo, hi));
        cols.push(c);
    }
    let n = y.len();
    let k = factors.len();
    // As `doe analyze` refuses it: a constant has nothing to learn.
    if let Some(&first) = y.first() {
        if y.iter().all(|&v| v == first) {
            return Err(format!(
                "{source}: the response is {first} in all {n} rows; there is nothing to model"
            ));
        }
    }
    if n < k + 3 {
        return Err(format!(
            "{source}: {n} rows for {k} factors; a surrogate needs at least {} to train and test on",
            k + 3
        ));
    }
    let x: Vec<Vec<f64>> = (0..n)
        .map(|i| {
            (0..k)
                .map(|j| {
                    let (lo, hi) = ranges[j];
                    (cols[j][i] - 0.5 * (lo + hi)) / (0.5 * (hi - lo))
                })
                .collect()
        })
        .collect();
    let (predictor, train, validation, test, details) = match req.model {
        Model::Gp(kernel) => {
            let (train, test) = split_stratified(&y, req.train_fraction, req.seed);
            let xt: Vec<Vec<f64>> = train.iter().map(|&i| x[i].clone()).collect();
            let yt: Vec<f64> = train.iter().map(|&i| y[i]).collect();
            let gp = Gp::fit(
                &xt,
                &yt,
                &GpOptions {
                    kernel,
                    seed: req.seed,
                    ..GpOptions::default()
                },
            )
            .map_err(|e| format!("{source}: {e}"))?;
            let details = json!({
                "kernel": kernel.name(),
                "length_scales": factors.iter().zip(gp.length_scales()).map(|(f, l)| (f.clone(), json!(l))).collect::<serde_json::Map<_, _>>(),
                "signal_variance": gp.signal_variance(),
                "noise_variance": gp.noise_variance(),
                "mean": gp.mean(),
                "log_marginal_likelihood": gp.log_marginal_likelihood(),
            });
            (
                Predictor::Gp(Box::new(gp)),
                train,
                Vec::new(),
                test,
                details,
            )
        }
        Model::Bp | Model::GaBp => {
            let trained = network::train(
                &x,
                &y,
                &BpOptions {
                    train_fraction: req.train_fraction,
                    seed: req.seed,
                    ga: (req.model == Model::GaBp).then(|| GaOptions::weights_default(req.seed)),
                    ensemble: 10,
                    ..BpOptions::default()
                },
            )
            .map_err(|e| format!("{source}: {e}"))?;
            let details = json!({
                "inputs": trained.network.inputs(),
                "hidden": trained.network.hidden(),
                "epochs": trained.epochs,
                "ga_generations": trained.ga_history.len(),
            });
            (
                Predictor::Network(Box::new(trained.network)),
                trained.train,
                trained.validation,
                trained.test,
                details,
            )
        }
    };
    let predict = |c: &[f64]| match &predictor {
        Predictor::Gp(g) => g.predict_mean(c),
        Predictor::Network(n) => n.predict(c),
    };
    let metrics = |rows: &[usize]| {
        let obs: Vec<f64> = rows.iter().map(|&i| y[i]).collect();
        let pred: Vec<f64> = rows.iter().map(|&i| predict(&x[i])).collect();
        FitMetrics::of(&obs, &pred)
    };
    let all: Vec<usize> = (0..n).collect();
    let (metrics_train, metrics_validation, metrics_test, metrics_all) = (
        metrics(&train),
        metrics(&validation),
        metrics(&test),
        metrics(&all),
    );
    let observed_min = y.iter().copied().fold(f64::INFINITY, f64::min);
    Ok(Fitted {
        observed_min,
        factors,
        ranges,
        model: req.model,
        predictor,
        train,
        validation,
        test,
        metrics_train,
        metrics_validation,
        metrics_test,
        metrics_all,
        details,
    })
}

fn metrics_json(f: &Fitted) -> serde_json::Map<String, serde_json::Value> {
    let mut m = serde_json::Map::new();
    for (name, v) in [
        ("train", &f.metrics_train),
        ("validation", &f.metrics_validation),
        ("test", &f.metrics_test),
        ("all", &f.metrics_all),
    ] {
        if v.n == 0 {
            continue;
        }
        m.insert(format!("r2_{name}"), json!(v.r2));
        m.insert(format!("rmse_{name}"), json!(v.rmse));
        m.insert(format!("mae_{name}"), json!(v.mae));
        m.insert(format!("n_{name}"), json!(v.n));
    }
    m
}

fn metrics_text(out: &mut String, f: &Fitted) {
    writeln!(
        out,
        "{:<10} {:>4} {:>9} {:>11} {:>11}",
        "rows", "n", "R^2", "RMSE", "MAE"
    )
    .unwrap();
    for (name, v) in [
        ("training", &f.metrics_train),
        ("validation", &f.metrics_validation),
        ("test", &f.metrics_test),
        ("all", &f.metrics_all),
    ] {
        if v.n == 0 {
            continue;
        }
        writeln!(
            out,
            "{name:<10} {:>4} {:>9.4} {:>11.5} {:>11.5}",
            v.n, v.r2, v.rmse, v.mae
        )
        .unwrap();
    }
}

/// `demcal surrogate fit`.
pub fn fit(req: &FitRequest, json_out: bool) -> Result<String, String> {
    fit_on_table(req, &DataTable::read(&req.data)?, json_out)
}

/// [`fit`] on a table already read.
pub fn fit_on_table(req: &FitRequest, table: &DataTable, json_out: bool) -> Result<String, String> {
    let f = fit_table(req, table)?;
    if json_out {
        return Ok(serde_json::to_string_pretty(&fitted_json(&f, req)).unwrap() + "\n");
    }
    let mut out = String::new();
    writeln!(
        out,
        "{} surrogate of {} on {} ({} rows: {} training, {} validation, {} test; seed {})",
        f.model.name(),
        req.response,
        f.factors.join(", "),
        f.metrics_all.n,
        f.train.len(),
        f.validation.len(),
        f.test.len(),
        req.seed
    )
    .unwrap();
    metrics_text(&mut out, &f);
    writeln!(out, "model: {}", f.details).unwrap();
    Ok(out)
}

/// What `surrogate fit --json` prints of a fitted model: its metrics on each share of the rows,
/// the rows, and facts about the model.
pub fn fitted_json(f: &Fitted, req: &FitRequest) -> serde_json::Value {
    let mut m = metrics_json(f);
    m.insert("model".into(), json!(f.model.name()));
    m.insert("response".into(), json!(req.response));
    m.insert("factors".into(), json!(f.factors));
    m.insert("seed".into(), json!(req.seed));
    m.insert(
        "train_rows".into(),
        json!(f.train.iter().map(|i| i + 1).collect::<Vec<_>>()),
    );
    m.insert(
        "test_rows".into(),
        json!(f.test.iter().map(|i| i + 1).collect::<Vec<_>>()),
    );
    m.insert("details".into(), f.details.clone());
    serde_json::Value::Object(m)
}

/// A number as people write it: 38.65, but 1e308 rather than 309 digits.
fn plain(v: f64) -> String {
    if v != 0.0 && !(1e-4..1e6).contains(&v.abs()) {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}

/// Where the search ended: the settings, and what the model says there.
struct Answer {
    /// The coded and actual settings.
    best: Vec<f64>,
    generations: usize,
    /// The prediction reported for the column searched (the error, with `--target-of`).
    predicted: f64,
    /// A target (or, with `--target-of`, the lab value) the model does not come within 1 % of.
    missed: Option<f64>,
    /// More to say (a clamped prediction, the modelled response), and the same for JSON.
    lines: Vec<String>,
    json: serde_json::Map<String, serde_json::Value>,
}

/// `demcal surrogate optimize`: fits, then searches the model with a genetic algorithm (for a
/// GA-BP network this is GA-BP-GA) inside the table's factor ranges. With `error_of`, the column
/// minimised is an error of a response column: the response is modelled instead ([`ErrorOf`]).
pub fn optimize(
    req: &FitRequest,
    goal: Goal,
    error_of: Option<&ErrorOf>,
    json_out: bool,
) -> Result<String, String> {
    optimize_table(req, &DataTable::read(&req.data)?, goal, error_of, json_out)
}

/// [`optimize`] on a table already read.
pub fn optimize_table(
    req: &FitRequest,
    table: &DataTable,
    goal: Goal,
    error_of: Option<&ErrorOf>,
    json_out: bool,
) -> Result<String, String> {
    let opts = GaOptions::search_default(req.seed);
    let (f, answer, goal_text) = match error_of {
        None => {
            let f = fit_table(req, table)?;
            let answer = search_column(&f, req, goal, &opts)?;
            (f, answer, goal_name(goal))
        }
        Some(e) => {
            if goal != Goal::Minimize {
                return Err(format!(
                    "--target-of {}: the error of {} is minimised; give --goal minimize",
                    e.response, e.response
                ));
            }
            let (f, answer) = search_error_of(req, table, e, &opts)?;
            (f, answer, goal_name(goal))
        }
    };
    let actual = f.to_actual(&answer.best);
    if json_out {
        let mut m = metrics_json(&f);
        m.insert("model".into(), json!(f.model.name()));
        m.insert("response".into(), json!(req.response));
        m.insert("goal".into(), json!(goal_text));
        m.insert(
            "solution".into(),
            json!(f
                .factors
                .iter()
                .zip(&actual)
                .map(|(n, v)| (n.clone(), json!(v)))
                .collect::<serde_json::Map<_, _>>()),
        );
        m.insert("predicted".into(), json!(answer.predicted));
        m.insert("target_reached".into(), json!(answer.missed.is_none()));
        m.insert("generations".into(), json!(answer.generations));
        m.extend(answer.json);
        return Ok(serde_json::to_string_pretty(&serde_json::Value::Object(m)).unwrap() + "\n");
    }
    let mut out = String::new();
    let modelled = match (error_of, answer.json.get("error_formula")) {
        (Some(e), Some(formula)) => format!(
            "{}, for {} = {}",
            e.response,
            req.response,
            formula.as_str().unwrap_or_default()
        ),
        _ => req.response.clone(),
    };
    writeln!(
        out,
        "{} surrogate of {modelled} ({goal_text}), searched by a genetic algorithm ({} generations of {})",
        f.model.name(),
        opts.generations,
        opts.population
    )
    .unwrap();
    metrics_text(&mut out, &f);
    for (n, v) in f.factors.iter().zip(&actual) {
        writeln!(out, "  {n} = {v:.6}").unwrap();
    }
    writeln!(out, "predicted {} = {:.6}", req.response, answer.predicted).unwrap();
    for line in &answer.lines {
        writeln!(out, "{line}").unwrap();
    }
    Ok(out)
}

fn goal_name(goal: Goal) -> String {
    match goal {
        Goal::Target(t) => format!("target {}", plain(t)),
        Goal::Minimize => "minimize".into(),
        Goal::Maximize => "maximize".into(),
    }
}

/// The search on the model of the column itself. When every observed value is >= 0 (an error,
/// an MSE) a prediction below 0 is read as 0. A minimum is still searched on the model as it is,
/// so that the answer is where the model is lowest rather than any point of the plateau the
/// clamp makes; the clamp is said.
fn search_column(
    f: &Fitted,
    req: &FitRequest,
    goal: Goal,
    opts: &GaOptions,
) -> Result<Answer, String> {
    let clamp = f.observed_min >= 0.0;
    let model = |c: &[f64]| {
        let p = f.predict_coded(c);
        if clamp {
            p.max(0.0)
        } else {
            p
        }
    };
    let bounds = vec![(-1.0, 1.0); f.factors.len()];
    let found = genetic::minimize(
        &bounds,
        |c| match goal {
            Goal::Target(t) => (model(c) - t).abs(),
            Goal::Minimize => f.predict_coded(c),
            Goal::Maximize => -model(c),
        },
        opts,
    )?;
    let raw = f.predict_coded(&found.best);
    let predicted = model(&found.best);
    let mut lines = Vec::new();
    let mut json = serde_json::Map::new();
    json.insert("model_prediction".into(), json!(raw));
    json.insert("clamped_at_zero".into(), json!(predicted != raw));
    if predicted != raw {
        lines.push(format!(
            "the model predicts {raw:.6} here, but {} is never below 0 in the table (its least value is {:.6}): reported as 0. A minimum below the data is often the model's own, at an edge of the ranges; to minimise an error, model its response instead: --target-of RESPONSE --value LAB",
            req.response,
            f.observed_min
        ));
    }
    // A target the surrogate cannot reach inside the data's ranges is said so, not passed off
    // as found (target=1e308 printed its nearest prediction without a word).
    let missed = match goal {
        Goal::Target(t) if (predicted - t).abs() > 0.01 * t.abs().max(1e-9) => Some(t),
        _ => None,
    };
    if let Some(t) = missed {
        lines.push(format!(
            "the target {} is not reached within the factors' ranges: this is the nearest prediction, {} from it",
            plain(t),
            plain((predicted - t).abs())
        ));
    }
    Ok(Answer {
        best: found.best,
        generations: found.history.len(),
        predicted,
        missed,
        lines,
        json,
    })
}

/// `--target-of`: fits the response, checks that the column minimised is its relative error
/// against the lab value (as a fraction or in %), and searches for the settings whose predicted
/// response comes nearest the lab value; the error reported is computed from that prediction.
fn search_error_of(
    req: &FitRequest,
    table: &DataTable,
    e: &ErrorOf,
    opts: &GaOptions,
) -> Result<(Fitted, Answer), String> {
    if !e.lab.is_normal() {
        return Err(format!(
            "--value {}: expected a non-zero lab value (the relative error divides by it)",
            e.lab
        ));
    }
    if e.response == req.response {
        return Err(format!(
            "--target-of {}: that is --response itself; name the response column the error of --response is computed from",
            e.response
        ));
    }
    let scale = error_scale(table, &req.response, e)?;
    if req
        .factors
        .as_ref()
        .is_some_and(|f| f.contains(&req.response))
    {
        return Err(format!(
            "--factors: '{}' is the error minimised; it cannot be a factor",
            req.response
        ));
    }
    let modelled = FitRequest {
        response: e.response.clone(),
        ..req.clone()
    };
    let f = fit_on(&modelled, table, std::slice::from_ref(&req.response))?;
    let bounds = vec![(-1.0, 1.0); f.factors.len()];
    let found = genetic::minimize(&bounds, |c| (f.predict_coded(c) - e.lab).abs(), opts)?;
    let response = f.predict_coded(&found.best);
    let predicted = scale * (response - e.lab).abs() / e.lab.abs();
    let formula = format!(
        "|{} - {}| / {}{}",
        e.response,
        plain(e.lab),
        plain(e.lab.abs()),
        if scale == 100.0 { " x 100" } else { "" }
    );
    let mut lines = vec![format!(
        "predicted {} = {response:.6} (the model is of {}, and the scores above; {} is computed from it)",
        e.response, e.response, req.response
    )];
    let missed = ((response - e.lab).abs() > 0.01 * e.lab.abs()).then_some(e.lab);
    if missed.is_some() {
        lines.push(format!(
            "the lab value {} is not reached within the factors' ranges: this is the nearest prediction",
            plain(e.lab)
        ));
    }
    let mut json = serde_json::Map::new();
    json.insert("modelled".into(), json!(e.response));
    json.insert("lab".into(), json!(e.lab));
    json.insert("predicted_response".into(), json!(response));
    json.insert("error_formula".into(), json!(formula));
    let answer = Answer {
        best: found.best,
        generations: found.history.len(),
        predicted,
        missed,
        lines,
        json,
    };
    Ok((f, answer))
}

/// Whether the table's `error` column is |response - lab| / |lab| (1) or that in % (100): each
/// row must agree within 1 % of the column's largest value (tables round their numbers). The
/// error names the row that agrees least, so a wrong lab value or column is caught before any
/// search.
fn error_scale(table: &DataTable, error: &str, e: &ErrorOf) -> Result<f64, String> {
    let errors = table.column(error)?;
    let response = table.column(&e.response)?;
    let fraction: Vec<f64> = response
        .iter()
        .map(|r| (r - e.lab).abs() / e.lab.abs())
        .collect();
    let tol = 0.01 * errors.iter().fold(0.0f64, |m, v| m.max(v.abs())) + 1e-12;
    // The row furthest from the formula at each scale: (scale, row, distance).
    let worst = [1.0, 100.0].map(|scale| {
        let (i, d) = errors
            .iter()
            .zip(&fraction)
            .map(|(v, f)| (v - scale * f).abs())
            .enumerate()
            .fold((0, 0.0f64), |w, (i, d)| if d > w.1 { (i, d) } else { w });
        (scale, i, d)
    });
    let (scale, i, d) = if worst[0].2 <= worst[1].2 {
        worst[0]
    } else {
        worst[1]
    };
    if d <= tol {
        return Ok(scale);
    }
    Err(format!(
        "--target-of {} --value {}: column '{error}' is not |{} - {}| / {} (as a fraction or in %): row {} has {} where that gives {}{}",
        e.response,
        plain(e.lab),
        e.response,
        plain(e.lab),
        plain(e.lab.abs()),
        i + 1,
        plain(errors[i]),
        plain(scale * fraction[i]),
        if scale == 100.0 { " (in %)" } else { "" }
    ))
}
