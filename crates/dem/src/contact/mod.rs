//! Contact laws and the one place every contact is evaluated.
//!
//! Design: a contact law is a plain-data type implementing [`ContactLaw`]: a pure function of the
//! pair's precomputed parameters ([`PairParams`]), the contact geometry ([`ContactPoint`]) and the
//! pair's history ([`ContactHistory`]), in the shape of DEM-Engine's force models, so the same code
//! can later run on a GPU. Particle-particle and particle-geometry contacts both reduce their
//! situation to a [`ContactPoint`] and call [`evaluate`], which applies the law and the rolling
//! resistance ([`rolling`]) once for both.
//!
//! Laws are registered by name in the [`contact_laws!`] line at the bottom of this file, as LAMMPS
//! registers pair styles: adding a law is its own file (a type implementing [`ContactLaw`]) plus its
//! name in that line. The registry builds [`ContactModel`], the enum a simulation stores; the hot
//! loops call [`ContactModel::dispatch`] once per stage so that they are compiled for the concrete
//! law (no branch or virtual call per contact).

use glam::DVec3;

pub mod jkr;
pub mod rolling;

pub use jkr::{jkr_contact_radius, jkr_cutoff_overlap};
pub use rolling::RollingModel;

/// Everything a contact law needs for one material pair, computed once when the material table is
/// built (`MaterialTable::pair`).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PairParams {
    /// Effective Young's modulus E* (Pa).
    pub e_star: f64,
    /// Effective shear modulus G* (Pa).
    pub g_star: f64,
    /// Damping ratio zeta = -ln e / sqrt(ln^2 e + pi^2) of the restitution e (0 for e = 1).
    pub damping_ratio: f64,
    /// Hertz-Mindlin's damping factor 2 sqrt(5/6) zeta: times sqrt(S m*) it gives a damping
    /// coefficient. Cached because the Hertz-Mindlin law needs it for every contact.
    pub hertz_damping: f64,
    /// sqrt(8 G* / (2 E*)): the tangential damping coefficient over the normal one, which saves a
    /// square root per contact. Derived by `MaterialTable`; 0 (not derived) makes the law
    /// compute it from the stiffnesses.
    pub tangential_damping_ratio: f64,
    pub static_friction: f64,
    pub rolling_friction: f64,
    /// JKR surface energy gamma (J/m^2); 0: no cohesion.
    pub surface_energy: f64,
}

/// What a pair remembers from step to step, carried by the neighbour list and the wall candidates
/// (and across list rebuilds) without knowing what is inside. Plain data, so a GPU back end can hold
/// it in a flat array. A law that needs more history adds a field here.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ContactHistory {
    /// Tangential spring (displacement, relative to the first body of the pair).
    pub tangential: DVec3,
    /// Rolling moment of the epsd rolling model.
    pub rolling: DVec3,
}

impl ContactHistory {
    /// Whether there is anything to carry over.
    #[inline(always)]
    pub fn is_empty(&self) -> bool {
        self.tangential == DVec3::ZERO && self.rolling == DVec3::ZERO
    }

    /// The same history seen from the other body of the pair.
    #[inline(always)]
    pub fn reversed(&self) -> Self {
        ContactHistory {
            tangential: -self.tangential,
            rolling: -self.rolling,
        }
    }
}

/// Geometry of one contact as a law sees it.
#[derive(Clone, Copy, Debug)]
pub struct ContactPoint {
    /// Unit normal pointing from the other body to this particle.
    pub normal: DVec3,
    /// Overlap (> 0 in contact; a cohesive law may act down to its negative cut-off).
    pub overlap: f64,
    pub r_eff: f64,
    pub m_eff: f64,
    /// Velocity of this particle's centre minus the other body's velocity (at its centre, or for a
    /// wall at the contact point).
    pub v_rel: DVec3,
    /// c_i w_i + c_j w_j: crossed with the normal it gives the spin part of the contact-point velocity.
    pub spin_lever: DVec3,
}

/// What a law produces.
#[derive(Clone, Copy, Debug, Default)]
pub struct ContactForce {
    /// Total normal force (positive = repulsive); not clamped at zero.
    pub normal: f64,
    /// The normal load that friction and rolling resistance scale with: the normal force, plus for
    /// JKR the pull-off correction 2 * 3 pi gamma R* (docs/physics.md), so a cohesive contact
    /// pulled to zero net force still has friction.
    pub load: f64,
    /// Tangential force on this particle.
    pub tangential: DVec3,
    /// Normal stiffness the epsd rolling spring scales with (Hertz: the secant (4/3) E* a).
    pub secant_stiffness: f64,
}

