//! Writing HTML: escaping, numbered figures and tables, number formats.

use std::fmt::Write as _;

/// `text` with the five characters HTML gives a meaning (`& < > " '`) escaped, safe in
/// element content and in quoted attribute values.
pub fn escape(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            c => out.push(c),
        }
    }
    out
}

/// A table: a caption, column headings and rows, each led by a row heading. Every cell
/// is text (escaped when written).
#[derive(Debug, Clone, Default)]
pub struct Table {
    /// What the table shows (numbered when written: "Table 3. …").
    pub caption: String,
    /// The headings: the row headings' column first, then one per data column.
    pub columns: Vec<String>,
    /// Rows: the row heading, then one cell per data column.
    pub rows: Vec<Vec<String>>,
    /// Cells (row, data column) shown emphasised, e.g. each column's largest value.
    pub emphasised: Vec<(usize, usize)>,
}

impl Table {
    /// An empty table with a caption and column headings.
    pub fn new(caption: impl Into<String>, columns: Vec<String>) -> Table {
        Table {
            caption: caption.into(),
            columns,
            ..Table::default()
        }
    }

    /// Adds a row: its heading and its cells.
    pub fn row(&mut self, heading: impl Into<String>, cells: Vec<String>) -> &mut Table {
        let mut row = vec![heading.into()];
        row.extend(cells);
        self.rows.push(row);
        self
    }

    /// A matrix with row and column labels, entries formatted by `format`.
    pub fn matrix(
        caption: impl Into<String>,
        corner: &str,
        row_labels: &[String],
        column_labels: &[String],
        m: &[Vec<f64>],
        format: impl Fn(f64) -> String,
    ) -> Table {
        let mut columns = vec![corner.to_owned()];
        columns.extend(column_labels.iter().cloned());
        let mut t = Table::new(caption, columns);
        for (label, row) in row_labels.iter().zip(m) {
            t.row(label.clone(), row.iter().map(|v| format(*v)).collect());
        }
        t
    }
}

/// An HTML document being written, with its figure and table counters.
#[derive(Debug, Default)]
pub struct Markup {
    html: String,
    figures: usize,
    tables: usize,
}

impl Markup {
    /// The HTML written so far.
    pub fn as_str(&self) -> &str {
        &self.html
    }

    /// The HTML.
    pub fn into_string(self) -> String {
        self.html
    }

    /// Appends HTML as it is (the caller has escaped what needs it).
    pub fn raw(&mut self, html: &str) -> &mut Markup {
        self.html.push_str(html);
        self
    }

    /// A paragraph of text (escaped).
    pub fn paragraph(&mut self, text: &str) -> &mut Markup {
        let _ = writeln!(self.html, "<p>{}</p>", escape(text));
        self
    }

    /// A paragraph with a CSS class (`note`, `warning`).
    pub fn note(&mut self, class: &str, text: &str) -> &mut Markup {
        let _ = writeln!(
            self.html,
            "<p class=\"{}\">{}</p>",
            escape(class),
            escape(text)
        );
        self
    }

    /// A sub-heading inside a section.
    pub fn subheading(&mut self, text: &str) -> &mut Markup {
        let _ = writeln!(self.html, "<h3>{}</h3>", escape(text));
        self
    }

    /// A bulleted list of text items.
    pub fn list(&mut self, items: &[String]) -> &mut Markup {
        self.html.push_str("<ul>\n");
        for item in items {
            let _ = writeln!(self.html, "<li>{}</li>", escape(item));
        }
        self.html.push_str("</ul>\n");
        self
    }

    /// A numbered figure: an inline `<svg>` and its caption; returns its number.
    pub fn figure(&mut self, svg: &str, caption: &str) -> usize {
        self.figures += 1;
        let _ = writeln!(
            self.html,
            "<figure>\n{svg}\n<figcaption><b>Figure {}.</b> {}</figcaption>\n</figure>",
            self.figures,
            escape(caption)
        );
        self.figures
    }

    /// The number the next figure will have (for text that refers to it).
    pub fn next_figure(&self) -> usize {
        self.figures + 1
    }

    /// A numbered table; returns its number.
    pub fn table(&mut self, t: &Table) -> usize {
        self.tables += 1;
        let h = &mut self.html;
        let _ = writeln!(
            h,
            "<table>\n<caption><b>Table {}.</b> {}</caption>",
            self.tables,
            escape(&t.caption)
        );
        h.push_str("<thead><tr>");
        for c in &t.columns {
            let _ = write!(h, "<th scope=\"col\">{}</th>", escape(c));
        }
        h.push_str("</tr></thead>\n<tbody>\n");
        for (i, row) in t.rows.iter().enumerate() {
            h.push_str("<tr>");
            for (j, cell) in row.iter().enumerate() {
                if j == 0 {
                    let _ = write!(h, "<th scope=\"row\">{}</th>", escape(cell));
                } else if t.emphasised.contains(&(i, j - 1)) {
                    let _ = write!(h, "<td class=\"hi\">{}</td>", escape(cell));
                } else {
                    let _ = write!(h, "<td>{}</td>", escape(cell));
                }
            }
            h.push_str("</tr>\n");
        }
        h.push_str("</tbody>\n</table>\n");
        self.tables
    }
}

