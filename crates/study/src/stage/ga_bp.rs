//! `ga_bp`: a GA-BP network (a back-propagation network whose first weights a genetic
//! algorithm chose, seed 002's MATLAB recipe) trained on runs (its own Latin hypercube of `runs`,
//! or every finished run of the stages before it), then GA-BP-GA: a genetic search of the
//! network for the lab value.

use std::any::Any;
use std::sync::Arc;

use doe::Factor;
use surrogate::bayesopt;
use surrogate::genetic::{self, GaOptions};
use surrogate::network::{self, BpOptions};

use crate::spec::{Section, Stage};
use crate::stage::table::{StageDef, StageTable};
use crate::limits::{MAX_GA, MAX_GA_EVALUATIONS, MAX_SURROGATE_RUNS};
use crate::spec::Study;
use crate::record::{Context, run_seed, StageResult};
use crate::text::{sig, tidy};
use crate::surrogate_stages::{calibrate, push_runs, GaBpOutcome, SurrogateOutcome};

#[derive(Clone, Debug, PartialEq)]
pub struct GaBp {
    pub runs: Option<usize>,
    pub hidden: Option<usize>,
    pub generations: usize,
    pub population: usize,
    pub mutation: f64,
    pub search_generations: usize,
    pub search_population: usize,
    pub train_fraction: f64,
    pub max_epochs: usize,
    /// Without runs of its own: the stages whose runs it trains on, by name or number (1 = the
    /// plan's first), or every stage before it when empty. Seed 001 trains on the CCD's runs
    /// only.
    pub train_on: Vec<String>,
}

impl StageDef for GaBp {
    const NAME: &'static str = "ga_bp";
    const KEYS: &'static [&'static str] = &[
        "runs",
        "hidden",
        "generations",
        "population",
        "mutation",
        "search_generations",
        "search_population",
        "train_fraction",
        "max_epochs",
        "train_on",
    ];

    fn parse(t: &StageTable) -> Result<Self, String> {
        // Stage numbers (1 = the plan's first) or stage names, checked against the plan in
        // `follows`.
        let mut train_on = Vec::new();
        if let Some(v) = t.get("train_on") {
            let expected = "expected a list of stages before it, by name or number (1 = the plan's first), e.g. [\"rsm\"] or [3]";
            let items = v.as_array().filter(|a| !a.is_empty()).ok_or_else(|| t.fail("train_on", expected))?;
            for item in items {
                train_on.push(match item {
                    toml::Value::String(s) => s.clone(),
                    toml::Value::Integer(n) if *n >= 1 => n.to_string(),
                    _ => return Err(t.fail("train_on", expected)),
                });
            }
            if t.get("runs").is_some() {
                return Err(t.fail("train_on", "a ga_bp stage with runs = N trains on its own hypercube; leave out runs or train_on"));
            }
        }
        let stage = GaBp {
            train_on,
            runs: t.count_opt("runs", 5, Some(MAX_SURROGATE_RUNS))?,
            hidden: t.count_opt("hidden", 1, Some(1000))?,
            generations: t.count("generations", 200, 1, Some(MAX_GA))?,
            population: t.count("population", 100, 4, Some(MAX_GA))?,
            mutation: t.fraction("mutation", 0.2)?,
            search_generations: t.count("search_generations", 100, 1, Some(MAX_GA))?,
            search_population: t.count("search_population", 100, 4, Some(MAX_GA))?,
            train_fraction: t.fraction("train_fraction", 0.8)?,
            max_epochs: t.count("max_epochs", 1000, 1, Some(MAX_GA))?,
        };
        // Each key alone may be large, not both: generations = population = 100 000 is 1e10
        // evaluations, which ran silent for longer than anyone would wait.
        for (g, p) in [
            ("generations", "population"),
            ("search_generations", "search_population"),
        ] {
            let (ng, np) = match g {
                "generations" => (stage.generations, stage.population),
                _ => (stage.search_generations, stage.search_population),
            };
            if ng.saturating_mul(np) > MAX_GA_EVALUATIONS {
                return Err(t.fail(
                    p,
                    format!("{g} × {p} = {ng} × {np} evaluations, at most {MAX_GA_EVALUATIONS}"),
                ));
            }
        }
        Ok(stage)
    }
}

