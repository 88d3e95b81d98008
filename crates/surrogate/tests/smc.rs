//! Sequential Monte Carlo filter and Gaussian mixture against problems with known answers.

use nalgebra::{DMatrix, DVector};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use surrogate::mixture::GaussianMixture;
use surrogate::smc::{
    effective_sample_size, halton, next_samples, posterior, run, stop_reason, weigh,
    LikelihoodScale, SmcOptions,
};

fn normal(rng: &mut Pcg64) -> f64 {
    let u1 = 1.0 - rng.gen::<f64>();
    let u2: f64 = rng.gen();
    (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
}

/// y = A theta, 3 observations of 2 parameters.
const A: [[f64; 2]; 3] = [[1.0, 0.4], [0.2, 1.0], [0.6, -0.5]];
const THETA_TRUE: [f64; 2] = [0.2, -0.3];
const NOISE_SD: f64 = 0.15;
/// A fixed draw of the noise (in units of NOISE_SD), so the test does not depend on luck.
const NOISE: [f64; 3] = [0.7, -1.1, 0.4];

fn y_obs() -> Vec<f64> {
    A.iter()
        .zip(NOISE)
        .map(|(row, e)| row[0] * THETA_TRUE[0] + row[1] * THETA_TRUE[1] + NOISE_SD * e)
        .collect()
}

fn linear_misfit(batch: &[Vec<f64>]) -> Vec<f64> {
    let y = y_obs();
    batch
        .iter()
        .map(|t| {
            A.iter()
                .zip(&y)
                .map(|(row, yi)| ((yi - row[0] * t[0] - row[1] * t[1]) / NOISE_SD).powi(2))
                .sum()
        })
        .collect()
}

/// Exact posterior of the linear-Gaussian problem (the box is > 5 posterior sd wide each way,
/// so the uniform prior's truncation is negligible): mean (A^T A)^-1 A^T y, covariance
/// s^2 (A^T A)^-1.
fn exact_posterior() -> (Vec<f64>, Vec<f64>) {
    let a = DMatrix::from_fn(3, 2, |i, j| A[i][j]);
    let y = DVector::from_vec(y_obs());
    let ata_inv = (a.transpose() * &a).try_inverse().unwrap();
    let mean = &ata_inv * a.transpose() * y;
    let cov = ata_inv * NOISE_SD * NOISE_SD;
    (
        mean.iter().copied().collect(),
        (0..2).map(|i| cov[(i, i)].sqrt()).collect(),
    )
}

#[test]
fn halton_matches_the_known_sequence() {
    let h = halton(5, 3);
    let b2 = [0.5, 0.25, 0.75, 0.125, 0.625];
    let b3 = [1.0 / 3.0, 2.0 / 3.0, 1.0 / 9.0, 4.0 / 9.0, 7.0 / 9.0];
    let b5 = [0.2, 0.4, 0.6, 0.8, 0.04];
    for i in 0..5 {
        assert!((h[i][0] - (2.0 * b2[i] - 1.0)).abs() < 1e-15);
        assert!((h[i][1] - (2.0 * b3[i] - 1.0)).abs() < 1e-15);
        assert!((h[i][2] - (2.0 * b5[i] - 1.0)).abs() < 1e-15);
    }
    assert!(halton(1000, 6).iter().flatten().all(|v| v.abs() < 1.0));
}

#[test]
fn linear_gaussian_posterior_with_fixed_sigma() {
    let (mean, sd) = exact_posterior();
    let opts = SmcOptions {
        samples: 400,
        iterations: 4,
        scale: LikelihoodScale::Fixed(1.0),
        sigma_tolerance: 0.0,
        components: 4,
        seed: 11,
    };
    let its = run(2, linear_misfit, &opts).unwrap();
    assert_eq!(its.len(), 4);
    let last = &its[3].posterior;
    println!(
        "exact mean {mean:?} sd {sd:?}; smc mean {:?} sd {:?} ess {:.1} (ESS per iteration {:?})",
        last.mean,
        last.std,
        last.ess,
        its.iter().map(|i| i.posterior.ess).collect::<Vec<_>>()
    );
    for d in 0..2 {
        assert!(
            (last.mean[d] - mean[d]).abs() < 0.2 * sd[d],
            "mean {d}: {} vs exact {} (sd {})",
            last.mean[d],
            mean[d],
            sd[d]
        );
        assert!(
            (last.std[d] / sd[d] - 1.0).abs() < 0.25,
            "sd {d}: {} vs exact {}",
            last.std[d],
            sd[d]
        );
        // The 95 % interval of a Gaussian spans 2 x 1.96 sd.
        let (lo, hi) = last.credible[d];
        assert!(((hi - lo) / (3.92 * sd[d]) - 1.0).abs() < 0.3);
        assert!(lo < mean[d] && mean[d] < hi);
    }
    // The mixture proposal concentrates the later batches where the posterior is.
    assert!(its[3].posterior.ess > 3.0 * its[0].posterior.ess);
}

#[test]
fn ess_target_tempers_down_to_the_noise_level() {
    // With the misfit scaled by the true noise, the default tolerance (sigma 1) stops the
    // tempering at the exact posterior.
    let (mean, sd) = exact_posterior();
    let opts = SmcOptions {
        samples: 400,
        iterations: 10,
        components: 4,
        ..SmcOptions::for_dim(2, 3)
    };
    let its = run(2, linear_misfit, &opts).unwrap();
    let sigmas: Vec<f64> = its.iter().map(|i| i.sigma).collect();
    println!("sigmas {sigmas:?}");
    assert!(its.len() < 10, "should stop on the tolerance: {sigmas:?}");
    assert_eq!(*sigmas.last().unwrap(), 1.0);
    assert!(stop_reason(&opts, &sigmas).unwrap().contains("tolerance"));
    let last = &its.last().unwrap().posterior;
    println!(
        "exact mean {mean:?} sd {sd:?}; smc {:?} {:?}",
        last.mean, last.std
    );
    for d in 0..2 {
        assert!((last.mean[d] - mean[d]).abs() < 0.25 * sd[d]);
        assert!((last.std[d] / sd[d] - 1.0).abs() < 0.3);
    }
}

#[test]
fn ess_target_is_met_and_sigma_falls() {
    let truth: [f64; 3] = [0.35, -0.45, 0.1];
    // Two nonlinear responses per parameter, a clear optimum at `truth`, small lab spread.
    let misfit = |batch: &[Vec<f64>]| -> Vec<f64> {
        batch
            .iter()
            .map(|t| {
                let mut m = 0.0;
                for d in 0..3 {
                    let r1 = t[d] + 0.3 * t[(d + 1) % 3].powi(2);
                    let l1 = truth[d] + 0.3 * truth[(d + 1) % 3].powi(2);
                    let r2 = (1.5 * t[d]).sin();
                    let l2 = (1.5 * truth[d]).sin();
                    m += ((r1 - l1) / 0.01).powi(2) + ((r2 - l2) / 0.01).powi(2);
                }
                m
            })
            .collect()
    };
    let opts = SmcOptions {
        samples: 150,
        iterations: 6,
        sigma_tolerance: 1e-6,
        ..SmcOptions::for_dim(3, 21)
    };
    let its = run(3, misfit, &opts).unwrap();
    assert_eq!(its.len(), 6);
    let mut errors = Vec::new();
    for (k, it) in its.iter().enumerate() {
        let ratio = effective_sample_size(&it.weights) / it.weights.len() as f64;
        let err: f64 = it
            .posterior
            .mean
            .iter()
            .zip(truth)
            .map(|(m, t)| (m - t).powi(2))
            .sum::<f64>()
            .sqrt();
        println!(
            "iteration {k}: sigma {:.4e} ESS/N {ratio:.4} |mean - truth| {err:.4e}",
            it.sigma
        );
        assert!(
            (ratio / 0.3 - 1.0).abs() < 0.01,
            "iteration {k}: ESS/N {ratio}"
        );
        if k > 0 {
            assert!(it.sigma < its[k - 1].sigma, "sigma rose at iteration {k}");
        }
        errors.push(err);
    }
    assert!(its[5].sigma < 0.2 * its[0].sigma);
    assert!(errors[5] < 0.02, "final error {}", errors[5]);
    assert!(errors[5] < 0.2 * errors[0]);
}

#[test]
fn weigh_tunes_sigma_to_the_ess_target() {
    let pts = halton(500, 2);
    let q = vec![0.25; pts.len()];
    let m: Vec<f64> = pts
        .iter()
        .map(|p| ((p[0] - 0.3) / 0.1).powi(2) + ((p[1] + 0.2) / 0.3).powi(2))
        .collect();
    for target in [0.1, 0.3, 0.6] {
        let (w, sigma) = weigh(&pts, &q, &m, LikelihoodScale::EssTarget(target)).unwrap();
        let ratio = effective_sample_size(&w) / 500.0;
        println!("target {target}: sigma {sigma:.5} ESS/N {ratio:.6}");
        assert!((ratio / target - 1.0).abs() < 0.01);
        assert!((w.iter().sum::<f64>() - 1.0).abs() < 1e-12);
    }
}

#[test]
fn weigh_with_fixed_sigma_is_likelihood_times_prior_over_proposal() {
    let pts = vec![vec![0.0], vec![0.5], vec![-0.5], vec![1.5]];
    let q = vec![0.5, 1.0, 2.0, 1.0];
    let m: Vec<f64> = vec![0.0, 1.0, 4.0, 0.0];
    let (w, sigma) = weigh(&pts, &q, &m, LikelihoodScale::Fixed(2.0)).unwrap();
    assert_eq!(sigma, 2.0);
    let raw: Vec<f64> = (0..3).map(|i| (-m[i] / 8.0).exp() * 0.5 / q[i]).collect();
    let s: f64 = raw.iter().sum();
    for i in 0..3 {
        assert!((w[i] - raw[i] / s).abs() < 1e-14);
    }
    // Outside the box the prior, hence the weight, is zero.
    assert_eq!(w[3], 0.0);
}

#[test]
fn bad_input_is_an_error() {
    let pts = halton(10, 2);
    let q = vec![0.25; 10];
    let m: Vec<f64> = (0..10).map(|i| i as f64).collect();
    let ess = LikelihoodScale::EssTarget(0.3);
    let expect_err = |r: Result<(Vec<f64>, f64), String>, what: &str| {
        let e = r.expect_err(what);
        assert!(
            e.starts_with("smc") && e.contains("expected"),
            "{what}: {e}"
        );
        assert!(!e.contains('\n'));
    };
    expect_err(weigh(&pts, &q[..9], &m, ess), "short proposal");
    expect_err(weigh(&pts, &q, &m[..9], ess), "short misfit");
    expect_err(weigh(&[], &[], &[], ess), "no samples");
    let mut bad = m.clone();
    bad[3] = f64::NAN;
    expect_err(weigh(&pts, &q, &bad, ess), "NaN misfit");
    bad[3] = f64::INFINITY;
    expect_err(weigh(&pts, &q, &bad, ess), "infinite misfit");
    let mut bad_q = q.clone();
    bad_q[0] = 0.0;
    expect_err(weigh(&pts, &bad_q, &m, ess), "zero proposal");
    expect_err(weigh(&pts, &q, &[2.0; 10], ess), "equal misfits");
    expect_err(
        weigh(&pts, &q, &m, LikelihoodScale::EssTarget(0.0)),
        "ESS 0",
    );
    expect_err(
        weigh(&pts, &q, &m, LikelihoodScale::EssTarget(1.5)),
        "ESS 1.5",
    );
    expect_err(
        weigh(&pts, &q, &m, LikelihoodScale::Fixed(-1.0)),
        "sigma < 0",
    );
    let outside = vec![vec![2.0, 0.0]; 10];
    expect_err(weigh(&outside, &q, &m, ess), "all outside");
    let mut ragged = pts.clone();
    ragged[2] = vec![0.0];
    expect_err(weigh(&ragged, &q, &m, ess), "ragged");

    assert!(next_samples(&pts, &[0.0; 10], 5, 2, 0).is_err());
    assert!(next_samples(&pts, &[1.0; 9], 5, 2, 0).is_err());
    assert!(next_samples(&pts, &[1.0; 10], 0, 2, 0).is_err());
    assert!(next_samples(&pts, &[1.0; 10], 5, 0, 0).is_err());

    let opts = SmcOptions::for_dim(2, 0);
    let e = run(2, |b: &[Vec<f64>]| vec![0.0; b.len() - 1], &opts).unwrap_err();
    assert!(e.contains("expected one misfit per sample"), "{e}");
    assert!(run(0, |b: &[Vec<f64>]| vec![0.0; b.len()], &opts).is_err());
    let bad_opts = SmcOptions {
        samples: 1,
        ..opts.clone()
    };
    assert!(run(2, |b: &[Vec<f64>]| vec![0.0; b.len()], &bad_opts).is_err());
    let nan = run(2, |b: &[Vec<f64>]| vec![f64::NAN; b.len()], &opts).unwrap_err();
    assert!(nan.contains("finite misfits"), "{nan}");
}

#[test]
fn run_is_deterministic_from_the_seed() {
    let opts = SmcOptions {
        samples: 60,
        iterations: 3,
        sigma_tolerance: 0.0,
        ..SmcOptions::for_dim(2, 99)
    };
    let bits = |its: &[surrogate::smc::Iteration]| -> Vec<u64> {
        its.iter()
            .flat_map(|it| {
                it.samples
                    .iter()
                    .flatten()
                    .chain(&it.proposal_density)
                    .chain(&it.weights)
                    .chain(std::iter::once(&it.sigma))
                    .map(|v| v.to_bits())
                    .collect::<Vec<_>>()
            })
            .collect()
    };
    let a = run(2, linear_misfit, &opts).unwrap();
    let b = run(2, linear_misfit, &opts).unwrap();
    assert_eq!(bits(&a), bits(&b));
    let c = run(2, linear_misfit, &SmcOptions { seed: 100, ..opts }).unwrap();
    assert_eq!(
        a[0].samples, c[0].samples,
        "the Halton batch does not depend on the seed"
    );
    assert_ne!(a[1].samples, c[1].samples);

    // The study replays iteration by iteration: next_samples alone gives the same batch.
    let (again, q) = next_samples(
        &a[0].samples,
        &a[0].weights,
        60,
        opts.components,
        surrogate::smc::iteration_seed(99, 1),
    )
    .unwrap();
    assert_eq!(again, a[1].samples);
    assert_eq!(q, a[1].proposal_density);
}

/// 0.3 N((-0.5, -0.5), S) + 0.7 N((0.5, 0.4), S), S = diag(0.1^2, 0.15^2) (a tied covariance).
fn two_blobs(n: usize, seed: u64) -> Vec<Vec<f64>> {
    let mut rng = Pcg64::seed_from_u64(seed);
    (0..n)
        .map(|_| {
            let c = if rng.gen::<f64>() < 0.3 {
                [-0.5, -0.5]
            } else {
                [0.5, 0.4]
            };
            vec![
                c[0] + 0.1 * normal(&mut rng),
                c[1] + 0.15 * normal(&mut rng),
            ]
        })
        .collect()
}

fn grouped(mix: &GaussianMixture) -> ([f64; 2], [[f64; 2]; 2]) {
    let centres = [[-0.5, -0.5], [0.5, 0.4]];
    let mut w = [0.0; 2];
    let mut m = [[0.0; 2]; 2];
    for (wk, mk) in mix.weights().iter().zip(mix.means()) {
        let d = |c: &[f64; 2]| (mk[0] - c[0]).powi(2) + (mk[1] - c[1]).powi(2);
        let g = if d(&centres[0]) < d(&centres[1]) {
            0
        } else {
            1
        };
        w[g] += wk;
        m[g][0] += wk * mk[0];
        m[g][1] += wk * mk[1];
    }
    for g in 0..2 {
        m[g][0] /= w[g];
        m[g][1] /= w[g];
    }
    (w, m)
}

#[test]
fn mixture_recovers_two_separated_gaussians() {
    let pts = two_blobs(3000, 4);
    let ones = vec![1.0; pts.len()];
    let centres = [[-0.5, -0.5], [0.5, 0.4]];
    for components in [2, 6] {
        let mix = GaussianMixture::fit(&pts, &ones, components, 8).unwrap();
        let (w, m) = grouped(&mix);
        println!(
            "{components} asked, {} kept: weights {w:?} means {m:?} covariance {}",
            mix.components(),
            mix.covariance()
        );
        assert!((w[0] - 0.3).abs() < 0.03 && (w[1] - 0.7).abs() < 0.03);
        for g in 0..2 {
            for d in 0..2 {
                assert!((m[g][d] - centres[g][d]).abs() < 0.02, "{m:?}");
            }
        }
        if components == 2 {
            let c = mix.covariance();
            assert!((c[(0, 0)].sqrt() - 0.1).abs() < 0.01, "{c}");
            assert!((c[(1, 1)].sqrt() - 0.15).abs() < 0.015, "{c}");
        }
        // Quasi-Monte Carlo integral of the density over [-2, 2]^2 (the mass outside is
        // below 1e-20).
        let q = halton(200_000, 2);
        let integral: f64 = 16.0
            * q.iter()
                .map(|x| mix.density(&[2.0 * x[0], 2.0 * x[1]]))
                .sum::<f64>()
            / q.len() as f64;
        println!("integral {integral}");
        assert!((integral - 1.0).abs() < 0.01);
    }
}

#[test]
fn mixture_weights_act_like_copies() {
    // Weighting the points of one blob by 3 is the same as drawing them 3 times as often.
    let pts = two_blobs(2000, 6);
    let w: Vec<f64> = pts
        .iter()
        .map(|p| if p[0] < 0.0 { 3.0 } else { 1.0 })
        .collect();
    let mix = GaussianMixture::fit(&pts, &w, 2, 1).unwrap();
    let (wg, _) = grouped(&mix);
    let expect = 0.9 / (0.9 + 0.7);
    println!("weighted blob weight {} (expected {expect})", wg[0]);
    assert!((wg[0] - expect).abs() < 0.03);
}

#[test]
fn next_samples_stay_in_the_box_with_the_truncated_density() {
    // A cloud against the +x face: about half of the mixture's mass lies outside the box.
    let pts = two_blobs(500, 9)
        .into_iter()
        .map(|p| vec![p[0] + 0.45, p[1]])
        .collect::<Vec<_>>();
    let w = vec![1.0; pts.len()];
    let (s, q) = next_samples(&pts, &w, 300, 3, 17).unwrap();
    assert_eq!(s.len(), 300);
    assert!(s.iter().flatten().all(|v| v.abs() <= 1.0));
    let mix = GaussianMixture::fit(&pts, &w, 3, 17).unwrap();
    let grid = halton(100_000, 2);
    let mass = 4.0 * grid.iter().map(|x| mix.density(x)).sum::<f64>() / grid.len() as f64;
    let ratio: Vec<f64> = s
        .iter()
        .zip(&q)
        .map(|(x, qi)| qi * mass / mix.density(x))
        .collect();
    println!("in-box mass {mass:.4}, density ratio {:.4}", ratio[0]);
    assert!(mass < 0.85);
    assert!(ratio.iter().all(|r| (r - 1.0).abs() < 0.03));
}

#[test]
fn posterior_of_weighted_points() {
    let pts = vec![vec![0.0, 10.0], vec![1.0, 20.0], vec![2.0, 30.0]];
    let p = posterior(&pts, &[1.0, 2.0, 1.0], 0.5);
    assert!((p.mean[0] - 1.0).abs() < 1e-12 && (p.mean[1] - 20.0).abs() < 1e-12);
    assert!((p.std[0] - 0.5f64.sqrt()).abs() < 1e-12);
    assert!((p.ess - 16.0 / 6.0).abs() < 1e-12);
    assert_eq!(p.sigma, 0.5);
    assert_eq!(p.credible[0], (0.0, 2.0));
}
