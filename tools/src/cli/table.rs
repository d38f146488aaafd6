//! A Markdown table with padded columns, readable as plain text and pasteable into a README,
//! and the formatting of its cells.

/// How a column's cells are aligned.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Align {
    Left,
    Right,
}

/// Column titles and alignment, and rows of already formatted cells.
#[derive(Debug, Default)]
pub struct Table {
    titles: Vec<String>,
    aligns: Vec<Align>,
    rows: Vec<Vec<String>>,
}

impl Table {
    /// Adds a column (before any row is pushed).
    pub fn column(&mut self, title: impl Into<String>, align: Align) {
        self.titles.push(title.into());
        self.aligns.push(align);
    }

    /// Adds a row; it must have one cell per column.
    pub fn push(&mut self, row: Vec<String>) {
        debug_assert_eq!(row.len(), self.titles.len(), "one cell per column");
        self.rows.push(row);
    }

    /// The table in Markdown, one line per row, each ending in a newline.
    pub fn render(&self) -> String {
        let widths = self.widths();
        let mut out = self.line(&self.titles, &widths);
        let rule: Vec<String> = widths
            .iter()
            .zip(&self.aligns)
            .map(|(&w, align)| match align {
                Align::Left => "-".repeat(w),
                Align::Right => format!("{}:", "-".repeat(w - 1)),
            })
            .collect();
        out += &self.line(&rule, &widths);
        for row in &self.rows {
            out += &self.line(row, &widths);
        }
        out
    }

    /// Width of each column: its widest cell, at least 3 (a Markdown rule needs `--:`).
    fn widths(&self) -> Vec<usize> {
        (0..self.titles.len())
            .map(|c| {
                let cells = std::iter::once(&self.titles[c]).chain(self.rows.iter().map(|r| &r[c]));
                cells.map(|s| s.chars().count()).max().unwrap_or(0).max(3)
            })
            .collect()
    }

    fn line(&self, cells: &[String], widths: &[usize]) -> String {
        let padded: Vec<String> = cells
            .iter()
            .zip(widths)
            .zip(&self.aligns)
            .map(|((cell, &w), align)| match align {
                Align::Left => format!("{cell:<w$}"),
                Align::Right => format!("{cell:>w$}"),
            })
            .collect();
        format!("| {} |\n", padded.join(" | "))
    }
}

/// A speed in Mrays/s.
pub fn mrays(x: f64) -> String {
    format!("{x:.2}")
}

/// A ratio such as `1.25x`, or `-` if it is not a number.
pub fn ratio(x: f64) -> String {
    if x.is_finite() {
        format!("{x:.2}x")
    } else {
        "-".to_string()
    }
}

/// `1234567` as `1,234,567`.
pub fn thousands(n: usize) -> String {
    let digits = n.to_string();
    let mut out = String::new();
    for (i, d) in digits.chars().enumerate() {
        if i > 0 && (digits.len() - i).is_multiple_of(3) {
            out.push(',');
        }
        out.push(d);
    }
    out
}
