//! Bonded particles: EDEM's "Hertz-Mindlin with bonding" (Bonding V2), the Potyondy-Cundall
//! parallel bond, as `docs/physics.md` ("Bonded particle model") states it.
//!
//! Design notes:
//! - **A step extension.** Bonds are a [`StepExtension`]: they add their forces after the contacts
//!   and before the second half kick, so the step knows nothing of them. The Hertz-Mindlin contact
//!   still acts between bonded spheres that overlap; bond forces add to it.
//! - **Keyed by stable ids.** The engine reorders particles by cell; a bond names its two spheres by
//!   their stable ids and looks up their current index each step.
//! - **Formed once.** Pairs whose contact spheres overlap at the formation time bond, each pair at
//!   most once; a broken bond is kept (flagged) for output and never re-forms.
//! - **Incremental.** The bond's normal force, shear force, twisting and bending moments start at
//!   zero and grow with the relative motion: `dF_n = -k_n A v_n dt`, `dF_t = -k_t A v_t dt`,
//!   `dM_n = -k_t J w_n dt`, `dM_t = -k_n I w_t dt`. The velocities are the mid-step ones (after
//!   the first half kick), so the increment is the central difference of the displacement over the
//!   step. The stored shear force and bending moment are turned with the bond each step: by the
//!   rotation taking the old bond axis to the new one, then about the axis by the pair's mean spin.
//! - **Breakage.** `sigma = -F_n/A + |M_t| R_B/I >= sigma_c` breaks in tension, `tau = |F_t|/A +
//!   |M_n| R_B/J >= tau_c` in shear (tension is checked first). Each break is logged with its time,
//!   position, mode and ids.
//! - **Deterministic.** Each bond is evaluated on its own (in parallel) into its own slot; the slots
//!   are summed onto the particles in bond order, so results do not depend on the thread count.
//! - **Damping.** Off by default. `damping` > 0 is the PFC local (non-viscous) damping fraction
//!   of every bonded sphere: each component of the sphere's whole force (torque) when the bonds
//!   have added theirs (contacts, gravity, extensions added before the bonds, bonds) is reduced by
//!   `damping` times its magnitude against the sphere's velocity (spin) component. It damps the
//!   unbalanced force, not each bond's (which would nearly cancel), so a quasi-static specimen
//!   settles fast; it is not viscous, so it does not depend on the loading speed. A held sphere
//!   (infinite mass: a test's grip) is not damped: its force is what a tool measures.
//! - **Stiffness range.** EDEM's option: with `stiffness_range` r > 0 each bond's k_n and k_t are
//!   both multiplied by one factor drawn uniformly from [1 - r, 1 + r] when it forms, from a hash
//!   of its two stable ids (the same bond gets the same draw whatever the particle order or the
//!   thread count).

pub mod chain;
mod kernel;
mod lanes;
pub mod output;
pub mod segment;
mod update4;

use crate::particles::{Particles, NO_BODY};
use crate::sim::{OnDevice, SimError, Simulation, StepExtension};
use glam::DVec3;
use rayon::prelude::*;
use std::any::Any;
use std::collections::HashMap;
use std::f64::consts::PI;

use kernel::{local_damping, Section};
use segment::{SegmentBonds, SegmentBondsEnd};

/// The bond's radius.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum BondRadius {
    /// Metres.
    Absolute(f64),
    /// EDEM's "bonded disk scale": times the smaller sphere's radius.
    DiskScale(f64),
}

/// Which pairs bond: those whose contact spheres overlap.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ContactRadius {
    /// EDEM's contact radius (m), the same for both spheres: pairs closer than twice it bond.
    Absolute(f64),
    /// Times each sphere's radius: pairs closer than `scale (R_i + R_j)` bond.
    Scale(f64),
}

/// A material pair's bond parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BondParams {
    /// k_n, normal stiffness per area (N/m^3).
    pub normal_stiffness: f64,
    /// k_t, shear stiffness per area (N/m^3).
    pub shear_stiffness: f64,
    /// sigma_c (Pa).
    pub critical_normal_stress: f64,
    /// tau_c (Pa).
    pub critical_shear_stress: f64,
    pub radius: BondRadius,
    pub contact_radius: ContactRadius,
    /// When the bonds form (s).
    pub formation_time: f64,
    /// PFC local damping fraction (0 = off).
    pub damping: f64,
    /// EDEM's stiffness range: each bond's stiffnesses times a factor drawn uniformly from
    /// [1 - r, 1 + r] (0 = every bond the same).
    pub stiffness_range: f64,
}

