//! The report's figures: each is shown in the page (inline SVG, numbered, captioned) and written
//! to `report/figures/` as its own SVG and PNG ([`doe::raster`], twice the SVG's size). Here
//! too the figures of the study's own making: the steepest path, the validation against the
//! lab and the model's prediction interval, and the validation heaps at one scale with a scale
//! bar and their fitted flank lines.

use std::fmt::Write;
use std::path::Path;

use base64::Engine;
use doe::diagnostics::Interval;
use doe::plots::{self, legend_row, svg_px, tick, Mark, FONT, SIZE, TEXT};
use plotters::prelude::*;

use crate::record::StageResult;
use crate::spec::Study;
use crate::text::sig;
use crate::text::{esc, FigureSink};

/// The PNG's pixels per SVG unit: a 640-unit figure becomes 1280 pixels wide, 300 dpi at 108 mm.
pub const PNG_SCALE: f32 = 2.0;

/// The figures of a report, in order.
#[derive(Default)]
pub(crate) struct Figures {
    /// (file stem, SVG) of each figure, numbered from 1.
    pub list: Vec<(String, String)>,
}

impl FigureSink for Figures {
    fn row(&mut self, h: &mut String, items: Vec<(String, Result<String, String>, String)>) {
        Figures::row(self, h, items)
    }
}

impl Figures {
    /// Numbers a figure, names its files, and writes it with its caption into `h`.
    fn figure(&mut self, h: &mut String, stem: &str, svg: String, caption: &str) {
        let n = self.list.len() + 1;
        let file = format!("fig{n:02}-{stem}");
        write!(
            h,
            "<figure id=\"{file}\"><div class=\"svg\">{svg}</div><figcaption><b>Figure {n}.</b> {caption} <span class=\"files\">(<a href=\"figures/{file}.svg\">SVG</a>, <a href=\"figures/{file}.png\">PNG</a>)</span></figcaption></figure>"
        )
        .unwrap();
        self.list.push((file, svg));
    }

    /// A row of figures (two side by side where the page is wide enough); a figure that could
    /// not be drawn is said in a note.
    pub fn row(&mut self, h: &mut String, items: Vec<(String, Result<String, String>, String)>) {
        if items.is_empty() {
            return;
        }
        h.push_str("<div class=\"plots\">");
        let mut missing = Vec::new();
        for (stem, svg, caption) in items {
            match svg {
                Ok(svg) => self.figure(h, &stem, svg, &caption),
                Err(e) => missing.push(format!("{caption}: {e}")),
            }
        }
        h.push_str("</div>");
        for m in missing {
            write!(h, "<p class=\"note\">No figure: {}</p>", esc(&m)).unwrap();
        }
    }

    /// Writes every figure as SVG and PNG into `dir`, removing figures of an earlier report.
    pub fn write(&self, dir: &Path) -> Result<(), String> {
        std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
        let keep: Vec<String> = self
            .list
            .iter()
            .flat_map(|(f, _)| [format!("{f}.svg"), format!("{f}.png")])
            .collect();
        if let Ok(entries) = std::fs::read_dir(dir) {
            for e in entries.flatten() {
                let name = e.file_name().to_string_lossy().into_owned();
                let ours =
                    name.starts_with("fig") && (name.ends_with(".svg") || name.ends_with(".png"));
                if ours && !keep.contains(&name) {
                    let _ = std::fs::remove_file(e.path());
                }
            }
        }
        for (file, svg) in &self.list {
            let put = |name: String, bytes: &[u8]| -> Result<(), String> {
                let p = dir.join(&name);
                let tmp = dir.join(format!(".{name}.tmp"));
                std::fs::write(&tmp, bytes).map_err(|e| format!("{}: {e}", tmp.display()))?;
                std::fs::rename(&tmp, &p).map_err(|e| format!("{}: {e}", p.display()))
            };
            put(format!("{file}.svg"), svg.as_bytes())?;
            let png =
                doe::raster::svg_to_png(svg, PNG_SCALE).map_err(|e| format!("{file}: {e}"))?;
            put(format!("{file}.png"), &png)?;
        }
        Ok(())
    }
}

