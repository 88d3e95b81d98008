//! The genetic algorithm, BP / GA-BP training and the GA-BP-GA target search, on known functions
//! and on the silage angle-of-repose CCD of the published GA-BP-GA calibration.

use std::path::PathBuf;
use std::time::Instant;

use surrogate::genetic::{minimize, GaOptions};
use surrogate::network::{search_target, train, BpOptions};

/// Axial distance of the rotatable three-factor CCD.
const ALPHA: f64 = 1.68179;
/// The lab angle of repose the published GA-BP-GA calibration aimed at (deg).
const LAB_ANGLE: f64 = 38.65;

/// The 23 runs of the published silage CCD (`crates/doe/tests/data/silage-repose-ccd.csv`, the
/// reference data of docs/calibration.md): coded D, E, G and the angle (deg).
fn silage() -> (Vec<Vec<f64>>, Vec<f64>) {
    let path =
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../doe/tests/data/silage-repose-ccd.csv");
    let text = std::fs::read_to_string(&path)
        .unwrap_or_else(|e| panic!("reading {}: {e}", path.display()));
    let mut lines = text.lines();
    assert_eq!(lines.next().map(str::trim), Some("run,D,E,G,angle_deg"));
    let (mut x, mut y) = (Vec::new(), Vec::new());
    for line in lines.filter(|l| !l.trim().is_empty()) {
        let v: Vec<f64> = line.split(',').map(|s| s.trim().parse().unwrap()).collect();
        x.push(v[1..4].to_vec());
        y.push(v[4]);
    }
    assert_eq!(x.len(), 23);
    (x, y)
}

fn sphere(x: &[f64]) -> f64 {
    x.iter().map(|v| (v - 0.5).powi(2)).sum()
}

fn rastrigin(x: &[f64]) -> f64 {
    10.0 * x.len() as f64
        + x.iter()
            .map(|v| v * v - 10.0 * (2.0 * std::f64::consts::PI * v).cos())
            .sum::<f64>()
}

#[test]
fn ga_minimises_sphere_and_rastrigin() {
    let bounds = [(-5.12, 5.12); 3];
    let r = minimize(&bounds, sphere, &GaOptions::search_default(1)).unwrap();
    assert!(r.value < 1e-6, "sphere {}", r.value);
    assert!(
        r.best.iter().all(|v| (v - 0.5).abs() < 1e-3),
        "{:?}",
        r.best
    );
    assert_eq!(r.history.len(), 100);
    assert!(r.history.windows(2).all(|w| w[1] <= w[0]));
    assert_eq!(*r.history.last().unwrap(), r.value);

    for seed in 0..5 {
        let r = minimize(&bounds, rastrigin, &GaOptions::weights_default(seed)).unwrap();
        assert!(
            r.value < 1e-4,
            "seed {seed}: rastrigin {} at {:?}",
            r.value,
            r.best
        );
        assert!(r.history.windows(2).all(|w| w[1] <= w[0]));
    }
}

#[test]
fn ga_is_deterministic_and_stays_in_the_box() {
    let bounds = [(-1.0, 2.0), (0.5, 0.5), (3.0, 4.0)];
    let mut calls = 0;
    let a = minimize(
        &bounds,
        |x| {
            calls += 1;
            assert!(x
                .iter()
                .zip(&bounds)
                .all(|(v, (lo, hi))| lo <= v && v <= hi));
            // A NaN region must not break the search.
            if x[0] > 1.5 {
                f64::NAN
            } else {
                (x[0] + 2.0).powi(2) + x[2]
            }
        },
        &GaOptions::search_default(9),
    )
    .unwrap();
    assert_eq!(calls, 100 * 101 - 2 * 100);
    let b = minimize(
        &bounds,
        |x| {
            if x[0] > 1.5 {
                f64::NAN
            } else {
                (x[0] + 2.0).powi(2) + x[2]
            }
        },
        &GaOptions::search_default(9),
    )
    .unwrap();
    assert_eq!(a.best, b.best);
    assert_eq!(a.value.to_bits(), b.value.to_bits());
    assert_eq!(a.history, b.history);
    // Minimum at the box's corner (-1, 0.5, 3): value 1 + 3.
    assert!((a.value - 4.0).abs() < 1e-6, "{}", a.value);
}