/// A contact law: the normal and tangential force of one contact.
pub trait ContactLaw: Copy + Default + std::fmt::Debug + PartialEq + Send + Sync + 'static {
    /// The name scene files use (`simulation.contact_model`).
    const NAME: &'static str;
    /// Whether the law uses a pair's surface energy (cohesion); scenes refuse a surface energy
    /// for laws without it rather than ignore it.
    const COHESIVE: bool = false;
    /// Settings the law reads from `simulation.contact_parameters`: (name, what it is).
    const PARAMETERS: &'static [(&'static str, &'static str)] = &[];
    /// Whether the GPU back end (`crates/gpu`) has this law's force in WGSL and runs its contacts
    /// on the device; false: the GPU stages hand its contacts to the CPU, and the user is told.
    /// No default: a new law says where it runs in the one file that defines it.
    const ON_GPU: bool;

    /// Sets one of [`Self::PARAMETERS`]; the error says what was expected.
    fn set_parameter(&mut self, name: &str, value: f64) -> Result<(), String> {
        let _ = value;
        Err(format!("{} takes no parameter \"{name}\"", Self::NAME))
    }

    /// Normal and tangential force; updates the tangential spring in `history`.
    fn force(
        &self,
        p: &PairParams,
        c: &ContactPoint,
        history: &mut ContactHistory,
        dt: f64,
    ) -> ContactForce;

    /// The overlap (<= 0) down to which a pair of effective radius `r_eff` still interacts: 0 for
    /// laws that act only while touching. The neighbour search reaches this much further.
    #[inline(always)]
    fn cutoff_overlap(&self, p: &PairParams, r_eff: f64) -> f64 {
        let _ = (p, r_eff);
        0.0
    }

    /// Duration of a head-on collision at `speed`: the time step must resolve it (about 10 steps).
    fn collision_time(&self, p: &PairParams, m_eff: f64, r_eff: f64, speed: f64) -> f64;
}

/// Runs generic code with the concrete law of a [`ContactModel`] (see [`ContactModel::dispatch`]).
pub trait LawVisitor {
    type Output;
    fn visit<L: ContactLaw>(self, law: &L) -> Self::Output;
}

/// What [`evaluate`] gives the caller.
#[derive(Clone, Copy, Debug, Default)]
pub struct ContactOutcome {
    /// Normal plus tangential force on this particle.
    pub force: DVec3,
    pub law: ContactForce,
    /// Rolling torque on this particle from the epsd rolling spring (zero for cdt).
    pub rolling_torque: DVec3,
    /// Constant-directional rolling resistance mu_r |load| (zero for epsd): each body is braked by
    /// this times its own lever arm.
    pub rolling_resistance: f64,
}

/// The one place a contact is evaluated: the law's force, then the rolling resistance.
/// `rel_spin` is this body's spin minus the other's; `rolling_inertia` is asked only by epsd.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub fn evaluate<L: ContactLaw>(
    law: &L,
    rolling: RollingModel,
    p: &PairParams,
    c: &ContactPoint,
    rel_spin: DVec3,
    rolling_inertia: impl FnOnce() -> f64,
    history: &mut ContactHistory,
    dt: f64,
) -> ContactOutcome {
    let f = law.force(p, c, history, dt);
    let mut out = ContactOutcome {
        force: f.normal * c.normal + f.tangential,
        law: f,
        ..Default::default()
    };
    match rolling {
        RollingModel::ConstantDirectionalTorque => {
            out.rolling_resistance = p.rolling_friction * f.load.abs();
        }
        RollingModel::Epsd { viscous_damping } => {
            out.rolling_torque = rolling::epsd_rolling_torque(
                p,
                &f,
                c.normal,
                c.r_eff,
                rolling_inertia(),
                viscous_damping,
                rel_spin,
                &mut history.rolling,
                dt,
            );
        }
    }
    out
}

