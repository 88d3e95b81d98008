//! The defects a second, independent battery of hostile inputs found (docs/reliability.md), each
//! refused in one line, at once: named pipes and devices given as files, a lock file with no end,
//! a record that would replace a device, results that overflow, contradictory or absurd settings
//! that were accepted, and command-line errors spanning lines.

mod common;

use common::{demcal, output_within, temp_dir};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const SETTLE: &str = include_str!("../../../examples/scenes/settle.toml");
const CCD: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../doe/tests/data/silage-repose-ccd.csv"
);

/// A study on the function test that runs in a second.
const BOWL: &str = r#"
name = "bowl"
seed = 5
plan = [{ stage = "screening", design = "pb" }]

[test]
test = "function"
[test.function]
expression = "30 + 10*((a - 0.6)^2 + (b - 0.3)^2)"
variables = { a = 0.8, b = 0.5 }

[[parameter]]
name = "a"
path = "function.variables.a"
min = 0.4
max = 1.2

[[parameter]]
name = "b"
path = "function.variables.b"
min = 0.1
max = 0.9

[target]
value = 30.0
"#;

/// Refused (any non-zero status) in one line, within 5 s; the line.
fn refused(cmd: Command) -> String {
    let out: Output = output_within(cmd, 5.0);
    let err = String::from_utf8_lossy(&out.stderr).trim_end().to_string();
    assert!(!out.status.success(), "accepted: {err}");
    assert_eq!(err.lines().count(), 1, "{err}");
    err
}

fn cmd(args: &[&str]) -> Command {
    let mut c = demcal();
    c.args(args);
    c
}

fn fifo(dir: &Path, name: &str) -> PathBuf {
    let p = dir.join(name);
    let ok = Command::new("mkfifo").arg(&p).status().unwrap().success();
    assert!(ok);
    p
}

fn write(dir: &Path, name: &str, text: &str) -> String {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p.display().to_string()
}

fn edited(text: &str, from: &str, to: &str) -> String {
    assert!(text.contains(from), "{from}");
    text.replacen(from, to, 1)
}

