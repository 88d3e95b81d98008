//! Multi-sphere models of maize kernels, fitted to the four shape classes of docs/lab-tests.md from
//! their measured dimensions.
//!
//! Each class is a target solid with an inside test. The fit is greedy coverage by inscribed
//! spheres: candidate centres lie on a grid in the kernel's mid-plane (its two long dimensions),
//! each candidate gets the largest sphere that stays inside the solid, and N times the candidate
//! that covers the most not-yet-covered volume (counted on a grid of interior sample points) is
//! taken; spheres under half the largest are not offered, since the smallest sphere sets the time
//! step. Inscribed spheres never poke out of the kernel, so the clump is smaller than
//! the solid (by 10-30 % with 6-12 spheres, most for the box-like wedge and disc);
//! [`KernelFit::volume_error`] reports by how much, and it shrinks as N grows.
//!
//! Frame: x across the width, y along the height (the long axis), z across the thickness.

use crate::clump::ClumpTemplate;
use glam::DVec3;
use std::f64::consts::PI;

/// The kernel shape classes of the maize repose calibration (dimensions in metres).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum KernelShape {
    /// Dent kernel: a wedge whose width and thickness vary linearly from the lower (y = 0) to the
    /// upper end (y = height).
    HorseTooth {
        upper_width: f64,
        lower_width: f64,
        height: f64,
        upper_thickness: f64,
        lower_thickness: f64,
    },
    /// A disc of the given diameter and thickness.
    Flat { diameter: f64, thickness: f64 },
    /// A cone with its tip at y = 0 capped by a half-sphere of diameter `width`, flattened to
    /// `thickness` across z.
    SphericalCone {
        width: f64,
        height: f64,
        thickness: f64,
    },
    /// An ellipsoid with the three dimensions as its axes.
    NearSpherical {
        width: f64,
        height: f64,
        thickness: f64,
    },
}

impl KernelShape {
    /// The published dimensions (docs/lab-tests.md section 1, maize kernels). The near-spherical
    /// class has no published dimensions; 8.0 x 8.5 x 6.5 mm is our assumption from the other
    /// classes' sizes.
    pub fn published(kind: &str) -> Option<KernelShape> {
        let mm = 1e-3;
        Some(match kind {
            "horse_tooth" => KernelShape::HorseTooth {
                upper_width: 7.22 * mm,
                lower_width: 8.82 * mm,
                height: 12.16 * mm,
                upper_thickness: 4.41 * mm,
                lower_thickness: 4.80 * mm,
            },
            "flat" => KernelShape::Flat {
                diameter: 9.05 * mm,
                thickness: 5.00 * mm,
            },
            "spherical_cone" => KernelShape::SphericalCone {
                width: 8.05 * mm,
                height: 10.03 * mm,
                thickness: 5.91 * mm,
            },
            "near_spherical" => KernelShape::NearSpherical {
                width: 8.0 * mm,
                height: 8.5 * mm,
                thickness: 6.5 * mm,
            },
            _ => return None,
        })
    }

    pub const KINDS: [&'static str; 4] =
        ["horse_tooth", "flat", "spherical_cone", "near_spherical"];

    /// The class's name, as [`KernelShape::published`] takes it.
    pub fn class(&self) -> &'static str {
        match self {
            KernelShape::HorseTooth { .. } => "horse_tooth",
            KernelShape::Flat { .. } => "flat",
            KernelShape::SphericalCone { .. } => "spherical_cone",
            KernelShape::NearSpherical { .. } => "near_spherical",
        }
    }

    /// The class's dimensions by name (the scene-file keys), to read or override.
    pub fn dimensions_mut(&mut self) -> Vec<(&'static str, &mut f64)> {
        match self {
            KernelShape::HorseTooth {
                upper_width,
                lower_width,
                height,
                upper_thickness,
                lower_thickness,
            } => vec![
                ("upper_width", upper_width),
                ("lower_width", lower_width),
                ("height", height),
                ("upper_thickness", upper_thickness),
                ("lower_thickness", lower_thickness),
            ],
            KernelShape::Flat {
                diameter,
                thickness,
            } => vec![("diameter", diameter), ("thickness", thickness)],
            KernelShape::SphericalCone {
                width,
                height,
                thickness,
            }
            | KernelShape::NearSpherical {
                width,
                height,
                thickness,
            } => vec![
                ("width", width),
                ("height", height),
                ("thickness", thickness),
            ],
        }
    }

