//! The report's tables of what a study holds fixed and what it calibrates: the test's settings
//! (particles, materials, interactions, geometry and speeds, time step and simulated time), and
//! each parameter's fate: calibrated, held at a value (screened out), or left undetermined by
//! the final model with the stretch of values the optimiser found equally good. Units come from
//! the keys (a friction has none, a density is in kg/m³) unless a parameter gives its own.

use std::fmt::Write;

use crate::record::Replay;
use crate::spec::{Parameter, Study};
use crate::stages::{self};
use crate::store::{RunRecord, Status};
use crate::text::sig;
use crate::text::{esc, letter};

/// The unit of a setting, material property or parameter told from its key: "–" for a
/// quantity without dimension, "" where the key does not say.
pub(crate) fn unit_of_key(key: &str) -> &'static str {
    let k = key.to_ascii_lowercase();
    let is = |s: &str| k == s || k.ends_with(&format!("_{s}"));
    let table: &[(&[&str], &str)] = &[
        (&["percent"], "%"),
        (&["deg", "angle"], "deg"),
        (&["m_s", "speed", "velocity"], "m/s"),
        (&["rad_s", "angular_velocity"], "rad/s"),
        (&["kg", "mass"], "kg"),
        (&["energy_density"], "J/m³"),
        (&["density"], "kg/m³"),
        (&["modulus", "pa"], "Pa"),
        (&["surface_energy"], "J/m²"),
        (&["force", "n"], "N"),
        (&["s", "time", "interval"], "s"),
        (
            &[
                "m",
                "radius",
                "diameter",
                "height",
                "size",
                "distance",
                "length",
                "width",
                "depth",
                "thickness",
                "gap",
            ],
            "m",
        ),
        (
            &[
                "friction",
                "restitution",
                "ratio",
                "coefficient",
                "damping",
                "fraction",
                "band",
            ],
            "–",
        ),
    ];
    for (keys, unit) in table {
        if keys.iter().any(|s| is(s)) {
            return unit;
        }
    }
    ""
}

/// A parameter's unit: its own `unit`, else told from its path's last key.
pub(crate) fn parameter_unit(p: &Parameter) -> String {
    if let Some(u) = &p.unit {
        return if u.trim() == "-" {
            "–".into()
        } else {
            u.clone()
        };
    }
    p.paths
        .first()
        .map(|(path, _)| {
            let last = path.text.rsplit('.').next().unwrap_or(&path.text);
            unit_of_key(last).to_string()
        })
        .unwrap_or_default()
}

/// `name (unit)` for a table's column heading, or the name alone.
fn with_unit(name: &str, unit: &str) -> String {
    if unit.is_empty() {
        esc(name)
    } else {
        format!("{} ({})", esc(name), esc(unit))
    }
}

/// What became of a parameter.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum Fate {
    /// Set by the optimiser (or the best run) from a model that depends on it.
    Calibrated,
    /// Not calibrated: held at its value, and why.
    Held(String),
    /// Set by a calibrating stage, but not identified (at a range end, hardly mattering, on a
    /// ridge with another): why, and its 95 % interval (actual units) when it has one.
    Undetermined(String, Option<(f64, f64)>),
}

