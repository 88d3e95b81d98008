//! The lab side of a curve target: the `[target]` keys that name the test's curve, the lab's CSV
//! files and the normalisation, the files read (one-line errors naming the file and the line),
//! and the replicates averaged on the displacement range they all cover, with their band.
//!
//! A lab CSV has a header row; its first column is the displacement, headed `displacement_m`
//! (metres) or `displacement_mm` (millimetres); every other column is one replicate's force in
//! newtons. Several files may be given; each column of each file is a replicate.

use std::path::Path;

use crate::curve::{self, Comparison, Curve, Measures, Normalisation, COMPARE_POINTS};
use crate::file::{FileNames, NormalisationName, Number, TargetEntry};

/// Most data rows a lab file may have.
pub const MAX_ROWS: usize = 1_000_000;
/// Most replicate columns a lab file may have.
pub const MAX_COLUMNS: usize = 1000;

/// The keys of `[target]` that only a curve target takes (`file::TargetEntry` reads them).
pub const CURVE_KEYS: &[&str] = &[
    "curve",
    "lab_curves",
    "normalisation",
    "area_m2",
    "length_m",
];

/// One replicate: where it came from and its curve (m, N).
#[derive(Clone, Debug, PartialEq)]
pub struct Replicate {
    /// `file: column`.
    pub label: String,
    pub curve: Curve,
}

/// The lab's curves: the replicates, their mean on the range all cover, and the band.
#[derive(Clone, Debug, PartialEq)]
pub struct LabCurves {
    pub replicates: Vec<Replicate>,
    /// The mean curve (m, N): the single replicate itself, or the replicates' mean on 1000 evenly
    /// spaced points over the displacement range they all cover.
    pub mean: Curve,
    /// The band: the replicates' smallest and largest force at each point of the mean (equal to
    /// the mean for a single replicate).
    pub min: Vec<f64>,
    pub max: Vec<f64>,
    /// The replicates' standard deviation at each point (zero for a single replicate).
    pub std: Vec<f64>,
}

/// A `[target]` with a curve.
#[derive(Clone, Debug, PartialEq)]
pub struct CurveTarget {
    /// The test's curve response compared (`force_displacement`).
    pub curve: String,
    /// The lab files, as the study file gives them.
    pub files: Vec<String>,
    pub normalisation: Normalisation,
    pub lab: LabCurves,
}

impl CurveTarget {
    /// What each job carries to compare its curve.
    pub fn comparison(&self) -> Comparison {
        Comparison {
            curve: self.curve.clone(),
            normalisation: self.normalisation,
            lab: self.lab.mean.clone(),
        }
    }

    /// The measure `response` names (`curve_peak`, ...) of each lab replicate, normalised.
    pub fn replicate_measures(&self, response: &str) -> Vec<f64> {
        let peak = self.lab.mean.peak().1;
        self.lab
            .replicates
            .iter()
            .filter_map(|r| Measures::of(&self.normalisation.apply(&r.curve, peak)).get(response))
            .collect()
    }