    /// Checks that every dimension is positive (and the cone is taller than its cap).
    pub fn validate(&self) -> Result<(), String> {
        let mut copy = *self;
        let dims: Vec<(&str, f64)> = copy
            .dimensions_mut()
            .into_iter()
            .map(|(n, v)| (n, *v))
            .collect();
        for (name, v) in dims {
            if !(v > 0.0 && v.is_finite()) {
                return Err(format!("{name} must be positive, got {v}"));
            }
        }
        if let KernelShape::SphericalCone { width, height, .. } = *self {
            if height <= 0.5 * width {
                return Err(format!(
                    "height ({height}) must exceed half the width ({}) for a cone under the cap",
                    0.5 * width
                ));
            }
        }
        Ok(())
    }

    /// Half extents of the bounding box, centred on the origin of [`Self::inside`]'s frame.
    pub fn half_extents(&self) -> DVec3 {
        match *self {
            KernelShape::HorseTooth {
                upper_width,
                lower_width,
                height,
                upper_thickness,
                lower_thickness,
            } => DVec3::new(
                0.5 * upper_width.max(lower_width),
                0.5 * height,
                0.5 * upper_thickness.max(lower_thickness),
            ),
            KernelShape::Flat {
                diameter,
                thickness,
            } => DVec3::new(0.5 * diameter, 0.5 * diameter, 0.5 * thickness),
            KernelShape::SphericalCone {
                width,
                height,
                thickness,
            }
            | KernelShape::NearSpherical {
                width,
                height,
                thickness,
            } => DVec3::new(0.5 * width, 0.5 * height, 0.5 * thickness),
        }
    }

    /// Whether a point (relative to the bounding box centre) is inside the solid.
    pub fn inside(&self, p: DVec3) -> bool {
        let h = self.half_extents();
        match *self {
            KernelShape::HorseTooth {
                upper_width,
                lower_width,
                height,
                upper_thickness,
                lower_thickness,
            } => {
                let s = (p.y + h.y) / height;
                if !(0.0..=1.0).contains(&s) {
                    return false;
                }
                let w = lower_width + (upper_width - lower_width) * s;
                let t = lower_thickness + (upper_thickness - lower_thickness) * s;
                p.x.abs() <= 0.5 * w && p.z.abs() <= 0.5 * t
            }
            KernelShape::Flat { .. } => p.x * p.x + p.y * p.y <= h.x * h.x && p.z.abs() <= h.z,
            KernelShape::SphericalCone {
                width,
                height,
                thickness,
            } => {
                let r = 0.5 * width;
                let y = p.y + h.y; // tip at 0
                let cone = height - r;
                let rho = (p.x * p.x + (p.z * width / thickness).powi(2)).sqrt();
                if !(0.0..=height).contains(&y) {
                    return false;
                }
                let limit = if y <= cone {
                    r * y / cone
                } else {
                    (r * r - (y - cone).powi(2)).max(0.0).sqrt()
                };
                rho <= limit
            }
            KernelShape::NearSpherical { .. } => (p / h).length_squared() <= 1.0,
        }
    }

    /// Volume of the target solid.
    pub fn volume(&self) -> f64 {
        match *self {
            KernelShape::HorseTooth {
                upper_width,
                lower_width,
                height,
                upper_thickness,
                lower_thickness,
            } => {
                let (dw, dt) = (upper_width - lower_width, upper_thickness - lower_thickness);
                height
                    * (lower_width * lower_thickness
                        + 0.5 * (lower_width * dt + lower_thickness * dw)
                        + dw * dt / 3.0)
            }
            KernelShape::Flat {
                diameter,
                thickness,
            } => PI * 0.25 * diameter * diameter * thickness,
            KernelShape::SphericalCone {
                width,
                height,
                thickness,
            } => {
                let r = 0.5 * width;
                (thickness / width) * (2.0 / 3.0 * PI * r.powi(3) + PI * r * r * (height - r) / 3.0)
            }
            KernelShape::NearSpherical {
                width,
                height,
                thickness,
            } => PI / 6.0 * width * height * thickness,
        }
    }

