//! SVG plots of a fit, drawn with plotters' SVG backend (text is left to the SVG viewer, so no
//! system fonts are needed): Pareto chart, predicted vs actual, residuals vs predicted, normal
//! plot of residuals, a contour plot and a 3-D surface over two factors.

use plotters::coord::Shift;
use plotters::prelude::*;
use statrs::distribution::{ContinuousCDF, Normal};

use crate::fit::{fmt_sig, t_critical, Fit};

const SIZE: (u32, u32) = (720, 540);
pub const FONT: &str = "sans-serif";
const POSITIVE: RGBColor = RGBColor(230, 120, 20);
const NEGATIVE: RGBColor = RGBColor(40, 100, 200);
const POINT: RGBColor = RGBColor(200, 30, 30);

/// A plotters error as text.
pub fn err<E: std::fmt::Debug>(e: E) -> String {
    format!("plot: {e:?}")
}

/// Draws an SVG of the plots' common size on a white background.
pub fn render(
    draw: impl FnOnce(&DrawingArea<SVGBackend, Shift>) -> Result<(), String>,
) -> Result<String, String> {
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, SIZE).into_drawing_area();
        root.fill(&WHITE).map_err(err)?;
        draw(&root)?;
        root.present().map_err(err)?;
    }
    Ok(svg)
}

/// The axis range for data spanning lo..hi, widened a little; a sane range when the data are
/// empty (lo > hi), a single value, or spread less than rounding (an exact fit's residuals),
/// because plotters' tick search does not end on a degenerate range.
pub fn padded(lo: f64, hi: f64) -> std::ops::Range<f64> {
    if !(lo.is_finite() && hi.is_finite()) || lo > hi {
        return -1.0..1.0;
    }
    let scale = lo.abs().max(hi.abs()).max(1e-12);
    let pad = if hi - lo > 1e-9 * scale {
        0.06 * (hi - lo)
    } else {
        0.5 * scale.max(1.0) * if scale < 1e-6 { 1.0 } else { 0.01 }
    };
    (lo - pad)..(hi + pad)
}

pub fn min_max(v: impl Iterator<Item = f64>) -> (f64, f64) {
    v.filter(|x| x.is_finite())
        .fold((f64::MAX, f64::MIN), |(a, b), x| (a.min(x), b.max(x)))
}

/// Pareto chart of |t| of the two-level effects, largest first, orange for positive and blue for
/// negative effects, with the t limit and the Bonferroni limit (alpha 0.05).
pub fn pareto_chart(fit: &Fit) -> Result<String, String> {
    if fit.effects.is_empty() {
        return Err("plot: a Pareto chart needs a two-level design (effects)".into());
    }
    let mut effects = fit.effects.clone();
    effects.sort_by(|a, b| b.t.abs().total_cmp(&a.t.abs()));
    let limits = fit.pareto_limits(0.05);
    let top = effects
        .iter()
        .map(|e| e.t.abs())
        .chain(limits.iter().flat_map(|(a, b)| [*a, *b]))
        .filter(|v| v.is_finite())
        .fold(0.0f64, f64::max)
        * 1.1;
    if fit.effects.iter().any(|e| !e.t.is_finite()) {
        return Err("plot: no residual error (exact fit), so the effects have no t values".into());
    }
    let top = if top > 0.0 { top } else { 1.0 };
    let m = effects.len();
    render(|root| {
        let mut chart = ChartBuilder::on(root)
            .caption(
                format!("Pareto chart: {}", fit.experiment.response_name),
                (FONT, 22),
            )
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(56)
            .build_cartesian_2d(0.0..m as f64, 0.0..top)
            .map_err(err)?;
        chart
            .configure_mesh()
            .disable_x_mesh()
            .disable_x_axis()
            .y_desc("|t-value|")
            .draw()
            .map_err(err)?;
        chart
            .draw_series(effects.iter().enumerate().map(|(i, e)| {
                let colour = if e.t >= 0.0 { POSITIVE } else { NEGATIVE };
                Rectangle::new(
                    [(i as f64 + 0.15, 0.0), (i as f64 + 0.85, e.t.abs())],
                    colour.filled(),
                )
            }))
            .map_err(err)?;
        chart
            .draw_series(effects.iter().enumerate().map(|(i, e)| {
                Text::new(
                    e.name.clone(),
                    (i as f64 + 0.5, 0.0),
                    (FONT, 15).into_font().color(&BLACK).pos(
                        plotters::style::text_anchor::Pos::new(
                            plotters::style::text_anchor::HPos::Center,
                            plotters::style::text_anchor::VPos::Bottom,
                        ),
                    ),
                )
            }))
            .map_err(err)?;
        if let Some((t, bonf)) = limits {
            for (value, label) in [(t, "t-value limit"), (bonf, "Bonferroni limit")] {
                if value <= top {
                    chart
                        .draw_series(LineSeries::new(
                            [(0.0, value), (m as f64, value)],
                            BLACK.stroke_width(1),
                        ))
                        .map_err(err)?;
                    chart
                        .draw_series([Text::new(
                            format!("{label} {value:.3}"),
                            (m as f64 * 0.98, value),
                            (FONT, 13).into_font().color(&BLACK).pos(
                                plotters::style::text_anchor::Pos::new(
                                    plotters::style::text_anchor::HPos::Right,
                                    plotters::style::text_anchor::VPos::Bottom,
                                ),
                            ),
                        )])
                        .map_err(err)?;
                }
            }
        }
        Ok(())
    })
}

