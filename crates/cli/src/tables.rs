//! `demcal doe` and `demcal surrogate`: the design-of-experiments and surrogate commands on the
//! user's own tables, each handing its work to the `doe` or `surrogate` crate.

use clap::Subcommand;
use std::path::PathBuf;

#[derive(Subcommand)]
pub(crate) enum DoeCommand {
    /// Write a design as CSV (run order, point type, coded and actual columns).
    #[command(
        after_help = "Example:\n  demcal doe design pb --factors restitution:0.2:0.6,static_friction:0.2:0.8,rolling_friction:0.02:0.2 --runs 12 --centers 1 --out pb.csv"
    )]
    Design {
        /// plackett-burman (pb), factorial, fractional, ccd, box-behnken (bbd), lhs, random, steepest.
        kind: String,
        /// A count (3), names (A,B,C) or ranges (restitution:0.2:0.6,stiffness:1e9:1e11:log).
        #[arg(long)]
        factors: String,
        /// Centre points (defaults: 0 for screening designs, 5 or 6 for CCD, 5 for Box-Behnken).
        #[arg(long)]
        centers: Option<usize>,
        /// CCD axial distance: rotatable, spherical, face, orthogonal, inscribed or a number.
        #[arg(long)]
        alpha: Option<String>,
        /// Runs: Plackett-Burman size (12, 20, 24, ...), LHS / random runs, or steepest steps.
        #[arg(long)]
        runs: Option<usize>,
        /// Fractional factorial: smallest fraction of at least this resolution.
        #[arg(long)]
        resolution: Option<usize>,
        /// Fractional factorial: 2^(k-P).
        #[arg(long)]
        fraction: Option<usize>,
        /// CCD: use (true) or not (false) a half-fraction cube (default: for 5 or more factors).
        #[arg(long)]
        half_fraction: Option<bool>,
        /// Latin hypercube: random, centred or maximin (default).
        #[arg(long)]
        lhs: Option<String>,
        /// Steepest path: coefficients or effect signs, one per factor (0 keeps it at the centre).
        #[arg(long, allow_hyphen_values = true)]
        direction: Option<String>,
        /// Steepest path: coded step along the largest coefficient (default 0.5; --runs steps, default 6).
        #[arg(long)]
        step: Option<f64>,
        /// Seed of the run order (and of LHS / random points).
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Write the CSV here (default: standard output, summary on standard error).
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// Fit a model and print the ANOVA table, fit statistics and equations.
    #[command(
        after_help = "Example:\n  demcal doe analyze crates/doe/tests/data/silage-repose-ccd.csv --response angle_deg --model quadratic --plots plots"
    )]
    Analyze {
        /// The design with its response columns filled in (CSV, as `demcal doe design` writes it).
        data: PathBuf,
        #[command(flatten)]
        model: ModelArgs,
        /// One JSON object per response instead of the tables.
        #[arg(long)]
        json: bool,
        /// Write SVG plots (Pareto, predicted vs actual, residuals, normal plot, contour, 3-D).
        #[arg(long)]
        plots: Option<PathBuf>,
    },
    /// Fit the responses and search for the settings that best meet the goals (desirability).
    #[command(
        after_help = "Example:\n  demcal doe optimize crates/doe/tests/data/silage-repose-ccd.csv --response angle_deg --model quadratic --goal angle_deg:target=38.65"
    )]
    Optimize {
        /// The design with its response columns filled in (CSV).
        data: PathBuf,
        #[command(flatten)]
        model: ModelArgs,
        /// [NAME:]maximize|minimize|target=V|range[:lower=L][:upper=U][:weight=W][:importance=1-5];
        /// NAME is a response or a factor (a factor's range limits the search).
        #[arg(long = "goal", required = true)]
        goals: Vec<String>,
        /// How many distinct solutions to print.
        #[arg(long, default_value_t = 10)]
        solutions: usize,
        /// Random starts of the local search.
        #[arg(long, default_value_t = 100)]
        starts: usize,
        /// Seed of the random starts.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// One JSON object with the solutions instead of the table.
        #[arg(long)]
        json: bool,
    },
}

