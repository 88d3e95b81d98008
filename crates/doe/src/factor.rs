//! Factors and the coded <-> actual mapping.

/// How coded levels map onto actual values.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Scale {
    /// actual = centre + coded * half range.
    Linear,
    /// log10(actual) is linear in the coded level: for ranges spanning decades (bond stiffness
    /// 1e9 ... 1e11).
    Log,
}

/// A factor of a design: coded -1 is `low`, +1 is `high`.
#[derive(Clone, Debug, PartialEq)]
pub struct Factor {
    pub name: String,
    pub low: f64,
    pub high: f64,
    pub scale: Scale,
}

impl Factor {
    pub fn new(name: &str, low: f64, high: f64, scale: Scale) -> Result<Factor, String> {
        if low >= high || low.is_nan() || high.is_nan() {
            return Err(format!(
                "factor {name}: expected low < high, got {low} and {high}"
            ));
        }
        if !(high - low).is_finite() {
            return Err(format!(
                "factor {name}: expected finite numbers, got {low:e} and {high:e}"
            ));
        }
        if scale == Scale::Log && low <= 0.0 {
            return Err(format!(
                "factor {name}: a logarithmic factor needs low > 0, got {low}"
            ));
        }
        Ok(Factor {
            name: name.into(),
            low,
            high,
            scale,
        })
    }

    pub fn to_actual(&self, coded: f64) -> f64 {
        match self.scale {
            Scale::Linear => 0.5 * (self.low + self.high) + coded * 0.5 * (self.high - self.low),
            Scale::Log => {
                let (a, b) = (self.low.log10(), self.high.log10());
                10f64.powf(0.5 * (a + b) + coded * 0.5 * (b - a))
            }
        }
    }

    /// The variable the coded level is linear in: the actual value, or its log10.
    pub fn transformed(&self, actual: f64) -> f64 {
        match self.scale {
            Scale::Linear => actual,
            Scale::Log => actual.log10(),
        }
    }

    /// `(a, b)` with coded = a * u + b, u being [`Factor::transformed`] of the actual value; used
    /// to write fitted equations in actual units.
    pub fn coded_affine(&self) -> (f64, f64) {
        let (lo, hi) = (self.transformed(self.low), self.transformed(self.high));
        let half = 0.5 * (hi - lo);
        (1.0 / half, -0.5 * (lo + hi) / half)
    }

    /// Reads `name:low:high` or `name:low:high:log`.
    pub fn parse(spec: &str) -> Result<Factor, String> {
        let parts: Vec<&str> = spec.split(':').map(str::trim).collect();
        let bad = || format!("factor '{spec}': expected name:low:high or name:low:high:log");
        if !(3..=4).contains(&parts.len()) || parts[0].is_empty() {
            return Err(bad());
        }
        let low: f64 = parts[1].parse().map_err(|_| bad())?;
        let high: f64 = parts[2].parse().map_err(|_| bad())?;
        let scale = match parts.get(3) {
            None | Some(&"linear") => Scale::Linear,
            Some(&"log") => Scale::Log,
            Some(_) => return Err(bad()),
        };
        Factor::new(parts[0], low, high, scale)
    }

    pub fn to_coded(&self, actual: f64) -> f64 {
        match self.scale {
            Scale::Linear => {
                (actual - 0.5 * (self.low + self.high)) / (0.5 * (self.high - self.low))
            }
            Scale::Log => {
                let (a, b) = (self.low.log10(), self.high.log10());
                (actual.log10() - 0.5 * (a + b)) / (0.5 * (b - a))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn linear_and_log_mappings_round_trip() {
        let f = Factor::new("restitution", 0.2, 0.6, Scale::Linear).unwrap();
        assert!((f.to_actual(-1.0) - 0.2).abs() < 1e-15);
        assert!((f.to_actual(0.0) - 0.4).abs() < 1e-15);
        assert!((f.to_coded(0.5) - 0.5).abs() < 1e-12);
        let k = Factor::new("bond_normal_stiffness", 1e9, 1e11, Scale::Log).unwrap();
        assert!((k.to_actual(0.0) / 1e10 - 1.0).abs() < 1e-12);
        assert!((k.to_actual(1.0) / 1e11 - 1.0).abs() < 1e-12);
        assert!((k.to_coded(1e9) + 1.0).abs() < 1e-12);
        assert!(Factor::new("x", 1.0, 1.0, Scale::Linear).is_err());
        assert!(Factor::new("x", 0.0, 1.0, Scale::Log).is_err());
    }

    /// A range with an infinite end (or one too wide to subtract) has no centre to code around.
    #[test]
    fn infinite_ranges_are_refused() {
        assert_eq!(
            Factor::parse("x:-inf:inf").unwrap_err(),
            "factor x: expected finite numbers, got -inf and inf"
        );
        assert_eq!(
            Factor::new("x", -1e308, 1e308, Scale::Linear).unwrap_err(),
            "factor x: expected finite numbers, got -1e308 and 1e308"
        );
    }
}
