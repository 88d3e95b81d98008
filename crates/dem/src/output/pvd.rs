//! The `.pvd` collection file: which file holds which dataset at which simulated time. ParaView
//! opens it as one time-varying source; its time steps are the `timestep` values, in seconds.

use super::{write_atomically, xml_escape};
use std::io::{self, Write};
use std::path::{Path, PathBuf};

/// One `<DataSet>` line: `file` (relative to the `.pvd`) holds part `part` at `time`.
#[derive(Clone, Debug, PartialEq)]
pub struct Entry {
    pub time: f64,
    pub part: usize,
    pub file: String,
}

/// A collection rewritten whole after every snapshot.
#[derive(Clone, Debug)]
pub struct Collection {
    path: PathBuf,
    entries: Vec<Entry>,
}

impl Collection {
    pub fn new(path: &Path) -> Self {
        Collection {
            path: path.to_path_buf(),
            entries: Vec::new(),
        }
    }

    pub fn path(&self) -> &Path {
        &self.path
    }

    pub fn entries(&self) -> &[Entry] {
        &self.entries
    }

    /// Keeps only the entries `keep` accepts.
    pub fn retain(&mut self, keep: impl FnMut(&Entry) -> bool) {
        self.entries.retain(keep);
    }

    pub fn add(&mut self, time: f64, part: usize, file: &str) {
        self.entries.push(Entry {
            time,
            part,
            file: file.to_string(),
        });
    }

    /// Writes the file through a temporary one renamed over it, so a run stopped at any moment
    /// leaves a collection that lists only files that are complete.
    pub fn write(&self) -> io::Result<()> {
        write_atomically(&self.path, |w| {
            writeln!(w, "<?xml version=\"1.0\"?>")?;
            writeln!(
                w,
                "<VTKFile type=\"Collection\" version=\"0.1\" byte_order=\"LittleEndian\">"
            )?;
            writeln!(w, "  <Collection>")?;
            for e in &self.entries {
                // `{}` prints the shortest text that reads back as the same f64.
                writeln!(
                    w,
                    "    <DataSet timestep=\"{}\" group=\"\" part=\"{}\" file=\"{}\"/>",
                    e.time,
                    e.part,
                    xml_escape(&e.file)
                )?;
            }
            writeln!(w, "  </Collection>")?;
            writeln!(w, "</VTKFile>")
        })
    }
}
