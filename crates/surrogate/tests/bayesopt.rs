//! Gaussian-process fits and Bayesian optimisation on functions whose answers are known.

use doe::design::random_design;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use surrogate::bayesopt::{initial_design, minimize, propose, BoOptions};
use surrogate::gp::{Gp, GpOptions, Kernel};

/// A standard normal draw (Box-Muller), so that the tests need no extra crate.
fn normal(rng: &mut Pcg64) -> f64 {
    let u: f64 = rng.gen_range(f64::EPSILON..1.0);
    let v: f64 = rng.gen();
    (-2.0 * u.ln()).sqrt() * (2.0 * std::f64::consts::PI * v).cos()
}

fn wave(x: f64) -> f64 {
    (3.0 * x).sin() + 0.5 * x
}

#[test]
fn gp_recovers_a_noisy_1d_function_and_its_noise() {
    let noise_sd = 0.05;
    let mut rng = Pcg64::seed_from_u64(11);
    let x = initial_design(1, 60, 3).unwrap();
    let y: Vec<f64> = x
        .iter()
        .map(|p| wave(p[0]) + noise_sd * normal(&mut rng))
        .collect();
    for kernel in [Kernel::Matern52, Kernel::SquaredExponential] {
        let gp = Gp::fit(
            &x,
            &y,
            &GpOptions {
                kernel,
                ..GpOptions::default()
            },
        )
        .unwrap();
        let grid: Vec<f64> = (0..=100).map(|i| -1.0 + 0.02 * i as f64).collect();
        let rmse = (grid
            .iter()
            .map(|&g| (gp.predict(&[g]).0 - wave(g)).powi(2))
            .sum::<f64>()
            / grid.len() as f64)
            .sqrt();
        let noise_ratio = gp.noise_variance() / (noise_sd * noise_sd);
        let (_, var_near) = gp.predict(&x[10]);
        let (mean_far, var_far) = gp.predict(&[50.0]);
        eprintln!(
            "{}: rmse {rmse:.4}, noise variance {:.3e} ({noise_ratio:.2} x true), variance at a training point {var_near:.2e}, far {var_far:.3} (signal {:.3}), length scale {:.3}",
            kernel.name(),
            gp.noise_variance(),
            gp.signal_variance(),
            gp.length_scales()[0]
        );
        assert!(rmse < 0.03, "rmse {rmse}");
        assert!(
            (0.5..2.0).contains(&noise_ratio),
            "noise ratio {noise_ratio}"
        );
        assert!(var_near < gp.noise_variance(), "{var_near}");
        assert!((var_far / gp.signal_variance() - 1.0).abs() < 1e-6);
        assert!((mean_far - gp.mean()).abs() < 1e-6 * gp.signal_variance().sqrt());
        assert!(gp.log_marginal_likelihood().is_finite());
    }
}

#[test]
fn gp_interpolates_noise_free_data() {
    let f = |p: &[f64]| (2.0 * p[0]).sin() * (1.0 + p[1] * p[1]) + 0.3 * p[1];
    let x = initial_design(2, 30, 5).unwrap();
    let y: Vec<f64> = x.iter().map(|p| f(p)).collect();
    let gp = Gp::fit(&x, &y, &GpOptions::default()).unwrap();
    let worst = x
        .iter()
        .zip(&y)
        .map(|(p, v)| (gp.predict(p).0 - v).abs())
        .fold(0.0, f64::max);
    let ratio = gp.noise_variance() / gp.signal_variance();
    eprintln!("noise / signal {ratio:.2e}, worst error at the points {worst:.2e}");
    assert!(ratio < 1e-5, "{ratio}");
    assert!(worst < 1e-3, "{worst}");
    // And it predicts between the points.
    let (m, _) = gp.predict(&[0.1, -0.2]);
    assert!((m - f(&[0.1, -0.2])).abs() < 0.05, "{m}");
}

/// A tilted 4-D bowl with its minimum (0) inside the box at CENTRE.
const CENTRE: [f64; 4] = [0.3, -0.4, 0.55, -0.2];
fn bowl(p: &[f64]) -> f64 {
    let d: Vec<f64> = p.iter().zip(CENTRE).map(|(a, c)| a - c).collect();
    d[0] * d[0] + 2.0 * d[1] * d[1] + 0.5 * d[2] * d[2] + 1.5 * d[3] * d[3] + 0.8 * d[0] * d[1]
        - 0.4 * d[2] * d[3]
        + 0.3 * d[0] * d[0] * d[1] * d[1]
}

