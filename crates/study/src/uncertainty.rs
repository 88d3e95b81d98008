//! How well each calibrated value is known, on every route, and whether it is identified at all.
//!
//! Every route that calibrates (optimize on a response surface, sweep, bayesopt, ga_bp, smc)
//! describes its answer the same way: an [`Uncertainty`] with a 95 % interval per calibrated
//! parameter, the identifiability flags (at a range end, hardly mattering, trading off with
//! another along a ridge), and, for a route with a fitted surrogate, global sensitivity indices.
//!
//! The surrogate routes share one construction ([`Band`]): a function of the coded factors that
//! is at most 1 where a setting is indistinguishable from the calibrated one (its predicted
//! response is within the model's and the lab's uncertainty of the lab value, or its predicted
//! objective within noise of the best). A parameter's interval is the stretch of that set through
//! the calibrated point along its own axis, the others held there (what the conditional
//! interval of a one-at-a-time inverse prediction is); a ridge is a pair of parameters whose set,
//! each free, reaches far beyond both conditional stretches: one lab value is matched along a
//! line of settings, and neither value is fixed by the data alone. Sweep keeps its delta-method
//! interval and smc its credible intervals; both are carried in the same shape.

use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;

use crate::target::Target;

/// The level every interval is given at.
pub const LEVEL: f64 = 0.95;
/// Points along one axis where the band is looked at before its edges are bisected.
const AXIS_POINTS: usize = 201;
/// Points along each axis of a pair's grid in the ridge search.
pub const PAIR_POINTS: usize = 41;
/// Base samples of the Sobol estimates (each costs k + 2 evaluations of the surrogate).
pub const SOBOL_SAMPLES: usize = 4096;
/// A total Sobol index below this: the objective hardly depends on the parameter.
pub const INSENSITIVE_TOTAL: f64 = 0.01;
/// A calibrated value within this share of its searched range from an end sits at that end.
const END_SHARE: f64 = 0.01;
/// A pair trades off when the set with both free reaches this many times past each one's own
/// stretch (and over at least [`RIDGE_MIN_SHARE`] of its range).
const RIDGE_FACTOR: f64 = 2.5;
const RIDGE_MIN_SHARE: f64 = 0.2;

/// Why a calibrated value is not reported as calibrated.
#[derive(Clone, Debug, PartialEq)]
pub enum Flag {
    /// The value sits at an end of the range searched (`high`: the upper one): the best setting
    /// may lie beyond it.
    AtRangeEnd { high: bool, end: f64 },
    /// The objective hardly depends on it; why (a sensitivity index, a length scale, a model
    /// without it).
    Insensitive(String),
    /// It trades off with another parameter (index into the study's): along the ridge the
    /// lab value is matched from `from` to `to`, each as (this value, the other's value).
    Ridge {
        with: usize,
        from: (f64, f64),
        to: (f64, f64),
    },
}

impl Flag {
    /// In words, for the report and the summary; `name` gives a parameter's name by its index.
    pub fn text(&self, name: &dyn Fn(usize) -> String) -> String {
        match self {
            Flag::AtRangeEnd { high, end } => format!(
                "at the {} end of the range searched ({}): the best setting may lie beyond it",
                if *high { "upper" } else { "lower" },
                crate::text::sig(*end)
            ),
            Flag::Insensitive(why) => format!("the objective hardly depends on it ({why})"),
            Flag::Ridge { with, from, to } => format!(
                "trades off with {}: the lab value is matched all along a ridge from ({}, {}) to ({}, {}) (this, {}); one target cannot fix both, another test or a held value can",
                name(*with),
                crate::text::sig(from.0),
                crate::text::sig(from.1),
                crate::text::sig(to.0),
                crate::text::sig(to.1),
                name(*with)
            ),
        }
    }

    /// The summary's short name of the flag.
    pub fn kind(&self) -> &'static str {
        match self {
            Flag::AtRangeEnd { .. } => "at_range_end",
            Flag::Insensitive(_) => "insensitive",
            Flag::Ridge { .. } => "ridge",
        }
    }
}

