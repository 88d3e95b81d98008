//! Scene files (TOML): materials, interactions, geometry, particles and run settings.
//!
//! Loading is two steps: serde reads the file into plain structs that reject unknown keys (with
//! `serde_path_to_error` supplying the key path), then [`Scene::build`] checks every value and builds
//! the [`Simulation`]. Every failure is one [`SceneError`] line naming the file, the key and what was
//! expected.

use crate::clump::ClumpTemplate;
use crate::contact::{ContactModel, RollingModel};
use crate::factory::{perpendicular_axes, Factory, FactoryShape, Rate};
use crate::fill::{self, Lattice, Region, SizeDistribution};
use crate::geometry::{self, shapes, Element, Geometry, Motion};
use crate::kernel::KernelShape;
use crate::material::{Interaction, Material, MaterialTable};
use crate::mixture::{self, FillTarget, Item, Mixture, ParticleType};
use crate::particles::Particles;
use crate::sim::{Simulation, SimulationParams};
use crate::timestep;
use glam::DVec3;
use serde::Deserialize;
use std::path::{Path, PathBuf};

/// A scene file problem: `file: key: message`.
#[derive(Clone, Debug, PartialEq)]
pub struct SceneError {
    pub file: String,
    pub key: String,
    pub message: String,
}

impl std::fmt::Display for SceneError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.key.is_empty() {
            write!(f, "{}: {}", self.file, self.message)
        } else {
            write!(f, "{}: {}: {}", self.file, self.key, self.message)
        }
    }
}

impl std::error::Error for SceneError {}

type V3 = [f64; 3];

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
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
struct SimulationSection {
    duration: Option<f64>,
    steps: Option<u64>,
    time_step: Option<f64>,
    time_step_percent: Option<f64>,
    gravity: Option<V3>,
    contact_model: Option<String>,
    rolling_friction_model: Option<String>,
    rolling_viscous_damping: Option<f64>,
    neighbour_skin: Option<f64>,
    domain: Option<BoxEntry>,
    max_initial_overlap: Option<f64>,
    expected_max_speed: Option<f64>,
}

#[derive(Deserialize, Debug, Clone, Copy)]
#[serde(deny_unknown_fields)]
struct BoxEntry {
    min: V3,
    max: V3,
}

#[derive(Deserialize, Debug, Default)]
#[serde(deny_unknown_fields)]
struct OutputSection {
    directory: Option<String>,
    snapshot_interval: Option<f64>,
    force_interval: Option<f64>,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
struct MaterialEntry {
    name: String,
    density: f64,
    poisson_ratio: f64,
    shear_modulus: Option<f64>,
    youngs_modulus: Option<f64>,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
struct InteractionEntry {
    materials: [String; 2],
    restitution: f64,
    static_friction: f64,
    #[serde(alias = "dynamic_friction", alias = "kinetic_friction")]
    rolling_friction: f64,
    /// JKR cohesion (J/m^2).
    #[serde(default)]
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
    point: Option<V3>,
    normal: Option<V3>,
    // box
    min: Option<V3>,
    max: Option<V3>,
    open: Option<Vec<String>>,
    // cylinder
    base: Option<V3>,
    axis: Option<V3>,
    radius: Option<f64>,
    length: Option<f64>,
    caps: Option<String>,
    // mesh
    file: Option<String>,
    scale: Option<f64>,
    offset: Option<V3>,
    torque_point: Option<V3>,
    #[serde(default)]
    motion: Vec<MotionEntry>,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
struct MotionEntry {
    #[serde(rename = "type")]
    kind: String,
    velocity: Option<V3>,
    axis_point: Option<V3>,
    axis: Option<V3>,
    angular_velocity: Option<f64>,
    rpm: Option<f64>,
    start: Option<f64>,
    end: Option<f64>,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
struct ParticleTypeEntry {
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
    length: Option<f64>,
    diameter: Option<f64>,
    count: Option<usize>,
    // spheres: [x, y, z, r] rows
    spheres: Option<Vec<[f64; 4]>>,
    // maize_kernel
    class: Option<String>,
    width: Option<f64>,
    height: Option<f64>,
    thickness: Option<f64>,
    upper_width: Option<f64>,
    lower_width: Option<f64>,
    upper_thickness: Option<f64>,
    lower_thickness: Option<f64>,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
struct ParticleEntry {
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
    velocity: Option<V3>,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
struct FactoryEntry {
    #[serde(rename = "type")]
    kind: String,
    #[serde(alias = "center")]
    centre: V3,
    normal: Option<V3>,
    radius: Option<f64>,
    size: Option<[f64; 2]>,
    u_axis: Option<V3>,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
struct SizeEntry {
    #[serde(rename = "type")]
    kind: String,
    /// `value` reads better for a clump's fixed scale factor.
    #[serde(alias = "value")]
    radius: Option<f64>,
    min: Option<f64>,
    max: Option<f64>,
    mean: Option<f64>,
    std: Option<f64>,
    radii: Option<Vec<f64>>,
    fractions: Option<Vec<f64>>,
    basis: Option<String>,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
struct RegionEntry {
    #[serde(rename = "type")]
    kind: String,
    min: Option<V3>,
    max: Option<V3>,
    base: Option<V3>,
    axis: Option<V3>,
    radius: Option<f64>,
    length: Option<f64>,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
struct FillEntry {
    #[serde(rename = "type")]
    kind: String,
    lattice: Option<String>,
    spacing: Option<f64>,
    origin: Option<V3>,
    count: Option<usize>,
    mass: Option<f64>,
    seed: Option<u64>,
    // factory
    rate: Option<f64>,
    mass_rate: Option<f64>,
    start: Option<f64>,
}

/// Output settings of a scene.
#[derive(Clone, Debug)]
pub struct OutputSettings {
    pub directory: PathBuf,
    /// Seconds between particle snapshots (None: only the first and last).
    pub snapshot_interval: Option<f64>,
    /// Seconds between geometry load records.
    pub force_interval: f64,
}

/// A loaded scene: the simulation ready to run and what to do with it.
pub struct Scene {
    pub simulation: Simulation,
    pub steps: u64,
    pub output: OutputSettings,
    pub rayleigh_time_step: f64,
    pub hertz_collision_time: f64,
    /// Non-fatal remarks (e.g. few steps per collision).
    pub warnings: Vec<String>,
    /// What was built that the user should know (e.g. each fitted kernel's volume error).
    pub notes: Vec<String>,
}

fn v3(a: V3) -> DVec3 {
    DVec3::from_array(a)
}

struct Ctx<'a> {
    file: &'a str,
}

impl Ctx<'_> {
    fn err(&self, key: impl Into<String>, message: impl Into<String>) -> SceneError {
        SceneError {
            file: self.file.to_string(),
            key: key.into(),
            message: message.into(),
        }
    }

