//! `sweep`: one parameter over given values, each run `repeats` times; a line or parabola fitted
//! to every run's response; and its inversion at the lab value, with a standard error and a 95 %
//! interval. Seed 004 calibrates kernel-steel rolling friction this way: 0.18 to 0.24 by 0.01,
//! ten repeats each, a quadratic fit of the sliding distance, inverted at the lab's 97 mm.
//!
//! The interval is the delta method's for an inverse prediction: the variance of the fitted
//! mean at the inverted value (the model's) plus the variance of the lab mean (its replicates'
//! SD² / n), over the squared slope there, with t at the fit's residual degrees of freedom.
//! The swept parameter is then held at its inverted value by the stages after it.

use std::any::Any;
use std::fmt::Write;
use std::sync::Arc;

use doe::{Curvature, Experiment, Factor, Fit, ModelOrder};
use plotters::prelude::*;

use crate::spec::{Section, Stage};
use crate::stage::table::{StageDef, StageTable};
use crate::design_stages::{bracket_note, with_failures};
use crate::paths::number;
use crate::limits::MAX_REPLICATES;
use crate::text::esc;
use crate::report_figures::{mean_sd, response_label};
use crate::spec::Study;
use crate::record::{Context, run_seed, RunSpec, StageResult};
use crate::text::{sig, tidy};

/// Most values a sweep may take.
pub const MAX_SWEEP_VALUES: usize = 1000;

#[derive(Clone, Debug, PartialEq)]
pub struct Sweep {
    /// The swept parameter (index into the study's).
    pub parameter: usize,
    pub values: Vec<f64>,
    pub repeats: usize,
    /// Quadratic (a parabola, as seed 004 fits) or linear.
    pub quadratic: bool,
}

/// What a sweep found.
#[derive(Clone, Debug)]
pub struct SweepOutcome {
    /// The fit on the swept parameter coded over the swept values.
    pub fit: Fit,
    pub factor: Factor,
    /// The parameter's value where the fitted curve meets the lab value, with its uncertainty;
    /// None when it does not within the swept values.
    pub inversion: Option<Inversion>,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Inversion {
    pub value: f64,
    /// Standard error of the value, in the parameter's units.
    pub std_error: f64,
    /// 95 % interval of the value.
    pub low: f64,
    pub high: f64,
    /// The fit's slope there, response per parameter unit.
    pub slope: f64,
    /// Residual degrees of freedom of the t quantile.
    pub df: usize,
}

impl StageDef for Sweep {
    const NAME: &'static str = "sweep";
    const KEYS: &'static [&'static str] =
        &["parameter", "values", "from", "to", "step", "repeats", "model"];

    fn parse(t: &StageTable) -> Result<Self, String> {
        let name = match t.get("parameter") {
            Some(toml::Value::String(s)) => s.clone(),
            Some(_) => return Err(t.fail("parameter", "expected a parameter's name")),
            None => {
                return Err(t.fail(
                    "parameter",
                    "missing: which parameter the sweep varies (parameter = \"name\")",
                ))
            }
        };
        let (parameter, min, max) = t.parameter("parameter", &name)?;
        let values = match (t.get("values"), t.get("from")) {
            (Some(_), Some(_)) => {
                return Err(t.fail("from", "give either values = [...] or from, to and step, not both"))
            }
            (Some(v), None) => {
                for k in ["to", "step"] {
                    if t.get(k).is_some() {
                        return Err(t.fail(k, "give either values = [...] or from, to and step, not both"));
                    }
                }
                StageTable::numbers(v)
                    .filter(|v| !v.is_empty() && v.len() <= MAX_SWEEP_VALUES)
                    .ok_or_else(|| {
                        t.fail(
                            "values",
                            format!("expected a list of 1 to {MAX_SWEEP_VALUES} finite numbers in the parameter's units"),
                        )
                    })?
            }
            (None, Some(_)) => {
                let get = |k: &str| {
                    t.get(k)
                        .and_then(number)
                        .filter(|x| x.is_finite())
                        .ok_or_else(|| t.fail(k, "expected a finite number in the parameter's units"))
                };
                let (from, to, step) = (get("from")?, get("to")?, get("step")?);
                if step <= 0.0 || to <= from {
                    return Err(t.fail("step", "expected step > 0 and to > from"));
                }
                // Rounding: 0.18 to 0.24 by 0.01 is 7 values, not 6. Counted in floating point
                // and checked before the cast: a step of 1e-300 would overflow a count.
                let steps = ((to - from) / step + 1e-9).floor();
                if steps.is_nan() || steps >= MAX_SWEEP_VALUES as f64 {
                    return Err(t.fail(
                        "step",
                        format!(
                            "{:e} values from {from} to {to}; at most {MAX_SWEEP_VALUES}",
                            steps + 1.0
                        ),
                    ));
                }
                let n = steps as usize + 1;
                (0..n).map(|i| tidy(from + i as f64 * step)).collect()
            }
            (None, None) => {
                return Err(t.fail(
                    "values",
                    "missing: the values to sweep (values = [...], or from, to and step)",
                ))
            }
        };
        for v in &values {
            if *v < min || *v > max {
                return Err(t.fail(
                    "values",
                    format!("{v} is outside the parameter's range {min} .. {max}"),
                ));
            }
        }
        let mut distinct = values.clone();
        distinct.sort_by(f64::total_cmp);
        distinct.dedup();
        let quadratic = match t.text("model", "linear")?.as_str() {
            "linear" => false,
            "quadratic" => true,
            _ => return Err(t.fail("model", "expected \"linear\" or \"quadratic\"")),
        };
        let needed = if quadratic { 3 } else { 2 };
        if distinct.len() < needed {
            return Err(t.fail(
                "values",
                format!(
                    "{} distinct value(s); a {} fit needs at least {needed}",
                    distinct.len(),
                    if quadratic { "quadratic" } else { "linear" }
                ),
            ));
        }
        Ok(Sweep {
            parameter,
            values,
            repeats: t.count("repeats", 3, 1, Some(MAX_REPLICATES))?,
            quadratic,
        })
    }
}

