//! SVG figures to PNG. demcal's figures are SVG (plotters' SVG backend, and the report's own
//! drawings); a paper wants them as bitmaps too. `resvg` draws them (Apache-2.0 OR MIT; its
//! dependencies are MIT, Apache, BSD or Zlib licensed, see ARCHITECTURE.md).
//!
//! Text is drawn with DejaVu Sans, embedded (`fonts/LICENSE-DejaVu.txt`) and loaded into usvg's
//! font database from its bytes; no system font is ever looked up (resvg's `system-fonts`
//! feature is off) and every generic family (`sans-serif`, `serif`, ...) and unknown family
//! falls back to it, so a PNG is the same on every machine. `<image>` elements are drawn from
//! data URLs only: a path in `href` is not read, so a figure cannot pull in a file.

use std::sync::{Arc, OnceLock};

use resvg::{tiny_skia, usvg};

static DEJAVU_SANS: &[u8] = include_bytes!("../fonts/DejaVuSans.ttf");
/// The family name inside `DEJAVU_SANS`.
const FAMILY: &str = "DejaVu Sans";
/// A picture larger than this many pixels is refused rather than allocated.
const MAX_PIXELS: u64 = 100_000_000;

/// usvg's options, built once: the font database (one font, parsed once, shared by every
/// figure) and an image resolver that reads data URLs but no files.
fn options() -> &'static usvg::Options<'static> {
    static OPTIONS: OnceLock<usvg::Options<'static>> = OnceLock::new();
    OPTIONS.get_or_init(|| {
        let mut db = usvg::fontdb::Database::new();
        db.load_font_source(usvg::fontdb::Source::Binary(Arc::new(DEJAVU_SANS)));
        db.set_sans_serif_family(FAMILY);
        db.set_serif_family(FAMILY);
        db.set_monospace_family(FAMILY);
        db.set_cursive_family(FAMILY);
        db.set_fantasy_family(FAMILY);
        usvg::Options {
            font_family: FAMILY.into(),
            fontdb: Arc::new(db),
            image_href_resolver: usvg::ImageHrefResolver {
                resolve_data: usvg::ImageHrefResolver::default_data_resolver(),
                resolve_string: Box::new(|_, _| None),
            },
            ..usvg::Options::default()
        }
    })
}

/// The advance width of `text` in DejaVu Sans at `font_size` (shaped, kerning included): what
/// the PNGs draw, and close to what a browser's sans-serif draws. It is measured by laying the
/// text out with usvg, so that layout code and the PNGs agree.
pub fn text_width(text: &str, font_size: f32) -> f32 {
    let escaped = text
        .replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;");
    let svg = format!(
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="1" height="1"><text font-family="{FAMILY}" font-size="{font_size}">{escaped}</text></svg>"#
    );
    let Ok(tree) = usvg::Tree::from_str(&svg, options()) else {
        return 0.55 * font_size * text.chars().count() as f32;
    };
    tree.root()
        .children()
        .iter()
        .find_map(|n| match n {
            // The text's object box is laid out from the glyphs' advances, not their ink.
            usvg::Node::Text(t) => Some(t.bounding_box().width()),
            _ => None,
        })
        .unwrap_or(0.0)
}

/// Renders `svg` at `scale` pixels per SVG unit and encodes it as PNG (8-bit RGB).
pub fn svg_to_png(svg: &str, scale: f32) -> Result<Vec<u8>, String> {
    let img = render(svg, scale)?;
    let mut bytes = Vec::new();
    img.write_to(
        &mut std::io::Cursor::new(&mut bytes),
        image::ImageFormat::Png,
    )
    .map_err(|e| format!("png: {e}"))?;
    Ok(bytes)
}

/// Renders `svg` at `scale` pixels per SVG unit on a white background.
pub fn render(svg: &str, scale: f32) -> Result<image::RgbImage, String> {
    let tree = usvg::Tree::from_str(svg, options()).map_err(|e| format!("svg: {e}"))?;
    let size = tree.size();
    let (pw, ph) = (
        (size.width() * scale).round(),
        (size.height() * scale).round(),
    );
    if !(pw >= 1.0 && ph >= 1.0 && (pw as f64) * (ph as f64) <= MAX_PIXELS as f64) {
        return Err(format!("svg: cannot draw a picture of {pw} x {ph} pixels"));
    }
    let (pw, ph) = (pw as u32, ph as u32);
    let mut pixmap = tiny_skia::Pixmap::new(pw, ph)
        .ok_or_else(|| format!("svg: cannot draw a picture of {pw} x {ph} pixels"))?;
    pixmap.fill(tiny_skia::Color::WHITE);
    resvg::render(
        &tree,
        tiny_skia::Transform::from_scale(scale, scale),
        &mut pixmap.as_mut(),
    );
    // The background is opaque, so every pixel is too and premultiplied RGBA is plain RGB.
    let rgb: Vec<u8> = pixmap
        .data()
        .chunks_exact(4)
        .flat_map(|p| [p[0], p[1], p[2]])
        .collect();
    image::RgbImage::from_raw(pw, ph, rgb).ok_or_else(|| "svg: pixel buffer".into())
}

