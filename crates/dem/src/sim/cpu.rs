//! The CPU back end: each stage a rayon loop over blocks of particles or pairs. No atomics, no
//! locks, no allocation; every contact writes its own slot and every particle sums its slots in a
//! fixed order, so results do not depend on the number of threads.

use super::backend::{Anchors, Backend, Moved, StepInputs};
use super::walls::{wall_contacts, WallBody, WallLists, WallOutput};
use super::{SimulationParams, BLOCK};
use crate::contact::{evaluate, ContactLaw, ContactPoint, LawVisitor};
use crate::neighbour::{NeighbourList, PairOutput, PAIR_CHUNK};
use crate::parallel::Shared;
use crate::particles::{Particles, NO_BODY};
use crate::polyhedron::contact::{
    polyhedra_pair, polyhedron_sphere, polyhedron_wall_contacts, Kinematics,
};
use crate::polyhedron::PolyFrames;
use glam::DVec3;
use rayon::prelude::*;

/// Runs the stages on this machine's cores (in the rayon pool the caller installs).
#[derive(Clone, Copy, Debug, Default)]
pub struct CpuBackend;

impl Backend for CpuBackend {
    fn name(&self) -> &'static str {
        "cpu"
    }

    fn integrate(
        &self,
        p: &mut Particles,
        anchors: Anchors,
        params: &SimulationParams,
        clumps: bool,
    ) -> Result<Moved, usize> {
        let (built, near) = (anchors.build, anchors.near);
        let dt = params.time_step;
        let half = 0.5 * dt;
        let domain = params.domain;
        let (inv_mass, inv_inertia, force, torque, limit, body) = (
            &p.inv_mass,
            &p.inv_inertia,
            &p.force,
            &p.torque,
            &p.rolling_torque_limit,
            &p.body,
        );
        let (max_d2, max_near_d2, bad) = p
            .position
            .par_chunks_mut(BLOCK)
            .zip(p.velocity.par_chunks_mut(BLOCK))
            .zip(p.angular_velocity.par_chunks_mut(BLOCK))
            .enumerate()
            .map(|(b, ((xs, vs), ws))| {
                let base = b * BLOCK;
                let len = xs.len();
                // Slices of one length, so the loop below runs without bounds checks.
                let (vs, ws) = (&mut vs[..len], &mut ws[..len]);
                let (fs, ts, ls) = (
                    &force[base..][..len],
                    &torque[base..][..len],
                    &limit[base..][..len],
                );
                let (ims, iis, bs, at) = (
                    &inv_mass[base..][..len],
                    &inv_inertia[base..][..len],
                    &body[base..][..len],
                    &built[base..][..len],
                );
                let nears = near.map(|a| &a[base..][..len]);
                let mut worst: f64 = 0.0;
                let mut worst_near: f64 = 0.0;
                // Branch-free checks in the loop: a NaN or infinite displacement and the box
                // around the block's positions; the block is searched for the culprit only when
                // one of them fails.
                let mut finite = true;
                let mut lo = DVec3::INFINITY;
                let mut hi = DVec3::NEG_INFINITY;
                for k in 0..len {
                    // Clump members were moved with their bodies.
                    if !clumps || bs[k] == NO_BODY {
                        vs[k] += fs[k] * (ims[k] * half);
                        ws[k] = kick_spin(ws[k], ts[k], ls[k], iis[k] * half);
                        xs[k] += vs[k] * dt;
                    }
                    let d2 = (xs[k] - at[k]).length_squared();
                    finite &= d2.is_finite();
                    worst = if d2 > worst { d2 } else { worst };
                    if let Some(ns) = nears {
                        let d2 = (xs[k] - ns[k]).length_squared();
                        worst_near = if d2 > worst_near { d2 } else { worst_near };
                    }
                    lo = lo.min(xs[k]);
                    hi = hi.max(xs[k]);
                }
                let outside =
                    domain.is_some_and(|(dlo, dhi)| lo.cmplt(dlo).any() || hi.cmpgt(dhi).any());
                let bad = if finite && !outside {
                    None
                } else {
                    (0..len)
                        .find(|&k| {
                            let x = xs[k];
                            !(x - at[k]).length_squared().is_finite()
                                || domain.is_some_and(|(dlo, dhi)| {
                                    x.cmplt(dlo).any() || x.cmpgt(dhi).any()
                                })
                        })
                        .map(|k| base + k)
                };
                (worst, worst_near, bad)
            })
            .reduce(|| (0.0, 0.0, None), merge_checks);
        match bad {
            Some(i) => Err(i),
            None => Ok(moved(max_d2, max_near_d2, near.is_some())),
        }
    }

    fn pair_forces(&self, particles: &Particles, lists: &mut NeighbourList, inputs: &StepInputs) {
        inputs.params.contact_model.dispatch(PairStage {
            p: particles,
            nl: lists,
            inputs,
        });
    }

    fn wall_forces(&self, particles: &Particles, walls: &mut WallLists, inputs: &StepInputs) {
        if walls.candidates.is_empty() {
            return;
        }
        inputs.params.contact_model.dispatch(WallStage {
            p: particles,
            walls,
            inputs,
        });
    }

    fn particle_sums(
        &self,
        p: &mut Particles,
        nl: &NeighbourList,
        walls: &WallLists,
        inputs: &StepInputs,
        kick: bool,
    ) {
        sums_of_slots(p, nl, walls, inputs, kick, None);
    }

    fn wall_forces_and_sums(
        &self,
        p: &mut Particles,
        nl: &NeighbourList,
        walls: &mut WallLists,
        inputs: &StepInputs,
        kick: bool,
    ) {
        self.gather(p, nl, walls, inputs, kick, None);
    }

    fn gather_and_integrate(
        &self,
        p: &mut Particles,
        nl: &NeighbourList,
        walls: &mut WallLists,
        inputs: &StepInputs,
    ) -> Result<Moved, usize> {
        self.gather(p, nl, walls, inputs, true, Some(Anchors::of(nl)))
            .expect("the pass integrates when asked to")
    }
}

