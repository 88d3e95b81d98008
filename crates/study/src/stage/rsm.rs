//! `rsm`: a response-surface design (central composite or Box-Behnken) over the active
//! parameters and their current region, a quadratic model with its ANOVA, reduced by backward
//! elimination when asked, for `optimize` to search.

use std::any::Any;

use doe::design::{self, CcdAlpha};
use doe::{Curvature, Fit, ModelOrder};

use crate::spec::{Section, Stage};
use crate::stage::table::{StageDef, StageTable};
use crate::design_stages::{
    enough, experiment, plateau_hint, replicates_key, specs_from_design, target_fits,
    with_failures,
};
use crate::paths::number;
use crate::limits::MAX_CENTER_POINTS;
use crate::spec::{Combine, Study};
use crate::record::{Context, StageResult};
use crate::text::sig;

#[derive(Clone, Debug, PartialEq)]
pub enum RsmDesign {
    CentralComposite { alpha: CcdAlpha },
    BoxBehnken,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Rsm {
    pub design: RsmDesign,
    pub center_points: Option<usize>,
    /// Backward elimination of terms with p above `alpha_out`, keeping hierarchy.
    pub reduce: bool,
    pub alpha_out: f64,
    /// Runs at each design point (their mean is modelled).
    pub replicates: usize,
}

impl StageDef for Rsm {
    const NAME: &'static str = "rsm";
    const KEYS: &'static [&'static str] = &[
        "design",
        "alpha",
        "center_points",
        "reduce",
        "alpha_out",
        "replicates",
    ];

    fn parse(t: &StageTable) -> Result<Self, String> {
        let design = match t.text("design", "ccd")?.as_str() {
            "ccd" | "central-composite" => RsmDesign::CentralComposite {
                alpha: ccd_alpha(t.get("alpha")).map_err(|e| t.fail("alpha", e))?,
            },
            "box-behnken" | "bbd" => {
                if t.get("alpha").is_some() {
                    return Err(t.fail("alpha", "a Box-Behnken design has no axial distance"));
                }
                RsmDesign::BoxBehnken
            }
            other => {
                return Err(t.fail(
                    "design",
                    format!("unknown response-surface design \"{other}\" (expected ccd, box-behnken)"),
                ))
            }
        };
        Ok(Rsm {
            design,
            center_points: t.count_opt("center_points", 1, Some(MAX_CENTER_POINTS))?,
            reduce: t.flag("reduce", true)?,
            alpha_out: t.fraction("alpha_out", 0.10)?,
            replicates: replicates_key(t)?,
        })
    }
}

