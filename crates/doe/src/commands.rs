//! The work behind `demcal doe design | analyze | optimize`, kept here so the binary only parses
//! arguments. Each function returns the text to print (and writes files it is asked to).

use std::fmt::Write;
use std::path::{Path, PathBuf};

use crate::design::{self, CcdAlpha, Design, LhsKind};
use crate::experiment::{Experiment, FactorColumns};
use crate::factor::{Factor, Scale};
use crate::fit::{fmt_sig, Curvature, Fit};
use crate::model::{parse_terms, ModelOrder, Term};
use crate::optimize::{Criterion, Goal, Problem, Subject};
use crate::text_table::{Align, TextTable};
use crate::DataTable;

/// Reads `--factors`: a count (`3` gives A, B, C in coded units), names (`A,B,C`, coded = actual)
/// or ranges (`restitution:0.2:0.6,bond_normal_stiffness:1e9:1e11:log`).
pub fn parse_factor_list(spec: &str) -> Result<Vec<Factor>, String> {
    let spec = spec.trim();
    if let Ok(k) = spec.parse::<usize>() {
        if k == 0 {
            return Err("--factors: expected at least one factor".into());
        }
        if k > MAX_FACTORS {
            return Err(format!("--factors {k}: at most {MAX_FACTORS} factors"));
        }
        return Ok((0..k)
            .map(|i| Factor::new(&design::factor_letter(i), -1.0, 1.0, Scale::Linear).unwrap())
            .collect());
    }
    let mut factors: Vec<Factor> = Vec::new();
    for item in spec.split(',').map(str::trim) {
        if item.is_empty() {
            return Err(format!("--factors '{spec}': empty factor name"));
        }
        let f = if item.contains(':') {
            Factor::parse(item).map_err(|e| format!("--factors: {e}"))?
        } else {
            Factor::new(item, -1.0, 1.0, Scale::Linear).unwrap()
        };
        if factors.iter().any(|g| g.name == f.name) {
            return Err(format!("--factors: '{}' is named twice", f.name));
        }
        // The name heads a CSV column, written as it is.
        if f.name.contains(['"', '\n', '\r']) {
            return Err(format!(
                "--factors: '{}': a factor name cannot hold a quote or a line break (it heads a CSV column)",
                f.name.escape_debug()
            ));
        }
        factors.push(f);
    }
    Ok(factors)
}

/// Most factors a design may have.
pub const MAX_FACTORS: usize = 1000;

/// Options of `demcal doe design`.
#[derive(Clone, Debug, Default)]
pub struct DesignRequest {
    pub kind: String,
    pub factors: String,
    pub center_points: Option<usize>,
    pub alpha: Option<String>,
    pub runs: Option<usize>,
    pub resolution: Option<usize>,
    pub fraction: Option<usize>,
    pub half_fraction: Option<bool>,
    pub lhs: Option<String>,
    /// Steepest path: one coefficient (or effect sign) per factor; zero keeps a factor at its centre.
    pub direction: Option<String>,
    /// Steepest path: coded distance of one step along the largest coefficient.
    pub step: Option<f64>,
    pub seed: u64,
}

pub const DESIGN_KINDS: &str =
    "plackett-burman (pb), factorial, fractional, ccd, box-behnken (bbd), lhs, random, steepest";

