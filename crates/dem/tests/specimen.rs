//! Stalk specimens (`dem::specimen`, `fill.type = "stalk"`): counts and geometry of the packings
//! of docs/lab-tests.md sections 3-4, hollow and core options, determinism, and scene-file errors.

use dem::fill::SizeDistribution;
use dem::scene::{GroupParticles, ParticleShape, Placement, Scene};
use dem::specimen::{
    pairs_within, Core, Packed, Packing, SpecimenSphere, StalkSpecimen, RANDOM_OVERLAP_TOLERANCE,
};
use glam::DVec3;
use std::path::Path;

const MAX: usize = 10_000_000;

/// Distance from the axis through `centre` along unit `axis`, and position along it.
fn cylindrical(p: DVec3, centre: DVec3, axis: DVec3) -> (f64, f64) {
    let rel = p - centre;
    let h = rel.dot(axis);
    ((rel - h * axis).length(), h)
}

/// Every sphere wholly inside the specimen, and every centre out of the hollow.
fn assert_inside(spec: &StalkSpecimen, spheres: &[SpecimenSphere]) {
    let axis = spec.axis.normalize();
    for s in spheres {
        let (rho, h) = cylindrical(s.position, spec.centre, axis);
        let tol = 1e-12;
        assert!(
            rho + s.radius <= 0.5 * spec.diameter + tol,
            "sphere at {rho} from the axis pokes out of the side"
        );
        assert!(
            h.abs() + s.radius <= 0.5 * spec.length + tol,
            "sphere at {h} along the axis pokes out of an end"
        );
        assert!(
            rho >= 0.5 * spec.hollow_diameter - tol,
            "centre at {rho} lies in the hollow"
        );
    }
}

/// The largest overlap of any pair as a fraction of the smaller radius (all pairs: small sets).
fn largest_overlap(spheres: &[SpecimenSphere]) -> f64 {
    let mut largest = 0.0f64;
    for (i, a) in spheres.iter().enumerate() {
        for b in &spheres[i + 1..] {
            let overlap = a.radius + b.radius - (a.position - b.position).length();
            largest = largest.max(overlap / a.radius.min(b.radius));
        }
    }
    largest
}

fn mean_coordination(packed: &Packed, contact_factor: f64) -> f64 {
    2.0 * pairs_within(&packed.spheres, contact_factor).len() as f64 / packed.spheres.len() as f64
}

/// docs/lab-tests.md section 3, the shear specimen: 20 mm long, 15 mm across, spheres of 0.43 mm on
/// a hexagonal close-packed lattice, bonded within a contact radius of 0.6 mm. EDEM reports
/// 4 235 particles and 18 980 bonds.
#[test]
fn shear_specimen_hcp_counts() {
    let r = 0.00043;
    let sizes = SizeDistribution::Fixed { radius: r };
    let spec = StalkSpecimen::hcp(0.020, 0.015);
    let packed = spec.build(&sizes, MAX).unwrap();
    // Touching spheres (spacing 2 r): the lattice's sqrt(2) / (2r)^3 sites per volume over the
    // 19.14 mm x 14.14 mm cylinder of centres is about 6 680. The second neighbours lie at
    // 2 r sqrt(2) = 1.216 mm, beyond 1.2 mm, so the bonds are the nearest-neighbour pairs:
    // 5.5 per sphere (6 inside, fewer at the surface).
    assert_eq!(packed.spheres.len(), 6725);
    assert_eq!(pairs_within(&packed.spheres, 0.6 / 0.43).len(), 37186);
    assert_inside(&spec, &packed.spheres);
    let min_distance = pairs_within(&packed.spheres, 1.0001)
        .iter()
        .map(|&(i, j)| (packed.spheres[i].position - packed.spheres[j].position).length())
        .fold(f64::INFINITY, f64::min);
    assert!((min_distance - 2.0 * r).abs() < 1e-12, "{min_distance}");
    // EDEM's 4 235 spheres are as sparse as a spacing of 1 mm: 4 313 with the close-packed
    // layers along the axis (4 217 with them across it). Its 18 980 bonds (4.5 per sphere) are
    // fewer than a lattice's 5.4: EDEM's packing is not a perfect lattice.
    let sparse = StalkSpecimen {
        packing: Packing::Hcp {
            spacing: Some(0.001),
        },
        ..spec.clone()
    };
    let packed = sparse.build(&sizes, MAX).unwrap();
    assert_eq!(packed.spheres.len(), 4313);
    assert_eq!(pairs_within(&packed.spheres, 0.6 / 0.43).len(), 23500);
    assert!(((packed.spheres.len() as f64 / 4235.0) - 1.0).abs() < 0.02);
}

