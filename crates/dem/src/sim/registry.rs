//! Back ends registered by name, as LAMMPS registers its styles: "cpu" is built in, and a crate
//! that provides another (demcal-gpu's "gpu") registers a maker for it once at start-up, so scene
//! files, test files and studies can name it without the engine depending on that crate.

use super::backend::Backend;
use super::cpu::CpuBackend;
use std::cell::Cell;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::RwLock;

thread_local! {
    static BATCH_GROUP: Cell<Option<u64>> = const { Cell::new(None) };
}

/// A new batch group (see [`in_batch_group`]).
pub fn new_batch_group() -> u64 {
    static NEXT: AtomicU64 = AtomicU64::new(1);
    NEXT.fetch_add(1, Ordering::Relaxed)
}

/// Runs `f` with the back ends it makes on this thread joined to batch `group`: a back end that
/// batches (the GPU) advances the simulations of one group that run at the same time in the same
/// kernel launches; the CPU ignores it. A study's runner puts the runs of a stage in one group.
pub fn in_batch_group<R>(group: u64, f: impl FnOnce() -> R) -> R {
    let before = BATCH_GROUP.with(|g| g.replace(Some(group)));
    struct Restore(Option<u64>);
    impl Drop for Restore {
        fn drop(&mut self) {
            BATCH_GROUP.with(|g| g.set(self.0));
        }
    }
    let _restore = Restore(before);
    f()
}

/// The batch group of back ends made on this thread now, if any.
pub fn batch_group() -> Option<u64> {
    BATCH_GROUP.with(|g| g.get())
}

/// Makes a back end, or says why it cannot (no GPU, no f64 shaders, ...).
pub type BackendMaker = fn() -> Result<Box<dyn Backend>, String>;

/// The back ends a file may name, whether or not this build or machine has them: a name outside
/// this list is a typo (an error); a name in it that cannot be made falls back to the CPU.
pub const BACKEND_NAMES: &[&str] = &["cpu", "gpu"];

/// The names a file may give, quoted, for messages: "\"cpu\" or \"gpu\"".
pub fn backend_choices() -> String {
    BACKEND_NAMES
        .iter()
        .map(|b| format!("\"{b}\""))
        .collect::<Vec<_>>()
        .join(" or ")
}

static MAKERS: RwLock<Vec<(&'static str, BackendMaker)>> = RwLock::new(Vec::new());

/// Registers (or replaces) the maker of the back end `name`.
pub fn register_backend(name: &'static str, maker: BackendMaker) {
    let mut makers = MAKERS.write().unwrap_or_else(|e| e.into_inner());
    makers.retain(|(n, _)| *n != name);
    makers.push((name, maker));
}

/// The back end called `name`. The error says why it cannot be had, in a form that reads after
/// "backend = \"gpu\": ".
pub fn make_backend(name: &str) -> Result<Box<dyn Backend>, String> {
    if name == "cpu" {
        return Ok(Box::new(CpuBackend));
    }
    if !BACKEND_NAMES.contains(&name) {
        return Err(format!(
            "unknown back end (expected {})",
            BACKEND_NAMES.join(" or ")
        ));
    }
    let maker = MAKERS
        .read()
        .unwrap_or_else(|e| e.into_inner())
        .iter()
        .find(|(n, _)| *n == name)
        .map(|(_, m)| *m);
    match maker {
        Some(make) => make(),
        None => Err("this program was built without it".to_string()),
    }
}

/// Checks that `name` can be had: `Ok(name)` when it can, and otherwise `Ok("cpu")` with the
/// message a front end prints once before falling back; `Err` only for a name that is no back
/// end at all.
pub fn resolve_backend(name: &str) -> Result<(&'static str, Option<String>), String> {
    let Some(&known) = BACKEND_NAMES.iter().find(|&&n| n == name) else {
        return Err(format!(
            "unknown back end \"{name}\" (expected {})",
            BACKEND_NAMES.join(" or ")
        ));
    };
    match make_backend(known) {
        Ok(_) => Ok((known, None)),
        Err(why) => Ok(("cpu", Some(format!("{why}; running on the CPU")))),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cpu_is_built_in_and_unknown_names_are_refused() {
        assert_eq!(make_backend("cpu").unwrap().name(), "cpu");
        let Err(e) = make_backend("cuda") else {
            panic!("\"cuda\" was made")
        };
        assert!(e.contains("expected cpu or gpu"), "{e}");
        assert!(resolve_backend("cuda").is_err());
        assert_eq!(resolve_backend("cpu").unwrap(), ("cpu", None));
    }
}
