//! The plan, stage by stage. [`replay`] walks the stages in order: it works out each stage's runs
//! from the study and the outcome of the stages before it, takes the finished ones from the store,
//! has the executor run the rest, and concludes the stage (fit, selection, best step, optimum,
//! validation). Because every run's seed and settings follow from the study and the stored
//! results alone, an interrupted study replays to the same point and goes on from there.

use std::collections::HashMap;

use crate::design_stages::factors_of;
pub use crate::record::*;
use crate::record::{CURVE_LINE, OBJECTIVE_LINE};
use crate::spec::Study;
use crate::store::RunRecord;
pub use crate::text::{sig, tidy};

/// Runs simulations for a replay; stores each one as it finishes.
pub trait Execute {
    /// Runs `runs` of `stage` and returns their records (also stored). An error (an interrupt)
    /// ends the replay; finished runs are already stored.
    fn execute(
        &mut self,
        study: &Study,
        stage: &StageResult,
        runs: &[RunSpec],
    ) -> Result<Vec<RunRecord>, String>;
}

/// Replays the plan; with an executor, runs what is missing.
pub fn replay(
    study: &Study,
    stored: &[RunRecord],
    mut exec: Option<&mut dyn Execute>,
) -> Result<Replay, String> {
    let mut by_key: HashMap<(usize, usize), RunRecord> = HashMap::new();
    for r in stored {
        if r.stage >= study.plan.len() {
            return Err(stale(
                study,
                &format!(
                    "stage {} ({}) has stored runs, but the plan now has {} stages",
                    r.stage + 1,
                    r.stage_kind,
                    study.plan.len()
                ),
            ));
        }
        // A run of several targets is scored with the targets as they are now.
        by_key.insert((r.stage, r.index), crate::job::rescored(study, r.clone()));
    }
    let n = study.parameters.len();
    let mut ctx = Context {
        active: (0..n).collect(),
        values: study.parameters.iter().map(|p| p.middle()).collect(),
        region: study.parameters.iter().map(|p| (p.min, p.max)).collect(),
        limits: study.parameters.iter().map(|p| (p.min, p.max)).collect(),
        model: None,
        model_targets: Vec::new(),
        model_quadratic: false,
        direction: Vec::new(),
        calibrated: None,
        candidates: Vec::new(),
        candidate_uncertainties: Vec::new(),
        chosen_solution: 0,
        best: None,
        finished: Vec::new(),
    };
    let mut stages: Vec<StageResult> = Vec::new();
    for (si, stage) in study.plan.iter().enumerate() {
        let mut st = match plan_stage(study, si, stage.as_ref(), &ctx) {
            Ok(st) => st,
            Err(why) => {
                return Ok(Replay {
                    stages,
                    state: State::Stopped(format!("stage {} ({}): {why}", si + 1, stage.kind())),
                })
            }
        };
        // Stored runs must be the runs the study asks for now. An iterative stage (bayesopt,
        // smc) plans a round at a time: once a round is complete, `extend` plans the next from
        // its results, until it says the stage is done.
        loop {
            for spec in &st.runs[st.records.len()..] {
                if let Some(r) = by_key.remove(&(si, spec.index)) {
                    if r.stage_kind != spec.stage_kind {
                        return Err(stale(
                            study,
                            &format!(
                                "stage {} was a {} stage, the plan now makes it {}",
                                si + 1,
                                r.stage_kind,
                                spec.stage_kind
                            ),
                        ));
                    }
                    if !spec.fingerprint_matches(study, &r.fingerprint) {
                        return Err(stale(study, &describe_change(study, spec, &r)));
                    }
                    st.records.push(Some(r));
                } else {
                    st.records.push(None);
                }
            }
            if st.pending() > 0 {
                match exec.as_deref_mut() {
                    None => {
                        stages.push(st);
                        return Ok(Replay {
                            stages,
                            state: State::Pending { stage: si },
                        });
                    }
                    Some(ex) => {
                        let missing: Vec<RunSpec> = st
                            .runs
                            .iter()
                            .zip(&st.records)
                            .filter(|(_, r)| r.is_none())
                            .map(|(s, _)| s.clone())
                            .collect();
                        for r in ex.execute(study, &st, &missing)? {
                            let slot = st
                                .runs
                                .iter()
                                .position(|s| s.index == r.index && r.stage == si)
                                .ok_or_else(|| {
                                    format!(
                                        "stage {} ({}): the executor returned run {}, which the stage does not have (it has runs 1 to {})",
                                        si + 1,
                                        stage.kind(),
                                        r.index + 1,
                                        st.runs.len()
                                    )
                                })?;
                            st.records[slot] = Some(r);
                        }
                        if st.pending() > 0 {
                            stages.push(st);
                            return Ok(Replay {
                                stages,
                                state: State::Pending { stage: si },
                            });
                        }
                    }
                }
            }
            match stage.next_round(study, &mut st, &ctx) {
                Ok(true) => continue,
                Ok(false) => break,
                Err(why) => {
                    let why = format!("stage {} ({}): {why}", si + 1, stage.kind());
                    stages.push(st);
                    return Ok(Replay {
                        stages,
                        state: State::Stopped(why),
                    });
                }
            }
        }
        if let Err(why) = conclude(study, stage.as_ref(), &mut st, &mut ctx) {
            let why = format!("stage {} ({}): {why}", si + 1, stage.kind());
            stages.push(st);
            return Ok(Replay {
                stages,
                state: State::Stopped(why),
            });
        }
        st.complete = true;
        ctx.finished.extend(
            st.successes()
                .iter()
                .map(|(s, y)| (si, s.values.clone(), *y)),
        );
        stages.push(st);
        ctx.best = best_run(study, &stages).map(|(s, _)| s.values.clone());
    }
    if let Some(((s, i), r)) = by_key.iter().next() {
        return Err(stale(
            study,
            &format!(
                "stage {} ({}) has a stored run {} that the plan no longer makes",
                s + 1,
                r.stage_kind,
                i + 1
            ),
        ));
    }
    Ok(Replay {
        stages,
        state: State::Complete,
    })
}

