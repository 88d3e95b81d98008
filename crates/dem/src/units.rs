//! Quantities in input files: a bare number in the key's own unit (SI, or degrees for an angle),
//! or a string with a unit (`"3 mm"`, `"29 MPa"`, `"0.6 m/s"`, `"10 mm/min"`, `"40 deg"`),
//! converted once when the file is read, so nothing past the reader ever sees a unit.
//!
//! Each key with a dimension is read by a serde `deserialize_with` function of the dimension's
//! module ([`length::one`], [`stress::opt`], [`length::three`], ...), so a wrong dimension is a
//! serde error and the file reader's usual message names the file, the key and the line:
//! `scene.toml: material[0].shear_modulus: "29 mm" is a length, expected a stress (Pa), e.g.
//! "29 MPa" (line 7)`. Keys whose dimension depends on another key (a size distribution is a
//! radius for spheres and a scale factor for clumps) read a [`Quantity`], which keeps the unit's
//! dimension for the reader to check.
//!
//! Why not a units crate (uom, dimensioned): they type quantities in the engine, which would touch
//! every formula for no gain once values are converted at the door; what is needed here is a table
//! of the units our users write and a parser of "number unit".

use serde::de::{self, Deserializer, Visitor};
use serde::Deserialize;
use std::fmt;
use std::marker::PhantomData;

/// What a quantity measures.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Dimension {
    Length,
    Time,
    Mass,
    Speed,
    Acceleration,
    Stress,
    Density,
    Angle,
    AngularSpeed,
    Force,
    SurfaceEnergy,
    BondStiffness,
    MassRate,
    Stiffness,
}

impl Dimension {
    /// The quantity's name and SI unit, for messages: "a length (m)".
    pub fn describe(self) -> &'static str {
        match self {
            Dimension::Length => "a length (m)",
            Dimension::Time => "a time (s)",
            Dimension::Mass => "a mass (kg)",
            Dimension::Speed => "a speed (m/s)",
            Dimension::Acceleration => "an acceleration (m/s2)",
            Dimension::Stress => "a stress or modulus (Pa)",
            Dimension::Density => "a density (kg/m3)",
            Dimension::Angle => "an angle (deg)",
            Dimension::AngularSpeed => "an angular speed (rad/s)",
            Dimension::Force => "a force (N)",
            Dimension::SurfaceEnergy => "a surface energy (J/m2)",
            Dimension::BondStiffness => "a stiffness per area (N/m3)",
            Dimension::MassRate => "a mass rate (kg/s)",
            Dimension::Stiffness => "a stiffness (N/m)",
        }
    }

    /// The base unit's symbol, as [`parse`] reads it.
    pub fn symbol(self) -> &'static str {
        match self {
            Dimension::Length => "m",
            Dimension::Time => "s",
            Dimension::Mass => "kg",
            Dimension::Speed => "m/s",
            Dimension::Acceleration => "m/s2",
            Dimension::Stress => "Pa",
            Dimension::Density => "kg/m3",
            Dimension::Angle => "deg",
            Dimension::AngularSpeed => "rad/s",
            Dimension::Force => "N",
            Dimension::SurfaceEnergy => "J/m2",
            Dimension::BondStiffness => "N/m3",
            Dimension::MassRate => "kg/s",
            Dimension::Stiffness => "N/m",
        }
    }

    /// An example string with a unit, for messages.
    pub fn example(self) -> &'static str {
        match self {
            Dimension::Length => "\"3 mm\"",
            Dimension::Time => "\"2 ms\"",
            Dimension::Mass => "\"50 g\"",
            Dimension::Speed => "\"10 mm/min\"",
            Dimension::Acceleration => "\"9.81 m/s2\"",
            Dimension::Stress => "\"29 MPa\"",
            Dimension::Density => "\"1.2 g/cm3\"",
            Dimension::Angle => "\"40 deg\"",
            Dimension::AngularSpeed => "\"30 rpm\"",
            Dimension::Force => "\"5 kN\"",
            Dimension::SurfaceEnergy => "\"0.2 J/m2\"",
            Dimension::BondStiffness => "\"5e9 N/m3\"",
            Dimension::MassRate => "\"2 kg/s\"",
            Dimension::Stiffness => "\"20 N/mm\"",
        }
    }
}

const PI: f64 = std::f64::consts::PI;

