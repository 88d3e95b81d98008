//! The report: `index.html` (self-contained: figures inline as SVG, pictures as data URLs),
//! `figures/` (every figure of the page as its own SVG and PNG, numbered as the page numbers
//! them), `results.csv` (every stored run) and `summary.json` (the calibrated values and the
//! validation, for scripts).
//!
//! The page: the summary (lab value, validation, each parameter calibrated, held at a value or
//! left undetermined), the test's fixed settings ([`crate::report_settings`]), then each stage
//! with its runs, models ([`crate::report_model`]) and figures ([`crate::report_figures`]).

use std::fmt::Write;
use std::path::{Path, PathBuf};

use crate::record::{Replay, StageResult, State};
use crate::report_data;
use crate::report_figures::{self as figures, mean_sd, Figures};
use crate::report_settings;
use crate::spec::Study;
use crate::store::{RunRecord, Status};
use crate::targets_report;
use crate::text::{breakable, esc, letter, sig};

/// Writes the report into `out` (default: `report/` next to the study); returns the folder.
pub fn write(
    study: &Study,
    r: &Replay,
    stored: &[RunRecord],
    out: Option<&Path>,
) -> Result<PathBuf, String> {
    let dir = out
        .map(Path::to_path_buf)
        .unwrap_or_else(|| study.report_dir());
    std::fs::create_dir_all(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let put = |name: &str, text: &str| -> Result<(), String> {
        let p = dir.join(name);
        // Write then rename, so a reader never sees half a file.
        let tmp = dir.join(format!(".{name}.tmp"));
        std::fs::write(&tmp, text).map_err(|e| format!("{}: {e}", tmp.display()))?;
        std::fs::rename(&tmp, &p).map_err(|e| format!("{}: {e}", p.display()))
    };
    put("results.csv", &report_data::results_csv(study, stored)?)?;
    put(
        "summary.json",
        &serde_json::to_string_pretty(&report_data::summary_json(study, r, stored)).unwrap(),
    )?;
    let (page, figs) = html(study, r, stored);
    figs.write(&dir.join("figures"))?;
    put("index.html", &page)?;
    Ok(dir)
}

/// Body text is 16 px; figures are drawn for 90-100 % of their 640-unit width, so their text
/// (18.5 units) shows at least as large. Wide tables scroll inside their own box.
const STYLE: &str = "
body { font-family: system-ui, -apple-system, 'Segoe UI', Roboto, 'DejaVu Sans', sans-serif; font-size: 16px; line-height: 1.45; margin: 0; color: #1d2330; background: #f4f6f9; }
main { max-width: 1220px; margin: 0 auto; padding: 24px 28px 60px; background: #fff; box-sizing: border-box; }
h1 { font-size: 1.7em; margin-bottom: 0.2em; line-height: 1.2; }
h2 { border-bottom: 2px solid #d6dde8; padding-bottom: 4px; margin-top: 2.2em; }
h3 { margin-top: 1.6em; color: #34405a; }
.sub { color: #5b6478; margin-top: 0; }
.scroll { overflow-x: auto; max-width: 100%; margin: 0.6em 0 1em; }
table { border-collapse: collapse; font-size: 0.9em; }
th, td { border: 1px solid #d6dde8; padding: 4px 9px; text-align: right; white-space: nowrap; vertical-align: top; }
td.wrap { white-space: normal; min-width: 11em; max-width: 34em; }
td.name { white-space: normal; min-width: 10em; }
.path { font-size: 0.85em; overflow-wrap: anywhere; color: #5b6478; }
th { white-space: normal; background: #eef2f7; }
td.l, th.l { text-align: left; }
tr.failed td { color: #a12a2a; background: #fff4f4; }
tr.best td { background: #eefaf0; font-weight: 600; }
tr.flag td { background: #fff6dd; }
.cards { display: flex; flex-wrap: wrap; gap: 14px; margin: 1em 0; }
.card { border: 1px solid #d6dde8; border-radius: 8px; padding: 10px 16px; min-width: 180px; background: #fafbfd; }
.card .v { font-size: 1.5em; font-weight: 600; }
.card .k { color: #5b6478; font-size: 0.9em; }
.note { background: #fff8e6; border-left: 4px solid #e0a800; padding: 6px 12px; margin: 0.5em 0; }
.stop { background: #fdecec; border-left: 4px solid #c62828; padding: 6px 12px; }
.plots { display: grid; grid-template-columns: repeat(auto-fill, minmax(min(100%, 540px), 1fr)); gap: 18px 22px; align-items: start; margin: 1em 0; }
figure { margin: 0; }
figure .svg svg, figure img { display: block; width: 100%; max-width: 640px; height: auto; border: 1px solid #e3e8ef; }
figcaption { margin-top: 6px; max-width: 640px; }
figcaption .files { color: #5b6478; white-space: nowrap; }
.mono { font-family: ui-monospace, Menlo, Consolas, 'DejaVu Sans Mono', monospace; font-size: 0.88em; }
p, li { max-width: 62em; }
nav.toc { border: 1px solid #d6dde8; border-radius: 8px; padding: 6px 16px; background: #fafbfd; max-width: 40em; margin: 1em 0; }
nav.toc ol { margin: 0.3em 0; padding-left: 1.6em; }
";

fn html(study: &Study, r: &Replay, stored: &[RunRecord]) -> (String, Figures) {
    let mut h = String::new();
    let mut figs = Figures::default();
    let t = &study.target;
    let unit = if t.unit.is_empty() {
        String::new()
    } else {
        format!(" {}", esc(&t.unit))
    };
    write!(
        h,
        "<!DOCTYPE html><html lang=\"en\"><head><meta charset=\"utf-8\"><meta name=\"viewport\" content=\"width=device-width, initial-scale=1\"><title>{} - demcal calibration report</title><style>{STYLE}</style></head><body><main>",
        esc(&study.name)
    )
    .unwrap();
    let lab = match t.std() {
        Some(sd) => format!(
            "{}{unit} (mean ± SD over {} replicates)",
            mean_sd(t.value, sd),
            t.replicates.len()
        ),
        None => format!("{}{unit}", sig(t.value)),
    };
    let against = if let Some(c) = study.combine {
        format!(
            "calibrated against {} targets by minimising {}, {}",
            study.targets.len(),
            esc(c.response()),
            esc(c.describe())
        )
    } else if t.minimised() {
        format!(
            "calibrated by minimising {}, the mean squared difference between its curve and the lab's",
            esc(&t.response)
        )
    } else {
        format!("calibrated against the lab's {} = {lab}", esc(&t.response))
    };
    write!(
        h,
        "<h1>Calibration report: {}</h1><p class=\"sub\">Virtual test <b>{}</b> ({}), {against}. Study file <span class=\"mono\">{}</span>, seed {}, demcal {}.</p>",
        esc(&study.name),
        esc(&study.test_kind()),
        esc(&study
            .tests
            .iter()
            .map(|t| t.source.as_str())
            .collect::<Vec<_>>()
            .join(", ")),
        esc(&study.path.display().to_string()),
        study.seed,
        env!("CARGO_PKG_VERSION")
    )
    .unwrap();
    write!(
        h,
        "<p class=\"sub\">Runs made: {}.</p>",
        esc(&report_data::where_ran(stored))
    )
    .unwrap();

    // Summary.
    h.push_str("<h2>Summary</h2>");
    if let State::Stopped(why) = &r.state {
        write!(h, "<p class=\"stop\">The study stopped: {}</p>", esc(why)).unwrap();
    }
    if let State::Pending { stage } = &r.state {
        write!(
            h,
            "<p class=\"note\">The study is not finished: stage {} ({}) still has runs to make. <span class=\"mono\">demcal run {}</span> goes on.</p>",
            stage + 1,
            study.plan[*stage].kind(),
            esc(&study.path.display().to_string())
        )
        .unwrap();
    }
    let validation = r.stages.iter().rev().find_map(|s| s.validation().cloned());
    let failed = stored.iter().filter(|x| x.status == Status::Failed).count();
    let wall: f64 = stored.iter().map(|x| x.wall_s).sum();
    h.push_str("<div class=\"cards\">");
    match &t.curve {
        _ if study.combine.is_some() => card(
            &mut h,
            &format!("{} targets", study.targets.len()),
            &format!("in {} test(s), one objective", study.tests.len()),
        ),
        Some(c) if t.minimised() => card(
            &mut h,
            &format!("{} curve(s)", c.lab.replicates.len()),
            &format!("lab replicates of {}", c.curve),
        ),
        _ => match t.std() {
            Some(sd) => card(
                &mut h,
                &format!("{}{unit}", mean_sd(t.value, sd)),
                &format!(
                    "lab value: mean ± SD over {} replicates",
                    t.replicates.len()
                ),
            ),
            None => card(&mut h, &format!("{}{unit}", sig(t.value)), "lab value"),
        },
    }
    if let Some(v) = &validation {
        match v.std {
            Some(sd) => card(
                &mut h,
                &format!("{}{unit}", mean_sd(v.mean, sd)),
                &format!("validation: mean ± SD over {} runs", v.runs),
            ),
            None => card(
                &mut h,
                &format!("{}{unit}", sig(v.mean)),
                &format!("validation ({} run)", v.runs),
            ),
        }
        let check = crate::uncertainty_report::check(v, t);
        if let Some(e) = v.relative_error_percent {
            let interval = check
                .as_ref()
                .and_then(|c| c.relative_error_interval)
                .map(|(lo, hi)| format!(" (95 %: {lo:.1} to {hi:.1} %)"))
                .unwrap_or_default();
            card(
                &mut h,
                &format!("{e:.2} %{interval}"),
                "relative error |sim - lab| / lab; the interval is of the signed difference",
            );
        }
        if let Some(c) = check.as_ref().and_then(|c| c.compatible.map(|ok| (c, ok))) {
            card(
                &mut h,
                if c.1 { "compatible" } else { "not compatible" },
                "validation mean against the lab's (95 %, Welch)",
            );
        }
    }
    card(
        &mut h,
        &format!("{} ({} failed)", stored.len(), failed),
        "simulations stored",
    );
    card(
        &mut h,
        &format!("{:.0} s", wall),
        "simulation wall time, summed",
    );
    h.push_str("</div>");
    targets_report::targets_section(&mut h, study, validation.as_ref());
    h.push_str("<h3>Parameters</h3>");
    report_settings::parameters_table(&mut h, study, r);
    crate::uncertainty_report::section(&mut h, &mut figs, study, &r.stages);
    for i in &study.imports {
        write!(
            h,
            "<p class=\"note\">Taken from another study: {} = <b>{}</b> (its {}, calibrated by {}).</p>",
            esc(&i.paths.iter().map(|x| x.0.text.clone()).collect::<Vec<_>>().join(", ")),
            sig(i.value),
            esc(&i.parameter),
            esc(&i.study)
        )
        .unwrap();
    }
    if !r.stages.iter().any(|s| s.calibrated.is_some())
        && crate::stages::calibrated(study, &r.stages).is_some()
    {
        h.push_str("<p class=\"note\">No optimisation has run yet: the values shown are those of the run nearest the lab value.</p>");
    }
    write!(
        h,
        "<p>Plan: {}.</p>",
        study
            .plan
            .iter()
            .enumerate()
            .map(|(i, s)| format!("{}. {}", i + 1, s.kind()))
            .collect::<Vec<_>>()
            .join(", ")
    )
    .unwrap();
    report_settings::fixed_settings(&mut h, study, r, stored);

    // A section per curve target: the study's one, or each curve among several targets.
    let curves = crate::curve_report::sections(study, r);
    if !curves.is_empty() {
        h.push_str("<h2>Curves</h2>");
    }
    for c in curves {
        if let Some(t) = &c.title {
            write!(h, "<h3>{}</h3>", esc(t)).unwrap();
        }
        for p in &c.paragraphs {
            write!(h, "<p>{}</p>", esc(p)).unwrap();
        }
        figs.row(
            &mut h,
            vec![(
                c.stem,
                c.svg,
                "The lab's mean curve with its band against the simulated curves.".into(),
            )],
        );
    }
    for st in &r.stages {
        stage_html(&mut h, &mut figs, study, &r.stages, st);
    }
    h.push_str("<h2>Files</h2><p><a href=\"results.csv\">results.csv</a> (every stored run), <a href=\"summary.json\">summary.json</a> (calibrated values and validation) and <a href=\"figures/\">figures/</a> (each figure as SVG and as PNG at twice the size, named by its number) lie beside this page.</p>");
    h.push_str("</main></body></html>\n");
    (with_contents(&h), figs)
}

/// The page with a table of contents before its first section: every `<h2>` gets an anchor and
/// a line.
fn with_contents(page: &str) -> String {
    let mut out = String::with_capacity(page.len() + 2048);
    let mut items = Vec::new();
    let mut rest = page;
    let mut n = 0;
    while let Some(at) = rest.find("<h2") {
        out.push_str(&rest[..at]);
        let tag_end = match rest[at..].find('>') {
            Some(e) => at + e,
            None => break,
        };
        let close = match rest[tag_end..].find("</h2>") {
            Some(c) => tag_end + c,
            None => break,
        };
        n += 1;
        let inner = &rest[tag_end + 1..close];
        // The heading's text without its markup (escaped already).
        let mut text = String::new();
        let mut in_tag = false;
        for c in inner.chars() {
            match c {
                '<' => in_tag = true,
                '>' => in_tag = false,
                c if !in_tag => text.push(c),
                _ => {}
            }
        }
        let id = format!("section-{n}");
        write!(out, "<h2 id=\"{id}\">{inner}</h2>").unwrap();
        items.push((id, text));
        rest = &rest[close + "</h2>".len()..];
    }
    out.push_str(rest);
    if items.len() < 2 {
        return out;
    }
    let mut toc = String::from("<nav class=\"toc\"><b>Contents</b><ol>");
    for (id, text) in &items {
        write!(toc, "<li><a href=\"#{id}\">{text}</a></li>").unwrap();
    }
    toc.push_str("</ol></nav>");
    match out.find("<h2 id=\"section-1\"") {
        Some(at) => out.insert_str(at, &toc),
        None => out.push_str(&toc),
    }
    out
}

fn card(h: &mut String, value: &str, key: &str) {
    write!(
        h,
        "<div class=\"card\"><div class=\"v\">{}</div><div class=\"k\">{}</div></div>",
        esc(value),
        esc(key)
    )
    .unwrap();
}

fn stage_html(
    h: &mut String,
    figs: &mut Figures,
    study: &Study,
    stages: &[StageResult],
    st: &StageResult,
) {
    write!(
        h,
        "<h2>Stage {}: {}</h2><p class=\"sub\">{}</p>",
        st.index + 1,
        study.plan.get(st.index).map_or("stage", |s| s.heading()),
        esc(&st.title)
    )
    .unwrap();
    for n in &st.notes {
        write!(h, "<p class=\"note\">{}</p>", esc(n)).unwrap();
    }
    if !st.runs.is_empty() {
        runs_table(h, study, st);
    }
    if let Some(stage) = study.plan.get(st.index) {
        stage.report(&mut crate::spec::Section {
            h,
            figs,
            study,
            stages,
            st,
        });
    }
}

fn runs_table(h: &mut String, study: &Study, st: &StageResult) {
    let best = if st.kind == "steepest" {
        st.best_step()
    } else {
        None
    };
    let counts: Vec<usize> = st
        .records
        .iter()
        .flatten()
        .filter_map(|r| figures::flank_spread(&r.outputs).map(|s| s.1))
        .collect();
    let spread = !counts.is_empty();
    // One count for every run goes in the heading.
    let one_count = counts
        .windows(2)
        .all(|w| w[0] == w[1])
        .then(|| counts.first().copied())
        .flatten();
    h.push_str("<div class=\"scroll\"><table><tr><th>Run</th><th class=\"l\">Point</th>");
    if st.kind != "validate" {
        write!(
            h,
            "<th class=\"l\">Coded levels ({})</th>",
            st.active.iter().map(|&i| letter(i)).collect::<String>()
        )
        .unwrap();
    }
    let shown: Vec<usize> = if st.kind == "validate" {
        (0..study.parameters.len()).collect()
    } else {
        st.active.clone()
    };
    // Factor letters keep wide designs readable; the summary's table and the tooltip name them.
    for &i in &shown {
        write!(
            h,
            "<th title=\"{}\">{}</th>",
            esc(&study.parameters[i].name),
            letter(i)
        )
        .unwrap();
    }
    write!(
        h,
        "<th>Seed</th><th>{}</th>{}<th>Rel. error %</th><th>Wall s</th><th class=\"l\">Status</th></tr>",
        breakable(&figures::response_label(study)),
        match (spread, one_count) {
            (true, Some(n)) => format!("<th>Flank SD over {n} flanks (deg)</th>"),
            (true, None) => "<th>Flank SD (deg)</th>".to_string(),
            _ => String::new(),
        }
    )
    .unwrap();
    for (spec, rec) in st.runs.iter().zip(&st.records) {
        let class = match rec {
            Some(r) if r.status == Status::Failed => " class=\"failed\"",
            _ if best == Some(spec.index) => " class=\"best\"",
            _ => "",
        };
        write!(
            h,
            "<tr{class}><td>{}</td><td class=\"l\">{}</td>",
            spec.index + 1,
            esc(&spec.label)
        )
        .unwrap();
        if st.kind != "validate" {
            let levels: Vec<String> = spec
                .coded
                .iter()
                .map(|c| {
                    if c.abs() < 1e-12 {
                        "0".to_string()
                    } else if (c.abs() - c.abs().round()).abs() < 1e-9 {
                        format!("{}{}", if *c < 0.0 { "−" } else { "+" }, c.abs().round())
                    } else {
                        format!("{}{:.3}", if *c < 0.0 { "−" } else { "+" }, c.abs())
                    }
                })
                .collect();
            write!(h, "<td class=\"l mono\">{}</td>", levels.join(" ")).unwrap();
        }
        for &i in &shown {
            write!(h, "<td>{}</td>", sig(spec.values[i])).unwrap();
        }
        write!(h, "<td>{}</td>", spec.seed).unwrap();
        match rec {
            Some(r) => {
                let y = r.response.map(sig).unwrap_or_default();
                let e = r
                    .response
                    .and_then(|y| study.target.relative_error_percent(y))
                    .map(|e| format!("{e:.2}"))
                    .unwrap_or_default();
                let s = if spread {
                    format!(
                        "<td>{}</td>",
                        figures::flank_spread(&r.outputs)
                            .map(|(sd, n)| if one_count.is_some() {
                                sig(sd)
                            } else {
                                format!("{} ({n} flanks)", sig(sd))
                            })
                            .unwrap_or_default()
                    )
                } else {
                    String::new()
                };
                let status = match r.status {
                    Status::Done => "done".to_string(),
                    Status::Failed => format!(
                        "failed ({}): {}{}",
                        r.error_kind.map(|k| k.as_str()).unwrap_or("unknown"),
                        r.error.clone().unwrap_or_default(),
                        targets_report::kept(study, r)
                    ),
                };
                write!(
                    h,
                    "<td>{y}</td>{s}<td>{e}</td><td>{:.1}</td><td class=\"l wrap\">{}</td></tr>",
                    r.wall_s,
                    esc(&status)
                )
                .unwrap();
            }
            None => {
                let blank = if spread { "<td></td>" } else { "" };
                write!(
                    h,
                    "<td></td>{blank}<td></td><td></td><td class=\"l\">pending</td></tr>"
                )
                .unwrap()
            }
        }
    }
    h.push_str("</table></div>");
}
