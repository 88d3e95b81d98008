//! Gaussian mixtures fitted to weighted points: the proposal density of the sequential Monte
//! Carlo filter ([`crate::smc`]).
//!
//! GrainLearning fits scikit-learn's variational Dirichlet-process mixture with a covariance
//! tied across components to an ensemble it first expands into copies (each sample repeated in
//! proportion to its weight). Here the weights enter the EM sums directly, which is the same fit
//! with the expansion taken to its limit and no rounding of small weights to zero copies. The
//! Dirichlet-process prior's effect that matters for resampling (a component the data do not
//! support dies instead of sitting on one or two points) is kept by a maximum-a-posteriori
//! weight update under a Dirichlet prior with concentration 1/K (GrainLearning's default): a
//! component holding less than about one effective sample gets weight zero and is dropped.
//! Components whose weight falls below [`MIN_COMPONENT_WEIGHT`] are dropped as well.

use nalgebra::{DMatrix, DVector};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;

/// Components lighter than this are dropped during EM: they barely shape the proposal but each
/// one costs a mean estimated from almost no data.
pub const MIN_COMPONENT_WEIGHT: f64 = 1e-3;

/// Ridge added to the tied covariance, relative to the data's mean variance (scikit-learn adds
/// 1e-6 absolute on data GrainLearning normalises to [0, 1]; relative keeps the same effect for
/// a posterior that has shrunk far inside the coded box).
const RELATIVE_REGULARISATION: f64 = 1e-6;
/// Absolute floor of the ridge, for points that all coincide (their variance is zero).
const ABSOLUTE_REGULARISATION: f64 = 1e-12;
const MAX_EM_ITERATIONS: usize = 500;
/// EM stops when the weighted mean log-likelihood gains less than this.
const EM_TOLERANCE: f64 = 1e-10;
const KMEANS_ITERATIONS: usize = 20;

/// A mixture of Gaussians sharing one covariance matrix.
#[derive(Clone, Debug)]
pub struct GaussianMixture {
    weights: Vec<f64>,
    means: Vec<Vec<f64>>,
    covariance: DMatrix<f64>,
    /// Lower Cholesky factor of `covariance`, for densities and draws.
    chol: DMatrix<f64>,
    /// ln of the Gaussian normalising constant: -(d ln 2 pi + ln det covariance) / 2.
    log_norm: f64,
}

