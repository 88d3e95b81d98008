//! Convex hull of a point set in 3-D (incremental: add points one by one, remove the faces a new
//! point sees and close the hole with a fan from the point), with coplanar triangles merged into
//! polygon faces.
//!
//! Why our own: the hulls here are built once per particle shape from tens to a few thousand
//! points, in f64 and glam 0.29; `quickhull` works in f32 on another glam, and `parry3d-f64`
//! brings a second linear-algebra stack for one function. O(n * faces) is milliseconds at these sizes.

use glam::DVec3;

/// A hull face: outward unit normal, offset (n . x = offset on the face) and its vertices in
/// counter-clockwise order seen from outside (indices into the hull's points).
#[derive(Clone, Debug, PartialEq)]
pub struct HullFace {
    pub normal: DVec3,
    pub offset: f64,
    pub vertices: Vec<usize>,
}

/// The hull: its vertices (a subset of the input, in input order) and faces indexing them.
#[derive(Clone, Debug)]
pub struct Hull {
    pub points: Vec<DVec3>,
    pub faces: Vec<HullFace>,
}

/// Convex hull of `points`; an error when they are fewer than four or all lie in one plane.
pub fn convex_hull(points: &[DVec3]) -> Result<Hull, String> {
    if points.len() < 4 {
        return Err(format!(
            "a convex hull needs at least 4 points, got {}",
            points.len()
        ));
    }
    if points.iter().any(|p| !p.is_finite()) {
        return Err("a point of the hull is not finite".into());
    }
    let (lo, hi) = points.iter().fold(
        (DVec3::splat(f64::MAX), DVec3::splat(f64::MIN)),
        |(l, h), p| (l.min(*p), h.max(*p)),
    );
    let size = (hi - lo).max_element();
    if size <= 0.0 {
        return Err("the hull's points coincide".into());
    }
    let eps = 1e-10 * size;
    // Initial tetrahedron: two extreme points, the point furthest from their line, the point
    // furthest from their plane.
    let a = (0..points.len())
        .min_by(|&i, &j| points[i].x.total_cmp(&points[j].x))
        .unwrap();
    let b = (0..points.len())
        .max_by(|&i, &j| {
            (points[i] - points[a])
                .length_squared()
                .total_cmp(&(points[j] - points[a]).length_squared())
        })
        .unwrap();
    let ab = (points[b] - points[a]).normalize();
    let c = (0..points.len())
        .max_by(|&i, &j| {
            let di = (points[i] - points[a]).cross(ab).length_squared();
            let dj = (points[j] - points[a]).cross(ab).length_squared();
            di.total_cmp(&dj)
        })
        .unwrap();
    let n = (points[b] - points[a]).cross(points[c] - points[a]);
    if n.length() <= eps * size {
        return Err("the hull's points lie on one line".into());
    }
    let n = n.normalize();
    let d = (0..points.len())
        .max_by(|&i, &j| {
            ((points[i] - points[a]).dot(n).abs()).total_cmp(&(points[j] - points[a]).dot(n).abs())
        })
        .unwrap();
    if (points[d] - points[a]).dot(n).abs() <= eps {
        return Err("the hull's points lie in one plane (a solid needs thickness)".into());
    }
    let inside = (points[a] + points[b] + points[c] + points[d]) * 0.25;
    let mut tris: Vec<[usize; 3]> = Vec::new();
    let push = |tris: &mut Vec<[usize; 3]>, t: [usize; 3]| {
        let (p, q, r) = (points[t[0]], points[t[1]], points[t[2]]);
        if (q - p).cross(r - p).dot(p - inside) < 0.0 {
            tris.push([t[0], t[2], t[1]]);
        } else {
            tris.push(t);
        }
    };
    for t in [[a, b, c], [a, b, d], [a, c, d], [b, c, d]] {
        push(&mut tris, t);
    }
    let visible = |t: &[usize; 3], p: DVec3| {
        let (x, y, z) = (points[t[0]], points[t[1]], points[t[2]]);
        let nn = (y - x).cross(z - x);
        let len = nn.length();
        len > 0.0 && nn.dot(p - x) / len > eps
    };
    let mut horizon: Vec<(usize, usize)> = Vec::new();
    for (k, &p) in points.iter().enumerate() {
        if [a, b, c, d].contains(&k) {
            continue;
        }
        let seen: Vec<bool> = tris.iter().map(|t| visible(t, p)).collect();
        if !seen.iter().any(|&s| s) {
            continue;
        }
        // Horizon: edges of seen faces whose reverse is not an edge of a seen face.
        horizon.clear();
        for (t, _) in tris.iter().zip(&seen).filter(|(_, s)| **s) {
            for e in 0..3 {
                horizon.push((t[e], t[(e + 1) % 3]));
            }
        }
        let edges = horizon.clone();
        horizon.retain(|&(u, v)| !edges.contains(&(v, u)));
        let mut kept: Vec<[usize; 3]> = tris
            .iter()
            .zip(&seen)
            .filter(|(_, s)| !**s)
            .map(|(t, _)| *t)
            .collect();
        for &(u, v) in &horizon {
            kept.push([u, v, k]);
        }
        tris = kept;
    }
    merge_coplanar(points, &tris, size)
}

