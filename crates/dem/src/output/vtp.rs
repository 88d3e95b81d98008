//! A writer of VTK XML PolyData (`.vtp`): points, vertex/line/polygon cells, point, cell and field
//! data, either as raw binary appended after the XML header (the default: exact, no number
//! formatting, and about half the size of text) or as ASCII text inside the XML.
//!
//! The format is the "VTK XML file formats" of the VTK user's guide: version 1.0 with a UInt64
//! byte-count header before each appended array, little-endian, no compression. Cells are given
//! as `connectivity` (the point indices of every cell, one cell after another) and `offsets` (the
//! end of each cell in `connectivity`). Cell data run over the vertices, then the lines, then the
//! polygons, the order VTK numbers cells in.

use super::xml_escape;
use glam::DVec3;
use std::io::{self, Write};

/// How the arrays are stored in the file.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Encoding {
    /// Raw little-endian bytes appended after the XML (`<AppendedData encoding="raw">`).
    #[default]
    Binary,
    /// Numbers as text inside each `<DataArray>`: readable, about twice the size (zeros and
    /// small integers are short; a full f64 takes up to 24 characters for its 8 bytes).
    Ascii,
}

/// The values of one array.
#[derive(Clone, Debug, PartialEq)]
pub enum Values {
    F64(Vec<f64>),
    I32(Vec<i32>),
    I64(Vec<i64>),
    /// One string per tuple (field data: names).
    Strings(Vec<String>),
}

impl Values {
    fn vtk_type(&self) -> &'static str {
        match self {
            Values::F64(_) => "Float64",
            Values::I32(_) => "Int32",
            Values::I64(_) => "Int64",
            Values::Strings(_) => "String",
        }
    }

    fn len(&self) -> usize {
        match self {
            Values::F64(v) => v.len(),
            Values::I32(v) => v.len(),
            Values::I64(v) => v.len(),
            Values::Strings(v) => v.len(),
        }
    }

    /// The appended block's bytes (without the byte-count header); strings each end with a NUL.
    fn bytes(&self) -> Vec<u8> {
        match self {
            Values::F64(v) => v.iter().flat_map(|x| x.to_le_bytes()).collect(),
            Values::I32(v) => v.iter().flat_map(|x| x.to_le_bytes()).collect(),
            Values::I64(v) => v.iter().flat_map(|x| x.to_le_bytes()).collect(),
            Values::Strings(v) => v
                .iter()
                .flat_map(|s| s.bytes().filter(|&b| b != 0).chain([0]))
                .collect(),
        }
    }

    /// The values as text, a few per line; strings as their byte codes each ending with 0, as VTK
    /// writes them.
    fn write_ascii(&self, w: &mut dyn Write) -> io::Result<()> {
        fn lines<T>(
            w: &mut dyn Write,
            v: &[T],
            f: impl Fn(&T) -> String,
            per_line: usize,
        ) -> io::Result<()> {
            for chunk in v.chunks(per_line) {
                let text: Vec<String> = chunk.iter().map(&f).collect();
                writeln!(w, "{}", text.join(" "))?;
            }
            Ok(())
        }
        match self {
            Values::F64(v) => lines(w, v, |x| format!("{x:e}"), 6),
            Values::I32(v) => lines(w, v, |x| x.to_string(), 12),
            Values::I64(v) => lines(w, v, |x| x.to_string(), 12),
            Values::Strings(_) => lines(w, &self.bytes(), |b| b.to_string(), 24),
        }
    }
}

/// A named array with `components` values per tuple (3 for a vector).
#[derive(Clone, Debug, PartialEq)]
pub struct DataArray {
    pub name: String,
    pub components: usize,
    pub values: Values,
}

impl DataArray {
    pub fn scalars_f64(name: &str, values: Vec<f64>) -> Self {
        DataArray {
            name: name.into(),
            components: 1,
            values: Values::F64(values),
        }
    }

    pub fn scalars_i32(name: &str, values: Vec<i32>) -> Self {
        DataArray {
            name: name.into(),
            components: 1,
            values: Values::I32(values),
        }
    }

