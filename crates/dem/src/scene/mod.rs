//! Scenes: materials, interactions, geometry, particles and run settings.
//!
//! A scene is built in two steps that can be used apart:
//!
//! 1. [`parse`] reads a scene file (TOML) into a [`SceneDescription`]: serde reads plain structs
//!    that reject unknown keys (`serde_path_to_error` supplies the key path), and each entry's
//!    form is checked (a `type` that exists, the keys that type uses, one of two alternatives).
//! 2. [`build`] turns a description into a ready [`Simulation`]: it checks every value, creates
//!    materials, geometry and particle types, picks the time step and skin, the domain, places
//!    the particles and checks their overlaps. Rust code that writes a description (a virtual
//!    test) uses this step alone, through [`Scene::from_description`].
//!
//! Every failure of either step is one [`SceneError`] line naming the file, the key as the scene
//! file spells it, and what was expected.

mod bonds;
pub mod build;
pub mod description;
mod geometry;
pub mod parse;
mod particles;
mod unit_hints;

pub use description::*;
pub use particles::prepare_shapes;

use crate::material::MaterialTable;
use crate::sim::Simulation;
use glam::DVec3;
use std::path::{Path, PathBuf};

/// The most time steps a scene may ask for: 1e10 steps take days even for a handful of
/// particles, so more is a typo (a duration in the wrong unit) rather than a plan.
pub const MAX_STEPS: u64 = 10_000_000_000;

/// The most spheres a scene may hold (a clump counts its spheres): each costs about 1 kB with
/// its neighbour list, so this is about what a workstation's memory holds. Fills are checked
/// against it before anything is allocated.
#[cfg(not(fuzzing))]
pub const MAX_SPHERES: usize = 10_000_000;
/// Under the fuzzer (cargo-fuzz builds with `--cfg fuzzing`) a scene holds at most 5 000
/// spheres, so that every input builds in well under its 10 s and 1 GB (a legitimate scene of
/// 10 million spheres takes about 10 GB; at 50 000 the scene target ran at 70 inputs a second),
/// and the limit's own path is fuzzed too.
#[cfg(fuzzing)]
pub const MAX_SPHERES: usize = 5_000;
/// The smallest and largest sphere radius a scene may give (m).
pub const MIN_RADIUS: f64 = 1e-7;
pub const MAX_RADIUS: f64 = 100.0;
/// The range of a material's shear modulus (Pa; Young's modulus is converted first): below it
/// the time step leaves any real run (1e-300 gave a step of 1e149 s), above it no solid.
pub const MIN_SHEAR_MODULUS: f64 = 1.0;
pub const MAX_SHEAR_MODULUS: f64 = 1e13;
/// The largest gravity a scene may set (m/s², 10 000 g: centrifuge tests included).
pub const MAX_GRAVITY: f64 = 1e5;
/// The largest initial speed a particle group may be given (m/s).
pub const MAX_SPEED: f64 = 1e4;

/// A scene problem: `file: key: message` (`file: message` where no key is to blame).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{file}: {}{message}", key_and_colon(.key))]
pub struct SceneError {
    pub file: String,
    pub key: String,
    pub message: String,
}

fn key_and_colon(key: &str) -> String {
    if key.is_empty() {
        String::new()
    } else {
        format!("{key}: ")
    }
}

/// Output settings of a scene.
#[derive(Clone, Debug)]
pub struct OutputSettings {
    pub directory: PathBuf,
    /// Seconds between particle snapshots (None: only the first and last).
    pub snapshot_interval: Option<f64>,
    /// Seconds between geometry load records.
    pub force_interval: f64,
    /// What the snapshots hold and how they are stored.
    pub snapshots: crate::output::SnapshotOptions,
}

/// A built scene: the simulation ready to run and what to do with it.
pub struct Scene {
    pub simulation: Simulation,
    pub steps: u64,
    pub output: OutputSettings,
    pub rayleigh_time_step: f64,
    /// Shortest collision time of the contact law at the fastest foreseen impact (s).
    pub collision_time: f64,
    /// Non-fatal remarks (few steps per collision, sizes that look like the wrong unit).
    pub warnings: Vec<String>,
    /// What was built that the user should know (e.g. each fitted kernel's volume error).
    pub notes: Vec<String>,
}

impl Scene {
    /// Reads and builds a scene file. Relative paths inside (STL files, output directory) are taken
    /// relative to the file's folder.
    pub fn load(path: &Path) -> Result<Scene, SceneError> {
        Scene::load_with_backend(path, None)
    }

