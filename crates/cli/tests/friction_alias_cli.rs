//! `dynamic_friction` (or `kinetic_friction`) in a test file is read as rolling friction, and
//! the command says so once on standard error: papers mean sliding friction by those names as
//! often as EDEM's rolling friction.

mod common;

use common::{demcal, temp_dir};

#[test]
fn demcal_test_warns_once_that_dynamic_friction_is_rolling_friction() {
    let dir = temp_dir("alias");
    let quickstart = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../examples/quickstart/repose.toml");
    let text = std::fs::read_to_string(quickstart).unwrap().replacen(
        "rolling_friction = 0.1",
        "dynamic_friction = 0.1",
        1,
    );
    std::fs::write(dir.join("repose.toml"), text).unwrap();
    // An --out that is a file stops the command before it simulates, after the file is read.
    std::fs::write(dir.join("taken"), "").unwrap();
    let out = demcal()
        .arg("test")
        .arg(dir.join("repose.toml"))
        .arg("--out")
        .arg(dir.join("taken"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    let warning = format!(
        "warning: {}: interaction[0].dynamic_friction: read as rolling friction, as EDEM and the calibration papers use the name; sliding (kinetic) friction is static_friction here. Write rolling_friction to silence this warning",
        dir.join("repose.toml").display()
    );
    assert_eq!(
        err.lines()
            .filter(|l| l.starts_with("warning"))
            .collect::<Vec<_>>(),
        [warning.as_str()],
        "{err}"
    );
    assert!(!out.status.success());
    let _ = std::fs::remove_dir_all(&dir);
}
