//! The study file: which virtual test, which parameters over which ranges, the lab value, and the
//! plan of stages. Every error is one line naming the file and the key.

use std::path::{Path, PathBuf};

use doe::{Factor, Scale};

use crate::curve::CURVE_RESPONSES;
use crate::lab_curve::{CurveTarget, CURVE_KEYS};
use crate::paths::{number, ParamPath};
use crate::plan::parse_plan;
pub use crate::plan::{RsmDesign, ScreeningDesign, Stage, STAGES};
use virtual_tests::file::one_line;

/// A parameter to calibrate: one value written into one or more places of the test.
#[derive(Clone, Debug)]
pub struct Parameter {
    pub name: String,
    pub paths: Vec<ParamPath>,
    pub min: f64,
    pub max: f64,
    pub scale: Scale,
}

impl Parameter {
    /// The factor over `lo..hi` (actual units) in this parameter's scale. A stage can narrow a
    /// range until its ends meet (a steepest path through a tiny range); that is an error naming
    /// the parameter, for the stage to report.
    pub fn factor(&self, lo: f64, hi: f64) -> Result<Factor, String> {
        Factor::new(&self.name, lo, hi, self.scale).map_err(|_| {
            format!(
                "parameter {}: its range has shrunk to {lo} .. {hi}, too narrow for a design",
                self.name
            )
        })
    }

    /// The value the coded level is linear in (the value, or its log10).
    pub fn transformed(&self, actual: f64) -> f64 {
        match self.scale {
            Scale::Linear => actual,
            Scale::Log => actual.log10(),
        }
    }

    pub fn actual(&self, transformed: f64) -> f64 {
        match self.scale {
            Scale::Linear => transformed,
            Scale::Log => 10f64.powf(transformed),
        }
    }

    /// The middle of the range (geometric for a logarithmic parameter).
    pub fn middle(&self) -> f64 {
        self.actual(0.5 * (self.transformed(self.min) + self.transformed(self.max)))
    }
}

/// The lab value to reproduce.
#[derive(Clone, Debug)]
pub struct Target {
    /// The key of the test's outcome compared with the lab (e.g. `angle_of_repose_deg`).
    pub response: String,
    pub value: f64,
    pub replicates: Vec<f64>,
    pub unit: String,
    /// The lab curves the test's curve is compared with, when the target has a curve.
    pub curve: Option<CurveTarget>,
}

impl Target {
    /// Whether the response is minimised rather than matched: the curve MSE, whose target is 0.
    pub fn minimised(&self) -> bool {
        self.response == "curve_mse"
    }

    /// |sim - lab| / lab in %; none for a minimised response (a relative error of a target of
    /// 0 means nothing: the response itself says how far off the run is).
    pub fn relative_error_percent(&self, simulated: f64) -> Option<f64> {
        (!self.minimised()).then(|| 100.0 * (simulated - self.value).abs() / self.value.abs())
    }

    /// How far a simulated response is from the lab, in words: the relative error, or the
    /// minimised response itself.
    pub fn misfit(&self, simulated: f64) -> String {
        match self.relative_error_percent(simulated) {
            Some(e) => format!("relative error {e:.2} %"),
            None => format!("{} {}", self.response, doe::fit::fmt_sig(simulated)),
        }
    }

