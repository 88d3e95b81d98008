//! What a study is: which virtual tests, which parameters over which ranges, the lab values, the
//! plan of stages and where the runs are made; and the two traits its plan and executor are
//! made of ([`Stage`], [`Executor`]). Reading a study file is `load`; the stages and executors
//! themselves are `stage::*` and `executor::*`.

use std::any::Any;
use std::fmt::Debug;
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::sync::Arc;

use doe::{Factor, Scale};

use crate::paths::ParamPath;
use crate::record::{Context, Replay, StageResult, CURVE_LINE, OBJECTIVE_LINE};
use crate::store::{RunRecord, Store};
pub use crate::target::{Combine, Target, Term};
use crate::text::FigureSink;

/// A parameter to calibrate: one value written into one or more places of the study's tests.
#[derive(Clone, Debug)]
pub struct Parameter {
    pub name: String,
    /// Each path, and the tests (indices) it is written into: every test that has it.
    pub paths: Vec<(ParamPath, Vec<usize>)>,
    pub min: f64,
    pub max: f64,
    pub scale: Scale,
    /// The dimension of `min` and `max` when they were given with a unit (`"1 MPa"`): values are
    /// then written into the tests with the dimension's base unit, so that the test's reader
    /// checks that the key takes that dimension.
    pub dimension: Option<dem::units::Dimension>,
    /// The unit the report's tables and axes give (`unit`, else the base unit of a range given
    /// with a unit); None: told from the path's last key (a friction has none, a density kg/m³).
    pub unit: Option<String>,
    /// How the report names it (`label`), and its symbol (`symbol`), when the study gives them.
    pub label: Option<String>,
    pub symbol: Option<String>,
}

impl Parameter {
    /// How the report names it: its label (or name), and its symbol when the study gives one
    /// ("bead-bead rolling friction μᵣ").
    pub fn display_name(&self) -> String {
        let name = self.label.as_deref().unwrap_or(&self.name);
        match &self.symbol {
            Some(s) => format!("{name} {s}"),
            None => name.to_string(),
        }
    }

    /// The factor over `lo..hi` (actual units) in this parameter's scale. A stage can narrow a
    /// range until its ends meet (a steepest path through a tiny range); that is an error naming
    /// the parameter, for the stage to report.
    pub fn factor(&self, lo: f64, hi: f64) -> Result<Factor, String> {
        Factor::new(&self.name, lo, hi, self.scale).map_err(|_| {
            format!(
                "parameter {}: its range has shrunk to {lo} .. {hi}, too narrow for a design",
                self.name
            )
        })
    }

    /// The value the coded level is linear in (the value, or its log10).
    pub fn transformed(&self, actual: f64) -> f64 {
        match self.scale {
            Scale::Linear => actual,
            Scale::Log => actual.log10(),
        }
    }

    pub fn actual(&self, transformed: f64) -> f64 {
        match self.scale {
            Scale::Linear => transformed,
            Scale::Log => 10f64.powf(transformed),
        }
    }

    /// The middle of the range (geometric for a logarithmic parameter).
    pub fn middle(&self) -> f64 {
        self.actual(0.5 * (self.transformed(self.min) + self.transformed(self.max)))
    }
}

/// A value calibrated by another study, written into this study's test: how calibrations chain
/// (particle-steel friction from an incline first, then particle-particle from a heap).
#[derive(Clone, Debug)]
pub struct Import {
    /// The other study's file, as given, and the summary the value was read from.
    pub study: String,
    pub summary: PathBuf,
    /// The parameter's name in the other study.
    pub parameter: String,
    /// Where the value went, and into which tests.
    pub paths: Vec<(ParamPath, Vec<usize>)>,
    pub value: f64,
}

/// One virtual test of a study.
#[derive(Clone, Debug)]
pub struct TestSpec {
    /// Its name in the study: `name` of a `[[test]]` table, else the test's kind (`repose`).
    pub name: String,
    /// The test file's content, before parameters are set.
    pub table: toml::Table,
    /// Where the test came from: the test file's path, or "inline".
    pub source: String,
    /// The folder the test's relative paths are taken from: the test file's, or the study's for
    /// an inline test.
    pub dir: PathBuf,
}

impl TestSpec {
    /// The test's kind (`repose`, `incline`, `function`, ...).
    pub fn kind(&self) -> &str {
        self.table
            .get("test")
            .and_then(|v| v.as_str())
            .unwrap_or("")
    }
}

