//! Stages as plug-ins. Each stage of a plan is a type in its own file here: it declares its name
//! and keys and reads its settings ([`StageDef`]), plans its runs, plans further rounds when it
//! is iterative, concludes once they are done and writes its report section ([`Stage`]). The
//! registry at the bottom is the one list of stage names: adding a stage is its file, one line
//! there, its docs and its test (ARCHITECTURE.md has the recipe).
//!
//! The shape is argmin's `Solver` (init / next_iter / terminate) as [`Stage::plan`],
//! [`Stage::next_round`] and [`Stage::conclude`], with our resume-by-replay: every call works
//! from the study and the stored runs alone, so a study killed anywhere replays to the same
//! point.

use std::any::Any;
use std::fmt::Debug;
use std::sync::Arc;

use crate::report_figures::Figures;
use crate::spec::Study;
use crate::stages::{Context, StageResult};

mod table;
pub use table::StageTable;

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

/// A stage as the plan reads it.
pub trait StageDef: Stage + Sized {
    const NAME: &'static str;
    /// The keys its table takes besides `stage`.
    const KEYS: &'static [&'static str];
    /// Its settings from its table (defaults filled in); errors name the key.
    fn parse(t: &StageTable) -> Result<Self, String>;
}

/// What a stage's report section writes into.
pub struct Section<'a> {
    pub(crate) h: &'a mut String,
    pub(crate) figs: &'a mut Figures,
    pub study: &'a Study,
    /// Every stage replayed, this one included.
    pub stages: &'a [StageResult],
    pub st: &'a StageResult,
}

/// Whether any stage of `before` is one of `kinds`.
pub(crate) fn any_of(before: &[Arc<dyn Stage>], kinds: &[&str]) -> bool {
    before.iter().any(|s| kinds.contains(&s.kind()))
}

/// The registry: each line a stage's module and type.
macro_rules! stages {
    ($($module:ident :: $ty:ident),* $(,)?) => {
        $(pub mod $module;)*

        /// The stages a plan may hold, in the order help texts list them.
        pub const STAGE_NAMES: &[&str] = &[$(<$module::$ty as StageDef>::NAME),*];

        /// The keys a stage's table takes (besides `stage`), or `None` for a stage that does
        /// not exist.
        pub fn stage_keys(name: &str) -> Option<&'static [&'static str]> {
            $(if name == <$module::$ty as StageDef>::NAME {
                return Some(<$module::$ty as StageDef>::KEYS);
            })*
            None
        }

        /// The stage `name` with its settings read from `t`; `None` for no such stage.
        pub(crate) fn parse_stage(
            name: &str,
            t: &StageTable,
        ) -> Option<Result<Arc<dyn Stage>, String>> {
            $(if name == <$module::$ty as StageDef>::NAME {
                return Some(<$module::$ty as StageDef>::parse(t).map(|s| Arc::new(s) as Arc<dyn Stage>));
            })*
            None
        }
    };
}

stages! {
    screening::Screening,
    steepest::Steepest,
    rsm::Rsm,
    optimize::Optimize,
    bayesopt::BayesOpt,
    ga_bp::GaBp,
    smc::Smc,
    sweep::Sweep,
    validate::Validate,
}

/// The stage names joined, for messages.
pub fn stage_list() -> String {
    STAGE_NAMES.join(", ")
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every registered stage reads an empty table (all defaults) or says why not, and calls
    /// itself by the name it is registered under.
    #[test]
    fn every_stage_is_called_by_its_registered_name() {
        let params = vec![
            ("a".to_string(), 0.0, 1.0),
            ("b".to_string(), 0.0, 1.0),
            ("c".to_string(), 0.0, 1.0),
        ];
        let err = |k: &str, why: String| format!("{k}: {why}");
        let mut parsed = 0;
        for name in STAGE_NAMES {
            let empty = toml::Table::new();
            let t = StageTable::new("plan[0]", &empty, &params, &err);
            if let Some(Ok(s)) = parse_stage(name, &t) {
                assert_eq!(s.kind(), *name);
                parsed += 1;
            }
            assert!(stage_keys(name).is_some());
        }
        assert!(parsed >= STAGE_NAMES.len() - 1, "{parsed}");
        assert!(parse_stage(
            "nonsense",
            &StageTable::new("p", &toml::Table::new(), &params, &err)
        )
        .is_none());
    }
}
