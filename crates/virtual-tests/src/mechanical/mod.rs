//! The mechanical tests of bonded stalks (docs/lab-tests.md sections 3-6): a bonded specimen, a
//! fixture, and a tool driven at a set speed while its force is recorded against its travel.
//!
//! Every test here shares one loop ([`load`]): the tool (a moving geometry, or a grip of spheres
//! driven at a set velocity) advances at `speed` until `max_displacement`, or until the force has
//! dropped below `stop_force_fraction` of its peak after the peak. The force-displacement curve is
//! the test's curve response (`force_displacement`); from it come the peak force, the mean force,
//! the initial stiffness (least-squares slope of the rising branch between 10 % and 50 % of the
//! peak), the displacement at the peak, and the bond counts. A quasi-static check compares the
//! specimen's kinetic energy with the work done: above 5 % between a tenth of the way to the peak
//! force (the blow of the touch itself does not count) and the peak (fragments
//! recoiling after failure do not count either) the run is marked not quasi-static: the outcome
//! carries a warning, and a study stores the run as failed (inertia shows in the curve; slow the
//! tool or lower `density_scaling`).
//!
//! An energy guard stops a run that creates energy: when the specimen's kinetic energy exceeds
//! twice the work done on it (by the tool and by gravity) plus its weight times its diameter, the
//! run has diverged (a step too long for the bonds, say), and it ends as such instead of
//! reporting the noise of an exploded specimen as a "peak force".
//!
//! The tool starts where it first touches the specimen: the approach is not simulated.
//!
//! The tests differ only in their fixture and tool: see [`tests`].

pub mod diagnostics;
pub mod tests;
mod watch;

use std::path::{Path, PathBuf};
use std::time::Instant;

use dem::bond::output::{write_bond_counts_csv, write_breakage_csv};
use dem::fill::SizeDistribution;
use dem::output::{SnapshotOptions, Snapshots};
use dem::scene::{GroupParticles, ParticleGroup, ParticleShape, Placement};
use dem::specimen::{Core, Packing, StalkSpecimen};
use dem::Simulation;
use glam::DVec3;
use serde::{Deserialize, Serialize};

use crate::file::TestFile;
use crate::harness::{self, Stop};
use crate::virtual_test::{Picture, Response, Run, TestError};
use diagnostics::{BondStress, Overlaps, Stage};
use watch::{Judged, Watch};

/// `specimen = { ... }`: a cylindrical stalk along x, centred at the origin.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct SpecimenSettings {
    /// The rind's (or the whole stalk's) material.
    pub material: String,
    /// Sphere radius (m): an hcp packing, or equal spheres packed at random.
    #[serde(deserialize_with = "dem::units::length::opt", default)]
    pub radius: Option<f64>,
    /// Radii (m) of a random packing's size classes, with their number `fractions`.
    #[serde(deserialize_with = "dem::units::length::opt_list", default)]
    pub radii: Option<Vec<f64>>,
    pub fractions: Option<Vec<f64>>,
    /// m.
    #[serde(deserialize_with = "dem::units::length::one")]
    pub length: f64,
    /// m.
    #[serde(deserialize_with = "dem::units::length::one")]
    pub diameter: f64,
    /// "hcp" (default) or "random".
    #[serde(default = "default_packing")]
    pub packing: String,
    /// hcp: nearest-neighbour distance (m); default one sphere diameter.
    #[serde(deserialize_with = "dem::units::length::opt", default)]
    pub spacing: Option<f64>,
    /// random: how many spheres.
    pub count: Option<usize>,
    /// m; default 0 (solid).
    #[serde(default)]
    #[serde(deserialize_with = "dem::units::length::one")]
    pub hollow_diameter: f64,
    /// Pith: spheres within `core_diameter` of the axis get this material.
    pub core_material: Option<String>,
    #[serde(deserialize_with = "dem::units::length::opt", default)]
    pub core_diameter: Option<f64>,
}

fn default_packing() -> String {
    "hcp".into()
}