/// Scatter of (x, y) with an optional reference line and horizontal lines.
#[allow(clippy::too_many_arguments)]
pub fn scatter(
    title: &str,
    x_desc: &str,
    y_desc: &str,
    points: &[(f64, f64)],
    line: Option<[(f64, f64); 2]>,
    hlines: &[f64],
    square: bool,
) -> Result<String, String> {
    let (mut x0, mut x1) = min_max(points.iter().map(|p| p.0));
    let (mut y0, mut y1) = min_max(points.iter().map(|p| p.1).chain(hlines.iter().copied()));
    if square {
        let (lo, hi) = (x0.min(y0), x1.max(y1));
        (x0, x1, y0, y1) = (lo, hi, lo, hi);
    }
    render(|root| {
        let mut chart = ChartBuilder::on(root)
            .caption(title, (FONT, 22))
            .margin(12)
            .x_label_area_size(44)
            .y_label_area_size(60)
            .build_cartesian_2d(padded(x0, x1), padded(y0, y1))
            .map_err(err)?;
        chart
            .configure_mesh()
            .x_desc(x_desc)
            .y_desc(y_desc)
            .draw()
            .map_err(err)?;
        let xr = padded(x0, x1);
        for &h in hlines {
            chart
                .draw_series(LineSeries::new(
                    [(xr.start, h), (xr.end, h)],
                    RED.stroke_width(1),
                ))
                .map_err(err)?;
        }
        if let Some(l) = line {
            chart
                .draw_series(LineSeries::new(l, BLACK.stroke_width(1)))
                .map_err(err)?;
        }
        chart
            .draw_series(
                points
                    .iter()
                    .filter(|p| p.0.is_finite() && p.1.is_finite())
                    .map(|&p| Circle::new(p, 4, POINT.filled())),
            )
            .map_err(err)?;
        Ok(())
    })
}

/// Predicted (fitted model) against observed values, with the line y = x.
pub fn predicted_vs_actual(fit: &Fit) -> Result<String, String> {
    let pts: Vec<(f64, f64)> = fit
        .experiment
        .response
        .iter()
        .copied()
        .zip(fit.predicted.iter().copied())
        .collect();
    let (lo, hi) = min_max(pts.iter().flat_map(|p| [p.0, p.1]));
    scatter(
        &format!("Predicted vs. actual: {}", fit.experiment.response_name),
        "Actual",
        "Predicted",
        &pts,
        Some([(lo, lo), (hi, hi)]),
        &[],
        true,
    )
}

/// Limit for externally studentized residuals: the Bonferroni-corrected two-sided t at 0.05.
fn outlier_limit(fit: &Fit) -> Option<f64> {
    let n = fit.experiment.runs();
    let df = fit.residual.df.checked_sub(1)?;
    t_critical(0.05 / n as f64, df)
}

/// Externally studentized residuals against predicted values, with the outlier limits.
pub fn residuals_vs_predicted(fit: &Fit) -> Result<String, String> {
    let pts: Vec<(f64, f64)> = fit
        .predicted
        .iter()
        .copied()
        .zip(fit.studentized.iter().copied())
        .collect();
    let limits: Vec<f64> = outlier_limit(fit).map_or(vec![], |l| vec![-l, l]);
    scatter(
        &format!("Residuals vs. predicted: {}", fit.experiment.response_name),
        "Predicted",
        "Externally studentized residuals",
        &pts,
        None,
        &limits,
        false,
    )
}

