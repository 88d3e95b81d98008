//! Least-squares fitting of polynomial models in coded factors and the ANOVA Design-Expert prints:
//! partial (type III) sums of squares, a curvature row for two-level designs with centre points,
//! lack of fit against pure error, fit statistics, backward elimination, coded and actual-unit
//! equations, and effects for two-level designs.

use std::collections::BTreeMap;

use nalgebra::{DMatrix, DVector};
use serde::Serialize;
use statrs::distribution::{ContinuousCDF, FisherSnedecor, StudentsT};

use crate::experiment::Experiment;
use crate::model::{design_expert_order, Term};

/// One row of an ANOVA table. `f` and `p` are absent where they do not apply (residual, pure
/// error) or cannot be computed (no residual degrees of freedom, an exact fit).
#[derive(Clone, Debug, Serialize)]
pub struct AnovaRow {
    pub name: String,
    pub sum_sq: f64,
    pub df: usize,
    pub mean_sq: f64,
    pub f: Option<f64>,
    pub p: Option<f64>,
}

/// A coefficient of the coded equation with its standard error, 95 % interval and VIF.
#[derive(Clone, Debug, Serialize)]
pub struct Coefficient {
    pub name: String,
    pub estimate: f64,
    pub std_error: f64,
    pub ci_low: f64,
    pub ci_high: f64,
    pub vif: Option<f64>,
}

/// A two-level effect: mean(high) - mean(low) over the factorial runs, with the t value of its
/// coefficient (for the Pareto chart).
#[derive(Clone, Debug, Serialize)]
pub struct Effect {
    pub name: String,
    pub effect: f64,
    pub t: f64,
    /// Its share of the corrected total sum of squares (%): the contrast's sum of squares
    /// (sum of y at +1 minus at -1)^2 / (runs at +-1) over the total, Design-Expert's
    /// "% Contribution" (seed 001's Table 6 "impact rate").
    pub contribution_percent: f64,
}

/// Whether to separate curvature (centre points against factorial points) from the residual.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Curvature {
    /// For two-level designs with centre points and a model without squares, as Design-Expert does.
    Auto,
    Off,
}

/// A fitted model with its ANOVA.
#[derive(Clone, Debug)]
pub struct Fit {
    pub experiment: Experiment,
    /// Model terms, intercept first.
    pub terms: Vec<Term>,
    pub coefficients: Vec<Coefficient>,
    /// The centre-point offset when curvature is separated.
    pub curvature_coefficient: Option<f64>,
    pub anova_terms: Vec<AnovaRow>,
    pub model: AnovaRow,
    pub curvature: Option<AnovaRow>,
    pub residual: AnovaRow,
    pub lack_of_fit: Option<AnovaRow>,
    pub pure_error: Option<AnovaRow>,
    pub total_sum_sq: f64,
    pub total_df: usize,
    pub mean: f64,
    pub std_dev: f64,
    pub cv_percent: f64,
    pub r2: f64,
    pub adj_r2: f64,
    pub pred_r2: Option<f64>,
    pub press: Option<f64>,
    pub adeq_precision: Option<f64>,
    /// Fitted values of the model part (without the curvature offset), one per run.
    pub predicted: Vec<f64>,
    pub residuals: Vec<f64>,
    pub leverage: Vec<f64>,
    /// Externally studentized residuals (NaN where the leverage is 1).
    pub studentized: Vec<f64>,
    /// Cook's distance of each run, D = e^2 / (p MSE) h / (1 - h)^2 (NaN where the leverage is
    /// 1 or there is no residual error).
    pub cooks_distance: Vec<f64>,
    /// (X'X)^-1 of the model matrix (with the curvature column last when curvature is
    /// separated): the coefficients' covariance over the residual mean square.
    pub xtx_inv: DMatrix<f64>,
    /// Effects, for two-level designs (every non-centre run at +-1).
    pub effects: Vec<Effect>,
    /// Terms removed by backward elimination, with the p value at which each left.
    pub removed: Vec<(String, f64)>,
    /// Terms of a cubic model left out because the design cannot estimate them.
    pub aliased: Vec<String>,
}

/// A leverage above this counts as 1: the model passes through the run whatever it measures, so
/// the run's deleted residual, PRESS and predicted R² are not defined.
pub const LEVERAGE_ONE: f64 = 1.0 - 1e-10;

