//! `demcal surrogate fit` and `demcal surrogate optimize` on the published silage repose CCD
//! (23 runs, coded D, E, G; lab angle 38.65 deg): the JSON keys the issue promises, the network's
//! test R^2, GA-BP-GA on the lab value, and one-line errors for bad input.

use std::path::PathBuf;
use std::process::Command;

const CCD: &str = include_str!("../../doe/tests/data/silage-repose-ccd.csv");

fn ccd_file(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("demcal-surrogate-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join(name);
    std::fs::write(&p, CCD).unwrap();
    p
}

fn demcal(args: &[&str]) -> (bool, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_demcal"))
        .args(args)
        .output()
        .unwrap();
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

fn json(args: &[&str]) -> serde_json::Value {
    let (ok, out, err) = demcal(args);
    assert!(ok, "{err}");
    serde_json::from_str(&out).unwrap_or_else(|e| panic!("{e}: {out}"))
}

#[test]
fn fit_prints_the_metrics_of_each_model() {
    let p = ccd_file("fit.csv");
    let p = p.to_str().unwrap();
    for model in ["gp", "bp", "ga-bp"] {
        let j = json(&[
            "surrogate",
            "fit",
            p,
            "--response",
            "angle_deg",
            "--factors",
            "D,E,G",
            "--model",
            model,
            "--json",
        ]);
        for key in ["r2_train", "r2_test", "rmse_test", "mae_test", "r2_all"] {
            assert!(j[key].as_f64().is_some(), "{model}: no {key} in {j}");
        }
        let n_validation = j["n_validation"].as_u64().unwrap_or(0);
        assert_eq!(
            j["n_train"].as_u64().unwrap() + n_validation + j["n_test"].as_u64().unwrap(),
            23
        );
        // A network stops early on validation rows; a GP has none.
        assert_eq!(n_validation > 0, model != "gp", "{model}: {j}");
        assert!(j["r2_all"].as_f64().unwrap() > 0.7, "{model}: {j}");
    }
}

#[test]
fn ga_bp_ga_finds_inputs_that_hit_the_lab_angle() {
    let p = ccd_file("opt.csv");
    let j = json(&[
        "surrogate",
        "optimize",
        p.to_str().unwrap(),
        "--response",
        "angle_deg",
        "--factors",
        "D,E,G",
        "--model",
        "ga-bp",
        "--goal",
        "target=38.65",
        "--json",
    ]);
    let predicted = j["predicted"].as_f64().unwrap();
    assert!((predicted - 38.65).abs() < 0.01, "{j}");
    for f in ["D", "E", "G"] {
        let v = j["solution"][f].as_f64().unwrap();
        assert!(v.abs() <= 1.68179 + 1e-9, "{f} = {v} outside the design");
    }
    // A GP searched for the lowest angle lands where the published model's is (all low).
    let j = json(&[
        "surrogate",
        "optimize",
        p.to_str().unwrap(),
        "--response",
        "angle_deg",
        "--model",
        "gp",
        "--goal",
        "minimize",
        "--json",
    ]);
    assert!(j["predicted"].as_f64().unwrap() < 33.0, "{j}");
    assert!(j["solution"]["D"].as_f64().unwrap() < -0.5, "{j}");
    assert!(j["solution"]["G"].as_f64().unwrap() < -0.5, "{j}");
}

#[test]
fn bad_input_is_one_line_naming_what_was_expected() {
    let p = ccd_file("bad.csv");
    let p = p.to_str().unwrap();
    let cases: &[(&[&str], &str)] = &[
        (
            &["--response", "angle", "--model", "gp"],
            "column 'angle' not found",
        ),
        (
            &["--response", "angle_deg", "--model", "svm"],
            "expected gp, bp or ga-bp",
        ),
        (
            &["--response", "angle_deg", "--model", "bp", "--kernel", "se"],
            "only a GP",
        ),
        (
            &[
                "--response",
                "angle_deg",
                "--model",
                "gp",
                "--factors",
                "D,angle_deg",
            ],
            "cannot be the response",
        ),
        (
            &[
                "--response",
                "angle_deg",
                "--model",
                "gp",
                "--train-fraction",
                "1.5",
            ],
            "between 0 and 1",
        ),
    ];
    for (args, expected) in cases {
        let mut all = vec!["surrogate", "fit", p];
        all.extend_from_slice(args);
        let (ok, _, err) = demcal(&all);
        assert!(!ok, "{args:?} should fail");
        assert!(err.contains(expected), "{args:?}: {err}");
        assert_eq!(err.trim().lines().count(), 1, "{err}");
    }
    let (ok, _, err) = demcal(&[
        "surrogate",
        "optimize",
        p,
        "--response",
        "angle_deg",
        "--model",
        "gp",
        "--goal",
        "target=abc",
    ]);
    assert!(!ok && err.contains("expected target=VALUE"), "{err}");
}

/// A constant response is refused as `doe analyze` refuses it, rather than fitted (issue 40).
#[test]
fn a_constant_response_is_refused() {
    let p = ccd_file("const.csv");
    let mut text = String::from("a,b,y\n");
    for i in 0..10 {
        text += &format!("{},{},5.0\n", i % 3, i % 4);
    }
    std::fs::write(&p, text).unwrap();
    for model in ["gp", "bp"] {
        let (ok, _, err) = demcal(&[
            "surrogate",
            "fit",
            p.to_str().unwrap(),
            "--response",
            "y",
            "--model",
            model,
        ]);
        assert!(!ok, "{model}");
        assert!(
            err.contains("the response is 5 in all 10 rows; there is nothing to model"),
            "{model}: {err}"
        );
    }
}
