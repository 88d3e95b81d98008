//! SVG plots of a fit, drawn with plotters' SVG backend (text is left to the SVG viewer, so no
//! system fonts are needed; [`crate::raster`] turns them into PNG): Pareto chart, predicted vs
//! actual, the residual diagnostics (normal plot, residuals against predicted values and against
//! run order, Cook's distance), and in [`crate::plots_surface`] the contour plot, 3-D surface
//! and perturbation plot.
//!
//! Every plot is [`SIZE`] SVG units, its text sized for a page that shows it at 90-100 % of
//! that: tick labels and legends 18.5 units, axis titles 19.4, like body text. Figures carry no
//! title: a report or paper captions them. Axis titles come from [`Labels`]: the response's and
//! factors' names with their units.

use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use statrs::distribution::{ContinuousCDF, Normal};

use crate::fit::{t_critical, Fit};
pub use crate::plots_surface::{
    colour_map, contour_plot, contour_segments, grid, map_with_colour_bar, nice_ticks,
    perturbation_plot, surface_plot, ContourMarks, FilledMap, Grid,
};

/// Width and height of every plot, in SVG units (pixels at 100 %).
pub const SIZE: (u32, u32) = (640, 480);
pub const FONT: &str = "sans-serif";
/// plotters' text sizes; its SVG backend writes font-size = size / 1.24.
/// Tick labels, legends and notes: 18.5 units.
pub const TEXT: u32 = 23;
/// Axis titles: 19.4 units.
pub const DESC: u32 = 24;
pub const POSITIVE: RGBColor = RGBColor(230, 120, 20);
pub const NEGATIVE: RGBColor = RGBColor(40, 100, 200);
pub const POINT: RGBColor = RGBColor(200, 30, 30);
/// Series colours for several lines (colour-blind safe, Okabe-Ito).
pub const SERIES: [RGBColor; 6] = [
    RGBColor(0, 114, 178),
    RGBColor(213, 94, 0),
    RGBColor(0, 158, 115),
    RGBColor(204, 121, 167),
    RGBColor(86, 180, 233),
    RGBColor(230, 159, 0),
];

/// The font size SVG text of plotters' `size` gets.
pub fn svg_px(size: u32) -> f32 {
    size as f32 / 1.24
}

/// Axis titles of a fit's plots: the response's and each factor's, with their units.
#[derive(Clone, Debug, PartialEq)]
pub struct Labels {
    pub response: String,
    pub factors: Vec<String>,
    /// Short names of the factors for labels on lines (A, B, ... by default).
    pub letters: Vec<String>,
}

impl Labels {
    /// The fit's own names: factors in actual units where their ranges are known, else coded.
    pub fn of(fit: &Fit) -> Labels {
        let coded = fit.experiment.factors.is_none();
        Labels {
            response: fit.experiment.response_name.clone(),
            factors: fit
                .experiment
                .factor_names
                .iter()
                .map(|n| {
                    if coded {
                        format!("{n} (coded)")
                    } else {
                        n.clone()
                    }
                })
                .collect(),
            letters: letters(fit),
        }
    }

    /// Names with units: `unit` of the response, `units` of each factor ("" where unknown).
    pub fn with_units(fit: &Fit, unit: &str, units: &[String]) -> Labels {
        Labels {
            response: with_unit(&fit.experiment.response_name, unit),
            factors: fit
                .experiment
                .factor_names
                .iter()
                .enumerate()
                .map(|(i, n)| with_unit(n, units.get(i).map_or("", String::as_str)))
                .collect(),
            letters: letters(fit),
        }
    }
}

fn letters(fit: &Fit) -> Vec<String> {
    (0..fit.experiment.factor_names.len())
        .map(crate::design::factor_letter)
        .collect()
}

