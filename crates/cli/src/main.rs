//! `demcal`: the command-line front end. Each subcommand parses its arguments and hands the work to
//! a library crate; nothing here knows physics.

mod bench;
mod curve;
mod help_check;
mod init;
mod lab;
mod progress;
mod shape;
mod tables;

use clap::{Parser, Subcommand};
use dem::output::{LoadWriter, Snapshots};
use dem::scene::Scene;
use indicatif::{ProgressBar, ProgressStyle};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Instant;

use progress::{check_count, check_jobs, LogLine};
use tables::{doe_command, surrogate_command, DoeCommand, SurrogateCommand};

#[derive(Parser)]
#[command(
    name = "demcal",
    version,
    about = "Calibrate DEM models of agricultural materials",
    after_help = "Example (a whole calibration, then its state):\n  demcal run examples/quickstart/study.toml --jobs 2\n  demcal status examples/quickstart/study.toml"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Run a scene file: snapshots for ParaView (particles.pvd, geometry.pvd, ...), geometry loads (CSV) and a one-line summary.
    #[command(
        after_help = "Example:\n  demcal simulate examples/scenes/cylinder_lift.toml --out lift-out --threads 2"
    )]
    Simulate {
        /// The scene file (TOML; keys in docs/reference.md).
        scene: PathBuf,
        /// Worker threads (default: all cores).
        #[arg(long)]
        threads: Option<usize>,
        /// Write output here instead of the scene's [output] directory.
        #[arg(long)]
        out: Option<PathBuf>,
        /// Run the stages on the CPU or the GPU (default: the scene's simulation.backend, or cpu).
        #[arg(long, value_parser = ["cpu", "gpu"])]
        backend: Option<String>,
    },
    /// Measure the angle of repose of a heap given as spheres: a CSV file (x, y, z, radius) or a
    /// LIGGGHTS/LAMMPS custom dump (last frame), the way `demcal test` measures its own heaps.
    #[command(
        after_help = "Example:\n  demcal heap-angle heap.csv --axis 0,0 --base 0 --out heap-check --json"
    )]
    HeapAngle {
        /// The heap: a CSV file with columns x, y, z, radius (m), or a LIGGGHTS/LAMMPS dump.
        file: PathBuf,
        /// Vertical planes through the heap axis.
        #[arg(long, default_value_t = 4)]
        planes: usize,
        /// Heap axis x and y (m).
        #[arg(
            long,
            default_value = "0,0",
            value_delimiter = ',',
            num_args = 1,
            allow_negative_numbers = true
        )]
        axis: Vec<f64>,
        /// Height of the base plate (m).
        #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
        base: f64,
        /// Write profiles.svg and heap.png here.
        #[arg(long)]
        out: Option<PathBuf>,
        /// End with one JSON object with the results.
        #[arg(long)]
        json: bool,
    },
    #[command(about = format!("Run a virtual lab test ({}) and print what it measures", virtual_tests::registry::names().join(", ")))]
    #[command(long_about = format!("Run a virtual lab test and print what it measures. Tests: {}.", virtual_tests::tests_help()))]
    #[command(
        after_help = "Example:\n  demcal test examples/quickstart/repose.toml --seed 2 --out repose-out --json"
    )]
    Test {
        /// The virtual test file (TOML: test = \"...\", materials, and the test's table).
        test: PathBuf,
        /// Seed of the particle generation (overrides the file's `seed`).
        #[arg(long)]
        seed: Option<u64>,
        /// End with one JSON object with the results.
        #[arg(long)]
        json: bool,
        /// Write result.json (and for the repose test profiles.svg and heap.png) here.
        #[arg(long)]
        out: Option<PathBuf>,
        /// Worker threads (default: all cores).
        #[arg(long)]
        threads: Option<usize>,
        /// Run the stages on the CPU or the GPU (default: the file's backend, or cpu).
        #[arg(long, value_parser = ["cpu", "gpu"])]
        backend: Option<String>,
    },
    /// Write a commented test file and a study file to start a calibration from (repose.toml and
    /// study.toml for `repose`, ...); existing files are never overwritten.
    #[command(
        after_help = "Then: demcal test DIR/<kind>.toml (one run), demcal status DIR/study.toml (a check without simulating), demcal run DIR/study.toml --jobs 2.\n\nExample:\n  demcal init repose my-heap"
    )]
    Init {
        /// The lab test: repose (lifted-cylinder angle of repose), incline (tilting plate),
        /// shear, compression or bending (bonded stalk specimens).
        #[arg(value_parser = init::KINDS)]
        kind: String,
        /// The folder to write into (created if missing; default: the current folder).
        #[arg(default_value = ".")]
        dir: PathBuf,
    },
    /// Run (or resume) a calibration study: every stage of its plan, the runs stored in
    /// <study>.db next to it, then the report in report/ next to it.
    #[command(
        after_help = "Exit status: 0 finished; 1 stopped (a stage could not go on; see the report) or failed; 2 the study file (or a file or test it names) is wrong, nothing ran; 75 another demcal run holds the study's store, nothing ran; 130 Ctrl-C, finished runs kept (run the same command to go on).\n\nExample:\n  demcal run examples/quickstart/study.toml --jobs 2\n  demcal run cluster-study.toml --executor slurm --jobs 50"
    )]
    Run {
        /// The study file (TOML: tests, parameters, target, plan; see docs/reference.md).
        study: PathBuf,
        /// Simulations at once; each gets its share of the cores (default 1). With the GPU back
        /// end, the runs per batch: simulations that run at once share the GPU's kernel launches
        /// (default: a stage's missing runs in one batch, up to 128; at most 1024). With
        /// --executor slurm, the most tasks of a stage's array running at once (the %N throttle).
        #[arg(long)]
        jobs: Option<usize>,
        /// Where the simulations run: local (this machine's cores or GPU) or slurm (one job
        /// array per stage on a Slurm cluster, with the study's [executor] settings). Default:
        /// the study's [executor], or local.
        #[arg(long, value_parser = ["local", "slurm"])]
        executor: Option<String>,
        /// Move the stored results aside (kept as <study>.db.old-<time>) and start over.
        #[arg(long)]
        restart: bool,
        /// Run failed simulations again instead of keeping their failure.
        #[arg(long)]
        retry_failed: bool,
        /// Run the simulations on the CPU or the GPU (default: the study's backend, or cpu).
        #[arg(long, value_parser = ["cpu", "gpu"])]
        backend: Option<String>,
    },
    /// Run one simulation of a study from a job file (the unit a cluster executor submits) and
    /// write its record as JSON.
    #[command(
        after_help = "Example (as a Slurm task runs it):\n  demcal run-one study.runs/stage1-screening/a1b2c3/run004.json --threads 4"
    )]
    RunOne {
        /// The job file a study wrote (runNNN.json: the test with its parameters set, the seed).
        job: PathBuf,
        /// Where to write the record (default: the job file with .record.json in place of .json).
        #[arg(long)]
        record: Option<PathBuf>,
        /// Worker threads (default: all cores).
        #[arg(long)]
        threads: Option<usize>,
    },
    /// Show a study's stages, runs done / failed / pending, and the best values so far.
    #[command(after_help = "Example:\n  demcal status examples/quickstart/study.toml")]
    Status {
        /// The study file whose stored runs to show.
        study: PathBuf,
    },
    /// Write a study's report (index.html, results.csv, summary.json) from its stored runs.
    #[command(
        after_help = "Example:\n  demcal report examples/quickstart/study.toml --out paper-report"
    )]
    Report {
        /// The study file whose stored runs to report.
        study: PathBuf,
        /// Folder to write to (default: report/ next to the study).
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// Designed experiments: generate designs, analyse results (ANOVA), optimise fitted models.
    #[command(
        after_help = "Example (a design, then its analysis once the response column is filled in):\n  demcal doe design ccd --factors static_friction:0.2:0.8,rolling_friction:0.02:0.2 --out ccd.csv\n  demcal doe analyze ccd.csv --response angle_deg --model quadratic"
    )]
    Doe {
        #[command(subcommand)]
        action: DoeCommand,
    },
    /// The lab side: angle of repose from a heap photo, friction, moduli, moisture, density.
    #[command(
        after_help = "Example:\n  demcal lab photo-angle heap.jpg --debug heap-check.png --json"
    )]
    Lab {
        #[command(subcommand)]
        action: lab::LabCommand,
    },
    /// Curves outside a study: a simulated force-displacement curve scored against lab curves.
    #[command(
        after_help = "Example:\n  demcal curve compare shear_out/force_displacement.csv lab_shear.csv --normalisation lab_peak"
    )]
    Curve {
        #[command(subcommand)]
        action: curve::CurveCommand,
    },
    /// Surrogates (GP, BP, GA-BP) trained on your own result table, and searched for a goal.
    #[command(
        after_help = "Example:\n  demcal surrogate optimize results.csv --response angle_deg --factors D,E,G --model ga-bp --goal target=38.65"
    )]
    Surrogate {
        #[command(subcommand)]
        action: SurrogateCommand,
    },
    /// Particle shapes: multi-sphere fits of the maize kernel classes or an STL solid to a volume
    /// error, with their surface error and smallest sphere.
    #[command(after_help = "Example:\n  demcal shape fit --volume-error 0.05 --today")]
    Shape {
        #[command(subcommand)]
        action: shape::ShapeCommand,
    },
    /// Run a peer benchmark and print particle-steps per second (batch: simulations per hour).
    #[command(after_help = "Example:\n  demcal bench settle --threads 2")]
    Bench {
        /// settle: 21 160 spheres settling in a box (--scale widens it); settle-wide: the box
        /// widened 8 times in x and y (1 444 000 spheres, 5 000 steps); bonded: the seed-000
        /// stalk specimen crushed; batch: 32 quickstart repose tests (seeds 1-32) made as a study
        /// stage makes them, on the back end chosen, then on the CPU runner; fill: a random fill
        /// of 1 000 000 spheres at a solid fraction of 0.35; stages: each stage of the step timed
        /// on its own on the settle scene's bed (after 20 000 steps; --scale, --steps, --calls);
        /// worlds: 32 seed-000-sized settle scenes (4 000 spheres each) for 2 000 steps, all at
        /// once (on the GPU in shared launches; --runs, --steps, --jobs).
        #[arg(value_parser = ["settle", "settle-wide", "bonded", "batch", "fill", "stages", "worlds"])]
        name: String,
        /// settle: widen the box this many times in x and y, for scale² times the spheres
        /// (8: the 1 444 000 spheres of settle-wide; 5 000 steps unless --steps).
        #[arg(long, default_value_t = 1)]
        scale: u32,
        /// fill: how many spheres.
        #[arg(long, default_value_t = 1_000_000)]
        count: usize,
        /// stages: how many times each stage runs while timed.
        #[arg(long, default_value_t = 200)]
        calls: usize,
        /// Time steps to run (default: the benchmark's own, 20 000 for settle).
        #[arg(long)]
        steps: Option<u64>,
        /// Worker threads (default: all cores).
        #[arg(long)]
        threads: Option<usize>,
        /// Run the stages on the CPU or the GPU.
        #[arg(long, value_parser = ["cpu", "gpu"], default_value = "cpu")]
        backend: String,
        /// batch: how many runs (seeds 1..N); worlds: how many worlds.
        #[arg(long, default_value_t = 32)]
        runs: usize,
        /// batch and worlds: runs at once on the chosen back end (on the GPU, runs per batch;
        /// default: all; worlds on the CPU: the cores).
        #[arg(long)]
        jobs: Option<usize>,
        /// batch: runs at once on the CPU runner it is compared with (default: the cores).
        #[arg(long)]
        cpu_jobs: Option<usize>,
        /// batch: the test file to run instead of the quickstart repose test.
        #[arg(long)]
        test: Option<PathBuf>,
    },
}