/// A study read and checked.
#[derive(Clone, Debug)]
pub struct Study {
    pub path: PathBuf,
    pub name: String,
    pub seed: u64,
    /// The virtual tests each run makes, in order; most studies have one.
    pub tests: Vec<TestSpec>,
    pub parameters: Vec<Parameter>,
    /// Values taken from other studies' summaries, already written into the tests.
    pub imports: Vec<Import>,
    /// The lab targets.
    pub targets: Vec<Target>,
    /// How several targets are combined (None with one target).
    pub combine: Option<Combine>,
    /// What the stages calibrate against: the one target, or the combination of several.
    pub target: Target,
    pub plan: Vec<Arc<dyn Stage>>,
    /// Wall-clock limit of one simulation; a run over it is stopped and stored as failed.
    pub run_time_limit_s: Option<f64>,
    /// The back end the simulations run on (`backend`, or `demcal run --backend`): "cpu" or
    /// "gpu". Results do not depend on it beyond round-off, so it is not part of a run's
    /// fingerprint: a study can move between machines and keep its runs.
    pub backend: String,
    /// Where the runs are made (`[executor]`, or `demcal run --executor`): this machine or a
    /// Slurm cluster. Not part of a run's fingerprint either.
    pub executor: Arc<dyn Executor>,
    /// The study file's text, stored with the runs.
    pub text: String,
}

impl Study {
    /// The kinds of the study's tests, joined: what the study calibrates with.
    pub fn test_kind(&self) -> String {
        let kinds: Vec<&str> = self.tests.iter().map(TestSpec::kind).collect();
        kinds.join(" + ")
    }

    /// Each target's term, for a combined objective.
    pub fn terms(&self) -> Vec<Term> {
        self.targets.iter().map(Target::term).collect()
    }

    /// The folder the study lives in; the store, run outputs and report go there.
    pub fn dir(&self) -> PathBuf {
        self.path
            .parent()
            .map(Path::to_path_buf)
            .filter(|p| !p.as_os_str().is_empty())
            .unwrap_or_else(|| PathBuf::from("."))
    }

    fn stem(&self) -> String {
        self.path
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| "study".into())
    }

    /// The results store: `<study>.db` next to the study file.
    pub fn store_path(&self) -> PathBuf {
        self.dir().join(format!("{}.db", self.stem()))
    }

    /// Where each run writes its pictures and result.
    pub fn runs_dir(&self) -> PathBuf {
        self.dir().join(format!("{}.runs", self.stem()))
    }

    pub fn report_dir(&self) -> PathBuf {
        self.dir().join("report")
    }

    /// How error messages name test `k`: the study file and, with several tests, its name.
    pub fn test_label(&self, k: usize) -> String {
        test_label(
            &self.path.display().to_string(),
            &self.tests,
            &self.tests[k],
        )
    }

    /// Builds each test's starting scene at the middle of every range (materials, geometry,
    /// particles placed, overlaps checked), as the first run would, without simulating.
    pub fn check_scene(&self) -> Result<(), String> {
        let middle: Vec<f64> = self.parameters.iter().map(Parameter::middle).collect();
        for (k, t) in self.tests.iter().enumerate() {
            let file = virtual_tests::TestFile::from_table_in(
                &self.test_label(k),
                &self.test_with(k, &middle),
                &t.dir,
            )?;
            virtual_tests::check_scene(&file, Some(self.seed))?;
        }
        Ok(())
    }

    /// Test `k`'s content with every parameter set to `values` (actual units).
    pub fn test_with(&self, k: usize, values: &[f64]) -> toml::Table {
        let mut t = self.tests[k].table.clone();
        for (p, v) in self.parameters.iter().zip(values) {
            for (path, _) in p.paths.iter().filter(|(_, ks)| ks.contains(&k)) {
                path.set_quantity(&mut t, *v, p.dimension)
                    .expect("paths checked when the study was read");
            }
        }
        t
    }
}

/// How errors name test `t`: `<study>: test` for a study of one test, `<study>: test <name>`
/// with several.
pub(crate) fn test_label(file: &str, tests: &[TestSpec], t: &TestSpec) -> String {
    if tests.len() == 1 {
        format!("{file}: test")
    } else {
        format!("{file}: test {}", t.name)
    }
}

impl crate::record::RunSpec {
    /// The exact tests this run simulates, and its seed: what its stored outcome depends on. A
    /// curve target's comparison is part of it, since the run stores the curve measures made
    /// against the lab curves. The targets' lab values, weights, limits and importance are not:
    /// a run of several targets stores each target's simulated value and every test's outcome,
    /// and the replay scores them again with the targets as they are ([`crate::job::rescored`]),
    /// so a changed lab value needs no simulation.
    pub fn fingerprint(&self, study: &Study) -> String {
        if study.combine.is_none() {
            let test = toml::to_string(&study.test_with(0, &self.values)).unwrap_or_default();
            let curve = match &study.target.curve {
                Some(c) => format!("{CURVE_LINE}{}\n", c.comparison().digest()),
                None => String::new(),
            };
            return format!("{test}\n# seed = {}\n{curve}", self.seed);
        }
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
        f
    }

