//! Benchmarks that compare the engine with its peers (docs/benchmarks.md).

use crate::scene::Scene;
use std::path::Path;
use std::time::Instant;

/// The settle scene, built into the binary so `demcal bench settle` runs from anywhere. The crate
/// keeps its own copy (a packaged crate has no `examples/`); `examples/scenes/settle.toml` is the
/// same file, which a test checks.
pub const SETTLE_SCENE: &str = include_str!("../data/settle.toml");

/// The bonded benchmark: the seed-000 stalk specimen crushed between plates
/// (`examples/scenes/bonded.toml`, the same file).
pub const BONDED_SCENE: &str = include_str!("../data/bonded.toml");

/// Result of one benchmark run.
#[derive(Clone, Debug)]
pub struct BenchResult {
    pub particles: usize,
    pub steps: u64,
    pub wall_s: f64,
    pub bed_height_m: f64,
    pub kinetic_energy_j: f64,
    pub stages: String,
    pub neighbour_rebuilds: u64,
    /// Pair stages over every listed pair, and over the near pairs only.
    pub pair_passes: (u64, u64),
    /// Bonds formed and broken (0 without bonds).
    pub bonds: usize,
    pub bonds_broken: usize,
    /// Share of the step time spent on bond forces on the host; None where steps ran as device
    /// segments, whose bonds run on the device with everything else.
    pub bond_share: Option<f64>,
    /// The back end that ran the stages, and what it said about the scene (what it left to the
    /// CPU, or why the CPU ran instead).
    pub backend: &'static str,
    pub remarks: Vec<String>,
}

impl BenchResult {
    pub fn particle_steps_per_s(&self) -> f64 {
        self.particles as f64 * self.steps as f64 / self.wall_s
    }

    /// The line `demcal bench NAME` ends with.
    pub fn line(&self, name: &str) -> String {
        let bonds = if self.bonds > 0 {
            let share = self
                .bond_share
                .map_or("device".to_string(), |s| format!("{:.1}%", 100.0 * s));
            format!(
                " bonds={} bonds_broken={} bond_share={share}",
                self.bonds, self.bonds_broken,
            )
        } else {
            String::new()
        };
        format!(
            "{name}: backend={} particles={} steps={} wall_s={:.1} particle_steps_per_s={:.1e}{bonds} bed_height_m={:.4} kinetic_energy_j={:.1e}",
            self.backend,
            self.particles,
            self.steps,
            self.wall_s,
            self.particle_steps_per_s(),
            self.bed_height_m,
            self.kinetic_energy_j
        )
    }
}

/// Mean height of the top 1 % of particle tops (z + r): the bed height.
pub fn bed_height(particles: &crate::Particles) -> f64 {
    let mut tops: Vec<f64> = (0..particles.len())
        .map(|k| particles.position[k].z + particles.radius[k])
        .collect();
    // A diverged state has no bed height (NaN of either sign would sort to one end or the other).
    if tops.iter().any(|t| t.is_nan()) {
        return f64::NAN;
    }
    tops.sort_unstable_by(|a, b| b.total_cmp(a));
    let k = (tops.len() / 100).max(1);
    tops[..k].iter().sum::<f64>() / k as f64
}

/// Runs the settle scene for `steps` steps (default: the scene's 50 000), calling `progress`
/// with the number of steps done from time to time.
pub fn settle(
    steps: Option<u64>,
    backend: &str,
    progress: impl FnMut(u64),
) -> Result<BenchResult, String> {
    run(
        SETTLE_SCENE,
        "examples/scenes/settle.toml",
        steps,
        backend,
        progress,
    )
}

/// Largest `--scale` of the settle scene: 16 times wider in x and y is 5.8 million spheres,
/// a few GiB of state.
pub const MAX_SETTLE_SCALE: u32 = 16;

