//! The clump stages of the step: bodies are kicked and drifted before the spheres, their members
//! placed from the body's pose, and after the forces the members' forces and torques gathered onto
//! the body. Each runs in parallel over the bodies (a member belongs to one body, so the writes
//! are disjoint).

use super::Simulation;
use crate::parallel::Shared;
use glam::DVec3;
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
