//! Sequential Monte Carlo calibration: the iterative Bayesian filter of GrainLearning 2.
//!
//! Each iteration runs a batch of parameter samples, weighs them by a Gaussian likelihood of
//! their misfit whose scale sigma is tuned so that the effective sample size is a set fraction
//! of the batch (a tempering: sigma shrinks from iteration to iteration as the samples close
//! in), fits a Gaussian mixture to the weighted samples and draws the next batch from it. The
//! first batch is a Halton sequence over the box.
//!
//! Everything is in coded units: each parameter's box is [-1, 1] and the prior is uniform on
//! it. Unlike GrainLearning (which by default leaves the proposal out of the weights), the
//! weights here are proper importance weights, likelihood x prior / proposal, so that with a
//! fixed sigma the weighted samples estimate the true posterior whatever the proposal.
//!
//! The study stage calls [`halton`], [`weigh`] and [`next_samples`] one iteration at a time and
//! stores what they return; all three are pure functions of their arguments (the seed of
//! iteration i is [`iteration_seed`]`(seed, i)`), so a replay from the store asks for the same
//! samples bit for bit. [`run`] strings them together for callers that can evaluate a batch
//! directly.

use rand_pcg::Pcg64;
use serde::Serialize;

use crate::mixture::GaussianMixture;

/// The first `dim` primes, the Halton bases.
fn primes(dim: usize) -> Vec<u64> {
    let mut out = Vec::with_capacity(dim);
    let mut c = 2u64;
    while out.len() < dim {
        if out
            .iter()
            .take_while(|p| *p * *p <= c)
            .all(|p| !c.is_multiple_of(*p))
        {
            out.push(c);
        }
        c += 1;
    }
    out
}

fn radical_inverse(mut i: u64, base: u64) -> f64 {
    let b = base as f64;
    let mut f = 1.0 / b;
    let mut r = 0.0;
    while i > 0 {
        r += f * (i % base) as f64;
        i /= base;
        f /= b;
    }
    r
}

/// `n` Halton points in the coded box [-1, 1]^dim, bases 2, 3, 5, 7, 11, ... (unscrambled, as
/// GrainLearning draws them). The sequence starts at index 1: index 0 is the corner
/// (-1, ..., -1), a point no low-discrepancy design wants.
pub fn halton(n: usize, dim: usize) -> Vec<Vec<f64>> {
    let bases = primes(dim);
    (1..=n as u64)
        .map(|i| {
            bases
                .iter()
                .map(|&b| 2.0 * radical_inverse(i, b) - 1.0)
                .collect()
        })
        .collect()
}

/// Default samples per iteration for `dim` parameters: GrainLearning's ceil(6 n ln n), but at
/// least 5 n + 10, since n ln n is 0 for one parameter and 8 for two, too few for a mixture to
/// learn anything from 30 % of them (1: 15, 2: 20, 3: 25, 4: 34, 5: 49, 8: 100, 10: 139).
pub fn default_samples(dim: usize) -> usize {
    let n = dim as f64;
    let gl = if dim > 1 {
        (6.0 * n * n.ln()).ceil() as usize
    } else {
        0
    };
    gl.max(5 * dim + 10)
}

/// How the likelihood scale sigma is chosen.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum LikelihoodScale {
    /// Sigma tuned (bisection on ln sigma) so that ESS / N equals this fraction (GrainLearning's
    /// `ess_target`, 0.3 by default).
    EssTarget(f64),
    /// A fixed sigma: the weights estimate the posterior of a problem whose misfit is already
    /// scaled by the known noise (sigma 1).
    Fixed(f64),
}

/// Settings of [`run`] (and of a study's SMC stage).
#[derive(Clone, Debug)]
pub struct SmcOptions {
    /// Samples per iteration.
    pub samples: usize,
    /// Most iterations.
    pub iterations: usize,
    pub scale: LikelihoodScale,
    /// With [`LikelihoodScale::EssTarget`], stop once the tuned sigma reaches this; that
    /// iteration's weights are computed at this sigma instead (GrainLearning's `sigma_tol`).
    pub sigma_tolerance: f64,
    /// Upper bound on the mixture's components.
    pub components: usize,
    pub seed: u64,
}

