//! The `function` test: no particles, the response is a formula of named variables plus seeded
//! Gaussian noise. It exists so that a calibration study's logic (designs, stages, resuming,
//! failures) can be tested quickly and against a known optimum, apart from DEM noise.
//!
//! ```toml
//! test = "function"
//! [function]
//! expression = "30 + 8*friction - 3*friction^2 + 5*rolling"
//! variables = { friction = 0.5, rolling = 0.1 }
//! noise = 0.2          # standard deviation of the added noise
//! fail_when = "friction - 0.95"   # optional: the run fails where this is > 0
//! duration_s = 0.0     # optional: wall time each run takes, for tests of interrupted studies
//! # optional: a force-displacement curve (x in m, y in N), the variables plus x, each point with
//! # its own noise draw of the same standard deviation; a study compares it with lab curves
//! curve = { expression = "k*x/(1 + 100*x)", x_min = 0.0, x_max = 0.01, points = 200 }
//! ```

use std::collections::BTreeMap;
use std::time::{Duration, Instant};

use exmex::prelude::*;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use serde::{Deserialize, Serialize};

use crate::file::TestFile;
use crate::virtual_test::{Response, Run, TestError, VirtualTest};

/// The formula test.
pub struct Function;

/// The longest wall time a run may be asked to take (s).
const MAX_DURATION_S: f64 = 3600.0;
/// The longest formula read (characters). Parsing time grows faster than the length (40 000
/// terms took 12.5 s), and a real response surface is a few hundred characters.
pub const MAX_EXPRESSION_CHARS: usize = 2000;

/// Most points a curve may have: more only eats memory in every stored run.
pub const MAX_CURVE_POINTS: usize = 1_000_000;

/// A force-displacement curve made from a formula of the variables and `x` (m), in N.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CurveSettings {
    pub expression: String,
    #[serde(default)]
    #[serde(deserialize_with = "dem::units::length::one")]
    pub x_min: f64,
    #[serde(deserialize_with = "dem::units::length::one")]
    pub x_max: f64,
    #[serde(default = "default_points")]
    pub points: usize,
}

fn default_points() -> usize {
    200
}

/// The curve a run made: displacement (m) and force (N), noise included.
#[derive(Clone, Debug, Serialize)]
pub struct CurveOutcome {
    pub displacement_m: Vec<f64>,
    pub force_n: Vec<f64>,
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Settings {
    pub expression: String,
    #[serde(default)]
    pub variables: BTreeMap<String, f64>,
    #[serde(default)]
    pub noise: f64,
    pub fail_when: Option<String>,
    #[serde(default)]
    pub duration_s: f64,
    pub curve: Option<CurveSettings>,
}

#[derive(Clone, Debug, Serialize)]
pub struct Outcome {
    /// The formula's value plus the noise.
    pub value: f64,
    /// The formula's value alone.
    pub exact: f64,
    pub noise: f64,
    pub seed: u64,
    pub wall_s: f64,
    /// The `force_displacement` curve, when the settings ask for one.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub force_displacement: Option<CurveOutcome>,
}

/// One standard normal draw (Box-Muller): the same generator state gives the same number.
fn normal(rng: &mut Pcg64) -> f64 {
    let (u1, u2): (f64, f64) = (rng.gen_range(f64::EPSILON..1.0), rng.gen());
    (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
}

/// The curve at `points` evenly spaced x from `x_min` to `x_max`, each point with its own noise.
fn curve(
    file: &TestFile,
    s: &Settings,
    c: &CurveSettings,
    rng: &mut Pcg64,
) -> Result<CurveOutcome, TestError> {
    let text = &c.expression;
    let expr = exmex::parse::<f64>(text).map_err(|e| {
        format!(
            "{}: function.curve.expression: cannot read \"{text}\": {e}",
            file.name
        )
    })?;
    // Where each of the expression's variables comes from: x, or a named variable.
    let mut values = Vec::new();
    let mut x_at = Vec::new();
    for (k, v) in expr.var_names().iter().enumerate() {
        if v == "x" {
            x_at.push(k);
            values.push(0.0);
        } else {
            values.push(*s.variables.get(v).ok_or_else(|| {
                format!(
                    "{}: function.curve.expression: \"{v}\" is not x nor among the variables ({})",
                    file.name,
                    s.variables.keys().cloned().collect::<Vec<_>>().join(", ")
                )
            })?);
        }
    }
    let n = c.points;
    let mut out = CurveOutcome {
        displacement_m: Vec::with_capacity(n),
        force_n: Vec::with_capacity(n),
    };
    for i in 0..n {
        let x = c.x_min + (c.x_max - c.x_min) * i as f64 / (n - 1) as f64;
        for &k in &x_at {
            values[k] = x;
        }
        let exact = expr
            .eval(&values)
            .map_err(|e| format!("{}: function.curve.expression: {e}", file.name))?;
        let y = exact + s.noise * normal(rng);
        if !y.is_finite() {
            return Err(TestError::Measurement(format!(
                "{}: function: the curve is not finite at x = {x} ({y})",
                file.name
            )));
        }
        out.displacement_m.push(x);
        out.force_n.push(y);
    }
    Ok(out)
}

/// Evaluates `text` with the named variables; errors name `key`.
fn evaluate(
    file: &TestFile,
    key: &str,
    text: &str,
    vars: &BTreeMap<String, f64>,
) -> Result<f64, String> {
    let expr = exmex::parse::<f64>(text)
        .map_err(|e| format!("{}: function.{key}: cannot read \"{text}\": {e}", file.name))?;
    let values = expr
        .var_names()
        .iter()
        .map(|v| {
            vars.get(v).copied().ok_or_else(|| {
                format!(
                    "{}: function.{key}: \"{v}\" is not among the variables ({})",
                    file.name,
                    vars.keys().cloned().collect::<Vec<_>>().join(", ")
                )
            })
        })
        .collect::<Result<Vec<f64>, String>>()?;
    expr.eval(&values)
        .map_err(|e| format!("{}: function.{key}: {e}", file.name))
}

impl VirtualTest for Function {
    fn reference_sections(&self) -> Vec<(String, Vec<&'static str>)> {
        vec![
            ("[function]".into(), dem::keys::of::<Settings>()),
            ("function.curve".into(), dem::keys::of::<CurveSettings>()),
        ]
    }

    type Settings = Settings;
    type Outcome = Outcome;

    fn name(&self) -> &'static str {
        "function"
    }

    fn about(&self) -> &'static str {
        "no particles: a formula of named variables plus seeded noise, for testing studies"
    }