impl Stage for Sweep {
    fn kind(&self) -> &'static str {
        Self::NAME
    }

    fn heading(&self) -> &'static str {
        "sweep and inversion"
    }

    fn follows(&self, _before: &[Arc<dyn Stage>]) -> Result<(), String> {
        Ok(())
    }

    fn plan(&self, study: &Study, st: &mut StageResult, ctx: &Context) -> Result<(), String> {
        let pi = self.parameter;
        let p = &study.parameters[pi];
        let lo = self.values.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = self.values.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        st.active = vec![pi];
        st.factors = vec![p.factor(lo, hi)?];
        st.title = format!(
            "{} swept over {} values ({} .. {}), {} run(s) each, {} fit inverted at the lab value",
            p.name,
            self.values.len(),
            sig(lo),
            sig(hi),
            self.repeats,
            if self.quadratic { "quadratic" } else { "linear" }
        );
        for (point, &v) in self.values.iter().enumerate() {
            let mut values = ctx.values.clone();
            values[pi] = v;
            for r in 0..self.repeats {
                let index = point * self.repeats + r;
                st.runs.push(RunSpec {
                    stage: st.index,
                    stage_kind: st.kind,
                    index,
                    point,
                    label: format!("{} = {} repeat {}", p.name, sig(v), r + 1),
                    coded: vec![st.factors[0].to_coded(v)],
                    values: values.clone(),
                    seed: run_seed(study.seed, st.index, index),
                });
            }
        }
        Ok(())
    }

    fn conclude(
        &self,
        study: &Study,
        st: &mut StageResult,
        ctx: &mut Context,
    ) -> Result<(), String> {
        let pi = self.parameter;
        let factor = st.factors[0].clone();
        let ok = st.successes();
        let order = if self.quadratic {
            ModelOrder::Quadratic
        } else {
            ModelOrder::Linear
        };
        let terms = order.terms(1);
        let exp = Experiment {
            response_name: study.target.response.clone(),
            factor_names: vec![factor.name.clone()],
            factors: Some(vec![factor.clone()]),
            coded: ok.iter().map(|(s, _)| s.coded.clone()).collect(),
            response: ok.iter().map(|(_, y)| *y).collect(),
        };
        if exp.response.len() < terms.len() + 1 {
            return Err(format!(
                "{} of {} runs gave a response{}; the fit needs at least {}",
                exp.response.len(),
                st.runs.len(),
                st.first_failure(),
                terms.len() + 1
            ));
        }
        let fit = Fit::new(&exp, &terms, Curvature::Off).map_err(|e| with_failures(st, e))?;
        bracket_note(study, st);
        let inversion = invert(study, &fit, &factor);
        match &inversion {
            Some(inv) => {
                st.notes.push(format!(
                    "{} = {} ± {} (standard error; 95 % interval {} .. {}) where the fitted curve meets the lab value {}; R² {:.4}",
                    factor.name,
                    sig(inv.value),
                    sig(inv.std_error),
                    sig(inv.low),
                    sig(inv.high),
                    sig(study.target.value),
                    fit.r2
                ));
                st.uncertainty = Some(crate::uncertainty_routes::from_sweep(
                    pi,
                    &factor,
                    inv.value,
                    (inv.low, inv.high),
                ));
                ctx.values[pi] = tidy(inv.value);
                ctx.active.retain(|&a| a != pi);
                let point = ctx.values.clone();
                ctx.calibrated = Some(point.clone());
                ctx.candidates.clear();
                ctx.candidate_uncertainties.clear();
                ctx.chosen_solution = 0;
                st.calibrated = Some(point);
            }
            None => {
                return Err(format!(
                    "the fitted curve does not reach the lab value {} between {} and {}: sweep other values",
                    sig(study.target.value),
                    sig(factor.low),
                    sig(factor.high)
                ))
            }
        }
        st.fit = Some(fit.clone());
        st.set_outcome(SweepOutcome {
            fit,
            factor,
            inversion,
        });
        Ok(())
    }

    fn summary(&self, study: &Study, st: &StageResult) -> Option<serde_json::Value> {
        let out = st.outcome::<SweepOutcome>()?;
        let inv = out.inversion.as_ref()?;
        Some(serde_json::json!({
            "parameter": study.parameters[self.parameter].name,
            "value": inv.value,
            "std_error": inv.std_error,
            "interval_95": [inv.low, inv.high],
            "slope": inv.slope,
            "df": inv.df,
            "r2": out.fit.r2,
        }))
    }

    fn report(&self, s: &mut Section<'_>) {
        let Some(out) = s.st.outcome::<SweepOutcome>() else {
            return;
        };
        let unit = &s.study.target.unit;
        s.h.push_str("<table><tr><th>value</th><th>runs</th><th>mean ± SD</th></tr>");
        for p in s.st.point_means() {
            let v = p.spec.values[self.parameter];
            write!(
                s.h,
                "<tr><td>{}</td><td>{}</td><td>{}</td></tr>",
                sig(v),
                p.runs,
                p.std.map_or(sig(p.mean), |sd| mean_sd(p.mean, sd))
            )
            .unwrap();
        }
        s.h.push_str("</table>");
        if let Some(eq) = out.fit.actual_equation() {
            let text: Vec<String> = eq
                .iter()
                .map(|(t, c)| {
                    let name = t.name(std::slice::from_ref(&out.factor.name));
                    if name.is_empty() || name == "Intercept" {
                        sig(*c)
                    } else {
                        format!("{} × {}", sig(*c), name)
                    }
                })
                .collect();
            write!(
                s.h,
                "<p>Fitted to every run: {} = {} (R² {:.4}).</p>",
                esc(&s.study.target.response),
                esc(&text.join(" + ").replace("+ -", "− ")),
                out.fit.r2
            )
            .unwrap();
        }
        if let Some(inv) = &out.inversion {
            write!(
                s.h,
                "<p>Inverted at the lab value {} {}: <b>{} = {} ± {}</b> (standard error), 95 % interval {} to {} (slope there {} {} per unit, t at {} residual degrees of freedom).</p>",
                sig(s.study.target.value),
                esc(unit),
                esc(&out.factor.name),
                sig(inv.value),
                sig(inv.std_error),
                sig(inv.low),
                sig(inv.high),
                sig(inv.slope),
                esc(unit),
                inv.df
            )
            .unwrap();
        }
        let stage = s.st.index + 1;
        s.figs.row(
            s.h,
            vec![(
                format!("stage{stage}-sweep"),
                sweep_plot(s.study, s.st, out),
                format!(
                    "Sweep (stage {stage}): {} of every run against {}, the fitted curve, the lab value, and the inverted value with its 95 % interval.",
                    esc(&response_label(s.study)),
                    esc(&out.factor.name)
                ),
            )],
        );
    }

    fn as_any(&self) -> &dyn Any {
        self
    }
}

