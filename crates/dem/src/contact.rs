//! Contact force models.
//!
//! The kernels here are shared by particle-particle and particle-geometry contacts: callers reduce
//! their situation to a normal, an overlap, effective radius and mass, a relative velocity and the
//! spin term of the contact point, and receive the normal force magnitude and the tangential force.
//! Adding a contact model means adding a variant to [`NormalModel`] (chosen by name from the scene
//! file) and a branch in [`normal_and_tangential`]; nothing else in the engine changes.

use crate::material::PairParams;
use glam::DVec3;

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
    /// Tangential force on this particle.
    pub tangential: DVec3,
    /// Secant normal stiffness k_n = (4/3) E* sqrt(R* d), needed by the epsd rolling model.
    pub secant_stiffness: f64,
}

/// Hertz-Mindlin (no slip) with the LAMMPS-style tangential spring update, as in physics.md.
/// `shear` is the pair's tangential spring history.
#[inline(always)]
pub fn hertz_mindlin(p: &PairParams, c: &ContactPoint, shear: &mut DVec3, dt: f64) -> ContactForce {
    let n = c.normal;
    let d = c.overlap;
    let sqrt_rd = (c.r_eff * d).sqrt();
    let f_elastic = (4.0 / 3.0) * p.e_star * sqrt_rd * d;
    let s_n = 2.0 * p.e_star * sqrt_rd;
    let s_t = 8.0 * p.g_star * sqrt_rd;
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
    let limit = p.static_friction * f_n.abs();
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
        tangential: f_t,
        secant_stiffness: (4.0 / 3.0) * p.e_star * sqrt_rd,
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
    let limit = p.rolling_friction * r_eff * f.normal.abs();
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
