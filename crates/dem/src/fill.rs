//! Creating particles: size distributions, regions and lattice fills (random fills of mixtures are
//! in [`crate::random_fill`]).

use glam::DVec3;
use rand::Rng;
use rand_pcg::Pcg64;
use std::f64::consts::PI;

/// Particle radius distribution.
#[derive(Clone, Debug, PartialEq)]
pub enum SizeDistribution {
    Fixed {
        radius: f64,
    },
    Uniform {
        min: f64,
        max: f64,
    },
    /// Normal in radius, truncated to [min, max] (default mean +/- 3 std).
    TruncatedNormal {
        mean: f64,
        std: f64,
        min: f64,
        max: f64,
    },
    /// Discrete classes; `fractions` are by number, or by mass when `by_mass` (same density).
    Classes {
        radii: Vec<f64>,
        fractions: Vec<f64>,
        by_mass: bool,
    },
}

impl SizeDistribution {
    pub fn sample(&self, rng: &mut Pcg64) -> f64 {
        match self {
            SizeDistribution::Fixed { radius } => *radius,
            SizeDistribution::Uniform { min, max } => min + (max - min) * rng.gen::<f64>(),
            SizeDistribution::TruncatedNormal {
                mean,
                std,
                min,
                max,
            } => loop {
                // Box-Muller; rejection keeps the truncated shape exact.
                let u1: f64 = 1.0 - rng.gen::<f64>();
                let u2: f64 = rng.gen();
                let z = (-2.0 * u1.ln()).sqrt() * (2.0 * PI * u2).cos();
                let r = mean + std * z;
                if r >= *min && r <= *max {
                    break r;
                }
            },
            SizeDistribution::Classes {
                radii,
                fractions,
                by_mass,
            } => {
                let weights: Vec<f64> = radii
                    .iter()
                    .zip(fractions)
                    .map(|(r, f)| if *by_mass { f / r.powi(3) } else { *f })
                    .collect();
                let total: f64 = weights.iter().sum();
                let mut u = rng.gen::<f64>() * total;
                for (r, w) in radii.iter().zip(&weights) {
                    if u < *w {
                        return *r;
                    }
                    u -= w;
                }
                *radii.last().unwrap()
            }
        }
    }

    pub fn min_radius(&self) -> f64 {
        match self {
            SizeDistribution::Fixed { radius } => *radius,
            SizeDistribution::Uniform { min, .. }
            | SizeDistribution::TruncatedNormal { min, .. } => *min,
            SizeDistribution::Classes { radii, .. } => {
                radii.iter().cloned().fold(f64::INFINITY, f64::min)
            }
        }
    }

    pub fn max_radius(&self) -> f64 {
        match self {
            SizeDistribution::Fixed { radius } => *radius,
            SizeDistribution::Uniform { max, .. }
            | SizeDistribution::TruncatedNormal { max, .. } => *max,
            SizeDistribution::Classes { radii, .. } => radii.iter().cloned().fold(0.0, f64::max),
        }
    }
}

/// A region to fill.
#[derive(Clone, Debug, PartialEq)]
pub enum FillRegion {
    Box {
        min: DVec3,
        max: DVec3,
    },
    /// Solid cylinder from `base` along unit `axis`.
    Cylinder {
        base: DVec3,
        axis: DVec3,
        radius: f64,
        length: f64,
    },
}

impl FillRegion {
    /// True when a sphere of radius `r` at `x` lies inside (use r = 0 for "centre inside").
    pub fn contains(&self, x: DVec3, r: f64) -> bool {
        match *self {
            FillRegion::Box { min, max } => {
                x.cmpge(min + DVec3::splat(r)).all() && x.cmple(max - DVec3::splat(r)).all()
            }
            FillRegion::Cylinder {
                base,
                axis,
                radius,
                length,
            } => {
                let rel = x - base;
                let h = rel.dot(axis);
                let rho = (rel - h * axis).length();
                h >= r && h <= length - r && rho <= radius - r
            }
        }
    }

