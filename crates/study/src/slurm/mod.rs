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
//!   ended meanwhile, instead of submitting them again. A task written but never given a job id
//!   (killed during `sbatch`) is looked for by its job name, which carries the submission's token.
//! - **No accounting needed.** What is queued comes from `squeue`; why a task left the queue
//!   without a result from `scontrol show job`, else `sacct`, else the line Slurm writes into the
//!   task's log when it kills it ([`queue`]).
//! - **Failures are results.** A time-limit kill is a failed run of kind `time_limit`; memory,
//!   cancellation and start-up errors are kind `cluster`; a node failure or pre-emption is not the
//!   run's fault and is submitted again (`retries`, default once) before it is stored as failed.
//! - **Ctrl-C** asks whether to `scancel` the stage's queued and running tasks or leave them for
//!   the next `demcal run` (`on_interrupt`).

pub mod ledger;
pub mod queue;
pub mod script;
pub mod settings;

use std::collections::{BTreeSet, HashMap};
use std::io::{BufRead, IsTerminal, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

use crate::job::Job;
use crate::run_error::{RunError, RunErrorKind};
use crate::spec::Study;
use crate::stages::{Execute, RunSpec, StageResult};
use crate::store::{now_utc, RunRecord, Status, Store};
use ledger::Task;
use queue::Verdict;
pub use settings::{ExecutorSpec, OnInterrupt, SlurmSettings};

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
    pub stats: SlurmStats,
}

impl<'a> SlurmExecutor<'a> {
    /// Checks that Slurm answers and prepares the run folder.
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
        let run_folder = settings
            .run_folder
            .clone()
            .unwrap_or_else(|| study.runs_dir().join("slurm"));
        let run_folder = std::path::absolute(&run_folder).unwrap_or(run_folder);
        std::fs::create_dir_all(run_folder.join("logs")).map_err(|e| {
            format!(
                "{}: cannot create the run folder: {e}",
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
            stats: SlurmStats::default(),
        })
    }

    /// The folder of a stage's job files and scripts.
    fn stage_folder(&self, stage: &StageResult) -> PathBuf {
        self.run_folder
            .join(format!("stage{}-{}", stage.index + 1, stage.kind))
    }

    /// Writes the job files, the task lists and scripts, records the tasks, and submits one
    /// array per `max_array` runs.
    fn submit(
        &mut self,
        study: &Study,
        stage: &StageResult,
        items: Vec<(Job, RunSpec, usize)>,
    ) -> Result<Vec<Tracked>, String> {
        let folder = self.stage_folder(stage);
        std::fs::create_dir_all(&folder)
            .map_err(|e| format!("{}: cannot create: {e}", folder.display()))?;
        let mut tracked = Vec::new();
        let chunk = self.max_array - 1;
        let mut items = items.into_iter().peekable();
        while items.peek().is_some() {
            let part: Vec<_> = items.by_ref().take(chunk).collect();
            let token = token();
            let base = self
                .settings
                .job_name
                .clone()
                .unwrap_or_else(|| format!("demcal-{}", stem(study)));
            let job_name = format!("{base}-s{}-{token}", stage.index + 1);
            let mut list = String::new();
            let mut tasks = Vec::new();
            for (i, (job, spec, attempt)) in part.iter().enumerate() {
                let name = format!("run{:03}", spec.index + 1);
                // `demcal run-one` writes its record beside the job file: runNNN.record.json.
                let job_file = folder.join(format!("{name}.json"));
                let record_file = folder.join(format!("{name}.record.json"));
                // A result left by an earlier attempt must not pass for this one's.
                let _ = std::fs::remove_file(&record_file);
                write_atomic(&job_file, &job.to_json())?;
                list.push_str(&job_file.display().to_string());
                list.push('\n');
                tasks.push(Task {
                    id: 0,
                    stage: stage.index,
                    index: spec.index,
                    attempt: *attempt,
                    token: token.clone(),
                    job_name: job_name.clone(),
                    job_id: None,
                    task: i as u32,
                    fingerprint: job.fingerprint.clone(),
                    job_file,
                    record_file,
                    log_dir: self.run_folder.join("logs"),
                    submitted_at: now_utc(),
                    state: "open".into(),
                    note: None,
                });
            }
            let tasks_file = folder.join(format!("array-{token}.tasks"));
            let script_file = folder.join(format!("array-{token}.sh"));
            write_atomic(&tasks_file, &list)?;
            let what = format!(
                "study {}, stage {} ({}), {} runs",
                study.path.display(),
                stage.index + 1,
                stage.kind,
                part.len()
            );
            write_atomic(
                &script_file,
                &script::batch_script(&self.settings, self.gpus, &what, &tasks_file, &self.demcal),
            )?;
            let ids = self.store.add_tasks(&tasks)?;
            let submitted = queue::submit(
                &script_file,
                part.len(),
                self.settings.max_running,
                &job_name,
                &self.run_folder.join("logs").join("%A_%a.out"),
            );
            let job_id = match submitted {
                Ok(id) => id,
                Err(e) => {
                    for id in &ids {
                        self.store.close_task(*id, "dropped", &e)?;
                    }
                    return Err(format!("stage {} ({}): {e}", stage.index + 1, stage.kind));
                }
            };
            self.store.set_job_id(&token, &job_id)?;
            self.stats.arrays += 1;
            self.stats.tasks += part.len();
            eprintln!(
                "stage {} ({}): submitted job {job_id}: {} runs as tasks 0-{} (at most {} at once){}",
                stage.index + 1,
                stage.kind,
                part.len(),
                part.len() - 1,
                self.settings.max_running,
                if part.iter().any(|p| p.2 > 1) {
                    ", submitted again after Slurm ended their tasks"
                } else {
                    ""
                }
            );
            for ((job, spec, _), (mut task, id)) in part.into_iter().zip(tasks.into_iter().zip(ids))
            {
                task.id = id;
                task.job_id = Some(job_id.clone());
                tracked.push(Tracked {
                    task,
                    job,
                    spec,
                    gone_since: None,
                });
            }
        }
        Ok(tracked)
    }

