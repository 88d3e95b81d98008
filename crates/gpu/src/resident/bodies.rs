//! A segment's clumps on the device (`dem::sim::SegmentBodies`): each world's bodies packed
//! ([`WorldBodies`]), a batch's laid side by side with their members shifted ([`MergedBodies`]),
//! their buffers and launches (`bodies_first` before `integrate`, `bodies_last` after the
//! forces), and each world's bodies read back.

use dem::sim::{SegmentBodies, SegmentBodiesEnd};
use glam::{DQuat, DVec3};

use super::world::{Offsets, World};
use super::Launch;
use crate::layout::{body, body_members, member};
use crate::pack::{put3, vec3_at, Counts};
use crate::GpuContext;

/// One world's clumps, packed.
pub(crate) struct WorldBodies {
    /// Rows of `bodies`.
    pub rows: Vec<f64>,
    pub member_start: Vec<u32>,
    pub members: Vec<u32>,
    /// Rows of `offsets` (`layout::member`), one a member.
    pub offsets: Vec<f64>,
}

impl WorldBodies {
    /// Packs `b` for a world of `n` particles; None when it is not whole.
    pub fn pack(b: &SegmentBodies, n: usize) -> Option<WorldBodies> {
        let count = b.position.len();
        let lens = [
            b.velocity.len(),
            b.orientation.len(),
            b.angular_momentum.len(),
            b.principal_inertia.len(),
            b.mass.len(),
            b.force.len(),
            b.torque.len(),
            b.rolling_limit.len(),
        ];
        if count == 0
            || lens.iter().any(|&l| l != count)
            || b.member_start.len() != count + 1
            || b.member_start.windows(2).any(|w| w[0] >= w[1])
            || b.member_start[count] as usize != b.members.len()
            || b.offset.len() != b.members.len()
            || b.members.iter().any(|&i| i as usize >= n)
        {
            return None;
        }
        let mut rows = vec![0.0; body::LEN * count];
        for k in 0..count {
            let r = &mut rows[body::LEN * k..body::LEN * (k + 1)];
            put3(r, body::POSITION, b.position[k]);
            put3(r, body::VELOCITY, b.velocity[k]);
            let q = b.orientation[k];
            put3(r, body::ORIENTATION, DVec3::new(q.x, q.y, q.z));
            r[body::ORIENTATION_W] = q.w;
            put3(r, body::ANGULAR_MOMENTUM, b.angular_momentum[k]);
            put3(r, body::INERTIA, b.principal_inertia[k]);
            r[body::MASS] = b.mass[k];
            put3(r, body::FORCE, b.force[k]);
            put3(r, body::TORQUE, b.torque[k]);
            r[body::ROLLING_LIMIT] = b.rolling_limit[k];
        }
        Some(WorldBodies {
            rows,
            member_start: b.member_start.clone(),
            members: b.members.clone(),
            offsets: b
                .offset
                .iter()
                .flat_map(|o| {
                    let mut row = [0.0; member::LEN];
                    put3(&mut row, member::OFFSET, *o);
                    row
                })
                .collect(),
        })
    }

    fn count(&self) -> usize {
        self.rows.len() / body::LEN
    }
}

/// The clumps of a batch's run, host side.
pub(crate) struct MergedBodies {
    pub rows: Vec<f64>,
    /// `body_members` rows.
    pub ranges: Vec<u32>,
    pub members: Vec<u32>,
    pub offsets: Vec<f64>,
    /// Each world's first body (None: a world without clumps).
    pub first: Vec<Option<usize>>,
    pub count: usize,
}

impl MergedBodies {
    /// The clumps of `worlds` laid side by side at `offsets`; None when no world has any.
    pub fn new(worlds: &[World], offsets: &[Offsets]) -> Option<MergedBodies> {
        if worlds.iter().all(|w| w.bodies.is_none()) {
            return None;
        }
        let mut m = MergedBodies {
            rows: Vec::new(),
            ranges: Vec::new(),
            members: Vec::new(),
            offsets: Vec::new(),
            first: Vec::with_capacity(worlds.len()),
            count: 0,
        };
        for (w, off) in worlds.iter().zip(offsets) {
            let Some(b) = &w.bodies else {
                m.first.push(None);
                continue;
            };
            m.first.push(Some(m.count));
            let at = m.members.len() as u32;
            m.rows.extend(&b.rows);
            for k in 0..b.count() {
                let mut range = [0u32; body_members::LEN];
                range[body_members::BEGIN] = at + b.member_start[k];
                range[body_members::END] = at + b.member_start[k + 1];
                m.ranges.extend(range);
            }
            m.members
                .extend(b.members.iter().map(|&i| i + off.particle as u32));
            m.offsets.extend(&b.offsets);
            m.count += b.count();
        }
        Some(m)
    }