impl BondParams {
    /// The bond radius between spheres of radii `a` and `b`.
    pub fn bond_radius(&self, a: f64, b: f64) -> f64 {
        match self.radius {
            BondRadius::Absolute(r) => r,
            BondRadius::DiskScale(s) => s * a.min(b),
        }
    }

    /// Largest centre distance at which spheres of radii `a` and `b` bond.
    pub fn bonding_distance(&self, a: f64, b: f64) -> f64 {
        match self.contact_radius {
            ContactRadius::Absolute(c) => 2.0 * c,
            ContactRadius::Scale(s) => s * (a + b),
        }
    }
}

/// How a bond broke.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BreakMode {
    Tension,
    Shear,
}

impl BreakMode {
    pub fn name(self) -> &'static str {
        match self {
            BreakMode::Tension => "tension",
            BreakMode::Shear => "shear",
        }
    }
}

/// One breakage, as the crack-growth log records it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Breakage {
    pub time: f64,
    /// The bond's mid-point.
    pub position: DVec3,
    pub mode: BreakMode,
    /// The two spheres' stable ids.
    pub ids: [u32; 2],
    /// The stresses at breakage (Pa).
    pub normal_stress: f64,
    pub shear_stress: f64,
}

/// The stored state of one bond.
#[derive(Clone, Copy, Debug, Default)]
struct BondState {
    /// Along the bond axis, positive pushing the spheres apart (N).
    normal_force: f64,
    shear_force: DVec3,
    /// Twisting moment about the axis (N m).
    twist: f64,
    bending: DVec3,
    /// The axis (from the second sphere to the first) at the last update.
    axis: DVec3,
}

/// What one bond does to its spheres this step (zero once broken). Whether it broke this step is
/// kept apart (`broke_now`), so that the gather reads 72 bytes per bond instead of 96.
#[derive(Clone, Copy, Debug, Default)]
struct BondOutput {
    /// Force on the first sphere (the second gets its opposite).
    force: DVec3,
    torque_first: DVec3,
    torque_second: DVec3,
}

/// Bonds per particle above which the contact radius is taken for a mistake (a close packing
/// has 12 neighbours; a random one at a contact radius of 1.5 radii about 20).
const MAX_BONDS_PER_SPHERE: usize = 40;

/// The bonds of a simulation: parameters per material pair and every bond's state.
#[derive(Clone, Debug)]
pub struct Bonds {
    params: Vec<BondParams>,
    /// For material pair (a, b): index into `params` at `a * materials + b`.
    pair: Vec<Option<u16>>,
    materials: usize,
    formed: Vec<bool>,
    ids: Vec<[u32; 2]>,
    kind: Vec<u16>,
    radius: Vec<f64>,
    /// Each bond's stiffness factor (1 without a stiffness range).
    stiffness: Vec<f64>,
    intact: Vec<bool>,
    state: Vec<BondState>,
    output: Vec<BondOutput>,
    /// Set by the update for the bonds that broke in it, cleared when they are logged.
    broke_now: Vec<bool>,
    /// Whether any bond kind has local damping: the gather skips the lookup otherwise.
    damped: bool,
    breakages: Vec<Breakage>,
    /// (time, intact, broken) at formation and after every step with a breakage.
    history: Vec<(f64, usize, usize)>,
    broken: usize,
    /// Time of the last incremental update (forces recomputed without a step are re-applied).
    last_update: f64,
    warnings: Vec<String>,
    /// Bonds by stable id (compressed rows): the bonds of id `k` are
    /// `by_id[by_id_start[k]..by_id_start[k + 1]]`, each `2 b` (first sphere of bond b) or
    /// `2 b + 1` (second), in bond order. Each sphere gathers its own bonds' forces, so the sum is
    /// parallel and its order does not depend on the thread count.
    by_id_start: Vec<u32>,
    by_id: Vec<u32>,
}

