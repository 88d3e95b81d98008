//! The simulation: a pipeline of stages run once per time step.
//!
//! A step is velocity Verlet split around the force computation:
//! 1. `integrate_first_half`: half kick, drift, and the largest displacement since the last list build.
//! 2. geometries advance their pose.
//! 3. the neighbour list is rebuilt when some particle (or geometry) has moved more than half the skin.
//! 4. `pair_forces`: every candidate pair computes its force once, in parallel, into its own slot.
//! 5. `particle_forces`: every particle sums its pair slots (as i and as j), computes its wall
//!    contacts, adds gravity and does the second half kick, in parallel over particles.
//! 6. geometry loads are summed from the wall contact slots.
//! 7. factories due at this time create their particles, which forces a list rebuild.
//!
//! No stage uses atomics or locks and every sum runs in a fixed order, so results are bit-identical
//! run to run for any thread count.

use crate::clump::Bodies;
use crate::contact::{
    epsd_rolling_torque, hertz_mindlin, jkr_cutoff_overlap, ContactPoint, RollingModel,
};
use crate::factory::Factory;
use crate::geometry::{ElementGrid, Geometry, Load, Region};
use crate::material::MaterialTable;
use crate::mixture::{Item, Mixture, Shape};
use crate::neighbour::{NeighbourList, PairOutput};
use crate::particles::Particles;
use crate::particles::NO_BODY;
use glam::{DMat3, DVec3};
use rayon::prelude::*;
use smallvec::SmallVec;
use std::time::{Duration, Instant};

/// Parameters of a simulation (one struct, as the scene file gives them).
#[derive(Clone, Debug)]
pub struct SimulationParams {
    pub time_step: f64,
    pub gravity: DVec3,
    pub rolling_model: RollingModel,
    /// Neighbour-list skin (m).
    pub skin: f64,
    /// Particles outside this box stop the run (an exploding simulation).
    pub domain: Option<(DVec3, DVec3)>,
}

/// Why a running simulation was stopped.
#[derive(Clone, Debug, PartialEq)]
pub enum SimError {
    NotFinite {
        time: f64,
        particle: u32,
    },
    LeftDomain {
        time: f64,
        particle: u32,
        position: DVec3,
    },
}

impl std::fmt::Display for SimError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            SimError::NotFinite { time, particle } => write!(
                f,
                "simulation diverged at t = {time:.6} s: particle {particle} has a non-finite position or \
                 velocity (time step too large for the stiffness, or overlapping start)"
            ),
            SimError::LeftDomain {
                time,
                particle,
                position,
            } => write!(
                f,
                "particle {particle} left the simulation domain at t = {time:.6} s (at [{:.4}, {:.4}, {:.4}] m)",
                position.x, position.y, position.z
            ),
        }
    }
}

impl std::error::Error for SimError {}

/// Wall time spent in each stage, LAMMPS-style.
#[derive(Clone, Debug, Default)]
pub struct StageTimers {
    pub integrate: Duration,
    pub geometry_motion: Duration,
    pub neighbour: Duration,
    pub pair_forces: Duration,
    pub particle_forces: Duration,
    pub geometry_loads: Duration,
}

impl StageTimers {
    pub fn total(&self) -> Duration {
        self.integrate
            + self.geometry_motion
            + self.neighbour
            + self.pair_forces
            + self.particle_forces
            + self.geometry_loads
    }

    /// One line with each stage's share of the time.
    pub fn breakdown(&self) -> String {
        let t = self.total().as_secs_f64().max(1e-12);
        let pct = |d: Duration| 100.0 * d.as_secs_f64() / t;
        format!(
            "integrate {:.1}%, geometry motion {:.1}%, neighbour {:.1}%, pair forces {:.1}%, particle+wall forces {:.1}%, geometry loads {:.1}%",
            pct(self.integrate),
            pct(self.geometry_motion),
            pct(self.neighbour),
            pct(self.pair_forces),
            pct(self.particle_forces),
            pct(self.geometry_loads)
        )
    }
}

/// A particle-geometry candidate with its contact history.
#[derive(Clone, Copy, Debug, Default)]
pub struct WallCandidate {
    pub geometry: u16,
    pub element: u32,
    pub shear: DVec3,
    pub rolling: DVec3,
}