/// Builds the requested design; returns it with its factors.
pub fn make_design(req: &DesignRequest) -> Result<(Design, Vec<Factor>), String> {
    // Sizes first: nothing is allocated for a request that cannot be met.
    if let Some(n) = req.runs.filter(|&n| n > design::MAX_RUNS) {
        return Err(format!("--runs {n}: at most {} runs", design::MAX_RUNS));
    }
    if let Some(n) = req.center_points.filter(|&n| n > design::MAX_RUNS) {
        return Err(format!(
            "--centers {n}: at most {} centre points",
            design::MAX_RUNS
        ));
    }
    let factors = parse_factor_list(&req.factors)?;
    let k = factors.len();
    if k > MAX_FACTORS {
        return Err(format!("--factors: {k} factors, at most {MAX_FACTORS}"));
    }
    let centres = |default: usize| req.center_points.unwrap_or(default);
    let d = match req.kind.to_ascii_lowercase().as_str() {
        "pb" | "plackett-burman" | "plackett_burman" => {
            design::plackett_burman(k, req.runs, centres(0))?
        }
        "factorial" | "full-factorial" | "full" => {
            design::full_factorial(k)?.with_center_points(centres(0))
        }
        "fractional" | "fractional-factorial" => {
            let d = match (req.fraction, req.resolution) {
                (Some(p), r) => design::fractional_factorial(k, p, r.unwrap_or(3))?,
                (None, Some(r)) => design::fractional_factorial_by_resolution(k, r)?,
                (None, None) => {
                    return Err(
                        "fractional: give --resolution R (smallest fraction reaching it) or --fraction P (2^(k-P))"
                            .into(),
                    )
                }
            };
            d.with_center_points(centres(0))
        }
        "ccd" | "central-composite" | "central_composite" => {
            let alpha = match req.alpha.as_deref().unwrap_or("rotatable") {
                "rotatable" => CcdAlpha::Rotatable,
                "spherical" => CcdAlpha::Spherical,
                "face" | "face-centred" | "face-centered" | "fcc" => CcdAlpha::FaceCentred,
                "orthogonal" => CcdAlpha::Orthogonal,
                "inscribed" => CcdAlpha::Inscribed,
                other => CcdAlpha::Custom(other.parse::<f64>().ok().filter(|a| *a > 0.0).ok_or_else(
                    || format!("--alpha '{other}': expected rotatable, spherical, face, orthogonal, inscribed or a positive number"),
                )?),
            };
            design::central_composite(
                k,
                alpha,
                centres(if k == 2 { 5 } else { 6 }),
                req.half_fraction,
            )?
        }
        "bbd" | "box-behnken" | "box_behnken" => design::box_behnken(k, centres(5))?,
        "lhs" | "latin-hypercube" => {
            let kind = match req.lhs.as_deref().unwrap_or("maximin") {
                "random" => LhsKind::Random,
                "centred" | "centered" => LhsKind::Centred,
                "maximin" => LhsKind::Maximin,
                other => {
                    return Err(format!(
                        "--lhs '{other}': expected random, centred or maximin"
                    ))
                }
            };
            let n = req
                .runs
                .ok_or("lhs: give the number of runs with --runs N")?;
            if kind == LhsKind::Maximin && n > design::MAX_MAXIMIN_RUNS {
                return Err(format!(
                    "--lhs maximin: at most {} runs (the search compares every pair of runs); use --lhs random or centred for more",
                    design::MAX_MAXIMIN_RUNS
                ));
            }
            design::latin_hypercube(k, n, kind, req.seed)?
        }
        "random" => {
            let n = req
                .runs
                .ok_or("random: give the number of runs with --runs N")?;
            design::random_design(k, n, req.seed)?
        }
        "steepest" | "steepest-ascent" | "steepest-descent" => {
            let dir = req.direction.as_deref().ok_or(
                "steepest: give one coefficient per factor with --direction, e.g. 1,-0.5,0 (negate to descend)",
            )?;
            let coef: Vec<f64> = dir
                .split(',')
                .map(|v| v.trim().parse::<f64>())
                .collect::<Result<_, _>>()
                .map_err(|_| {
                    format!("--direction '{dir}': expected numbers separated by commas")
                })?;
            if coef.len() != k {
                return Err(format!(
                    "--direction '{dir}': {} numbers for {k} factors",
                    coef.len()
                ));
            }
            let step = req.step.unwrap_or(0.5);
            if !step.is_finite() || step <= 0.0 {
                return Err(format!("--step {step}: expected a positive coded distance"));
            }
            design::steepest_path(&coef, step, req.runs.unwrap_or(6))?
        }
        other => {
            return Err(format!(
                "unknown design '{other}'; expected one of: {DESIGN_KINDS}"
            ))
        }
    };
    Ok((d, factors))
}

