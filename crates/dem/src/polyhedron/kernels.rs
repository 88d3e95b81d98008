//! The maize kernel classes as convex polyhedra: the convex hull of points on each class's target
//! solid (docs/lab-tests.md section 1 dimensions; [`KernelShape`]).
//!
//! The horse-tooth wedge is itself convex with 8 corners, so its hull is exact. The rounded classes
//! are sampled on rings: the flat kernel as a 12-sided prism, the spherical cone as its tip and two
//! rings of 10 plus the cap's top, the near-spherical ellipsoid as three rings of 10 and its poles.
//! Points on the surface make a hull inside the solid: the flat prism holds 95.5 % of the disc's
//! volume, the cone 84.8 %, the ellipsoid 79.9 %. [`kernel_polyhedron`] therefore scales each hull
//! about its centre to the target solid's volume (and mass), which lengthens every dimension by the
//! cube root of the ratio (at most 7.8 %); [`KernelPolyhedron`] reports by how much.

use super::ConvexPolyhedron;
use crate::maize_kernel::KernelShape;
use glam::DVec3;
use std::f64::consts::PI;

/// A kernel polyhedron and how it was made.
#[derive(Clone, Debug)]
pub struct KernelPolyhedron {
    pub polyhedron: ConvexPolyhedron,
    /// Volume of the target solid.
    pub target_volume: f64,
    /// Hull volume over the target's, before scaling.
    pub hull_volume_ratio: f64,
    /// The linear scale applied to match the target volume.
    pub scale: f64,
}

/// Points on the class's surface, in [`KernelShape::inside`]'s frame (x width, y height, z thickness).
pub fn kernel_hull_points(shape: &KernelShape) -> Vec<DVec3> {
    let ring = |n: usize, rx: f64, rz: f64, y: f64, out: &mut Vec<DVec3>| {
        for k in 0..n {
            let phi = 2.0 * PI * k as f64 / n as f64;
            out.push(DVec3::new(rx * phi.cos(), y, rz * phi.sin()));
        }
    };
    let mut pts = Vec::new();
    match *shape {
        KernelShape::HorseTooth {
            upper_width,
            lower_width,
            height,
            upper_thickness,
            lower_thickness,
        } => {
            for (y, w, t) in [
                (-0.5 * height, lower_width, lower_thickness),
                (0.5 * height, upper_width, upper_thickness),
            ] {
                for (sx, sz) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
                    pts.push(DVec3::new(0.5 * w * sx, y, 0.5 * t * sz));
                }
            }
        }
        KernelShape::Flat {
            diameter,
            thickness,
        } => {
            // The disc's axis is z: rings in x-y at z = +-t/2.
            for z in [-0.5 * thickness, 0.5 * thickness] {
                for k in 0..12 {
                    let phi = 2.0 * PI * k as f64 / 12.0;
                    pts.push(DVec3::new(
                        0.5 * diameter * phi.cos(),
                        0.5 * diameter * phi.sin(),
                        z,
                    ));
                }
            }
        }
        KernelShape::SphericalCone {
            width,
            height,
            thickness,
        } => {
            let r = 0.5 * width;
            let flat = thickness / width;
            let tip = -0.5 * height;
            let cone = tip + height - r;
            pts.push(DVec3::new(0.0, tip, 0.0));
            for lat in [0.0f64, 50.0] {
                let a = lat.to_radians();
                ring(
                    10,
                    r * a.cos(),
                    r * a.cos() * flat,
                    cone + r * a.sin(),
                    &mut pts,
                );
            }
            pts.push(DVec3::new(0.0, cone + r, 0.0));
        }
        KernelShape::NearSpherical {
            width,
            height,
            thickness,
        } => {
            let (a, b, c) = (0.5 * width, 0.5 * height, 0.5 * thickness);
            for lat in [-45.0f64, 0.0, 45.0] {
                let t = lat.to_radians();
                ring(10, a * t.cos(), c * t.cos(), b * t.sin(), &mut pts);
            }
            pts.push(DVec3::new(0.0, -b, 0.0));
            pts.push(DVec3::new(0.0, b, 0.0));
        }
    }
    pts
}

/// The class as a convex polyhedron of the target solid's volume (see the module notes).
pub fn kernel_polyhedron(shape: &KernelShape) -> Result<KernelPolyhedron, String> {
    shape.validate()?;
    let (hull, _) = ConvexPolyhedron::from_points(&kernel_hull_points(shape))?;
    let target = shape.volume();
    let ratio = hull.volume / target;
    let scale = (1.0 / ratio).cbrt();
    Ok(KernelPolyhedron {
        polyhedron: hull.scaled(scale),
        target_volume: target,
        hull_volume_ratio: ratio,
        scale,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kernel_hulls_hold_their_solid_and_match_its_volume() {
        for kind in KernelShape::KINDS {
            let s = KernelShape::published(kind).unwrap();
            let k = kernel_polyhedron(&s).unwrap();
            let p = &k.polyhedron;
            assert!((p.volume / s.volume() - 1.0).abs() < 1e-12, "{kind}");
            assert!(p.faces.len() <= super::super::MAX_FACES);
            // The hull of surface points lies inside the solid: at most 25 % smaller.
            assert!(
                k.hull_volume_ratio > 0.75 && k.hull_volume_ratio <= 1.0 + 1e-12,
                "{kind}: {}",
                k.hull_volume_ratio
            );
            if kind == "horse_tooth" {
                assert!((k.hull_volume_ratio - 1.0).abs() < 1e-12);
                assert_eq!(p.vertices.len(), 8);
            }
        }
    }
}