impl Stage for GaBp {
    fn kind(&self) -> &'static str {
        Self::NAME
    }

    fn heading(&self) -> &'static str {
        "GA-BP network and GA-BP-GA search"
    }

    fn runs_simulations(&self) -> bool {
        self.runs.is_some()
    }

    fn follows(&self, before: &[Arc<dyn Stage>]) -> Result<(), String> {
        for item in &self.train_on {
            let found = match item.parse::<usize>() {
                Ok(n) => n >= 1 && n <= before.len(),
                Err(_) => before.iter().any(|s| s.kind() == item),
            };
            if !found {
                return Err(format!(
                    "train_on: \"{item}\" is not a stage before it (the stages before it: {})",
                    before
                        .iter()
                        .enumerate()
                        .map(|(i, s)| format!("{} {}", i + 1, s.kind()))
                        .collect::<Vec<_>>()
                        .join(", ")
                ));
            }
        }
        if self.runs.is_none() && !before.iter().any(|s| s.runs_simulations()) {
            return Err("ga_bp without runs = N trains on the runs of the stages before it, and none runs simulations; give runs = N for its own Latin hypercube, or put a design stage first".into());
        }
        Ok(())
    }

    fn plan(&self, study: &Study, st: &mut StageResult, ctx: &Context) -> Result<(), String> {
        let k = st.active.len();
        match self.runs {
            Some(n) => {
                let coded = bayesopt::initial_design(k, n, run_seed(study.seed, st.index, 0))?;
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
                st.title = format!(
                    "GA-BP network on the runs of {}, then GA-BP-GA search for the lab value",
                    if self.train_on.is_empty() {
                        "the stages before it".to_string()
                    } else {
                        format!("stage(s) {}", self.train_on.join(", "))
                    }
                );
            }
        }
        Ok(())
    }

    fn conclude(
        &self,
        study: &Study,
        st: &mut StageResult,
        ctx: &mut Context,
    ) -> Result<(), String> {
        let (source, x, y): (String, Vec<Vec<f64>>, Vec<f64>) = if self.runs.is_some() {
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
            let wanted = |stage: usize| {
                self.train_on.is_empty()
                    || self.train_on.iter().any(|w| match w.parse::<usize>() {
                        Ok(n) => n == stage + 1,
                        Err(_) => study.plan.get(stage).is_some_and(|s| s.kind() == w),
                    })
            };
            let rows: Vec<&(usize, Vec<f64>, f64)> =
                ctx.finished.iter().filter(|r| wanted(r.0)).collect();
            let x = rows
                .iter()
                .map(|(_, v, _)| {
                    st.factors
                        .iter()
                        .zip(&st.active)
                        .map(|(f, &pi)| f.to_coded(v[pi]))
                        .collect()
                })
                .collect::<Vec<Vec<f64>>>();
            let from = if self.train_on.is_empty() {
                "the stages before it".to_string()
            } else {
                format!("stage(s) {}", self.train_on.join(", "))
            };
            (
                format!("{} finished runs of {from}", x.len()),
                x,
                rows.iter().map(|r| r.2).collect(),
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
                hidden: self.hidden,
                max_epochs: self.max_epochs,
                train_fraction: self.train_fraction,
                seed,
                ga: Some(GaOptions {
                    generations: self.generations,
                    population: self.population,
                    mutation: self.mutation,
                    ..GaOptions::weights_default(seed)
                }),
                // The average of ten early-stopped networks generalises better than one
                // (network.rs has the survey on the silage CCD).
                ensemble: 10,
                ..BpOptions::default()
            },
        )?;
        let search_opts = GaOptions {
            generations: self.search_generations,
            population: self.search_population,
            ..GaOptions::search_default(run_seed(study.seed, st.index, 1 << 41))
        };
        let bounds = vec![(-1.0, 1.0); k];
        let search = if study.target.minimised() {
            genetic::minimize(&bounds, |c| trained.network.predict(c), &search_opts)?
        } else {
            network::search_target(&trained.network, &bounds, study.target.value, &search_opts)?
        };
        let predicted = study.target.predicted(trained.network.predict(&search.best));
        let mut point = ctx.values.clone();
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
        st.uncertainty = Some(crate::uncertainty_routes::from_network(
            study,
            st,
            &trained.network,
            search.best.clone(),
        ));
        st.set_outcome(SurrogateOutcome::GaBp(Box::new(GaBpOutcome {
            source,
            x,
            y,
            trained,
            search,
            predicted,
        })));
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