/// Every unit accepted, with its dimension and its size in the dimension's base unit (SI; degrees
/// for angles, since every angle key of our files is in degrees). Spellings users write in papers
/// and in EDEM are listed as they are (`^3` and `3`, `um` for µm).
const UNITS: &[(&str, Dimension, f64)] = &[
    ("m", Dimension::Length, 1.0),
    ("cm", Dimension::Length, 1e-2),
    ("mm", Dimension::Length, 1e-3),
    ("um", Dimension::Length, 1e-6),
    ("µm", Dimension::Length, 1e-6),
    ("s", Dimension::Time, 1.0),
    ("ms", Dimension::Time, 1e-3),
    ("us", Dimension::Time, 1e-6),
    ("µs", Dimension::Time, 1e-6),
    ("min", Dimension::Time, 60.0),
    ("h", Dimension::Time, 3600.0),
    ("kg", Dimension::Mass, 1.0),
    ("g", Dimension::Mass, 1e-3),
    ("mg", Dimension::Mass, 1e-6),
    ("m/s", Dimension::Speed, 1.0),
    ("cm/s", Dimension::Speed, 1e-2),
    ("mm/s", Dimension::Speed, 1e-3),
    ("m/min", Dimension::Speed, 1.0 / 60.0),
    ("mm/min", Dimension::Speed, 1e-3 / 60.0),
    ("km/h", Dimension::Speed, 1.0 / 3.6),
    ("m/s2", Dimension::Acceleration, 1.0),
    ("m/s^2", Dimension::Acceleration, 1.0),
    ("Pa", Dimension::Stress, 1.0),
    ("kPa", Dimension::Stress, 1e3),
    ("MPa", Dimension::Stress, 1e6),
    ("GPa", Dimension::Stress, 1e9),
    ("N/m2", Dimension::Stress, 1.0),
    ("N/m^2", Dimension::Stress, 1.0),
    ("N/mm2", Dimension::Stress, 1e6),
    ("N/mm^2", Dimension::Stress, 1e6),
    ("kg/m3", Dimension::Density, 1.0),
    ("kg/m^3", Dimension::Density, 1.0),
    ("g/cm3", Dimension::Density, 1e3),
    ("g/cm^3", Dimension::Density, 1e3),
    ("g/ml", Dimension::Density, 1e3),
    ("kg/l", Dimension::Density, 1e3),
    ("t/m3", Dimension::Density, 1e3),
    ("deg", Dimension::Angle, 1.0),
    ("°", Dimension::Angle, 1.0),
    ("rad", Dimension::Angle, 180.0 / PI),
    ("rad/s", Dimension::AngularSpeed, 1.0),
    ("deg/s", Dimension::AngularSpeed, PI / 180.0),
    ("°/s", Dimension::AngularSpeed, PI / 180.0),
    ("rpm", Dimension::AngularSpeed, 2.0 * PI / 60.0),
    ("N", Dimension::Force, 1.0),
    ("mN", Dimension::Force, 1e-3),
    ("kN", Dimension::Force, 1e3),
    ("J/m2", Dimension::SurfaceEnergy, 1.0),
    ("J/m^2", Dimension::SurfaceEnergy, 1.0),
    ("mJ/m2", Dimension::SurfaceEnergy, 1e-3),
    ("mJ/m^2", Dimension::SurfaceEnergy, 1e-3),
    ("N/m3", Dimension::BondStiffness, 1.0),
    ("N/m^3", Dimension::BondStiffness, 1.0),
    ("N/mm3", Dimension::BondStiffness, 1e9),
    ("N/mm^3", Dimension::BondStiffness, 1e9),
    ("kg/s", Dimension::MassRate, 1.0),
    ("g/s", Dimension::MassRate, 1e-3),
    ("kg/min", Dimension::MassRate, 1.0 / 60.0),
    ("kg/h", Dimension::MassRate, 1.0 / 3600.0),
    ("N/m", Dimension::Stiffness, 1.0),
    ("N/mm", Dimension::Stiffness, 1e3),
    ("kN/m", Dimension::Stiffness, 1e3),
];

