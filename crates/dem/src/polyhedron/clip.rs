//! The overlap of two convex polyhedra, or of a polyhedron and a wall, as a solid: its volume,
//! centroid, and the vector area of each body's surface inside the other.
//!
//! The overlap of convex bodies is convex and bounded by the parts of each body's faces that lie
//! inside the other body. Each such part is a face polygon clipped (Sutherland-Hodgman) by the other
//! body's planes; volume and centroid follow from the divergence theorem over these polygons. Only
//! the faces whose plane cuts the other body take part ("involved" faces), and only the other body's
//! involved planes can clip them: a plane that holds the whole of this body cuts nothing. That keeps
//! a contact between two 30-face kernels at a few clipped polygons. Everything is on the stack.

use super::ConvexPolyhedron;
use glam::DVec3;

/// Most vertices a clipped polygon can have: a convex face of at most
/// [`super::MAX_FACE_VERTICES`] gains at most one per clipping plane (a wall cap starts with 4 and
/// meets at most 16 sides and [`super::MAX_FACES`] faces).
const POLY_CAP: usize = super::MAX_FACE_VERTICES + super::MAX_FACES + 16;

/// A half-space `normal . x <= offset` (normal: unit, outward).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Plane {
    pub normal: DVec3,
    pub offset: f64,
}

impl Plane {
    #[inline(always)]
    pub fn distance(&self, x: DVec3) -> f64 {
        self.normal.dot(x) - self.offset
    }
}

/// A polyhedron placed in the world: its shape (for the face lists), vertices and face planes in
/// world coordinates, centre of mass and bounding radius.
#[derive(Clone, Copy, Debug)]
pub struct Placed<'a> {
    pub shape: &'a ConvexPolyhedron,
    /// The scale the shape is drawn at (its vertices and planes here include it).
    pub scale: f64,
    pub vertices: &'a [DVec3],
    pub planes: &'a [Plane],
    pub centre: DVec3,
    pub radius: f64,
}

/// The overlap region of two bodies.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Overlap {
    pub volume: f64,
    pub centroid: DVec3,
    /// Vector area of the part of the first body's surface inside the second (outward from the first).
    pub area_first: DVec3,
    /// The same for the second body (for a wall: the part of the wall surface inside the particle).
    pub area_second: DVec3,
}

impl Overlap {
    /// Unit normal from the second body toward the first, and the contact area (the overlap's
    /// cross-section): the two area vectors are opposite for a closed region; their mean is used.
    pub fn normal_and_area(&self) -> Option<(DVec3, f64)> {
        let s = 0.5 * (self.area_second - self.area_first);
        let a = s.length();
        (a > 0.0 && a.is_finite()).then(|| (s / a, a))
    }
}

#[derive(Clone, Copy)]
struct Polygon {
    pts: [DVec3; POLY_CAP],
    n: usize,
}

impl Polygon {
    fn new() -> Self {
        Polygon {
            pts: [DVec3::ZERO; POLY_CAP],
            n: 0,
        }
    }

    /// Keeps the part with `plane.distance <= 0`.
    #[inline]
    fn clip(&self, plane: &Plane, out: &mut Polygon) {
        out.n = 0;
        if self.n == 0 {
            return;
        }
        let mut p = self.pts[self.n - 1];
        let mut dp = plane.distance(p);
        for k in 0..self.n {
            let q = self.pts[k];
            let dq = plane.distance(q);
            if (dp <= 0.0) != (dq <= 0.0) && out.n < POLY_CAP {
                out.pts[out.n] = p + (q - p) * (dp / (dp - dq));
                out.n += 1;
            }
            if dq <= 0.0 && out.n < POLY_CAP {
                out.pts[out.n] = q;
                out.n += 1;
            }
            p = q;
            dp = dq;
        }
    }
}

/// Running sums of the divergence theorem over boundary polygons, about a reference point.
#[derive(Clone, Copy, Default)]
struct Sums {
    origin: DVec3,
    six_volume: f64,
    moment24: DVec3,
}

