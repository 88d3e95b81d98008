//! Running a study's simulations on a Slurm cluster: each stage's missing runs go out as one job
//! array whose task `i` runs `demcal run-one` on the `i`-th job file, in a run folder the nodes
//! share; this process (the coordinator, on a login node) polls `squeue` and the tasks' result
//! files, and alone writes the results store.
//!
//! Design notes:
//! - **Nothing lost, nothing twice.** Tasks are written to the store's ledger ([`ledger`]) before
//!   `sbatch` runs and get their job id as soon as it answers; a run's record is stored in the
//!   same transaction that closes its task. A coordinator killed at any moment, started again,
//!   re-attaches to the tasks still queued or running and collects the results of those that
//!   ended meanwhile, instead of submitting them again ([`submit`]). A task written but never
//!   given a job id (killed during `sbatch`, or sbatch timed out) is looked for by its job name,
//!   which carries the submission's token. Each submission has its own folder, so a result of an
//!   older submission can never pass for a newer one's. The store's lock names its host, so a
//!   second coordinator on another login node is refused.
//! - **No accounting needed.** What is queued comes from `squeue`; why a task left the queue
//!   without a result from `scontrol show job`, else `sacct`, else the line Slurm writes into the
//!   task's log when it kills it ([`queue`]).
//! - **Failures are results.** A time-limit kill is a failed run of kind `time_limit`; memory,
//!   cancellation and start-up errors are kind `cluster`; a node failure, pre-emption, or an end
//!   nobody can explain any more is not the run's fault and is submitted again (`retries`,
//!   default once, counted across restarts) before it is stored as failed. A task that completed
//!   without its result showing gets minutes for a shared file system to show it.
//! - **Ctrl-C** asks whether to `scancel` the stage's queued and running tasks or leave them for
//!   the next `demcal run` (`on_interrupt`).

pub mod ledger;
pub mod queue;
pub mod script;
pub mod settings;
mod status;
mod submit;

use std::collections::{BTreeMap, BTreeSet};
use std::io::{BufRead, IsTerminal, Write};
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

use crate::job::Job;
use crate::record::{RunSpec, StageResult};
use crate::run_error::{RunError, RunErrorKind};
use crate::spec::Study;
use crate::stages::Execute;
use crate::store::{RunRecord, Status, Store};
use crate::text::job_list;
use ledger::Task;
use queue::Verdict;
pub use settings::{OnInterrupt, SlurmSettings};
pub use status::status_lines;
pub use submit::withdraw_open;

/// How long a task that completed (exit 0) may take to show its result on this machine: NFS
/// caches a folder's listing for up to a minute by default.
const RESULT_SHOWS_WITHIN: Duration = Duration::from_secs(300);

/// What a coordinator did, for its closing line.
#[derive(Clone, Debug, Default)]
pub struct SlurmStats {
    /// Arrays submitted.
    pub arrays: usize,
    /// Tasks submitted (retries included).
    pub tasks: usize,
    /// Tasks found queued, running or ended when the coordinator started again.
    pub reattached: usize,
    /// Runs stored from tasks' results.
    pub stored: usize,
    /// Tasks submitted again after a node failure or pre-emption.
    pub retried: usize,
}

/// A task being followed, with the job it runs.
struct Tracked {
    task: Task,
    job: Job,
    spec: RunSpec,
    /// When it was first seen out of the queue without a result.
    gone_since: Option<Instant>,
}

pub struct SlurmExecutor<'a> {
    settings: SlurmSettings,
    store: &'a mut Store,
    interrupted: Arc<AtomicBool>,
    /// The demcal the nodes run.
    demcal: PathBuf,
    run_folder: PathBuf,
    max_array: usize,
    gpus: usize,
    terminal: bool,
    /// Reasons for waiting already warned about.
    warned: BTreeSet<String>,
    pub stats: SlurmStats,
}

