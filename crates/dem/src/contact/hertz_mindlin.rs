//! Hertz-Mindlin (no slip), EDEM's default law, with optional JKR cohesion (docs/physics.md).

use super::jkr::{jkr_contact_radius, jkr_cutoff_overlap};
use super::{tangential_spring, ContactForce, ContactHistory, ContactLaw, ContactPoint, PairParams};
use std::f64::consts::PI;

/// Hertz-Mindlin (no slip) with the LAMMPS-style tangential spring update; with a surface energy,
/// the JKR normal force replaces Hertz (EDEM's "Hertz-Mindlin with JKR"), and the stiffnesses use
/// the JKR contact radius a in place of sqrt(R* d).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct HertzMindlin;

impl ContactLaw for HertzMindlin {
    const NAME: &'static str = "hertz_mindlin";
    const COHESIVE: bool = true;
    /// `crates/gpu/src/wgsl/contact.wgsl`, with JKR and both rolling models.
    const ON_GPU: bool = true;

    #[inline(always)]
    fn force(
        &self,
        p: &PairParams,
        c: &ContactPoint,
        history: &mut ContactHistory,
        dt: f64,
    ) -> ContactForce {
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
        let gamma_n = p.hertz_damping * (s_n * c.m_eff).sqrt();
        let f_n = f_elastic - gamma_n * v_n;

        let v_t = c.v_rel - v_n * n;
        let v_c = v_t - c.spin_lever.cross(n);
        let gamma_t = if p.tangential_damping_ratio > 0.0 {
            gamma_n * p.tangential_damping_ratio
        } else {
            p.hertz_damping * (s_t * c.m_eff).sqrt()
        };
        let load = f_n + pull_off;
        let limit = p.static_friction * load.abs();
        let f_t = tangential_spring(&mut history.tangential, n, v_c, s_t, gamma_t, limit, dt);
        ContactForce {
            normal: f_n,
            load,
            tangential: f_t,
            secant_stiffness: (4.0 / 3.0) * p.e_star * a,
        }
    }

    /// The JKR cut-off (0 without surface energy).
    #[inline(always)]
    fn cutoff_overlap(&self, p: &PairParams, r_eff: f64) -> f64 {
        jkr_cutoff_overlap(p.surface_energy, p.e_star, r_eff)
    }

    /// Hertz collision time T_H = 2.87 (m*^2 / (R* E*^2 v))^(1/5).
    fn collision_time(&self, p: &PairParams, m_eff: f64, r_eff: f64, speed: f64) -> f64 {
        2.87 * (m_eff * m_eff / (r_eff * p.e_star * p.e_star * speed)).powf(0.2)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

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
        let law = HertzMindlin;
        let hertz = law
            .force(&p, &c, &mut ContactHistory::default(), 1e-6)
            .normal;
        p.surface_energy = 1e-12;
        let jkr = law
            .force(&p, &c, &mut ContactHistory::default(), 1e-6)
            .normal;
        assert!((jkr - hertz).abs() < 1e-4 * hertz, "{jkr} vs {hertz}");
        // At the cut-off the force is still attractive, between the pull-off force 3 pi gamma R*
        // and the EDEM-documented -(3/2) pi gamma R*.
        p.surface_energy = 0.5;
        let d_c = law.cutoff_overlap(&p, c.r_eff);
        let at_cut = law.force(
            &p,
            &ContactPoint { overlap: d_c, ..c },
            &mut ContactHistory::default(),
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
