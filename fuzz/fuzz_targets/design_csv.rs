//! Design and result tables (`demcal doe analyze`, `surrogate fit`): read, or refused in one
//! line naming the file.
#![no_main]
#[path = "common.rs"]
mod common;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    if let Err(e) = doe::data::DataTable::parse("design.csv", text) {
        common::one_line(&e, "design.csv");
    }
});
