//! Walls and meshes: analytic planes, boxes, cylinder shells and STL triangle meshes, their motion,
//! and the load (force and torque) each one records.
//!
//! Every geometry is reduced to a list of primitive [`Element`]s kept in a reference frame plus a rigid
//! transform, so contact detection only needs one closest-point routine per primitive, and motion is
//! the same for an analytic wall and a mesh.

use glam::{DMat3, DVec3};
use std::path::Path;

/// Where on a primitive the closest point lies: a face contact is preferred over an edge or vertex
/// contact at the same place, so a sphere on a flat patch of triangles is not pushed twice.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Feature {
    Face,
    Edge,
}

/// A primitive surface.
#[derive(Clone, Debug)]
pub enum Element {
    /// Infinite one-sided plane; particles live on the side the normal points to.
    Plane { point: DVec3, normal: DVec3 },
    /// Finite two-sided rectangle: centre, unit normal, unit in-plane axes, half sizes.
    Rect {
        center: DVec3,
        normal: DVec3,
        u: DVec3,
        v: DVec3,
        half_u: f64,
        half_v: f64,
    },
    /// Two-sided disc.
    Disc {
        center: DVec3,
        normal: DVec3,
        radius: f64,
    },
    /// Open cylinder shell from `base` along unit `axis` for `length`, contact from inside or outside.
    CylinderShell {
        base: DVec3,
        axis: DVec3,
        radius: f64,
        length: f64,
    },
    /// Two-sided triangle.
    Triangle { a: DVec3, b: DVec3, c: DVec3 },
}

/// Closest point of an element to a sphere centre.
#[derive(Clone, Copy, Debug)]
pub struct Closest {
    pub point: DVec3,
    /// Unit vector from the surface toward the sphere centre.
    pub normal: DVec3,
    /// Signed distance along `normal` from the surface to the centre.
    pub distance: f64,
    pub feature: Feature,
}

fn closest_from_vector(point: DVec3, x: DVec3, feature: Feature) -> Option<Closest> {
    let d = x - point;
    let dist = d.length();
    if dist <= 0.0 {
        return None;
    }
    Some(Closest {
        point,
        normal: d / dist,
        distance: dist,
        feature,
    })
}

impl Element {
    /// Closest point to `x`, or `None` when the centre is behind a one-sided plane by more than `reach`,
    /// or exactly on a surface (no defined normal).
    pub fn closest(&self, x: DVec3, reach: f64) -> Option<Closest> {
        match *self {
            Element::Plane { point, normal } => {
                let s = (x - point).dot(normal);
                if s < -reach {
                    return None;
                }
                Some(Closest {
                    point: x - s * normal,
                    normal,
                    distance: s,
                    feature: Feature::Face,
                })
            }
            Element::Rect {
                center,
                normal,
                u,
                v,
                half_u,
                half_v,
            } => {
                let r = x - center;
                let (pu, pv, s) = (r.dot(u), r.dot(v), r.dot(normal));
                if pu.abs() <= half_u && pv.abs() <= half_v {
                    let side = if s >= 0.0 { 1.0 } else { -1.0 };
                    Some(Closest {
                        point: x - s * normal,
                        normal: side * normal,
                        distance: s.abs(),
                        feature: Feature::Face,
                    })
                } else {
                    let q = center + pu.clamp(-half_u, half_u) * u + pv.clamp(-half_v, half_v) * v;
                    closest_from_vector(q, x, Feature::Edge)
                }
            }
            Element::Disc {
                center,
                normal,
                radius,
            } => {
                let r = x - center;
                let s = r.dot(normal);
                let inplane = r - s * normal;
                let rho = inplane.length();
                if rho <= radius {
                    let side = if s >= 0.0 { 1.0 } else { -1.0 };
                    Some(Closest {
                        point: x - s * normal,
                        normal: side * normal,
                        distance: s.abs(),
                        feature: Feature::Face,
                    })
                } else {
                    closest_from_vector(center + inplane * (radius / rho), x, Feature::Edge)
                }
            }
            Element::CylinderShell {
                base,
                axis,
                radius,
                length,
            } => {
                let r = x - base;
                let h = r.dot(axis);
                let radial = r - h * axis;
                let rho = radial.length();
                if rho <= 0.0 {
                    return None;
                }
                let e = radial / rho;
                if (0.0..=length).contains(&h) {
                    let side = if rho >= radius { 1.0 } else { -1.0 };
                    Some(Closest {
                        point: base + h * axis + radius * e,
                        normal: side * e,
                        distance: (rho - radius).abs(),
                        feature: Feature::Face,
                    })
                } else {
                    let q = base + h.clamp(0.0, length) * axis + radius * e;
                    closest_from_vector(q, x, Feature::Edge)
                }
            }
            Element::Triangle { a, b, c } => closest_on_triangle(a, b, c, x),
        }
    }

