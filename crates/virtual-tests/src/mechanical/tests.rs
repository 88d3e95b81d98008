//! The five mechanical tests: their fixtures and tools. The specimen lies along x, centred at the
//! origin; loads come down along -z (tension pulls along +x).
//!
//! - `shear`: two support blocks with a slot between them, a blade (a thin block) coming down
//!   through the slot across the stalk (the grooved shear fixture of docs/lab-tests.md section 3).
//! - `compression`: radial compression between two flat plates (section 4).
//! - `bending`: three-point bending: two cylindrical supports `span` apart, a cylindrical punch
//!   in the middle (section 5).
//! - `tension`: the spheres within `grip_length` of each end are gripped; one grip pulls along
//!   the axis (the simplest check of bond strength).
//! - `cantilever`: one end gripped, the spheres within `grip_length` of the other end driven down
//!   (V7 of docs/physics.md in test form).

use dem::scene::{GeometryDescription, GeometryShape, SceneDescription};
use dem::Simulation;
use glam::DVec3;
use serde::{Deserialize, Serialize};

use super::{
    check_loading, load, pictures, responses, specimen_group, summary, LoadingSettings,
    MechanicalOutcome, SpecimenSettings, Tool, RESPONSES,
};
use crate::file::TestFile;
use crate::harness;
use crate::virtual_test::{Picture, Response, Run, TestError, VirtualTest};

/// `[shear]`, `[compression]`, `[bending]`, `[tension]`, `[cantilever]`: the specimen, the
/// loading, the fixture's material and dimensions (each test uses its own).
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Settings {
    pub specimen: SpecimenSettings,
    /// The fixture's and tool's material (e.g. steel).
    pub fixture_material: String,
    #[serde(flatten)]
    pub loading: LoadingSettings,
    /// shear: gap between the supports (m; default 1.5 blade thicknesses).
    #[serde(deserialize_with = "dem::units::length::opt", default)]
    pub slot_width: Option<f64>,
    /// shear: blade thickness (m; default 1 mm).
    #[serde(deserialize_with = "dem::units::length::opt", default)]
    pub blade_thickness: Option<f64>,
    /// shear: whether cover blocks over the supports hold the specimen down, as the holes or
    /// the clamped lid of a lab shear fixture do (default true); without them a compliant
    /// specimen bends down into the slot and its ends lift instead of being cut.
    pub clamped: Option<bool>,
    /// bending: distance between the supports (m).
    #[serde(deserialize_with = "dem::units::length::opt", default)]
    pub span: Option<f64>,
    /// bending: radii of the supports and the punch (m; default 5 mm).
    #[serde(deserialize_with = "dem::units::length::opt", default)]
    pub support_radius: Option<f64>,
    #[serde(deserialize_with = "dem::units::length::opt", default)]
    pub punch_radius: Option<f64>,
    /// tension, cantilever: length of each gripped end (m; default a tenth of the specimen).
    #[serde(deserialize_with = "dem::units::length::opt", default)]
    pub grip_length: Option<f64>,
}

/// Which test.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    Shear,
    Compression,
    Bending,
    Tension,
    Cantilever,
}

impl Kind {
    fn name(self) -> &'static str {
        match self {
            Kind::Shear => "shear",
            Kind::Compression => "compression",
            Kind::Bending => "bending",
            Kind::Tension => "tension",
            Kind::Cantilever => "cantilever",
        }
    }

    /// The keys of [`Settings`] this test uses beyond the common ones.
    fn own_keys(self) -> &'static [&'static str] {
        match self {
            Kind::Shear => &["slot_width", "blade_thickness", "clamped"],
            Kind::Bending => &["span", "support_radius", "punch_radius"],
            Kind::Tension | Kind::Cantilever => &["grip_length"],
            Kind::Compression => &[],
        }
    }
}

pub struct Shear;
pub struct Compression;
pub struct Bending;
pub struct Tension;
pub struct Cantilever;

