//! Particle state as a struct of arrays.
//!
//! The engine reorders particles by grid cell from time to time so that neighbours sit close in
//! memory; `id` keeps each particle's stable identity for output.

use glam::DVec3;
use rayon::prelude::*;
use std::f64::consts::PI;

#[derive(Clone, Debug, Default)]
pub struct Particles {
    /// Stable id (index at creation).
    pub id: Vec<u32>,
    pub position: Vec<DVec3>,
    pub velocity: Vec<DVec3>,
    pub angular_velocity: Vec<DVec3>,
    pub force: Vec<DVec3>,
    pub torque: Vec<DVec3>,
    /// Sum over contacts of the constant-directional rolling torque magnitude (applied against the
    /// spin when velocities are updated, see `Simulation`).
    pub rolling_torque_limit: Vec<f64>,
    pub radius: Vec<f64>,
    pub mass: Vec<f64>,
    pub inv_mass: Vec<f64>,
    pub inv_inertia: Vec<f64>,
    pub material: Vec<u16>,
    /// The clump a sphere belongs to ([`NO_BODY`] for a free sphere); see [`crate::clump::Bodies`].
    pub body: Vec<u32>,
    /// A clump member's centre in its body's frame (relative to the body's centre of mass).
    pub body_offset: Vec<DVec3>,
}

/// `body` of a sphere that is not part of a clump.
pub const NO_BODY: u32 = u32::MAX;

impl Particles {
    pub fn len(&self) -> usize {
        self.position.len()
    }

    pub fn is_empty(&self) -> bool {
        self.position.is_empty()
    }

    /// Appends a solid sphere.
    pub fn push(
        &mut self,
        position: DVec3,
        velocity: DVec3,
        radius: f64,
        density: f64,
        material: usize,
    ) {
        let mass = density * 4.0 / 3.0 * PI * radius.powi(3);
        let inertia = 0.4 * mass * radius * radius;
        self.id.push(self.position.len() as u32);
        self.position.push(position);
        self.velocity.push(velocity);
        self.angular_velocity.push(DVec3::ZERO);
        self.force.push(DVec3::ZERO);
        self.torque.push(DVec3::ZERO);
        self.rolling_torque_limit.push(0.0);
        self.radius.push(radius);
        self.mass.push(mass);
        self.inv_mass.push(1.0 / mass);
        self.inv_inertia.push(1.0 / inertia);
        self.material.push(material as u16);
        self.body.push(NO_BODY);
        self.body_offset.push(DVec3::ZERO);
    }

    /// Reorders every array so that new index k holds old particle `order[k]`, in parallel.
    /// `scratch` is reused for every array, so a reorder allocates nothing after warm-up.
    pub fn permute(&mut self, order: &[u32], scratch: &mut Vec<u64>) {
        fn apply<T: Copy + Send + Sync>(v: &mut [T], order: &[u32], scratch: &mut Vec<u64>) {
            let words = (std::mem::size_of_val(v)).div_ceil(8);
            if scratch.len() < words {
                scratch.resize(words, 0);
            }
            // SAFETY: the scratch words are initialised, 8-byte aligned (enough for every field
            // type here) and cover `v.len()` values of T; the fields are plain numbers, for
            // which any bits are a value, and every slot is written before it is read.
            let tmp =
                unsafe { std::slice::from_raw_parts_mut(scratch.as_mut_ptr() as *mut T, v.len()) };
            crate::parallel::gather(v, order, tmp);
            v.par_chunks_mut(crate::parallel::CHUNK)
                .zip(tmp.par_chunks(crate::parallel::CHUNK))
                .for_each(|(a, b)| a.copy_from_slice(b));
        }
        apply(&mut self.id, order, scratch);
        apply(&mut self.position, order, scratch);
        apply(&mut self.velocity, order, scratch);
        apply(&mut self.angular_velocity, order, scratch);
        apply(&mut self.force, order, scratch);
        apply(&mut self.torque, order, scratch);
        apply(&mut self.rolling_torque_limit, order, scratch);
        apply(&mut self.radius, order, scratch);
        apply(&mut self.mass, order, scratch);
        apply(&mut self.inv_mass, order, scratch);
        apply(&mut self.inv_inertia, order, scratch);
        apply(&mut self.material, order, scratch);
        apply(&mut self.body, order, scratch);
        apply(&mut self.body_offset, order, scratch);
    }

    /// Axis-aligned box around the centres, grown by each radius when `with_radius`.
    pub fn bounds(&self, with_radius: bool) -> (DVec3, DVec3) {
        crate::parallel::bounds(&self.position, with_radius.then_some(&self.radius[..]))
    }

    /// Translational plus rotational kinetic energy.
    /// Kinetic energy of the free spheres (clumps: [`crate::Simulation::kinetic_energy`]).
    pub fn kinetic_energy(&self) -> f64 {
        (0..self.len())
            .filter(|&k| self.body[k] == NO_BODY)
            .map(|k| {
                0.5 * self.mass[k] * self.velocity[k].length_squared()
                    + 0.5 * self.angular_velocity[k].length_squared() / self.inv_inertia[k]
            })
            .sum()
    }

    /// Mass of the free spheres (a clump member carries its whole body's mass for its contacts).
    pub fn total_mass(&self) -> f64 {
        (0..self.len())
            .filter(|&k| self.body[k] == NO_BODY)
            .map(|k| self.mass[k])
            .sum()
    }
}