fn point_type(d: &Design, run: &[f64]) -> &'static str {
    let nonzero = run.iter().filter(|v| v.abs() > 1e-12).count();
    if nonzero == 0 {
        "center"
    } else if d.sequential {
        "path"
    } else if d.alpha.is_some() && nonzero == 1 {
        "axial"
    } else if run
        .iter()
        .all(|v| v.abs() < 1e-12 || (v.abs() - 1.0).abs() < 1e-12)
    {
        if nonzero == run.len() {
            "factorial"
        } else {
            "edge"
        }
    } else {
        "interior"
    }
}

/// The design as CSV, rows in run order: `std_order,run_order,point_type`, the coded columns (named
/// by the factors), then `<name>_actual` columns.
pub fn design_csv(d: &Design, factors: &[Factor], seed: u64) -> String {
    let order = d.run_order(seed);
    let mut s = String::from("std_order,run_order,point_type");
    for f in factors {
        write!(s, ",{}", f.name).unwrap();
    }
    for f in factors {
        write!(s, ",{}_actual", f.name).unwrap();
    }
    s.push('\n');
    for (run, &std) in order.iter().enumerate() {
        let x = &d.runs[std];
        write!(s, "{},{},{}", std + 1, run + 1, point_type(d, x)).unwrap();
        for v in x {
            write!(s, ",{}", round_coded(*v)).unwrap();
        }
        for (f, v) in factors.iter().zip(x) {
            write!(s, ",{}", round_sig(f.to_actual(*v), 12)).unwrap();
        }
        s.push('\n');
    }
    s
}

/// `v` rounded to `digits` significant digits, so 0.1 + 0.4 * -1 prints as -0.3, not -0.30000000000000004.
pub fn round_sig(v: f64, digits: i32) -> f64 {
    if v == 0.0 || !v.is_finite() {
        return v;
    }
    let scale = 10f64.powi(digits - 1 - v.abs().log10().floor() as i32);
    (v * scale).round() / scale
}

fn round_coded(v: f64) -> f64 {
    // Exact levels stay exact; irrational ones (alpha) keep 10 digits.
    // + 0.0 turns -0 into 0.
    (v * 1e10).round() / 1e10 + 0.0
}

/// A summary of a design for the terminal.
pub fn design_summary(d: &Design, factors: &[Factor], seed: u64) -> String {
    let mut s = format!(
        "{}: {} runs ({} centre points), {} factors, run order seed {seed}\n",
        d.kind,
        d.runs.len(),
        d.center_points,
        factors.len()
    );
    if let Some(a) = d.alpha {
        writeln!(s, "alpha = {a:.5}").unwrap();
    }
    if !d.generators.is_empty() {
        writeln!(s, "generators: {}", d.generators.join(", ")).unwrap();
        writeln!(
            s,
            "defining relation: I = {}",
            d.defining_relation.join(" = ")
        )
        .unwrap();
        writeln!(s, "aliases (up to two-factor interactions):").unwrap();
        // Each chain once: "AB = CE = DF" is also listed under CE and DF.
        let mut seen: Vec<Vec<String>> = Vec::new();
        for a in &d.aliases {
            let mut words: Vec<String> = a.split('=').map(|w| w.trim().to_string()).collect();
            words.sort();
            if !seen.contains(&words) {
                seen.push(words);
                writeln!(s, "  {a}").unwrap();
            }
        }
    }
    for (j, f) in factors.iter().enumerate() {
        writeln!(
            s,
            "  {}: {} .. {} ({})",
            f.name,
            f.low,
            f.high,
            if f.scale == Scale::Log {
                "log"
            } else {
                "linear"
            }
        )
        .unwrap();
        // Axial points beyond the range can take a non-negative parameter below zero.
        let lowest = d.runs.iter().map(|r| r[j]).fold(f64::MAX, f64::min);
        let actual = f.to_actual(lowest);
        if f.low >= 0.0 && actual < 0.0 {
            writeln!(
                s,
                "warning: {} reaches {} at coded {:.5}, below zero; narrow its range or use --alpha face or inscribed",
                f.name,
                round_sig(actual, 6),
                lowest
            )
            .unwrap();
        }
    }
    s
}

