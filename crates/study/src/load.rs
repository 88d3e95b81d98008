//! Reading a study file: every key checked, every error one line naming the file and the key
//! (`parameter[1].path`, `plan[3].stage`, `target.value`), each test read and checked with every
//! parameter at its middle and at each end of its range. The plan's stages and the executor are
//! read through their registries (`plan`, `executor`): this module sits above them, and
//! `spec` (what a study is) below.

use std::path::{Path, PathBuf};

use doe::Scale;

use crate::file::{keys_of, ImportEntry, ParameterEntry, ScaleName, StudyFile, TargetEntry};
use crate::paths::ParamPath;
use crate::plan::parse_plan;
use crate::spec::{test_label, Import, Parameter, Study, TestSpec};
use crate::target::{parse_objective, parse_target, Target, TestOutputs};
use virtual_tests::file::one_line;

/// The longest name of a parameter.
pub const MAX_NAME_CHARS: usize = 100;
/// The keys of a `[[test]]` beside the test's own content given inline.
pub(crate) const TEST_KEYS: &[&str] = &["name", "file"];

/// Every section of a study file, as `docs/reference.md` heads it, with the keys its reader
/// accepts, so that the reference is checked against the code.
pub fn reference_sections() -> Vec<(String, Vec<&'static str>)> {
    let mut v = vec![
        ("study file".to_string(), keys_of::<StudyFile>()),
        ("[[test]]".to_string(), TEST_KEYS.to_vec()),
        ("[[parameter]]".to_string(), keys_of::<ParameterEntry>()),
        ("[[import]]".to_string(), keys_of::<ImportEntry>()),
        ("[target]".to_string(), keys_of::<TargetEntry>()),
        (
            "[objective]".to_string(),
            keys_of::<crate::file::ObjectiveEntry>(),
        ),
    ];
    for stage in crate::plan::STAGE_NAMES {
        let keys = crate::plan::stage_keys(stage).expect("every stage has its keys");
        v.push((format!("plan: {stage}"), [&["stage"][..], keys].concat()));
    }
    // Every executor's keys: the reference lists them in one table.
    let mut keys: Vec<&'static str> = Vec::new();
    for name in crate::executor::EXECUTOR_NAMES {
        for k in crate::executor::executor_keys(name).expect("registered") {
            if !keys.contains(&k) {
                keys.push(k);
            }
        }
    }
    v.push(("[executor]".to_string(), keys));
    v
}

impl Study {
    pub fn load(path: &Path) -> Result<Study, String> {
        let text = dem::files::read_text(path, dem::files::MAX_TEXT_BYTES)
            .map_err(|e| format!("{}: cannot read: {e}", path.display()))?;
        Study::parse(path, &text)
    }

    pub fn parse(path: &Path, text: &str) -> Result<Study, String> {
        // A value from the file (a path, a name) may hold a line break; the error is one line.
        Study::parse_text(path, text).map_err(|e| one_line(&e))
    }

