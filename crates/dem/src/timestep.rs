//! Critical time steps: the Rayleigh step users size dt against, and the contact law's collision
//! time (each law knows its own, [`crate::contact::ContactLaw::collision_time`]).

use crate::contact::ContactModel;
use crate::material::MaterialTable;

/// Rayleigh time step for the smallest radius each material can have (its size distribution's lower
/// bound: mean - 3 std for a normal distribution unless capped), the minimum over materials. This is
/// what EDEM reports the time step against.
pub fn rayleigh_time_step_for(materials: &MaterialTable, smallest: &[(usize, f64)]) -> f64 {
    smallest
        .iter()
        .map(|&(m, r)| materials.material(m).rayleigh_time_step(r))
        .fold(f64::INFINITY, f64::min)
}

/// Shortest collision time of the contact law at impact speed `speed` over the pairs that can
/// meet (Hertz-Mindlin: T_H = 2.87 (m*^2 / (R* E*^2 v))^(1/5)). `smallest` lists (material, radius,
/// mass) of the smallest particle each particle type can produce (a clump sphere's mass is its
/// body's); each meets every other and each geometry material.
pub fn shortest_collision_time(
    model: &ContactModel,
    smallest: &[(usize, f64, f64)],
    materials: &MaterialTable,
    geometry_materials: &[usize],
    speed: f64,
) -> f64 {
    let mut best = f64::INFINITY;
    for &(a, ra, ma) in smallest {
        for &(b, rb, mb) in smallest {
            let p = materials.pair(a, b);
            best =
                best.min(model.collision_time(p, ma * mb / (ma + mb), ra * rb / (ra + rb), speed));
        }
        for &g in geometry_materials {
            best = best.min(model.collision_time(materials.pair(a, g), ma, ra, speed));
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use crate::material::Material;

    #[test]
    fn rayleigh_step_of_the_settle_benchmark() {
        // r = 2 mm, rho = 2500, E = 1e7, nu = 0.3: G = 3.846e6, T_R = pi r sqrt(rho/G)/(0.1631 nu + 0.8766).
        let m = Material {
            name: "glass".into(),
            density: 2500.0,
            poisson_ratio: 0.3,
            shear_modulus: 1e7 / 2.6,
        };
        let expected = std::f64::consts::PI * 0.002 * (2500.0f64 / (1e7 / 2.6)).sqrt()
            / (0.1631 * 0.3 + 0.8766);
        assert!((m.rayleigh_time_step(0.002) - expected).abs() < 1e-15);
        assert!((expected - 1.7312e-4).abs() < 1e-7, "{expected}");
    }
}
