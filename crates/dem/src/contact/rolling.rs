//! Rolling resistance models, chosen by name in the scene file (`rolling_friction_model`). Both
//! scale with the contact's load; [`super::evaluate`] applies the chosen one to every contact.

use super::{ContactForce, PairParams};
use glam::DVec3;

/// Rolling resistance model (default: constant directional torque, EDEM's standard).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum RollingModel {
    /// EDEM's standard "constant directional torque" (`cdt`): each particle gets
    /// mu_r |F_n| c_i against its own spin.
    #[default]
    ConstantDirectionalTorque,
    /// Elastic-plastic spring-dashpot (`epsd`, EDEM type C, LIGGGHTS `epsd`).
    Epsd { viscous_damping: f64 },
}

impl RollingModel {
    /// Names scene files use.
    pub const NAMES: &'static [&'static str] = &["cdt", "epsd"];

    pub fn name(&self) -> &'static str {
        match self {
            Self::ConstantDirectionalTorque => "cdt",
            Self::Epsd { .. } => "epsd",
        }
    }

    pub fn from_name(name: &str, viscous_damping: f64) -> Option<Self> {
        match name {
            "cdt" => Some(Self::ConstantDirectionalTorque),
            "epsd" => Some(Self::Epsd { viscous_damping }),
            _ => None,
        }
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