impl CpuBackend {
    /// The gather stage (see [`sums`]), with the wall contacts when there are geometries.
    fn gather(
        &self,
        p: &mut Particles,
        nl: &NeighbourList,
        walls: &mut WallLists,
        inputs: &StepInputs,
        kick: bool,
        ahead: Option<Anchors>,
    ) -> Option<Result<Moved, usize>> {
        if walls.candidates.is_empty() {
            return sums_of_slots(p, nl, walls, inputs, kick, ahead);
        }
        inputs.params.contact_model.dispatch(GatherStage {
            p,
            nl,
            walls,
            inputs,
            kick,
            ahead,
        })
    }
}

/// [`sums`] of the slots as they are, without computing any wall contact first (the wall slots
/// were written by the wall stage, or there are none).
fn sums_of_slots(
    p: &mut Particles,
    nl: &NeighbourList,
    walls: &WallLists,
    inputs: &StepInputs,
    kick: bool,
    ahead: Option<Anchors>,
) -> Option<Result<Moved, usize>> {
    // `sums` only reads the wall slots when it is given no `before` that writes them.
    let out = Shared(walls.output.as_ptr() as *mut WallOutput);
    let no_walls = |_: &Particles, _: usize, _: &Motion| {};
    sums(p, nl, out, &walls.start, inputs, kick, ahead, no_walls)
}

/// Merges two blocks' displacement checks: the larger squared displacements, the first culprit.
fn merge_checks(
    a: (f64, f64, Option<usize>),
    b: (f64, f64, Option<usize>),
) -> (f64, f64, Option<usize>) {
    (a.0.max(b.0), a.1.max(b.1), a.2.min(b.2).or(a.2).or(b.2))
}

/// The displacements from the largest squared ones (infinite since the near scan when there is
/// none to measure against).
fn moved(max_d2: f64, max_near_d2: f64, near: bool) -> Moved {
    Moved {
        since_build: max_d2.sqrt(),
        since_near: if near {
            max_near_d2.sqrt()
        } else {
            f64::INFINITY
        },
    }
}

/// A particle's position, velocity and spin as a stage began.
struct Motion {
    x: DVec3,
    v: DVec3,
    w: DVec3,
}

