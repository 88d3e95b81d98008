//! `demcal run` end to end: kill -9 and Ctrl-C mid-study lose and repeat nothing, and its errors
//! are one line with the exit status that says what kind of end it was.

use std::path::Path;
use std::process::Command;

mod common;
use common::*;

fn results_rows(dir: &Path) -> Vec<Vec<String>> {
    let text = std::fs::read_to_string(dir.join("report/results.csv")).unwrap();
    let mut r = csv::Reader::from_reader(text.as_bytes());
    r.records()
        .map(|row| row.unwrap().iter().map(String::from).collect())
        .collect()
}

#[test]
fn a_killed_study_resumes_without_losing_or_repeating_runs() {
    let study = slow_bowl();
    // Uninterrupted, for comparison.
    let whole = temp_dir("study-whole");
    std::fs::write(whole.join("study.toml"), &study).unwrap();
    run_ok(&[
        "run".as_ref(),
        whole.join("study.toml").as_os_str(),
        "--jobs".as_ref(),
        "2".as_ref(),
    ]);

    let dir = temp_dir("study-killed");
    let path = dir.join("study.toml");
    std::fs::write(&path, &study).unwrap();
    let mut child = demcal()
        .args([
            "run".as_ref(),
            path.as_os_str(),
            "--jobs".as_ref(),
            "2".as_ref(),
        ])
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    // Kill once a few runs are stored (status reads the store while the study writes to it).
    let stored = |text: &str| -> usize {
        text.split(" done")
            .next()
            .and_then(|h| h.rsplit(' ').next())
            .and_then(|n| n.parse().ok())
            .unwrap_or(0)
    };
    let t0 = std::time::Instant::now();
    while t0.elapsed().as_secs() < 30 {
        std::thread::sleep(std::time::Duration::from_millis(50));
        let out = demcal()
            .args(["status".as_ref(), path.as_os_str()])
            .output()
            .unwrap();
        if stored(&String::from_utf8_lossy(&out.stdout)) >= 4 {
            break;
        }
    }
    // A second `demcal run` of the same study while the first runs is refused, naming the
    // process that holds the store, and runs nothing.
    let second = demcal()
        .args(["run".as_ref(), path.as_os_str()])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&second.stderr);
    // 75, EX_TEMPFAIL: a script may try again later.
    assert_eq!(second.status.code(), Some(75), "{err}");
    assert_eq!(
        err.trim_end(),
        format!(
            "error: {}: the study is being run by process {} (lock file {}); wait for it to end, or stop it",
            dir.join("study.db").display(),
            child.id(),
            dir.join("study.db.lock").display()
        )
    );
    child.kill().unwrap(); // SIGKILL
    child.wait().unwrap();
    // The killed process left its lock behind; the next run sees that its process is gone.
    assert!(dir.join("study.db.lock").exists());
    run_ok(&["report".as_ref(), path.as_os_str()]);
    let before = results_rows(&dir);
    assert!(
        !before.is_empty() && before.len() < 34,
        "the kill should land mid-study: {} runs stored",
        before.len()
    );
    let status = run_ok(&["status".as_ref(), path.as_os_str()]);
    assert!(status.contains("has runs to make"), "{status}");

    run_ok(&[
        "run".as_ref(),
        path.as_os_str(),
        "--jobs".as_ref(),
        "2".as_ref(),
    ]);
    let after = results_rows(&dir);
    assert_eq!(after.len(), 34);
    // Every run stored before the kill is still there, untouched (same finish time and wall
    // time: it was not run again), and no run is stored twice.
    for row in &before {
        assert!(after.contains(row), "run lost or re-run: {row:?}");
    }
    let mut keys: Vec<(String, String)> =
        after.iter().map(|r| (r[0].clone(), r[2].clone())).collect();
    keys.sort();
    keys.dedup();
    assert_eq!(keys.len(), 34);
    // The result is the uninterrupted one.
    let summary = |d: &Path| -> serde_json::Value {
        serde_json::from_str(&std::fs::read_to_string(d.join("report/summary.json")).unwrap())
            .unwrap()
    };
    let (a, b) = (summary(&whole), summary(&dir));
    assert_eq!(a["calibrated"], b["calibrated"]);
    assert_eq!(a["validation_mean"], b["validation_mean"]);
    assert_eq!(a["relative_error_percent"], b["relative_error_percent"]);
    // Responses of every run agree with the uninterrupted study's.
    let col = |rows: &[Vec<String>]| -> Vec<(String, String, String)> {
        let mut v: Vec<_> = rows
            .iter()
            .map(|r| (r[0].clone(), r[2].clone(), r[9].clone()))
            .collect();
        v.sort();
        v
    };
    assert_eq!(col(&results_rows(&whole)), col(&after));
}

/// Ctrl-C (SIGINT) mid-study: the runs finished so far are kept, the message says how to go on,
/// and the exit status is 130, as the shell reports an interrupted command.
#[cfg(unix)]
#[test]
fn an_interrupted_study_exits_130_and_keeps_its_runs() {
    let dir = temp_dir("study-int");
    let path = dir.join("study.toml");
    std::fs::write(&path, slow_bowl()).unwrap();
    let child = demcal()
        .args([
            "run".as_ref(),
            path.as_os_str(),
            "--jobs".as_ref(),
            "2".as_ref(),
        ])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let t0 = std::time::Instant::now();
    while !dir.join("study.db").exists() && t0.elapsed().as_secs() < 30 {
        std::thread::sleep(std::time::Duration::from_millis(50));
    }
    std::thread::sleep(std::time::Duration::from_millis(600));
    let sent = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(sent.success());
    let out = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(130), "{err}");
    assert!(
        err.contains("interrupted: ") && err.contains("run the same command again to go on"),
        "{err}"
    );
    // The store is whole and the study goes on from it.
    let out = demcal()
        .args(["status".as_ref(), path.as_os_str()])
        .output()
        .unwrap();
    assert!(out.status.success());
    assert!(String::from_utf8_lossy(&out.stdout).contains("state: "));
}

#[test]
fn study_errors_are_one_line() {
    let dir = temp_dir("study-error");
    let path = dir.join("study.toml");
    std::fs::write(&path, slow_bowl().replace("\"rsm\",", "\"rsn\",")).unwrap();
    let out = demcal()
        .args(["run".as_ref(), path.as_os_str()])
        .output()
        .unwrap();
    // 2: a study file to fix, nothing ran.
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8(out.stderr).unwrap();
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(
        err.contains("plan[2].stage: unknown stage \"rsn\""),
        "{err}"
    );
    std::fs::write(&path, format!("backend = \"opencl\"\n{}", slow_bowl())).unwrap();
    let out = demcal()
        .args(["run".as_ref(), path.as_os_str()])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8(out.stderr).unwrap();
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(
        err.contains("study.toml: backend: expected \"cpu\" or \"gpu\", got \"opencl\""),
        "{err}"
    );
    let out = demcal()
        .args(["status".as_ref(), dir.join("nothing.toml").as_os_str()])
        .output()
        .unwrap();
    assert!(!out.status.success());
}