/// Raw HTML by `write!` (the caller has escaped what needs it).
impl std::fmt::Write for Markup {
    fn write_str(&mut self, s: &str) -> std::fmt::Result {
        self.html.push_str(s);
        Ok(())
    }
}

/// A state, part or input name for people: `stator_winding_temp` → "stator winding temp".
pub fn spoken(name: &str) -> String {
    name.replace('_', " ")
}

/// `v` with `digits` significant digits, in scientific notation outside 10⁻⁴ … 10⁶
/// (so Φ's small couplings read as the paper prints them, 0.00078830).
pub fn sig(v: f64, digits: usize) -> String {
    if !v.is_finite() {
        return "–".into();
    }
    if v == 0.0 {
        return "0".into();
    }
    let a = v.abs();
    if !(1e-4..1e6).contains(&a) {
        return format!("{v:.prec$e}", prec = digits.saturating_sub(1));
    }
    let decimals = (digits as i32 - 1 - a.log10().floor() as i32).max(0) as usize;
    format!("{v:.decimals$}")
}

/// `v` with a fixed number of decimals ("–" where not finite).
pub fn fixed(v: f64, decimals: usize) -> String {
    if v.is_finite() {
        format!("{v:.decimals$}")
    } else {
        "–".into()
    }
}

/// `value unit` with an SI prefix that keeps the number between 1 and 1000
/// (`si(81e-6, "K/W")` = "81.0 µK/W"), three significant digits.
pub fn si(value: f64, unit: &str) -> String {
    const PREFIXES: [(f64, &str); 9] = [
        (1e12, "T"),
        (1e9, "G"),
        (1e6, "M"),
        (1e3, "k"),
        (1.0, ""),
        (1e-3, "m"),
        (1e-6, "µ"),
        (1e-9, "n"),
        (1e-12, "p"),
    ];
    if !value.is_finite() {
        return format!("– {unit}");
    }
    if value == 0.0 {
        return format!("0 {unit}");
    }
    let (factor, prefix) = PREFIXES
        .iter()
        .find(|(f, _)| value.abs() >= *f * 0.9995)
        .copied()
        .unwrap_or((1e-12, "p"));
    format!("{} {prefix}{unit}", sig(value / factor, 3))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn escaping_covers_markup_and_quotes() {
        assert_eq!(
            escape(r#"<a href="x">'T' & y</a>"#),
            "&lt;a href=&quot;x&quot;&gt;&#39;T&#39; &amp; y&lt;/a&gt;"
        );
        assert_eq!(escape("Φ (eq. 19), °C"), "Φ (eq. 19), °C");
    }

    #[test]
    fn numbers_have_the_digits_asked_for() {
        assert_eq!(sig(0.9978, 5), "0.99780");
        assert_eq!(sig(737.2134, 5), "737.21");
        assert_eq!(sig(0.00078830, 5), "0.00078830");
        assert_eq!(sig(2.5e-7, 3), "2.50e-7");
        assert_eq!(sig(-3305.73, 6), "-3305.73");
        assert_eq!(sig(f64::NAN, 3), "–");
        assert_eq!(fixed(99.1234, 2), "99.12");
    }

    #[test]
    fn si_prefixes_keep_the_number_readable() {
        assert_eq!(si(81.2e-6, "K/W"), "81.2 µK/W");
        assert_eq!(si(12_345.0, "W/K"), "12.3 kW/K");
        assert_eq!(si(4.2e6, "J/K"), "4.20 MJ/K");
        assert_eq!(si(-0.5, "W/K"), "-500 mW/K");
        assert_eq!(si(0.0, "W"), "0 W");
    }

    #[test]
    fn a_table_escapes_its_cells_and_numbers_itself() {
        let mut m = Markup::default();
        let mut t = Table::new("a <b>", vec!["".into(), "x".into()]);
        t.row("r&1", vec!["1 < 2".into()]);
        t.emphasised.push((0, 0));
        assert_eq!(m.table(&t), 1);
        assert_eq!(m.table(&t), 2);
        let html = m.into_string();
        assert!(html.contains("<caption><b>Table 2.</b> a &lt;b&gt;</caption>"));
        assert!(html.contains("<th scope=\"row\">r&amp;1</th><td class=\"hi\">1 &lt; 2</td>"));
    }
}
