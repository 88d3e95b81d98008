//! Talking to Slurm through its commands: `sbatch` to submit an array, `squeue` for what is
//! queued or running, `scontrol show job` (then `sacct` where accounting exists, then the task's
//! own log) for why a task ended, `scancel` to withdraw tasks. The parsers are plain functions
//! of the commands' text, tested on what Slurm 22.05 prints.

use std::collections::HashMap;
use std::path::Path;
use std::process::Command;

use crate::run_error::RunErrorKind;

/// Runs a Slurm command; its standard output, or one line saying what went wrong.
fn slurm(program: &str, args: &[String]) -> Result<String, String> {
    let mut cmd = Command::new(program);
    cmd.args(args);
    // The user's squeue defaults (SQUEUE_STATES=all, a partition) would hide or invent tasks,
    // and a time format would change what is parsed; long task ranges are printed whole.
    for (k, _) in std::env::vars_os() {
        if k.to_str()
            .is_some_and(|k| k.starts_with("SQUEUE_") || k == "SLURM_TIME_FORMAT")
        {
            cmd.env_remove(k);
        }
    }
    cmd.env("SLURM_BITSTR_LEN", "0");
    // In a process group of its own, so that the Ctrl-C meant for the coordinator does not also
    // stop an sbatch half way (the array made, its id never heard).
    #[cfg(unix)]
    std::os::unix::process::CommandExt::process_group(&mut cmd, 0);
    let out = cmd.output().map_err(|e| {
        if e.kind() == std::io::ErrorKind::NotFound {
            format!("{program}: not found (is this a Slurm login node? the Slurm commands must be on PATH)")
        } else {
            format!("{program}: cannot run: {e}")
        }
    })?;
    if out.status.success() {
        Ok(String::from_utf8_lossy(&out.stdout).into_owned())
    } else {
        let err = String::from_utf8_lossy(&out.stderr);
        let line = err
            .lines()
            .map(str::trim)
            .filter(|l| !l.is_empty())
            .collect::<Vec<_>>()
            .join("; ");
        Err(format!(
            "{program} {}: {line} ({})",
            args.join(" "),
            out.status
        ))
    }
}

/// Whether the Slurm commands answer here: the version `sbatch` reports.
pub fn check_available() -> Result<String, String> {
    slurm("sbatch", &["--version".into()]).map(|v| v.trim().to_string())
}

/// The largest array index the cluster accepts plus one (`MaxArraySize`, 1001 unless set).
pub fn max_array_size() -> usize {
    slurm("scontrol", &["show".into(), "config".into()])
        .ok()
        .and_then(|text| {
            text.lines().find_map(|l| {
                let (k, v) = l.split_once('=')?;
                (k.trim() == "MaxArraySize").then(|| v.trim().parse().ok())?
            })
        })
        .unwrap_or(1001)
}

/// Submits `script` as an array of tasks `0..tasks` with at most `throttle` running at once,
/// each logging to `<log_dir>/<array id>_<task>.out`; the array's job id.
pub fn submit(
    script: &Path,
    tasks: usize,
    throttle: usize,
    job_name: &str,
    log_dir: &Path,
) -> Result<String, String> {
    // sbatch expands % in the log's name: the folder's own are doubled.
    let log = format!(
        "{}/%A_%a.out",
        log_dir.display().to_string().replace('%', "%%")
    );
    let args = vec![
        "--parsable".to_string(),
        format!("--array=0-{}%{throttle}", tasks.max(1) - 1),
        format!("--job-name={job_name}"),
        format!("--output={log}"),
        script.display().to_string(),
    ];
    let out = slurm("sbatch", &args)?;
    parse_parsable(&out).ok_or_else(|| format!("sbatch: expected a job id, got \"{}\"", out.trim()))
}

/// The job id in `sbatch --parsable`'s answer (`123` or `123;cluster`).
pub fn parse_parsable(out: &str) -> Option<String> {
    let id = out.trim().split(';').next()?.trim();
    (!id.is_empty() && id.bytes().all(|b| b.is_ascii_digit())).then(|| id.to_string())
}

