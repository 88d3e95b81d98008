//! Bad scene files stop with one line naming the file, the key and what was expected.

use dem::scene::Scene;
use std::path::Path;
use std::sync::LazyLock;
use test_support::{Interaction, Material, Materials};

/// A good scene; each test breaks one thing in it. The tests replace lines of the materials'
/// blocks as written here (`restitution = 0.3` is the first interaction's, `density = 1200` the
/// kernel's, material[1]).
static GOOD: LazyLock<String> = LazyLock::new(|| {
    let kernel = Materials {
        particle: Material {
            name: "kernel",
            density: 1200.0,
            poisson_ratio: 0.4,
            shear_modulus: 1e7,
        },
        particle_particle: Interaction {
            restitution: 0.3,
            static_friction: 0.3,
            rolling_friction: 0.1,
        },
        particle_wall: Interaction {
            restitution: 0.5,
            static_friction: 0.5,
            rolling_friction: 0.2,
        },
        wall_first: true,
        ..Materials::default()
    };
    format!(
        r#"
[simulation]
duration = 0.01
time_step_percent = 20

{}
[[geometry]]
name = "floor"
type = "plane"
material = "steel"
point = [0.0, 0.0, 0.0]
normal = [0.0, 0.0, 1.0]

[[particles]]
material = "kernel"
size = {{ type = "fixed", radius = 0.004 }}
region = {{ type = "box", min = [0.0, 0.0, 0.005], max = [0.05, 0.05, 0.05] }}
fill = {{ type = "lattice", lattice = "sc", spacing = 0.01 }}
"#,
        kernel.toml()
    )
});

fn load(text: &str) -> Result<Scene, String> {
    Scene::from_toml(text, "scene.toml", Path::new(".")).map_err(|e| e.to_string())
}

/// Loads `GOOD` with `from` replaced by `to` and returns the error line.
fn error_after(from: &str, to: &str) -> String {
    assert!(
        GOOD.contains(from),
        "test edits text that is in the scene: {from}"
    );
    let text = GOOD.replacen(from, to, 1);
    match load(&text) {
        Ok(_) => panic!("scene with {to:?} was accepted"),
        Err(e) => {
            assert!(!e.contains('\n'), "one line: {e}");
            assert!(e.starts_with("scene.toml: "), "names the file: {e}");
            e
        }
    }
}

fn assert_has(e: &str, parts: &[&str]) {
    for p in parts {
        assert!(e.contains(p), "{e:?} should contain {p:?}");
    }
}

#[test]
fn the_good_scene_loads() {
    let s = load(&GOOD).unwrap();
    assert_eq!(s.simulation.particles.len(), 6 * 6 * 5);
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    let dt = s.simulation.params.time_step;
    assert!((dt / s.rayleigh_time_step - 0.2).abs() < 1e-12);
    assert_eq!(s.steps, (0.01 / dt).round() as u64);
}

#[test]
fn unknown_key() {
    let e = error_after(
        "static_friction = 0.3",
        "static_friction = 0.3\nstatic_frictoin = 0.3",
    );
    assert_has(
        &e,
        &["interaction[0]", "unknown field `static_frictoin`", "line"],
    );
    let e = error_after("[simulation]", "[simulation]\nthreads = 2");
    assert_has(&e, &["simulation", "unknown field `threads`"]);
}

#[test]
fn key_of_another_type() {
    let e = error_after(
        "normal = [0.0, 0.0, 1.0]",
        "normal = [0.0, 0.0, 1.0]\nradius = 0.1",
    );
    assert_has(&e, &["geometry[0].radius", "not used by type \"plane\""]);
}

#[test]
fn negative_radius() {
    let e = error_after("radius = 0.004", "radius = -0.004");
    assert_has(
        &e,
        &[
            "particles[0].size.radius",
            "expected a positive number, got -0.004",
        ],
    );
}

#[test]
fn restitution_outside_zero_one() {
    let e = error_after("restitution = 0.3", "restitution = 1.2");
    assert_has(
        &e,
        &[
            "interaction[0].restitution",
            "expected a value in (0, 1], got 1.2",
        ],
    );
    let e = error_after("restitution = 0.3", "restitution = 0.0");
    assert_has(&e, &["interaction[0].restitution", "(0, 1]"]);
}

