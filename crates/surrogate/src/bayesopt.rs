//! Bayesian optimisation: a Latin hypercube, then batches of points that maximise expected
//! improvement on a [`Gp`] fitted to every evaluation so far, minimising the objective.
//!
//! [`propose`] is a pure function of the evaluations, the options and the iteration number, so
//! a study that replays its store asks for the same points bit for bit; [`minimize`] is the whole
//! loop for callers that can evaluate the objective themselves.
//!
//! Batches use the constant liar: after picking a point, the GP is conditioned on a pretend
//! observation there equal to the lowest response seen (hyperparameters kept), which lowers the
//! expected improvement around it, and the next point is picked on that GP.

use crate::gp::{Gp, GpOptions};
use doe::design::{latin_hypercube, LhsKind, MAX_MAXIMIN_RUNS};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use serde::Serialize;

/// How to run Bayesian optimisation.
#[derive(Clone, Debug)]
pub struct BoOptions {
    /// Points of the initial Latin hypercube; 0 means 10 per factor.
    pub initial: usize,
    /// Batches to propose after the initial design.
    pub iterations: usize,
    /// Points per batch (parallel runs).
    pub batch: usize,
    /// Most evaluations in all, the initial design included.
    pub budget: Option<usize>,
    /// Stop after this many iterations without improving the best observed value by more than
    /// `tolerance`.
    pub patience: Option<usize>,
    /// In the objective's units.
    pub tolerance: f64,
    pub gp: GpOptions,
    /// Seeds the initial design and the search for the next points.
    pub seed: u64,
}

impl Default for BoOptions {
    fn default() -> BoOptions {
        BoOptions {
            initial: 0,
            iterations: 20,
            batch: 1,
            budget: None,
            patience: None,
            tolerance: 0.0,
            gp: GpOptions::default(),
            seed: 0,
        }
    }
}

/// Random points scored before the local searches, per factor and in all.
const CANDIDATES_PER_FACTOR: usize = 200;
const CANDIDATES_BASE: usize = 500;
/// Best candidates refined by Nelder-Mead.
const LOCAL_STARTS: usize = 5;
/// Function evaluations per local search, per factor.
const LOCAL_EVALUATIONS_PER_FACTOR: usize = 60;
/// Points of one batch closer than this (coded units) count as the same point.
const MIN_SEPARATION: f64 = 1e-3;

/// Initial design of `n` points in the coded box [-1, 1]^dim: a maximin Latin hypercube, or a
/// random one beyond the size the maximin search can handle.
pub fn initial_design(dim: usize, n: usize, seed: u64) -> Result<Vec<Vec<f64>>, String> {
    let kind = if n <= MAX_MAXIMIN_RUNS {
        LhsKind::Maximin
    } else {
        LhsKind::Random
    };
    latin_hypercube(dim, n, kind, seed)
        .map(|d| d.runs)
        .map_err(|e| format!("Bayesian optimisation initial design: {e}"))
}

/// Expected improvement below `best` of a normal prediction (mean, variance): the expected
/// amount by which a new evaluation beats `best`, for minimisation.
pub fn expected_improvement(mean: f64, variance: f64, best: f64) -> f64 {
    log_expected_improvement(mean, variance, best).exp()
}

