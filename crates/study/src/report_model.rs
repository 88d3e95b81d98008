//! The report's account of a fitted model: the ANOVA with Design-Expert's fit statistics, the
//! coefficient table (estimate, standard error, 95 % interval, VIF), the equations, the figures
//! (Pareto chart, contours with the target and the optimum, 3-D surface, perturbation plot,
//! residual diagnostics), and the optimisation's solutions with the prediction interval at the
//! first and each factor's equally good stretch.

use std::fmt::Write;

use doe::diagnostics::Interval;
use doe::fit::{fmt_p, AnovaRow};
use doe::plots::{self, ContourMarks, Labels};
use doe::Fit;

use crate::record::{StageResult, EQUALLY_GOOD};
use crate::report_figures::response_label;
use crate::report_settings::parameter_unit;
use crate::spec::Study;
use crate::text::sig;
use crate::text::FigureSink;
use crate::text::{breakable, esc, letter};

/// Axis titles of a stage's model: names with units, the parameters' letters.
pub(crate) fn labels(study: &Study, st: &StageResult, fit: &Fit) -> Labels {
    let units: Vec<String> = st
        .active
        .iter()
        .map(|&pi| parameter_unit(&study.parameters[pi]))
        .collect();
    let mut l = Labels::with_units(fit, &study.target.unit, &units);
    if st.active.len() == l.letters.len() {
        l.letters = st.active.iter().map(|&pi| letter(pi)).collect();
    }
    l
}

/// The run number of each row of a stage's model (its finished runs, in run order).
fn run_numbers(st: &StageResult) -> Vec<usize> {
    st.point_means().iter().map(|p| p.spec.index + 1).collect()
}

/// The first solution of the optimisation that follows stage `st` (coded), if any.
pub(crate) fn optimum_after<'a>(
    stages: &'a [StageResult],
    st: &StageResult,
) -> Option<&'a StageResult> {
    stages
        .iter()
        .skip(st.index + 1)
        .find(|s| s.kind == "optimize" && s.target_fits().is_empty() && !s.solutions().is_empty())
}

/// The model's 95 % prediction interval at the validated solution of the last optimisation (the
/// first, unless a validation of several candidates chose another).
pub(crate) fn interval_at_optimum(stages: &[StageResult]) -> Option<(Interval, &StageResult)> {
    let at = stages.iter().rposition(|s| {
        s.kind == "optimize" && s.target_fits().is_empty() && !s.solutions().is_empty()
    })?;
    let st = &stages[at];
    let chosen = stages
        .get(at + 1)
        .filter(|s| s.kind == "validate")
        .map_or(0, |v| v.chosen_solution());
    let fit = st.fit.as_ref()?;
    let solution = st.solutions().get(chosen)?;
    Some((fit.prediction_interval(&solution.coded, 0.95)?, st))
}

/// The screening stage's model and figures.
pub(crate) fn screening(
    h: &mut String,
    figs: &mut dyn FigureSink,
    study: &Study,
    st: &StageResult,
    fit: &Fit,
) {
    anova_html(h, fit, "First-order model with curvature");
    verdicts_html(h, study, st, fit);
    effects_html(h, fit);
    let l = labels(study, st, fit);
    let stage = st.index + 1;
    let response = esc(&response_label(study));
    figs.row(
        h,
        vec![
            (
                format!("stage{stage}-pareto"),
                plots::pareto_chart(fit),
                format!("Screening (stage {stage}): Pareto chart of the effects on {response}, |t| of each, largest at the top; orange raises the response, blue lowers it. An effect beyond the t limit is significant at 0.05, beyond the Bonferroni limit also when all are tested at once."),
            ),
            (
                format!("stage{stage}-predicted-vs-actual"),
                plots::predicted_vs_actual(fit, &l),
                format!("Screening (stage {stage}): {response} the first-order model predicts against the simulated value, one point per run."),
            ),
        ],
    );
}