/// Options shared by `analyze` and `optimize`: which columns and which model.
#[derive(Clone, Debug, Default)]
pub struct ModelRequest {
    pub data: PathBuf,
    pub responses: Vec<String>,
    /// `--factors`: names of coded columns, or `name:low:high[:log]` for columns in actual units.
    pub factors: Option<String>,
    /// linear | 2fi | quadratic | cubic | mean | an explicit term list. None: linear for two-level
    /// data, quadratic otherwise.
    pub model: Option<String>,
    pub reduce: bool,
    pub alpha_out: f64,
    pub no_hierarchy: bool,
    pub no_curvature: bool,
}

fn factor_columns(spec: &Option<String>) -> Result<FactorColumns, String> {
    let Some(spec) = spec else {
        return Ok(FactorColumns::Default);
    };
    if spec.contains(':') {
        let factors = spec
            .split(',')
            .map(|s| Factor::parse(s.trim()).map_err(|e| format!("--factors: {e}")))
            .collect::<Result<Vec<_>, _>>()?;
        Ok(FactorColumns::Actual(factors))
    } else {
        Ok(FactorColumns::Coded(
            spec.split(',').map(|s| s.trim().to_string()).collect(),
        ))
    }
}

fn model_terms(spec: Option<&str>, exp: &Experiment) -> Result<Vec<Term>, String> {
    let k = exp.factor_names.len();
    let default = || {
        if crate::fit::two_level_runs(&exp.coded).0 {
            ModelOrder::Linear
        } else {
            ModelOrder::Quadratic
        }
    };
    match spec {
        None => Ok(default().terms(k)),
        Some(s) => match ModelOrder::parse(s) {
            Some(order) => Ok(order.terms(k)),
            None => parse_terms(s, &exp.factor_names).map_err(|e| {
                format!("--model: {e} (expected linear, 2fi, quadratic, cubic or a term list)")
            }),
        },
    }
}

/// Fits one response as requested.
pub fn fit_response(req: &ModelRequest, table: &DataTable, response: &str) -> Result<Fit, String> {
    if req.reduce && !(req.alpha_out > 0.0 && req.alpha_out < 1.0) {
        return Err(format!(
            "--alpha-out {}: expected a number between 0 and 1",
            req.alpha_out
        ));
    }
    // Without --factors, every column but the responses is a factor: with several responses,
    // the others are not factors of this one (they would fit it exactly).
    let columns = match factor_columns(&req.factors)? {
        FactorColumns::Default => {
            let mut responses = req.responses.clone();
            if !responses.iter().any(|r| r == response) {
                responses.push(response.to_string());
            }
            FactorColumns::Coded(table.default_factor_columns(&responses))
        }
        given => given,
    };
    let exp = Experiment::from_table(table, response, &columns)?;
    let mut terms = model_terms(req.model.as_deref(), &exp)?;
    // "Cubic where estimable": leave out the cubic terms the design aliases.
    let mut aliased = Vec::new();
    if req.model.as_deref().and_then(ModelOrder::parse) == Some(ModelOrder::Cubic) {
        let (kept, dropped) = crate::fit::drop_aliased(&exp, &terms, 3);
        terms = kept;
        aliased = dropped.iter().map(|t| t.name(&exp.factor_names)).collect();
    }
    let curvature = if req.no_curvature {
        Curvature::Off
    } else {
        Curvature::Auto
    };
    let fit = if req.reduce {
        Fit::reduce(&exp, &terms, curvature, req.alpha_out, !req.no_hierarchy)
    } else {
        Fit::new(&exp, &terms, curvature)
    };
    let mut fit = fit.map_err(|e| format!("{}: {e}", table.source))?;
    fit.aliased = aliased;
    Ok(fit)
}

/// Each response named once (a second `--response D` repeated the whole analysis).
fn once_each(responses: &[String]) -> Result<(), String> {
    for (i, r) in responses.iter().enumerate() {
        if responses[..i].contains(r) {
            return Err(format!("--response {r}: named twice"));
        }
    }
    Ok(())
}