/// A task's place in the queue.
#[derive(Clone, Debug, PartialEq)]
pub struct Queued {
    /// PENDING, RUNNING, COMPLETING, CONFIGURING, SUSPENDED, REQUEUED, ...
    pub state: String,
    /// Why it waits (Priority, Resources, JobArrayTaskLimit, ...).
    pub reason: String,
}

impl Queued {
    pub fn running(&self) -> bool {
        matches!(
            self.state.as_str(),
            "RUNNING" | "COMPLETING" | "CONFIGURING" | "STAGE_OUT" | "SIGNALING"
        )
    }
}

/// The tasks of the arrays `job_ids` still in the queue, by (array job id, task).
pub fn squeue(job_ids: &[String]) -> Result<HashMap<(String, u32), Queued>, String> {
    if job_ids.is_empty() {
        return Ok(HashMap::new());
    }
    let args = vec![
        "--noheader".to_string(),
        "--array".to_string(),
        // Hidden partitions too: a task there is not gone.
        "--all".to_string(),
        format!("--jobs={}", job_ids.join(",")),
        "--format=%F|%K|%T|%r".to_string(),
    ];
    match slurm("squeue", &args) {
        Ok(out) => Ok(parse_squeue(&out)),
        // Every job named has left the controller's memory: none is queued.
        Err(e) if e.contains("Invalid job id") => Ok(HashMap::new()),
        Err(e) => Err(e),
    }
}

/// The tasks in a queue named `name` (for an array whose id was never recorded).
pub fn squeue_by_name(name: &str) -> Result<HashMap<(String, u32), Queued>, String> {
    let args = vec![
        "--noheader".to_string(),
        "--array".to_string(),
        "--all".to_string(),
        format!("--name={name}"),
        "--format=%F|%K|%T|%r".to_string(),
    ];
    slurm("squeue", &args).map(|out| parse_squeue(&out))
}

/// Lines of `squeue --array --format=%F|%K|%T|%r`. A pending array not yet split prints its
/// tasks as a range (`2-5%2`, `[0,3-4]`); each task of the range is listed.
pub fn parse_squeue(out: &str) -> HashMap<(String, u32), Queued> {
    let mut map = HashMap::new();
    for line in out.lines() {
        let f: Vec<&str> = line.trim().split('|').collect();
        if f.len() < 4 || f[0].is_empty() {
            continue;
        }
        let queued = Queued {
            state: f[2].trim().to_string(),
            reason: f[3].trim().to_string(),
        };
        for task in task_range(f[1]) {
            map.insert((f[0].trim().to_string(), task), queued.clone());
        }
    }
    map
}

/// The tasks of `7`, `2-5`, `2-5%2` or `[0,3-4]%1`.
fn task_range(s: &str) -> Vec<u32> {
    let s = s.trim().trim_start_matches('[');
    let s = s.split('%').next().unwrap_or("").trim_end_matches(']');
    let mut tasks = Vec::new();
    for part in s.split(',') {
        match part.split_once('-') {
            Some((a, b)) => {
                if let (Ok(a), Ok(b)) = (a.parse::<u32>(), b.parse::<u32>()) {
                    if b >= a && b - a < 1_000_000 {
                        tasks.extend(a..=b);
                    }
                }
            }
            None => tasks.extend(part.parse::<u32>().ok()),
        }
    }
    tasks
}

/// What Slurm says about a task that left the queue.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Ending {
    /// COMPLETED, FAILED, TIMEOUT, NODE_FAIL, PREEMPTED, OUT_OF_MEMORY, CANCELLED, ...; empty
    /// when nobody knows any more.
    pub state: String,
    pub reason: String,
    pub exit_code: String,
    pub run_time: String,
    pub time_limit: String,
    pub node: String,
    /// Where this came from: scontrol, sacct or the task's log.
    pub source: &'static str,
}

/// Why task `task` of array `job_id` ended: from `scontrol show job` while the controller
/// remembers it (`MinJobAge`, 300 s by default), else from `sacct` where there is accounting,
/// else from the lines Slurm writes into the task's log when it kills it.
pub fn ending(job_id: &str, task: u32, log: &Path) -> Ending {
    let id = format!("{job_id}_{task}");
    if let Ok(out) = slurm("scontrol", &["show".into(), "job".into(), id.clone()]) {
        let e = parse_scontrol(&out);
        if !e.state.is_empty() {
            return e;
        }
    }
    let args = vec![
        "--noheader".into(),
        "--parsable2".into(),
        "--allocations".into(),
        format!("--jobs={id}"),
        "--format=State,ExitCode,Elapsed,Timelimit,NodeList,Reason".into(),
    ];
    if let Ok(out) = slurm("sacct", &args) {
        if let Some(e) = parse_sacct(&out) {
            return e;
        }
    }
    let text = std::fs::read_to_string(log).unwrap_or_default();
    parse_log(&text)
}

