//! The lifted-cylinder test end to end on a small heap, and its file errors.

use test_support::{Interaction, Material, Materials};
use virtual_tests::{run_file, TestFile};

fn file(settings_extra: &str, count: u32) -> String {
    let beads = Materials {
        particle: Material {
            name: "bead",
            shear_modulus: 5e6,
            ..Materials::default().particle
        },
        wall: Material {
            density: 7850.0,
            ..Materials::default().wall
        },
        particle_particle: Interaction {
            restitution: 0.4,
            ..Materials::default().particle_particle
        },
        ..Materials::default()
    };
    let materials = beads.toml();
    format!(
        r#"
test = "angle_of_repose"
seed = 3

{materials}
[angle_of_repose]
particles = {{ material = "bead", size = {{ type = "fixed", radius = 0.002 }} }}
wall_material = "steel"
cylinder_diameter = 0.04
cylinder_height = 0.06
plate_size = 0.24
fill = {{ count = {count} }}
lift_speed = 0.1
{settings_extra}
"#
    )
}

#[test]
fn same_seed_same_angle_and_pictures_are_written() {
    let f = TestFile::parse("heap.toml", &file("", 500)).unwrap();
    let out = std::env::temp_dir().join(format!("demcal-heap-{}", std::process::id()));
    let done = run_file(&f, None, Some(&out), &mut |_, _| Ok(())).unwrap();
    let (a, summary) = (done.json, done.summary);
    let b = run_file(&f, None, None, &mut |_, _| Ok(())).unwrap().json;
    eprintln!("{summary}");
    assert_eq!(a["angle_of_repose_deg"], b["angle_of_repose_deg"]);
    assert_eq!(a["particles"], 500);
    let angle = a["angle_of_repose_deg"].as_f64().unwrap();
    assert!(angle > 5.0 && angle < 45.0, "{angle}");
    // The heap is still and lower than the filled column was.
    assert!(a["final_rms_speed_m_s"].as_f64().unwrap() < 0.005);
    assert!(a["heap_height_m"].as_f64().unwrap() < 0.06);
    for key in [
        "angle_std_deg",
        "heap_radius_m",
        "wall_s",
        "simulated_time_s",
    ] {
        assert!(a.get(key).is_some(), "{key}");
    }
    let svg = std::fs::read_to_string(out.join("profiles.svg")).unwrap();
    let doc = roxmltree::Document::parse(&svg).unwrap();
    let lines = doc
        .descendants()
        .filter(|n| n.has_tag_name("polyline") && n.attribute("stroke-width") == Some("2"))
        .count();
    assert_eq!(lines, 8, "one fitted line per flank (4 planes)");
    let png = std::fs::read(out.join("heap.png")).unwrap();
    assert_eq!(&png[1..4], b"PNG");
    // The time step's share of the Rayleigh step is the file's (default) 20 %; the mass is
    // 500 beads of the file's size and density.
    let share = a["time_step_s"].as_f64().unwrap() / a["rayleigh_time_step_s"].as_f64().unwrap();
    assert!((share - 0.2).abs() < 1e-9, "{share}");
    assert!(a["particle_mass_kg"].as_f64().unwrap() > 0.0);
    // Where the side view lies, and the two flanks of the plane it looks across.
    let heap: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("heap.json")).unwrap()).unwrap();
    let flanks = heap["flanks"].as_array().unwrap();
    assert_eq!(flanks.len(), 2);
    for fl in flanks {
        let slope = fl["slope"].as_f64().unwrap();
        let angle = fl["angle_deg"].as_f64().unwrap();
        assert!(((-slope).atan().to_degrees() - angle).abs() < 1e-9);
    }
    let (w, m) = (
        heap["width_px"].as_f64().unwrap(),
        heap["m_per_px"].as_f64().unwrap(),
    );
    let x_left = heap["x_left_m"].as_f64().unwrap();
    assert_eq!(w, 900.0);
    // The picture spans the heap: its left edge lies left of the axis, its right edge right.
    assert!(x_left < 0.0 && x_left + w * m > 0.0, "{x_left} {m}");
    // Another seed gives another heap.
    let c = run_file(&f, Some(4), None, &mut |_, _| Ok(()))
        .unwrap()
        .json;
    assert_ne!(a["angle_of_repose_deg"], c["angle_of_repose_deg"]);
}

