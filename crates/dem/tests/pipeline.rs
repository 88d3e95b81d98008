//! The step pipeline's seams: a per-step extension that adds forces before the second half kick,
//! one that acts after the step, and a second back end plugged in behind `Backend`.

mod common;

use common::*;
use dem::contact::RollingModel;
use dem::neighbour::NeighbourList;
use dem::particles::Particles;
use dem::sim::walls::WallLists;
use dem::sim::{
    Anchors, Backend, CpuBackend, Moved, SimError, Simulation, SimulationParams, StepExtension,
    StepInputs,
};
use glam::DVec3;
use std::f64::consts::PI;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;

/// A linear spring pulling particle 0 (by stable id) to the origin.
struct Anchor {
    stiffness: f64,
}

impl StepExtension for Anchor {
    fn name(&self) -> &str {
        "anchor"
    }
    fn on_device(&self) -> dem::sim::OnDevice {
        dem::sim::OnDevice::EveryStep
    }
    fn adds_forces(&self) -> bool {
        true
    }
    fn add_forces(&mut self, p: &mut Particles, index_of: &[u32], _time: f64, _dt: f64) {
        let k = index_of[0] as usize;
        p.force[k] -= self.stiffness * p.position[k];
    }
    fn as_any(&self) -> &dyn std::any::Any {
        self
    }
}

/// Counts steps and stops the run after `limit`.
struct StopAfter {
    limit: u64,
}

impl StepExtension for StopAfter {
    fn name(&self) -> &str {
        "stop"
    }
    fn on_device(&self) -> dem::sim::OnDevice {
        dem::sim::OnDevice::BetweenSegments
    }
    fn after_step(&mut self, sim: &mut Simulation) -> Result<(), SimError> {
        if sim.steps >= self.limit {
            return Err(SimError::NotFinite {
                time: sim.time,
                particle: 0,
            });
        }
        Ok(())
    }
    fn as_any(&self) -> &dyn std::any::Any {
        self
    }
}

fn lone_sphere() -> Simulation {
    let m = material("m", 1e7, 0.3, 1000.0);
    let t = table(m.clone(), m, interaction(0.5, 0.5, 0.0));
    let mut p = Particles::default();
    p.push(DVec3::new(0.01, 0.0, 0.0), DVec3::ZERO, 0.001, 1000.0, 0);
    simulation(
        p,
        t,
        vec![],
        1e-4,
        DVec3::ZERO,
        RollingModel::ConstantDirectionalTorque,
    )
}

#[test]
fn an_extension_force_acts_before_the_kick_a_spring_oscillates_with_its_period() {
    let mut sim = lone_sphere();
    let mass = sim.particles.mass[0];
    let k = 0.1;
    sim.add_extension(Box::new(Anchor { stiffness: k }));
    let period = 2.0 * PI * (mass / k).sqrt();
    // Velocity Verlet on a harmonic spring: after one period the particle is back at x0 (to
    // second order in omega dt).
    let steps = (period / sim.params.time_step).round() as u64;
    sim.run(steps).unwrap();
    let x = sim.particles.position[0].x;
    eprintln!("period {period:.5} s over {steps} steps: x = {x:.6e} (x0 = 0.01)");
    assert!((x - 0.01).abs() < 1e-3 * 0.01, "x after one period {x}");
    // Half a period: at -x0.
    sim.run(steps / 2).unwrap();
    assert!((sim.particles.position[0].x + 0.01).abs() < 2e-3 * 0.01);
}

#[test]
fn an_extension_error_stops_the_run() {
    let mut sim = lone_sphere();
    sim.add_extension(Box::new(StopAfter { limit: 7 }));
    let err = sim.run(100).unwrap_err();
    assert_eq!(sim.steps, 7);
    assert!(matches!(err, SimError::NotFinite { .. }));
}

/// A back end that hands every stage to the CPU one and counts the calls: the seam a GPU back end
/// plugs into.
struct Counting {
    calls: Arc<AtomicUsize>,
}

impl Backend for Counting {
    fn name(&self) -> &'static str {
        "counting"
    }
    fn integrate(
        &self,
        p: &mut Particles,
        anchors: Anchors,
        params: &SimulationParams,
        clumps: bool,
    ) -> Result<Moved, usize> {
        self.calls.fetch_add(1, Ordering::Relaxed);
        CpuBackend.integrate(p, anchors, params, clumps)
    }
    fn pair_forces(&self, p: &Particles, lists: &mut NeighbourList, inputs: &StepInputs) {
        self.calls.fetch_add(1, Ordering::Relaxed);
        CpuBackend.pair_forces(p, lists, inputs)
    }
    fn wall_forces(&self, p: &Particles, walls: &mut WallLists, inputs: &StepInputs) {
        self.calls.fetch_add(1, Ordering::Relaxed);
        CpuBackend.wall_forces(p, walls, inputs)
    }
    fn particle_sums(
        &self,
        p: &mut Particles,
        lists: &NeighbourList,
        walls: &WallLists,
        inputs: &StepInputs,
        kick: bool,
    ) {
        self.calls.fetch_add(1, Ordering::Relaxed);
        CpuBackend.particle_sums(p, lists, walls, inputs, kick)
    }
}

fn falling_column() -> Simulation {
    let m = material("m", 1e7, 0.3, 2500.0);
    let t = table(m.clone(), m, interaction(0.5, 0.5, 0.1));
    let mut p = Particles::default();
    for k in 0..20 {
        p.push(
            DVec3::new(1e-4 * (k % 3) as f64, 0.0, 0.0011 + 0.0021 * k as f64),
            DVec3::ZERO,
            0.001,
            2500.0,
            0,
        );
    }
    simulation(
        p,
        t,
        vec![floor(1)],
        1e-5,
        DVec3::new(0.0, 0.0, -9.81),
        RollingModel::ConstantDirectionalTorque,
    )
}

#[test]
fn a_second_back_end_behind_the_seam_gives_the_same_numbers() {
    let mut cpu = falling_column();
    cpu.run(3000).unwrap();
    let calls = Arc::new(AtomicUsize::new(0));
    let mut other = falling_column().with_backend(Box::new(Counting {
        calls: calls.clone(),
    }));
    assert_eq!(other.backend_name(), "counting");
    other.run(3000).unwrap();
    assert_eq!(cpu.particles.position, other.particles.position);
    assert_eq!(cpu.particles.velocity, other.particles.velocity);
    // 4 stages a step, plus the first force computation (3 stages).
    assert_eq!(calls.load(Ordering::Relaxed), 4 * 3000 + 3);
}
