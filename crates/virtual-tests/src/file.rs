//! Virtual test files: TOML with `test = "<name>"`, the materials, interactions and particle
//! types in the scene format (`[[material]]`, `[[interaction]]`, `[[particle_type]]`), and a
//! table named after the test with its settings.
//!
//! The scene parts are read into the engine's typed scene description when the file is read, so
//! their errors name the file and the key exactly as a scene file's do. A test then writes its
//! scene in Rust ([`TestFile::scene`]) and builds it ([`TestFile::build`]); errors of the built
//! scene are told in the test's terms (`angle_of_repose.particles.size.radius`).
//!
//! The constructors that check the test's name against the registry ([`TestFile::load`],
//! [`TestFile::parse`], [`TestFile::from_table`]) live in [`crate::registry`], so that this
//! module, which every test uses, does not depend on the tests.

use std::path::{Path, PathBuf};

use dem::scene::parse::{self, SharedParts};
use dem::scene::{
    prepare_shapes, GeometryDescription, GroupParticles, OutputDescription, ParticleGroup,
    RunLength, Scene, SceneDescription, SceneError, SimulationSettings,
};
use dem::sim::BACKEND_NAMES;
use serde::de::DeserializeOwned;

/// The keys of a test file's top level (beside the table named after its test).
pub const FILE_KEYS: &[&str] = &[
    "test",
    "seed",
    "backend",
    "material",
    "interaction",
    "particle_type",
    "bond",
    "density_scaling",
];

/// The tests whose files may set `density_scaling`: the quasi-static mechanical tests, whose
/// result must not depend on inertia. A flow test (a heap, a slide) is all inertia.
pub const DENSITY_SCALING_TESTS: &[&str] =
    &["shear", "compression", "bending", "tension", "cantilever"];

/// The largest `density_scaling`: 1e8 makes the step 1e4 times longer, past what any quasi-static
/// test needs (the kinetic-energy check would refuse the run anyway).
pub const MAX_DENSITY_SCALING: f64 = 1e8;

/// A test file read into its parts.
#[derive(Clone, Debug)]
pub struct TestFile {
    /// For messages: the file's path.
    pub name: String,
    /// The folder relative paths in the file are taken from.
    pub folder: PathBuf,
    pub test: String,
    pub seed: Option<u64>,
    /// The back end that runs the test's simulations (`backend`, or the command line's
    /// `--backend`); `None` leaves the scene's default, the CPU.
    pub backend: Option<String>,
    /// `[[material]]`, `[[interaction]]` and `[[particle_type]]`, typed.
    pub parts: SharedParts,
    /// The table named after the test.
    pub settings: toml::Value,
    /// `density_scaling = F` (mechanical tests): every particle's mass and inertia times F, so
    /// the step is sqrt(F) times longer; the weight stays the real one (gravity over F). 1 = off.
    pub density_scaling: f64,
}

