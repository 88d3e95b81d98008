//! The host's side of the data contract (`crate::layout`): what the stages and segments write
//! into the buffers they share with the kernels, and how they read the results back. Every
//! place is a `layout` constant, so these functions and the kernels cannot disagree on one.

use dem::contact::{ContactHistory, RollingModel};
use dem::geometry::Element;
use dem::neighbour::{NeighbourList, PairOutput};
use dem::particles::Particles;
use dem::sim::walls::WallOutput;
use dem::sim::{SimulationParams, StepInputs};
use glam::DVec3;

use crate::layout::{self, element, element_kind, geometry, history, pair_output, wall_output};
use crate::row_width;

/// Positions, 3 numbers a particle (the kernels' `built`).
pub(crate) fn flat(v: &[DVec3]) -> Vec<f64> {
    v.iter().flat_map(|v| [v.x, v.y, v.z]).collect()
}

pub(crate) fn put3(out: &mut [f64], at: usize, v: DVec3) {
    out[at..at + 3].copy_from_slice(&[v.x, v.y, v.z]);
}

pub(crate) fn vec3_at(v: &[f64], k: usize) -> DVec3 {
    DVec3::new(v[k], v[k + 1], v[k + 2])
}

/// Writes `v` as block `block` of a buffer in blocks of N (N = `v.len()`; see `layout`).
pub(crate) fn put_block<T: Copy>(out: &mut [T], block: usize, v: &[T]) {
    out[block * v.len()..(block + 1) * v.len()].copy_from_slice(v);
}

/// Writes `v` as block `block` of a buffer in blocks of N: vector i at `block * N + 3 i`.
pub(crate) fn put_block3(out: &mut [f64], block: usize, v: &[DVec3]) {
    for (i, x) in v.iter().enumerate() {
        put3(out, block * v.len() + 3 * i, *x);
    }
}

/// Particle i's vector in block `block` of a buffer in blocks of `n`.
pub(crate) fn block3(v: &[f64], block: usize, n: usize, i: usize) -> DVec3 {
    vec3_at(v, block * n + 3 * i)
}

/// `state` of the kernels (`layout::state`).
pub(crate) fn state_of(p: &Particles) -> Vec<f64> {
    use layout::state as s;
    let mut out = vec![0.0; s::LEN * p.len()];
    put_block3(&mut out, s::POSITION, &p.position);
    put_block3(&mut out, s::VELOCITY, &p.velocity);
    put_block3(&mut out, s::ANGULAR_VELOCITY, &p.angular_velocity);
    out
}

/// `loads` of the kernels (`layout::loads`).
pub(crate) fn loads_of(p: &Particles) -> Vec<f64> {
    use layout::loads as l;
    let mut out = vec![0.0; l::LEN * p.len()];
    put_block3(&mut out, l::FORCE, &p.force);
    put_block3(&mut out, l::TORQUE, &p.torque);
    put_block(&mut out, l::ROLLING_LIMIT, &p.rolling_torque_limit);
    out
}

/// `props` of the kernels (`layout::props`); every particle in world 0 (a batch sets the worlds).
pub(crate) fn props_of(p: &Particles) -> Vec<f64> {
    use layout::props as r;
    let mut out = vec![0.0; r::LEN * p.len()];
    put_block(&mut out, r::RADIUS, &p.radius);
    put_block(&mut out, r::MASS, &p.mass);
    put_block(&mut out, r::INV_MASS, &p.inv_mass);
    put_block(&mut out, r::INV_INERTIA, &p.inv_inertia);
    out
}

/// `ints` of the kernels (`layout::ints`).
pub(crate) fn ints_of(p: &Particles) -> Vec<u32> {
    use layout::ints as k;
    let material: Vec<u32> = p.material.iter().map(|&m| m as u32).collect();
    let mut out = vec![0; k::LEN * p.len()];
    put_block(&mut out, k::MATERIAL, &material);
    put_block(&mut out, k::BODY, &p.body);
    out
}

/// `counts` of the kernels (`layout::counts`): what a stage run alone leaves out is 0.
#[derive(Default)]
pub(crate) struct Counts {
    pub particles: usize,
    pub pairs: usize,
    pub reverse: usize,
    pub walls: usize,
    pub bonds: usize,
    pub bodies: usize,
}

impl Counts {
    /// The words for a dispatch of `threads` threads.
    pub(crate) fn words(&self, threads: u32) -> [u32; layout::counts::LEN] {
        use layout::counts as c;
        let mut w = [0; c::LEN];
        w[c::PARTICLES] = self.particles as u32;
        w[c::PAIRS] = self.pairs as u32;
        w[c::REVERSE] = self.reverse as u32;
        w[c::WALLS] = self.walls as u32;
        w[c::BONDS] = self.bonds as u32;
        w[c::BODIES] = self.bodies as u32;
        w[c::ROW_WIDTH] = row_width(threads);
        w
    }
}

