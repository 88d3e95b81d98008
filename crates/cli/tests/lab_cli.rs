//! `demcal lab`: the photo angle as JSON on a heap drawn at known angles, the calculators'
//! formulas, and one-line errors.

use std::process::Command;

fn demcal(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_demcal"))
        .args(args)
        .output()
        .unwrap()
}

#[test]
fn photo_angle_prints_both_flanks_as_json_and_draws_its_check() {
    let dir = std::env::temp_dir().join(format!("demcal-lab-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    // A dark heap on white, flanks at 32 and 28 degrees, base on row 380.
    let (tl, tr) = (32f64.to_radians().tan(), 28f64.to_radians().tan());
    let img = image::GrayImage::from_fn(700, 420, |x, y| {
        let (x, height) = (x as f64, 380.0 - y as f64);
        let z = (200.0 - (330.0 - x).abs() * if x < 330.0 { tl } else { tr }).min(190.0);
        image::Luma([if height >= 0.0 && height <= z {
            60
        } else {
            220
        }])
    });
    let photo = dir.join("heap.png");
    img.save(&photo).unwrap();
    let check = dir.join("check.png");
    let out = demcal(&[
        "lab",
        "photo-angle",
        photo.to_str().unwrap(),
        "--json",
        "--debug",
        check.to_str().unwrap(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let (l, r, m) = (
        json["left_deg"].as_f64().unwrap(),
        json["right_deg"].as_f64().unwrap(),
        json["mean_deg"].as_f64().unwrap(),
    );
    assert!((l - 32.0).abs() < 1.0 && (r - 28.0).abs() < 1.0, "{l} {r}");
    assert!((m - 0.5 * (l + r)).abs() < 1e-9);
    assert_eq!(image::open(&check).unwrap().width(), 700);
    // A wrong crop and a file that is not an image: one line each.
    for (args, says) in [
        (
            vec!["--crop", "1,2,3"],
            "--crop 1,2,3: expected x,y,width,height",
        ),
        (
            vec!["--crop", "650,0,100,100"],
            "outside the 700 x 420 pixel image",
        ),
    ] {
        let mut a = vec!["lab", "photo-angle", photo.to_str().unwrap()];
        a.extend(args);
        let out = demcal(&a);
        let err = String::from_utf8(out.stderr).unwrap();
        assert!(
            !out.status.success() && err.lines().count() == 1 && err.contains(says),
            "{err}"
        );
    }
    std::fs::write(dir.join("not.png"), "text").unwrap();
    let out = demcal(&["lab", "photo-angle", dir.join("not.png").to_str().unwrap()]);
    let err = String::from_utf8(out.stderr).unwrap();
    assert!(
        err.contains("cannot read the image") && err.lines().count() == 1,
        "{err}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn calculators_print_the_formula_they_used() {
    for (args, line) in [
        (
            vec!["friction", "--tilt-deg", "28.6"],
            "mu_s = tan(angle) = tan(28.6 deg) = 0.5452",
        ),
        (
            vec![
                "modulus",
                "--slope",
                "1e5",
                "--length",
                "0.02",
                "--diameter",
                "0.01",
                "--poisson",
                "0.31",
            ],
            "G = E / (2 (1 + nu)) = 2.5465e7 Pa / (2 x (1 + 0.31)) = 9.7194e6 Pa",
        ),
        (
            vec!["moisture", "--wet", "0.1", "--dry", "0.0635"],
            "= 36.50 %",
        ),
        (
            vec![
                "bulk-density",
                "--filled",
                "1.5",
                "--empty",
                "0.5",
                "--volume",
                "0.001",
            ],
            "= 1000.0000 kg/m^3",
        ),
        (
            vec!["relative-error", "--simulated", "27.67", "--lab", "27.35"],
            "= 1.170 %",
        ),
    ] {
        let mut a = vec!["lab"];
        a.extend(args);
        let out = demcal(&a);
        let text = String::from_utf8(out.stdout).unwrap();
        assert!(out.status.success() && text.contains(line), "{a:?}: {text}");
    }
    let out = demcal(&["lab", "friction", "--tilt-deg", "90"]);
    let err = String::from_utf8(out.stderr).unwrap();
    assert!(
        err.starts_with("error: --tilt-deg: expected an angle between 0 and 90"),
        "{err}"
    );
}
