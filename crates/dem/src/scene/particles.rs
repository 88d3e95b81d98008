//! Building particle types, mixtures and placements from their descriptions, with the checks
//! and key names of the scene file.

use super::description::*;
use super::{Ctx, SceneError};
use crate::clump::ClumpTemplate;
use crate::factory::{perpendicular_axes, FactoryShape, Rate};
use crate::fill::{self, FillRegion, Lattice, SizeDistribution};
use crate::mixture::{self, FillTarget, Mixture, ParticleType, Shape};
use crate::polyhedron::{kernels::kernel_polyhedron, ConvexPolyhedron};
use crate::specimen::{Packing, SpecimenSphere, StalkSpecimen};
use crate::sphere_fit::{self, mesh::MeshSolid, FitOptions, SphereFit};
use glam::DVec3;

/// Checks a size (sphere radius) or scale (clump) distribution; `prefix` is its key.
pub(super) fn size(
    ctx: &Ctx,
    prefix: &str,
    s: &SizeDistribution,
) -> Result<SizeDistribution, SceneError> {
    let key = |n: &str| format!("{prefix}.{n}");
    Ok(match s {
        SizeDistribution::Fixed { radius } => SizeDistribution::Fixed {
            radius: ctx.positive(*radius, key("radius"))?,
        },
        SizeDistribution::Uniform { min, max } => {
            let min = ctx.positive(*min, key("min"))?;
            let max = ctx.positive(*max, key("max"))?;
            if max < min {
                return Err(ctx.err(
                    key("max"),
                    format!("expected max >= min ({min}), got {max}"),
                ));
            }
            SizeDistribution::Uniform { min, max }
        }
        &SizeDistribution::TruncatedNormal {
            mean,
            std,
            min,
            max,
        } => {
            ctx.positive(mean, key("mean"))?;
            ctx.non_negative(std, key("std"))?;
            ctx.positive(min, key("min")).map_err(|_| {
                ctx.err(
                    key("min"),
                    format!(
                        "the smallest radius {min} is not positive; give min, or a smaller std"
                    ),
                )
            })?;
            if max < mean || min > mean {
                return Err(ctx.err(key("max"), "expected min <= mean <= max"));
            }
            if std == 0.0 {
                SizeDistribution::Fixed { radius: mean }
            } else {
                SizeDistribution::TruncatedNormal {
                    mean,
                    std,
                    min,
                    max,
                }
            }
        }
        SizeDistribution::Classes {
            radii,
            fractions,
            by_mass,
        } => {
            if radii.is_empty() || radii.len() != fractions.len() {
                return Err(ctx.err(
                    key("fractions"),
                    format!("expected one fraction per radius ({} radii)", radii.len()),
                ));
            }
            for (i, r) in radii.iter().enumerate() {
                ctx.positive(*r, format!("{prefix}.radii[{i}]"))?;
            }
            for (i, f) in fractions.iter().enumerate() {
                ctx.non_negative(*f, format!("{prefix}.fractions[{i}]"))?;
            }
            if fractions.iter().sum::<f64>() <= 0.0 {
                return Err(ctx.err(
                    key("fractions"),
                    "expected fractions that sum to more than zero",
                ));
            }
            SizeDistribution::Classes {
                radii: radii.clone(),
                fractions: fractions.clone(),
                by_mass: *by_mass,
            }
        }
    })
}

