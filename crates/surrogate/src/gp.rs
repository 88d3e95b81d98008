//! Gaussian-process regression for noisy simulation responses: constant mean, one length scale
//! per factor (Matern 5/2 or squared exponential), signal and noise variances, all estimated by
//! maximum likelihood from seeded restarts of a BFGS search with analytic gradients.
//!
//! Written here on nalgebra rather than taken from a GP crate: in the egobox-gp versions checked
//! (to 0.26) the full GP's nugget is a fixed conditioning constant (only the sparse GP estimates
//! a noise variance) and it brings the ndarray/linfa stack; friedrich's kernels have one length
//! scale for all inputs. DEM responses need an estimated noise and a length scale per factor.
//!
//! Inputs are coded factors (each normally in [-1, 1]); responses are standardised inside the fit
//! and every reported quantity is back in the responses' units.

use nalgebra::{Cholesky, DMatrix, DVector, Dyn};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use serde::Serialize;

/// Most points a GP is fitted to: its covariance matrix is 8 n² bytes (200 MB here) and each
/// factorisation n³/3 operations.
pub const MAX_GP_ROWS: usize = 5_000;
/// Above this many points the hyperparameters are fitted on a subset of this size.
pub const HYPER_ROWS: usize = 400;

/// Covariance of the latent function between two points, as a function of their scaled distance.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum Kernel {
    /// Twice differentiable: the usual choice for physical responses.
    Matern52,
    /// Infinitely smooth; can be overconfident on responses with kinks.
    SquaredExponential,
}

impl Kernel {
    /// Reads "matern52" (or "matern"), "squared_exponential" (or "se", "rbf"), in any case.
    pub fn parse(s: &str) -> Result<Kernel, String> {
        match s.trim().to_ascii_lowercase().as_str() {
            "matern52" | "matern" => Ok(Kernel::Matern52),
            "squared_exponential" | "se" | "rbf" => Ok(Kernel::SquaredExponential),
            other => Err(format!(
                "kernel: expected matern52 or squared_exponential, got {other:?}"
            )),
        }
    }

    pub fn name(&self) -> &'static str {
        match self {
            Kernel::Matern52 => "matern52",
            Kernel::SquaredExponential => "squared_exponential",
        }
    }

    /// Correlation at scaled distance r (r^2 given), and the factor g with
    /// d(correlation)/d(log length scale k) = g * (dx_k / l_k)^2.
    fn correlation(&self, r2: f64) -> (f64, f64) {
        match self {
            Kernel::SquaredExponential => {
                let c = (-0.5 * r2).exp();
                (c, c)
            }
            Kernel::Matern52 => {
                let s5r = (5.0 * r2).sqrt();
                let e = (-s5r).exp();
                (
                    (1.0 + s5r + 5.0 * r2 / 3.0) * e,
                    5.0 / 3.0 * (1.0 + s5r) * e,
                )
            }
        }
    }
}

/// How to fit a [`Gp`].
#[derive(Clone, Debug)]
pub struct GpOptions {
    pub kernel: Kernel,
    /// Random starts of the likelihood search besides the default one.
    pub restarts: usize,
    /// Seeds the random starts: the same seed gives the same fit bit for bit.
    pub seed: u64,
}

impl Default for GpOptions {
    fn default() -> GpOptions {
        GpOptions {
            kernel: Kernel::Matern52,
            restarts: 5,
            seed: 0,
        }
    }
}

// Bounds on the log hyperparameters, in coded inputs and standardised responses (variance 1).
// Length scales from 1/100 to 100 times the unit of the coded box. The noise floor keeps the
// covariance matrix well conditioned when the data are noise-free; noise above the responses' own
// variance would mean nothing is explained. The signal may exceed that variance: a long length
// scale with a large variance is how a GP with a constant mean draws a bowl.
const LOG_LENGTH: (f64, f64) = (-4.605_170_185_988_091, 4.605_170_185_988_091);
const LOG_SIGNAL: (f64, f64) = (-6.907_755_278_982_137, 9.210_340_371_976_184);
const LOG_NOISE: (f64, f64) = (-18.420_680_743_952_367, 0.0);
/// Weight of the quadratic penalty that keeps the search near the bounds; the result is clamped.
const BOUND_PENALTY: f64 = 1e3;
const MAX_BFGS_ITERATIONS: usize = 200;