#[test]
fn hcp_along_any_axis_with_hollow_and_core() {
    let r = 0.0005;
    let sizes = SizeDistribution::Fixed { radius: r };
    let spec = StalkSpecimen {
        hollow_diameter: 0.004,
        core: Some(Core {
            material: "pith".into(),
            diameter: 0.007,
        }),
        centre: DVec3::new(0.1, -0.02, 0.3),
        axis: DVec3::new(1.0, 2.0, 2.0),
        ..StalkSpecimen::hcp(0.012, 0.010)
    };
    let packed = spec.build(&sizes, MAX).unwrap();
    assert_inside(&spec, &packed.spheres);
    let axis = spec.axis.normalize();
    for s in &packed.spheres {
        let (rho, _) = cylindrical(s.position, spec.centre, axis);
        assert_eq!(s.core, rho <= 0.0035 + 1e-12, "core by distance {rho}");
    }
    // The same lattice along x, moved and turned, is the same specimen: the same count, and the
    // same spheres in the core.
    let along_x = StalkSpecimen {
        centre: DVec3::ZERO,
        axis: DVec3::X,
        ..spec.clone()
    };
    let reference = along_x.build(&sizes, MAX).unwrap();
    assert_eq!(packed.spheres.len(), reference.spheres.len());
    let cores = |p: &Packed| p.spheres.iter().filter(|s| s.core).count();
    assert_eq!(cores(&packed), cores(&reference));
    assert!(cores(&packed) > 0 && cores(&packed) < packed.spheres.len());
    // The wall between the hollow and the outside (3 mm thick) holds 0.7405 of its volume in
    // spheres in the bulk, less against its surfaces.
    let fraction = packed.solid_fraction(&spec);
    assert!(
        fraction > 0.35 && fraction < 0.74,
        "solid fraction {fraction}"
    );
}

/// A small bimodal random specimen (a debug build packs it in well under a second).
fn small_random(seed: u64) -> (StalkSpecimen, SizeDistribution) {
    let spec = StalkSpecimen {
        hollow_diameter: 0.003,
        core: Some(Core {
            material: "pith".into(),
            diameter: 0.008,
        }),
        ..StalkSpecimen::random(0.02, 0.012, 560, seed)
    };
    let sizes = SizeDistribution::Classes {
        radii: vec![0.001, 0.0005],
        fractions: vec![0.4, 0.6],
        by_mass: false,
    };
    (spec, sizes)
}

#[test]
fn random_packing_touches_without_overlap() {
    let (spec, sizes) = small_random(7);
    let packed = spec.build(&sizes, MAX).unwrap();
    assert_eq!(packed.spheres.len(), 560);
    assert_inside(&spec, &packed.spheres);
    let largest = largest_overlap(&packed.spheres);
    assert!(largest < RANDOM_OVERLAP_TOLERANCE, "overlap {largest}");
    assert!((largest - packed.largest_overlap).abs() < 1e-12);
    // Densified until in contact: every sphere touches others within a contact radius of 1.1 r
    // (a random packing has about 6 contacts, fewer at the walls).
    let coordination = mean_coordination(&packed, 1.1);
    let fraction = packed.solid_fraction(&spec);
    // 40 % large spheres by number: 0.51 of the 3 mm wall between hollow and outside.
    assert!(
        (fraction - 0.5099).abs() < 0.0005,
        "solid fraction {fraction}"
    );
    assert!(coordination > 4.5, "coordination {coordination}");
    for s in &packed.spheres {
        let (rho, _) = cylindrical(s.position, DVec3::ZERO, DVec3::X);
        assert_eq!(s.core, rho <= 0.004);
    }
    // The radii follow the size classes, drawn by number.
    let big = packed.spheres.iter().filter(|s| s.radius > 0.0007).count();
    assert!(
        (big as f64 / 560.0 - 0.4).abs() < 0.08,
        "{big} large spheres"
    );
}

