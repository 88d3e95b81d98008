//! Lab force-displacement curves (a study's `[target] curve`, `demcal curve`): read into
//! replicates, or refused in one line naming the file.
#![no_main]
#[path = "common.rs"]
mod common;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Err(e) = study::lab_curve::parse_csv("lab.csv", data) {
        common::one_line(&e, "lab.csv");
    }
});