    /// Unsigned distance from a point to the surface (zero on it).
    pub fn distance_to(&self, q: DVec3) -> f64 {
        self.closest(q, f64::INFINITY)
            .map_or(0.0, |c| c.distance.abs())
    }

    /// Axis-aligned bounds; infinite for planes.
    pub fn bounds(&self) -> (DVec3, DVec3) {
        match *self {
            Element::Plane { .. } => (DVec3::splat(f64::NEG_INFINITY), DVec3::splat(f64::INFINITY)),
            Element::Rect {
                center,
                u,
                v,
                half_u,
                half_v,
                ..
            } => {
                let ext = (u * half_u).abs() + (v * half_v).abs();
                (center - ext, center + ext)
            }
            Element::Disc {
                center,
                normal,
                radius,
            } => {
                let ext = disc_extent(normal, radius);
                (center - ext, center + ext)
            }
            Element::CylinderShell {
                base,
                axis,
                radius,
                length,
            } => {
                let ext = disc_extent(axis, radius);
                let top = base + axis * length;
                (base.min(top) - ext, base.max(top) + ext)
            }
            Element::Triangle { a, b, c } => (a.min(b).min(c), a.max(b).max(c)),
        }
    }

    /// The element moved by a rigid transform `x -> rot * x + trans`.
    pub fn transformed(&self, rot: &DMat3, trans: DVec3) -> Element {
        let p = |x: DVec3| *rot * x + trans;
        let d = |x: DVec3| *rot * x;
        match *self {
            Element::Plane { point, normal } => Element::Plane {
                point: p(point),
                normal: d(normal),
            },
            Element::Rect {
                center,
                normal,
                u,
                v,
                half_u,
                half_v,
            } => Element::Rect {
                center: p(center),
                normal: d(normal),
                u: d(u),
                v: d(v),
                half_u,
                half_v,
            },
            Element::Disc {
                center,
                normal,
                radius,
            } => Element::Disc {
                center: p(center),
                normal: d(normal),
                radius,
            },
            Element::CylinderShell {
                base,
                axis,
                radius,
                length,
            } => Element::CylinderShell {
                base: p(base),
                axis: d(axis),
                radius,
                length,
            },
            Element::Triangle { a, b, c } => Element::Triangle {
                a: p(a),
                b: p(b),
                c: p(c),
            },
        }
    }
}

/// Half extents along x, y, z of a circle of `radius` whose plane has unit normal `axis`.
pub fn disc_extent(axis: DVec3, radius: f64) -> DVec3 {
    (DVec3::ONE - axis * axis).max(DVec3::ZERO).powf(0.5) * radius
}

