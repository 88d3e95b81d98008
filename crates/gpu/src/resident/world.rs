//! One simulation's segment as the device runs it (a "world"), and a batch of worlds merged into
//! the arrays of one run.
//!
//! A [`World`] owns what a segment's kernels read, packed from the [`Segment`] on the thread that
//! runs the simulation; [`Merged`] lays several worlds side by side with their indices shifted
//! (particles, geometries, elements), so that the same launches step them all: a particle
//! carries its world, every world has its own parameter block (time step, gravity, domain,
//! rolling model, its own number of steps, its geometries and particles, where its material pair
//! table starts), the cell hash mixes in the world, the list builds skip other worlds, and a
//! world that has stopped is left out of them. A world's result does not depend on its neighbours in the batch: its lists hold the
//! same contacts (a larger reach or an extra rebuild only adds pairs apart, which add exact
//! zeros), and every particle sums its own contacts in the order of its own indices.

use dem::contact::ContactHistory;
use dem::geometry::Load;
use dem::neighbour::Pair;
use dem::sim::walls::WallCandidate;
use dem::sim::{Segment, SegmentEnd};

use super::bodies::{MergedBodies, WorldBodies};
use super::bonds::{MergedBonds, WorldBonds};
use super::{Capacity, EMPTY};
use crate::layout::{self, element, geometry, overflow};
use crate::pack::{
    block3, element_row, geometry_row, history_at, loads_of, numbers, pair_table, params_of,
    props_of, put_history, state_of, vec3_at,
};

/// One simulation's segment, packed for the device.
pub(crate) struct World {
    pub n: usize,
    /// `state`, `loads` and `props` in blocks of n (`layout`; the world block is 0 here).
    pub state: Vec<f64>,
    pub loads: Vec<f64>,
    pub props: Vec<f64>,
    pub material: Vec<u32>,
    pub body: Vec<u32>,
    /// Pair rows (CSR over the particles): j and the history.
    pub pair_start: Vec<u32>,
    pub pairs: Vec<(u32, ContactHistory)>,
    /// Wall rows (CSR): geometry, element, history.
    pub wall_start: Vec<u32>,
    pub walls: Vec<(u32, u32, ContactHistory)>,
    /// The material pair table (`layout::table`).
    pub table: Vec<f64>,
    /// Per geometry: its material, its first element, its velocity field at the start.
    pub geometry_material: Vec<u32>,
    pub geometry_first: Vec<usize>,
    pub geometry_velocity: Vec<[f64; 6]>,
    /// Every element's row at the segment's start (`layout::element`).
    pub elements: Vec<f64>,
    /// Geometries that move, their element rows after each step (`steps` times the rows of all
    /// the moving elements) and every geometry's velocity in each step.
    pub moving: Vec<usize>,
    pub element_track: Vec<f64>,
    pub velocity_track: Vec<[f64; 6]>,
    /// Whether geometry motion forces a rebuild at each step.
    pub forced: Vec<bool>,
    /// The parameter block (`layout::params`; a batch sets where its geometries, particles and
    /// table are).
    pub params: Vec<f64>,
    pub steps: u64,
    pub max_radius: f64,
    pub pair_reach: f64,
    pub wall_reach: f64,
    pub half_skin: f64,
    /// Longest pair or reverse row, longest wall row (for the first capacities).
    pub longest_row: usize,
    pub longest_wall: usize,
    /// The bonds that run with it (`dem::bond::segment`).
    pub bonds: Option<WorldBonds>,
    /// Its clumps (`dem::sim::SegmentBodies`).
    pub bodies: Option<WorldBodies>,
}

