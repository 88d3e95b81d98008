//! The mechanical tests of bonded specimens: a bar pulled apart breaks in tension at about the
//! strength of the bonds that cross it, the curve and the bond logs are written, and bad settings
//! are refused with the key named. (The bond model itself is checked against beam theory and exact
//! breakage in crates/dem/tests/bonds.rs, V7.)

use virtual_tests::{run_file, TestFile};

fn file(test: &str, table: &str) -> TestFile {
    TestFile::parse(
        "bar.toml",
        &format!(
            "test = \"{test}\"\nseed = 1\n{}\n[{test}]\n{table}",
            test_support::BONDED_BAR_PARTS
        ),
    )
    .unwrap()
}

#[test]
fn a_bonded_bar_pulled_apart_breaks_at_the_strength_of_its_bonds() {
    let f = file(
        "tension",
        r#"specimen = { material = "stalk", radius = 0.001, length = 0.012, diameter = 0.006 }
fixture_material = "steel"
speed = 0.05
max_displacement = 0.002
stop_force_fraction = 0.2
curve_points = 300
grip_length = 0.003
snapshots = 4
"#,
    );
    let out = std::env::temp_dir().join(format!("demcal-tension-{}", std::process::id()));
    let done = run_file(&f, None, Some(&out), &mut |_, _| Ok(())).unwrap();
    let (json, summary) = (done.json, done.summary);
    eprintln!("{summary}");
    let peak = json["peak_force_n"].as_f64().unwrap();
    let broken = json["bonds_broken"].as_u64().unwrap();
    let tension = json["bonds_broken_tension"].as_u64().unwrap();
    assert!(broken > 0 && tension * 2 > broken, "{summary}");
    // The bonds crossing the weakest section hold sigma_c A each at most (pi r^2 each here):
    // the peak lies below their sum and well above a small share of it.
    let per_bond = 2e5 * std::f64::consts::PI * 0.001f64.powi(2);
    assert!(
        peak > per_bond && peak < 40.0 * per_bond,
        "peak {peak} N, one bond {per_bond} N"
    );
    // The curve file holds the curve (header plus one row per sample) and ends after the drop.
    let csv = std::fs::read_to_string(json["curve_csv"].as_str().unwrap()).unwrap();
    let rows: Vec<(f64, f64)> = csv
        .lines()
        .skip(1)
        .map(|l| {
            let mut it = l.split(',').map(|v| v.parse::<f64>().unwrap());
            (it.next().unwrap(), it.next().unwrap())
        })
        .collect();
    assert!(rows.len() > 10);
    assert_eq!(rows[0].0, 0.0);
    let max = rows.iter().map(|r| r.1).fold(0.0, f64::max);
    assert!((max - peak).abs() <= 1e-9 * peak);
    assert!(rows.last().unwrap().1 < 0.2 * peak);
    // The breakage log has one row per broken bond.
    let log = std::fs::read_to_string(out.join("bond_breakage.csv")).unwrap();
    assert_eq!(log.lines().count() as u64, broken + 1);
    assert!(out.join("force_displacement.svg").exists());
    // The snapshots for ParaView: particles and bonds at the same times, bonds as lines that
    // say which are intact.
    let listed = |name: &str| {
        let pvd = std::fs::read_to_string(out.join(name)).unwrap();
        pvd.lines()
            .filter(|l| l.contains("<DataSet"))
            .map(|l| {
                l.split("timestep=\"")
                    .nth(1)
                    .unwrap()
                    .split('"')
                    .next()
                    .unwrap()
                    .to_string()
            })
            .collect::<Vec<_>>()
    };
    let times = listed("particles.pvd");
    // The bar breaks (and the test stops) before a quarter of the travel: two snapshots.
    assert!(times.len() >= 2, "{times:?}");
    assert_eq!(listed("bonds.pvd"), times);
    let bonds = std::fs::read(out.join("bonds_00000000.vtp")).unwrap();
    let header = String::from_utf8_lossy(&bonds[..bonds.len().min(4000)]);
    assert!(header.contains("Name=\"intact\""), "{header}");
    assert!(!header.contains("NumberOfLines=\"0\""), "{header}");
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn bad_mechanical_settings_are_refused_with_the_key() {
    let cases = [
        (
            "bending",
            "span = 0.02\n",
            "bending.span: 0.02 m is not shorter than the specimen",
        ),
        (
            "compression",
            "span = 0.005\n",
            "compression.span: not used by the compression test",
        ),
        (
            "shear",
            "blade_thickness = 0.002\nslot_width = 0.001\n",
            "shear.blade_thickness: the blade",
        ),
        (
            "bending",
            "span = 0.005\nclamped = false\n",
            "bending.clamped: not used by the bending test",
        ),
        (
            "tension",
            "grip_length = 0.006\n",
            "tension.grip_length: two grips",
        ),
        (
            "compression",
            "speed = -1\n",
            "compression.speed: expected a positive number",
        ),
    ];
    for (test, extra, expected) in cases {
        let speed = if extra.contains("speed") {
            ""
        } else {
            "speed = 0.01\n"
        };
        let f = file(
            test,
            &format!(
                "specimen = {{ material = \"stalk\", radius = 0.001, length = 0.01, diameter = 0.004 }}\nfixture_material = \"steel\"\nmax_displacement = 0.001\n{speed}{extra}"
            ),
        );
        let e = run_file(&f, None, None, &mut |_, _| Ok(())).unwrap_err();
        assert!(e.message().contains(expected), "{test}: {}", e.message());
        assert!(e.message().starts_with("bar.toml: "), "{}", e.message());
    }
    let f = file(
        "compression",
        "specimen = { material = \"wood\", radius = 0.001, length = 0.01, diameter = 0.004 }\nfixture_material = \"steel\"\nspeed = 0.01\nmax_displacement = 0.001\n",
    );
    let e = run_file(&f, None, None, &mut |_, _| Ok(())).unwrap_err();
    assert!(
        e.message().contains("compression.specimen.material"),
        "{}",
        e.message()
    );
}

/// Pulled a hundred times faster than in the breakage test, the bar's inertia shows: the
/// quasi-static check warns, and at the slow speed it does not.
#[test]
fn fast_loading_is_flagged_as_not_quasi_static() {
    let ratio = |speed: f64| {
        let f = file(
            "tension",
            &format!(
                r#"specimen = {{ material = "stalk", radius = 0.001, length = 0.012, diameter = 0.006 }}
fixture_material = "steel"
speed = {speed}
max_displacement = 0.0005
grip_length = 0.003
"#
            ),
        );
        let done = run_file(&f, None, None, &mut |_, _| Ok(())).unwrap();
        let warned = done.json["warnings"]
            .as_array()
            .unwrap()
            .iter()
            .any(|w| w.as_str().unwrap().contains("not quasi-static"));
        (done.json["kinetic_to_work_ratio"].as_f64().unwrap(), warned)
    };
    let (slow, slow_warned) = ratio(0.02);
    let (fast, fast_warned) = ratio(2.0);
    eprintln!("kinetic/work: {slow:.3e} at 0.02 m/s, {fast:.3e} at 2 m/s");
    assert!(slow < 0.05 && !slow_warned, "{slow}");
    assert!(fast > 0.05 && fast_warned, "{fast}");
}
