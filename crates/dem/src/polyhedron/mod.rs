//! Convex polyhedral particles: shapes (the convex hull of points, of a maize kernel class's
//! measured dimensions, or of an STL solid), their exact mass properties, the overlap of two of
//! them or of one and a wall ([`clip`]), and the contact model ([`contact`]).
//!
//! Design notes. A polyhedron lives in a simulation as a rigid body (see [`crate::clump::Bodies`])
//! with one member sphere, its *proxy*: centred on the centre of mass with the bounding radius, so
//! the neighbour lists, wall candidates, fills and factories find its candidates as for any sphere,
//! and the integrator moves it as any clump. The pair and wall stages send a pair with a proxy
//! here instead of to the sphere formulas.
//!
//! The contact model is volume based (Nassauer, Liedke and Kuna 2013; Feng 2021's family of
//! overlap-volume models): the overlap of the two solids is computed exactly (a convex polyhedron),
//! its volume V, centroid, and the vector area S of the contact surface (the mean of the two
//! bodies' surfaces inside each other, opposite for a closed region). The contact normal is S/|S|,
//! the contact point the overlap's centroid, the contact area A = |S| and the contact radius
//! a = sqrt(A/pi). The elastic normal force is the flat-punch (Boussinesq) force of the mean
//! depth V/A over that contact: F = 2 E* a V/A. For two faces pressed together this is the exact
//! flat-punch stiffness 2 E* a; for a rounded tip it is within 6 % of Hertz. The contact is then
//! handed to the simulation's contact law as the Hertz contact with the same contact radius and
//! force: overlap 1.5 V/A and effective radius A^2/(1.5 pi V). With Hertz-Mindlin this gives
//! normal force F, normal stiffness 2 E* a, Mindlin tangential stiffness 8 G* a, Coulomb friction,
//! Hertz-Mindlin damping from the restitution, and rolling friction: the same inputs as EDEM.
//! The law damps the normal velocity at the contact point, which a rocking motion about that point
//! does not have, so the normal damping is also spread over the contact area: a moment
//! -gamma_n (a^2/4) w against the relative spin about axes in the contact plane (what the same
//! damping per unit area gives on a disc of radius a). Without it a frictionless cube in a corner
//! rocks for ever.
//! Limits: the force is not derived from a potential, so it conserves energy only for contacts
//! whose area does not change with the overlap (faces); torque comes from the force at the
//! overlap's centroid.

pub mod clip;
pub mod contact;
pub mod frames;
mod hull;
pub mod kernels;

pub use clip::{polyhedra_overlap, wall_overlap, Overlap, Placed, Plane};
pub use frames::{PolyFrames, NO_SHAPE};
pub use hull::{convex_hull, Hull, HullFace};

use crate::clump::{from_second_moments, MassProperties};
use glam::{DQuat, DVec3};

/// Most vertices, faces and vertices per face of a particle shape: a contact's polygons live on
/// the stack. Hulls with more are reduced (see [`ConvexPolyhedron::from_points`]).
pub const MAX_VERTICES: usize = 64;
pub const MAX_FACES: usize = 64;
pub const MAX_FACE_VERTICES: usize = 32;

/// A face: outward unit normal, offset (normal . x on the face) and its vertex indices
/// (`face_vertices[first..first + count]`, counter-clockwise seen from outside).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Face {
    pub normal: DVec3,
    pub offset: f64,
    pub first: u16,
    pub count: u16,
}

/// A convex polyhedron in its body frame: centre of mass at the origin, principal axes along x, y,
/// z (smallest moment first).
#[derive(Clone, Debug, PartialEq)]
pub struct ConvexPolyhedron {
    pub vertices: Vec<DVec3>,
    pub faces: Vec<Face>,
    pub face_vertices: Vec<u16>,
    /// Each edge once (vertex index pairs).
    pub edges: Vec<[u16; 2]>,
    pub volume: f64,
    /// Principal moments of inertia per unit density.
    pub principal_inertia: DVec3,
    /// Largest distance of a vertex from the centre of mass.
    pub bounding_radius: f64,
    /// Smallest width between two parallel supporting planes normal to a face (an upper bound of
    /// the true smallest width; half of it is the radius the time step and the start-up overlap
    /// checks take).
    pub min_width: f64,
}

