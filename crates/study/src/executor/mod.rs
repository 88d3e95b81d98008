//! Executors as plug-ins: where a study's runs are made (this machine, a Slurm cluster). Each is
//! a type in its own file here with its `[executor]` settings, its preflight, how it makes a
//! stage's missing runs, and what it adds to `demcal status` and to a restart; the registry at
//! the bottom is the one list of names. `lib.rs` and the CLI ask the chosen executor and hold no
//! branch of their own for any one of them (ARCHITECTURE.md has the recipe).

use std::path::Path;
use std::sync::Arc;

pub mod def;
pub use crate::spec::Executor;
use crate::spec::Study;
use crate::store::Store;
pub use def::ExecutorDef;

/// The registry: each line an executor's module and type; the first is the default.
macro_rules! executors {
    ($($module:ident :: $ty:ident),* $(,)?) => {
        $(pub mod $module;)*

        /// The executors, the default first.
        pub const EXECUTOR_NAMES: &[&str] = &[$(<$module::$ty as ExecutorDef>::NAME),*];

        /// The keys of `[executor]` for `name`, `kind` included.
        pub fn executor_keys(name: &str) -> Option<Vec<&'static str>> {
            $(if name == <$module::$ty as ExecutorDef>::NAME {
                return Some([&["kind"][..], <$module::$ty as ExecutorDef>::KEYS].concat());
            })*
            None
        }

        fn parse_kind(
            name: &str,
            t: &toml::Table,
            dir: &Path,
            err: &dyn Fn(&str, String) -> String,
        ) -> Option<Result<Arc<dyn Executor>, String>> {
            $(if name == <$module::$ty as ExecutorDef>::NAME {
                return Some(<$module::$ty as ExecutorDef>::parse(t, dir, err).map(|e| Arc::new(e) as Arc<dyn Executor>));
            })*
            None
        }

        fn defaults_of(name: &str) -> Option<Arc<dyn Executor>> {
            $(if name == <$module::$ty as ExecutorDef>::NAME {
                return Some(Arc::new(<$module::$ty as ExecutorDef>::defaults()));
            })*
            None
        }

        /// Every executor's [`ExecutorDef::withdraw`]: what each took back, by executor name
        /// (those that took back nothing left out).
        pub fn withdraw_all(store: &Store) -> Result<Vec<(&'static str, usize)>, String> {
            let mut taken = Vec::new();
            $(
                let n = <$module::$ty as ExecutorDef>::withdraw(store)?;
                if n > 0 {
                    taken.push((<$module::$ty as ExecutorDef>::NAME, n));
                }
            )*
            Ok(taken)
        }

        /// Every executor's [`ExecutorDef::status_lines`].
        pub fn status_lines(study: &Study, store: &Store) -> Result<String, String> {
            let mut s = String::new();
            $(s += &<$module::$ty as ExecutorDef>::status_lines(study, store)?;)*
            Ok(s)
        }
    };
}

executors! {
    local::Local,
    slurm::Slurm,
}

/// The names joined, for messages.
fn names(sep: &str) -> String {
    EXECUTOR_NAMES
        .iter()
        .map(|n| format!("\"{n}\""))
        .collect::<Vec<_>>()
        .join(sep)
}

/// Reads `[executor]` (absent: the default, this machine).
pub fn parse_executor(
    executor: Option<&toml::Value>,
    dir: &Path,
    err: &dyn Fn(&str, String) -> String,
) -> Result<Arc<dyn Executor>, String> {
    let t = match executor {
        None => return Ok(defaults_of(EXECUTOR_NAMES[0]).expect("the default is registered")),
        Some(toml::Value::Table(t)) => t,
        Some(_) => {
            return Err(err(
                "executor",
                format!("expected a table: [executor] with kind = {}", names(" or ")),
            ))
        }
    };
    let kind = match t.get("kind") {
        None => return Err(err("executor.kind", format!("missing: {}", names(" or ")))),
        Some(toml::Value::String(s)) if EXECUTOR_NAMES.contains(&s.as_str()) => s.as_str(),
        Some(v) => {
            return Err(err(
                "executor.kind",
                format!("expected {}, got {v}", names(" or ")),
            ))
        }
    };
    let keys = executor_keys(kind).expect("a registered executor has keys");
    for k in t.keys() {
        if !keys.contains(&k.as_str()) {
            return Err(err(
                &format!("executor.{k}"),
                if keys.len() == 1 {
                    format!("a {kind} executor has no settings")
                } else {
                    format!(
                        "unknown key for a {kind} executor (expected {})",
                        keys[1..].join(", ")
                    )
                },
            ));
        }
    }
    parse_kind(kind, t, dir, err).expect("a registered executor parses")
}

/// The executor a run uses: `--executor NAME` over the study's `[executor]` (the study's own
/// settings when it names the same one, else that one's defaults).
pub fn chosen(study: &Study, flag: Option<&str>) -> Result<Arc<dyn Executor>, String> {
    match flag {
        None => Ok(study.executor.clone()),
        Some(name) if name == study.executor.kind() => Ok(study.executor.clone()),
        Some(name) => defaults_of(name)
            .ok_or_else(|| format!("--executor: expected {}, got \"{name}\"", names(" or "))),
    }
}
