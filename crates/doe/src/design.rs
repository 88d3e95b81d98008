//! Design generators. Every design holds coded runs (one row per run, one column per factor) in
//! standard order; [`Design::run_order`] gives a seeded randomised order to run them in.

use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;

mod lhs;
pub use lhs::{latin_hypercube, LhsKind, MAXIMIN_WORK, MAX_MAXIMIN_RUNS};

/// Most runs a design may have (centre points included): a hundred thousand simulations is
/// beyond any calibration, and the check comes before anything is allocated.
pub const MAX_RUNS: usize = 100_000;
/// Most runs of a Plackett-Burman design (its construction holds a runs x runs matrix).
pub const MAX_PB_RUNS: usize = 1024;

/// A generated design in coded units.
#[derive(Clone, Debug, PartialEq)]
pub struct Design {
    /// What it is, e.g. "central composite (rotatable, alpha = 1.68179)".
    pub kind: String,
    pub factors: usize,
    /// Coded runs in standard order.
    pub runs: Vec<Vec<f64>>,
    /// Of the runs, how many (at the end) are centre points.
    pub center_points: usize,
    /// Fractional factorials: the generators, e.g. "D = ABC".
    pub generators: Vec<String>,
    /// Fractional factorials: the defining relation words, e.g. "ABCD".
    pub defining_relation: Vec<String>,
    /// Fractional factorials: the alias chains of main effects and two-factor interactions.
    pub aliases: Vec<String>,
    /// Central composite designs: the axial distance in coded units.
    pub alpha: Option<f64>,
    /// Runs that must be made in order (a steepest path), not shuffled.
    pub sequential: bool,
}

impl Design {
    fn new(kind: String, factors: usize, runs: Vec<Vec<f64>>) -> Design {
        Design {
            kind,
            factors,
            runs,
            center_points: 0,
            generators: Vec::new(),
            defining_relation: Vec::new(),
            aliases: Vec::new(),
            alpha: None,
            sequential: false,
        }
    }

    /// Appends `n` centre points.
    pub fn with_center_points(mut self, n: usize) -> Design {
        for _ in 0..n {
            self.runs.push(vec![0.0; self.factors]);
        }
        self.center_points += n;
        self
    }

    /// A seeded random order in which to run the design (indices into `runs`); a sequential
    /// design keeps its own order.
    pub fn run_order(&self, seed: u64) -> Vec<usize> {
        let mut order: Vec<usize> = (0..self.runs.len()).collect();
        if !self.sequential {
            order.shuffle(&mut Pcg64::seed_from_u64(seed));
        }
        order
    }
}

/// Factor letters as Design-Expert writes them: A..Z without I, then A'..
pub fn factor_letter(k: usize) -> String {
    const LETTERS: &[u8] = b"ABCDEFGHJKLMNOPQRSTUVWXYZ";
    let base = LETTERS[k % LETTERS.len()] as char;
    if k < LETTERS.len() {
        base.to_string()
    } else {
        format!("{base}{}", "'".repeat(k / LETTERS.len()))
    }
}

/// Two-level full factorial 2^k in standard (Yates) order: factor j switches every 2^j runs.
pub fn full_factorial(k: usize) -> Result<Design, String> {
    if !(1..=20).contains(&k) {
        return Err(format!("full factorial: expected 1 to 20 factors, got {k}"));
    }
    let runs = (0..1usize << k)
        .map(|r| {
            (0..k)
                .map(|j| if r >> j & 1 == 1 { 1.0 } else { -1.0 })
                .collect()
        })
        .collect();
    Ok(Design::new(format!("full factorial 2^{k}"), k, runs))
}

/// A word (interaction) as a bit mask over factors.
type Word = u32;

fn word_name(w: Word) -> String {
    (0..32)
        .filter(|j| w >> j & 1 == 1)
        .map(factor_letter)
        .collect()
}

