//! `steepest`: a path of runs (Design-Expert's steepest ascent or descent, the papers' "steepest
//! climb"), and the step nearest the lab value centres the next design on the ranges between its
//! neighbours.
//!
//! The path follows the screening's effects (their signs or coefficients) from coded −`reach` to
//! +`reach`; a parameter may go past its range only up to the `limits` given for it. Or the
//! path is given (`path = { name = [first, last] }`): then the named parameters are the ones the
//! following stages design over, no screening is needed before it, and the ends may lie past
//! the ranges, as seed 003's path does.

use std::any::Any;
use std::sync::Arc;

use crate::spec::{Section, Stage};
use crate::stage::table::{any_of, StageDef, StageTable};
use crate::limits::MAX_STEPS;
use crate::report_figures as figures;
use crate::text::esc;
use crate::spec::Study;
use crate::record::{Context, run_seed, RunSpec, StageResult, SteepestOutcome};
use crate::text::{sig, tidy};

#[derive(Clone, Debug, PartialEq)]
pub struct Steepest {
    /// Runs along the path, both ends included.
    pub steps: usize,
    /// Move every factor by the sign of its effect (false) or in proportion to it.
    pub proportional: bool,
    /// The path's ends in coded units of the ranges (1: from one end of the ranges to the other).
    pub reach: f64,
    /// How far past its range a parameter may go, by parameter index.
    pub limits: Vec<(usize, f64, f64)>,
    /// A given path: parameter index, first and last value.
    pub path: Vec<(usize, f64, f64)>,
}

/// Largest `reach`: ten times the ranges is already far outside what a screening says.
const MAX_REACH: f64 = 10.0;

impl StageDef for Steepest {
    const NAME: &'static str = "steepest";
    const KEYS: &'static [&'static str] = &["steps", "direction", "reach", "limits", "path"];

    fn parse(t: &StageTable) -> Result<Self, String> {
        let proportional = match t.text("direction", "signs")?.as_str() {
            "signs" => false,
            "coefficients" => true,
            _ => return Err(t.fail("direction", "expected \"signs\" or \"coefficients\"")),
        };
        let reach = match t.get("reach") {
            None => 1.0,
            Some(v) => crate::paths::number(v)
                .filter(|r| *r > 0.0 && *r <= MAX_REACH)
                .ok_or_else(|| {
                    t.fail(
                        "reach",
                        format!("expected a number above 0 and at most {MAX_REACH} (coded units of the ranges; 1 goes from one end of the ranges to the other)"),
                    )
                })?,
        };
        let named = |key: &str| -> Result<Vec<(usize, f64, f64)>, String> {
            let Some(v) = t.get(key) else {
                return Ok(Vec::new());
            };
            let table = v.as_table().filter(|t| !t.is_empty()).ok_or_else(|| {
                t.fail(key, "expected a table of [low, high] by parameter name, e.g. { rolling_friction = [0.05, 0.5] }")
            })?;
            let mut out = Vec::new();
            for (name, v) in table {
                let k = format!("{key}.{name}");
                let (i, _, _) = t.parameter(&k, name)?;
                if key == "path" {
                    match StageTable::numbers(v).as_deref() {
                        Some(&[a, b]) if a != b => out.push((i, a, b)),
                        _ => {
                            return Err(t.fail(
                                &k,
                                "expected [first, last]: the path's two ends, two different finite numbers in the parameter's units",
                            ))
                        }
                    }
                } else {
                    let (lo, hi) = t.pair(&k, v, "in the parameter's units")?;
                    out.push((i, lo, hi));
                }
            }
            Ok(out)
        };
        let path = named("path")?;
        let limits = named("limits")?;
        if !path.is_empty() {
            for k in ["direction", "reach", "limits"] {
                if t.get(k).is_some() {
                    return Err(t.fail(
                        k,
                        "a given path has its own ends and direction; leave this key out or the path",
                    ));
                }
            }
        }
        for &(i, lo, hi) in &limits {
            let (name, min, max) = &t.params[i];
            if lo > *min || hi < *max {
                return Err(t.fail(
                    &format!("limits.{name}"),
                    format!("[{lo}, {hi}] does not hold the parameter's range {min} .. {max}: limits say how far past it the path may go"),
                ));
            }
        }
        Ok(Steepest {
            steps: t.count("steps", 5, 3, Some(MAX_STEPS))?,
            proportional,
            reach,
            limits,
            path,
        })
    }
}

