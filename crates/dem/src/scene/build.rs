//! A [`SceneDescription`] into a ready [`Simulation`]: materials, geometry, particle types, the
//! time step (against the Rayleigh step of the smallest sphere any type can produce), the skin,
//! the domain, placement group by group, and the overlap checks. Every value is checked here, so
//! a description written in Rust gets the same one-line errors as a scene file, with the keys a
//! file would use.

use super::description::*;
use super::particles::{self, Planned};
use super::MAX_STEPS;
use super::{Ctx, OutputSettings, Scene, SceneError};
use crate::contact::{ContactModel, RollingModel};
use crate::factory::Factory;
use crate::geometry::Geometry;
use crate::material::{Interaction, Material, MaterialTable};
use crate::mixture::{self, Item, Mixture, ParticleType};
use crate::output::{Encoding, SnapshotOptions};
use crate::particles::Particles;
use crate::sim::{Simulation, SimulationParams, BACKEND_NAMES};
use crate::specimen::StalkSpecimen;
use crate::timestep;
use glam::DVec3;

/// Particle radii above this (m) look like millimetres typed as metres.
const LARGE_RADIUS: f64 = 0.5;
/// Geometry and fill regions larger than this (m) look like millimetres typed as metres.
const LARGE_GEOMETRY: f64 = 100.0;

/// One group, its particles resolved but not placed yet.
struct Group {
    mixture: Mixture,
    planned: Planned,
    velocity: DVec3,
}

