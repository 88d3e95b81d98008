//! Comparing a simulated curve with the lab's, as `docs/lab-tests.md` ("How a curve is
//! compared") asks: both curves normalised the way the study file says, resampled on 1000 evenly
//! spaced points over the range both cover by linear interpolation, and the mean squared
//! difference taken. From the normalised simulated curve come the measures a study can also
//! calibrate against: its peak, its mean and its initial stiffness.
//!
//! The lab side (reading CSV files, averaging replicates) is [`crate::lab_curve`]; this module
//! knows nothing of files.

use serde::{Deserialize, Serialize};

/// Points of the comparison grid (docs/lab-tests.md, "How a curve is compared").
pub const COMPARE_POINTS: usize = 1000;
/// Points of the copy of the simulated curve kept in a run's outputs for the report's plot.
pub const PLOT_POINTS: usize = 200;
/// Points over which the initial stiffness is fitted.
const STIFFNESS_POINTS: usize = 21;
/// The initial stiffness is fitted over this fraction of the displacement to the peak.
pub const STIFFNESS_FRACTION: f64 = 0.2;

/// The responses a study derives from a curve, which `target.response` may name.
pub const CURVE_RESPONSES: &[&str] = &["curve_mse", "curve_peak", "curve_mean", "curve_stiffness"];

/// How both curves are scaled before they are compared.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Normalisation {
    /// Force (N) against displacement (m) as measured.
    None,
    /// Force divided by the peak of the lab's mean curve, against displacement (m).
    LabPeak,
    /// Stress = force / area (MPa) against strain = displacement / length.
    StressStrain { area_m2: f64, length_m: f64 },
}

impl Normalisation {
    /// The study file's word for it.
    pub fn name(&self) -> &'static str {
        match self {
            Normalisation::None => "none",
            Normalisation::LabPeak => "lab_peak",
            Normalisation::StressStrain { .. } => "stress_strain",
        }
    }

    /// The x axis after normalisation: name and unit.
    pub fn x_axis(&self) -> (&'static str, &'static str) {
        match self {
            Normalisation::StressStrain { .. } => ("strain", "-"),
            _ => ("displacement", "m"),
        }
    }

    /// The y axis after normalisation: name and unit.
    pub fn y_axis(&self) -> (&'static str, &'static str) {
        match self {
            Normalisation::None => ("force", "N"),
            Normalisation::LabPeak => ("force / lab peak", "-"),
            Normalisation::StressStrain { .. } => ("stress", "MPa"),
        }
    }

    /// The unit of a derived response (`curve_mse`, ...).
    pub fn unit_of(&self, response: &str) -> String {
        let (_, x) = self.x_axis();
        let (_, y) = self.y_axis();
        let y = if y == "-" { "" } else { y };
        match response {
            "curve_mse" if y.is_empty() => String::new(),
            "curve_mse" => format!("{y}²"),
            "curve_peak" | "curve_mean" => y.to_string(),
            "curve_stiffness" => match (y.is_empty(), x == "-") {
                (true, true) => String::new(),
                (true, false) => format!("1/{x}"),
                (false, true) => y.to_string(),
                (false, false) => format!("{y}/{x}"),
            },
            _ => String::new(),
        }
    }

    /// One sentence for the report.
    pub fn describe(&self, lab_peak_n: f64) -> String {
        match self {
            Normalisation::None => {
                "none: force in N against displacement in m, as measured".into()
            }
            Normalisation::LabPeak => format!(
                "lab_peak: forces divided by the peak of the lab's mean curve ({} N), against displacement in m",
                doe::fit::fmt_sig(lab_peak_n)
            ),
            Normalisation::StressStrain { area_m2, length_m } => format!(
                "stress_strain: stress = force / {} m² in MPa against strain = displacement / {} m",
                doe::fit::fmt_sig(*area_m2),
                doe::fit::fmt_sig(*length_m)
            ),
        }
    }

    /// The curve (displacement in m, force in N) normalised; `lab_peak_n` is the lab mean
    /// curve's peak force.
    pub fn apply(&self, c: &Curve, lab_peak_n: f64) -> Curve {
        let (sx, sy) = match self {
            Normalisation::None => (1.0, 1.0),
            Normalisation::LabPeak => (1.0, 1.0 / lab_peak_n),
            Normalisation::StressStrain { area_m2, length_m } => (1.0 / length_m, 1e-6 / area_m2),
        };
        Curve {
            x: c.x.iter().map(|x| x * sx).collect(),
            y: c.y.iter().map(|y| y * sy).collect(),
        }
    }
}

