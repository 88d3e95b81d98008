//! The plan: the ordered stages of a study, each with its settings, read from the study file's
//! `plan` list (a stage's name, or a table with `stage = ...` and its keys). What each stage
//! reads is its own (`stage::*`); the registry there names them all.

use std::sync::Arc;

pub use crate::record::SearchRegion;
pub use crate::stage::rsm::RsmDesign;
pub use crate::stage::screening::ScreeningDesign;
use crate::stage::{parse_stage, StageTable};
pub use crate::stage::{stage_keys, stage_list, Stage, STAGE_NAMES};

pub use crate::limits::*;

pub(crate) fn parse_plan(
    plan: Option<&toml::Value>,
    err: &dyn Fn(&str, String) -> String,
    params: &[(String, f64, f64)],
) -> Result<Vec<Arc<dyn Stage>>, String> {
    let stages = stage_list();
    let items = match plan {
        None => {
            return Err(err(
                "plan",
                format!("missing: an ordered list of stages ({stages}), e.g. plan = [\"rsm\", \"optimize\", \"validate\"]"),
            ))
        }
        Some(toml::Value::Array(a)) if !a.is_empty() => a,
        Some(_) => {
            return Err(err(
                "plan",
                format!("expected a non-empty list of stages ({stages})"),
            ))
        }
    };
    let mut plan: Vec<Arc<dyn Stage>> = Vec::new();
    for (i, item) in items.iter().enumerate() {
        let key = format!("plan[{i}]");
        let empty = toml::Table::new();
        let (kind, t) = match item {
            toml::Value::String(s) => (s.clone(), &empty),
            toml::Value::Table(t) => (
                t.get("stage")
                    .and_then(|v| v.as_str())
                    .ok_or_else(|| {
                        err(
                            &format!("{key}.stage"),
                            format!("missing: which stage ({stages})"),
                        )
                    })?
                    .to_string(),
                t,
            ),
            _ => {
                return Err(err(
                    &key,
                    format!("expected a stage name ({stages}) or a table with stage = ..."),
                ))
            }
        };
        let Some(allowed) = stage_keys(&kind) else {
            return Err(err(
                &format!("{key}.stage"),
                format!("unknown stage \"{kind}\" (expected one of: {stages})"),
            ));
        };
        for k in t.keys() {
            if k != "stage" && !allowed.contains(&k.as_str()) {
                return Err(err(
                    &format!("{key}.{k}"),
                    format!(
                        "unknown key for a {kind} stage (expected {})",
                        allowed.join(", ")
                    ),
                ));
            }
        }
        let table = StageTable::new(&key, t, params, err);
        let stage = parse_stage(&kind, &table).expect("a stage with keys is registered")?;
        // What each stage reads from the ones before it.
        stage.follows(&plan).map_err(|why| err(&key, why))?;
        plan.push(stage);
    }
    Ok(plan)
}
