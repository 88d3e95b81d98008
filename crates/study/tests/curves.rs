//! Curve targets on the `function` test's force-displacement curve: a whole plan minimising the
//! MSE against lab curves made at known parameters recovers them; runs whose curve misses the
//! lab's fail as measurements; changed lab curves are noticed; bad curve keys name the key.

use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

use study::Study;

mod common;
use common::{run_path, write_study};

/// The curve is linear in k and q, so the MSE is a quadratic bowl in them with its minimum at
/// the lab's k = 5000 N/m, q = 2e5 N/m², which lie off the ranges' centres. d changes nothing
/// (a parameter that does not matter), so screening drops it.
const STUDY: &str = r#"
name = "curve"
seed = 5
# A full factorial: in a Plackett-Burman design the large k x q interaction of an MSE valley
# would be aliased into d's main effect.
plan = [{ stage = "screening", design = "factorial" }, "steepest", "rsm", "optimize", "validate"]

[test]
test = "function"
[test.function]
expression = "0"
variables = { k = 6000, q = 2.5e5, d = 0.5 }
noise = 0.1
curve = { expression = "k*x - q*x^2", x_max = 0.01, points = 101 }

[[parameter]]
name = "k"
path = "function.variables.k"
min = 4000
max = 8000

[[parameter]]
name = "q"
path = "function.variables.q"
min = 1e5
max = 4e5

[[parameter]]
name = "d"
path = "function.variables.d"
min = 0
max = 1

[target]
curve = "force_displacement"
lab_curves = ["lab/a.csv", "lab/b.csv"]
normalisation = "lab_peak"
"#;

/// The lab force at x (m) for k = 5000, q = 2e5.
fn lab_force(x: f64) -> f64 {
    5000.0 * x - 2e5 * x * x
}

fn fresh_dir(name: &str) -> PathBuf {
    let dir = test_support::fresh_dir("curves", name);
    std::fs::create_dir_all(dir.join("lab")).unwrap();
    dir
}

/// Two replicates 2 % above and below the lab force in one file (mm), a third exactly on it
/// over a shorter range in another (m): their mean is the lab force over 0.5 .. 9.5 mm.
fn write_lab(dir: &Path, shift_mm: f64) {
    let mut a = String::from("displacement_mm,force_1_n,force_2_n\n");
    for i in 0..=50 {
        let mm = 0.2 * i as f64 + shift_mm;
        let f = lab_force(mm * 1e-3);
        a.push_str(&format!("{mm},{},{}\n", 1.02 * f, 0.98 * f));
    }
    let mut b = String::from("displacement_m,force_n\n");
    for i in 0..=90 {
        let m = (0.5 + 0.1 * i as f64 + shift_mm) * 1e-3;
        b.push_str(&format!("{m},{}\n", lab_force(m)));
    }
    std::fs::write(dir.join("lab/a.csv"), a).unwrap();
    std::fs::write(dir.join("lab/b.csv"), b).unwrap();
}

