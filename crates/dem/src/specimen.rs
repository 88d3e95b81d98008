//! Stalk specimens: cylinders packed with spheres that a bond model will join.
//!
//! The lab tests of a stalk (shear, radial compression, three-point bending; `docs/lab-tests.md`
//! sections 3-6) model the stalk as a packing of spheres bonded where their contact spheres
//! overlap. This module builds the packing only: where each sphere is, its radius, and whether it
//! lies in the core (pith) or the rind (epidermis). Bonds are someone else's business.
//!
//! Choices:
//!
//! - **Frame.** A specimen is a cylinder of `length` and `diameter` centred at `centre` with its
//!   axis along `axis` (default: x through the origin, lying horizontal as it does in the shear,
//!   compression and bending fixtures). Packings are made in a local frame whose x is the axis and
//!   rotated into place, so a specimen along x is exactly the local packing.
//! - **Every sphere wholly inside.** A centre lies at most `diameter / 2 - r` from the axis and at
//!   least `r` from each end face, so a platen or blade touching the specimen's outline touches
//!   spheres, not space.
//! - **Hexagonal close packing** (`Packing::Hcp`) places equal spheres on
//!   [`fill::lattice_points`] with the lattice anchored at the specimen's centre (a site on the
//!   axis, so the cross-section is symmetric about it) and its close-packed layers stacked along
//!   the local z, that is, containing the stalk's axis. Spacing defaults to one diameter, the
//!   spheres touching: docs/lab-tests.md section 3's shear specimen (20 mm long, 15 mm across,
//!   0.43 mm spheres) then holds 6 725 spheres with 37 186 pairs within the 0.6 mm contact
//!   radius. EDEM's 4 235 spheres are as sparse as a spacing of 1 mm (4 313 here; 4 217 with the
//!   layers across the axis), and its 18 980 bonds (4.5 per sphere, against a lattice's 5.4 at
//!   that spacing) say that its "hcp" is not a perfect lattice; `spacing` is there to match a
//!   published count.
//! - **Random packing** (`Packing::Random`) draws `count` radii from the group's size
//!   distribution, scatters the centres in the cylinder with every radius scaled down (to a
//!   solid fraction of 0.3), and then alternates overlap relaxation with projection back into the
//!   cylinder, growing the radius scale toward 1 by 0.4 % whenever the largest overlap is small.
//!   Relaxation (`packing.rs`, shared with random fills; here on one thread) moves each
//!   overlapping pair apart along its line of centres, half each, to a hair
//!   (0.2 %) beyond touching, so overlaps fall below the tolerance in fewer passes than an exact
//!   target would take. Pairs come from a Verlet list (a cell grid, a skin of a quarter of the
//!   smallest radius, rebuilt when spheres may have moved that far), so a pass is O(N); pairs are
//!   visited in the grid's order and each move is seen by the next pair, which halves the passes
//!   near jamming, and the order is fixed, so the packing depends on the seed alone. It stops
//!   when the scale is 1 and the largest overlap is below [`RANDOM_OVERLAP_TOLERANCE`] of the
//!   smaller radius, checked over all pairs. No DEM run is needed. The count sets the solid
//!   fraction and so how many spheres touch: the spheres are as dense as the count makes them,
//!   and only a fraction near jamming (0.55-0.6 for two sizes in a stalk a few large spheres
//!   across) gives a connected specimen with about 6-7 neighbours each. A solid fraction above
//!   [`MAX_RANDOM_SOLID_FRACTION`] is refused before anything is placed; one that jams before
//!   the scale reaches 1 is reported with the fraction it reached. docs/lab-tests.md section 4's
//!   3 534 spheres of 1.5 mm would fill 125 % of their stalk, so "bimodal" needs a second, smaller
//!   class: 0.75 mm (half the radius, so the small spheres sit in the large ones' voids) with
//!   40.6 % large by number gives a solid fraction of 0.60 in about 1.5 s.
//! - **Hollow and core.** No sphere has its centre within `hollow_diameter / 2` of the axis (a
//!   hollow stalk); spheres whose centre lies within `core_diameter / 2` of the axis are core
//!   (pith) spheres, the others rind (epidermis): the scene gives them the core material.

