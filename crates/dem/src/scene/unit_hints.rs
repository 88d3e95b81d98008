//! Warnings for values that look like the wrong unit: a bare number is taken in SI units, and
//! the common slip is a value copied from a paper in g/cm3, MPa or mm/s. Sizes are checked where
//! the particles and walls are built (`build.rs`), since only there is a clump's extent known.
//!
//! These are warnings, not errors: a foam of 30 kg/m3 or a 5 kPa gel exists. Each says what the
//! value would be had it been meant in the likelier unit, and how to write that unit.

use super::description::{SceneDescription, Stiffness};
use crate::geometry::Motion;

/// Densities below this (kg/m3) look like g/cm3.
const SMALL_DENSITY: f64 = 50.0;
/// Moduli below this (Pa) look like MPa (the softest crop tissue is about 1 MPa).
const SMALL_MODULUS: f64 = 1e4;
/// Bond stiffnesses per area below this (N/m3) look like N/mm3.
const SMALL_BOND_STIFFNESS: f64 = 1e4;
/// Bond strengths below this (Pa) look like MPa.
const SMALL_BOND_STRENGTH: f64 = 100.0;
/// Wall speeds above this (m/s) look like mm/s.
const LARGE_SPEED: f64 = 50.0;

/// Appends a warning for each value of `d` that looks like the wrong unit.
pub(super) fn check(d: &SceneDescription, warnings: &mut Vec<String>) {
    let mut warn = |key: String, value: f64, si: &str, meant: &str, factor: f64| {
        warnings.push(format!(
            "{key}: {value} {si} looks like the wrong unit: a plain number is in {si}; if {meant} was meant, write \"{value} {meant}\" ({:e} {si})",
            value * factor
        ))
    };
    for (k, m) in d.materials.iter().enumerate() {
        if m.density > 0.0 && m.density < SMALL_DENSITY {
            warn(
                format!("material[{k}].density"),
                m.density,
                "kg/m3",
                "g/cm3",
                1e3,
            );
        }
        let (key, modulus) = match m.stiffness {
            Stiffness::ShearModulus(g) => ("shear_modulus", g),
            Stiffness::YoungsModulus(e) => ("youngs_modulus", e),
        };
        if modulus > 0.0 && modulus < SMALL_MODULUS {
            warn(format!("material[{k}].{key}"), modulus, "Pa", "MPa", 1e6);
        }
    }
    for (k, b) in d.bonds.iter().enumerate() {
        let p = &b.params;
        for (key, v) in [
            ("normal_stiffness", p.normal_stiffness),
            ("shear_stiffness", p.shear_stiffness),
        ] {
            if v > 0.0 && v < SMALL_BOND_STIFFNESS {
                warn(format!("bond[{k}].{key}"), v, "N/m3", "N/mm3", 1e9);
            }
        }
        for (key, v) in [
            ("critical_normal_stress", p.critical_normal_stress),
            ("critical_shear_stress", p.critical_shear_stress),
        ] {
            if v > 0.0 && v < SMALL_BOND_STRENGTH {
                warn(format!("bond[{k}].{key}"), v, "Pa", "MPa", 1e6);
            }
        }
    }
    for (k, g) in d.geometries.iter().enumerate() {
        for (j, m) in g.motion.iter().enumerate() {
            if let Motion::Translation { velocity, .. } = m {
                let speed = velocity.length();
                if speed > LARGE_SPEED && speed.is_finite() {
                    warn(
                        format!("geometry[{k}].motion[{j}].velocity"),
                        speed,
                        "m/s",
                        "mm/s",
                        1e-3,
                    );
                }
            }
        }
    }
}