/// The response-surface stage's model and figures.
pub(crate) fn rsm(
    h: &mut String,
    figs: &mut dyn FigureSink,
    study: &Study,
    stages: &[StageResult],
    st: &StageResult,
) {
    if let Some(full) = &st.full_fit {
        anova_html(h, full, "Full quadratic model");
    }
    if let (Some(fit), Some(full)) = (&st.fit, &st.full_fit) {
        if fit.terms != full.terms {
            anova_html(h, fit, "Reduced model (backward elimination)");
        }
    }
    if let Some(fit) = &st.fit {
        verdicts_html(h, study, st, fit);
    }
    let Some(fit) = &st.fit else { return };
    let l = labels(study, st, fit);
    let stage = st.index + 1;
    let k = fit.experiment.factor_names.len();
    let response = esc(&response_label(study));
    let optimum = optimum_after(stages, st).map(|o| o.solutions()[0].coded.clone());
    let held = optimum.clone().unwrap_or_else(|| vec![0.0; k]);
    let target = (!study.target.minimised()).then(|| {
        (
            study.target.value,
            format!(
                "lab value {} {}",
                sig(study.target.value),
                study.target.unit
            )
            .trim()
            .to_string(),
        )
    });
    let names = |j: usize| esc(&l.factors[j]);
    let held_text = |fx: usize, fy: usize| -> String {
        let others: Vec<String> = (0..k)
            .filter(|&f| f != fx && f != fy)
            .map(|f| {
                let v = fit
                    .experiment
                    .factors
                    .as_ref()
                    .map_or(held[f], |fs| fs[f].to_actual(held[f]));
                format!("{} = {}", esc(&fit.experiment.factor_names[f]), sig(v))
            })
            .collect();
        if others.is_empty() {
            String::new()
        } else {
            format!(
                " The other factors are held at {} ({}).",
                others.join(", "),
                if optimum.is_some() {
                    "the optimum"
                } else {
                    "the centre"
                }
            )
        }
    };
    let mut items = Vec::new();
    // Every pair of the design's factors, also those the reduction dropped: flat contours show
    // as plainly as curved ones that a factor does not matter.
    for (a, b) in crate::report_figures::drawn_pairs(h, k) {
        let marks = ContourMarks {
            held: held.clone(),
            range: ContourMarks::covering(fit, a, b, &held),
            target: target.clone(),
            optimum: optimum
                .clone()
                .map(|o| (o, "optimum (solution 1)".to_string())),
        };
        items.push((
            format!("stage{stage}-contour-{}{}", l.letters[a], l.letters[b]),
            plots::contour_plot(fit, &l, a, b, &marks),
            format!(
                "Response surface (stage {stage}): contours of {response} over {} and {} from the final model, with every design run in this plane (the axial runs too){}{}.{}",
                names(a),
                names(b),
                if target.is_some() { ", the lab value's contour (dashed)" } else { "" },
                if optimum.is_some() { " and the optimum the next stage found (cross)" } else { "" },
                held_text(a, b)
            ),
        ));
    }
    if k >= 2 {
        let marks = ContourMarks {
            held: held.clone(),
            range: ContourMarks::covering(fit, 0, 1, &held),
            target: None,
            optimum: optimum.clone().map(|o| (o, String::new())),
        };
        items.push((
            format!("stage{stage}-surface"),
            plots::surface_plot(fit, &l, 0, 1, &marks),
            format!(
                "Response surface (stage {stage}): {response} over {} and {} in 3-D{}.{}",
                names(0),
                names(1),
                if optimum.is_some() {
                    ", the optimum marked (cross)"
                } else {
                    ""
                },
                held_text(0, 1)
            ),
        ));
    }
    items.push((
        format!("stage{stage}-perturbation"),
        plots::perturbation_plot(fit, &l, &held, 1.0),
        format!(
            "Perturbation plot (stage {stage}): {response} as each factor alone moves one coded unit either way from the {}; a flat line is a factor the final model does not depend on.",
            if optimum.is_some() { "optimum" } else { "centre of the design" }
        ),
    ));
    items.push((
        format!("stage{stage}-predicted-vs-actual"),
        plots::predicted_vs_actual(fit, &l),
        format!("Response surface (stage {stage}): {response} the final model predicts against the simulated value, one point per run."),
    ));
    figs.row(h, items);
    h.push_str("<h3>Residual diagnostics</h3>");
    diagnostics(h, figs, fit, &l, &run_numbers(st), stage);
}

