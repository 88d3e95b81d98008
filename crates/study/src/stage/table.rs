//! A stage's table in the plan, read key by key with one-line errors naming the key.

use std::sync::Arc;

use crate::paths::number;
use crate::spec::Stage;

/// A stage's table (`{ stage = "rsm", alpha = "face" }`) and what its values are checked
/// against: the study's parameters (name, min, max) for keys that name them.
pub struct StageTable<'a> {
    /// Where the table is: `plan[2]`.
    pub key: String,
    pub table: &'a toml::Table,
    pub params: &'a [(String, f64, f64)],
    err: &'a dyn Fn(&str, String) -> String,
}

impl<'a> StageTable<'a> {
    pub fn new(
        key: &str,
        table: &'a toml::Table,
        params: &'a [(String, f64, f64)],
        err: &'a dyn Fn(&str, String) -> String,
    ) -> StageTable<'a> {
        StageTable {
            key: key.to_string(),
            table,
            params,
            err,
        }
    }

    pub fn get(&self, k: &str) -> Option<&'a toml::Value> {
        self.table.get(k)
    }

    /// The error for key `k` of this table (`k` empty: the table itself).
    pub fn fail(&self, k: &str, why: impl Into<String>) -> String {
        let at = if k.is_empty() {
            self.key.clone()
        } else {
            format!("{}.{k}", self.key)
        };
        (self.err)(&at, why.into())
    }

    /// A whole number from `min` to `max` (None: no upper limit).
    pub fn count(
        &self,
        k: &str,
        default: usize,
        min: usize,
        max: Option<usize>,
    ) -> Result<usize, String> {
        Ok(self.count_opt(k, min, max)?.unwrap_or(default))
    }

    /// A whole number from `min` to `max`, or None when the key is absent.
    pub fn count_opt(
        &self,
        k: &str,
        min: usize,
        max: Option<usize>,
    ) -> Result<Option<usize>, String> {
        match self.get(k) {
            None => Ok(None),
            Some(toml::Value::Integer(n))
                if *n >= min as i64 && max.is_none_or(|m| *n <= m as i64) =>
            {
                Ok(Some(*n as usize))
            }
            Some(_) => Err(self.fail(
                k,
                match max {
                    Some(m) => format!("expected a whole number from {min} to {m}"),
                    None => format!("expected a whole number >= {min}"),
                },
            )),
        }
    }

    /// A number strictly between 0 and 1.
    pub fn fraction(&self, k: &str, default: f64) -> Result<f64, String> {
        match self.get(k) {
            None => Ok(default),
            Some(v) => number(v)
                .filter(|a| *a > 0.0 && *a < 1.0)
                .ok_or_else(|| self.fail(k, "expected a number between 0 and 1")),
        }
    }

    /// A finite number >= 0, or None when the key is absent.
    pub fn non_negative(&self, k: &str) -> Result<Option<f64>, String> {
        match self.get(k) {
            None => Ok(None),
            Some(v) => number(v)
                .filter(|x| *x >= 0.0 && x.is_finite())
                .map(Some)
                .ok_or_else(|| self.fail(k, "expected a number >= 0")),
        }
    }

    /// A string, lower-cased.
    pub fn text(&self, k: &str, default: &str) -> Result<String, String> {
        match self.get(k) {
            None => Ok(default.to_string()),
            Some(toml::Value::String(s)) => Ok(s.to_ascii_lowercase()),
            Some(_) => Err(self.fail(k, "expected a string")),
        }
    }

    pub fn flag(&self, k: &str, default: bool) -> Result<bool, String> {
        match self.get(k) {
            None => Ok(default),
            Some(toml::Value::Boolean(b)) => Ok(*b),
            Some(_) => Err(self.fail(k, "expected true or false")),
        }
    }

    /// The parameter called `name` (its index, min and max), or an error at `k` listing them.
    pub fn parameter(&self, k: &str, name: &str) -> Result<(usize, f64, f64), String> {
        match self.params.iter().position(|(n, _, _)| n == name) {
            Some(i) => Ok((i, self.params[i].1, self.params[i].2)),
            None => Err(self.fail(
                k,
                format!(
                    "no parameter is named \"{name}\" (the parameters: {})",
                    self.params
                        .iter()
                        .map(|(n, _, _)| n.as_str())
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            )),
        }
    }

    /// A list of finite numbers (integers allowed), or None when `v` is not one.
    pub fn numbers(v: &toml::Value) -> Option<Vec<f64>> {
        v.as_array()?
            .iter()
            .map(|x| number(x).filter(|x| x.is_finite()))
            .collect()
    }

    /// `[low, high]`: two finite numbers with low < high.
    pub fn pair(&self, k: &str, v: &toml::Value, what: &str) -> Result<(f64, f64), String> {
        match Self::numbers(v).as_deref() {
            Some(&[lo, hi]) if lo < hi => Ok((lo, hi)),
            _ => Err(self.fail(
                k,
                format!("expected [low, high], two finite numbers with low < high, {what}"),
            )),
        }
    }
}

/// A stage as the plan reads it.
pub trait StageDef: Stage + Sized {
    const NAME: &'static str;
    /// The keys its table takes besides `stage`.
    const KEYS: &'static [&'static str];
    /// Its settings from its table (defaults filled in); errors name the key.
    fn parse(t: &StageTable) -> Result<Self, String>;
}

/// Whether any stage of `before` is one of `kinds`.
pub fn any_of(before: &[Arc<dyn Stage>], kinds: &[&str]) -> bool {
    before.iter().any(|s| kinds.contains(&s.kind()))
}
