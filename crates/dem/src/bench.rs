//! Benchmarks that compare the engine with its peers (shared/bench/README.md).

use crate::scene::Scene;
use std::path::Path;
use std::time::Instant;

/// The settle scene, built into the binary so `demcal bench settle` runs from anywhere. The crate
/// keeps its own copy (a packaged crate has no `examples/`); `examples/scenes/settle.toml` is the
/// same file, which a test checks.
pub const SETTLE_SCENE: &str = include_str!("../data/settle.toml");

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

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

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

    /// The scene built into the crate is the example users run and LIGGGHTS compares against.
    #[test]
    fn the_built_in_scene_is_the_example() {
        let example =
            Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/scenes/settle.toml");
        // The crate alone (packaged) has no examples folder to compare with.
        if let Ok(text) = std::fs::read_to_string(&example) {
            assert_eq!(
                text,
                SETTLE_SCENE,
                "{} and the built-in copy differ",
                example.display()
            );
        }
    }
}