fn f_p_value(f: f64, df1: usize, df2: usize) -> Option<f64> {
    if df1 == 0 || df2 == 0 || !f.is_finite() {
        return None;
    }
    let dist = FisherSnedecor::new(df1 as f64, df2 as f64).ok()?;
    Some(dist.sf(f))
}

/// Two-sided critical t value at significance `alpha`.
pub fn t_critical(alpha: f64, df: usize) -> Option<f64> {
    if df == 0 {
        return None;
    }
    let t = StudentsT::new(0.0, 1.0, df as f64).ok()?;
    Some(t.inverse_cdf(1.0 - alpha / 2.0))
}

fn row(name: &str, sum_sq: f64, df: usize, error_ms: Option<f64>, error_df: usize) -> AnovaRow {
    let mean_sq = if df > 0 { sum_sq / df as f64 } else { 0.0 };
    let f = match error_ms {
        Some(ms) if ms > 0.0 && df > 0 => Some(mean_sq / ms),
        _ => None,
    };
    let p = f.and_then(|f| f_p_value(f, df, error_df));
    AnovaRow {
        name: name.into(),
        sum_sq,
        df,
        mean_sq,
        f,
        p,
    }
}

fn key(x: &[f64]) -> Vec<i64> {
    x.iter().map(|v| (v * 1e9).round() as i64).collect()
}

/// Whether every run is a centre point or has every factor at +-1 (with at least one such
/// factorial run), and which runs are centre points.
pub fn two_level_runs(coded: &[Vec<f64>]) -> (bool, Vec<bool>) {
    let centre: Vec<bool> = coded
        .iter()
        .map(|r| r.iter().all(|v| v.abs() < 1e-9))
        .collect();
    let two_level = coded
        .iter()
        .zip(&centre)
        .all(|(r, &c)| c || r.iter().all(|v| (v.abs() - 1.0).abs() < 1e-9));
    (two_level && centre.iter().any(|&c| !c), centre)
}

/// Splits `terms` into those the runs can estimate and those of order `min_order` or more that are
/// combinations of earlier terms (aliased), as Design-Expert does for a cubic model on a CCD.
/// Aliased lower-order terms are kept, so fitting still reports them as an error.
pub fn drop_aliased(exp: &Experiment, terms: &[Term], min_order: u32) -> (Vec<Term>, Vec<Term>) {
    let mut basis: Vec<DVector<f64>> = Vec::new();
    let (mut kept, mut dropped) = (Vec::new(), Vec::new());
    for t in terms {
        let col = DVector::from_iterator(exp.runs(), exp.coded.iter().map(|x| t.value(x)));
        let norm = col.norm();
        let mut v = col;
        for _ in 0..2 {
            for q in &basis {
                let d = q.dot(&v);
                v -= q * d;
            }
        }
        if v.norm() <= 1e-9 * norm.max(1e-300) && t.order() >= min_order {
            dropped.push(t.clone());
            continue;
        }
        if v.norm() > 1e-9 * norm.max(1e-300) {
            let vn = v.norm();
            basis.push(v / vn);
        }
        kept.push(t.clone());
    }
    (kept, dropped)
}

/// Explains a singular design matrix by naming the term that is a combination of earlier ones.
fn aliasing_message(x: &DMatrix<f64>, names: &[String]) -> Option<String> {
    let n = x.nrows();
    let mut basis: Vec<DVector<f64>> = Vec::new();
    let mut independent: Vec<usize> = Vec::new();
    for j in 0..x.ncols() {
        let col = x.column(j).into_owned();
        let norm = col.norm();
        let mut v = col.clone();
        for q in &basis {
            let d = q.dot(&v);
            v -= q * d;
        }
        if v.norm() <= 1e-9 * norm.max(1e-300) || norm == 0.0 {
            // Express column j by the independent columns before it.
            let a = DMatrix::from_fn(n, independent.len(), |r, c| x[(r, independent[c])]);
            let coef = (a.transpose() * &a)
                .cholesky()
                .map(|ch| ch.solve(&(a.transpose() * &col)))
                .unwrap_or_else(|| DVector::zeros(independent.len()));
            let mut parts = Vec::new();
            for (c, &i) in independent.iter().enumerate() {
                let v = coef[c];
                if v.abs() > 1e-6 {
                    let sign = if v < 0.0 { "-" } else { "+" };
                    let mag = v.abs();
                    if (mag - 1.0).abs() < 1e-9 {
                        parts.push(format!("{sign} {}", names[i]));
                    } else {
                        parts.push(format!("{sign} {} {}", fmt_sig(mag), names[i]));
                    }
                }
            }
            let rhs = if parts.is_empty() {
                "0 (the column is zero in every run)".to_string()
            } else {
                parts.join(" ").trim_start_matches("+ ").to_string()
            };
            return Some(format!(
                "singular design matrix: term {} is aliased ({} = {rhs}); drop one of the aliased terms or use a smaller model",
                names[j], names[j]
            ));
        }
        for q in &basis {
            // A second pass keeps the basis orthogonal to rounding.
            let d = q.dot(&v);
            v -= q * d;
        }
        let vn = v.norm();
        basis.push(v / vn);
        independent.push(j);
    }
    None
}

