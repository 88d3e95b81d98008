//! Verification cases V1-V6 and V8 of shared/spec/physics.md on the CPU back end; the cases are
//! `common/verification_cases.rs`, kept apart so that the GPU back end can run the same cases.

mod common;

fn backend() -> &'static str {
    "cpu"
}

include!("common/verification_cases.rs");