/// Closest point on triangle abc to x (Ericson, Real-Time Collision Detection, 5.1.5), with the
/// region it falls in.
pub fn closest_on_triangle(a: DVec3, b: DVec3, c: DVec3, x: DVec3) -> Option<Closest> {
    let ab = b - a;
    let ac = c - a;
    let ap = x - a;
    let d1 = ab.dot(ap);
    let d2 = ac.dot(ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return closest_from_vector(a, x, Feature::Edge);
    }
    let bp = x - b;
    let d3 = ab.dot(bp);
    let d4 = ac.dot(bp);
    if d3 >= 0.0 && d4 <= d3 {
        return closest_from_vector(b, x, Feature::Edge);
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let t = d1 / (d1 - d3);
        return closest_from_vector(a + t * ab, x, Feature::Edge);
    }
    let cp = x - c;
    let d5 = ab.dot(cp);
    let d6 = ac.dot(cp);
    if d6 >= 0.0 && d5 <= d6 {
        return closest_from_vector(c, x, Feature::Edge);
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let t = d2 / (d2 - d6);
        return closest_from_vector(a + t * ac, x, Feature::Edge);
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let t = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return closest_from_vector(b + t * (c - b), x, Feature::Edge);
    }
    let denom = 1.0 / (va + vb + vc);
    let v = vb * denom;
    let w = vc * denom;
    let q = a + ab * v + ac * w;
    let nrm = ab.cross(ac).normalize();
    let s = (x - q).dot(nrm);
    let side = if s >= 0.0 { 1.0 } else { -1.0 };
    Some(Closest {
        point: q,
        normal: side * nrm,
        distance: s.abs(),
        feature: Feature::Face,
    })
}

/// One segment of prescribed motion, active on `[start, end)` in simulated time.
#[derive(Clone, Debug, PartialEq)]
pub enum Motion {
    Translation {
        velocity: DVec3,
        start: f64,
        end: f64,
    },
    /// Rotation about the axis through `axis_point` (a point that moves with the geometry).
    Rotation {
        axis_point: DVec3,
        axis: DVec3,
        /// rad/s, right-handed about `axis`.
        angular_velocity: f64,
        start: f64,
        end: f64,
    },
}

impl Motion {
    fn active(&self, t: f64) -> bool {
        let (s, e) = match *self {
            Motion::Translation { start, end, .. } | Motion::Rotation { start, end, .. } => {
                (start, end)
            }
        };
        t >= s && t < e
    }
}

/// Rigid-body velocity field v(p) = linear + angular x p.
#[derive(Clone, Copy, Debug, Default)]
pub struct VelocityField {
    pub linear: DVec3,
    pub angular: DVec3,
}

impl VelocityField {
    #[inline(always)]
    pub fn at(&self, p: DVec3) -> DVec3 {
        self.linear + self.angular.cross(p)
    }
}

/// Force and torque a geometry receives from the particles.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Load {
    pub force: DVec3,
    pub torque: DVec3,
}

/// A wall or mesh with its material, motion and current pose.
#[derive(Clone, Debug)]
pub struct Geometry {
    pub name: String,
    pub material: usize,
    /// Elements in the reference (t = 0) frame.
    pub reference: Vec<Element>,
    /// Elements in the current pose.
    pub elements: Vec<Element>,
    pub motion: Vec<Motion>,
    pub rotation: DMat3,
    pub translation: DVec3,
    pub velocity: VelocityField,
    /// Torque is reported about this point (moves with the geometry).
    pub torque_point: DVec3,
    pub load: Load,
    /// Uniform grid over the reference frame's triangles, for meshes with many elements.
    pub(crate) grid: Option<ElementGrid>,
}

impl Geometry {
    pub fn new(name: &str, material: usize, elements: Vec<Element>) -> Self {
        Geometry {
            name: name.to_string(),
            material,
            elements: elements.clone(),
            reference: elements,
            motion: Vec::new(),
            rotation: DMat3::IDENTITY,
            translation: DVec3::ZERO,
            velocity: VelocityField::default(),
            torque_point: DVec3::ZERO,
            load: Load::default(),
            grid: None,
        }
    }

    pub fn with_motion(mut self, motion: Vec<Motion>) -> Self {
        self.motion = motion;
        self
    }

    /// Current world position of a reference-frame point.
    pub fn to_world(&self, p: DVec3) -> DVec3 {
        self.rotation * p + self.translation
    }

    pub fn is_moving_at(&self, t: f64) -> bool {
        self.motion.iter().any(|m| m.active(t))
    }