#[test]
fn named_pipes_given_as_files_are_refused_at_once() {
    let dir = temp_dir("fifos");
    let f = |n: &str| fifo(&dir, n).display().to_string();
    for (args, file) in [
        (vec!["simulate", &f("s.toml")], "s.toml"),
        (vec!["run", &f("st.toml")], "st.toml"),
        (vec!["run-one", &f("j.json")], "j.json"),
        (vec!["heap-angle", &f("h.csv")], "h.csv"),
        (vec!["lab", "photo-angle", &f("p.png")], "p.png"),
        (
            vec!["doe", "analyze", &f("d.csv"), "--response", "y"],
            "d.csv",
        ),
        (vec!["shape", "fit", "--stl", &f("m.stl")], "m.stl"),
    ] {
        let e = refused(cmd(&args));
        assert!(e.contains(file) && e.contains("not a plain file"), "{e}");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_lock_file_with_no_end_is_read_no_further_than_a_lock() {
    let dir = temp_dir("endless-lock");
    let study = write(&dir, "study.toml", BOWL);
    // A pipe and /dev/zero: the first waited for a writer, the second grew to 2 GB.
    fifo(&dir, "study.db.lock");
    let out = output_within(cmd(&["run", &study]), 60.0);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    std::os::unix::fs::symlink("/dev/zero", dir.join("study.db.lock")).unwrap();
    let out = output_within(cmd(&["run", &study]), 60.0);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_record_is_never_written_over_something_that_is_not_a_file() {
    let dir = temp_dir("record");
    let study = write(&dir, "study.toml", BOWL);
    let out = output_within(cmd(&["run", &study]), 60.0);
    assert!(out.status.success());
    // A job file as a cluster task gets it, from the study's own store.
    let job = study::Job::new(
        &study::Study::load(Path::new(&study)).unwrap(),
        &study::replay(&study::Study::load(Path::new(&study)).unwrap(), &[], None)
            .unwrap()
            .stages[0]
            .runs[0],
    );
    let job_file = dir.join("run001.json");
    std::fs::write(&job_file, job.to_json()).unwrap();
    // A pipe stands for a device: writing the record beside it and renaming it onto it replaced
    // /dev/full with a plain file.
    let record = fifo(&dir, "record.json");
    let e = refused(cmd(&[
        "run-one",
        &job_file.display().to_string(),
        "--record",
        &record.display().to_string(),
    ]));
    assert!(
        e.contains("--record") && e.contains("not a plain file"),
        "{e}"
    );
    use std::os::unix::fs::FileTypeExt;
    assert!(std::fs::metadata(&record).unwrap().file_type().is_fifo());
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn results_that_overflow_are_refused() {
    let e = refused(cmd(&[
        "lab",
        "modulus",
        "--slope",
        "1e308",
        "--length",
        "1e308",
        "--diameter",
        "1e-300",
    ]));
    assert!(e.contains("youngs_modulus: the result is inf Pa"), "{e}");
    let e = refused(cmd(&[
        "lab",
        "bulk-density",
        "--filled",
        "1e308",
        "--empty",
        "1e-308",
        "--volume",
        "1e-308",
    ]));
    assert!(e.contains("bulk_density: the result is inf"), "{e}");
    let dir = temp_dir("tiny-target");
    let s = write(
        &dir,
        "study.toml",
        &edited(BOWL, "value = 30.0", "value = 1e-320"),
    );
    let e = refused(cmd(&["run", &s]));
    assert!(
        e.contains("target.value") && e.contains("at least 1e-300"),
        "{e}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn absurd_or_contradictory_study_settings_are_refused_when_read() {
    let dir = temp_dir("study-settings");
    let pb = "plan = [{ stage = \"screening\", design = \"pb\" }]";
    for (from, to, key) in [
        (
            pb,
            "plan = [{ stage = \"screening\", design = \"pb\", runs = 7 }]",
            "runs",
        ),
        (
            pb,
            "plan = [{ stage = \"screening\", design = \"fractional\", runs = 12 }]",
            "runs",
        ),
        (pb, "plan = [{ stage = \"rsm\", alpha = 1e9 }]", "alpha"),
        (
            "value = 30.0",
            "value = 30.0\nreplicates = [1.0, 2.0]",
            "target.value",
        ),
        ("name = \"bowl\"", "name = \"two\\nlines\"", "name"),
    ] {
        let s = write(&dir, "study.toml", &edited(BOWL, from, to));
        let e = refused(cmd(&["status", &s]));
        assert!(e.contains(key), "{to}: {e}");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn absurd_scene_values_are_refused_when_read() {
    let dir = temp_dir("scene-values");
    for (from, to, key) in [
        ("gravity = [0.0, 0.0, -9.81]", "gravity = [nan, 0.0, -9.81]", "simulation.gravity"),
        ("gravity = [0.0, 0.0, -9.81]", "gravity = [0.0, 0.0, -1e308]", "simulation.gravity"),
        (
            "fill = { type = \"lattice\"",
            "velocity = [inf, 0.0, 0.0]\nfill = { type = \"lattice\"",
            "particles[0].velocity",
        ),
        (
            "materials = [\"glass\", \"glass\"]",
            "materials = [\"glass\", \"glass\", \"glass\"]",
            "interaction[0].materials",
        ),
        ("name = \"glass\"", "name = \"\"", "material[0].name"),
        ("youngs_modulus = 1.0e7", "youngs_modulus = 1e-300", "material[0].youngs_modulus"),
        ("radius = 0.002", "radius = 1e-300", "particles[0].size"),
        (
            "fill = { type = \"lattice\", lattice = \"sc\", spacing = 0.0042, origin = [0.0, 0.0, 0.0] }",
            "fill = { type = \"random\", count = 9999999 }",
            "region is too small",
        ),
    ] {
        let s = write(&dir, "s.toml", &edited(SETTLE, from, to));
        let e = refused(cmd(&["simulate", &s, "--threads", "1", "--out", &dir.join("o").display().to_string()]));
        assert!(e.contains(key), "{to}: {e}");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn absurd_test_and_job_values_are_refused_when_read() {
    let dir = temp_dir("test-values");
    let long = format!(
        "test = \"function\"\n[function]\nexpression = \"{}1\"\n",
        "1+".repeat(5000)
    );
    let e = refused(cmd(&["test", &write(&dir, "t.toml", &long)]));
    assert!(
        e.contains("function.expression") && e.contains("at most 2000"),
        "{e}"
    );
    let compression = include_str!("../../../examples/stalks/stalk_compression.toml");
    let t = write(
        &dir,
        "c.toml",
        &edited(
            compression,
            "max_displacement = 0.012",
            "max_displacement = 1.0",
        ),
    );
    let e = refused(cmd(&["test", &t, "--threads", "1"]));
    assert!(
        e.contains("max_displacement") && e.contains("diameter"),
        "{e}"
    );
    // A job's stage past any study's, which wrapped to "stage 0" when shown.
    let job = r#"{"tests":[{"name":"function","label":"t","test":{"test":"function","function":{"expression":"1"}},"dir":"/tmp","seed":1}],
        "seed":1,"stage":18446744073709551615,"stage_kind":"screening","index":0,"label":"x","inputs":{},
        "response":"value","run_time_limit_s":null,"out_dir":"/tmp/s.runs/stage1-screening/run001","fingerprint":"f"}"#;
    let e = refused(cmd(&["run-one", &write(&dir, "job.json", job)]));
    assert!(
        e.contains("stage: expected a stage number below 1000"),
        "{e}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_dump_whose_atom_count_disagrees_with_its_rows_is_refused() {
    let dir = temp_dir("dump-count");
    let dump = "ITEM: TIMESTEP\n0\nITEM: NUMBER OF ATOMS\n3\nITEM: BOX BOUNDS pp pp ff\n0 1\n0 1\n0 1\nITEM: ATOMS id x y z radius\n1 0 0 0.001 0.001\n2 0.002 0 0.001 0.001\n";
    let e = refused(cmd(&["heap-angle", &write(&dir, "h.dump", dump)]));
    assert!(e.contains("declares 3 atoms but holds 2 rows"), "{e}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn contradictory_optimisation_goals_are_refused() {
    let base = [
        "doe",
        "optimize",
        CCD,
        "--response",
        "angle_deg",
        "--model",
        "quadratic",
    ];
    for (extra, key) in [
        (
            vec![
                "--goal",
                "angle_deg:maximize",
                "--goal",
                "angle_deg:minimize",
            ],
            "has a goal already",
        ),
        (
            vec!["--goal", "angle_deg:maximize", "--starts", "0"],
            "--starts 0",
        ),
        (
            vec![
                "--goal",
                "angle_deg:maximize",
                "--goal",
                "D:range:lower=5:upper=6",
            ],
            "outside the runs' range of D",
        ),
        (
            vec!["--response", "angle_deg", "--goal", "angle_deg:maximize"],
            "named twice",
        ),
    ] {
        let args: Vec<&str> = base.iter().copied().chain(extra).collect();
        let e = refused(cmd(&args));
        assert!(e.contains(key), "{e}");
    }
    let e = refused(cmd(&[
        "doe",
        "design",
        "lhs",
        "--factors",
        "1000",
        "--runs",
        "10000",
        "--lhs",
        "maximin",
    ]));
    assert!(e.contains("pair terms"), "{e}");
}

#[test]
fn command_line_errors_are_one_line_and_negative_numbers_are_values() {
    let e = refused(cmd(&["test", "x.toml", "--threads", "-1"]));
    assert!(
        e.contains("'--threads <THREADS>'") && e.contains("see demcal test --help"),
        "{e}"
    );
    let e = refused(cmd(&["lab", "modulus", "--slope"]));
    assert!(
        e.contains("--slope") && e.contains("see demcal lab modulus --help"),
        "{e}"
    );
    let e = refused(cmd(&["lab", "friction", "--tilt-deg", "-10"]));
    assert!(e.contains("--tilt-deg: expected an angle"), "{e}");
    // A list starting with a minus is the option's value.
    let dir = temp_dir("negative-axis");
    let e = refused(cmd(&[
        "heap-angle",
        &dir.join("none.csv").display().to_string(),
        "--axis",
        "-0.001,0.002",
    ]));
    assert!(e.contains("none.csv"), "{e}");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// What the rerun of the battery on the fixed binary still found, each fixed.
#[test]
fn the_rerun_of_the_battery_finds_these_refused_or_said() {
    let dir = temp_dir("rerun");
    // A sweep step so small that its count overflowed (a panic in builds with overflow checks).
    let s = write(
        &dir,
        "study.toml",
        &edited(
            BOWL,
            "plan = [{ stage = \"screening\", design = \"pb\" }]",
            "plan = [{ stage = \"sweep\", parameter = \"a\", from = 0.4, to = 1.2, step = 1e-300 }]",
        ),
    );
    let e = refused(cmd(&["status", &s]));
    assert!(
        e.contains("plan[0].step") && e.contains("at most 1000"),
        "{e}"
    );
    // A crop starting with a minus names --crop, not an unknown "-5".
    let e = refused(cmd(&[
        "lab",
        "photo-angle",
        "x.png",
        "--crop",
        "-5,-5,10,10",
    ]));
    assert!(e.contains("--crop"), "{e}");
    // A plate height above the heap names --base.
    let dump = "x,y,z,radius\n0,0,0.001,0.001\n0.002,0,0.001,0.001\n";
    let e = refused(cmd(&[
        "heap-angle",
        &write(&dir, "h.csv", dump),
        "--base",
        "10",
    ]));
    assert!(
        e.starts_with("error: --base 10: at or above the top"),
        "{e}"
    );
    // A scale that takes the solid's volume out of f64.
    let stl = "solid t\nfacet normal 0 0 0\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\nendloop\nendfacet\nendsolid t\n";
    let e = refused(cmd(&[
        "shape",
        "fit",
        "--stl",
        &write(&dir, "t.stl", stl),
        "--scale",
        "1e300",
    ]));
    assert!(
        e.contains("--scale: expected a factor from 1e-9 to 1e3"),
        "{e}"
    );
    // A target the surrogate cannot reach is said so.
    let out = output_within(
        cmd(&[
            "surrogate",
            "optimize",
            CCD,
            "--response",
            "angle_deg",
            "--factors",
            "D,E,G",
            "--model",
            "gp",
            "--goal",
            "target=1e308",
        ]),
        60.0,
    );
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success()
            && text.contains("the target 1e308 is not reached")
            && text.contains("(target 1e308)"),
        "{text}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The record is written through a temporary file of the process's own: a pipe or a file at the
/// old fixed name (`rec.tmp`) is neither waited on nor overwritten.
#[test]
fn a_record_is_written_through_a_temporary_file_of_its_own() {
    let dir = temp_dir("record-tmp");
    let study = write(&dir, "study.toml", BOWL);
    let loaded = study::Study::load(Path::new(&study)).unwrap();
    let job = study::Job::new(
        &loaded,
        &study::replay(&loaded, &[], None).unwrap().stages[0].runs[0],
    );
    let job_file = dir.join("run001.json");
    std::fs::write(&job_file, job.to_json()).unwrap();
    let pipe = fifo(&dir, "rec.tmp");
    let record = dir.join("rec.json");
    let out = output_within(
        cmd(&[
            "run-one",
            &job_file.display().to_string(),
            "--record",
            &record.display().to_string(),
        ]),
        30.0,
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(std::fs::read_to_string(&record)
        .unwrap()
        .contains("\"status\""));
    use std::os::unix::fs::FileTypeExt;
    assert!(std::fs::metadata(&pipe).unwrap().file_type().is_fifo());
    let left: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().ends_with(".part"))
        .collect();
    assert!(left.is_empty());
    std::fs::remove_dir_all(&dir).unwrap();
}