impl SmcOptions {
    /// Defaults for `dim` parameters: [`default_samples`] samples, max(4, dim) iterations (the
    /// published runs took about 4 for 4 parameters), ESS target 0.3, sigma tolerance 1 (the
    /// misfit is scaled by the lab's own spread, so sigma 1 is the likelihood of the lab noise:
    /// tempering further would fit the noise), components samples / 10 within [2, 8].
    pub fn for_dim(dim: usize, seed: u64) -> Self {
        let samples = default_samples(dim);
        SmcOptions {
            samples,
            iterations: dim.max(4),
            scale: LikelihoodScale::EssTarget(0.3),
            sigma_tolerance: 1.0,
            components: (samples / 10).clamp(2, 8),
            seed,
        }
    }

    /// Checks the settings; the error names the first bad one.
    pub fn validate(&self) -> Result<(), String> {
        if self.samples < 2 {
            return Err(format!(
                "smc: expected at least 2 samples per iteration, got {}",
                self.samples
            ));
        }
        if self.iterations == 0 {
            return Err("smc: expected at least 1 iteration, got 0".into());
        }
        if self.components == 0 {
            return Err("smc: expected at least 1 mixture component, got 0".into());
        }
        if !(self.sigma_tolerance.is_finite() && self.sigma_tolerance >= 0.0) {
            return Err(format!(
                "smc: expected a finite non-negative sigma tolerance, got {}",
                self.sigma_tolerance
            ));
        }
        check_scale(self.scale)
    }
}

fn check_scale(scale: LikelihoodScale) -> Result<(), String> {
    match scale {
        LikelihoodScale::EssTarget(f) if !(f > 0.0 && f <= 1.0) => Err(format!(
            "smc: expected an ESS target fraction in (0, 1], got {f}"
        )),
        LikelihoodScale::Fixed(s) if !(s.is_finite() && s > 0.0) => Err(format!(
            "smc: expected a finite positive fixed sigma, got {s}"
        )),
        _ => Ok(()),
    }
}

/// Weighted summary of an ensemble.
#[derive(Clone, Debug, Serialize)]
pub struct Posterior {
    pub mean: Vec<f64>,
    pub std: Vec<f64>,
    /// 95 % credible interval (2.5 % and 97.5 % weighted quantiles) of each coordinate.
    pub credible: Vec<(f64, f64)>,
    /// Effective sample size of the weights.
    pub ess: f64,
    pub sigma: f64,
}

/// Coded samples lie in the box up to rounding.
const BOX_SLACK: f64 = 1e-12;

fn in_box(x: &[f64]) -> bool {
    x.iter().all(|v| v.abs() <= 1.0 + BOX_SLACK)
}

