//! The uncertainty of the calibrated values as the report, `summary.json` and the terminal give
//! it: each parameter's 95 % interval from the last stage that calibrated it, its value rounded to
//! the digits the interval supports, the identifiability flags, the Sobol indices with their
//! figure, and the validation's interval against the lab's.

use std::fmt::Write;

use plotters::prelude::*;
use serde_json::json;

use crate::record::{StageResult, Validation};
use crate::spec::Study;
use crate::target::Target;
use crate::text::{esc, sig, FigureSink};
use crate::uncertainty::{rounded, validation_check, ParameterInterval, Sobol, ValidationCheck};

/// Each parameter's interval from the last stage that calibrated it, with that stage's index.
pub(crate) fn per_parameter(
    study: &Study,
    stages: &[StageResult],
) -> Vec<Option<(usize, ParameterInterval)>> {
    let mut out = vec![None; study.parameters.len()];
    for st in stages {
        if let Some(u) = &st.uncertainty {
            for p in &u.intervals {
                if let Some(slot) = out.get_mut(p.parameter) {
                    *slot = Some((st.index, p.clone()));
                }
            }
        }
    }
    out
}

/// A parameter's name by index, for flags.
fn namer(study: &Study) -> impl Fn(usize) -> String + '_ {
    move |i| {
        study
            .parameters
            .get(i)
            .map_or_else(String::new, |p| p.name.clone())
    }
}

/// "0.115 (95 % interval 0.110 to 0.121)", with an open end marked.
pub(crate) fn interval_text(p: &ParameterInterval) -> String {
    match p.interval {
        Some((lo, hi)) => {
            let (v, a, b) = rounded(p.value, lo, hi);
            let a = if p.open.0 { format!("≤ {a}") } else { a };
            let b = if p.open.1 { format!("≥ {b}") } else { b };
            let open = if p.open.0 || p.open.1 {
                ", open where it reaches the end of the range searched"
            } else {
                ""
            };
            format!("{v} (95 % interval {a} to {b}{open})")
        }
        None => format!(
            "{} (no interval: no setting matches the lab value within the model's uncertainty)",
            sig(p.value)
        ),
    }
}

/// The value rounded as its interval allows (4 significant digits without one).
pub(crate) fn value_text(p: &ParameterInterval) -> String {
    match p.interval {
        Some((lo, hi)) => rounded(p.value, lo, hi).0,
        None => sig(p.value),
    }
}

/// The terminal's lines: each calibrated value with its interval and flags.
pub(crate) fn status_lines(study: &Study, stages: &[StageResult]) -> Vec<String> {
    let name = namer(study);
    per_parameter(study, stages)
        .into_iter()
        .flatten()
        .map(|(_, p)| {
            let mut line = format!(
                "  {} = {}",
                study.parameters[p.parameter].name,
                interval_text(&p)
            );
            for f in &p.flags {
                write!(line, "\n      ⚠ {}", f.text(&name)).unwrap();
            }
            line
        })
        .collect()
}

/// The validation's check against the lab (None without a lab value to match).
pub(crate) fn check(v: &Validation, t: &Target) -> Option<ValidationCheck> {
    (!t.minimised()).then(|| validation_check(v.mean, v.std, v.runs, t))
}

/// The validation line's interval part for the terminal.
pub(crate) fn validation_words(v: &Validation, t: &Target) -> Option<String> {
    let c = check(v, t)?;
    let mut s = String::new();
    if let Some((lo, hi)) = c.mean_interval {
        write!(s, "95 % interval of the mean {} to {}", sig(lo), sig(hi)).unwrap();
    }
    if let Some((lo, hi)) = c.lab_interval {
        write!(s, "; the lab's {} to {}", sig(lo), sig(hi)).unwrap();
    }
    if let Some((lo, hi)) = c.relative_error_interval {
        write!(s, "; relative error's interval {lo:.1} to {hi:.1} %").unwrap();
    }
    if !s.is_empty() {
        s.push_str("; ");
    }
    s.push_str(&c.statement);
    Some(s)
}

