//! The text tables of `demcal doe analyze` and `optimize`: columns stay in line whatever the
//! length of the factor names, and statistics that cannot be computed read "N/A" with a note
//! saying why.

use doe::commands::{self, DesignRequest, ModelRequest, OptimizeRequest};
use doe::{Curvature, DataTable, Experiment, FactorColumns, Fit, ModelOrder};

/// 40 characters.
const LONG: &str = "bond_normal_stiffness_of_the_stalk_cells";

fn temp_file(name: &str, text: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("demcal-report-text-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

/// A central composite design over the long-named factor and two short ones, with a quadratic
/// response and a fixed wobble so that the residual error is not zero.
fn long_name_data() -> std::path::PathBuf {
    let req = DesignRequest {
        kind: "ccd".into(),
        factors: format!("{LONG}:1e6:1e8:log,mu:0.2:0.6,e:0.1:0.5"),
        center_points: Some(4),
        seed: 3,
        ..Default::default()
    };
    let (d, f) = commands::make_design(&req).unwrap();
    let csv = commands::design_csv(&d, &f, 3);
    let t = DataTable::parse("design.csv", &csv).unwrap();
    let coded: Vec<Vec<f64>> = [LONG, "mu", "e"]
        .iter()
        .map(|c| t.column(c).unwrap())
        .collect();
    let mut out = format!("{},y\n", t.headers.join(","));
    for (i, row) in t.rows.iter().enumerate() {
        let (a, b, c) = (coded[0][i], coded[1][i], coded[2][i]);
        let wobble = 0.3 * ((i * 7 % 5) as f64 - 2.0);
        let y = 30.0 + 2.0 * a - 1.5 * b + 0.8 * c + 1.2 * a * b - 2.0 * a * a + wobble;
        out.push_str(&format!("{},{y}\n", row.join(",")));
    }
    temp_file("long.csv", &out)
}

/// The lines from the one starting with `first` to the one starting with `last`.
fn block<'a>(text: &'a str, first: &str, last: &str) -> Vec<&'a str> {
    let lines: Vec<&str> = text.lines().collect();
    let a = lines.iter().position(|l| l.starts_with(first)).unwrap();
    let b = a + lines[a..].iter().position(|l| l.starts_with(last)).unwrap();
    lines[a..=b].to_vec()
}

/// Checks that every line of `table` (its header first) has each right-aligned column `titles`
/// ending at the char where the header's title ends, with a space (or the line's end) after it:
/// the columns sit at the same positions on every line. Columns in `always` must be filled on every line.
fn assert_aligned(table: &[&str], titles: &[&str], always: &[&str]) {
    let header: Vec<char> = table[0].chars().collect();
    let find = |t: &str| {
        let t: Vec<char> = t.chars().collect();
        header.windows(t.len()).position(|w| w == t).unwrap()
    };
    for line in table {
        let c: Vec<char> = line.chars().collect();
        for t in titles {
            let start = find(t);
            let end = start + t.chars().count();
            assert!(
                c.get(end).is_none_or(|ch| *ch == ' '),
                "'{t}' spills over at char {end}:\n{line}"
            );
            let filled = c.get(end - 1).is_some_and(|ch| *ch != ' ');
            let blank = c.iter().skip(start).take(end - start).all(|ch| *ch == ' ');
            assert!(filled || blank, "'{t}' not right-aligned:\n{line}");
            if always.contains(t) {
                assert!(filled, "'{t}' empty:\n{line}");
            }
        }
    }
}

#[test]
fn a_forty_character_factor_name_keeps_the_tables_in_line() {
    assert_eq!(LONG.chars().count(), 40);
    let data = long_name_data();
    let req = ModelRequest {
        data: data.clone(),
        responses: vec!["y".into()],
        model: Some("quadratic".into()),
        ..Default::default()
    };
    let text = commands::analyze(&req, false, None).unwrap();
    let anova = block(&text, "Source", "Cor Total");
    // Model, 9 terms, residual, lack of fit, pure error and the header around them.
    assert_eq!(anova.len(), 1 + 1 + 9 + 3 + 1, "{text}");
    let interaction = format!("{LONG}*mu");
    assert!(anova
        .iter()
        .any(|l| l.starts_with(&format!("{interaction}  "))));
    assert!(anova.iter().any(|l| l.starts_with(&format!("{LONG}^2  "))));
    assert_aligned(
        &anova,
        &["Sum of Squares", "df", "Mean Square", "F-value", "p-value"],
        &["Sum of Squares", "df"],
    );
    // The name column is as wide as the longest name (the 43-char interaction) and two spaces.
    let sum_col = anova[0].find("Sum of Squares").unwrap();
    let widest = anova[1..].iter().map(|l| l.find("  ").unwrap()).max();
    assert_eq!(widest, Some(interaction.len()));
    assert!(sum_col >= interaction.len() + 2, "{}", anova[0]);
    let coefficients = block(&text, "Term", "e^2");
    assert_eq!(coefficients.len(), 11, "{text}");
    assert_aligned(
        &coefficients,
        &["Estimate", "df", "Std Error", "95% CI Low", "95% CI High"],
        &["Estimate", "df", "Std Error", "95% CI Low", "95% CI High"],
    );

    // The optimisation's solutions: a header of long names over short numbers.
    let opt = OptimizeRequest {
        goals: vec!["y:target=31".into()],
        solutions: 3,
        starts: 20,
        seed: 1,
    };
    let text = commands::optimize(&req, &opt, false).unwrap();
    let title = format!("{LONG} (actual)");
    let table = block(&text, "#", "3");
    assert_eq!(table.len(), 4, "{text}");
    assert!(table[0].contains(&title));
    assert_aligned(
        &table,
        &[&title, "mu (actual)", "e (actual)", "y", "desirability"],
        &[&title, "mu (actual)", "e (actual)", "y", "desirability"],
    );
    let _ = std::fs::remove_file(data);
}

