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
    let bars: Vec<_> = elements(&doc, "rect")
        .into_iter()
        .filter(|r| matches!(r.attribute("fill"), Some("#E67814") | Some("#2864C8")))
        .collect();
    assert_eq!(bars.len(), 8);
    let heights: Vec<f64> = bars
        .iter()
        .map(|r| r.attribute("height").unwrap().parse().unwrap())
        .collect();
    assert!(heights.windows(2).all(|w| w[0] >= w[1]), "{heights:?}");
    let positive = bars
        .iter()
        .filter(|r| r.attribute("fill") == Some("#E67814"))
        .count();
    assert_eq!(positive, f.effects.iter().filter(|e| e.t > 0.0).count());
    let t = texts(&doc);
    for name in ["A", "B", "C", "D", "E", "F", "G", "H"] {
        assert!(t.iter().any(|s| s == name), "label {name}");
    }
    assert!(t.iter().any(|s| s.starts_with("t-value limit 3.182")));
    assert!(t.iter().any(|s| s.starts_with("Bonferroni limit")));
}

#[test]
fn scatter_plots_show_every_run() {
    let f = fit(CCD, ModelOrder::Quadratic, 3);
    let finite = f.studentized.iter().filter(|v| v.is_finite()).count();
    for (svg, n) in [
        (plots::predicted_vs_actual(&f).unwrap(), 23),
        (plots::residuals_vs_predicted(&f).unwrap(), finite),
        (plots::normal_plot(&f).unwrap(), finite),
    ] {
        let doc = roxmltree::Document::parse(&svg).unwrap();
        assert_eq!(elements(&doc, "circle").len(), n);
    }
    assert_eq!(finite, 23, "no run of a CCD has leverage 1");
}

#[test]
fn contour_and_surface_cover_the_grid() {
    let f = fit(CCD, ModelOrder::Quadratic, 3);
    let held = [0.0, 0.0, 0.0];
    let svg = plots::contour_plot(&f, 0, 2, &held, (-1.0, 1.0)).unwrap();
    let doc = roxmltree::Document::parse(&svg).unwrap();
    // 41 x 41 coloured cells (plus the background).
    assert_eq!(elements(&doc, "rect").len(), 41 * 41 + 1);
    assert!(elements(&doc, "polyline").len() > 50, "contour lines");
    // Design points in the E = 0 plane and inside the plotted square: the 9 centre points. The
    // axial points of D and G (at +-1.68179) show once the square reaches alpha.
    assert_eq!(elements(&doc, "circle").len(), 9);
    let wide = plots::contour_plot(&f, 0, 2, &held, (-1.68179, 1.68179)).unwrap();
    let wide = roxmltree::Document::parse(&wide).unwrap();
    assert_eq!(elements(&wide, "circle").len(), 9 + 4);
    let t = texts(&doc);
    assert!(t.iter().any(|s| s == "held: E = 0"));
    let svg = plots::surface_plot(&f, 0, 2, &held, (-1.0, 1.0)).unwrap();
    let doc = roxmltree::Document::parse(&svg).unwrap();
    assert!(elements(&doc, "polygon").len() >= 24 * 24);
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
    assert!(plots::residuals_vs_predicted(&f).is_ok());
}
