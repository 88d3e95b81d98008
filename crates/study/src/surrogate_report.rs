//! Report sections and summary entries of the surrogate stages: BO convergence and the GP's
//! predicted objective over pairs of factors; the network's regression plots, metrics and GA
//! convergence; the SMC posterior's marginals and pairs with the calibrated point and credible
//! intervals. (The validation runs against the lab value are the validate stage's section.)

use std::fmt::Write;

use doe::plots::{self, padded, FONT};

use crate::report_figures::drawn_pairs;
use plotters::prelude::*;
use serde_json::json;

use crate::record::StageResult;
use crate::spec::Study;
use crate::surrogate_stages::{BoOutcome, GaBpOutcome, SmcOutcome, SurrogateOutcome};
use crate::text::sig;
use crate::text::FigureSink;

const BLUE: RGBColor = RGBColor(40, 100, 200);
const ORANGE: RGBColor = RGBColor(230, 120, 20);
const GREEN: RGBColor = RGBColor(30, 150, 60);
const RED_LINE: RGBColor = RGBColor(200, 30, 30);

/// What a surrogate stage adds to its entry in `summary.json`.
pub fn stage_json(study: &Study, st: &StageResult) -> Option<(&'static str, serde_json::Value)> {
    let names = |st: &StageResult| -> Vec<String> {
        st.active
            .iter()
            .map(|&i| study.parameters[i].name.clone())
            .collect()
    };
    match st.surrogate()? {
        SurrogateOutcome::BayesOpt(o) => Some((
            "bayesopt",
            json!({
                "rounds": o.rounds,
                "history": o.history,
                "stop": o.stop,
                "gp": o.gp.as_ref().map(|g| json!({
                    "kernel": g.kernel().name(),
                    "length_scales": names(st).iter().zip(g.length_scales()).map(|(n, l)| (n.clone(), json!(l))).collect::<serde_json::Map<_, _>>(),
                    "signal_variance": g.signal_variance(),
                    "noise_variance": g.noise_variance(),
                })),
            }),
        )),
        SurrogateOutcome::GaBp(o) => Some((
            "network",
            json!({
                "source": o.source,
                "rows": o.y.len(),
                "hidden": o.trained.network.hidden(),
                "epochs": o.trained.epochs,
                "r2_train": o.trained.metrics_train.r2,
                "r2_validation": o.trained.metrics_validation.r2,
                "r2_test": o.trained.metrics_test.r2,
                "r2_all": o.trained.metrics_all.r2,
                "rmse_train": o.trained.metrics_train.rmse,
                "rmse_test": o.trained.metrics_test.rmse,
                "rmse_all": o.trained.metrics_all.rmse,
                "mae_train": o.trained.metrics_train.mae,
                "mae_test": o.trained.metrics_test.mae,
                "mae_all": o.trained.metrics_all.mae,
                "ga_generations": o.trained.ga_history.len(),
                "search_generations": o.search.history.len(),
                "predicted": o.predicted,
            }),
        )),
        SurrogateOutcome::Smc(o) => {
            let last = o.rounds.iter().rev().find(|r| !r.weights.is_empty())?;
            let p = &last.posterior;
            Some((
                "posterior",
                json!(names(st)
                    .iter()
                    .enumerate()
                    .map(|(j, n)| (
                        n.clone(),
                        json!({
                            "mean": p.mean[j],
                            "std": p.std[j],
                            "credible_low": p.credible[j].0,
                            "credible_high": p.credible[j].1,
                        })
                    ))
                    .chain([
                        ("iterations".to_string(), json!(o.rounds.len())),
                        ("sigma".to_string(), json!(p.sigma)),
                        ("effective_sample_size".to_string(), json!(p.ess)),
                        ("stop".to_string(), json!(o.stop)),
                    ])
                    .collect::<serde_json::Map<_, _>>()),
            ))
        }
    }
}