    /// Standard deviation of the replicates, when there are two or more.
    pub fn std(&self) -> Option<f64> {
        let n = self.replicates.len();
        (n >= 2).then(|| {
            let m = self.replicates.iter().sum::<f64>() / n as f64;
            (self.replicates.iter().map(|v| (v - m).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt()
        })
    }
}

/// A value calibrated by another study, written into this study's test: how calibrations chain
/// (particle-steel friction from an incline first, then particle-particle from a heap).
#[derive(Clone, Debug)]
pub struct Import {
    /// The other study's file, as given, and the summary the value was read from.
    pub study: String,
    pub summary: PathBuf,
    /// The parameter's name in the other study.
    pub parameter: String,
    pub paths: Vec<ParamPath>,
    pub value: f64,
}

/// A study read and checked.
#[derive(Clone, Debug)]
pub struct Study {
    pub path: PathBuf,
    pub name: String,
    pub seed: u64,
    /// The test file's content, before parameters are set.
    pub test: toml::Table,
    /// Where the test came from: the test file's path, or "inline".
    pub test_source: String,
    /// The folder the test's relative paths are taken from: the test file's, or the study's for
    /// an inline test.
    pub test_dir: PathBuf,
    pub parameters: Vec<Parameter>,
    /// Values taken from other studies' summaries, already written into `test`.
    pub imports: Vec<Import>,
    pub target: Target,
    pub plan: Vec<Stage>,
    /// Wall-clock limit of one simulation; a run over it is stopped and stored as failed.
    pub run_time_limit_s: Option<f64>,
    /// The study file's text, stored with the runs.
    pub text: String,
}

impl Study {
    pub fn test_kind(&self) -> &str {
        self.test.get("test").and_then(|v| v.as_str()).unwrap_or("")
    }

    /// The folder the study lives in; the store, run outputs and report go there.
    pub fn dir(&self) -> PathBuf {
        self.path
            .parent()
            .map(Path::to_path_buf)
            .filter(|p| !p.as_os_str().is_empty())
            .unwrap_or_else(|| PathBuf::from("."))
    }

    fn stem(&self) -> String {
        self.path
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| "study".into())
    }

    /// The results store: `<study>.db` next to the study file.
    pub fn store_path(&self) -> PathBuf {
        self.dir().join(format!("{}.db", self.stem()))
    }

    /// Where each run writes its pictures and result.
    pub fn runs_dir(&self) -> PathBuf {
        self.dir().join(format!("{}.runs", self.stem()))
    }

    pub fn report_dir(&self) -> PathBuf {
        self.dir().join("report")
    }

    pub fn load(path: &Path) -> Result<Study, String> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| format!("{}: cannot read: {e}", path.display()))?;
        Study::parse(path, &text)
    }

    pub fn parse(path: &Path, text: &str) -> Result<Study, String> {
        let file = path.display().to_string();
        let err = |key: &str, msg: String| format!("{file}: {key}: {msg}");
        let doc: toml::Table =
            toml::from_str(text).map_err(|e| format!("{file}: {}", one_line(&e.to_string())))?;
        const KEYS: &[&str] = &[
            "name",
            "seed",
            "test",
            "parameter",
            "target",
            "plan",
            "run_time_limit_s",
            "import",
        ];
        for k in doc.keys() {
            if !KEYS.contains(&k.as_str()) {
                return Err(err(
                    k,
                    format!("unknown key (expected {})", KEYS.join(", ")),
                ));
            }
        }
        let name = match doc.get("name") {
            None => path
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_else(|| "study".into()),
            Some(toml::Value::String(s)) => s.clone(),
            Some(_) => return Err(err("name", "expected a string".into())),
        };
        let seed = match doc.get("seed") {
            None => 1,
            Some(toml::Value::Integer(s)) if *s >= 0 => *s as u64,
            Some(_) => return Err(err("seed", "expected a whole number >= 0".into())),
        };
        let run_time_limit_s = match doc.get("run_time_limit_s") {
            None => None,
            Some(v) => Some(
                number(v)
                    .filter(|t| *t > 0.0)
                    .ok_or_else(|| err("run_time_limit_s", "expected seconds > 0".into()))?,
            ),
        };

        // The test: a path to a test file, or the test file's content inline.
        let dir = path.parent().unwrap_or(Path::new(""));
        let (test, test_source) = match doc.get("test") {
            None => {
                return Err(err(
                    "test",
                    "missing (a test file's path, e.g. test = \"repose.toml\", or an inline [test] table)".into(),
                ))
            }
            Some(toml::Value::String(p)) => {
                let tp = dir.join(p);
                let t = std::fs::read_to_string(&tp)
                    .map_err(|e| err("test", format!("cannot read {}: {e}", tp.display())))?;
                let table: toml::Table = toml::from_str(&t)
                    .map_err(|e| format!("{}: {}", tp.display(), one_line(&e.to_string())))?;
                (table, tp.display().to_string())
            }
            Some(toml::Value::Table(t)) => (t.clone(), "inline".to_string()),
            Some(_) => {
                return Err(err(
                    "test",
                    "expected a test file's path or an inline table".into(),
                ))
            }
        };
        let mut test = test;
        let imports = parse_imports(&doc, dir, &mut test, &err)?;
        let test_name = format!("{file}: test");
        let test_dir = match doc.get("test") {
            Some(toml::Value::String(p)) => dir.join(p).parent().map(Path::to_path_buf),
            _ => None,
        }
        .unwrap_or_else(|| dir.to_path_buf());
        let test_dir = if test_dir.as_os_str().is_empty() {
            PathBuf::from(".")
        } else {
            test_dir
        };
        let base = virtual_tests::TestFile::from_table_in(&test_name, &test, &test_dir)?;

        // Parameters.
        let list = match doc.get("parameter") {
            Some(toml::Value::Array(a)) if !a.is_empty() => a,
            Some(_) => return Err(err("parameter", "expected [[parameter]] tables".into())),
            None => {
                return Err(err(
                    "parameter",
                    "missing: give at least one [[parameter]] with name, path, min and max".into(),
                ))
            }
        };
        let mut parameters: Vec<Parameter> = Vec::new();
        for (i, p) in list.iter().enumerate() {
            let key = format!("parameter[{i}]");
            let t = p
                .as_table()
                .ok_or_else(|| err(&key, "expected a table".into()))?;
            for k in t.keys() {
                if !["name", "path", "paths", "min", "max", "scale"].contains(&k.as_str()) {
                    return Err(err(
                        &format!("{key}.{k}"),
                        "unknown key (expected name, path or paths, min, max, scale)".into(),
                    ));
                }
            }
            let name = t
                .get("name")
                .and_then(|v| v.as_str())
                .ok_or_else(|| err(&format!("{key}.name"), "missing (expected a string)".into()))?
                .to_string();
            if parameters.iter().any(|q| q.name == name) {
                return Err(err(
                    &format!("{key}.name"),
                    format!("\"{name}\" is given twice"),
                ));
            }
            let paths = read_paths(t, &key, &test, &err)?;
            let get = |k: &str| -> Result<f64, String> {
                number(t.get(k).ok_or_else(|| {
                    err(&format!("{key}.{k}"), "missing (expected a number)".into())
                })?)
                .ok_or_else(|| err(&format!("{key}.{k}"), "expected a number".into()))
            };
            let (min, max) = (get("min")?, get("max")?);
            if min.is_nan() || max.is_nan() || min >= max {
                return Err(err(
                    &format!("{key}.min"),
                    format!("expected min < max, got min = {min} and max = {max}"),
                ));
            }
            if !(max - min).is_finite() {
                return Err(err(
                    &format!("{key}.min"),
                    format!("expected finite numbers, got min = {min} and max = {max}"),
                ));
            }
            // Run values are stored to 12 significant digits; a narrower range would collapse
            // to one value on the way through the stages.
            if max - min <= 1e-6 * min.abs().max(max.abs()) {
                return Err(err(
                    &format!("{key}.max"),
                    format!("the range {min} .. {max} is too narrow: values are kept to 12 significant digits, so give a range wider than a millionth of its values"),
                ));
            }
            let scale = match t.get("scale").map(|v| v.as_str()) {
                None | Some(Some("linear")) => Scale::Linear,
                Some(Some("log")) => Scale::Log,
                _ => {
                    return Err(err(
                        &format!("{key}.scale"),
                        "expected \"linear\" or \"log\"".into(),
                    ))
                }
            };
            if scale == Scale::Log && min <= 0.0 {
                return Err(err(
                    &format!("{key}.min"),
                    format!("a log-scale parameter needs min > 0, got {min}"),
                ));
            }
            parameters.push(Parameter {
                name,
                paths,
                min,
                max,
                scale,
            });
        }

        // Target.
        let target_table = match doc.get("target") {
            Some(toml::Value::Table(t)) => t,
            Some(_) => return Err(err("target", "expected a table".into())),
            None => {
                return Err(err(
                    "target",
                    "missing: the lab value to calibrate against, e.g. [target] value = 38.65"
                        .into(),
                ))
            }
        };
        for k in target_table.keys() {
            if !["response", "value", "replicates", "unit"].contains(&k.as_str())
                && !CURVE_KEYS.contains(&k.as_str())
            {
                return Err(err(
                    &format!("target.{k}"),
                    format!(
                        "unknown key (expected response, value, replicates, unit, {})",
                        CURVE_KEYS.join(", ")
                    ),
                ));
            }
        }
        let outputs = virtual_tests::responses(&base.test);
        let curve = CurveTarget::parse(target_table, dir, &err)?;
        if let Some(c) = &curve {
            if !outputs.contains(&c.curve.as_str()) {
                return Err(err(
                    "target.curve",
                    format!(
                        "\"{}\" is not a response of {} (expected one of: {})",
                        c.curve,
                        base.test,
                        outputs.join(", ")
                    ),
                ));
            }
        }
        let response = match target_table.get("response") {
            None if curve.is_some() => "curve_mse".to_string(),
            None => outputs
                .first()
                .ok_or_else(|| {
                    err(
                        "test",
                        format!("{} has no outcome to calibrate against", base.test),
                    )
                })?
                .to_string(),
            Some(toml::Value::String(r)) if outputs.contains(&r.as_str()) => r.clone(),
            Some(toml::Value::String(r))
                if curve.is_some() && CURVE_RESPONSES.contains(&r.as_str()) =>
            {
                r.clone()
            }
            Some(toml::Value::String(r)) if CURVE_RESPONSES.contains(&r.as_str()) => {
                return Err(err(
                    "target.response",
                    format!("{r} compares the test's curve with the lab's: give target.curve, target.lab_curves and target.normalisation"),
                ))
            }
            Some(v) => {
                let mut expected = outputs.to_vec();
                if curve.is_some() {
                    expected.extend(CURVE_RESPONSES);
                }
                return Err(err(
                    "target.response",
                    format!(
                        "{v} is not an outcome of {} (expected one of: {})",
                        base.test,
                        expected.join(", ")
                    ),
                ));
            }
        };
        let minimised = response == "curve_mse";
        if minimised {
            if let Some(k) = ["value", "replicates"]
                .iter()
                .find(|k| target_table.contains_key(**k))
            {
                return Err(err(
                    &format!("target.{k}"),
                    "curve_mse is minimised (its target is 0): give no value".into(),
                ));
            }
        }
        let replicates: Vec<f64> = match (target_table.get("replicates"), &curve) {
            (None, Some(c)) if CURVE_RESPONSES.contains(&response.as_str()) => {
                c.replicate_measures(&response)
            }
            (None, _) => Vec::new(),
            (Some(toml::Value::Array(a)), _) => a
                .iter()
                .map(|v| number(v).filter(|x| x.is_finite()))
                .collect::<Option<Vec<_>>>()
                .ok_or_else(|| {
                    err(
                        "target.replicates",
                        "expected a list of finite numbers".into(),
                    )
                })?,
            (Some(_), _) => {
                return Err(err(
                    "target.replicates",
                    "expected a list of numbers".into(),
                ))
            }
        };
        let value = match target_table.get("value") {
            None if minimised => 0.0,
            Some(v) => number(v).ok_or_else(|| err("target.value", "expected a number".into()))?,
            None if !replicates.is_empty() => {
                replicates.iter().sum::<f64>() / replicates.len() as f64
            }
            None if curve.is_some() && CURVE_RESPONSES.contains(&response.as_str()) => {
                return Err(err(
                    "target.value",
                    format!("missing: the lab curves give no {response} (their peak is at the start); give the lab value"),
                ))
            }
            None => {
                return Err(err(
                    "target.value",
                    "missing: give the lab value or its replicates".into(),
                ))
            }
        };
        if !minimised && (value == 0.0 || !value.is_finite()) {
            return Err(err(
                "target.value",
                format!("expected a non-zero number (relative errors divide by it), got {value}"),
            ));
        }
        let unit = match (target_table.get("unit").and_then(|v| v.as_str()), &curve) {
            (Some(u), _) => u.to_string(),
            (None, Some(c)) => c.normalisation.unit_of(&response),
            (None, None) => String::new(),
        };
        let target = Target {
            response,
            value,
            replicates,
            unit,
            curve,
        };

        let plan = parse_plan(&doc, &err, parameters.len())?;

        let study = Study {
            path: path.to_path_buf(),
            name,
            seed,
            test,
            test_source,
            test_dir,
            parameters,
            imports,
            target,
            plan,
            run_time_limit_s,
            text: text.to_string(),
        };
        // The test must read with every parameter set (middle values), and its settings and
        // materials must hold at each end of every range (the others in the middle), so that
        // a range the test would refuse (a restitution up to 1.6) shows now rather than after a
        // stage of failed runs. `check_scene` builds the whole scene before a study runs.
        let middle: Vec<f64> = study.parameters.iter().map(Parameter::middle).collect();
        study.check_values(&test_name, &middle)?;
        for (i, p) in study.parameters.iter().enumerate() {
            for (end, v) in [("min", p.min), ("max", p.max)] {
                let mut values = middle.clone();
                values[i] = v;
                study.check_values(&test_name, &values).map_err(|e| {
                    err(
                        &format!("parameter[{i}].{end}"),
                        format!("{} = {v} is refused by the test: {e}", p.name),
                    )
                })?;
            }
        }
        Ok(study)
    }

    /// The test with `values` written in must read, pass its settings checks and have valid
    /// materials and interactions.
    fn check_values(&self, test_name: &str, values: &[f64]) -> Result<(), String> {
        let file = virtual_tests::TestFile::from_table_in(
            test_name,
            &self.test_with(values),
            &self.test_dir,
        )?;
        virtual_tests::check_file(&file)?;
        if !file.parts.materials.is_empty() {
            file.check_materials()?;
        }
        Ok(())
    }

    /// Builds the test's starting scene at the middle of every range (materials, geometry,
    /// particles placed, overlaps checked), as the first run would, without simulating.
    pub fn check_scene(&self) -> Result<(), String> {
        let middle: Vec<f64> = self.parameters.iter().map(Parameter::middle).collect();
        let name = format!("{}: test", self.path.display());
        let file = virtual_tests::TestFile::from_table_in(
            &name,
            &self.test_with(&middle),
            &self.test_dir,
        )?;
        virtual_tests::check_scene(&file, Some(self.seed))
    }

    /// The test's content with every parameter set to `values` (actual units).
    pub fn test_with(&self, values: &[f64]) -> toml::Table {
        let mut t = self.test.clone();
        for (p, v) in self.parameters.iter().zip(values) {
            for path in &p.paths {
                path.set(&mut t, *v)
                    .expect("paths checked when the study was read");
            }
        }
        t
    }
}

