//! Kernel time shares from GPU timestamps, for `tools/gpu/measure.sh`: with
//! `DEMCAL_GPU_PROFILE=1` in the environment and a device with timestamp queries, the segment
//! runs each launch in a compute pass of its own that writes a timestamp at its start and end,
//! and adds the time between them to its kernel's total ([`kernel_times`]).
//!
//! Why passes of their own: timestamps inside a pass need a feature few drivers have
//! (`TIMESTAMP_QUERY_INSIDE_PASSES`), while pass timestamps are core to timestamp queries. The
//! passes synchronise as the dispatches of one pass do, so the results are the same bits; the
//! extra passes cost a little, which is why profiling is asked for, not always on.

use std::collections::BTreeMap;
use std::sync::{Mutex, OnceLock};

/// Queries in the set of one chunk: two per launch, at most this many launches a chunk.
pub(crate) const MOST_LAUNCHES: usize = 2048;

/// Whether profiling was asked for (`DEMCAL_GPU_PROFILE=1`), read once.
pub(crate) fn asked() -> bool {
    static ASKED: OnceLock<bool> = OnceLock::new();
    *ASKED.get_or_init(|| std::env::var("DEMCAL_GPU_PROFILE").as_deref() == Ok("1"))
}

/// Seconds and launches per kernel, over the process.
fn totals() -> &'static Mutex<BTreeMap<&'static str, (f64, u64)>> {
    static TOTALS: OnceLock<Mutex<BTreeMap<&'static str, (f64, u64)>>> = OnceLock::new();
    TOTALS.get_or_init(Default::default)
}

/// Adds the launches of one chunk: `names[k]` ran from `stamps[2k]` to `stamps[2k + 1]`, in
/// ticks of `period` nanoseconds.
pub(crate) fn add(names: &[&'static str], stamps: &[u64], period: f32) {
    let mut t = totals().lock().unwrap_or_else(|e| e.into_inner());
    for (k, name) in names.iter().enumerate() {
        let ticks = stamps[2 * k + 1].saturating_sub(stamps[2 * k]);
        let e = t.entry(name).or_default();
        e.0 += ticks as f64 * period as f64 * 1e-9;
        e.1 += 1;
    }
}

/// Each kernel's device time in seconds and its number of launches, since the process started,
/// largest first; empty unless profiling ran.
pub fn kernel_times() -> Vec<(&'static str, f64, u64)> {
    let t = totals().lock().unwrap_or_else(|e| e.into_inner());
    let mut v: Vec<_> = t.iter().map(|(&n, &(s, c))| (n, s, c)).collect();
    v.sort_by(|a, b| b.1.total_cmp(&a.1));
    v
}

/// One line of each kernel's share of the timed device time, or None when nothing was timed.
pub fn shares_line() -> Option<String> {
    let times = kernel_times();
    let total: f64 = times.iter().map(|t| t.1).sum();
    if times.is_empty() || total <= 0.0 {
        return None;
    }
    let parts: Vec<String> = times
        .iter()
        .map(|(name, s, n)| {
            format!(
                "{name} {:.1} % ({:.1} us a launch)",
                100.0 * s / total,
                1e6 * s / *n as f64
            )
        })
        .collect();
    Some(format!(
        "kernel shares of {:.3} s of device time: {}",
        total,
        parts.join(", ")
    ))
}

/// What a benchmark prints about the profile: None unless profiling was asked for; then the
/// shares, or why there are none, and on a second line the host's time per try of a segment.
pub fn report_line() -> Option<String> {
    if !asked() {
        return None;
    }
    let shares = shares_line().unwrap_or_else(|| {
        "kernel shares: none timed (the device has no timestamp queries, or no segment ran on it)"
            .to_string()
    });
    Some(match host_line() {
        Some(host) => format!("{shares}\n{host}"),
        None => shares,
    })
}

/// Seconds in each phase, in the order first seen, and the tries added.
type HostTotals = (Vec<(&'static str, f64)>, u64);

/// The host's seconds in each phase of a segment's tries, and the tries, over the process.
fn host_totals() -> &'static Mutex<HostTotals> {
    static TOTALS: OnceLock<Mutex<HostTotals>> = OnceLock::new();
    TOTALS.get_or_init(Default::default)
}

/// The wall-clock time of the phases of one try of a segment on the host (`resident::run`):
/// what a segment costs besides its steps (merging the worlds, making and writing the buffers
/// (their writes submitted at that phase's end), the bind groups, submitting the lists' first
/// build, reading the end back and splitting it), which a world resident across segments would save in part. Cheap enough to
/// take always; added up only when profiling, and only for tries that reach their end.
pub(crate) struct HostPhases {
    last: std::time::Instant,
    phases: Vec<(&'static str, f64)>,
}

impl HostPhases {
    pub(crate) fn start() -> HostPhases {
        HostPhases {
            last: std::time::Instant::now(),
            phases: Vec::new(),
        }
    }

    /// Ends phase `name` (it began where the last ended).
    pub(crate) fn mark(&mut self, name: &'static str) {
        let now = std::time::Instant::now();
        self.phases
            .push((name, now.duration_since(self.last).as_secs_f64()));
        self.last = now;
    }

    /// Adds the try's phases to the process's totals, when profiling.
    pub(crate) fn record(self) {
        if !asked() {
            return;
        }
        let mut t = host_totals().lock().unwrap_or_else(|e| e.into_inner());
        for (name, secs) in self.phases {
            match t.0.iter_mut().find(|(n, _)| *n == name) {
                Some(e) => e.1 += secs,
                None => t.0.push((name, secs)),
            }
        }
        t.1 += 1;
    }
}

/// One line of the host's mean milliseconds per try in each phase, or None when none ran.
pub fn host_line() -> Option<String> {
    let t = host_totals().lock().unwrap_or_else(|e| e.into_inner());
    if t.1 == 0 {
        return None;
    }
    let parts: Vec<String> =
        t.0.iter()
            .map(|(name, secs)| format!("{name} {:.3}", 1e3 * secs / t.1 as f64))
            .collect();
    Some(format!(
        "host ms per segment try ({} tries): {}",
        t.1,
        parts.join(", ")
    ))
}
