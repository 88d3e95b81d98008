//! `surrogate optimize` of an error column (issue 41): a model of an error that is never negative
//! in the table never reports a prediction below zero (it is clamped, and says so), and
//! `--target-of` models the response the error is computed from, so the answer is the interior
//! point where the response meets the lab value, not a corner where a model of the error dips
//! below zero.

use std::path::PathBuf;

use surrogate::commands::{optimize, ErrorOf, FitRequest, Goal, Model};
use surrogate::gp::Kernel;

fn write(name: &str, csv: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("demcal-error-objectives-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join(name);
    std::fs::write(&p, csv).unwrap();
    p
}

/// x on 0 .. 1 in 21 steps, the response r = 30 + 20 x, whose lab value 38 is met at x = 0.4,
/// and its relative error |r - 38| / 38 (in % when `percent`): V-shaped, its point inside.
fn one_factor(name: &str, percent: bool) -> PathBuf {
    let mut csv = String::from("x,r,rel_error\n");
    for i in 0..=20 {
        let x = i as f64 / 20.0;
        let r = 30.0 + 20.0 * x;
        let e = (r - 38.0).abs() / 38.0 * if percent { 100.0 } else { 1.0 };
        csv.push_str(&format!("{x},{r},{e}\n"));
    }
    write(name, &csv)
}

/// x and z on a 6 x 6 grid of 0 .. 1 cut to x + z <= 1.4 (the corner x = z = 1 unobserved), the
/// response r = 30 + 5 (x + z), met at x + z = 1.6, and its relative error, which falls all the
/// way to the cut: every model carries that fall on to the corner, 2 / 38 below zero.
fn cut_corner(name: &str) -> PathBuf {
    let mut csv = String::from("x,z,r,rel_error\n");
    for i in 0..6 {
        for j in 0..6 {
            let (x, z) = (i as f64 / 5.0, j as f64 / 5.0);
            if x + z <= 1.4 + 1e-9 {
                let r = 30.0 + 5.0 * (x + z);
                csv.push_str(&format!("{x},{z},{r},{}\n", (r - 38.0).abs() / 38.0));
            }
        }
    }
    write(name, &csv)
}

fn request(data: PathBuf, factors: &str, model: Model) -> FitRequest {
    FitRequest {
        data,
        response: "rel_error".into(),
        factors: Some(factors.split(',').map(String::from).collect()),
        model,
        seed: 1,
        train_fraction: 0.8,
    }
}

fn json(out: &str) -> serde_json::Value {
    serde_json::from_str(out).unwrap()
}

#[test]
fn minimising_an_error_through_its_response_finds_the_interior_point() {
    let r = ErrorOf {
        response: "r".into(),
        lab: 38.0,
    };
    for (percent, scale) in [(false, 1.0), (true, 100.0)] {
        let p = one_factor(&format!("one-{percent}.csv"), percent);
        for model in [Model::Gp(Kernel::Matern52), Model::Bp] {
            let req = request(p.clone(), "x", model);
            let j = json(&optimize(&req, Goal::Minimize, Some(&r), true).unwrap());
            let x = j["solution"]["x"].as_f64().unwrap();
            let e = j["predicted"].as_f64().unwrap();
            let y = j["predicted_response"].as_f64().unwrap();
            // The response is a line, which every model fits closely: r = 38 at x = 0.4.
            assert!((x - 0.4).abs() < 0.005, "{model:?}: x = {x}");
            assert!((y - 38.0).abs() < 1e-3, "{model:?}: r = {y}");
            assert!((0.0..1e-4 * scale).contains(&e), "{model:?}: error {e}");
            assert!((e - scale * (y - 38.0).abs() / 38.0).abs() < 1e-12);
            assert_eq!(j["modelled"], "r");
            assert_eq!(j["target_reached"], true);
        }
        let req = request(p.clone(), "x", Model::Gp(Kernel::Matern52));
        let text = optimize(&req, Goal::Minimize, Some(&r), false).unwrap();
        let formula = if percent {
            "surrogate of r, for rel_error = |r - 38| / 38 x 100 (minimize)"
        } else {
            "surrogate of r, for rel_error = |r - 38| / 38 (minimize)"
        };
        assert!(text.contains(formula), "{text}");
        assert!(text.contains("predicted r = 38.000"), "{text}");
    }
}

#[test]
fn a_model_of_an_error_is_never_reported_below_zero() {
    // The issue's case: minimising the model of the error lands on the corner the table lacks,
    // where the model is below zero. It is reported as 0, with the reason.
    let p = cut_corner("cut.csv");
    let models = [Model::Gp(Kernel::Matern52), Model::Bp, Model::GaBp];
    for model in models {
        let req = request(p.clone(), "x,z", model);
        let j = json(&optimize(&req, Goal::Minimize, None, true).unwrap());
        let raw = j["model_prediction"].as_f64().unwrap();
        let (x, z) = (
            j["solution"]["x"].as_f64().unwrap(),
            j["solution"]["z"].as_f64().unwrap(),
        );
        assert!(
            x > 0.99 && z > 0.99,
            "{model:?}: the corner, not x {x} z {z}"
        );
        // The fall of the error, 5 / 38 per unit of x + z, carried from 1.4 to 2.
        assert!((raw + 2.0 / 38.0).abs() < 0.006, "{model:?}: {raw}");
        assert_eq!(j["predicted"].as_f64(), Some(0.0), "{model:?}");
        assert_eq!(j["clamped_at_zero"], true, "{model:?}");
        let text = optimize(&req, Goal::Minimize, None, false).unwrap();
        assert!(text.contains("predicted rel_error = 0.000000"), "{text}");
        assert!(
            text.contains("but rel_error is never below 0 in the table (its least value is 0.026316): reported as 0")
                && text.contains("--target-of RESPONSE --value LAB"),
            "{text}"
        );
    }
    // Through the response every model finds a point of the line x + z = 1.6 instead, where
    // the error is 0.
    let r = ErrorOf {
        response: "r".into(),
        lab: 38.0,
    };
    for model in models {
        let req = request(p.clone(), "x,z", model);
        let j = json(&optimize(&req, Goal::Minimize, Some(&r), true).unwrap());
        let (x, z) = (
            j["solution"]["x"].as_f64().unwrap(),
            j["solution"]["z"].as_f64().unwrap(),
        );
        let true_error = (30.0 + 5.0 * (x + z) - 38.0).abs() / 38.0;
        assert!(true_error < 5e-3, "{model:?}: x {x} z {z}: {true_error}");
        let e = j["predicted"].as_f64().unwrap();
        assert!((0.0..1e-4).contains(&e), "{model:?}: {e}");
    }
}

#[test]
fn target_of_checks_the_error_column_and_its_arguments() {
    let p = one_factor("check.csv", false);
    let req = request(p.clone(), "x", Model::Gp(Kernel::Matern52));
    let wrong = ErrorOf {
        response: "r".into(),
        lab: 40.0,
    };
    let e = optimize(&req, Goal::Minimize, Some(&wrong), false).unwrap_err();
    // Row 21, the furthest: r = 50, whose error against 38 is 12/38; against 40, 10/40.
    assert!(
        e.contains("column 'rel_error' is not |r - 40| / 40 (as a fraction or in %): row 21 has 0.3157894736842105 where that gives 0.25"),
        "{e}"
    );
    let r = ErrorOf {
        response: "r".into(),
        lab: 38.0,
    };
    let e = optimize(&req, Goal::Maximize, Some(&r), false).unwrap_err();
    assert!(e.contains("give --goal minimize"), "{e}");
    let zero = ErrorOf {
        response: "r".into(),
        lab: 0.0,
    };
    let e = optimize(&req, Goal::Minimize, Some(&zero), false).unwrap_err();
    assert!(
        e.contains("--value 0: expected a non-zero lab value"),
        "{e}"
    );
    let mut with_error = req.clone();
    with_error.factors = Some(vec!["x".into(), "rel_error".into()]);
    let e = optimize(&with_error, Goal::Minimize, Some(&r), false).unwrap_err();
    assert!(e.contains("'rel_error' is the error minimised"), "{e}");
    // Without --factors neither the error nor its response is a factor.
    let mut default = req.clone();
    default.factors = None;
    let j = json(&optimize(&default, Goal::Minimize, Some(&r), true).unwrap());
    let factors: Vec<&String> = j["solution"].as_object().unwrap().keys().collect();
    assert_eq!(factors, ["x"]);
}
