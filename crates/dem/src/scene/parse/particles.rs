//! Particle types, size distributions, regions and `[[particles]]` groups of a scene file.

use super::size::{basis, size_distribution, SizeEntry};
use super::{v3, V3};
use crate::factory::Rate;
use crate::fill::{FillRegion, Lattice, SizeDistribution};
use crate::maize_kernel::KernelShape;
use crate::mixture::FillTarget;
use crate::scene::description::*;
use crate::scene::{Ctx, SceneError};
use crate::specimen::{Core, Packing, StalkSpecimen};
use crate::sphere_fit::FitOptions;
use crate::units::Dimension;
use glam::DVec3;
use serde::Deserialize;
use std::path::Path;

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
pub(super) struct ParticleTypeEntry {
    name: String,
    material: String,
    shape: Option<ShapeEntry>,
    size: Option<SizeEntry>,
    scale: Option<SizeEntry>,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
struct ShapeEntry {
    #[serde(rename = "type")]
    kind: String,
    // rod
    #[serde(deserialize_with = "crate::units::length::opt", default)]
    length: Option<f64>,
    #[serde(deserialize_with = "crate::units::length::opt", default)]
    diameter: Option<f64>,
    count: Option<usize>,
    // spheres: [x, y, z, r] rows
    #[serde(deserialize_with = "crate::units::length::opt_four_list", default)]
    spheres: Option<Vec<[f64; 4]>>,
    // maize_kernel
    class: Option<String>,
    #[serde(deserialize_with = "crate::units::length::opt", default)]
    width: Option<f64>,
    #[serde(deserialize_with = "crate::units::length::opt", default)]
    height: Option<f64>,
    #[serde(deserialize_with = "crate::units::length::opt", default)]
    thickness: Option<f64>,
    #[serde(deserialize_with = "crate::units::length::opt", default)]
    upper_width: Option<f64>,
    #[serde(deserialize_with = "crate::units::length::opt", default)]
    lower_width: Option<f64>,
    #[serde(deserialize_with = "crate::units::length::opt", default)]
    upper_thickness: Option<f64>,
    #[serde(deserialize_with = "crate::units::length::opt", default)]
    lower_thickness: Option<f64>,
    // polyhedron: [x, y, z] rows
    #[serde(deserialize_with = "crate::units::length::opt_three_list", default)]
    vertices: Option<Vec<[f64; 3]>>,
    // fitted to a volume error: maize_kernel, multi_sphere
    volume_error: Option<f64>,
    min_radius_ratio: Option<f64>,
    max_spheres: Option<usize>,
    // multi_sphere
    file: Option<String>,
    file_scale: Option<f64>,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
pub(super) struct ParticleEntry {
    // One type given inline ...
    material: Option<String>,
    size: Option<SizeEntry>,
    shape: Option<ShapeEntry>,
    scale: Option<SizeEntry>,
    // ... or a mixture of named [[particle_type]]s.
    types: Option<Vec<String>>,
    fractions: Option<Vec<f64>>,
    basis: Option<String>,
    region: Option<RegionEntry>,
    factory: Option<FactoryEntry>,
    fill: FillEntry,
    #[serde(deserialize_with = "crate::units::speed::opt_three", default)]
    velocity: Option<V3>,
}

/// A group's particles without placement (a virtual test's `particles`).
#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
pub(super) struct GroupParticlesEntry {
    material: Option<String>,
    size: Option<SizeEntry>,
    shape: Option<ShapeEntry>,
    scale: Option<SizeEntry>,
    types: Option<Vec<String>>,
    fractions: Option<Vec<f64>>,
    basis: Option<String>,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
struct FactoryEntry {
    #[serde(rename = "type")]
    kind: String,
    #[serde(alias = "center")]
    #[serde(deserialize_with = "crate::units::length::three")]
    centre: V3,
    normal: Option<V3>,
    #[serde(deserialize_with = "crate::units::length::opt", default)]
    radius: Option<f64>,
    #[serde(deserialize_with = "crate::units::length::opt_two", default)]
    size: Option<[f64; 2]>,
    u_axis: Option<V3>,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
struct RegionEntry {
    #[serde(rename = "type")]
    kind: String,
    #[serde(deserialize_with = "crate::units::length::opt_three", default)]
    min: Option<V3>,
    #[serde(deserialize_with = "crate::units::length::opt_three", default)]
    max: Option<V3>,
    #[serde(deserialize_with = "crate::units::length::opt_three", default)]
    base: Option<V3>,
    axis: Option<V3>,
    #[serde(deserialize_with = "crate::units::length::opt", default)]
    radius: Option<f64>,
    #[serde(deserialize_with = "crate::units::length::opt", default)]
    length: Option<f64>,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
struct FillEntry {
    #[serde(rename = "type")]
    kind: String,
    lattice: Option<String>,
    #[serde(deserialize_with = "crate::units::length::opt", default)]
    spacing: Option<f64>,
    #[serde(deserialize_with = "crate::units::length::opt_three", default)]
    origin: Option<V3>,
    count: Option<usize>,
    #[serde(deserialize_with = "crate::units::mass::opt", default)]
    mass: Option<f64>,
    seed: Option<u64>,
    // factory
    rate: Option<f64>,
    #[serde(deserialize_with = "crate::units::mass_rate::opt", default)]
    mass_rate: Option<f64>,
    #[serde(deserialize_with = "crate::units::time::opt", default)]
    start: Option<f64>,
    // stalk specimen
    #[serde(deserialize_with = "crate::units::length::opt", default)]
    length: Option<f64>,
    #[serde(deserialize_with = "crate::units::length::opt", default)]
    diameter: Option<f64>,
    packing: Option<String>,
    #[serde(deserialize_with = "crate::units::length::opt", default)]
    hollow_diameter: Option<f64>,
    core_material: Option<String>,
    #[serde(deserialize_with = "crate::units::length::opt", default)]
    core_diameter: Option<f64>,
    #[serde(alias = "center")]
    #[serde(deserialize_with = "crate::units::length::opt_three", default)]
    centre: Option<V3>,
    axis: Option<V3>,
}

/// The particle sections of a scene file with the keys each accepts (see
/// [`super::reference_sections`]).
pub(super) fn reference_sections() -> Vec<(&'static str, Vec<&'static str>)> {
    use crate::keys::of;
    vec![
        ("[[particle_type]]", of::<ParticleTypeEntry>()),
        ("shape", of::<ShapeEntry>()),
        ("size and scale", of::<SizeEntry>()),
        ("[[particles]]", of::<ParticleEntry>()),
        ("particles (of a virtual test)", of::<GroupParticlesEntry>()),
        ("particles.region", of::<RegionEntry>()),
        ("particles.fill", of::<FillEntry>()),
        ("particles.factory", of::<FactoryEntry>()),
    ]
}

pub(super) fn particle_type(
    ctx: &Ctx,
    k: usize,
    t: ParticleTypeEntry,
    base: &Path,
) -> Result<ParticleTypeDescription, SceneError> {
    let prefix = format!("particle_type[{k}]");
    let (shape, size) = shape_and_size(ctx, &prefix, t.shape, t.size, t.scale, base)?;
    Ok(ParticleTypeDescription {
        name: t.name,
        material: t.material,
        shape,
        size,
    })
}

/// A virtual test's `particles` (a group without placement).
pub(super) fn group_from_entry(
    ctx: &Ctx,
    key: &str,
    e: GroupParticlesEntry,
    base: &Path,
) -> Result<GroupParticles, SceneError> {
    particles_of_group(
        ctx,
        key,
        base,
        TypeKeys {
            material: e.material,
            size: e.size,
            shape: e.shape,
            scale: e.scale,
            types: e.types,
            fractions: e.fractions,
            basis: e.basis,
        },
    )
}

/// The keys of a group that say which particles it holds.
struct TypeKeys {
    material: Option<String>,
    size: Option<SizeEntry>,
    shape: Option<ShapeEntry>,
    scale: Option<SizeEntry>,
    types: Option<Vec<String>>,
    fractions: Option<Vec<f64>>,
    basis: Option<String>,
}

fn particles_of_group(
    ctx: &Ctx,
    prefix: &str,
    base: &Path,
    p: TypeKeys,
) -> Result<GroupParticles, SceneError> {
    let key = |s: &str| format!("{prefix}.{s}");
    Ok(match (p.types, p.material) {
        (Some(types), None) => {
            for (name, given) in [
                ("size", p.size.is_some()),
                ("shape", p.shape.is_some()),
                ("scale", p.scale.is_some()),
            ] {
                if given {
                    return Err(ctx.err(
                        key(name),
                        "not used with types (each [[particle_type]] has its own)",
                    ));
                }
            }
            let by_mass = basis(ctx, key("basis"), p.basis.as_deref())?;
            GroupParticles::Mixture {
                types,
                fractions: p.fractions,
                by_mass,
            }
        }
        (None, Some(material)) => {
            for (name, given) in [
                ("fractions", p.fractions.is_some()),
                ("basis", p.basis.is_some()),
            ] {
                if given {
                    return Err(ctx.err(
                        key(name),
                        "only used with types (a mixture of [[particle_type]]s)",
                    ));
                }
            }
            let (shape, size) = shape_and_size(ctx, prefix, p.shape, p.size, p.scale, base)?;
            GroupParticles::Inline {
                material,
                shape,
                size,
            }
        }
        (Some(_), Some(_)) => {
            return Err(ctx.err(
                key("types"),
                "give types (named [[particle_type]]s) or material (one type inline), not both",
            ))
        }
        (None, None) => {
            return Err(ctx.err(
                key("material"),
                "missing; expected material (with size, or shape) or types",
            ))
        }
    })
}

/// A type's shape with its size (a sphere's radius) or scale (a clump's) distribution; `base`
/// resolves a relative STL path.
fn shape_and_size(
    ctx: &Ctx,
    prefix: &str,
    shape: Option<ShapeEntry>,
    size: Option<SizeEntry>,
    scale: Option<SizeEntry>,
    base: &Path,
) -> Result<(ParticleShape, SizeDistribution), SceneError> {
    let key = |n: &str| format!("{prefix}.{n}");
    let sh = match shape {
        Some(sh) if sh.kind != "sphere" => sh,
        sphere => {
            if let Some(sh) = &sphere {
                shape_keys(ctx, &key("shape"), sh, &[])?;
            }
            if scale.is_some() {
                return Err(ctx.err(
                    key("scale"),
                    "not used by a sphere (give its radius distribution as size)",
                ));
            }
            let size = size.ok_or_else(|| ctx.err(key("size"), "missing; expected the radius distribution, e.g. { type = \"fixed\", radius = 0.002 }"))?;
            let dist = size_distribution(ctx, &key("size"), &size, Some(Dimension::Length))?;
            // Past these the time step and the masses leave what f64 and a run can hold (a
            // radius of 1e-300 m "diverged at t = 0").
            let (lo, hi) = (dist.min_radius(), dist.max_radius());
            // (A radius of 0 or less, or not a number, is the size's own check, by key.)
            if lo > 0.0
                && hi.is_finite()
                && (lo < super::super::MIN_RADIUS || hi > super::super::MAX_RADIUS)
            {
                return Err(ctx.err(
                    key("size"),
                    format!(
                        "radii from {lo:e} to {hi:e} m: expected {:e} m (0.1 µm) to {:e} m",
                        super::super::MIN_RADIUS,
                        super::super::MAX_RADIUS
                    ),
                ));
            }
            return Ok((ParticleShape::Sphere, dist));
        }
    };
    if size.is_some() {
        return Err(ctx.err(
            key("size"),
            "not used by a clump (its shape sets its size; give a scale distribution as scale)",
        ));
    }
    let scale = match scale {
        Some(sc) => size_distribution(ctx, &key("scale"), &sc, None)?,
        None => SizeDistribution::Fixed { radius: 1.0 },
    };
    let sk = |n: &str| format!("{prefix}.shape.{n}");
    let shape = match sh.kind.as_str() {
        "rod" => {
            shape_keys(ctx, &key("shape"), &sh, &["length", "diameter", "count"])?;
            ParticleShape::Rod {
                length: ctx.require(sh.length, sk("length"), "the rod length end to end (m)")?,
                diameter: ctx.require(sh.diameter, sk("diameter"), "the rod diameter (m)")?,
                count: ctx.require(sh.count, sk("count"), "the number of spheres")?,
            }
        }
        "spheres" => {
            shape_keys(ctx, &key("shape"), &sh, &["spheres"])?;
            let rows = ctx.require(
                sh.spheres.as_ref(),
                sk("spheres"),
                "rows [x, y, z, radius] (m)",
            )?;
            ParticleShape::Spheres {
                spheres: rows
                    .iter()
                    .map(|r| (DVec3::new(r[0], r[1], r[2]), r[3]))
                    .collect(),
            }
        }
        "polyhedron" => match (&sh.class, &sh.vertices, &sh.file) {
            (Some(_), None, None) => ParticleShape::Polyhedron {
                source: PolyhedronSource::Kernel(kernel_class(ctx, prefix, &sh, &[])?),
            },
            (None, None, Some(file)) => {
                shape_keys(ctx, &key("shape"), &sh, &["file", "file_scale"])?;
                ParticleShape::Polyhedron {
                    source: PolyhedronSource::Stl {
                        file: base.join(file),
                        scale: sh.file_scale.unwrap_or(1.0),
                    },
                }
            }
            (None, Some(rows), None) => {
                shape_keys(ctx, &key("shape"), &sh, &["vertices"])?;
                ParticleShape::Polyhedron {
                    source: PolyhedronSource::Vertices(
                        rows.iter().map(|r| DVec3::new(r[0], r[1], r[2])).collect(),
                    ),
                }
            }
            _ => {
                return Err(ctx.err(
                    key("shape"),
                    format!(
                        "a polyhedron takes one of class (one of {}), vertices (rows [x, y, z] in m) or file (an STL solid)",
                        KernelShape::KINDS.join(", ")
                    ),
                ))
            }
        },
        "maize_kernel" => {
            let kernel = kernel_class(
                ctx,
                prefix,
                &sh,
                &["count", "volume_error", "min_radius_ratio", "max_spheres"],
            )?;
            match (sh.count, sh.volume_error) {
                (Some(count), None) => {
                    for (name, given) in [
                        ("min_radius_ratio", sh.min_radius_ratio.is_some()),
                        ("max_spheres", sh.max_spheres.is_some()),
                    ] {
                        if given {
                            return Err(ctx.err(
                                sk(name),
                                "only used with volume_error (a fit to a volume error)",
                            ));
                        }
                    }
                    ParticleShape::MaizeKernel { kernel, count }
                }
                (None, Some(_)) => ParticleShape::MaizeKernelFit {
                    kernel,
                    options: fit_options(&sh),
                },
                (Some(_), Some(_)) => {
                    return Err(ctx.err(
                        sk("volume_error"),
                        "give count (inscribed spheres) or volume_error (a fit to that error), not both",
                    ))
                }
                (None, None) => {
                    return Err(ctx.err(
                        sk("count"),
                        "missing; expected count (the number of spheres) or volume_error (e.g. 0.05)",
                    ))
                }
            }
        }
        "multi_sphere" => {
            shape_keys(
                ctx,
                &key("shape"),
                &sh,
                &[
                    "file",
                    "file_scale",
                    "volume_error",
                    "min_radius_ratio",
                    "max_spheres",
                ],
            )?;
            let file = ctx.require(
                sh.file.as_deref(),
                sk("file"),
                "the path of a closed STL solid",
            )?;
            ParticleShape::MultiSphere {
                file: base.join(file),
                scale: sh.file_scale.unwrap_or(1.0),
                options: fit_options(&sh),
            }
        }
        other => {
            return Err(ctx.err(
                sk("type"),
                format!(
                    "unknown shape \"{other}\" (expected sphere, rod, spheres, maize_kernel, multi_sphere or polyhedron)"
                ),
            ))
        }
    };
    Ok((shape, scale))
}

/// The kernel class of a shape entry with its dimensions overridden by the entry's keys; `extra`
/// are the other keys the shape type takes.
fn kernel_class(
    ctx: &Ctx,
    prefix: &str,
    sh: &ShapeEntry,
    extra: &[&'static str],
) -> Result<KernelShape, SceneError> {
    let key = |n: &str| format!("{prefix}.{n}");
    let sk = |n: &str| format!("{prefix}.shape.{n}");
    let class = sh.class.as_deref().ok_or_else(|| {
        ctx.err(
            sk("class"),
            format!("missing; expected one of {}", KernelShape::KINDS.join(", ")),
        )
    })?;
    let mut kernel = KernelShape::published(class).ok_or_else(|| {
        ctx.err(
            sk("class"),
            format!(
                "unknown kernel class \"{class}\" (expected {})",
                KernelShape::KINDS.join(", ")
            ),
        )
    })?;
    let mut allowed = vec!["class"];
    allowed.extend_from_slice(extra);
    allowed.extend(kernel.dimensions_mut().into_iter().map(|(n, _)| n));
    shape_keys(ctx, &key("shape"), sh, &allowed)?;
    let given = shape_values(sh);
    for (name, v) in kernel.dimensions_mut() {
        if let Some(g) = given.iter().find(|(n, _)| *n == name).and_then(|(_, g)| *g) {
            *v = g;
        }
    }
    Ok(kernel)
}

/// The fit's knobs, defaults where not given (their ranges are checked when built).
fn fit_options(s: &ShapeEntry) -> FitOptions {
    let d = FitOptions::default();
    FitOptions {
        volume_error: s.volume_error.unwrap_or(d.volume_error),
        min_radius_ratio: s.min_radius_ratio.unwrap_or(d.min_radius_ratio),
        max_spheres: s.max_spheres.unwrap_or(d.max_spheres),
    }
}

/// The numeric keys of a shape entry, by name.
fn shape_values(s: &ShapeEntry) -> [(&'static str, Option<f64>); 9] {
    [
        ("length", s.length),
        ("diameter", s.diameter),
        ("width", s.width),
        ("height", s.height),
        ("thickness", s.thickness),
        ("upper_width", s.upper_width),
        ("lower_width", s.lower_width),
        ("upper_thickness", s.upper_thickness),
        ("lower_thickness", s.lower_thickness),
    ]
}

/// Rejects shape keys that the shape type does not use.
fn shape_keys(ctx: &Ctx, prefix: &str, s: &ShapeEntry, allowed: &[&str]) -> Result<(), SceneError> {
    let mut given: Vec<(&str, bool)> = shape_values(s)
        .iter()
        .map(|(n, v)| (*n, v.is_some()))
        .collect();
    given.extend([
        ("count", s.count.is_some()),
        ("spheres", s.spheres.is_some()),
        ("class", s.class.is_some()),
        ("vertices", s.vertices.is_some()),
        ("volume_error", s.volume_error.is_some()),
        ("min_radius_ratio", s.min_radius_ratio.is_some()),
        ("max_spheres", s.max_spheres.is_some()),
        ("file", s.file.is_some()),
        ("file_scale", s.file_scale.is_some()),
    ]);
    ctx.only(prefix, &s.kind, &given, allowed)
}

fn region(ctx: &Ctx, prefix: &str, r: &RegionEntry) -> Result<FillRegion, SceneError> {
    let key = |n: &str| format!("{prefix}.{n}");
    let given = [
        ("min", r.min.is_some()),
        ("max", r.max.is_some()),
        ("base", r.base.is_some()),
        ("axis", r.axis.is_some()),
        ("radius", r.radius.is_some()),
        ("length", r.length.is_some()),
    ];
    Ok(match r.kind.as_str() {
        "box" => {
            ctx.only(prefix, "box", &given, &["min", "max"])?;
            FillRegion::Box {
                min: v3(ctx.require(r.min, key("min"), "the lower corner [x, y, z]")?),
                max: v3(ctx.require(r.max, key("max"), "the upper corner [x, y, z]")?),
            }
        }
        "cylinder" => {
            ctx.only(
                prefix,
                "cylinder",
                &given,
                &["base", "axis", "radius", "length"],
            )?;
            FillRegion::Cylinder {
                base: v3(ctx.require(r.base, key("base"), "the centre of the bottom [x, y, z]")?),
                axis: v3(r.axis.unwrap_or([0.0, 0.0, 1.0])),
                radius: ctx.require(r.radius, key("radius"), "the radius (m)")?,
                length: ctx.require(r.length, key("length"), "the length (m)")?,
            }
        }
        other => {
            return Err(ctx.err(
                key("type"),
                format!("unknown region \"{other}\" (expected box or cylinder)"),
            ))
        }
    })
}

pub(super) fn particle_group(
    ctx: &Ctx,
    k: usize,
    p: ParticleEntry,
    base: &Path,
) -> Result<ParticleGroup, SceneError> {
    let prefix = format!("particles[{k}]");
    let key = |s: &str| format!("particles[{k}].{s}");
    let fk = |s: &str| format!("particles[{k}].fill.{s}");
    let particles = particles_of_group(
        ctx,
        &prefix,
        base,
        TypeKeys {
            material: p.material,
            size: p.size,
            shape: p.shape,
            scale: p.scale,
            types: p.types,
            fractions: p.fractions,
            basis: p.basis,
        },
    )?;
    let fe = &p.fill;
    let given = [
        ("lattice", fe.lattice.is_some()),
        ("spacing", fe.spacing.is_some()),
        ("origin", fe.origin.is_some()),
        ("count", fe.count.is_some()),
        ("mass", fe.mass.is_some()),
        ("seed", fe.seed.is_some()),
        ("rate", fe.rate.is_some()),
        ("mass_rate", fe.mass_rate.is_some()),
        ("start", fe.start.is_some()),
        ("length", fe.length.is_some()),
        ("diameter", fe.diameter.is_some()),
        ("packing", fe.packing.is_some()),
        ("hollow_diameter", fe.hollow_diameter.is_some()),
        ("core_material", fe.core_material.is_some()),
        ("core_diameter", fe.core_diameter.is_some()),
        ("centre", fe.centre.is_some()),
        ("axis", fe.axis.is_some()),
    ];
    let amount = || -> Result<FillTarget, SceneError> {
        match (fe.count, fe.mass) {
            (Some(n), None) => Ok(FillTarget::Count(n)),
            (None, Some(m)) => Ok(FillTarget::Mass(m)),
            (Some(_), Some(_)) => Err(ctx.err(fk("mass"), "give count or mass, not both")),
            (None, None) => Err(ctx.err(
                fk("count"),
                "missing; expected count (particles) or mass (kg)",
            )),
        }
    };
    let fill_region = |what: &str| -> Result<FillRegion, SceneError> {
        if p.factory.is_some() {
            return Err(ctx.err(
                key("factory"),
                format!("not used by a {what} fill (use fill.type = \"factory\")"),
            ));
        }
        let r = p
            .region
            .as_ref()
            .ok_or_else(|| ctx.err(key("region"), "missing; expected the region to fill"))?;
        region(ctx, &key("region"), r)
    };
    let placement = match fe.kind.as_str() {
        "lattice" => {
            ctx.only(
                &key("fill"),
                "lattice",
                &given,
                &["lattice", "spacing", "origin", "seed"],
            )?;
            let region = fill_region("lattice")?;
            let lattice = match fe.lattice.as_deref().unwrap_or("sc") {
                "sc" | "simple_cubic" => Lattice::SimpleCubic,
                "hcp" | "hexagonal_close_packed" => Lattice::HexagonalClosePacked,
                other => {
                    return Err(ctx.err(
                        fk("lattice"),
                        format!("unknown lattice \"{other}\" (expected sc or hcp)"),
                    ))
                }
            };
            Placement::Lattice {
                region,
                lattice,
                spacing: fe.spacing,
                origin: fe.origin.map(v3),
                seed: fe.seed,
            }
        }
        "random" => {
            ctx.only(&key("fill"), "random", &given, &["count", "mass", "seed"])?;
            Placement::Random {
                region: fill_region("random")?,
                amount: amount()?,
                seed: fe.seed,
            }
        }
        "factory" => {
            ctx.only(
                &key("fill"),
                "factory",
                &given,
                &["count", "mass", "seed", "rate", "mass_rate", "start"],
            )?;
            if p.region.is_some() {
                return Err(ctx.err(
                    key("region"),
                    "not used by a factory fill (give factory = { ... })",
                ));
            }
            let fa = p.factory.as_ref().ok_or_else(|| ctx.err(key("factory"), "missing; expected factory = { type = \"disc\" or \"rectangle\", centre = [x, y, z], ... }"))?;
            let fak = |s: &str| format!("particles[{k}].factory.{s}");
            let centre = v3(fa.centre);
            let outlet = match fa.kind.as_str() {
                "disc" => {
                    if fa.size.is_some() || fa.u_axis.is_some() {
                        return Err(ctx.err(
                            fak(if fa.size.is_some() { "size" } else { "u_axis" }),
                            "not used by a disc (give radius)",
                        ));
                    }
                    FactoryOutlet::Disc {
                        centre,
                        radius: ctx.require(fa.radius, fak("radius"), "the disc radius (m)")?,
                    }
                }
                "rectangle" => {
                    if fa.radius.is_some() {
                        return Err(ctx.err(
                            fak("radius"),
                            "not used by a rectangle (give size = [a, b])",
                        ));
                    }
                    FactoryOutlet::Rectangle {
                        centre,
                        size: ctx.require(fa.size, fak("size"), "the side lengths [a, b] (m)")?,
                        u_axis: fa.u_axis.map(v3),
                    }
                }
                other => {
                    return Err(ctx.err(
                        fak("type"),
                        format!("unknown factory \"{other}\" (expected disc or rectangle)"),
                    ))
                }
            };
            let rate = match (fe.rate, fe.mass_rate) {
                (Some(r), None) => Rate::Count(r),
                (None, Some(r)) => Rate::Mass(r),
                (Some(_), Some(_)) => {
                    return Err(ctx.err(fk("mass_rate"), "give rate or mass_rate, not both"))
                }
                (None, None) => {
                    return Err(ctx.err(
                        fk("rate"),
                        "missing; expected rate (particles/s) or mass_rate (kg/s)",
                    ))
                }
            };
            Placement::Factory {
                outlet,
                normal: v3(fa.normal.unwrap_or([0.0, 0.0, -1.0])),
                amount: amount()?,
                rate,
                start: fe.start.unwrap_or(0.0),
                seed: fe.seed,
            }
        }
        "stalk" => {
            ctx.only(
                &key("fill"),
                "stalk",
                &given,
                &[
                    "length",
                    "diameter",
                    "packing",
                    "spacing",
                    "count",
                    "seed",
                    "hollow_diameter",
                    "core_material",
                    "core_diameter",
                    "centre",
                    "axis",
                ],
            )?;
            for (name, given) in [
                ("region", p.region.is_some()),
                ("factory", p.factory.is_some()),
            ] {
                if given {
                    return Err(ctx.err(
                        key(name),
                        "not used by a stalk fill (the specimen's length, diameter, centre and axis place it)",
                    ));
                }
            }
            Placement::Specimen(stalk(ctx, k, fe)?)
        }
        other => {
            return Err(ctx.err(
                fk("type"),
                format!("unknown fill \"{other}\" (expected lattice, random, factory or stalk)"),
            ))
        }
    };
    let velocity = v3(p.velocity.unwrap_or([0.0; 3]));
    if !(velocity.is_finite() && velocity.length() <= super::super::MAX_SPEED) {
        return Err(ctx.err(
            format!("particles[{k}].velocity"),
            format!(
                "expected finite numbers (m/s) of size at most {:e}, got [{}, {}, {}]",
                super::super::MAX_SPEED,
                velocity.x,
                velocity.y,
                velocity.z
            ),
        ));
    }
    Ok(ParticleGroup {
        particles,
        placement,
        velocity,
    })
}

/// A `fill = { type = "stalk", ... }`: a stalk specimen (its values are checked when built).
fn stalk(ctx: &Ctx, k: usize, fe: &FillEntry) -> Result<StalkSpecimen, SceneError> {
    let fk = |s: &str| format!("particles[{k}].fill.{s}");
    let packing = match fe.packing.as_deref().unwrap_or("hcp") {
        "hcp" | "hexagonal_close_packed" => {
            for (name, given) in [("count", fe.count.is_some()), ("seed", fe.seed.is_some())] {
                if given {
                    return Err(ctx.err(
                        fk(name),
                        "not used by packing \"hcp\" (the lattice sets the count; give spacing, or packing = \"random\")",
                    ));
                }
            }
            Packing::Hcp {
                spacing: fe.spacing,
            }
        }
        "random" => {
            if fe.spacing.is_some() {
                return Err(ctx.err(fk("spacing"), "not used by packing \"random\" (give count)"));
            }
            Packing::Random {
                count: ctx.require(fe.count, fk("count"), "the number of spheres")?,
                seed: fe.seed.unwrap_or(1),
            }
        }
        other => {
            return Err(ctx.err(
                fk("packing"),
                format!("unknown packing \"{other}\" (expected hcp or random)"),
            ))
        }
    };
    let core = match (&fe.core_material, fe.core_diameter) {
        (Some(material), Some(diameter)) => Some(Core {
            material: material.clone(),
            diameter,
        }),
        (None, None) => None,
        (Some(_), None) => {
            return Err(ctx.err(
                fk("core_diameter"),
                "missing; expected the core's diameter (m) with core_material",
            ))
        }
        (None, Some(_)) => {
            return Err(ctx.err(
                fk("core_material"),
                "missing; expected the core's material with core_diameter",
            ))
        }
    };
    Ok(StalkSpecimen {
        length: ctx.require(fe.length, fk("length"), "the specimen's length (m)")?,
        diameter: ctx.require(fe.diameter, fk("diameter"), "the specimen's diameter (m)")?,
        packing,
        hollow_diameter: fe.hollow_diameter.unwrap_or(0.0),
        core,
        centre: v3(fe.centre.unwrap_or([0.0; 3])),
        axis: v3(fe.axis.unwrap_or([1.0, 0.0, 0.0])),
    })
}
