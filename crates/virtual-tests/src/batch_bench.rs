//! The batch benchmark: many runs of one virtual test (seeds 1, 2, ...) made `jobs` at a time,
//! as a study's stage makes them, timed as simulations per hour. On the GPU the runs that run at
//! once form one batch group, so their steps share kernel launches (`dem::sim::in_batch_group`);
//! on the CPU each job gets its share of the cores.

use std::collections::VecDeque;
use std::sync::Mutex;
use std::time::Instant;

use crate::{run_file, Response, TestFile};

/// What a batch benchmark measured.
#[derive(Clone, Debug)]
pub struct BatchBench {
    pub runs: usize,
    pub jobs: usize,
    pub backend: String,
    pub wall_s: f64,
    /// Each finished run's first response (the angle of repose for a repose test), by seed.
    pub responses: Vec<(u64, f64)>,
    /// Runs that failed, with why.
    pub failures: Vec<(u64, String)>,
}

impl BatchBench {
    pub fn per_hour(&self) -> f64 {
        self.runs as f64 / self.wall_s * 3600.0
    }

    /// Mean and standard deviation of the responses (None without any).
    pub fn mean_sd(&self) -> Option<(f64, f64)> {
        if self.responses.is_empty() {
            return None;
        }
        let n = self.responses.len() as f64;
        let mean = self.responses.iter().map(|r| r.1).sum::<f64>() / n;
        let var = self
            .responses
            .iter()
            .map(|r| (r.1 - mean).powi(2))
            .sum::<f64>()
            / (n - 1.0).max(1.0);
        Some((mean, var.sqrt()))
    }
}

/// Runs `file` with seeds 1..=`runs`, `jobs` at a time, on `backend`; `finished` hears each run
/// that ends (its seed).
pub fn run_batch(
    file: &TestFile,
    runs: usize,
    jobs: usize,
    backend: &str,
    finished: &(dyn Fn(u64) + Sync),
) -> Result<BatchBench, String> {
    if runs == 0 || jobs == 0 {
        return Err("a batch needs at least one run and one job".into());
    }
    let mut file = file.clone();
    file.backend = Some(backend.to_string());
    let jobs = jobs.min(runs);
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let threads = (cores / jobs).max(1);
    let pools = (0..jobs)
        .map(|_| rayon::ThreadPoolBuilder::new().num_threads(threads).build())
        .collect::<Result<Vec<_>, _>>()
        .map_err(|e| format!("cannot start {jobs} job(s): {e}"))?;
    let seeds = Mutex::new((1..=runs as u64).collect::<VecDeque<_>>());
    let results = Mutex::new((Vec::new(), Vec::new()));
    let group = dem::sim::new_batch_group();
    let started = Instant::now();
    std::thread::scope(|scope| {
        for pool in &pools {
            let (file, seeds, results) = (&file, &seeds, &results);
            scope.spawn(move || loop {
                let Some(seed) = seeds.lock().unwrap_or_else(|e| e.into_inner()).pop_front() else {
                    break;
                };
                let done = pool.install(|| {
                    dem::sim::in_batch_group(group, || {
                        run_file(file, Some(seed), None, &mut |_, _| Ok(()))
                    })
                });
                let mut r = results.lock().unwrap_or_else(|e| e.into_inner());
                match done {
                    Ok(d) => match d.responses.first() {
                        Some((_, Response::Scalar(v))) => r.0.push((seed, *v)),
                        _ => r.1.push((seed, "no scalar response".to_string())),
                    },
                    Err(e) => r.1.push((seed, e.to_string())),
                }
                drop(r);
                finished(seed);
            });
        }
    });
    let wall_s = started.elapsed().as_secs_f64();
    let (mut responses, failures) = results.into_inner().unwrap_or_else(|e| e.into_inner());
    responses.sort_by_key(|r| r.0);
    Ok(BatchBench {
        runs,
        jobs,
        backend: backend.to_string(),
        wall_s,
        responses,
        failures,
    })
}