/// Groups triangles by plane and orders each group's vertices around its centre.
fn merge_coplanar(points: &[DVec3], tris: &[[usize; 3]], size: f64) -> Result<Hull, String> {
    let mut groups: Vec<(DVec3, f64, Vec<usize>)> = Vec::new();
    for t in tris {
        let (p, q, r) = (points[t[0]], points[t[1]], points[t[2]]);
        let nn = (q - p).cross(r - p);
        // A sliver (from near-duplicate points) has no reliable normal; its corners belong to
        // its neighbours' faces anyway.
        if nn.length() <= 1e-10 * size * size {
            continue;
        }
        let n = nn.normalize();
        let off = n.dot(p);
        // Coplanar within what f32 coordinates (STL files) resolve: 1e-6 of the size.
        match groups
            .iter_mut()
            .find(|(gn, go, _)| gn.dot(n) > 1.0 - 1e-9 && (go - off).abs() < 1e-6 * size)
        {
            Some(g) => g.2.extend_from_slice(t),
            None => groups.push((n, off, t.to_vec())),
        }
    }
    let mut rings: Vec<(DVec3, DVec3, Vec<usize>)> = Vec::with_capacity(groups.len());
    for (n, _, mut vs) in groups {
        vs.sort_unstable();
        vs.dedup();
        let centre = vs.iter().map(|&i| points[i]).sum::<DVec3>() / vs.len() as f64;
        // The face is the 2-D hull of the group's points (drops points inside it or on its edges,
        // which an early, smaller hull can have made vertices).
        let u = n.any_orthonormal_vector();
        let w = n.cross(u);
        let flat = |i: usize| {
            let p = points[i] - centre;
            (p.dot(u), p.dot(w))
        };
        vs.sort_by(|&i, &j| {
            let (a, b) = (flat(i), flat(j));
            a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1))
        });
        let turn = |o: usize, a: usize, b: usize| {
            let (o, a, b) = (flat(o), flat(a), flat(b));
            (a.0 - o.0) * (b.1 - o.1) - (a.1 - o.1) * (b.0 - o.0)
        };
        let tol = 1e-12 * size * size;
        let mut ring: Vec<usize> = Vec::with_capacity(vs.len() + 1);
        for &i in &vs {
            while ring.len() >= 2 && turn(ring[ring.len() - 2], ring[ring.len() - 1], i) <= tol {
                ring.pop();
            }
            ring.push(i);
        }
        let lower = ring.len() + 1;
        for &i in vs.iter().rev().skip(1) {
            while ring.len() >= lower && turn(ring[ring.len() - 2], ring[ring.len() - 1], i) <= tol
            {
                ring.pop();
            }
            ring.push(i);
        }
        ring.pop();
        if ring.len() < 3 {
            continue;
        }
        let vs = ring;
        rings.push((n, centre, vs));
    }
    let mut used: Vec<usize> = rings.iter().flat_map(|g| g.2.iter().copied()).collect();
    used.sort_unstable();
    used.dedup();
    let remap = |i: usize| used.binary_search(&i).unwrap();
    let faces = rings
        .into_iter()
        .map(|(n, centre, ring)| HullFace {
            normal: n,
            offset: n.dot(centre),
            vertices: ring.into_iter().map(remap).collect(),
        })
        .collect();
    Ok(Hull {
        points: used.iter().map(|&i| points[i]).collect(),
        faces,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cube_with_interior_and_face_points_has_six_square_faces() {
        let mut pts = Vec::new();
        for i in 0..3 {
            for j in 0..3 {
                for k in 0..3 {
                    pts.push(DVec3::new(i as f64, j as f64, k as f64) - 1.0);
                }
            }
        }
        let h = convex_hull(&pts).unwrap();
        assert_eq!(h.faces.len(), 6);
        for f in &h.faces {
            assert_eq!(f.vertices.len(), 4, "{f:?}");
            assert!((f.offset - 1.0).abs() < 1e-12);
            // Counter-clockwise seen from outside.
            let p: Vec<DVec3> = f.vertices.iter().map(|&i| h.points[i]).collect();
            assert!((p[1] - p[0]).cross(p[2] - p[1]).dot(f.normal) > 0.0);
        }
        assert!(convex_hull(&pts[..9]).is_err(), "one plane");
    }
}
