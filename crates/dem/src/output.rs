//! Output files: particle snapshots as legacy VTK (ParaView opens them directly) and the geometry
//! load time series as CSV.

use crate::geometry::Geometry;
use crate::particles::Particles;
use std::fs::File;
use std::io::{self, BufWriter, Write};
use std::path::Path;

/// Writes one snapshot: points, with radius, velocity, angular velocity, material id and stable id,
/// in stable-id order so files from different steps line up.
pub fn write_vtk(path: &Path, particles: &Particles, time: f64) -> io::Result<()> {
    let n = particles.len();
    let mut by_id: Vec<usize> = (0..n).collect();
    by_id.sort_unstable_by_key(|&k| particles.id[k]);
    let tmp = path.with_extension("vtk.part");
    {
        let mut w = BufWriter::new(File::create(&tmp)?);
        writeln!(w, "# vtk DataFile Version 3.0")?;
        writeln!(w, "demcal particles t={time:.9e}")?;
        writeln!(w, "ASCII")?;
        writeln!(w, "DATASET POLYDATA")?;
        writeln!(w, "POINTS {n} double")?;
        for &k in &by_id {
            let x = particles.position[k];
            writeln!(w, "{:e} {:e} {:e}", x.x, x.y, x.z)?;
        }
        writeln!(w, "VERTICES {n} {}", 2 * n)?;
        for k in 0..n {
            writeln!(w, "1 {k}")?;
        }
        writeln!(w, "POINT_DATA {n}")?;
        writeln!(w, "SCALARS radius double 1")?;
        writeln!(w, "LOOKUP_TABLE default")?;
        for &k in &by_id {
            writeln!(w, "{:e}", particles.radius[k])?;
        }
        writeln!(w, "SCALARS material_id int 1")?;
        writeln!(w, "LOOKUP_TABLE default")?;
        for &k in &by_id {
            writeln!(w, "{}", particles.material[k])?;
        }
        writeln!(w, "SCALARS id int 1")?;
        writeln!(w, "LOOKUP_TABLE default")?;
        for &k in &by_id {
            writeln!(w, "{}", particles.id[k])?;
        }
        writeln!(w, "VECTORS velocity double")?;
        for &k in &by_id {
            let v = particles.velocity[k];
            writeln!(w, "{:e} {:e} {:e}", v.x, v.y, v.z)?;
        }
        writeln!(w, "VECTORS angular_velocity double")?;
        for &k in &by_id {
            let v = particles.angular_velocity[k];
            writeln!(w, "{:e} {:e} {:e}", v.x, v.y, v.z)?;
        }
        w.flush()?;
    }
    // Rename so a reader never sees half a file.
    std::fs::rename(tmp, path)
}

/// Geometry force and torque time series: one row per record, six columns per geometry.
pub struct LoadWriter {
    w: BufWriter<File>,
}

impl LoadWriter {
    pub fn create(path: &Path, geometries: &[Geometry]) -> io::Result<Self> {
        let mut w = BufWriter::new(File::create(path)?);
        write!(w, "time_s")?;
        for g in geometries {
            for c in ["fx_n", "fy_n", "fz_n", "tx_nm", "ty_nm", "tz_nm"] {
                write!(w, ",{}_{}", g.name, c)?;
            }
        }
        writeln!(w)?;
        Ok(LoadWriter { w })
    }

    pub fn record(&mut self, time: f64, geometries: &[Geometry]) -> io::Result<()> {
        write!(self.w, "{time:.9e}")?;
        for g in geometries {
            let (f, t) = (g.load.force, g.load.torque);
            write!(
                self.w,
                ",{:e},{:e},{:e},{:e},{:e},{:e}",
                f.x, f.y, f.z, t.x, t.y, t.z
            )?;
        }
        writeln!(self.w)
    }

    pub fn finish(mut self) -> io::Result<()> {
        self.w.flush()
    }
}
