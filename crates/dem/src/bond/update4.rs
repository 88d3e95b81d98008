//! The bond update four bonds at a time: `kernel::update_bond`'s arithmetic on lanes (see
//! `lanes.rs` for why), giving the same bits as the scalar update for every bond, its rare
//! branches (a large turn or spin in one step) taken lane by lane.

use std::f64::consts::{FRAC_1_PI, PI};

use super::kernel::update_bond;
use super::lanes::{F4, LANES, V4};
use super::{BondOutput, BondParams, BondState};
use crate::particles::Particles;

/// One run of consecutive bonds of the bond list, at most [`LANES`] long.
pub(super) struct Chunk<'a> {
    pub ids: &'a [[u32; 2]],
    pub kind: &'a [u16],
    pub radius: &'a [f64],
    pub stiffness: &'a [f64],
    pub intact: &'a [bool],
    pub state: &'a mut [BondState],
    pub output: &'a mut [BondOutput],
    pub broke: &'a mut [bool],
}

/// What every chunk of one step shares.
pub(super) struct Step<'a> {
    pub particles: &'a Particles,
    pub index_of: &'a [u32],
    pub params: &'a [BondParams],
    pub dt: f64,
    /// Whether this CPU runs AVX2 (checked once per step): the same arithmetic, wider registers.
    pub avx2: bool,
}

