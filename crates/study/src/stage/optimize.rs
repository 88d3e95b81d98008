//! `optimize`: Design-Expert's numerical optimisation of the model the stage before it fitted
//! (a response surface, or a screening's first-order model): the settings whose predicted
//! response comes nearest the lab value (or lowest, for a minimised one), by desirability, within
//! the search region; with several targets, each target modelled and their desirabilities
//! combined.

use std::any::Any;
use std::sync::Arc;

use doe::optimize::{Criterion, Goal, Problem, Subject};
use doe::{Experiment, Fit};

use crate::spec::{Section, Stage};
use crate::stage::table::{any_of, StageDef, StageTable};
use crate::design_stages::target_fits;
use crate::limits::MAX_SOLUTIONS;
use crate::spec::{Combine, Study};
use crate::record::{run_seed, Context, OptimizeOutcome, SearchRegion, StageResult};

#[derive(Clone, Debug, PartialEq)]
pub struct Optimize {
    pub solutions: usize,
    pub starts: usize,
    pub region: SearchRegion,
}

impl StageDef for Optimize {
    const NAME: &'static str = "optimize";
    const KEYS: &'static [&'static str] = &["solutions", "starts", "region"];

    fn parse(t: &StageTable) -> Result<Self, String> {
        Ok(Optimize {
            solutions: t.count("solutions", 5, 1, Some(MAX_SOLUTIONS))?,
            starts: t.count("starts", 40, 1, Some(doe::optimize::MAX_STARTS))?,
            region: search_region(t)?,
        })
    }
}

