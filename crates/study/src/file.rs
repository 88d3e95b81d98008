//! Sections of a study file as serde reads them: plain structs that reject unknown keys, read
//! with `serde_path_to_error` so that every error names its key (`parameter[1].min`), and
//! serde's wording turned into the one-line form the rest of the study reader uses ("unknown key
//! (expected ...)", "missing", "expected ..., got ..."). What serde cannot say (min < max, a path
//! that reaches the test, a value the test refuses) `load` checks after reading. The keys each
//! struct accepts come from the struct itself ([`keys_of`], through `dem::keys`), so the reference's key tables cannot
//! drift from what is read. The bottom of the crate: it imports nothing of it.

use serde::de::{self, DeserializeOwned};
use serde::Deserialize;

/// An enum read from one of the strings its variants are named by in files; anything else (a
/// wrong string, a number, a table) is refused with the choices.
macro_rules! choices {
    ($(#[$m:meta])* $name:ident { $($variant:ident = $text:literal),+ $(,)? }) => {
        $(#[$m])*
        #[derive(Clone, Copy, Debug, PartialEq, Eq)]
        pub enum $name { $($variant),+ }

        impl $name {
            /// The names files give the choices by.
            pub const NAMES: &'static [&'static str] = &[$($text),+];
        }

        impl<'de> Deserialize<'de> for $name {
            fn deserialize<D: de::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
                let v = toml::Value::deserialize(d)?;
                match v.as_str() {
                    $(Some($text) => Ok($name::$variant),)+
                    _ => Err(de::Error::custom(format!(
                        "invalid value: {v}, expected {}",
                        quoted_choices(Self::NAMES)
                    ))),
                }
            }
        }
    };
}

/// `"a", "b" or "c"`.
fn quoted_choices(names: &[&str]) -> String {
    let quoted: Vec<String> = names.iter().map(|n| format!("\"{n}\"")).collect();
    or_list(&quoted.join(", "))
}

/// The top level of a study file. The sections read by a registry (`plan` by the stages',
/// `executor` by the executors') or with checks across tests (`test`, `target`, `objective`)
/// stay TOML here and are handed on.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StudyFile {
    pub name: Option<String>,
    #[serde(default, deserialize_with = "whole_number")]
    pub seed: Option<u64>,
    pub test: Option<toml::Value>,
    pub parameter: Option<Vec<ParameterEntry>>,
    pub target: Option<toml::Value>,
    pub plan: Option<toml::Value>,
    #[serde(default, deserialize_with = "seconds")]
    pub run_time_limit_s: Option<f64>,
    pub import: Option<Vec<ImportEntry>>,
    pub objective: Option<toml::Value>,
    pub backend: Option<String>,
    pub executor: Option<toml::Value>,
}

/// A `[[parameter]]`: a name, where its value goes in the test(s), its range (numbers, or
/// strings with units), its scale and the unit its values are shown in.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ParameterEntry {
    pub name: String,
    pub path: Option<String>,
    pub paths: Option<Vec<String>>,
    pub min: dem::units::Quantity,
    pub max: dem::units::Quantity,
    pub scale: Option<ScaleName>,
    pub unit: Option<String>,
    /// How the report names it ("bead-bead rolling friction"); the name otherwise.
    pub label: Option<String>,
    /// Its symbol in the report (`mu_r`, `e`, `G`): Greek names become letters, `_x` a
    /// subscript.
    pub symbol: Option<String>,
}

/// An `[[import]]`: a value another study calibrated (`parameter` of `study`'s summary) written
/// into this study's test(s).
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ImportEntry {
    pub study: String,
    pub parameter: String,
    pub path: Option<String>,
    pub paths: Option<Vec<String>>,
}

/// `[objective]`: how several targets combine into one number.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObjectiveEntry {
    pub combine: Option<CombineName>,
}

/// A `[target]` (or one of several `[[target]]`): the lab value of one of a test's responses, or
/// the lab's curves to compare the test's curve with (the curve keys, `curve` to `length_m`), and
/// how it weighs against the other targets.
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TargetEntry {
    pub response: Option<String>,
    pub value: Option<Number>,
    pub replicates: Option<Vec<Number>>,
    pub unit: Option<String>,
    pub test: Option<String>,
    pub weight: Option<Number>,
    pub importance: Option<Whole>,
    pub low: Option<Number>,
    pub high: Option<Number>,
    pub curve: Option<String>,
    pub lab_curves: Option<FileNames>,
    pub normalisation: Option<NormalisationName>,
    pub area_m2: Option<Number>,
    pub length_m: Option<Number>,
}