/// The response's mean and total sum of squares, or why there is nothing to fit: a value or a
/// factor setting that is not a finite number (simulated responses can be anything; the tables
/// must be numbers), sums that overflow, a constant response.
fn check_response(exp: &Experiment) -> Result<(f64, f64), String> {
    let n = exp.runs();
    let y = &exp.response;
    if let Some(i) = y.iter().position(|v| !v.is_finite()) {
        return Err(format!(
            "response '{}': run {} is {}, not a finite number",
            exp.response_name,
            i + 1,
            y[i]
        ));
    }
    if let Some(i) = exp
        .coded
        .iter()
        .position(|r| r.iter().any(|v| !v.is_finite()))
    {
        return Err(format!(
            "response '{}': run {} has a factor setting that is not a finite number",
            exp.response_name,
            i + 1
        ));
    }
    let mean = y.iter().sum::<f64>() / n as f64;
    let total_sum_sq: f64 = y.iter().map(|v| (v - mean).powi(2)).sum();
    if !total_sum_sq.is_finite() {
        return Err(overflow_message(exp));
    }
    let spread = y.iter().fold(0.0f64, |m, v| m.max((v - mean).abs()));
    if spread <= 1e-12 * mean.abs().max(1e-300) {
        return Err(format!(
            "response '{}' is constant ({}) in all {n} runs; there is nothing to model",
            exp.response_name,
            fmt_sig(mean)
        ));
    }
    Ok((mean, total_sum_sq))
}

/// Lack of fit and pure error rows, the pure error from runs at identical settings; none
/// without replicated settings or without residual degrees of freedom beyond them.
fn pure_error_rows(
    exp: &Experiment,
    ss_res: f64,
    df_res: usize,
) -> (Option<AnovaRow>, Option<AnovaRow>) {
    let y = &exp.response;
    let mut groups: BTreeMap<Vec<i64>, Vec<f64>> = BTreeMap::new();
    for (xi, &yi) in exp.coded.iter().zip(y) {
        groups.entry(key(xi)).or_default().push(yi);
    }
    let (mut ss_pe, mut df_pe) = (0.0, 0usize);
    for g in groups.values() {
        let m = g.iter().sum::<f64>() / g.len() as f64;
        ss_pe += g.iter().map(|v| (v - m).powi(2)).sum::<f64>();
        df_pe += g.len() - 1;
    }
    if df_pe > 0 && df_res > df_pe {
        let pe_ms = ss_pe / df_pe as f64;
        (
            Some(row(
                "Lack of Fit",
                (ss_res - ss_pe).max(0.0),
                df_res - df_pe,
                (pe_ms > 0.0).then_some(pe_ms),
                df_pe,
            )),
            Some(row("Pure Error", ss_pe, df_pe, None, 0)),
        )
    } else {
        (None, None)
    }
}

/// Each run's leverage (the diagonal of the hat matrix) and PRESS, the sum of the squared
/// deleted residuals; no PRESS when a run has leverage 1 (Design-Expert's N/A).
fn leverage_and_press(
    x: &DMatrix<f64>,
    c: &DMatrix<f64>,
    residuals: &[f64],
) -> (Vec<f64>, Option<f64>) {
    let n = x.nrows();
    let leverage: Vec<f64> = (0..n)
        .map(|i| {
            let xi = x.row(i);
            (xi * c * xi.transpose())[(0, 0)]
        })
        .collect();
    let press = if leverage.iter().any(|&h| h > LEVERAGE_ONE) {
        None
    } else {
        Some(
            residuals
                .iter()
                .zip(&leverage)
                .map(|(e, h)| (e / (1.0 - h)).powi(2))
                .sum::<f64>(),
        )
    };
    (leverage, press)
}