/// `name (unit)`; a name that ends in its unit (`angle_deg`, `deg`) drops the ending. "-" or
/// "–" marks a quantity without dimension; an empty unit leaves the name bare.
pub fn with_unit(name: &str, unit: &str) -> String {
    let unit = unit.trim();
    if unit.is_empty() {
        return name.to_string();
    }
    let unit = if unit == "-" { "–" } else { unit };
    let base = name
        .strip_suffix(&format!("_{unit}"))
        .filter(|b| !b.is_empty())
        .unwrap_or(name);
    format!("{base} ({unit})")
}

/// A plotters error as text.
pub fn err<E: std::fmt::Debug>(e: E) -> String {
    format!("plot: {e:?}")
}

/// Draws an SVG of the plots' common size on a white background.
pub fn render(
    draw: impl FnOnce(&DrawingArea<SVGBackend, Shift>) -> Result<(), String>,
) -> Result<String, String> {
    render_sized(SIZE, draw)
}

/// [`render`] at another size.
pub fn render_sized(
    size: (u32, u32),
    draw: impl FnOnce(&DrawingArea<SVGBackend, Shift>) -> Result<(), String>,
) -> Result<String, String> {
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, size).into_drawing_area();
        root.fill(&WHITE).map_err(err)?;
        draw(&root)?;
        root.present().map_err(err)?;
    }
    Ok(svg)
}

/// A 2-D chart of numbers.
pub type Chart<'a, 'b> =
    ChartContext<'a, SVGBackend<'b>, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// A tick label: the shortest decimal that shows the value (ticks are round numbers).
pub fn tick(v: &f64) -> String {
    let v = *v;
    if v == 0.0 || !v.is_finite() {
        return "0".into();
    }
    let a = v.abs();
    if !(1e-3..1e5).contains(&a) {
        let s = format!("{v:.2e}");
        let (m, e) = s.split_once('e').unwrap_or((&s, "0"));
        let m = m.trim_end_matches('0').trim_end_matches('.');
        return format!("{m}e{e}");
    }
    let s = format!("{v:.6}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" {
        "0".into()
    } else {
        s.replace('-', "−")
    }
}

/// How an axis is ticked: `Decimal` for measured values (round ticks, fractional where the
/// range is short), `Whole` for an axis that counts things (rounds, runs, iterations,
/// generations), where 2.5 means nothing: whole-number ticks only, however short the range.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Ticks {
    #[default]
    Decimal,
    Whole,
}

impl Ticks {
    /// `Whole` when every finite value is a whole number (and there is one), else `Decimal`.
    pub fn detect(values: impl IntoIterator<Item = f64>) -> Ticks {
        let mut any = false;
        for v in values.into_iter().filter(|v| v.is_finite()) {
            if v.fract() != 0.0 {
                return Ticks::Decimal;
            }
            any = true;
        }
        if any {
            Ticks::Whole
        } else {
            Ticks::Decimal
        }
    }

    /// How many labels to ask plotters for over `range` (its `x_labels` / `y_labels`), at most
    /// `n`. Plotters ticks with the finest step of 1, 2 or 5 times a power of ten that gives no
    /// more labels than asked; asking for no more than the whole numbers in the range keeps
    /// that step at 1 or more, so every tick is a whole number.
    pub fn labels(self, range: &std::ops::Range<f64>, n: usize) -> usize {
        match self {
            Ticks::Decimal => n,
            Ticks::Whole => {
                let whole = range.end.floor() - range.start.ceil() + 1.0;
                if whole.is_finite() && whole >= 1.0 {
                    n.min(whole as usize)
                } else {
                    0
                }
            }
        }
    }
}

/// Axes in the plots' style: a light grid, round ticks, the labels' size, titles `x` and `y`.
pub fn draw_mesh(chart: &mut Chart, x: &str, y: &str) -> Result<(), String> {
    draw_mesh_ticks(chart, x, y, Ticks::Decimal)
}