/// A curve with strictly increasing, finite x and finite y, at least two points.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Curve {
    pub x: Vec<f64>,
    pub y: Vec<f64>,
}

impl Curve {
    /// Checks a curve; the error says what is wrong and at which point (0-based).
    pub fn new(x: Vec<f64>, y: Vec<f64>) -> Result<Curve, String> {
        if x.len() != y.len() {
            return Err(format!("{} x values but {} y values", x.len(), y.len()));
        }
        if x.len() < 2 {
            return Err(format!("{} point(s): a curve needs at least 2", x.len()));
        }
        if let Some(i) = (0..x.len()).find(|&i| !(x[i].is_finite() && y[i].is_finite())) {
            return Err(format!("point {}: not a finite number", i + 1));
        }
        if let Some(i) = (1..x.len()).find(|&i| x[i] <= x[i - 1]) {
            return Err(format!(
                "point {}: x = {} does not increase (the point before has {})",
                i + 1,
                x[i],
                x[i - 1]
            ));
        }
        Ok(Curve { x, y })
    }

    /// A simulated curve: x may repeat (a recorder sampling before the tool moves, which gives
    /// the mean force there) but must not go back.
    pub fn from_simulated(x: &[f64], y: &[f64]) -> Result<Curve, String> {
        if x.len() != y.len() {
            return Err(format!("{} x values but {} y values", x.len(), y.len()));
        }
        let (mut cx, mut cy) = (Vec::<f64>::new(), Vec::<f64>::new());
        let mut count = 0.0;
        for (i, (&a, &b)) in x.iter().zip(y).enumerate() {
            if !(a.is_finite() && b.is_finite()) {
                return Err(format!("point {}: not a finite number", i + 1));
            }
            match cx.last() {
                Some(&last) if a < last => {
                    return Err(format!(
                        "point {}: x = {a} goes back (the point before has {last})",
                        i + 1
                    ))
                }
                Some(&last) if a == last => {
                    count += 1.0;
                    let m = cy.last_mut().expect("same length as cx");
                    *m += (b - *m) / count;
                }
                _ => {
                    cx.push(a);
                    cy.push(b);
                    count = 1.0;
                }
            }
        }
        Curve::new(cx, cy)
    }

    pub fn range(&self) -> (f64, f64) {
        (self.x[0], self.x[self.x.len() - 1])
    }

    /// Linear interpolation at `x` (the end values beyond the ends).
    pub fn at(&self, x: f64) -> f64 {
        let n = self.x.len();
        if x <= self.x[0] {
            return self.y[0];
        }
        if x >= self.x[n - 1] {
            return self.y[n - 1];
        }
        // The first point beyond x; x lies strictly inside, so 1 <= j <= n - 1.
        let j = self.x.partition_point(|&v| v <= x);
        let (x0, x1, y0, y1) = (self.x[j - 1], self.x[j], self.y[j - 1], self.y[j]);
        y0 + (y1 - y0) * (x - x0) / (x1 - x0)
    }

    /// `n` evenly spaced x from `lo` to `hi` (ends included).
    pub fn grid(lo: f64, hi: f64, n: usize) -> Vec<f64> {
        (0..n)
            .map(|i| {
                if i + 1 == n {
                    hi
                } else {
                    lo + (hi - lo) * i as f64 / (n - 1) as f64
                }
            })
            .collect()
    }

    /// The curve interpolated on `n` evenly spaced points from `lo` to `hi`.
    pub fn resample(&self, lo: f64, hi: f64, n: usize) -> Curve {
        let x = Curve::grid(lo, hi, n);
        let y = x.iter().map(|&v| self.at(v)).collect();
        Curve { x, y }
    }

    /// The highest point: (x, y); the first of equal ones.
    pub fn peak(&self) -> (f64, f64) {
        let mut best = 0;
        for i in 1..self.y.len() {
            if self.y[i] > self.y[best] {
                best = i;
            }
        }
        (self.x[best], self.y[best])
    }

    /// The mean over the displacement: the area under the curve (trapezoids) divided by its x
    /// range, so it does not depend on how densely the curve was sampled.
    pub fn mean(&self) -> f64 {
        let (lo, hi) = self.range();
        let area: f64 = self
            .x
            .windows(2)
            .zip(self.y.windows(2))
            .map(|(x, y)| 0.5 * (y[0] + y[1]) * (x[1] - x[0]))
            .sum();
        area / (hi - lo)
    }