/// Normal probability plot of the externally studentized residuals (Blom scores), with the line
/// a standard normal sample would follow.
pub fn normal_plot(fit: &Fit) -> Result<String, String> {
    let mut r: Vec<f64> = fit
        .studentized
        .iter()
        .copied()
        .filter(|v| v.is_finite())
        .collect();
    r.sort_by(f64::total_cmp);
    let n = r.len() as f64;
    let normal = Normal::new(0.0, 1.0).map_err(err)?;
    let pts: Vec<(f64, f64)> = r
        .iter()
        .enumerate()
        .map(|(i, &v)| (v, normal.inverse_cdf((i as f64 + 1.0 - 0.375) / (n + 0.25))))
        .collect();
    let (lo, hi) = min_max(pts.iter().flat_map(|p| [p.0, p.1]));
    scatter(
        &format!("Normal plot of residuals: {}", fit.experiment.response_name),
        "Externally studentized residuals",
        "Normal score",
        &pts,
        Some([(lo, lo), (hi, hi)]),
        &[],
        false,
    )
}

/// A response evaluated on a grid over two factors, the others held at `held` (coded).
pub struct Grid {
    pub x: Vec<f64>,
    pub y: Vec<f64>,
    /// values[i][j] at (x[i], y[j]).
    pub values: Vec<Vec<f64>>,
}

fn axis_value(fit: &Fit, factor: usize, coded: f64) -> f64 {
    match &fit.experiment.factors {
        Some(f) => f[factor].to_actual(coded),
        None => coded,
    }
}

fn axis_name(fit: &Fit, factor: usize) -> String {
    let name = &fit.experiment.factor_names[factor];
    match &fit.experiment.factors {
        Some(_) => format!("{name} (actual)"),
        None => format!("{name} (coded)"),
    }
}

/// Evaluates the model over factors `fx` and `fy` across `range` (coded), others at `held`.
pub fn grid(fit: &Fit, fx: usize, fy: usize, held: &[f64], range: (f64, f64), n: usize) -> Grid {
    let coords: Vec<f64> = (0..n)
        .map(|i| range.0 + (range.1 - range.0) * i as f64 / (n - 1) as f64)
        .collect();
    let values = coords
        .iter()
        .map(|&cx| {
            coords
                .iter()
                .map(|&cy| {
                    let mut x = held.to_vec();
                    x[fx] = cx;
                    x[fy] = cy;
                    fit.predict_coded(&x)
                })
                .collect()
        })
        .collect();
    Grid {
        x: coords.clone(),
        y: coords,
        values,
    }
}

pub fn colour_map(t: f64) -> RGBColor {
    // Blue - cyan - green - yellow - red, as response-surface software shows low to high.
    let stops = [
        (0.0, (40.0, 60.0, 200.0)),
        (0.25, (40.0, 170.0, 220.0)),
        (0.5, (60.0, 190.0, 90.0)),
        (0.75, (240.0, 220.0, 60.0)),
        (1.0, (220.0, 50.0, 40.0)),
    ];
    let t = t.clamp(0.0, 1.0);
    let i = stops.iter().rposition(|s| s.0 <= t).unwrap_or(0).min(3);
    let (a, b) = (stops[i], stops[i + 1]);
    let u = (t - a.0) / (b.0 - a.0);
    let mix = |p: f64, q: f64| (p + u * (q - p)).round() as u8;
    RGBColor(
        mix(a.1 .0, b.1 .0),
        mix(a.1 .1, b.1 .1),
        mix(a.1 .2, b.1 .2),
    )
}

/// Contour line segments of `g` at `level` by marching squares, in grid (coded) coordinates.
pub fn contour_segments(g: &Grid, level: f64) -> Vec<[(f64, f64); 2]> {
    let mut segs = Vec::new();
    let interp = |p: (f64, f64), q: (f64, f64), vp: f64, vq: f64| {
        let t = if vq != vp {
            (level - vp) / (vq - vp)
        } else {
            0.5
        };
        (p.0 + t * (q.0 - p.0), p.1 + t * (q.1 - p.1))
    };
    for i in 0..g.x.len() - 1 {
        for j in 0..g.y.len() - 1 {
            let c = [
                ((g.x[i], g.y[j]), g.values[i][j]),
                ((g.x[i + 1], g.y[j]), g.values[i + 1][j]),
                ((g.x[i + 1], g.y[j + 1]), g.values[i + 1][j + 1]),
                ((g.x[i], g.y[j + 1]), g.values[i][j + 1]),
            ];
            let mut crossings = Vec::new();
            for e in 0..4 {
                let (p, vp) = c[e];
                let (q, vq) = c[(e + 1) % 4];
                if (vp < level) != (vq < level) {
                    crossings.push(interp(p, q, vp, vq));
                }
            }
            match crossings.len() {
                2 => segs.push([crossings[0], crossings[1]]),
                4 => {
                    // Saddle: decide by the cell centre.
                    let centre = 0.25 * c.iter().map(|v| v.1).sum::<f64>();
                    if (centre < level) == (c[0].1 < level) {
                        segs.push([crossings[0], crossings[3]]);
                        segs.push([crossings[1], crossings[2]]);
                    } else {
                        segs.push([crossings[0], crossings[1]]);
                        segs.push([crossings[2], crossings[3]]);
                    }
                }
                _ => {}
            }
        }
    }
    segs
}

