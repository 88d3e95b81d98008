//! Type III ANOVA against statsmodels (`anova_lm(ols(...), typ=3)`) on three further data sets:
//! a Box-Behnken design, an unbalanced replicated factorial (one run lost, so the types of sums of
//! squares differ) and scattered runs with a partial quadratic model. The data files and the
//! numbers below come from `python3 tools/doe/statsmodels_anova.py` (statsmodels 0.15.0).

use doe::model::parse_terms;
use doe::{Curvature, DataTable, Experiment, FactorColumns, Fit};

struct Expected {
    file: &'static str,
    terms: &'static str,
    /// (name, sum_sq, F, p) per term.
    rows: &'static [(&'static str, f64, f64, f64)],
    residual: (f64, usize),
    r2: f64,
    adj_r2: f64,
}

const CASES: &[Expected] = &[
    Expected {
        file: include_str!("data/bbd3.csv"),
        terms: "A,B,C,AB,AC,BC,A^2,B^2,C^2",
        rows: &[
            ("A", 49.52278414, 222.5934717, 2.448175528e-05),
            ("B", 13.75739383, 61.83630642, 0.0005342485175),
            ("C", 1.900306317, 8.5414378, 0.03291521227),
            ("AB", 8.903715904, 40.02014565, 0.001454924455),
            ("AC", 0.1065999645, 0.4791422089, 0.5196352519),
            ("BC", 0.3460045331, 1.555210426, 0.2675981061),
            ("A^2", 18.54916364, 83.37420448, 0.0002639205935),
            ("B^2", 0.02413039177, 0.1084605353, 0.7552517669),
            ("C^2", 6.19779999, 27.85767886, 0.003250193531),
        ],
        residual: (1.112404235, 5),
        r2: 0.9891157924,
        adj_r2: 0.9695242188,
    },
    Expected {
        file: include_str!("data/factorial_unbalanced.csv"),
        terms: "A,B,C,AB,AC,BC",
        rows: &[
            ("A", 20.4326355, 121.3053713, 4.109536534e-06),
            ("B", 4.462684231, 26.4942605, 0.0008772731717),
            ("C", 5.231926181, 31.06113002, 0.0005264389463),
            ("AB", 0.2257192238, 1.34005984, 0.2804144302),
            ("AC", 1.918775085, 11.39146852, 0.009711538174),
            ("BC", 0.01813507776, 0.1076651292, 0.7512412893),
        ],
        residual: (1.34751728, 8),
        r2: 0.9637429972,
        adj_r2: 0.9365502451,
    },
    Expected {
        file: include_str!("data/scattered4.csv"),
        terms: "A,B,C,D,AB,A^2,C^2",
        rows: &[
            ("A", 6.5749183, 96.72081332, 1.633510434e-09),
            ("B", 2.114213715, 31.10129445, 1.319524527e-05),
            ("C", 0.4802296504, 7.064453161, 0.01437074083),
            ("D", 0.2114578165, 3.110665572, 0.09166569263),
            ("AB", 1.106682403, 16.27993189, 0.0005540265182),
            ("A^2", 1.481954075, 21.80039308, 0.0001177407069),
            ("C^2", 0.006922301389, 0.1018310175, 0.7526534879),
        ],
        residual: (1.495523018, 22),
        r2: 0.9040996806,
        adj_r2: 0.8735859427,
    },
];

fn close(got: f64, want: f64, what: &str) {
    // statsmodels' numbers are printed to 10 significant digits.
    assert!(
        (got - want).abs() <= 1e-8 * want.abs() + 1e-15,
        "{what}: got {got}, statsmodels {want}"
    );
}

#[test]
fn type_three_anova_matches_statsmodels() {
    for case in CASES {
        let table = DataTable::parse("data.csv", case.file).unwrap();
        let exp = Experiment::from_table(&table, "y", &FactorColumns::Default).unwrap();
        let terms = parse_terms(case.terms, &exp.factor_names).unwrap();
        let fit = Fit::new(&exp, &terms, Curvature::Auto).unwrap();
        assert!(fit.curvature.is_none());
        assert_eq!(fit.anova_terms.len(), case.rows.len());
        for (row, &(name, ss, f, p)) in fit.anova_terms.iter().zip(case.rows) {
            assert_eq!(row.name, name);
            close(row.sum_sq, ss, &format!("{name} sum_sq"));
            close(row.f.unwrap(), f, &format!("{name} F"));
            close(row.p.unwrap(), p, &format!("{name} p"));
        }
        close(fit.residual.sum_sq, case.residual.0, "residual");
        assert_eq!(fit.residual.df, case.residual.1);
        close(fit.r2, case.r2, "R^2");
        close(fit.adj_r2, case.adj_r2, "adjusted R^2");
    }
}
