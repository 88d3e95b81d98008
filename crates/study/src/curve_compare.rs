//! `demcal curve compare`: a simulated curve against the lab's, scored as a study scores it (the
//! lab files averaged as `[target] lab_curves`, the same normalisation, `curve_mse` on the same
//! 1000 points), for a curve made outside a study (a validation on another test, a check of a
//! run against another).

use std::path::{Path, PathBuf};

use serde_json::json;

use crate::curve::{common_range, Comparison, Measures, Normalisation, COMPARE_POINTS};
use crate::lab_curve::{read_csv, read_simulated_csv, LabCurves};

/// One comparison's numbers, normalised.
#[derive(Clone, Debug)]
pub struct CurveComparison {
    pub simulated_file: PathBuf,
    pub lab_files: Vec<PathBuf>,
    pub replicates: usize,
    pub normalisation: Normalisation,
    /// The lab mean curve's peak force (N).
    pub lab_peak_n: f64,
    /// The x range both curves cover, normalised.
    pub range: (f64, f64),
    pub mse: f64,
    pub simulated: Measures,
    pub lab: Measures,
    /// Where each curve has its peak (normalised x).
    pub simulated_peak_at: f64,
    pub lab_peak_at: f64,
}

/// Compares the simulated curve in `simulated` with the mean of the lab files' replicates.
pub fn compare_files(
    simulated: &Path,
    lab_files: &[PathBuf],
    normalisation: Normalisation,
) -> Result<CurveComparison, String> {
    if lab_files.is_empty() {
        return Err("no lab curve file given".into());
    }
    let sim = read_simulated_csv(simulated)?;
    let mut replicates = Vec::new();
    for f in lab_files {
        replicates.extend(read_csv(f)?);
    }
    let count = replicates.len();
    let lab = LabCurves::average(replicates)?;
    let comparison = Comparison {
        curve: "force_displacement".into(),
        normalisation,
        lab: lab.mean,
    };
    let scored = comparison.evaluate(&sim.x, &sim.y)?;
    let number = |k: &str| scored.get(k).and_then(|v| v.as_f64());
    let lab_peak_n = comparison.lab_peak_n();
    let sim_n = normalisation.apply(&sim, lab_peak_n);
    let lab_n = comparison.lab_normalised();
    let range = common_range([&sim_n, &lab_n]).ok_or("the curves do not overlap")?;
    // The measures are null in JSON when they are not finite: say why in the users' terms.
    let not_finite = |what: &str| {
        if !(lab_peak_n.is_finite() && lab_peak_n > 0.0) {
            format!("no {what}: the lab curves' peak force is {lab_peak_n} N, which the curves cannot be scaled by (--normalisation none compares the forces as they are)")
        } else {
            format!("no {what}: it is not a finite number (forces past any real range? the simulated peak is {} N)", sim.peak().1)
        }
    };
    Ok(CurveComparison {
        simulated_file: simulated.to_path_buf(),
        lab_files: lab_files.to_vec(),
        replicates: count,
        normalisation,
        lab_peak_n,
        range,
        mse: number("curve_mse").ok_or_else(|| not_finite("curve_mse"))?,
        simulated: Measures {
            peak: number("curve_peak").ok_or_else(|| not_finite("curve_peak"))?,
            mean: number("curve_mean").ok_or_else(|| not_finite("curve_mean"))?,
            stiffness: number("curve_stiffness"),
        },
        lab: Measures::of(&lab_n),
        simulated_peak_at: sim_n.peak().0,
        lab_peak_at: lab_n.peak().0,
    })
}

fn relative(a: f64, b: f64) -> Option<f64> {
    (b != 0.0).then(|| 100.0 * (a / b - 1.0))
}

