//! Numerical optimisation of fitted models with Derringer-Suich desirability functions, the way
//! Design-Expert's "Numerical optimization" works: a goal per response (and optionally per
//! factor), weights and importance, factors bounded, many starts of a local search, and the
//! distinct solutions ranked by overall desirability.

use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use serde::Serialize;

use crate::fit::Fit;

/// Most random starts of a search: each is a Nelder-Mead run of up to 600 steps, and all are
/// held at once before the ranking.
pub const MAX_STARTS: usize = 10_000;

/// What a criterion asks of a response (or factor).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Goal {
    Maximize,
    Minimize,
    Target(f64),
    /// A constraint only: desirability 1 inside the limits, 0 outside; it does not weigh in the
    /// overall desirability.
    InRange,
}

/// A goal with its limits, weights and importance (1 to 5).
#[derive(Clone, Debug, Serialize)]
pub struct Criterion {
    pub name: String,
    pub goal: Goal,
    pub lower: f64,
    pub upper: f64,
    pub weight_lower: f64,
    pub weight_upper: f64,
    pub importance: u8,
}

impl Criterion {
    /// The desirability of value `y`, in 0..=1.
    pub fn desirability(&self, y: f64) -> f64 {
        let (l, u) = (self.lower, self.upper);
        match self.goal {
            Goal::Maximize => {
                if y <= l {
                    0.0
                } else if y >= u {
                    1.0
                } else {
                    ((y - l) / (u - l)).powf(self.weight_lower)
                }
            }
            Goal::Minimize => {
                if y >= u {
                    0.0
                } else if y <= l {
                    1.0
                } else {
                    ((u - y) / (u - l)).powf(self.weight_upper)
                }
            }
            Goal::Target(t) => {
                if y < l || y > u {
                    0.0
                } else if y <= t {
                    if t == l {
                        1.0
                    } else {
                        ((y - l) / (t - l)).powf(self.weight_lower)
                    }
                } else if t == u {
                    1.0
                } else {
                    ((u - y) / (u - t)).powf(self.weight_upper)
                }
            }
            Goal::InRange => {
                if (l..=u).contains(&y) {
                    1.0
                } else {
                    0.0
                }
            }
        }
    }

    /// How far `y` lies outside the region where the desirability is positive, relative to the
    /// limits' span; 0 inside. Guides the search out of zero-desirability regions.
    fn shortfall(&self, y: f64) -> f64 {
        let span = (self.upper - self.lower).abs().max(1e-300);
        let (l, u) = (self.lower, self.upper);
        let below = (l - y).max(0.0);
        let above = (y - u).max(0.0);
        match self.goal {
            Goal::Maximize => below / span + if y == l { 1e-9 } else { 0.0 },
            Goal::Minimize => above / span + if y == u { 1e-9 } else { 0.0 },
            Goal::Target(_) | Goal::InRange => (below + above) / span,
        }
    }

    fn counts(&self) -> bool {
        self.goal != Goal::InRange
    }

    pub fn validate(&self) -> Result<(), String> {
        if let Goal::Target(t) = self.goal {
            if !t.is_finite() {
                return Err(format!(
                    "goal on '{}': target {t} is not a finite number",
                    self.name
                ));
            }
        }
        if !self.lower.is_finite() || !self.upper.is_finite() {
            return Err(format!(
                "goal on '{}': limits must be finite numbers, got {} and {}",
                self.name, self.lower, self.upper
            ));
        }
        if self.lower > self.upper {
            return Err(format!(
                "goal on '{}': expected lower <= upper, got {} and {}",
                self.name, self.lower, self.upper
            ));
        }
        if let Goal::Target(t) = self.goal {
            if t < self.lower || t > self.upper {
                return Err(format!(
                    "goal on '{}': target {t} lies outside its limits {} .. {}",
                    self.name, self.lower, self.upper
                ));
            }
        }
        if !(1..=5).contains(&self.importance) {
            return Err(format!(
                "goal on '{}': importance must be 1 to 5, got {}",
                self.name, self.importance
            ));
        }
        if !(self.weight_lower > 0.0
            && self.weight_upper > 0.0
            && self.weight_lower.is_finite()
            && self.weight_upper.is_finite())
        {
            return Err(format!("goal on '{}': weights must be positive", self.name));
        }
        Ok(())
    }
}

