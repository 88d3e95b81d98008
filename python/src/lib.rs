//! `demcal._demcal`: the native half of the Python package (PyO3, stable ABI 3.9).
//!
//! Thin on purpose: each function takes what a command-line call takes (file text, a folder,
//! parameter values, options), runs the same library code as the `demcal` binary, and hands the
//! answer back as JSON text, which the pure-Python half (`python/demcal/`) turns into typed
//! objects and numpy arrays. So the Python API and the binary cannot drift apart, and no Rust
//! type has to mirror a Python one.
//!
//! Every simulation runs on a thread of its own with the GIL released ([`interruptible`]); the
//! calling thread wakes every 100 ms to let Python handle signals, so Ctrl-C stops the run
//! (the same stop a study gets from `demcal run`) and raises `KeyboardInterrupt`.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{self, RecvTimeoutError};
use std::sync::Arc;
use std::time::Duration;

use pyo3::create_exception;
use pyo3::exceptions::{PyException, PyKeyboardInterrupt};
use pyo3::prelude::*;

mod design;
mod scene;
mod study;
mod surrogate;
mod test;

create_exception!(
    _demcal,
    DemcalError,
    PyException,
    "Every error demcal raises."
);
create_exception!(
    _demcal,
    InputError,
    DemcalError,
    "A file, a key or an argument is wrong; the message names it and what was expected."
);
create_exception!(
    _demcal,
    RunError,
    DemcalError,
    "A simulation gave no result: `kind` says why (the kinds a study stores)."
);
create_exception!(
    _demcal,
    SettingsError,
    RunError,
    "The test's settings, with the parameter values, were refused."
);
create_exception!(
    _demcal,
    DivergedError,
    RunError,
    "The simulation blew up: positions or velocities not finite."
);
create_exception!(
    _demcal,
    EscapedError,
    RunError,
    "A particle left the simulation domain."
);
create_exception!(
    _demcal,
    MeasurementError,
    RunError,
    "The run finished but its measurement could not be made."
);
create_exception!(
    _demcal,
    NotQuasiStaticError,
    RunError,
    "A mechanical test whose specimen's kinetic energy exceeded its share of the work."
);
create_exception!(
    _demcal,
    OutputError,
    RunError,
    "The run's files could not be written."
);
create_exception!(
    _demcal,
    StudyError,
    DemcalError,
    "A study ended without finishing (its report says why)."
);
create_exception!(
    _demcal,
    StudyLockedError,
    StudyError,
    "Another process runs the study: try again when it has finished."
);

/// An input error with `message`.
pub(crate) fn input(message: impl Into<String>) -> PyErr {
    InputError::new_err(message.into())
}

/// A count given from Python (threads, jobs): at least 1 and at most what the CLI takes.
pub(crate) fn check_count(what: &str, n: usize) -> PyResult<()> {
    if n == 0 || n > 4096 {
        return Err(input(format!("{what}={n}: expected 1 to 4096")));
    }
    Ok(())
}

/// How a piece of work uses rayon's threads.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Pool {
    /// One simulation: it runs on a pool thread and works on its parallel stages itself, the
    /// other threads joining in (as the binary's `on_pool`), on `threads` threads or the global
    /// pool (one per core).
    One(Option<usize>),
    /// A study: it starts simulations from threads of its own, which would queue behind it if
    /// it held a pool thread (as `demcal run`).
    Own,
}