impl<'a> SlurmExecutor<'a> {
    /// Checks that Slurm answers, that the files the nodes need are there, and prepares the run
    /// folder.
    pub fn new(
        settings: SlurmSettings,
        store: &'a mut Store,
        interrupted: Arc<AtomicBool>,
        study: &Study,
    ) -> Result<Self, String> {
        let version = queue::check_available()?;
        let demcal = match &settings.demcal {
            Some(d) => d.clone(),
            None => std::env::current_exe().map_err(|e| {
                format!("cannot tell which demcal is running ({e}); set demcal in [executor]")
            })?,
        };
        // The nodes see the same paths (a shared file system), so what is missing here is
        // missing there: said now rather than as a stage of failed tasks.
        for (key, path) in [
            ("demcal", Some(&demcal)),
            ("environment_script", settings.environment_script.as_ref()),
        ] {
            if let Some(p) = path.filter(|p| !p.is_file()) {
                return Err(format!(
                    "{}: executor.{key}: {} is not a file here (the nodes must see it at the same path)",
                    study.path.display(),
                    p.display()
                ));
            }
        }
        let run_folder = settings
            .run_folder
            .clone()
            .unwrap_or_else(|| study.runs_dir().join("slurm"));
        let run_folder = std::path::absolute(&run_folder).unwrap_or(run_folder);
        // A backslash in sbatch's --output turns off its %A_%a: every log would be one file.
        if run_folder.to_string_lossy().contains('\\') {
            return Err(format!(
                "{}: executor.run_folder: {} holds a backslash, which sbatch's log names cannot take",
                study.path.display(),
                run_folder.display()
            ));
        }
        std::fs::create_dir_all(run_folder.join("logs")).map_err(|e| {
            format!(
                "{}: executor.run_folder: {}: cannot create: {e}",
                study.path.display(),
                run_folder.display()
            )
        })?;
        let gpus = settings
            .gpus_per_run
            .unwrap_or(usize::from(study.backend == "gpu"));
        if let (Some(limit), Some(minutes)) = (
            study.run_time_limit_s,
            settings
                .time_limit
                .as_deref()
                .and_then(settings::slurm_time_minutes),
        ) {
            if limit > minutes as f64 * 60.0 {
                eprintln!(
                    "warning: run_time_limit_s = {limit} s is longer than the Slurm time limit ({minutes} min): Slurm will stop long runs first"
                );
            }
        }
        eprintln!(
            "Slurm executor ({version}): run folder {}, nodes run {}",
            run_folder.display(),
            demcal.display()
        );
        Ok(SlurmExecutor {
            settings,
            store,
            interrupted,
            demcal,
            run_folder,
            max_array: queue::max_array_size().max(2),
            gpus,
            terminal: std::io::stderr().is_terminal(),
            warned: BTreeSet::new(),
            stats: SlurmStats::default(),
        })
    }

    /// The task's result when its record file is there, whole and for this run.
    fn read_record(&self, t: &Tracked) -> Option<Result<RunRecord, String>> {
        let text = std::fs::read_to_string(&t.task.record_file).ok()?;
        let rec: RunRecord = match serde_json::from_str(&text) {
            Ok(r) => r,
            Err(e) => {
                return Some(Err(format!(
                    "{}: unreadable result: {e}",
                    t.task.record_file.display()
                )))
            }
        };
        if rec.stage != t.spec.stage
            || rec.index != t.spec.index
            || rec.fingerprint != t.task.fingerprint
        {
            return Some(Err(format!(
                "{}: the result is for another run (stage {} run {})",
                t.task.record_file.display(),
                rec.stage + 1,
                rec.index + 1
            )));
        }
        Some(Ok(rec))
    }

    /// Stores a finished task's run (its result, or a failure), and says so.
    fn store_run(
        &mut self,
        study: &Study,
        stage_name: &str,
        t: &Tracked,
        mut rec: RunRecord,
        bar: &ProgressBar,
    ) -> Result<RunRecord, String> {
        rec.executor = format!("slurm job {}", t.task.name());
        self.store.store_task_run(t.task.id, &rec)?;
        self.stats.stored += 1;
        let outcome = crate::runner::outcome(study, &rec);
        bar.inc(1);
        let line = format!(
            "{stage_name}: run {} ({}) {outcome} ({:.1} s, {}{})",
            t.spec.index + 1,
            t.spec.label,
            rec.wall_s,
            rec.executor,
            if rec.host.is_empty() {
                String::new()
            } else {
                format!(" on {}", rec.host)
            }
        );
        if self.terminal {
            bar.println(line);
        } else {
            eprintln!("{line}");
        }
        Ok(rec)
    }