/// The summary's entries: per parameter (by name), the method, the Sobol tables.
pub(crate) fn summary(study: &Study, stages: &[StageResult]) -> serde_json::Value {
    let name = namer(study);
    let params: serde_json::Map<String, serde_json::Value> = per_parameter(study, stages)
        .into_iter()
        .flatten()
        .map(|(stage, p)| {
            (
                study.parameters[p.parameter].name.clone(),
                json!({
                    "value": p.value,
                    "rounded": value_text(&p),
                    "interval_95": p.interval.map(|(a, b)| [a, b]),
                    "open_low": p.open.0,
                    "open_high": p.open.1,
                    "stage": stage + 1,
                    "identified": p.flags.is_empty() && p.interval.is_some(),
                    "flags": p.flags.iter().map(|f| json!({"kind": f.kind(), "text": f.text(&name)})).collect::<Vec<_>>(),
                }),
            )
        })
        .collect();
    let methods: Vec<serde_json::Value> = stages
        .iter()
        .filter_map(|st| {
            st.uncertainty
                .as_ref()
                .map(|u| json!({"stage": st.index + 1, "kind": st.kind, "method": u.method}))
        })
        .collect();
    let sobol: Vec<serde_json::Value> = stages
        .iter()
        .filter_map(|st| st.uncertainty.as_ref().map(|u| (st, u)))
        .flat_map(|(st, u)| {
            u.sobol.iter().map(move |s| {
                json!({
                    "stage": st.index + 1,
                    "of": s.of,
                    "samples": s.samples,
                    "indices": s.parameters.iter().enumerate().map(|(j, &pi)| json!({
                        "parameter": study.parameters[pi].name,
                        "first_order": s.first[j],
                        "total": s.total[j],
                    })).collect::<Vec<_>>(),
                })
            })
        })
        .collect();
    json!({
        "level": crate::uncertainty::LEVEL,
        "parameters": params,
        "methods": methods,
        "sobol": sobol,
    })
}

/// The validation entry of the summary.
pub(crate) fn validation_summary(v: &Validation, t: &Target) -> serde_json::Value {
    match check(v, t) {
        Some(c) => json!({
            "mean_interval_95": c.mean_interval.map(|(a, b)| [a, b]),
            "lab_interval_95": c.lab_interval.map(|(a, b)| [a, b]),
            "difference": c.difference,
            "difference_interval_95": c.difference_interval.map(|(a, b)| [a, b]),
            "relative_error_interval_95": c.relative_error_interval.map(|(a, b)| [a, b]),
            "compatible": c.compatible,
            "statement": c.statement,
        }),
        None => serde_json::Value::Null,
    }
}

/// The report's section: the table of intervals and flags, how they were made, and the Sobol
/// indices with their figure.
pub(crate) fn section(
    h: &mut String,
    figs: &mut dyn FigureSink,
    study: &Study,
    stages: &[StageResult],
) {
    let per = per_parameter(study, stages);
    if per.iter().all(Option::is_none) {
        return;
    }
    let name = namer(study);
    h.push_str("<h2>Uncertainty and identifiability</h2>");
    h.push_str("<div class=\"scroll\"><table><tr><th class=\"l\">Parameter</th><th>Calibrated</th><th>95 % interval</th><th class=\"l\">Stage</th><th class=\"l\">Identifiability</th></tr>");
    for (stage, p) in per.iter().flatten() {
        let interval = match p.interval {
            Some((lo, hi)) => {
                let (_, a, b) = rounded(p.value, lo, hi);
                format!(
                    "{}{a} to {}{b}",
                    if p.open.0 { "≤ " } else { "" },
                    if p.open.1 { "≥ " } else { "" }
                )
            }
            None => "none".into(),
        };
        let flags = if p.flags.is_empty() {
            if p.interval.is_some() {
                "identified".to_string()
            } else {
                "no interval".to_string()
            }
        } else {
            p.flags
                .iter()
                .map(|f| format!("⚠ {}", f.text(&name)))
                .collect::<Vec<_>>()
                .join("<br>")
        };
        write!(
            h,
            "<tr{}><td class=\"l name\">{}</td><td>{}</td><td>{}</td><td class=\"l\">{} ({})</td><td class=\"l wrap\">{}</td></tr>",
            if p.flags.is_empty() { "" } else { " class=\"flag\"" },
            esc(&study.parameters[p.parameter].display_name()),
            esc(&value_text(p)),
            esc(&interval),
            stage + 1,
            esc(stages[*stage].kind),
            // The flags' own text is escaped piece by piece; the breaks between them are ours.
            flags.split("<br>").map(esc).collect::<Vec<_>>().join("<br>")
        )
        .unwrap();
    }
    h.push_str("</table></div>");
    for st in stages {
        if let Some(u) = &st.uncertainty {
            write!(
                h,
                "<p class=\"note\">Stage {} ({}): the intervals are {}. A value is rounded to the digits its interval supports. A parameter flagged is not reported as calibrated: at a range end the best setting may lie beyond the range; one the objective hardly depends on is not fixed by it; two on a ridge trade off, and the lab value is matched all along it.</p>",
                st.index + 1,
                esc(st.kind),
                esc(&u.method)
            )
            .unwrap();
        }
    }
    for st in stages {
        let Some(u) = &st.uncertainty else { continue };
        for (n, s) in u.sobol.iter().enumerate() {
            sobol_table(h, study, s);
            figs.row(
                h,
                vec![(
                    format!("stage{}-sobol-{}", st.index + 1, n + 1),
                    sobol_plot(study, s),
                    format!(
                        "Global sensitivity of {} (stage {}, {}): Sobol first-order index (blue: the share of its variance each parameter causes alone) and total index (orange: alone and with the others), each parameter uniform over the range searched; {} samples.",
                        esc(&s.of),
                        st.index + 1,
                        st.kind,
                        s.samples
                    ),
                )],
            );
        }
    }
}