/// The clump template of a clump shape (None for a sphere or a prepared shape), with a note for
/// a fitted kernel. `prefix` is the type's key, `name` its name in the note.
fn clump_template(
    ctx: &Ctx,
    prefix: &str,
    name: &str,
    shape: &ParticleShape,
    notes: &mut Vec<String>,
) -> Result<Option<ClumpTemplate>, SceneError> {
    let key = |n: &str| format!("{prefix}.{n}");
    let sk = |n: &str| format!("{prefix}.shape.{n}");
    Ok(Some(match shape {
        ParticleShape::Sphere | ParticleShape::Prepared(_) | ParticleShape::Polyhedron { .. } => {
            return Ok(None)
        }
        ParticleShape::Rod {
            length,
            diameter,
            count,
        } => {
            let length = ctx.positive(*length, sk("length"))?;
            let diameter = ctx.positive(*diameter, sk("diameter"))?;
            ClumpTemplate::rod(length, diameter, *count).map_err(|m| ctx.err(key("shape"), m))?
        }
        ParticleShape::Spheres { spheres } => {
            for (i, (_, r)) in spheres.iter().enumerate() {
                ctx.positive(*r, format!("{prefix}.shape.spheres[{i}]"))?;
            }
            ClumpTemplate::new(spheres.clone()).map_err(|m| ctx.err(sk("spheres"), m))?
        }
        ParticleShape::MaizeKernel { kernel, count } => {
            let mut kernel = *kernel;
            for (dimension, v) in kernel.dimensions_mut() {
                ctx.positive(*v, sk(dimension))?;
            }
            let fit = kernel.fit(*count).map_err(|m| ctx.err(key("shape"), m))?;
            notes.push(format!(
                "{prefix} (\"{name}\"): {} maize kernel of {} spheres, volume {:.4e} m^3, {:+.1} % against the target solid ({:.4e} m^3)",
                kernel.class(),
                fit.template.spheres.len(),
                fit.clump_volume,
                100.0 * fit.volume_error,
                fit.target_volume
            ));
            fit.template
        }
        ParticleShape::MaizeKernelFit { kernel, options } => {
            let mut kernel = *kernel;
            for (dimension, v) in kernel.dimensions_mut() {
                ctx.positive(*v, sk(dimension))?;
            }
            fit_knobs(ctx, prefix, options)?;
            let fit = kernel
                .fit_to(options)
                .map_err(|m| ctx.err(sk("volume_error"), m))?;
            notes.push(fit_note(
                prefix,
                name,
                &format!("{} maize kernel", kernel.class()),
                &fit,
            ));
            fit.template
        }
        ParticleShape::MultiSphere {
            file,
            scale,
            options,
        } => {
            if !file.exists() {
                return Err(ctx.err(
                    sk("file"),
                    format!("STL file {} does not exist", file.display()),
                ));
            }
            let scale = ctx.positive(*scale, sk("file_scale"))?;
            fit_knobs(ctx, prefix, options)?;
            let solid = MeshSolid::read(file, scale).map_err(|m| ctx.err(sk("file"), m))?;
            let fit = sphere_fit::fit(&solid, options)
                .map_err(|m| ctx.err(sk("volume_error"), format!("{}: {m}", file.display())))?;
            let what = format!(
                "solid {}",
                file.file_name().unwrap_or_default().to_string_lossy()
            );
            notes.push(fit_note(prefix, name, &what, &fit));
            fit.template
        }
    }))
}

