//! `size = { ... }` and `scale = { ... }` of a particle type: radius or scale-factor
//! distributions, read and checked (split from `particles.rs`, which reads the rest of a group).

use crate::fill::SizeDistribution;
use crate::scene::{Ctx, SceneError};
use crate::units::{Dimension, Quantity};
use serde::Deserialize;

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
pub(super) struct SizeEntry {
    #[serde(rename = "type")]
    kind: String,
    /// `value` reads better for a clump's fixed scale factor.
    #[serde(alias = "value")]
    radius: Option<Quantity>,
    min: Option<Quantity>,
    max: Option<Quantity>,
    mean: Option<Quantity>,
    std: Option<Quantity>,
    radii: Option<Vec<Quantity>>,
    fractions: Option<Vec<f64>>,
    basis: Option<String>,
}

/// A size distribution: radii (`length`) for spheres, or scale factors (`None`) for clumps,
/// whose values are plain numbers.
pub(super) fn size_distribution(
    ctx: &Ctx,
    prefix: &str,
    s: &SizeEntry,
    length: Option<Dimension>,
) -> Result<SizeDistribution, SceneError> {
    let key = |n: &str| format!("{prefix}.{n}");
    let value = |q: &Quantity, name: &str| {
        match length {
            Some(d) => q.as_dimension(d),
            None => q.as_number("a scale factor"),
        }
        .map_err(|e| ctx.err(key(name), e))
    };
    let one = |q: Option<Quantity>, name: &str| q.map(|q| value(&q, name)).transpose();
    let (radius, min, max, mean, std) = (
        one(s.radius, "radius")?,
        one(s.min, "min")?,
        one(s.max, "max")?,
        one(s.mean, "mean")?,
        one(s.std, "std")?,
    );
    let radii = match &s.radii {
        Some(list) => Some(
            list.iter()
                .enumerate()
                .map(|(i, q)| value(q, &format!("radii[{i}]")))
                .collect::<Result<Vec<f64>, _>>()?,
        ),
        None => None,
    };
    let given = [
        ("radius", radius.is_some()),
        ("min", min.is_some()),
        ("max", max.is_some()),
        ("mean", mean.is_some()),
        ("std", std.is_some()),
        ("radii", radii.is_some()),
        ("fractions", s.fractions.is_some()),
        ("basis", s.basis.is_some()),
    ];
    Ok(match s.kind.as_str() {
        "fixed" => {
            ctx.only(prefix, "fixed", &given, &["radius"])?;
            SizeDistribution::Fixed {
                radius: ctx.require(radius, key("radius"), "the particle radius (m)")?,
            }
        }
        "uniform" => {
            ctx.only(prefix, "uniform", &given, &["min", "max"])?;
            SizeDistribution::Uniform {
                min: ctx.require(min, key("min"), "the smallest radius (m)")?,
                max: ctx.require(max, key("max"), "the largest radius (m)")?,
            }
        }
        "normal" => {
            ctx.only(prefix, "normal", &given, &["mean", "std", "min", "max"])?;
            let mean = ctx.require(mean, key("mean"), "the mean radius (m)")?;
            let std = ctx.require(
                std,
                key("std"),
                "the standard deviation of the radius (m)",
            )?;
            SizeDistribution::TruncatedNormal {
                mean,
                std,
                min: min.unwrap_or(mean - 3.0 * std),
                max: max.unwrap_or(mean + 3.0 * std),
            }
        }
        "classes" => {
            ctx.only(prefix, "classes", &given, &["radii", "fractions", "basis"])?;
            let radii = radii.ok_or_else(|| ctx.err(key("radii"), "missing; expected a list of radii (m)"))?;
            let fractions = s.fractions.clone().ok_or_else(|| {
                ctx.err(key("fractions"), "missing; expected a list of fractions")
            })?;
            SizeDistribution::Classes {
                radii,
                fractions,
                by_mass: basis(ctx, key("basis"), s.basis.as_deref())?,
            }
        }
        other => {
            return Err(ctx.err(
                key("type"),
                format!(
                    "unknown size distribution \"{other}\" (expected fixed, uniform, normal or classes)"
                ),
            ))
        }
    })
}

pub(super) fn basis(ctx: &Ctx, key: String, basis: Option<&str>) -> Result<bool, SceneError> {
    match basis.unwrap_or("number") {
        "number" => Ok(false),
        "mass" => Ok(true),
        other => Err(ctx.err(
            key,
            format!("unknown basis \"{other}\" (expected number or mass)"),
        )),
    }
}
