//! The boundary between the step pipeline and the code that does the per-particle and per-contact
//! work. The pipeline ([`super::Simulation::step`]) decides what runs when (list rebuilds, clumps,
//! extensions, timers); a [`Backend`] does the arithmetic over the struct-of-arrays layout below.
//! The CPU back end ([`super::cpu::CpuBackend`]) runs it with rayon; a GPU back end implements the
//! same four stages over the same arrays (copied to the device), which is why every input is plain
//! data: particle arrays, pair and wall-candidate lists with their [`ContactHistory`] and output
//! slots, the material pair table, the geometry elements.
//!
//! Determinism: each contact writes its own output slot and each particle sums its slots in a
//! fixed order, so results are bit-identical run to run for any thread count. A back end must keep
//! that property.
//!
//! [`ContactHistory`]: crate::contact::ContactHistory

use super::segment::{Segment, SegmentEnd};
use super::walls::WallLists;
use super::SimulationParams;
use crate::geometry::Geometry;
use crate::material::MaterialTable;
use crate::neighbour::NeighbourList;
use crate::particles::Particles;
use glam::DVec3;

/// What every force stage reads besides the particles and lists.
pub struct StepInputs<'a> {
    pub materials: &'a MaterialTable,
    pub geometries: &'a [Geometry],
    pub params: &'a SimulationParams,
    /// Whether any particle belongs to a clump (members of one clump do not touch each other, and
    /// are moved by their body rather than integrated).
    pub clumps: bool,
    /// Whether any pair attracts beyond touching (JKR): then candidates that do not touch must
    /// still be checked against the law's cut-off.
    pub cohesive: bool,
    /// The polyhedral bodies' shapes and world frames, when there are any (their pairs and wall
    /// contacts go to [`crate::polyhedron::contact`]).
    pub polyhedra: Option<&'a crate::polyhedron::PolyFrames>,
}

/// Where the particles were when the lists were made: what [`Backend::integrate`] measures the
/// displacements against.
#[derive(Clone, Copy)]
pub struct Anchors<'a> {
    /// At the last list build (a rebuild is due past half the skin).
    pub build: &'a [DVec3],
    /// At the near list's last scan, when there is one ([`crate::neighbour::NearList`]).
    pub near: Option<&'a [DVec3]>,
}

impl<'a> Anchors<'a> {
    pub fn of(lists: &'a NeighbourList) -> Self {
        Anchors {
            build: &lists.built_at,
            near: lists.near.anchor(),
        }
    }
}

/// The largest displacement of any particle since each anchor.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Moved {
    pub since_build: f64,
    /// Infinite without a near anchor (or from a back end that does not measure it: the pair
    /// stage then goes over every pair).
    pub since_near: f64,
}

impl Moved {
    /// What a back end that measures only the displacement since the list build returns: the
    /// near list is then never used (a smaller made-up `since_near` would skip pairs that touch).
    pub fn since_build_only(since_build: f64) -> Self {
        Moved {
            since_build,
            since_near: f64::INFINITY,
        }
    }
}

/// The per-step arithmetic, in the order the pipeline calls it.
pub trait Backend: Send + Sync {
    fn name(&self) -> &'static str;

    /// What this back end hands to the CPU for a simulation with these inputs, one line each for
    /// the user (a law it does not run yet, ...). Nothing by default.
    fn remarks(&self, inputs: &StepInputs) -> Vec<String> {
        let _ = inputs;
        Vec::new()
    }

    /// Whether [`Self::run_segment`] can run a simulation with these inputs (no polyhedra, no
    /// extension forces but those of an `OnDevice::InSegments` extension, which the segment
    /// hands over with the clump bodies: the pipeline checks those). False by default: the
    /// pipeline calls the stages one by one.
    fn runs_segments(&self, inputs: &StepInputs) -> bool {
        let _ = inputs;
        false
    }

    /// Runs a whole segment of steps with the state on the back end's device (see
    /// [`super::segment`]), or None when it cannot (then the pipeline runs the steps stage by
    /// stage, and nothing has changed).
    fn run_segment(&self, segment: &Segment) -> Option<SegmentEnd> {
        let _ = segment;
        None
    }

    /// Half kick (from the forces of the last step) and drift of every sphere that is not a clump
    /// member. Returns the largest displacements since the `anchors` (the one since the near
    /// scan must be measured, or infinite: [`Moved::since_build_only`]), or the index of the first
    /// particle that is not finite or outside `params.domain`.
    fn integrate(
        &self,
        particles: &mut Particles,
        anchors: Anchors,
        params: &SimulationParams,
        clumps: bool,
    ) -> Result<Moved, usize>;

    /// Every candidate pair computes its contact once, into its own output slot, updating its
    /// history (a back end may skip the pairs the near list leaves out, which cannot touch:
    /// [`crate::neighbour::NearList`]).
    fn pair_forces(&self, particles: &Particles, lists: &mut NeighbourList, inputs: &StepInputs);

    /// Every particle's geometry candidates compute their contacts into their output slots.
    fn wall_forces(&self, particles: &Particles, walls: &mut WallLists, inputs: &StepInputs);

    /// Each particle sums gravity, its pair slots (as i and as j) and its wall slots into its force,
    /// torque and rolling-resistance limit; with `kick`, free spheres then get the second half kick.
    fn particle_sums(
        &self,
        particles: &mut Particles,
        lists: &NeighbourList,
        walls: &WallLists,
        inputs: &StepInputs,
        kick: bool,
    );

    /// [`Self::wall_forces`] then [`Self::particle_sums`]. A back end may do both in one pass
    /// over the particles (the CPU does: each particle's wall contacts are summed while still in
    /// cache, and a step has one parallel section fewer).
    fn wall_forces_and_sums(
        &self,
        particles: &mut Particles,
        lists: &NeighbourList,
        walls: &mut WallLists,
        inputs: &StepInputs,
        kick: bool,
    ) {
        self.wall_forces(particles, walls, inputs);
        self.particle_sums(particles, lists, walls, inputs, kick);
    }

    /// [`Self::wall_forces_and_sums`] with the kick, then the next step's [`Self::integrate`]
    /// (against the lists' anchors), for a step that follows at once with nothing in between (no
    /// clumps, extensions or device segments: the pipeline checks). A back end may do it all in
    /// one pass over the particles (the CPU does).
    fn gather_and_integrate(
        &self,
        particles: &mut Particles,
        lists: &NeighbourList,
        walls: &mut WallLists,
        inputs: &StepInputs,
    ) -> Result<Moved, usize> {
        self.wall_forces_and_sums(particles, lists, walls, inputs, true);
        self.integrate(particles, Anchors::of(lists), inputs.params, inputs.clumps)
    }
}