/// What a criterion looks at.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Subject {
    /// The prediction of `fits[i]`.
    Response(usize),
    /// Factor `j`, in the units of the data's factor column (coded unless ranges were given).
    Factor(usize),
}

/// Models to optimise together (all on the same factors) and the goals.
pub struct Problem<'a> {
    pub fits: Vec<&'a Fit>,
    pub criteria: Vec<(Subject, Criterion)>,
    /// Search box in coded units, one (low, high) per factor.
    pub bounds: Vec<(f64, f64)>,
}

#[derive(Clone, Debug, Serialize)]
pub struct Solution {
    pub coded: Vec<f64>,
    /// Actual settings when the factors' ranges are known.
    pub actual: Option<Vec<f64>>,
    /// Predicted responses, one per fit.
    pub responses: Vec<f64>,
    /// Desirability of each criterion.
    pub individual: Vec<f64>,
    pub desirability: f64,
}

impl Problem<'_> {
    fn subject_value(&self, s: Subject, coded: &[f64]) -> f64 {
        match s {
            Subject::Response(i) => self.fits[i].predict_coded(coded),
            Subject::Factor(j) => match &self.fits[0].experiment.factors {
                Some(f) => f[j].to_actual(coded[j]),
                None => coded[j],
            },
        }
    }

    /// Overall desirability: the importance-weighted geometric mean of the criteria that count,
    /// times the in-range constraints.
    pub fn desirability(&self, coded: &[f64]) -> (f64, Vec<f64>) {
        let mut log_sum = 0.0;
        let mut importance = 0.0;
        let mut feasible = true;
        let individual: Vec<f64> = self
            .criteria
            .iter()
            .map(|(s, c)| {
                let d = c.desirability(self.subject_value(*s, coded));
                if c.counts() {
                    importance += c.importance as f64;
                    log_sum += c.importance as f64 * d.max(1e-300).ln();
                    if d == 0.0 {
                        feasible = false;
                    }
                } else if d == 0.0 {
                    feasible = false;
                }
                d
            })
            .collect();
        let overall = if !feasible {
            0.0
        } else if importance == 0.0 {
            1.0
        } else {
            (log_sum / importance).exp()
        };
        (overall, individual)
    }

    fn clamp(&self, x: &[f64]) -> Vec<f64> {
        x.iter()
            .zip(&self.bounds)
            .map(|(v, (lo, hi))| v.clamp(*lo, *hi))
            .collect()
    }

    /// What the local search maximises: the desirability where it is positive, else minus the
    /// total shortfall, less a penalty for leaving the box.
    fn merit(&self, x: &[f64]) -> f64 {
        let xc = self.clamp(x);
        let outside: f64 = x.iter().zip(&xc).map(|(a, b)| (a - b).powi(2)).sum();
        let (d, _) = self.desirability(&xc);
        let base = if d > 0.0 {
            d
        } else {
            -self
                .criteria
                .iter()
                .map(|(s, c)| c.shortfall(self.subject_value(*s, &xc)))
                .sum::<f64>()
        };
        base - outside
    }

    fn solution(&self, coded: Vec<f64>) -> Solution {
        let (desirability, individual) = self.desirability(&coded);
        let actual = self.fits[0].experiment.factors.as_ref().map(|fs| {
            fs.iter()
                .zip(&coded)
                .map(|(f, &c)| f.to_actual(c))
                .collect()
        });
        Solution {
            responses: self.fits.iter().map(|f| f.predict_coded(&coded)).collect(),
            actual,
            individual,
            desirability,
            coded,
        }
    }

    /// Multi-start search: `starts` seeded random points in the box plus the design points inside
    /// it, each refined by Nelder-Mead; returns up to `max_solutions` solutions that differ by more
    /// than 0.05 coded units in some factor, best first. Ties in desirability (a target met on a
    /// whole curve) go to the solution nearest the centre of the box.
    pub fn solve(
        &self,
        starts: usize,
        seed: u64,
        max_solutions: usize,
    ) -> Result<Vec<Solution>, String> {
        if self.fits.is_empty() {
            return Err("optimise: no fitted response".into());
        }
        if starts > MAX_STARTS {
            return Err(format!(
                "optimise: {starts} random starts asked, at most {MAX_STARTS}"
            ));
        }
        if max_solutions == 0 {
            return Err("optimise: asked for no solutions (expected at least 1)".into());
        }
        for (_, c) in &self.criteria {
            c.validate()?;
        }
        for (j, &(lo, hi)) in self.bounds.iter().enumerate() {
            if !(lo.is_finite() && hi.is_finite() && lo <= hi) {
                return Err(format!(
                    "optimise: factor {}'s search range {lo} .. {hi} is not a range (expected finite low <= high)",
                    j + 1
                ));
            }
        }
        let mut rng = Pcg64::seed_from_u64(seed);
        let mut points: Vec<Vec<f64>> = self.fits[0]
            .experiment
            .coded
            .iter()
            .filter(|x| {
                x.iter()
                    .zip(&self.bounds)
                    .all(|(v, (lo, hi))| v >= lo && v <= hi)
            })
            .cloned()
            .collect();
        for _ in 0..starts {
            points.push(
                self.bounds
                    .iter()
                    .map(|(lo, hi)| {
                        if hi > lo {
                            rng.gen_range(*lo..=*hi)
                        } else {
                            *lo
                        }
                    })
                    .collect(),
            );
        }
        let scale: Vec<f64> = self.bounds.iter().map(|(lo, hi)| 0.2 * (hi - lo)).collect();
        let mut found: Vec<Solution> = points
            .iter()
            .map(|p| {
                let x = nelder_mead(|x| -self.merit(x), p, &scale, 600);
                self.solution(self.clamp(&x))
            })
            .collect();
        let centre: Vec<f64> = self.bounds.iter().map(|(lo, hi)| 0.5 * (lo + hi)).collect();
        let dist = |s: &Solution| -> f64 {
            s.coded
                .iter()
                .zip(&centre)
                .map(|(a, b)| (a - b).powi(2))
                .sum()
        };
        found.sort_by(|a, b| {
            let da = (a.desirability * 1e6).round();
            let db = (b.desirability * 1e6).round();
            db.total_cmp(&da).then(dist(a).total_cmp(&dist(b)))
        });
        let mut distinct: Vec<Solution> = Vec::new();
        for s in found {
            if distinct.len() >= max_solutions {
                break;
            }
            let new = distinct.iter().all(|d| {
                d.coded
                    .iter()
                    .zip(&s.coded)
                    .any(|(a, b)| (a - b).abs() > 0.05)
            });
            if new {
                distinct.push(s);
            }
        }
        Ok(distinct)
    }
}

