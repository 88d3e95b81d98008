//! The BP network of the GA-BP papers: one hidden layer of tansig (tanh) neurons, 2n+1 of them
//! for n inputs, and a linear output; inputs and output min-max normalised to [-1, 1] with the
//! training rows' minimum and maximum (MATLAB's `mapminmax`); Levenberg-Marquardt training;
//! optionally a genetic algorithm for the initial weights (GA-BP) and a second one for the
//! inputs whose prediction is the lab value (GA-BP-GA, [`search_target`]).
//!
//! Generalisation. A 3-7-1 network has 36 weights and the silage CCD (23 runs, 9 of them centre
//! points spreading 36.8 to 41 deg) leaves 18 rows once 20 % are held out for testing, so plain
//! least squares interpolates the training rows, pure error included. The default is MATLAB's
//! own default for `trainlm`, which the published method (training, validation, test and all
//! data) follows: a validation slice of the non-test rows (`validation_fraction` 0.2, stratified
//! on the response like the test rows: 4 of the 18), Levenberg-Marquardt on the training rows'
//! squared error, stop after `max_fail` = 6 epochs without a new lowest validation error and
//! keep the weights of the lowest. `ensemble` > 1 averages that many such networks, each with
//! its own validation slice, GA seed and initial weights (bagging); the test rows are the same
//! for all.
//!
//! What we measured (GA-BP with the published GA settings, split seeds 0..20, test R^2 >= 0.8
//! on the 5 stratified test rows; `survey_variants` in tests/ga_bp.rs):
//! - trainbr's Bayesian regularisation (`bayesian`, no validation rows), the previous default:
//!   2/20. gamma settles near 10, but the GA's weights already interpolate the training rows and
//!   the evidence keeps them (train R^2 0.97, test RMSE 4 deg against 0.9 in training).
//! - early stopping, one network: 6/20 (LM stops within a few epochs: the GA has already fitted
//!   the 14 training rows, and the validation slice of 4 rows picks among overfitted weights).
//!   With Bayesian regularisation as well: 6/20.
//! - early stopping, ensemble of 10: 9/20 (kept as the acceptance configuration).
//! - weight decay chosen by 6-fold cross-validation on the training rows (`cv_folds`): 7/20.
//! - for scale, least squares on the same 18 rows: linear 11/20, the ANOVA-supported reduced
//!   quadratic (D, E, G, D^2, G^2) 10/20, the full quadratic 2/20; the reduced quadratic fitted
//!   to all 23 rows scores 19/20 on the same test rows. So a majority of splits is out of reach
//!   of any model fitted to 18 of these rows: the stratified test rows hold the extreme
//!   responses, i.e. the axial points, one per factor and sign, and taking one out leaves that
//!   curvature to extrapolation. A fixed weight decay of 0.3 scored 10/20, but that value was
//!   picked by looking at test R^2, so it is not the default.

use nalgebra::{DMatrix, DVector};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use serde::Serialize;

use crate::genetic::{self, GaOptions, GaResult};
use crate::metrics::{split_stratified, FitMetrics};

/// Levenberg-Marquardt damping: MATLAB's defaults (start, decrease, increase, give up).
const MU_INIT: f64 = 0.005;
const MU_DEC: f64 = 0.1;
const MU_INC: f64 = 10.0;
const MU_MAX: f64 = 1e10;
/// Stop when the gradient of the regularised objective is this small (MATLAB's `min_grad`).
const MIN_GRAD: f64 = 1e-7;
/// GA-BP searches initial weights in [-W, W] per weight, the box of the published GA-BP code;
/// inputs and output are normalised to [-1, 1], so tanh units in this range span from linear
/// to saturated.
const GA_WEIGHT_BOUND: f64 = 3.0;

/// Min-max mapping of one variable to [-1, 1] (MATLAB `mapminmax`). A variable that is
/// constant in the training rows maps to 0: it carries no information to learn from.
#[derive(Clone, Copy, Debug, Serialize)]
struct MinMax {
    min: f64,
    max: f64,
}

impl MinMax {
    fn of(values: impl Iterator<Item = f64>) -> MinMax {
        let (min, max) = values.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
        MinMax { min, max }
    }

    fn normalise(&self, v: f64) -> f64 {
        if self.max > self.min {
            2.0 * (v - self.min) / (self.max - self.min) - 1.0
        } else {
            0.0
        }
    }