impl TestFile {
    /// Reads the parts of a test file already read as TOML, for a test that exists and
    /// (`needs_materials`) simulates particles.
    pub(crate) fn read(
        name: &str,
        folder: &Path,
        value: &toml::Table,
        test: &str,
        needs_materials: bool,
    ) -> Result<TestFile, String> {
        for key in value.keys() {
            if key != test && !FILE_KEYS.contains(&key.as_str()) {
                return Err(format!(
                    "{name}: {key}: unknown key (expected test, seed, backend, material, interaction, particle_type, bond, density_scaling, {test})"
                ));
            }
        }
        let seed = match value.get("seed") {
            None => None,
            Some(toml::Value::Integer(s)) if *s >= 0 => Some(*s as u64),
            Some(_) => return Err(format!("{name}: seed: expected a whole number >= 0")),
        };
        let backend = match value.get("backend") {
            None => None,
            Some(toml::Value::String(b)) if BACKEND_NAMES.contains(&b.as_str()) => Some(b.clone()),
            Some(v) => {
                return Err(format!(
                    "{name}: backend: expected {}, got {v}",
                    dem::sim::backend_choices()
                ))
            }
        };
        let density_scaling = match value.get("density_scaling") {
            None => 1.0,
            Some(_) if !DENSITY_SCALING_TESTS.contains(&test) => {
                return Err(format!(
                    "{name}: density_scaling: only for the quasi-static mechanical tests ({}); the {test} test depends on inertia",
                    DENSITY_SCALING_TESTS.join(", ")
                ))
            }
            Some(v) => match v.as_float().or_else(|| v.as_integer().map(|i| i as f64)) {
                Some(f) if (1.0..=MAX_DENSITY_SCALING).contains(&f) => f,
                _ => {
                    return Err(format!(
                        "{name}: density_scaling: expected a number from 1 (off) to {MAX_DENSITY_SCALING:e}, got {v}"
                    ))
                }
            },
        };
        let settings = value
            .get(test)
            .cloned()
            .ok_or_else(|| format!("{name}: {test}: missing table [{test}]"))?;
        if needs_materials {
            for (key, what) in [
                ("material", "[[material]]"),
                ("interaction", "[[interaction]]"),
            ] {
                if !value.contains_key(key) {
                    return Err(format!("{name}: {key}: missing {what}"));
                }
            }
        }
        let parts = parse::shared_parts(value, name, folder).map_err(|e| e.to_string())?;
        Ok(TestFile {
            name: name.to_string(),
            folder: folder.to_path_buf(),
            test: test.to_string(),
            seed,
            backend,
            parts,
            settings,
            density_scaling,
        })
    }

    /// A path given in the file, taken relative to the file's folder.
    pub fn resolve(&self, path: &str) -> PathBuf {
        self.folder.join(path)
    }

    /// The settings table as `T`, with errors naming the key.
    pub fn settings<T: DeserializeOwned>(&self) -> Result<T, String> {
        serde_path_to_error::deserialize(self.settings.clone()).map_err(|e| {
            let path = e.path().to_string();
            let msg = one_line(&e.into_inner().to_string());
            if path == "." || path.is_empty() {
                format!("{}: {}: {msg}", self.name, self.test)
            } else {
                format!("{}: {}.{path}: {msg}", self.name, self.test)
            }
        })
    }

    /// An error about the test's setting `key`: `file: test.key: message`.
    pub fn error(&self, key: &str, message: impl std::fmt::Display) -> String {
        format!("{}: {}.{key}: {message}", self.name, self.test)
    }

    /// Checks that the setting `key` names one of the file's materials.
    pub fn check_material(&self, key: &str, material: &str) -> Result<(), String> {
        let known: Vec<&str> = self
            .parts
            .materials
            .iter()
            .map(|m| m.name.as_str())
            .collect();
        if known.contains(&material) {
            Ok(())
        } else {
            Err(self.error(
                key,
                format!(
                    "unknown material \"{material}\" (defined: {})",
                    known.join(", ")
                ),
            ))
        }
    }

    /// Checks a test's `particles` setting: one type inline (`material` with `size`, or with
    /// `shape` and `scale`) or a mixture (`types`, `fractions`, `basis`), in the scene format.
    /// Where and how many is the test's business.
    pub fn check_particles(&self, particles: &toml::Value) -> Result<(), String> {
        let key = format!("{}: {}.particles", self.name, self.test);
        let t = particles
            .as_table()
            .ok_or_else(|| format!("{key}: expected a table, e.g. {{ material = \"bead\", size = {{ type = \"fixed\", radius = 0.002 }} }}"))?;
        for k in t.keys() {
            if ![
                "material",
                "size",
                "shape",
                "scale",
                "types",
                "fractions",
                "basis",
            ]
            .contains(&k.as_str())
            {
                return Err(format!(
                    "{key}.{k}: unknown key (expected material, size, shape, scale, types, fractions, basis)"
                ));
            }
        }
        Ok(())
    }