/// Nelder-Mead minimisation from `start` with initial steps `scale`.
pub fn nelder_mead(
    f: impl Fn(&[f64]) -> f64,
    start: &[f64],
    scale: &[f64],
    max_iter: usize,
) -> Vec<f64> {
    let n = start.len();
    let mut simplex: Vec<(Vec<f64>, f64)> = Vec::with_capacity(n + 1);
    simplex.push((start.to_vec(), f(start)));
    for i in 0..n {
        let mut p = start.to_vec();
        p[i] += if scale[i] != 0.0 { scale[i] } else { 0.1 };
        let v = f(&p);
        simplex.push((p, v));
    }
    for _ in 0..max_iter {
        simplex.sort_by(|a, b| a.1.total_cmp(&b.1));
        let (best, worst) = (simplex[0].1, simplex[n].1);
        let size: f64 = simplex[1..]
            .iter()
            .map(|(p, _)| {
                p.iter()
                    .zip(&simplex[0].0)
                    .map(|(a, b)| (a - b).abs())
                    .fold(0.0, f64::max)
            })
            .fold(0.0, f64::max);
        if (worst - best).abs() <= 1e-12 * (best.abs() + 1e-12) && size < 1e-6 {
            break;
        }
        let centroid: Vec<f64> = (0..n)
            .map(|j| simplex[..n].iter().map(|(p, _)| p[j]).sum::<f64>() / n as f64)
            .collect();
        let along = |t: f64| -> Vec<f64> {
            (0..n)
                .map(|j| centroid[j] + t * (simplex[n].0[j] - centroid[j]))
                .collect()
        };
        let xr = along(-1.0);
        let fr = f(&xr);
        if fr < simplex[0].1 {
            let xe = along(-2.0);
            let fe = f(&xe);
            simplex[n] = if fe < fr { (xe, fe) } else { (xr, fr) };
        } else if fr < simplex[n - 1].1 {
            simplex[n] = (xr, fr);
        } else {
            let (xc, fc) = if fr < simplex[n].1 {
                let x = along(-0.5);
                let v = f(&x);
                (x, v)
            } else {
                let x = along(0.5);
                let v = f(&x);
                (x, v)
            };
            if fc < simplex[n].1.min(fr) {
                simplex[n] = (xc, fc);
            } else {
                let best = simplex[0].0.clone();
                for s in simplex.iter_mut().skip(1) {
                    s.0 =
                        s.0.iter()
                            .zip(&best)
                            .map(|(a, b)| b + 0.5 * (a - b))
                            .collect();
                    s.1 = f(&s.0);
                }
            }
        }
    }
    simplex.sort_by(|a, b| a.1.total_cmp(&b.1));
    simplex.swap_remove(0).0
}