#[test]
fn time_step_larger_than_rayleigh() {
    let e = error_after("time_step_percent = 20", "time_step_percent = 150");
    assert_has(
        &e,
        &[
            "simulation.time_step_percent",
            "larger than the Rayleigh time step",
        ],
    );
    let e = error_after("time_step_percent = 20", "time_step = 1e-3");
    assert_has(
        &e,
        &["simulation.time_step", "larger than the Rayleigh time step"],
    );
}

#[test]
fn particles_overlapping_beyond_tolerance() {
    let text = GOOD.replacen(
        "[[particles]]",
        "[[particles]]\nmaterial = \"kernel\"\nsize = { type = \"fixed\", radius = 0.001 }\nregion = { type = \"box\", min = [0.0048, 0.0, 0.005], max = [0.0049, 0.0001, 0.0051] }\nfill = { type = \"lattice\", spacing = 0.01 }\n\n[[particles]]",
        1,
    );
    let Err(e) = load(&text) else {
        panic!("accepted")
    };
    assert_has(
        &e,
        &[
            "scene.toml: particles[",
            "overlap at start by 20.0 %",
            "simulation.max_initial_overlap",
        ],
    );
    // Raising the tolerance accepts it.
    let text = text.replacen(
        "[simulation]",
        "[simulation]\nmax_initial_overlap = 0.25",
        1,
    );
    load(&text).unwrap();
}

#[test]
fn lattice_spacing_below_diameter() {
    let e = error_after("spacing = 0.01", "spacing = 0.006");
    assert_has(
        &e,
        &[
            "particles[0].fill.spacing",
            "smaller than the largest diameter",
        ],
    );
}

#[test]
fn missing_stl_file() {
    let e = error_after(
        "type = \"plane\"\nmaterial = \"steel\"\npoint = [0.0, 0.0, 0.0]\nnormal = [0.0, 0.0, 1.0]",
        "type = \"mesh\"\nmaterial = \"steel\"\nfile = \"no/such/chute.stl\"",
    );
    assert_has(
        &e,
        &[
            "geometry[0].file",
            "STL file",
            "no/such/chute.stl",
            "does not exist",
        ],
    );
}

#[test]
fn unknown_material() {
    let e = error_after("material = \"steel\"\npoint", "material = \"stee1\"\npoint");
    assert_has(
        &e,
        &[
            "geometry[0].material",
            "unknown material \"stee1\"",
            "kernel",
        ],
    );
}

#[test]
fn missing_interaction() {
    let e = error_after(
        "materials = [\"kernel\", \"steel\"]",
        "materials = [\"steel\", \"steel\"]",
    );
    assert_has(
        &e,
        &[
            "interaction",
            "no [[interaction]] for materials \"kernel\" and \"steel\"",
        ],
    );
}

#[test]
fn dynamic_friction_is_an_alias_of_rolling_friction() {
    let text = GOOD.replacen("rolling_friction = 0.1", "dynamic_friction = 0.1", 1);
    let s = load(&text).unwrap();
    let k = s.simulation.materials.id_of("kernel").unwrap();
    assert_eq!(
        s.simulation
            .materials
            .interaction(k, k)
            .unwrap()
            .rolling_friction,
        0.1
    );
    // Papers mean sliding friction by "dynamic friction" as often as EDEM's rolling friction:
    // the alias is read, and said how.
    let warning = "scene.toml: interaction[0].dynamic_friction: read as rolling friction, as EDEM and the calibration papers use the name; sliding (kinetic) friction is static_friction here. Write rolling_friction to silence this warning";
    assert_eq!(
        s.warnings
            .iter()
            .filter(|w| w.contains("friction"))
            .collect::<Vec<_>>(),
        [warning]
    );
    let kinetic = GOOD.replacen("rolling_friction = 0.1", "kinetic_friction = 0.1", 1);
    let s = load(&kinetic).unwrap();
    assert!(
        s.warnings
            .contains(&warning.replace("dynamic_friction", "kinetic_friction")),
        "{:?}",
        s.warnings
    );
    // The plain name says nothing.
    assert!(!load(&GOOD)
        .unwrap()
        .warnings
        .iter()
        .any(|w| w.contains("rolling friction")));
    let e = error_after(
        "rolling_friction = 0.1",
        "rolling_friction = 0.1\ndynamic_friction = 0.1",
    );
    assert_has(&e, &["interaction[0]", "duplicate"]);
}

#[test]
fn wrong_value_type() {
    let e = error_after("density = 1200", "density = \"heavy\"");
    assert_has(
        &e,
        &[
            "material[1].density",
            "\"heavy\": expected a number and a unit",
            "(line 14)",
        ],
    );
    let e = error_after("density = 1200", "density = true");
    assert_has(
        &e,
        &[
            "material[1].density",
            "invalid type: boolean `true`, expected a density (kg/m3): a number, or a string with a unit such as \"1.2 g/cm3\"",
        ],
    );
}