/// All products of the generator words: the defining relation (without I).
fn defining_words(generators: &[Word]) -> Vec<Word> {
    let mut words = Vec::new();
    for mask in 1..(1u32 << generators.len()) {
        let w = (0..generators.len())
            .filter(|g| mask >> g & 1 == 1)
            .fold(0, |acc, g| acc ^ generators[g]);
        words.push(w);
    }
    words.sort_by_key(|w| (w.count_ones(), *w));
    words
}

/// Word length pattern (A3, A4, ...): fewer short words is better (minimum aberration).
fn word_length_pattern(words: &[Word], k: usize) -> Vec<usize> {
    (3..=k)
        .map(|l| {
            words
                .iter()
                .filter(|w| w.count_ones() as usize == l)
                .count()
        })
        .collect()
}

/// The largest custom axial distance of a central composite design (coded units). The
/// rotatable alpha of 24 factors is 16.
pub const MAX_ALPHA: f64 = 100.0;

/// Generators chosen one at a time, each the candidate that keeps the word-length pattern
/// smallest (for fractions with too many combinations to try them all).
fn greedy_generators(
    candidates: &[Word],
    p: usize,
    m: usize,
    k: usize,
) -> Result<Vec<Word>, String> {
    let mut chosen: Vec<Word> = Vec::new();
    for _ in 0..p {
        let mut pick = None;
        let mut pick_pattern: Option<Vec<usize>> = None;
        for &c in candidates {
            if chosen.contains(&c) {
                continue;
            }
            let mut trial = chosen.clone();
            trial.push(c);
            let gens: Vec<Word> = trial
                .iter()
                .enumerate()
                .map(|(g, &c)| c | 1 << (m + g))
                .collect();
            let words = defining_words(&gens);
            if words.iter().any(|w| w.count_ones() < 3) {
                continue;
            }
            let pattern = word_length_pattern(&words, k);
            if pick_pattern.as_ref().is_none_or(|bp| pattern < *bp) {
                pick = Some(c);
                pick_pattern = Some(pattern);
            }
        }
        chosen.push(pick.ok_or_else(|| {
            format!("fractional factorial 2^({k}-{p}): no fraction of resolution III or more")
        })?);
    }
    Ok(chosen)
}

/// Alias chains for main effects and two-factor interactions, up to three-factor terms.
fn alias_chains(words: &[Word], k: usize) -> Vec<String> {
    let mut aliases = Vec::new();
    let mut effects: Vec<Word> = (0..k).map(|j| 1 << j).collect();
    for a in 0..k {
        for b in a + 1..k {
            effects.push(1 << a | 1 << b);
        }
    }
    for e in effects {
        let mut chain: Vec<Word> = words
            .iter()
            .map(|w| w ^ e)
            .filter(|a| a.count_ones() <= 3)
            .collect();
        chain.sort_by_key(|w| (w.count_ones(), *w));
        if !chain.is_empty() {
            let names: Vec<String> = chain.iter().map(|&w| word_name(w)).collect();
            aliases.push(format!("{} = {}", word_name(e), names.join(" = ")));
        }
    }
    aliases
}

