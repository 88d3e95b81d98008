//! `demcal surrogate optimize --target-of RESPONSE --value LAB` (issue 41): minimising a relative
//! error through a model of its response; and the two flags needing each other.

use std::process::Command;

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

/// x on 0 .. 1, the response r = 30 + 20 x and its error in % against the lab value 38, whose
/// point is at x = 0.4.
fn table() -> String {
    let dir =
        std::env::temp_dir().join(format!("demcal-surrogate-error-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let mut csv = String::from("x,r,error_percent\n");
    for i in 0..=20 {
        let x = i as f64 / 20.0;
        let r = 30.0 + 20.0 * x;
        csv.push_str(&format!("{x},{r},{}\n", 100.0 * (r - 38.0).abs() / 38.0));
    }
    let p = dir.join("v.csv");
    std::fs::write(&p, csv).unwrap();
    p.display().to_string()
}

#[test]
fn target_of_models_the_response_and_reports_the_error_from_it() {
    let p = table();
    let base = [
        "surrogate",
        "optimize",
        p.as_str(),
        "--response",
        "error_percent",
        "--model",
        "gp",
        "--goal",
        "minimize",
    ];
    let mut args = base.to_vec();
    args.extend(["--target-of", "r", "--value", "38", "--json"]);
    let (ok, out, err) = demcal(&args);
    assert!(ok, "{err}");
    let j: serde_json::Value = serde_json::from_str(&out).unwrap();
    let x = j["solution"]["x"].as_f64().unwrap();
    assert!((x - 0.4).abs() < 0.005, "{j}");
    let e = j["predicted"].as_f64().unwrap();
    assert!((0.0..0.01).contains(&e), "error {e} % in {j}");
    assert_eq!(j["error_formula"], "|r - 38| / 38 x 100");
    assert!((j["predicted_response"].as_f64().unwrap() - 38.0).abs() < 1e-3);
    // Each flag needs the other.
    let mut half = base.to_vec();
    half.extend(["--target-of", "r"]);
    let (ok, _, err) = demcal(&half);
    assert!(!ok && err.contains("--value <LAB>"), "{err}");
    let mut half = base.to_vec();
    half.extend(["--value", "38"]);
    let (ok, _, err) = demcal(&half);
    assert!(!ok && err.contains("--target-of <RESPONSE>"), "{err}");
    let (_, help, _) = demcal(&["surrogate", "optimize", "--help"]);
    assert!(help.contains("--target-of <RESPONSE>") && help.contains("never predicted below 0"));
    let _ = std::fs::remove_dir_all(std::path::Path::new(&p).parent().unwrap());
}
