//! The stage-by-stage path: each stage copies its arrays to the device, runs its kernel and
//! copies the results back (scenes with clumps, and segments the device declined). Each returns
//! Err when the device failed (`crate::failure`), before anything of the host's is changed, and
//! Ok(false) (None for the integration) when the stage is the CPU's to run (a law the kernels
//! lack, arrays too large for a binding, a particle touching more walls than the kernel keeps):
//! the caller runs it on the CPU outside the guard, so that a CPU stage never runs twice and a
//! panic in it is never taken for the device's failure.

use dem::neighbour::NeighbourList;
use dem::particles::Particles;
use dem::sim::walls::WallLists;
use dem::sim::{Anchors, Moved, SimulationParams, StepInputs};

use crate::layout::{self, element, geometry, pair_output, wall_output};
use crate::pack::{
    block3, element_row, flat, geometry_row, history_at, history_of, ints_of, loads_of, numbers,
    pair_output_at, pair_output_of, pair_table, params_of, props_of, rows_of, stage_params,
    state_of, wall_output_at, wall_output_of, Counts,
};
use crate::{GpuStages, STATE_BYTES};

impl GpuStages {
    pub(crate) fn integrate_device(
        &self,
        p: &mut Particles,
        anchors: Anchors,
        params: &SimulationParams,
        clumps: bool,
    ) -> Result<Option<Result<Moved, usize>>, String> {
        // The kernel measures the displacement since the list build only: without the one since
        // the near scan, the CPU pair stage (where it runs) goes over every pair.
        let built_at = anchors.build;
        let n = p.len();
        if n == 0 {
            return Ok(Some(Ok(Moved::since_build_only(0.0))));
        }
        let c = &self.ctx;
        if !c.fits(STATE_BYTES * n) {
            return Ok(None);
        }
        let threads = n as u32;
        let state = c.storage(&state_of(p));
        let loads = c.storage(&loads_of(p));
        let props = c.storage(&props_of(p));
        let body = c.storage(&p.body);
        let built = c.storage(&flat(built_at));
        let par = c.storage(&params_of(params, clumps, false, 0, false));
        let counts = c.storage(
            &Counts {
                particles: n,
                ..Default::default()
            }
            .words(threads),
        );
        let moved = c.storage(&vec![0.0f64; n]);
        let outside = c.storage(&vec![0u32; n]);
        let out = c.run(
            &c.integrate,
            &[
                &state, &loads, &props, &body, &built, &par, &counts, &moved, &outside,
            ],
            threads,
            &[0, 7, 8],
        )?;
        let s = numbers::<f64>(&out[0]);
        for i in 0..n {
            p.position[i] = block3(&s, layout::state::POSITION, n, i);
            p.velocity[i] = block3(&s, layout::state::VELOCITY, n, i);
            p.angular_velocity[i] = block3(&s, layout::state::ANGULAR_VELOCITY, n, i);
        }
        let moved = numbers::<f64>(&out[1]);
        let outside: Vec<u32> = bytemuck::pod_collect_to_vec(&out[2]);
        Ok(Some(
            match (0..n).find(|&i| !moved[i].is_finite() || outside[i] != 0) {
                Some(i) => Err(i),
                None => Ok(Moved::since_build_only(
                    moved[..n].iter().copied().fold(0.0, f64::max).sqrt(),
                )),
            },
        ))
    }

    pub(crate) fn pair_forces_device(
        &self,
        p: &Particles,
        lists: &mut NeighbourList,
        inputs: &StepInputs,
    ) -> Result<bool, String> {
        if !Self::runs_pairs(inputs) {
            return Ok(false);
        }
        let pairs = lists.pairs.len();
        if pairs == 0 {
            return Ok(true);
        }
        let n = p.len();
        let c = &self.ctx;
        if !c.fits((STATE_BYTES * n).max(8 * pair_output::LEN * pairs)) {
            return Ok(false);
        }
        let threads = pairs as u32;
        let state = c.storage(&state_of(p));
        let props = c.storage(&props_of(p));
        let ints = c.storage(&ints_of(p));
        let mut ij = vec![0; layout::pair_ij::LEN * pairs];
        for (q, pair) in lists.pairs.iter().enumerate() {
            ij[layout::pair_ij::LEN * q + layout::pair_ij::I] = pair.i;
            ij[layout::pair_ij::LEN * q + layout::pair_ij::J] = pair.j;
        }
        let ij = c.storage(&ij);
        let history = c.storage(&history_of(lists.pairs.iter().map(|q| &q.history)));
        let output = c.storage(&vec![0.0f64; pair_output::LEN * pairs]);
        let table = c.storage(&pair_table(inputs));
        let par = c.storage(&stage_params(inputs, false));
        let counts = c.storage(
            &Counts {
                particles: n,
                pairs,
                ..Default::default()
            }
            .words(threads),
        );
        // The kernel's own bindings, then its lists, whole (`kernels::SPLIT`).
        let out = c.run(
            &c.pair_forces,
            &[
                &state, &props, &ints, &ij, &table, &par, &counts, &history, &output,
            ],
            threads,
            &[7, 8],
        )?;
        let h = numbers::<f64>(&out[0]);
        let o = numbers::<f64>(&out[1]);
        for (q, pair) in lists.pairs.iter_mut().enumerate() {
            pair.history = history_at(&h, q);
            lists.output[q] = pair_output_at(&o, q);
        }
        lists.mark_all_active();
        Ok(true)
    }