#[derive(Clone, Copy, Debug, Default)]
struct WallOutput {
    force: DVec3,
    torque: DVec3,
}

pub struct Simulation {
    pub particles: Particles,
    pub materials: MaterialTable,
    pub geometries: Vec<Geometry>,
    pub params: SimulationParams,
    pub time: f64,
    pub steps: u64,
    pub timers: StageTimers,
    neighbours: NeighbourList,
    wall_start: Vec<u32>,
    walls: Vec<WallCandidate>,
    wall_output: Vec<WallOutput>,
    /// Geometry poses and the particle bounds at the last build, for the geometry displacement check.
    poses_at_build: Vec<(DMat3, DVec3)>,
    bounds_at_build: (DVec3, DVec3),
    forces_ready: bool,
    /// Extra neighbour-search reach for JKR attraction beyond touching (0 without cohesion).
    cohesive_reach: f64,
    /// Clumps (rigid multi-sphere bodies); their members are particles flagged with `body`.
    pub bodies: Bodies,
    /// Current index of each particle by stable id (particles are reordered at rebuilds).
    index_of: Vec<u32>,
    /// Particle factories (creating particles during the run).
    pub factories: Vec<Factory>,
    /// Largest sphere radius the wall grids and cohesive reach were sized for.
    prepared_radius: f64,
}

/// Raw pointer that may be shared between rayon tasks that write disjoint slots.
#[derive(Clone, Copy)]
struct Shared<T>(*mut T);
unsafe impl<T> Send for Shared<T> {}
unsafe impl<T> Sync for Shared<T> {}

impl<T> Shared<T> {
    /// Going through a method makes closures capture the whole wrapper (which is Send), not the
    /// raw pointer field.
    #[inline(always)]
    fn ptr(self) -> *mut T {
        self.0
    }
}

