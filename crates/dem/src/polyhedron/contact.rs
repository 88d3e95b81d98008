//! Contacts of polyhedra with polyhedra, spheres and walls, reduced to the equivalent Hertz contact
//! the contact law evaluates (see the module notes of [`super`]).

use super::clip::{polyhedra_overlap, wall_overlap, Placed, Plane};
use crate::contact::{
    evaluate, ContactHistory, ContactLaw, ContactPoint, PairParams, RollingModel,
};
use crate::geometry::{Element, Geometry};
use crate::material::MaterialTable;
use crate::neighbour::PairOutput;
use crate::sim::walls::{WallCandidate, WallOutput};
use glam::DVec3;
use std::f64::consts::PI;

/// Motion of a body: centre of mass, velocity, spin, mass.
#[derive(Clone, Copy, Debug)]
pub struct Kinematics {
    pub x: DVec3,
    pub v: DVec3,
    pub w: DVec3,
    pub m: f64,
}

impl Kinematics {
    #[inline(always)]
    fn velocity_at(&self, p: DVec3) -> DVec3 {
        self.v + self.w.cross(p - self.x)
    }
}

/// The Hertz contact with the flat-punch force and contact radius of an overlap of `volume` over
/// `area`: (overlap, effective radius).
#[inline(always)]
pub fn equivalent_contact(volume: f64, area: f64) -> (f64, f64) {
    let overlap = 1.5 * volume / area;
    (overlap, area * area / (1.5 * PI * volume))
}

/// The damping moment of a contact spread over `area`: the law damps the normal velocity at the
/// contact point, which a rocking motion about that point does not have; spread over the area, the
/// same damping per unit area resists rocking with the moment -gamma_n (a^2 / 4) w (a disc of radius
/// a, gamma_n the Hertz-Mindlin normal damping at this contact). `rel_spin` is this body's spin
/// minus the other's.
#[inline(always)]
fn rocking_damping(params: &PairParams, area: f64, m_eff: f64, n: DVec3, rel_spin: DVec3) -> DVec3 {
    if area <= 0.0 {
        return DVec3::ZERO;
    }
    let a = (area / PI).sqrt();
    let gamma_n = params.hertz_damping * (2.0 * params.e_star * a * m_eff).sqrt();
    let rocking = rel_spin - rel_spin.dot(n) * n;
    -gamma_n * 0.25 * a * a * rocking
}

/// A contact between bodies i and j at `point` with normal `n` (from j toward i) and contact area
/// `area` (0 for a sphere's point contact, which has no rocking damping).
#[inline]
#[allow(clippy::too_many_arguments)]
fn pair_contact<L: ContactLaw>(
    law: &L,
    rolling: RollingModel,
    params: &PairParams,
    n: DVec3,
    point: DVec3,
    overlap: f64,
    r_eff: f64,
    area: f64,
    i: &Kinematics,
    j: &Kinematics,
    history: &mut ContactHistory,
    dt: f64,
) -> PairOutput {
    let (arm_i, arm_j) = (point - i.x, point - j.x);
    let cp = ContactPoint {
        normal: n,
        overlap,
        r_eff,
        m_eff: i.m * j.m / (i.m + j.m),
        v_rel: i.velocity_at(point) - j.velocity_at(point),
        spin_lever: DVec3::ZERO,
    };
    let (li, lj) = (arm_i.length(), arm_j.length());
    let inertia = || {
        let (a, b) = (i.m * li * li, j.m * lj * lj);
        1.4 * a * b / (a + b)
    };
    let c = evaluate(law, rolling, params, &cp, i.w - j.w, inertia, history, dt);
    let rocking = rocking_damping(params, area, cp.m_eff, n, i.w - j.w);
    PairOutput {
        force: c.force,
        torque_i: arm_i.cross(c.force) + c.rolling_torque + rocking,
        torque_j: -arm_j.cross(c.force) - c.rolling_torque - rocking,
        rolling_i: c.rolling_resistance * li,
        rolling_j: c.rolling_resistance * lj,
    }
}