/// Filled contour plot of the response over factors `fx`, `fy` (coded `range`), the other factors
/// held at `held` (coded), with labelled contour lines and the design points that lie in the plane.
pub fn contour_plot(
    fit: &Fit,
    fx: usize,
    fy: usize,
    held: &[f64],
    range: (f64, f64),
) -> Result<String, String> {
    const N: usize = 41;
    const LEVELS: usize = 8;
    let g = grid(fit, fx, fy, held, range, N);
    let (lo, hi) = min_max(g.values.iter().flatten().copied());
    let ax = |c: f64| axis_value(fit, fx, c);
    let ay = |c: f64| axis_value(fit, fy, c);
    let (x0, x1) = (ax(range.0), ax(range.1));
    let (y0, y1) = (ay(range.0), ay(range.1));
    let held_note: Vec<String> = (0..held.len())
        .filter(|&f| f != fx && f != fy)
        .map(|f| {
            format!(
                "{} = {}",
                fit.experiment.factor_names[f],
                fmt_sig(axis_value(fit, f, held[f]))
            )
        })
        .collect();
    render(|root| {
        let mut chart = ChartBuilder::on(root)
            .caption(
                format!("{} contours", fit.experiment.response_name),
                (FONT, 22),
            )
            .margin(12)
            .x_label_area_size(44)
            .y_label_area_size(64)
            .build_cartesian_2d(x0..x1, y0..y1)
            .map_err(err)?;
        chart
            .configure_mesh()
            .disable_mesh()
            .x_desc(axis_name(fit, fx))
            .y_desc(axis_name(fit, fy))
            .draw()
            .map_err(err)?;
        let span = (hi - lo).max(1e-300);
        let half = 0.5 * (g.x[1] - g.x[0]);
        chart
            .draw_series((0..N).flat_map(|i| {
                let g = &g;
                (0..N).map(move |j| {
                    let (cx, cy) = (g.x[i], g.y[j]);
                    let a = (ax((cx - half).max(range.0)), ay((cy - half).max(range.0)));
                    let b = (ax((cx + half).min(range.1)), ay((cy + half).min(range.1)));
                    Rectangle::new([a, b], colour_map((g.values[i][j] - lo) / span).filled())
                })
            }))
            .map_err(err)?;
        for l in 1..=LEVELS {
            let level = lo + span * l as f64 / (LEVELS + 1) as f64;
            let segs = contour_segments(&g, level);
            chart
                .draw_series(segs.iter().map(|s| {
                    PathElement::new(
                        vec![(ax(s[0].0), ay(s[0].1)), (ax(s[1].0), ay(s[1].1))],
                        BLACK.stroke_width(1),
                    )
                }))
                .map_err(err)?;
            if let Some(s) = segs.get(segs.len() / 2) {
                chart
                    .draw_series([Text::new(
                        fmt_sig(level),
                        (ax(s[0].0), ay(s[0].1)),
                        (FONT, 12).into_font().color(&BLACK),
                    )])
                    .map_err(err)?;
            }
        }
        // Design points in this plane (other factors at their held values).
        let pts: Vec<(f64, f64)> = fit
            .experiment
            .coded
            .iter()
            .filter(|x| {
                (0..x.len()).all(|f| f == fx || f == fy || (x[f] - held[f]).abs() < 1e-9)
                    && [x[fx], x[fy]]
                        .iter()
                        .all(|v| *v >= range.0 - 1e-9 && *v <= range.1 + 1e-9)
            })
            .map(|x| (ax(x[fx]), ay(x[fy])))
            .collect();
        chart
            .draw_series(pts.iter().map(|&p| Circle::new(p, 4, BLACK.filled())))
            .map_err(err)?;
        if !held_note.is_empty() {
            root.draw(&Text::new(
                format!("held: {}", held_note.join(", ")),
                (80, SIZE.1 as i32 - 18),
                (FONT, 13).into_font(),
            ))
            .map_err(err)?;
        }
        Ok(())
    })
}