/// How the tool is driven, common to every mechanical test.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct LoadingSettings {
    /// Tool speed (m/s).
    #[serde(deserialize_with = "dem::units::speed::one")]
    pub speed: f64,
    /// Travel at which the test ends (m).
    #[serde(deserialize_with = "dem::units::length::one")]
    pub max_displacement: f64,
    /// End early once the force has fallen below this fraction of its peak after the peak
    /// (0: run to `max_displacement`).
    #[serde(default)]
    pub stop_force_fraction: f64,
    /// Points on the curve (default 500 over `max_displacement`).
    #[serde(default = "default_points")]
    pub curve_points: usize,
    /// Time step as a percentage of the Rayleigh step (default 10 %, as the stalk studies).
    #[serde(default = "default_time_step_percent")]
    pub time_step_percent: f64,
    /// Snapshots for ParaView (particles, bonds, geometry; `particles.pvd` lists them) written
    /// into the output folder over the loading.
    #[serde(default)]
    pub snapshots: usize,
    /// Side views (SVG) of the specimen's middle slice at this many stages of the travel and at
    /// the peak force, broken bonds marked, written into the output folder.
    #[serde(default)]
    pub side_views: usize,
}

fn default_points() -> usize {
    500
}
fn default_time_step_percent() -> f64 {
    10.0
}

/// The most curve points and snapshots one run may ask for.
const MAX_CURVE_POINTS: usize = 1_000_000;
const MAX_SNAPSHOTS: usize = 10_000;
const MAX_SIDE_VIEWS: usize = 100;

/// Kinetic energy over work above which the loading is not quasi-static.
pub const QUASI_STATIC_LIMIT: f64 = 0.05;

/// Net force on the specimen over the peak force above which the loading is not quasi-static:
/// the tool and the fixture no longer hold the specimen between them, its inertia takes a share
/// of the tool's force. The kinetic energy alone misses a specimen so heavy that it hardly moves
/// while the tool tears the bonds next to it (docs/benchmarks.md has the runs).
pub const IMBALANCE_LIMIT: f64 = 0.05;

/// What every mechanical test measures (the keys of `demcal test --json`).
#[derive(Clone, Debug, Serialize)]
pub struct MechanicalOutcome {
    pub particles: usize,
    pub bonds: usize,
    pub bonds_broken: usize,
    pub bonds_broken_tension: usize,
    pub bonds_broken_shear: usize,
    pub peak_force_n: f64,
    pub mean_force_n: f64,
    pub stiffness_n_per_m: f64,
    pub displacement_at_peak_m: f64,
    /// Tool travel when the test ended.
    pub displacement_m: f64,
    /// Largest kinetic energy of the specimen over the work done so far, from a tenth of the
    /// way to the peak force up to the peak: the quasi-static check.
    pub kinetic_to_work_ratio: f64,
    /// The same over the whole run from a tenth of the way to the peak (after the peak too, where
    /// fragments recoil).
    pub max_kinetic_to_work_ratio: f64,
    /// Largest net force on the specimen along the load (tool, fixture and weight together: what
    /// accelerates it), averaged over 11 curve points, over the peak force, over the same span as
    /// `kinetic_to_work_ratio`.
    pub unbalanced_force_ratio: f64,
    /// Whether `kinetic_to_work_ratio` stayed within [`QUASI_STATIC_LIMIT`] and
    /// `unbalanced_force_ratio` within [`IMBALANCE_LIMIT`].
    pub quasi_static: bool,
    /// The density scaling the run used (1: none).
    pub density_scaling: f64,
    /// Work done by the tool over the run (J).
    pub work_j: f64,
    /// Largest overlaps over the run: spheres passing through each other or the tool.
    pub overlaps: Overlaps,
    /// The bonds' stresses against their strengths at the peak force.
    pub bond_stress_at_peak: Option<BondStress>,
    pub warnings: Vec<String>,
    /// The curve as CSV (displacement_m, force_n), when an output folder was given.
    pub curve_csv: Option<PathBuf>,
    pub breakage_csv: Option<PathBuf>,
    /// The specimen's cross-section (m^2) and length along the load (m), for stress-strain.
    pub specimen_area_m2: f64,
    pub specimen_length_m: f64,
    pub time_step_s: f64,
    pub simulated_time_s: f64,
    pub wall_s: f64,
    pub seed: u64,
    #[serde(skip)]
    pub displacement: Vec<f64>,
    #[serde(skip)]
    pub force: Vec<f64>,
    /// The specimen at the start, at stages and at the peak (for the side views).
    #[serde(skip)]
    pub stages: Vec<Stage>,
}

