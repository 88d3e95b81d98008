//! The clump stages of the step: bodies are kicked and drifted before the spheres, their members
//! placed from the body's pose, and after the forces the members' forces and torques gathered onto
//! the body. Each runs in parallel over the bodies (a member belongs to one body, so the writes
//! are disjoint).

use super::Simulation;
use crate::parallel::Shared;
use glam::{DQuat, DVec3};
use rayon::prelude::*;

/// Bodies per parallel task.
const BODY_BLOCK: usize = 256;

impl Simulation {
    /// Clumps: half kick, drift, orientation update, then their members follow.
    pub(super) fn bodies_first_half(&mut self, dt: f64) {
        self.bodies.kick_all(0.5 * dt, Some(dt));
        self.place_members(true);
    }

    /// Sets clump members' velocity and spin (and position when `positions`) from their body.
    pub(super) fn place_members(&mut self, positions: bool) {
        let p = &mut self.particles;
        let bodies = &self.bodies;
        let index_of = &self.index_of;
        let offset = &p.body_offset;
        let (x, v, w) = (
            Shared(p.position.as_mut_ptr()),
            Shared(p.velocity.as_mut_ptr()),
            Shared(p.angular_velocity.as_mut_ptr()),
        );
        (0..bodies.len())
            .into_par_iter()
            .with_min_len(BODY_BLOCK)
            .for_each(|b| {
                let rot = &bodies.rotation[b];
                let spin = rot.angular_velocity();
                for &id in &bodies.members[b] {
                    let k = index_of[id as usize] as usize;
                    let arm = rot.orientation * offset[k];
                    // SAFETY: a member belongs to one body, so member k is written by this task
                    // alone, and `offset` is another array.
                    unsafe {
                        if positions {
                            x.ptr().add(k).write(bodies.position[b] + arm);
                        }
                        v.ptr().add(k).write(bodies.velocity[b] + spin.cross(arm));
                        w.ptr().add(k).write(spin);
                    }
                }
            });
    }

    /// Sums members' forces and torques onto their bodies. A member's force includes gravity on
    /// the whole body's mass (it carries that mass for its contacts), so that is taken off and the
    /// body's weight added once.
    pub(super) fn gather_bodies(&mut self) {
        let p = &self.particles;
        let g = self.params.gravity;
        let index_of = &self.index_of;
        let bodies = &mut self.bodies;
        let (mass, position, members) = (&bodies.mass, &bodies.position, &bodies.members);
        bodies
            .force
            .par_iter_mut()
            .zip(bodies.torque.par_iter_mut())
            .zip(bodies.rolling_limit.par_iter_mut())
            .enumerate()
            .with_min_len(BODY_BLOCK)
            .for_each(|(b, ((force, torque), limit))| {
                let (mut f, mut t, mut lim) = (g * mass[b], DVec3::ZERO, 0.0);
                for &id in &members[b] {
                    let k = index_of[id as usize] as usize;
                    let contact = p.force[k] - g * p.mass[k];
                    f += contact;
                    t += (p.position[k] - position[b]).cross(contact) + p.torque[k];
                    lim += p.rolling_torque_limit[k];
                }
                *force = f;
                *torque = t;
                *limit = lim;
            });
    }
}

/// A segment's clumps, as the host hands them to the device ([`super::segment`]): each body's
/// state and its last force, and its members (particle indices) with their offsets in the body
/// frame. The device runs the clump stages of every step as the pipeline does (the first half:
/// kick, drift, turn, members placed; after the forces: members gathered, kick, members'
/// velocities).
#[derive(Clone, Debug, Default)]
pub struct SegmentBodies {
    pub position: Vec<DVec3>,
    pub velocity: Vec<DVec3>,
    pub orientation: Vec<DQuat>,
    pub angular_momentum: Vec<DVec3>,
    pub principal_inertia: Vec<DVec3>,
    pub mass: Vec<f64>,
    pub force: Vec<DVec3>,
    pub torque: Vec<DVec3>,
    pub rolling_limit: Vec<f64>,
    /// Body b's members are `members[member_start[b]..member_start[b + 1]]`, in the body's order.
    pub member_start: Vec<u32>,
    pub members: Vec<u32>,
    /// Each member's offset from its body's centre of mass, in the body frame.
    pub offset: Vec<DVec3>,
}

/// The clumps after a segment's last step.
#[derive(Clone, Debug, Default)]
pub struct SegmentBodiesEnd {
    pub position: Vec<DVec3>,
    pub velocity: Vec<DVec3>,
    pub orientation: Vec<DQuat>,
    pub angular_momentum: Vec<DVec3>,
    pub force: Vec<DVec3>,
    pub torque: Vec<DVec3>,
    pub rolling_limit: Vec<f64>,
}

impl Simulation {
    /// The clumps for a segment; None without clumps, or with polyhedra (whose contacts the
    /// device does not have) or a member not among the particles.
    pub(super) fn segment_bodies(&self) -> Option<SegmentBodies> {
        let b = &self.bodies;
        if b.is_empty() || b.polyhedra.any() {
            return None;
        }
        let mut member_start = vec![0u32];
        let mut members = Vec::new();
        let mut offset = Vec::new();
        for list in &b.members {
            for &id in list {
                let k = *self.index_of.get(id as usize)? as usize;
                members.push(k as u32);
                offset.push(*self.particles.body_offset.get(k)?);
            }
            member_start.push(members.len() as u32);
        }
        Some(SegmentBodies {
            position: b.position.clone(),
            velocity: b.velocity.clone(),
            orientation: b.rotation.iter().map(|r| r.orientation).collect(),
            angular_momentum: b.rotation.iter().map(|r| r.angular_momentum).collect(),
            principal_inertia: b.rotation.iter().map(|r| r.principal_inertia).collect(),
            mass: b.mass.clone(),
            force: b.force.clone(),
            torque: b.torque.clone(),
            rolling_limit: b.rolling_limit.clone(),
            member_start,
            members,
            offset,
        })
    }

    /// Takes back the clumps after a segment; Err when the device returned another count.
    pub(super) fn end_segment_bodies(&mut self, end: SegmentBodiesEnd) -> Result<(), String> {
        let b = &mut self.bodies;
        let n = b.len();
        let lens = [
            end.position.len(),
            end.velocity.len(),
            end.orientation.len(),
            end.angular_momentum.len(),
            end.force.len(),
            end.torque.len(),
            end.rolling_limit.len(),
        ];
        if lens.iter().any(|&l| l != n) {
            return Err(format!(
                "clump bodies: the device returned {lens:?} states for {n} clumps"
            ));
        }
        b.position = end.position;
        b.velocity = end.velocity;
        for (r, (q, l)) in b
            .rotation
            .iter_mut()
            .zip(end.orientation.into_iter().zip(end.angular_momentum))
        {
            r.orientation = q;
            r.angular_momentum = l;
        }
        b.force = end.force;
        b.torque = end.torque;
        b.rolling_limit = end.rolling_limit;
        Ok(())
    }
}