/// 3-D response surface over factors `fx`, `fy`, the others held at `held` (coded).
pub fn surface_plot(
    fit: &Fit,
    fx: usize,
    fy: usize,
    held: &[f64],
    range: (f64, f64),
) -> Result<String, String> {
    const N: usize = 25;
    let g = grid(fit, fx, fy, held, range, N);
    let (lo, hi) = min_max(g.values.iter().flatten().copied());
    let span = (hi - lo).max(1e-300);
    let xs: Vec<f64> = g.x.iter().map(|&c| axis_value(fit, fx, c)).collect();
    let ys: Vec<f64> = g.y.iter().map(|&c| axis_value(fit, fy, c)).collect();
    let value_at = |x: f64, y: f64| -> f64 {
        let i = xs.iter().position(|v| *v == x).unwrap_or(0);
        let j = ys.iter().position(|v| *v == y).unwrap_or(0);
        g.values[i][j]
    };
    render(|root| {
        let mut chart = ChartBuilder::on(root)
            .caption(
                format!(
                    "{} over {} and {}",
                    fit.experiment.response_name,
                    fit.experiment.factor_names[fx],
                    fit.experiment.factor_names[fy]
                ),
                (FONT, 22),
            )
            .margin(20)
            .build_cartesian_3d(xs[0]..xs[N - 1], padded(lo, hi), ys[0]..ys[N - 1])
            .map_err(err)?;
        chart.with_projection(|mut p| {
            // A low view: the height reads off the surface instead of being folded into depth.
            p.pitch = 0.2;
            p.yaw = 0.6;
            p.scale = 0.85;
            p.into_matrix()
        });
        chart
            .configure_axes()
            .light_grid_style(BLACK.mix(0.1))
            .max_light_lines(3)
            .draw()
            .map_err(err)?;
        let style = |v: &f64| colour_map((v - lo) / span).mix(0.9).filled();
        chart
            .draw_series(
                SurfaceSeries::xoz(xs.iter().copied(), ys.iter().copied(), value_at)
                    .style_func(&style),
            )
            .map_err(err)?;
        root.draw(&Text::new(
            format!(
                "x: {}   z: {}   vertical: {}",
                axis_name(fit, fx),
                axis_name(fit, fy),
                fit.experiment.response_name
            ),
            (40, SIZE.1 as i32 - 22),
            (FONT, 14).into_font(),
        ))
        .map_err(err)?;
        Ok(())
    })
}

/// Writes every plot that applies to `fit` into `dir`; returns the files written. The contour and
/// surface use the two most significant main effects (by p value), others held at the centre.
pub fn write_all(fit: &Fit, dir: &std::path::Path) -> Result<Vec<std::path::PathBuf>, String> {
    std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let mut plots: Vec<(&str, String)> = Vec::new();
    if !fit.effects.is_empty() && fit.effects.iter().all(|e| e.t.is_finite()) {
        plots.push(("pareto.svg", pareto_chart(fit)?));
    }
    plots.push(("predicted_vs_actual.svg", predicted_vs_actual(fit)?));
    if fit.studentized.iter().any(|r| r.is_finite()) {
        plots.push(("residuals_vs_predicted.svg", residuals_vs_predicted(fit)?));
        plots.push(("normal_plot.svg", normal_plot(fit)?));
    }
    if let Some((fx, fy)) = two_main_factors(fit) {
        let k = fit.experiment.factor_names.len();
        let held = vec![0.0; k];
        plots.push((
            "contour.svg",
            contour_plot(fit, fx, fy, &held, (-1.0, 1.0))?,
        ));
        plots.push((
            "surface.svg",
            surface_plot(fit, fx, fy, &held, (-1.0, 1.0))?,
        ));
    }
    let mut written = Vec::new();
    for (name, svg) in plots {
        let path = dir.join(name);
        std::fs::write(&path, svg).map_err(|e| format!("{}: {e}", path.display()))?;
        written.push(path);
    }
    Ok(written)
}

/// The two factors whose main effects are most significant, if the model has two.
pub fn two_main_factors(fit: &Fit) -> Option<(usize, usize)> {
    let mut mains: Vec<(usize, f64)> = fit
        .terms
        .iter()
        .skip(1)
        .zip(&fit.anova_terms)
        .filter(|(t, _)| t.order() == 1)
        .map(|(t, r)| {
            (
                t.powers.iter().position(|&p| p == 1).unwrap(),
                r.p.unwrap_or(1.0),
            )
        })
        .collect();
    mains.sort_by(|a, b| a.1.total_cmp(&b.1));
    if mains.len() >= 2 {
        let (a, b) = (mains[0].0, mains[1].0);
        Some((a.min(b), a.max(b)))
    } else {
        None
    }
}
