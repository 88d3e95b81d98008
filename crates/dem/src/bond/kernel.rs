//! One bond's arithmetic for a step: the incremental update of its forces and moments (turned
//! with the bond, then loaded by the relative motion), the breakage test, and PFC local damping.
//! Kept apart from the bond list so that the hot path reads as one piece.

use std::f64::consts::{FRAC_1_PI, PI};

use glam::DVec3;

use super::{BondOutput, BondParams, BondState, BreakMode};
use crate::particles::Particles;

/// A bond's cross-section of radius R_B: area A = pi R_B^2, polar second moment J = pi R_B^4 / 2,
/// second moment of area I = J / 2, and the quotients the stresses need. Divisions are the slow
/// part of the bond arithmetic: one reciprocal of R_B serves every quotient.
pub(super) struct Section {
    area: f64,
    polar: f64,
    inertia: f64,
    inv_area: f64,
    /// R_B / J = 2 / (pi R_B^3); R_B / I is twice this.
    rb_over_polar: f64,
}

impl Section {
    pub(super) fn new(rb: f64) -> Section {
        let rb2 = rb * rb;
        let polar = 0.5 * PI * rb2 * rb2;
        let inv_rb = rb.recip();
        let inv_area = FRAC_1_PI * inv_rb * inv_rb;
        Section {
            area: PI * rb2,
            polar,
            inertia: 0.5 * polar,
            inv_area,
            rb_over_polar: 2.0 * inv_area * inv_rb,
        }
    }

    /// The normal and shear stresses of the breakage criterion in state `s`:
    /// sigma = -F_n/A + |M_b| R_B/I, tau = |F_t|/A + |M_t| R_B/J.
    pub(super) fn stresses(&self, s: &BondState) -> (f64, f64) {
        (
            -s.normal_force * self.inv_area + s.bending.length() * 2.0 * self.rb_over_polar,
            s.shear_force.length() * self.inv_area + s.twist.abs() * self.rb_over_polar,
        )
    }

    /// The limit state `s` reaches, tension first: sigma >= sigma_c or tau >= tau_c. Tested on
    /// squares (|M_b| R_B/I >= sigma_c + F_n/A, |F_t|/A >= tau_c - |M_t| R_B/J) so that an
    /// intact bond costs no square root: the two were a fifth of the update's time.
    pub(super) fn breaks(&self, s: &BondState, b: &BondParams) -> Option<BreakMode> {
        let room = b.critical_normal_stress + s.normal_force * self.inv_area;
        let bending = 2.0 * self.rb_over_polar;
        if room <= 0.0 || s.bending.length_squared() * (bending * bending) >= room * room {
            return Some(BreakMode::Tension);
        }
        let room = b.critical_shear_stress - s.twist.abs() * self.rb_over_polar;
        let shear = self.inv_area;
        if room <= 0.0 || s.shear_force.length_squared() * (shear * shear) >= room * room {
            return Some(BreakMode::Shear);
        }
        None
    }
}

/// PFC local damping of one force component by component against the velocity.
pub(super) fn local_damping(f: DVec3, v: DVec3, fraction: f64) -> DVec3 {
    let sign = |x: f64| {
        if x > 0.0 {
            1.0
        } else if x < 0.0 {
            -1.0
        } else {
            0.0
        }
    };
    f - fraction
        * DVec3::new(
            f.x.abs() * sign(v.x),
            f.y.abs() * sign(v.y),
            f.z.abs() * sign(v.z),
        )
}

/// The rotation taking unit `from` to unit `to` (Rodrigues, no trigonometry), set up once per
/// bond and applied to both stored tangential vectors.
struct Turn {
    cos: f64,
    /// `from x to`: the rotation axis times the sine of the angle.
    sine_axis: DVec3,
    /// `1 / (1 + cos)`, used by the general case only.
    scale: f64,
}

