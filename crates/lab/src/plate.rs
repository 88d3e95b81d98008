//! The plate a photographed heap stands on: found so that the heap is measured above it.
//!
//! Users photograph the heap on its base plate, and the plate is seldom the background's grey.
//! One threshold over the whole photo then takes the plate into the heap (the flanks came out
//! 5-14 deg too low: the heap's height and outline included the plate), or, when the plate is
//! lighter than the background and the heap darker, splits the plate from the rest and loses
//! the heap. Measured above the plate's top edge (what `--crop` did by hand) the photo holds
//! only the heap and its background again, and the threshold works as before.
//!
//! How the plate is told from the heap: by the width of what differs from the background, row by
//! row. Going down the photo the heap widens steadily (two pixels a row over tan(angle)); the
//! plate is a band of rows of one constant width, wider than the heap's base, starting at once
//! below the heap. That holds whatever the three greys are (a plate darker or lighter than the
//! heap or the background, or as dark as the heap), needs no threshold between the greys, and no
//! row of a heap on a plain background has it: a heap's rows change width, and below a heap on
//! plain background nothing is left. Grey levels alone would not do: a plate of the heap's grey
//! is common (a dark heap on a dark steel plate), and one row's median grey is the heap's
//! wherever the heap covers most of the photo's width.

use image::GrayImage;

/// The plate found below the heap.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Plate {
    /// The plate's first row (the heap's base line); the heap is measured on the rows above it.
    pub top_row: u32,
    /// Rows from its top edge to where its width changes (or the photo ends).
    pub height_px: u32,
    /// Its width in pixels (the median over its rows).
    pub width_px: u32,
    /// Its median grey, 0 black to 1 white.
    pub grey: f64,
}

/// Radius of the box blur the widths are counted on: it takes pixel noise of a few tens of
/// grey levels down to a few, so that a pixel's difference from the background is its grey's.
const BLUR: u32 = 2;

/// Finds the plate below the heap in `grey`, or None (a heap on plain background, a photo
/// cropped above its plate, or a plate this cannot tell: thinner than 1 % of the photo's height,
/// about as wide as the heap's base, or of the background's grey).
///
/// A row y starts the plate when, with w(y) the number of pixels differing from the background:
/// something stands on it (w at a few rows above, past the blur, is at least 8 pixels: the
/// heap's base); the next rows, 1 % of the photo's height and at least 8, are all wider than
/// that by 2 % of the photo's width (at least 8 pixels): the plate is wider than the heap; and
/// their widths agree within a quarter of a percent of the photo's width (at least 3 pixels),
/// which no heap's rows do: even flanks at 60 deg widen a heap by 9 pixels over 8 rows (at
/// 30 deg by 28), and a rounded apex faster still (with 4 rows and 1 % an apex passed for a
/// plate). The topmost such row is taken, then moved to the exact edge on the mean grey of the
/// columns beside the heap, where the background meets the plate.
pub fn find(grey: &GrayImage) -> Option<Plate> {
    let (w, h) = grey.dimensions();
    if w < 16 || h < 32 {
        return None;
    }
    let blurred = imageproc::filter::box_filter(grey, BLUR, BLUR);
    let (background, tolerance) = background_level(&blurred);
    let differs =
        |x: u32, y: u32| (blurred.get_pixel(x, y)[0] as f64 - background).abs() > tolerance;
    let widths: Vec<u32> = (0..h)
        .map(|y| (0..w).filter(|&x| differs(x, y)).count() as u32)
        .collect();
    let min_rows = (h / 100).max(8);
    let gap = BLUR + 2;
    let jump = (w / 50).max(8);
    let spread = (w / 400).max(3);
    let top = (gap..h.saturating_sub(min_rows)).find(|&y| {
        let stand = widths[(y - gap) as usize];
        let band = &widths[y as usize..(y + min_rows) as usize];
        let (lo, hi) = band
            .iter()
            .fold((u32::MAX, 0), |(lo, hi), &v| (lo.min(v), hi.max(v)));
        stand >= 8 && lo >= stand + jump && hi - lo <= spread
    })?;
    let width = median(&mut widths[top as usize..(top + min_rows) as usize].to_vec());
    // The plate goes on while its rows keep its width.
    let end = (top..h)
        .find(|&y| widths[y as usize].abs_diff(width) > spread)
        .unwrap_or(h);
    let edge = exact_edge(grey, &differs, top, gap, min_rows);
    // Below the heap's base rows only: 16 rows at least stand above the plate for a heap.
    if edge < 16 {
        return None;
    }
    // A histogram, not a list: a plate may be tens of millions of pixels.
    let mut histogram = [0u64; 256];
    for y in edge..end.max(edge + 1).min(h) {
        for x in (0..w).filter(|&x| differs(x, y)) {
            histogram[grey.get_pixel(x, y)[0] as usize] += 1;
        }
    }
    let half = histogram.iter().sum::<u64>() / 2;
    let mut below = 0;
    let plate_grey = histogram
        .iter()
        .position(|&n| {
            below += n;
            below > half
        })
        .unwrap_or(0) as f64
        / 255.0;
    Some(Plate {
        top_row: edge,
        height_px: end.max(edge + 1) - edge,
        width_px: width,
        grey: plate_grey,
    })
}

/// The background's grey (median of the blurred photo's top rows: a heap photo has background
/// above the heap's apex) and how far a pixel's grey must be from it to differ: four times the
/// top rows' noise (median absolute deviation) but at least 10 grey levels.
fn background_level(blurred: &GrayImage) -> (f64, f64) {
    let (w, h) = blurred.dimensions();
    let rows = (h / 32).max(2);
    let mut top: Vec<u32> = (0..rows)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .map(|(x, y)| blurred.get_pixel(x, y)[0] as u32)
        .collect();
    let level = median(&mut top);
    let mut deviations: Vec<u32> = top.iter().map(|v| v.abs_diff(level)).collect();
    let mad = median(&mut deviations) as f64 * 1.4826;
    (level as f64, (4.0 * mad).max(10.0))
}

/// The plate's first row, near `top` (found on blurred widths): where the mean grey of the
/// columns beside the heap (background a few rows above `top`, plate a few rows below) passes
/// half-way from the background's level to the plate's. Where no column is beside the heap
/// (a plate hardly wider than it), all the plate's columns; where the two levels do not differ,
/// `top` itself.
fn exact_edge(
    grey: &GrayImage,
    differs: &dyn Fn(u32, u32) -> bool,
    top: u32,
    gap: u32,
    min_rows: u32,
) -> u32 {
    let w = grey.width();
    let (above, below) = (top - gap, top + min_rows / 2);
    let mut columns: Vec<u32> = (0..w)
        .filter(|&x| !differs(x, above) && differs(x, below))
        .collect();
    if columns.len() < 8 {
        columns = (0..w).filter(|&x| differs(x, below)).collect();
    }
    if columns.is_empty() {
        return top;
    }
    let mean = |y: u32| {
        columns
            .iter()
            .map(|&x| grey.get_pixel(x, y)[0] as f64)
            .sum::<f64>()
            / columns.len() as f64
    };
    let (upper, lower) = (mean(above), mean(below));
    if (upper - lower).abs() < 5.0 {
        return top;
    }
    (above + 1..=below)
        .find(|&y| (mean(y) - upper).abs() > (mean(y) - lower).abs())
        .unwrap_or(top)
}

/// The median (the upper one of an even count); 0 for none.
fn median(v: &mut [u32]) -> u32 {
    if v.is_empty() {
        return 0;
    }
    let k = v.len() / 2;
    *v.select_nth_unstable(k).1
}
