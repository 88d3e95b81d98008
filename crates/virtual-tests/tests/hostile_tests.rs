//! Property test: virtual test files with random edits are read and checked, or refused in one
//! line naming the file, never a panic (docs/reliability.md).

use proptest::prelude::*;
use test_support::hostile::hostile;
use virtual_tests::TestFile;

const REPOSE: &str = include_str!("../../../examples/quickstart/repose.toml");

proptest! {
    #![proptest_config(test_support::hostile::config(512))]

    #[test]
    fn edited_test_files_read_or_give_one_line(text in hostile(REPOSE)) {
        let checked = TestFile::parse("repose.toml", &text)
            .and_then(|f| virtual_tests::check_file(&f).map(|_| ()));
        if let Err(e) = checked {
            prop_assert!(!e.contains('\n') && e.contains("repose.toml"), "{}", e);
        }
    }
}

/// Found by the `test_file` fuzz target: a test name holding a line break made a two-line error.
#[test]
fn an_unknown_test_name_with_a_line_break_is_shown_on_one_line() {
    let e = TestFile::parse("t.toml", "test = \"angle\\nof_repose\"\n").unwrap_err();
    assert_eq!(
        e,
        "t.toml: test: unknown test \"angle\\nof_repose\" (expected one of: angle_of_repose, incline_tilt, incline_slide, shear, compression, bending, tension, cantilever, function)"
    );
}