/// A stage's runs: the active parameters and their factors, then what the stage plans.
fn plan_stage(
    study: &Study,
    si: usize,
    stage: &dyn crate::spec::Stage,
    ctx: &Context,
) -> Result<StageResult, String> {
    let mut st = StageResult::new(si, stage.kind());
    st.active = ctx.active.clone();
    st.factors = factors_of(study, ctx)?;
    stage.plan(study, &mut st, ctx)?;
    Ok(st)
}

/// Once a stage's runs are done: what every stage checks first, then its own conclusion.
fn conclude(
    study: &Study,
    stage: &dyn crate::spec::Stage,
    st: &mut StageResult,
    ctx: &mut Context,
) -> Result<(), String> {
    if st.runs.is_empty() && stage.runs_simulations() {
        return Err(st.notes.join("; "));
    }
    if st.failed() > 0 {
        st.notes.push(format!(
            "{} of {} runs failed{}",
            st.failed(),
            st.runs.len(),
            st.first_failure()
        ));
    }
    stage.conclude(study, st, ctx)
}

fn stale(study: &Study, what: &str) -> String {
    format!(
        "{}: the stored runs no longer match {}: {what}. Restore the study file, or start over with `demcal run {} --restart` (the old store is kept beside it)",
        study.store_path().display(),
        study.path.display(),
        study.path.display()
    )
}

fn describe_change(study: &Study, spec: &RunSpec, r: &RunRecord) -> String {
    let head = format!(
        "stage {} ({}) run {}",
        spec.stage + 1,
        spec.stage_kind,
        spec.index + 1
    );
    for (p, v) in study.parameters.iter().zip(&spec.values) {
        match r.inputs.get(&p.name).and_then(|x| x.as_f64()) {
            None => {
                return format!("{head} was simulated without the parameter {}", p.name);
            }
            Some(old) if (old - v).abs() > 1e-12 * v.abs().max(1e-300) => {
                // Stored runs are scored with the targets as they are now, so a new lab value,
                // weight or limit moves what a stage plans from the runs before it.
                return format!(
                    "{head} was simulated with {} = {}, the study now gives {} (a stage that chooses its runs from the results before it asks for other runs when a lab value, weight or limit changed)",
                    p.name,
                    sig(old),
                    sig(*v)
                );
            }
            _ => {}
        }
    }
    if r.seed != spec.seed {
        return format!(
            "{head} was simulated with seed {}, the study now gives {}",
            r.seed, spec.seed
        );
    }
    let test_part = |f: &str| {
        let f = f.split(CURVE_LINE).next().unwrap_or("");
        f.split(OBJECTIVE_LINE).next().unwrap_or("").to_string()
    };
    // The targets' lab values, weights and limits are not in a fingerprint (the runs are scored
    // again); a stored one may end in them (`OBJECTIVE_LINE`), from before.
    let now = spec.fingerprint(study);
    if test_part(&r.fingerprint) == test_part(&now) {
        return format!("{head} was compared with other lab curves or another normalisation");
    }
    format!("{head} was simulated with other test settings (the test's fixed settings changed)")
}

/// The finished run nearest the lab value, over all stages.
pub fn best_run<'a>(study: &Study, stages: &'a [StageResult]) -> Option<(&'a RunSpec, f64)> {
    stages.iter().flat_map(|s| s.successes()).min_by(|a, b| {
        (a.1 - study.target.value)
            .abs()
            .total_cmp(&(b.1 - study.target.value).abs())
    })
}

/// The calibrated values: the last optimised (or validated) point, else the best run so far.
pub fn calibrated(study: &Study, stages: &[StageResult]) -> Option<Vec<f64>> {
    stages
        .iter()
        .rev()
        .find_map(|s| s.calibrated.clone())
        .or_else(|| best_run(study, stages).map(|(s, _)| s.values.clone()))
}
