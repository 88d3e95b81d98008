//! `demcal init KIND [DIR]`: a commented virtual test file and a study file to start a
//! calibration from, so that a new user edits a working pair rather than writing one from the
//! reference. The templates are files under `crates/cli/templates/`, embedded in the binary; a
//! test (`tests/init_cli.rs`) checks that each one reads and builds without simulating.

use std::io::Write;
use std::path::Path;

/// One kind of starting point: the test file's name and text, and the study's text.
struct Template {
    kind: &'static str,
    test_file: &'static str,
    test: &'static str,
    study: &'static str,
}

const TEMPLATES: &[Template] = &[
    Template {
        kind: "repose",
        test_file: "repose.toml",
        test: include_str!("../templates/repose/repose.toml"),
        study: include_str!("../templates/repose/study.toml"),
    },
    Template {
        kind: "incline",
        test_file: "incline.toml",
        test: include_str!("../templates/incline/incline.toml"),
        study: include_str!("../templates/incline/study.toml"),
    },
    Template {
        kind: "shear",
        test_file: "shear.toml",
        test: include_str!("../templates/shear/shear.toml"),
        study: include_str!("../templates/shear/study.toml"),
    },
    Template {
        kind: "compression",
        test_file: "compression.toml",
        test: include_str!("../templates/compression/compression.toml"),
        study: include_str!("../templates/compression/study.toml"),
    },
    Template {
        kind: "bending",
        test_file: "bending.toml",
        test: include_str!("../templates/bending/bending.toml"),
        study: include_str!("../templates/bending/study.toml"),
    },
];

/// The kinds `demcal init` writes, in the order its help lists them.
pub const KINDS: [&str; 5] = ["repose", "incline", "shear", "compression", "bending"];

/// Writes the test file and `study.toml` of `kind` into `dir` (created if missing). Refuses,
/// naming them, when either file exists: a user's edited file must never be overwritten.
pub fn run(kind: &str, dir: &Path) -> Result<(), String> {
    let t = TEMPLATES
        .iter()
        .find(|t| t.kind == kind)
        .ok_or_else(|| format!("{kind}: expected one of {}", KINDS.join(", ")))?;
    let files = [(t.test_file, t.test), ("study.toml", t.study)];
    let existing: Vec<String> = files
        .iter()
        .map(|(name, _)| dir.join(name))
        .filter(|p| p.symlink_metadata().is_ok())
        .map(|p| p.display().to_string())
        .collect();
    if !existing.is_empty() {
        return Err(format!(
            "{} already exist{}: demcal init writes new files only (move {} or give another folder)",
            existing.join(" and "),
            if existing.len() == 1 { "s" } else { "" },
            if existing.len() == 1 { "it" } else { "them" }
        ));
    }
    std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    for (name, text) in files {
        let path = dir.join(name);
        // create_new: a file that appeared since the check above is refused, not replaced.
        std::fs::OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(&path)
            .and_then(|mut f| f.write_all(text.as_bytes()))
            .map_err(|e| format!("{}: {e}", path.display()))?;
    }
    let test = dir.join(t.test_file);
    let study = dir.join("study.toml");
    println!(
        "wrote {} (the virtual test) and {} (the calibration); next:\n  demcal test {}            # one run of the test, to check it\n  demcal status {}          # the study and its test checked, without simulating\n  demcal run {} --jobs 2    # the calibration; then open its report/index.html",
        test.display(),
        study.display(),
        test.display(),
        study.display(),
        study.display()
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    #[test]
    fn every_kind_has_a_template_whose_test_file_the_study_names() {
        assert_eq!(super::TEMPLATES.len(), super::KINDS.len());
        for (t, kind) in super::TEMPLATES.iter().zip(super::KINDS) {
            assert_eq!(t.kind, kind);
            let line = format!("test = \"{}\"", t.test_file);
            assert!(t.study.contains(&line), "{kind}: study lacks {line}");
        }
    }
}