/// Importance weights of one iteration: likelihood exp(-misfit / (2 sigma^2)) x prior /
/// proposal, normalised to sum 1, and the sigma used. `samples` are coded, `proposal_density`
/// is the density each sample was drawn from (2^-dim for the uniform first iteration, the
/// mixture density from [`next_samples`] later), `misfit` the caller's sum over responses of
/// ((simulated - lab) / lab_spread)^2. A sample outside the box gets weight zero (the prior
/// vanishes there).
///
/// With [`LikelihoodScale::EssTarget`] the smallest sigma whose ESS reaches the target is
/// taken (ESS need not grow monotonically with sigma once the proposal is not uniform); when no
/// sigma reaches it, the sigma of largest ESS.
pub fn weigh(
    samples: &[Vec<f64>],
    proposal_density: &[f64],
    misfit: &[f64],
    scale: LikelihoodScale,
) -> Result<(Vec<f64>, f64), String> {
    let n = samples.len();
    if n == 0 {
        return Err("smc weigh: expected at least one sample, got none".into());
    }
    if proposal_density.len() != n || misfit.len() != n {
        return Err(format!(
            "smc weigh: expected one proposal density and one misfit per sample ({n}), got {} and {}",
            proposal_density.len(),
            misfit.len()
        ));
    }
    let dim = samples[0].len();
    if dim == 0 {
        return Err("smc weigh: expected samples with at least one coordinate".into());
    }
    for (i, s) in samples.iter().enumerate() {
        if s.len() != dim || s.iter().any(|v| !v.is_finite()) {
            return Err(format!(
                "smc weigh: expected {dim} finite coordinates in every sample, sample {i} is {s:?}"
            ));
        }
    }
    if let Some(i) = proposal_density
        .iter()
        .position(|q| !(q.is_finite() && *q > 0.0))
    {
        return Err(format!(
            "smc weigh: expected finite positive proposal densities, sample {i} has {}",
            proposal_density[i]
        ));
    }
    if let Some(i) = misfit.iter().position(|m| !m.is_finite()) {
        return Err(format!(
            "smc weigh: expected finite misfits, sample {i} has {}",
            misfit[i]
        ));
    }
    check_scale(scale)?;

    let inside: Vec<bool> = samples.iter().map(|s| in_box(s)).collect();
    let best = misfit
        .iter()
        .zip(&inside)
        .filter(|(_, i)| **i)
        .map(|(m, _)| *m)
        .fold(f64::INFINITY, f64::min);
    if best == f64::INFINITY {
        return Err("smc weigh: expected some sample inside the coded box [-1, 1], none is".into());
    }
    // Misfit above the best, so that the likelihood's exponent never overflows; the constant
    // factor it removes cancels in the normalisation.
    let excess: Vec<f64> = misfit.iter().map(|m| m - best).collect();
    // ln(prior / proposal); the prior's 2^-dim cancels too but keeps the numbers meaningful.
    let base: Vec<f64> = proposal_density
        .iter()
        .zip(&inside)
        .map(|(q, i)| {
            if *i {
                -(dim as f64) * std::f64::consts::LN_2 - q.ln()
            } else {
                f64::NEG_INFINITY
            }
        })
        .collect();
    let weights_at = |sigma: f64| -> Vec<f64> {
        let inv = 1.0 / (2.0 * sigma * sigma);
        let logw: Vec<f64> = base.iter().zip(&excess).map(|(b, e)| b - e * inv).collect();
        let top = logw.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
        let mut w: Vec<f64> = logw.iter().map(|l| (l - top).exp()).collect();
        let s: f64 = w.iter().sum();
        w.iter_mut().for_each(|v| *v /= s);
        w
    };

    let sigma = match scale {
        LikelihoodScale::Fixed(s) => s,
        LikelihoodScale::EssTarget(fraction) => {
            let target = fraction * n as f64;
            let positive: Vec<f64> = excess
                .iter()
                .zip(&inside)
                .filter(|(e, i)| **i && **e > 0.0)
                .map(|(e, _)| *e)
                .collect();
            if positive.is_empty() {
                return Err(
                    "smc weigh: expected misfits that differ between samples, all are equal".into(),
                );
            }
            let lo_e = positive.iter().cloned().fold(f64::INFINITY, f64::min);
            let hi_e = positive.iter().cloned().fold(0.0, f64::max);
            // Below sigma = sqrt(lo_e) e^-5 every sample but the best is weighed out by
            // e^-11000 or more; above sqrt(hi_e) e^5 the likelihood is flat to 1e-4.
            let t_lo = 0.5 * lo_e.ln() - 5.0;
            let t_hi = 0.5 * hi_e.ln() + 5.0;
            let ess_at = |t: f64| effective_sample_size(&weights_at(t.exp()));
            const GRID: usize = 400;
            let grid: Vec<f64> = (0..=GRID)
                .map(|k| t_lo + (t_hi - t_lo) * k as f64 / GRID as f64)
                .collect();
            let mut found = None;
            let mut best_t = grid[0];
            let mut best_ess = f64::NEG_INFINITY;
            for (k, &t) in grid.iter().enumerate() {
                let e = ess_at(t);
                if e > best_ess {
                    best_ess = e;
                    best_t = t;
                }
                if e >= target {
                    found = Some(k);
                    break;
                }
            }
            match found {
                None => best_t.exp(),
                Some(0) => grid[0].exp(),
                Some(k) => {
                    // ESS is below the target at grid[k-1] and at or above it at grid[k].
                    let (mut a, mut b) = (grid[k - 1], grid[k]);
                    for _ in 0..200 {
                        let m = 0.5 * (a + b);
                        if m <= a || m >= b {
                            break;
                        }
                        if ess_at(m) >= target {
                            b = m;
                        } else {
                            a = m;
                        }
                    }
                    b.exp()
                }
            }
        }
    };
    Ok((weights_at(sigma), sigma))
}

