//! Parameter paths: where a calibrated value goes in the test's TOML. Segments are separated by
//! dots; a segment naming an array of tables picks one with `[...]`: `material[bead]` (by name),
//! `interaction[bead,steel]` (by the pair of materials, in either order) or `[2]` (by position).
//!
//! `interaction[bead,steel].static_friction`, `material[silage].shear_modulus`,
//! `angle_of_repose.lift_speed`, `function.variables.x`.

#[derive(Clone, Debug, PartialEq)]
enum Select {
    Index(usize),
    Name(String),
    Pair(String, String),
}

#[derive(Clone, Debug, PartialEq)]
struct Segment {
    key: String,
    select: Option<Select>,
}

#[derive(Clone, Debug, PartialEq)]
pub struct ParamPath {
    pub text: String,
    segments: Vec<Segment>,
}

impl ParamPath {
    /// Whether `other` reaches the same value (however either is spaced or written).
    pub fn same_place(&self, other: &ParamPath) -> bool {
        self.segments == other.segments
    }
}

impl std::fmt::Display for ParamPath {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.text)
    }
}

impl ParamPath {
    pub fn parse(text: &str) -> Result<ParamPath, String> {
        let bad = |why: &str| format!("\"{text}\": {why}");
        let mut segments = Vec::new();
        for part in text.split('.') {
            let part = part.trim();
            let (key, select) = match part.find('[') {
                None => (part, None),
                Some(open) => {
                    let inner = part[open + 1..]
                        .strip_suffix(']')
                        .ok_or_else(|| bad("expected ']' at the end of a segment"))?;
                    let items: Vec<&str> = inner.split(',').map(str::trim).collect();
                    let select = match items.as_slice() {
                        [one] if one.parse::<usize>().is_ok() => {
                            Select::Index(one.parse().unwrap())
                        }
                        [one] if !one.is_empty() => Select::Name(one.to_string()),
                        [a, b] if !a.is_empty() && !b.is_empty() => {
                            Select::Pair(a.to_string(), b.to_string())
                        }
                        _ => return Err(bad("expected [name], [material,material] or [index]")),
                    };
                    (&part[..open], Some(select))
                }
            };
            if key.is_empty() {
                return Err(bad("empty segment"));
            }
            segments.push(Segment {
                key: key.to_string(),
                select,
            });
        }
        if segments.last().is_some_and(|s| s.select.is_some()) {
            return Err(bad("must end at a value, not at a table"));
        }
        Ok(ParamPath {
            text: text.to_string(),
            segments,
        })
    }

    /// The number at the path (a string with a unit, `"29 MPa"`, counts, in its base unit), or
    /// why there is none.
    pub fn check(&self, root: &toml::Table) -> Result<f64, String> {
        let mut copy = root.clone();
        let slot = self.slot(&mut copy)?;
        match (number(slot), slot.as_str()) {
            (Some(x), _) => Ok(x),
            (None, Some(s)) => dem::units::parse(s)
                .map(|(x, _)| x)
                .map_err(|e| format!("holds {e}")),
            _ => Err(format!("holds {slot}, not a number")),
        }
    }

    /// Writes `value` at the path.
    pub fn set(&self, root: &mut toml::Table, value: f64) -> Result<(), String> {
        self.set_quantity(root, value, None)
    }

    /// Writes `value` at the path: a number, or with `unit` a string in the dimension's base
    /// unit (`"2.9e7 Pa"`), which the test's reader converts back exactly and checks that the key
    /// takes that dimension.
    pub fn set_quantity(
        &self,
        root: &mut toml::Table,
        value: f64,
        unit: Option<dem::units::Dimension>,
    ) -> Result<(), String> {
        *self.slot(root)? = match unit {
            None => toml::Value::Float(value),
            Some(d) => toml::Value::String(format!("{value:e} {}", d.symbol())),
        };
        Ok(())
    }

    /// Writes any TOML value at the path (a quantity with its unit, `"29 MPa"`, from the Python
    /// API, where the test's reader checks the unit).
    pub fn set_value(&self, root: &mut toml::Table, value: toml::Value) -> Result<(), String> {
        *self.slot(root)? = value;
        Ok(())
    }

