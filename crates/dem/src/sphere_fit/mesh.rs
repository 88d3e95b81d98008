//! A closed STL triangle mesh as a [`Solid`]: volume and centroid by the divergence theorem,
//! inside test by ray-crossing parity, surface points sampled on the triangles.
//!
//! The inside test casts a ray from the point along a fixed direction that is not aligned with
//! any axis or diagonal, (1, a, b) with a = sqrt(2)/10, b = sqrt(3)/10, so that rays from grid
//! points do not graze the edges of the axis-aligned triangles CAD tools write. Along that
//! direction the mesh is sheared to (u, v) = (y - a x, z - b x), where each ray is a point; the
//! triangles are binned by their (u, v) bounding boxes, and a query tests only its bin's triangles.
//! This is hand-written rather than taken from a mesh crate (parry3d, for instance) because it is
//! some 150 lines against a large dependency tree the engine does not otherwise need, and the
//! fit needs only the inside test (distances come from the sampled surface, as for the analytic
//! kernel shapes).

use super::Solid;
use glam::{DVec2, DVec3};
use std::collections::HashMap;
use std::path::Path;

/// A closed triangle mesh, in metres.
#[derive(Clone, Debug)]
pub struct MeshSolid {
    pub triangles: Vec<[DVec3; 3]>,
    volume: f64,
    pub centroid: DVec3,
    lo: DVec3,
    hi: DVec3,
    bins: Bins,
}

const SHEAR_A: f64 = std::f64::consts::SQRT_2 / 10.0;
const SHEAR_B: f64 = 0.173_205_080_756_887_72; // sqrt(3) / 10

fn shear(p: DVec3) -> DVec2 {
    DVec2::new(p.y - SHEAR_A * p.x, p.z - SHEAR_B * p.x)
}

#[derive(Clone, Debug)]
struct Bins {
    lo: DVec2,
    cell: f64,
    n: [usize; 2],
    start: Vec<u32>,
    items: Vec<u32>,
}

impl MeshSolid {
    /// Reads an STL file (binary or ASCII) and scales it (0.001 for a model drawn in mm).
    /// Refuses a mesh that is not closed. Errors are one line naming the file.
    pub fn read(path: &Path, scale: f64) -> Result<MeshSolid, String> {
        let name = path.display();
        let mut file = crate::files::open_checked(path, crate::files::MAX_MESH_BYTES)
            .map_err(|e| format!("{name}: cannot open: {e}"))?;
        let mesh = stl_io::read_stl(&mut file)
            .map_err(|e| format!("{name}: not a valid STL file: {e}"))?;
        // stl_io merges equal vertices bit for bit; merge 0.0 with -0.0 as well, so that
        // a mesh that is closed reads as closed.
        let mut merged: HashMap<[u32; 3], usize> = HashMap::new();
        let mut vertices: Vec<DVec3> = Vec::new();
        let index: Vec<usize> = mesh
            .vertices
            .iter()
            .map(|v| {
                let key = [0, 1, 2].map(|a| (v[a] + 0.0).to_bits());
                *merged.entry(key).or_insert_with(|| {
                    vertices.push(DVec3::new(v[0] as f64, v[1] as f64, v[2] as f64) * scale);
                    vertices.len() - 1
                })
            })
            .collect();
        let faces: Vec<[usize; 3]> = mesh
            .faces
            .iter()
            .map(|f| f.vertices.map(|i| index[i]))
            .collect();
        MeshSolid::new(&vertices, &faces).map_err(|m| format!("{name}: {m}"))
    }

    /// A mesh from shared vertices and triangles of vertex indices; refuses a mesh that is not
    /// closed (every edge shared by exactly two triangles).
    pub fn new(vertices: &[DVec3], faces: &[[usize; 3]]) -> Result<MeshSolid, String> {
        let faces: Vec<[usize; 3]> = faces
            .iter()
            .copied()
            .filter(|f| f[0] != f[1] && f[1] != f[2] && f[0] != f[2])
            .collect();
        if faces.is_empty() {
            return Err("the mesh holds no triangles".into());
        }
        let mut edges: HashMap<(usize, usize), u32> = HashMap::new();
        for f in &faces {
            for e in 0..3 {
                let (a, b) = (f[e], f[(e + 1) % 3]);
                *edges.entry((a.min(b), a.max(b))).or_default() += 1;
            }
        }
        let open = edges.values().filter(|&&n| n != 2).count();
        if open > 0 {
            return Err(format!(
                "the mesh is not closed: {open} of its {} edges are not shared by exactly two triangles",
                edges.len()
            ));
        }
        let triangles: Vec<[DVec3; 3]> = faces
            .iter()
            .map(|f| [vertices[f[0]], vertices[f[1]], vertices[f[2]]])
            .collect();
        // Divergence theorem: signed tetrahedra from the origin.
        let (mut volume, mut moment) = (0.0, DVec3::ZERO);
        for [a, b, c] in &triangles {
            let v = a.dot(b.cross(*c)) / 6.0;
            volume += v;
            moment += v * (*a + *b + *c) / 4.0;
        }
        if volume.abs() <= 0.0 || !volume.is_finite() {
            return Err("the mesh encloses no volume".into());
        }
        let centroid = moment / volume;
        let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
        for t in &triangles {
            for p in t {
                lo = lo.min(*p);
                hi = hi.max(*p);
            }
        }
        let bins = Bins::new(&triangles);
        Ok(MeshSolid {
            triangles,
            // Triangles wound inward give a negative volume: the solid is the same.
            volume: volume.abs(),
            centroid,
            lo,
            hi,
            bins,
        })
    }
}