/// The polyhedron of a polyhedral shape (None for other shapes), with a note on how it was made.
fn polyhedron_shape(
    ctx: &Ctx,
    prefix: &str,
    name: &str,
    shape: &ParticleShape,
    notes: &mut Vec<String>,
) -> Result<Option<ConvexPolyhedron>, SceneError> {
    let ParticleShape::Polyhedron { source } = shape else {
        return Ok(None);
    };
    let key = |n: &str| format!("{prefix}.{n}");
    let sk = |n: &str| format!("{prefix}.shape.{n}");
    Ok(Some(match source {
        PolyhedronSource::Kernel(kernel) => {
            let mut kernel = *kernel;
            for (dimension, v) in kernel.dimensions_mut() {
                ctx.positive(*v, sk(dimension))?;
            }
            let k = kernel_polyhedron(&kernel).map_err(|m| ctx.err(key("shape"), m))?;
            notes.push(format!(
                "{prefix} (\"{name}\"): {} maize kernel as a convex polyhedron of {} vertices and {} faces, volume {:.4e} m^3 (the hull of the dimensions held {:.1} % of the target solid and was scaled by {:.4} to its volume)",
                kernel.class(),
                k.polyhedron.vertices.len(),
                k.polyhedron.faces.len(),
                k.polyhedron.volume,
                100.0 * k.hull_volume_ratio,
                k.scale
            ));
            k.polyhedron
        }
        PolyhedronSource::Stl { file, scale } => {
            if !file.exists() {
                return Err(ctx.err(
                    sk("file"),
                    format!("STL file {} does not exist", file.display()),
                ));
            }
            let scale = ctx.positive(*scale, sk("file_scale"))?;
            let (p, stl_notes) =
                crate::polyhedron::from_stl(file, scale).map_err(|m| ctx.err(sk("file"), m))?;
            for note in stl_notes {
                notes.push(format!("{prefix} (\"{name}\"): {}: {note}", file.display()));
            }
            p
        }
        PolyhedronSource::Vertices(points) => {
            let (p, _, note) = ConvexPolyhedron::from_points_noted(points)
                .map_err(|m| ctx.err(sk("vertices"), m))?;
            if let Some(note) = note {
                notes.push(format!("{prefix} (\"{name}\"): {note}"));
            }
            p
        }
    }))
}

/// Checks a fit's knobs, naming the key at fault.
fn fit_knobs(ctx: &Ctx, prefix: &str, options: &FitOptions) -> Result<(), SceneError> {
    options.validate().map_err(|m| {
        let key = m.split(':').next().unwrap_or("volume_error").to_string();
        ctx.err(format!("{prefix}.shape.{key}"), m)
    })
}

/// The note on a fit: sphere count, volume error, surface error and smallest sphere.
fn fit_note(prefix: &str, name: &str, what: &str, fit: &SphereFit) -> String {
    let q = &fit.quality;
    format!(
        "{prefix} (\"{name}\"): {what} fitted with {} spheres, volume {:.4e} m^3, {:+.1} % against the solid ({:.4e} m^3), symmetric difference {:.1} %, surface error {:.2} mm RMS ({:.1} % of the equal-volume radius), {:.2} mm largest, smallest sphere radius {:.3} mm",
        fit.template.spheres.len(),
        q.clump_volume,
        100.0 * q.volume_error,
        q.solid_volume,
        100.0 * q.symmetric_difference,
        1e3 * q.surface_rms,
        100.0 * q.surface_rms / q.equal_volume_radius,
        1e3 * q.surface_max,
        1e3 * q.smallest_radius
    )
}

/// Builds a particle type; `prefix` is its key in messages.
#[allow(clippy::too_many_arguments)]
pub(super) fn particle_type(
    ctx: &Ctx,
    prefix: &str,
    name: &str,
    material: usize,
    density: f64,
    shape: &ParticleShape,
    sizes: &SizeDistribution,
    notes: &mut Vec<String>,
) -> Result<ParticleType, SceneError> {
    let key = |n: &str| format!("{prefix}.{n}");
    match shape {
        ParticleShape::Sphere | ParticleShape::Prepared(Shape::Sphere) => Ok(ParticleType::sphere(
            name,
            material,
            density,
            size(ctx, &key("size"), sizes)?,
        )),
        ParticleShape::Polyhedron { .. } => {
            let scale = size(ctx, &key("scale"), sizes)?;
            let poly = polyhedron_shape(ctx, prefix, name, shape, notes)?
                .expect("a polyhedral shape has a polyhedron");
            Ok(ParticleType::polyhedron(
                name, material, density, poly, scale,
            ))
        }
        ParticleShape::Prepared(shape) => Ok(ParticleType {
            name: name.into(),
            material,
            density,
            shape: shape.clone(),
            size: size(ctx, &key("scale"), sizes)?,
        }),
        _ => {
            let scale = size(ctx, &key("scale"), sizes)?;
            let template = clump_template(ctx, prefix, name, shape, notes)?
                .expect("a clump shape has a template");
            Ok(ParticleType::clump(
                name, material, density, template, scale,
            ))
        }
    }
}

