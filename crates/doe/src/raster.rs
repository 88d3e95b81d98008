//! SVG figures to PNG. demcal's figures are SVG (plotters' SVG backend, and the report's own
//! drawings); a paper wants them as bitmaps too. This draws the part of SVG those figures use:
//! `rect`, `line`, `polyline`, `polygon`, `circle`, `text` (anchors, `dy` in em or ex, bold,
//! rotation), `image` (PNG data URLs), `g`, the `transform`s `translate`, `scale` and `rotate`,
//! `opacity`, `fill-opacity`, `stroke-opacity` and `stroke-dasharray`. Shapes are filled with
//! exact-area anti-aliasing (`ab_glyph_rasterizer`, the rasteriser fonts use) and text is drawn
//! from the outlines of DejaVu Sans, embedded (`fonts/LICENSE-DejaVu.txt`): the PNG looks the
//! same on every machine, with no system fonts. Elements outside this subset are skipped.

use ab_glyph::{Font, FontRef, OutlineCurve};
use ab_glyph_rasterizer::{point, Point, Rasterizer};
use base64::Engine;

static DEJAVU_SANS: &[u8] = include_bytes!("../fonts/DejaVuSans.ttf");

/// The advance width of `text` in DejaVu Sans at `font_size` (kerning included): what the PNGs
/// draw, and close to what a browser's sans-serif draws.
pub fn text_width(text: &str, font_size: f32) -> f32 {
    let Ok(font) = FontRef::try_from_slice(DEJAVU_SANS) else {
        return 0.55 * font_size * text.chars().count() as f32;
    };
    let k = font_size / font.units_per_em().unwrap_or(2048.0);
    let mut pen = 0.0;
    let mut prev = None;
    for ch in text.chars() {
        let id = font.glyph_id(ch);
        if let Some(p) = prev {
            pen += font.kern_unscaled(p, id);
        }
        pen += font.h_advance_unscaled(id);
        prev = Some(id);
    }
    pen * k
}

/// Renders `svg` at `scale` pixels per SVG unit and encodes it as PNG.
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
    let doc = roxmltree::Document::parse(svg).map_err(|e| format!("svg: {e}"))?;
    let root = doc.root_element();
    if !root.has_tag_name("svg") {
        return Err("svg: the root element is not <svg>".into());
    }
    let size = |name: &str| root.attribute(name).and_then(|v| length(v, 16.0));
    let view: Option<Vec<f32>> = root
        .attribute("viewBox")
        .map(|v| numbers(v).into_iter().collect())
        .filter(|v: &Vec<f32>| v.len() == 4 && v[2] > 0.0 && v[3] > 0.0);
    let (w, h) = match (size("width"), size("height"), &view) {
        (Some(w), Some(h), _) => (w, h),
        (_, _, Some(v)) => (v[2], v[3]),
        _ => return Err("svg: no width and height".into()),
    };
    let (pw, ph) = ((w * scale).round() as u32, (h * scale).round() as u32);
    if pw == 0 || ph == 0 || pw as u64 * ph as u64 > 100_000_000 {
        return Err(format!("svg: cannot draw a picture of {pw} x {ph} pixels"));
    }
    let mut base = Affine::scale(scale);
    if let Some(v) = &view {
        base = base
            .then_before(Affine::scale_xy(w / v[2], h / v[3]))
            .then_before(Affine::translate(-v[0], -v[1]));
    }
    let font = FontRef::try_from_slice(DEJAVU_SANS).map_err(|e| format!("font: {e}"))?;
    let mut c = Canvas {
        img: image::RgbImage::from_pixel(pw, ph, image::Rgb([255, 255, 255])),
        font,
    };
    c.children(root, base, Style::default());
    Ok(c.img)
}

/// A 2-D affine map: (x, y) -> (a x + c y + e, b x + d y + f).
#[derive(Clone, Copy, Debug, PartialEq)]
struct Affine([f32; 6]);

impl Affine {
    const ID: Affine = Affine([1.0, 0.0, 0.0, 1.0, 0.0, 0.0]);

    fn scale(s: f32) -> Affine {
        Affine([s, 0.0, 0.0, s, 0.0, 0.0])
    }