fn run_test(
    path: &Path,
    seed: Option<u64>,
    json: bool,
    out: Option<&Path>,
    backend: Option<String>,
) -> Result<(), String> {
    let mut file = virtual_tests::TestFile::load(path)?;
    for w in &file.parts.warnings {
        eprintln!("warning: {w}");
    }
    if let Some(b) = backend.or(file.backend.take()) {
        file.backend = Some(chosen_backend(&b)?.to_string());
    }
    // A test with a curve writes it (and its logs) by default next to the file, so that the
    // curve_csv it reports exists.
    let default_out;
    let out = match out {
        Some(o) => Some(o),
        None if virtual_tests::responses(&file.test).contains(&"force_displacement")
            && file.test != "function" =>
        {
            let stem = path.file_stem().unwrap_or_default().to_string_lossy();
            default_out = path.with_file_name(format!("{stem}_out"));
            Some(default_out.as_path())
        }
        None => None,
    };
    let bar = ProgressBar::new_spinner();
    bar.set_style(
        ProgressStyle::with_template("{spinner} {elapsed_precise} {msg}")
            .map_err(|e| e.to_string())?,
    );
    let mut log = LogLine::new();
    let mut progress = |phase: &str, t: f64| {
        bar.set_message(format!("{phase}: t = {t:.2} s"));
        bar.tick();
        if let Some(elapsed) = log.due() {
            eprintln!(
                "{}: {phase}: t = {t:.2} s, {elapsed:.0} s elapsed",
                path.display()
            );
        }
        Ok(())
    };
    // Before the run: a folder that cannot be written would fail only after it.
    if let Some(dir) = out {
        dem::files::check_writable(dir)?;
    }
    let result = virtual_tests::run_file(&file, seed, out, &mut progress);
    bar.finish_and_clear();
    let done = result?;
    println!("{}", done.summary);
    if let Some(dir) = out {
        println!("wrote the results to {}", dir.display());
    }
    if json {
        println!("{}", done.json);
    }
    Ok(())
}

