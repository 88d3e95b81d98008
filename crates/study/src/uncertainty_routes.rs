//! Each calibrating route's [`Uncertainty`]: the band of settings indistinguishable from the
//! calibrated one as that route's model sees it, the intervals and flags that follow, and the
//! Sobol indices of its surrogate. The construction they share is `uncertainty`'s; here is only
//! what each model contributes:
//!
//! - a response surface (optimize): inverse prediction, the set of settings whose fitted mean is
//!   within t √(var of the fitted mean + var of the lab mean) of the lab value (t at the model's
//!   residual degrees of freedom); for a minimised response, whose fitted mean is within t √(the
//!   two fitted means' variances) of the optimum's;
//! - a Gaussian process (bayesopt): the settings whose posterior mean of the objective is within
//!   1.96 √(posterior variance + the GP's noise + the lab's relative variance) of the calibrated
//!   run's: within noise of the best;
//! - a GA-BP ensemble (ga_bp): as a response surface, with the spread of the ensemble's members
//!   (their standard deviation) as the model's uncertainty;
//! - smc: the posterior's 95 % credible intervals, a ridge where two parameters' posterior
//!   correlation is strong;
//! - sweep: its delta-method interval of the inverted curve.

use doe::{Factor, Fit};
use surrogate::gp::Gp;
use surrogate::network::Network;
use surrogate::smc::Posterior;

use crate::record::StageResult;
use crate::spec::Study;
use crate::target::Target;
use crate::uncertainty::{
    at_end, lab_std_error, sobol_indices, Band, Flag, ParameterInterval, Sobol, Uncertainty,
    INSENSITIVE_TOTAL, LEVEL, PAIR_POINTS, SOBOL_SAMPLES,
};

/// A GP length scale (coded units, the box 2 wide) beyond which the objective is nearly flat
/// along the factor.
const FLAT_LENGTH_SCALE: f64 = 20.0;
/// An interval this share of the range searched wide: the data hardly constrain the value.
const WIDE_SHARE: f64 = 0.9;
/// A posterior correlation this strong between two parameters is a ridge.
const RIDGE_CORRELATION: f64 = 0.8;
/// A credible interval this share of the range wide: the posterior is about the prior.
const PRIOR_WIDE: f64 = 0.85;
/// z of a two-sided 95 % normal interval.
const Z95: f64 = 1.959_963_984_540_054;

/// A band's measure of a coded point (at most 1 inside).
type Measure<'a> = Box<dyn Fn(&[f64]) -> f64 + 'a>;

/// Intervals, flags and Sobol tables from a band over the stage's active factors.
struct Parts<'a> {
    st: &'a StageResult,
    factors: &'a [Factor],
    bounds: Vec<(f64, f64)>,
    best: Vec<f64>,
    /// Flags a route knows of itself (a factor not in the reduced model), per factor.
    insensitive: Vec<Option<String>>,
    sobol: Vec<Sobol>,
    /// Columns of the ridge search's walk (fewer for a costly measure).
    columns: usize,
}

