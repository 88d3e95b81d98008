//! `smc`: sequential Monte Carlo (GrainLearning's iterative Bayesian filter): Halton samples,
//! then rounds drawn from a Gaussian mixture fitted to the weighted samples; calibrated at the
//! posterior mean, with credible intervals.

use std::any::Any;

use surrogate::smc::{self, LikelihoodScale};

use crate::spec::{Section, Stage};
use crate::stage::table::{StageDef, StageTable};
use crate::limits::MAX_SURROGATE_RUNS;
use crate::spec::Study;
use crate::record::{Context, run_seed, StageResult};
use crate::text::{sig, tidy};
use crate::surrogate_stages::{
    calibrate, empty_posterior, misfit, push_runs, SmcOutcome, SmcRound, SurrogateOutcome,
};

#[derive(Clone, Debug, PartialEq)]
pub struct Smc {
    pub samples: Option<usize>,
    pub iterations: usize,
    /// Effective sample size the likelihood's scale is tuned to, as a fraction of the samples.
    pub ess: f64,
    /// Stop when the tuned scale falls below this (None: 1, the lab's own spread, for a
    /// matched response; 0, iterations only, for a minimised one).
    pub sigma_tolerance: Option<f64>,
    pub components: usize,
}

impl StageDef for Smc {
    const NAME: &'static str = "smc";
    const KEYS: &'static [&'static str] = &[
        "samples",
        "iterations",
        "ess",
        "sigma_tolerance",
        "components",
    ];

    fn parse(t: &StageTable) -> Result<Self, String> {
        Ok(Smc {
            samples: t.count_opt("samples", 4, Some(MAX_SURROGATE_RUNS))?,
            iterations: t.count("iterations", 4, 1, Some(1000))?,
            ess: t.fraction("ess", 0.3)?,
            sigma_tolerance: t.non_negative("sigma_tolerance")?,
            components: t.count("components", 8, 1, Some(100))?,
        })
    }
}