/// Builds every clump shape of `description` (each maize kernel fit and clump mass properties)
/// and puts it back as [`ParticleShape::Prepared`], so that many scenes made from copies of the
/// description share the work. Returns the notes on what was built (a kernel's volume error).
/// `file` names the description in errors.
pub fn prepare_shapes(
    description: &mut SceneDescription,
    file: &str,
) -> Result<Vec<String>, SceneError> {
    let ctx = Ctx { file };
    let mut notes = Vec::new();
    let mut prepare =
        |prefix: &str, name: &str, shape: &mut ParticleShape| -> Result<(), SceneError> {
            if let Some(template) = clump_template(&ctx, prefix, name, shape, &mut notes)? {
                let built = ParticleType::clump(
                    name,
                    0,
                    1.0,
                    template,
                    SizeDistribution::Fixed { radius: 1.0 },
                );
                *shape = ParticleShape::Prepared(built.shape);
            } else if matches!(
                shape,
                ParticleShape::Polyhedron {
                    source: PolyhedronSource::Stl { .. }
                }
            ) {
                // Left to each build, which reads the file and warns when the solid is not
                // convex (a prepared shape would carry no warning into the scenes made from it).
            } else if let Some(poly) = polyhedron_shape(&ctx, prefix, name, shape, &mut notes)? {
                let built = ParticleType::polyhedron(
                    name,
                    0,
                    1.0,
                    poly,
                    SizeDistribution::Fixed { radius: 1.0 },
                );
                *shape = ParticleShape::Prepared(built.shape);
            }
            Ok(())
        };
    for (k, t) in description.particle_types.iter_mut().enumerate() {
        prepare(&format!("particle_type[{k}]"), &t.name, &mut t.shape)?;
    }
    for (k, g) in description.particles.iter_mut().enumerate() {
        if let GroupParticles::Inline { shape, .. } = &mut g.particles {
            let prefix = format!("particles[{k}]");
            prepare(&prefix, &prefix, shape)?;
        }
    }
    Ok(notes)
}

/// The mixture of named types a group draws from, with its shares normalised.
pub(super) fn mixture_of(
    ctx: &Ctx,
    k: usize,
    names: &[String],
    fractions: Option<&[f64]>,
    by_mass: bool,
    named: &[ParticleType],
) -> Result<Mixture, SceneError> {
    let key = |s: &str| format!("particles[{k}].{s}");
    if names.is_empty() {
        return Err(ctx.err(key("types"), "expected at least one particle type name"));
    }
    let mut types = Vec::new();
    for (i, name) in names.iter().enumerate() {
        let t = named.iter().find(|t| &t.name == name).ok_or_else(|| {
            let known: Vec<&str> = named.iter().map(|t| t.name.as_str()).collect();
            ctx.err(
                format!("particles[{k}].types[{i}]"),
                format!(
                    "no [[particle_type]] named \"{name}\" (defined: {})",
                    if known.is_empty() {
                        "none".to_string()
                    } else {
                        known.join(", ")
                    }
                ),
            )
        })?;
        types.push(t.clone());
    }
    let fractions = match fractions {
        Some(fr) => {
            if fr.len() != types.len() {
                return Err(ctx.err(
                    key("fractions"),
                    format!(
                        "expected one fraction per type ({} types), got {}",
                        types.len(),
                        fr.len()
                    ),
                ));
            }
            for (i, v) in fr.iter().enumerate() {
                ctx.non_negative(*v, format!("particles[{k}].fractions[{i}]"))?;
            }
            let sum: f64 = fr.iter().sum();
            if sum <= 0.0 {
                return Err(ctx.err(
                    key("fractions"),
                    "expected fractions that sum to more than zero",
                ));
            }
            fr.iter().map(|v| v / sum).collect()
        }
        None if types.len() == 1 => vec![1.0],
        None => {
            return Err(ctx.err(
                key("fractions"),
                format!(
                    "missing; expected one fraction per type ({} types)",
                    types.len()
                ),
            ))
        }
    };
    Ok(Mixture {
        types,
        fractions,
        by_mass,
    })
}