/// The normal (from the second body toward the first) and contact area of an overlap. When one
/// body is wholly inside the other there is no contact surface; then the line of centres
/// (`apart`, from the second toward the first) and the area of a cube of the overlap's volume are
/// used, so the bodies are pushed apart rather than left inside each other.
fn contact_normal(o: &super::Overlap, apart: DVec3) -> Option<(DVec3, f64)> {
    match o.normal_and_area() {
        Some((n, area)) if area > 1e-6 * o.volume.powf(2.0 / 3.0) => Some((n, area)),
        _ => {
            let len = apart.length();
            (len > 0.0).then(|| (apart / len, o.volume.powf(2.0 / 3.0)))
        }
    }
}

/// Contact of polyhedra `a` (body i) and `b` (body j); `None` when they do not overlap.
#[inline]
#[allow(clippy::too_many_arguments)]
pub fn polyhedra_pair<L: ContactLaw>(
    law: &L,
    rolling: RollingModel,
    params: &PairParams,
    a: &Placed,
    i: &Kinematics,
    b: &Placed,
    j: &Kinematics,
    history: &mut ContactHistory,
    dt: f64,
) -> Option<PairOutput> {
    let o = polyhedra_overlap(a, b)?;
    let (n, area) = contact_normal(&o, a.centre - b.centre)?;
    let (overlap, r_eff) = equivalent_contact(o.volume, area);
    Some(pair_contact(
        law, rolling, params, n, o.centroid, overlap, r_eff, area, i, j, history, dt,
    ))
}

/// Closest point of a placed polyhedron's surface to `c`: (point, unit normal from the surface
/// toward `c`, signed distance, negative inside).
pub fn closest_on_polyhedron(p: &Placed, c: DVec3) -> (DVec3, DVec3, f64) {
    let (mut best_face, mut best_s) = (0, f64::MIN);
    for (f, plane) in p.planes.iter().enumerate() {
        let s = plane.distance(c);
        if s > best_s {
            best_s = s;
            best_face = f;
        }
    }
    if best_s <= 0.0 {
        let n = p.planes[best_face].normal;
        return (c - best_s * n, n, best_s);
    }
    let mut best = (c, DVec3::Z, f64::MAX);
    for (f, plane) in p.planes.iter().enumerate() {
        let s = plane.distance(c);
        if s <= 0.0 {
            continue;
        }
        let n = plane.normal;
        let y = c - s * n;
        let idx = p.shape.face(f);
        let m = idx.len();
        let mut inside = true;
        let mut q_best = (y, f64::MAX);
        for k in 0..m {
            let (u, v) = (
                p.vertices[idx[k] as usize],
                p.vertices[idx[(k + 1) % m] as usize],
            );
            if (v - u).cross(y - u).dot(n) < 0.0 {
                inside = false;
            }
            let e = v - u;
            let t = ((c - u).dot(e) / e.length_squared()).clamp(0.0, 1.0);
            let q = u + t * e;
            let d = (c - q).length_squared();
            if d < q_best.1 {
                q_best = (q, d);
            }
        }
        let (q, d) = if inside {
            (y, s)
        } else {
            (q_best.0, q_best.1.sqrt())
        };
        if d < best.2 {
            let normal = if d > 0.0 { (c - q) / d } else { n };
            best = (q, normal, d);
        }
    }
    best
}

/// Contact of polyhedron `poly` with a sphere at `sphere.x` of radius `r`. The polyhedron is
/// locally flat next to the sphere, so R* is the sphere's radius. With `poly_is_i` the output is
/// for the pair (poly, sphere), otherwise (sphere, poly).
#[inline]
#[allow(clippy::too_many_arguments)]
pub fn polyhedron_sphere<L: ContactLaw>(
    law: &L,
    rolling: RollingModel,
    params: &PairParams,
    poly: &Placed,
    pk: &Kinematics,
    sphere: &Kinematics,
    r: f64,
    poly_is_i: bool,
    history: &mut ContactHistory,
    dt: f64,
) -> Option<PairOutput> {
    let (q, n, dist) = closest_on_polyhedron(poly, sphere.x);
    let overlap = r - dist;
    if overlap <= 0.0 {
        return None;
    }
    let point = sphere.x - (r - 0.5 * overlap) * n;
    let _ = q;
    Some(if poly_is_i {
        pair_contact(
            law, rolling, params, -n, point, overlap, r, 0.0, pk, sphere, history, dt,
        )
    } else {
        pair_contact(
            law, rolling, params, n, point, overlap, r, 0.0, sphere, pk, history, dt,
        )
    })
}

