//! Axes that count things tick at whole numbers only; a filled map carries a colour bar with
//! its scale and quantity (checked in the SVG and in the PNG that `raster` draws of it).

use doe::plots::{self, FilledMap, Line, Ticks};

fn elements<'a>(doc: &'a roxmltree::Document, tag: &str) -> Vec<roxmltree::Node<'a, 'a>> {
    doc.descendants().filter(|n| n.has_tag_name(tag)).collect()
}

/// The x axis's tick labels: plotters centres them under their ticks (y labels end at theirs).
fn x_tick_labels(svg: &str) -> Vec<String> {
    let doc = roxmltree::Document::parse(svg).unwrap();
    elements(&doc, "text")
        .iter()
        .filter(|n| n.attribute("text-anchor") == Some("middle"))
        .filter_map(|n| n.text().map(|t| t.trim().replace('−', "-")))
        .filter(|t| t.parse::<f64>().is_ok())
        .collect()
}

#[test]
fn whole_number_ticks_follow_from_the_range() {
    assert_eq!(Ticks::detect([0.0, 1.0, 2.0, 10.0]), Ticks::Whole);
    assert_eq!(Ticks::detect([0.0, 1.5]), Ticks::Decimal);
    assert_eq!(Ticks::detect([f64::NAN, 3.0]), Ticks::Whole);
    assert_eq!(Ticks::detect(std::iter::empty()), Ticks::Decimal);
    // -0.18..3.18 holds 0, 1, 2, 3; 0.3..1.7 holds 1; 0.2..0.8 none.
    assert_eq!(Ticks::Whole.labels(&(-0.18..3.18), 6), 4);
    assert_eq!(Ticks::Whole.labels(&(-0.6..40.6), 6), 6);
    assert_eq!(Ticks::Whole.labels(&(0.3..1.7), 6), 1);
    assert_eq!(Ticks::Whole.labels(&(0.2..0.8), 6), 0);
    assert_eq!(Ticks::Decimal.labels(&(0.2..0.8), 6), 6);
}

#[test]
fn a_convergence_plot_over_rounds_ticks_whole_rounds_only() {
    // Three rounds (0 = the initial hypercube): plotters alone would tick every half round.
    let best = Line {
        label: "best observed".into(),
        colour: plots::SERIES[0],
        points: vec![(0.0, 4.2), (1.0, 3.1), (2.0, 2.95)],
    };
    let proposed = Line {
        label: "proposed".into(),
        colour: plots::SERIES[1],
        points: vec![(1.0, 3.1), (2.0, 3.4)],
    };
    let lines = [best, proposed];
    let whole = plots::line_plot("round", "objective (deg)", &lines, None).unwrap();
    assert_eq!(x_tick_labels(&whole), ["0", "1", "2"]);
    let doc = roxmltree::Document::parse(&whole).unwrap();
    // A dot per point, legend entries for both lines.
    assert_eq!(elements(&doc, "circle").len(), 5);
    let texts: Vec<String> = elements(&doc, "text")
        .iter()
        .filter_map(|n| n.text().map(|t| t.trim().to_string()))
        .collect();
    for t in ["best observed", "proposed", "round", "objective (deg)"] {
        assert!(texts.iter().any(|s| s == t), "{t}: {texts:?}");
    }
    // The same points on a measured axis get plotters' half steps.
    let decimal =
        plots::line_plot("round", "objective (deg)", &lines, Some(Ticks::Decimal)).unwrap();
    let labels = x_tick_labels(&decimal);
    assert!(labels.iter().any(|l| l.contains('.')), "{labels:?}");
    assert!(plots::line_plot("x", "y", &[], None).is_err());
}

/// A 20 x 10 map of 10 + 5 x over x in 0..2, y in 0..1: 10 at the left edge to 20 at the right.
fn ramp() -> Vec<Vec<f64>> {
    (0..20)
        .map(|i| vec![10.0 + 5.0 * (i as f64 + 0.5) * 0.1; 10])
        .collect()
}

