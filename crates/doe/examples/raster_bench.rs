//! Times `doe::raster::svg_to_png` on two typical report figures (the contour plot of the silage
//! CCD and the Pareto chart of the silage Plackett-Burman screening) at the reports' scale, and
//! writes their SVGs and PNGs into the directory given (default: the temporary directory), so a
//! change to the rasteriser can be measured and looked at:
//!
//!     cargo run -p demcal-doe --profile test --example raster_bench -- /tmp/raster 20

use doe::plots::{self, ContourMarks, Labels};
use doe::{Curvature, DataTable, Experiment, FactorColumns, Fit, ModelOrder};

const PB: &str = include_str!("../tests/data/silage-repose-pb.csv");
const CCD: &str = include_str!("../tests/data/silage-repose-ccd.csv");
/// The report's PNG scale (`study::report_figures::PNG_SCALE`).
const SCALE: f32 = 2.0;

fn fit(text: &str, order: ModelOrder, k: usize) -> Fit {
    let t = DataTable::parse("data.csv", text).unwrap();
    let e = Experiment::from_table(&t, "angle_deg", &FactorColumns::Default).unwrap();
    Fit::new(&e, &order.terms(k), Curvature::Auto).unwrap()
}

fn main() {
    let mut args = std::env::args().skip(1);
    let dir = args
        .next()
        .map(std::path::PathBuf::from)
        .unwrap_or_else(std::env::temp_dir);
    let repeats: usize = args.next().and_then(|n| n.parse().ok()).unwrap_or(20);
    std::fs::create_dir_all(&dir).unwrap();
    let ccd = fit(CCD, ModelOrder::Quadratic, 3);
    let mut labels = Labels::of(&ccd);
    labels.response = "angle of repose (deg)".into();
    let mut marks = ContourMarks::centre(3);
    marks.target = Some((40.0, "target 40 deg".into()));
    marks.optimum = Some((vec![0.3, -0.4, 0.0], "optimum".into()));
    let figures = [
        (
            "contour",
            plots::contour_plot(&ccd, &labels, 0, 1, &marks).unwrap(),
        ),
        (
            "pareto",
            plots::pareto_chart(&fit(PB, ModelOrder::Linear, 8)).unwrap(),
        ),
    ];
    for (name, svg) in &figures {
        let mut png = Vec::new();
        let start = std::time::Instant::now();
        for _ in 0..repeats {
            png = doe::raster::svg_to_png(svg, SCALE).unwrap();
        }
        let ms = start.elapsed().as_secs_f64() * 1e3 / repeats as f64;
        std::fs::write(dir.join(format!("{name}.svg")), svg).unwrap();
        std::fs::write(dir.join(format!("{name}.png")), &png).unwrap();
        println!(
            "{name}: {ms:.1} ms per PNG (mean of {repeats}), {} bytes of PNG, {} bytes of SVG",
            png.len(),
            svg.len()
        );
    }
}
