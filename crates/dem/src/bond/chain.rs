//! The exact response of a straight chain of bonded spheres, the reference the bond model is
//! checked against (docs/physics.md, V7).
//!
//! A chain of `n` bonds of length `l` (centre to centre) and radius R_B: each bond is a bending
//! joint of stiffness k_n I and a shear spring of stiffness k_t A at its contact point (for equal
//! spheres, the bond's mid-point), and an axial spring of stiffness k_n A. Under a load P across
//! the chain at its end, every shear spring carries P and the joint at x_k = (k + 1/2) l carries
//! the moment there, so the end deflects by
//!
//! - free end (a cantilever's tip): P [l^2 (n^3/3 - n/12) / (k_n I) + n / (k_t A)];
//! - guided end (held against turning, as a test's grip): P [l^2 (n^3 - n) / 12 / (k_n I) + n / (k_t A)].
//!
//! The first terms are Euler-Bernoulli's P L^3 / (3 EI) and P L^3 / (12 EI) with EI = k_n I l and
//! L = n l, times (1 - 1/(4 n^2)) and (1 - 1/n^2); the second is the shear springs', which the
//! beam formula leaves out: with k_t = k_n / 40 it is several per cent of the deflection.

use std::f64::consts::PI;

/// How the loaded end of a chain is held.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ChainEnd {
    /// Free to turn (a cantilever's tip).
    Free,
    /// Held against turning (driven by a grip).
    Guided,
}

/// A straight chain of equal bonds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Chain {
    /// Bonds between the held end and the loaded end.
    pub bonds: usize,
    /// Centre-to-centre length of each bond (m).
    pub length: f64,
    /// Bond radius R_B (m).
    pub radius: f64,
    /// k_n and k_t (N/m^3).
    pub normal_stiffness: f64,
    pub shear_stiffness: f64,
}

impl Chain {
    fn area(&self) -> f64 {
        PI * self.radius.powi(2)
    }

    fn second_moment(&self) -> f64 {
        PI * self.radius.powi(4) / 4.0
    }

    /// Axial stiffness end to end (N/m): the bonds' k_n A in series.
    pub fn axial_stiffness(&self) -> f64 {
        self.normal_stiffness * self.area() / self.bonds as f64
    }

    /// Deflection of the loaded end per unit load across the chain (m/N), bending and shear.
    pub fn transverse_compliance(&self, end: ChainEnd) -> f64 {
        let n = self.bonds as f64;
        let bending = match end {
            ChainEnd::Free => n.powi(3) / 3.0 - n / 12.0,
            ChainEnd::Guided => (n.powi(3) - n) / 12.0,
        } * self.length.powi(2)
            / (self.normal_stiffness * self.second_moment());
        bending + self.shear_compliance()
    }

    /// The shear springs' share of [`Self::transverse_compliance`] (m/N).
    pub fn shear_compliance(&self) -> f64 {
        self.bonds as f64 / (self.shear_stiffness * self.area())
    }

    /// Euler-Bernoulli's stiffness with EI = k_n I l (no shear springs, continuous): what V7's
    /// beam formula gives, for comparison.
    pub fn beam_stiffness(&self, end: ChainEnd) -> f64 {
        let span = self.bonds as f64 * self.length;
        let ei = self.normal_stiffness * self.second_moment() * self.length;
        match end {
            ChainEnd::Free => 3.0 * ei / span.powi(3),
            ChainEnd::Guided => 12.0 * ei / span.powi(3),
        }
    }
}

#[cfg(test)]
mod unit {
    use super::*;

    #[test]
    fn one_bond_is_its_joint_and_its_spring() {
        // One bond, free end: the joint turns by P l/2 / (k_n I), the end moves that times l/2,
        // plus the shear spring's P / (k_t A).
        let c = Chain {
            bonds: 1,
            length: 2.0,
            radius: 1.0,
            normal_stiffness: 3.0,
            shear_stiffness: 5.0,
        };
        let i = PI / 4.0;
        let expected = 1.0 / (3.0 * i) + 1.0 / (5.0 * PI);
        assert!((c.transverse_compliance(ChainEnd::Free) - expected).abs() < 1e-12);
        // Guided, one bond cannot bend (its two ends are held parallel): the shear spring alone.
        assert!((c.transverse_compliance(ChainEnd::Guided) - 1.0 / (5.0 * PI)).abs() < 1e-12);
        assert!((c.axial_stiffness() - 3.0 * PI).abs() < 1e-12);
    }

    #[test]
    fn long_stiff_in_shear_chains_tend_to_the_beam() {
        let c = Chain {
            bonds: 400,
            length: 1e-3,
            radius: 5e-4,
            normal_stiffness: 1e10,
            shear_stiffness: 1e16,
        };
        for end in [ChainEnd::Free, ChainEnd::Guided] {
            let k = 1.0 / c.transverse_compliance(end);
            assert!((k / c.beam_stiffness(end) - 1.0).abs() < 1e-4, "{end:?}");
        }
    }
}