    /// The initial slope: the least-squares slope of the curve sampled (linear interpolation) at
    /// 21 evenly spaced points over the first 20 % of the displacement from its start to its
    /// peak. None when the peak is at the start.
    pub fn initial_stiffness(&self) -> Option<f64> {
        let x0 = self.x[0];
        let w = STIFFNESS_FRACTION * (self.peak().0 - x0);
        if w <= 0.0 {
            return None;
        }
        let s = self.resample(x0, x0 + w, STIFFNESS_POINTS);
        let n = s.x.len() as f64;
        let (mx, my) = (s.x.iter().sum::<f64>() / n, s.y.iter().sum::<f64>() / n);
        let sxy: f64 = s.x.iter().zip(&s.y).map(|(x, y)| (x - mx) * (y - my)).sum();
        let sxx: f64 = s.x.iter().map(|x| (x - mx).powi(2)).sum();
        Some(sxy / sxx)
    }
}

/// The x range every curve covers, when it is not empty.
pub fn common_range<'a>(curves: impl IntoIterator<Item = &'a Curve>) -> Option<(f64, f64)> {
    let (lo, hi) = curves
        .into_iter()
        .map(Curve::range)
        .fold((f64::MIN, f64::MAX), |(a, b), (lo, hi)| {
            (a.max(lo), b.min(hi))
        });
    (lo < hi).then_some((lo, hi))
}

/// Mean squared difference of two curves on 1000 evenly spaced points over the range both
/// cover; None when they do not overlap.
pub fn mse(a: &Curve, b: &Curve) -> Option<f64> {
    let (lo, hi) = common_range([a, b])?;
    let x = Curve::grid(lo, hi, COMPARE_POINTS);
    Some(x.iter().map(|&v| (a.at(v) - b.at(v)).powi(2)).sum::<f64>() / x.len() as f64)
}

/// The measures of a normalised curve a study can calibrate against (all but the MSE).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Measures {
    pub peak: f64,
    pub mean: f64,
    pub stiffness: Option<f64>,
}

impl Measures {
    pub fn of(c: &Curve) -> Measures {
        Measures {
            peak: c.peak().1,
            mean: c.mean(),
            stiffness: c.initial_stiffness(),
        }
    }

    /// The measure `response` names (`curve_peak`, `curve_mean`, `curve_stiffness`).
    pub fn get(&self, response: &str) -> Option<f64> {
        match response {
            "curve_peak" => Some(self.peak),
            "curve_mean" => Some(self.mean),
            "curve_stiffness" => self.stiffness,
            _ => None,
        }
    }
}

/// What a run needs to compare its curve with the lab's: carried by each job, so a run on
/// another machine needs no lab files.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Comparison {
    /// The test's curve response compared (`force_displacement`).
    pub curve: String,
    pub normalisation: Normalisation,
    /// The lab's mean curve: displacement (m) and force (N).
    pub lab: Curve,
}

impl Comparison {
    /// The lab mean curve's peak force (N), which `lab_peak` divides by.
    pub fn lab_peak_n(&self) -> f64 {
        self.lab.peak().1
    }

    /// A short digest of the comparison (curve, normalisation, lab curve): part of each run's
    /// fingerprint, so that runs compared with other lab curves are not reused.
    pub fn digest(&self) -> String {
        // FNV-1a over the JSON text, which serde_json writes the same on every platform.
        let text = serde_json::to_string(self).unwrap_or_default();
        let mut h: u64 = 0xcbf2_9ce4_8422_2325;
        for b in text.bytes() {
            h = (h ^ b as u64).wrapping_mul(0x0100_0000_01b3);
        }
        format!("{h:016x}")
    }

    pub fn lab_normalised(&self) -> Curve {
        self.normalisation.apply(&self.lab, self.lab_peak_n())
    }