/// One calibrated parameter's interval and flags.
#[derive(Clone, Debug, PartialEq)]
pub struct ParameterInterval {
    /// Index into the study's parameters.
    pub parameter: usize,
    pub value: f64,
    /// The 95 % interval in the parameter's units; None when the route found no setting
    /// matching the lab value within its uncertainty.
    pub interval: Option<(f64, f64)>,
    /// Whether the interval runs to the end of the range searched (low end, high end): the data
    /// do not bound it on that side.
    pub open: (bool, bool),
    pub flags: Vec<Flag>,
}

/// Global sensitivity of a fitted surrogate: Sobol first-order and total indices over the
/// searched box (each factor uniform there).
#[derive(Clone, Debug, PartialEq)]
pub struct Sobol {
    /// What was analysed ("the response model", "the GP mean of the objective").
    pub of: String,
    /// The parameters (indices into the study's), in the factors' order.
    pub parameters: Vec<usize>,
    pub first: Vec<f64>,
    pub total: Vec<f64>,
    pub samples: usize,
}

/// How well a route's calibrated values are known.
#[derive(Clone, Debug, PartialEq)]
pub struct Uncertainty {
    /// How the intervals were made, in words.
    pub method: String,
    pub intervals: Vec<ParameterInterval>,
    /// One table per surrogate analysed (each target's model in a desirability study).
    pub sobol: Vec<Sobol>,
}

impl Uncertainty {
    /// Parameter `i`'s interval, when the route calibrated it.
    pub fn of(&self, i: usize) -> Option<&ParameterInterval> {
        self.intervals.iter().find(|p| p.parameter == i)
    }
}

/// The lab mean's standard error (SD / sqrt n of the replicates; 0 without replicates).
pub fn lab_std_error(t: &Target) -> f64 {
    match t.std() {
        Some(s) => s / (t.replicates.len() as f64).sqrt(),
        None => 0.0,
    }
}

/// The set of settings indistinguishable from the calibrated one, as a function of the coded
/// factors that is at most 1 inside it.
pub struct Band<'a> {
    /// The coded box searched.
    pub bounds: Vec<(f64, f64)>,
    /// The calibrated point, coded.
    pub best: Vec<f64>,
    pub measure: &'a dyn Fn(&[f64]) -> f64,
    /// Columns of a pair's walk in the ridge search ([`PAIR_POINTS`] unless a costly measure
    /// asks for fewer).
    pub columns: usize,
}

/// Two factors (i, j) that trade off, and the ridge's two ends as coded (x_i, x_j).
pub type Ridge = (usize, usize, [(f64, f64); 2]);

/// Whether a band's measure says "inside" (a NaN is outside).
fn inside_band(m: f64) -> bool {
    m <= 1.0
}

/// One factor's stretch of the band through the calibrated point (coded), and whether it runs
/// to each end of the box.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Stretch {
    pub low: f64,
    pub high: f64,
    pub open: (bool, bool),
}

