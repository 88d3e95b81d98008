//! Bond output: the breakage log and the bond counts over time as CSV, and the bonds as lines
//! (intact and broken) for the snapshots (`bonds_*.vtp`, see [`crate::output`]) so that ParaView
//! shows the crack next to the particles.

use super::Bonds;
use crate::output::particles::{point_of, stable_order};
use crate::output::vtp::{Cells, DataArray, PolyData};
use crate::output::write_atomically;
use crate::particles::Particles;
use std::io::{self, Write};
use std::path::Path;

/// The breakage log: one row per broken bond, in the order they broke.
pub fn write_breakage_csv(path: &Path, bonds: &Bonds) -> io::Result<()> {
    write_atomically(path, |w| {
        writeln!(
            w,
            "time_s,x_m,y_m,z_m,mode,id_a,id_b,normal_stress_pa,shear_stress_pa"
        )?;
        for b in bonds.breakages() {
            writeln!(
                w,
                "{:.9e},{:e},{:e},{:e},{},{},{},{:e},{:e}",
                b.time,
                b.position.x,
                b.position.y,
                b.position.z,
                b.mode.name(),
                b.ids[0],
                b.ids[1],
                b.normal_stress,
                b.shear_stress
            )?;
        }
        Ok(())
    })
}

/// Intact and broken bond counts over time: at formation and after every step with a breakage.
pub fn write_bond_counts_csv(path: &Path, bonds: &Bonds) -> io::Result<()> {
    write_atomically(path, |w| {
        writeln!(w, "time_s,intact,broken")?;
        for (t, intact, broken) in bonds.history() {
            writeln!(w, "{t:.9e},{intact},{broken}")?;
        }
        Ok(())
    })
}

/// The bonds as lines between the current sphere centres (points in stable-id order, as in the
/// particles file, with `id`), with cell data `intact` (1 or 0), `normal_force` (N, positive
/// pushing apart) and `shear_force` (N, magnitude); a broken bond is drawn between where its
/// spheres are now, with zero forces.
pub fn bonds_polydata(bonds: &Bonds, particles: &Particles) -> PolyData {
    let order = stable_order(particles);
    let point = point_of(&order);
    // Point index by stable id.
    let mut by_id = vec![
        u32::MAX;
        particles
            .id
            .iter()
            .map(|&i| i as usize + 1)
            .max()
            .unwrap_or(0)
    ];
    for k in 0..particles.len() {
        by_id[particles.id[k] as usize] = point[k] as u32;
    }
    let at = |id: u32| by_id.get(id as usize).copied().filter(|&p| p != u32::MAX);
    let mut lines = Cells::default();
    let (mut intact, mut normal, mut shear) = (Vec::new(), Vec::new(), Vec::new());
    for b in 0..bonds.len() {
        let (ids, whole) = bonds.bond(b);
        let (Some(a), Some(c)) = (at(ids[0]), at(ids[1])) else {
            continue;
        };
        lines.push([a as usize, c as usize]);
        let (fn_, fs) = if whole {
            bonds.bond_forces(b)
        } else {
            (0.0, 0.0)
        };
        intact.push(whole as i32);
        normal.push(fn_);
        shear.push(fs);
    }
    PolyData {
        points: order.iter().map(|&k| particles.position[k]).collect(),
        lines,
        point_data: vec![DataArray::scalars_i32(
            "id",
            order.iter().map(|&k| particles.id[k] as i32).collect(),
        )],
        cell_data: vec![
            DataArray::scalars_i32("intact", intact),
            DataArray::scalars_f64("normal_force", normal),
            DataArray::scalars_f64("shear_force", shear),
        ],
        ..Default::default()
    }
}