/// Kish's effective sample size (sum w)^2 / sum w^2, i.e. 1 / sum w^2 for normalised weights;
/// 0 for no (or all-zero) weights.
pub fn effective_sample_size(weights: &[f64]) -> f64 {
    let s: f64 = weights.iter().sum();
    let s2: f64 = weights.iter().map(|w| w * w).sum();
    if s2 > 0.0 {
        s * s / s2
    } else {
        0.0
    }
}

/// Weighted quantile `p` of values sorted ascending with their normalised weights: linear
/// interpolation between the points' mid-cumulative weights.
fn weighted_quantile(sorted: &[(f64, f64)], p: f64) -> f64 {
    let mut mids = Vec::with_capacity(sorted.len());
    let mut acc = 0.0;
    for (_, w) in sorted {
        mids.push(acc + 0.5 * w);
        acc += w;
    }
    if p <= mids[0] {
        return sorted[0].0;
    }
    for k in 1..sorted.len() {
        if p <= mids[k] {
            let f = (p - mids[k - 1]) / (mids[k] - mids[k - 1]);
            return sorted[k - 1].0 + f * (sorted[k].0 - sorted[k - 1].0);
        }
    }
    sorted[sorted.len() - 1].0
}

/// Weighted mean, standard deviation and 95 % credible interval of each coordinate of `points`
/// (coded or actual values, as the caller likes). Weights need not be normalised; negative or
/// non-finite weights count as zero, and points beyond the weights or with a different number
/// of coordinates from the first are left out. With no usable weight every statistic is NaN.
pub fn posterior(points: &[Vec<f64>], weights: &[f64], sigma: f64) -> Posterior {
    let dim = points.first().map_or(0, |p| p.len());
    let used: Vec<(&Vec<f64>, f64)> = points
        .iter()
        .zip(weights)
        .filter(|(p, w)| p.len() == dim && w.is_finite() && **w > 0.0)
        .map(|(p, w)| (p, *w))
        .collect();
    let total: f64 = used.iter().map(|(_, w)| w).sum();
    let ws: Vec<f64> = used.iter().map(|(_, w)| w / total).collect();
    let ess = effective_sample_size(&ws);
    if used.is_empty() || !total.is_finite() {
        return Posterior {
            mean: vec![f64::NAN; dim],
            std: vec![f64::NAN; dim],
            credible: vec![(f64::NAN, f64::NAN); dim],
            ess: 0.0,
            sigma,
        };
    }
    let mut mean = vec![0.0; dim];
    let mut std = vec![0.0; dim];
    let mut credible = Vec::with_capacity(dim);
    for d in 0..dim {
        let m: f64 = used.iter().zip(&ws).map(|((p, _), w)| w * p[d]).sum();
        let v: f64 = used
            .iter()
            .zip(&ws)
            .map(|((p, _), w)| w * (p[d] - m).powi(2))
            .sum();
        mean[d] = m;
        std[d] = v.sqrt();
        let mut sorted: Vec<(f64, f64)> =
            used.iter().zip(&ws).map(|((p, _), w)| (p[d], *w)).collect();
        sorted.sort_by(|a, b| a.0.total_cmp(&b.0));
        credible.push((
            weighted_quantile(&sorted, 0.025),
            weighted_quantile(&sorted, 0.975),
        ));
    }
    Posterior {
        mean,
        std,
        credible,
        ess,
        sigma,
    }
}

/// SplitMix64 finaliser: decorrelates nearby seeds.
fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// The seed [`run`] passes to [`next_samples`] for iteration `iteration` (1 for the batch
/// after the Halton one); a study stage uses the same so that a CLI run and a study agree.
pub fn iteration_seed(seed: u64, iteration: usize) -> u64 {
    mix64(seed ^ mix64(iteration as u64 ^ 0x5343_4d43))
}