/// Each parameter's fate, from the stages the study went through.
pub(crate) fn fates(study: &Study, r: &Replay) -> Vec<Fate> {
    let mut fate = vec![Fate::Calibrated; study.parameters.len()];
    for st in &r.stages {
        if st.kind == "screening" && !st.selected().is_empty() {
            let p_of = |j: usize| {
                let fit = st.fit.as_ref()?;
                fit.terms
                    .iter()
                    .skip(1)
                    .zip(&fit.anova_terms)
                    .find(|(t, _)| t.order() == 1 && t.powers.get(j) == Some(&1))
                    .and_then(|(_, row)| row.p)
            };
            for (j, &pi) in st.active.iter().enumerate() {
                if !st.selected().contains(&pi) {
                    let p = p_of(j)
                        .map(|p| format!(", p = {} in the screening model", doe::fit::fmt_p(p)))
                        .unwrap_or_default();
                    fate[pi] = Fate::Held(format!(
                        "screened out at stage {}{p}; held at the middle of its range",
                        st.index + 1
                    ));
                }
            }
        }
    }
    let name = |i: usize| study.parameters[i].name.clone();
    for (stage, p) in crate::uncertainty_report::per_parameter(study, &r.stages)
        .into_iter()
        .flatten()
    {
        if !p.flags.is_empty() {
            let why = p
                .flags
                .iter()
                .map(|f| f.text(&name))
                .collect::<Vec<_>>()
                .join("; ");
            fate[p.parameter] =
                Fate::Undetermined(format!("{why} (stage {})", stage + 1), p.interval);
        } else if p.interval.is_none() {
            fate[p.parameter] = Fate::Undetermined(
                format!(
                    "no interval: no setting matches the lab value within the model's uncertainty (stage {})",
                    stage + 1
                ),
                None,
            );
        }
    }
    fate
}

/// The summary's table of parameters: letter, name and unit, where it goes, range, scale, the
/// value the validation used with its 95 % interval, and what became of it.
pub(crate) fn parameters_table(h: &mut String, study: &Study, r: &Replay) {
    let calibrated = stages::calibrated(study, &r.stages);
    let fates = fates(study, r);
    let intervals = crate::uncertainty_report::per_parameter(study, &r.stages);
    h.push_str("<div class=\"scroll\"><table><tr><th>Factor</th><th class=\"l\">Parameter (unit) and where in the test</th><th>Range</th><th class=\"l\">Scale</th><th>Value used</th><th>95 % interval</th><th class=\"l\">Status</th></tr>");
    for (i, p) in study.parameters.iter().enumerate() {
        let value = match (&intervals[i], &calibrated) {
            (Some((_, pi)), _) => crate::uncertainty_report::value_text(pi),
            (None, Some(v)) => sig(v[i]),
            (None, None) => "-".into(),
        };
        let interval = match &intervals[i] {
            Some((_, pi)) => match pi.interval {
                Some((lo, hi)) => {
                    let (_, a, b) = crate::uncertainty::rounded(pi.value, lo, hi);
                    format!(
                        "{}{a} to {}{b}",
                        if pi.open.0 { "≤ " } else { "" },
                        if pi.open.1 { "≥ " } else { "" }
                    )
                }
                None => "none".into(),
            },
            None => "-".into(),
        };
        let (class, status) = match &fates[i] {
            Fate::Calibrated if calibrated.is_some() => ("", "calibrated".to_string()),
            Fate::Calibrated => ("", "not calibrated yet".to_string()),
            Fate::Held(why) => ("", format!("held at {value}: {why}")),
            Fate::Undetermined(why, _) => (
                " class=\"flag\"",
                format!("⚠ not identified, so not reported as calibrated: {why}; {value} is the value the stage set"),
            ),
        };
        write!(
            h,
            "<tr{class}><td>{}</td><td class=\"l name\">{}<br><span class=\"mono path\">{}</span></td><td>{} to {}</td><td class=\"l\">{}</td><td>{value}</td><td>{}</td><td class=\"l wrap\">{}</td></tr>",
            letter(i),
            with_unit(&p.display_name(), &parameter_unit(p)),
            esc(&p.paths.iter().map(|x| x.0.text.clone()).collect::<Vec<_>>().join(", ")),
            sig(p.min),
            sig(p.max),
            if p.scale == doe::Scale::Log { "log" } else { "linear" },
            esc(&interval),
            esc(&status)
        )
        .unwrap();
    }
    h.push_str("</table></div>");
}