pub(super) fn build(d: &SceneDescription, ctx: &Ctx) -> Result<Scene, SceneError> {
    let table = materials(d, ctx)?;
    let bonds = super::bonds::bonds(d, ctx, &table)?;
    let material_id = |name: &str, key: String| material_lookup(ctx, &table, name, key);

    // Simulation settings that the particles and walls need. The contact law is checked here
    // and nowhere else.
    let s = &d.simulation;
    let name = s.contact_model.as_str();
    let mut contact_model = ContactModel::from_name(name).ok_or_else(|| {
        ctx.err(
            "simulation.contact_model",
            format!(
                "unknown model \"{name}\" (expected one of: {})",
                ContactModel::NAMES.join(", ")
            ),
        )
    })?;
    for (key, value) in &s.contact_parameters {
        contact_model
            .set_parameter(key, *value)
            .map_err(|m| ctx.err(format!("simulation.contact_parameters.{key}"), m))?;
    }
    if !contact_model.cohesive() {
        if let Some(k) = d.interactions.iter().position(|i| i.surface_energy != 0.0) {
            return Err(ctx.err(
                format!("interaction[{k}].surface_energy"),
                format!(
                    "the {name} contact model has no cohesion; expected 0, or contact_model = \"hertz_mindlin\" (JKR)"
                ),
            ));
        }
    }
    if !BACKEND_NAMES.contains(&s.backend.as_str()) {
        return Err(ctx.err(
            "simulation.backend",
            format!(
                "unknown back end \"{}\" (expected {})",
                s.backend,
                BACKEND_NAMES.join(" or ")
            ),
        ));
    }
    let rolling_name = s.rolling_friction_model.as_str();
    let damping = s.rolling_viscous_damping;
    ctx.non_negative(damping, "simulation.rolling_viscous_damping".into())?;
    let rolling_model = RollingModel::from_name(rolling_name, damping).ok_or_else(|| {
        ctx.err(
            "simulation.rolling_friction_model",
            format!(
                "unknown model \"{rolling_name}\" (expected {})",
                RollingModel::NAMES.join(" or ")
            ),
        )
    })?;

    // Geometry.
    let mut warnings = Vec::new();
    super::unit_hints::check(d, &mut warnings);
    let mut geometries = Vec::new();
    for (k, g) in d.geometries.iter().enumerate() {
        let geo = super::geometry::build(ctx, k, g, &material_id)?;
        let size = super::geometry::extent(&geo);
        if size > LARGE_GEOMETRY {
            let hint = if matches!(g.shape, GeometryShape::Mesh { .. }) {
                "; an STL drawn in millimetres needs scale = 0.001"
            } else {
                ""
            };
            warnings.push(format!(
                "geometry[{k}]: \"{}\" is {size:.4} m across, which looks like the wrong unit: scene values are in metres ({size:.4} mm would be {:.4e}){hint}",
                geo.name,
                size / 1000.0
            ));
        }
        geometries.push(geo);
    }

    // Particle types: the named ones, then each group's (a mixture of named types, or one inline).
    let mut notes = Vec::new();
    let mut named: Vec<ParticleType> = Vec::new();
    for (k, t) in d.particle_types.iter().enumerate() {
        let prefix = format!("particle_type[{k}]");
        if named.iter().any(|n| n.name == t.name) {
            return Err(ctx.err(
                format!("{prefix}.name"),
                format!("particle type \"{}\" is defined twice", t.name),
            ));
        }
        let mat = material_id(&t.material, format!("{prefix}.material"))?;
        let density = table.material(mat).density;
        let built = particles::particle_type(
            ctx, &prefix, &t.name, mat, density, &t.shape, &t.size, &mut notes,
        )?;
        large_radius(&prefix, &built, &mut warnings);
        named.push(built);
    }
    let mut groups: Vec<Group> = Vec::new();
    let mut spheres = 0.0;
    for (k, p) in d.particles.iter().enumerate() {
        let mixture = match &p.particles {
            GroupParticles::Mixture {
                types,
                fractions,
                by_mass,
            } => particles::mixture_of(ctx, k, types, fractions.as_deref(), *by_mass, &named)?,
            GroupParticles::Inline {
                material,
                shape,
                size,
            } => {
                let prefix = format!("particles[{k}]");
                let mat = material_id(material, format!("{prefix}.material"))?;
                let density = table.material(mat).density;
                let built = particles::particle_type(
                    ctx, &prefix, &prefix, mat, density, shape, size, &mut notes,
                )?;
                large_radius(&prefix, &built, &mut warnings);
                Mixture::single(built)
            }
        };
        if let Placement::Lattice { region, .. } | Placement::Random { region, .. } = &p.placement {
            let (lo, hi) = region.bounds();
            let size = (hi - lo).max_element();
            if size > LARGE_GEOMETRY && size.is_finite() {
                warnings.push(format!(
                    "particles[{k}].region: {size:.4} m across, which looks like the wrong unit: scene values are in metres ({size:.4} mm would be {:.4e})",
                    size / 1000.0
                ));
            }
        }
        if let Placement::Specimen(specimen) = &p.placement {
            let size = specimen.length.max(specimen.diameter);
            if size > LARGE_GEOMETRY && size.is_finite() {
                warnings.push(format!(
                    "particles[{k}].fill: a stalk {size:.4} m across looks like the wrong unit: scene values are in metres ({size:.4} mm would be {:.4e})",
                    size / 1000.0
                ));
            }
        }
        let planned = particles::plan(ctx, k, &p.placement, &mixture, &mut spheres)
            .map_err(|e| with_unit_warnings(e, &warnings))?;
        if let (Placement::Specimen(specimen), Planned::Specimen { spheres }) =
            (&p.placement, &planned)
        {
            let volume: f64 = spheres
                .iter()
                .map(|s| 4.0 / 3.0 * std::f64::consts::PI * s.radius.powi(3))
                .sum();
            notes.push(format!(
                "particles[{k}]: stalk specimen of {} spheres ({} in the core), solid fraction {:.3}",
                spheres.len(),
                spheres.iter().filter(|s| s.core).count(),
                volume / specimen.volume()
            ));
        }
        // A specimen's core spheres are a second type: the group's, in the core's material.
        let mut mixture = mixture;
        if let Placement::Specimen(StalkSpecimen {
            core: Some(core), ..
        }) = &p.placement
        {
            let mat = material_id(&core.material, format!("particles[{k}].fill.core_material"))?;
            let rind = &mixture.types[0];
            let core_type = ParticleType::sphere(
                &format!("{} core", rind.name),
                mat,
                table.material(mat).density,
                rind.size.clone(),
            );
            mixture.types.push(core_type);
            mixture.fractions.push(0.0);
        }
        groups.push(Group {
            mixture,
            planned,
            velocity: p.velocity,
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
    let dt = match s.time_step {
        TimeStep::Fixed(dt) => ctx.positive(dt, "simulation.time_step".into())?,
        TimeStep::PercentOfRayleigh(p) => {
            ctx.positive(p, "simulation.time_step_percent".into())? / 100.0 * rayleigh
        }
    };
    if dt > rayleigh {
        let key = match s.time_step {
            TimeStep::Fixed(_) => "simulation.time_step",
            TimeStep::PercentOfRayleigh(_) => "simulation.time_step_percent",
        };
        return Err(ctx.err(key, format!(
            "time step {dt:.3e} s is larger than the Rayleigh time step {rayleigh:.3e} s; expected at most 100 % (EDEM users pick 10-40 %)"
        )));
    }
    let steps = match s.run_length {
        RunLength::Duration(t) => {
            let t = ctx.positive(t, "simulation.duration".into())?;
            let steps = (t / dt).round().max(1.0);
            if steps > MAX_STEPS as f64 {
                return Err(ctx.err(
                    "simulation.duration",
                    format!(
                        "{t} s takes {steps:.3e} time steps of {dt:.3e} s, more than the {MAX_STEPS:.0e} a run may take; expected a duration in seconds"
                    ),
                ));
            }
            steps as u64
        }
        RunLength::Steps(0) => return Err(ctx.err("simulation.steps", "expected a step count > 0")),
        RunLength::Steps(n) if n > MAX_STEPS => {
            return Err(ctx.err(
                "simulation.steps",
                format!("{n} steps are more than the {MAX_STEPS:.0e} a run may take"),
            ))
        }
        RunLength::Steps(n) => n,
    };
    let gravity = s.gravity;
    if !(gravity.is_finite() && gravity.length() <= super::MAX_GRAVITY) {
        return Err(ctx.err(
            "simulation.gravity",
            format!(
                "expected finite numbers (m/s²) of size at most {:e} (10 000 g), got [{}, {}, {}]",
                super::MAX_GRAVITY,
                gravity.x,
                gravity.y,
                gravity.z
            ),
        ));
    }
    let min_r = groups
        .iter()
        .map(|g| g.mixture.min_sphere_radius())
        .fold(f64::INFINITY, f64::min);
    let skin = match s.neighbour_skin {
        Some(v) => {
            let v = ctx.positive(v, "simulation.neighbour_skin".into())?;
            // A skin of many diameters puts every pair in the neighbour lists (1e300 was
            // taken): more than a few of the largest spheres' diameters only costs memory.
            let max_r = groups
                .iter()
                .map(|g| g.mixture.max_sphere_radius())
                .fold(0.0, f64::max);
            let most = MAX_SKIN_RADII * max_r;
            if max_r > 0.0 && v > most {
                return Err(ctx.err(
                    "simulation.neighbour_skin",
                    format!("expected at most {MAX_SKIN_RADII} times the largest sphere radius ({most:.4e} m), got {v:e} m"),
                ));
            }
            v
        }
        None => SimulationParams::default().skin_fraction * min_r,
    };
    let domain = match s.domain {
        Some(d) => {
            if !(d.min.cmplt(d.max).all()) {
                return Err(ctx.err(
                    "simulation.domain",
                    "expected min < max in every coordinate",
                ));
            }
            Some((d.min, d.max))
        }
        None => None,
    };

    // Hertz collision time at the fastest speed we can foresee: the fastest initial velocity or
    // a fall over the height of everything that starts or is created.
    let spawn: Vec<(DVec3, DVec3)> = groups
        .iter()
        .map(|g| g.planned.bounds(&g.mixture))
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
    let polyhedra = groups.iter().any(|g| {
        g.mixture
            .types
            .iter()
            .any(|t| matches!(t.shape, crate::mixture::Shape::Polyhedron { .. }))
    });
    if polyhedra {
        polyhedra_supported(d, ctx, &contact_model, &rolling_model)?;
    }
    let collision = timestep::shortest_collision_time(
        &contact_model,
        &smallest,
        &table,
        &geometry_materials,
        speed,
    );
    if collision / dt < 10.0 {
        warnings.push(format!(
            "only {:.1} time steps fit in the {} collision time {collision:.3e} s at {speed:.2} m/s; \
             contacts may be poorly resolved (aim for at least 10)",
            collision / dt,
            contact_model.name()
        ));
    }

    // Output.
    let o = &d.output;
    let snapshot_interval = match o.snapshot_interval {
        Some(v) => Some(ctx.positive(v, "output.snapshot_interval".into())?),
        None => None,
    };
    let force_interval = match o.force_interval {
        Some(v) => ctx.positive(v, "output.force_interval".into())?,
        None => (steps as f64 * dt / 1000.0).max(dt),
    };
    let encoding = match o.format.as_str() {
        "binary" => Encoding::Binary,
        "ascii" => Encoding::Ascii,
        other => {
            return Err(ctx.err(
                "output.format",
                format!("unknown format \"{other}\" (expected \"binary\" or \"ascii\")"),
            ))
        }
    };

    let max_overlap = ctx.non_negative(
        s.max_initial_overlap,
        "simulation.max_initial_overlap".into(),
    )?;
    let params = SimulationParams {
        time_step: dt,
        gravity,
        contact_model,
        rolling_model,
        rolling_viscous_damping: damping,
        skin,
        domain,
        max_initial_overlap: max_overlap,
        // What the chosen values are as fractions, for whoever reads the parameters back.
        time_step_fraction: dt / rayleigh,
        skin_fraction: skin / min_r,
        ..SimulationParams::default()
    };

    // Place the particles group by group, each avoiding those before it.
    let with_units = |e: SceneError| with_unit_warnings(e, &warnings);
    let mut simulation = Simulation::new(Particles::default(), table, geometries, params);
    let mut group_of: Vec<usize> = Vec::new();
    for (k, g) in groups.into_iter().enumerate() {
        let seed = |s: Option<u64>| s.unwrap_or(1) + k as u64;
        let specimen = matches!(g.planned, Planned::Specimen { .. });
        let items = match g.planned {
            Planned::Lattice { points, seed: s } => {
                let mut rng = <rand_pcg::Pcg64 as rand::SeedableRng>::seed_from_u64(s.unwrap_or(1));
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
            Planned::Specimen { spheres } => spheres
                .into_iter()
                .map(|s| Item {
                    kind: usize::from(s.core && g.mixture.types.len() > 1),
                    size: s.radius,
                    position: s.position,
                    orientation: glam::DQuat::IDENTITY,
                })
                .collect(),
            Planned::Random {
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
                    .map_err(|m| with_units(ctx.err(format!("particles[{k}].fill"), m)))?
            }
            Planned::Factory {
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
            let (key, place) = if specimen {
                (
                    "fill",
                    "specimen (its wall is thinner than the lattice can fill)",
                )
            } else {
                ("region", "region")
            };
            return Err(with_units(ctx.err(
                format!("particles[{k}].{key}"),
                format!("no particle fits in the {place}"),
            )));
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
            return Err(with_units(ctx.err(format!("particles[{ga}]"), format!(
                "particles overlap at start by {:.1} % of the smaller radius (particle {a} of particles[{ga}] and \
                 particle {b} of particles[{gb}]); at most {:.1} % allowed (simulation.max_initial_overlap)",
                100.0 * rel, 100.0 * max_overlap
            ))));
        }
    }
    if let Some((rel, a, g)) = simulation.largest_wall_overlap() {
        if rel > max_overlap {
            return Err(with_units(ctx.err(format!("particles[{}]", group_of[a as usize]), format!(
                "particle {a} overlaps geometry \"{g}\" at start by {:.1} % of its radius; at most {:.1} % allowed \
                 (simulation.max_initial_overlap)",
                100.0 * rel, 100.0 * max_overlap
            ))));
        }
    }
    if let Some(bonds) = bonds {
        super::bonds::attach(bonds, &mut simulation, ctx, &mut warnings, &mut notes)?;
    }
    // Last, so that the back end sees the whole scene when it says what it leaves to the CPU.
    warnings.extend(simulation.choose_backend(&s.backend));
    Ok(Scene {
        simulation,
        steps,
        output: OutputSettings {
            directory: o.directory.clone(),
            snapshot_interval,
            force_interval,
            snapshots: SnapshotOptions {
                encoding,
                contacts: o.contacts,
            },
        },
        rayleigh_time_step: rayleigh,
        collision_time: collision,
        warnings: {
            // A polyhedron made from a non-convex STL solid takes its hull: the user should see
            // that among the warnings, not only the notes.
            let mut warnings = warnings;
            warnings.extend(
                notes
                    .iter()
                    .filter(|n| n.contains(crate::polyhedron::NOT_CONVEX))
                    .cloned(),
            );
            warnings
        },
        notes: notes
            .into_iter()
            .filter(|n| !n.contains(crate::polyhedron::NOT_CONVEX))
            .collect(),
    })
}

/// Polyhedral particles reach the contact law as an equivalent Hertz contact whose effective
/// radius has no meaning beyond the Hertz-Mindlin stiffnesses (docs/physics.md, polyhedral
/// particles): laws and models that use that radius otherwise are refused.
fn polyhedra_supported(
    d: &SceneDescription,
    ctx: &Ctx,
    contact_model: &ContactModel,
    rolling_model: &RollingModel,
) -> Result<(), SceneError> {
    if contact_model.name() != "hertz_mindlin" {
        return Err(ctx.err(
            "simulation.contact_model",
            format!(
                "polyhedral particles take contact_model = \"hertz_mindlin\", not \"{}\"",
                contact_model.name()
            ),
        ));
    }
    if !matches!(rolling_model, RollingModel::ConstantDirectionalTorque) {
        return Err(ctx.err(
            "simulation.rolling_friction_model",
            "polyhedral particles take the constant directional torque (\"cdt\"), not epsd",
        ));
    }
    if let Some(k) = d.interactions.iter().position(|i| i.surface_energy != 0.0) {
        return Err(ctx.err(
            format!("interaction[{k}].surface_energy"),
            "JKR cohesion is not defined for polyhedral particles; expected 0",
        ));
    }
    Ok(())
}

/// The densities a material may have (kg/m³): far past any real one either way, and past the
/// mass-scaled ones (density_scaling multiplies by up to 1e8).
pub const MIN_DENSITY: f64 = 1e-3;
pub const MAX_DENSITY: f64 = 1e15;
/// The largest neighbour skin, in radii of the largest sphere.
pub const MAX_SKIN_RADII: f64 = 4.0;

/// The material table: every material, then every interaction.
pub(super) fn materials(d: &SceneDescription, ctx: &Ctx) -> Result<MaterialTable, SceneError> {
    let mut table = MaterialTable::new();
    if d.materials.is_empty() {
        return Err(ctx.err("material", "no [[material]] given; at least one is needed"));
    }
    for (k, m) in d.materials.iter().enumerate() {
        let key = |s: &str| format!("material[{k}].{s}");
        // Names head columns, files and messages: one printable line of reasonable length.
        let chars = m.name.chars().count();
        if chars == 0 || chars > 100 || m.name.chars().any(char::is_control) {
            return Err(ctx.err(
                key("name"),
                format!(
                    "expected 1 to 100 characters without line breaks or control characters, got {chars} characters"
                ),
            ));
        }
        if table.id_of(&m.name).is_some() {
            return Err(ctx.err(
                key("name"),
                format!("material \"{}\" is defined twice", m.name),
            ));
        }
        ctx.positive(m.density, key("density"))?;
        // Beyond these the masses and time steps leave f64 (1e-300 ended in NaN energies).
        if !(MIN_DENSITY..=MAX_DENSITY).contains(&m.density) {
            return Err(ctx.err(
                key("density"),
                format!(
                    "expected {MIN_DENSITY:e} to {MAX_DENSITY:e} kg/m³, got {:e}",
                    m.density
                ),
            ));
        }
        if !(m.poisson_ratio > -1.0 && m.poisson_ratio < 0.5) {
            return Err(ctx.err(
                key("poisson_ratio"),
                format!("expected a value in (-1, 0.5), got {}", m.poisson_ratio),
            ));
        }
        let shear = match m.stiffness {
            Stiffness::ShearModulus(g) => ctx.positive(g, key("shear_modulus"))?,
            Stiffness::YoungsModulus(e) => {
                ctx.positive(e, key("youngs_modulus"))? / (2.0 * (1.0 + m.poisson_ratio))
            }
        };
        if !(super::MIN_SHEAR_MODULUS..=super::MAX_SHEAR_MODULUS).contains(&shear) {
            let which = match m.stiffness {
                Stiffness::ShearModulus(_) => "shear_modulus",
                Stiffness::YoungsModulus(_) => "youngs_modulus",
            };
            return Err(ctx.err(
                key(which),
                format!(
                    "a shear modulus of {shear:e} Pa: expected {:e} to {:e} Pa",
                    super::MIN_SHEAR_MODULUS,
                    super::MAX_SHEAR_MODULUS
                ),
            ));
        }
        table.add_material(Material {
            name: m.name.clone(),
            density: m.density,
            poisson_ratio: m.poisson_ratio,
            shear_modulus: shear,
        });
    }
    let mut interactions: Vec<(usize, usize, Interaction)> = Vec::new();
    for (k, i) in d.interactions.iter().enumerate() {
        let key = |s: &str| format!("interaction[{k}].{s}");
        let a = material_lookup(ctx, &table, &i.materials[0], key("materials"))?;
        let b = material_lookup(ctx, &table, &i.materials[1], key("materials"))?;
        // A second table for the same pair silently replaced the first, so the result hung on
        // their order.
        if let Some(j) = interactions
            .iter()
            .position(|(x, y, _)| (*x, *y) == (a, b) || (*x, *y) == (b, a))
        {
            return Err(ctx.err(
                key("materials"),
                format!(
                    "[{}, {}] is already given by interaction[{j}]: one [[interaction]] per pair of materials",
                    i.materials[0], i.materials[1]
                ),
            ));
        }
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
    Ok(table)
}

/// Warns when a type's spheres are so large that its sizes were probably meant as millimetres.
fn large_radius(prefix: &str, t: &ParticleType, warnings: &mut Vec<String>) {
    let r = t.max_sphere_radius();
    if r > LARGE_RADIUS {
        warnings.push(format!(
            "{prefix}: particle spheres of radius up to {r:.4} m look like the wrong unit: scene values are in metres ({r:.4} mm would be {:.4e})",
            r / 1000.0
        ));
    }
}

/// Adds the unit warnings to an error they may explain (a fill that does not fit).
fn with_unit_warnings(mut e: SceneError, warnings: &[String]) -> SceneError {
    let units: Vec<&str> = warnings
        .iter()
        .filter(|w| w.contains("wrong unit"))
        .map(String::as_str)
        .collect();
    if !units.is_empty() {
        e.message = format!("{}; note: {}", e.message, units.join("; "));
    }
    e
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
