//! `validate`: replicate simulations at the calibrated point (or at each of the optimisation's
//! best solutions, the one nearest the lab value then calibrated), their mean, spread and
//! relative error against the lab value.

use std::any::Any;

use crate::spec::{Section, Stage};
use crate::stage::table::{StageDef, StageTable};
use crate::design_stages::enough;
use crate::limits::{MAX_REPLICATES, MAX_SOLUTIONS};
use crate::spec::Study;
use crate::record::{Context, run_seed, RunSpec, StageResult, target_values, ValidateOutcome, Validation};
use crate::text::sig;
use crate::store::{RunRecord, Status};

#[derive(Clone, Debug, PartialEq)]
pub struct Validate {
    pub replicates: usize,
    /// How many of the optimisation's distinct solutions are replicated, best first: all their
    /// runs go at once (they fill the cores of a large machine that three replicates would
    /// leave idle), and the one whose mean comes nearest the lab value is calibrated.
    pub candidates: usize,
}

impl StageDef for Validate {
    const NAME: &'static str = "validate";
    const KEYS: &'static [&'static str] = &["replicates", "candidates"];

    fn parse(t: &StageTable) -> Result<Self, String> {
        Ok(Validate {
            replicates: t.count("replicates", 3, 1, Some(MAX_REPLICATES))?,
            candidates: t.count("candidates", 1, 1, Some(MAX_SOLUTIONS))?,
        })
    }
}

impl Stage for Validate {
    fn kind(&self) -> &'static str {
        Self::NAME
    }

    fn heading(&self) -> &'static str {
        "validation"
    }

    fn plan(&self, study: &Study, st: &mut StageResult, ctx: &Context) -> Result<(), String> {
        let si = st.index;
        let (replicates, candidates) = (&self.replicates, &self.candidates);
        // The optimum; without an optimisation, the best run so far; else the middle.
        let point = ctx
            .calibrated
            .clone()
            .or_else(|| ctx.best.clone())
            .unwrap_or_else(|| ctx.values.clone());
        // With several candidates, the optimisation's next solutions after it (as many as
        // it found).
        let points: Vec<Vec<f64>> = if ctx.candidates.first() == Some(&point) {
            ctx.candidates.iter().take(*candidates).cloned().collect()
        } else {
            vec![point.clone()]
        };
        if *candidates > points.len() {
            st.notes.push(if ctx.candidates.first() == Some(&point) {
                format!(
                    "{candidates} candidates asked for, the optimisation found {} distinct solution(s): all are replicated",
                    points.len()
                )
            } else {
                format!("{candidates} candidates asked for, but no optimisation since the last validation gave solutions: the calibrated point alone is replicated")
            });
        }
        st.title = if points.len() == 1 {
            format!("{replicates} replicate simulations at the calibrated point")
        } else {
            format!(
                "{replicates} replicate simulations at each of the {} best solutions",
                points.len()
            )
        };
        for (c, values) in points.iter().enumerate() {
            for r in 0..*replicates {
                let i = c * replicates + r;
                st.runs.push(RunSpec {
                    stage: si,
                    point: i,
                    stage_kind: st.kind,
                    index: i,
                    label: if points.len() == 1 {
                        format!("replicate {}", r + 1)
                    } else {
                        format!("solution {} replicate {}", c + 1, r + 1)
                    },
                    coded: Vec::new(),
                    values: values.clone(),
                    seed: run_seed(study.seed, si, i),
                });
            }
        }
        st.calibrated = Some(point);
        Ok(())
    }

    fn conclude(
        &self,
        study: &Study,
        st: &mut StageResult,
        ctx: &mut Context,
    ) -> Result<(), String> {
        let replicates = &self.replicates;
        enough(st, 1, "validation")?;
        // With several candidates, the one whose runs come nearest the lab value (lowest,
        // for a minimised response) is validated and calibrated.
        let candidates = st.runs.len().div_ceil(*replicates);
        let found: Vec<Option<Validation>> = (0..candidates)
            .map(|c| candidate_validation(study, st, *replicates, c))
            .collect();
        let miss = |v: &Validation| {
            if study.target.minimised() {
                v.mean
            } else {
                (v.mean - study.target.value).abs()
            }
        };
        let chosen = (0..candidates)
            .filter_map(|c| found[c].as_ref().map(|v| (c, miss(v))))
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(c, _)| c)
            .ok_or("no validation run gave a response")?;
        if candidates > 1 {
            for (c, v) in found.iter().enumerate() {
                st.notes.push(match v {
                    Some(v) => format!(
                        "solution {}: {} = {}{} over {} run(s){}",
                        c + 1,
                        study.target.response,
                        sig(v.mean),
                        v.std.map(|s| format!(" ± {}", sig(s))).unwrap_or_default(),
                        v.runs,
                        v.relative_error_percent
                            .map(|e| format!(", {e:.2} % from the lab value"))
                            .unwrap_or_default()
                    ),
                    None => format!("solution {}: no run gave a response", c + 1),
                });
            }
            st.notes.push(format!(
                "solution {} validates nearest the lab value: it is the calibrated point",
                chosen + 1
            ));
            st.notes.push("the runs that chose it also measure its error, which therefore reads a little low; a second validate stage replicates the chosen point with new seeds".into());
            st.calibrated = Some(st.runs[chosen * replicates].values.clone());
            // The intervals follow the point chosen (the optimisation's were of its first).
            if chosen > 0 {
                st.uncertainty = ctx.candidate_uncertainties.get(chosen).cloned().map(|mut u| {
                    u.method = format!("at the solution validation chose ({}): {}", chosen + 1, u.method);
                    u
                });
            }
        }
        // A validation of one point replicates what the context calibrated.
        let chosen_solution = if candidates > 1 {
            chosen
        } else {
            ctx.chosen_solution
        };
        ctx.chosen_solution = chosen_solution;
        st.set_outcome(ValidateOutcome {
            validation: found[chosen].clone(),
            chosen_solution,
        });
        // A later stage (another validation) starts from the chosen point alone.
        ctx.calibrated = st.calibrated.clone();
        ctx.candidates.clear();
        ctx.candidate_uncertainties.clear();
        Ok(())
    }

    fn report(&self, s: &mut Section<'_>) {
        crate::report_validation::validation_html(s.h, s.figs, s.study, s.stages, s.st);
    }

    fn as_any(&self) -> &dyn Any {
        self
    }
}

/// The validation of candidate `c` of a validation stage (its runs are `c * replicates ..`):
/// `None` when none of them gave a response.
fn candidate_validation(
    study: &Study,
    st: &StageResult,
    replicates: usize,
    c: usize,
) -> Option<Validation> {
    let runs: Vec<&RunRecord> = st
        .runs
        .iter()
        .zip(&st.records)
        .filter(|(s, _)| s.index / replicates == c)
        .filter_map(|(_, r)| r.as_ref())
        .filter(|r| r.status == Status::Done && r.response.is_some())
        .collect();
    let ys: Vec<f64> = runs.iter().filter_map(|r| r.response).collect();
    if ys.is_empty() {
        return None;
    }
    let mut v = Validation::of(&ys, &study.target);
    let per_run: Vec<Vec<f64>> = runs
        .iter()
        .filter_map(|r| target_values(r))
        .filter(|t| t.len() == study.targets.len())
        .collect();
    if study.combine.is_some() && per_run.len() == ys.len() {
        v.targets = study
            .targets
            .iter()
            .enumerate()
            .map(|(i, t)| {
                let ys: Vec<f64> = per_run.iter().map(|r| r[i]).collect();
                Validation::of(&ys, t)
            })
            .collect();
    }
    Some(v)
}