#[test]
fn ga_rejects_bad_input() {
    let f = |x: &[f64]| x[0];
    let ok = GaOptions::search_default(0);
    assert!(minimize(&[], f, &ok).unwrap_err().contains("at least one"));
    assert!(minimize(&[(1.0, 0.0)], f, &ok)
        .unwrap_err()
        .contains("lower <= upper"));
    assert!(minimize(&[(0.0, f64::INFINITY)], f, &ok).is_err());
    assert!(minimize(&[(f64::NAN, 1.0)], f, &ok).is_err());
    let small = GaOptions {
        population: 1,
        ..ok.clone()
    };
    assert!(minimize(&[(0.0, 1.0)], f, &small)
        .unwrap_err()
        .contains("population"));
    let bad_p = GaOptions {
        mutation: 1.5,
        ..ok.clone()
    };
    assert!(minimize(&[(0.0, 1.0)], f, &bad_p)
        .unwrap_err()
        .contains("mutation"));
    let bad_c = GaOptions {
        crossover: f64::NAN,
        ..ok.clone()
    };
    assert!(minimize(&[(0.0, 1.0)], f, &bad_c)
        .unwrap_err()
        .contains("crossover"));
    let nowhere = minimize(&[(0.0, 1.0)], |_| f64::NAN, &ok).unwrap_err();
    assert!(nowhere.contains("finite"), "{nowhere}");
}

/// A smooth function of three inputs on a 5x5x5 grid plus a seeded jitter, in its own units.
fn smooth_data() -> (Vec<Vec<f64>>, Vec<f64>) {
    let f = |x: &[f64]| 10.0 + 3.0 * (x[0]).sin() + x[1] * x[2] - 0.5 * x[2] * x[2];
    let mut x = Vec::new();
    for i in 0..5 {
        for j in 0..5 {
            for k in 0..5 {
                x.push(vec![
                    -2.0 + i as f64,
                    -2.0 + j as f64 + 0.1 * ((i + k) as f64).sin(),
                    -2.0 + k as f64 + 0.1 * ((i * j) as f64).cos(),
                ]);
            }
        }
    }
    let y = x.iter().map(|r| f(r)).collect();
    (x, y)
}

#[test]
fn bp_fits_a_smooth_function() {
    let (x, y) = smooth_data();
    for seed in [1, 2] {
        let t = train(
            &x,
            &y,
            &BpOptions {
                seed,
                ..Default::default()
            },
        )
        .unwrap();
        assert_eq!(t.network.inputs(), 3);
        assert_eq!(t.network.hidden(), 7);
        assert_eq!(
            (t.train.len(), t.validation.len(), t.test.len()),
            (80, 20, 25)
        );
        assert!(t.ga_history.is_empty());
        assert_eq!(t.predictions.len(), 125);
        println!(
            "smooth seed {seed}: R2 train {:.5} test {:.5} all {:.5}, RMSE test {:.4}, epochs {}, gamma {:.1}",
            t.metrics_train.r2,
            t.metrics_test.r2,
            t.metrics_all.r2,
            t.metrics_test.rmse,
            t.epochs,
            t.effective_parameters
        );
        assert!(
            t.metrics_test.r2 > 0.95,
            "seed {seed}: {:?}",
            t.metrics_test
        );
        assert!(
            t.metrics_train.r2 > 0.95,
            "seed {seed}: {:?}",
            t.metrics_train
        );
    }
}

fn ga_bp_options(seed: u64, ga: GaOptions) -> BpOptions {
    BpOptions {
        seed,
        ga: Some(ga),
        ..Default::default()
    }
}

/// GA-BP as the acceptance runs it: early stopping on a validation slice (the default) and an
/// average of 10 networks with their own validation slices and GA seeds.
fn ensemble_options(seed: u64) -> BpOptions {
    BpOptions {
        ensemble: 10,
        ..ga_bp_options(seed, GaOptions::weights_default(seed))
    }
}