/// [`draw_mesh`] with the x axis ticked as `x_ticks` says (whole numbers for counts).
pub fn draw_mesh_ticks(chart: &mut Chart, x: &str, y: &str, x_ticks: Ticks) -> Result<(), String> {
    let x_labels = x_ticks.labels(&chart.x_range(), 6);
    chart
        .configure_mesh()
        .x_desc(x)
        .y_desc(y)
        .x_labels(x_labels)
        .y_labels(6)
        .x_label_formatter(&tick)
        .y_label_formatter(&tick)
        .label_style((FONT, TEXT))
        .axis_desc_style((FONT, DESC))
        .light_line_style(TRANSPARENT)
        .bold_line_style(BLACK.mix(0.1))
        .draw()
        .map_err(err)
}

/// A chart on `root` over `x` by `y`, with room for tick labels and axis titles.
pub fn chart<'a, 'b>(
    root: &'a DrawingArea<SVGBackend<'b>, Shift>,
    x: std::ops::Range<f64>,
    y: std::ops::Range<f64>,
    top: u32,
) -> Result<Chart<'a, 'b>, String> {
    ChartBuilder::on(root)
        .margin(14)
        .margin_top(top)
        .margin_right(22)
        .x_label_area_size(66)
        .y_label_area_size(92)
        .build_cartesian_2d(x, y)
        .map_err(err)
}

/// A legend entry's mark.
#[derive(Clone, Copy, Debug)]
pub enum Mark {
    Dot(RGBColor),
    Ring(RGBColor),
    Cross(RGBColor),
    Line(RGBColor, u32),
    Dashed(RGBColor, u32),
    Bar(RGBColor),
}

/// Width of `text` at plotters size `size` (DejaVu Sans, what the PNGs use and the usual
/// sans-serif).
pub fn text_width(text: &str, size: u32) -> i32 {
    crate::raster::text_width(text, svg_px(size)).ceil() as i32
}

/// Draws a mark of the legend centred at (x, y), 26 units wide.
pub fn draw_mark(
    root: &DrawingArea<SVGBackend, Shift>,
    m: Mark,
    x: i32,
    y: i32,
) -> Result<(), String> {
    match m {
        Mark::Dot(c) => root.draw(&Circle::new((x, y), 6, c.filled())),
        Mark::Ring(c) => root.draw(&Circle::new((x, y), 8, c.stroke_width(3))),
        Mark::Cross(c) => {
            root.draw(&Cross::new((x, y), 8, WHITE.stroke_width(6)))
                .map_err(err)?;
            root.draw(&Cross::new((x, y), 8, c.stroke_width(3)))
        }
        Mark::Line(c, w) => root.draw(&PathElement::new(
            vec![(x - 13, y), (x + 13, y)],
            c.stroke_width(w),
        )),
        Mark::Dashed(c, w) => {
            for dx in [-13, -1, 10] {
                root.draw(&PathElement::new(
                    vec![(x + dx, y), ((x + dx + 7).min(x + 13), y)],
                    c.stroke_width(w),
                ))
                .map_err(err)?;
            }
            Ok(())
        }
        Mark::Bar(c) => root.draw(&Rectangle::new(
            [(x - 11, y - 8), (x + 11, y + 8)],
            c.filled(),
        )),
    }
    .map_err(err)
}