/// One group's placement, checked and ready to carry out.
pub(super) enum Planned {
    Lattice {
        points: Vec<DVec3>,
        seed: Option<u64>,
    },
    Random {
        region: FillRegion,
        target: FillTarget,
        seed: Option<u64>,
    },
    Factory {
        shape: FactoryShape,
        normal: DVec3,
        total: FillTarget,
        rate: Rate,
        start: f64,
        seed: Option<u64>,
    },
    Specimen {
        spheres: Vec<SpecimenSphere>,
    },
}

impl Planned {
    /// Where this group's particles start or are created.
    pub fn bounds(&self, mixture: &Mixture) -> (DVec3, DVec3) {
        match self {
            Planned::Lattice { points, .. } => points.iter().fold(
                (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
                |(lo, hi), p| (lo.min(*p), hi.max(*p)),
            ),
            Planned::Specimen { spheres } => spheres.iter().fold(
                (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
                |(lo, hi), s| (lo.min(s.position), hi.max(s.position)),
            ),
            Planned::Random { region, .. } => region.bounds(),
            Planned::Factory { shape, normal, .. } => {
                shape.slab_bounds(*normal, 2.0 * mixture.bounding_radius())
            }
        }
    }
}

fn region(ctx: &Ctx, prefix: &str, r: &FillRegion) -> Result<FillRegion, SceneError> {
    let key = |n: &str| format!("{prefix}.{n}");
    Ok(match *r {
        FillRegion::Box { min, max } => {
            if !min.cmplt(max).all() {
                return Err(ctx.err(key("max"), "expected max > min in every coordinate"));
            }
            FillRegion::Box { min, max }
        }
        FillRegion::Cylinder {
            base,
            axis,
            radius,
            length,
        } => FillRegion::Cylinder {
            base,
            axis: ctx.direction(axis, key("axis"))?,
            radius: ctx.positive(radius, key("radius"))?,
            length: ctx.positive(length, key("length"))?,
        },
    })
}

fn amount(ctx: &Ctx, k: usize, a: FillTarget) -> Result<FillTarget, SceneError> {
    let fk = |s: &str| format!("particles[{k}].fill.{s}");
    match a {
        FillTarget::Count(0) => Err(ctx.err(fk("count"), "expected a count > 0")),
        FillTarget::Count(n) => Ok(FillTarget::Count(n)),
        FillTarget::Mass(m) => Ok(FillTarget::Mass(ctx.positive(m, fk("mass"))?)),
    }
}

/// Counts the spheres a group may create against [`super::MAX_SPHERES`] before anything is
/// allocated, together with the groups before it (`total`).
struct SphereBudget<'a> {
    ctx: &'a Ctx<'a>,
    total: f64,
}

impl SphereBudget<'_> {
    /// Takes `spheres` more (`what` says how many and why, as the start of the message).
    fn take(&mut self, key: String, spheres: f64, what: String) -> Result<(), SceneError> {
        let cap = super::MAX_SPHERES as f64;
        let limit = format!(
            "more than a scene may hold (at most {} spheres, about 1 kB of memory each)",
            super::MAX_SPHERES
        );
        if spheres.is_nan() || spheres > cap {
            return Err(self.ctx.err(key, format!("{what}: {limit}")));
        }
        self.total += spheres;
        if self.total > cap {
            return Err(self.ctx.err(
                key,
                format!(
                    "{what}, with the groups before it up to {:.3e} spheres: {limit}",
                    self.total
                ),
            ));
        }
        Ok(())
    }

