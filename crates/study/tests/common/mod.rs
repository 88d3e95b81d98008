//! What the study crate's integration tests share: writing a study file into a folder and
//! running it on this machine with two jobs, as `demcal run` does.

// Each test file uses what it needs of these.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::sync::Arc;

use study::RunOptions;

/// Writes `text` as `dir/study.toml` and returns its path.
pub fn write_study(dir: &Path, text: &str) -> PathBuf {
    let p = dir.join("study.toml");
    std::fs::write(&p, text).unwrap();
    p
}

/// Writes `text` as `dir/study.toml` and runs it with two jobs; the terminal text, or the error.
pub fn run_study(dir: &Path, text: &str) -> Result<String, String> {
    run_path(&write_study(dir, text), 2)
}

/// Runs the study file at `path` with `jobs` runs at once; the terminal text, or the error.
pub fn run_path(path: &Path, jobs: usize) -> Result<String, String> {
    study::run(
        path,
        &RunOptions {
            jobs,
            ..Default::default()
        },
        Arc::new(AtomicBool::new(false)),
    )
    .map_err(|e| e.to_string())
}
