//! The inclined-plane tests of lab-tests.md, section 2.
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

use dem::geometry::Motion;
use dem::mixture::furthest_below_share;
use dem::scene::Scene;
use dem::Simulation;
use glam::DVec3;
use serde::{Deserialize, Serialize};

use crate::file::{arr, group, plate_geometry, table, text, TestFile};

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
    pub plate_size: [f64; 2],
    #[serde(default = "default_tilt_rate")]
    pub tilt_rate_deg_s: f64,
    #[serde(default = "default_max_angle")]
    pub max_angle_deg: f64,
    /// How far down the plate (m, mean over the sample) counts as sliding.
    #[serde(default = "default_slide_distance")]
    pub slide_distance: f64,
    #[serde(default = "default_time_step_percent")]
    pub time_step_percent: f64,
    #[serde(default = "default_rest_speed")]
    pub settle_speed: f64,
    #[serde(default = "default_settle_max_time")]
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
    pub ramp_angle_deg: f64,
    /// Slope distance from the release point to the foot (m).
    pub ramp_length: f64,
    /// Releases to average over.
    #[serde(default = "default_releases")]
    pub releases: usize,
    #[serde(default = "default_time_step_percent")]
    pub time_step_percent: f64,
    /// At rest when the particle's speed falls below this (m/s).
    #[serde(default = "default_rest_speed")]
    pub rest_speed: f64,
    /// Longest simulated time per release (s).
    #[serde(default = "default_max_time")]
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
        return Err(format!(
            "{}: {}.{key}: expected a positive number, got {v}",
            file.name, file.test
        ));
    }
    Ok(())
}

fn load(file: &TestFile, text: &str) -> Result<Simulation, String> {
    Scene::from_toml(text, &file.name, std::path::Path::new("."))
        .map(|s| s.simulation)
        .map_err(|e| e.to_string())
}

/// The centre of mass of every particle (free spheres and clumps).
fn centres(sim: &Simulation) -> Vec<DVec3> {
    let p = &sim.particles;
    let mut out: Vec<DVec3> = (0..p.len())
        .filter(|&k| p.body[k] == dem::particles::NO_BODY)
        .map(|k| p.position[k])
        .collect();
    out.extend(sim.bodies.position.iter().cloned());
    out
}

fn rms_speed(sim: &Simulation) -> f64 {
    (2.0 * sim.kinetic_energy() / sim.total_mass()).sqrt()
}

