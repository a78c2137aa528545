//! The default's decisions on the replay's page: for each, what was weighed, the figures
//! each candidate was judged by, and the verdict with its reason
//! ([`crate::decide::Decision`], read from the report as every output reads it).

use super::markup::{Markup, Table};
use super::{HtmlError, Section};
use crate::decide::Figure;
use crate::model_file::Report;

/// The decisions the replay made for the user; the page has the section only where it
/// made some (a library caller's replay, every choice given, has none).
pub struct DecisionsSection<'a> {
    /// The report.
    pub report: &'a Report,
}

impl Section for DecisionsSection<'_> {
    fn id(&self) -> &str {
        "decisions"
    }

    fn title(&self) -> String {
        "The default's decisions".into()
    }

    fn render(&self, out: &mut Markup) -> Result<(), HtmlError> {
        let decisions = &self.report.decisions;
        out.paragraph(
            "Where the user did not say, the replay chose: each table lists the candidates \
             weighed and the figures compared (against a noise model that holds each \
             temperature's resolution), the chosen one first in the caption.",
        );
        for d in decisions {
            let mut t = Table::new(
                format!("{}: {}. {}", d.what, d.chosen, d.reason),
                vec!["candidate".into(), "figures".into()],
            );
            for c in &d.candidates {
                let figures: Vec<String> = c.figures.iter().map(Figure::text).collect();
                let marked = if c.name == d.chosen {
                    format!("{} (chosen)", c.name)
                } else {
                    c.name.clone()
                };
                let cell = if figures.is_empty() {
                    "–".to_owned()
                } else {
                    figures.join("; ")
                };
                t.row(marked, vec![cell]);
            }
            out.table(&t);
        }
        Ok(())
    }
}
