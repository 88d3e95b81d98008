//! The results store: one SQLite file next to the study. A run is written in one transaction when
//! it finishes (done or failed), so killing the process at any moment loses only the runs that
//! were still going; nothing is written for them, and the next `demcal run` starts them again.

use std::path::{Path, PathBuf};

use rusqlite::{params, Connection, OptionalExtension};

use crate::error::LockError;
use crate::run_error::RunErrorKind;

/// How a finished run ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Status {
    Done,
    Failed,
}

impl Status {
    pub fn as_str(self) -> &'static str {
        match self {
            Status::Done => "done",
            Status::Failed => "failed",
        }
    }
}

/// One finished simulation (also what `demcal run-one` writes as JSON).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RunRecord {
    pub stage: usize,
    pub stage_kind: String,
    pub index: usize,
    /// Every parameter's value, by name, as JSON (for people and for checks).
    pub inputs: serde_json::Value,
    pub seed: u64,
    pub status: Status,
    pub response: Option<f64>,
    /// The test's whole outcome as JSON (null for failed runs).
    pub outputs: serde_json::Value,
    /// Why a failed run gave no result: the message, and its kind.
    pub error: Option<String>,
    pub error_kind: Option<RunErrorKind>,
    pub wall_s: f64,
    pub finished_at: String,
    pub version: String,
    /// Where the run wrote its pictures.
    pub out_dir: String,
    /// The exact test the run simulated (TOML, parameters set) and its seed; a stored run is
    /// reused only while the study would still give the same.
    pub fingerprint: String,
    /// The machine that simulated the run (empty in stores from before it was recorded).
    #[serde(default)]
    pub host: String,
    /// What ran it: `local`, or `slurm job 14_3`.
    #[serde(default)]
    pub executor: String,
}

pub struct Store {
    pub(crate) conn: Connection,
    pub path: PathBuf,
    /// What an older store opened read-only lacks.
    pub(crate) columns: Columns,
}

/// The columns and tables added since the first stores, and whether this store has them.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Columns {
    error_kind: bool,
    origin: bool,
    pub(crate) ledger: bool,
}

/// Brings an older store up to date: the schema, the columns added since.
fn migrate(conn: &Connection) -> rusqlite::Result<()> {
    conn.execute_batch(SCHEMA)?;
    for column in ["error_kind", "host", "executor"] {
        let has = conn
            .prepare(&format!("SELECT {column} FROM runs LIMIT 0"))
            .is_ok();
        if !has {
            if let Err(e) =
                conn.execute_batch(&format!("ALTER TABLE runs ADD COLUMN {column} TEXT"))
            {
                if !e.to_string().contains("duplicate column") {
                    return Err(e);
                }
            }
        }
    }
    conn.execute_batch(LEDGER_SCHEMA)
}

/// The tasks an executor that outlives its coordinator submitted (`slurm::ledger` reads and
/// writes them): which task makes which run, and whether its result is stored.
pub(crate) const LEDGER_SCHEMA: &str = "
CREATE TABLE IF NOT EXISTS cluster_tasks (
    id INTEGER PRIMARY KEY AUTOINCREMENT,
    stage INTEGER NOT NULL,
    idx INTEGER NOT NULL,
    attempt INTEGER NOT NULL,
    token TEXT NOT NULL,
    job_name TEXT NOT NULL,
    job_id TEXT,
    task INTEGER NOT NULL,
    fingerprint TEXT NOT NULL,
    job_file TEXT NOT NULL,
    record_file TEXT NOT NULL,
    log_dir TEXT NOT NULL,
    submitted_at TEXT NOT NULL,
    state TEXT NOT NULL CHECK (state IN ('open', 'stored', 'retried', 'cancelled', 'dropped')),
    note TEXT
);
CREATE INDEX IF NOT EXISTS cluster_tasks_open ON cluster_tasks (state, stage);
";

const SCHEMA: &str = "
CREATE TABLE IF NOT EXISTS meta (key TEXT PRIMARY KEY, value TEXT NOT NULL);
CREATE TABLE IF NOT EXISTS runs (
    stage INTEGER NOT NULL,
    stage_kind TEXT NOT NULL,
    idx INTEGER NOT NULL,
    inputs TEXT NOT NULL,
    seed INTEGER NOT NULL,
    status TEXT NOT NULL CHECK (status IN ('done', 'failed')),
    response REAL,
    outputs TEXT NOT NULL,
    error TEXT,
    error_kind TEXT,
    wall_s REAL NOT NULL,
    finished_at TEXT NOT NULL,
    version TEXT NOT NULL,
    out_dir TEXT NOT NULL,
    fingerprint TEXT NOT NULL,
    host TEXT,
    executor TEXT,
    PRIMARY KEY (stage, idx)
);
";