    /// The device memory of the clumps' buffers ([`BodyBuffers::new`]), in bytes.
    pub fn bytes(&self) -> usize {
        4 * 16
            + 4 * (self.ranges.len() + self.members.len()).max(4)
            + 8 * (self.rows.len() + self.offsets.len()).max(2)
    }

    /// The largest of its buffers, in bytes.
    pub fn largest(&self) -> usize {
        (8 * self.rows.len()).max(8 * self.offsets.len())
    }

    /// Each world's clumps after the run, from the read-back `bodies` buffer; None for a world
    /// without clumps.
    pub fn split(&self, worlds: &[World], out: &[u8]) -> Vec<Option<SegmentBodiesEnd>> {
        let rows: Vec<f64> = bytemuck::pod_collect_to_vec(out);
        worlds
            .iter()
            .zip(&self.first)
            .map(|(w, first)| {
                let (b, first) = (w.bodies.as_ref()?, (*first)?);
                let mut end = SegmentBodiesEnd::default();
                for k in first..first + b.count() {
                    let r = body::LEN * k;
                    let v = |f: usize| -> DVec3 { vec3_at(&rows, r + f) };
                    end.position.push(v(body::POSITION));
                    end.velocity.push(v(body::VELOCITY));
                    let q = v(body::ORIENTATION);
                    let w = rows[r + body::ORIENTATION_W];
                    end.orientation.push(DQuat::from_xyzw(q.x, q.y, q.z, w));
                    end.angular_momentum.push(v(body::ANGULAR_MOMENTUM));
                    end.force.push(v(body::FORCE));
                    end.torque.push(v(body::TORQUE));
                    end.rolling_limit.push(rows[r + body::ROLLING_LIMIT]);
                }
                Some(end)
            })
            .collect()
    }
}

/// The device buffers of a run's clumps.
pub(crate) struct BodyBuffers {
    counts: wgpu::Buffer,
    pub rows: wgpu::Buffer,
    ranges: wgpu::Buffer,
    members: wgpu::Buffer,
    offsets: wgpu::Buffer,
}

impl BodyBuffers {
    /// Every buffer, for the count of device memory.
    pub fn all(&self) -> [&wgpu::Buffer; 5] {
        [
            &self.counts,
            &self.rows,
            &self.ranges,
            &self.members,
            &self.offsets,
        ]
    }

    pub fn new(c: &GpuContext, m: &MergedBodies, n: usize) -> BodyBuffers {
        let words = Counts {
            particles: n,
            bodies: m.count,
            ..Default::default()
        }
        .words(m.count as u32);
        BodyBuffers {
            counts: c.storage(&words),
            rows: c.storage(&m.rows),
            ranges: c.storage(&m.ranges),
            members: c.storage(&m.members),
            offsets: c.storage(&m.offsets),
        }
    }

    /// `bodies_first` (before `integrate`) and `bodies_last` (after the forces).
    pub fn launches<'a>(
        &self,
        c: &'a GpuContext,
        state: &wgpu::Buffer,
        props: &wgpu::Buffer,
        params: &wgpu::Buffer,
        loads: &wgpu::Buffer,
        count: usize,
    ) -> [Launch<'a>; 2] {
        let k = &c.resident;
        let common = [
            state,
            props,
            params,
            &self.counts,
            &self.rows,
            &self.ranges,
            &self.members,
            &self.offsets,
        ];
        let mut last = common.to_vec();
        last.push(loads);
        [
            super::run::launch(c, &k.bodies_first, &common, count),
            super::run::launch(c, &k.bodies_last, &last, count),
        ]
    }
}
