//! Scene files (TOML) into a [`SceneDescription`].
//!
//! serde reads the file into plain structs that reject unknown keys, with `serde_path_to_error`
//! supplying the key path; then each entry's form is checked and turned into the typed
//! description: a `type` that exists, only the keys that type uses, required keys present, one of
//! two alternatives (`duration` or `steps`). Values (positive sizes, names that exist) are the
//! builder's business, so that a description written in Rust gets the same checks.

mod bonds;
mod particles;
mod size;

use super::description::*;
use super::{Ctx, SceneError};
use crate::geometry::Motion;
use glam::DVec3;
use particles::{
    particle_group, particle_type, GroupParticlesEntry, ParticleEntry, ParticleTypeEntry,
};
use serde::de::DeserializeOwned;
use serde::Deserialize;
use std::path::Path;

pub(super) type V3 = [f64; 3];

pub(super) fn v3(a: V3) -> DVec3 {
    DVec3::from_array(a)
}

/// Reads a scene file's text; `file` names it in errors, `base` (its folder) resolves the
/// relative paths inside (STL files, the output directory).
pub fn scene(text: &str, file: &str, base: &Path) -> Result<SceneDescription, SceneError> {
    scene_with_warnings(text, file, base).map(|(d, _)| d)
}

/// [`scene`], with the warnings about how the file is written (a friction alias that papers use
/// for another coefficient), which the built scene's warnings do not see.
pub fn scene_with_warnings(
    text: &str,
    file: &str,
    base: &Path,
) -> Result<(SceneDescription, Vec<String>), SceneError> {
    let ctx = Ctx { file };
    let de = toml::Deserializer::new(text);
    let parsed: SceneFile = serde_path_to_error::deserialize(de).map_err(|e| {
        let key = e.path().to_string();
        let inner = e.into_inner();
        // toml spreads some messages over lines; an error here is always one line.
        let msg = inner
            .message()
            .split_whitespace()
            .collect::<Vec<_>>()
            .join(" ");
        let at = inner
            .span()
            .map(|s| {
                let line = text[..s.start.min(text.len())].matches('\n').count() + 1;
                format!(" (line {line})")
            })
            .unwrap_or_default();
        ctx.err(
            if key == "." { String::new() } else { key },
            format!("{msg}{at}"),
        )
    })?;
    let description = describe(parsed, &ctx, base)?;
    // Only a file that spells an alias is read a second time, as a plain table.
    let warnings = if FRICTION_ALIASES.iter().any(|a| text.contains(a)) {
        let table: toml::Table = text.parse().unwrap_or_default();
        friction_alias_warnings(table.get("interaction"), file)
    } else {
        Vec::new()
    };
    Ok((description, warnings))
}

/// Other names `rolling_friction` is read under (serde aliases of [`InteractionEntry`]).
const FRICTION_ALIASES: [&str; 2] = ["dynamic_friction", "kinetic_friction"];

/// A warning for each `[[interaction]]` that gives rolling friction under another name. The
/// calibration papers written with EDEM call rolling friction "dynamic friction", which is what
/// the alias is for; but in mechanics "dynamic" or "kinetic" friction is the sliding coefficient,
/// and a user who means that would silently set rolling friction instead.
fn friction_alias_warnings(interactions: Option<&toml::Value>, file: &str) -> Vec<String> {
    let Some(list) = interactions.and_then(toml::Value::as_array) else {
        return Vec::new();
    };
    let mut warnings = Vec::new();
    for (k, entry) in list.iter().enumerate() {
        for alias in FRICTION_ALIASES {
            if entry.get(alias).is_some() {
                warnings.push(format!(
                    "{file}: interaction[{k}].{alias}: read as rolling friction, as EDEM and the calibration papers use the name; sliding (kinetic) friction is static_friction here. Write rolling_friction to silence this warning"
                ));
            }
        }
    }
    warnings
}