impl Sums {
    /// Adds a polygon (counter-clockwise seen from outside the region); returns its vector area.
    #[inline]
    fn add(&mut self, poly: &Polygon) -> DVec3 {
        let mut area = DVec3::ZERO;
        if poly.n < 3 {
            return area;
        }
        let a = poly.pts[0] - self.origin;
        for k in 1..poly.n - 1 {
            let b = poly.pts[k] - self.origin;
            let c = poly.pts[k + 1] - self.origin;
            let det = a.dot(b.cross(c));
            self.six_volume += det;
            self.moment24 += det * (a + b + c);
            area += 0.5 * (b - a).cross(c - a);
        }
        area
    }

    fn finish(&self, area_first: DVec3, area_second: DVec3) -> Option<Overlap> {
        let volume = self.six_volume / 6.0;
        if volume.is_nan() || volume <= 0.0 {
            return None;
        }
        Some(Overlap {
            volume,
            centroid: self.origin + self.moment24 / (24.0 * volume),
            area_first,
            area_second,
        })
    }
}

/// Faces of `a` whose plane cuts `b` (indices), or `None` when a face plane separates them.
/// A face of `b` lying in the plane of a face of `a` (stacked cubes) bounds the overlap once: the
/// first body (`first`) takes such faces, the second does not.
#[inline]
fn involved(
    a: &Placed,
    b: &Placed,
    first: bool,
    out: &mut [u8; super::MAX_FACES],
) -> Option<usize> {
    let tol = 1e-12 * a.radius.max(b.radius);
    let cut = if first { -tol } else { tol };
    let mut n = 0;
    for (f, plane) in a.planes.iter().enumerate() {
        let s = plane.distance(b.centre);
        if s > b.radius {
            return None;
        }
        if s < -b.radius {
            continue;
        }
        // Separating (all of b outside), or cutting b: stop as soon as both sides are seen.
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for v in b.vertices {
            let d = plane.distance(*v);
            lo = lo.min(d);
            hi = hi.max(d);
            if lo <= 0.0 && hi > cut {
                break;
            }
        }
        if lo > 0.0 {
            return None;
        }
        if hi > cut {
            out[n] = f as u8;
            n += 1;
        }
    }
    Some(n)
}

/// Orders `faces` of `a` by how squarely they face the point `toward` (most facing first).
fn facing_first(a: &Placed, toward: DVec3, faces: &mut [u8]) {
    let d = toward - a.centre;
    let key = |f: u8| -a.planes[f as usize].normal.dot(d);
    for k in 1..faces.len() {
        let mut j = k;
        while j > 0 && key(faces[j]) < key(faces[j - 1]) {
            faces.swap(j, j - 1);
            j -= 1;
        }
    }
}

/// Adds the faces `faces` of `a`, each clipped by the planes `clip_by` of `b`; returns their area.
fn add_clipped_faces(
    sums: &mut Sums,
    a: &Placed,
    faces: &[u8],
    b: &Placed,
    clip_by: &[u8],
    buffers: &mut (Polygon, Polygon),
) -> DVec3 {
    let mut area = DVec3::ZERO;
    for &f in faces {
        // Swap references, not the buffers (each is a few kilobytes).
        let (mut p, mut q) = (&mut buffers.0, &mut buffers.1);
        let face = &a.shape.faces[f as usize];
        let idx = &a.shape.face_vertices[face.first as usize..(face.first + face.count) as usize];
        p.n = idx.len();
        for (k, &i) in idx.iter().enumerate() {
            p.pts[k] = a.vertices[i as usize];
        }
        for &g in clip_by {
            p.clip(&b.planes[g as usize], q);
            std::mem::swap(&mut p, &mut q);
            if p.n < 3 {
                break;
            }
        }
        if p.n >= 3 {
            area += sums.add(p);
        }
    }
    area
}

