//! Pictures of a heap: the measured profiles with their fitted lines (SVG, plotters), and a side
//! view of the particles (PNG, a small z-buffered sphere rasteriser).

use glam::DVec3;
use plotters::prelude::*;

use crate::repose::ReposeResult;

const COLOURS: [RGBColor; 6] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
];

fn err<E: std::fmt::Debug>(e: E) -> String {
    format!("plot: {e:?}")
}

/// Profiles of every plane (points; flank on the left drawn at negative distance) and the line
/// fitted to each flank over the points it used.
pub fn profiles_svg(res: &ReposeResult) -> Result<String, String> {
    let xmax = res
        .flanks
        .iter()
        .flat_map(|f| f.profile.iter().map(|p| p.0))
        .fold(0.0f64, f64::max)
        * 1.05;
    let zmax = res.heap_height * 1.15;
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (800, 480)).into_drawing_area();
        root.fill(&WHITE).map_err(err)?;
        let mut chart = ChartBuilder::on(&root)
            .caption(
                format!(
                    "Heap profiles: angle {:.2} ± {:.2} deg over {} flanks",
                    res.angle_deg,
                    res.angle_std_deg,
                    res.flanks.len()
                ),
                ("sans-serif", 20),
            )
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(56)
            .build_cartesian_2d(-xmax..xmax, 0.0..zmax)
            .map_err(err)?;
        chart
            .configure_mesh()
            .x_desc("distance from the axis (m)")
            .y_desc("height (m)")
            .draw()
            .map_err(err)?;
        for (i, f) in res.flanks.iter().enumerate() {
            let colour = COLOURS[(i / 2) % COLOURS.len()];
            chart
                .draw_series(
                    f.profile
                        .iter()
                        .map(|&(s, z)| Circle::new((f.side * s, z), 2, colour.filled())),
                )
                .map_err(err)?;
            let (s0, s1) = f
                .fitted
                .iter()
                .fold((f64::MAX, f64::MIN), |(a, b), p| (a.min(p.0), b.max(p.0)));
            let line = [
                (f.side * s0, f.intercept + f.slope * s0),
                (f.side * s1, f.intercept + f.slope * s1),
            ];
            chart
                .draw_series(LineSeries::new(line, BLACK.stroke_width(2)))
                .map_err(err)?;
        }
        root.present().map_err(err)?;
    }
    Ok(svg)
}

/// A side view (looking along +y) of spheres, shaded by their normal, `width` pixels wide,
/// written as a PNG file.
pub fn side_view_png(
    positions: &[DVec3],
    radii: &[f64],
    width: u32,
    path: &std::path::Path,
) -> Result<(), String> {
    let bytes = side_view_png_bytes(positions, radii, width)?;
    std::fs::write(path, bytes).map_err(|e| format!("{}: {e}", path.display()))
}

/// The side view of [`side_view_png`] as PNG bytes.
pub fn side_view_png_bytes(
    positions: &[DVec3],
    radii: &[f64],
    width: u32,
) -> Result<Vec<u8>, String> {
    side_view(positions, radii, width).map(|v| v.png)
}

/// A side view and where it lies: the picture's left edge is at x = `x_left_m`, its top at
/// z = `z_top_m`, and a pixel is `m_per_px` wide and high; x grows to the right, z upwards.
#[derive(Clone, Debug)]
pub struct SideView {
    pub png: Vec<u8>,
    pub width_px: u32,
    pub height_px: u32,
    pub x_left_m: f64,
    pub z_top_m: f64,
    pub m_per_px: f64,
}