    /// A failed run the coordinator records itself (Slurm ended the task): made on `node`,
    /// if Slurm said which, never on this login node.
    fn failure(
        t: &Tracked,
        kind: RunErrorKind,
        message: String,
        wall_s: f64,
        node: &str,
    ) -> RunRecord {
        let mut rec = t.job.record(Some(RunError::new(kind, message)), wall_s);
        rec.host = if node == "(null)" {
            String::new()
        } else {
            node.to_string()
        };
        rec
    }

    /// Ctrl-C came while `open` tasks are out: cancel them (asking first when told to) or leave
    /// them for the next coordinator. Results that come in while cancelling are stored. Returns
    /// the line to add to the interrupt's message.
    fn interrupted_with(
        &mut self,
        study: &Study,
        stage_name: &str,
        open: Vec<Tracked>,
        finished: &mut Vec<RunRecord>,
        bar: &ProgressBar,
    ) -> Result<String, String> {
        if open.is_empty() {
            return Ok(String::new());
        }
        let cancel = match self.settings.on_interrupt {
            OnInterrupt::Cancel => true,
            OnInterrupt::Leave => false,
            OnInterrupt::Ask if std::io::stdin().is_terminal() => {
                let answer = bar.suspend(|| {
                    eprint!(
                        "{} task(s) are still queued or running on Slurm. Cancel them (scancel)? [y/N] ",
                        open.len()
                    );
                    let _ = std::io::stderr().flush();
                    let mut line = String::new();
                    let _ = std::io::stdin().lock().read_line(&mut line);
                    line
                });
                matches!(answer.trim(), "y" | "Y" | "yes" | "Yes")
            }
            OnInterrupt::Ask => false,
        };
        let leave = format!(
            "{} task(s) left queued or running on Slurm: the next demcal run collects them",
            open.len()
        );
        if !cancel {
            return Ok(leave);
        }
        let tasks: Vec<Task> = open.iter().map(|t| t.task.clone()).collect();
        // Cancelled ones are not closed yet: a task that ends in between has its result kept.
        let cancelled = submit::cancel_tasks(&tasks);
        if let Err(e) = cancelled {
            eprintln!("warning: {e}");
            return Ok(leave);
        }
        let mut n = 0;
        for t in open {
            match self.read_record(&t) {
                Some(Ok(rec)) => finished.push(self.store_run(study, stage_name, &t, rec, bar)?),
                _ => {
                    self.store
                        .close_task(t.task.id, "cancelled", "cancelled at Ctrl-C")?;
                    n += 1;
                }
            }
        }
        Ok(format!("cancelled {n} queued or running task(s)"))
    }
}