    pub fn vectors(name: &str, values: impl IntoIterator<Item = DVec3>) -> Self {
        DataArray {
            name: name.into(),
            components: 3,
            values: Values::F64(values.into_iter().flat_map(|v| v.to_array()).collect()),
        }
    }

    pub fn strings(name: &str, values: Vec<String>) -> Self {
        DataArray {
            name: name.into(),
            components: 1,
            values: Values::Strings(values),
        }
    }

    fn tuples(&self) -> usize {
        self.values.len() / self.components.max(1)
    }
}

/// Cells of one kind (vertices, lines or polygons) as VTK stores them.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Cells {
    pub connectivity: Vec<i64>,
    /// End of each cell in `connectivity`.
    pub offsets: Vec<i64>,
}

impl Cells {
    /// Adds a cell through these points.
    pub fn push(&mut self, points: impl IntoIterator<Item = usize>) {
        self.connectivity
            .extend(points.into_iter().map(|p| p as i64));
        self.offsets.push(self.connectivity.len() as i64);
    }

    pub fn len(&self) -> usize {
        self.offsets.len()
    }

    pub fn is_empty(&self) -> bool {
        self.offsets.is_empty()
    }
}

/// One PolyData piece with its data.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PolyData {
    pub points: Vec<DVec3>,
    pub verts: Cells,
    pub lines: Cells,
    pub polys: Cells,
    pub point_data: Vec<DataArray>,
    /// Over the vertices, then the lines, then the polygons.
    pub cell_data: Vec<DataArray>,
    /// Whole-dataset values (`TimeValue`, names).
    pub field_data: Vec<DataArray>,
}

impl PolyData {
    /// One vertex cell per point, so that ParaView draws the points.
    pub fn with_a_vertex_per_point(mut self) -> Self {
        self.verts = Cells {
            connectivity: (0..self.points.len() as i64).collect(),
            offsets: (1..=self.points.len() as i64).collect(),
        };
        self
    }

    pub fn cell_count(&self) -> usize {
        self.verts.len() + self.lines.len() + self.polys.len()
    }

    /// Writes the file's bytes. `time` goes into the field data as `TimeValue`, the array
    /// ParaView reads a file's time from when it is opened without the `.pvd`.
    pub fn write(&self, w: &mut dyn Write, encoding: Encoding, time: f64) -> io::Result<()> {
        let n = self.points.len();
        for a in &self.point_data {
            check_length(a, n, "point")?;
        }
        for a in &self.cell_data {
            check_length(a, self.cell_count(), "cell")?;
        }
        // Connectivity as Int32 whenever it fits: 8 bytes less per point of a particle file.
        let small = n < i32::MAX as usize
            && [&self.verts, &self.lines, &self.polys]
                .iter()
                .all(|c| c.connectivity.len() < i32::MAX as usize);
        let index_array = |name: &str, v: &[i64]| DataArray {
            name: name.into(),
            components: 1,
            values: if small {
                Values::I32(v.iter().map(|&x| x as i32).collect())
            } else {
                Values::I64(v.to_vec())
            },
        };
        let mut field = vec![DataArray::scalars_f64("TimeValue", vec![time])];
        field.extend(self.field_data.iter().cloned());
        let points = DataArray::vectors("Points", self.points.iter().copied());
        let cells = [
            ("Verts", &self.verts),
            ("Lines", &self.lines),
            ("Polys", &self.polys),
        ];

        let mut doc = Document::new(encoding);
        doc.line(
            "<VTKFile type=\"PolyData\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\">",
        );
        doc.line("  <PolyData>");
        doc.line("    <FieldData>");
        for a in &field {
            doc.array(a, 6);
        }
        doc.line("    </FieldData>");
        doc.line(&format!(
            "    <Piece NumberOfPoints=\"{n}\" NumberOfVerts=\"{}\" NumberOfLines=\"{}\" NumberOfStrips=\"0\" NumberOfPolys=\"{}\">",
            self.verts.len(),
            self.lines.len(),
            self.polys.len()
        ));
        doc.data_section("PointData", &self.point_data);
        doc.data_section("CellData", &self.cell_data);
        doc.line("      <Points>");
        doc.array(&points, 8);
        doc.line("      </Points>");
        for (tag, c) in cells {
            if c.is_empty() {
                continue;
            }
            doc.line(&format!("      <{tag}>"));
            doc.array(&index_array("connectivity", &c.connectivity), 8);
            doc.array(&index_array("offsets", &c.offsets), 8);
            doc.line(&format!("      </{tag}>"));
        }
        doc.line("    </Piece>");
        doc.line("  </PolyData>");
        doc.finish(w)
    }
}

