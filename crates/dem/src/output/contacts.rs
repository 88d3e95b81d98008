//! The contact force network: a line between the centres of every two spheres that push (or
//! pull) on each other, with the force as cell data.

use super::particles::{point_of, stable_order};
use super::vtp::{Cells, DataArray, PolyData};
use crate::particles::Particles;
use crate::sim::PairContact;
use glam::DVec3;

/// Points: every sphere centre in stable-id order (the particles file's points), with `id`.
/// Cells: one line per contact, from the sphere of lower stable id to the other, with
/// `force` (N, the force on the line's first sphere from the second), `normal_force` (N, its
/// component along the line, positive pushing the spheres apart, negative pulling them together),
/// `tangential_force` (N, the rest of the force) and `overlap` (m, negative for a cohesive pair
/// pulling across a gap).
pub fn polydata(particles: &Particles, contacts: &[PairContact]) -> PolyData {
    let order = stable_order(particles);
    let point = point_of(&order);
    let p = particles;
    let mut lines = Cells::default();
    let (mut force, mut normal, mut tangential, mut overlap) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let mut sorted: Vec<PairContact> = contacts
        .iter()
        .map(|c| {
            if p.id[c.i] <= p.id[c.j] {
                *c
            } else {
                PairContact {
                    i: c.j,
                    j: c.i,
                    force: -c.force,
                }
            }
        })
        .collect();
    // Stable-id order, so two snapshots' files list the same contact at comparable places.
    sorted.sort_unstable_by_key(|c| (p.id[c.i], p.id[c.j]));
    for c in &sorted {
        lines.push([point[c.i], point[c.j]]);
        let delta = p.position[c.i] - p.position[c.j];
        let distance = delta.length();
        // From j to i: a force along it pushes i away from j.
        let n = if distance > 0.0 {
            delta / distance
        } else {
            DVec3::ZERO
        };
        let fn_ = c.force.dot(n);
        force.push(c.force);
        normal.push(fn_);
        tangential.push(c.force - n * fn_);
        overlap.push(p.radius[c.i] + p.radius[c.j] - distance);
    }
    PolyData {
        points: order.iter().map(|&k| p.position[k]).collect(),
        lines,
        point_data: vec![DataArray::scalars_i32(
            "id",
            order.iter().map(|&k| p.id[k] as i32).collect(),
        )],
        cell_data: vec![
            DataArray::scalars_f64("normal_force", normal),
            DataArray::vectors("force", force),
            DataArray::vectors("tangential_force", tangential),
            DataArray::scalars_f64("overlap", overlap),
        ],
        ..Default::default()
    }
}
