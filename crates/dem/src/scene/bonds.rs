//! `[[bond]]` descriptions into the simulation's [`Bonds`]: every value checked, bonds due at the
//! start formed on the placed spheres, and the time step checked against their stiffness.

use super::description::SceneDescription;
use super::{Ctx, SceneError};
use crate::bond::{BondParams, BondRadius, Bonds, ContactRadius};
use crate::material::MaterialTable;
use crate::sim::Simulation;

/// The largest contact radius scale: twice the radius reaches past the second neighbours of a
/// close packing, so more is a typo.
const MAX_CONTACT_SCALE: f64 = 2.0;

/// Checks the `[[bond]]` entries against the materials; `None` when there are none.
pub(super) fn bonds(
    d: &SceneDescription,
    ctx: &Ctx,
    table: &MaterialTable,
) -> Result<Option<Bonds>, SceneError> {
    if d.bonds.is_empty() {
        return Ok(None);
    }
    let mut pairs: Vec<([usize; 2], BondParams)> = Vec::new();
    for (k, bond) in d.bonds.iter().enumerate() {
        let b = &bond.params;
        let key = |s: &str| format!("bond[{k}].{s}");
        let mut ids = [0; 2];
        for (n, name) in bond.materials.iter().enumerate() {
            ids[n] = table.id_of(name).ok_or_else(|| {
                ctx.err(
                    key("materials"),
                    format!("unknown material \"{name}\" (not among the [[material]] names)"),
                )
            })?;
        }
        if pairs
            .iter()
            .any(|(p, _)| (p[0], p[1]) == (ids[0], ids[1]) || (p[0], p[1]) == (ids[1], ids[0]))
        {
            return Err(ctx.err(
                key("materials"),
                format!(
                    "bonds between \"{}\" and \"{}\" are given twice",
                    bond.materials[0], bond.materials[1]
                ),
            ));
        }
        for (name, v) in [
            ("normal_stiffness", b.normal_stiffness),
            ("shear_stiffness", b.shear_stiffness),
            ("critical_normal_stress", b.critical_normal_stress),
            ("critical_shear_stress", b.critical_shear_stress),
        ] {
            ctx.positive(v, key(name))?;
        }
        match b.radius {
            BondRadius::Absolute(r) => {
                ctx.positive(r, key("bond_radius"))?;
            }
            BondRadius::DiskScale(s) => {
                if !(s > 0.0 && s <= 1.0) {
                    return Err(ctx.err(
                        key("bonded_disk_scale"),
                        format!("expected a number in (0, 1] (times the smaller sphere's radius), got {s}"),
                    ));
                }
            }
        }
        match b.contact_radius {
            ContactRadius::Absolute(r) => {
                ctx.positive(r, key("contact_radius"))?;
            }
            ContactRadius::Scale(s) => {
                if !(1.0..=MAX_CONTACT_SCALE).contains(&s) {
                    return Err(ctx.err(
                        key("contact_radius_scale"),
                        format!("expected a number from 1 to {MAX_CONTACT_SCALE} (times each sphere's radius), got {s}"),
                    ));
                }
            }
        }
        ctx.non_negative(b.formation_time, key("formation_time"))?;
        if !(b.damping >= 0.0 && b.damping < 1.0) {
            return Err(ctx.err(
                key("damping"),
                format!(
                    "expected a fraction from 0 (off) to below 1, got {}",
                    b.damping
                ),
            ));
        }
        if !(b.stiffness_range >= 0.0 && b.stiffness_range < 1.0) {
            return Err(ctx.err(
                key("stiffness_range"),
                format!(
                    "expected a fraction from 0 (every bond the same) to below 1 (each bond's stiffness drawn within plus or minus it), got {}",
                    b.stiffness_range
                ),
            ));
        }
        pairs.push((ids, *b));
    }
    Ok(Some(Bonds::new(table.len(), &pairs)))
}

/// Forms the bonds due at the start on the placed spheres and adds them to the simulation;
/// time-step warnings and a note with the counts go to `warnings` and `notes`.
pub(super) fn attach(
    mut bonds: Bonds,
    sim: &mut Simulation,
    ctx: &Ctx,
    warnings: &mut Vec<String>,
    notes: &mut Vec<String>,
) -> Result<(), SceneError> {
    let dt = sim.params.time_step;
    let w = bonds
        .form_due(&sim.particles, sim.time, dt)
        .map_err(|m| ctx.err("bond", m))?;
    warnings.extend(w);
    if bonds.all_formed() {
        if bonds.is_empty() {
            warnings.push(
                "bond: no pair of spheres is close enough to bond (closer than the sum of their contact radii)"
                    .to_string(),
            );
        } else {
            notes.push(format!(
                "bonds: {} formed between {} spheres",
                bonds.len(),
                sim.particles.len()
            ));
        }
    }
    sim.add_extension(Box::new(bonds));
    Ok(())
}
