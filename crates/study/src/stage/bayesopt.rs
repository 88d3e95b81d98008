//! `bayesopt`: Gaussian-process Bayesian optimisation (seed 000's calibration): a Latin
//! hypercube, then rounds of `batch` points by expected improvement until `iterations`,
//! `budget` or `patience` says stop; calibrated at the finished run whose GP mean is lowest.
//!
//! Each round's points follow from every finished run of the rounds before it and the study's
//! seed, so a study killed in the middle replays the same rounds from its store.

use std::any::Any;

use surrogate::bayesopt::{self, BoOptions, IterationSummary};
use surrogate::gp::{GpOptions, Kernel};

use crate::spec::{Section, Stage};
use crate::stage::table::{StageDef, StageTable};
use crate::limits::MAX_SURROGATE_RUNS;
use crate::spec::Study;
use crate::record::{Context, run_seed, StageResult};
use crate::text::sig;
use crate::surrogate_stages::{calibrate, finished, push_runs, BoOutcome, SurrogateOutcome};

#[derive(Clone, Debug, PartialEq)]
pub struct BayesOpt {
    /// Runs of the Latin hypercube (None: 10 per parameter).
    pub initial: Option<usize>,
    pub iterations: usize,
    /// Points per round: the runs that fit at once (jobs, cluster slots). Part of the study,
    /// not of the command line, so that a resumed study asks for the same points.
    pub batch: usize,
    /// Most runs of the stage in all, the hypercube included.
    pub budget: Option<usize>,
    /// Stop after this many rounds without the best objective improving by `tolerance`.
    pub patience: Option<usize>,
    pub tolerance: f64,
    pub kernel: Kernel,
    pub restarts: usize,
}

impl StageDef for BayesOpt {
    const NAME: &'static str = "bayesopt";
    const KEYS: &'static [&'static str] = &[
        "initial",
        "iterations",
        "batch",
        "budget",
        "patience",
        "tolerance",
        "kernel",
        "restarts",
    ];

    fn parse(t: &StageTable) -> Result<Self, String> {
        Ok(BayesOpt {
            initial: t.count_opt("initial", 2, Some(MAX_SURROGATE_RUNS))?,
            iterations: t.count("iterations", 20, 0, Some(MAX_SURROGATE_RUNS))?,
            batch: t.count("batch", 4, 1, Some(1000))?,
            budget: t.count_opt("budget", 2, Some(MAX_SURROGATE_RUNS))?,
            patience: t.count_opt("patience", 1, Some(MAX_SURROGATE_RUNS))?,
            tolerance: t.non_negative("tolerance")?.unwrap_or(0.0),
            kernel: Kernel::parse(&t.text("kernel", "matern52")?).map_err(|e| t.fail("kernel", e))?,
            restarts: t.count("restarts", 5, 0, Some(1000))?,
        })
    }
}

impl BayesOpt {
    fn options(&self, study: &Study, st: &StageResult) -> BoOptions {
        BoOptions {
            initial: self.initial.unwrap_or(10 * st.active.len()),
            iterations: self.iterations,
            batch: self.batch,
            budget: self.budget,
            patience: self.patience,
            tolerance: self.tolerance,
            gp: GpOptions {
                kernel: self.kernel,
                restarts: self.restarts,
                seed: run_seed(study.seed, st.index, 1 << 40),
            },
            seed: run_seed(study.seed, st.index, 1 << 41),
        }
    }
}

