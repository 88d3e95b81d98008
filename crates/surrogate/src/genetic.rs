//! A real-coded genetic algorithm: the optimiser of the GA-BP papers, both for the initial weights
//! of a BP network (GA-BP) and for the inputs of a trained network whose prediction hits the lab
//! value (GA-BP-GA).
//!
//! Each generation keeps the best individuals unchanged (elitism, so the best value never gets
//! worse), fills the rest by binary tournaments, blends pairs of parents gene by gene (extended
//! intermediate recombination) and mutates genes by Michalewicz's non-uniform mutation, whose
//! step shrinks as the generations run out: early generations explore the whole box, late ones
//! polish the best point to many digits, which is what a target search to 0.01 deg needs.
//!
//! Everything runs on one thread from one seeded generator in a fixed order, so the same bounds,
//! objective and options give the same result bit for bit.

use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use serde::Serialize;

/// Settings of the genetic algorithm.
#[derive(Clone, Debug)]
pub struct GaOptions {
    /// Generations after the initial population.
    pub generations: usize,
    /// Individuals per generation (at least 2).
    pub population: usize,
    /// Probability that a selected pair is recombined rather than copied.
    pub crossover: f64,
    /// Probability that a gene of a child is mutated.
    pub mutation: f64,
    pub seed: u64,
}

impl GaOptions {
    /// The published GA-BP setting for the initial weights: 200 generations of 100, crossover
    /// 0.8, mutation 0.2.
    pub fn weights_default(seed: u64) -> Self {
        GaOptions {
            generations: 200,
            population: 100,
            crossover: 0.8,
            mutation: 0.2,
            seed,
        }
    }

    /// The published GA-BP-GA setting for the search of the trained network: 100 generations of
    /// 100, crossover 0.8, mutation 0.2.
    pub fn search_default(seed: u64) -> Self {
        GaOptions {
            generations: 100,
            population: 100,
            crossover: 0.8,
            mutation: 0.2,
            seed,
        }
    }

    fn validate(&self) -> Result<(), String> {
        if self.population < 2 {
            return Err(format!(
                "GA: expected a population of at least 2, got {}",
                self.population
            ));
        }
        for (name, p) in [("crossover", self.crossover), ("mutation", self.mutation)] {
            if !(0.0..=1.0).contains(&p) {
                return Err(format!(
                    "GA: expected a {name} probability in [0, 1], got {p}"
                ));
            }
        }
        Ok(())
    }
}

/// The best point found, its objective value, and the best value after each generation.
#[derive(Clone, Debug, Serialize)]
pub struct GaResult {
    pub best: Vec<f64>,
    pub value: f64,
    /// Best value after each generation (one entry per generation, non-increasing).
    pub history: Vec<f64>,
}

/// Shape of the non-uniform mutation: how fast its step shrinks over the generations
/// (Michalewicz's b; 2 to 5 are usual, larger shrinks sooner).
const NON_UNIFORM_B: f64 = 3.0;

/// How far past its parents a blended gene may go (extended intermediate recombination: the
/// weight is drawn from [-D, 1 + D]); some overshoot keeps the population from contracting
/// onto the interior of its own hull.
const BLEND_OVERSHOOT: f64 = 0.25;

/// Checks a search box: at least one dimension, finite, lower <= upper.
pub fn validate_bounds(bounds: &[(f64, f64)]) -> Result<(), String> {
    if bounds.is_empty() {
        return Err("GA: expected at least one bounded variable, got none".into());
    }
    for (i, &(lo, hi)) in bounds.iter().enumerate() {
        if !lo.is_finite() || !hi.is_finite() || lo > hi {
            return Err(format!(
                "GA: expected finite bounds with lower <= upper for variable {i}, got ({lo}, {hi})"
            ));
        }
    }
    Ok(())
}

