//! The surrogate stages: `bayesopt`, `ga_bp` and `smc`.
//!
//! `bayesopt` and `smc` plan round by round: each round's points follow from every finished run
//! of the rounds before it (and the study's seed), so [`extend`] is called by the replay after
//! each round is complete, and a study killed in the middle replays the same rounds from its
//! store and goes on where it stopped. `ga_bp` plans at most one design (its own Latin
//! hypercube) and trains on what it gets, or on the finished runs of the stages before it.
//!
//! The objective a surrogate stage works on is the relative error |sim - lab| / |lab| for a
//! matched response, or the response itself for a minimised one (a curve MSE).

use doe::Factor;
use surrogate::bayesopt::{self, BoOptions, IterationSummary};
use surrogate::genetic::{self, GaOptions, GaResult};
use surrogate::gp::{Gp, GpOptions};
use surrogate::network::{self, BpOptions, TrainedNetwork};
use surrogate::smc::{self, LikelihoodScale, Posterior};

use crate::spec::Combine;
use crate::spec::{Stage, Study};
use crate::stages::{run_seed, sig, tidy, Context, RunSpec, StageResult};

/// What a surrogate stage found, for the report and the summary.
#[derive(Clone, Debug)]
pub enum SurrogateOutcome {
    BayesOpt(Box<BoOutcome>),
    GaBp(Box<GaBpOutcome>),
    Smc(SmcOutcome),
}

#[derive(Clone, Debug)]
pub struct BoOutcome {
    /// Runs planned in each round (the hypercube first).
    pub rounds: Vec<usize>,
    /// After each finished round: the best objective observed and the GP's predicted minimum.
    pub history: Vec<IterationSummary>,
    pub stop: Option<String>,
    /// The last GP, fitted to every finished run's objective (coded factors of the stage).
    pub gp: Option<Gp>,
}

#[derive(Clone, Debug)]
pub struct GaBpOutcome {
    /// Where the training rows came from.
    pub source: String,
    /// Training rows: the active parameters coded over `factors`, and the response.
    pub x: Vec<Vec<f64>>,
    pub y: Vec<f64>,
    pub trained: TrainedNetwork,
    /// GA-BP-GA: the coded inputs whose prediction is nearest the lab value.
    pub search: GaResult,
    pub predicted: f64,
}

#[derive(Clone, Debug)]
pub struct SmcRound {
    /// First run index of the round, and how many runs it planned.
    pub start: usize,
    pub count: usize,
    /// Each planned run's proposal density (coded box), in run order.
    pub proposal_density: Vec<f64>,
    /// Runs that gave a response, with their normalised weights.
    pub used: Vec<usize>,
    pub weights: Vec<f64>,
    /// The posterior of the active parameters in actual units.
    pub posterior: Posterior,
}

#[derive(Clone, Debug)]
pub struct SmcOutcome {
    pub rounds: Vec<SmcRound>,
    pub stop: Option<String>,
}

/// The objective a surrogate minimises for a response `y`.
pub fn objective(study: &Study, y: f64) -> f64 {
    if study.target.minimised() {
        y
    } else {
        (y - study.target.value).abs() / study.target.value.abs()
    }
}

fn push_runs(study: &Study, st: &mut StageResult, ctx: &Context, coded: &[Vec<f64>], label: &str) {
    for c in coded {
        let index = st.runs.len();
        let mut values = ctx.values.clone();
        for (j, &pi) in st.active.iter().enumerate() {
            values[pi] = tidy(st.factors[j].to_actual(c[j]));
        }
        // The coded point that is stored is the one the tidied values give back, so that a
        // replay's GP sees the same numbers whether or not the run was just made.
        let coded = st
            .factors
            .iter()
            .zip(&st.active)
            .map(|(f, &pi)| f.to_coded(values[pi]))
            .collect();
        st.runs.push(RunSpec {
            stage: st.index,
            stage_kind: st.kind,
            index,
            label: format!("{label}, run {}", index + 1),
            coded,
            values,
            seed: run_seed(study.seed, st.index, index),
        });
    }
}

fn bo_options(study: &Study, stage: &Stage, st: &StageResult) -> BoOptions {
    let Stage::BayesOpt {
        initial,
        iterations,
        batch,
        budget,
        patience,
        tolerance,
        kernel,
        restarts,
    } = stage
    else {
        unreachable!("bo_options of a {} stage", stage.kind())
    };
    BoOptions {
        initial: initial.unwrap_or(10 * st.active.len()),
        iterations: *iterations,
        batch: *batch,
        budget: *budget,
        patience: *patience,
        tolerance: *tolerance,
        gp: GpOptions {
            kernel: *kernel,
            restarts: *restarts,
            seed: run_seed(study.seed, st.index, 1 << 40),
        },
        seed: run_seed(study.seed, st.index, 1 << 41),
    }
}