/// A value read from a string with a unit: the value in the dimension's base unit, and the
/// dimension.
pub fn parse(text: &str) -> Result<(f64, Dimension), String> {
    let t = text.trim();
    let end = number_end(t);
    let (num, unit) = t.split_at(end);
    let value: f64 = num.parse().map_err(|_| {
        format!("\"{text}\": expected a number and a unit, such as \"3 mm\" or \"29 MPa\"")
    })?;
    let unit = unit.trim();
    if unit.is_empty() {
        return Err(format!(
            "\"{text}\": a number in quotes needs a unit (\"3 mm\"); write a plain number without quotes for the SI unit"
        ));
    }
    match UNITS.iter().find(|(s, _, _)| *s == unit) {
        Some((_, dim, factor)) if value.is_finite() => Ok((value * factor, *dim)),
        Some(_) => Err(format!("\"{text}\": the number is not finite")),
        None => {
            let near: Vec<&str> = UNITS
                .iter()
                .filter(|(s, _, _)| s.eq_ignore_ascii_case(unit))
                .map(|(s, _, _)| *s)
                .collect();
            let hint = if near.is_empty() {
                String::new()
            } else {
                format!(" (did you mean {}?)", near.join(" or "))
            };
            Err(format!("\"{text}\": unknown unit \"{unit}\"{hint}"))
        }
    }
}

/// Where the number at the start of `t` ends: digits, a sign, a point, and an exponent only when a
/// digit or sign follows the `e`, so that a unit beginning with a letter is left whole.
fn number_end(t: &str) -> usize {
    let b = t.as_bytes();
    let mut i = 0;
    while i < b.len() {
        let c = b[i];
        let ok = c.is_ascii_digit()
            || c == b'.'
            || ((c == b'+' || c == b'-') && (i == 0 || matches!(b[i - 1], b'e' | b'E')))
            || ((c == b'e' || c == b'E')
                && i > 0
                && b.get(i + 1)
                    .is_some_and(|n| n.is_ascii_digit() || *n == b'+' || *n == b'-'));
        if !ok {
            break;
        }
        i += 1;
    }
    i
}

/// `text` as a value of dimension `want`, in units of `base` (the key's own unit in the dimension's
/// base unit: 1 for SI keys, π/180 for a key in deg/s).
pub fn parse_as(text: &str, want: Dimension, base: f64) -> Result<f64, String> {
    let (value, dim) = parse(text)?;
    if dim != want {
        return Err(format!(
            "\"{text}\" is {}, expected {}, e.g. {}",
            dim.describe(),
            want.describe(),
            want.example()
        ));
    }
    Ok(value / base)
}

/// A quantity whose dimension the reader checks later (when it depends on another key).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Quantity {
    /// The value: the number as written, or converted to the base unit when a unit was given.
    pub value: f64,
    /// The unit's dimension; `None` for a bare number.
    pub dimension: Option<Dimension>,
}

impl Quantity {
    /// The value as a quantity of `want` (a bare number is taken in the base unit), or why not.
    pub fn as_dimension(&self, want: Dimension) -> Result<f64, String> {
        match self.dimension {
            None => Ok(self.value),
            Some(d) if d == want => Ok(self.value),
            Some(d) => Err(format!(
                "{} {} is {}, expected {}",
                self.value,
                d.symbol(),
                d.describe(),
                want.describe()
            )),
        }
    }

    /// The value as a plain number (a scale factor, a fraction), refusing a unit.
    pub fn as_number(&self, what: &str) -> Result<f64, String> {
        match self.dimension {
            None => Ok(self.value),
            Some(d) => Err(format!(
                "{what} is a plain number, but {} {} ({}) was given",
                self.value,
                d.symbol(),
                d.describe()
            )),
        }
    }
}

impl<'de> Deserialize<'de> for Quantity {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl Visitor<'_> for V {
            type Value = Quantity;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a number, or a string with a unit such as \"3 mm\"")
            }
            fn visit_f64<E: de::Error>(self, v: f64) -> Result<Quantity, E> {
                Ok(Quantity {
                    value: v,
                    dimension: None,
                })
            }
            fn visit_i64<E: de::Error>(self, v: i64) -> Result<Quantity, E> {
                self.visit_f64(v as f64)
            }
            fn visit_u64<E: de::Error>(self, v: u64) -> Result<Quantity, E> {
                self.visit_f64(v as f64)
            }
            fn visit_str<E: de::Error>(self, v: &str) -> Result<Quantity, E> {
                let (value, dim) = parse(v).map_err(E::custom)?;
                Ok(Quantity {
                    value,
                    dimension: Some(dim),
                })
            }
        }
        d.deserialize_any(V)
    }
}