    fn denormalise(&self, u: f64) -> f64 {
        if self.max > self.min {
            self.min + (u + 1.0) * 0.5 * (self.max - self.min)
        } else {
            self.min
        }
    }
}

/// A trained n-h-1 network with its normalisation.
///
/// Weights are stored flat, in the order the Jacobian uses: for each hidden neuron j its n
/// input weights then its bias, then the h output weights, then the output bias.
#[derive(Clone, Debug, Serialize)]
pub struct Network {
    n: usize,
    h: usize,
    weights: Vec<f64>,
    /// Further members of an ensemble; the prediction averages them with `weights`.
    members: Vec<Vec<f64>>,
    x_norm: Vec<MinMax>,
    y_norm: MinMax,
}

impl Network {
    fn parameter_count(n: usize, h: usize) -> usize {
        h * (n + 1) + h + 1
    }

    /// The prediction for inputs `x` in the data's own units, in the output's units; NaN when
    /// `x` has the wrong length.
    pub fn predict(&self, x: &[f64]) -> f64 {
        if x.len() != self.n {
            return f64::NAN;
        }
        let u: Vec<f64> = x
            .iter()
            .zip(&self.x_norm)
            .map(|(&v, m)| m.normalise(v))
            .collect();
        let sum: f64 = std::iter::once(&self.weights)
            .chain(&self.members)
            .map(|w| forward(self.n, self.h, w, &u))
            .sum();
        self.y_norm
            .denormalise(sum / (1 + self.members.len()) as f64)
    }

    pub fn inputs(&self) -> usize {
        self.n
    }

    /// How many networks the prediction averages (1 without an ensemble).
    pub fn members(&self) -> usize {
        1 + self.members.len()
    }

    /// Each member's prediction at `x`, in the output's units: their spread is how much the
    /// ensemble's answer depends on which rows and seeds each member was trained on. Empty when
    /// `x` has the wrong length.
    pub fn member_predictions(&self, x: &[f64]) -> Vec<f64> {
        if x.len() != self.n {
            return Vec::new();
        }
        let u: Vec<f64> = x
            .iter()
            .zip(&self.x_norm)
            .map(|(&v, m)| m.normalise(v))
            .collect();
        std::iter::once(&self.weights)
            .chain(&self.members)
            .map(|w| self.y_norm.denormalise(forward(self.n, self.h, w, &u)))
            .collect()
    }

    pub fn hidden(&self) -> usize {
        self.h
    }

    /// The weights and biases in normalised units, in the layout described on [`Network`].
    pub fn weights(&self) -> &[f64] {
        &self.weights
    }
}

/// The network's output in normalised units for normalised inputs `u`.
fn forward(n: usize, h: usize, w: &[f64], u: &[f64]) -> f64 {
    let out = &w[h * (n + 1)..];
    let mut y = out[h];
    for j in 0..h {
        let row = &w[j * (n + 1)..(j + 1) * (n + 1)];
        let z = row[n] + row[..n].iter().zip(u).map(|(a, b)| a * b).sum::<f64>();
        y += out[j] * z.tanh();
    }
    y
}

/// Output and its gradient with respect to every weight (backpropagation for one sample),
/// written into `grad`.
fn forward_grad(n: usize, h: usize, w: &[f64], u: &[f64], grad: &mut [f64]) -> f64 {
    let out_at = h * (n + 1);
    let mut y = w[out_at + h];
    for j in 0..h {
        let row = &w[j * (n + 1)..(j + 1) * (n + 1)];
        let z = row[n] + row[..n].iter().zip(u).map(|(a, b)| a * b).sum::<f64>();
        let a = z.tanh();
        let v = w[out_at + j];
        y += v * a;
        // d y / d z_j = v_j (1 - a_j^2), then by the chain rule to the input weights and bias.
        let dz = v * (1.0 - a * a);
        for k in 0..n {
            grad[j * (n + 1) + k] = dz * u[k];
        }
        grad[j * (n + 1) + n] = dz;
        grad[out_at + j] = a;
    }
    grad[out_at + h] = 1.0;
    y
}