/// Minimises f over the box (real-coded GA: tournament selection, arithmetic/blend crossover,
/// non-uniform mutation clipped to the box, elitism).
///
/// A non-finite objective value counts as worse than every finite one. Errors on an empty or
/// non-finite box, bad options, or an objective that is finite nowhere it was tried.
pub fn minimize(
    bounds: &[(f64, f64)],
    mut f: impl FnMut(&[f64]) -> f64,
    opts: &GaOptions,
) -> Result<GaResult, String> {
    validate_bounds(bounds)?;
    opts.validate()?;
    let dim = bounds.len();
    let pop_size = opts.population;
    // Two elites out of a hundred: enough to keep the best and a runner-up, few enough that the
    // population does not collapse onto them.
    let elites = (pop_size / 50).clamp(1, pop_size - 1);
    let mut rng = Pcg64::seed_from_u64(opts.seed);
    let mut eval = |x: &[f64]| {
        let v = f(x);
        if v.is_finite() {
            v
        } else {
            f64::INFINITY
        }
    };

    let mut pop: Vec<Vec<f64>> = (0..pop_size)
        .map(|_| {
            bounds
                .iter()
                .map(|&(lo, hi)| lo + (hi - lo) * rng.gen::<f64>())
                .collect()
        })
        .collect();
    let mut fit: Vec<f64> = pop.iter().map(|x| eval(x)).collect();
    let mut history = Vec::with_capacity(opts.generations);

    for gen in 0..opts.generations {
        // Elites first, by value then by index, so ties resolve the same way every time.
        let mut order: Vec<usize> = (0..pop_size).collect();
        order.sort_by(|&a, &b| fit[a].total_cmp(&fit[b]).then(a.cmp(&b)));
        let mut next: Vec<Vec<f64>> = order[..elites].iter().map(|&i| pop[i].clone()).collect();
        let mut next_fit: Vec<f64> = order[..elites].iter().map(|&i| fit[i]).collect();

        // Fraction of the run still to go, for the non-uniform mutation's shrinking step.
        let remaining = 1.0 - gen as f64 / opts.generations as f64;
        while next.len() < pop_size {
            let a = tournament(&fit, &mut rng);
            let b = tournament(&fit, &mut rng);
            let (mut c1, mut c2) = (pop[a].clone(), pop[b].clone());
            if rng.gen::<f64>() < opts.crossover {
                for k in 0..dim {
                    let w = -BLEND_OVERSHOOT + (1.0 + 2.0 * BLEND_OVERSHOOT) * rng.gen::<f64>();
                    let (pa, pb) = (pop[a][k], pop[b][k]);
                    c1[k] = w * pa + (1.0 - w) * pb;
                    c2[k] = (1.0 - w) * pa + w * pb;
                }
            }
            for mut child in [c1, c2] {
                if next.len() == pop_size {
                    break;
                }
                for (k, &(lo, hi)) in bounds.iter().enumerate() {
                    if rng.gen::<f64>() < opts.mutation {
                        child[k] = non_uniform(child[k], lo, hi, remaining, &mut rng);
                    }
                    child[k] = child[k].clamp(lo, hi);
                }
                next_fit.push(eval(&child));
                next.push(child);
            }
        }
        pop = next;
        fit = next_fit;
        history.push(fit.iter().copied().fold(f64::INFINITY, f64::min));
    }

    let best_i = (0..pop_size)
        .min_by(|&a, &b| fit[a].total_cmp(&fit[b]).then(a.cmp(&b)))
        .unwrap_or(0);
    if !fit[best_i].is_finite() {
        return Err("GA: expected an objective finite somewhere in the box, got none".into());
    }
    Ok(GaResult {
        best: pop[best_i].clone(),
        value: fit[best_i],
        history,
    })
}

/// Binary tournament: the better of two individuals drawn at random (the lower index on a tie).
fn tournament(fit: &[f64], rng: &mut Pcg64) -> usize {
    let a = rng.gen_range(0..fit.len());
    let b = rng.gen_range(0..fit.len());
    match fit[a].total_cmp(&fit[b]) {
        std::cmp::Ordering::Less => a,
        std::cmp::Ordering::Greater => b,
        std::cmp::Ordering::Equal => a.min(b),
    }
}

/// Michalewicz's non-uniform mutation: a move towards one side of the box by a random fraction
/// of the room there, the fraction shrinking to zero as `remaining` (the share of generations
/// left) goes to zero.
fn non_uniform(x: f64, lo: f64, hi: f64, remaining: f64, rng: &mut Pcg64) -> f64 {
    let r: f64 = rng.gen();
    let shrink = 1.0 - r.powf(remaining.powf(NON_UNIFORM_B));
    if rng.gen::<bool>() {
        x + (hi - x) * shrink
    } else {
        x - (x - lo) * shrink
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn non_uniform_mutation_stays_in_the_box_and_shrinks() {
        let mut rng = Pcg64::seed_from_u64(1);
        for _ in 0..1000 {
            let y = non_uniform(0.3, -1.0, 2.0, 0.7, &mut rng);
            assert!((-1.0..=2.0).contains(&y));
        }
        // With no generations left the step is zero.
        assert_eq!(non_uniform(0.3, -1.0, 2.0, 0.0, &mut rng), 0.3);
    }

    #[test]
    fn tournament_prefers_the_better() {
        let mut rng = Pcg64::seed_from_u64(2);
        let fit = [3.0, 1.0, 2.0];
        let wins = (0..3000)
            .filter(|_| tournament(&fit, &mut rng) == 1)
            .count();
        // P(index 1 wins) = 1 - (2/3)^2 = 5/9.
        assert!((wins as f64 / 3000.0 - 5.0 / 9.0).abs() < 0.05, "{wins}");
    }
}