    /// Sets the velocity field for the step starting at `t` and advances the pose by `dt`.
    /// Returns true when the geometry moved.
    pub fn advance(&mut self, t: f64, dt: f64) -> bool {
        let mut field = VelocityField::default();
        let mut moved = false;
        for m in &self.motion {
            if !m.active(t) {
                continue;
            }
            moved = true;
            match *m {
                Motion::Translation { velocity, .. } => {
                    field.linear += velocity;
                    self.translation += velocity * dt;
                }
                Motion::Rotation {
                    axis_point,
                    axis,
                    angular_velocity,
                    ..
                } => {
                    let axis = axis.normalize();
                    let centre = self.to_world(axis_point);
                    let w = axis * angular_velocity;
                    field.angular += w;
                    field.linear -= w.cross(centre);
                    let r = DMat3::from_axis_angle(axis, angular_velocity * dt);
                    self.rotation = r * self.rotation;
                    self.translation = r * (self.translation - centre) + centre;
                }
            }
        }
        self.velocity = field;
        if moved {
            for (e, r) in self.elements.iter_mut().zip(&self.reference) {
                *e = r.transformed(&self.rotation, self.translation);
            }
        }
        moved
    }

    /// Largest displacement of any point of `lo..hi` between the pose (rot0, trans0) and now.
    pub fn displacement_since(&self, rot0: &DMat3, trans0: DVec3, lo: DVec3, hi: DVec3) -> f64 {
        // A rigid displacement field is affine in the point, so its length is largest at a corner.
        let inv0 = rot0.transpose();
        let mut worst: f64 = 0.0;
        for k in 0..8 {
            let p = DVec3::new(
                if k & 1 == 0 { lo.x } else { hi.x },
                if k & 2 == 0 { lo.y } else { hi.y },
                if k & 4 == 0 { lo.z } else { hi.z },
            );
            let reference = inv0 * (p - trans0);
            worst = worst.max((self.to_world(reference) - p).length());
        }
        worst
    }
}

/// Uniform grid of element ids over the reference frame, for fast candidate lookup in large meshes.
#[derive(Clone, Debug)]
pub(crate) struct ElementGrid {
    lo: DVec3,
    cell: f64,
    dims: [usize; 3],
    start: Vec<u32>,
    items: Vec<u32>,
}

impl ElementGrid {
    /// Bins elements whose bounds, widened by `reach`, touch a cell.
    pub(crate) fn build(elements: &[Element], reach: f64) -> Option<ElementGrid> {
        let mut lo = DVec3::splat(f64::INFINITY);
        let mut hi = DVec3::splat(f64::NEG_INFINITY);
        for e in elements {
            let (a, b) = e.bounds();
            if !a.is_finite() || !b.is_finite() {
                return None;
            }
            lo = lo.min(a);
            hi = hi.max(b);
        }
        lo -= DVec3::splat(reach);
        hi += DVec3::splat(reach);
        let ext = hi - lo;
        // About as many cells as elements, but never thinner than the reach.
        let target = (elements.len().max(1) as f64).cbrt().max(1.0);
        let cell = (ext.max_element() / target).max(2.0 * reach).max(1e-9);
        let dims = [
            ((ext.x / cell).ceil() as usize).max(1),
            ((ext.y / cell).ceil() as usize).max(1),
            ((ext.z / cell).ceil() as usize).max(1),
        ];
        let ncell = dims[0] * dims[1] * dims[2];
        let mut lists: Vec<Vec<u32>> = vec![Vec::new(); ncell];
        for (k, e) in elements.iter().enumerate() {
            let (a, b) = e.bounds();
            let a = ((a - DVec3::splat(reach) - lo) / cell).floor();
            let b = ((b + DVec3::splat(reach) - lo) / cell).floor();
            let clamp = |v: f64, d: usize| (v.max(0.0) as usize).min(d - 1);
            for z in clamp(a.z, dims[2])..=clamp(b.z, dims[2]) {
                for y in clamp(a.y, dims[1])..=clamp(b.y, dims[1]) {
                    for x in clamp(a.x, dims[0])..=clamp(b.x, dims[0]) {
                        lists[x + dims[0] * (y + dims[1] * z)].push(k as u32);
                    }
                }
            }
        }
        let mut start = Vec::with_capacity(ncell + 1);
        let mut items = Vec::new();
        start.push(0);
        for l in lists {
            items.extend_from_slice(&l);
            start.push(items.len() as u32);
        }
        Some(ElementGrid {
            lo,
            cell,
            dims,
            start,
            items,
        })
    }

