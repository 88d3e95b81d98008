//! `screening`: a two-level design (Plackett-Burman, fractional or full factorial) over every
//! active parameter, a first-order model with its ANOVA, and the parameters whose effects are
//! significant go on; the others are held at the middle of their ranges.

use std::any::Any;
use std::fmt::Write;

use doe::design;
use doe::{Curvature, Fit, ModelOrder};

use crate::spec::{Section, Stage};
use crate::stage::table::{StageDef, StageTable};
use crate::design_stages::{
    enough, experiment, plateau_hint, replicates_key, specs_from_design, with_failures,
};
use crate::limits::MAX_CENTER_POINTS;
use crate::text::esc;
use crate::spec::Study;
use crate::record::{Context, ScreeningOutcome, StageResult};

#[derive(Clone, Debug, PartialEq)]
pub enum ScreeningDesign {
    PlackettBurman { runs: Option<usize> },
    Fractional { resolution: usize },
    Factorial,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Screening {
    pub design: ScreeningDesign,
    pub center_points: usize,
    /// Significance level for a factor to go on.
    pub alpha: f64,
    pub min_factors: usize,
    pub max_factors: usize,
    /// Runs at each design point (their mean is modelled, as seed 001 repeats each run 3 times).
    pub replicates: usize,
}

impl StageDef for Screening {
    const NAME: &'static str = "screening";
    const KEYS: &'static [&'static str] = &[
        "design",
        "runs",
        "resolution",
        "center_points",
        "alpha",
        "min_factors",
        "max_factors",
        "replicates",
    ];

    fn parse(t: &StageTable) -> Result<Self, String> {
        let n_params = t.params.len();
        if n_params < 2 {
            return Err(t.fail("", "screening needs at least two parameters"));
        }
        let design = match t.text("design", "plackett-burman")?.as_str() {
            "plackett-burman" | "pb" => ScreeningDesign::PlackettBurman {
                runs: t.count_opt("runs", 4, Some(design::MAX_PB_RUNS))?,
            },
            "fractional" | "fractional-factorial" => ScreeningDesign::Fractional {
                resolution: t.count("resolution", 4, 3, None)?,
            },
            "factorial" | "full-factorial" => ScreeningDesign::Factorial,
            other => {
                return Err(t.fail(
                    "design",
                    format!("unknown screening design \"{other}\" (expected plackett-burman, fractional, factorial)"),
                ))
            }
        };
        if t.get("runs").is_some() && !matches!(design, ScreeningDesign::PlackettBurman { .. }) {
            return Err(t.fail(
                "runs",
                "only a plackett-burman design takes runs (a fractional design's size follows from its resolution, a factorial's from the parameters)",
            ));
        }
        // The design is made now, over every parameter, so that a size it cannot have (a
        // Plackett-Burman of 7 runs) is refused when the file is read, not when the stage starts.
        let (made, key) = match design {
            ScreeningDesign::PlackettBurman { runs } => {
                (design::plackett_burman(n_params, runs, 0), "runs")
            }
            ScreeningDesign::Fractional { resolution } => (
                design::fractional_factorial_by_resolution(n_params, resolution),
                "resolution",
            ),
            ScreeningDesign::Factorial => (design::full_factorial(n_params), "design"),
        };
        made.map_err(|e| t.fail(key, e))?;
        let min_factors = t.count("min_factors", 2.min(n_params), 1, None)?;
        let max_factors = t.count("max_factors", 4.min(n_params), 1, None)?;
        if min_factors > max_factors {
            return Err(t.fail(
                "min_factors",
                format!("expected min_factors <= max_factors ({max_factors})"),
            ));
        }
        Ok(Screening {
            design,
            center_points: t.count("center_points", 1, 0, Some(MAX_CENTER_POINTS))?,
            alpha: t.fraction("alpha", 0.05)?,
            min_factors,
            max_factors,
            replicates: replicates_key(t)?,
        })
    }
}

