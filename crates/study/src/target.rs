//! What a study calibrates against: one lab target, or several (scalars and curves of one or more
//! tests) combined into one objective.
//!
//! A study with several targets is calibrated against a single number per run, so that every
//! stage (screening, steepest path, response surface, Bayesian optimisation, GA-BP, SMC) works on
//! it unchanged; the optimise stage of a desirability study also models each response on its own,
//! as Design-Expert's numerical optimisation does. Two combinations:
//!
//! - `weighted`: the weighted root mean square of the targets' relative errors, in %
//!   (`combined_error_percent`). A curve target's relative error is the root of its curve MSE
//!   over the mean square of the lab curve, so a curve and a scalar weigh alike.
//! - `desirability`: Derringer-Suich. Each target's desirability is 1 at the lab value and falls
//!   linearly to 0 at its limits (`low`, `high`; by default the lab value ± 50 %); the overall
//!   desirability is their geometric mean weighted by importance (1 to 5). The study minimises
//!   `undesirability` = 1 - D.

use std::path::Path;

use doe::optimize::{Criterion, Goal};
use serde::{Deserialize, Serialize};

use crate::curve::CURVE_RESPONSES;
use crate::file::TargetEntry;
use crate::file::{CombineName, ObjectiveEntry};
use crate::file::{Number, Whole};
use crate::lab_curve::CurveTarget;

/// The lab value (or curve) a test's response is compared with.
#[derive(Clone, Debug)]
pub struct Target {
    /// The key of the test's outcome compared with the lab (e.g. `angle_of_repose_deg`).
    pub response: String,
    pub value: f64,
    pub replicates: Vec<f64>,
    pub unit: String,
    /// The lab curves the test's curve is compared with, when the target has a curve.
    pub curve: Option<CurveTarget>,
    /// The study's test (index) the response comes from.
    pub test: usize,
    /// Whether the response is minimised (a curve MSE, a combined objective) rather than matched.
    pub minimised: bool,
    /// Weight in a weighted objective.
    pub weight: f64,
    /// Importance (1 to 5) in a desirability.
    pub importance: u8,
    /// Desirability limits (see [`Term`]).
    pub low: f64,
    pub high: f64,
    /// The lab curve's mean square (1 without a curve).
    pub curve_scale: f64,
}

impl Target {
    /// Whether the response is minimised rather than matched: a curve MSE, or a combined
    /// objective, whose target is 0.
    pub fn minimised(&self) -> bool {
        self.minimised
    }

    /// What a run needs of the target to score itself.
    pub fn term(&self) -> Term {
        Term {
            test: self.test,
            response: self.response.clone(),
            lab: self.value,
            minimised: self.minimised,
            weight: self.weight,
            importance: self.importance,
            low: self.low,
            high: self.high,
            curve_scale: self.curve_scale,
        }
    }

    /// |sim - lab| / lab in %; none for a minimised response (a relative error of a target of
    /// 0 means nothing: the response itself says how far off the run is).
    pub fn relative_error_percent(&self, simulated: f64) -> Option<f64> {
        (!self.minimised()).then(|| 100.0 * (simulated - self.value).abs() / self.value.abs())
    }

    /// How far a simulated response is from the lab, in words: the relative error, or the
    /// minimised response itself.
    pub fn misfit(&self, simulated: f64) -> String {
        match self.relative_error_percent(simulated) {
            Some(e) => format!("relative error {e:.2} %"),
            None => format!("{} {}", self.response, doe::fit::fmt_sig(simulated)),
        }
    }

    /// A model's prediction of the response, as a report gives it: a minimised response (a curve
    /// MSE, a combined error or undesirability) is never negative, so a prediction below 0 is
    /// read as 0 ([`non_negative`]).
    pub fn predicted(&self, model: f64) -> f64 {
        if self.minimised {
            non_negative(model)
        } else {
            model
        }
    }

