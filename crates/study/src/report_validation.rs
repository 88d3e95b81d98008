//! The validation stage's section of the report: the runs' mean and spread against the lab's,
//! the model's prediction interval at the optimum, its figure, and the validation heaps.

use std::fmt::Write;
use std::path::Path;

use base64::Engine;

use crate::record::StageResult;
use crate::report_figures::{self as figures, mean_sd, Heap};
use crate::report_model;
use crate::spec::Study;
use crate::text::{esc, sig, FigureSink};

/// The validation: the runs' mean and spread against the lab's, the model's prediction
/// interval at the optimum, the figure, and the heaps.
pub(crate) fn validation_html(
    h: &mut String,
    figs: &mut dyn FigureSink,
    study: &Study,
    stages: &[StageResult],
    st: &StageResult,
) {
    let t = &study.target;
    let unit = if t.unit.is_empty() {
        String::new()
    } else {
        format!(" {}", t.unit)
    };
    if let Some(v) = st.validation() {
        let sim = match v.std {
            Some(sd) => format!(
                "<b>{}{unit}</b> (mean ± SD over {} runs)",
                mean_sd(v.mean, sd),
                v.runs
            ),
            None => format!("<b>{}{unit}</b> ({} run)", sig(v.mean), v.runs),
        };
        let lab = match t.std() {
            Some(sd) => format!(
                "{}{unit} (mean ± SD over {} replicates)",
                mean_sd(t.value, sd),
                t.replicates.len()
            ),
            None => format!("{}{unit}", sig(t.value)),
        };
        write!(
            h,
            "<p>Simulated {} = {sim}{}.</p>",
            esc(&t.response),
            match v.relative_error_percent {
                Some(e) => format!(" against the lab's {lab}: relative error <b>{e:.2} %</b>"),
                None if study.combine.is_some() => {
                    " (0 would match every target; the targets' own validation is in the summary)"
                        .into()
                }
                None => " (minimised: 0 would be the lab curve itself)".into(),
            }
        )
        .unwrap();
        if let Some(words) = crate::uncertainty_report::validation_words(v, t) {
            write!(h, "<p><b>Validation interval:</b> {}.</p>", esc(&words)).unwrap();
        }
    }
    let interval = (study.combine.is_none())
        .then(|| report_model::interval_at_optimum(stages))
        .flatten();
    if let Some((pi, _)) = &interval {
        let ys: Vec<f64> = st.validation_successes().iter().map(|(_, y)| *y).collect();
        let inside = ys
            .iter()
            .filter(|y| **y >= pi.low && **y <= pi.high)
            .count();
        write!(
            h,
            "<p>The model of the response surface predicted {}{unit} at the optimum, with a 95 % prediction interval for one new run of {} to {}{unit}: {inside} of the {} validation runs fall inside it.</p>",
            sig(if t.minimised() { pi.predicted.max(0.0) } else { pi.predicted }),
            // A minimised response (a curve MSE) is never negative: the interval starts at 0.
            sig(if t.minimised() { pi.low.max(0.0) } else { pi.low }),
            sig(pi.high),
            ys.len()
        )
        .unwrap();
    }
    if study.combine.is_none() {
        figs.row(
            h,
            vec![(
                format!("stage{}-validation", st.index + 1),
                figures::validation_plot(study, st, interval.map(|i| i.0)),
                format!(
                    "Validation (stage {}): {} of each lab replicate and each validation run at the calibrated point (a run's whisker: the standard deviation over the flanks it measured), each column's mean with one standard deviation{}.",
                    st.index + 1,
                    esc(&figures::response_label(study)),
                    if interval.is_some() { ", and the model's prediction at the optimum with its 95 % prediction interval" } else { "" }
                ),
            )],
        );
    }
    heap_pictures(h, figs, study, st);
}

/// The validation heaps: one figure at one scale when the runs wrote `heap.json`, else the
/// pictures as they are (runs from an older demcal).
fn heap_pictures(h: &mut String, figs: &mut dyn FigureSink, study: &Study, st: &StageResult) {
    let mut heaps = Vec::new();
    let mut plain = Vec::new();
    for (spec, rec) in st.runs.iter().zip(&st.records) {
        let Some(r) = rec else { continue };
        let spread = figures::flank_spread(&r.outputs);
        let label = format!(
            "Run {}: {}{}",
            spec.index + 1,
            r.response.map(sig).unwrap_or_else(|| "failed".into()),
            match spread {
                Some((sd, n)) => format!(
                    " {}, flank SD {} {} over {n} flanks",
                    study.target.unit,
                    sig(sd),
                    study.target.unit
                ),
                None => format!(" {}", study.target.unit),
            }
        );
        match Heap::read(study, &r.out_dir, label.clone()) {
            Some(heap) => heaps.push(heap),
            None => {
                let run = Path::new(&r.out_dir);
                let mut dirs = std::iter::once(run.to_path_buf())
                    .chain(study.tests.iter().map(|t| run.join(&t.name)));
                if let Some(bytes) = dirs.find_map(|d| std::fs::read(d.join("heap.png")).ok()) {
                    plain.push(format!(
                        "<figure><img alt=\"heap of run {}\" src=\"data:image/png;base64,{}\"><figcaption>{}</figcaption></figure>",
                        spec.index + 1,
                        base64::engine::general_purpose::STANDARD.encode(bytes),
                        esc(&label)
                    ));
                }
            }
        }
    }
    if heaps.is_empty() && plain.is_empty() {
        return;
    }
    h.push_str("<h3>Heaps</h3>");
    if !heaps.is_empty() {
        figs.row(
            h,
            vec![(
                format!("stage{}-heaps", st.index + 1),
                figures::heaps_figure(&heaps),
                format!(
                    "Validation heaps (stage {}): side views of each run's heap, cropped to one frame around the axis at one scale (scale bar), with the two flank lines fitted in the vertical plane across the view; the reported angle is the mean over every plane's flanks.",
                    st.index + 1
                ),
            )],
        );
    }
    if !plain.is_empty() {
        h.push_str("<p class=\"note\">These runs were made by an older demcal that did not record the pictures' scale: shown as they are, without scale bar or flank lines.</p><div class=\"plots\">");
        for f in plain {
            h.push_str(&f);
        }
        h.push_str("</div>");
    }
}
