//! Geometry as surfaces for ParaView: every element in its current pose as polygons, with the
//! geometry it belongs to as cell data.
//!
//! An infinite plane is drawn as its cut through a box (the simulation domain: where particles
//! can be); a cylinder shell and a disc as [`SEGMENTS`] facets round; mesh triangles share their
//! corners, so a mesh file is about half the size of one with three points per triangle.

use super::vtp::{Cells, DataArray, PolyData};
use crate::geometry::{Element, Geometry};
use glam::DVec3;
use std::collections::HashMap;

/// Facets round a cylinder or a disc: about 0.2 % short of the true circumference, fine to see.
pub const SEGMENTS: usize = 48;

/// The surfaces of `geometries[k]` for every k in `which`; planes are cut by `extent`.
/// Cell data: `geometry_id` (the index in the scene's geometry list, the order of
/// `geometry_forces.csv`) and `material_id`; field data `geometry_names` (index = geometry_id).
pub fn polydata(geometries: &[Geometry], which: &[usize], extent: (DVec3, DVec3)) -> PolyData {
    let mut out = Surface::default();
    let mut geometry_id = Vec::new();
    let mut material_id = Vec::new();
    for &g in which {
        let geometry = &geometries[g];
        let before = out.polys.len();
        out.shared.clear();
        for e in &geometry.elements {
            out.element(e, extent);
        }
        let added = out.polys.len() - before;
        geometry_id.extend(std::iter::repeat_n(g as i32, added));
        material_id.extend(std::iter::repeat_n(geometry.material as i32, added));
    }
    PolyData {
        points: out.points,
        polys: out.polys,
        cell_data: vec![
            DataArray::scalars_i32("geometry_id", geometry_id),
            DataArray::scalars_i32("material_id", material_id),
        ],
        field_data: vec![DataArray::strings(
            "geometry_names",
            geometries.iter().map(|g| g.name.clone()).collect(),
        )],
        ..Default::default()
    }
}

#[derive(Default)]
struct Surface {
    points: Vec<DVec3>,
    polys: Cells,
    /// Points of the current geometry by their exact coordinates, for meshes to share corners.
    shared: HashMap<[u64; 3], usize>,
}

impl Surface {
    fn point(&mut self, x: DVec3) -> usize {
        self.points.push(x);
        self.points.len() - 1
    }

    fn polygon(&mut self, corners: &[DVec3]) {
        let first = self.points.len();
        self.points.extend_from_slice(corners);
        self.polys.push(first..first + corners.len());
    }

    fn shared_point(&mut self, x: DVec3) -> usize {
        let key = [x.x.to_bits(), x.y.to_bits(), x.z.to_bits()];
        if let Some(&p) = self.shared.get(&key) {
            return p;
        }
        let p = self.point(x);
        self.shared.insert(key, p);
        p
    }

    fn element(&mut self, e: &Element, extent: (DVec3, DVec3)) {
        match *e {
            Element::Plane { point, normal } => {
                let polygon = plane_in_box(point, normal, extent);
                self.polygon(&polygon);
            }
            Element::Rect {
                center,
                u,
                v,
                half_u,
                half_v,
                ..
            } => {
                let (a, b) = (u * half_u, v * half_v);
                self.polygon(&[
                    center - a - b,
                    center + a - b,
                    center + a + b,
                    center - a + b,
                ]);
            }
            Element::Disc {
                center,
                normal,
                radius,
            } => {
                let (u, v) = in_plane_axes(normal);
                let rim: Vec<DVec3> = (0..SEGMENTS)
                    .map(|s| center + radius * round(u, v, s))
                    .collect();
                self.polygon(&rim);
            }
            Element::CylinderShell {
                base,
                axis,
                radius,
                length,
            } => {
                let (u, v) = in_plane_axes(axis);
                let first = self.points.len();
                for s in 0..SEGMENTS {
                    let r = radius * round(u, v, s);
                    self.point(base + r);
                    self.point(base + axis * length + r);
                }
                for s in 0..SEGMENTS {
                    let (a, b) = (first + 2 * s, first + 2 * ((s + 1) % SEGMENTS));
                    self.polys.push([a, b, b + 1, a + 1]);
                }
            }
            Element::Triangle { a, b, c } => {
                let corners = [
                    self.shared_point(a),
                    self.shared_point(b),
                    self.shared_point(c),
                ];
                self.polys.push(corners);
            }
        }
    }
}

/// Unit direction of facet corner `s` round an axis with in-plane axes `u`, `v`.
fn round(u: DVec3, v: DVec3, s: usize) -> DVec3 {
    let a = std::f64::consts::TAU * s as f64 / SEGMENTS as f64;
    u * a.cos() + v * a.sin()
}

/// Two unit vectors perpendicular to `normal` and to each other.
fn in_plane_axes(normal: DVec3) -> (DVec3, DVec3) {
    let n = normal.normalize();
    let u = n.any_orthonormal_vector();
    (u, n.cross(u))
}

/// The polygon where the plane through `point` with `normal` cuts the box `extent`, in order
/// round the plane; when the plane misses the box, a square as wide as the box's diagonal
/// centred on the box centre's foot on the plane, so the plane is still seen.
pub fn plane_in_box(point: DVec3, normal: DVec3, extent: (DVec3, DVec3)) -> Vec<DVec3> {
    let (lo, hi) = extent;
    let n = normal.normalize();
    let corner = |k: usize| {
        DVec3::new(
            if k & 1 == 0 { lo.x } else { hi.x },
            if k & 2 == 0 { lo.y } else { hi.y },
            if k & 4 == 0 { lo.z } else { hi.z },
        )
    };
    let size = (hi - lo).length().max(1e-12);
    let mut cut: Vec<DVec3> = Vec::new();
    // The 12 edges join corners that differ in one bit.
    for a in 0..8 {
        for bit in [1, 2, 4] {
            let b = a | bit;
            if b == a {
                continue;
            }
            let (p, q) = (corner(a), corner(b));
            let (sp, sq) = ((p - point).dot(n), (q - point).dot(n));
            if (sp < 0.0) == (sq < 0.0) && sp != 0.0 && sq != 0.0 {
                continue;
            }
            let x = if sp == sq {
                p
            } else {
                p + (q - p) * (sp / (sp - sq))
            };
            if cut.iter().all(|c| (*c - x).length() > 1e-9 * size) {
                cut.push(x);
            }
        }
    }
    let (u, v) = in_plane_axes(n);
    if cut.len() < 3 {
        let centre = (lo + hi) * 0.5;
        let foot = centre - n * (centre - point).dot(n);
        let h = 0.5 * size;
        return vec![
            foot - u * h - v * h,
            foot + u * h - v * h,
            foot + u * h + v * h,
            foot - u * h + v * h,
        ];
    }
    let mid = cut.iter().copied().sum::<DVec3>() / cut.len() as f64;
    cut.sort_by(|a, b| {
        let angle = |x: &DVec3| (*x - mid).dot(v).atan2((*x - mid).dot(u));
        angle(a).total_cmp(&angle(b))
    });
    cut
}