    fn require<T: Copy>(&self, v: Option<T>, key: String, what: &str) -> Result<T, SceneError> {
        v.ok_or_else(|| self.err(key, format!("missing; expected {what}")))
    }

    fn positive(&self, v: f64, key: String) -> Result<f64, SceneError> {
        if v > 0.0 && v.is_finite() {
            Ok(v)
        } else {
            Err(self.err(key, format!("expected a positive number, got {v}")))
        }
    }

    fn non_negative(&self, v: f64, key: String) -> Result<f64, SceneError> {
        if v >= 0.0 && v.is_finite() {
            Ok(v)
        } else {
            Err(self.err(key, format!("expected a number >= 0, got {v}")))
        }
    }

    fn direction(&self, v: V3, key: String) -> Result<DVec3, SceneError> {
        let d = v3(v);
        if d.length() > 0.0 && d.is_finite() {
            Ok(d.normalize())
        } else {
            Err(self.err(key, "expected a non-zero direction vector"))
        }
    }

    /// Rejects keys that belong to other variants, so a typo in `type` is not silently ignored.
    fn only(
        &self,
        prefix: &str,
        kind: &str,
        given: &[(&str, bool)],
        allowed: &[&str],
    ) -> Result<(), SceneError> {
        for (name, present) in given {
            if *present && !allowed.contains(name) {
                return Err(self.err(
                    format!("{prefix}.{name}"),
                    format!(
                        "not used by type \"{kind}\" (expected one of: {})",
                        allowed.join(", ")
                    ),
                ));
            }
        }
        Ok(())
    }
}

impl Scene {
    /// Reads and builds a scene file. Relative paths inside (STL files, output directory) are taken
    /// relative to the file's folder.
    pub fn load(path: &Path) -> Result<Scene, SceneError> {
        let name = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|e| SceneError {
            file: name.clone(),
            key: String::new(),
            message: format!("cannot read the scene file: {e}"),
        })?;
        let base = path.parent().unwrap_or(Path::new(".")).to_path_buf();
        Scene::from_toml(&text, &name, &base)
    }

    /// Builds a scene from TOML text; `file` names it in errors, `base` resolves relative paths.
    pub fn from_toml(text: &str, file: &str, base: &Path) -> Result<Scene, SceneError> {
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
        Scene::build(parsed, &ctx, base)
    }

