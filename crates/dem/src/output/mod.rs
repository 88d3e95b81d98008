//! Output files: snapshots for ParaView and the geometry load time series (CSV).
//!
//! Each snapshot ([`Snapshots::write`]) writes VTK XML PolyData files named by the step number,
//! and rewrites one `.pvd` collection per kind that lists every file with its simulated time:
//!
//! | collection | files | what |
//! | --- | --- | --- |
//! | `particles.pvd` | `particles_NNNNNNNN.vtp` | sphere centres with radius, velocities, ids, clump id and orientation ([`particles`]) |
//! | `geometry.pvd` | `geometry_static_NNNNNNNN.vtp`, `geometry_NNNNNNNN.vtp` | walls and meshes as surfaces ([`geometry`]) |
//! | `contacts.pvd` | `contacts_NNNNNNNN.vtp` | the contact force network, when asked for ([`contacts`]) |
//! | `bonds.pvd` | `bonds_NNNNNNNN.vtp` | bonds as lines, in a scene with bonds ([`crate::bond::output`]) |
//! | `polyhedra.pvd` | `polyhedra_NNNNNNNN.vtp` | polyhedral particles as surfaces, in a scene with polyhedra ([`polyhedra`]) |
//!
//! One collection per kind rather than one with a part per kind: ParaView opens each as its own
//! source, so the particles can take a Glyph filter without first being extracted from a
//! multiblock.
//!
//! Geometry that never moves is written once and listed at every time step: the geometries
//! without motion go into `geometry_static_*.vtp` (part 0 of `geometry.pvd`), the others into a
//! `geometry_*.vtp` per snapshot (part 1), and ParaView shows the two parts as blocks of one
//! source. A geometry that starts moving later (a servo-driven plate) joins the moving part from
//! then on, and a new static file without it is written; earlier time steps keep theirs.
//!
//! Files are binary by default (raw little-endian arrays appended after the XML; ASCII files
//! are about twice the size) and every file, `.pvd` included, is written to a temporary
//! name and renamed, so a run stopped at any moment leaves a series ParaView loads.
//! The format is written by hand ([`vtp`]): it is a page of XML around raw arrays. The Rust VTK
//! crate (`vtkio`, MIT or Apache-2.0) would bring nom, quick-xml and serde models of every VTK
//! dataset to write this one, and has had no stable release since 2021; the tests here parse the
//! files back and `tools/paraview/check_pvd.py` has VTK itself read them.

pub mod contacts;
pub mod geometry;
mod loads;
pub mod particles;
pub mod polyhedra;
pub mod pvd;
mod series;
pub mod vtp;

#[cfg(test)]
mod tests;

pub use loads::LoadWriter;
pub use series::{SnapshotOptions, Snapshots};
pub use vtp::Encoding;

use std::fs::File;
use std::io::{self, BufWriter, Write};
use std::path::Path;

/// Writes `path` through a temporary file (`path` with `.part` added) renamed at the end, so a
/// reader never sees half a file.
pub fn write_atomically(
    path: &Path,
    body: impl FnOnce(&mut BufWriter<File>) -> io::Result<()>,
) -> io::Result<()> {
    // The rename would replace whatever is there: never a folder or a device (/dev/null).
    if std::fs::metadata(path).is_ok_and(|m| !m.is_file()) {
        return Err(io::Error::other(format!(
            "{}: exists and is not a plain file; not replaced",
            path.display()
        )));
    }
    let mut tmp = path.as_os_str().to_owned();
    tmp.push(".part");
    {
        let mut w = BufWriter::new(File::create(&tmp)?);
        body(&mut w)?;
        w.flush()?;
    }
    std::fs::rename(tmp, path)
}

/// Escapes text for an XML attribute (geometry names are the user's).
pub(crate) fn xml_escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('"', "&quot;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}