/// Checks the loading settings.
pub fn check_loading(file: &TestFile, table: &str, l: &LoadingSettings) -> Result<(), String> {
    let key = |k: &str| format!("{table}.{k}");
    for (k, v) in [
        ("speed", l.speed),
        ("max_displacement", l.max_displacement),
        ("time_step_percent", l.time_step_percent),
    ] {
        if !(v > 0.0 && v.is_finite()) {
            return Err(format!(
                "{}: {}: expected a positive number, got {v}",
                file.name,
                key(k)
            ));
        }
    }
    if !(0.0..1.0).contains(&l.stop_force_fraction) {
        return Err(format!(
            "{}: {}: expected a fraction from 0 (off) to below 1, got {}",
            file.name,
            key("stop_force_fraction"),
            l.stop_force_fraction
        ));
    }
    if !(2..=MAX_CURVE_POINTS).contains(&l.curve_points) {
        return Err(format!(
            "{}: {}: expected 2 to {MAX_CURVE_POINTS}, got {}",
            file.name,
            key("curve_points"),
            l.curve_points
        ));
    }
    if l.side_views > MAX_SIDE_VIEWS {
        return Err(format!(
            "{}: {}: expected at most {MAX_SIDE_VIEWS}, got {}",
            file.name,
            key("side_views"),
            l.side_views
        ));
    }
    if l.snapshots > MAX_SNAPSHOTS {
        return Err(format!(
            "{}: {}: expected at most {MAX_SNAPSHOTS}, got {}",
            file.name,
            key("snapshots"),
            l.snapshots
        ));
    }
    Ok(())
}

/// The specimen as a particle group (checked as the scene builder checks it).
pub fn specimen_group(
    file: &TestFile,
    table: &str,
    s: &SpecimenSettings,
    seed: u64,
) -> Result<ParticleGroup, String> {
    let key = |k: &str| format!("{}: {table}.specimen.{k}", file.name);
    file.check_material(&format!("{table}.specimen.material"), &s.material)?;
    let size = match (s.radius, &s.radii) {
        (Some(r), None) => SizeDistribution::Fixed { radius: r },
        (None, Some(radii)) => {
            let fractions = s
                .fractions
                .clone()
                .unwrap_or_else(|| vec![1.0; radii.len()]);
            if fractions.len() != radii.len() || radii.is_empty() {
                return Err(format!(
                    "{}: expected one number fraction per radius ({} radii)",
                    key("fractions"),
                    radii.len()
                ));
            }
            SizeDistribution::Classes {
                radii: radii.clone(),
                fractions,
                by_mass: false,
            }
        }
        (Some(_), Some(_)) => {
            return Err(format!("{}: give radius or radii, not both", key("radii")))
        }
        (None, None) => {
            return Err(format!(
                "{}: missing; expected radius (m) or radii = [..] with fractions",
                key("radius")
            ))
        }
    };
    let packing = match s.packing.as_str() {
        "hcp" => {
            if s.count.is_some() {
                return Err(format!("{}: not used by packing \"hcp\"", key("count")));
            }
            Packing::Hcp { spacing: s.spacing }
        }
        "random" => {
            if s.spacing.is_some() {
                return Err(format!(
                    "{}: not used by packing \"random\"",
                    key("spacing")
                ));
            }
            Packing::Random {
                count: s.count.ok_or_else(|| {
                    format!("{}: missing; a random packing needs count", key("count"))
                })?,
                seed,
            }
        }
        other => {
            return Err(format!(
                "{}: unknown packing \"{other}\" (expected hcp or random)",
                key("packing")
            ))
        }
    };
    let core = match (&s.core_material, s.core_diameter) {
        (Some(m), Some(d)) => {
            file.check_material(&format!("{table}.specimen.core_material"), m)?;
            Some(Core {
                material: m.clone(),
                diameter: d,
            })
        }
        (None, None) => None,
        _ => {
            return Err(format!(
                "{}: give core_material and core_diameter together",
                key("core_material")
            ))
        }
    };
    Ok(ParticleGroup {
        particles: GroupParticles::Inline {
            material: s.material.clone(),
            shape: ParticleShape::Sphere,
            size,
        },
        placement: Placement::Specimen(StalkSpecimen {
            length: s.length,
            diameter: s.diameter,
            packing,
            hollow_diameter: s.hollow_diameter,
            core,
            centre: DVec3::ZERO,
            axis: DVec3::X,
        }),
        velocity: DVec3::ZERO,
    })
}