impl CurveComparison {
    /// The comparison as text: the MSE, then the measures side by side.
    pub fn text(&self) -> String {
        let n = &self.normalisation;
        let (xn, xu) = n.x_axis();
        let (_, yu) = n.y_axis();
        let g = doe::fit::fmt_sig;
        let lab_files: Vec<String> = self
            .lab_files
            .iter()
            .map(|p| p.display().to_string())
            .collect();
        let mut out = format!(
            "simulated: {}\nlab: {} ({} replicate{}, their mean)\nnormalisation: {}\ncompared over {xn} {} .. {} {xu} on {COMPARE_POINTS} points\ncurve_mse = {}{}\n",
            self.simulated_file.display(),
            lab_files.join(", "),
            self.replicates,
            if self.replicates == 1 { "" } else { "s" },
            n.describe(self.lab_peak_n),
            g(self.range.0),
            g(self.range.1),
            g(self.mse),
            match n.unit_of("curve_mse").as_str() {
                "" => String::new(),
                u => format!(" {u}"),
            },
        );
        out += &format!(
            "{:<22}{:>14}{:>14}{:>12}\n",
            "", "simulated", "lab", "difference"
        );
        let rows = [
            ("peak", Some(self.simulated.peak), Some(self.lab.peak), yu),
            (
                "peak at",
                Some(self.simulated_peak_at),
                Some(self.lab_peak_at),
                xu,
            ),
            ("mean", Some(self.simulated.mean), Some(self.lab.mean), yu),
            (
                "initial stiffness",
                self.simulated.stiffness,
                self.lab.stiffness,
                "",
            ),
        ];
        for (label, a, b, unit) in rows {
            let cell = |v: Option<f64>| v.map(g).unwrap_or_else(|| "-".into());
            let diff = match (a, b) {
                (Some(a), Some(b)) => relative(a, b)
                    .map(|d| format!("{d:+.2} %"))
                    .unwrap_or_else(|| "-".into()),
                _ => "-".into(),
            };
            let label = if unit.is_empty() || unit == "-" {
                label.to_string()
            } else {
                format!("{label} ({unit})")
            };
            out += &format!("{label:<22}{:>14}{:>14}{diff:>12}\n", cell(a), cell(b));
        }
        out
    }

    /// The comparison as one JSON object.
    pub fn json(&self) -> serde_json::Value {
        json!({
            "simulated": self.simulated_file.display().to_string(),
            "lab": self.lab_files.iter().map(|p| p.display().to_string()).collect::<Vec<_>>(),
            "replicates": self.replicates,
            "normalisation": self.normalisation,
            "lab_peak_n": self.lab_peak_n,
            "range": [self.range.0, self.range.1],
            "points": COMPARE_POINTS,
            "curve_mse": self.mse,
            "curve_peak": self.simulated.peak,
            "curve_peak_at": self.simulated_peak_at,
            "curve_mean": self.simulated.mean,
            "curve_stiffness": self.simulated.stiffness,
            "lab_peak": self.lab.peak,
            "lab_peak_at": self.lab_peak_at,
            "lab_mean": self.lab.mean,
            "lab_stiffness": self.lab.stiffness,
            "peak_difference_percent": relative(self.simulated.peak, self.lab.peak),
            "mean_difference_percent": relative(self.simulated.mean, self.lab.mean),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dir(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("demcal-compare-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        p
    }

    /// A line against a line 10 % higher, with lab_peak: forces over the lab peak, so the
    /// difference is 0.1 x / 1.1 and its mean square over 1000 points on 0..1 is known.
    #[test]
    fn a_line_against_a_steeper_line_gives_the_analytic_mse() {
        let dir = dir("line");
        let sim = write(
            &dir,
            "sim.csv",
            "displacement_m,force_n\n0,0\n0,0\n0.5,50\n1,100\n",
        );
        let lab = write(
            &dir,
            "lab.csv",
            "displacement_mm,a,b\n0,0,0\n1000,100,120\n",
        );
        let c = compare_files(&sim, &[lab], Normalisation::LabPeak).unwrap();
        assert_eq!(c.replicates, 2);
        assert!((c.lab_peak_n - 110.0).abs() < 1e-9);
        // sim - lab = (100 x - 110 x) / 110 = -x / 11; mean of x_i^2 on 1000 points 0..1 is
        // 1999 / 5994.
        let expected = 1999.0 / 5994.0 / 121.0;
        assert!(
            (c.mse / expected - 1.0).abs() < 1e-9,
            "{} {expected}",
            c.mse
        );
        assert!((c.simulated.peak - 100.0 / 110.0).abs() < 1e-12);
        assert!((c.lab.peak - 1.0).abs() < 1e-12);
        let j = c.json();
        assert!((j["peak_difference_percent"].as_f64().unwrap() + 100.0 / 11.0).abs() < 1e-9);
        assert!(c.text().contains("curve_mse = "), "{}", c.text());
    }

    #[test]
    fn a_simulated_curve_that_goes_back_is_refused_with_its_file_and_point() {
        let dir = dir("back");
        let sim = write(
            &dir,
            "sim.csv",
            "displacement_m,force_n\n0,0\n0.5,50\n0.4,60\n",
        );
        let lab = write(&dir, "lab.csv", "displacement_m,f\n0,0\n1,1\n");
        let e = compare_files(&sim, &[lab], Normalisation::None).unwrap_err();
        assert!(
            e.contains("sim.csv") && e.contains("point 3") && e.contains("goes back"),
            "{e}"
        );
    }
}
