//! Benchmarks that compare the engine with its peers (shared/bench/README.md).

use crate::scene::Scene;
use std::path::Path;
use std::time::Instant;

/// The settle scene, built into the binary so `demcal bench settle` runs from anywhere.
pub const SETTLE_SCENE: &str = include_str!("../../../examples/scenes/settle.toml");

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
}

impl BenchResult {
    pub fn particle_steps_per_s(&self) -> f64 {
        self.particles as f64 * self.steps as f64 / self.wall_s
    }

    /// The line `demcal bench settle` ends with.
    pub fn line(&self, name: &str) -> String {
        format!(
            "{name}: particles={} steps={} wall_s={:.1} particle_steps_per_s={:.1e} bed_height_m={:.4} kinetic_energy_j={:.1e}",
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
    tops.sort_unstable_by(|a, b| b.partial_cmp(a).unwrap());
    let k = (tops.len() / 100).max(1);
    tops[..k].iter().sum::<f64>() / k as f64
}

/// Runs the settle scene for `steps` steps (default: the scene's 50 000), calling `progress`
/// with the number of steps done from time to time.
pub fn settle(steps: Option<u64>, mut progress: impl FnMut(u64)) -> Result<BenchResult, String> {
    let scene = Scene::from_toml(SETTLE_SCENE, "examples/scenes/settle.toml", Path::new("."))
        .map_err(|e| e.to_string())?;
    let steps = steps.unwrap_or(scene.steps);
    let mut sim = scene.simulation;
    let start = Instant::now();
    let chunk = 1000;
    let mut done = 0;
    while done < steps {
        let n = chunk.min(steps - done);
        sim.run(n).map_err(|e| e.to_string())?;
        done += n;
        progress(done);
    }
    let wall_s = start.elapsed().as_secs_f64();
    Ok(BenchResult {
        particles: sim.particles.len(),
        steps,
        wall_s,
        bed_height_m: bed_height(&sim.particles),
        kinetic_energy_j: sim.kinetic_energy(),
        stages: sim.timers.breakdown(),
        neighbour_rebuilds: sim.neighbour_rebuilds(),
    })
}
