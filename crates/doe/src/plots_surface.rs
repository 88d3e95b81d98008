//! Plots of a fitted surface: the contour plot (with its colour bar, the design runs, a target
//! contour and the optimum), the 3-D surface and the perturbation plot. Shared style in
//! [`crate::plots`].

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use crate::fit::{fmt_sig, Fit};
use crate::plots::{
    draw_mesh, err, legend_row, min_max, padded, render, text_width, tick, Labels, Mark, DESC,
    FONT, SERIES, SIZE, TEXT,
};

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

/// Round values (steps of 1, 2, 2.5 or 5 times a power of ten) inside lo..hi, about `n` of them.
pub fn nice_ticks(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    if !(lo.is_finite() && hi.is_finite()) || hi <= lo {
        return vec![];
    }
    let raw = (hi - lo) / n.max(1) as f64;
    let p = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 2.5, 5.0, 10.0]
        .iter()
        .map(|m| m * p)
        .find(|s| *s >= raw)
        .unwrap_or(10.0 * p);
    let first = (lo / step).ceil() as i64;
    let last = (hi / step).floor() as i64;
    (first..=last)
        .map(|k| {
            let v = k as f64 * step;
            // Rid the tick of the step's rounding (0.30000000000000004).
            (v / p * 1e6).round() * p / 1e6
        })
        .collect()
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

/// Joins segments that share ends into polylines.
pub fn chain(segs: &[[(f64, f64); 2]]) -> Vec<Vec<(f64, f64)>> {
    let close = |a: (f64, f64), b: (f64, f64)| (a.0 - b.0).abs() < 1e-9 && (a.1 - b.1).abs() < 1e-9;
    let mut left: Vec<[(f64, f64); 2]> = segs.to_vec();
    let mut lines = Vec::new();
    while let Some(s) = left.pop() {
        let mut line = vec![s[0], s[1]];
        loop {
            let end = *line.last().unwrap();
            let start = line[0];
            if let Some(k) = left
                .iter()
                .position(|t| close(t[0], end) || close(t[1], end))
            {
                let t = left.swap_remove(k);
                line.push(if close(t[0], end) { t[1] } else { t[0] });
            } else if let Some(k) = left
                .iter()
                .position(|t| close(t[0], start) || close(t[1], start))
            {
                let t = left.swap_remove(k);
                line.insert(0, if close(t[0], start) { t[1] } else { t[0] });
            } else {
                break;
            }
        }
        lines.push(line);
    }
    lines
}

/// What a contour plot or surface shows beyond the model: where the other factors are held,
/// the range of the axes, a target level and the optimum.
#[derive(Clone, Debug)]
pub struct ContourMarks {
    /// Coded values of every factor; those not plotted stay there.
    pub held: Vec<f64>,
    /// Coded range of both axes.
    pub range: (f64, f64),
    /// A response level drawn as a thick dashed contour, with its legend text.
    pub target: Option<(f64, String)>,
    /// A point marked with a cross (coded, every factor), with its legend text.
    pub optimum: Option<(Vec<f64>, String)>,
}

impl ContourMarks {
    /// The other factors at the centre, the axes over -1..1, nothing marked.
    pub fn centre(k: usize) -> ContourMarks {
        ContourMarks {
            held: vec![0.0; k],
            range: (-1.0, 1.0),
            target: None,
            optimum: None,
        }
    }

    /// The coded range that shows every run of the fit lying in the plane of `fx` and `fy`
    /// (a central composite design's axial runs at ±alpha included), at least -1..1.
    pub fn covering(fit: &Fit, fx: usize, fy: usize, held: &[f64]) -> (f64, f64) {
        let reach = in_plane(fit, fx, fy, held)
            .iter()
            .flat_map(|x| [x[fx].abs(), x[fy].abs()])
            .fold(1.0f64, f64::max);
        // A little beyond the outermost runs, so that none sits on the frame.
        (-1.06 * reach, 1.06 * reach)
    }
}

/// The runs whose factors other than `fx` and `fy` sit at `held`.
fn in_plane<'a>(fit: &'a Fit, fx: usize, fy: usize, held: &[f64]) -> Vec<&'a Vec<f64>> {
    fit.experiment
        .coded
        .iter()
        .filter(|x| (0..x.len()).all(|f| f == fx || f == fy || (x[f] - held[f]).abs() < 1e-9))
        .collect()
}

