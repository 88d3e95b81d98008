//! The Slurm tasks a study submitted, kept in its results store beside the runs: which array
//! and task makes which run, with which job file, in which attempt, and whether its result has
//! been stored. A task is written before `sbatch` is called (with a token in its job name), given
//! its job id the moment `sbatch` answers, and closed in the same transaction that stores its run,
//! so a coordinator killed at any point finds on restart exactly the tasks still out there. The
//! table is the store's (`store::LEDGER_SCHEMA`): the store owns every schema.

use std::path::PathBuf;

use rusqlite::params;

use crate::store::{insert_in, RunRecord, Store};

/// One task of a submitted array.
#[derive(Clone, Debug, PartialEq)]
pub struct Task {
    pub id: i64,
    pub stage: usize,
    pub index: usize,
    /// 1 for the first submission of the run, 2 for its first retry, ...
    pub attempt: usize,
    /// The submission's token, also in the array's job name.
    pub token: String,
    pub job_name: String,
    /// The array's job id; None only between the task being written and sbatch answering.
    pub job_id: Option<String>,
    pub task: u32,
    pub fingerprint: String,
    pub job_file: PathBuf,
    pub record_file: PathBuf,
    pub log_dir: PathBuf,
    pub submitted_at: String,
    /// open (submitted, result not stored), stored, retried, cancelled or dropped.
    pub state: String,
    pub note: Option<String>,
}

impl Task {
    /// `14_3`, or the token while the job id is unknown.
    pub fn name(&self) -> String {
        match &self.job_id {
            Some(j) => format!("{j}_{}", self.task),
            None => format!("{}[{}]", self.job_name, self.task),
        }
    }

    /// The task's log (`<log_dir>/<array id>_<task>.out`).
    pub fn log(&self) -> PathBuf {
        self.log_dir.join(format!(
            "{}_{}.out",
            self.job_id.as_deref().unwrap_or("unknown"),
            self.task
        ))
    }
}

fn err(store: &Store) -> impl Fn(rusqlite::Error) -> String + '_ {
    move |e| format!("{}: results store: {e}", store.path.display())
}

