//! Every virtual test, one line each. `demcal test`, a study's check of its response and the CLI
//! help all read this list; a new test is a module implementing
//! [`VirtualTest`](crate::virtual_test::VirtualTest) and one line here.
//!
//! The test file constructors live here too, since they check the file's `test` against the
//! list (and [`crate::file`], which the tests use, cannot depend on the tests).

use std::path::Path;

use crate::angle_of_repose::AngleOfRepose;
use crate::file::{one_line, TestFile};
use crate::function::Function;
use crate::incline::{InclineSlide, InclineTilt};
use crate::mechanical::tests::{Bending, Cantilever, Compression, Shear, Tension};
use crate::virtual_test::Registered;

/// The tests, in the order help texts list them.
pub static TESTS: &[&dyn Registered] = &[
    &AngleOfRepose,
    &InclineTilt,
    &InclineSlide,
    &Shear,
    &Compression,
    &Bending,
    &Tension,
    &Cantilever,
    &Function,
];

/// Every section of a test file, as `docs/reference.md` heads it, with the keys its reader
/// accepts: the file's top level, then each test's tables.
pub fn reference_sections() -> Vec<(String, Vec<&'static str>)> {
    let mut v = vec![("test file".to_string(), crate::file::FILE_KEYS.to_vec())];
    for t in TESTS {
        for s in t.reference_sections() {
            if !v.iter().any(|(name, _)| *name == s.0) {
                v.push(s);
            }
        }
    }
    v
}

/// The test called `name`.
pub fn find(name: &str) -> Option<&'static dyn Registered> {
    TESTS.iter().copied().find(|t| t.name() == name)
}

/// The tests' names.
pub fn names() -> Vec<&'static str> {
    TESTS.iter().map(|t| t.name()).collect()
}

impl TestFile {
    /// Reads a test file; relative paths in it are taken from its folder.
    pub fn load(path: &Path) -> Result<TestFile, String> {
        let text = dem::files::read_text(path, dem::files::MAX_TEXT_BYTES)
            .map_err(|e| format!("{}: cannot read: {e}", path.display()))?;
        let name = path.display().to_string();
        let value: toml::Table =
            toml::from_str(&text).map_err(|e| format!("{name}: {}", one_line(&e.to_string())))?;
        TestFile::from_table_in(&name, &value, path.parent().unwrap_or(Path::new(".")))
    }

    /// Reads a test file's text (relative paths from the working directory).
    pub fn parse(name: &str, text: &str) -> Result<TestFile, String> {
        let value: toml::Table =
            toml::from_str(text).map_err(|e| format!("{name}: {}", one_line(&e.to_string())))?;
        TestFile::from_table(name, &value)
    }

    /// A test file already read as TOML (a study's inline test, or one with parameters set);
    /// relative paths from the working directory.
    pub fn from_table(name: &str, value: &toml::Table) -> Result<TestFile, String> {
        TestFile::from_table_in(name, value, Path::new("."))
    }