#[derive(Subcommand)]
pub(crate) enum SurrogateCommand {
    /// Train a surrogate on 80 % of the rows and print R^2, RMSE and MAE on training, test and
    /// all rows.
    #[command(
        after_help = "Example:\n  demcal surrogate fit crates/doe/tests/data/silage-repose-ccd.csv --response angle_deg --factors D,E,G --model gp"
    )]
    Fit {
        /// The result table (CSV: factor columns and the response column).
        data: PathBuf,
        #[command(flatten)]
        model: SurrogateArgs,
        /// One JSON object with the scores instead of the table.
        #[arg(long)]
        json: bool,
    },
    /// Train a surrogate, then search it with a genetic algorithm (GA-BP-GA for --model ga-bp)
    /// for the factor settings that meet the goal, inside the table's factor ranges.
    #[command(
        after_help = "A response whose every value in the table is >= 0 (an error, an MSE) is never predicted below 0: a model that dips below zero is reported as 0, and the output says so. To minimise a relative error, model the response it is computed from: --target-of RESPONSE --value LAB.\n\nExamples:\n  demcal surrogate optimize crates/doe/tests/data/silage-repose-ccd.csv --response angle_deg --factors D,E,G --model ga-bp --goal target=38.65\n  demcal surrogate optimize results.csv --response relative_error --target-of angle_deg --value 38.65 --factors D,E,G --model gp --goal minimize"
    )]
    Optimize {
        /// The result table (CSV: factor columns and the response column).
        data: PathBuf,
        #[command(flatten)]
        model: SurrogateArgs,
        /// target=V (e.g. the lab's 38.65), minimize or maximize.
        #[arg(long)]
        goal: String,
        /// With --goal minimize: --response is the relative error |RESPONSE - VALUE| / |VALUE|
        /// (a fraction or in %, checked against the table) of this column. The surrogate then
        /// models this column and computes the error from its prediction, so the error is never
        /// below zero and smallest where the model meets the lab value.
        #[arg(long, value_name = "RESPONSE", requires = "value")]
        target_of: Option<String>,
        /// The lab value the error of --target-of is taken against.
        #[arg(
            long,
            value_name = "LAB",
            requires = "target_of",
            allow_hyphen_values = true
        )]
        value: Option<f64>,
        /// One JSON object with the solution instead of the table.
        #[arg(long)]
        json: bool,
    },
}

#[derive(clap::Args)]
pub(crate) struct SurrogateArgs {
    /// Response column.
    #[arg(long)]
    response: String,
    /// Factor columns, comma-separated (default: every other column except run/order/type
    /// bookkeeping).
    #[arg(long)]
    factors: Option<String>,
    /// gp, bp or ga-bp.
    #[arg(long)]
    model: String,
    /// GP kernel: matern52 (default) or squared_exponential.
    #[arg(long)]
    kernel: Option<String>,
    /// Seeds the train/test split, the starting weights and the genetic algorithms.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Share of the rows trained on; the rest test the model.
    #[arg(long, default_value_t = 0.8)]
    train_fraction: f64,
}

impl SurrogateArgs {
    fn request(self, data: PathBuf) -> Result<surrogate::commands::FitRequest, String> {
        if !(self.train_fraction > 0.0 && self.train_fraction < 1.0) {
            return Err(format!(
                "--train-fraction {}: expected a number between 0 and 1",
                self.train_fraction
            ));
        }
        Ok(surrogate::commands::FitRequest {
            data,
            response: self.response,
            factors: self.factors.map(|f| {
                f.split(',')
                    .map(|s| s.trim().to_string())
                    .filter(|s| !s.is_empty())
                    .collect()
            }),
            model: surrogate::commands::Model::parse(&self.model, self.kernel.as_deref())?,
            seed: self.seed,
            train_fraction: self.train_fraction,
        })
    }
}