    /// Element ids near a reference-frame point; empty outside the grid.
    pub(crate) fn near(&self, p: DVec3) -> &[u32] {
        let c = ((p - self.lo) / self.cell).floor();
        if c.x < 0.0 || c.y < 0.0 || c.z < 0.0 {
            return &[];
        }
        let (x, y, z) = (c.x as usize, c.y as usize, c.z as usize);
        if x >= self.dims[0] || y >= self.dims[1] || z >= self.dims[2] {
            return &[];
        }
        let k = x + self.dims[0] * (y + self.dims[1] * z);
        &self.items[self.start[k] as usize..self.start[k + 1] as usize]
    }

    pub(crate) fn reach(&self) -> f64 {
        self.cell
    }
}

/// Builders for the analytic geometries.
pub mod shapes {
    use super::*;

    /// Faces of an axis-aligned box, normals pointing inward. `open` lists the faces to leave out,
    /// as "-x", "+x", "-y", "+y", "-z", "+z".
    pub fn box_walls(lo: DVec3, hi: DVec3, open: &[String]) -> Vec<Element> {
        let c = (lo + hi) * 0.5;
        let h = (hi - lo) * 0.5;
        let mut out = Vec::new();
        let faces = [
            ("-x", DVec3::X, lo.x, DVec3::Y, DVec3::Z, h.y, h.z),
            ("+x", -DVec3::X, hi.x, DVec3::Y, DVec3::Z, h.y, h.z),
            ("-y", DVec3::Y, lo.y, DVec3::X, DVec3::Z, h.x, h.z),
            ("+y", -DVec3::Y, hi.y, DVec3::X, DVec3::Z, h.x, h.z),
            ("-z", DVec3::Z, lo.z, DVec3::X, DVec3::Y, h.x, h.y),
            ("+z", -DVec3::Z, hi.z, DVec3::X, DVec3::Y, h.x, h.y),
        ];
        for (name, normal, at, u, v, hu, hv) in faces {
            if open.iter().any(|o| o == name) {
                continue;
            }
            let axis = normal.abs();
            let center = c - axis * c.dot(axis) + axis * at;
            out.push(Element::Rect {
                center,
                normal,
                u,
                v,
                half_u: hu,
                half_v: hv,
            });
        }
        out
    }

    /// A cylinder shell with optional end caps ("bottom" at `base`, "top" at the far end).
    pub fn cylinder(
        base: DVec3,
        axis: DVec3,
        radius: f64,
        length: f64,
        bottom: bool,
        top: bool,
    ) -> Vec<Element> {
        let axis = axis.normalize();
        let mut out = vec![Element::CylinderShell {
            base,
            axis,
            radius,
            length,
        }];
        if bottom {
            out.push(Element::Disc {
                center: base,
                normal: axis,
                radius,
            });
        }
        if top {
            out.push(Element::Disc {
                center: base + axis * length,
                normal: -axis,
                radius,
            });
        }
        out
    }
}

/// Reads a binary or ASCII STL file, scales it (e.g. 0.001 for a model drawn in mm) and offsets it.
pub fn read_stl(path: &Path, scale: f64, offset: DVec3) -> Result<Vec<Element>, String> {
    let mut file = crate::files::open_checked(path, crate::files::MAX_MESH_BYTES)
        .map_err(|e| format!("cannot open: {e}"))?;
    stl_triangles(&mut file, scale, offset)
}