    fn scale_xy(sx: f32, sy: f32) -> Affine {
        Affine([sx, 0.0, 0.0, sy, 0.0, 0.0])
    }

    fn translate(x: f32, y: f32) -> Affine {
        Affine([1.0, 0.0, 0.0, 1.0, x, y])
    }

    fn rotate_deg(a: f32) -> Affine {
        let (s, c) = a.to_radians().sin_cos();
        Affine([c, s, -s, c, 0.0, 0.0])
    }

    /// `self` applied after `inner`: p -> self(inner(p)).
    fn then_before(self, inner: Affine) -> Affine {
        let [a, b, c, d, e, f] = self.0;
        let [a2, b2, c2, d2, e2, f2] = inner.0;
        Affine([
            a * a2 + c * b2,
            b * a2 + d * b2,
            a * c2 + c * d2,
            b * c2 + d * d2,
            a * e2 + c * f2 + e,
            b * e2 + d * f2 + f,
        ])
    }

    fn apply(&self, x: f32, y: f32) -> Point {
        let [a, b, c, d, e, f] = self.0;
        point(a * x + c * y + e, b * x + d * y + f)
    }

    /// How much lengths grow (the mean of the two axes' stretch).
    fn stretch(&self) -> f32 {
        let [a, b, c, d, ..] = self.0;
        0.5 * ((a * a + b * b).sqrt() + (c * c + d * d).sqrt())
    }
}

/// Parses an SVG `transform` list (translate, scale, rotate, matrix).
fn transform(text: &str) -> Affine {
    let mut m = Affine::ID;
    let mut rest = text;
    while let Some(open) = rest.find('(') {
        let name = rest[..open]
            .trim()
            .trim_start_matches(',')
            .trim()
            .to_string();
        let Some(close) = rest[open..].find(')') else {
            break;
        };
        let args = numbers(&rest[open + 1..open + close]);
        rest = &rest[open + close + 1..];
        let t = match (name.as_str(), args.as_slice()) {
            ("translate", [x]) => Affine::translate(*x, 0.0),
            ("translate", [x, y]) => Affine::translate(*x, *y),
            ("scale", [s]) => Affine::scale(*s),
            ("scale", [x, y]) => Affine::scale_xy(*x, *y),
            ("rotate", [a]) => Affine::rotate_deg(*a),
            ("rotate", [a, x, y]) => Affine::translate(*x, *y)
                .then_before(Affine::rotate_deg(*a))
                .then_before(Affine::translate(-x, -y)),
            ("matrix", [a, b, c, d, e, f]) => Affine([*a, *b, *c, *d, *e, *f]),
            _ => Affine::ID,
        };
        m = m.then_before(t);
    }
    m
}

/// The numbers in a list separated by commas or spaces (`points`, `viewBox`, arguments).
fn numbers(text: &str) -> Vec<f32> {
    text.split(|c: char| c == ',' || c.is_whitespace())
        .filter(|s| !s.is_empty())
        .filter_map(|s| s.parse().ok())
        .collect()
}

/// A length in user units: a plain number or px; em relative to `font_size`.
fn length(text: &str, font_size: f32) -> Option<f32> {
    let t = text.trim();
    if let Some(v) = t.strip_suffix("px") {
        return v.trim().parse().ok();
    }
    if let Some(v) = t.strip_suffix("em") {
        return v.trim().parse::<f32>().ok().map(|v| v * font_size);
    }
    t.parse().ok()
}

/// A paint: `none`, `#rgb`, `#rrggbb`, `rgb(r, g, b)` or a few colour names.
fn paint(text: &str) -> Option<Option<[u8; 3]>> {
    let t = text.trim();
    if t == "none" || t == "transparent" {
        return Some(None);
    }
    if let Some(hex) = t.strip_prefix('#') {
        let v = |s: &str| u8::from_str_radix(s, 16).ok();
        return match hex.len() {
            6 => Some(Some([v(&hex[0..2])?, v(&hex[2..4])?, v(&hex[4..6])?])),
            3 => {
                let d = |i: usize| v(&hex[i..i + 1]).map(|x| x * 17);
                Some(Some([d(0)?, d(1)?, d(2)?]))
            }
            _ => None,
        };
    }
    if let Some(inner) = t.strip_prefix("rgb(").and_then(|s| s.strip_suffix(')')) {
        let n = numbers(inner);
        if n.len() == 3 {
            return Some(Some([n[0] as u8, n[1] as u8, n[2] as u8]));
        }
        return None;
    }
    let named = match t.to_ascii_lowercase().as_str() {
        "black" => [0, 0, 0],
        "white" => [255, 255, 255],
        "red" => [255, 0, 0],
        "green" => [0, 128, 0],
        "blue" => [0, 0, 255],
        "gray" | "grey" => [128, 128, 128],
        _ => return None,
    };
    Some(Some(named))
}