impl Parts<'_> {
    fn assemble(self, measure: &dyn Fn(&[f64]) -> f64, method: String) -> Uncertainty {
        let band = Band {
            bounds: self.bounds.clone(),
            best: self.best.clone(),
            measure,
            columns: self.columns,
        };
        let k = self.best.len();
        let stretches: Vec<_> = (0..k).map(|j| band.stretch(j)).collect();
        let ridges = band.ridges(&stretches);
        let actual = |j: usize, c: f64| self.factors[j].to_actual(c);
        let mut intervals = Vec::with_capacity(k);
        for (j, stretch) in stretches.iter().enumerate() {
            let pi = self.st.active[j];
            let mut flags = Vec::new();
            if let Some(high) = at_end(self.best[j], self.bounds[j]) {
                let end = if high {
                    self.bounds[j].1
                } else {
                    self.bounds[j].0
                };
                flags.push(Flag::AtRangeEnd {
                    high,
                    end: actual(j, end),
                });
            }
            let total = self
                .sobol
                .iter()
                .filter_map(|s| s.total.get(j))
                .copied()
                .fold(f64::NAN, f64::max);
            let (lo, hi) = self.bounds[j];
            let share = stretch.map_or(0.0, |s| (s.high - s.low) / (hi - lo));
            if let Some(why) = &self.insensitive[j] {
                flags.push(Flag::Insensitive(why.clone()));
            } else if total < INSENSITIVE_TOTAL {
                flags.push(Flag::Insensitive(format!(
                    "total Sobol index {total:.3}, below {INSENSITIVE_TOTAL}"
                )));
            } else if share >= WIDE_SHARE {
                flags.push(Flag::Insensitive(format!(
                    "its interval spans {:.0} % of the range searched: the data hardly constrain it",
                    100.0 * share
                )));
            }
            for &(a, b, ends) in &ridges {
                if a != j && b != j {
                    continue;
                }
                let other = if a == j { b } else { a };
                // Each end as (this, the other), in actual units.
                let end = |p: (f64, f64)| {
                    let (this, that) = if a == j { (p.0, p.1) } else { (p.1, p.0) };
                    (actual(j, this), actual(other, that))
                };
                let (from, to) = (end(ends[0]), end(ends[1]));
                let (from, to) = if from.0 <= to.0 {
                    (from, to)
                } else {
                    (to, from)
                };
                flags.push(Flag::Ridge {
                    with: self.st.active[other],
                    from,
                    to,
                });
            }
            let (interval, open) = match *stretch {
                Some(s) => {
                    let (a, b) = (actual(j, s.low), actual(j, s.high));
                    (Some((a.min(b), a.max(b))), s.open)
                }
                None => (None, (false, false)),
            };
            intervals.push(ParameterInterval {
                parameter: pi,
                value: actual(j, self.best[j]),
                interval,
                open,
                flags,
            });
        }
        Uncertainty {
            method,
            intervals,
            sobol: self.sobol,
        }
    }
}

fn sobol_of(
    st: &StageResult,
    of: String,
    f: &dyn Fn(&[f64]) -> f64,
    bounds: &[(f64, f64)],
    seed: u64,
) -> Sobol {
    let (first, total) = sobol_indices(f, bounds, SOBOL_SAMPLES, seed);
    Sobol {
        of,
        parameters: st.active.clone(),
        first,
        total,
        samples: SOBOL_SAMPLES,
    }
}

/// The variance of a response surface's fitted mean at `coded`: MSE x0' (X'X)^-1 x0.
fn mean_variance(fit: &Fit, coded: &[f64]) -> f64 {
    let p = fit.xtx_inv.nrows();
    let x0: Vec<f64> = (0..p)
        .map(|j| fit.terms.get(j).map_or(0.0, |t| t.value(coded)))
        .collect();
    let mut q = 0.0;
    for i in 0..p {
        for j in 0..p {
            q += x0[i] * fit.xtx_inv[(i, j)] * x0[j];
        }
    }
    fit.residual.mean_sq * q.max(0.0)
}

/// How far a model's prediction is from what calibrates it, in units of its band: matched to
/// the lab value, or (minimised) no worse than at the calibrated point. `variance` is the
/// model's variance of its prediction, `t` the band's quantile.
fn matched_or_minimised<P, V>(
    target: &Target,
    predict: P,
    variance: V,
    best: &[f64],
    t: f64,
) -> impl Fn(&[f64]) -> f64
where
    P: Fn(&[f64]) -> f64,
    V: Fn(&[f64]) -> f64,
{
    let minimised = target.minimised();
    let lab = target.value;
    let lab_var = lab_std_error(target).powi(2);
    let at_best = predict(best);
    let var_best = variance(best);
    move |x: &[f64]| {
        let (p, v) = (predict(x), variance(x));
        let (gap, s) = if minimised {
            ((p - at_best).max(0.0), t * (v + var_best).sqrt())
        } else {
            ((p - lab).abs(), t * (v + lab_var).sqrt())
        };
        if gap == 0.0 {
            0.0
        } else if s > 0.0 {
            gap / s
        } else {
            f64::INFINITY
        }
    }
}