/// Over split seeds 0..20, GA-BP (ensemble of 10, published GA settings) reaches test R^2 >= 0.8
/// on 9. That is no clear majority, and no model fitted to 18 of these 23 runs gets one: least
/// squares on the same rows gives 11/20 for a linear model and 10/20 for the reduced quadratic
/// the ANOVA supports (see the module notes of `network` and `survey_variants`). The test
/// asserts the count that holds, all-data R^2 >= 0.8 on every split, and that GA-BP-GA finds
/// inputs predicting the lab angle to 0.01 deg on split 1.
#[test]
fn ga_bp_ga_on_the_silage_ccd() {
    let (x, y) = silage();
    let bounds = [(-ALPHA, ALPHA); 3];
    let mut pass = 0;
    for split in 0..20u64 {
        let start = Instant::now();
        let t = train(&x, &y, &ensemble_options(split)).unwrap();
        let trained = start.elapsed();
        pass += (t.metrics_test.r2 >= 0.8) as usize;
        println!(
            "silage GA-BP split {split}: R2 train {:.4} validation {:.4} test {:.4} all {:.4}; \
             RMSE {:.3}/{:.3}/{:.3}; MAE {:.3}/{:.3}/{:.3}; epochs {}, {trained:?}",
            t.metrics_train.r2,
            t.metrics_validation.r2,
            t.metrics_test.r2,
            t.metrics_all.r2,
            t.metrics_train.rmse,
            t.metrics_test.rmse,
            t.metrics_all.rmse,
            t.metrics_train.mae,
            t.metrics_test.mae,
            t.metrics_all.mae,
            t.epochs,
        );
        assert!(
            t.metrics_all.r2 >= 0.8,
            "split {split}: {:?}",
            t.metrics_all
        );
        assert_eq!(
            (t.train.len(), t.validation.len(), t.test.len()),
            (14, 4, 5)
        );
        assert_eq!(t.ga_history.len(), 200);
        assert!(t.ga_history.windows(2).all(|w| w[1] <= w[0]));
        if split == 1 {
            let s = search_target(
                &t.network,
                &bounds,
                LAB_ANGLE,
                &GaOptions::search_default(split),
            )
            .unwrap();
            let p = t.network.predict(&s.best);
            println!(
                "GA-BP-GA split {split}: D {:.4} E {:.4} G {:.4} -> {p:.4} deg",
                s.best[0], s.best[1], s.best[2]
            );
            assert!((p - LAB_ANGLE).abs() <= 0.01, "{p}");
            assert!(s.value <= 0.01);
            assert!(s.best.iter().all(|v| v.abs() <= ALPHA));
            assert_eq!(s.history.len(), 100);
        }
    }
    println!("test R2 >= 0.8 on {pass} of 20 splits");
    assert!(pass >= 9, "{pass} of 20");
}

#[test]
fn training_is_deterministic() {
    let (x, y) = silage();
    let small = GaOptions {
        generations: 20,
        population: 30,
        ..GaOptions::weights_default(4)
    };
    let a = train(&x, &y, &ga_bp_options(4, small.clone())).unwrap();
    let b = train(&x, &y, &ga_bp_options(4, small)).unwrap();
    assert_eq!(a.network.weights(), b.network.weights());
    assert_eq!(a.predictions, b.predictions);
    assert_eq!(a.ga_history, b.ga_history);
    assert_eq!(a.test, b.test);
    let c = train(&x, &y, &BpOptions::default()).unwrap();
    let d = train(&x, &y, &BpOptions::default()).unwrap();
    assert_eq!(c.network.weights(), d.network.weights());
    assert_eq!(c.epochs, d.epochs);
}

