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
/// shares, or why there are none.
pub fn report_line() -> Option<String> {
    if !asked() {
        return None;
    }
    Some(shares_line().unwrap_or_else(|| {
        "kernel shares: none timed (the device has no timestamp queries, or no segment ran on it)"
            .to_string()
    }))
}