    fn parse_text(path: &Path, text: &str) -> Result<Study, String> {
        let file = path.display().to_string();
        let err = |key: &str, msg: String| format!("{file}: {key}: {msg}");
        let doc: toml::Table =
            toml::from_str(text).map_err(|e| format!("{file}: {}", one_line(&e.to_string())))?;
        let raw: StudyFile =
            crate::file::read("", toml::Value::Table(doc)).map_err(|(k, m)| err(&k, m))?;
        let name = raw.name.clone().unwrap_or_else(|| {
            path.file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_else(|| "study".into())
        });
        // The name titles the report and its figures: one printable line.
        let chars = name.chars().count();
        if chars == 0 || chars > MAX_NAME_CHARS || name.chars().any(char::is_control) {
            return Err(err(
                "name",
                format!("expected 1 to {MAX_NAME_CHARS} characters without line breaks or control characters, got {chars} characters"),
            ));
        }
        let seed = raw.seed.unwrap_or(1);
        let run_time_limit_s = raw.run_time_limit_s;
        let backend = match &raw.backend {
            None => "cpu".to_string(),
            Some(b) if dem::sim::BACKEND_NAMES.contains(&b.as_str()) => b.clone(),
            Some(b) => {
                return Err(err(
                    "backend",
                    format!("expected {}, got \"{b}\"", dem::sim::backend_choices()),
                ))
            }
        };

        // The tests: a path to a test file, the test file's content inline, or several
        // [[test]] tables, each with a name and a file or the content inline.
        let dir = path.parent().unwrap_or(Path::new(""));
        let mut tests = parse_tests(raw.test.as_ref(), dir, &err)?;
        let imports = parse_imports(raw.import.as_deref().unwrap_or(&[]), dir, &mut tests, &err)?;
        let mut outputs = Vec::new();
        for t in &tests {
            let name = test_label(&file, &tests, t);
            let base = virtual_tests::TestFile::from_table_in(&name, &t.table, &t.dir)?;
            outputs.push((base.test.clone(), virtual_tests::responses(&base.test)));
        }

        // Parameters.
        // A study without parameters only validates: the values another study calibrated
        // ([[import]]) on a test of its own, as seed 000 validates its shear calibration by
        // three-point bending.
        let validates_only = matches!(&raw.plan, Some(toml::Value::Array(a))
        if !a.is_empty() && a.iter().all(|s| {
            s.as_str().or_else(|| s.get("stage").and_then(|v| v.as_str())) == Some("validate")
        }));
        let list = match raw.parameter.as_deref() {
            Some(a) if !a.is_empty() => a,
            _ if validates_only => &[],
            _ => {
                return Err(err(
                    "parameter",
                    "missing: give at least one [[parameter]] with name, path, min and max (a study without parameters can only validate: plan = [\"validate\"], with the calibrated values from [[import]])".into(),
                ))
            }
        };
        let mut parameters: Vec<Parameter> = Vec::new();
        for (i, p) in list.iter().enumerate() {
            let key = format!("parameter[{i}]");
            let name = p.name.clone();
            // A name heads columns, tables and figures in every run's record and the report
            // (a 1 MB name took 1.27 GB).
            if name.is_empty() || name.chars().count() > MAX_NAME_CHARS {
                return Err(err(
                    &format!("{key}.name"),
                    format!(
                        "expected 1 to {MAX_NAME_CHARS} characters, got {}",
                        name.chars().count()
                    ),
                ));
            }
            if parameters.iter().any(|q| q.name == name) {
                return Err(err(
                    &format!("{key}.name"),
                    format!("\"{name}\" is given twice"),
                ));
            }
            let paths = read_paths(p.path.as_ref(), p.paths.as_deref(), &key, &tests, &err)?;
            // Two parameters writing the same value: the later one wins, and the first would be
            // reported calibrated with no effect on anything.
            for (j, q) in parameters.iter().enumerate() {
                for (pp, _) in &paths {
                    if q.paths.iter().any(|(qp, _)| qp.same_place(pp)) {
                        return Err(err(
                            &format!("{key}.path"),
                            format!(
                                "\"{pp}\" is also where parameter[{j}] (\"{}\") goes: two parameters cannot set the same value",
                                q.name
                            ),
                        ));
                    }
                }
            }
            let (min, min_unit) = (p.min.value, p.min.dimension);
            let (max, max_unit) = (p.max.value, p.max.dimension);
            if min_unit != max_unit {
                let says = |u: Option<dem::units::Dimension>| {
                    u.map_or("a plain number", dem::units::Dimension::describe)
                };
                return Err(err(
                    &format!("{key}.max"),
                    format!(
                        "min is {} but max is {}: give both in units of the same quantity",
                        says(min_unit),
                        says(max_unit)
                    ),
                ));
            }
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
            let scale = match p.scale {
                None | Some(ScaleName::Linear) => Scale::Linear,
                Some(ScaleName::Log) => Scale::Log,
            };
            if scale == Scale::Log && min <= 0.0 {
                return Err(err(
                    &format!("{key}.min"),
                    format!("a log-scale parameter needs min > 0, got {min}"),
                ));
            }
            for (k, v) in [("label", &p.label), ("symbol", &p.symbol)] {
                if let Some(v) = v {
                    let chars = v.chars().count();
                    if chars == 0 || chars > MAX_NAME_CHARS || v.chars().any(char::is_control) {
                        return Err(err(
                            &format!("{key}.{k}"),
                            format!("expected 1 to {MAX_NAME_CHARS} characters without line breaks or control characters, got {chars} characters"),
                        ));
                    }
                }
            }
            let unit = p.unit.clone();
            // Values are kept (and shown) in the base unit of a range given with a unit; a
            // label of another unit would show 1e6 as "1e6 MPa".
            if let (Some(d), Some(u)) = (min_unit, unit.as_deref()) {
                if u.trim() != d.symbol() {
                    return Err(err(
                        &format!("{key}.unit"),
                        format!(
                            "min and max are given with units, so the values are kept and shown in {}; leave unit out or give unit = \"{}\"",
                            d.symbol(),
                            d.symbol()
                        ),
                    ));
                }
            }
            parameters.push(Parameter {
                name,
                paths,
                min,
                max,
                scale,
                dimension: min_unit,
                unit: unit.or_else(|| min_unit.map(|d| d.symbol().to_string())),
                label: p.label.clone(),
                symbol: p.symbol.as_deref().map(crate::text::symbol),
            });
        }

        // Targets: one [target], or several [[target]] tables combined as [objective] says.
        let combine = parse_objective(raw.objective.as_ref(), &err)?;
        let seen: Vec<TestOutputs> = tests
            .iter()
            .zip(&outputs)
            .map(|(t, (kind, outputs))| TestOutputs {
                name: &t.name,
                kind,
                outputs,
            })
            .collect();
        let tables: Vec<(String, &toml::Value)> = match &raw.target {
            Some(t @ toml::Value::Table(_)) => vec![("target".to_string(), t)],
            Some(toml::Value::Array(a)) if !a.is_empty() => a
                .iter()
                .enumerate()
                .map(|(i, v)| (format!("target[{i}]"), v))
                .collect(),
            Some(_) => {
                return Err(err(
                    "target",
                    "expected a [target] table or [[target]] tables".into(),
                ))
            }
            None => {
                return Err(err(
                    "target",
                    "missing: the lab value to calibrate against, e.g. [target] value = 38.65"
                        .into(),
                ))
            }
        };
        let entries = tables
            .iter()
            .map(|(key, v)| {
                crate::file::read::<TargetEntry>(key, (*v).clone()).map_err(|(k, m)| err(&k, m))
            })
            .collect::<Result<Vec<_>, _>>()?;
        let combine = match (tables.len(), combine) {
            (1, Some(_)) => {
                return Err(err(
                    "objective",
                    "combines several targets, and the study has one: remove [objective]".into(),
                ))
            }
            (1, None) => None,
            (_, Some(c)) => Some(c),
            (n, None) => {
                return Err(err(
                    "objective",
                    format!("missing: the study has {n} targets; say how they combine, e.g. [objective] combine = \"desirability\" (or \"weighted\")"),
                ))
            }
        };
        let targets = tables
            .iter()
            .zip(&entries)
            .map(|((key, _), t)| parse_target(t, key, &seen, combine, dir, &err))
            .collect::<Result<Vec<_>, _>>()?;
        for (i, a) in targets.iter().enumerate() {
            for b in &targets[..i] {
                if a.test == b.test && a.response == b.response {
                    return Err(err(
                        &format!("target[{i}].response"),
                        format!(
                            "{} of test {} is a target twice",
                            a.response, tests[a.test].name
                        ),
                    ));
                }
                if a.test == b.test && a.curve.is_some() && b.curve.is_some() {
                    return Err(err(
                        &format!("target[{i}].curve"),
                        format!("test {} is compared with lab curves twice: give one curve target per test, other measures of the same curve as its response", tests[a.test].name),
                    ));
                }
            }
        }
        if let Some(i) = (0..tests.len()).find(|i| !targets.iter().any(|t| t.test == *i)) {
            return Err(err(
                "target",
                format!("no target is measured in test {}: each test needs at least one (its target's test = \"{}\")", tests[i].name, tests[i].name),
            ));
        }
        let target = match combine {
            Some(c) => Target::combined(c),
            None => targets[0].clone(),
        };

        let ranges: Vec<(String, f64, f64)> = parameters
            .iter()
            .map(|p| (p.name.clone(), p.min, p.max))
            .collect();
        let plan = parse_plan(raw.plan.as_ref(), &err, &ranges)?;
        let executor = crate::executor::parse_executor(raw.executor.as_ref(), dir, &err)?;

        let study = Study {
            path: path.to_path_buf(),
            name,
            seed,
            tests,
            parameters,
            imports,
            targets,
            combine,
            target,
            plan,
            run_time_limit_s,
            backend,
            executor,
            text: text.to_string(),
        };
        // The test must read with every parameter set (middle values), and its settings and
        // materials must hold at each end of every range (the others in the middle), so that
        // a range the test would refuse (a restitution up to 1.6) shows now rather than after a
        // stage of failed runs. `check_scene` builds the whole scene before a study runs.
        let middle: Vec<f64> = study.parameters.iter().map(Parameter::middle).collect();
        // A range given with a unit must fit each key it is written to; checked one parameter
        // at a time so that the error names the parameter.
        for (i, p) in study.parameters.iter().enumerate() {
            let Some(unit) = p.dimension else { continue };
            for (path, ks) in &p.paths {
                for &k in ks {
                    let mut table = study.tests[k].table.clone();
                    path.set_quantity(&mut table, middle[i], Some(unit))?;
                    let label = study.test_label(k);
                    virtual_tests::TestFile::from_table_in(&label, &table, &study.tests[k].dir)
                        .map_err(|e| {
                            let e = e.strip_prefix(&format!("{label}: ")).unwrap_or(&e);
                            err(
                                &format!("parameter[{i}].min"),
                                format!(
                                    "{} is given in units of {}, which \"{path}\" does not take: {e}",
                                    p.name,
                                    unit.describe()
                                ),
                            )
                        })?;
                }
            }
        }
        study.check_values(&middle)?;
        for (i, p) in study.parameters.iter().enumerate() {
            for (end, v) in [("min", p.min), ("max", p.max)] {
                let mut values = middle.clone();
                values[i] = v;
                study.check_values(&values).map_err(|e| {
                    err(
                        &format!("parameter[{i}].{end}"),
                        format!("{} = {v} is refused by the test: {e}", p.name),
                    )
                })?;
            }
        }
        Ok(study)
    }

