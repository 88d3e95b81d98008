//! `local`: the runs on this machine's cores (`runner::LocalExecutor`), `--jobs` at once.

use std::any::Any;
use std::path::Path;
use std::sync::atomic::AtomicBool;
use std::sync::Arc;

use crate::executor::def::ExecutorDef;
use crate::spec::Executor;
use crate::runner::LocalExecutor;
use crate::spec::Study;
use crate::record::Replay;
use crate::stages::replay;
use crate::store::{RunRecord, Store};

#[derive(Clone, Debug, Default, PartialEq)]
pub struct Local;

impl ExecutorDef for Local {
    const NAME: &'static str = "local";
    const KEYS: &'static [&'static str] = &[];

    fn parse(
        _t: &toml::Table,
        _dir: &Path,
        _err: &dyn Fn(&str, String) -> String,
    ) -> Result<Self, String> {
        Ok(Local)
    }

    fn defaults() -> Self {
        Local
    }
}

impl Executor for Local {
    fn kind(&self) -> &'static str {
        Self::NAME
    }

    fn on_this_machine(&self) -> bool {
        true
    }

    fn with_jobs(&self, jobs: usize) -> Result<(Arc<dyn Executor>, usize), String> {
        Ok((Arc::new(Local), jobs.max(1)))
    }

    fn run(
        &self,
        study: &Study,
        store: &mut Store,
        stored: &[RunRecord],
        jobs: usize,
        interrupted: Arc<AtomicBool>,
    ) -> Result<(Result<Replay, String>, Option<String>), String> {
        let mut exec = LocalExecutor::new(jobs, store, interrupted);
        Ok((replay(study, stored, Some(&mut exec)), None))
    }

    fn as_any(&self) -> &dyn Any {
        self
    }
}