impl Stage for BayesOpt {
    fn kind(&self) -> &'static str {
        Self::NAME
    }

    fn heading(&self) -> &'static str {
        "Bayesian optimisation"
    }

    fn plan(&self, study: &Study, st: &mut StageResult, ctx: &Context) -> Result<(), String> {
        let k = st.active.len();
        let opts = self.options(study, st);
        let n = opts.budget.map_or(opts.initial, |b| opts.initial.min(b));
        let coded = bayesopt::initial_design(k, n, opts.seed)?;
        st.title = format!(
            "Bayesian optimisation: {n}-run Latin hypercube, then up to {} rounds of {} by expected improvement ({} GP)",
            opts.iterations,
            self.batch,
            self.kernel.name()
        );
        push_runs(study, st, ctx, &coded, "hypercube");
        st.set_outcome(SurrogateOutcome::BayesOpt(Box::new(BoOutcome {
            rounds: vec![n],
            history: Vec::new(),
            stop: None,
            gp: None,
        })));
        Ok(())
    }

    fn next_round(
        &self,
        study: &Study,
        st: &mut StageResult,
        ctx: &Context,
    ) -> Result<bool, String> {

        let opts = self.options(study, st);
        let (_, x, y) = finished(study, st);
        if x.len() < 2 {
            return Err(format!(
                "{} of {} runs gave a response; a Gaussian process needs at least 2{}",
                x.len(),
                st.runs.len(),
                st.first_failure()
            ));
        }
        let Some(SurrogateOutcome::BayesOpt(mut out)) = st.take_outcome::<SurrogateOutcome>() else {
            return Err("internal: the bayesopt stage's rounds were not planned before it went on".into())
        };
        let iteration = out.rounds.len() - 1;
        let planned: usize = out.rounds.iter().sum();
        let room = opts
            .budget
            .map_or(usize::MAX, |b| b.saturating_sub(planned));
        let q = opts.batch.min(room).max(1);
        let proposal = bayesopt::propose(&x, &y, q, &opts, iteration + 1)?;
        let best = y.iter().copied().fold(f64::INFINITY, f64::min);
        out.history.push(IterationSummary {
            iteration,
            evaluations: x.len(),
            best_observed: best,
            // The objective (an error) is never negative; its GP may dip below zero.
            predicted_minimum: crate::target::non_negative(proposal.predicted_minimum),
        });
        let stop = if room == 0 {
            Some(format!("budget of {planned} runs spent"))
        } else {
            bayesopt::stop_reason(&opts, &out.history)
        };
        out.gp = Some(proposal.gp.clone());
        if let Some(why) = stop {
            out.stop = Some(why);
            st.set_outcome(SurrogateOutcome::BayesOpt(out));
            return Ok(false);
        }
        debug_assert_eq!(proposal.points.len(), q);
        out.rounds.push(proposal.points.len());
        st.set_outcome(SurrogateOutcome::BayesOpt(out));
        push_runs(
            study,
            st,
            ctx,
            &proposal.points,
            &format!("round {}", iteration + 1),
        );
        Ok(true)
    }

    fn conclude(
        &self,
        study: &Study,
        st: &mut StageResult,
        ctx: &mut Context,
    ) -> Result<(), String> {
        crate::design_stages::bracket_note(study, st);
        let Some(SurrogateOutcome::BayesOpt(out)) = st.surrogate() else {
            return Err("internal: the bayesopt stage concluded without its rounds".into())
        };
        let gp = out.gp.as_ref().ok_or("no Gaussian process was fitted")?;
        // With noisy runs the lowest observed objective is partly luck: the calibrated run
        // is the finished one whose GP mean (the smoothed objective) is lowest.
        let (idx, x, y) = finished(study, st);
        let (j, _) = x
            .iter()
            .map(|c| gp.predict_mean(c))
            .enumerate()
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .ok_or("no run gave a response")?;
        let i = idx[j];
        let point = st.runs[i].values.clone();
        let uncertainty = crate::uncertainty_routes::from_gp(study, st, gp, x[j].clone());
        st.notes.push(format!(
            "{}; calibrated at run {} (GP mean of the objective {}, observed {}); the GP's predicted minimum {}",
            out.stop.clone().unwrap_or_default(),
            i + 1,
            sig(crate::target::non_negative(gp.predict_mean(&x[j]))),
            sig(y[j]),
            sig(out.history.last().map_or(f64::NAN, |h| h.predicted_minimum))
        ));
        st.uncertainty = Some(uncertainty);
        calibrate(st, ctx, point);
        Ok(())
    }

    fn report(&self, s: &mut Section<'_>) {
        crate::surrogate_report::stage_html(s.h, s.figs, s.study, s.st);
    }

    fn as_any(&self) -> &dyn Any {
        self
    }
}