/// "held: E = 12.5" for the factors not plotted, or None.
fn held_note(fit: &Fit, fx: usize, fy: usize, held: &[f64]) -> Option<String> {
    let parts: Vec<String> = (0..held.len())
        .filter(|&f| f != fx && f != fy)
        .map(|f| {
            format!(
                "{} = {}",
                fit.experiment.factor_names[f],
                fmt_sig(axis_value(fit, f, held[f]))
            )
        })
        .collect();
    (!parts.is_empty()).then(|| format!("held: {}", parts.join(", ")))
}

/// Filled contour plot of the response over factors `fx`, `fy`, the other factors at
/// `marks.held`: a colour bar with the response's scale, labelled contour lines at round
/// levels, the design runs lying in the plane, and the target contour and optimum when given.
pub fn contour_plot(
    fit: &Fit,
    labels: &Labels,
    fx: usize,
    fy: usize,
    marks: &ContourMarks,
) -> Result<String, String> {
    const N: usize = 41;
    let range = marks.range;
    let held = &marks.held;
    let g = grid(fit, fx, fy, held, range, N);
    let (lo, hi) = min_max(g.values.iter().flatten().copied());
    let ax = |c: f64| axis_value(fit, fx, c);
    let ay = |c: f64| axis_value(fit, fy, c);
    let (x0, x1) = (ax(range.0), ax(range.1));
    let (y0, y1) = (ay(range.0), ay(range.1));
    let runs: Vec<(f64, f64)> = in_plane(fit, fx, fy, held)
        .iter()
        .filter(|x| {
            [x[fx], x[fy]]
                .iter()
                .all(|v| *v >= range.0 - 1e-9 && *v <= range.1 + 1e-9)
        })
        .map(|x| (ax(x[fx]), ay(x[fy])))
        .collect();
    let mut avoid: Vec<(f64, f64)> = in_plane(fit, fx, fy, held)
        .iter()
        .map(|x| (x[fx], x[fy]))
        .collect();
    if let Some((opt, _)) = &marks.optimum {
        avoid.push((opt[fx], opt[fy]));
    }
    let span = (hi - lo).max(1e-300);
    let levels = nice_ticks(lo, hi, 6);
    let note = held_note(fit, fx, fy, held);
    render(|root| {
        let mut items = vec![(Mark::Dot(BLACK), "design runs".to_string())];
        if let Some((_, label)) = &marks.optimum {
            items.push((Mark::Cross(BLACK), label.clone()));
        }
        if let Some((level, label)) = &marks.target {
            if *level >= lo && *level <= hi {
                items.push((Mark::Dashed(BLACK, 3), label.clone()));
            }
        }
        let mut used = legend_row(root, &items, 16, 26, SIZE.0 as i32 - 32)?;
        if let Some(n) = &note {
            root.draw(&Text::new(
                n.clone(),
                (16, 26 + used),
                (FONT, TEXT)
                    .into_font()
                    .color(&BLACK)
                    .pos(Pos::new(HPos::Left, VPos::Center)),
            ))
            .map_err(err)?;
            used += (crate::plots::svg_px(TEXT) * 1.45) as i32;
        }
        let (left, _) = root.split_horizontally(SIZE.0 - BAR_AREA);
        let mut chart = ChartBuilder::on(&left)
            .margin(14)
            .margin_top(used + TOP_TICK_ROOM)
            .margin_right(8)
            .x_label_area_size(66)
            .y_label_area_size(92)
            .build_cartesian_2d(x0..x1, y0..y1)
            .map_err(err)?;
        draw_mesh(&mut chart, &labels.factors[fx], &labels.factors[fy])?;
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
        let to_actual = |l: &Vec<(f64, f64)>| -> Vec<(f64, f64)> {
            l.iter().map(|p| (ax(p.0), ay(p.1))).collect()
        };
        let (_, px_y) = chart.plotting_area().get_pixel_range();
        for &level in &levels {
            let lines = chain(&contour_segments(&g, level));
            for l in &lines {
                chart
                    .draw_series(LineSeries::new(
                        to_actual(l),
                        BLACK.mix(0.7).stroke_width(1),
                    ))
                    .map_err(err)?;
            }
            // The label where the line is farthest from the plot's edges, the runs and the
            // optimum.
            let best = lines
                .iter()
                .flat_map(|l| l.iter())
                .map(|p| {
                    let w = range.1 - range.0;
                    let (u, v) = ((p.0 - range.0) / w, (p.1 - range.0) / w);
                    let edge = u.min(1.0 - u).min(v.min(1.0 - v));
                    let near = avoid
                        .iter()
                        .map(|q| ((p.0 - q.0).hypot(p.1 - q.1)) / w)
                        .fold(f64::MAX, f64::min);
                    (p, edge.min(near))
                })
                .max_by(|a, b| a.1.total_cmp(&b.1));
            if let Some((p, _)) = best {
                let (px, py) = chart.backend_coord(&(ax(p.0), ay(p.1)));
                let text = tick(&level);
                let w = text_width(&text, TEXT - 3);
                left.draw(&Rectangle::new(
                    [(px - w / 2 - 3, py - 10), (px + w / 2 + 3, py + 10)],
                    WHITE.mix(0.8).filled(),
                ))
                .map_err(err)?;
                left.draw(&Text::new(
                    text,
                    (px, py),
                    (FONT, TEXT - 3)
                        .into_font()
                        .color(&BLACK)
                        .pos(Pos::new(HPos::Center, VPos::Center)),
                ))
                .map_err(err)?;
            }
        }
        if let Some((level, _)) = &marks.target {
            for l in chain(&contour_segments(&g, *level)) {
                let l = to_actual(&l);
                chart
                    .draw_series(LineSeries::new(l.clone(), WHITE.stroke_width(6)))
                    .map_err(err)?;
                chart
                    .draw_series(DashedLineSeries::new(l, 10, 7, BLACK.stroke_width(3)))
                    .map_err(err)?;
            }
        }
        chart
            .draw_series(runs.iter().map(|&p| Circle::new(p, 8, WHITE.filled())))
            .map_err(err)?;
        chart
            .draw_series(runs.iter().map(|&p| Circle::new(p, 6, BLACK.filled())))
            .map_err(err)?;
        if let Some((opt, _)) = &marks.optimum {
            let p = (ax(opt[fx]), ay(opt[fy]));
            chart
                .draw_series([Cross::new(p, 11, WHITE.stroke_width(7))])
                .map_err(err)?;
            chart
                .draw_series([Cross::new(p, 11, BLACK.stroke_width(3))])
                .map_err(err)?;
        }
        colour_bar(
            root,
            (px_y.start, px_y.end),
            (lo, hi),
            &levels,
            &labels.response,
        )?;
        Ok(())
    })
}

