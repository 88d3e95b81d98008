//! The design-of-experiments stages: screening, steepest path, response surface, optimisation
//! and validation. [`plan_stage`] makes a stage's runs from the study and what the stages before
//! it found ([`Context`]); [`conclude`] fits, selects, optimises or validates once they are done.
//! The surrogate stages are planned and concluded in `surrogate_stages`.

use doe::design::{self, Design};
use doe::optimize::{Criterion, Goal, Problem, Subject};
use doe::{Curvature, Experiment, Factor, Fit, ModelOrder};

use crate::plan::SearchRegion;
use crate::spec::{Combine, RsmDesign, ScreeningDesign, Stage, Study};
use crate::stages::{
    run_seed, sig, target_values, tidy, Context, RunSpec, StageResult, Validation,
};
use crate::store::{RunRecord, Status};
use crate::surrogate_stages;

fn factors_of(study: &Study, ctx: &Context) -> Result<Vec<Factor>, String> {
    ctx.active
        .iter()
        .map(|&i| {
            let (lo, hi) = ctx.region[i];
            study.parameters[i].factor(lo, hi)
        })
        .collect()
}

fn specs_from_design(study: &Study, st: &mut StageResult, ctx: &Context, d: &Design) {
    let seed = run_seed(study.seed, st.index, usize::MAX >> 1);
    for (index, &std) in d.run_order(seed).iter().enumerate() {
        let coded = d.runs[std].clone();
        let mut values = ctx.values.clone();
        for (j, &pi) in st.active.iter().enumerate() {
            values[pi] = tidy(st.factors[j].to_actual(coded[j]));
        }
        st.runs.push(RunSpec {
            stage: st.index,
            stage_kind: st.kind,
            index,
            label: format!("{} (std {})", point_label(d, &coded), std + 1),
            coded,
            values,
            seed: run_seed(study.seed, st.index, index),
        });
    }
}