impl Bonds {
    /// Bonds for `materials` materials with parameters per material pair (either order).
    pub fn new(materials: usize, pairs: &[([usize; 2], BondParams)]) -> Bonds {
        let mut pair = vec![None; materials * materials];
        let mut params = Vec::new();
        for ([a, b], p) in pairs {
            let k = params.len() as u16;
            params.push(*p);
            pair[a * materials + b] = Some(k);
            pair[b * materials + a] = Some(k);
        }
        Bonds {
            formed: vec![false; params.len()],
            params,
            pair,
            materials,
            ids: Vec::new(),
            kind: Vec::new(),
            radius: Vec::new(),
            stiffness: Vec::new(),
            intact: Vec::new(),
            state: Vec::new(),
            output: Vec::new(),
            broke_now: Vec::new(),
            damped: pairs.iter().any(|(_, p)| p.damping > 0.0),
            breakages: Vec::new(),
            history: Vec::new(),
            broken: 0,
            last_update: f64::NEG_INFINITY,
            warnings: Vec::new(),
            by_id_start: vec![0],
            by_id: Vec::new(),
        }
    }

    /// Bonds formed so far (intact and broken).
    pub fn len(&self) -> usize {
        self.ids.len()
    }

    pub fn is_empty(&self) -> bool {
        self.ids.is_empty()
    }

    pub fn intact_count(&self) -> usize {
        self.ids.len() - self.broken
    }

    pub fn broken_count(&self) -> usize {
        self.broken
    }

    /// Every breakage so far, in order.
    pub fn breakages(&self) -> &[Breakage] {
        &self.breakages
    }

    /// (time, intact, broken) at formation and after every step in which bonds broke.
    pub fn history(&self) -> &[(f64, usize, usize)] {
        &self.history
    }

    /// Time-step warnings raised when bonds formed.
    pub fn warnings(&self) -> &[String] {
        &self.warnings
    }

    /// The two stable ids, whether intact, of bond `k`.
    pub fn bond(&self, k: usize) -> ([u32; 2], bool) {
        (self.ids[k], self.intact[k])
    }

    /// Bond `k`'s normal force (N, positive pushing apart) and shear force magnitude (N).
    pub fn bond_forces(&self, k: usize) -> (f64, f64) {
        (
            self.state[k].normal_force,
            self.state[k].shear_force.length(),
        )
    }

    /// Every intact bond's sigma / sigma_c and tau / tau_c now: how near each is to breaking (1
    /// breaks), in bond order.
    pub fn stress_ratios(&self) -> Vec<(f64, f64)> {
        (0..self.ids.len())
            .filter(|&b| self.intact[b])
            .map(|b| {
                let p = &self.params[self.kind[b] as usize];
                let (sigma, tau) = Section::new(self.radius[b]).stresses(&self.state[b]);
                (
                    sigma / p.critical_normal_stress,
                    tau / p.critical_shear_stress,
                )
            })
            .collect()
    }

    /// Bond `k`'s stiffness factor (1 unless a stiffness range is set).
    pub fn stiffness_factor(&self, k: usize) -> f64 {
        self.stiffness[k]
    }

    /// Whether every material pair with bonds has formed them.
    pub fn all_formed(&self) -> bool {
        self.formed.iter().all(|f| *f)
    }