    /// The tasks of this stage that an earlier coordinator left open: those still good are
    /// followed again; those of runs no longer wanted (the study changed) are withdrawn.
    fn reattach(
        &mut self,
        study: &Study,
        stage: &StageResult,
        runs: &[RunSpec],
    ) -> Result<(Vec<Tracked>, Vec<RunSpec>), String> {
        let open: Vec<Task> = self
            .store
            .cluster_tasks(true)?
            .into_iter()
            .filter(|t| t.stage == stage.index)
            .collect();
        let mut by_index: HashMap<usize, Task> = HashMap::new();
        let mut stale = Vec::new();
        for t in open {
            // Only the newest attempt of a run counts; older ones were closed when retried.
            if let Some(old) = by_index.insert(t.index, t) {
                stale.push(old);
            }
        }
        let mut tracked = Vec::new();
        let mut fresh = Vec::new();
        for spec in runs {
            let job = Job::new(study, spec);
            match by_index.remove(&spec.index) {
                Some(t) if t.fingerprint == job.fingerprint => tracked.push(Tracked {
                    task: t,
                    job,
                    spec: spec.clone(),
                    gone_since: None,
                }),
                Some(t) => {
                    stale.push(t);
                    fresh.push(spec.clone());
                }
                None => fresh.push(spec.clone()),
            }
        }
        stale.extend(by_index.into_values());
        let withdraw: Vec<String> = stale
            .iter()
            .filter(|t| t.job_id.is_some())
            .map(Task::name)
            .collect();
        if !withdraw.is_empty() {
            if let Err(e) = queue::cancel(&withdraw) {
                eprintln!("warning: {e}");
            }
        }
        for t in &stale {
            self.store.close_task(
                t.id,
                "dropped",
                "the study no longer plans this run (changed or already stored)",
            )?;
        }
        // Tasks written but never given a job id: the coordinator died during sbatch.
        let tokens: BTreeSet<(String, String)> = tracked
            .iter()
            .filter(|t| t.task.job_id.is_none())
            .map(|t| (t.task.token.clone(), t.task.job_name.clone()))
            .collect();
        for (token, name) in tokens {
            let found = queue::squeue_by_name(&name)?;
            match found.keys().next() {
                Some((job_id, _)) => {
                    self.store.set_job_id(&token, job_id)?;
                    for t in tracked.iter_mut().filter(|t| t.task.token == token) {
                        t.task.job_id = Some(job_id.clone());
                    }
                }
                None => {
                    // Not in the queue: ended already (its results may be there) or never
                    // submitted. Results are collected below; the others are submitted again.
                    let (done, lost): (Vec<_>, Vec<_>) = std::mem::take(&mut tracked)
                        .into_iter()
                        .partition(|t| t.task.token != token || t.task.record_file.exists());
                    tracked = done;
                    for t in lost {
                        self.store.close_task(
                            t.task.id,
                            "dropped",
                            "sbatch's answer was never recorded and no such job is queued",
                        )?;
                        fresh.push(t.spec);
                    }
                }
            }
        }
        if !tracked.is_empty() {
            let jobs = job_list(tracked.iter().filter_map(|t| t.task.job_id.as_deref()));
            eprintln!(
                "stage {} ({}): re-attached to {} task(s) of Slurm job(s) {} submitted earlier",
                stage.index + 1,
                stage.kind,
                tracked.len(),
                jobs
            );
            self.stats.reattached += tracked.len();
        }
        Ok((tracked, fresh))
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
        let outcome = match (&rec.status, rec.response) {
            (Status::Done, Some(y)) => {
                format!("{} = {}", study.target.response, crate::stages::sig(y))
            }
            _ => format!(
                "failed ({}): {}",
                rec.error_kind.map(|k| k.as_str()).unwrap_or("unknown"),
                rec.error.clone().unwrap_or_default()
            ),
        };
        bar.inc(1);
        let line = format!(
            "{stage_name}: run {} ({}) {outcome} ({:.1} s, {} on {})",
            t.spec.index + 1,
            t.spec.label,
            rec.wall_s,
            rec.executor,
            if rec.host.is_empty() { "?" } else { &rec.host }
        );
        if self.terminal {
            bar.println(line);
        } else {
            eprintln!("{line}");
        }
        Ok(rec)
    }

