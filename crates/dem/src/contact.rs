//! Contact force models.
//!
//! The kernels here are shared by particle-particle and particle-geometry contacts: callers reduce
//! their situation to a normal, an overlap, effective radius and mass, a relative velocity and the
//! spin term of the contact point, and receive the normal force magnitude and the tangential force.
//! Adding a contact model means adding a variant to [`NormalModel`] (chosen by name from the scene
//! file) and a branch in [`normal_and_tangential`]; nothing else in the engine changes.

use crate::material::PairParams;
use glam::DVec3;
use std::f64::consts::PI;

/// Rolling resistance model, chosen by name in the scene file.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RollingModel {
    /// EDEM's standard "constant directional torque" (`cdt`): each particle gets
    /// mu_r |F_n| c_i against its own spin.
    ConstantDirectionalTorque,
    /// Elastic-plastic spring-dashpot (`epsd`, EDEM type C, LIGGGHTS `epsd`).
    Epsd { viscous_damping: f64 },
}

impl RollingModel {
    pub fn from_name(name: &str, viscous_damping: f64) -> Option<Self> {
        match name {
            "cdt" => Some(Self::ConstantDirectionalTorque),
            "epsd" => Some(Self::Epsd { viscous_damping }),
            _ => None,
        }
    }
}

/// Normal/tangential contact model, chosen by name in the scene file.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum NormalModel {
    /// Hertz-Mindlin (no slip), EDEM's default model.
    HertzMindlin,
}

impl NormalModel {
    pub fn from_name(name: &str) -> Option<Self> {
        match name {
            "hertz_mindlin" => Some(Self::HertzMindlin),
            _ => None,
        }
    }
}

/// Geometry of one contact as the kernel sees it.
#[derive(Clone, Copy, Debug)]
pub struct ContactPoint {
    /// Unit normal pointing from the other body to this particle.
    pub normal: DVec3,
    /// Overlap (> 0 in contact).
    pub overlap: f64,
    pub r_eff: f64,
    pub m_eff: f64,
    /// Velocity of this particle's centre minus the other body's velocity (at its centre, or for a
    /// wall at the contact point).
    pub v_rel: DVec3,
    /// c_i w_i + c_j w_j: crossed with the normal it gives the spin part of the contact-point velocity.
    pub spin_lever: DVec3,
}

/// What a contact produces.
#[derive(Clone, Copy, Debug, Default)]
pub struct ContactForce {
    /// Total normal force (positive = repulsive); not clamped at zero.
    pub normal: f64,
    /// The normal load that friction and rolling resistance scale with: the normal force, plus for
    /// JKR the pull-off correction 2 * 3 pi gamma R* (physics.md), so a cohesive contact pulled
    /// to zero net force still has friction.
    pub load: f64,
    /// Tangential force on this particle.
    pub tangential: DVec3,
    /// Secant normal stiffness k_n = (4/3) E* a (a = sqrt(R* d) for Hertz), for the epsd model.
    pub secant_stiffness: f64,
}

/// The (negative) overlap d_c down to which a JKR contact still attracts (physics.md):
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

