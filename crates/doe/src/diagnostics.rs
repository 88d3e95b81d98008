//! What a report shows about a fitted model beyond its ANOVA: the prediction interval of a new
//! run, the perturbation traces, and how far a factor can move from an optimum before the
//! optimum gets worse (a factor the model does not determine).

use crate::fit::{t_critical, Fit};

/// A prediction with its two-sided interval for one new observation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Interval {
    pub predicted: f64,
    /// Standard error of a new observation, sqrt(MSE (1 + x0' (X'X)^-1 x0)).
    pub std_error: f64,
    pub low: f64,
    pub high: f64,
    /// Residual degrees of freedom the t quantile is taken at.
    pub df: usize,
}

impl Fit {
    /// The `level` (e.g. 0.95) prediction interval of one new run at `coded`:
    /// y0 ± t(1 - (1 - level)/2, df_resid) sqrt(MSE (1 + x0' (X'X)^-1 x0)), as Design-Expert's
    /// point prediction gives it. A model with a curvature column predicts off the centre (the
    /// curvature term 0). None without residual degrees of freedom.
    pub fn prediction_interval(&self, coded: &[f64], level: f64) -> Option<Interval> {
        let df = self.residual.df;
        let t = t_critical(1.0 - level, df)?;
        let p = self.xtx_inv.nrows();
        let x0: Vec<f64> = (0..p)
            .map(|j| self.terms.get(j).map_or(0.0, |t| t.value(coded)))
            .collect();
        let mut q = 0.0;
        for i in 0..p {
            for j in 0..p {
                q += x0[i] * self.xtx_inv[(i, j)] * x0[j];
            }
        }
        let mse = self.residual.mean_sq;
        let std_error = (mse * (1.0 + q)).sqrt();
        let predicted = self.predict_coded(coded);
        Some(Interval {
            predicted,
            std_error,
            low: predicted - t * std_error,
            high: predicted + t * std_error,
            df,
        })
    }
}

/// One factor's perturbation trace: the model's prediction as that factor alone moves from the
/// reference point, the others held there.
#[derive(Clone, Debug, PartialEq)]
pub struct Trace {
    pub factor: usize,
    /// (deviation from the reference in coded units, predicted response).
    pub points: Vec<(f64, f64)>,
}

/// Perturbation traces of every factor through `reference` (coded), each over deviations
/// -`span`..`span` in `n` steps (Design-Expert's perturbation plot: span 1 from the centre).
pub fn perturbation(fit: &Fit, reference: &[f64], span: f64, n: usize) -> Vec<Trace> {
    let n = n.max(2);
    (0..fit.experiment.factor_names.len())
        .map(|f| Trace {
            factor: f,
            points: (0..n)
                .map(|i| {
                    let d = -span + 2.0 * span * i as f64 / (n - 1) as f64;
                    let mut x = reference.to_vec();
                    x[f] += d;
                    (d, fit.predict_coded(&x))
                })
                .collect(),
        })
        .collect()
}

