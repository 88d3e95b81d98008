//! Materials and the per-pair interaction table.
//!
//! Users enter EDEM-style values: per material density, Poisson ratio and shear modulus (or Young's
//! modulus); per material pair restitution, static friction and rolling friction. The contact kernel
//! never looks at those raw numbers: [`MaterialTable::pair`] hands it the effective moduli and the
//! damping ratio ([`PairParams`]), computed once when the table is built.

pub use crate::contact::PairParams;
use std::f64::consts::PI;

/// One material as the user enters it.
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    pub name: String,
    /// kg/m^3
    pub density: f64,
    pub poisson_ratio: f64,
    /// Pa (EDEM's input). Young's modulus is E = 2 G (1 + nu).
    pub shear_modulus: f64,
}

impl Material {
    pub fn youngs_modulus(&self) -> f64 {
        2.0 * self.shear_modulus * (1.0 + self.poisson_ratio)
    }

    /// Rayleigh wave time step for a sphere of radius `r` of this material.
    pub fn rayleigh_time_step(&self, r: f64) -> f64 {
        PI * r * (self.density / self.shear_modulus).sqrt() / (0.1631 * self.poisson_ratio + 0.8766)
    }
}

/// Interaction parameters of one material pair as the user enters them.
#[derive(Clone, Debug, PartialEq)]
pub struct Interaction {
    pub restitution: f64,
    pub static_friction: f64,
    /// Also called "dynamic" or "kinetic" friction in many calibration papers.
    pub rolling_friction: f64,
    /// JKR surface energy gamma (J/m^2); 0 for no cohesion.
    pub surface_energy: f64,
}

/// Smallest restitution accepted; a zero restitution makes beta = -1 and the damping infinite.
pub const MIN_RESTITUTION: f64 = 1e-4;

/// beta = ln(e) / sqrt(ln(e)^2 + pi^2), the Hertz-Mindlin damping ratio.
pub fn damping_beta(restitution: f64) -> f64 {
    let e = restitution.max(MIN_RESTITUTION);
    if e >= 1.0 {
        return 0.0;
    }
    let l = e.ln();
    l / (l * l + PI * PI).sqrt()
}

/// Materials plus a dense table of pair parameters indexed by material ids.
#[derive(Clone, Debug, Default)]
pub struct MaterialTable {
    materials: Vec<Material>,
    interactions: Vec<Option<Interaction>>,
    pairs: Vec<PairParams>,
}

impl MaterialTable {
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds a material and returns its id.
    pub fn add_material(&mut self, m: Material) -> usize {
        self.materials.push(m);
        let n = self.materials.len();
        let mut inter = vec![None; n * n];
        for a in 0..n - 1 {
            for b in 0..n - 1 {
                inter[a * n + b] = self.interactions[a * (n - 1) + b].clone();
            }
        }
        self.interactions = inter;
        self.rebuild();
        n - 1
    }

    /// Sets the interaction of a pair (symmetric).
    pub fn set_interaction(&mut self, a: usize, b: usize, i: Interaction) {
        let n = self.materials.len();
        self.interactions[a * n + b] = Some(i.clone());
        self.interactions[b * n + a] = Some(i);
        self.rebuild();
    }

    pub fn len(&self) -> usize {
        self.materials.len()
    }

    pub fn is_empty(&self) -> bool {
        self.materials.is_empty()
    }

    pub fn material(&self, id: usize) -> &Material {
        &self.materials[id]
    }

    pub fn materials(&self) -> &[Material] {
        &self.materials
    }

    pub fn id_of(&self, name: &str) -> Option<usize> {
        self.materials.iter().position(|m| m.name == name)
    }

    pub fn interaction(&self, a: usize, b: usize) -> Option<&Interaction> {
        self.interactions[a * self.materials.len() + b].as_ref()
    }

    #[inline(always)]
    pub fn pair(&self, a: usize, b: usize) -> &PairParams {
        &self.pairs[a * self.materials.len() + b]
    }

    /// Every pair's parameters (for laws that look over all of them, e.g. the cohesive reach).
    pub fn pairs(&self) -> &[PairParams] {
        &self.pairs
    }

    fn rebuild(&mut self) {
        let n = self.materials.len();
        self.pairs = vec![PairParams::default(); n * n];
        for a in 0..n {
            for b in 0..n {
                let (ma, mb) = (&self.materials[a], &self.materials[b]);
                let e_star = 1.0
                    / ((1.0 - ma.poisson_ratio.powi(2)) / ma.youngs_modulus()
                        + (1.0 - mb.poisson_ratio.powi(2)) / mb.youngs_modulus());
                let g_star = 1.0
                    / ((2.0 - ma.poisson_ratio) / ma.shear_modulus
                        + (2.0 - mb.poisson_ratio) / mb.shear_modulus);
                let mut p = PairParams {
                    e_star,
                    g_star,
                    tangential_damping_ratio: (4.0 * g_star / e_star).sqrt(),
                    ..Default::default()
                };
                if let Some(i) = &self.interactions[a * n + b] {
                    p.damping_ratio = -damping_beta(i.restitution);
                    p.hertz_damping = 2.0 * (5.0f64 / 6.0).sqrt() * p.damping_ratio;
                    p.static_friction = i.static_friction;
                    p.rolling_friction = i.rolling_friction;
                    p.surface_energy = i.surface_energy;
                }
                self.pairs[a * n + b] = p;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn effective_moduli_of_equal_materials() {
        let mut t = MaterialTable::new();
        let g = t.add_material(Material {
            name: "glass".into(),
            density: 2800.0,
            poisson_ratio: 0.2,
            shear_modulus: 48e9 / 2.4,
        });
        t.set_interaction(
            g,
            g,
            Interaction {
                restitution: 0.5,
                static_friction: 0.3,
                rolling_friction: 0.01,
                surface_energy: 0.0,
            },
        );
        let p = t.pair(g, g);
        assert!((p.e_star - 48e9 / (2.0 * 0.96)).abs() / p.e_star < 1e-12);
        assert!((p.g_star - 20e9 / (2.0 * 1.8)).abs() / p.g_star < 1e-12);
        // beta(0.5) = ln 0.5 / sqrt(ln^2 0.5 + pi^2)
        let beta = 0.5f64.ln() / (0.5f64.ln().powi(2) + PI * PI).sqrt();
        assert!((p.damping_ratio + beta).abs() < 1e-15);
        assert!((p.hertz_damping + 2.0 * (5.0f64 / 6.0).sqrt() * beta).abs() < 1e-12);
    }
}