#[cfg(test)]
mod tests {
    use super::*;
    use base64::Engine;

    fn at(img: &image::RgbImage, x: u32, y: u32) -> [u8; 3] {
        img.get_pixel(x, y).0
    }

    /// The pixels darker than mid grey in x0..x1 by y0..y1.
    fn dark(img: &image::RgbImage, x0: u32, x1: u32, y0: u32, y1: u32) -> Vec<(u32, u32)> {
        (y0..y1)
            .flat_map(|y| (x0..x1).map(move |x| (x, y)))
            .filter(|&(x, y)| at(img, x, y)[0] < 128)
            .collect()
    }

    /// The box (x0, x1, y0, y1) around `pixels`.
    fn extent(pixels: &[(u32, u32)]) -> (u32, u32, u32, u32) {
        pixels.iter().fold((u32::MAX, 0, u32::MAX, 0), |a, p| {
            (a.0.min(p.0), a.1.max(p.0), a.2.min(p.1), a.3.max(p.1))
        })
    }

    #[test]
    fn shapes_land_where_the_svg_puts_them_at_twice_the_size() {
        let svg = r##"<svg width="100" height="50" xmlns="http://www.w3.org/2000/svg">
<rect x="0" y="0" width="100" height="50" fill="#FFFFFF" stroke="none"/>
<rect x="10" y="10" width="20" height="10" opacity="1" fill="#FF0000" stroke="none"/>
<circle cx="70" cy="25" r="10" fill="#0000FF" stroke="none"/>
<line x1="0" y1="45" x2="100" y2="45" stroke="#000000" stroke-width="2"/>
<rect x="40" y="5" width="10" height="10" opacity="0.5" fill="#000000"/>
</svg>"##;
        let img = render(svg, 2.0).unwrap();
        assert_eq!((img.width(), img.height()), (200, 100));
        assert_eq!(at(&img, 40, 30), [255, 0, 0]); // inside the red rectangle
        assert_eq!(at(&img, 10, 10), [255, 255, 255]); // outside it
        assert_eq!(at(&img, 140, 50), [0, 0, 255]); // the circle's centre
        assert_eq!(at(&img, 140 + 18, 50), [0, 0, 255]); // just inside its edge
        assert_eq!(at(&img, 140 + 22, 50), [255, 255, 255]); // just outside
        assert_eq!(at(&img, 50, 90), [0, 0, 0]); // the 2-unit line is 4 pixels thick
        assert_eq!(at(&img, 50, 93), [255, 255, 255]);
        let half = at(&img, 90, 20)[0];
        assert!((126..=129).contains(&half), "50 % black over white: {half}");
        // An edge half across a pixel is drawn about half covered.
        let svg = r##"<svg width="4" height="4" xmlns="http://www.w3.org/2000/svg"><rect x="1.5" y="0" width="2" height="4" fill="#000000"/></svg>"##;
        let img = render(svg, 1.0).unwrap();
        let v = at(&img, 1, 2)[0];
        assert!((120..=135).contains(&v), "{v}");
        assert_eq!(at(&img, 2, 2), [0, 0, 0]);
        assert_eq!(at(&img, 0, 2), [255, 255, 255]);
    }

    #[test]
    fn text_is_drawn_at_its_anchor_and_rotated_text_runs_upwards() {
        let svg = r##"<svg width="200" height="200" xmlns="http://www.w3.org/2000/svg">
<text x="100" y="50" dy="0.76em" text-anchor="middle" font-family="sans-serif" font-size="20" fill="#000000">
MMMM
</text>
<text x="30" y="150" dy="0.5ex" text-anchor="middle" font-family="sans-serif" font-size="20" fill="#000000" transform="rotate(270, 30, 150)">MMMMMM</text>
</svg>"##;
        let img = render(svg, 1.0).unwrap();
        // "MMMM" in DejaVu Sans at 20 px: M's advance is 1767/2048 em, so 69.0 px wide, centred
        // on x = 100; the ink is that less the side bearings (about 2 px each side). Its top (cap
        // height 0.729 em = 14.6 px above the baseline at 50 + 15.2) is at about y = 50.6.
        assert!((text_width("MMMM", 20.0) - 69.02).abs() < 0.05);
        let (x0, x1, y0, y1) = extent(&dark(&img, 0, 200, 0, 100));
        assert!(
            (66..=69).contains(&x0) && (131..=134).contains(&x1),
            "{x0} {x1}"
        );
        assert!(
            (49..=52).contains(&y0) && (63..=66).contains(&y1),
            "{y0} {y1}"
        );
        // Rotated by 270 degrees about (30, 150): the six Ms run up the picture, tall and
        // narrow, centred on y = 150.
        let (x0, x1, y0, y1) = extent(&dark(&img, 0, 100, 100, 200));
        assert!(y1 - y0 > 90 && x1 - x0 < 20, "{x0}..{x1} x {y0}..{y1}");
        assert!(((y0 + y1) / 2).abs_diff(150) <= 2, "{y0} {y1}");
    }