/// `scontrol show job`'s `Key=Value` words.
pub fn parse_scontrol(out: &str) -> Ending {
    let mut e = Ending {
        source: "scontrol",
        ..Ending::default()
    };
    for word in out.split_whitespace() {
        let Some((k, v)) = word.split_once('=') else {
            continue;
        };
        let v = v.to_string();
        match k {
            "JobState" if e.state.is_empty() => e.state = v,
            "Reason" if e.reason.is_empty() => e.reason = v,
            "ExitCode" if e.exit_code.is_empty() => e.exit_code = v,
            "RunTime" if e.run_time.is_empty() => e.run_time = v,
            "TimeLimit" if e.time_limit.is_empty() => e.time_limit = v,
            "NodeList" if e.node.is_empty() => e.node = v,
            _ => {}
        }
    }
    e
}

/// The first line of `sacct --parsable2` with State|ExitCode|Elapsed|Timelimit|NodeList|Reason.
pub fn parse_sacct(out: &str) -> Option<Ending> {
    let line = out.lines().find(|l| !l.trim().is_empty())?;
    let f: Vec<&str> = line.split('|').collect();
    if f.len() < 6 || f[0].is_empty() {
        return None;
    }
    Some(Ending {
        // "CANCELLED by 0" reads as CANCELLED.
        state: f[0].split_whitespace().next().unwrap_or("").to_string(),
        exit_code: f[1].to_string(),
        run_time: f[2].to_string(),
        time_limit: f[3].to_string(),
        node: f[4].to_string(),
        reason: f[5].to_string(),
        source: "sacct",
    })
}

/// What slurmstepd wrote into the log when it ended the task
/// (`*** JOB 12 ON node3 CANCELLED AT 2026-... DUE TO TIME LIMIT ***`).
pub fn parse_log(text: &str) -> Ending {
    let mut e = Ending {
        source: "log",
        ..Ending::default()
    };
    for line in text.lines().rev() {
        let Some(start) = line.find("*** JOB ") else {
            continue;
        };
        let words: Vec<&str> = line[start..].split_whitespace().collect();
        // *** JOB <id> ON <node> CANCELLED AT <time> [DUE TO <why>] ***
        if let Some(i) = words.iter().position(|w| *w == "ON") {
            e.node = words.get(i + 1).unwrap_or(&"").to_string();
        }
        let rest = line[start..].to_string();
        e.state = if rest.contains("DUE TO TIME LIMIT") {
            "TIMEOUT"
        } else if rest.contains("DUE TO PREEMPTION") {
            "PREEMPTED"
        } else if rest.contains("DUE TO NODE FAILURE") {
            "NODE_FAIL"
        } else {
            "CANCELLED"
        }
        .to_string();
        e.reason = rest
            .trim_matches(|c: char| c == '*' || c.is_whitespace())
            .to_string();
        return e;
    }
    if text.contains("oom_kill event") || text.contains("oom-kill") {
        e.state = "OUT_OF_MEMORY".into();
    }
    e
}

/// What becomes of a task that left the queue without a result.
#[derive(Clone, Debug, PartialEq)]
pub enum Verdict {
    /// Still on its way out (requeued, completing): look again later.
    Wait,
    /// Ended for a reason not the run's own: submit it again (if retries are left).
    Retry(String),
    /// A failed run, with its kind and reason.
    Fail(RunErrorKind, String),
}