    /// The test's `particles` setting read as a scene group's particles (checked first with
    /// [`TestFile::check_particles`]).
    pub fn particles(&self, particles: &toml::Value) -> Result<GroupParticles, String> {
        self.check_particles(particles)?;
        parse::group_particles(
            particles.clone(),
            &self.name,
            &format!("{}.particles", self.test),
            &self.folder,
        )
        .map_err(|e| e.to_string())
    }

    /// A scene with this file's materials, interactions and particle types, and what the test
    /// sets up.
    pub fn scene(
        &self,
        simulation: SimulationSettings,
        geometries: Vec<GeometryDescription>,
        particles: Vec<ParticleGroup>,
    ) -> SceneDescription {
        // Density scaling: inertia times F (every density), weight unchanged (gravity over F), so
        // the Rayleigh step and the bonds' safe step both grow by sqrt(F).
        let f = self.density_scaling;
        let mut materials = self.parts.materials.clone();
        let mut simulation = simulation;
        if f != 1.0 {
            for m in &mut materials {
                m.density *= f;
            }
            simulation.gravity /= f;
        }
        SceneDescription {
            simulation,
            output: OutputDescription::default(),
            materials,
            interactions: self.parts.interactions.clone(),
            geometries,
            particle_types: self.parts.particle_types.clone(),
            particles,
            bonds: self.parts.bonds.clone(),
        }
    }

    /// Checks the file's materials and interactions as a scene would (restitution in (0, 1],
    /// frictions >= 0, every material named), without building anything else.
    pub fn check_materials(&self) -> Result<(), String> {
        let scene = self.scene(SimulationSettings::new(RunLength::Steps(1)), vec![], vec![]);
        Scene::check_materials(&scene, &self.name)
            .map(|_| ())
            .map_err(|e| e.to_string())
    }

    /// Fits every clump shape of `scene` once (kernel fits, mass properties), so that the
    /// scenes built from copies of it share them.
    pub fn prepare(&self, scene: &mut SceneDescription, placement_key: &str) -> Result<(), String> {
        prepare_shapes(scene, &self.name)
            .map(|_| ())
            .map_err(|e| self.scene_error(e, placement_key))
    }

    /// Builds a scene the test wrote. Errors name the test's keys: the particles' own keys as
    /// `<test>.particles.*`, placement problems as `placement_key` (the setting that placed
    /// them, e.g. `angle_of_repose.fill`), run settings as `<test>.<setting>`.
    pub fn build(&self, scene: &SceneDescription, placement_key: &str) -> Result<Scene, String> {
        let on_backend;
        let scene = match &self.backend {
            Some(b) if *b != scene.simulation.backend => {
                on_backend = SceneDescription {
                    simulation: SimulationSettings {
                        backend: b.clone(),
                        ..scene.simulation.clone()
                    },
                    ..scene.clone()
                };
                &on_backend
            }
            _ => scene,
        };
        Scene::from_description(scene, &self.name).map_err(|e| self.scene_error(e, placement_key))
    }

    fn scene_error(&self, mut e: SceneError, placement_key: &str) -> String {
        let own = [
            "material",
            "size",
            "shape",
            "scale",
            "types",
            "fractions",
            "basis",
        ];
        if let Some(rest) = e.key.strip_prefix("particles[0]") {
            let first = rest
                .trim_start_matches('.')
                .split(['.', '['])
                .next()
                .unwrap_or("");
            e.key = if own.contains(&first) {
                format!("{}.particles{rest}", self.test)
            } else {
                placement_key.to_string()
            };
        } else if let Some(rest) = e.key.strip_prefix("simulation.") {
            e.key = format!("{}.{rest}", self.test);
        }
        e.to_string()
    }
}

/// A TOML parser message on one line (without the source excerpt and carets).
pub fn one_line(s: &str) -> String {
    s.split('\n')
        .map(str::trim)
        .filter(|l| {
            !l.is_empty() && !l.starts_with('|') && !l.chars().all(|c| c == '^' || c == ' ')
        })
        .collect::<Vec<_>>()
        .join(" ")
}
