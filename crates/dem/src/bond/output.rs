//! Bond output: the breakage log and the bond counts over time as CSV, and the bonds as VTK lines
//! (intact and broken) so that ParaView shows the crack next to the particle snapshots.

use super::Bonds;
use crate::particles::Particles;
use std::fs::File;
use std::io::{self, BufWriter, Write};
use std::path::Path;

/// Writes `path` through a temporary file renamed at the end, so a reader never sees half a file.
fn write_atomically(
    path: &Path,
    body: impl FnOnce(&mut BufWriter<File>) -> io::Result<()>,
) -> io::Result<()> {
    let tmp = path.with_extension("part");
    {
        let mut w = BufWriter::new(File::create(&tmp)?);
        body(&mut w)?;
        w.flush()?;
    }
    std::fs::rename(tmp, path)
}

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

/// The bonds as VTK lines between the current sphere centres, with cell data `intact` (1 or 0)
/// and the points' stable ids; a broken bond is drawn between where its spheres are now.
pub fn write_bonds_vtk(
    path: &Path,
    bonds: &Bonds,
    particles: &Particles,
    time: f64,
) -> io::Result<()> {
    let n = particles.len();
    let mut index = vec![
        u32::MAX;
        particles
            .id
            .iter()
            .map(|&i| i as usize + 1)
            .max()
            .unwrap_or(0)
    ];
    for k in 0..n {
        index[particles.id[k] as usize] = k as u32;
    }
    let lines: Vec<([u32; 2], bool)> = (0..bonds.len())
        .map(|b| bonds.bond(b))
        .filter(|(ids, _)| {
            ids.iter()
                .all(|&i| (i as usize) < index.len() && index[i as usize] != u32::MAX)
        })
        .map(|(ids, intact)| ([index[ids[0] as usize], index[ids[1] as usize]], intact))
        .collect();
    let tmp = path.with_extension("vtk.part");
    {
        let mut w = BufWriter::new(File::create(&tmp)?);
        writeln!(w, "# vtk DataFile Version 3.0")?;
        writeln!(w, "demcal bonds t={time:.9e}")?;
        writeln!(w, "ASCII")?;
        writeln!(w, "DATASET POLYDATA")?;
        writeln!(w, "POINTS {n} double")?;
        for x in &particles.position {
            writeln!(w, "{:e} {:e} {:e}", x.x, x.y, x.z)?;
        }
        writeln!(w, "LINES {} {}", lines.len(), 3 * lines.len())?;
        for (ends, _) in &lines {
            writeln!(w, "2 {} {}", ends[0], ends[1])?;
        }
        writeln!(w, "CELL_DATA {}", lines.len())?;
        writeln!(w, "SCALARS intact int 1")?;
        writeln!(w, "LOOKUP_TABLE default")?;
        for (_, intact) in &lines {
            writeln!(w, "{}", *intact as u8)?;
        }
        writeln!(w, "POINT_DATA {n}")?;
        writeln!(w, "SCALARS id int 1")?;
        writeln!(w, "LOOKUP_TABLE default")?;
        for id in &particles.id {
            writeln!(w, "{id}")?;
        }
        w.flush()?;
    }
    std::fs::rename(tmp, path)
}