/// A row of legend entries starting at (x, y) (the middle of the first row), wrapped within
/// `width`; returns the height used.
pub fn legend_row(
    root: &DrawingArea<SVGBackend, Shift>,
    items: &[(Mark, String)],
    x: i32,
    y: i32,
    width: i32,
) -> Result<i32, String> {
    let line = (svg_px(TEXT) * 1.45).round() as i32;
    let (mut cx, mut cy) = (x, y);
    for (m, label) in items {
        let w = 30 + text_width(label, TEXT) + 22;
        if cx > x && cx + w > x + width {
            cx = x;
            cy += line;
        }
        draw_mark(root, *m, cx + 13, cy)?;
        root.draw(&Text::new(
            label.clone(),
            (cx + 32, cy),
            (FONT, TEXT)
                .into_font()
                .color(&BLACK)
                .pos(Pos::new(HPos::Left, VPos::Center)),
        ))
        .map_err(err)?;
        cx += w;
    }
    Ok(cy - y + line)
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

/// Pareto chart of |t| of the two-level effects, largest at the top, orange for positive and
/// blue for negative effects, with the t limit and the Bonferroni limit (alpha 0.05) and a
/// legend saying so.
pub fn pareto_chart(fit: &Fit) -> Result<String, String> {
    if fit.effects.is_empty() {
        return Err("plot: a Pareto chart needs a two-level design (effects)".into());
    }
    if fit.effects.iter().any(|e| !e.t.is_finite()) {
        return Err("plot: no residual error (exact fit), so the effects have no t values".into());
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
        * 1.08;
    let top = if top > 0.0 { top } else { 1.0 };
    let m = effects.len();
    let name_width = effects
        .iter()
        .map(|e| text_width(&e.name, TEXT))
        .max()
        .unwrap_or(0)
        .clamp(30, 300);
    render(|root| {
        let mut items = vec![
            (Mark::Bar(POSITIVE), "positive effect".to_string()),
            (Mark::Bar(NEGATIVE), "negative effect".to_string()),
        ];
        if let Some((t, bonf)) = limits {
            items.push((
                Mark::Line(BLACK, 2),
                format!("t limit {}", tick(&round_to(t, 3))),
            ));
            items.push((
                Mark::Dashed(BLACK, 2),
                format!("Bonferroni limit {}", tick(&round_to(bonf, 3))),
            ));
        }
        let used = legend_row(root, &items, 16, 26, SIZE.0 as i32 - 32)?;
        let mut chart = ChartBuilder::on(root)
            .margin(14)
            .margin_top(used + 10)
            .margin_right(22)
            .x_label_area_size(66)
            .y_label_area_size(name_width + 18)
            .build_cartesian_2d(0.0..top, 0.0..m as f64)
            .map_err(err)?;
        chart
            .configure_mesh()
            .disable_y_mesh()
            .y_labels(0)
            .x_labels(6)
            .x_label_formatter(&tick)
            .x_desc("|t| of the effect")
            .label_style((FONT, TEXT))
            .axis_desc_style((FONT, DESC))
            .light_line_style(TRANSPARENT)
            .bold_line_style(BLACK.mix(0.1))
            .draw()
            .map_err(err)?;
        let row = |i: usize| (m - i) as f64;
        chart
            .draw_series(effects.iter().enumerate().map(|(i, e)| {
                let colour = if e.t >= 0.0 { POSITIVE } else { NEGATIVE };
                Rectangle::new(
                    [(0.0, row(i) - 0.85), (e.t.abs(), row(i) - 0.15)],
                    colour.filled(),
                )
            }))
            .map_err(err)?;
        for (i, e) in effects.iter().enumerate() {
            let (px, py) = chart.backend_coord(&(0.0, row(i) - 0.5));
            root.draw(&Text::new(
                e.name.clone(),
                (px - 8, py),
                (FONT, TEXT)
                    .into_font()
                    .color(&BLACK)
                    .pos(Pos::new(HPos::Right, VPos::Center)),
            ))
            .map_err(err)?;
        }
        if let Some((t, bonf)) = limits {
            if t <= top {
                chart
                    .draw_series(LineSeries::new(
                        [(t, 0.0), (t, m as f64)],
                        BLACK.stroke_width(2),
                    ))
                    .map_err(err)?;
            }
            if bonf <= top {
                chart
                    .draw_series(DashedLineSeries::new(
                        [(bonf, 0.0), (bonf, m as f64)],
                        8,
                        6,
                        BLACK.stroke_width(2),
                    ))
                    .map_err(err)?;
            }
        }
        Ok(())
    })
}

fn round_to(v: f64, decimals: i32) -> f64 {
    let k = 10f64.powi(decimals);
    (v * k).round() / k
}

/// A horizontal reference line with its legend text.
#[derive(Clone, Debug)]
pub struct HLine {
    pub y: f64,
    pub label: String,
}

/// Scatter of (x, y) with an optional y = x line (`square` axes) and labelled horizontal lines.
pub fn scatter(
    x_desc: &str,
    y_desc: &str,
    points: &[(f64, f64)],
    line: Option<([(f64, f64); 2], &str)>,
    hlines: &[HLine],
    square: bool,
) -> Result<String, String> {
    scatter_ticks(x_desc, y_desc, points, line, hlines, square, Ticks::Decimal)
}

/// [`scatter`] with the x axis ticked as `x_ticks` says.
fn scatter_ticks(
    x_desc: &str,
    y_desc: &str,
    points: &[(f64, f64)],
    line: Option<([(f64, f64); 2], &str)>,
    hlines: &[HLine],
    square: bool,
    x_ticks: Ticks,
) -> Result<String, String> {
    let (mut x0, mut x1) = min_max(points.iter().map(|p| p.0));
    let (mut y0, mut y1) = min_max(points.iter().map(|p| p.1).chain(hlines.iter().map(|h| h.y)));
    if square {
        let (lo, hi) = (x0.min(y0), x1.max(y1));
        (x0, x1, y0, y1) = (lo, hi, lo, hi);
    }
    render(|root| {
        let mut items = Vec::new();
        if let Some((_, label)) = line {
            items.push((Mark::Line(BLACK, 2), label.to_string()));
        }
        let mut seen = Vec::new();
        for h in hlines {
            if !seen.contains(&h.label) {
                items.push((Mark::Dashed(POINT, 2), h.label.clone()));
                seen.push(h.label.clone());
            }
        }
        let top = if items.is_empty() {
            18
        } else {
            legend_row(root, &items, 16, 26, SIZE.0 as i32 - 32)? + 10
        };
        let (xr, yr) = (padded(x0, x1), padded(y0, y1));
        let mut chart = chart(root, xr.clone(), yr, top as u32)?;
        draw_mesh_ticks(&mut chart, x_desc, y_desc, x_ticks)?;
        for h in hlines {
            chart
                .draw_series(DashedLineSeries::new(
                    [(xr.start, h.y), (xr.end, h.y)],
                    8,
                    6,
                    POINT.stroke_width(2),
                ))
                .map_err(err)?;
        }
        if let Some((l, _)) = line {
            chart
                .draw_series(LineSeries::new(l, BLACK.stroke_width(2)))
                .map_err(err)?;
        }
        chart
            .draw_series(
                points
                    .iter()
                    .filter(|p| p.0.is_finite() && p.1.is_finite())
                    .map(|&p| Circle::new(p, 6, NEGATIVE.filled())),
            )
            .map_err(err)?;
        Ok(())
    })
}

/// Predicted (fitted model) against observed values, with the line y = x.
pub fn predicted_vs_actual(fit: &Fit, labels: &Labels) -> Result<String, String> {
    let pts: Vec<(f64, f64)> = fit
        .experiment
        .response
        .iter()
        .copied()
        .zip(fit.predicted.iter().copied())
        .collect();
    let (lo, hi) = min_max(pts.iter().flat_map(|p| [p.0, p.1]));
    scatter(
        &format!("actual {}", labels.response),
        &format!("predicted {}", labels.response),
        &pts,
        Some(([(lo, lo), (hi, hi)], "predicted = actual")),
        &[],
        true,
    )
}

/// Limit for externally studentized residuals: the Bonferroni-corrected two-sided t at 0.05.
pub fn outlier_limit(fit: &Fit) -> Option<f64> {
    let n = fit.experiment.runs();
    let df = fit.residual.df.checked_sub(1)?;
    t_critical(0.05 / n as f64, df)
}

fn outlier_lines(fit: &Fit) -> Vec<HLine> {
    outlier_limit(fit).map_or(vec![], |l| {
        let label = format!("outlier limits (Bonferroni t {})", tick(&round_to(l, 2)));
        vec![
            HLine {
                y: -l,
                label: label.clone(),
            },
            HLine { y: l, label },
        ]
    })
}

const STUDENTIZED: &str = "externally studentized residual";

/// Externally studentized residuals against predicted values, with the outlier limits.
pub fn residuals_vs_predicted(fit: &Fit, labels: &Labels) -> Result<String, String> {
    let pts: Vec<(f64, f64)> = fit
        .predicted
        .iter()
        .copied()
        .zip(fit.studentized.iter().copied())
        .collect();
    scatter(
        &format!("predicted {}", labels.response),
        STUDENTIZED,
        &pts,
        None,
        &outlier_lines(fit),
        false,
    )
}

/// Externally studentized residuals in the order the runs were made (`runs`: each row's run
/// number; the row's position when empty), with the outlier limits: a trend shows drift.
pub fn residuals_vs_run(fit: &Fit, runs: &[usize]) -> Result<String, String> {
    let pts: Vec<(f64, f64)> = fit
        .studentized
        .iter()
        .enumerate()
        .map(|(i, r)| (runs.get(i).copied().unwrap_or(i + 1) as f64, *r))
        .collect();
    scatter_ticks(
        "run number (order made)",
        STUDENTIZED,
        &pts,
        None,
        &outlier_lines(fit),
        false,
        Ticks::Whole,
    )
}

/// Cook's distance of each run against its run number (as [`residuals_vs_run`]), stems from
/// zero, with the usual limit D = 1 (a run above it moves the fit by itself).
pub fn cooks_distance_plot(fit: &Fit, runs: &[usize]) -> Result<String, String> {
    let pts: Vec<(f64, f64)> = fit
        .cooks_distance
        .iter()
        .enumerate()
        .filter(|(_, d)| d.is_finite())
        .map(|(i, d)| (runs.get(i).copied().unwrap_or(i + 1) as f64, *d))
        .collect();
    if pts.is_empty() {
        return Err("plot: no Cook's distance (no residual error)".into());
    }
    let (x0, x1) = min_max(pts.iter().map(|p| p.0));
    let top = pts.iter().map(|p| p.1).fold(1.0f64, f64::max) * 1.1;
    render(|root| {
        let used = legend_row(
            root,
            &[
                (Mark::Dot(NEGATIVE), "Cook's distance of a run".to_string()),
                (Mark::Dashed(POINT, 2), "D = 1".to_string()),
            ],
            16,
            26,
            SIZE.0 as i32 - 32,
        )?;
        let xr = (x0 - 0.7)..(x1 + 0.7);
        let mut chart = chart(root, xr.clone(), 0.0..top, (used + 10) as u32)?;
        draw_mesh_ticks(
            &mut chart,
            "run number (order made)",
            "Cook's distance",
            Ticks::Whole,
        )?;
        chart
            .draw_series(DashedLineSeries::new(
                [(xr.start, 1.0), (xr.end, 1.0)],
                8,
                6,
                POINT.stroke_width(2),
            ))
            .map_err(err)?;
        for &(x, d) in &pts {
            chart
                .draw_series(LineSeries::new(
                    [(x, 0.0), (x, d)],
                    NEGATIVE.stroke_width(3),
                ))
                .map_err(err)?;
        }
        chart
            .draw_series(pts.iter().map(|&p| Circle::new(p, 6, NEGATIVE.filled())))
            .map_err(err)?;
        Ok(())
    })
}

/// One line of a [`line_plot`]: its legend text, colour and points (drawn as dots joined).
#[derive(Clone, Debug)]
pub struct Line {
    pub label: String,
    pub colour: RGBColor,
    pub points: Vec<(f64, f64)>,
}

/// Lines over a common x axis with a legend row above the plot, such as a search's best value
/// by round. `x_ticks`: [`Ticks::Whole`] for an axis that counts (rounds, iterations,
/// generations, runs); `None` decides from the points ([`Ticks::detect`]).
pub fn line_plot(
    x_desc: &str,
    y_desc: &str,
    lines: &[Line],
    x_ticks: Option<Ticks>,
) -> Result<String, String> {
    let all = || lines.iter().flat_map(|l| l.points.iter());
    let (x0, x1) = min_max(all().map(|p| p.0));
    let (y0, y1) = min_max(all().map(|p| p.1));
    if x0 > x1 || y0 > y1 {
        return Err("plot: no points to draw".into());
    }
    let x_ticks = x_ticks.unwrap_or_else(|| Ticks::detect(all().map(|p| p.0)));
    render(|root| {
        let items: Vec<(Mark, String)> = lines
            .iter()
            .filter(|l| !l.label.is_empty())
            .map(|l| (Mark::Line(l.colour, 3), l.label.clone()))
            .collect();
        let top = if items.is_empty() {
            18
        } else {
            legend_row(root, &items, 16, 26, SIZE.0 as i32 - 32)? + 10
        };
        let mut chart = chart(root, padded(x0, x1), padded(y0, y1), top as u32)?;
        draw_mesh_ticks(&mut chart, x_desc, y_desc, x_ticks)?;
        for l in lines {
            let finite = || {
                l.points
                    .iter()
                    .filter(|p| p.0.is_finite() && p.1.is_finite())
                    .copied()
            };
            chart
                .draw_series(LineSeries::new(finite(), l.colour.stroke_width(3)))
                .map_err(err)?;
            chart
                .draw_series(finite().map(|p| Circle::new(p, 5, l.colour.filled())))
                .map_err(err)?;
        }
        Ok(())
    })
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
        STUDENTIZED,
        "normal quantile",
        &pts,
        Some(([(lo, lo), (hi, hi)], "normal residuals")),
        &[],
        false,
    )
}

/// Writes every plot that applies to `fit` into `dir`; returns the files written. The contour and
/// surface use the two most significant main effects (by p value), others held at the centre.
pub fn write_all(fit: &Fit, dir: &std::path::Path) -> Result<Vec<std::path::PathBuf>, String> {
    std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let labels = Labels::of(fit);
    let mut plots: Vec<(&str, String)> = Vec::new();
    if !fit.effects.is_empty() && fit.effects.iter().all(|e| e.t.is_finite()) {
        plots.push(("pareto.svg", pareto_chart(fit)?));
    }
    plots.push((
        "predicted_vs_actual.svg",
        predicted_vs_actual(fit, &labels)?,
    ));
    if fit.studentized.iter().any(|r| r.is_finite()) {
        plots.push((
            "residuals_vs_predicted.svg",
            residuals_vs_predicted(fit, &labels)?,
        ));
        plots.push(("normal_plot.svg", normal_plot(fit)?));
    }
    if let Some((fx, fy)) = two_main_factors(fit) {
        let k = fit.experiment.factor_names.len();
        let marks = ContourMarks::centre(k);
        plots.push(("contour.svg", contour_plot(fit, &labels, fx, fy, &marks)?));
        plots.push(("surface.svg", surface_plot(fit, &labels, fx, fy, &marks)?));
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_and_units_read_plainly() {
        assert_eq!(tick(&0.15000000000000002), "0.15");
        assert_eq!(tick(&20.0), "20");
        assert_eq!(tick(&-2.5), "−2.5");
        assert_eq!(tick(&2.5e-5), "2.5e-5");
        assert_eq!(
            with_unit("angle_of_repose_deg", "deg"),
            "angle_of_repose (deg)"
        );
        assert_eq!(with_unit("static_friction", "-"), "static_friction (–)");
        assert_eq!(with_unit("density", "kg/m³"), "density (kg/m³)");
        assert_eq!(with_unit("y", ""), "y");
    }
}