/// The triangles of a binary or ASCII STL read from `stl` (see `read_stl`).
pub fn stl_triangles<R: std::io::Read + std::io::Seek>(
    stl: &mut R,
    scale: f64,
    offset: DVec3,
) -> Result<Vec<Element>, String> {
    let mesh = stl_io::read_stl(stl).map_err(|e| format!("not a valid STL file: {e}"))?;
    let v = |i: usize| {
        let p = mesh.vertices[i];
        DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64) * scale + offset
    };
    let mut out = Vec::with_capacity(mesh.faces.len());
    for f in &mesh.faces {
        let (a, b, c) = (v(f.vertices[0]), v(f.vertices[1]), v(f.vertices[2]));
        // Degenerate triangles have no normal and can only produce spurious edge contacts.
        if (b - a).cross(c - a).length_squared() > 0.0 {
            out.push(Element::Triangle { a, b, c });
        }
    }
    if out.is_empty() {
        return Err("the STL file holds no triangles".into());
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn triangle_regions() {
        let (a, b, c) = (DVec3::ZERO, DVec3::X, DVec3::Y);
        let f = closest_on_triangle(a, b, c, DVec3::new(0.2, 0.2, 0.5)).unwrap();
        assert_eq!(f.feature, Feature::Face);
        assert!((f.distance - 0.5).abs() < 1e-12);
        let e = closest_on_triangle(a, b, c, DVec3::new(0.5, -0.3, 0.4)).unwrap();
        assert_eq!(e.feature, Feature::Edge);
        assert!((e.point - DVec3::new(0.5, 0.0, 0.0)).length() < 1e-12);
        assert!((e.distance - 0.5).abs() < 1e-12);
        let v = closest_on_triangle(a, b, c, DVec3::new(-1.0, -1.0, 0.0)).unwrap();
        assert!((v.point - a).length() < 1e-12);
    }

    #[test]
    fn cylinder_inside_contact() {
        let shell = Element::CylinderShell {
            base: DVec3::ZERO,
            axis: DVec3::Z,
            radius: 0.05,
            length: 0.1,
        };
        let c = shell.closest(DVec3::new(0.04, 0.0, 0.05), 0.01).unwrap();
        assert!((c.distance - 0.01).abs() < 1e-12);
        assert!((c.normal + DVec3::X).length() < 1e-12);
    }

    #[test]
    fn motion_sequence_translates_then_turns_about_the_moved_axis() {
        let p = DVec3::new(1.0, 0.0, 0.0);
        let mut g = Geometry::new(
            "g",
            0,
            vec![Element::Plane {
                point: p,
                normal: DVec3::Z,
            }],
        )
        .with_motion(vec![
            Motion::Translation {
                velocity: DVec3::new(0.0, 0.0, 1.0),
                start: 0.0,
                end: 0.5,
            },
            Motion::Rotation {
                axis_point: DVec3::ZERO,
                axis: DVec3::Y,
                angular_velocity: std::f64::consts::TAU,
                start: 0.5,
                end: 1.0,
            },
        ]);
        for k in 0..2000 {
            g.advance(k as f64 * 1e-3, 1e-3);
        }
        // Up by 0.5, then half a turn about the y axis through the lifted origin (0, 0, 0.5):
        // (1, 0, 0.5) goes to (-1, 0, 0.5), and the normal flips.
        if let Element::Plane { point, normal } = g.elements[0] {
            assert!(
                (point - DVec3::new(-1.0, 0.0, 0.5)).length() < 1e-9,
                "{point}"
            );
            assert!((normal + DVec3::Z).length() < 1e-9, "{normal}");
        }
        assert!(!g.is_moving_at(1.5));
    }

    #[test]
    fn rotation_motion_keeps_axis_point_fixed() {
        let mut g = Geometry::new(
            "g",
            0,
            vec![Element::Triangle {
                a: DVec3::new(1.0, 0.0, 0.0),
                b: DVec3::new(1.0, 1.0, 0.0),
                c: DVec3::new(1.0, 0.0, 1.0),
            }],
        )
        .with_motion(vec![Motion::Rotation {
            axis_point: DVec3::new(0.0, 0.0, 0.0),
            axis: DVec3::Z,
            angular_velocity: std::f64::consts::FRAC_PI_2,
            start: 0.0,
            end: 1.0,
        }]);
        for k in 0..1000 {
            g.advance(k as f64 * 1e-3, 1e-3);
        }
        // A quarter turn about z takes (1, 0, 0) to (0, 1, 0).
        if let Element::Triangle { a, .. } = g.elements[0] {
            assert!((a - DVec3::new(0.0, 1.0, 0.0)).length() < 1e-9, "{a}");
        }
        let v = g.velocity.at(DVec3::new(0.0, 1.0, 0.0));
        assert!((v - DVec3::new(-std::f64::consts::FRAC_PI_2, 0.0, 0.0)).length() < 1e-12);
    }
}