impl Turn {
    fn new(from: DVec3, to: DVec3) -> Turn {
        let cos = from.dot(to);
        // A bond turns by about 1e-7 rad in a step: there 1 / (1 + cos) = 1 / (2 - e) with
        // e = 1 - cos below 1e-4 is its series to e^4, the terms left out below 1e-21 (and this
        // factor only scales a term of order e), which saves a division per bond.
        let e = 1.0 - cos;
        let scale = if e.abs() < 1e-4 {
            0.5 * (1.0 + 0.5 * e * (1.0 + 0.5 * e * (1.0 + 0.5 * e * (1.0 + 0.5 * e))))
        } else {
            (1.0 + cos).recip()
        };
        Turn {
            cos,
            sine_axis: from.cross(to),
            scale,
        }
    }

    fn apply(&self, v: DVec3) -> DVec3 {
        if self.cos > 1.0 - 1e-15 {
            return v;
        }
        if self.cos < -1.0 + 1e-12 {
            // Flipped in one step: only an exploding run does this; drop the direction.
            return -v;
        }
        let k = self.sine_axis;
        v * self.cos + k.cross(v) + k * (k.dot(v) * self.scale)
    }
}

/// `x.sin_cos()`, by its Taylor series where the angle is small (a bond's spin in one step is
/// about 1e-7 rad): the terms left out are below 1e-17 of the result, under f64's rounding, and
/// the library call was a tenth of a bonded step.
fn small_angle_sin_cos(x: f64) -> (f64, f64) {
    if x.abs() >= 1e-2 {
        return x.sin_cos();
    }
    let x2 = x * x;
    let sin = x * (1.0 - x2 * (1.0 / 6.0) * (1.0 - x2 * (1.0 / 20.0) * (1.0 - x2 * (1.0 / 42.0))));
    let cos = 1.0 - x2 * 0.5 * (1.0 - x2 * (1.0 / 12.0) * (1.0 - x2 * (1.0 / 30.0)));
    (sin, cos)
}

/// One bond's incremental update for a step of `dt`; returns its forces, or `None` if it broke.
/// `stiffness` is the bond's own factor on k_n and k_t (the stiffness range).
#[allow(clippy::too_many_arguments)]
pub(super) fn update_bond(
    p: &Particles,
    i: usize,
    j: usize,
    b: &BondParams,
    rb: f64,
    stiffness: f64,
    s: &mut BondState,
    dt: f64,
) -> Option<BondOutput> {
    // Divisions are the slow part of this arithmetic: one reciprocal each of the distance, the
    // radius sum and the bond radius serve every quotient below.
    let delta = p.position[i] - p.position[j];
    let dist = delta.length();
    let n = delta * dist.recip();
    let (wi, wj) = (p.angular_velocity[i], p.angular_velocity[j]);
    // Turn the stored tangential vectors with the bond: the axis's own turn, then the pair's
    // mean spin about the axis.
    let (sin, cos) = small_angle_sin_cos(0.5 * (wi + wj).dot(n) * dt);
    let turn = Turn::new(s.axis, n);
    let follow = |v: DVec3| -> DVec3 {
        let v = turn.apply(v);
        let v = v - n * v.dot(n);
        v * cos + n.cross(v) * sin
    };
    s.shear_force = follow(s.shear_force);
    s.bending = follow(s.bending);
    s.axis = n;

    let (ri, rj) = (p.radius[i], p.radius[j]);
    let share = dist * (ri + rj).recip();
    let ci = ri * share;
    let cj = rj * share;
    let v = p.velocity[i] - p.velocity[j];
    let vn = v.dot(n);
    let vt = v - n * vn - (wi * ci + wj * cj).cross(n);
    let w = wi - wj;
    let wn = w.dot(n);
    let wt = w - n * wn;

    let section = Section::new(rb);
    let (k_n, k_t) = (
        b.normal_stiffness * stiffness,
        b.shear_stiffness * stiffness,
    );
    s.normal_force -= k_n * section.area * vn * dt;
    s.shear_force -= vt * (k_t * section.area * dt);
    s.twist -= k_t * section.polar * wn * dt;
    s.bending -= wt * (k_n * section.inertia * dt);

    if section.breaks(s, b).is_some() {
        return None;
    }
    let moment = n * s.twist + s.bending;
    let lever = n.cross(s.shear_force);
    Some(BondOutput {
        force: n * s.normal_force + s.shear_force,
        torque_first: moment - lever * ci,
        torque_second: -moment - lever * cj,
    })
}