/// A row of the stage's figures, each with its caption.
fn plots_row(
    h: &mut String,
    figs: &mut dyn FigureSink,
    st: &StageResult,
    svgs: Vec<(String, String)>,
) {
    let stage = st.index + 1;
    let items = svgs
        .into_iter()
        .enumerate()
        .map(|(i, (svg, caption))| {
            (
                format!("stage{stage}-{}-{}", st.kind.replace('_', "-"), i + 1),
                Ok(svg),
                format!("Stage {stage} ({}): {caption}", st.kind),
            )
        })
        .collect();
    figs.row(h, items);
}

/// The stage's own section of the report, after its runs table.
pub(crate) fn stage_html(
    h: &mut String,
    figs: &mut dyn FigureSink,
    study: &Study,
    st: &StageResult,
) {
    match st.surrogate() {
        Some(SurrogateOutcome::BayesOpt(o)) => bo_html(h, figs, study, st, o),
        Some(SurrogateOutcome::GaBp(o)) => ga_bp_html(h, figs, study, st, o),
        Some(SurrogateOutcome::Smc(o)) => smc_html(h, figs, study, st, o),
        None => {}
    }
}

fn objective_name(study: &Study) -> String {
    if study.target.minimised() {
        study.target.response.clone()
    } else {
        format!("|{} - lab| / lab", study.target.response)
    }
}

fn bo_html(
    h: &mut String,
    figs: &mut dyn FigureSink,
    study: &Study,
    st: &StageResult,
    o: &BoOutcome,
) {
    if let Some(g) = &o.gp {
        write!(
            h,
            "<p>Objective: {}. GP ({} kernel) length scales (coded units): {}; noise variance {}, signal variance {}.</p>",
            objective_name(study),
            g.kernel().name(),
            st.factors
                .iter()
                .zip(g.length_scales())
                .map(|(f, l)| format!("{} {}", f.name, sig(*l)))
                .collect::<Vec<_>>()
                .join(", "),
            sig(g.noise_variance()),
            sig(g.signal_variance())
        )
        .unwrap();
    }
    let mut row = Vec::new();
    if let Ok(svg) = convergence_plot(
        "Bayesian optimisation: convergence",
        "round (0 = hypercube)",
        &objective_name(study),
        &[
            (
                "best observed",
                BLUE,
                o.history
                    .iter()
                    .map(|s| (s.iteration as f64, s.best_observed))
                    .collect(),
            ),
            (
                "GP predicted minimum",
                ORANGE,
                o.history
                    .iter()
                    .map(|s| (s.iteration as f64, s.predicted_minimum))
                    .collect(),
            ),
        ],
    ) {
        row.push((svg, format!(
            "convergence of the Bayesian optimisation: after each round (0 = the Latin hypercube), the lowest objective ({}) observed so far and the minimum the GP fitted to the runs then predicted.",
            objective_name(study)
        )));
    }
    if let Some(g) = &o.gp {
        // The calibrated point in the stage's coded units: where the other factors are held.
        let centre: Vec<f64> = st
            .calibrated
            .as_ref()
            .map(|v| {
                st.factors
                    .iter()
                    .zip(&st.active)
                    .map(|(f, &pi)| f.to_coded(v[pi]))
                    .collect()
            })
            .unwrap_or_else(|| vec![0.0; st.factors.len()]);
        let k = st.factors.len();
        let points: Vec<Vec<f64>> = st
            .runs
            .iter()
            .zip(&st.records)
            .filter(|(_, r)| r.is_some())
            .map(|(s, _)| s.coded.clone())
            .collect();
        for (a, b) in drawn_pairs(h, k) {
            let f = |x: f64, y: f64| {
                let mut c = centre.clone();
                c[a] = x;
                c[b] = y;
                // Every objective (a relative error, a curve MSE, an undesirability) is >= 0; a
                // GP mean that dips below 0 between runs is shown at 0, as the stages read it.
                g.predict_mean(&c).max(0.0)
            };
            if let Ok(svg) = heat_map(
                (&st.factors[a], &st.factors[b]),
                &format!("GP predicted {}", objective_name(study)),
                f,
                &points.iter().map(|p| (p[a], p[b])).collect::<Vec<_>>(),
                Some((centre[a], centre[b])),
            ) {
                row.push((svg, format!(
                    "the GP's predicted objective ({}) over {} and {}, the other parameters held at their calibrated values; dots are the runs, the white ring the calibrated run.",
                    objective_name(study),
                    st.factors[a].name,
                    st.factors[b].name
                )));
            }
        }
    }
    plots_row(h, figs, st, row);
}