    /// Standard deviation of the replicates, when there are two or more.
    pub fn std(&self) -> Option<f64> {
        let n = self.replicates.len();
        (n >= 2).then(|| {
            let m = self.replicates.iter().sum::<f64>() / n as f64;
            (self.replicates.iter().map(|v| (v - m).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt()
        })
    }

    /// The target a study with several targets calibrates against: their combination, minimised.
    pub fn combined(combine: Combine) -> Target {
        Target {
            response: combine.response().to_string(),
            value: 0.0,
            replicates: Vec::new(),
            unit: combine.unit().to_string(),
            curve: None,
            test: 0,
            minimised: true,
            weight: 1.0,
            importance: 3,
            low: 0.0,
            high: 1.0,
            curve_scale: 1.0,
        }
    }
}

/// A model's prediction of something never negative (a relative error, a curve MSE, a combined
/// error or undesirability): a smooth model of values that reach down to 0 dips below it near
/// their least value, or carries their fall past it at an edge of the ranges, and such a
/// prediction is read as 0. A search still minimises the model as it is, so that its answer is
/// where the model is lowest rather than any point of the plateau the clamp would make.
pub fn non_negative(model: f64) -> f64 {
    // NaN stays NaN: a failed prediction is not a perfect one.
    if model < 0.0 {
        0.0
    } else {
        model
    }
}

/// How several targets make one objective.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Combine {
    Weighted,
    Desirability,
}

impl Combine {
    /// The name of the combined response each run stores.
    pub fn response(self) -> &'static str {
        match self {
            Combine::Weighted => "combined_error_percent",
            Combine::Desirability => "undesirability",
        }
    }

    pub fn unit(self) -> &'static str {
        match self {
            Combine::Weighted => "%",
            Combine::Desirability => "",
        }
    }

    pub fn describe(self) -> &'static str {
        match self {
            Combine::Weighted => "the weighted root mean square of the targets' relative errors (%)",
            Combine::Desirability => {
                "1 - D, D the importance-weighted geometric mean of the targets' Derringer-Suich desirabilities"
            }
        }
    }

    /// The objective of one run from each term's simulated response.
    pub fn combine(self, terms: &[Term], ys: &[f64]) -> f64 {
        match self {
            Combine::Weighted => {
                let w: f64 = terms.iter().map(|t| t.weight).sum();
                let s: f64 = terms
                    .iter()
                    .zip(ys)
                    .map(|(t, y)| t.weight * t.relative_error(*y).powi(2))
                    .sum();
                100.0 * (s / w).sqrt()
            }
            Combine::Desirability => {
                let imp: f64 = terms.iter().map(|t| t.importance as f64).sum();
                let mut log = 0.0;
                for (t, y) in terms.iter().zip(ys) {
                    let d = t.desirability(*y);
                    if d <= 0.0 {
                        return 1.0;
                    }
                    log += t.importance as f64 * d.ln();
                }
                1.0 - (log / imp).exp()
            }
        }
    }
}

/// What a run needs of a target to score itself: carried by each job of a study with several
/// targets.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Term {
    /// The study's test (index) the response comes from.
    pub test: usize,
    pub response: String,
    /// The lab value (0 for a minimised curve MSE).
    pub lab: f64,
    pub minimised: bool,
    /// Weight in a weighted objective.
    pub weight: f64,
    /// Importance (1 to 5) in a desirability.
    pub importance: u8,
    /// Desirability limits: 0 at and beyond them, 1 at the lab value (at `low` for a minimised
    /// response).
    pub low: f64,
    pub high: f64,
    /// The lab curve's mean square, which a curve MSE is divided by to make it relative.
    pub curve_scale: f64,
}

impl Term {
    /// The relative error as a fraction: |y - lab| / |lab|, or for a curve MSE the root of it
    /// over the lab curve's mean square.
    pub fn relative_error(&self, y: f64) -> f64 {
        if self.minimised {
            (y.max(0.0) / self.curve_scale).sqrt()
        } else {
            (y - self.lab).abs() / self.lab.abs()
        }
    }

    /// The Derringer-Suich criterion of the target, as Design-Expert states it.
    pub fn criterion(&self) -> Criterion {
        Criterion {
            name: self.response.clone(),
            goal: if self.minimised {
                Goal::Minimize
            } else {
                Goal::Target(self.lab)
            },
            lower: self.low,
            upper: self.high,
            weight_lower: 1.0,
            weight_upper: 1.0,
            importance: self.importance,
        }
    }

    pub fn desirability(&self, y: f64) -> f64 {
        self.criterion().desirability(y)
    }
}

