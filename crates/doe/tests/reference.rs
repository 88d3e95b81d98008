//! The two reference analyses of docs/calibration.md (data in tests/data), to the
//! printed precision: each value must round to the printed digits, so the tolerance is half a unit
//! in the last place.

use doe::model::parse_terms;
use doe::{Curvature, DataTable, Experiment, FactorColumns, Fit, ModelOrder};

const PB: &str = include_str!("data/silage-repose-pb.csv");
const CCD: &str = include_str!("data/silage-repose-ccd.csv");

fn experiment(text: &str) -> Experiment {
    let t = DataTable::parse("data.csv", text).unwrap();
    Experiment::from_table(&t, "angle_deg", &FactorColumns::Default).unwrap()
}

/// `printed` as written in the spec: the number of decimals sets the tolerance.
fn printed(got: f64, printed: &str, what: &str) {
    let want: f64 = printed.parse().unwrap();
    let decimals = printed.split('.').nth(1).map_or(0, str::len) as i32;
    let tol = 0.5 * 10f64.powi(-decimals) + 1e-12;
    assert!(
        (got - want).abs() <= tol,
        "{what}: got {got}, printed {printed} (tolerance {tol})"
    );
}

fn term<'a>(fit: &'a Fit, name: &str) -> &'a doe::fit::AnovaRow {
    fit.anova_terms
        .iter()
        .find(|r| r.name == name)
        .unwrap_or_else(|| panic!("no term {name}"))
}

#[test]
fn plackett_burman_first_order_with_curvature() {
    let e = experiment(PB);
    assert_eq!(e.factor_names, ["A", "B", "C", "D", "E", "F", "G", "H"]);
    let f = Fit::new(&e, &ModelOrder::Linear.terms(8), Curvature::Auto).unwrap();
    printed(f.model.sum_sq, "63.98", "model SS");
    assert_eq!(f.model.df, 8);
    printed(f.residual.sum_sq, "1.26", "residual SS");
    assert_eq!(f.residual.df, 3);
    printed(f.total_sum_sq, "65.50", "total SS");
    assert_eq!(f.total_df, 12);
    assert!(f.curvature.is_some());
    assert!(f.lack_of_fit.is_none(), "one centre point: no pure error");
    for (name, ss, p) in [
        ("A", "0.6674", "0.2967"),
        ("B", "0.1610", "0.5798"),
        ("C", "0.3434", "0.4327"),
        ("D", "6.89", "0.0272"),
        ("E", "46.93", "0.0018"),
        ("F", "1.04", "0.2140"),
        ("G", "5.24", "0.0386"),
        ("H", "2.72", "0.0845"),
    ] {
        let r = term(&f, name);
        printed(r.sum_sq, ss, &format!("{name} SS"));
        printed(r.p.unwrap(), p, &format!("{name} p"));
    }
    // Effects are mean(high) - mean(low); with a balanced design they are twice the coefficients.
    for (e, c) in f.effects.iter().zip(&f.coefficients[1..]) {
        assert!((e.effect - 2.0 * c.estimate).abs() < 1e-12);
    }
    // % contribution: each effect's sum of squares over the corrected total, as Design-Expert
    // lists it; in this orthogonal design the contrast's SS is the ANOVA's.
    for e in &f.effects {
        let from_anova = 100.0 * term(&f, &e.name).sum_sq / f.total_sum_sq;
        assert!(
            (e.contribution_percent - from_anova).abs() < 1e-9,
            "{}: {} against {from_anova}",
            e.name,
            e.contribution_percent
        );
    }
    // With the curvature and the residual, the contributions account for the whole variation.
    let rest = f.residual.sum_sq + f.curvature.as_ref().map_or(0.0, |c| c.sum_sq);
    let whole: f64 = f
        .effects
        .iter()
        .map(|e| e.contribution_percent)
        .sum::<f64>()
        + 100.0 * rest / f.total_sum_sq;
    assert!((whole - 100.0).abs() < 1e-9, "{whole}");
    let (t, bonf) = f.pareto_limits(0.05).unwrap();
    printed(t, "3.1824", "t(0.025, 3)");
    assert!(bonf > t);
}

