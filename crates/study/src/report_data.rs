//! The report's machine-readable files: `results.csv` (every stored run) and `summary.json`
//! (the calibrated values, the validation, the targets and every stage with its model).

use crate::record::{Replay, State};
use crate::report_settings::Fate;
use crate::spec::Study;
use crate::stages::{self};
use crate::store::{RunRecord, Status};
use crate::targets_report;

pub(crate) fn results_csv(study: &Study, stored: &[RunRecord]) -> Result<String, String> {
    let mut w = csv::Writer::from_writer(Vec::new());
    let mut head: Vec<String> = ["stage", "stage_kind", "run", "seed", "status"]
        .iter()
        .map(|s| s.to_string())
        .collect();
    head.extend(study.parameters.iter().map(|p| p.name.clone()));
    head.extend([
        study.target.response.clone(),
        "relative_error_percent".into(),
        "wall_s".into(),
        "finished_at".into(),
        "error_kind".into(),
        "error".into(),
        "host".into(),
        "executor".into(),
    ]);
    head.extend(targets_report::csv_head(study));
    w.write_record(&head).map_err(|e| e.to_string())?;
    for r in stored {
        let mut row = vec![
            (r.stage + 1).to_string(),
            r.stage_kind.clone(),
            (r.index + 1).to_string(),
            r.seed.to_string(),
            r.status.as_str().to_string(),
        ];
        for p in &study.parameters {
            row.push(
                r.inputs
                    .get(&p.name)
                    .and_then(|v| v.as_f64())
                    .map(|v| v.to_string())
                    .unwrap_or_default(),
            );
        }
        row.push(r.response.map(|v| v.to_string()).unwrap_or_default());
        row.push(
            r.response
                .and_then(|v| study.target.relative_error_percent(v))
                .map(|e| format!("{e:.4}"))
                .unwrap_or_default(),
        );
        row.push(format!("{:.3}", r.wall_s));
        row.push(r.finished_at.clone());
        row.push(
            r.error_kind
                .map(|k| k.as_str().to_string())
                .unwrap_or_default(),
        );
        row.push(r.error.clone().unwrap_or_default());
        row.push(r.host.clone());
        row.push(r.executor.clone());
        row.extend(targets_report::csv_row(study, r));
        w.write_record(&row).map_err(|e| e.to_string())?;
    }
    String::from_utf8(w.into_inner().map_err(|e| e.to_string())?).map_err(|e| e.to_string())
}

/// Where the stored runs were made, for the report: how many by Slurm tasks (with their jobs
/// and nodes) and how many on a local machine (with its name).
pub(crate) fn where_ran(stored: &[RunRecord]) -> String {
    use std::collections::BTreeSet;
    let list = |set: BTreeSet<&str>| set.into_iter().collect::<Vec<_>>().join(", ");
    let mut parts = Vec::new();
    let slurm: Vec<&RunRecord> = stored
        .iter()
        .filter(|r| r.executor.starts_with("slurm job "))
        .collect();
    if !slurm.is_empty() {
        let jobs: BTreeSet<&str> = slurm
            .iter()
            .filter_map(|r| {
                // `slurm job 14_3`: the array's id is the leading digits.
                let rest = &r.executor["slurm job ".len()..];
                let id = &rest[..rest
                    .find(|c: char| !c.is_ascii_digit())
                    .unwrap_or(rest.len())];
                (!id.is_empty()).then_some(id)
            })
            .collect();
        let nodes: BTreeSet<&str> = slurm
            .iter()
            .map(|r| r.host.as_str())
            .filter(|h| !h.is_empty())
            .collect();
        parts.push(format!(
            "{} as tasks of Slurm job arrays (job{} {}; node{} {})",
            slurm.len(),
            if jobs.len() == 1 { "" } else { "s" },
            crate::text::job_list(jobs.into_iter()),
            if nodes.len() == 1 { "" } else { "s" },
            list(nodes)
        ));
    }
    let local: Vec<&RunRecord> = stored.iter().filter(|r| r.executor == "local").collect();
    if !local.is_empty() {
        let hosts: BTreeSet<&str> = local.iter().map(|r| r.host.as_str()).collect();
        parts.push(format!(
            "{} by the local executor on {}",
            local.len(),
            list(hosts)
        ));
    }
    let unknown = stored.len() - slurm.len() - local.len();
    if unknown > 0 {
        parts.push(format!("{unknown} by a demcal that did not record where"));
    }
    if parts.is_empty() {
        "no runs stored yet".into()
    } else {
        parts.join("; ")
    }
}

