//! `demcal curve compare`: a simulated curve against lab replicates with a known MSE under each
//! normalisation, and one-line errors for wrong flags.

use std::process::Command;

fn demcal(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_demcal"))
        .args(args)
        .output()
        .unwrap()
}

/// A simulated force rising to 100 N over 1 mm (written as `demcal test` writes it, the first point twice);
/// lab replicates reaching 110 and 130 N at 1 mm (in millimetres): their mean reaches 120 N.
#[test]
fn compare_scores_as_a_study_under_each_normalisation() {
    let dir = std::env::temp_dir().join(format!("demcal-curve-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let sim = dir.join("force_displacement.csv");
    std::fs::write(
        &sim,
        "displacement_m,force_n\n0e0,0e0\n0e0,0e0\n5e-4,50\n1e-3,100\n",
    )
    .unwrap();
    let lab = dir.join("lab.csv");
    std::fs::write(&lab, "displacement_mm,r1,r2\n0,0,0\n1,110,130\n").unwrap();
    let (s, l) = (sim.to_str().unwrap(), lab.to_str().unwrap());
    // The grid: 1000 points on 0..1 mm; mean of (i / 999)^2 is 1999 / 5994.
    let grid = 1999.0 / 5994.0;
    for (args, expected) in [
        // lab_peak: (100 - 120) / 120 = -1/6 at the end of the range.
        (vec![], grid / 36.0),
        (vec!["--normalisation", "none"], 400.0 * grid),
        // stress_strain: forces over 1e-4 m^2 in MPa: 20 N -> 0.2 MPa.
        (
            vec![
                "--normalisation",
                "stress_strain",
                "--area-m2",
                "1e-4",
                "--length-m",
                "0.01",
            ],
            0.04 * grid,
        ),
    ] {
        let mut all = vec!["curve", "compare", s, l, "--json"];
        all.extend(args.iter().copied());
        let out = demcal(&all);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let j: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        let mse = j["curve_mse"].as_f64().unwrap();
        assert!(
            (mse / expected - 1.0).abs() < 1e-9,
            "{args:?}: {mse} against {expected}"
        );
        assert_eq!(j["replicates"], 2);
        assert!((j["lab_peak_n"].as_f64().unwrap() - 120.0).abs() < 1e-9);
    }
    // Text: the MSE and the side-by-side table.
    let out = demcal(&["curve", "compare", s, l]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.contains("curve_mse = ") && text.contains("2 replicates"),
        "{text}"
    );

    for (args, says) in [
        (
            vec!["--area-m2", "1e-4"],
            "are for --normalisation stress_strain",
        ),
        (
            vec!["--normalisation", "stress_strain", "--area-m2", "1e-4"],
            "needs --length-m",
        ),
        (
            vec![
                "--normalisation",
                "stress_strain",
                "--area-m2",
                "-1",
                "--length-m",
                "1",
            ],
            "--area-m2 -1: expected a positive number",
        ),
    ] {
        let mut all = vec!["curve", "compare", s, l];
        all.extend(args.iter().copied());
        let out = demcal(&all);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            !out.status.success() && err.contains(says),
            "{args:?}: {err}"
        );
        assert_eq!(err.trim().lines().count(), 1, "{err}");
    }
    let missing = dir.join("missing.csv");
    let out = demcal(&["curve", "compare", missing.to_str().unwrap(), l]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("missing.csv") && err.contains("cannot read"),
        "{err}"
    );
}
