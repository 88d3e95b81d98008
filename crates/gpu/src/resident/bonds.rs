//! A segment's bonds on the device (`dem::bond::segment`): each world's bonds packed
//! ([`WorldBonds`]), a batch's laid side by side with their spheres, kinds and slots shifted
//! ([`MergedBonds`]), their buffers and launches, and each world's end read back.
//!
//! Each world keeps its own bonds: a bond joins two spheres of its world, its kind is a row of
//! its world's parameters, and each sphere's row lists its world's bonds only, so a world's
//! result does not depend on its neighbours in the batch.

use dem::bond::segment::{SegmentBonds, SegmentBondsEnd, SegmentBreakage};

use super::world::{Offsets, World};
use super::Launch;
use crate::layout::bond_state;
use crate::layout::{bond_broke, bond_ends, bond_output, bond_params, bond_props, bond_rows};
use crate::pack::{vec3_at, Counts};
use crate::GpuContext;

/// One world's bonds, packed.
pub(crate) struct WorldBonds {
    /// Rows of `bond_params`, one per kind.
    pub params: Vec<f64>,
    /// Rows of `bond_ends` (the world's own sphere indices and kinds).
    pub ends: Vec<u32>,
    pub props: Vec<f64>,
    pub state: Vec<f64>,
    /// Each sphere's slots (compressed rows over the world's spheres).
    pub row_start: Vec<u32>,
    pub slots: Vec<u32>,
}

impl WorldBonds {
    /// Packs `b` for a world of `n` spheres; None when a bond names a sphere outside it.
    pub fn pack(b: &SegmentBonds, n: usize) -> Option<WorldBonds> {
        let count = b.ends.len();
        if b.ends.iter().flatten().any(|&i| i as usize >= n)
            || b.row_start.len() != n + 1
            || [
                b.kind.len(),
                b.radius.len(),
                b.stiffness.len(),
                b.intact.len(),
            ]
            .iter()
            .chain([&b.state.len()])
            .any(|&l| l != count)
            || b.slots.iter().any(|&s| s as usize >= 2 * count)
            || b.kind.iter().any(|&k| k as usize >= b.params.len())
        {
            return None;
        }
        let mut params = vec![0.0; bond_params::LEN * b.params.len()];
        for (k, p) in b.params.iter().enumerate() {
            let row = &mut params[bond_params::LEN * k..bond_params::LEN * (k + 1)];
            row[bond_params::NORMAL_STIFFNESS] = p.normal_stiffness;
            row[bond_params::SHEAR_STIFFNESS] = p.shear_stiffness;
            row[bond_params::CRITICAL_NORMAL_STRESS] = p.critical_normal_stress;
            row[bond_params::CRITICAL_SHEAR_STRESS] = p.critical_shear_stress;
            row[bond_params::DAMPING] = p.damping;
        }
        let mut ends = vec![0u32; bond_ends::LEN * count];
        let mut props = vec![0.0; bond_props::LEN * count];
        for k in 0..count {
            let e = &mut ends[bond_ends::LEN * k..bond_ends::LEN * (k + 1)];
            e[bond_ends::FIRST] = b.ends[k][0];
            e[bond_ends::SECOND] = b.ends[k][1];
            e[bond_ends::KIND] = b.kind[k] as u32;
            e[bond_ends::INTACT] = u32::from(b.intact[k]);
            let q = &mut props[bond_props::LEN * k..bond_props::LEN * (k + 1)];
            q[bond_props::RADIUS] = b.radius[k];
            q[bond_props::STIFFNESS] = b.stiffness[k];
        }
        Some(WorldBonds {
            params,
            ends,
            props,
            state: b.state.iter().flatten().copied().collect(),
            row_start: b.row_start.clone(),
            slots: b.slots.clone(),
        })
    }

    fn count(&self) -> usize {
        self.ends.len() / bond_ends::LEN
    }
}

/// The bonds of a batch's run, host side.
pub(crate) struct MergedBonds {
    pub params: Vec<f64>,
    pub ends: Vec<u32>,
    pub props: Vec<f64>,
    pub state: Vec<f64>,
    /// `bond_rows`: blocks of N, then the slots.
    pub rows: Vec<u32>,
    /// Each world's first bond (None: a world without bonds).
    pub first: Vec<Option<usize>>,
    pub count: usize,
}

impl MergedBonds {
    /// The bonds of `worlds` laid side by side at `offsets` over `n` spheres in all; None when
    /// no world has bonds.
    pub fn new(worlds: &[World], offsets: &[Offsets], n: usize) -> Option<MergedBonds> {
        if worlds.iter().all(|w| w.bonds.is_none()) {
            return None;
        }
        let mut m = MergedBonds {
            params: Vec::new(),
            ends: Vec::new(),
            props: Vec::new(),
            state: Vec::new(),
            rows: vec![0; bond_rows::SLOTS * n],
            first: Vec::with_capacity(worlds.len()),
            count: 0,
        };
        let mut slots: Vec<u32> = Vec::new();
        for (w, off) in worlds.iter().zip(offsets) {
            let Some(b) = &w.bonds else {
                m.first.push(None);
                continue;
            };
            let (first_bond, first_kind) = (m.count, m.params.len() / bond_params::LEN);
            m.first.push(Some(first_bond));
            m.params.extend(&b.params);
            for row in b.ends.chunks(bond_ends::LEN) {
                let mut row = row.to_vec();
                row[bond_ends::FIRST] += off.particle as u32;
                row[bond_ends::SECOND] += off.particle as u32;
                row[bond_ends::KIND] += first_kind as u32;
                m.ends.extend(row);
            }
            m.props.extend(&b.props);
            m.state.extend(&b.state);
            for i in 0..w.n {
                let g = off.particle + i;
                m.rows[bond_rows::BEGIN * n + g] = slots.len() as u32;
                let (a, z) = (b.row_start[i] as usize, b.row_start[i + 1] as usize);
                slots.extend(b.slots[a..z].iter().map(|&s| s + 2 * first_bond as u32));
                m.rows[bond_rows::END * n + g] = slots.len() as u32;
            }
            m.count += b.count();
        }
        m.rows.extend(slots);
        Some(m)
    }

