//! Heaps as spheres (`demcal heap-angle`): a LAMMPS/LIGGGHTS dump or a CSV read and measured,
//! or refused in one line naming the file.
#![no_main]
#[path = "common.rs"]
mod common;
use libfuzzer_sys::fuzz_target;
use virtual_tests::repose::{measure, parse_spheres, ReposeMeasurement};

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    match parse_spheres("heap.dump", text) {
        Ok((positions, radii)) => {
            if let Err(e) = measure(&positions, &radii, &ReposeMeasurement::default()) {
                assert!(!e.contains('\n'), "{e}");
            }
        }
        Err(e) => common::one_line(&e, "heap.dump"),
    }
});