    /// The spheres a fill of `target` may make: a count times the most spheres per particle, or
    /// for a mass the mass over the lightest particle, times that.
    fn fill(&mut self, k: usize, mixture: &Mixture, target: FillTarget) -> Result<(), SceneError> {
        let fk = |s: &str| format!("particles[{k}].fill.{s}");
        let per_particle = mixture
            .types
            .iter()
            .map(|t| match &t.shape {
                mixture::Shape::Sphere | mixture::Shape::Polyhedron { .. } => 1,
                mixture::Shape::Clump { members, .. } => members.len(),
            })
            .max()
            .unwrap_or(1) as f64;
        let of_spheres = |n: f64| {
            if per_particle > 1.0 {
                format!(
                    " of up to {per_particle} spheres ({:.3e} spheres)",
                    n * per_particle
                )
            } else {
                String::new()
            }
        };
        match target {
            FillTarget::Count(n) => self.take(
                fk("count"),
                n as f64 * per_particle,
                format!("{n} particles{}", of_spheres(n as f64)),
            ),
            FillTarget::Mass(m) => {
                let lightest = mixture
                    .types
                    .iter()
                    .map(|t| t.mass(t.size.min_radius()))
                    .fold(f64::INFINITY, f64::min);
                // A mass fill stops at the first particle that reaches the mass.
                let particles = (m / lightest).ceil() + 1.0;
                self.take(
                    fk("mass"),
                    particles * per_particle,
                    format!(
                        "{m} kg may take up to {particles:.3e} particles{} (the mass over the lightest particle, {lightest:.3e} kg)",
                        of_spheres(particles)
                    ),
                )
            }
        }
    }
}

