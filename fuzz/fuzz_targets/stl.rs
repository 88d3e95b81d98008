//! STL meshes (scene geometry, `demcal shape`): binary or ASCII read into triangles, or refused
//! with one line.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let mut stl = std::io::Cursor::new(data);
    if let Err(e) = dem::geometry::stl_triangles(&mut stl, 0.001, glam::DVec3::ZERO) {
        assert!(!e.contains('\n'), "{e}");
    }
});