impl ConvexPolyhedron {
    /// The convex hull of `points`, moved to its principal frame; also returns the hull's mass
    /// properties in the frame of `points` (centroid and axes) and a note when the hull had more
    /// vertices or faces than a particle may ([`MAX_VERTICES`], [`MAX_FACES`]) and was reduced to the
    /// hull of its most spread-out vertices.
    pub fn from_points(points: &[DVec3]) -> Result<(ConvexPolyhedron, MassProperties), String> {
        let (poly, props, _) = Self::from_points_noted(points)?;
        Ok((poly, props))
    }

    /// [`Self::from_points`] with the note on a reduction.
    pub fn from_points_noted(
        points: &[DVec3],
    ) -> Result<(ConvexPolyhedron, MassProperties, Option<String>), String> {
        let mut hull = convex_hull(points)?;
        let mut note = None;
        let fits = |h: &Hull| {
            h.points.len() <= MAX_VERTICES
                && h.faces.len() <= MAX_FACES
                && h.faces
                    .iter()
                    .all(|f| f.vertices.len() <= MAX_FACE_VERTICES)
        };
        if !fits(&hull) {
            let full = hull_volume(&hull);
            let mut keep = MAX_VERTICES;
            while !fits(&hull) && keep >= 8 {
                hull = convex_hull(&farthest_points(&hull.points, keep))?;
                keep -= 4;
            }
            if !fits(&hull) {
                return Err(format!(
                    "its convex hull cannot be reduced to {MAX_VERTICES} vertices and {MAX_FACES} faces"
                ));
            }
            note = Some(format!(
                "convex hull reduced to {} vertices and {} faces ({:+.1} % volume)",
                hull.points.len(),
                hull.faces.len(),
                100.0 * (hull_volume(&hull) / full - 1.0)
            ));
        }
        let props = hull_properties(&hull);
        let to_body = props.axes.transpose();
        let vertices: Vec<DVec3> = hull
            .points
            .iter()
            .map(|p| to_body * (*p - props.centroid))
            .collect();
        let mut faces = Vec::with_capacity(hull.faces.len());
        let mut face_vertices = Vec::new();
        let mut edges: Vec<[u16; 2]> = Vec::new();
        for f in &hull.faces {
            let normal = (to_body * f.normal).normalize();
            let first = face_vertices.len() as u16;
            face_vertices.extend(f.vertices.iter().map(|&i| i as u16));
            faces.push(Face {
                normal,
                offset: normal.dot(vertices[f.vertices[0]]),
                first,
                count: f.vertices.len() as u16,
            });
            for k in 0..f.vertices.len() {
                let (u, v) = (f.vertices[k], f.vertices[(k + 1) % f.vertices.len()]);
                let e = [u.min(v) as u16, u.max(v) as u16];
                if !edges.contains(&e) {
                    edges.push(e);
                }
            }
        }
        let mut poly = ConvexPolyhedron {
            vertices,
            faces,
            face_vertices,
            edges,
            volume: props.volume,
            principal_inertia: props.principal_inertia,
            bounding_radius: 0.0,
            min_width: 0.0,
        };
        poly.measure();
        Ok((poly, props, note))
    }

    fn measure(&mut self) {
        self.bounding_radius = self.vertices.iter().map(|v| v.length()).fold(0.0, f64::max);
        self.min_width = self
            .faces
            .iter()
            .map(|f| {
                let lowest = self
                    .vertices
                    .iter()
                    .map(|v| f.normal.dot(*v))
                    .fold(f64::MAX, f64::min);
                f.offset - lowest
            })
            .fold(f64::MAX, f64::min);
    }

    /// The same shape scaled by `s` about its centre of mass.
    pub fn scaled(&self, s: f64) -> ConvexPolyhedron {
        let mut p = self.clone();
        for v in &mut p.vertices {
            *v *= s;
        }
        for f in &mut p.faces {
            f.offset *= s;
        }
        p.volume *= s.powi(3);
        p.principal_inertia *= s.powi(5);
        p.bounding_radius *= s;
        p.min_width *= s;
        p
    }

    /// Mass properties per unit density in the body frame.
    pub fn mass_properties(&self) -> MassProperties {
        MassProperties {
            volume: self.volume,
            centroid: DVec3::ZERO,
            principal_inertia: self.principal_inertia,
            axes: glam::DMat3::IDENTITY,
            exact: true,
        }
    }

    /// Radius of the sphere of the same volume.
    pub fn equal_volume_radius(&self) -> f64 {
        (3.0 * self.volume / (4.0 * std::f64::consts::PI)).cbrt()
    }

    /// Vertex indices of face `f`.
    pub fn face(&self, f: usize) -> &[u16] {
        let face = &self.faces[f];
        &self.face_vertices[face.first as usize..(face.first + face.count) as usize]
    }

