//! Quantities with units in scene files: converted once when read (the same scene written in SI
//! numbers describes the same simulation), a wrong dimension stops with one line naming the key
//! and its line, and bare numbers that look like the wrong unit are warned about.

use dem::scene::parse;
use dem::scene::Scene;
use std::path::Path;

/// One scene twice: `{..}` holds the SI number and the same value with a unit.
const SCENE: &str = r#"
[simulation]
duration = {0.01|"10 ms"}
time_step_percent = 20
gravity = [0, 0, {-9.81|"-9.81 m/s2"}]

[output]
snapshot_interval = {0.002|"2 ms"}

[[material]]
name = "steel"
density = {7800|"7.8 g/cm3"}
poisson_ratio = 0.3
shear_modulus = {7e10|"70 GPa"}

[[material]]
name = "kernel"
density = {1200|"1200 kg/m3"}
poisson_ratio = 0.4
youngs_modulus = {2.9e7|"29 MPa"}

[[interaction]]
materials = ["kernel", "kernel"]
restitution = 0.3
static_friction = 0.3
rolling_friction = 0.1

[[interaction]]
materials = ["kernel", "steel"]
restitution = 0.5
static_friction = 0.5
rolling_friction = 0.2

[[geometry]]
name = "floor"
type = "plane"
material = "steel"
point = [0, 0, {0.001|"1 mm"}]
normal = [0, 0, 1]

[[geometry]]
name = "pusher"
type = "box"
material = "steel"
min = [{-0.03|"-30 mm"}, 0, 0]
max = [{-0.01|"-1 cm"}, {0.05|"5 cm"}, {0.02|"20 mm"}]
open = ["-x"]
motion = [{ type = "translation", velocity = [{0.0006|"36 mm/min"}, 0, 0], start = {0.002|"2 ms"} }]

[[particles]]
material = "kernel"
size = { type = "uniform", min = {0.0035|"3.5 mm"}, max = {0.004|"4 mm"} }
region = { type = "box", min = [0.0, 0.0, {0.005|"5 mm"}], max = [{0.05|"50 mm"}, 0.05, 0.05] }
fill = { type = "lattice", lattice = "sc", spacing = {0.01|"1 cm"} }
"#;

/// The scene with the SI numbers (`unit = false`) or the strings with units.
fn written(unit: bool) -> String {
    let mut out = String::new();
    let mut rest = SCENE;
    while let Some(i) = rest.find('{') {
        if rest[i..].starts_with("{ ") {
            // An inline table, not a placeholder.
            out.push_str(&rest[..i + 2]);
            rest = &rest[i + 2..];
            continue;
        }
        let j = rest[i..].find('}').unwrap() + i;
        let (si, with_unit) = rest[i + 1..j].split_once('|').unwrap();
        out.push_str(&rest[..i]);
        out.push_str(if unit { with_unit } else { si });
        rest = &rest[j + 1..];
    }
    out.push_str(rest);
    out
}

#[test]
fn a_scene_with_units_describes_the_same_simulation_as_in_si() {
    let si = parse::scene(&written(false), "si.toml", Path::new(".")).unwrap();
    let units = parse::scene(&written(true), "units.toml", Path::new(".")).unwrap();
    // Exact where the conversion factor is a power of ten that rounds the same way; compare the
    // debug form of both descriptions with numbers rounded to 12 significant digits.
    let round = |d: &dem::scene::SceneDescription| {
        let text = format!("{d:?}");
        let mut out = String::new();
        for token in
            text.split_inclusive(|c: char| !(c.is_ascii_alphanumeric() || c == '.' || c == '-'))
        {
            let (body, sep) =
                token.split_at(token.len() - token.chars().last().map_or(0, |c| c.len_utf8()));
            match body.parse::<f64>() {
                Ok(v) if body.contains('.') || body.contains('e') => {
                    out.push_str(&format!("{v:.11e}{sep}"))
                }
                _ => out.push_str(token),
            }
        }
        out
    };
    assert_eq!(round(&si), round(&units));
    let a = Scene::from_toml(&written(false), "si.toml", Path::new(".")).unwrap();
    let b = Scene::from_toml(&written(true), "units.toml", Path::new(".")).unwrap();
    assert_eq!(a.steps, b.steps);
    assert_eq!(a.simulation.particles.len(), b.simulation.particles.len());
    assert!((a.rayleigh_time_step / b.rayleigh_time_step - 1.0).abs() < 1e-12);
    assert!(b.warnings.is_empty(), "{:?}", b.warnings);
}

fn error(from: &str, to: &str) -> String {
    let good = written(true);
    assert!(good.contains(from), "{from}");
    let e = Scene::from_toml(&good.replacen(from, to, 1), "scene.toml", Path::new("."))
        .err()
        .unwrap_or_else(|| panic!("{to} accepted"))
        .to_string();
    assert!(!e.contains('\n'), "{e}");
    e
}

#[test]
fn a_wrong_dimension_names_the_file_the_key_and_the_line() {
    let e = error("\"29 MPa\"", "\"29 mm\"");
    assert!(
        e.starts_with("scene.toml: material[1].youngs_modulus: \"29 mm\" is a length (m), expected a stress or modulus (Pa), e.g. \"29 MPa\" (line "),
        "{e}"
    );
    let e = error("\"36 mm/min\"", "\"36 mm\"");
    assert!(
        e.starts_with("scene.toml: geometry[1].motion[0].velocity[0]: \"36 mm\" is a length"),
        "{e}"
    );
    let e = error("\"3.5 mm\"", "\"3.5 kg\"");
    assert_eq!(
        e,
        "scene.toml: particles[0].size.min: 3.5 kg is a mass (kg), expected a length (m)"
    );
    let e = error("\"10 ms\"", "\"10 parsecs\"");
    assert!(
        e.starts_with("scene.toml: simulation.duration: \"10 parsecs\": unknown unit \"parsecs\""),
        "{e}"
    );
}

#[test]
fn bare_numbers_that_look_like_the_wrong_unit_are_warned_about() {
    let good = written(false);
    let text = good
        .replacen("density = 1200", "density = 1.2", 1)
        .replacen("youngs_modulus = 2.9e7", "youngs_modulus = 29", 1);
    let s = Scene::from_toml(&text, "scene.toml", Path::new(".")).unwrap();
    let all = s.warnings.join("\n");
    assert!(
        all.contains("material[1].density: 1.2 kg/m3 looks like the wrong unit: a plain number is in kg/m3; if g/cm3 was meant, write \"1.2 g/cm3\" (1.2e3 kg/m3)"),
        "{all}"
    );
    assert!(
        all.contains("material[1].youngs_modulus: 29 Pa looks like the wrong unit")
            && all.contains("write \"29 MPa\" (2.9e7 Pa)"),
        "{all}"
    );
    // The same values with their units give no warning.
    let s = Scene::from_toml(&written(true), "scene.toml", Path::new(".")).unwrap();
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
}