    /// Forms the bonds of every material pair whose formation time has come by `time`: each pair
    /// of free spheres (not clump members) whose contact spheres overlap, not bonded before.
    /// Returns the time-step warnings raised (also kept, see [`Self::warnings`]); an error when
    /// the contact radius bonds absurdly many pairs.
    pub fn form_due(
        &mut self,
        particles: &Particles,
        time: f64,
        dt: f64,
    ) -> Result<Vec<String>, String> {
        let due: Vec<bool> = (0..self.params.len())
            .map(|k| !self.formed[k] && self.params[k].formation_time <= time + 1e-12 * dt)
            .collect();
        if !due.iter().any(|d| *d) {
            return Ok(Vec::new());
        }
        let p = particles;
        let kind_of = |a: u16, b: u16| -> Option<u16> {
            let k = self.pair[a as usize * self.materials + b as usize]?;
            due[k as usize].then_some(k)
        };
        // Spheres that take part, on a grid of the largest bonding distance.
        let takes_part: Vec<usize> = (0..p.len())
            .filter(|&k| {
                p.body[k] == NO_BODY
                    && (p.material[k] as usize) < self.materials
                    && (0..self.materials as u16).any(|m| kind_of(p.material[k], m).is_some())
            })
            .collect();
        let reach = takes_part
            .iter()
            .map(|&k| {
                let r = p.radius[k];
                self.params
                    .iter()
                    .map(|b| b.bonding_distance(r, r))
                    .fold(0.0, f64::max)
            })
            .fold(0.0, f64::max);
        if takes_part.is_empty() || reach <= 0.0 {
            self.mark_formed(&due, time);
            return Ok(Vec::new());
        }
        let cell = |x: DVec3| -> (i64, i64, i64) {
            let c = (x / reach).floor();
            (c.x as i64, c.y as i64, c.z as i64)
        };
        let mut grid: HashMap<(i64, i64, i64), Vec<usize>> = HashMap::new();
        for &k in &takes_part {
            grid.entry(cell(p.position[k])).or_default().push(k);
        }
        let mut existing: std::collections::HashSet<[u32; 2]> = self.ids.iter().cloned().collect();
        let mut new_bonds: Vec<([u32; 2], u16, usize, usize)> = Vec::new();
        for &i in &takes_part {
            let (cx, cy, cz) = cell(p.position[i]);
            for dx in -1..=1 {
                for dy in -1..=1 {
                    for dz in -1..=1 {
                        // Saturating: a reach far below the positions' scale puts cells at
                        // i64's ends (a contact radius of 1e-320 overflowed here).
                        let key = (
                            cx.saturating_add(dx),
                            cy.saturating_add(dy),
                            cz.saturating_add(dz),
                        );
                        let Some(list) = grid.get(&key) else {
                            continue;
                        };
                        for &j in list {
                            if p.id[j] <= p.id[i] {
                                continue;
                            }
                            let Some(kind) = kind_of(p.material[i], p.material[j]) else {
                                continue;
                            };
                            let b = &self.params[kind as usize];
                            let d = (p.position[i] - p.position[j]).length();
                            if d < b.bonding_distance(p.radius[i], p.radius[j]) && d > 0.0 {
                                let ids = [p.id[i], p.id[j]];
                                if existing.insert(ids) {
                                    new_bonds.push((ids, kind, i, j));
                                }
                            }
                        }
                    }
                }
                if new_bonds.len() > MAX_BONDS_PER_SPHERE * takes_part.len() {
                    return Err(format!(
                        "bond: more than {MAX_BONDS_PER_SPHERE} bonds per sphere: the contact radius is far too large for the packing"
                    ));
                }
            }
        }
        // Stable-id order, whatever the particle order was.
        new_bonds.sort_unstable_by_key(|b| b.0);
        for (ids, kind, i, j) in new_bonds {
            let b = &self.params[kind as usize];
            self.ids.push(ids);
            self.kind.push(kind);
            self.radius.push(b.bond_radius(p.radius[i], p.radius[j]));
            self.stiffness
                .push(1.0 + b.stiffness_range * (2.0 * unit_draw(ids, kind) - 1.0));
            self.intact.push(true);
            self.state.push(BondState {
                axis: (p.position[i] - p.position[j]).normalize(),
                ..BondState::default()
            });
            self.output.push(BondOutput::default());
            self.broke_now.push(false);
        }
        self.index_by_id();
        self.mark_formed(&due, time);
        let warnings = self.time_step_check(p, dt);
        self.warnings.extend(warnings.iter().cloned());
        Ok(warnings)
    }