/// Each particle sums gravity, its pair slots (as i, then as j) and its wall slots, in that
/// fixed order, then gets the second half kick when `kick`. `before(p, i, motion)` runs first
/// for each particle with its state as the stage began (the fused gather stage computes the
/// particle's wall contacts there, into the particle's own wall slots).
///
/// With `ahead` (the positions at the last list build and near scan), the pass goes on into the
/// next step's half kick and drift ([`Backend::integrate`]) with the same force, the same
/// operations in the same order as that stage, and returns what it returns. This is sound
/// because nothing between the end of one step and the next one's integration reads or writes
/// the particles when the pipeline asks for it (no clumps, extensions or device segments).
#[allow(clippy::too_many_arguments)]
fn sums(
    p: &mut Particles,
    nl: &NeighbourList,
    wall_output: Shared<WallOutput>,
    wall_start: &[u32],
    inputs: &StepInputs,
    kick: bool,
    ahead: Option<Anchors>,
    before: impl Fn(&Particles, usize, &Motion) + Sync,
) -> Option<Result<Moved, usize>> {
    let params = inputs.params;
    let dt = params.time_step;
    let half = 0.5 * dt;
    let gravity = params.gravity;
    let clumps = inputs.clumps;
    let domain = params.domain;
    // The arrays this stage writes are taken out of the particles for the pass, so that the rest
    // (radii, masses, ...) can be read through a shared reference beside them.
    let mut position = std::mem::take(&mut p.position);
    let mut force = std::mem::take(&mut p.force);
    let mut torque = std::mem::take(&mut p.torque);
    let mut limit = std::mem::take(&mut p.rolling_torque_limit);
    let mut velocity = std::mem::take(&mut p.velocity);
    let mut spin = std::mem::take(&mut p.angular_velocity);
    let shared: &Particles = p;
    let near = ahead.and_then(|a| a.near);
    let (max_d2, max_near_d2, bad) = position
        .par_chunks_mut(BLOCK)
        .zip(force.par_chunks_mut(BLOCK))
        .zip(torque.par_chunks_mut(BLOCK))
        .zip(limit.par_chunks_mut(BLOCK))
        .zip(velocity.par_chunks_mut(BLOCK))
        .zip(spin.par_chunks_mut(BLOCK))
        .enumerate()
        .map(|(b, (((((xs, fs), ts), ls), vs), ws))| {
            let p = shared;
            let mut worst: f64 = 0.0;
            let mut worst_near: f64 = 0.0;
            let mut bad = None;
            for k in 0..fs.len() {
                let i = b * BLOCK + k;
                before(
                    p,
                    i,
                    &Motion {
                        x: xs[k],
                        v: vs[k],
                        w: ws[k],
                    },
                );
                let mut f = gravity * p.mass[i];
                let mut t = DVec3::ZERO;
                let mut lim = 0.0;
                // Inactive slots are zero (see `NeighbourList::active`): passing them by adds
                // nothing, so the sum is the same as over every slot.
                let row = nl.row_start[i] as usize..nl.row_start[i + 1] as usize;
                for (o, &a) in nl.output[row.clone()].iter().zip(&nl.active[row]) {
                    if a != 0 {
                        f += o.force;
                        t += o.torque_i;
                        lim += o.rolling_i;
                    }
                }
                for &q in
                    &nl.reverse[nl.reverse_start[i] as usize..nl.reverse_start[i + 1] as usize]
                {
                    if nl.active[q as usize] != 0 {
                        let o = &nl.output[q as usize];
                        f -= o.force;
                        t += o.torque_j;
                        lim += o.rolling_j;
                    }
                }
                let (w0, w1) = (wall_start[i] as usize, wall_start[i + 1] as usize);
                // SAFETY: this particle's wall slots were written (if at all) by `before` on
                // this task just now, and no other task touches them.
                let wall_slots =
                    unsafe { std::slice::from_raw_parts(wall_output.ptr().add(w0), w1 - w0) };
                for o in wall_slots {
                    f -= o.force;
                    t += o.particle_torque;
                    lim += o.rolling;
                }
                fs[k] = f;
                ts[k] = t;
                ls[k] = lim;
                let free = !clumps || p.body[i] == NO_BODY;
                if kick && free {
                    vs[k] += f * (p.inv_mass[i] * half);
                    ws[k] = kick_spin(ws[k], t, lim, p.inv_inertia[i] * half);
                }
                if let Some(Anchors { build: built, .. }) = ahead {
                    // The next step's integration, as `CpuBackend::integrate` does it.
                    if free {
                        vs[k] += f * (p.inv_mass[i] * half);
                        ws[k] = kick_spin(ws[k], t, lim, p.inv_inertia[i] * half);
                        xs[k] += vs[k] * dt;
                    }
                    let x = xs[k];
                    let d2 = (x - built[i]).length_squared();
                    worst = if d2 > worst { d2 } else { worst };
                    if let Some(anchor) = near {
                        let d2 = (x - anchor[i]).length_squared();
                        worst_near = if d2 > worst_near { d2 } else { worst_near };
                    }
                    let outside =
                        domain.is_some_and(|(lo, hi)| x.cmplt(lo).any() || x.cmpgt(hi).any());
                    if bad.is_none() && (!d2.is_finite() || outside) {
                        bad = Some(i);
                    }
                }
            }
            (worst, worst_near, bad)
        })
        .reduce(|| (0.0, 0.0, None), merge_checks);
    p.position = position;
    p.force = force;
    p.torque = torque;
    p.rolling_torque_limit = limit;
    p.velocity = velocity;
    p.angular_velocity = spin;
    ahead.map(|_| match bad {
        Some(i) => Err(i),
        None => Ok(moved(max_d2, max_near_d2, near.is_some())),
    })
}