/// A Gaussian process fitted to (x, y): constant mean, stationary kernel, Gaussian noise.
#[derive(Clone, Debug)]
pub struct Gp {
    kernel: Kernel,
    x: Vec<Vec<f64>>,
    /// Standardised responses, kept so that the GP can be conditioned on more.
    y: Vec<f64>,
    /// y = shift + scale * standardised y.
    shift: f64,
    scale: f64,
    length_scales: Vec<f64>,
    /// Standardised units from here on.
    signal: f64,
    noise: f64,
    /// Added to the diagonal only when the Cholesky factorisation needed it.
    jitter: f64,
    mean: f64,
    chol: Cholesky<f64, Dyn>,
    /// K^-1 (y - mean).
    alpha: DVector<f64>,
    log_likelihood: f64,
}

/// The log hyperparameters: length scales, then signal variance, then noise variance.
struct Hyper<'a> {
    log: &'a [f64],
}

impl Hyper<'_> {
    fn dim(&self) -> usize {
        self.log.len() - 2
    }
    fn inverse_length_sq(&self) -> Vec<f64> {
        self.log[..self.dim()]
            .iter()
            .map(|l| (-2.0 * l).exp())
            .collect()
    }
    fn signal(&self) -> f64 {
        self.log[self.dim()].exp()
    }
    fn noise(&self) -> f64 {
        self.log[self.dim() + 1].exp()
    }
}

/// Everything the likelihood needs that does not change with the hyperparameters.
struct Data<'a> {
    kernel: Kernel,
    x: &'a [Vec<f64>],
    y: DVector<f64>,
    /// Squared coordinate differences of each pair i < j, factor by factor.
    sq: Vec<Vec<f64>>,
}

/// A factorised covariance matrix with its GLS mean and the terms the gradient needs.
struct Factored {
    chol: Cholesky<f64, Dyn>,
    jitter: f64,
    mean: f64,
    alpha: DVector<f64>,
    /// Log marginal likelihood of the standardised responses.
    log_likelihood: f64,
    /// Correlation and its length-scale factor for each pair i < j.
    corr: Vec<(f64, f64)>,
}