const BLOCK: usize = 256;

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
            neighbours: NeighbourList::new(skin),
            wall_start: Vec::new(),
            walls: Vec::new(),
            wall_output: Vec::new(),
            poses_at_build: Vec::new(),
            bounds_at_build: (DVec3::ZERO, DVec3::ZERO),
            forces_ready: false,
            cohesive_reach: 0.0,
            bodies: Bodies::default(),
            index_of: Vec::new(),
            factories: Vec::new(),
            prepared_radius: -1.0,
        };
        let max_r = sim.particles.radius.iter().cloned().fold(0.0, f64::max);
        sim.prepare_radius(max_r);
        sim
    }

    /// Sizes the cohesive reach and the wall search grids for spheres up to `radius` (needed
    /// before particles larger than any present are added).
    pub fn prepare_radius(&mut self, radius: f64) {
        if radius <= self.prepared_radius {
            return;
        }
        self.prepared_radius = radius;
        // A wall contact has R* = r, the largest any contact of these particles can have.
        self.cohesive_reach = self.materials.cohesive_reach(radius);
        let reach = radius + self.params.skin + self.cohesive_reach;
        for g in &mut self.geometries {
            if g.reference.len() > 16 {
                g.grid = ElementGrid::build(&g.reference, reach);
            }
        }
        self.forces_ready = false;
    }

    /// Adds a particle factory.
    pub fn add_factory(&mut self, factory: Factory) {
        self.prepare_radius(factory.mixture.max_sphere_radius());
        self.factories.push(factory);
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

    /// Whether every factory has created all it should.
    pub fn factories_done(&self) -> bool {
        self.factories.iter().all(|f| f.done())
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

    /// Whether a sphere at `x` of radius `r` touches a particle among `near` or any geometry.
    fn spot_is_free(&self, near: &[(DVec3, f64)], x: DVec3, r: f64) -> bool {
        if near
            .iter()
            .any(|(y, q)| (x - *y).length_squared() < (r + q) * (r + q))
        {
            return false;
        }
        let mut clear = true;
        for geo in &self.geometries {
            visit_elements(geo, x, |e| {
                if clear {
                    if let Some(c) = geo.elements[e].closest(x, r) {
                        clear = c.distance >= r;
                    }
                }
            });
        }
        clear
    }

    /// Runs the factories that are due.
    fn run_factories(&mut self) {
        let time = self.time;
        let mut factories = std::mem::take(&mut self.factories);
        for factory in factories.iter_mut().filter(|f| f.due(time)) {
            let (lo, hi) = factory.bounds();
            let pad = DVec3::splat(2.0 * self.prepared_radius);
            let (lo, hi) = (lo - pad, hi + pad);
            let p = &self.particles;
            let near: Vec<(DVec3, f64)> = (0..p.len())
                .filter(|&k| p.position[k].cmpge(lo).all() && p.position[k].cmple(hi).all())
                .map(|k| (p.position[k], p.radius[k]))
                .collect();
            let items = factory.batch(time, |x, r| self.spot_is_free(&near, x, r));
            self.add_items(&factory.mixture, &items, factory.velocity);
        }
        self.factories = factories;
    }

    pub fn neighbour_rebuilds(&self) -> u64 {
        self.neighbours.rebuilds
    }

    pub fn pair_candidates(&self) -> usize {
        self.neighbours.pairs.len()
    }

    /// Pairs and wall candidates currently touching.
    pub fn contact_count(&self) -> usize {
        let pairs = self
            .neighbours
            .output
            .iter()
            .filter(|o| o.force != DVec3::ZERO)
            .count();
        let walls = self
            .wall_output
            .iter()
            .filter(|o| o.force != DVec3::ZERO)
            .count();
        pairs + walls
    }

    /// Largest overlap between two particles divided by the smaller radius, and the pair's stable ids.
    pub fn largest_relative_overlap(&mut self) -> Option<(f64, u32, u32)> {
        self.ensure_lists();
        let p = &self.particles;
        let mut worst: Option<(f64, u32, u32)> = None;
        for pair in &self.neighbours.pairs {
            let (i, j) = (pair.i as usize, pair.j as usize);
            if p.body[i] != NO_BODY && p.body[i] == p.body[j] {
                continue; // Members of one clump overlap by design.
            }
            let d = p.radius[i] + p.radius[j] - (p.position[i] - p.position[j]).length();
            let rel = d / p.radius[i].min(p.radius[j]);
            if rel > 0.0 && worst.is_none_or(|w| rel > w.0) {
                worst = Some((rel, p.id[i], p.id[j]));
            }
        }
        worst
    }

    /// Largest particle-geometry overlap divided by the particle radius: (value, particle id, geometry name).
    pub fn largest_wall_overlap(&mut self) -> Option<(f64, u32, String)> {
        self.ensure_lists();
        let p = &self.particles;
        let mut worst: Option<(f64, u32, String)> = None;
        for k in 0..p.len() {
            for c in &self.walls[self.wall_start[k] as usize..self.wall_start[k + 1] as usize] {
                let g = &self.geometries[c.geometry as usize];
                if let Some(cl) = g.elements[c.element as usize].closest(p.position[k], p.radius[k])
                {
                    let rel = (p.radius[k] - cl.distance) / p.radius[k];
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

    /// Advances `n` steps.
    pub fn run(&mut self, n: u64) -> Result<(), SimError> {
        for _ in 0..n {
            self.step()?;
        }
        Ok(())
    }

    /// Adds clumps whose member spheres are already among the particles (see [`Bodies::add`]).
    pub fn with_bodies(mut self, bodies: Bodies) -> Self {
        self.bodies = bodies;
        self.forces_ready = false;
        self
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

    /// One velocity-Verlet step.
    pub fn step(&mut self) -> Result<(), SimError> {
        if !self.forces_ready {
            self.ensure_lists();
            self.compute_forces(false);
            self.forces_ready = true;
        }
        let dt = self.params.time_step;

        let t0 = Instant::now();
        if !self.bodies.is_empty() {
            self.bodies_first_half(dt);
        }
        let max_disp = self.integrate_first_half(dt)?;
        let t1 = Instant::now();
        self.timers.integrate += t1 - t0;

        let mut geometry_disp: f64 = 0.0;
        let (blo, bhi) = self.bounds_at_build;
        for (g, (rot0, trans0)) in self.geometries.iter_mut().zip(&self.poses_at_build) {
            if g.advance(self.time, dt) {
                geometry_disp = geometry_disp.max(g.displacement_since(rot0, *trans0, blo, bhi));
            }
        }
        let t2 = Instant::now();
        self.timers.geometry_motion += t2 - t1;

        let half_skin = 0.5 * self.params.skin;
        if max_disp > half_skin || max_disp + geometry_disp > self.params.skin {
            self.rebuild();
        }
        self.timers.neighbour += t2.elapsed();

        self.compute_forces(true);
        self.time = (self.steps + 1) as f64 * dt;
        self.steps += 1;
        if !self.factories.is_empty() {
            self.run_factories();
        }
        Ok(())
    }

    fn compute_forces(&mut self, kick: bool) {
        let t0 = Instant::now();
        self.pair_forces();
        let t1 = Instant::now();
        self.timers.pair_forces += t1 - t0;
        self.particle_forces(kick);
        if !self.bodies.is_empty() {
            self.gather_bodies();
            if kick {
                let half = 0.5 * self.params.time_step;
                for b in 0..self.bodies.len() {
                    self.bodies.kick(b, half);
                }
                self.place_members(false);
            }
        }
        let t2 = Instant::now();
        self.timers.particle_forces += t2 - t1;
        self.geometry_loads();
        self.timers.geometry_loads += t2.elapsed();
    }

    /// Clumps: half kick, drift, orientation update, then their members follow.
    fn bodies_first_half(&mut self, dt: f64) {
        let half = 0.5 * dt;
        let bodies = &mut self.bodies;
        for b in 0..bodies.len() {
            bodies.kick(b, half);
            bodies.position[b] += bodies.velocity[b] * dt;
            bodies.rotation[b].advance_orientation(dt);
        }
        self.place_members(true);
    }

    /// Sets clump members' velocity and spin (and position when `positions`) from their body.
    fn place_members(&mut self, positions: bool) {
        let p = &mut self.particles;
        let bodies = &self.bodies;
        for b in 0..bodies.len() {
            let rot = &bodies.rotation[b];
            let w = rot.angular_velocity();
            for &id in &bodies.members[b] {
                let k = self.index_of[id as usize] as usize;
                let arm = rot.orientation * p.body_offset[k];
                if positions {
                    p.position[k] = bodies.position[b] + arm;
                }
                p.velocity[k] = bodies.velocity[b] + w.cross(arm);
                p.angular_velocity[k] = w;
            }
        }
    }

    /// Sums members' forces and torques onto their bodies. A member's force includes gravity on
    /// the whole body's mass (it carries that mass for its contacts), so that is taken off and the
    /// body's weight added once.
    fn gather_bodies(&mut self) {
        let p = &self.particles;
        let g = self.params.gravity;
        let bodies = &mut self.bodies;
        for b in 0..bodies.len() {
            let (mut f, mut t, mut lim) = (g * bodies.mass[b], DVec3::ZERO, 0.0);
            for &id in &bodies.members[b] {
                let k = self.index_of[id as usize] as usize;
                let contact = p.force[k] - g * p.mass[k];
                f += contact;
                t += (p.position[k] - bodies.position[b]).cross(contact) + p.torque[k];
                lim += p.rolling_torque_limit[k];
            }
            bodies.force[b] = f;
            bodies.torque[b] = t;
            bodies.rolling_limit[b] = lim;
        }
    }

    /// Half kick and drift; returns the largest displacement since the last list build.
    fn integrate_first_half(&mut self, dt: f64) -> Result<f64, SimError> {
        let half = 0.5 * dt;
        let p = &mut self.particles;
        let built = &self.neighbours.built_at;
        let domain = self.params.domain;
        let clumps = !self.bodies.is_empty();
        let (inv_mass, inv_inertia, force, torque, limit, body) = (
            &p.inv_mass,
            &p.inv_inertia,
            &p.force,
            &p.torque,
            &p.rolling_torque_limit,
            &p.body,
        );
        let (max_d2, bad) = p
            .position
            .par_chunks_mut(BLOCK)
            .zip(p.velocity.par_chunks_mut(BLOCK))
            .zip(p.angular_velocity.par_chunks_mut(BLOCK))
            .enumerate()
            .map(|(b, ((xs, vs), ws))| {
                let base = b * BLOCK;
                let mut worst: f64 = 0.0;
                let mut bad: Option<usize> = None;
                for k in 0..xs.len() {
                    let i = base + k;
                    // Clump members were moved with their bodies.
                    if !clumps || body[i] == NO_BODY {
                        vs[k] += force[i] * (inv_mass[i] * half);
                        ws[k] = kick_spin(ws[k], torque[i], limit[i], inv_inertia[i] * half);
                        xs[k] += vs[k] * dt;
                    }
                    let d2 = (xs[k] - built[i]).length_squared();
                    if d2.is_finite() {
                        worst = worst.max(d2);
                    } else if bad.is_none() {
                        bad = Some(i);
                    }
                    if let Some((lo, hi)) = domain {
                        let x = xs[k];
                        if bad.is_none() && (x.cmplt(lo).any() || x.cmpgt(hi).any()) {
                            bad = Some(i);
                        }
                    }
                }
                (worst, bad)
            })
            .reduce(
                || (0.0, None),
                |a, b| (a.0.max(b.0), a.1.min(b.1).or(a.1).or(b.1)),
            );
        if let Some(i) = bad {
            let x = p.position[i];
            let time = self.time + dt;
            return Err(if x.is_finite() && p.velocity[i].is_finite() {
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
            });
        }
        Ok(max_d2.sqrt())
    }

    #[allow(clippy::needless_range_loop)]
    fn rebuild(&mut self) {
        let old_walls = std::mem::take(&mut self.walls);
        let old_start = std::mem::take(&mut self.wall_start);
        let reorder = self
            .neighbours
            .rebuild(&mut self.particles, self.cohesive_reach);
        let order = reorder.order.to_vec();
        self.index_of.resize(self.particles.len(), 0);
        for (k, &id) in self.particles.id.iter().enumerate() {
            self.index_of[id as usize] = k as u32;
        }

        let p = &self.particles;
        let n = p.len();
        let skin = self.params.skin + self.cohesive_reach;
        let geometries = &self.geometries;
        let blocks: Vec<(Vec<u32>, Vec<WallCandidate>)> = (0..n.div_ceil(BLOCK))
            .into_par_iter()
            .map(|b| {
                let mut counts = Vec::with_capacity(BLOCK);
                let mut cands = Vec::new();
                for k in b * BLOCK..((b + 1) * BLOCK).min(n) {
                    let before = cands.len();
                    let x = p.position[k];
                    let reach = p.radius[k] + skin;
                    let old = order[k] as usize;
                    let history: &[WallCandidate] = if old + 1 < old_start.len() {
                        &old_walls[old_start[old] as usize..old_start[old + 1] as usize]
                    } else {
                        &[]
                    };
                    let mut push = |g: usize, e: usize| {
                        let el = &geometries[g].elements[e];
                        if let Some(c) = el.closest(x, reach) {
                            if c.distance < reach {
                                let mut cand = WallCandidate {
                                    geometry: g as u16,
                                    element: e as u32,
                                    ..Default::default()
                                };
                                if let Some(h) = history
                                    .iter()
                                    .find(|h| h.geometry as usize == g && h.element as usize == e)
                                {
                                    cand.shear = h.shear;
                                    cand.rolling = h.rolling;
                                }
                                cands.push(cand);
                            }
                        }
                    };
                    for (g, geo) in geometries.iter().enumerate() {
                        visit_elements(geo, x, |e| push(g, e));
                    }
                    counts.push((cands.len() - before) as u32);
                }
                (counts, cands)
            })
            .collect();
        let mut start = Vec::with_capacity(n + 1);
        start.push(0u32);
        let mut walls = Vec::new();
        for (counts, cands) in blocks {
            for c in counts {
                start.push(start.last().unwrap() + c);
            }
            walls.extend(cands);
        }
        self.wall_output.clear();
        self.wall_output.resize(walls.len(), WallOutput::default());
        self.walls = walls;
        self.wall_start = start;

        self.poses_at_build = self
            .geometries
            .iter()
            .map(|g| (g.rotation, g.translation))
            .collect();
        self.bounds_at_build = self.particles.bounds(true);
    }

    /// Phase 1: each candidate pair computes its contact once, into its own output slot.
    fn pair_forces(&mut self) {
        let p = &self.particles;
        let materials = &self.materials;
        let dt = self.params.time_step;
        let rolling = self.params.rolling_model;
        let cohesive = self.cohesive_reach > 0.0;
        let clumps = !self.bodies.is_empty();
        let nl = &mut self.neighbours;
        nl.pairs
            .par_chunks_mut(BLOCK * 4)
            .zip(nl.output.par_chunks_mut(BLOCK * 4))
            .for_each(|(pairs, outs)| {
                for (pair, out) in pairs.iter_mut().zip(outs.iter_mut()) {
                    let (i, j) = (pair.i as usize, pair.j as usize);
                    if clumps && p.body[i] == p.body[j] && p.body[i] != NO_BODY {
                        // Members of one clump overlap by design.
                        *out = PairOutput::default();
                        continue;
                    }
                    let delta = p.position[i] - p.position[j];
                    let (ri, rj) = (p.radius[i], p.radius[j]);
                    let sum = ri + rj;
                    let dist2 = delta.length_squared();
                    let r_eff = ri * rj / sum;
                    // A cohesive (JKR) pair attracts until the gap reaches -d_c. Without any
                    // cohesion in the table, non-touching candidates leave before the lookup.
                    let reach = if cohesive {
                        let q = materials.pair(p.material[i] as usize, p.material[j] as usize);
                        sum - jkr_cutoff_overlap(q.surface_energy, q.e_star, r_eff)
                    } else {
                        sum
                    };
                    if dist2 >= reach * reach {
                        pair.shear = DVec3::ZERO;
                        pair.rolling = DVec3::ZERO;
                        *out = PairOutput::default();
                        continue;
                    }
                    let dist = dist2.sqrt();
                    let n = delta / dist;
                    let d = sum - dist;
                    let (ci, cj) = (ri - 0.5 * d, rj - 0.5 * d);
                    let (wi, wj) = (p.angular_velocity[i], p.angular_velocity[j]);
                    let m_eff = 1.0 / (p.inv_mass[i] + p.inv_mass[j]);
                    let params = materials.pair(p.material[i] as usize, p.material[j] as usize);
                    let cp = ContactPoint {
                        normal: n,
                        overlap: d,
                        r_eff,
                        m_eff,
                        v_rel: p.velocity[i] - p.velocity[j],
                        spin_lever: ci * wi + cj * wj,
                    };
                    let f = hertz_mindlin(params, &cp, &mut pair.shear, dt);
                    let nxf = n.cross(f.tangential);
                    let mut o = PairOutput {
                        force: f.normal * n + f.tangential,
                        torque_i: -ci * nxf,
                        torque_j: -cj * nxf,
                        rolling_i: 0.0,
                        rolling_j: 0.0,
                    };
                    match rolling {
                        RollingModel::ConstantDirectionalTorque => {
                            let m = params.rolling_friction * f.load.abs();
                            o.rolling_i = m * ci;
                            o.rolling_j = m * cj;
                        }
                        RollingModel::Epsd { viscous_damping } => {
                            let ai = p.mass[i] * ri * ri;
                            let aj = p.mass[j] * rj * rj;
                            let inertia = 1.4 * ai * aj / (ai + aj);
                            let t = epsd_rolling_torque(
                                params,
                                &f,
                                n,
                                r_eff,
                                inertia,
                                viscous_damping,
                                wi - wj,
                                &mut pair.rolling,
                                dt,
                            );
                            o.torque_i += t;
                            o.torque_j -= t;
                        }
                    }
                    *out = o;
                }
            });
    }

    /// Phase 2: per particle, sum pair slots, compute wall contacts, add gravity, second half kick.
    fn particle_forces(&mut self, kick: bool) {
        let half = 0.5 * self.params.time_step;
        let dt = self.params.time_step;
        let gravity = self.params.gravity;
        let rolling = self.params.rolling_model;
        let clumps = !self.bodies.is_empty();
        let nl = &self.neighbours;
        let materials = &self.materials;
        let geometries = &self.geometries;
        let wall_start = &self.wall_start;
        let walls = Shared(self.walls.as_mut_ptr());
        let wall_out = Shared(self.wall_output.as_mut_ptr());
        let p = &mut self.particles;
        let (position, radius, mass, inv_mass, inv_inertia, material, body) = (
            &p.position,
            &p.radius,
            &p.mass,
            &p.inv_mass,
            &p.inv_inertia,
            &p.material,
            &p.body,
        );
        p.force
            .par_chunks_mut(BLOCK)
            .zip(p.torque.par_chunks_mut(BLOCK))
            .zip(p.rolling_torque_limit.par_chunks_mut(BLOCK))
            .zip(p.velocity.par_chunks_mut(BLOCK))
            .zip(p.angular_velocity.par_chunks_mut(BLOCK))
            .enumerate()
            .for_each(|(b, ((((fs, ts), ls), vs), ws))| {
                for k in 0..fs.len() {
                    let i = b * BLOCK + k;
                    let mut f = gravity * mass[i];
                    let mut t = DVec3::ZERO;
                    let mut lim = 0.0;
                    for o in &nl.output[nl.row_start[i] as usize..nl.row_start[i + 1] as usize] {
                        f += o.force;
                        t += o.torque_i;
                        lim += o.rolling_i;
                    }
                    for &q in
                        &nl.reverse[nl.reverse_start[i] as usize..nl.reverse_start[i + 1] as usize]
                    {
                        let o = &nl.output[q as usize];
                        f -= o.force;
                        t += o.torque_j;
                        lim += o.rolling_j;
                    }
                    let (w0, w1) = (wall_start[i] as usize, wall_start[i + 1] as usize);
                    if w1 > w0 {
                        // SAFETY: candidate ranges of different particles are disjoint, and each
                        // particle is handled by exactly one task.
                        let cands =
                            unsafe { std::slice::from_raw_parts_mut(walls.ptr().add(w0), w1 - w0) };
                        let outs = unsafe {
                            std::slice::from_raw_parts_mut(wall_out.ptr().add(w0), w1 - w0)
                        };
                        let body = WallBody {
                            x: position[i],
                            v: vs[k],
                            w: ws[k],
                            r: radius[i],
                            m: mass[i],
                            material: material[i] as usize,
                        };
                        wall_contacts(
                            &body, cands, outs, geometries, materials, rolling, dt, &mut f, &mut t,
                            &mut lim,
                        );
                    }
                    fs[k] = f;
                    ts[k] = t;
                    ls[k] = lim;
                    if kick && (!clumps || body[i] == NO_BODY) {
                        vs[k] += f * (inv_mass[i] * half);
                        ws[k] = kick_spin(ws[k], t, lim, inv_inertia[i] * half);
                    }
                }
            });
    }

    fn geometry_loads(&mut self) {
        for g in &mut self.geometries {
            g.load = Load::default();
        }
        for (c, o) in self.walls.iter().zip(&self.wall_output) {
            if o.force != DVec3::ZERO {
                let l = &mut self.geometries[c.geometry as usize].load;
                l.force += o.force;
                l.torque += o.torque;
            }
        }
        for g in &mut self.geometries {
            let p = g.to_world(g.torque_point);
            g.load.torque -= p.cross(g.load.force);
        }
    }
}

/// Half kick of the spin with the constant-directional rolling torque applied implicitly: it opposes
/// the spin with magnitude `limit` but can at most bring the spin to rest, so particles at rest do not
/// jitter and a rolling resistance larger than the driving torque holds them exactly.
#[inline(always)]
/// Calls `f` with every element of `geo` that a sphere at `x` can reach (all of them when the
/// geometry has no search grid).
fn visit_elements(geo: &Geometry, x: DVec3, mut f: impl FnMut(usize)) {
    match &geo.grid {
        Some(grid) if grid.reach() > 0.0 => {
            let local = geo.rotation.transpose() * (x - geo.translation);
            for &e in grid.near(local) {
                f(e as usize);
            }
        }
        _ => (0..geo.elements.len()).for_each(f),
    }
}

fn kick_spin(w: DVec3, torque: DVec3, limit: f64, inv_inertia_half_dt: f64) -> DVec3 {
    let w = w + torque * inv_inertia_half_dt;
    if limit <= 0.0 {
        return w;
    }
    let brake = limit * inv_inertia_half_dt;
    let s2 = w.length_squared();
    if s2 <= brake * brake {
        DVec3::ZERO
    } else {
        w * (1.0 - brake / s2.sqrt())
    }
}

struct WallBody {
    x: DVec3,
    v: DVec3,
    w: DVec3,
    r: f64,
    m: f64,
    material: usize,
}

/// Contacts of one particle with its geometry candidates. Face contacts are taken first; an edge or
/// vertex contact is dropped when its point lies on a face already in contact or coincides with an
/// edge point already taken, so a sphere on a flat patch of triangles is pushed once.
#[allow(clippy::too_many_arguments)]
#[inline]
fn wall_contacts(
    body: &WallBody,
    cands: &mut [WallCandidate],
    outs: &mut [WallOutput],
    geometries: &[Geometry],
    materials: &MaterialTable,
    rolling: RollingModel,
    dt: f64,
    f: &mut DVec3,
    t: &mut DVec3,
    lim: &mut f64,
) {
    let mut accepted: SmallVec<[(usize, DVec3, Region); 8]> = SmallVec::new();
    let tol = 1e-9 + 1e-6 * body.r;
    for pass in [Region::Face, Region::Edge] {
        for k in 0..cands.len() {
            let geometry = cands[k].geometry;
            let g = &geometries[geometry as usize];
            let el = &g.elements[cands[k].element as usize];
            let params = materials.pair(body.material, g.material);
            let cutoff = jkr_cutoff_overlap(params.surface_energy, params.e_star, body.r);
            let Some(cl) = el.closest(body.x, body.r - cutoff) else {
                if pass == Region::Face {
                    cands[k].shear = DVec3::ZERO;
                    cands[k].rolling = DVec3::ZERO;
                    outs[k] = WallOutput::default();
                }
                continue;
            };
            if cl.region != pass {
                continue;
            }
            let d = body.r - cl.distance;
            if d <= cutoff {
                cands[k].shear = DVec3::ZERO;
                cands[k].rolling = DVec3::ZERO;
                outs[k] = WallOutput::default();
                continue;
            }
            if pass == Region::Face {
                // A centre right above an edge shared by two coplanar triangles sees the same face
                // point in both.
                let duplicate = accepted.iter().any(|&(a, q, _)| {
                    cands[a].geometry == geometry && (q - cl.point).length_squared() < tol * tol
                });
                if duplicate {
                    let c = &mut cands[k];
                    c.shear = DVec3::ZERO;
                    c.rolling = DVec3::ZERO;
                    outs[k] = WallOutput::default();
                    continue;
                }
            }
            if pass == Region::Edge {
                let duplicate = accepted.iter().any(|&(a, q, region)| {
                    if cands[a].geometry != geometry {
                        return false;
                    }
                    match region {
                        Region::Edge => (q - cl.point).length_squared() < tol * tol,
                        Region::Face => {
                            g.elements[cands[a].element as usize].distance_to(cl.point) < tol
                        }
                    }
                });
                let c = &mut cands[k];
                if duplicate {
                    c.shear = DVec3::ZERO;
                    c.rolling = DVec3::ZERO;
                    outs[k] = WallOutput::default();
                    continue;
                }
            }
            let c = &mut cands[k];
            accepted.push((k, cl.point, pass));
            let n = cl.normal;
            let ci = body.r - 0.5 * d;
            let contact_point = body.x - ci * n;
            let cp = ContactPoint {
                normal: n,
                overlap: d,
                r_eff: body.r,
                m_eff: body.m,
                v_rel: body.v - g.velocity.at(contact_point),
                spin_lever: ci * body.w,
            };
            let cf = hertz_mindlin(params, &cp, &mut c.shear, dt);
            let force = cf.normal * n + cf.tangential;
            let mut torque = -ci * n.cross(cf.tangential);
            let mut reaction_rolling = DVec3::ZERO;
            match rolling {
                RollingModel::ConstantDirectionalTorque => {
                    let m = params.rolling_friction * cf.load.abs() * ci;
                    *lim += m;
                    let s = body.w.length();
                    if s > 0.0 {
                        reaction_rolling = body.w * (m / s);
                    }
                }
                RollingModel::Epsd { viscous_damping } => {
                    let inertia = 1.4 * body.m * body.r * body.r;
                    let tr = epsd_rolling_torque(
                        params,
                        &cf,
                        n,
                        body.r,
                        inertia,
                        viscous_damping,
                        body.w - g.velocity.angular,
                        &mut c.rolling,
                        dt,
                    );
                    torque += tr;
                    reaction_rolling = -tr;
                }
            }
            *f += force;
            *t += torque;
            outs[k] = WallOutput {
                force: -force,
                // About the world origin; `geometry_loads` moves it to the torque point once per
                // geometry instead of once per contact.
                torque: contact_point.cross(-force) + reaction_rolling,
            };
        }
    }
}