/// Space between a filled plot and the legend or note above it. The axes end on round values,
/// so the top tick label sits on the plot's top edge and reaches half its height above it.
const TOP_TICK_ROOM: i32 = 22;

/// Width kept at the right of a filled plot for its colour bar, tick labels and title.
const BAR_AREA: u32 = 128;

/// The colour bar of [`colour_map`] over `lo..hi` at the right of `root`, spanning the pixel
/// rows `top..bottom` (the plot's height), with a tick and label at each of `ticks` and
/// `title` (the mapped quantity with its unit) along its outer side.
fn colour_bar(
    root: &DrawingArea<SVGBackend, Shift>,
    (top, bottom): (i32, i32),
    (lo, hi): (f64, f64),
    ticks: &[f64],
    title: &str,
) -> Result<(), String> {
    let bx = (SIZE.0 - BAR_AREA) as i32 + 12;
    let span = (hi - lo).max(1e-300);
    const SLICES: i32 = 96;
    for s in 0..SLICES {
        let ya = bottom - (bottom - top) * (s + 1) / SLICES;
        let yb = bottom - (bottom - top) * s / SLICES;
        root.draw(&Rectangle::new(
            [(bx, ya), (bx + 22, yb + 1)],
            colour_map((s as f64 + 0.5) / SLICES as f64).filled(),
        ))
        .map_err(err)?;
    }
    root.draw(&Rectangle::new(
        [(bx, top), (bx + 22, bottom)],
        BLACK.stroke_width(1),
    ))
    .map_err(err)?;
    for &level in ticks {
        let y = bottom - ((level - lo) / span * (bottom - top) as f64).round() as i32;
        root.draw(&PathElement::new(vec![(bx + 22, y), (bx + 28, y)], BLACK))
            .map_err(err)?;
        root.draw(&Text::new(
            tick(&level),
            (bx + 31, y),
            (FONT, TEXT)
                .into_font()
                .color(&BLACK)
                .pos(Pos::new(HPos::Left, VPos::Center)),
        ))
        .map_err(err)?;
    }
    root.draw(&Text::new(
        title.to_string(),
        (SIZE.0 as i32 - 14, (top + bottom) / 2),
        (FONT, DESC)
            .into_font()
            .transform(FontTransform::Rotate270)
            .color(&BLACK)
            .pos(Pos::new(HPos::Center, VPos::Center)),
    ))
    .map_err(err)?;
    Ok(())
}