/// Runs `work` on a thread of its own with the GIL released, as `pool` says. The calling
/// thread checks Python's signals
/// every 100 ms: on Ctrl-C it sets `stop`, waits for `work` to notice and return, and raises
/// `KeyboardInterrupt`. `work` must poll `stop` (every simulation's progress callback does).
pub(crate) fn interruptible<T, F>(
    py: Python<'_>,
    pool: Pool,
    stop: Arc<AtomicBool>,
    work: F,
) -> PyResult<T>
where
    T: Send + 'static,
    F: FnOnce() -> T + Send + 'static,
{
    let threads = match pool {
        Pool::One(t) => t,
        Pool::Own => None,
    };
    let own = pool == Pool::Own;
    // rayon's global pool does not survive fork(): its threads stay in the parent, and work
    // handed to it from a forked child (multiprocessing's default start method on Linux) waits
    // forever. A child gets a pool of its own for one simulation; a study, whose runs start
    // simulations from threads of their own on the global pool, is refused.
    let forked = std::process::id() != *IMPORTED_IN;
    if forked && own {
        return Err(input(
            "a study cannot run in a process forked from one that imported demcal (rayon's threads do not survive fork): use multiprocessing's \"spawn\" start method, or demcal run",
        ));
    }
    let threads = match threads {
        None if forked => Some(
            std::thread::available_parallelism()
                .map(|n| n.get())
                .unwrap_or(1),
        ),
        t => t,
    };
    let pool = match threads {
        Some(n) => {
            check_count("threads", n)?;
            Some(
                rayon::ThreadPoolBuilder::new()
                    .num_threads(n)
                    .build()
                    .map_err(|e| DemcalError::new_err(format!("threads={n}: {e}")))?,
            )
        }
        None => None,
    };
    let (tx, rx) = mpsc::channel();
    std::thread::Builder::new()
        .name("demcal".into())
        // The binary runs a study on its main thread (8 MiB of stack); a report's figures
        // recurse deeper than a spawned thread's default 2 MiB allows for.
        .stack_size(8 << 20)
        .spawn(move || {
            // One simulation works on its parallel stages itself with the pool's other threads
            // joining in (as the binary's `on_pool`), rather than queueing each stage.
            let run = move || {
                std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| match &pool {
                    _ if own => work(),
                    Some(p) => p.install(work),
                    None => rayon::scope(|_| work()),
                }))
            };
            let _ = tx.send(run());
        })
        .map_err(|e| DemcalError::new_err(format!("cannot start a thread: {e}")))?;
    let mut rx = rx;
    // The first Ctrl-C asks the run to stop (it looks every few hundred steps) and waits for
    // it; a second one returns at once and leaves the thread to end on its own (a study's lock
    // and store are released when it does).
    let mut interrupt: Option<PyErr> = None;
    loop {
        let (got, back) = py.detach(move || {
            let got = rx.recv_timeout(Duration::from_millis(100));
            (got, rx)
        });
        rx = back;
        match got {
            Ok(_) if interrupt.is_some() => return Err(interrupt.unwrap()),
            Ok(Ok(value)) => return Ok(value),
            Ok(Err(panic)) => {
                let msg = panic
                    .downcast_ref::<String>()
                    .cloned()
                    .or_else(|| panic.downcast_ref::<&str>().map(|s| s.to_string()))
                    .unwrap_or_default();
                return Err(DemcalError::new_err(format!(
                    "demcal panicked (a bug; please report it): {msg}"
                )));
            }
            Err(RecvTimeoutError::Disconnected) => {
                return Err(interrupt.unwrap_or_else(|| {
                    DemcalError::new_err("the simulation thread ended without an answer")
                }))
            }
            Err(RecvTimeoutError::Timeout) => {
                if let Err(e) = py.check_signals() {
                    if interrupt.is_some() {
                        return Err(e);
                    }
                    stop.store(true, Ordering::SeqCst);
                    interrupt = Some(e);
                }
            }
        }
    }
}

/// The process that imported the module: a different process id later means a fork.
static IMPORTED_IN: std::sync::LazyLock<u32> = std::sync::LazyLock::new(std::process::id);

/// `KeyboardInterrupt` with `message`, for a run that `stop` ended from elsewhere.
pub(crate) fn interrupted(message: &str) -> PyErr {
    PyKeyboardInterrupt::new_err(message.to_string())
}

/// JSON text for Python's `json.loads`.
pub(crate) fn to_json(v: &serde_json::Value) -> String {
    serde_json::to_string(v).expect("JSON values serialise")
}

/// The demcal version this extension was built from.
#[pyfunction]
fn version() -> &'static str {
    env!("CARGO_PKG_VERSION")
}

#[pymodule]
fn _demcal(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    std::sync::LazyLock::force(&IMPORTED_IN);
    m.add("DemcalError", py.get_type::<DemcalError>())?;
    m.add("InputError", py.get_type::<InputError>())?;
    m.add("RunError", py.get_type::<RunError>())?;
    m.add("SettingsError", py.get_type::<SettingsError>())?;
    m.add("DivergedError", py.get_type::<DivergedError>())?;
    m.add("EscapedError", py.get_type::<EscapedError>())?;
    m.add("MeasurementError", py.get_type::<MeasurementError>())?;
    m.add("NotQuasiStaticError", py.get_type::<NotQuasiStaticError>())?;
    m.add("OutputError", py.get_type::<OutputError>())?;
    m.add("StudyError", py.get_type::<StudyError>())?;
    m.add("StudyLockedError", py.get_type::<StudyLockedError>())?;
    m.add_function(wrap_pyfunction!(version, m)?)?;
    test::register(m)?;
    scene::register(m)?;
    study::register(m)?;
    design::register(m)?;
    surrogate::register(m)?;
    Ok(())
}