fn check_length(a: &DataArray, expected: usize, what: &str) -> io::Result<()> {
    if a.tuples() == expected && a.values.len() == expected * a.components {
        Ok(())
    } else {
        // A bug in the caller, not in the user's input; said plainly rather than as a corrupt file.
        Err(io::Error::new(
            io::ErrorKind::InvalidInput,
            format!(
                "{what} array \"{}\" has {} values, expected {} tuples of {}",
                a.name,
                a.values.len(),
                expected,
                a.components
            ),
        ))
    }
}

/// The XML text, with the appended bytes gathered beside it as the arrays are declared.
struct Document {
    encoding: Encoding,
    xml: Vec<u8>,
    appended: Vec<u8>,
}

impl Document {
    fn new(encoding: Encoding) -> Self {
        let mut xml = Vec::new();
        xml.extend_from_slice(b"<?xml version=\"1.0\"?>\n");
        Document {
            encoding,
            xml,
            appended: Vec::new(),
        }
    }

    fn line(&mut self, text: &str) {
        self.xml.extend_from_slice(text.as_bytes());
        self.xml.push(b'\n');
    }

    fn data_section(&mut self, tag: &str, arrays: &[DataArray]) {
        // The first scalar and vector arrays are made active: filters (Glyph) pick them by default.
        let active = |components: usize| {
            arrays
                .iter()
                .find(|a| a.components == components && !matches!(a.values, Values::Strings(_)))
                .map(|a| a.name.clone())
        };
        let mut attrs = String::new();
        if let Some(s) = active(1) {
            attrs += &format!(" Scalars=\"{}\"", xml_escape(&s));
        }
        if let Some(v) = active(3) {
            attrs += &format!(" Vectors=\"{}\"", xml_escape(&v));
        }
        self.line(&format!("      <{tag}{attrs}>"));
        for a in arrays {
            self.array(a, 8);
        }
        self.line(&format!("      </{tag}>"));
    }

    fn array(&mut self, a: &DataArray, indent: usize) {
        let pad = " ".repeat(indent);
        // VTK's own name for a string array's element.
        let element = match a.values {
            Values::Strings(_) => "Array",
            _ => "DataArray",
        };
        let head = format!(
            "{pad}<{element} type=\"{}\" Name=\"{}\" NumberOfComponents=\"{}\" NumberOfTuples=\"{}\"",
            a.values.vtk_type(),
            xml_escape(&a.name),
            a.components,
            a.tuples()
        );
        match self.encoding {
            Encoding::Binary => {
                let bytes = a.values.bytes();
                let offset = self.appended.len();
                self.appended
                    .extend_from_slice(&(bytes.len() as u64).to_le_bytes());
                self.appended.extend_from_slice(&bytes);
                self.line(&format!("{head} format=\"appended\" offset=\"{offset}\"/>"));
            }
            Encoding::Ascii => {
                self.line(&format!("{head} format=\"ascii\">"));
                // Writing into a Vec cannot fail.
                let _ = a.values.write_ascii(&mut self.xml);
                self.line(&format!("{pad}</{element}>"));
            }
        }
    }

    fn finish(mut self, w: &mut dyn Write) -> io::Result<()> {
        if self.encoding == Encoding::Binary {
            self.line("  <AppendedData encoding=\"raw\">");
            // The data start right after the underscore; offsets count from there.
            self.xml.extend_from_slice(b"   _");
            w.write_all(&self.xml)?;
            w.write_all(&self.appended)?;
            w.write_all(b"\n  </AppendedData>\n</VTKFile>\n")
        } else {
            self.line("</VTKFile>");
            w.write_all(&self.xml)
        }
    }
}
