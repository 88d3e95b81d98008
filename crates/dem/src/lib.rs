//! The demcal DEM engine.
//!
//! Spheres with per-particle radius and material, multi-sphere clumps as rigid bodies ([`clump`]),
//! Hertz-Mindlin (no slip) contacts with optional JKR cohesion, constant directional torque or
//! elastic-plastic spring-dashpot rolling friction, analytic walls and STL
//! meshes with prescribed motion, cell-grid neighbour lists with a skin, velocity Verlet, and TOML
//! scene files. The physics contract is `docs/physics.md`; [`sim`] explains the step pipeline.

pub mod bench;
pub mod bond;
pub mod clump;
pub mod contact;
pub mod factory;
pub mod files;
pub mod fill;
pub mod geometry;
pub mod keys;
pub mod maize_kernel;
pub mod material;
pub mod mixture;
pub mod neighbour;
pub mod output;
mod packing;
mod parallel;
pub mod particles;
pub mod polyhedron;
pub mod random_fill;
pub mod scene;
pub mod sim;
pub mod specimen;
pub mod sphere_fit;
pub mod timestep;
pub mod units;

pub use geometry::{Element, Geometry, Load, Motion};
pub use material::{Interaction, Material, MaterialTable};
pub use particles::Particles;
pub use sim::{SimError, Simulation, SimulationParams};