    /// Compares a simulated curve (displacement in m, force in N) with the lab's. The result is
    /// what a run adds to its outputs: `curve_mse`, `curve_peak`, `curve_mean`,
    /// `curve_stiffness` (null when the peak is at the start) and `curve_simulated` (the
    /// normalised curve on 200 points, for the report). An error says why no comparison could
    /// be made (a curve that goes back, no overlap with the lab curve).
    pub fn evaluate(
        &self,
        x: &[f64],
        y: &[f64],
    ) -> Result<serde_json::Map<String, serde_json::Value>, String> {
        let raw = Curve::from_simulated(x, y)
            .map_err(|e| format!("the simulated {} curve: {e}", self.curve))?;
        let sim = self.normalisation.apply(&raw, self.lab_peak_n());
        let lab = self.lab_normalised();
        let (xn, xu) = self.normalisation.x_axis();
        let mse = mse(&sim, &lab).ok_or_else(|| {
            let ((a, b), (c, d)) = (sim.range(), lab.range());
            format!(
                "the simulated {} curve ({xn} {} .. {} {xu}) and the lab curve ({} .. {} {xu}) do not overlap",
                self.curve,
                doe::fit::fmt_sig(a),
                doe::fit::fmt_sig(b),
                doe::fit::fmt_sig(c),
                doe::fit::fmt_sig(d)
            )
        })?;
        let m = Measures::of(&sim);
        let (lo, hi) = sim.range();
        let plot = sim.resample(lo, hi, PLOT_POINTS.min(sim.x.len().max(2)));
        let mut out = serde_json::Map::new();
        out.insert("curve_mse".into(), serde_json::json!(mse));
        out.insert("curve_peak".into(), serde_json::json!(m.peak));
        out.insert("curve_mean".into(), serde_json::json!(m.mean));
        out.insert("curve_stiffness".into(), serde_json::json!(m.stiffness));
        out.insert(
            "curve_simulated".into(),
            serde_json::json!({ "x": plot.x, "y": plot.y }),
        );
        Ok(out)
    }
}