#[test]
fn random_packing_depends_on_the_seed_alone() {
    let (spec, sizes) = small_random(3);
    let a = spec.build(&sizes, MAX).unwrap();
    let b = spec.build(&sizes, MAX).unwrap();
    assert_eq!(a, b);
    let (other, _) = small_random(4);
    let c = other.build(&sizes, MAX).unwrap();
    assert_ne!(a.spheres[0].position, c.spheres[0].position);
}

#[test]
fn absurd_specimens_are_refused() {
    let sizes = SizeDistribution::Classes {
        radii: vec![0.0015, 0.00075],
        fractions: vec![1.0, 0.0],
        by_mass: false,
    };
    // 3 534 spheres of 1.5 mm would fill 125 % of the 90 mm x 23.78 mm stalk.
    let spec = StalkSpecimen::random(0.09, 0.02378, 3534, 1);
    let e = spec.build(&sizes, MAX).unwrap_err();
    assert_eq!(e.key, "count");
    assert!(e.message.contains("125.0 %"), "{e}");
    // A lattice of 1e-6 m spheres in the specimen: some 1e13 sites, refused before any.
    let tiny = SizeDistribution::Fixed { radius: 1e-6 };
    let e = StalkSpecimen::hcp(0.02, 0.015)
        .build(&tiny, MAX)
        .unwrap_err();
    assert_eq!(e.key, "spacing");
    let fixed = SizeDistribution::Fixed { radius: 0.001 };
    let e = StalkSpecimen::hcp(0.02, 0.0015)
        .build(&fixed, MAX)
        .unwrap_err();
    assert_eq!(e.key, "diameter");
    let mut hollow = StalkSpecimen::hcp(0.02, 0.015);
    hollow.hollow_diameter = 0.015;
    assert_eq!(
        hollow.build(&fixed, MAX).unwrap_err().key,
        "hollow_diameter"
    );
    let e = StalkSpecimen::hcp(0.02, 0.015)
        .build(
            &SizeDistribution::Uniform {
                min: 0.0005,
                max: 0.001,
            },
            MAX,
        )
        .unwrap_err();
    assert_eq!(e.key, "packing");
}

/// docs/lab-tests.md section 4, the radial compression specimen: 3 534 spheres of 1.5 mm and
/// 0.75 mm in a stalk 90 mm long and 23.78 mm across. About 1.5 s (the test profile is optimised).
#[test]
fn compression_specimen_random() {
    // 40.6 % of the spheres large gives a solid fraction of 0.6 (see the module notes).
    let sizes = SizeDistribution::Classes {
        radii: vec![0.0015, 0.00075],
        fractions: vec![0.406, 0.594],
        by_mass: false,
    };
    let spec = StalkSpecimen::random(0.09, 0.02378, 3534, 1);
    let started = std::time::Instant::now();
    let packed = spec.build(&sizes, MAX).unwrap();
    let seconds = started.elapsed().as_secs_f64();
    let fraction = packed.solid_fraction(&spec);
    let coordination = mean_coordination(&packed, 1.1);
    println!(
        "seed 1: solid fraction {fraction:.4}, coordination {coordination:.3} at 1.1 r, {} passes, largest overlap {:.3} %, {seconds:.2} s",
        packed.iterations,
        100.0 * packed.largest_overlap
    );
    assert_eq!(packed.spheres.len(), 3534);
    assert_inside(&spec, &packed.spheres);
    assert!(largest_overlap(&packed.spheres) < RANDOM_OVERLAP_TOLERANCE);
    assert!((fraction - 0.5985).abs() < 0.0005, "{fraction}");
    assert!((coordination - 6.99).abs() < 0.2, "{coordination}");
}

// Scene files.

fn scene(fill: &str) -> String {
    format!(
        r#"
[simulation]
steps = 10
gravity = [0.0, 0.0, 0.0]

[[material]]
name = "rind"
density = 136.4
poisson_ratio = 0.35
shear_modulus = 1.5e8

[[material]]
name = "pith"
density = 60
poisson_ratio = 0.3
shear_modulus = 5e7

[[interaction]]
materials = ["rind", "rind"]
restitution = 0.4
static_friction = 0.28
rolling_friction = 0.16

[[interaction]]
materials = ["rind", "pith"]
restitution = 0.4
static_friction = 0.28
rolling_friction = 0.16

[[interaction]]
materials = ["pith", "pith"]
restitution = 0.4
static_friction = 0.28
rolling_friction = 0.16

[[particles]]
material = "rind"
size = {{ type = "fixed", radius = 0.0005 }}
fill = {fill}
"#
    )
}