use crate::fill::{self, FillRegion, Lattice, SizeDistribution};
use crate::packing::{Bodies, Grid, Relaxation};
use glam::{DQuat, DVec3};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use std::f64::consts::PI;

/// The largest overlap a random packing ends with, as a fraction of the smaller radius of the
/// pair (half the default `max_initial_overlap` of a scene).
pub const RANDOM_OVERLAP_TOLERANCE: f64 = 0.005;

/// The largest solid fraction (sphere volume over the stalk's volume) a random packing tries:
/// random close packing of spheres is about 0.64, a little more with two sizes, less against a
/// curved wall.
pub const MAX_RANDOM_SOLID_FRACTION: f64 = 0.66;

/// A cylindrical stalk specimen (plain data; [`StalkSpecimen::build`] checks and packs it).
#[derive(Clone, Debug, PartialEq)]
pub struct StalkSpecimen {
    /// m, end face to end face.
    pub length: f64,
    /// m, outer diameter.
    pub diameter: f64,
    pub packing: Packing,
    /// m; no sphere centre lies within it (0: a solid stalk).
    pub hollow_diameter: f64,
    /// Core (pith) spheres and their material; None: all spheres of the group's material.
    pub core: Option<Core>,
    /// The middle of the axis (m); default the origin.
    pub centre: DVec3,
    /// The direction of the axis (need not be a unit vector); default x.
    pub axis: DVec3,
}

/// The core of a stalk: spheres whose centre lies within `diameter / 2` of the axis.
#[derive(Clone, Debug, PartialEq)]
pub struct Core {
    /// The name of the core's material (a scene's `[[material]]`).
    pub material: String,
    /// m.
    pub diameter: f64,
}

/// How the spheres are arranged.
#[derive(Clone, Debug, PartialEq)]
pub enum Packing {
    /// Equal spheres on a hexagonal close-packed lattice; `spacing` is the nearest-neighbour
    /// distance (default one sphere diameter).
    Hcp { spacing: Option<f64> },
    /// `count` spheres with radii from the group's size distribution, packed until they touch;
    /// `seed` draws the radii and the start.
    Random { count: usize, seed: u64 },
}

/// One sphere of a specimen.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpecimenSphere {
    pub position: DVec3,
    pub radius: f64,
    /// Whether its centre lies in the core (within the core diameter).
    pub core: bool,
}

/// A specimen's spheres, with what the packing did.
#[derive(Clone, Debug, PartialEq)]
pub struct Packed {
    pub spheres: Vec<SpecimenSphere>,
    /// Relaxation passes of a random packing (0 for a lattice).
    pub iterations: usize,
    /// The largest overlap as a fraction of the smaller radius of the pair (0 for a lattice at a
    /// spacing of at least one diameter).
    pub largest_overlap: f64,
}

impl Packed {
    /// Sphere volume over the specimen's volume (the hollow left out).
    pub fn solid_fraction(&self, specimen: &StalkSpecimen) -> f64 {
        let v: f64 = self
            .spheres
            .iter()
            .map(|s| 4.0 / 3.0 * PI * s.radius.powi(3))
            .sum();
        v / specimen.volume()
    }
}

/// A bad specimen value: `key` is its name in a scene's placement (`diameter`, `count`), or the
/// empty string for the packing as a whole.
#[derive(Clone, Debug, PartialEq)]
pub struct SpecimenError {
    pub key: &'static str,
    pub message: String,
}

impl std::fmt::Display for SpecimenError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.key.is_empty() {
            write!(f, "{}", self.message)
        } else {
            write!(f, "{}: {}", self.key, self.message)
        }
    }
}

impl std::error::Error for SpecimenError {}

fn err(key: &'static str, message: impl Into<String>) -> SpecimenError {
    SpecimenError {
        key,
        message: message.into(),
    }
}

impl StalkSpecimen {
    /// A solid specimen along x at the origin, hexagonal close packed at one diameter.
    pub fn hcp(length: f64, diameter: f64) -> StalkSpecimen {
        StalkSpecimen {
            length,
            diameter,
            packing: Packing::Hcp { spacing: None },
            hollow_diameter: 0.0,
            core: None,
            centre: DVec3::ZERO,
            axis: DVec3::X,
        }
    }

