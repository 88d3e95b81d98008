//! Polyhedral particles as surfaces: each body's faces as polygons in the world, with the
//! particle's id, body id, material and velocity per face (so ParaView colours a whole particle).
//! The particles file still lists each polyhedron's bounding sphere (its proxy).

use super::vtp::{Cells, DataArray, PolyData};
use crate::clump::Bodies;
use crate::particles::Particles;

/// The polyhedra of `bodies` (None when there are none), as of the last update of their world
/// frames ([`Bodies::update_polyhedra`]).
pub fn polydata(particles: &Particles, bodies: &Bodies) -> Option<PolyData> {
    let frames = &bodies.polyhedra;
    if !frames.any() {
        return None;
    }
    let mut out = PolyData::default();
    let mut polys = Cells::default();
    let (mut id, mut body_id, mut material, mut velocity) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for k in 0..particles.len() {
        let b = particles.body[k];
        let Some((shape, _, vertices)) = frames.world(b) else {
            continue;
        };
        let body = b as usize;
        let first = out.points.len();
        out.points.extend(vertices);
        for f in 0..shape.faces.len() {
            polys.push(shape.face(f).iter().map(|&v| first + v as usize));
            id.push(particles.id[k] as i32);
            body_id.push(b as i32);
            material.push(particles.material[k] as i32);
            velocity.push(bodies.velocity[body]);
        }
    }
    out.polys = polys;
    out.cell_data = vec![
        DataArray::scalars_i32("id", id),
        DataArray::scalars_i32("clump_id", body_id),
        DataArray::scalars_i32("material_id", material),
        DataArray::vectors("velocity", velocity),
    ];
    Some(out)
}