impl<'a> Data<'a> {
    fn new(kernel: Kernel, x: &'a [Vec<f64>], y: DVector<f64>) -> Data<'a> {
        let n = x.len();
        let d = x[0].len();
        let sq = (0..d)
            .map(|k| {
                let mut v = Vec::with_capacity(n * (n - 1) / 2);
                for i in 0..n {
                    for j in i + 1..n {
                        v.push((x[i][k] - x[j][k]).powi(2));
                    }
                }
                v
            })
            .collect();
        Data { kernel, x, y, sq }
    }

    fn n(&self) -> usize {
        self.x.len()
    }

    /// Factorises K at these hyperparameters; with `mean` None the constant mean is estimated by
    /// generalised least squares (the maximum-likelihood value given the rest). None when even
    /// jitter cannot make K positive definite.
    fn factor(&self, h: &Hyper, mean: Option<f64>) -> Option<Factored> {
        let n = self.n();
        let inv_l2 = h.inverse_length_sq();
        let (signal, noise) = (h.signal(), h.noise());
        let mut corr = Vec::with_capacity(n * (n - 1) / 2);
        for p in 0..n * (n - 1) / 2 {
            let r2: f64 = self.sq.iter().zip(&inv_l2).map(|(s, w)| s[p] * w).sum();
            corr.push(self.kernel.correlation(r2));
        }
        let mut k = DMatrix::<f64>::zeros(n, n);
        let mut p = 0;
        for i in 0..n {
            k[(i, i)] = signal + noise;
            for j in i + 1..n {
                k[(i, j)] = signal * corr[p].0;
                k[(j, i)] = k[(i, j)];
                p += 1;
            }
        }
        // Jitter only when needed, so that a well-posed fit is exactly the model it claims.
        let mut jitter = 0.0;
        let chol = loop {
            if let Some(c) = Cholesky::new(k.clone()) {
                break c;
            }
            jitter = if jitter == 0.0 {
                1e-10 * (signal + noise)
            } else {
                jitter * 100.0
            };
            if jitter > 1e-2 * (signal + noise) {
                return None;
            }
            for i in 0..n {
                k[(i, i)] = signal + noise + jitter;
            }
        };
        let mean = match mean {
            Some(m) => m,
            None => {
                let ones = DVector::from_element(n, 1.0);
                let k1 = chol.solve(&ones);
                let denom = k1.sum();
                if denom.is_nan() || denom <= 0.0 {
                    return None;
                }
                k1.dot(&self.y) / denom
            }
        };
        let r = self.y.add_scalar(-mean);
        let alpha = chol.solve(&r);
        let log_det: f64 = 2.0
            * chol
                .l_dirty()
                .diagonal()
                .iter()
                .map(|v| v.ln())
                .sum::<f64>();
        let log_likelihood = -0.5 * r.dot(&alpha)
            - 0.5 * log_det
            - 0.5 * n as f64 * (2.0 * std::f64::consts::PI).ln();
        if !log_likelihood.is_finite() {
            return None;
        }
        Some(Factored {
            chol,
            jitter,
            mean,
            alpha,
            log_likelihood,
            corr,
        })
    }

    /// Negative log likelihood (plus the bound penalty) and its gradient in the log
    /// hyperparameters. The GLS mean maximises the likelihood for the others, so its own
    /// dependence on them drops out of the gradient.
    fn objective(&self, log: &[f64]) -> Option<(f64, Vec<f64>)> {
        let h = Hyper { log };
        let f = self.factor(&h, None)?;
        let n = self.n();
        let d = h.dim();
        let (signal, noise) = (h.signal(), h.noise());
        let inv_l2 = h.inverse_length_sq();
        // dL/dtheta = 1/2 tr((alpha alpha' - K^-1) dK/dtheta).
        let kinv = f.chol.inverse();
        let w = |i: usize, j: usize| f.alpha[i] * f.alpha[j] - kinv[(i, j)];
        let mut grad = vec![0.0; d + 2];
        let mut p = 0;
        for i in 0..n {
            let wii = w(i, i);
            grad[d] += 0.5 * wii * signal;
            grad[d + 1] += 0.5 * wii * noise;
            for j in i + 1..n {
                let wij = w(i, j);
                let (c, g) = f.corr[p];
                // Off-diagonal terms appear twice in the trace.
                grad[d] += wij * signal * c;
                for k in 0..d {
                    grad[k] += wij * signal * g * self.sq[k][p] * inv_l2[k];
                }
                p += 1;
            }
        }
        let mut value = -f.log_likelihood;
        let mut gradient: Vec<f64> = grad.iter().map(|g| -g).collect();
        for (i, &t) in log.iter().enumerate() {
            let (lo, hi) = bounds(i, d);
            let excess = if t < lo {
                t - lo
            } else if t > hi {
                t - hi
            } else {
                0.0
            };
            value += 0.5 * BOUND_PENALTY * excess * excess;
            gradient[i] += BOUND_PENALTY * excess;
        }
        if !value.is_finite() || gradient.iter().any(|g| !g.is_finite()) {
            return None;
        }
        Some((value, gradient))
    }
}

fn bounds(i: usize, d: usize) -> (f64, f64) {
    if i < d {
        LOG_LENGTH
    } else if i == d {
        LOG_SIGNAL
    } else {
        LOG_NOISE
    }
}

/// A function to minimise with its gradient; None where it cannot be evaluated.
type Objective<'a> = dyn Fn(&[f64]) -> Option<(f64, Vec<f64>)> + 'a;

/// Minimises `f` from `start` by BFGS with a backtracking (Armijo) line search. Steps that would
/// move any log hyperparameter by more than 2 (a factor of e^2) are shortened first.
fn bfgs(f: &Objective, start: Vec<f64>) -> Option<Vec<f64>> {
    let p = start.len();
    let mut x = start;
    let (mut fx, mut g) = f(&x)?;
    let mut h = DMatrix::<f64>::identity(p, p);
    let mut first = true;
    for _ in 0..MAX_BFGS_ITERATIONS {
        if g.iter().all(|v| v.abs() < 1e-4) {
            break;
        }
        let gv = DVector::from_column_slice(&g);
        let mut dir = -(&h * &gv);
        if dir.dot(&gv) >= 0.0 {
            h = DMatrix::identity(p, p);
            dir = -gv.clone();
        }
        let biggest = dir.amax();
        if biggest > 2.0 {
            dir *= 2.0 / biggest;
        }
        let slope = dir.dot(&gv);
        let mut step = 1.0;
        let mut accepted = None;
        for _ in 0..40 {
            let trial: Vec<f64> = x
                .iter()
                .zip(dir.iter())
                .map(|(a, b)| a + step * b)
                .collect();
            if let Some((ft, gt)) = f(&trial) {
                if ft <= fx + 1e-4 * step * slope {
                    accepted = Some((trial, ft, gt));
                    break;
                }
            }
            step *= 0.5;
        }
        let Some((xn, fnew, gn)) = accepted else {
            break;
        };
        let s = DVector::from_iterator(p, xn.iter().zip(&x).map(|(a, b)| a - b));
        let yv = DVector::from_iterator(p, gn.iter().zip(&g).map(|(a, b)| a - b));
        let sy = s.dot(&yv);
        // Skip the update when the curvature condition fails, keeping H positive definite.
        if sy > 1e-12 * s.norm() * yv.norm() {
            if first {
                h *= sy / yv.dot(&yv);
                first = false;
            }
            let rho = 1.0 / sy;
            let hy = &h * &yv;
            let yhy = yv.dot(&hy);
            h += (&s * s.transpose()) * (rho * (1.0 + rho * yhy))
                - (&hy * s.transpose() + &s * hy.transpose()) * rho;
        }
        let done = (fx - fnew).abs() <= 1e-9 * (1.0 + fx.abs());
        x = xn;
        fx = fnew;
        g = gn;
        if done {
            break;
        }
    }
    Some(x)
}

impl Gp {
    /// Fits the GP by maximum likelihood. x: points in coded units (each coordinate normally in
    /// [-1, 1]); y: responses. Non-finite values, fewer than two points, and rows of different
    /// lengths are refused: the caller filters failed runs out first.
    pub fn fit(x: &[Vec<f64>], y: &[f64], opts: &GpOptions) -> Result<Gp, String> {
        let (shift, scale) = check_data(x, y)?;
        if x.len() > MAX_GP_ROWS {
            return Err(format!(
                "Gaussian process: {} points, at most {MAX_GP_ROWS} (its covariance grows as the square of the points and its fit as the cube): fit a subset, or use a response surface or a network",
                x.len()
            ));
        }
        let d = x[0].len();
        let ys = DVector::from_iterator(y.len(), y.iter().map(|v| (v - shift) / scale));
        let data = Data::new(opts.kernel, x, ys);
        // Subset of data: above HYPER_ROWS points the hyperparameters are fitted on an evenly
        // spread, seeded subset (each likelihood costs the cube of the points, and a search
        // takes hundreds), then the GP is conditioned on every point with them. 1 000 points
        // took 56 s in full and 3 000 did not finish in 200 s.
        let subset: Option<(Vec<Vec<f64>>, DVector<f64>)> = (x.len() > HYPER_ROWS).then(|| {
            let mut rng = Pcg64::seed_from_u64(opts.seed ^ 0x5eed_5b5e);
            let mut idx: Vec<usize> = (0..x.len()).collect();
            for i in 0..HYPER_ROWS {
                let j = rng.gen_range(i..idx.len());
                idx.swap(i, j);
            }
            idx.truncate(HYPER_ROWS);
            idx.sort_unstable();
            (
                idx.iter().map(|&i| x[i].clone()).collect(),
                DVector::from_iterator(idx.len(), idx.iter().map(|&i| data.y[i])),
            )
        });
        let hyper_data = subset
            .as_ref()
            .map(|(sx, sy)| Data::new(opts.kernel, sx, sy.clone()));
        let search = hyper_data.as_ref().unwrap_or(&data);
        let objective = |log: &[f64]| search.objective(log);

        let mut starts = vec![default_start(d)];
        let mut rng = Pcg64::seed_from_u64(opts.seed);
        for _ in 0..opts.restarts {
            let mut s: Vec<f64> = (0..d)
                .map(|_| rng.gen_range(0.1f64.ln()..5.0f64.ln()))
                .collect();
            s.push(rng.gen_range(0.1f64.ln()..10.0f64.ln()));
            s.push(rng.gen_range(1e-6f64.ln()..0.5f64.ln()));
            starts.push(s);
        }
        // The best clamped optimum; the first wins ties, so the order of starts decides.
        let mut best: Option<(Vec<f64>, Factored)> = None;
        for start in starts {
            let Some(mut log) = bfgs(&objective, start) else {
                continue;
            };
            for (i, t) in log.iter_mut().enumerate() {
                let (lo, hi) = bounds(i, d);
                *t = t.clamp(lo, hi);
            }
            let Some(f) = search.factor(&Hyper { log: &log }, None) else {
                continue;
            };
            if best
                .as_ref()
                .is_none_or(|(_, b)| f.log_likelihood > b.log_likelihood)
            {
                best = Some((log, f));
            }
        }
        let none = || {
            "Gaussian process: expected a positive definite covariance at some hyperparameters, found none (are the points all identical?)"
                .to_string()
        };
        let (log, f) = best.ok_or_else(none)?;
        // With a subset, the chosen hyperparameters conditioned on every point.
        let f = if hyper_data.is_some() {
            data.factor(&Hyper { log: &log }, None).ok_or_else(none)?
        } else {
            f
        };
        let h = Hyper { log: &log };
        Ok(Gp {
            kernel: opts.kernel,
            x: x.to_vec(),
            y: data.y.iter().copied().collect(),
            shift,
            scale,
            length_scales: log[..d].iter().map(|l| l.exp()).collect(),
            signal: h.signal(),
            noise: h.noise(),
            jitter: f.jitter,
            mean: f.mean,
            chol: f.chol,
            alpha: f.alpha,
            log_likelihood: f.log_likelihood - y.len() as f64 * scale.ln(),
        })
    }

