//! The report's parts for a study with several targets: the targets and how they combine, the
//! optimiser's prediction of each target, each target's validation, and their place in
//! `summary.json` and `results.csv`.

use std::fmt::Write;

use serde_json::json;

use crate::record::{StageResult, Validation};
use crate::spec::{Combine, Study};
use crate::store::RunRecord;
use crate::text::{esc, sig};

fn with_unit(v: String, unit: &str) -> String {
    if unit.is_empty() {
        v
    } else {
        format!("{v} {unit}")
    }
}

/// The targets table: each target's test, response, lab value, weight or importance and limits,
/// and its validation when there is one.
pub(crate) fn targets_section(h: &mut String, study: &Study, validation: Option<&Validation>) {
    let Some(combine) = study.combine else {
        return;
    };
    write!(
        h,
        "<p>{} targets, combined into one objective per run, <b>{}</b> = {}.{}</p>",
        study.targets.len(),
        esc(combine.response()),
        esc(combine.describe()),
        match combine {
            Combine::Weighted => "",
            Combine::Desirability =>
                " A target's desirability is 1 at the lab value and 0 at its limits; the optimise stage models each target's response and maximises their overall desirability, as Design-Expert does.",
        }
    )
    .unwrap();
    let (wcol, lcol) = match combine {
        Combine::Weighted => ("weight", ""),
        Combine::Desirability => ("importance", "<th>limits</th>"),
    };
    write!(
        h,
        "<table><tr><th class=\"l\">test</th><th class=\"l\">response</th><th>lab</th><th>{wcol}</th>{lcol}<th>validation</th><th>relative error</th></tr>"
    )
    .unwrap();
    for (i, t) in study.targets.iter().enumerate() {
        let lab = if t.minimised() {
            format!(
                "lab curves ({} replicates), minimised",
                t.curve.as_ref().map_or(0, |c| c.lab.replicates.len())
            )
        } else {
            match t.std() {
                Some(sd) => with_unit(
                    format!(
                        "{} (mean ± SD over {} replicates)",
                        crate::report_figures::mean_sd(t.value, sd),
                        t.replicates.len()
                    ),
                    &t.unit,
                ),
                None => with_unit(sig(t.value), &t.unit),
            }
        };
        let weight = match combine {
            Combine::Weighted => sig(t.weight),
            Combine::Desirability => t.importance.to_string(),
        };
        let limits = match combine {
            Combine::Weighted => String::new(),
            Combine::Desirability => {
                format!("<td>{} .. {}</td>", sig(t.low), sig(t.high))
            }
        };
        let v = validation.and_then(|v| v.targets.get(i));
        let val = v
            .map(|v| {
                let m = match v.std {
                    Some(sd) => format!(
                        "{} (mean ± SD over {} runs)",
                        crate::report_figures::mean_sd(v.mean, sd),
                        v.runs
                    ),
                    None => format!("{} (N = {})", sig(v.mean), v.runs),
                };
                with_unit(m, &t.unit)
            })
            .unwrap_or_else(|| "-".into());
        let err = v
            .map(|v| match v.relative_error_percent {
                Some(e) => format!("{e:.2} %"),
                None => format!(
                    "relative curve error {:.2} %",
                    100.0 * t.term().relative_error(v.mean)
                ),
            })
            .unwrap_or_else(|| "-".into());
        write!(
            h,
            "<tr><td class=\"l\">{}</td><td class=\"l\">{}</td><td>{lab}</td><td>{weight}</td>{limits}<td>{val}</td><td>{err}</td></tr>",
            esc(&study.tests[t.test].name),
            esc(&t.response),
        )
        .unwrap();
    }
    h.push_str("</table>");
}

