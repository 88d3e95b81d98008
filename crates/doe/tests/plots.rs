//! The SVG plots parse as XML and hold the series they should.

use doe::{plots, Curvature, DataTable, Experiment, FactorColumns, Fit, ModelOrder};

const PB: &str = include_str!("data/silage-repose-pb.csv");
const CCD: &str = include_str!("data/silage-repose-ccd.csv");

fn fit(text: &str, order: ModelOrder, k: usize) -> Fit {
    let t = DataTable::parse("data.csv", text).unwrap();
    let e = Experiment::from_table(&t, "angle_deg", &FactorColumns::Default).unwrap();
    Fit::new(&e, &order.terms(k), Curvature::Auto).unwrap()
}

fn elements<'a>(doc: &'a roxmltree::Document, tag: &str) -> Vec<roxmltree::Node<'a, 'a>> {
    doc.descendants().filter(|n| n.has_tag_name(tag)).collect()
}

fn texts(doc: &roxmltree::Document) -> Vec<String> {
    elements(doc, "text")
        .iter()
        .filter_map(|n| n.text().map(|t| t.trim().to_string()))
        .collect()
}

#[test]
fn pareto_chart_has_one_bar_per_effect_sorted_with_both_limits() {
    let f = fit(PB, ModelOrder::Linear, 8);
    let svg = plots::pareto_chart(&f).unwrap();
    let doc = roxmltree::Document::parse(&svg).unwrap();
    let coloured: Vec<_> = elements(&doc, "rect")
        .into_iter()
        .filter(|r| matches!(r.attribute("fill"), Some("#E67814") | Some("#2864C8")))
        .collect();
    // The legend's two swatches come first, then a horizontal bar per effect, top down.
    assert_eq!(coloured.len(), 2 + 8);
    let bars = &coloured[2..];
    let widths: Vec<f64> = bars
        .iter()
        .map(|r| r.attribute("width").unwrap().parse().unwrap())
        .collect();
    let tops: Vec<f64> = bars
        .iter()
        .map(|r| r.attribute("y").unwrap().parse().unwrap())
        .collect();
    assert!(widths.windows(2).all(|w| w[0] >= w[1]), "{widths:?}");
    assert!(tops.windows(2).all(|w| w[0] < w[1]), "{tops:?}");
    let positive = bars
        .iter()
        .filter(|r| r.attribute("fill") == Some("#E67814"))
        .count();
    assert_eq!(positive, f.effects.iter().filter(|e| e.t > 0.0).count());
    let t = texts(&doc);
    for name in ["A", "B", "C", "D", "E", "F", "G", "H"] {
        assert!(t.iter().any(|s| s == name), "label {name}");
    }
    for legend in ["positive effect", "negative effect", "t limit 3.182"] {
        assert!(t.iter().any(|s| s == legend), "{legend}: {t:?}");
    }
    assert!(t.iter().any(|s| s.starts_with("Bonferroni limit")));
    assert!(t.iter().any(|s| s == "|t| of the effect"));
}

#[test]
fn scatter_plots_show_every_run() {
    let f = fit(CCD, ModelOrder::Quadratic, 3);
    let labels = plots::Labels::with_units(&f, "deg", &["-".into(), "-".into(), "-".into()]);
    let finite = f.studentized.iter().filter(|v| v.is_finite()).count();
    let runs: Vec<usize> = (1..=23).collect();
    for (svg, n) in [
        (plots::predicted_vs_actual(&f, &labels).unwrap(), 23),
        (plots::residuals_vs_predicted(&f, &labels).unwrap(), finite),
        (plots::normal_plot(&f).unwrap(), finite),
        (plots::residuals_vs_run(&f, &runs).unwrap(), finite),
    ] {
        let doc = roxmltree::Document::parse(&svg).unwrap();
        assert_eq!(elements(&doc, "circle").len(), n);
    }
    assert_eq!(finite, 23, "no run of a CCD has leverage 1");
    let svg = plots::predicted_vs_actual(&f, &labels).unwrap();
    let doc = roxmltree::Document::parse(&svg).unwrap();
    assert!(texts(&doc).iter().any(|s| s == "actual angle (deg)"));
    // Cook's distance: a stem and a dot per run, and the legend's dot.
    let svg = plots::cooks_distance_plot(&f, &runs).unwrap();
    let doc = roxmltree::Document::parse(&svg).unwrap();
    assert_eq!(elements(&doc, "circle").len(), 23 + 1);
    assert!(texts(&doc).iter().any(|s| s == "D = 1"));
}

/// The black design-run dots of a contour plot (each on a white disc), without the legend's.
fn run_dots(doc: &roxmltree::Document) -> usize {
    elements(doc, "circle")
        .iter()
        .filter(|c| c.attribute("fill") == Some("#000000") && c.attribute("r") == Some("6"))
        .count()
        - 1
}