impl Stage for Smc {
    fn kind(&self) -> &'static str {
        Self::NAME
    }

    fn heading(&self) -> &'static str {
        "sequential Monte Carlo"
    }

    fn plan(&self, study: &Study, st: &mut StageResult, ctx: &Context) -> Result<(), String> {
        let k = st.active.len();
        let (iterations, ess) = (self.iterations, self.ess);
        let n = self.samples.unwrap_or_else(|| smc::default_samples(k));
        let coded = smc::halton(n, k);
        st.title = format!(
            "sequential Monte Carlo: {n} samples per iteration, up to {iterations} iterations, effective sample size {ess} of the samples"
        );
        push_runs(study, st, ctx, &coded, "iteration 1");
        let density = 0.5f64.powi(k as i32);
        st.set_outcome(SurrogateOutcome::Smc(SmcOutcome {
            rounds: vec![SmcRound {
                start: 0,
                count: n,
                proposal_density: vec![density; n],
                used: Vec::new(),
                weights: Vec::new(),
                posterior: empty_posterior(),
            }],
            stop: None,
        }));
        Ok(())
    }

    fn next_round(
        &self,
        study: &Study,
        st: &mut StageResult,
        ctx: &Context,
    ) -> Result<bool, String> {
        let Some(SurrogateOutcome::Smc(mut out)) = st.take_outcome::<SurrogateOutcome>() else {
            return Err("internal: the smc stage's rounds were not planned before it went on".into())
        };
        let round = out.rounds.len() - 1;
        let (start, count) = (out.rounds[round].start, out.rounds[round].count);
        let mut used = Vec::new();
        let mut samples = Vec::new();
        let mut density = Vec::new();
        let mut misfits = Vec::new();
        let mut actual = Vec::new();
        for i in start..start + count {
            if let Some(v) = st.records[i]
                .as_ref()
                .filter(|r| r.status == crate::store::Status::Done)
                .and_then(|r| r.response)
                .filter(|v| v.is_finite())
            {
                used.push(i);
                samples.push(st.runs[i].coded.clone());
                density.push(out.rounds[round].proposal_density[i - start]);
                misfits.push(misfit(study, v));
                actual.push(
                    st.active
                        .iter()
                        .map(|&pi| st.runs[i].values[pi])
                        .collect::<Vec<f64>>(),
                );
            }
        }
        if used.len() < 2 {
            st.set_outcome(SurrogateOutcome::Smc(out));
            return Err(format!(
                "{} of {count} runs of iteration {} gave a response; the filter needs at least 2{}",
                used.len(),
                round + 1,
                st.first_failure()
            ));
        }
        let tolerance = self.sigma_tolerance.unwrap_or(if study.target.minimised() { 0.0 } else { 1.0 });
        let (mut weights, mut sigma) = smc::weigh(
            &samples,
            &density,
            &misfits,
            LikelihoodScale::EssTarget(self.ess),
        )?;
        if sigma < tolerance {
            // The misfit is in units of the lab's spread: a scale below the tolerance would fit
            // the runs' noise, so the last iteration is weighed at the tolerance and the filter stops.
            (weights, sigma) = smc::weigh(
                &samples,
                &density,
                &misfits,
                LikelihoodScale::Fixed(tolerance),
            )?;
        }
        let posterior = smc::posterior(&actual, &weights, sigma);
        let r = &mut out.rounds[round];
        r.used = used;
        r.weights = weights.clone();
        r.posterior = posterior;
        let sigmas: Vec<f64> = out.rounds.iter().map(|r| r.posterior.sigma).collect();
        let opts = smc::SmcOptions {
            samples: count,
            iterations: self.iterations,
            scale: LikelihoodScale::EssTarget(self.ess),
            sigma_tolerance: tolerance,
            components: self.components,
            seed: run_seed(study.seed, st.index, 1 << 40),
        };
        let stop = if out.rounds.len() >= self.iterations {
            Some(format!("{} iterations done", self.iterations))
        } else {
            smc::stop_reason(&opts, &sigmas)
        };
        if let Some(why) = stop {
            out.stop = Some(why);
            st.set_outcome(SurrogateOutcome::Smc(out));
            return Ok(false);
        }
        let (next, next_density) = smc::next_samples(
            &samples,
            &weights,
            count,
            self.components,
            smc::iteration_seed(opts.seed, round + 1),
        )?;
        out.rounds.push(SmcRound {
            start: st.runs.len(),
            count: next.len(),
            proposal_density: next_density,
            used: Vec::new(),
            weights: Vec::new(),
            posterior: empty_posterior(),
        });
        st.set_outcome(SurrogateOutcome::Smc(out));
        push_runs(study, st, ctx, &next, &format!("iteration {}", round + 2));
        Ok(true)
    }

    fn conclude(
        &self,
        study: &Study,
        st: &mut StageResult,
        ctx: &mut Context,
    ) -> Result<(), String> {
        crate::design_stages::bracket_note(study, st);
        let Some(SurrogateOutcome::Smc(out)) = st.surrogate() else {
            return Err("internal: the smc stage concluded without its rounds".into())
        };
        let mut point = ctx.values.clone();
        let last = out.rounds.last().ok_or("no iteration")?;
        for (j, &pi) in st.active.iter().enumerate() {
            point[pi] = tidy(last.posterior.mean[j]);
        }
        let points: Vec<Vec<f64>> = last
            .used
            .iter()
            .map(|&i| st.active.iter().map(|&pi| st.runs[i].values[pi]).collect())
            .collect();
        let uncertainty = crate::uncertainty_routes::from_posterior(
            st,
            &last.posterior,
            &points,
            &last.weights,
        );
        st.notes.push(format!(
            "{}; calibrated at the posterior mean (scale sigma {}, effective sample size {:.1} of {})",
            out.stop.clone().unwrap_or_default(),
            sig(last.posterior.sigma),
            last.posterior.ess,
            last.used.len()
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
