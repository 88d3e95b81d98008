//! What `demcal status` says about a study's Slurm tasks.

use std::collections::{BTreeMap, BTreeSet};

use super::ledger::Task;
use super::queue;
use crate::spec::Study;
use crate::store::Store;
use crate::text::job_list;

/// `demcal status`'s lines for the Slurm tasks: per stage, how many are queued (and why),
/// running and finished, with their job ids. Asks `squeue` about the open ones when it can.
pub fn status_lines(study: &Study, store: &Store) -> Result<String, String> {
    let tasks = store.cluster_tasks(false)?;
    if tasks.is_empty() {
        return Ok(String::new());
    }
    // A task still open whose run is stored (by a later coordinator or another executor) is
    // finished as far as the study goes.
    let stored_runs: BTreeSet<(usize, usize, String)> = store
        .runs()?
        .into_iter()
        .map(|r| (r.stage, r.index, r.fingerprint))
        .collect();
    let is_stored = |t: &Task| stored_runs.contains(&(t.stage, t.index, t.fingerprint.clone()));
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
        let finished = of
            .iter()
            .filter(|t| t.state == "stored" || t.state == "open" && is_stored(t))
            .count();
        let open: Vec<&&Task> = of
            .iter()
            .filter(|t| t.state == "open" && !is_stored(t))
            .collect();
        let counts = match &queued {
            Ok(q) => {
                let (mut running, mut ended) = (0, 0);
                let mut waiting: BTreeMap<&str, usize> = BTreeMap::new();
                for t in &open {
                    match t.job_id.as_ref().and_then(|j| q.get(&(j.clone(), t.task))) {
                        Some(p) if p.running() => running += 1,
                        Some(p) => *waiting.entry(p.reason.as_str()).or_default() += 1,
                        None => ended += 1,
                    }
                }
                format!(
                    "{} queued{}, {running} running, {finished} finished{}",
                    waiting.values().sum::<usize>(),
                    reasons(&waiting),
                    if ended > 0 {
                        format!(", {ended} ended and not yet collected")
                    } else {
                        String::new()
                    }
                )
            }
            Err(e) => format!(
                "{} submitted and not yet collected, {finished} finished (queue not readable here: {e})",
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

/// Why tasks wait, as " (3 Priority, 1 Resources)"; empty when none wait.
pub(super) fn reasons(waiting: &BTreeMap<&str, usize>) -> String {
    // Slurm says None for a task not yet looked at.
    let parts: Vec<String> = waiting
        .iter()
        .filter(|(reason, _)| !reason.is_empty() && **reason != "None")
        .map(|(reason, n)| format!("{n} {reason}"))
        .collect();
    if parts.is_empty() {
        return String::new();
    }
    format!(" ({})", parts.join(", "))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn job_ids_in_numeric_order_and_reasons() {
        assert_eq!(job_list(["19", "2", "24", "2"].into_iter()), "2, 19, 24");
        let mut w = BTreeMap::new();
        assert_eq!(reasons(&w), "");
        w.insert("Priority", 3);
        w.insert("JobArrayTaskLimit", 1);
        w.insert("None", 2);
        assert_eq!(reasons(&w), " (1 JobArrayTaskLimit, 3 Priority)");
    }
}