/// The response's axis title: its name with the target's unit.
pub(crate) fn response_label(study: &Study) -> String {
    plots::with_unit(&study.target.response, &study.target.unit)
}

/// "mean ± sd": the standard deviation to two significant digits and the mean to the same
/// decimal place.
pub(crate) fn mean_sd(mean: f64, sd: f64) -> String {
    if !(sd.is_finite() && sd > 0.0) {
        return format!("{} ± 0", sig(mean));
    }
    let decimals = (1 - sd.abs().log10().floor() as i32).max(0) as usize;
    format!("{mean:.decimals$} ± {sd:.decimals$}")
}

/// Response along the steepest path with the lab value, the best step ringed.
pub(crate) fn steepest_plot(study: &Study, st: &StageResult) -> Result<String, String> {
    let pts: Vec<(f64, f64)> = st
        .runs
        .iter()
        .zip(&st.records)
        .filter_map(|(s, r)| r.as_ref()?.response.map(|y| ((s.index + 1) as f64, y)))
        .collect();
    if pts.is_empty() {
        return Err("no finished runs".into());
    }
    let target = study.target.value;
    let (lo, hi) = pts
        .iter()
        .map(|p| p.1)
        .chain([target])
        .fold((f64::MAX, f64::MIN), |(a, b), y| (a.min(y), b.max(y)));
    let n = st.runs.len() as f64;
    let red = RGBColor(200, 30, 30);
    let blue = plots::NEGATIVE;
    let green = RGBColor(30, 150, 60);
    plots::render(|root| {
        let mut items = vec![
            (Mark::Line(blue, 3), "simulated".to_string()),
            (
                Mark::Dashed(red, 3),
                format!(
                    "lab value {}",
                    plots::with_unit(&sig(target), &study.target.unit).replace(['(', ')'], "")
                ),
            ),
        ];
        if st.best_step().is_some() {
            items.push((Mark::Ring(green), "nearest the lab value".to_string()));
        }
        let used = legend_row(root, &items, 16, 26, SIZE.0 as i32 - 32)?;
        let mut chart = plots::chart(
            root,
            0.5..n + 0.5,
            plots::padded(lo, hi),
            (used + 10) as u32,
        )?;
        chart
            .configure_mesh()
            .x_desc("step along the path")
            .y_desc(response_label(study))
            .x_labels(st.runs.len() + 2)
            .y_labels(6)
            .x_label_formatter(&|x: &f64| {
                if (x - x.round()).abs() < 1e-9 && *x >= 1.0 {
                    format!("{}", x.round() as i64)
                } else {
                    String::new()
                }
            })
            .y_label_formatter(&tick)
            .label_style((FONT, TEXT))
            .axis_desc_style((FONT, plots::DESC))
            .light_line_style(TRANSPARENT)
            .bold_line_style(BLACK.mix(0.1))
            .draw()
            .map_err(plots::err)?;
        chart
            .draw_series(DashedLineSeries::new(
                [(0.5, target), (n + 0.5, target)],
                10,
                7,
                red.stroke_width(3),
            ))
            .map_err(plots::err)?;
        chart
            .draw_series(LineSeries::new(pts.clone(), blue.stroke_width(3)))
            .map_err(plots::err)?;
        chart
            .draw_series(pts.iter().map(|p| Circle::new(*p, 6, blue.filled())))
            .map_err(plots::err)?;
        if let Some(b) = st.best_step() {
            if let Some(p) = pts.iter().find(|p| p.0 == (b + 1) as f64) {
                chart
                    .draw_series([Circle::new(*p, 12, green.stroke_width(3))])
                    .map_err(plots::err)?;
            }
        }
        Ok(())
    })
}