/// optimize on a response surface (or a screening's first-order model); with several targets
/// modelled one by one, a setting is in the band when every target is.
pub(crate) fn from_response_model(
    study: &Study,
    st: &StageResult,
    fit: &Fit,
    target_fits: &[Fit],
    bounds: Vec<(f64, f64)>,
    best: Vec<f64>,
    equally_good: &[(f64, f64)],
) -> Uncertainty {
    let factors = fit.experiment.factors.clone().unwrap_or_default();
    // Each model with the target it is calibrated against.
    let models: Vec<(&Fit, &Target)> = if target_fits.is_empty() {
        vec![(fit, &study.target)]
    } else {
        target_fits.iter().zip(&study.targets).collect()
    };
    let df = models.iter().map(|(f, _)| f.residual.df).min().unwrap_or(0);
    let seed = crate::record::run_seed(study.seed, st.index, 1 << 42);
    let sobol = models
        .iter()
        .map(|(f, t)| {
            sobol_of(
                st,
                format!("the fitted model of {}", t.response),
                &|x| f.predict_coded(x),
                &bounds,
                seed,
            )
        })
        .collect();
    let insensitive = (0..best.len())
        .map(|j| {
            let in_model = models.iter().any(|(f, _)| {
                f.terms
                    .iter()
                    .any(|t| t.powers.get(j).is_some_and(|&p| p > 0))
            });
            if !in_model {
                Some(
                    "not in the reduced model: backward elimination dropped every term with it"
                        .into(),
                )
            } else if equally_good.get(j).is_some_and(|(lo, hi)| hi - lo >= 1.0) {
                Some("the optimiser found half its range or more equally good".into())
            } else {
                None
            }
        })
        .collect();
    let parts = Parts {
        st,
        factors: &factors,
        bounds,
        best: best.clone(),
        insensitive,
        sobol,
        columns: PAIR_POINTS,
    };
    let Some(t) = doe::fit::t_critical(1.0 - LEVEL, df) else {
        // Without residual degrees of freedom the model has no variance to invert with.
        let none = |_: &[f64]| f64::INFINITY;
        return parts.assemble(
            &none,
            "no interval: the model has no residual degrees of freedom to estimate its error"
                .into(),
        );
    };
    let bands: Vec<Measure<'_>> = models
        .iter()
        .map(|&(f, target)| {
            Box::new(matched_or_minimised(
                target,
                move |x: &[f64]| f.predict_coded(x),
                move |x: &[f64]| mean_variance(f, x),
                &best,
                t,
            )) as Measure<'_>
        })
        .collect();
    let measure = |x: &[f64]| bands.iter().map(|b| b(x)).fold(0.0, f64::max);
    let within = if study.target.minimised() && target_fits.is_empty() {
        "within t √(variance of the fitted mean there + at the optimum) of the optimum's fitted mean"
    } else if target_fits
        .iter()
        .zip(&study.targets)
        .any(|(_, t)| t.minimised())
    {
        "within t √(variance of the fitted mean + variance of the lab mean) of each matched target's lab value, and within t √(the two fitted means' variances) of each minimised target's optimum"
    } else {
        "within t √(variance of the fitted mean + variance of the lab mean) of the lab value"
    };
    parts.assemble(
        &measure,
        format!(
            "inverse prediction from the response surface: each value's 95 % interval is the stretch, the other parameters held at their calibrated values, over which the model's fitted mean stays {within} (t at {df} residual degrees of freedom)"
        ),
    )
}

