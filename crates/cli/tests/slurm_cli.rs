//! `demcal run --executor slurm` where it cannot work: no Slurm on the machine, a wrong
//! `[executor]` table, a throttle of zero. Each ends in one line, before anything is written.
//! The executor itself is tested against a real Slurm by `tools/slurm/test-cluster.sh`.

use std::path::PathBuf;
use std::process::Command;

const STUDY: &str = r#"
name = "line"
plan = ["screening"]

[test]
test = "function"
[test.function]
expression = "20 + a + b"
variables = { a = 1.0, b = 1.0 }

[[parameter]]
name = "a"
path = "function.variables.a"
min = 0.0
max = 2.0

[[parameter]]
name = "b"
path = "function.variables.b"
min = 0.0
max = 2.0

[target]
value = 21.0
"#;

fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("demcal-slurm-cli-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Runs `demcal run` on `study` with `args`, with no Slurm commands on PATH; its one-line error.
fn fails(dir: &std::path::Path, study: &str, args: &[&str]) -> String {
    let path = dir.join("study.toml");
    std::fs::write(&path, study).unwrap();
    let empty = dir.join("no-slurm-here");
    std::fs::create_dir_all(&empty).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_demcal"))
        .arg("run")
        .arg(&path)
        .args(args)
        .env("PATH", &empty)
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8(out.stderr).unwrap();
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(!dir.join("study.db").exists(), "a store was written: {err}");
    err
}

#[test]
fn without_slurm_the_error_says_so_and_nothing_is_written() {
    let dir = temp_dir("none");
    let err = fails(&dir, STUDY, &["--executor", "slurm"]);
    assert!(
        err.starts_with("error: sbatch: not found") && err.contains("PATH"),
        "{err}"
    );
    // The same from the study file's [executor] table.
    let err = fails(
        &dir,
        &format!("{STUDY}\n[executor]\nkind = \"slurm\"\npartition = \"compute\"\n"),
        &[],
    );
    assert!(err.contains("sbatch: not found"), "{err}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_wrong_executor_table_or_throttle_is_one_line() {
    let dir = temp_dir("wrong");
    let err = fails(
        &dir,
        &format!("{STUDY}\n[executor]\nkind = \"slurm\"\ntime_limit = \"2 hours\"\n"),
        &[],
    );
    assert!(
        err.contains("study.toml: executor.time_limit: expected Slurm's time format"),
        "{err}"
    );
    let err = fails(
        &dir,
        &format!("{STUDY}\n[executor]\nkind = \"slurm\"\nqueue = \"long\"\n"),
        &[],
    );
    assert!(
        err.contains("executor.queue: unknown key for a slurm executor (expected partition"),
        "{err}"
    );
    let err = fails(&dir, STUDY, &["--executor", "slurm", "--jobs", "0"]);
    assert!(
        err.contains("--jobs 0: with --executor slurm, expected 1 to 100000"),
        "{err}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}