impl Bins {
    fn new(triangles: &[[DVec3; 3]]) -> Bins {
        let boxes: Vec<(DVec2, DVec2)> = triangles
            .iter()
            .map(|t| {
                let (a, b, c) = (shear(t[0]), shear(t[1]), shear(t[2]));
                (a.min(b).min(c), a.max(b).max(c))
            })
            .collect();
        let (mut lo, mut hi) = (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY));
        for (a, b) in &boxes {
            lo = lo.min(*a);
            hi = hi.max(*b);
        }
        // About as many bins as triangles.
        let side = (triangles.len() as f64).sqrt().ceil().max(1.0);
        let cell = ((hi - lo).max_element() / side).max(1e-300);
        let n = [
            ((hi.x - lo.x) / cell).floor() as usize + 1,
            ((hi.y - lo.y) / cell).floor() as usize + 1,
        ];
        let range = |a: DVec2, b: DVec2| {
            let i0 = (((a.x - lo.x) / cell).floor() as usize).min(n[0] - 1);
            let j0 = (((a.y - lo.y) / cell).floor() as usize).min(n[1] - 1);
            let i1 = (((b.x - lo.x) / cell).floor() as usize).min(n[0] - 1);
            let j1 = (((b.y - lo.y) / cell).floor() as usize).min(n[1] - 1);
            (i0, j0, i1, j1)
        };
        let mut start = vec![0u32; n[0] * n[1] + 1];
        for (a, b) in &boxes {
            let (i0, j0, i1, j1) = range(*a, *b);
            for j in j0..=j1 {
                for i in i0..=i1 {
                    start[i + n[0] * j + 1] += 1;
                }
            }
        }
        for c in 0..n[0] * n[1] {
            start[c + 1] += start[c];
        }
        let mut fill = start.clone();
        let mut items = vec![0u32; start[n[0] * n[1]] as usize];
        for (t, (a, b)) in boxes.iter().enumerate() {
            let (i0, j0, i1, j1) = range(*a, *b);
            for j in j0..=j1 {
                for i in i0..=i1 {
                    let c = i + n[0] * j;
                    items[fill[c] as usize] = t as u32;
                    fill[c] += 1;
                }
            }
        }
        Bins {
            lo,
            cell,
            n,
            start,
            items,
        }
    }

    fn bin(&self, q: DVec2) -> Option<&[u32]> {
        let f = (q - self.lo) / self.cell;
        if f.x < 0.0 || f.y < 0.0 {
            return None;
        }
        let (i, j) = (f.x as usize, f.y as usize);
        if i >= self.n[0] || j >= self.n[1] {
            return None;
        }
        let c = i + self.n[0] * j;
        Some(&self.items[self.start[c] as usize..self.start[c + 1] as usize])
    }
}

impl Solid for MeshSolid {
    fn bounds(&self) -> (DVec3, DVec3) {
        (self.lo, self.hi)
    }

    fn inside(&self, p: DVec3) -> bool {
        if p.cmplt(self.lo).any() || p.cmpgt(self.hi).any() {
            return false;
        }
        let q = shear(p);
        let Some(list) = self.bins.bin(q) else {
            return false;
        };
        let mut crossings = 0u32;
        for &t in list {
            let [a, b, c] = self.triangles[t as usize];
            let (a2, b2, c2) = (shear(a) - q, shear(b) - q, shear(c) - q);
            // Barycentric weights of the origin in the projected triangle (edge functions).
            let wa = b2.perp_dot(c2);
            let wb = c2.perp_dot(a2);
            let wc = a2.perp_dot(b2);
            let all_pos = wa > 0.0 && wb > 0.0 && wc > 0.0;
            let all_neg = wa < 0.0 && wb < 0.0 && wc < 0.0;
            if !(all_pos || all_neg) {
                continue;
            }
            let x = (wa * a.x + wb * b.x + wc * c.x) / (wa + wb + wc);
            if x > p.x {
                crossings += 1;
            }
        }
        crossings % 2 == 1
    }

    fn volume(&self) -> f64 {
        self.volume
    }

    /// Points on every triangle at most `spacing` apart (a barycentric lattice).
    fn surface_points(&self, spacing: f64) -> Vec<DVec3> {
        let mut out = Vec::new();
        for [a, b, c] in &self.triangles {
            let longest = (*b - *a)
                .length()
                .max((*c - *b).length())
                .max((*a - *c).length());
            let n = ((longest / spacing).ceil() as usize).max(1);
            for i in 0..=n {
                for j in 0..=n - i {
                    let (u, v) = (i as f64 / n as f64, j as f64 / n as f64);
                    out.push(*a + u * (*b - *a) + v * (*c - *a));
                }
            }
        }
        out
    }
}