/// The back end `name` when this machine has it, else the CPU, said once on standard error.
pub(crate) fn chosen_backend(name: &str) -> Result<&'static str, String> {
    let (chosen, why) = dem::sim::resolve_backend(name)?;
    if let Some(why) = why {
        eprintln!("warning: backend \"{name}\": {why}");
    }
    Ok(chosen)
}

fn heap_angle(
    path: &Path,
    planes: usize,
    axis: &[f64],
    base: f64,
    out: Option<&Path>,
    json: bool,
) -> Result<(), String> {
    use virtual_tests::repose::{measure, read_spheres, ReposeMeasurement};
    if planes == 0 {
        return Err("--planes: expected at least 1".into());
    }
    // Each plane scans every sphere; beyond one plane per degree nothing more is learnt.
    if planes > 180 {
        return Err(format!("--planes {planes}: at most 180 (one per degree)"));
    }
    if axis.len() != 2 {
        return Err(format!("--axis: expected X,Y, got {} numbers", axis.len()));
    }
    if axis.iter().any(|v| !v.is_finite()) {
        return Err(format!(
            "--axis {},{}: expected two finite numbers X,Y (m)",
            axis[0], axis[1]
        ));
    }
    if !base.is_finite() {
        return Err(format!("--base {base}: expected a finite height (m)"));
    }
    let (positions, radii) = read_spheres(path)?;
    let top = positions
        .iter()
        .zip(&radii)
        .map(|(p, r)| p.z + r)
        .fold(f64::NEG_INFINITY, f64::max);
    if base >= top {
        return Err(format!(
            "--base {base}: at or above the top of every sphere in {} ({top:.4} m): give the height of the plate the heap stands on (m)",
            path.display()
        ));
    }
    let m = ReposeMeasurement {
        axis: (axis[0], axis[1]),
        base_z: base,
        planes,
        ..Default::default()
    };
    let r = measure(&positions, &radii, &m).map_err(|e| format!("{}: {e}", path.display()))?;
    println!(
        "{}: angle_deg={:.2} std_deg={:.2} heap_height_m={:.4} heap_radius_m={:.4} spheres={}",
        path.display(),
        r.angle_deg,
        r.angle_std_deg,
        r.heap_height,
        r.heap_radius,
        positions.len()
    );
    if let Some(dir) = out {
        std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
        let svg = virtual_tests::render::profiles_svg(&r)?;
        std::fs::write(dir.join("profiles.svg"), svg)
            .map_err(|e| format!("{}: {e}", dir.display()))?;
        virtual_tests::render::side_view_png(&positions, &radii, 900, &dir.join("heap.png"))?;
    }
    if json {
        let flanks: Vec<f64> = r.flanks.iter().map(|f| f.angle_deg).collect();
        println!(
            "{}",
            serde_json::json!({
                "angle_of_repose_deg": r.angle_deg,
                "angle_std_deg": r.angle_std_deg,
                "heap_height_m": r.heap_height,
                "heap_radius_m": r.heap_radius,
                "flank_angles_deg": flanks,
                "spheres": positions.len(),
            })
        );
    }
    Ok(())
}