#[test]
fn training_rejects_bad_input() {
    let (x, y) = silage();
    let o = BpOptions::default();
    let err = |x: &[Vec<f64>], y: &[f64], o: &BpOptions| train(x, y, o).unwrap_err();
    assert!(err(&x, &y[..22], &o).contains("as many responses"));
    assert!(err(&x[..2], &y[..2], &o).contains("at least 3 rows"));
    let mut ragged = x.clone();
    ragged[5].pop();
    assert!(err(&ragged, &y, &o).contains("row 5"));
    let mut nan = x.clone();
    nan[7][1] = f64::NAN;
    assert!(err(&nan, &y, &o).contains("finite inputs"));
    let mut inf_y = y.clone();
    inf_y[0] = f64::INFINITY;
    assert!(err(&x, &inf_y, &o).contains("finite responses"));
    let empty_rows = vec![Vec::new(); 5];
    assert!(err(&empty_rows, &[1.0; 5], &o).contains("at least one input"));
    for frac in [0.0, 1.0, f64::NAN] {
        let bad = BpOptions {
            train_fraction: frac,
            ..o.clone()
        };
        assert!(err(&x, &y, &bad).contains("train_fraction"));
    }
    let none_hidden = BpOptions {
        hidden: Some(0),
        ..o.clone()
    };
    assert!(err(&x, &y, &none_hidden).contains("hidden"));
    for vf in [-0.1, 1.0, f64::NAN] {
        let bad = BpOptions {
            validation_fraction: vf,
            ..o.clone()
        };
        assert!(err(&x, &y, &bad).contains("validation_fraction"));
    }
    let no_members = BpOptions {
        ensemble: 0,
        ..o.clone()
    };
    assert!(err(&x, &y, &no_members).contains("ensemble"));
    let bad_goal = BpOptions {
        goal_mse: -1.0,
        ..o.clone()
    };
    assert!(err(&x, &y, &bad_goal).contains("goal_mse"));
    let bad_ga = BpOptions {
        ga: Some(GaOptions {
            population: 0,
            ..GaOptions::weights_default(0)
        }),
        ..o.clone()
    };
    assert!(err(&x, &y, &bad_ga).contains("population"));

    let t = train(&x, &y, &o).unwrap();
    assert!(t.network.predict(&[0.0, 0.0]).is_nan());
    let s = GaOptions::search_default(0);
    assert!(search_target(&t.network, &[(-1.0, 1.0); 2], 38.0, &s)
        .unwrap_err()
        .contains("3 inputs"));
    assert!(search_target(&t.network, &[(-1.0, 1.0); 3], f64::NAN, &s)
        .unwrap_err()
        .contains("finite target"));
}

/// Fits of the form the quadratic RSM and a linear model, by least squares on the training rows
/// of a split, for comparison with the network in `survey_silage_seeds`.
fn polynomial_metrics(
    x: &[Vec<f64>],
    y: &[f64],
    split: u64,
    quadratic: bool,
) -> (surrogate::FitMetrics, surrogate::FitMetrics) {
    polynomial_metrics_of(x, y, split, if quadratic { 2 } else { 0 })
}

/// The terms of a polynomial in D, E, G: `kind` 0 linear, 1 the reduced quadratic D, E, G, D^2,
/// G^2 (the published RSM model), 2 the full quadratic.
fn polynomial_terms(r: &[f64], kind: usize) -> Vec<f64> {
    let mut t = vec![1.0, r[0], r[1], r[2]];
    if kind == 1 {
        t.extend([r[0] * r[0], r[2] * r[2]]);
    }
    if kind == 2 {
        t.extend([
            r[0] * r[1],
            r[0] * r[2],
            r[1] * r[2],
            r[0] * r[0],
            r[1] * r[1],
            r[2] * r[2],
        ]);
    }
    t
}

/// The polynomial of `kind` fitted by least squares on `rows`, as a predictor.
fn polynomial_fit(
    x: &[Vec<f64>],
    y: &[f64],
    rows: &[usize],
    kind: usize,
) -> impl Fn(&[f64]) -> f64 {
    let k = polynomial_terms(&x[0], kind).len();
    let a =
        nalgebra::DMatrix::from_fn(rows.len(), k, |i, j| polynomial_terms(&x[rows[i]], kind)[j]);
    let b = nalgebra::DVector::from_fn(rows.len(), |i, _| y[rows[i]]);
    let c = a.svd(true, true).solve(&b, 1e-12).unwrap();
    move |r: &[f64]| {
        polynomial_terms(r, kind)
            .iter()
            .zip(c.iter())
            .map(|(t, c)| t * c)
            .sum::<f64>()
    }
}