#[test]
fn poisson_ratio_out_of_range() {
    let e = error_after("poisson_ratio = 0.4", "poisson_ratio = 0.5");
    assert_has(&e, &["material[1].poisson_ratio", "(-1, 0.5)"]);
}

#[test]
fn unknown_geometry_type_and_motion() {
    let e = error_after("type = \"plane\"", "type = \"cone\"");
    assert_has(&e, &["geometry[0].type", "unknown geometry type \"cone\""]);
    let e = error_after(
        "normal = [0.0, 0.0, 1.0]",
        "normal = [0.0, 0.0, 1.0]\n[[geometry.motion]]\ntype = \"translation\"\nvelocity = [0.0, 0.0, 1.0]\nstart = 1.0\nend = 0.5",
    );
    assert_has(&e, &["geometry[0].motion[0].end", "expected end > start"]);
}

#[test]
fn missing_duration() {
    let e = error_after("duration = 0.01", "");
    assert_has(&e, &["simulation.duration", "missing"]);
}

#[test]
fn toml_syntax_error_names_the_line() {
    let e = error_after("density = 7800", "density = = 7800");
    assert_has(&e, &["line"]);
}

#[test]
fn random_fill_that_cannot_fit() {
    let e = error_after(
        "fill = { type = \"lattice\", lattice = \"sc\", spacing = 0.01 }",
        "fill = { type = \"random\", count = 100000 }",
    );
    assert_has(&e, &["particles[0].fill", "region is too small"]);
}

const INLINE_GROUP: &str = r#"[[particles]]
material = "kernel"
size = { type = "fixed", radius = 0.004 }
region = { type = "box", min = [0.0, 0.0, 0.005], max = [0.05, 0.05, 0.05] }
fill = { type = "lattice", lattice = "sc", spacing = 0.01 }"#;

#[test]
fn unknown_particle_type_lists_the_defined_ones() {
    let e = error_after(
        INLINE_GROUP,
        r#"[[particle_type]]
name = "rod"
material = "kernel"
shape = { type = "rod", length = 0.02, diameter = 0.004, count = 4 }

[[particles]]
types = ["rods"]
region = { type = "box", min = [0.0, 0.0, 0.005], max = [0.05, 0.05, 0.05] }
fill = { type = "random", count = 5 }"#,
    );
    assert_has(&e, &["particles[0].types[0]", "\"rods\"", "defined: rod"]);
}

#[test]
fn clump_shape_errors_name_the_key() {
    let e = error_after(
        "size = { type = \"fixed\", radius = 0.004 }",
        "shape = { type = \"maize_kernel\", class = \"dent\", count = 6 }",
    );
    assert_has(&e, &["particles[0].shape.class", "horse_tooth, flat"]);
    let e = error_after(
        "size = { type = \"fixed\", radius = 0.004 }",
        "shape = { type = \"maize_kernel\", class = \"flat\", count = 6, upper_width = 0.007 }",
    );
    assert_has(&e, &["particles[0].shape.upper_width", "not used"]);
    let e = error_after(
        "size = { type = \"fixed\", radius = 0.004 }",
        "shape = { type = \"rod\", length = 0.02, diameter = 0.004 }",
    );
    assert_has(&e, &["particles[0].shape.count", "missing"]);
    // A lattice places spheres only.
    let e = error_after(
        "size = { type = \"fixed\", radius = 0.004 }",
        "shape = { type = \"rod\", length = 0.02, diameter = 0.004, count = 4 }",
    );
    assert_has(&e, &["particles[0].fill.type", "lattice places spheres"]);
}

