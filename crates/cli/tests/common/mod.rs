//! Helpers the command-line tests share: the binary, a fresh folder, a run that must succeed or
//! end within a time.

#![allow(dead_code)]

use std::path::PathBuf;
use std::process::Command;

pub fn demcal() -> Command {
    Command::new(env!("CARGO_BIN_EXE_demcal"))
}

/// Runs demcal with `args`, requires success, returns standard output.
pub fn run_ok(args: &[&std::ffi::OsStr]) -> String {
    let out = demcal().args(args).output().unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).unwrap()
}

pub fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("demcal-cli-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Runs `cmd`, killing it (and failing) if it takes longer than `secs`: a refused value must not
/// hang first.
pub fn output_within(mut cmd: Command, secs: f64) -> std::process::Output {
    let mut child = cmd
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let t0 = std::time::Instant::now();
    while child.try_wait().unwrap().is_none() {
        if t0.elapsed().as_secs_f64() > secs {
            child.kill().unwrap();
            child.wait().unwrap();
            panic!("still running after {secs} s");
        }
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    child.wait_with_output().unwrap()
}

/// Exit status 1 and one line on standard error, which is returned.
pub fn one_line_error(out: &std::process::Output) -> String {
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert_eq!(err.lines().count(), 1, "{err}");
    err.trim_end().to_string()
}

/// The bowl study of the study crate's tests, each run taking 0.2 s so that a kill lands mid-way.
pub fn slow_bowl() -> String {
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../study/tests/studies.rs"
    ))
    .unwrap();
    let start = text.find("r#\"").unwrap() + 3;
    let end = start + text[start..].find("\"#;").unwrap();
    text[start..end].replace("noise = 0.02", "noise = 0.02\nduration_s = 0.2")
}
