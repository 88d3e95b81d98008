//! Study files (`demcal run`): read and checked with the quickstart's folder (its test and lab
//! files), or refused in one line naming the file.
#![no_main]
#[path = "common.rs"]
mod common;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let path = common::examples().join("quickstart/study.toml");
    if let Err(e) = study::Study::parse(&path, text) {
        common::one_line(&e, "study.toml");
    }
});
