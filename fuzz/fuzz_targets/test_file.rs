//! Virtual test files (`demcal test`): read and their settings checked, or refused in one line
//! naming the file.
#![no_main]
#[path = "common.rs"]
mod common;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let checked = virtual_tests::TestFile::parse("test.toml", text)
        .and_then(|f| virtual_tests::check_file(&f));
    if let Err(e) = checked {
        common::one_line(&e, "test.toml");
    }
});
