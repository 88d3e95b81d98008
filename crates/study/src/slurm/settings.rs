//! The study file's `[executor]` table: where the runs are made, and for Slurm everything a user
//! would otherwise write into a job script. Read and checked once, before anything is submitted;
//! every error names the key and what was expected.

use std::path::{Path, PathBuf};

use crate::paths::number;

/// What to do with a stage's queued and running tasks when the coordinator is interrupted.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum OnInterrupt {
    /// Ask on a terminal; leave them running otherwise.
    #[default]
    Ask,
    /// `scancel` them.
    Cancel,
    /// Leave them: the next `demcal run` re-attaches and collects their results.
    Leave,
}

/// The Slurm executor's settings, one per key of `[executor]`.
#[derive(Clone, Debug, PartialEq)]
pub struct SlurmSettings {
    pub partition: Option<String>,
    pub account: Option<String>,
    pub qos: Option<String>,
    /// Each run's time limit, in Slurm's format (`90`, `30:00`, `2:00:00`, `1-12:00:00`).
    pub time_limit: Option<String>,
    pub cpus_per_run: usize,
    /// GPUs per run (`--gres=gpu:N`); the GPU back end asks for one unless told.
    pub gpus_per_run: Option<usize>,
    /// Memory per run (`--mem`): a whole number with an optional unit K, M, G or T.
    pub memory: Option<String>,
    /// The array's throttle: at most this many of its tasks run at once (`%N`).
    pub max_running: usize,
    /// More `#SBATCH` lines, each one option (`--constraint=skylake`).
    pub sbatch_lines: Vec<String>,
    /// `module load` lines run before demcal on the node.
    pub modules: Vec<String>,
    /// A shell script sourced before demcal on the node (conda, spack, paths).
    pub environment_script: Option<PathBuf>,
    /// The demcal binary the nodes run (default: this one, which must be on a shared file system).
    pub demcal: Option<PathBuf>,
    /// Seconds between looks at the queue and the result files.
    pub poll_s: f64,
    /// The folder the job files, scripts, results and logs go to; the nodes must see it at
    /// the same path (default `<study>.runs/slurm`).
    pub run_folder: Option<PathBuf>,
    /// How many times a run that Slurm ended for a reason not the run's own (node failure,
    /// pre-emption, boot failure) is submitted again.
    pub retries: usize,
    pub on_interrupt: OnInterrupt,
    /// The array's job name (default `demcal-<study file stem>`).
    pub job_name: Option<String>,
}

impl Default for SlurmSettings {
    fn default() -> Self {
        SlurmSettings {
            partition: None,
            account: None,
            qos: None,
            time_limit: None,
            cpus_per_run: 1,
            gpus_per_run: None,
            memory: None,
            max_running: DEFAULT_MAX_RUNNING,
            sbatch_lines: Vec::new(),
            modules: Vec::new(),
            environment_script: None,
            demcal: None,
            poll_s: DEFAULT_POLL_S,
            run_folder: None,
            retries: 1,
            on_interrupt: OnInterrupt::Ask,
            job_name: None,
        }
    }
}

/// A shared queue is not flooded by one study unless the user says so.
pub const DEFAULT_MAX_RUNNING: usize = 100;
/// Often enough to keep a stage moving, rarely enough not to burden slurmctld.
pub const DEFAULT_POLL_S: f64 = 15.0;
/// The most tasks of one array that may run at once, and of `cpus_per_run`/`gpus_per_run`.
pub(crate) const MOST_RUNNING: usize = 100_000;
const MOST_CPUS: usize = 4096;
const MOST_GPUS: usize = 64;
const MOST_RETRIES: usize = 5;

/// The keys of `[executor]`.
pub(crate) const KEYS: &[&str] = &[
    "partition",
    "account",
    "qos",
    "time_limit",
    "cpus_per_run",
    "gpus_per_run",
    "memory",
    "max_running",
    "sbatch_lines",
    "modules",
    "environment_script",
    "demcal",
    "poll_s",
    "run_folder",
    "retries",
    "on_interrupt",
    "job_name",
];