#[test]
fn minimising_the_curve_mse_recovers_the_lab_parameters() {
    let dir = fresh_dir("plan");
    write_lab(&dir, 0.0);
    let path = write_study(&dir, STUDY);
    let s = Study::load(&path).unwrap();
    assert_eq!(s.target.response, "curve_mse");
    assert!(s.target.minimised());
    assert_eq!(s.target.relative_error_percent(0.1), None);
    let lab = &s.target.curve.as_ref().unwrap().lab;
    assert_eq!(lab.replicates.len(), 3);
    assert_eq!(lab.mean.range(), (0.0005, 0.0095));
    let out = run_path(&path, 2).unwrap();
    assert!(out.contains("state: complete"), "{out}");
    assert!(out.contains("calibrated by minimising curve_mse"), "{out}");
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("report/summary.json")).unwrap())
            .unwrap();
    let cal = &summary["calibrated"];
    let (k, q) = (cal["k"].as_f64().unwrap(), cal["q"].as_f64().unwrap());
    assert!(
        (k - 5000.0).abs() < 0.01 * 5000.0 && (q - 2e5).abs() < 0.02 * 2e5,
        "k = {k}, q = {q}"
    );
    assert_eq!(
        summary["stages"][0]["selected"],
        serde_json::json!(["k", "q"])
    );
    assert_eq!(summary["relative_error_percent"], serde_json::Value::Null);
    assert_eq!(summary["target"]["minimised"], true);
    // The noise alone (0.1 N against a peak near 30 N) gives an MSE about 1e-5; the validation
    // runs at the calibrated point come near it.
    let mse = summary["validation_mean"].as_f64().unwrap();
    assert!(mse < 2e-4, "validation MSE {mse}");
    let csv = std::fs::read_to_string(dir.join("report/results.csv")).unwrap();
    assert!(csv.lines().next().unwrap().contains(",curve_mse,"));
    let html = std::fs::read_to_string(dir.join("report/index.html")).unwrap();
    for part in [
        "\">Curves</h2>",
        "Lab and simulated curves",
        "lab band (replicates",
        "smallest MSE",
        "validation run 1",
        "lab_peak: forces divided by the peak of the lab",
        "force / lab peak (-)",
        "displacement (m)",
        "minimised",
    ] {
        assert!(html.contains(part), "report lacks {part}");
    }
    let status = study::status(&path).unwrap();
    assert!(
        status.contains("best run so far") && !status.contains("relative error"),
        "{status}"
    );

    // A job carries the lab curve, reads back from its JSON and gives the stored record's
    // response on its own (what `demcal run-one` does on another machine).
    let stored = study::Store::open(&s.store_path(), false)
        .unwrap()
        .runs()
        .unwrap();
    let replay = study::replay(&s, &stored, None).unwrap();
    let (spec, rec) = (
        &replay.stages[0].runs[0],
        replay.stages[0].records[0].as_ref().unwrap(),
    );
    let job = study::Job::new(&s, spec);
    assert!(job.tests[0].curve.is_some());
    let job_path = dir.join("job.json");
    std::fs::write(&job_path, job.to_json()).unwrap();
    let back = study::Job::load(&job_path).unwrap();
    assert_eq!(back, job);
    let again = back.execute(&AtomicBool::new(false), &|_, _| {}).unwrap();
    assert_eq!(again.response, rec.response);
    assert_eq!(again.fingerprint, rec.fingerprint);
    assert!(
        again.outputs["curve_simulated"]["x"]
            .as_array()
            .unwrap()
            .len()
            == 101
    );

    // Changed lab curves make the stored comparisons stale, and the message says so.
    write_lab(&dir, 0.1);
    let e = study::status(&path).unwrap_err();
    assert!(e.contains("compared with other lab curves"), "{e}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_derived_measure_is_matched_against_the_lab_replicates() {
    // curve_peak: the lab value is the mean of the replicates' normalised peaks.
    let dir = fresh_dir("peak");
    write_lab(&dir, 0.0);
    let text = STUDY
        .replace("normalisation = \"lab_peak\"", "normalisation = \"none\"\nresponse = \"curve_peak\"")
        .replace(
            "plan = [{ stage = \"screening\", design = \"factorial\" }, \"steepest\", \"rsm\", \"optimize\", \"validate\"]",
            "plan = [\"validate\"]",
        );
    let path = write_study(&dir, &text);
    let s = Study::load(&path).unwrap();
    assert_eq!(s.target.unit, "N");
    assert_eq!(s.target.replicates.len(), 3);
    let peak = lab_force(0.01);
    let want = (1.02 * peak + 0.98 * peak + lab_force(0.0095)) / 3.0;
    assert!(
        (s.target.value - want).abs() < 1e-9,
        "{} vs {want}",
        s.target.value
    );
    run_path(&path, 2).unwrap();
    // At the middle values (k = 6000, q = 2.5e5) the peak is 60 - 25 N.
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("report/summary.json")).unwrap())
            .unwrap();
    let mean = summary["validation_mean"].as_f64().unwrap();
    assert!((mean - 35.0).abs() < 0.4, "{mean}");
    assert!(summary["relative_error_percent"].as_f64().is_some());
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_curve_that_misses_the_lab_range_fails_as_a_measurement() {
    let dir = fresh_dir("miss");
    write_lab(&dir, 20.0);
    let text = STUDY.replace(
        "plan = [{ stage = \"screening\", design = \"factorial\" }, \"steepest\", \"rsm\", \"optimize\", \"validate\"]",
        "plan = [{ stage = \"validate\", replicates = 1 }]",
    );
    let path = write_study(&dir, &text);
    let e = run_path(&path, 2).unwrap_err();
    assert!(e.contains("validation needs at least 1"), "{e}");
    let csv = std::fs::read_to_string(dir.join("report/results.csv")).unwrap();
    assert!(csv.contains("measurement_failed"), "{csv}");
    assert!(csv.contains("do not overlap"), "{csv}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn bad_curve_targets_name_the_key() {
    let dir = fresh_dir("bad");
    write_lab(&dir, 0.0);
    let path = dir.join("study.toml");
    let cases = [
        (
            STUDY.replace("curve = \"force_displacement\"", "curve = \"torque_angle\""),
            "target.curve: \"torque_angle\" is not a response of function",
        ),
        (
            STUDY.replace("normalisation = \"lab_peak\"", "normalisation = \"lab_peak\"\nvalue = 0.1"),
            "target.value: curve_mse is minimised (its target is 0): give no value",
        ),
        (
            STUDY.replace("normalisation = \"lab_peak\"", "normalisation = \"stress_strain\"\narea_m2 = 1e-4"),
            "target.length_m: missing",
        ),
        (
            STUDY.replace("\"lab/b.csv\"", "\"lab/c.csv\""),
            "lab/c.csv: cannot read",
        ),
        (
            STUDY.replace("normalisation = \"lab_peak\"", "normalisation = \"lab_peak\"\nresponse = \"curve_area\""),
            "target.response: \"curve_area\" is not an outcome of function (expected one of: value, exact, force_displacement, curve_mse, curve_peak",
        ),
        (
            STUDY
                .replace("curve = \"force_displacement\"\n", "")
                .replace("lab_curves = [\"lab/a.csv\", \"lab/b.csv\"]\nnormalisation = \"lab_peak\"", "response = \"curve_mse\""),
            "target.response: curve_mse compares the test's curve with the lab's",
        ),
    ];
    for (text, want) in cases {
        let e = Study::parse(&path, &text).unwrap_err();
        assert!(e.contains(want), "{e}\nwanted: {want}");
        assert_eq!(e.lines().count(), 1, "{e}");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The twin experiment of examples/stalks/twin (issue 12): a small bonded stalk's shear curve,
/// simulated at known bonds and noised, is calibrated by screening, steepest path, CCD and
/// optimisation, end to end from the files as committed. About two minutes on 2 cores.
#[test]
fn the_twin_stalk_study_runs_end_to_end() {
    let twin = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/stalks/twin");
    let dir = fresh_dir("twin");
    for f in ["study.toml", "shear.toml", "lab/twin_shear.csv"] {
        std::fs::copy(twin.join(f), dir.join(f)).unwrap();
    }
    let path = dir.join("study.toml");
    let out = run_path(&path, 2).unwrap();
    assert!(out.contains("state: complete"), "{out}");
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("report/summary.json")).unwrap())
            .unwrap();
    let cal = &summary["calibrated"];
    let k_n = cal["bond_normal_stiffness"].as_f64().unwrap();
    let tau_c = cal["critical_shear_stress"].as_f64().unwrap();
    // True values 3e10 N/m^3 and 3e6 Pa; this plan comes back within about a quarter of them
    // (measured 2.51e10 and 2.31e6, the closing note of issue 12).
    assert!((k_n - 3e10).abs() < 0.3 * 3e10, "k_n = {k_n}");
    assert!((tau_c - 3e6).abs() < 0.3 * 3e6, "tau_c = {tau_c}");
    let mse = summary["validation_mean"].as_f64().unwrap();
    assert!(mse < 0.015, "validation MSE {mse}");
    let html = std::fs::read_to_string(dir.join("report/index.html")).unwrap();
    for part in ["\">Curves</h2>", "lab band (replicates", "validation run 1"] {
        assert!(html.contains(part), "report lacks {part}");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Seed 000 first checks that its design's curves bracket the lab curve (its Fig. 13). Over
/// k 4000..8000 and q 1e5..4e5 the factorial's curves enclose the lab's (k 5000, q 2e5); with k
/// from 6000 and q up to 2e5 every run is stiffer than the lab specimen, and the note says
/// where the lab curve lies below them all.
#[test]
fn the_design_curves_are_checked_to_bracket_the_lab_curve() {
    let screening = |text: &str| {
        text.replace(
            r#"plan = [{ stage = "screening", design = "factorial" }, "steepest", "rsm", "optimize", "validate"]"#,
            r#"plan = [{ stage = "screening", design = "factorial" }]"#,
        )
    };
    let dir = fresh_dir("bracket");
    write_lab(&dir, 0.0);
    let path = write_study(&dir, &screening(STUDY));
    let out = run_path(&path, 2).unwrap();
    assert!(out.contains("state: complete"), "{out}");
    let notes = test_support::summary(&dir)["stages"][0]["notes"].to_string();
    assert!(
        notes.contains(
            "bracket check: the 9 runs' curves enclose the lab curve over 100 % of its range"
        ),
        "{notes}"
    );
    let stiff = screening(STUDY)
        .replace("min = 4000", "min = 6000")
        .replace("max = 4e5", "max = 2e5");
    let path = write_study(&dir, &stiff);
    let _ = std::fs::remove_file(dir.join("study.db"));
    let out = run_path(&path, 2).unwrap();
    assert!(out.contains("state: complete"), "{out}");
    let notes = test_support::summary(&dir)["stages"][0]["notes"].to_string();
    assert!(
        notes.contains(
            "enclose the lab curve over 0 % of its range; it lies below them all over 100 %"
        ),
        "{notes}"
    );
    std::fs::remove_dir_all(dir).unwrap();
}