impl World {
    /// Packs a segment; None when its lists are not the shape the device expects.
    pub fn pack(seg: &Segment) -> Option<World> {
        let p = seg.particles;
        let n = p.len();
        let lists = seg.lists;
        if lists.row_start.len() != n + 1 || seg.wall_start.len() != n + 1 {
            return None;
        }
        let mut longest_reverse = vec![0usize; n];
        for q in &lists.pairs {
            longest_reverse[q.j as usize] += 1;
        }
        let longest_row = (0..n)
            .map(|i| (lists.row_start[i + 1] - lists.row_start[i]) as usize)
            .chain(longest_reverse)
            .max()
            .unwrap_or(0);
        let longest_wall = (0..n)
            .map(|i| (seg.wall_start[i + 1] - seg.wall_start[i]) as usize)
            .max()
            .unwrap_or(0);
        let inputs = &seg.inputs;
        let geometries = inputs.geometries;
        let track = seg.track;
        let mut elements: Vec<f64> = Vec::new();
        let mut geometry_first = Vec::with_capacity(geometries.len());
        for g in geometries {
            geometry_first.push(elements.len() / element::LEN);
            for e in &g.elements {
                elements.extend(element_row(e));
            }
        }
        // Moving geometries' elements at the start (the geometries hold them at the end).
        let mut at = 0;
        for &g in &track.moving {
            for k in 0..geometries[g].elements.len() {
                let row = element_row(&track.elements[0][at + k]);
                let e = geometry_first[g] + k;
                elements[element::LEN * e..element::LEN * (e + 1)].copy_from_slice(&row);
            }
            at += geometries[g].elements.len();
        }
        let field = |v: &dem::geometry::VelocityField| {
            [
                v.linear.x,
                v.linear.y,
                v.linear.z,
                v.angular.x,
                v.angular.y,
                v.angular.z,
            ]
        };
        let steps = seg.steps as usize;
        let (element_track, velocity_track) = if track.moving.is_empty() {
            (Vec::new(), Vec::new())
        } else {
            let e = track.elements[1..=steps]
                .iter()
                .flatten()
                .flat_map(element_row)
                .collect();
            let v = track.velocity[..steps]
                .iter()
                .flatten()
                .map(field)
                .collect();
            (e, v)
        };
        let params = inputs.params;
        let mut params_block = params_of(
            params,
            inputs.clumps,
            true,
            inputs.materials.len(),
            inputs.cohesive,
        );
        let bodies = match seg.bodies {
            Some(b) => Some(WorldBodies::pack(b, n)?),
            None => None,
        };
        // Clumps run with the segment only with their bodies.
        if inputs.clumps != bodies.is_some() {
            return None;
        }
        params_block[layout::params::STEPS] = seg.steps as f64;
        let bonds = match seg.bonds {
            Some(b) => Some(WorldBonds::pack(b, n)?),
            None => None,
        };
        if bonds.is_some() {
            params_block[layout::params::BONDS] = 1.0;
        }
        Some(World {
            n,
            state: state_of(p),
            loads: loads_of(p),
            props: props_of(p),
            material: p.material.iter().map(|&m| m as u32).collect(),
            body: p.body.clone(),
            pair_start: lists.row_start.clone(),
            pairs: lists.pairs.iter().map(|q| (q.j, q.history)).collect(),
            wall_start: seg.wall_start.to_vec(),
            walls: seg
                .wall_candidates
                .iter()
                .map(|w| (w.geometry as u32, w.element, w.history))
                .collect(),
            table: pair_table(inputs),
            geometry_material: geometries.iter().map(|g| g.material as u32).collect(),
            geometry_first,
            geometry_velocity: geometries.iter().map(|g| field(&g.velocity)).collect(),
            elements,
            moving: track.moving.clone(),
            element_track,
            velocity_track,
            forced: track.rebuild.clone(),
            params: params_block,
            steps: seg.steps,
            max_radius: p.radius.iter().cloned().fold(0.0, f64::max),
            pair_reach: seg.pair_reach,
            wall_reach: seg.wall_reach,
            half_skin: 0.5 * params.skin,
            longest_row,
            longest_wall,
            bonds,
            bodies,
        })
    }

    fn moving_elements(&self) -> usize {
        self.moving.iter().map(|&g| self.geometry_elements(g)).sum()
    }