/// Where the fit meets the lab value within the swept values (coded −1 .. +1), with the delta
/// method's standard error; the root nearest the middle when a parabola meets it twice.
fn invert(study: &Study, fit: &Fit, factor: &Factor) -> Option<Inversion> {
    let c = |i: usize| fit.coefficients.get(i).map_or(0.0, |c| c.estimate);
    let (b0, b1, b2) = (c(0), c(1), c(2));
    let y = study.target.value;
    let roots: Vec<f64> = if b2 == 0.0 {
        (b1 != 0.0).then(|| (y - b0) / b1).into_iter().collect()
    } else {
        let d = b1 * b1 - 4.0 * b2 * (b0 - y);
        if d < 0.0 {
            Vec::new()
        } else {
            // The numerically stable pair of roots.
            let sign = if b1 >= 0.0 { 1.0 } else { -1.0 };
            let q = -0.5 * (b1 + sign * d.sqrt());
            let mut r = vec![q / b2];
            if q != 0.0 {
                r.push((b0 - y) / q);
            }
            r
        }
    };
    let x = roots
        .into_iter()
        .filter(|x| x.is_finite() && x.abs() <= 1.0 + 1e-9)
        .min_by(|a, b| a.abs().total_cmp(&b.abs()))?;
    let slope_coded = b1 + 2.0 * b2 * x;
    // Variance of the fitted mean at x: MSE x0' (X'X)^-1 x0.
    let x0: Vec<f64> = fit.terms.iter().map(|t| t.value(&[x])).collect();
    let mut q = 0.0;
    for i in 0..x0.len() {
        for j in 0..x0.len() {
            q += x0[i] * fit.xtx_inv[(i, j)] * x0[j];
        }
    }
    let var_fit = fit.residual.mean_sq * q;
    let n_lab = study.target.replicates.len();
    let var_lab = study
        .target
        .std()
        .filter(|_| n_lab > 0)
        .map_or(0.0, |sd| sd * sd / n_lab as f64);
    let se_coded = (var_fit + var_lab).sqrt() / slope_coded.abs();
    let t = doe::fit::t_critical(0.05, fit.residual.df)?;
    // Coded to actual is linear on a linear scale; through the factor on a log one.
    let value = factor.to_actual(x);
    let per_coded = (factor.to_actual(x + 1e-6) - factor.to_actual(x - 1e-6)) / 2e-6;
    Some(Inversion {
        value,
        std_error: se_coded * per_coded.abs(),
        low: factor.to_actual(x - t * se_coded).min(factor.to_actual(x + t * se_coded)),
        high: factor.to_actual(x - t * se_coded).max(factor.to_actual(x + t * se_coded)),
        slope: slope_coded / per_coded,
        df: fit.residual.df,
    })
}

