//! The small formulas of a calibration's lab side, each with the formula it used written out
//! (docs/features.md, "Lab helpers"): friction from a tilt angle, elastic and shear modulus from a
//! load-displacement slope, moisture content on a wet basis, bulk density, relative error.

/// A computed quantity: its name, value, unit and the formula with the numbers put in.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Worked {
    pub name: &'static str,
    pub value: f64,
    pub unit: &'static str,
    pub formula: String,
}

/// The results, or an error when one overflowed (inputs each finite but together past any real
/// range, e.g. a slope of 1e308 N/m): a value of `inf` is no answer to print.
pub fn finite(worked: Vec<Worked>) -> Result<Vec<Worked>, String> {
    match worked.iter().find(|w| !w.value.is_finite()) {
        Some(w) => Err(format!(
            "{}: the result is {} {}: the inputs are past any real range (check their units)",
            w.name, w.value, w.unit
        )),
        None => Ok(worked),
    }
}

fn positive(name: &str, v: f64) -> Result<f64, String> {
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        Err(format!("{name}: expected a number > 0, got {v}"))
    }
}

/// mu_s = tan(tilt angle at which the sample starts to slide).
pub fn friction_from_tilt(tilt_deg: f64) -> Result<Vec<Worked>, String> {
    if !(tilt_deg.is_finite() && tilt_deg > 0.0 && tilt_deg < 90.0) {
        return Err(format!(
            "--tilt-deg: expected an angle between 0 and 90 degrees, got {tilt_deg}"
        ));
    }
    let mu = tilt_deg.to_radians().tan();
    Ok(vec![Worked {
        name: "static_friction",
        value: mu,
        unit: "",
        formula: format!("mu_s = tan(angle) = tan({tilt_deg} deg) = {mu:.4}"),
    }])
}

/// E = 4 k L0 / (pi d^2) for a cylindrical specimen of length L0 and diameter d compressed
/// along its axis with load-displacement slope k; with a Poisson ratio also G = E / (2 (1 + nu)).
pub fn modulus(
    slope_n_per_m: f64,
    length_m: f64,
    diameter_m: f64,
    poisson: Option<f64>,
) -> Result<Vec<Worked>, String> {
    let k = positive("--slope", slope_n_per_m)?;
    let l = positive("--length", length_m)?;
    let d = positive("--diameter", diameter_m)?;
    let e = 4.0 * k * l / (std::f64::consts::PI * d * d);
    let mut out = vec![Worked {
        name: "youngs_modulus",
        value: e,
        unit: "Pa",
        formula: format!(
            "E = 4 k L0 / (pi d^2) = 4 x {k} N/m x {l} m / (pi x ({d} m)^2) = {e:.4e} Pa"
        ),
    }];
    if let Some(nu) = poisson {
        if !(nu.is_finite() && nu > -1.0 && nu < 0.5) {
            return Err(format!(
                "--poisson: expected a ratio between -1 and 0.5, got {nu}"
            ));
        }
        let g = e / (2.0 * (1.0 + nu));
        out.push(Worked {
            name: "shear_modulus",
            value: g,
            unit: "Pa",
            formula: format!("G = E / (2 (1 + nu)) = {e:.4e} Pa / (2 x (1 + {nu})) = {g:.4e} Pa"),
        });
    }
    Ok(out)
}

/// Moisture content on a wet basis: m_water / (m_water + m_dry), from the sample's mass before
/// and after drying.
pub fn moisture(wet_kg: f64, dry_kg: f64) -> Result<Vec<Worked>, String> {
    let wet = positive("--wet", wet_kg)?;
    let dry = positive("--dry", dry_kg)?;
    if dry > wet {
        return Err(format!(
            "--dry {dry} is more than --wet {wet}: the dried sample cannot weigh more"
        ));
    }
    let mc = (wet - dry) / wet;
    Ok(vec![Worked {
        name: "moisture_content_wet_basis",
        value: 100.0 * mc,
        unit: "%",
        formula: format!(
            "MC = m_water / (m_water + m_dry) = ({wet} - {dry}) / {wet} = {:.2} %",
            100.0 * mc
        ),
    }])
}