/// What drives the loading.
pub enum Tool {
    /// A geometry moving along `direction`; its force is what the particles put on it, against
    /// the motion.
    Geometry { name: String, direction: DVec3 },
    /// Spheres (stable ids) driven at the tool velocity, held against turning; their force is the
    /// sum of what acts on them, against the motion. `fixed` spheres are held still.
    Grip {
        moving: Vec<u32>,
        fixed: Vec<u32>,
        direction: DVec3,
    },
}

impl Tool {
    pub(super) fn direction(&self) -> DVec3 {
        match self {
            Tool::Geometry { direction, .. } | Tool::Grip { direction, .. } => *direction,
        }
    }
}

/// Holds the spheres of a grip: infinite mass and inertia, the given velocity.
fn hold(sim: &mut Simulation, ids: &[u32], velocity: DVec3) {
    let p = &mut sim.particles;
    for k in 0..p.len() {
        if ids.binary_search(&p.id[k]).is_ok() {
            p.inv_mass[k] = 0.0;
            p.inv_inertia[k] = 0.0;
            p.velocity[k] = velocity;
            p.angular_velocity[k] = DVec3::ZERO;
        }
    }
}

/// The force against the tool's motion now.
pub(super) fn tool_force(sim: &Simulation, tool: &Tool) -> f64 {
    match tool {
        Tool::Geometry { name, direction } => sim
            .geometry(name)
            .map(|g| -g.load.force.dot(*direction))
            .unwrap_or(0.0),
        Tool::Grip {
            moving, direction, ..
        } => {
            let p = &sim.particles;
            -(0..p.len())
                .filter(|&k| moving.binary_search(&p.id[k]).is_ok())
                .map(|k| p.force[k] - sim.params.gravity * p.mass[k])
                .sum::<DVec3>()
                .dot(*direction)
        }
    }
}

/// Moves the tool to where it first touches the specimen, `approach` along its direction: the
/// approach would be simulated time with nothing to measure.
fn start_touching(sim: &mut Simulation, tool: &Tool, approach: f64) {
    if let Tool::Geometry { name, direction } = tool {
        if approach > 0.0 {
            if let Some(g) = sim.geometry_index(name) {
                sim.displace_geometry(g, direction.normalize() * approach);
            }
        }
    }
}