/// Regular two-level fractional factorial 2^(k-p), with minimum-aberration generators found by
/// search over the interactions of the k - p base factors (exhaustive while that stays small).
/// Returns an error when no fraction reaches `min_resolution`.
pub fn fractional_factorial(k: usize, p: usize, min_resolution: usize) -> Result<Design, String> {
    // Resolution III is the least a design that estimates main effects can have.
    if min_resolution < 3 {
        return Err(format!(
            "fractional factorial: resolution {min_resolution} asked; expected 3 (III) or more"
        ));
    }
    if p == 0 {
        return full_factorial(k);
    }
    if k < 3 || p >= k || k - p < 2 || k > 24 {
        return Err(format!(
            "fractional factorial 2^({k}-{p}): expected 3 <= k <= 24 and 1 <= p <= k - 2"
        ));
    }
    let m = k - p;
    // Candidate generator columns: interactions of at least two base factors.
    let candidates: Vec<Word> = (1u32..(1 << m)).filter(|w| w.count_ones() >= 2).collect();
    if candidates.len() < p {
        return Err(format!(
            "fractional factorial 2^({k}-{p}): too few base factors for {p} generators"
        ));
    }
    let mut best: Option<(Vec<usize>, Vec<Word>)> = None;
    let mut consider = |choice: &[Word]| {
        // Generator g adds factor m + g: its word is the base interaction times the new factor.
        let gens: Vec<Word> = choice
            .iter()
            .enumerate()
            .map(|(g, &c)| c | 1 << (m + g))
            .collect();
        let words = defining_words(&gens);
        let pattern = word_length_pattern(&words, k);
        if words.iter().any(|w| w.count_ones() < 3) {
            return;
        }
        if best.as_ref().is_none_or(|(bp, _)| pattern < *bp) {
            best = Some((pattern, gens));
        }
    };
    // Exhaustive over combinations when affordable, else greedy (each generator the one that keeps
    // the pattern smallest).
    let combos = binomial(candidates.len(), p);
    if combos <= 300_000.0 {
        let mut idx: Vec<usize> = (0..p).collect();
        loop {
            let choice: Vec<Word> = idx.iter().map(|&i| candidates[i]).collect();
            consider(&choice);
            // Next combination.
            let mut i = p;
            loop {
                if i == 0 {
                    break;
                }
                i -= 1;
                if idx[i] < candidates.len() - p + i {
                    idx[i] += 1;
                    for j in i + 1..p {
                        idx[j] = idx[j - 1] + 1;
                    }
                    break;
                }
                if i == 0 {
                    idx.clear();
                }
            }
            if idx.is_empty() || idx[0] > candidates.len() - p {
                break;
            }
        }
    } else {
        let chosen = greedy_generators(&candidates, p, m, k)?;
        consider(&chosen);
    }
    let (_, gens) = best.ok_or_else(|| {
        format!("fractional factorial 2^({k}-{p}): no fraction of resolution III or more")
    })?;
    let words = defining_words(&gens);
    let resolution = words
        .iter()
        .map(|w| w.count_ones() as usize)
        .min()
        .unwrap_or(k + 1);
    if resolution < min_resolution {
        return Err(format!(
            "fractional factorial 2^({k}-{p}): the best fraction has resolution {} (asked for at least {})",
            roman(resolution),
            roman(min_resolution)
        ));
    }
    let base = full_factorial(m)?;
    let runs: Vec<Vec<f64>> = base
        .runs
        .iter()
        .map(|r| {
            let mut row = r.clone();
            for g in &gens {
                let base_part = g & ((1 << m) - 1);
                row.push(
                    (0..m)
                        .filter(|j| base_part >> j & 1 == 1)
                        .map(|j| r[j])
                        .product(),
                );
            }
            row
        })
        .collect();
    let mut d = Design::new(
        format!(
            "fractional factorial 2^({k}-{p}), resolution {}",
            roman(resolution)
        ),
        k,
        runs,
    );
    d.generators = gens
        .iter()
        .enumerate()
        .map(|(g, w)| {
            format!(
                "{} = {}",
                factor_letter(m + g),
                word_name(w & ((1 << m) - 1))
            )
        })
        .collect();
    d.defining_relation = words.iter().map(|&w| word_name(w)).collect();
    d.aliases = alias_chains(&words, k);
    Ok(d)
}

/// Smallest fraction 2^(k-p) with at least `resolution`.
pub fn fractional_factorial_by_resolution(k: usize, resolution: usize) -> Result<Design, String> {
    let mut last_err = String::new();
    for p in (0..k.saturating_sub(1)).rev() {
        match fractional_factorial(k, p, resolution) {
            Ok(d) => return Ok(d),
            Err(e) => last_err = e,
        }
    }
    Err(last_err)
}

