//! The parameters of a simulation (one struct, with `Default` the single home of the defaults),
//! why a run stops, and the per-stage timers.

use crate::contact::{ContactModel, RollingModel};
use glam::DVec3;
use std::time::Duration;

/// Parameters of a simulation. Scene files fill it; every default lives in [`Default`] below.
#[derive(Clone, Debug, PartialEq)]
pub struct SimulationParams {
    /// Time step (s). The scene builder sets it from `time_step_fraction` when the scene gives
    /// none.
    pub time_step: f64,
    /// Fraction of the Rayleigh time step used when none is given. Default 0.2 (EDEM users pick
    /// 10-40 %).
    pub time_step_fraction: f64,
    /// Default [0, 0, -9.81] m/s^2.
    pub gravity: DVec3,
    /// The contact law. Default Hertz-Mindlin (no slip).
    pub contact_model: ContactModel,
    /// Rolling resistance. Default constant directional torque (EDEM's standard).
    pub rolling_model: RollingModel,
    /// Viscous damping of the epsd rolling model when a scene chooses it without one. Default 0.3.
    pub rolling_viscous_damping: f64,
    /// Neighbour-list skin (m). The scene builder sets it from `skin_fraction` when none is given.
    pub skin: f64,
    /// Skin as a fraction of the smallest sphere radius. Default 0.3.
    pub skin_fraction: f64,
    /// The near list's margin as a fraction of the skin (`dem::neighbour::NearList`): between
    /// full passes the pair stage visits only the pairs closer than this. Default 0.125; 0 turns
    /// the near list off (the results are the same bits either way).
    pub near_margin_fraction: f64,
    /// Particles outside this box stop the run (an exploding simulation). Default: none here;
    /// the scene builder puts a box around the set-up.
    pub domain: Option<(DVec3, DVec3)>,
    /// Largest overlap at the start, as a fraction of the smaller radius. Default 0.01.
    pub max_initial_overlap: f64,
}

impl Default for SimulationParams {
    fn default() -> Self {
        SimulationParams {
            time_step: 0.0,
            time_step_fraction: 0.2,
            gravity: DVec3::new(0.0, 0.0, -9.81),
            contact_model: ContactModel::default(),
            rolling_model: RollingModel::default(),
            rolling_viscous_damping: 0.3,
            skin: 0.0,
            skin_fraction: 0.3,
            near_margin_fraction: 0.125,
            domain: None,
            max_initial_overlap: 0.01,
        }
    }
}

/// Why a running simulation was stopped. A study stores each kind as its own failure
/// (`RunErrorKind`), so the variants are what callers tell apart.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum SimError {
    #[error(
        "simulation diverged at t = {time:.6} s: particle {particle} has a non-finite position or \
         velocity (time step too large for the stiffness, or overlapping start)"
    )]
    NotFinite { time: f64, particle: u32 },
    #[error(
        "particle {particle} left the simulation domain at t = {time:.6} s (at [{:.4}, {:.4}, {:.4}] m)",
        .position.x, .position.y, .position.z
    )]
    LeftDomain {
        time: f64,
        particle: u32,
        position: DVec3,
    },
    /// A step extension stopped the run (bonds that cannot form, say), or a device segment handed
    /// back what the host cannot take: its one-line reason.
    #[error("stopped at t = {time:.6} s: {message}")]
    Extension { time: f64, message: String },
}

/// Wall time spent in each stage of the step, LAMMPS-style.
#[derive(Clone, Debug, Default)]
pub struct StageTimers {
    /// Half kick and drift of spheres.
    pub integrate: Duration,
    /// Clumps: kicks, drift, members placed and gathered.
    pub bodies: Duration,
    pub geometry_motion: Duration,
    pub neighbour: Duration,
    pub pair_forces: Duration,
    /// The gather: each particle's wall contacts, the sum of all its contacts and gravity, and
    /// the second half kick.
    pub gather: Duration,
    /// Forces that extensions add before the kick (bonds).
    pub extension_forces: Duration,
    pub geometry_loads: Duration,
    /// Per-step extensions (factories, ...).
    pub extensions: Duration,
    /// Steps run on a back end's own device as whole segments (every stage of them).
    pub device_segments: Duration,
}

impl StageTimers {
    fn stages(&self) -> [(&'static str, Duration); 10] {
        [
            ("integrate", self.integrate),
            ("bodies", self.bodies),
            ("geometry motion", self.geometry_motion),
            ("neighbour", self.neighbour),
            ("pair forces", self.pair_forces),
            ("wall forces + sums", self.gather),
            ("extension forces", self.extension_forces),
            ("geometry loads", self.geometry_loads),
            ("extensions", self.extensions),
            ("device segments", self.device_segments),
        ]
    }

    pub fn total(&self) -> Duration {
        self.stages().iter().map(|s| s.1).sum()
    }

    /// One line with each stage's share of the time.
    pub fn breakdown(&self) -> String {
        let t = self.total().as_secs_f64().max(1e-12);
        self.stages()
            .iter()
            .map(|(name, d)| format!("{name} {:.1}%", 100.0 * d.as_secs_f64() / t))
            .collect::<Vec<_>>()
            .join(", ")
    }
}