/// Reads `[objective]`: how several targets are combined.
pub fn parse_objective(
    objective: Option<&toml::Value>,
    err: &dyn Fn(&str, String) -> String,
) -> Result<Option<Combine>, String> {
    let Some(v) = objective else {
        return Ok(None);
    };
    let entry: ObjectiveEntry =
        crate::file::read("objective", v.clone()).map_err(|(k, m)| err(&k, m))?;
    match entry.combine {
        Some(CombineName::Weighted) => Ok(Some(Combine::Weighted)),
        Some(CombineName::Desirability) => Ok(Some(Combine::Desirability)),
        None => Err(err(
            "objective.combine",
            "missing (expected \"weighted\" or \"desirability\")".into(),
        )),
    }
}

/// A test as targets see it: its name in the study and what it can give.
pub struct TestOutputs<'a> {
    pub name: &'a str,
    pub kind: &'a str,
    pub outputs: &'a [&'static str],
}

/// Reads one target table, `key` (`target` or `target[i]`). `combine` is how the study combines
/// its targets (None for a single target); `dir` is where lab curve files are taken from.
pub fn parse_target(
    t: &TargetEntry,
    key: &str,
    tests: &[TestOutputs],
    combine: Option<Combine>,
    dir: &Path,
    err: &dyn Fn(&str, String) -> String,
) -> Result<Target, String> {
    let only = |k: &str, with: Option<Combine>, what: &str| -> Result<(), String> {
        if t.given(k) && combine != with {
            return Err(err(&format!("{key}.{k}"), what.into()));
        }
        Ok(())
    };
    let (weighted, desirability) = match combine {
        None => (
            "only in a study of several targets (it weighs targets against each other)",
            "only in a study of several targets (it weighs targets against each other)",
        ),
        Some(_) => (
            "only with [objective] combine = \"weighted\" (a desirability weighs targets by importance)",
            "only with [objective] combine = \"desirability\"",
        ),
    };
    only("weight", Some(Combine::Weighted), weighted)?;
    for k in ["importance", "low", "high"] {
        only(k, Some(Combine::Desirability), desirability)?;
    }
    let test = match &t.test {
        None if tests.len() == 1 => 0,
        None => {
            return Err(err(
                &format!("{key}.test"),
                format!(
                    "missing: the study has {} tests, name the one this target is measured in ({})",
                    tests.len(),
                    names(tests)
                ),
            ))
        }
        Some(s) => tests.iter().position(|x| x.name == s).ok_or_else(|| {
            err(
                &format!("{key}.test"),
                format!(
                    "\"{s}\" is not a test of the study (expected {})",
                    names(tests)
                ),
            )
        })?,
    };
    let TestOutputs { kind, outputs, .. } = tests[test];
    // The curve keys' errors name this target's key.
    let curve_err = |k: &str, m: String| err(&k.replacen("target", key, 1), m);
    let curve = CurveTarget::parse(t, dir, &curve_err)?;
    if let Some(c) = &curve {
        if !outputs.contains(&c.curve.as_str()) {
            return Err(err(
                &format!("{key}.curve"),
                format!(
                    "\"{}\" is not a response of {kind} (expected one of: {})",
                    c.curve,
                    outputs.join(", ")
                ),
            ));
        }
    }
    let response = match &t.response {
        None if curve.is_some() => "curve_mse".to_string(),
        None => outputs
            .first()
            .ok_or_else(|| {
                err(
                    &format!("{key}.response"),
                    format!("{kind} has no outcome to calibrate against"),
                )
            })?
            .to_string(),
        Some(r) if outputs.contains(&r.as_str()) => r.clone(),
        Some(r) if curve.is_some() && CURVE_RESPONSES.contains(&r.as_str()) => r.clone(),
        Some(r) if CURVE_RESPONSES.contains(&r.as_str()) => {
            return Err(err(
                &format!("{key}.response"),
                format!("{r} compares the test's curve with the lab's: give {key}.curve, {key}.lab_curves and {key}.normalisation"),
            ))
        }
        Some(r) => {
            let mut expected = outputs.to_vec();
            if curve.is_some() {
                expected.extend(CURVE_RESPONSES);
            }
            return Err(err(
                &format!("{key}.response"),
                format!(
                    "\"{r}\" is not an outcome of {kind} (expected one of: {})",
                    expected.join(", ")
                ),
            ));
        }
    };
    let minimised = response == "curve_mse";
    if minimised {
        if let Some(k) = ["value", "replicates"].iter().find(|k| t.given(k)) {
            return Err(err(
                &format!("{key}.{k}"),
                "curve_mse is minimised (its target is 0): give no value".into(),
            ));
        }
    }
    let replicates: Vec<f64> = match (&t.replicates, &curve) {
        (None, Some(c)) if CURVE_RESPONSES.contains(&response.as_str()) => {
            c.replicate_measures(&response)
        }
        (None, _) => Vec::new(),
        (Some(a), _) => a
            .iter()
            .map(|&Number(v)| v.is_finite().then_some(v))
            .collect::<Option<Vec<_>>>()
            .ok_or_else(|| {
                err(
                    &format!("{key}.replicates"),
                    "expected a list of finite numbers".into(),
                )
            })?,
    };
    let value = match t.value {
        None if minimised => 0.0,
        Some(Number(v)) => v,
        None if !replicates.is_empty() => replicates.iter().sum::<f64>() / replicates.len() as f64,
        None if curve.is_some() && CURVE_RESPONSES.contains(&response.as_str()) => {
            return Err(err(
                &format!("{key}.value"),
                format!("missing: the lab curves give no {response} (their peak is at the start); give the lab value"),
            ))
        }
        None => {
            return Err(err(
                &format!("{key}.value"),
                "missing: give the lab value or its replicates".into(),
            ))
        }
    };
    // Subnormal values too: a relative error divided by 1e-320 is infinite.
    if !minimised && !value.is_normal() {
        return Err(err(
            &format!("{key}.value"),
            format!("expected a non-zero number, at least 1e-300 in size (relative errors divide by it), got {value}"),
        ));
    }
    if t.value.is_some() && t.replicates.is_some() && !replicates.is_empty() {
        let lo = replicates.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = replicates.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        if !(lo..=hi).contains(&value) {
            return Err(err(
                &format!("{key}.value"),
                format!("{value} lies outside its replicates ({lo} .. {hi}), so it cannot be their mean: give the replicates alone, or the value that belongs to them"),
            ));
        }
    }
    let unit = match (&t.unit, &curve) {
        (Some(u), _) => u.clone(),
        (None, Some(c)) => c.normalisation.unit_of(&response),
        (None, None) => String::new(),
    };
    let term = parse_term(t, key, test, &response, value, curve.as_ref(), err)?;
    Ok(Target {
        response,
        value,
        replicates,
        unit,
        curve,
        test,
        minimised: term.minimised,
        weight: term.weight,
        importance: term.importance,
        low: term.low,
        high: term.high,
        curve_scale: term.curve_scale,
    })
}

