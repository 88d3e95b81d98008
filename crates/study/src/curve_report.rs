//! The report's curve sections, one per curve target (the study's one target, or each curve
//! target among several): what was compared and how (the normalisation and units in words), and
//! a plot of the lab's mean curve with its band against the simulated curves of the run with the
//! smallest MSE and of the validation runs. The report ([`crate::report`]) renders them; this
//! module draws and words them, and does not import the report.

use doe::plots;
use plotters::prelude::*;

use crate::curve::{stored_curve, Curve, COMPARE_POINTS, STIFFNESS_FRACTION};
use crate::lab_curve::CurveTarget;
use crate::record::Replay;
use crate::spec::Study;
use crate::store::Status;
use crate::text::sig;

/// Points each curve is drawn with.
const DRAW_POINTS: usize = 400;

/// A section: paragraphs of plain text (the report escapes them) and the plot.
pub struct Section {
    /// With several targets, which test's curve it is (`test compression: force_displacement`),
    /// for a heading; None for a study of one target.
    pub title: Option<String>,
    /// What the figure's files are named after.
    pub stem: String,
    pub paragraphs: Vec<String>,
    pub svg: Result<String, String>,
}

/// A simulated curve to draw: its label and the normalised curve a run stored.
struct Simulated {
    label: String,
    curve: Curve,
    best: bool,
}

/// A section for each of `study`'s curve targets (none without one).
pub fn sections(study: &Study, r: &Replay) -> Vec<Section> {
    if study.combine.is_none() {
        return study
            .target
            .curve
            .iter()
            .map(|c| section(study, r, c, None))
            .collect();
    }
    // With several targets each test's outcome is under its name in the run's `tests`.
    study
        .targets
        .iter()
        .filter_map(|t| Some((t.curve.as_ref()?, study.tests[t.test].name.as_str())))
        .map(|(c, test)| section(study, r, c, Some(test)))
        .collect()
}

/// The section for the curve target `c`, whose test's outcome is a run's outputs (`test`
/// None) or the outputs' `tests.<test>`.
fn section(study: &Study, r: &Replay, c: &CurveTarget, test: Option<&str>) -> Section {
    let cmp = c.comparison();
    let norm = c.normalisation;
    let (xn, xu) = norm.x_axis();
    let (yn, yu) = norm.y_axis();
    let (lo, hi) = c.lab.mean.range();
    let mut paragraphs = vec![
        format!(
            "The {}{} curve is compared with {} lab replicate(s) from {}. Normalisation {}. The lab curve is {}; the band spans the replicates' smallest to largest force at each point.",
            test.map_or("test's ".to_string(), |t| format!("test {t}'s ")),
            c.curve,
            c.lab.replicates.len(),
            c.files.join(", "),
            norm.describe(cmp.lab_peak_n()),
            if c.lab.replicates.len() == 1 {
                "the single replicate".to_string()
            } else {
                format!(
                    "the replicates' mean on {COMPARE_POINTS} evenly spaced points over the displacement range all cover ({} .. {} m)",
                    sig(lo),
                    sig(hi)
                )
            },
        ),
        format!(
            "curve_mse is the mean squared difference of the normalised curves on {COMPARE_POINTS} evenly spaced points over the {xn} range both cover (linear interpolation), in {}; curve_peak is the simulated curve's highest {yn}, curve_mean its mean over the {xn}, curve_stiffness its least-squares slope over the first {:.0} % of the {xn} to its peak. Axes: {xn} ({xu}), {yn} ({yu}).",
            match norm.unit_of("curve_mse") {
                u if u.is_empty() => "the normalised force's units squared (none)".to_string(),
                u => u,
            },
            100.0 * STIFFNESS_FRACTION
        ),
    ];
    // The run with the smallest MSE over every stage, and the validation runs.
    let mut sims = Vec::new();
    let mut best: Option<(f64, String, Curve)> = None;
    for st in &r.stages {
        for (spec, rec) in st.runs.iter().zip(&st.records) {
            let Some(rec) = rec.as_ref().filter(|r| r.status == Status::Done) else {
                continue;
            };
            let outputs = match test {
                None => &rec.outputs,
                Some(t) => &rec.outputs["tests"][t],
            };
            let (Some(mse), Some(curve)) = (
                outputs.get("curve_mse").and_then(|v| v.as_f64()),
                stored_curve(outputs),
            ) else {
                continue;
            };
            let label = format!("stage {} run {}", spec.stage + 1, spec.index + 1);
            if st.kind == "validate" {
                sims.push(Simulated {
                    label: format!("validation run {} (MSE {})", spec.index + 1, sig(mse)),
                    curve: curve.clone(),
                    best: false,
                });
            }
            if best.as_ref().is_none_or(|b| mse < b.0) {
                best = Some((mse, label, curve));
            }
        }
    }
    if let Some((mse, label, curve)) = best {
        paragraphs.push(format!(
            "The run with the smallest {}curve_mse is {label}: {}.",
            test.map_or(String::new(), |t| format!("{t} ")),
            sig(mse)
        ));
        sims.insert(
            0,
            Simulated {
                label: format!("{label} (smallest MSE, {})", sig(mse)),
                curve,
                best: true,
            },
        );
    }
    let lab = cmp.lab_normalised();
    let band = (c.lab.replicates.len() > 1).then(|| {
        let peak = cmp.lab_peak_n();
        let side = |y: &[f64]| {
            norm.apply(
                &Curve {
                    x: c.lab.mean.x.clone(),
                    y: y.to_vec(),
                },
                peak,
            )
        };
        (side(&c.lab.min), side(&c.lab.max))
    });
    let what = match test {
        None => study.target.response.clone(),
        Some(t) => format!("test {t}"),
    };
    let svg = plot(&what, &lab, band.as_ref(), &sims, (xn, xu), (yn, yu));
    Section {
        title: test.map(|t| format!("test {t}: {}", c.curve)),
        stem: match test {
            None => "curves".to_string(),
            Some(t) => format!("curves-{t}"),
        },
        paragraphs,
        svg,
    }
}

