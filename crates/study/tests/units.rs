//! Units in study and test files: a test written with units reads as the same test in SI
//! numbers, a parameter's range may carry a unit (its values then reach the test in the
//! dimension's base unit, so the test's reader checks the key's dimension), and a range whose
//! unit does not fit the key is refused when the study is read.

use std::path::Path;
use study::Study;

const STUDY: &str = r#"
name = "units"
seed = 1
test = "repose.toml"
plan = ["screening"]

[[parameter]]
name = "bead_modulus"
path = "material[bead].shear_modulus"
min = MIN
max = MAX

[[parameter]]
name = "static_friction"
path = "interaction[bead,bead].static_friction"
min = 0.2
max = 0.8

[target]
response = "angle_of_repose_deg"
value = 18.5
unit = "deg"
"#;

fn folder(with_units: bool) -> std::path::PathBuf {
    use std::sync::atomic::{AtomicUsize, Ordering};
    static N: AtomicUsize = AtomicUsize::new(0);
    let dir = std::env::temp_dir().join(format!(
        "demcal-units-{}-{}",
        std::process::id(),
        N.fetch_add(1, Ordering::Relaxed)
    ));
    std::fs::create_dir_all(&dir).unwrap();
    let test = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/quickstart/repose.toml"),
    )
    .unwrap();
    let test = if with_units {
        let mut t = test;
        for (from, to) in [
            ("density = 1500", "density = \"1.5 g/cm3\""),
            ("shear_modulus = 5.0e6", "shear_modulus = \"5 MPa\""),
            ("cylinder_diameter = 0.045", "cylinder_diameter = \"45 mm\""),
            ("cylinder_height = 0.09", "cylinder_height = \"9 cm\""),
            ("radius = 0.0025", "radius = \"2.5 mm\""),
            ("lift_speed = 0.1", "lift_speed = \"100 mm/s\""),
        ] {
            assert_eq!(t.matches(from).count(), 1, "{from}");
            t = t.replacen(from, to, 1);
        }
        t
    } else {
        test
    };
    std::fs::write(dir.join("repose.toml"), test).unwrap();
    dir
}

fn study(dir: &Path, min: &str, max: &str) -> Result<Study, String> {
    let text = STUDY.replace("MIN", min).replace("MAX", max);
    Study::parse(&dir.join("study.toml"), &text)
}

#[test]
fn a_test_with_units_is_the_same_test_in_si() {
    let si = folder(false);
    let units = folder(true);
    let a = study(&si, "1e6", "1e7").unwrap();
    let b = study(&units, "1e6", "1e7").unwrap();
    let values = [2e6, 0.5];
    let load = |s: &Study| {
        let t =
            virtual_tests::TestFile::from_table("repose.toml", &s.test_with(0, &values)).unwrap();
        let mut settings: virtual_tests::angle_of_repose::Settings = t.settings().unwrap();
        let particles = dem::scene::parse::group_particles(
            std::mem::replace(&mut settings.particles, toml::Value::Boolean(false)),
            "repose.toml",
            "angle_of_repose.particles",
            std::path::Path::new("."),
        )
        .unwrap();
        (
            format!("{:?}", t.parts),
            format!("{settings:?}"),
            format!("{particles:?}"),
        )
    };
    assert_eq!(load(&a), load(&b));
}

#[test]
fn a_range_with_a_unit_reaches_the_test_in_the_base_unit() {
    let dir = folder(true);
    let s = study(&dir, "\"1 MPa\"", "\"10 MPa\"").unwrap();
    assert_eq!((s.parameters[0].min, s.parameters[0].max), (1e6, 1e7));
    let t = s.test_with(0, &[2.5e6, 0.5]);
    let written = t["material"].as_array().unwrap()[0]["shear_modulus"].clone();
    assert_eq!(written, toml::Value::String("2.5e6 Pa".into()));
    let file = virtual_tests::TestFile::from_table("repose.toml", &t).unwrap();
    assert_eq!(
        format!("{:?}", file.parts.materials[0].stiffness),
        "ShearModulus(2500000.0)"
    );
}

#[test]
fn a_range_whose_unit_does_not_fit_is_refused_in_one_line() {
    let dir = folder(true);
    let e = study(&dir, "\"1 MPa\"", "1e7").err().unwrap();
    assert!(
        e.contains("parameter[0].max: min is a stress or modulus (Pa) but max is a plain number"),
        "{e}"
    );
    let e = study(&dir, "\"1 mm\"", "\"10 mm\"").err().unwrap();
    assert!(!e.contains('\n'), "{e}");
    assert!(
        e.contains("parameter[0].min: bead_modulus is given in units of a length (m), which \"material[bead].shear_modulus\" does not take: material[0].shear_modulus: \"5.5e-3 m\" is a length (m), expected a stress"),
        "{e}"
    );
    let text = STUDY
        .replace("MIN", "\"1 MPa\"")
        .replace("MAX", "\"10 MPa\"\nunit = \"MPa\"");
    let e = Study::parse(&dir.join("study.toml"), &text).err().unwrap();
    assert!(
        e.contains("parameter[0].unit: min and max are given with units, so the values are kept and shown in Pa"),
        "{e}"
    );
    let e = study(&dir, "\"1 furlong\"", "\"10 MPa\"").err().unwrap();
    assert!(
        e.contains("parameter[0].min: \"1 furlong\": unknown unit"),
        "{e}"
    );
}