/// `demcal doe analyze`: the report (or JSON) of every response; plots when asked.
pub fn analyze(req: &ModelRequest, json: bool, plots: Option<&Path>) -> Result<String, String> {
    analyze_table(req, &DataTable::read(&req.data)?, json, plots)
}

/// [`analyze`] on a table already read (the Python API's data frames); `req.data` is not read.
pub fn analyze_table(
    req: &ModelRequest,
    table: &DataTable,
    json: bool,
    plots: Option<&Path>,
) -> Result<String, String> {
    if req.responses.is_empty() {
        return Err("--response: name the response column".into());
    }
    once_each(&req.responses)?;
    let mut out = String::new();
    let mut docs = Vec::new();
    for r in &req.responses {
        let fit = fit_response(req, table, r)?;
        if let Some(dir) = plots {
            let dir = if req.responses.len() > 1 {
                dir.join(r)
            } else {
                dir.to_path_buf()
            };
            let files = crate::plots::write_all(&fit, &dir)?;
            if !json {
                writeln!(out, "plots: {} files in {}", files.len(), dir.display()).unwrap();
            }
        }
        if json {
            docs.push(fit.to_json());
        } else {
            out.push_str(&fit.report());
            out.push('\n');
        }
    }
    if json {
        let v = if docs.len() == 1 {
            docs.pop().unwrap()
        } else {
            serde_json::Value::Array(docs)
        };
        out.push_str(&serde_json::to_string(&v).unwrap());
        out.push('\n');
    }
    Ok(out)
}

/// Reads `--goal`: `[NAME:]GOAL[:key=value...]` with GOAL one of `maximize`, `minimize`,
/// `target=V`, `range`, and keys `lower`, `upper`, `weight` (both sides), `weight_lower`,
/// `weight_upper`, `importance` (1-5). NAME may be left out when there is one response.
pub fn parse_goal(spec: &str, sole_response: Option<&str>) -> Result<(String, Criterion), String> {
    let bad = |why: &str| format!("--goal '{spec}': {why}");
    let parts: Vec<&str> = spec.split(':').map(str::trim).collect();
    let is_goal = |p: &str| {
        matches!(
            p.split('=').next().unwrap_or(""),
            "maximize" | "max" | "minimize" | "min" | "target" | "range" | "in_range"
        )
    };
    let (name, rest) = if is_goal(parts[0]) {
        (
            sole_response
                .ok_or_else(|| bad("name the response or factor first (NAME:GOAL)"))?
                .to_string(),
            &parts[..],
        )
    } else {
        (parts[0].to_string(), &parts[1..])
    };
    let Some((goal_part, options)) = rest.split_first() else {
        return Err(bad(
            "expected a goal: maximize, minimize, target=V or range",
        ));
    };
    let goal = match goal_part.split_once('=') {
        Some(("target", v)) => Goal::Target(
            v.parse::<f64>()
                .ok()
                .filter(|t| t.is_finite())
                .ok_or_else(|| bad("target value is not a finite number"))?,
        ),
        None if matches!(*goal_part, "maximize" | "max") => Goal::Maximize,
        None if matches!(*goal_part, "minimize" | "min") => Goal::Minimize,
        None if matches!(*goal_part, "range" | "in_range") => Goal::InRange,
        _ => {
            return Err(bad(
                "expected a goal: maximize, minimize, target=V or range",
            ))
        }
    };
    let mut c = Criterion {
        name: name.clone(),
        goal,
        lower: f64::NAN,
        upper: f64::NAN,
        weight_lower: 1.0,
        weight_upper: 1.0,
        importance: 3,
    };
    for opt in options {
        let (k, v) = opt
            .split_once('=')
            .ok_or_else(|| bad(&format!("'{opt}' is not key=value")))?;
        let num: f64 = v
            .parse()
            .ok()
            .filter(|x: &f64| x.is_finite())
            .ok_or_else(|| bad(&format!("{k}: '{v}' is not a finite number")))?;
        match k {
            "lower" => c.lower = num,
            "upper" => c.upper = num,
            "weight" => (c.weight_lower, c.weight_upper) = (num, num),
            "weight_lower" => c.weight_lower = num,
            "weight_upper" => c.weight_upper = num,
            "importance" => {
                if num.fract() != 0.0 || !(1.0..=5.0).contains(&num) {
                    return Err(bad("importance must be a whole number 1 to 5"));
                }
                c.importance = num as u8
            }
            _ => {
                return Err(bad(&format!(
                    "unknown key '{k}' (expected lower, upper, weight, weight_lower, weight_upper, importance)"
                )))
            }
        }
    }
    Ok((name, c))
}

