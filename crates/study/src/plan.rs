//! The plan: the ordered stages of a study, each with its settings, read from the study file's
//! `plan` list (a stage's name, or a table with `stage = ...` and its keys).

use doe::design::CcdAlpha;

use crate::paths::number;

#[derive(Clone, Debug, PartialEq)]
pub enum ScreeningDesign {
    PlackettBurman { runs: Option<usize> },
    Fractional { resolution: usize },
    Factorial,
}

#[derive(Clone, Debug, PartialEq)]
pub enum RsmDesign {
    CentralComposite { alpha: CcdAlpha },
    BoxBehnken,
}

/// Largest counts a plan may ask for: beyond them a stage would only eat memory and time.
pub const MAX_CENTER_POINTS: usize = 1000;
pub const MAX_STEPS: usize = 1000;
pub const MAX_REPLICATES: usize = 1000;
pub const MAX_SOLUTIONS: usize = 1000;

/// One stage of the plan, with its settings (defaults filled in).
#[derive(Clone, Debug, PartialEq)]
pub enum Stage {
    Screening {
        design: ScreeningDesign,
        center_points: usize,
        /// Significance level for a factor to go on.
        alpha: f64,
        min_factors: usize,
        max_factors: usize,
    },
    Steepest {
        /// Runs along the path, from one end of the ranges to the other.
        steps: usize,
        /// Move every factor by the sign of its effect (`signs`) or in proportion to it.
        proportional: bool,
    },
    Rsm {
        design: RsmDesign,
        center_points: Option<usize>,
        /// Backward elimination of terms with p above `alpha_out`, keeping hierarchy.
        reduce: bool,
        alpha_out: f64,
    },
    Optimize {
        solutions: usize,
        starts: usize,
        region: SearchRegion,
    },
    Validate {
        replicates: usize,
        /// How many of the optimisation's distinct solutions are replicated, best first: all
        /// their runs go at once (they fill the cores of a large machine that three replicates
        /// would leave idle), and the one whose mean comes nearest the lab value is calibrated.
        candidates: usize,
    },
    /// Gaussian-process Bayesian optimisation: a Latin hypercube, then rounds of `batch` points
    /// by expected improvement until `iterations`, `budget` or `patience` says stop.
    BayesOpt {
        /// Runs of the Latin hypercube (None: 10 per parameter).
        initial: Option<usize>,
        iterations: usize,
        /// Points per round: the runs that fit at once (jobs, cluster slots). Part of the study,
        /// not of the command line, so that a resumed study asks for the same points.
        batch: usize,
        /// Most runs of the stage in all, the hypercube included.
        budget: Option<usize>,
        /// Stop after this many rounds without the best objective improving by `tolerance`.
        patience: Option<usize>,
        tolerance: f64,
        kernel: surrogate::gp::Kernel,
        restarts: usize,
    },
    /// GA-BP network trained on runs (its own Latin hypercube of `runs`, or every finished run
    /// of the stages before it), then GA-BP-GA: a genetic search of the network for the lab value.
    GaBp {
        runs: Option<usize>,
        hidden: Option<usize>,
        generations: usize,
        population: usize,
        mutation: f64,
        search_generations: usize,
        search_population: usize,
        train_fraction: f64,
        max_epochs: usize,
    },
    /// Sequential Monte Carlo (GrainLearning's iterative Bayesian filter): Halton samples, then
    /// rounds drawn from a Gaussian mixture fitted to the weighted samples.
    Smc {
        samples: Option<usize>,
        iterations: usize,
        /// Effective sample size the likelihood's scale is tuned to, as a fraction of the samples.
        ess: f64,
        /// Stop when the tuned scale falls below this (None: 1, the lab's own spread, for a
        /// matched response; 0, iterations only, for a minimised one).
        sigma_tolerance: Option<f64>,
        components: usize,
    },
}

/// The stages a plan may hold, in the order help texts list them.
pub const STAGE_NAMES: &[&str] = &[
    "screening",
    "steepest",
    "rsm",
    "optimize",
    "bayesopt",
    "ga_bp",
    "smc",
    "validate",
];