/// Drives the tool from where it touches the specimen (`approach` away from it at the start)
/// over `max_displacement`, and records the curve.
#[allow(clippy::too_many_arguments)]
pub fn load(
    file: &TestFile,
    test: &str,
    mut sim: Simulation,
    tool: Tool,
    loading: &LoadingSettings,
    approach: f64,
    area: f64,
    length: f64,
    run: &mut Run,
) -> Result<MechanicalOutcome, TestError> {
    let wall = Instant::now();
    let dt = sim.params.time_step;
    start_touching(&mut sim, &tool, approach);
    let duration = loading.max_displacement / loading.speed;
    harness::budget(
        file,
        dt,
        &[(
            "speed",
            format!(
                "{} m of travel at {} m/s",
                harness::number(loading.max_displacement),
                harness::number(loading.speed)
            ),
            duration,
        )],
    )?;
    let direction = tool.direction().normalize();
    let velocity = direction * loading.speed;
    match &tool {
        Tool::Geometry { name, .. } => {
            harness::translate(&mut sim, name, velocity, duration)?;
        }
        Tool::Grip { moving, fixed, .. } => {
            hold(&mut sim, fixed, DVec3::ZERO);
            hold(&mut sim, moving, velocity);
        }
    }
    let start = sim.time;
    let steps_total = (duration / dt).ceil() as u64;
    let every = (steps_total / loading.curve_points as u64).max(1);
    let snapshot_every = if loading.snapshots > 0 {
        (steps_total / loading.snapshots as u64).max(1)
    } else {
        u64::MAX
    };
    let fail = |e: Stop| e.error(file, "");
    let mut displacement = vec![0.0];
    let mut force = vec![tool_force(&sim, &tool)];
    let mut work = 0.0;
    let size = length.max(area.sqrt());
    let mut watch = Watch::new(
        &mut sim, &tool, loading, test, &file.name, size, force[0], run.out,
    )?;
    let out = run.out.map(|d| d.to_path_buf());
    let mut snapshots = out
        .as_ref()
        .map(|dir| Snapshots::new(dir, SnapshotOptions::default()));
    let mut snapshot = |sim: &mut Simulation| -> Result<(), TestError> {
        if let (Some(dir), Some(series)) = (&out, snapshots.as_mut()) {
            std::fs::create_dir_all(dir)
                .map_err(|e| TestError::Output(format!("{}: {e}", dir.display())))?;
            series
                .write(sim)
                .map_err(|e| TestError::Output(format!("{}: {e}", dir.display())))?;
        }
        Ok(())
    };
    if loading.snapshots > 0 {
        snapshot(&mut sim)?;
    }
    let mut done = 0u64;
    let phase = format!("{test}: loading");
    while done < steps_total {
        let n = every.min(steps_total - done);
        harness::advance(&mut sim, n, &phase, run, None).map_err(fail)?;
        done += n;
        if let Tool::Grip { moving, .. } = &tool {
            // Grips keep their velocity whatever acts on them; re-assert it after reordering.
            hold(&mut sim, moving, velocity);
        }
        let d = (sim.time - start) * loading.speed;
        let f = tool_force(&sim, &tool);
        work += 0.5 * (f + force[force.len() - 1]) * (d - displacement[displacement.len() - 1]);
        let new_peak = f > peak_of(&force).1;
        displacement.push(d);
        force.push(f);
        watch.point(&mut sim, &tool, d, f, work, new_peak)?;
        if done % snapshot_every < n && loading.snapshots > 0 {
            snapshot(&mut sim)?;
        }
        if loading.stop_force_fraction > 0.0 {
            let (k_peak, peak) = peak_of(&force);
            if k_peak + 1 < force.len() && peak > 0.0 && f < loading.stop_force_fraction * peak {
                break;
            }
        }
    }
    let (first, displacement, force) = from_first_contact(&displacement, &force);
    let (k_peak, peak) = peak_of(&force);
    let Judged {
        ratio,
        max_ratio,
        imbalance,
    } = watch.judge(&displacement, first, k_peak, peak);
    let quasi_static = ratio <= QUASI_STATIC_LIMIT && imbalance <= IMBALANCE_LIMIT;
    let mut warnings: Vec<String> = sim
        .bonds()
        .map(|b| b.warnings().to_vec())
        .unwrap_or_default();
    if !quasi_static {
        warnings.push(not_quasi_static(
            test,
            ratio,
            imbalance,
            file.density_scaling,
        ));
    }
    let (count, broken, tension) = bond_counts(&sim);
    let mut outcome = MechanicalOutcome {
        particles: sim.particle_count(),
        bonds: count,
        bonds_broken: broken,
        bonds_broken_tension: tension,
        bonds_broken_shear: broken - tension,
        peak_force_n: peak,
        mean_force_n: mean_force(&displacement, &force),
        stiffness_n_per_m: initial_stiffness(&displacement, &force),
        displacement_at_peak_m: displacement[k_peak],
        displacement_m: displacement[displacement.len() - 1],
        kinetic_to_work_ratio: ratio,
        max_kinetic_to_work_ratio: max_ratio,
        unbalanced_force_ratio: imbalance,
        quasi_static,
        density_scaling: file.density_scaling,
        work_j: work,
        overlaps: watch.overlaps.clone(),
        bond_stress_at_peak: watch.at_peak.clone(),
        warnings,
        curve_csv: None,
        breakage_csv: None,
        specimen_area_m2: area,
        specimen_length_m: length,
        time_step_s: dt,
        simulated_time_s: sim.time,
        wall_s: wall.elapsed().as_secs_f64(),
        seed: run.seed,
        displacement,
        force,
        stages: watch.into_stages(),
    };
    if let Some(dir) = run.out {
        write_logs(dir, &sim, &mut outcome)?;
    }
    Ok(outcome)
}