fn load(text: &str) -> Result<Scene, String> {
    Scene::from_toml(text, "stalk.toml", Path::new(".")).map_err(|e| e.to_string())
}

#[test]
fn scene_builds_a_specimen_with_its_materials() {
    let text = scene(
        r#"{ type = "stalk", length = 0.012, diameter = 0.010, packing = "hcp", hollow_diameter = 0.002, core_material = "pith", core_diameter = 0.006, centre = [0.0, 0.0, 0.02], axis = [0.0, 1.0, 0.0] }"#,
    );
    let built = load(&text).unwrap();
    let p = &built.simulation.particles;
    let spec = StalkSpecimen {
        hollow_diameter: 0.002,
        core: Some(Core {
            material: "pith".into(),
            diameter: 0.006,
        }),
        centre: DVec3::new(0.0, 0.0, 0.02),
        axis: DVec3::Y,
        ..StalkSpecimen::hcp(0.012, 0.010)
    };
    let expected = spec
        .build(&SizeDistribution::Fixed { radius: 0.0005 }, MAX)
        .unwrap();
    assert_eq!(p.len(), expected.spheres.len());
    let (rind, pith) = (0u16, 1u16);
    let mut cores = 0;
    for k in 0..p.len() {
        let (rho, _) = cylindrical(p.position[k], spec.centre, DVec3::Y);
        let in_core = rho <= 0.003 + 1e-12;
        assert_eq!(p.material[k], if in_core { pith } else { rind });
        let density = if in_core { 60.0 } else { 136.4 };
        let volume = 4.0 / 3.0 * std::f64::consts::PI * 0.0005f64.powi(3);
        assert!((p.mass[k] / (density * volume) - 1.0).abs() < 1e-12);
        cores += usize::from(in_core);
    }
    assert_eq!(cores, expected.spheres.iter().filter(|s| s.core).count());
    assert!(cores > 0);

    // The same specimen written in Rust, as a virtual test would.
    let mut description = dem::scene::parse::scene(&text, "stalk.toml", Path::new(".")).unwrap();
    let group = &mut description.particles[0];
    assert!(matches!(&group.placement, Placement::Specimen(s) if *s == spec));
    group.particles = GroupParticles::Inline {
        material: "rind".into(),
        shape: ParticleShape::Sphere,
        size: SizeDistribution::Fixed { radius: 0.0005 },
    };
    group.placement = Placement::Specimen(spec);
    let from_rust = Scene::from_description(&description, "scene").unwrap();
    assert_eq!(from_rust.simulation.particles.position, p.position);
    assert_eq!(from_rust.simulation.particles.material, p.material);
}

#[test]
fn scene_random_specimen() {
    let text = scene(
        r#"{ type = "stalk", length = 0.02, diameter = 0.012, packing = "random", count = 200, seed = 5 }"#,
    );
    let built = load(&text).unwrap();
    let p = &built.simulation.particles;
    assert_eq!(p.len(), 200);
    assert!(p.material.iter().all(|&m| m == 0));
    let spec = StalkSpecimen::random(0.02, 0.012, 200, 5);
    let expected = spec
        .build(&SizeDistribution::Fixed { radius: 0.0005 }, MAX)
        .unwrap();
    let mut got: Vec<[f64; 3]> = p.position.iter().map(|x| x.to_array()).collect();
    let mut want: Vec<[f64; 3]> = expected
        .spheres
        .iter()
        .map(|s| s.position.to_array())
        .collect();
    // The simulation keeps particles in neighbour-grid order.
    got.sort_by(|a, b| a.partial_cmp(b).unwrap());
    want.sort_by(|a, b| a.partial_cmp(b).unwrap());
    assert_eq!(got, want);
}