fn db_err(path: &Path) -> impl Fn(rusqlite::Error) -> String + '_ {
    move |e| format!("{}: results store: {e}", path.display())
}

impl Store {
    /// Opens (creating when `create`) the store. Without `create` a missing file is an error.
    pub fn open(path: &Path, create: bool) -> Result<Store, String> {
        if !create && !path.exists() {
            return Err(format!(
                "{}: no results yet (run the study with demcal run first)",
                path.display()
            ));
        }
        // A store of no bytes is one cut short (a full disk, a copy that failed): SQLite would
        // take it as new and every run would be made again without a word.
        if std::fs::metadata(path).is_ok_and(|m| m.is_file() && m.len() == 0) {
            return Err(format!(
                "{}: the results store is empty (0 bytes), not a store: its runs are lost; run with --restart to move it aside and start over",
                path.display()
            ));
        }
        let conn = Connection::open(path).map_err(db_err(path))?;
        // FULL: a finished transaction survives a power cut, not just a killed process.
        conn.execute_batch("PRAGMA journal_mode = DELETE; PRAGMA synchronous = FULL;")
            .map_err(db_err(path))?;
        // Wait for a reader or another process rather than fail at once.
        conn.busy_timeout(std::time::Duration::from_secs(10))
            .map_err(db_err(path))?;
        // Stores written before run errors had kinds (their failures read as kind "unknown"),
        // before hosts and executors were recorded, or before Slurm tasks were kept, get the
        // columns and the table. Another process may add one at the same moment: that is fine
        // too. A reader that cannot write (a read-only copy) reads without them.
        let migrated = migrate(&conn);
        if create {
            migrated.map_err(db_err(path))?;
        }
        let has = |sql: &str| conn.prepare(sql).is_ok();
        let columns = Columns {
            error_kind: has("SELECT error_kind FROM runs LIMIT 0"),
            origin: has("SELECT host, executor FROM runs LIMIT 0"),
            ledger: has("SELECT id FROM cluster_tasks LIMIT 0"),
        };
        Ok(Store {
            conn,
            path: path.to_path_buf(),
            columns,
        })
    }

    pub fn meta(&self, key: &str) -> Result<Option<String>, String> {
        self.conn
            .query_row("SELECT value FROM meta WHERE key = ?1", [key], |r| r.get(0))
            .optional()
            .map_err(db_err(&self.path))
    }

    pub fn set_meta(&self, key: &str, value: &str) -> Result<(), String> {
        self.conn
            .execute(
                "INSERT INTO meta (key, value) VALUES (?1, ?2)
                 ON CONFLICT(key) DO UPDATE SET value = excluded.value",
                params![key, value],
            )
            .map(|_| ())
            .map_err(db_err(&self.path))
    }

    /// Stores a finished run in its own transaction.
    pub fn insert(&mut self, r: &RunRecord) -> Result<(), String> {
        let path = self.path.clone();
        let tx = self.conn.transaction().map_err(db_err(&path))?;
        insert_in(&tx, r).map_err(db_err(&path))?;
        tx.commit().map_err(db_err(&path))
    }

    /// Forgets failed runs so that they run again.
    pub fn delete_failed(&mut self) -> Result<usize, String> {
        self.delete_failed_where("1", "its run was run again (--retry-failed)")
    }

    /// Deletes the failed runs whose failure was the machine's, not the parameters'
    /// (`RunErrorKind::is_transient`: files that could not be written, a task the cluster
    /// ended), so that they are made again; how many.
    pub fn delete_transient(&mut self) -> Result<usize, String> {
        if !self.columns.error_kind {
            return Ok(0);
        }
        let kinds: Vec<String> = RunErrorKind::transient()
            .into_iter()
            .map(|k| format!("'{}'", k.as_str()))
            .collect();
        self.delete_failed_where(
            &format!("error_kind IN ({})", kinds.join(", ")),
            "its run failed for the machine, not its parameters, and was run again",
        )
    }

