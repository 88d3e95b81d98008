//! Designed experiments, the Design-Expert part of demcal.
//!
//! So far: factors with coded <-> actual mapping (linear or logarithmic) and the design generators
//! of `shared/spec/calibration.md` (Plackett-Burman, regular two-level factorials with generators and
//! aliases, central composite, Box-Behnken, Latin hypercube), each returning coded runs that
//! [`Design::randomised`] can shuffle with a recorded seed. Regression, ANOVA and desirability
//! optimisation come next (issue 3).

pub mod design;
pub mod factor;

pub use design::Design;
pub use factor::{Factor, Scale};
