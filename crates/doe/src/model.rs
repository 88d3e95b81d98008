//! Polynomial model terms in coded factors, named the way Design-Expert names them.

use std::fmt::Write;

/// One polynomial term: the power of each factor. All powers zero is the intercept.
#[derive(Clone, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Term {
    pub powers: Vec<u8>,
}

impl Term {
    pub fn intercept(k: usize) -> Term {
        Term { powers: vec![0; k] }
    }

    pub fn main(k: usize, factor: usize) -> Term {
        let mut t = Term::intercept(k);
        t.powers[factor] = 1;
        t
    }

    /// Total degree: 1 for main effects, 2 for AB and A^2, ...
    pub fn order(&self) -> u32 {
        self.powers.iter().map(|&p| p as u32).sum()
    }

    pub fn is_intercept(&self) -> bool {
        self.order() == 0
    }

    pub fn value(&self, coded: &[f64]) -> f64 {
        self.powers
            .iter()
            .zip(coded)
            .fold(1.0, |acc, (&p, &x)| acc * x.powi(p as i32))
    }

    /// Whether `other` divides this term (A divides AB and A^2; AB divides A^2B). A term does not
    /// contain itself. Used to keep models hierarchical.
    pub fn contains(&self, other: &Term) -> bool {
        self != other
            && !other.is_intercept()
            && self.powers.iter().zip(&other.powers).all(|(a, b)| a >= b)
    }

    /// Design-Expert style name: `AB`, `A^2`, `A^2B`; with multi-letter factor names the parts are
    /// joined by `*` (`temp*speed`, `temp^2`).
    pub fn name(&self, factor_names: &[String]) -> String {
        if self.is_intercept() {
            return "Intercept".into();
        }
        let joiner = if factor_names.iter().all(|n| n.chars().count() == 1) {
            ""
        } else {
            "*"
        };
        let mut parts = Vec::new();
        for (name, &p) in factor_names.iter().zip(&self.powers) {
            match p {
                0 => {}
                1 => parts.push(name.clone()),
                _ => {
                    let mut s = name.clone();
                    write!(s, "^{p}").unwrap();
                    parts.push(s)
                }
            }
        }
        parts.join(joiner)
    }
}

/// The usual model orders.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ModelOrder {
    Mean,
    Linear,
    TwoFactorInteraction,
    Quadratic,
    Cubic,
}

impl ModelOrder {
    pub fn parse(s: &str) -> Option<ModelOrder> {
        Some(match s.to_ascii_lowercase().as_str() {
            "mean" => ModelOrder::Mean,
            "linear" => ModelOrder::Linear,
            "2fi" | "interaction" | "two-factor-interaction" => ModelOrder::TwoFactorInteraction,
            "quadratic" => ModelOrder::Quadratic,
            "cubic" => ModelOrder::Cubic,
            _ => return None,
        })
    }

    pub fn label(self) -> &'static str {
        match self {
            ModelOrder::Mean => "mean",
            ModelOrder::Linear => "linear",
            ModelOrder::TwoFactorInteraction => "2FI",
            ModelOrder::Quadratic => "quadratic",
            ModelOrder::Cubic => "cubic",
        }
    }

    /// Terms of the model (intercept first), in Design-Expert's order: main effects, two-factor
    /// interactions, squares, then the cubic terms.
    pub fn terms(self, k: usize) -> Vec<Term> {
        let mut terms = vec![Term::intercept(k)];
        if self == ModelOrder::Mean {
            return terms;
        }
        terms.extend((0..k).map(|i| Term::main(k, i)));
        if self == ModelOrder::Linear {
            return terms;
        }
        for i in 0..k {
            for j in i + 1..k {
                let mut t = Term::intercept(k);
                t.powers[i] = 1;
                t.powers[j] = 1;
                terms.push(t);
            }
        }
        if self == ModelOrder::TwoFactorInteraction {
            return terms;
        }
        for i in 0..k {
            let mut t = Term::intercept(k);
            t.powers[i] = 2;
            terms.push(t);
        }
        if self == ModelOrder::Quadratic {
            return terms;
        }
        for i in 0..k {
            for j in i + 1..k {
                for l in j + 1..k {
                    let mut t = Term::intercept(k);
                    t.powers[i] = 1;
                    t.powers[j] = 1;
                    t.powers[l] = 1;
                    terms.push(t);
                }
            }
        }
        for i in 0..k {
            for j in 0..k {
                if i != j {
                    let mut t = Term::intercept(k);
                    t.powers[i] = 2;
                    t.powers[j] = 1;
                    terms.push(t);
                }
            }
        }
        for i in 0..k {
            let mut t = Term::intercept(k);
            t.powers[i] = 3;
            terms.push(t);
        }
        terms
    }
}