impl Execute for SlurmExecutor<'_> {
    fn execute(
        &mut self,
        study: &Study,
        stage: &StageResult,
        runs: &[RunSpec],
    ) -> Result<Vec<RunRecord>, String> {
        let stage_name = format!(
            "stage {}/{} {}",
            stage.index + 1,
            study.plan.len(),
            stage.kind
        );
        let (mut tracked, fresh) = self.reattach(study, stage, runs)?;
        let mut items = Vec::new();
        for spec in fresh {
            let job = Job::new(study, &spec);
            // Retries count across coordinators: after the tasks Slurm already ended.
            let attempt = 1 + self
                .store
                .retried(spec.stage, spec.index, &job.fingerprint)?;
            items.push((job, spec, attempt));
        }
        tracked.extend(self.submit(study, stage, items)?);
        let bar = if self.terminal {
            let bar = ProgressBar::with_draw_target(
                Some(stage.runs.len() as u64),
                ProgressDrawTarget::stderr(),
            );
            bar.set_style(
                ProgressStyle::with_template(
                    "{prefix:.bold} [{bar:30.cyan/blue}] {pos}/{len} runs  {elapsed_precise}  {msg}",
                )
                .expect("a valid template")
                .progress_chars("=> "),
            );
            bar
        } else {
            ProgressBar::hidden()
        };
        bar.set_prefix(stage_name.clone());
        bar.set_position((stage.runs.len() - runs.len()) as u64);
        let poll = Duration::from_secs_f64(self.settings.poll_s);
        // A task out of the queue gets this long for its result file to appear before Slurm is
        // asked why it ended.
        let grace = (poll * 2).clamp(Duration::from_secs(5), Duration::from_secs(120));
        let every = crate::runner::log_interval().max(poll);
        let mut last_log: Option<(Instant, String)> = None;
        let mut finished = Vec::new();
        let mut queue_warned = false;
        loop {
            // The queue first, then the result files: a task that leaves the queue in between
            // has its result found on the next look.
            let ids: Vec<String> = tracked
                .iter()
                .filter_map(|t| t.task.job_id.clone())
                .collect::<BTreeSet<_>>()
                .into_iter()
                .collect();
            let queued = match queue::squeue(&ids) {
                Ok(q) => {
                    queue_warned = false;
                    Some(q)
                }
                Err(e) => {
                    if !queue_warned {
                        eprintln!(
                            "warning: {e}; trying again every {:.0} s",
                            poll.as_secs_f64()
                        );
                        queue_warned = true;
                    }
                    None
                }
            };
            // Listing a folder makes a network file system look again at what it holds.
            let folders: BTreeSet<PathBuf> = tracked
                .iter()
                .filter_map(|t| t.task.record_file.parent().map(PathBuf::from))
                .collect();
            for f in folders {
                let _ = std::fs::read_dir(f).map(|d| d.count());
            }
            let mut retry = Vec::new();
            let mut keep = Vec::new();
            let mut running = 0;
            let mut waiting: BTreeMap<String, usize> = BTreeMap::new();
            let mut waiting_jobs: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
            for mut t in std::mem::take(&mut tracked) {
                match self.read_record(&t) {
                    Some(Ok(rec)) => {
                        finished.push(self.store_run(study, &stage_name, &t, rec, &bar)?);
                        continue;
                    }
                    // Maybe being written: judged once the task has been out of the queue a while.
                    Some(Err(e)) if t.gone_since.is_some_and(|s| s.elapsed() >= grace) => {
                        let rec = Self::failure(&t, RunErrorKind::Cluster, e, 0.0, "");
                        finished.push(self.store_run(study, &stage_name, &t, rec, &bar)?);
                        continue;
                    }
                    _ => {}
                }
                let Some(q) = &queued else {
                    keep.push(t);
                    continue;
                };
                // A task never given a job id is not in the queue (its name was looked for).
                let place = t
                    .task
                    .job_id
                    .as_ref()
                    .and_then(|j| q.get(&(j.clone(), t.task.task)));
                if let Some(place) = place {
                    if place.running() {
                        running += 1;
                    } else {
                        *waiting.entry(place.reason.clone()).or_default() += 1;
                        if let Some(j) = &t.task.job_id {
                            waiting_jobs
                                .entry(place.reason.clone())
                                .or_default()
                                .insert(j.clone());
                        }
                    }
                    t.gone_since = None;
                    keep.push(t);
                    continue;
                }
                let since = *t.gone_since.get_or_insert_with(Instant::now);
                if since.elapsed() < grace {
                    keep.push(t);
                    continue;
                }
                let log = t.task.log();
                let ending = match &t.task.job_id {
                    Some(job_id) => queue::ending(job_id, t.task.task, &log),
                    None => queue::Ending::default(),
                };
                // demcal run-one exits 0 only after writing its result: the file is on its way.
                if ending.state == "COMPLETED"
                    && ending.exit_code.starts_with("0:")
                    && since.elapsed() < RESULT_SHOWS_WITHIN
                {
                    keep.push(t);
                    continue;
                }
                match queue::verdict(&ending, &t.task.name(), &log, &queue::log_tail(&log)) {
                    Verdict::Wait => {
                        t.gone_since = None;
                        keep.push(t);
                    }
                    Verdict::Retry(why) if t.task.attempt <= self.settings.retries => {
                        eprintln!(
                            "{stage_name}: run {} will be submitted again: {why}",
                            t.spec.index + 1
                        );
                        self.store.close_task(t.task.id, "retried", &why)?;
                        retry.push(t);
                    }
                    Verdict::Retry(why) => {
                        let msg = format!(
                            "Slurm ended the run's task {} time(s), the last time: {why}",
                            t.task.attempt
                        );
                        let rec = Self::failure(&t, RunErrorKind::Cluster, msg, 0.0, &ending.node);
                        finished.push(self.store_run(study, &stage_name, &t, rec, &bar)?);
                    }
                    Verdict::Fail(kind, msg) => {
                        let wall = seconds(&ending.run_time);
                        let rec = Self::failure(&t, kind, msg, wall, &ending.node);
                        finished.push(self.store_run(study, &stage_name, &t, rec, &bar)?);
                    }
                }
            }
            tracked = keep;
            if !retry.is_empty() {
                self.stats.retried += retry.len();
                let items = retry
                    .into_iter()
                    .map(|t| (t.job, t.spec, t.task.attempt + 1))
                    .collect();
                tracked.extend(self.submit(study, stage, items)?);
            }
            if tracked.is_empty() {
                break;
            }
            self.warn_stuck(&stage_name, &waiting, &waiting_jobs);
            let jobs = job_list(tracked.iter().filter_map(|t| t.task.job_id.as_deref()));
            let queued_n: usize = waiting.values().sum();
            let reasons = status::reasons(&waiting.iter().map(|(r, n)| (r.as_str(), *n)).collect());
            let line = format!("{queued_n} queued{reasons}, {running} running (job {jobs})");
            bar.set_message(line.clone());
            // Off a terminal: the line when it changes (at most every few seconds), and once a
            // minute or so in any case, so a long stage never looks hung.
            let due = match &last_log {
                None => true,
                Some((at, said)) => {
                    at.elapsed() >= every && (*said != line || at.elapsed() >= every * 12)
                }
            };
            if !self.terminal && due {
                eprintln!("{stage_name}: {line}");
                last_log = Some((Instant::now(), line));
            }
            // Sleep in slices so that Ctrl-C is answered at once.
            let until = Instant::now() + poll;
            while Instant::now() < until && !self.interrupted.load(Ordering::Relaxed) {
                std::thread::sleep(Duration::from_millis(100).min(poll));
            }
            if self.interrupted.load(Ordering::Relaxed) {
                // Results that arrived meanwhile are kept.
                let mut open = Vec::new();
                for t in std::mem::take(&mut tracked) {
                    match self.read_record(&t) {
                        Some(Ok(rec)) => {
                            finished.push(self.store_run(study, &stage_name, &t, rec, &bar)?)
                        }
                        _ => open.push(t),
                    }
                }
                let left = self.interrupted_with(study, &stage_name, open, &mut finished, &bar)?;
                bar.finish_and_clear();
                return Err(format!(
                    "interrupted: {} finished runs are stored in {}{}; run the same command again to go on",
                    finished.len(),
                    self.store.path.display(),
                    if left.is_empty() { String::new() } else { format!("; {left}") }
                ));
            }
        }
        bar.finish_and_clear();
        let done = finished.iter().filter(|r| r.status == Status::Done).count();
        eprintln!(
            "{stage_name}: {done} done, {} failed",
            finished.len() - done
        );
        Ok(finished)
    }
}