    /// Deletes the failed runs that also meet `condition` (SQL on `runs`' columns); a cluster
    /// task retried for such a run is closed as dropped, with `note`.
    fn delete_failed_where(&mut self, condition: &str, note: &str) -> Result<usize, String> {
        let path = self.path.clone();
        let tx = self.conn.transaction().map_err(db_err(&path))?;
        if self.columns.ledger {
            // Their runs start afresh, with their retries after a node failure unused again.
            tx.execute(
                &format!(
                    "UPDATE cluster_tasks SET state = 'dropped', note = ?1
                     WHERE state = 'retried' AND EXISTS (SELECT 1 FROM runs
                         WHERE runs.stage = cluster_tasks.stage AND runs.idx = cluster_tasks.idx
                           AND runs.status = 'failed' AND ({condition}))"
                ),
                [note],
            )
            .map_err(db_err(&path))?;
        }
        let n = tx
            .execute(
                &format!("DELETE FROM runs WHERE status = 'failed' AND ({condition})"),
                [],
            )
            .map_err(db_err(&path))?;
        tx.commit().map_err(db_err(&path))?;
        Ok(n)
    }

    pub fn runs(&self) -> Result<Vec<RunRecord>, String> {
        let mut st = self
            .conn
            .prepare(&format!(
                "SELECT stage, stage_kind, idx, inputs, seed, status, response, outputs, error,
                        wall_s, finished_at, version, out_dir, fingerprint, {}, {}
                 FROM runs ORDER BY stage, idx",
                if self.columns.error_kind {
                    "error_kind"
                } else {
                    "NULL"
                },
                if self.columns.origin {
                    "host, executor"
                } else {
                    "NULL, NULL"
                }
            ))
            .map_err(db_err(&self.path))?;
        let rows = st
            .query_map([], |r| {
                let status: String = r.get(5)?;
                Ok(RunRecord {
                    stage: r.get::<_, i64>(0)? as usize,
                    stage_kind: r.get(1)?,
                    index: r.get::<_, i64>(2)? as usize,
                    inputs: serde_json::from_str(&r.get::<_, String>(3)?)
                        .unwrap_or(serde_json::Value::Null),
                    seed: r.get::<_, i64>(4)? as u64,
                    status: if status == "done" {
                        Status::Done
                    } else {
                        Status::Failed
                    },
                    response: r.get(6)?,
                    outputs: serde_json::from_str(&r.get::<_, String>(7)?)
                        .unwrap_or(serde_json::Value::Null),
                    error_kind: match (
                        r.get::<_, Option<String>>(8)?,
                        r.get::<_, Option<String>>(14)?,
                    ) {
                        (_, Some(k)) => Some(RunErrorKind::from_stored(&k)),
                        (Some(_), None) => Some(RunErrorKind::Unknown),
                        (None, None) => None,
                    },
                    error: r.get(8)?,
                    wall_s: r.get(9)?,
                    finished_at: r.get(10)?,
                    version: r.get(11)?,
                    out_dir: r.get(12)?,
                    fingerprint: r.get(13)?,
                    host: r.get::<_, Option<String>>(15)?.unwrap_or_default(),
                    executor: r.get::<_, Option<String>>(16)?.unwrap_or_default(),
                })
            })
            .map_err(db_err(&self.path))?;
        rows.collect::<Result<Vec<_>, _>>()
            .map_err(db_err(&self.path))
    }
}

/// Writes a finished run inside the caller's transaction (replacing an earlier record of it).
pub(crate) fn insert_in(tx: &rusqlite::Transaction, r: &RunRecord) -> rusqlite::Result<()> {
    tx.execute(
        "INSERT OR REPLACE INTO runs (stage, stage_kind, idx, inputs, seed, status, response,
             outputs, error, wall_s, finished_at, version, out_dir, fingerprint, error_kind,
             host, executor)
         VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12, ?13, ?14, ?15, ?16, ?17)",
        params![
            r.stage as i64,
            r.stage_kind,
            r.index as i64,
            r.inputs.to_string(),
            r.seed as i64,
            r.status.as_str(),
            r.response,
            r.outputs.to_string(),
            r.error,
            r.wall_s,
            r.finished_at,
            r.version,
            r.out_dir,
            r.fingerprint,
            r.error_kind.map(|k| k.as_str()),
            r.host,
            r.executor,
        ],
    )
    .map(|_| ())
}

/// The right to run a study: `<store>.lock` next to the store, holding the process id of the
/// `demcal run` that owns it. Created atomically (a second `demcal run` of the same study finds it
/// and stops, naming the process); removed when the run ends. A lock left by a process that no
/// longer exists (killed, power cut) is stale and taken over. Readers (`status`, `report`) take
/// no lock: SQLite keeps every transaction whole for them.
#[derive(Debug)]
pub struct StoreLock {
    path: PathBuf,
}

