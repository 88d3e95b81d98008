//! The lab side of a calibration, as `demcal lab ...`: the angle of repose measured on a side
//! photo of a real heap the same way the virtual test measures its particle heap ([`photo`]),
//! and the small formulas labs use to turn their measurements into model inputs ([`formulas`]).
//! A photo's base plate is found by [`plate`], so that the heap is measured above it.
//!
//! Design note: the image work uses the `image` and `imageproc` crates (Otsu's threshold,
//! connected regions, a box blur, line drawing); written here are the flank fit, because it must
//! be the virtual test's (a least-squares line between 15 % and 85 % of the heap height per
//! flank), and the plate search, which no crate offers (rows of one width below the heap).

pub mod formulas;
pub mod photo;
pub mod plate;