/// Reads `value` as `T` (a section of a scene already read as TOML); errors name the key after
/// `prefix`.
fn from_value<T: DeserializeOwned>(
    ctx: &Ctx,
    prefix: &str,
    value: toml::Value,
) -> Result<T, SceneError> {
    serde_path_to_error::deserialize(value).map_err(|e| {
        let path = e.path().to_string();
        let msg = e
            .into_inner()
            .to_string()
            .split_whitespace()
            .collect::<Vec<_>>()
            .join(" ");
        // toml's value errors end with " in `key`", which the key in front already says.
        let msg = match msg.rfind(" in `") {
            Some(i) if msg.ends_with('`') => msg[..i].to_string(),
            _ => msg,
        };
        let key = match (prefix.is_empty(), path == "." || path.is_empty()) {
            (_, true) => prefix.to_string(),
            (true, false) => path,
            (false, false) if path.starts_with('[') => format!("{prefix}{path}"),
            (false, false) => format!("{prefix}.{path}"),
        };
        ctx.err(key, msg)
    })
}

/// The parts of a scene that a virtual test file carries in the scene format: `[[material]]`,
/// `[[interaction]]`, `[[particle_type]]` and `[[bond]]` (each may be absent).
#[derive(Clone, Debug, Default)]
pub struct SharedParts {
    pub materials: Vec<MaterialDescription>,
    pub interactions: Vec<InteractionDescription>,
    pub particle_types: Vec<ParticleTypeDescription>,
    pub bonds: Vec<BondDescription>,
    /// How the parts are written that the user should hear about (a friction alias); the
    /// command that reads the file prints them once.
    pub warnings: Vec<String>,
}

/// Reads the `material`, `interaction` and `particle_type` arrays of `table` (other keys are the
/// caller's); errors name `file` and the key as in a scene file (`material[1].density`).
/// `base` resolves relative paths inside (STL files of particle shapes).
pub fn shared_parts(
    table: &toml::Table,
    file: &str,
    base: &Path,
) -> Result<SharedParts, SceneError> {
    let ctx = Ctx { file };
    let get = |k: &str| table.get(k).cloned();
    let materials: Vec<MaterialEntry> = match get("material") {
        Some(v) => from_value(&ctx, "material", v)?,
        None => Vec::new(),
    };
    let interactions: Vec<InteractionEntry> = match get("interaction") {
        Some(v) => from_value(&ctx, "interaction", v)?,
        None => Vec::new(),
    };
    let types: Vec<ParticleTypeEntry> = match get("particle_type") {
        Some(v) => from_value(&ctx, "particle_type", v)?,
        None => Vec::new(),
    };
    let bond_entries: Vec<bonds::BondEntry> = match get("bond") {
        Some(v) => from_value(&ctx, "bond", v)?,
        None => Vec::new(),
    };
    Ok(SharedParts {
        warnings: friction_alias_warnings(table.get("interaction"), file),
        bonds: bonds::bonds(&ctx, bond_entries)?,
        materials: materials
            .into_iter()
            .enumerate()
            .map(|(k, m)| material(&ctx, k, m))
            .collect::<Result<_, _>>()?,
        interactions: interactions.into_iter().map(interaction).collect(),
        particle_types: types
            .into_iter()
            .enumerate()
            .map(|(k, t)| particle_type(&ctx, k, t, base))
            .collect::<Result<_, _>>()?,
    })
}

/// Reads which particles a group holds, as a scene's `[[particles]]` gives them without their
/// placement: one type inline (`material` with `size`, or `shape` and `scale`) or a mixture of
/// named types (`types`, `fractions`, `basis`). `key` names the table in errors; `base` resolves
/// relative paths inside.
pub fn group_particles(
    value: toml::Value,
    file: &str,
    key: &str,
    base: &Path,
) -> Result<GroupParticles, SceneError> {
    let ctx = Ctx { file };
    let e: GroupParticlesEntry = from_value(&ctx, key, value)?;
    particles::group_from_entry(&ctx, key, e, base)
}

