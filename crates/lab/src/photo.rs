//! The angle of repose from a side photo of a heap, measured the way labs do and the way the
//! virtual test measures its particle heap: greyscale, a threshold (Otsu's or the iterative
//! one), the heap as the largest connected region with its holes filled, its outline (the top
//! heap pixel of each column), and a straight line fitted to each flank between 15 % and 85 % of
//! the heap's height, which leaves out the toe and the rounded apex. Pixels become degrees with
//! the camera level and square pixels. A plate the heap stands on is found first and the heap
//! measured above its top edge ([`crate::plate`]): taken into the heap, it made the flanks
//! 5-14 deg too low.

use image::{GrayImage, Luma, Rgb, RgbImage};
use imageproc::region_labelling::{connected_components, Connectivity};

use crate::plate::{self, Plate};

/// How the heap is told from its background.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Threshold {
    Otsu,
    /// Ridler and Calvard's iterative mean of the two classes.
    Iterative,
}

/// Which side of the threshold the background is on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Background {
    /// The class that holds most of the image's border.
    Auto,
    Light,
    Dark,
}

/// How to measure.
#[derive(Clone, Debug)]
pub struct PhotoSettings {
    pub threshold: Threshold,
    pub background: Background,
    /// Part of the photo to use: x, y, width, height in pixels.
    pub crop: Option<(u32, u32, u32, u32)>,
    /// Heights (fractions of the heap's) between which the flanks are fitted.
    pub fit_band: (f64, f64),
    /// Look for a plate below the heap and measure above it (`--no-plate` turns it off).
    pub find_plate: bool,
}

impl Default for PhotoSettings {
    fn default() -> Self {
        PhotoSettings {
            threshold: Threshold::Otsu,
            background: Background::Auto,
            crop: None,
            fit_band: (0.15, 0.85),
            find_plate: true,
        }
    }
}

/// A flank's fitted line, in pixels: height above the base = intercept + slope * column.
#[derive(Clone, Debug, serde::Serialize)]
pub struct FlankFit {
    pub angle_deg: f64,
    pub slope: f64,
    pub intercept: f64,
    /// Columns used in the fit.
    pub points: usize,
    /// Root-mean-square distance of the outline from the line (pixels, vertical).
    pub rms_px: f64,
}

/// What a photo gave.
#[derive(Clone, Debug, serde::Serialize)]
pub struct PhotoAngle {
    pub left_deg: f64,
    pub right_deg: f64,
    pub mean_deg: f64,
    pub left: FlankFit,
    pub right: FlankFit,
    /// The threshold used (0-255) and the heap's size in pixels.
    pub threshold: u8,
    pub heap_height_px: u32,
    pub heap_width_px: u32,
    /// Image row of the heap's base and column of its apex (in the cropped image).
    pub base_row: u32,
    pub apex_column: u32,
    /// The plate found below the heap, whose top edge is the heap's base line (the heap was
    /// measured on the rows above it), or None.
    pub plate: Option<Plate>,
    /// What the search for the base line did, in words.
    pub base_line: String,
    /// The top heap pixel of each column (row), None where the column has no heap.
    #[serde(skip)]
    pub outline: Vec<Option<u32>>,
}

/// The largest photo measured, in pixels (64 megapixels: 8 000 x 8 000). Measuring takes about
/// 17 bytes a pixel (the colour image, its grey copy, the plate search's blurred copy, the part
/// above the plate, the region labels), so this bounds it near 1.1 GB; a larger photo is refused
/// before it is decoded.
#[cfg(not(fuzzing))]
pub const MAX_PIXELS: u64 = 64_000_000;
/// Under the fuzzer (`--cfg fuzzing`) 100 000 pixels, so that each input is measured in
/// milliseconds (at a megapixel the target ran 140 inputs a second) and the refusal is fuzzed.
#[cfg(fuzzing)]
pub const MAX_PIXELS: u64 = 100_000;

/// The largest photo file read (256 MiB).
pub const MAX_FILE_BYTES: u64 = 256 << 20;