/// Displacement counts from first contact, as a lab machine's from its preload: the points
/// before the tool touched are dropped (all but the last). Returns the first point kept and the
/// curve from there.
fn from_first_contact(displacement: &[f64], force: &[f64]) -> (usize, Vec<f64>, Vec<f64>) {
    let first = force
        .iter()
        .position(|f| *f > 0.0)
        .unwrap_or(0)
        .saturating_sub(1);
    let offset = displacement[first];
    let d = displacement[first..].iter().map(|d| d - offset).collect();
    (first, d, force[first..].to_vec())
}

/// Bonds formed, broken, broken in tension.
fn bond_counts(sim: &Simulation) -> (usize, usize, usize) {
    sim.bonds()
        .map(|b| {
            let tension = b
                .breakages()
                .iter()
                .filter(|x| x.mode == dem::bond::BreakMode::Tension)
                .count();
            (b.len(), b.broken_count(), tension)
        })
        .unwrap_or((0, 0, 0))
}

/// Writes the breakage log and the bond counts into `dir` and names the files in the outcome
/// (the curve is written with the pictures, see [`pictures`]).
fn write_logs(
    dir: &Path,
    sim: &Simulation,
    outcome: &mut MechanicalOutcome,
) -> Result<(), TestError> {
    let absolute = |p: PathBuf| std::path::absolute(&p).unwrap_or(p);
    outcome.curve_csv = Some(absolute(dir.join(CURVE_FILE)));
    if let Some(b) = sim.bonds() {
        let io = |e: std::io::Error| TestError::Output(format!("{}: {e}", dir.display()));
        std::fs::create_dir_all(dir).map_err(io)?;
        write_breakage_csv(&dir.join("bond_breakage.csv"), b).map_err(io)?;
        write_bond_counts_csv(&dir.join("bond_counts.csv"), b).map_err(io)?;
        outcome.breakage_csv = Some(absolute(dir.join("bond_breakage.csv")));
    }
    Ok(())
}

/// The warning (and a study's failure message) of a run that is not quasi-static.
fn not_quasi_static(test: &str, ratio: f64, imbalance: f64, scaling: f64) -> String {
    let cure = if scaling > 1.0 {
        format!("lower {test}.speed or density_scaling ({scaling})")
    } else {
        format!("lower {test}.speed")
    };
    format!(
        "not quasi-static: the specimen's kinetic energy reached {:.1} % of the work done (limit {:.0} %) and the net force on it {:.1} % of the peak force (limit {:.0} %); inertia shows in the curve, {cure}",
        100.0 * ratio,
        100.0 * QUASI_STATIC_LIMIT,
        100.0 * imbalance,
        100.0 * IMBALANCE_LIMIT
    )
}

/// Why an outcome must not be used as a measurement: a run that was not quasi-static.
pub fn rejected(test: &str, o: &MechanicalOutcome) -> Option<String> {
    (!o.quasi_static).then(|| {
        not_quasi_static(
            test,
            o.kinetic_to_work_ratio,
            o.unbalanced_force_ratio,
            o.density_scaling,
        )
    })
}

/// The curve as CSV and as an SVG plot, and the side views.
pub fn pictures(test: &str, o: &MechanicalOutcome) -> Result<Vec<Picture>, String> {
    let mut views = Vec::new();
    if let Some(start) = o.stages.first() {
        for (k, stage) in o.stages.iter().enumerate() {
            let name = if k + 1 == o.stages.len() && stage.label.ends_with("peak force") {
                "side_view_peak.svg".to_string()
            } else {
                format!("side_view_{k:02}.svg")
            };
            views.push(Picture {
                file_name: name,
                bytes: diagnostics::side_view_svg(start, stage)?.into_bytes(),
            });
        }
    }
    Ok(vec![
        Picture {
            file_name: CURVE_FILE.into(),
            bytes: curve_csv(o).into_bytes(),
        },
        Picture {
            file_name: "force_displacement.svg".into(),
            bytes: crate::render::curve_svg(test, &o.displacement, &o.force)?.into_bytes(),
        },
    ]
    .into_iter()
    .chain(views)
    .collect())
}

/// The curve as it is made (travel from the tool's start, force, the specimen's kinetic energy,
/// the tool's work, bonds broken), in the output folder.
pub const PROGRESS_FILE: &str = "curve_progress.csv";

/// The curve file's name in the output folder.
pub const CURVE_FILE: &str = "force_displacement.csv";