/// Settings of BP (and GA-BP) training.
#[derive(Clone, Debug)]
pub struct BpOptions {
    /// Hidden neurons; None for 2n+1.
    pub hidden: Option<usize>,
    /// Levenberg-Marquardt epochs at most.
    pub max_epochs: usize,
    /// Stop once the training mean squared error in normalised units ([-1, 1] output) is at or
    /// below this (0 to run until the other criteria stop it).
    pub goal_mse: f64,
    /// Share of the rows used for training; the rest are the test rows.
    pub train_fraction: f64,
    /// Seeds the train/test split and the initial weights of plain BP.
    pub seed: u64,
    /// Some for GA-BP: a genetic algorithm picks the initial weights.
    pub ga: Option<GaOptions>,
    /// Share of the non-test rows held out as validation rows for early stopping (stratified
    /// on the response like the test rows); 0 for no validation rows and no early stopping.
    pub validation_fraction: f64,
    /// Early stopping: training stops after this many epochs in a row without a new lowest
    /// validation error (MATLAB's `max_fail`) and keeps the weights of the lowest.
    pub max_fail: usize,
    /// Minimise trainbr's Bayesian-regularised objective (true) or the plain sum of squared
    /// errors of trainlm (false).
    pub bayesian: bool,
    /// A fixed weight decay: Levenberg-Marquardt minimises E_D + weight_decay E_W (normalised
    /// units) instead of the objective `bayesian` picks; the GA-BP fitness stays the training
    /// MSE.
    pub weight_decay: Option<f64>,
    /// Above 1: the weight decay is chosen by `cv_folds`-fold cross-validation on the training
    /// rows only (see [`DECAY_GRID`]), overriding `weight_decay`.
    pub cv_folds: usize,
    /// Networks averaged (bagging over validation slices and GA seeds); 1 for one network.
    pub ensemble: usize,
}

impl Default for BpOptions {
    fn default() -> Self {
        BpOptions {
            hidden: None,
            max_epochs: 1000,
            goal_mse: 0.0,
            train_fraction: 0.8,
            seed: 0,
            ga: None,
            validation_fraction: 0.2,
            max_fail: 6,
            bayesian: false,
            weight_decay: None,
            cv_folds: 0,
            ensemble: 1,
        }
    }
}

/// A trained network with its split, goodness of fit and training history.
#[derive(Clone, Debug, Serialize)]
pub struct TrainedNetwork {
    pub network: Network,
    /// Rows used for training and for testing (sorted).
    pub train: Vec<usize>,
    pub test: Vec<usize>,
    /// Rows held out of training for early stopping (sorted; empty without early stopping).
    pub validation: Vec<usize>,
    pub metrics_train: FitMetrics,
    pub metrics_test: FitMetrics,
    /// Fit on the validation rows (all NaN without them).
    pub metrics_validation: FitMetrics,
    pub metrics_all: FitMetrics,
    /// GA-BP: the GA's best training MSE (normalised units) after each generation; empty for
    /// plain BP.
    pub ga_history: Vec<f64>,
    /// Levenberg-Marquardt epochs run.
    pub epochs: usize,
    /// The prediction for every row, in row order, for regression plots.
    pub predictions: Vec<f64>,
    /// Effective number of parameters at the end of training (Bayesian regularisation's gamma).
    pub effective_parameters: f64,
}

/// Trains a BP network (GA-BP when `opts.ga` is set) on rows `x` with responses `y`.
///
/// Errors on fewer than 3 rows, rows of different lengths, non-finite values, or bad options.
pub fn train(x: &[Vec<f64>], y: &[f64], opts: &BpOptions) -> Result<TrainedNetwork, String> {
    validate(x, y, opts)?;
    let mut first = train_member(x, y, opts, 0)?;
    if opts.ensemble <= 1 {
        return Ok(first);
    }
    for m in 1..opts.ensemble as u64 {
        let other = train_member(x, y, opts, m)?;
        first.network.members.push(other.network.weights);
        first.epochs += other.epochs;
        first.effective_parameters += other.effective_parameters;
    }
    first.effective_parameters /= opts.ensemble as f64;
    first.predictions = x.iter().map(|row| first.network.predict(row)).collect();
    let metrics = |rows: &[usize]| {
        let obs: Vec<f64> = rows.iter().map(|&i| y[i]).collect();
        let pred: Vec<f64> = rows.iter().map(|&i| first.predictions[i]).collect();
        FitMetrics::of(&obs, &pred)
    };
    first.metrics_train = metrics(&first.train);
    first.metrics_test = metrics(&first.test);
    first.metrics_validation = metrics(&first.validation);
    first.metrics_all = FitMetrics::of(y, &first.predictions);
    Ok(first)
}

