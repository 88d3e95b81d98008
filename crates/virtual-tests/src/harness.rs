//! What every virtual test does with its simulation: pieces of a set-up (run settings, a plate),
//! a budget of time steps checked before the run, running in pieces with progress reports,
//! settling until quiet (with a cap), moving a geometry by name, and recording a geometry's
//! force against its displacement.

use dem::geometry::Motion;
use dem::scene::{
    Domain, GeometryDescription, GeometryShape, RunLength, SimulationSettings, TimeStep,
};
use dem::sim::SimError;
use dem::Simulation;
use glam::DVec3;

use crate::file::TestFile;
use crate::virtual_test::{Response, Run, TestError};

/// The most time steps one test run may take: 1e9 steps are hours even for a handful of
/// particles, so a setting that needs more (a lift at 1e-9 m/s) is a mistake, refused before
/// the run rather than found out after days.
pub const MAX_TEST_STEPS: f64 = 1e9;

/// The most steps between two progress reports, so a long run is seen to move and can be
/// stopped promptly.
const PIECE: u64 = 1000;

/// Run settings of a test's scene: the time step as a percentage of the Rayleigh step, and a
/// domain that stops the run when a particle leaves it. A test drives its phases itself, so the
/// scene's own run length (which only sizes output schedules) is one step; [`budget`] checks what
/// the phases need instead.
pub fn simulation(time_step_percent: f64, domain: (DVec3, DVec3)) -> SimulationSettings {
    let mut s = SimulationSettings::new(RunLength::Steps(1));
    s.time_step = TimeStep::PercentOfRayleigh(time_step_percent);
    s.domain = Some(Domain {
        min: domain.0,
        max: domain.1,
    });
    s
}

/// A flat plate named "plate": a box whose top face (z = `top`) is the only closed one, so
/// particles see a plate and nothing of its sides.
pub fn plate(material: &str, half_x: f64, half_y: f64, top: f64) -> GeometryDescription {
    GeometryDescription {
        name: "plate".into(),
        material: material.into(),
        shape: GeometryShape::Box {
            min: DVec3::new(-half_x, -half_y, top - 0.01),
            max: DVec3::new(half_x, half_y, top),
            open: ["-x", "+x", "-y", "+y", "-z"].map(String::from).to_vec(),
        },
        motion: Vec::new(),
        torque_point: None,
    }
}

/// Checks that the phases of a test fit in [`MAX_TEST_STEPS`] at the time step `dt`. Each phase
/// is the setting that sets its length (`key`), what it is, and its simulated seconds; the
/// error names the longest.
pub fn budget(file: &TestFile, dt: f64, phases: &[(&str, String, f64)]) -> Result<(), String> {
    let total: f64 = phases.iter().map(|p| p.2).sum();
    let steps = total / dt;
    if steps.is_nan() || steps > MAX_TEST_STEPS {
        let longest = phases
            .iter()
            .max_by(|a, b| a.2.total_cmp(&b.2))
            .expect("a test has phases");
        return Err(file.error(
            longest.0,
            format!(
                "{} takes {:.3e} s of simulated time; the test would need {steps:.3e} time steps of {dt:.3e} s, more than the {MAX_TEST_STEPS:.0e} a test run may take",
                longest.1, longest.2
            ),
        ));
    }
    Ok(())
}

/// A setting's value for a message: plain for everyday sizes, in exponent form otherwise (1e-9,
/// not 0.000000001).
pub fn number(x: f64) -> String {
    if x == 0.0 || (1e-3..1e6).contains(&x.abs()) {
        format!("{x}")
    } else {
        format!("{x:e}")
    }
}

/// Why driving a simulation stopped.
#[derive(Debug)]
pub enum Stop {
    /// The simulation failed (diverged, a particle left the domain).
    Failed(SimError),
    /// The progress callback asked to stop (its message).
    Stopped(String),
}

impl Stop {
    /// The typed error, with a failure's message `file: <what>simulation failed: <why>` and a
    /// stop's as it came.
    pub fn error(self, file: &TestFile, what: &str) -> TestError {
        match self {
            Stop::Failed(e) => {
                let m = format!("{}: {what}simulation failed: {e}", file.name);
                match e {
                    SimError::NotFinite { .. } => TestError::Diverged(m),
                    SimError::LeftDomain { .. } => TestError::Escaped(m),
                    // An extension refusing its settings (bonds that cannot form).
                    SimError::Extension { .. } => TestError::Settings(m),
                }
            }
            Stop::Stopped(m) => TestError::Stopped(m),
        }
    }
}

/// The rms speed of the particles, by mass (clumps count as bodies).
pub fn rms_speed(sim: &Simulation) -> f64 {
    (2.0 * sim.kinetic_energy() / sim.total_mass()).sqrt()
}

/// The centre of mass of every particle (free spheres and clumps).
pub fn centres(sim: &Simulation) -> Vec<DVec3> {
    let p = &sim.particles;
    let mut out: Vec<DVec3> = (0..p.len())
        .filter(|&k| p.body[k] == dem::particles::NO_BODY)
        .map(|k| p.position[k])
        .collect();
    out.extend(sim.bodies.position.iter().cloned());
    out
}