impl Store {
    /// Writes a submission's tasks (job id not yet known), in one transaction.
    pub(crate) fn add_tasks(&mut self, tasks: &[Task]) -> Result<Vec<i64>, String> {
        let path = self.path.clone();
        let e = move |e: rusqlite::Error| format!("{}: results store: {e}", path.display());
        let tx = self.conn.transaction().map_err(&e)?;
        let mut ids = Vec::new();
        for t in tasks {
            tx.execute(
                "INSERT INTO cluster_tasks (stage, idx, attempt, token, job_name, job_id, task,
                     fingerprint, job_file, record_file, log_dir, submitted_at, state, note)
                 VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12, ?13, ?14)",
                params![
                    t.stage as i64,
                    t.index as i64,
                    t.attempt as i64,
                    t.token,
                    t.job_name,
                    t.job_id,
                    t.task as i64,
                    t.fingerprint,
                    t.job_file.display().to_string(),
                    t.record_file.display().to_string(),
                    t.log_dir.display().to_string(),
                    t.submitted_at,
                    t.state,
                    t.note,
                ],
            )
            .map_err(&e)?;
            ids.push(tx.last_insert_rowid());
        }
        tx.commit().map_err(&e)?;
        Ok(ids)
    }

    /// Records the job id sbatch gave the submission `token`.
    pub(crate) fn set_job_id(&self, token: &str, job_id: &str) -> Result<(), String> {
        self.conn
            .execute(
                "UPDATE cluster_tasks SET job_id = ?2 WHERE token = ?1",
                params![token, job_id],
            )
            .map(|_| ())
            .map_err(err(self))
    }

    /// Closes a task without a result of its own: retried, cancelled or dropped, and why.
    pub(crate) fn close_task(&self, id: i64, state: &str, note: &str) -> Result<(), String> {
        self.conn
            .execute(
                "UPDATE cluster_tasks SET state = ?2, note = ?3 WHERE id = ?1",
                params![id, state, note],
            )
            .map(|_| ())
            .map_err(err(self))
    }

    /// How many times Slurm ended this run's tasks for reasons not its own (node failure,
    /// pre-emption): the tasks closed as retried, across coordinator restarts.
    pub(crate) fn retried(
        &self,
        stage: usize,
        index: usize,
        fingerprint: &str,
    ) -> Result<usize, String> {
        if !self.columns.ledger {
            return Ok(0);
        }
        self.conn
            .query_row(
                "SELECT COUNT(*) FROM cluster_tasks
                 WHERE stage = ?1 AND idx = ?2 AND fingerprint = ?3 AND state = 'retried'",
                params![stage as i64, index as i64, fingerprint],
                |r| r.get::<_, i64>(0),
            )
            .map(|n| n as usize)
            .map_err(err(self))
    }

    /// Stores a task's run and closes the task, in one transaction: after a crash either both
    /// happened or neither.
    pub(crate) fn store_task_run(&mut self, task: i64, r: &RunRecord) -> Result<(), String> {
        let path = self.path.clone();
        let e = move |e: rusqlite::Error| format!("{}: results store: {e}", path.display());
        let tx = self.conn.transaction().map_err(&e)?;
        insert_in(&tx, r).map_err(&e)?;
        tx.execute(
            "UPDATE cluster_tasks SET state = 'stored' WHERE id = ?1",
            params![task],
        )
        .map_err(&e)?;
        tx.commit().map_err(&e)
    }

    /// Every task (`open_only`: those whose result is not stored yet), oldest first.
    pub fn cluster_tasks(&self, open_only: bool) -> Result<Vec<Task>, String> {
        // A store from before Slurm tasks were kept, opened read-only, has none.
        if !self.columns.ledger {
            return Ok(Vec::new());
        }
        let mut st = self
            .conn
            .prepare(&format!(
                "SELECT id, stage, idx, attempt, token, job_name, job_id, task, fingerprint,
                        job_file, record_file, log_dir, submitted_at, state, note
                 FROM cluster_tasks {} ORDER BY id",
                if open_only {
                    "WHERE state = 'open'"
                } else {
                    ""
                }
            ))
            .map_err(err(self))?;
        let rows = st
            .query_map([], |r| {
                Ok(Task {
                    id: r.get(0)?,
                    stage: r.get::<_, i64>(1)? as usize,
                    index: r.get::<_, i64>(2)? as usize,
                    attempt: r.get::<_, i64>(3)? as usize,
                    token: r.get(4)?,
                    job_name: r.get(5)?,
                    job_id: r.get(6)?,
                    task: r.get::<_, i64>(7)? as u32,
                    fingerprint: r.get(8)?,
                    job_file: PathBuf::from(r.get::<_, String>(9)?),
                    record_file: PathBuf::from(r.get::<_, String>(10)?),
                    log_dir: PathBuf::from(r.get::<_, String>(11)?),
                    submitted_at: r.get(12)?,
                    state: r.get(13)?,
                    note: r.get(14)?,
                })
            })
            .map_err(err(self))?;
        rows.collect::<Result<Vec<_>, _>>().map_err(err(self))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::run_error::RunErrorKind;
    use crate::store::Status;

    #[test]
    fn tasks_round_trip_and_retries_restart_with_retry_failed() {
        let dir = std::env::temp_dir().join(format!("demcal-ledger-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("s.db");
        let _ = std::fs::remove_file(&path);
        let mut s = Store::open(&path, true).unwrap();
        let task = |attempt: usize, state: &str| Task {
            id: 0,
            stage: 0,
            index: 2,
            attempt,
            token: format!("tok{attempt}"),
            job_name: "demcal-s1".into(),
            job_id: None,
            task: 5,
            fingerprint: "f".into(),
            job_file: dir.join("run003.json"),
            record_file: dir.join("run003.record.json"),
            log_dir: dir.join("logs"),
            submitted_at: "t".into(),
            state: state.into(),
            note: None,
        };
        s.add_tasks(&[task(1, "retried"), task(2, "open")]).unwrap();
        s.set_job_id("tok2", "812").unwrap();
        let open = s.cluster_tasks(true).unwrap();
        assert_eq!(open.len(), 1);
        assert_eq!(open[0].name(), "812_5");
        assert_eq!(open[0].log(), dir.join("logs/812_5.out"));
        assert_eq!(s.retried(0, 2, "f").unwrap(), 1);
        // The run fails after its retry: stored with its task closed in one go.
        let rec = RunRecord {
            stage: 0,
            stage_kind: "screening".into(),
            index: 2,
            inputs: serde_json::Value::Null,
            seed: 1,
            status: Status::Failed,
            response: None,
            outputs: serde_json::Value::Null,
            error: Some("node failed twice".into()),
            error_kind: Some(RunErrorKind::Cluster),
            wall_s: 0.0,
            finished_at: "t".into(),
            version: "v".into(),
            out_dir: "d".into(),
            fingerprint: "f".into(),
            host: String::new(),
            executor: "slurm job 812_5".into(),
        };
        s.store_task_run(open[0].id, &rec).unwrap();
        assert!(s.cluster_tasks(true).unwrap().is_empty());
        assert_eq!(s.runs().unwrap()[0].error_kind, Some(RunErrorKind::Cluster));
        // --retry-failed: the run starts afresh, its retries unused again.
        assert_eq!(s.delete_failed().unwrap(), 1);
        assert_eq!(s.retried(0, 2, "f").unwrap(), 0);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