#[test]
fn scene_file_errors_name_the_key() {
    let cases: &[(&str, &str)] = &[
        (
            r#"{ type = "stalk", length = 0.02, diameter = -0.015 }"#,
            "stalk.toml: particles[0].fill.diameter: expected a positive diameter (m), got -0.015",
        ),
        (
            r#"{ type = "stalk", diameter = 0.015 }"#,
            "stalk.toml: particles[0].fill.length: missing; expected the specimen's length (m)",
        ),
        (
            r#"{ type = "stalk", length = 0.02, diameter = 0.015, packing = "fcc" }"#,
            "stalk.toml: particles[0].fill.packing: unknown packing \"fcc\" (expected hcp or random)",
        ),
        (
            r#"{ type = "stalk", length = 0.02, diameter = 0.015, count = 100 }"#,
            "stalk.toml: particles[0].fill.count: not used by packing \"hcp\" (the lattice sets the count; give spacing, or packing = \"random\")",
        ),
        (
            r#"{ type = "stalk", length = 0.02, diameter = 0.015, packing = "random" }"#,
            "stalk.toml: particles[0].fill.count: missing; expected the number of spheres",
        ),
        (
            r#"{ type = "stalk", length = 0.02, diameter = 0.015, packing = "random", count = 20000000 }"#,
            "stalk.toml: particles[0].fill.count: 20000000 spheres: more than a scene may hold (at most 10000000 spheres, about 1 kB of memory each)",
        ),
        (
            r#"{ type = "stalk", length = 0.02, diameter = 0.015, spacing = 1e-7 }"#,
            "stalk.toml: particles[0].fill.spacing: spacing 0.0000001 is smaller than the sphere diameter 0.001; spheres would overlap",
        ),
        (
            r#"{ type = "stalk", length = 0.02, diameter = 0.0008 }"#,
            "stalk.toml: particles[0].fill.diameter: spheres of radius up to 0.0005 m do not fit in a stalk 0.02 m long with a wall 0.0004 m thick; expected a larger stalk or smaller spheres",
        ),
        (
            r#"{ type = "stalk", length = 0.02, diameter = 0.015, core_material = "pith" }"#,
            "stalk.toml: particles[0].fill.core_diameter: missing; expected the core's diameter (m) with core_material",
        ),
        (
            r#"{ type = "stalk", length = 0.02, diameter = 0.015, core_material = "wood", core_diameter = 0.01 }"#,
            "stalk.toml: particles[0].fill.core_material: unknown material \"wood\" (defined: rind, pith)",
        ),
        (
            r#"{ type = "stalk", length = 0.02, diameter = 0.015, core_material = "pith", core_diameter = 0.02 }"#,
            "stalk.toml: particles[0].fill.core_diameter: expected a diameter above the hollow (0 m) and at most the stalk's 0.015 m, got 0.02",
        ),
        (
            r#"{ type = "stalk", length = 0.02, diameter = 0.015, axis = [0, 0, 0] }"#,
            "stalk.toml: particles[0].fill.axis: expected a non-zero direction vector",
        ),
        (
            r#"{ type = "random", count = 10, length = 0.02 }"#,
            "stalk.toml: particles[0].fill.length: not used by type \"random\" (expected one of: count, mass, seed)",
        ),
        (
            r#"{ type = "stalk", length = 0.02, diameter = 0.015, radius = 0.001 }"#,
            "stalk.toml: particles[0].fill.radius: unknown field `radius`",
        ),
    ];
    for (fill, expected) in cases {
        let e = load(&scene(fill)).err().unwrap();
        assert!(
            e.starts_with(expected),
            "{fill}\ngot:  {e}\nwant: {expected}"
        );
    }
    // A clump cannot be part of a specimen.
    let clumps = scene(r#"{ type = "stalk", length = 0.02, diameter = 0.015 }"#).replace(
        r#"size = { type = "fixed", radius = 0.0005 }"#,
        r#"shape = { type = "rod", length = 0.004, diameter = 0.001, count = 3 }"#,
    );
    let e = load(&clumps).err().unwrap();
    assert!(
        e.starts_with(
            "stalk.toml: particles[0].fill.type: a stalk specimen is built of spheres of one type"
        ),
        "{e}"
    );
    // A region belongs to other fills.
    let region = scene(r#"{ type = "stalk", length = 0.02, diameter = 0.015 }"#).replace(
        "fill = ",
        "region = { type = \"box\", min = [0, 0, 0], max = [1, 1, 1] }\nfill = ",
    );
    let e = load(&region).err().unwrap();
    assert!(
        e.starts_with("stalk.toml: particles[0].region: not used by a stalk fill"),
        "{e}"
    );
}