/// Each run's externally studentized residual and Cook's distance (NaN where they do not
/// exist: leverage 1, too few residual degrees of freedom, an exact fit).
fn case_diagnostics(
    residuals: &[f64],
    leverage: &[f64],
    ss_res: f64,
    df_res: usize,
    error_ms: Option<f64>,
    p: usize,
) -> (Vec<f64>, Vec<f64>) {
    let n = residuals.len();
    let ms_res = ss_res / df_res as f64;
    let studentized: Vec<f64> = (0..n)
        .map(|i| {
            let h = leverage[i];
            if h > LEVERAGE_ONE || df_res < 2 {
                return f64::NAN;
            }
            // Residual variance without run i.
            let s2_i = (ss_res - residuals[i].powi(2) / (1.0 - h)) / (df_res - 1) as f64;
            if s2_i <= 0.0 {
                return f64::NAN;
            }
            residuals[i] / (s2_i * (1.0 - h)).sqrt()
        })
        .collect();

    let cooks_distance: Vec<f64> = (0..n)
        .map(|i| {
            let h = leverage[i];
            if h > LEVERAGE_ONE || error_ms.is_none() {
                return f64::NAN;
            }
            residuals[i].powi(2) / (p as f64 * ms_res) * h / (1.0 - h).powi(2)
        })
        .collect();
    (studentized, cooks_distance)
}

/// Each coefficient of the coded equation with its standard error, 95 % interval and VIF.
fn coefficient_table(
    x: &DMatrix<f64>,
    c: &DMatrix<f64>,
    b: &DVector<f64>,
    names: &[String],
    ms_res: f64,
    df_res: usize,
) -> Vec<Coefficient> {
    let n = x.nrows();
    let t_crit = t_critical(0.05, df_res).unwrap_or(f64::NAN);
    (0..names.len())
        .map(|j| {
            let se = (c[(j, j)] * ms_res).sqrt();
            let vif = (j > 0).then(|| {
                let col = x.column(j);
                let m = col.sum() / n as f64;
                let sxx: f64 = col.iter().map(|v| (v - m).powi(2)).sum();
                c[(j, j)] * sxx
            });
            Coefficient {
                name: names[j].clone(),
                estimate: b[j],
                std_error: se,
                ci_low: b[j] - t_crit * se,
                ci_high: b[j] + t_crit * se,
                vif,
            }
        })
        .collect()
}

/// The two-level effects (mean at +1 minus mean at -1 over the factorial runs) of the terms
/// without squares, with their t values and shares of the total sum of squares.
fn two_level_effects(
    exp: &Experiment,
    terms: &[Term],
    names: &[String],
    x: &DMatrix<f64>,
    centre: &[bool],
    coefficients: &[Coefficient],
    total_sum_sq: f64,
) -> Vec<Effect> {
    let (n, y) = (exp.runs(), &exp.response);
    (1..terms.len())
        .filter(|&j| terms[j].powers.iter().all(|&p| p <= 1))
        .map(|j| {
            let (mut hi, mut nhi, mut lo, mut nlo) = (0.0, 0, 0.0, 0);
            for i in 0..n {
                if centre[i] {
                    continue;
                }
                if x[(i, j)] > 0.0 {
                    hi += y[i];
                    nhi += 1;
                } else {
                    lo += y[i];
                    nlo += 1;
                }
            }
            let contrast = (hi - lo).powi(2) / (nhi + nlo).max(1) as f64;
            Effect {
                name: names[j].clone(),
                effect: hi / nhi.max(1) as f64 - lo / nlo.max(1) as f64,
                t: coefficients[j].estimate / coefficients[j].std_error,
                contribution_percent: 100.0 * contrast / total_sum_sq,
            }
        })
        .collect()
}

/// Why a fit of finite data came out non-finite: the values are too large to square and sum.
fn overflow_message(exp: &Experiment) -> String {
    let biggest = exp.response.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    format!(
        "response '{}': the sums of squares are not finite (values up to {biggest:e}); rescale the response or the factors",
        exp.response_name
    )
}

