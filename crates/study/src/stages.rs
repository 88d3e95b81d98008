//! The plan, stage by stage. [`replay`] walks the stages in order: it works out each stage's runs
//! from the study and the outcome of the stages before it, takes the finished ones from the store,
//! has the executor run the rest, and concludes the stage (fit, selection, best step, optimum,
//! validation). Because every run's seed and settings follow from the study and the stored
//! results alone, an interrupted study replays to the same point and goes on from there.

use std::any::Any;
use std::collections::HashMap;
use std::sync::Arc;

use doe::design::Design;
use doe::optimize::Solution;
use doe::{Factor, Fit};

use crate::design_stages::factors_of;
use crate::spec::Study;
use crate::store::{RunRecord, Status};
use crate::surrogate_stages::SurrogateOutcome;

/// Where a curve target's digest starts in a fingerprint.
const CURVE_LINE: &str = "# curve comparison = ";
/// Where a combined objective's terms start in a fingerprint.
const OBJECTIVE_LINE: &str = "# objective = ";

/// How much lower a desirability may be and still count as equally good as the optimum's.
pub const EQUALLY_GOOD: f64 = 1e-3;

/// One simulation the plan asks for.
#[derive(Clone, Debug)]
pub struct RunSpec {
    pub stage: usize,
    pub stage_kind: &'static str,
    /// Position in the stage's (randomised) run order.
    pub index: usize,
    /// Which point of the stage it is: runs of one point are replicates (their mean is
    /// modelled); without replicates, `index`.
    pub point: usize,
    /// What the point is: factorial, center, axial, step 3, replicate 2, ...
    pub label: String,
    /// Settings of the stage's factors, coded.
    pub coded: Vec<f64>,
    /// Every parameter's value (actual units), in the study's order.
    pub values: Vec<f64>,
    pub seed: u64,
}

impl RunSpec {
    /// The exact test this run simulates, and its seed.
    pub fn fingerprint(&self, study: &Study) -> String {
        let Some(combine) = study.combine else {
            let test = toml::to_string(&study.test_with(0, &self.values)).unwrap_or_default();
            // A curve target's runs also depend on the lab curves they were compared with.
            let curve = match &study.target.curve {
                Some(c) => format!("{CURVE_LINE}{}\n", c.comparison().digest()),
                None => String::new(),
            };
            return format!("{test}\n# seed = {}\n{curve}", self.seed);
        };
        // Several targets: every test, and how the targets score the run.
        let mut f = String::new();
        for (k, t) in study.tests.iter().enumerate() {
            let test = toml::to_string(&study.test_with(k, &self.values)).unwrap_or_default();
            f.push_str(&format!("# test {}\n{test}\n", t.name));
        }
        f.push_str(&format!("# seed = {}\n", self.seed));
        for t in &study.targets {
            if let Some(c) = &t.curve {
                f.push_str(&format!("{CURVE_LINE}{}\n", c.comparison().digest()));
            }
        }
        let terms = serde_json::to_string(&study.terms()).unwrap_or_default();
        f.push_str(&format!("{OBJECTIVE_LINE}{combine:?} {terms}\n"));
        f
    }

    pub fn inputs(&self, study: &Study) -> serde_json::Value {
        serde_json::Value::Object(
            study
                .parameters
                .iter()
                .zip(&self.values)
                .map(|(p, v)| (p.name.clone(), serde_json::json!(v)))
                .collect(),
        )
    }
}

/// Mean, spread and error of the validation runs.
#[derive(Clone, Debug)]
pub struct Validation {
    pub runs: usize,
    pub mean: f64,
    pub std: Option<f64>,
    /// None for a minimised response (the curve MSE): its mean says how far off it is.
    pub relative_error_percent: Option<f64>,
    /// With several targets, each target's validation, in the study's order.
    pub targets: Vec<Validation>,
}