    /// [`Scene::load`], on the back end `backend` in place of the file's `simulation.backend`
    /// when given (the command line's `--backend`).
    pub fn load_with_backend(path: &Path, backend: Option<&str>) -> Result<Scene, SceneError> {
        let name = path.display().to_string();
        let text = crate::files::read_text(path, crate::files::MAX_TEXT_BYTES).map_err(|e| {
            SceneError {
                file: name.clone(),
                key: String::new(),
                message: format!("cannot read the scene file: {e}"),
            }
        })?;
        let base = path.parent().unwrap_or(Path::new(".")).to_path_buf();
        let (mut description, warnings) = parse::scene_with_warnings(&text, &name, &base)?;
        if let Some(b) = backend {
            description.simulation.backend = b.to_string();
        }
        Scene::from_description(&description, &name).map(|s| s.with_warnings(warnings))
    }

    /// Builds a scene from TOML text; `file` names it in errors, `base` resolves relative paths.
    pub fn from_toml(text: &str, file: &str, base: &Path) -> Result<Scene, SceneError> {
        let (description, warnings) = parse::scene_with_warnings(text, file, base)?;
        Scene::from_description(&description, file).map(|s| s.with_warnings(warnings))
    }

    /// The parser's warnings (how the file is written) before the builder's.
    fn with_warnings(mut self, mut warnings: Vec<String>) -> Scene {
        warnings.append(&mut self.warnings);
        self.warnings = warnings;
        self
    }

    /// Builds a scene from its description; `file` names it in errors ("scene" when there is no
    /// file).
    pub fn from_description(
        description: &SceneDescription,
        file: &str,
    ) -> Result<Scene, SceneError> {
        build::build(description, &Ctx { file })
    }

    /// Checks a description's materials and interactions (the values a calibration varies) and
    /// builds their table, without placing anything: cheap enough to check every corner of a
    /// study's parameter ranges.
    pub fn check_materials(
        description: &SceneDescription,
        file: &str,
    ) -> Result<MaterialTable, SceneError> {
        let ctx = Ctx { file };
        let table = build::materials(description, &ctx)?;
        bonds::bonds(description, &ctx, &table)?;
        Ok(table)
    }
}

/// Names the file in errors and checks values on behalf of the parser and the builder.
pub(crate) struct Ctx<'a> {
    pub file: &'a str,
}

impl Ctx<'_> {
    pub fn err(&self, key: impl Into<String>, message: impl Into<String>) -> SceneError {
        // A message quotes the file's own values (a motion's type, a name), which may hold line
        // breaks: shown escaped, so that an error stays one line (a fuzz find).
        let message: String = message.into();
        let message = if message.chars().any(char::is_control) {
            message
                .chars()
                .map(|c| {
                    if c.is_control() {
                        c.escape_debug().to_string()
                    } else {
                        c.to_string()
                    }
                })
                .collect()
        } else {
            message
        };
        SceneError {
            file: self.file.to_string(),
            key: key.into(),
            message,
        }
    }

    pub fn require<T>(&self, v: Option<T>, key: String, what: &str) -> Result<T, SceneError> {
        v.ok_or_else(|| self.err(key, format!("missing; expected {what}")))
    }

    pub fn positive(&self, v: f64, key: String) -> Result<f64, SceneError> {
        if v > 0.0 && v.is_finite() {
            Ok(v)
        } else {
            Err(self.err(key, format!("expected a positive number, got {v}")))
        }
    }

    pub fn non_negative(&self, v: f64, key: String) -> Result<f64, SceneError> {
        if v >= 0.0 && v.is_finite() {
            Ok(v)
        } else {
            Err(self.err(key, format!("expected a number >= 0, got {v}")))
        }
    }

    /// A finite number (any sign).
    pub fn finite(&self, v: f64, key: String) -> Result<f64, SceneError> {
        if v.is_finite() {
            Ok(v)
        } else {
            Err(self.err(key, format!("expected a finite number, got {v}")))
        }
    }

    /// A point or vector of finite numbers.
    pub fn finite3(&self, v: DVec3, key: String) -> Result<DVec3, SceneError> {
        if v.is_finite() {
            Ok(v)
        } else {
            Err(self.err(
                key,
                format!("expected finite numbers, got [{}, {}, {}]", v.x, v.y, v.z),
            ))
        }
    }

    pub fn direction(&self, d: DVec3, key: String) -> Result<DVec3, SceneError> {
        if d.length() > 0.0 && d.is_finite() {
            Ok(d.normalize())
        } else {
            Err(self.err(key, "expected a non-zero direction vector"))
        }
    }

    /// Rejects keys that belong to other variants, so a typo in `type` is not silently ignored.
    pub fn only(
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
