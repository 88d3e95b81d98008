//! How much a plan may ask for: beyond these a stage would only eat memory and time.

/// Largest counts of the design stages.
pub const MAX_CENTER_POINTS: usize = 1000;
pub const MAX_STEPS: usize = 1000;
pub const MAX_REPLICATES: usize = 1000;
pub const MAX_SOLUTIONS: usize = 1000;

/// Largest sizes a surrogate stage may ask for.
pub const MAX_SURROGATE_RUNS: usize = 100_000;
pub const MAX_GA: usize = 100_000;
/// Most evaluations of a genetic algorithm (generations × population): the published GA-BP
/// settings are a few thousand; a million takes minutes.
pub const MAX_GA_EVALUATIONS: usize = 1_000_000;
