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

use std::sync::Arc;

pub use crate::spec::{Section, Stage};

pub mod table;
pub use table::{any_of, StageDef, StageTable};

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