    fn needs_materials(&self) -> bool {
        false
    }

    fn response_names(&self) -> &'static [&'static str] {
        // `force_displacement` only when the settings give a curve.
        &["value", "exact", "force_displacement"]
    }

    fn check(&self, file: &TestFile, s: &Settings) -> Result<(), String> {
        if !(s.noise >= 0.0 && s.duration_s >= 0.0) {
            return Err(format!(
                "{}: function: noise and duration_s must be >= 0",
                file.name
            ));
        }
        let formulas = [
            ("expression", Some(&s.expression)),
            ("fail_when", s.fail_when.as_ref()),
            ("curve.expression", s.curve.as_ref().map(|c| &c.expression)),
        ];
        for (key, text) in formulas {
            let n = text.map_or(0, |t| t.chars().count());
            if n > MAX_EXPRESSION_CHARS {
                return Err(file.error(
                    key,
                    format!("a formula of {n} characters: at most {MAX_EXPRESSION_CHARS}"),
                ));
            }
        }
        if s.duration_s > MAX_DURATION_S {
            return Err(file.error(
                "duration_s",
                format!(
                    "expected at most {MAX_DURATION_S} s of wall time, got {}",
                    crate::harness::number(s.duration_s)
                ),
            ));
        }
        if let Some(c) = &s.curve {
            if !(c.x_min.is_finite() && c.x_max.is_finite() && c.x_min < c.x_max) {
                return Err(file.error(
                    "curve.x_max",
                    format!(
                        "expected finite x_min < x_max (m), got x_min = {} and x_max = {}",
                        c.x_min, c.x_max
                    ),
                ));
            }
            if !(2..=MAX_CURVE_POINTS).contains(&c.points) {
                return Err(file.error(
                    "curve.points",
                    format!("expected 2 to {MAX_CURVE_POINTS} points, got {}", c.points),
                ));
            }
            if s.variables.contains_key("x") {
                return Err(file.error(
                    "variables.x",
                    "x is the curve's displacement; give the variable another name",
                ));
            }
        }
        Ok(())
    }

    /// Evaluates the formula; the progress callback hears "evaluate" and may stop the run.
    fn run(&self, file: &TestFile, s: &Settings, run: &mut Run) -> Result<Outcome, TestError> {
        let seed = run.seed;
        let wall = Instant::now();
        let exact = evaluate(file, "expression", &s.expression, &s.variables)?;
        if let Some(cond) = &s.fail_when {
            if evaluate(file, "fail_when", cond, &s.variables)? > 0.0 {
                // Stands for a simulation that blew up.
                return Err(TestError::Diverged(format!(
                    "{}: function: simulation failed: fail_when \"{cond}\" holds",
                    file.name
                )));
            }
        }
        // Sleep in slices so that an interrupted study stops the run promptly.
        let end = wall + Duration::from_secs_f64(s.duration_s);
        loop {
            run.progress("evaluate", wall.elapsed().as_secs_f64())
                .map_err(TestError::Stopped)?;
            let now = Instant::now();
            if now >= end {
                break;
            }
            std::thread::sleep((end - now).min(Duration::from_millis(20)));
        }
        // Box-Muller on a seeded generator: the same seed always gives the same noise.
        let mut rng = Pcg64::seed_from_u64(seed);
        let noise = s.noise * normal(&mut rng);
        let value = exact + noise;
        if !value.is_finite() {
            return Err(TestError::Measurement(format!(
                "{}: function: the response is not finite ({value})",
                file.name
            )));
        }
        // The curve's noise comes after the value's from the same generator, so a file
        // without a curve gives the numbers it always gave.
        let force_displacement = match &s.curve {
            Some(c) => Some(curve(file, s, c, &mut rng)?),
            None => None,
        };
        Ok(Outcome {
            value,
            exact,
            noise,
            seed,
            wall_s: wall.elapsed().as_secs_f64(),
            force_displacement,
        })
    }

    fn responses(&self, o: &Outcome) -> Vec<(&'static str, Response)> {
        let mut r = vec![
            ("value", Response::Scalar(o.value)),
            ("exact", Response::Scalar(o.exact)),
        ];
        if let Some(c) = &o.force_displacement {
            r.push((
                "force_displacement",
                Response::Curve {
                    x_name: "displacement".into(),
                    x_unit: "m".into(),
                    y_name: "force".into(),
                    y_unit: "N".into(),
                    x: c.displacement_m.clone(),
                    y: c.force_n.clone(),
                },
            ));
        }
        r
    }

    fn summary(&self, o: &Outcome) -> String {
        format!(
            "function: value={} exact={} noise={}",
            o.value, o.exact, o.noise
        )
    }
}