    #[test]
    fn every_font_family_draws_the_embedded_font() {
        // A family the machine may or may not have draws the same pixels as the generic one:
        // nothing depends on the system's fonts.
        let draw = |family: &str| {
            let svg = format!(
                r##"<svg width="160" height="40" xmlns="http://www.w3.org/2000/svg"><text x="5" y="30" font-family="{family}" font-size="24" fill="#000000">R² = 0.97</text></svg>"##
            );
            render(&svg, 1.0).unwrap()
        };
        let sans = draw("sans-serif");
        let ink = dark(&sans, 0, 160, 0, 40);
        let (x0, x1, _, _) = extent(&ink);
        assert!(ink.len() > 150, "{} dark pixels", ink.len());
        let width = text_width("R² = 0.97", 24.0);
        assert!((x1 - x0) as f32 > 0.85 * width && (x1 - x0) as f32 <= width + 1.0);
        for other in ["Arial", "serif", "Times New Roman", "monospace"] {
            assert_eq!(draw(other), sans, "{other}");
        }
        assert_eq!(text_width("", 20.0), 0.0);
        // Markup characters are measured as text.
        let amp = text_width("a < b & c", 20.0);
        assert!(amp > text_width("a b c", 20.0) + 10.0, "{amp}");
    }

    #[test]
    fn dashes_alternate_and_images_are_scaled_into_their_box() {
        let svg = r##"<svg width="100" height="20" xmlns="http://www.w3.org/2000/svg"><line x1="0" y1="10" x2="100" y2="10" stroke="#000000" stroke-width="4" stroke-dasharray="10,10"/></svg>"##;
        let img = render(svg, 1.0).unwrap();
        assert_eq!(at(&img, 5, 10), [0, 0, 0]);
        assert_eq!(at(&img, 15, 10), [255, 255, 255]);
        assert_eq!(at(&img, 25, 10), [0, 0, 0]);
        // A 2 x 1 PNG (red, blue) stretched over 40 x 20.
        let mut png = Vec::new();
        let src = image::RgbaImage::from_fn(2, 1, |x, _| {
            image::Rgba(if x == 0 {
                [255, 0, 0, 255]
            } else {
                [0, 0, 255, 255]
            })
        });
        src.write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
            .unwrap();
        let data = base64::engine::general_purpose::STANDARD.encode(&png);
        let svg = format!(
            r##"<svg width="60" height="30" xmlns="http://www.w3.org/2000/svg"><image x="10" y="5" width="40" height="20" preserveAspectRatio="none" href="data:image/png;base64,{data}"/></svg>"##
        );
        let img = render(&svg, 1.0).unwrap();
        assert_eq!(at(&img, 12, 15), [255, 0, 0]);
        assert_eq!(at(&img, 48, 15), [0, 0, 255]);
        assert_eq!(at(&img, 5, 15), [255, 255, 255]);
        assert_eq!(at(&img, 30, 28), [255, 255, 255]);
        // The same PNG named by a path is not read.
        let path = std::env::temp_dir().join(format!("demcal-raster-{}.png", std::process::id()));
        std::fs::write(&path, &png).unwrap();
        let svg = format!(
            r##"<svg width="60" height="30" xmlns="http://www.w3.org/2000/svg"><image x="10" y="5" width="40" height="20" href="{}"/></svg>"##,
            path.display()
        );
        let img = render(&svg, 1.0).unwrap();
        let _ = std::fs::remove_file(&path);
        assert_eq!(at(&img, 12, 15), [255, 255, 255]);
    }

    #[test]
    fn the_png_holds_the_picture_and_bad_input_is_an_error() {
        let svg = r##"<svg width="30" height="20" xmlns="http://www.w3.org/2000/svg"><rect x="0" y="0" width="15" height="20" fill="#00FF00"/></svg>"##;
        let png = svg_to_png(svg, 2.0).unwrap();
        let img = image::load_from_memory_with_format(&png, image::ImageFormat::Png)
            .unwrap()
            .to_rgb8();
        assert_eq!((img.width(), img.height()), (60, 40));
        assert_eq!(at(&img, 10, 20), [0, 255, 0]);
        assert_eq!(at(&img, 50, 20), [255, 255, 255]);
        assert!(render("<html/>", 1.0).unwrap_err().starts_with("svg: "));
        assert!(render("not xml", 1.0).is_err());
        let huge = r##"<svg width="20000" height="20000" xmlns="http://www.w3.org/2000/svg"/>"##;
        assert!(render(huge, 1.0).unwrap_err().contains("20000 x 20000"));
    }
}