fn positive(file: &TestFile, key: String, v: f64) -> Result<f64, String> {
    if v > 0.0 && v.is_finite() {
        Ok(v)
    } else {
        Err(format!(
            "{}: {key}: expected a positive number, got {v}",
            file.name
        ))
    }
}

fn check(kind: Kind, file: &TestFile, s: &Settings) -> Result<(), String> {
    let t = kind.name();
    check_loading(file, t, &s.loading)?;
    file.check_material(&format!("{t}.fixture_material"), &s.fixture_material)?;
    let given = [
        ("slot_width", s.slot_width),
        ("blade_thickness", s.blade_thickness),
        ("span", s.span),
        ("support_radius", s.support_radius),
        ("punch_radius", s.punch_radius),
        ("grip_length", s.grip_length),
    ];
    for (k, v) in given {
        if let Some(v) = v {
            if !kind.own_keys().contains(&k) {
                return Err(format!(
                    "{}: {t}.{k}: not used by the {t} test (it uses: {})",
                    file.name,
                    kind.own_keys().join(", ")
                ));
            }
            positive(file, format!("{t}.{k}"), v)?;
        }
    }
    let sp = &s.specimen;
    if s.clamped.is_some() && kind != Kind::Shear {
        return Err(format!(
            "{}: {t}.clamped: not used by the {t} test (it uses: {})",
            file.name,
            kind.own_keys().join(", ")
        ));
    }
    positive(file, format!("{t}.specimen.length"), sp.length)?;
    positive(file, format!("{t}.specimen.diameter"), sp.diameter)?;
    match kind {
        Kind::Bending => {
            let span = s.span.ok_or_else(|| {
                format!(
                    "{}: {t}.span: missing; expected the support distance (m)",
                    file.name
                )
            })?;
            if span >= sp.length {
                return Err(format!(
                    "{}: {t}.span: {span} m is not shorter than the specimen ({} m)",
                    file.name, sp.length
                ));
            }
        }
        Kind::Shear => {
            let (slot, blade) = shear_sizes(s);
            if blade >= slot {
                return Err(format!(
                    "{}: {t}.blade_thickness: the blade ({blade} m) must be thinner than the slot ({slot} m)",
                    file.name
                ));
            }
        }
        Kind::Tension | Kind::Cantilever => {
            if 2.0 * grip(s) >= sp.length {
                return Err(format!(
                    "{}: {t}.grip_length: two grips of {} m do not fit on the {} m specimen",
                    file.name,
                    grip(s),
                    sp.length
                ));
            }
        }
        Kind::Compression => {
            // Radial compression: past the diameter the plates would meet through the stalk.
            if s.loading.max_displacement >= sp.diameter {
                return Err(format!(
                    "{}: {t}.max_displacement: {} m is not less than the specimen's diameter ({} m): the plates would meet",
                    file.name, s.loading.max_displacement, sp.diameter
                ));
            }
        }
    }
    Ok(())
}

fn shear_sizes(s: &Settings) -> (f64, f64) {
    let blade = s.blade_thickness.unwrap_or(0.001);
    (s.slot_width.unwrap_or(1.5 * blade), blade)
}

fn grip(s: &Settings) -> f64 {
    s.grip_length.unwrap_or(0.1 * s.specimen.length)
}

fn block(name: &str, material: &str, min: DVec3, max: DVec3) -> GeometryDescription {
    GeometryDescription {
        name: name.into(),
        material: material.into(),
        // A box's faces are two-sided rectangles: closed, it is a solid block from outside.
        shape: GeometryShape::Box {
            min,
            max,
            open: Vec::new(),
        },
        motion: Vec::new(),
        torque_point: None,
    }
}