    /// The same GP (hyperparameters and constant mean kept) given more observations, as batch
    /// selection needs when it pretends a pending point has been evaluated.
    pub fn condition(&self, x: &[Vec<f64>], y: &[f64]) -> Result<Gp, String> {
        if x.len() != y.len() {
            return Err(format!(
                "Gaussian process: expected as many responses as points, got {} and {}",
                y.len(),
                x.len()
            ));
        }
        let d = self.dim();
        if let Some(bad) = x.iter().find(|p| p.len() != d) {
            return Err(format!(
                "Gaussian process: expected points of {d} coordinates, got one of {}",
                bad.len()
            ));
        }
        if x.iter().flatten().chain(y).any(|v| !v.is_finite()) {
            return Err("Gaussian process: expected finite points and responses".into());
        }
        let mut all_x = self.x.clone();
        all_x.extend_from_slice(x);
        let ys = DVector::from_iterator(
            self.x.len() + y.len(),
            self.y
                .iter()
                .copied()
                .chain(y.iter().map(|v| (v - self.shift) / self.scale)),
        );
        let mut log: Vec<f64> = self.length_scales.iter().map(|l| l.ln()).collect();
        log.push(self.signal.ln());
        log.push(self.noise.ln());
        let data = Data::new(self.kernel, &all_x, ys);
        let f = data
            .factor(&Hyper { log: &log }, Some(self.mean))
            .ok_or("Gaussian process: expected a positive definite covariance with the new points, got none")?;
        let all_y = data.y.iter().copied().collect();
        Ok(Gp {
            x: all_x,
            y: all_y,
            jitter: f.jitter,
            chol: f.chol,
            alpha: f.alpha,
            log_likelihood: f.log_likelihood - (self.x.len() + y.len()) as f64 * self.scale.ln(),
            ..self.clone()
        })
    }

