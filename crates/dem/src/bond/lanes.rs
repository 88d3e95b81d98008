//! Four f64 lanes and three-vectors of them, for updating four bonds at once.
//!
//! Why by hand: one bond's update is a chain of dependent square roots, divisions and products,
//! so a core runs it at about one instruction per cycle, waiting on latencies (`perf annotate` of
//! a seed-000 run: three quarters of the run in the bond update). Four independent bonds side by
//! side fill those waits and let the compiler use packed instructions. `std::simd` is not stable;
//! plain arrays that LLVM vectorises rather than the `wide` crate (tried for the contacts,
//! docs/benchmarks.md): `wide` picks its instructions when it is compiled (SSE2 on the baseline
//! target), while these inline into an AVX2 copy of the update that `update4.rs` chooses at run
//! time, so one binary uses AVX2 where the CPU has it. Every operation is the one `glam::DVec3`
//! performs, in the same order, so a lane gives the same bits as the scalar code.

use glam::DVec3;
use std::ops::{Add, Mul, Neg, Sub};

/// Number of bonds updated side by side.
pub(super) const LANES: usize = 4;

#[derive(Clone, Copy, Debug)]
pub(super) struct F4(pub [f64; LANES]);

impl F4 {
    #[inline(always)]
    pub fn splat(x: f64) -> F4 {
        F4([x; LANES])
    }

    #[inline(always)]
    pub fn from_fn(f: impl FnMut(usize) -> f64) -> F4 {
        F4(std::array::from_fn(f))
    }

    #[inline(always)]
    fn zip(self, o: F4, f: impl Fn(f64, f64) -> f64) -> F4 {
        F4::from_fn(|k| f(self.0[k], o.0[k]))
    }

    #[inline(always)]
    pub fn sqrt(self) -> F4 {
        F4::from_fn(|k| self.0[k].sqrt())
    }

    /// `1 / x`, as `f64::recip`.
    #[inline(always)]
    pub fn recip(self) -> F4 {
        F4::from_fn(|k| 1.0 / self.0[k])
    }

    #[inline(always)]
    pub fn abs(self) -> F4 {
        F4::from_fn(|k| self.0[k].abs())
    }
}

impl Add for F4 {
    type Output = F4;
    #[inline(always)]
    fn add(self, o: F4) -> F4 {
        self.zip(o, |a, b| a + b)
    }
}

impl Sub for F4 {
    type Output = F4;
    #[inline(always)]
    fn sub(self, o: F4) -> F4 {
        self.zip(o, |a, b| a - b)
    }
}

impl Mul for F4 {
    type Output = F4;
    #[inline(always)]
    fn mul(self, o: F4) -> F4 {
        self.zip(o, |a, b| a * b)
    }
}

impl Mul<f64> for F4 {
    type Output = F4;
    #[inline(always)]
    fn mul(self, o: f64) -> F4 {
        self * F4::splat(o)
    }
}

impl Neg for F4 {
    type Output = F4;
    #[inline(always)]
    fn neg(self) -> F4 {
        F4::from_fn(|k| -self.0[k])
    }
}

/// Four three-vectors, component by component.
#[derive(Clone, Copy, Debug)]
pub(super) struct V4 {
    pub x: F4,
    pub y: F4,
    pub z: F4,
}

impl V4 {
    #[inline(always)]
    pub fn from_fn(mut f: impl FnMut(usize) -> DVec3) -> V4 {
        let v: [DVec3; LANES] = std::array::from_fn(&mut f);
        V4 {
            x: F4::from_fn(|k| v[k].x),
            y: F4::from_fn(|k| v[k].y),
            z: F4::from_fn(|k| v[k].z),
        }
    }

    #[inline(always)]
    pub fn lane(&self, k: usize) -> DVec3 {
        DVec3::new(self.x.0[k], self.y.0[k], self.z.0[k])
    }

    /// As `DVec3::dot`: (x x' + y y') + z z'.
    #[inline(always)]
    pub fn dot(self, o: V4) -> F4 {
        self.x * o.x + self.y * o.y + self.z * o.z
    }

    #[inline(always)]
    pub fn length_squared(self) -> F4 {
        self.dot(self)
    }

    /// As `DVec3::cross`.
    #[inline(always)]
    pub fn cross(self, o: V4) -> V4 {
        V4 {
            x: self.y * o.z - o.y * self.z,
            y: self.z * o.x - o.z * self.x,
            z: self.x * o.y - o.x * self.y,
        }
    }

    /// Lane by lane: `a` where `take[k]`, else `self`.
    #[inline(always)]
    pub fn select(self, take: [bool; LANES], a: V4) -> V4 {
        V4::from_fn(|k| if take[k] { a.lane(k) } else { self.lane(k) })
    }
}

impl Add for V4 {
    type Output = V4;
    #[inline(always)]
    fn add(self, o: V4) -> V4 {
        V4 {
            x: self.x + o.x,
            y: self.y + o.y,
            z: self.z + o.z,
        }
    }
}

impl Sub for V4 {
    type Output = V4;
    #[inline(always)]
    fn sub(self, o: V4) -> V4 {
        V4 {
            x: self.x - o.x,
            y: self.y - o.y,
            z: self.z - o.z,
        }
    }
}

/// Each vector times its lane's scalar.
impl Mul<F4> for V4 {
    type Output = V4;
    #[inline(always)]
    fn mul(self, s: F4) -> V4 {
        V4 {
            x: self.x * s,
            y: self.y * s,
            z: self.z * s,
        }
    }
}

impl Neg for V4 {
    type Output = V4;
    #[inline(always)]
    fn neg(self) -> V4 {
        V4 {
            x: -self.x,
            y: -self.y,
            z: -self.z,
        }
    }
}
