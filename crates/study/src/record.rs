//! What a study's replay is made of, as plain data: the runs a stage asks for, what a stage
//! found, what the stages pass on, where a replay ended. Near the bottom of the crate: it imports
//! only the store, the targets and the text helpers, so every layer above can use it.

use std::any::Any;
use std::sync::Arc;

use doe::design::Design;
use doe::optimize::Solution;
use doe::{Factor, Fit};
use surrogate::bayesopt::IterationSummary;
use surrogate::genetic::GaResult;
use surrogate::gp::Gp;
use surrogate::network::TrainedNetwork;
use surrogate::smc::Posterior;

use crate::store::{RunRecord, Status};

/// Where a curve target's digest starts in a fingerprint.
pub(crate) const CURVE_LINE: &str = "# curve comparison = ";
/// Where a combined objective's terms start in a fingerprint.
pub(crate) const OBJECTIVE_LINE: &str = "# objective = ";

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
    pub fn of(ys: &[f64], target: &crate::target::Target) -> Validation {
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
    /// Optimize and validate: every parameter's value at the calibrated point.
    pub calibrated: Option<Vec<f64>>,
    /// What the stage found, in its own type (`OptimizeOutcome`, `ValidateOutcome`,
    /// `SurrogateOutcome`, `SweepOutcome`, ...): set with [`StageResult::set_outcome`], read with
    /// [`StageResult::outcome`] or the accessors below.
    pub outcome: Option<Arc<dyn Any + Send + Sync>>,
    /// A calibrating stage: how well its calibrated values are known, and which are not
    /// identified (`uncertainty`).
    pub uncertainty: Option<crate::uncertainty::Uncertainty>,
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
            calibrated: None,
            outcome: None,
            uncertainty: None,
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

    /// The failed runs that failed for the machine, not their parameters
    /// (`RunErrorKind::is_transient`).
    pub fn failed_transiently(&self) -> usize {
        self.records
            .iter()
            .flatten()
            .filter(|r| {
                r.status == Status::Failed && r.error_kind.is_some_and(|k| k.is_transient())
            })
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

    /// Sets what the stage found.
    pub fn set_outcome<T: Any + Send + Sync>(&mut self, outcome: T) {
        self.outcome = Some(Arc::new(outcome));
    }

    /// Takes back what the stage found so far, to add to it (an iterative stage's rounds);
    /// None, and the outcome left alone, when it is not a `T`.
    pub fn take_outcome<T: Any + Clone + Send + Sync>(&mut self) -> Option<T> {
        let found = self.outcome.take()?;
        match found.downcast::<T>() {
            Ok(t) => Some(Arc::unwrap_or_clone(t)),
            Err(other) => {
                self.outcome = Some(other);
                None
            }
        }
    }

    /// Optimize: the solutions, best first (none for another stage).
    pub fn solutions(&self) -> &[Solution] {
        self.outcome::<OptimizeOutcome>()
            .map_or(&[], |o| o.solutions.as_slice())
    }

    /// Optimize: each factor's equally good stretch ([`OptimizeOutcome::equally_good`]).
    pub fn equally_good(&self) -> &[(f64, f64)] {
        self.outcome::<OptimizeOutcome>()
            .map_or(&[], |o| o.equally_good.as_slice())
    }

    /// Optimize in a desirability study: each target's model ([`OptimizeOutcome::target_fits`]).
    pub fn target_fits(&self) -> &[Fit] {
        self.outcome::<OptimizeOutcome>()
            .map_or(&[], |o| o.target_fits.as_slice())
    }

    /// Validate: the validation of the calibrated point.
    pub fn validation(&self) -> Option<&Validation> {
        self.outcome::<ValidateOutcome>()?.validation.as_ref()
    }

    /// Validate: which of the optimisation's solutions was validated (0: the first).
    pub fn chosen_solution(&self) -> usize {
        self.outcome::<ValidateOutcome>()
            .map_or(0, |o| o.chosen_solution)
    }

    /// A surrogate stage (bayesopt, ga_bp, smc): what it fitted and found.
    pub fn surrogate(&self) -> Option<&SurrogateOutcome> {
        self.outcome::<SurrogateOutcome>()
    }

    /// Screening: the parameters that go on (none for another stage).
    pub fn selected(&self) -> &[usize] {
        self.outcome::<ScreeningOutcome>()
            .map_or(&[], |o| o.selected.as_slice())
    }

    /// Steepest: the step nearest the lab value (index into the runs).
    pub fn best_step(&self) -> Option<usize> {
        self.outcome::<SteepestOutcome>().map(|o| o.best_step)
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
    /// Each candidate's uncertainty, in the same order: a validation that chooses another
    /// solution than the first reports that one's intervals.
    pub(crate) candidate_uncertainties: Vec<crate::uncertainty::Uncertainty>,
    /// Which of the last optimisation's solutions `calibrated` is (0: the first).
    pub(crate) chosen_solution: usize,
    /// Every parameter's value in the finished run nearest the lab value so far.
    pub(crate) best: Option<Vec<f64>>,
    /// Every finished run of the completed stages that gave a response: its stage (index into
    /// the plan), values and response (what a ga_bp stage without runs of its own trains on).
    pub(crate) finished: Vec<(usize, Vec<f64>, f64)>,
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

/// What a surrogate stage found, for the report and the summary.
#[derive(Clone, Debug)]
pub enum SurrogateOutcome {
    BayesOpt(Box<BoOutcome>),
    GaBp(Box<GaBpOutcome>),
    Smc(SmcOutcome),
}

#[derive(Clone, Debug)]
pub struct BoOutcome {
    /// Runs planned in each round (the hypercube first).
    pub rounds: Vec<usize>,
    /// After each finished round: the best objective observed and the GP's predicted minimum.
    pub history: Vec<IterationSummary>,
    pub stop: Option<String>,
    /// The last GP, fitted to every finished run's objective (coded factors of the stage).
    pub gp: Option<Gp>,
}

#[derive(Clone, Debug)]
pub struct GaBpOutcome {
    /// Where the training rows came from.
    pub source: String,
    /// Training rows: the active parameters coded over `factors`, and the response.
    pub x: Vec<Vec<f64>>,
    pub y: Vec<f64>,
    pub trained: TrainedNetwork,
    /// GA-BP-GA: the coded inputs whose prediction is nearest the lab value.
    pub search: GaResult,
    pub predicted: f64,
}

#[derive(Clone, Debug)]
pub struct SmcRound {
    /// First run index of the round, and how many runs it planned.
    pub start: usize,
    pub count: usize,
    /// Each planned run's proposal density (coded box), in run order.
    pub proposal_density: Vec<f64>,
    /// Runs that gave a response, with their normalised weights.
    pub used: Vec<usize>,
    pub weights: Vec<f64>,
    /// The posterior of the active parameters in actual units.
    pub posterior: Posterior,
}

#[derive(Clone, Debug)]
pub struct SmcOutcome {
    pub rounds: Vec<SmcRound>,
    pub stop: Option<String>,
}

/// Where `optimize` searches the fitted model.
#[derive(Clone, Debug, PartialEq)]
pub enum SearchRegion {
    /// The factorial box, coded ±1: the screening or CCD ranges (Design-Expert's "in range").
    Cube,
    /// As far as the design's runs reach on each factor: out to the axial points (±alpha) of a
    /// central composite design, as seeds 002-004 optimise; ±1 for a box design.
    Axial,
    /// Limits in the parameters' own units, by name; a factor not named keeps ±1.
    Limits(Vec<(String, f64, f64)>),
}

/// What optimize found.
#[derive(Clone, Debug, Default)]
pub struct OptimizeOutcome {
    /// The solutions, best first.
    pub solutions: Vec<Solution>,
    /// For each factor (coded, in `active` order), the stretch around the first solution over
    /// which the desirability stays within [`EQUALLY_GOOD`] of its best, the other factors held:
    /// the whole range for a factor the model does not determine.
    pub equally_good: Vec<(f64, f64)>,
    /// In a desirability study: each target's model, in the study's order (the solutions'
    /// predicted responses follow it).
    pub target_fits: Vec<Fit>,
}

/// What validate found.
#[derive(Clone, Debug, Default)]
pub struct ValidateOutcome {
    /// The validation of the calibrated point (None when too few runs finished).
    pub validation: Option<Validation>,
    /// Which of the optimisation's solutions was validated and calibrated (0: the first;
    /// another only with `candidates`).
    pub chosen_solution: usize,
}

impl SearchRegion {
    /// Words for the report.
    pub fn describe(&self) -> String {
        match self {
            SearchRegion::Cube => "within its coded range −1 to +1".into(),
            SearchRegion::Axial => {
                "out to the design's axial points (coded −alpha to +alpha)".into()
            }
            SearchRegion::Limits(l) => format!(
                "within the limits given: {}",
                l.iter()
                    .map(|(n, lo, hi)| format!("{n} {lo} .. {hi}"))
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        }
    }
}

/// What a screening found: the parameters that go on (indices into the study's).
#[derive(Clone, Debug, PartialEq)]
pub struct ScreeningOutcome {
    pub selected: Vec<usize>,
}

/// What a steepest path found: the step nearest the lab value (index into its runs).
#[derive(Clone, Debug, PartialEq)]
pub struct SteepestOutcome {
    pub best_step: usize,
}
