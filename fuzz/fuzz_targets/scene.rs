//! Scene files (`demcal simulate`): read, checked and built (particles placed, nothing
//! simulated), or refused in one line naming the file.
#![no_main]
#[path = "common.rs"]
mod common;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return; // refused by dem::files::read_text before parsing
    };
    let dir = common::examples().join("scenes");
    if let Err(e) = dem::scene::Scene::from_toml(text, "scene.toml", &dir) {
        common::one_line(&e.to_string(), "scene.toml");
    }
});