/// Normal plot, residuals against predicted values and run order, Cook's distance.
fn diagnostics(
    h: &mut String,
    figs: &mut dyn FigureSink,
    fit: &Fit,
    l: &Labels,
    runs: &[usize],
    stage: usize,
) {
    if !fit.studentized.iter().any(|r| r.is_finite()) {
        h.push_str(
            "<p class=\"note\">No residual diagnostics: the model fits every run exactly.</p>",
        );
        return;
    }
    figs.row(
        h,
        vec![
            (
                format!("stage{stage}-normal-plot"),
                plots::normal_plot(fit),
                format!("Residuals (stage {stage}): normal probability plot of the externally studentized residuals; normal residuals lie along the line."),
            ),
            (
                format!("stage{stage}-residuals-vs-predicted"),
                plots::residuals_vs_predicted(fit, l),
                format!("Residuals (stage {stage}) against the predicted value: no funnel or curve should show. Dashed: the outlier limits."),
            ),
            (
                format!("stage{stage}-residuals-vs-run"),
                plots::residuals_vs_run(fit, runs),
                format!("Residuals (stage {stage}) in the order the runs were made: no trend should show."),
            ),
            (
                format!("stage{stage}-cooks-distance"),
                plots::cooks_distance_plot(fit, runs),
                format!("Cook's distance of each run (stage {stage}): how much the fit moves without it; a run above 1 steers the model by itself."),
            ),
        ],
    );
}

/// The optimisation of a single response (or combined objective): the goal, the solutions,
/// each factor's equally good stretch and the prediction interval at the first solution.
pub(crate) fn optimize(
    h: &mut String,
    study: &Study,
    st: &StageResult,
    fit: &Fit,
    region: &crate::record::SearchRegion,
) {
    let goal = if study.target.minimised() {
        "minimised (lower limit: below the model's least value)".to_string()
    } else {
        format!(
            "on target {} (limits: the observed range)",
            sig(study.target.value)
        )
    };
    let region = region.describe();
    write!(
        h,
        "<p>Goal: {} {goal}, each factor {}. The first solution is validated (with several candidates, the one whose runs come nearest the lab value).</p>",
        esc(&fit.experiment.response_name),
        esc(&region),
    )
    .unwrap();
    h.push_str("<div class=\"scroll\"><table><tr><th>#</th>");
    for (j, f) in st.factors.iter().enumerate() {
        let unit = st
            .active
            .get(j)
            .map(|&pi| parameter_unit(&study.parameters[pi]))
            .unwrap_or_default();
        write!(
            h,
            "<th>{}{}</th>",
            breakable(&f.name),
            if unit.is_empty() {
                String::new()
            } else {
                format!(" ({})", esc(&unit))
            }
        )
        .unwrap();
    }
    write!(
        h,
        "<th>predicted {}</th><th>desirability</th></tr>",
        breakable(&response_label(study))
    )
    .unwrap();
    for (i, s) in st.solutions().iter().enumerate() {
        write!(
            h,
            "<tr{}><td>{}</td>",
            if i == 0 { " class=\"best\"" } else { "" },
            i + 1
        )
        .unwrap();
        for v in s.actual.clone().unwrap_or_default() {
            write!(h, "<td>{}</td>", sig(v)).unwrap();
        }
        write!(
            h,
            "<td>{}</td><td>{:.3}</td></tr>",
            sig(s.responses[0]),
            s.desirability
        )
        .unwrap();
    }
    h.push_str("</table></div>");
    if !st.equally_good().is_empty() {
        h.push_str("<p>How far each factor can move from solution 1, the others held, with the desirability staying within ");
        write!(h, "{EQUALLY_GOOD} of its best:</p><ul>").unwrap();
        for (j, &(lo, hi)) in st.equally_good().iter().enumerate() {
            let Some(f) = st.factors.get(j) else { continue };
            let in_model = fit
                .terms
                .iter()
                .any(|t| t.powers.get(j).is_some_and(|&p| p > 0));
            let flag = if !in_model {
                " <b>⚠ not in the final model: the optimum does not determine it</b>"
            } else if hi - lo >= 1.0 {
                " <b>⚠ the model hardly depends on it</b>"
            } else {
                ""
            };
            write!(
                h,
                "<li>{}: {} to {}{flag}</li>",
                esc(&f.name),
                sig(f.to_actual(lo)),
                sig(f.to_actual(hi))
            )
            .unwrap();
        }
        h.push_str("</ul>");
    }
    if let Some(s) = st.solutions().first() {
        if let Some(pi) = fit.prediction_interval(&s.coded, 0.95) {
            write!(
                h,
                "<p>At solution 1 the model predicts {} = <b>{}</b>; a new run there would fall between {} and {} (95 % prediction interval: t with {} residual degrees of freedom, standard error of a new run {}).</p>",
                esc(&response_label(study)),
                sig(pi.predicted),
                sig(pi.low),
                sig(pi.high),
                pi.df,
                sig(pi.std_error)
            )
            .unwrap();
        }
    }
}

