//! The `demcal doe` work end to end at library level: a design written as CSV, a response added,
//! analysed back with actual-unit equations; goals parsed; errors that name what is wrong.

use doe::commands::{self, DesignRequest, ModelRequest, OptimizeRequest};
use doe::{DataTable, Experiment, FactorColumns, Fit, ModelOrder};

fn design(kind: &str, factors: &str, centres: Option<usize>) -> String {
    let req = DesignRequest {
        kind: kind.into(),
        factors: factors.into(),
        center_points: centres,
        seed: 3,
        ..Default::default()
    };
    let (d, f) = commands::make_design(&req).unwrap();
    commands::design_csv(&d, &f, 3)
}

/// Appends a response column computed from the actual columns.
fn with_response(csv: &str, name: &str, f: impl Fn(&[f64]) -> f64) -> String {
    let t = DataTable::parse("design.csv", csv).unwrap();
    let actual: Vec<String> = t
        .headers
        .iter()
        .filter(|h| h.ends_with("_actual"))
        .cloned()
        .collect();
    let cols: Vec<Vec<f64>> = actual.iter().map(|c| t.column(c).unwrap()).collect();
    let mut out = format!("{},{name}\n", t.headers.join(","));
    for (i, row) in t.rows.iter().enumerate() {
        let x: Vec<f64> = cols.iter().map(|c| c[i]).collect();
        out.push_str(&format!("{},{}\n", row.join(","), f(&x)));
    }
    out
}

