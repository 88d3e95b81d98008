//! Job files (`demcal run-one`, what a cluster node reads): read and checked, or refused in one
//! line naming the file.
#![no_main]
#[path = "common.rs"]
mod common;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    if let Err(e) = study::Job::parse("job.json", text) {
        common::one_line(&e, "job.json");
    }
});