fn binomial(n: usize, k: usize) -> f64 {
    (0..k).fold(1.0, |acc, i| acc * (n - i) as f64 / (i + 1) as f64)
}

fn roman(r: usize) -> String {
    [
        "0", "I", "II", "III", "IV", "V", "VI", "VII", "VIII", "IX", "X",
    ]
    .get(r)
    .map(|s| s.to_string())
    .unwrap_or_else(|| r.to_string())
}

fn is_prime(n: usize) -> bool {
    n >= 2
        && (2..)
            .take_while(|d| d * d <= n)
            .all(|d| !n.is_multiple_of(d))
}

/// Run counts `plackett_burman` can build: powers of two (Sylvester) and N with N - 1 a prime
/// congruent to 3 mod 4 (Paley's cyclic designs, which include Plackett and Burman's 12, 20 and 24),
/// and doublings of those.
pub fn plackett_burman_sizes(up_to: usize) -> Vec<usize> {
    let mut ok: Vec<usize> = (4..=up_to)
        .filter(|&n| n % 4 == 0 && pb_construction(n).is_some())
        .collect();
    ok.dedup();
    ok
}

enum PbConstruction {
    Paley(usize),
    Double(usize),
}

fn pb_construction(n: usize) -> Option<PbConstruction> {
    if n >= 4 && is_prime(n - 1) && (n - 1) % 4 == 3 {
        Some(PbConstruction::Paley(n - 1))
    } else if n == 4 || n >= 4 && n.is_multiple_of(2) && pb_construction(n / 2).is_some() {
        Some(PbConstruction::Double(n / 2))
    } else {
        None
    }
}

/// Hadamard matrix of order n (first column all +1).
fn hadamard(n: usize) -> Option<Vec<Vec<f64>>> {
    match pb_construction(n)? {
        PbConstruction::Paley(q) => {
            // Cyclic generator: + at 0 and at the quadratic residues mod q (for q = 11 this is
            // Plackett and Burman's ++-+++---+-).
            let mut residue = vec![false; q];
            for x in 1..q {
                residue[x * x % q] = true;
            }
            let gen: Vec<f64> = (0..q)
                .map(|i| if i == 0 || residue[i] { 1.0 } else { -1.0 })
                .collect();
            let mut h = Vec::with_capacity(n);
            for r in 0..q {
                let mut row = vec![1.0];
                row.extend((0..q).map(|c| gen[(c + q - r) % q]));
                h.push(row);
            }
            let mut last = vec![1.0];
            last.extend(std::iter::repeat_n(-1.0, q));
            h.push(last);
            Some(h)
        }
        PbConstruction::Double(half) => {
            let h = if half == 2 {
                vec![vec![1.0, 1.0], vec![1.0, -1.0]]
            } else {
                hadamard(half)?
            };
            let mut out = Vec::with_capacity(n);
            for row in &h {
                out.push(row.iter().chain(row.iter()).cloned().collect());
            }
            for row in &h {
                out.push(row.iter().cloned().chain(row.iter().map(|v| -v)).collect());
            }
            Some(out)
        }
    }
}

/// Plackett-Burman screening design for `k` factors in `runs` runs (None: the smallest that fits,
/// 12 runs for up to 11 factors), with centre points.
pub fn plackett_burman(
    k: usize,
    runs: Option<usize>,
    center_points: usize,
) -> Result<Design, String> {
    if k == 0 {
        return Err("Plackett-Burman: expected at least one factor".into());
    }
    if k >= MAX_PB_RUNS {
        return Err(format!(
            "Plackett-Burman: {k} factors, at most {}",
            MAX_PB_RUNS - 1
        ));
    }
    let n = match runs {
        Some(n) => n,
        // Powers of two always qualify, so the search ends by 2 * MAX_PB_RUNS.
        None => (12.max(k + 1)..)
            .find(|&n| n % 4 == 0 && pb_construction(n).is_some())
            .unwrap_or(usize::MAX),
    };
    if n > MAX_PB_RUNS {
        return Err(format!(
            "Plackett-Burman: {n} runs asked, at most {MAX_PB_RUNS}"
        ));
    }
    if n < k + 1 {
        return Err(format!(
            "Plackett-Burman: {n} runs hold at most {} factors, got {k}",
            n - 1
        ));
    }
    let h = hadamard(n).filter(|_| n % 4 == 0).ok_or_else(|| {
        format!(
            "Plackett-Burman: {n} runs not available (available: {:?}, ...)",
            plackett_burman_sizes(64)
        )
    })?;
    let rows = h.into_iter().map(|r| r[1..=k].to_vec()).collect();
    Ok(
        Design::new(format!("Plackett-Burman, {n} runs"), k, rows)
            .with_center_points(center_points),
    )
}