/// The presentation attributes an element inherits from its group.
#[derive(Clone, Debug)]
struct Style {
    fill: Option<[u8; 3]>,
    stroke: Option<[u8; 3]>,
    stroke_width: f32,
    opacity: f32,
    fill_opacity: f32,
    stroke_opacity: f32,
    font_size: f32,
    bold: bool,
    anchor: Anchor,
    dash: Vec<f32>,
}

impl Default for Style {
    fn default() -> Self {
        Style {
            fill: Some([0, 0, 0]),
            stroke: None,
            stroke_width: 1.0,
            opacity: 1.0,
            fill_opacity: 1.0,
            stroke_opacity: 1.0,
            font_size: 16.0,
            bold: false,
            anchor: Anchor::Start,
            dash: Vec::new(),
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Anchor {
    Start,
    Middle,
    End,
}

impl Style {
    fn of(&self, n: roxmltree::Node) -> Style {
        let mut s = self.clone();
        // Opacity does not inherit in SVG, but the figures never nest it: multiplying is right
        // for a group's opacity over its children.
        s.opacity = self.opacity;
        let num = |name: &str| n.attribute(name).and_then(|v| v.trim().parse::<f32>().ok());
        if let Some(p) = n.attribute("fill").and_then(paint) {
            s.fill = p;
        }
        if let Some(p) = n.attribute("stroke").and_then(paint) {
            s.stroke = p;
        }
        if let Some(w) = n
            .attribute("stroke-width")
            .and_then(|v| length(v, s.font_size))
        {
            s.stroke_width = w;
        }
        if let Some(o) = num("opacity") {
            s.opacity *= o.clamp(0.0, 1.0);
        }
        if let Some(o) = num("fill-opacity") {
            s.fill_opacity = o.clamp(0.0, 1.0);
        }
        if let Some(o) = num("stroke-opacity") {
            s.stroke_opacity = o.clamp(0.0, 1.0);
        }
        if let Some(f) = n
            .attribute("font-size")
            .and_then(|v| length(v, s.font_size))
        {
            s.font_size = f;
        }
        if let Some(w) = n.attribute("font-weight") {
            s.bold = w == "bold" || w.parse::<u32>().is_ok_and(|v| v >= 600);
        }
        if let Some(a) = n.attribute("text-anchor") {
            s.anchor = match a {
                "middle" => Anchor::Middle,
                "end" => Anchor::End,
                _ => Anchor::Start,
            };
        }
        if let Some(d) = n.attribute("stroke-dasharray") {
            s.dash = if d.trim() == "none" {
                Vec::new()
            } else {
                numbers(d)
            };
        }
        s
    }
}

struct Canvas<'f> {
    img: image::RgbImage,
    font: FontRef<'f>,
}

/// A closed contour of a filled area, in pixels.
type Contour = Vec<Point>;

/// Twice the signed area of a contour.
fn area2(c: &[Point]) -> f32 {
    (0..c.len())
        .map(|i| {
            let (p, q) = (c[i], c[(i + 1) % c.len()]);
            p.x * q.y - q.x * p.y
        })
        .sum()
}

fn circle(cx: f32, cy: f32, r: f32, m: &Affine) -> Contour {
    let rp = r * m.stretch();
    let n = ((std::f32::consts::TAU * rp / 0.6).ceil() as usize).clamp(8, 720);
    (0..n)
        .map(|i| {
            let t = std::f32::consts::TAU * i as f32 / n as f32;
            m.apply(cx + r * t.cos(), cy + r * t.sin())
        })
        .collect()
}

/// The outline of a stroke of width `w` (pixels) along `pts` (pixels), as contours of one
/// orientation: a quadrilateral per segment, a disc at each joint (and at the ends of a closed
/// path), so that their union is the stroke.
fn stroke_outline(pts: &[Point], closed: bool, w: f32) -> Vec<Contour> {
    let mut out = Vec::new();
    let h = 0.5 * w;
    let n = pts.len();
    let segs = if closed { n } else { n.saturating_sub(1) };
    for i in 0..segs {
        let (p, q) = (pts[i], pts[(i + 1) % n]);
        let (dx, dy) = (q.x - p.x, q.y - p.y);
        let len = (dx * dx + dy * dy).sqrt();
        if len < 1e-6 {
            continue;
        }
        let (nx, ny) = (-dy / len * h, dx / len * h);
        out.push(vec![
            point(p.x + nx, p.y + ny),
            point(q.x + nx, q.y + ny),
            point(q.x - nx, q.y - ny),
            point(p.x - nx, p.y - ny),
        ]);
    }
    if h > 0.75 {
        let joints = if closed { 0..n } else { 1..n.saturating_sub(1) };
        for i in joints {
            out.push(circle(pts[i].x, pts[i].y, h, &Affine::ID));
        }
    }
    out
}

/// Splits a path into its dashes (lengths in pixels).
fn dashes(pts: &[Point], closed: bool, pattern: &[f32]) -> Vec<Vec<Point>> {
    let mut path = pts.to_vec();
    if closed && !pts.is_empty() {
        path.push(pts[0]);
    }
    let total: f32 = pattern.iter().sum();
    if pattern.is_empty() || total <= 0.0 || pattern.iter().any(|v| *v < 0.0) {
        return vec![path];
    }
    let mut out: Vec<Vec<Point>> = Vec::new();
    let (mut k, mut left, mut on) = (0usize, pattern[0], true);
    let mut current: Vec<Point> = path.first().map(|p| vec![*p]).unwrap_or_default();
    for w in path.windows(2) {
        let (mut p, q) = (w[0], w[1]);
        let mut seg = ((q.x - p.x).powi(2) + (q.y - p.y).powi(2)).sqrt();
        while seg > left {
            let t = left / seg;
            let m = point(p.x + t * (q.x - p.x), p.y + t * (q.y - p.y));
            if on {
                current.push(m);
                out.push(std::mem::take(&mut current));
            } else {
                current = vec![m];
            }
            seg -= left;
            p = m;
            on = !on;
            k = (k + 1) % pattern.len();
            left = pattern[k];
        }
        left -= seg;
        if on {
            current.push(q);
        }
    }
    if on && current.len() > 1 {
        out.push(current);
    }
    out
}

impl Canvas<'_> {
    fn children(&mut self, node: roxmltree::Node, m: Affine, style: Style) {
        for n in node.children().filter(|n| n.is_element()) {
            let s = style.of(n);
            let m = match n.attribute("transform") {
                Some(t) => m.then_before(transform(t)),
                None => m,
            };
            self.element(n, m, &s);
        }
    }

    fn element(&mut self, n: roxmltree::Node, m: Affine, s: &Style) {
        let f = |name: &str| -> f32 {
            n.attribute(name)
                .and_then(|v| length(v, s.font_size))
                .unwrap_or(0.0)
        };
        match n.tag_name().name() {
            "g" | "a" => self.children(n, m, s.clone()),
            "rect" => {
                let (x, y, w, h) = (f("x"), f("y"), f("width"), f("height"));
                if w <= 0.0 || h <= 0.0 {
                    return;
                }
                let pts = [(x, y), (x + w, y), (x + w, y + h), (x, y + h)];
                self.shape(&pts, true, m, s);
            }
            "line" => {
                let pts = [(f("x1"), f("y1")), (f("x2"), f("y2"))];
                let s = Style {
                    fill: None,
                    ..s.clone()
                };
                self.shape(&pts, false, m, &s);
            }
            "polyline" | "polygon" => {
                let v = numbers(n.attribute("points").unwrap_or(""));
                let pts: Vec<(f32, f32)> = v.chunks_exact(2).map(|c| (c[0], c[1])).collect();
                self.shape(&pts, n.has_tag_name("polygon"), m, s);
            }
            "circle" => {
                let (cx, cy, r) = (f("cx"), f("cy"), f("r"));
                if r <= 0.0 {
                    return;
                }
                let outline = circle(cx, cy, r, &m);
                if let Some(c) = s.fill {
                    self.fill(
                        std::slice::from_ref(&outline),
                        true,
                        c,
                        s.opacity * s.fill_opacity,
                    );
                }
                if let Some(c) = s.stroke {
                    let w = s.stroke_width * m.stretch();
                    if w > 0.0 {
                        // A ring: the outer circle and the inner one the other way round.
                        let outer = circle(cx, cy, r + 0.5 * s.stroke_width, &m);
                        let mut inner = circle(cx, cy, (r - 0.5 * s.stroke_width).max(0.0), &m);
                        if area2(&outer) * area2(&inner) > 0.0 {
                            inner.reverse();
                        }
                        self.fill(&[outer, inner], false, c, s.opacity * s.stroke_opacity);
                    }
                }
            }
            "text" => self.text(n, m, s),
            "image" => self.image(n, m, s),
            _ => {}
        }
    }

    /// Fills (when closed and the style fills) and strokes a polyline given in user units.
    fn shape(&mut self, pts: &[(f32, f32)], closed: bool, m: Affine, s: &Style) {
        if pts.len() < 2 {
            return;
        }
        let px: Vec<Point> = pts.iter().map(|&(x, y)| m.apply(x, y)).collect();
        if closed && pts.len() >= 3 {
            if let Some(c) = s.fill {
                self.fill(
                    std::slice::from_ref(&px),
                    false,
                    c,
                    s.opacity * s.fill_opacity,
                );
            }
        }
        if let Some(c) = s.stroke {
            let w = s.stroke_width * m.stretch();
            if w <= 0.0 {
                return;
            }
            let pattern: Vec<f32> = s.dash.iter().map(|d| d * m.stretch()).collect();
            let mut contours = Vec::new();
            for piece in dashes(&px, closed, &pattern) {
                let whole = closed && s.dash.is_empty();
                contours.extend(stroke_outline(&piece, whole, w));
            }
            self.fill(&contours, true, c, s.opacity * s.stroke_opacity);
        }
    }

    /// Fills contours (pixels). With `union`, each is turned to one orientation so that
    /// overlapping pieces (a stroke's segments and joints) add up to their union.
    fn fill(&mut self, contours: &[Contour], union: bool, rgb: [u8; 3], alpha: f32) {
        let segs: Vec<[Point; 2]> = contours
            .iter()
            .filter(|c| c.len() >= 3)
            .flat_map(|c| {
                let flip = union && area2(c) < 0.0;
                (0..c.len()).map(move |i| {
                    let (p, q) = (c[i], c[(i + 1) % c.len()]);
                    if flip {
                        [q, p]
                    } else {
                        [p, q]
                    }
                })
            })
            .collect();
        let curves: Vec<Curve> = segs.iter().map(|s| Curve::Line(s[0], s[1])).collect();
        self.fill_curves(&curves, rgb, alpha);
    }

    fn fill_curves(&mut self, curves: &[Curve], rgb: [u8; 3], alpha: f32) {
        if alpha <= 0.0 || curves.is_empty() {
            return;
        }
        let (mut x0, mut y0, mut x1, mut y1) = (f32::MAX, f32::MAX, f32::MIN, f32::MIN);
        for c in curves {
            for p in c.points() {
                if !(p.x.is_finite() && p.y.is_finite()) {
                    return;
                }
                x0 = x0.min(p.x);
                y0 = y0.min(p.y);
                x1 = x1.max(p.x);
                y1 = y1.max(p.y);
            }
        }
        let (iw, ih) = (self.img.width() as f32, self.img.height() as f32);
        if x1 < 0.0 || y1 < 0.0 || x0 > iw || y0 > ih {
            return;
        }
        let (ox, oy) = (x0.floor() - 1.0, y0.floor() - 1.0);
        let (w, h) = ((x1 - ox).ceil() as usize + 2, (y1 - oy).ceil() as usize + 2);
        if w as u64 * h as u64 > 200_000_000 {
            return;
        }
        let mut r = Rasterizer::new(w, h);
        let at = |p: Point| point(p.x - ox, p.y - oy);
        for c in curves {
            match *c {
                Curve::Line(p, q) => r.draw_line(at(p), at(q)),
                Curve::Quad(p, q, s) => r.draw_quad(at(p), at(q), at(s)),
                Curve::Cubic(p, q, s, t) => r.draw_cubic(at(p), at(q), at(s), at(t)),
            }
        }
        let img = &mut self.img;
        let (iw, ih) = (img.width() as i64, img.height() as i64);
        r.for_each_pixel_2d(|x, y, cover| {
            let a = cover.min(1.0) * alpha;
            if a <= 1.0 / 512.0 {
                return;
            }
            let (px, py) = (x as i64 + ox as i64, y as i64 + oy as i64);
            if px < 0 || py < 0 || px >= iw || py >= ih {
                return;
            }
            let pixel = img.get_pixel_mut(px as u32, py as u32);
            for (p, &q) in pixel.0.iter_mut().zip(&rgb) {
                *p = (*p as f32 * (1.0 - a) + q as f32 * a)
                    .round()
                    .clamp(0.0, 255.0) as u8;
            }
        });
    }

    fn text(&mut self, n: roxmltree::Node, m: Affine, s: &Style) {
        let Some(colour) = s.fill else { return };
        let raw: String = n
            .descendants()
            .filter(|d| d.is_text())
            .filter_map(|d| d.text())
            .collect();
        // SVG's default white-space handling: newlines go, runs of spaces become one, the ends
        // are trimmed.
        let text = raw
            .replace('\n', "")
            .replace('\t', " ")
            .split(' ')
            .filter(|w| !w.is_empty())
            .collect::<Vec<_>>()
            .join(" ");
        if text.is_empty() {
            return;
        }
        let size = s.font_size;
        let font = &self.font;
        let upem = font.units_per_em().unwrap_or(2048.0);
        let k = size / upem;
        let x_height = font
            .outline(font.glyph_id('x'))
            .map(|o| o.bounds.max.y / upem)
            .unwrap_or(0.55);
        let dy = match n.attribute("dy").map(str::trim) {
            Some(v) if v.ends_with("ex") => v
                .trim_end_matches("ex")
                .parse::<f32>()
                .map(|e| e * x_height * size)
                .unwrap_or(0.0),
            Some(v) => length(v, size).unwrap_or(0.0),
            None => 0.0,
        };
        let x = n
            .attribute("x")
            .and_then(|v| length(v, size))
            .unwrap_or(0.0);
        let y = n
            .attribute("y")
            .and_then(|v| length(v, size))
            .unwrap_or(0.0)
            + dy;
        let mut glyphs = Vec::new();
        let mut pen = 0.0f32;
        let mut prev = None;
        for ch in text.chars() {
            let id = font.glyph_id(ch);
            if let Some(p) = prev {
                pen += font.kern_unscaled(p, id);
            }
            glyphs.push((id, pen));
            pen += font.h_advance_unscaled(id);
            prev = Some(id);
        }
        let width = pen * k;
        let start = match s.anchor {
            Anchor::Start => x,
            Anchor::Middle => x - 0.5 * width,
            Anchor::End => x - width,
        };
        let mut curves = Vec::new();
        let passes: &[f32] = if s.bold { &[0.0, 0.045] } else { &[0.0] };
        for &shift in passes {
            for &(id, at) in &glyphs {
                let Some(outline) = font.outline(id) else {
                    continue;
                };
                let map = |p: &ab_glyph::Point| {
                    m.apply(start + (at + p.x) * k + shift * size, y - p.y * k)
                };
                for c in &outline.curves {
                    curves.push(match c {
                        OutlineCurve::Line(a, b) => Curve::Line(map(a), map(b)),
                        OutlineCurve::Quad(a, b, c) => Curve::Quad(map(a), map(b), map(c)),
                        OutlineCurve::Cubic(a, b, c, d) => {
                            Curve::Cubic(map(a), map(b), map(c), map(d))
                        }
                    });
                }
            }
        }
        self.fill_curves(&curves, colour, s.opacity * s.fill_opacity);
    }

    /// An embedded PNG (`href` or `xlink:href` with a data URL), drawn into its box with
    /// bilinear sampling; only translation and scaling of the box are honoured.
    fn image(&mut self, n: roxmltree::Node, m: Affine, s: &Style) {
        let href = n
            .attribute("href")
            .or_else(|| n.attribute(("http://www.w3.org/1999/xlink", "href")));
        let Some(data) = href.and_then(|h| h.strip_prefix("data:image/png;base64,")) else {
            return;
        };
        let Ok(bytes) = base64::engine::general_purpose::STANDARD.decode(data.trim()) else {
            return;
        };
        let Ok(src) = image::load_from_memory_with_format(&bytes, image::ImageFormat::Png) else {
            return;
        };
        let src = src.to_rgba8();
        let num = |name: &str| {
            n.attribute(name)
                .and_then(|v| length(v, s.font_size))
                .unwrap_or(0.0)
        };
        let (x, y, w, h) = (num("x"), num("y"), num("width"), num("height"));
        if w <= 0.0 || h <= 0.0 || src.width() == 0 || src.height() == 0 {
            return;
        }
        let (p0, p1) = (m.apply(x, y), m.apply(x + w, y + h));
        let (dx0, dy0, dx1, dy1) = (
            p0.x.min(p1.x),
            p0.y.min(p1.y),
            p0.x.max(p1.x),
            p0.y.max(p1.y),
        );
        let (sw, sh) = (src.width() as f32, src.height() as f32);
        let (iw, ih) = (self.img.width() as f32, self.img.height() as f32);
        let sample = |u: f32, v: f32| -> [f32; 4] {
            let (u, v) = (
                (u - 0.5).clamp(0.0, sw - 1.0),
                (v - 0.5).clamp(0.0, sh - 1.0),
            );
            let (i, j) = (u.floor() as u32, v.floor() as u32);
            let (i1, j1) = ((i + 1).min(src.width() - 1), (j + 1).min(src.height() - 1));
            let (fu, fv) = (u - i as f32, v - j as f32);
            let mut out = [0.0; 4];
            for (k, o) in out.iter_mut().enumerate() {
                let g = |a: u32, b: u32| src.get_pixel(a, b).0[k] as f32;
                *o = (g(i, j) * (1.0 - fu) + g(i1, j) * fu) * (1.0 - fv)
                    + (g(i, j1) * (1.0 - fu) + g(i1, j1) * fu) * fv;
            }
            out
        };
        let (ya, yb) = (dy0.floor().max(0.0) as u32, dy1.ceil().min(ih) as u32);
        let (xa, xb) = (dx0.floor().max(0.0) as u32, dx1.ceil().min(iw) as u32);
        for py in ya..yb {
            for px in xa..xb {
                let (cx, cy) = (px as f32 + 0.5, py as f32 + 0.5);
                if cx < dx0 || cx > dx1 || cy < dy0 || cy > dy1 {
                    continue;
                }
                let u = (cx - dx0) / (dx1 - dx0) * sw;
                let v = (cy - dy0) / (dy1 - dy0) * sh;
                let c = sample(u, v);
                let a = c[3] / 255.0 * s.opacity;
                let pixel = self.img.get_pixel_mut(px, py);
                for (p, &q) in pixel.0.iter_mut().zip(&c[..3]) {
                    *p = (*p as f32 * (1.0 - a) + q * a).round().clamp(0.0, 255.0) as u8;
                }
            }
        }
    }
}

#[derive(Clone, Copy, Debug)]
enum Curve {
    Line(Point, Point),
    Quad(Point, Point, Point),
    Cubic(Point, Point, Point, Point),
}

impl Curve {
    fn points(&self) -> Vec<Point> {
        match *self {
            Curve::Line(a, b) => vec![a, b],
            Curve::Quad(a, b, c) => vec![a, b, c],
            Curve::Cubic(a, b, c, d) => vec![a, b, c, d],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(img: &image::RgbImage, x: u32, y: u32) -> [u8; 3] {
        img.get_pixel(x, y).0
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
        // An edge half across a pixel is drawn half covered.
        let svg = r##"<svg width="4" height="4"><rect x="1.5" y="0" width="2" height="4" fill="#000000"/></svg>"##;
        let img = render(svg, 1.0).unwrap();
        let v = at(&img, 1, 2)[0];
        assert!((126..=129).contains(&v), "{v}");
        assert_eq!(at(&img, 2, 2), [0, 0, 0]);
    }

    #[test]
    fn text_is_drawn_at_its_anchor_and_rotated_text_runs_upwards() {
        let svg = r##"<svg width="200" height="200">
<text x="100" y="50" dy="0.76em" text-anchor="middle" font-family="sans-serif" font-size="20" fill="#000000">
MMMM
</text>
<text x="30" y="150" dy="0.5ex" text-anchor="middle" font-size="20" fill="#000000" transform="rotate(270, 30, 150)">MMMMMM</text>
</svg>"##;
        let img = render(svg, 1.0).unwrap();
        let dark = |x0: u32, x1: u32, y0: u32, y1: u32| {
            (y0..y1)
                .flat_map(|y| (x0..x1).map(move |x| (x, y)))
                .filter(|&(x, y)| at(&img, x, y)[0] < 128)
                .collect::<Vec<_>>()
        };
        // "MMMM" in DejaVu Sans at 20 px is about 69 px wide, centred on x = 100, its top at
        // about y = 50 + 0.76 * 20 - 14.6 (cap height 0.73 em) = 50.6.
        let ink = dark(0, 200, 0, 100);
        let (x0, x1) = ink
            .iter()
            .fold((999, 0), |a, p| (a.0.min(p.0), a.1.max(p.0)));
        let (y0, y1) = ink
            .iter()
            .fold((999, 0), |a, p| (a.0.min(p.1), a.1.max(p.1)));
        assert!(
            (63..=68).contains(&x0) && (132..=137).contains(&x1),
            "{x0} {x1}"
        );
        assert!(
            (49..=52).contains(&y0) && (63..=67).contains(&y1),
            "{y0} {y1}"
        );
        // Rotated by 270 degrees about (30, 150): the six Ms run up the picture, tall and
        // narrow, centred on y = 150.
        let ink = dark(0, 100, 100, 200);
        let (x0, x1) = ink
            .iter()
            .fold((999, 0), |a, p| (a.0.min(p.0), a.1.max(p.0)));
        let (y0, y1) = ink
            .iter()
            .fold((999, 0), |a, p| (a.0.min(p.1), a.1.max(p.1)));
        assert!(y1 - y0 > 90 && x1 - x0 < 20, "{x0}..{x1} x {y0}..{y1}");
        assert!(((y0 + y1) / 2).abs_diff(150) <= 2, "{y0} {y1}");
    }

    #[test]
    fn dashes_alternate_and_images_are_scaled_into_their_box() {
        let svg = r##"<svg width="100" height="20"><line x1="0" y1="10" x2="100" y2="10" stroke="#000000" stroke-width="4" stroke-dasharray="10,10"/></svg>"##;
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
        let data = base64::engine::general_purpose::STANDARD.encode(png);
        let svg = format!(
            r##"<svg width="60" height="30"><image x="10" y="5" width="40" height="20" href="data:image/png;base64,{data}"/></svg>"##
        );
        let img = render(&svg, 1.0).unwrap();
        assert_eq!(at(&img, 12, 15), [255, 0, 0]);
        assert_eq!(at(&img, 48, 15), [0, 0, 255]);
        assert_eq!(at(&img, 5, 15), [255, 255, 255]);
        assert_eq!(at(&img, 30, 28), [255, 255, 255]);
    }

    #[test]
    fn transforms_compose() {
        let m = transform("translate(10, 20) rotate(90)");
        let p = m.apply(1.0, 0.0);
        assert!(
            (p.x - 10.0).abs() < 1e-5 && (p.y - 21.0).abs() < 1e-5,
            "{p:?}"
        );
        let m = transform("rotate(180, 5, 5)");
        let p = m.apply(0.0, 0.0);
        assert!(
            (p.x - 10.0).abs() < 1e-5 && (p.y - 10.0).abs() < 1e-5,
            "{p:?}"
        );
    }
}