    fn geometry_elements(&self, g: usize) -> usize {
        let end = self
            .geometry_first
            .get(g + 1)
            .copied()
            .unwrap_or(self.elements.len() / element::LEN);
        end - self.geometry_first[g]
    }
}

/// Where each world's items start in the merged arrays (materials stay the world's own: each
/// world's pair table has its own place in `table`).
#[derive(Clone, Copy, Default)]
pub(crate) struct Offsets {
    pub particle: usize,
    pub geometry: usize,
}

/// How a run of worlds ended: the list rebuilds of the whole run, each world's failing step (if
/// any), and the step at which an overflow ended the run early (if it did).
pub(crate) struct Ended<'a> {
    pub rebuilds: u64,
    pub failed: &'a [Option<u64>],
    pub stop: Option<u64>,
}

/// The host arrays of a batch's run, at given capacities.
pub(crate) struct Merged {
    pub n: usize,
    pub offsets: Vec<Offsets>,
    pub state: Vec<f64>,
    pub loads: Vec<f64>,
    pub props: Vec<f64>,
    pub ints: Vec<u32>,
    pub pair_ij: Vec<u32>,
    pub pair_history: Vec<f64>,
    pub cands: Vec<u32>,
    pub wall_history: Vec<f64>,
    /// Row begins and ends (pair, reverse, wall), then room for the reverse entries.
    pub rows: Vec<u32>,
    pub table: Vec<f64>,
    pub params: Vec<f64>,
    pub elements: Vec<f64>,
    /// The geometry rows (`layout::geometry`).
    pub geoms: Vec<f64>,
    /// Moving geometries (merged indices) and, per step, their elements and every geometry row.
    pub moving: Vec<(usize, usize)>,
    pub element_track: Vec<f64>,
    pub geoms_track: Vec<f64>,
    pub forced: Vec<u32>,
    /// The reaches of the list rebuilds (`layout::search`).
    pub search: [f64; layout::search::LEN],
    /// The worlds' bonds; None when none has any.
    pub bonds: Option<MergedBonds>,
    /// The worlds' clumps; None when none has any.
    pub bodies: Option<MergedBodies>,
}

/// An index shifted by a world's offset.
fn shift(v: usize, by: usize) -> u32 {
    (v + by) as u32
}

impl Merged {
    /// Lays `worlds` side by side with rows of `cap`; Err(code) when a row is longer than its
    /// capacity (an `overflow` code).
    pub fn new(worlds: &[World], cap: Capacity) -> Result<Merged, u32> {
        use layout::{cands, history, ints, loads, pair_ij, props, rows, search, state};
        let n: usize = worlds.iter().map(|w| w.n).sum();
        let steps = worlds.iter().map(|w| w.steps).max().unwrap_or(0) as usize;
        let mut offsets = Vec::with_capacity(worlds.len());
        let mut o = Offsets::default();
        let mut elements_count = 0;
        for w in worlds {
            offsets.push(o);
            o.particle += w.n;
            o.geometry += w.geometry_first.len();
            elements_count += w.elements.len() / element::LEN;
        }
        let geometries = o.geometry;
        let pairs = n * cap.pair;
        let walls = n * cap.wall;
        let mut m = Merged {
            n,
            offsets: offsets.clone(),
            state: vec![0.0; state::LEN * n],
            loads: vec![0.0; loads::LEN * n],
            props: vec![0.0; props::LEN * n],
            ints: vec![0; ints::LEN * n],
            pair_ij: vec![EMPTY; pair_ij::LEN * pairs],
            pair_history: vec![0.0; history::LEN * pairs],
            cands: vec![EMPTY; cands::LEN * walls],
            wall_history: vec![0.0; history::LEN * walls],
            rows: vec![0; rows::REVERSE_ENTRIES * n + pairs],
            table: Vec::with_capacity(worlds.iter().map(|w| w.table.len()).sum()),
            params: Vec::with_capacity(layout::params::LEN * worlds.len()),
            elements: Vec::with_capacity(element::LEN * elements_count),
            geoms: Vec::with_capacity(geometry::LEN * geometries),
            moving: Vec::new(),
            element_track: Vec::new(),
            geoms_track: Vec::new(),
            forced: vec![0; steps + 1],
            search: [0.0; search::LEN],
            bonds: MergedBonds::new(worlds, &offsets, n),
            bodies: MergedBodies::new(worlds, &offsets),
        };
        m.search[search::HALF_SKIN_SQUARED] = f64::INFINITY;
        let mut max_radius: f64 = 0.0;
        for (k, (w, off)) in worlds.iter().zip(&offsets).enumerate() {
            m.put_particles(k, w, off);
            m.put_rows(w, off, cap)?;
            m.put_geometries(w, off);
            for (s, &f) in w.forced.iter().enumerate().take(w.steps as usize) {
                if f {
                    m.forced[s] = 1;
                }
            }
            max_radius = max_radius.max(w.max_radius);
            let se = &mut m.search;
            se[search::PAIR_REACH] = se[search::PAIR_REACH].max(w.pair_reach);
            se[search::WALL_REACH] = se[search::WALL_REACH].max(w.wall_reach);
            se[search::HALF_SKIN_SQUARED] =
                se[search::HALF_SKIN_SQUARED].min(w.half_skin * w.half_skin);
        }
        m.search[search::INV_CELL] =
            1.0 / (1.01 * (2.0 * max_radius + m.search[search::PAIR_REACH]));
        if !m.moving.is_empty() {
            m.put_tracks(worlds, steps);
        }
        Ok(m)
    }