/// Options of `demcal doe optimize` beyond the model.
#[derive(Clone, Debug)]
pub struct OptimizeRequest {
    pub goals: Vec<String>,
    pub solutions: usize,
    pub starts: usize,
    pub seed: u64,
}

/// `demcal doe optimize`: fits each response, then searches the desirability.
pub fn optimize(req: &ModelRequest, opt: &OptimizeRequest, json: bool) -> Result<String, String> {
    optimize_table(req, &DataTable::read(&req.data)?, opt, json)
}

/// [`optimize`] on a table already read.
pub fn optimize_table(
    req: &ModelRequest,
    table: &DataTable,
    opt: &OptimizeRequest,
    json: bool,
) -> Result<String, String> {
    if opt.solutions == 0 {
        return Err("--solutions 0: expected at least 1".into());
    }
    if opt.starts == 0 {
        return Err("--starts 0: expected at least 1 random start".into());
    }
    if opt.starts > crate::optimize::MAX_STARTS {
        return Err(format!(
            "--starts {}: at most {} random starts",
            opt.starts,
            crate::optimize::MAX_STARTS
        ));
    }
    if req.responses.is_empty() {
        return Err("--response: name at least one response column".into());
    }
    if opt.goals.is_empty() {
        return Err("--goal: give at least one goal, e.g. --goal angle_deg:target=38.65".into());
    }
    once_each(&req.responses)?;
    let fits: Vec<Fit> = req
        .responses
        .iter()
        .map(|r| fit_response(req, table, r))
        .collect::<Result<_, _>>()?;
    let exp = &fits[0].experiment;
    let k = exp.factor_names.len();
    let mut bounds = vec![(-1.0, 1.0); k];
    let sole = (req.responses.len() == 1).then(|| req.responses[0].as_str());
    let mut criteria = Vec::new();
    let mut named: Vec<String> = Vec::new();
    for g in &opt.goals {
        let (name, mut c) = parse_goal(g, sole)?;
        // Two goals for one column contradict or repeat each other (maximise and minimise
        // averaged to 0.5 everywhere).
        if named.contains(&name) {
            return Err(format!(
                "--goal '{g}': '{name}' has a goal already; give one goal per column"
            ));
        }
        named.push(name.clone());
        if let Some(i) = req.responses.iter().position(|r| *r == name) {
            let y = &fits[i].experiment.response;
            let lo = y.iter().cloned().fold(f64::MAX, f64::min);
            let hi = y.iter().cloned().fold(f64::MIN, f64::max);
            let (lo, hi) = match c.goal {
                Goal::Target(t) => (lo.min(t), hi.max(t)),
                _ => (lo, hi),
            };
            if c.lower.is_nan() {
                c.lower = lo;
            }
            if c.upper.is_nan() {
                c.upper = hi;
            }
            criteria.push((Subject::Response(i), c));
        } else if let Some(j) = exp.factor_names.iter().position(|f| *f == name) {
            let to_unit = |coded: f64| match &exp.factors {
                Some(f) => f[j].to_actual(coded),
                None => coded,
            };
            if c.lower.is_nan() {
                c.lower = to_unit(-1.0);
            }
            if c.upper.is_nan() {
                c.upper = to_unit(1.0);
            }
            // A factor's limits become the search box: checked as a response goal's are, so
            // that lower > upper is a message, not a clamp that panics.
            c.validate().map_err(|e| format!("--goal '{g}': {e}"))?;
            let to_coded = |v: f64| match &exp.factors {
                Some(f) => f[j].to_coded(v),
                None => v,
            };
            // The search stays within the design's cube and its runs (axial points included):
            // a model is not to be read far past them.
            let (lo, hi) = exp
                .coded
                .iter()
                .map(|r| r[j])
                .fold((-1.0f64, 1.0f64), |(a, b), v| (a.min(v), b.max(v)));
            let (a, b) = (to_coded(c.lower).max(lo), to_coded(c.upper).min(hi));
            if a > b || a.is_nan() || b.is_nan() {
                return Err(format!(
                    "--goal '{g}': {} .. {} lies outside the runs' range of {name} ({} .. {}): the model cannot be read there",
                    c.lower,
                    c.upper,
                    to_unit(lo),
                    to_unit(hi)
                ));
            }
            bounds[j] = (a, b);
            if c.goal != Goal::InRange {
                criteria.push((Subject::Factor(j), c));
            }
        } else {
            return Err(format!(
                "--goal '{g}': '{name}' is neither a response ({}) nor a factor ({})",
                req.responses.join(", "),
                exp.factor_names.join(", ")
            ));
        }
    }
    let problem = Problem {
        fits: fits.iter().collect(),
        criteria,
        bounds,
    };
    let solutions = problem.solve(opt.starts, opt.seed, opt.solutions)?;
    if json {
        let v = serde_json::json!({
            "factors": exp.factor_names,
            "responses": req.responses,
            "criteria": problem.criteria.iter().map(|(_, c)| c).collect::<Vec<_>>(),
            "solutions": solutions,
        });
        return Ok(format!("{}\n", serde_json::to_string(&v).unwrap()));
    }
    Ok(solutions_text(
        &fits,
        &req.responses,
        &problem.criteria,
        &solutions,
    ))
}