    /// Mean and variance of the latent function at x (the noise variance NOT included), in y's
    /// units. NaN for a point with the wrong number of coordinates or a non-finite one.
    pub fn predict(&self, x: &[f64]) -> (f64, f64) {
        if x.len() != self.dim() || x.iter().any(|v| !v.is_finite()) {
            return (f64::NAN, f64::NAN);
        }
        let k = self.cross_covariance(x);
        let mean = self.mean + k.dot(&self.alpha);
        let v = self
            .chol
            .l_dirty()
            .solve_lower_triangular(&k)
            .unwrap_or_else(|| DVector::zeros(k.len()));
        let var = (self.signal - v.dot(&v)).max(0.0);
        (
            self.shift + self.scale * mean,
            var * self.scale * self.scale,
        )
    }

    /// The predicted mean alone: a dot product over the points (the variance's triangular
    /// solve costs the square of them, which at a few thousand points made `surrogate fit`
    /// spend most of a minute on predictions whose variance it threw away).
    pub fn predict_mean(&self, x: &[f64]) -> f64 {
        if x.len() != self.dim() || x.iter().any(|v| !v.is_finite()) {
            return f64::NAN;
        }
        let k = self.cross_covariance(x);
        self.shift + self.scale * (self.mean + k.dot(&self.alpha))
    }

