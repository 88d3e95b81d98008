//! Goodness of fit on held-out data, as the GA-BP papers report it, and seeded train/test splits
//! (random, as the papers do, and stratified on the response, the default here).

use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use serde::Serialize;

/// R^2, RMSE and MAE of predictions against observations.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct FitMetrics {
    pub n: usize,
    /// 1 - SS_residual / SS_total about the observations' own mean (can be negative on test
    /// data a model predicts worse than that mean; NaN when fewer than two observations).
    pub r2: f64,
    pub rmse: f64,
    pub mae: f64,
}

impl FitMetrics {
    pub fn of(observed: &[f64], predicted: &[f64]) -> FitMetrics {
        assert_eq!(observed.len(), predicted.len());
        let n = observed.len();
        if n == 0 {
            return FitMetrics {
                n,
                r2: f64::NAN,
                rmse: f64::NAN,
                mae: f64::NAN,
            };
        }
        let mean = observed.iter().sum::<f64>() / n as f64;
        let ss_tot: f64 = observed.iter().map(|y| (y - mean).powi(2)).sum();
        let ss_res: f64 = observed
            .iter()
            .zip(predicted)
            .map(|(y, p)| (y - p).powi(2))
            .sum();
        let mae = observed
            .iter()
            .zip(predicted)
            .map(|(y, p)| (y - p).abs())
            .sum::<f64>()
            / n as f64;
        FitMetrics {
            n,
            r2: if n < 2 || ss_tot == 0.0 {
                f64::NAN
            } else {
                1.0 - ss_res / ss_tot
            },
            rmse: (ss_res / n as f64).sqrt(),
            mae,
        }
    }
}

/// A seeded split of `n` rows into training and test rows (`train_fraction` of them, rounded,
/// for training; at least one of each when n >= 2). Both lists are sorted.
pub fn split_train_test(n: usize, train_fraction: f64, seed: u64) -> (Vec<usize>, Vec<usize>) {
    let mut idx: Vec<usize> = (0..n).collect();
    idx.shuffle(&mut Pcg64::seed_from_u64(seed));
    let mut n_train = (n as f64 * train_fraction).round() as usize;
    if n >= 2 {
        n_train = n_train.clamp(1, n - 1);
    } else {
        n_train = n;
    }
    let mut train = idx[..n_train].to_vec();
    let mut test = idx[n_train..].to_vec();
    train.sort_unstable();
    test.sort_unstable();
    (train, test)
}

/// A seeded split stratified on the response: the rows sorted by `y` are cut into consecutive
/// blocks of about 1 / (1 - train_fraction) rows and one row of each block, drawn at random, is
/// a test row. The test rows then span the response's range. A purely random 5 of a CCD's 23
/// rows is often mostly centre points, whose spread is pure error, and an R^2 on them says
/// nothing about the model (on the silage CCD, a polynomial that explains 94 % of the variance
/// scores a test R^2 below 0.8 on most random splits).
pub fn split_stratified(y: &[f64], train_fraction: f64, seed: u64) -> (Vec<usize>, Vec<usize>) {
    let n = y.len();
    if n < 2 {
        return ((0..n).collect(), Vec::new());
    }
    let mut order: Vec<usize> = (0..n).collect();
    // Ties (and NaN, which the callers refuse earlier) keep row order: the split is a pure
    // function of the data and the seed.
    order.sort_by(|&a, &b| y[a].total_cmp(&y[b]).then(a.cmp(&b)));
    let n_test = ((n as f64 * (1.0 - train_fraction)).round() as usize).clamp(1, n - 1);
    let mut rng = Pcg64::seed_from_u64(seed);
    let mut test = Vec::with_capacity(n_test);
    for b in 0..n_test {
        // Block b holds sorted positions [b n / n_test, (b + 1) n / n_test).
        let (lo, hi) = (b * n / n_test, (b + 1) * n / n_test);
        test.push(order[rng.gen_range(lo..hi)]);
    }
    test.sort_unstable();
    let train = (0..n).filter(|i| test.binary_search(i).is_err()).collect();
    (train, test)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn metrics_of_a_known_prediction() {
        let m = FitMetrics::of(&[1.0, 2.0, 3.0, 4.0], &[1.0, 2.0, 3.0, 5.0]);
        // SS_tot = 5, SS_res = 1.
        assert!((m.r2 - 0.8).abs() < 1e-12);
        assert!((m.rmse - 0.5).abs() < 1e-12);
        assert!((m.mae - 0.25).abs() < 1e-12);
    }

    #[test]
    fn stratified_split_takes_one_test_row_per_block_of_the_sorted_response() {
        let y: Vec<f64> = (0..23).map(|i| ((i * 7) % 23) as f64).collect();
        let (train, test) = split_stratified(&y, 0.8, 3);
        assert_eq!((train.len(), test.len()), (18, 5));
        // Block b of the sorted responses 0..22 holds values [b 23 / 5, (b + 1) 23 / 5).
        let mut vals: Vec<f64> = test.iter().map(|&i| y[i]).collect();
        vals.sort_by(f64::total_cmp);
        for (b, v) in vals.iter().enumerate() {
            assert!(
                *v >= (b * 23 / 5) as f64 && *v < ((b + 1) * 23 / 5) as f64,
                "{vals:?}"
            );
        }
        assert_eq!(split_stratified(&y, 0.8, 3), (train, test));
    }

    #[test]
    fn split_is_seeded_and_covers_every_row() {
        let (a, b) = split_train_test(23, 0.8, 7);
        assert_eq!((a.len(), b.len()), (18, 5));
        let mut all = [a.clone(), b].concat();
        all.sort_unstable();
        assert_eq!(all, (0..23).collect::<Vec<_>>());
        assert_eq!(split_train_test(23, 0.8, 7).0, a);
    }
}