/// The side view of [`side_view_png`] with its scale and position, so that a report can put a
/// scale bar on it and draw the measured flank lines over it.
pub fn side_view(positions: &[DVec3], radii: &[f64], width: u32) -> Result<SideView, String> {
    if positions.is_empty() {
        return Err("side view: no particles".into());
    }
    let (mut lo, mut hi) = (DVec3::splat(f64::MAX), DVec3::splat(f64::MIN));
    for (p, &r) in positions.iter().zip(radii) {
        lo = lo.min(*p - DVec3::splat(r));
        hi = hi.max(*p + DVec3::splat(r));
    }
    let pad = 0.05 * (hi.x - lo.x).max(hi.z - lo.z);
    let (x0, x1, z0, z1) = (lo.x - pad, hi.x + pad, lo.z.min(0.0) - pad, hi.z + pad);
    let scale = width as f64 / (x1 - x0);
    let height = ((z1 - z0) * scale).ceil().max(1.0) as u32;
    let mut img = image::RgbImage::from_pixel(width, height, image::Rgb([255, 255, 255]));
    let mut depth = vec![f64::INFINITY; (width * height) as usize];
    let light = DVec3::new(-0.4, -0.8, 0.45).normalize();
    for (p, &r) in positions.iter().zip(radii) {
        let (cx, cz) = ((p.x - x0) * scale, (z1 - p.z) * scale);
        let pr = r * scale;
        let (ia, ib) = (
            (cx - pr).floor().max(0.0) as u32,
            ((cx + pr).ceil() as u32).min(width - 1),
        );
        let (ja, jb) = (
            (cz - pr).floor().max(0.0) as u32,
            ((cz + pr).ceil() as u32).min(height - 1),
        );
        for j in ja..=jb {
            for i in ia..=ib {
                let (dx, dz) = ((i as f64 + 0.5 - cx) / pr, (cz - (j as f64 + 0.5)) / pr);
                let q = dx * dx + dz * dz;
                if q > 1.0 {
                    continue;
                }
                let dy = -(1.0 - q).sqrt(); // the surface facing the viewer at -y
                let d = p.y + dy * r;
                let k = (j * width + i) as usize;
                if d < depth[k] {
                    depth[k] = d;
                    let normal = DVec3::new(dx, dy, dz);
                    let shade = 0.25 + 0.75 * normal.dot(light).max(0.0);
                    let c = |base: f64| (base * shade).clamp(0.0, 255.0) as u8;
                    img.put_pixel(i, j, image::Rgb([c(214.0), c(170.0), c(70.0)]));
                }
            }
        }
    }
    // The base plate as a dark line at z = 0.
    let jz = ((z1 - 0.0) * scale) as u32;
    for j in jz..(jz + 3).min(height) {
        for i in 0..width {
            if depth[(j * width + i) as usize].is_infinite() {
                img.put_pixel(i, j, image::Rgb([90, 90, 90]));
            }
        }
    }
    let mut bytes = Vec::new();
    img.write_to(
        &mut std::io::Cursor::new(&mut bytes),
        image::ImageFormat::Png,
    )
    .map_err(|e| format!("side view: {e}"))?;
    Ok(SideView {
        png: bytes,
        width_px: width,
        height_px: height,
        x_left_m: x0,
        z_top_m: z1,
        m_per_px: 1.0 / scale,
    })
}

/// `heap.json`: where the side view lies (as [`SideView`]) and the flank lines fitted in the
/// vertical plane the side view looks across (plane 0, through the axis along x): for each,
/// the side (+1 right, -1 left), the line z = intercept + slope s with s the distance from the
/// axis, the stretch of s its points covered, and its angle.
pub fn heap_json(view: &SideView, res: &ReposeResult) -> serde_json::Value {
    let flanks: Vec<serde_json::Value> = res
        .flanks
        .iter()
        .filter(|f| f.plane_angle.abs() < 1e-9)
        .map(|f| {
            let (s0, s1) = f
                .fitted
                .iter()
                .fold((f64::MAX, f64::MIN), |(a, b), p| (a.min(p.0), b.max(p.0)));
            serde_json::json!({
                "side": f.side,
                "slope": f.slope,
                "intercept_m": f.intercept,
                "fitted_from_m": s0,
                "fitted_to_m": s1,
                "angle_deg": f.angle_deg,
            })
        })
        .collect();
    serde_json::json!({
        "picture": "heap.png",
        "width_px": view.width_px,
        "height_px": view.height_px,
        "x_left_m": view.x_left_m,
        "z_top_m": view.z_top_m,
        "m_per_px": view.m_per_px,
        "heap_height_m": res.heap_height,
        "heap_radius_m": res.heap_radius,
        "flanks_measured": res.flanks.len(),
        "angle_deg": res.angle_deg,
        "angle_std_deg": res.angle_std_deg,
        "flanks": flanks,
    })
}

/// A force-displacement curve (displacement in mm, force in N).
pub fn curve_svg(test: &str, displacement: &[f64], force: &[f64]) -> Result<String, String> {
    let xmax = displacement
        .iter()
        .cloned()
        .fold(0.0f64, f64::max)
        .max(1e-12)
        * 1e3;
    let fmax = force.iter().cloned().fold(0.0f64, f64::max);
    let fmin = force.iter().cloned().fold(0.0f64, f64::min);
    let pad = 0.05 * (fmax - fmin).max(1e-12);
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (800, 480)).into_drawing_area();
        root.fill(&WHITE).map_err(err)?;
        let mut chart = ChartBuilder::on(&root)
            .caption(
                format!("{test}: force against displacement (peak {fmax:.3} N)"),
                ("sans-serif", 20),
            )
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(64)
            .build_cartesian_2d(0.0..xmax, (fmin - pad)..(fmax + pad))
            .map_err(err)?;
        chart
            .configure_mesh()
            .x_desc("displacement (mm)")
            .y_desc("force (N)")
            .draw()
            .map_err(err)?;
        chart
            .draw_series(LineSeries::new(
                displacement.iter().zip(force).map(|(d, f)| (d * 1e3, *f)),
                COLOURS[0].stroke_width(2),
            ))
            .map_err(err)?;
        root.present().map_err(err)?;
    }
    Ok(svg)
}
