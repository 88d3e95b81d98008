//! Segments: many steps run by a back end on its own device, with the state kept there.
//!
//! A GPU is fast only when the particles stay on it from step to step, so a back end that can
//! ([`super::Backend::run_segment`]) is handed whole runs of steps instead of single stages:
//! [`super::Simulation::run`] cuts its steps into segments that end where the host must see the
//! state (the end of the call, or a step at which an extension such as a factory has work), and
//! hands each segment over with everything it needs that the host computes:
//! - the particles, the pair and wall lists with their contact histories, at the segment's start;
//! - the geometry motion of every step ([`GeometryTrack`]), computed on the host beforehand as
//!   the pipeline would (`Geometry::advance`), so moving walls cost the device a copy of a few
//!   elements per step (by a kernel that reads the step's rows), not a host round trip;
//! - the clumps (their state, last force and members), whose stages the device runs with the
//!   particles' (not polyhedra, whose contacts are the host's);
//! - the bonds of an extension that runs on the device ([`super::OnDevice::InSegments`]), which it
//!   takes back after the segment;
//! - the steps at which geometry motion forces a list rebuild: the device rebuilds on its own when
//!   a particle has moved half the skin, and the host forces one when a geometry has moved a
//!   quarter of the skin since the last forced one, so particle and geometry motion since any
//!   rebuild stay within the skin together, as the pipeline's check keeps them.
//!
//! The back end hands back the state after the last step ([`SegmentEnd`]), with the histories of
//! the pairs and wall candidates in touch; the simulation then rebuilds its own lists (which
//! carries the histories over, as a rebuild always does) and runs the extensions.

use super::walls::WallCandidate;
use super::{OnDevice, SegmentBodies, SegmentBodiesEnd, SimError, StepInputs};
use crate::bond::segment::{SegmentBonds, SegmentBondsEnd};
use crate::geometry::{Element, Load, VelocityField};
use crate::neighbour::{NeighbourList, Pair};
use crate::particles::Particles;
use glam::DVec3;
use std::time::Instant;

/// Geometry motion over a segment of `steps` steps.
#[derive(Clone, Debug, Default)]
pub struct GeometryTrack {
    /// Geometries that have a motion (indices into the geometries); only their elements change.
    pub moving: Vec<usize>,
    /// `elements[s]`: the elements of the moving geometries, one after another in `moving`
    /// order, after the motion of step `s` (`elements[0]` at the segment's start); `steps + 1`
    /// entries.
    pub elements: Vec<Vec<Element>>,
    /// `velocity[s]`: every geometry's velocity field during step `s + 1`; `steps` entries.
    pub velocity: Vec<Vec<VelocityField>>,
    /// `rebuild[s]`: whether the lists must be rebuilt in step `s + 1` because a geometry moved.
    pub rebuild: Vec<bool>,
}

/// What a back end needs to run `steps` steps on its own.
pub struct Segment<'a> {
    /// The state at the segment's start, with the forces of that state (the next half kick's).
    pub particles: &'a Particles,
    /// The half pair list (i < j) with its histories; the segment keeps the particles' order.
    pub lists: &'a NeighbourList,
    /// The wall candidates with their histories, rows as [`super::walls::WallLists::start`].
    pub wall_start: &'a [u32],
    pub wall_candidates: &'a [WallCandidate],
    /// Materials, parameters and the geometries in their pose at the segment's end (static
    /// geometries' elements, materials and element counts are read from them).
    pub inputs: StepInputs<'a>,
    pub steps: u64,
    pub track: &'a GeometryTrack,
    /// Pair search reach beyond touching: the skin, plus the cohesive reach.
    pub pair_reach: f64,
    /// Wall search reach beyond touching (the same).
    pub wall_reach: f64,
    /// The bonds the device runs with the particles (an [`OnDevice::InSegments`] extension's).
    /// A back end that cannot run them declines the segment.
    pub bonds: Option<&'a SegmentBonds>,
    /// The clumps, whose stages the device runs with the particles' (`inputs.clumps` is set).
    /// A back end that cannot run them declines the segment.
    pub bodies: Option<&'a SegmentBodies>,
}