impl Step<'_> {
    /// Whether the CPU can run the AVX2 copy of the four-bond update.
    pub fn detect_avx2() -> bool {
        #[cfg(target_arch = "x86_64")]
        {
            std::arch::is_x86_feature_detected!("avx2")
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            false
        }
    }

    /// Updates a chunk's intact bonds; returns how many broke.
    pub fn update(&self, c: Chunk) -> usize {
        if c.ids.len() < LANES {
            return self.update_one_by_one(c);
        }
        #[cfg(target_arch = "x86_64")]
        if self.avx2 {
            // SAFETY: `avx2` is set only where the CPU reports AVX2.
            return unsafe { update_four_avx2(self, c) };
        }
        update_four(self, c)
    }

    fn update_one_by_one(&self, c: Chunk) -> usize {
        let mut broke = 0;
        for k in 0..c.ids.len() {
            c.broke[k] = false;
            if !c.intact[k] {
                c.output[k] = BondOutput::default();
                continue;
            }
            let (i, j) = self.pair(c.ids[k]);
            let b = &self.params[c.kind[k] as usize];
            let out = update_bond(
                self.particles,
                i,
                j,
                b,
                c.radius[k],
                c.stiffness[k],
                &mut c.state[k],
                self.dt,
            );
            c.output[k] = out.unwrap_or_default();
            c.broke[k] = out.is_none();
            broke += usize::from(out.is_none());
        }
        broke
    }

    fn pair(&self, ids: [u32; 2]) -> (usize, usize) {
        (
            self.index_of[ids[0] as usize] as usize,
            self.index_of[ids[1] as usize] as usize,
        )
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn update_four_avx2(step: &Step, c: Chunk) -> usize {
    update_four(step, c)
}

/// `update_bond` on four bonds side by side (`c` holds exactly four). A bond that is not intact
/// borrows an intact one's spheres, and its lane's results are dropped.
#[inline(always)]
fn update_four(step: &Step, c: Chunk) -> usize {
    let Some(first) = (0..LANES).find(|&k| c.intact[k]) else {
        for k in 0..LANES {
            c.output[k] = BondOutput::default();
            c.broke[k] = false;
        }
        return 0;
    };
    let pairs: [(usize, usize); LANES] =
        std::array::from_fn(|k| step.pair(c.ids[if c.intact[k] { k } else { first }]));
    let p = step.particles;
    let dt = step.dt;
    let param = |k: usize| &step.params[c.kind[k] as usize];
    let delta = V4::from_fn(|k| p.position[pairs[k].0]) - V4::from_fn(|k| p.position[pairs[k].1]);
    let dist = delta.length_squared().sqrt();
    let n = delta * dist.recip();
    let wi = V4::from_fn(|k| p.angular_velocity[pairs[k].0]);
    let wj = V4::from_fn(|k| p.angular_velocity[pairs[k].1]);

    // The pair's mean spin about the axis this step, by its series (see `small_angle_sin_cos`).
    let x = F4::splat(0.5) * (wi + wj).dot(n) * dt;
    let x2 = x * x;
    let one = F4::splat(1.0);
    let mut sin =
        x * (one - x2 * (1.0 / 6.0) * (one - x2 * (1.0 / 20.0) * (one - x2 * (1.0 / 42.0))));
    let mut cos = one - x2 * 0.5 * (one - x2 * (1.0 / 12.0) * (one - x2 * (1.0 / 30.0)));
    for k in 0..LANES {
        if x.0[k].abs() >= 1e-2 {
            (sin.0[k], cos.0[k]) = x.0[k].sin_cos();
        }
    }

    // The axis's own turn (see `Turn`).
    let axis = V4::from_fn(|k| c.state[k].axis);
    let turn_cos = axis.dot(n);
    let e = one - turn_cos;
    let half = F4::splat(0.5);
    let mut scale =
        half * (one + half * e * (one + half * e * (one + half * e * (one + half * e))));
    for k in 0..LANES {
        // As in `Turn::new`: the division wherever the series is not used, NaN included.
        if e.0[k].abs() < 1e-4 {
            continue;
        }
        scale.0[k] = (1.0 + turn_cos.0[k]).recip();
    }
    let sine_axis = axis.cross(n);
    let unturned: [bool; LANES] = std::array::from_fn(|k| turn_cos.0[k] > 1.0 - 1e-15);
    let flipped: [bool; LANES] =
        std::array::from_fn(|k| !unturned[k] && turn_cos.0[k] < -1.0 + 1e-12);
    let turn = Turn {
        cos: turn_cos,
        sine_axis,
        scale,
        unturned,
        flipped,
        n,
        spin_cos: cos,
        spin_sin: sin,
    };
    let shear_force = turn.follow(V4::from_fn(|k| c.state[k].shear_force));
    let bending = turn.follow(V4::from_fn(|k| c.state[k].bending));

    let ri = F4::from_fn(|k| p.radius[pairs[k].0]);
    let rj = F4::from_fn(|k| p.radius[pairs[k].1]);
    let share = dist * (ri + rj).recip();
    let ci = ri * share;
    let cj = rj * share;
    let v = V4::from_fn(|k| p.velocity[pairs[k].0]) - V4::from_fn(|k| p.velocity[pairs[k].1]);
    let vn = v.dot(n);
    let vt = v - n * vn - (wi * ci + wj * cj).cross(n);
    let w = wi - wj;
    let wn = w.dot(n);
    let wt = w - n * wn;

    // The section (see `Section::new`).
    let rb = F4::from_fn(|k| c.radius[k]);
    let rb2 = rb * rb;
    let polar = F4::splat(0.5 * PI) * rb2 * rb2;
    let area = F4::splat(PI) * rb2;
    let inertia = half * polar;
    let inv_rb = rb.recip();
    let inv_area = F4::splat(FRAC_1_PI) * inv_rb * inv_rb;
    let rb_over_polar = F4::splat(2.0) * inv_area * inv_rb;

    let stiffness = F4::from_fn(|k| c.stiffness[k]);
    let k_n = F4::from_fn(|k| param(k).normal_stiffness) * stiffness;
    let k_t = F4::from_fn(|k| param(k).shear_stiffness) * stiffness;
    let dt4 = F4::splat(dt);
    let normal_force = F4::from_fn(|k| c.state[k].normal_force) - k_n * area * vn * dt4;
    let shear_force = shear_force - vt * (k_t * area * dt4);
    let twist = F4::from_fn(|k| c.state[k].twist) - k_t * polar * wn * dt4;
    let bending = bending - wt * (k_n * inertia * dt4);

    // The break test (see `Section::breaks`).
    let room = F4::from_fn(|k| param(k).critical_normal_stress) + normal_force * inv_area;
    let bend = F4::splat(2.0) * rb_over_polar;
    let bend_sq = bending.length_squared() * (bend * bend);
    let shear_room = F4::from_fn(|k| param(k).critical_shear_stress) - twist.abs() * rb_over_polar;
    let shear_sq = shear_force.length_squared() * (inv_area * inv_area);
    let breaks: [bool; LANES] = std::array::from_fn(|k| {
        let (room, shear_room) = (room.0[k], shear_room.0[k]);
        room <= 0.0
            || bend_sq.0[k] >= room * room
            || shear_room <= 0.0
            || shear_sq.0[k] >= shear_room * shear_room
    });

    let moment = n * twist + bending;
    let lever = n.cross(shear_force);
    let force = n * normal_force + shear_force;
    let torque_first = moment - lever * ci;
    let torque_second = -moment - lever * cj;
    let mut broke = 0;
    for (k, &breaks) in breaks.iter().enumerate() {
        c.broke[k] = false;
        if !c.intact[k] {
            c.output[k] = BondOutput::default();
            continue;
        }
        c.state[k] = BondState {
            normal_force: normal_force.0[k],
            shear_force: shear_force.lane(k),
            twist: twist.0[k],
            bending: bending.lane(k),
            axis: n.lane(k),
        };
        if breaks {
            c.output[k] = BondOutput::default();
            c.broke[k] = true;
            broke += 1;
        } else {
            c.output[k] = BondOutput {
                force: force.lane(k),
                torque_first: torque_first.lane(k),
                torque_second: torque_second.lane(k),
            };
        }
    }
    broke
}

/// `Turn` and the spin of `update_bond`'s `follow`, on lanes.
struct Turn {
    cos: F4,
    sine_axis: V4,
    scale: F4,
    unturned: [bool; LANES],
    flipped: [bool; LANES],
    n: V4,
    spin_cos: F4,
    spin_sin: F4,
}

impl Turn {
    /// A stored tangential vector turned with the bond, kept across it, and spun about it.
    #[inline(always)]
    fn follow(&self, v: V4) -> V4 {
        let k = self.sine_axis;
        let turned = v * self.cos + k.cross(v) + k * (k.dot(v) * self.scale);
        let v = turned.select(self.flipped, -v).select(self.unturned, v);
        let n = self.n;
        let v = v - n * v.dot(n);
        v * self.spin_cos + n.cross(v) * self.spin_sin
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bond::{BondRadius, ContactRadius};
    use glam::DVec3;

    /// The four-bond update against the scalar one, bond by bond, bit for bit: bonds near and
    /// past their limits, broken ones among them, spins and turns that take the rare branches
    /// (a large spin, a large turn, no turn, a flip), with and without AVX2.
    #[test]
    fn four_bonds_side_by_side_are_the_scalar_update_bit_for_bit() {
        let mut draw = super::super::kernel::uniform_draws(11);
        let params = [
            BondParams {
                normal_stiffness: 5.12e9,
                shear_stiffness: 1.28e8,
                critical_normal_stress: 1.6e7,
                critical_shear_stress: 2.48e6,
                radius: BondRadius::DiskScale(1.0),
                contact_radius: ContactRadius::Absolute(6e-4),
                formation_time: 0.0,
                damping: 0.0,
                stiffness_range: 0.0,
            },
            BondParams {
                normal_stiffness: 2e10,
                shear_stiffness: 8e9,
                critical_normal_stress: 3e6,
                critical_shear_stress: 5e6,
                radius: BondRadius::Absolute(3e-4),
                contact_radius: ContactRadius::Scale(1.1),
                formation_time: 0.0,
                damping: 0.0,
                stiffness_range: 0.2,
            },
        ];
        let mut p = Particles::default();
        for k in 0..400 {
            let at = DVec3::new(k as f64 * 1e-3, 0.0, 0.0);
            let wobble = DVec3::new(draw(), draw(), draw()) * 2e-4;
            p.push(
                at + wobble,
                DVec3::new(draw(), draw(), draw()) * 0.05,
                4.3e-4 * (1.0 + 0.2 * draw()),
                88.0,
                0,
            );
            let spin = if k % 37 == 0 { 1e6 } else { 50.0 };
            p.angular_velocity[k] = DVec3::new(draw(), draw(), draw()) * spin;
        }
        let index_of: Vec<u32> = (0..400).collect();
        let bonds = 399;
        let ids: Vec<[u32; 2]> = (0..bonds as u32).map(|k| [k + 1, k]).collect();
        let kind: Vec<u16> = (0..bonds).map(|k| (k % 3 == 0) as u16).collect();
        let radius: Vec<f64> = (0..bonds).map(|_| 4.3e-4 * (1.0 + 0.1 * draw())).collect();
        let stiffness: Vec<f64> = (0..bonds).map(|_| 1.0 + 0.2 * draw()).collect();
        let intact: Vec<bool> = (0..bonds).map(|k| k % 11 != 5).collect();
        let state: Vec<BondState> = (0..bonds)
            .map(|k| {
                let n = (p.position[k + 1] - p.position[k]).normalize();
                let axis = match k % 13 {
                    0 => n,
                    1 => -n,
                    2 => (n + DVec3::new(draw(), draw(), draw()) * 0.1).normalize(),
                    _ => (n + DVec3::new(draw(), draw(), draw()) * 1e-5).normalize(),
                };
                let load = 1.5 * draw().abs();
                BondState {
                    normal_force: 8.0 * draw() * load,
                    shear_force: DVec3::new(draw(), draw(), draw()) * load,
                    twist: 1e-4 * draw() * load,
                    bending: DVec3::new(draw(), draw(), draw()) * 2e-3 * load,
                    axis,
                }
            })
            .collect();
        // Every rare branch is taken by some intact bond.
        let (mut spun, mut turned, mut unturned, mut flipped) = (0, 0, 0, 0);
        for k in (0..bonds).filter(|&k| intact[k]) {
            let n = (p.position[k + 1] - p.position[k]).normalize();
            let w = p.angular_velocity[k + 1] + p.angular_velocity[k];
            spun += usize::from((0.5 * w.dot(n) * 2.3e-7).abs() >= 1e-2);
            let cos = state[k].axis.dot(n);
            turned += usize::from(1.0 - cos >= 1e-4 && cos > -0.5);
            unturned += usize::from(cos > 1.0 - 1e-15);
            flipped += usize::from(cos < -1.0 + 1e-12);
        }
        assert!(
            spun > 0 && turned > 0 && unturned > 0 && flipped > 0,
            "{spun} {turned} {unturned} {flipped}"
        );
        let run = |avx2: bool, four: bool| {
            let step = Step {
                particles: &p,
                index_of: &index_of,
                params: &params,
                dt: 2.3e-7,
                avx2,
            };
            let mut state = state.clone();
            let mut output = vec![BondOutput::default(); bonds];
            let mut broke = vec![false; bonds];
            let mut count = 0;
            for at in (0..bonds).step_by(LANES) {
                let end = (at + LANES).min(bonds);
                let c = Chunk {
                    ids: &ids[at..end],
                    kind: &kind[at..end],
                    radius: &radius[at..end],
                    stiffness: &stiffness[at..end],
                    intact: &intact[at..end],
                    state: &mut state[at..end],
                    output: &mut output[at..end],
                    broke: &mut broke[at..end],
                };
                count += if four {
                    step.update(c)
                } else {
                    step.update_one_by_one(c)
                };
            }
            (state, output, broke, count)
        };
        let bits = |v: DVec3| v.to_array().map(f64::to_bits);
        let (state, output, broke, count) = run(false, false);
        assert!(count > 20 && count < 300, "{count} of {bonds} broke");
        for avx2 in [false, Step::detect_avx2()] {
            let (s4, o4, b4, c4) = run(avx2, true);
            assert_eq!(c4, count);
            assert_eq!(b4, broke);
            for k in 0..bonds {
                let (a, b) = (&state[k], &s4[k]);
                assert_eq!(
                    a.normal_force.to_bits(),
                    b.normal_force.to_bits(),
                    "bond {k}"
                );
                assert_eq!(a.twist.to_bits(), b.twist.to_bits(), "bond {k}");
                for (x, y) in [
                    (a.shear_force, b.shear_force),
                    (a.bending, b.bending),
                    (a.axis, b.axis),
                    (output[k].force, o4[k].force),
                    (output[k].torque_first, o4[k].torque_first),
                    (output[k].torque_second, o4[k].torque_second),
                ] {
                    assert_eq!(bits(x), bits(y), "bond {k}: {x} against {y}");
                }
            }
        }
    }
}
