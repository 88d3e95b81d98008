//! Bonds run by a back end's device inside a segment of steps ([`crate::sim::segment`]): what the
//! host hands over ([`SegmentBonds`]) and what it takes back ([`SegmentBondsEnd`]).
//!
//! The device updates every intact bond each step with the arithmetic of `kernel::update_bond`,
//! tests breakage, and adds the bonds' forces to their spheres in the order the host does (each
//! sphere its own bonds, in bond order, after its contacts and gravity; then local damping and
//! the second half kick). A bond that breaks records the step and its mid-point; the host then
//! logs the breakages by step, and within a step by the bonds' stable ids, as a step by step run
//! logs them, with the stresses read from the state the device left (a broken bond is not
//! updated again).

use glam::DVec3;

use super::kernel::Section;
use super::{BondOutput, BondParams, BondState, Bonds, BreakMode, Breakage};

/// Numbers of a bond's state: normal force, shear force (3), twist, bending moment (3), axis (3).
pub const STATE_LEN: usize = 11;
/// Numbers of a bond's output: force on the first sphere (3), torque on the first (3), on the
/// second (3).
pub const OUTPUT_LEN: usize = 9;

/// A segment's bonds, as the host hands them to the device.
#[derive(Clone, Debug, Default)]
pub struct SegmentBonds {
    /// Parameters of each bond kind.
    pub params: Vec<BondParams>,
    /// Per bond: the indices of its first and second sphere among the segment's particles.
    pub ends: Vec<[u32; 2]>,
    pub kind: Vec<u16>,
    /// The bond radius R_B (m).
    pub radius: Vec<f64>,
    /// The bond's own factor on k_n and k_t (the stiffness range).
    pub stiffness: Vec<f64>,
    pub intact: Vec<bool>,
    pub state: Vec<[f64; STATE_LEN]>,
    /// Each particle's bonds (compressed rows over the particle indices): `2 b` where it is bond
    /// b's first sphere, `2 b + 1` its second, in bond order (the order the host sums them).
    pub row_start: Vec<u32>,
    pub slots: Vec<u32>,
}

/// A bond that broke in a segment.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SegmentBreakage {
    /// The step (0-based within the segment) in which it broke.
    pub step: u64,
    pub bond: usize,
    /// Its mid-point then.
    pub position: DVec3,
}

/// What the device did with a segment's bonds.
#[derive(Clone, Debug, Default)]
pub struct SegmentBondsEnd {
    pub state: Vec<[f64; STATE_LEN]>,
    pub output: Vec<[f64; OUTPUT_LEN]>,
    /// The bonds that broke, in any order.
    pub breakages: Vec<SegmentBreakage>,
}

fn state_row(s: &BondState) -> [f64; STATE_LEN] {
    let (f, b, a) = (s.shear_force, s.bending, s.axis);
    [
        s.normal_force,
        f.x,
        f.y,
        f.z,
        s.twist,
        b.x,
        b.y,
        b.z,
        a.x,
        a.y,
        a.z,
    ]
}

fn state_of(r: &[f64; STATE_LEN]) -> BondState {
    BondState {
        normal_force: r[0],
        shear_force: DVec3::new(r[1], r[2], r[3]),
        twist: r[4],
        bending: DVec3::new(r[5], r[6], r[7]),
        axis: DVec3::new(r[8], r[9], r[10]),
    }
}

impl Bonds {
    /// The bonds for a segment over particles whose stable ids are `id` (`index_of[id]` their
    /// index); Ok(None) without bonds (the step then needs nothing of them), Err when a bond's
    /// sphere has no index (the segment must then be declined, not run without the bonds).
    pub fn for_segment(
        &self,
        id: &[u32],
        index_of: &[u32],
    ) -> Result<Option<SegmentBonds>, String> {
        if self.ids.is_empty() {
            return Ok(None);
        }
        let index = |k: u32| index_of.get(k as usize).copied();
        let ends = self
            .ids
            .iter()
            .map(|&[a, b]| Some([index(a)?, index(b)?]))
            .collect::<Option<Vec<_>>>()
            .ok_or("a bonded sphere is not among the particles")?;
        let mut row_start = Vec::with_capacity(id.len() + 1);
        let mut slots = Vec::with_capacity(2 * self.ids.len());
        row_start.push(0);
        for &k in id {
            let k = k as usize;
            if k + 1 < self.by_id_start.len() {
                let (a, b) = (self.by_id_start[k], self.by_id_start[k + 1]);
                slots.extend_from_slice(&self.by_id[a as usize..b as usize]);
            }
            row_start.push(slots.len() as u32);
        }
        Ok(Some(SegmentBonds {
            params: self.params.clone(),
            ends,
            kind: self.kind.clone(),
            radius: self.radius.clone(),
            stiffness: self.stiffness.clone(),
            intact: self.intact.clone(),
            state: self.state.iter().map(state_row).collect(),
            row_start,
            slots,
        }))
    }

    /// Takes back a segment's bonds: their state and output after its last step, and its
    /// breakages, logged as a step by step run logs them (by step, then bond order) at the
    /// times of a segment that began after step `first_step` with steps of `dt` and ran `steps`
    /// steps.
    pub fn end_segment(
        &mut self,
        end: SegmentBondsEnd,
        first_step: u64,
        steps: u64,
        dt: f64,
    ) -> Result<(), String> {
        let n = self.ids.len();
        if end.state.len() != n
            || end.output.len() != n
            || end.breakages.iter().any(|b| b.bond >= n)
        {
            return Err(format!(
                "the device returned {} bond states for {n} bonds",
                end.state.len()
            ));
        }
        self.state = end.state.iter().map(state_of).collect();
        self.output = end
            .output
            .iter()
            .map(|o| BondOutput {
                force: DVec3::new(o[0], o[1], o[2]),
                torque_first: DVec3::new(o[3], o[4], o[5]),
                torque_second: DVec3::new(o[6], o[7], o[8]),
            })
            .collect();
        let mut broke = end.breakages;
        broke.sort_by_key(|b| (b.step, self.ids[b.bond]));
        let mut k = 0;
        while k < broke.len() {
            let step = broke[k].step;
            // As a step by step run has it: the step's start time plus the step.
            let time = (first_step + step) as f64 * dt + dt;
            while k < broke.len() && broke[k].step == step {
                let b = broke[k].bond;
                k += 1;
                if !self.intact[b] {
                    continue;
                }
                let section = Section::new(self.radius[b]);
                let (sigma, tau) = section.stresses(&self.state[b]);
                let mode = section
                    .breaks(&self.state[b], &self.params[self.kind[b] as usize])
                    .unwrap_or(BreakMode::Shear);
                self.intact[b] = false;
                self.broken += 1;
                self.breakages.push(Breakage {
                    time,
                    position: broke[k - 1].position,
                    mode,
                    ids: self.ids[b],
                    normal_stress: sigma,
                    shear_stress: tau,
                });
            }
            self.history
                .push((time, self.intact_count(), self.broken_count()));
        }
        self.last_update = self.last_update.max((first_step + steps) as f64 * dt);
        Ok(())
    }
}