/// The state after a segment's last step.
#[derive(Clone, Debug, Default)]
pub struct SegmentEnd {
    pub position: Vec<DVec3>,
    pub velocity: Vec<DVec3>,
    pub angular_velocity: Vec<DVec3>,
    pub force: Vec<DVec3>,
    pub torque: Vec<DVec3>,
    pub rolling_torque_limit: Vec<f64>,
    /// Pairs (i < j, the particles' indices) whose history is not empty.
    pub pairs: Vec<Pair>,
    /// Wall candidates whose history is not empty, in rows over the particles.
    pub wall_start: Vec<u32>,
    pub wall_candidates: Vec<WallCandidate>,
    /// Each geometry's load in the last step: force, and torque about the world origin.
    pub geometry_loads: Vec<Load>,
    /// List rebuilds during the segment (on a GPU batch, those of the whole batch).
    pub rebuilds: u64,
    /// Steps run: all of the segment's, or fewer when a failure stopped it early or the back end
    /// ended it early (a GPU list that overflowed: the simulation goes on in the next segment).
    pub steps_done: u64,
    /// The step (0-based within the segment) in which a particle first stopped being finite or
    /// left the domain, not counted in the simulation's steps, as on the CPU (the segment's own
    /// count of steps when it was found after the last step's kick: the next step, in which the
    /// CPU finds it); the state is then that of the segment's end, for the message only.
    pub failed_at: Option<u64>,
    /// The bonds after the last step, when the segment had bonds.
    pub bonds: Option<SegmentBondsEnd>,
    /// The clumps after the last step, when the segment had clumps.
    pub bodies: Option<SegmentBodiesEnd>,
}

/// Most steps in one segment: segments chain, and this bounds what the host keeps per step and
/// the per-step buffers a back end binds.
const MAX_SEGMENT_STEPS: u64 = 20_000;

/// Most elements of moving geometries kept per segment (all steps together): a long segment with
/// a large moving mesh is cut shorter rather than fill the memory.
const MAX_TRACKED_ELEMENTS: usize = 4_000_000;

impl super::Simulation {
    /// How many of the next `left` steps can run as one segment on the back end: 0 when it cannot
    /// (polyhedra, extension forces the device does not run, a back end without segments), else up
    /// to the first step at which an extension has work.
    pub(super) fn segment_steps(&self, left: u64) -> u64 {
        if left < 2
            || self.particles.is_empty()
            || self.steps < self.segments_declined_until
            // Polyhedra's contacts are the host's.
            || self.bodies.polyhedra.any()
            || self.extensions.iter().any(|e| match e.on_device() {
                OnDevice::EveryStep => true,
                OnDevice::BetweenSegments => e.adds_forces(),
                OnDevice::InSegments => false,
            })
            // The device runs one extension's bonds.
            || self
                .extensions
                .iter()
                .filter(|e| e.on_device() == OnDevice::InSegments)
                .count()
                > 1
            || !self
                .backend
                .runs_segments(&self.inputs(!self.bodies.is_empty()))
        {
            return 0;
        }
        let dt = self.params.time_step;
        let mut steps = left.min(MAX_SEGMENT_STEPS);
        for e in &self.extensions {
            steps = steps.min(e.idle_steps(self.time, dt).saturating_add(1));
        }
        let moving: usize = self
            .geometries
            .iter()
            .filter(|g| !g.motion.is_empty())
            .map(|g| g.elements.len())
            .sum();
        if let Some(most) = MAX_TRACKED_ELEMENTS.checked_div(moving) {
            steps = steps.min(most.max(1) as u64);
        }
        steps
    }