/// The ANOVA table, fit statistics, coefficients and equations of a fit.
/// The screening effects with their percent contribution, largest first (seed 001's Table 6:
/// effect, sum of squares, "impact rate", significance order).
fn effects_html(h: &mut String, fit: &Fit) {
    if fit.effects.is_empty() {
        return;
    }
    let mut effects: Vec<_> = fit.effects.iter().collect();
    effects.sort_by(|a, b| b.contribution_percent.total_cmp(&a.contribution_percent));
    write!(
        h,
        "<h3>Effects on {}, largest contribution first</h3><div class=\"scroll\"><table><tr><th>Order</th><th class=\"l\">Term</th><th>Effect</th><th>t-value</th><th>% Contribution</th></tr>",
        esc(&fit.experiment.response_name)
    )
    .unwrap();
    for (k, e) in effects.iter().enumerate() {
        write!(
            h,
            "<tr><td>{}</td><td class=\"l\">{}</td><td>{}</td><td>{}</td><td>{:.2}</td></tr>",
            k + 1,
            esc(&e.name),
            sig(e.effect),
            sig(e.t),
            e.contribution_percent
        )
        .unwrap();
    }
    h.push_str("</table></div><p class=\"note\">% Contribution: the effect's sum of squares over the corrected total sum of squares.</p>");
}