/// Parses an explicit term list such as `A,B,C,AB,A^2` (single-letter factors) or
/// `temp,speed,temp*speed,temp^2`. The intercept is always included and need not be listed.
pub fn parse_terms(spec: &str, factor_names: &[String]) -> Result<Vec<Term>, String> {
    let k = factor_names.len();
    let single_letters = factor_names.iter().all(|n| n.chars().count() == 1);
    let mut terms = vec![Term::intercept(k)];
    for raw in spec.split(',').map(str::trim).filter(|s| !s.is_empty()) {
        let mut term = Term::intercept(k);
        let parts: Vec<String> = if raw.contains('*') || !single_letters {
            raw.split('*').map(|s| s.trim().to_string()).collect()
        } else {
            // AB^2C -> ["A", "B^2", "C"]
            let mut parts: Vec<String> = Vec::new();
            for ch in raw.chars() {
                if ch.is_alphabetic() || ch == '\'' && parts.is_empty() {
                    parts.push(ch.to_string());
                } else if let Some(last) = parts.last_mut() {
                    last.push(ch);
                } else {
                    return Err(format!("term '{raw}': cannot read it"));
                }
            }
            parts
        };
        for part in parts {
            let (name, power) = match part.split_once('^') {
                Some((n, p)) => (
                    n.trim(),
                    p.trim().parse::<u8>().map_err(|_| {
                        format!("term '{raw}': power '{p}' is not a small whole number")
                    })?,
                ),
                None => (part.trim(), 1),
            };
            let f = factor_names.iter().position(|n| n == name).ok_or_else(|| {
                format!(
                    "term '{raw}': '{name}' is not a factor (factors: {})",
                    factor_names.join(", ")
                )
            })?;
            term.powers[f] += power;
        }
        if term.is_intercept() {
            return Err(format!("term '{raw}' has no factor in it"));
        }
        if terms.contains(&term) {
            return Err(format!("term '{raw}' is listed twice"));
        }
        terms.push(term);
    }
    Ok(terms)
}

/// Adds the terms a hierarchical model needs: every divisor of every term.
pub fn make_hierarchical(terms: &mut Vec<Term>) {
    let mut i = 0;
    while i < terms.len() {
        let t = terms[i].clone();
        for f in 0..t.powers.len() {
            if t.powers[f] > 0 {
                let mut d = t.clone();
                d.powers[f] -= 1;
                if !terms.contains(&d) {
                    terms.push(d);
                }
            }
        }
        i += 1;
    }
    terms.sort_by(design_expert_order);
}

/// Order used in tables: intercept, main effects, interactions, squares, higher terms.
pub fn design_expert_order(a: &Term, b: &Term) -> std::cmp::Ordering {
    fn key(t: &Term) -> (u32, u8, Vec<std::cmp::Reverse<u8>>) {
        let max_power = t.powers.iter().copied().max().unwrap_or(0);
        (
            t.order(),
            max_power,
            t.powers.iter().map(|&p| std::cmp::Reverse(p)).collect(),
        )
    }
    key(a).cmp(&key(b))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names(s: &str) -> Vec<String> {
        s.split(',').map(String::from).collect()
    }

    #[test]
    fn term_counts_and_names() {
        let n = names("A,B,C");
        assert_eq!(ModelOrder::Linear.terms(3).len(), 4);
        assert_eq!(ModelOrder::TwoFactorInteraction.terms(3).len(), 7);
        assert_eq!(ModelOrder::Quadratic.terms(3).len(), 10);
        assert_eq!(ModelOrder::Cubic.terms(3).len(), 20);
        let q: Vec<String> = ModelOrder::Quadratic
            .terms(3)
            .iter()
            .map(|t| t.name(&n))
            .collect();
        assert_eq!(
            q,
            [
                "Intercept",
                "A",
                "B",
                "C",
                "AB",
                "AC",
                "BC",
                "A^2",
                "B^2",
                "C^2"
            ]
        );
        let long = names("temp,speed");
        assert_eq!(
            ModelOrder::TwoFactorInteraction.terms(2)[3].name(&long),
            "temp*speed"
        );
    }

    #[test]
    fn parse_and_hierarchy() {
        let n = names("A,B,C");
        let mut t = parse_terms("A^2B, C", &n).unwrap();
        assert_eq!(t[1].powers, vec![2, 1, 0]);
        make_hierarchical(&mut t);
        let got: Vec<String> = t.iter().map(|t| t.name(&n)).collect();
        assert_eq!(got, ["Intercept", "A", "B", "C", "AB", "A^2", "A^2B"]);
        assert!(parse_terms("AX", &n)
            .unwrap_err()
            .contains("'X' is not a factor"));
        let long = names("temp,speed");
        let t = parse_terms("temp, temp*speed, speed^2", &long).unwrap();
        assert_eq!(t[2].powers, vec![1, 1]);
        assert_eq!(t[3].powers, vec![0, 2]);
    }
}