/// The tangential spring shared by the laws with history (Mindlin, Hooke with history): rotate the
/// stored spring into the current tangent plane keeping its length, stretch it by the slip
/// velocity `v_c`, and cap the force at `limit` (Coulomb), truncating the spring to the slip
/// length. Returns the tangential force.
#[inline(always)]
pub fn tangential_spring(
    shear: &mut DVec3,
    n: DVec3,
    v_c: DVec3,
    stiffness: f64,
    damping: f64,
    limit: f64,
    dt: f64,
) -> DVec3 {
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
    let mut f_t = -stiffness * *shear - damping * v_c;
    let ft2 = f_t.length_squared();
    if ft2 > limit * limit {
        f_t *= limit / ft2.sqrt();
        // -S_t s equals the elastic share of the scaled force.
        *shear = if stiffness > 0.0 {
            -(f_t + damping * v_c) / stiffness
        } else {
            DVec3::ZERO
        };
    }
    f_t
}

/// Builds [`ContactModel`] from the registered laws: one `module::Type` per law.
macro_rules! contact_laws {
    ($($module:ident :: $law:ident),+ $(,)?) => {
        $(pub mod $module;)+
        $(pub use $module::$law;)+

        /// The contact law of a simulation, one variant per registered law.
        #[derive(Clone, Copy, Debug, PartialEq)]
        pub enum ContactModel {
            $($law($law),)+
        }

        impl ContactModel {
            /// Names of the registered laws, as scene files give them.
            pub const NAMES: &'static [&'static str] = &[$(<$law as ContactLaw>::NAME,)+];

            /// The law with this name, with its default parameters.
            pub fn from_name(name: &str) -> Option<Self> {
                $(if name == <$law as ContactLaw>::NAME {
                    return Some(Self::$law($law::default()));
                })+
                None
            }

            pub fn name(&self) -> &'static str {
                match self { $(Self::$law(_) => <$law as ContactLaw>::NAME,)+ }
            }

            /// Whether the law uses surface energy (cohesion).
            pub fn cohesive(&self) -> bool {
                match self { $(Self::$law(_) => <$law as ContactLaw>::COHESIVE,)+ }
            }

            /// Whether the GPU back end runs the law's contacts on the device
            /// ([`ContactLaw::ON_GPU`]).
            pub fn on_gpu(&self) -> bool {
                match self { $(Self::$law(_) => <$law as ContactLaw>::ON_GPU,)+ }
            }

            /// The settings the law reads: (name, what it is).
            pub fn parameters(&self) -> &'static [(&'static str, &'static str)] {
                match self { $(Self::$law(_) => <$law as ContactLaw>::PARAMETERS,)+ }
            }

            pub fn set_parameter(&mut self, name: &str, value: f64) -> Result<(), String> {
                match self { $(Self::$law(l) => l.set_parameter(name, value),)+ }
            }

            /// Runs `visitor` with the concrete law: hot loops are compiled once per law.
            #[inline(always)]
            pub fn dispatch<V: LawVisitor>(&self, visitor: V) -> V::Output {
                match self { $(Self::$law(l) => visitor.visit(l),)+ }
            }

            pub fn cutoff_overlap(&self, p: &PairParams, r_eff: f64) -> f64 {
                match self { $(Self::$law(l) => l.cutoff_overlap(p, r_eff),)+ }
            }

            pub fn collision_time(&self, p: &PairParams, m_eff: f64, r_eff: f64, speed: f64) -> f64 {
                match self { $(Self::$law(l) => l.collision_time(p, m_eff, r_eff, speed),)+ }
            }
        }
    };
}

impl Default for ContactModel {
    /// Hertz-Mindlin (no slip), EDEM's default.
    fn default() -> Self {
        ContactModel::HertzMindlin(HertzMindlin)
    }
}

impl ContactModel {
    /// How far beyond touching any pair of `pairs` still attracts, for bodies of effective radius
    /// up to `max_r_eff`: the neighbour search must reach this much further. 0 without cohesion.
    pub fn reach<'a>(
        &self,
        pairs: impl IntoIterator<Item = &'a PairParams>,
        max_r_eff: f64,
    ) -> f64 {
        pairs
            .into_iter()
            .map(|p| -self.cutoff_overlap(p, max_r_eff))
            .fold(0.0, f64::max)
    }
}

// The registry: one line per contact law.
contact_laws! {
    hertz_mindlin::HertzMindlin,
    hooke::Hooke,
}