pub(crate) fn anova_html(h: &mut String, fit: &Fit, title: &str) {
    write!(
        h,
        "<h3>{title}: ANOVA for {}</h3><div class=\"scroll\"><table><tr><th class=\"l\">Source</th><th>Sum of squares</th><th>df</th><th>Mean square</th><th>F-value</th><th>p-value</th><th class=\"l\"></th></tr>",
        esc(&fit.experiment.response_name)
    )
    .unwrap();
    // Pure error on one or two degrees of freedom (a 12-run Plackett-Burman repeating a point)
    // makes any lack-of-fit test meaningless: said instead of a verdict.
    let thin_pure_error = fit
        .pure_error
        .as_ref()
        .map(|p| p.df)
        .filter(|df| (1..=2).contains(df));
    let row = |h: &mut String, r: &AnovaRow, verdict: bool| {
        let lack_of_fit = fit.lack_of_fit.as_ref().is_some_and(|l| std::ptr::eq(l, r));
        let thin = thin_pure_error.filter(|_| lack_of_fit).map(|df| {
            format!(
                "not judged: pure error has only {df} degree{} of freedom",
                if df == 1 { "" } else { "s" }
            )
        });
        let note = match (verdict, r.p, thin) {
            (_, _, Some(t)) => t,
            (true, Some(p), _) if p < 0.05 => "significant".to_string(),
            (true, Some(_), _) => "not significant".to_string(),
            _ => String::new(),
        };
        write!(
            h,
            "<tr><td class=\"l\">{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td class=\"l wrap\">{note}</td></tr>",
            esc(&r.name),
            sig(r.sum_sq),
            r.df,
            if r.df > 0 { sig(r.mean_sq) } else { String::new() },
            r.f.map(sig).unwrap_or_default(),
            r.p.map(fmt_p).unwrap_or_default()
        )
        .unwrap();
    };
    row(h, &fit.model, true);
    for r in &fit.anova_terms {
        row(h, r, false);
    }
    if let Some(c) = &fit.curvature {
        row(h, c, true);
    }
    row(h, &fit.residual, false);
    if let Some(l) = &fit.lack_of_fit {
        row(h, l, true);
    }
    if let Some(p) = &fit.pure_error {
        row(h, p, false);
    }
    write!(
        h,
        "<tr><td class=\"l\">Cor Total</td><td>{}</td><td>{}</td><td></td><td></td><td></td><td></td></tr></table></div>",
        sig(fit.total_sum_sq),
        fit.total_df
    )
    .unwrap();
    write!(
        h,
        "<div class=\"scroll\"><table><tr><th>Std. Dev.</th><th>Mean</th><th>C.V. %</th><th>R²</th><th>Adjusted R²</th><th>Predicted R²</th><th>Adeq. precision</th></tr><tr><td>{}</td><td>{}</td><td>{}</td><td>{:.4}</td><td>{:.4}</td><td>{}</td><td>{}</td></tr></table></div>",
        sig(fit.std_dev),
        sig(fit.mean),
        fit.cv_percent_defined().map(sig).unwrap_or_else(|| "N/A".into()),
        fit.r2,
        fit.adj_r2,
        fit.pred_r2.map(|v| format!("{v:.4}")).unwrap_or_else(|| "N/A".into()),
        fit.adeq_precision.map(sig).unwrap_or_else(|| "N/A".into())
    )
    .unwrap();
    for note in fit.not_available_notes() {
        write!(h, "<p class=\"note\">{}</p>", esc(&note)).unwrap();
    }
    coefficients_html(h, fit);
    equations_html(h, fit);
}

/// Curvature and lack of fit said in words, with what the plan does about them.
fn verdicts_html(h: &mut String, study: &Study, st: &StageResult, fit: &Fit) {
    let later: Vec<(usize, &str)> = study
        .plan
        .iter()
        .enumerate()
        .skip(st.index + 1)
        .map(|(i, s)| (i + 1, s.kind()))
        .collect();
    let find = |k: &str| later.iter().find(|(_, s)| *s == k).map(|(i, _)| *i);
    let mut words = Vec::new();
    if let Some(c) = fit.curvature.as_ref().and_then(|c| c.p.map(|p| (c, p))) {
        let (_, p) = c;
        words.push(if p < 0.05 {
            let plan = match find("rsm") {
                Some(i) => format!("The plan goes on to a response surface (stage {i}), whose squared terms model the bend; the screening's first-order effects still rank the parameters."),
                None => "This plan fits no quadratic model after it: its first-order model misjudges the centre of the ranges, so add an rsm stage, or narrow the ranges.".into(),
            };
            format!("Curvature is significant (p = {}): the response bends inside the ranges, and the centre points do not lie on the first-order model's plane. {plan}", fmt_p(p))
        } else {
            format!("Curvature is not significant (p = {}): the centre points agree with the first-order model.", fmt_p(p))
        });
    }
    let thin = fit.pure_error.as_ref().is_some_and(|p| p.df <= 2);
    if let Some(p) = fit.lack_of_fit.as_ref().and_then(|l| l.p).filter(|_| !thin) {
        words.push(if p < 0.05 {
            let plan = match find("optimize").or(find("validate")) {
                Some(i) => format!("The plan uses it all the same (stage {i}); the validation runs show how far its optimum can be trusted."),
                None => "Nothing after it relies on the model.".into(),
            };
            format!("Lack of fit is significant (p = {}): the model misses part of the response beyond the runs' own scatter (pure error). {plan}", fmt_p(p))
        } else {
            format!("Lack of fit is not significant (p = {}): the model's misfit is of the size of the runs' own scatter.", fmt_p(p))
        });
    }
    for w in words {
        write!(h, "<p class=\"note\">{}</p>", esc(&w)).unwrap();
    }
}