#[cfg(test)]
mod tests {
    use super::*;

    fn crit(goal: Goal, lower: f64, upper: f64) -> Criterion {
        Criterion {
            name: "y".into(),
            goal,
            lower,
            upper,
            weight_lower: 1.0,
            weight_upper: 1.0,
            importance: 3,
        }
    }

    #[test]
    fn desirability_functions() {
        let max = crit(Goal::Maximize, 10.0, 20.0);
        assert_eq!(max.desirability(5.0), 0.0);
        assert!((max.desirability(15.0) - 0.5).abs() < 1e-15);
        assert_eq!(max.desirability(25.0), 1.0);
        let mut min = crit(Goal::Minimize, 10.0, 20.0);
        min.weight_upper = 2.0;
        assert!((min.desirability(15.0) - 0.25).abs() < 1e-15);
        let t = crit(Goal::Target(12.0), 10.0, 20.0);
        assert!((t.desirability(11.0) - 0.5).abs() < 1e-15);
        assert!((t.desirability(16.0) - 0.5).abs() < 1e-15);
        assert_eq!(t.desirability(12.0), 1.0);
        assert_eq!(t.desirability(21.0), 0.0);
        assert_eq!(crit(Goal::InRange, 1.0, 2.0).desirability(1.5), 1.0);
    }

    #[test]
    fn nelder_mead_finds_the_rosenbrock_minimum() {
        let x = nelder_mead(
            |x| (1.0 - x[0]).powi(2) + 100.0 * (x[1] - x[0] * x[0]).powi(2),
            &[-1.2, 1.0],
            &[0.5, 0.5],
            5000,
        );
        assert!(
            (x[0] - 1.0).abs() < 1e-4 && (x[1] - 1.0).abs() < 1e-4,
            "{x:?}"
        );
    }
}