/// The weight, importance and limits of a target.
fn parse_term(
    t: &TargetEntry,
    key: &str,
    test: usize,
    response: &str,
    value: f64,
    curve: Option<&CurveTarget>,
    err: &dyn Fn(&str, String) -> String,
) -> Result<Term, String> {
    let minimised = response == "curve_mse";
    let curve_scale = match curve {
        Some(c) if minimised => {
            let lab = c.comparison().lab_normalised();
            let ms = lab.y.iter().map(|y| y * y).sum::<f64>() / lab.y.len() as f64;
            if ms > 0.0 && ms.is_finite() {
                ms
            } else {
                return Err(err(
                    &format!("{key}.lab_curves"),
                    "the lab curve is zero everywhere: a curve MSE cannot be made relative to it"
                        .into(),
                ));
            }
        }
        _ => 1.0,
    };
    let weight = match t.weight {
        None => 1.0,
        Some(Number(w)) if w > 0.0 && w.is_finite() => w,
        Some(_) => {
            return Err(err(
                &format!("{key}.weight"),
                "expected a number > 0".into(),
            ))
        }
    };
    let importance = match t.importance {
        None => 3,
        Some(Whole(i)) if (1..=5).contains(&i) => i as u8,
        Some(_) => {
            return Err(err(
                &format!("{key}.importance"),
                "expected a whole number from 1 to 5 (Design-Expert's + to +++++)".into(),
            ))
        }
    };
    let limit = |k: &str, v: Option<Number>| -> Result<Option<f64>, String> {
        v.map(|Number(x)| {
            x.is_finite()
                .then_some(x)
                .ok_or_else(|| err(&format!("{key}.{k}"), "expected a finite number".into()))
        })
        .transpose()
    };
    // By default a target is worth nothing 50 % away from the lab value; a curve when its
    // relative error reaches 50 %.
    let (low, high) = if minimised {
        (0.0, limit("high", t.high)?.unwrap_or(0.25 * curve_scale))
    } else {
        let half = 0.5 * value.abs();
        (
            limit("low", t.low)?.unwrap_or(value - half),
            limit("high", t.high)?.unwrap_or(value + half),
        )
    };
    if minimised && t.given("low") {
        return Err(err(
            &format!("{key}.low"),
            "a curve MSE is best at 0: give only high, the MSE at which it is worth nothing".into(),
        ));
    }
    // `limit` refuses NaN, so plain comparisons say what they mean.
    if minimised && high <= 0.0 {
        return Err(err(
            &format!("{key}.high"),
            format!("expected a curve MSE > 0 at which the target is worth nothing, got {high}"),
        ));
    }
    let inside = low < value && value < high;
    if !minimised && !inside {
        let bad = if low < value { "high" } else { "low" };
        return Err(err(
            &format!("{key}.{bad}"),
            format!(
                "expected low < lab value < high, got low = {low}, lab value = {value}, high = {high}"
            ),
        ));
    }
    Ok(Term {
        test,
        response: response.to_string(),
        lab: value,
        minimised,
        weight,
        importance,
        low,
        high,
        curve_scale,
    })
}

