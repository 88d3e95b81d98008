//! Particle types and mixtures, and placing them without overlap.
//!
//! A [`ParticleType`] is a material with a shape: a sphere whose radius follows a size
//! distribution, or a clump template scaled by a factor that follows one (EDEM's "scale"). A
//! [`Mixture`] draws types by number or by mass fraction. Draws are not independent: each draw
//! takes the type furthest below its share so far, so that 500 particles of a 13.86 / 47.53 /
//! 38.61 % mixture hold those shares to within one particle, which random draws would not.
//!
//! Random fills of a mixture are in [`crate::random_fill`] ([`fill_region`]): each member sphere
//! of a candidate (random position, random orientation) is tested against the spheres already
//! there, so long rods pack as densely as their shape allows rather than as their bounding spheres
//! would.

use crate::clump::{ClumpTemplate, MassProperties};
use crate::fill::SizeDistribution;
pub use crate::random_fill::fill_region;
use glam::{DQuat, DVec3};
use rand::Rng;
use rand_pcg::Pcg64;
use std::f64::consts::PI;

/// A sphere, a rigid clump of spheres, or a convex polyhedron.
#[derive(Clone, Debug)]
pub enum Shape {
    Sphere,
    /// A convex polyhedron at scale 1 (in its principal frame); placed as its bounding sphere.
    Polyhedron {
        polyhedron: std::sync::Arc<crate::polyhedron::ConvexPolyhedron>,
    },
    Clump {
        template: ClumpTemplate,
        props: MassProperties,
        /// Member centres relative to the centre of mass in the principal frame, and radii, at scale 1.
        members: Vec<(DVec3, f64)>,
    },
}

#[derive(Clone, Debug)]
pub struct ParticleType {
    pub name: String,
    pub material: usize,
    pub density: f64,
    pub shape: Shape,
    /// Radius for a sphere, scale factor for a clump.
    pub size: SizeDistribution,
}

impl ParticleType {
    pub fn sphere(name: &str, material: usize, density: f64, size: SizeDistribution) -> Self {
        ParticleType {
            name: name.into(),
            material,
            density,
            shape: Shape::Sphere,
            size,
        }
    }

    pub fn clump(
        name: &str,
        material: usize,
        density: f64,
        template: ClumpTemplate,
        scale: SizeDistribution,
    ) -> Self {
        let props = template.mass_properties();
        let to_body = props.axes.transpose();
        let members = template
            .spheres
            .iter()
            .map(|(c, r)| (to_body * (*c - props.centroid), *r))
            .collect();
        ParticleType {
            name: name.into(),
            material,
            density,
            shape: Shape::Clump {
                template,
                props,
                members,
            },
            size: scale,
        }
    }

    /// A convex polyhedron scaled by a factor that follows `scale`.
    pub fn polyhedron(
        name: &str,
        material: usize,
        density: f64,
        polyhedron: crate::polyhedron::ConvexPolyhedron,
        scale: SizeDistribution,
    ) -> Self {
        ParticleType {
            name: name.into(),
            material,
            density,
            shape: Shape::Polyhedron {
                polyhedron: std::sync::Arc::new(polyhedron),
            },
            size: scale,
        }
    }

    /// Mass of one particle drawn with size value `s`.
    pub fn mass(&self, s: f64) -> f64 {
        match &self.shape {
            Shape::Sphere => self.density * 4.0 / 3.0 * PI * s.powi(3),
            Shape::Clump { props, .. } => self.density * props.volume * s.powi(3),
            Shape::Polyhedron { polyhedron } => self.density * polyhedron.volume * s.powi(3),
        }
    }

    fn member_radius_range(&self) -> (f64, f64) {
        match &self.shape {
            Shape::Sphere => (1.0, 1.0),
            // Half the thinnest width bounds the contact stiffness' length scale (time step);
            // the bounding radius is what the neighbour search sees.
            Shape::Polyhedron { polyhedron } => {
                (0.5 * polyhedron.min_width, polyhedron.bounding_radius)
            }
            Shape::Clump { members, .. } => members
                .iter()
                .fold((f64::INFINITY, 0.0), |(lo, hi), (_, r)| {
                    (lo.min(*r), hi.max(*r))
                }),
        }
    }

    /// Smallest sphere radius this type can produce (for the time step).
    pub fn min_sphere_radius(&self) -> f64 {
        self.member_radius_range().0 * self.size.min_radius()
    }

    /// Largest sphere radius this type can produce (for neighbour search).
    pub fn max_sphere_radius(&self) -> f64 {
        self.member_radius_range().1 * self.size.max_radius()
    }

    /// Radius of the sphere about the centre of mass that holds the largest particle.
    pub fn bounding_radius(&self) -> f64 {
        let unit = match &self.shape {
            Shape::Sphere => 1.0,
            Shape::Polyhedron { polyhedron } => polyhedron.bounding_radius,
            Shape::Clump { members, .. } => members
                .iter()
                .map(|(c, r)| c.length() + r)
                .fold(0.0, f64::max),
        };
        unit * self.size.max_radius()
    }