/// Runs `steps` steps in pieces of at most a thousand, reporting `phase` after each piece, and
/// recording into `recorder` at its interval.
pub fn advance(
    sim: &mut Simulation,
    steps: u64,
    phase: &str,
    run: &mut Run,
    mut recorder: Option<&mut ForceRecorder>,
) -> Result<(), Stop> {
    let mut left = steps;
    while left > 0 {
        let mut piece = left.min(PIECE);
        if let Some(r) = &recorder {
            piece = piece.min(r.next.saturating_sub(sim.steps).max(1));
        }
        sim.run(piece).map_err(Stop::Failed)?;
        left -= piece;
        if let Some(r) = &mut recorder {
            if sim.steps >= r.next {
                r.record(sim);
            }
        }
        run.progress(phase, sim.time).map_err(Stop::Stopped)?;
    }
    Ok(())
}

/// When a settling phase counts as quiet.
#[derive(Clone, Copy, Debug)]
pub struct Quiet {
    /// The rms particle speed (m/s) below which it is quiet.
    pub rms_speed: f64,
    /// Simulated seconds into the phase before quiet counts (a fill at rest is not settled).
    pub min_time: f64,
    /// The longest the phase may take (s).
    pub max_time: f64,
    /// Simulated seconds between checks.
    pub check_every: f64,
    /// Not quiet while a factory (or any per-step extension) has work left.
    pub wait_for_factories: bool,
}

/// Runs until the particles are quiet or `max_time` has passed; true when quiet.
pub fn settle(
    sim: &mut Simulation,
    quiet: &Quiet,
    phase: &str,
    run: &mut Run,
) -> Result<bool, Stop> {
    let start = sim.time;
    let end = start + quiet.max_time;
    let chunk = ((quiet.check_every / sim.params.time_step).ceil() as u64).max(1);
    while sim.time < end {
        advance(sim, chunk, phase, run, None)?;
        if (quiet.min_time <= 0.0 || sim.time - start > quiet.min_time)
            && (!quiet.wait_for_factories || sim.extensions_finished())
            && rms_speed(sim) < quiet.rms_speed
        {
            return Ok(true);
        }
    }
    Ok(false)
}

/// The index of the geometry called `name`.
pub fn geometry(sim: &Simulation, name: &str) -> Result<usize, String> {
    sim.geometry_index(name).ok_or_else(|| {
        let names: Vec<&str> = sim.geometries.iter().map(|g| g.name.as_str()).collect();
        format!(
            "no geometry named \"{name}\" (the scene has: {})",
            names.join(", ")
        )
    })
}

/// Moves the geometry called `name` at `velocity` from now for `duration` seconds; returns the
/// time it stops.
pub fn translate(
    sim: &mut Simulation,
    name: &str,
    velocity: DVec3,
    duration: f64,
) -> Result<f64, String> {
    let g = geometry(sim, name)?;
    let start = sim.time;
    sim.geometries[g].motion.push(Motion::Translation {
        velocity,
        start,
        end: start + duration,
    });
    Ok(start + duration)
}

/// Turns the geometry called `name` at `angular_velocity` (rad/s) about the axis through
/// `axis_point` from now for `duration` seconds; returns the time it stops.
pub fn rotate(
    sim: &mut Simulation,
    name: &str,
    axis_point: DVec3,
    axis: DVec3,
    angular_velocity: f64,
    duration: f64,
) -> Result<f64, String> {
    let g = geometry(sim, name)?;
    let start = sim.time;
    sim.geometries[g].motion.push(Motion::Rotation {
        axis_point,
        axis,
        angular_velocity,
        start,
        end: start + duration,
    });
    Ok(start + duration)
}

/// Records one geometry's displacement from where it was when recording began and the force the
/// particles put on it, both along one direction, every so many steps (and once at the start).
#[derive(Clone, Debug)]
pub struct ForceRecorder {
    geometry: usize,
    direction: DVec3,
    origin: DVec3,
    every: u64,
    next: u64,
    displacement: Vec<f64>,
    force: Vec<f64>,
}

impl ForceRecorder {
    /// Starts recording the geometry called `name` along `direction` every `every` steps.
    pub fn new(
        sim: &Simulation,
        name: &str,
        direction: DVec3,
        every: u64,
    ) -> Result<ForceRecorder, String> {
        let geometry = geometry(sim, name)?;
        if !(direction.length() > 0.0 && direction.is_finite()) {
            return Err(format!(
                "recording \"{name}\": expected a non-zero direction"
            ));
        }
        let mut r = ForceRecorder {
            geometry,
            direction: direction.normalize(),
            origin: sim.geometries[geometry].translation,
            every: every.max(1),
            next: sim.steps,
            displacement: Vec::new(),
            force: Vec::new(),
        };
        r.record(sim);
        Ok(r)
    }

    fn record(&mut self, sim: &Simulation) {
        let g = &sim.geometries[self.geometry];
        self.displacement
            .push((g.translation - self.origin).dot(self.direction));
        self.force.push(g.load.force.dot(self.direction));
        self.next = sim.steps + self.every;
    }

    /// The samples so far: displacement (m) and force (N).
    pub fn samples(&self) -> (&[f64], &[f64]) {
        (&self.displacement, &self.force)
    }

    /// The force-displacement curve.
    pub fn curve(&self) -> Response {
        Response::Curve {
            x_name: "displacement".into(),
            x_unit: "m".into(),
            y_name: "force".into(),
            y_unit: "N".into(),
            x: self.displacement.clone(),
            y: self.force.clone(),
        }
    }
}
