#![allow(dead_code)] // each target uses part of it
//! What every target asserts about a refusal: one line that names the file.

/// Panics (a crash to libFuzzer) unless `e` is one line starting with or naming `file`.
pub fn one_line(e: &str, file: &str) {
    assert!(!e.contains('\n'), "an error of more than one line: {e}");
    assert!(e.contains(file), "an error that does not name {file}: {e}");
}

/// The repository's examples folder, for files a study or scene names by relative path.
pub fn examples() -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples")
}