/// A filled map for [`map_with_colour_bar`]: values on a regular grid of cells over two axes,
/// with optional marks. Fields left out (`..Default::default()`) draw nothing.
#[derive(Clone, Debug, Default)]
pub struct FilledMap<'a> {
    /// Axis titles, each with its unit.
    pub x_desc: &'a str,
    pub y_desc: &'a str,
    /// The ranges the cells cover.
    pub x_range: (f64, f64),
    pub y_range: (f64, f64),
    /// `values[i][j]`: the cell i of the columns along x, j of the rows along y (bottom up);
    /// every column as long. Non-finite cells are left white.
    pub values: &'a [Vec<f64>],
    /// The colour bar's title: the mapped quantity with its unit, e.g. "predicted angle of
    /// repose (deg)".
    pub quantity: &'a str,
    /// Points drawn as black dots (the runs), with their legend text ("" for no legend entry).
    pub points: &'a [(f64, f64)],
    pub points_label: &'a str,
    /// A point ringed in white (the chosen or best point), with its legend text.
    pub chosen: Option<((f64, f64), &'a str)>,
}

/// A filled map of `map.values` in the colours of [`colour_map`] (blue low, red high) with a
/// colour bar giving the scale, its ticks and the quantity with its unit, as the contour plot
/// has: a map without one cannot be read. Points and the chosen point are marked, with a legend
/// row above the plot when they have labels.
pub fn map_with_colour_bar(map: &FilledMap) -> Result<String, String> {
    let nx = map.values.len();
    let ny = map.values.first().map_or(0, Vec::len);
    if nx == 0 || ny == 0 || map.values.iter().any(|c| c.len() != ny) {
        return Err("plot: a map needs a rectangular grid of values".into());
    }
    let ((x0, x1), (y0, y1)) = (map.x_range, map.y_range);
    if !(x0.is_finite() && x1.is_finite() && x0 < x1 && y0.is_finite() && y1.is_finite() && y0 < y1)
    {
        return Err("plot: a map needs increasing finite ranges".into());
    }
    let (lo, hi) = min_max(map.values.iter().flatten().copied());
    if lo > hi {
        return Err("plot: no finite value to map".into());
    }
    let ticks = if hi - lo > 1e-12 * lo.abs().max(hi.abs()).max(1e-300) {
        nice_ticks(lo, hi, 6)
    } else {
        vec![lo]
    };
    let (cw, ch) = ((x1 - x0) / nx as f64, (y1 - y0) / ny as f64);
    render(|root| {
        let mut items = Vec::new();
        if !map.points.is_empty() && !map.points_label.is_empty() {
            items.push((Mark::Dot(BLACK), map.points_label.to_string()));
        }
        if let Some((_, label)) = map.chosen.filter(|c| !c.1.is_empty()) {
            items.push((Mark::Ring(BLACK), label.to_string()));
        }
        let used = if items.is_empty() {
            8
        } else {
            legend_row(root, &items, 16, 26, SIZE.0 as i32 - 32)?
        };
        let (left, _) = root.split_horizontally(SIZE.0 - BAR_AREA);
        let mut chart = ChartBuilder::on(&left)
            .margin(14)
            .margin_top(used + TOP_TICK_ROOM)
            .margin_right(8)
            .x_label_area_size(66)
            .y_label_area_size(92)
            .build_cartesian_2d(x0..x1, y0..y1)
            .map_err(err)?;
        draw_mesh(&mut chart, map.x_desc, map.y_desc)?;
        let span = (hi - lo).max(1e-300);
        chart
            .draw_series((0..nx).flat_map(|i| {
                (0..ny).filter_map(move |j| {
                    let v = map.values[i][j];
                    let (xa, ya) = (x0 + i as f64 * cw, y0 + j as f64 * ch);
                    v.is_finite().then(|| {
                        Rectangle::new(
                            [(xa, ya), (xa + cw, ya + ch)],
                            colour_map((v - lo) / span).filled(),
                        )
                    })
                })
            }))
            .map_err(err)?;
        let inside = |p: &&(f64, f64)| p.0.is_finite() && p.1.is_finite();
        chart
            .draw_series(
                map.points
                    .iter()
                    .filter(inside)
                    .map(|&p| Circle::new(p, 6, WHITE.filled())),
            )
            .map_err(err)?;
        chart
            .draw_series(
                map.points
                    .iter()
                    .filter(inside)
                    .map(|&p| Circle::new(p, 4, BLACK.filled())),
            )
            .map_err(err)?;
        if let Some((c, _)) = map.chosen {
            chart
                .draw_series([Circle::new(c, 10, BLACK.stroke_width(5))])
                .map_err(err)?;
            chart
                .draw_series([Circle::new(c, 10, WHITE.stroke_width(3))])
                .map_err(err)?;
        }
        let (_, py) = chart.plotting_area().get_pixel_range();
        colour_bar(root, (py.start, py.end), (lo, hi), &ticks, map.quantity)
    })
}

