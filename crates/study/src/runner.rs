//! Running simulations on this machine: `jobs` runs at once, each in its own rayon pool holding
//! its share of the cores (with `backend = "gpu"`, the runs that run at the same time advance in
//! the same kernel launches: `jobs` is then the runs per batch), with a progress bar per stage (and a line per job) on a terminal and
//! otherwise plain log lines: one per finished run, and one per running job every
//! [`log_interval`]. Finished runs go to the store one transaction each, from this thread only,
//! so the store never sees two writers.

use std::collections::VecDeque;
use std::io::IsTerminal;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{mpsc, Arc, Mutex};
use std::time::{Duration, Instant};

use indicatif::{MultiProgress, ProgressBar, ProgressDrawTarget, ProgressStyle};

use crate::job::Job;
use crate::record::{RunSpec, StageResult};
use crate::spec::Study;
use crate::stages::Execute;
use crate::store::{RunRecord, Status, Store};

/// A finished run in a few words for a progress line: its response, or why it failed.
pub(crate) fn outcome(study: &Study, rec: &RunRecord) -> String {
    match (&rec.status, rec.response) {
        (Status::Done, Some(y)) => {
            format!("{} = {}", study.target.response, crate::text::sig(y))
        }
        _ => format!(
            "failed ({}): {}",
            rec.error_kind.map(|k| k.as_str()).unwrap_or("unknown"),
            rec.error.clone().unwrap_or_default()
        ),
    }
}

/// How often a long run logs how far it is when standard error is not a terminal (a log file, a
/// batch job): `DEMCAL_PROGRESS_S` seconds, default 5.
pub fn log_interval() -> Duration {
    std::env::var("DEMCAL_PROGRESS_S")
        .ok()
        .and_then(|v| v.trim().parse::<f64>().ok())
        .filter(|s| s.is_finite() && *s >= 0.0)
        .map(|s| Duration::from_secs_f64(s.min(1e6)))
        .unwrap_or(Duration::from_secs(5))
}

pub struct LocalExecutor<'a> {
    pub jobs: usize,
    pub store: &'a mut Store,
    /// Set by Ctrl-C: running simulations stop, nothing more starts.
    pub interrupted: Arc<AtomicBool>,
    multi: MultiProgress,
    terminal: bool,
}

impl<'a> LocalExecutor<'a> {
    pub fn new(jobs: usize, store: &'a mut Store, interrupted: Arc<AtomicBool>) -> Self {
        let terminal = std::io::stderr().is_terminal();
        let multi = MultiProgress::with_draw_target(if terminal {
            ProgressDrawTarget::stderr()
        } else {
            ProgressDrawTarget::hidden()
        });
        LocalExecutor {
            jobs: jobs.max(1),
            store,
            interrupted,
            multi,
            terminal,
        }
    }
}