    /// Advances the geometries through `steps` steps as the pipeline would, recording what the
    /// device needs (see [`GeometryTrack`]).
    fn geometry_track(&mut self, steps: u64) -> GeometryTrack {
        let dt = self.params.time_step;
        let moving: Vec<usize> = (0..self.geometries.len())
            .filter(|&g| !self.geometries[g].motion.is_empty())
            .collect();
        let elements_now = |geometries: &[crate::geometry::Geometry]| -> Vec<Element> {
            moving
                .iter()
                .flat_map(|&g| geometries[g].elements.iter().cloned())
                .collect()
        };
        let mut track = GeometryTrack {
            elements: vec![elements_now(&self.geometries)],
            ..Default::default()
        };
        // Where contacts can be, for how far a rotation moves the walls there: where the
        // particles can be, and the moving elements themselves (a contact point lies on one, and
        // a rotation keeps each point's distance from its axis).
        let (mut lo, mut hi) = match self.params.domain {
            Some(d) => d,
            None => {
                let (lo, hi) = self.particles.bounds(true);
                let pad = DVec3::splat(0.5 * (hi - lo).max_element() + self.params.skin);
                (lo - pad, hi + pad)
            }
        };
        for &g in &moving {
            for e in &self.geometries[g].elements {
                let (a, b) = e.bounds();
                if a.is_finite() && b.is_finite() {
                    lo = lo.min(a);
                    hi = hi.max(b);
                }
            }
        }
        let mut forced_at: Vec<_> = self
            .geometries
            .iter()
            .map(|g| (g.rotation, g.translation))
            .collect();
        let quarter_skin = 0.25 * self.params.skin;
        for s in 0..steps {
            let time = if s == 0 {
                self.time
            } else {
                (self.steps + s) as f64 * dt
            };
            let mut moved: f64 = 0.0;
            for &g in &moving {
                let geo = &mut self.geometries[g];
                if geo.advance(time, dt) {
                    let (rot, trans) = &forced_at[g];
                    moved = moved.max(geo.displacement_since(rot, *trans, lo, hi));
                }
            }
            for g in &mut self.geometries {
                if g.motion.is_empty() {
                    // As `advance` leaves a geometry without motion.
                    g.velocity = VelocityField::default();
                }
            }
            let rebuild = moved > quarter_skin;
            if rebuild {
                for (f, g) in forced_at.iter_mut().zip(&self.geometries) {
                    *f = (g.rotation, g.translation);
                }
            }
            track.rebuild.push(rebuild);
            track
                .velocity
                .push(self.geometries.iter().map(|g| g.velocity).collect());
            track.elements.push(elements_now(&self.geometries));
        }
        track.moving = moving;
        track
    }