impl Band<'_> {
    fn at(&self, j: usize, v: f64) -> f64 {
        let mut x = self.best.clone();
        x[j] = v;
        (self.measure)(&x)
    }

    /// Factor `j`'s stretch: the run of the band along its axis that holds the calibrated point
    /// (or, when the calibrated point is outside the band, None).
    pub fn stretch(&self, j: usize) -> Option<Stretch> {
        let (lo, hi) = self.bounds[j];
        let b = self.best[j].clamp(lo, hi);
        if !inside_band(self.at(j, b)) {
            return None;
        }
        let step = (hi - lo) / (AXIS_POINTS - 1) as f64;
        // Walk out from the calibrated point each way to the first point outside, then bisect.
        let edge = |dir: f64| -> (f64, bool) {
            let mut inside = b;
            loop {
                let next = inside + dir * step;
                let next = next.clamp(lo, hi);
                if next == inside {
                    return (inside, true);
                }
                if !inside_band(self.at(j, next)) {
                    let (mut a, mut z) = (inside, next);
                    for _ in 0..40 {
                        let m = 0.5 * (a + z);
                        if inside_band(self.at(j, m)) {
                            a = m
                        } else {
                            z = m
                        }
                    }
                    return (a, false);
                }
                inside = next;
            }
        };
        let (low, open_low) = edge(-1.0);
        let (high, open_high) = edge(1.0);
        Some(Stretch {
            low,
            high,
            open: (open_low, open_high),
        })
    }

    /// Pairs that trade off: for each, (i, j, the ridge's two ends as coded (x_i, x_j)).
    pub fn ridges(&self, stretches: &[Option<Stretch>]) -> Vec<Ridge> {
        let k = self.best.len();
        let mut out = Vec::new();
        for i in 0..k {
            for j in i + 1..k {
                let (Some(si), Some(sj)) = (stretches[i], stretches[j]) else {
                    continue;
                };
                if let Some(ends) = self.ridge(i, j, si, sj) {
                    out.push((i, j, ends));
                }
            }
        }
        out
    }

    /// The lowest measure along x_j at x_i = `xi` (the others held): a scan, then a golden
    /// section around the scan's least point, so that a band thinner than the scan's step is
    /// still found. Returns (x_j, measure).
    fn column_min(&self, i: usize, j: usize, xi: f64) -> (f64, f64) {
        let (lj, hj) = self.bounds[j];
        let mut x = self.best.clone();
        x[i] = xi;
        let mut at = |v: f64| {
            x[j] = v;
            let m = (self.measure)(&x);
            if m.is_nan() {
                f64::INFINITY
            } else {
                m
            }
        };
        let n = self.columns;
        let step = (hj - lj) / (n - 1) as f64;
        let (mut best_v, mut best_m) = (lj, f64::INFINITY);
        for b in 0..n {
            let v = lj + step * b as f64;
            let m = at(v);
            if m < best_m {
                (best_v, best_m) = (v, m);
            }
        }
        // Golden section over the two steps around it.
        let (mut a, mut z) = ((best_v - step).max(lj), (best_v + step).min(hj));
        let g = 0.618_033_988_749_895;
        for _ in 0..30 {
            let (c, d) = (z - g * (z - a), a + g * (z - a));
            if at(c) < at(d) {
                z = d;
            } else {
                a = c;
            }
        }
        let v = 0.5 * (a + z);
        let m = at(v);
        if m < best_m {
            (v, m)
        } else {
            (best_v, best_m)
        }
    }

    /// Whether factors i and j trade off: walking x_i out from the calibrated point column by
    /// column, each column holds a setting in the band (the lowest measure along x_j), and the
    /// walk stops at the first column that has none, so separate islands are not joined. A ridge
    /// reaches well past both conditional stretches.
    fn ridge(&self, i: usize, j: usize, si: Stretch, sj: Stretch) -> Option<[(f64, f64); 2]> {
        let (li, hi_) = self.bounds[i];
        let (lj, hj) = self.bounds[j];
        let n = self.columns;
        let step = (hi_ - li) / (n - 1) as f64;
        let start = ((self.best[i] - li) / step)
            .round()
            .clamp(0.0, (n - 1) as f64) as usize;
        let column = |c: usize| {
            let xi = li + step * c as f64;
            let (xj, m) = self.column_min(i, j, xi);
            (m <= 1.0).then_some((xi, xj))
        };
        let mut inside = Vec::new();
        for c in (0..=start).rev() {
            match column(c) {
                Some(p) => inside.push(p),
                None if c != start => break,
                None => {}
            }
        }
        for c in start + 1..n {
            match column(c) {
                Some(p) => inside.push(p),
                None => break,
            }
        }
        if inside.len() < 3 {
            return None;
        }
        let span = |f: &dyn Fn(&(f64, f64)) -> f64| {
            let lo = inside.iter().map(f).fold(f64::INFINITY, f64::min);
            let hi = inside.iter().map(f).fold(f64::NEG_INFINITY, f64::max);
            hi - lo
        };
        let (wi, wj) = (span(&|p| p.0), span(&|p| p.1));
        let far = |w: f64, s: Stretch, grid: f64, range: f64| {
            w > RIDGE_FACTOR * (s.high - s.low) + grid && w >= RIDGE_MIN_SHARE * range
        };
        if !(far(wi, si, 2.0 * step, hi_ - li)
            && far(wj, sj, 2.0 * (hj - lj) / (n - 1) as f64, hj - lj))
        {
            return None;
        }
        let first = inside.iter().copied().min_by(|a, b| a.0.total_cmp(&b.0))?;
        let last = inside.iter().copied().max_by(|a, b| a.0.total_cmp(&b.0))?;
        Some([first, last])
    }
}