impl StoreLock {
    /// The lock file of the store at `store`.
    pub fn path_for(store: &Path) -> PathBuf {
        let mut name = store.as_os_str().to_owned();
        name.push(".lock");
        PathBuf::from(name)
    }

    pub fn acquire(store: &Path) -> Result<StoreLock, LockError> {
        let path = StoreLock::path_for(store);
        let me = std::process::id();
        // Two tries: the second after removing a stale lock.
        for _ in 0..2 {
            match std::fs::OpenOptions::new()
                .write(true)
                .create_new(true)
                .open(&path)
            {
                Ok(mut f) => {
                    use std::io::Write;
                    // The host too: on a shared file system the lock may be seen from another
                    // login node, where this process id means nothing. The process's start
                    // time tells a reused process id from this process.
                    let start = process_start(me).map(|t| t.to_string()).unwrap_or_default();
                    f.write_all(format!("{me}\n{}\n{start}\n", machine_name()).as_bytes())
                        .and_then(|_| f.sync_all())
                        .map_err(|e| {
                            LockError::Io(format!("{}: cannot write: {e}", path.display()))
                        })?;
                    return Ok(StoreLock { path });
                }
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {
                    match held_by(&path, me) {
                        Holder::Stale => {
                            let _ = std::fs::remove_file(&path);
                        }
                        Holder::EmptyFolder => {
                            let _ = std::fs::remove_dir(&path);
                        }
                        Holder::Folder => {
                            return Err(LockError::Io(format!(
                                "{}: is a folder with files in it, where the study's lock file belongs: move it away",
                                path.display()
                            )))
                        }
                        Holder::Elsewhere { pid, host } => {
                            return Err(LockError::Held(format!(
                                "{}: the study is being run by process {pid} on {host} (lock file {}); stop it there, or if it no longer runs, remove that file",
                                store.display(),
                                path.display()
                            )))
                        }
                        Holder::Process(pid) => {
                            return Err(LockError::Held(format!(
                                "{}: the study is being run by process {pid} (lock file {}); wait for it to end, or stop it",
                                store.display(),
                                path.display()
                            )))
                        }
                        Holder::BeingWritten => {
                            return Err(LockError::Held(format!(
                                "{}: another process is taking the study's lock this moment (lock file {}); try again",
                                store.display(),
                                path.display()
                            )))
                        }
                    }
                }
                Err(e) => {
                    return Err(LockError::Io(format!(
                        "{}: cannot create: {e}",
                        path.display()
                    )))
                }
            }
        }
        Err(LockError::Held(format!(
            "{}: cannot take the lock: another process took it over at the same moment",
            path.display()
        )))
    }
}

impl Drop for StoreLock {
    fn drop(&mut self) {
        // Only our own lock: after a takeover the file may be another process's.
        let ours = read_lock(&self.path)
            .lines()
            .next()
            .is_some_and(|l| l.trim() == std::process::id().to_string());
        if ours {
            let _ = std::fs::remove_file(&self.path);
        }
    }
}

/// Who holds an existing lock file, as far as this machine can tell.
enum Holder {
    /// A process that still runs: this one, or another `demcal run`.
    Process(u32),
    /// A process on another machine (a login node sharing the file system): never taken over.
    Elsewhere { pid: String, host: String },
    /// Empty or unreadable and only just made: another process is writing it.
    BeingWritten,
    /// Safe to replace: its process is gone, its process id now belongs to another program
    /// (its start time differs), or it is empty or garbage and older than a few seconds.
    Stale,
    /// An empty folder where the lock file belongs (removed, then the lock taken).
    EmptyFolder,
    /// A folder with files in it: not ours to remove.
    Folder,
}

/// The start of a lock file's text: a lock is three short lines, so a few kilobytes are plenty
/// and a huge or endless file is not read on; "" for anything but a readable plain file.
fn read_lock(path: &Path) -> String {
    use std::io::Read;
    if !std::fs::metadata(path).is_ok_and(|m| m.is_file()) {
        return String::new();
    }
    let mut bytes = Vec::new();
    let _ = std::fs::File::open(path).and_then(|f| f.take(4096).read_to_end(&mut bytes));
    String::from_utf8_lossy(&bytes).into_owned()
}

