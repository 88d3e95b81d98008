//! The inclined-plane tests against mechanics: a flat clump slides at tan(angle) = static
//! friction, a sphere rolls at tan(angle) = rolling friction (constant directional torque), and a
//! flat clump's slide distance is bounded by the work of friction.

use test_support::{Interaction, Material, Materials};
use virtual_tests::{run_file, TestFile};

/// Grain on steel with the particle-wall coefficients under test, and a flat "tile" clump.
fn materials(static_friction: f64, rolling_friction: f64, restitution: f64) -> String {
    let grain_on_steel = Materials {
        wall: Material {
            density: 7850.0,
            shear_modulus: 7.9e10,
            ..Materials::default().wall
        },
        particle_wall: Interaction {
            restitution,
            static_friction,
            rolling_friction,
        },
        ..Materials::default()
    };
    format!(
        r#"
{}
[[particle_type]]
name = "tile"
material = "grain"
# Four spheres in a square: it cannot roll, so it slides.
shape = {{ type = "spheres", spheres = [[0.0, 0.0, 0.0, 0.002], [0.003, 0.0, 0.0, 0.002], [0.0, 0.003, 0.0, 0.002], [0.003, 0.003, 0.0, 0.002]] }}
"#,
        grain_on_steel.toml()
    )
}

fn run(text: &str) -> serde_json::Value {
    let f = TestFile::parse("incline.toml", text).unwrap();
    let done = run_file(&f, None, None, &mut |_, _| Ok(())).unwrap_or_else(|e| panic!("{e}"));
    eprintln!("{}", done.summary);
    done.json
}

#[test]
fn a_flat_clump_slides_at_the_friction_angle() {
    let text = format!(
        "test = \"incline_tilt\"\n{}\n[incline_tilt]\nparticles = {{ types = [\"tile\"] }}\nplate_material = \"steel\"\n",
        materials(0.4, 0.05, 0.3)
    );
    let j = run(&text);
    let angle = j["angle_deg"].as_f64().unwrap();
    // Sliding starts at atan(0.4) = 21.80 deg; 2 mm of travel at 2 deg/s adds about half a degree.
    assert!(j["slid"].as_bool().unwrap());
    assert!(
        (angle - 0.4f64.atan().to_degrees() - 0.5).abs() < 0.6,
        "{angle}"
    );
    assert!((j["tan_angle"].as_f64().unwrap() - angle.to_radians().tan()).abs() < 1e-12);
}

#[test]
fn a_sphere_rolls_at_the_rolling_friction_angle() {
    let text = format!(
        "test = \"incline_tilt\"\n{}\n[incline_tilt]\nparticles = {{ material = \"grain\", size = {{ type = \"fixed\", radius = 0.002 }} }}\nplate_material = \"steel\"\n",
        materials(0.5, 0.1, 0.3)
    );
    let j = run(&text);
    let angle = j["angle_deg"].as_f64().unwrap();
    // Rolling starts when tan(angle) exceeds the rolling friction: atan(0.1) = 5.71 deg.
    assert!(
        (angle - 0.1f64.atan().to_degrees() - 0.5).abs() < 0.7,
        "{angle}"
    );
}

#[test]
fn slide_distance_of_a_flat_clump_is_bounded_by_the_work_of_friction() {
    let (mu, e, theta, length) = (0.2f64, 0.1, 20f64.to_radians(), 0.2);
    let text = format!(
        "test = \"incline_slide\"\nseed = 2\n{}\n[incline_slide]\nparticles = {{ types = [\"tile\"] }}\nramp_material = \"steel\"\nramp_angle_deg = 20\nramp_length = {length}\nreleases = 2\n",
        materials(mu, 0.05, e)
    );
    let j = run(&text);
    // Down the ramp: v^2 = 2 g L (sin - mu cos); then it slides to rest over v_h^2 / (2 mu g).
    // At the foot a point mass would lose its normal velocity v sin (e of it returned) and, to
    // friction during that impact, mu (1 + e) v sin of v cos; a tile turns over the corner and
    // loses less. So the distance lies between those two ends (plus the tile's half length,
    // as the centre is measured).
    let g = 9.81;
    let v = (2.0 * g * length * (theta.sin() - mu * theta.cos())).sqrt();
    let vh = v * theta.cos() - mu * (1.0 + e) * v * theta.sin();
    let (shortest, longest) = (vh * vh / (2.0 * mu * g), v * v / (2.0 * mu * g) + 0.0035);
    let d = j["distance_m"].as_f64().unwrap();
    assert!(
        d > shortest && d < longest,
        "{d} outside [{shortest}, {longest}]"
    );
    assert_eq!(j["stopped_on_ramp"], 0);
}

