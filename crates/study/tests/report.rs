//! The report of a whole study, ready for a paper: every figure of the page is also its own SVG
//! and PNG under `report/figures/`, the test's fixed settings are tabled, the parameters the
//! study did not calibrate say what they were held at and why, and every "±" says what it is.

use std::sync::atomic::AtomicBool;
use std::sync::Arc;

use study::RunOptions;

/// A bowl with its minimum, 30, at a = 0.6, b = 0.3; c and d barely matter, so screening drops
/// them.
const BOWL: &str = r#"
name = "bowl"
seed = 3
plan = ["screening", "steepest", "rsm", "optimize", "validate"]

[test]
test = "function"
[test.function]
expression = "30 + 10*((a - 0.6)^2 + (b - 0.3)^2) + 0.01*c + 0.01*d"
variables = { a = 0.8, b = 0.5, c = 0.5, d = 0.5 }
noise = 0.02

[[parameter]]
name = "a"
path = "function.variables.a"
min = 0.4
max = 1.2

[[parameter]]
name = "b"
path = "function.variables.b"
min = 0.1
max = 0.9
unit = "mm"

[[parameter]]
name = "c"
path = "function.variables.c"
min = 0.0
max = 1.0

[[parameter]]
name = "d"
path = "function.variables.d"
min = 0.0
max = 1.0

[target]
response = "value"
replicates = [29.9, 30.1, 30.0]
unit = "deg"
"#;

/// The page's text without its tags (and without the SVG inside it).
fn text_of(html: &str) -> String {
    let mut out = String::new();
    let mut depth = 0usize;
    let mut in_svg = false;
    let mut rest = html;
    while let Some(open) = rest.find('<') {
        if !in_svg && depth == 0 {
            out.push_str(&rest[..open]);
        }
        let close = rest[open..].find('>').map_or(rest.len(), |c| open + c + 1);
        let tag = &rest[open..close];
        if tag.starts_with("<svg") {
            in_svg = true;
        } else if tag.starts_with("</svg") {
            in_svg = false;
        } else if tag.starts_with("<style") {
            depth += 1;
        } else if tag.starts_with("</style") {
            depth -= 1;
        }
        out.push(' ');
        rest = &rest[close..];
    }
    out.push_str(rest);
    let out = out
        .replace("&amp;", "&")
        .replace("&lt;", "<")
        .replace("&gt;", ">");
    out.split_whitespace().collect::<Vec<_>>().join(" ")
}

#[test]
fn the_report_has_its_figures_as_files_its_settings_and_says_what_every_spread_is() {
    let dir = std::env::temp_dir().join(format!("demcal-report-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("study.toml");
    std::fs::write(&path, BOWL).unwrap();
    let out = study::run(
        &path,
        &RunOptions {
            jobs: 2,
            ..Default::default()
        },
        Arc::new(AtomicBool::new(false)),
    )
    .unwrap();
    assert!(out.contains("state: complete"), "{out}");
    let report = dir.join("report");
    let html = std::fs::read_to_string(report.join("index.html")).unwrap();

    // Every figure the page numbers is a file pair under figures/, the PNG at twice the SVG's
    // size, and there is nothing else there.
    let ids: Vec<&str> = html
        .split("<figure id=\"")
        .skip(1)
        .map(|s| &s[..s.find('"').unwrap()])
        .collect();
    assert!(ids.len() >= 12, "{} figures", ids.len());
    for (n, id) in ids.iter().enumerate() {
        assert!(id.starts_with(&format!("fig{:02}-", n + 1)), "{id}");
        assert!(html.contains(&format!("<b>Figure {}.</b>", n + 1)));
        let svg = std::fs::read_to_string(report.join(format!("figures/{id}.svg"))).unwrap();
        let doc = roxmltree::Document::parse(&svg).unwrap();
        let width: f64 = doc
            .root_element()
            .attribute("width")
            .unwrap()
            .parse()
            .unwrap();
        let png = std::fs::read(report.join(format!("figures/{id}.png"))).unwrap();
        let img = image::load_from_memory_with_format(&png, image::ImageFormat::Png).unwrap();
        assert_eq!(img.width() as f64, 2.0 * width, "{id}");
    }
    let files = std::fs::read_dir(report.join("figures")).unwrap().count();
    assert_eq!(files, 2 * ids.len());
    for figure in [
        "pareto",
        "steepest-path",
        "contour-AB",
        "surface",
        "perturbation",
        "normal-plot",
        "residuals-vs-predicted",
        "residuals-vs-run",
        "cooks-distance",
        "validation",
    ] {
        assert!(
            ids.iter().any(|id| id.ends_with(figure)),
            "no {figure} figure"
        );
    }

    let text = text_of(&html);
    // The fixed settings, the coefficient table and the prediction interval.
    for part in [
        "The virtual test: what it holds fixed",
        "Geometry, speeds and measurement",
        "95 % CI low",
        "VIF",
        "95 % prediction interval",
        "b (mm)",
        "% Contribution",
    ] {
        assert!(text.contains(part), "the report lacks {part}");
    }
    // c and d were screened out: held at the middle of their ranges, and said why; their
    // slots in the test's table name them.
    for p in ["C", "D"] {
        assert!(text.contains(&format!("0.5000 ({p}, held)")), "{p}");
    }
    assert_eq!(
        text.matches("held at 0.5000: screened out at stage 1")
            .count(),
        2,
        "{text}"
    );
    // Every "±" is followed by what it is.
    let mut seen = 0;
    for (i, _) in text.match_indices('±') {
        let after: String = text[i..].chars().take(80).collect();
        assert!(
            ["SD over", "standard deviation"]
                .iter()
                .any(|w| after.contains(w)),
            "a ± without what it is: {after}"
        );
        seen += 1;
    }
    assert!(seen >= 3, "{seen}");

    // Issue 41: a table of contents; every calibrated value with its interval; the Sobol
    // indices as a table and a figure; curvature in words; the validation against the lab.
    assert!(html.contains("<nav class=\"toc\">"), "no contents");
    for part in [
        "Contents",
        "Uncertainty and identifiability",
        "inverse prediction from the response surface",
        "Sobol indices of the fitted model of value",
        "First order",
        "Curvature is",
        "Validation interval:",
    ] {
        assert!(text.contains(part), "the report lacks {part}");
    }
    assert!(
        ids.iter().any(|id| id.ends_with("sobol-1")),
        "no Sobol figure: {ids:?}"
    );
    let summary = test_support::summary(&dir);
    for p in ["a", "b"] {
        let u = &summary["uncertainty"]["parameters"][p];
        let iv = u["interval_95"]
            .as_array()
            .unwrap_or_else(|| panic!("{p}: {u}"));
        let (lo, hi) = (iv[0].as_f64().unwrap(), iv[1].as_f64().unwrap());
        let truth = if p == "a" { 0.6 } else { 0.3 };
        // The bowl's minimum is the lab value: the interval holds it and is narrow.
        assert!(lo <= truth && truth <= hi && hi - lo < 0.3, "{p}: {u}");
        assert_eq!(u["identified"], true, "{p}: {u}");
    }
    assert!(
        summary["validation"]["statement"].as_str().is_some(),
        "{}",
        summary["validation"]
    );
    std::fs::remove_dir_all(&dir).unwrap();
}
