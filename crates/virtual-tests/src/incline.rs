//! The inclined-plane tests of docs/lab-tests.md, section 2.
//!
//! `incline_tilt`: a steel plate carrying a sample is tilted slowly about a horizontal axis until
//! the sample slides; the angle at which it has moved `slide_distance` down the plate (in the
//! plate's frame) is reported with its tangent, the static friction the lab infers.
//!
//! `incline_slide`: a particle released from rest at the top of a ramp of given angle and length
//! slides or rolls onto a horizontal plate; the distance from the foot of the ramp to where it
//! stops is reported, averaged over releases (the lab's mean of many kernels). Each release is
//! its own small simulation with its own seed (orientation), and a mixture is released type by
//! type in its number shares. Ramp and plate are two planes meeting at the foot, so the corner
//! is exact and nothing has an edge to catch on.

use std::time::Instant;

use dem::fill::FillRegion;
use dem::mixture::{furthest_below_share, FillTarget};
use dem::scene::{GeometryDescription, GeometryShape, GroupParticles, ParticleGroup, Placement};
use dem::Simulation;
use glam::DVec3;
use serde::{Deserialize, Serialize};

use crate::file::TestFile;
use crate::harness::{self, centres, rms_speed, Quiet};
use crate::virtual_test::{Response, Run, TestError, VirtualTest};
use dem::scene::SceneDescription;

/// The tilted-plate test.
pub struct InclineTilt;

/// The ramp-and-plate slide test.
pub struct InclineSlide;

/// The most releases of one slide test: each is its own simulation.
const MAX_RELEASES: usize = 10_000;

/// `[incline_tilt]` settings.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct TiltSettings {
    /// The sample, as in angle_of_repose.
    pub particles: toml::Value,
    /// How many particles the sample holds (dropped on the plate and settled first).
    #[serde(default = "one")]
    pub count: u64,
    pub plate_material: String,
    /// Plate length (down the slope) and width (m).
    #[serde(default = "default_plate")]
    #[serde(deserialize_with = "dem::units::length::two")]
    pub plate_size: [f64; 2],
    #[serde(default = "default_tilt_rate")]
    #[serde(deserialize_with = "dem::units::angular_speed_deg::one")]
    pub tilt_rate_deg_s: f64,
    #[serde(default = "default_max_angle")]
    #[serde(deserialize_with = "dem::units::angle::one")]
    pub max_angle_deg: f64,
    /// How far down the plate (m, mean over the sample) counts as sliding.
    #[serde(default = "default_slide_distance")]
    #[serde(deserialize_with = "dem::units::length::one")]
    pub slide_distance: f64,
    #[serde(default = "default_time_step_percent")]
    pub time_step_percent: f64,
    #[serde(default = "default_rest_speed")]
    #[serde(deserialize_with = "dem::units::speed::one")]
    pub settle_speed: f64,
    #[serde(default = "default_settle_max_time")]
    #[serde(deserialize_with = "dem::units::time::one")]
    pub settle_max_time: f64,
}

/// `[incline_slide]` settings.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct SlideSettings {
    pub particles: toml::Value,
    pub ramp_material: String,
    /// Default: the ramp's material.
    pub plate_material: Option<String>,
    #[serde(deserialize_with = "dem::units::angle::one")]
    pub ramp_angle_deg: f64,
    /// Slope distance from the release point to the foot (m).
    #[serde(deserialize_with = "dem::units::length::one")]
    pub ramp_length: f64,
    /// Releases to average over.
    #[serde(default = "default_releases")]
    pub releases: usize,
    #[serde(default = "default_time_step_percent")]
    pub time_step_percent: f64,
    /// At rest when the particle's speed falls below this (m/s).
    #[serde(default = "default_rest_speed")]
    #[serde(deserialize_with = "dem::units::speed::one")]
    pub rest_speed: f64,
    /// Longest simulated time per release (s).
    #[serde(default = "default_max_time")]
    #[serde(deserialize_with = "dem::units::time::one")]
    pub max_time: f64,
}

fn one() -> u64 {
    1
}
fn default_plate() -> [f64; 2] {
    [0.2, 0.1]
}
fn default_tilt_rate() -> f64 {
    2.0
}
fn default_max_angle() -> f64 {
    60.0
}
fn default_slide_distance() -> f64 {
    0.002
}
fn default_time_step_percent() -> f64 {
    20.0
}
fn default_rest_speed() -> f64 {
    0.005
}
fn default_settle_max_time() -> f64 {
    1.0
}
fn default_releases() -> usize {
    5
}
fn default_max_time() -> f64 {
    3.0
}

