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
        &["value", "exact"]
    }

    fn check(&self, file: &TestFile, s: &Settings) -> Result<(), String> {
        if !(s.noise >= 0.0 && s.duration_s >= 0.0) {
            return Err(format!(
                "{}: function: noise and duration_s must be >= 0",
                file.name
            ));
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
        let (u1, u2): (f64, f64) = (rng.gen_range(f64::EPSILON..1.0), rng.gen());
        let normal = (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos();
        let noise = s.noise * normal;
        let value = exact + noise;
        if !value.is_finite() {
            return Err(TestError::Measurement(format!(
                "{}: function: the response is not finite ({value})",
                file.name
            )));
        }
        Ok(Outcome {
            value,
            exact,
            noise,
            seed,
            wall_s: wall.elapsed().as_secs_f64(),
        })
    }

    fn responses(&self, o: &Outcome) -> Vec<(&'static str, Response)> {
        vec![
            ("value", Response::Scalar(o.value)),
            ("exact", Response::Scalar(o.exact)),
        ]
    }

    fn summary(&self, o: &Outcome) -> String {
        format!(
            "function: value={} exact={} noise={}",
            o.value, o.exact, o.noise
        )
    }
}