    fn cross_covariance(&self, x: &[f64]) -> DVector<f64> {
        DVector::from_iterator(
            self.x.len(),
            self.x.iter().map(|xi| {
                let r2: f64 = xi
                    .iter()
                    .zip(x)
                    .zip(&self.length_scales)
                    .map(|((a, b), l)| ((a - b) / l).powi(2))
                    .sum();
                self.signal * self.kernel.correlation(r2).0
            }),
        )
    }

    pub fn kernel(&self) -> Kernel {
        self.kernel
    }

    /// Number of factors.
    pub fn dim(&self) -> usize {
        self.length_scales.len()
    }

    /// The points the GP was fitted to (and conditioned on).
    pub fn points(&self) -> &[Vec<f64>] {
        &self.x
    }

    /// One length scale per factor, in coded units: a factor with a long one hardly matters.
    pub fn length_scales(&self) -> &[f64] {
        &self.length_scales
    }

    /// Prior variance of the latent function about the constant mean, in y's units squared.
    pub fn signal_variance(&self) -> f64 {
        self.signal * self.scale * self.scale
    }

    /// Variance of the observation noise (run-to-run scatter), in y's units squared; includes
    /// any jitter the factorisation needed.
    pub fn noise_variance(&self) -> f64 {
        (self.noise + self.jitter) * self.scale * self.scale
    }

    /// The constant mean, in y's units.
    pub fn mean(&self) -> f64 {
        self.shift + self.scale * self.mean
    }