#[derive(Clone, Debug, Serialize)]
pub struct TiltOutcome {
    pub angle_deg: f64,
    pub tan_angle: f64,
    pub slid: bool,
    pub particles: usize,
    pub simulated_time_s: f64,
    pub wall_s: f64,
    pub seed: u64,
}

#[derive(Clone, Debug, Serialize)]
pub struct SlideOutcome {
    /// Mean stopping distance from the foot of the ramp, along the plate (m).
    pub distance_m: f64,
    pub distance_std_m: f64,
    pub distances_m: Vec<f64>,
    /// The particle type of each release.
    pub release_types: Vec<String>,
    pub stopped_on_ramp: usize,
    pub simulated_time_s: f64,
    pub wall_s: f64,
    pub seed: u64,
}

fn positive(file: &TestFile, key: &str, v: f64) -> Result<(), String> {
    if v.is_nan() || v <= 0.0 {
        return Err(file.error(key, format!("expected a positive number, got {v}")));
    }
    Ok(())
}

impl VirtualTest for InclineTilt {
    type Settings = TiltSettings;
    type Outcome = TiltOutcome;

    fn name(&self) -> &'static str {
        "incline_tilt"
    }

    fn about(&self) -> &'static str {
        "a plate carrying a sample is tilted until the sample slides"
    }

    fn response_names(&self) -> &'static [&'static str] {
        &["angle_deg", "tan_angle"]
    }

    fn check(&self, file: &TestFile, s: &TiltSettings) -> Result<(), String> {
        for (k, v) in [
            ("plate_size", s.plate_size[0].min(s.plate_size[1])),
            ("tilt_rate_deg_s", s.tilt_rate_deg_s),
            ("max_angle_deg", s.max_angle_deg),
            ("slide_distance", s.slide_distance),
            ("time_step_percent", s.time_step_percent),
            ("settle_speed", s.settle_speed),
            ("settle_max_time", s.settle_max_time),
            ("count", s.count as f64),
        ] {
            positive(file, k, v)?;
        }
        if s.max_angle_deg >= 90.0 {
            return Err(file.error(
                "max_angle_deg",
                format!("expected less than 90, got {}", s.max_angle_deg),
            ));
        }
        file.check_particles(&s.particles)?;
        file.check_material("plate_material", &s.plate_material)
    }

    fn check_scene(&self, file: &TestFile, s: &TiltSettings, seed: u64) -> Result<(), String> {
        file.build(&tilt_scene(file, s, seed)?, "incline_tilt.count")
            .map(|_| ())
    }

    fn run(
        &self,
        file: &TestFile,
        s: &TiltSettings,
        run: &mut Run,
    ) -> Result<TiltOutcome, TestError> {
        let seed = run.seed;
        let tilt_time = s.max_angle_deg / s.tilt_rate_deg_s;
        let description = tilt_scene(file, s, seed)?;
        let mut sim = file.build(&description, "incline_tilt.count")?.simulation;
        harness::budget(
            file,
            sim.params.time_step,
            &[
                ("settle_max_time", "settling".into(), s.settle_max_time),
                (
                    "tilt_rate_deg_s",
                    format!(
                        "tilting to {} deg at {} deg/s",
                        harness::number(s.max_angle_deg),
                        harness::number(s.tilt_rate_deg_s)
                    ),
                    tilt_time,
                ),
            ],
        )?;
        let wall = Instant::now();
        let fail = |e: harness::Stop| e.error(file, "");
        let quiet = Quiet {
            rms_speed: s.settle_speed,
            min_time: 0.05,
            max_time: s.settle_max_time,
            check_every: 0.005,
            wait_for_factories: false,
        };
        harness::settle(&mut sim, &quiet, "settle", run).map_err(fail)?;
        // Tilt about the y axis through the plate's top centre: +x goes down.
        let start = sim.time;
        let omega = s.tilt_rate_deg_s.to_radians();
        let end = harness::rotate(&mut sim, "plate", DVec3::ZERO, DVec3::Y, omega, tilt_time)?;
        let plate = harness::geometry(&sim, "plate")?;
        let local = |sim: &Simulation| -> f64 {
            let g = &sim.geometries[plate];
            let xs = centres(sim);
            xs.iter()
                .map(|x| (g.rotation.transpose() * (*x - g.translation)).x)
                .sum::<f64>()
                / xs.len() as f64
        };
        let at_start = local(&sim);
        let step_chunk = ((0.001 / sim.params.time_step).ceil() as u64).max(1);
        let mut slid = false;
        while sim.time < end {
            harness::advance(&mut sim, step_chunk, "tilt", run, None).map_err(fail)?;
            if local(&sim) - at_start > s.slide_distance {
                slid = true;
                break;
            }
        }
        let angle_deg = (omega * (sim.time - start))
            .to_degrees()
            .min(s.max_angle_deg);
        Ok(TiltOutcome {
            angle_deg,
            tan_angle: angle_deg.to_radians().tan(),
            slid,
            particles: sim.particle_count(),
            simulated_time_s: sim.time,
            wall_s: wall.elapsed().as_secs_f64(),
            seed,
        })
    }

    fn responses(&self, o: &TiltOutcome) -> Vec<(&'static str, Response)> {
        vec![
            ("angle_deg", Response::Scalar(o.angle_deg)),
            ("tan_angle", Response::Scalar(o.tan_angle)),
        ]
    }

    fn summary(&self, o: &TiltOutcome) -> String {
        format!(
            "incline_tilt: angle_deg={:.2} tan={:.3} slid={} particles={} simulated_s={:.2} wall_s={:.1}",
            o.angle_deg, o.tan_angle, o.slid, o.particles, o.simulated_time_s, o.wall_s
        )
    }
}