/// Each validation run's spread over the flanks it measured (SD, count), when the test
/// reports it (the angle of repose).
pub(crate) fn flank_spread(outputs: &serde_json::Value) -> Option<(f64, usize)> {
    let sd = outputs["angle_std_deg"].as_f64()?;
    let n = outputs["flank_angles_deg"]
        .as_array()
        .map_or(0, |a| a.len());
    Some((sd, n))
}

/// Validation runs against the lab replicates, with the runs' mean and SD, each run's flank
/// spread, and the model's prediction interval at the optimum.
pub(crate) fn validation_plot(
    study: &Study,
    st: &StageResult,
    interval: Option<Interval>,
) -> Result<String, String> {
    // With several candidates, the chosen solution's runs (those at the calibrated point).
    let sims: Vec<(f64, Option<(f64, usize)>)> = st
        .runs
        .iter()
        .zip(&st.records)
        .filter(|(s, _)| st.calibrated.as_ref().is_none_or(|c| &s.values == c))
        .filter_map(|(_, r)| {
            let r = r.as_ref()?;
            Some((r.response?, flank_spread(&r.outputs)))
        })
        .collect();
    if sims.is_empty() {
        return Err("no finished runs".into());
    }
    let t = &study.target;
    let labs: Vec<f64> = if t.replicates.is_empty() {
        vec![t.value]
    } else {
        t.replicates.clone()
    };
    let sd = |v: &[f64]| -> Option<f64> {
        let n = v.len();
        (n >= 2).then(|| {
            let m = v.iter().sum::<f64>() / n as f64;
            (v.iter().map(|y| (y - m).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt()
        })
    };
    let ys: Vec<f64> = sims.iter().map(|s| s.0).collect();
    let mean = ys.iter().sum::<f64>() / ys.len() as f64;
    let lab_mean = labs.iter().sum::<f64>() / labs.len() as f64;
    let (lab_sd, sim_sd) = (sd(&labs), sd(&ys));
    let mut extent: Vec<f64> = labs.iter().chain(&ys).copied().collect();
    for (y, s) in &sims {
        if let Some((s, _)) = s {
            extent.extend([y - s, y + s]);
        }
    }
    if let Some(i) = interval {
        extent.extend([i.low, i.high]);
    }
    let (lo, hi) = plots::min_max(extent.into_iter());
    let red = RGBColor(200, 30, 30);
    let blue = plots::NEGATIVE;
    let green = RGBColor(30, 150, 60);
    let columns = if interval.is_some() { 3.0 } else { 2.0 };
    plots::render(|root| {
        let flanks = sims.iter().find_map(|s| s.1).map(|s| s.1);
        let mut items = vec![
            (Mark::Dot(red), "lab replicate".to_string()),
            (
                Mark::Dot(blue),
                match flanks {
                    Some(n) => format!("validation run (whisker: SD over its {n} flanks)"),
                    None => "validation run".to_string(),
                },
            ),
            (
                Mark::Line(BLACK, 4),
                "mean (whisker: SD over the column)".to_string(),
            ),
        ];
        if interval.is_some() {
            items.push((
                Mark::Dot(green),
                "model at the optimum (whisker: 95 % prediction interval)".to_string(),
            ));
        }
        let used = legend_row(root, &items, 16, 26, SIZE.0 as i32 - 32)?;
        let mut chart = plots::chart(
            root,
            0.4..columns + 0.6,
            plots::padded(lo, hi),
            (used + 10) as u32,
        )?;
        chart
            .configure_mesh()
            .disable_x_mesh()
            .x_labels(2 * columns as usize + 2)
            .y_labels(6)
            .x_label_formatter(&|x: &f64| match x.round() as i64 {
                1 if (x - 1.0).abs() < 0.01 => "lab".into(),
                2 if (x - 2.0).abs() < 0.01 => "simulation".into(),
                3 if (x - 3.0).abs() < 0.01 => "model".into(),
                _ => String::new(),
            })
            .y_label_formatter(&tick)
            .y_desc(response_label(study))
            .label_style((FONT, TEXT))
            .axis_desc_style((FONT, plots::DESC))
            .light_line_style(TRANSPARENT)
            .bold_line_style(BLACK.mix(0.1))
            .draw()
            .map_err(plots::err)?;
        let whisker = |chart: &mut plots::Chart, x: f64, a: f64, b: f64, c: RGBColor, w: u32| {
            chart
                .draw_series(LineSeries::new([(x, a), (x, b)], c.stroke_width(w)))
                .map_err(plots::err)?;
            for y in [a, b] {
                chart
                    .draw_series(LineSeries::new(
                        [(x - 0.04, y), (x + 0.04, y)],
                        c.stroke_width(w),
                    ))
                    .map_err(plots::err)?;
            }
            Ok::<(), String>(())
        };
        let spread = |n: usize, i: usize| 0.75 + 0.35 * (i as f64 + 0.5) / n as f64;
        for (i, y) in labs.iter().enumerate() {
            chart
                .draw_series([Circle::new((spread(labs.len(), i), *y), 6, red.filled())])
                .map_err(plots::err)?;
        }
        for (i, (y, s)) in sims.iter().enumerate() {
            let x = 1.0 + spread(sims.len(), i);
            if let Some((s, _)) = s {
                whisker(&mut chart, x, y - s, y + s, RGBColor(120, 160, 225), 2)?;
            }
            chart
                .draw_series([Circle::new((x, *y), 6, blue.filled())])
                .map_err(plots::err)?;
        }
        for (x, m, s) in [(1.25, lab_mean, lab_sd), (2.25, mean, sim_sd)] {
            chart
                .draw_series(LineSeries::new(
                    [(x - 0.07, m), (x + 0.07, m)],
                    BLACK.stroke_width(4),
                ))
                .map_err(plots::err)?;
            if let Some(s) = s {
                whisker(&mut chart, x, m - s, m + s, BLACK, 2)?;
            }
        }
        if let Some(i) = interval {
            whisker(&mut chart, 3.0, i.low, i.high, green, 3)?;
            chart
                .draw_series([Circle::new((3.0, i.predicted), 7, green.filled())])
                .map_err(plots::err)?;
        }
        Ok(())
    })
}

/// One validation run's heap picture and its `heap.json`.
pub(crate) struct Heap {
    pub label: String,
    pub png: image::RgbImage,
    pub meta: serde_json::Value,
}

impl Heap {
    /// The heap picture a run wrote (in its folder or its test's), with its `heap.json`.
    pub fn read(study: &Study, out_dir: &str, label: String) -> Option<Heap> {
        let run = Path::new(out_dir);
        let dirs =
            std::iter::once(run.to_path_buf()).chain(study.tests.iter().map(|t| run.join(&t.name)));
        for d in dirs {
            let (Ok(meta), Ok(png)) = (
                std::fs::read(d.join("heap.json")),
                std::fs::read(d.join("heap.png")),
            ) else {
                continue;
            };
            let meta: serde_json::Value = serde_json::from_slice(&meta).ok()?;
            let png = image::load_from_memory_with_format(&png, image::ImageFormat::Png)
                .ok()?
                .to_rgb8();
            return Some(Heap { label, png, meta });
        }
        None
    }

    fn num(&self, key: &str) -> f64 {
        self.meta[key].as_f64().unwrap_or(f64::NAN)
    }
}

/// A round length for a scale bar about a fifth of `width` (m).
fn scale_bar_length(width: f64) -> f64 {
    let raw = width / 5.0;
    let p = 10f64.powf(raw.log10().floor());
    [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|m| m * p)
        .rfind(|l| *l <= raw)
        .unwrap_or(p)
}

/// "20 mm", "1.5 m".
fn length_text(m: f64) -> String {
    if m < 1.0 {
        format!("{} mm", tick(&(m * 1e3)))
    } else {
        format!("{} m", tick(&m))
    }
}

/// The validation heaps, one panel each, cropped to one frame around the axis so that every
/// panel has the same size and scale; a scale bar, and the flank lines fitted in the vertical
/// plane across the view drawn over each.
pub(crate) fn heaps_figure(heaps: &[Heap]) -> Result<String, String> {
    if heaps.is_empty() {
        return Err("no heap pictures with heap.json".into());
    }
    let reach = heaps
        .iter()
        .flat_map(|h| {
            let flank_end = h.meta["flanks"]
                .as_array()
                .map(|a| {
                    a.iter()
                        .filter_map(|f| f["fitted_to_m"].as_f64())
                        .fold(0.0, f64::max)
                })
                .unwrap_or(0.0);
            [1.25 * h.num("heap_radius_m"), 1.15 * flank_end]
        })
        .filter(|v| v.is_finite())
        .fold(0.0f64, f64::max);
    let top = heaps
        .iter()
        .map(|h| h.num("heap_height_m"))
        .filter(|v| v.is_finite())
        .fold(0.0f64, f64::max)
        * 1.2;
    if !(reach > 0.0 && top > 0.0) {
        return Err("heap.json without the heap's size".into());
    }
    let bottom = -0.1 * top;
    let (margin, width) = (12.0, SIZE.0 as f64 - 24.0);
    let k = width / (2.0 * reach);
    let panel_h = ((top - bottom) * k).round();
    let text = svg_px(TEXT) as f64;
    let line = (text * 1.5).round();
    let legend_h = 2.0 * line;
    let height = legend_h + heaps.len() as f64 * (line + panel_h + 8.0) + 2.0 * line;
    let mut svg = String::new();
    write!(
        svg,
        "<svg width=\"{w}\" height=\"{height}\" viewBox=\"0 0 {w} {height}\" xmlns=\"http://www.w3.org/2000/svg\">\n<rect x=\"0\" y=\"0\" width=\"{w}\" height=\"{height}\" fill=\"#FFFFFF\" stroke=\"none\"/>\n",
        w = SIZE.0
    )
    .unwrap();
    let t = |svg: &mut String, x: f64, y: f64, s: &str, anchor: &str| {
        writeln!(
            svg,
            "<text x=\"{x:.1}\" y=\"{y:.1}\" dy=\"0.5ex\" text-anchor=\"{anchor}\" font-family=\"{FONT}\" font-size=\"{text:.2}\" fill=\"#000000\">{}</text>",
            esc(s)
        )
        .unwrap();
    };
    let blue = "#0060C8";
    writeln!(svg, "<line x1=\"{:.1}\" y1=\"{:.1}\" x2=\"{:.1}\" y2=\"{:.1}\" stroke=\"{blue}\" stroke-width=\"4\"/>", margin + 4.0, line * 0.7, margin + 30.0, line * 0.7).unwrap();
    t(
        &mut svg,
        margin + 38.0,
        line * 0.7,
        "flank lines fitted in the vertical plane across the view",
        "start",
    );
    t(
        &mut svg,
        margin + 38.0,
        line * 1.7,
        "(the angle is the mean over every plane's flanks)",
        "start",
    );
    let mut y = legend_h;
    for h in heaps {
        t(&mut svg, margin, y + 0.5 * line, &h.label, "start");
        y += line;
        // Crop the picture to the frame (white where the frame reaches beyond it).
        let m = h.num("m_per_px");
        let (x_left, z_top) = (h.num("x_left_m"), h.num("z_top_m"));
        if !(m > 0.0 && x_left.is_finite() && z_top.is_finite()) {
            return Err("heap.json without the picture's scale".into());
        }
        let (cw, ch) = (
            ((2.0 * reach) / m).round() as u32,
            ((top - bottom) / m).round() as u32,
        );
        let mut crop =
            image::RgbImage::from_pixel(cw.max(1), ch.max(1), image::Rgb([255, 255, 255]));
        let (u0, v0) = (
            ((-reach - x_left) / m).round() as i64,
            ((z_top - top) / m).round() as i64,
        );
        for (cx, cy, px) in crop.enumerate_pixels_mut() {
            let (u, v) = (cx as i64 + u0, cy as i64 + v0);
            if u >= 0 && v >= 0 && (u as u32) < h.png.width() && (v as u32) < h.png.height() {
                *px = *h.png.get_pixel(u as u32, v as u32);
            }
        }
        let mut bytes = Vec::new();
        crop.write_to(
            &mut std::io::Cursor::new(&mut bytes),
            image::ImageFormat::Png,
        )
        .map_err(|e| format!("heap picture: {e}"))?;
        writeln!(
            svg,
            "<image x=\"{margin}\" y=\"{y:.1}\" width=\"{width:.1}\" height=\"{panel_h:.1}\" href=\"data:image/png;base64,{}\"/>",
            base64::engine::general_purpose::STANDARD.encode(bytes)
        )
        .unwrap();
        let to_px = |x: f64, z: f64| (margin + (x + reach) * k, y + (top - z) * k);
        for f in h.meta["flanks"].as_array().into_iter().flatten() {
            let g = |key: &str| f[key].as_f64().unwrap_or(f64::NAN);
            let (side, slope, b, s0, s1) = (
                g("side"),
                g("slope"),
                g("intercept_m"),
                g("fitted_from_m"),
                g("fitted_to_m"),
            );
            if ![side, slope, b, s0, s1].iter().all(|v| v.is_finite()) {
                continue;
            }
            // A little beyond the fitted stretch, but not below the base.
            let ext = 0.2 * (s1 - s0);
            let toe = if slope < 0.0 {
                -b / slope
            } else {
                f64::INFINITY
            };
            let (sa, sb) = ((s0 - ext).max(0.0), (s1 + ext).min(toe));
            let (p, q) = (
                to_px(side * sa, b + slope * sa),
                to_px(side * sb, b + slope * sb),
            );
            for (colour, w) in [("#FFFFFF", 7), (blue, 4)] {
                writeln!(svg, "<line x1=\"{:.1}\" y1=\"{:.1}\" x2=\"{:.1}\" y2=\"{:.1}\" stroke=\"{colour}\" stroke-width=\"{w}\"/>", p.0, p.1, q.0, q.1).unwrap();
            }
        }
        y += panel_h + 8.0;
    }
    let bar = scale_bar_length(2.0 * reach);
    let by = y + line;
    writeln!(
        svg,
        "<rect x=\"{margin}\" y=\"{:.1}\" width=\"{:.1}\" height=\"8\" fill=\"#000000\"/>",
        by - 4.0,
        bar * k
    )
    .unwrap();
    t(
        &mut svg,
        margin + bar * k + 10.0,
        by,
        &format!("{} (every panel at this scale)", length_text(bar)),
        "start",
    );
    svg.push_str("</svg>\n");
    Ok(svg)
}

/// Most pairs of factors drawn as maps (every pair of up to 8 factors).
pub(crate) const MAX_PAIR_MAPS: usize = 28;

/// The pairs of `k` factors to draw, every one up to [`MAX_PAIR_MAPS`]; says in `h` when more
/// exist than are drawn.
pub(crate) fn drawn_pairs(h: &mut String, k: usize) -> Vec<(usize, usize)> {
    let all: Vec<(usize, usize)> = (0..k)
        .flat_map(|a| (a + 1..k).map(move |b| (a, b)))
        .collect();
    if all.len() > MAX_PAIR_MAPS {
        write!(
            h,
            "<p class=\"note\">{} pairs of factors: the maps show the first {MAX_PAIR_MAPS}, in the order of the factors.</p>",
            all.len()
        )
        .unwrap();
    }
    all.into_iter().take(MAX_PAIR_MAPS).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spreads_read_to_two_digits_and_scale_bars_are_round() {
        assert_eq!(mean_sd(19.16, 0.8752), "19.16 ± 0.88");
        assert_eq!(mean_sd(18.48, 0.4764), "18.48 ± 0.48");
        assert_eq!(mean_sd(1234.5, 56.7), "1234 ± 57");
        assert_eq!(scale_bar_length(0.143), 0.02);
        assert_eq!(scale_bar_length(0.5), 0.1);
        assert_eq!(length_text(0.02), "20 mm");
    }
}