fn thin(c: &Curve) -> Vec<(f64, f64)> {
    let (lo, hi) = c.range();
    let d = if c.x.len() > DRAW_POINTS {
        c.resample(lo, hi, DRAW_POINTS)
    } else {
        c.clone()
    };
    d.x.into_iter().zip(d.y).collect()
}

/// The plot; `what` names the curve in its caption (the response, or the test).
fn plot(
    what: &str,
    lab: &Curve,
    band: Option<&(Curve, Curve)>,
    sims: &[Simulated],
    (xn, xu): (&str, &str),
    (yn, yu): (&str, &str),
) -> Result<String, String> {
    let lab_pts = thin(lab);
    let band_pts = band.map(|(lo, hi)| {
        let mut poly = thin(hi);
        poly.extend(thin(lo).into_iter().rev());
        poly
    });
    let sim_pts: Vec<Vec<(f64, f64)>> = sims.iter().map(|s| thin(&s.curve)).collect();
    let all = lab_pts
        .iter()
        .chain(band_pts.iter().flatten())
        .chain(sim_pts.iter().flatten());
    let (x0, x1, y0, y1) = all.fold(
        (f64::MAX, f64::MIN, f64::MAX, f64::MIN),
        |(a, b, c, d), p| (a.min(p.0), b.max(p.0), c.min(p.1), d.max(p.1)),
    );
    let px = 0.03 * (x1 - x0).max(1e-12 * x1.abs().max(1e-300));
    let py = 0.08 * (y1 - y0).max(1e-9 * y1.abs().max(1e-300));
    let red = RGBColor(200, 30, 30);
    let blue = RGBColor(40, 100, 200);
    let green = RGBColor(30, 150, 60);
    plots::render(|root| {
        let mut chart = ChartBuilder::on(root)
            .caption(
                format!("Lab and simulated curves ({what})"),
                ("sans-serif", 24),
            )
            .margin(14)
            .x_label_area_size(66)
            .y_label_area_size(92)
            .build_cartesian_2d((x0 - px)..(x1 + px), (y0 - py)..(y1 + py))
            .map_err(plots::err)?;
        chart
            .configure_mesh()
            .label_style((plots::FONT, plots::TEXT))
            .axis_desc_style((plots::FONT, plots::DESC))
            .x_desc(format!("{xn} ({xu})"))
            .y_desc(format!("{yn} ({yu})"))
            .draw()
            .map_err(plots::err)?;
        if let Some(poly) = band_pts {
            chart
                .draw_series([Polygon::new(poly, red.mix(0.18).filled())])
                .map_err(plots::err)?
                .label("lab band (replicates' min .. max)")
                .legend(move |(x, y)| {
                    Rectangle::new([(x, y - 5), (x + 18, y + 5)], red.mix(0.18).filled())
                });
        }
        chart
            .draw_series(LineSeries::new(lab_pts, red.stroke_width(3)))
            .map_err(plots::err)?
            .label("lab mean")
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 18, y)], red.stroke_width(3)));
        for (s, pts) in sims.iter().zip(sim_pts) {
            let (colour, width) = if s.best { (blue, 2) } else { (green, 1) };
            chart
                .draw_series(LineSeries::new(pts, colour.stroke_width(width)))
                .map_err(plots::err)?
                .label(s.label.clone())
                .legend(move |(x, y)| {
                    PathElement::new([(x, y), (x + 18, y)], colour.stroke_width(width))
                });
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.9))
            .border_style(BLACK)
            .label_font((plots::FONT, plots::TEXT))
            .position(SeriesLabelPosition::LowerRight)
            .draw()
            .map_err(plots::err)?;
        Ok(())
    })
}