impl Stage for Optimize {
    fn kind(&self) -> &'static str {
        Self::NAME
    }

    fn heading(&self) -> &'static str {
        "optimisation"
    }

    fn runs_simulations(&self) -> bool {
        false
    }

    fn follows(&self, before: &[Arc<dyn Stage>]) -> Result<(), String> {
        if !any_of(before, &["screening", "rsm"]) {
            return Err(
                "optimize searches a fitted model; put a screening or rsm stage before it".into(),
            );
        }
        Ok(())
    }

    fn plan(&self, _study: &Study, st: &mut StageResult, _ctx: &Context) -> Result<(), String> {
        st.title = "numerical optimisation (desirability) toward the lab value".into();
        Ok(())
    }

    fn conclude(
        &self,
        study: &Study,
        st: &mut StageResult,
        ctx: &mut Context,
    ) -> Result<(), String> {
        let (fit, active) = ctx
            .model
            .clone()
            .ok_or("no stage before it fitted a model (put a screening or rsm stage first)")?;
        let rows = fit.experiment.response.len();
        let bounds = search_bounds(&fit.experiment, &self.region)?;
        let searched = bounds.clone();
        st.notes
            .push(format!("the search: each factor {}", self.region.describe()));
        if let SearchRegion::Limits(limits) = &self.region {
            for (name, _, _) in limits {
                if !fit.experiment.factor_names.contains(name) {
                    st.notes.push(format!(
                        "region.{name}: not a factor of the model (screened out or held); its limits are not used"
                    ));
                }
            }
        }
        let desirability = study.combine == Some(Combine::Desirability)
            && ctx.model_targets.len() == rows
            && rows > 0;
        let (mut found, equally_good, target_fits) = if desirability {
            // Design-Expert's numerical optimisation: each response its own model, their
            // desirabilities combined.
            let fits = target_fits(
                study,
                &fit.experiment,
                ctx.model_quadratic,
                &ctx.model_targets,
            )?;
            st.notes.push(format!(
                "each target's response modelled on the same runs ({}); the search maximises their overall desirability",
                fits.iter()
                    .map(|f| format!("{} R² {:.3}", f.experiment.response_name, f.r2))
                    .collect::<Vec<_>>()
                    .join(", ")
            ));
            let problem = Problem {
                fits: fits.iter().collect(),
                criteria: study
                    .targets
                    .iter()
                    .enumerate()
                    .map(|(i, t)| (Subject::Response(i), t.term().criterion()))
                    .collect(),
                bounds: bounds.clone(),
            };
            let found =
                problem.solve(self.starts, run_seed(study.seed, st.index, 0), self.solutions)?;
            let ranges = equally_good(&problem, &found);
            drop(problem);
            (found, ranges, fits)
        } else {
            let problem = single_response_problem(study, &fit, bounds);
            let found =
                problem.solve(self.starts, run_seed(study.seed, st.index, 0), self.solutions)?;
            let ranges = equally_good(&problem, &found);
            (found, ranges, Vec::new())
        };

        // A minimised response's polynomial dips below zero near its least value; reported as 0.
        for s in &mut found {
            for (i, y) in s.responses.iter_mut().enumerate() {
                let t = if desirability {
                    study.targets.get(i)
                } else {
                    Some(&study.target)
                };
                *y = t.map_or(*y, |t| t.predicted(*y));
            }
        }
        let best = found.first().ok_or("the search found no solution")?.clone();
        // Every solution as every parameter's value, for a validation of several.
        let full = |s: &doe::optimize::Solution| {
            let mut point = ctx.values.clone();
            for (j, &pi) in active.iter().enumerate() {
                point[pi] = s.actual.as_ref().map(|a| a[j]).unwrap_or(point[pi]);
            }
            point
        };
        let point = full(&best);
        ctx.candidates = found.iter().map(full).collect();
        if best.desirability <= 0.0 && !study.target.minimised() {
            st.notes.push("the model does not reach the lab value inside the ranges; the closest setting is taken".into());
        }
        if desirability && best.desirability <= 0.0 {
            st.notes.push("no setting inside the ranges brings every target within its limits (desirability 0): widen the limits (low, high) or the ranges".into());
        }
        st.active = active;
        st.factors = fit.experiment.factors.clone().unwrap_or_default();
        // Each solution's intervals: a validation of several candidates may choose another.
        ctx.candidate_uncertainties = found
            .iter()
            .map(|s| {
                crate::uncertainty_routes::from_response_model(
                    study,
                    st,
                    &fit,
                    &target_fits,
                    searched.clone(),
                    s.coded.clone(),
                    &equally_good,
                )
            })
            .collect();
        st.uncertainty = ctx.candidate_uncertainties.first().cloned();
        st.set_outcome(OptimizeOutcome {
            solutions: found,
            equally_good,
            target_fits,
        });
        st.fit = Some(fit);
        ctx.calibrated = Some(point.clone());
        ctx.chosen_solution = 0;
        st.calibrated = Some(point);
        Ok(())
    }

    fn report(&self, s: &mut Section<'_>) {
        if !s.st.target_fits().is_empty() {
            crate::targets_report::optimize_table(s.h, s.study, s.st)
        } else if let Some(fit) = &s.st.fit {
            crate::report_model::optimize(s.h, s.study, s.st, fit, &self.region);
        }
    }

    fn as_any(&self) -> &dyn Any {
        self
    }
}

/// Reads `optimize`'s `region`: "cube", "axial", or a table of [low, high] by parameter name.
fn search_region(t: &StageTable) -> Result<SearchRegion, String> {
    let v = t.get("region");
    let expected = "expected \"cube\" (coded ±1), \"axial\" (out to the axial points, ±alpha) or limits by parameter, e.g. { rolling_friction = [0.05, 0.3] }";
    match v {
        None => Ok(SearchRegion::Cube),
        Some(toml::Value::String(s)) if s == "cube" => Ok(SearchRegion::Cube),
        Some(toml::Value::String(s)) if s == "axial" => Ok(SearchRegion::Axial),
        Some(toml::Value::Table(named)) if !named.is_empty() => {
            let mut limits = Vec::new();
            for (name, v) in named {
                let k = format!("region.{name}");
                let (_, min, max) = t.parameter(&k, name)?;
                let (lo, hi) = t.pair(&k, v, "in the parameter's units")?;
                // The parameter's range is where it may be set at all.
                if lo < min || hi > max {
                    return Err(t.fail(
                        &k,
                        format!("[{lo}, {hi}] leaves the parameter's range {min} .. {max}"),
                    ));
                }
                limits.push((name.clone(), lo, hi))
            }
            Ok(SearchRegion::Limits(limits))
        }
        Some(_) => Err(t.fail("region", expected)),
    }
}