    pub(crate) fn wall_forces_device(
        &self,
        p: &Particles,
        walls: &mut WallLists,
        inputs: &StepInputs,
    ) -> Result<bool, String> {
        let count = walls.candidates().len();
        if count == 0 {
            return Ok(true);
        }
        let n = p.len();
        let c = &self.ctx;
        let elements: usize = inputs.geometries.iter().map(|g| g.elements.len()).sum();
        let largest = (STATE_BYTES * n)
            .max(8 * wall_output::LEN * count)
            .max(8 * element::LEN * elements);
        if !Self::runs_pairs(inputs) || !c.fits(largest) {
            return Ok(false);
        }
        let threads = n as u32;
        let mut flat_elements: Vec<f64> = Vec::with_capacity(element::LEN * elements);
        let mut geoms: Vec<f64> = Vec::with_capacity(geometry::LEN * inputs.geometries.len());
        for g in inputs.geometries {
            let (lin, ang) = (g.velocity.linear, g.velocity.angular);
            geoms.extend(geometry_row(
                g.material as f64,
                (flat_elements.len() / element::LEN) as f64,
                [lin.x, lin.y, lin.z, ang.x, ang.y, ang.z],
            ));
            for e in &g.elements {
                flat_elements.extend(element_row(e));
            }
        }
        let state = c.storage(&state_of(p));
        let props = c.storage(&props_of(p));
        let ints = c.storage(&ints_of(p));
        let flat_elements = c.storage(&flat_elements);
        let geoms = c.storage(&geoms);
        let mut cands = vec![0; layout::cands::LEN * count];
        for (k, w) in walls.candidates().iter().enumerate() {
            cands[layout::cands::LEN * k + layout::cands::GEOMETRY] = w.geometry as u32;
            cands[layout::cands::LEN * k + layout::cands::ELEMENT] = w.element;
        }
        let cands = c.storage(&cands);
        let rows = c.storage(&rows_of(None, walls.start(), n));
        let history = c.storage(&history_of(walls.candidates().iter().map(|w| &w.history)));
        let output = c.storage(&vec![0.0f64; wall_output::LEN * count]);
        let table = c.storage(&pair_table(inputs));
        let par = c.storage(&stage_params(inputs, false));
        let counts = c.storage(
            &Counts {
                particles: n,
                walls: count,
                ..Default::default()
            }
            .words(threads),
        );
        let status = c.storage(&vec![0u32; n]);
        // The kernel's own bindings, then its lists, whole (`kernels::SPLIT`).
        let out = c.run(
            &c.wall_forces,
            &[
                &state,
                &props,
                &ints,
                &flat_elements,
                &geoms,
                &cands,
                &rows,
                &table,
                &par,
                &counts,
                &status,
                &history,
                &output,
            ],
            threads,
            &[11, 12, 10],
        )?;
        let status: Vec<u32> = bytemuck::pod_collect_to_vec(&out[2]);
        if status[..n].iter().any(|&s| s != 0) {
            // A particle touching more walls at once than the kernel keeps: the CPU has no limit.
            return Ok(false);
        }
        let h = numbers::<f64>(&out[0]);
        let o = numbers::<f64>(&out[1]);
        for (k, w) in walls.candidates_mut().iter_mut().enumerate() {
            w.history = history_at(&h, k);
        }
        for (k, slot) in walls.output_mut().iter_mut().enumerate() {
            *slot = wall_output_at(&o, k);
        }
        Ok(true)
    }

    pub(crate) fn particle_sums_device(
        &self,
        p: &mut Particles,
        lists: &NeighbourList,
        walls: &WallLists,
        inputs: &StepInputs,
        kick: bool,
    ) -> Result<bool, String> {
        let n = p.len();
        if n == 0 {
            return Ok(true);
        }
        let c = &self.ctx;
        let csr_len = layout::rows::REVERSE_ENTRIES * n + lists.reverse.len();
        if !c.fits(
            (STATE_BYTES * n)
                .max(8 * pair_output::LEN * lists.output.len())
                .max(8 * wall_output::LEN * walls.output().len())
                .max(4 * csr_len),
        ) {
            return Ok(false);
        }
        let threads = n as u32;
        let state = c.storage(&state_of(p));
        let loads = c.storage(&vec![0.0f64; layout::loads::LEN * n]);
        let props = c.storage(&props_of(p));
        let body = c.storage(&p.body);
        let pair_out = c.storage(&pair_output_of(&lists.output));
        let rows = c.storage(&rows_of(Some(lists), walls.start(), n));
        let wall_out = c.storage(&wall_output_of(walls.output()));
        let par = c.storage(&stage_params(inputs, kick));
        let counts = c.storage(
            &Counts {
                particles: n,
                pairs: lists.pairs.len(),
                reverse: lists.reverse.len(),
                walls: walls.output().len(),
                bonds: 0,
                bodies: 0,
            }
            .words(threads),
        );
        let out = c.run(
            &c.particle_sums,
            &[
                &state, &loads, &props, &body, &pair_out, &rows, &wall_out, &par, &counts,
            ],
            threads,
            &[0, 1],
        )?;
        let s = numbers::<f64>(&out[0]);
        let l = numbers::<f64>(&out[1]);
        use layout::{loads, state};
        for i in 0..n {
            p.velocity[i] = block3(&s, state::VELOCITY, n, i);
            p.angular_velocity[i] = block3(&s, state::ANGULAR_VELOCITY, n, i);
            p.force[i] = block3(&l, loads::FORCE, n, i);
            p.torque[i] = block3(&l, loads::TORQUE, n, i);
            p.rolling_torque_limit[i] = l[loads::ROLLING_LIMIT * n + i];
        }
        Ok(true)
    }
}
