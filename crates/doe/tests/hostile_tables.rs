//! Property test: design data tables with random edits are read, and their columns taken, or
//! refused in one line naming the file, never a panic (docs/reliability.md).

use doe::data::DataTable;
use proptest::prelude::*;
use test_support::hostile::hostile;

const CCD: &str = include_str!("data/silage-repose-ccd.csv");

proptest! {
    #![proptest_config(test_support::hostile::config(512))]

    #[test]
    fn edited_tables_read_or_give_one_line(text in hostile(CCD)) {
        match DataTable::parse("ccd.csv", &text) {
            Ok(t) => {
                for name in ["D", "E", "G", "angle_deg", "run"] {
                    if let Err(e) = t.column(name) {
                        prop_assert!(!e.contains('\n') && e.starts_with("ccd.csv"), "{}", e);
                    }
                }
            }
            Err(e) => prop_assert!(!e.contains('\n') && e.starts_with("ccd.csv"), "{}", e),
        }
    }
}