/// A mixture's type names and number shares as the slide test releases them, read from the
/// `particles` setting (empty for one type given inline).
fn release_shares(
    file: &TestFile,
    particles: &toml::Value,
) -> Result<(Vec<String>, Vec<f64>), String> {
    let key = format!("{}: incline_slide.particles", file.name);
    let types: Vec<String> = match particles.get("types") {
        None => Vec::new(),
        Some(t) => t
            .as_array()
            .map(|a| {
                a.iter()
                    .map(|v| v.as_str().map(String::from))
                    .collect::<Option<Vec<_>>>()
            })
            .and_then(|v| v.filter(|v| !v.is_empty()))
            .ok_or_else(|| format!("{key}.types: expected a list of particle type names"))?,
    };
    let fractions: Vec<f64> = match particles.get("fractions") {
        None => vec![1.0; types.len()],
        Some(f) => {
            let v: Option<Vec<f64>> = f.as_array().and_then(|a| {
                a.iter()
                    .map(|v| v.as_float().or(v.as_integer().map(|i| i as f64)))
                    .collect()
            });
            match v {
                Some(v)
                    if v.len() == types.len()
                        && v.iter().all(|x| *x >= 0.0)
                        && v.iter().sum::<f64>() > 0.0 =>
                {
                    v
                }
                _ => {
                    return Err(format!(
                    "{key}.fractions: expected one number >= 0 per type ({} types), not all zero",
                    types.len()
                ))
                }
            }
        }
    };
    Ok((types, fractions))
}

impl VirtualTest for InclineSlide {
    type Settings = SlideSettings;
    type Outcome = SlideOutcome;