/// bayesopt: the GP of the objective.
pub(crate) fn from_gp(study: &Study, st: &StageResult, gp: &Gp, best: Vec<f64>) -> Uncertainty {
    let k = best.len();
    let bounds = vec![(-1.0, 1.0); k];
    let lab_rel = if study.target.minimised() || study.target.value == 0.0 {
        0.0
    } else {
        lab_std_error(&study.target) / study.target.value.abs()
    };
    let noise = gp.noise_variance() + lab_rel * lab_rel;
    let at_best = gp.predict_mean(&best);
    let measure = move |x: &[f64]| {
        let (m, v) = gp.predict(x);
        if m <= at_best {
            return 0.0;
        }
        let s = Z95 * (v + noise).sqrt();
        if s > 0.0 {
            (m - at_best) / s
        } else {
            f64::INFINITY
        }
    };
    let seed = crate::record::run_seed(study.seed, st.index, 1 << 42);
    let sobol = vec![sobol_of(
        st,
        "the GP mean of the objective".into(),
        &|x| gp.predict_mean(x),
        &bounds,
        seed,
    )];
    let insensitive = gp
        .length_scales()
        .iter()
        .map(|&l| {
            (l >= FLAT_LENGTH_SCALE).then(|| {
                format!(
                    "the GP's length scale {} in coded units, the range being 2 wide",
                    crate::text::sig(l)
                )
            })
        })
        .collect();
    let factors = st.factors.clone();
    // The GP's variance costs the square of its points per evaluation: a few thousand runs
    // would make every `demcal status` slow, so the ridge search walks fewer columns then.
    let columns = if gp.points().len() > 400 {
        11
    } else {
        PAIR_POINTS
    };
    Parts {
        st,
        factors: &factors,
        bounds,
        best,
        insensitive,
        sobol,
        columns,
    }
    .assemble(
        &measure,
        "the Gaussian process's posterior: each value's 95 % interval is the stretch, the other parameters held at their calibrated values, over which the GP mean of the objective stays within 1.96 √(its posterior variance + the GP's noise variance + the lab mean's relative variance) of its value at the calibrated run: within noise of the best".into(),
    )
}

/// ga_bp: the network ensemble; its members' spread is the model's uncertainty.
pub(crate) fn from_network(
    study: &Study,
    st: &StageResult,
    net: &Network,
    best: Vec<f64>,
) -> Uncertainty {
    let k = best.len();
    let bounds = vec![(-1.0, 1.0); k];
    let spread = |x: &[f64]| {
        let m = net.member_predictions(x);
        let n = m.len();
        if n < 2 {
            return 0.0;
        }
        let mean = m.iter().sum::<f64>() / n as f64;
        m.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1) as f64
    };
    let measure = matched_or_minimised(
        &study.target,
        |x: &[f64]| net.predict(x),
        spread,
        &best,
        Z95,
    );
    let seed = crate::record::run_seed(study.seed, st.index, 1 << 42);
    let sobol = vec![sobol_of(
        st,
        format!("the network's prediction of {}", study.target.response),
        &|x| net.predict(x),
        &bounds,
        seed,
    )];
    let factors = st.factors.clone();
    Parts {
        st,
        factors: &factors,
        bounds,
        best,
        insensitive: vec![None; k],
        sobol,
        columns: PAIR_POINTS,
    }
    .assemble(
        &measure,
        format!(
            "the spread of the network ensemble ({} members): each value's 95 % interval is the stretch, the other parameters held at their calibrated values, over which the ensemble's mean prediction stays within 1.96 √(variance of the members' predictions + variance of the lab mean) of {}",
            net.members(),
            if study.target.minimised() { "its value at the calibrated point" } else { "the lab value" }
        ),
    )
}