    /// The member spheres of one particle (world centres and radii).
    pub fn spheres(&self, item: &Item, out: &mut Vec<(DVec3, f64)>) {
        out.clear();
        match &self.shape {
            Shape::Sphere => out.push((item.position, item.size)),
            Shape::Polyhedron { polyhedron } => {
                out.push((item.position, polyhedron.bounding_radius * item.size))
            }
            Shape::Clump { members, .. } => out.extend(members.iter().map(|(c, r)| {
                (
                    item.position + item.orientation * (*c * item.size),
                    r * item.size,
                )
            })),
        }
    }

    /// The clump template and mass properties at scale `s` (None for a sphere).
    pub fn scaled_clump(&self, s: f64) -> Option<(ClumpTemplate, MassProperties)> {
        match &self.shape {
            Shape::Sphere | Shape::Polyhedron { .. } => None,
            Shape::Clump {
                template, props, ..
            } => {
                let t = ClumpTemplate {
                    spheres: template
                        .spheres
                        .iter()
                        .map(|(c, r)| (*c * s, r * s))
                        .collect(),
                };
                let p = MassProperties {
                    volume: props.volume * s.powi(3),
                    centroid: props.centroid * s,
                    principal_inertia: props.principal_inertia * s.powi(5),
                    ..*props
                };
                Some((t, p))
            }
        }
    }
}

/// One particle to create: its type, size value (radius or scale), position and orientation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Item {
    pub kind: usize,
    pub size: f64,
    pub position: DVec3,
    pub orientation: DQuat,
}

/// How much to generate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FillTarget {
    Count(usize),
    /// Total mass in kg.
    Mass(f64),
}

/// Types with their shares, by number or by mass.
#[derive(Clone, Debug)]
pub struct Mixture {
    pub types: Vec<ParticleType>,
    pub fractions: Vec<f64>,
    pub by_mass: bool,
}

/// Running totals of a mixture's draws.
#[derive(Clone, Debug, Default)]
pub struct Drawn {
    pub count: usize,
    pub mass: f64,
    per_type: Vec<f64>,
}

impl Mixture {
    pub fn single(t: ParticleType) -> Mixture {
        Mixture {
            types: vec![t],
            fractions: vec![1.0],
            by_mass: false,
        }
    }

    /// Draws the next particle's type and size (position and orientation unset).
    pub fn draw(&self, drawn: &mut Drawn, rng: &mut Pcg64) -> Item {
        drawn.per_type.resize(self.types.len(), 0.0);
        let kind = furthest_below_share(&drawn.per_type, &self.fractions);
        let t = &self.types[kind];
        let size = t.size.sample(rng);
        let mass = t.mass(size);
        drawn.per_type[kind] += if self.by_mass { mass } else { 1.0 };
        drawn.count += 1;
        drawn.mass += mass;
        Item {
            kind,
            size,
            position: DVec3::ZERO,
            orientation: random_orientation(rng),
        }
    }

    /// Draws particles until the target is met.
    pub fn draw_all(&self, target: FillTarget, rng: &mut Pcg64) -> Result<Vec<Item>, String> {
        let mut drawn = Drawn::default();
        let mut items = Vec::new();
        loop {
            let done = match target {
                FillTarget::Count(n) => drawn.count >= n,
                FillTarget::Mass(m) => drawn.mass >= m,
            };
            if done {
                return Ok(items);
            }
            if items.len() >= 50_000_000 {
                return Err("the target needs more than 50 million particles".into());
            }
            items.push(self.draw(&mut drawn, rng));
        }
    }

    pub fn min_sphere_radius(&self) -> f64 {
        self.types
            .iter()
            .map(|t| t.min_sphere_radius())
            .fold(f64::INFINITY, f64::min)
    }

    pub fn max_sphere_radius(&self) -> f64 {
        self.types
            .iter()
            .map(|t| t.max_sphere_radius())
            .fold(0.0, f64::max)
    }

    pub fn bounding_radius(&self) -> f64 {
        self.types
            .iter()
            .map(|t| t.bounding_radius())
            .fold(0.0, f64::max)
    }
}

/// The type whose amount so far is furthest below its share of the total (the first on ties;
/// types with a zero fraction are never picked). Fractions need not sum to one.
pub fn furthest_below_share(so_far: &[f64], fractions: &[f64]) -> usize {
    let total: f64 = so_far.iter().sum();
    let norm: f64 = fractions.iter().sum();
    (0..fractions.len())
        .filter(|&k| fractions[k] > 0.0)
        .min_by(|&a, &b| {
            let excess = |k: usize| so_far[k] - fractions[k] / norm * total;
            excess(a).total_cmp(&excess(b))
        })
        .unwrap_or(0)
}