    /// Fits `spheres` inscribed spheres (see the module notes).
    pub fn fit(&self, spheres: usize) -> Result<KernelFit, String> {
        self.validate()?;
        if spheres == 0 {
            return Err("expected at least one sphere".into());
        }
        // Refused before the fit: a count past any clump's (1e18) took seconds to refuse.
        if spheres > crate::clump::MAX_CLUMP_SPHERES {
            return Err(format!(
                "count = {spheres}: a clump holds at most {} spheres",
                crate::clump::MAX_CLUMP_SPHERES
            ));
        }
        let h = self.half_extents();
        // Sample grid: ~48 cells along the longest side.
        let step = 2.0 * h.max_element() / 48.0;
        let counts = (2.0 * h / step).ceil().as_ivec3() + 2;
        let origin = -h - DVec3::splat(step);
        let at = |i: i32, j: i32, k: i32| {
            origin + DVec3::new(i as f64 + 0.5, j as f64 + 0.5, k as f64 + 0.5) * step
        };
        let mut interior = Vec::new();
        let mut boundary = Vec::new();
        let inside = |i: i32, j: i32, k: i32| self.inside(at(i, j, k));
        for k in 0..counts.z {
            for j in 0..counts.y {
                for i in 0..counts.x {
                    if inside(i, j, k) {
                        interior.push(at(i, j, k));
                    } else if [
                        (1, 0, 0),
                        (-1, 0, 0),
                        (0, 1, 0),
                        (0, -1, 0),
                        (0, 0, 1),
                        (0, 0, -1),
                    ]
                    .iter()
                    .any(|(a, b, c)| inside(i + a, j + b, k + c))
                    {
                        // An outside point next to the solid: distance to it bounds a sphere.
                        boundary.push(at(i, j, k));
                    }
                }
            }
        }
        // Candidate centres in the mid-plane z = 0, finer than the sample grid.
        let fine = 0.5 * step;
        let mut candidates: Vec<(DVec3, f64)> = Vec::new();
        let nx = (h.x / fine).floor() as i32;
        let ny = (h.y / fine).floor() as i32;
        for j in -ny..=ny {
            for i in -nx..=nx {
                let c = DVec3::new(i as f64 * fine, j as f64 * fine, 0.0);
                if !self.inside(c) {
                    continue;
                }
                // The nearest outside sample lies at most half a cell beyond the surface.
                let d = boundary
                    .iter()
                    .map(|b| (*b - c).length())
                    .fold(f64::INFINITY, f64::min);
                let r = d - 0.5 * step;
                if r > 0.05 * h.min_element() {
                    candidates.push((c, r));
                }
            }
        }
        if candidates.is_empty() {
            return Err("the shape is too thin to hold a sphere".into());
        }
        // Tiny spheres in the corners would add little volume but set the time step (it scales
        // with the smallest radius), so none below half the largest.
        let largest = candidates.iter().map(|c| c.1).fold(0.0, f64::max);
        candidates.retain(|c| c.1 >= 0.5 * largest);
        let covers: Vec<Vec<u32>> = candidates
            .iter()
            .map(|(c, r)| {
                interior
                    .iter()
                    .enumerate()
                    .filter(|(_, p)| (**p - *c).length_squared() <= r * r)
                    .map(|(k, _)| k as u32)
                    .collect()
            })
            .collect();
        let mut covered = vec![false; interior.len()];
        let mut chosen: Vec<(DVec3, f64)> = Vec::new();
        for _ in 0..spheres {
            let (best, gain) = covers
                .iter()
                .enumerate()
                .map(|(k, c)| (k, c.iter().filter(|&&p| !covered[p as usize]).count()))
                .max_by(|a, b| a.1.cmp(&b.1).then(b.0.cmp(&a.0)))
                .unwrap();
            if gain == 0 {
                break; // Everything a sphere can reach is covered; more spheres add nothing.
            }
            for &p in &covers[best] {
                covered[p as usize] = true;
            }
            chosen.push(candidates[best]);
        }
        // Fewer than asked means the rest would cover nothing: say so rather than hand back a
        // clump other than the one the file describes.
        if chosen.len() < spheres {
            return Err(format!(
                "count = {spheres}: at most {} spheres add volume to this kernel (every point a sphere can reach is covered by then); give count <= {}",
                chosen.len(),
                chosen.len()
            ));
        }
        let template = ClumpTemplate::new(chosen)?;
        let props = template.mass_properties();
        let target = self.volume();
        Ok(KernelFit {
            volume_error: props.volume / target - 1.0,
            target_volume: target,
            clump_volume: props.volume,
            template,
        })
    }
}