fn set_threads(threads: Option<usize>) -> Result<(), String> {
    if let Some(t) = threads {
        check_count("--threads", t)?;
        rayon::ThreadPoolBuilder::new()
            .num_threads(t)
            .build_global()
            .map_err(|e| format!("--threads: {e}"))?;
    }
    Ok(())
}

/// Runs `f` on a thread of rayon's global pool. A command that drives one simulation at a time
/// then works on each parallel stage itself, with the other threads joining in, rather than
/// handing every stage to the pool and sleeping until it is done: a wake-up each way three times
/// a step, which cost 7 % of a one-thread settle run in system time. Not for commands that run
/// simulations from threads of their own (`run`, `bench batch`): those would queue behind it.
fn on_pool<R: Send>(f: impl FnOnce() -> R + Send) -> R {
    rayon::scope(|_| f())
}

/// Every option that takes a value accepts a negative number (`--base -0.001`), and a list
/// (`--axis -0.001,0.002`) may start with a minus; otherwise clap reads `-1` as a flag and says
/// "unexpected argument '-1'" without naming the option it was for.
fn with_negative_numbers(c: clap::Command) -> clap::Command {
    c.mut_args(|a| {
        if !a.get_action().takes_values() {
            a
        } else if a.get_value_delimiter().is_some() || a.get_id() == "crop" {
            // A list (`--axis -0.001,0.002`, `--crop -5,0,10,10`) is not a number, so only
            // hyphen values let it start with a minus.
            a.allow_hyphen_values(true)
        } else {
            a.allow_negative_numbers(true)
        }
    })
    .mut_subcommands(with_negative_numbers)
}