impl Fit {
    /// Fits `terms` (the intercept must be the first) by least squares on the coded factors.
    pub fn new(
        experiment: &Experiment,
        terms: &[Term],
        curvature: Curvature,
    ) -> Result<Fit, String> {
        let exp = experiment;
        let n = exp.runs();
        let y = &exp.response;
        let names: Vec<String> = terms.iter().map(|t| t.name(&exp.factor_names)).collect();
        assert!(
            terms.first().is_some_and(Term::is_intercept),
            "intercept first"
        );
        let (mean, total_sum_sq) = check_response(exp)?;
        let (two_level, centre) = two_level_runs(&exp.coded);
        let has_squares = terms.iter().any(|t| t.powers.iter().any(|&p| p >= 2));
        let use_curvature = curvature == Curvature::Auto
            && two_level
            && !has_squares
            && centre.iter().any(|&c| c)
            && terms.len() > 1;
        let p = terms.len() + use_curvature as usize;
        if n <= p {
            return Err(format!(
                "too few runs for the model: it has {} coefficients{}, so it needs at least {} runs for an ANOVA, and '{}' has {n}",
                terms.len(),
                if use_curvature { " plus curvature" } else { "" },
                p + 1,
                exp.response_name
            ));
        }
        let mut all_names = names.clone();
        if use_curvature {
            all_names.push("Curvature".into());
        }
        let x = DMatrix::from_fn(n, p, |i, j| {
            if j < terms.len() {
                terms[j].value(&exp.coded[i])
            } else if centre[i] {
                1.0
            } else {
                0.0
            }
        });
        if let Some(msg) = aliasing_message(&x, &all_names) {
            return Err(msg);
        }
        let xtx = x.transpose() * &x;
        let c = xtx
            .clone()
            .try_inverse()
            .ok_or_else(|| "singular design matrix".to_string())?;
        let yv = DVector::from_column_slice(y);
        let b = &c * (x.transpose() * &yv);
        let fitted_all = &x * &b;
        let residuals: Vec<f64> = (0..n).map(|i| y[i] - fitted_all[i]).collect();
        let ss_res: f64 = residuals.iter().map(|e| e * e).sum();
        if !ss_res.is_finite() || b.iter().any(|v| !v.is_finite()) {
            return Err(overflow_message(exp));
        }
        let df_res = n - p;
        let ms_res = ss_res / df_res as f64;
        let error_ms = (ms_res > 1e-14 * total_sum_sq / (n - 1) as f64).then_some(ms_res);

        let anova_terms: Vec<AnovaRow> = (1..terms.len())
            .map(|j| row(&names[j], b[j] * b[j] / c[(j, j)], 1, error_ms, df_res))
            .collect();
        let curvature_row = use_curvature.then(|| {
            let j = p - 1;
            row("Curvature", b[j] * b[j] / c[(j, j)], 1, error_ms, df_res)
        });
        let ss_curv = curvature_row.as_ref().map_or(0.0, |r| r.sum_sq);
        let model_df = terms.len() - 1;
        let model = row(
            "Model",
            (total_sum_sq - ss_res - ss_curv).max(0.0),
            model_df,
            error_ms,
            df_res,
        );
        let residual = row("Residual", ss_res, df_res, None, 0);

        let (lack_of_fit, pure_error) = pure_error_rows(exp, ss_res, df_res);

        // Statistics on the total without curvature, as Design-Expert reports them.
        let ss_t = model.sum_sq + ss_res;
        let df_t = model_df + df_res;
        let r2 = 1.0 - ss_res / ss_t;
        let adj_r2 = 1.0 - ms_res / (ss_t / df_t as f64);
        let (leverage, press) = leverage_and_press(&x, &c, &residuals);
        let pred_r2 = press.map(|pr| 1.0 - pr / ss_t);
        let std_dev = ms_res.sqrt();
        let predicted: Vec<f64> = (0..n)
            .map(|i| (0..terms.len()).map(|j| b[j] * x[(i, j)]).sum())
            .collect();
        let adeq_precision = error_ms.map(|ms| {
            let hi = predicted.iter().cloned().fold(f64::MIN, f64::max);
            let lo = predicted.iter().cloned().fold(f64::MAX, f64::min);
            (hi - lo) / (terms.len() as f64 * ms / n as f64).sqrt()
        });
        let (studentized, cooks_distance) =
            case_diagnostics(&residuals, &leverage, ss_res, df_res, error_ms, p);

        let coefficients = coefficient_table(&x, &c, &b, &names, ms_res, df_res);

        let effects = if two_level {
            two_level_effects(exp, terms, &names, &x, &centre, &coefficients, total_sum_sq)
        } else {
            Vec::new()
        };

        Ok(Fit {
            experiment: exp.clone(),
            terms: terms.to_vec(),
            coefficients,
            curvature_coefficient: use_curvature.then(|| b[p - 1]),
            anova_terms,
            model,
            curvature: curvature_row,
            residual,
            lack_of_fit,
            pure_error,
            total_sum_sq,
            total_df: n - 1,
            mean,
            std_dev,
            cv_percent: 100.0 * std_dev / mean.abs(),
            r2,
            adj_r2,
            pred_r2,
            press,
            adeq_precision,
            predicted,
            residuals,
            leverage,
            studentized,
            cooks_distance,
            xtx_inv: c,
            effects,
            removed: Vec::new(),
            aliased: Vec::new(),
        })
    }