pub fn summary_json(study: &Study, r: &Replay, stored: &[RunRecord]) -> serde_json::Value {
    use serde_json::json;
    let calibrated = stages::calibrated(study, &r.stages).map(|v| {
        study
            .parameters
            .iter()
            .zip(v)
            .map(|(p, x)| (p.name.clone(), json!(x)))
            .collect::<serde_json::Map<_, _>>()
    });
    let validation = r.stages.iter().rev().find_map(|s| s.validation().cloned());
    let state = match &r.state {
        State::Complete => "complete".to_string(),
        State::Pending { stage } => format!("pending at stage {}", stage + 1),
        State::Stopped(why) => format!("stopped: {why}"),
    };
    json!({
        "study": study.name,
        "study_file": study.path.display().to_string(),
        "test": study.test_kind(),
        "state": state,
        "target": {
            "response": study.target.response,
            "value": study.target.value,
            "unit": study.target.unit,
            "minimised": study.target.minimised(),
            "curve": study.target.curve.as_ref().map(|c| json!({
                "curve": c.curve,
                "lab_curves": c.files,
                "normalisation": c.normalisation,
                "replicates": c.lab.replicates.len(),
            })),
            "replicates": study.target.replicates,
            "std": study.target.std(),
        },
        "parameters": study.parameters.iter().zip(crate::report_settings::fates(study, r)).map(|(p, fate)| {
            let (status, why, range) = match fate {
                Fate::Calibrated => ("calibrated", None, None),
                Fate::Held(why) => ("held", Some(why), None),
                Fate::Undetermined(why, Some((lo, hi))) => ("undetermined", Some(why), Some(json!([lo, hi]))),
                Fate::Undetermined(why, None) => ("undetermined", Some(why), None),
            };
            json!({
                "name": p.name,
                "paths": p.paths.iter().map(|x| x.0.text.clone()).collect::<Vec<_>>(),
                "min": p.min,
                "max": p.max,
                "scale": if p.scale == doe::Scale::Log { "log" } else { "linear" },
                "unit": crate::report_settings::parameter_unit(p),
                "status": status,
                "why": why,
                "interval_95": range,
            })
        }).collect::<Vec<_>>(),
        "calibrated": calibrated,
        "validation_mean": validation.as_ref().map(|v| v.mean),
        "validation_std": validation.as_ref().and_then(|v| v.std),
        "validation_runs": validation.as_ref().map(|v| v.runs),
        // Which of the optimisation's solutions the validation chose (1: the first).
        "validation_solution": r.stages.iter().rev().find(|s| s.validation().is_some()).map(|s| s.chosen_solution() + 1),
        "relative_error_percent": validation.as_ref().and_then(|v| v.relative_error_percent),
        "validation": validation.as_ref().map(|v| crate::uncertainty_report::validation_summary(v, &study.target)),
        "uncertainty": crate::uncertainty_report::summary(study, &r.stages),
        "objective": targets_report::summary(study, validation.as_ref()),
        "runs_made": where_ran(stored),
        "imports": study.imports.iter().map(|i| json!({
            "study": i.study,
            "parameter": i.parameter,
            "value": i.value,
            "paths": i.paths.iter().map(|x| x.0.text.clone()).collect::<Vec<_>>(),
        })).collect::<Vec<_>>(),
        "stages": r.stages.iter().map(|s| {
            let mut entry = json!({
            "stage": s.index + 1,
            "kind": s.kind,
            "title": s.title,
            "runs": s.runs.len(),
            "done": s.done(),
            "failed": s.failed(),
            "complete": s.complete,
            "selected": s.selected().iter().map(|&i| study.parameters[i].name.clone()).collect::<Vec<_>>(),
            "best_step": s.best_step().map(|b| b + 1),
            "model": s.fit.as_ref().map(|f| f.to_json()),
            "solutions": s.solutions(),
            "notes": s.notes,
            });
            if let Some((key, value)) = crate::surrogate_report::stage_json(study, s) {
                entry[key] = value;
            }
            if let Some(value) = study.plan.get(s.index).and_then(|p| p.summary(study, s)) {
                entry["outcome"] = value;
            }
            entry
        }).collect::<Vec<_>>(),
        "runs_total": stored.len(),
        "runs_failed": stored.iter().filter(|r| r.status == Status::Failed).count(),
        "simulation_wall_s": stored.iter().map(|r| r.wall_s).sum::<f64>(),
        "demcal_version": env!("CARGO_PKG_VERSION"),
    })
}
