//! `demcal surrogate fit` and `demcal surrogate optimize`: a surrogate trained on a user's own
//! result table (an EDEM design's CSV), as `demcal doe analyze` fits a polynomial to one.
//!
//! Factor columns are mapped onto [-1, 1] by their observed minimum and maximum (what MATLAB's
//! `mapminmax` does before a BP network, and the box a GP's length scales are read in), so the
//! search stays inside the ranges the table covers.

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

    pub fn to_actual(&self, c: &[f64]) -> Vec<f64> {
        c.iter()
            .zip(&self.ranges)
            .map(|(v, (lo, hi))| 0.5 * (lo + hi) + v * 0.5 * (hi - lo))
            .collect()
    }
}

/// Reads the table and fits the model.
pub fn fit_model(req: &FitRequest) -> Result<Fitted, String> {
    let table = DataTable::read(&req.data)?;
    let source = req.data.display().to_string();
    let y = table.column(&req.response)?;
    let factors = match &req.factors {
        Some(f) if !f.is_empty() => f.clone(),
        _ => table.default_factor_columns(std::slice::from_ref(&req.response)),
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
    Ok(Fitted {
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
    let f = fit_model(req)?;
    if json_out {
        let mut m = metrics_json(&f);
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
        return Ok(serde_json::to_string_pretty(&serde_json::Value::Object(m)).unwrap() + "\n");
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

/// `demcal surrogate optimize`: fits, then searches the model with a genetic algorithm (for a
/// GA-BP network this is GA-BP-GA) inside the table's factor ranges.
/// A number as people write it: 38.65, but 1e308 rather than 309 digits.
fn plain(v: f64) -> String {
    if v != 0.0 && !(1e-4..1e6).contains(&v.abs()) {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}

pub fn optimize(req: &FitRequest, goal: Goal, json_out: bool) -> Result<String, String> {
    let f = fit_model(req)?;
    let k = f.factors.len();
    let bounds = vec![(-1.0, 1.0); k];
    let opts = GaOptions::search_default(req.seed);
    let found = genetic::minimize(
        &bounds,
        |c| {
            let p = f.predict_coded(c);
            match goal {
                Goal::Target(t) => (p - t).abs(),
                Goal::Minimize => p,
                Goal::Maximize => -p,
            }
        },
        &opts,
    )?;
    let predicted = f.predict_coded(&found.best);
    let actual = f.to_actual(&found.best);
    let goal_text = match goal {
        Goal::Target(t) => format!("target {}", plain(t)),
        Goal::Minimize => "minimize".into(),
        Goal::Maximize => "maximize".into(),
    };
    // A target the surrogate cannot reach inside the data's ranges is said so, not passed off
    // as found (target=1e308 printed its nearest prediction without a word).
    let missed = match goal {
        Goal::Target(t) if (predicted - t).abs() > 0.01 * t.abs().max(1e-9) => Some(t),
        _ => None,
    };
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
        m.insert("predicted".into(), json!(predicted));
        m.insert("target_reached".into(), json!(missed.is_none()));
        m.insert("generations".into(), json!(found.history.len()));
        return Ok(serde_json::to_string_pretty(&serde_json::Value::Object(m)).unwrap() + "\n");
    }
    let mut out = String::new();
    writeln!(
        out,
        "{} surrogate of {} ({goal_text}), searched by a genetic algorithm ({} generations of {})",
        f.model.name(),
        req.response,
        opts.generations,
        opts.population
    )
    .unwrap();
    metrics_text(&mut out, &f);
    for (n, v) in f.factors.iter().zip(&actual) {
        writeln!(out, "  {n} = {v:.6}").unwrap();
    }
    writeln!(out, "predicted {} = {predicted:.6}", req.response).unwrap();
    if let Some(t) = missed {
        writeln!(
            out,
            "the target {} is not reached within the factors' ranges: this is the nearest prediction, {} from it",
            plain(t),
            plain((predicted - t).abs())
        )
        .unwrap();
    }
    Ok(out)
}