fn ga_bp_html(
    h: &mut String,
    figs: &mut dyn FigureSink,
    study: &Study,
    st: &StageResult,
    o: &GaBpOutcome,
) {
    let t = &o.trained;
    write!(
        h,
        "<p>Network {}-{}-1 (tansig hidden layer, linear output, inputs and output mapped to [-1, 1]), trained on {} by Levenberg-Marquardt with early stopping on the validation rows ({} epochs) from the weights a genetic algorithm chose ({} generations); the prediction averages the ensemble's networks. GA-BP-GA predicts <b>{} {}</b> at the calibrated point (lab {}).</p>",
        t.network.inputs(),
        t.network.hidden(),
        o.source,
        t.epochs,
        t.ga_history.len(),
        sig(o.predicted),
        study.target.unit,
        sig(study.target.value)
    )
    .unwrap();
    h.push_str("<table><tr><th>rows</th><th>n</th><th>R^2</th><th>RMSE</th><th>MAE</th></tr>");
    for (name, m) in [
        ("training", &t.metrics_train),
        ("validation", &t.metrics_validation),
        ("test", &t.metrics_test),
        ("all", &t.metrics_all),
    ] {
        write!(
            h,
            "<tr><td>{name}</td><td>{}</td><td>{:.4}</td><td>{}</td><td>{}</td></tr>",
            m.n,
            m.r2,
            sig(m.rmse),
            sig(m.mae)
        )
        .unwrap();
    }
    h.push_str("</table>");
    let mut row = Vec::new();
    for (name, rows, m) in [
        ("training", &t.train, &t.metrics_train),
        ("validation", &t.validation, &t.metrics_validation),
        ("test", &t.test, &t.metrics_test),
    ] {
        let pts: Vec<(f64, f64)> = rows.iter().map(|&i| (o.y[i], t.predictions[i])).collect();
        if let Ok(svg) = regression_plot(
            &format!("Network, {name} rows: R^2 {:.3}", m.r2),
            &study.target.response,
            &pts,
        ) {
            row.push((svg, format!(
                "the network's prediction of {} against the simulated value for the {name} rows ({} of them, R² {:.3}); on the line the network is exact.",
                study.target.response,
                rows.len(),
                m.r2
            )));
        }
    }
    let all: Vec<(f64, f64)> =
        o.y.iter()
            .copied()
            .zip(t.predictions.iter().copied())
            .collect();
    if let Ok(svg) = regression_plot(
        &format!("Network, all rows: R^2 {:.3}", t.metrics_all.r2),
        &study.target.response,
        &all,
    ) {
        row.push((
            svg,
            format!(
            "the network's prediction of {} against the simulated value for every row (R² {:.3}).",
            study.target.response, t.metrics_all.r2
        ),
        ));
    }
    let mut series = Vec::new();
    if !t.ga_history.is_empty() {
        series.push((
            "GA-BP: training MSE of the best weights",
            BLUE,
            t.ga_history
                .iter()
                .enumerate()
                .map(|(i, v)| ((i + 1) as f64, *v))
                .collect(),
        ));
    }
    series.push((
        "GA-BP-GA: |prediction - lab|",
        ORANGE,
        o.search
            .history
            .iter()
            .enumerate()
            .map(|(i, v)| ((i + 1) as f64, *v))
            .collect(),
    ));
    if let Ok(svg) = convergence_plot(
        "Genetic algorithms: convergence",
        "generation",
        "best value",
        &series,
    ) {
        row.push((svg, "convergence of the genetic algorithms: per generation, the training error of the best initial weights GA-BP found, and the distance of GA-BP-GA's best prediction from the lab value.".to_string()));
    }
    plots_row(h, figs, st, row);
}