/// smc: the posterior's credible intervals; `points` (actual units) and `weights` the last
/// iteration's weighted runs.
pub(crate) fn from_posterior(
    st: &StageResult,
    posterior: &Posterior,
    points: &[Vec<f64>],
    weights: &[f64],
) -> Uncertainty {
    let k = st.active.len();
    let coded: Vec<Vec<f64>> = points
        .iter()
        .map(|p| {
            st.factors
                .iter()
                .zip(p)
                .map(|(f, v)| f.to_coded(*v))
                .collect()
        })
        .collect();
    let wsum: f64 = weights.iter().sum();
    let wmean = |j: usize| {
        coded
            .iter()
            .zip(weights)
            .map(|(c, w)| w * c[j])
            .sum::<f64>()
            / wsum
    };
    let means: Vec<f64> = (0..k).map(wmean).collect();
    let cov = |a: usize, b: usize| {
        coded
            .iter()
            .zip(weights)
            .map(|(c, w)| w * (c[a] - means[a]) * (c[b] - means[b]))
            .sum::<f64>()
            / wsum
    };
    let mut intervals = Vec::with_capacity(k);
    for j in 0..k {
        let pi = st.active[j];
        let (lo, hi) = posterior.credible[j];
        let mut flags = Vec::new();
        let value = posterior.mean[j];
        // A posterior piled against an end of the range sampled: its credible interval
        // reaches that end (its mean need not).
        let f = &st.factors[j];
        let (cl, ch) = (f.to_coded(lo), f.to_coded(hi));
        let open = (
            at_end(cl, (-1.0, 1.0)) == Some(false),
            at_end(ch, (-1.0, 1.0)) == Some(true),
        );
        let c = f.to_coded(value);
        if let Some(high) = at_end(c, (-1.0, 1.0)) {
            flags.push(Flag::AtRangeEnd {
                high,
                end: if high { f.high } else { f.low },
            });
        } else if open.0 != open.1 {
            flags.push(Flag::AtRangeEnd {
                high: open.1,
                end: if open.1 { f.high } else { f.low },
            });
        }
        let width = (st.factors[j].to_coded(hi) - st.factors[j].to_coded(lo)).abs();
        if width >= PRIOR_WIDE * 2.0 {
            flags.push(Flag::Insensitive(format!(
                "its credible interval spans {:.0} % of the range: the posterior is about the prior",
                50.0 * width
            )));
        }
        for o in (0..k).filter(|&o| o != j) {
            let r = cov(j, o) / (cov(j, j) * cov(o, o)).sqrt();
            if r.abs() >= RIDGE_CORRELATION {
                // The ridge's ends: the regression line of the other on this one, at this
                // one's credible ends.
                let slope = r * (cov(o, o) / cov(j, j)).sqrt();
                let along = |cj: f64| means[o] + slope * (cj - means[j]);
                let (cl, ch) = (st.factors[j].to_coded(lo), st.factors[j].to_coded(hi));
                let end = |cj: f64| {
                    (
                        st.factors[j].to_actual(cj),
                        st.factors[o].to_actual(along(cj).clamp(-1.0, 1.0)),
                    )
                };
                flags.push(Flag::Ridge {
                    with: st.active[o],
                    from: end(cl),
                    to: end(ch),
                });
            }
        }
        intervals.push(ParameterInterval {
            parameter: pi,
            value,
            interval: Some((lo, hi)),
            open,
            flags,
        });
    }
    Uncertainty {
        method: format!(
            "the 95 % credible intervals of the last iteration's posterior (2.5 % and 97.5 % weighted quantiles); a ridge where two parameters' posterior correlation is {RIDGE_CORRELATION} or stronger"
        ),
        intervals,
        sobol: Vec::new(),
    }
}

/// sweep: the delta-method interval of the inverted curve.
pub(crate) fn from_sweep(
    parameter: usize,
    factor: &Factor,
    value: f64,
    interval: (f64, f64),
) -> Uncertainty {
    let mut flags = Vec::new();
    let c = factor.to_coded(value);
    if let Some(high) = at_end(c, (-1.0, 1.0)) {
        flags.push(Flag::AtRangeEnd {
            high,
            end: if high { factor.high } else { factor.low },
        });
    }
    let (lo, hi) = interval;
    if (factor.to_coded(hi) - factor.to_coded(lo)).abs() >= 2.0 {
        flags.push(Flag::Insensitive(
            "its interval is wider than the values swept: the curve is nearly flat at the lab value".into(),
        ));
    }
    Uncertainty {
        method: "the delta method's inverse-prediction interval of the swept curve: the fitted mean's variance at the inverted value plus the lab mean's, over the squared slope there, t at the fit's residual degrees of freedom".into(),
        intervals: vec![ParameterInterval {
            parameter,
            value,
            interval: Some((lo, hi)),
            open: (lo <= factor.low, hi >= factor.high),
            flags,
        }],
        sobol: Vec::new(),
    }
}
