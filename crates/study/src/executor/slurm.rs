//! `slurm`: each stage's missing runs as one job array on a Slurm cluster (`crate::slurm`, which
//! has the design notes); `--jobs` is the array's throttle. Its `[executor]` settings are
//! `crate::slurm::settings`.

use std::any::Any;
use std::path::Path;
use std::sync::atomic::AtomicBool;
use std::sync::Arc;

use crate::executor::def::ExecutorDef;
use crate::spec::Executor;
use crate::slurm::settings::{parse_slurm, KEYS, MOST_RUNNING};
use crate::slurm::{self as cluster, SlurmExecutor, SlurmSettings};
use crate::spec::Study;
use crate::record::Replay;
use crate::stages::replay;
use crate::store::{RunRecord, Store};

#[derive(Clone, Debug, Default, PartialEq)]
pub struct Slurm(pub SlurmSettings);

impl ExecutorDef for Slurm {
    const NAME: &'static str = "slurm";
    const KEYS: &'static [&'static str] = KEYS;

    fn parse(
        t: &toml::Table,
        dir: &Path,
        err: &dyn Fn(&str, String) -> String,
    ) -> Result<Self, String> {
        parse_slurm(t, dir, err).map(Slurm)
    }

    fn defaults() -> Self {
        Slurm(SlurmSettings::default())
    }

    fn withdraw(store: &Store) -> Result<usize, String> {
        cluster::withdraw_open(store)
    }

    fn status_lines(study: &Study, store: &Store) -> Result<String, String> {
        cluster::status_lines(study, store)
    }
}

impl Executor for Slurm {
    fn kind(&self) -> &'static str {
        Self::NAME
    }

    fn on_this_machine(&self) -> bool {
        false
    }

    /// `--jobs` is the array's throttle: the cluster's cores, not this machine's; this process
    /// only submits and collects.
    fn with_jobs(&self, jobs: usize) -> Result<(Arc<dyn Executor>, usize), String> {
        if !(1..=MOST_RUNNING).contains(&jobs) {
            return Err(format!(
                "--jobs {jobs}: with --executor slurm, expected 1 to {MOST_RUNNING} tasks at once"
            ));
        }
        let mut s = self.0.clone();
        s.max_running = jobs;
        Ok((Arc::new(Slurm(s)), 1))
    }

    fn preflight(&self) -> Result<(), String> {
        cluster::queue::check_available().map(|_| ())
    }

    fn run(
        &self,
        study: &Study,
        store: &mut Store,
        stored: &[RunRecord],
        _jobs: usize,
        interrupted: Arc<AtomicBool>,
    ) -> Result<(Result<Replay, String>, Option<String>), String> {
        let mut exec = SlurmExecutor::new(self.0.clone(), store, interrupted, study)?;
        let r = replay(study, stored, Some(&mut exec));
        let c = &exec.stats;
        let line = format!(
            "Slurm: {} run(s) stored from tasks; {} array(s) of {} task(s) submitted, {} submitted again, {} task(s) re-attached",
            c.stored, c.arrays, c.tasks, c.retried, c.reattached
        );
        Ok((r, Some(line)))
    }

    fn as_any(&self) -> &dyn Any {
        self
    }
}