/// The wall half-space and footprint planes of element `el` seen by a polyhedron (`None` when the
/// element kind cannot touch it). Writes the sides into `sides` and returns the wall plane and
/// the number of sides.
fn wall_region(el: &Element, p: &Placed, sides: &mut [Plane; 16]) -> (Plane, usize) {
    let half = |normal: DVec3, point: DVec3| Plane {
        normal,
        offset: normal.dot(point),
    };
    match *el {
        Element::Plane { point, normal } => (half(normal, point), 0),
        Element::Rect {
            center,
            normal,
            u,
            v,
            half_u,
            half_v,
        } => {
            let side = if (p.centre - center).dot(normal) >= 0.0 {
                1.0
            } else {
                -1.0
            };
            sides[0] = half(u, center + half_u * u);
            sides[1] = half(-u, center - half_u * u);
            sides[2] = half(v, center + half_v * v);
            sides[3] = half(-v, center - half_v * v);
            (half(side * normal, center), 4)
        }
        Element::Disc {
            center,
            normal,
            radius,
        } => {
            let side = if (p.centre - center).dot(normal) >= 0.0 {
                1.0
            } else {
                -1.0
            };
            let e1 = normal.any_orthonormal_vector();
            let e2 = normal.cross(e1);
            // A circumscribed 16-gon.
            let apothem = radius;
            for (k, s) in sides.iter_mut().enumerate() {
                let phi = 2.0 * PI * k as f64 / 16.0;
                let d = phi.cos() * e1 + phi.sin() * e2;
                *s = half(d, center + apothem * d);
            }
            (half(side * normal, center), 16)
        }
        Element::CylinderShell {
            base,
            axis,
            radius,
            length,
        } => {
            let radial = |x: DVec3| {
                let r = x - base;
                r - r.dot(axis) * axis
            };
            let centre_rho = radial(p.centre).length();
            let inside = centre_rho < radius;
            // From inside, the deepest point is a vertex (the furthest from the axis), and the
            // tangent plane there bounds the wall. From outside (the shell is convex), the
            // tangent plane facing the particle's centre.
            let mut pick = radial(p.centre);
            if inside {
                let mut best = f64::MIN;
                for v in p.vertices {
                    let r = radial(*v);
                    let rho = r.length();
                    if rho > best {
                        best = rho;
                        pick = r;
                    }
                }
            }
            let e = if pick.length() > 0.0 {
                pick.normalize()
            } else {
                axis.any_orthonormal_vector()
            };
            sides[0] = half(-axis, base);
            sides[1] = half(axis, base + length * axis);
            let on_wall = base + radius * e;
            let wall = if inside {
                half(-e, on_wall)
            } else {
                half(e, on_wall)
            };
            (wall, 2)
        }
        Element::Triangle { a, b, c } => {
            let n = (b - a).cross(c - a).normalize();
            let side = if (p.centre - a).dot(n) >= 0.0 {
                1.0
            } else {
                -1.0
            };
            for (k, (u, w, other)) in [(a, b, c), (b, c, a), (c, a, b)].into_iter().enumerate() {
                let mut m = (w - u).cross(n).normalize();
                if m.dot(other - u) > 0.0 {
                    m = -m;
                }
                sides[k] = half(m, u);
            }
            (half(side * n, a), 3)
        }
    }
}

/// The equivalent overlap (1.5 V / A, see [`equivalent_contact`]) of a placed polyhedron with a
/// wall element, if they overlap: the depth the start-up overlap checks compare.
pub fn wall_penetration(el: &Element, poly: &Placed) -> Option<f64> {
    let mut sides = [Plane::default(); 16];
    let (wall, count) = wall_region(el, poly, &mut sides);
    let o = wall_overlap(poly, &wall, &sides[..count])?;
    let area = o.area_second.length().max(o.volume.powf(2.0 / 3.0) * 1e-6);
    Some(equivalent_contact(o.volume, area).0)
}

/// The same for two placed polyhedra.
pub fn pair_penetration(a: &Placed, b: &Placed) -> Option<f64> {
    let o = polyhedra_overlap(a, b)?;
    let (_, area) = contact_normal(&o, a.centre - b.centre)?;
    Some(equivalent_contact(o.volume, area).0)
}

/// Most pieces of one particle's wall contacts merged per step; beyond it pieces go alone.
const MAX_PIECES: usize = 16;