/// Whether a coded value sits at an end of its range: Some(true) the upper, Some(false) the lower.
pub fn at_end(v: f64, (lo, hi): (f64, f64)) -> Option<bool> {
    let tol = END_SHARE * (hi - lo);
    if v >= hi - tol {
        Some(true)
    } else if v <= lo + tol {
        Some(false)
    } else {
        None
    }
}

/// Sobol first-order and total indices of `f` over the box `bounds` (each factor uniform):
/// Saltelli's (2010) estimator of the first-order index and Jansen's of the total, on `n` pairs
/// of seeded random points. Indices of a function that does not vary are 0.
pub fn sobol_indices(
    f: &dyn Fn(&[f64]) -> f64,
    bounds: &[(f64, f64)],
    n: usize,
    seed: u64,
) -> (Vec<f64>, Vec<f64>) {
    let k = bounds.len();
    let mut rng = Pcg64::seed_from_u64(seed);
    let mut draw = || -> Vec<f64> {
        bounds
            .iter()
            .map(|&(lo, hi)| lo + (hi - lo) * rng.gen::<f64>())
            .collect()
    };
    let a: Vec<Vec<f64>> = (0..n).map(|_| draw()).collect();
    let b: Vec<Vec<f64>> = (0..n).map(|_| draw()).collect();
    let fa: Vec<f64> = a.iter().map(|x| f(x)).collect();
    let fb: Vec<f64> = b.iter().map(|x| f(x)).collect();
    let all = fa.iter().chain(&fb);
    let mean = all.clone().sum::<f64>() / (2 * n) as f64;
    let var = all.map(|y| (y - mean).powi(2)).sum::<f64>() / (2 * n) as f64;
    if var.is_nan() || var <= 1e-300 || !var.is_finite() {
        return (vec![0.0; k], vec![0.0; k]);
    }
    let mut first = Vec::with_capacity(k);
    let mut total = Vec::with_capacity(k);
    let mut x = vec![0.0; k];
    for i in 0..k {
        let (mut s, mut t) = (0.0, 0.0);
        for r in 0..n {
            x.copy_from_slice(&a[r]);
            x[i] = b[r][i];
            let fab = f(&x);
            // f(B) centred: E[f(A_B) - f(A)] = 0, so the centring changes nothing on average (to
            // O(1/n), the mean being estimated from the same points),
            // but without it the estimate's spread grows with the response's mean (an angle of
            // 36 deg with an SD of 4 put a first-order index 0.07 off at 4 096 pairs).
            s += (fb[r] - mean) * (fab - fa[r]);
            t += (fa[r] - fab).powi(2);
        }
        first.push((s / n as f64 / var).clamp(0.0, 1.0));
        total.push((0.5 * t / n as f64 / var).clamp(0.0, 1.0));
    }
    (first, total)
}