/// How long a lock file may stay empty or unreadable while its maker writes it.
const LOCK_WRITE_GRACE: std::time::Duration = std::time::Duration::from_secs(5);

fn held_by(path: &Path, me: u32) -> Holder {
    if path.is_dir() {
        let empty = std::fs::read_dir(path).is_ok_and(|mut d| d.next().is_none());
        return if empty {
            Holder::EmptyFolder
        } else {
            Holder::Folder
        };
    }
    if std::fs::metadata(path).is_ok_and(|m| !m.is_file()) {
        // A pipe or a device (or a link to one) is no lock any demcal wrote: reading it could
        // wait for ever (a pipe) or never end (/dev/zero).
        return Holder::Stale;
    }
    let text = read_lock(path);
    let mut lines = text.lines().map(str::trim);
    let (first, host, start) = (
        lines.next().unwrap_or(""),
        lines.next().unwrap_or(""),
        lines.next().unwrap_or(""),
    );
    let Ok(pid) = first.parse::<u32>() else {
        let age = std::fs::metadata(path)
            .and_then(|m| m.modified())
            .ok()
            .and_then(|t| t.elapsed().ok());
        return match age {
            Some(a) if a < LOCK_WRITE_GRACE => Holder::BeingWritten,
            _ => Holder::Stale,
        };
    };
    if !host.is_empty() && !same_machine(host, &machine_name()) {
        return Holder::Elsewhere {
            pid: first.to_string(),
            host: host.to_string(),
        };
    }
    if pid == me {
        return Holder::Process(pid);
    }
    if !process_exists(pid) {
        return Holder::Stale;
    }
    // The id is in use: by the process that wrote the lock only if it started when the lock
    // says (an older lock without a start time: only if that process is a demcal).
    let same = match (start.parse::<u64>().ok(), process_start(pid)) {
        (Some(written), Some(now)) => written == now,
        (None, _) => runs_demcal(pid),
        (Some(_), None) => true,
    };
    if same {
        Holder::Process(pid)
    } else {
        Holder::Stale
    }
}

/// When process `pid` started, in clock ticks since boot (field 22 of /proc/PID/stat); None
/// where there is no /proc.
fn process_start(pid: u32) -> Option<u64> {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).ok()?;
    let (_, rest) = stat.rsplit_once(')')?;
    rest.split_whitespace().nth(19)?.parse().ok()
}

/// Whether process `pid` is a demcal (its program's name); true where it cannot be told.
fn runs_demcal(pid: u32) -> bool {
    match std::fs::read(format!("/proc/{pid}/cmdline")) {
        Ok(cmd) => {
            let argv0 = cmd.split(|b| *b == 0).next().unwrap_or(&[]);
            String::from_utf8_lossy(argv0).contains("demcal")
        }
        Err(_) => !Path::new("/proc/self").exists(),
    }
}

/// Whether two names are the same machine's: `login1` and `login1.cluster.example` are.
fn same_machine(a: &str, b: &str) -> bool {
    let short = |s: &str| s.split('.').next().unwrap_or("").to_ascii_lowercase();
    short(a) == short(b)
}

/// Whether a process with this id exists on this machine.
fn process_exists(pid: u32) -> bool {
    if Path::new("/proc/self").exists() {
        // A zombie (ended, not yet reaped by its parent) holds nothing either.
        return match std::fs::read_to_string(format!("/proc/{pid}/stat")) {
            Ok(stat) => stat
                .rsplit_once(')')
                .is_none_or(|(_, rest)| rest.split_whitespace().next() != Some("Z")),
            Err(_) => false,
        };
    }
    #[cfg(unix)]
    {
        // No /proc (macOS, BSD): `kill -0` asks without sending anything.
        std::process::Command::new("kill")
            .args(["-0", &pid.to_string()])
            .stderr(std::process::Stdio::null())
            .status()
            .map(|s| s.success())
            .unwrap_or(true)
    }
    #[cfg(not(unix))]
    {
        // Without a way to ask, assume it runs; the message says how to remove the lock.
        true
    }
}

/// The time now as `YYYY-MM-DD HH:MM:SS` UTC, without a date crate.
pub fn now_utc() -> String {
    let secs = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_secs() as i64)
        .unwrap_or(0);
    let (days, rem) = (secs.div_euclid(86_400), secs.rem_euclid(86_400));
    // Civil date from days since 1970-01-01 (Howard Hinnant's algorithm).
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    format!(
        "{y:04}-{m:02}-{d:02} {:02}:{:02}:{:02}",
        rem / 3600,
        rem % 3600 / 60,
        rem % 60
    )
}

