//! The heap measurement's guards (`virtual_tests::repose`): a heap too small to have flanks fails
//! with its reason instead of giving a number, and a good heap measures what it did before the
//! guards.
//!
//! The two heaps in `tests/data` are the quickstart's test (`examples/quickstart/repose.toml`,
//! 5 mm beads) run at seed 1 with 100 and with 500 beads, written as x, y, z, radius to 0.1 um:
//! fixed files, so that these numbers do not move with the engine.

use virtual_tests::repose::{measure, parse_spheres, ReposeMeasurement};
use virtual_tests::{run_file, TestError, TestFile};

fn heap(name: &str) -> (Vec<glam::DVec3>, Vec<f64>) {
    let path = format!("{}/tests/data/{name}", env!("CARGO_MANIFEST_DIR"));
    parse_spheres(&path, &std::fs::read_to_string(&path).unwrap()).unwrap()
}

/// Before the guards this heap (2.6 beads high) measured 4.80 +- 7.43 deg, a flank at
/// -5.86 deg averaged in and the heap radius NaN.
#[test]
fn a_100_bead_heap_is_refused_naming_the_flank_that_rises() {
    let (p, r) = heap("heap_100_beads.csv");
    let e = measure(&p, &r, &ReposeMeasurement::default()).unwrap_err();
    eprintln!("{e}");
    assert!(
        e.starts_with(
            "repose measurement: 1 of 8 flanks do not fall away from the axis between 15 % and 85 % of the heap height (plane 0 deg, side -1: -5.86 deg)"
        ),
        "{e}"
    );
    assert!(
        e.contains("a heap 2.6 particle diameters high is too low or too small to show its slope: use more particles"),
        "{e}"
    );
    assert_eq!(e.lines().count(), 1);
    // With more planes the same heap has planes with too few points in the band.
    let twelve = ReposeMeasurement {
        planes: 12,
        ..Default::default()
    };
    let e = measure(&p, &r, &twelve).unwrap_err();
    assert!(e.starts_with("repose measurement: "), "{e}");
}

/// The quickstart's heap of 500 beads measures to 1e-9 what it measured before the guards.
#[test]
fn a_good_heap_measures_the_same_as_before() {
    let (p, r) = heap("heap_500_beads.csv");
    for (planes, angle, spread, radius) in [
        (
            4,
            16.049024336134366,
            3.667157389095055,
            0.06346726603297587,
        ),
        (
            12,
            15.996805146853587,
            3.469386888791822,
            0.06320675889725795,
        ),
    ] {
        let m = ReposeMeasurement {
            planes,
            ..Default::default()
        };
        let res = measure(&p, &r, &m).unwrap();
        eprintln!(
            "{planes} planes: {} +- {} deg, radius {} m",
            res.angle_deg, res.angle_std_deg, res.heap_radius
        );
        assert!((res.angle_deg - angle).abs() < 1e-9, "{}", res.angle_deg);
        assert!((res.angle_std_deg - spread).abs() < 1e-9);
        assert!((res.heap_radius - radius).abs() < 1e-9);
        assert!((res.heap_height - 0.0209439).abs() < 1e-9);
        assert_eq!(res.flanks.len(), 2 * planes);
    }
}

/// A particle that is not finite is named, not measured as a NaN angle.
#[test]
fn a_particle_that_is_not_finite_is_refused() {
    let (mut p, r) = heap("heap_500_beads.csv");
    p[7].z = f64::NAN;
    let e = measure(&p, &r, &ReposeMeasurement::default()).unwrap_err();
    assert_eq!(
        e,
        "repose measurement: particle 8: its position or size is not a finite number"
    );
}

/// The lifted-cylinder test with the quickstart's file at 100 beads: the run fails as a
/// measurement (what a study stores as `measurement_failed`, with this message), whatever the
/// reason the tiny heap gives.
#[test]
fn the_quickstart_test_with_100_beads_fails_its_measurement() {
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../examples/quickstart/repose.toml"
    ))
    .unwrap()
    .replace("fill = { count = 500 }", "fill = { count = 100 }");
    let f = TestFile::parse("repose.toml", &text).unwrap();
    for seed in [1, 2] {
        match run_file(&f, Some(seed), None, &mut |_, _| Ok(())) {
            Err(TestError::Measurement(e)) => {
                eprintln!("seed {seed}: {e}");
                assert!(e.starts_with("repose.toml: repose measurement: "), "{e}");
                assert_eq!(e.lines().count(), 1);
            }
            Err(e) => panic!("seed {seed}: failed otherwise: {e}"),
            Ok(done) => panic!("seed {seed}: measured {}", done.summary),
        }
    }
}