    /// Each test with `values` written in must read, pass its settings checks and have valid
    /// materials and interactions.
    fn check_values(&self, values: &[f64]) -> Result<(), String> {
        for (k, t) in self.tests.iter().enumerate() {
            let file = virtual_tests::TestFile::from_table_in(
                &self.test_label(k),
                &self.test_with(k, values),
                &t.dir,
            )?;
            virtual_tests::check_file(&file)?;
            if !file.parts.materials.is_empty() {
                file.check_materials()?;
            }
        }
        Ok(())
    }
}

/// Reads a test file (relative to the study's folder) or takes an inline table.
fn read_test(
    dir: &Path,
    v: &toml::Value,
    key: &str,
    err: &dyn Fn(&str, String) -> String,
) -> Result<(toml::Table, String, PathBuf), String> {
    let (table, source, test_dir) = match v {
        toml::Value::String(p) => {
            let tp = dir.join(p);
            let t = dem::files::read_text(&tp, dem::files::MAX_TEXT_BYTES)
                .map_err(|e| err(key, format!("cannot read {}: {e}", tp.display())))?;
            let table: toml::Table = toml::from_str(&t)
                .map_err(|e| format!("{}: {}", tp.display(), one_line(&e.to_string())))?;
            let parent = tp.parent().map(Path::to_path_buf).unwrap_or_default();
            (table, tp.display().to_string(), parent)
        }
        toml::Value::Table(t) => (t.clone(), "inline".to_string(), dir.to_path_buf()),
        _ => {
            return Err(err(
                key,
                "expected a test file's path or an inline table".into(),
            ))
        }
    };
    let test_dir = if test_dir.as_os_str().is_empty() {
        PathBuf::from(".")
    } else {
        test_dir
    };
    Ok((table, source, test_dir))
}

