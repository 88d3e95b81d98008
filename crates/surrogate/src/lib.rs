//! Surrogate calibration: the methods published calibrations use when they do not fit a
//! Design-Expert polynomial.
//!
//! - [`gp`]: Gaussian-process regression (Matern 5/2 or squared exponential, one length scale per
//!   factor, constant mean, estimated noise), hyperparameters by maximum likelihood with restarts.
//! - [`bayesopt`]: Bayesian optimisation on a GP, Latin hypercube then batched expected
//!   improvement, so that parallel runs and cluster jobs stay busy.
//! - [`network`]: the BP network of the GA-BP papers (one hidden layer of 2n+1 sigmoid neurons,
//!   Levenberg-Marquardt), [`genetic`]: the genetic algorithm that seeds its weights (GA-BP) and
//!   searches the trained network for the lab value (GA-BP-GA).
//! - [`smc`]: the iterative Bayesian filter of GrainLearning (sequential Monte Carlo with an
//!   effective-sample-size target and Gaussian-mixture resampling), with [`mixture`].
//!
//! Design notes. Every method works on coded factors ([`doe::Factor`], so a factor whose range
//! spans decades is searched on a log scale) and is a pure function of its inputs and a seed:
//! a study that is killed and replayed from its store asks for exactly the same next points. No
//! method calls a simulation itself; the caller (a study stage, `demcal surrogate`, or a test's
//! closure) runs the points and hands back the responses.

pub mod bayesopt;
pub mod genetic;
pub mod gp;
pub mod metrics;
pub mod mixture;
pub mod network;
pub mod smc;

pub use metrics::{split_stratified, split_train_test, FitMetrics};