/// Axial distance choice of a central composite design.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum CcdAlpha {
    /// alpha = F^(1/4), F the number of cube points.
    Rotatable,
    /// alpha = sqrt(k).
    Spherical,
    /// alpha = 1 (face-centred).
    FaceCentred,
    /// alpha making the quadratic terms orthogonal: alpha^4 = F (sqrt(N) - sqrt(F))^2 / 4.
    Orthogonal,
    /// Rotatable, scaled so the axial points sit at +/-1 and the cube inside.
    Inscribed,
    Custom(f64),
}

/// Central composite design: cube (half fraction of resolution V for k >= 5 when `half_fraction`
/// is None), 2k axial points, and centre points.
pub fn central_composite(
    k: usize,
    alpha: CcdAlpha,
    center_points: usize,
    half_fraction: Option<bool>,
) -> Result<Design, String> {
    if !(2..=10).contains(&k) {
        return Err(format!(
            "central composite: expected 2 to 10 factors, got {k}"
        ));
    }
    let half = half_fraction.unwrap_or(k >= 5);
    let cube = if half {
        fractional_factorial(k, 1, 5.min(k))?
    } else {
        full_factorial(k)?
    };
    let f = cube.runs.len() as f64;
    let n = f + 2.0 * k as f64 + center_points as f64;
    let (a, name) = match alpha {
        CcdAlpha::Rotatable => (f.powf(0.25), "rotatable"),
        CcdAlpha::Spherical => ((k as f64).sqrt(), "spherical"),
        CcdAlpha::FaceCentred => (1.0, "face-centred"),
        CcdAlpha::Orthogonal => (
            (f * (n.sqrt() - f.sqrt()).powi(2) / 4.0).powf(0.25),
            "orthogonal",
        ),
        CcdAlpha::Inscribed => (f.powf(0.25), "inscribed"),
        // Past MAX_ALPHA the axial points leave any real range (1e308 wrote inf).
        CcdAlpha::Custom(a) if a > 0.0 && a <= MAX_ALPHA => (a, "custom alpha"),
        CcdAlpha::Custom(a) => {
            return Err(format!(
                "central composite: alpha must be a positive number up to {MAX_ALPHA}, got {a}"
            ))
        }
    };
    let scale = if alpha == CcdAlpha::Inscribed {
        1.0 / a
    } else {
        1.0
    };
    let mut runs: Vec<Vec<f64>> = cube
        .runs
        .iter()
        .map(|r| r.iter().map(|v| v * scale).collect())
        .collect();
    for j in 0..k {
        for s in [-1.0, 1.0] {
            let mut r = vec![0.0; k];
            r[j] = s * a * scale;
            runs.push(r);
        }
    }
    let axial = a * scale;
    let mut d = Design::new(
        format!(
            "central composite ({name}, alpha = {axial:.5}{})",
            if half { ", half-fraction cube" } else { "" }
        ),
        k,
        runs,
    )
    .with_center_points(center_points);
    d.alpha = Some(axial);
    d.generators = cube.generators;
    d.defining_relation = cube.defining_relation;
    Ok(d)
}