/// The stretch of factor `factor` around `optimum` (coded, inside `bounds`) over which
/// `score` (a desirability: higher is better) stays within `tolerance` of its value at the
/// optimum, the other factors held: (low, high), coded. It is the whole range for a factor the
/// model does not contain, and a sliver for one the optimum depends on. The edges are found to
/// 1e-6 of the range by bisection after a scan of 200 steps each way.
pub fn equally_good_range(
    score: impl Fn(&[f64]) -> f64,
    optimum: &[f64],
    factor: usize,
    bounds: (f64, f64),
    tolerance: f64,
) -> (f64, f64) {
    let best = score(optimum);
    let good = |v: f64| {
        let mut x = optimum.to_vec();
        x[factor] = v;
        score(&x) >= best - tolerance
    };
    let x0 = optimum[factor].clamp(bounds.0, bounds.1);
    let step = (bounds.1 - bounds.0) / 200.0;
    let edge = |toward: f64| -> f64 {
        // Walk out until the score drops, then bisect between the last good and first bad.
        let mut inside = x0;
        loop {
            let next = inside + toward * step;
            let next = next.clamp(bounds.0, bounds.1);
            if next == inside {
                return inside;
            }
            if !good(next) {
                let (mut a, mut b) = (inside, next);
                while (b - a).abs() > 1e-6 * (bounds.1 - bounds.0) {
                    let m = 0.5 * (a + b);
                    if good(m) {
                        a = m;
                    } else {
                        b = m;
                    }
                }
                return a;
            }
            inside = next;
        }
    };
    (edge(-1.0), edge(1.0))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::experiment::Experiment;
    use crate::fit::Curvature;
    use crate::model::parse_terms;

    /// A 2² factorial, three centre points and one off-grid run, model A + B + AB (n 8, p 4).
    fn small() -> Fit {
        let coded = vec![
            vec![-1.0, -1.0],
            vec![1.0, -1.0],
            vec![-1.0, 1.0],
            vec![1.0, 1.0],
            vec![0.0, 0.0],
            vec![0.0, 0.0],
            vec![0.0, 0.0],
            vec![0.5, -0.5],
        ];
        let exp = Experiment {
            response_name: "y".into(),
            factor_names: vec!["A".into(), "B".into()],
            factors: None,
            coded,
            response: vec![10.2, 14.1, 11.9, 18.3, 13.0, 13.9, 12.6, 13.4],
        };
        let terms = parse_terms("A,B,AB", &exp.factor_names).unwrap();
        Fit::new(&exp, &terms, Curvature::Off).unwrap()
    }

    /// Against numpy (2.4): X the model matrix, C = inv(X'X), h = diag(X C X'),
    /// D = e² / (p MSE) h / (1 - h)², statsmodels' `OLSInfluence.cooks_distance` formula.
    #[test]
    fn cooks_distance_matches_numpy() {
        let f = small();
        let expected = [
            2.529073712781,
            0.876394214716,
            1.798102170543,
            2.529073712781,
            0.017499942498,
            0.032306307854,
            0.073422558058,
            0.028427450138,
        ];
        for (d, e) in f.cooks_distance.iter().zip(expected) {
            assert!((d - e).abs() < 1e-9, "{d} vs {e}");
        }
        assert!((f.residual.mean_sq - 0.34643695652173945).abs() < 1e-12);
    }

    /// At A = 0.3, B = 0.6: numpy gives y0 = x0'b = 15.167606086956527 and
    /// sqrt(MSE (1 + x0' C x0)) = 0.6597861758468145; with t(0.975, 4) = 2.776445105197799
    /// (scipy.stats.t.ppf, as printed in t tables) the 95 % interval is
    /// 13.335745988549464 .. 16.999466185363588.
    #[test]
    fn prediction_interval_matches_numpy() {
        let f = small();
        let pi = f.prediction_interval(&[0.3, 0.6], 0.95).unwrap();
        assert_eq!(pi.df, 4);
        assert!((pi.predicted - 15.167606086956527).abs() < 1e-9, "{pi:?}");
        assert!((pi.std_error - 0.6597861758468145).abs() < 1e-9, "{pi:?}");
        assert!((pi.low - 13.335745988549464).abs() < 1e-6, "{pi:?}");
        assert!((pi.high - 16.999466185363588).abs() < 1e-6, "{pi:?}");
    }

    #[test]
    fn perturbation_moves_one_factor_at_a_time() {
        let f = small();
        let traces = perturbation(&f, &[0.0, 0.0], 1.0, 5);
        assert_eq!(traces.len(), 2);
        // Through the centre, A alone: b0 + b1 d (the AB term is 0 with B at 0).
        let (b0, b1) = (f.coefficients[0].estimate, f.coefficients[1].estimate);
        for &(d, y) in &traces[0].points {
            assert!((y - (b0 + b1 * d)).abs() < 1e-12);
        }
        assert_eq!(traces[1].points[0].0, -1.0);
        assert_eq!(traces[1].points[4].0, 1.0);
        assert!((traces[0].points[2].1 - b0).abs() < 1e-12);
    }

    /// A score that ignores x1 and falls off linearly in x0 around 0.2: x1 is free over its
    /// whole range, x0 only within the tolerance (0.01 / slope 2 = 0.005 each side).
    #[test]
    fn an_undetermined_factor_spans_its_range() {
        let score = |x: &[f64]| 1.0 - 2.0 * (x[0] - 0.2).abs();
        let opt = [0.2, 0.7];
        let (lo, hi) = equally_good_range(score, &opt, 1, (-1.0, 1.0), 0.01);
        assert_eq!((lo, hi), (-1.0, 1.0));
        let (lo, hi) = equally_good_range(score, &opt, 0, (-1.0, 1.0), 0.01);
        assert!(
            (lo - 0.195).abs() < 1e-5 && (hi - 0.205).abs() < 1e-5,
            "{lo} {hi}"
        );
    }
}
