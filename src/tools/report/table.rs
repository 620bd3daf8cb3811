//! Tables of measurements: aligned plain text for the terminal, CSV (RFC 4180) for files.

use std::fmt::Write as _;

/// A table of text cells under a header row.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Table {
    pub header: Vec<String>,
    pub rows: Vec<Vec<String>>,
}

impl Table {
    pub fn new<S: Into<String>>(header: impl IntoIterator<Item = S>) -> Table {
        Table { header: header.into_iter().map(Into::into).collect(), rows: Vec::new() }
    }

    /// Appends a row; it must have one cell per header column.
    pub fn push<S: Into<String>>(&mut self, row: impl IntoIterator<Item = S>) {
        let row: Vec<String> = row.into_iter().map(Into::into).collect();
        assert_eq!(row.len(), self.header.len(), "row has {} cells for {} columns", row.len(), self.header.len());
        self.rows.push(row);
    }

    /// Columns padded to their widest cell; cells that look numeric are right-aligned.
    pub fn to_text(&self) -> String {
        let widths: Vec<usize> = (0..self.header.len())
            .map(|c| {
                self.rows
                    .iter()
                    .map(|r| r[c].chars().count())
                    .chain([self.header[c].chars().count()])
                    .max()
                    .unwrap_or(0)
            })
            .collect();
        let mut out = String::new();
        let line = |cells: &[String], out: &mut String| {
            let mut l = String::new();
            for (c, cell) in cells.iter().enumerate() {
                if c > 0 {
                    l.push_str("  ");
                }
                let pad = widths[c] - cell.chars().count();
                if looks_numeric(cell) {
                    l.extend(std::iter::repeat_n(' ', pad));
                    l.push_str(cell);
                } else {
                    l.push_str(cell);
                    l.extend(std::iter::repeat_n(' ', pad));
                }
            }
            let _ = writeln!(out, "{}", l.trim_end());
        };
        line(&self.header, &mut out);
        let rule: Vec<String> = widths.iter().map(|&w| "-".repeat(w)).collect();
        line(&rule, &mut out);
        for r in &self.rows {
            line(r, &mut out);
        }
        out
    }

    /// CSV with a header line; fields with commas, quotes or line breaks are quoted.
    pub fn to_csv(&self) -> String {
        let mut out = String::new();
        for r in std::iter::once(&self.header).chain(&self.rows) {
            let cells: Vec<String> = r.iter().map(|c| csv_field(c)).collect();
            out.push_str(&cells.join(","));
            out.push('\n');
        }
        out
    }
}

fn looks_numeric(s: &str) -> bool {
    let s = s.trim_start_matches(['-', '+']).trim_end_matches(['×', '%', 'x']);
    !s.is_empty()
        && s.chars().all(|c| c.is_ascii_digit() || matches!(c, '.' | ',' | 'e' | 'E' | '-' | '+'))
        && s.chars().any(|c| c.is_ascii_digit())
}

fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) { format!("\"{}\"", s.replace('"', "\"\"")) } else { s.to_string() }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn text_aligns_and_csv_quotes() {
        let mut t = Table::new(["scene", "Mrays/s"]);
        t.push(["teapot", "12.5"]);
        t.push(["a, \"b\"", "3"]);
        assert_eq!(t.to_text(), "scene   Mrays/s\n------  -------\nteapot     12.5\na, \"b\"        3\n");
        assert_eq!(t.to_csv(), "scene,Mrays/s\nteapot,12.5\n\"a, \"\"b\"\"\",3\n");
    }

    #[test]
    #[should_panic(expected = "row has 1 cells for 2 columns")]
    fn rows_must_fill_the_header() {
        Table::new(["a", "b"]).push(["x"]);
    }
}