    /// Puts the bonds in the order of their first sphere's current index, so that the update
    /// reads the particles nearly in order and each sphere's gather finds its bonds' outputs
    /// close together (measured in docs/benchmarks.md). Nothing moves when the order holds
    /// already (a quasi-static specimen is re-sorted the same way at most rebuilds).
    fn follow_particle_order(&mut self, index_of: &[u32]) {
        let key = |ids: &[u32; 2]| -> u32 {
            let (a, b) = (ids[0] as usize, ids[1] as usize);
            match (index_of.get(a), index_of.get(b)) {
                (Some(&x), Some(&y)) => x.min(y),
                _ => u32::MAX,
            }
        };
        if self.ids.windows(2).all(|w| key(&w[0]) <= key(&w[1])) {
            return;
        }
        let mut order: Vec<u32> = (0..self.ids.len() as u32).collect();
        order.sort_by_key(|&b| (key(&self.ids[b as usize]), b));
        fn permute<T: Copy>(v: &mut Vec<T>, order: &[u32]) {
            *v = order.iter().map(|&b| v[b as usize]).collect();
        }
        permute(&mut self.ids, &order);
        permute(&mut self.kind, &order);
        permute(&mut self.radius, &order);
        permute(&mut self.stiffness, &order);
        permute(&mut self.intact, &order);
        permute(&mut self.state, &order);
        permute(&mut self.output, &order);
        permute(&mut self.broke_now, &order);
        self.index_by_id();
    }

    /// Rebuilds the bonds-by-id rows after bonds formed.
    fn index_by_id(&mut self) {
        let ids = self.ids.iter().flatten().map(|&id| id as usize + 1).max();
        let mut start = vec![0u32; ids.unwrap_or(0) + 1];
        for &id in self.ids.iter().flatten() {
            start[id as usize + 1] += 1;
        }
        for k in 1..start.len() {
            start[k] += start[k - 1];
        }
        let mut fill = start.clone();
        let mut by_id = vec![0u32; 2 * self.ids.len()];
        for (b, ids) in self.ids.iter().enumerate() {
            for (end, &id) in ids.iter().enumerate() {
                let slot = &mut fill[id as usize];
                by_id[*slot as usize] = 2 * b as u32 + end as u32;
                *slot += 1;
            }
        }
        self.by_id_start = start;
        self.by_id = by_id;
    }

    fn mark_formed(&mut self, due: &[bool], time: f64) {
        // New bonds start from zero at `time`: forces recomputed then add nothing.
        self.last_update = self.last_update.max(time);
        for (f, d) in self.formed.iter_mut().zip(due) {
            *f |= *d;
        }
        self.history
            .push((time, self.intact_count(), self.broken_count()));
    }

    /// The highest natural frequency of the bonded spheres (rad/s), estimated sphere by sphere
    /// from the stiffness of its bonds against its mass and inertia (the neighbours moving
    /// opposite, hence the factor 2).
    pub fn highest_frequency(&self, p: &Particles) -> f64 {
        let mut index: HashMap<u32, usize> = HashMap::with_capacity(p.len());
        for k in 0..p.len() {
            index.insert(p.id[k], k);
        }
        let mut translational = vec![0.0f64; p.len()];
        let mut rotational = vec![0.0f64; p.len()];
        for b in 0..self.ids.len() {
            if !self.intact[b] {
                continue;
            }
            let (Some(&i), Some(&j)) = (index.get(&self.ids[b][0]), index.get(&self.ids[b][1]))
            else {
                continue;
            };
            let params = &self.params[self.kind[b] as usize];
            let rb = self.radius[b];
            let area = PI * rb * rb;
            let polar = 0.5 * PI * rb.powi(4);
            let (k_n, k_t) = (
                params.normal_stiffness * self.stiffness[b],
                params.shear_stiffness * self.stiffness[b],
            );
            let k = k_n.max(k_t) * area;
            let moment = (k_n * 0.5 * polar).max(k_t * polar);
            let d = (p.position[i] - p.position[j]).length();
            for (s, r_s, r_o) in [(i, p.radius[i], p.radius[j]), (j, p.radius[j], p.radius[i])] {
                let lever = d * r_s / (r_s + r_o);
                translational[s] += k;
                rotational[s] += moment + k_t * area * lever * lever;
            }
        }
        (0..p.len())
            .map(|s| {
                let t = translational[s] * p.inv_mass[s];
                let r = rotational[s] * p.inv_inertia[s];
                (2.0 * t.max(r)).sqrt()
            })
            .fold(0.0, f64::max)
    }

    /// The time step the bonds take accurately: `SAFE_PHASE` radians of their fastest
    /// oscillation per step.
    pub fn safe_time_step(&self, p: &Particles) -> Option<f64> {
        let w = self.highest_frequency(p);
        (w > 0.0).then(|| SAFE_PHASE / w)
    }