fn polynomial_metrics_of(
    x: &[Vec<f64>],
    y: &[f64],
    split: u64,
    kind: usize,
) -> (surrogate::FitMetrics, surrogate::FitMetrics) {
    let (tr, te) = surrogate::split_stratified(y, 0.8, split);
    let pred = polynomial_fit(x, y, &tr, kind);
    let m = |rows: &[usize]| {
        let obs: Vec<f64> = rows.iter().map(|&i| y[i]).collect();
        let p: Vec<f64> = rows.iter().map(|&i| pred(&x[i])).collect();
        surrogate::FitMetrics::of(&obs, &p)
    };
    (m(&tr), m(&te))
}

/// Not a check: pooled 5-fold cross-validation on the silage CCD, every row predicted once by a
/// model that did not train on it (folds stratified on the response, 10 fold seeds), for GA-BP as
/// the `ga_bp` stage trains it (10 early-stopped networks) and for the published reduced
/// quadratic. About 30 s. `cargo test --release -p demcal-surrogate --test ga_bp -- --ignored
/// --nocapture survey_cross_validation`.
#[test]
#[ignore]
fn survey_cross_validation() {
    let (x, y) = silage();
    let n = y.len();
    for seed in 0..10u64 {
        // Sorted by response, each block of 5 rows is dealt at random to the 5 folds.
        let mut order: Vec<usize> = (0..n).collect();
        order.sort_by(|&a, &b| y[a].total_cmp(&y[b]));
        let mut fold = vec![0usize; n];
        let mut s = seed.wrapping_mul(6_364_136_223_846_793_005) ^ 0x9e37_79b9;
        for chunk in order.chunks(5) {
            let mut f: Vec<usize> = (0..5).collect();
            for i in (1..5).rev() {
                s = s
                    .wrapping_mul(6_364_136_223_846_793_005)
                    .wrapping_add(1_442_695_040_888_963_407);
                f.swap(i, (s >> 33) as usize % (i + 1));
            }
            for (p, &row) in chunk.iter().enumerate() {
                fold[row] = f[p];
            }
        }
        let (mut net, mut quad) = (vec![0.0; n], vec![0.0; n]);
        for k in 0..5 {
            let tr: Vec<usize> = (0..n).filter(|&i| fold[i] != k).collect();
            let xt: Vec<Vec<f64>> = tr.iter().map(|&i| x[i].clone()).collect();
            let yt: Vec<f64> = tr.iter().map(|&i| y[i]).collect();
            // Nearly every training row trains (one is the network's own test row).
            let opts = BpOptions {
                train_fraction: 0.97,
                ..ensemble_options(seed * 10 + k as u64)
            };
            let t = train(&xt, &yt, &opts).unwrap();
            let q = polynomial_fit(&x, &y, &tr, 1);
            for i in (0..n).filter(|&i| fold[i] == k) {
                net[i] = t.network.predict(&x[i]);
                quad[i] = q(&x[i]);
            }
        }
        let (a, b) = (
            surrogate::FitMetrics::of(&y, &net),
            surrogate::FitMetrics::of(&y, &quad),
        );
        println!(
            "fold seed {seed}: cross-validated R2 GA-BP {:.3} (RMSE {:.2}), reduced quadratic {:.3} (RMSE {:.2})",
            a.r2, a.rmse, b.r2, b.rmse
        );
    }
}