/// Uniformly distributed rotation (Shoemake's method).
pub fn random_orientation(rng: &mut Pcg64) -> DQuat {
    let (u1, u2, u3): (f64, f64, f64) = (rng.gen(), rng.gen(), rng.gen());
    let (a, b) = ((1.0 - u1).sqrt(), u1.sqrt());
    let (t2, t3) = (2.0 * PI * u2, 2.0 * PI * u3);
    DQuat::from_xyzw(a * t2.sin(), a * t2.cos(), b * t3.sin(), b * t3.cos()).normalize()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fill::FillRegion;
    use rand::SeedableRng;

    fn bead(size: SizeDistribution) -> Mixture {
        Mixture::single(ParticleType::sphere("bead", 0, 1200.0, size))
    }

    #[test]
    fn sphere_fill_is_seeded_and_overlap_free() {
        let region = FillRegion::Cylinder {
            base: DVec3::ZERO,
            axis: DVec3::Z,
            radius: 0.02,
            length: 0.04,
        };
        let m = bead(SizeDistribution::Uniform {
            min: 0.001,
            max: 0.0015,
        });
        let a = fill_region(&region, &m, FillTarget::Count(500), 7, &[]).unwrap();
        let b = fill_region(&region, &m, FillTarget::Count(500), 7, &[]).unwrap();
        assert_eq!(a, b);
        assert_eq!(a.len(), 500);
        for (k, x) in a.iter().enumerate() {
            assert!(region.contains(x.position, x.size));
            for y in &a[k + 1..] {
                assert!((x.position - y.position).length() >= x.size + y.size);
            }
        }
    }

    #[test]
    fn fill_to_a_target_mass() {
        let region = FillRegion::Box {
            min: DVec3::ZERO,
            max: DVec3::splat(0.05),
        };
        let m = bead(SizeDistribution::Fixed { radius: 0.002 });
        let placed = fill_region(&region, &m, FillTarget::Mass(0.02), 1, &[]).unwrap();
        let one = 1200.0 * 4.0 / 3.0 * PI * 0.002f64.powi(3);
        let total = placed.len() as f64 * one;
        assert!(total >= 0.02 && total < 0.02 + one, "{total}");
    }

    fn rods() -> Mixture {
        let rod = |name: &str, l: f64, n: usize| {
            ParticleType::clump(
                name,
                0,
                1000.0,
                ClumpTemplate::rod(l, 0.005, n).unwrap(),
                SizeDistribution::Fixed { radius: 1.0 },
            )
        };
        Mixture {
            types: vec![
                rod("long", 0.025, 6),
                rod("medium", 0.013, 3),
                rod("short", 0.006, 2),
            ],
            fractions: vec![0.1386, 0.4753, 0.3861],
            by_mass: true,
        }
    }

    #[test]
    fn mass_fractions_hold_to_one_particle() {
        let m = rods();
        let mut rng = Pcg64::seed_from_u64(3);
        let items = m.draw_all(FillTarget::Mass(0.2), &mut rng).unwrap();
        let mut per = [0.0; 3];
        for it in &items {
            per[it.kind] += m.types[it.kind].mass(it.size);
        }
        let total: f64 = per.iter().sum();
        let largest = m.types[0].mass(1.0);
        for (k, (got, share)) in per.iter().zip(&m.fractions).enumerate() {
            assert!(
                (got - share * total).abs() <= largest,
                "type {k}: {got} of {total}"
            );
        }
        // By number: 30 % / 70 %.
        let by_number = Mixture {
            fractions: vec![0.3, 0.7, 0.0],
            by_mass: false,
            ..m
        };
        let items = by_number
            .draw_all(FillTarget::Count(100), &mut rng)
            .unwrap();
        assert_eq!(items.iter().filter(|i| i.kind == 0).count(), 30);
        assert_eq!(items.iter().filter(|i| i.kind == 1).count(), 70);
    }

    #[test]
    fn clump_members_do_not_overlap_and_stay_inside() {
        let m = rods();
        let region = FillRegion::Cylinder {
            base: DVec3::ZERO,
            axis: DVec3::Z,
            radius: 0.045,
            length: 0.1,
        };
        let items = fill_region(&region, &m, FillTarget::Mass(0.05), 2, &[]).unwrap();
        let mut all = Vec::new();
        let mut members = Vec::new();
        for it in &items {
            m.types[it.kind].spheres(it, &mut members);
            for s in &members {
                assert!(region.contains(s.0, s.1 * (1.0 - 1e-12)));
            }
            all.push(members.clone());
        }
        for a in 0..all.len() {
            for b in a + 1..all.len() {
                for (x, r) in &all[a] {
                    for (y, q) in &all[b] {
                        assert!((*x - *y).length() >= r + q - 1e-12);
                    }
                }
            }
        }
    }

    #[test]
    fn orientations_are_uniform() {
        // The mean of a rotated unit vector over uniform rotations is zero, and each component's
        // square averages to 1/3.
        let mut rng = Pcg64::seed_from_u64(5);
        let n = 100_000;
        let (mut mean, mut sq) = (DVec3::ZERO, DVec3::ZERO);
        for _ in 0..n {
            let v = random_orientation(&mut rng) * DVec3::X;
            mean += v;
            sq += v * v;
        }
        mean /= n as f64;
        sq /= n as f64;
        assert!(mean.length() < 0.01, "{mean}");
        assert!(
            (sq - DVec3::splat(1.0 / 3.0)).abs().max_element() < 0.01,
            "{sq}"
        );
    }
}