/// The keys a stage's table takes (besides `stage`), or `None` for a stage that does not exist.
pub fn stage_keys(kind: &str) -> Option<&'static [&'static str]> {
    Some(match kind {
        "screening" => &[
            "design",
            "runs",
            "resolution",
            "center_points",
            "alpha",
            "min_factors",
            "max_factors",
        ],
        "steepest" => &["steps", "direction"],
        "rsm" => &["design", "alpha", "center_points", "reduce", "alpha_out"],
        "optimize" => &["solutions", "starts", "region"],
        "validate" => &["replicates", "candidates"],
        "bayesopt" => &[
            "initial",
            "iterations",
            "batch",
            "budget",
            "patience",
            "tolerance",
            "kernel",
            "restarts",
        ],
        "ga_bp" => &[
            "runs",
            "hidden",
            "generations",
            "population",
            "mutation",
            "search_generations",
            "search_population",
            "train_fraction",
            "max_epochs",
        ],
        "smc" => &[
            "samples",
            "iterations",
            "ess",
            "sigma_tolerance",
            "components",
        ],
        _ => return None,
    })
}

pub const STAGES: &str = "screening, steepest, rsm, optimize, bayesopt, ga_bp, smc, validate";

/// Largest sizes a surrogate stage may ask for.
pub const MAX_SURROGATE_RUNS: usize = 100_000;
pub const MAX_GA: usize = 100_000;

impl Stage {
    pub fn kind(&self) -> &'static str {
        match self {
            Stage::Screening { .. } => "screening",
            Stage::Steepest { .. } => "steepest",
            Stage::Rsm { .. } => "rsm",
            Stage::Optimize { .. } => "optimize",
            Stage::Validate { .. } => "validate",
            Stage::BayesOpt { .. } => "bayesopt",
            Stage::GaBp { .. } => "ga_bp",
            Stage::Smc { .. } => "smc",
        }
    }

    /// Whether the stage runs simulations (optimize only searches a model; ga_bp without runs
    /// trains on the runs before it).
    pub fn runs_simulations(&self) -> bool {
        !matches!(
            self,
            Stage::Optimize { .. } | Stage::GaBp { runs: None, .. }
        )
    }

    /// Whether the stage plans its runs round by round from the results of the rounds before.
    pub fn iterative(&self) -> bool {
        matches!(self, Stage::BayesOpt { .. } | Stage::Smc { .. })
    }
}

/// Where `optimize` searches the fitted model.
#[derive(Clone, Debug, PartialEq)]
pub enum SearchRegion {
    /// The factorial box, coded ±1: the screening or CCD ranges (Design-Expert's "in range").
    Cube,
    /// As far as the design's runs reach on each factor: out to the axial points (±alpha) of a
    /// central composite design, as seeds 002-004 optimise; ±1 for a box design.
    Axial,
    /// Limits in the parameters' own units, by name; a factor not named keeps ±1.
    Limits(Vec<(String, f64, f64)>),
}