/// Reads a Slurm `[executor]` (its keys already checked against [`KEYS`]). `dir` is the study's
/// folder, which relative paths are taken from; `err` names the file and key.
pub fn parse_slurm(
    t: &toml::Table,
    dir: &Path,
    err: &dyn Fn(&str, String) -> String,
) -> Result<SlurmSettings, String> {
    let key = |k: &str| format!("executor.{k}");
    // One line of a job script: no line breaks, nothing that ends the line early.
    let line = |k: &str, v: &toml::Value| -> Result<String, String> {
        match v {
            toml::Value::String(s) if !s.trim().is_empty() && !s.contains(['\n', '\r', '\0']) => {
                Ok(s.trim().to_string())
            }
            _ => Err(err(
                &key(k),
                "expected a non-empty string on one line".into(),
            )),
        }
    };
    // A Slurm name (partition, account, QOS, job name): no spaces or shell characters. A job
    // name may not hold a comma either: squeue --name reads one as a list.
    let name = |k: &str, others: &str| -> Result<Option<String>, String> {
        match t.get(k) {
            None => Ok(None),
            Some(toml::Value::String(s))
                if !s.is_empty()
                    && s.len() <= 200
                    && s.chars()
                        .all(|c| c.is_ascii_alphanumeric() || others.contains(c)) =>
            {
                Ok(Some(s.clone()))
            }
            Some(v) => Err(err(
                &key(k),
                format!(
                    "expected a Slurm name (letters, digits and {}), got {v}",
                    others
                        .chars()
                        .map(String::from)
                        .collect::<Vec<_>>()
                        .join(" ")
                ),
            )),
        }
    };
    let count = |k: &str, default: usize, min: usize, max: usize| -> Result<usize, String> {
        match t.get(k) {
            None => Ok(default),
            Some(toml::Value::Integer(n)) if *n >= min as i64 && *n <= max as i64 => {
                Ok(*n as usize)
            }
            Some(v) => Err(err(
                &key(k),
                format!("expected a whole number from {min} to {max}, got {v}"),
            )),
        }
    };
    let lines = |k: &str| -> Result<Vec<String>, String> {
        match t.get(k) {
            None => Ok(Vec::new()),
            Some(toml::Value::Array(a)) => a.iter().map(|v| line(k, v)).collect(),
            Some(_) => Err(err(&key(k), "expected a list of strings".into())),
        }
    };
    let path = |k: &str| -> Result<Option<PathBuf>, String> {
        t.get(k)
            .map(|v| line(k, v).map(|s| dir.join(s)))
            .transpose()
    };
    let time_limit = match t.get("time_limit") {
        None => None,
        Some(toml::Value::Integer(m)) if *m > 0 => Some(m.to_string()),
        Some(toml::Value::String(s)) if slurm_time_minutes(s).is_some() => Some(s.clone()),
        Some(v) => {
            return Err(err(
                &key("time_limit"),
                format!("expected Slurm's time format (minutes, MM:SS, HH:MM:SS, D-HH, D-HH:MM or D-HH:MM:SS, more than zero), got {v}"),
            ))
        }
    };
    let memory = match t.get("memory") {
        None => None,
        Some(toml::Value::String(s)) if memory_ok(s) => Some(s.clone()),
        Some(v) => {
            return Err(err(
                &key("memory"),
                format!(
                    "expected a whole number with an optional unit K, M, G or T (\"4G\"), got {v}"
                ),
            ))
        }
    };
    let poll_s = match t.get("poll_s") {
        None => DEFAULT_POLL_S,
        Some(v) => number(v)
            .filter(|s| (0.1..=3600.0).contains(s))
            .ok_or_else(|| {
                err(
                    &key("poll_s"),
                    format!("expected seconds from 0.1 to 3600, got {v}"),
                )
            })?,
    };
    let on_interrupt = match t.get("on_interrupt") {
        None => OnInterrupt::Ask,
        Some(toml::Value::String(s)) if s == "ask" => OnInterrupt::Ask,
        Some(toml::Value::String(s)) if s == "cancel" => OnInterrupt::Cancel,
        Some(toml::Value::String(s)) if s == "leave" => OnInterrupt::Leave,
        Some(v) => {
            return Err(err(
                &key("on_interrupt"),
                format!("expected \"ask\", \"cancel\" or \"leave\", got {v}"),
            ))
        }
    };
    let sbatch_lines = lines("sbatch_lines")?
        .into_iter()
        .map(|l| {
            let option = l.strip_prefix("#SBATCH").map(str::trim).unwrap_or(&l);
            if option.starts_with('-') {
                Ok(option.to_string())
            } else {
                Err(err(
                    &key("sbatch_lines"),
                    format!(
                        "expected sbatch options such as \"--constraint=skylake\", got \"{l}\""
                    ),
                ))
            }
        })
        .collect::<Result<Vec<_>, _>>()?;
    Ok(SlurmSettings {
        partition: name("partition", "-_.,+@")?,
        account: name("account", "-_.,+@")?,
        qos: name("qos", "-_.,+@")?,
        time_limit,
        cpus_per_run: count("cpus_per_run", 1, 1, MOST_CPUS)?,
        gpus_per_run: t
            .get("gpus_per_run")
            .map(|_| count("gpus_per_run", 0, 0, MOST_GPUS))
            .transpose()?,
        memory,
        max_running: count("max_running", DEFAULT_MAX_RUNNING, 1, MOST_RUNNING)?,
        sbatch_lines,
        modules: lines("modules")?
            .into_iter()
            .map(|m| {
                if m.chars()
                    .all(|c| c.is_ascii_alphanumeric() || "/._+-: ".contains(c))
                {
                    Ok(m)
                } else {
                    Err(err(
                        &key("modules"),
                        format!(
                            "expected module names (letters, digits, / . _ + - :), got \"{m}\""
                        ),
                    ))
                }
            })
            .collect::<Result<Vec<_>, _>>()?,
        environment_script: path("environment_script")?,
        demcal: path("demcal")?,
        poll_s,
        run_folder: path("run_folder")?,
        retries: count("retries", 1, 0, MOST_RETRIES)?,
        on_interrupt,
        job_name: name("job_name", "-_.+@")?,
    })
}