    /// Runs `steps` steps as one segment on the back end; false (and nothing changed) when it
    /// declines them.
    pub(super) fn run_segment(&mut self, steps: u64) -> Result<bool, SimError> {
        if !self.forces_ready {
            self.ensure_lists();
            self.compute_forces(false, false);
            self.forces_ready = true;
        }
        let t0 = Instant::now();
        let saved = self
            .geometries
            .iter()
            .any(|g| !g.motion.is_empty())
            .then(|| self.geometries.clone());
        let track = self.geometry_track(steps);
        let reach = self.params.skin + self.cohesive_reach;
        let bonded = self
            .extensions
            .iter()
            .position(|e| e.on_device() == OnDevice::InSegments);
        let bonds =
            bonded.map(|k| self.extensions[k].segment_bonds(&self.particles, &self.index_of));
        let clumps = !self.bodies.is_empty();
        let bodies = self.segment_bodies();
        let bonds = match bonds {
            // Stage by stage, the extension's forces or the clumps on the host, as for a declined
            // segment.
            Some(Err(_)) => None,
            None => Some(None),
            Some(Ok(b)) => Some(b),
        }
        .filter(|_| !clumps || bodies.is_some());
        let Some(bonds) = bonds else {
            if let Some(g) = saved {
                self.geometries = g;
            }
            self.segment_backoff = (2 * self.segment_backoff).clamp(16, 4096);
            self.segments_declined_until = self.steps + self.segment_backoff;
            return Ok(false);
        };
        let segment = Segment {
            particles: &self.particles,
            lists: &self.neighbours,
            wall_start: &self.walls.start,
            wall_candidates: &self.walls.candidates,
            inputs: self.inputs(clumps),
            steps,
            track: &track,
            pair_reach: reach,
            wall_reach: reach,
            bonds: bonds.as_ref(),
            bodies: bodies.as_ref(),
        };
        let end = self
            .backend
            .run_segment(&segment)
            // A back end that left the bonds or the clumps out has not run the segment.
            .filter(|end| {
                (bonds.is_none() || end.bonds.is_some())
                    && (bodies.is_none() || end.bodies.is_some())
            });
        let Some(mut end) = end else {
            if let Some(g) = saved {
                self.geometries = g;
            }
            // Stepped stage by stage for a while before the back end is asked again.
            self.segment_backoff = (2 * self.segment_backoff).clamp(16, 4096);
            self.segments_declined_until = self.steps + self.segment_backoff;
            return Ok(false);
        };
        self.segment_backoff = 0;
        let dt = self.params.time_step;
        let (start_steps, start_time) = (self.steps, self.time);
        if let Some(b) = end.bodies.take() {
            let time = (start_steps + end.steps_done) as f64 * dt;
            self.end_segment_bodies(b)
                .map_err(|message| SimError::Extension { time, message })?;
        }
        if let (Some(k), Some(mut b)) = (bonded, end.bonds.take()) {
            // The kernels of a world's failing step still ran on its failed state.
            if let Some(f) = end.failed_at {
                b.breakages.retain(|x| x.step < f);
            }
            let time = (start_steps + end.steps_done) as f64 * dt;
            self.extensions[k]
                .end_segment(b, start_steps, end.steps_done, dt)
                .map_err(|message| SimError::Extension { time, message })?;
        }
        let p = &mut self.particles;
        p.position = end.position;
        p.velocity = end.velocity;
        p.angular_velocity = end.angular_velocity;
        p.force = end.force;
        p.torque = end.torque;
        p.rolling_torque_limit = end.rolling_torque_limit;
        // The steps that count: not a failing step, as on the CPU, which stops in it before the
        // step is counted and the geometries move.
        let counted = end.failed_at.unwrap_or(end.steps_done);
        self.steps += counted;
        self.time = self.steps as f64 * dt;
        self.timers.device_segments += t0.elapsed();
        if counted < steps {
            // The device stopped early (a failure, or a list that overflowed and ended the
            // segment at its chunk's start): the geometries go back to that pose.
            if let Some(g) = saved {
                self.geometries = g;
                self.steps = start_steps;
                self.time = start_time;
                self.geometry_track(counted);
                self.steps += counted;
                self.time = self.steps as f64 * dt;
            }
        }
        if let Some(s) = end.failed_at {
            self.forces_ready = false;
            let time = (start_steps + s + 1) as f64 * dt;
            let i = self.first_failed().unwrap_or(0);
            return Err(self.failure(i, time));
        }
        self.neighbours.pairs = end.pairs;
        self.neighbours.rebuilds += end.rebuilds;
        self.walls.start = end.wall_start;
        self.walls.candidates = end.wall_candidates;
        let t1 = Instant::now();
        self.rebuild();
        self.timers.neighbour += t1.elapsed();
        for (g, load) in self.geometries.iter_mut().zip(&end.geometry_loads) {
            let point = g.to_world(g.torque_point);
            g.load = Load {
                force: load.force,
                torque: load.torque - point.cross(load.force),
            };
        }
        if !self.extensions.is_empty() {
            let t = Instant::now();
            let result = self.run_extensions();
            self.timers.extensions += t.elapsed();
            result?;
        }
        Ok(true)
    }

    /// The first particle that is not finite or is outside the domain.
    fn first_failed(&self) -> Option<usize> {
        let p = &self.particles;
        (0..p.len()).find(|&i| {
            let x = p.position[i];
            !x.is_finite()
                || !p.velocity[i].is_finite()
                || self
                    .params
                    .domain
                    .is_some_and(|(lo, hi)| x.cmplt(lo).any() || x.cmpgt(hi).any())
        })
    }
}
