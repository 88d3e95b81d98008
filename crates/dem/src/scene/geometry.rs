//! Building geometry from its description, with the checks and key names of the scene file.

use super::description::{GeometryDescription, GeometryShape};
use super::{Ctx, SceneError};
use crate::geometry::{self, shapes, Element, Geometry, Motion};
use glam::DVec3;

pub(super) fn build(
    ctx: &Ctx,
    k: usize,
    g: &GeometryDescription,
    material_id: &dyn Fn(&str, String) -> Result<usize, SceneError>,
) -> Result<Geometry, SceneError> {
    let key = |s: &str| format!("geometry[{k}].{s}");
    let material = material_id(&g.material, key("material"))?;
    let elements: Vec<Element> = match &g.shape {
        &GeometryShape::Plane { point, normal } => vec![Element::Plane {
            point,
            normal: ctx.direction(normal, key("normal"))?,
        }],
        GeometryShape::Box { min, max, open } => {
            if !min.cmplt(*max).all() {
                return Err(ctx.err(key("max"), "expected max > min in every coordinate"));
            }
            for o in open {
                if !["-x", "+x", "-y", "+y", "-z", "+z"].contains(&o.as_str()) {
                    return Err(ctx.err(
                        key("open"),
                        format!("unknown face \"{o}\" (expected -x, +x, -y, +y, -z, +z)"),
                    ));
                }
            }
            shapes::box_walls(*min, *max, open)
        }
        &GeometryShape::Cylinder {
            base,
            axis,
            radius,
            length,
            bottom_cap,
            top_cap,
        } => {
            let axis = ctx.direction(axis, key("axis"))?;
            let radius = ctx.positive(radius, key("radius"))?;
            let length = ctx.positive(length, key("length"))?;
            shapes::cylinder(base, axis, radius, length, bottom_cap, top_cap)
        }
        GeometryShape::Mesh {
            file,
            scale,
            offset,
        } => {
            if !file.exists() {
                return Err(ctx.err(
                    key("file"),
                    format!("STL file {} does not exist", file.display()),
                ));
            }
            let scale = ctx.positive(*scale, key("scale"))?;
            geometry::read_stl(file, scale, *offset)
                .map_err(|m| ctx.err(key("file"), format!("{}: {m}", file.display())))?
        }
    };
    let mut motion = Vec::new();
    for (m, e) in g.motion.iter().enumerate() {
        let mk = |s: &str| format!("geometry[{k}].motion[{m}].{s}");
        let (start, end) = match *e {
            Motion::Translation { start, end, .. } | Motion::Rotation { start, end, .. } => {
                (start, end)
            }
        };
        let start = ctx.non_negative(start, mk("start"))?;
        if end.is_nan() || end <= start {
            return Err(ctx.err(
                mk("end"),
                format!("expected end > start ({start}), got {end}"),
            ));
        }
        motion.push(match *e {
            // A NaN or infinite motion would run with walls at NaN.
            Motion::Translation { velocity, .. } => Motion::Translation {
                velocity: ctx.finite3(velocity, mk("velocity"))?,
                start,
                end,
            },
            Motion::Rotation {
                axis_point,
                axis,
                angular_velocity,
                ..
            } => Motion::Rotation {
                axis_point: ctx.finite3(axis_point, mk("axis_point"))?,
                axis: ctx.direction(axis, mk("axis"))?,
                angular_velocity: ctx.finite(angular_velocity, mk("angular_velocity"))?,
                start,
                end,
            },
        });
    }
    if let Some(p) = g.torque_point {
        ctx.finite3(p, format!("geometry[{k}].torque_point"))?;
    }
    let mut geo = Geometry::new(&g.name, material, elements).with_motion(motion);
    geo.torque_point = g.torque_point.unwrap_or_else(|| {
        g.motion
            .iter()
            .find_map(|m| match m {
                Motion::Rotation { axis_point, .. } => Some(*axis_point),
                Motion::Translation { .. } => None,
            })
            .unwrap_or(DVec3::ZERO)
    });
    Ok(geo)
}

/// The largest extent of a geometry's finite elements (0 for a plane alone).
pub(super) fn extent(g: &Geometry) -> f64 {
    let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
    for e in &g.elements {
        let (a, b) = e.bounds();
        if a.is_finite() && b.is_finite() {
            lo = lo.min(a);
            hi = hi.max(b);
        }
    }
    if lo.cmple(hi).all() {
        (hi - lo).max_element()
    } else {
        0.0
    }
}