impl TargetEntry {
    /// Whether key `k` is given.
    pub fn given(&self, k: &str) -> bool {
        match k {
            "response" => self.response.is_some(),
            "value" => self.value.is_some(),
            "replicates" => self.replicates.is_some(),
            "unit" => self.unit.is_some(),
            "test" => self.test.is_some(),
            "weight" => self.weight.is_some(),
            "importance" => self.importance.is_some(),
            "low" => self.low.is_some(),
            "high" => self.high.is_some(),
            "curve" => self.curve.is_some(),
            "lab_curves" => self.lab_curves.is_some(),
            "normalisation" => self.normalisation.is_some(),
            "area_m2" => self.area_m2.is_some(),
            "length_m" => self.length_m.is_some(),
            _ => false,
        }
    }
}

choices! {
    /// How simulated and lab curves are scaled before they are compared.
    NormalisationName { None = "none", LabPeak = "lab_peak", StressStrain = "stress_strain" }
}

/// A number (TOML's integers too), named so in errors.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Number(pub f64);

impl<'de> Deserialize<'de> for Number {
    fn deserialize<D: de::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl de::Visitor<'_> for V {
            type Value = Number;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a number")
            }
            fn visit_f64<E: de::Error>(self, v: f64) -> Result<Number, E> {
                Ok(Number(v))
            }
            fn visit_i64<E: de::Error>(self, v: i64) -> Result<Number, E> {
                Ok(Number(v as f64))
            }
            fn visit_u64<E: de::Error>(self, v: u64) -> Result<Number, E> {
                Ok(Number(v as f64))
            }
        }
        d.deserialize_any(V)
    }
}

/// A whole number, named so in errors.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Whole(pub i64);

impl<'de> Deserialize<'de> for Whole {
    fn deserialize<D: de::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl de::Visitor<'_> for V {
            type Value = Whole;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a whole number")
            }
            fn visit_i64<E: de::Error>(self, v: i64) -> Result<Whole, E> {
                Ok(Whole(v))
            }
            fn visit_u64<E: de::Error>(self, v: u64) -> Result<Whole, E> {
                i64::try_from(v)
                    .map(Whole)
                    .map_err(|_| E::custom(format!("{v} is too large")))
            }
        }
        d.deserialize_any(V)
    }
}

/// A file name or a non-empty list of them.
#[derive(Clone, Debug, PartialEq)]
pub struct FileNames(pub Vec<String>);

impl<'de> Deserialize<'de> for FileNames {
    fn deserialize<D: de::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> de::Visitor<'de> for V {
            type Value = FileNames;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a CSV file name or a non-empty list of them")
            }
            fn visit_str<E: de::Error>(self, v: &str) -> Result<FileNames, E> {
                Ok(FileNames(vec![v.to_string()]))
            }
            fn visit_seq<A: de::SeqAccess<'de>>(self, mut a: A) -> Result<FileNames, A::Error> {
                let mut names = Vec::new();
                while let Some(n) = a.next_element::<String>()? {
                    names.push(n);
                }
                if names.is_empty() {
                    return Err(de::Error::invalid_length(0, &self));
                }
                Ok(FileNames(names))
            }
        }
        d.deserialize_any(V)
    }
}

choices! {
    /// A parameter's scale: its designs and models work on the value or on its logarithm.
    ScaleName { Linear = "linear", Log = "log" }
}

choices! {
    /// How several targets combine into one objective.
    CombineName { Weighted = "weighted", Desirability = "desirability" }
}

/// `T` from the TOML `value`, which sits at `prefix` in the file (empty: the top level). The
/// error is `(key, what was wrong)`, in the wording of the study reader's other messages.
pub fn read<T: DeserializeOwned>(prefix: &str, value: toml::Value) -> Result<T, (String, String)> {
    serde_path_to_error::deserialize(value).map_err(|e| {
        let path = e.path().to_string();
        let at = if path == "." || path.is_empty() {
            prefix.to_string()
        } else if prefix.is_empty() {
            path
        } else if path.starts_with('[') {
            format!("{prefix}{path}")
        } else {
            format!("{prefix}.{path}")
        };
        explain(&at, &e.into_inner().to_string())
    })
}