    /// Backward elimination: repeatedly drops the term with the largest p value above `alpha_out`.
    /// With `hierarchy`, a term stays while a higher-order term containing it is in the model.
    pub fn reduce(
        experiment: &Experiment,
        terms: &[Term],
        curvature: Curvature,
        alpha_out: f64,
        hierarchy: bool,
    ) -> Result<Fit, String> {
        let mut terms = terms.to_vec();
        let mut removed = Vec::new();
        loop {
            let fit = Fit::new(experiment, &terms, curvature)?;
            let candidate = (1..terms.len())
                .filter(|&j| !hierarchy || !terms.iter().any(|t| t.contains(&terms[j])))
                .filter_map(|j| fit.anova_terms[j - 1].p.map(|p| (j, p)))
                .max_by(|a, b| a.1.total_cmp(&b.1));
            match candidate {
                Some((j, p)) if p > alpha_out => {
                    removed.push((fit.anova_terms[j - 1].name.clone(), p));
                    terms.remove(j);
                }
                _ => {
                    let mut fit = fit;
                    fit.removed = removed;
                    return Ok(fit);
                }
            }
        }
    }

    pub fn term_names(&self) -> Vec<String> {
        self.terms
            .iter()
            .map(|t| t.name(&self.experiment.factor_names))
            .collect()
    }

    /// Prediction of the model at coded settings.
    pub fn predict_coded(&self, coded: &[f64]) -> f64 {
        self.terms
            .iter()
            .zip(&self.coefficients)
            .map(|(t, c)| c.estimate * t.value(coded))
            .sum()
    }

    /// Prediction at actual settings, when the factors' ranges are known.
    pub fn predict_actual(&self, actual: &[f64]) -> Option<f64> {
        let factors = self.experiment.factors.as_ref()?;
        let coded: Vec<f64> = factors
            .iter()
            .zip(actual)
            .map(|(f, &a)| f.to_coded(a))
            .collect();
        Some(self.predict_coded(&coded))
    }

    /// The equation in actual units: polynomial coefficients keyed by powers of the actual
    /// factor (or its log10 for logarithmic factors), in table order. None without ranges.
    pub fn actual_equation(&self) -> Option<Vec<(Term, f64)>> {
        let factors = self.experiment.factors.as_ref()?;
        let k = factors.len();
        let mut total: BTreeMap<Vec<u8>, f64> = BTreeMap::new();
        for (t, c) in self.terms.iter().zip(&self.coefficients) {
            let mut poly: BTreeMap<Vec<u8>, f64> = BTreeMap::from([(vec![0u8; k], c.estimate)]);
            for (f, &power) in t.powers.iter().enumerate() {
                let (a, b) = factors[f].coded_affine();
                for _ in 0..power {
                    let mut next = BTreeMap::new();
                    for (pw, v) in &poly {
                        let mut up = pw.clone();
                        up[f] += 1;
                        *next.entry(up).or_insert(0.0) += v * a;
                        *next.entry(pw.clone()).or_insert(0.0) += v * b;
                    }
                    poly = next;
                }
            }
            for (pw, v) in poly {
                *total.entry(pw).or_insert(0.0) += v;
            }
        }
        let mut out: Vec<(Term, f64)> = total
            .into_iter()
            .map(|(powers, v)| (Term { powers }, v))
            .filter(|(t, _)| self.terms.contains(t))
            .collect();
        out.sort_by(|a, b| design_expert_order(&a.0, &b.0));
        Some(out)
    }

