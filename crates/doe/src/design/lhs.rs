//! Latin hypercubes: one point per stratum of every factor, the strata's order a seeded
//! permutation per factor, and the maximin variant's pair-swap search for the permutations that
//! spread the runs widest.

use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;

use super::{check_size, Design};

/// Most runs of a maximin Latin hypercube: its search compares every pair of runs.
pub const MAX_MAXIMIN_RUNS: usize = 10_000;
/// Pair-distance terms (pairs x factors) the maximin search may evaluate in all (its first scan
/// of every pair, its swaps and its rescans), so that large hypercubes end in seconds; the usual
/// sizes never reach it. A hypercube whose first scan alone passes it is refused.
pub const MAXIMIN_WORK: usize = 2_000_000_000;

/// Latin hypercube variants.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LhsKind {
    /// A random point inside each stratum.
    Random,
    /// The centre of each stratum.
    Centred,
    /// Centred strata, permutations improved by pair swaps to maximise the smallest distance.
    Maximin,
}

/// Latin hypercube of `n` runs in coded units [-1, 1]: exactly one point per stratum per factor.
pub fn latin_hypercube(k: usize, n: usize, kind: LhsKind, seed: u64) -> Result<Design, String> {
    if k == 0 || n < 2 {
        return Err(format!(
            "Latin hypercube: expected at least 1 factor and 2 runs, got {k} and {n}"
        ));
    }
    check_size("Latin hypercube", k, n)?;
    if kind == LhsKind::Maximin && n > MAX_MAXIMIN_RUNS {
        return Err(format!(
            "Latin hypercube (maximin): {n} runs asked, at most {MAX_MAXIMIN_RUNS} (the search compares every pair of runs)"
        ));
    }
    let scan = (n * (n - 1) / 2 * k).max(1);
    if kind == LhsKind::Maximin && scan > MAXIMIN_WORK {
        return Err(format!(
            "Latin hypercube (maximin): {n} runs of {k} factors make {scan} pair terms to compare, at most {MAXIMIN_WORK}: use fewer runs or factors, or a centred or random hypercube"
        ));
    }
    let mut rng = Pcg64::seed_from_u64(seed);
    let mut perms: Vec<Vec<usize>> = (0..k)
        .map(|_| {
            let mut p: Vec<usize> = (0..n).collect();
            p.shuffle(&mut rng);
            p
        })
        .collect();
    if kind == LhsKind::Maximin {
        maximin(&mut perms, &mut rng, scan);
    }
    let runs = (0..n)
        .map(|r| {
            (0..k)
                .map(|j| {
                    let u = match kind {
                        LhsKind::Random => rng.gen::<f64>(),
                        LhsKind::Centred | LhsKind::Maximin => 0.5,
                    };
                    2.0 * (perms[j][r] as f64 + u) / n as f64 - 1.0
                })
                .collect()
        })
        .collect();
    let name = match kind {
        LhsKind::Random => "random",
        LhsKind::Centred => "centred",
        LhsKind::Maximin => "maximin",
    };
    Ok(Design::new(
        format!("Latin hypercube ({name}), {n} runs"),
        k,
        runs,
    ))
}

/// Improves the permutations (`perms[j]`: the stratum of each run in factor j) by random pair
/// swaps within a factor, keeping a swap when the smallest distance between two runs does not
/// fall; `scan` is the work of one pass over every pair.
fn maximin(perms: &mut [Vec<usize>], rng: &mut Pcg64, scan: usize) {
    let (k, n) = (perms.len(), perms[0].len());
    let pair = |perms: &[Vec<usize>], a: usize, b: usize| -> f64 {
        (0..k)
            .map(|j| (perms[j][a] as f64 - perms[j][b] as f64).powi(2))
            .sum()
    };
    // The smallest pair distance, and how many pairs have it.
    let min_dist = |perms: &[Vec<usize>]| -> (f64, usize) {
        let (mut best, mut count) = (f64::INFINITY, 0);
        for a in 0..n {
            for b in a + 1..n {
                let d = pair(perms, a, b);
                if d < best {
                    (best, count) = (d, 1);
                } else if d == best {
                    count += 1;
                }
            }
        }
        (best, count)
    };
    // The pairs holding row a or b, each once: all a swap of a and b changes.
    let changed = |perms: &[Vec<usize>], a: usize, b: usize, f: &mut dyn FnMut(f64)| {
        for x in 0..n {
            if x != a {
                f(pair(perms, a, x));
            }
            if x != a && x != b {
                f(pair(perms, b, x));
            }
        }
    };
    // A swap is kept when the smallest distance does not fall. The pairs it leaves alone
    // are at least the current minimum, so that is decided by the changed pairs alone (2n
    // distances); and the minimum stays while some pair still has it, so a full rescan is
    // needed only when the last such pair goes. Same choices as rescanning every time, far
    // fewer distances. A work cap ends the search of very large hypercubes.
    let mut work_left = MAXIMIN_WORK - scan;
    let (mut current, mut at_min) = min_dist(perms);
    for _ in 0..(200 * n * k).min(20_000) {
        // Each swap looks at the 2n pairs of its two rows, before and after.
        let swap = 4 * n * k;
        if work_left < swap {
            break;
        }
        work_left -= swap;
        let j = rng.gen_range(0..k);
        let (a, b) = (rng.gen_range(0..n), rng.gen_range(0..n));
        if a == b {
            continue;
        }
        let mut before = 0;
        changed(perms, a, b, &mut |d| before += usize::from(d == current));
        perms[j].swap(a, b);
        let (mut keeps, mut after) = (true, 0);
        changed(perms, a, b, &mut |d| {
            keeps &= d >= current;
            after += usize::from(d == current);
        });
        if keeps {
            at_min = at_min - before + after;
            if at_min == 0 {
                if work_left < scan {
                    break;
                }
                work_left -= scan;
                (current, at_min) = min_dist(perms);
            }
        } else {
            perms[j].swap(a, b);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn column(d: &Design, j: usize) -> Vec<f64> {
        d.runs.iter().map(|r| r[j]).collect()
    }

    #[test]
    fn latin_hypercube_has_one_point_per_stratum() {
        for kind in [LhsKind::Random, LhsKind::Centred, LhsKind::Maximin] {
            let (k, n) = (4, 15);
            let d = latin_hypercube(k, n, kind, 9).unwrap();
            assert_eq!(d.runs.len(), n);
            for j in 0..k {
                let mut strata: Vec<usize> = column(&d, j)
                    .iter()
                    .map(|v| (((v + 1.0) / 2.0 * n as f64).floor() as usize).min(n - 1))
                    .collect();
                strata.sort_unstable();
                assert_eq!(strata, (0..n).collect::<Vec<_>>(), "{kind:?} factor {j}");
            }
            assert_eq!(d, latin_hypercube(k, n, kind, 9).unwrap(), "seeded");
        }
        // Maximin spreads points at least as well as the centred start it improves on.
        let min_d = |d: &Design| {
            let mut m = f64::INFINITY;
            for a in 0..d.runs.len() {
                for b in a + 1..d.runs.len() {
                    m = m.min(
                        d.runs[a]
                            .iter()
                            .zip(&d.runs[b])
                            .map(|(x, y)| (x - y).powi(2))
                            .sum(),
                    );
                }
            }
            m
        };
        let c = latin_hypercube(3, 20, LhsKind::Centred, 2).unwrap();
        let m = latin_hypercube(3, 20, LhsKind::Maximin, 2).unwrap();
        assert!(min_d(&m) >= min_d(&c));
    }
}
