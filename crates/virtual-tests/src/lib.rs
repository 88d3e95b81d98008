//! Virtual lab tests: the set-ups of `shared/spec/lab-tests.md` built on the DEM engine, and the
//! measurements the labs make on them.
//!
//! A test file names its test (`test = "angle_of_repose"`), carries the materials and
//! interactions in the scene format, and a table of the test's settings ([`file`]). Each test
//! builds its scene, drives it through its phases (fill, settle, move geometry), and measures from
//! the particle state: the lifted-cylinder angle of repose ([`angle_of_repose`]) with its
//! measurement ([`repose`]) and pictures ([`render`]), and the inclined-plane tilt and slide tests
//! ([`incline`]).

pub mod angle_of_repose;
pub mod file;
pub mod function;
pub mod incline;
pub mod render;
pub mod repose;

pub use file::TestFile;

/// Runs the test a file describes and writes its pictures into `out` when given. Returns the
/// outcome as JSON (the keys `demcal test --json` prints) and a one-line summary. `progress` hears
/// the phase and the simulated time, and stops the run by returning an error.
pub fn run_file(
    file: &TestFile,
    seed: Option<u64>,
    out: Option<&std::path::Path>,
    progress: &mut dyn FnMut(&str, f64) -> Result<(), String>,
) -> Result<(serde_json::Value, String), String> {
    let write = |name: &str, bytes: &[u8]| -> Result<(), String> {
        if let Some(dir) = out {
            std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
            let p = dir.join(name);
            std::fs::write(&p, bytes).map_err(|e| format!("{}: {e}", p.display()))?;
        }
        Ok(())
    };
    let (json, summary) = match file.test.as_str() {
        "angle_of_repose" => {
            let o = angle_of_repose::run(file, seed, out, progress)?;
            if let Some(dir) = out {
                write(
                    "profiles.svg",
                    render::profiles_svg(&o.measurement)?.as_bytes(),
                )?;
                render::side_view_png(&o.positions, &o.radii, 900, &dir.join("heap.png"))?;
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
            (serde_json::to_value(&o).unwrap(), summary)
        }
        "incline_tilt" => {
            let o = incline::run_tilt(file, seed, progress)?;
            let summary = format!(
                "incline_tilt: angle_deg={:.2} tan={:.3} slid={} particles={} simulated_s={:.2} wall_s={:.1}",
                o.angle_deg, o.tan_angle, o.slid, o.particles, o.simulated_time_s, o.wall_s
            );
            (serde_json::to_value(&o).unwrap(), summary)
        }
        "incline_slide" => {
            let o = incline::run_slide(file, seed, progress)?;
            let summary = format!(
                "incline_slide: distance_m={:.4} std_m={:.4} releases={} stopped_on_ramp={} simulated_s={:.2} wall_s={:.1}",
                o.distance_m,
                o.distance_std_m,
                o.distances_m.len(),
                o.stopped_on_ramp,
                o.simulated_time_s,
                o.wall_s
            );
            (serde_json::to_value(&o).unwrap(), summary)
        }
        "function" => {
            let o = function::run(file, seed, progress)?;
            let summary = format!(
                "function: value={} exact={} noise={}",
                o.value, o.exact, o.noise
            );
            (serde_json::to_value(&o).unwrap(), summary)
        }
        other => return Err(format!("{}: test: unknown test \"{other}\"", file.name)),
    };
    write(
        "result.json",
        serde_json::to_string_pretty(&json).unwrap().as_bytes(),
    )?;
    Ok((json, summary))
}

/// The numeric outcomes of a test that a study can calibrate against, the usual one first.
pub fn responses(test: &str) -> &'static [&'static str] {
    match test {
        "angle_of_repose" => &[
            "angle_of_repose_deg",
            "angle_std_deg",
            "heap_height_m",
            "heap_radius_m",
        ],
        "incline_tilt" => &["angle_deg", "tan_angle"],
        "incline_slide" => &["distance_m", "distance_std_m"],
        "function" => &["value", "exact"],
        _ => &[],
    }
}