/// Every run's response against the swept value, the fitted curve, the lab value, and the
/// inverted value with its interval.
fn sweep_plot(study: &Study, st: &StageResult, out: &SweepOutcome) -> Result<String, String> {
    use doe::plots::{self, legend_row, tick, Mark, FONT, SIZE, TEXT};
    let pi = st.active.first().copied().ok_or("no swept parameter")?;
    let pts: Vec<(f64, f64)> = st
        .successes()
        .iter()
        .map(|(s, y)| (s.values[pi], *y))
        .collect();
    if pts.is_empty() {
        return Err("no finished runs".into());
    }
    let f = &out.factor;
    let curve: Vec<(f64, f64)> = (0..=100)
        .map(|i| {
            let c = -1.0 + 2.0 * i as f64 / 100.0;
            (f.to_actual(c), out.fit.predict_coded(&[c]))
        })
        .collect();
    let target = study.target.value;
    let (ylo, yhi) = pts
        .iter()
        .chain(&curve)
        .map(|p| p.1)
        .chain([target])
        .fold((f64::MAX, f64::MIN), |(a, b), y| (a.min(y), b.max(y)));
    let (xlo, xhi) = (f.low.min(f.high), f.low.max(f.high));
    let pad = 0.05 * (xhi - xlo);
    let red = RGBColor(200, 30, 30);
    let blue = plots::NEGATIVE;
    let green = RGBColor(30, 150, 60);
    plots::render(|root| {
        let mut items = vec![
            (Mark::Dot(blue), "runs".to_string()),
            (Mark::Line(blue, 3), "fitted".to_string()),
            (Mark::Dashed(red, 3), format!("lab value {}", sig(target))),
        ];
        if out.inversion.is_some() {
            items.push((Mark::Line(green, 3), "inverted, 95 % interval".to_string()));
        }
        let used = legend_row(root, &items, 16, 26, SIZE.0 as i32 - 32)?;
        let mut chart = plots::chart(
            root,
            xlo - pad..xhi + pad,
            plots::padded(ylo, yhi),
            (used + 10) as u32,
        )?;
        chart
            .configure_mesh()
            .x_desc(f.name.clone())
            .y_desc(response_label(study))
            .x_labels(6)
            .y_labels(6)
            .x_label_formatter(&tick)
            .y_label_formatter(&tick)
            .label_style((FONT, TEXT))
            .axis_desc_style((FONT, plots::DESC))
            .light_line_style(TRANSPARENT)
            .bold_line_style(BLACK.mix(0.1))
            .draw()
            .map_err(plots::err)?;
        chart
            .draw_series(DashedLineSeries::new(
                [(xlo - pad, target), (xhi + pad, target)],
                10,
                7,
                red.stroke_width(3),
            ))
            .map_err(plots::err)?;
        chart
            .draw_series(LineSeries::new(curve.clone(), blue.stroke_width(3)))
            .map_err(plots::err)?;
        chart
            .draw_series(pts.iter().map(|p| Circle::new(*p, 4, blue.filled())))
            .map_err(plots::err)?;
        if let Some(inv) = &out.inversion {
            chart
                .draw_series(LineSeries::new(
                    [(inv.low, target), (inv.high, target)],
                    green.stroke_width(5),
                ))
                .map_err(plots::err)?;
            chart
                .draw_series([Circle::new((inv.value, target), 8, green.stroke_width(3))])
                .map_err(plots::err)?;
        }
        Ok(())
    })
}