    /// World vertices and planes of the shape at a pose (allocating; the step uses
    /// [`Self::place_into`]).
    pub fn placed_frame(&self, position: DVec3, orientation: DQuat) -> PlacedFrame {
        let mut f = PlacedFrame {
            vertices: vec![DVec3::ZERO; self.vertices.len()],
            planes: vec![Plane::default(); self.faces.len()],
            centre: position,
            radius: self.bounding_radius,
        };
        self.place_into(position, orientation, 1.0, &mut f.vertices, &mut f.planes);
        f
    }

    /// Writes the world vertices and face planes of the shape drawn at `scale` at a pose into the
    /// given slices (of the shape's vertex and face counts).
    #[inline]
    pub fn place_into(
        &self,
        position: DVec3,
        orientation: DQuat,
        scale: f64,
        vertices: &mut [DVec3],
        planes: &mut [Plane],
    ) {
        for (w, v) in vertices.iter_mut().zip(&self.vertices) {
            *w = position + orientation * (*v * scale);
        }
        for (p, f) in planes.iter_mut().zip(&self.faces) {
            let n = orientation * f.normal;
            *p = Plane {
                normal: n,
                offset: f.offset * scale + n.dot(position),
            };
        }
    }

    /// Whether a body-frame point is inside (or on) the polyhedron.
    pub fn contains(&self, p: DVec3) -> bool {
        self.faces.iter().all(|f| f.normal.dot(p) <= f.offset)
    }
}

/// A shape's world vertices and planes at one pose.
#[derive(Clone, Debug)]
pub struct PlacedFrame {
    pub vertices: Vec<DVec3>,
    pub planes: Vec<Plane>,
    pub centre: DVec3,
    pub radius: f64,
}

impl PlacedFrame {
    pub fn placed<'a>(&'a self, shape: &'a ConvexPolyhedron) -> Placed<'a> {
        Placed {
            shape,
            scale: 1.0,
            vertices: &self.vertices,
            planes: &self.planes,
            centre: self.centre,
            radius: self.radius,
        }
    }
}

/// Volume, centroid and second moments of a hull by tetrahedra from an interior point.
fn hull_properties(hull: &Hull) -> MassProperties {
    let o = hull.points.iter().sum::<DVec3>() / hull.points.len() as f64;
    let mut volume = 0.0;
    let mut first = DVec3::ZERO;
    let mut second = [[0.0f64; 3]; 3];
    for f in &hull.faces {
        let p0 = hull.points[f.vertices[0]] - o;
        for k in 1..f.vertices.len() - 1 {
            let (p1, p2) = (
                hull.points[f.vertices[k]] - o,
                hull.points[f.vertices[k + 1]] - o,
            );
            let v = p0.dot(p1.cross(p2)) / 6.0;
            volume += v;
            let sum = p0 + p1 + p2;
            first += v * sum / 4.0;
            // Integral of x_p x_q over the tetrahedron (0, p0, p1, p2).
            let (a, b, c, s) = (p0.to_array(), p1.to_array(), p2.to_array(), sum.to_array());
            for (p, row) in second.iter_mut().enumerate() {
                for (q, m) in row.iter_mut().enumerate() {
                    *m += v / 20.0 * (a[p] * a[q] + b[p] * b[q] + c[p] * c[q] + s[p] * s[q]);
                }
            }
        }
    }
    let centroid_rel = first / volume;
    let c = centroid_rel.to_array();
    let mut cov = [[0.0f64; 3]; 3];
    for p in 0..3 {
        for q in 0..3 {
            cov[p][q] = second[p][q] - volume * c[p] * c[q];
        }
    }
    from_second_moments(volume, o + centroid_rel, cov, true)
}

fn hull_volume(hull: &Hull) -> f64 {
    hull_properties(hull).volume
}

/// `k` of `points` chosen one by one as the furthest from those already chosen (the first: the
/// furthest from the centre), so the hull of the subset keeps the shape's extent.
fn farthest_points(points: &[DVec3], k: usize) -> Vec<DVec3> {
    let centre = points.iter().sum::<DVec3>() / points.len() as f64;
    let mut chosen = vec![points
        .iter()
        .copied()
        .max_by(|a, b| (*a - centre).length().total_cmp(&(*b - centre).length()))
        .unwrap()];
    let mut nearest: Vec<f64> = points.iter().map(|p| (*p - chosen[0]).length()).collect();
    while chosen.len() < k.min(points.len()) {
        let (i, _) = nearest
            .iter()
            .enumerate()
            .max_by(|a, b| a.1.total_cmp(b.1))
            .unwrap();
        let p = points[i];
        chosen.push(p);
        for (d, q) in nearest.iter_mut().zip(points) {
            *d = d.min((*q - p).length());
        }
    }
    chosen
}