/// This machine's own name (the kernel's, not a Slurm node name that may alias it).
pub fn machine_name() -> String {
    std::fs::read_to_string("/proc/sys/kernel/hostname")
        .ok()
        .map(|h| h.trim().to_string())
        .or_else(|| std::env::var("HOSTNAME").ok())
        .or_else(|| std::env::var("COMPUTERNAME").ok())
        .filter(|h| !h.is_empty())
        .unwrap_or_else(|| "unknown".into())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A store written before failed runs had kinds opens with the column added: its failures
    /// read as kind "unknown", its done runs as none.
    #[test]
    fn a_store_from_before_error_kinds_is_migrated() {
        let dir = std::env::temp_dir().join(format!("demcal-store-old-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("old.db");
        let _ = std::fs::remove_file(&path);
        let old = SCHEMA
            .replace("    error_kind TEXT,\n", "")
            .replace("    host TEXT,\n    executor TEXT,\n", "");
        assert_ne!(old, SCHEMA);
        let conn = Connection::open(&path).unwrap();
        conn.execute_batch(&old).unwrap();
        for (idx, status, response, error) in [
            (0, "done", Some(31.0), None),
            (1, "failed", None, Some("diverged at t = 0.1 s")),
        ] {
            conn.execute(
                "INSERT INTO runs (stage, stage_kind, idx, inputs, seed, status, response, outputs,
                     error, wall_s, finished_at, version, out_dir, fingerprint)
                 VALUES (0, 'screening', ?1, '{}', 1, ?2, ?3, 'null', ?4, 1.0, 't', '0.1.0', 'd', 'f')",
                params![idx, status, response, error],
            )
            .unwrap();
        }
        drop(conn);
        let s = Store::open(&path, false).unwrap();
        let runs = s.runs().unwrap();
        assert_eq!(runs[0].error_kind, None);
        assert_eq!(runs[1].error_kind, Some(RunErrorKind::Unknown));
        assert_eq!(runs[1].error.as_deref(), Some("diverged at t = 0.1 s"));
        drop(s);
        // Opening it again finds the column there.
        assert_eq!(Store::open(&path, false).unwrap().runs().unwrap().len(), 2);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_machine_by_its_short_or_full_name() {
        assert!(same_machine("login1", "LOGIN1.cluster.example"));
        assert!(!same_machine("login1", "login2.cluster.example"));
    }

    #[test]
    fn runs_round_trip_and_failed_runs_can_be_retried() {
        let dir = std::env::temp_dir().join(format!("demcal-store-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("s.db");
        let _ = std::fs::remove_file(&path);
        let mut s = Store::open(&path, true).unwrap();
        let mut r = RunRecord {
            stage: 0,
            stage_kind: "rsm".into(),
            index: 3,
            inputs: serde_json::json!({"x": 0.5}),
            seed: 7,
            status: Status::Done,
            response: Some(31.5),
            outputs: serde_json::json!({"value": 31.5}),
            error: None,
            error_kind: None,
            wall_s: 1.25,
            finished_at: now_utc(),
            version: "0.1.0".into(),
            out_dir: "d".into(),
            fingerprint: "f".into(),
            host: "node7".into(),
            executor: "slurm job 14_3".into(),
        };
        s.insert(&r).unwrap();
        r.index = 4;
        r.status = Status::Failed;
        r.response = None;
        r.error = Some("diverged".into());
        r.error_kind = Some(RunErrorKind::Diverged);
        s.insert(&r).unwrap();
        drop(s);
        let mut s = Store::open(&path, false).unwrap();
        let runs = s.runs().unwrap();
        assert_eq!(runs.len(), 2);
        assert_eq!(runs[0].response, Some(31.5));
        assert_eq!(runs[0].inputs["x"], 0.5);
        assert_eq!(
            (runs[0].host.as_str(), runs[0].executor.as_str()),
            ("node7", "slurm job 14_3")
        );
        assert_eq!(runs[1].status, Status::Failed);
        assert_eq!(runs[1].error.as_deref(), Some("diverged"));
        assert_eq!(runs[1].error_kind, Some(RunErrorKind::Diverged));
        assert_eq!(runs[0].error_kind, None);
        assert_eq!(s.delete_failed().unwrap(), 1);
        assert_eq!(s.runs().unwrap().len(), 1);
        assert!(now_utc().starts_with("20"));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
