//! `demcal bench`: the peer benchmarks in particle-steps per second, and the batch benchmark in
//! simulations per hour.

use std::path::Path;

use crate::progress::{check_jobs, LogLine, MOST_PER_BATCH};
use crate::{chosen_backend, progress_bar};

/// The quickstart's repose test, the batch benchmark's default.
const QUICKSTART_REPOSE: &str = include_str!("../../../examples/quickstart/repose.toml");

/// `demcal bench batch`: the runs on the chosen back end, then (when that is the GPU) on the
/// CPU runner, as simulations per hour.
pub fn batch(
    test: Option<&Path>,
    runs: usize,
    jobs: Option<usize>,
    cpu_jobs: Option<usize>,
    backend: &str,
) -> Result<(), String> {
    use virtual_tests::batch_bench::run_batch;
    if runs == 0 || runs > 100_000 {
        return Err(format!("--runs {runs}: expected 1 to 100000"));
    }
    let file = match test {
        Some(path) => virtual_tests::TestFile::load(path)?,
        None => virtual_tests::TestFile::parse("quickstart repose.toml", QUICKSTART_REPOSE)?,
    };
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let backend = chosen_backend(backend)?;
    let default_jobs = if backend == "cpu" {
        cores
    } else {
        runs.min(MOST_PER_BATCH)
    };
    let mut sides = vec![(backend, jobs.unwrap_or(default_jobs), "--jobs")];
    if backend != "cpu" {
        sides.push(("cpu", cpu_jobs.unwrap_or(cores), "--cpu-jobs"));
    }
    let mut per_hour = Vec::new();
    for (backend, jobs, flag) in sides {
        check_jobs(flag, jobs, backend != "cpu")?;
        let bar = progress_bar(runs as u64);
        let before = dem_gpu::batch::batch_stats();
        let r = run_batch(&file, runs, jobs, backend, &|_| bar.inc(1))?;
        bar.finish_and_clear();
        let after = dem_gpu::batch::batch_stats();
        let response = match r.mean_sd() {
            Some((mean, sd)) => format!(
                "first response {mean:.3} +- {sd:.3} (sd over {} runs)",
                r.responses.len()
            ),
            None => "no run gave a response".to_string(),
        };
        let batches = if backend == "cpu" {
            String::new()
        } else {
            format!(
                ", {} batches of {:.1} simulations on average (largest {}; the most device memory one took {:.1} MB; packed to the memory {} times)",
                after.batches - before.batches,
                (after.worlds - before.worlds) as f64
                    / (after.batches - before.batches).max(1) as f64,
                after.largest,
                after.most_bytes as f64 * 1e-6,
                after.packed - before.packed
            )
        };
        println!(
            "batch {backend}: {runs} runs of {} ({}), {jobs} at a time: {:.1} s, {:.1} simulations per hour; {response}{batches}",
            file.test,
            file.name,
            r.wall_s,
            r.per_hour(),
        );
        for (seed, why) in &r.failures {
            println!("  seed {seed} failed: {why}");
        }
        per_hour.push(r.per_hour());
    }
    if let [gpu, cpu] = per_hour[..] {
        println!(
            "batch: the {backend} makes {:.2}x the simulations per hour of the CPU runner",
            gpu / cpu
        );
    }
    Ok(())
}

/// `demcal bench worlds`: many seed-000-sized simulations at once (the batches a study's GPU
/// rounds make), in particle-steps per second over all of them.
pub fn worlds(
    runs: usize,
    steps: Option<u64>,
    jobs: Option<usize>,
    backend: &str,
) -> Result<(), String> {
    let backend = chosen_backend(backend)?;
    let cores = rayon::current_num_threads();
    let jobs = jobs.unwrap_or(if backend == "cpu" {
        cores
    } else {
        runs.min(MOST_PER_BATCH)
    });
    check_jobs("--jobs", jobs, backend != "cpu")?;
    let bar = progress_bar(runs as u64);
    let r = dem::bench::worlds(runs, steps.unwrap_or(2_000), jobs, backend, &|| bar.inc(1))?;
    bar.finish_and_clear();
    println!("{}", r.line());
    if let Some(line) = dem_gpu::profile::report_line() {
        println!("{line}");
    }
    Ok(())
}

/// `demcal bench fill`: a random fill of `count` spheres, timed.
pub fn fill(count: usize) -> Result<(), String> {
    // As many as a scene may hold, checked before anything is drawn: 1e8 reached 3.5 GB before
    // the fill refused it.
    let most = dem::scene::MAX_SPHERES;
    if count == 0 || count > most {
        return Err(format!("--count: expected 1 to {most}, got {count}"));
    }
    let r = dem::random_fill::fill_benchmark(count)?;
    println!(
        "fill: spheres={} solid_fraction={:.3} wall_s={:.2} spheres_per_s={:.2e} relaxation_passes={}",
        r.count,
        r.solid_fraction,
        r.seconds,
        r.count as f64 / r.seconds.max(1e-9),
        r.report.passes
    );
    Ok(())
}

pub fn steps(name: &str, steps: Option<u64>, backend: &str, scale: u32) -> Result<(), String> {
    let total = steps.unwrap_or(match name {
        "bonded" => 20_000,
        "settle-wide" => dem::bench::SETTLE_WIDE_STEPS,
        _ if scale > 1 => dem::bench::SETTLE_WIDE_STEPS,
        _ => 50_000,
    });
    let bar = progress_bar(total);
    let mut log = LogLine::new();
    let progress = |done| {
        bar.set_position(done);
        if let Some(elapsed) = log.due() {
            eprintln!("{name}: {}", LogLine::steps(done, total, "", elapsed));
        }
    };
    let r = match name {
        "bonded" => dem::bench::bonded(steps, backend, progress)?,
        "settle-wide" => dem::bench::settle_wide(steps, backend, progress)?,
        _ => dem::bench::settle_scaled(scale, steps, backend, progress)?,
    };
    bar.finish_and_clear();
    for w in &r.remarks {
        eprintln!("warning: {w}");
    }
    println!("stages: {}", r.stages);
    println!(
        "neighbour rebuilds: {}, pair passes over every pair: {}, over the near pairs: {}, threads: {}",
        r.neighbour_rebuilds,
        r.pair_passes.0,
        r.pair_passes.1,
        rayon::current_num_threads()
    );
    println!("{}", r.line(name));
    if let Some(line) = dem_gpu::profile::report_line() {
        println!("{line}");
    }
    Ok(())
}

/// `demcal bench stages`: each stage of the step timed on its own on a settled bed.
pub fn stages(scale: u32, steps: Option<u64>, calls: usize) -> Result<(), String> {
    let total = steps.unwrap_or(if scale == 1 {
        dem::bench::STAGES_SETTLE_STEPS
    } else {
        dem::bench::SETTLE_WIDE_STEPS
    });
    let bar = progress_bar(total);
    let (particles, costs) =
        dem::bench::stage_costs(scale, steps, calls, |done| bar.set_position(done))?;
    bar.finish_and_clear();
    println!(
        "stages of the settle scene (scale {scale}, {particles} spheres, after {total} steps), {calls} calls each, threads: {}",
        rayon::current_num_threads()
    );
    for c in &costs {
        println!(
            "  {:<40} {:>10.1} us/call {:>8.1} ns/particle",
            c.stage,
            1e6 * c.seconds_per_call,
            c.ns_per_particle(particles)
        );
    }
    Ok(())
}