    /// A solid specimen along x at the origin, `count` spheres packed at random from `seed`.
    pub fn random(length: f64, diameter: f64, count: usize, seed: u64) -> StalkSpecimen {
        StalkSpecimen {
            packing: Packing::Random { count, seed },
            ..StalkSpecimen::hcp(length, diameter)
        }
    }

    /// The specimen's volume less its hollow (m^3).
    pub fn volume(&self) -> f64 {
        PI / 4.0 * (self.diameter.powi(2) - self.hollow_diameter.powi(2)) * self.length
    }

    /// The unit axis, after [`StalkSpecimen::check`].
    fn unit_axis(&self) -> DVec3 {
        self.axis.normalize()
    }

    /// Checks every value against spheres of `sizes` and returns the most spheres the packing
    /// can make, so that a caller can refuse an absurd specimen before anything is allocated.
    pub fn check(&self, sizes: &SizeDistribution) -> Result<f64, SpecimenError> {
        let positive = |v: f64, key: &'static str, what: &str| {
            if v > 0.0 && v.is_finite() {
                Ok(v)
            } else {
                Err(err(key, format!("expected a positive {what}, got {v}")))
            }
        };
        let length = positive(self.length, "length", "length (m)")?;
        let diameter = positive(self.diameter, "diameter", "diameter (m)")?;
        let hollow = self.hollow_diameter;
        if !(hollow >= 0.0 && hollow < diameter) {
            return Err(err(
                "hollow_diameter",
                format!(
                    "expected a diameter >= 0 and below the stalk's {diameter} m, got {hollow}"
                ),
            ));
        }
        if let Some(core) = &self.core {
            let d = core.diameter;
            if !(d > hollow && d <= diameter && d.is_finite()) {
                return Err(err(
                    "core_diameter",
                    format!(
                        "expected a diameter above the hollow ({hollow} m) and at most the stalk's {diameter} m, got {d}"
                    ),
                ));
            }
        }
        if !self.centre.is_finite() {
            return Err(err("centre", "expected a finite point [x, y, z] (m)"));
        }
        if !(self.axis.is_finite() && self.axis.length() > 0.0) {
            return Err(err("axis", "expected a non-zero direction vector"));
        }
        let r_max = sizes.max_radius();
        let wall = 0.5 * (diameter - hollow);
        if !(r_max <= wall && 2.0 * r_max <= length) {
            return Err(err(
                "diameter",
                format!(
                    "spheres of radius up to {r_max} m do not fit in a stalk {length} m long with a wall {wall} m thick; expected a larger stalk or smaller spheres"
                ),
            ));
        }
        match self.packing {
            Packing::Hcp { spacing } => {
                let r = sizes.min_radius();
                if r_max > r * (1.0 + 1e-12) {
                    return Err(err(
                        "packing",
                        format!(
                            "hcp packs equal spheres, and the sizes range from {r} to {r_max} m; expected a fixed radius, or packing = \"random\""
                        ),
                    ));
                }
                let s = spacing.unwrap_or(2.0 * r);
                positive(s, "spacing", "spacing (m)")?;
                if s < 2.0 * r * (1.0 - 1e-9) {
                    return Err(err(
                        "spacing",
                        format!(
                            "spacing {s} is smaller than the sphere diameter {}; spheres would overlap",
                            2.0 * r
                        ),
                    ));
                }
                // sqrt(2) / s^3 sites per volume, over the box around the cylinder grown by a
                // spacing: a bound on what the lattice can place.
                Ok(std::f64::consts::SQRT_2 / s.powi(3) * (length + s) * (diameter + s).powi(2))
            }
            Packing::Random { count, .. } => {
                if count == 0 {
                    return Err(err("count", "expected a count > 0"));
                }
                Ok(count as f64)
            }
        }
    }

    /// Packs the specimen with spheres of `sizes`, refusing one that could make more than
    /// `max_spheres` before allocating.
    pub fn build(
        &self,
        sizes: &SizeDistribution,
        max_spheres: usize,
    ) -> Result<Packed, SpecimenError> {
        let most = self.check(sizes)?;
        if most.is_nan() || most > max_spheres as f64 {
            let key = match self.packing {
                Packing::Hcp { .. } => "spacing",
                Packing::Random { .. } => "count",
            };
            return Err(err(
                key,
                format!("the specimen may take up to {most:.3e} spheres, more than the {max_spheres} allowed"),
            ));
        }
        let rotation = DQuat::from_rotation_arc(DVec3::X, self.unit_axis());
        let half = 0.5 * self.length;
        let outer = 0.5 * self.diameter;
        let inner = 0.5 * self.hollow_diameter;
        let (local, iterations, largest_overlap): (Vec<(DVec3, f64)>, usize, f64) = match self
            .packing
        {
            Packing::Hcp { spacing } => {
                let r = sizes.max_radius();
                let s = spacing.unwrap_or(2.0 * r);
                let region = FillRegion::Cylinder {
                    base: DVec3::new(-half + r, 0.0, 0.0),
                    axis: DVec3::X,
                    radius: outer - r,
                    length: self.length - 2.0 * r,
                };
                let points =
                    fill::lattice_points(&region, Lattice::HexagonalClosePacked, s, DVec3::ZERO);
                let spheres = points
                    .into_iter()
                    .filter(|p| p.y.hypot(p.z) >= inner)
                    // lattice_points keeps centres up to 1e-9 spacing outside its region;
                    // keep every sphere wholly inside.
                    .map(|p| (clamp_into(p, r, half, 0.0, outer), r))
                    .collect();
                (spheres, 0, 0.0)
            }
            Packing::Random { count, seed } => {
                let mut rng = Pcg64::seed_from_u64(seed);
                let radii: Vec<f64> = (0..count).map(|_| sizes.sample(&mut rng)).collect();
                let volume: f64 = radii.iter().map(|r| 4.0 / 3.0 * PI * r.powi(3)).sum();
                let fraction = volume / self.volume();
                if fraction > MAX_RANDOM_SOLID_FRACTION {
                    return Err(err(
                            "count",
                            format!(
                                "{count} spheres of these sizes fill {:.1} % of the stalk's volume; a random packing holds at most {:.0} %; expected fewer or smaller spheres",
                                100.0 * fraction,
                                100.0 * MAX_RANDOM_SOLID_FRACTION
                            ),
                        ));
                }
                let cylinder = Cylinder { half, inner, outer };
                let out = relax(&cylinder, &radii, fraction, &mut rng)?;
                let spheres = out.positions.into_iter().zip(radii).collect();
                (spheres, out.iterations, out.largest_overlap)
            }
        };
        let core = self.core.as_ref().map(|c| 0.5 * c.diameter);
        let spheres = local
            .into_iter()
            .map(|(p, radius)| SpecimenSphere {
                position: self.centre + rotation * p,
                radius,
                core: core.is_some_and(|c| p.y.hypot(p.z) <= c),
            })
            .collect();
        Ok(Packed {
            spheres,
            iterations,
            largest_overlap,
        })
    }
}