    fn slot<'a>(&self, root: &'a mut toml::Table) -> Result<&'a mut toml::Value, String> {
        let mut table = root;
        let last = self.segments.len() - 1;
        let mut walked = String::new();
        for (i, seg) in self.segments.iter().enumerate() {
            if !walked.is_empty() {
                walked.push('.');
            }
            walked.push_str(&seg.key);
            let keys = || table.keys().cloned().collect::<Vec<_>>().join(", ");
            if !table.contains_key(&seg.key) {
                return Err(format!("the test has no \"{walked}\" (there: {})", keys()));
            }
            let value = table.get_mut(&seg.key).unwrap();
            if i == last {
                return Ok(value);
            }
            let next = match (&seg.select, value) {
                (None, toml::Value::Table(t)) => t,
                (Some(sel), toml::Value::Array(items)) => {
                    let describe = |t: &toml::Table| -> String {
                        if let Some(n) = t.get("name").and_then(|v| v.as_str()) {
                            n.to_string()
                        } else if let Some(toml::Value::Array(m)) = t.get("materials") {
                            m.iter()
                                .filter_map(|v| v.as_str())
                                .collect::<Vec<_>>()
                                .join(",")
                        } else {
                            "?".into()
                        }
                    };
                    let listed: Vec<String> = items
                        .iter()
                        .filter_map(|v| v.as_table().map(describe))
                        .collect();
                    let found = items.iter_mut().enumerate().find(|(j, v)| {
                        let Some(t) = v.as_table() else { return false };
                        match sel {
                            Select::Index(k) => j == k,
                            Select::Name(n) => t.get("name").and_then(|v| v.as_str()) == Some(n),
                            Select::Pair(a, b) => match t.get("materials") {
                                Some(toml::Value::Array(m)) if m.len() == 2 => {
                                    let (x, y) = (m[0].as_str(), m[1].as_str());
                                    (x == Some(a) && y == Some(b)) || (x == Some(b) && y == Some(a))
                                }
                                _ => false,
                            },
                        }
                    });
                    match found {
                        Some((_, toml::Value::Table(t))) => t,
                        _ => {
                            return Err(format!(
                                "no {} matches {} (there: {})",
                                seg.key,
                                match sel {
                                    Select::Index(k) => format!("[{k}]"),
                                    Select::Name(n) => format!("[{n}]"),
                                    Select::Pair(a, b) => format!("[{a},{b}]"),
                                },
                                listed.join("; ")
                            ))
                        }
                    }
                }
                (None, toml::Value::Array(_)) => {
                    return Err(format!(
                    "\"{walked}\" is a list: pick one with [name], [material,material] or [index]"
                ))
                }
                (Some(_), _) => return Err(format!("\"{walked}\" is not a list of tables")),
                (None, _) => return Err(format!("\"{walked}\" is a value, not a table")),
            };
            table = next;
        }
        unreachable!()
    }
}

/// A TOML integer or float as a number.
pub fn number(v: &toml::Value) -> Option<f64> {
    match v {
        toml::Value::Float(f) => Some(*f),
        toml::Value::Integer(i) => Some(*i as f64),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const TEST: &str = r#"
test = "angle_of_repose"
[[material]]
name = "bead"
shear_modulus = 5e6
[[interaction]]
materials = ["bead", "steel"]
static_friction = 0.5
[angle_of_repose]
lift_speed = 0.1
"#;

    #[test]
    fn paths_find_and_set_values() {
        let mut t: toml::Table = toml::from_str(TEST).unwrap();
        let p = ParamPath::parse("interaction[steel,bead].static_friction").unwrap();
        assert_eq!(p.check(&t).unwrap(), 0.5);
        p.set(&mut t, 0.7).unwrap();
        assert_eq!(p.check(&t).unwrap(), 0.7);
        assert_eq!(
            ParamPath::parse("material[bead].shear_modulus")
                .unwrap()
                .check(&t)
                .unwrap(),
            5e6
        );
        assert_eq!(
            ParamPath::parse("material[0].shear_modulus")
                .unwrap()
                .check(&t)
                .unwrap(),
            5e6
        );
        assert_eq!(
            ParamPath::parse("angle_of_repose.lift_speed")
                .unwrap()
                .check(&t)
                .unwrap(),
            0.1
        );
        let e = ParamPath::parse("interaction[bead,bead].static_friction")
            .unwrap()
            .check(&t)
            .unwrap_err();
        assert!(
            e.contains("no interaction matches [bead,bead]") && e.contains("bead,steel"),
            "{e}"
        );
        let e = ParamPath::parse("angle_of_repose.lift_sped")
            .unwrap()
            .check(&t)
            .unwrap_err();
        assert!(e.contains("no \"angle_of_repose.lift_sped\""), "{e}");
        assert!(ParamPath::parse("material[bead]").is_err());
        assert!(ParamPath::parse("material[bead.x").is_err());
    }
}