    pub fn bounds(&self) -> (DVec3, DVec3) {
        match *self {
            FillRegion::Box { min, max } => (min, max),
            FillRegion::Cylinder {
                base,
                axis,
                radius,
                length,
            } => {
                let top = base + axis * length;
                let ext = crate::geometry::disc_extent(axis, radius);
                (base.min(top) - ext, base.max(top) + ext)
            }
        }
    }

    /// The nearest place to `x` for the centre of a sphere of radius `r` inside (`x` itself when
    /// the sphere is inside). The region must be at least `2 r` wide ([`Self::smallest_width`]).
    pub fn clamp(&self, x: DVec3, r: f64) -> DVec3 {
        if self.contains(x, r) {
            return x;
        }
        match *self {
            FillRegion::Box { min, max } => x.clamp(min + DVec3::splat(r), max - DVec3::splat(r)),
            FillRegion::Cylinder {
                base,
                axis,
                radius,
                length,
            } => {
                let rel = x - base;
                let h = rel.dot(axis);
                let radial = rel - h * axis;
                let rho = radial.length();
                let reach = radius - r;
                let radial = if rho > reach {
                    radial * (reach / rho)
                } else {
                    radial
                };
                base + h.clamp(r, length - r) * axis + radial
            }
        }
    }

    /// The smallest width across: the box's shortest side, or the cylinder's diameter or length.
    pub fn smallest_width(&self) -> f64 {
        match *self {
            FillRegion::Box { min, max } => (max - min).min_element(),
            FillRegion::Cylinder { radius, length, .. } => (2.0 * radius).min(length),
        }
    }