fn smc_html(
    h: &mut String,
    figs: &mut dyn FigureSink,
    study: &Study,
    st: &StageResult,
    o: &SmcOutcome,
) {
    let Some(last) = o.rounds.iter().rev().find(|r| !r.weights.is_empty()) else {
        return;
    };
    let p = &last.posterior;
    h.push_str("<p>Posterior of the last iteration (mean, standard deviation, 95 % credible interval), per iteration the likelihood's scale sigma was tuned to the target effective sample size:</p><table><tr><th>parameter</th><th>mean</th><th>std</th><th>95 % credible</th></tr>");
    for (j, &pi) in st.active.iter().enumerate() {
        write!(
            h,
            "<tr><td>{}</td><td>{}</td><td>{}</td><td>{} .. {}</td></tr>",
            study.parameters[pi].name,
            sig(p.mean[j]),
            sig(p.std[j]),
            sig(p.credible[j].0),
            sig(p.credible[j].1)
        )
        .unwrap();
    }
    h.push_str("</table><table><tr><th>iteration</th><th>runs used</th><th>sigma</th><th>effective sample size</th></tr>");
    for (i, r) in o
        .rounds
        .iter()
        .enumerate()
        .filter(|(_, r)| !r.weights.is_empty())
    {
        write!(
            h,
            "<tr><td>{}</td><td>{}</td><td>{}</td><td>{:.1}</td></tr>",
            i + 1,
            r.used.len(),
            sig(r.posterior.sigma),
            r.posterior.ess
        )
        .unwrap();
    }
    h.push_str("</table>");
    let values: Vec<Vec<f64>> = last
        .used
        .iter()
        .map(|&i| st.active.iter().map(|&pi| st.runs[i].values[pi]).collect())
        .collect();
    let mut row = Vec::new();
    for (j, &pi) in st.active.iter().enumerate() {
        let name = &study.parameters[pi].name;
        let xs: Vec<f64> = values.iter().map(|v| v[j]).collect();
        if let Ok(svg) = marginal_plot(name, &xs, &last.weights, p.mean[j], p.credible[j]) {
            row.push((svg, format!(
                "the posterior of {name} in the last iteration: its runs' weighted histogram, the posterior mean and the 95 % credible interval."
            )));
        }
    }
    let k = st.active.len();
    for (a, b) in drawn_pairs(h, k) {
        let pts: Vec<(f64, f64, f64)> = values
            .iter()
            .zip(&last.weights)
            .map(|(v, w)| (v[a], v[b], *w))
            .collect();
        if let Ok(svg) = pair_plot(
            &study.parameters[st.active[a]].name,
            &study.parameters[st.active[b]].name,
            &pts,
            (p.mean[a], p.mean[b]),
        ) {
            row.push((svg, format!(
                "the last iteration's runs over {} and {}, each dot sized by its posterior weight; the red ring is the posterior mean.",
                study.parameters[st.active[a]].name,
                study.parameters[st.active[b]].name
            )));
        }
    }
    plots_row(h, figs, st, row);
}

type Series<'a> = (&'a str, RGBColor, Vec<(f64, f64)>);

