//! An executor as the study file and the command line name it (the registry in `mod.rs` lists
//! the types that implement it).

use std::path::Path;

use crate::spec::{Executor, Study};
use crate::store::Store;

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