/// The logarithm of [`expected_improvement`], accurate where the improvement itself underflows,
/// so that the search still has a slope to climb far from the best point (-inf where no
/// improvement is possible).
pub fn log_expected_improvement(mean: f64, variance: f64, best: f64) -> f64 {
    if !(mean.is_finite() && variance.is_finite() && best.is_finite()) {
        return f64::NAN;
    }
    let sd = variance.max(0.0).sqrt();
    if sd <= 1e-300 || sd <= 1e-15 * (mean.abs() + best.abs()) {
        return (best - mean).max(0.0).ln();
    }
    let z = (best - mean) / sd;
    // EI = sd (z Phi(z) + phi(z)) = sd phi(z) (1 + z Phi(z)/phi(z)).
    let ln_phi = -0.5 * z * z - 0.5 * (2.0 * std::f64::consts::PI).ln();
    let tail = if z > -1.0 {
        let phi = ln_phi.exp();
        let cdf = 0.5 * erfc(-z / std::f64::consts::SQRT_2);
        return sd.ln() + (z * cdf + phi).ln();
    } else if z > -30.0 {
        // Phi(z)/phi(z) = sqrt(pi/2) erfcx(-z/sqrt 2), without underflow.
        1.0 + z * (std::f64::consts::PI / 2.0).sqrt() * erfcx(-z / std::f64::consts::SQRT_2)
    } else {
        // Asymptotic series, where the subtraction above would cancel.
        let w = 1.0 / (z * z);
        w * (1.0 - 3.0 * w + 15.0 * w * w)
    };
    sd.ln() + ln_phi + tail.ln()
}

/// exp(x^2) erfc(x) for x >= 0 (Numerical Recipes' Chebyshev fit, relative error below 1.2e-7).
fn erfcx(x: f64) -> f64 {
    let t = 1.0 / (1.0 + 0.5 * x);
    let poly = -1.265_512_23
        + t * (1.000_023_68
            + t * (0.374_091_96
                + t * (0.096_784_18
                    + t * (-0.186_288_06
                        + t * (0.278_868_07
                            + t * (-1.135_203_98
                                + t * (1.488_515_87 + t * (-0.822_152_23 + t * 0.170_872_77))))))));
    t * poly.exp()
}

fn erfc(x: f64) -> f64 {
    let v = erfcx(x.abs()) * (-x * x).exp();
    if x >= 0.0 {
        v
    } else {
        2.0 - v
    }
}

/// The next batch of points, and the GP that chose them.
#[derive(Clone, Debug)]
pub struct Proposal {
    /// Coded points, q of them, distinct.
    pub points: Vec<Vec<f64>>,
    /// Expected improvement of each point, in the objective's units, on the GP conditioned on
    /// the pretend observations at the points before it.
    pub expected_improvement: Vec<f64>,
    /// The lowest GP mean over the box: the objective the GP expects at its best point.
    pub predicted_minimum: f64,
    pub predicted_minimizer: Vec<f64>,
    /// Fitted to the evaluations only.
    pub gp: Gp,
}

/// The next q points to evaluate, minimising the objective y, given every evaluation so far
/// (failed runs left out). `iteration` numbers the call, so that each call searches with its own
/// seeded candidates while a replay of the same call repeats it. q = 0 only fits the GP and finds
/// its predicted minimum.
pub fn propose(
    x: &[Vec<f64>],
    y: &[f64],
    q: usize,
    opts: &BoOptions,
    iteration: usize,
) -> Result<Proposal, String> {
    let gp_opts = GpOptions {
        seed: mix(opts.gp.seed, iteration as u64, 0),
        ..opts.gp.clone()
    };
    let gp = Gp::fit(x, y, &gp_opts).map_err(|e| format!("Bayesian optimisation: {e}"))?;
    let dim = gp.dim();
    let mut rng = Pcg64::seed_from_u64(mix(opts.seed, iteration as u64, 1));

    let mean = |p: &[f64]| gp.predict_mean(p);
    let (predicted_minimizer, predicted_minimum) = search_box(&mean, dim, x.to_vec(), &mut rng);

    // Constant liar: the lowest response seen stands in for each pending point's result.
    let lie = y.iter().copied().fold(f64::INFINITY, f64::min);
    let mut points: Vec<Vec<f64>> = Vec::with_capacity(q);
    let mut improvements = Vec::with_capacity(q);
    let mut current = gp.clone();
    for k in 0..q {
        if k > 0 {
            current = gp
                .condition(&points, &vec![lie; points.len()])
                .map_err(|e| format!("Bayesian optimisation: {e}"))?;
        }
        // The best the GP believes has been seen: its mean at the evaluated points (and the
        // pending ones), since the lowest noisy observation is partly luck.
        let best = current
            .points()
            .iter()
            .map(|p| current.predict_mean(p))
            .fold(f64::INFINITY, f64::min);
        let chosen = &points;
        let score = |p: &[f64]| {
            if chosen.iter().any(|c| distance(c, p) < MIN_SEPARATION) {
                return f64::INFINITY;
            }
            let (m, v) = current.predict(p);
            let l = log_expected_improvement(m, v, best);
            if l.is_nan() {
                f64::INFINITY
            } else {
                -l
            }
        };
        let mut starts = vec![predicted_minimizer.clone()];
        starts.extend(x.iter().cloned());
        let (point, value) = search_box(&score, dim, starts, &mut rng);
        if !value.is_finite() {
            return Err(format!(
                "Bayesian optimisation: found no point with a finite expected improvement for batch point {} of {q}",
                k + 1
            ));
        }
        let (m, v) = current.predict(&point);
        improvements.push(expected_improvement(m, v, best));
        points.push(point);
    }
    Ok(Proposal {
        points,
        expected_improvement: improvements,
        predicted_minimum,
        predicted_minimizer,
        gp,
    })
}