    /// Log marginal likelihood of the responses, in y's units (comparable between fits to the
    /// same data).
    pub fn log_marginal_likelihood(&self) -> f64 {
        self.log_likelihood
    }
}

/// The default start: length scales of half the coded box, signal about the responses' variance,
/// a little noise.
fn default_start(d: usize) -> Vec<f64> {
    let mut s = vec![0.0; d];
    s.push(0.0);
    s.push(0.01f64.ln());
    s
}

/// Checks the training data and returns the shift and scale that standardise y.
fn check_data(x: &[Vec<f64>], y: &[f64]) -> Result<(f64, f64), String> {
    if x.len() != y.len() {
        return Err(format!(
            "Gaussian process: expected as many responses as points, got {} and {}",
            y.len(),
            x.len()
        ));
    }
    if x.len() < 2 {
        return Err(format!(
            "Gaussian process: expected at least 2 points, got {}",
            x.len()
        ));
    }
    let d = x[0].len();
    if d == 0 {
        return Err("Gaussian process: expected points of at least 1 coordinate, got 0".into());
    }
    if let Some((i, p)) = x.iter().enumerate().find(|(_, p)| p.len() != d) {
        return Err(format!(
            "Gaussian process: expected points of {d} coordinates, point {i} has {}",
            p.len()
        ));
    }
    if let Some(i) = x.iter().position(|p| p.iter().any(|v| !v.is_finite())) {
        return Err(format!(
            "Gaussian process: expected finite coordinates, point {i} has {:?}",
            x[i]
        ));
    }
    if let Some(i) = y.iter().position(|v| !v.is_finite()) {
        return Err(format!(
            "Gaussian process: expected finite responses, response {i} is {} (leave failed runs out)",
            y[i]
        ));
    }
    let n = y.len() as f64;
    let shift = y.iter().sum::<f64>() / n;
    let var = y.iter().map(|v| (v - shift).powi(2)).sum::<f64>() / n;
    let scale = var.sqrt();
    if !scale.is_finite() || !shift.is_finite() {
        return Err("Gaussian process: expected responses small enough to square".into());
    }
    // Constant responses: nothing to standardise by, keep the units.
    let scale = if scale > 1e-300 * (1.0 + shift.abs()) {
        scale
    } else {
        1.0
    };
    Ok((shift, scale))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample(n: usize, d: usize, seed: u64) -> (Vec<Vec<f64>>, Vec<f64>) {
        let mut rng = Pcg64::seed_from_u64(seed);
        let x: Vec<Vec<f64>> = (0..n)
            .map(|_| (0..d).map(|_| rng.gen_range(-1.0..1.0)).collect())
            .collect();
        let y = x
            .iter()
            .map(|p| p.iter().map(|v| (2.0 * v).sin()).sum::<f64>() + rng.gen_range(-0.1..0.1))
            .collect();
        (x, y)
    }

    #[test]
    fn kernel_names_round_trip() {
        for k in [Kernel::Matern52, Kernel::SquaredExponential] {
            assert_eq!(Kernel::parse(k.name()).unwrap(), k);
        }
        assert_eq!(Kernel::parse("RBF").unwrap(), Kernel::SquaredExponential);
        assert_eq!(Kernel::parse("matern").unwrap(), Kernel::Matern52);
        assert!(Kernel::parse("linear").unwrap_err().contains("matern52"));
    }

    #[test]
    fn likelihood_gradient_matches_finite_differences() {
        let (x, y) = sample(15, 3, 7);
        for kernel in [Kernel::Matern52, Kernel::SquaredExponential] {
            let data = Data::new(kernel, &x, DVector::from_vec(y.clone()));
            let log = vec![-0.3, 0.2, 0.5, 0.1, -3.0];
            let (_, g) = data.objective(&log).unwrap();
            for i in 0..log.len() {
                let h = 1e-6;
                let mut up = log.clone();
                up[i] += h;
                let mut down = log.clone();
                down[i] -= h;
                let fd =
                    (data.objective(&up).unwrap().0 - data.objective(&down).unwrap().0) / (2.0 * h);
                assert!(
                    (fd - g[i]).abs() < 1e-5 * (1.0 + fd.abs()),
                    "{kernel:?} parameter {i}: analytic {} finite difference {fd}",
                    g[i]
                );
            }
        }
    }

    #[test]
    fn conditioning_moves_the_mean_only_near_the_new_point() {
        let (x, y) = sample(12, 2, 3);
        let gp = Gp::fit(&x, &y, &GpOptions::default()).unwrap();
        let more = gp.condition(&[vec![0.9, -0.9]], &[5.0]).unwrap();
        assert_eq!(more.points().len(), 13);
        // Far from the new point the prediction barely moves; at it the mean moves toward 5.
        let (m0, _) = gp.predict(&x[0]);
        let (m1, _) = more.predict(&x[0]);
        assert!((m0 - m1).abs() < 0.5, "{m0} {m1}");
        assert!(more.predict(&[0.9, -0.9]).0 > gp.predict(&[0.9, -0.9]).0);
    }

    #[test]
    fn bad_data_is_refused() {
        let o = GpOptions::default();
        assert!(Gp::fit(&[vec![0.0]], &[1.0], &o)
            .unwrap_err()
            .contains("at least 2"));
        assert!(Gp::fit(&[vec![0.0], vec![1.0]], &[1.0, f64::NAN], &o)
            .unwrap_err()
            .contains("finite responses"));
        assert!(Gp::fit(&[vec![0.0], vec![1.0, 2.0]], &[1.0, 2.0], &o)
            .unwrap_err()
            .contains("coordinates"));
        assert!(Gp::fit(&[vec![0.0], vec![f64::INFINITY]], &[1.0, 2.0], &o)
            .unwrap_err()
            .contains("finite coordinates"));
        assert!(Gp::fit(&[vec![0.0], vec![1.0]], &[1.0], &o)
            .unwrap_err()
            .contains("as many"));
        let gp = Gp::fit(&[vec![0.0], vec![1.0]], &[1.0, 2.0], &o).unwrap();
        assert!(gp.predict(&[0.0, 1.0]).0.is_nan());
        assert!(gp.condition(&[vec![0.0, 1.0]], &[1.0]).is_err());
    }

    /// Past MAX_GP_ROWS the fit is refused before anything is allocated (20 000 rows asked
    /// 6.1 GB); past HYPER_ROWS the hyperparameters come from a subset and the GP still
    /// interpolates every point's neighbourhood.
    #[test]
    fn large_data_is_fitted_on_a_subset_or_refused() {
        let o = GpOptions::default();
        let many: Vec<Vec<f64>> = (0..MAX_GP_ROWS + 1).map(|i| vec![i as f64]).collect();
        let ys = vec![0.0; many.len()];
        assert!(Gp::fit(&many, &ys, &o)
            .unwrap_err()
            .contains("5001 points, at most 5000"));
        let f = |p: &[f64]| (2.0 * p[0]).sin() + p[1] * p[1];
        let mut rng = Pcg64::seed_from_u64(3);
        let x: Vec<Vec<f64>> = (0..1200)
            .map(|_| vec![rng.gen_range(-1.0..1.0), rng.gen_range(-1.0..1.0)])
            .collect();
        let y: Vec<f64> = x.iter().map(|p| f(p)).collect();
        let gp = Gp::fit(&x, &y, &o).unwrap();
        for p in [[0.1, -0.3], [-0.7, 0.6], [0.5, 0.5]] {
            let (m, _) = gp.predict(&p);
            assert!((m - f(&p)).abs() < 0.01, "{p:?}: {m} against {}", f(&p));
        }
    }

    #[test]
    fn constant_responses_fit() {
        let x = vec![vec![-1.0], vec![0.0], vec![1.0]];
        let gp = Gp::fit(&x, &[2.0, 2.0, 2.0], &GpOptions::default()).unwrap();
        assert!((gp.predict(&[0.5]).0 - 2.0).abs() < 1e-9);
        assert_eq!(gp.predict_mean(&[0.5]), gp.predict(&[0.5]).0);
    }
}