/// The overlap of two placed convex polyhedra (`None` when they do not overlap).
pub fn polyhedra_overlap(a: &Placed, b: &Placed) -> Option<Overlap> {
    let d = b.centre - a.centre;
    let dist = d.length();
    if dist >= a.radius + b.radius {
        return None;
    }
    if dist > 0.0 {
        // Separated along the line of centres (the common case for near misses).
        let u = d / dist;
        let reach_a = a.vertices.iter().map(|v| v.dot(u)).fold(f64::MIN, f64::max);
        let reach_b = b.vertices.iter().map(|v| v.dot(u)).fold(f64::MAX, f64::min);
        if reach_a < reach_b {
            return None;
        }
    }
    let mut fa = [0u8; super::MAX_FACES];
    let mut fb = [0u8; super::MAX_FACES];
    let na = involved(a, b, true, &mut fa)?;
    let nb = involved(b, a, false, &mut fb)?;
    // Planes facing the other body first: they cut most of its faces away at the first clip.
    facing_first(a, b.centre, &mut fa[..na]);
    facing_first(b, a.centre, &mut fb[..nb]);
    let mut sums = Sums {
        origin: 0.5 * (a.centre + b.centre),
        ..Default::default()
    };
    let mut buffers = (Polygon::new(), Polygon::new());
    let area_a = add_clipped_faces(&mut sums, a, &fa[..na], b, &fb[..nb], &mut buffers);
    let area_b = add_clipped_faces(&mut sums, b, &fb[..nb], a, &fa[..na], &mut buffers);
    sums.finish(area_a, area_b)
}

/// The overlap of a placed polyhedron with a wall region: the intersection of the half-spaces
/// `wall` (its normal points out of the wall, toward free space) and `sides` (the element's
/// footprint; none for an infinite plane). `area_second` is the vector area of the part of the
/// wall plane inside the particle (along the wall normal); side planes count toward the volume
/// only.
pub fn wall_overlap(a: &Placed, wall: &Plane, sides: &[Plane]) -> Option<Overlap> {
    // Quick outs: the particle is clear of the wall plane, or of a side.
    let lowest = a
        .vertices
        .iter()
        .map(|v| wall.distance(*v))
        .fold(f64::MAX, f64::min);
    if lowest >= 0.0 {
        return None;
    }
    for s in sides {
        let lo = a
            .vertices
            .iter()
            .map(|v| s.distance(*v))
            .fold(f64::MAX, f64::min);
        if lo >= 0.0 {
            return None;
        }
    }
    let mut planes = [Plane::default(); 17];
    let count = 1 + sides.len().min(16);
    planes[0] = *wall;
    planes[1..count].copy_from_slice(&sides[..count - 1]);
    let all: [u8; 17] = std::array::from_fn(|k| k as u8);
    let region = Placed {
        shape: a.shape,
        scale: a.scale,
        vertices: &[],
        planes: &planes[..count],
        centre: a.centre,
        radius: f64::INFINITY,
    };
    let faces: [u8; super::MAX_FACES] = std::array::from_fn(|k| k as u8);
    let mut sums = Sums {
        origin: a.centre,
        ..Default::default()
    };
    let mut buffers = (Polygon::new(), Polygon::new());
    let area_a = add_clipped_faces(
        &mut sums,
        a,
        &faces[..a.planes.len()],
        &region,
        &all[..count],
        &mut buffers,
    );
    // The region's own faces: a square on each plane, large enough to hold the particle's
    // section, clipped by the other region planes and the particle's planes.
    let mut area_wall = DVec3::ZERO;
    for k in 0..count {
        let (mut p, mut q) = (&mut buffers.0, &mut buffers.1);
        let plane = planes[k];
        let n = plane.normal;
        let centre = a.centre - plane.distance(a.centre) * n;
        let e1 = n.any_orthonormal_vector();
        let e2 = n.cross(e1);
        let l = 2.0 * a.radius;
        p.n = 4;
        p.pts[0] = centre - l * e1 - l * e2;
        p.pts[1] = centre + l * e1 - l * e2;
        p.pts[2] = centre + l * e1 + l * e2;
        p.pts[3] = centre - l * e1 + l * e2;
        for (j, other) in planes[..count].iter().enumerate() {
            if j != k {
                p.clip(other, q);
                std::mem::swap(&mut p, &mut q);
            }
        }
        for other in a.planes {
            if p.n < 3 {
                break;
            }
            p.clip(other, q);
            std::mem::swap(&mut p, &mut q);
        }
        if p.n >= 3 {
            let area = sums.add(p);
            if k == 0 {
                area_wall = area;
            }
        }
    }
    // Side caps close the region but are not contact: the contact is the wall cap alone, so the
    // particle's side is reported as its opposite (see `Overlap::normal_and_area`).
    let _ = area_a;
    sums.finish(-area_wall, area_wall)
}

