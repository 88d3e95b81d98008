//! The typed scene description: what a scene file says, as plain data that Rust code can also
//! write directly (a virtual test builds its scene this way, no file involved).
//!
//! A description holds what was asked for, not yet checked: [`crate::scene::build`] checks every
//! value (positive sizes, names that exist, a time step the contacts can take) and names the
//! failing key as a scene file would spell it (`particles[0].fill.count`). Units are SI
//! throughout: metres, seconds, kilograms, pascals.

use crate::bond::BondParams;
use crate::factory::Rate;
use crate::fill::{FillRegion, Lattice, SizeDistribution};
use crate::geometry::Motion;
use crate::maize_kernel::KernelShape;
use crate::mixture::{FillTarget, Shape};
use crate::sim::SimulationParams;
use crate::specimen::StalkSpecimen;
use crate::sphere_fit::FitOptions;
use glam::DVec3;
use std::path::PathBuf;

/// A whole scene: run settings, output, materials, geometry and particles.
#[derive(Clone, Debug)]
pub struct SceneDescription {
    pub simulation: SimulationSettings,
    pub output: OutputDescription,
    pub materials: Vec<MaterialDescription>,
    /// One per pair of materials that can touch.
    pub interactions: Vec<InteractionDescription>,
    pub geometries: Vec<GeometryDescription>,
    /// Named particle types that groups mix (`[[particle_type]]`).
    pub particle_types: Vec<ParticleTypeDescription>,
    /// Groups of particles with their placement (`[[particles]]`); at least one.
    pub particles: Vec<ParticleGroup>,
    /// Bonds between the spheres of material pairs (`[[bond]]`).
    pub bonds: Vec<BondDescription>,
}

impl SceneDescription {
    /// A scene of `run_length` with default settings and nothing in it yet.
    pub fn new(run_length: RunLength) -> SceneDescription {
        SceneDescription {
            simulation: SimulationSettings::new(run_length),
            output: OutputDescription::default(),
            materials: Vec::new(),
            interactions: Vec::new(),
            geometries: Vec::new(),
            particle_types: Vec::new(),
            particles: Vec::new(),
            bonds: Vec::new(),
        }
    }

    /// The geometry called `name`, to change it before building.
    pub fn geometry_mut(&mut self, name: &str) -> Option<&mut GeometryDescription> {
        self.geometries.iter_mut().find(|g| g.name == name)
    }
}

/// How long the scene runs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RunLength {
    /// Simulated seconds (`duration`).
    Duration(f64),
    /// Time steps (`steps`).
    Steps(u64),
}

/// The time step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum TimeStep {
    /// Seconds (`time_step`).
    Fixed(f64),
    /// Per cent of the Rayleigh time step of the smallest sphere (`time_step_percent`).
    PercentOfRayleigh(f64),
}

/// `[simulation]`.
#[derive(Clone, Debug, PartialEq)]
pub struct SimulationSettings {
    pub run_length: RunLength,
    /// Default: 20 % of the Rayleigh time step.
    pub time_step: TimeStep,
    /// m/s^2; default [0, 0, -9.81].
    pub gravity: DVec3,
    /// Normal/tangential contact law by name (`dem::contact::ContactModel::NAMES`); default
    /// "hertz_mindlin".
    pub contact_model: String,
    /// Settings of the contact law by name (e.g. hooke's `characteristic_velocity`).
    pub contact_parameters: Vec<(String, f64)>,
    /// "cdt" (default) or "epsd".
    pub rolling_friction_model: String,
    /// Viscous damping of the epsd model; default 0.3.
    pub rolling_viscous_damping: f64,
    /// Neighbour-list skin (m); default 0.3 times the smallest sphere radius.
    pub neighbour_skin: Option<f64>,
    /// Particles leaving this box stop the run; default the particles and geometry grown by
    /// their extent on every side.
    pub domain: Option<Domain>,
    /// Largest overlap at the start as a fraction of the smaller radius; default 0.01.
    pub max_initial_overlap: f64,
    /// Speed (m/s) for the collision-time check; default the fastest foreseen.
    pub expected_max_speed: Option<f64>,
    /// The back end that runs the stages, by name (`dem::sim::BACKEND_NAMES`); default "cpu".
    /// One that cannot be had here (no GPU) falls back to the CPU with a warning.
    pub backend: String,
}