/// The runs of a stage. An error (a parameter whose range has shrunk to nothing) stops the
/// study with the reason.
pub(crate) fn plan_stage(
    study: &Study,
    si: usize,
    stage: &Stage,
    ctx: &Context,
) -> Result<StageResult, String> {
    let mut st = StageResult::new(si, stage.kind());
    st.active = ctx.active.clone();
    st.factors = factors_of(study, ctx)?;
    let k = st.active.len();
    match stage {
        Stage::Screening {
            design,
            center_points,
            ..
        } => {
            let d = match design {
                ScreeningDesign::PlackettBurman { runs } => design::plackett_burman(k, *runs, 0),
                ScreeningDesign::Fractional { resolution } => {
                    design::fractional_factorial_by_resolution(k, *resolution)
                }
                ScreeningDesign::Factorial => design::full_factorial(k),
            };
            match d {
                Ok(d) => {
                    let d = d.with_center_points(*center_points);
                    st.title = format!("{}, {} centre point(s)", d.kind, center_points);
                    specs_from_design(study, &mut st, ctx, &d);
                    st.design = Some(d);
                }
                Err(e) => st.notes.push(format!("design: {e}")),
            }
        }
        Stage::Steepest {
            steps,
            proportional,
        } => {
            let biggest = ctx.direction.iter().fold(0.0f64, |m, c| m.max(c.abs()));
            let dir: Vec<f64> = ctx
                .direction
                .iter()
                .map(|c| {
                    if *proportional {
                        c / biggest.max(1e-300)
                    } else if *c >= 0.0 {
                        1.0
                    } else {
                        -1.0
                    }
                })
                .collect();
            st.title = format!(
                "steepest path, {steps} steps across the ranges ({})",
                if *proportional {
                    "in proportion to the coefficients"
                } else {
                    "by the signs of the effects"
                }
            );
            for i in 0..*steps {
                let t = -1.0 + 2.0 * i as f64 / (*steps - 1) as f64;
                let coded: Vec<f64> = dir.iter().map(|d| t * d).collect();
                let mut values = ctx.values.clone();
                for (j, &pi) in st.active.iter().enumerate() {
                    values[pi] = tidy(st.factors[j].to_actual(coded[j]));
                }
                st.runs.push(RunSpec {
                    stage: si,
                    stage_kind: st.kind,
                    index: i,
                    label: format!("step {}", i + 1),
                    coded,
                    values,
                    seed: run_seed(study.seed, si, i),
                });
            }
        }
        Stage::Rsm {
            design: kind,
            center_points,
            ..
        } => {
            let d = match kind {
                RsmDesign::CentralComposite { alpha } => {
                    let cp = center_points.unwrap_or(if k == 2 { 5 } else { 6 });
                    design::central_composite(k, *alpha, cp, None)
                }
                RsmDesign::BoxBehnken => design::box_behnken(k, center_points.unwrap_or(5)),
            };
            match d {
                Ok(d) => {
                    // Axial points must stay inside the parameters' limits: shift the region,
                    // or shrink it, until they do.
                    let a = d.alpha.unwrap_or(1.0);
                    let mut factors = Vec::new();
                    for (j, &pi) in st.active.iter().enumerate() {
                        let p = &study.parameters[pi];
                        let f = &st.factors[j];
                        let (lo, hi) = (p.transformed(f.low), p.transformed(f.high));
                        let (lim_lo, lim_hi) = (p.transformed(p.min), p.transformed(p.max));
                        let mut h = 0.5 * (hi - lo);
                        let mut c = 0.5 * (hi + lo);
                        if c - a * h < lim_lo - 1e-12 || c + a * h > lim_hi + 1e-12 {
                            let a_text = sig(a);
                            h = h.min((lim_hi - lim_lo) / (2.0 * a));
                            // When the region fills the whole range the two bounds for the
                            // centre meet, and rounding can leave them a hair crossed.
                            let (c_lo, c_hi) = (lim_lo + a * h, lim_hi - a * h);
                            c = if c_lo <= c_hi {
                                c.clamp(c_lo, c_hi)
                            } else {
                                0.5 * (lim_lo + lim_hi)
                            };
                            st.notes.push(format!(
                                "{}: the design's axial points (coded −{a_text} and +{a_text}) would leave {} .. {}; its coded range −1 to +1 is now {} .. {}",
                                p.name,
                                sig(p.min),
                                sig(p.max),
                                sig(p.actual(c - h)),
                                sig(p.actual(c + h))
                            ));
                        }
                        factors.push(p.factor(p.actual(c - h), p.actual(c + h))?);
                    }
                    st.factors = factors;
                    st.title = format!("{}, {} runs", d.kind, d.runs.len());
                    specs_from_design(study, &mut st, ctx, &d);
                    st.design = Some(d);
                }
                Err(e) => st.notes.push(format!("design: {e}")),
            }
        }
        Stage::Optimize { .. } => {
            st.title = "numerical optimisation (desirability) toward the lab value".into();
        }
        Stage::BayesOpt { .. } | Stage::GaBp { .. } | Stage::Smc { .. } => {
            surrogate_stages::plan(study, stage, &mut st, ctx)?;
        }
        Stage::Validate {
            replicates,
            candidates,
        } => {
            // The optimum; without an optimisation, the best run so far; else the middle.
            let point = ctx
                .calibrated
                .clone()
                .or_else(|| ctx.best.clone())
                .unwrap_or_else(|| ctx.values.clone());
            // With several candidates, the optimisation's next solutions after it (as many as
            // it found).
            let points: Vec<Vec<f64>> = if ctx.candidates.first() == Some(&point) {
                ctx.candidates.iter().take(*candidates).cloned().collect()
            } else {
                vec![point.clone()]
            };
            if *candidates > points.len() {
                st.notes.push(if ctx.candidates.first() == Some(&point) {
                    format!(
                        "{candidates} candidates asked for, the optimisation found {} distinct solution(s): all are replicated",
                        points.len()
                    )
                } else {
                    format!("{candidates} candidates asked for, but no optimisation since the last validation gave solutions: the calibrated point alone is replicated")
                });
            }
            st.title = if points.len() == 1 {
                format!("{replicates} replicate simulations at the calibrated point")
            } else {
                format!(
                    "{replicates} replicate simulations at each of the {} best solutions",
                    points.len()
                )
            };
            for (c, values) in points.iter().enumerate() {
                for r in 0..*replicates {
                    let i = c * replicates + r;
                    st.runs.push(RunSpec {
                        stage: si,
                        stage_kind: st.kind,
                        index: i,
                        label: if points.len() == 1 {
                            format!("replicate {}", r + 1)
                        } else {
                            format!("solution {} replicate {}", c + 1, r + 1)
                        },
                        coded: Vec::new(),
                        values: values.clone(),
                        seed: run_seed(study.seed, si, i),
                    });
                }
            }
            st.calibrated = Some(point);
        }
    }
    Ok(st)
}

fn experiment(study: &Study, st: &StageResult) -> Experiment {
    let ok = st.successes();
    Experiment {
        response_name: study.target.response.clone(),
        factor_names: st.factors.iter().map(|f| f.name.clone()).collect(),
        factors: Some(st.factors.clone()),
        coded: ok.iter().map(|(s, _)| s.coded.clone()).collect(),
        response: ok.iter().map(|(_, y)| *y).collect(),
    }
}

