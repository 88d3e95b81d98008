//! Scenes written in Rust: the typed description builds the same simulation as the file it
//! stands for, with the file's checks and key names.

use dem::fill::{FillRegion, SizeDistribution};
use dem::maize_kernel::KernelShape;
use dem::mixture::FillTarget;
use dem::scene::{
    parse, prepare_shapes, GeometryDescription, GeometryShape, GroupParticles,
    InteractionDescription, MaterialDescription, ParticleGroup, ParticleShape,
    ParticleTypeDescription, Placement, RunLength, Scene, SceneDescription, Stiffness,
};
use glam::DVec3;
use std::path::Path;

const FILE: &str = r#"
[simulation]
duration = 0.05

[[material]]
name = "grain"
density = 1250
poisson_ratio = 0.4
shear_modulus = 1e7

[[material]]
name = "steel"
density = 7850
poisson_ratio = 0.3
youngs_modulus = 2e11

[[interaction]]
materials = ["grain", "grain"]
restitution = 0.3
static_friction = 0.4
rolling_friction = 0.1

[[interaction]]
materials = ["grain", "steel"]
restitution = 0.5
static_friction = 0.5
rolling_friction = 0.1

[[geometry]]
name = "cup"
type = "cylinder"
material = "steel"
base = [0.0, 0.0, 0.0]
radius = 0.03
length = 0.06
caps = "bottom"

[[particle_type]]
name = "kernel"
material = "grain"
shape = { type = "maize_kernel", class = "flat", count = 5 }

[[particle_type]]
name = "bead"
material = "grain"
size = { type = "uniform", min = 0.002, max = 0.0025 }

[[particles]]
types = ["kernel", "bead"]
fractions = [1, 1]
region = { type = "cylinder", base = [0.0, 0.0, 0.001], radius = 0.029, length = 0.05 }
fill = { type = "random", count = 60, seed = 4 }
"#;

fn described() -> SceneDescription {
    let mut d = SceneDescription::new(RunLength::Duration(0.05));
    d.materials = vec![
        MaterialDescription {
            name: "grain".into(),
            density: 1250.0,
            poisson_ratio: 0.4,
            stiffness: Stiffness::ShearModulus(1e7),
        },
        MaterialDescription {
            name: "steel".into(),
            density: 7850.0,
            poisson_ratio: 0.3,
            stiffness: Stiffness::YoungsModulus(2e11),
        },
    ];
    let interaction = |b: &str, restitution: f64, static_friction: f64| InteractionDescription {
        materials: ["grain".into(), b.into()],
        restitution,
        static_friction,
        rolling_friction: 0.1,
        surface_energy: 0.0,
    };
    d.interactions = vec![
        interaction("grain", 0.3, 0.4),
        interaction("steel", 0.5, 0.5),
    ];
    d.geometries = vec![GeometryDescription {
        name: "cup".into(),
        material: "steel".into(),
        shape: GeometryShape::Cylinder {
            base: DVec3::ZERO,
            axis: DVec3::Z,
            radius: 0.03,
            length: 0.06,
            bottom_cap: true,
            top_cap: false,
        },
        motion: Vec::new(),
        torque_point: None,
    }];
    d.particle_types = vec![
        ParticleTypeDescription {
            name: "kernel".into(),
            material: "grain".into(),
            shape: ParticleShape::MaizeKernel {
                kernel: KernelShape::published("flat").unwrap(),
                count: 5,
            },
            size: SizeDistribution::Fixed { radius: 1.0 },
        },
        ParticleTypeDescription {
            name: "bead".into(),
            material: "grain".into(),
            shape: ParticleShape::Sphere,
            size: SizeDistribution::Uniform {
                min: 0.002,
                max: 0.0025,
            },
        },
    ];
    d.particles = vec![ParticleGroup {
        particles: GroupParticles::Mixture {
            types: vec!["kernel".into(), "bead".into()],
            fractions: Some(vec![1.0, 1.0]),
            by_mass: false,
        },
        placement: Placement::Random {
            region: FillRegion::Cylinder {
                base: DVec3::new(0.0, 0.0, 0.001),
                axis: DVec3::Z,
                radius: 0.029,
                length: 0.05,
            },
            amount: FillTarget::Count(60),
            seed: Some(4),
        },
        velocity: DVec3::ZERO,
    }];
    d
}

/// The state a scene starts from, exactly.
fn state(s: &Scene) -> (Vec<[f64; 3]>, Vec<f64>, f64, f64, u64, usize) {
    let p = &s.simulation.particles;
    (
        p.position.iter().map(|x| x.to_array()).collect(),
        p.radius.clone(),
        s.simulation.params.time_step,
        s.simulation.params.skin,
        s.steps,
        s.simulation.bodies.position.len(),
    )
}