/// Minutes in a Slurm time limit (`M`, `M:S`, `H:M:S`, `D-H`, `D-H:M`, `D-H:M:S`), rounded up as
/// Slurm does; None for anything else or zero.
pub fn slurm_time_minutes(s: &str) -> Option<u64> {
    let s = s.trim();
    let whole = |p: &str| -> Option<u64> {
        (!p.is_empty() && p.len() <= 6 && p.bytes().all(|b| b.is_ascii_digit()))
            .then(|| p.parse().ok())
            .flatten()
    };
    let (days, rest) = match s.split_once('-') {
        Some((d, rest)) => (Some(whole(d)?), rest),
        None => (None, s),
    };
    let parts: Vec<u64> = rest.split(':').map(whole).collect::<Option<_>>()?;
    let seconds = match (days, parts.as_slice()) {
        (None, [m]) => m * 60,
        (None, [m, sec]) => m * 60 + sec,
        (None, [h, m, sec]) => h * 3600 + m * 60 + sec,
        (Some(d), [h]) => d * 86400 + h * 3600,
        (Some(d), [h, m]) => d * 86400 + h * 3600 + m * 60,
        (Some(d), [h, m, sec]) => d * 86400 + h * 3600 + m * 60 + sec,
        _ => return None,
    };
    (seconds > 0).then(|| seconds.div_ceil(60))
}

