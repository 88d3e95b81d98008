//! The report: `index.html` (self-contained: SVG inline, pictures as data URLs), `results.csv`
//! (every stored run) and `summary.json` (the calibrated values and the validation, for scripts).

use std::fmt::Write;
use std::path::{Path, PathBuf};

use base64::Engine;
use doe::fit::{fmt_p, AnovaRow};
use doe::{plots, Fit};
use plotters::prelude::*;

use crate::report_data;
use crate::spec::Study;
use crate::stages::{self, sig, Replay, StageResult, State};
use crate::store::{RunRecord, Status};
use crate::targets_report;

/// Writes the report into `out` (default: `report/` next to the study); returns the folder.
pub fn write(
    study: &Study,
    r: &Replay,
    stored: &[RunRecord],
    out: Option<&Path>,
) -> Result<PathBuf, String> {
    let dir = out
        .map(Path::to_path_buf)
        .unwrap_or_else(|| study.report_dir());
    std::fs::create_dir_all(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let put = |name: &str, text: &str| -> Result<(), String> {
        let p = dir.join(name);
        // Write then rename, so a reader never sees half a file.
        let tmp = dir.join(format!(".{name}.tmp"));
        std::fs::write(&tmp, text).map_err(|e| format!("{}: {e}", tmp.display()))?;
        std::fs::rename(&tmp, &p).map_err(|e| format!("{}: {e}", p.display()))
    };
    put("results.csv", &report_data::results_csv(study, stored)?)?;
    put(
        "summary.json",
        &serde_json::to_string_pretty(&report_data::summary_json(study, r, stored)).unwrap(),
    )?;
    put("index.html", &html(study, r, stored))?;
    Ok(dir)
}

fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

const STYLE: &str = "
body { font-family: system-ui, -apple-system, 'Segoe UI', Roboto, sans-serif; margin: 0; color: #1d2330; background: #f4f6f9; }
main { max-width: 1220px; margin: 0 auto; padding: 24px 28px 60px; background: #fff; }
h1 { font-size: 1.7em; margin-bottom: 0.2em; }
h2 { border-bottom: 2px solid #d6dde8; padding-bottom: 4px; margin-top: 2.2em; }
h3 { margin-top: 1.6em; color: #34405a; }
.sub { color: #5b6478; margin-top: 0; }
table { border-collapse: collapse; margin: 0.6em 0 1em; font-size: 0.9em; }
th, td { border: 1px solid #d6dde8; padding: 4px 9px; text-align: right; white-space: nowrap; }
td.wrap { white-space: normal; min-width: 16em; }
th { white-space: normal; }
th { background: #eef2f7; }
td.l, th.l { text-align: left; }
tr.failed td { color: #a12a2a; background: #fff4f4; }
tr.best td { background: #eefaf0; font-weight: 600; }
.cards { display: flex; flex-wrap: wrap; gap: 14px; margin: 1em 0; }
.card { border: 1px solid #d6dde8; border-radius: 8px; padding: 10px 16px; min-width: 180px; background: #fafbfd; }
.card .v { font-size: 1.5em; font-weight: 600; }
.card .k { color: #5b6478; font-size: 0.85em; }
.note { background: #fff8e6; border-left: 4px solid #e0a800; padding: 6px 12px; margin: 0.5em 0; }
.stop { background: #fdecec; border-left: 4px solid #c62828; padding: 6px 12px; }
.plots { display: flex; flex-wrap: wrap; gap: 12px; }
.plots > div { flex: 1 1 480px; max-width: 540px; }
.plots svg, .plots img { width: 100%; height: auto; border: 1px solid #e3e8ef; }
.heaps { display: flex; flex-wrap: wrap; gap: 12px; }
.heaps figure { margin: 0; flex: 1 1 300px; max-width: 520px; }
.heaps img { width: 100%; border: 1px solid #e3e8ef; }
.mono { font-family: ui-monospace, Menlo, Consolas, monospace; font-size: 0.88em; }
.scroll { overflow-x: auto; }
";

fn html(study: &Study, r: &Replay, stored: &[RunRecord]) -> String {
    let mut h = String::new();
    let t = &study.target;
    let unit = if t.unit.is_empty() {
        String::new()
    } else {
        format!(" {}", esc(&t.unit))
    };
    write!(
        h,
        "<!DOCTYPE html><html lang=\"en\"><head><meta charset=\"utf-8\"><title>{} - demcal calibration report</title><style>{STYLE}</style></head><body><main>",
        esc(&study.name)
    )
    .unwrap();
    let against = if let Some(c) = study.combine {
        format!(
            "calibrated against {} targets by minimising {}, {}",
            study.targets.len(),
            esc(c.response()),
            esc(c.describe())
        )
    } else if t.minimised() {
        format!(
            "calibrated by minimising {}, the mean squared difference between its curve and the lab's",
            esc(&t.response)
        )
    } else {
        format!(
            "calibrated against the lab's {} = {}{unit}",
            esc(&t.response),
            sig(t.value)
        )
    };
    write!(
        h,
        "<h1>Calibration report: {}</h1><p class=\"sub\">Virtual test <b>{}</b> ({}), {against}. Study file <span class=\"mono\">{}</span>, seed {}, demcal {}.</p>",
        esc(&study.name),
        esc(&study.test_kind()),
        esc(&study
            .tests
            .iter()
            .map(|t| t.source.as_str())
            .collect::<Vec<_>>()
            .join(", ")),
        esc(&study.path.display().to_string()),
        study.seed,
        env!("CARGO_PKG_VERSION")
    )
    .unwrap();
    write!(
        h,
        "<p class=\"sub\">Runs made: {}.</p>",
        esc(&report_data::where_ran(stored))
    )
    .unwrap();

    // Summary.
    h.push_str("<h2>Summary</h2>");
    if let State::Stopped(why) = &r.state {
        write!(h, "<p class=\"stop\">The study stopped: {}</p>", esc(why)).unwrap();
    }
    if let State::Pending { stage } = &r.state {
        write!(
            h,
            "<p class=\"note\">The study is not finished: stage {} ({}) still has runs to make. <span class=\"mono\">demcal run {}</span> goes on.</p>",
            stage + 1,
            study.plan[*stage].kind(),
            esc(&study.path.display().to_string())
        )
        .unwrap();
    }
    let validation = r.stages.iter().rev().find_map(|s| s.validation.clone());
    let failed = stored.iter().filter(|x| x.status == Status::Failed).count();
    let wall: f64 = stored.iter().map(|x| x.wall_s).sum();
    h.push_str("<div class=\"cards\">");
    let lab = match t.std() {
        Some(sd) => format!("{} ± {}{unit}", sig(t.value), sig(sd)),
        None => format!("{}{unit}", sig(t.value)),
    };
    match &t.curve {
        _ if study.combine.is_some() => card(
            &mut h,
            &format!("{} targets", study.targets.len()),
            &format!("in {} test(s), one objective", study.tests.len()),
        ),
        Some(c) if t.minimised() => card(
            &mut h,
            &format!("{} curve(s)", c.lab.replicates.len()),
            &format!("lab replicates of {}", c.curve),
        ),
        _ => card(
            &mut h,
            &lab,
            &format!("lab value ({} replicates)", t.replicates.len()),
        ),
    }
    if let Some(v) = &validation {
        let s = match v.std {
            Some(sd) => format!("{} ± {}{unit}", sig(v.mean), sig(sd)),
            None => format!("{}{unit}", sig(v.mean)),
        };
        card(&mut h, &s, &format!("validation mean ({} runs)", v.runs));
        if let Some(e) = v.relative_error_percent {
            card(
                &mut h,
                &format!("{e:.2} %"),
                "relative error |sim - lab| / lab",
            );
        }
    }
    card(
        &mut h,
        &format!("{} ({} failed)", stored.len(), failed),
        "simulations stored",
    );
    card(
        &mut h,
        &format!("{:.0} s", wall),
        "simulation wall time, summed",
    );
    h.push_str("</div>");
    targets_report::targets_section(&mut h, study, validation.as_ref());
    let calibrated = stages::calibrated(study, &r.stages);
    h.push_str("<table><tr><th>Factor</th><th class=\"l\">Parameter</th><th class=\"l\">Where in the test</th><th>Range</th><th class=\"l\">Scale</th><th>Calibrated value</th></tr>");
    for (i, p) in study.parameters.iter().enumerate() {
        write!(
            h,
            "<tr><td>{}</td><td class=\"l\">{}</td><td class=\"l mono\">{}</td><td>{} .. {}</td><td class=\"l\">{}</td><td>{}</td></tr>",
            letter(i),
            esc(&p.name),
            esc(&p.paths.iter().map(|x| x.0.text.clone()).collect::<Vec<_>>().join(", ")),
            sig(p.min),
            sig(p.max),
            if p.scale == doe::Scale::Log { "log" } else { "linear" },
            calibrated.as_ref().map(|v| sig(v[i])).unwrap_or_else(|| "-".into())
        )
        .unwrap();
    }
    h.push_str("</table>");
    for i in &study.imports {
        write!(
            h,
            "<p class=\"note\">Taken from another study: {} = <b>{}</b> (its {}, calibrated by {}).</p>",
            esc(&i.paths.iter().map(|x| x.0.text.clone()).collect::<Vec<_>>().join(", ")),
            sig(i.value),
            esc(&i.parameter),
            esc(&i.study)
        )
        .unwrap();
    }
    if !r.stages.iter().any(|s| s.calibrated.is_some()) && calibrated.is_some() {
        h.push_str("<p class=\"note\">No optimisation has run yet: the values shown are those of the run nearest the lab value.</p>");
    }
    write!(
        h,
        "<p>Plan: {}.</p>",
        study
            .plan
            .iter()
            .enumerate()
            .map(|(i, s)| format!("{}. {}", i + 1, s.kind()))
            .collect::<Vec<_>>()
            .join(", ")
    )
    .unwrap();

    if let Some(c) = crate::curve_report::section(study, r) {
        h.push_str("<h2>Curves</h2>");
        for p in &c.paragraphs {
            write!(h, "<p>{}</p>", esc(p)).unwrap();
        }
        match c.svg {
            Ok(svg) => plots_div(&mut h, &[svg]),
            Err(e) => write!(h, "<p class=\"note\">No curve plot: {}</p>", esc(&e)).unwrap(),
        }
    }
    for st in &r.stages {
        stage_html(&mut h, study, st);
    }
    h.push_str("<h2>Files</h2><p><a href=\"results.csv\">results.csv</a> (every stored run) and <a href=\"summary.json\">summary.json</a> (calibrated values and validation) lie beside this page.</p>");
    h.push_str("</main></body></html>\n");
    h
}

/// A name for a narrow column heading: it may break after its underscores.
fn breakable(name: &str) -> String {
    esc(name).replace('_', "_<wbr>")
}

/// The letter a parameter goes by in tables (A, B, ... without I, as Design-Expert names factors).
fn letter(i: usize) -> String {
    doe::design::factor_letter(i)
}

fn card(h: &mut String, value: &str, key: &str) {
    write!(
        h,
        "<div class=\"card\"><div class=\"v\">{}</div><div class=\"k\">{}</div></div>",
        esc(value),
        esc(key)
    )
    .unwrap();
}

fn stage_html(h: &mut String, study: &Study, st: &StageResult) {
    write!(
        h,
        "<h2>Stage {}: {}</h2><p class=\"sub\">{}</p>",
        st.index + 1,
        stage_title(st.kind),
        esc(&st.title)
    )
    .unwrap();
    for n in &st.notes {
        write!(h, "<p class=\"note\">{}</p>", esc(n)).unwrap();
    }
    if !st.runs.is_empty() {
        runs_table(h, study, st);
    }
    match st.kind {
        "screening" => {
            if let Some(fit) = &st.fit {
                anova_html(h, fit, "First-order model with curvature");
                let mut plots_row = Vec::new();
                if let Ok(svg) = plots::pareto_chart(fit) {
                    plots_row.push(svg);
                }
                if let Ok(svg) = plots::predicted_vs_actual(fit) {
                    plots_row.push(svg);
                }
                plots_div(h, &plots_row);
                if !st.selected.is_empty() {
                    write!(
                        h,
                        "<p>Going on to the next stages: <b>{}</b>. The others are held at the middle of their ranges.</p>",
                        st.selected
                            .iter()
                            .map(|&i| esc(&study.parameters[i].name))
                            .collect::<Vec<_>>()
                            .join(", ")
                    )
                    .unwrap();
                }
            }
        }
        "steepest" => {
            if let Ok(svg) = steepest_plot(study, st) {
                plots_div(h, &[svg]);
            }
        }
        "rsm" => {
            if let Some(full) = &st.full_fit {
                anova_html(h, full, "Full quadratic model");
            }
            if let (Some(fit), Some(full)) = (&st.fit, &st.full_fit) {
                if fit.terms != full.terms {
                    anova_html(h, fit, "Reduced model (backward elimination)");
                }
            }
            if let Some(fit) = &st.fit {
                let mut row = Vec::new();
                // Every pair of the design's factors, also those the reduction dropped: flat
                // contours show as plainly as curved ones that a factor does not matter.
                let k = fit.experiment.factor_names.len();
                let mains: Vec<usize> = (0..k).collect();
                for a in 0..mains.len() {
                    for b in a + 1..mains.len() {
                        if row.len() < 3 {
                            if let Ok(svg) = plots::contour_plot(
                                fit,
                                mains[a],
                                mains[b],
                                &vec![0.0; k],
                                (-1.0, 1.0),
                            ) {
                                row.push(svg);
                            }
                        }
                    }
                }
                if let Ok(svg) = plots::predicted_vs_actual(fit) {
                    row.push(svg);
                }
                plots_div(h, &row);
            }
        }
        "optimize" if !st.target_fits.is_empty() => {
            crate::targets_report::optimize_table(h, study, st)
        }
        "optimize" => {
            if let Some(fit) = &st.fit {
                let goal = if study.target.minimised() {
                    "minimised (lower limit: below the model's least value)".to_string()
                } else {
                    format!(
                        "on target {} (limits: the observed range)",
                        sig(study.target.value)
                    )
                };
                write!(
                    h,
                    "<p>Goal: {} {goal}, factors within their ±1 ranges. The first solution is validated.</p>",
                    esc(&fit.experiment.response_name),
                )
                .unwrap();
                h.push_str("<table><tr><th>#</th>");
                for f in &st.factors {
                    write!(h, "<th>{}</th>", breakable(&f.name)).unwrap();
                }
                write!(
                    h,
                    "<th>predicted {}</th><th>desirability</th></tr>",
                    breakable(&fit.experiment.response_name)
                )
                .unwrap();
                for (i, s) in st.solutions.iter().enumerate() {
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
                h.push_str("</table>");
            }
        }
        "validate" => {
            if let Some(v) = &st.validation {
                write!(
                    h,
                    "<p>Simulated {} = <b>{}</b>{} over {} runs{}.</p>",
                    esc(&study.target.response),
                    sig(v.mean),
                    v.std.map(|d| format!(" ± {}", sig(d))).unwrap_or_default(),
                    v.runs,
                    match v.relative_error_percent {
                        Some(e) => format!(
                            " against the lab's {}: relative error <b>{e:.2} %</b>",
                            sig(study.target.value)
                        ),
                        None if study.combine.is_some() => {
                            " (0 would match every target; the targets' own validation is in the summary)".into()
                        }
                        None => " (minimised: 0 would be the lab curve itself)".into(),
                    }
                )
                .unwrap();
            }
            if let Some(Ok(svg)) = study.combine.is_none().then(|| validation_plot(study, st)) {
                plots_div(h, &[svg]);
            }
            heap_pictures(h, study, st);
        }
        "bayesopt" | "ga_bp" | "smc" => crate::surrogate_report::stage_html(h, study, st),
        _ => {}
    }
}

fn stage_title(kind: &str) -> &'static str {
    match kind {
        "screening" => "screening",
        "steepest" => "steepest path",
        "rsm" => "response surface",
        "optimize" => "optimisation",
        "validate" => "validation",
        "bayesopt" => "Bayesian optimisation",
        "ga_bp" => "GA-BP network and GA-BP-GA search",
        "smc" => "sequential Monte Carlo",
        _ => "stage",
    }
}

fn plots_div(h: &mut String, svgs: &[String]) {
    if svgs.is_empty() {
        return;
    }
    h.push_str("<div class=\"plots\">");
    for s in svgs {
        write!(h, "<div>{s}</div>").unwrap();
    }
    h.push_str("</div>");
}

fn runs_table(h: &mut String, study: &Study, st: &StageResult) {
    let best = if st.kind == "steepest" {
        st.best_step
    } else {
        None
    };
    h.push_str("<div class=\"scroll\"><table><tr><th>Run</th><th class=\"l\">Point</th>");
    if st.kind != "validate" {
        write!(
            h,
            "<th class=\"l\">Coded levels ({})</th>",
            st.active.iter().map(|&i| letter(i)).collect::<String>()
        )
        .unwrap();
    }
    let shown: Vec<usize> = if st.kind == "validate" {
        (0..study.parameters.len()).collect()
    } else {
        st.active.clone()
    };
    // Factor letters keep wide designs readable; the summary's table and the tooltip name them.
    for &i in &shown {
        write!(
            h,
            "<th title=\"{}\">{}</th>",
            esc(&study.parameters[i].name),
            letter(i)
        )
        .unwrap();
    }
    write!(
        h,
        "<th>Seed</th><th>{}</th><th>Rel. error %</th><th>Wall s</th><th class=\"l\">Status</th></tr>",
        breakable(&study.target.response)
    )
    .unwrap();
    for (spec, rec) in st.runs.iter().zip(&st.records) {
        let class = match rec {
            Some(r) if r.status == Status::Failed => " class=\"failed\"",
            _ if best == Some(spec.index) => " class=\"best\"",
            _ => "",
        };
        write!(
            h,
            "<tr{class}><td>{}</td><td class=\"l\">{}</td>",
            spec.index + 1,
            esc(&spec.label)
        )
        .unwrap();
        if st.kind != "validate" {
            let levels: Vec<String> = spec
                .coded
                .iter()
                .map(|c| {
                    if c.abs() < 1e-12 {
                        "0".to_string()
                    } else if (c.abs() - c.abs().round()).abs() < 1e-9 {
                        format!("{}{}", if *c < 0.0 { "−" } else { "+" }, c.abs().round())
                    } else {
                        format!("{}{:.3}", if *c < 0.0 { "−" } else { "+" }, c.abs())
                    }
                })
                .collect();
            write!(h, "<td class=\"l mono\">{}</td>", levels.join(" ")).unwrap();
        }
        for &i in &shown {
            write!(h, "<td>{}</td>", sig(spec.values[i])).unwrap();
        }
        write!(h, "<td>{}</td>", spec.seed).unwrap();
        match rec {
            Some(r) => {
                let y = r.response.map(sig).unwrap_or_default();
                let e = r
                    .response
                    .and_then(|y| study.target.relative_error_percent(y))
                    .map(|e| format!("{e:.2}"))
                    .unwrap_or_default();
                let status = match r.status {
                    Status::Done => "done".to_string(),
                    Status::Failed => format!(
                        "failed ({}): {}",
                        r.error_kind.map(|k| k.as_str()).unwrap_or("unknown"),
                        r.error.clone().unwrap_or_default()
                    ),
                };
                write!(
                    h,
                    "<td>{y}</td><td>{e}</td><td>{:.1}</td><td class=\"l wrap\">{}</td></tr>",
                    r.wall_s,
                    esc(&status)
                )
                .unwrap();
            }
            None => h.push_str("<td></td><td></td><td></td><td class=\"l\">pending</td></tr>"),
        }
    }
    h.push_str("</table></div>");
}

fn anova_html(h: &mut String, fit: &Fit, title: &str) {
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
            "<tr><td class=\"l\">{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td class=\"l\">{note}</td></tr>",
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
        "<table><tr><th>Std. Dev.</th><th>Mean</th><th>C.V. %</th><th>R²</th><th>Adjusted R²</th><th>Predicted R²</th><th>Adeq. precision</th></tr><tr><td>{}</td><td>{}</td><td>{:.2}</td><td>{:.4}</td><td>{:.4}</td><td>{}</td><td>{}</td></tr></table>",
        sig(fit.std_dev),
        sig(fit.mean),
        fit.cv_percent,
        fit.r2,
        fit.adj_r2,
        fit.pred_r2.map(|v| format!("{v:.4}")).unwrap_or_default(),
        fit.adeq_precision.map(|v| format!("{v:.3}")).unwrap_or_default()
    )
    .unwrap();
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

fn heap_pictures(h: &mut String, study: &Study, st: &StageResult) {
    let mut figs = Vec::new();
    for (spec, rec) in st.runs.iter().zip(&st.records) {
        let Some(r) = rec else { continue };
        // A run of several tests keeps each test's pictures in the test's own folder.
        let run = Path::new(&r.out_dir);
        let mut dirs =
            std::iter::once(run.to_path_buf()).chain(study.tests.iter().map(|t| run.join(&t.name)));
        if let Some(bytes) = dirs.find_map(|d| std::fs::read(d.join("heap.png")).ok()) {
            figs.push(format!(
                "<figure><img alt=\"heap of run {}\" src=\"data:image/png;base64,{}\"><figcaption>Run {} (seed {}): {}</figcaption></figure>",
                spec.index + 1,
                base64::engine::general_purpose::STANDARD.encode(bytes),
                spec.index + 1,
                spec.seed,
                r.response.map(sig).unwrap_or_else(|| "failed".into())
            ));
        }
    }
    if !figs.is_empty() {
        h.push_str("<h3>Heaps</h3><div class=\"heaps\">");
        for f in figs {
            h.push_str(&f);
        }
        h.push_str("</div>");
    }
}

const FONT: &str = "sans-serif";

/// Response along the steepest path with the lab value, the best step marked.
fn steepest_plot(study: &Study, st: &StageResult) -> Result<String, String> {
    let pts: Vec<(f64, f64)> = st
        .runs
        .iter()
        .zip(&st.records)
        .filter_map(|(s, r)| r.as_ref()?.response.map(|y| ((s.index + 1) as f64, y)))
        .collect();
    if pts.is_empty() {
        return Err("no finished runs".into());
    }
    let target = study.target.value;
    let (lo, hi) = pts
        .iter()
        .map(|p| p.1)
        .chain([target])
        .fold((f64::MAX, f64::MIN), |(a, b), y| (a.min(y), b.max(y)));
    let pad = 0.1 * (hi - lo).max(1e-9 * hi.abs().max(1.0));
    let n = st.runs.len() as f64;
    plots::render(|root| {
        let mut chart = ChartBuilder::on(root)
            .caption(
                format!("Steepest path: {}", study.target.response),
                (FONT, 22),
            )
            .margin(14)
            .x_label_area_size(44)
            .y_label_area_size(64)
            .build_cartesian_2d(0.5..n + 0.5, (lo - pad)..(hi + pad))
            .map_err(plots::err)?;
        chart
            .configure_mesh()
            .x_desc("step")
            .y_desc(study.target.response.as_str())
            .x_labels(st.runs.len() + 2)
            .x_label_formatter(&|x: &f64| {
                if (x - x.round()).abs() < 1e-9 && *x >= 1.0 {
                    format!("{}", x.round() as i64)
                } else {
                    String::new()
                }
            })
            .draw()
            .map_err(plots::err)?;
        chart
            .draw_series(LineSeries::new(
                [(0.5, target), (n + 0.5, target)],
                RGBColor(200, 30, 30).stroke_width(2),
            ))
            .map_err(plots::err)?
            .label(format!("lab value {}", sig(target)))
            .legend(|(x, y)| PathElement::new([(x, y), (x + 18, y)], RGBColor(200, 30, 30)));
        chart
            .draw_series(LineSeries::new(
                pts.clone(),
                RGBColor(40, 100, 200).stroke_width(2),
            ))
            .map_err(plots::err)?
            .label("simulated")
            .legend(|(x, y)| PathElement::new([(x, y), (x + 18, y)], RGBColor(40, 100, 200)));
        chart
            .draw_series(
                pts.iter()
                    .map(|p| Circle::new(*p, 5, RGBColor(40, 100, 200).filled())),
            )
            .map_err(plots::err)?;
        if let Some(b) = st.best_step {
            if let Some(p) = pts.iter().find(|p| p.0 == (b + 1) as f64) {
                chart
                    .draw_series([Circle::new(*p, 9, RGBColor(30, 150, 60).stroke_width(3))])
                    .map_err(plots::err)?;
            }
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.9))
            .border_style(BLACK)
            .label_font((FONT, 14))
            .position(SeriesLabelPosition::UpperLeft)
            .draw()
            .map_err(plots::err)?;
        Ok(())
    })
}

/// Validation runs against the lab value and its replicates' spread.
fn validation_plot(study: &Study, st: &StageResult) -> Result<String, String> {
    let sims: Vec<f64> = st
        .records
        .iter()
        .filter_map(|r| r.as_ref()?.response)
        .collect();
    if sims.is_empty() {
        return Err("no finished runs".into());
    }
    let t = &study.target;
    let labs: Vec<f64> = if t.replicates.is_empty() {
        vec![t.value]
    } else {
        t.replicates.clone()
    };
    let (lo, hi) = sims
        .iter()
        .chain(&labs)
        .fold((f64::MAX, f64::MIN), |(a, b), y| (a.min(*y), b.max(*y)));
    let pad = 0.15 * (hi - lo).max(0.02 * hi.abs().max(1e-9));
    let mean = sims.iter().sum::<f64>() / sims.len() as f64;
    plots::render(|root| {
        let mut chart = ChartBuilder::on(root)
            .caption(format!("Validation: {}", t.response), (FONT, 22))
            .margin(14)
            .x_label_area_size(44)
            .y_label_area_size(64)
            .build_cartesian_2d(0.0..3.0, (lo - pad)..(hi + pad))
            .map_err(plots::err)?;
        chart
            .configure_mesh()
            .disable_x_mesh()
            .x_labels(4)
            .x_label_formatter(&|x: &f64| {
                if (x - 1.0).abs() < 0.01 {
                    "lab".into()
                } else if (x - 2.0).abs() < 0.01 {
                    "simulation".into()
                } else {
                    String::new()
                }
            })
            .y_desc(t.response.as_str())
            .draw()
            .map_err(plots::err)?;
        let red = RGBColor(200, 30, 30);
        let blue = RGBColor(40, 100, 200);
        let spread = |v: &[f64], i: usize| 0.9 + 0.2 * (i as f64 + 0.5) / v.len() as f64;
        chart
            .draw_series(
                labs.iter()
                    .enumerate()
                    .map(|(i, y)| Circle::new((spread(&labs, i), *y), 5, red.filled())),
            )
            .map_err(plots::err)?;
        chart
            .draw_series(
                sims.iter()
                    .enumerate()
                    .map(|(i, y)| Circle::new((1.0 + spread(&sims, i), *y), 5, blue.filled())),
            )
            .map_err(plots::err)?;
        for (x, y, c) in [(1.0, t.value, red), (2.0, mean, blue)] {
            chart
                .draw_series(LineSeries::new(
                    [(x - 0.25, y), (x + 0.25, y)],
                    c.stroke_width(3),
                ))
                .map_err(plots::err)?;
        }
        Ok(())
    })
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