/// Contacts of one polyhedron with its geometry candidates (the polyhedral counterpart of
/// [`crate::sim::walls::wall_contacts`]): each element's overlap with the particle, restricted to
/// the element's footprint so a flat patch of triangles shares the contact without counting it
/// twice. Pieces of one geometry that lie in one plane (the triangles of a flat patch) are summed
/// into one contact before the law sees them, so the stiffness does not depend on how the
/// surface is cut into elements: the contact is that of the whole flat area, carried by the
/// first candidate of the piece (its history and output); the others output zero.
#[inline]
#[allow(clippy::too_many_arguments)]
pub fn polyhedron_wall_contacts<L: ContactLaw>(
    law: &L,
    rolling: RollingModel,
    poly: &Placed,
    body: &Kinematics,
    material: usize,
    cands: &mut [WallCandidate],
    outs: &mut [WallOutput],
    geometries: &[Geometry],
    materials: &MaterialTable,
    dt: f64,
) {
    // (first candidate, geometry, wall plane, volume, first moment, area vector)
    let mut pieces: [(usize, u16, Plane, f64, DVec3, DVec3); MAX_PIECES] =
        [(0, 0, Plane::default(), 0.0, DVec3::ZERO, DVec3::ZERO); MAX_PIECES];
    let mut count_pieces = 0;
    let mut sides = [Plane::default(); 16];
    let tol = 1e-9 * poly.radius.max(1e-12);
    for k in 0..cands.len() {
        let g = &geometries[cands[k].geometry as usize];
        let el = &g.elements[cands[k].element as usize];
        let (wall, count) = wall_region(el, poly, &mut sides);
        let overlap = wall_overlap(poly, &wall, &sides[..count]);
        outs[k] = WallOutput::default();
        let Some(o) = overlap else {
            cands[k].history = ContactHistory::default();
            continue;
        };
        let same = pieces[..count_pieces].iter().position(|p| {
            p.1 == cands[k].geometry
                && p.2.normal.dot(wall.normal) > 1.0 - 1e-9
                && (p.2.offset - wall.offset).abs() < tol
        });
        match same {
            Some(at) => {
                let p = &mut pieces[at];
                p.3 += o.volume;
                p.4 += o.volume * o.centroid;
                p.5 += o.area_second;
                cands[k].history = ContactHistory::default();
            }
            None if count_pieces < MAX_PIECES => {
                pieces[count_pieces] = (
                    k,
                    cands[k].geometry,
                    wall,
                    o.volume,
                    o.volume * o.centroid,
                    o.area_second,
                );
                count_pieces += 1;
            }
            None => {
                // More separate walls than pieces: this one alone.
                wall_contact(
                    law,
                    rolling,
                    poly,
                    body,
                    material,
                    &mut cands[k],
                    &mut outs[k],
                    g,
                    materials,
                    o.volume,
                    o.centroid,
                    o.area_second,
                    &wall,
                    dt,
                );
            }
        }
    }
    for p in &pieces[..count_pieces] {
        let k = p.0;
        let g = &geometries[p.1 as usize];
        wall_contact(
            law,
            rolling,
            poly,
            body,
            material,
            &mut cands[k],
            &mut outs[k],
            g,
            materials,
            p.3,
            p.4 / p.3,
            p.5,
            &p.2,
            dt,
        );
    }
}