fn sobol_table(h: &mut String, study: &Study, s: &Sobol) {
    write!(
        h,
        "<p>Sobol indices of {}:</p><div class=\"scroll\"><table><tr><th class=\"l\">Parameter</th><th>First order S<sub>i</sub></th><th>Total S<sub>Ti</sub></th><th class=\"l\">Reads</th></tr>",
        esc(&s.of)
    )
    .unwrap();
    for (j, &pi) in s.parameters.iter().enumerate() {
        let (first, total) = (s.first[j], s.total[j]);
        let reads = if total < crate::uncertainty::INSENSITIVE_TOTAL {
            "hardly matters"
        } else if total - first > 0.1 {
            "matters, much of it through interactions"
        } else {
            "matters"
        };
        write!(
            h,
            "<tr><td class=\"l name\">{}</td><td>{first:.3}</td><td>{total:.3}</td><td class=\"l\">{reads}</td></tr>",
            esc(&study.parameters[pi].display_name())
        )
        .unwrap();
    }
    h.push_str("</table></div>");
}

/// Bars of the first-order (blue) and total (orange) indices of each parameter, the first
/// parameter at the top.
fn sobol_plot(study: &Study, s: &Sobol) -> Result<String, String> {
    use doe::plots;
    let names: Vec<String> = s
        .parameters
        .iter()
        .map(|&pi| study.parameters[pi].display_name())
        .collect();
    let k = names.len();
    if k == 0 {
        return Err("no parameters".into());
    }
    let blue = RGBColor(40, 100, 200);
    let orange = RGBColor(230, 120, 20);
    // Parameter j owns the band k-1-j .. k-j of the y axis; its name sits at the band's middle.
    let name_at = |v: f64| -> String {
        let band = v.floor();
        if (v - band - 0.5).abs() > 1e-6 || band < 0.0 || band >= k as f64 {
            return String::new();
        }
        names[k - 1 - band as usize].clone()
    };
    plots::render(|root| {
        let mut chart = ChartBuilder::on(root)
            .caption(
                "Sobol indices: first order (blue), total (orange)",
                (plots::FONT, 22),
            )
            .margin(16)
            .x_label_area_size(66)
            .y_label_area_size(210)
            .build_cartesian_2d(0.0..1.0f64, 0.0..k as f64)
            .map_err(plots::err)?;
        chart
            .configure_mesh()
            .disable_y_mesh()
            .label_style((plots::FONT, plots::TEXT))
            .axis_desc_style((plots::FONT, plots::DESC))
            .x_desc("index (share of the variance)")
            .x_labels(6)
            .y_labels(2 * k + 1)
            .y_label_formatter(&|v| name_at(*v))
            .draw()
            .map_err(plots::err)?;
        for (series, colour, (lo, hi)) in [
            (&s.first, blue, (0.52, 0.86)),
            (&s.total, orange, (0.14, 0.48)),
        ] {
            chart
                .draw_series(series.iter().enumerate().map(|(j, &v)| {
                    let y = (k - 1 - j) as f64;
                    Rectangle::new([(0.0, y + lo), (v, y + hi)], colour.filled())
                }))
                .map_err(plots::err)?;
        }
        Ok(())
    })
}