/// 3-D response surface over factors `fx`, `fy`, the others at `marks.held`, over `marks.range`;
/// the axes named at their middles, the optimum marked when given.
pub fn surface_plot(
    fit: &Fit,
    labels: &Labels,
    fx: usize,
    fy: usize,
    marks: &ContourMarks,
) -> Result<String, String> {
    const N: usize = 25;
    let g = grid(fit, fx, fy, &marks.held, marks.range, N);
    let (lo, hi) = min_max(g.values.iter().flatten().copied());
    let span = (hi - lo).max(1e-300);
    let xs: Vec<f64> = g.x.iter().map(|&c| axis_value(fit, fx, c)).collect();
    let ys: Vec<f64> = g.y.iter().map(|&c| axis_value(fit, fy, c)).collect();
    let value_at = |x: f64, y: f64| -> f64 {
        let i = xs.iter().position(|v| *v == x).unwrap_or(0);
        let j = ys.iter().position(|v| *v == y).unwrap_or(0);
        g.values[i][j]
    };
    let vr = padded(lo, hi);
    render(|root| {
        let mut chart = ChartBuilder::on(root)
            .margin(30)
            .margin_bottom(90)
            .margin_top(40)
            .build_cartesian_3d(xs[0]..xs[N - 1], vr.clone(), ys[0]..ys[N - 1])
            .map_err(err)?;
        chart.with_projection(|mut p| {
            // A low view: the height reads off the surface instead of being folded into depth.
            p.pitch = 0.25;
            p.yaw = 0.6;
            p.scale = 0.9;
            p.into_matrix()
        });
        chart
            .configure_axes()
            .light_grid_style(BLACK.mix(0.08))
            .max_light_lines(3)
            .x_labels(4)
            .y_labels(5)
            .z_labels(4)
            .x_formatter(&tick)
            .y_formatter(&tick)
            .z_formatter(&tick)
            .label_style((FONT, TEXT))
            .draw()
            .map_err(err)?;
        let style = |v: &f64| colour_map((v - lo) / span).mix(0.95).filled();
        chart
            .draw_series(
                SurfaceSeries::xoz(xs.iter().copied(), ys.iter().copied(), value_at)
                    .style_func(&style),
            )
            .map_err(err)?;
        if let Some((opt, _)) = &marks.optimum {
            let p = (
                axis_value(fit, fx, opt[fx]),
                fit.predict_coded(opt),
                axis_value(fit, fy, opt[fy]),
            );
            let px = chart.plotting_area().map_coordinate(&p);
            root.draw(&Cross::new(px, 11, WHITE.stroke_width(7)))
                .map_err(err)?;
            root.draw(&Cross::new(px, 11, BLACK.stroke_width(3)))
                .map_err(err)?;
        }
        // Axis names beyond the tick labels of the front edges, and above the vertical axis.
        let area = chart.plotting_area();
        let (xa, xb) = (xs[0], xs[N - 1]);
        let (za, zb) = (ys[0], ys[N - 1]);
        let front = |a: (i32, i32), b: (i32, i32)| if a.1 >= b.1 { a } else { b };
        let xm = 0.5 * (xa + xb);
        let zm = 0.5 * (za + zb);
        let px = front(
            area.map_coordinate(&(xm, vr.start, za)),
            area.map_coordinate(&(xm, vr.start, zb)),
        );
        let pz = front(
            area.map_coordinate(&(xa, vr.start, zm)),
            area.map_coordinate(&(xb, vr.start, zm)),
        );
        // Each name on the outer side of its edge: away from the other edge's midpoint.
        for (p, other, text) in [(px, pz, &labels.factors[fx]), (pz, px, &labels.factors[fy])] {
            let (h, dx) = if p.0 <= other.0 {
                (HPos::Right, -24)
            } else {
                (HPos::Left, 24)
            };
            root.draw(&Text::new(
                text.clone(),
                (p.0 + dx, p.1 + 44),
                (FONT, DESC)
                    .into_font()
                    .color(&BLACK)
                    .pos(Pos::new(h, VPos::Top)),
            ))
            .map_err(err)?;
        }
        let pv = area.map_coordinate(&(xa, vr.end, za));
        root.draw(&Text::new(
            labels.response.clone(),
            (pv.0.max(14), (pv.1 - 12).max(4)),
            (FONT, DESC)
                .into_font()
                .color(&BLACK)
                .pos(Pos::new(HPos::Left, VPos::Bottom)),
        ))
        .map_err(err)?;
        Ok(())
    })
}