    fn name(&self) -> &'static str {
        "incline_slide"
    }

    fn about(&self) -> &'static str {
        "particles released on a ramp slide onto a plate; their stopping distance"
    }

    fn response_names(&self) -> &'static [&'static str] {
        &["distance_m", "distance_std_m"]
    }

    fn check(&self, file: &TestFile, s: &SlideSettings) -> Result<(), String> {
        for (k, v) in [
            ("ramp_angle_deg", s.ramp_angle_deg),
            ("ramp_length", s.ramp_length),
            ("releases", s.releases as f64),
            ("time_step_percent", s.time_step_percent),
            ("rest_speed", s.rest_speed),
            ("max_time", s.max_time),
        ] {
            positive(file, k, v)?;
        }
        if s.ramp_angle_deg >= 90.0 {
            return Err(file.error(
                "ramp_angle_deg",
                format!("expected less than 90, got {}", s.ramp_angle_deg),
            ));
        }
        if s.releases > MAX_RELEASES {
            return Err(file.error(
                "releases",
                format!(
                    "expected at most {MAX_RELEASES} (each is its own simulation), got {}",
                    s.releases
                ),
            ));
        }
        file.check_particles(&s.particles)?;
        release_shares(file, &s.particles)?;
        file.check_material("ramp_material", &s.ramp_material)?;
        if let Some(m) = &s.plate_material {
            file.check_material("plate_material", m)?;
        }
        Ok(())
    }

    fn check_scene(&self, file: &TestFile, s: &SlideSettings, seed: u64) -> Result<(), String> {
        file.build(&slide_scene(file, s, seed)?, "incline_slide.particles")
            .map(|_| ())
    }

    fn run(
        &self,
        file: &TestFile,
        s: &SlideSettings,
        run: &mut Run,
    ) -> Result<SlideOutcome, TestError> {
        let seed = run.seed;
        let (normal, top) = ramp(s);
        let placement = |release: usize| slide_placement(s, seed, release);
        // A mixture is released type by type in its number shares.
        let (types, fractions) = release_shares(file, &s.particles)?;
        let mut base = slide_scene(file, s, seed)?;
        // Kernel fits and clump mass properties once for all releases.
        file.prepare(&mut base, "incline_slide.particles")?;
        let mut released = vec![0.0; types.len()];

        let wall = Instant::now();
        let mut distances = Vec::new();
        let mut release_types = Vec::new();
        let mut stopped_on_ramp = 0;
        let mut simulated = 0.0;
        for release in 0..s.releases {
            let mut description = base.clone();
            let group = &mut description.particles[0];
            group.placement = placement(release);
            if !types.is_empty() {
                let k = furthest_below_share(&released, &fractions);
                released[k] += 1.0;
                group.particles = GroupParticles::Mixture {
                    types: vec![types[k].clone()],
                    fractions: None,
                    by_mass: false,
                };
                release_types.push(types[k].clone());
            } else {
                release_types.push(
                    s.particles
                        .get("material")
                        .and_then(|m| m.as_str())
                        .unwrap_or("")
                        .to_string(),
                );
            }
            let mut sim = file
                .build(&description, "incline_slide.particles")?
                .simulation;
            // Each release has its own time step (its type's smallest sphere).
            harness::budget(
                file,
                sim.params.time_step,
                &[(
                    "max_time",
                    format!(
                        "{} releases of up to {} s",
                        s.releases,
                        harness::number(s.max_time)
                    ),
                    s.releases as f64 * s.max_time,
                )],
            )?;
            let com = centres(&sim)[0];
            // A polyhedron's lowest point is its lowest corner, not its bounding sphere's.
            sim.bodies.update_polyhedra();
            let frames = &sim.bodies.polyhedra;
            let lowest = (0..sim.particles.len())
                .map(|k| match frames.world(sim.particles.body[k]) {
                    Some((_, _, corners)) => corners
                        .iter()
                        .map(|v| (*v - com).dot(normal))
                        .fold(f64::INFINITY, f64::min),
                    None => (sim.particles.position[k] - com).dot(normal) - sim.particles.radius[k],
                })
                .fold(f64::INFINITY, f64::min);
            // Lowest point a hair above the ramp at the release point.
            let gap = 1e-5;
            sim.shift(top + normal * (gap - lowest) - com);
            let quiet = Quiet {
                rms_speed: s.rest_speed,
                min_time: 0.05,
                max_time: s.max_time,
                check_every: 0.005,
                wait_for_factories: false,
            };
            let phase = format!("release {}/{}", release + 1, s.releases);
            let at_rest = harness::settle(&mut sim, &quiet, &phase, run)
                .map_err(|e| e.error(file, &format!("release {release}: ")))?;
            if !at_rest {
                return Err(TestError::Measurement(format!(
                    "{}: incline_slide: release {release} still moves at {:.3} m/s after max_time = {} s; allow more time",
                    file.name,
                    rms_speed(&sim),
                    s.max_time
                )));
            }
            simulated += sim.time;
            let x = centres(&sim)[0].x;
            if x < 0.0 {
                stopped_on_ramp += 1;
            }
            distances.push(x.max(0.0));
        }
        let n = distances.len() as f64;
        let mean = distances.iter().sum::<f64>() / n;
        let std = if distances.len() > 1 {
            (distances.iter().map(|d| (d - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt()
        } else {
            0.0
        };
        Ok(SlideOutcome {
            distance_m: mean,
            distance_std_m: std,
            distances_m: distances,
            release_types,
            stopped_on_ramp,
            simulated_time_s: simulated,
            wall_s: wall.elapsed().as_secs_f64(),
            seed,
        })
    }

    fn responses(&self, o: &SlideOutcome) -> Vec<(&'static str, Response)> {
        vec![
            ("distance_m", Response::Scalar(o.distance_m)),
            ("distance_std_m", Response::Scalar(o.distance_std_m)),
        ]
    }

    fn summary(&self, o: &SlideOutcome) -> String {
        format!(
            "incline_slide: distance_m={:.4} std_m={:.4} releases={} stopped_on_ramp={} simulated_s={:.2} wall_s={:.1}",
            o.distance_m,
            o.distance_std_m,
            o.distances_m.len(),
            o.stopped_on_ramp,
            o.simulated_time_s,
            o.wall_s
        )
    }
}

/// The ramp's unit normal and its top edge's centre (the plate is z = 0, the ramp meets it at x = 0).
fn ramp(s: &SlideSettings) -> (DVec3, DVec3) {
    let theta = s.ramp_angle_deg.to_radians();
    let normal = DVec3::new(theta.sin(), 0.0, theta.cos());
    let top = DVec3::new(
        -s.ramp_length * theta.cos(),
        0.0,
        s.ramp_length * theta.sin(),
    );
    (normal, top)
}

/// Where release `release` is made: well above everything, then set down on the ramp (any
/// orientation, from rest).
fn slide_placement(s: &SlideSettings, seed: u64, release: usize) -> Placement {
    let reach = s.ramp_length + 1.0;
    Placement::Random {
        region: FillRegion::Box {
            min: DVec3::new(-0.1, -0.1, reach),
            max: DVec3::new(0.1, 0.1, reach + 0.2),
        },
        amount: FillTarget::Count(1),
        seed: Some(seed + release as u64),
    }
}

/// The slide test's scene for the first release: plate and ramp, and the whole mixture placed
/// as release 0 (each release then takes one type of it).
fn slide_scene(file: &TestFile, s: &SlideSettings, seed: u64) -> Result<SceneDescription, String> {
    let (normal, _) = ramp(s);
    let reach = s.ramp_length + 1.0;
    let simulation = harness::simulation(
        s.time_step_percent,
        (
            DVec3::new(-reach, -reach, -0.05),
            DVec3::new(reach, reach, reach + 2.0),
        ),
    );
    let plate_material = s.plate_material.clone().unwrap_or(s.ramp_material.clone());
    let plane = |name: &str, material: &str, normal: DVec3| GeometryDescription {
        name: name.into(),
        material: material.into(),
        shape: GeometryShape::Plane {
            point: DVec3::ZERO,
            normal,
        },
        motion: Vec::new(),
        torque_point: None,
    };
    let geometries = vec![
        plane("plate", &plate_material, DVec3::Z),
        plane("ramp", &s.ramp_material, normal),
    ];
    Ok(file.scene(
        simulation,
        geometries,
        vec![ParticleGroup {
            particles: file.particles(&s.particles)?,
            placement: slide_placement(s, seed, 0),
            velocity: DVec3::ZERO,
        }],
    ))
}

/// The tilt test's starting scene: the sample dropped onto the middle of the flat plate.
fn tilt_scene(file: &TestFile, s: &TiltSettings, seed: u64) -> Result<SceneDescription, String> {
    let [length, width] = s.plate_size;
    // The sample is dropped from a few millimetres onto the middle of the plate.
    let side = (0.25 * length.min(width)).max(0.01);
    let simulation = harness::simulation(
        s.time_step_percent,
        (DVec3::splat(-length), DVec3::splat(length)),
    );
    let plate = harness::plate(&s.plate_material, 0.5 * length, 0.5 * width, 0.0);
    let group = ParticleGroup {
        particles: file.particles(&s.particles)?,
        placement: Placement::Random {
            region: FillRegion::Box {
                min: DVec3::new(-0.5 * side, -0.5 * side, 0.0),
                max: DVec3::new(0.5 * side, 0.5 * side, side),
            },
            amount: FillTarget::Count(s.count as usize),
            seed: Some(seed),
        },
        velocity: DVec3::ZERO,
    };
    Ok(file.scene(simulation, vec![plate], vec![group]))
}