fn enough(st: &StageResult, needed: usize, what: &str) -> Result<(), String> {
    let ok = st.usable();
    if ok < needed {
        // Runs stored as done without a response (a store from elsewhere) do not count.
        let without = st.done() - ok;
        return Err(format!(
            "{ok} of {} runs finished{} ({} failed{}); {what} needs at least {needed}. Look at the failures, narrow the ranges or make the test more robust, then run again with --retry-failed",
            st.runs.len(),
            if without > 0 {
                format!(" with a response, {without} without")
            } else {
                String::new()
            },
            st.failed(),
            st.first_failure()
        ));
    }
    Ok(())
}

/// A fit's complaint, prefixed with the failed runs when they are the likely cause.
/// A desirability study's model complaint, with why its response can be flat.
fn plateau_hint(study: &Study, e: String) -> String {
    if study.combine != Some(Combine::Desirability) {
        return e;
    }
    format!("{e} (a run with any target at or beyond its limits has undesirability 1: widen the targets' low and high, or combine = \"weighted\")")
}

fn with_failures(st: &StageResult, e: String) -> String {
    if st.failed() == 0 {
        return e;
    }
    format!(
        "{} of {} runs failed{}; the finished ones cannot be modelled: {e}",
        st.failed(),
        st.runs.len(),
        st.first_failure()
    )
}