impl SimulationSettings {
    /// The defaults of a scene file's `[simulation]` with the given run length: those of
    /// [`SimulationParams::default`], the one home of the defaults.
    pub fn new(run_length: RunLength) -> SimulationSettings {
        let defaults = SimulationParams::default();
        SimulationSettings {
            run_length,
            time_step: TimeStep::PercentOfRayleigh(100.0 * defaults.time_step_fraction),
            gravity: defaults.gravity,
            contact_model: defaults.contact_model.name().into(),
            contact_parameters: Vec::new(),
            rolling_friction_model: defaults.rolling_model.name().into(),
            rolling_viscous_damping: defaults.rolling_viscous_damping,
            neighbour_skin: None,
            domain: None,
            max_initial_overlap: defaults.max_initial_overlap,
            expected_max_speed: None,
            backend: "cpu".into(),
        }
    }
}

/// A box given by its lower and upper corners.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Domain {
    pub min: DVec3,
    pub max: DVec3,
}

/// `[output]`.
#[derive(Clone, Debug, PartialEq)]
pub struct OutputDescription {
    /// Default "out" (a scene file's folder joined in front).
    pub directory: PathBuf,
    /// Seconds between particle snapshots (None: only the first and last).
    pub snapshot_interval: Option<f64>,
    /// Seconds between geometry load records (default a thousandth of the run).
    pub force_interval: Option<f64>,
    /// How snapshots are stored: "binary" (default) or "ascii" (text, about twice the size).
    pub format: String,
    /// Whether snapshots include the contact force network (default false).
    pub contacts: bool,
}

impl Default for OutputDescription {
    fn default() -> Self {
        OutputDescription {
            directory: PathBuf::from("out"),
            snapshot_interval: None,
            force_interval: None,
            format: "binary".into(),
            contacts: false,
        }
    }
}

/// Elastic stiffness of a material: one of the two moduli.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Stiffness {
    ShearModulus(f64),
    YoungsModulus(f64),
}

/// `[[material]]`.
#[derive(Clone, Debug, PartialEq)]
pub struct MaterialDescription {
    pub name: String,
    /// kg/m^3.
    pub density: f64,
    pub poisson_ratio: f64,
    /// Pa.
    pub stiffness: Stiffness,
}

/// `[[interaction]]`: how two materials meet.
#[derive(Clone, Debug, PartialEq)]
pub struct InteractionDescription {
    pub materials: [String; 2],
    pub restitution: f64,
    pub static_friction: f64,
    pub rolling_friction: f64,
    /// JKR cohesion (J/m^2); 0 for none.
    pub surface_energy: f64,
}

/// `[[bond]]`: EDEM's "Hertz-Mindlin with bonding" between two materials' spheres (see
/// [`crate::bond`]).
#[derive(Clone, Debug, PartialEq)]
pub struct BondDescription {
    pub materials: [String; 2],
    /// The pair's bond parameters, as the engine takes them (checked when the scene is built).
    pub params: BondParams,
}

/// `[[geometry]]`: a wall, box, cylinder or mesh with its material and motion.
#[derive(Clone, Debug, PartialEq)]
pub struct GeometryDescription {
    /// The file's `name`, or "geometry<index>".
    pub name: String,
    pub material: String,
    pub shape: GeometryShape,
    /// Windows of prescribed motion (directions need not be unit vectors).
    pub motion: Vec<Motion>,
    /// The point loads are reported about; default the first rotation's axis point, else the
    /// origin.
    pub torque_point: Option<DVec3>,
}

/// A geometry's shape.
#[derive(Clone, Debug, PartialEq)]
pub enum GeometryShape {
    /// An infinite wall through `point` facing the particles along `normal`.
    Plane { point: DVec3, normal: DVec3 },
    /// The inside faces of a box, less those named in `open` ("-x", "+x", ... "+z").
    Box {
        min: DVec3,
        max: DVec3,
        open: Vec<String>,
    },
    /// A cylinder shell from `base` along `axis`, with caps as asked.
    Cylinder {
        base: DVec3,
        axis: DVec3,
        radius: f64,
        length: f64,
        bottom_cap: bool,
        top_cap: bool,
    },
    /// An STL file (the path as given: a scene file's folder is joined in front when read).
    Mesh {
        file: PathBuf,
        scale: f64,
        offset: DVec3,
    },
}