/// `[[import]]` tables: `study` (another study file), `parameter` (a name in its summary's
/// calibrated values) and `path` or `paths` (where the value goes in this study's test). The
/// value is read from the other study's `report/summary.json`, which `demcal run` writes.
fn parse_imports(
    doc: &toml::Table,
    dir: &Path,
    test: &mut toml::Table,
    err: &dyn Fn(&str, String) -> String,
) -> Result<Vec<Import>, String> {
    let list = match doc.get("import") {
        None => return Ok(Vec::new()),
        Some(toml::Value::Array(a)) => a,
        Some(_) => {
            return Err(err(
                "import",
                "expected [[import]] tables with study, parameter and path".into(),
            ))
        }
    };
    let mut imports = Vec::new();
    for (i, item) in list.iter().enumerate() {
        let key = format!("import[{i}]");
        let t = item
            .as_table()
            .ok_or_else(|| err(&key, "expected a table".into()))?;
        for k in t.keys() {
            if !["study", "parameter", "path", "paths"].contains(&k.as_str()) {
                return Err(err(
                    &format!("{key}.{k}"),
                    "unknown key (expected study, parameter, path or paths)".into(),
                ));
            }
        }
        let text = |k: &str| -> Result<String, String> {
            t.get(k)
                .and_then(|v| v.as_str())
                .map(String::from)
                .ok_or_else(|| err(&format!("{key}.{k}"), "missing (expected a string)".into()))
        };
        let study = text("study")?;
        let parameter = text("parameter")?;
        let paths = read_paths(t, &key, test, err)?;
        let study_path = dir.join(&study);
        let other_dir = study_path
            .parent()
            .map(Path::to_path_buf)
            .filter(|p| !p.as_os_str().is_empty())
            .unwrap_or_else(|| PathBuf::from("."));
        let summary = other_dir.join("report").join("summary.json");
        let body = std::fs::read_to_string(&summary).map_err(|e| {
            err(
                &format!("{key}.study"),
                format!(
                    "cannot read {} ({e}): run that study first (demcal run {})",
                    summary.display(),
                    study_path.display()
                ),
            )
        })?;
        let json: serde_json::Value = serde_json::from_str(&body).map_err(|e| {
            err(
                &format!("{key}.study"),
                format!("{}: not a study summary: {e}", summary.display()),
            )
        })?;
        if json["state"].as_str() != Some("complete") {
            return Err(err(
                &format!("{key}.study"),
                format!(
                    "{} is {}, not complete: finish it first (demcal run {})",
                    study,
                    json["state"].as_str().unwrap_or("of unknown state"),
                    study_path.display()
                ),
            ));
        }
        let value = json["calibrated"][&parameter].as_f64().ok_or_else(|| {
            let names: Vec<String> = json["calibrated"]
                .as_object()
                .map(|m| m.keys().cloned().collect())
                .unwrap_or_default();
            err(
                &format!("{key}.parameter"),
                format!(
                    "\"{parameter}\" is not a calibrated value of {study} (it has: {})",
                    names.join(", ")
                ),
            )
        })?;
        for pp in &paths {
            pp.set(test, value)
                .map_err(|e| err(&format!("{key}.path"), format!("\"{pp}\": {e}")))?;
        }
        imports.push(Import {
            study,
            summary,
            parameter,
            paths,
            value,
        });
    }
    Ok(imports)
}