/// A number to four significant digits; very large and very small ones as m × 10ⁿ.
pub(crate) fn num(v: f64) -> String {
    let a = v.abs();
    if v == 0.0 || !v.is_finite() || (1e-3..1e5).contains(&a) {
        return sig(v);
    }
    let e = a.log10().floor() as i32;
    let m = v / 10f64.powi(e);
    // Rounding can carry the mantissa to 10.
    let (m, e) = if (m.abs() * 1e3).round() >= 1e4 {
        (m / 10.0, e + 1)
    } else {
        (m, e)
    };
    let sup: String = e
        .to_string()
        .chars()
        .map(|c| match c {
            '-' => '⁻',
            d => ['⁰', '¹', '²', '³', '⁴', '⁵', '⁶', '⁷', '⁸', '⁹']
                [d.to_digit(10).unwrap_or(0) as usize],
        })
        .collect();
    format!("{m:.3} × 10{sup}")
}

/// A value of the test's TOML for a table: numbers to four significant digits, a parameter's
/// slot named after it (its sentinel), lists and tables inline.
fn cell(
    v: &toml::Value,
    owner: &dyn Fn(f64) -> Option<usize>,
    what: &dyn Fn(usize) -> String,
) -> String {
    match v {
        toml::Value::Float(x) => match owner(*x) {
            Some(i) => what(i),
            None => num(*x),
        },
        toml::Value::Integer(n) => n.to_string(),
        toml::Value::String(s) => esc(s),
        toml::Value::Boolean(b) => b.to_string(),
        toml::Value::Array(a) => format!(
            "[{}]",
            a.iter()
                .map(|x| cell(x, owner, what))
                .collect::<Vec<_>>()
                .join(", ")
        ),
        toml::Value::Table(t) => t
            .iter()
            .map(|(k, x)| format!("{} {}", esc(k), cell(x, owner, what)))
            .collect::<Vec<_>>()
            .join(", "),
        toml::Value::Datetime(d) => d.to_string(),
    }
}

/// The sentinel written into parameter `i`'s slots to find them in the test's tables.
fn sentinel(i: usize) -> f64 {
    -7.654321e29 * (i as f64 + 1.0)
}

/// Mean, least and greatest of an output over the finished runs.
fn output_stats(
    stored: &[RunRecord],
    test: Option<&str>,
    key: &str,
) -> Option<(f64, f64, f64, usize)> {
    let v: Vec<f64> = stored
        .iter()
        .filter(|r| r.status == Status::Done)
        .filter_map(|r| {
            let o = match test {
                Some(t) => &r.outputs["tests"][t],
                None => &r.outputs,
            };
            o[key].as_f64()
        })
        .collect();
    if v.is_empty() {
        return None;
    }
    let (lo, hi) = v
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, b), x| (a.min(*x), b.max(*x)));
    Some((v.iter().sum::<f64>() / v.len() as f64, lo, hi, v.len()))
}

/// "mean (min to max over N runs)", or the value when every run gave the same.
fn over_runs(s: (f64, f64, f64, usize), scale: f64) -> String {
    let (m, lo, hi, n) = s;
    if (hi - lo).abs() <= 1e-9 * m.abs().max(1e-300) {
        num(m * scale)
    } else {
        format!(
            "{} (mean; {} to {} over {n} runs)",
            num(m * scale),
            num(lo * scale),
            num(hi * scale)
        )
    }
}