/// Box-Behnken design for 3 to 7 factors. For 3-5 factors every pair of factors takes the 2^2
/// corners with the others at 0; for 6 and 7 factors, Box and Behnken's triples (for 7 the
/// balanced incomplete block design of the Fano plane) take the 2^3 corners.
pub fn box_behnken(k: usize, center_points: usize) -> Result<Design, String> {
    let blocks: Vec<Vec<usize>> = match k {
        3..=5 => (0..k)
            .flat_map(|a| (a + 1..k).map(move |b| vec![a, b]))
            .collect(),
        6 => vec![
            vec![0, 1, 3],
            vec![1, 2, 4],
            vec![2, 3, 5],
            vec![0, 3, 4],
            vec![1, 4, 5],
            vec![0, 2, 5],
        ],
        7 => vec![
            vec![3, 4, 5],
            vec![0, 5, 6],
            vec![1, 4, 6],
            vec![0, 1, 3],
            vec![2, 3, 6],
            vec![1, 2, 5],
            vec![0, 2, 4],
        ],
        _ => return Err(format!("Box-Behnken: expected 3 to 7 factors, got {k}")),
    };
    let mut runs = Vec::new();
    for b in &blocks {
        for corner in 0..1usize << b.len() {
            let mut r = vec![0.0; k];
            for (t, &f) in b.iter().enumerate() {
                r[f] = if corner >> t & 1 == 1 { 1.0 } else { -1.0 };
            }
            runs.push(r);
        }
    }
    Ok(Design::new(format!("Box-Behnken, {k} factors"), k, runs).with_center_points(center_points))
}

/// Refuses a design of `n` runs of `k` factors beyond [`MAX_RUNS`] runs or ten million values.
fn check_size(what: &str, k: usize, n: usize) -> Result<(), String> {
    if n > MAX_RUNS {
        return Err(format!("{what}: {n} runs asked, at most {MAX_RUNS}"));
    }
    if n.saturating_mul(k) > 10_000_000 {
        return Err(format!(
            "{what}: {n} runs of {k} factors are {} values, at most 10000000",
            n.saturating_mul(k)
        ));
    }
    Ok(())
}

/// Uniform random points in the coded box, for comparison with space-filling designs.
pub fn random_design(k: usize, n: usize, seed: u64) -> Result<Design, String> {
    check_size("random design", k, n)?;
    let mut rng = Pcg64::seed_from_u64(seed);
    let runs = (0..n)
        .map(|_| (0..k).map(|_| rng.gen_range(-1.0..=1.0)).collect())
        .collect();
    Ok(Design::new(format!("random, {n} runs"), k, runs))
}

