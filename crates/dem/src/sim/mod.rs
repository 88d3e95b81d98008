//! The simulation: its state, and the pipeline of stages run once per time step.
//!
//! A step is velocity Verlet split around the force computation. Each stage is timed
//! ([`StageTimers`]); the arithmetic of the particle and contact stages is done by a [`Backend`]
//! (the CPU one by default), over the struct-of-arrays state kept here:
//! 1. **integrate**: half kick, drift, and the largest displacements since the last list build
//!    and since the near list's scan (clump bodies first, **bodies**, then their members follow).
//! 2. **geometry motion**: geometries advance their pose.
//! 3. **neighbour**: the pair and wall-candidate lists are rebuilt when some particle (or
//!    geometry) has moved more than half the skin.
//! 4. **pair forces**: every candidate pair evaluates its contact once, into its own slot (between
//!    passes over the whole list, only the pairs of the near list, which the others cannot
//!    touch: [`crate::neighbour::NearList`]).
//! 5. **wall forces + sums** (the gather): every particle evaluates its geometry candidates'
//!    contacts into their slots, sums gravity and all its slots, then gets the second half kick
//!    (**extension forces**, e.g. bonds, come in before the kick and are timed apart; clumps
//!    gather their members' forces and are kicked as bodies). The CPU does this in one pass.
//! 6. **geometry loads**: each geometry's force and torque, summed from its wall slots.
//! 7. **extensions**: per-step extensions ([`StepExtension`]): factories creating particles now,
//!    recorders and servo-controlled plates next.
//!
//! No stage uses atomics or locks and every sum runs in a fixed order, so results are bit-identical
//! run to run for any thread count.

mod backend;
mod bodies;
mod contacts;
mod cpu;
mod extension;
mod params;
mod registry;
pub mod segment;
mod stage_bench;
pub mod walls;

pub use backend::{Anchors, Backend, Moved, StepInputs};
pub use bodies::{SegmentBodies, SegmentBodiesEnd};
pub use contacts::PairContact;
pub use cpu::{kick_spin, CpuBackend};
pub use extension::{OnDevice, StepExtension};
pub use params::{SimError, SimulationParams, StageTimers};
pub use registry::{
    backend_choices, batch_group, in_batch_group, make_backend, new_batch_group, register_backend,
    resolve_backend, BackendMaker, BACKEND_NAMES,
};
pub use segment::{GeometryTrack, Segment, SegmentEnd};
pub use stage_bench::StageCost;

use crate::clump::Bodies;
use crate::geometry::{ElementGrid, Geometry, Load};
use crate::material::MaterialTable;
use crate::mixture::{Item, Mixture, Shape};
use crate::neighbour::NeighbourList;
use crate::particles::{Particles, NO_BODY};
use glam::{DMat3, DVec3};
use rayon::prelude::*;
use std::time::Instant;
use walls::WallLists;

/// Particles per parallel task in the per-particle stages.
pub(crate) const BLOCK: usize = 256;

pub struct Simulation {
    pub particles: Particles,
    pub materials: MaterialTable,
    pub geometries: Vec<Geometry>,
    pub params: SimulationParams,
    pub time: f64,
    pub steps: u64,
    pub timers: StageTimers,
    /// Clumps (rigid multi-sphere bodies); their members are particles flagged with `body`.
    pub bodies: Bodies,
    /// Per-step extensions, run in order at the end of each step.
    pub extensions: Vec<Box<dyn StepExtension>>,
    neighbours: NeighbourList,
    walls: WallLists,
    backend: Box<dyn Backend>,
    /// Geometry poses and the particle bounds at the last build, for the geometry displacement check.
    poses_at_build: Vec<(DMat3, DVec3)>,
    bounds_at_build: (DVec3, DVec3),
    forces_ready: bool,
    /// Whether the pair output slots hold the forces of the current state (a list rebuild clears
    /// them until the next force evaluation).
    pair_forces_current: bool,
    /// Extra neighbour-search reach for attraction beyond touching (0 without cohesion).
    cohesive_reach: f64,
    /// Current index of each particle by stable id (particles are reordered at rebuilds).
    index_of: Vec<u32>,
    /// Largest sphere radius the wall grids and cohesive reach were sized for.
    prepared_radius: f64,
    /// After the back end declined a segment, steps run one by one until this step, and how long
    /// that wait was (it doubles with each decline in a row).
    segments_declined_until: u64,
    segment_backoff: u64,
    /// Per-chunk partial geometry loads (see `geometry_loads`), kept between steps.
    load_partials: Vec<Load>,
    /// The next step's integration (its largest displacements or failing particle), when the
    /// last step did it in its final pass.
    integrated_ahead: Option<Result<Moved, usize>>,
}

