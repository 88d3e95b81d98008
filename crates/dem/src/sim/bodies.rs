//! The clump stages of the step: bodies are kicked and drifted before the spheres, their members
//! placed from the body's pose, and after the forces the members' forces and torques gathered onto
//! the body.

use super::Simulation;
use glam::DVec3;

impl Simulation {
    /// Clumps: half kick, drift, orientation update, then their members follow.
    pub(super) fn bodies_first_half(&mut self, dt: f64) {
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
    pub(super) fn place_members(&mut self, positions: bool) {
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
    pub(super) fn gather_bodies(&mut self) {
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
}
