//! Test fixtures shared by the demcal crates' tests.
//!
//! Scene files and virtual-test files all start with the same blocks: a particle material, a wall
//! material and the two `[[interaction]]`s between them. [`Materials`] writes those blocks, so a
//! test states only the numbers it cares about and each test file keeps its own values (the
//! assertions were written against them). Numbers are written so that the text reads as a person
//! would type it (`density = 7800`, `shear_modulus = 7e10`), since tests edit the text by
//! replacing such lines.

use std::fmt::Write;
use std::path::{Path, PathBuf};

/// The bonded bar of the mechanical tests' checks: a stalk material, steel, their interactions
/// and the stalk's bonds (k_n = k_t = 1e9 N/m^3, sigma_c 0.2 MPa, tau_c 1 MPa), as the top of a
/// test file (after `test = "..."`); a test adds its own table, or [`BONDED_BAR_TENSION`].
pub const BONDED_BAR_PARTS: &str = r#"
[[material]]
name = "stalk"
density = 136.4
poisson_ratio = 0.357
shear_modulus = 1.511e8

[[material]]
name = "steel"
density = 7850
poisson_ratio = 0.3
shear_modulus = 7.9e10

[[interaction]]
materials = ["stalk", "stalk"]
restitution = 0.47
static_friction = 0.28
rolling_friction = 0.16

[[interaction]]
materials = ["stalk", "steel"]
restitution = 0.52
static_friction = 0.45
rolling_friction = 0.24

[[interaction]]
materials = ["steel", "steel"]
restitution = 0.5
static_friction = 0.2
rolling_friction = 0.01

[[bond]]
materials = ["stalk", "stalk"]
normal_stiffness = 1e9
shear_stiffness = 1e9
critical_normal_stress = 2e5
critical_shear_stress = 1e6
bonded_disk_scale = 1.0
contact_radius_scale = 1.05
"#;

/// The bar's tension test: a 12 mm x 6 mm bar of 1 mm spheres pulled at 20 mm/s by 3 mm grips,
/// ending once the force has fallen to a fifth of its peak.
pub const BONDED_BAR_TENSION: &str = r#"[tension]
specimen = { material = "stalk", radius = 0.001, length = 0.012, diameter = 0.006 }
fixture_material = "steel"
speed = 0.02
max_displacement = 0.002
stop_force_fraction = 0.2
grip_length = 0.003
"#;

/// The bar's tension test file: `top` lines after `test = "tension"` (density_scaling, seed),
/// then the parts, then the tension table with `extra` lines added.
pub fn bonded_bar_tension(top: &str, extra: &str) -> String {
    format!(
        "test = \"tension\"\nseed = 1\n{top}\n{BONDED_BAR_PARTS}\n{BONDED_BAR_TENSION}{extra}\n"
    )
}

/// One `[[material]]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Material {
    pub name: &'static str,
    /// kg/m^3.
    pub density: f64,
    pub poisson_ratio: f64,
    /// Pa.
    pub shear_modulus: f64,
}

/// The coefficients of one `[[interaction]]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Interaction {
    pub restitution: f64,
    pub static_friction: f64,
    pub rolling_friction: f64,
}

/// A particle material, a wall material and their interactions: particle-particle and
/// particle-wall (wall-wall contacts never happen, so there is none).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Materials {
    /// Default: "grain", 1200 kg/m^3, Poisson ratio 0.3, shear modulus 1e7 Pa.
    pub particle: Material,
    /// Default: "steel", 7800 kg/m^3, Poisson ratio 0.3, shear modulus 7e10 Pa.
    pub wall: Material,
    /// Default: restitution 0.3, static friction 0.5, rolling friction 0.1.
    pub particle_particle: Interaction,
    /// Default: restitution 0.5, static friction 0.5, rolling friction 0.1.
    pub particle_wall: Interaction,
    /// Write the wall's `[[material]]` before the particle's. Material indices in error keys
    /// (`material[1]`) and the "(defined: ...)" lists follow the file's order, so a test that
    /// asserts them picks the order it was written with. Default: false.
    pub wall_first: bool,
}

