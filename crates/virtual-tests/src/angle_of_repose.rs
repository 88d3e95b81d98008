//! The lifted-cylinder angle-of-repose test (docs/lab-tests.md, section 1): a cylinder open at
//! both ends stands on a plate, is filled with particles that settle, is lifted at constant speed,
//! and the heap left behind is measured once it is still.

use std::time::Instant;

use dem::factory::Rate;
use dem::fill::FillRegion;
use dem::mixture::FillTarget;
use dem::scene::{FactoryOutlet, GeometryDescription, GeometryShape, ParticleGroup, Placement};
use glam::DVec3;
use serde::{Deserialize, Serialize};

use crate::file::TestFile;
use crate::harness::{self, Quiet};
use crate::repose::{measure_particles, HeapParticle, ReposeMeasurement, ReposeResult};
use crate::virtual_test::{Picture, Response, Run, TestError, VirtualTest};
use dem::sim::Simulation;

/// The lifted-cylinder test.
pub struct AngleOfRepose;

/// `[angle_of_repose]` settings.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Settings {
    /// The particles, as in a scene's `[[particles]]` without placement: one type inline
    /// (`material` and `size`, or `material`, `shape` and `scale`) or a mixture of the file's
    /// `[[particle_type]]`s (`types`, `fractions`, `basis`).
    pub particles: toml::Value,
    /// Material of the cylinder and plate.
    pub wall_material: String,
    /// Inner diameter and height of the cylinder (m).
    #[serde(deserialize_with = "dem::units::length::one")]
    pub cylinder_diameter: f64,
    #[serde(deserialize_with = "dem::units::length::one")]
    pub cylinder_height: f64,
    /// Side of the square base plate (m; default 6 cylinder diameters).
    #[serde(deserialize_with = "dem::units::length::opt", default)]
    pub plate_size: Option<f64>,
    /// `{ count = N }` or `{ mass = kg }`: generated at random inside the cylinder, or with
    /// `from = "factory"` poured from a disc at the cylinder's top.
    pub fill: Fill,
    /// Height of the region filled inside the cylinder (m; default the cylinder height).
    #[serde(deserialize_with = "dem::units::length::opt", default)]
    pub fill_height: Option<f64>,
    #[serde(default = "default_time_step_percent")]
    pub time_step_percent: f64,
    /// As in a scene's `[simulation]`: "cdt" (EDEM's standard, default) or "epsd", and the
    /// epsd viscous damping.
    pub rolling_friction_model: Option<String>,
    pub rolling_viscous_damping: Option<f64>,
    /// Settled when the rms particle speed falls below this (m/s).
    #[serde(default = "default_settle_speed")]
    #[serde(deserialize_with = "dem::units::speed::one")]
    pub settle_speed: f64,
    /// Longest settling before the lift (s of simulated time).
    #[serde(default = "default_settle_max_time")]
    #[serde(deserialize_with = "dem::units::time::one")]
    pub settle_max_time: f64,
    /// Lift speed (m/s) and distance (m; default the cylinder height).
    #[serde(deserialize_with = "dem::units::speed::one")]
    pub lift_speed: f64,
    #[serde(deserialize_with = "dem::units::length::opt", default)]
    pub lift_distance: Option<f64>,
    /// Longest settling after the lift (s).
    #[serde(default = "default_final_max_time")]
    #[serde(deserialize_with = "dem::units::time::one")]
    pub final_max_time: f64,
    /// Measurement: vertical planes through the axis, and the height band of each flank fitted.
    #[serde(default = "default_planes")]
    pub planes: usize,
    #[serde(default = "default_fit_band")]
    pub fit_band: [f64; 2],
}

#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Fill {
    pub count: Option<u64>,
    #[serde(deserialize_with = "dem::units::mass::opt", default)]
    pub mass: Option<f64>,
    /// "inside" (default) or "factory".
    #[serde(default = "default_from")]
    pub from: String,
    /// Factory rate: particles/s or kg/s (default: the whole fill in 0.5 s).
    pub rate: Option<f64>,
    #[serde(deserialize_with = "dem::units::mass_rate::opt", default)]
    pub mass_rate: Option<f64>,
    /// Downward speed of poured particles (m/s).
    #[serde(default)]
    #[serde(deserialize_with = "dem::units::speed::one")]
    pub speed: f64,
}

