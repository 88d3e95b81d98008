//! Virtual lab tests: the set-ups of `shared/spec/lab-tests.md` built on the DEM engine, and the
//! measurements the labs make on them.
//!
//! So far: the angle-of-repose measurement of a particle heap ([`repose`]), which the lifted-cylinder
//! test will call on its final state (issue 4).

pub mod repose;
