//! The contact network of the current state, for output: which spheres touch and with what force.

use super::{Backend, CpuBackend, Simulation};
use crate::neighbour::{NeighbourList, PairOutput};
use glam::DVec3;

/// Two spheres in contact (or attracting, with cohesion): their indices in the current particle
/// order and the contact force on `i` from `j` (j gets the opposite).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PairContact {
    pub i: usize,
    pub j: usize,
    pub force: DVec3,
}

impl Simulation {
    /// Every sphere pair with a non-zero contact force (members of one clump never touch; bond
    /// forces are not contacts, see [`crate::bond`]).
    ///
    /// These are the forces of the last force evaluation, the ones the particles move under.
    /// Where there is none yet (before the first step) or the lists were rebuilt since (after a
    /// device segment), the pairs are evaluated on a copy of the list: the run itself is left
    /// as it was, so writing the contacts never changes the results; the tangential force of such
    /// a copy is one time step's slip ahead of the stored one.
    pub fn pair_contacts(&mut self) -> Vec<PairContact> {
        // The first step would build the lists at this same state: building them now is the same.
        self.ensure_lists();
        let fresh;
        let outputs: &[PairOutput] = if self.pair_forces_current {
            &self.neighbours.output
        } else {
            let mut copy = NeighbourList::new(self.params.skin);
            copy.pairs = self.neighbours.pairs.clone();
            copy.output = vec![PairOutput::default(); copy.pairs.len()];
            copy.mark_all_active();
            let inputs = self.inputs(!self.bodies.is_empty());
            CpuBackend.pair_forces(&self.particles, &mut copy, &inputs);
            fresh = copy.output;
            &fresh
        };
        self.neighbours
            .pairs
            .iter()
            .zip(outputs)
            .filter(|(_, o)| o.force != DVec3::ZERO)
            .map(|(pair, o)| PairContact {
                i: pair.i as usize,
                j: pair.j as usize,
                force: o.force,
            })
            .collect()
    }
}