/// Reads back the normalised simulated curve a run stored (`curve_simulated`).
pub fn stored_curve(outputs: &serde_json::Value) -> Option<Curve> {
    let c = outputs.get("curve_simulated")?;
    let list = |k: &str| -> Option<Vec<f64>> {
        c.get(k)?.as_array()?.iter().map(|v| v.as_f64()).collect()
    };
    Curve::new(list("x")?, list("y")?).ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn line(a: f64, b: f64, lo: f64, hi: f64, n: usize) -> Curve {
        let x = Curve::grid(lo, hi, n);
        let y = x.iter().map(|x| a + b * x).collect();
        Curve::new(x, y).unwrap()
    }

    #[test]
    fn identical_curves_have_no_error() {
        let c = line(1.0, 2.0, 0.0, 1.0, 7);
        assert_eq!(mse(&c, &c), Some(0.0));
    }

    #[test]
    fn a_shifted_curve_has_the_square_of_the_shift() {
        let a = line(1.0, 2.0, 0.0, 1.0, 5);
        let b = line(1.5, 2.0, 0.0, 1.0, 9);
        assert!((mse(&a, &b).unwrap() - 0.25).abs() < 1e-12);
    }

    #[test]
    fn two_lines_give_the_analytic_mse_on_the_grid() {
        // a = x, b = 0 over 0..1: mean of x_i^2 on 1000 evenly spaced points is
        // (n - 1)(2n - 1) / (6 (n - 1)^2) = 1999 / 5994, which tends to 1/3.
        let a = line(0.0, 1.0, 0.0, 1.0, 2);
        let b = line(0.0, 0.0, 0.0, 1.0, 3);
        let want = 1999.0 / 5994.0;
        assert!((mse(&a, &b).unwrap() - want).abs() < 1e-14);
        assert!((want - 1.0 / 3.0).abs() < 2e-4);
    }

    #[test]
    fn only_the_common_range_counts() {
        // b agrees with a on 0..1 and differs wildly beyond; the overlap is 0.5..1.
        let a = line(0.0, 1.0, 0.5, 1.0, 2);
        let b = Curve::new(vec![0.0, 1.0, 2.0], vec![0.0, 1.0, 100.0]).unwrap();
        assert_eq!(common_range([&a, &b]), Some((0.5, 1.0)));
        assert!(mse(&a, &b).unwrap() < 1e-28);
        // Curves that do not overlap give none.
        let c = line(0.0, 1.0, 1.5, 2.0, 2);
        assert_eq!(mse(&a, &c), None);
    }

    #[test]
    fn interpolation_and_measures() {
        let c = Curve::new(vec![0.0, 1.0, 2.0, 4.0], vec![0.0, 10.0, 4.0, 4.0]).unwrap();
        assert_eq!(c.at(0.5), 5.0);
        assert_eq!(c.at(3.0), 4.0);
        assert_eq!(c.at(-1.0), 0.0);
        assert_eq!(c.at(9.0), 4.0);
        assert_eq!(c.peak(), (1.0, 10.0));
        // Area 5 + 7 + 8 = 20 over 4.
        assert_eq!(c.mean(), 5.0);
        // Slope over the first 20 % of the way to the peak: 10 per unit.
        assert!((c.initial_stiffness().unwrap() - 10.0).abs() < 1e-12);
        let falling = Curve::new(vec![0.0, 1.0], vec![3.0, 1.0]).unwrap();
        assert_eq!(falling.initial_stiffness(), None);
    }

    #[test]
    fn bad_curves_are_refused_with_the_point() {
        assert!(Curve::new(vec![0.0], vec![1.0])
            .unwrap_err()
            .contains("at least 2"));
        let e = Curve::new(vec![0.0, 1.0, 1.0], vec![0.0; 3]).unwrap_err();
        assert!(e.starts_with("point 3: x = 1 does not increase"), "{e}");
        let e = Curve::new(vec![0.0, f64::NAN], vec![0.0; 2]).unwrap_err();
        assert!(e.starts_with("point 2: not a finite"), "{e}");
        // A simulated curve may stand still (the mean force is kept) but not go back.
        let c = Curve::from_simulated(&[0.0, 0.0, 0.0, 1.0], &[1.0, 2.0, 6.0, 5.0]).unwrap();
        assert_eq!(c, Curve::new(vec![0.0, 1.0], vec![3.0, 5.0]).unwrap());
        let e = Curve::from_simulated(&[0.0, 1.0, 0.5], &[0.0; 3]).unwrap_err();
        assert!(e.starts_with("point 3: x = 0.5 goes back"), "{e}");
    }

    #[test]
    fn normalisations_scale_both_axes_as_stated() {
        let c = Curve::new(vec![0.0, 0.01], vec![0.0, 50.0]).unwrap();
        assert_eq!(Normalisation::None.apply(&c, 25.0), c);
        assert_eq!(Normalisation::LabPeak.apply(&c, 25.0).y, vec![0.0, 2.0]);
        let ss = Normalisation::StressStrain {
            area_m2: 1e-4,
            length_m: 0.02,
        }
        .apply(&c, 25.0);
        assert_eq!(ss.x, vec![0.0, 0.5]);
        assert!((ss.y[1] - 0.5).abs() < 1e-12, "50 N on 1 cm² is 0.5 MPa");
        assert_eq!(Normalisation::None.unit_of("curve_mse"), "N²");
        assert_eq!(Normalisation::None.unit_of("curve_stiffness"), "N/m");
        assert_eq!(Normalisation::LabPeak.unit_of("curve_stiffness"), "1/m");
        assert_eq!(Normalisation::LabPeak.unit_of("curve_mse"), "");
    }

    #[test]
    fn a_comparison_gives_the_derived_responses() {
        let lab = Curve::new(vec![0.0, 0.01], vec![0.0, 100.0]).unwrap();
        let cmp = Comparison {
            curve: "force_displacement".into(),
            normalisation: Normalisation::LabPeak,
            lab,
        };
        // The simulation is 10 % stiffer: y/peak = 110 x over 0..0.01, against 100 x.
        let x = Curve::grid(0.0, 0.01, 11);
        let y: Vec<f64> = x.iter().map(|x| 11000.0 * x).collect();
        let out = cmp.evaluate(&x, &y).unwrap();
        // (10 x)^2 averaged on the grid: 100 * 1e-4 * 1999 / 5994.
        let want = 1e-2 * 1999.0 / 5994.0;
        assert!((out["curve_mse"].as_f64().unwrap() - want).abs() < 1e-15);
        assert!((out["curve_peak"].as_f64().unwrap() - 1.1).abs() < 1e-12);
        assert!((out["curve_mean"].as_f64().unwrap() - 0.55).abs() < 1e-12);
        assert!((out["curve_stiffness"].as_f64().unwrap() - 110.0).abs() < 1e-9);
        let kept = stored_curve(&serde_json::Value::Object(out)).unwrap();
        assert_eq!(kept.x.len(), 11);
        // No overlap: a measurement error saying so.
        let far: Vec<f64> = x.iter().map(|x| x + 1.0).collect();
        let e = cmp.evaluate(&far, &y).unwrap_err();
        assert!(e.contains("do not overlap"), "{e}");
    }
}