impl GaussianMixture {
    /// Fits at most `components` Gaussians with a tied covariance to `points` weighted by
    /// `weights` (any non-negative scale; zero-weight points are ignored), by weighted EM from a
    /// seeded, weighted k-means++ start refined by weighted k-means. Fewer components come back
    /// when there are fewer distinct points or the weights support fewer (see the module notes).
    pub fn fit(
        points: &[Vec<f64>],
        weights: &[f64],
        components: usize,
        seed: u64,
    ) -> Result<GaussianMixture, String> {
        if points.is_empty() {
            return Err("mixture fit: expected at least one point, got none".into());
        }
        if weights.len() != points.len() {
            return Err(format!(
                "mixture fit: expected one weight per point ({}), got {}",
                points.len(),
                weights.len()
            ));
        }
        if components == 0 {
            return Err("mixture fit: expected at least one component, got 0".into());
        }
        let dim = points[0].len();
        if dim == 0 {
            return Err("mixture fit: expected points with at least one coordinate".into());
        }
        for (i, p) in points.iter().enumerate() {
            if p.len() != dim {
                return Err(format!(
                    "mixture fit: expected {dim} coordinates in every point, point {i} has {}",
                    p.len()
                ));
            }
            if p.iter().any(|v| !v.is_finite()) {
                return Err(format!(
                    "mixture fit: expected finite coordinates, point {i} has {p:?}"
                ));
            }
        }
        if let Some(i) = weights.iter().position(|w| !w.is_finite() || *w < 0.0) {
            return Err(format!(
                "mixture fit: expected finite non-negative weights, weight {i} is {}",
                weights[i]
            ));
        }
        let total: f64 = weights.iter().sum();
        if total <= 0.0 {
            return Err("mixture fit: expected some positive weight, all weights are zero".into());
        }
        let (xs, w): (Vec<&[f64]>, Vec<f64>) = points
            .iter()
            .zip(weights)
            .filter(|(_, w)| **w > 0.0)
            .map(|(p, w)| (p.as_slice(), w / total))
            .unzip();
        // Kish's effective sample size: the number of equally weighted points these weights are
        // worth, the count the Dirichlet prior's pseudo-count is compared against.
        let n_eff = 1.0 / w.iter().map(|w| w * w).sum::<f64>();

        let mean = weighted_mean(&xs, &w, dim);
        let mut data_var = 0.0;
        for (x, wi) in xs.iter().zip(&w) {
            data_var += wi
                * x.iter()
                    .zip(&mean)
                    .map(|(a, m)| (a - m).powi(2))
                    .sum::<f64>();
        }
        let ridge = RELATIVE_REGULARISATION * data_var / dim as f64 + ABSOLUTE_REGULARISATION;

        let mut rng = Pcg64::seed_from_u64(seed);
        let mut means = kmeans_plus_plus(&xs, &w, components, &mut rng);
        let assignment = kmeans(&xs, &w, &mut means);
        let k0 = means.len();
        // Hard responsibilities from k-means start EM.
        let mut resp: Vec<Vec<f64>> = assignment
            .iter()
            .map(|&a| (0..k0).map(|k| if k == a { 1.0 } else { 0.0 }).collect())
            .collect();
        let alpha = 1.0 / components as f64;

        let mut mix = GaussianMixture {
            weights: vec![1.0 / k0 as f64; k0],
            means,
            covariance: DMatrix::identity(dim, dim),
            chol: DMatrix::identity(dim, dim),
            log_norm: 0.0,
        };
        let mut last_ll = f64::NEG_INFINITY;
        for _ in 0..MAX_EM_ITERATIONS {
            mix.m_step(&xs, &w, &resp, n_eff, alpha, ridge)?;
            let ll = mix.e_step(&xs, &w, &mut resp);
            if (ll - last_ll).abs() < EM_TOLERANCE * (1.0 + ll.abs()) {
                break;
            }
            last_ll = ll;
        }
        // Leave the parameters consistent with the final responsibilities.
        mix.m_step(&xs, &w, &resp, n_eff, alpha, ridge)?;
        Ok(mix)
    }

    /// Mixture weights, means and the tied covariance re-estimated from responsibilities
    /// `resp` (one row per point, one column per current component); components whose weight
    /// vanishes are removed (from `resp` too).
    fn m_step(
        &mut self,
        xs: &[&[f64]],
        w: &[f64],
        resp: &[Vec<f64>],
        n_eff: f64,
        alpha: f64,
        ridge: f64,
    ) -> Result<(), String> {
        let dim = xs[0].len();
        let k = self.means.len();
        let mut mass = vec![0.0; k];
        for (r, wi) in resp.iter().zip(w) {
            for (m, rk) in mass.iter_mut().zip(r) {
                *m += wi * rk;
            }
        }
        // MAP weights under a Dirichlet(alpha) prior: with alpha < 1 a component carrying less
        // than (1 - alpha) effective samples gets no weight at all.
        let mut pi: Vec<f64> = mass
            .iter()
            .map(|m| (n_eff * m - (1.0 - alpha)).max(0.0))
            .collect();
        let s: f64 = pi.iter().sum();
        if s > 0.0 {
            pi.iter_mut().for_each(|p| *p /= s);
        } else {
            // Too few effective samples for the prior to leave anything: fall back on the plain
            // maximum-likelihood weights instead of an empty mixture.
            pi.clone_from(&mass);
        }
        let keep: Vec<usize> = (0..k)
            .filter(|&j| pi[j] >= MIN_COMPONENT_WEIGHT && mass[j] > 0.0)
            .collect();
        // At least the heaviest component survives (it holds the most data).
        let keep = if keep.is_empty() {
            let best = (0..k).fold(0, |b, j| if mass[j] > mass[b] { j } else { b });
            vec![best]
        } else {
            keep
        };
        let kept_sum: f64 = keep.iter().map(|&j| pi[j]).sum();
        let mut means = Vec::with_capacity(keep.len());
        let mut weights = Vec::with_capacity(keep.len());
        for &j in &keep {
            let mut mu = vec![0.0; dim];
            for ((x, r), wi) in xs.iter().zip(resp).zip(w) {
                let c = wi * r[j];
                for (m, v) in mu.iter_mut().zip(x.iter()) {
                    *m += c * v;
                }
            }
            mu.iter_mut().for_each(|m| *m /= mass[j]);
            means.push(mu);
            weights.push(if kept_sum > 0.0 {
                pi[j] / kept_sum
            } else {
                1.0 / keep.len() as f64
            });
        }
        // Tied covariance: within-component scatter of the points that each kept component
        // claims, renormalised over the kept components' share of the data.
        let mut cov = DMatrix::<f64>::zeros(dim, dim);
        let mut claimed = 0.0;
        for ((x, r), wi) in xs.iter().zip(resp).zip(w) {
            for (kk, &j) in keep.iter().enumerate() {
                let c = wi * r[j];
                if c == 0.0 {
                    continue;
                }
                claimed += c;
                for a in 0..dim {
                    let da = x[a] - means[kk][a];
                    for b in 0..=a {
                        cov[(a, b)] += c * da * (x[b] - means[kk][b]);
                    }
                }
            }
        }
        if claimed > 0.0 {
            cov /= claimed;
        }
        for a in 0..dim {
            for b in 0..a {
                cov[(b, a)] = cov[(a, b)];
            }
        }
        self.means = means;
        self.weights = weights;
        self.set_covariance(cov, ridge)
    }