    /// Reads the curve keys of `[target]` (None without `curve`); lab files are taken relative
    /// to `dir`. `err` makes the one-line error for a key.
    pub fn parse(
        t: &TargetEntry,
        dir: &Path,
        err: &dyn Fn(&str, String) -> String,
    ) -> Result<Option<CurveTarget>, String> {
        let Some(curve) = t.curve.clone() else {
            if let Some(k) = CURVE_KEYS.iter().find(|k| t.given(k)) {
                return Err(err(
                    &format!("target.{k}"),
                    "only with target.curve (the test's curve to compare, e.g. curve = \"force_displacement\")".into(),
                ));
            }
            return Ok(None);
        };
        let Some(FileNames(files)) = t.lab_curves.clone() else {
            return Err(err(
                "target.lab_curves",
                "missing: the lab's force-displacement CSV file(s), e.g. lab_curves = [\"lab/shear_1.csv\"]".into(),
            ));
        };
        let positive = |k: &str, v: Option<Number>| -> Result<Option<f64>, String> {
            v.map(|Number(a)| {
                (a.is_finite() && a > 0.0)
                    .then_some(a)
                    .ok_or_else(|| err(&format!("target.{k}"), "expected a number > 0".into()))
            })
            .transpose()
        };
        let (area, length) = (
            positive("area_m2", t.area_m2)?,
            positive("length_m", t.length_m)?,
        );
        let normalisation = match t.normalisation {
            Some(NormalisationName::None) => Normalisation::None,
            Some(NormalisationName::LabPeak) => Normalisation::LabPeak,
            Some(NormalisationName::StressStrain) => match (area, length) {
                (Some(area_m2), Some(length_m)) => Normalisation::StressStrain { area_m2, length_m },
                (None, _) => return Err(err(
                    "target.area_m2",
                    "missing: stress_strain divides the force by the specimen's cross-section area (m²)".into(),
                )),
                (_, None) => return Err(err(
                    "target.length_m",
                    "missing: stress_strain divides the displacement by the specimen's length (m)".into(),
                )),
            },
            None => {
                return Err(err(
                    "target.normalisation",
                    "missing: how curves are scaled before they are compared (\"none\", \"lab_peak\" or \"stress_strain\")".into(),
                ))
            }
        };
        if !matches!(normalisation, Normalisation::StressStrain { .. }) {
            if let Some(k) = ["area_m2", "length_m"].iter().find(|k| t.given(k)) {
                return Err(err(
                    &format!("target.{k}"),
                    "only with normalisation = \"stress_strain\"".into(),
                ));
            }
        }
        let mut replicates = Vec::new();
        for f in &files {
            replicates.extend(read_csv(&dir.join(f))?);
        }
        let lab = LabCurves::average(replicates).map_err(|e| err("target.lab_curves", e))?;
        if normalisation == Normalisation::LabPeak && lab.mean.peak().1 <= 0.0 {
            return Err(err(
                "target.normalisation",
                format!(
                    "lab_peak divides by the lab mean curve's peak, which is {} N; expected a positive force",
                    lab.mean.peak().1
                ),
            ));
        }
        Ok(Some(CurveTarget {
            curve,
            files,
            normalisation,
            lab,
        }))
    }
}

impl LabCurves {
    /// The replicates' mean and band on the displacement range they all cover.
    pub fn average(replicates: Vec<Replicate>) -> Result<LabCurves, String> {
        let first = replicates.first().ok_or("no replicate curves")?;
        if replicates.len() == 1 {
            let mean = first.curve.clone();
            let n = mean.y.len();
            return Ok(LabCurves {
                min: mean.y.clone(),
                max: mean.y.clone(),
                std: vec![0.0; n],
                mean,
                replicates,
            });
        }
        let (lo, hi) =
            curve::common_range(replicates.iter().map(|r| &r.curve)).ok_or_else(|| {
                // Name the two that share nothing: the one ending first and the one starting last.
                let end = replicates
                    .iter()
                    .min_by(|a, b| a.curve.range().1.total_cmp(&b.curve.range().1))
                    .expect("several");
                let start = replicates
                    .iter()
                    .max_by(|a, b| a.curve.range().0.total_cmp(&b.curve.range().0))
                    .expect("several");
                format!(
                "the replicates share no displacement range: {} ends at {} m, {} starts at {} m",
                end.label,
                end.curve.range().1,
                start.label,
                start.curve.range().0
            )
            })?;
        let x = Curve::grid(lo, hi, COMPARE_POINTS);
        let n = replicates.len() as f64;
        let (mut y, mut min, mut max, mut std) = (vec![], vec![], vec![], vec![]);
        for &v in &x {
            let ys: Vec<f64> = replicates.iter().map(|r| r.curve.at(v)).collect();
            let m = ys.iter().sum::<f64>() / n;
            y.push(m);
            min.push(ys.iter().copied().fold(f64::MAX, f64::min));
            max.push(ys.iter().copied().fold(f64::MIN, f64::max));
            std.push((ys.iter().map(|a| (a - m).powi(2)).sum::<f64>() / (n - 1.0)).sqrt());
        }
        Ok(LabCurves {
            mean: Curve { x, y },
            min,
            max,
            std,
            replicates,
        })
    }
}

/// A curve CSV's header and columns (displacement in metres), checked cell by cell.
struct Table {
    name: String,
    heads: Vec<String>,
    cols: Vec<Vec<f64>>,
    /// Metres per unit of the file's displacement column.
    scale: f64,
}

/// Reads a curve CSV (the lab's or a simulated one): a displacement column, then force columns.
/// Errors name the file, the line and the column.
fn read_table(path: &Path) -> Result<Table, String> {
    let name = path.display().to_string();
    let file = dem::files::open_checked(path, dem::files::MAX_TABLE_BYTES)
        .map_err(|e| format!("{name}: cannot read: {e}"))?;
    table_from(name, std::io::BufReader::new(file))
}

