//! Plain-text tables for the terminal: each column as wide as its widest cell, header included,
//! so that a long factor or term name widens its column instead of pushing the cells after it
//! out of line. Widths count chars, not bytes: "R²", "µ" and "–" take one column each, as they
//! do in a terminal (the tables hold no wide CJK text or emoji).

/// How a column's cells sit in its width.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Align {
    Left,
    Right,
}

/// Rows of cells under a header; [`TextTable::render`] lays them out.
#[derive(Clone, Debug)]
pub struct TextTable {
    align: Vec<Align>,
    rows: Vec<Vec<String>>,
}

/// Spaces between two columns.
const GAP: usize = 2;

impl TextTable {
    /// A table with these column titles and alignments (one each).
    pub fn new(header: &[&str], align: &[Align]) -> TextTable {
        assert_eq!(
            header.len(),
            align.len(),
            "a title and an alignment per column"
        );
        TextTable {
            align: align.to_vec(),
            rows: vec![header.iter().map(|h| h.to_string()).collect()],
        }
    }

    /// A table without a header row (label and value pairs).
    pub fn headless(align: &[Align]) -> TextTable {
        TextTable {
            align: align.to_vec(),
            rows: Vec::new(),
        }
    }

    /// Adds a row; a row shorter than the header leaves its last cells empty.
    pub fn row(&mut self, cells: Vec<String>) {
        debug_assert!(cells.len() <= self.align.len(), "{cells:?}");
        self.rows.push(cells);
    }

    /// The table, one line per row (the header first), each ending in a newline, without
    /// trailing spaces.
    pub fn render(&self) -> String {
        let n = self.align.len();
        let width: Vec<usize> = (0..n)
            .map(|c| {
                self.rows
                    .iter()
                    .filter_map(|r| r.get(c))
                    .map(|s| s.chars().count())
                    .max()
                    .unwrap_or(0)
            })
            .collect();
        let mut out = String::new();
        for r in &self.rows {
            let mut line = String::new();
            for (c, (&w, &align)) in width.iter().zip(&self.align).enumerate() {
                let cell = r.get(c).map_or("", String::as_str);
                let pad = " ".repeat(w - cell.chars().count());
                if c > 0 {
                    line.push_str(&" ".repeat(GAP));
                }
                match align {
                    Align::Left => {
                        line.push_str(cell);
                        line.push_str(&pad);
                    }
                    Align::Right => {
                        line.push_str(&pad);
                        line.push_str(cell);
                    }
                }
            }
            out.push_str(line.trim_end());
            out.push('\n');
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn columns_are_as_wide_as_their_widest_cell_counted_in_chars() {
        let mut t = TextTable::new(
            &["Term", "Estimate", ""],
            &[Align::Left, Align::Right, Align::Left],
        );
        t.row(vec!["µ²-friction".into(), "1.5".into(), "note".into()]);
        t.row(vec!["A".into(), "-12.25".into()]);
        let text = t.render();
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(
            lines,
            [
                "Term         Estimate",
                "µ²-friction       1.5  note",
                "A              -12.25",
            ]
        );
        // "µ²" is four bytes and two chars: padding by bytes would leave that row two short.
        assert_eq!(lines[1].chars().position(|c| c == '5'), Some(20));
    }
}