pub fn run_tilt(
    file: &TestFile,
    seed_override: Option<u64>,
    progress: &mut dyn FnMut(&str, f64) -> Result<(), String>,
) -> Result<TiltOutcome, String> {
    use toml::Value;
    let s: TiltSettings = file.settings()?;
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
        return Err(format!(
            "{}: incline_tilt.max_angle_deg: expected less than 90, got {}",
            file.name, s.max_angle_deg
        ));
    }
    file.check_particles(&s.particles)?;
    let seed = seed_override.or(file.seed).unwrap_or(1);
    let [length, width] = s.plate_size;
    // The sample is dropped from a few millimetres onto the middle of the plate.
    let side = (0.25 * length.min(width)).max(0.01);
    let tilt_time = s.max_angle_deg / s.tilt_rate_deg_s;
    let simulation = table(vec![
        ("duration", Value::Float(s.settle_max_time + tilt_time)),
        ("time_step_percent", Value::Float(s.time_step_percent)),
        (
            "domain",
            table(vec![
                ("min", arr([-length, -length, -length])),
                ("max", arr([length, length, length])),
            ]),
        ),
    ]);
    let plate = plate_geometry(&s.plate_material, 0.5 * length, 0.5 * width, 0.0);
    let particles = group(
        &s.particles,
        vec![
            (
                "region",
                table(vec![
                    ("type", text("box")),
                    ("min", arr([-0.5 * side, -0.5 * side, 0.0])),
                    ("max", arr([0.5 * side, 0.5 * side, side])),
                ]),
            ),
            (
                "fill",
                table(vec![
                    ("type", text("random")),
                    ("count", Value::Integer(s.count as i64)),
                    ("seed", Value::Integer(seed as i64)),
                ]),
            ),
        ],
    );
    let mut sim = load(
        file,
        &file.scene_text(simulation, vec![plate], vec![particles])?,
    )?;
    let wall = Instant::now();
    let fail = |e: dem::sim::SimError| format!("{}: simulation failed: {e}", file.name);
    let chunk = ((0.005 / sim.params.time_step).ceil() as u64).max(1);
    while sim.time < s.settle_max_time {
        sim.run(chunk).map_err(fail)?;
        progress("settle", sim.time)?;
        if sim.time > 0.05 && rms_speed(&sim) < s.settle_speed {
            break;
        }
    }
    // Tilt about the y axis through the plate's top centre: +x goes down.
    let start = sim.time;
    let omega = s.tilt_rate_deg_s.to_radians();
    sim.geometries[0].motion.push(Motion::Rotation {
        axis_point: DVec3::ZERO,
        axis: DVec3::Y,
        angular_velocity: omega,
        start,
        end: start + tilt_time,
    });
    let local = |sim: &Simulation| -> f64 {
        let g = &sim.geometries[0];
        let xs = centres(sim);
        xs.iter()
            .map(|x| (g.rotation.transpose() * (*x - g.translation)).x)
            .sum::<f64>()
            / xs.len() as f64
    };
    let at_start = local(&sim);
    let step_chunk = ((0.001 / sim.params.time_step).ceil() as u64).max(1);
    let mut slid = false;
    while sim.time < start + tilt_time {
        sim.run(step_chunk).map_err(fail)?;
        if local(&sim) - at_start > s.slide_distance {
            slid = true;
            break;
        }
        progress("tilt", sim.time)?;
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

pub fn run_slide(
    file: &TestFile,
    seed_override: Option<u64>,
    progress: &mut dyn FnMut(&str, f64) -> Result<(), String>,
) -> Result<SlideOutcome, String> {
    use toml::Value;
    let s: SlideSettings = file.settings()?;
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
        return Err(format!(
            "{}: incline_slide.ramp_angle_deg: expected less than 90, got {}",
            file.name, s.ramp_angle_deg
        ));
    }
    file.check_particles(&s.particles)?;
    let seed = seed_override.or(file.seed).unwrap_or(1);
    let theta = s.ramp_angle_deg.to_radians();
    let normal = DVec3::new(theta.sin(), 0.0, theta.cos());
    let top = DVec3::new(
        -s.ramp_length * theta.cos(),
        0.0,
        s.ramp_length * theta.sin(),
    );
    let reach = s.ramp_length + 1.0;
    let simulation = table(vec![
        ("duration", Value::Float(s.max_time)),
        ("time_step_percent", Value::Float(s.time_step_percent)),
        (
            "domain",
            table(vec![
                ("min", arr([-reach, -reach, -0.05])),
                ("max", arr([reach, reach, reach + 2.0])),
            ]),
        ),
    ]);
    let plate_material = s.plate_material.clone().unwrap_or(s.ramp_material.clone());
    let geometries = vec![
        table(vec![
            ("name", text("plate")),
            ("type", text("plane")),
            ("material", text(&plate_material)),
            ("point", arr([0.0; 3])),
            ("normal", arr([0.0, 0.0, 1.0])),
        ]),
        table(vec![
            ("name", text("ramp")),
            ("type", text("plane")),
            ("material", text(&s.ramp_material)),
            ("point", arr([0.0; 3])),
            ("normal", arr(normal.to_array())),
        ]),
    ];
    // A mixture is released type by type in its number shares (the scene checks the names).
    let key = format!("{}: incline_slide.particles", file.name);
    let types: Vec<String> = match s.particles.get("types") {
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
    let fractions: Vec<f64> = match s.particles.get("fractions") {
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
    let mut released = vec![0.0; types.len()];

    let wall = Instant::now();
    let mut distances = Vec::new();
    let mut release_types = Vec::new();
    let mut stopped_on_ramp = 0;
    let mut simulated = 0.0;
    for release in 0..s.releases {
        let mut particles = s.particles.clone();
        if !types.is_empty() {
            let k = furthest_below_share(&released, &fractions);
            released[k] += 1.0;
            let t = particles.as_table_mut().unwrap();
            t.insert("types".into(), Value::Array(vec![text(&types[k])]));
            t.remove("fractions");
            t.remove("basis");
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
        // Made well above everything, then set down on the ramp (any orientation, from rest).
        let particles = group(
            &particles,
            vec![
                (
                    "region",
                    table(vec![
                        ("type", text("box")),
                        ("min", arr([-0.1, -0.1, reach])),
                        ("max", arr([0.1, 0.1, reach + 0.2])),
                    ]),
                ),
                (
                    "fill",
                    table(vec![
                        ("type", text("random")),
                        ("count", Value::Integer(1)),
                        ("seed", Value::Integer((seed + release as u64) as i64)),
                    ]),
                ),
            ],
        );
        let mut sim = load(
            file,
            &file.scene_text(simulation.clone(), geometries.clone(), vec![particles])?,
        )?;
        let com = centres(&sim)[0];
        let lowest = (0..sim.particles.len())
            .map(|k| (sim.particles.position[k] - com).dot(normal) - sim.particles.radius[k])
            .fold(f64::INFINITY, f64::min);
        // Lowest point a hair above the ramp at the release point.
        let gap = 1e-5;
        sim.shift(top + normal * (gap - lowest) - com);
        let fail = |e: dem::sim::SimError| {
            format!("{}: release {release}: simulation failed: {e}", file.name)
        };
        let chunk = ((0.005 / sim.params.time_step).ceil() as u64).max(1);
        loop {
            sim.run(chunk).map_err(fail)?;
            progress(&format!("release {}/{}", release + 1, s.releases), sim.time)?;
            if sim.time > 0.05 && rms_speed(&sim) < s.rest_speed {
                break;
            }
            if sim.time >= s.max_time {
                return Err(format!(
                    "{}: incline_slide: release {release} still moves at {:.3} m/s after max_time = {} s; allow more time",
                    file.name,
                    rms_speed(&sim),
                    s.max_time
                ));
            }
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
