//! Virtual lab tests: the set-ups of `shared/spec/lab-tests.md` built on the DEM engine, and the
//! measurements the labs make on them.
//!
//! A test file names its test (`test = "angle_of_repose"`), carries the materials and
//! interactions in the scene format, and a table of the test's settings ([`file`]). Each test
//! builds its scene, drives it through its phases (fill, settle, move geometry), and measures from
//! the particle state. So far: the lifted-cylinder angle of repose ([`angle_of_repose`]) with its
//! measurement ([`repose`]) and pictures ([`render`]).

pub mod angle_of_repose;
pub mod file;
pub mod render;
pub mod repose;

pub use file::TestFile;

/// Runs the test a file describes and writes its pictures into `out` when given. Returns the
/// outcome as JSON (the keys `demcal test --json` prints) and a one-line summary.
pub fn run_file(
    file: &TestFile,
    seed: Option<u64>,
    out: Option<&std::path::Path>,
    progress: &mut dyn FnMut(&str, f64),
) -> Result<(serde_json::Value, String), String> {
    match file.test.as_str() {
        "angle_of_repose" => {
            let o = angle_of_repose::run(file, seed, progress)?;
            if let Some(dir) = out {
                std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
                let svg = render::profiles_svg(&o.measurement)?;
                let p = dir.join("profiles.svg");
                std::fs::write(&p, svg).map_err(|e| format!("{}: {e}", p.display()))?;
                render::side_view_png(&o.positions, &o.radii, 900, &dir.join("heap.png"))?;
                let j = dir.join("result.json");
                std::fs::write(&j, serde_json::to_string_pretty(&o).unwrap())
                    .map_err(|e| format!("{}: {e}", j.display()))?;
            }
            let summary = format!(
                "angle_of_repose: angle_deg={:.2} std_deg={:.2} heap_height_m={:.4} heap_radius_m={:.4} particles={} simulated_s={:.2} wall_s={:.1}",
                o.angle_of_repose_deg,
                o.angle_std_deg,
                o.heap_height_m,
                o.heap_radius_m,
                o.particles,
                o.simulated_time_s,
                o.wall_s
            );
            Ok((serde_json::to_value(&o).unwrap(), summary))
        }
        other => Err(format!("{}: test: unknown test \"{other}\"", file.name)),
    }
}
