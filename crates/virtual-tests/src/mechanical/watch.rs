//! What a mechanical run watches at every curve point besides the force: the energy guard, the
//! quasi-static measures (kinetic energy over work, net force on the specimen), the overlaps, the
//! bonds' stresses at the peak, the side views' stages and the curve written as it is made.

use std::fs::File;
use std::io::Write;
use std::path::Path;

use dem::Simulation;
use glam::DVec3;

use super::diagnostics::{BondStress, Overlaps, Stage};
use super::{tool_force, LoadingSettings, Tool, PROGRESS_FILE};
use crate::virtual_test::TestError;

/// Curve points either side over which the net force is averaged (11 of the default 500: about
/// 2 % of the travel).
const IMBALANCE_WINDOW: usize = 5;

/// Kinetic energy of the specimen's free spheres (grips excluded: their mass is infinite).
pub(super) fn specimen_kinetic_energy(sim: &Simulation) -> f64 {
    let p = &sim.particles;
    (0..p.len())
        .filter(|&k| p.inv_mass[k] > 0.0)
        .map(|k| {
            0.5 * p.mass[k] * p.velocity[k].length_squared()
                + 0.5 * p.angular_velocity[k].length_squared() / p.inv_inertia[k]
        })
        .sum()
}

/// Potential energy of the free spheres in gravity (J; the real weight, whatever the density
/// scaling).
fn potential_energy(sim: &Simulation) -> f64 {
    let p = &sim.particles;
    let g = sim.params.gravity;
    (0..p.len())
        .filter(|&k| p.inv_mass[k] > 0.0)
        .map(|k| -p.mass[k] * g.dot(p.position[k]))
        .sum()
}

/// The net force on the specimen along the tool's direction: the tool's, the fixture's (every
/// other geometry, a fixed grip) and the weight together, which accelerates it. Loading is
/// quasi-static while it stays a small share of the tool's force.
fn unbalanced_force(sim: &Simulation, tool: &Tool) -> f64 {
    let p = &sim.particles;
    let g = sim.params.gravity;
    let dir = tool.direction().normalize();
    let (own, fixed): (Option<&str>, &[u32]) = match tool {
        Tool::Geometry { name, .. } => (Some(name.as_str()), &[]),
        Tool::Grip { fixed, .. } => (None, fixed.as_slice()),
    };
    let geometries: DVec3 = sim
        .geometries
        .iter()
        .filter(|x| Some(x.name.as_str()) != own)
        .map(|x| -x.load.force)
        .sum();
    let mut grip = DVec3::ZERO;
    let mut weight = DVec3::ZERO;
    for k in 0..p.len() {
        if p.inv_mass[k] > 0.0 {
            weight += g * p.mass[k];
        } else if fixed.binary_search(&p.id[k]).is_ok() {
            grip -= p.force[k] - g * p.mass[k];
        }
    }
    tool_force(sim, tool) + (geometries + grip + weight).dot(dir)
}

/// The quasi-static measures of a finished curve.
pub(super) struct Judged {
    /// Largest kinetic energy over work up to the peak, and over the whole run.
    pub ratio: f64,
    pub max_ratio: f64,
    /// Largest net force (averaged over the window) over the peak force, up to the peak.
    pub imbalance: f64,
}

/// Everything watched over one run.
pub(super) struct Watch {
    test: String,
    file_name: String,
    kinetic0: f64,
    potential0: f64,
    /// The energy below which the guard does not judge: the specimen's weight times its size
    /// (settling on the supports moves that much at most).
    slack: f64,
    /// (kinetic energy, work so far) at every curve point.
    energies: Vec<(f64, f64)>,
    /// The net force at every curve point.
    unbalanced: Vec<f64>,
    pub overlaps: Overlaps,
    pub at_peak: Option<BondStress>,
    stages: Vec<Stage>,
    peak_stage: Option<Stage>,
    views: usize,
    next_view: usize,
    max_displacement: f64,
    /// The curve as it is made, one flushed row per point: a run stopped by kill -9 or a time
    /// limit leaves what it measured so far.
    progress: Option<File>,
}