/// A value and its interval rounded to the digits the interval supports: the half-width to one
/// significant digit (two when that digit is 1 or 2), the value and ends to the same place.
pub fn rounded(value: f64, low: f64, high: f64) -> (String, String, String) {
    let half = 0.5 * (high - low).abs();
    if half.is_nan() || half <= 0.0 || !half.is_finite() || !value.is_finite() {
        let s = crate::text::sig;
        return (s(value), s(low), s(high));
    }
    let mut e = half.log10().floor() as i32;
    let lead = half / 10f64.powi(e);
    // 0.3 / 0.1 is 2.9999999999999996: a lead of 3 is meant there.
    if lead < 3.0 - 1e-9 {
        e -= 1;
    }
    // Never coarser than the value's own first digit, nor finer than 6 significant digits.
    let top = value.abs().max(low.abs()).max(high.abs());
    if top > 0.0 {
        let first = top.log10().floor() as i32;
        e = e.clamp(first - 5, first);
    }
    let step = 10f64.powi(e);
    let fmt = |v: f64| -> String {
        // Rounded to the place e first, whatever the notation.
        let r = (v / step).round() * step;
        let r = if r == 0.0 { 0.0 } else { r };
        if !(1e-3..1e5).contains(&top) {
            // Powers of ten: the mantissa relative to the largest number's exponent, with as
            // many digits as the place e leaves.
            let first = top.log10().floor() as i32;
            let digits = (first - e).max(0) as usize;
            format!("{:.*}e{first}", digits, r / 10f64.powi(first))
        } else {
            let decimals = (-e).max(0) as usize;
            format!("{r:.decimals$}")
        }
    };
    (fmt(value), fmt(low), fmt(high))
}

/// The validation's mean against the lab's: each with its 95 % interval, and whether they are
/// compatible (Welch's interval of the difference holds zero).
#[derive(Clone, Debug, PartialEq)]
pub struct ValidationCheck {
    /// The simulated mean's interval (None with fewer than 2 runs).
    pub mean_interval: Option<(f64, f64)>,
    /// The lab mean's interval (None with fewer than 2 replicates).
    pub lab_interval: Option<(f64, f64)>,
    /// Simulated minus lab, with its interval.
    pub difference: f64,
    pub difference_interval: Option<(f64, f64)>,
    /// The relative error's interval in percent (of the lab value).
    pub relative_error_interval: Option<(f64, f64)>,
    pub compatible: Option<bool>,
    /// In words.
    pub statement: String,
}

