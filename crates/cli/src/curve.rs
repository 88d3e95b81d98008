//! `demcal curve ...`: curves outside a study (crate `study`, module `curve_compare`).

use std::path::PathBuf;

use clap::Subcommand;
use study::curve::Normalisation;

#[derive(Subcommand)]
pub enum CurveCommand {
    /// Score a simulated force-displacement curve against the lab's as a study scores it: the lab
    /// files' replicates averaged, both curves normalised, the mean squared difference on 1000
    /// points over the range both cover (curve_mse), and the peak, mean and initial stiffness
    /// side by side.
    #[command(
        after_help = "Example (seed 000's validation: a bending run against the lab's bending curves):\n  demcal curve compare bending_out/force_displacement.csv lab_bending.csv --normalisation lab_peak"
    )]
    Compare {
        /// The simulated curve: a CSV with displacement_m (or displacement_mm) and the force (N),
        /// as `demcal test` writes force_displacement.csv.
        simulated: PathBuf,
        /// The lab curves: CSV files with displacement_m (or displacement_mm), then one force
        /// column (N) per replicate.
        #[arg(required = true)]
        lab: Vec<PathBuf>,
        /// none: N against m; lab_peak: forces over the peak of the lab's mean curve (seed 000);
        /// stress_strain: MPa against strain (with --area-m2 and --length-m).
        #[arg(long, value_parser = ["none", "lab_peak", "stress_strain"], default_value = "lab_peak")]
        normalisation: String,
        /// stress_strain: the specimen's cross-section (m²).
        #[arg(long, allow_negative_numbers = true)]
        area_m2: Option<f64>,
        /// stress_strain: the specimen's length (m).
        #[arg(long, allow_negative_numbers = true)]
        length_m: Option<f64>,
        /// Print one JSON object instead of text.
        #[arg(long)]
        json: bool,
    },
}

pub fn run(action: CurveCommand) -> Result<(), String> {
    match action {
        CurveCommand::Compare {
            simulated,
            lab,
            normalisation,
            area_m2,
            length_m,
            json,
        } => {
            let normalisation = normalisation_of(&normalisation, area_m2, length_m)?;
            let c = study::curve_compare::compare_files(&simulated, &lab, normalisation)?;
            if json {
                println!("{}", c.json());
            } else {
                print!("{}", c.text());
            }
            Ok(())
        }
    }
}

fn normalisation_of(
    name: &str,
    area_m2: Option<f64>,
    length_m: Option<f64>,
) -> Result<Normalisation, String> {
    let positive = |flag: &str, v: Option<f64>| -> Result<f64, String> {
        match v {
            Some(v) if v.is_finite() && v > 0.0 => Ok(v),
            Some(v) => Err(format!("{flag} {v}: expected a positive number")),
            None => Err(format!("--normalisation stress_strain needs {flag}")),
        }
    };
    match name {
        "stress_strain" => Ok(Normalisation::StressStrain {
            area_m2: positive("--area-m2", area_m2)?,
            length_m: positive("--length-m", length_m)?,
        }),
        _ if area_m2.is_some() || length_m.is_some() => Err(format!(
            "--area-m2 and --length-m are for --normalisation stress_strain, not {name}"
        )),
        "none" => Ok(Normalisation::None),
        _ => Ok(Normalisation::LabPeak),
    }
}
