//! Verification cases V1-V6 and V8 of docs/physics.md on the GPU back end, with the same
//! tolerances as on the CPU (`crates/dem/tests/verification.rs` includes the same cases). On a
//! machine without a GPU they run on Mesa's lavapipe; with no adapter at all they are skipped,
//! unless `DEMCAL_REQUIRE_GPU=1` (as CI sets) makes that a failure.

#[path = "../../dem/tests/common/mod.rs"]
mod common;

/// "gpu" when a GPU context can be made, else (unless `DEMCAL_REQUIRE_GPU` is set) "cpu", so that
/// the cases still run.
fn backend() -> &'static str {
    static NAME: std::sync::OnceLock<&'static str> = std::sync::OnceLock::new();
    NAME.get_or_init(|| {
        dem_gpu::register();
        match dem_gpu::shared_context() {
            Ok(c) => {
                eprintln!("GPU: {}", c.adapter());
                "gpu"
            }
            Err(e) if std::env::var_os("DEMCAL_REQUIRE_GPU").is_some() => {
                panic!("DEMCAL_REQUIRE_GPU is set and there is no GPU: {e}")
            }
            Err(e) => {
                eprintln!("no GPU ({e}): the cases run on the CPU");
                "cpu"
            }
        }
    })
}

include!("../../dem/tests/common/verification_cases.rs");