    fn time_step_check(&self, p: &Particles, dt: f64) -> Vec<String> {
        match self.safe_time_step(p) {
            Some(safe) if dt > safe => vec![format!(
                "the time step {dt:.3e} s is too long for the bond stiffness: the stiffest bonded sphere \
                 oscillates every {:.3e} s; use at most {safe:.3e} s ({:.0} % of the present step)",
                2.0 * PI * SAFE_PHASE.recip() * safe,
                100.0 * safe / dt
            )],
            _ => Vec::new(),
        }
    }

    /// Updates every intact bond for the step ending at `time` and adds its forces to the spheres.
    fn update(&mut self, p: &mut Particles, index_of: &[u32], dt: f64, time: f64) {
        let step = update4::Step {
            particles: p,
            index_of,
            params: &self.params,
            dt,
            avx2: update4::Step::detect_avx2(),
        };
        // Chunks of four consecutive bonds, updated side by side (`update4.rs`).
        const L: usize = lanes::LANES;
        let broke: usize = self
            .ids
            .par_chunks(L)
            .zip(self.kind.par_chunks(L))
            .zip(self.radius.par_chunks(L))
            .zip(self.stiffness.par_chunks(L))
            .zip(self.intact.par_chunks(L))
            .zip(self.state.par_chunks_mut(L))
            .zip(self.output.par_chunks_mut(L))
            .zip(self.broke_now.par_chunks_mut(L))
            .with_min_len(64)
            .map(
                |(((((((ids, kind), radius), stiffness), intact), state), output), broke)| {
                    step.update(update4::Chunk {
                        ids,
                        kind,
                        radius,
                        stiffness,
                        intact,
                        state,
                        output,
                        broke,
                    })
                },
            )
            .sum();
        if broke > 0 {
            self.record_breakages(p, index_of, time);
        }
        self.apply(p);
    }

    /// Marks the bonds that broke in this step's update as broken and logs them, by stable ids.
    fn record_breakages(&mut self, p: &Particles, index_of: &[u32], time: f64) {
        // By stable ids within the step: the bond order follows the particles' (re-sorted at
        // rebuilds), and a device keeps it fixed over a segment (`segment.rs`).
        let mut broke: Vec<usize> = (0..self.ids.len())
            .filter(|&b| std::mem::take(&mut self.broke_now[b]) && self.intact[b])
            .collect();
        broke.sort_by_key(|&b| self.ids[b]);
        for b in broke {
            // The stresses and the limit it broke at, from the state the update left.
            let section = Section::new(self.radius[b]);
            let (sigma, tau) = section.stresses(&self.state[b]);
            let mode = section
                .breaks(&self.state[b], &self.params[self.kind[b] as usize])
                .unwrap_or(BreakMode::Shear);
            let i = index_of[self.ids[b][0] as usize] as usize;
            let j = index_of[self.ids[b][1] as usize] as usize;
            self.intact[b] = false;
            self.broken += 1;
            self.breakages.push(Breakage {
                time,
                position: 0.5 * (p.position[i] + p.position[j]),
                mode,
                ids: self.ids[b],
                normal_stress: sigma,
                shear_stress: tau,
            });
        }
        self.history
            .push((time, self.intact_count(), self.broken_count()));
    }

    /// Adds each intact bond's stored output to its spheres: every sphere gathers its own bonds
    /// in bond order (in parallel, the same sums for any thread count), then local damping.
    fn apply(&self, p: &mut Particles) {
        let Particles {
            id,
            force,
            torque,
            velocity,
            angular_velocity,
            inv_mass,
            ..
        } = p;
        let (start, by_id) = (&self.by_id_start, &self.by_id);
        id.par_iter()
            .zip(force.par_iter_mut())
            .zip(torque.par_iter_mut())
            .zip(velocity.par_iter())
            .zip(angular_velocity.par_iter())
            .zip(inv_mass.par_iter())
            .with_min_len(512)
            .for_each(
                |(((((&id, force), torque), velocity), angular_velocity), &inv_mass)| {
                    let id = id as usize;
                    if id + 1 >= start.len() {
                        return;
                    }
                    let mut damping: f64 = 0.0;
                    for &slot in &by_id[start[id] as usize..start[id + 1] as usize] {
                        let b = (slot / 2) as usize;
                        if !self.intact[b] {
                            continue;
                        }
                        let o = &self.output[b];
                        if slot % 2 == 0 {
                            *force += o.force;
                            *torque += o.torque_first;
                        } else {
                            *force -= o.force;
                            *torque += o.torque_second;
                        }
                        if self.damped {
                            damping = damping.max(self.params[self.kind[b] as usize].damping);
                        }
                    }
                    // A held sphere (a grip) does not move by its force, and a tool reads that force:
                    // damping it would report (1 + damping) times the specimen's resistance.
                    if damping > 0.0 && inv_mass > 0.0 {
                        // The sphere's whole force and torque (contacts, gravity, extensions before
                        // the bonds, its bonds), as PFC damps the unbalanced force.
                        *force = local_damping(*force, *velocity, damping);
                        *torque = local_damping(*torque, *angular_velocity, damping);
                    }
                },
            );
    }
}