impl Steepest {
    /// Where parameter `pi` may be set: its stated limits, else its range.
    fn limit(&self, study: &Study, pi: usize) -> (f64, f64) {
        self.limits
            .iter()
            .find(|l| l.0 == pi)
            .map(|l| (l.1, l.2))
            .unwrap_or((study.parameters[pi].min, study.parameters[pi].max))
    }
}

impl Stage for Steepest {
    fn kind(&self) -> &'static str {
        Self::NAME
    }

    fn heading(&self) -> &'static str {
        "steepest path"
    }

    fn follows(&self, before: &[Arc<dyn Stage>]) -> Result<(), String> {
        if self.path.is_empty() && !any_of(before, &["screening"]) {
            return Err("steepest follows the effects of a screening stage; put one before it, or give the path (path = { name = [first, last], ... })".into());
        }
        Ok(())
    }

    fn plan(&self, study: &Study, st: &mut StageResult, ctx: &Context) -> Result<(), String> {
        let si = st.index;
        let steps = self.steps;
        let fraction = |i: usize| i as f64 / (steps - 1) as f64;
        // Each step's coded settings and every parameter's value.
        let mut points: Vec<(Vec<f64>, Vec<f64>)> = Vec::new();
        if !self.path.is_empty() {
            // The given path: its parameters are the stage's factors, coded over the path.
            st.active = self.path.iter().map(|p| p.0).collect();
            st.factors = self
                .path
                .iter()
                .map(|&(pi, a, b)| study.parameters[pi].factor(a.min(b), a.max(b)))
                .collect::<Result<_, _>>()?;
            st.title = format!("steepest path given, {steps} steps");
            for i in 0..steps {
                let mut values = ctx.values.clone();
                for &(pi, a, b) in &self.path {
                    let p = &study.parameters[pi];
                    let (ta, tb) = (p.transformed(a), p.transformed(b));
                    values[pi] = tidy(p.actual(ta + fraction(i) * (tb - ta)));
                }
                let coded = st
                    .active
                    .iter()
                    .zip(&st.factors)
                    .map(|(&pi, f)| tidy(f.to_coded(values[pi])))
                    .collect();
                points.push((coded, values));
            }
        } else {
            let biggest = ctx.direction.iter().fold(0.0f64, |m, c| m.max(c.abs()));
            let dir: Vec<f64> = ctx
                .direction
                .iter()
                .map(|c| {
                    if self.proportional {
                        c / biggest.max(1e-300)
                    } else if *c >= 0.0 {
                        1.0
                    } else {
                        -1.0
                    }
                })
                .collect();
            st.title = format!(
                "steepest path, {steps} steps {} ({})",
                if self.reach == 1.0 {
                    "across the ranges".to_string()
                } else {
                    format!("from coded −{r} to +{r}", r = sig(self.reach))
                },
                if self.proportional {
                    "in proportion to the coefficients"
                } else {
                    "by the signs of the effects"
                }
            );
            let mut clamped = Vec::new();
            for i in 0..steps {
                let t = self.reach * (2.0 * fraction(i) - 1.0);
                let mut values = ctx.values.clone();
                let mut coded: Vec<f64> = dir.iter().map(|d| t * d).collect();
                for (j, &pi) in st.active.iter().enumerate() {
                    let v = st.factors[j].to_actual(coded[j]);
                    let (lo, hi) = self.limit(study, pi);
                    // Rounding at an end of the range is not leaving it.
                    let tol = 1e-9 * (hi - lo).abs();
                    if v < lo - tol || v > hi + tol {
                        if !clamped.contains(&pi) {
                            clamped.push(pi);
                        }
                        values[pi] = tidy(v.clamp(lo, hi));
                        coded[j] = st.factors[j].to_coded(values[pi]);
                    } else {
                        values[pi] = tidy(v);
                    }
                }
                points.push((coded, values));
            }
            for pi in clamped {
                let (lo, hi) = self.limit(study, pi);
                st.notes.push(format!(
                    "{}: the path would leave {} .. {}; its steps stop there{}",
                    study.parameters[pi].name,
                    sig(lo),
                    sig(hi),
                    if self.limits.iter().any(|l| l.0 == pi) {
                        ""
                    } else {
                        " (its range; limits = { name = [low, high] } lets it go further)"
                    }
                ));
            }
        }
        for (i, (coded, values)) in points.into_iter().enumerate() {
            st.runs.push(RunSpec {
                stage: si,
                stage_kind: st.kind,
                index: i,
                point: i,
                label: format!("step {}", i + 1),
                coded,
                values,
                seed: run_seed(study.seed, si, i),
            });
        }
        Ok(())
    }

    fn conclude(
        &self,
        study: &Study,
        st: &mut StageResult,
        ctx: &mut Context,
    ) -> Result<(), String> {
        let target = study.target.value;
        crate::design_stages::enough(st, 1, "choosing the best step")?;
        crate::design_stages::bracket_note(study, st);
        let ok = st.successes();
        let (best_spec, best_y) = ok
            .iter()
            .min_by(|a, b| (a.1 - target).abs().total_cmp(&(b.1 - target).abs()))
            .copied()
            .ok_or("no run of the path gave a response")?;
        let b = best_spec.index;
        let last = st.runs.len() - 1;
        let (lo_i, hi_i) = if b == 0 {
            (0, 1)
        } else if b == last {
            (last - 1, last)
        } else {
            (b - 1, b + 1)
        };
        if b == 0 || b == last {
            st.notes.push(format!(
                "the step nearest the lab value is at the end of the path (step {}): the lab value may lie outside the parameters' ranges",
                b + 1
            ));
        }
        if !self.path.is_empty() {
            // The stages after a given path design over its parameters.
            ctx.active = st.active.clone();
        }
        for &pi in &st.active {
            let p = &study.parameters[pi];
            let a = st.runs[lo_i].values[pi];
            let c = st.runs[hi_i].values[pi];
            // Where the designs after it may go: past the range as far as the path went.
            let span = st
                .runs
                .iter()
                .map(|r| r.values[pi])
                .fold(ctx.limits[pi], |(lo, hi), v| (lo.min(v), hi.max(v)));
            ctx.limits[pi] = span;
            if a == c {
                // A parameter the path does not move (its coefficient is zero, to the digits
                // values are kept to) keeps the range it had: a range of nothing cannot be
                // designed over.
                let (lo, hi) = ctx.region[pi];
                st.notes.push(format!(
                    "{}: the path does not move it (its coefficient is about zero); its range stays {} .. {}",
                    p.name,
                    sig(lo),
                    sig(hi)
                ));
                ctx.values[pi] = a;
                continue;
            }
            ctx.region[pi] = (a.min(c), a.max(c));
            ctx.values[pi] = if b == 0 || b == last {
                p.actual(0.5 * (p.transformed(a) + p.transformed(c)))
            } else {
                st.runs[b].values[pi]
            };
        }
        st.notes.push(match study.target.relative_error_percent(best_y) {
            Some(e) => format!(
                "step {} gives {} against the lab's {} (relative error {e:.2} %)",
                b + 1,
                sig(best_y),
                sig(target),
            ),
            None => format!(
                "step {} gives the smallest {}: {}",
                b + 1,
                study.target.response,
                sig(best_y)
            ),
        });
        st.set_outcome(SteepestOutcome { best_step: b });
        Ok(())
    }

    fn report(&self, s: &mut Section<'_>) {
        s.figs.row(
            s.h,
            vec![(
                format!("stage{}-steepest-path", s.st.index + 1),
                figures::steepest_plot(s.study, s.st),
                format!(
                    "Steepest path (stage {}): {} at each step along the path, against the lab value; the ringed step is the nearest, and the next stage centres on it.",
                    s.st.index + 1,
                    esc(&figures::response_label(s.study))
                ),
            )],
        );
    }

    fn as_any(&self) -> &dyn Any {
        self
    }
}
