//! The plans the papers use, as whole studies on the `function` test, each recovering a known
//! answer: the search region of `optimize` (coded ±1, out to the axial points, given limits).

mod common;
use common::run_study;

use std::path::{Path, PathBuf};
use test_support::summary;

fn fresh_dir(name: &str) -> PathBuf {
    test_support::fresh_dir("plan", name)
}

/// value = 30 + 20 a (+ a trace of b), a and b in 0 .. 1. The CCD keeps its axial points
/// (coded ±1.414) inside the range, so its coded ±1 is a = 0.146 .. 0.854, and the lab value
/// 48 needs a = 0.9: beyond coded +1 (1.131), inside the axial points.
fn line(region: &str) -> String {
    format!(
        r#"
name = "line"
seed = 4
plan = ["rsm", {{ stage = "optimize", solutions = 1{region} }}]

[test]
test = "function"
[test.function]
expression = "30 + 20*a + 0.01*b"
variables = {{ a = 0.5, b = 0.5 }}

[[parameter]]
name = "a"
path = "function.variables.a"
min = 0.0
max = 1.0

[[parameter]]
name = "b"
path = "function.variables.b"
min = 0.0
max = 1.0

[target]
response = "value"
value = 48.0
"#
    )
}

#[test]
fn optimize_reaches_an_optimum_at_the_axial_points_only_when_asked() {
    // Inside coded ±1 the closest is its edge, a = 0.854 (value 47.07); out to the axial
    // points the lab value itself; within given limits their edge.
    for (region, a_expected, says) in [
        ("", 0.8536, "coded range −1 to +1"),
        (r#", region = "cube""#, 0.8536, "coded range −1 to +1"),
        (r#", region = "axial""#, 0.9, "axial points"),
        (r#", region = { a = [0.0, 0.88] }"#, 0.88, "a 0 .. 0.88"),
    ] {
        let dir = fresh_dir("region");
        let out = run_study(&dir, &line(region)).unwrap();
        assert!(out.contains("state: complete"), "{out}");
        let s = summary(&dir);
        let a = s["calibrated"]["a"].as_f64().unwrap();
        assert!((a - a_expected).abs() < 0.005, "{region}: a = {a}");
        let notes = s["stages"][1]["notes"].to_string();
        assert!(notes.contains(says), "{region}: {notes}");
        std::fs::remove_dir_all(dir).unwrap();
    }
}

#[test]
fn a_region_naming_no_parameter_or_not_a_range_is_refused_in_one_line() {
    for (region, says) in [
        (
            r#", region = { c = [0.0, 1.0] }"#,
            "plan[1].region.c: no parameter is named \"c\"",
        ),
        (
            r#", region = { a = [1.0, 0.0] }"#,
            "plan[1].region.a: expected [low, high]",
        ),
        (
            r#", region = { a = [0.0, 1.5] }"#,
            "plan[1].region.a: [0, 1.5] leaves the parameter's range 0 .. 1",
        ),
        (
            r#", region = "sphere""#,
            "plan[1].region: expected \"cube\"",
        ),
    ] {
        let dir = fresh_dir("bad-region");
        let e = run_study(&dir, &line(region)).unwrap_err();
        assert!(e.contains(says) && !e.contains('\n'), "{region}: {e}");
        std::fs::remove_dir_all(dir).unwrap();
    }
}

/// Seed 004's sliding-distance curve, y = 177.52 − 328.93 a − 226.19 a² (mm), with 1 mm of
/// noise, swept as the paper did (0.18 to 0.24 by 0.01, ten repeats) and inverted at the lab's
/// 97 mm: the root is a = 0.21346.
fn sweep_study(extra: &str) -> String {
    format!(
        r#"
name = "sweep"
seed = 11
plan = [{{ stage = "sweep", parameter = "a", from = 0.18, to = 0.24, step = 0.01, repeats = 10, model = "quadratic"{extra} }}]

[test]
test = "function"
[test.function]
expression = "177.52 - 328.93*a - 226.19*a^2 + 0*b"
variables = {{ a = 0.2, b = 0.5 }}
noise = 1.0

[[parameter]]
name = "a"
path = "function.variables.a"
min = 0.01
max = 0.3

[[parameter]]
name = "b"
path = "function.variables.b"
min = 0.0
max = 1.0

[target]
response = "value"
value = 97.0
replicates = [96.0, 97.0, 98.0]
"#
    )
}

#[test]
fn a_sweep_inverts_a_known_curve_with_its_uncertainty() {
    let dir = fresh_dir("sweep");
    let out = run_study(&dir, &sweep_study("")).unwrap();
    assert!(out.contains("state: complete"), "{out}");
    let s = summary(&dir);
    assert_eq!(s["stages"][0]["runs"], 70);
    let o = &s["stages"][0]["outcome"];
    let (a, se) = (
        o["value"].as_f64().unwrap(),
        o["std_error"].as_f64().unwrap(),
    );
    // The standard error: the lab mean's SD/sqrt(3) = 0.577 mm and the fit's ~0.15 mm, over a
    // slope of about 425 mm per unit: about 0.0014.
    assert!((0.001..0.002).contains(&se), "se {se}");
    assert!((a - 0.21346).abs() < 2.0 * se, "a = {a} ± {se}");
    let ci = o["interval_95"].as_array().unwrap();
    let (lo, hi) = (ci[0].as_f64().unwrap(), ci[1].as_f64().unwrap());
    assert!(lo < 0.21346 && 0.21346 < hi, "{lo} .. {hi}");
    assert!((o["slope"].as_f64().unwrap() + 425.5).abs() < 15.0, "{o}");
    // The swept parameter is calibrated at its inversion; the other is held.
    assert!((s["calibrated"]["a"].as_f64().unwrap() - a).abs() < 1e-9);
    assert_eq!(s["calibrated"]["b"].as_f64().unwrap(), 0.5);
    let notes = s["stages"][0]["notes"].to_string();
    assert!(notes.contains("enclose the lab value"), "{notes}");
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn a_sweep_that_cannot_reach_the_lab_value_or_is_badly_given_says_so_in_one_line() {
    let dir = fresh_dir("sweep-bad");
    for (extra, says) in [
        (", values = [0.1]", "plan[0].from: give either values"),
        (", step = 0.0", "plan[0].step"),
    ] {
        // A key given twice is a TOML error; replace the generated one instead.
        let text = if extra.contains("step = 0.0") {
            sweep_study("").replace("step = 0.01", "step = 0.0")
        } else {
            sweep_study(extra)
        };
        let e = run_study(&dir, &text).unwrap_err();
        assert!(e.contains(says) && !e.contains('\n'), "{extra}: {e}");
    }
    let bad = sweep_study("").replace("from = 0.18, to = 0.24, step = 0.01", "values = [0.2, 0.5]");
    let e = run_study(&dir, &bad).unwrap_err();
    assert!(
        e.contains("plan[0].values: 0.5 is outside the parameter's range"),
        "{e}"
    );
    let e = run_study(
        &dir,
        &sweep_study("").replace("parameter = \"a\"", "parameter = \"z\""),
    )
    .unwrap_err();
    assert!(
        e.contains("plan[0].parameter: no parameter is named \"z\""),
        "{e}"
    );
    // The lab value beyond what the swept values give: stopped with the reason.
    let far = sweep_study("")
        .replace("value = 97.0", "value = 20.0")
        .replace(
            "replicates = [96.0, 97.0, 98.0]",
            "replicates = [19.0, 20.0, 21.0]",
        );
    let e = run_study(&dir, &far).unwrap_err();
    assert!(e.contains("stage 1 (sweep): the fitted curve does not reach the lab value 20.00 between 0.1800 and 0.2400"), "{e}");
    let notes = summary(&dir)["stages"][0]["notes"].to_string();
    assert!(notes.contains("do not enclose the lab value"), "{notes}");
    std::fs::remove_dir_all(dir).unwrap();
}

/// value = 30 + 20 a − 5 b, both in 0 .. 1; the lab value 51 needs 20 a − 5 b = 21, so
/// a >= 1.05: past a's range. Seed 003's plan: a given steepest path first (no screening),
/// past the range, then a CCD and the optimisation.
#[test]
fn a_given_steepest_path_goes_first_and_past_the_ranges() {
    let dir = fresh_dir("steepest-first");
    let text = r#"
name = "steepest-first"
seed = 5
plan = [{ stage = "steepest", steps = 5, path = { a = [0.5, 1.3], b = [0.2, 0.8] } }, "rsm", { stage = "optimize", solutions = 1 }]

[test]
test = "function"
[test.function]
expression = "30 + 20*a - 5*b"
variables = { a = 0.5, b = 0.5 }

[[parameter]]
name = "a"
path = "function.variables.a"
min = 0.0
max = 1.0

[[parameter]]
name = "b"
path = "function.variables.b"
min = 0.0
max = 1.0

[target]
response = "value"
value = 51.0
"#;
    let out = run_study(&dir, text).unwrap();
    assert!(out.contains("state: complete"), "{out}");
    let s = summary(&dir);
    assert_eq!(s["stages"][0]["best_step"], 5);
    let (a, b) = (
        s["calibrated"]["a"].as_f64().unwrap(),
        s["calibrated"]["b"].as_f64().unwrap(),
    );
    assert!(a > 1.05, "a = {a}");
    assert!(
        (30.0 + 20.0 * a - 5.0 * b - 51.0).abs() < 0.05,
        "a {a} b {b}"
    );
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn an_automatic_path_stops_at_the_ranges_unless_limits_say_further() {
    let study = |steepest: &str| {
        format!(
            r#"
name = "reach"
seed = 6
plan = [{{ stage = "screening", design = "factorial", center_points = 1 }}, {{ stage = "steepest", steps = 5{steepest} }}]

[test]
test = "function"
[test.function]
expression = "30 + 20*a - 5*b"
variables = {{ a = 0.5, b = 0.5 }}
noise = 0.01

[[parameter]]
name = "a"
path = "function.variables.a"
min = 0.0
max = 1.0

[[parameter]]
name = "b"
path = "function.variables.b"
min = 0.0
max = 1.0

[target]
response = "value"
value = 51.0
"#
        )
    };
    let a_of_last = |dir: &Path| -> f64 {
        let csv = std::fs::read_to_string(dir.join("report/results.csv")).unwrap();
        let mut rows = csv.lines();
        let head: Vec<&str> = rows.next().unwrap().split(',').collect();
        let (col, stage) = (
            head.iter().position(|h| *h == "a").unwrap(),
            head.iter().position(|h| *h == "stage").unwrap(),
        );
        rows.map(|r| r.split(',').collect::<Vec<_>>())
            .filter(|r| r[stage] == "2")
            .map(|r| r[col].parse::<f64>().unwrap())
            .fold(f64::MIN, f64::max)
    };
    let dir = fresh_dir("reach");
    // Twice the ranges, no limits: a stops at 1.
    let out = run_study(&dir, &study(", reach = 2.0")).unwrap();
    assert!(out.contains("state: complete"), "{out}");
    assert_eq!(a_of_last(&dir), 1.0);
    assert!(summary(&dir)["stages"][1]["notes"]
        .to_string()
        .contains("a: the path would leave 0 .. 1"));
    std::fs::remove_dir_all(&dir).unwrap();
    let dir = fresh_dir("reach-limits");
    let out = run_study(&dir, &study(", reach = 2.0, limits = { a = [0.0, 1.4] }")).unwrap();
    assert!(out.contains("state: complete"), "{out}");
    assert_eq!(a_of_last(&dir), 1.4);
    std::fs::remove_dir_all(&dir).unwrap();
    let dir = fresh_dir("reach-bad");
    let e = run_study(&dir, &study(", limits = { a = [0.2, 1.4] }")).unwrap_err();
    assert!(
        e.contains("plan[1].limits.a: [0.2, 1.4] does not hold the parameter's range"),
        "{e}"
    );
    let e = run_study(&dir, "name = \"x\"\nplan = [\"steepest\"]\n[test]\ntest = \"function\"\n[test.function]\nexpression = \"a\"\nvariables = { a = 0.5 }\n[[parameter]]\nname = \"a\"\npath = \"function.variables.a\"\nmin = 0.0\nmax = 1.0\n[target]\nresponse = \"value\"\nvalue = 1.0\n").unwrap_err();
    assert!(e.contains("or give the path"), "{e}");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Seed 001 repeats every Plackett-Burman run 3 times and models the mean: 13 points (12 + a
/// centre), 39 runs, a model of 13 rows whose effects are those of the noise-free formula.
#[test]
fn replicated_design_points_are_modelled_by_their_means() {
    let dir = fresh_dir("replicates");
    let text = r#"
name = "replicates"
seed = 8
plan = [{ stage = "screening", replicates = 3 }]

[test]
test = "function"
[test.function]
expression = "30 + 10*a + 0*b + 0*c"
variables = { a = 0.5, b = 0.5, c = 0.5 }
noise = 0.5

[[parameter]]
name = "a"
path = "function.variables.a"
min = 0.0
max = 1.0

[[parameter]]
name = "b"
path = "function.variables.b"
min = 0.0
max = 1.0

[[parameter]]
name = "c"
path = "function.variables.c"
min = 0.0
max = 1.0

[target]
response = "value"
value = 36.0
"#;
    let out = run_study(&dir, text).unwrap();
    assert!(out.contains("state: complete"), "{out}");
    let s = summary(&dir);
    let st = &s["stages"][0];
    assert_eq!(st["runs"], 39);
    assert_eq!(st["model"]["runs"], 13);
    assert!(
        st["title"]
            .as_str()
            .unwrap()
            .contains("each point run 3 times"),
        "{st}"
    );
    // The coded coefficient of a: half the effect of 10 over the range; the mean of 3 runs has
    // noise 0.29, so over 12 points its coefficient is within ±0.15 or so.
    let coded = &st["model"]["coefficients_coded"];
    let coef = coded["a"]
        .as_f64()
        .or(coded["A"].as_f64())
        .expect("a's coefficient");
    assert!((coef - 5.0).abs() < 0.3, "{coef}");
    // Each run has its own seed: the replicates differ.
    let csv = std::fs::read_to_string(dir.join("report/results.csv")).unwrap();
    let seeds: std::collections::BTreeSet<&str> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').nth(3).unwrap())
        .collect();
    assert_eq!(seeds.len(), 39);
    std::fs::remove_dir_all(dir).unwrap();
}

/// Seed 001 trains its GA-BP network on the CCD's runs only: `train_on = ["rsm"]` takes the 13
/// runs of the response surface and none of the screening's.
#[test]
fn a_network_trains_on_the_runs_of_the_stages_it_is_given() {
    let study = |train_on: &str| {
        format!(
            r#"
name = "train-on"
seed = 9
plan = [{{ stage = "screening", design = "factorial", center_points = 1 }}, "rsm", {{ stage = "ga_bp", generations = 5, population = 8, search_generations = 5, search_population = 8, max_epochs = 20{train_on} }}]

[test]
test = "function"
[test.function]
expression = "30 + 10*a + 5*b*b"
variables = {{ a = 0.5, b = 0.5 }}

[[parameter]]
name = "a"
path = "function.variables.a"
min = 0.0
max = 1.0

[[parameter]]
name = "b"
path = "function.variables.b"
min = 0.0
max = 1.0

[target]
response = "value"
value = 37.0
"#
        )
    };
    for (train_on, rows, says) in [
        ("", 5 + 13, "18 finished runs of the stages before it"),
        (
            r#", train_on = ["rsm"]"#,
            13,
            "13 finished runs of stage(s) rsm",
        ),
        (", train_on = [1]", 5, "5 finished runs of stage(s) 1"),
    ] {
        let dir = fresh_dir("train-on");
        let out = run_study(&dir, &study(train_on)).unwrap();
        assert!(out.contains("state: complete"), "{out}");
        let s = summary(&dir);
        let notes = s["stages"][2]["notes"].to_string();
        assert!(notes.contains(says), "{train_on}: {rows} rows: {notes}");
        std::fs::remove_dir_all(dir).unwrap();
    }
    let dir = fresh_dir("train-on-bad");
    let e = run_study(&dir, &study(r#", train_on = ["smc"]"#)).unwrap_err();
    assert!(
        e.contains("plan[2]: train_on: \"smc\" is not a stage before it (the stages before it: 1 screening, 2 rsm)"),
        "{e}"
    );
    let e = run_study(&dir, &study(r#", train_on = ["rsm"], runs = 20"#)).unwrap_err();
    assert!(
        e.contains("plan[2].train_on: a ga_bp stage with runs = N"),
        "{e}"
    );
    std::fs::remove_dir_all(dir).unwrap();
}

/// Seed 000 validates its shear calibration on another test, three-point bending: a second
/// study without parameters of its own imports the calibrated values and only validates. Here
/// the first study sweeps a (value = 30 + 20 a, lab 40: a = 0.5), the second validates
/// value = 2 a + 1 against its lab value 2.
#[test]
fn a_calibration_is_validated_on_a_second_test() {
    let dir = fresh_dir("second-test");
    std::fs::create_dir_all(dir.join("shear")).unwrap();
    std::fs::create_dir_all(dir.join("bending")).unwrap();
    let first = r#"
name = "shear"
plan = [{ stage = "sweep", parameter = "a", values = [0.3, 0.4, 0.6, 0.7], repeats = 1 }]

[test]
test = "function"
[test.function]
expression = "30 + 20*a"
variables = { a = 0.1 }

[[parameter]]
name = "a"
path = "function.variables.a"
min = 0.0
max = 1.0

[target]
response = "value"
value = 40.0
"#;
    let out = run_study(&dir.join("shear"), first).unwrap();
    assert!(out.contains("state: complete"), "{out}");
    let second = r#"
name = "bending"
plan = [{ stage = "validate", replicates = 2 }]

[test]
test = "function"
[test.function]
expression = "2*a + 1"
variables = { a = 0.1 }

[[import]]
study = "../shear/study.toml"
parameter = "a"
path = "function.variables.a"

[target]
response = "value"
value = 2.0
"#;
    let out = run_study(&dir.join("bending"), second).unwrap();
    assert!(out.contains("state: complete"), "{out}");
    let s = summary(&dir.join("bending"));
    assert!(
        (s["validation_mean"].as_f64().unwrap() - 2.0).abs() < 1e-9,
        "{s}"
    );
    assert_eq!(s["validation_runs"], 2);
    assert!(s["relative_error_percent"].as_f64().unwrap().abs() < 1e-6);
    assert_eq!(s["imports"][0]["value"].as_f64().unwrap(), 0.5);
    // Without parameters, a plan that calibrates is refused in one line.
    let e = run_study(
        &dir.join("bending"),
        &second.replace("stage = \"validate\", replicates = 2", "stage = \"rsm\""),
    )
    .unwrap_err();
    assert!(
        e.contains("parameter: missing") && e.contains("can only validate") && !e.contains('\n'),
        "{e}"
    );
    std::fs::remove_dir_all(dir).unwrap();
}