#[test]
fn contour_and_surface_cover_the_grid() {
    let f = fit(CCD, ModelOrder::Quadratic, 3);
    let labels = plots::Labels::of(&f);
    let centre = plots::ContourMarks::centre(3);
    let svg = plots::contour_plot(&f, &labels, 0, 2, &centre).unwrap();
    let doc = roxmltree::Document::parse(&svg).unwrap();
    // 41 x 41 coloured cells, the background, the colour bar's slices.
    assert!(elements(&doc, "rect").len() > 41 * 41 + 1 + 90);
    assert!(elements(&doc, "polyline").len() > 3, "contour lines");
    // Design points in the E = 0 plane and inside the plotted square: the 9 centre points. The
    // axial points of D and G (at +-1.68179) show once the square reaches alpha, which is the
    // range `covering` gives.
    assert_eq!(run_dots(&doc), 9);
    let range = plots::ContourMarks::covering(&f, 0, 2, &[0.0; 3]);
    assert!((range.1 - 1.06 * 1.68179).abs() < 1e-4, "{range:?}");
    let wide = plots::ContourMarks {
        range,
        ..centre.clone()
    };
    let svg = plots::contour_plot(&f, &labels, 0, 2, &wide).unwrap();
    let wide = roxmltree::Document::parse(&svg).unwrap();
    assert_eq!(run_dots(&wide), 9 + 4);
    let t = texts(&doc);
    assert!(t.iter().any(|s| s == "held: E = 0"));
    assert!(t.iter().any(|s| s == "design runs"));
    let svg = plots::surface_plot(&f, &labels, 0, 2, &centre).unwrap();
    let doc = roxmltree::Document::parse(&svg).unwrap();
    assert!(elements(&doc, "polygon").len() >= 24 * 24);
}

#[test]
fn the_contour_plot_marks_the_target_and_the_optimum_and_has_a_colour_bar() {
    let f = fit(CCD, ModelOrder::Quadratic, 3);
    let labels = plots::Labels::with_units(&f, "deg", &[]);
    let g = plots::grid(&f, 0, 2, &[0.0; 3], (-1.0, 1.0), 41);
    let (lo, hi) = plots::min_max(g.values.iter().flatten().copied());
    let marks = plots::ContourMarks {
        target: Some((0.5 * (lo + hi), "lab value".into())),
        optimum: Some((vec![0.2, 0.0, -0.3], "optimum".into())),
        ..plots::ContourMarks::centre(3)
    };
    let svg = plots::contour_plot(&f, &labels, 0, 2, &marks).unwrap();
    let doc = roxmltree::Document::parse(&svg).unwrap();
    let t = texts(&doc);
    for legend in ["lab value", "optimum", "angle (deg)"] {
        assert!(t.iter().any(|s| s == legend), "{legend}: {t:?}");
    }
    // The colour bar's ticks are the contour levels: round numbers between lo and hi.
    for level in plots::nice_ticks(lo, hi, 6) {
        assert!(
            t.iter().any(|s| *s == plots::tick(&level)),
            "{level}: {t:?}"
        );
    }
}

#[test]
fn the_perturbation_plot_has_a_trace_per_factor() {
    let f = fit(CCD, ModelOrder::Quadratic, 3);
    let labels = plots::Labels::of(&f);
    let svg = plots::perturbation_plot(&f, &labels, &[0.0; 3], 1.0).unwrap();
    let doc = roxmltree::Document::parse(&svg).unwrap();
    let traces = elements(&doc, "polyline")
        .iter()
        .filter(|p| p.attribute("stroke-width") == Some("3"))
        .count();
    // A trace per factor and its legend's line.
    assert_eq!(traces, 2 * 3);
    let t = texts(&doc);
    for (letter, name) in ["A", "B", "C"].iter().zip(&labels.factors) {
        assert!(t.iter().any(|s| s == letter));
        assert!(t.iter().any(|s| *s == format!("{letter}: {name}")), "{t:?}");
    }
}

#[test]
fn contour_lines_sit_on_their_level() {
    let f = fit(CCD, ModelOrder::Quadratic, 3);
    let g = plots::grid(&f, 0, 2, &[0.0; 3], (-1.0, 1.0), 41);
    for seg in plots::contour_segments(&g, 42.0) {
        for (x, y) in seg {
            let v = f.predict_coded(&[x, 0.0, y]);
            assert!((v - 42.0).abs() < 0.05, "{v} at ({x}, {y})");
        }
    }
}

#[test]
fn an_exact_fit_still_plots() {
    // No residual error: residual plots are skipped, the others render (plotters' tick search
    // would not end on a zero-width axis, so ranges are guarded).
    let mut csv = String::from("A,B,y\n");
    for (a, b) in [(-1, -1), (1, -1), (-1, 1), (1, 1), (0, 0), (0, 0)] {
        csv.push_str(&format!("{a},{b},{}\n", 5 + 2 * a - b));
    }
    let t = DataTable::parse("exact.csv", &csv).unwrap();
    let e = Experiment::from_table(&t, "y", &FactorColumns::Default).unwrap();
    let f = Fit::new(&e, &ModelOrder::Linear.terms(2), Curvature::Off).unwrap();
    assert!(f.residual.sum_sq < 1e-20);
    let dir = std::env::temp_dir().join(format!("demcal-exact-{}", std::process::id()));
    let files = plots::write_all(&f, &dir).unwrap();
    let names: Vec<String> = files
        .iter()
        .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
        .collect();
    assert_eq!(
        names,
        ["predicted_vs_actual.svg", "contour.svg", "surface.svg"]
    );
    assert!(plots::residuals_vs_predicted(&f, &plots::Labels::of(&f)).is_ok());
}