    /// Whether a stored run's fingerprint is this run's. Runs of several targets stored before
    /// their fingerprints left the objective out end in it (`# objective = ` and the targets'
    /// terms): they match when what comes before it does, and are scored again like any other.
    pub fn fingerprint_matches(&self, study: &Study, stored: &str) -> bool {
        let now = self.fingerprint(study);
        stored == now
            || (study.combine.is_some()
                && stored
                    .split_once(OBJECTIVE_LINE)
                    .is_some_and(|(simulated, _)| simulated == now))
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

/// A stage of a plan, with its settings.
pub trait Stage: Debug + Send + Sync + 'static {
    /// The name the plan gives it (`stage = "..."`).
    fn kind(&self) -> &'static str;

    /// The report's heading for it ("response surface").
    fn heading(&self) -> &'static str;

    /// Whether it runs simulations (optimize only searches a model).
    fn runs_simulations(&self) -> bool {
        true
    }

    /// Whether the stages before it give it what it needs: the error says what to put first.
    fn follows(&self, _before: &[Arc<dyn Stage>]) -> Result<(), String> {
        Ok(())
    }

    /// Its first runs and its title, from the study and what the stages before it found. `st`
    /// comes with the active parameters and their factors over the current region. An error
    /// stops the study with the reason.
    fn plan(&self, study: &Study, st: &mut StageResult, ctx: &Context) -> Result<(), String>;

    /// After every planned run has finished: plans another round (true) or says the stage is
    /// done (false). Only iterative stages plan rounds.
    fn next_round(
        &self,
        _study: &Study,
        _st: &mut StageResult,
        _ctx: &Context,
    ) -> Result<bool, String> {
        Ok(false)
    }

    /// Once its runs are done: fits, selects, optimises or validates, and passes on what the
    /// stages after it need.
    fn conclude(
        &self,
        study: &Study,
        st: &mut StageResult,
        ctx: &mut Context,
    ) -> Result<(), String>;

    /// What it found in its own terms, for `summary.json` (under the stage's `outcome`).
    fn summary(&self, _study: &Study, _st: &StageResult) -> Option<serde_json::Value> {
        None
    }

    /// Its part of the report, after the heading, notes and runs table the report writes for
    /// every stage.
    fn report(&self, _section: &mut Section<'_>) {}

    /// For a stage that wants another stage's settings (the report of an optimisation reads
    /// its region).
    fn as_any(&self) -> &dyn Any;
}

/// What a stage's report section writes into.
pub struct Section<'a> {
    pub(crate) h: &'a mut String,
    pub(crate) figs: &'a mut dyn FigureSink,
    pub study: &'a Study,
    /// Every stage replayed, this one included.
    pub stages: &'a [StageResult],
    pub st: &'a StageResult,
}

/// An executor with its settings.
pub trait Executor: Debug + Send + Sync {
    /// The name `[executor] kind = "..."` and `--executor` give.
    fn kind(&self) -> &'static str;

    /// Whether the runs are made on this machine: the back end is then chosen here (a missing
    /// GPU falls back to the CPU), and `--jobs` is how many run at once here. Elsewhere the
    /// nodes have the GPUs, and `--jobs` is whatever [`Executor::with_jobs`] makes of it.
    fn on_this_machine(&self) -> bool;

    /// `demcal run --jobs N` for this executor: itself with N applied, and the runs this
    /// process makes at once. An error names `--jobs` and what was expected.
    fn with_jobs(&self, jobs: usize) -> Result<(Arc<dyn Executor>, usize), String>;

    /// What it checks before anything is written or simulated (the cluster answers).
    fn preflight(&self) -> Result<(), String> {
        Ok(())
    }

    /// Replays the study with itself making the missing runs, storing each as it finishes;
    /// returns the replay and, when it has one, a closing line for the terminal.
    fn run(
        &self,
        study: &Study,
        store: &mut Store,
        stored: &[RunRecord],
        jobs: usize,
        interrupted: Arc<AtomicBool>,
    ) -> Result<(Result<Replay, String>, Option<String>), String>;

    /// For a caller that wants its settings (tests, the Slurm status).
    fn as_any(&self) -> &dyn Any;
}