    /// World `k`'s particles at their place in the blocks of N.
    fn put_particles(&mut self, k: usize, w: &World, off: &Offsets) {
        use layout::{ints, loads, props, state};
        let (n, p0, nw) = (self.n, off.particle, w.n);
        for block in [state::POSITION, state::VELOCITY, state::ANGULAR_VELOCITY] {
            self.state[block * n + 3 * p0..block * n + 3 * (p0 + nw)]
                .copy_from_slice(&w.state[block * nw..block * nw + 3 * nw]);
        }
        for block in [loads::FORCE, loads::TORQUE] {
            self.loads[block * n + 3 * p0..block * n + 3 * (p0 + nw)]
                .copy_from_slice(&w.loads[block * nw..block * nw + 3 * nw]);
        }
        let block = loads::ROLLING_LIMIT;
        self.loads[block * n + p0..block * n + p0 + nw]
            .copy_from_slice(&w.loads[block * nw..(block + 1) * nw]);
        for block in [
            props::RADIUS,
            props::MASS,
            props::INV_MASS,
            props::INV_INERTIA,
        ] {
            self.props[block * n + p0..block * n + p0 + nw]
                .copy_from_slice(&w.props[block * nw..(block + 1) * nw]);
        }
        self.props[props::WORLD * n + p0..props::WORLD * n + p0 + nw].fill(k as f64);
        for i in 0..nw {
            self.ints[ints::MATERIAL * n + p0 + i] = w.material[i];
            self.ints[ints::BODY * n + p0 + i] = w.body[i];
        }
    }

    /// A world's pair and wall rows at their capacity; Err when one is longer.
    fn put_rows(&mut self, w: &World, off: &Offsets, cap: Capacity) -> Result<(), u32> {
        use layout::{cands, pair_ij, rows};
        let (n, p0) = (self.n, off.particle);
        for i in 0..w.n {
            let g = p0 + i;
            let (a, b) = (w.pair_start[i] as usize, w.pair_start[i + 1] as usize);
            if b - a > cap.pair {
                return Err(overflow::PAIR_ROW);
            }
            for (s, (j, h)) in w.pairs[a..b].iter().enumerate() {
                let q = g * cap.pair + s;
                self.pair_ij[pair_ij::LEN * q + pair_ij::I] = g as u32;
                self.pair_ij[pair_ij::LEN * q + pair_ij::J] = shift(*j as usize, p0);
                put_history(&mut self.pair_history, q, h);
            }
            self.rows[rows::PAIR_BEGIN * n + g] = (g * cap.pair) as u32;
            self.rows[rows::PAIR_END * n + g] = (g * cap.pair + b - a) as u32;
            let (a, b) = (w.wall_start[i] as usize, w.wall_start[i + 1] as usize);
            if b - a > cap.wall {
                return Err(overflow::WALL_ROW);
            }
            for (s, (geometry, element, h)) in w.walls[a..b].iter().enumerate() {
                let q = g * cap.wall + s;
                self.cands[cands::LEN * q + cands::GEOMETRY] =
                    shift(*geometry as usize, off.geometry);
                self.cands[cands::LEN * q + cands::ELEMENT] = *element;
                put_history(&mut self.wall_history, q, h);
            }
            self.rows[rows::WALL_BEGIN * n + g] = (g * cap.wall) as u32;
            self.rows[rows::WALL_END * n + g] = (g * cap.wall + b - a) as u32;
        }
        Ok(())
    }

