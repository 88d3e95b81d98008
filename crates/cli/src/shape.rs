//! `demcal shape fit`: multi-sphere fits of the maize kernel classes or an STL solid to a volume
//! error, as a table (crate `dem`, module `sphere_fit`).

use std::path::PathBuf;

use clap::Subcommand;
use dem::maize_kernel::KernelShape;
use dem::sphere_fit::{self, mesh::MeshSolid, FitOptions, FitQuality};

#[derive(Subcommand)]
pub enum ShapeCommand {
    /// Fit overlapping spheres to the four maize kernel classes (or one, or a closed STL solid)
    /// until the clump's volume is within --volume-error of the solid's, and print each fit's
    /// spheres, volume error, symmetric difference, surface error, smallest sphere and time-step
    /// factor (the smallest radius over that of today's count-based kernel fit, or over the
    /// equal-volume radius of an STL solid; the time step scales with it).
    #[command(
        after_help = "Example (the kernel classes at 5 %, with today's count-based fits below):\n  demcal shape fit --volume-error 0.05 --today\n\nExample (an STL solid drawn in mm):\n  demcal shape fit --stl kernel.stl --scale 0.001 --json"
    )]
    Fit {
        /// Only this kernel class: horse_tooth, flat, spherical_cone or near_spherical.
        #[arg(long, value_parser = KernelShape::KINDS, conflicts_with = "stl")]
        class: Option<String>,
        /// Fit this closed STL solid (binary or ASCII) instead of the kernel classes.
        #[arg(long)]
        stl: Option<PathBuf>,
        /// The STL's coordinates times this are metres (0.001 for a model in mm).
        #[arg(long, default_value_t = 1.0, requires = "stl")]
        scale: f64,
        /// The largest |volume error| accepted, as a fraction (0.05: 5 %).
        #[arg(long, default_value_t = 0.05)]
        volume_error: f64,
        /// No sphere smaller than this times the largest.
        #[arg(long, default_value_t = 0.3)]
        min_radius_ratio: f64,
        /// Fail beyond this many spheres.
        #[arg(long, default_value_t = 40)]
        max_spheres: usize,
        /// Also print today's count-based kernel fits (inscribed spheres, the counts of
        /// examples/tests/maize_heap.toml) measured the same way.
        #[arg(long)]
        today: bool,
        /// Print one JSON object per fit, one a line, instead of the table.
        #[arg(long)]
        json: bool,
    },
}

/// One row of the table.
struct Row {
    name: String,
    spheres: usize,
    quality: FitQuality,
    time_step_factor: f64,
}

pub fn run(action: ShapeCommand) -> Result<(), String> {
    match action {
        ShapeCommand::Fit {
            class,
            stl,
            scale,
            volume_error,
            min_radius_ratio,
            max_spheres,
            today,
            json,
        } => {
            let options = FitOptions {
                volume_error,
                min_radius_ratio,
                max_spheres,
            };
            options
                .validate()
                .map_err(|m| format!("--{}", m.replace('_', "-")))?;
            let mut rows = Vec::new();
            let mut counted = Vec::new();
            if let Some(path) = stl {
                // From a drawing in nanometres to one in kilometres; past these the solid's
                // volume leaves f64 ("encloses no volume" at 1e300).
                if !(1e-9..=1e3).contains(&scale) {
                    return Err(format!("--scale: expected a factor from 1e-9 to 1e3 (0.001 for a drawing in mm), got {scale}"));
                }
                let solid = MeshSolid::read(&path, scale)?;
                let fit = sphere_fit::fit(&solid, &options)
                    .map_err(|m| format!("{}: {m}", path.display()))?;
                rows.push(Row {
                    name: path.display().to_string(),
                    spheres: fit.template.spheres.len(),
                    time_step_factor: fit.time_step_factor(),
                    quality: fit.quality,
                });
            } else {
                let kinds: Vec<&str> = match &class {
                    Some(c) => vec![c.as_str()],
                    None => KernelShape::KINDS.to_vec(),
                };
                for kind in kinds {
                    let shape = KernelShape::published(kind).expect("a known class");
                    let fit = shape.fit_to(&options).map_err(|m| format!("{kind}: {m}"))?;
                    rows.push(Row {
                        name: kind.to_string(),
                        spheres: fit.template.spheres.len(),
                        time_step_factor: fit.time_step_factor(),
                        quality: fit.quality,
                    });
                    if today {
                        let count = sphere_fit::reference_count(kind);
                        let old = shape.fit(count)?;
                        let quality = sphere_fit::assess(&shape, &old.template);
                        counted.push(Row {
                            name: format!("{kind} (count = {count})"),
                            spheres: count,
                            time_step_factor: 1.0,
                            quality,
                        });
                    }
                }
            }
            if json {
                for (r, how) in rows
                    .iter()
                    .map(|r| (r, "volume_error"))
                    .chain(counted.iter().map(|r| (r, "count")))
                {
                    println!("{}", row_json(r, how, volume_error));
                }
            } else {
                println!(
                    "Fits to a volume error of {} % (smallest sphere >= {} x the largest, at most {} spheres):",
                    100.0 * volume_error,
                    min_radius_ratio,
                    max_spheres
                );
                print_table(&rows);
                if !counted.is_empty() {
                    println!("\nToday's count-based fits (inscribed spheres in the mid-plane):");
                    print_table(&counted);
                }
            }
            Ok(())
        }
    }
}

fn print_table(rows: &[Row]) {
    let width = rows.iter().map(|r| r.name.len()).max().unwrap_or(5).max(5);
    println!(
        "{:<width$}  {:>7}  {:>10}  {:>10}  {:>11}  {:>11}  {:>12}  {:>9}",
        "class",
        "spheres",
        "volume %",
        "sym diff %",
        "surf RMS mm",
        "surf max mm",
        "smallest mm",
        "dt factor"
    );
    for r in rows {
        let q = &r.quality;
        println!(
            "{:<width$}  {:>7}  {:>+10.2}  {:>10.1}  {:>11.3}  {:>11.3}  {:>12.3}  {:>9.2}",
            r.name,
            r.spheres,
            100.0 * q.volume_error,
            100.0 * q.symmetric_difference,
            1e3 * q.surface_rms,
            1e3 * q.surface_max,
            1e3 * q.smallest_radius,
            r.time_step_factor
        );
    }
}

fn row_json(r: &Row, how: &str, target: f64) -> serde_json::Value {
    let q = &r.quality;
    serde_json::json!({
        "class": r.name,
        "fit": how,
        "target_volume_error": if how == "count" { None } else { Some(target) },
        "spheres": r.spheres,
        "solid_volume_m3": q.solid_volume,
        "clump_volume_m3": q.clump_volume,
        "volume_error": q.volume_error,
        "symmetric_difference": q.symmetric_difference,
        "surface_rms_m": q.surface_rms,
        "surface_max_m": q.surface_max,
        "surface_rms_relative": q.surface_rms / q.equal_volume_radius,
        "surface_max_relative": q.surface_max / q.equal_volume_radius,
        "equal_volume_radius_m": q.equal_volume_radius,
        "smallest_radius_m": q.smallest_radius,
        "largest_radius_m": q.largest_radius,
        "time_step_factor": r.time_step_factor,
    })
}
