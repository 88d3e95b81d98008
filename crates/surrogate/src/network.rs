//! The BP network of the GA-BP papers: one hidden layer of tansig (tanh) neurons, 2n+1 of them
//! for n inputs, and a linear output; inputs and output min-max normalised to [-1, 1] with the
//! training rows' minimum and maximum (MATLAB's `mapminmax`); Levenberg-Marquardt training;
//! optionally a genetic algorithm for the initial weights (GA-BP) and a second one for the
//! inputs whose prediction is the lab value (GA-BP-GA, [`search_target`]).
//!
//! Regularisation. A 3-7-1 network has 36 weights and the silage CCD leaves 18 training rows,
//! so plain least squares interpolates the training rows (including the centre points' pure
//! error) and generalises badly. Training therefore minimises MATLAB `trainbr`'s Bayesian
//! regularised objective F = beta E_D + alpha E_W (E_D the sum of squared errors, E_W the sum of
//! squared weights) and re-estimates alpha and beta after every epoch from the effective number
//! of parameters gamma (MacKay 1992; Foresee and Hagan 1997). We chose it over early stopping
//! because early stopping would take a validation slice out of only 18 rows, and over a fixed
//! weight decay because its strength would be one more number to tune per data set: the
//! evidence framework sets the strength from the data, and gamma comes out near the number of
//! parameters the data can support (a quadratic in three factors has 10).

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
        self.y_norm
            .denormalise(forward(self.n, self.h, &self.weights, &u))
    }

    pub fn inputs(&self) -> usize {
        self.n
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
    pub metrics_train: FitMetrics,
    pub metrics_test: FitMetrics,
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
    let n = x[0].len();
    let h = opts.hidden.unwrap_or(2 * n + 1);
    let (train, test) = split_stratified(y, opts.train_fraction, opts.seed);
    if train.len() < 2 {
        return Err(format!(
            "BP: expected at least 2 training rows, got {} (train_fraction {})",
            train.len(),
            opts.train_fraction
        ));
    }

    let x_norm: Vec<MinMax> = (0..n)
        .map(|k| MinMax::of(train.iter().map(|&i| x[i][k])))
        .collect();
    let y_norm = MinMax::of(train.iter().map(|&i| y[i]));
    let u: Vec<Vec<f64>> = train
        .iter()
        .map(|&i| {
            x[i].iter()
                .zip(&x_norm)
                .map(|(&v, m)| m.normalise(v))
                .collect()
        })
        .collect();
    let t: Vec<f64> = train.iter().map(|&i| y_norm.normalise(y[i])).collect();

    let p = Network::parameter_count(n, h);
    let (w0, ga_history) = match &opts.ga {
        Some(ga) => {
            let bounds = vec![(-GA_WEIGHT_BOUND, GA_WEIGHT_BOUND); p];
            let r = genetic::minimize(&bounds, |w| mse(n, h, w, &u, &t), ga)?;
            (r.best, r.history)
        }
        None => (initial_weights(n, h, opts.seed), Vec::new()),
    };

    let fit = levenberg_marquardt(n, h, w0, &u, &t, opts);
    let network = Network {
        n,
        h,
        weights: fit.weights,
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
        metrics_all: FitMetrics::of(y, &predictions),
        network,
        train,
        test,
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
    u: &[Vec<f64>],
    t: &[f64],
    opts: &BpOptions,
) -> LmFit {
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
