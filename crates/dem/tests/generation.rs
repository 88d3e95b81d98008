//! Particle types, mixtures, clumps in scene files, and factories.

use dem::scene::Scene;
use std::path::Path;
use test_support::{Material, Materials};

/// Crop and steel, and a steel floor.
fn crop_on_a_steel_floor() -> String {
    let crop = Materials {
        particle: Material {
            name: "crop",
            density: 1000.0,
            ..Materials::default().particle
        },
        wall_first: true,
        ..Materials::default()
    };
    format!(
        r#"
{}
[[geometry]]
name = "floor"
type = "plane"
material = "steel"
point = [0.0, 0.0, 0.0]
normal = [0.0, 0.0, 1.0]
"#,
        crop.toml()
    )
}

fn load(text: &str) -> Scene {
    Scene::from_toml(text, "scene.toml", Path::new(".")).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn a_mass_mixture_of_rods_kernels_and_spheres() {
    let materials = crop_on_a_steel_floor();
    let text = format!(
        r#"[simulation]
duration = 0.02
{materials}
[[particle_type]]
name = "long"
material = "crop"
shape = {{ type = "rod", length = 0.024, diameter = 0.005, count = 6 }}

[[particle_type]]
name = "kernel"
material = "crop"
shape = {{ type = "maize_kernel", class = "horse_tooth", count = 6 }}
scale = {{ type = "uniform", min = 0.9, max = 1.1 }}

[[particle_type]]
name = "fine"
material = "crop"
size = {{ type = "fixed", radius = 0.002 }}

[[particles]]
types = ["long", "kernel", "fine"]
fractions = [0.2, 0.5, 0.3]
basis = "mass"
region = {{ type = "cylinder", base = [0.0, 0.0, 0.001], radius = 0.045, length = 0.15 }}
fill = {{ type = "random", mass = 0.1 }}
"#
    );
    let mut scene = load(&text);
    assert_eq!(scene.notes.len(), 1, "{:?}", scene.notes);
    assert!(scene.notes[0].contains("horse_tooth maize kernel of 6 spheres"));
    let sim = &mut scene.simulation;
    // Masses by kind: a rod body has 6 members, a kernel 6, a fine sphere is free.
    let (mut rods, mut kernels, mut fines) = (0.0, 0.0, 0.0);
    let rod_mass = 1000.0
        * dem::clump::ClumpTemplate::rod(0.024, 0.005, 6)
            .unwrap()
            .mass_properties()
            .volume;
    for &m in &sim.bodies.mass {
        // Rods all weigh the same; kernels vary with their scale.
        if (m / rod_mass - 1.0).abs() < 1e-9 {
            rods += m;
        } else {
            kernels += m;
        }
    }
    let p = &sim.particles;
    for k in 0..p.len() {
        if p.body[k] == dem::particles::NO_BODY {
            fines += p.mass[k];
        }
    }
    let total = rods + kernels + fines;
    assert!((0.1..0.102).contains(&total), "{total}");
    for (got, want) in [(rods, 0.2), (kernels, 0.5), (fines, 0.3)] {
        // Within one particle (a kernel at scale 1.1 weighs less than 0.5 g).
        assert!(
            (got - want * total).abs() < rod_mass.max(5e-4),
            "{got} vs {}",
            want * total
        );
    }
    assert!((sim.total_mass() / total - 1.0).abs() < 1e-12);
    sim.run(scene.steps).unwrap();
    assert!(sim.kinetic_energy().is_finite());
}

#[test]
fn a_factory_creates_at_its_rate_without_overlap() {
    let materials = crop_on_a_steel_floor();
    let text = format!(
        r#"[simulation]
duration = 0.3
{materials}
[[geometry]]
name = "box"
type = "box"
material = "steel"
min = [-0.05, -0.05, 0.0]
max = [0.05, 0.05, 0.3]
open = ["+z"]

[[particles]]
material = "crop"
size = {{ type = "uniform", min = 0.0018, max = 0.0022 }}
factory = {{ type = "disc", centre = [0.0, 0.0, 0.2], radius = 0.03 }}
fill = {{ type = "factory", count = 200, rate = 1000, seed = 4 }}
velocity = [0.0, 0.0, -0.5]

[[particle_type]]
name = "rod"
material = "crop"
shape = {{ type = "rod", length = 0.02, diameter = 0.004, count = 5 }}

[[particles]]
types = ["rod"]
factory = {{ type = "rectangle", centre = [0.0, 0.0, 0.26], size = [0.06, 0.06] }}
fill = {{ type = "factory", mass = 0.004, mass_rate = 0.04, start = 0.05 }}
"#
    );
    let mut scene = load(&text);
    let sim = &mut scene.simulation;
    assert_eq!(sim.particles.len(), 0);
    let dt = sim.params.time_step;
    let mut worst: f64 = 0.0;
    let mut created_at_01 = 0;
    while sim.time < 0.3 {
        let before = sim.particles.len();
        sim.step().unwrap();
        // Fresh particles (new ids) touch nothing.
        let p = &sim.particles;
        for k in 0..p.len() {
            if (p.id[k] as usize) < before {
                continue;
            }
            for l in 0..p.len() {
                let same_body = p.body[k] != dem::particles::NO_BODY && p.body[k] == p.body[l];
                if l != k && !same_body {
                    let gap = (p.position[k] - p.position[l]).length() - p.radius[k] - p.radius[l];
                    worst = worst.max(-gap / p.radius[k]);
                }
            }
        }
        if (sim.time - 0.1).abs() < 0.5 * dt {
            created_at_01 = sim.factories().next().unwrap().created;
        }
    }
    assert!(worst <= 0.0, "overlap at creation {worst}");
    // 1000 per second: 100 by 0.1 s, to within one batch (4 ms: 4 particles).
    assert!((created_at_01 as i64 - 100).abs() <= 5, "{created_at_01}");
    assert!(sim.factories_done());
    assert_eq!(sim.factories().next().unwrap().created, 200);
    let rods = sim.factories().nth(1).unwrap();
    assert!(rods.created_mass >= 0.004, "{}", rods.created_mass);
    assert_eq!(sim.bodies.len(), rods.created);
    assert_eq!(sim.particles.len(), 200 + 5 * rods.created);
}