fn join(at: &str, key: &str) -> String {
    if at.is_empty() {
        key.to_string()
    } else if at == key || at.ends_with(&format!(".{key}")) {
        at.to_string()
    } else {
        format!("{at}.{key}")
    }
}

/// serde's message at `at` as `(key, message)` in our words: unknown keys with the list the
/// table takes, missing keys under their own name, wrong types as "expected X, got Y".
fn explain(at: &str, message: &str) -> (String, String) {
    let msg = message.split_whitespace().collect::<Vec<_>>().join(" ");
    // toml's value errors end with " in `key`", which the key in front already says.
    let msg = match msg.rfind(" in `") {
        Some(i) if msg.ends_with('`') => msg[..i].to_string(),
        _ => msg,
    };
    let names = |list: &str| list.replace('`', "").replace(" or ", ", ");
    if let Some(rest) = msg.strip_prefix("missing field `") {
        let field = rest.trim_end_matches('`');
        return (join(at, field), "missing".to_string());
    }
    if let Some(rest) = msg.strip_prefix("unknown field `") {
        if let Some((field, expected)) = rest.split_once('`') {
            let expected = expected
                .trim_start_matches(", expected one of ")
                .trim_start_matches(", expected ");
            let why = if expected.starts_with(", there are no fields") {
                "unknown key (this table takes none)".to_string()
            } else {
                format!("unknown key (expected {})", names(expected))
            };
            return (join(at, field), why);
        }
    }
    if let Some(rest) = msg.strip_prefix("unknown variant `") {
        if let Some((got, expected)) = rest.split_once('`') {
            let expected = expected
                .trim_start_matches(", expected one of ")
                .trim_start_matches(", expected ");
            let choices = or_list(&expected.replace('`', "\""));
            return (at.to_string(), format!("expected {choices}, got \"{got}\""));
        }
    }
    for lead in ["invalid type: ", "invalid value: ", "invalid length "] {
        if let Some(rest) = msg.strip_prefix(lead) {
            if let Some((got, expected)) = rest.rsplit_once(", expected ") {
                // A derived struct expects "struct ParameterEntry": in a file, a table.
                let expected = if expected.starts_with("struct ") {
                    "a table"
                } else {
                    expected
                };
                let mut got = got.replace('`', "");
                if lead == "invalid length " {
                    got = format!("{got} entries");
                }
                // serde's words for TOML's tables and arrays.
                if got == "map" {
                    got = "a table".to_string();
                } else if got == "sequence" {
                    got = "a list".to_string();
                }
                if expected == "a sequence" {
                    let name = at.rsplit('.').next().unwrap_or(at);
                    let want = if got == "a table" {
                        format!("[[{name}]] tables (write [[{name}]], not [{name}])")
                    } else {
                        format!("[[{name}]] tables")
                    };
                    return (at.to_string(), format!("expected {want}, got {got}"));
                }
                return (at.to_string(), format!("expected {expected}, got {got}"));
            }
        }
    }
    (at.to_string(), msg)
}

/// `a, b, c` as `a, b or c`.
fn or_list(list: &str) -> String {
    match list.rsplit_once(", ") {
        Some((head, last)) => format!("{head} or {last}"),
        None => list.to_string(),
    }
}

/// The keys the struct `T` reads, in its order, as serde's derive lists them.
pub fn keys_of<T: DeserializeOwned>() -> Vec<&'static str> {
    dem::keys::of::<T>()
}

/// A whole number >= 0.
fn whole_number<'de, D: de::Deserializer<'de>>(d: D) -> Result<Option<u64>, D::Error> {
    match toml::Value::deserialize(d)? {
        toml::Value::Integer(n) if n >= 0 => Ok(Some(n as u64)),
        v => Err(de::Error::custom(format!(
            "invalid value: {v}, expected a whole number >= 0"
        ))),
    }
}