#[test]
fn mixture_and_factory_errors_name_the_key() {
    let group = |body: &str| {
        format!(
            r#"[[particle_type]]
name = "a"
material = "kernel"
size = {{ type = "fixed", radius = 0.003 }}

[[particle_type]]
name = "b"
material = "kernel"
size = {{ type = "fixed", radius = 0.002 }}

[[particles]]
{body}"#
        )
    };
    let random = "region = { type = \"box\", min = [0.0, 0.0, 0.005], max = [0.05, 0.05, 0.05] }\nfill = { type = \"random\", count = 5 }";
    let e = error_after(
        INLINE_GROUP,
        &group(&format!("types = [\"a\", \"b\"]\n{random}")),
    );
    assert_has(&e, &["particles[0].fractions", "missing"]);
    let e = error_after(
        INLINE_GROUP,
        &group(&format!(
            "types = [\"a\", \"b\"]\nfractions = [1, 2, 3]\n{random}"
        )),
    );
    assert_has(&e, &["particles[0].fractions", "one fraction per type"]);
    let e = error_after(
        INLINE_GROUP,
        &group(&format!("types = [\"a\"]\nbasis = \"volume\"\n{random}")),
    );
    assert_has(&e, &["particles[0].basis", "number or mass"]);
    let e = error_after(
        INLINE_GROUP,
        &group("types = [\"a\"]\nfactory = { type = \"disc\", centre = [0.02, 0.02, 0.1], radius = 0.01 }\nfill = { type = \"factory\", count = 5 }"),
    );
    assert_has(&e, &["particles[0].fill.rate", "particles/s"]);
    let e = error_after(
        INLINE_GROUP,
        &group("types = [\"a\"]\nfactory = { type = \"hexagon\", centre = [0.02, 0.02, 0.1] }\nfill = { type = \"factory\", count = 5, rate = 100 }"),
    );
    assert_has(&e, &["particles[0].factory.type", "disc or rectangle"]);
    let e = error_after(
        INLINE_GROUP,
        &group(&format!(
            "types = [\"a\"]\nsize = {{ type = \"fixed\", radius = 0.003 }}\n{random}"
        )),
    );
    assert_has(&e, &["particles[0].size", "not used with types"]);
}

#[test]
fn absurd_durations_and_step_counts_are_refused_up_front() {
    // 1e300 s would have run u64::MAX steps.
    let e = error_after("duration = 0.01", "duration = 1e300");
    assert_has(
        &e,
        &[
            "simulation.duration",
            "time steps",
            "more than the 1e10 a run may take",
        ],
    );
    let e = error_after("duration = 0.01", "steps = 20000000000");
    assert_has(&e, &["simulation.steps", "more than the 1e10"]);
    // Just under the limit is fine.
    let s = load(&GOOD.replacen("duration = 0.01", "steps = 10000000000", 1)).unwrap();
    assert_eq!(s.steps, dem::scene::MAX_STEPS);
}

#[test]
fn particle_counts_beyond_memory_are_refused_before_allocating() {
    let random = "fill = { type = \"random\", count = 100000000 }";
    let start = std::time::Instant::now();
    let e = error_after(
        "fill = { type = \"lattice\", lattice = \"sc\", spacing = 0.01 }",
        random,
    );
    assert_has(
        &e,
        &[
            "particles[0].fill.count",
            "100000000 particles",
            "at most 10000000 spheres",
        ],
    );
    // Refused from the count alone: no 3.5 GB of draws first.
    assert!(start.elapsed().as_secs_f64() < 1.0, "{:?}", start.elapsed());
    // A mass fill: 1e6 kg of 4 mm beads (0.32 g each) is 3e9 particles.
    let e = error_after(
        "fill = { type = \"lattice\", lattice = \"sc\", spacing = 0.01 }",
        "fill = { type = \"random\", mass = 1e6 }",
    );
    assert_has(
        &e,
        &[
            "particles[0].fill.mass",
            "the mass over the lightest particle",
            "at most 10000000 spheres",
        ],
    );
    // A lattice in a region far too large for its spacing.
    let e = error_after("max = [0.05, 0.05, 0.05]", "max = [50.0, 50.0, 50.0]");
    assert_has(
        &e,
        &["particles[0].fill.spacing", "at most 10000000 spheres"],
    );
    // Groups add up: two of 6 million each.
    let six = "fill = { type = \"factory\", count = 6000000, rate = 100 }\nfactory = { type = \"disc\", centre = [0.02, 0.02, 0.1], radius = 0.01 }";
    let region = "region = { type = \"box\", min = [0.0, 0.0, 0.005], max = [0.05, 0.05, 0.05] }\nfill = { type = \"lattice\", lattice = \"sc\", spacing = 0.01 }";
    let e = error_after(
        region,
        &format!("{six}\n\n[[particles]]\nmaterial = \"kernel\"\nsize = {{ type = \"fixed\", radius = 0.004 }}\n{six}"),
    );
    assert_has(
        &e,
        &[
            "particles[1].fill.count",
            "with the groups before it up to 1.200e7 spheres",
        ],
    );
}

