//! Heap photos (`demcal lab photo-angle`): PNG or JPEG decoded within the pixel limit and
//! measured, or refused with one line.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    match lab::photo::decode(data) {
        Ok(img) => {
            if let Err(e) = lab::photo::measure(&img, &lab::photo::PhotoSettings::default()) {
                assert!(!e.contains('\n'), "{e}");
            }
        }
        Err(e) => assert!(!e.contains('\n'), "{e}"),
    }
});