    /// A test file already read as TOML whose relative paths are taken from `folder`.
    pub fn from_table_in(
        name: &str,
        value: &toml::Table,
        folder: &Path,
    ) -> Result<TestFile, String> {
        let list = names().join(", ");
        let test = match value.get("test") {
            Some(toml::Value::String(s)) => s.clone(),
            Some(_) => return Err(format!("{name}: test: expected a string")),
            None => return Err(format!("{name}: test: missing (expected one of: {list})")),
        };
        let registered = find(&test).ok_or_else(|| {
            format!(
                "{name}: test: unknown test \"{}\" (expected one of: {list})",
                test.escape_debug()
            )
        })?;
        TestFile::read(name, folder, value, &test, registered.needs_materials())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_test_lists_the_keys_of_its_settings() {
        for (section, keys) in reference_sections() {
            assert!(!keys.is_empty(), "{section}: no keys listed");
        }
        let all = reference_sections();
        let keys = |name: &str| &all.iter().find(|(s, _)| s == name).unwrap().1;
        // The mechanical tests' own keys and those of the flattened loading.
        let m = keys("shear, compression, bending, tension, cantilever");
        for k in [
            "specimen",
            "fixture_material",
            "speed",
            "snapshots",
            "grip_length",
        ] {
            assert!(m.contains(&k), "{k}: {m:?}");
        }
        assert!(keys("angle_of_repose.fill").contains(&"mass_rate"));
    }

    #[test]
    fn names_are_unique_and_every_test_has_responses() {
        let mut n = names();
        n.sort_unstable();
        n.dedup();
        assert_eq!(n.len(), TESTS.len());
        for t in TESTS {
            assert!(!t.response_names().is_empty(), "{}", t.name());
            assert!(!t.about().is_empty(), "{}", t.name());
        }
    }

    #[test]
    fn the_function_test_reports_its_responses_under_their_json_keys() {
        let file = TestFile::parse(
            "f.toml",
            "test = \"function\"\n[function]\nexpression = \"2*a + 1\"\nvariables = { a = 3 }\n",
        )
        .unwrap();
        let test = find("function").unwrap();
        let mut progress = |_: &str, _: f64| Ok(());
        let mut run = crate::virtual_test::Run::new(1, None, &mut progress);
        let done = test.run_file(&file, &mut run).unwrap();
        let names: Vec<&str> = done.responses.iter().map(|r| r.0).collect();
        // No curve asked for: the scalars only.
        assert_eq!(names, test.response_names()[..2]);
        for (name, r) in &done.responses {
            let crate::virtual_test::Response::Scalar(v) = r else {
                panic!("{name} is a scalar")
            };
            assert_eq!(done.json[*name].as_f64(), Some(*v), "{name}");
        }
        assert_eq!(done.json["exact"], 7.0);
        assert!(done.pictures.is_empty());
    }

    #[test]
    fn the_function_test_gives_a_curve_with_noise_per_point_when_asked() {
        let text = |noise: f64| {
            format!(
                "test = \"function\"\n[function]\nexpression = \"k\"\nvariables = {{ k = 2 }}\nnoise = {noise}\ncurve = {{ expression = \"k*x\", x_min = 0.0, x_max = 0.01, points = 5 }}\n"
            )
        };
        let run = |text: &str, seed: u64| {
            let file = TestFile::parse("f.toml", text).unwrap();
            crate::run_file(&file, Some(seed), None, &mut |_, _| Ok(())).unwrap()
        };
        let done = run(&text(0.0), 1);
        let names: Vec<&str> = done.responses.iter().map(|r| r.0).collect();
        assert_eq!(names, ["value", "exact", "force_displacement"]);
        let crate::Response::Curve {
            x,
            y,
            x_unit,
            y_unit,
            ..
        } = &done.responses[2].1
        else {
            panic!("force_displacement is a curve")
        };
        assert_eq!((x_unit.as_str(), y_unit.as_str()), ("m", "N"));
        assert_eq!(x, &[0.0, 0.0025, 0.005, 0.0075, 0.01]);
        for (x, y) in x.iter().zip(y) {
            assert!((y - 2.0 * x).abs() < 1e-15, "{x} {y}");
        }
        assert_eq!(done.json["force_displacement"]["force_n"][4], 0.02);
        // With noise: the value's draw is unchanged by the curve, each point has its own draw,
        // and the same seed gives the same curve.
        let scalar = run(
            "test = \"function\"\n[function]\nexpression = \"k\"\nvariables = { k = 2 }\nnoise = 0.1\n",
            7,
        );
        let (a, b) = (run(&text(0.1), 7), run(&text(0.1), 7));
        assert_eq!(a.json["value"], scalar.json["value"]);
        assert_eq!(a.json["force_displacement"], b.json["force_displacement"]);
        let noise: Vec<f64> = (0..5)
            .map(|i| {
                a.json["force_displacement"]["force_n"][i].as_f64().unwrap()
                    - 2.0 * 0.0025 * i as f64
            })
            .collect();
        assert!(
            noise.iter().all(|n| n.abs() > 1e-6 && n.abs() < 0.5),
            "{noise:?}"
        );
        assert!(noise.windows(2).all(|w| w[0] != w[1]), "{noise:?}");
        // Bad curve settings name the key.
        for (bad, want) in [
            (
                "x_min = 0.0, x_max = 0.0",
                "f.toml: function.curve.x_max: expected finite x_min < x_max",
            ),
            (
                "x_max = 0.01, points = 1",
                "f.toml: function.curve.points: expected 2 to 1000000 points, got 1",
            ),
        ] {
            let t = format!("test = \"function\"\n[function]\nexpression = \"1\"\ncurve = {{ expression = \"x\", {bad} }}\n");
            let e = crate::run_file(
                &TestFile::parse("f.toml", &t).unwrap(),
                None,
                None,
                &mut |_, _| Ok(()),
            )
            .unwrap_err();
            assert!(e.message().starts_with(want), "{e}");
        }
    }

    #[test]
    fn a_function_run_asked_to_take_forever_is_refused() {
        // Duration::from_secs_f64(1e300) would panic, and sleeping that long never ends.
        let text = "test = \"function\"\n[function]\nexpression = \"1\"\nduration_s = 1e300\n";
        let file = TestFile::parse("f.toml", text).unwrap();
        let e = crate::run_file(&file, None, None, &mut |_, _| Ok(())).unwrap_err();
        assert_eq!(
            e,
            crate::TestError::Settings(
                "f.toml: function.duration_s: expected at most 3600 s of wall time, got 1e300"
                    .into()
            )
        );
    }
}