/// The verdict on a task Slurm ended as `e`; `id` names it (`14_3`), `log` is its log, whose last
/// line goes into the message.
pub fn verdict(e: &Ending, id: &str, log: &Path, log_tail: &str) -> Verdict {
    let on = if e.node.is_empty() || e.node == "(null)" {
        String::new()
    } else {
        format!(" on {}", e.node)
    };
    let tail = if log_tail.is_empty() {
        String::new()
    } else {
        format!("; its log {} ends: {log_tail}", log.display())
    };
    let k = RunErrorKind::Cluster;
    match e.state.as_str() {
        "PENDING" | "RUNNING" | "REQUEUED" | "REQUEUE_HOLD" | "REQUEUE_FED" | "COMPLETING"
        | "CONFIGURING" | "SUSPENDED" | "RESIZING" | "SIGNALING" | "STAGE_OUT" => Verdict::Wait,
        "TIMEOUT" | "DEADLINE" => Verdict::Fail(
            RunErrorKind::TimeLimit,
            format!(
                "Slurm stopped the task at its time limit{} (job {id}{on}{})",
                if e.time_limit.is_empty() {
                    String::new()
                } else {
                    format!(" of {}", e.time_limit)
                },
                if e.run_time.is_empty() {
                    String::new()
                } else {
                    format!(", ran {}", e.run_time)
                }
            ),
        ),
        "NODE_FAIL" => Verdict::Retry(format!("its node failed (job {id}{on})")),
        "PREEMPTED" => Verdict::Retry(format!("it was pre-empted (job {id}{on})")),
        "BOOT_FAIL" => Verdict::Retry(format!("its node failed to boot (job {id}{on})")),
        "OUT_OF_MEMORY" => Verdict::Fail(
            k,
            format!("Slurm stopped the task: out of memory (job {id}{on}; raise memory in [executor]){tail}"),
        ),
        "CANCELLED" => Verdict::Fail(
            k,
            format!(
                "the task was cancelled (job {id}{on}{}){tail}",
                if e.reason.is_empty() || e.reason == "None" {
                    String::new()
                } else {
                    format!(": {}", e.reason)
                }
            ),
        ),
        "FAILED" => Verdict::Fail(
            k,
            format!(
                "the task ended with exit code {} and no result (job {id}{on}){tail}",
                e.exit_code
            ),
        ),
        "COMPLETED" => Verdict::Fail(
            k,
            format!("the task ended without writing its result (job {id}{on}){tail}"),
        ),
        // demcal run-one records every failure of its own, so a task gone without a record and
        // without a known cause most likely met its node's end while nobody was looking.
        "" => Verdict::Retry(format!(
            "it left the queue without a result, and Slurm no longer says why (job {id}){tail}"
        )),
        other => Verdict::Fail(
            k,
            format!("Slurm ended the task as {other} (job {id}{on}, reason {}){tail}", e.reason),
        ),
    }
}

/// The last non-empty line of a log, shortened to one readable line.
pub fn log_tail(log: &Path) -> String {
    let text = std::fs::read_to_string(log).unwrap_or_default();
    let line = text
        .lines()
        .rev()
        .map(str::trim)
        .find(|l| !l.is_empty())
        .unwrap_or("");
    line.chars().take(240).collect()
}

/// Whether a task waiting for `reason` waits until someone acts: a hold, or a request beyond a
/// limit of its partition, QOS or account.
pub fn never_clears(reason: &str) -> bool {
    reason.starts_with("JobHeld")
        || reason.contains("launch failed requeued held")
        || reason.starts_with("Partition")
            && reason != "PartitionDown"
            && reason != "PartitionInactive"
        || reason.starts_with("QOSMax") && reason.ends_with("PerJobLimit")
        || reason.starts_with("AssocMax") && reason.ends_with("PerJobLimit")
        || matches!(
            reason,
            "InvalidAccount" | "InvalidQOS" | "DependencyNeverSatisfied" | "BadConstraints"
        )
}

/// Withdraws every task of the submission named `name` (its job name carries its token).
pub fn cancel_by_name(name: &str) -> Result<(), String> {
    slurm("scancel", &[format!("--name={name}")]).map(|_| ())
}