/// The search for the optimum of the model of the study's one response (or combined
/// objective): on target, or minimised.
fn single_response_problem<'a>(
    study: &Study,
    fit: &'a Fit,
    bounds: Vec<(f64, f64)>,
) -> Problem<'a> {
    let target = study.target.value;
    let observed = &fit.experiment.response;
    let (goal, lo, hi) = if study.target.minimised() {
        // Minimise the model itself: below the lower limit every point would be equally
        // desirable, so the limit is put under the model's least value in the search box
        // (a term of degree d of a coded polynomial lies within ±m^d there, m the box's
        // largest coded distance).
        let m = bounds
            .iter()
            .map(|&(lo, hi)| lo.abs().max(hi.abs()))
            .fold(1.0, f64::max);
        let reach: f64 = fit
            .coefficients
            .iter()
            .zip(&fit.terms)
            .skip(1)
            .map(|(c, t)| c.estimate.abs() * m.powi(t.powers.iter().map(|&p| i32::from(p)).sum()))
            .sum();
        let floor = fit.coefficients.first().map(|c| c.estimate).unwrap_or(0.0) - reach;
        let hi = observed.iter().copied().fold(f64::MIN, f64::max);
        let lo = floor.min(hi) - 1e-9 * (1.0 + hi.abs() + reach);
        (Goal::Minimize, lo, hi)
    } else {
        let lo = observed.iter().copied().fold(target, f64::min);
        let hi = observed.iter().copied().fold(target, f64::max);
        (Goal::Target(target), lo, hi)
    };
    Problem {
        fits: vec![fit],
        criteria: vec![(
            Subject::Response(0),
            Criterion {
                name: study.target.response.clone(),
                goal,
                lower: lo,
                upper: hi,
                weight_lower: 1.0,
                weight_upper: 1.0,
                importance: 3,
            },
        )],
        bounds,
    }
}

/// The coded box `optimize` searches (see [`SearchRegion`]).
fn search_bounds(e: &Experiment, region: &SearchRegion) -> Result<Vec<(f64, f64)>, String> {
    let k = e.factor_names.len();
    Ok(match region {
        SearchRegion::Cube => vec![(-1.0, 1.0); k],
        SearchRegion::Axial => (0..k)
            .map(|j| {
                let reach = e.coded.iter().map(|r| r[j].abs()).fold(1.0, f64::max);
                (-reach, reach)
            })
            .collect(),
        SearchRegion::Limits(limits) => {
            let factors = e
                .factors
                .as_ref()
                .ok_or("the model's factors have no actual ranges to place the limits in")?;
            factors
                .iter()
                .map(|f| match limits.iter().find(|(n, _, _)| *n == f.name) {
                    Some(&(_, lo, hi)) => {
                        let (a, b) = (f.to_coded(lo), f.to_coded(hi));
                        if a.is_finite() && b.is_finite() {
                            Ok((a.min(b), a.max(b)))
                        } else {
                            Err(format!(
                                "region.{}: the limits {lo} .. {hi} cannot be placed on the factor's scale",
                                f.name
                            ))
                        }
                    }
                    None => Ok((-1.0, 1.0)),
                })
                .collect::<Result<_, String>>()?
        }
    })
}

/// Each factor's equally good stretch around the first solution ([`StageResult::equally_good`]).
fn equally_good(problem: &Problem, found: &[doe::optimize::Solution]) -> Vec<(f64, f64)> {
    let Some(best) = found.first() else {
        return Vec::new();
    };
    (0..best.coded.len())
        .map(|j| {
            doe::diagnostics::equally_good_range(
                |x| problem.desirability(x).0,
                &best.coded,
                j,
                problem.bounds[j],
                crate::stages::EQUALLY_GOOD,
            )
        })
        .collect()
}