/// One wall contact of overlap `volume` about `centroid` with the wall's area vector `area_vector`
/// (along the wall normal; zero when the particle is wholly beyond the wall plane, and then the
/// wall's normal and the area of a cube of that volume are used, so the particle is pushed out).
#[inline]
#[allow(clippy::too_many_arguments)]
fn wall_contact<L: ContactLaw>(
    law: &L,
    rolling: RollingModel,
    poly: &Placed,
    body: &Kinematics,
    material: usize,
    cand: &mut WallCandidate,
    out: &mut WallOutput,
    g: &Geometry,
    materials: &MaterialTable,
    volume: f64,
    centroid: DVec3,
    area_vector: DVec3,
    wall: &Plane,
    dt: f64,
) {
    let _ = poly;
    let area_len = area_vector.length();
    let floor = volume.powf(2.0 / 3.0) * 1e-6;
    let (n, area) = if area_len > floor {
        (area_vector / area_len, area_len)
    } else {
        (wall.normal, volume.powf(2.0 / 3.0))
    };
    let (overlap, r_eff) = equivalent_contact(volume, area);
    let point = centroid;
    let arm = point - body.x;
    let lever = arm.length();
    let params = materials.pair(material, g.material);
    let cp = ContactPoint {
        normal: n,
        overlap,
        r_eff,
        m_eff: body.m,
        v_rel: body.velocity_at(point) - g.velocity.at(point),
        spin_lever: DVec3::ZERO,
    };
    let c = evaluate(
        law,
        rolling,
        params,
        &cp,
        body.w - g.velocity.angular,
        || 1.4 * body.m * lever * lever,
        &mut cand.history,
        dt,
    );
    let rocking = rocking_damping(params, area, body.m, n, body.w - g.velocity.angular);
    let rolling_limit = c.rolling_resistance * lever;
    let mut reaction_rolling = -c.rolling_torque - rocking;
    if rolling_limit > 0.0 {
        let s = body.w.length();
        if s > 0.0 {
            reaction_rolling += body.w * (rolling_limit / s);
        }
    }
    *out = WallOutput {
        force: -c.force,
        torque: point.cross(-c.force) + reaction_rolling,
        particle_torque: arm.cross(c.force) + c.rolling_torque + rocking,
        rolling: rolling_limit,
    };
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn equivalent_contact_of_a_face_is_the_flat_punch() {
        // Face contact: area A, depth d, volume A d.
        let (area, depth) = (1e-4, 1e-6);
        let (overlap, r_eff) = equivalent_contact(area * depth, area);
        let a = (area / PI).sqrt();
        // Hertz with these: F = 4/3 E* sqrt(r d) d; stiffness 2 E* sqrt(r d).
        assert!(((r_eff * overlap).sqrt() / a - 1.0).abs() < 1e-12);
        let e_star = 1e7;
        let hertz = 4.0 / 3.0 * e_star * (r_eff * overlap).sqrt() * overlap;
        assert!((hertz / (2.0 * e_star * a * depth) - 1.0).abs() < 1e-12);
        // A sphere on a flat: V = pi R d^2 / 2, A = 2 pi R d / 2 (the cap over the plane) gives
        // within 6 % of Hertz with R* = R.
        let (r, d) = (0.003, 1e-5);
        let cap_v = PI * d * d * (r - d / 3.0);
        let cap_a = PI * (2.0 * r * d - d * d);
        let (ov, re) = equivalent_contact(cap_v, cap_a);
        let f = (re * ov).sqrt() * ov;
        let want = r.sqrt() * d.powf(1.5);
        assert!((f / want - 1.0).abs() < 0.07, "{}", f / want);
    }

    #[test]
    fn closest_point_on_a_cube() {
        let pts: Vec<DVec3> = (0..8)
            .map(|k| {
                DVec3::new(
                    if k & 1 == 0 { -0.5 } else { 0.5 },
                    if k & 2 == 0 { -0.5 } else { 0.5 },
                    if k & 4 == 0 { -0.5 } else { 0.5 },
                )
            })
            .collect();
        let (c, _) = super::super::ConvexPolyhedron::from_points(&pts).unwrap();
        let f = c.placed_frame(DVec3::ZERO, glam::DQuat::IDENTITY);
        let p = f.placed(&c);
        let (q, n, d) = closest_on_polyhedron(&p, DVec3::new(0.2, 0.1, 0.9));
        assert!((d - 0.4).abs() < 1e-12 && (n - DVec3::Z).length() < 1e-12);
        assert!((q - DVec3::new(0.2, 0.1, 0.5)).length() < 1e-12);
        // Beyond a corner.
        let (q, _, d) = closest_on_polyhedron(&p, DVec3::splat(1.5));
        assert!((q - DVec3::splat(0.5)).length() < 1e-12 && (d - 3f64.sqrt()).abs() < 1e-12);
        // Beyond an edge.
        let (q, _, _) = closest_on_polyhedron(&p, DVec3::new(1.0, 1.0, 0.2));
        assert!((q - DVec3::new(0.5, 0.5, 0.2)).length() < 1e-12);
        // Inside: the nearest face.
        let (_, n, d) = closest_on_polyhedron(&p, DVec3::new(0.0, 0.0, -0.4));
        assert!((d + 0.1).abs() < 1e-12 && (n + DVec3::Z).length() < 1e-12);
    }
}