/// Each coefficient of the coded equation with its standard error, 95 % confidence interval
/// and variance inflation factor.
fn coefficients_html(h: &mut String, fit: &Fit) {
    write!(
        h,
        "<div class=\"scroll\"><table><tr><th class=\"l\">Term (coded)</th><th>Estimate</th><th>Standard error</th><th>95 % CI low</th><th>95 % CI high</th><th>VIF</th></tr>"
    )
    .unwrap();
    for c in &fit.coefficients {
        write!(
            h,
            "<tr><td class=\"l\">{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
            esc(&c.name),
            sig(c.estimate),
            sig(c.std_error),
            sig(c.ci_low),
            sig(c.ci_high),
            c.vif.map(sig).unwrap_or_default()
        )
        .unwrap();
    }
    write!(
        h,
        "</table></div><p class=\"sub\">Confidence intervals from t with {} residual degrees of freedom; VIF 1 is an orthogonal term.</p>",
        fit.residual.df
    )
    .unwrap();
}

fn equations_html(h: &mut String, fit: &Fit) {
    let coded: Vec<String> = fit
        .coefficients
        .iter()
        .enumerate()
        .map(|(i, c)| {
            if i == 0 {
                sig(c.estimate)
            } else {
                format!(
                    "{} {} {}",
                    if c.estimate < 0.0 { "−" } else { "+" },
                    sig(c.estimate.abs()),
                    c.name
                )
            }
        })
        .collect();
    write!(
        h,
        "<p>Coded equation: <span class=\"mono\">{} = {}</span></p>",
        esc(&fit.experiment.response_name),
        esc(&coded.join(" "))
    )
    .unwrap();
    if let Some(eq) = fit.actual_equation() {
        let vars = fit.actual_variable_names();
        let parts: Vec<String> = eq
            .iter()
            .enumerate()
            .map(|(i, (t, v))| {
                let name = t.name(&vars);
                if i == 0 && t.is_intercept() {
                    sig(*v)
                } else {
                    format!(
                        "{} {} × {}",
                        if *v < 0.0 { "−" } else { "+" },
                        sig(v.abs()),
                        name
                    )
                }
            })
            .collect();
        write!(
            h,
            "<p>Actual equation: <span class=\"mono\">{} = {}</span></p>",
            esc(&fit.experiment.response_name),
            esc(&parts.join(" "))
        )
        .unwrap();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A two-factor square with its centre twice and one more point: pure error on one degree
    /// of freedom, and a lack of fit that a verdict would call significant.
    #[test]
    fn lack_of_fit_on_thin_pure_error_is_not_judged() {
        let coded = vec![
            vec![-1.0, -1.0],
            vec![1.0, -1.0],
            vec![-1.0, 1.0],
            vec![1.0, 1.0],
            vec![0.0, 0.0],
            vec![0.0, 0.0],
            vec![0.5, 0.5],
        ];
        let response = coded
            .iter()
            .map(|x: &Vec<f64>| 10.0 + 2.0 * x[0] + 3.0 * x[0] * x[0] + 5.0 * x[1] * x[1])
            .zip([0.0, 0.0, 0.0, 0.0, 0.001, -0.001, 0.0])
            .map(|(y, e)| y + e)
            .collect();
        let exp = doe::experiment::Experiment {
            response_name: "y".into(),
            factor_names: vec!["A".into(), "B".into()],
            factors: None,
            coded,
            response,
        };
        let fit = Fit::new(
            &exp,
            &doe::model::ModelOrder::Linear.terms(2),
            doe::fit::Curvature::Off,
        )
        .unwrap();
        let (l, p) = (
            fit.lack_of_fit.as_ref().unwrap(),
            fit.pure_error.as_ref().unwrap(),
        );
        assert_eq!(p.df, 1);
        assert!(l.p.unwrap() < 0.05, "{:?}", l.p);
        let mut h = String::new();
        anova_html(&mut h, &fit, "Screening");
        let row = h.split("<tr>").find(|r| r.contains("Lack of Fit")).unwrap();
        assert!(
            row.contains("not judged: pure error has only 1 degree of freedom")
                && !row.contains(">significant<"),
            "{row}"
        );
    }
}