impl Simulation {
    pub fn new(
        particles: Particles,
        materials: MaterialTable,
        geometries: Vec<Geometry>,
        params: SimulationParams,
    ) -> Self {
        let skin = params.skin;
        let mut sim = Simulation {
            particles,
            materials,
            geometries,
            params,
            time: 0.0,
            steps: 0,
            timers: StageTimers::default(),
            bodies: Bodies::default(),
            extensions: Vec::new(),
            neighbours: NeighbourList::new(skin),
            walls: WallLists::default(),
            backend: Box::new(CpuBackend),
            poses_at_build: Vec::new(),
            bounds_at_build: (DVec3::ZERO, DVec3::ZERO),
            forces_ready: false,
            pair_forces_current: false,
            cohesive_reach: 0.0,
            index_of: Vec::new(),
            prepared_radius: -1.0,
            segments_declined_until: 0,
            segment_backoff: 0,
            load_partials: Vec::new(),
            integrated_ahead: None,
        };
        let max_r = sim.particles.radius.iter().cloned().fold(0.0, f64::max);
        sim.prepare_radius(max_r);
        sim
    }

    /// Runs the particle and contact stages on another back end.
    pub fn with_backend(mut self, backend: Box<dyn Backend>) -> Self {
        self.backend = backend;
        self
    }