/// `doe optimize`'s text: each response's model, each goal, and the solutions as a table.
fn solutions_text(
    fits: &[Fit],
    responses: &[String],
    criteria: &[(Subject, Criterion)],
    solutions: &[crate::optimize::Solution],
) -> String {
    let exp = &fits[0].experiment;
    let mut s = String::new();
    for (f, r) in fits.iter().zip(responses) {
        writeln!(
            s,
            "{r}: {} model, {} terms, R² {:.4}",
            crate::fit::model_title(&f.terms),
            f.terms.len(),
            f.r2
        )
        .unwrap();
    }
    for (_, c) in criteria {
        let goal = match c.goal {
            Goal::Maximize => "maximize".to_string(),
            Goal::Minimize => "minimize".into(),
            Goal::Target(t) => format!("target {}", fmt_sig(t)),
            Goal::InRange => "in range".into(),
        };
        writeln!(
            s,
            "goal: {} {goal}, limits {} .. {}, weights {} / {}, importance {}",
            c.name,
            fmt_sig(c.lower),
            fmt_sig(c.upper),
            c.weight_lower,
            c.weight_upper,
            c.importance
        )
        .unwrap();
    }
    let unit = if exp.factors.is_some() {
        "actual"
    } else {
        "coded"
    };
    // Columns as wide as their names: "restitution (actual)" is wider than its numbers.
    let mut header = vec!["#".to_string()];
    header.extend(exp.factor_names.iter().map(|f| format!("{f} ({unit})")));
    header.extend(responses.iter().cloned());
    header.push("desirability".into());
    let titles: Vec<&str> = header.iter().map(String::as_str).collect();
    let mut table = TextTable::new(&titles, &vec![Align::Right; titles.len()]);
    for (i, sol) in solutions.iter().enumerate() {
        let values = sol.actual.as_ref().unwrap_or(&sol.coded);
        let mut row = vec![(i + 1).to_string()];
        row.extend(values.iter().chain(&sol.responses).map(|v| fmt_sig(*v)));
        row.push(format!("{:.4}", sol.desirability));
        table.row(row);
    }
    writeln!(s).unwrap();
    s.push_str(&table.render());
    if solutions.iter().all(|s| s.desirability == 0.0) {
        writeln!(
            s,
            "no setting inside the factor ranges gives a positive desirability; widen the limits"
        )
        .unwrap();
    }
    s
}