#[test]
fn sizes_that_look_like_millimetres_are_named() {
    // A radius of 3 (meant as 3 mm) cannot fit; the error says why.
    let e = error_after(
        "radius = 0.004 }\nregion = { type = \"box\", min = [0.0, 0.0, 0.005], max = [0.05, 0.05, 0.05] }\nfill = { type = \"lattice\", lattice = \"sc\", spacing = 0.01 }",
        "radius = 3 }\nregion = { type = \"box\", min = [0.0, 0.0, 0.005], max = [0.05, 0.05, 0.05] }\nfill = { type = \"random\", count = 20 }",
    );
    assert_has(
        &e,
        &[
            "particles[0].fill",
            "region is too small",
            "particles[0]: particle spheres of radius up to 3.0000 m look like the wrong unit",
            "3.0000 mm would be 3.0000e-3",
        ],
    );
    // It stays a warning where the scene can be built.
    let s = load(&GOOD.replacen(
        "radius = 0.004 }\nregion = { type = \"box\", min = [0.0, 0.0, 0.005], max = [0.05, 0.05, 0.05] }\nfill = { type = \"lattice\", lattice = \"sc\", spacing = 0.01 }",
        "radius = 0.6 }\nregion = { type = \"box\", min = [0.0, 0.0, 0.7], max = [5.0, 5.0, 5.0] }\nfill = { type = \"lattice\" }",
        1,
    ))
    .unwrap();
    assert!(
        s.warnings.iter().any(|w| w.contains(
            "particles[0]: particle spheres of radius up to 0.6000 m look like the wrong unit"
        )),
        "{:?}",
        s.warnings
    );
    // Geometry hundreds of metres across (an STL in millimetres, or a size typed in mm).
    let s = load(&GOOD.replacen(
        "type = \"plane\"\nmaterial = \"steel\"\npoint = [0.0, 0.0, 0.0]\nnormal = [0.0, 0.0, 1.0]",
        "type = \"cylinder\"\nmaterial = \"steel\"\nbase = [0.0, 0.0, 0.0]\nradius = 300\nlength = 0.1\ncaps = \"bottom\"",
        1,
    ))
    .unwrap();
    assert_eq!(s.warnings.len(), 1, "{:?}", s.warnings);
    assert_has(
        &s.warnings[0],
        &[
            "geometry[0]: \"floor\" is 600.0000 m across",
            "wrong unit",
            "in metres",
        ],
    );
}

#[test]
fn unknown_backend_is_refused_and_a_missing_one_falls_back_to_the_cpu() {
    let e = error_after("[simulation]", "[simulation]\nbackend = \"cuda\"");
    assert_has(
        &e,
        &[
            "simulation.backend",
            "unknown back end \"cuda\"",
            "expected cpu or gpu",
        ],
    );
    // This test program registers no GPU back end: the scene runs on the CPU and says why.
    let s = load(&GOOD.replacen("[simulation]", "[simulation]\nbackend = \"gpu\"", 1)).unwrap();
    assert_eq!(s.simulation.backend_name(), "cpu");
    assert_eq!(
        s.warnings,
        ["backend \"gpu\": this program was built without it; running on the CPU"]
    );
}