impl Watch {
    /// Starts watching `sim` before the loading (the tool's force `f0` now), writing the curve
    /// as it is made into `out` when given.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        sim: &mut Simulation,
        tool: &Tool,
        loading: &LoadingSettings,
        test: &str,
        file_name: &str,
        size: f64,
        f0: f64,
        out: Option<&Path>,
    ) -> Result<Watch, TestError> {
        let weight: f64 = (0..sim.particles.len())
            .filter(|&k| sim.particles.inv_mass[k] > 0.0)
            .map(|k| sim.particles.mass[k] * sim.params.gravity.length())
            .sum();
        let progress = match out {
            Some(dir) => {
                let io = |e: std::io::Error| TestError::Output(format!("{}: {e}", dir.display()));
                std::fs::create_dir_all(dir).map_err(io)?;
                let mut f = File::create(dir.join(PROGRESS_FILE)).map_err(io)?;
                writeln!(f, "travel_m,force_n,kinetic_energy_j,work_j,bonds_broken").map_err(io)?;
                Some(f)
            }
            None => None,
        };
        let mut overlaps = Overlaps::default();
        overlaps.observe(sim, 0.0);
        let views = loading.side_views;
        let stages = if views > 0 {
            vec![Stage::take(sim, format!("{test}: start"), 0.0, f0)]
        } else {
            Vec::new()
        };
        Ok(Watch {
            test: test.to_string(),
            file_name: file_name.to_string(),
            kinetic0: specimen_kinetic_energy(sim),
            potential0: potential_energy(sim),
            slack: weight * size,
            energies: vec![(0.0, 0.0)],
            unbalanced: vec![unbalanced_force(sim, tool)],
            overlaps,
            at_peak: None,
            stages,
            peak_stage: None,
            views,
            next_view: 1,
            max_displacement: loading.max_displacement,
            progress,
        })
    }

    /// One curve point: travel `d`, force `f` (a new peak when `new_peak`), the tool's work so
    /// far. Stops the run as diverged when its kinetic energy exceeds twice the work done on it
    /// (tool and gravity) plus the slack: energy is being created.
    pub fn point(
        &mut self,
        sim: &mut Simulation,
        tool: &Tool,
        d: f64,
        f: f64,
        work: f64,
        new_peak: bool,
    ) -> Result<(), TestError> {
        let kinetic = specimen_kinetic_energy(sim);
        self.energies.push((kinetic, work));
        self.unbalanced.push(unbalanced_force(sim, tool));
        let gravity_work = self.potential0 - potential_energy(sim);
        if kinetic - self.kinetic0 > 2.0 * (work + gravity_work).max(0.0) + self.slack {
            let test = &self.test;
            // The bonds' own time-step check, when it warned, says by how much the step is too
            // long: the likeliest cause, so it goes with the error rather than being lost with it.
            let cause: String = sim
                .bonds()
                .map(|b| b.warnings().iter().map(|w| format!("; {w}")).collect())
                .unwrap_or_default();
            return Err(TestError::Diverged(format!(
                "{}: {test}: diverged at {:.3} mm of travel: the specimen's kinetic energy ({kinetic:.3e} J) exceeds the work done on it ({work:.3e} J by the tool, {gravity_work:.3e} J by gravity); energy is being created, so the time step is too long for the bonds or contacts (lower {test}.time_step_percent){cause}",
                self.file_name,
                1e3 * d
            )));
        }
        self.overlaps.observe(sim, d);
        if let Some(file) = self.progress.as_mut() {
            let broken = sim.bonds().map_or(0, |b| b.broken_count());
            // Best effort: the curve itself is written at the end whatever happens here.
            let _ = writeln!(file, "{d:e},{f:e},{kinetic:e},{work:e},{broken}")
                .and_then(|_| file.flush());
        }
        let test = &self.test;
        if new_peak {
            self.at_peak = sim.bonds().map(BondStress::of);
            if self.views > 0 {
                self.peak_stage = Some(Stage::take(sim, format!("{test}: peak force"), d, f));
            }
        }
        let (views, next) = (self.views, self.next_view);
        if views > 0 && d >= next as f64 * self.max_displacement / views as f64 - 1e-12 {
            let label = format!("{test}: stage {next} of {views}");
            self.stages.push(Stage::take(sim, label, d, f));
            self.next_view += 1;
        }
        Ok(())
    }

    /// The quasi-static measures of the curve kept from point `first` on (`displacement` from
    /// there), peak at `k_peak`: judged from a tenth of the way to the peak (the blow of the first
    /// touch is not loading inertia; a tenth of the whole travel would leave nothing to judge
    /// when the specimen fails early) up to the peak (recoil after failure is not either). The
    /// net force is averaged over a window of points (the momentum it changes over that travel):
    /// the ringing after a snap-through or a breakage averages out, a sustained acceleration
    /// does not.
    pub fn judge(&self, displacement: &[f64], first: usize, k_peak: usize, peak: f64) -> Judged {
        let from = 0.1 * displacement[k_peak];
        let energies = &self.energies;
        let ratio_over = |last: usize| {
            (0..=last)
                .filter(|&k| displacement[k] > from)
                .map(|k| energies[first + k])
                .filter(|&(_, work)| work > 0.0)
                .map(|(kinetic, work)| kinetic / work)
                .fold(0.0, f64::max)
        };
        let window = |k: usize| {
            let (a, b) = (
                k.saturating_sub(IMBALANCE_WINDOW),
                (k + IMBALANCE_WINDOW).min(k_peak),
            );
            self.unbalanced[first + a..=first + b].iter().sum::<f64>() / (b - a + 1) as f64
        };
        let imbalance = if peak > 0.0 {
            (0..=k_peak)
                .filter(|&k| displacement[k] > from)
                .map(|k| window(k).abs() / peak)
                .fold(0.0, f64::max)
        } else {
            0.0
        };
        Judged {
            ratio: ratio_over(k_peak),
            max_ratio: ratio_over(displacement.len() - 1),
            imbalance,
        }
    }

    /// The side views' stages: the start, each stage, the peak last.
    pub fn into_stages(self) -> Vec<Stage> {
        self.stages.into_iter().chain(self.peak_stage).collect()
    }
}