/// The section on the test's fixed settings.
pub(crate) fn fixed_settings(h: &mut String, study: &Study, r: &Replay, stored: &[RunRecord]) {
    let fates = fates(study, r);
    let calibrated = stages::calibrated(study, &r.stages);
    h.push_str("<h2>The virtual test: what it holds fixed</h2><p>Every run of the study simulates this set-up; only the parameters above change. A cell with a parameter's letter holds that parameter: its value where the study holds it (held), else the value each run sets.</p>");
    let sentinels: Vec<f64> = (0..study.parameters.len()).map(sentinel).collect();
    let owner = |x: f64| sentinels.iter().position(|s| *s == x);
    let what = |i: usize| -> String {
        let p = &study.parameters[i];
        match &fates[i] {
            Fate::Held(_) => format!(
                "{} <span title=\"{}\">({}, held)</span>",
                calibrated.as_ref().map(|v| num(v[i])).unwrap_or_default(),
                esc(&p.name),
                letter(i)
            ),
            Fate::Undetermined(..) => format!(
                "<i title=\"{}\">{}, undetermined</i>",
                esc(&p.name),
                letter(i)
            ),
            Fate::Calibrated => format!(
                "<i title=\"{}\">{}, calibrated</i>",
                esc(&p.name),
                letter(i)
            ),
        }
    };
    for (k, test) in study.tests.iter().enumerate() {
        let table = study.test_with(k, &sentinels);
        let several = study.tests.len() > 1;
        if several {
            write!(h, "<h3>Test {}: {}</h3>", esc(&test.name), esc(test.kind())).unwrap();
        }
        let kind = test.kind().to_string();
        // The test's settings with its defaults where it gives them, else the file's table.
        let full = virtual_tests::registry::find(&kind).and_then(|reg| {
            let file =
                virtual_tests::TestFile::from_table_in(&test.name, &table, &test.dir).ok()?;
            reg.full_settings(&file)
        });
        let settings = full.or_else(|| table.get(&kind).cloned());
        let settings = settings.as_ref().and_then(|v| v.as_table());
        let test_key = several.then_some(test.name.as_str());
        particles_table(h, settings, stored, test_key, &owner, &what);
        materials_table(h, &table, &owner, &what);
        interactions_table(h, &table, &owner, &what);
        if let Some(s) = settings {
            geometry_table(h, s, &owner, &what);
        }
        time_table(h, settings, stored, test_key);
    }
}

type Owner<'a> = dyn Fn(f64) -> Option<usize> + 'a;
type What<'a> = dyn Fn(usize) -> String + 'a;

fn particles_table(
    h: &mut String,
    settings: Option<&toml::Table>,
    stored: &[RunRecord],
    test: Option<&str>,
    owner: &Owner,
    what: &What,
) {
    let Some(s) = settings else { return };
    let Some(p) = s.get("particles").and_then(|v| v.as_table()) else {
        return;
    };
    h.push_str("<h3>Particles</h3><div class=\"scroll\"><table><tr><th class=\"l\">Material or types</th><th class=\"l\">Shape and size (radius, m)</th><th class=\"l\">Amount asked for</th><th>Particles made</th><th>Total mass (kg)</th></tr>");
    let material = p
        .get("material")
        .map(|v| cell(v, owner, what))
        .or_else(|| {
            p.get("types").map(|t| {
                let fr = p
                    .get("fractions")
                    .map(|f| cell(f, owner, what))
                    .unwrap_or_default();
                let basis = p
                    .get("basis")
                    .map(|b| cell(b, owner, what))
                    .unwrap_or_default();
                format!(
                    "mixture {} (fractions {fr} by {basis})",
                    cell(t, owner, what)
                )
            })
        })
        .unwrap_or_default();
    let shape = match (p.get("size"), p.get("shape")) {
        (Some(size), _) => {
            // The size distribution's kind first, then its radii.
            let kind = size.get("type").and_then(|t| t.as_str()).unwrap_or("size");
            let rest = size
                .as_table()
                .map(|t| {
                    t.iter()
                        .filter(|(k, _)| k.as_str() != "type")
                        .map(|(k, x)| format!("{} {}", esc(k), cell(x, owner, what)))
                        .collect::<Vec<_>>()
                        .join(", ")
                })
                .unwrap_or_default();
            format!("spheres, {} {rest}", esc(kind))
        }
        (None, Some(shape)) => format!(
            "clump shape {}{}",
            cell(shape, owner, what),
            p.get("scale")
                .map(|v| format!(", scale {}", cell(v, owner, what)))
                .unwrap_or_default()
        ),
        _ => "as the particle types give".into(),
    };
    let amount = s
        .get("fill")
        .map(|f| cell(f, owner, what))
        .unwrap_or_default();
    let made = output_stats(stored, test, "particles")
        .map(|(m, lo, hi, n)| {
            if lo == hi {
                format!("{m:.0}")
            } else {
                format!("{lo:.0} to {hi:.0} over {n} runs")
            }
        })
        .unwrap_or_else(|| "-".into());
    let mass = output_stats(stored, test, "particle_mass_kg")
        .map(|v| over_runs(v, 1.0))
        .unwrap_or_else(|| "-".into());
    write!(
        h,
        "<tr><td class=\"l\">{material}</td><td class=\"l wrap\">{shape}</td><td class=\"l wrap\">{amount}</td><td>{made}</td><td>{mass}</td></tr></table></div>"
    )
    .unwrap();
}