#[test]
fn a_description_in_rust_builds_what_the_file_builds() {
    let from_file = Scene::from_toml(FILE, "cup.toml", Path::new(".")).unwrap();
    let from_rust = Scene::from_description(&described(), "scene").unwrap();
    assert_eq!(state(&from_file), state(&from_rust));
    assert_eq!(from_file.notes, from_rust.notes);
    assert_eq!(from_rust.simulation.particle_count(), 60);
    assert_eq!(
        from_file.simulation.params.domain,
        from_rust.simulation.params.domain
    );
    // The parser gives the same description.
    let parsed = parse::scene(FILE, "cup.toml", Path::new(".")).unwrap();
    let again = Scene::from_description(&parsed, "cup.toml").unwrap();
    assert_eq!(state(&again), state(&from_file));
}

#[test]
fn prepared_shapes_build_the_same_particles_once() {
    let mut d = described();
    let notes = prepare_shapes(&mut d, "scene").unwrap();
    assert_eq!(notes.len(), 1, "{notes:?}");
    assert!(notes[0].contains("particle_type[0] (\"kernel\"): flat maize kernel of 5 spheres"));
    assert!(matches!(
        d.particle_types[0].shape,
        ParticleShape::Prepared(_)
    ));
    let prepared = Scene::from_description(&d, "scene").unwrap();
    let direct = Scene::from_description(&described(), "scene").unwrap();
    assert_eq!(state(&prepared), state(&direct));
    // Nothing is fitted again, so nothing is noted again.
    assert!(prepared.notes.is_empty(), "{:?}", prepared.notes);
}

#[test]
fn a_description_is_checked_with_the_file_keys() {
    let build = |d: &SceneDescription| {
        Scene::from_description(d, "scene")
            .map(|_| ())
            .unwrap_err()
            .to_string()
    };
    let mut d = described();
    d.particle_types[1].size = SizeDistribution::Fixed { radius: -0.002 };
    assert_eq!(
        build(&d),
        "scene: particle_type[1].size.radius: expected a positive number, got -0.002"
    );
    let mut d = described();
    d.particles[0].placement = Placement::Random {
        region: FillRegion::Box {
            min: DVec3::ZERO,
            max: DVec3::splat(0.05),
        },
        amount: FillTarget::Count(0),
        seed: None,
    };
    assert_eq!(
        build(&d),
        "scene: particles[0].fill.count: expected a count > 0"
    );
    let mut d = described();
    d.geometry_mut("cup").unwrap().material = "iron".into();
    assert_eq!(
        build(&d),
        "scene: geometry[0].material: unknown material \"iron\" (defined: grain, steel)"
    );
    let mut d = described();
    d.simulation.contact_model = "walton".into();
    assert_eq!(
        build(&d),
        "scene: simulation.contact_model: unknown model \"walton\" (expected one of: hertz_mindlin, hooke)"
    );
    let mut d = described();
    if let GroupParticles::Mixture { fractions, .. } = &mut d.particles[0].particles {
        *fractions = None;
    }
    assert_eq!(
        build(&d),
        "scene: particles[0].fractions: missing; expected one fraction per type (2 types)"
    );
}

#[test]
fn shared_parts_and_group_particles_read_as_in_a_scene() {
    let table: toml::Table = toml::from_str(FILE).unwrap();
    let parts = parse::shared_parts(&table, "cup.toml", std::path::Path::new(".")).unwrap();
    assert_eq!(parts.materials.len(), 2);
    assert_eq!(parts.materials[1].stiffness, Stiffness::YoungsModulus(2e11));
    assert_eq!(parts.interactions.len(), 2);
    assert_eq!(parts.particle_types.len(), 2);
    let mut bad = table.clone();
    bad["material"].as_array_mut().unwrap()[1]
        .as_table_mut()
        .unwrap()
        .insert("density".into(), toml::Value::String("heavy".into()));
    let e = parse::shared_parts(&bad, "cup.toml", std::path::Path::new("."))
        .unwrap_err()
        .to_string();
    assert!(
        e == "cup.toml: material[1].density: \"heavy\": expected a number and a unit, such as \"3 mm\" or \"29 MPa\"",
        "{e}"
    );

    let group: toml::Value = toml::from_str::<toml::Table>(
        "p = { material = \"grain\", size = { type = \"fixed\", radius = 0.002 } }",
    )
    .unwrap()["p"]
        .clone();
    let g = parse::group_particles(group, "t.toml", "test.particles", std::path::Path::new("."))
        .unwrap();
    assert!(matches!(
        g,
        GroupParticles::Inline {
            shape: ParticleShape::Sphere,
            size: SizeDistribution::Fixed { radius: 0.002 },
            ..
        }
    ));
    let group: toml::Value = toml::from_str::<toml::Table>(
        "p = { types = [\"a\"], size = { type = \"fixed\", radius = 0.002 } }",
    )
    .unwrap()["p"]
        .clone();
    let e = parse::group_particles(group, "t.toml", "test.particles", std::path::Path::new("."))
        .unwrap_err()
        .to_string();
    assert_eq!(
        e,
        "t.toml: test.particles.size: not used with types (each [[particle_type]] has its own)"
    );
}