/// One network of `train`; `member` varies the validation slice, the GA seed and the initial
/// weights, never the test rows.
fn train_member(
    x: &[Vec<f64>],
    y: &[f64],
    opts: &BpOptions,
    member: u64,
) -> Result<TrainedNetwork, String> {
    let n = x[0].len();
    let h = opts.hidden.unwrap_or(2 * n + 1);
    let (fit_rows, test) = split_stratified(y, opts.train_fraction, opts.seed);
    let (train, validation) = if opts.validation_fraction > 0.0 {
        let yf: Vec<f64> = fit_rows.iter().map(|&i| y[i]).collect();
        let (a, b) = split_stratified(
            &yf,
            1.0 - opts.validation_fraction,
            (opts.seed ^ 0x5851_f42d_4c95_7f2d).wrapping_add(member),
        );
        (
            a.iter().map(|&k| fit_rows[k]).collect::<Vec<_>>(),
            b.iter().map(|&k| fit_rows[k]).collect::<Vec<_>>(),
        )
    } else {
        (fit_rows.clone(), Vec::new())
    };
    if train.len() < 2 {
        return Err(format!(
            "BP: expected at least 2 training rows, got {} (train_fraction {})",
            train.len(),
            opts.train_fraction
        ));
    }

    // Normalised with the training and validation rows (MATLAB normalises before dividing);
    // the test rows never enter.
    let x_norm: Vec<MinMax> = (0..n)
        .map(|k| MinMax::of(fit_rows.iter().map(|&i| x[i][k])))
        .collect();
    let y_norm = MinMax::of(fit_rows.iter().map(|&i| y[i]));
    let norm_rows = |rows: &[usize]| -> (Vec<Vec<f64>>, Vec<f64>) {
        let u = rows
            .iter()
            .map(|&i| {
                x[i].iter()
                    .zip(&x_norm)
                    .map(|(&v, m)| m.normalise(v))
                    .collect()
            })
            .collect();
        (u, rows.iter().map(|&i| y_norm.normalise(y[i])).collect())
    };
    let (u, t) = norm_rows(&train);
    let (uv, tv) = norm_rows(&validation);

    let mut chosen = opts.clone();
    if opts.cv_folds > 1 {
        chosen.weight_decay = Some(cv_decay(n, h, &u, &t, opts));
    }
    let opts = &chosen;
    let p = Network::parameter_count(n, h);
    let (w0, ga_history) = match &opts.ga {
        Some(ga) => {
            let bounds = vec![(-GA_WEIGHT_BOUND, GA_WEIGHT_BOUND); p];
            let ga = &GaOptions {
                seed: ga.seed.wrapping_add(member),
                ..ga.clone()
            };
            let r = genetic::minimize(&bounds, |w| mse(n, h, w, &u, &t), ga)?;
            (r.best, r.history)
        }
        None => (
            initial_weights(n, h, opts.seed.wrapping_add(member << 32)),
            Vec::new(),
        ),
    };

    let fit = levenberg_marquardt(n, h, w0, (&u, &t), (&uv, &tv), opts);
    let network = Network {
        n,
        h,
        weights: fit.weights,
        members: Vec::new(),
        x_norm,
        y_norm,
    };
    let predictions: Vec<f64> = x.iter().map(|row| network.predict(row)).collect();
    let metrics = |rows: &[usize]| {
        let obs: Vec<f64> = rows.iter().map(|&i| y[i]).collect();
        let pred: Vec<f64> = rows.iter().map(|&i| predictions[i]).collect();
        FitMetrics::of(&obs, &pred)
    };
    Ok(TrainedNetwork {
        metrics_train: metrics(&train),
        metrics_test: metrics(&test),
        metrics_validation: metrics(&validation),
        metrics_all: FitMetrics::of(y, &predictions),
        network,
        train,
        test,
        validation,
        ga_history,
        epochs: fit.epochs,
        predictions,
        effective_parameters: fit.gamma,
    })
}