/// The settle scene widened `scale` times in x and y (the lattice, the box and the domain), so
/// it holds about `scale`² times the spheres (the lattice keeps its spacing): 21 160 at 1,
/// 88 360 at 2, 1 444 000 at 8 (the scaled scene of the
/// GPU benchmarks and the engine's 16-core figures).
pub fn settle_scene(scale: u32) -> Result<String, String> {
    if !(1..=MAX_SETTLE_SCALE).contains(&scale) {
        return Err(format!(
            "--scale: expected 1 to {MAX_SETTLE_SCALE}, got {scale}"
        ));
    }
    if scale == 1 {
        return Ok(SETTLE_SCENE.to_string());
    }
    Ok(settle_scene_mm(100 * scale))
}

/// The settle scene with a box `mm` millimetres wide in x and y (100: the settle scene; the
/// lattice keeps its spacing of 4.2 mm, so the count goes with the width squared).
fn settle_scene_mm(mm: u32) -> String {
    let widened = [
        (BOX_MAX, format!("max = [{mm}e-3, {mm}e-3, 0.4]")),
        (LATTICE_MAX, format!("max = [{0}e-3, {0}e-3, 0.17]", mm - 2)),
        (DOMAIN_MAX, format!("max = [{0}e-3, {0}e-3, 0.41]", mm + 10)),
    ];
    widened
        .iter()
        .fold(SETTLE_SCENE.to_string(), |text, (from, to)| {
            text.replace(from, to)
        })
}

/// Width of a world of `demcal bench worlds`: 46 mm holds 10 x 10 x 40 = 4 000 lattice spheres,
/// about the seed-000 shear specimen's 4 300.
pub const WORLD_WIDTH_MM: u32 = 46;

/// What `demcal bench worlds` measured: many small simulations at once.
#[derive(Clone, Debug)]
pub struct WorldsResult {
    pub worlds: usize,
    pub particles_each: usize,
    pub steps: u64,
    pub jobs: usize,
    pub wall_s: f64,
    pub backend: &'static str,
    /// Mean bed height over the worlds (each world is the same scene, so they agree).
    pub bed_height_m: f64,
}

impl WorldsResult {
    /// Particle-steps per second over all the worlds together.
    pub fn particle_steps_per_s(&self) -> f64 {
        (self.worlds * self.particles_each) as f64 * self.steps as f64 / self.wall_s
    }

    pub fn line(&self) -> String {
        format!(
            "worlds: backend={} worlds={} particles_each={} steps={} jobs={} wall_s={:.1} particle_steps_per_s={:.1e} bed_height_m={:.4}",
            self.backend,
            self.worlds,
            self.particles_each,
            self.steps,
            self.jobs,
            self.wall_s,
            self.particle_steps_per_s(),
            self.bed_height_m
        )
    }
}