    /// Responsibilities of the current components for every point; returns the weighted mean
    /// log-likelihood.
    fn e_step(&self, xs: &[&[f64]], w: &[f64], resp: &mut Vec<Vec<f64>>) -> f64 {
        let k = self.means.len();
        let mut ll = 0.0;
        resp.clear();
        for (x, wi) in xs.iter().zip(w) {
            let logs: Vec<f64> = (0..k)
                .map(|j| self.weights[j].ln() + self.log_component(x, j))
                .collect();
            let top = logs.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
            let s: f64 = logs.iter().map(|l| (l - top).exp()).sum();
            let lse = top + s.ln();
            ll += wi * lse;
            resp.push(logs.iter().map(|l| (l - lse).exp()).collect());
        }
        ll
    }

    /// Sets the tied covariance (plus the ridge, grown tenfold until it factorises).
    fn set_covariance(&mut self, cov: DMatrix<f64>, ridge: f64) -> Result<(), String> {
        let dim = cov.nrows();
        let mut r = ridge;
        for _ in 0..20 {
            let c = &cov + DMatrix::identity(dim, dim) * r;
            if let Some(ch) = c.clone().cholesky() {
                let l = ch.l();
                let log_det: f64 = 2.0 * (0..dim).map(|i| l[(i, i)].ln()).sum::<f64>();
                self.log_norm = -0.5 * (dim as f64 * (2.0 * std::f64::consts::PI).ln() + log_det);
                self.covariance = c;
                self.chol = l;
                return Ok(());
            }
            r = (r * 10.0).max(1e-12);
        }
        Err("mixture fit: expected a positive definite covariance, regularisation failed".into())
    }

    /// ln N(x; mean_j, covariance).
    fn log_component(&self, x: &[f64], j: usize) -> f64 {
        let diff =
            DVector::from_iterator(x.len(), x.iter().zip(&self.means[j]).map(|(a, m)| a - m));
        // Solve L z = diff; the Mahalanobis distance is |z|^2.
        let z = self
            .chol
            .solve_lower_triangular(&diff)
            .unwrap_or_else(|| DVector::from_element(x.len(), f64::INFINITY));
        self.log_norm - 0.5 * z.norm_squared()
    }

    /// ln of the density at `x` (NaN when `x` has the wrong number of coordinates).
    pub fn log_density(&self, x: &[f64]) -> f64 {
        if x.len() != self.dim() {
            return f64::NAN;
        }
        let logs: Vec<f64> = (0..self.means.len())
            .map(|j| self.weights[j].ln() + self.log_component(x, j))
            .collect();
        let top = logs.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
        if top == f64::NEG_INFINITY {
            return top;
        }
        top + logs.iter().map(|l| (l - top).exp()).sum::<f64>().ln()
    }

    /// The density at `x` (NaN when `x` has the wrong number of coordinates).
    pub fn density(&self, x: &[f64]) -> f64 {
        self.log_density(x).exp()
    }