/// Decodes a photo (PNG or JPEG, told from its first bytes). Its size is read from its header
/// and refused above `MAX_PIXELS` before any pixel is decoded.
pub fn decode(bytes: &[u8]) -> Result<image::DynamicImage, String> {
    use image::ImageDecoder;
    // The decoders' messages may span lines (a JPEG's I/O error does).
    let unreadable = |e: &dyn std::fmt::Display| {
        let words: Vec<String> = e
            .to_string()
            .split_whitespace()
            .map(str::to_string)
            .collect();
        format!("cannot read the image: {}", words.join(" "))
    };
    // The JPEG decoder fills a file cut short with grey and says nothing (half a photo measured
    // 7 deg against the whole one's 30): a complete JPEG has its end marker after its last scan
    // (inside a scan every 0xFF byte is followed by 0x00, so the marker cannot occur there).
    if bytes.starts_with(&[0xFF, 0xD8]) {
        let last_scan = bytes.windows(2).rposition(|w| w == [0xFF, 0xDA]);
        let end = bytes.windows(2).rposition(|w| w == [0xFF, 0xD9]);
        if !matches!((last_scan, end), (Some(s), Some(e)) if e > s) {
            return Err("cannot read the image: the JPEG is cut short (no end-of-image marker after its last scan)".into());
        }
    }
    let mut reader = image::ImageReader::new(std::io::Cursor::new(bytes))
        .with_guessed_format()
        .map_err(|e| unreadable(&e))?;
    let mut limits = image::Limits::default();
    limits.max_alloc = Some(MAX_PIXELS * 8);
    reader.limits(limits);
    let decoder = reader.into_decoder().map_err(|e| unreadable(&e))?;
    let (w, h) = decoder.dimensions();
    if u64::from(w) * u64::from(h) > MAX_PIXELS {
        return Err(format!(
            "the image is {w} x {h} pixels; at most {MAX_PIXELS} pixels are measured: scale it down or crop it"
        ));
    }
    if w == 0 || h == 0 {
        return Err(format!("the image is {w} x {h} pixels: it is empty"));
    }
    image::DynamicImage::from_decoder(decoder).map_err(|e| unreadable(&e))
}

/// Reads and decodes the photo at `path` (see `decode`); a file over `MAX_FILE_BYTES` is
/// refused before it is read.
pub fn open(path: &std::path::Path) -> Result<image::DynamicImage, String> {
    let name = path.display();
    let meta = std::fs::metadata(path).map_err(|e| format!("{name}: cannot read: {e}"))?;
    if !meta.is_file() {
        return Err(format!("{name}: not a plain file"));
    }
    if meta.len() > MAX_FILE_BYTES {
        return Err(format!(
            "{name}: the file is {} bytes; photos up to {MAX_FILE_BYTES} bytes are read",
            meta.len()
        ));
    }
    let bytes = std::fs::read(path).map_err(|e| format!("{name}: cannot read: {e}"))?;
    decode(&bytes).map_err(|e| format!("{name}: {e}"))
}

/// Measures the heap in `image` (any colour type; it is made grey): within `--crop`, above the
/// plate the heap stands on when one is found.
pub fn measure(image: &image::DynamicImage, s: &PhotoSettings) -> Result<PhotoAngle, String> {
    let grey = cropped_grey(image, s)?;
    let found = if s.find_plate {
        plate::find(&grey)
    } else {
        None
    };
    let Some(p) = found else {
        let mut a = measure_grey(&grey, s)?;
        a.base_line = if s.find_plate {
            "no plate found below the heap: the whole photo measured".into()
        } else {
            "no plate looked for (--no-plate): the whole photo measured".into()
        };
        return Ok(a);
    };
    let above = image::imageops::crop_imm(&grey, 0, 0, grey.width(), p.top_row).to_image();
    let within = if s.crop.is_some() { " of the crop" } else { "" };
    let base_line = format!(
        "base line found at row {}{within} (a plate {} px high, {} px wide, grey {:.2}, below the heap): measured above it",
        p.top_row, p.height_px, p.width_px, p.grey
    );
    let mut a = measure_grey(&above, s).map_err(|e| {
        format!("{e} ({base_line}; --no-plate measures the whole photo, --crop a part of it)")
    })?;
    a.plate = Some(p);
    a.base_line = base_line;
    Ok(a)
}