fn temp_file(name: &str, text: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("demcal-doe-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

#[test]
fn design_csv_round_trips_into_an_actual_unit_equation() {
    // A quadratic in actual units, one factor logarithmic: y = 3 + 20 mu - 15 mu^2 + 2 e
    // + 4 mu e + 0.5 log10(k) - 0.25 log10(k)^2.
    let csv = design("ccd", "mu:0.2:0.6,e:0.1:0.5,k:1e6:1e8:log", Some(4));
    let truth = |x: &[f64]| {
        let (mu, e, lk) = (x[0], x[1], x[2].log10());
        3.0 + 20.0 * mu - 15.0 * mu * mu + 2.0 * e + 4.0 * mu * e + 0.5 * lk - 0.25 * lk * lk
    };
    let data = with_response(&csv, "y", truth);
    let t = DataTable::parse("d.csv", &data).unwrap();
    let exp = Experiment::from_table(&t, "y", &FactorColumns::Default).unwrap();
    assert_eq!(exp.factor_names, ["mu", "e", "k"]);
    let f = exp
        .factors
        .as_ref()
        .expect("ranges recovered from the _actual columns");
    assert_eq!(f[2].scale, doe::Scale::Log);
    assert!((f[2].low / 1e6 - 1.0).abs() < 1e-9 && (f[0].high - 0.6).abs() < 1e-9);
    let fit = Fit::new(&exp, &ModelOrder::Quadratic.terms(3), doe::Curvature::Auto).unwrap();
    let eq = fit.actual_equation().unwrap();
    let names = fit.actual_variable_names();
    let coef = |n: &str| {
        eq.iter()
            .find(|(t, _)| t.name(&names) == n)
            .map(|(_, v)| *v)
            .unwrap_or_else(|| panic!("no term {n}"))
    };
    for (name, want) in [
        ("Intercept", 3.0),
        ("mu", 20.0),
        ("mu^2", -15.0),
        ("e", 2.0),
        ("mu*e", 4.0),
        ("log10(k)", 0.5),
        ("log10(k)^2", -0.25),
        ("e^2", 0.0),
        ("e*log10(k)", 0.0),
    ] {
        assert!(
            (coef(name) - want).abs() < 1e-6,
            "{name}: {} vs {want}",
            coef(name)
        );
    }
    // Predictions in actual units agree with the truth anywhere in the box.
    let x = [0.33, 0.27, 3.3e6];
    assert!((fit.predict_actual(&x).unwrap() - truth(&x)).abs() < 1e-8);
}

#[test]
fn analyze_json_has_the_documented_keys() {
    let p = temp_file("ccd.csv", include_str!("data/silage-repose-ccd.csv"));
    let req = ModelRequest {
        data: p,
        responses: vec!["angle_deg".into()],
        model: Some("quadratic".into()),
        alpha_out: 0.1,
        ..Default::default()
    };
    let out = commands::analyze(&req, true, None).unwrap();
    let v: serde_json::Value = serde_json::from_str(out.trim()).unwrap();
    for key in [
        "terms",
        "model",
        "residual",
        "lack_of_fit",
        "pure_error",
        "curvature",
        "total",
        "r2",
        "adj_r2",
        "pred_r2",
        "adeq_precision",
        "std_dev",
        "cv_percent",
        "coefficients_coded",
    ] {
        assert!(v.get(key).is_some(), "key {key}");
    }
    assert!(v["curvature"].is_null());
    let first = &v["terms"][0];
    for key in ["name", "sum_sq", "df", "mean_sq", "f", "p"] {
        assert!(first.get(key).is_some(), "term key {key}");
    }
    assert_eq!(v["terms"][3]["name"], "DE");
    assert_eq!(v["total"]["df"], 22);
    assert!((v["coefficients_coded"]["G^2"].as_f64().unwrap() - 1.390).abs() < 5e-4);
}

#[test]
fn optimize_hits_a_target_and_ranks_solutions() {
    let p = temp_file("ccd-opt.csv", include_str!("data/silage-repose-ccd.csv"));
    let req = ModelRequest {
        data: p,
        responses: vec!["angle_deg".into()],
        model: Some("quadratic".into()),
        reduce: true,
        alpha_out: 0.1,
        ..Default::default()
    };
    let opt = OptimizeRequest {
        goals: vec![
            "angle_deg:target=38.65".into(),
            "D:range:lower=-0.5:upper=0.5".into(),
        ],
        solutions: 5,
        starts: 40,
        seed: 1,
    };
    let out = commands::optimize(&req, &opt, true).unwrap();
    let v: serde_json::Value = serde_json::from_str(out.trim()).unwrap();
    let sols = v["solutions"].as_array().unwrap();
    assert_eq!(sols.len(), 5);
    for s in sols {
        assert!((s["responses"][0].as_f64().unwrap() - 38.65).abs() < 1e-3);
        assert!(s["desirability"].as_f64().unwrap() > 0.999);
        assert!(s["coded"][0].as_f64().unwrap().abs() <= 0.5 + 1e-12);
    }
    // Maximising the angle puts every factor at its high end (all main effects positive). The
    // upper limit defaults to the largest observed angle, which the model exceeds on a plateau of
    // desirability 1; raising it makes the corner the one best solution.
    let opt = OptimizeRequest {
        goals: vec!["maximize:upper=60".into()],
        solutions: 3,
        starts: 20,
        seed: 2,
    };
    let out = commands::optimize(&req, &opt, true).unwrap();
    let v: serde_json::Value = serde_json::from_str(out.trim()).unwrap();
    let best = &v["solutions"][0];
    for j in 0..3 {
        assert!(
            (best["coded"][j].as_f64().unwrap() - 1.0).abs() < 1e-6,
            "{best}"
        );
    }
}

#[test]
fn goals_parse_with_their_options() {
    let (n, c) =
        commands::parse_goal("angle:target=38.65:lower=35:upper=42:importance=5", None).unwrap();
    assert_eq!(n, "angle");
    assert_eq!(c.goal, doe::optimize::Goal::Target(38.65));
    assert_eq!((c.lower, c.upper, c.importance), (35.0, 42.0, 5));
    let (n, c) = commands::parse_goal("max:weight=2", Some("y")).unwrap();
    assert_eq!(
        (n.as_str(), c.weight_lower, c.weight_upper),
        ("y", 2.0, 2.0)
    );
    assert!(commands::parse_goal("y:best", None)
        .unwrap_err()
        .contains("expected a goal"));
    assert!(commands::parse_goal("y:max:importance=9", None)
        .unwrap_err()
        .contains("1 to 5"));
}

fn analyze_error(csv: &str, response: &str, model: Option<&str>) -> String {
    let p = temp_file(&format!("err-{}.csv", csv.len()), csv);
    let req = ModelRequest {
        data: p,
        responses: vec![response.into()],
        model: model.map(String::from),
        alpha_out: 0.1,
        ..Default::default()
    };
    commands::analyze(&req, false, None).unwrap_err()
}

#[test]
fn errors_say_what_is_wrong() {
    let e = analyze_error("A,B,y\n-1,-1,1\n1,-1,2\n-1,1,3\n1,1,5\n", "angle", None);
    assert!(
        e.contains("column 'angle' not found (columns: A, B, y)"),
        "{e}"
    );
    let e = analyze_error("A,B,y\n-1,-1,1\n1,-1,2\n-1,oops,3\n1,1,5\n", "y", None);
    assert!(
        e.ends_with("row 4, column 'B': 'oops' is not a number"),
        "{e}"
    );
    let e = analyze_error("A,B,y\n-1,-1,1\n1,-1,2\n-1,1,3\n1,1,5\n", "y", Some("2fi"));
    assert!(
        e.contains("too few runs for the model: it has 4 coefficients"),
        "{e}"
    );
    let e = analyze_error("A,B,y\n-1,-1,4\n1,-1,4\n-1,1,4\n1,1,4\n0,0,4\n", "y", None);
    assert!(
        e.contains("response 'y' is constant (4.000) in all 5 runs"),
        "{e}"
    );
    // A half fraction with D = ABC: the 2FI model aliases CD with AB.
    let mut csv = String::from("A,B,C,D,y\n");
    for i in 0..8 {
        let (a, b, c) = (
            if i & 1 == 1 { 1 } else { -1 },
            if i & 2 == 2 { 1 } else { -1 },
            if i & 4 == 4 { 1 } else { -1 },
        );
        csv.push_str(&format!("{a},{b},{c},{},{}\n", a * b * c, i * i));
    }
    for _ in 0..3 {
        csv.push_str("0,0,0,0,20\n");
    }
    let e = analyze_error(&csv, "y", Some("A,B,C,D,AB,CD"));
    assert!(e.contains("term CD is aliased (CD = AB)"), "{e}");
    let e = analyze_error(&csv, "y", Some("A,B,Q"));
    assert!(e.contains("'Q' is not a factor"), "{e}");
    // Backward elimination needs a significance level.
    let p = temp_file("alpha-out.csv", &csv);
    let req = ModelRequest {
        data: p,
        responses: vec!["y".into()],
        model: Some("linear".into()),
        reduce: true,
        alpha_out: f64::NAN,
        ..Default::default()
    };
    assert_eq!(
        commands::analyze(&req, false, None).unwrap_err(),
        "--alpha-out NaN: expected a number between 0 and 1"
    );
}

#[test]
fn steepest_path_is_written_in_order() {
    let req = DesignRequest {
        kind: "steepest".into(),
        factors: "D:0.1:0.5,E:0.2:0.8,G:1:3".into(),
        direction: Some("1,-0.5,0".into()),
        step: Some(0.5),
        runs: Some(4),
        seed: 9,
        ..Default::default()
    };
    let (d, f) = commands::make_design(&req).unwrap();
    let csv = commands::design_csv(&d, &f, 9);
    let lines: Vec<&str> = csv.lines().collect();
    assert_eq!(lines[1], "1,1,center,0,0,0,0.3,0.5,2");
    assert_eq!(lines[5], "5,5,path,2,-1,0,0.7,0.2,2");
    let bad = DesignRequest {
        direction: Some("1,2".into()),
        ..req
    };
    assert!(commands::make_design(&bad)
        .unwrap_err()
        .contains("2 numbers for 3 factors"));
}

fn design_error(req: DesignRequest) -> String {
    commands::make_design(&req).unwrap_err()
}

/// Sizes are checked before anything is allocated: a billion-run Latin hypercube (7.8 GB) and
/// its friends are refused at once with the limit.
#[test]
fn absurd_design_sizes_are_refused_with_the_limit() {
    let lhs = DesignRequest {
        kind: "lhs".into(),
        factors: "3".into(),
        runs: Some(1_000_000_000),
        ..Default::default()
    };
    assert_eq!(
        design_error(lhs.clone()),
        "--runs 1000000000: at most 100000 runs"
    );
    assert_eq!(
        design_error(DesignRequest {
            kind: "random".into(),
            ..lhs.clone()
        }),
        "--runs 1000000000: at most 100000 runs"
    );
    assert_eq!(
        design_error(DesignRequest {
            kind: "ccd".into(),
            runs: None,
            center_points: Some(1_000_000_000),
            ..lhs.clone()
        }),
        "--centers 1000000000: at most 100000 centre points"
    );
    assert_eq!(
        design_error(DesignRequest {
            kind: "pb".into(),
            runs: Some(2048),
            ..lhs.clone()
        }),
        "Plackett-Burman: 2048 runs asked, at most 1024"
    );
    assert_eq!(
        design_error(DesignRequest {
            kind: "steepest".into(),
            direction: Some("1,1,1".into()),
            ..lhs.clone()
        }),
        "--runs 1000000000: at most 100000 runs"
    );
    // The maximin search compares every pair of runs; beyond 10 000 runs it would not end.
    assert_eq!(
        design_error(DesignRequest {
            runs: Some(20_000),
            ..lhs.clone()
        }),
        "--lhs maximin: at most 10000 runs (the search compares every pair of runs); use --lhs random or centred for more"
    );
    // Within the limits these are quick: 20 000 random-order runs.
    let (d, _) = commands::make_design(&DesignRequest {
        runs: Some(20_000),
        lhs: Some("centred".into()),
        ..lhs
    })
    .unwrap();
    assert_eq!(d.runs.len(), 20_000);
}

/// A maximin hypercube of thousands of runs ends in seconds (before, each of its 20 000 trial
/// swaps rescanned every pair of runs: minutes).
#[test]
fn maximin_hypercubes_end_in_bounded_time() {
    let t = std::time::Instant::now();
    let d = doe::design::latin_hypercube(3, 2000, doe::design::LhsKind::Maximin, 1).unwrap();
    assert_eq!(d.runs.len(), 2000);
    assert!(t.elapsed().as_secs_f64() < 20.0, "{:?}", t.elapsed());
}

fn optimize_error(goals: &[&str], solutions: usize, starts: usize) -> String {
    let p = temp_file(
        "ccd-opt-err.csv",
        include_str!("data/silage-repose-ccd.csv"),
    );
    let req = ModelRequest {
        data: p,
        responses: vec!["angle_deg".into()],
        model: Some("quadratic".into()),
        alpha_out: 0.1,
        ..Default::default()
    };
    let opt = OptimizeRequest {
        goals: goals.iter().map(|g| g.to_string()).collect(),
        solutions,
        starts,
        seed: 1,
    };
    commands::optimize(&req, &opt, false).unwrap_err()
}

#[test]
fn optimize_refuses_nonsense_goals_and_counts() {
    // A hundred million starts would take 5.9 GB before the search began.
    assert_eq!(
        optimize_error(&["target=38"], 5, 100_000_000),
        "--starts 100000000: at most 10000 random starts"
    );
    assert_eq!(
        optimize_error(&["target=38"], 0, 40),
        "--solutions 0: expected at least 1"
    );
    assert_eq!(
        optimize_error(&["target=nan"], 5, 40),
        "--goal 'target=nan': target value is not a finite number"
    );
    assert_eq!(
        optimize_error(&["angle_deg:target=38:upper=inf"], 5, 40),
        "--goal 'angle_deg:target=38:upper=inf': upper: 'inf' is not a finite number"
    );
    assert_eq!(
        optimize_error(&["maximize:weight=nan"], 5, 40),
        "--goal 'maximize:weight=nan': weight: 'nan' is not a finite number"
    );
    // A factor's limits upside down used to panic in f64::clamp (issue 40).
    assert_eq!(
        optimize_error(&["angle_deg:target=40", "D:range:lower=1:upper=-1"], 5, 40),
        "--goal 'D:range:lower=1:upper=-1': goal on 'D': expected lower <= upper, got 1 and -1"
    );
}

/// A cell too large to square and sum (1e300) is refused with its file, row and column, and a
/// fit that still comes out non-finite says so instead of printing NaN.
#[test]
fn overflowing_data_is_refused_with_file_row_and_column() {
    let e = analyze_error(
        "A,B,y\n-1,-1,1\n1,-1,2\n-1,1,1e300\n1,1,5\n0,0,3\n",
        "y",
        Some("linear"),
    );
    assert!(
        e.ends_with("row 4, column 'y': 1e300 is too large (values beyond ±1e150 overflow the sums of squares)"),
        "{e}"
    );
    let e = analyze_error(
        "A,B,y\n-1,-1,1\n1,-1,2\n-1,1e200,1\n1,1,5\n0,0,3\n",
        "y",
        Some("linear"),
    );
    assert!(e.ends_with("row 4, column 'B': 1e200 is too large (values beyond ±1e150 overflow the sums of squares)"), "{e}");
    // Through the library (a study's responses come from simulations, not a file): values whose
    // squares overflow, and values that are not numbers, are refused by the fit itself.
    let mut exp = Experiment {
        response_name: "y".into(),
        factor_names: vec!["A".into()],
        factors: None,
        coded: vec![vec![-1.0], vec![1.0], vec![0.0], vec![0.5]],
        response: vec![1e200, -1e200, 1e200, 3.0],
    };
    let e = Fit::new(&exp, &ModelOrder::Linear.terms(1), doe::Curvature::Off).unwrap_err();
    assert_eq!(
        e,
        "response 'y': the sums of squares are not finite (values up to 1e200); rescale the response or the factors"
    );
    exp.response[2] = f64::NAN;
    let e = Fit::new(&exp, &ModelOrder::Linear.terms(1), doe::Curvature::Off).unwrap_err();
    assert_eq!(e, "response 'y': run 3 is NaN, not a finite number");
}

/// Nonsense the design and data commands used to accept (issue 40): an axial distance that
/// writes inf, resolution 0, a factor name that breaks the CSV, and a table with two columns of
/// one name (the second silently never read).
#[test]
fn nonsense_designs_and_tables_are_refused() {
    let ccd = DesignRequest {
        kind: "ccd".into(),
        factors: "3".into(),
        alpha: Some("1e308".into()),
        ..Default::default()
    };
    assert_eq!(
        design_error(ccd),
        format!(
            "central composite: alpha must be a positive number up to 100, got {}",
            1e308f64
        )
    );
    let frac = DesignRequest {
        kind: "fractional".into(),
        factors: "5".into(),
        resolution: Some(0),
        ..Default::default()
    };
    assert_eq!(
        design_error(frac),
        "fractional factorial: resolution 0 asked; expected 3 (III) or more"
    );
    let named = DesignRequest {
        kind: "factorial".into(),
        factors: "a\"b:0:1,c:0:1".into(),
        ..Default::default()
    };
    assert_eq!(
        design_error(named),
        "--factors: 'a\\\"b': a factor name cannot hold a quote or a line break (it heads a CSV column)"
    );
    let e = DataTable::parse("d.csv", "A,B,A,y\n1,2,3,4\n").unwrap_err();
    assert_eq!(e, "d.csv: columns 1 and 3 are both named 'A'");
}

/// With several responses and no --factors, the other responses are not factors: a second
/// response made from the first (y2 = 2 angle + D) once fitted exactly on it (R² 1 with the
/// angle as a term).
#[test]
fn several_responses_are_not_each_others_factors() {
    let mut csv = String::new();
    for (i, line) in include_str!("data/silage-repose-ccd.csv")
        .lines()
        .enumerate()
    {
        if i == 0 {
            csv.push_str(&format!("{line},y2\n"));
            continue;
        }
        let cells: Vec<f64> = line.split(',').map(|c| c.parse().unwrap()).collect();
        csv.push_str(&format!("{line},{}\n", 2.0 * cells[4] + cells[1]));
    }
    let req = ModelRequest {
        data: temp_file("two-responses.csv", &csv),
        responses: vec!["angle_deg".into(), "y2".into()],
        model: Some("linear".into()),
        alpha_out: 0.1,
        ..Default::default()
    };
    let out = commands::analyze(&req, true, None).unwrap();
    let v: serde_json::Value = serde_json::from_str(out.trim()).unwrap();
    let fits = v.as_array().unwrap();
    assert_eq!(fits.len(), 2);
    for fit in fits {
        let terms: Vec<&str> = fit["terms"]
            .as_array()
            .unwrap()
            .iter()
            .map(|t| t["name"].as_str().unwrap())
            .collect();
        assert_eq!(terms, ["D", "E", "G"], "{}", fit["response"]);
    }
    // y2's linear fit is twice the angle's, plus D's coefficient 1: its R² is not 1.
    let r2 = fits[1]["r2"].as_f64().unwrap();
    assert!(r2 < 0.99, "R² {r2}");
    let a = fits[0]["coefficients_coded"]["D"].as_f64().unwrap();
    let b = fits[1]["coefficients_coded"]["D"].as_f64().unwrap();
    assert!((b - (2.0 * a + 1.0)).abs() < 1e-9, "{a} {b}");
}
