//! Property tests: study files, job files and lab curve CSVs with random edits are read or
//! refused in one line naming the file, never a panic (docs/reliability.md).

use proptest::prelude::*;
use std::path::{Path, PathBuf};
use study::Study;
use test_support::hostile::hostile;

const STUDY: &str = include_str!("../../../examples/quickstart/study.toml");

const LAB_CSV: &str = "displacement_mm,force_1,force_2\n0,0,0\n0.5,10.2,9.8\n1.0,20.5,19.7\n1.5,15.1,16.0\n2.0,3.2,2.9\n";

/// The quickstart's folder: its study names repose.toml there.
fn quickstart() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/quickstart/study.toml")
}

fn one_line(e: &str, file: &str) {
    assert!(!e.contains('\n'), "more than one line: {e}");
    assert!(e.contains(file), "does not name {file}: {e}");
}

/// A job file of the quickstart study, as `demcal run` writes it for a cluster node.
fn job_json() -> &'static str {
    static JOB: std::sync::OnceLock<String> = std::sync::OnceLock::new();
    JOB.get_or_init(|| {
        let study = Study::load(&quickstart()).unwrap();
        let r = study::replay(&study, &[], None).unwrap();
        study::Job::new(&study, &r.stages[0].runs[0]).to_json()
    })
}

proptest! {
    #![proptest_config(test_support::hostile::config(256))]

    #[test]
    fn edited_study_files_load_or_give_one_line(text in hostile(STUDY)) {
        if let Err(e) = Study::parse(&quickstart(), &text) {
            one_line(&e, "study.toml");
        }
    }

    #[test]
    fn edited_job_files_load_or_give_one_line(edits in hostile(job_json())) {
        let dir = std::env::temp_dir().join(format!("demcal-hostile-job-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("job.json");
        std::fs::write(&p, edits).unwrap();
        if let Err(e) = study::Job::load(&p) {
            one_line(&e, "job.json");
        }
    }

    #[test]
    fn edited_lab_curves_read_or_give_one_line(text in hostile(LAB_CSV)) {
        let dir = std::env::temp_dir().join(format!("demcal-hostile-csv-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("lab.csv");
        std::fs::write(&p, text).unwrap();
        if let Err(e) = study::lab_curve::read_csv(&p) {
            one_line(&e, "lab.csv");
        }
    }
}