/// A fitted kernel clump and how well it matches its target solid.
#[derive(Clone, Debug)]
pub struct KernelFit {
    pub template: ClumpTemplate,
    pub target_volume: f64,
    pub clump_volume: f64,
    /// clump_volume / target_volume - 1 (negative: the clump is smaller).
    pub volume_error: f64,
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid_volume(shape: &KernelShape) -> f64 {
        let h = shape.half_extents();
        let n = 120;
        let cell = 2.0 * h / n as f64;
        let mut inside = 0;
        for k in 0..n {
            for j in 0..n {
                for i in 0..n {
                    let p = -h + (DVec3::new(i as f64, j as f64, k as f64) + 0.5) * cell;
                    inside += shape.inside(p) as usize;
                }
            }
        }
        inside as f64 * cell.x * cell.y * cell.z
    }

    #[test]
    fn target_volumes_match_their_inside_tests() {
        for kind in KernelShape::KINDS {
            let s = KernelShape::published(kind).unwrap();
            assert_eq!(s.class(), kind);
            let (analytic, counted) = (s.volume(), grid_volume(&s));
            assert!(
                (counted / analytic - 1.0).abs() < 0.01,
                "{kind}: {analytic:e} vs {counted:e}"
            );
        }
    }

    /// More spheres than can add volume is refused with the most that can, where it used to
    /// give a clump of that many without a word.
    #[test]
    fn a_count_past_what_adds_volume_is_refused_with_the_most_that_does() {
        let s = KernelShape::published("flat").unwrap();
        let e = s.fit(5_000).unwrap_err();
        let most: usize = e
            .split("at most ")
            .nth(1)
            .and_then(|t| t.split(' ').next())
            .and_then(|n| n.parse().ok())
            .unwrap_or_else(|| panic!("{e}"));
        assert!(e.starts_with("count = 5000: at most "), "{e}");
        assert_eq!(s.fit(most).unwrap().template.spheres.len(), most);
        assert!(s.fit(most + 1).is_err());
        // Past any clump's size it is refused before the fit.
        let e = s.fit(usize::MAX).unwrap_err();
        assert!(e.contains("a clump holds at most 10000 spheres"), "{e}");
    }

    #[test]
    fn spheres_stay_inside_and_error_shrinks_with_count() {
        for kind in KernelShape::KINDS {
            let s = KernelShape::published(kind).unwrap();
            let few = s.fit(3).unwrap();
            let many = s.fit(12).unwrap();
            assert!(few.volume_error < 0.0 && many.volume_error < 0.0, "{kind}");
            assert!(
                many.volume_error > few.volume_error,
                "{kind}: {} vs {}",
                many.volume_error,
                few.volume_error
            );
            // Spheres cannot fill a box's edges: 12 leave 29 % of the wedge and 27 % of the disc
            // empty, 15 % of the cone and 10 % of the ellipsoid.
            assert!(many.volume_error > -0.30, "{kind}: {}", many.volume_error);
            // Inscribed: every sphere's surface stays within the solid, to the half sample cell the
            // surface is known to.
            let half_cell = s.half_extents().max_element() / 48.0;
            for (c, r) in &many.template.spheres {
                for d in [
                    DVec3::X,
                    DVec3::NEG_X,
                    DVec3::Y,
                    DVec3::NEG_Y,
                    DVec3::Z,
                    DVec3::NEG_Z,
                ] {
                    assert!(s.inside(*c + d * (*r - half_cell)), "{kind}");
                }
            }
        }
    }
}