fn distance(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(u, v)| (u - v).powi(2))
        .sum::<f64>()
        .sqrt()
}

/// A seed for one purpose of one iteration, so that neighbouring seeds give unrelated streams
/// (splitmix64 finaliser).
fn mix(seed: u64, iteration: u64, purpose: u64) -> u64 {
    let mut z = seed
        ^ iteration.wrapping_mul(0x9e37_79b9_7f4a_7c15)
        ^ purpose.wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// Minimises f over [-1, 1]^dim: scores the given starts (clamped into the box) and seeded
/// random points, then refines the best few with Nelder-Mead. The first of equal points wins.
fn search_box(
    f: &dyn Fn(&[f64]) -> f64,
    dim: usize,
    starts: Vec<Vec<f64>>,
    rng: &mut Pcg64,
) -> (Vec<f64>, f64) {
    let n_random = CANDIDATES_BASE + CANDIDATES_PER_FACTOR * dim;
    let mut candidates: Vec<(Vec<f64>, f64)> = starts
        .into_iter()
        .map(|p| p.iter().map(|v| v.clamp(-1.0, 1.0)).collect::<Vec<f64>>())
        .chain((0..n_random).map(|_| (0..dim).map(|_| rng.gen_range(-1.0..=1.0)).collect()))
        .map(|p| {
            let v = sanitise(f(&p));
            (p, v)
        })
        .collect();
    // A stable sort keeps the order of equal values, so ties go to the earlier candidate.
    candidates.sort_by(|a, b| a.1.total_cmp(&b.1));
    let mut best = candidates[0].clone();
    let mut refined: Vec<Vec<f64>> = Vec::new();
    for (p, v) in &candidates {
        if refined.len() == LOCAL_STARTS || !v.is_finite() {
            break;
        }
        if refined.iter().any(|r| distance(r, p) < 1e-6) {
            continue;
        }
        refined.push(p.clone());
        let (q, w) = nelder_mead(f, p, *v, LOCAL_EVALUATIONS_PER_FACTOR * dim);
        if w < best.1 {
            best = (q, w);
        }
    }
    best
}

fn sanitise(v: f64) -> f64 {
    if v.is_nan() {
        f64::INFINITY
    } else {
        v
    }
}

/// Nelder-Mead inside the box: every trial point is clamped to [-1, 1], so that a minimum on a
/// face is reached rather than stepped over.
fn nelder_mead(
    f: &dyn Fn(&[f64]) -> f64,
    start: &[f64],
    f_start: f64,
    max_evaluations: usize,
) -> (Vec<f64>, f64) {
    let dim = start.len();
    let clamp = |p: Vec<f64>| -> Vec<f64> { p.into_iter().map(|v| v.clamp(-1.0, 1.0)).collect() };
    let mut simplex: Vec<(Vec<f64>, f64)> = vec![(start.to_vec(), f_start)];
    for i in 0..dim {
        let mut p = start.to_vec();
        // Step inward from a face.
        p[i] += if p[i] > 0.9 { -0.1 } else { 0.1 };
        let v = sanitise(f(&p));
        simplex.push((p, v));
    }
    let mut evaluations = dim;
    while evaluations < max_evaluations {
        simplex.sort_by(|a, b| a.1.total_cmp(&b.1));
        let (lo, hi) = (simplex[0].1, simplex[dim].1);
        let size = simplex[1..]
            .iter()
            .map(|(p, _)| distance(p, &simplex[0].0))
            .fold(0.0, f64::max);
        if size < 1e-7 || (hi.is_finite() && hi - lo <= 1e-12 * (1.0 + lo.abs()) && size < 1e-4) {
            break;
        }
        let centroid: Vec<f64> = (0..dim)
            .map(|j| simplex[..dim].iter().map(|(p, _)| p[j]).sum::<f64>() / dim as f64)
            .collect();
        let towards = |t: f64| -> Vec<f64> {
            clamp(
                centroid
                    .iter()
                    .zip(&simplex[dim].0)
                    .map(|(c, w)| c + t * (w - c))
                    .collect(),
            )
        };
        let reflected = towards(-1.0);
        let fr = sanitise(f(&reflected));
        evaluations += 1;
        if fr < simplex[0].1 {
            let expanded = towards(-2.0);
            let fe = sanitise(f(&expanded));
            evaluations += 1;
            simplex[dim] = if fe < fr {
                (expanded, fe)
            } else {
                (reflected, fr)
            };
        } else if fr < simplex[dim - 1].1 {
            simplex[dim] = (reflected, fr);
        } else {
            let contracted = if fr < simplex[dim].1 {
                towards(-0.5)
            } else {
                towards(0.5)
            };
            let fc = sanitise(f(&contracted));
            evaluations += 1;
            if fc < fr.min(simplex[dim].1) {
                simplex[dim] = (contracted, fc);
            } else {
                // Shrink toward the best vertex.
                let best = simplex[0].0.clone();
                for (p, v) in simplex[1..].iter_mut() {
                    *p = clamp(
                        best.iter()
                            .zip(p.iter())
                            .map(|(b, x)| b + 0.5 * (x - b))
                            .collect(),
                    );
                    *v = sanitise(f(p));
                }
                evaluations += dim;
            }
        }
    }
    simplex.sort_by(|a, b| a.1.total_cmp(&b.1));
    simplex.swap_remove(0)
}

/// Where the optimisation stood after one iteration (iteration 0: the initial design).
#[derive(Clone, Debug, Serialize)]
pub struct IterationSummary {
    pub iteration: usize,
    /// Evaluations so far, failed ones included.
    pub evaluations: usize,
    pub best_observed: f64,
    /// The lowest mean of the GP fitted to the evaluations so far.
    pub predicted_minimum: f64,
}

/// Why to stop now (None = go on): iterations done, budget spent, or no improvement of the best
/// observed value by more than the tolerance in the last `patience` iterations.
pub fn stop_reason(opts: &BoOptions, history: &[IterationSummary]) -> Option<String> {
    let last = history.last()?;
    if last.iteration >= opts.iterations {
        return Some(format!("{} iterations done", opts.iterations));
    }
    if let Some(budget) = opts.budget {
        if last.evaluations >= budget {
            return Some(format!("budget of {budget} evaluations spent"));
        }
    }
    if let Some(p) = opts.patience.filter(|&p| p > 0) {
        if history.len() > p {
            let before = history[history.len() - 1 - p].best_observed;
            if before - last.best_observed <= opts.tolerance {
                return Some(format!(
                    "best value improved by no more than {} in {p} iterations",
                    opts.tolerance
                ));
            }
        }
    }
    None
}

/// Everything a full run evaluated, and where it ended.
#[derive(Clone, Debug)]
pub struct BoResult {
    /// Every evaluated point (coded), in order, failed ones included.
    pub x: Vec<Vec<f64>>,
    pub y: Vec<f64>,
    /// Index of the lowest finite y.
    pub best: usize,
    pub history: Vec<IterationSummary>,
    pub stop: String,
    /// The final GP's lowest mean and where it lies: on a noisy objective, often a better
    /// estimate of the minimiser than the lowest observation.
    pub predicted_minimum: f64,
    pub predicted_minimizer: Vec<f64>,
}

/// Full loop for callers that can evaluate directly (tests, CLI): Latin hypercube, then
/// propose/evaluate until [`stop_reason`]. `f` gets a batch of coded points and returns one value
/// each; non-finite values count as failed runs and are left out of the fits.
pub fn minimize(
    dim: usize,
    mut f: impl FnMut(&[Vec<f64>]) -> Vec<f64>,
    opts: &BoOptions,
) -> Result<BoResult, String> {
    check_options(dim, opts)?;
    let mut n0 = if opts.initial == 0 {
        10 * dim
    } else {
        opts.initial
    };
    if let Some(b) = opts.budget {
        n0 = n0.min(b);
    }
    let mut x = initial_design(dim, n0, opts.seed)?;
    let mut y = evaluate(&mut f, &x)?;
    let mut history = Vec::new();
    let mut iteration = 0;
    loop {
        let (fx, fy): (Vec<Vec<f64>>, Vec<f64>) = x
            .iter()
            .zip(&y)
            .filter(|(_, v)| v.is_finite())
            .map(|(p, v)| (p.clone(), *v))
            .unzip();
        if fy.len() < 2 {
            return Err(format!(
                "Bayesian optimisation: expected at least 2 successful evaluations, got {} of {}",
                fy.len(),
                y.len()
            ));
        }
        let left = opts
            .budget
            .map_or(usize::MAX, |b| b.saturating_sub(x.len()));
        let q = if iteration >= opts.iterations {
            0
        } else {
            opts.batch.min(left)
        };
        let proposal = propose(&fx, &fy, q, opts, iteration)?;
        history.push(IterationSummary {
            iteration,
            evaluations: x.len(),
            best_observed: fy.iter().copied().fold(f64::INFINITY, f64::min),
            predicted_minimum: proposal.predicted_minimum,
        });
        let stop = stop_reason(opts, &history).or_else(|| (q == 0).then(|| "budget spent".into()));
        if let Some(stop) = stop {
            let best = (0..y.len())
                .filter(|&i| y[i].is_finite())
                .min_by(|&a, &b| y[a].total_cmp(&y[b]))
                .unwrap_or(0);
            return Ok(BoResult {
                x,
                y,
                best,
                history,
                stop,
                predicted_minimum: proposal.predicted_minimum,
                predicted_minimizer: proposal.predicted_minimizer,
            });
        }
        y.extend(evaluate(&mut f, &proposal.points)?);
        x.extend(proposal.points);
        iteration += 1;
    }
}

fn evaluate(
    f: &mut impl FnMut(&[Vec<f64>]) -> Vec<f64>,
    points: &[Vec<f64>],
) -> Result<Vec<f64>, String> {
    let y = f(points);
    if y.len() != points.len() {
        return Err(format!(
            "Bayesian optimisation: expected one value per point from the objective, got {} for {}",
            y.len(),
            points.len()
        ));
    }
    Ok(y)
}

fn check_options(dim: usize, opts: &BoOptions) -> Result<(), String> {
    if dim == 0 {
        return Err("Bayesian optimisation: expected at least 1 factor, got 0".into());
    }
    if opts.batch == 0 {
        return Err("Bayesian optimisation: expected a batch of at least 1 point, got 0".into());
    }
    if opts.patience == Some(0) {
        return Err(
            "Bayesian optimisation: expected a patience of at least 1 iteration, got 0".into(),
        );
    }
    if !opts.tolerance.is_finite() || opts.tolerance < 0.0 {
        return Err(format!(
            "Bayesian optimisation: expected a finite tolerance >= 0, got {}",
            opts.tolerance
        ));
    }
    if let Some(b) = opts.budget {
        if b < 2 {
            return Err(format!(
                "Bayesian optimisation: expected a budget of at least 2 evaluations, got {b}"
            ));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn expected_improvement_known_values() {
        // At the best with unit variance: phi(0).
        let ei = expected_improvement(0.0, 1.0, 0.0);
        assert!((ei - 0.398_942_280_4).abs() < 1e-7, "{ei}");
        // No uncertainty: the plain improvement.
        assert_eq!(expected_improvement(1.0, 0.0, 3.0), 2.0);
        assert_eq!(expected_improvement(3.0, 0.0, 1.0), 0.0);
        // Far above the best: tiny but its log still finite and falling with the mean.
        let a = log_expected_improvement(50.0, 1.0, 0.0);
        let b = log_expected_improvement(60.0, 1.0, 0.0);
        assert!(a.is_finite() && b.is_finite() && b < a, "{a} {b}");
        // The three formulas agree where they meet.
        for z in [-1.0f64, -30.0] {
            let lo = log_expected_improvement(-z + 1e-9, 1.0, 0.0);
            let hi = log_expected_improvement(-z - 1e-9, 1.0, 0.0);
            assert!((lo - hi).abs() < 1e-4 * lo.abs(), "z {z}: {lo} {hi}");
        }
        // z = -3 against direct evaluation: EI = -3 Phi(-3) + phi(-3).
        let direct = -3.0 * 0.001_349_898_031_6 + 0.004_431_848_411_9;
        let ei = expected_improvement(3.0, 1.0, 0.0);
        assert!((ei / direct - 1.0).abs() < 1e-5, "{ei} {direct}");
        assert!(expected_improvement(f64::NAN, 1.0, 0.0).is_nan());
    }

    #[test]
    fn stop_reasons() {
        let s = |iteration, evaluations, best| IterationSummary {
            iteration,
            evaluations,
            best_observed: best,
            predicted_minimum: best,
        };
        let opts = BoOptions {
            iterations: 5,
            budget: Some(30),
            patience: Some(2),
            tolerance: 0.1,
            ..BoOptions::default()
        };
        assert_eq!(stop_reason(&opts, &[]), None);
        assert_eq!(stop_reason(&opts, &[s(0, 10, 5.0), s(1, 12, 4.0)]), None);
        assert!(stop_reason(&opts, &[s(0, 10, 5.0), s(1, 12, 4.0), s(2, 14, 3.95)]).is_none());
        assert!(stop_reason(
            &opts,
            &[s(0, 10, 5.0), s(1, 12, 4.0), s(2, 14, 3.95), s(3, 16, 3.95)]
        )
        .unwrap()
        .contains("improved"));
        assert!(stop_reason(&opts, &[s(5, 20, 1.0)])
            .unwrap()
            .contains("iterations"));
        assert!(stop_reason(&opts, &[s(1, 30, 1.0)])
            .unwrap()
            .contains("budget"));
    }

    #[test]
    fn nelder_mead_finds_a_minimum_on_a_face() {
        let f = |p: &[f64]| (p[0] - 2.0).powi(2) + (p[1] + 0.3).powi(2);
        let mut rng = Pcg64::seed_from_u64(1);
        let (p, v) = search_box(&f, 2, vec![], &mut rng);
        assert!(
            (p[0] - 1.0).abs() < 1e-6 && (p[1] + 0.3).abs() < 1e-4,
            "{p:?}"
        );
        assert!((v - 1.0).abs() < 1e-6);
    }
}