    /// Names used in the actual-unit equation: the factor name, or `log10(name)`.
    pub fn actual_variable_names(&self) -> Vec<String> {
        match &self.experiment.factors {
            Some(fs) => fs
                .iter()
                .map(|f| match f.scale {
                    crate::factor::Scale::Linear => f.name.clone(),
                    crate::factor::Scale::Log => format!("log10({})", f.name),
                })
                .collect(),
            None => self.experiment.factor_names.clone(),
        }
    }

    /// Pareto limits for |t| of the effects at significance `alpha`: (t limit, Bonferroni limit).
    pub fn pareto_limits(&self, alpha: f64) -> Option<(f64, f64)> {
        let m = self.effects.len().max(1) as f64;
        Some((
            t_critical(alpha, self.residual.df)?,
            t_critical(alpha / m, self.residual.df)?,
        ))
    }

    /// The ANOVA and statistics in the JSON form `demcal doe analyze --json` prints.
    pub fn to_json(&self) -> serde_json::Value {
        let coded: serde_json::Map<String, serde_json::Value> = self
            .coefficients
            .iter()
            .map(|c| (c.name.clone(), serde_json::json!(c.estimate)))
            .collect();
        let actual = self.actual_equation().map(|eq| {
            let vars = self.actual_variable_names();
            eq.iter()
                .map(|(t, v)| (t.name(&vars), serde_json::json!(v)))
                .collect::<serde_json::Map<_, _>>()
        });
        serde_json::json!({
            "response": self.experiment.response_name,
            "runs": self.experiment.runs(),
            "terms": self.anova_terms,
            "model": self.model,
            "curvature": self.curvature,
            "residual": self.residual,
            "lack_of_fit": self.lack_of_fit,
            "pure_error": self.pure_error,
            "total": { "sum_sq": self.total_sum_sq, "df": self.total_df },
            "std_dev": self.std_dev,
            "mean": self.mean,
            "cv_percent": self.cv_percent,
            "r2": self.r2,
            "adj_r2": self.adj_r2,
            "pred_r2": self.pred_r2,
            "press": self.press,
            "adeq_precision": self.adeq_precision,
            "coefficients_coded": coded,
            "coefficients": self.coefficients,
            "coefficients_actual": actual,
            "effects": self.effects,
            "aliased_terms": self.aliased,
            "removed_terms": self.removed.iter().map(|(n, p)| serde_json::json!({"name": n, "p": p})).collect::<Vec<_>>(),
        })
    }
}

/// "quadratic", "2FI", ... when the terms are exactly a standard model, else "reduced" or "custom".
pub fn model_title(terms: &[Term]) -> String {
    let max_order = terms.iter().map(Term::order).max().unwrap_or(0);
    let k = terms.first().map_or(0, |t| t.powers.len());
    use crate::model::ModelOrder::*;
    for order in [Mean, Linear, TwoFactorInteraction, Quadratic, Cubic] {
        let mut full = order.terms(k);
        let mut mine = terms.to_vec();
        full.sort();
        mine.sort();
        if full == mine {
            return order.label().to_string();
        }
    }
    match max_order {
        1 => "reduced linear".into(),
        2 if terms.iter().any(|t| t.powers.contains(&2)) => "reduced quadratic".into(),
        2 => "reduced 2FI".into(),
        _ => "custom".into(),
    }
}

/// Four significant digits, without exponent for ordinary magnitudes.
pub fn fmt_sig(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    let mag = v.abs().log10().floor() as i32;
    if !(-4..=7).contains(&mag) {
        return format!("{v:.3e}");
    }
    let decimals = (3 - mag).max(0) as usize;
    format!("{v:.decimals$}")
}

/// p values as Design-Expert prints them.
pub fn fmt_p(p: f64) -> String {
    if p < 0.0001 {
        "< 0.0001".into()
    } else {
        format!("{p:.4}")
    }
}
