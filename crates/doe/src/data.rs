//! Reading experiment results from CSV: named numeric columns, with errors that name the file, the
//! row and the column.

use std::path::Path;

/// Largest magnitude a cell may hold: squares of larger values summed over the runs overflow
/// (1e150 squared is 1e300, and doubles end near 1.8e308).
pub const MAX_MAGNITUDE: f64 = 1e150;

/// A table of columns read from a CSV file (header row required).
#[derive(Clone, Debug)]
pub struct DataTable {
    /// Where it came from, for messages.
    pub source: String,
    pub headers: Vec<String>,
    /// Raw cells, row-major.
    pub rows: Vec<Vec<String>>,
}

/// Most bytes a data table may have (as `dem::files::MAX_TABLE_BYTES`; this crate does not
/// depend on the engine): a wrong path such as /dev/zero is refused, not read into memory.
pub const MAX_TABLE_BYTES: u64 = 256 << 20;

/// A cell or a name as an error shows it: on one line (a quoted CSV cell may hold line breaks)
/// and at most 40 characters.
fn shown(s: &str) -> String {
    let one: String = s.escape_debug().collect();
    match one.char_indices().nth(40) {
        Some((i, _)) => format!("{}…", &one[..i]),
        None => one,
    }
}

/// The file's text, refused past [`MAX_TABLE_BYTES`].
fn read_limited(path: &Path) -> Result<String, String> {
    use std::io::Read;
    let mut bytes = Vec::new();
    // A named pipe would block the open: only a plain file is read.
    let meta = std::fs::metadata(path).map_err(|e| e.to_string())?;
    if !meta.is_file() {
        return Err("not a plain file (a folder, a device or a pipe)".into());
    }
    std::fs::File::open(path)
        .and_then(|f| f.take(MAX_TABLE_BYTES + 1).read_to_end(&mut bytes))
        .map_err(|e| e.to_string())?;
    if bytes.len() as u64 > MAX_TABLE_BYTES {
        return Err("larger than 256 MiB, the most a data table may be".into());
    }
    String::from_utf8(bytes).map_err(|e| {
        format!(
            "not text: invalid UTF-8 at byte {}",
            e.utf8_error().valid_up_to()
        )
    })
}

impl DataTable {
    pub fn read(path: &Path) -> Result<DataTable, String> {
        let text =
            read_limited(path).map_err(|e| format!("{}: cannot read: {e}", path.display()))?;
        DataTable::parse(&path.display().to_string(), &text)
    }

    pub fn parse(source: &str, text: &str) -> Result<DataTable, String> {
        let mut reader = csv::ReaderBuilder::new()
            .trim(csv::Trim::All)
            .comment(Some(b'#'))
            .from_reader(text.as_bytes());
        let headers: Vec<String> = reader
            .headers()
            .map_err(|e| format!("{source}: cannot read the header row: {e}"))?
            .iter()
            .map(String::from)
            .collect();
        if headers.is_empty() || headers.iter().all(|h| h.is_empty()) {
            return Err(format!("{source}: no header row"));
        }
        // Columns are found by name: a second of the same name would never be read.
        for (j, h) in headers.iter().enumerate() {
            if let Some(i) = headers[..j].iter().position(|g| g == h && !h.is_empty()) {
                return Err(format!(
                    "{source}: columns {} and {} are both named '{}'",
                    i + 1,
                    j + 1,
                    shown(h)
                ));
            }
        }
        let mut rows = Vec::new();
        for (i, rec) in reader.records().enumerate() {
            let rec = rec.map_err(|e| format!("{source}: row {}: {e}", i + 2))?;
            if rec.iter().all(|c| c.is_empty()) {
                continue;
            }
            rows.push(rec.iter().map(String::from).collect());
        }
        if rows.is_empty() {
            return Err(format!("{source}: no data rows"));
        }
        Ok(DataTable {
            source: source.to_string(),
            headers,
            rows,
        })
    }

    pub fn has_column(&self, name: &str) -> bool {
        self.headers.iter().any(|h| h == name)
    }

    /// A numeric column. Rows are numbered as in a spreadsheet (header = row 1).
    pub fn column(&self, name: &str) -> Result<Vec<f64>, String> {
        let j = self.headers.iter().position(|h| h == name).ok_or_else(|| {
            format!(
                "{}: column '{}' not found (columns: {})",
                self.source,
                shown(name),
                self.headers
                    .iter()
                    .map(|h| shown(h))
                    .collect::<Vec<_>>()
                    .join(", ")
            )
        })?;
        self.rows
            .iter()
            .enumerate()
            .map(|(i, r)| {
                let cell = r.get(j).map(String::as_str).unwrap_or("");
                let at = || format!("{}: row {}, column '{}'", self.source, i + 2, shown(name));
                let v = cell
                    .parse::<f64>()
                    .ok()
                    .filter(|v| v.is_finite())
                    .ok_or_else(|| format!("{}: '{}' is not a number", at(), shown(cell)))?;
                if v.abs() > MAX_MAGNITUDE {
                    return Err(format!(
                        "{}: {cell} is too large (values beyond ±1e150 overflow the sums of squares)",
                        at()
                    ));
                }
                Ok(v)
            })
            .collect()
    }

    /// Factor columns when none are named: every column except the responses and the bookkeeping
    /// columns a design file has (run order, standard order, block, point type, `*_actual`).
    pub fn default_factor_columns(&self, responses: &[String]) -> Vec<String> {
        const BOOKKEEPING: &[&str] = &[
            "run",
            "std",
            "std_order",
            "run_order",
            "order",
            "block",
            "type",
            "point_type",
        ];
        self.headers
            .iter()
            .filter(|h| {
                !responses.contains(h)
                    && !BOOKKEEPING.contains(&h.to_ascii_lowercase().as_str())
                    && !h.ends_with("_actual")
            })
            .cloned()
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn errors_name_row_and_column() {
        let t = DataTable::parse("d.csv", "run,A,y\n1,1,2\n2,x,3\n").unwrap();
        assert_eq!(t.column("y").unwrap(), vec![2.0, 3.0]);
        assert_eq!(
            t.column("A").unwrap_err(),
            "d.csv: row 3, column 'A': 'x' is not a number"
        );
        assert_eq!(
            t.column("B").unwrap_err(),
            "d.csv: column 'B' not found (columns: run, A, y)"
        );
        assert_eq!(
            t.default_factor_columns(&["y".into()]),
            vec!["A".to_string()]
        );
    }
}