#[test]
fn central_composite_full_quadratic() {
    let e = experiment(CCD);
    let f = Fit::new(&e, &ModelOrder::Quadratic.terms(3), Curvature::Auto).unwrap();
    assert!(f.curvature.is_none());
    printed(f.model.sum_sq, "590.10", "model SS");
    assert_eq!(f.model.df, 9);
    printed(f.residual.sum_sq, "39.22", "residual SS");
    assert_eq!(f.residual.df, 13);
    let lof = f.lack_of_fit.as_ref().unwrap();
    printed(lof.sum_sq, "24.41", "lack of fit SS");
    assert_eq!(lof.df, 5);
    printed(lof.p.unwrap(), "0.1073", "lack of fit p");
    let pe = f.pure_error.as_ref().unwrap();
    printed(pe.sum_sq, "14.81", "pure error SS");
    assert_eq!(pe.df, 8);
    printed(f.total_sum_sq, "629.32", "total SS");
    assert_eq!(f.total_df, 22);
    for (name, ss) in [
        ("D", "199.26"),
        ("E", "69.59"),
        ("G", "258.26"),
        ("DE", "4.98"),
        ("DG", "3.91"),
        ("EG", "7.39"),
        ("D^2", "14.43"),
        ("E^2", "2.07"),
        ("G^2", "30.69"),
    ] {
        printed(term(&f, name).sum_sq, ss, &format!("{name} SS"));
    }
    printed(term(&f, "DE").p.unwrap(), "0.2214", "DE p");
    printed(term(&f, "D^2").p.unwrap(), "0.0476", "D^2 p");
    printed(term(&f, "G^2").p.unwrap(), "0.0071", "G^2 p");
    printed(f.r2, "0.9377", "R^2");
    printed(f.adj_r2, "0.8945", "adjusted R^2");
}

#[test]
fn central_composite_reduced_by_backward_elimination() {
    let e = experiment(CCD);
    let f = Fit::reduce(
        &e,
        &ModelOrder::Quadratic.terms(3),
        Curvature::Auto,
        0.10,
        true,
    )
    .unwrap();
    assert_eq!(f.term_names(), ["Intercept", "D", "E", "G", "D^2", "G^2"]);
    printed(f.model.sum_sq, "571.76", "model SS");
    printed(f.residual.sum_sq, "57.57", "residual SS");
    assert_eq!(f.residual.df, 17);
    let lof = f.lack_of_fit.as_ref().unwrap();
    printed(lof.sum_sq, "42.76", "lack of fit SS");
    assert_eq!(lof.df, 9);
    printed(lof.p.unwrap(), "0.0996", "lack of fit p");
    for (c, want) in f
        .coefficients
        .iter()
        .zip(["39.07", "3.82", "2.26", "4.35", "0.9505", "1.39"])
    {
        printed(c.estimate, want, &format!("coefficient {}", c.name));
    }
    // The same model given as an explicit term list fits identically.
    let terms = parse_terms("D,E,G,D^2,G^2", &e.factor_names).unwrap();
    let g = Fit::new(&e, &terms, Curvature::Auto).unwrap();
    assert!((g.model.sum_sq - f.model.sum_sq).abs() < 1e-9);
    // Without hierarchy the same terms go (none of D, E, G is removable here).
    let h = Fit::reduce(
        &e,
        &ModelOrder::Quadratic.terms(3),
        Curvature::Auto,
        0.10,
        false,
    )
    .unwrap();
    assert_eq!(h.term_names(), f.term_names());
}

#[test]
fn statistics_follow_their_definitions() {
    let e = experiment(CCD);
    let f = Fit::new(&e, &ModelOrder::Quadratic.terms(3), Curvature::Auto).unwrap();
    let n = e.runs() as f64;
    // Std. Dev. = sqrt(39.22 / 13) from the spec's residual row, and C.V. = 100 Std. Dev. / 40.46
    // (the mean of the data), worked out by hand.
    printed(f.std_dev, "1.737", "Std. Dev.");
    printed(f.cv_percent, "4.29", "C.V. %");
    // PRESS by refitting without each run, against the leverage shortcut.
    let mut press = 0.0;
    for i in 0..e.runs() {
        let mut sub = e.clone();
        sub.coded.remove(i);
        sub.response.remove(i);
        let g = Fit::new(&sub, &f.terms, Curvature::Off).unwrap();
        press += (e.response[i] - g.predict_coded(&e.coded[i])).powi(2);
    }
    assert!((f.press.unwrap() - press).abs() < 1e-8 * press);
    // Adequate precision: the spec's formula with p = 10 model parameters (not counting pure
    // error or curvature) over the fitted range of the design points.
    let hi = f.predicted.iter().cloned().fold(f64::MIN, f64::max);
    let lo = f.predicted.iter().cloned().fold(f64::MAX, f64::min);
    let ap = (hi - lo) / (10.0 * 39.22 / 13.0 / n).sqrt();
    assert!((f.adeq_precision.unwrap() - ap).abs() < 1e-3 * ap);
    // Mean leverage is p / n.
    let mean_h = f.leverage.iter().sum::<f64>() / n;
    assert!((mean_h - 10.0 / n).abs() < 1e-12);
}
