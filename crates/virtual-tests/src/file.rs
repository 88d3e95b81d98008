//! Virtual test files: TOML with `test = "<name>"`, the materials and interactions in the scene
//! format (`[[material]]`, `[[interaction]]`), and a table named after the test with its settings.
//! A test builds its scene as TOML and hands it to the engine's scene loader, so material and
//! interaction errors read exactly as they do for scenes.

use std::path::Path;

use serde::de::DeserializeOwned;

/// A test file read into its parts.
#[derive(Clone, Debug)]
pub struct TestFile {
    /// For messages: the file's path.
    pub name: String,
    pub test: String,
    pub seed: Option<u64>,
    /// `[[material]]`, `[[interaction]]` and `[[particle_type]]` as given.
    pub materials: toml::Value,
    pub interactions: toml::Value,
    pub particle_types: Option<toml::Value>,
    /// The table named after the test.
    pub settings: toml::Value,
}

pub const TESTS: &[&str] = &[
    "angle_of_repose",
    "incline_tilt",
    "incline_slide",
    "function",
];

/// Tests that simulate particles and so need materials and interactions.
fn needs_materials(test: &str) -> bool {
    test != "function"
}

impl TestFile {
    pub fn load(path: &Path) -> Result<TestFile, String> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| format!("{}: cannot read: {e}", path.display()))?;
        TestFile::parse(&path.display().to_string(), &text)
    }

    pub fn parse(name: &str, text: &str) -> Result<TestFile, String> {
        let value: toml::Table =
            toml::from_str(text).map_err(|e| format!("{name}: {}", one_line(&e.to_string())))?;
        TestFile::from_table(name, &value)
    }

    /// A test file already read as TOML (a study's inline test, or one with parameters set).
    pub fn from_table(name: &str, value: &toml::Table) -> Result<TestFile, String> {
        let test = match value.get("test") {
            Some(toml::Value::String(s)) => s.clone(),
            Some(_) => return Err(format!("{name}: test: expected a string")),
            None => {
                return Err(format!(
                    "{name}: test: missing (expected one of: {})",
                    TESTS.join(", ")
                ))
            }
        };
        if !TESTS.contains(&test.as_str()) {
            return Err(format!(
                "{name}: test: unknown test \"{test}\" (expected one of: {})",
                TESTS.join(", ")
            ));
        }
        for key in value.keys() {
            if ![
                "test",
                "seed",
                "material",
                "interaction",
                "particle_type",
                test.as_str(),
            ]
            .contains(&key.as_str())
            {
                return Err(format!(
                    "{name}: {key}: unknown key (expected test, seed, material, interaction, particle_type, {test})"
                ));
            }
        }
        let seed = match value.get("seed") {
            None => None,
            Some(toml::Value::Integer(s)) if *s >= 0 => Some(*s as u64),
            Some(_) => return Err(format!("{name}: seed: expected a whole number >= 0")),
        };
        let get = |k: &str| value.get(k).cloned();
        Ok(TestFile {
            name: name.to_string(),
            settings: get(&test)
                .ok_or_else(|| format!("{name}: {test}: missing table [{test}]"))?,
            test: test.clone(),
            seed,
            materials: match get("material") {
                Some(m) => m,
                None if needs_materials(&test) => {
                    return Err(format!("{name}: material: missing [[material]]"))
                }
                None => toml::Value::Array(Vec::new()),
            },
            interactions: match get("interaction") {
                Some(i) => i,
                None if needs_materials(&test) => {
                    return Err(format!("{name}: interaction: missing [[interaction]]"))
                }
                None => toml::Value::Array(Vec::new()),
            },
            particle_types: get("particle_type"),
        })
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

    /// A scene (as TOML) with this file's materials, interactions and particle types.
    pub fn scene_text(
        &self,
        simulation: toml::Value,
        geometries: Vec<toml::Value>,
        particles: Vec<toml::Value>,
    ) -> Result<String, String> {
        let mut scene = vec![
            ("simulation", simulation),
            ("material", self.materials.clone()),
            ("interaction", self.interactions.clone()),
            ("geometry", toml::Value::Array(geometries)),
            ("particles", toml::Value::Array(particles)),
        ];
        if let Some(t) = &self.particle_types {
            scene.push(("particle_type", t.clone()));
        }
        toml::to_string(&table(scene)).map_err(|e| format!("{}: {e}", self.name))
    }
}

/// `[x, y, z]` as TOML.
pub fn arr(v: [f64; 3]) -> toml::Value {
    toml::Value::Array(v.iter().map(|x| toml::Value::Float(*x)).collect())
}

/// A TOML table from pairs.
pub fn table(pairs: Vec<(&str, toml::Value)>) -> toml::Value {
    toml::Value::Table(pairs.into_iter().map(|(k, v)| (k.to_string(), v)).collect())
}

/// A flat plate as a scene geometry: a box whose top face (z = `top`) is the only closed one, so
/// particles see a plate and nothing of its sides.
pub fn plate_geometry(material: &str, half_x: f64, half_y: f64, top: f64) -> toml::Value {
    table(vec![
        ("name", text("plate")),
        ("type", text("box")),
        ("material", text(material)),
        ("min", arr([-half_x, -half_y, top - 0.01])),
        ("max", arr([half_x, half_y, top])),
        (
            "open",
            toml::Value::Array(
                ["-x", "+x", "-y", "+y", "-z"]
                    .iter()
                    .map(|f| text(f))
                    .collect(),
            ),
        ),
    ])
}

/// A TOML string.
pub fn text(s: &str) -> toml::Value {
    toml::Value::String(s.to_string())
}

/// `particles` with more keys (region, fill, velocity) added.
pub fn group(particles: &toml::Value, extra: Vec<(&str, toml::Value)>) -> toml::Value {
    let mut t = particles.as_table().cloned().unwrap_or_default();
    for (k, v) in extra {
        t.insert(k.to_string(), v);
    }
    toml::Value::Table(t)
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