/// The command line, or a usage error in one line (clap's own spans several: the error, a
/// tip, the usage) with where to look; help and version print as they are.
fn parse_command_line() -> Result<Cli, ExitCode> {
    use clap::{CommandFactory, FromArgMatches};
    let matches = with_negative_numbers(Cli::command()).try_get_matches();
    match matches.and_then(|m| Cli::from_arg_matches(&m)) {
        Ok(cli) => Ok(cli),
        Err(e) => {
            use clap::error::ErrorKind as K;
            if matches!(
                e.kind(),
                K::DisplayHelp | K::DisplayVersion | K::DisplayHelpOnMissingArgumentOrSubcommand
            ) {
                e.exit();
            }
            let text = e.render().to_string();
            let mut lines = text.lines().filter(|l| !l.trim().is_empty());
            let first = lines
                .next()
                .unwrap_or("error: cannot read the command line");
            let first = first.strip_prefix("error: ").unwrap_or(first);
            // "the following required arguments were not provided:" lists them on the indented
            // lines after it.
            let listed: Vec<&str> = lines
                .take_while(|l| l.starts_with(' '))
                .map(str::trim)
                .collect();
            let first = match first.strip_suffix(':') {
                Some(head) if !listed.is_empty() => format!("{head}: {}", listed.join(", ")),
                _ => first.to_string(),
            };
            // The (sub)command the error is about: the leading words that name one.
            let mut words = Vec::new();
            let mut cmd = Cli::command();
            for a in std::env::args().skip(1) {
                let Some(sub) = cmd.find_subcommand(&a).cloned() else {
                    break;
                };
                words.push(a);
                cmd = sub;
            }
            let at = if words.is_empty() {
                String::new()
            } else {
                format!(" {}", words.join(" "))
            };
            eprintln!("error: {first} (see demcal{at} --help)");
            Err(ExitCode::from(2))
        }
    }
}

