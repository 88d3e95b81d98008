//! Verification cases V1-V6 and V8 of docs/physics.md on the CPU back end; the cases are
//! `common/verification_cases.rs` (which the GPU back end runs too) and
//! `common/verification_more.rs`.

mod common;

fn backend() -> &'static str {
    "cpu"
}

include!("common/verification_cases.rs");
include!("common/verification_more.rs");