    /// One draw: a component by weight, then its Gaussian.
    pub fn sample(&self, rng: &mut impl Rng) -> Vec<f64> {
        let u: f64 = rng.gen();
        let mut j = self.weights.len() - 1;
        let mut acc = 0.0;
        for (i, w) in self.weights.iter().enumerate() {
            acc += w;
            if u < acc {
                j = i;
                break;
            }
        }
        let dim = self.dim();
        let mut z = DVector::zeros(dim);
        let mut i = 0;
        while i < dim {
            // Box-Muller, both values used; written out so that draws depend on nothing but
            // the generator's stream (no distribution crate whose algorithm could change).
            let u1 = 1.0 - rng.gen::<f64>(); // (0, 1], keeps ln finite
            let u2: f64 = rng.gen();
            let r = (-2.0 * u1.ln()).sqrt();
            let t = 2.0 * std::f64::consts::PI * u2;
            z[i] = r * t.cos();
            if i + 1 < dim {
                z[i + 1] = r * t.sin();
            }
            i += 2;
        }
        let y = &self.chol * z;
        self.means[j]
            .iter()
            .zip(y.iter())
            .map(|(m, v)| m + v)
            .collect()
    }

    /// Number of components kept by the fit.
    pub fn components(&self) -> usize {
        self.means.len()
    }

    /// Number of coordinates.
    pub fn dim(&self) -> usize {
        self.means[0].len()
    }

    /// Mixture weights (sum 1).
    pub fn weights(&self) -> &[f64] {
        &self.weights
    }

    /// Component means.
    pub fn means(&self) -> &[Vec<f64>] {
        &self.means
    }

    /// The covariance all components share (regularisation included).
    pub fn covariance(&self) -> &DMatrix<f64> {
        &self.covariance
    }
}

fn weighted_mean(xs: &[&[f64]], w: &[f64], dim: usize) -> Vec<f64> {
    let mut m = vec![0.0; dim];
    for (x, wi) in xs.iter().zip(w) {
        for (a, v) in m.iter_mut().zip(x.iter()) {
            *a += wi * v;
        }
    }
    m
}

fn dist2(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| (x - y).powi(2)).sum()
}

/// Index drawn with probability proportional to `p` (which sums to `total` > 0).
fn draw_index(p: &[f64], total: f64, rng: &mut Pcg64) -> usize {
    let u = rng.gen::<f64>() * total;
    let mut acc = 0.0;
    let mut last = 0;
    for (i, v) in p.iter().enumerate() {
        if *v > 0.0 {
            acc += v;
            last = i;
            if u < acc {
                return i;
            }
        }
    }
    last
}

/// Weighted k-means++ seeding: the first centre by weight, each further one with probability
/// proportional to weight x squared distance to the nearest centre. Stops early when every
/// point coincides with a centre (fewer distinct points than components).
fn kmeans_plus_plus(xs: &[&[f64]], w: &[f64], k: usize, rng: &mut Pcg64) -> Vec<Vec<f64>> {
    let first = draw_index(w, w.iter().sum(), rng);
    let mut centres = vec![xs[first].to_vec()];
    let mut d2: Vec<f64> = xs.iter().map(|x| dist2(x, &centres[0])).collect();
    while centres.len() < k {
        let p: Vec<f64> = d2.iter().zip(w).map(|(d, w)| d * w).collect();
        let total: f64 = p.iter().sum();
        if total <= 0.0 {
            break;
        }
        let i = draw_index(&p, total, rng);
        centres.push(xs[i].to_vec());
        let c = centres.last().expect("just pushed");
        for (d, x) in d2.iter_mut().zip(xs) {
            *d = d.min(dist2(x, c));
        }
    }
    centres
}

