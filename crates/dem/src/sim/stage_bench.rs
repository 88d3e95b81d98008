//! Micro-benchmarks of the step's stages (`demcal bench stages`): each stage run on its own, again
//! and again, on one state. The stage timers of a run say where its time goes; these say what one
//! stage costs per particle with nothing else running beside it, so that a change to one stage
//! is measured on its own (docs/benchmarks.md).

use super::backend::{Anchors, StepInputs};
use super::Simulation;
use crate::particles::Particles;
use glam::DVec3;
use std::time::Instant;

/// What one stage costs on the current state.
#[derive(Clone, Debug, PartialEq)]
pub struct StageCost {
    /// The stage, named as the stage timers name it.
    pub stage: &'static str,
    /// Times it ran while timed (after a round of calls untimed).
    pub calls: usize,
    /// Wall time of one call (s): the mean of the best of [`ROUNDS`] rounds.
    pub seconds_per_call: f64,
}

impl StageCost {
    /// Nanoseconds per particle per call.
    pub fn ns_per_particle(&self, particles: usize) -> f64 {
        1e9 * self.seconds_per_call / particles.max(1) as f64
    }
}

/// The particle arrays the stages write, kept to be put back.
struct Motion {
    position: Vec<DVec3>,
    velocity: Vec<DVec3>,
    spin: Vec<DVec3>,
    force: Vec<DVec3>,
    torque: Vec<DVec3>,
}

impl Motion {
    fn of(p: &Particles) -> Motion {
        Motion {
            position: p.position.clone(),
            velocity: p.velocity.clone(),
            spin: p.angular_velocity.clone(),
            force: p.force.clone(),
            torque: p.torque.clone(),
        }
    }

    fn restore(&self, p: &mut Particles) {
        p.position.copy_from_slice(&self.position);
        p.velocity.copy_from_slice(&self.velocity);
        p.angular_velocity.copy_from_slice(&self.spin);
        p.force.copy_from_slice(&self.force);
        p.torque.copy_from_slice(&self.torque);
    }
}

/// Mean time of `calls` calls of `f` (s).
fn time(calls: usize, mut f: impl FnMut()) -> f64 {
    let t = Instant::now();
    for _ in 0..calls {
        f();
    }
    t.elapsed().as_secs_f64() / calls.max(1) as f64
}

/// Rounds the calls are split into: each stage's cost is its best round, so that a moment of
/// another program's load on a shared machine does not count against one stage.
const ROUNDS: usize = 5;

/// The stages timed, in the order they run in a round.
const STAGES: [&str; 7] = [
    "neighbour rebuild",
    "pair forces",
    "wall forces + sums",
    "wall forces + sums + next integration",
    "integrate",
    "geometry loads",
    "pair forces over every pair",
];