    fn build(f: SceneFile, ctx: &Ctx, base: &Path) -> Result<Scene, SceneError> {
        // Materials.
        let mut table = MaterialTable::new();
        if f.materials.is_empty() {
            return Err(ctx.err("material", "no [[material]] given; at least one is needed"));
        }
        for (k, m) in f.materials.iter().enumerate() {
            let key = |s: &str| format!("material[{k}].{s}");
            if table.id_of(&m.name).is_some() {
                return Err(ctx.err(
                    key("name"),
                    format!("material \"{}\" is defined twice", m.name),
                ));
            }
            ctx.positive(m.density, key("density"))?;
            if !(m.poisson_ratio > -1.0 && m.poisson_ratio < 0.5) {
                return Err(ctx.err(
                    key("poisson_ratio"),
                    format!("expected a value in (-1, 0.5), got {}", m.poisson_ratio),
                ));
            }
            let shear = match (m.shear_modulus, m.youngs_modulus) {
                (Some(g), None) => ctx.positive(g, key("shear_modulus"))?,
                (None, Some(e)) => {
                    ctx.positive(e, key("youngs_modulus"))? / (2.0 * (1.0 + m.poisson_ratio))
                }
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
            table.add_material(Material {
                name: m.name.clone(),
                density: m.density,
                poisson_ratio: m.poisson_ratio,
                shear_modulus: shear,
            });
        }
        let material_id = |name: &str, key: String| material_lookup(ctx, &table, name, key);
        let mut interactions = Vec::new();
        for (k, i) in f.interactions.iter().enumerate() {
            let key = |s: &str| format!("interaction[{k}].{s}");
            let a = material_id(&i.materials[0], key("materials"))?;
            let b = material_id(&i.materials[1], key("materials"))?;
            if !(i.restitution > 0.0 && i.restitution <= 1.0) {
                return Err(ctx.err(
                    key("restitution"),
                    format!("expected a value in (0, 1], got {}", i.restitution),
                ));
            }
            ctx.non_negative(i.static_friction, key("static_friction"))?;
            ctx.non_negative(i.rolling_friction, key("rolling_friction"))?;
            ctx.non_negative(i.surface_energy, key("surface_energy"))?;
            interactions.push((
                a,
                b,
                Interaction {
                    restitution: i.restitution,
                    static_friction: i.static_friction,
                    rolling_friction: i.rolling_friction,
                    surface_energy: i.surface_energy,
                },
            ));
        }
        for (a, b, i) in interactions {
            table.set_interaction(a, b, i);
        }
        let material_id = |name: &str, key: String| material_lookup(ctx, &table, name, key);

        // Simulation settings that the particles and walls need.
        let s = &f.simulation;
        let contact_model = s.contact_model.as_deref().unwrap_or("hertz_mindlin");
        let contact_model = ContactModel::from_name(contact_model).ok_or_else(|| {
            ctx.err(
                "simulation.contact_model",
                format!(
                    "unknown model \"{contact_model}\" (expected one of: {})",
                    ContactModel::NAMES.join(", ")
                ),
            )
        })?;
        let rolling_name = s.rolling_friction_model.as_deref().unwrap_or("cdt");
        let damping = s.rolling_viscous_damping.unwrap_or(0.3);
        ctx.non_negative(damping, "simulation.rolling_viscous_damping".into())?;
        let rolling_model = RollingModel::from_name(rolling_name, damping).ok_or_else(|| {
            ctx.err(
                "simulation.rolling_friction_model",
                format!("unknown model \"{rolling_name}\" (expected cdt or epsd)"),
            )
        })?;

        // Geometry.
        let mut geometries = Vec::new();
        for (k, g) in f.geometries.iter().enumerate() {
            geometries.push(build_geometry(ctx, k, g, base, &material_id)?);
        }

        // Particle types: the named ones, then each group's (a mixture of named types, or one inline).
        let mut notes = Vec::new();
        let mut named: Vec<ParticleType> = Vec::new();
        for (k, t) in f.particle_types.iter().enumerate() {
            let prefix = format!("particle_type[{k}]");
            if named.iter().any(|n| n.name == t.name) {
                return Err(ctx.err(
                    format!("{prefix}.name"),
                    format!("particle type \"{}\" is defined twice", t.name),
                ));
            }
            let mat = material_id(&t.material, format!("{prefix}.material"))?;
            let density = table.material(mat).density;
            let parts = TypeParts {
                shape: t.shape.as_ref(),
                size: t.size.as_ref(),
                scale: t.scale.as_ref(),
            };
            named.push(build_type(
                ctx, &prefix, &t.name, mat, density, parts, &mut notes,
            )?);
        }
        let mut groups: Vec<Group> = Vec::new();
        for (k, p) in f.particles.iter().enumerate() {
            let key = |s: &str| format!("particles[{k}].{s}");
            let mixture = match (&p.types, &p.material) {
                (Some(names), None) => {
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
                    if names.is_empty() {
                        return Err(
                            ctx.err(key("types"), "expected at least one particle type name")
                        );
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
                    let fractions = match &p.fractions {
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
                    let by_mass = match p.basis.as_deref().unwrap_or("number") {
                        "number" => false,
                        "mass" => true,
                        other => {
                            return Err(ctx.err(
                                key("basis"),
                                format!("unknown basis \"{other}\" (expected number or mass)"),
                            ))
                        }
                    };
                    Mixture {
                        types,
                        fractions,
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
                    let mat = material_id(material, key("material"))?;
                    let density = table.material(mat).density;
                    let parts = TypeParts {
                        shape: p.shape.as_ref(),
                        size: p.size.as_ref(),
                        scale: p.scale.as_ref(),
                    };
                    let prefix = format!("particles[{k}]");
                    Mixture::single(build_type(
                        ctx, &prefix, &prefix, mat, density, parts, &mut notes,
                    )?)
                }
                (Some(_), Some(_)) => return Err(ctx.err(
                    key("types"),
                    "give types (named [[particle_type]]s) or material (one type inline), not both",
                )),
                (None, None) => {
                    return Err(ctx.err(
                        key("material"),
                        "missing; expected material (with size, or shape) or types",
                    ))
                }
            };
            let placement = build_placement(ctx, k, p, &mixture)?;
            groups.push(Group {
                mixture,
                placement,
                velocity: v3(p.velocity.unwrap_or([0.0; 3])),
            });
        }
        if groups.is_empty() {
            return Err(ctx.err(
                "particles",
                "no [[particles]] given; at least one group is needed",
            ));
        }

        // Every pair that can meet needs an interaction.
        let mut particle_materials: Vec<usize> = groups
            .iter()
            .flat_map(|g| g.mixture.types.iter().map(|t| t.material))
            .collect();
        particle_materials.sort_unstable();
        particle_materials.dedup();
        let mut geometry_materials: Vec<usize> =
            geometries.iter().map(|g: &Geometry| g.material).collect();
        geometry_materials.sort_unstable();
        geometry_materials.dedup();
        for &a in &particle_materials {
            for &b in particle_materials.iter().chain(&geometry_materials) {
                if table.interaction(a, b).is_none() {
                    return Err(ctx.err(
                        "interaction",
                        format!(
                            "no [[interaction]] for materials \"{}\" and \"{}\", which can touch",
                            table.material(a).name,
                            table.material(b).name
                        ),
                    ));
                }
            }
        }

        // Time step, from the smallest sphere each type can produce.
        let smallest: Vec<(usize, f64, f64)> = groups
            .iter()
            .flat_map(|g| g.mixture.types.iter())
            .map(|t| {
                (
                    t.material,
                    t.min_sphere_radius(),
                    t.mass(t.size.min_radius()),
                )
            })
            .collect();
        let smallest_radii: Vec<(usize, f64)> = smallest.iter().map(|s| (s.0, s.1)).collect();
        let rayleigh = timestep::rayleigh_time_step_for(&table, &smallest_radii);
        let dt = match (s.time_step, s.time_step_percent) {
            (Some(dt), None) => ctx.positive(dt, "simulation.time_step".into())?,
            (None, Some(p)) => {
                ctx.positive(p, "simulation.time_step_percent".into())? / 100.0 * rayleigh
            }
            (None, None) => 0.2 * rayleigh,
            (Some(_), Some(_)) => {
                return Err(ctx.err(
                    "simulation.time_step",
                    "give time_step or time_step_percent, not both",
                ))
            }
        };
        if dt > rayleigh {
            let key = if s.time_step.is_some() {
                "simulation.time_step"
            } else {
                "simulation.time_step_percent"
            };
            return Err(ctx.err(key, format!(
                "time step {dt:.3e} s is larger than the Rayleigh time step {rayleigh:.3e} s; expected at most 100 % (EDEM users pick 10-40 %)"
            )));
        }
        let steps = match (s.duration, s.steps) {
            (Some(t), None) => (ctx.positive(t, "simulation.duration".into())? / dt)
                .round()
                .max(1.0) as u64,
            (None, Some(n)) if n > 0 => n,
            (None, Some(_)) => return Err(ctx.err("simulation.steps", "expected a step count > 0")),
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
        let gravity = v3(s.gravity.unwrap_or([0.0, 0.0, -9.81]));
        let min_r = groups
            .iter()
            .map(|g| g.mixture.min_sphere_radius())
            .fold(f64::INFINITY, f64::min);
        let skin = match s.neighbour_skin {
            Some(v) => ctx.positive(v, "simulation.neighbour_skin".into())?,
            None => 0.3 * min_r,
        };
        let domain = match s.domain {
            Some(d) => {
                if !(v3(d.min).cmplt(v3(d.max)).all()) {
                    return Err(ctx.err(
                        "simulation.domain",
                        "expected min < max in every coordinate",
                    ));
                }
                Some((v3(d.min), v3(d.max)))
            }
            None => None,
        };

        // Hertz collision time at the fastest speed we can foresee: the fastest initial velocity or
        // a fall over the height of everything that starts or is created.
        let spawn: Vec<(DVec3, DVec3)> = groups
            .iter()
            .map(|g| g.placement.bounds(&g.mixture))
            .collect();
        let height: f64 = {
            let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
            let gdir = if gravity.length() > 0.0 {
                gravity.normalize()
            } else {
                DVec3::Z
            };
            for (a, b) in &spawn {
                for x in [*a, *b] {
                    lo = lo.min(x.dot(gdir));
                    hi = hi.max(x.dot(gdir));
                }
            }
            hi - lo
        };
        let initial_speed = groups
            .iter()
            .map(|g| g.velocity.length())
            .fold(0.0, f64::max);
        let fall_speed = (2.0 * gravity.length() * height).sqrt();
        let speed = match s.expected_max_speed {
            Some(v) => ctx.positive(v, "simulation.expected_max_speed".into())?,
            None => initial_speed.max(fall_speed).max(0.1),
        };
        let hertz = timestep::shortest_collision_time(
            &contact_model,
            &smallest,
            &table,
            &geometry_materials,
            speed,
        );
        let mut warnings = Vec::new();
        if hertz / dt < 10.0 {
            warnings.push(format!(
                "only {:.1} time steps fit in the {} collision time {hertz:.3e} s at {speed:.2} m/s; \
                 contacts may be poorly resolved (aim for at least 10)",
                hertz / dt,
                contact_model.name()
            ));
        }

        // Output.
        let o = &f.output;
        let directory = base.join(o.directory.as_deref().unwrap_or("out"));
        let snapshot_interval = match o.snapshot_interval {
            Some(v) => Some(ctx.positive(v, "output.snapshot_interval".into())?),
            None => None,
        };
        let force_interval = match o.force_interval {
            Some(v) => ctx.positive(v, "output.force_interval".into())?,
            None => (steps as f64 * dt / 1000.0).max(dt),
        };

        let max_overlap = ctx.non_negative(
            s.max_initial_overlap.unwrap_or(0.01),
            "simulation.max_initial_overlap".into(),
        )?;
        let params = SimulationParams {
            time_step: dt,
            gravity,
            contact_model,
            rolling_model,
            skin,
            domain,
            ..Default::default()
        };

        // Place the particles group by group, each avoiding those before it.
        let mut simulation = Simulation::new(Particles::default(), table, geometries, params);
        let mut group_of: Vec<usize> = Vec::new();
        for (k, g) in groups.into_iter().enumerate() {
            let seed = |s: Option<u64>| s.unwrap_or(1) + k as u64;
            let items = match g.placement {
                Placement::Lattice { points, seed: s } => {
                    let mut rng =
                        <rand_pcg::Pcg64 as rand::SeedableRng>::seed_from_u64(s.unwrap_or(1));
                    let t = &g.mixture.types[0];
                    points
                        .into_iter()
                        .map(|x| Item {
                            kind: 0,
                            size: t.size.sample(&mut rng),
                            position: x,
                            orientation: glam::DQuat::IDENTITY,
                        })
                        .collect()
                }
                Placement::Random {
                    region,
                    target,
                    seed: s,
                } => {
                    let p = &simulation.particles;
                    let existing: Vec<(DVec3, f64)> = p
                        .position
                        .iter()
                        .cloned()
                        .zip(p.radius.iter().cloned())
                        .collect();
                    mixture::fill_region(&region, &g.mixture, target, seed(s), &existing)
                        .map_err(|m| ctx.err(format!("particles[{k}].fill"), m))?
                }
                Placement::Factory {
                    shape,
                    normal,
                    total,
                    rate,
                    start,
                    seed: s,
                } => {
                    simulation.add_factory(Factory::new(
                        &format!("particles[{k}]"),
                        shape,
                        normal,
                        g.mixture,
                        total,
                        rate,
                        start,
                        g.velocity,
                        seed(s),
                    ));
                    continue;
                }
            };
            if items.is_empty() {
                return Err(ctx.err(
                    format!("particles[{k}].region"),
                    "no particle fits in the region",
                ));
            }
            simulation.add_items(&g.mixture, &items, g.velocity);
            group_of.resize(simulation.particles.len(), k);
        }
        if simulation.params.domain.is_none() {
            let mut d = default_domain(&simulation.particles, &simulation.geometries);
            for f in simulation.factories() {
                let (lo, hi) = f.bounds();
                let ext = (hi - lo).max_element();
                d = (
                    d.0.min(lo - DVec3::splat(ext)),
                    d.1.max(hi + DVec3::splat(ext)),
                );
            }
            simulation.params.domain = Some(d);
        }
        if let Some((rel, a, b)) = simulation.largest_relative_overlap() {
            if rel > max_overlap {
                let (ga, gb) = (group_of[a as usize], group_of[b as usize]);
                return Err(ctx.err(format!("particles[{ga}]"), format!(
                    "particles overlap at start by {:.1} % of the smaller radius (particle {a} of particles[{ga}] and \
                     particle {b} of particles[{gb}]); at most {:.1} % allowed (simulation.max_initial_overlap)",
                    100.0 * rel, 100.0 * max_overlap
                )));
            }
        }
        if let Some((rel, a, g)) = simulation.largest_wall_overlap() {
            if rel > max_overlap {
                return Err(ctx.err(format!("particles[{}]", group_of[a as usize]), format!(
                    "particle {a} overlaps geometry \"{g}\" at start by {:.1} % of its radius; at most {:.1} % allowed \
                     (simulation.max_initial_overlap)",
                    100.0 * rel, 100.0 * max_overlap
                )));
            }
        }
        Ok(Scene {
            simulation,
            steps,
            output: OutputSettings {
                directory,
                snapshot_interval,
                force_interval,
            },
            rayleigh_time_step: rayleigh,
            hertz_collision_time: hertz,
            warnings,
            notes,
        })
    }
}

/// The box holding the particles and every finite geometry, grown by its largest extent on every
/// side: a particle that gets out of it has been thrown out by an unstable simulation (or fell off
/// the set-up), and running on would waste the time of a study.
fn default_domain(particles: &Particles, geometries: &[Geometry]) -> (DVec3, DVec3) {
    let (mut lo, mut hi) = particles.bounds(true);
    for e in geometries.iter().flat_map(|g| &g.elements) {
        let (a, b) = e.bounds();
        if a.is_finite() && b.is_finite() {
            lo = lo.min(a);
            hi = hi.max(b);
        }
    }
    let pad = DVec3::splat((hi - lo).max_element());
    (lo - pad, hi + pad)
}

fn material_lookup(
    ctx: &Ctx,
    table: &MaterialTable,
    name: &str,
    key: String,
) -> Result<usize, SceneError> {
    table.id_of(name).ok_or_else(|| {
        let known: Vec<&str> = table.materials().iter().map(|m| m.name.as_str()).collect();
        ctx.err(
            key,
            format!(
                "unknown material \"{name}\" (defined: {})",
                known.join(", ")
            ),
        )
    })
}

fn build_geometry(
    ctx: &Ctx,
    k: usize,
    g: &GeometryEntry,
    base: &Path,
    material_id: &dyn Fn(&str, String) -> Result<usize, SceneError>,
) -> Result<Geometry, SceneError> {
    let key = |s: &str| format!("geometry[{k}].{s}");
    let prefix = format!("geometry[{k}]");
    let material = material_id(&g.material, key("material"))?;
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
    let elements: Vec<Element> = match g.kind.as_str() {
        "plane" => {
            ctx.only(&prefix, "plane", &given, &["point", "normal"])?;
            let point = v3(ctx.require(g.point, key("point"), "a point [x, y, z] on the plane")?);
            let normal = ctx.direction(
                ctx.require(
                    g.normal,
                    key("normal"),
                    "the normal [x, y, z] toward the particles",
                )?,
                key("normal"),
            )?;
            vec![Element::Plane { point, normal }]
        }
        "box" => {
            ctx.only(&prefix, "box", &given, &["min", "max", "open"])?;
            let lo = v3(ctx.require(g.min, key("min"), "the lower corner [x, y, z]")?);
            let hi = v3(ctx.require(g.max, key("max"), "the upper corner [x, y, z]")?);
            if !lo.cmplt(hi).all() {
                return Err(ctx.err(key("max"), "expected max > min in every coordinate"));
            }
            let open = g.open.clone().unwrap_or_default();
            for o in &open {
                if !["-x", "+x", "-y", "+y", "-z", "+z"].contains(&o.as_str()) {
                    return Err(ctx.err(
                        key("open"),
                        format!("unknown face \"{o}\" (expected -x, +x, -y, +y, -z, +z)"),
                    ));
                }
            }
            shapes::box_walls(lo, hi, &open)
        }
        "cylinder" => {
            ctx.only(
                &prefix,
                "cylinder",
                &given,
                &["base", "axis", "radius", "length", "caps"],
            )?;
            let b = v3(ctx.require(g.base, key("base"), "the centre of the bottom [x, y, z]")?);
            let axis = ctx.direction(g.axis.unwrap_or([0.0, 0.0, 1.0]), key("axis"))?;
            let radius = ctx.positive(
                ctx.require(g.radius, key("radius"), "the radius (m)")?,
                key("radius"),
            )?;
            let length = ctx.positive(
                ctx.require(g.length, key("length"), "the length (m)")?,
                key("length"),
            )?;
            let (bottom, top) = match g.caps.as_deref().unwrap_or("none") {
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
            shapes::cylinder(b, axis, radius, length, bottom, top)
        }
        "mesh" => {
            ctx.only(&prefix, "mesh", &given, &["file", "scale", "offset"])?;
            let file = g
                .file
                .as_ref()
                .ok_or_else(|| ctx.err(key("file"), "missing; expected the path of an STL file"))?;
            let path = base.join(file);
            if !path.exists() {
                return Err(ctx.err(
                    key("file"),
                    format!("STL file {} does not exist", path.display()),
                ));
            }
            let scale = ctx.positive(g.scale.unwrap_or(1.0), key("scale"))?;
            geometry::read_stl(&path, scale, v3(g.offset.unwrap_or([0.0; 3])))
                .map_err(|m| ctx.err(key("file"), format!("{}: {m}", path.display())))?
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
        let start = ctx.non_negative(e.start.unwrap_or(0.0), mk("start"))?;
        let end = e.end.unwrap_or(f64::INFINITY);
        if end <= start {
            return Err(ctx.err(
                mk("end"),
                format!("expected end > start ({start}), got {end}"),
            ));
        }
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
                let axis = ctx.direction(
                    ctx.require(e.axis, mk("axis"), "the rotation axis [x, y, z]")?,
                    mk("axis"),
                )?;
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
    let name = g.name.clone().unwrap_or_else(|| format!("geometry{k}"));
    let mut geo = Geometry::new(&name, material, elements).with_motion(motion);
    let default_point = g
        .motion
        .iter()
        .find_map(|m| m.axis_point)
        .unwrap_or([0.0; 3]);
    geo.torque_point = v3(g.torque_point.unwrap_or(default_point));
    Ok(geo)
}

fn build_size(ctx: &Ctx, prefix: &str, s: &SizeEntry) -> Result<SizeDistribution, SceneError> {
    let key = |n: &str| format!("{prefix}.{n}");
    let given = [
        ("radius", s.radius.is_some()),
        ("min", s.min.is_some()),
        ("max", s.max.is_some()),
        ("mean", s.mean.is_some()),
        ("std", s.std.is_some()),
        ("radii", s.radii.is_some()),
        ("fractions", s.fractions.is_some()),
        ("basis", s.basis.is_some()),
    ];
    Ok(match s.kind.as_str() {
        "fixed" => {
            ctx.only(prefix, "fixed", &given, &["radius"])?;
            let r = ctx.require(s.radius, key("radius"), "the particle radius (m)")?;
            SizeDistribution::Fixed { radius: ctx.positive(r, key("radius"))? }
        }
        "uniform" => {
            ctx.only(prefix, "uniform", &given, &["min", "max"])?;
            let min = ctx.positive(ctx.require(s.min, key("min"), "the smallest radius (m)")?, key("min"))?;
            let max = ctx.positive(ctx.require(s.max, key("max"), "the largest radius (m)")?, key("max"))?;
            if max < min {
                return Err(ctx.err(key("max"), format!("expected max >= min ({min}), got {max}")));
            }
            SizeDistribution::Uniform { min, max }
        }
        "normal" => {
            ctx.only(prefix, "normal", &given, &["mean", "std", "min", "max"])?;
            let mean = ctx.positive(ctx.require(s.mean, key("mean"), "the mean radius (m)")?, key("mean"))?;
            let std = ctx.non_negative(ctx.require(s.std, key("std"), "the standard deviation of the radius (m)")?, key("std"))?;
            let min = s.min.unwrap_or(mean - 3.0 * std);
            let max = s.max.unwrap_or(mean + 3.0 * std);
            ctx.positive(min, key("min")).map_err(|_| {
                ctx.err(key("min"), format!("the smallest radius {min} is not positive; give min, or a smaller std"))
            })?;
            if max < mean || min > mean {
                return Err(ctx.err(key("max"), "expected min <= mean <= max"));
            }
            if std == 0.0 {
                SizeDistribution::Fixed { radius: mean }
            } else {
                SizeDistribution::TruncatedNormal { mean, std, min, max }
            }
        }
        "classes" => {
            ctx.only(prefix, "classes", &given, &["radii", "fractions", "basis"])?;
            let radii = s.radii.clone().ok_or_else(|| ctx.err(key("radii"), "missing; expected a list of radii (m)"))?;
            let fractions = s.fractions.clone().ok_or_else(|| ctx.err(key("fractions"), "missing; expected a list of fractions"))?;
            if radii.is_empty() || radii.len() != fractions.len() {
                return Err(ctx.err(key("fractions"), format!("expected one fraction per radius ({} radii)", radii.len())));
            }
            for (i, r) in radii.iter().enumerate() {
                ctx.positive(*r, format!("{prefix}.radii[{i}]"))?;
            }
            for (i, f) in fractions.iter().enumerate() {
                ctx.non_negative(*f, format!("{prefix}.fractions[{i}]"))?;
            }
            if fractions.iter().sum::<f64>() <= 0.0 {
                return Err(ctx.err(key("fractions"), "expected fractions that sum to more than zero"));
            }
            let by_mass = match s.basis.as_deref().unwrap_or("number") {
                "number" => false,
                "mass" => true,
                other => return Err(ctx.err(key("basis"), format!("unknown basis \"{other}\" (expected number or mass)"))),
            };
            SizeDistribution::Classes { radii, fractions, by_mass }
        }
        other => {
            return Err(ctx.err(key("type"), format!("unknown size distribution \"{other}\" (expected fixed, uniform, normal or classes)")))
        }
    })
}

fn build_region(ctx: &Ctx, prefix: &str, r: &RegionEntry) -> Result<Region, SceneError> {
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
            let min = v3(ctx.require(r.min, key("min"), "the lower corner [x, y, z]")?);
            let max = v3(ctx.require(r.max, key("max"), "the upper corner [x, y, z]")?);
            if !min.cmplt(max).all() {
                return Err(ctx.err(key("max"), "expected max > min in every coordinate"));
            }
            Region::Box { min, max }
        }
        "cylinder" => {
            ctx.only(
                prefix,
                "cylinder",
                &given,
                &["base", "axis", "radius", "length"],
            )?;
            let base =
                v3(ctx.require(r.base, key("base"), "the centre of the bottom [x, y, z]")?);
            let axis = ctx.direction(r.axis.unwrap_or([0.0, 0.0, 1.0]), key("axis"))?;
            let radius = ctx.positive(
                ctx.require(r.radius, key("radius"), "the radius (m)")?,
                key("radius"),
            )?;
            let length = ctx.positive(
                ctx.require(r.length, key("length"), "the length (m)")?,
                key("length"),
            )?;
            Region::Cylinder {
                base,
                axis,
                radius,
                length,
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

/// The parts of a [[particle_type]] (or an inline one in [[particles]]).
struct TypeParts<'a> {
    shape: Option<&'a ShapeEntry>,
    size: Option<&'a SizeEntry>,
    scale: Option<&'a SizeEntry>,
}

/// One [[particles]] group, checked but not placed yet.
struct Group {
    mixture: Mixture,
    placement: Placement,
    velocity: DVec3,
}

enum Placement {
    Lattice {
        points: Vec<DVec3>,
        seed: Option<u64>,
    },
    Random {
        region: Region,
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
}

impl Placement {
    /// Where this group's particles start or are created.
    fn bounds(&self, mixture: &Mixture) -> (DVec3, DVec3) {
        match self {
            Placement::Lattice { points, .. } => points.iter().fold(
                (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
                |(lo, hi), p| (lo.min(*p), hi.max(*p)),
            ),
            Placement::Random { region, .. } => region.bounds(),
            Placement::Factory { shape, normal, .. } => {
                shape.slab_bounds(*normal, 2.0 * mixture.bounding_radius())
            }
        }
    }
}

fn build_type(
    ctx: &Ctx,
    prefix: &str,
    name: &str,
    material: usize,
    density: f64,
    parts: TypeParts,
    notes: &mut Vec<String>,
) -> Result<ParticleType, SceneError> {
    let key = |n: &str| format!("{prefix}.{n}");
    let shape_kind = parts.shape.map(|s| s.kind.as_str()).unwrap_or("sphere");
    if shape_kind == "sphere" {
        if let Some(sh) = parts.shape {
            shape_keys(ctx, &key("shape"), sh, &[])?;
        }
        if parts.scale.is_some() {
            return Err(ctx.err(
                key("scale"),
                "not used by a sphere (give its radius distribution as size)",
            ));
        }
        let size = parts
            .size
            .ok_or_else(|| ctx.err(key("size"), "missing; expected the radius distribution, e.g. { type = \"fixed\", radius = 0.002 }"))?;
        return Ok(ParticleType::sphere(
            name,
            material,
            density,
            build_size(ctx, &key("size"), size)?,
        ));
    }
    let sh = parts.shape.unwrap();
    if parts.size.is_some() {
        return Err(ctx.err(
            key("size"),
            "not used by a clump (its shape sets its size; give a scale distribution as scale)",
        ));
    }
    let scale = match parts.scale {
        Some(sc) => build_size(ctx, &key("scale"), sc)?,
        None => SizeDistribution::Fixed { radius: 1.0 },
    };
    let sk = |n: &str| format!("{prefix}.shape.{n}");
    let template = match shape_kind {
        "rod" => {
            shape_keys(ctx, &key("shape"), sh, &["length", "diameter", "count"])?;
            let length = ctx.positive(
                ctx.require(sh.length, sk("length"), "the rod length end to end (m)")?,
                sk("length"),
            )?;
            let diameter = ctx.positive(
                ctx.require(sh.diameter, sk("diameter"), "the rod diameter (m)")?,
                sk("diameter"),
            )?;
            let count = ctx.require(sh.count, sk("count"), "the number of spheres")?;
            ClumpTemplate::rod(length, diameter, count).map_err(|m| ctx.err(key("shape"), m))?
        }
        "spheres" => {
            shape_keys(ctx, &key("shape"), sh, &["spheres"])?;
            let rows = sh.spheres.as_ref().ok_or_else(|| {
                ctx.err(
                    sk("spheres"),
                    "missing; expected rows [x, y, z, radius] (m)",
                )
            })?;
            let mut spheres = Vec::new();
            for (i, r) in rows.iter().enumerate() {
                ctx.positive(r[3], format!("{prefix}.shape.spheres[{i}]"))?;
                spheres.push((DVec3::new(r[0], r[1], r[2]), r[3]));
            }
            ClumpTemplate::new(spheres).map_err(|m| ctx.err(sk("spheres"), m))?
        }
        "maize_kernel" => {
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
            let mut allowed = vec!["class", "count"];
            allowed.extend(kernel.dimensions_mut().into_iter().map(|(n, _)| n));
            shape_keys(ctx, &key("shape"), sh, &allowed)?;
            let given = shape_values(sh);
            for (name, v) in kernel.dimensions_mut() {
                if let Some(g) = given.iter().find(|(n, _)| *n == name).and_then(|(_, g)| *g) {
                    *v = ctx.positive(g, sk(name))?;
                }
            }
            let count = ctx.require(sh.count, sk("count"), "the number of spheres")?;
            let fit = kernel.fit(count).map_err(|m| ctx.err(key("shape"), m))?;
            notes.push(format!(
                "{prefix} (\"{name}\"): {class} maize kernel of {} spheres, volume {:.4e} m^3, {:+.1} % against the target solid ({:.4e} m^3)",
                fit.template.spheres.len(),
                fit.clump_volume,
                100.0 * fit.volume_error,
                fit.target_volume
            ));
            fit.template
        }
        other => {
            return Err(ctx.err(
                sk("type"),
                format!(
                    "unknown shape \"{other}\" (expected sphere, rod, spheres or maize_kernel)"
                ),
            ))
        }
    };
    Ok(ParticleType::clump(
        name, material, density, template, scale,
    ))
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
    ]);
    ctx.only(prefix, &s.kind, &given, allowed)
}

fn build_placement(
    ctx: &Ctx,
    k: usize,
    p: &ParticleEntry,
    mixture: &Mixture,
) -> Result<Placement, SceneError> {
    let key = |s: &str| format!("particles[{k}].{s}");
    let fk = |s: &str| format!("particles[{k}].fill.{s}");
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
    ];
    let target = || -> Result<FillTarget, SceneError> {
        match (fe.count, fe.mass) {
            (Some(n), None) if n > 0 => Ok(FillTarget::Count(n)),
            (Some(_), None) => Err(ctx.err(fk("count"), "expected a count > 0")),
            (None, Some(m)) => Ok(FillTarget::Mass(ctx.positive(m, fk("mass"))?)),
            (Some(_), Some(_)) => Err(ctx.err(fk("mass"), "give count or mass, not both")),
            (None, None) => Err(ctx.err(
                fk("count"),
                "missing; expected count (particles) or mass (kg)",
            )),
        }
    };
    let region = |what: &str| -> Result<Region, SceneError> {
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
        build_region(ctx, &key("region"), r)
    };
    Ok(match fe.kind.as_str() {
        "lattice" => {
            ctx.only(
                &key("fill"),
                "lattice",
                &given,
                &["lattice", "spacing", "origin", "seed"],
            )?;
            let region = region("lattice")?;
            if mixture.types.len() != 1 || !matches!(mixture.types[0].shape, mixture::Shape::Sphere)
            {
                return Err(ctx.err(fk("type"), "a lattice places spheres of one type; use a random fill or a factory for clumps and mixtures"));
            }
            let sizes = &mixture.types[0].size;
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
            let spacing = ctx.positive(
                fe.spacing.unwrap_or(2.0 * sizes.max_radius()),
                fk("spacing"),
            )?;
            if spacing < 2.0 * sizes.max_radius() * (1.0 - 1e-9) {
                return Err(ctx.err(fk("spacing"), format!(
                    "spacing {spacing} is smaller than the largest diameter {}; particles would overlap",
                    2.0 * sizes.max_radius()
                )));
            }
            let origin = fe.origin.map(v3).unwrap_or(region.bounds().0);
            Placement::Lattice {
                points: fill::lattice_points(&region, lattice, spacing, origin),
                seed: fe.seed,
            }
        }
        "random" => {
            ctx.only(&key("fill"), "random", &given, &["count", "mass", "seed"])?;
            Placement::Random {
                region: region("random")?,
                target: target()?,
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
            let normal = ctx.direction(fa.normal.unwrap_or([0.0, 0.0, -1.0]), fak("normal"))?;
            let centre = v3(fa.centre);
            let shape = match fa.kind.as_str() {
                "disc" => {
                    if fa.size.is_some() || fa.u_axis.is_some() {
                        return Err(ctx.err(
                            fak(if fa.size.is_some() { "size" } else { "u_axis" }),
                            "not used by a disc (give radius)",
                        ));
                    }
                    let radius = ctx.positive(
                        ctx.require(fa.radius, fak("radius"), "the disc radius (m)")?,
                        fak("radius"),
                    )?;
                    FactoryShape::Disc { centre, radius }
                }
                "rectangle" => {
                    if fa.radius.is_some() {
                        return Err(ctx.err(
                            fak("radius"),
                            "not used by a rectangle (give size = [a, b])",
                        ));
                    }
                    let size = ctx.require(fa.size, fak("size"), "the side lengths [a, b] (m)")?;
                    ctx.positive(size[0], fak("size"))?;
                    ctx.positive(size[1], fak("size"))?;
                    let u = match fa.u_axis {
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
                other => {
                    return Err(ctx.err(
                        fak("type"),
                        format!("unknown factory \"{other}\" (expected disc or rectangle)"),
                    ))
                }
            };
            let rate = match (fe.rate, fe.mass_rate) {
                (Some(r), None) => Rate::Count(ctx.positive(r, fk("rate"))?),
                (None, Some(r)) => Rate::Mass(ctx.positive(r, fk("mass_rate"))?),
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
            let start = ctx.non_negative(fe.start.unwrap_or(0.0), fk("start"))?;
            Placement::Factory {
                shape,
                normal,
                total: target()?,
                rate,
                start,
                seed: fe.seed,
            }
        }
        other => {
            return Err(ctx.err(
                fk("type"),
                format!("unknown fill \"{other}\" (expected lattice, random or factory)"),
            ))
        }
    })
}