impl Default for Materials {
    fn default() -> Self {
        Materials {
            particle: Material {
                name: "grain",
                density: 1200.0,
                poisson_ratio: 0.3,
                shear_modulus: 1e7,
            },
            wall: Material {
                name: "steel",
                density: 7800.0,
                poisson_ratio: 0.3,
                shear_modulus: 7e10,
            },
            particle_particle: Interaction {
                restitution: 0.3,
                static_friction: 0.5,
                rolling_friction: 0.1,
            },
            particle_wall: Interaction {
                restitution: 0.5,
                static_friction: 0.5,
                rolling_friction: 0.1,
            },
            wall_first: false,
        }
    }
}

impl Materials {
    /// The two `[[material]]` and two `[[interaction]]` blocks, separated by blank lines and
    /// ending in a newline. Plain numbers are written as Rust displays them (`0.3`, `7800`), the
    /// shear modulus in exponent form (`7e10`, `7.9e10`); TOML reads back the same `f64`.
    pub fn toml(&self) -> String {
        let (first, second) = if self.wall_first {
            (&self.wall, &self.particle)
        } else {
            (&self.particle, &self.wall)
        };
        let p = self.particle.name;
        let mut text = String::new();
        material(&mut text, first);
        text.push('\n');
        material(&mut text, second);
        text.push('\n');
        interaction(&mut text, [p, p], &self.particle_particle);
        text.push('\n');
        interaction(&mut text, [p, self.wall.name], &self.particle_wall);
        text
    }
}

fn material(text: &mut String, m: &Material) {
    // Writing to a String cannot fail.
    let _ = write!(
        text,
        "[[material]]\nname = \"{}\"\ndensity = {}\npoisson_ratio = {}\nshear_modulus = {:e}\n",
        m.name, m.density, m.poisson_ratio, m.shear_modulus
    );
}

fn interaction(text: &mut String, [a, b]: [&str; 2], i: &Interaction) {
    let _ = write!(
        text,
        "[[interaction]]\nmaterials = [\"{a}\", \"{b}\"]\nrestitution = {}\nstatic_friction = {}\nrolling_friction = {}\n",
        i.restitution, i.static_friction, i.rolling_friction
    );
}