/// The photo made grey and cropped to `--crop`, refused when too small to hold a heap.
fn cropped_grey(image: &image::DynamicImage, s: &PhotoSettings) -> Result<GrayImage, String> {
    let mut grey = image.to_luma8();
    if let Some((x, y, w, h)) = s.crop {
        let (iw, ih) = grey.dimensions();
        if w == 0 || h == 0 || x.saturating_add(w) > iw || y.saturating_add(h) > ih {
            return Err(format!(
                "--crop {x},{y},{w},{h}: outside the {iw} x {ih} pixel image"
            ));
        }
        grey = image::imageops::crop_imm(&grey, x, y, w, h).to_image();
    }
    let (w, h) = grey.dimensions();
    if w < 16 || h < 16 {
        return Err(format!(
            "the image is {w} x {h} pixels: too small to measure a heap"
        ));
    }
    Ok(grey)
}

/// Measures the heap in `grey` (already cropped): threshold, the heap region with its holes
/// filled, its outline and a line fitted to each flank.
fn measure_grey(grey: &GrayImage, s: &PhotoSettings) -> Result<PhotoAngle, String> {
    let (w, h) = grey.dimensions();
    let level = match s.threshold {
        Threshold::Otsu => imageproc::contrast::otsu_level(grey),
        Threshold::Iterative => iterative_level(grey),
    };
    let dark = |p: &Luma<u8>| p[0] <= level;
    // The background is the class that holds most of the border unless told.
    let dark_background = match s.background {
        Background::Dark => true,
        Background::Light => false,
        Background::Auto => {
            let border: Vec<&Luma<u8>> = (0..w)
                .flat_map(|x| [grey.get_pixel(x, 0), grey.get_pixel(x, h - 1)])
                .chain((0..h).flat_map(|y| [grey.get_pixel(0, y), grey.get_pixel(w - 1, y)]))
                .collect();
            2 * border.iter().filter(|p| dark(p)).count() > border.len()
        }
    };
    let mask = GrayImage::from_fn(w, h, |x, y| {
        let heap = dark(grey.get_pixel(x, y)) != dark_background;
        Luma([if heap { 255 } else { 0 }])
    });
    // The heap: the largest region; holes (background not reaching the border) are heap too.
    let labels = connected_components(&mask, Connectivity::Eight, Luma([0u8]));
    let mut sizes = std::collections::HashMap::<u32, usize>::new();
    for p in labels.pixels() {
        if p[0] != 0 {
            *sizes.entry(p[0]).or_default() += 1;
        }
    }
    let Some((&heap_label, _)) = sizes
        .iter()
        .max_by_key(|(l, n)| (**n, std::cmp::Reverse(**l)))
    else {
        return Err(format!(
            "no heap found: every pixel is on one side of the threshold ({level})"
        ));
    };
    let inverse = GrayImage::from_fn(w, h, |x, y| {
        Luma([if labels.get_pixel(x, y)[0] == heap_label {
            0
        } else {
            255
        }])
    });
    let holes = connected_components(&inverse, Connectivity::Four, Luma([0u8]));
    let mut outside = std::collections::HashSet::new();
    for x in 0..w {
        outside.insert(holes.get_pixel(x, 0)[0]);
        outside.insert(holes.get_pixel(x, h - 1)[0]);
    }
    for y in 0..h {
        outside.insert(holes.get_pixel(0, y)[0]);
        outside.insert(holes.get_pixel(w - 1, y)[0]);
    }
    let is_heap = |x: u32, y: u32| {
        labels.get_pixel(x, y)[0] == heap_label || !outside.contains(&holes.get_pixel(x, y)[0])
    };
    let outline: Vec<Option<u32>> = (0..w).map(|x| (0..h).find(|&y| is_heap(x, y))).collect();
    let base_row = (0..h)
        .rev()
        .find(|&y| (0..w).any(|x| is_heap(x, y)))
        .unwrap_or(0);
    let top = outline.iter().flatten().copied().min().unwrap_or(base_row);
    let height = base_row - top + 1;
    let columns: Vec<u32> = (0..w).filter(|&x| outline[x as usize].is_some()).collect();
    let heap_width = columns.len() as u32;
    if height < 8 || heap_width < 16 {
        return Err(format!(
            "the heap found is {heap_width} x {height} pixels: too small to fit its flanks (check the threshold {level}, --background and --crop)"
        ));
    }
    // The apex: the middle of the columns that reach the top row.
    let tops: Vec<u32> = columns
        .iter()
        .copied()
        .filter(|&x| outline[x as usize] == Some(top))
        .collect();
    let apex = tops[tops.len() / 2];
    let rise = |x: u32| (base_row - outline[x as usize].unwrap_or(base_row) + 1) as f64;
    let (lo, hi) = (s.fit_band.0 * height as f64, s.fit_band.1 * height as f64);
    let band = |xs: Vec<u32>| -> Vec<(f64, f64)> {
        xs.into_iter()
            .filter(|&x| outline[x as usize].is_some())
            .map(|x| (x as f64, rise(x)))
            .filter(|(_, z)| *z >= lo && *z <= hi)
            .collect()
    };
    let left = fit(&band((0..apex).collect()), "left")?;
    let right = fit(&band((apex + 1..w).collect()), "right")?;
    Ok(PhotoAngle {
        left_deg: left.angle_deg,
        right_deg: right.angle_deg,
        mean_deg: 0.5 * (left.angle_deg + right.angle_deg),
        left,
        right,
        threshold: level,
        heap_height_px: height,
        heap_width_px: heap_width,
        base_row,
        apex_column: apex,
        plate: None,
        base_line: String::new(),
        outline,
    })
}

