//! Per-step extensions: what plugs into the step without the step knowing it, in the manner of
//! rapier's physics hooks and LAMMPS fixes. Factories are one ([`crate::factory`]); bonds,
//! recorders and servo-controlled plates come next.

use super::cpu::kick_spin;
use super::{SimError, Simulation, SimulationParams};
use crate::bond::segment::{SegmentBonds, SegmentBondsEnd};
use crate::particles::{Particles, NO_BODY};
use std::any::Any;

/// Where an extension does its work when the simulation's stages run on a device (the GPU back
/// end), as [`StepExtension::on_device`] declares it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum OnDevice {
    /// Its work falls on chosen steps ([`StepExtension::idle_steps`]) and needs the host only
    /// there: the device runs the steps between as whole segments (a factory).
    BetweenSegments,
    /// It works on the host at every step (it adds forces): the simulation runs stage by stage,
    /// the particles copied to the device and back at each stage.
    EveryStep,
    /// It adds forces at every step, and the device runs it with the particles inside segments:
    /// it hands its state over ([`StepExtension::segment_bonds`]) and takes it back
    /// ([`StepExtension::end_segment`]) (the bonds).
    InSegments,
}

impl OnDevice {
    /// What a back end tells the user about the extension `name`.
    pub fn remark(self, name: &str) -> String {
        match self {
            OnDevice::BetweenSegments => format!(
                "the {name} extension works on the host between segments of steps that stay on the device"
            ),
            OnDevice::InSegments => format!(
                "the {name} extension runs on the device with the particles where the steps run in segments (scenes without polyhedra), on the host where they run stage by stage"
            ),
            OnDevice::EveryStep => format!(
                "the {name} extension works on the host at every step, so the simulation runs stage by stage with the particles copied to the device and back at every stage (slower than the CPU)"
            ),
        }
    }
}

/// Something that runs with every step.
pub trait StepExtension: Send + Any {
    /// What the stage timers and messages call it.
    fn name(&self) -> &str;

    /// Where it works when the stages run on a device. No default: each extension declares it
    /// where it is written. One that adds forces must say [`OnDevice::EveryStep`] or
    /// [`OnDevice::InSegments`] ([`crate::sim::Simulation::add_extension`] refuses anything else
    /// in a debug build).
    fn on_device(&self) -> OnDevice;

    /// For [`OnDevice::InSegments`]: its bonds, for a segment over `particles` (`index_of` as
    /// [`Self::add_forces`] has it); Ok(None) when it has none, Err when it cannot hand them
    /// over (the steps then run stage by stage, its forces on the host). The default declines:
    /// an extension that says `InSegments` must hand its forces to the device.
    fn segment_bonds(
        &self,
        particles: &Particles,
        index_of: &[u32],
    ) -> Result<Option<SegmentBonds>, String> {
        let _ = (particles, index_of);
        Err(format!("the {} extension has no device state", self.name()))
    }

    /// For [`OnDevice::InSegments`]: takes back what the device did with its bonds in a segment
    /// that began after step `first_step` and ran `steps` steps of `dt`; Err stops the run.
    fn end_segment(
        &mut self,
        end: SegmentBondsEnd,
        first_step: u64,
        steps: u64,
        dt: f64,
    ) -> Result<(), String> {
        let _ = (end, first_step, steps, dt);
        Ok(())
    }

    /// Whether [`Self::add_forces`] is to be called: then the second half kick waits for it.
    fn adds_forces(&self) -> bool {
        false
    }

    /// Adds forces and torques to `particles` after the contacts and before the second half kick
    /// (bonds, springs), for the state at `time`. `index_of[id]` is the current index of the
    /// particle with stable id `id` (particles are reordered when the lists are rebuilt). Also
    /// called when forces are recomputed without a step (after particles are added or moved), so
    /// it must not count calls as steps.
    fn add_forces(&mut self, particles: &mut Particles, index_of: &[u32], time: f64, dt: f64) {
        let _ = (particles, index_of, time, dt);
    }

    /// Told after the particles were reordered (a list rebuild sorts them by cell), with the new
    /// index of each stable id: an extension that walks particles in its own order may re-sort
    /// it to follow theirs (the bonds do, so that a bond's spheres lie near its neighbours').
    fn reordered(&mut self, index_of: &[u32]) {
        let _ = index_of;
    }

    /// Runs at the end of each step with the whole simulation: create particles, move a plate,
    /// record a curve. An error stops the run.
    fn after_step(&mut self, sim: &mut Simulation) -> Result<(), SimError> {
        let _ = sim;
        Ok(())
    }

    /// For how many of the coming steps, from `time` on with steps of `dt`, [`Self::after_step`]
    /// would do nothing, so that a back end may run them on its device without the host (see
    /// [`super::segment`]). 0, the default, means every step needs the host.
    fn idle_steps(&self, time: f64, dt: f64) -> u64 {
        let _ = (time, dt);
        0
    }

    /// Whether the extension has done all it was set up to do (a factory that has created
    /// everything); a test waits for this before it judges the particles settled.
    fn finished(&self) -> bool {
        true
    }

    /// For finding extensions of one type (`Simulation::factories`).
    fn as_any(&self) -> &dyn Any;
}

impl Simulation {
    /// Whether every extension has finished (see [`StepExtension::finished`]).
    pub fn extensions_finished(&self) -> bool {
        self.extensions.iter().all(|e| e.finished())
    }

    /// The extensions of type `T`, in order.
    pub fn extensions_of<T: StepExtension>(&self) -> impl Iterator<Item = &T> {
        self.extensions
            .iter()
            .filter_map(|e| e.as_any().downcast_ref::<T>())
    }
}

/// The second half kick on its own, for steps where extensions added forces after the sums.
pub(super) fn kick(p: &mut Particles, params: &SimulationParams, clumps: bool) {
    let half = 0.5 * params.time_step;
    for i in 0..p.len() {
        if !clumps || p.body[i] == NO_BODY {
            p.velocity[i] += p.force[i] * (p.inv_mass[i] * half);
            p.angular_velocity[i] = kick_spin(
                p.angular_velocity[i],
                p.torque[i],
                p.rolling_torque_limit[i],
                p.inv_inertia[i] * half,
            );
        }
    }
}