/// Withdraws tasks (`14_3`) or whole arrays (`14`).
pub fn cancel(ids: &[String]) -> Result<(), String> {
    if ids.is_empty() {
        return Ok(());
    }
    // Thousands of ids in one call would pass the command-line limit.
    for chunk in ids.chunks(500) {
        slurm("scancel", chunk)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn squeue_lines_with_split_and_unsplit_arrays() {
        let q = parse_squeue(
            "8|1|PENDING|JobArrayTaskLimit\n8|0|RUNNING|None\n9|[2-4,7]%2|PENDING|Priority\n\n",
        );
        assert_eq!(q.len(), 6);
        assert!(q[&("8".to_string(), 0)].running());
        assert!(!q[&("8".to_string(), 1)].running());
        assert_eq!(q[&("9".to_string(), 7)].reason, "Priority");
        assert!(q.contains_key(&("9".to_string(), 3)));
        assert_eq!(task_range("2-5%2"), [2, 3, 4, 5]);
        assert_eq!(parse_parsable("123;cluster\n").as_deref(), Some("123"));
        assert_eq!(parse_parsable("sbatch: error"), None);
    }

    #[test]
    fn endings_from_scontrol_sacct_and_the_log() {
        let e = parse_scontrol(
            "JobId=8 ArrayJobId=7 ArrayTaskId=0 JobName=job.sh\n   JobState=TIMEOUT Reason=TimeLimit Dependency=(null)\n   Requeue=1 Restarts=0 BatchFlag=1 Reboot=0 ExitCode=0:15\n   RunTime=00:01:14 TimeLimit=00:01:00 TimeMin=N/A\n   NodeList=vm\n",
        );
        assert_eq!(
            (
                e.state.as_str(),
                e.run_time.as_str(),
                e.time_limit.as_str(),
                e.node.as_str()
            ),
            ("TIMEOUT", "00:01:14", "00:01:00", "vm")
        );
        let v = verdict(&e, "7_0", Path::new("l.out"), "");
        assert_eq!(
            v,
            Verdict::Fail(
                RunErrorKind::TimeLimit,
                "Slurm stopped the task at its time limit of 00:01:00 (job 7_0 on vm, ran 00:01:14)".into()
            )
        );
        let s = parse_sacct("NODE_FAIL|0:0|00:10:00|01:00:00|node7|None\n").unwrap();
        assert!(
            matches!(verdict(&s, "3_1", Path::new("l"), ""), Verdict::Retry(m) if m.contains("node failed") && m.contains("node7"))
        );
        let c = parse_sacct("CANCELLED by 0|0:15|00:00:03|01:00:00|vm|None\n").unwrap();
        assert_eq!(c.state, "CANCELLED");
        let l = parse_log("task 0\nslurmstepd-vm: error: *** JOB 7 ON vm CANCELLED AT 2026-11-23T05:30:54 DUE TO TIME LIMIT ***\n");
        assert_eq!((l.state.as_str(), l.node.as_str()), ("TIMEOUT", "vm"));
        let p = parse_log("*** JOB 9 ON n2 CANCELLED AT 2026-11-23T05:30:54 DUE TO PREEMPTION ***");
        assert!(matches!(
            verdict(&p, "9", Path::new("l"), ""),
            Verdict::Retry(_)
        ));
        assert_eq!(parse_log("nothing").state, "");
        let failed = Ending {
            state: "FAILED".into(),
            exit_code: "1:0".into(),
            ..Ending::default()
        };
        assert!(matches!(
            verdict(&failed, "4_2", Path::new("/r/4_2.out"), "error: job.json: cannot read"),
            Verdict::Fail(RunErrorKind::Cluster, m) if m.contains("exit code 1:0") && m.contains("/r/4_2.out ends: error: job.json")
        ));
        let running = Ending {
            state: "REQUEUED".into(),
            ..Ending::default()
        };
        assert_eq!(verdict(&running, "4_2", Path::new("l"), ""), Verdict::Wait);
        // Forgotten by Slurm and without a log line: most likely the node, so tried again.
        assert!(
            matches!(verdict(&Ending::default(), "4_2", Path::new("l"), ""), Verdict::Retry(m) if m.contains("no longer says why"))
        );
        for (reason, stuck) in [
            ("Priority", false),
            ("Resources", false),
            ("JobArrayTaskLimit", false),
            ("PartitionDown", false),
            ("PartitionTimeLimit", true),
            ("JobHeldAdmin", true),
            ("QOSMaxWallDurationPerJobLimit", true),
            ("QOSMaxJobsPerUserLimit", false),
            ("InvalidAccount", true),
        ] {
            assert_eq!(never_clears(reason), stuck, "{reason}");
        }
    }
}
