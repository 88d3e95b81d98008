//! Virtual lab tests: the set-ups of `docs/lab-tests.md` built on the DEM engine, and the
//! measurements the labs make on them.
//!
//! A test file names its test (`test = "angle_of_repose"`), carries the materials,
//! interactions and particle types in the scene format, and a table of the test's settings
//! ([`file`]). Each test implements [`VirtualTest`] ([`virtual_test`]): it checks its settings,
//! writes its scene as a typed description and builds it, drives it through its phases with the
//! shared [`harness`] (settle until quiet, move a geometry by name, record a geometry's force),
//! and measures: the lifted-cylinder angle of repose ([`angle_of_repose`]) with its measurement
//! ([`repose`]) and pictures ([`render`]), the inclined-plane tilt and slide tests ([`incline`]),
//! and a formula for testing studies ([`function`]). [`registry`] lists them.

pub mod angle_of_repose;
pub mod batch_bench;
pub mod file;
pub mod function;
pub mod harness;
pub mod incline;
pub mod mechanical;
pub mod registry;
pub mod render;
pub mod repose;
pub mod virtual_test;

pub use file::TestFile;
pub use virtual_test::{Finished, Response, Run, TestError, VirtualTest};

/// Runs the test a file describes and writes its pictures and `result.json` into `out` when
/// given. Returns the finished run: the outcome as JSON (the keys `demcal test --json` prints),
/// a one-line summary and the responses (curves among them, which a study compares with lab
/// curves); its pictures are already written. `progress` hears the phase and the simulated time, and stops the run by returning an
/// error (the run then ends in [`TestError::Stopped`] with that message).
pub fn run_file(
    file: &TestFile,
    seed: Option<u64>,
    out: Option<&std::path::Path>,
    progress: &mut dyn FnMut(&str, f64) -> Result<(), String>,
) -> Result<Finished, TestError> {
    let test = registry::find(&file.test).ok_or_else(|| {
        TestError::Settings(format!(
            "{}: test: unknown test \"{}\"",
            file.name,
            file.test.escape_debug()
        ))
    })?;
    let mut run = Run::new(seed.or(file.seed).unwrap_or(1), out, progress);
    let done = test.run_file(file, &mut run)?;
    if let Some(dir) = out {
        let write = |name: &str, bytes: &[u8]| -> Result<(), String> {
            std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
            let p = dir.join(name);
            std::fs::write(&p, bytes).map_err(|e| format!("{}: {e}", p.display()))
        };
        let written = done
            .pictures
            .iter()
            .try_for_each(|picture| write(&picture.file_name, &picture.bytes))
            .and_then(|_| {
                let json = serde_json::to_string_pretty(&done.json).map_err(|e| e.to_string())?;
                write("result.json", json.as_bytes())
            });
        written.map_err(TestError::Output)?;
    }
    Ok(done)
}

/// Reads and checks a test file's settings without running anything.
pub fn check_file(file: &TestFile) -> Result<(), String> {
    registry::find(&file.test)
        .ok_or_else(|| {
            format!(
                "{}: test: unknown test \"{}\"",
                file.name,
                file.test.escape_debug()
            )
        })?
        .check_file(file)
}

/// Checks a test file as a run would begin: its settings, then its starting scene built (and
/// dropped) with `seed`. Nothing is simulated.
pub fn check_scene(file: &TestFile, seed: Option<u64>) -> Result<(), String> {
    registry::find(&file.test)
        .ok_or_else(|| {
            format!(
                "{}: test: unknown test \"{}\"",
                file.name,
                file.test.escape_debug()
            )
        })?
        .check_scene_file(file, seed.or(file.seed).unwrap_or(1))
}

/// The responses of a test that a study can calibrate against, the usual one first (none for
/// a test that does not exist).
pub fn responses(test: &str) -> &'static [&'static str] {
    registry::find(test)
        .map(|t| t.response_names())
        .unwrap_or(&[])
}

/// The tests for a help text: "name (what it does), ...".
pub fn tests_help() -> String {
    registry::TESTS
        .iter()
        .map(|t| format!("{} ({})", t.name(), t.about()))
        .collect::<Vec<_>>()
        .join("; ")
}
