//! Every example runs wherever its folder is copied: each folder under examples/ that holds a
//! study is copied to a temporary folder, as a user would copy it, and each study in the copy
//! must read and pass its checks without simulating (`demcal status`, and the library's
//! `Study::check_scene`, which builds each test's starting scene as the first run would). A
//! study that names a file outside its folder (`../quickstart/repose.toml`) fails here.

mod common;

use common::{demcal, temp_dir};
use std::path::{Path, PathBuf};

fn examples() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples")
}

/// What `demcal run` leaves beside a study, which a fresh copy from the repository lacks.
fn generated(name: &str) -> bool {
    name.starts_with("study.db")
        || name.ends_with(".runs")
        || name.ends_with("_out")
        || name == "report"
}

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for entry in std::fs::read_dir(from).unwrap() {
        let entry = entry.unwrap();
        let name = entry.file_name().to_string_lossy().into_owned();
        if generated(&name) {
            continue;
        }
        let kind = entry.file_type().unwrap();
        if kind.is_dir() {
            copy_dir(&entry.path(), &to.join(&name));
        } else if kind.is_file() {
            std::fs::copy(entry.path(), to.join(&name)).unwrap();
        }
    }
}

/// The study files under `dir`, sorted.
fn studies(dir: &Path) -> Vec<PathBuf> {
    let mut found = Vec::new();
    for entry in std::fs::read_dir(dir).unwrap() {
        let entry = entry.unwrap();
        let name = entry.file_name().to_string_lossy().into_owned();
        if entry.file_type().unwrap().is_dir() && !generated(&name) {
            found.extend(studies(&entry.path()));
        } else if name == "study.toml" {
            found.push(entry.path());
        }
    }
    found.sort();
    found
}

/// The `(study, parameter)` of each `[[import]]` table of a study's text.
fn imports(text: &str) -> Vec<(String, String)> {
    let value = |line: &str, key: &str| {
        let rest = line.trim().strip_prefix(key)?.trim().strip_prefix('=')?;
        Some(rest.trim().trim_matches('"').to_string())
    };
    let mut out = Vec::new();
    for block in text.split("[[import]]").skip(1) {
        let block = block.split("\n[").next().unwrap();
        let study = block.lines().find_map(|l| value(l, "study"));
        let parameter = block.lines().find_map(|l| value(l, "parameter"));
        out.push((study.unwrap(), parameter.unwrap()));
    }
    out
}

/// `demcal status` on the copied study must succeed, and its scene must build.
fn dry_check(study: &Path) {
    let out = demcal().arg("status").arg(study).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        out.status.success(),
        "demcal status {}: {err}",
        study.display()
    );
    assert!(
        String::from_utf8_lossy(&out.stdout).contains("not started"),
        "{}",
        study.display()
    );
    let loaded = study::Study::load(study).unwrap_or_else(|e| panic!("{e}"));
    loaded
        .check_scene()
        .unwrap_or_else(|e| panic!("{}: {e}", study.display()));
}

#[test]
fn every_example_with_a_study_runs_from_a_copy_of_its_folder() {
    let root = temp_dir("examples-copy");
    let mut checked = Vec::new();
    for entry in std::fs::read_dir(examples()).unwrap() {
        let folder = entry.unwrap().path();
        if !folder.is_dir() || studies(&folder).is_empty() {
            continue;
        }
        let name = folder.file_name().unwrap().to_owned();
        // Each in a folder of its own: beside the other copies, `../quickstart/repose.toml`
        // would still be found.
        let copy = root.join(&name).join(&name);
        copy_dir(&folder, &copy);
        for study in studies(&copy) {
            let text = std::fs::read_to_string(&study).unwrap();
            // A study that imports another's result needs that study run first: it says so,
            // and reads once the other's summary is there (as the user's run would leave it).
            for (other, parameter) in imports(&text) {
                let dir = study.parent().unwrap();
                let out = demcal().arg("status").arg(&study).output().unwrap();
                let err = String::from_utf8_lossy(&out.stderr);
                assert!(!out.status.success());
                assert!(
                    err.contains("run that study first") && err.contains(&other),
                    "{err}"
                );
                let report = dir.join(&other).parent().unwrap().join("report");
                std::fs::create_dir_all(&report).unwrap();
                std::fs::write(
                    report.join("summary.json"),
                    format!(r#"{{"state": "complete", "calibrated": {{"{parameter}": 0.5}}}}"#),
                )
                .unwrap();
            }
            dry_check(&study);
            checked.push(
                study
                    .strip_prefix(root.join(&name))
                    .unwrap()
                    .display()
                    .to_string(),
            );
        }
    }
    // The examples this test is about: a folder that loses its study would drop out silently.
    for must in [
        "quickstart/study.toml",
        "quickstart-bayesopt/study.toml",
        "quickstart-smc/study.toml",
        "maize-kernel-repose/study.toml",
        "maize-kernel-multi/study.toml",
        "maize-kernel-chained/heap/study.toml",
        "maize-kernel-chained/incline/study.toml",
        "silage-repose/study.toml",
        "stalks/twin/study.toml",
    ] {
        assert!(
            checked.iter().any(|c| c == must),
            "{must} not checked: {checked:?}"
        );
    }
    let _ = std::fs::remove_dir_all(&root);
}

/// The text of a TOML file below its leading comment block.
fn body(path: &Path) -> String {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let start = text
        .lines()
        .take_while(|l| l.starts_with('#'))
        .map(|l| l.len() + 1)
        .sum::<usize>();
    text[start..].to_string()
}

/// The test files an example carries as its own copy are the originals below their header: a
/// change to one (examples/tests/maize_heap.toml) must reach the example that runs it.
#[test]
fn the_examples_copies_of_test_files_equal_their_originals() {
    let ex = examples();
    let mut pairs = 0;
    for study in studies(&ex) {
        for entry in std::fs::read_dir(study.parent().unwrap()).unwrap() {
            let path = entry.unwrap().path();
            let text = std::fs::read_to_string(&path).unwrap_or_default();
            let Some(rest) = text.strip_prefix("# A copy of ") else {
                continue;
            };
            let original = rest.split(',').next().unwrap();
            let original = ex.join(original.strip_prefix("examples/").unwrap());
            assert_eq!(
                body(&path),
                body(&original),
                "{} differs from {} below the header",
                path.display(),
                original.display()
            );
            pairs += 1;
        }
    }
    assert_eq!(pairs, 7, "the copies of test files in examples/");
}