/// Checks a group's placement and works out its lattice points.
pub(super) fn plan(
    ctx: &Ctx,
    k: usize,
    placement: &Placement,
    mixture: &Mixture,
    budget_total: &mut f64,
) -> Result<Planned, SceneError> {
    let key = |s: &str| format!("particles[{k}].{s}");
    let fk = |s: &str| format!("particles[{k}].fill.{s}");
    let mut budget = SphereBudget {
        ctx,
        total: *budget_total,
    };
    let planned = match placement {
        Placement::Lattice {
            region: r,
            lattice,
            spacing,
            origin,
            seed,
        } => {
            let region = region(ctx, &key("region"), r)?;
            if mixture.types.len() != 1 || !matches!(mixture.types[0].shape, mixture::Shape::Sphere)
            {
                return Err(ctx.err(fk("type"), "a lattice places spheres of one type; use a random fill or a factory for clumps and mixtures"));
            }
            let sizes = &mixture.types[0].size;
            let spacing =
                ctx.positive(spacing.unwrap_or(2.0 * sizes.max_radius()), fk("spacing"))?;
            if spacing < 2.0 * sizes.max_radius() * (1.0 - 1e-9) {
                return Err(ctx.err(fk("spacing"), format!(
                    "spacing {spacing} is smaller than the largest diameter {}; particles would overlap",
                    2.0 * sizes.max_radius()
                )));
            }
            // Points per volume: 1 / s^3 for simple cubic, sqrt(2) / s^3 close packed; the box
            // around the region, one spacing larger, bounds what the lattice can hold.
            let (lo, hi) = region.bounds();
            let density = match lattice {
                Lattice::SimpleCubic => 1.0,
                Lattice::HexagonalClosePacked => std::f64::consts::SQRT_2,
            };
            let points =
                ((hi - lo) + DVec3::splat(spacing)).element_product() / spacing.powi(3) * density;
            budget.take(
                fk("spacing"),
                points,
                format!("a lattice spacing of {spacing} m places up to {points:.3e} spheres in this region"),
            )?;
            let origin = origin.unwrap_or(region.bounds().0);
            Planned::Lattice {
                points: fill::lattice_points(&region, *lattice, spacing, origin),
                seed: *seed,
            }
        }
        Placement::Random {
            region: r,
            amount: a,
            seed,
        } => {
            let region = region(ctx, &key("region"), r)?;
            let target = amount(ctx, k, *a)?;
            budget.fill(k, mixture, target)?;
            Planned::Random {
                region,
                target,
                seed: *seed,
            }
        }
        Placement::Factory {
            outlet,
            normal,
            amount: a,
            rate,
            start,
            seed,
        } => {
            let fak = |s: &str| format!("particles[{k}].factory.{s}");
            let normal = ctx.direction(*normal, fak("normal"))?;
            let shape = match *outlet {
                FactoryOutlet::Disc { centre, radius } => FactoryShape::Disc {
                    centre,
                    radius: ctx.positive(radius, fak("radius"))?,
                },
                FactoryOutlet::Rectangle {
                    centre,
                    size,
                    u_axis,
                } => {
                    ctx.positive(size[0], fak("size"))?;
                    ctx.positive(size[1], fak("size"))?;
                    let u = match u_axis {
                        Some(a) => {
                            let u = ctx.direction(a, fak("u_axis"))?;
                            let u = u - normal * u.dot(normal);
                            if u.length() < 1e-9 {
                                return Err(ctx.err(
                                    fak("u_axis"),
                                    "expected a direction in the face (not along the normal)",
                                ));
                            }
                            u.normalize()
                        }
                        None if normal.z.abs() > 0.999 => DVec3::X,
                        None => perpendicular_axes(normal).0,
                    };
                    FactoryShape::Rectangle {
                        centre,
                        u,
                        v: normal.cross(u),
                        half_u: 0.5 * size[0],
                        half_v: 0.5 * size[1],
                    }
                }
            };
            let rate = match *rate {
                Rate::Count(r) => Rate::Count(ctx.positive(r, fk("rate"))?),
                Rate::Mass(r) => Rate::Mass(ctx.positive(r, fk("mass_rate"))?),
            };
            let start = ctx.non_negative(*start, fk("start"))?;
            let total = amount(ctx, k, *a)?;
            budget.fill(k, mixture, total)?;
            Planned::Factory {
                shape,
                normal,
                total,
                rate,
                start,
                seed: *seed,
            }
        }
        Placement::Specimen(specimen) => Planned::Specimen {
            spheres: specimen_spheres(ctx, k, specimen, mixture, &mut budget)?,
        },
    };
    *budget_total = budget.total;
    Ok(planned)
}

/// Checks a stalk specimen against the group's one sphere type and packs it, refusing one that
/// would take the scene past [`super::MAX_SPHERES`] before anything is allocated.
fn specimen_spheres(
    ctx: &Ctx,
    k: usize,
    specimen: &StalkSpecimen,
    mixture: &Mixture,
    budget: &mut SphereBudget,
) -> Result<Vec<SpecimenSphere>, SceneError> {
    let fk = |s: &str| {
        if s.is_empty() {
            format!("particles[{k}].fill")
        } else {
            format!("particles[{k}].fill.{s}")
        }
    };
    if mixture.types.len() != 1 || !matches!(mixture.types[0].shape, mixture::Shape::Sphere) {
        return Err(ctx.err(
            fk("type"),
            "a stalk specimen is built of spheres of one type (give material and size; the core's material is core_material), not of clumps or a mixture",
        ));
    }
    let sizes = &mixture.types[0].size;
    let most = specimen
        .check(sizes)
        .map_err(|e| ctx.err(fk(e.key), e.message))?;
    let (key, what) = match specimen.packing {
        Packing::Hcp { .. } => (
            "spacing",
            format!("the lattice may place up to {most:.3e} spheres in this specimen"),
        ),
        Packing::Random { count, .. } => ("count", format!("{count} spheres")),
    };
    budget.take(fk(key), most, what)?;
    let packed = specimen
        .build(sizes, super::MAX_SPHERES)
        .map_err(|e| ctx.err(fk(e.key), e.message))?;
    Ok(packed.spheres)
}