/// Lines of a quantity over rounds or generations: the x axis counts, so its ticks are whole
/// numbers (an f64 axis labelled 0.0, 1.0 ... 10.0 read as if half a round existed).
fn convergence_plot(
    title: &str,
    x_desc: &str,
    y_desc: &str,
    series: &[Series],
) -> Result<String, String> {
    let all = series.iter().flat_map(|s| s.2.iter());
    let (x0, x1) = plots::min_max(all.clone().map(|p| p.0));
    let (y0, y1) = plots::min_max(all.map(|p| p.1));
    if x0 > x1 || !x0.is_finite() || !x1.is_finite() {
        return Err("no points".into());
    }
    let (first, last) = (x0.floor() as i64, x1.ceil() as i64);
    // At most about ten labels, each a whole number.
    let labels = ((last - first) as usize + 1).min(11);
    plots::render(|root| {
        let mut chart = ChartBuilder::on(root)
            .caption(title, (FONT, 24))
            .margin(12)
            .x_label_area_size(66)
            .y_label_area_size(92)
            .build_cartesian_2d(first..last.max(first + 1), padded(y0, y1))
            .map_err(plots::err)?;
        chart
            .configure_mesh()
            .label_style((plots::FONT, plots::TEXT))
            .axis_desc_style((plots::FONT, plots::DESC))
            .x_labels(labels)
            .x_label_formatter(&|v| v.to_string())
            .x_desc(x_desc)
            .y_desc(y_desc)
            .draw()
            .map_err(plots::err)?;
        for (name, colour, pts) in series {
            let c = *colour;
            let pts: Vec<(i64, f64)> = pts.iter().map(|p| (p.0.round() as i64, p.1)).collect();
            chart
                .draw_series(LineSeries::new(pts.clone(), c.stroke_width(2)))
                .map_err(plots::err)?
                .label(*name)
                .legend(move |(x, y)| PathElement::new([(x, y), (x + 18, y)], c));
            chart
                .draw_series(pts.iter().map(|p| Circle::new(*p, 3, c.filled())))
                .map_err(plots::err)?;
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.9))
            .border_style(BLACK)
            .label_font((plots::FONT, plots::TEXT))
            .position(SeriesLabelPosition::UpperRight)
            .draw()
            .map_err(plots::err)?;
        Ok(())
    })
}

fn regression_plot(title: &str, response: &str, pts: &[(f64, f64)]) -> Result<String, String> {
    if pts.is_empty() {
        return Err("no points".into());
    }
    let (lo, hi) = plots::min_max(pts.iter().flat_map(|p| [p.0, p.1]));
    let _ = title;
    plots::scatter(
        &format!("simulated {response}"),
        &format!("network {response}"),
        pts,
        Some(([(lo, lo), (hi, hi)], "network = simulated")),
        &[],
        true,
    )
}

/// A map of `f` over two coded factors (-1 .. 1) with its colour bar (`quantity` names what
/// the colours are), the runs as dots, the chosen point ringed.
fn heat_map(
    (fa, fb): (&doe::Factor, &doe::Factor),
    quantity: &str,
    f: impl Fn(f64, f64) -> f64,
    points: &[(f64, f64)],
    chosen: Option<(f64, f64)>,
) -> Result<String, String> {
    const N: usize = 40;
    let cell = 2.0 / N as f64;
    let values: Vec<Vec<f64>> = (0..N)
        .map(|i| {
            (0..N)
                .map(|j| {
                    f(
                        -1.0 + (i as f64 + 0.5) * cell,
                        -1.0 + (j as f64 + 0.5) * cell,
                    )
                })
                .collect()
        })
        .collect();
    let desc = |f: &doe::Factor| {
        format!(
            "{} (coded; -1 = {}, +1 = {})",
            f.name,
            sig(f.low),
            sig(f.high)
        )
    };
    let (xd, yd) = (desc(fa), desc(fb));
    plots::map_with_colour_bar(&plots::FilledMap {
        x_desc: &xd,
        y_desc: &yd,
        x_range: (-1.0, 1.0),
        y_range: (-1.0, 1.0),
        values: &values,
        quantity,
        points,
        points_label: "runs",
        chosen: chosen.map(|c| (c, "calibrated run")),
    })
}