fn names(tests: &[TestOutputs]) -> String {
    tests.iter().map(|t| t.name).collect::<Vec<_>>().join(", ")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn term(lab: f64) -> Term {
        Term {
            test: 0,
            response: "r".into(),
            lab,
            minimised: false,
            weight: 1.0,
            importance: 3,
            low: 0.5 * lab,
            high: 1.5 * lab,
            curve_scale: 1.0,
        }
    }

    #[test]
    fn weighted_objective_is_the_weighted_rms_of_relative_errors() {
        let mut a = term(10.0);
        let b = term(2.0);
        a.weight = 3.0;
        // a is 10 % off, b 50 % off: sqrt((3 * 0.01 + 1 * 0.25) / 4) = sqrt(0.07).
        let y = Combine::Weighted.combine(&[a, b], &[11.0, 1.0]);
        assert!((y - 100.0 * 0.07f64.sqrt()).abs() < 1e-12, "{y}");
    }

    #[test]
    fn desirability_is_the_importance_weighted_geometric_mean() {
        let mut a = term(10.0);
        let b = term(2.0);
        a.importance = 5;
        // a: 1 - 1/5 = 0.8; b: 1 - 0.25/1 = 0.75; D = (0.8^5 0.75^3)^(1/8).
        let y = Combine::Desirability.combine(&[a.clone(), b.clone()], &[11.0, 2.25]);
        let d = (0.8f64.powi(5) * 0.75f64.powi(3)).powf(1.0 / 8.0);
        assert!((y - (1.0 - d)).abs() < 1e-12, "{y} against {}", 1.0 - d);
        // Beyond a limit the whole point is worth nothing.
        assert_eq!(Combine::Desirability.combine(&[a, b], &[16.0, 2.0]), 1.0);
    }

    #[test]
    fn a_minimised_response_is_never_predicted_below_zero() {
        let mut t = Target::combined(Combine::Weighted);
        assert_eq!(t.predicted(-0.15), 0.0);
        assert_eq!(t.predicted(2.5), 2.5);
        assert!(t.predicted(f64::NAN).is_nan());
        // A matched response may be negative (a displacement, a signed force).
        t.minimised = false;
        assert_eq!(t.predicted(-0.15), -0.15);
    }

    #[test]
    fn a_curve_mse_is_relative_to_the_lab_curve() {
        let t = Term {
            minimised: true,
            lab: 0.0,
            low: 0.0,
            high: 0.25 * 4.0,
            curve_scale: 4.0,
            ..term(1.0)
        };
        // MSE 0.04 against a lab mean square of 4: relative error 0.1.
        assert!((t.relative_error(0.04) - 0.1).abs() < 1e-12);
        assert!((t.desirability(0.5) - 0.5).abs() < 1e-12);
    }
}