fn main() -> ExitCode {
    let cli = match parse_command_line() {
        Ok(cli) => cli,
        Err(code) => return code,
    };
    // The GPU back end, for scene, test and study files and `--backend gpu`.
    dem_gpu::register();
    let result = match cli.command {
        Command::Simulate {
            scene,
            threads,
            out,
            backend,
        } => set_threads(threads)
            .and_then(|_| on_pool(|| simulate(&scene, out.as_deref(), backend.as_deref()))),
        Command::Doe { action } => doe_command(action),
        Command::Surrogate { action } => surrogate_command(action),
        Command::Lab { action } => lab::run(action),
        Command::Curve { action } => curve::run(action),
        Command::Shape { action } => shape::run(action),
        Command::Run {
            study,
            jobs,
            executor,
            restart,
            retry_failed,
            backend,
        } => match run_study(&study, jobs, executor, restart, retry_failed, backend) {
            // The exit status says what kind of end it was (a study file to fix, a store another
            // run holds, Ctrl-C), for scripts that act on it.
            Err(e) => {
                eprintln!("error: {e}");
                return ExitCode::from(e.exit_code());
            }
            Ok(()) => Ok(()),
        },
        Command::RunOne {
            job,
            record,
            threads,
        } => set_threads(threads).and_then(|_| on_pool(|| run_job(&job, record.as_deref()))),
        Command::Init { kind, dir } => init::run(&kind, &dir),
        Command::Status { study } => study::status(&study).map(|s| print!("{s}")),
        Command::Report { study, out } => study::report(&study, out.as_deref()).map(|dir| {
            println!("wrote {}", dir.join("index.html").display());
        }),
        Command::Test {
            test,
            seed,
            json,
            out,
            threads,
            backend,
        } => set_threads(threads)
            .and_then(|_| on_pool(|| run_test(&test, seed, json, out.as_deref(), backend))),
        Command::HeapAngle {
            file,
            planes,
            axis,
            base,
            out,
            json,
        } => heap_angle(&file, planes, &axis, base, out.as_deref(), json),
        Command::Bench {
            name,
            steps,
            threads,
            backend,
            runs,
            jobs,
            cpu_jobs,
            test,
            scale,
            count,
            calls,
        } => set_threads(threads).and_then(|_| match name.as_str() {
            _ if scale != 1 && name != "settle" && name != "stages" => Err(format!(
                "--scale: only bench settle and stages are widened, not {name}"
            )),
            "stages" if backend != "cpu" => {
                Err("--backend: bench stages times the CPU stages".into())
            }
            "stages" => on_pool(|| bench::stages(scale, steps, calls)),
            "batch" if steps.is_some() => {
                Err("--steps: bench batch runs whole tests (use --test for a shorter one)".into())
            }
            "batch" => bench::batch(test.as_deref(), runs, jobs, cpu_jobs, &backend),
            "fill" => on_pool(|| bench::fill(count)),
            "worlds" => bench::worlds(runs, steps, jobs, &backend),
            _ => on_pool(|| bench::steps(&name, steps, &backend, scale)),
        }),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

fn run_study(
    path: &Path,
    jobs: Option<usize>,
    executor: Option<String>,
    restart: bool,
    retry_failed: bool,
    backend: Option<String>,
) -> Result<(), study::RunStudyError> {
    // Where the runs are made says what --jobs means: runs at once here, or what the executor
    // makes of it elsewhere (a Slurm array's throttle). A study that does not load fails in
    // study::run with its own message.
    let here = study::Study::load(path)
        .ok()
        .and_then(|s| study::executor::chosen(&s, executor.as_deref()).ok())
        .is_none_or(|e| e.on_this_machine());
    // On the GPU, jobs are the runs per batch: by default all of a stage's missing runs.
    let gpu =
        here && match &backend {
            Some(b) => b == "gpu",
            None => study::Study::load(path).is_ok_and(|s| s.backend == "gpu"),
        } && dem::sim::resolve_backend("gpu").is_ok_and(|(chosen, _)| chosen == "gpu");
    if let Ok(s) = study::Study::load(path) {
        print_test_warnings(&s);
    }
    let jobs_given = jobs.is_some();
    let jobs = jobs.unwrap_or(if gpu { progress::DEFAULT_PER_BATCH } else { 1 });
    if here {
        check_jobs("--jobs", jobs, gpu)?;
    }
    let interrupted = Arc::new(AtomicBool::new(false));
    let flag = interrupted.clone();
    // The first Ctrl-C stops the running simulations and keeps every finished one; the store is
    // written by one thread in transactions, so it is whole whenever the process ends.
    ctrlc::set_handler(move || {
        if flag.swap(true, Ordering::SeqCst) {
            std::process::exit(130);
        }
        eprintln!("\nstopping: finished runs are kept (Ctrl-C again to quit at once)");
    })
    .map_err(|e| format!("cannot catch Ctrl-C: {e}"))?;
    let opts = study::RunOptions {
        jobs,
        jobs_given,
        restart,
        retry_failed,
        backend,
        executor,
    };
    let result = study::run(path, &opts, interrupted);
    let batches = dem_gpu::batch::batch_stats();
    if batches.batches > 0 {
        eprintln!(
            "GPU batches: {} runs of launches shared by {:.1} simulations on average (largest {})",
            batches.batches,
            batches.worlds as f64 / batches.batches as f64,
            batches.largest
        );
    }
    print!("{}", result?);
    Ok(())
}

/// How a study's test files are written that the user should hear about (a friction alias),
/// once per run rather than once per simulation.
fn print_test_warnings(study: &study::Study) {
    for t in &study.tests {
        if let Ok(parts) = dem::scene::parse::shared_parts(&t.table, &t.source, &t.dir) {
            for w in &parts.warnings {
                eprintln!("warning: {w}");
            }
        }
    }
}

/// `demcal run-one`: runs a job and writes its record (done, or failed with its kind and reason)
/// next to it. Exits 0 whenever a record is written: a failed simulation is a result.
fn run_job(path: &Path, record: Option<&Path>) -> Result<(), String> {
    let job = study::Job::load(path)?;
    let out = record
        .map(Path::to_path_buf)
        .unwrap_or_else(|| path.with_extension("record.json"));
    // The record is written beside its place and renamed onto it: onto a device (/dev/full) or
    // a folder that would replace it or fail only after the run, so they are refused first.
    if std::fs::metadata(&out).is_ok_and(|m| !m.is_file()) {
        return Err(format!(
            "{}: --record: expected a file to write (it exists and is not a plain file)",
            out.display()
        ));
    }
    if let Some(dir) = out.parent().filter(|d| !d.as_os_str().is_empty()) {
        dem::files::check_writable(dir).map_err(|e| format!("--record: {e}"))?;
    }
    let interrupted = Arc::new(AtomicBool::new(false));
    let flag = interrupted.clone();
    ctrlc::set_handler(move || {
        if flag.swap(true, Ordering::SeqCst) {
            std::process::exit(130);
        }
    })
    .map_err(|e| format!("cannot catch Ctrl-C: {e}"))?;
    let name = format!(
        "stage {} {} run {}",
        job.stage + 1,
        job.stage_kind,
        job.index + 1
    );
    let log = std::sync::Mutex::new(LogLine::new());
    let report = |phase: &str, t: f64| {
        let mut log = log.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(elapsed) = log.due() {
            eprintln!("{name}: {phase}: t = {t:.3} s, {elapsed:.0} s elapsed");
        }
    };
    let Some(rec) = job.execute(&interrupted, &report) else {
        return Err(format!("{name}: interrupted; no record written"));
    };
    let json = serde_json::to_string_pretty(&rec).map_err(|e| e.to_string())?;
    // A temporary name of this process's own, made new (never an existing file or pipe), and
    // removed if the write fails.
    let mut tmp = out.clone().into_os_string();
    tmp.push(format!(".{}.part", std::process::id()));
    let tmp = PathBuf::from(tmp);
    let cannot = |e: std::io::Error| format!("{}: cannot write the record: {e}", out.display());
    let mut file = std::fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(&tmp)
        .map_err(cannot)?;
    let written = {
        use std::io::Write;
        file.write_all(json.as_bytes())
            .and_then(|_| file.sync_all())
            .and_then(|_| std::fs::rename(&tmp, &out))
    };
    if let Err(e) = written {
        let _ = std::fs::remove_file(&tmp);
        return Err(cannot(e));
    }
    match (&rec.response, &rec.error, rec.error_kind) {
        (Some(y), _, _) => println!("{name}: {} = {y} (record {})", job.response, out.display()),
        (None, e, kind) => println!(
            "{name}: failed ({}): {} (record {})",
            kind.map(|k| k.as_str()).unwrap_or("unknown"),
            e.clone().unwrap_or_default(),
            out.display()
        ),
    }
    Ok(())
}

pub(crate) fn progress_bar(len: u64) -> ProgressBar {
    let bar = ProgressBar::new(len);
    bar.set_style(
        ProgressStyle::with_template("{bar:40} {pos}/{len} steps  {msg}  eta {eta}")
            .expect("valid template"),
    );
    bar
}

fn simulate(path: &Path, out: Option<&Path>, backend: Option<&str>) -> Result<(), String> {
    let scene = Scene::load_with_backend(path, backend).map_err(|e| e.to_string())?;
    let Scene {
        mut simulation,
        steps,
        output,
        rayleigh_time_step,
        collision_time,
        warnings,
        notes,
    } = scene;
    let dt = simulation.params.time_step;
    eprintln!(
        "{}: {} particles, {} geometries, dt = {:.3e} s ({:.1} % of the Rayleigh step {:.3e} s), {} collision time {:.3e} s, {} steps, on the {}",
        path.display(),
        simulation.particles.len(),
        simulation.geometries.len(),
        dt,
        100.0 * dt / rayleigh_time_step,
        rayleigh_time_step,
        simulation.params.contact_model.name(),
        collision_time,
        steps,
        simulation.backend_name().to_uppercase()
    );
    for n in &notes {
        eprintln!("{n}");
    }
    if simulation.factories().next().is_some() {
        eprintln!(
            "{} factories create particles during the run",
            simulation.factories().count()
        );
    }
    for w in &warnings {
        eprintln!("warning: {w}");
    }
    let dir = out
        .map(Path::to_path_buf)
        .unwrap_or(output.directory.clone());
    std::fs::create_dir_all(&dir)
        .map_err(|e| format!("{}: cannot create output directory: {e}", dir.display()))?;
    let io = |e: std::io::Error| format!("{}: {e}", dir.display());
    let mut snapshots = Snapshots::new(&dir, output.snapshots);
    let mut snapshot = |sim: &mut dem::Simulation| snapshots.write(sim).map_err(io);
    snapshot(&mut simulation)?;
    let mut loads =
        LoadWriter::create(&dir.join("geometry_forces.csv"), &simulation.geometries).map_err(io)?;
    loads
        .record(simulation.time, &simulation.geometries)
        .map_err(io)?;
    // Schedules by simulated time, so intervals that are not whole multiples of dt still land.
    let mut next_load = output.force_interval;
    let mut next_snapshot = output.snapshot_interval.unwrap_or(f64::INFINITY);
    let mut last_snapshot_step = 0;
    let bar = progress_bar(steps);
    let mut log = LogLine::new();
    let start = Instant::now();
    let mut failure = None;
    while simulation.steps < steps {
        if let Err(e) = simulation.step() {
            failure = Some(e.to_string());
            break;
        }
        let (s, t) = (simulation.steps, simulation.time);
        if t >= next_load - 0.5 * dt {
            loads.record(t, &simulation.geometries).map_err(io)?;
            next_load += output.force_interval;
        }
        if t >= next_snapshot - 0.5 * dt {
            snapshot(&mut simulation)?;
            last_snapshot_step = s;
            next_snapshot += output.snapshot_interval.unwrap_or(f64::INFINITY);
        }
        if s % 200 == 0 {
            bar.set_position(s);
            bar.set_message(format!("t = {t:.4} s"));
            if let Some(elapsed) = log.due() {
                eprintln!(
                    "{}: {}",
                    path.display(),
                    LogLine::steps(s, steps, &format!(", t = {t:.4} s"), elapsed)
                );
            }
        }
    }
    bar.finish_and_clear();
    loads.finish().map_err(io)?;
    // The breakage log and the bond counts are written even when the run failed: they say how.
    let bond_summary = match simulation.bonds() {
        Some(bonds) => {
            dem::bond::output::write_breakage_csv(&dir.join("bond_breakage.csv"), bonds)
                .map_err(io)?;
            dem::bond::output::write_bond_counts_csv(&dir.join("bond_counts.csv"), bonds)
                .map_err(io)?;
            for w in bonds.warnings().iter().filter(|w| !warnings.contains(w)) {
                eprintln!("warning: {w}");
            }
            format!(
                " bonds={} bonds_intact={} bonds_broken={}",
                bonds.len(),
                bonds.intact_count(),
                bonds.broken_count()
            )
        }
        None => String::new(),
    };
    if let Some(e) = failure {
        return Err(format!("{}: {e}", path.display()));
    }
    if last_snapshot_step != simulation.steps {
        snapshot(&mut simulation)?;
    }
    let wall = start.elapsed().as_secs_f64();
    eprintln!("stages: {}", simulation.timers.breakdown());
    println!(
        "simulate: particles={} steps={} simulated_s={:.4} wall_s={:.1} particle_steps_per_s={:.2e} kinetic_energy_j={:.3e}{bond_summary} snapshots={} output={}",
        simulation.particles.len(),
        simulation.steps,
        simulation.time,
        wall,
        simulation.particles.len() as f64 * simulation.steps as f64 / wall.max(1e-9),
        simulation.kinetic_energy(),
        snapshots.count(),
        dir.display()
    );
    Ok(())
}