pub(crate) fn surrogate_command(action: SurrogateCommand) -> Result<(), String> {
    use surrogate::commands;
    match action {
        SurrogateCommand::Fit { data, model, json } => {
            print!("{}", commands::fit(&model.request(data)?, json)?);
        }
        SurrogateCommand::Optimize {
            data,
            model,
            goal,
            target_of,
            value,
            json,
        } => {
            let goal = commands::Goal::parse(&goal)?;
            // clap makes each of the two need the other.
            let error_of = target_of
                .zip(value)
                .map(|(response, lab)| commands::ErrorOf { response, lab });
            print!(
                "{}",
                commands::optimize(&model.request(data)?, goal, error_of.as_ref(), json)?
            );
        }
    }
    Ok(())
}

#[derive(clap::Args)]
pub(crate) struct ModelArgs {
    /// Response column (repeat for several).
    #[arg(long = "response", required = true)]
    responses: Vec<String>,
    /// Factor columns: names of coded columns, or name:low:high[:log] for columns in actual units
    /// (default: every other column except run/order/type bookkeeping).
    #[arg(long)]
    factors: Option<String>,
    /// linear, 2fi, quadratic, cubic, mean, or a term list such as "A,B,C,AB,A^2" (default:
    /// linear for two-level data, quadratic otherwise).
    #[arg(long)]
    model: Option<String>,
    /// Backward elimination of non-significant terms.
    #[arg(long)]
    reduce: bool,
    /// Alpha out for --reduce.
    #[arg(long, default_value_t = 0.10)]
    alpha_out: f64,
    /// Let --reduce remove terms that higher-order terms contain.
    #[arg(long)]
    no_hierarchy: bool,
    /// Do not separate curvature for two-level designs with centre points.
    #[arg(long)]
    no_curvature: bool,
}

impl ModelArgs {
    fn request(self, data: PathBuf) -> doe::commands::ModelRequest {
        doe::commands::ModelRequest {
            data,
            responses: self.responses,
            factors: self.factors,
            model: self.model,
            reduce: self.reduce,
            alpha_out: self.alpha_out,
            no_hierarchy: self.no_hierarchy,
            no_curvature: self.no_curvature,
        }
    }
}

pub(crate) fn doe_command(action: DoeCommand) -> Result<(), String> {
    use doe::commands;
    match action {
        DoeCommand::Design {
            kind,
            factors,
            centers,
            alpha,
            runs,
            resolution,
            fraction,
            half_fraction,
            lhs,
            direction,
            step,
            seed,
            out,
        } => {
            let req = commands::DesignRequest {
                kind,
                factors,
                center_points: centers,
                alpha,
                runs,
                resolution,
                fraction,
                half_fraction,
                lhs,
                direction,
                step,
                seed,
            };
            let (design, factors) = commands::make_design(&req)?;
            let csv = commands::design_csv(&design, &factors, seed);
            let summary = commands::design_summary(&design, &factors, seed);
            match out {
                Some(path) => {
                    std::fs::write(&path, csv).map_err(|e| format!("{}: {e}", path.display()))?;
                    print!("{summary}");
                    println!("wrote {}", path.display());
                }
                None => {
                    eprint!("{summary}");
                    print!("{csv}");
                }
            }
            Ok(())
        }
        DoeCommand::Analyze {
            data,
            model,
            json,
            plots,
        } => {
            print!(
                "{}",
                commands::analyze(&model.request(data), json, plots.as_deref())?
            );
            Ok(())
        }
        DoeCommand::Optimize {
            data,
            model,
            goals,
            solutions,
            starts,
            seed,
            json,
        } => {
            let opt = commands::OptimizeRequest {
                goals,
                solutions,
                starts,
                seed,
            };
            print!("{}", commands::optimize(&model.request(data), &opt, json)?);
            Ok(())
        }
    }
}