#[test]
fn bo_beats_random_search_on_a_noisy_4d_bowl() {
    // The bowl spans about 0 to 9 over the box: noise sd 0.09 is 1 % of that range.
    let noise_sd = 0.09;
    let budget = 20 + 10 * 4;
    let (mut bo_gaps, mut bo_pred_gaps, mut random_gaps) = (Vec::new(), Vec::new(), Vec::new());
    for seed in 0..5u64 {
        let mut rng = Pcg64::seed_from_u64(100 + seed);
        let opts = BoOptions {
            initial: 20,
            iterations: 10,
            batch: 4,
            seed,
            gp: GpOptions {
                seed,
                ..GpOptions::default()
            },
            ..BoOptions::default()
        };
        let result = minimize(
            4,
            |pts| {
                pts.iter()
                    .map(|p| bowl(p) + noise_sd * normal(&mut rng))
                    .collect()
            },
            &opts,
        )
        .unwrap();
        assert_eq!(result.x.len(), budget);
        assert_eq!(result.history.len(), 11);
        bo_gaps.push(bowl(&result.x[result.best]));
        bo_pred_gaps.push(bowl(&result.predicted_minimizer));

        let mut rng = Pcg64::seed_from_u64(200 + seed);
        let random = random_design(4, budget, 300 + seed).unwrap().runs;
        let best = random
            .iter()
            .map(|p| (bowl(p) + noise_sd * normal(&mut rng), p))
            .min_by(|a, b| a.0.total_cmp(&b.0))
            .unwrap()
            .1;
        random_gaps.push(bowl(best));
    }
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    eprintln!(
        "true value at the chosen point, 5 seeds, {budget} evaluations:\n  BO best observed {bo_gaps:.4?} mean {:.4}\n  BO predicted minimiser {bo_pred_gaps:.4?} mean {:.4}\n  random search {random_gaps:.4?} mean {:.4}",
        mean(&bo_gaps),
        mean(&bo_pred_gaps),
        mean(&random_gaps)
    );
    assert!(mean(&bo_gaps) < 0.1, "BO best observed {bo_gaps:?}");
    assert!(mean(&bo_pred_gaps) < 0.05, "BO predicted {bo_pred_gaps:?}");
    assert!(mean(&bo_gaps) < 0.5 * mean(&random_gaps));
}

fn noisy_sample(n: usize, seed: u64) -> (Vec<Vec<f64>>, Vec<f64>) {
    let mut rng = Pcg64::seed_from_u64(seed);
    let x = initial_design(3, n, seed).unwrap();
    let y = x
        .iter()
        .map(|p| bowl(&[p[0], p[1], p[2], 0.0]) + 0.05 * normal(&mut rng))
        .collect();
    (x, y)
}

#[test]
fn proposals_are_deterministic_and_batches_distinct() {
    let (x, y) = noisy_sample(15, 4);
    let opts = BoOptions::default();
    let a = propose(&x, &y, 4, &opts, 3).unwrap();
    let b = propose(&x, &y, 4, &opts, 3).unwrap();
    assert_eq!(a.points, b.points);
    assert_eq!(a.expected_improvement, b.expected_improvement);
    assert_eq!(a.predicted_minimum.to_bits(), b.predicted_minimum.to_bits());
    assert_eq!(a.gp.length_scales(), b.gp.length_scales());
    assert_eq!(a.points.len(), 4);
    for (i, p) in a.points.iter().enumerate() {
        assert!(p.iter().all(|v| (-1.0..=1.0).contains(v)));
        for q in &a.points[..i] {
            let d: f64 = p.iter().zip(q).map(|(u, v)| (u - v).powi(2)).sum();
            assert!(d.sqrt() > 1e-3, "{p:?} and {q:?}");
        }
    }
    assert!(a.expected_improvement.iter().all(|e| *e >= 0.0));
    // Another iteration number searches differently.
    let c = propose(&x, &y, 4, &opts, 4).unwrap();
    assert_ne!(a.points, c.points);
}

#[test]
fn bad_input_is_refused() {
    let (x, mut y) = noisy_sample(10, 1);
    let opts = BoOptions::default();
    y[3] = f64::NAN;
    assert!(propose(&x, &y, 1, &opts, 0)
        .unwrap_err()
        .contains("finite responses"));
    y[3] = 1.0;
    assert!(propose(&x[..1], &y[..1], 1, &opts, 0)
        .unwrap_err()
        .contains("at least 2"));
    let mut short = x.clone();
    short[2].pop();
    assert!(propose(&short, &y, 1, &opts, 0)
        .unwrap_err()
        .contains("coordinates"));
    assert!(propose(&x, &y[..9], 1, &opts, 0).is_err());
    assert!(initial_design(0, 10, 0).is_err());
    let bad = |o: BoOptions| minimize(2, |p| vec![0.0; p.len()], &o).unwrap_err();
    assert!(bad(BoOptions {
        batch: 0,
        ..BoOptions::default()
    })
    .contains("batch"));
    assert!(bad(BoOptions {
        tolerance: f64::NAN,
        ..BoOptions::default()
    })
    .contains("tolerance"));
    assert!(minimize(0, |p| vec![0.0; p.len()], &BoOptions::default()).is_err());
    // An objective that returns the wrong number of values.
    assert!(minimize(2, |_| vec![1.0], &BoOptions::default())
        .unwrap_err()
        .contains("one value per point"));
}

#[test]
fn minimize_respects_budget_and_patience_and_skips_failed_runs() {
    let f = |pts: &[Vec<f64>]| -> Vec<f64> {
        pts.iter()
            .map(|p| {
                if p[0] > 0.8 {
                    f64::NAN
                } else {
                    (p[0] - 0.2).powi(2) + p[1] * p[1]
                }
            })
            .collect()
    };
    let budget = BoOptions {
        initial: 8,
        batch: 3,
        budget: Some(15),
        ..BoOptions::default()
    };
    let r = minimize(2, f, &budget).unwrap();
    assert_eq!(r.x.len(), 15);
    assert!(r.stop.contains("budget"), "{}", r.stop);
    assert!(r.y[r.best].is_finite());

    let patient = BoOptions {
        initial: 8,
        iterations: 50,
        patience: Some(2),
        tolerance: 1e9,
        ..BoOptions::default()
    };
    let r = minimize(2, f, &patient).unwrap();
    assert_eq!(r.history.len(), 3);
    assert!(r.stop.contains("improved"), "{}", r.stop);
}