/// A number in [0, 1) from a bond's stable ids and kind (splitmix64): the stiffness range's draw,
/// the same for the same bond whatever the order in which bonds form.
fn unit_draw(ids: [u32; 2], kind: u16) -> f64 {
    let mut z =
        ((ids[0] as u64) << 32 | ids[1] as u64) ^ ((kind as u64) << 48) ^ 0x9E37_79B9_7F4A_7C15;
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    (z >> 11) as f64 / (1u64 << 53) as f64
}

/// Radians of the fastest bond oscillation per step taken as accurate (the published stalk
/// calibration found 10 % of the Rayleigh step, about 0.36 rad here, fine and 15 % not).
pub const SAFE_PHASE: f64 = 0.4;

impl StepExtension for Bonds {
    fn name(&self) -> &str {
        "bonds"
    }

    /// A device runs the bonds with the particles (`segment.rs`); stepped stage by stage, the
    /// host updates them at every step.
    fn on_device(&self) -> OnDevice {
        OnDevice::InSegments
    }

    fn segment_bonds(
        &self,
        particles: &Particles,
        index_of: &[u32],
    ) -> Result<Option<SegmentBonds>, String> {
        self.for_segment(&particles.id, index_of)
    }

    fn end_segment(
        &mut self,
        end: SegmentBondsEnd,
        first_step: u64,
        steps: u64,
        dt: f64,
    ) -> Result<(), String> {
        Bonds::end_segment(self, end, first_step, steps, dt)
    }

    /// Nothing to do between steps until the next bond kind forms, nothing at all once every
    /// kind has (less one step for the round-off in the step times, as a factory counts).
    fn idle_steps(&self, time: f64, dt: f64) -> u64 {
        let next = (0..self.params.len())
            .filter(|&k| !self.formed[k])
            .map(|k| self.params[k].formation_time)
            .fold(f64::INFINITY, f64::min);
        if next == f64::INFINITY {
            return u64::MAX;
        }
        let steps = ((next - 1e-12 - time) / dt).floor();
        if steps.is_finite() && steps > 1.0 {
            steps as u64 - 1
        } else {
            0
        }
    }

    fn adds_forces(&self) -> bool {
        true
    }

    fn add_forces(&mut self, particles: &mut Particles, index_of: &[u32], time: f64, dt: f64) {
        if self.ids.is_empty() {
            return;
        }
        if time > self.last_update {
            self.last_update = time;
            self.update(particles, index_of, dt, time);
        } else {
            // Forces recomputed without a step (particles added or moved): the same bond forces.
            self.apply(particles);
        }
    }

    fn reordered(&mut self, index_of: &[u32]) {
        self.follow_particle_order(index_of);
    }

    fn after_step(&mut self, sim: &mut Simulation) -> Result<(), SimError> {
        if !self.all_formed() {
            let (time, dt) = (sim.time, sim.params.time_step);
            self.form_due(&sim.particles, time, dt)
                .map_err(|message| SimError::Extension { time, message })?;
        }
        Ok(())
    }

    fn finished(&self) -> bool {
        self.all_formed()
    }

    fn as_any(&self) -> &dyn Any {
        self
    }
}

impl Simulation {
    /// The simulation's bonds, if it has any.
    pub fn bonds(&self) -> Option<&Bonds> {
        self.extensions_of::<Bonds>().next()
    }
}