/// `rows` of the kernels (`layout::rows`) from the CSR rows of the lists: pair, reverse and wall
/// rows as begin and end, then the reverse entries. Without pair lists the pair and reverse rows
/// are empty.
pub(crate) fn rows_of(lists: Option<&NeighbourList>, wall_start: &[u32], n: usize) -> Vec<u32> {
    use layout::rows as r;
    let mut rows = vec![0; r::REVERSE_ENTRIES * n];
    let mut csr = |begin: usize, end: usize, start: &[u32]| {
        put_block(&mut rows, begin, &start[..n]);
        put_block(&mut rows, end, &start[1..=n]);
    };
    if let Some(l) = lists {
        csr(r::PAIR_BEGIN, r::PAIR_END, &l.row_start);
        csr(r::REVERSE_BEGIN, r::REVERSE_END, &l.reverse_start);
    }
    csr(r::WALL_BEGIN, r::WALL_END, wall_start);
    if let Some(l) = lists {
        rows.extend(&l.reverse);
    }
    rows
}

/// Writes contact `q`'s history row (`layout::history`).
pub(crate) fn put_history(out: &mut [f64], q: usize, h: &ContactHistory) {
    put3(out, history::LEN * q + history::TANGENTIAL, h.tangential);
    put3(out, history::LEN * q + history::ROLLING, h.rolling);
}

/// Contact `q`'s history row.
pub(crate) fn history_at(h: &[f64], q: usize) -> ContactHistory {
    ContactHistory {
        tangential: vec3_at(h, history::LEN * q + history::TANGENTIAL),
        rolling: vec3_at(h, history::LEN * q + history::ROLLING),
    }
}

/// Contact histories, one row each.
pub(crate) fn history_of<'a>(h: impl ExactSizeIterator<Item = &'a ContactHistory>) -> Vec<f64> {
    let mut out = vec![0.0; history::LEN * h.len()];
    for (q, h) in h.enumerate() {
        put_history(&mut out, q, h);
    }
    out
}

/// The pair kernel's output rows (`layout::pair_output`).
pub(crate) fn pair_output_of(slots: &[PairOutput]) -> Vec<f64> {
    use pair_output as o;
    let mut out = vec![0.0; o::LEN * slots.len()];
    for (q, s) in slots.iter().enumerate() {
        let row = o::LEN * q;
        put3(&mut out, row + o::FORCE, s.force);
        put3(&mut out, row + o::TORQUE_I, s.torque_i);
        put3(&mut out, row + o::TORQUE_J, s.torque_j);
        out[row + o::ROLLING_I] = s.rolling_i;
        out[row + o::ROLLING_J] = s.rolling_j;
    }
    out
}

/// Pair slot `q`'s output row.
pub(crate) fn pair_output_at(v: &[f64], q: usize) -> PairOutput {
    use pair_output as o;
    let row = o::LEN * q;
    PairOutput {
        force: vec3_at(v, row + o::FORCE),
        torque_i: vec3_at(v, row + o::TORQUE_I),
        torque_j: vec3_at(v, row + o::TORQUE_J),
        rolling_i: v[row + o::ROLLING_I],
        rolling_j: v[row + o::ROLLING_J],
    }
}

/// The wall kernel's output rows (`layout::wall_output`).
pub(crate) fn wall_output_of(slots: &[WallOutput]) -> Vec<f64> {
    use wall_output as o;
    let mut out = vec![0.0; o::LEN * slots.len()];
    for (c, s) in slots.iter().enumerate() {
        let row = o::LEN * c;
        put3(&mut out, row + o::FORCE, s.force);
        put3(&mut out, row + o::TORQUE, s.torque);
        put3(&mut out, row + o::PARTICLE_TORQUE, s.particle_torque);
        out[row + o::ROLLING] = s.rolling;
    }
    out
}

/// Wall candidate slot `c`'s output row.
pub(crate) fn wall_output_at(v: &[f64], c: usize) -> WallOutput {
    use wall_output as o;
    let row = o::LEN * c;
    WallOutput {
        force: vec3_at(v, row + o::FORCE),
        torque: vec3_at(v, row + o::TORQUE),
        particle_torque: vec3_at(v, row + o::PARTICLE_TORQUE),
        rolling: v[row + o::ROLLING],
    }
}

/// `bytes` read back as numbers of `T`: in place where they are aligned for `T` (the allocator
/// aligns a large read-back, the lists' case), else copied. A segment's end reads some tens of
/// bytes a pair slot; copying them all once more cost about half its split's time.
pub(crate) fn numbers<T: bytemuck::Pod>(bytes: &[u8]) -> std::borrow::Cow<'_, [T]> {
    match bytemuck::try_cast_slice(bytes) {
        Ok(v) => std::borrow::Cow::Borrowed(v),
        Err(_) => std::borrow::Cow::Owned(bytemuck::pod_collect_to_vec(bytes)),
    }
}

