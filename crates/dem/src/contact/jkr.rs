//! JKR cohesion: the cut-off overlap and the contact radius (docs/physics.md). The Hertz-Mindlin
//! law uses them when a pair has a surface energy (EDEM's "Hertz-Mindlin with JKR").

use std::f64::consts::PI;

/// The (negative) overlap d_c down to which a JKR contact still attracts (docs/physics.md):
/// d_c = a_c^2/R* - sqrt(4 pi gamma a_c / E*), a_c = [(9 pi gamma R*^2 / (2 E*)) (3/4 - 1/sqrt 2)]^(1/3).
pub fn jkr_cutoff_overlap(gamma: f64, e_star: f64, r_eff: f64) -> f64 {
    if gamma <= 0.0 {
        return 0.0;
    }
    let a_c = (9.0 * PI * gamma * r_eff * r_eff / (2.0 * e_star)
        * (0.75 - std::f64::consts::FRAC_1_SQRT_2))
        .cbrt();
    a_c * a_c / r_eff - (4.0 * PI * gamma * a_c / e_star).sqrt()
}

/// JKR contact radius for overlap `d` (>= the cut-off): the root of d = a^2/R* - sqrt(4 pi gamma
/// a / E*) on the stable branch. With s = sqrt(a) this is g(s) = s^4/R* - c s - d = 0, c =
/// sqrt(4 pi gamma / E*); g is convex and increasing to the right of its minimum, so Newton from a
/// point where g >= 0 (s0 = (R* d+)^(1/4) + (c R*)^(1/3), for which every binomial term bounds one
/// of g's) falls monotonically onto the root: no bracketing fallback is needed.
pub fn jkr_contact_radius(d: f64, gamma: f64, e_star: f64, r_eff: f64) -> f64 {
    let c = (4.0 * PI * gamma / e_star).sqrt();
    let s_min = (c * r_eff / 4.0).cbrt();
    let mut s = (r_eff * d.max(0.0)).sqrt().sqrt() + (c * r_eff).cbrt();
    for _ in 0..60 {
        let g = s.powi(4) / r_eff - c * s - d;
        let slope = 4.0 * s.powi(3) / r_eff - c;
        if slope <= 0.0 {
            break;
        }
        let next = (s - g / slope).max(s_min);
        if (s - next).abs() <= 1e-14 * s {
            s = next;
            break;
        }
        s = next;
    }
    s * s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn contact_radius_solves_the_jkr_relation_on_the_stable_branch() {
        let (gamma, e_star, r) = (0.2735, 2.9e7, 0.004);
        let d_c = jkr_cutoff_overlap(gamma, e_star, r);
        let a_m = ((4.0 * PI * gamma / e_star).sqrt() * r / 4.0).powf(2.0 / 3.0);
        for i in 0..=200 {
            let d = d_c + (1e-4 - d_c) * i as f64 / 200.0;
            let a = jkr_contact_radius(d, gamma, e_star, r);
            let back = a * a / r - (4.0 * PI * gamma * a / e_star).sqrt();
            assert!(
                (back - d).abs() < 1e-12 * (1.0 + d.abs() / 1e-6) * 1e-6,
                "d {d}: {back}"
            );
            assert!(a >= a_m * (1.0 - 1e-9), "stable branch");
        }
    }
}