/// The least-squares line through a flank's (column, height) points.
fn fit(points: &[(f64, f64)], side: &str) -> Result<FlankFit, String> {
    if points.len() < 3 {
        return Err(format!(
            "the {side} flank has {} columns between 15 % and 85 % of the heap's height: too few to fit (is the heap cut off by the image or --crop?)",
            points.len()
        ));
    }
    let n = points.len() as f64;
    let (mx, mz) = points
        .iter()
        .fold((0.0, 0.0), |(a, b), (x, z)| (a + x / n, b + z / n));
    let sxx: f64 = points.iter().map(|(x, _)| (x - mx) * (x - mx)).sum();
    let sxz: f64 = points.iter().map(|(x, z)| (x - mx) * (z - mz)).sum();
    let slope = sxz / sxx;
    let intercept = mz - slope * mx;
    let rms = (points
        .iter()
        .map(|(x, z)| (z - intercept - slope * x).powi(2))
        .sum::<f64>()
        / n)
        .sqrt();
    Ok(FlankFit {
        angle_deg: slope.abs().atan().to_degrees(),
        slope,
        intercept,
        points: points.len(),
        rms_px: rms,
    })
}

/// Ridler and Calvard's threshold: the mean of the two classes' means, until it stops moving.
pub fn iterative_level(grey: &GrayImage) -> u8 {
    let mut hist = [0u64; 256];
    for p in grey.pixels() {
        hist[p[0] as usize] += 1;
    }
    let mean = |range: std::ops::Range<usize>| -> Option<f64> {
        let n: u64 = hist[range.clone()].iter().sum();
        (n > 0).then(|| range.map(|i| i as f64 * hist[i] as f64).sum::<f64>() / n as f64)
    };
    let mut t = mean(0..256).unwrap_or(128.0);
    for _ in 0..256 {
        let cut = t.floor() as usize + 1;
        let next = match (mean(0..cut.min(256)), mean(cut.min(256)..256)) {
            (Some(a), Some(b)) => 0.5 * (a + b),
            _ => break,
        };
        if (next - t).abs() < 0.5 {
            t = next;
            break;
        }
        t = next;
    }
    t.clamp(0.0, 255.0) as u8
}