#[cfg(test)]
mod tests {
    use super::super::ConvexPolyhedron;
    use super::*;
    use glam::DQuat;

    fn cube(h: f64) -> ConvexPolyhedron {
        let pts: Vec<DVec3> = (0..8)
            .map(|k| {
                DVec3::new(
                    if k & 1 == 0 { -h } else { h },
                    if k & 2 == 0 { -h } else { h },
                    if k & 4 == 0 { -h } else { h },
                )
            })
            .collect();
        ConvexPolyhedron::from_points(&pts).unwrap().0
    }

    #[test]
    fn overlap_of_offset_cubes_is_a_box() {
        let c = cube(0.5);
        let fa = c.placed_frame(DVec3::ZERO, DQuat::IDENTITY);
        let fb = c.placed_frame(DVec3::new(0.8, 0.3, 0.0), DQuat::IDENTITY);
        let (a, b) = (fa.placed(&c), fb.placed(&c));
        let o = polyhedra_overlap(&a, &b).unwrap();
        // Box 0.2 x 0.7 x 1.
        assert!((o.volume - 0.14).abs() < 1e-12, "{}", o.volume);
        assert!((o.centroid - DVec3::new(0.4, 0.15, 0.0)).length() < 1e-12);
        // Face to face: the x faces carry the contact, area 1, normal from b to a (-x).
        let fb = c.placed_frame(DVec3::new(0.8, 0.0, 0.0), DQuat::IDENTITY);
        let o = polyhedra_overlap(&a, &fb.placed(&c)).unwrap();
        assert!((o.volume - 0.2).abs() < 1e-12, "{}", o.volume);
        let (n, area) = o.normal_and_area().unwrap();
        assert!(
            (area - 1.0).abs() < 1e-12 && (n + DVec3::X).length() < 1e-12,
            "{n} {area}"
        );
        let far = c.placed_frame(DVec3::new(1.01, 0.0, 0.0), DQuat::IDENTITY);
        assert!(polyhedra_overlap(&a, &far.placed(&c)).is_none());
        // A rotated cube: the overlap is the analytic wedge. Cube b turned 45 deg about z with a
        // vertex edge 0.1 into a: a triangular prism of half-width 0.1, height 0.1, length 1.
        let q = DQuat::from_rotation_z(std::f64::consts::FRAC_PI_4);
        let reach = 0.5 * 2f64.sqrt();
        let fr = c.placed_frame(DVec3::new(0.5 + reach - 0.1, 0.0, 0.0), q);
        let o = polyhedra_overlap(&a, &fr.placed(&c)).unwrap();
        assert!((o.volume - 0.01).abs() < 1e-12, "{}", o.volume);
        let (n, area) = o.normal_and_area().unwrap();
        assert!((area - 0.2).abs() < 1e-12 && (n + DVec3::X).length() < 1e-12);
    }

    #[test]
    fn cube_in_a_plane_and_a_triangle_footprint() {
        let c = cube(0.5);
        let f = c.placed_frame(DVec3::new(0.0, 0.0, 0.45), DQuat::IDENTITY);
        let a = f.placed(&c);
        let floor = Plane {
            normal: DVec3::Z,
            offset: 0.0,
        };
        let o = wall_overlap(&a, &floor, &[]).unwrap();
        assert!((o.volume - 0.05).abs() < 1e-12);
        assert!((o.area_second - DVec3::Z).length() < 1e-12);
        let (n, area) = o.normal_and_area().unwrap();
        assert!((n - DVec3::Z).length() < 1e-12 && (area - 1.0).abs() < 1e-12);
        assert!((o.centroid - DVec3::new(0.0, 0.0, -0.025)).length() < 1e-12);
        // Only the part over x <= 0.1: a side plane.
        let side = Plane {
            normal: DVec3::X,
            offset: 0.1,
        };
        let o = wall_overlap(&a, &floor, &[side]).unwrap();
        assert!((o.volume - 0.6 * 0.05).abs() < 1e-12, "{}", o.volume);
        let (_, area) = o.normal_and_area().unwrap();
        assert!((area - 0.6).abs() < 1e-12, "{area}");
    }
}