/// A new, empty folder `demcal-<kind>-<name>-<process id>` in the system's temp folder (an old one
/// of the same name is removed first), for a test's study or scene files.
pub fn fresh_dir(kind: &str, name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("demcal-{kind}-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// The `report/summary.json` a study in `dir` wrote.
pub fn summary(dir: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(dir.join("report/summary.json")).unwrap())
        .unwrap()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_blocks_read_as_typed() {
        assert_eq!(
            Materials::default().toml(),
            r#"[[material]]
name = "grain"
density = 1200
poisson_ratio = 0.3
shear_modulus = 1e7

[[material]]
name = "steel"
density = 7800
poisson_ratio = 0.3
shear_modulus = 7e10

[[interaction]]
materials = ["grain", "grain"]
restitution = 0.3
static_friction = 0.5
rolling_friction = 0.1

[[interaction]]
materials = ["grain", "steel"]
restitution = 0.5
static_friction = 0.5
rolling_friction = 0.1
"#
        );
    }

    #[test]
    fn wall_first_swaps_only_the_materials() {
        let m = Materials {
            wall_first: true,
            ..Materials::default()
        };
        let text = m.toml();
        let steel = text.find("name = \"steel\"").unwrap();
        let grain = text.find("name = \"grain\"").unwrap();
        assert!(steel < grain);
        assert!(text.contains("materials = [\"grain\", \"steel\"]"));
    }

    #[test]
    fn exponents_and_fractions_are_written_as_typed() {
        let m = Materials {
            wall: Material {
                shear_modulus: 7.9e10,
                density: 7850.0,
                ..Materials::default().wall
            },
            ..Materials::default()
        };
        let text = m.toml();
        assert!(text.contains("shear_modulus = 7.9e10\n"), "{text}");
        assert!(text.contains("density = 7850\n"), "{text}");
    }
}

/// Hostile inputs for property tests: a good file's text with random edits, the way a typo, a
/// bad paste or a damaged copy changes it. Every parser must answer these with a result or a
/// one-line error, never a panic.
pub mod hostile {
    use proptest::prelude::*;
    use proptest::test_runner::{Config, RngSeed};

    /// The property tests' settings: `cases` cases from a fixed seed, so that `cargo test`
    /// gives the same verdict every time; `DEMCAL_FUZZ_CASES` and `DEMCAL_FUZZ_SEED` run more,
    /// from another seed (docs/reliability.md).
    pub fn config(cases: u32) -> Config {
        let env = |k: &str| std::env::var(k).ok().and_then(|v| v.parse::<u64>().ok());
        Config {
            cases: env("DEMCAL_FUZZ_CASES").map_or(cases, |c| c as u32),
            rng_seed: RngSeed::Fixed(env("DEMCAL_FUZZ_SEED").unwrap_or(40)),
            failure_persistence: None,
            ..Config::default()
        }
    }

    /// Pieces an edit inserts: the file formats' punctuation, numbers at f64's and u64's ends,
    /// non-ASCII and control characters.
    const PIECES: &[&str] = &[
        "",
        "\"",
        "'",
        "[",
        "]",
        "{",
        "}",
        "=",
        ",",
        ".",
        ":",
        "\n",
        "#",
        "[[",
        "]]",
        "nan",
        "inf",
        "-inf",
        "1e308",
        "-1e308",
        "1e-320",
        "-1",
        "0",
        "-0",
        "18446744073709551616",
        "9223372036854775807",
        "true",
        "\"\"",
        "é",
        "\u{0}",
        "\t",
        "1e400",
        "0x10",
        "_",
    ];

    /// `text` with one to three edits, each deleting up to 12 characters at a point and putting
    /// one of [`PIECES`] there.
    pub fn mutated(text: &'static str) -> impl Strategy<Value = String> {
        let edit = (
            any::<prop::sample::Index>(),
            0usize..12,
            prop::sample::select(PIECES),
        );
        prop::collection::vec(edit, 1..4).prop_map(move |edits| {
            let mut chars: Vec<char> = text.chars().collect();
            for (at, cut, piece) in edits {
                let i = at.index(chars.len() + 1);
                let end = (i + cut).min(chars.len());
                chars.splice(i..end, piece.chars());
            }
            chars.into_iter().collect()
        })
    }

    /// Numbers an edit puts in place of one of the file's: the ends of f64 and i64, zero, signs,
    /// and not-a-number.
    const NUMBERS: &[&str] = &[
        "0",
        "-0",
        "-1",
        "1e308",
        "-1e308",
        "1e-320",
        "nan",
        "inf",
        "-inf",
        "1e9",
        "1e12",
        "9223372036854775807",
        "-9223372036854775808",
        "1e-9",
        "0.5",
        "3",
    ];

    /// `text` with one of its numbers (a run of digits, with its sign, point and exponent)
    /// replaced by one of [`NUMBERS`]: a file that still parses, with a value at an extreme.
    pub fn number_swapped(text: &'static str) -> impl Strategy<Value = String> {
        let bytes = text.as_bytes();
        let mut spans = Vec::new();
        let mut i = 0;
        while i < bytes.len() {
            let starts = bytes[i].is_ascii_digit()
                && (i == 0 || matches!(bytes[i - 1], b' ' | b'=' | b'[' | b',' | b'-' | b'\n'));
            if starts {
                let begin = if i > 0 && bytes[i - 1] == b'-' {
                    i - 1
                } else {
                    i
                };
                let mut j = i;
                while j < bytes.len()
                    && (bytes[j].is_ascii_digit() || matches!(bytes[j], b'.' | b'e' | b'E' | b'_'))
                {
                    j += 1;
                }
                spans.push((begin, j));
                i = j;
            } else {
                i += 1;
            }
        }
        assert!(!spans.is_empty(), "a text without numbers");
        (prop::sample::select(spans), prop::sample::select(NUMBERS))
            .prop_map(move |((a, b), n)| format!("{}{n}{}", &text[..a], &text[b..]))
    }

    /// Either kind of edit.
    pub fn hostile(text: &'static str) -> impl Strategy<Value = String> {
        prop_oneof![mutated(text), number_swapped(text)]
    }
}