    /// A world's params block, pair table, elements and geometries.
    fn put_geometries(&mut self, w: &World, off: &Offsets) {
        use layout::params as p;
        let mut params = w.params.clone();
        params[p::FIRST_GEOMETRY] = off.geometry as f64;
        params[p::END_GEOMETRY] = (off.geometry + w.geometry_first.len()) as f64;
        params[p::FIRST_PARTICLE] = off.particle as f64;
        params[p::END_PARTICLE] = (off.particle + w.n) as f64;
        params[p::TABLE] = self.table.len() as f64;
        self.params.extend(params);
        self.table.extend(&w.table);
        let first_element = self.elements.len() / element::LEN;
        self.elements.extend(&w.elements);
        for g in 0..w.geometry_first.len() {
            self.geoms.extend(geometry_row(
                w.geometry_material[g] as f64,
                (first_element + w.geometry_first[g]) as f64,
                w.geometry_velocity[g],
            ));
        }
        for &g in &w.moving {
            self.moving.push((off.geometry + g, w.geometry_elements(g)));
        }
    }

    /// Per step: the moving elements of every world (a world past its steps keeps its last
    /// pose) and every geometry's row.
    fn put_tracks(&mut self, worlds: &[World], steps: usize) {
        for s in 0..steps {
            for w in worlds.iter().filter(|w| !w.moving.is_empty()) {
                let rows = element::LEN * w.moving_elements();
                let at = s.min((w.steps as usize).saturating_sub(1));
                self.element_track
                    .extend(&w.element_track[rows * at..rows * (at + 1)]);
            }
            for (w, off) in worlds.iter().zip(&self.offsets) {
                for g in 0..w.geometry_first.len() {
                    let row = geometry::LEN * (off.geometry + g);
                    let v = if w.moving.is_empty() {
                        w.geometry_velocity[g]
                    } else {
                        let at = s.min((w.steps as usize).saturating_sub(1));
                        w.velocity_track[at * w.geometry_first.len() + g]
                    };
                    self.geoms_track.extend(geometry_row(
                        self.geoms[row + geometry::MATERIAL],
                        self.geoms[row + geometry::FIRST_ELEMENT],
                        v,
                    ));
                }
            }
        }
    }

    /// The rows of moving elements per step.
    pub fn moving_rows(&self) -> usize {
        self.moving.iter().map(|&(_, e)| e).sum()
    }

    /// The element each moving row of the element track goes to, in its order (empty without
    /// moving geometries: a binding of one zero).
    pub fn pose_table(&self) -> Vec<u32> {
        let table: Vec<u32> = self
            .moving
            .iter()
            .flat_map(|&(g, count)| {
                let first = self.geoms[geometry::LEN * g + geometry::FIRST_ELEMENT] as u32;
                first..first + count as u32
            })
            .collect();
        if table.is_empty() {
            vec![0]
        } else {
            table
        }
    }