    /// The device memory of the bonds' buffers ([`BondBuffers::new`]), in bytes.
    pub fn bytes(&self) -> usize {
        let words = 4 * 16 + 4 * (self.ends.len() + self.rows.len()).max(4);
        let f64s = self.props.len() + self.params.len() + self.state.len();
        words + 8 * (f64s.max(3) + (bond_output::LEN + bond_broke::LEN) * self.count.max(1))
    }

    /// The largest of its buffers, in bytes.
    pub fn largest(&self) -> usize {
        [
            8 * self.state.len(),
            8 * bond_output::LEN * self.count,
            4 * self.rows.len(),
            4 * self.ends.len(),
            8 * self.params.len(),
        ]
        .into_iter()
        .max()
        .unwrap_or(0)
    }

    /// Each world's bonds after the run, from the read-back `state`, `output` and `broke`
    /// buffers; None for a world without bonds.
    pub fn split(&self, worlds: &[World], out: [&[u8]; 3]) -> Vec<Option<SegmentBondsEnd>> {
        let state: Vec<f64> = bytemuck::pod_collect_to_vec(out[0]);
        let output: Vec<f64> = bytemuck::pod_collect_to_vec(out[1]);
        let broke: Vec<f64> = bytemuck::pod_collect_to_vec(out[2]);
        worlds
            .iter()
            .zip(&self.first)
            .map(|(w, first)| {
                let (b, first) = (w.bonds.as_ref()?, (*first)?);
                let range = first..first + b.count();
                let rows = |v: &[f64], len: usize| -> Vec<f64> {
                    v[len * range.start..len * range.end].to_vec()
                };
                let breakages = range
                    .clone()
                    .filter_map(|k| {
                        let step = broke[bond_broke::LEN * k + bond_broke::STEP];
                        (step >= 0.0).then(|| SegmentBreakage {
                            step: step as u64,
                            bond: k - first,
                            position: vec3_at(&broke, bond_broke::LEN * k + bond_broke::POSITION),
                        })
                    })
                    .collect();
                Some(SegmentBondsEnd {
                    state: rows(&state, bond_state::LEN)
                        .chunks(bond_state::LEN)
                        .map(|r| r.try_into().expect("a state row"))
                        .collect(),
                    output: rows(&output, bond_output::LEN)
                        .chunks(bond_output::LEN)
                        .map(|r| r.try_into().expect("an output row"))
                        .collect(),
                    breakages,
                })
            })
            .collect()
    }
}

/// The device buffers of a run's bonds.
pub(crate) struct BondBuffers {
    pub counts: wgpu::Buffer,
    pub ends: wgpu::Buffer,
    pub props: wgpu::Buffer,
    pub params: wgpu::Buffer,
    pub state: wgpu::Buffer,
    pub output: wgpu::Buffer,
    pub broke: wgpu::Buffer,
    pub rows: wgpu::Buffer,
}

impl BondBuffers {
    /// Every buffer, for the count of device memory.
    pub fn all(&self) -> [&wgpu::Buffer; 8] {
        [
            &self.counts,
            &self.ends,
            &self.props,
            &self.params,
            &self.state,
            &self.output,
            &self.broke,
            &self.rows,
        ]
    }

    pub fn new(c: &GpuContext, m: &MergedBonds, n: usize) -> BondBuffers {
        let count = m.count;
        let mut broke = vec![0.0f64; bond_broke::LEN * count];
        for k in 0..count {
            broke[bond_broke::LEN * k + bond_broke::STEP] = -1.0;
        }
        // The bond kernel's launch over the bonds (the bond sums use the particles' counts).
        let words = Counts {
            particles: n,
            bonds: count,
            ..Default::default()
        }
        .words(count as u32);
        BondBuffers {
            counts: c.storage(&words),
            ends: c.storage(&m.ends),
            props: c.storage(&m.props),
            params: c.storage(&m.params),
            state: c.storage(&m.state),
            output: c.storage(&vec![0.0f64; bond_output::LEN * count]),
            broke: c.storage(&broke),
            rows: c.storage(&m.rows),
        }
    }

    /// The bond kernel over the bonds, then the bond sums over the `n` particles (whose
    /// `counts_n` has their row width).
    #[allow(clippy::too_many_arguments)]
    pub fn launches<'a>(
        &self,
        c: &'a GpuContext,
        state: &wgpu::Buffer,
        loads: &wgpu::Buffer,
        props: &wgpu::Buffer,
        params: &wgpu::Buffer,
        counts_n: &wgpu::Buffer,
        ctrl: &wgpu::Buffer,
        body: &wgpu::Buffer,
        count: usize,
        n: usize,
    ) -> [Launch<'a>; 2] {
        let k = &c.resident;
        [
            super::run::launch(
                c,
                &k.bond_forces,
                &[
                    state,
                    props,
                    params,
                    &self.counts,
                    &self.ends,
                    &self.props,
                    &self.params,
                    &self.state,
                    &self.output,
                    &self.broke,
                    ctrl,
                ],
                count,
            ),
            super::run::launch(
                c,
                &k.bond_sums,
                &[
                    state,
                    loads,
                    props,
                    params,
                    counts_n,
                    &self.rows,
                    &self.ends,
                    &self.params,
                    &self.output,
                    body,
                ],
                n,
            ),
        ]
    }
}