    pub fn backend_name(&self) -> &'static str {
        self.backend.name()
    }

    /// Runs the stages on the back end registered as `name` (see [`make_backend`]); on an error
    /// the current back end stays.
    pub fn use_backend(&mut self, name: &str) -> Result<(), String> {
        if name != self.backend.name() {
            self.backend = make_backend(name)?;
        }
        Ok(())
    }

    /// Runs on the back end `name` when this machine has it, and otherwise stays on the CPU:
    /// the lines say which back end runs and what it leaves to the CPU, or why the CPU runs
    /// instead (for the user; nothing for "cpu").
    pub fn choose_backend(&mut self, name: &str) -> Vec<String> {
        if name == "cpu" {
            let _ = self.use_backend("cpu");
            return Vec::new();
        }
        match self.use_backend(name) {
            // Every back end but the CPU runs on a device: each extension says where it works
            // there (`StepExtension::on_device`).
            Ok(()) => self
                .backend
                .remarks(&self.inputs(!self.bodies.is_empty()))
                .into_iter()
                .chain(
                    self.extensions
                        .iter()
                        .map(|e| e.on_device().remark(e.name())),
                )
                .map(|r| format!("backend \"{name}\": {r}"))
                .collect(),
            Err(why) => vec![format!("backend \"{name}\": {why}; running on the CPU")],
        }
    }

    fn inputs(&self, clumps: bool) -> StepInputs<'_> {
        StepInputs {
            materials: &self.materials,
            geometries: &self.geometries,
            params: &self.params,
            clumps,
            cohesive: self.cohesive_reach > 0.0,
            polyhedra: self
                .bodies
                .polyhedra
                .any()
                .then_some(&self.bodies.polyhedra),
        }
    }

    /// Adds clumps whose member spheres are already among the particles (see [`Bodies::add`]).
    pub fn with_bodies(mut self, bodies: Bodies) -> Self {
        self.bodies = bodies;
        self.forces_ready = false;
        self
    }

    /// Sizes the cohesive reach and the wall search grids for spheres up to `radius` (needed
    /// before particles larger than any present are added).
    pub fn prepare_radius(&mut self, radius: f64) {
        if radius <= self.prepared_radius {
            return;
        }
        self.prepared_radius = radius;
        // A wall contact has R* = r, the largest any contact of these particles can have.
        self.cohesive_reach = self
            .params
            .contact_model
            .reach(self.materials.pairs(), radius);
        let reach = radius + self.params.skin + self.cohesive_reach;
        for g in &mut self.geometries {
            if g.reference.len() > 16 {
                g.grid = ElementGrid::build(&g.reference, reach);
            }
        }
        self.forces_ready = false;
    }

    /// Largest sphere radius prepared for (see [`Self::prepare_radius`]).
    pub fn prepared_radius(&self) -> f64 {
        self.prepared_radius
    }

    /// Adds a per-step extension.
    pub fn add_extension(&mut self, extension: Box<dyn StepExtension>) {
        debug_assert!(
            !extension.adds_forces() || extension.on_device() != OnDevice::BetweenSegments,
            "{}: adds forces at every step (OnDevice::EveryStep or InSegments)",
            extension.name()
        );
        self.extensions.push(extension);
    }

    /// Index of the geometry with this name.
    pub fn geometry_index(&self, name: &str) -> Option<usize> {
        self.geometries.iter().position(|g| g.name == name)
    }

    /// The geometry with this name.
    pub fn geometry(&self, name: &str) -> Option<&Geometry> {
        self.geometries.iter().find(|g| g.name == name)
    }

    /// The geometry with this name, to change its motion.
    pub fn geometry_mut(&mut self, name: &str) -> Option<&mut Geometry> {
        self.geometries.iter_mut().find(|g| g.name == name)
    }

    /// Moves every particle and clump by `delta` (placing a specimen where a test wants it).
    pub fn shift(&mut self, delta: DVec3) {
        for x in &mut self.particles.position {
            *x += delta;
        }
        for x in &mut self.bodies.position {
            *x += delta;
        }
        self.rebuild();
        self.forces_ready = false;
    }

    /// Moves geometry `index` by `delta` at once (a test starting its tool where it first
    /// touches, instead of simulating the approach), with the contact lists rebuilt.
    pub fn displace_geometry(&mut self, index: usize, delta: DVec3) {
        let g = &mut self.geometries[index];
        g.translation += delta;
        for (e, r) in g.elements.iter_mut().zip(&g.reference) {
            *e = r.transformed(&g.rotation, g.translation);
        }
        self.rebuild();
        self.forces_ready = false;
    }

    /// Adds particles of a mixture (spheres, or clumps as bodies) with a common velocity. Their
    /// force starts as their weight: they are placed free of contacts.
    pub fn add_items(&mut self, mixture: &Mixture, items: &[Item], velocity: DVec3) {
        if items.is_empty() {
            return;
        }
        self.prepare_radius(mixture.max_sphere_radius());
        let g = self.params.gravity;
        for it in items {
            let t = &mixture.types[it.kind];
            let first = self.particles.len();
            match &t.shape {
                Shape::Sphere => {
                    self.particles
                        .push(it.position, velocity, it.size, t.density, t.material);
                }
                Shape::Polyhedron { polyhedron } => {
                    let b = self.bodies.add_polyhedron(
                        &mut self.particles,
                        polyhedron,
                        it.size,
                        t.density,
                        t.material,
                        it.position,
                        it.orientation,
                        velocity,
                    );
                    self.bodies.force[b] = g * self.bodies.mass[b];
                }
                Shape::Clump { .. } => {
                    let (template, props) = t.scaled_clump(it.size).unwrap();
                    let b = self.bodies.add(
                        &mut self.particles,
                        &template,
                        &props,
                        t.density,
                        t.material,
                        it.position,
                        it.orientation,
                        velocity,
                    );
                    self.bodies.force[b] = g * self.bodies.mass[b];
                }
            }
            let p = &mut self.particles;
            for k in first..p.len() {
                p.force[k] = g * p.mass[k];
            }
        }
        if self.forces_ready {
            self.rebuild();
        }
    }

    pub fn neighbour_rebuilds(&self) -> u64 {
        self.neighbours.rebuilds
    }

    /// Pair stages so far that went over every listed pair, and over the near pairs only
    /// ([`crate::neighbour::NearList`]).
    pub fn pair_passes(&self) -> (u64, u64) {
        let near = &self.neighbours.near;
        (near.full_passes, near.near_passes)
    }

    /// Largest overlap between two particles divided by the smaller radius, and the pair's stable ids.
    pub fn largest_relative_overlap(&mut self) -> Option<(f64, u32, u32)> {
        self.ensure_lists();
        self.bodies.update_polyhedra();
        let p = &self.particles;
        let frames = &self.bodies.polyhedra;
        let mut worst: Option<(f64, u32, u32)> = None;
        for pair in &self.neighbours.pairs {
            let (i, j) = (pair.i as usize, pair.j as usize);
            if p.body[i] != NO_BODY && p.body[i] == p.body[j] {
                continue; // Members of one clump overlap by design.
            }
            let rel = match (
                frames.placed(p.body[i], p.position[i]),
                frames.placed(p.body[j], p.position[j]),
            ) {
                (None, None) => {
                    let d = p.radius[i] + p.radius[j] - (p.position[i] - p.position[j]).length();
                    d / p.radius[i].min(p.radius[j])
                }
                // A polyhedron: its overlap depth over its inscribed radius.
                (Some(a), Some(b)) => crate::polyhedron::contact::pair_penetration(&a, &b)
                    .map_or(0.0, |d| {
                        d / (0.5 * (a.shape.min_width * a.scale).min(b.shape.min_width * b.scale))
                    }),
                (Some(a), None) | (None, Some(a)) => {
                    let s = if frames.is_polyhedron(p.body[i]) {
                        j
                    } else {
                        i
                    };
                    let (_, _, dist) =
                        crate::polyhedron::contact::closest_on_polyhedron(&a, p.position[s]);
                    (p.radius[s] - dist) / p.radius[s].min(0.5 * a.shape.min_width * a.scale)
                }
            };
            if rel > 0.0 && worst.is_none_or(|w| rel > w.0) {
                worst = Some((rel, p.id[i], p.id[j]));
            }
        }
        worst
    }

    /// Largest particle-geometry overlap divided by the particle radius: (value, particle id, geometry name).
    pub fn largest_wall_overlap(&mut self) -> Option<(f64, u32, String)> {
        self.ensure_lists();
        self.bodies.update_polyhedra();
        let p = &self.particles;
        let frames = &self.bodies.polyhedra;
        let mut worst: Option<(f64, u32, String)> = None;
        for k in 0..p.len() {
            let poly = frames.placed(p.body[k], p.position[k]);
            for c in &self.walls.candidates[self.walls.row(k)] {
                let g = &self.geometries[c.geometry as usize];
                let el = &g.elements[c.element as usize];
                // A polyhedron: its overlap depth over its inscribed radius.
                let rel = match &poly {
                    Some(poly) => crate::polyhedron::contact::wall_penetration(el, poly)
                        .map(|d| d / (0.5 * poly.shape.min_width * poly.scale)),
                    None => el
                        .closest(p.position[k], p.radius[k])
                        .map(|cl| (p.radius[k] - cl.distance) / p.radius[k]),
                };
                if let Some(rel) = rel {
                    if rel > 0.0 && worst.as_ref().is_none_or(|w| rel > w.0) {
                        worst = Some((rel, p.id[k], g.name.clone()));
                    }
                }
            }
        }
        worst
    }

    fn ensure_lists(&mut self) {
        if self.neighbours.built_at.len() != self.particles.len() || self.neighbours.rebuilds == 0 {
            self.rebuild();
        }
    }

    /// Advances `n` steps: as segments on the back end's device where it runs them (see
    /// [`segment`]), else step by step.
    pub fn run(&mut self, n: u64) -> Result<(), SimError> {
        let mut left = n;
        while left > 0 {
            let steps = self.segment_steps(left);
            let before = self.steps;
            if steps > 1 && self.run_segment(steps)? {
                // The back end may end a segment early (it then ran at least one step).
                debug_assert!(self.steps > before && self.steps - before <= steps);
                left -= (self.steps - before).clamp(1, steps);
                continue;
            }
            // A step that another follows at once, with nothing in between, does the next
            // step's integration in its last pass (see `Backend::gather_and_integrate`).
            let ahead = left > 1
                && self.extensions.is_empty()
                && self.bodies.is_empty()
                && !self.backend.runs_segments(&self.inputs(false));
            self.step_then(ahead)?;
            left -= 1;
        }
        Ok(())
    }

    /// Kinetic energy of free spheres and clumps.
    pub fn kinetic_energy(&self) -> f64 {
        self.particles.kinetic_energy() + self.bodies.kinetic_energy()
    }

    /// Particles as a user counts them: free spheres plus clumps.
    pub fn particle_count(&self) -> usize {
        let free = self
            .particles
            .body
            .iter()
            .filter(|&&b| b == NO_BODY)
            .count();
        free + self.bodies.len()
    }

    /// Mass of free spheres and clumps.
    pub fn total_mass(&self) -> f64 {
        self.particles.total_mass() + self.bodies.mass.iter().sum::<f64>()
    }

    /// One velocity-Verlet step through the pipeline (see the module documentation).
    pub fn step(&mut self) -> Result<(), SimError> {
        self.step_then(false)
    }

    /// One step; with `integrate_next`, the next step's integration is done in this step's
    /// last pass and kept for it (only where the next step follows with nothing in between).
    fn step_then(&mut self, integrate_next: bool) -> Result<(), SimError> {
        if !self.forces_ready {
            self.ensure_lists();
            self.compute_forces(false, false);
            self.forces_ready = true;
        }
        let dt = self.params.time_step;

        let t0 = Instant::now();
        let ahead = self.integrated_ahead.take();
        if ahead.is_none() && !self.bodies.is_empty() {
            self.bodies_first_half(dt);
        }
        let t1 = Instant::now();
        self.timers.bodies += t1 - t0;
        let clumps = !self.bodies.is_empty();
        let integrated = match ahead {
            Some(done) => done,
            None => self.backend.integrate(
                &mut self.particles,
                Anchors::of(&self.neighbours),
                &self.params,
                clumps,
            ),
        };
        let moved = integrated.map_err(|i| self.failure(i, self.time + dt))?;
        let max_disp = moved.since_build;
        self.neighbours.near.moved = moved.since_near;
        let t2 = Instant::now();
        self.timers.integrate += t2 - t1;

        let mut geometry_disp: f64 = 0.0;
        let (blo, bhi) = self.bounds_at_build;
        for (g, (rot0, trans0)) in self.geometries.iter_mut().zip(&self.poses_at_build) {
            if g.advance(self.time, dt) {
                geometry_disp = geometry_disp.max(g.displacement_since(rot0, *trans0, blo, bhi));
            }
        }
        let t3 = Instant::now();
        self.timers.geometry_motion += t3 - t2;

        let half_skin = 0.5 * self.params.skin;
        if max_disp > half_skin || max_disp + geometry_disp > self.params.skin {
            self.rebuild();
        }
        self.timers.neighbour += t3.elapsed();

        self.compute_forces(true, integrate_next);
        self.time = (self.steps + 1) as f64 * dt;
        self.steps += 1;
        if !self.extensions.is_empty() {
            let t = Instant::now();
            let result = self.run_extensions();
            self.timers.extensions += t.elapsed();
            result?;
        }
        Ok(())
    }

    /// Why particle `i` stopped the run.
    fn failure(&self, i: usize, time: f64) -> SimError {
        let p = &self.particles;
        let x = p.position[i];
        if x.is_finite() && p.velocity[i].is_finite() {
            SimError::LeftDomain {
                time,
                particle: p.id[i],
                position: x,
            }
        } else {
            SimError::NotFinite {
                time,
                particle: p.id[i],
            }
        }
    }

    fn run_extensions(&mut self) -> Result<(), SimError> {
        let mut extensions = std::mem::take(&mut self.extensions);
        let mut result = Ok(());
        for e in extensions.iter_mut() {
            result = e.after_step(self);
            if result.is_err() {
                break;
            }
        }
        // Extensions added by an extension during the step run from the next step on.
        extensions.append(&mut self.extensions);
        self.extensions = extensions;
        result
    }

    fn compute_forces(&mut self, kick: bool, integrate_next: bool) {
        let clumps = !self.bodies.is_empty();
        let force_hooks = self.extensions.iter().any(|e| e.adds_forces());
        let extension_before = self.timers.extension_forces;
        if self.bodies.polyhedra.any() {
            let t = Instant::now();
            self.bodies.update_polyhedra();
            self.timers.bodies += t.elapsed();
        }
        // Field by field (not `self.inputs`): the stages borrow the lists mutably beside it.
        let inputs = StepInputs {
            materials: &self.materials,
            geometries: &self.geometries,
            params: &self.params,
            clumps,
            cohesive: self.cohesive_reach > 0.0,
            polyhedra: self
                .bodies
                .polyhedra
                .any()
                .then_some(&self.bodies.polyhedra),
        };
        let t0 = Instant::now();
        self.backend
            .pair_forces(&self.particles, &mut self.neighbours, &inputs);
        self.pair_forces_current = true;
        let t2 = Instant::now();
        self.timers.pair_forces += t2 - t0;
        let mut ahead = None;
        if integrate_next && kick && !force_hooks && !clumps {
            ahead = Some(self.backend.gather_and_integrate(
                &mut self.particles,
                &self.neighbours,
                &mut self.walls,
                &inputs,
            ));
        } else {
            self.backend.wall_forces_and_sums(
                &mut self.particles,
                &self.neighbours,
                &mut self.walls,
                &inputs,
                kick && !force_hooks,
            );
        }
        self.integrated_ahead = ahead;
        if force_hooks {
            // With the kick the forces are those at the end of the step being taken.
            let dt = self.params.time_step;
            let time = if kick { self.time + dt } else { self.time };
            let t = Instant::now();
            for e in self.extensions.iter_mut().filter(|e| e.adds_forces()) {
                e.add_forces(&mut self.particles, &self.index_of, time, dt);
            }
            self.timers.extension_forces += t.elapsed();
            if kick {
                extension::kick(&mut self.particles, &self.params, clumps);
            }
        }
        let t3 = Instant::now();
        // Extension forces are timed on their own inside this span.
        self.timers.gather +=
            (t3 - t2).saturating_sub(self.timers.extension_forces - extension_before);
        if clumps {
            self.gather_bodies();
            if kick {
                self.bodies.kick_all(0.5 * self.params.time_step, None);
                self.place_members(false);
            }
        }
        let t4 = Instant::now();
        self.timers.bodies += t4 - t3;
        self.geometry_loads();
        self.timers.geometry_loads += t4.elapsed();
    }

    fn rebuild(&mut self) {
        let reorder = self
            .neighbours
            .rebuild(&mut self.particles, self.cohesive_reach);
        let order = reorder.order;
        self.pair_forces_current = false;
        self.index_of.resize(self.particles.len(), 0);
        let index_of = crate::parallel::Shared(self.index_of.as_mut_ptr());
        self.particles
            .id
            .par_iter()
            .enumerate()
            .for_each(|(k, &id)| {
                // SAFETY: ids are a permutation of 0..n, so each slot is written once.
                unsafe { index_of.ptr().add(id as usize).write(k as u32) };
            });
        for e in &mut self.extensions {
            e.reordered(&self.index_of);
        }
        let skin = self.params.skin + self.cohesive_reach;
        self.walls
            .rebuild(&self.particles, order, &self.geometries, skin);
        self.poses_at_build = self
            .geometries
            .iter()
            .map(|g| (g.rotation, g.translation))
            .collect();
        self.bounds_at_build = self.particles.bounds(true);
    }

    /// Each geometry's force and torque: partial sums over fixed chunks of the wall slots, in
    /// parallel, then added in chunk order, so the result does not depend on the thread count.
    fn geometry_loads(&mut self) {
        let count = self.geometries.len();
        for g in &mut self.geometries {
            g.load = Load::default();
        }
        if count == 0 {
            return;
        }
        let chunk = crate::parallel::CHUNK;
        let add = |loads: &mut [Load], c: &walls::WallCandidate, o: &walls::WallOutput| {
            if o.force != DVec3::ZERO {
                let l = &mut loads[c.geometry as usize];
                l.force += o.force;
                l.torque += o.torque;
            }
        };
        let (cands, outs) = (&self.walls.candidates, &self.walls.output);
        if cands.len() <= chunk {
            for (c, o) in cands.iter().zip(outs) {
                if o.force != DVec3::ZERO {
                    let l = &mut self.geometries[c.geometry as usize].load;
                    l.force += o.force;
                    l.torque += o.torque;
                }
            }
        } else {
            // One row of partial loads per chunk (the buffer is kept between steps).
            let partial = &mut self.load_partials;
            partial.clear();
            partial.resize(cands.len().div_ceil(chunk) * count, Load::default());
            partial
                .par_chunks_mut(count)
                .zip(cands.par_chunks(chunk).zip(outs.par_chunks(chunk)))
                .for_each(|(loads, (cs, os))| {
                    for (c, o) in cs.iter().zip(os) {
                        add(loads, c, o);
                    }
                });
            for loads in partial.chunks(count) {
                for (g, l) in self.geometries.iter_mut().zip(loads) {
                    g.load.force += l.force;
                    g.load.torque += l.torque;
                }
            }
        }
        for g in &mut self.geometries {
            let p = g.to_world(g.torque_point);
            g.load.torque -= p.cross(g.load.force);
        }
    }
}
