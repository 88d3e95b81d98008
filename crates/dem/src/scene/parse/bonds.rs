//! `[[bond]]` entries: EDEM's bond parameters per material pair, each with one of two ways to give
//! the bond radius and the contact radius.

use super::super::description::BondDescription;
use super::super::{Ctx, SceneError};
use crate::bond::{BondParams, BondRadius, ContactRadius};
use serde::Deserialize;

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
pub(super) struct BondEntry {
    #[serde(deserialize_with = "super::material_pair")]
    materials: [String; 2],
    #[serde(deserialize_with = "crate::units::bond_stiffness::one")]
    normal_stiffness: f64,
    #[serde(deserialize_with = "crate::units::bond_stiffness::one")]
    shear_stiffness: f64,
    #[serde(deserialize_with = "crate::units::stress::one")]
    critical_normal_stress: f64,
    #[serde(deserialize_with = "crate::units::stress::one")]
    critical_shear_stress: f64,
    #[serde(deserialize_with = "crate::units::length::opt", default)]
    bond_radius: Option<f64>,
    bonded_disk_scale: Option<f64>,
    #[serde(deserialize_with = "crate::units::length::opt", default)]
    contact_radius: Option<f64>,
    contact_radius_scale: Option<f64>,
    #[serde(deserialize_with = "crate::units::time::one", default)]
    formation_time: f64,
    #[serde(default)]
    damping: f64,
    #[serde(default)]
    stiffness_range: f64,
}

pub(super) fn bonds(
    ctx: &Ctx,
    entries: Vec<BondEntry>,
) -> Result<Vec<BondDescription>, SceneError> {
    entries
        .into_iter()
        .enumerate()
        .map(|(k, b)| {
            let key = |s: &str| format!("bond[{k}].{s}");
            let radius = match (b.bond_radius, b.bonded_disk_scale) {
                (Some(r), None) => BondRadius::Absolute(r),
                (None, Some(s)) => BondRadius::DiskScale(s),
                (Some(_), Some(_)) => {
                    return Err(ctx.err(
                        key("bonded_disk_scale"),
                        "give bond_radius or bonded_disk_scale, not both",
                    ))
                }
                (None, None) => {
                    return Err(ctx.err(
                        key("bond_radius"),
                        "missing; expected bond_radius (m) or bonded_disk_scale (times the smaller sphere's radius)",
                    ))
                }
            };
            let contact_radius = match (b.contact_radius, b.contact_radius_scale) {
                (Some(r), None) => ContactRadius::Absolute(r),
                (None, Some(s)) => ContactRadius::Scale(s),
                (Some(_), Some(_)) => {
                    return Err(ctx.err(
                        key("contact_radius_scale"),
                        "give contact_radius or contact_radius_scale, not both",
                    ))
                }
                (None, None) => {
                    return Err(ctx.err(
                        key("contact_radius"),
                        "missing; expected contact_radius (m) or contact_radius_scale (times each sphere's radius): pairs whose contact spheres overlap bond",
                    ))
                }
            };
            Ok(BondDescription {
                materials: b.materials,
                params: BondParams {
                    normal_stiffness: b.normal_stiffness,
                    shear_stiffness: b.shear_stiffness,
                    critical_normal_stress: b.critical_normal_stress,
                    critical_shear_stress: b.critical_shear_stress,
                    radius,
                    contact_radius,
                    formation_time: b.formation_time,
                    damping: b.damping,
                    stiffness_range: b.stiffness_range,
                },
            })
        })
        .collect()
}