/// The photo (greyscale, cropped as measured) with the outline in red, the fitted lines in
/// green, from the base to the apex's height, and the plate's top edge (the base line the heap
/// was measured above) in blue across the photo, for a person to check the measurement.
pub fn debug_picture(image: &image::DynamicImage, s: &PhotoSettings, a: &PhotoAngle) -> RgbImage {
    let mut grey = image.to_luma8();
    if let Some((x, y, w, h)) = s.crop {
        grey = image::imageops::crop_imm(&grey, x, y, w, h).to_image();
    }
    let mut out = RgbImage::from_fn(grey.width(), grey.height(), |x, y| {
        let g = grey.get_pixel(x, y)[0];
        Rgb([g, g, g])
    });
    for (x, top) in a.outline.iter().enumerate() {
        if let Some(y) = top {
            out.put_pixel(x as u32, *y, Rgb([230, 30, 30]));
        }
    }
    if let Some(p) = &a.plate {
        // Two rows thick, on the plate: the heap's last row stays visible above it.
        for y in p.top_row..(p.top_row + 2).min(out.height()) {
            for x in 0..out.width() {
                out.put_pixel(x, y, Rgb([40, 90, 230]));
            }
        }
    }
    let row = |z: f64| a.base_row as f64 + 1.0 - z;
    for f in [&a.left, &a.right] {
        // Where the line meets the base and the heap's top.
        let x0 = -f.intercept / f.slope;
        let x1 = (a.heap_height_px as f64 - f.intercept) / f.slope;
        for d in [-1.0f32, 0.0, 1.0] {
            imageproc::drawing::draw_line_segment_mut(
                &mut out,
                (x0 as f32 + d, row(0.0) as f32),
                (x1 as f32 + d, row(a.heap_height_px as f64) as f32),
                Rgb([30, 200, 60]),
            );
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_iterative_threshold_splits_two_levels() {
        let img = GrayImage::from_fn(100, 100, |x, _| Luma([if x < 40 { 40 } else { 200 }]));
        let t = iterative_level(&img);
        assert!((40..200).contains(&t), "{t}");
        let f = fit(&[(0.0, 1.0), (1.0, 3.0), (2.0, 5.0)], "left").unwrap();
        assert!((f.slope - 2.0).abs() < 1e-12 && f.rms_px < 1e-12);
        assert!(fit(&[(0.0, 1.0)], "left").unwrap_err().contains("too few"));
    }

    /// A PNG whose header declares `w` x `h` pixels, with one byte of image data.
    fn png_declaring(w: u32, h: u32) -> Vec<u8> {
        fn crc32(bytes: &[u8]) -> u32 {
            let mut c = !0u32;
            for &b in bytes {
                c ^= u32::from(b);
                for _ in 0..8 {
                    c = if c & 1 != 0 {
                        0xEDB8_8320 ^ (c >> 1)
                    } else {
                        c >> 1
                    };
                }
            }
            !c
        }
        let chunk = |kind: &[u8], data: &[u8]| {
            let mut out = (data.len() as u32).to_be_bytes().to_vec();
            let body = [kind, data].concat();
            out.extend_from_slice(&body);
            out.extend_from_slice(&crc32(&body).to_be_bytes());
            out
        };
        let mut ihdr = w.to_be_bytes().to_vec();
        ihdr.extend_from_slice(&h.to_be_bytes());
        ihdr.extend_from_slice(&[8, 2, 0, 0, 0]);
        [
            b"\x89PNG\r\n\x1a\n".to_vec(),
            chunk(b"IHDR", &ihdr),
            chunk(b"IDAT", &[0x78, 0x9c, 0x03, 0x00, 0x00, 0x00, 0x00, 0x01]),
            chunk(b"IEND", &[]),
        ]
        .concat()
    }

    #[test]
    fn a_photo_past_the_pixel_limit_is_refused_from_its_header() {
        // 100 000 x 100 000 RGB would be 30 GB decoded.
        let e = decode(&png_declaring(100_000, 100_000)).unwrap_err();
        assert!(
            e.contains("100000 x 100000") && e.contains("64000000"),
            "{e}"
        );
        // Just under the limit the header is accepted and the missing data is the error.
        let e = decode(&png_declaring(8_000, 8_000)).unwrap_err();
        assert!(e.contains("cannot read the image"), "{e}");
        assert!(decode(b"not an image")
            .unwrap_err()
            .contains("cannot read the image"));
    }

    #[test]
    fn a_jpeg_cut_short_is_refused() {
        let mut jpeg = Vec::new();
        let img = image::RgbImage::from_fn(64, 48, |x, y| {
            image::Rgb([(x * 4) as u8, (y * 5) as u8, 90])
        });
        image::DynamicImage::ImageRgb8(img)
            .write_to(
                &mut std::io::Cursor::new(&mut jpeg),
                image::ImageFormat::Jpeg,
            )
            .unwrap();
        assert!(decode(&jpeg).is_ok());
        let e = decode(&jpeg[..jpeg.len() / 2]).unwrap_err();
        assert!(e.contains("the JPEG is cut short"), "{e}");
    }

    #[test]
    fn a_damaged_jpeg_is_refused_in_one_line() {
        // Found by the `image` fuzz target: the JPEG decoder's message had a line break.
        let e = decode(include_bytes!("../tests/data/fuzz-jpeg-two-line-error.jpg")).unwrap_err();
        assert!(
            e.starts_with("cannot read the image: ") && !e.contains('\n'),
            "{e:?}"
        );
    }
}