/// A dimension and the key's unit in its base unit, as a type, so one generic reader serves
/// every dimension.
pub trait Unit {
    const DIMENSION: Dimension;
    /// The key's unit in the dimension's base unit (1 for SI keys).
    const BASE: f64 = 1.0;
}

/// One value of unit `U`: a number taken as is, or a string converted.
struct Of<U: Unit>(f64, PhantomData<U>);

impl<'de, U: Unit> Deserialize<'de> for Of<U> {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V<U>(PhantomData<U>);
        impl<U: Unit> Visitor<'_> for V<U> {
            type Value = Of<U>;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                write!(
                    f,
                    "{}: a number, or a string with a unit such as {}",
                    U::DIMENSION.describe(),
                    U::DIMENSION.example()
                )
            }
            fn visit_f64<E: de::Error>(self, v: f64) -> Result<Of<U>, E> {
                Ok(Of(v, PhantomData))
            }
            fn visit_i64<E: de::Error>(self, v: i64) -> Result<Of<U>, E> {
                self.visit_f64(v as f64)
            }
            fn visit_u64<E: de::Error>(self, v: u64) -> Result<Of<U>, E> {
                self.visit_f64(v as f64)
            }
            fn visit_str<E: de::Error>(self, v: &str) -> Result<Of<U>, E> {
                parse_as(v, U::DIMENSION, U::BASE)
                    .map(|x| Of(x, PhantomData))
                    .map_err(E::custom)
            }
        }
        d.deserialize_any(V(PhantomData))
    }
}

/// Readers of one dimension, for `#[serde(deserialize_with = "...")]`: `one` (a value), `opt` (an
/// optional value; pair it with `#[serde(default)]`), `two`, `three`, `four` and `list` (arrays of
/// values), and `opt_two`, `opt_three`, `opt_list`.
macro_rules! unit_module {
    ($module:ident, $marker:ident, $dim:expr, $base:expr, $doc:literal) => {
        #[doc = $doc]
        pub struct $marker;
        impl Unit for $marker {
            const DIMENSION: Dimension = $dim;
            const BASE: f64 = $base;
        }
        #[doc = $doc]
        pub mod $module {
            use super::{$marker, Of};
            use serde::{Deserialize, Deserializer};
            type T = Of<$marker>;
            pub fn one<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
                T::deserialize(d).map(|v| v.0)
            }
            pub fn opt<'de, D: Deserializer<'de>>(d: D) -> Result<Option<f64>, D::Error> {
                Option::<T>::deserialize(d).map(|v| v.map(|v| v.0))
            }
            pub fn two<'de, D: Deserializer<'de>>(d: D) -> Result<[f64; 2], D::Error> {
                <[T; 2]>::deserialize(d).map(|[a, b]| [a.0, b.0])
            }
            pub fn three<'de, D: Deserializer<'de>>(d: D) -> Result<[f64; 3], D::Error> {
                <[T; 3]>::deserialize(d).map(|[a, b, c]| [a.0, b.0, c.0])
            }
            pub fn four<'de, D: Deserializer<'de>>(d: D) -> Result<[f64; 4], D::Error> {
                <[T; 4]>::deserialize(d).map(|[a, b, c, e]| [a.0, b.0, c.0, e.0])
            }
            pub fn list<'de, D: Deserializer<'de>>(d: D) -> Result<Vec<f64>, D::Error> {
                Vec::<T>::deserialize(d).map(|v| v.into_iter().map(|v| v.0).collect())
            }
            pub fn opt_two<'de, D: Deserializer<'de>>(d: D) -> Result<Option<[f64; 2]>, D::Error> {
                Option::<[T; 2]>::deserialize(d).map(|v| v.map(|[a, b]| [a.0, b.0]))
            }
            pub fn opt_three<'de, D: Deserializer<'de>>(
                d: D,
            ) -> Result<Option<[f64; 3]>, D::Error> {
                Option::<[T; 3]>::deserialize(d).map(|v| v.map(|[a, b, c]| [a.0, b.0, c.0]))
            }
            pub fn opt_list<'de, D: Deserializer<'de>>(d: D) -> Result<Option<Vec<f64>>, D::Error> {
                Option::<Vec<T>>::deserialize(d)
                    .map(|v| v.map(|v| v.into_iter().map(|v| v.0).collect()))
            }
            pub fn opt_three_list<'de, D: Deserializer<'de>>(
                d: D,
            ) -> Result<Option<Vec<[f64; 3]>>, D::Error> {
                Option::<Vec<[T; 3]>>::deserialize(d)
                    .map(|v| v.map(|v| v.into_iter().map(|[a, b, c]| [a.0, b.0, c.0]).collect()))
            }
            pub fn opt_four_list<'de, D: Deserializer<'de>>(
                d: D,
            ) -> Result<Option<Vec<[f64; 4]>>, D::Error> {
                Option::<Vec<[T; 4]>>::deserialize(d).map(|v| {
                    v.map(|v| {
                        v.into_iter()
                            .map(|[a, b, c, e]| [a.0, b.0, c.0, e.0])
                            .collect()
                    })
                })
            }
        }
    };
}