/// The optimise stage of a desirability study: each solution's predicted value and desirability
/// of every target, and the overall desirability.
pub(crate) fn optimize_table(h: &mut String, study: &Study, st: &StageResult) {
    if st.target_fits().is_empty() {
        return;
    }
    h.push_str("<p>Each target's model and its fit:</p><table><tr><th class=\"l\">response</th><th>R²</th><th>adj. R²</th><th>model p</th></tr>");
    for f in st.target_fits() {
        write!(
            h,
            "<tr><td class=\"l\">{}</td><td>{:.4}</td><td>{:.4}</td><td>{}</td></tr>",
            esc(&f.experiment.response_name),
            f.r2,
            f.adj_r2,
            f.model.p.map(doe::fit::fmt_p).unwrap_or_else(|| "-".into())
        )
        .unwrap();
    }
    h.push_str("</table><table><tr><th>#</th>");
    for f in &st.factors {
        write!(h, "<th>{}</th>", esc(&f.name)).unwrap();
    }
    for t in &study.targets {
        write!(
            h,
            "<th>predicted {} of {} (d)</th>",
            esc(&t.response),
            esc(&study.tests[t.test].name)
        )
        .unwrap();
    }
    h.push_str("<th>desirability D</th></tr>");
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
        for (y, d) in s.responses.iter().zip(&s.individual) {
            write!(h, "<td>{} ({d:.3})</td>", sig(*y)).unwrap();
        }
        write!(h, "<td>{:.3}</td></tr>", s.desirability).unwrap();
    }
    h.push_str("</table>");
}

/// `summary.json`'s `targets` and `objective` (null for a study with one target).
pub(crate) fn summary(study: &Study, validation: Option<&Validation>) -> serde_json::Value {
    let Some(combine) = study.combine else {
        return serde_json::Value::Null;
    };
    json!({
        "combine": combine,
        "response": combine.response(),
        "targets": study.targets.iter().enumerate().map(|(i, t)| {
            let v = validation.and_then(|v| v.targets.get(i));
            json!({
                "test": study.tests[t.test].name,
                "response": t.response,
                "value": t.value,
                "unit": t.unit,
                "replicates": t.replicates,
                "std": t.std(),
                "minimised": t.minimised(),
                "weight": t.weight,
                "importance": t.importance,
                "low": t.low,
                "high": t.high,
                "validation_mean": v.map(|v| v.mean),
                "validation_std": v.and_then(|v| v.std),
                "validation_runs": v.map(|v| v.runs),
                "relative_error_percent": v.map(|v| v.relative_error_percent
                    .unwrap_or(100.0 * t.term().relative_error(v.mean))),
            })
        }).collect::<Vec<_>>(),
    })
}

/// `results.csv`'s extra column names: one per target (`test.response`).
pub(crate) fn csv_head(study: &Study) -> Vec<String> {
    if study.combine.is_none() {
        return Vec::new();
    }
    study
        .targets
        .iter()
        .map(|t| format!("{}.{}", study.tests[t.test].name, t.response))
        .collect()
}

/// A run's values of the extra columns: each target's simulated value, also in a failed run
/// for the targets whose tests finished before the failure.
pub(crate) fn csv_row(study: &Study, r: &RunRecord) -> Vec<String> {
    if study.combine.is_none() {
        return Vec::new();
    }
    simulated(study, r)
        .into_iter()
        .map(|y| y.map(|y| y.to_string()).unwrap_or_default())
        .collect()
}

/// Each target's simulated value in a run (None where its test did not finish or gave none);
/// all None when the run's targets are not the study's (a store from before they were kept).
fn simulated(study: &Study, r: &RunRecord) -> Vec<Option<f64>> {
    match r.outputs["targets"].as_array() {
        Some(rows) if rows.len() == study.targets.len() => {
            rows.iter().map(|t| t["simulated"].as_f64()).collect()
        }
        _ => vec![None; study.targets.len()],
    }
}

/// For the runs table's status of a failed run of several targets: what the tests that
/// finished before the failure gave (`; kept: stiff value = 13.9`), or nothing.
pub(crate) fn kept(study: &Study, r: &RunRecord) -> String {
    if study.combine.is_none() || r.status != crate::store::Status::Failed {
        return String::new();
    }
    let kept: Vec<String> = study
        .targets
        .iter()
        .zip(simulated(study, r))
        .filter_map(|(t, y)| {
            let y = y?;
            Some(format!(
                "{} {} = {}",
                study.tests[t.test].name,
                t.response,
                sig(y)
            ))
        })
        .collect();
    if kept.is_empty() {
        String::new()
    } else {
        format!("; kept: {}", kept.join(", "))
    }
}
