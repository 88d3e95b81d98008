//! The plans the papers use, as whole studies on the `function` test, each recovering a known
//! answer: the search region of `optimize` (coded ±1, out to the axial points, given limits).

use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::sync::Arc;

use study::RunOptions;

fn fresh_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("demcal-plan-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn run_study(dir: &Path, text: &str) -> Result<String, String> {
    let p = dir.join("study.toml");
    std::fs::write(&p, text).unwrap();
    study::run(
        &p,
        &RunOptions {
            jobs: 2,
            ..Default::default()
        },
        Arc::new(AtomicBool::new(false)),
    )
}

fn summary(dir: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(dir.join("report/summary.json")).unwrap())
        .unwrap()
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