impl Stage for Rsm {
    fn kind(&self) -> &'static str {
        Self::NAME
    }

    fn heading(&self) -> &'static str {
        "response surface"
    }

    fn plan(&self, study: &Study, st: &mut StageResult, ctx: &Context) -> Result<(), String> {
        let k = st.active.len();
        let d = match self.design {
            RsmDesign::CentralComposite { alpha } => {
                let cp = self.center_points.unwrap_or(if k == 2 { 5 } else { 6 });
                design::central_composite(k, alpha, cp, None)
            }
            RsmDesign::BoxBehnken => design::box_behnken(k, self.center_points.unwrap_or(5)),
        };
        let d = match d {
            Ok(d) => d,
            Err(e) => {
                st.notes.push(format!("design: {e}"));
                return Ok(());
            }
        };
        // Axial points must stay inside where the parameters may be set (their ranges, or
        // as far past them as a steepest path went): shift the region, or shrink it, until
        // they do.
        let a = d.alpha.unwrap_or(1.0);
        let mut factors = Vec::new();
        for (j, &pi) in st.active.iter().enumerate() {
            let p = &study.parameters[pi];
            let f = &st.factors[j];
            let (lo, hi) = (p.transformed(f.low), p.transformed(f.high));
            let (min, max) = ctx.limits[pi];
            let (lim_lo, lim_hi) = (p.transformed(min), p.transformed(max));
            let mut h = 0.5 * (hi - lo);
            let mut c = 0.5 * (hi + lo);
            if c - a * h < lim_lo - 1e-12 || c + a * h > lim_hi + 1e-12 {
                let a_text = sig(a);
                h = h.min((lim_hi - lim_lo) / (2.0 * a));
                // When the region fills the whole range the two bounds for the centre meet,
                // and rounding can leave them a hair crossed.
                let (c_lo, c_hi) = (lim_lo + a * h, lim_hi - a * h);
                c = if c_lo <= c_hi {
                    c.clamp(c_lo, c_hi)
                } else {
                    0.5 * (lim_lo + lim_hi)
                };
                st.notes.push(format!(
                    "{}: the design's axial points (coded −{a_text} and +{a_text}) would leave {} .. {}; its coded range −1 to +1 is now {} .. {}",
                    p.name,
                    sig(min),
                    sig(max),
                    sig(p.actual(c - h)),
                    sig(p.actual(c + h))
                ));
            }
            factors.push(p.factor(p.actual(c - h), p.actual(c + h))?);
        }
        st.factors = factors;
        st.title = format!("{}, {} runs", d.kind, d.runs.len());
        if self.replicates > 1 {
            st.title += &format!(", each run {} times", self.replicates);
        }
        specs_from_design(study, st, ctx, &d, self.replicates);
        st.design = Some(d);
        Ok(())
    }

    fn conclude(
        &self,
        study: &Study,
        st: &mut StageResult,
        ctx: &mut Context,
    ) -> Result<(), String> {
        let k = st.active.len();
        let terms = ModelOrder::Quadratic.terms(k);
        enough(
            st,
            terms.len() + 1,
            "a quadratic model with one residual degree of freedom",
        )?;
        crate::design_stages::bracket_note(study, st);
        let exp = experiment(study, st);
        let per_target = st.target_values(study.targets.len());
        let full = match Fit::new(&exp, &terms, Curvature::Off) {
            Ok(f) => f,
            Err(e)
                if study.combine == Some(Combine::Desirability)
                    && per_target.len() == exp.response.len() =>
            {
                // Every run beyond some target's limits scores 1, and a design can sit wholly
                // there; the optimiser models each target's response anyway.
                let fits = target_fits(study, &exp, true, &per_target)?;
                st.notes.push(format!(
                    "the combined undesirability cannot be modelled ({e}); the stage's model is the first target's, and optimize models each target"
                ));
                let first = fits[0].clone();
                ctx.model = Some((first.clone(), st.active.clone()));
                ctx.model_targets = per_target;
                ctx.model_quadratic = true;
                st.full_fit = Some(first.clone());
                st.fit = Some(first);
                return Ok(());
            }
            Err(e) => return Err(plateau_hint(study, with_failures(st, e))),
        };
        let fit = if self.reduce {
            Fit::reduce(&exp, &terms, Curvature::Off, self.alpha_out, true)
                .map_err(|e| with_failures(st, e))?
        } else {
            full.clone()
        };
        if !fit.removed.is_empty() {
            st.notes.push(format!(
                "backward elimination (alpha out {}) removed {}",
                self.alpha_out,
                fit.removed
                    .iter()
                    .map(|(n, p)| format!("{n} (p {})", doe::fit::fmt_p(*p)))
                    .collect::<Vec<_>>()
                    .join(", ")
            ));
        }
        ctx.model = Some((fit.clone(), st.active.clone()));
        ctx.model_targets = per_target;
        ctx.model_quadratic = true;
        st.full_fit = Some(full);
        st.fit = Some(fit);
        Ok(())
    }

    fn report(&self, s: &mut Section<'_>) {
        crate::report_model::rsm(s.h, s.figs, s.study, s.stages, s.st);
    }

    fn as_any(&self) -> &dyn Any {
        self
    }
}

/// The axial distance of a CCD: `rotatable`, `face`, `spherical`, `orthogonal`, or a positive
/// number (written as a number or as text).
fn ccd_alpha(v: Option<&toml::Value>) -> Result<CcdAlpha, String> {
    const EXPECTED: &str =
        "expected rotatable, face, spherical, orthogonal or a positive number up to 100";
    let positive = |a: f64| {
        (a.is_finite() && a > 0.0 && a <= design::MAX_ALPHA)
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
                Ok(a) if a.is_finite() && a > 0.0 && a <= design::MAX_ALPHA => {
                    Ok(CcdAlpha::Custom(a))
                }
                _ => Err(format!("\"{s}\": {EXPECTED}")),
            },
        },
        Some(v) => match number(v) {
            Some(a) => positive(a),
            None => Err(format!("{v}: {EXPECTED}")),
        },
    }
}