/// Weighted histogram of one parameter's samples, the posterior mean and credible interval.
fn marginal_plot(
    name: &str,
    xs: &[f64],
    w: &[f64],
    mean: f64,
    ci: (f64, f64),
) -> Result<String, String> {
    const BINS: usize = 20;
    let (x0, x1) = plots::min_max(xs.iter().copied().chain([ci.0, ci.1]));
    if x0 > x1 {
        return Err("no samples".into());
    }
    let width = ((x1 - x0) / BINS as f64).max(1e-12 * x1.abs().max(1.0));
    let mut bins = [0.0; BINS];
    for (x, wi) in xs.iter().zip(w) {
        let b = (((x - x0) / width) as usize).min(BINS - 1);
        bins[b] += wi;
    }
    let top = bins.iter().copied().fold(0.0, f64::max).max(1e-12);
    plots::render(|root| {
        let mut chart = ChartBuilder::on(root)
            .caption(format!("Posterior of {name}"), (FONT, 24))
            .margin(12)
            .x_label_area_size(66)
            .y_label_area_size(92)
            .build_cartesian_2d(padded(x0, x1), 0.0..top * 1.1)
            .map_err(plots::err)?;
        chart
            .configure_mesh()
            .label_style((plots::FONT, plots::TEXT))
            .axis_desc_style((plots::FONT, plots::DESC))
            .x_desc(name)
            .y_desc("posterior weight")
            .draw()
            .map_err(plots::err)?;
        chart
            .draw_series(bins.iter().enumerate().map(|(i, v)| {
                let a = x0 + i as f64 * width;
                Rectangle::new([(a, 0.0), (a + width, *v)], BLUE.mix(0.6).filled())
            }))
            .map_err(plots::err)?;
        chart
            .draw_series(LineSeries::new(
                [(mean, 0.0), (mean, top * 1.1)],
                RED_LINE.stroke_width(2),
            ))
            .map_err(plots::err)?
            .label(format!("mean {}", sig(mean)))
            .legend(|(x, y)| PathElement::new([(x, y), (x + 18, y)], RED_LINE));
        for e in [ci.0, ci.1] {
            chart
                .draw_series(LineSeries::new(
                    [(e, 0.0), (e, top * 1.1)],
                    GREEN.stroke_width(2),
                ))
                .map_err(plots::err)?;
        }
        chart
            .draw_series(LineSeries::new(
                [(ci.0, top * 1.05), (ci.1, top * 1.05)],
                GREEN.stroke_width(2),
            ))
            .map_err(plots::err)?
            .label(format!("95 % credible {} .. {}", sig(ci.0), sig(ci.1)))
            .legend(|(x, y)| PathElement::new([(x, y), (x + 18, y)], GREEN));
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.9))
            .border_style(BLACK)
            .label_font((plots::FONT, plots::TEXT))
            .position(SeriesLabelPosition::UpperRight)
            .draw()
            .map_err(plots::err)?;
        Ok(())
    })
}

/// The last iteration's samples of two parameters, dot size by weight, the calibrated point ringed.
fn pair_plot(
    a: &str,
    b: &str,
    pts: &[(f64, f64, f64)],
    mean: (f64, f64),
) -> Result<String, String> {
    let (x0, x1) = plots::min_max(pts.iter().map(|p| p.0));
    let (y0, y1) = plots::min_max(pts.iter().map(|p| p.1));
    let wmax = pts.iter().map(|p| p.2).fold(0.0, f64::max).max(1e-300);
    plots::render(|root| {
        let mut chart = ChartBuilder::on(root)
            .caption(format!("Posterior samples: {a} x {b}"), (FONT, 24))
            .margin(12)
            .x_label_area_size(66)
            .y_label_area_size(92)
            .build_cartesian_2d(padded(x0, x1), padded(y0, y1))
            .map_err(plots::err)?;
        chart
            .configure_mesh()
            .label_style((plots::FONT, plots::TEXT))
            .axis_desc_style((plots::FONT, plots::DESC))
            .x_desc(a)
            .y_desc(b)
            .draw()
            .map_err(plots::err)?;
        chart
            .draw_series(pts.iter().map(|p| {
                let r = 2 + (8.0 * (p.2 / wmax).sqrt()) as i32;
                Circle::new((p.0, p.1), r, BLUE.mix(0.5).filled())
            }))
            .map_err(plots::err)?;
        chart
            .draw_series([Circle::new(mean, 10, RED_LINE.stroke_width(3))])
            .map_err(plots::err)?;
        Ok(())
    })
}