/// `path = "..."` or `paths = [...]` of a `[[parameter]]` or `[[import]]` table `key`, each parsed
/// and checked to reach a number in `test`.
fn read_paths(
    t: &toml::Table,
    key: &str,
    test: &toml::Table,
    err: &dyn Fn(&str, String) -> String,
) -> Result<Vec<ParamPath>, String> {
    let texts: Vec<String> = match (t.get("path"), t.get("paths")) {
        (Some(toml::Value::String(s)), None) => vec![s.clone()],
        (None, Some(toml::Value::Array(a))) if !a.is_empty() => a
            .iter()
            .map(|v| v.as_str().map(String::from))
            .collect::<Option<Vec<_>>>()
            .ok_or_else(|| err(&format!("{key}.paths"), "expected a list of strings".into()))?,
        (Some(_), Some(_)) => {
            return Err(err(
                &format!("{key}.path"),
                "give path or paths, not both".into(),
            ))
        }
        _ => {
            return Err(err(
                &format!("{key}.path"),
                "missing: where the value goes in the test, e.g. \"interaction[bead,bead].static_friction\"".into(),
            ))
        }
    };
    let mut paths = Vec::new();
    for s in &texts {
        let pp = ParamPath::parse(s).map_err(|e| err(&format!("{key}.path"), e))?;
        pp.check(test)
            .map_err(|e| err(&format!("{key}.path"), format!("\"{s}\": {e}")))?;
        paths.push(pp);
    }
    Ok(paths)
}