/// Weighted Lloyd iterations from `centres`; drops centres left without points. Returns each
/// point's centre.
fn kmeans(xs: &[&[f64]], w: &[f64], centres: &mut Vec<Vec<f64>>) -> Vec<usize> {
    let dim = xs[0].len();
    let nearest = |x: &[f64], cs: &[Vec<f64>]| -> usize {
        let mut best = 0;
        let mut bd = f64::INFINITY;
        for (j, c) in cs.iter().enumerate() {
            let d = dist2(x, c);
            if d < bd {
                bd = d;
                best = j;
            }
        }
        best
    };
    let mut assign: Vec<usize> = xs.iter().map(|x| nearest(x, centres)).collect();
    for _ in 0..KMEANS_ITERATIONS {
        let k = centres.len();
        let mut sums = vec![vec![0.0; dim]; k];
        let mut mass = vec![0.0; k];
        for ((x, a), wi) in xs.iter().zip(&assign).zip(w) {
            mass[*a] += wi;
            for (s, v) in sums[*a].iter_mut().zip(x.iter()) {
                *s += wi * v;
            }
        }
        let new: Vec<Vec<f64>> = (0..k)
            .filter(|&j| mass[j] > 0.0)
            .map(|j| sums[j].iter().map(|s| s / mass[j]).collect())
            .collect();
        *centres = new;
        let next: Vec<usize> = xs.iter().map(|x| nearest(x, centres)).collect();
        let done = next == assign;
        assign = next;
        if done {
            break;
        }
    }
    // A final pass can leave a centre with no points; drop it and renumber.
    let k = centres.len();
    let used: Vec<bool> = (0..k).map(|j| assign.contains(&j)).collect();
    if used.iter().all(|u| *u) {
        return assign;
    }
    let mut map = vec![usize::MAX; k];
    let mut kept = Vec::new();
    for j in 0..k {
        if used[j] {
            map[j] = kept.len();
            kept.push(centres[j].clone());
        }
    }
    *centres = kept;
    assign.iter().map(|a| map[*a]).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn single_gaussian_recovers_mean_and_covariance() {
        let truth = GaussianMixture {
            weights: vec![1.0],
            means: vec![vec![0.2, -0.1]],
            covariance: DMatrix::identity(2, 2),
            chol: DMatrix::from_row_slice(2, 2, &[0.1, 0.0, 0.05, 0.08]),
            log_norm: 0.0,
        };
        let mut rng = Pcg64::seed_from_u64(5);
        let pts: Vec<Vec<f64>> = (0..4000).map(|_| truth.sample(&mut rng)).collect();
        let w = vec![1.0; pts.len()];
        let m = GaussianMixture::fit(&pts, &w, 1, 1).unwrap();
        assert_eq!(m.components(), 1);
        assert!((m.means()[0][0] - 0.2).abs() < 0.01);
        assert!((m.means()[0][1] + 0.1).abs() < 0.01);
        // covariance = L L^T = [[0.01, 0.005], [0.005, 0.0089]]
        let c = m.covariance();
        assert!((c[(0, 0)] - 0.01).abs() < 0.001, "{c}");
        assert!((c[(1, 0)] - 0.005).abs() < 0.001, "{c}");
        assert!((c[(1, 1)] - 0.0089).abs() < 0.001, "{c}");
    }

    #[test]
    fn coincident_points_give_one_narrow_component() {
        let pts = vec![vec![0.3, 0.3]; 5];
        let m = GaussianMixture::fit(&pts, &[1.0; 5], 4, 0).unwrap();
        assert_eq!(m.components(), 1);
        assert!(m.density(&[0.3, 0.3]) > 1e6);
    }

    #[test]
    fn bad_input_is_an_error() {
        let pts = vec![vec![0.0, 0.0], vec![1.0, 1.0]];
        assert!(GaussianMixture::fit(&pts, &[1.0], 2, 0).is_err());
        assert!(GaussianMixture::fit(&pts, &[0.0, 0.0], 2, 0).is_err());
        assert!(GaussianMixture::fit(&pts, &[1.0, -1.0], 2, 0).is_err());
        assert!(GaussianMixture::fit(&pts, &[1.0, 1.0], 0, 0).is_err());
        assert!(GaussianMixture::fit(&[], &[], 2, 0).is_err());
        assert!(GaussianMixture::fit(&[vec![0.0], vec![0.0, 1.0]], &[1.0, 1.0], 2, 0).is_err());
        assert!(GaussianMixture::fit(&[vec![f64::NAN]], &[1.0], 1, 0).is_err());
        let m = GaussianMixture::fit(&pts, &[1.0, 1.0], 1, 0).unwrap();
        assert!(m.density(&[0.0]).is_nan());
    }
}
