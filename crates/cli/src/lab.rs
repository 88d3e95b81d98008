//! `demcal lab ...`: the lab side of a calibration (crate `lab`).

use std::path::{Path, PathBuf};

use clap::Subcommand;
use lab::formulas::{self, Worked};
use lab::photo::{self, Background, PhotoSettings, Threshold};

#[derive(Subcommand)]
pub enum LabCommand {
    /// Angle of repose from a side photo of a heap: the plate it stands on found and left out,
    /// greyscale, threshold, the heap with its holes filled, its outline, and a line fitted to
    /// each flank between 15 % and 85 % of its height (camera level, square pixels).
    #[command(
        after_help = "Example:\n  demcal lab photo-angle heap.jpg --crop 100,50,1600,900 --debug heap-check.png --json"
    )]
    PhotoAngle {
        /// The photo (PNG or JPEG), the heap seen from the side against a plain background.
        image: PathBuf,
        /// How the heap is told from the background: otsu or iterative.
        #[arg(long, value_parser = ["otsu", "iterative"], default_value = "otsu")]
        threshold: String,
        /// Which side of the threshold the background is: auto (the class holding most of the
        /// image's border), light or dark.
        #[arg(long, value_parser = ["auto", "light", "dark"], default_value = "auto")]
        background: String,
        /// Use only this part of the photo: x,y,width,height in pixels (leave out the cylinder,
        /// a ruler, or a plate that is not found).
        #[arg(long)]
        crop: Option<String>,
        /// Do not look for the plate below the heap: measure the whole (cropped) photo. The
        /// plate is a band of rows of one width, wider than the heap's base, right below it.
        #[arg(long)]
        no_plate: bool,
        /// Write the photo with the outline (red), the fitted flank lines (green) and the plate's
        /// top edge (blue) here (PNG).
        #[arg(long)]
        debug: Option<PathBuf>,
        /// Print one JSON object (left_deg, right_deg, mean_deg, ...) instead of text.
        #[arg(long)]
        json: bool,
    },
    /// Static friction from the tilt angle at which the sample starts to slide: mu_s = tan(angle).
    #[command(after_help = "Example:\n  demcal lab friction --tilt-deg 28.6")]
    Friction {
        /// The tilt angle, degrees.
        #[arg(long)]
        tilt_deg: f64,
    },
    /// Elastic modulus from a compression test's load-displacement slope: E = 4 k L0 / (pi d^2),
    /// and the shear modulus G = E / (2 (1 + nu)) when the Poisson ratio is given.
    #[command(
        after_help = "Example:\n  demcal lab modulus --slope 1.2e5 --length 0.02 --diameter 0.01 --poisson 0.31"
    )]
    Modulus {
        /// The slope k of the linear part of the load-displacement curve, N/m.
        #[arg(long)]
        slope: f64,
        /// The specimen's length L0, m.
        #[arg(long)]
        length: f64,
        /// The specimen's diameter d, m.
        #[arg(long)]
        diameter: f64,
        /// The Poisson ratio, for the shear modulus.
        #[arg(long)]
        poisson: Option<f64>,
    },
    /// Moisture content on a wet basis from a sample weighed before and after drying.
    #[command(after_help = "Example:\n  demcal lab moisture --wet 0.100 --dry 0.0635")]
    Moisture {
        /// The sample's mass before drying, kg.
        #[arg(long)]
        wet: f64,
        /// Its mass after drying, kg.
        #[arg(long)]
        dry: f64,
    },
    /// Bulk density of a container filled and struck off: (m_filled - m_empty) / V.
    #[command(
        after_help = "Example:\n  demcal lab bulk-density --filled 1.25 --empty 0.48 --volume 0.001"
    )]
    BulkDensity {
        /// The container's mass filled, kg.
        #[arg(long)]
        filled: f64,
        /// Its mass empty, kg.
        #[arg(long)]
        empty: f64,
        /// Its volume, m^3.
        #[arg(long)]
        volume: f64,
    },
    /// Relative error of a simulated value against the lab's: |sim - lab| / lab x 100 %.
    #[command(after_help = "Example:\n  demcal lab relative-error --simulated 27.67 --lab 27.35")]
    RelativeError {
        /// The simulated value (any unit, the same as --lab).
        #[arg(long, allow_negative_numbers = true)]
        simulated: f64,
        /// The lab's value (not zero).
        #[arg(long, allow_negative_numbers = true)]
        lab: f64,
    },
}

