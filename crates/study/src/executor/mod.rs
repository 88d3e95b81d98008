//! Executors as plug-ins: where a study's runs are made (this machine, a Slurm cluster). Each is
//! a type in its own file here with its `[executor]` settings, its preflight, how it makes a
//! stage's missing runs, and what it adds to `demcal status` and to a restart; the registry at
//! the bottom is the one list of names. `lib.rs` and the CLI ask the chosen executor and hold no
//! branch of their own for any one of them (ARCHITECTURE.md has the recipe).

use std::any::Any;
use std::fmt::Debug;
use std::path::Path;
use std::sync::atomic::AtomicBool;
use std::sync::Arc;

use crate::spec::Study;
use crate::stages::Replay;
use crate::store::{RunRecord, Store};

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

/// An executor as the study file and the command line name it.
pub trait ExecutorDef: Executor + Sized + 'static {
    const NAME: &'static str;
    /// The keys of `[executor]` besides `kind`.
    const KEYS: &'static [&'static str];
    /// Its settings from `[executor]`; `dir` is the study's folder (relative paths start
    /// there), `err` names the file and key.
    fn parse(
        t: &toml::Table,
        dir: &Path,
        err: &dyn Fn(&str, String) -> String,
    ) -> Result<Self, String>;
    /// With every setting at its default (`--executor NAME` on a study that names another).
    fn defaults() -> Self;
    /// On `--restart`: takes back what the old results still have out (queued tasks), whatever
    /// executor the study uses now. Returns how many.
    fn withdraw(_store: &Store) -> Result<usize, String> {
        Ok(0)
    }
    /// What `demcal status` adds about its work in the store.
    fn status_lines(_study: &Study, _store: &Store) -> Result<String, String> {
        Ok(String::new())
    }
}

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

        /// Every executor's [`ExecutorDef::withdraw`]: the total taken back.
        pub fn withdraw_all(store: &Store) -> Result<usize, String> {
            let mut n = 0;
            $(n += <$module::$ty as ExecutorDef>::withdraw(store)?;)*
            Ok(n)
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
    doc: &toml::Table,
    dir: &Path,
    err: &dyn Fn(&str, String) -> String,
) -> Result<Arc<dyn Executor>, String> {
    let t = match doc.get("executor") {
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