#[test]
fn file_errors_name_the_key() {
    let cases = [
        (
            file("bogus = 1", 10),
            "heap.toml: angle_of_repose.bogus: unknown field",
        ),
        (
            file("", 10).replace("fill = { count = 10 }", "fill = { count = 10, mass = 1.0 }"),
            "angle_of_repose.fill: expected exactly one of count or mass",
        ),
        (
            file("", 10).replace("lift_speed = 0.1", "lift_speed = -1"),
            "angle_of_repose.lift_speed: expected a positive number",
        ),
        (
            file("", 10).replace("test = \"angle_of_repose\"", "test = \"torsion\""),
            "heap.toml: test: unknown test \"torsion\"",
        ),
        (
            file("", 10).replace("material = \"bead\"", "material = \"corn\""),
            "heap.toml: angle_of_repose.particles.material: unknown material \"corn\"",
        ),
        (
            file("", 10).replace("wall_material = \"steel\"", "wall_material = \"iron\""),
            "heap.toml: angle_of_repose.wall_material: unknown material \"iron\" (defined: bead, steel)",
        ),
        (
            file("", 10).replace("radius = 0.002", "radius = -0.002"),
            "heap.toml: angle_of_repose.particles.size.radius: expected a positive number",
        ),
        (
            file("", 10).replace("fill = { count = 10 }", "fill = { count = 100000 }"),
            "heap.toml: angle_of_repose.fill: the region is too small",
        ),
        (
            file("time_step_percent = 150", 10),
            "heap.toml: angle_of_repose.time_step_percent: time step",
        ),
    ];
    for (text, want) in cases {
        let e = TestFile::parse("heap.toml", &text)
            .and_then(|f| {
                run_file(&f, None, None, &mut |_, _| Ok(()))
                    .map(|_| ())
                    .map_err(String::from)
            })
            .unwrap_err();
        assert!(e.contains(want), "{e}\nwanted: {want}");
        assert_eq!(e.lines().count(), 1, "{e}");
    }
}

#[test]
fn settings_that_would_never_end_are_refused_before_the_run() {
    let cases = [
        (
            file("", 10).replace("lift_speed = 0.1", "lift_speed = 1e-9"),
            "heap.toml: angle_of_repose.lift_speed: lifting 0.06 m at 1e-9 m/s takes 6.000e7 s of simulated time; the test would need",
        ),
        (
            file("settle_max_time = 1e300", 10),
            "heap.toml: angle_of_repose.settle_max_time: settling takes 1.000e300 s",
        ),
        (
            file("final_max_time = 1e300", 10),
            "heap.toml: angle_of_repose.final_max_time: the final settling takes 1.000e300 s",
        ),
    ];
    for (text, want) in cases {
        let start = std::time::Instant::now();
        let mut reports = 0;
        let e = TestFile::parse("heap.toml", &text)
            .and_then(|f| {
                run_file(&f, None, None, &mut |_, _| {
                    reports += 1;
                    Ok(())
                })
                .map(|_| ())
                .map_err(String::from)
            })
            .unwrap_err();
        assert!(e.contains(want), "{e}\nwanted: {want}");
        assert!(e.contains("more than the 1e9 a test run may take"), "{e}");
        assert_eq!(e.lines().count(), 1, "{e}");
        // Refused before a single step.
        assert_eq!(reports, 0);
        assert!(start.elapsed().as_secs_f64() < 5.0);
    }
}

/// A measurement that would grow without bound is refused before the run, naming the limit
/// (1e9 planes grew to 7.9 GB after the whole simulation).
#[test]
fn too_many_measuring_planes_are_refused_before_the_run() {
    let text = file("planes = 1000000000", 10);
    let mut reports = 0;
    let e = TestFile::parse("heap.toml", &text)
        .and_then(|f| {
            run_file(&f, None, None, &mut |_, _| {
                reports += 1;
                Ok(())
            })
            .map(|_| ())
            .map_err(String::from)
        })
        .unwrap_err();
    assert_eq!(
        e,
        "heap.toml: angle_of_repose.planes: expected 1 to 180, got 1000000000"
    );
    assert_eq!(reports, 0);
}
