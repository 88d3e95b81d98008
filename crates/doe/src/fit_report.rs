//! The plain-text report of a fit, laid out like Design-Expert's ANOVA, fit-statistics and
//! coefficient panes (what `demcal doe analyze` prints), and the notes saying why a statistic
//! reads "N/A". Tables size their columns from their content ([`TextTable`]), so long factor
//! names keep them aligned.

use std::fmt::Write;

use crate::fit::{fmt_p, fmt_sig, model_title, AnovaRow, Fit, LEVERAGE_ONE};
use crate::text_table::{Align, TextTable};

/// What a statistic that cannot be computed reads as.
pub const NOT_AVAILABLE: &str = "N/A";

impl Fit {
    /// The runs (1-based, in table order) with leverage 1.
    pub fn runs_with_leverage_one(&self) -> Vec<usize> {
        self.leverage
            .iter()
            .enumerate()
            .filter(|(_, h)| **h > LEVERAGE_ONE)
            .map(|(i, _)| i + 1)
            .collect()
    }

    /// C.V. %, or None where it means nothing (a mean response of zero).
    pub fn cv_percent_defined(&self) -> Option<f64> {
        self.cv_percent.is_finite().then_some(self.cv_percent)
    }

    /// One sentence for each fit statistic that reads "N/A", saying why, in the spirit of
    /// Design-Expert's "Case(s) with leverage of 1.0000: Pred R-Squared and PRESS statistic not
    /// defined". Empty when every statistic is defined. For a report's fit-statistics table:
    /// print "N/A" ([`NOT_AVAILABLE`]) for `pred_r2`, `press` and `adeq_precision` when they are
    /// None and for C.V. % when [`Fit::cv_percent_defined`] is None, and these notes under it.
    pub fn not_available_notes(&self) -> Vec<String> {
        let mut notes = Vec::new();
        if self.pred_r2.is_none() || self.press.is_none() {
            let ones: Vec<String> = self
                .runs_with_leverage_one()
                .iter()
                .map(usize::to_string)
                .collect();
            notes.push(if ones.is_empty() {
                "PRESS and Predicted R² are N/A: they are not defined for this model.".to_string()
            } else {
                format!(
                    "PRESS and Predicted R² are N/A: leverage 1.0000 at run(s) {}; the model passes through such a run whatever it measures, so it cannot be predicted from the other runs.",
                    ones.join(", ")
                )
            });
        }
        if self.adeq_precision.is_none() {
            notes.push(
                "Adeq Precision is N/A: the model fits every run exactly, so there is no error variance to compare its predicted range with (the F and p values are blank for the same reason).".into(),
            );
        }
        if self.cv_percent_defined().is_none() {
            notes.push("C.V. % is N/A: the mean response is zero.".into());
        }
        notes
    }

    /// A plain-text report laid out like Design-Expert's ANOVA and fit-statistics panes.
    pub fn report(&self) -> String {
        let mut s = String::new();
        let title = if self.aliased.is_empty() {
            model_title(&self.terms)
        } else {
            "cubic (aliased terms left out)".into()
        };
        writeln!(
            s,
            "ANOVA for {title} model, response {} ({} runs)",
            self.experiment.response_name,
            self.experiment.runs()
        )
        .unwrap();
        if !self.aliased.is_empty() {
            writeln!(s, "Aliased terms left out: {}", self.aliased.join(", ")).unwrap();
        }
        if !self.removed.is_empty() {
            let list: Vec<String> = self
                .removed
                .iter()
                .map(|(n, p)| format!("{n} (p {})", fmt_p(*p)))
                .collect();
            writeln!(s, "Backward elimination removed: {}", list.join(", ")).unwrap();
        }
        writeln!(s, "Partial (type III) sums of squares\n").unwrap();
        s.push_str(&self.anova_table().render());
        writeln!(s).unwrap();
        s.push_str(&self.statistics_table().render());
        for note in self.not_available_notes() {
            writeln!(s, "Note: {note}").unwrap();
        }
        writeln!(s, "\nCoefficients in coded factors").unwrap();
        s.push_str(&self.coefficient_table().render());
        self.equations(&mut s);
        if !self.effects.is_empty() {
            writeln!(s, "\nEffects (two-level runs)").unwrap();
            let mut t = TextTable::new(
                &["Term", "Effect", "t-value", "% Contribution"],
                &[Align::Left, Align::Right, Align::Right, Align::Right],
            );
            for e in &self.effects {
                t.row(vec![
                    e.name.clone(),
                    fmt_sig(e.effect),
                    fmt_sig(e.t),
                    format!("{:.2}", e.contribution_percent),
                ]);
            }
            s.push_str(&t.render());
            if let Some((t, bonf)) = self.pareto_limits(0.05) {
                writeln!(s, "t limit {t:.4}, Bonferroni limit {bonf:.4} (alpha 0.05)").unwrap();
            }
        }
        s
    }