/// The table in `csv`; `name` heads the errors.
fn table_from(name: String, csv: impl std::io::Read) -> Result<Table, String> {
    let mut rdr = csv::ReaderBuilder::new()
        .has_headers(false)
        .flexible(true)
        .trim(csv::Trim::All)
        .from_reader(csv);
    let mut records = rdr.records();
    let header = match records.next() {
        None => return Err(format!("{name}: empty: expected a header row (displacement_m or displacement_mm, then one force column in N per replicate)")),
        Some(r) => r.map_err(|e| format!("{name}: line 1: {e}"))?,
    };
    let heads: Vec<String> = header.iter().map(str::to_string).collect();
    let scale = match heads.first().map(|h| h.to_ascii_lowercase()) {
        Some(h) if h == "displacement_m" => 1.0,
        Some(h) if h == "displacement_mm" => 1e-3,
        other => {
            return Err(format!(
                "{name}: line 1: the first column is headed \"{}\": expected displacement_m or displacement_mm",
                crate::text::shown(&other.unwrap_or_default())
            ))
        }
    };
    if heads.len() < 2 {
        return Err(format!(
            "{name}: line 1: no force column: expected displacement, then one force column (N) per replicate"
        ));
    }
    if heads.len() > MAX_COLUMNS + 1 {
        return Err(format!(
            "{name}: line 1: {} force columns: at most {MAX_COLUMNS}",
            heads.len() - 1
        ));
    }
    if let Some(h) = heads.iter().skip(1).find(|h| h.is_empty()) {
        return Err(format!(
            "{name}: line 1: a force column has no name (\"{}\")",
            crate::text::shown(h)
        ));
    }
    let mut cols: Vec<Vec<f64>> = vec![Vec::new(); heads.len()];
    for (i, rec) in records.enumerate() {
        let line = i + 2;
        if i >= MAX_ROWS {
            return Err(format!(
                "{name}: more than {MAX_ROWS} data rows: refused (resample the curve)"
            ));
        }
        let rec =
            rec.map_err(|e| virtual_tests::file::one_line(&format!("{name}: line {line}: {e}")))?;
        if rec.len() != heads.len() {
            return Err(format!(
                "{name}: line {line}: {} cells, expected {} (as the header)",
                rec.len(),
                heads.len()
            ));
        }
        for (j, cell) in rec.iter().enumerate() {
            let v: f64 = cell
                .parse()
                .ok()
                .filter(|v: &f64| v.is_finite())
                .ok_or_else(|| {
                    format!(
                        "{name}: line {line}, column {}: expected a number, got \"{}\"",
                        crate::text::shown(&heads[j]),
                        crate::text::shown(cell)
                    )
                })?;
            cols[j].push(if j == 0 { v * scale } else { v });
        }
    }
    Ok(Table {
        name,
        heads,
        cols,
        scale,
    })
}

/// Reads a simulated curve CSV, as `demcal test` writes it (`force_displacement.csv`:
/// `displacement_m,force_n`): the displacement may repeat (averaged there) but not go back.
pub fn read_simulated_csv(path: &Path) -> Result<Curve, String> {
    let Table {
        name, heads, cols, ..
    } = read_table(path)?;
    if heads.len() != 2 {
        return Err(format!(
            "{name}: line 1: {} columns: expected two, the displacement and the force (N)",
            heads.len()
        ));
    }
    Curve::from_simulated(&cols[0], &cols[1]).map_err(|e| format!("{name}: {e}"))
}

/// Reads one lab CSV: a replicate per force column. Errors name the file, the line and the
/// column.
pub fn read_csv(path: &Path) -> Result<Vec<Replicate>, String> {
    replicates(read_table(path)?)
}

/// The replicates of a lab CSV's bytes (see `read_csv`); `name` heads the errors.
pub fn parse_csv(name: &str, csv: &[u8]) -> Result<Vec<Replicate>, String> {
    replicates(table_from(name.to_string(), csv)?)
}