fn materials_table(h: &mut String, table: &toml::Table, owner: &Owner, what: &What) {
    let Some(list) = table.get("material").and_then(|v| v.as_array()) else {
        return;
    };
    let mut keys: Vec<String> = Vec::new();
    for m in list.iter().filter_map(|m| m.as_table()) {
        for k in m.keys() {
            if k != "name" && !keys.contains(k) {
                keys.push(k.clone());
            }
        }
    }
    h.push_str("<h3>Materials</h3><div class=\"scroll\"><table><tr><th class=\"l\">Material</th>");
    for k in &keys {
        write!(h, "<th>{}</th>", with_unit(k, unit_of_key(k))).unwrap();
    }
    h.push_str("</tr>");
    for m in list.iter().filter_map(|m| m.as_table()) {
        write!(
            h,
            "<tr><td class=\"l\">{}</td>",
            m.get("name")
                .map(|v| cell(v, owner, what))
                .unwrap_or_default()
        )
        .unwrap();
        for k in &keys {
            write!(
                h,
                "<td>{}</td>",
                m.get(k).map(|v| cell(v, owner, what)).unwrap_or_default()
            )
            .unwrap();
        }
        h.push_str("</tr>");
    }
    h.push_str("</table></div>");
}

fn interactions_table(h: &mut String, table: &toml::Table, owner: &Owner, what: &What) {
    let Some(list) = table.get("interaction").and_then(|v| v.as_array()) else {
        return;
    };
    let mut keys: Vec<String> = Vec::new();
    for m in list.iter().filter_map(|m| m.as_table()) {
        for k in m.keys() {
            if k != "materials" && !keys.contains(k) {
                keys.push(k.clone());
            }
        }
    }
    h.push_str("<h3>Interactions</h3><div class=\"scroll\"><table><tr><th class=\"l\">Pair</th>");
    for k in &keys {
        write!(h, "<th>{}</th>", with_unit(k, unit_of_key(k))).unwrap();
    }
    h.push_str("</tr>");
    for m in list.iter().filter_map(|m| m.as_table()) {
        let pair = m
            .get("materials")
            .and_then(|v| v.as_array())
            .map(|a| {
                a.iter()
                    .filter_map(|x| x.as_str())
                    .map(esc)
                    .collect::<Vec<_>>()
                    .join(" – ")
            })
            .unwrap_or_default();
        write!(h, "<tr><td class=\"l\">{pair}</td>").unwrap();
        for k in &keys {
            write!(
                h,
                "<td class=\"wrap\">{}</td>",
                m.get(k).map(|v| cell(v, owner, what)).unwrap_or_default()
            )
            .unwrap();
        }
        h.push_str("</tr>");
    }
    h.push_str("</table></div>");
}