fn validate(x: &[Vec<f64>], y: &[f64], opts: &BpOptions) -> Result<(), String> {
    if x.len() != y.len() {
        return Err(format!(
            "BP: expected as many responses as input rows, got {} rows and {} responses",
            x.len(),
            y.len()
        ));
    }
    if x.len() < 3 {
        return Err(format!(
            "BP: expected at least 3 rows (training and test), got {}",
            x.len()
        ));
    }
    let n = x[0].len();
    if n == 0 {
        return Err("BP: expected at least one input per row, got none".into());
    }
    for (i, row) in x.iter().enumerate() {
        if row.len() != n {
            return Err(format!(
                "BP: expected {n} inputs in every row, got {} in row {i}",
                row.len()
            ));
        }
        if let Some(v) = row.iter().find(|v| !v.is_finite()) {
            return Err(format!("BP: expected finite inputs, got {v} in row {i}"));
        }
    }
    if let Some((i, v)) = y.iter().enumerate().find(|(_, v)| !v.is_finite()) {
        return Err(format!("BP: expected finite responses, got {v} in row {i}"));
    }
    if opts.hidden == Some(0) {
        return Err("BP: expected at least one hidden neuron, got 0".into());
    }
    if !(opts.train_fraction > 0.0 && opts.train_fraction < 1.0) {
        return Err(format!(
            "BP: expected a train_fraction in (0, 1), got {}",
            opts.train_fraction
        ));
    }
    if !(opts.goal_mse.is_finite() && opts.goal_mse >= 0.0) {
        return Err(format!(
            "BP: expected a finite goal_mse >= 0, got {}",
            opts.goal_mse
        ));
    }
    if !(opts.validation_fraction >= 0.0 && opts.validation_fraction < 1.0) {
        return Err(format!(
            "BP: expected a validation_fraction in [0, 1), got {}",
            opts.validation_fraction
        ));
    }
    if let Some(a) = opts.weight_decay {
        if !(a.is_finite() && a >= 0.0) {
            return Err(format!("BP: expected a finite weight_decay >= 0, got {a}"));
        }
    }
    if opts.ensemble == 0 {
        return Err("BP: expected an ensemble of at least one network, got 0".into());
    }
    Ok(())
}

/// Initial weights of plain BP: uniform in [-1, 1] for the output layer, and for the hidden
/// layer Nguyen-Widrow's scaling (MATLAB's `initnw` in spirit), which spreads the hidden
/// neurons' active regions over the normalised input box instead of leaving them all saturated
/// or all linear.
fn initial_weights(n: usize, h: usize, seed: u64) -> Vec<f64> {
    // A different stream from the split's, which uses the same seed.
    let mut rng = Pcg64::seed_from_u64(seed ^ 0x9e37_79b9_7f4a_7c15);
    let p = Network::parameter_count(n, h);
    let mut w: Vec<f64> = (0..p).map(|_| rng.gen_range(-1.0..1.0)).collect();
    let beta = 0.7 * (h as f64).powf(1.0 / n as f64);
    for j in 0..h {
        let row = &mut w[j * (n + 1)..(j + 1) * (n + 1)];
        let norm = row[..n].iter().map(|v| v * v).sum::<f64>().sqrt();
        if norm > 0.0 {
            for v in &mut row[..n] {
                *v *= beta / norm;
            }
        }
        row[n] *= beta;
    }
    w
}

/// Levenberg-Marquardt epochs at most per cross-validation fit.
const CV_EPOCHS: usize = 100;
/// Weight decays tried by cross-validation.
const DECAY_GRID: [f64; 8] = [0.003, 0.01, 0.03, 0.1, 0.3, 1.0, 3.0, 10.0];