/// Runs `worlds` seed-000-sized settle scenes ([`WORLD_WIDTH_MM`]) for `steps` steps each,
/// `jobs` at a time on `backend`, as a study stage runs its jobs: on a device the simulations that
/// run at once form one batch group and share launches (`crate::sim::in_batch_group`); on the CPU
/// each job gets its share of the cores. `finished` hears each world that ends.
pub fn worlds(
    worlds: usize,
    steps: u64,
    jobs: usize,
    backend: &str,
    finished: &(dyn Fn() + Sync),
) -> Result<WorldsResult, String> {
    if worlds == 0 || worlds > 10_000 {
        return Err(format!("--runs {worlds}: expected 1 to 10000 worlds"));
    }
    if steps == 0 || steps > MAX_BENCH_STEPS {
        return Err(format!(
            "--steps: expected 1 to {MAX_BENCH_STEPS}, got {steps}"
        ));
    }
    let jobs = jobs.clamp(1, worlds);
    let text = settle_scene_mm(WORLD_WIDTH_MM);
    // Built once up front: a scene that fails fails before anything is timed.
    let first = Scene::from_toml(&text, "a world of bench worlds", Path::new("."))
        .map_err(|e| e.to_string())?;
    // The threads the caller set (`--threads`), shared between the jobs.
    let cores = rayon::current_num_threads();
    let pools = (0..jobs)
        .map(|_| {
            rayon::ThreadPoolBuilder::new()
                .num_threads((cores / jobs).max(1))
                .build()
        })
        .collect::<Result<Vec<_>, _>>()
        .map_err(|e| format!("cannot start {jobs} job(s): {e}"))?;
    let left = std::sync::atomic::AtomicUsize::new(worlds);
    let heights = std::sync::Mutex::new(Vec::new());
    let chosen = std::sync::Mutex::new("cpu");
    let group = crate::sim::new_batch_group();
    let start = Instant::now();
    let outcome: Result<(), String> = std::thread::scope(|scope| {
        let handles: Vec<_> = pools
            .iter()
            .map(|pool| {
                let (text, left, heights, chosen) = (&text, &left, &heights, &chosen);
                scope.spawn(move || -> Result<(), String> {
                    use std::sync::atomic::Ordering;
                    while left
                        .fetch_update(Ordering::Relaxed, Ordering::Relaxed, |n| n.checked_sub(1))
                        .is_ok()
                    {
                        let height = pool.install(|| {
                            crate::sim::in_batch_group(group, || {
                                let scene = Scene::from_toml(text, "a world", Path::new("."))
                                    .map_err(|e| e.to_string())?;
                                let mut sim = scene.simulation;
                                sim.choose_backend(backend);
                                *chosen.lock().unwrap_or_else(|e| e.into_inner()) =
                                    sim.backend_name();
                                sim.run(steps).map_err(|e| e.to_string())?;
                                Ok::<_, String>(bed_height(&sim.particles))
                            })
                        })?;
                        heights
                            .lock()
                            .unwrap_or_else(|e| e.into_inner())
                            .push(height);
                        finished();
                    }
                    Ok(())
                })
            })
            .collect();
        handles
            .into_iter()
            .try_for_each(|h| h.join().unwrap_or_else(|_| Err("a world panicked".into())))
    });
    outcome?;
    let wall_s = start.elapsed().as_secs_f64();
    let heights = heights.into_inner().unwrap_or_else(|e| e.into_inner());
    Ok(WorldsResult {
        worlds,
        particles_each: first.simulation.particles.len(),
        steps,
        jobs,
        wall_s,
        backend: chosen.into_inner().unwrap_or_else(|e| e.into_inner()),
        bed_height_m: heights.iter().sum::<f64>() / heights.len().max(1) as f64,
    })
}

/// The settle scene widened 8 times in x and y: 1 444 000 spheres.
pub fn settle_wide_scene() -> String {
    settle_scene(8).expect("8 is a valid scale")
}

/// What widening the settle scene changes: the box, the lattice region and the domain.
const BOX_MAX: &str = "max = [0.1, 0.1, 0.4]";
const LATTICE_MAX: &str = "max = [0.098, 0.098, 0.17]";
const DOMAIN_MAX: &str = "max = [0.11, 0.11, 0.41]";

/// Steps of a widened settle scene when not asked (a tenth of the settle scene's).
pub const SETTLE_WIDE_STEPS: u64 = 5_000;

/// Runs the settle scene widened `scale` times for `steps` steps (default: 50 000 at scale 1,
/// else [`SETTLE_WIDE_STEPS`]).
pub fn settle_scaled(
    scale: u32,
    steps: Option<u64>,
    backend: &str,
    progress: impl FnMut(u64),
) -> Result<BenchResult, String> {
    if scale == 1 {
        return settle(steps, backend, progress);
    }
    run(
        &settle_scene(scale)?,
        "the widened settle scene",
        Some(steps.unwrap_or(SETTLE_WIDE_STEPS)),
        backend,
        progress,
    )
}

/// Runs the settle scene widened 8 times (`settle_scaled(8, ..)`).
pub fn settle_wide(
    steps: Option<u64>,
    backend: &str,
    progress: impl FnMut(u64),
) -> Result<BenchResult, String> {
    settle_scaled(8, steps, backend, progress)
}