/// Draws, at most, per sample wanted before giving up on a mixture that puts almost no mass
/// in the box (it was fitted to in-box points, so this means broken input).
const MAX_DRAWS_PER_SAMPLE: usize = 1000;
/// Draws made in all (extra ones only counted) to estimate the mixture's mass in the box.
const MASS_DRAWS: usize = 20_000;

/// The next iteration's samples: a Gaussian mixture (at most `components`) fitted to the
/// weighted `samples`, `n` draws from it inside the box, and the density each was drawn from.
///
/// Draws outside the box are rejected and redrawn rather than clipped: clipping would pile
/// samples onto the faces, where the proposal has a point mass and no density, breaking the
/// importance weights. The proposal is then the mixture truncated to the box, whose density is
/// the mixture's divided by its in-box mass, estimated as the accepted fraction of at least
/// 20 000 draws. (The mass is one factor common to all samples of the batch, so the normalised
/// weights do not depend on its accuracy; it only makes the reported density right.)
pub fn next_samples(
    samples: &[Vec<f64>],
    weights: &[f64],
    n: usize,
    components: usize,
    seed: u64,
) -> Result<(Vec<Vec<f64>>, Vec<f64>), String> {
    if n == 0 {
        return Err("smc next samples: expected at least 1 sample to draw, got 0".into());
    }
    let mix = GaussianMixture::fit(samples, weights, components, seed)?;
    // A stream of its own, so that the draws do not depend on how many numbers the fit used.
    let mut rng = Pcg64::new(seed as u128, 0x736d_6364_7261_7773);
    let mut out = Vec::with_capacity(n);
    let mut draws = 0usize;
    let cap = MAX_DRAWS_PER_SAMPLE * n + MASS_DRAWS;
    while out.len() < n {
        if draws >= cap {
            return Err(format!(
                "smc next samples: expected the mixture to put mass in the box [-1, 1], {} of {draws} draws fell inside",
                out.len()
            ));
        }
        let x = mix.sample(&mut rng);
        draws += 1;
        if in_box(&x) {
            out.push(x);
        }
    }
    let mut accepted = n;
    while draws < MASS_DRAWS {
        let x = mix.sample(&mut rng);
        draws += 1;
        if in_box(&x) {
            accepted += 1;
        }
    }
    let mass = accepted as f64 / draws as f64;
    let density = out.iter().map(|x| mix.density(x) / mass).collect();
    Ok((out, density))
}

/// Why to stop after iterations whose sigmas are `sigmas` (None: go on). With an ESS target,
/// stop once sigma reaches the tolerance; in any case after `opts.iterations`.
pub fn stop_reason(opts: &SmcOptions, sigmas: &[f64]) -> Option<String> {
    let last = *sigmas.last()?;
    if matches!(opts.scale, LikelihoodScale::EssTarget(_)) && last <= opts.sigma_tolerance {
        return Some(format!(
            "sigma {last:.4e} reached the tolerance {:.4e} after {} iteration(s)",
            opts.sigma_tolerance,
            sigmas.len()
        ));
    }
    if sigmas.len() >= opts.iterations {
        return Some(format!(
            "ran the {} iteration(s) asked for (last sigma {last:.4e})",
            opts.iterations
        ));
    }
    None
}

/// One iteration of the filter.
#[derive(Clone, Debug)]
pub struct Iteration {
    pub samples: Vec<Vec<f64>>,
    pub proposal_density: Vec<f64>,
    pub misfit: Vec<f64>,
    pub weights: Vec<f64>,
    pub sigma: f64,
    pub posterior: Posterior,
}