pub fn run(action: LabCommand) -> Result<(), String> {
    let worked = match action {
        LabCommand::PhotoAngle {
            image,
            threshold,
            background,
            crop,
            no_plate,
            debug,
            json,
        } => {
            let find_plate = !no_plate;
            return photo_angle(
                &image,
                &threshold,
                &background,
                crop,
                find_plate,
                debug,
                json,
            );
        }
        LabCommand::Friction { tilt_deg } => formulas::friction_from_tilt(tilt_deg),
        LabCommand::Modulus {
            slope,
            length,
            diameter,
            poisson,
        } => formulas::modulus(slope, length, diameter, poisson),
        LabCommand::Moisture { wet, dry } => formulas::moisture(wet, dry),
        LabCommand::BulkDensity {
            filled,
            empty,
            volume,
        } => formulas::bulk_density(filled, empty, volume),
        LabCommand::RelativeError { simulated, lab } => formulas::relative_error(simulated, lab),
    }
    .and_then(formulas::finite)?;
    for Worked { formula, .. } in worked {
        println!("{formula}");
    }
    Ok(())
}

fn photo_angle(
    path: &Path,
    threshold: &str,
    background: &str,
    crop: Option<String>,
    find_plate: bool,
    debug: Option<PathBuf>,
    json: bool,
) -> Result<(), String> {
    // The picture's format follows its name; checked before the photo is measured.
    if let Some(d) = &debug {
        let ext = d
            .extension()
            .and_then(|e| e.to_str())
            .unwrap_or("")
            .to_ascii_lowercase();
        if !matches!(ext.as_str(), "png" | "jpg" | "jpeg") {
            return Err(format!(
                "--debug {}: expected a file name ending in .png or .jpg",
                d.display()
            ));
        }
        if std::fs::metadata(d).is_ok_and(|m| !m.is_file()) {
            return Err(format!(
                "--debug {}: exists and is not a plain file",
                d.display()
            ));
        }
    }
    let crop = crop
        .map(|c| {
            let parts: Vec<u32> = c
                .split(',')
                .map(|p| p.trim().parse::<u32>())
                .collect::<Result<_, _>>()
                .map_err(|_| format!("--crop {c}: expected x,y,width,height in whole pixels"))?;
            match parts[..] {
                [x, y, w, h] => Ok((x, y, w, h)),
                _ => Err(format!(
                    "--crop {c}: expected x,y,width,height in whole pixels"
                )),
            }
        })
        .transpose()?;
    let settings = PhotoSettings {
        threshold: if threshold == "iterative" {
            Threshold::Iterative
        } else {
            Threshold::Otsu
        },
        background: match background {
            "light" => Background::Light,
            "dark" => Background::Dark,
            _ => Background::Auto,
        },
        crop,
        find_plate,
        ..PhotoSettings::default()
    };
    let img = photo::open(path)?;
    let a = photo::measure(&img, &settings).map_err(|e| format!("{}: {e}", path.display()))?;
    if let Some(out) = &debug {
        photo::debug_picture(&img, &settings, &a)
            .save(out)
            .map_err(|e| format!("{}: cannot write: {e}", out.display()))?;
    }
    if json {
        println!("{}", serde_json::to_string(&a).map_err(|e| e.to_string())?);
    } else {
        println!(
            "angle of repose: left flank {:.2} deg, right flank {:.2} deg, mean {:.2} deg (threshold {}, heap {} x {} px{})",
            a.left_deg,
            a.right_deg,
            a.mean_deg,
            a.threshold,
            a.heap_width_px,
            a.heap_height_px,
            debug
                .map(|d| format!("; outline and lines drawn in {}", d.display()))
                .unwrap_or_default()
        );
        println!("{}", a.base_line);
    }
    Ok(())
}