    pub fn volume(&self) -> f64 {
        match *self {
            FillRegion::Box { min, max } => (max - min).element_product(),
            FillRegion::Cylinder { radius, length, .. } => PI * radius * radius * length,
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Lattice {
    SimpleCubic,
    HexagonalClosePacked,
}

/// Lattice points (centres) inside `region`. The lattice is anchored at `origin`; `spacing` is the
/// nearest-neighbour distance. Points are those whose centre lies inside the region, as LIGGGHTS'
/// `create_atoms region` does, so shrink the region by the radius to keep spheres inside walls.
pub fn lattice_points(
    region: &FillRegion,
    lattice: Lattice,
    spacing: f64,
    origin: DVec3,
) -> Vec<DVec3> {
    let (lo, hi) = region.bounds();
    let mut out = Vec::new();
    let eps = 1e-9 * spacing;
    match lattice {
        Lattice::SimpleCubic => {
            let k0 = ((lo - origin) / spacing - DVec3::splat(1e-9)).ceil();
            let k1 = ((hi - origin) / spacing + DVec3::splat(1e-9)).floor();
            for z in k0.z as i64..=k1.z as i64 {
                for y in k0.y as i64..=k1.y as i64 {
                    for x in k0.x as i64..=k1.x as i64 {
                        let p = origin + DVec3::new(x as f64, y as f64, z as f64) * spacing;
                        if region.contains(p, -eps) {
                            out.push(p);
                        }
                    }
                }
            }
        }
        Lattice::HexagonalClosePacked => {
            let dy = spacing * 3f64.sqrt() / 2.0;
            let dz = spacing * (2.0f64 / 3.0).sqrt();
            let z0 = ((lo.z - origin.z) / dz).ceil() as i64 - 1;
            let z1 = ((hi.z - origin.z) / dz).floor() as i64 + 1;
            let y0 = ((lo.y - origin.y) / dy).floor() as i64 - 2;
            let y1 = ((hi.y - origin.y) / dy).ceil() as i64 + 2;
            let x0 = ((lo.x - origin.x) / spacing).floor() as i64 - 2;
            let x1 = ((hi.x - origin.x) / spacing).ceil() as i64 + 2;
            for z in z0..=z1 {
                // ABAB stacking: B layers shift by (a/2, a sqrt(3)/6).
                let (sx, sy) = if z.rem_euclid(2) == 1 {
                    (0.5 * spacing, spacing * 3f64.sqrt() / 6.0)
                } else {
                    (0.0, 0.0)
                };
                for y in y0..=y1 {
                    let row = if y.rem_euclid(2) == 1 {
                        0.5 * spacing
                    } else {
                        0.0
                    };
                    for x in x0..=x1 {
                        let p = origin
                            + DVec3::new(
                                x as f64 * spacing + row + sx,
                                y as f64 * dy + sy,
                                z as f64 * dz,
                            );
                        if region.contains(p, -eps) {
                            out.push(p);
                        }
                    }
                }
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    #[test]
    fn settle_lattice_has_21160_points() {
        let region = FillRegion::Box {
            min: DVec3::new(0.002, 0.002, 0.002),
            max: DVec3::new(0.098, 0.098, 0.17),
        };
        let pts = lattice_points(&region, Lattice::SimpleCubic, 0.0042, DVec3::ZERO);
        assert_eq!(pts.len(), 21160);
    }

    #[test]
    fn hcp_nearest_neighbours_at_spacing() {
        let region = FillRegion::Box {
            min: DVec3::ZERO,
            max: DVec3::splat(0.01),
        };
        let a = 0.001;
        let pts = lattice_points(&region, Lattice::HexagonalClosePacked, a, DVec3::ZERO);
        let mut min_d = f64::INFINITY;
        let mut twelve = 0;
        for (k, p) in pts.iter().enumerate() {
            let mut near = 0;
            for (l, q) in pts.iter().enumerate() {
                if k != l {
                    let d = (*p - *q).length();
                    min_d = min_d.min(d);
                    if d < a * 1.001 {
                        near += 1;
                    }
                }
            }
            if near == 12 {
                twelve += 1;
            }
        }
        assert!((min_d - a).abs() < 1e-12);
        assert!(
            twelve > 100,
            "interior points have 12 neighbours ({twelve})"
        );
        // Number density of HCP is sqrt(2) / a^3 (solid fraction pi / (3 sqrt 2) = 0.7405); count
        // away from the region boundary.
        let inner = pts
            .iter()
            .filter(|p| p.cmpge(DVec3::splat(0.002)).all() && p.cmplt(DVec3::splat(0.008)).all())
            .count() as f64;
        let expected = 2f64.sqrt() / (a * a * a) * 0.006f64.powi(3);
        assert!(
            (inner / expected - 1.0).abs() < 0.05,
            "{inner} vs {expected}"
        );
    }

    #[test]
    fn classes_by_mass_fraction() {
        let sizes = SizeDistribution::Classes {
            radii: vec![0.001, 0.002],
            fractions: vec![0.5, 0.5],
            by_mass: true,
        };
        let mut rng = Pcg64::seed_from_u64(1);
        let (mut m1, mut m2) = (0.0, 0.0);
        for _ in 0..200_000 {
            let r = sizes.sample(&mut rng);
            if r < 0.0015 {
                m1 += r.powi(3)
            } else {
                m2 += r.powi(3)
            }
        }
        assert!((m1 / (m1 + m2) - 0.5).abs() < 0.01, "{}", m1 / (m1 + m2));
    }

    #[test]
    fn truncated_normal_stays_in_bounds_with_right_mean() {
        let sizes = SizeDistribution::TruncatedNormal {
            mean: 0.002,
            std: 0.0002,
            min: 0.0016,
            max: 0.0024,
        };
        let mut rng = Pcg64::seed_from_u64(3);
        let xs: Vec<f64> = (0..100_000).map(|_| sizes.sample(&mut rng)).collect();
        assert!(xs.iter().all(|&r| (0.0016..=0.0024).contains(&r)));
        let mean = xs.iter().sum::<f64>() / xs.len() as f64;
        assert!((mean - 0.002).abs() < 2e-6);
    }
}
