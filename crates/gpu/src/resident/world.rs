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

use super::{history_at, put_history, Capacity, EMPTY};
use crate::{block, element_row, flat, pair_table, params_of, vec3_at, PARAMS};

/// One simulation's segment, packed for the device.
pub(crate) struct World {
    pub n: usize,
    /// Position, velocity, angular velocity (3n each).
    pub state: Vec<f64>,
    /// Force, torque (3n each), rolling torque limit (n).
    pub loads: Vec<f64>,
    /// Radius, mass, inverse mass, inverse inertia (n each).
    pub props: Vec<f64>,
    pub material: Vec<u32>,
    pub body: Vec<u32>,
    /// Pair rows (CSR over the particles): j and the history.
    pub pair_start: Vec<u32>,
    pub pairs: Vec<(u32, ContactHistory)>,
    /// Wall rows (CSR): geometry, element, history.
    pub wall_start: Vec<u32>,
    pub walls: Vec<(u32, u32, ContactHistory)>,
    /// The material pair table (7 numbers a pair).
    pub table: Vec<f64>,
    /// Per geometry: its material, its first element, its velocity field at the start.
    pub geometry_material: Vec<u32>,
    pub geometry_first: Vec<usize>,
    pub geometry_velocity: Vec<[f64; 6]>,
    /// Every element at the segment's start, 16 numbers each.
    pub elements: Vec<f64>,
    /// Geometries that move, their elements after each step (16 numbers each, `steps` rows of
    /// all the moving elements) and every geometry's velocity in each step.
    pub moving: Vec<usize>,
    pub element_track: Vec<f64>,
    pub velocity_track: Vec<[f64; 6]>,
    /// Whether geometry motion forces a rebuild at each step.
    pub forced: Vec<bool>,
    /// The parameter block (PARAMS numbers; a batch sets where its geometries, particles and
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
            geometry_first.push(elements.len() / 16);
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
                elements[16 * e..16 * e + 16].copy_from_slice(&row);
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
        let mut params_block =
            params_of(params, false, true, inputs.materials.len(), inputs.cohesive);
        params_block[block::STEPS] = seg.steps as f64;
        Some(World {
            n,
            state: flat(&[&p.position, &p.velocity, &p.angular_velocity]),
            loads: {
                let mut l = flat(&[&p.force, &p.torque]);
                l.extend(&p.rolling_torque_limit);
                l
            },
            props: [&p.radius, &p.mass, &p.inv_mass, &p.inv_inertia]
                .into_iter()
                .flat_map(|v| v.iter().copied())
                .collect(),
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
            .unwrap_or(self.elements.len() / 16);
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
    /// 8 numbers a geometry: material, first element, velocity field.
    pub geoms: Vec<f64>,
    /// Moving geometries (merged indices) and, per step, their elements and every geometry row.
    pub moving: Vec<(usize, usize)>,
    pub element_track: Vec<f64>,
    pub geoms_track: Vec<f64>,
    pub forced: Vec<u32>,
    /// Inverse cell size, pair reach, wall reach, (half the skin) squared.
    pub search: [f64; 4],
}

/// An index shifted by a world's offset.
fn shift(v: usize, by: usize) -> u32 {
    (v + by) as u32
}

impl Merged {
    /// Lays `worlds` side by side with rows of `cap`; Err(code) when a row is longer than its
    /// capacity (the overflow codes of `ctrl[3]`).
    pub fn new(worlds: &[World], cap: Capacity) -> Result<Merged, u32> {
        let n: usize = worlds.iter().map(|w| w.n).sum();
        let steps = worlds.iter().map(|w| w.steps).max().unwrap_or(0) as usize;
        let mut offsets = Vec::with_capacity(worlds.len());
        let mut o = Offsets::default();
        let mut elements_count = 0;
        for w in worlds {
            offsets.push(o);
            o.particle += w.n;
            o.geometry += w.geometry_first.len();
            elements_count += w.elements.len() / 16;
        }
        let geometries = o.geometry;
        let pairs = n * cap.pair;
        let walls = n * cap.wall;
        let mut m = Merged {
            n,
            offsets: offsets.clone(),
            state: vec![0.0; 9 * n],
            loads: vec![0.0; 7 * n],
            props: vec![0.0; 5 * n],
            ints: vec![0; 2 * n],
            pair_ij: vec![EMPTY; 2 * pairs],
            pair_history: vec![0.0; 6 * pairs],
            cands: vec![EMPTY; 2 * walls],
            wall_history: vec![0.0; 6 * walls],
            rows: vec![0; 6 * n + pairs],
            table: Vec::with_capacity(worlds.iter().map(|w| w.table.len()).sum()),
            params: Vec::with_capacity(PARAMS * worlds.len()),
            elements: Vec::with_capacity(16 * elements_count),
            geoms: Vec::with_capacity(8 * geometries),
            moving: Vec::new(),
            element_track: Vec::new(),
            geoms_track: Vec::new(),
            forced: vec![0; steps + 1],
            search: [0.0, 0.0, 0.0, f64::INFINITY],
        };
        let mut max_radius: f64 = 0.0;
        for (k, (w, off)) in worlds.iter().zip(&offsets).enumerate() {
            let (p0, nw) = (off.particle, w.n);
            // Blocks of 3n, 3n, 3n (state), 3n, 3n, n (loads), n x 4 (props).
            for b in 0..3 {
                m.state[3 * (b * n + p0)..3 * (b * n + p0 + nw)]
                    .copy_from_slice(&w.state[3 * b * nw..3 * (b + 1) * nw]);
            }
            for b in 0..2 {
                m.loads[3 * (b * n + p0)..3 * (b * n + p0 + nw)]
                    .copy_from_slice(&w.loads[3 * b * nw..3 * (b + 1) * nw]);
            }
            m.loads[6 * n + p0..6 * n + p0 + nw].copy_from_slice(&w.loads[6 * nw..7 * nw]);
            for b in 0..4 {
                m.props[b * n + p0..b * n + p0 + nw]
                    .copy_from_slice(&w.props[b * nw..(b + 1) * nw]);
            }
            m.props[4 * n + p0..4 * n + p0 + nw].fill(k as f64);
            for i in 0..nw {
                m.ints[p0 + i] = w.material[i];
                m.ints[n + p0 + i] = w.body[i];
            }
            // Pair and wall rows at their capacity.
            for i in 0..nw {
                let g = p0 + i;
                let (a, b) = (w.pair_start[i] as usize, w.pair_start[i + 1] as usize);
                if b - a > cap.pair {
                    return Err(2);
                }
                for (s, (j, h)) in w.pairs[a..b].iter().enumerate() {
                    let q = g * cap.pair + s;
                    m.pair_ij[2 * q] = g as u32;
                    m.pair_ij[2 * q + 1] = shift(*j as usize, p0);
                    put_history(&mut m.pair_history, q, h);
                }
                m.rows[g] = (g * cap.pair) as u32;
                m.rows[n + g] = (g * cap.pair + b - a) as u32;
                let (a, b) = (w.wall_start[i] as usize, w.wall_start[i + 1] as usize);
                if b - a > cap.wall {
                    return Err(4);
                }
                for (s, (geometry, element, h)) in w.walls[a..b].iter().enumerate() {
                    let q = g * cap.wall + s;
                    m.cands[2 * q] = shift(*geometry as usize, off.geometry);
                    m.cands[2 * q + 1] = *element;
                    put_history(&mut m.wall_history, q, h);
                }
                m.rows[4 * n + g] = (g * cap.wall) as u32;
                m.rows[5 * n + g] = (g * cap.wall + b - a) as u32;
            }
            let mut params = w.params.clone();
            params[block::FIRST_GEOMETRY] = off.geometry as f64;
            params[block::END_GEOMETRY] = (off.geometry + w.geometry_first.len()) as f64;
            params[block::FIRST_PARTICLE] = p0 as f64;
            params[block::END_PARTICLE] = (p0 + nw) as f64;
            params[block::TABLE] = m.table.len() as f64;
            m.params.extend(params);
            m.table.extend(&w.table);
            let first_element = m.elements.len() / 16;
            m.elements.extend(&w.elements);
            for g in 0..w.geometry_first.len() {
                m.geoms.extend([
                    w.geometry_material[g] as f64,
                    (first_element + w.geometry_first[g]) as f64,
                ]);
                m.geoms.extend(w.geometry_velocity[g]);
            }
            for &g in &w.moving {
                m.moving.push((off.geometry + g, w.geometry_elements(g)));
            }
            for (s, &f) in w.forced.iter().enumerate().take(w.steps as usize) {
                if f {
                    m.forced[s] = 1;
                }
            }
            max_radius = max_radius.max(w.max_radius);
            m.search[1] = m.search[1].max(w.pair_reach);
            m.search[2] = m.search[2].max(w.wall_reach);
            m.search[3] = m.search[3].min(w.half_skin * w.half_skin);
        }
        m.search[0] = 1.0 / (1.01 * (2.0 * max_radius + m.search[1]));
        // Per step: the moving elements of every world (a world past its steps keeps its last
        // pose) and every geometry's row.
        if !m.moving.is_empty() {
            for s in 0..steps {
                for w in worlds.iter().filter(|w| !w.moving.is_empty()) {
                    let rows = w.moving_elements();
                    let at = s.min((w.steps as usize).saturating_sub(1));
                    m.element_track
                        .extend(&w.element_track[16 * rows * at..16 * rows * (at + 1)]);
                }
                for (w, off) in worlds.iter().zip(&offsets) {
                    for g in 0..w.geometry_first.len() {
                        let row = 8 * (off.geometry + g);
                        m.geoms_track.extend(&m.geoms[row..row + 2]);
                        let v = if w.moving.is_empty() {
                            w.geometry_velocity[g]
                        } else {
                            let at = s.min((w.steps as usize).saturating_sub(1));
                            w.velocity_track[at * w.geometry_first.len() + g]
                        };
                        m.geoms_track.extend(v);
                    }
                }
            }
        }
        Ok(m)
    }

    /// The rows of moving elements per step.
    pub fn moving_rows(&self) -> usize {
        self.moving.iter().map(|&(_, e)| e).sum()
    }

    /// Each world's end from what the device held at the end: `out` is ctrl, state, loads, pair
    /// ij, pair history, rows, wall candidates, wall history, geometry loads.
    pub fn split(
        &self,
        worlds: &[World],
        out: &[Vec<u8>],
        rebuilds: u64,
        failed: &[Option<u64>],
    ) -> Vec<SegmentEnd> {
        let n = self.n;
        let s: Vec<f64> = bytemuck::pod_collect_to_vec(&out[1]);
        let l: Vec<f64> = bytemuck::pod_collect_to_vec(&out[2]);
        let ij: Vec<u32> = bytemuck::pod_collect_to_vec(&out[3]);
        let ph: Vec<f64> = bytemuck::pod_collect_to_vec(&out[4]);
        let rows: Vec<u32> = bytemuck::pod_collect_to_vec(&out[5]);
        let cands: Vec<u32> = bytemuck::pod_collect_to_vec(&out[6]);
        let wh: Vec<f64> = bytemuck::pod_collect_to_vec(&out[7]);
        let gl: Vec<f64> = bytemuck::pod_collect_to_vec(&out[8]);
        worlds
            .iter()
            .zip(&self.offsets)
            .zip(failed)
            .map(|((w, off), &failed_at)| {
                let range = off.particle..off.particle + w.n;
                let v = |block: &[f64], base: usize| {
                    range
                        .clone()
                        .map(|i| vec3_at(block, base + 3 * i))
                        .collect::<Vec<_>>()
                };
                let mut end = SegmentEnd {
                    position: v(&s, 0),
                    velocity: v(&s, 3 * n),
                    angular_velocity: v(&s, 6 * n),
                    force: v(&l, 0),
                    torque: v(&l, 3 * n),
                    rolling_torque_limit: l[6 * n + off.particle..6 * n + off.particle + w.n]
                        .to_vec(),
                    rebuilds,
                    failed_at,
                    steps_done: failed_at.map_or(w.steps, |f| f + 1),
                    ..Default::default()
                };
                for i in range.clone() {
                    for q in rows[i] as usize..rows[n + i] as usize {
                        let history = history_at(&ph, q);
                        if !history.is_empty() {
                            end.pairs.push(Pair {
                                i: (i - off.particle) as u32,
                                j: ij[2 * q + 1] - off.particle as u32,
                                history,
                            });
                        }
                    }
                }
                end.wall_start.push(0);
                for i in range {
                    for c in rows[4 * n + i] as usize..rows[5 * n + i] as usize {
                        let history = history_at(&wh, c);
                        if !history.is_empty() {
                            end.wall_candidates.push(WallCandidate {
                                geometry: (cands[2 * c] as usize - off.geometry) as u16,
                                element: cands[2 * c + 1],
                                history,
                            });
                        }
                    }
                    end.wall_start.push(end.wall_candidates.len() as u32);
                }
                end.geometry_loads = (off.geometry..off.geometry + w.geometry_first.len())
                    .map(|g| Load {
                        force: vec3_at(&gl, 6 * g),
                        torque: vec3_at(&gl, 6 * g + 3),
                    })
                    .collect();
                end
            })
            .collect()
    }
}