/// The wall stage and the particle sums in one pass, compiled for one contact law: each particle
/// computes its wall contacts, then sums them with its pair slots.
struct GatherStage<'a> {
    p: &'a mut Particles,
    nl: &'a NeighbourList,
    walls: &'a mut WallLists,
    inputs: &'a StepInputs<'a>,
    kick: bool,
    ahead: Option<Anchors<'a>>,
}

impl LawVisitor for GatherStage<'_> {
    type Output = Option<Result<Moved, usize>>;

    fn visit<L: ContactLaw>(self, law: &L) -> Self::Output {
        let start = &self.walls.start;
        let cands = Shared(self.walls.candidates.as_mut_ptr());
        let outs = Shared(self.walls.output.as_mut_ptr());
        let inputs = self.inputs;
        let before = |p: &Particles, i: usize, m: &Motion| {
            let (w0, w1) = (start[i] as usize, start[i + 1] as usize);
            if w1 == w0 {
                return;
            }
            // SAFETY: candidate rows of different particles are disjoint and each particle is
            // handled by exactly one task.
            let cands = unsafe { std::slice::from_raw_parts_mut(cands.ptr().add(w0), w1 - w0) };
            let outs = unsafe { std::slice::from_raw_parts_mut(outs.ptr().add(w0), w1 - w0) };
            particle_walls(law, p, i, m, cands, outs, inputs);
        };
        sums(
            self.p, self.nl, outs, start, inputs, self.kick, self.ahead, before,
        )
    }
}

/// The pair stage compiled for one contact law.
struct PairStage<'a> {
    p: &'a Particles,
    nl: &'a mut NeighbourList,
    inputs: &'a StepInputs<'a>,
}

impl LawVisitor for PairStage<'_> {
    type Output = ();

    fn visit<L: ContactLaw>(self, law: &L) {
        let (p, inputs) = (self.p, self.inputs);
        let NeighbourList {
            pairs,
            output,
            active,
            near,
            ..
        } = self.nl;
        let use_near = near.usable();
        // A displacement measured by the integration serves this pair stage only.
        near.moved = f64::INFINITY;
        if use_near {
            let margin = near.margin;
            // Only the pairs that were near at the last scan can touch (see `NearList`).
            pairs
                .par_chunks_mut(PAIR_CHUNK)
                .zip(output.par_chunks_mut(PAIR_CHUNK))
                .zip(active.par_chunks_mut(PAIR_CHUNK))
                .zip(near.slots.par_chunks(PAIR_CHUNK))
                .zip(near.counts.par_iter())
                .for_each(|((((pairs, outs), actives), slots), &count)| {
                    for &q in &slots[..count as usize] {
                        let q = q as usize;
                        pair_contact(
                            law,
                            p,
                            &mut pairs[q],
                            &mut outs[q],
                            &mut actives[q],
                            inputs,
                            margin,
                        );
                    }
                });
            near.near_passes += 1;
            return;
        }
        // Every pair, noting the near ones when there is a margin. The buffers grow with the
        // list and are then reused.
        let margin = inputs.params.near_margin_fraction * inputs.params.skin;
        let record = margin > 0.0;
        near.current = false;
        near.full_passes += 1;
        let chunks = pairs.len().div_ceil(PAIR_CHUNK);
        if record {
            near.slots.resize(pairs.len(), 0);
            near.counts.resize(chunks, 0);
        }
        let (slots, counts) = (
            Shared(near.slots.as_mut_ptr()),
            Shared(near.counts.as_mut_ptr()),
        );
        pairs
            .par_chunks_mut(PAIR_CHUNK)
            .zip(output.par_chunks_mut(PAIR_CHUNK))
            .zip(active.par_chunks_mut(PAIR_CHUNK))
            .enumerate()
            .for_each(|(c, ((pairs, outs), actives))| {
                let mut count = 0;
                for (k, ((pair, out), active)) in
                    pairs.iter_mut().zip(outs).zip(actives).enumerate()
                {
                    let is_near = pair_contact(law, p, pair, out, active, inputs, margin);
                    if record && is_near {
                        // SAFETY: chunk c owns its stretch of the slots and its count.
                        unsafe { *slots.ptr().add(c * PAIR_CHUNK + count) = k as u16 };
                        count += 1;
                    }
                }
                if record {
                    // SAFETY: as above.
                    unsafe { *counts.ptr().add(c) = count as u32 };
                }
            });
        if record {
            near.anchor.resize(p.len(), DVec3::ZERO);
            near.anchor
                .par_chunks_mut(PAIR_CHUNK)
                .zip(p.position.par_chunks(PAIR_CHUNK))
                .for_each(|(a, x)| a.copy_from_slice(x));
            near.margin = margin;
            near.current = true;
        }
    }
}