/// The words that start the note on a non-convex STL solid (scenes turn it into a warning).
pub const NOT_CONVEX: &str = "the solid is not convex";

/// Reads a closed STL solid (scaled, e.g. 0.001 for millimetres; errors name the file) and returns
/// its convex hull, with
/// a note when the solid is not convex (its volume below the hull's) or the hull was reduced.
pub fn from_stl(
    path: &std::path::Path,
    scale: f64,
) -> Result<(ConvexPolyhedron, Vec<String>), String> {
    // Read as the multi-sphere fits read a solid: closed, its volume by the divergence theorem.
    let mesh = crate::sphere_fit::mesh::MeshSolid::read(path, scale)?;
    let solid = crate::sphere_fit::Solid::volume(&mesh);
    let points: Vec<DVec3> = mesh.triangles.iter().flatten().copied().collect();
    // A scanned solid can have 1e5 vertices; its hull is reduced to at most MAX_VERTICES anyway,
    // so the hull is taken of the 4000 most spread-out points (the full hull's volume as well).
    let points = if points.len() > 4000 {
        farthest_points(&points, 4000)
    } else {
        points
    };
    let (poly, _, reduced) = ConvexPolyhedron::from_points_noted(&points)?;
    let mut notes = Vec::new();
    let full = match &reduced {
        Some(_) => convex_hull(&points).map(|h| hull_volume(&h))?,
        None => poly.volume,
    };
    if solid.abs() < (1.0 - 0.01) * full {
        notes.push(format!(
            "{NOT_CONVEX}: its volume is {:.1} % of its convex hull's, which the particle takes",
            100.0 * solid.abs() / full
        ));
    }
    notes.extend(reduced);
    Ok((poly, notes))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn box_mass_properties_are_exact() {
        let (a, b, c) = (0.03, 0.02, 0.01);
        let pts: Vec<DVec3> = (0..8)
            .map(|k| {
                DVec3::new(
                    if k & 1 == 0 { 0.0 } else { a },
                    if k & 2 == 0 { 0.0 } else { b },
                    if k & 4 == 0 { 0.0 } else { c },
                )
            })
            .collect();
        let (p, props) = ConvexPolyhedron::from_points(&pts).unwrap();
        assert!((p.volume - a * b * c).abs() < 1e-18);
        assert!((props.centroid - DVec3::new(a, b, c) * 0.5).length() < 1e-15);
        // Smallest moment about the long axis: (b^2 + c^2)/12 V.
        let v = a * b * c;
        let want = DVec3::new(b * b + c * c, a * a + c * c, a * a + b * b) * (v / 12.0);
        assert!((p.principal_inertia - want).length() < 1e-12 * want.length());
        assert_eq!(p.faces.len(), 6);
        assert_eq!(p.edges.len(), 12);
        assert!((p.min_width - c).abs() < 1e-15);
        assert!((p.bounding_radius - 0.5 * (a * a + b * b + c * c).sqrt()).abs() < 1e-15);
        // In the body frame the long side is along x.
        let ext = p.vertices.iter().map(|v| v.x.abs()).fold(0.0, f64::max);
        assert!((ext - 0.5 * a).abs() < 1e-15);
        assert!(p.contains(DVec3::ZERO) && !p.contains(DVec3::new(0.016, 0.0, 0.0)));
    }

    #[test]
    fn too_many_points_are_reduced() {
        // 2000 points on a sphere: the hull is reduced to at most MAX_VERTICES vertices.
        let pts: Vec<DVec3> = (0..2000)
            .map(|k| {
                let z = 1.0 - 2.0 * (k as f64 + 0.5) / 2000.0;
                let phi = k as f64 * 2.399_963;
                let r = (1.0 - z * z).sqrt();
                DVec3::new(r * phi.cos(), r * phi.sin(), z)
            })
            .collect();
        let (p, _, note) = ConvexPolyhedron::from_points_noted(&pts).unwrap();
        assert!(p.vertices.len() <= MAX_VERTICES && p.faces.len() <= MAX_FACES);
        let ratio = p.volume / (4.0 / 3.0 * std::f64::consts::PI);
        assert!(ratio > 0.75 && ratio < 1.0, "{ratio}");
        assert!(note.unwrap().contains("reduced"));
    }
}
