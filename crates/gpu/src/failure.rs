//! A device that fails is an error with a message, never a panic.
//!
//! Why this is needed: wgpu reports a device lost to a driver reset, an allocation the driver
//! refuses, or any error outside an error scope in three ways, and two of them end the process by
//! default: `Device::poll` panics on a lost device (`handle_error_fatal` in wgpu 30), and errors
//! without a scope go to an uncaptured-error handler that panics. A calibration runs hundreds of
//! simulations for hours; one bad moment of the GPU must not take the study down. So:
//!
//! - the context installs a device-lost callback and an uncaptured-error handler that record the
//!   first failure here ([`Failure::record`]) instead of panicking;
//! - every piece of device work (a stage, a try of a segment) runs inside [`Failure::guard`], which
//!   turns a panic inside wgpu into an error, without the panic's message on stderr;
//! - from the first failure on, the context does no more device work: each stage runs on the CPU
//!   (from the state the host still holds, so the results are the CPU's), segments are declined,
//!   and new simulations that ask for "gpu" get the CPU with the failure as the reason
//!   (`dem::sim::resolve_backend`), so a study goes on, on the CPU;
//! - the first failure is said once on stderr as a warning, with the adapter and wgpu's message.

use std::cell::Cell;
use std::panic::{self, AssertUnwindSafe};
use std::sync::{Mutex, Once};

/// The first failure of one device.
#[derive(Default)]
pub(crate) struct Failure {
    first: Mutex<Option<String>>,
}

impl Failure {
    /// Records `what` as the device's failure (the first one stays) and says it once.
    pub(crate) fn record(&self, what: String) {
        let mut first = self.first.lock().unwrap_or_else(|e| e.into_inner());
        if first.is_none() {
            eprintln!(
                "warning: {what}; the GPU stages stop, and this and every later simulation of this run go on on the CPU (their results are the CPU's)"
            );
            *first = Some(what);
        }
    }

    /// The device's failure, if it failed.
    pub(crate) fn get(&self) -> Option<String> {
        self.first.lock().unwrap_or_else(|e| e.into_inner()).clone()
    }

    /// Runs `work` (calls into the device of `adapter`, and nothing else: no CPU stage, no
    /// assertion of the caller's): a panic inside it (wgpu's on a lost device) becomes an error,
    /// recorded. Err at once when the device failed before.
    pub(crate) fn guard<T>(
        &self,
        adapter: &str,
        work: impl FnOnce() -> Result<T, String>,
    ) -> Result<T, String> {
        if let Some(f) = self.get() {
            return Err(f);
        }
        quiet_panics_here();
        QUIET.with(|q| q.set(q.get() + 1));
        let result = panic::catch_unwind(AssertUnwindSafe(work));
        QUIET.with(|q| q.set(q.get() - 1));
        // A failure recorded meanwhile by another thread does not void a result that `work`
        // got: `read_back` refuses data once a failure is recorded, and data read before it are
        // sound. Voiding it would run a stage whose results are already applied a second time.
        match result {
            Ok(r) => r,
            Err(payload) => {
                let message = payload
                    .downcast_ref::<String>()
                    .map(String::as_str)
                    .or_else(|| payload.downcast_ref::<&str>().copied())
                    .unwrap_or("no message");
                let what = format!("the GPU {adapter} failed: {}", one_line(message));
                self.record(what.clone());
                Err(what)
            }
        }
    }
}

/// wgpu's messages run over several indented lines (and, where an error was formatted with
/// `Debug` inside another, over escaped line breaks).
pub(crate) fn one_line(s: &str) -> String {
    s.replace("\\n", "\n")
        .split('\n')
        .map(str::trim)
        .filter(|l| !l.is_empty())
        .collect::<Vec<_>>()
        .join(" ")
}

thread_local! {
    /// How deep this thread is in guarded device work (whose panics are turned into errors).
    static QUIET: Cell<u32> = const { Cell::new(0) };
}

/// Installs, once, a panic hook that says nothing for a panic inside guarded device work (it is
/// reported as the device's failure instead) and hands every other panic to the hook before it.
fn quiet_panics_here() {
    static INSTALL: Once = Once::new();
    INSTALL.call_once(|| {
        let before = panic::take_hook();
        panic::set_hook(Box::new(move |info| {
            if QUIET.with(|q| q.get()) == 0 {
                before(info);
            }
        }));
    });
}