#[test]
fn a_filled_map_has_a_colour_bar_with_its_scale_and_quantity() {
    let values = ramp();
    let points = [(0.5, 0.5), (1.5, 0.25)];
    let map = FilledMap {
        x_desc: "static friction (–)",
        y_desc: "rolling friction (–)",
        x_range: (0.0, 2.0),
        y_range: (0.0, 1.0),
        values: &values,
        quantity: "GP predicted angle (deg)",
        points: &points,
        points_label: "runs",
        chosen: Some(((1.0, 0.5), "chosen")),
    };
    let svg = plots::map_with_colour_bar(&map).unwrap();
    let doc = roxmltree::Document::parse(&svg).unwrap();
    let texts: Vec<(String, Option<&str>)> = elements(&doc, "text")
        .iter()
        .filter_map(|n| {
            n.text()
                .map(|t| (t.trim().to_string(), n.attribute("transform")))
        })
        .collect();
    // The quantity runs up the bar's side; the bar's ticks are the round values 10.25..19.75
    // holds, every 2 (nice_ticks), each once.
    let title = texts
        .iter()
        .find(|t| t.0 == "GP predicted angle (deg)")
        .unwrap();
    assert!(title.1.is_some_and(|t| t.contains("rotate")), "{title:?}");
    for tick in ["12", "14", "16", "18"] {
        assert_eq!(texts.iter().filter(|t| t.0 == tick).count(), 1, "{tick}");
    }
    for t in [
        "runs",
        "chosen",
        "static friction (–)",
        "rolling friction (–)",
    ] {
        assert!(texts.iter().any(|s| s.0 == t), "{t}");
    }
    // 200 cells, the background, 96 slices of the bar and two legend swatches at most.
    let rects = elements(&doc, "rect").len();
    assert!(
        (200 + 1 + 96..=200 + 1 + 96 + 3).contains(&rects),
        "{rects}"
    );

    // In the PNG: the bar runs from the map's blue (colour_map(0) = 40, 60, 200) at the bottom
    // to its red (220, 50, 40) at the top; the map's left column is blue, its right red.
    let img = doe::raster::render(&svg, 1.0).unwrap();
    // The middle of the bar: 128 units at the right hold it, 12 in from their edge, 22 wide.
    let bar_x = plots::SIZE.0 - 128 + 12 + 11;
    let column: Vec<[u8; 3]> = (0..plots::SIZE.1)
        .map(|y| img.get_pixel(bar_x, y).0)
        .collect();
    let near = |p: [u8; 3], q: [u8; 3]| p.iter().zip(q).all(|(a, b)| a.abs_diff(b) <= 12);
    let first = column.iter().position(|p| near(*p, [220, 50, 40])).unwrap();
    let last = column
        .iter()
        .rposition(|p| near(*p, [40, 60, 200]))
        .unwrap();
    assert!(last - first > 250, "bar from {first} to {last}");
    let row = (first + last) as u32 / 2;
    let left = (0..bar_x).find(|&x| near(img.get_pixel(x, row).0, [40, 60, 200]));
    let right = (0..bar_x - 40)
        .rev()
        .find(|&x| near(img.get_pixel(x, row).0, [220, 50, 40]));
    assert!(left.is_some() && right.is_some_and(|r| r > left.unwrap() + 300));
}

#[test]
fn a_map_without_values_or_with_ragged_columns_is_refused() {
    let empty = FilledMap {
        x_range: (0.0, 1.0),
        y_range: (0.0, 1.0),
        ..Default::default()
    };
    assert!(plots::map_with_colour_bar(&empty).is_err());
    let ragged = vec![vec![1.0, 2.0], vec![3.0]];
    let map = FilledMap {
        values: &ragged,
        ..empty.clone()
    };
    assert!(plots::map_with_colour_bar(&map).is_err());
    // A flat map still draws, its bar labelled with the one value.
    let flat = vec![vec![7.0; 3]; 3];
    let map = FilledMap {
        values: &flat,
        quantity: "y",
        ..empty
    };
    let svg = plots::map_with_colour_bar(&map).unwrap();
    assert!(
        svg.contains(">7<") || svg.contains(">\n7\n<"),
        "the bar's one tick"
    );
}
