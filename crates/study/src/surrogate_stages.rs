//! What the surrogate stages (`stage::bayesopt`, `stage::ga_bp`, `stage::smc`) share: their
//! outcomes for the report and the summary, the objective, and how their runs are made.
//!
//! The objective a surrogate stage works on is the relative error |sim - lab| / |lab| for a
//! matched response, or the response itself for a minimised one (a curve MSE).

use surrogate::smc::Posterior;

use crate::record::{run_seed, Context, RunSpec, StageResult};
pub use crate::record::{BoOutcome, GaBpOutcome, SmcOutcome, SmcRound, SurrogateOutcome};
use crate::spec::{Combine, Study};
use crate::text::tidy;

/// The objective a surrogate minimises for a response `y`.
pub fn objective(study: &Study, y: f64) -> f64 {
    if study.target.minimised() {
        y
    } else {
        (y - study.target.value).abs() / study.target.value.abs()
    }
}

pub(crate) fn push_runs(
    study: &Study,
    st: &mut StageResult,
    ctx: &Context,
    coded: &[Vec<f64>],
    label: &str,
) {
    for c in coded {
        let index = st.runs.len();
        let mut values = ctx.values.clone();
        for (j, &pi) in st.active.iter().enumerate() {
            values[pi] = tidy(st.factors[j].to_actual(c[j]));
        }
        // The coded point that is stored is the one the tidied values give back, so that a
        // replay's GP sees the same numbers whether or not the run was just made.
        let coded = st
            .factors
            .iter()
            .zip(&st.active)
            .map(|(f, &pi)| f.to_coded(values[pi]))
            .collect();
        st.runs.push(RunSpec {
            stage: st.index,
            stage_kind: st.kind,
            index,
            point: index,
            label: format!("{label}, run {}", index + 1),
            coded,
            values,
            seed: run_seed(study.seed, st.index, index),
        });
    }
}

pub(crate) fn empty_posterior() -> Posterior {
    Posterior {
        mean: Vec::new(),
        std: Vec::new(),
        credible: Vec::new(),
        ess: f64::NAN,
        sigma: f64::NAN,
    }
}

/// Finished runs with a response: coded point, objective.
pub(crate) fn finished(study: &Study, st: &StageResult) -> (Vec<usize>, Vec<Vec<f64>>, Vec<f64>) {
    let mut idx = Vec::new();
    let mut x = Vec::new();
    let mut y = Vec::new();
    for (i, (s, r)) in st.runs.iter().zip(&st.records).enumerate() {
        if let Some(v) = r
            .as_ref()
            .filter(|r| r.status == crate::store::Status::Done)
            .and_then(|r| r.response)
            .filter(|v| v.is_finite())
        {
            idx.push(i);
            x.push(s.coded.clone());
            y.push(objective(study, v));
        }
    }
    (idx, x, y)
}

/// A run's misfit for the likelihood: the squared error in units of the lab's spread (the
/// replicates' standard deviation, or the lab value itself when there are fewer than two), the
/// minimised response itself, or for several targets the weighted mean square of their relative
/// errors.
pub fn misfit(study: &Study, y: f64) -> f64 {
    if study.combine == Some(Combine::Weighted) {
        // The weighted mean square of the relative errors, as a sum of squares is.
        (y / 100.0).powi(2)
    } else if study.target.minimised() {
        y
    } else {
        let s = study
            .target
            .std()
            .filter(|s| *s > 0.0)
            .unwrap_or(study.target.value.abs());
        ((y - study.target.value) / s).powi(2)
    }
}

/// A surrogate stage's calibrated point, passed on to the stages after it.
pub(crate) fn calibrate(st: &mut StageResult, ctx: &mut Context, point: Vec<f64>) {
    ctx.calibrated = Some(point.clone());
    ctx.chosen_solution = 0;
    st.calibrated = Some(point);
}