pub(crate) fn conclude(
    study: &Study,
    stage: &Stage,
    st: &mut StageResult,
    ctx: &mut Context,
) -> Result<(), String> {
    let target = study.target.value;
    if st.runs.is_empty() && stage.runs_simulations() {
        return Err(st.notes.join("; "));
    }
    if st.failed() > 0 {
        st.notes.push(format!(
            "{} of {} runs failed{}",
            st.failed(),
            st.runs.len(),
            st.first_failure()
        ));
    }
    match stage {
        Stage::Screening {
            alpha,
            min_factors,
            max_factors,
            ..
        } => {
            let k = st.active.len();
            let terms = ModelOrder::Linear.terms(k);
            enough(
                st,
                terms.len() + 1,
                "a first-order model with one residual degree of freedom",
            )?;
            let fit = Fit::new(&experiment(study, st), &terms, Curvature::Auto)
                .map_err(|e| plateau_hint(study, with_failures(st, e)))?;
            // p of each main effect, in factor order.
            let p: Vec<f64> = (0..k)
                .map(|j| {
                    fit.terms
                        .iter()
                        .skip(1)
                        .zip(&fit.anova_terms)
                        .find(|(t, _)| t.powers[j] == 1 && t.order() == 1)
                        .and_then(|(_, r)| r.p)
                        .unwrap_or(1.0)
                })
                .collect();
            let coef: Vec<f64> = (0..k)
                .map(|j| {
                    fit.terms
                        .iter()
                        .zip(&fit.coefficients)
                        .find(|(t, _)| t.powers[j] == 1 && t.order() == 1)
                        .map(|(_, c)| c.estimate)
                        .unwrap_or(0.0)
                })
                .collect();
            let mut order: Vec<usize> = (0..k).collect();
            order.sort_by(|&a, &b| {
                p[a].total_cmp(&p[b])
                    .then(coef[b].abs().total_cmp(&coef[a].abs()))
            });
            let significant: Vec<usize> =
                order.iter().copied().filter(|&j| p[j] < *alpha).collect();
            let mut chosen: Vec<usize> = significant.clone();
            if chosen.len() < *min_factors {
                chosen = order[..(*min_factors).min(k)].to_vec();
                st.notes.push(format!(
                    "{} parameter(s) significant at p < {}; the {} with the smallest p go on",
                    significant.len(),
                    alpha,
                    chosen.len()
                ));
            }
            if chosen.len() > *max_factors {
                chosen.truncate(*max_factors);
                st.notes.push(format!(
                    "{} parameters significant at p < {}; the {} with the smallest p go on (max_factors)",
                    significant.len(),
                    alpha,
                    max_factors
                ));
            }
            chosen.sort_unstable();
            let selected: Vec<usize> = chosen.iter().map(|&j| st.active[j]).collect();
            for (j, &pi) in st.active.iter().enumerate() {
                if !chosen.contains(&j) {
                    // Held at the middle of its range, as the published studies do.
                    let pmid = &study.parameters[pi];
                    let (lo, hi) = ctx.region[pi];
                    ctx.values[pi] =
                        pmid.actual(0.5 * (pmid.transformed(lo) + pmid.transformed(hi)));
                }
            }
            ctx.direction = chosen.iter().map(|&j| coef[j]).collect();
            ctx.model = Some((fit.clone(), st.active.clone()));
            ctx.model_targets = st.target_values(study.targets.len());
            ctx.model_quadratic = false;
            ctx.active = selected.clone();
            st.selected = selected;
            st.fit = Some(fit);
        }
        Stage::Steepest { .. } => {
            enough(st, 1, "choosing the best step")?;
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
            for &pi in &st.active {
                let p = &study.parameters[pi];
                let a = st.runs[lo_i].values[pi];
                let c = st.runs[hi_i].values[pi];
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
            st.notes
                .push(match study.target.relative_error_percent(best_y) {
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
            st.best_step = Some(b);
        }
        Stage::Rsm {
            reduce, alpha_out, ..
        } => {
            let k = st.active.len();
            let terms = ModelOrder::Quadratic.terms(k);
            enough(
                st,
                terms.len() + 1,
                "a quadratic model with one residual degree of freedom",
            )?;
            let exp = experiment(study, st);
            let per_target = st.target_values(study.targets.len());
            let full = match Fit::new(&exp, &terms, Curvature::Off) {
                Ok(f) => f,
                Err(e)
                    if study.combine == Some(Combine::Desirability)
                        && per_target.len() == exp.response.len() =>
                {
                    // Every run beyond some target's limits scores 1, and a design can sit
                    // wholly there; the optimiser models each target's response anyway.
                    let fits = target_fits(study, &exp, true, &per_target)?;
                    st.notes.push(format!(
                        "the combined undesirability cannot be modelled ({e}); the stage's model is the first target's, and optimize models each target"
                    ));
                    let first = fits[0].clone();
                    ctx.model = Some((first.clone(), st.active.clone()));
                    ctx.model_targets = per_target;
                    ctx.model_quadratic = true;
                    st.full_fit = Some(first.clone());
                    st.fit = Some(first);
                    return Ok(());
                }
                Err(e) => return Err(plateau_hint(study, with_failures(st, e))),
            };
            let fit = if *reduce {
                Fit::reduce(&exp, &terms, Curvature::Off, *alpha_out, true)
                    .map_err(|e| with_failures(st, e))?
            } else {
                full.clone()
            };
            if !fit.removed.is_empty() {
                st.notes.push(format!(
                    "backward elimination (alpha out {alpha_out}) removed {}",
                    fit.removed
                        .iter()
                        .map(|(n, p)| format!("{n} (p {})", doe::fit::fmt_p(*p)))
                        .collect::<Vec<_>>()
                        .join(", ")
                ));
            }
            ctx.model = Some((fit.clone(), st.active.clone()));
            ctx.model_targets = per_target;
            ctx.model_quadratic = true;
            st.full_fit = Some(full);
            st.fit = Some(fit);
        }
        Stage::Optimize {
            solutions,
            starts,
            region,
        } => {
            let (fit, active) = ctx
                .model
                .clone()
                .ok_or("no stage before it fitted a model (put a screening or rsm stage first)")?;
            let rows = fit.experiment.response.len();
            let bounds = search_bounds(&fit.experiment, region)?;
            st.notes
                .push(format!("the search: each factor {}", region.describe()));
            if let SearchRegion::Limits(limits) = region {
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
            let (found, equally_good) = if desirability {
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
                    problem.solve(*starts, run_seed(study.seed, st.index, 0), *solutions)?;
                let ranges = equally_good(&problem, &found);
                drop(problem);
                st.target_fits = fits;
                (found, ranges)
            } else {
                let problem = single_response_problem(study, &fit, bounds);
                let found =
                    problem.solve(*starts, run_seed(study.seed, st.index, 0), *solutions)?;
                let ranges = equally_good(&problem, &found);
                (found, ranges)
            };
            st.equally_good = equally_good;

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
            st.solutions = found;
            st.fit = Some(fit);
            ctx.calibrated = Some(point.clone());
            ctx.chosen_solution = 0;
            st.calibrated = Some(point);
        }
        Stage::BayesOpt { .. } | Stage::GaBp { .. } | Stage::Smc { .. } => {
            surrogate_stages::conclude(study, stage, st, ctx)?;
        }
        Stage::Validate { replicates, .. } => {
            enough(st, 1, "validation")?;
            // With several candidates, the one whose runs come nearest the lab value (lowest,
            // for a minimised response) is validated and calibrated.
            let candidates = st.runs.len().div_ceil(*replicates);
            let found: Vec<Option<Validation>> = (0..candidates)
                .map(|c| candidate_validation(study, st, *replicates, c))
                .collect();
            let miss = |v: &Validation| {
                if study.target.minimised() {
                    v.mean
                } else {
                    (v.mean - study.target.value).abs()
                }
            };
            let chosen = (0..candidates)
                .filter_map(|c| found[c].as_ref().map(|v| (c, miss(v))))
                .min_by(|a, b| a.1.total_cmp(&b.1))
                .map(|(c, _)| c)
                .ok_or("no validation run gave a response")?;
            if candidates > 1 {
                for (c, v) in found.iter().enumerate() {
                    st.notes.push(match v {
                        Some(v) => format!(
                            "solution {}: {} = {}{} over {} run(s){}",
                            c + 1,
                            study.target.response,
                            sig(v.mean),
                            v.std.map(|s| format!(" ± {}", sig(s))).unwrap_or_default(),
                            v.runs,
                            v.relative_error_percent
                                .map(|e| format!(", {e:.2} % from the lab value"))
                                .unwrap_or_default()
                        ),
                        None => format!("solution {}: no run gave a response", c + 1),
                    });
                }
                st.notes.push(format!(
                    "solution {} validates nearest the lab value: it is the calibrated point",
                    chosen + 1
                ));
                st.notes.push("the runs that chose it also measure its error, which therefore reads a little low; a second validate stage replicates the chosen point with new seeds".into());
                st.calibrated = Some(st.runs[chosen * replicates].values.clone());
            }
            // A validation of one point replicates what the context calibrated.
            st.chosen_solution = if candidates > 1 {
                chosen
            } else {
                ctx.chosen_solution
            };
            ctx.chosen_solution = st.chosen_solution;
            st.validation = found[chosen].clone();
            // A later stage (another validation) starts from the chosen point alone.
            ctx.calibrated = st.calibrated.clone();
            ctx.candidates.clear();
        }
    }
    Ok(())
}

fn point_label(d: &Design, run: &[f64]) -> String {
    let nonzero = run.iter().filter(|v| v.abs() > 1e-12).count();
    let label = if nonzero == 0 {
        "center"
    } else if d.alpha.is_some_and(|a| (a - 1.0).abs() > 1e-9) && nonzero == 1 {
        "axial"
    } else if nonzero == run.len() {
        "factorial"
    } else {
        "edge"
    };
    label.to_string()
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

/// One model per target on the runs of `exp` (each run's target values in `values`): a full
/// quadratic after a response surface, a linear model after screening.
fn target_fits(
    study: &Study,
    exp: &Experiment,
    quadratic: bool,
    values: &[Vec<f64>],
) -> Result<Vec<Fit>, String> {
    let k = exp.factor_names.len();
    let order = if quadratic {
        ModelOrder::Quadratic
    } else {
        ModelOrder::Linear
    };
    let terms = order.terms(k);
    study
        .targets
        .iter()
        .enumerate()
        .map(|(i, t)| {
            let exp = Experiment {
                response_name: format!("{} ({})", t.response, study.tests[t.test].name),
                response: values.iter().map(|r| r[i]).collect(),
                ..exp.clone()
            };
            Fit::new(&exp, &terms, Curvature::Off)
                .map_err(|e| format!("the model of {}: {e}", exp.response_name))
        })
        .collect()
}

/// The validation of candidate `c` of a validation stage (its runs are `c * replicates ..`):
/// `None` when none of them gave a response.
fn candidate_validation(
    study: &Study,
    st: &StageResult,
    replicates: usize,
    c: usize,
) -> Option<Validation> {
    let runs: Vec<&RunRecord> = st
        .runs
        .iter()
        .zip(&st.records)
        .filter(|(s, _)| s.index / replicates == c)
        .filter_map(|(_, r)| r.as_ref())
        .filter(|r| r.status == Status::Done && r.response.is_some())
        .collect();
    let ys: Vec<f64> = runs.iter().filter_map(|r| r.response).collect();
    if ys.is_empty() {
        return None;
    }
    let mut v = Validation::of(&ys, &study.target);
    let per_run: Vec<Vec<f64>> = runs
        .iter()
        .filter_map(|r| target_values(r))
        .filter(|t| t.len() == study.targets.len())
        .collect();
    if study.combine.is_some() && per_run.len() == ys.len() {
        v.targets = study
            .targets
            .iter()
            .enumerate()
            .map(|(i, t)| {
                let ys: Vec<f64> = per_run.iter().map(|r| r[i]).collect();
                Validation::of(&ys, t)
            })
            .collect();
    }
    Some(v)
}