/// One candidate pair: its contact into its output slot and history, or the slot cleared when
/// the two do not touch. Returns whether the pair is near: touching, or closer than `margin`
/// beyond touching (or beyond a cohesive law's reach).
#[inline(always)]
fn pair_contact<L: ContactLaw>(
    law: &L,
    p: &Particles,
    pair: &mut crate::neighbour::Pair,
    out: &mut PairOutput,
    active: &mut u8,
    inputs: &StepInputs,
    margin: f64,
) -> bool {
    let materials = inputs.materials;
    let dt = inputs.params.time_step;
    let rolling = inputs.params.rolling_model;
    let (i, j) = (pair.i as usize, pair.j as usize);
    if inputs.clumps && p.body[i] == p.body[j] && p.body[i] != NO_BODY {
        // Members of one clump overlap by design; their pair is never noted as near.
        clear(pair, out, active);
        return false;
    }
    let delta = p.position[i] - p.position[j];
    let (ri, rj) = (p.radius[i], p.radius[j]);
    let sum = ri + rj;
    let dist2 = delta.length_squared();
    // A cohesive (JKR) pair attracts until the gap reaches the law's cut-off. Without any
    // cohesion, non-touching candidates leave before the lookup (and before any division).
    let reach = if inputs.cohesive {
        let q = materials.pair(p.material[i] as usize, p.material[j] as usize);
        sum - law.cutoff_overlap(q, ri * rj / sum)
    } else {
        sum
    };
    if dist2 >= reach * reach {
        clear(pair, out, active);
        let near = reach + margin;
        return dist2 < near * near;
    }
    let r_eff = ri * rj / sum;
    if let Some(frames) = inputs.polyhedra {
        if let Some(o) = polyhedral_pair(
            law,
            rolling,
            p,
            i,
            j,
            frames,
            materials,
            &mut pair.history,
            dt,
        ) {
            *out = o;
            *active = 1;
            return true;
        }
    }
    let dist = dist2.sqrt();
    // One division, not three (the step is bound by divisions and square roots).
    let n = delta * (1.0 / dist);
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
    let inertia = || {
        let ai = p.mass[i] * ri * ri;
        let aj = p.mass[j] * rj * rj;
        1.4 * ai * aj / (ai + aj)
    };
    let c = evaluate(
        law,
        rolling,
        params,
        &cp,
        wi - wj,
        inertia,
        &mut pair.history,
        dt,
    );
    let nxf = n.cross(c.law.tangential);
    *active = 1;
    *out = PairOutput {
        force: c.force,
        torque_i: -ci * nxf + c.rolling_torque,
        torque_j: -cj * nxf - c.rolling_torque,
        rolling_i: c.rolling_resistance * ci,
        rolling_j: c.rolling_resistance * cj,
    };
    true
}

/// Clears a pair that does not touch, unless it was clear already (see
/// [`NeighbourList::active`]): its slots are then neither read nor written.
#[inline(always)]
fn clear(pair: &mut crate::neighbour::Pair, out: &mut PairOutput, active: &mut u8) {
    if *active != 0 {
        pair.history = Default::default();
        *out = PairOutput::default();
        *active = 0;
    }
}

/// The wall stage compiled for one contact law.
struct WallStage<'a> {
    p: &'a Particles,
    walls: &'a mut WallLists,
    inputs: &'a StepInputs<'a>,
}