/// A sphere at `p` (local frame) of radius `r`, moved the least distance to lie wholly in the
/// cylinder with its centre out of the hollow.
fn clamp_into(p: DVec3, r: f64, half: f64, inner: f64, outer: f64) -> DVec3 {
    let x = p.x.clamp(-half + r, half - r);
    let rho = (p.y * p.y + p.z * p.z).sqrt();
    let (lo, hi) = (inner, (outer - r).max(inner));
    if rho > hi {
        DVec3::new(x, p.y * hi / rho, p.z * hi / rho)
    } else if rho < lo {
        // On the axis there is no nearest way out: any direction will do, the same each time.
        let (cy, cz) = if rho > 0.0 {
            (p.y / rho, p.z / rho)
        } else {
            (1.0, 0.0)
        };
        DVec3::new(x, cy * lo, cz * lo)
    } else {
        DVec3::new(x, p.y, p.z)
    }
}

/// The cylinder of a random packing in the local frame: x along the axis in [-half, half],
/// centres at distances from the axis in [inner, outer - r].
struct Cylinder {
    half: f64,
    inner: f64,
    outer: f64,
}

struct Relaxed {
    positions: Vec<DVec3>,
    iterations: usize,
    largest_overlap: f64,
}

/// The solid fraction a random packing starts from (radii scaled down to it): loose enough that
/// the first passes untangle quickly, dense enough that few growth steps remain.
const START_FRACTION: f64 = 0.3;
/// The relaxation (see the module notes): radius steps of 0.4 %, small enough that a step's new
/// overlaps (about this fraction of a radius) are undone in a few passes; pairs pushed to 0.2 %
/// beyond touching; a skin of a quarter of the smallest radius; jammed after 4 000 passes without
/// progress; one thread.
const RELAXATION: Relaxation = Relaxation {
    tolerance: RANDOM_OVERLAP_TOLERANCE,
    growth: 0.004,
    stall_passes: 4000,
    aim_beyond: 0.002,
    skin: 0.25,
    slabs: false,
};