fn default_from() -> String {
    "inside".into()
}

fn default_time_step_percent() -> f64 {
    20.0
}
fn default_settle_speed() -> f64 {
    0.005
}
fn default_settle_max_time() -> f64 {
    2.0
}
fn default_final_max_time() -> f64 {
    5.0
}
/// Most measuring planes through the heap's axis.
pub const MAX_PLANES: usize = 180;

fn default_planes() -> usize {
    4
}
fn default_fit_band() -> [f64; 2] {
    [0.15, 0.85]
}

/// What the test reports.
#[derive(Clone, Debug, Serialize)]
pub struct Outcome {
    pub angle_of_repose_deg: f64,
    pub angle_std_deg: f64,
    pub heap_height_m: f64,
    pub heap_radius_m: f64,
    pub flank_angles_deg: Vec<f64>,
    /// Particles (a clump counts once) and the spheres they are made of.
    pub particles: usize,
    pub spheres: usize,
    pub time_step_s: f64,
    /// The Rayleigh time step of the smallest particle: the time step is this share of it.
    pub rayleigh_time_step_s: f64,
    /// Mass of all the particles.
    pub particle_mass_kg: f64,
    pub settle_time_s: f64,
    pub simulated_time_s: f64,
    pub final_rms_speed_m_s: f64,
    pub wall_s: f64,
    pub seed: u64,
    #[serde(skip)]
    pub measurement: ReposeResult,
    #[serde(skip)]
    pub positions: Vec<DVec3>,
    #[serde(skip)]
    pub radii: Vec<f64>,
}

fn check(file: &TestFile, s: &Settings) -> Result<(), String> {
    let err = |key: &str, msg: String| Err(file.error(key, msg));
    for (key, v) in [
        ("cylinder_diameter", s.cylinder_diameter),
        ("cylinder_height", s.cylinder_height),
        ("lift_speed", s.lift_speed),
        ("settle_speed", s.settle_speed),
        ("time_step_percent", s.time_step_percent),
        ("settle_max_time", s.settle_max_time),
        ("final_max_time", s.final_max_time),
        ("fill_height", s.fill_height.unwrap_or(1.0)),
        ("lift_distance", s.lift_distance.unwrap_or(1.0)),
    ] {
        if v.is_nan() || v <= 0.0 {
            return err(key, format!("expected a positive number, got {v}"));
        }
    }
    if let Some(p) = s.plate_size {
        if p.is_nan() || p <= s.cylinder_diameter {
            return err(
                "plate_size",
                format!(
                    "expected more than the cylinder diameter {}, got {p}",
                    s.cylinder_diameter
                ),
            );
        }
    }
    match (s.fill.count, s.fill.mass) {
        (Some(_), None) | (None, Some(_)) => {}
        _ => return err("fill", "expected exactly one of count or mass".into()),
    }
    match s.fill.from.as_str() {
        "inside" => {
            if s.fill.rate.is_some() || s.fill.mass_rate.is_some() || s.fill.speed != 0.0 {
                return err(
                    "fill",
                    "rate, mass_rate and speed are for from = \"factory\"".into(),
                );
            }
        }
        "factory" => {
            if s.fill.rate.is_some() && s.fill.mass_rate.is_some() {
                return err("fill.mass_rate", "give rate or mass_rate, not both".into());
            }
            if s.fill.speed < 0.0 {
                return err(
                    "fill.speed",
                    format!("expected a speed >= 0, got {}", s.fill.speed),
                );
            }
        }
        other => {
            return err(
                "fill.from",
                format!("expected \"inside\" or \"factory\", got \"{other}\""),
            )
        }
    }
    file.check_particles(&s.particles)?;
    if !(0.0..1.0).contains(&s.fit_band[0]) || s.fit_band[1] <= s.fit_band[0] || s.fit_band[1] > 1.0
    {
        return err(
            "fit_band",
            format!("expected 0 <= low < high <= 1, got {:?}", s.fit_band),
        );
    }
    // Each plane is two profiles of the heap; one per degree is already finer than the particles
    // (1e9 planes grew to 7.9 GB after the whole simulation).
    if !(1..=MAX_PLANES).contains(&s.planes) {
        return err(
            "planes",
            format!("expected 1 to {MAX_PLANES}, got {}", s.planes),
        );
    }
    file.check_material("wall_material", &s.wall_material)?;
    Ok(())
}

