//! Particle-geometry contacts: the candidate list (built with the neighbour list, carrying each
//! candidate's history across rebuilds) and the contacts of one particle with its candidates.

use crate::contact::{evaluate, ContactHistory, ContactLaw, ContactPoint, RollingModel};
use crate::geometry::{Feature, Geometry};
use crate::material::MaterialTable;
use crate::parallel::Shared;
use crate::particles::Particles;
use glam::DVec3;
use rayon::prelude::*;
use smallvec::SmallVec;

/// A particle-geometry candidate with its contact history.
#[derive(Clone, Copy, Debug, Default)]
pub struct WallCandidate {
    pub geometry: u16,
    pub element: u32,
    pub history: ContactHistory,
}

/// What one particle-geometry contact contributes this step.
#[derive(Clone, Copy, Debug, Default)]
pub struct WallOutput {
    /// Force on the geometry (the particle gets the opposite).
    pub force: DVec3,
    /// Torque on the geometry about the world origin; `geometry_loads` moves it to the geometry's
    /// torque point once per geometry instead of once per contact.
    pub torque: DVec3,
    /// Torque on the particle about its centre.
    pub particle_torque: DVec3,
    /// Constant-directional rolling torque magnitude for the particle.
    pub rolling: f64,
}

/// Candidates in CSR rows over particles (`start[i]..start[i + 1]`) and their output slots.
/// The rows are only built here ([`WallLists::rebuild`]): the CPU back end hands each row to one
/// task as a mutable slice, which is sound only while rows are increasing and end at the
/// candidates' length, so other code reads them and writes slots but cannot change the rows.
#[derive(Clone, Default)]
pub struct WallLists {
    pub(crate) start: Vec<u32>,
    pub(crate) candidates: Vec<WallCandidate>,
    pub(crate) output: Vec<WallOutput>,
}

impl WallLists {
    /// Row starts: particle i's candidates are `start[i]..start[i + 1]`.
    pub fn start(&self) -> &[u32] {
        &self.start
    }

    pub fn candidates(&self) -> &[WallCandidate] {
        &self.candidates
    }

    /// Candidates with their history, for a back end to update in place.
    pub fn candidates_mut(&mut self) -> &mut [WallCandidate] {
        &mut self.candidates
    }

    pub fn output(&self) -> &[WallOutput] {
        &self.output
    }

    /// Output slots, for a back end to write.
    pub fn output_mut(&mut self) -> &mut [WallOutput] {
        &mut self.output
    }

    /// The candidates of particle `i`.
    pub fn row(&self, i: usize) -> std::ops::Range<usize> {
        self.start[i] as usize..self.start[i + 1] as usize
    }