impl Execute for LocalExecutor<'_> {
    fn execute(
        &mut self,
        study: &Study,
        stage: &StageResult,
        runs: &[RunSpec],
    ) -> Result<Vec<RunRecord>, String> {
        let cores = std::thread::available_parallelism()
            .map(|n| n.get())
            .unwrap_or(1);
        let jobs = self.jobs.min(runs.len()).max(1);
        // A stage with fewer runs than jobs gives its runs all the cores: each gets an equal
        // share, and the first `cores % jobs` one thread more, so no core idles.
        let threads = (cores / jobs).max(1);
        let extra = if cores > jobs { cores % jobs } else { 0 };
        let share = if extra > 0 {
            format!("{threads}-{}", threads + 1)
        } else {
            threads.to_string()
        };
        let stage_name = format!(
            "stage {}/{} {}",
            stage.index + 1,
            study.plan.len(),
            stage.kind
        );
        let bar = self.multi.add(ProgressBar::new(stage.runs.len() as u64));
        bar.set_style(
            ProgressStyle::with_template(
                "{prefix:.bold} [{bar:30.cyan/blue}] {pos}/{len} runs  {elapsed_precise}  ETA {eta}  {msg}",
            )
            .unwrap()
            .progress_chars("=> "),
        );
        bar.set_prefix(stage_name.clone());
        bar.set_position((stage.runs.len() - runs.len()) as u64);
        bar.reset_eta();
        if !self.terminal {
            eprintln!(
                "{stage_name}: {} runs to make ({} stored), {jobs} at a time with {share} thread(s) each",
                runs.len(),
                stage.runs.len() - runs.len()
            );
        }
        let pools = (0..jobs)
            .map(|job| {
                rayon::ThreadPoolBuilder::new()
                    .num_threads(threads + usize::from(job < extra))
                    .build()
            })
            .collect::<Result<Vec<_>, _>>()
            .map_err(|e| format!("cannot start {jobs} job(s) of {threads} thread(s): {e}"))?;
        let every = log_interval();
        // On the GPU the jobs of a stage form one batch (see dem_gpu::batch); the CPU ignores it.
        let batch = dem::sim::new_batch_group();
        let queue = Mutex::new(runs.iter().cloned().collect::<VecDeque<_>>());
        let (tx, rx) = mpsc::channel::<(RunSpec, Option<RunRecord>)>();
        let mut finished = Vec::new();
        let mut store_error = None;
        let interrupted = self.interrupted.clone();
        let multi = &self.multi;
        let terminal = self.terminal;
        let store = &mut *self.store;
        let stage_name = &stage_name;
        std::thread::scope(|scope| {
            for (job, pool) in pools.into_iter().enumerate() {
                let tx = tx.clone();
                let queue = &queue;
                let interrupted = &*interrupted;
                let line = multi.add(ProgressBar::new_spinner());
                line.set_style(ProgressStyle::with_template("  {spinner} {msg}").unwrap());
                scope.spawn(move || {
                    loop {
                        if interrupted.load(Ordering::Relaxed) {
                            break;
                        }
                        // Nothing panics while holding the queue, so a poisoned lock is whole.
                        let next = queue.lock().unwrap_or_else(|e| e.into_inner()).pop_front();
                        let Some(spec) = next else {
                            break;
                        };
                        let head =
                            format!("job {}: run {} ({})", job + 1, spec.index + 1, spec.label);
                        line.set_message(head.clone());
                        let started = Instant::now();
                        let last_log = Mutex::new(started);
                        // Called every few hundred steps: format only when it is shown.
                        let report = |phase: &str, t: f64| {
                            if terminal {
                                line.set_message(format!("{head}: {phase}: t = {t:.2} s"));
                                line.tick();
                            } else {
                                let mut last = last_log.lock().unwrap_or_else(|e| e.into_inner());
                                if last.elapsed() >= every {
                                    *last = Instant::now();
                                    eprintln!(
                                        "{stage_name}: {head}: {phase}: t = {t:.2} s ({:.0} s running)",
                                        started.elapsed().as_secs_f64()
                                    );
                                }
                            }
                        };
                        let job = Job::new(study, &spec);
                        // The stage's runs that run at the same time share the GPU's launches.
                        let rec = pool.install(|| {
                            dem::sim::in_batch_group(batch, || job.execute(interrupted, &report))
                        });
                        if tx.send((spec, rec)).is_err() {
                            break;
                        }
                    }
                    line.finish_and_clear();
                });
            }
            drop(tx);
            for (spec, rec) in rx {
                let Some(rec) = rec else { continue };
                if store_error.is_none() {
                    if let Err(e) = store.insert(&rec) {
                        // Without a store nothing more is worth running.
                        store_error = Some(e);
                        interrupted.store(true, Ordering::Relaxed);
                    }
                }
                let outcome = outcome(study, &rec);
                bar.inc(1);
                let short: String = outcome.chars().take(70).collect();
                bar.set_message(format!("last: run {} {short}", spec.index + 1));
                if !terminal {
                    eprintln!(
                        "{stage_name}: run {} ({}) {outcome} ({:.1} s)",
                        spec.index + 1,
                        spec.label,
                        rec.wall_s
                    );
                }
                finished.push(rec);
            }
        });
        bar.finish_and_clear();
        if let Some(e) = store_error {
            // The flag stopped the other jobs; lowered again, it no longer says "Ctrl-C", so
            // `study::run` reports a failed store (exit 1), not an interruption to resume.
            self.interrupted.store(false, Ordering::SeqCst);
            return Err(e);
        }
        if self.interrupted.load(Ordering::Relaxed) {
            return Err(format!(
                "interrupted: {} finished runs are stored in {}; run the same command again to go on",
                finished.len(),
                store.path.display()
            ));
        }
        if !terminal {
            let done = finished.iter().filter(|r| r.status == Status::Done).count();
            eprintln!(
                "{stage_name}: {done} done, {} failed",
                finished.len() - done
            );
        }
        Ok(finished)
    }
}
