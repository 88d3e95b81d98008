//! DEM scenes from Python: a scene file (or a dict) built and simulated, and its particles'
//! final state handed back. Snapshots for ParaView stay with `demcal simulate`.

use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Instant;

use dem::scene::Scene;
use pyo3::prelude::*;
use serde_json::json;

use crate::test::table_from;
use crate::{input, interruptible, to_json, Pool};

pub(crate) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(scene_info, m)?)?;
    m.add_function(wrap_pyfunction!(scene_run, m)?)?;
    Ok(())
}

/// Most steps one call may ask for: 1e10 is days of the largest scenes.
const MAX_STEPS: u64 = 10_000_000_000;

fn build(table_json: &str, name: &str, folder: &str) -> Result<Scene, String> {
    let table = table_from(table_json, "json", name).map_err(|e| e.to_string())?;
    let text = toml::to_string(&table).map_err(|e| format!("{name}: {e}"))?;
    Scene::from_toml(&text, name, Path::new(folder)).map_err(|e| e.to_string())
}

/// Builds the scene (nothing simulated) and says what it holds.
#[pyfunction]
fn scene_info(py: Python<'_>, table_json: &str, name: &str, folder: &str) -> PyResult<String> {
    let scene = py
        .detach(|| build(table_json, name, folder))
        .map_err(input)?;
    let sim = &scene.simulation;
    Ok(to_json(&json!({
        "particles": sim.particles.len(),
        "geometries": sim.geometries.len(),
        "time_step_s": sim.params.time_step,
        "rayleigh_time_step_s": scene.rayleigh_time_step,
        "steps": scene.steps,
        "contact_model": sim.params.contact_model.name(),
        "warnings": scene.warnings,
        "notes": scene.notes,
    })))
}

/// Builds and runs the scene for `steps` (the file's own run length when `None`) and returns
/// its end state as JSON: counts, times, kinetic energy, bonds, and each particle's position,
/// velocity and radius. A run that blows up raises `DivergedError`, one that loses a particle
/// out of its domain `EscapedError`, with the engine's message.
#[pyfunction]
#[pyo3(signature = (table_json, name, folder, steps=None, threads=None))]
fn scene_run(
    py: Python<'_>,
    table_json: &str,
    name: &str,
    folder: &str,
    steps: Option<u64>,
    threads: Option<usize>,
) -> PyResult<String> {
    if let Some(n) = steps.filter(|&n| n > MAX_STEPS) {
        return Err(input(format!("steps={n}: at most {MAX_STEPS:e}")));
    }
    // Built here (errors are the input's), moved whole onto the simulation thread.
    let scene = py
        .detach(|| build(table_json, name, folder))
        .map_err(input)?;
    let stop = Arc::new(AtomicBool::new(false));
    let flag = stop.clone();
    let (answer, failure) = interruptible(py, Pool::One(threads), stop, move || {
        let mut sim = scene.simulation;
        let steps = steps.unwrap_or(scene.steps);
        let start = Instant::now();
        let mut failure = None;
        while sim.steps < steps {
            if sim.steps % 200 == 0 && flag.load(Ordering::Relaxed) {
                failure = Some(("interrupted", "interrupted".to_string()));
                break;
            }
            if let Err(e) = sim.step() {
                let kind = match e {
                    dem::sim::SimError::LeftDomain { .. } => "escaped",
                    dem::sim::SimError::NotFinite { .. } => "diverged",
                    _ => "stopped",
                };
                failure = Some((kind, e.to_string()));
                break;
            }
        }
        let wall = start.elapsed().as_secs_f64();
        let p = &sim.particles;
        let bonds = sim.bonds().map(
            |b| json!({"bonds": b.len(), "intact": b.intact_count(), "broken": b.broken_count()}),
        );
        let answer = json!({
            "particles": p.len(),
            "steps": sim.steps,
            "simulated_s": sim.time,
            "wall_s": wall,
            "particle_steps_per_s": p.len() as f64 * sim.steps as f64 / wall.max(1e-9),
            "kinetic_energy_j": sim.kinetic_energy(),
            "bonds": bonds,
            "position": p.position.iter().map(|v| [v.x, v.y, v.z]).collect::<Vec<_>>(),
            "velocity": p.velocity.iter().map(|v| [v.x, v.y, v.z]).collect::<Vec<_>>(),
            "radius": p.radius,
        });
        (answer, failure)
    })?;
    match failure {
        None => Ok(to_json(&answer)),
        Some(("interrupted", _)) => Err(crate::interrupted("interrupted")),
        Some(("escaped", why)) => Err(crate::EscapedError::new_err(format!("{name}: {why}"))),
        Some(("diverged", why)) => Err(crate::DivergedError::new_err(format!("{name}: {why}"))),
        Some((_, why)) => Err(crate::RunError::new_err(format!("{name}: {why}"))),
    }
}