    /// What to do when Ctrl-C came while `open` tasks are out: cancel them or leave them.
    fn interrupted_with(&mut self, open: &[Tracked], bar: &ProgressBar) -> Result<bool, String> {
        if open.is_empty() {
            return Ok(false);
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
        if cancel {
            let ids: Vec<String> = open.iter().map(|t| t.task.name()).collect();
            queue::cancel(&ids)?;
            for t in open {
                self.store
                    .close_task(t.task.id, "cancelled", "cancelled at Ctrl-C")?;
            }
        }
        Ok(cancel)
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
        let items = fresh
            .into_iter()
            .map(|spec| (Job::new(study, &spec), spec, 1))
            .collect();
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
        // A task out of the queue gets this long for its result file to appear (a shared file
        // system may show it late) before Slurm is asked why it ended.
        let grace = (poll * 2).clamp(Duration::from_secs(5), Duration::from_secs(120));
        let every = crate::runner::log_interval().max(poll);
        let mut last_log = Instant::now();
        let mut last_counts = (usize::MAX, usize::MAX);
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
            let mut retry = Vec::new();
            let mut keep = Vec::new();
            let (mut waiting, mut running) = (0, 0);
            for mut t in std::mem::take(&mut tracked) {
                if let Some(result) = self.read_record(&t) {
                    match result {
                        Ok(rec) => {
                            finished.push(self.store_run(study, &stage_name, &t, rec, &bar)?);
                            continue;
                        }
                        // Maybe being written: judged once the task has left the queue.
                        Err(e) if t.gone_since.is_none_or(|s| s.elapsed() < grace) => {
                            let _ = e;
                        }
                        Err(e) => {
                            let rec = t
                                .job
                                .record(Some(RunError::new(RunErrorKind::Cluster, e)), 0.0);
                            finished.push(self.store_run(study, &stage_name, &t, rec, &bar)?);
                            continue;
                        }
                    }
                }
                let (Some(q), Some(job_id)) = (&queued, t.task.job_id.clone()) else {
                    keep.push(t);
                    continue;
                };
                if let Some(place) = q.get(&(job_id.clone(), t.task.task)) {
                    if place.running() {
                        running += 1;
                    } else {
                        waiting += 1;
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
                let ending = queue::ending(&job_id, t.task.task, &log);
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
                        let msg = format!("Slurm ended the task {} time(s): {why}", t.task.attempt);
                        let rec = t
                            .job
                            .record(Some(RunError::new(RunErrorKind::Cluster, msg)), 0.0);
                        finished.push(self.store_run(study, &stage_name, &t, rec, &bar)?);
                    }
                    Verdict::Fail(kind, msg) => {
                        let wall = seconds(&ending.run_time);
                        let mut rec = t.job.record(Some(RunError::new(kind, msg)), wall);
                        if !ending.node.is_empty() && ending.node != "(null)" {
                            rec.host = ending.node.clone();
                        }
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
            let jobs = job_list(tracked.iter().filter_map(|t| t.task.job_id.as_deref()));
            let status = format!("{waiting} queued, {running} running (job {jobs})");
            bar.set_message(status.clone());
            if !self.terminal
                && ((waiting, running) != last_counts || last_log.elapsed() >= every * 12)
                && last_log.elapsed() >= every
            {
                eprintln!("{stage_name}: {status}");
                last_log = Instant::now();
                last_counts = (waiting, running);
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
                let cancelled = self.interrupted_with(&open, &bar)?;
                bar.finish_and_clear();
                let left = if open.is_empty() {
                    String::new()
                } else if cancelled {
                    format!("; cancelled {} queued or running task(s)", open.len())
                } else {
                    format!(
                        "; {} task(s) left queued or running on Slurm: the next demcal run collects them",
                        open.len()
                    )
                };
                return Err(format!(
                    "interrupted: {} finished runs are stored in {}{left}; run the same command again to go on",
                    finished.len(),
                    self.store.path.display()
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

/// Job ids in numeric order, each once, joined by commas.
pub fn job_list<'s>(ids: impl Iterator<Item = &'s str>) -> String {
    let set: BTreeSet<(usize, &str)> = ids.map(|i| (i.len(), i)).collect();
    set.into_iter()
        .map(|(_, i)| i)
        .collect::<Vec<_>>()
        .join(", ")
}

/// A short token unique to this submission (its job name carries it).
fn token() -> String {
    use std::sync::atomic::AtomicU64;
    static COUNT: AtomicU64 = AtomicU64::new(0);
    let nanos = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_nanos() as u64)
        .unwrap_or(0);
    let mix = nanos
        ^ (u64::from(std::process::id()) << 32)
        ^ COUNT
            .fetch_add(1, Ordering::Relaxed)
            .wrapping_mul(0x9e37_79b9_7f4a_7c15);
    // SplitMix64's finaliser spreads the bits.
    let mut z = mix.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    format!("{:08x}", (z ^ (z >> 31)) as u32)
}

fn stem(study: &Study) -> String {
    let s: String = study
        .path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "study".into())
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                c
            } else {
                '_'
            }
        })
        .take(40)
        .collect();
    s
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

/// Writes a file whole or not at all (the nodes may read it the moment it is there).
fn write_atomic(path: &Path, text: &str) -> Result<(), String> {
    let mut tmp = path.as_os_str().to_owned();
    tmp.push(".tmp");
    let tmp = PathBuf::from(tmp);
    std::fs::write(&tmp, text)
        .and_then(|_| std::fs::rename(&tmp, path))
        .map_err(|e| format!("{}: cannot write: {e}", path.display()))
}

/// `demcal status`'s lines for the Slurm tasks: per stage, how many are queued, running, and
/// finished, with their job ids. Asks `squeue` for the open ones when it can.
pub fn status_lines(study: &Study, store: &Store) -> Result<String, String> {
    let tasks = store.cluster_tasks(false)?;
    if tasks.is_empty() {
        return Ok(String::new());
    }
    let open_ids: Vec<String> = tasks
        .iter()
        .filter(|t| t.state == "open")
        .filter_map(|t| t.job_id.clone())
        .collect::<BTreeSet<_>>()
        .into_iter()
        .collect();
    let queued = queue::squeue(&open_ids);
    let mut s = String::from("on Slurm:\n");
    let stages: BTreeSet<usize> = tasks.iter().map(|t| t.stage).collect();
    for stage in stages {
        let of: Vec<&Task> = tasks.iter().filter(|t| t.stage == stage).collect();
        let jobs: BTreeSet<&str> = of.iter().filter_map(|t| t.job_id.as_deref()).collect();
        let several = jobs.len() > 1;
        let stored = of.iter().filter(|t| t.state == "stored").count();
        let open: Vec<&&Task> = of.iter().filter(|t| t.state == "open").collect();
        let counts = match &queued {
            Ok(q) => {
                let (mut waiting, mut running, mut ended) = (0, 0, 0);
                for t in &open {
                    match t.job_id.as_ref().and_then(|j| q.get(&(j.clone(), t.task))) {
                        Some(p) if p.running() => running += 1,
                        Some(_) => waiting += 1,
                        None => ended += 1,
                    }
                }
                format!(
                    "{waiting} queued, {running} running, {stored} finished{}",
                    if ended > 0 {
                        format!(", {ended} ended and not yet collected")
                    } else {
                        String::new()
                    }
                )
            }
            Err(e) => format!(
                "{} submitted and not yet collected, {stored} finished (queue not readable here: {e})",
                open.len()
            ),
        };
        let retried = of.iter().filter(|t| t.state == "retried").count();
        let cancelled = of.iter().filter(|t| t.state == "cancelled").count();
        let kind = study.plan.get(stage).map(|p| p.kind()).unwrap_or("?");
        s.push_str(&format!(
            "  {}. {kind:<10} job{} {}: {counts}{}\n",
            stage + 1,
            if several { "s" } else { "" },
            job_list(jobs.into_iter()),
            [("submitted again", retried), ("cancelled", cancelled)]
                .iter()
                .filter(|(_, n)| *n > 0)
                .map(|(what, n)| format!(", {n} {what}"))
                .collect::<String>()
        ));
    }
    Ok(s)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tokens_differ_and_times_read() {
        let a = token();
        let b = token();
        assert_ne!(a, b);
        assert_eq!(a.len(), 8);
        assert_eq!(seconds("00:01:14"), 74.0);
        assert_eq!(seconds("1-00:00:01"), 86401.0);
        assert_eq!(seconds(""), 0.0);
    }
}