/// The scene of the test: a plate, the cylinder standing on it, and the particles filled in
/// (or poured from a disc at the fill height).
pub fn scene(
    file: &TestFile,
    s: &Settings,
    seed: u64,
) -> Result<dem::scene::SceneDescription, String> {
    let plate = s.plate_size.unwrap_or(6.0 * s.cylinder_diameter);
    let fill_height = s.fill_height.unwrap_or(s.cylinder_height);
    let r = 0.5 * s.cylinder_diameter;
    let half = 0.5 * plate;
    let amount = match (s.fill.count, s.fill.mass) {
        (Some(c), _) => FillTarget::Count(c as usize),
        (None, m) => FillTarget::Mass(m.unwrap_or(0.0)),
    };
    let (placement, velocity) = if s.fill.from == "factory" {
        let rate = match (s.fill.rate, s.fill.mass_rate, s.fill.count, s.fill.mass) {
            (Some(rate), _, _, _) => Rate::Count(rate),
            (_, Some(rate), _, _) => Rate::Mass(rate),
            (_, _, Some(n), _) => Rate::Count(n as f64 / 0.5),
            (_, _, _, m) => Rate::Mass(m.unwrap_or(0.0) / 0.5),
        };
        // A disc just inside the rim, particles created below it.
        (
            Placement::Factory {
                outlet: FactoryOutlet::Disc {
                    centre: DVec3::new(0.0, 0.0, fill_height),
                    radius: 0.95 * r,
                },
                normal: DVec3::new(0.0, 0.0, -1.0),
                amount,
                rate,
                start: 0.0,
                seed: Some(seed),
            },
            DVec3::new(0.0, 0.0, -s.fill.speed),
        )
    } else {
        (
            Placement::Random {
                region: FillRegion::Cylinder {
                    base: DVec3::ZERO,
                    axis: DVec3::Z,
                    radius: r,
                    length: fill_height,
                },
                amount,
                seed: Some(seed),
            },
            DVec3::ZERO,
        )
    };
    // A particle that rolls off the plate falls out of the domain and stops the run with its
    // reason: the plate is too small.
    let mut simulation = harness::simulation(
        s.time_step_percent,
        (
            DVec3::new(-half * 1.2, -half * 1.2, -0.25 * s.cylinder_height),
            DVec3::new(
                half * 1.2,
                half * 1.2,
                fill_height + 2.0 * s.cylinder_height,
            ),
        ),
    );
    if let Some(m) = &s.rolling_friction_model {
        simulation.rolling_friction_model = m.clone();
    }
    if let Some(d) = s.rolling_viscous_damping {
        simulation.rolling_viscous_damping = d;
    }
    let geometries = vec![
        harness::plate(&s.wall_material, half, half, 0.0),
        GeometryDescription {
            name: "cylinder".into(),
            material: s.wall_material.clone(),
            shape: GeometryShape::Cylinder {
                base: DVec3::ZERO,
                axis: DVec3::Z,
                radius: r,
                length: s.cylinder_height,
                bottom_cap: false,
                top_cap: false,
            },
            motion: Vec::new(),
            torque_point: None,
        },
    ];
    let group = ParticleGroup {
        particles: file.particles(&s.particles)?,
        placement,
        velocity,
    };
    Ok(file.scene(simulation, geometries, vec![group]))
}

