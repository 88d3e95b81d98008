//! The geometry load time series as CSV: each geometry's force and torque over time.

use crate::geometry::Geometry;
use std::fs::File;
use std::io::{self, BufWriter, Write};
use std::path::Path;

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