/// Hertz-Mindlin (no slip) with the LAMMPS-style tangential spring update, as in physics.md; with
/// a surface energy, the JKR normal force replaces Hertz (EDEM's "Hertz-Mindlin with JKR"), and the
/// stiffnesses use the JKR contact radius a in place of sqrt(R* d). `shear` is the pair's
/// tangential spring history. The caller checks the overlap against [`jkr_cutoff_overlap`].
#[inline(always)]
pub fn hertz_mindlin(p: &PairParams, c: &ContactPoint, shear: &mut DVec3, dt: f64) -> ContactForce {
    let n = c.normal;
    let d = c.overlap;
    let (a, f_elastic, pull_off) = if p.surface_energy > 0.0 {
        let gamma = p.surface_energy;
        let a = jkr_contact_radius(d, gamma, p.e_star, c.r_eff);
        let f = (4.0 * p.e_star / (3.0 * c.r_eff)) * a * a * a
            - 4.0 * (PI * gamma * p.e_star).sqrt() * a.powf(1.5);
        (a, f, 6.0 * PI * gamma * c.r_eff)
    } else {
        let a = (c.r_eff * d).sqrt();
        (a, (4.0 / 3.0) * p.e_star * a * d, 0.0)
    };
    let s_n = 2.0 * p.e_star * a;
    let s_t = 8.0 * p.g_star * a;
    let v_n = c.v_rel.dot(n);
    let gamma_n = p.damping_factor * (s_n * c.m_eff).sqrt();
    let f_n = f_elastic - gamma_n * v_n;

    let v_t = c.v_rel - v_n * n;
    let v_c = v_t - c.spin_lever.cross(n);

    // Rotate the stored spring into the current tangent plane keeping its length, then stretch it.
    let old_len2 = shear.length_squared();
    if old_len2 > 0.0 {
        let projected = *shear - shear.dot(n) * n;
        let new_len2 = projected.length_squared();
        *shear = if new_len2 > 0.0 {
            projected * (old_len2 / new_len2).sqrt()
        } else {
            DVec3::ZERO
        };
    }
    *shear += v_c * dt;

    let gamma_t = p.damping_factor * (s_t * c.m_eff).sqrt();
    let mut f_t = -s_t * *shear - gamma_t * v_c;
    let load = f_n + pull_off;
    let limit = p.static_friction * load.abs();
    let ft2 = f_t.length_squared();
    if ft2 > limit * limit {
        f_t *= limit / ft2.sqrt();
        // Truncate the spring to the slip length: -S_t s equals the elastic share of the scaled force.
        *shear = if s_t > 0.0 {
            -(f_t + gamma_t * v_c) / s_t
        } else {
            DVec3::ZERO
        };
    }
    ContactForce {
        normal: f_n,
        load,
        tangential: f_t,
        secant_stiffness: (4.0 / 3.0) * p.e_star * a,
    }
}

/// Elastic-plastic spring-dashpot rolling resistance. Returns the torque on particle i (particle j,
/// if any, gets the opposite). `moment` is the pair's rolling history; `rel_spin` is w_i - w_j.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub fn epsd_rolling_torque(
    p: &PairParams,
    f: &ContactForce,
    normal: DVec3,
    r_eff: f64,
    rolling_inertia: f64,
    viscous_damping: f64,
    rel_spin: DVec3,
    moment: &mut DVec3,
    dt: f64,
) -> DVec3 {
    let w = rel_spin - rel_spin.dot(normal) * normal;
    let k_r = 2.25 * f.secant_stiffness * p.rolling_friction * p.rolling_friction * r_eff * r_eff;
    let mut m = *moment - moment.dot(normal) * normal + k_r * w * dt;
    let limit = p.rolling_friction * r_eff * f.load.abs();
    let m2 = m.length_squared();
    if m2 > limit * limit {
        m *= limit / m2.sqrt();
        *moment = m;
        -m
    } else {
        *moment = m;
        let damping = viscous_damping * 2.0 * (rolling_inertia * k_r).sqrt();
        -(m + damping * w)
    }
}

#[cfg(test)]
mod jkr_tests {
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

    #[test]
    fn without_surface_energy_jkr_is_hertz_and_force_at_cut_off_is_attractive() {
        let mut p = PairParams {
            e_star: 1e8,
            g_star: 4e7,
            static_friction: 0.5,
            ..Default::default()
        };
        let c = ContactPoint {
            normal: DVec3::Z,
            overlap: 1e-5,
            r_eff: 0.002,
            m_eff: 1e-3,
            v_rel: DVec3::ZERO,
            spin_lever: DVec3::ZERO,
        };
        let hertz = hertz_mindlin(&p, &c, &mut DVec3::new(0.0, 0.0, 0.0), 1e-6).normal;
        p.surface_energy = 1e-12;
        let jkr = hertz_mindlin(&p, &c, &mut DVec3::new(0.0, 0.0, 0.0), 1e-6).normal;
        assert!((jkr - hertz).abs() < 1e-4 * hertz, "{jkr} vs {hertz}");
        // At the cut-off the force is still attractive, between the pull-off force 3 pi gamma R*
        // and the EDEM-documented -(3/2) pi gamma R*.
        p.surface_energy = 0.5;
        let d_c = jkr_cutoff_overlap(0.5, p.e_star, c.r_eff);
        let at_cut = hertz_mindlin(
            &p,
            &ContactPoint { overlap: d_c, ..c },
            &mut DVec3::new(0.0, 0.0, 0.0),
            1e-6,
        );
        let unit = PI * 0.5 * c.r_eff;
        assert!(
            at_cut.normal < -1.5 * unit && at_cut.normal > -3.0 * unit,
            "{}",
            at_cut.normal / unit
        );
        // Friction scales with the pull-off corrected load.
        assert!((at_cut.load - (at_cut.normal + 6.0 * unit)).abs() < 1e-12);
    }
}