/// Runs the bonded scene for `steps` steps (default: the scene's 20 000).
pub fn bonded(
    steps: Option<u64>,
    backend: &str,
    progress: impl FnMut(u64),
) -> Result<BenchResult, String> {
    run(
        BONDED_SCENE,
        "examples/scenes/bonded.toml",
        steps,
        backend,
        progress,
    )
}

/// The most steps a benchmark may be asked for (a day of the settle scene on one core).
pub const MAX_BENCH_STEPS: u64 = 100_000_000;

fn run(
    text: &str,
    name: &str,
    steps: Option<u64>,
    backend: &str,
    mut progress: impl FnMut(u64),
) -> Result<BenchResult, String> {
    if let Some(n) = steps {
        if n == 0 || n > MAX_BENCH_STEPS {
            return Err(format!("--steps: expected 1 to {MAX_BENCH_STEPS}, got {n}"));
        }
    }
    let scene = Scene::from_toml(text, name, Path::new(".")).map_err(|e| e.to_string())?;
    let steps = steps.unwrap_or(scene.steps);
    let mut sim = scene.simulation;
    let remarks = sim.choose_backend(backend);
    let start = Instant::now();
    // A back end that runs whole segments on its device reads the state back after each chunk.
    let chunk = if sim.backend_name() == "cpu" {
        1000
    } else {
        5000
    };
    let mut done = 0;
    while done < steps {
        let n = chunk.min(steps - done);
        sim.run(n).map_err(|e| e.to_string())?;
        done += n;
        progress(done);
    }
    let wall_s = start.elapsed().as_secs_f64();
    let (bonds, bonds_broken) = sim
        .bonds()
        .map(|b| (b.len(), b.broken_count()))
        .unwrap_or((0, 0));
    Ok(BenchResult {
        particles: sim.particles.len(),
        steps,
        wall_s,
        bed_height_m: bed_height(&sim.particles),
        kinetic_energy_j: sim.kinetic_energy(),
        stages: sim.timers.breakdown(),
        neighbour_rebuilds: sim.neighbour_rebuilds(),
        pair_passes: sim.pair_passes(),
        bonds,
        bonds_broken,
        bond_share: sim.timers.device_segments.is_zero().then(|| {
            sim.timers.extension_forces.as_secs_f64() / sim.timers.total().as_secs_f64().max(1e-12)
        }),
        backend: sim.backend_name(),
        remarks,
    })
}

/// Steps the settle scene runs before its stages are timed (`demcal bench stages`): by then the
/// spheres lie in a bed, with the contacts of a packed state.
pub const STAGES_SETTLE_STEPS: u64 = 20_000;

