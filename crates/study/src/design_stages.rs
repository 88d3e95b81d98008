//! What the design-of-experiments stages share (`stage::screening`, `steepest`, `rsm`,
//! `optimize`, `validate`, `sweep`): the runs of a design, with replicates; the experiment a
//! model is fitted to (the mean of each design point's replicates); the checks and messages
//! before a fit.

use doe::design::Design;
use doe::{Curvature, Experiment, Factor, Fit, ModelOrder};

use crate::curve::{stored_curve, Curve};
use crate::limits::MAX_REPLICATES;
use crate::record::{run_seed, Context, RunSpec, StageResult};
use crate::spec::{Combine, Study};
use crate::stage::table::StageTable;
use crate::store::Status;
use crate::text::{sig, tidy};

/// The active parameters' factors over their current region.
pub(crate) fn factors_of(study: &Study, ctx: &Context) -> Result<Vec<Factor>, String> {
    ctx.active
        .iter()
        .map(|&i| {
            let (lo, hi) = ctx.region[i];
            study.parameters[i].factor(lo, hi)
        })
        .collect()
}

/// A design stage's `replicates`: runs at each design point, each with its own seed.
pub(crate) fn replicates_key(t: &StageTable) -> Result<usize, String> {
    t.count("replicates", 1, 1, Some(MAX_REPLICATES))
}

/// The runs of design `d` in its randomised order, each point `replicates` times in a row (run
/// `point * replicates + r`); one replicate gives the runs and seeds a design always had.
pub(crate) fn specs_from_design(
    study: &Study,
    st: &mut StageResult,
    ctx: &Context,
    d: &Design,
    replicates: usize,
) {
    let seed = run_seed(study.seed, st.index, usize::MAX >> 1);
    for (point, &std) in d.run_order(seed).iter().enumerate() {
        let coded = d.runs[std].clone();
        let mut values = ctx.values.clone();
        for (j, &pi) in st.active.iter().enumerate() {
            values[pi] = tidy(st.factors[j].to_actual(coded[j]));
        }
        for r in 0..replicates {
            let index = point * replicates + r;
            let label = format!("{} (std {})", point_label(d, &coded), std + 1);
            st.runs.push(RunSpec {
                stage: st.index,
                stage_kind: st.kind,
                index,
                point,
                label: if replicates > 1 {
                    format!("{label} replicate {}", r + 1)
                } else {
                    label
                },
                coded: coded.clone(),
                values: values.clone(),
                seed: run_seed(study.seed, st.index, index),
            });
        }
    }
}

/// What a model is fitted to: each design point's mean response over its finished replicates.
pub(crate) fn experiment(study: &Study, st: &StageResult) -> Experiment {
    let points = st.point_means();
    Experiment {
        response_name: study.target.response.clone(),
        factor_names: st.factors.iter().map(|f| f.name.clone()).collect(),
        factors: Some(st.factors.clone()),
        coded: points.iter().map(|p| p.spec.coded.clone()).collect(),
        response: points.iter().map(|p| p.mean).collect(),
    }
}

/// Says in the stage's notes whether its responses enclose the lab value: a model fitted to
/// responses all on one side of it can only reach it by extrapolating. For a curve target
/// (minimised curve_mse), whether the runs' curves enclose the lab curve, as seed 000 checks
/// first (its Fig. 13).
pub(crate) fn bracket_note(study: &Study, st: &mut StageResult) {
    if study.target.minimised() {
        if let Some(note) = curve_bracket(study, st) {
            st.notes.push(note);
        }
        return;
    }
    let ys: Vec<f64> = st.successes().iter().map(|(_, y)| *y).collect();
    if ys.is_empty() {
        return;
    }
    let lo = ys.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = ys.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let lab = study.target.value;
    let span = format!("{} .. {}", sig(lo), sig(hi));
    st.notes.push(if lab < lo || lab > hi {
        format!(
            "bracket check: the runs' {} span {span} and do not enclose the lab value {} ({}): the model can only reach it by extrapolating; widen or move the ranges",
            study.target.response,
            sig(lab),
            if lab < lo { "below them all" } else { "above them all" }
        )
    } else {
        format!(
            "bracket check: the runs' {} span {span} and enclose the lab value {}",
            study.target.response,
            sig(lab)
        )
    });
}

