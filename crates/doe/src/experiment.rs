//! An experiment ready to model: coded factor settings and one response, taken from a data table.

use crate::data::DataTable;
use crate::factor::{Factor, Scale};

/// Coded factor settings and the observed response, with the actual-unit mapping of each factor
/// when it is known (needed only for equations and plots in actual units).
#[derive(Clone, Debug)]
pub struct Experiment {
    pub response_name: String,
    pub factor_names: Vec<String>,
    /// One per factor when every factor's actual range is known.
    pub factors: Option<Vec<Factor>>,
    /// Coded settings, one row per run.
    pub coded: Vec<Vec<f64>>,
    pub response: Vec<f64>,
}

/// How the factor columns of a table are to be read.
#[derive(Clone, Debug)]
pub enum FactorColumns {
    /// Every column that is neither the response nor bookkeeping; coded values.
    Default,
    /// These columns hold coded values.
    Coded(Vec<String>),
    /// These columns hold actual values in the given ranges; they are coded by the ranges.
    Actual(Vec<Factor>),
}

impl Experiment {
    /// Reads one response and its factors from a table. When coded columns have a matching
    /// `<name>_actual` column (as `demcal doe design` writes), the actual-unit mapping is
    /// recovered from the pair (linear or logarithmic).
    pub fn from_table(
        table: &DataTable,
        response: &str,
        columns: &FactorColumns,
    ) -> Result<Experiment, String> {
        let y = table.column(response)?;
        let (names, coded_cols, factors) = match columns {
            FactorColumns::Actual(factors) => {
                let mut cols = Vec::new();
                for f in factors {
                    let actual = table.column(&f.name)?;
                    if f.scale == Scale::Log {
                        if let Some(v) = actual.iter().find(|v| **v <= 0.0) {
                            return Err(format!(
                                "{}: column '{}' holds {v}, which a logarithmic factor cannot take",
                                table.source, f.name
                            ));
                        }
                    }
                    cols.push(actual.iter().map(|&a| f.to_coded(a)).collect::<Vec<_>>());
                }
                let names = factors.iter().map(|f| f.name.clone()).collect();
                (names, cols, Some(factors.clone()))
            }
            FactorColumns::Coded(_) | FactorColumns::Default => {
                let names = match columns {
                    FactorColumns::Coded(n) => n.clone(),
                    _ => table.default_factor_columns(&[response.to_string()]),
                };
                if names.is_empty() {
                    return Err(format!(
                        "{}: no factor columns besides the response '{response}'",
                        table.source
                    ));
                }
                if names.iter().any(|n| n == response) {
                    return Err(format!(
                        "{}: '{response}' is both the response and a factor",
                        table.source
                    ));
                }
                let mut cols = Vec::new();
                let mut factors = Vec::new();
                for n in &names {
                    let coded = table.column(n)?;
                    let actual_name = format!("{n}_actual");
                    if table.has_column(&actual_name) {
                        let actual = table.column(&actual_name)?;
                        factors.push(infer_mapping(n, &coded, &actual).ok_or_else(|| {
                            format!(
                                "{}: column '{actual_name}' is neither linear nor logarithmic in '{n}'",
                                table.source
                            )
                        })?);
                    }
                    cols.push(coded);
                }
                let factors = (factors.len() == names.len()).then_some(factors);
                (names, cols, factors)
            }
        };
        let n = y.len();
        let coded = (0..n)
            .map(|i| coded_cols.iter().map(|c| c[i]).collect())
            .collect();
        Ok(Experiment {
            response_name: response.to_string(),
            factor_names: names,
            factors,
            coded,
            response: y,
        })
    }

    pub fn runs(&self) -> usize {
        self.response.len()
    }
}

/// Finds the mapping with actual = map(coded) from paired columns, if one exists.
fn infer_mapping(name: &str, coded: &[f64], actual: &[f64]) -> Option<Factor> {
    let try_scale = |scale: Scale| -> Option<Factor> {
        let u: Vec<f64> = match scale {
            Scale::Linear => actual.to_vec(),
            Scale::Log => {
                if actual.iter().any(|&a| a <= 0.0) {
                    return None;
                }
                actual.iter().map(|a| a.log10()).collect()
            }
        };
        // u = m + h * coded, from the two most distant coded values.
        let (imin, imax) = extreme_indices(coded)?;
        let h = (u[imax] - u[imin]) / (coded[imax] - coded[imin]);
        let m = u[imin] - h * coded[imin];
        let span = u.iter().fold(0.0f64, |s, v| s.max(v.abs())).max(1e-300);
        if u.iter()
            .zip(coded)
            .any(|(&ui, &c)| (ui - (m + h * c)).abs() > 1e-6 * span)
            || h <= 0.0
        {
            return None;
        }
        let (lo, hi) = match scale {
            Scale::Linear => (m - h, m + h),
            Scale::Log => (10f64.powf(m - h), 10f64.powf(m + h)),
        };
        Factor::new(name, lo, hi, scale).ok()
    };
    try_scale(Scale::Linear).or_else(|| try_scale(Scale::Log))
}

fn extreme_indices(v: &[f64]) -> Option<(usize, usize)> {
    let imin = (0..v.len()).min_by(|&a, &b| v[a].total_cmp(&v[b]))?;
    let imax = (0..v.len()).max_by(|&a, &b| v[a].total_cmp(&v[b]))?;
    (v[imax] > v[imin]).then_some((imin, imax))
}
