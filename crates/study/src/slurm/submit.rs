//! Sending a stage's runs out and finding them again: `submit` writes one folder per submission
//! (job files, task list, batch script; the tasks' results land beside their job files, so a
//! result from an older submission can never pass for a newer one's), records its tasks, then
//! calls sbatch; `reattach` takes up the tasks an earlier coordinator left, and withdraws those
//! the study no longer wants.

use std::collections::{BTreeSet, HashMap};
use std::path::{Path, PathBuf};
use std::sync::atomic::Ordering;

use super::ledger::Task;
use super::{queue, script, SlurmExecutor, Tracked};
use crate::job::Job;
use crate::record::{RunSpec, StageResult};
use crate::spec::Study;
use crate::store::{now_utc, Store};

impl SlurmExecutor<'_> {
    /// The folder of a stage's submissions.
    fn stage_folder(&self, stage: &StageResult) -> PathBuf {
        self.run_folder
            .join(format!("stage{}-{}", stage.index + 1, stage.kind))
    }

    /// Writes the job files, task lists and scripts, records the tasks, and submits one array
    /// per `MaxArraySize - 1` runs; `items` are each run's job, spec and attempt. The stage's
    /// throttle is shared among its arrays.
    pub(super) fn submit(
        &mut self,
        study: &Study,
        stage: &StageResult,
        items: Vec<(Job, RunSpec, usize)>,
    ) -> Result<Vec<Tracked>, String> {
        let mut tracked = Vec::new();
        let chunk = self.max_array - 1;
        let total = items.len();
        let mut items = items.into_iter().peekable();
        while items.peek().is_some() {
            let part: Vec<_> = items.by_ref().take(chunk).collect();
            // A stage split into several arrays shares its throttle in proportion to their sizes.
            let throttle = (self.settings.max_running * part.len())
                .div_ceil(total)
                .max(1);
            let token = token();
            let folder = self.stage_folder(stage).join(&token);
            std::fs::create_dir_all(&folder).map_err(|e| {
                format!(
                    "executor.run_folder: {}: cannot create: {e}",
                    folder.display()
                )
            })?;
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
            let tasks_file = folder.join("tasks");
            let script_file = folder.join("array.sh");
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
            // Recorded before sbatch runs: whatever happens next, the next start looks for them.
            let ids = self.store.add_tasks(&tasks)?;
            let job_id = queue::submit(
                &script_file,
                part.len(),
                throttle,
                &job_name,
                &self.run_folder.join("logs"),
            )
            .map_err(|e| {
                // sbatch may have made the array and failed to say so (a timeout): its tasks stay
                // open without a job id, and the next start looks for them by name.
                format!(
                    "stage {} ({}): {e}; the next demcal run looks for this submission ({job_name}) before submitting again",
                    stage.index + 1,
                    stage.kind
                )
            })?;
            self.store.set_job_id(&token, &job_id)?;
            self.stats.arrays += 1;
            self.stats.tasks += part.len();
            eprintln!(
                "stage {} ({}): submitted job {job_id}: {} runs as tasks 0-{} (at most {throttle} at once){}",
                stage.index + 1,
                stage.kind,
                part.len(),
                part.len() - 1,
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
    /// followed again; those of runs no longer wanted (the study changed) are withdrawn. Returns
    /// the tasks to follow and the runs to submit.
    pub(super) fn reattach(
        &mut self,
        study: &Study,
        stage: &StageResult,
        runs: &[RunSpec],
    ) -> Result<(Vec<Tracked>, Vec<RunSpec>), String> {
        let mut open: Vec<Task> = self
            .store
            .cluster_tasks(true)?
            .into_iter()
            .filter(|t| t.stage == stage.index)
            .collect();
        // Submissions whose job id was never recorded (the coordinator died in sbatch, or
        // sbatch failed to answer): found by their job name, which carries their token.
        let unnamed: BTreeSet<(String, String)> = open
            .iter()
            .filter(|t| t.job_id.is_none())
            .map(|t| (t.token.clone(), t.job_name.clone()))
            .collect();
        for (token, name) in unnamed {
            if let Some((job_id, _)) = queue::squeue_by_name(&name)?.keys().next() {
                self.store.set_job_id(&token, job_id)?;
                for t in open.iter_mut().filter(|t| t.token == token) {
                    t.job_id = Some(job_id.clone());
                }
            }
        }
        let mut by_index: HashMap<usize, Task> = HashMap::new();
        let mut stale = Vec::new();
        for t in open {
            // The newest attempt of a run counts; an older one still open is withdrawn.
            match by_index.get(&t.index) {
                Some(old) if old.id > t.id => stale.push(t),
                _ => stale.extend(by_index.insert(t.index, t)),
            }
        }
        let mut tracked = Vec::new();
        let mut fresh = Vec::new();
        for spec in runs {
            let job = Job::new(study, spec);
            match by_index.remove(&spec.index) {
                // Not in the queue and never named: ended already (its result may be there)
                // or never submitted.
                Some(t) if t.job_id.is_none() && !t.record_file.exists() => {
                    self.store.close_task(
                        t.id,
                        "dropped",
                        "sbatch's answer was never recorded and no such job is queued",
                    )?;
                    fresh.push(spec.clone());
                }
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
        // A stale task left running would wipe and rewrite its run's picture folder, which the
        // run submitted afresh now uses too: nothing is submitted until they are withdrawn.
        withdraw(
            self.store,
            &stale,
            "dropped",
            "the study no longer plans this run (changed, or stored meanwhile)",
        )
        .map_err(|e| {
            format!(
                "stage {} ({}): cannot withdraw the tasks of runs the study no longer plans: {e}; cancel them (scancel) and run again",
                stage.index + 1,
                stage.kind
            )
        })?;
        if !tracked.is_empty() {
            eprintln!(
                "stage {} ({}): re-attached to {} task(s) of Slurm job(s) {} submitted earlier",
                stage.index + 1,
                stage.kind,
                tracked.len(),
                crate::text::job_list(tracked.iter().filter_map(|t| t.task.job_id.as_deref()))
            );
            self.stats.reattached += tracked.len();
        }
        Ok((tracked, fresh))
    }
}

/// Cancels `tasks` and closes them as `state` with `note`. When the cancel fails nothing is
/// closed: the next coordinator looks at them again.
pub(super) fn withdraw(
    store: &Store,
    tasks: &[Task],
    state: &str,
    note: &str,
) -> Result<(), String> {
    cancel_tasks(tasks)?;
    for t in tasks {
        store.close_task(t.id, state, note)?;
    }
    Ok(())
}

/// `scancel`s `tasks`: by `A_T` where the job id is known, else by their submission's name.
pub(super) fn cancel_tasks(tasks: &[Task]) -> Result<(), String> {
    if tasks.is_empty() {
        return Ok(());
    }
    let named: Vec<String> = tasks
        .iter()
        .filter(|t| t.job_id.is_some())
        .map(Task::name)
        .collect();
    let unnamed: BTreeSet<&str> = tasks
        .iter()
        .filter(|t| t.job_id.is_none())
        .map(|t| t.job_name.as_str())
        .collect();
    let mut result = queue::cancel(&named);
    for name in unnamed {
        result = result.and(queue::cancel_by_name(name));
    }
    result
}

/// `demcal run --restart`: the old store's tasks still out are cancelled before it is moved
/// aside, so that none of them goes on writing into the run folders the new study uses.
pub fn withdraw_open(store: &Store) -> Result<usize, String> {
    let open = store.cluster_tasks(true)?;
    if open.is_empty() {
        return Ok(0);
    }
    let jobs = crate::text::job_list(open.iter().filter_map(|t| t.job_id.as_deref()));
    // The old store is moved aside whatever happens: a restart must always be possible.
    let cancelled = queue::check_available().and_then(|_| {
        withdraw(
            store,
            &open,
            "cancelled",
            "cancelled by demcal run --restart",
        )
    });
    match cancelled {
        Ok(()) => Ok(open.len()),
        Err(e) => {
            eprintln!(
                "warning: {} Slurm task(s) of the old results may still be queued or running (jobs {jobs}) and could not be cancelled ({e}): cancel them with scancel before their runs start again",
                open.len()
            );
            Ok(0)
        }
    }
}

/// A short token unique to this submission (its folder and job name carry it).
pub(super) fn token() -> String {
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

/// The study file's stem as a job name (letters, digits, - and _).
fn stem(study: &Study) -> String {
    study
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
        .collect()
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

#[cfg(test)]
mod tests {
    #[test]
    fn tokens_differ() {
        let a = super::token();
        let b = super::token();
        assert_ne!(a, b);
        assert_eq!(a.len(), 8);
    }
}