#[test]
fn incline_file_errors_name_the_key() {
    let base = format!(
        "test = \"incline_slide\"\n{}\n[incline_slide]\nparticles = {{ types = [\"tile\"] }}\nramp_material = \"steel\"\nramp_angle_deg = 20\nramp_length = 0.2\n",
        materials(0.2, 0.05, 0.1)
    );
    for (from, to, want) in [
        (
            "ramp_angle_deg = 20",
            "ramp_angle_deg = 95",
            "incline_slide.ramp_angle_deg: expected less than 90",
        ),
        (
            "ramp_length = 0.2",
            "ramp_length = 0",
            "incline_slide.ramp_length: expected a positive number",
        ),
        (
            "ramp_material = \"steel\"",
            "ramp_material = \"iron\"",
            "incline.toml: incline_slide.ramp_material: unknown material \"iron\" (defined: grain, steel)",
        ),
        (
            "ramp_length = 0.2",
            "ramp_length = 0.2\nmax_time = 1e300",
            "incline_slide.max_time: 5 releases of up to 1e300 s takes 5.000e300 s of simulated time",
        ),
        (
            "ramp_length = 0.2",
            "ramp_length = 0.2\nreleases = 1000000000",
            "incline_slide.releases: expected at most 10000 (each is its own simulation), got 1000000000",
        ),
        (
            "types = [\"tile\"] }",
            "types = [\"tiles\"] }",
            "incline.toml: incline_slide.particles.types[0]: no [[particle_type]] named \"tiles\" (defined: tile)",
        ),
        (
            "particles = {",
            "particles = { region = 1, ",
            "incline_slide.particles.region: unknown key",
        ),
        (
            "types = [\"tile\"] }",
            "types = [\"tile\"], fractions = [\"all\"] }",
            "incline_slide.particles.fractions: expected one number",
        ),
        (
            "test = \"incline_slide\"",
            "test = \"incline_slide\"\nbackend = \"tpu\"",
            "incline.toml: backend: expected \"cpu\" or \"gpu\", got \"tpu\"",
        ),
    ] {
        let text = base.replace(from, to);
        let e = TestFile::parse("incline.toml", &text)
            .and_then(|f| run_file(&f, None, None, &mut |_, _| Ok(())).map(|_| ()).map_err(String::from))
            .unwrap_err();
        assert!(e.contains(want), "{e}\nwanted: {want}");
        assert_eq!(e.lines().count(), 1, "{e}");
    }
}

#[test]
fn a_tilt_that_would_never_end_is_refused_before_the_run() {
    let text = format!(
        "test = \"incline_tilt\"\n{}\n[incline_tilt]\nparticles = {{ types = [\"tile\"] }}\nplate_material = \"steel\"\ntilt_rate_deg_s = 1e-12\n",
        materials(0.4, 0.05, 0.3)
    );
    let mut reports = 0;
    let e = TestFile::parse("incline.toml", &text)
        .and_then(|f| {
            run_file(&f, None, None, &mut |_, _| {
                reports += 1;
                Ok(())
            })
            .map(|_| ())
            .map_err(String::from)
        })
        .unwrap_err();
    assert!(
        e.starts_with("incline.toml: incline_tilt.tilt_rate_deg_s: tilting to 60 deg at 1e-12 deg/s takes 6.000e13 s"),
        "{e}"
    );
    assert_eq!(reports, 0);
}