/// Seconds > 0.
fn seconds<'de, D: de::Deserializer<'de>>(d: D) -> Result<Option<f64>, D::Error> {
    let v = toml::Value::deserialize(d)?;
    match v {
        toml::Value::Integer(n) if n > 0 => Ok(Some(n as f64)),
        toml::Value::Float(x) if x > 0.0 && x.is_finite() => Ok(Some(x)),
        v => Err(de::Error::custom(format!(
            "invalid value: {v}, expected seconds > 0"
        ))),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn top(text: &str) -> Result<StudyFile, (String, String)> {
        read("", toml::Value::Table(toml::from_str(text).unwrap()))
    }

    #[test]
    fn errors_name_the_key_and_say_what_was_expected() {
        let (k, m) = top("seed = 3\njobs = 2").unwrap_err();
        assert_eq!(k, "jobs");
        assert!(
            m.starts_with("unknown key (expected name, seed, test, "),
            "{m}"
        );
        let (k, m) = top("parameter = [3]").unwrap_err();
        assert_eq!(
            (k.as_str(), m.as_str()),
            ("parameter[0]", "expected a table, got integer 3")
        );
        let (k, m) = top("[parameter]\nname = \"a\"").unwrap_err();
        assert_eq!(k, "parameter");
        assert_eq!(
            m,
            "expected [[parameter]] tables (write [[parameter]], not [parameter]), got a table"
        );
        let (k, m) = top("[[parameter]]\nname = \"a\"\npath = \"x\"\nmin = 0\nmax = 1\nscale = 3")
            .unwrap_err();
        assert_eq!(k, "parameter[0].scale");
        assert_eq!(m, "expected \"linear\" or \"log\", got 3");
        let (_, m) = top(
            "[[parameter]]\nname = \"a\"\npath = \"x\"\nmin = 0\nmax = 1\nscale = { log = {} }",
        )
        .unwrap_err();
        assert!(
            m.starts_with("expected \"linear\" or \"log\", got {"),
            "{m}"
        );
        let (k, m) = top("seed = -1").unwrap_err();
        assert_eq!(
            (k.as_str(), m.as_str()),
            ("seed", "expected a whole number >= 0, got -1")
        );
        let (k, m) = top("[[parameter]]\nname = \"a\"\npath = \"x\"\nmax = 1").unwrap_err();
        assert_eq!((k.as_str(), m.as_str()), ("parameter[0].min", "missing"));
        let (k, m) =
            top("[[parameter]]\nname = \"a\"\npath = \"x\"\nmin = 0\nmax = 1\nscale = \"logs\"")
                .unwrap_err();
        assert_eq!(k, "parameter[0].scale");
        assert_eq!(m, "expected \"linear\" or \"log\", got \"logs\"");
        let (k, m) = top("[[parameter]]\nname = 3\npath = \"x\"\nmin = 0\nmax = 1").unwrap_err();
        assert_eq!(
            (k.as_str(), m.as_str()),
            ("parameter[0].name", "expected a string, got integer 3")
        );
        let (k, m) =
            top("[[import]]\nstudy = \"s.toml\"\nparameter = \"a\"\npath = \"x\"\nvalue = 1")
                .unwrap_err();
        assert_eq!(k, "import[0].value");
        assert!(
            m.starts_with("unknown key (expected study, parameter"),
            "{m}"
        );
        let f = top("run_time_limit_s = 2\n[[parameter]]\nname = \"a\"\npaths = [\"x\", \"y\"]\nmin = \"1 MPa\"\nmax = 2e6").unwrap();
        assert_eq!(f.run_time_limit_s, Some(2.0));
        let p = &f.parameter.unwrap()[0];
        assert_eq!(
            p.paths.as_deref(),
            Some(&["x".to_string(), "y".to_string()][..])
        );
        assert_eq!(p.min.value, 1e6);
        assert_eq!(p.scale, None);
    }

    #[test]
    fn the_keys_come_from_the_structs() {
        assert_eq!(
            keys_of::<StudyFile>(),
            [
                "name",
                "seed",
                "test",
                "parameter",
                "target",
                "plan",
                "run_time_limit_s",
                "import",
                "objective",
                "backend",
                "executor"
            ]
        );
        assert_eq!(keys_of::<ObjectiveEntry>(), ["combine"]);
    }
}