/// The stage micro-benchmarks (`demcal bench stages`): the settle scene widened `scale` times
/// runs `steps` steps on the CPU (default [`STAGES_SETTLE_STEPS`], or [`SETTLE_WIDE_STEPS`]
/// widened), then each stage runs `calls` times on that state
/// ([`crate::sim::Simulation::stage_costs`]). Returns the particle count and the costs.
pub fn stage_costs(
    scale: u32,
    steps: Option<u64>,
    calls: usize,
    mut progress: impl FnMut(u64),
) -> Result<(usize, Vec<crate::sim::StageCost>), String> {
    if !(1..=10_000).contains(&calls) {
        return Err(format!("--calls: expected 1 to 10000, got {calls}"));
    }
    let default = if scale == 1 {
        STAGES_SETTLE_STEPS
    } else {
        SETTLE_WIDE_STEPS
    };
    let steps = steps.unwrap_or(default);
    if steps > MAX_BENCH_STEPS {
        return Err(format!(
            "--steps: expected 0 to {MAX_BENCH_STEPS}, got {steps}"
        ));
    }
    let scene = Scene::from_toml(&settle_scene(scale)?, "the settle scene", Path::new("."))
        .map_err(|e| e.to_string())?;
    let mut sim = scene.simulation;
    let mut done = 0;
    while done < steps {
        let n = 1000.min(steps - done);
        sim.run(n).map_err(|e| e.to_string())?;
        done += n;
        progress(done);
    }
    let costs = sim.stage_costs(calls)?;
    Ok((sim.particles.len(), costs))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A world of `bench worlds` is seed-000-sized (10 x 10 x 40 lattice spheres), every world
    /// runs its steps, and identical worlds settle identically (the batch's runs do not mix).
    #[test]
    fn worlds_are_seed_000_sized_and_run_alike() {
        let heard = std::sync::atomic::AtomicUsize::new(0);
        let r = worlds(3, 200, 2, "cpu", &|| {
            heard.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        })
        .unwrap();
        assert_eq!(r.particles_each, 4000);
        assert_eq!((r.worlds, r.steps, r.backend), (3, 200, "cpu"));
        assert_eq!(heard.into_inner(), 3);
        let one = worlds(1, 200, 1, "cpu", &|| {}).unwrap();
        assert_eq!(r.bed_height_m, one.bed_height_m);
        assert!(
            r.bed_height_m > 0.16 && r.bed_height_m < 0.18,
            "{}",
            r.bed_height_m
        );
        assert!(worlds(0, 10, 1, "cpu", &|| {}).is_err());
    }
    use glam::DVec3;

    /// The widened scene changes the box, the lattice region and the domain, each once, and
    /// holds about scale² times the spheres.
    #[test]
    fn the_wide_settle_scene_is_the_settle_scene_widened() {
        for from in [BOX_MAX, LATTICE_MAX, DOMAIN_MAX] {
            assert_eq!(SETTLE_SCENE.matches(from).count(), 1, "{from}");
        }
        assert_eq!(settle_scene(1).unwrap(), SETTLE_SCENE);
        let wide = settle_wide_scene();
        for to in [
            "max = [800e-3, 800e-3, 0.4]",
            "max = [798e-3, 798e-3, 0.17]",
            "max = [810e-3, 810e-3, 0.41]",
        ] {
            assert!(wide.contains(to), "{to}");
        }
        let count = |text: &str| {
            Scene::from_toml(text, "settle", Path::new("."))
                .unwrap()
                .simulation
                .particles
                .len()
        };
        assert_eq!(count(SETTLE_SCENE), 21_160);
        // The lattice keeps its spacing, so a side holds 94 spheres, not 2 x 46.
        assert_eq!(count(&settle_scene(2).unwrap()), 88_360);
        assert!(settle_scene(0).is_err() && settle_scene(MAX_SETTLE_SCALE + 1).is_err());
    }

    /// The bed height of a state with a NaN position (a diverged run) is NaN, not a panic.
    #[test]
    fn bed_height_of_a_diverged_state_is_nan() {
        let mut p = crate::Particles::default();
        for z in [0.01, f64::NAN, 0.03] {
            p.push(DVec3::new(0.0, 0.0, z), DVec3::ZERO, 0.002, 2500.0, 0);
        }
        assert!(bed_height(&p).is_nan());
        // Finite states: the mean top of the highest 1 % (here the one highest sphere).
        p.position[1].z = 0.02;
        assert!((bed_height(&p) - 0.032).abs() < 1e-15);
    }

    /// The scenes built into the crate are the examples users run (and LIGGGHTS compares
    /// against).
    #[test]
    fn the_built_in_scenes_are_the_examples() {
        for (file, built_in) in [("settle.toml", SETTLE_SCENE), ("bonded.toml", BONDED_SCENE)] {
            let example = Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("../../examples/scenes")
                .join(file);
            // The crate alone (packaged) has no examples folder to compare with.
            if let Ok(text) = std::fs::read_to_string(&example) {
                assert_eq!(
                    text,
                    built_in,
                    "{} and the built-in copy differ",
                    example.display()
                );
            }
        }
    }
}