/// Bulk density = (m_filled - m_empty) / V of a container filled and struck off.
pub fn bulk_density(filled_kg: f64, empty_kg: f64, volume_m3: f64) -> Result<Vec<Worked>, String> {
    let filled = positive("--filled", filled_kg)?;
    let empty = if empty_kg.is_finite() && empty_kg >= 0.0 {
        empty_kg
    } else {
        return Err(format!("--empty: expected a mass >= 0, got {empty_kg}"));
    };
    let v = positive("--volume", volume_m3)?;
    if empty >= filled {
        return Err(format!(
            "--empty {empty} is not less than --filled {filled}: the container holds nothing"
        ));
    }
    let rho = (filled - empty) / v;
    Ok(vec![Worked {
        name: "bulk_density",
        value: rho,
        unit: "kg/m^3",
        formula: format!(
            "rho_b = (m_filled - m_empty) / V = ({filled} - {empty}) kg / {v} m^3 = {rho:.4} kg/m^3"
        ),
    }])
}

/// e = |sim - lab| / lab x 100 %.
pub fn relative_error(simulated: f64, lab: f64) -> Result<Vec<Worked>, String> {
    if !simulated.is_finite() {
        return Err(format!("--simulated: expected a number, got {simulated}"));
    }
    if !(lab.is_finite() && lab != 0.0) {
        return Err(format!("--lab: expected a number other than 0, got {lab}"));
    }
    let e = 100.0 * (simulated - lab).abs() / lab.abs();
    // Values near f64's ends overflow the difference or the quotient.
    if !e.is_finite() {
        return Err(format!(
            "--simulated {simulated}, --lab {lab}: the relative error is not a finite number"
        ));
    }
    Ok(vec![Worked {
        name: "relative_error",
        value: e,
        unit: "%",
        formula: format!(
            "e = |sim - lab| / lab x 100 % = |{simulated} - {lab}| / {lab} x 100 % = {e:.3} %"
        ),
    }])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn published_values() {
        // Maize on steel: 28.6 deg gives mu_s = 0.545 (docs/lab-tests.md section 2).
        let mu = friction_from_tilt(28.6).unwrap()[0].value;
        assert!((mu - 0.545).abs() < 5e-4, "{mu}");
        // A 10 mm x 20 mm cylinder with k = 1e5 N/m: E = 4e5 x 0.02 / (pi 1e-4) = 25.46 MPa.
        let m = modulus(1e5, 0.02, 0.01, Some(0.31)).unwrap();
        assert!((m[0].value - 8.0e3 / (std::f64::consts::PI * 1e-4)).abs() < 1e-6);
        assert!((m[1].value - m[0].value / 2.62).abs() < 1e-6);
        assert!(m[0].formula.starts_with("E = 4 k L0 / (pi d^2)"));
        assert!((moisture(0.1, 0.0635).unwrap()[0].value - 36.5).abs() < 1e-9);
        assert!((bulk_density(1.5, 0.5, 0.001).unwrap()[0].value - 1000.0).abs() < 1e-9);
        assert!((relative_error(27.67, 27.35).unwrap()[0].value - 1.17001828).abs() < 1e-6);
    }

    #[test]
    fn a_result_that_overflows_is_refused() {
        let e = modulus(1e308, 1e308, 1e-300, None)
            .and_then(finite)
            .unwrap_err();
        assert!(e.starts_with("youngs_modulus: the result is inf Pa"), "{e}");
        let e = bulk_density(1e308, 1e-308, 1e-308)
            .and_then(finite)
            .unwrap_err();
        assert!(e.starts_with("bulk_density: the result is inf"), "{e}");
        assert!(moisture(2.0, 1.0).and_then(finite).is_ok());
    }

    #[test]
    fn absurd_inputs_name_the_option() {
        assert!(friction_from_tilt(95.0)
            .unwrap_err()
            .starts_with("--tilt-deg"));
        assert!(modulus(-1.0, 0.02, 0.01, None)
            .unwrap_err()
            .starts_with("--slope"));
        assert!(modulus(1.0, 0.02, 0.01, Some(0.7))
            .unwrap_err()
            .starts_with("--poisson"));
        assert!(moisture(0.1, 0.2).unwrap_err().starts_with("--dry"));
        assert!(bulk_density(0.5, 0.5, 1.0)
            .unwrap_err()
            .starts_with("--empty"));
        assert!(relative_error(1.0, 0.0).unwrap_err().starts_with("--lab"));
        // The difference overflows: refused, not printed as "inf %" (issue 40).
        assert!(relative_error(1e308, -1e308)
            .unwrap_err()
            .ends_with("the relative error is not a finite number"));
    }
}
