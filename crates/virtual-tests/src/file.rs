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
    /// `[[material]]` and `[[interaction]]` as given.
    pub materials: toml::Value,
    pub interactions: toml::Value,
    /// The table named after the test.
    pub settings: toml::Value,
}

pub const TESTS: &[&str] = &["angle_of_repose"];

impl TestFile {
    pub fn load(path: &Path) -> Result<TestFile, String> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| format!("{}: cannot read: {e}", path.display()))?;
        TestFile::parse(&path.display().to_string(), &text)
    }

    pub fn parse(name: &str, text: &str) -> Result<TestFile, String> {
        let value: toml::Table =
            toml::from_str(text).map_err(|e| format!("{name}: {}", one_line(&e.to_string())))?;
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
            if !["test", "seed", "material", "interaction", test.as_str()].contains(&key.as_str()) {
                return Err(format!(
                    "{name}: {key}: unknown key (expected test, seed, material, interaction, {test})"
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
            test,
            seed,
            materials: get("material")
                .ok_or_else(|| format!("{name}: material: missing [[material]]"))?,
            interactions: get("interaction")
                .ok_or_else(|| format!("{name}: interaction: missing [[interaction]]"))?,
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
}

fn one_line(s: &str) -> String {
    s.split('\n')
        .map(str::trim)
        .filter(|l| {
            !l.is_empty() && !l.starts_with('|') && !l.chars().all(|c| c == '^' || c == ' ')
        })
        .collect::<Vec<_>>()
        .join(" ")
}