fn replicates(table: Table) -> Result<Vec<Replicate>, String> {
    let Table {
        name,
        heads,
        cols,
        scale,
    } = table;
    let x = &cols[0];
    if x.len() < 2 {
        return Err(format!(
            "{name}: {} data row(s): a curve needs at least 2",
            x.len()
        ));
    }
    if let Some(i) = (1..x.len()).find(|&i| x[i] <= x[i - 1]) {
        return Err(format!(
            "{name}: line {}, column {}: the displacement does not increase ({} after {})",
            i + 2,
            heads[0],
            cols[0][i] / scale,
            cols[0][i - 1] / scale
        ));
    }
    Ok(heads
        .iter()
        .zip(&cols)
        .skip(1)
        .map(|(h, y)| Replicate {
            label: format!("{name}: {h}"),
            curve: Curve {
                x: x.clone(),
                y: y.clone(),
            },
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::PathBuf;

    fn dir(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("demcal-lab-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    #[test]
    fn replicates_are_averaged_on_the_common_range_with_their_band() {
        let d = dir("avg");
        // Two columns in one file (mm), a third replicate in another file over a shorter range.
        std::fs::write(
            d.join("a.csv"),
            "displacement_mm,force_1,force_2\n0,0,0\n1,10,20\n2,20,40\n",
        )
        .unwrap();
        std::fs::write(
            d.join("b.csv"),
            "displacement_m,force\n0.0005,0\n0.0015,30\n",
        )
        .unwrap();
        let mut reps = read_csv(&d.join("a.csv")).unwrap();
        assert_eq!(reps.len(), 2);
        assert_eq!(reps[0].curve.x, vec![0.0, 0.001, 0.002]);
        assert!(reps[1].label.ends_with("a.csv: force_2"));
        reps.extend(read_csv(&d.join("b.csv")).unwrap());
        let lab = LabCurves::average(reps).unwrap();
        assert_eq!(lab.mean.range(), (0.0005, 0.0015));
        assert_eq!(lab.mean.x.len(), COMPARE_POINTS);
        // At 1 mm: 10, 20 and 15 -> mean 15, band 10 .. 20, std 5.
        let k = lab
            .mean
            .x
            .iter()
            .position(|x| (x - 0.001).abs() < 6e-7)
            .unwrap();
        let x = lab.mean.x[k];
        let (a, b, c) = (1e4 * x, 2e4 * x, 3e4 * (x - 0.0005));
        assert!((lab.mean.y[k] - (a + b + c) / 3.0).abs() < 1e-9);
        assert!((lab.min[k] - a.min(c)).abs() < 1e-9);
        assert!((lab.max[k] - b.max(c)).abs() < 1e-9);
        let m = (a + b + c) / 3.0;
        let sd = (((a - m).powi(2) + (b - m).powi(2) + (c - m).powi(2)) / 2.0).sqrt();
        assert!((lab.std[k] - sd).abs() < 1e-9);
        // A single replicate is its own mean.
        let one = LabCurves::average(read_csv(&d.join("b.csv")).unwrap()).unwrap();
        assert_eq!(one.mean.x, vec![0.0005, 0.0015]);
        assert_eq!(one.min, one.mean.y);
        std::fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn bad_lab_files_give_one_line_naming_the_file_and_line() {
        let d = dir("bad");
        let cases = [
            ("", "empty: expected a header row"),
            ("disp,force\n0,1\n1,2\n", "line 1: the first column is headed \"disp\": expected displacement_m or displacement_mm"),
            ("displacement_m\n0\n1\n", "line 1: no force column"),
            ("displacement_m,force\n0,1\n0.1,abc\n", "line 3, column force: expected a number, got \"abc\""),
            ("displacement_m,force\n0,1\n0.1,\n", "line 3, column force: expected a number, got \"\""),
            ("displacement_m,force\n0,1\n0.1\n", "line 3: 1 cells, expected 2"),
            ("displacement_m,force\n0,1\n", "1 data row(s): a curve needs at least 2"),
            ("displacement_mm,force\n0,1\n2,2\n2,3\n", "line 4, column displacement_mm: the displacement does not increase (2 after 2)"),
            ("displacement_m,force\n0,1\n0.1,inf\n", "expected a number, got \"inf\""),
            // A quoted cell may hold a line break: the message stays on one line.
            ("displacement_m,force\n0,1\n0.1,\"9\n8\"\n", "expected a number, got \"9\\n8\""),
        ];
        for (i, (text, want)) in cases.iter().enumerate() {
            let p = d.join(format!("c{i}.csv"));
            std::fs::write(&p, text).unwrap();
            let e = read_csv(&p).unwrap_err();
            assert!(e.starts_with(&p.display().to_string()), "{e}");
            assert!(e.contains(want), "{e}\nwanted: {want}");
            assert_eq!(e.lines().count(), 1, "{e}");
        }
        let e = read_csv(&d.join("missing.csv")).unwrap_err();
        assert!(e.contains("missing.csv: cannot read"), "{e}");
        // Too many rows are refused.
        let mut big = String::from("displacement_m,force\n");
        for i in 0..=MAX_ROWS {
            big.push_str(&format!("{i},1\n"));
        }
        let p = d.join("big.csv");
        std::fs::write(&p, big).unwrap();
        assert!(read_csv(&p)
            .unwrap_err()
            .contains("more than 1000000 data rows"));
        // Replicates that share no range.
        std::fs::write(d.join("x.csv"), "displacement_m,f\n0,1\n1,1\n").unwrap();
        std::fs::write(d.join("y.csv"), "displacement_m,g\n2,1\n3,1\n").unwrap();
        let mut reps = read_csv(&d.join("x.csv")).unwrap();
        reps.extend(read_csv(&d.join("y.csv")).unwrap());
        let e = LabCurves::average(reps).unwrap_err();
        assert!(
            e.contains("share no displacement range") && e.contains("x.csv: f ends at 1 m"),
            "{e}"
        );
        std::fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn target_keys_are_checked() {
        let d = dir("keys");
        std::fs::write(d.join("lab.csv"), "displacement_m,f\n0,0\n0.01,10\n").unwrap();
        let err = |k: &str, m: String| format!("s.toml: {k}: {m}");
        let parse = |text: &str| {
            let t: toml::Table = toml::from_str(text).unwrap();
            let t: TargetEntry =
                crate::file::read("target", toml::Value::Table(t)).map_err(|(k, m)| err(&k, m))?;
            CurveTarget::parse(&t, &d, &err)
        };
        assert_eq!(parse("value = 3").unwrap(), None);
        let ok = parse("curve = \"force_displacement\"\nlab_curves = \"lab.csv\"\nnormalisation = \"stress_strain\"\narea_m2 = 1e-4\nlength_m = 0.02").unwrap().unwrap();
        assert_eq!(
            ok.normalisation,
            Normalisation::StressStrain {
                area_m2: 1e-4,
                length_m: 0.02
            }
        );
        // 10 N on 1 cm² is 0.1 MPa.
        let peak = ok.replicate_measures("curve_peak");
        assert!(peak.len() == 1 && (peak[0] - 0.1).abs() < 1e-15, "{peak:?}");
        for (text, want) in [
            ("lab_curves = \"lab.csv\"", "s.toml: target.lab_curves: only with target.curve"),
            ("curve = \"f\"\nnormalisation = \"none\"", "s.toml: target.lab_curves: missing"),
            ("curve = \"f\"\nlab_curves = \"lab.csv\"", "s.toml: target.normalisation: missing"),
            ("curve = \"f\"\nlab_curves = \"lab.csv\"\nnormalisation = \"peak\"", "s.toml: target.normalisation: expected \"none\""),
            ("curve = \"f\"\nlab_curves = \"lab.csv\"\nnormalisation = \"stress_strain\"\nlength_m = 0.1", "s.toml: target.area_m2: missing"),
            ("curve = \"f\"\nlab_curves = \"lab.csv\"\nnormalisation = \"stress_strain\"\narea_m2 = 0.1", "s.toml: target.length_m: missing"),
            ("curve = \"f\"\nlab_curves = \"lab.csv\"\nnormalisation = \"none\"\narea_m2 = 0.1", "s.toml: target.area_m2: only with normalisation = \"stress_strain\""),
            ("curve = \"f\"\nlab_curves = \"lab.csv\"\nnormalisation = \"stress_strain\"\narea_m2 = -1\nlength_m = 1", "s.toml: target.area_m2: expected a number > 0"),
            ("curve = \"f\"\nlab_curves = \"nope.csv\"\nnormalisation = \"none\"", "nope.csv: cannot read"),
            ("curve = \"f\"\nlab_curves = []\nnormalisation = \"none\"", "s.toml: target.lab_curves: expected a CSV file name"),
        ] {
            let e = parse(text).unwrap_err();
            assert!(e.contains(want), "{e}\nwanted: {want}");
        }
        std::fs::remove_dir_all(&d).unwrap();
    }
}
