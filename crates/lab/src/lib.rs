//! The lab side of a calibration, as `demcal lab ...`: the angle of repose measured on a side
//! photo of a real heap the same way the virtual test measures its particle heap ([`photo`]),
//! and the small formulas labs use to turn their measurements into model inputs ([`formulas`]).
//!
//! Design note: the image work uses the `image` and `imageproc` crates (Otsu's threshold,
//! connected regions, line drawing); only the flank fit is written here, because it must be the
//! virtual test's (a least-squares line between 15 % and 85 % of the heap height per flank).

pub mod formulas;
pub mod photo;