/// Steepest ascent (or descent) path from the centre: step `i` moves every factor by
/// i * step * coefficient / max |coefficient| (coded units); zero coefficients stay at the centre.
/// Use the signs of significant effects or the fitted first-order coefficients; negate them to descend.
pub fn steepest_path(coefficients: &[f64], step: f64, steps: usize) -> Result<Design, String> {
    let biggest = coefficients.iter().fold(0.0f64, |m, c| m.max(c.abs()));
    if biggest == 0.0 {
        return Err("steepest path: every coefficient is zero, there is no direction".into());
    }
    if coefficients.iter().any(|c| !c.is_finite()) || !step.is_finite() {
        return Err("steepest path: the coefficients and the step must be finite numbers".into());
    }
    check_size("steepest path", coefficients.len(), steps.saturating_add(1))?;
    let runs = (0..=steps)
        .map(|i| {
            coefficients
                .iter()
                .map(|c| i as f64 * step * c / biggest)
                .collect()
        })
        .collect();
    let mut d = Design::new(
        format!("steepest path, {steps} steps of {step}"),
        coefficients.len(),
        runs,
    );
    d.sequential = true;
    Ok(d)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn column(d: &Design, j: usize) -> Vec<f64> {
        d.runs.iter().map(|r| r[j]).collect()
    }

    fn dot(a: &[f64], b: &[f64]) -> f64 {
        a.iter().zip(b).map(|(x, y)| x * y).sum()
    }

    #[test]
    fn plackett_burman_columns_are_balanced_and_orthogonal() {
        for n in [8, 12, 16, 20, 24, 32, 40, 44, 48] {
            let d = plackett_burman(n - 1, Some(n), 0).unwrap();
            assert_eq!(d.runs.len(), n);
            for a in 0..n - 1 {
                let ca = column(&d, a);
                assert_eq!(ca.iter().sum::<f64>(), 0.0, "N = {n}, column {a} balanced");
                for b in a + 1..n - 1 {
                    assert_eq!(
                        dot(&ca, &column(&d, b)),
                        0.0,
                        "N = {n}, columns {a} and {b} orthogonal"
                    );
                }
            }
        }
    }

    #[test]
    fn plackett_burman_12_uses_the_published_generator() {
        let d = plackett_burman(11, None, 1).unwrap();
        assert_eq!(d.runs.len(), 13);
        let first: String = d.runs[0]
            .iter()
            .map(|v| if *v > 0.0 { '+' } else { '-' })
            .collect();
        assert_eq!(first, "++-+++---+-");
        assert!(d.runs[12].iter().all(|v| *v == 0.0));
        assert_eq!(plackett_burman(8, None, 0).unwrap().runs.len(), 12);
        assert_eq!(plackett_burman(15, None, 0).unwrap().runs.len(), 16);
        assert!(plackett_burman(12, Some(28), 0).is_err());
    }

    #[test]
    fn fractional_factorial_generators_and_aliases() {
        let d = fractional_factorial(4, 1, 4).unwrap();
        assert_eq!(d.runs.len(), 8);
        assert_eq!(d.generators, ["D = ABC"]);
        assert_eq!(d.defining_relation, ["ABCD"]);
        assert!(d.kind.contains("resolution IV"));
        assert!(d.aliases.contains(&"A = BCD".to_string()));
        assert!(d.aliases.contains(&"AB = CD".to_string()));

        let d = fractional_factorial(5, 2, 3).unwrap();
        assert!(d.kind.contains("resolution III"), "{}", d.kind);
        assert_eq!(d.defining_relation.len(), 3);

        // Every word of the defining relation multiplies to +1 on every run.
        for (k, p) in [(5, 1), (6, 2), (7, 3), (8, 4), (7, 1), (9, 4)] {
            let d = fractional_factorial(k, p, 3).unwrap();
            assert_eq!(d.runs.len(), 1 << (k - p));
            for w in &d.defining_relation {
                let cols: Vec<usize> = w
                    .chars()
                    .map(|c| "ABCDEFGHJKLMNOPQRSTUVWXYZ".find(c).unwrap())
                    .collect();
                for r in &d.runs {
                    assert_eq!(
                        cols.iter().map(|&j| r[j]).product::<f64>(),
                        1.0,
                        "{k}-{p}: {w}"
                    );
                }
            }
        }
        // Known best resolutions: 2^(5-1) V, 2^(6-2) IV, 2^(7-3) IV, 2^(8-4) IV, 2^(7-4) III.
        for (k, p, res) in [
            (5, 1, "V"),
            (6, 2, "IV"),
            (7, 3, "IV"),
            (8, 4, "IV"),
            (7, 4, "III"),
            (6, 1, "VI"),
        ] {
            let d = fractional_factorial(k, p, 3).unwrap();
            assert!(
                d.kind.ends_with(&format!("resolution {res}")),
                "2^({k}-{p}): {}",
                d.kind
            );
        }
        assert!(fractional_factorial(7, 4, 4).is_err());
        assert_eq!(
            fractional_factorial_by_resolution(7, 4).unwrap().runs.len(),
            16
        );
    }

    #[test]
    fn central_composite_run_counts_and_alpha() {
        // (k, runs with 6 centre points, rotatable alpha)
        for (k, runs, alpha) in [
            (2, 14, std::f64::consts::SQRT_2),
            (3, 20, 1.68179),
            (4, 30, 2.0),
            (5, 32, 2.0),
            (6, 50, 2.37841),
        ] {
            let d = central_composite(k, CcdAlpha::Rotatable, 6, None).unwrap();
            assert_eq!(d.runs.len(), runs, "k = {k}");
            assert!(
                (d.alpha.unwrap() - alpha).abs() < 1e-5,
                "k = {k}: {}",
                d.alpha.unwrap()
            );
        }
        let d = central_composite(3, CcdAlpha::FaceCentred, 1, None).unwrap();
        assert_eq!(d.alpha, Some(1.0));
        let d = central_composite(3, CcdAlpha::Spherical, 1, None).unwrap();
        assert!((d.alpha.unwrap() - 3f64.sqrt()).abs() < 1e-12);
        // Orthogonal CCD: k = 2 with 1 centre point has alpha = 1; k = 3 with 1 centre 1.2154.
        let d = central_composite(2, CcdAlpha::Orthogonal, 1, None).unwrap();
        assert!((d.alpha.unwrap() - 1.0).abs() < 1e-12);
        let d = central_composite(3, CcdAlpha::Orthogonal, 1, None).unwrap();
        assert!(
            (d.alpha.unwrap() - 1.2154).abs() < 1e-3,
            "{}",
            d.alpha.unwrap()
        );
        // Inscribed: axial at 1, cube at 1/alpha.
        let d = central_composite(3, CcdAlpha::Inscribed, 0, None).unwrap();
        let max = d.runs.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
        assert!((max - 1.0).abs() < 1e-12);
        assert!((d.runs[0][0].abs() - 1.0 / 1.68179).abs() < 1e-5);
        // The squared columns of a rotatable CCD have equal sums (a symptom of rotatability).
        let d = central_composite(3, CcdAlpha::Rotatable, 6, None).unwrap();
        let s: Vec<f64> = (0..3)
            .map(|j| column(&d, j).iter().map(|v| v * v).sum())
            .collect();
        assert!((s[0] - s[1]).abs() < 1e-12 && (s[1] - s[2]).abs() < 1e-12);
    }

    #[test]
    fn box_behnken_run_counts() {
        for (k, c, runs) in [(3, 5, 17), (4, 5, 29), (5, 6, 46), (6, 6, 54), (7, 6, 62)] {
            let d = box_behnken(k, c).unwrap();
            assert_eq!(d.runs.len(), runs, "k = {k}");
            // Balanced: every factor takes -1, 0, +1, and every column sums to zero.
            for j in 0..k {
                let col = column(&d, j);
                assert_eq!(col.iter().sum::<f64>(), 0.0);
                assert!(col.contains(&1.0) && col.contains(&-1.0));
            }
        }
        assert!(box_behnken(2, 3).is_err());
        assert!(box_behnken(8, 3).is_err());
    }

    #[test]
    fn steepest_path_moves_in_proportion_to_the_coefficients() {
        let d = steepest_path(&[2.0, 0.0, -1.0], 0.5, 4).unwrap();
        assert_eq!(d.runs.len(), 5);
        assert_eq!(d.runs[0], [0.0, 0.0, 0.0]);
        assert_eq!(d.runs[2], [1.0, 0.0, -0.5]);
        assert!(steepest_path(&[0.0, 0.0], 1.0, 3).is_err());
    }

    #[test]
    fn run_order_is_a_seeded_permutation() {
        let d = box_behnken(3, 5).unwrap();
        let a = d.run_order(42);
        let mut sorted = a.clone();
        sorted.sort_unstable();
        assert_eq!(sorted, (0..17).collect::<Vec<_>>());
        assert_eq!(a, d.run_order(42));
        assert_ne!(a, d.run_order(43));
    }
}