pub(crate) fn enough(st: &StageResult, needed: usize, what: &str) -> Result<(), String> {
    // With replicates, design points count: each gives one mean to the model.
    let ok = st.point_means().len();
    if ok < needed {
        // Runs stored as done without a response (a store from elsewhere) do not count.
        let without = st.done() - ok;
        let advice = if st.failed_transiently() > 0 {
            "The machine failed them, not their parameters: fix what the failure names (a folder that cannot be written, a full disk, the cluster's limits), then run again; those runs are made again"
        } else {
            "Look at the failures, narrow the ranges or make the test more robust, then run again with --retry-failed"
        };
        return Err(format!(
            "{ok} of {} runs finished{} ({} failed{}); {what} needs at least {needed}. {advice}",
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
pub(crate) fn plateau_hint(study: &Study, e: String) -> String {
    if study.combine != Some(Combine::Desirability) {
        return e;
    }
    format!("{e} (a run with any target at or beyond its limits has undesirability 1: widen the targets' low and high, or combine = \"weighted\")")
}

pub(crate) fn with_failures(st: &StageResult, e: String) -> String {
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

pub(crate) fn point_label(d: &Design, run: &[f64]) -> String {
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

/// One model per target on the runs of `exp` (each run's target values in `values`): a full
/// quadratic after a response surface, a linear model after screening.
pub(crate) fn target_fits(
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

/// Points along the lab curve the curve bracket check looks at.
const BRACKET_POINTS: usize = 200;

/// Over how much of the lab curve's range the runs' (normalised) curves lie on both sides of it,
/// and where it lies above or below them all; None without a curve target or two curves.
fn curve_bracket(study: &Study, st: &StageResult) -> Option<String> {
    let lab = study.target.curve.as_ref()?.comparison().lab_normalised();
    let sims: Vec<Curve> = st
        .records
        .iter()
        .flatten()
        .filter(|r| r.status == Status::Done)
        .filter_map(|r| stored_curve(&r.outputs))
        .collect();
    if sims.len() < 2 {
        return None;
    }
    let (lo, hi) = lab.range();
    let (mut inside, mut seen) = (0usize, 0usize);
    let (mut above, mut below): (Vec<f64>, Vec<f64>) = (Vec::new(), Vec::new());
    for x in Curve::grid(lo, hi, BRACKET_POINTS) {
        // Only the runs whose curve reaches x (a run may stop early, once the specimen failed).
        let ys: Vec<f64> = sims
            .iter()
            .filter(|c| {
                let (a, b) = c.range();
                a <= x && x <= b
            })
            .map(|c| c.at(x))
            .collect();
        if ys.len() < 2 {
            continue;
        }
        seen += 1;
        let (min, max) = ys
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), y| {
                (a.min(*y), b.max(*y))
            });
        let y = lab.at(x);
        if y > max {
            above.push(x);
        } else if y < min {
            below.push(x);
        } else {
            inside += 1;
        }
    }
    if seen == 0 {
        return Some("bracket check: no two runs' curves cover the lab curve's range".into());
    }
    let (xname, _) = study
        .target
        .curve
        .as_ref()
        .map_or(("x", ""), |c| c.normalisation.x_axis());
    let stretch = |xs: &[f64], side: &str| -> Option<String> {
        let (a, b) = (xs.first()?, xs.last()?);
        Some(format!(
            "; it lies {side} them all over {:.0} % ({xname} {} .. {})",
            100.0 * xs.len() as f64 / seen as f64,
            sig(*a),
            sig(*b)
        ))
    };
    Some(format!(
        "bracket check: the {} runs' curves enclose the lab curve over {:.0} % of its range{}{}{}",
        sims.len(),
        100.0 * inside as f64 / seen as f64,
        stretch(&above, "above").unwrap_or_default(),
        stretch(&below, "below").unwrap_or_default(),
        if inside < seen {
            ": the best curve reachable in these ranges misses the lab's there; widen or move the ranges"
        } else {
            ""
        }
    ))
}
