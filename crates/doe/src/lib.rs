//! Designed experiments, the Design-Expert part of demcal.
//!
//! Factors with coded <-> actual mapping (linear or logarithmic); the design generators of
//! `docs/calibration.md` (Plackett-Burman, regular two-level factorials with generators and
//! aliases, central composite, Box-Behnken, Latin hypercube, steepest paths), each returning coded
//! runs that [`Design::run_order`] shuffles with a recorded seed; least-squares response-surface
//! models with Design-Expert's ANOVA ([`Fit`]); desirability optimisation ([`optimize`]); and SVG
//! plots of a fit ([`plots`]).

pub mod commands;
pub mod data;
pub mod design;
pub mod diagnostics;
pub mod experiment;
pub mod factor;
pub mod fit;
pub mod fit_report;
pub mod model;
pub mod optimize;
pub mod plots;
pub mod plots_surface;
pub mod raster;
pub mod text_table;

pub use data::DataTable;
pub use design::Design;
pub use experiment::{Experiment, FactorColumns};
pub use factor::{Factor, Scale};
pub use fit::{Curvature, Fit};
pub use model::{ModelOrder, Term};