/// Reproducible draws uniform on -1..1 (a 64-bit LCG), for the bond kernels' tests.
#[cfg(test)]
pub(super) fn uniform_draws(mut seed: u64) -> impl FnMut() -> f64 {
    move || {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (seed >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bond::{BondRadius, ContactRadius};

    /// The squared break test against the stresses compared with the limits directly, on states
    /// spread around both limits: they agree except within rounding of a limit.
    #[test]
    fn the_squared_break_test_is_the_stress_test() {
        let b = BondParams {
            normal_stiffness: 5.12e9,
            shear_stiffness: 1.28e8,
            critical_normal_stress: 1.6e7,
            critical_shear_stress: 2.48e6,
            radius: BondRadius::DiskScale(1.0),
            contact_radius: ContactRadius::Absolute(6e-4),
            formation_time: 0.0,
            damping: 0.0,
            stiffness_range: 0.0,
        };
        let rb = 4.3e-4;
        let section = Section::new(rb);
        let (area, limit) = (PI * rb * rb, 1.6e7 * PI * rb * rb);
        let mut draw = uniform_draws(7);
        let (mut tension, mut shear, mut whole) = (0, 0, 0);
        for _ in 0..200_000 {
            let s = BondState {
                normal_force: 1.5 * limit * draw(),
                shear_force: DVec3::new(draw(), draw(), draw()) * (0.8 * 2.48e6 * area),
                twist: draw() * 0.3 * 2.48e6 * 0.5 * PI * rb.powi(3),
                bending: DVec3::new(draw(), draw(), draw())
                    * (0.5 * 1.6e7 * 0.25 * PI * rb.powi(3)),
                axis: DVec3::X,
            };
            let (sigma, tau) = section.stresses(&s);
            let expected = if sigma >= b.critical_normal_stress {
                Some(BreakMode::Tension)
            } else if tau >= b.critical_shear_stress {
                Some(BreakMode::Shear)
            } else {
                None
            };
            let near = |x: f64, c: f64| (x / c - 1.0).abs() < 1e-12;
            if near(sigma, b.critical_normal_stress) || near(tau, b.critical_shear_stress) {
                continue;
            }
            assert_eq!(section.breaks(&s, &b), expected, "{s:?}");
            match expected {
                Some(BreakMode::Tension) => tension += 1,
                Some(BreakMode::Shear) => shear += 1,
                None => whole += 1,
            }
        }
        // Every outcome was tried many times.
        assert!(
            tension > 10_000 && shear > 10_000 && whole > 10_000,
            "{tension} {shear} {whole}"
        );
    }

    /// The turn's series for 1 / (1 + cos) against the division, and a vector across the bond
    /// turned and kept across it (as `update_bond` does) against the exact rotation, over the
    /// angles a step gives.
    #[test]
    fn the_turn_series_is_the_division() {
        for k in 0..400 {
            let angle = 10f64.powf(-12.0 + 10.0 * k as f64 / 400.0);
            let to = DVec3::new(angle.cos(), angle.sin(), 0.0);
            let turn = Turn::new(DVec3::X, to);
            let exact = (1.0 + turn.cos).recip();
            assert!(
                (turn.scale / exact - 1.0).abs() < 4.0 * f64::EPSILON,
                "{angle}"
            );
            let v = turn.apply(DVec3::new(0.0, -0.2, 0.7));
            let v = v - to * v.dot(to);
            let expected = DVec3::new(0.2 * angle.sin(), -0.2 * angle.cos(), 0.7);
            assert!(
                (v - expected).length() < 1e-15,
                "{angle}: {v} against {expected}"
            );
        }
    }
}