    /// Each world's end from what the device held at the end: `out` is ctrl, state, loads, pair
    /// ij, the pair histories' even and odd halves, rows, wall candidates, wall history, geometry
    /// loads; `ended` how the run ended.
    pub fn split(
        &self,
        worlds: &[World],
        out: &[Vec<u8>],
        ended: Ended,
        bonds: Vec<Option<dem::bond::segment::SegmentBondsEnd>>,
        bodies: Vec<Option<dem::sim::SegmentBodiesEnd>>,
    ) -> Vec<SegmentEnd> {
        use layout::{cands, geometry_loads, loads, pair_ij, rows as r, state};
        let n = self.n;
        let s = numbers::<f64>(&out[1]);
        let l = numbers::<f64>(&out[2]);
        let ij = numbers::<u32>(&out[3]);
        let halves = [numbers::<f64>(&out[4]), numbers::<f64>(&out[5])];
        let rows = numbers::<u32>(&out[6]);
        let wc = numbers::<u32>(&out[7]);
        let wh = numbers::<f64>(&out[8]);
        let gl = numbers::<f64>(&out[9]);
        worlds
            .iter()
            .zip(&self.offsets)
            .zip(ended.failed)
            .zip(bonds)
            .zip(bodies)
            .map(|((((w, off), &failed_at), bonds), bodies)| {
                let range = off.particle..off.particle + w.n;
                let v = |buffer: &[f64], block: usize| {
                    range
                        .clone()
                        .map(|i| block3(buffer, block, n, i))
                        .collect::<Vec<_>>()
                };
                let limits = loads::ROLLING_LIMIT * n + off.particle;
                let mut end = SegmentEnd {
                    position: v(&s, state::POSITION),
                    velocity: v(&s, state::VELOCITY),
                    angular_velocity: v(&s, state::ANGULAR_VELOCITY),
                    force: v(&l, loads::FORCE),
                    torque: v(&l, loads::TORQUE),
                    rolling_torque_limit: l[limits..limits + w.n].to_vec(),
                    rebuilds: ended.rebuilds,
                    failed_at,
                    // Never past the world's steps (a failure found after its last step is
                    // the next step's), nor the step the state went back to when the run ended
                    // early.
                    steps_done: failed_at
                        .map_or(w.steps, |f| f + 1)
                        .min(w.steps)
                        .min(ended.stop.unwrap_or(u64::MAX)),
                    bonds,
                    bodies,
                    ..Default::default()
                };
                // The world's last step wrote its histories to the half of its steps' parity
                // (`history_halves.wgsl`).
                let ph: &[f64] = &halves[(end.steps_done % 2) as usize];
                for i in range.clone() {
                    let slots = rows[r::PAIR_BEGIN * n + i]..rows[r::PAIR_END * n + i];
                    for q in slots.start as usize..slots.end as usize {
                        let history = history_at(ph, q);
                        if !history.is_empty() {
                            end.pairs.push(Pair {
                                i: (i - off.particle) as u32,
                                j: ij[pair_ij::LEN * q + pair_ij::J] - off.particle as u32,
                                history,
                            });
                        }
                    }
                }
                end.wall_start.push(0);
                for i in range {
                    let slots = rows[r::WALL_BEGIN * n + i]..rows[r::WALL_END * n + i];
                    for c in slots.start as usize..slots.end as usize {
                        let history = history_at(&wh, c);
                        if !history.is_empty() {
                            let geometry = wc[cands::LEN * c + cands::GEOMETRY] as usize;
                            end.wall_candidates.push(WallCandidate {
                                geometry: (geometry - off.geometry) as u16,
                                element: wc[cands::LEN * c + cands::ELEMENT],
                                history,
                            });
                        }
                    }
                    end.wall_start.push(end.wall_candidates.len() as u32);
                }
                end.geometry_loads = (off.geometry..off.geometry + w.geometry_first.len())
                    .map(|g| Load {
                        force: vec3_at(&gl, geometry_loads::LEN * g + geometry_loads::FORCE),
                        torque: vec3_at(&gl, geometry_loads::LEN * g + geometry_loads::TORQUE),
                    })
                    .collect();
                end
            })
            .collect()
    }
}