impl Stage for Screening {
    fn kind(&self) -> &'static str {
        Self::NAME
    }

    fn heading(&self) -> &'static str {
        "screening"
    }

    fn plan(&self, study: &Study, st: &mut StageResult, ctx: &Context) -> Result<(), String> {
        let k = st.active.len();
        let d = match self.design {
            ScreeningDesign::PlackettBurman { runs } => design::plackett_burman(k, runs, 0),
            ScreeningDesign::Fractional { resolution } => {
                design::fractional_factorial_by_resolution(k, resolution)
            }
            ScreeningDesign::Factorial => design::full_factorial(k),
        };
        match d {
            Ok(d) => {
                let d = d.with_center_points(self.center_points);
                st.title = format!("{}, {} centre point(s)", d.kind, self.center_points);
                if self.replicates > 1 {
                    st.title += &format!(", each point run {} times", self.replicates);
                }
                specs_from_design(study, st, ctx, &d, self.replicates);
                st.design = Some(d);
            }
            Err(e) => st.notes.push(format!("design: {e}")),
        }
        Ok(())
    }

    fn conclude(
        &self,
        study: &Study,
        st: &mut StageResult,
        ctx: &mut Context,
    ) -> Result<(), String> {
        let k = st.active.len();
        let terms = ModelOrder::Linear.terms(k);
        enough(
            st,
            terms.len() + 1,
            "a first-order model with one residual degree of freedom",
        )?;
        let fit = Fit::new(&experiment(study, st), &terms, Curvature::Auto)
            .map_err(|e| plateau_hint(study, with_failures(st, e)))?;
        crate::design_stages::bracket_note(study, st);
        // p and coefficient of each main effect, in factor order.
        let main = |j: usize| {
            fit.terms
                .iter()
                .position(|t| t.powers[j] == 1 && t.order() == 1)
        };
        let p: Vec<f64> = (0..k)
            .map(|j| {
                main(j)
                    .filter(|&i| i > 0)
                    .and_then(|i| fit.anova_terms.get(i - 1))
                    .and_then(|r| r.p)
                    .unwrap_or(1.0)
            })
            .collect();
        let coef: Vec<f64> = (0..k)
            .map(|j| main(j).map_or(0.0, |i| fit.coefficients[i].estimate))
            .collect();
        let mut order: Vec<usize> = (0..k).collect();
        order.sort_by(|&a, &b| {
            p[a].total_cmp(&p[b])
                .then(coef[b].abs().total_cmp(&coef[a].abs()))
        });
        let significant: Vec<usize> = order.iter().copied().filter(|&j| p[j] < self.alpha).collect();
        let mut chosen: Vec<usize> = significant.clone();
        if chosen.len() < self.min_factors {
            chosen = order[..self.min_factors.min(k)].to_vec();
            st.notes.push(format!(
                "{} parameter(s) significant at p < {}; the {} with the smallest p go on",
                significant.len(),
                self.alpha,
                chosen.len()
            ));
        }
        if chosen.len() > self.max_factors {
            chosen.truncate(self.max_factors);
            st.notes.push(format!(
                "{} parameters significant at p < {}; the {} with the smallest p go on (max_factors)",
                significant.len(),
                self.alpha,
                self.max_factors
            ));
        }
        chosen.sort_unstable();
        let selected: Vec<usize> = chosen.iter().map(|&j| st.active[j]).collect();
        for (j, &pi) in st.active.iter().enumerate() {
            if !chosen.contains(&j) {
                // Held at the middle of its range, as the published studies do.
                let p = &study.parameters[pi];
                let (lo, hi) = ctx.region[pi];
                ctx.values[pi] = p.actual(0.5 * (p.transformed(lo) + p.transformed(hi)));
            }
        }
        ctx.direction = chosen.iter().map(|&j| coef[j]).collect();
        ctx.model = Some((fit.clone(), st.active.clone()));
        ctx.model_targets = st.target_values(study.targets.len());
        ctx.model_quadratic = false;
        ctx.active = selected.clone();
        st.set_outcome(ScreeningOutcome { selected });
        st.fit = Some(fit);
        Ok(())
    }

    fn report(&self, s: &mut Section<'_>) {
        let Some(fit) = &s.st.fit else { return };
        crate::report_model::screening(s.h, s.figs, s.study, s.st, fit);
        if !s.st.selected().is_empty() {
            write!(
                s.h,
                "<p>Going on to the next stages: <b>{}</b>. The others are held at the middle of their ranges.</p>",
                s.st.selected()
                    .iter()
                    .map(|&i| esc(&s.study.parameters[i].name))
                    .collect::<Vec<_>>()
                    .join(", ")
            )
            .unwrap();
        }
    }

    fn as_any(&self) -> &dyn Any {
        self
    }
}