impl Simulation {
    /// Runs each stage of the step `calls` times on the current state with this simulation's back
    /// end and says what one call costs: the neighbour rebuild, the pair forces, the gather (wall
    /// forces + sums, without the kick), the gather with the kick going on into the next step's
    /// integration (the pass a run makes), the integration on its own, the geometry loads, and
    /// the pair forces again over every listed pair (the pass that scans the near list anew; the
    /// pair forces above visit the near pairs, as a run's steps between scans do). The calls run
    /// in rounds, each stage in turn, and a stage's cost is its best round.
    ///
    /// The state is put back as it was afterwards (positions, velocities, forces, contact
    /// histories; the lists are rebuilt where it stands), so a run can go on from it.
    pub fn stage_costs(&mut self, calls: usize) -> Result<Vec<StageCost>, String> {
        if !self.bodies.is_empty() || !self.extensions.is_empty() {
            return Err(
                "stage micro-benchmarks run scenes of free spheres without extensions".into(),
            );
        }
        if self.integrated_ahead.is_some() {
            return Err("stage micro-benchmarks need a state between steps".into());
        }
        self.ensure_lists();
        if !self.forces_ready {
            self.compute_forces(false, false);
            self.forces_ready = true;
        }
        // The first rebuild may sort the particles anew; every later one finds them sorted and
        // builds the same lists. What is put back at the end is kept after it.
        self.rebuild();
        let motion = Motion::of(&self.particles);
        let pairs = self.neighbours.pairs.clone();
        let pair_output = self.neighbours.output.clone();
        let active = self.neighbours.active.clone();
        let walls = self.walls.clone();
        let per_round = calls.div_ceil(ROUNDS);
        let mut best = [f64::INFINITY; STAGES.len()];
        let mut restore = f64::INFINITY;
        // One round untimed first, to warm the caches.
        for round in 0..=ROUNDS {
            let mut seconds = [0.0; STAGES.len()];
            seconds[0] = time(per_round, || self.rebuild());
            let inputs = StepInputs {
                materials: &self.materials,
                geometries: &self.geometries,
                params: &self.params,
                clumps: false,
                cohesive: self.cohesive_reach > 0.0,
                polyhedra: None,
            };
            let backend = &self.backend;
            let (particles, neighbours, wall_lists) =
                (&mut self.particles, &mut self.neighbours, &mut self.walls);
            // After the rebuild, one pass over every pair scans the near list; then the calls
            // visit the near pairs, as a run's steps do while the particles barely move (here
            // they are put back after every stage that moves them).
            backend.pair_forces(particles, neighbours, &inputs);
            seconds[1] = time(per_round, || {
                neighbours.near.moved = 0.0;
                backend.pair_forces(particles, neighbours, &inputs)
            });
            // Without the kick the gather writes only forces and torques, the same every call.
            seconds[2] = time(per_round, || {
                backend.wall_forces_and_sums(particles, neighbours, wall_lists, &inputs, false)
            });
            // These move the particles: they are put back after each call, and the time of that
            // copy, measured apart, is not theirs.
            seconds[3] = time(per_round, || {
                let _ = backend.gather_and_integrate(particles, neighbours, wall_lists, &inputs);
                motion.restore(particles);
            });
            let anchors = Anchors::of(neighbours);
            seconds[4] = time(per_round, || {
                let _ = backend.integrate(particles, anchors, inputs.params, false);
                motion.restore(particles);
            });
            seconds[6] = time(per_round, || {
                neighbours.near.current = false;
                backend.pair_forces(particles, neighbours, &inputs)
            });
            let copy = time(per_round, || motion.restore(particles));
            seconds[5] = time(per_round, || self.geometry_loads());
            if round > 0 {
                restore = restore.min(copy);
                for (b, s) in best.iter_mut().zip(seconds) {
                    *b = b.min(s);
                }
            }
        }
        for b in &mut best[3..5] {
            *b = (*b - restore).max(0.0);
        }
        self.neighbours.pairs = pairs;
        self.neighbours.output = pair_output;
        self.neighbours.active = active;
        // The next pair stage goes over every pair again.
        self.neighbours.near.current = false;
        self.walls = walls;
        motion.restore(&mut self.particles);
        self.geometry_loads();
        Ok(STAGES
            .iter()
            .zip(best)
            .map(|(&stage, seconds_per_call)| StageCost {
                stage,
                calls: per_round * ROUNDS,
                seconds_per_call,
            })
            .collect())
    }
}

#[cfg(test)]
mod tests {
    use crate::scene::Scene;
    use glam::DVec3;
    use std::path::Path;

    /// Each particle's position and velocity, by id (a rebuild may reorder the particles).
    fn by_id(sim: &super::Simulation) -> Vec<(u32, DVec3, DVec3)> {
        let p = &sim.particles;
        let mut v: Vec<_> = (0..p.len())
            .map(|k| (p.id[k], p.position[k], p.velocity[k]))
            .collect();
        v.sort_by_key(|e| e.0);
        v
    }

    #[test]
    fn every_stage_is_timed_and_the_state_is_put_back() {
        let scene = Scene::from_toml(crate::bench::SETTLE_SCENE, "settle", Path::new(".")).unwrap();
        let mut sim = scene.simulation;
        // Long enough for the first layers to reach the floor: pairs and walls in contact.
        sim.run(3000).unwrap();
        let before = by_id(&sim);
        let costs = sim.stage_costs(5).unwrap();
        let names: Vec<&str> = costs.iter().map(|c| c.stage).collect();
        assert_eq!(names, super::STAGES);
        for c in &costs {
            assert!(
                c.seconds_per_call.is_finite() && c.seconds_per_call >= 0.0,
                "{c:?}"
            );
            assert_eq!(c.calls, 5);
        }
        assert!(costs[1].seconds_per_call > 0.0 && costs[0].seconds_per_call > 0.0);
        assert_eq!(by_id(&sim), before);
        // And the run goes on from it.
        sim.run(10).unwrap();
    }
}