/// `[[particle_type]]`: a named material with a shape.
#[derive(Clone, Debug)]
pub struct ParticleTypeDescription {
    pub name: String,
    pub material: String,
    pub shape: ParticleShape,
    /// The radius distribution of a sphere, the scale factor distribution of a clump.
    pub size: SizeDistribution,
}

/// The shape of a particle type.
#[derive(Clone, Debug)]
pub enum ParticleShape {
    Sphere,
    /// Equal spheres in a row, `length` end to end.
    Rod {
        length: f64,
        diameter: f64,
        count: usize,
    },
    /// Spheres given by centre and radius (m), at scale 1.
    Spheres {
        spheres: Vec<(DVec3, f64)>,
    },
    /// A maize kernel class with its dimensions, fitted with `count` spheres.
    MaizeKernel {
        kernel: KernelShape,
        count: usize,
    },
    /// A convex polyhedron: a maize kernel class as the hull of its dimensions, the hull of the
    /// given vertices (m, at scale 1), or the hull of an STL solid.
    Polyhedron {
        source: PolyhedronSource,
    },
    /// A maize kernel class with its dimensions, fitted with spheres to a volume error (see
    /// [`crate::sphere_fit`]).
    MaizeKernelFit {
        kernel: KernelShape,
        options: FitOptions,
    },
    /// A closed STL solid (`file`, its coordinates times `scale` in metres) fitted with spheres to
    /// a volume error.
    MultiSphere {
        file: PathBuf,
        scale: f64,
        options: FitOptions,
    },
    /// A shape built before (a fitted kernel, a clump with its mass properties), so that many
    /// scenes can share one fit; see [`crate::scene::prepare_shapes`].
    Prepared(Shape),
}

/// Where a polyhedral particle's shape comes from.
#[derive(Clone, Debug, PartialEq)]
pub enum PolyhedronSource {
    Kernel(KernelShape),
    Vertices(Vec<DVec3>),
    /// The convex hull of an STL solid, its coordinates times `scale` in metres.
    Stl {
        file: PathBuf,
        scale: f64,
    },
}

/// Which particles a group holds.
// A scene holds a handful of these; boxing the inline type would only make them harder to write.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug)]
pub enum GroupParticles {
    /// One type given in the group (its name in messages is the group's key).
    Inline {
        material: String,
        shape: ParticleShape,
        size: SizeDistribution,
    },
    /// A mixture of named types with their shares (by number, or by mass when `by_mass`);
    /// `fractions` may be left out for a single type.
    Mixture {
        types: Vec<String>,
        fractions: Option<Vec<f64>>,
        by_mass: bool,
    },
}

/// `[[particles]]`: particles and where they start.
#[derive(Clone, Debug)]
pub struct ParticleGroup {
    pub particles: GroupParticles,
    pub placement: Placement,
    /// Initial velocity (m/s).
    pub velocity: DVec3,
}

/// Where a group's particles start, or where they are created during the run.
#[derive(Clone, Debug)]
pub enum Placement {
    /// Spheres of one type on a lattice; `spacing` defaults to the largest diameter, `origin` to
    /// the region's lower corner. `seed` draws the sizes (default 1).
    Lattice {
        region: FillRegion,
        lattice: Lattice,
        spacing: Option<f64>,
        origin: Option<DVec3>,
        seed: Option<u64>,
    },
    /// Random positions and orientations without overlap. The seed (default 1) is offset by the
    /// group's index.
    Random {
        region: FillRegion,
        amount: FillTarget,
        seed: Option<u64>,
    },
    /// Created at `rate` from a face during the run, from `start` (s) until `amount` is made.
    Factory {
        outlet: FactoryOutlet,
        /// The direction particles are created in; default [0, 0, -1].
        normal: DVec3,
        amount: FillTarget,
        rate: Rate,
        start: f64,
        seed: Option<u64>,
    },
    /// A stalk specimen: a cylinder packed with spheres of the group's one sphere type (radii
    /// from its size), core spheres given the core's material (`fill.type = "stalk"`).
    Specimen(StalkSpecimen),
}

/// The face a factory creates particles from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FactoryOutlet {
    Disc {
        centre: DVec3,
        radius: f64,
    },
    /// Side lengths `size` along `u_axis` (default: x, or a direction across the normal) and the
    /// axis across it.
    Rectangle {
        centre: DVec3,
        size: [f64; 2],
        u_axis: Option<DVec3>,
    },
}