/// Every section of a scene file, as `docs/reference.md` heads it, with the keys its reader
/// accepts (read from the structs below, so the reference is checked against them).
pub fn reference_sections() -> Vec<(&'static str, Vec<&'static str>)> {
    use crate::keys::of;
    let mut v = vec![
        ("scene file", of::<SceneFile>()),
        ("[simulation]", of::<SimulationSection>()),
        ("simulation.domain", of::<BoxEntry>()),
        ("[output]", of::<OutputSection>()),
        ("[[material]]", of::<MaterialEntry>()),
        ("[[interaction]]", of::<InteractionEntry>()),
        ("[[geometry]]", of::<GeometryEntry>()),
        ("geometry.motion", of::<MotionEntry>()),
    ];
    v.extend(particles::reference_sections());
    v.push(("[[bond]]", of::<bonds::BondEntry>()));
    v
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
struct SceneFile {
    simulation: SimulationSection,
    #[serde(default)]
    output: OutputSection,
    #[serde(rename = "material", default)]
    materials: Vec<MaterialEntry>,
    #[serde(rename = "interaction", default)]
    interactions: Vec<InteractionEntry>,
    #[serde(rename = "geometry", default)]
    geometries: Vec<GeometryEntry>,
    #[serde(rename = "particle_type", default)]
    particle_types: Vec<ParticleTypeEntry>,
    #[serde(rename = "particles", default)]
    particles: Vec<ParticleEntry>,
    #[serde(rename = "bond", default)]
    bonds: Vec<bonds::BondEntry>,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
struct SimulationSection {
    #[serde(deserialize_with = "crate::units::time::opt", default)]
    duration: Option<f64>,
    steps: Option<u64>,
    #[serde(deserialize_with = "crate::units::time::opt", default)]
    time_step: Option<f64>,
    time_step_percent: Option<f64>,
    #[serde(deserialize_with = "crate::units::acceleration::opt_three", default)]
    gravity: Option<V3>,
    contact_model: Option<String>,
    contact_parameters: Option<std::collections::BTreeMap<String, f64>>,
    rolling_friction_model: Option<String>,
    rolling_viscous_damping: Option<f64>,
    #[serde(deserialize_with = "crate::units::length::opt", default)]
    neighbour_skin: Option<f64>,
    domain: Option<BoxEntry>,
    max_initial_overlap: Option<f64>,
    #[serde(deserialize_with = "crate::units::speed::opt", default)]
    expected_max_speed: Option<f64>,
    backend: Option<String>,
}

#[derive(Deserialize, Debug, Clone, Copy)]
#[serde(deny_unknown_fields)]
struct BoxEntry {
    #[serde(deserialize_with = "crate::units::length::three")]
    min: V3,
    #[serde(deserialize_with = "crate::units::length::three")]
    max: V3,
}

#[derive(Deserialize, Debug, Default)]
#[serde(deny_unknown_fields)]
struct OutputSection {
    directory: Option<String>,
    #[serde(deserialize_with = "crate::units::time::opt", default)]
    snapshot_interval: Option<f64>,
    #[serde(deserialize_with = "crate::units::time::opt", default)]
    force_interval: Option<f64>,
    format: Option<String>,
    contacts: Option<bool>,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
struct MaterialEntry {
    name: String,
    #[serde(deserialize_with = "crate::units::density::one")]
    density: f64,
    poisson_ratio: f64,
    #[serde(deserialize_with = "crate::units::stress::opt", default)]
    shear_modulus: Option<f64>,
    #[serde(deserialize_with = "crate::units::stress::opt", default)]
    youngs_modulus: Option<f64>,
}

/// A pair of material names, exactly two (a fixed array would take the first two of three).
pub(super) fn material_pair<'de, D: serde::Deserializer<'de>>(
    d: D,
) -> Result<[String; 2], D::Error> {
    let names = Vec::<String>::deserialize(d)?;
    match <[String; 2]>::try_from(names) {
        Ok(pair) => Ok(pair),
        Err(names) => Err(serde::de::Error::custom(format!(
            "expected two material names, got {}",
            names.len()
        ))),
    }
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
struct InteractionEntry {
    #[serde(deserialize_with = "material_pair")]
    materials: [String; 2],
    restitution: f64,
    static_friction: f64,
    // The names in FRICTION_ALIASES; reading one gives a warning (friction_alias_warnings).
    #[serde(alias = "dynamic_friction", alias = "kinetic_friction")]
    rolling_friction: f64,
    /// JKR cohesion (J/m^2).
    #[serde(deserialize_with = "crate::units::surface_energy::one", default)]
    surface_energy: f64,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
struct GeometryEntry {
    name: Option<String>,
    #[serde(rename = "type")]
    kind: String,
    material: String,
    // plane
    #[serde(deserialize_with = "crate::units::length::opt_three", default)]
    point: Option<V3>,
    normal: Option<V3>,
    // box
    #[serde(deserialize_with = "crate::units::length::opt_three", default)]
    min: Option<V3>,
    #[serde(deserialize_with = "crate::units::length::opt_three", default)]
    max: Option<V3>,
    open: Option<Vec<String>>,
    // cylinder
    #[serde(deserialize_with = "crate::units::length::opt_three", default)]
    base: Option<V3>,
    axis: Option<V3>,
    #[serde(deserialize_with = "crate::units::length::opt", default)]
    radius: Option<f64>,
    #[serde(deserialize_with = "crate::units::length::opt", default)]
    length: Option<f64>,
    caps: Option<String>,
    // mesh
    file: Option<String>,
    scale: Option<f64>,
    #[serde(deserialize_with = "crate::units::length::opt_three", default)]
    offset: Option<V3>,
    #[serde(deserialize_with = "crate::units::length::opt_three", default)]
    torque_point: Option<V3>,
    #[serde(default)]
    motion: Vec<MotionEntry>,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
struct MotionEntry {
    #[serde(rename = "type")]
    kind: String,
    #[serde(deserialize_with = "crate::units::speed::opt_three", default)]
    velocity: Option<V3>,
    #[serde(deserialize_with = "crate::units::length::opt_three", default)]
    axis_point: Option<V3>,
    axis: Option<V3>,
    #[serde(deserialize_with = "crate::units::angular_speed::opt", default)]
    angular_velocity: Option<f64>,
    rpm: Option<f64>,
    #[serde(deserialize_with = "crate::units::time::opt", default)]
    start: Option<f64>,
    #[serde(deserialize_with = "crate::units::time::opt", default)]
    end: Option<f64>,
}

fn describe(f: SceneFile, ctx: &Ctx, base: &Path) -> Result<SceneDescription, SceneError> {
    let materials = f
        .materials
        .into_iter()
        .enumerate()
        .map(|(k, m)| material(ctx, k, m))
        .collect::<Result<_, _>>()?;
    let interactions = f.interactions.into_iter().map(interaction).collect();
    let simulation = simulation(ctx, f.simulation)?;
    let geometries = f
        .geometries
        .into_iter()
        .enumerate()
        .map(|(k, g)| geometry(ctx, k, g, base))
        .collect::<Result<_, _>>()?;
    let particle_types = f
        .particle_types
        .into_iter()
        .enumerate()
        .map(|(k, t)| particle_type(ctx, k, t, base))
        .collect::<Result<_, _>>()?;
    let particles = f
        .particles
        .into_iter()
        .enumerate()
        .map(|(k, p)| particle_group(ctx, k, p, base))
        .collect::<Result<_, _>>()?;
    let bonds = bonds::bonds(ctx, f.bonds)?;
    let o = f.output;
    let defaults = OutputDescription::default();
    Ok(SceneDescription {
        bonds,
        simulation,
        output: OutputDescription {
            directory: base.join(o.directory.as_deref().unwrap_or("out")),
            snapshot_interval: o.snapshot_interval,
            force_interval: o.force_interval,
            format: o.format.unwrap_or(defaults.format),
            contacts: o.contacts.unwrap_or(defaults.contacts),
        },
        materials,
        interactions,
        geometries,
        particle_types,
        particles,
    })
}

fn material(ctx: &Ctx, k: usize, m: MaterialEntry) -> Result<MaterialDescription, SceneError> {
    let key = |s: &str| format!("material[{k}].{s}");
    let stiffness = match (m.shear_modulus, m.youngs_modulus) {
        (Some(g), None) => Stiffness::ShearModulus(g),
        (None, Some(e)) => Stiffness::YoungsModulus(e),
        (Some(_), Some(_)) => {
            return Err(ctx.err(
                key("youngs_modulus"),
                "give shear_modulus or youngs_modulus, not both",
            ))
        }
        (None, None) => {
            return Err(ctx.err(
                key("shear_modulus"),
                "missing; expected shear_modulus (Pa) or youngs_modulus (Pa)",
            ))
        }
    };
    Ok(MaterialDescription {
        name: m.name,
        density: m.density,
        poisson_ratio: m.poisson_ratio,
        stiffness,
    })
}

fn interaction(i: InteractionEntry) -> InteractionDescription {
    InteractionDescription {
        materials: i.materials,
        restitution: i.restitution,
        static_friction: i.static_friction,
        rolling_friction: i.rolling_friction,
        surface_energy: i.surface_energy,
    }
}

fn simulation(ctx: &Ctx, s: SimulationSection) -> Result<SimulationSettings, SceneError> {
    let run_length = match (s.duration, s.steps) {
        (Some(t), None) => RunLength::Duration(t),
        (None, Some(n)) => RunLength::Steps(n),
        (Some(_), Some(_)) => {
            return Err(ctx.err("simulation.duration", "give duration or steps, not both"))
        }
        (None, None) => {
            return Err(ctx.err(
                "simulation.duration",
                "missing; expected duration (s) or steps",
            ))
        }
    };
    let time_step = match (s.time_step, s.time_step_percent) {
        (Some(dt), None) => TimeStep::Fixed(dt),
        (None, Some(p)) => TimeStep::PercentOfRayleigh(p),
        (None, None) => SimulationSettings::new(run_length).time_step,
        (Some(_), Some(_)) => {
            return Err(ctx.err(
                "simulation.time_step",
                "give time_step or time_step_percent, not both",
            ))
        }
    };
    let defaults = SimulationSettings::new(run_length);
    Ok(SimulationSettings {
        run_length,
        time_step,
        gravity: s.gravity.map(v3).unwrap_or(defaults.gravity),
        contact_model: s.contact_model.unwrap_or(defaults.contact_model),
        contact_parameters: s
            .contact_parameters
            .map(|t| t.into_iter().collect())
            .unwrap_or_default(),
        rolling_friction_model: s
            .rolling_friction_model
            .unwrap_or(defaults.rolling_friction_model),
        rolling_viscous_damping: s
            .rolling_viscous_damping
            .unwrap_or(defaults.rolling_viscous_damping),
        neighbour_skin: s.neighbour_skin,
        domain: s.domain.map(|d| Domain {
            min: v3(d.min),
            max: v3(d.max),
        }),
        max_initial_overlap: s
            .max_initial_overlap
            .unwrap_or(defaults.max_initial_overlap),
        expected_max_speed: s.expected_max_speed,
        backend: s.backend.unwrap_or(defaults.backend),
    })
}

fn geometry(
    ctx: &Ctx,
    k: usize,
    g: GeometryEntry,
    base: &Path,
) -> Result<GeometryDescription, SceneError> {
    let key = |s: &str| format!("geometry[{k}].{s}");
    let prefix = format!("geometry[{k}]");
    let given = [
        ("point", g.point.is_some()),
        ("normal", g.normal.is_some()),
        ("min", g.min.is_some()),
        ("max", g.max.is_some()),
        ("open", g.open.is_some()),
        ("base", g.base.is_some()),
        ("axis", g.axis.is_some()),
        ("radius", g.radius.is_some()),
        ("length", g.length.is_some()),
        ("caps", g.caps.is_some()),
        ("file", g.file.is_some()),
        ("scale", g.scale.is_some()),
        ("offset", g.offset.is_some()),
    ];
    let shape = match g.kind.as_str() {
        "plane" => {
            ctx.only(&prefix, "plane", &given, &["point", "normal"])?;
            let point = v3(ctx.require(g.point, key("point"), "a point [x, y, z] on the plane")?);
            let normal = v3(ctx.require(
                g.normal,
                key("normal"),
                "the normal [x, y, z] toward the particles",
            )?);
            GeometryShape::Plane { point, normal }
        }
        "box" => {
            ctx.only(&prefix, "box", &given, &["min", "max", "open"])?;
            let min = v3(ctx.require(g.min, key("min"), "the lower corner [x, y, z]")?);
            let max = v3(ctx.require(g.max, key("max"), "the upper corner [x, y, z]")?);
            GeometryShape::Box {
                min,
                max,
                open: g.open.unwrap_or_default(),
            }
        }
        "cylinder" => {
            ctx.only(
                &prefix,
                "cylinder",
                &given,
                &["base", "axis", "radius", "length", "caps"],
            )?;
            let base =
                v3(ctx.require(g.base, key("base"), "the centre of the bottom [x, y, z]")?);
            let radius = ctx.require(g.radius, key("radius"), "the radius (m)")?;
            let length = ctx.require(g.length, key("length"), "the length (m)")?;
            let (bottom_cap, top_cap) = match g.caps.as_deref().unwrap_or("none") {
                "none" => (false, false),
                "bottom" => (true, false),
                "top" => (false, true),
                "both" => (true, true),
                other => {
                    return Err(ctx.err(
                        key("caps"),
                        format!("unknown value \"{other}\" (expected none, bottom, top or both)"),
                    ))
                }
            };
            GeometryShape::Cylinder {
                base,
                axis: v3(g.axis.unwrap_or([0.0, 0.0, 1.0])),
                radius,
                length,
                bottom_cap,
                top_cap,
            }
        }
        "mesh" => {
            ctx.only(&prefix, "mesh", &given, &["file", "scale", "offset"])?;
            let file = g
                .file
                .as_ref()
                .ok_or_else(|| ctx.err(key("file"), "missing; expected the path of an STL file"))?;
            GeometryShape::Mesh {
                file: base.join(file),
                scale: g.scale.unwrap_or(1.0),
                offset: v3(g.offset.unwrap_or([0.0; 3])),
            }
        }
        other => {
            return Err(ctx.err(
                key("type"),
                format!(
                    "unknown geometry type \"{other}\" (expected plane, box, cylinder or mesh)"
                ),
            ))
        }
    };
    let mut motion = Vec::new();
    for (m, e) in g.motion.iter().enumerate() {
        let mk = |s: &str| format!("geometry[{k}].motion[{m}].{s}");
        let start = e.start.unwrap_or(0.0);
        let end = e.end.unwrap_or(f64::INFINITY);
        let given = [
            ("velocity", e.velocity.is_some()),
            ("axis_point", e.axis_point.is_some()),
            ("axis", e.axis.is_some()),
            ("angular_velocity", e.angular_velocity.is_some()),
            ("rpm", e.rpm.is_some()),
        ];
        let mprefix = format!("geometry[{k}].motion[{m}]");
        motion.push(match e.kind.as_str() {
            "translation" => {
                ctx.only(&mprefix, "translation", &given, &["velocity"])?;
                let velocity = v3(ctx.require(
                    e.velocity,
                    mk("velocity"),
                    "a velocity [vx, vy, vz] in m/s",
                )?);
                Motion::Translation {
                    velocity,
                    start,
                    end,
                }
            }
            "rotation" => {
                ctx.only(
                    &mprefix,
                    "rotation",
                    &given,
                    &["axis_point", "axis", "angular_velocity", "rpm"],
                )?;
                let axis = v3(ctx.require(e.axis, mk("axis"), "the rotation axis [x, y, z]")?);
                let angular_velocity = match (e.angular_velocity, e.rpm) {
                    (Some(w), None) => w,
                    (None, Some(rpm)) => rpm * std::f64::consts::TAU / 60.0,
                    (Some(_), Some(_)) => {
                        return Err(ctx.err(mk("rpm"), "give angular_velocity or rpm, not both"))
                    }
                    (None, None) => {
                        return Err(ctx.err(
                            mk("angular_velocity"),
                            "missing; expected angular_velocity (rad/s) or rpm",
                        ))
                    }
                };
                Motion::Rotation {
                    axis_point: v3(e.axis_point.unwrap_or([0.0; 3])),
                    axis,
                    angular_velocity,
                    start,
                    end,
                }
            }
            other => {
                return Err(ctx.err(
                    mk("type"),
                    format!("unknown motion \"{other}\" (expected translation or rotation)"),
                ))
            }
        });
    }
    // Loads are reported about the first axis point given, as a file reads.
    let default_point = g
        .motion
        .iter()
        .find_map(|m| m.axis_point)
        .unwrap_or([0.0; 3]);
    Ok(GeometryDescription {
        name: g.name.unwrap_or_else(|| format!("geometry{k}")),
        material: g.material,
        shape,
        motion,
        torque_point: Some(v3(g.torque_point.unwrap_or(default_point))),
    })
}
