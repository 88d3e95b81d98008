//! The linear spring-dashpot law, as LIGGGHTS `model hooke` (with `tangential_damping on`): the
//! stiffness comes from the Hertz stiffness at a characteristic impact velocity, the damping from
//! the restitution, so that a head-on impact rebounds with exactly the restitution.

use super::{tangential_spring, ContactForce, ContactHistory, ContactLaw, ContactPoint, PairParams};
use std::f64::consts::PI;

/// Linear spring-dashpot. With Y* the effective Young's modulus, R* and m* the effective radius
/// and mass and v_c the characteristic velocity:
/// k_n = 16/15 sqrt(R*) Y* (15 m* v_c^2 / (16 sqrt(R*) Y*))^(1/5), k_t = k_n,
/// gamma_n = gamma_t = sqrt(4 m* k_n / (1 + (pi / ln e)^2)) = 2 zeta sqrt(m* k_n).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hooke {
    /// Impact speed at which the linear spring matches the Hertz stiffness (m/s; LIGGGHTS
    /// `characteristicVelocity`).
    pub characteristic_velocity: f64,
}

impl Default for Hooke {
    fn default() -> Self {
        Hooke {
            characteristic_velocity: 1.0,
        }
    }
}

impl Hooke {
    /// Normal spring stiffness k_n (N/m) of a pair.
    pub fn stiffness(&self, p: &PairParams, m_eff: f64, r_eff: f64) -> f64 {
        let sqrt_r = r_eff.sqrt();
        let v = self.characteristic_velocity;
        16.0 / 15.0
            * sqrt_r
            * p.e_star
            * (15.0 * m_eff * v * v / (16.0 * sqrt_r * p.e_star)).powf(0.2)
    }
}

impl ContactLaw for Hooke {
    const NAME: &'static str = "hooke";
    /// Not written in WGSL yet: the GPU stages hand its contacts to the CPU.
    const ON_GPU: bool = false;
    const PARAMETERS: &'static [(&'static str, &'static str)] = &[(
        "characteristic_velocity",
        "impact speed (m/s) at which the spring matches Hertz; default 1",
    )];

    fn set_parameter(&mut self, name: &str, value: f64) -> Result<(), String> {
        match name {
            "characteristic_velocity" if value > 0.0 && value.is_finite() => {
                self.characteristic_velocity = value;
                Ok(())
            }
            "characteristic_velocity" => Err(format!("expected a speed > 0 (m/s), got {value}")),
            _ => Err(format!(
                "hooke takes no parameter \"{name}\" (expected characteristic_velocity)"
            )),
        }
    }

    #[inline(always)]
    fn force(
        &self,
        p: &PairParams,
        c: &ContactPoint,
        history: &mut ContactHistory,
        dt: f64,
    ) -> ContactForce {
        let n = c.normal;
        let k = self.stiffness(p, c.m_eff, c.r_eff);
        let damping = 2.0 * p.damping_ratio * (c.m_eff * k).sqrt();
        let v_n = c.v_rel.dot(n);
        let f_n = k * c.overlap - damping * v_n;
        let v_c = c.v_rel - v_n * n - c.spin_lever.cross(n);
        let limit = p.static_friction * f_n.abs();
        let f_t = tangential_spring(&mut history.tangential, n, v_c, k, damping, limit, dt);
        ContactForce {
            normal: f_n,
            load: f_n,
            tangential: f_t,
            secant_stiffness: k,
        }
    }

    /// Half the damped period: pi / (omega_0 sqrt(1 - zeta^2)), omega_0 = sqrt(k_n / m*).
    fn collision_time(&self, p: &PairParams, m_eff: f64, r_eff: f64, _speed: f64) -> f64 {
        let omega = (self.stiffness(p, m_eff, r_eff) / m_eff).sqrt();
        PI / (omega * (1.0 - p.damping_ratio * p.damping_ratio).sqrt())
    }
}