#[test]
fn polyhedron_shapes() {
    let shape = |s: &str| {
        format!(
            "shape = {{ type = \"polyhedron\", {s} }}\nscale = {{ type = \"fixed\", value = 1.0 }}"
        )
    };
    let fill = "fill = { type = \"lattice\", lattice = \"sc\", spacing = 0.01 }";
    let random = "fill = { type = \"random\", count = 20, seed = 2 }";
    let size = "size = { type = \"fixed\", radius = 0.004 }";
    // Neither a class nor vertices, or both.
    let text = GOOD
        .replacen(size, &shape("thickness = 0.004"), 1)
        .replacen(fill, random, 1);
    let e = load(&text).err().expect("refused");
    assert_has(
        &e,
        &["particles[0].shape", "one of class", "vertices", "file"],
    );
    // Vertices in one plane.
    let flat = "vertices = [[0, 0, 0], [0.004, 0, 0], [0, 0.004, 0], [0.004, 0.004, 0]]";
    let text = GOOD
        .replacen(size, &shape(flat), 1)
        .replacen(fill, random, 1);
    let e = load(&text).err().expect("refused");
    assert_has(&e, &["particles[0].shape.vertices", "one plane"]);
    // Laws and models that use the equivalent contact's radius beyond Hertz-Mindlin are refused.
    let kernel = shape("class = \"flat\"");
    for (from, to, key) in [
        (
            "time_step_percent = 20",
            "time_step_percent = 20\ncontact_model = \"hooke\"",
            "simulation.contact_model",
        ),
        (
            "time_step_percent = 20",
            "time_step_percent = 20\nrolling_friction_model = \"epsd\"",
            "simulation.rolling_friction_model",
        ),
        (
            "restitution = 0.3",
            "restitution = 0.3\nsurface_energy = 0.1",
            "interaction[0].surface_energy",
        ),
    ] {
        let text = GOOD
            .replacen(size, &kernel, 1)
            .replacen(fill, random, 1)
            .replacen(from, to, 1);
        let e = load(&text).err().expect("refused");
        assert_has(&e, &[key, "polyhedral particles"]);
    }
    // A box from its corners, and a kernel class with one dimension changed, both load.
    let corners = "vertices = [[0, 0, 0], [0.006, 0, 0], [0, 0.004, 0], [0.006, 0.004, 0], [0, 0, 0.003], [0.006, 0, 0.003], [0, 0.004, 0.003], [0.006, 0.004, 0.003]]";
    for s in [corners, "class = \"flat\", diameter = \"8 mm\""] {
        let text = GOOD.replacen(size, &shape(s), 1).replacen(fill, random, 1);
        let scene = load(&text).unwrap();
        let sim = &scene.simulation;
        assert_eq!(sim.bodies.len(), 20);
        assert!((0..20u32).all(|b| sim.bodies.polyhedra.is_polyhedron(b)));
        let poly = sim.bodies.polyhedra.shape_of(0).unwrap();
        let want = if s == corners {
            0.006 * 0.004 * 0.003
        } else {
            // The 12-sided prism of an 8 mm x 5 mm disc, scaled to the disc's volume.
            std::f64::consts::PI * 0.25 * 0.008 * 0.008 * 0.005
        };
        assert!(
            (poly.volume / want - 1.0).abs() < 1e-9,
            "{s}: {}",
            poly.volume
        );
    }
}

/// Nonsense a scene used to accept (issue 40): a second table for the same pair of materials,
/// a density that ends in NaN energies, a skin that puts every pair in the lists, and motions
/// that are not finite.
#[test]
fn nonsense_that_used_to_run_is_refused() {
    // The same pair again (either order), after the two the scene has.
    let e = error_after(
        "[[geometry]]",
        "[[interaction]]\nmaterials = [\"steel\", \"kernel\"]\nrestitution = 0.9\nstatic_friction = 0.5\nrolling_friction = 0.1\n\n[[geometry]]",
    );
    assert_has(
        &e,
        &[
            "interaction[2].materials",
            "[steel, kernel] is already given by interaction[1]",
        ],
    );
    let e = error_after("density = 1200", "density = 1e-300");
    assert_has(
        &e,
        &[
            "material[1].density",
            "expected 1e-3 to 1e15 kg/m³, got 1e-300",
        ],
    );
    let e = error_after(
        "time_step_percent = 20",
        "time_step_percent = 20\nneighbour_skin = 1e300",
    );
    assert_has(
        &e,
        &[
            "simulation.neighbour_skin",
            "expected at most 4 times the largest sphere radius",
        ],
    );
    for (motion, key, got) in [
        (
            "{ type = \"translation\", velocity = [0.0, nan, 0.0] }",
            "geometry[0].motion[0].velocity",
            "expected finite numbers, got [0, NaN, 0]",
        ),
        (
            "{ type = \"rotation\", axis = [0.0, 0.0, 1.0], rpm = inf }",
            "geometry[0].motion[0].angular_velocity",
            "expected a finite number, got inf",
        ),
        (
            "{ type = \"rotation\", axis = [0.0, 0.0, 1.0], axis_point = [inf, 0.0, 0.0], rpm = 1.0 }",
            "geometry[0].motion[0].axis_point",
            "expected finite numbers",
        ),
    ] {
        let e = error_after(
            "normal = [0.0, 0.0, 1.0]",
            &format!("normal = [0.0, 0.0, 1.0]\nmotion = [{motion}]"),
        );
        assert_has(&e, &[key, got]);
    }
    let e = error_after(
        "normal = [0.0, 0.0, 1.0]",
        "normal = [0.0, 0.0, 1.0]\ntorque_point = [0.0, -inf, 0.0]",
    );
    assert_has(&e, &["geometry[0].torque_point", "expected finite numbers"]);
}