/// `test = "file.toml"`, an inline `[test]`, or `[[test]]` tables with `name` and `file` (or
/// the test's content inline).
fn parse_tests(
    test: Option<&toml::Value>,
    dir: &Path,
    err: &dyn Fn(&str, String) -> String,
) -> Result<Vec<TestSpec>, String> {
    let kind_of = |t: &toml::Table| {
        t.get("test")
            .and_then(|v| v.as_str())
            .unwrap_or("test")
            .to_string()
    };
    match test {
        None => Err(err(
            "test",
            "missing (a test file's path, e.g. test = \"repose.toml\", an inline [test] table, or [[test]] tables with name and file)".into(),
        )),
        Some(toml::Value::Array(list)) if !list.is_empty() => {
            let mut tests: Vec<TestSpec> = Vec::new();
            for (i, item) in list.iter().enumerate() {
                let key = format!("test[{i}]");
                let t = item
                    .as_table()
                    .ok_or_else(|| err(&key, "expected a table".into()))?;
                let mut inline = t.clone();
                inline.remove("name");
                let file = inline.remove("file");
                let (table, source, test_dir) = match file {
                    Some(f @ toml::Value::String(_)) if inline.is_empty() => {
                        read_test(dir, &f, &format!("{key}.file"), err)?
                    }
                    Some(toml::Value::String(_)) => {
                        return Err(err(
                            &format!("{key}.file"),
                            "give file or the test inline, not both".into(),
                        ))
                    }
                    Some(_) => {
                        return Err(err(
                            &format!("{key}.file"),
                            "expected a test file's path (relative to the study)".into(),
                        ))
                    }
                    None => read_test(dir, &toml::Value::Table(inline), &key, err)?,
                };
                let name = match t.get("name") {
                    None => kind_of(&table),
                    Some(toml::Value::String(s))
                        if !s.is_empty()
                            && s.chars()
                                .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-') =>
                    {
                        s.clone()
                    }
                    Some(_) => {
                        return Err(err(
                            &format!("{key}.name"),
                            "expected a name of letters, digits, _ and - (it names the test's folder in each run)".into(),
                        ))
                    }
                };
                if tests.iter().any(|x| x.name == name) {
                    return Err(err(
                        &format!("{key}.name"),
                        format!("two tests are named \"{name}\": give each [[test]] its own name"),
                    ));
                }
                tests.push(TestSpec {
                    name,
                    table,
                    source,
                    dir: test_dir,
                });
            }
            Ok(tests)
        }
        Some(v @ (toml::Value::String(_) | toml::Value::Table(_))) => {
            let (table, source, test_dir) = read_test(dir, v, "test", err)?;
            Ok(vec![TestSpec {
                name: kind_of(&table),
                table,
                source,
                dir: test_dir,
            }])
        }
        Some(_) => Err(err(
            "test",
            "expected a test file's path, an inline table, or [[test]] tables".into(),
        )),
    }
}