/// Overlap relaxation with a growing radius scale (see the module notes and [`crate::packing`])
/// from centres scattered at random in the cylinder.
fn relax(
    cyl: &Cylinder,
    radii: &[f64],
    fraction: f64,
    rng: &mut Pcg64,
) -> Result<Relaxed, SpecimenError> {
    let scale = (START_FRACTION / fraction).cbrt().min(1.0);
    let positions: Vec<DVec3> = radii
        .iter()
        .map(|&r| {
            let r = scale * r;
            let x = (2.0 * rng.gen::<f64>() - 1.0) * (cyl.half - r);
            let (lo, hi) = (cyl.inner, (cyl.outer - r).max(cyl.inner));
            // Uniform over the annulus: the squared distance is uniform.
            let rho = (lo * lo + (hi * hi - lo * lo) * rng.gen::<f64>()).sqrt();
            let theta = 2.0 * PI * rng.gen::<f64>();
            DVec3::new(x, rho * theta.cos(), rho * theta.sin())
        })
        .collect();
    let mut bodies = Bodies::spheres(positions, radii.to_vec());
    let lo = DVec3::new(-cyl.half, -cyl.outer, -cyl.outer);
    let out = RELAXATION.run(&mut bodies, lo, -lo, scale, |p, r| {
        clamp_into(p, r, cyl.half, cyl.inner, cyl.outer)
    });
    if out.done {
        return Ok(Relaxed {
            positions: bodies.position,
            iterations: out.passes,
            largest_overlap: out.largest_overlap,
        });
    }
    let reached = fraction * out.scale.powi(3);
    Err(err(
        "count",
        if out.scale < 1.0 {
            format!(
                "the spheres jam at a solid fraction of {reached:.3} of the stalk, below the {fraction:.3} asked for; expected fewer or smaller spheres"
            )
        } else {
            format!(
                "the spheres at a solid fraction of {fraction:.3} keep overlapping by {:.2} % of a radius (at most {:.2} % wanted); expected fewer or smaller spheres",
                100.0 * out.largest_overlap,
                100.0 * RANDOM_OVERLAP_TOLERANCE
            )
        },
    ))
}

/// The pairs of spheres whose contact spheres overlap: centres closer than
/// `contact_factor * (r_i + r_j)` (a contact radius of `contact_factor` times the radius). For
/// reports and tests; a bond model keeps its own list.
pub fn pairs_within(spheres: &[SpecimenSphere], contact_factor: f64) -> Vec<(usize, usize)> {
    if spheres.is_empty() {
        return Vec::new();
    }
    let (lo, hi) = spheres.iter().fold(
        (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
        |(lo, hi), s| (lo.min(s.position), hi.max(s.position)),
    );
    let r_max = spheres.iter().map(|s| s.radius).fold(0.0, f64::max);
    let reach = 2.0 * contact_factor * r_max;
    let pad = DVec3::splat(reach);
    let centre = 0.5 * (lo + hi);
    // A grid over the box of centres, as the packing's (its cylinder stands in for the box).
    let half_extent = 0.5 * (hi - lo) + pad;
    let mut grid = Grid::new(centre - half_extent, 2.0 * half_extent, spheres.len());
    let positions: Vec<DVec3> = spheres.iter().map(|s| s.position).collect();
    grid.sort(&positions, reach);
    let mut pairs = Vec::new();
    grid.for_each_pair(|i, j| {
        let reach = contact_factor * (spheres[i].radius + spheres[j].radius);
        if (positions[i] - positions[j]).length_squared() < reach * reach {
            pairs.push((i.min(j), i.max(j)));
        }
    });
    pairs.sort_unstable();
    pairs
}