/// The weight decay of [`DECAY_GRID`] with the lowest k-fold cross-validated squared error on
/// the training rows (folds stratified on the response: sorted position mod k), plain LM from
/// Nguyen-Widrow initial weights of a few seeds.
fn cv_decay(n: usize, h: usize, u: &[Vec<f64>], t: &[f64], opts: &BpOptions) -> f64 {
    let k = opts.cv_folds.min(t.len());
    let mut order: Vec<usize> = (0..t.len()).collect();
    order.sort_by(|&a, &b| t[a].total_cmp(&t[b]).then(a.cmp(&b)));
    let mut fold = vec![0; t.len()];
    for (pos, &i) in order.iter().enumerate() {
        fold[i] = pos % k;
    }
    let mut best = (f64::INFINITY, DECAY_GRID[0]);
    for &a in &DECAY_GRID {
        let o = BpOptions {
            weight_decay: Some(a),
            bayesian: false,
            max_epochs: opts.max_epochs.min(CV_EPOCHS),
            ..opts.clone()
        };
        let mut err = 0.0;
        for f in 0..k {
            let pick = |inside: bool| -> (Vec<Vec<f64>>, Vec<f64>) {
                (0..t.len())
                    .filter(|&i| (fold[i] == f) != inside)
                    .map(|i| (u[i].clone(), t[i]))
                    .unzip()
            };
            let (ut, tt) = pick(true);
            let (uh, th) = pick(false);
            for r in 0..1u64 {
                let w0 = initial_weights(n, h, opts.seed.wrapping_add(1000 * r + f as u64));
                let fit = levenberg_marquardt(n, h, w0, (&ut, &tt), (&[], &[]), &o);
                err += sse(n, h, &fit.weights, &uh, &th);
            }
        }
        if err < best.0 {
            best = (err, a);
        }
    }
    best.1
}

/// Training mean squared error in normalised units (the GA-BP fitness).
fn mse(n: usize, h: usize, w: &[f64], u: &[Vec<f64>], t: &[f64]) -> f64 {
    sse(n, h, w, u, t) / t.len() as f64
}

fn sse(n: usize, h: usize, w: &[f64], u: &[Vec<f64>], t: &[f64]) -> f64 {
    u.iter()
        .zip(t)
        .map(|(ui, ti)| (ti - forward(n, h, w, ui)).powi(2))
        .sum()
}

struct LmFit {
    weights: Vec<f64>,
    epochs: usize,
    gamma: f64,
}

/// Levenberg-Marquardt on the Bayesian-regularised objective F = beta E_D + alpha E_W, with
/// alpha and beta re-estimated after every epoch as MATLAB's `trainbr` does.
fn levenberg_marquardt(
    n: usize,
    h: usize,
    mut w: Vec<f64>,
    (u, t): (&[Vec<f64>], &[f64]),
    (uv, tv): (&[Vec<f64>], &[f64]),
    opts: &BpOptions,
) -> LmFit {
    let early = !tv.is_empty();
    let mut best_val = if early { sse(n, h, &w, uv, tv) } else { 0.0 };
    let mut best_w = w.clone();
    let mut fails = 0;
    let p = w.len();
    let rows = t.len() as f64;
    let sum_sq = |w: &[f64]| w.iter().map(|v| v * v).sum::<f64>();

    // trainbr's start: gamma = all parameters, then alpha and beta from it.
    let mut e_d = sse(n, h, &w, u, t);
    let mut e_w = sum_sq(&w);
    let mut gamma = p as f64;
    let mut beta = if e_d > 0.0 {
        (rows - gamma) / (2.0 * e_d)
    } else {
        1.0
    };
    if beta <= 0.0 {
        beta = 1.0;
    }
    let mut alpha = if e_w > 0.0 { gamma / (2.0 * e_w) } else { 1.0 };
    if !opts.bayesian || opts.weight_decay.is_some() {
        // trainlm: F = E_D.
        beta = 1.0;
        alpha = opts.weight_decay.unwrap_or(0.0);
    }
    let mut mu = MU_INIT;

    let mut jac = DMatrix::<f64>::zeros(t.len(), p);
    let mut err = DVector::<f64>::zeros(t.len());
    let mut grad_row = vec![0.0; p];
    let mut epochs = 0;
    while epochs < opts.max_epochs {
        if e_d / rows <= opts.goal_mse {
            break;
        }
        for (i, (ui, ti)) in u.iter().zip(t).enumerate() {
            let yi = forward_grad(n, h, &w, ui, &mut grad_row);
            err[i] = ti - yi;
            for (k, g) in grad_row.iter().enumerate() {
                jac[(i, k)] = *g;
            }
        }
        let jtj = jac.transpose() * &jac;
        let wv = DVector::from_column_slice(&w);
        // Descent direction of F/2: beta J^T e - alpha w (J is d output / d w, e = t - output).
        let g = jac.transpose() * &err * beta - &wv * alpha;
        if g.norm() < MIN_GRAD {
            break;
        }
        let f_now = beta * e_d + alpha * e_w;
        let mut accepted = false;
        while mu <= MU_MAX {
            let mut a = &jtj * beta;
            for k in 0..p {
                a[(k, k)] += alpha + mu;
            }
            if let Some(chol) = a.cholesky() {
                let step = chol.solve(&g);
                let trial: Vec<f64> = w.iter().zip(step.iter()).map(|(a, b)| a + b).collect();
                let (ed_t, ew_t) = (sse(n, h, &trial, u, t), sum_sq(&trial));
                let f_trial = beta * ed_t + alpha * ew_t;
                if f_trial.is_finite() && f_trial < f_now {
                    w = trial;
                    e_d = ed_t;
                    e_w = ew_t;
                    mu *= MU_DEC;
                    accepted = true;
                    break;
                }
            }
            mu *= MU_INC;
        }
        epochs += 1;
        if !accepted {
            break;
        }
        if early {
            let v = sse(n, h, &w, uv, tv);
            if v < best_val {
                best_val = v;
                best_w.clone_from(&w);
                fails = 0;
            } else {
                fails += 1;
                if fails >= opts.max_fail {
                    break;
                }
            }
        }
        if !opts.bayesian || opts.weight_decay.is_some() {
            continue;
        }

        // Re-estimate the hyperparameters at the new weights (the Gauss-Newton Hessian at the
        // old ones, as trainbr does; it changes little in one accepted step).
        let mut a = &jtj * beta;
        for k in 0..p {
            a[(k, k)] += alpha;
        }
        if let Some(inv) = a.cholesky().map(|c| c.inverse()) {
            gamma = (p as f64 - alpha * inv.trace()).clamp(0.0, p as f64);
            alpha = if e_w > 0.0 { gamma / (2.0 * e_w) } else { 1.0 };
            // gamma at or above the row count would make beta negative or infinite: keep the
            // last beta until the data support fewer parameters.
            if e_d > 0.0 && rows - gamma > 0.0 {
                beta = (rows - gamma) / (2.0 * e_d);
            }
        }
    }
    if early {
        w = best_w;
    }
    if !opts.bayesian {
        gamma = p as f64;
    }
    LmFit {
        weights: w,
        epochs,
        gamma,
    }
}