unit_module!(length, Metres, Dimension::Length, 1.0, "A length in m.");
unit_module!(time, Seconds, Dimension::Time, 1.0, "A time in s.");
unit_module!(mass, Kilograms, Dimension::Mass, 1.0, "A mass in kg.");
unit_module!(
    speed,
    MetresPerSecond,
    Dimension::Speed,
    1.0,
    "A speed in m/s."
);
unit_module!(
    acceleration,
    MetresPerSecondSquared,
    Dimension::Acceleration,
    1.0,
    "An acceleration in m/s2."
);
unit_module!(
    stress,
    Pascals,
    Dimension::Stress,
    1.0,
    "A stress or modulus in Pa."
);
unit_module!(
    density,
    KilogramsPerCubicMetre,
    Dimension::Density,
    1.0,
    "A density in kg/m3."
);
unit_module!(
    angle,
    Degrees,
    Dimension::Angle,
    1.0,
    "An angle in degrees."
);
unit_module!(
    angular_speed,
    RadiansPerSecond,
    Dimension::AngularSpeed,
    1.0,
    "An angular speed in rad/s."
);
unit_module!(
    angular_speed_deg,
    DegreesPerSecond,
    Dimension::AngularSpeed,
    PI / 180.0,
    "An angular speed in deg/s."
);
unit_module!(force, Newtons, Dimension::Force, 1.0, "A force in N.");
unit_module!(
    surface_energy,
    JoulesPerSquareMetre,
    Dimension::SurfaceEnergy,
    1.0,
    "A surface energy in J/m2."
);
unit_module!(
    bond_stiffness,
    NewtonsPerCubicMetre,
    Dimension::BondStiffness,
    1.0,
    "A stiffness per unit area in N/m3."
);
unit_module!(
    mass_rate,
    KilogramsPerSecond,
    Dimension::MassRate,
    1.0,
    "A mass rate in kg/s."
);
unit_module!(
    stiffness,
    NewtonsPerMetre,
    Dimension::Stiffness,
    1.0,
    "A stiffness in N/m."
);

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Deserialize, Debug)]
    #[serde(deny_unknown_fields)]
    struct Sample {
        #[serde(deserialize_with = "length::one")]
        radius: f64,
        #[serde(deserialize_with = "stress::opt", default)]
        modulus: Option<f64>,
        #[serde(deserialize_with = "speed::three", default)]
        velocity: [f64; 3],
        #[serde(deserialize_with = "angular_speed_deg::one", default)]
        tilt_rate: f64,
        #[serde(default)]
        scale: Option<Quantity>,
    }

    fn read(text: &str) -> Result<Sample, String> {
        let de = toml::Deserializer::new(text);
        serde_path_to_error::deserialize(de).map_err(|e| {
            let path = e.path().to_string();
            format!("{path}: {}", e.into_inner().message())
        })
    }

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() <= 1e-12 * b.abs().max(1e-300)
    }

    #[test]
    fn strings_with_units_are_converted_and_numbers_taken_as_si() {
        let s = read(
            "radius = \"3 mm\"\nmodulus = \"29 MPa\"\nvelocity = [0, \"10 mm/min\", \"0.6 m/s\"]\ntilt_rate = \"1 rad/s\"",
        )
        .unwrap();
        assert!(close(s.radius, 0.003));
        assert!(close(s.modulus.unwrap(), 2.9e7));
        assert_eq!(s.velocity[0], 0.0);
        assert!(close(s.velocity[1], 10e-3 / 60.0));
        assert!(close(s.velocity[2], 0.6));
        assert!(close(s.tilt_rate, 180.0 / PI));
        let s = read("radius = 0.003\ntilt_rate = 2").unwrap();
        assert_eq!((s.radius, s.modulus, s.tilt_rate), (0.003, None, 2.0));
        for (text, value, dim) in [
            ("3mm", 3e-3, Dimension::Length),
            ("1.5e-3 m", 1.5e-3, Dimension::Length),
            ("1.2 g/cm3", 1200.0, Dimension::Density),
            ("1.2 g/cm^3", 1200.0, Dimension::Density),
            ("40 deg", 40.0, Dimension::Angle),
            ("40°", 40.0, Dimension::Angle),
            ("30 rpm", PI, Dimension::AngularSpeed),
            ("9.81 m/s2", 9.81, Dimension::Acceleration),
            ("-9.81 m/s^2", -9.81, Dimension::Acceleration),
            ("2 min", 120.0, Dimension::Time),
            ("5e9 N/m3", 5e9, Dimension::BondStiffness),
            ("3 N/mm3", 3e9, Dimension::BondStiffness),
            ("20 N/mm", 2e4, Dimension::Stiffness),
            ("3 kN", 3e3, Dimension::Force),
        ] {
            let (v, d) = parse(text).unwrap();
            assert!(close(v, value), "{text}: {v}");
            assert_eq!(d, dim, "{text}");
        }
    }

    #[test]
    fn a_wrong_dimension_or_unit_is_one_line_naming_the_key() {
        let e = read("radius = \"3 kg\"").unwrap_err();
        assert_eq!(
            e,
            "radius: \"3 kg\" is a mass (kg), expected a length (m), e.g. \"3 mm\""
        );
        let e = read("radius = 0.1\nmodulus = \"29 mm\"").unwrap_err();
        assert!(
            e.starts_with("modulus: \"29 mm\" is a length (m), expected a stress"),
            "{e}"
        );
        let e = read("radius = \"3 furlongs\"").unwrap_err();
        assert_eq!(e, "radius: \"3 furlongs\": unknown unit \"furlongs\"");
        let e = read("radius = \"3 MM\"").unwrap_err();
        assert!(e.contains("did you mean mm?"), "{e}");
        let e = read("radius = \"0.003\"").unwrap_err();
        assert!(e.contains("needs a unit"), "{e}");
        let e = read("radius = \"mm\"").unwrap_err();
        assert!(e.contains("expected a number and a unit"), "{e}");
        let e = read("radius = true").unwrap_err();
        assert!(e.contains("a length (m): a number, or a string"), "{e}");
        let e = read("radius = 1\nvelocity = [1, \"2 mm\", 3]").unwrap_err();
        assert!(e.starts_with("velocity[1]: \"2 mm\" is a length"), "{e}");
    }

    #[test]
    fn each_base_symbol_reads_back_as_one_base_unit() {
        for d in [
            Dimension::Length,
            Dimension::Time,
            Dimension::Mass,
            Dimension::Speed,
            Dimension::Acceleration,
            Dimension::Stress,
            Dimension::Density,
            Dimension::Angle,
            Dimension::AngularSpeed,
            Dimension::Force,
            Dimension::SurfaceEnergy,
            Dimension::BondStiffness,
            Dimension::MassRate,
            Dimension::Stiffness,
        ] {
            let v = 2.9e7_f64 / 3.0;
            assert_eq!(parse(&format!("{v:e} {}", d.symbol())).unwrap(), (v, d));
            assert!(parse(d.example().trim_matches('"')).unwrap().1 == d);
        }
    }

    #[test]
    fn a_quantity_keeps_its_dimension_for_the_reader() {
        let s = read("radius = 1\nscale = \"4 mm\"").unwrap();
        let q = s.scale.unwrap();
        assert!(close(q.as_dimension(Dimension::Length).unwrap(), 0.004));
        assert!(q.as_dimension(Dimension::Mass).is_err());
        assert_eq!(
            q.as_number("a scale factor").unwrap_err(),
            "a scale factor is a plain number, but 0.004 m (a length (m)) was given"
        );
        assert_eq!(
            q.as_dimension(Dimension::Mass).unwrap_err(),
            "0.004 m is a length (m), expected a mass (kg)"
        );
        let s = read("radius = 1\nscale = 1.5").unwrap();
        assert_eq!(s.scale.unwrap().as_number("scale").unwrap(), 1.5);
        assert_eq!(
            s.scale.unwrap().as_dimension(Dimension::Length).unwrap(),
            1.5
        );
    }
}