impl LawVisitor for WallStage<'_> {
    type Output = ();

    fn visit<L: ContactLaw>(self, law: &L) {
        let p = self.p;
        let inputs = self.inputs;
        let start = &self.walls.start;
        let cands = Shared(self.walls.candidates.as_mut_ptr());
        let outs = Shared(self.walls.output.as_mut_ptr());
        (0..p.len().div_ceil(BLOCK)).into_par_iter().for_each(|b| {
            for i in b * BLOCK..((b + 1) * BLOCK).min(p.len()) {
                let (w0, w1) = (start[i] as usize, start[i + 1] as usize);
                if w1 == w0 {
                    continue;
                }
                // SAFETY: candidate rows of different particles are disjoint, and each particle is
                // handled by exactly one task.
                let cands = unsafe { std::slice::from_raw_parts_mut(cands.ptr().add(w0), w1 - w0) };
                let outs = unsafe { std::slice::from_raw_parts_mut(outs.ptr().add(w0), w1 - w0) };
                let m = Motion {
                    x: p.position[i],
                    v: p.velocity[i],
                    w: p.angular_velocity[i],
                };
                particle_walls(law, p, i, &m, cands, outs, inputs);
            }
        });
    }
}

/// The contacts of particle `i` (in the state `m`) with its geometry candidates, into their
/// slots.
#[inline]
fn particle_walls<L: ContactLaw>(
    law: &L,
    p: &Particles,
    i: usize,
    m: &Motion,
    cands: &mut [super::walls::WallCandidate],
    outs: &mut [WallOutput],
    inputs: &StepInputs,
) {
    let rolling = inputs.params.rolling_model;
    let dt = inputs.params.time_step;
    let (x, v, w) = (m.x, m.v, m.w);
    if let Some(frames) = inputs.polyhedra {
        if let Some(poly) = frames.placed(p.body[i], x) {
            polyhedron_wall_contacts(
                law,
                rolling,
                &poly,
                &Kinematics {
                    x,
                    v,
                    w,
                    m: p.mass[i],
                },
                p.material[i] as usize,
                cands,
                outs,
                inputs.geometries,
                inputs.materials,
                dt,
            );
            return;
        }
    }
    let body = WallBody {
        x,
        v,
        w,
        r: p.radius[i],
        m: p.mass[i],
        material: p.material[i] as usize,
    };
    wall_contacts(
        law,
        rolling,
        &body,
        cands,
        outs,
        inputs.geometries,
        inputs.materials,
        dt,
    );
}

fn kinematics(p: &Particles, i: usize) -> Kinematics {
    Kinematics {
        x: p.position[i],
        v: p.velocity[i],
        w: p.angular_velocity[i],
        m: p.mass[i],
    }
}

/// The contact of a candidate pair of which one or both are polyhedra (their proxies): `Some`
/// with its output (zero when they do not touch, history cleared), `None` when neither is a
/// polyhedron.
#[inline]
#[allow(clippy::too_many_arguments)]
fn polyhedral_pair<L: ContactLaw>(
    law: &L,
    rolling: crate::contact::RollingModel,
    p: &Particles,
    i: usize,
    j: usize,
    frames: &PolyFrames,
    materials: &crate::material::MaterialTable,
    history: &mut crate::contact::ContactHistory,
    dt: f64,
) -> Option<PairOutput> {
    let pi = frames.placed(p.body[i], p.position[i]);
    let pj = frames.placed(p.body[j], p.position[j]);
    if pi.is_none() && pj.is_none() {
        return None;
    }
    let params = materials.pair(p.material[i] as usize, p.material[j] as usize);
    let (ki, kj) = (kinematics(p, i), kinematics(p, j));
    let out = match (pi, pj) {
        (Some(a), Some(b)) => polyhedra_pair(law, rolling, params, &a, &ki, &b, &kj, history, dt),
        (Some(a), None) => polyhedron_sphere(
            law,
            rolling,
            params,
            &a,
            &ki,
            &kj,
            p.radius[j],
            true,
            history,
            dt,
        ),
        (None, Some(b)) => polyhedron_sphere(
            law,
            rolling,
            params,
            &b,
            &kj,
            &ki,
            p.radius[i],
            false,
            history,
            dt,
        ),
        (None, None) => unreachable!(),
    };
    Some(out.unwrap_or_else(|| {
        *history = Default::default();
        PairOutput::default()
    }))
}

/// Half kick of the spin with the constant-directional rolling torque applied implicitly: it opposes
/// the spin with magnitude `limit` but can at most bring the spin to rest, so particles at rest do not
/// jitter and a rolling resistance larger than the driving torque holds them exactly.
#[inline(always)]
pub fn kick_spin(w: DVec3, torque: DVec3, limit: f64, inv_inertia_half_dt: f64) -> DVec3 {
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