/// The stage's first runs (and its title).
pub(crate) fn plan(
    study: &Study,
    stage: &Stage,
    st: &mut StageResult,
    ctx: &Context,
) -> Result<(), String> {
    let k = st.active.len();
    match stage {
        Stage::BayesOpt { kernel, batch, .. } => {
            let opts = bo_options(study, stage, st);
            let n = opts.budget.map_or(opts.initial, |b| opts.initial.min(b));
            let coded = bayesopt::initial_design(k, n, opts.seed)?;
            st.title = format!(
                "Bayesian optimisation: {n}-run Latin hypercube, then up to {} rounds of {batch} by expected improvement ({} GP)",
                opts.iterations,
                kernel.name()
            );
            push_runs(study, st, ctx, &coded, "hypercube");
            st.surrogate = Some(SurrogateOutcome::BayesOpt(Box::new(BoOutcome {
                rounds: vec![n],
                history: Vec::new(),
                stop: None,
                gp: None,
            })));
        }
        Stage::Smc {
            samples,
            iterations,
            ess,
            ..
        } => {
            let n = samples.unwrap_or_else(|| smc::default_samples(k));
            let coded = smc::halton(n, k);
            st.title = format!(
                "sequential Monte Carlo: {n} samples per iteration, up to {iterations} iterations, effective sample size {ess} of the samples"
            );
            push_runs(study, st, ctx, &coded, "iteration 1");
            let density = 0.5f64.powi(k as i32);
            st.surrogate = Some(SurrogateOutcome::Smc(SmcOutcome {
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
        }
        Stage::GaBp { runs, .. } => match runs {
            Some(n) => {
                let coded = bayesopt::initial_design(k, *n, run_seed(study.seed, st.index, 0))?;
                st.title = format!("GA-BP network on its own {n}-run Latin hypercube, then GA-BP-GA search for the lab value");
                push_runs(study, st, ctx, &coded, "hypercube");
            }
            None => {
                // Trained on whatever the earlier stages ran: coded over the parameters' whole
                // ranges, where every earlier run lies.
                st.factors = st
                    .active
                    .iter()
                    .map(|&pi| {
                        let p = &study.parameters[pi];
                        p.factor(p.min, p.max)
                    })
                    .collect::<Result<Vec<Factor>, String>>()?;
                st.title = "GA-BP network on the runs of the stages before it, then GA-BP-GA search for the lab value".into();
            }
        },
        _ => unreachable!("surrogate plan of a {} stage", stage.kind()),
    }
    Ok(())
}

fn empty_posterior() -> Posterior {
    Posterior {
        mean: Vec::new(),
        std: Vec::new(),
        credible: Vec::new(),
        ess: f64::NAN,
        sigma: f64::NAN,
    }
}

/// Finished runs with a response: coded point, objective.
fn finished(study: &Study, st: &StageResult) -> (Vec<usize>, Vec<Vec<f64>>, Vec<f64>) {
    let mut idx = Vec::new();
    let mut x = Vec::new();
    let mut y = Vec::new();
    for (i, (s, r)) in st.runs.iter().zip(&st.records).enumerate() {
        if let Some(v) = r
            .as_ref()
            .filter(|r| r.status == crate::store::Status::Done)
            .and_then(|r| r.response)
            .filter(|v| v.is_finite())
        {
            idx.push(i);
            x.push(s.coded.clone());
            y.push(objective(study, v));
        }
    }
    (idx, x, y)
}

/// After a finished round: plans the next one (true), or says the stage is done (false).
pub(crate) fn extend(
    study: &Study,
    stage: &Stage,
    st: &mut StageResult,
    ctx: &Context,
) -> Result<bool, String> {
    match stage {
        Stage::BayesOpt { .. } => extend_bo(study, stage, st, ctx),
        Stage::Smc { .. } => extend_smc(study, stage, st, ctx),
        _ => Ok(false),
    }
}

fn extend_bo(
    study: &Study,
    stage: &Stage,
    st: &mut StageResult,
    ctx: &Context,
) -> Result<bool, String> {
    let opts = bo_options(study, stage, st);
    let (_, x, y) = finished(study, st);
    if x.len() < 2 {
        return Err(format!(
            "{} of {} runs gave a response; a Gaussian process needs at least 2{}",
            x.len(),
            st.runs.len(),
            st.first_failure()
        ));
    }
    let Some(SurrogateOutcome::BayesOpt(mut out)) = st.surrogate.take() else {
        unreachable!("a bayesopt stage without its outcome")
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
        predicted_minimum: proposal.predicted_minimum,
    });
    let stop = if room == 0 {
        Some(format!("budget of {planned} runs spent"))
    } else {
        bayesopt::stop_reason(&opts, &out.history)
    };
    out.gp = Some(proposal.gp.clone());
    if let Some(why) = stop {
        out.stop = Some(why);
        st.surrogate = Some(SurrogateOutcome::BayesOpt(out));
        return Ok(false);
    }
    debug_assert_eq!(proposal.points.len(), q);
    out.rounds.push(proposal.points.len());
    st.surrogate = Some(SurrogateOutcome::BayesOpt(out));
    push_runs(
        study,
        st,
        ctx,
        &proposal.points,
        &format!("round {}", iteration + 1),
    );
    Ok(true)
}

/// A run's misfit for the likelihood: the squared error in units of the lab's spread (the
/// replicates' standard deviation, or the lab value itself when there are fewer than two), the
/// minimised response itself, or for several targets the weighted mean square of their relative
/// errors.
pub fn misfit(study: &Study, y: f64) -> f64 {
    if study.combine == Some(Combine::Weighted) {
        // The weighted mean square of the relative errors, as a sum of squares is.
        (y / 100.0).powi(2)
    } else if study.target.minimised() {
        y
    } else {
        let s = study
            .target
            .std()
            .filter(|s| *s > 0.0)
            .unwrap_or(study.target.value.abs());
        ((y - study.target.value) / s).powi(2)
    }
}

fn extend_smc(
    study: &Study,
    stage: &Stage,
    st: &mut StageResult,
    ctx: &Context,
) -> Result<bool, String> {
    let Stage::Smc {
        iterations,
        ess,
        sigma_tolerance,
        components,
        ..
    } = stage
    else {
        unreachable!()
    };
    let Some(SurrogateOutcome::Smc(mut out)) = st.surrogate.take() else {
        unreachable!("an smc stage without its outcome")
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
        st.surrogate = Some(SurrogateOutcome::Smc(out));
        return Err(format!(
            "{} of {count} runs of iteration {} gave a response; the filter needs at least 2{}",
            used.len(),
            round + 1,
            st.first_failure()
        ));
    }
    let tolerance = sigma_tolerance.unwrap_or(if study.target.minimised() { 0.0 } else { 1.0 });
    let (mut weights, mut sigma) = smc::weigh(
        &samples,
        &density,
        &misfits,
        LikelihoodScale::EssTarget(*ess),
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
        iterations: *iterations,
        scale: LikelihoodScale::EssTarget(*ess),
        sigma_tolerance: tolerance,
        components: *components,
        seed: run_seed(study.seed, st.index, 1 << 40),
    };
    let stop = if out.rounds.len() >= *iterations {
        Some(format!("{iterations} iterations done"))
    } else {
        smc::stop_reason(&opts, &sigmas)
    };
    if let Some(why) = stop {
        out.stop = Some(why);
        st.surrogate = Some(SurrogateOutcome::Smc(out));
        return Ok(false);
    }
    let (next, next_density) = smc::next_samples(
        &samples,
        &weights,
        count,
        *components,
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
    st.surrogate = Some(SurrogateOutcome::Smc(out));
    push_runs(study, st, ctx, &next, &format!("iteration {}", round + 2));
    Ok(true)
}

/// Once every round is done: the calibrated point.
pub(crate) fn conclude(
    study: &Study,
    stage: &Stage,
    st: &mut StageResult,
    ctx: &mut Context,
) -> Result<(), String> {
    let mut point = ctx.values.clone();
    match stage {
        Stage::BayesOpt { .. } => {
            let Some(SurrogateOutcome::BayesOpt(out)) = &st.surrogate else {
                unreachable!()
            };
            let gp = out.gp.as_ref().ok_or("no Gaussian process was fitted")?;
            // With noisy runs the lowest observed objective is partly luck: the calibrated run
            // is the finished one whose GP mean (the smoothed objective) is lowest.
            let (idx, x, y) = finished(study, st);
            let (j, _) = x
                .iter()
                .map(|c| gp.predict(c).0)
                .enumerate()
                .min_by(|a, b| a.1.total_cmp(&b.1))
                .ok_or("no run gave a response")?;
            let i = idx[j];
            point = st.runs[i].values.clone();
            st.notes.push(format!(
                "{}; calibrated at run {} (GP mean of the objective {}, observed {}); the GP's predicted minimum {}",
                out.stop.clone().unwrap_or_default(),
                i + 1,
                sig(gp.predict(&x[j]).0),
                sig(y[j]),
                sig(out.history.last().map_or(f64::NAN, |h| h.predicted_minimum))
            ));
        }
        Stage::Smc { .. } => {
            let Some(SurrogateOutcome::Smc(out)) = &st.surrogate else {
                unreachable!()
            };
            let last = out.rounds.last().ok_or("no iteration")?;
            for (j, &pi) in st.active.iter().enumerate() {
                point[pi] = tidy(last.posterior.mean[j]);
            }
            st.notes.push(format!(
                "{}; calibrated at the posterior mean (scale sigma {}, effective sample size {:.1} of {})",
                out.stop.clone().unwrap_or_default(),
                sig(last.posterior.sigma),
                last.posterior.ess,
                last.used.len()
            ));
        }
        Stage::GaBp {
            runs,
            hidden,
            generations,
            population,
            mutation,
            search_generations,
            search_population,
            train_fraction,
            max_epochs,
        } => {
            let (source, x, y): (String, Vec<Vec<f64>>, Vec<f64>) = if runs.is_some() {
                let ok: Vec<(Vec<f64>, f64)> = st
                    .runs
                    .iter()
                    .zip(&st.records)
                    .filter_map(|(s, r)| {
                        r.as_ref()
                            .filter(|r| r.status == crate::store::Status::Done)
                            .and_then(|r| r.response)
                            .filter(|v| v.is_finite())
                            .map(|v| (s.coded.clone(), v))
                    })
                    .collect();
                (
                    format!("{} runs of its own hypercube", ok.len()),
                    ok.iter().map(|o| o.0.clone()).collect(),
                    ok.iter().map(|o| o.1).collect(),
                )
            } else {
                let x = ctx
                    .finished
                    .iter()
                    .map(|(v, _)| {
                        st.factors
                            .iter()
                            .zip(&st.active)
                            .map(|(f, &pi)| f.to_coded(v[pi]))
                            .collect()
                    })
                    .collect::<Vec<Vec<f64>>>();
                (
                    format!("{} finished runs of the stages before it", x.len()),
                    x,
                    ctx.finished.iter().map(|(_, y)| *y).collect(),
                )
            };
            let k = st.active.len();
            if y.len() < k + 3 {
                return Err(format!(
                    "{source}: a network of {k} inputs needs at least {} to train and test on{}",
                    k + 3,
                    st.first_failure()
                ));
            }
            let seed = run_seed(study.seed, st.index, 1 << 40);
            let trained = network::train(
                &x,
                &y,
                &BpOptions {
                    hidden: *hidden,
                    max_epochs: *max_epochs,
                    train_fraction: *train_fraction,
                    seed,
                    ga: Some(GaOptions {
                        generations: *generations,
                        population: *population,
                        mutation: *mutation,
                        ..GaOptions::weights_default(seed)
                    }),
                    // The average of ten early-stopped networks generalises better than one
                    // (network.rs has the survey on the silage CCD).
                    ensemble: 10,
                    ..BpOptions::default()
                },
            )?;
            let search_opts = GaOptions {
                generations: *search_generations,
                population: *search_population,
                ..GaOptions::search_default(run_seed(study.seed, st.index, 1 << 41))
            };
            let bounds = vec![(-1.0, 1.0); k];
            let search = if study.target.minimised() {
                genetic::minimize(&bounds, |c| trained.network.predict(c), &search_opts)?
            } else {
                network::search_target(&trained.network, &bounds, study.target.value, &search_opts)?
            };
            let predicted = trained.network.predict(&search.best);
            for (j, &pi) in st.active.iter().enumerate() {
                point[pi] = tidy(st.factors[j].to_actual(search.best[j]));
            }
            st.notes.push(format!(
                "network trained on {source}: R^2 training {:.3}, test {:.3}; GA-BP-GA predicts {} {} at the calibrated point",
                trained.metrics_train.r2,
                trained.metrics_test.r2,
                sig(predicted),
                study.target.unit
            ));
            st.surrogate = Some(SurrogateOutcome::GaBp(Box::new(GaBpOutcome {
                source,
                x,
                y,
                trained,
                search,
                predicted,
            })));
        }
        _ => unreachable!("surrogate conclude of a {} stage", stage.kind()),
    }
    ctx.calibrated = Some(point.clone());
    ctx.chosen_solution = 0;
    st.calibrated = Some(point);
    Ok(())
}