/// The test's other settings: geometry, speeds, settling and measurement.
fn geometry_table(h: &mut String, settings: &toml::Table, owner: &Owner, what: &What) {
    let rows: Vec<(&String, &toml::Value)> = settings
        .iter()
        .filter(|(k, _)| !["particles", "fill"].contains(&k.as_str()))
        .collect();
    if rows.is_empty() {
        return;
    }
    h.push_str("<h3>Geometry, speeds and measurement</h3><div class=\"scroll\"><table><tr><th class=\"l\">Setting</th><th>Value</th><th class=\"l\">Unit</th></tr>");
    for (k, v) in rows {
        write!(
            h,
            "<tr><td class=\"l mono\">{}</td><td>{}</td><td class=\"l\">{}</td></tr>",
            esc(k),
            cell(v, owner, what),
            esc(
                if matches!(v, toml::Value::Float(_) | toml::Value::Array(_)) {
                    unit_of_key(k)
                } else {
                    ""
                }
            )
        )
        .unwrap();
    }
    h.push_str("</table></div>");
}

/// Time step, its share of the Rayleigh step, and the simulated time, from the runs' outputs.
fn time_table(
    h: &mut String,
    settings: Option<&toml::Table>,
    stored: &[RunRecord],
    test: Option<&str>,
) {
    let dt = output_stats(stored, test, "time_step_s");
    let rayleigh = output_stats(stored, test, "rayleigh_time_step_s");
    let simulated = output_stats(stored, test, "simulated_time_s");
    if dt.is_none() && simulated.is_none() {
        return;
    }
    h.push_str("<h3>Time step and simulated time</h3><div class=\"scroll\"><table><tr><th class=\"l\">Quantity</th><th>Value</th><th class=\"l\">Unit</th></tr>");
    if let Some(d) = dt {
        write!(
            h,
            "<tr><td class=\"l\">time step</td><td>{}</td><td class=\"l\">s</td></tr>",
            over_runs(d, 1.0)
        )
        .unwrap();
        let share = match rayleigh {
            Some(r) => Some(sig(100.0 * d.0 / r.0)),
            None => settings
                .and_then(|s| s.get("time_step_percent"))
                .and_then(|v| v.as_float().or_else(|| v.as_integer().map(|i| i as f64)))
                .map(sig),
        };
        if let Some(r) = rayleigh {
            write!(h, "<tr><td class=\"l\">Rayleigh time step of the smallest particle</td><td>{}</td><td class=\"l\">s</td></tr>", over_runs(r, 1.0)).unwrap();
        }
        if let Some(s) = share {
            write!(h, "<tr><td class=\"l\">time step as a share of the Rayleigh step</td><td>{s}</td><td class=\"l\">%</td></tr>").unwrap();
        }
    }
    if let Some(t) = simulated {
        write!(h, "<tr><td class=\"l\">simulated time per run (settling, the test, the final settling)</td><td>{}</td><td class=\"l\">s</td></tr>", over_runs(t, 1.0)).unwrap();
    }
    h.push_str("</table></div>");
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn large_and_small_numbers_read_as_powers_of_ten() {
        assert_eq!(num(5e6), "5.000 × 10⁶");
        assert_eq!(num(7e10), "7.000 × 10¹⁰");
        assert_eq!(num(2.9396e-5), "2.940 × 10⁻⁵");
        assert_eq!(num(9.99996e5), "1.000 × 10⁶");
        assert_eq!(num(0.045), "0.04500");
        assert_eq!(num(1500.0), "1500");
    }

    #[test]
    fn units_are_told_from_keys() {
        for (key, unit) in [
            ("static_friction", "–"),
            ("rolling_friction", "–"),
            ("restitution", "–"),
            ("poisson_ratio", "–"),
            ("density", "kg/m³"),
            ("shear_modulus", "Pa"),
            ("cylinder_diameter", "m"),
            ("plate_size", "m"),
            ("lift_speed", "m/s"),
            ("settle_max_time", "s"),
            ("time_step_percent", "%"),
            ("heap_height_m", "m"),
            ("angle_of_repose_deg", "deg"),
            ("wall_material", ""),
            ("planes", ""),
        ] {
            assert_eq!(unit_of_key(key), unit, "{key}");
        }
    }
}