/// The material pair table (`layout::table`), one row a pair.
pub(crate) fn pair_table(inputs: &StepInputs) -> Vec<f64> {
    use layout::table as t;
    inputs
        .materials
        .pairs()
        .iter()
        .flat_map(|q| {
            let mut row = [0.0; t::LEN];
            row[t::E_STAR] = q.e_star;
            row[t::G_STAR] = q.g_star;
            row[t::TANGENTIAL_DAMPING_RATIO] = q.tangential_damping_ratio;
            row[t::HERTZ_DAMPING] = q.hertz_damping;
            row[t::STATIC_FRICTION] = q.static_friction;
            row[t::ROLLING_FRICTION] = q.rolling_friction;
            row[t::SURFACE_ENERGY] = q.surface_energy;
            row
        })
        .collect()
}

/// An element's row as the kernels read it (`layout::element`): its kind, then its numbers.
pub(crate) fn element_row(e: &Element) -> [f64; element::LEN] {
    use element as f;
    let mut row = [0.0; f::LEN];
    let kind = match *e {
        Element::Plane { point, normal } => {
            put3(&mut row, f::PLANE_POINT, point);
            put3(&mut row, f::PLANE_NORMAL, normal);
            element_kind::PLANE
        }
        Element::Rect {
            center,
            normal,
            u,
            v,
            half_u,
            half_v,
        } => {
            put3(&mut row, f::RECT_CENTER, center);
            put3(&mut row, f::RECT_NORMAL, normal);
            put3(&mut row, f::RECT_U, u);
            put3(&mut row, f::RECT_V, v);
            row[f::RECT_HALF_U] = half_u;
            row[f::RECT_HALF_V] = half_v;
            element_kind::RECT
        }
        Element::Disc {
            center,
            normal,
            radius,
        } => {
            put3(&mut row, f::DISC_CENTER, center);
            put3(&mut row, f::DISC_NORMAL, normal);
            row[f::DISC_RADIUS] = radius;
            element_kind::DISC
        }
        Element::CylinderShell {
            base,
            axis,
            radius,
            length,
        } => {
            put3(&mut row, f::CYLINDER_BASE, base);
            put3(&mut row, f::CYLINDER_AXIS, axis);
            row[f::CYLINDER_RADIUS] = radius;
            row[f::CYLINDER_LENGTH] = length;
            element_kind::CYLINDER
        }
        Element::Triangle { a, b, c } => {
            put3(&mut row, f::TRIANGLE_A, a);
            put3(&mut row, f::TRIANGLE_B, b);
            put3(&mut row, f::TRIANGLE_C, c);
            element_kind::TRIANGLE
        }
    };
    row[f::KIND] = kind as f64;
    row
}

/// A geometry's row (`layout::geometry`); `velocity` is its linear then angular velocity.
pub(crate) fn geometry_row(
    material: f64,
    first_element: f64,
    velocity: [f64; 6],
) -> [f64; geometry::LEN] {
    let mut row = [0.0; geometry::LEN];
    row[geometry::MATERIAL] = material;
    row[geometry::FIRST_ELEMENT] = first_element;
    row[geometry::LINEAR_VELOCITY..geometry::LINEAR_VELOCITY + 3].copy_from_slice(&velocity[..3]);
    row[geometry::ANGULAR_VELOCITY..geometry::ANGULAR_VELOCITY + 3].copy_from_slice(&velocity[3..]);
    row
}

/// A world's block of the params buffer (`layout::params`); a segment sets its steps, and a batch
/// where its geometries, particles and table are.
/// The params block of a stage called with `inputs` (`kick`: the particle sums' second half
/// kick).
pub(crate) fn stage_params(inputs: &StepInputs, kick: bool) -> Vec<f64> {
    params_of(
        inputs.params,
        inputs.clumps,
        kick,
        inputs.materials.len(),
        inputs.cohesive,
    )
}

pub(crate) fn params_of(
    params: &SimulationParams,
    clumps: bool,
    kick: bool,
    materials: usize,
    cohesive: bool,
) -> Vec<f64> {
    use layout::params as p;
    let flag = |b: bool| if b { 1.0 } else { 0.0 };
    let mut block = vec![0.0; p::LEN];
    block[p::DT] = params.time_step;
    put3(&mut block, p::GRAVITY, params.gravity);
    if let Some((lo, hi)) = params.domain {
        block[p::HAS_DOMAIN] = 1.0;
        put3(&mut block, p::DOMAIN_LOW, lo);
        put3(&mut block, p::DOMAIN_HIGH, hi);
    }
    block[p::CLUMPS] = flag(clumps);
    block[p::KICK] = flag(kick);
    (block[p::ROLLING_MODEL], block[p::ROLLING_DAMPING]) = match params.rolling_model {
        RollingModel::ConstantDirectionalTorque => (0.0, 0.0),
        RollingModel::Epsd { viscous_damping } => (1.0, viscous_damping),
    };
    block[p::MATERIALS] = materials as f64;
    block[p::COHESIVE] = flag(cohesive);
    block[p::STEPPING] = 1.0;
    block
}
