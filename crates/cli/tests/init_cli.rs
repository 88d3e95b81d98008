//! `demcal init KIND DIR`: each kind writes a test file and a study that read and pass their
//! checks without simulating (the same dry check as the examples: `demcal status` and
//! `Study::check_scene`), and a second init into the same folder refuses to overwrite them.

mod common;

use common::{demcal, temp_dir};

const KINDS: [(&str, &str, &str); 5] = [
    ("repose", "repose.toml", "angle_of_repose"),
    ("incline", "incline.toml", "incline_tilt"),
    ("shear", "shear.toml", "shear"),
    ("compression", "compression.toml", "compression"),
    ("bending", "bending.toml", "bending"),
];

#[test]
fn each_kind_writes_a_study_that_passes_its_checks_and_is_never_overwritten() {
    let root = temp_dir("init");
    for (kind, test_file, test) in KINDS {
        let dir = root.join(kind);
        let out = demcal().args(["init", kind]).arg(&dir).output().unwrap();
        let stdout = String::from_utf8_lossy(&out.stdout);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        assert!(
            stdout.starts_with(&format!(
                "wrote {} (the virtual test) and {} (the calibration)",
                dir.join(test_file).display(),
                dir.join("study.toml").display()
            )),
            "{stdout}"
        );
        let text = std::fs::read_to_string(dir.join(test_file)).unwrap();
        assert!(text.contains(&format!("test = \"{test}\"")), "{text}");
        // Every key is commented for its reader: the templates carry more comment than TOML.
        let comments = text.lines().filter(|l| l.contains('#')).count();
        assert!(
            comments * 2 > text.lines().count(),
            "{kind}: {comments} comments"
        );

        let study = dir.join("study.toml");
        let status = demcal().arg("status").arg(&study).output().unwrap();
        assert!(
            status.status.success(),
            "{kind}: {}",
            String::from_utf8_lossy(&status.stderr)
        );
        assert!(String::from_utf8_lossy(&status.stdout).contains("not started"));
        let loaded = study::Study::load(&study).unwrap_or_else(|e| panic!("{kind}: {e}"));
        assert_eq!(loaded.tests[0].kind(), test);
        loaded
            .check_scene()
            .unwrap_or_else(|e| panic!("{kind}: {e}"));

        // A second init refuses, naming both files, and leaves the edited one as it was.
        std::fs::write(dir.join(test_file), "# mine\n").unwrap();
        let again = demcal().args(["init", kind]).arg(&dir).output().unwrap();
        let err = String::from_utf8_lossy(&again.stderr);
        assert_eq!(again.status.code(), Some(1), "{err}");
        assert_eq!(
            err.trim_end(),
            format!(
                "error: {} and {} already exist: demcal init writes new files only (move them or give another folder)",
                dir.join(test_file).display(),
                study.display()
            )
        );
        assert_eq!(
            std::fs::read_to_string(dir.join(test_file)).unwrap(),
            "# mine\n"
        );
    }
    let _ = std::fs::remove_dir_all(&root);
}

#[test]
fn init_writes_into_the_current_folder_by_default_and_names_a_single_existing_file() {
    let dir = temp_dir("init-here");
    std::fs::write(dir.join("study.toml"), "name = \"mine\"\n").unwrap();
    let out = demcal()
        .args(["init", "repose"])
        .current_dir(&dir)
        .output()
        .unwrap();
    assert_eq!(
        String::from_utf8_lossy(&out.stderr).trim_end(),
        "error: ./study.toml already exists: demcal init writes new files only (move it or give another folder)"
    );
    assert!(!dir.join("repose.toml").exists());
    std::fs::remove_file(dir.join("study.toml")).unwrap();
    let out = demcal()
        .args(["init", "repose"])
        .current_dir(&dir)
        .output()
        .unwrap();
    assert!(out.status.success());
    assert!(dir.join("repose.toml").is_file() && dir.join("study.toml").is_file());
    let bad = demcal().args(["init", "heap"]).output().unwrap();
    let err = String::from_utf8_lossy(&bad.stderr);
    assert_eq!(bad.status.code(), Some(2), "{err}");
    assert!(
        err.contains("invalid value 'heap'") && err.contains("demcal init --help"),
        "{err}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}