fn curve_csv(o: &MechanicalOutcome) -> String {
    let mut s = String::from("displacement_m,force_n\n");
    for (d, f) in o.displacement.iter().zip(&o.force) {
        s.push_str(&format!("{d:e},{f:e}\n"));
    }
    s
}

/// Index and value of the largest force (the first, if several).
pub fn peak_of(force: &[f64]) -> (usize, f64) {
    force
        .iter()
        .enumerate()
        .fold((0, f64::NEG_INFINITY), |best, (k, &f)| {
            if f > best.1 {
                (k, f)
            } else {
                best
            }
        })
}

/// Mean force over the travel (trapezoids; the curve's area over its length).
pub fn mean_force(displacement: &[f64], force: &[f64]) -> f64 {
    let span = displacement[displacement.len() - 1] - displacement[0];
    if span <= 0.0 {
        return force[0];
    }
    let area: f64 = (1..force.len())
        .map(|k| 0.5 * (force[k] + force[k - 1]) * (displacement[k] - displacement[k - 1]))
        .sum();
    area / span
}

/// Least-squares slope of the rising branch between 10 % and 50 % of the peak force (before the
/// peak); the secant from the start to the peak when too few points lie there.
pub fn initial_stiffness(displacement: &[f64], force: &[f64]) -> f64 {
    let (k_peak, peak) = peak_of(force);
    if peak <= 0.0 || k_peak == 0 {
        return 0.0;
    }
    let points: Vec<(f64, f64)> = (0..=k_peak)
        .filter(|&k| force[k] >= 0.1 * peak && force[k] <= 0.5 * peak)
        .map(|k| (displacement[k], force[k]))
        .collect();
    if points.len() < 3 {
        return (peak - force[0]) / (displacement[k_peak] - displacement[0]).max(f64::MIN_POSITIVE);
    }
    let n = points.len() as f64;
    let mx = points.iter().map(|p| p.0).sum::<f64>() / n;
    let my = points.iter().map(|p| p.1).sum::<f64>() / n;
    let sxy: f64 = points.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let sxx: f64 = points.iter().map(|p| (p.0 - mx).powi(2)).sum();
    if sxx > 0.0 {
        sxy / sxx
    } else {
        0.0
    }
}

/// The responses every mechanical test offers, the usual first.
pub const RESPONSES: &[&str] = &[
    "peak_force_n",
    "mean_force_n",
    "stiffness_n_per_m",
    "displacement_at_peak_m",
    "bonds_broken",
    "force_displacement",
];

pub fn responses(o: &MechanicalOutcome) -> Vec<(&'static str, Response)> {
    vec![
        ("peak_force_n", Response::Scalar(o.peak_force_n)),
        ("mean_force_n", Response::Scalar(o.mean_force_n)),
        ("stiffness_n_per_m", Response::Scalar(o.stiffness_n_per_m)),
        (
            "displacement_at_peak_m",
            Response::Scalar(o.displacement_at_peak_m),
        ),
        ("bonds_broken", Response::Scalar(o.bonds_broken as f64)),
        (
            "force_displacement",
            Response::Curve {
                x_name: "displacement".into(),
                x_unit: "m".into(),
                y_name: "force".into(),
                y_unit: "N".into(),
                x: o.displacement.clone(),
                y: o.force.clone(),
            },
        ),
    ]
}

pub fn summary(test: &str, o: &MechanicalOutcome) -> String {
    let mut s = format!(
        "{test}: peak_force_n={:.4} mean_force_n={:.4} stiffness_n_per_m={:.4e} displacement_at_peak_m={:.4e} particles={} bonds={} intact={} broken={} (tension {}, shear {}) simulated_s={:.4} wall_s={:.1}",
        o.peak_force_n,
        o.mean_force_n,
        o.stiffness_n_per_m,
        o.displacement_at_peak_m,
        o.particles,
        o.bonds,
        o.bonds - o.bonds_broken,
        o.bonds_broken,
        o.bonds_broken_tension,
        o.bonds_broken_shear,
        o.simulated_time_s,
        o.wall_s
    );
    if o.density_scaling != 1.0 {
        s.push_str(&format!(
            " density_scaling={} kinetic_to_work={:.2e}",
            o.density_scaling, o.kinetic_to_work_ratio
        ));
    }
    for w in &o.warnings {
        s.push_str(&format!("\nwarning: {w}"));
    }
    s
}