fn memory_ok(s: &str) -> bool {
    let digits = s.trim_end_matches(['K', 'M', 'G', 'T', 'k', 'm', 'g', 't']);
    (s.len() - digits.len()) <= 1
        && !digits.is_empty()
        && digits.len() <= 9
        && digits.bytes().all(|b| b.is_ascii_digit())
        && digits.parse::<u64>().is_ok_and(|n| n > 0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::executor::slurm::Slurm;

    /// What `[executor]` read as, for the assertions.
    #[derive(Debug, PartialEq)]
    enum ExecutorSpec {
        Local,
        Slurm(Box<SlurmSettings>),
    }

    fn parse(text: &str) -> Result<ExecutorSpec, String> {
        let doc: toml::Table = toml::from_str(text).unwrap();
        let e = crate::executor::parse_executor(
            doc.get("executor"),
            Path::new("/studies"),
            &|k, m| format!("s.toml: {k}: {m}"),
        )?;
        Ok(match e.as_any().downcast_ref::<Slurm>() {
            Some(Slurm(s)) => ExecutorSpec::Slurm(Box::new(s.clone())),
            None => ExecutorSpec::Local,
        })
    }

    #[test]
    fn every_key_is_read() {
        let ExecutorSpec::Slurm(s) = parse(
            r##"[executor]
kind = "slurm"
partition = "compute"
account = "agri-dem"
qos = "normal"
time_limit = "1-02:30:00"
cpus_per_run = 4
gpus_per_run = 1
memory = "8G"
max_running = 20
sbatch_lines = ["--constraint=skylake", "#SBATCH --exclusive"]
modules = ["gcc/12"]
environment_script = "env.sh"
demcal = "/opt/demcal/bin/demcal"
poll_s = 30
run_folder = "/scratch/me/runs"
retries = 2
on_interrupt = "leave"
job_name = "maize"
"##,
        )
        .unwrap() else {
            panic!("not slurm")
        };
        assert_eq!(s.partition.as_deref(), Some("compute"));
        assert_eq!(s.time_limit.as_deref(), Some("1-02:30:00"));
        assert_eq!(
            (s.cpus_per_run, s.gpus_per_run, s.max_running),
            (4, Some(1), 20)
        );
        assert_eq!(s.sbatch_lines, ["--constraint=skylake", "--exclusive"]);
        assert_eq!(s.environment_script, Some(PathBuf::from("/studies/env.sh")));
        assert_eq!(s.run_folder, Some(PathBuf::from("/scratch/me/runs")));
        assert_eq!((s.poll_s, s.retries), (30.0, 2));
        assert_eq!(s.on_interrupt, OnInterrupt::Leave);
        assert_eq!(parse("").unwrap(), ExecutorSpec::Local);
        assert_eq!(
            parse("[executor]\nkind = \"local\"").unwrap(),
            ExecutorSpec::Local
        );
        assert_eq!(
            parse("[executor]\nkind = \"slurm\"").unwrap(),
            ExecutorSpec::Slurm(Box::default())
        );
    }

    #[test]
    fn the_documented_example_reads() {
        let readme = include_str!("../../../../docs/features.md");
        let start = readme
            .find("[executor]\nkind = \"slurm\"")
            .expect("the example of docs/features.md, \"Running on a cluster\"");
        let end = start + readme[start..].find("```").unwrap();
        let ExecutorSpec::Slurm(s) = parse(&readme[start..end]).unwrap() else {
            panic!("not slurm")
        };
        assert_eq!(s.partition.as_deref(), Some("compute"));
        assert_eq!((s.cpus_per_run, s.max_running), (4, 50));
    }

    #[test]
    fn wrong_values_name_the_key() {
        for (text, key, what) in [
            ("kind = \"pbs\"", "executor.kind", "\"local\" or \"slurm\""),
            (
                "kind = \"slurm\"\npartiton = \"x\"",
                "executor.partiton",
                "unknown key",
            ),
            (
                "kind = \"slurm\"\ntime_limit = \"2 hours\"",
                "executor.time_limit",
                "Slurm's time format",
            ),
            (
                "kind = \"slurm\"\ntime_limit = \"0:00\"",
                "executor.time_limit",
                "more than zero",
            ),
            (
                "kind = \"slurm\"\ncpus_per_run = 0",
                "executor.cpus_per_run",
                "from 1 to 4096",
            ),
            (
                "kind = \"slurm\"\nmemory = \"4 GB\"",
                "executor.memory",
                "K, M, G or T",
            ),
            (
                "kind = \"slurm\"\npartition = \"a b\"",
                "executor.partition",
                "Slurm name",
            ),
            (
                "kind = \"slurm\"\njob_name = \"a,b\"",
                "executor.job_name",
                "Slurm name",
            ),
            (
                "kind = \"slurm\"\nmodules = [\"gcc; rm -rf ~\"]",
                "executor.modules",
                "module names",
            ),
            (
                "kind = \"slurm\"\nsbatch_lines = [\"exclusive\"]",
                "executor.sbatch_lines",
                "sbatch options",
            ),
            (
                "kind = \"slurm\"\nmodules = [\"a\\nb\"]",
                "executor.modules",
                "one line",
            ),
            (
                "kind = \"slurm\"\npoll_s = 0",
                "executor.poll_s",
                "0.1 to 3600",
            ),
            (
                "kind = \"slurm\"\non_interrupt = \"kill\"",
                "executor.on_interrupt",
                "\"ask\"",
            ),
            (
                "kind = \"local\"\npartition = \"x\"",
                "executor.partition",
                "a local executor has no settings",
            ),
        ] {
            let e = parse(&format!("[executor]\n{text}")).unwrap_err();
            assert!(
                e.starts_with(&format!("s.toml: {key}: ")) && e.contains(what),
                "{text}: {e}"
            );
        }
        let e = parse("executor = \"slurm\"").unwrap_err();
        assert!(e.contains("expected a table"), "{e}");
    }

    #[test]
    fn slurm_time_formats_in_minutes() {
        for (s, m) in [
            ("90", Some(90)),
            ("0:30", Some(1)),
            ("30:00", Some(30)),
            ("2:00:00", Some(120)),
            ("1-12", Some(2160)),
            ("1-0:01", Some(1441)),
            ("1-00:00:01", Some(1441)),
            ("0", None),
            ("1:2:3:4", None),
            ("-5", None),
            ("1h", None),
            ("", None),
        ] {
            assert_eq!(slurm_time_minutes(s), m, "{s}");
        }
    }
}