/// `mean` of `runs` simulations with standard deviation `std` against target `t`.
pub fn validation_check(mean: f64, std: Option<f64>, runs: usize, t: &Target) -> ValidationCheck {
    let t_at = |df: usize| doe::fit::t_critical(1.0 - LEVEL, df);
    let ci = |m: f64, s: Option<f64>, n: usize| -> Option<(f64, f64)> {
        let s = s?;
        let h = t_at(n.checked_sub(1)?)? * s / (n as f64).sqrt();
        Some((m - h, m + h))
    };
    let lab_n = t.replicates.len();
    let lab_mean = t.value;
    let mean_interval = (runs >= 2).then(|| ci(mean, std, runs)).flatten();
    let lab_interval = (lab_n >= 2).then(|| ci(lab_mean, t.std(), lab_n)).flatten();
    let difference = mean - lab_mean;
    // Welch: each side's variance of its mean, the degrees of freedom Satterthwaite's.
    let vs = std.filter(|_| runs >= 2).map(|s| s * s / runs as f64);
    let vl = t.std().filter(|_| lab_n >= 2).map(|s| s * s / lab_n as f64);
    let difference_interval = match (vs, vl) {
        (Some(a), Some(b)) => {
            let df = (a + b).powi(2)
                / (a * a / (runs - 1) as f64 + b * b / (lab_n - 1) as f64).max(1e-300);
            let df = (df.floor() as usize).max(1);
            t_at(df).map(|q| q * (a + b).sqrt())
        }
        (Some(a), None) => t_at(runs - 1).map(|q| q * a.sqrt()),
        _ => None,
    }
    .map(|h| (difference - h, difference + h));
    // The relative error is |sim - lab| / lab: its interval is that of the difference's
    // absolute value (from 0 when the difference's interval holds 0).
    let relative_error_interval = difference_interval
        .filter(|_| !t.minimised() && lab_mean != 0.0)
        .map(|(lo, hi)| {
            let (a, b) = (100.0 * lo / lab_mean.abs(), 100.0 * hi / lab_mean.abs());
            if a <= 0.0 && 0.0 <= b {
                (0.0, a.abs().max(b.abs()))
            } else {
                (a.abs().min(b.abs()), a.abs().max(b.abs()))
            }
        });
    let compatible = difference_interval.map(|(lo, hi)| lo <= 0.0 && 0.0 <= hi);
    let unit = if t.unit.is_empty() {
        String::new()
    } else {
        format!(" {}", t.unit)
    };
    let sig = crate::text::sig;
    let lab_note = if vl.is_none() {
        " (the lab's own spread is not known: fewer than 2 replicates, so only the runs' spread is counted)"
    } else {
        ""
    };
    let statement = match (difference_interval, compatible) {
        (Some((lo, hi)), Some(true)) => format!(
            "compatible with the lab: the difference {}{unit} has the 95 % interval {} to {}{unit}, which holds zero{lab_note}",
            sig(difference),
            sig(lo),
            sig(hi)
        ),
        (Some((lo, hi)), _) => format!(
            "not compatible with the lab: the difference {}{unit} has the 95 % interval {} to {}{unit}, which leaves out zero{lab_note}",
            sig(difference),
            sig(lo),
            sig(hi)
        ),
        _ => format!(
            "no interval: {} validation run(s) and {} lab replicate(s); at least 2 validation runs are needed to say whether the difference {}{unit} is within noise",
            runs,
            lab_n,
            sig(difference)
        ),
    };
    ValidationCheck {
        mean_interval,
        lab_interval,
        difference,
        difference_interval,
        relative_error_interval,
        compatible,
        statement,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The Ishigami function's indices are known in closed form (Sobol' & Levitan 1999):
    /// S = (0.3139, 0.4424, 0), ST = (0.5576, 0.4424, 0.2437) for a = 7, b = 0.1 on [-pi, pi]^3.
    #[test]
    fn sobol_indices_of_the_ishigami_function() {
        let pi = std::f64::consts::PI;
        let f = |x: &[f64]| x[0].sin() + 7.0 * x[1].sin().powi(2) + 0.1 * x[2].powi(4) * x[0].sin();
        let (s, t) = sobol_indices(&f, &[(-pi, pi); 3], 1 << 15, 7);
        for (got, want) in s.iter().zip([0.3139, 0.4424, 0.0]) {
            assert!((got - want).abs() < 0.03, "first {s:?}");
        }
        for (got, want) in t.iter().zip([0.5576, 0.4424, 0.2437]) {
            assert!((got - want).abs() < 0.03, "total {t:?}");
        }
    }

    /// A linear function: each index is its coefficient's share of the variance.
    #[test]
    fn sobol_indices_of_a_linear_function() {
        let f = |x: &[f64]| 3.0 * x[0] + 1.0 * x[1] + 0.0 * x[2];
        let (s, t) = sobol_indices(&f, &[(-1.0, 1.0); 3], SOBOL_SAMPLES, 1);
        assert!(
            (s[0] - 0.9).abs() < 0.03 && (t[0] - 0.9).abs() < 0.03,
            "{s:?} {t:?}"
        );
        assert!(
            (s[1] - 0.1).abs() < 0.03 && (t[1] - 0.1).abs() < 0.03,
            "{s:?} {t:?}"
        );
        assert!(t[2] < 1e-12);
    }

    /// The silage example's fitted model (36.29 + 3.47 E + 2.57 G in coded units): a response
    /// far from zero must not widen the estimates' error. Exact: S = ST = (0.646, 0.354, 0).
    #[test]
    fn sobol_indices_of_a_response_with_a_large_mean() {
        let f = |x: &[f64]| 36.29 + 3.47 * x[0] + 2.57 * x[1] + 0.0 * x[2];
        let exact = [3.47f64.powi(2), 2.57f64.powi(2), 0.0]
            .map(|v| v / (3.47f64.powi(2) + 2.57f64.powi(2)));
        for seed in 1..=5 {
            let (s, t) = sobol_indices(&f, &[(-1.0, 1.0); 3], SOBOL_SAMPLES, seed);
            for i in 0..3 {
                assert!((s[i] - exact[i]).abs() < 0.03, "seed {seed}: first {s:?}");
                assert!((t[i] - exact[i]).abs() < 0.03, "seed {seed}: total {t:?}");
            }
        }
    }

    #[test]
    fn values_are_rounded_to_what_their_interval_supports() {
        assert_eq!(
            rounded(0.11514, 0.1098, 0.1206),
            ("0.115".into(), "0.110".into(), "0.121".into())
        );
        assert_eq!(
            rounded(0.11514, 0.095, 0.135),
            ("0.115".into(), "0.095".into(), "0.135".into())
        );
        assert_eq!(
            rounded(18.72, 16.0, 21.4),
            ("18.7".into(), "16.0".into(), "21.4".into())
        );
        assert_eq!(
            rounded(4.2e7, 3.1e7, 5.3e7),
            ("4.2e7".into(), "3.1e7".into(), "5.3e7".into())
        );
        // The place the interval supports, not each number's own digits.
        assert_eq!(
            rounded(1e-6, -4e-4, 6e-4),
            ("0e-4".into(), "-4e-4".into(), "6e-4".into())
        );
        assert_eq!(
            rounded(12.0, -3e5, 3e5),
            ("0e5".into(), "-3e5".into(), "3e5".into())
        );
        assert_eq!(
            rounded(0.2, 0.1, 0.7),
            ("0.2".into(), "0.1".into(), "0.7".into())
        );
        assert_eq!(
            rounded(-0.003, -0.01, 0.004),
            ("-0.003".into(), "-0.010".into(), "0.004".into())
        );
        assert_eq!(
            rounded(0.5, 0.0, 1.0),
            ("0.5".into(), "0.0".into(), "1.0".into())
        );
    }

    #[test]
    fn a_band_gives_the_stretch_and_finds_a_ridge() {
        // y = x0 + x1 matched at 0 with a band of 0.1: along each axis ±0.1, together a ridge
        // x1 = -x0 across the whole box.
        let f = |x: &[f64]| (x[0] + x[1]).abs() / 0.1;
        let band = Band {
            bounds: vec![(-1.0, 1.0); 2],
            best: vec![0.0, 0.0],
            measure: &f,
            columns: PAIR_POINTS,
        };
        let s = band.stretch(0).unwrap();
        assert!(
            (s.low + 0.1).abs() < 1e-9 && (s.high - 0.1).abs() < 1e-9,
            "{s:?}"
        );
        assert_eq!(s.open, (false, false));
        let stretches = [band.stretch(0), band.stretch(1)];
        let ridges = band.ridges(&stretches);
        assert_eq!(ridges.len(), 1);
        let [a, b] = ridges[0].2;
        assert!(a.0 <= -0.9 && b.0 >= 0.9, "{a:?} {b:?}");
        assert!(a.1 >= 0.8 && b.1 <= -0.8, "{a:?} {b:?}");
        // y = x0 alone: x0 narrow, x1 open both ways, no ridge.
        let g = |x: &[f64]| x[0].abs() / 0.1;
        let band = Band {
            bounds: vec![(-1.0, 1.0); 2],
            best: vec![0.0, 0.0],
            measure: &g,
            columns: PAIR_POINTS,
        };
        let s1 = band.stretch(1).unwrap();
        assert_eq!((s1.low, s1.high, s1.open), (-1.0, 1.0, (true, true)));
        assert!(band.ridges(&[band.stretch(0), Some(s1)]).is_empty());
        // A ridge thinner than the grid's step, off its nodes, is still found.
        let thin = |x: &[f64]| (x[0] + x[1] - 0.025).abs() / 0.01;
        let band = Band {
            bounds: vec![(-1.0, 1.0); 2],
            best: vec![0.0125, 0.0125],
            measure: &thin,
            columns: PAIR_POINTS,
        };
        assert_eq!(band.ridges(&[band.stretch(0), band.stretch(1)]).len(), 1);
        // Two separate islands are not a ridge.
        let islands = |x: &[f64]| {
            let d = |c: f64| ((x[0] - c).powi(2) + (x[1] - c).powi(2)).sqrt() / 0.1;
            d(-0.8).min(d(0.8))
        };
        let band = Band {
            bounds: vec![(-1.0, 1.0); 2],
            best: vec![-0.8, -0.8],
            measure: &islands,
            columns: PAIR_POINTS,
        };
        assert!(band.ridges(&[band.stretch(0), band.stretch(1)]).is_empty());
    }
}
