//! World vertices and face planes of every polyhedral body, refreshed once per force evaluation so
//! each contact reads them instead of rotating the shape again.

use super::clip::{Placed, Plane};
use super::ConvexPolyhedron;
use glam::{DQuat, DVec3};
use std::collections::HashMap;
use std::sync::Arc;

/// `shape` of a body that is a clump, not a polyhedron.
pub const NO_SHAPE: u32 = u32::MAX;

/// Shapes of the polyhedral bodies and their world frames (ranges per body; empty for clumps).
#[derive(Clone, Debug, Default)]
pub struct PolyFrames {
    pub shapes: Vec<Arc<ConvexPolyhedron>>,
    /// Per body: index into `shapes`, or [`NO_SHAPE`].
    pub shape: Vec<u32>,
    /// Per body: the scale its shape is drawn at (1 for clumps).
    pub scale: Vec<f64>,
    /// Index in `shapes` by the shape's address.
    by_address: HashMap<usize, u32>,
    vertex_start: Vec<u32>,
    plane_start: Vec<u32>,
    vertices: Vec<DVec3>,
    planes: Vec<Plane>,
}

impl PolyFrames {
    /// Whether any body is a polyhedron.
    pub fn any(&self) -> bool {
        !self.shapes.is_empty()
    }

    /// Registers the next body (`None`: a clump), a shape at a scale. Shapes are shared by
    /// address, so bodies of one shape at many scales hold it once.
    pub fn push(&mut self, shape: Option<(&Arc<ConvexPolyhedron>, f64)>) {
        if self.vertex_start.is_empty() {
            self.vertex_start.push(0);
            self.plane_start.push(0);
        }
        let index = match shape {
            None => NO_SHAPE,
            Some((s, _)) => {
                let next = self.shapes.len() as u32;
                let k = *self
                    .by_address
                    .entry(Arc::as_ptr(s) as usize)
                    .or_insert(next);
                if k == next {
                    self.shapes.push(s.clone());
                }
                k
            }
        };
        self.shape.push(index);
        self.scale.push(shape.map_or(1.0, |s| s.1));
        let (nv, nf) = shape.map_or((0, 0), |(s, _)| (s.vertices.len(), s.faces.len()));
        self.vertices.resize(self.vertices.len() + nv, DVec3::ZERO);
        self.planes.resize(self.planes.len() + nf, Plane::default());
        self.vertex_start.push(self.vertices.len() as u32);
        self.plane_start.push(self.planes.len() as u32);
    }

    /// Makes the last registered body (a clump so far) the polyhedron `shape`.
    pub fn set_last(&mut self, shape: &Arc<ConvexPolyhedron>, scale: f64) {
        self.shape.pop();
        self.scale.pop();
        self.vertex_start.pop();
        self.plane_start.pop();
        let (v, p) = (
            *self.vertex_start.last().unwrap() as usize,
            *self.plane_start.last().unwrap() as usize,
        );
        self.vertices.truncate(v);
        self.planes.truncate(p);
        self.push(Some((shape, scale)));
    }

    /// The shape of body `b`, if it is a polyhedron.
    #[inline(always)]
    pub fn shape_of(&self, b: u32) -> Option<&ConvexPolyhedron> {
        let s = *self.shape.get(b as usize)?;
        (s != NO_SHAPE).then(|| &*self.shapes[s as usize])
    }

    /// Whether body `b` is a polyhedron.
    #[inline(always)]
    pub fn is_polyhedron(&self, b: u32) -> bool {
        self.shape.get(b as usize).is_some_and(|&s| s != NO_SHAPE)
    }

    /// Recomputes the world frames from the bodies' poses.
    /// In parallel over the bodies: each writes its own vertex and plane rows.
    pub fn update(&mut self, positions: &[DVec3], orientations: impl Fn(usize) -> DQuat + Sync) {
        use crate::parallel::Shared;
        use rayon::prelude::*;
        let (vertices, planes) = (
            Shared(self.vertices.as_mut_ptr()),
            Shared(self.planes.as_mut_ptr()),
        );
        let (shape_of, shapes, scale) = (&self.shape, &self.shapes, &self.scale);
        let (vertex_start, plane_start) = (&self.vertex_start, &self.plane_start);
        (0..shape_of.len())
            .into_par_iter()
            .with_min_len(64)
            .for_each(|b| {
                let s = shape_of[b];
                if s == NO_SHAPE {
                    return;
                }
                let (v0, v1) = (vertex_start[b] as usize, vertex_start[b + 1] as usize);
                let (p0, p1) = (plane_start[b] as usize, plane_start[b + 1] as usize);
                // SAFETY: the rows of different bodies are disjoint ranges of the buffers.
                let (vs, ps) = unsafe {
                    (
                        std::slice::from_raw_parts_mut(vertices.ptr().add(v0), v1 - v0),
                        std::slice::from_raw_parts_mut(planes.ptr().add(p0), p1 - p0),
                    )
                };
                shapes[s as usize].place_into(positions[b], orientations(b), scale[b], vs, ps);
            });
    }

    /// Body `b` placed in the world (as of the last [`Self::update`]); `centre` its centre of mass.
    #[inline(always)]
    pub fn placed(&self, b: u32, centre: DVec3) -> Option<Placed<'_>> {
        let shape = self.shape_of(b)?;
        let b = b as usize;
        let scale = self.scale[b];
        Some(Placed {
            shape,
            scale,
            vertices: &self.vertices
                [self.vertex_start[b] as usize..self.vertex_start[b + 1] as usize],
            planes: &self.planes[self.plane_start[b] as usize..self.plane_start[b + 1] as usize],
            centre,
            radius: shape.bounding_radius * scale,
        })
    }

    /// Body `b`'s world vertices as of the last [`Self::update`], its shape and scale.
    pub fn world(&self, b: u32) -> Option<(&ConvexPolyhedron, f64, &[DVec3])> {
        let shape = self.shape_of(b)?;
        let b = b as usize;
        Some((
            shape,
            self.scale[b],
            &self.vertices[self.vertex_start[b] as usize..self.vertex_start[b + 1] as usize],
        ))
    }
}
