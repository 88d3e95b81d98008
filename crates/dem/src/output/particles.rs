//! The spheres of a snapshot as points, in stable-id order so that point k is the same sphere in
//! every file of a run.

use super::vtp::{DataArray, PolyData};
use crate::clump::Bodies;
use crate::particles::{Particles, NO_BODY};
use glam::{DQuat, DVec3};

/// `clump_id` of a sphere that belongs to no clump.
pub const FREE_SPHERE: i32 = -1;

/// Particle indices sorted by stable id.
pub fn stable_order(particles: &Particles) -> Vec<usize> {
    let mut by_id: Vec<usize> = (0..particles.len()).collect();
    by_id.sort_unstable_by_key(|&k| particles.id[k]);
    by_id
}

/// Point index of each particle index in a file written in `order` (the inverse permutation).
pub fn point_of(order: &[usize]) -> Vec<usize> {
    let mut point = vec![0; order.len()];
    for (p, &k) in order.iter().enumerate() {
        point[k] = p;
    }
    point
}

/// Points with a vertex each and the arrays: `radius`, `material_id`, `id` (stable), `velocity`,
/// `angular_velocity`, and for clump members `clump_id` (the clump's index, [`FREE_SPHERE`] for
/// a free sphere), `orientation` (the clump's rotation from its body frame as a quaternion
/// w, x, y, z; 1, 0, 0, 0 for a free sphere) and `clump_axis` (the clump's first principal axis,
/// the one of least inertia: a rod's long axis; zero for a free sphere).
pub fn polydata(particles: &Particles, bodies: &Bodies) -> PolyData {
    let order = stable_order(particles);
    let p = particles;
    let body_of = |k: usize| {
        let b = p.body[k];
        (b != NO_BODY && (b as usize) < bodies.len()).then_some(b as usize)
    };
    let orientation =
        |k: usize| body_of(k).map_or(DQuat::IDENTITY, |b| bodies.rotation[b].orientation);
    let each_f64 = |f: &dyn Fn(usize) -> f64| order.iter().map(|&k| f(k)).collect::<Vec<_>>();
    let each_i32 = |f: &dyn Fn(usize) -> i32| order.iter().map(|&k| f(k)).collect::<Vec<_>>();
    let each_vec = |f: &dyn Fn(usize) -> DVec3| order.iter().map(|&k| f(k)).collect::<Vec<_>>();
    let mut point_data = vec![
        DataArray::scalars_f64("radius", each_f64(&|k| p.radius[k])),
        DataArray::scalars_i32("material_id", each_i32(&|k| p.material[k] as i32)),
        DataArray::scalars_i32("id", each_i32(&|k| p.id[k] as i32)),
        DataArray::vectors("velocity", each_vec(&|k| p.velocity[k])),
        DataArray::vectors("angular_velocity", each_vec(&|k| p.angular_velocity[k])),
        DataArray::scalars_i32(
            "clump_id",
            each_i32(&|k| body_of(k).map_or(FREE_SPHERE, |b| b as i32)),
        ),
    ];
    point_data.push(DataArray {
        name: "orientation".into(),
        components: 4,
        values: super::vtp::Values::F64(
            order
                .iter()
                .flat_map(|&k| {
                    let q = orientation(k);
                    [q.w, q.x, q.y, q.z]
                })
                .collect(),
        ),
    });
    point_data.push(DataArray::vectors(
        "clump_axis",
        each_vec(&|k| body_of(k).map_or(DVec3::ZERO, |_| orientation(k) * DVec3::X)),
    ));
    PolyData {
        points: each_vec(&|k| p.position[k]),
        point_data,
        ..Default::default()
    }
    .with_a_vertex_per_point()
}