/// GA-BP-GA: the inputs within `bounds` whose prediction is `target` (minimises
/// |prediction - target|). `value` in the result is that absolute difference.
pub fn search_target(
    network: &Network,
    bounds: &[(f64, f64)],
    target: f64,
    opts: &GaOptions,
) -> Result<GaResult, String> {
    if bounds.len() != network.inputs() {
        return Err(format!(
            "GA-BP-GA: expected bounds for {} inputs, got {}",
            network.inputs(),
            bounds.len()
        ));
    }
    if !target.is_finite() {
        return Err(format!("GA-BP-GA: expected a finite target, got {target}"));
    }
    genetic::minimize(bounds, |x| (network.predict(x) - target).abs(), opts)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn backprop_gradient_matches_finite_differences() {
        let (n, h) = (3, 4);
        let w = initial_weights(n, h, 5);
        let u = [0.3, -0.7, 0.9];
        let mut g = vec![0.0; w.len()];
        forward_grad(n, h, &w, &u, &mut g);
        for k in 0..w.len() {
            let mut wp = w.clone();
            let mut wm = w.clone();
            wp[k] += 1e-6;
            wm[k] -= 1e-6;
            let fd = (forward(n, h, &wp, &u) - forward(n, h, &wm, &u)) / 2e-6;
            assert!((fd - g[k]).abs() < 1e-7, "weight {k}: {fd} vs {}", g[k]);
        }
    }

    #[test]
    fn min_max_maps_to_the_unit_box_and_back() {
        let m = MinMax::of([2.0, 6.0, 4.0].into_iter());
        assert_eq!(m.normalise(2.0), -1.0);
        assert_eq!(m.normalise(6.0), 1.0);
        assert_eq!(m.denormalise(m.normalise(5.0)), 5.0);
        let c = MinMax::of([3.0, 3.0].into_iter());
        assert_eq!(c.normalise(7.0), 0.0);
        assert_eq!(c.denormalise(0.4), 3.0);
    }
}