fn fit_of(csv: &str, order: ModelOrder, k: usize) -> Fit {
    let t = DataTable::parse("data.csv", csv).unwrap();
    let e = Experiment::from_table(&t, "y", &FactorColumns::Default).unwrap();
    Fit::new(&e, &order.terms(k), Curvature::Auto).unwrap()
}

/// The value after `label` on the line of the statistics that holds it.
fn statistic<'a>(report: &'a str, label: &str) -> &'a str {
    let line = report
        .lines()
        .find(|l| l.contains(label))
        .unwrap_or_else(|| panic!("{label}: {report}"));
    let rest = &line[line.find(label).unwrap() + label.len()..];
    rest.split("  ")
        .find(|s| !s.trim().is_empty())
        .unwrap()
        .trim()
}

#[test]
fn predicted_r2_of_a_run_with_leverage_one_reads_na_with_the_reason() {
    // One factor at -1 and +1 (twice each) and one centre run: only the centre run tells the
    // A² coefficient apart from the intercept, so the quadratic passes through it whatever it
    // measures (leverage 1) and PRESS, which predicts each run from the others, is not defined.
    let f = fit_of(
        "A,y\n-1,1.0\n-1,1.2\n1,3.1\n1,2.9\n0,2.5\n",
        ModelOrder::Quadratic,
        1,
    );
    assert!((f.leverage[4] - 1.0).abs() < 1e-9, "{:?}", f.leverage);
    assert!(f.leverage[..4].iter().all(|h| (h - 0.5).abs() < 1e-9));
    assert_eq!(f.runs_with_leverage_one(), [5]);
    assert!(f.pred_r2.is_none() && f.press.is_none());
    let report = f.report();
    assert_eq!(statistic(&report, "Predicted R²"), "N/A", "{report}");
    assert_eq!(statistic(&report, "PRESS"), "N/A", "{report}");
    // The rest is defined: the residuals are ±0.1 at the four corner runs, so R² = 1 - 0.04 /
    // 3.812 (the squares about the mean 2.14), and Adeq Precision is the predicted range
    // 3.0 - 1.1 over sqrt(p MSE / n) = sqrt(3 x 0.02 / 5).
    let r2: f64 = statistic(&report, "R²").parse().unwrap();
    assert!((r2 - (1.0 - 0.04 / 3.812)).abs() < 6e-5, "{report}");
    let adeq: f64 = statistic(&report, "Adeq Precision").parse().unwrap();
    assert!((adeq - 1.9 / 0.012f64.sqrt()).abs() < 6e-5, "{report}");
    let notes = f.not_available_notes();
    assert_eq!(notes.len(), 1, "{notes:?}");
    assert!(notes[0].starts_with("PRESS and Predicted R² are N/A: leverage 1.0000 at run(s) 5;"));
    assert!(report.contains(&format!("Note: {}", notes[0])), "{report}");
}

#[test]
fn adeq_precision_of_an_exact_fit_reads_na_with_the_reason() {
    // y = 1 + 2A + 3B exactly: no residual error, so F, p and Adeq Precision are undefined,
    // while PRESS (zero) and Predicted R² (one) are. (Two centre runs: with one, the curvature
    // term would pass through it, leverage 1.)
    let f = fit_of(
        "A,B,y\n-1,-1,-4\n1,-1,0\n-1,1,2\n1,1,6\n0,0,1\n0,0,1\n",
        ModelOrder::Linear,
        2,
    );
    assert!(f.adeq_precision.is_none() && f.model.f.is_none());
    let report = f.report();
    assert_eq!(statistic(&report, "Adeq Precision"), "N/A", "{report}");
    let pred: f64 = statistic(&report, "Predicted R²").parse().unwrap();
    assert!((pred - 1.0).abs() < 1e-4, "{report}");
    let notes = f.not_available_notes();
    assert_eq!(notes.len(), 1, "{notes:?}");
    assert!(notes[0].starts_with("Adeq Precision is N/A: the model fits every run exactly"));
    assert!(report.contains(&format!("Note: {}", notes[0])));
    // A fit with every statistic defined has no notes.
    let g = fit_of(
        "A,B,y\n-1,-1,-4.1\n1,-1,0.2\n-1,1,2.1\n1,1,5.8\n0,0,1.1\n0,0,0.9\n",
        ModelOrder::Linear,
        2,
    );
    assert!(g.not_available_notes().is_empty());
    assert!(!g.report().contains("N/A"));
}