fn roller(
    name: &str,
    material: &str,
    x: f64,
    z: f64,
    radius: f64,
    width: f64,
) -> GeometryDescription {
    GeometryDescription {
        name: name.into(),
        material: material.into(),
        shape: GeometryShape::Cylinder {
            base: DVec3::new(x, -0.5 * width, z),
            axis: DVec3::Y,
            radius,
            length: width,
            bottom_cap: true,
            top_cap: true,
        },
        motion: Vec::new(),
        torque_point: None,
    }
}

/// The test's scene: fixture, tool and specimen.
fn scene(kind: Kind, file: &TestFile, s: &Settings, seed: u64) -> Result<SceneDescription, String> {
    let t = kind.name();
    let sp = &s.specimen;
    let (l, d) = (sp.length, sp.diameter);
    let half = 0.5 * d;
    let m = &s.fixture_material;
    // Pieces of a broken specimen fall onto a catch floor below the fixture and may slide or fly
    // off sideways, as in the lab: the domain is wide so that only an exploding run leaves it.
    let floor = -half - 2.0 * d - s.loading.max_displacement;
    let reach = 100.0 * l.max(d);
    let simulation = harness::simulation(
        s.loading.time_step_percent,
        (
            DVec3::new(-reach, -reach, floor - d),
            DVec3::new(reach, reach, reach),
        ),
    );
    let catch_floor = GeometryDescription {
        name: "catch_floor".into(),
        material: m.clone(),
        shape: GeometryShape::Plane {
            point: DVec3::new(0.0, 0.0, floor),
            normal: DVec3::Z,
        },
        motion: Vec::new(),
        torque_point: None,
    };
    let wide = 2.0 * d;
    let mut geometries = match kind {
        Kind::Shear => {
            let (slot, blade) = shear_sizes(s);
            let x_out = l;
            let mut blocks = vec![
                block(
                    "support_left",
                    m,
                    DVec3::new(-x_out, -wide, -half - d),
                    DVec3::new(-0.5 * slot, wide, -half),
                ),
                block(
                    "support_right",
                    m,
                    DVec3::new(0.5 * slot, -wide, -half - d),
                    DVec3::new(x_out, wide, -half),
                ),
                block(
                    "blade",
                    m,
                    DVec3::new(-0.5 * blade, -wide, half),
                    DVec3::new(0.5 * blade, wide, half + d),
                ),
            ];
            if s.clamped.unwrap_or(true) {
                for (name, lo, hi) in [
                    ("clamp_left", -x_out, -0.5 * slot),
                    ("clamp_right", 0.5 * slot, x_out),
                ] {
                    blocks.push(block(
                        name,
                        m,
                        DVec3::new(lo, -wide, half),
                        DVec3::new(hi, wide, half + d),
                    ));
                }
            }
            blocks
        }
        Kind::Compression => {
            let x_out = l;
            vec![
                block(
                    "bottom_plate",
                    m,
                    DVec3::new(-x_out, -wide, -half - 0.1 * d),
                    DVec3::new(x_out, wide, -half),
                ),
                block(
                    "top_plate",
                    m,
                    DVec3::new(-x_out, -wide, half),
                    DVec3::new(x_out, wide, half + 0.1 * d),
                ),
            ]
        }
        Kind::Bending => {
            let span = s.span.unwrap_or(0.5 * l);
            let rs = s.support_radius.unwrap_or(0.005);
            let rp = s.punch_radius.unwrap_or(0.005);
            vec![
                roller("support_left", m, -0.5 * span, -half - rs, rs, 2.0 * wide),
                roller("support_right", m, 0.5 * span, -half - rs, rs, 2.0 * wide),
                roller("punch", m, 0.0, half + rp, rp, 2.0 * wide),
            ]
        }
        Kind::Tension | Kind::Cantilever => Vec::new(),
    };
    geometries.push(catch_floor);
    let group = specimen_group(file, t, sp, seed)?;
    Ok(file.scene(simulation, geometries, vec![group]))
}

