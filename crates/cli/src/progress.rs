//! Progress on long runs. On a terminal, indicatif draws bars and spinners; anywhere else (a log
//! file, a batch job, a pipe) it draws nothing, so [`LogLine`] prints a plain line every
//! `DEMCAL_PROGRESS_S` seconds (default 5) instead, and a long run never looks hung.

use std::io::IsTerminal;
use std::time::{Duration, Instant};

/// Decides when the next plain progress line is due.
pub struct LogLine {
    /// Off on a terminal, where the bar shows progress.
    on: bool,
    every: Duration,
    start: Instant,
    last: Instant,
}

impl LogLine {
    pub fn new() -> LogLine {
        let now = Instant::now();
        LogLine {
            on: !std::io::stderr().is_terminal(),
            every: study::runner::log_interval(),
            start: now,
            last: now,
        }
    }

    /// Seconds since the run started, when a line is due (and the clock restarted).
    pub fn due(&mut self) -> Option<f64> {
        if !self.on || self.last.elapsed() < self.every {
            return None;
        }
        self.last = Instant::now();
        Some(self.start.elapsed().as_secs_f64())
    }

    /// `step done/total (pct %)<detail>, E s elapsed, about L s left` (at the pace so far).
    pub fn steps(done: u64, total: u64, detail: &str, elapsed: f64) -> String {
        let frac = done as f64 / total.max(1) as f64;
        let left = if done > 0 {
            format!(", about {:.0} s left", elapsed * (1.0 / frac - 1.0))
        } else {
            String::new()
        };
        format!(
            "step {done}/{total} ({:.0} %){detail}, {elapsed:.0} s elapsed{left}",
            100.0 * frac
        )
    }
}

/// Most worker threads a command may ask for: a few per core is plenty (the engine's loops are
/// compute-bound); a hundred thousand would only spend minutes starting threads.
pub const THREADS_PER_CORE: usize = 4;

/// Most runs in one GPU batch: each is a thread that mostly waits for the batch, and its
/// particles share the device's memory with the others.
pub const MOST_PER_BATCH: usize = 1024;

/// Runs per GPU batch when `--jobs` is not given: a stage's missing runs, up to this many (each
/// run also holds its scene and a thread on the host).
pub const DEFAULT_PER_BATCH: usize = 128;

/// Checks a job count: on the GPU jobs are the runs per batch, up to [`MOST_PER_BATCH`]; on the
/// CPU as [`check_count`].
pub fn check_jobs(flag: &str, n: usize, gpu: bool) -> Result<(), String> {
    if !gpu {
        return check_count(flag, n);
    }
    if n == 0 || n > MOST_PER_BATCH {
        return Err(format!(
            "{flag} {n}: expected 1 to {MOST_PER_BATCH} runs per GPU batch"
        ));
    }
    Ok(())
}

/// Checks a thread or job count given with `flag` against this machine's cores.
pub fn check_count(flag: &str, n: usize) -> Result<(), String> {
    if n == 0 {
        return Err(format!("{flag} 0: expected at least 1"));
    }
    let cores = std::thread::available_parallelism()
        .map(|c| c.get())
        .unwrap_or(1);
    let most = THREADS_PER_CORE * cores;
    if n > most {
        return Err(format!(
            "{flag} {n}: at most {most} ({THREADS_PER_CORE} per core, {cores} cores here)"
        ));
    }
    Ok(())
}