/// The whole filter for callers that evaluate directly (tests, CLI): `f` maps a batch of coded
/// samples to their misfits. Iteration 0 is [`halton`]; iteration i > 0 is [`next_samples`]
/// with [`iteration_seed`]`(opts.seed, i)`. With an ESS target, an iteration whose tuned sigma
/// falls to the tolerance is weighed at the tolerance and ends the run.
pub fn run(
    dim: usize,
    mut f: impl FnMut(&[Vec<f64>]) -> Vec<f64>,
    opts: &SmcOptions,
) -> Result<Vec<Iteration>, String> {
    if dim == 0 {
        return Err("smc: expected at least 1 parameter, got 0".into());
    }
    opts.validate()?;
    let mut samples = halton(opts.samples, dim);
    let mut proposal = vec![0.5f64.powi(dim as i32); samples.len()];
    let mut out: Vec<Iteration> = Vec::new();
    let mut sigmas = Vec::new();
    loop {
        let misfit = f(&samples);
        if misfit.len() != samples.len() {
            return Err(format!(
                "smc: expected one misfit per sample ({}), the evaluation returned {}",
                samples.len(),
                misfit.len()
            ));
        }
        let (mut weights, mut sigma) = weigh(&samples, &proposal, &misfit, opts.scale)?;
        if matches!(opts.scale, LikelihoodScale::EssTarget(_)) && sigma < opts.sigma_tolerance {
            // Tempering past the tolerance would sharpen the posterior beyond what the
            // misfit's scale supports.
            (weights, sigma) = weigh(
                &samples,
                &proposal,
                &misfit,
                LikelihoodScale::Fixed(opts.sigma_tolerance),
            )?;
        }
        let post = posterior(&samples, &weights, sigma);
        sigmas.push(sigma);
        let stop = stop_reason(opts, &sigmas).is_some();
        let (next, next_q) = if stop {
            (Vec::new(), Vec::new())
        } else {
            next_samples(
                &samples,
                &weights,
                opts.samples,
                opts.components,
                iteration_seed(opts.seed, out.len() + 1),
            )?
        };
        out.push(Iteration {
            samples: std::mem::replace(&mut samples, next),
            proposal_density: std::mem::replace(&mut proposal, next_q),
            misfit,
            weights,
            sigma,
            posterior: post,
        });
        if stop {
            return Ok(out);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ess_of_uniform_and_degenerate_weights() {
        assert_eq!(effective_sample_size(&[0.25; 4]), 4.0);
        assert_eq!(effective_sample_size(&[1.0, 0.0, 0.0]), 1.0);
        assert_eq!(effective_sample_size(&[]), 0.0);
        assert!((effective_sample_size(&[2.0; 5]) - 5.0).abs() < 1e-12);
    }

    #[test]
    fn default_samples_table() {
        let v: Vec<usize> = (1..=5).map(default_samples).collect();
        assert_eq!(v, vec![15, 20, 25, 34, 49]);
        assert_eq!(default_samples(10), 139);
    }

    #[test]
    fn weighted_quantiles_of_equal_weights() {
        let pts: Vec<Vec<f64>> = (0..1001).map(|i| vec![i as f64 / 1000.0]).collect();
        let p = posterior(&pts, &vec![1.0; 1001], 1.0);
        assert!((p.mean[0] - 0.5).abs() < 1e-12);
        assert!((p.credible[0].0 - 0.025).abs() < 1e-3);
        assert!((p.credible[0].1 - 0.975).abs() < 1e-3);
        assert!((p.std[0] - (1.0f64 / 12.0).sqrt()).abs() < 1e-3);
    }

    #[test]
    fn posterior_without_weight_is_nan() {
        let p = posterior(&[vec![0.0, 1.0]], &[0.0], 1.0);
        assert!(p.mean[0].is_nan() && p.std[1].is_nan());
        assert_eq!(p.ess, 0.0);
    }

    #[test]
    fn stop_reasons() {
        let opts = SmcOptions::for_dim(2, 0);
        assert!(stop_reason(&opts, &[]).is_none());
        assert!(stop_reason(&opts, &[5.0, 3.0]).is_none());
        assert!(stop_reason(&opts, &[5.0, 0.9])
            .unwrap()
            .contains("tolerance"));
        assert!(stop_reason(&opts, &[5.0, 4.0, 3.0, 2.0])
            .unwrap()
            .contains("iteration"));
        let fixed = SmcOptions {
            scale: LikelihoodScale::Fixed(0.1),
            ..opts
        };
        assert!(stop_reason(&fixed, &[0.1]).is_none());
    }
}