/// The tool of a built simulation.
fn tool(kind: Kind, s: &Settings, sim: &Simulation) -> Tool {
    let ends = |sim: &Simulation| {
        let g = grip(s);
        let half = 0.5 * s.specimen.length;
        let p = &sim.particles;
        let mut left: Vec<u32> = (0..p.len())
            .filter(|&k| p.position[k].x < -half + g)
            .map(|k| p.id[k])
            .collect();
        let mut right: Vec<u32> = (0..p.len())
            .filter(|&k| p.position[k].x > half - g)
            .map(|k| p.id[k])
            .collect();
        left.sort_unstable();
        right.sort_unstable();
        (left, right)
    };
    match kind {
        Kind::Shear => Tool::Geometry {
            name: "blade".into(),
            direction: -DVec3::Z,
        },
        Kind::Compression => Tool::Geometry {
            name: "top_plate".into(),
            direction: -DVec3::Z,
        },
        Kind::Bending => Tool::Geometry {
            name: "punch".into(),
            direction: -DVec3::Z,
        },
        Kind::Tension => {
            let (fixed, moving) = ends(sim);
            Tool::Grip {
                moving,
                fixed,
                direction: DVec3::X,
            }
        }
        Kind::Cantilever => {
            let (fixed, moving) = ends(sim);
            Tool::Grip {
                moving,
                fixed,
                direction: -DVec3::Z,
            }
        }
    }
}

/// Cross-section and length for stress and strain.
fn dimensions(kind: Kind, s: &Settings) -> (f64, f64) {
    let sp = &s.specimen;
    let section = std::f64::consts::PI / 4.0 * (sp.diameter.powi(2) - sp.hollow_diameter.powi(2));
    match kind {
        Kind::Shear => (section, sp.diameter),
        // The projected area the plates press on, strain across the diameter.
        Kind::Compression => (sp.length * sp.diameter, sp.diameter),
        Kind::Bending => (section, s.span.unwrap_or(0.5 * sp.length)),
        Kind::Tension | Kind::Cantilever => (section, sp.length - 2.0 * grip(s)),
    }
}

fn run(
    kind: Kind,
    file: &TestFile,
    s: &Settings,
    run: &mut Run,
) -> Result<MechanicalOutcome, TestError> {
    let t = kind.name();
    let description = scene(kind, file, s, run.seed)?;
    let built = file.build(&description, &format!("{t}.specimen"))?;
    let mut sim = built.simulation;
    // Set the specimen down on its supports, and find how far the tool is from touching it: the
    // fixture is drawn at the specimen's envelope, which its spheres do not quite fill.
    let mut approach = 0.0;
    if matches!(kind, Kind::Shear | Kind::Compression | Kind::Bending) {
        let half = 0.5 * s.specimen.diameter;
        let p = &sim.particles;
        let lowest = (0..p.len())
            .map(|k| p.position[k].z - p.radius[k])
            .fold(f64::INFINITY, f64::min);
        sim.shift(DVec3::Z * (-half - lowest));
        // The blade meets only the spheres under it (a lattice's top row may lie beside it).
        let reach = match kind {
            Kind::Shear => 0.5 * shear_sizes(s).1,
            _ => f64::INFINITY,
        };
        let p = &sim.particles;
        let top = (0..p.len())
            .filter(|&k| p.position[k].x.abs() < reach + p.radius[k])
            .map(|k| p.position[k].z + p.radius[k])
            .fold(f64::NEG_INFINITY, f64::max);
        if top.is_finite() {
            approach = (half - top).max(0.0);
        }
    }
    let tool = tool(kind, s, &sim);
    if let Tool::Grip { moving, fixed, .. } = &tool {
        if moving.is_empty() || fixed.is_empty() {
            return Err(TestError::Settings(format!(
                "{}: {t}.grip_length: a grip holds no sphere; make it longer",
                file.name
            )));
        }
    }
    let (area, length) = dimensions(kind, s);
    let mut outcome = load(file, t, sim, tool, &s.loading, approach, area, length, run)?;
    for w in built.warnings.into_iter().rev() {
        if !outcome.warnings.contains(&w) {
            outcome.warnings.insert(0, w);
        }
    }
    Ok(outcome)
}

