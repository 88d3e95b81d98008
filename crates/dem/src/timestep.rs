//! Critical time steps: the Rayleigh step users size dt against, and the Hertz collision time.

use crate::material::MaterialTable;
use crate::particles::Particles;

/// Rayleigh time step of the smallest particle of each material present; the minimum over materials.
pub fn rayleigh_time_step(particles: &Particles, materials: &MaterialTable) -> f64 {
    smallest_per_material(particles, materials.len())
        .iter()
        .enumerate()
        .filter_map(|(m, s)| s.map(|(r, _)| materials.material(m).rayleigh_time_step(r)))
        .fold(f64::INFINITY, f64::min)
}

/// Rayleigh time step for the smallest radius each material can have (its size distribution's lower
/// bound: mean - 3 std for a normal distribution unless capped), the minimum over materials. This is
/// what EDEM reports the time step against.
pub fn rayleigh_time_step_for(materials: &MaterialTable, smallest: &[(usize, f64)]) -> f64 {
    smallest
        .iter()
        .map(|&(m, r)| materials.material(m).rayleigh_time_step(r))
        .fold(f64::INFINITY, f64::min)
}

/// Hertz collision time T_H = 2.87 (m*^2 / (R* E*^2 v))^(1/5).
pub fn hertz_collision_time(m_eff: f64, r_eff: f64, e_star: f64, speed: f64) -> f64 {
    2.87 * (m_eff * m_eff / (r_eff * e_star * e_star * speed)).powf(0.2)
}

/// Shortest Hertz collision time at impact speed `speed` over the pairs that can meet: the smallest
/// particle of each material against the smallest of every other, and against each geometry material.
pub fn shortest_collision_time(
    particles: &Particles,
    materials: &MaterialTable,
    geometry_materials: &[usize],
    speed: f64,
) -> f64 {
    let smallest = smallest_per_material(particles, materials.len());
    let mut best = f64::INFINITY;
    for (a, sa) in smallest.iter().enumerate() {
        let Some((ra, ma)) = *sa else { continue };
        for (b, sb) in smallest.iter().enumerate() {
            let Some((rb, mb)) = *sb else { continue };
            let e = materials.pair(a, b).e_star;
            best = best.min(hertz_collision_time(
                ma * mb / (ma + mb),
                ra * rb / (ra + rb),
                e,
                speed,
            ));
        }
        for &g in geometry_materials {
            let e = materials.pair(a, g).e_star;
            best = best.min(hertz_collision_time(ma, ra, e, speed));
        }
    }
    best
}

fn smallest_per_material(particles: &Particles, n: usize) -> Vec<Option<(f64, f64)>> {
    let mut smallest: Vec<Option<(f64, f64)>> = vec![None; n];
    for k in 0..particles.len() {
        let m = particles.material[k] as usize;
        let r = particles.radius[k];
        if smallest[m].is_none_or(|(s, _)| r < s) {
            smallest[m] = Some((r, particles.mass[k]));
        }
    }
    smallest
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
