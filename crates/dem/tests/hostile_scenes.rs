//! Property test: scene files with random edits are read into a scene or refused in one line
//! naming the file, never a panic (docs/reliability.md).

use dem::scene::Scene;
use proptest::prelude::*;
use std::path::Path;
use test_support::hostile::hostile;

const CHUTE: &str = include_str!("../../../examples/scenes/chute.toml");
const BONDED: &str = include_str!("../../../examples/scenes/bonded.toml");

fn read(text: &str) {
    let dir = Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../examples/scenes"
    ));
    if let Err(e) = Scene::from_toml(text, "scene.toml", dir) {
        let line = e.to_string();
        assert!(!line.contains('\n'), "more than one line: {line}");
        assert!(line.starts_with("scene.toml"), "{line}");
    }
}

proptest! {
    #![proptest_config(test_support::hostile::config(256))]

    #[test]
    fn edited_scenes_load_or_give_one_line(text in hostile(CHUTE)) {
        read(&text);
    }

    #[test]
    fn edited_bonded_scenes_load_or_give_one_line(text in hostile(BONDED)) {
        read(&text);
    }
}

/// Found by the `scene` fuzz target: a motion type holding a line break made a two-line error.
#[test]
fn a_value_with_a_line_break_is_quoted_on_one_line() {
    let text = CHUTE.replacen(
        "[[geometry]]",
        "[[geometry]]\nmotion = [{ type = \"tr\\nslation\" }]",
        1,
    );
    read(&text);
    let Err(e) = Scene::from_toml(&text, "scene.toml", Path::new(".")) else {
        panic!("accepted");
    };
    let e = e.to_string();
    assert!(e.contains("unknown motion \"tr\\nslation\""), "{e}");
}