/// `[[import]]` tables: `study` (another study file), `parameter` (a name in its summary's
/// calibrated values) and `path` or `paths` (where the value goes in this study's test). The
/// value is read from the other study's `report/summary.json`, which `demcal run` writes.
fn parse_imports(
    list: &[ImportEntry],
    dir: &Path,
    tests: &mut [TestSpec],
    err: &dyn Fn(&str, String) -> String,
) -> Result<Vec<Import>, String> {
    let mut imports = Vec::new();
    for (i, entry) in list.iter().enumerate() {
        let key = format!("import[{i}]");
        let (study, parameter) = (entry.study.clone(), entry.parameter.clone());
        let paths = read_paths(
            entry.path.as_ref(),
            entry.paths.as_deref(),
            &key,
            tests,
            err,
        )?;
        let study_path = dir.join(&study);
        let other_dir = study_path
            .parent()
            .map(Path::to_path_buf)
            .filter(|p| !p.as_os_str().is_empty())
            .unwrap_or_else(|| PathBuf::from("."));
        let summary = other_dir.join("report").join("summary.json");
        let body = dem::files::read_text(&summary, dem::files::MAX_TEXT_BYTES).map_err(|e| {
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
        for (pp, ks) in &paths {
            for &k in ks {
                pp.set(&mut tests[k].table, value)
                    .map_err(|e| err(&format!("{key}.path"), format!("\"{pp}\": {e}")))?;
            }
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
/// and checked to reach a number in at least one of the tests; with each, the tests it reaches.
fn read_paths(
    path: Option<&String>,
    paths: Option<&[String]>,
    key: &str,
    tests: &[TestSpec],
    err: &dyn Fn(&str, String) -> String,
) -> Result<Vec<(ParamPath, Vec<usize>)>, String> {
    let texts: Vec<String> = match (path, paths) {
        (Some(s), None) => vec![s.clone()],
        (None, Some(a)) if !a.is_empty() => a.to_vec(),
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
        let checks: Vec<Result<f64, String>> = tests.iter().map(|x| pp.check(&x.table)).collect();
        let ks: Vec<usize> = (0..tests.len()).filter(|&k| checks[k].is_ok()).collect();
        if ks.is_empty() {
            let why = match &checks[..] {
                [Err(e)] => e.clone(),
                _ => format!(
                    "in none of the tests ({})",
                    tests
                        .iter()
                        .zip(&checks)
                        .map(|(x, c)| format!(
                            "{}: {}",
                            x.name,
                            c.clone().err().unwrap_or_default()
                        ))
                        .collect::<Vec<_>>()
                        .join("; ")
                ),
            };
            return Err(err(&format!("{key}.path"), format!("\"{s}\": {why}")));
        }
        paths.push((pp, ks));
    }
    Ok(paths)
}