impl SlurmExecutor<'_> {
    /// Warns once per reason when tasks wait for something that does not clear by itself.
    fn warn_stuck(
        &mut self,
        stage_name: &str,
        waiting: &BTreeMap<String, usize>,
        jobs: &BTreeMap<String, BTreeSet<String>>,
    ) {
        for (reason, n) in waiting {
            if queue::never_clears(reason) && self.warned.insert(reason.clone()) {
                let ids = jobs.get(reason).cloned().unwrap_or_default();
                let list = job_list(ids.iter().map(String::as_str));
                eprintln!(
                    "warning: {stage_name}: {n} task(s) of job {list} wait with reason {reason}, which does not clear by itself (a hold, or more than the partition, QOS or account allows): check [executor] (time_limit, partition, account, qos, memory) or ask the administrators; `scancel {}` withdraws them, and their runs are then stored as failed",
                    list.replace(", ", " ")
                );
            }
        }
    }
}

/// Seconds in Slurm's `[D-]HH:MM:SS` (0 when it cannot be read).
fn seconds(s: &str) -> f64 {
    let (days, rest) = match s.split_once('-') {
        Some((d, r)) => (d.parse::<f64>().unwrap_or(0.0), r),
        None => (0.0, s),
    };
    let parts: Vec<f64> = rest.split(':').filter_map(|p| p.parse().ok()).collect();
    let hms = parts.iter().fold(0.0, |acc, p| acc * 60.0 + p);
    days * 86400.0 + hms
}

#[cfg(test)]
mod tests {
    #[test]
    fn slurm_times_in_seconds() {
        assert_eq!(super::seconds("00:01:14"), 74.0);
        assert_eq!(super::seconds("1-00:00:01"), 86401.0);
        assert_eq!(super::seconds(""), 0.0);
    }
}