/// Perturbation plot: each factor moved alone from `reference` (coded) over -span..span, the
/// others held there; a steep trace is a factor the response is sensitive to, a flat one a
/// factor it ignores. Each trace is labelled with its factor's letter.
pub fn perturbation_plot(
    fit: &Fit,
    labels: &Labels,
    reference: &[f64],
    span: f64,
) -> Result<String, String> {
    let traces = crate::diagnostics::perturbation(fit, reference, span, 41);
    let (lo, hi) = min_max(traces.iter().flat_map(|t| t.points.iter().map(|p| p.1)));
    render(|root| {
        let items: Vec<(Mark, String)> = traces
            .iter()
            .map(|t| {
                (
                    Mark::Line(SERIES[t.factor % SERIES.len()], 3),
                    format!("{}: {}", labels.letters[t.factor], labels.factors[t.factor]),
                )
            })
            .collect();
        let used = legend_row(root, &items, 16, 26, SIZE.0 as i32 - 32)?;
        let mut chart =
            crate::plots::chart(root, -span..span * 1.12, padded(lo, hi), (used + 10) as u32)?;
        draw_mesh(
            &mut chart,
            "deviation from the reference point (coded)",
            &labels.response,
        )?;
        for t in &traces {
            let c = SERIES[t.factor % SERIES.len()];
            chart
                .draw_series(LineSeries::new(t.points.clone(), c.stroke_width(3)))
                .map_err(err)?;
            if let Some(&(x, y)) = t.points.last() {
                chart
                    .draw_series([Text::new(
                        labels.letters[t.factor].clone(),
                        (x + 0.03 * span, y),
                        (FONT, DESC)
                            .into_font()
                            .color(&c)
                            .pos(Pos::new(HPos::Left, VPos::Center)),
                    )])
                    .map_err(err)?;
            }
        }
        Ok(())
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_are_round_and_inside() {
        assert_eq!(nice_ticks(13.2, 21.7, 6), vec![14.0, 16.0, 18.0, 20.0]);
        assert_eq!(nice_ticks(0.0, 1.0, 4), vec![0.0, 0.25, 0.5, 0.75, 1.0]);
        assert_eq!(nice_ticks(0.31, 0.62, 6), vec![0.4, 0.5, 0.6]);
        assert_eq!(
            nice_ticks(0.31, 0.62, 10),
            vec![0.35, 0.4, 0.45, 0.5, 0.55, 0.6]
        );
        assert!(nice_ticks(1.0, 1.0, 5).is_empty());
    }

    #[test]
    fn segments_chain_into_lines() {
        let segs = [
            [(1.0, 0.0), (2.0, 0.0)],
            [(0.0, 0.0), (1.0, 0.0)],
            [(5.0, 5.0), (6.0, 6.0)],
            [(2.0, 0.0), (3.0, 1.0)],
        ];
        let mut lines = chain(&segs);
        lines.sort_by_key(|l| l.len());
        assert_eq!(lines[0].len(), 2);
        assert_eq!(lines[1].len(), 4);
        let ends = (lines[1][0], lines[1][3]);
        assert!(ends == ((0.0, 0.0), (3.0, 1.0)) || ends == ((3.0, 1.0), (0.0, 0.0)));
    }
}