impl VirtualTest for AngleOfRepose {
    type Settings = Settings;
    type Outcome = Outcome;

    fn name(&self) -> &'static str {
        "angle_of_repose"
    }

    fn about(&self) -> &'static str {
        "a cylinder on a plate is filled, lifted, and the heap's angle measured"
    }

    fn reference_sections(&self) -> Vec<(String, Vec<&'static str>)> {
        vec![
            ("[angle_of_repose]".into(), dem::keys::of::<Settings>()),
            ("angle_of_repose.fill".into(), dem::keys::of::<Fill>()),
        ]
    }

    fn response_names(&self) -> &'static [&'static str] {
        &[
            "angle_of_repose_deg",
            "angle_std_deg",
            "heap_height_m",
            "heap_radius_m",
        ]
    }

    fn check(&self, file: &TestFile, s: &Settings) -> Result<(), String> {
        check(file, s)
    }

    fn settings_value(&self, s: &Settings) -> Option<toml::Value> {
        toml::Value::try_from(s).ok()
    }

    fn check_scene(&self, file: &TestFile, s: &Settings, seed: u64) -> Result<(), String> {
        file.build(&scene(file, s, seed)?, "angle_of_repose.fill")
            .map(|_| ())
    }

    /// When the heap cannot be measured and pictures are wanted, its side view is written
    /// first.
    fn run(&self, file: &TestFile, s: &Settings, run: &mut Run) -> Result<Outcome, TestError> {
        let seed = run.seed;
        let description = scene(file, s, seed)?;
        let scene = file.build(&description, "angle_of_repose.fill")?;
        let rayleigh = scene.rayleigh_time_step;
        let wall = Instant::now();
        let mut sim = scene.simulation;
        let dt = sim.params.time_step;
        let lift = s.lift_distance.unwrap_or(s.cylinder_height);
        let lift_time = lift / s.lift_speed;
        harness::budget(
            file,
            dt,
            &[
                ("settle_max_time", "settling".into(), s.settle_max_time),
                (
                    "lift_speed",
                    format!(
                        "lifting {} m at {} m/s",
                        harness::number(lift),
                        harness::number(s.lift_speed)
                    ),
                    lift_time,
                ),
                (
                    "final_max_time",
                    "the final settling".into(),
                    s.final_max_time,
                ),
            ],
        )?;
        let fail = |e: harness::Stop| e.error(file, "");

        // 1. Settle in the cylinder (at least 0.05 s so a fill at rest does not count as settled).
        let quiet = |max_time: f64, min_time: f64, wait_for_factories: bool| Quiet {
            rms_speed: s.settle_speed,
            min_time,
            max_time,
            check_every: 0.01,
            wait_for_factories,
        };
        harness::settle(
            &mut sim,
            &quiet(s.settle_max_time, 0.05, true),
            "settle",
            run,
        )
        .map_err(fail)?;
        if !sim.factories_done() {
            return Err(TestError::Measurement(file.error(
                "settle_max_time",
                format!(
                    "the factory had not finished pouring after {} s; allow more time or pour faster",
                    s.settle_max_time
                ),
            )));
        }
        let settle_time = sim.time;
        // 2. Lift.
        let chunk = ((0.01 / dt).ceil() as u64).max(1);
        let end = harness::translate(
            &mut sim,
            "cylinder",
            DVec3::new(0.0, 0.0, s.lift_speed),
            lift_time,
        )?;
        while sim.time < end {
            harness::advance(&mut sim, chunk, "lift", run, None).map_err(fail)?;
        }
        // 3. Let the heap come to rest.
        harness::settle(
            &mut sim,
            &quiet(s.final_max_time, 0.0, false),
            "final settle",
            run,
        )
        .map_err(fail)?;
        let final_rms = harness::rms_speed(&sim);
        let positions = sim.particles.position.clone();
        let (heap, radii) = heap_particles(&mut sim);
        let m = ReposeMeasurement {
            planes: s.planes,
            fit_band: (s.fit_band[0], s.fit_band[1]),
            ..Default::default()
        };
        let res = measure_particles(&heap, &m).map_err(|e| {
            let picture = run.out.and_then(|dir| {
                std::fs::create_dir_all(dir).ok()?;
                let png = dir.join("heap.png");
                crate::render::side_view_png(&positions, &radii, 900, &png).ok()?;
                Some(format!(" (side view in {})", png.display()))
            });
            TestError::Measurement(format!("{}: {e}{}", file.name, picture.unwrap_or_default()))
        })?;
        Ok(Outcome {
            angle_of_repose_deg: res.angle_deg,
            angle_std_deg: res.angle_std_deg,
            heap_height_m: res.heap_height,
            heap_radius_m: res.heap_radius,
            flank_angles_deg: res.flanks.iter().map(|f| f.angle_deg).collect(),
            particles: sim.particle_count(),
            spheres: positions.len(),
            time_step_s: dt,
            rayleigh_time_step_s: rayleigh,
            particle_mass_kg: sim.total_mass(),
            settle_time_s: settle_time,
            simulated_time_s: sim.time,
            final_rms_speed_m_s: final_rms,
            wall_s: wall.elapsed().as_secs_f64(),
            seed,
            measurement: res,
            positions,
            radii,
        })
    }

    fn responses(&self, o: &Outcome) -> Vec<(&'static str, Response)> {
        vec![
            (
                "angle_of_repose_deg",
                Response::Scalar(o.angle_of_repose_deg),
            ),
            ("angle_std_deg", Response::Scalar(o.angle_std_deg)),
            ("heap_height_m", Response::Scalar(o.heap_height_m)),
            ("heap_radius_m", Response::Scalar(o.heap_radius_m)),
        ]
    }

    fn summary(&self, o: &Outcome) -> String {
        format!(
            "angle_of_repose: angle_deg={:.2} std_deg={:.2} heap_height_m={:.4} heap_radius_m={:.4} particles={} simulated_s={:.2} wall_s={:.1}",
            o.angle_of_repose_deg,
            o.angle_std_deg,
            o.heap_height_m,
            o.heap_radius_m,
            o.particles,
            o.simulated_time_s,
            o.wall_s
        )
    }

    fn pictures(&self, o: &Outcome) -> Result<Vec<Picture>, String> {
        let view = crate::render::side_view(&o.positions, &o.radii, 900)?;
        let json = crate::render::heap_json(&view, &o.measurement);
        Ok(vec![
            Picture {
                file_name: "profiles.svg".into(),
                bytes: crate::render::profiles_svg(&o.measurement)?.into_bytes(),
            },
            Picture {
                file_name: "heap.json".into(),
                bytes: serde_json::to_string_pretty(&json)
                    .map_err(|e| e.to_string())?
                    .into_bytes(),
            },
            Picture {
                file_name: "heap.png".into(),
                bytes: view.png,
            },
        ])
    }
}

/// The heap's particles for the measurement (a polyhedron by its vertices and edges), and a
/// radius per particle for pictures (a polyhedron's equal-volume sphere).
pub fn heap_particles(sim: &mut Simulation) -> (Vec<HeapParticle>, Vec<f64>) {
    sim.bodies.update_polyhedra();
    let p = &sim.particles;
    let frames = &sim.bodies.polyhedra;
    let mut heap = Vec::with_capacity(p.len());
    let mut radii = Vec::with_capacity(p.len());
    for k in 0..p.len() {
        let b = p.body[k];
        match frames.world(b) {
            Some((shape, scale, vertices)) => {
                let r = shape.equal_volume_radius() * scale;
                heap.push(HeapParticle::Convex {
                    centre: p.position[k],
                    vertices: vertices.to_vec(),
                    edges: shape.edges.clone(),
                    equal_volume_radius: r,
                });
                radii.push(r);
            }
            None => {
                heap.push(HeapParticle::Sphere {
                    centre: p.position[k],
                    radius: p.radius[k],
                });
                radii.push(p.radius[k]);
            }
        }
    }
    (heap, radii)
}