/// The mechanical tests' sections (one for all five: they read the same settings). serde lists
/// no keys for a struct that flattens another, so the settings' own keys come from serialising
/// a minimal one, where every field shows (an absent option as null).
fn reference_sections() -> Vec<(String, Vec<&'static str>)> {
    let minimal: Settings = toml::from_str(
        "fixture_material = \"steel\"\nspeed = 0.1\nmax_displacement = 0.001\n\
         specimen = { material = \"stalk\", radius = 0.001, length = 0.02, diameter = 0.01 }",
    )
    .expect("the minimal mechanical settings read");
    let json = serde_json::to_value(&minimal).expect("settings serialise");
    let own: Vec<&'static str> = json
        .as_object()
        .map(|o| {
            o.keys()
                .map(|k| &*Box::leak(k.clone().into_boxed_str()))
                .collect()
        })
        .unwrap_or_default();
    vec![
        (
            "shear, compression, bending, tension, cantilever".into(),
            own,
        ),
        (
            "specimen".into(),
            dem::keys::of::<super::SpecimenSettings>(),
        ),
    ]
}

macro_rules! mechanical_test {
    ($ty:ident, $kind:expr, $about:expr) => {
        impl VirtualTest for $ty {
            type Settings = Settings;
            type Outcome = MechanicalOutcome;

            fn name(&self) -> &'static str {
                $kind.name()
            }

            fn about(&self) -> &'static str {
                $about
            }

            fn reference_sections(&self) -> Vec<(String, Vec<&'static str>)> {
                reference_sections()
            }

            fn response_names(&self) -> &'static [&'static str] {
                RESPONSES
            }

            fn check(&self, file: &TestFile, s: &Settings) -> Result<(), String> {
                check($kind, file, s)
            }

            fn settings_value(&self, s: &Settings) -> Option<toml::Value> {
                toml::Value::try_from(s).ok()
            }

            fn check_scene(&self, file: &TestFile, s: &Settings, seed: u64) -> Result<(), String> {
                let t = $kind.name();
                file.build(&scene($kind, file, s, seed)?, &format!("{t}.specimen"))
                    .map(|_| ())
            }

            fn run(
                &self,
                file: &TestFile,
                s: &Settings,
                r: &mut Run,
            ) -> Result<MechanicalOutcome, TestError> {
                run($kind, file, s, r)
            }

            fn responses(&self, o: &MechanicalOutcome) -> Vec<(&'static str, Response)> {
                responses(o)
            }

            fn summary(&self, o: &MechanicalOutcome) -> String {
                summary($kind.name(), o)
            }

            fn rejected(&self, o: &MechanicalOutcome) -> Option<String> {
                super::rejected($kind.name(), o)
            }

            fn pictures(&self, o: &MechanicalOutcome) -> Result<Vec<Picture>, String> {
                pictures($kind.name(), o)
            }
        }
    };
}

mechanical_test!(
    Shear,
    Kind::Shear,
    "a blade comes down through the slot of a support across a bonded stalk; force-displacement curve"
);
mechanical_test!(
    Compression,
    Kind::Compression,
    "a bonded stalk compressed radially between two flat plates; force-displacement curve"
);
mechanical_test!(
    Bending,
    Kind::Bending,
    "three-point bending of a bonded stalk on two cylindrical supports; force-displacement curve"
);
mechanical_test!(
    Tension,
    Kind::Tension,
    "a bonded bar gripped at both ends and pulled along its axis; force-displacement curve"
);
mechanical_test!(
    Cantilever,
    Kind::Cantilever,
    "a bonded bar gripped at one end, the other end driven down; force-displacement curve"
);