    /// Rebuilds the candidates of every particle (particles already in their new order; `order[new]
    /// = old` maps to the rows of the old list, whose history is carried over).
    #[allow(clippy::needless_range_loop)]
    pub fn rebuild(
        &mut self,
        particles: &Particles,
        order: &[u32],
        geometries: &[Geometry],
        skin: f64,
    ) {
        let old_walls = std::mem::take(&mut self.candidates);
        let old_start = std::mem::take(&mut self.start);
        let p = particles;
        let n = p.len();
        let blocks: Vec<(Vec<u32>, Vec<WallCandidate>)> = (0..n.div_ceil(super::BLOCK))
            .into_par_iter()
            .map(|b| {
                let mut counts = Vec::with_capacity(super::BLOCK);
                let mut cands = Vec::new();
                for k in b * super::BLOCK..((b + 1) * super::BLOCK).min(n) {
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
                                    cand.history = h.history;
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
        // Each block's rows and candidates go in at the block's offset, in parallel.
        let mut offsets = Vec::with_capacity(blocks.len() + 1);
        offsets.push(0usize);
        for (_, cands) in &blocks {
            offsets.push(offsets.last().unwrap() + cands.len());
        }
        let total = *offsets.last().unwrap();
        let mut start = old_start;
        start.resize(n + 1, 0);
        start[n] = total as u32;
        let mut walls = old_walls;
        walls.resize(total, WallCandidate::default());
        let (rows, slots) = (Shared(start.as_mut_ptr()), Shared(walls.as_mut_ptr()));
        blocks
            .par_iter()
            .enumerate()
            .for_each(|(b, (counts, cands))| {
                let mut at = offsets[b];
                // SAFETY: rows b * BLOCK.. and slots offsets[b].. belong to this block alone.
                let dst =
                    unsafe { std::slice::from_raw_parts_mut(slots.ptr().add(at), cands.len()) };
                dst.copy_from_slice(cands);
                for (r, &c) in counts.iter().enumerate() {
                    unsafe { rows.ptr().add(b * super::BLOCK + r).write(at as u32) };
                    at += c as usize;
                }
            });
        self.output.clear();
        self.output
            .par_extend((0..total).into_par_iter().map(|_| WallOutput::default()));
        self.candidates = walls;
        self.start = start;
    }
}

/// Calls `f` with every element of `geo` that a sphere at `x` can reach (all of them when the
/// geometry has no search grid).
pub fn visit_elements(geo: &Geometry, x: DVec3, mut f: impl FnMut(usize)) {
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

/// The particle side of a wall contact.
pub struct WallBody {
    pub x: DVec3,
    pub v: DVec3,
    pub w: DVec3,
    pub r: f64,
    pub m: f64,
    pub material: usize,
}

/// Contacts of one particle with its geometry candidates. Face contacts are taken first; an edge or
/// vertex contact is dropped when its point lies on a face already in contact or coincides with an
/// edge point already taken, so a sphere on a flat patch of triangles is pushed once.
#[inline]
#[allow(clippy::too_many_arguments)]
pub fn wall_contacts<L: ContactLaw>(
    law: &L,
    rolling: RollingModel,
    body: &WallBody,
    cands: &mut [WallCandidate],
    outs: &mut [WallOutput],
    geometries: &[Geometry],
    materials: &MaterialTable,
    dt: f64,
) {
    let mut accepted: SmallVec<[(usize, DVec3, Feature); 8]> = SmallVec::new();
    let tol = 1e-9 + 1e-6 * body.r;
    for pass in [Feature::Face, Feature::Edge] {
        for k in 0..cands.len() {
            let geometry = cands[k].geometry;
            let g = &geometries[geometry as usize];
            let el = &g.elements[cands[k].element as usize];
            let params = materials.pair(body.material, g.material);
            let cutoff = law.cutoff_overlap(params, body.r);
            let Some(cl) = el.closest(body.x, body.r - cutoff) else {
                if pass == Feature::Face {
                    cands[k].history = ContactHistory::default();
                    outs[k] = WallOutput::default();
                }
                continue;
            };
            if cl.feature != pass {
                continue;
            }
            let d = body.r - cl.distance;
            let duplicate = d > cutoff
                && accepted.iter().any(|&(a, q, feature)| {
                    if cands[a].geometry != geometry {
                        return false;
                    }
                    match (pass, feature) {
                        // A centre right above an edge shared by two coplanar triangles sees the
                        // same face point in both.
                        (Feature::Face, _) | (Feature::Edge, Feature::Edge) => {
                            (q - cl.point).length_squared() < tol * tol
                        }
                        (Feature::Edge, Feature::Face) => {
                            g.elements[cands[a].element as usize].distance_to(cl.point) < tol
                        }
                    }
                });
            if d <= cutoff || duplicate {
                cands[k].history = ContactHistory::default();
                outs[k] = WallOutput::default();
                continue;
            }
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
            let c = evaluate(
                law,
                rolling,
                params,
                &cp,
                body.w - g.velocity.angular,
                || 1.4 * body.m * body.r * body.r,
                &mut cands[k].history,
                dt,
            );
            let rolling_limit = c.rolling_resistance * ci;
            // The reaction of the rolling resistance on the geometry: the epsd torque's opposite,
            // or the constant-directional torque against the particle's spin.
            let mut reaction_rolling = -c.rolling_torque;
            if rolling_limit > 0.0 {
                let s = body.w.length();
                if s > 0.0 {
                    reaction_rolling += body.w * (rolling_limit / s);
                }
            }
            outs[k] = WallOutput {
                force: -c.force,
                torque: contact_point.cross(-c.force) + reaction_rolling,
                particle_torque: -ci * n.cross(c.law.tangential) + c.rolling_torque,
                rolling: rolling_limit,
            };
        }
    }
}