impl SearchRegion {
    /// Words for the report.
    pub fn describe(&self) -> String {
        match self {
            SearchRegion::Cube => "within its coded range −1 to +1".into(),
            SearchRegion::Axial => {
                "out to the design's axial points (coded −alpha to +alpha)".into()
            }
            SearchRegion::Limits(l) => format!(
                "within the limits given: {}",
                l.iter()
                    .map(|(n, lo, hi)| format!("{n} {lo} .. {hi}"))
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        }
    }
}

/// Reads `optimize`'s `region`: "cube", "axial", or a table of [low, high] by parameter name.
fn search_region(
    v: Option<&toml::Value>,
    key: &str,
    params: &[(String, f64, f64)],
    err: &dyn Fn(&str, String) -> String,
) -> Result<SearchRegion, String> {
    let expected = "expected \"cube\" (coded ±1), \"axial\" (out to the axial points, ±alpha) or limits by parameter, e.g. { rolling_friction = [0.05, 0.3] }";
    match v {
        None => Ok(SearchRegion::Cube),
        Some(toml::Value::String(s)) if s == "cube" => Ok(SearchRegion::Cube),
        Some(toml::Value::String(s)) if s == "axial" => Ok(SearchRegion::Axial),
        Some(toml::Value::Table(t)) if !t.is_empty() => {
            let mut limits = Vec::new();
            for (name, v) in t {
                let k = format!("{key}.region.{name}");
                let Some(&(_, min, max)) = params.iter().find(|(n, _, _)| n == name) else {
                    let names: Vec<&str> = params.iter().map(|(n, _, _)| n.as_str()).collect();
                    return Err(err(
                        &k,
                        format!(
                            "no parameter is named \"{name}\" (the parameters: {})",
                            names.join(", ")
                        ),
                    ));
                };
                let pair: Vec<f64> = v
                    .as_array()
                    .map(|a| {
                        a.iter()
                            .filter_map(|x| x.as_float().or(x.as_integer().map(|i| i as f64)))
                            .collect()
                    })
                    .unwrap_or_default();
                match pair[..] {
                    [lo, hi] if lo.is_finite() && hi.is_finite() && lo < hi => {
                        // The parameter's range is where it may be set at all.
                        if lo < min || hi > max {
                            return Err(err(
                                &k,
                                format!("[{lo}, {hi}] leaves the parameter's range {min} .. {max}"),
                            ));
                        }
                        limits.push((name.clone(), lo, hi))
                    }
                    _ => {
                        return Err(err(
                            &k,
                            "expected [low, high], two finite numbers with low < high, in the parameter's units".into(),
                        ))
                    }
                }
            }
            Ok(SearchRegion::Limits(limits))
        }
        Some(_) => Err(err(&format!("{key}.region"), expected.into())),
    }
}

pub(crate) fn parse_plan(
    doc: &toml::Table,
    err: &dyn Fn(&str, String) -> String,
    params: &[(String, f64, f64)],
) -> Result<Vec<Stage>, String> {
    let n_params = params.len();
    let items = match doc.get("plan") {
        None => {
            return Err(err(
                "plan",
                format!("missing: an ordered list of stages ({STAGES}), e.g. plan = [\"rsm\", \"optimize\", \"validate\"]"),
            ))
        }
        Some(toml::Value::Array(a)) if !a.is_empty() => a,
        Some(_) => {
            return Err(err(
                "plan",
                format!("expected a non-empty list of stages ({STAGES})"),
            ))
        }
    };
    let mut plan = Vec::new();
    for (i, item) in items.iter().enumerate() {
        let key = format!("plan[{i}]");
        let empty = toml::Table::new();
        let (kind, t) = match item {
            toml::Value::String(s) => (s.clone(), &empty),
            toml::Value::Table(t) => (
                t.get("stage")
                    .and_then(|v| v.as_str())
                    .ok_or_else(|| {
                        err(
                            &format!("{key}.stage"),
                            format!("missing: which stage ({STAGES})"),
                        )
                    })?
                    .to_string(),
                t,
            ),
            _ => {
                return Err(err(
                    &key,
                    format!("expected a stage name ({STAGES}) or a table with stage = ..."),
                ))
            }
        };
        let allowed: &[&str] = match stage_keys(&kind) {
            Some(keys) => keys,
            None => {
                return Err(err(
                    &format!("{key}.stage"),
                    format!("unknown stage \"{kind}\" (expected one of: {STAGES})"),
                ))
            }
        };
        for k in t.keys() {
            if k != "stage" && !allowed.contains(&k.as_str()) {
                return Err(err(
                    &format!("{key}.{k}"),
                    format!(
                        "unknown key for a {kind} stage (expected {})",
                        allowed.join(", ")
                    ),
                ));
            }
        }
        // A whole number from `min` to `max` (None: no upper limit).
        let count =
            |k: &str, default: usize, min: usize, max: Option<usize>| -> Result<usize, String> {
                match t.get(k) {
                    None => Ok(default),
                    Some(toml::Value::Integer(n))
                        if *n >= min as i64 && max.is_none_or(|m| *n <= m as i64) =>
                    {
                        Ok(*n as usize)
                    }
                    Some(_) => Err(err(
                        &format!("{key}.{k}"),
                        match max {
                            Some(m) => format!("expected a whole number from {min} to {m}"),
                            None => format!("expected a whole number >= {min}"),
                        },
                    )),
                }
            };
        let fraction = |k: &str, default: f64| -> Result<f64, String> {
            match t.get(k) {
                None => Ok(default),
                Some(v) => number(v).filter(|a| *a > 0.0 && *a < 1.0).ok_or_else(|| {
                    err(
                        &format!("{key}.{k}"),
                        "expected a number between 0 and 1".into(),
                    )
                }),
            }
        };
        let text = |k: &str, default: &str| -> Result<String, String> {
            match t.get(k) {
                None => Ok(default.to_string()),
                Some(toml::Value::String(s)) => Ok(s.to_ascii_lowercase()),
                Some(_) => Err(err(&format!("{key}.{k}"), "expected a string".into())),
            }
        };
        let stage = match kind.as_str() {
            "screening" => {
                if n_params < 2 {
                    return Err(err(&key, "screening needs at least two parameters".into()));
                }
                let design = match text("design", "plackett-burman")?.as_str() {
                    "plackett-burman" | "pb" => ScreeningDesign::PlackettBurman {
                        runs: t
                            .get("runs")
                            .map(|_| count("runs", 12, 4, Some(doe::design::MAX_PB_RUNS)))
                            .transpose()?,
                    },
                    "fractional" | "fractional-factorial" => ScreeningDesign::Fractional {
                        resolution: count("resolution", 4, 3, None)?,
                    },
                    "factorial" | "full-factorial" => ScreeningDesign::Factorial,
                    other => {
                        return Err(err(
                            &format!("{key}.design"),
                            format!("unknown screening design \"{other}\" (expected plackett-burman, fractional, factorial)"),
                        ))
                    }
                };
                let min_factors = count("min_factors", 2.min(n_params), 1, None)?;
                let max_factors = count("max_factors", 4.min(n_params), 1, None)?;
                if min_factors > max_factors {
                    return Err(err(
                        &format!("{key}.min_factors"),
                        format!("expected min_factors <= max_factors ({max_factors})"),
                    ));
                }
                Stage::Screening {
                    design,
                    center_points: count("center_points", 1, 0, Some(MAX_CENTER_POINTS))?,
                    alpha: fraction("alpha", 0.05)?,
                    min_factors,
                    max_factors,
                }
            }
            "steepest" => Stage::Steepest {
                steps: count("steps", 5, 3, Some(MAX_STEPS))?,
                proportional: match text("direction", "signs")?.as_str() {
                    "signs" => false,
                    "coefficients" => true,
                    _ => {
                        return Err(err(
                            &format!("{key}.direction"),
                            "expected \"signs\" or \"coefficients\"".into(),
                        ))
                    }
                },
            },
            "rsm" => {
                let design = match text("design", "ccd")?.as_str() {
                    "ccd" | "central-composite" => RsmDesign::CentralComposite {
                        alpha: ccd_alpha(t.get("alpha"))
                            .map_err(|e| err(&format!("{key}.alpha"), e))?,
                    },
                    "box-behnken" | "bbd" => {
                        if t.contains_key("alpha") {
                            return Err(err(
                                &format!("{key}.alpha"),
                                "a Box-Behnken design has no axial distance".into(),
                            ));
                        }
                        RsmDesign::BoxBehnken
                    }
                    other => {
                        return Err(err(
                            &format!("{key}.design"),
                            format!("unknown response-surface design \"{other}\" (expected ccd, box-behnken)"),
                        ))
                    }
                };
                Stage::Rsm {
                    design,
                    center_points: t
                        .get("center_points")
                        .map(|_| count("center_points", 0, 1, Some(MAX_CENTER_POINTS)))
                        .transpose()?,
                    reduce: match t.get("reduce") {
                        None => true,
                        Some(toml::Value::Boolean(b)) => *b,
                        Some(_) => {
                            return Err(err(
                                &format!("{key}.reduce"),
                                "expected true or false".into(),
                            ))
                        }
                    },
                    alpha_out: fraction("alpha_out", 0.10)?,
                }
            }
            "optimize" => Stage::Optimize {
                solutions: count("solutions", 5, 1, Some(MAX_SOLUTIONS))?,
                starts: count("starts", 40, 1, Some(doe::optimize::MAX_STARTS))?,
                region: search_region(t.get("region"), &key, params, err)?,
            },
            "validate" => Stage::Validate {
                replicates: count("replicates", 3, 1, Some(MAX_REPLICATES))?,
                candidates: count("candidates", 1, 1, Some(MAX_SOLUTIONS))?,
            },
            "bayesopt" => Stage::BayesOpt {
                initial: t
                    .get("initial")
                    .map(|_| count("initial", 0, 2, Some(MAX_SURROGATE_RUNS)))
                    .transpose()?,
                iterations: count("iterations", 20, 0, Some(MAX_SURROGATE_RUNS))?,
                batch: count("batch", 4, 1, Some(1000))?,
                budget: t
                    .get("budget")
                    .map(|_| count("budget", 0, 2, Some(MAX_SURROGATE_RUNS)))
                    .transpose()?,
                patience: t
                    .get("patience")
                    .map(|_| count("patience", 0, 1, Some(MAX_SURROGATE_RUNS)))
                    .transpose()?,
                tolerance: match t.get("tolerance") {
                    None => 0.0,
                    Some(v) => number(v)
                        .filter(|x| *x >= 0.0 && x.is_finite())
                        .ok_or_else(|| {
                            err(&format!("{key}.tolerance"), "expected a number >= 0".into())
                        })?,
                },
                kernel: surrogate::gp::Kernel::parse(&text("kernel", "matern52")?)
                    .map_err(|e| err(&format!("{key}.kernel"), e))?,
                restarts: count("restarts", 5, 0, Some(1000))?,
            },
            "ga_bp" => Stage::GaBp {
                runs: t
                    .get("runs")
                    .map(|_| count("runs", 0, 5, Some(MAX_SURROGATE_RUNS)))
                    .transpose()?,
                hidden: t
                    .get("hidden")
                    .map(|_| count("hidden", 0, 1, Some(1000)))
                    .transpose()?,
                generations: count("generations", 200, 1, Some(MAX_GA))?,
                population: count("population", 100, 4, Some(MAX_GA))?,
                mutation: fraction("mutation", 0.2)?,
                search_generations: count("search_generations", 100, 1, Some(MAX_GA))?,
                search_population: count("search_population", 100, 4, Some(MAX_GA))?,
                train_fraction: fraction("train_fraction", 0.8)?,
                max_epochs: count("max_epochs", 1000, 1, Some(MAX_GA))?,
            },
            "smc" => Stage::Smc {
                samples: t
                    .get("samples")
                    .map(|_| count("samples", 0, 4, Some(MAX_SURROGATE_RUNS)))
                    .transpose()?,
                iterations: count("iterations", 4, 1, Some(1000))?,
                ess: fraction("ess", 0.3)?,
                sigma_tolerance: match t.get("sigma_tolerance") {
                    None => None,
                    Some(v) => Some(
                        number(v)
                            .filter(|x| *x >= 0.0 && x.is_finite())
                            .ok_or_else(|| {
                                err(
                                    &format!("{key}.sigma_tolerance"),
                                    "expected a number >= 0".into(),
                                )
                            })?,
                    ),
                },
                components: count("components", 8, 1, Some(100))?,
            },
            _ => unreachable!(),
        };
        // What each stage reads from the ones before it.
        let before = |kinds: &[&str]| plan.iter().any(|s: &Stage| kinds.contains(&s.kind()));
        match &stage {
            Stage::Steepest { .. } if !before(&["screening"]) => {
                return Err(err(
                    &key,
                    "steepest follows the effects of a screening stage; put one before it".into(),
                ))
            }
            Stage::GaBp { runs: None, .. }
                if !plan.iter().any(|s: &Stage| s.runs_simulations()) =>
            {
                return Err(err(
                    &key,
                    "ga_bp without runs = N trains on the runs of the stages before it, and none runs simulations; give runs = N for its own Latin hypercube, or put a design stage first".into(),
                ))
            }
            Stage::Optimize { .. } if !before(&["screening", "rsm"]) => {
                return Err(err(
                    &key,
                    "optimize searches a fitted model; put a screening or rsm stage before it"
                        .into(),
                ))
            }
            _ => {}
        }
        plan.push(stage);
    }
    Ok(plan)
}

/// The axial distance of a CCD: `rotatable`, `face`, `spherical`, `orthogonal`, or a positive
/// number (written as a number or as text).
fn ccd_alpha(v: Option<&toml::Value>) -> Result<CcdAlpha, String> {
    const EXPECTED: &str = "expected rotatable, face, spherical, orthogonal or a positive number";
    let positive = |a: f64| {
        (a.is_finite() && a > 0.0)
            .then_some(CcdAlpha::Custom(a))
            .ok_or_else(|| format!("{a}: {EXPECTED}"))
    };
    match v {
        None => Ok(CcdAlpha::Rotatable),
        Some(toml::Value::String(s)) => match s.to_ascii_lowercase().as_str() {
            "rotatable" => Ok(CcdAlpha::Rotatable),
            "face" => Ok(CcdAlpha::FaceCentred),
            "spherical" => Ok(CcdAlpha::Spherical),
            "orthogonal" => Ok(CcdAlpha::Orthogonal),
            other => match other.parse::<f64>() {
                Ok(a) if a.is_finite() && a > 0.0 => Ok(CcdAlpha::Custom(a)),
                _ => Err(format!("\"{s}\": {EXPECTED}")),
            },
        },
        Some(v) => match number(v) {
            Some(a) => positive(a),
            None => Err(format!("{v}: {EXPECTED}")),
        },
    }
}