impl Validation {
    /// Mean, standard deviation and relative error of `ys` against `target`.
    pub fn of(ys: &[f64], target: &crate::spec::Target) -> Validation {
        let n = ys.len();
        let mean = ys.iter().sum::<f64>() / n as f64;
        let std = (n >= 2)
            .then(|| (ys.iter().map(|y| (y - mean).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt());
        Validation {
            runs: n,
            mean,
            std,
            relative_error_percent: target.relative_error_percent(mean),
            targets: Vec::new(),
        }
    }
}

/// Each target's simulated value in a run of a study with several targets (what the run
/// stored under `targets`).
pub fn target_values(r: &RunRecord) -> Option<Vec<f64>> {
    r.outputs["targets"]
        .as_array()?
        .iter()
        .map(|t| t["simulated"].as_f64())
        .collect()
}

/// What a stage planned and found.
#[derive(Clone, Debug)]
pub struct StageResult {
    pub index: usize,
    pub kind: &'static str,
    pub title: String,
    /// The parameters the stage varies (indices into the study's parameters).
    pub active: Vec<usize>,
    /// The design's factors (the active parameters over the stage's ranges).
    pub factors: Vec<Factor>,
    pub design: Option<Design>,
    pub runs: Vec<RunSpec>,
    /// The stored outcome of each run, when it has finished.
    pub records: Vec<Option<RunRecord>>,
    /// The model the stage fitted (reduced when asked), and the full one before reduction.
    pub fit: Option<Fit>,
    pub full_fit: Option<Fit>,
    /// Screening: the parameters that go on.
    pub selected: Vec<usize>,
    /// Steepest: the step nearest the lab value.
    pub best_step: Option<usize>,
    pub solutions: Vec<Solution>,
    /// Optimize: for each factor (coded, in `active` order), the stretch around the first
    /// solution over which the desirability stays within [`EQUALLY_GOOD`] of its best, the
    /// other factors held: the whole range for a factor the model does not determine.
    pub equally_good: Vec<(f64, f64)>,
    /// Optimize in a desirability study: each target's model, in the study's order (the
    /// solutions' predicted responses follow it).
    pub target_fits: Vec<Fit>,
    /// Optimize and validate: every parameter's value at the calibrated point.
    pub calibrated: Option<Vec<f64>>,
    pub validation: Option<Validation>,
    /// Validate: which of the optimisation's solutions was validated and calibrated (0: the
    /// first; another only with `candidates`).
    pub chosen_solution: usize,
    /// What a surrogate stage (bayesopt, ga_bp, smc) fitted and found.
    pub surrogate: Option<SurrogateOutcome>,
    /// What a stage found in a type of its own (a sweep's fitted curve and inversion): read
    /// with [`StageResult::outcome`].
    pub outcome: Option<Arc<dyn Any + Send + Sync>>,
    pub notes: Vec<String>,
    pub complete: bool,
}

impl StageResult {
    pub(crate) fn new(index: usize, kind: &'static str) -> StageResult {
        StageResult {
            index,
            kind,
            title: String::new(),
            active: Vec::new(),
            factors: Vec::new(),
            design: None,
            runs: Vec::new(),
            records: Vec::new(),
            fit: None,
            full_fit: None,
            selected: Vec::new(),
            best_step: None,
            solutions: Vec::new(),
            equally_good: Vec::new(),
            target_fits: Vec::new(),
            calibrated: None,
            validation: None,
            chosen_solution: 0,
            surrogate: None,
            outcome: None,
            notes: Vec::new(),
            complete: false,
        }
    }

    pub fn done(&self) -> usize {
        self.records
            .iter()
            .flatten()
            .filter(|r| r.status == Status::Done)
            .count()
    }

    pub fn failed(&self) -> usize {
        self.records
            .iter()
            .flatten()
            .filter(|r| r.status == Status::Failed)
            .count()
    }

    pub fn pending(&self) -> usize {
        self.records.iter().filter(|r| r.is_none()).count()
    }

    /// The finished runs with a response, with their specs.
    pub(crate) fn successes(&self) -> Vec<(&RunSpec, f64)> {
        self.runs
            .iter()
            .zip(&self.records)
            .filter_map(|(s, r)| {
                r.as_ref()
                    .filter(|r| r.status == Status::Done)
                    .and_then(|r| r.response)
                    .map(|y| (s, y))
            })
            .collect()
    }

    /// The stage's own outcome, when it is a `T`.
    pub fn outcome<T: Any>(&self) -> Option<&T> {
        self.outcome.as_deref()?.downcast_ref::<T>()
    }

    /// Each point's finished runs with a response (replicates of one point together), in the
    /// order of the points' first runs: mean, spread and count.
    pub(crate) fn point_means(&self) -> Vec<PointMean<'_>> {
        let mut out: Vec<PointMean<'_>> = Vec::new();
        let mut ys: Vec<Vec<f64>> = Vec::new();
        for (s, y) in self.successes() {
            match out.iter().position(|p| p.spec.point == s.point) {
                Some(i) => ys[i].push(y),
                None => {
                    out.push(PointMean {
                        spec: s,
                        mean: 0.0,
                        std: None,
                        runs: 0,
                    });
                    ys.push(vec![y]);
                }
            }
        }
        for (p, ys) in out.iter_mut().zip(ys) {
            let n = ys.len();
            p.mean = ys.iter().sum::<f64>() / n as f64;
            p.std = (n >= 2).then(|| {
                (ys.iter().map(|y| (y - p.mean).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt()
            });
            p.runs = n;
        }
        out
    }

    /// Validate: the finished runs at the calibrated point, with their responses (with several
    /// candidates, the chosen solution's runs; the others were made at other points).
    pub(crate) fn validation_successes(&self) -> Vec<(&RunSpec, f64)> {
        self.successes()
            .into_iter()
            .filter(|(s, _)| self.calibrated.as_ref().is_none_or(|c| &s.values == c))
            .collect()
    }

    /// Each target's simulated values, as [`Self::point_means`] gives the response (the mean
    /// of each point's replicates); empty unless every such run has them (a study with several
    /// targets).
    pub(crate) fn target_values(&self, targets: usize) -> Vec<Vec<f64>> {
        let runs: Option<Vec<(usize, Vec<f64>)>> = self
            .runs
            .iter()
            .zip(&self.records)
            .filter_map(|(s, r)| {
                r.as_ref()
                    .filter(|r| r.status == Status::Done && r.response.is_some())
                    .map(|r| (s.point, r))
            })
            .map(|(p, r)| {
                target_values(r)
                    .filter(|v| v.len() == targets)
                    .map(|v| (p, v))
            })
            .collect();
        let Some(runs) = runs else {
            return Vec::new();
        };
        let mut points: Vec<(usize, Vec<f64>, usize)> = Vec::new();
        for (p, v) in runs {
            match points.iter_mut().find(|q| q.0 == p) {
                Some(q) => {
                    q.1.iter_mut().zip(&v).for_each(|(a, b)| *a += b);
                    q.2 += 1;
                }
                None => points.push((p, v, 1)),
            }
        }
        points
            .into_iter()
            .map(|(_, v, n)| v.into_iter().map(|x| x / n as f64).collect())
            .collect()
    }

    pub(crate) fn first_failure(&self) -> String {
        self.runs
            .iter()
            .zip(&self.records)
            .find_map(|(s, r)| {
                r.as_ref().filter(|r| r.status == Status::Failed).map(|r| {
                    format!(
                        "; run {}: {}",
                        s.index + 1,
                        r.error.clone().unwrap_or_default()
                    )
                })
            })
            .unwrap_or_default()
    }
}

/// A point of a stage: its first finished run, and the mean of its finished runs' responses.
pub(crate) struct PointMean<'a> {
    pub spec: &'a RunSpec,
    pub mean: f64,
    pub std: Option<f64>,
    pub runs: usize,
}

/// Where a replay ended.
#[derive(Clone, Debug, PartialEq)]
pub enum State {
    Complete,
    /// Runs of this stage have not been made (status and report replay without running).
    Pending {
        stage: usize,
    },
    /// The stage cannot go on (too many failed runs, a design that does not fit); why.
    Stopped(String),
}

pub struct Replay {
    pub stages: Vec<StageResult>,
    pub state: State,
}

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

/// What the stages pass on.
pub struct Context {
    pub(crate) active: Vec<usize>,
    /// Every parameter's current value: fixed ones where they were fixed, active ones at the
    /// centre of their region.
    pub(crate) values: Vec<f64>,
    /// Each parameter's current range, actual units.
    pub(crate) region: Vec<(f64, f64)>,
    /// Where each parameter may be set: its range, or as far past it as a steepest path went.
    pub(crate) limits: Vec<(f64, f64)>,
    pub(crate) model: Option<(Fit, Vec<usize>)>,
    /// With several targets: each target's simulated value in each run the model was fitted
    /// on (in the model's row order), for the optimiser to model them one by one.
    pub(crate) model_targets: Vec<Vec<f64>>,
    /// Whether that model is a response surface (quadratic) rather than a screening (linear).
    pub(crate) model_quadratic: bool,
    /// Screening: first-order coefficient of each selected parameter.
    pub(crate) direction: Vec<f64>,
    pub(crate) calibrated: Option<Vec<f64>>,
    /// The optimisation's distinct solutions as every parameter's value, best first (the first
    /// is `calibrated`): what a validation with several candidates replicates.
    pub(crate) candidates: Vec<Vec<f64>>,
    /// Which of the last optimisation's solutions `calibrated` is (0: the first).
    pub(crate) chosen_solution: usize,
    /// Every parameter's value in the finished run nearest the lab value so far.
    pub(crate) best: Option<Vec<f64>>,
    /// Every finished run of the completed stages that gave a response: its stage (index into
    /// the plan), values and response (what a ga_bp stage without runs of its own trains on).
    pub(crate) finished: Vec<(usize, Vec<f64>, f64)>,
}

/// `v` to 12 significant digits: coded-to-actual arithmetic leaves 0.29999999999999993 where the
/// design means 0.3, and stored values, fingerprints and tables should say 0.3.
pub(crate) fn tidy(v: f64) -> f64 {
    format!("{v:.11e}").parse().unwrap_or(v)
}

/// A run's seed: distinct for every stage and run, fixed by the study's seed.
pub fn run_seed(study_seed: u64, stage: usize, index: usize) -> u64 {
    let mut z = study_seed
        .wrapping_add((stage as u64) << 32)
        .wrapping_add(index as u64)
        .wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    (z ^ (z >> 31)) % 1_000_000_000
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
        by_key.insert((r.stage, r.index), r.clone());
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
                    if r.fingerprint != spec.fingerprint(study) {
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
    stage: &dyn crate::stage::Stage,
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
    stage: &dyn crate::stage::Stage,
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
                return format!(
                    "{head} was simulated with {} = {}, the study now gives {}",
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
    let objective_part = |f: &str| f.split(OBJECTIVE_LINE).nth(1).unwrap_or("").to_string();
    let now = spec.fingerprint(study);
    if test_part(&r.fingerprint) == test_part(&now) {
        if objective_part(&r.fingerprint) != objective_part(&now) {
            return format!("{head} was scored with other targets, weights or limits");
        }
        return format!("{head} was compared with other lab curves or another normalisation");
    }
    format!("{head} was simulated with other test settings (the test's fixed settings changed)")
}

pub fn sig(v: f64) -> String {
    doe::fit::fmt_sig(v)
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