    /// Source, sums of squares, df, mean squares, F and p, and the significance in words.
    fn anova_table(&self) -> TextTable {
        let mut t = TextTable::new(
            &[
                "Source",
                "Sum of Squares",
                "df",
                "Mean Square",
                "F-value",
                "p-value",
                "",
            ],
            &[
                Align::Left,
                Align::Right,
                Align::Right,
                Align::Right,
                Align::Right,
                Align::Right,
                Align::Left,
            ],
        );
        let line = |t: &mut TextTable, r: &AnovaRow, note: &str| {
            t.row(vec![
                r.name.clone(),
                fmt_sig(r.sum_sq),
                r.df.to_string(),
                if r.df > 0 {
                    fmt_sig(r.mean_sq)
                } else {
                    String::new()
                },
                r.f.map_or(String::new(), fmt_sig),
                r.p.map_or(String::new(), fmt_p),
                note.to_string(),
            ])
        };
        let sig = |p: Option<f64>| match p {
            Some(p) if p < 0.05 => "significant",
            Some(_) => "not significant",
            None => "",
        };
        line(&mut t, &self.model, sig(self.model.p));
        for r in &self.anova_terms {
            line(&mut t, r, "");
        }
        if let Some(c) = &self.curvature {
            line(&mut t, c, sig(c.p));
        }
        line(&mut t, &self.residual, "");
        if let Some(l) = &self.lack_of_fit {
            line(&mut t, l, sig(l.p));
        }
        if let Some(pe) = &self.pure_error {
            line(&mut t, pe, "");
        }
        t.row(vec![
            "Cor Total".into(),
            fmt_sig(self.total_sum_sq),
            self.total_df.to_string(),
        ]);
        t
    }

    /// The fit statistics in two pairs of columns, as Design-Expert shows them.
    fn statistics_table(&self) -> TextTable {
        let na = |v: Option<f64>, f: &dyn Fn(f64) -> String| v.map_or(NOT_AVAILABLE.into(), f);
        let four = |v: f64| format!("{v:.4}");
        let mut t = TextTable::headless(&[Align::Left, Align::Right, Align::Left, Align::Right]);
        let rows = [
            ("Std. Dev.", fmt_sig(self.std_dev), "R²", four(self.r2)),
            ("Mean", fmt_sig(self.mean), "Adjusted R²", four(self.adj_r2)),
            (
                "C.V. %",
                na(self.cv_percent_defined(), &|v| format!("{v:.2}")),
                "Predicted R²",
                na(self.pred_r2, &four),
            ),
            (
                "PRESS",
                na(self.press, &fmt_sig),
                "Adeq Precision",
                na(self.adeq_precision, &four),
            ),
        ];
        for (a, va, b, vb) in rows {
            // Two spaces more between the pairs than within them.
            t.row(vec![a.into(), va, format!("  {b}"), vb]);
        }
        t
    }

    fn coefficient_table(&self) -> TextTable {
        let mut t = TextTable::new(
            &[
                "Term",
                "Estimate",
                "df",
                "Std Error",
                "95% CI Low",
                "95% CI High",
                "VIF",
            ],
            &[
                Align::Left,
                Align::Right,
                Align::Right,
                Align::Right,
                Align::Right,
                Align::Right,
                Align::Right,
            ],
        );
        for c in &self.coefficients {
            t.row(vec![
                c.name.clone(),
                fmt_sig(c.estimate),
                "1".into(),
                fmt_sig(c.std_error),
                fmt_sig(c.ci_low),
                fmt_sig(c.ci_high),
                c.vif.map_or(String::new(), |v| format!("{v:.4}")),
            ]);
        }
        t
    }

    /// The final equations in coded factors and, when the ranges are known, in actual units.
    fn equations(&self, s: &mut String) {
        let names = self.term_names();
        writeln!(s, "\nFinal equation in terms of coded factors:").unwrap();
        writeln!(
            s,
            "{} = {}",
            self.experiment.response_name,
            equation(
                self.coefficients
                    .iter()
                    .map(|c| c.estimate)
                    .zip(names.iter().cloned())
            )
        )
        .unwrap();
        if let Some(eq) = self.actual_equation() {
            let vars = self.actual_variable_names();
            writeln!(s, "\nFinal equation in terms of actual factors:").unwrap();
            writeln!(
                s,
                "{} = {}",
                self.experiment.response_name,
                equation(eq.iter().map(|(t, v)| (*v, t.name(&vars))))
            )
            .unwrap();
        }
    }
}

fn equation(parts: impl Iterator<Item = (f64, String)>) -> String {
    let mut s = String::new();
    for (i, (v, name)) in parts.enumerate() {
        let sign = if v < 0.0 { "-" } else { "+" };
        let body = if name == "Intercept" {
            fmt_sig(v.abs())
        } else {
            format!("{} {name}", fmt_sig(v.abs()))
        };
        if i == 0 {
            s.push_str(&format!("{}{body}", if v < 0.0 { "-" } else { "" }));
        } else {
            s.push_str(&format!(" {sign} {body}"));
        }
    }
    s
}