/// Not a check: prints plain BP and GA-BP fits (published GA settings, timed) on the silage CCD
/// for split seeds 0..20, beside a linear and a quadratic least-squares fit of the same training
/// rows. `cargo test --release -p demcal-surrogate --test ga_bp -- --ignored --nocapture`.
#[test]
#[ignore]
fn survey_silage_seeds() {
    let (x, y) = silage();
    let mut pass = [0; 4];
    for seed in 0..20u64 {
        for (slot, ga) in [false, true].into_iter().enumerate() {
            let opts = if ga {
                ga_bp_options(seed, GaOptions::weights_default(seed))
            } else {
                BpOptions {
                    seed,
                    ..Default::default()
                }
            };
            let start = Instant::now();
            let t = train(&x, &y, &opts).unwrap();
            let el = start.elapsed();
            let s = search_target(
                &t.network,
                &[(-ALPHA, ALPHA); 3],
                LAB_ANGLE,
                &GaOptions::search_default(seed),
            )
            .unwrap();
            pass[slot] += (t.metrics_test.r2 >= 0.8) as usize;
            println!(
                "{} seed {seed:2}: test {:?} R2 {:.3}/{:.3}/{:.3} RMSE {:.2}/{:.2}/{:.2} \
                 MAE {:.2}/{:.2}/{:.2} epochs {:4} gamma {:5.2} {:6.1} ms; \
                 search ({:.3}, {:.3}, {:.3}) |err| {:.1e}",
                if ga { "GA-BP" } else { "BP   " },
                t.test,
                t.metrics_train.r2,
                t.metrics_test.r2,
                t.metrics_all.r2,
                t.metrics_train.rmse,
                t.metrics_test.rmse,
                t.metrics_all.rmse,
                t.metrics_train.mae,
                t.metrics_test.mae,
                t.metrics_all.mae,
                t.epochs,
                t.effective_parameters,
                el.as_secs_f64() * 1e3,
                s.best[0],
                s.best[1],
                s.best[2],
                s.value
            );
        }
        for (slot, quadratic) in [(2, false), (3, true)] {
            let (tr, te) = polynomial_metrics(&x, &y, seed, quadratic);
            pass[slot] += (te.r2 >= 0.8) as usize;
            println!(
                "{} seed {seed:2}: R2 {:.3}/{:.3} RMSE {:.2}/{:.2}",
                if quadratic { "quad " } else { "lin  " },
                tr.r2,
                te.r2,
                tr.rmse,
                te.rmse
            );
        }
    }
    println!(
        "test R2 >= 0.8 of 20 splits: BP {}, GA-BP {}, linear {}, quadratic {}",
        pass[0], pass[1], pass[2], pass[3]
    );
}

/// Not a check: GA-BP test R^2 over split seeds 0..20 for the training variants compared in the
/// module notes of `network` (early stopping, Bayesian regularisation, both, a fixed weight
/// decay, one network or an ensemble of 10, the weight decay by cross-validation), beside least
/// squares polynomials (kind 0 linear, 1 reduced quadratic, 2 full quadratic) on the same rows.
/// About 90 s. `cargo test --release -p demcal-surrogate --test ga_bp -- --ignored --nocapture
/// survey_variants`.
#[test]
#[ignore]
fn survey_variants() {
    let (x, y) = silage();
    let mut variants: Vec<(String, BpOptions)> = Vec::new();
    variants.push((
        "weight decay by 6-fold CV".into(),
        BpOptions {
            validation_fraction: 0.0,
            cv_folds: 6,
            ..Default::default()
        },
    ));
    for e in [1, 10] {
        variants.push((
            format!("ES LM vf 0.2 ens {e}"),
            BpOptions {
                ensemble: e,
                ..Default::default()
            },
        ));
        variants.push((
            format!("BR ens {e}"),
            BpOptions {
                validation_fraction: 0.0,
                bayesian: true,
                ensemble: e,
                ..Default::default()
            },
        ));
        variants.push((
            format!("decay 0.3 ens {e}"),
            BpOptions {
                validation_fraction: 0.0,
                weight_decay: Some(0.3),
                ensemble: e,
                ..Default::default()
            },
        ));
        variants.push((
            format!("BR+ES ens {e}"),
            BpOptions {
                bayesian: true,
                ensemble: e,
                ..Default::default()
            },
        ));
    }
    for kind in 0..3 {
        let n = (0..20u64)
            .filter(|&s| polynomial_metrics_of(&x, &y, s, kind).1.r2 >= 0.8)
            .count();
        println!("polynomial kind {kind}: {n}/20");
    }
    for (name, base) in variants {
        let mut pass = 0;
        let mut r2s = Vec::new();
        let start = Instant::now();
        for seed in 0..20u64 {
            let opts = BpOptions {
                seed,
                ga: Some(GaOptions::weights_default(seed)),
                ..base.clone()
            };
            let t = train(&x, &y, &opts).unwrap();
            pass += (t.metrics_test.r2 >= 0.8) as usize;
            r2s.push(format!(
                "{:.2}/{:.2}/{:.2}/{}",
                t.metrics_train.r2, t.metrics_validation.r2, t.metrics_test.r2, t.epochs
            ));
        }
        println!(
            "{name}: {pass}/20 in {:?}\n  {}",
            start.elapsed(),
            r2s.join(" ")
        );
    }
}
