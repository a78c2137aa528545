//! The HTML report: one self-contained page (styles inline, figures as inline SVG, no
//! reference outside itself) that reads like the paper's results section and prints to
//! PDF.
//!
//! A [`Page`] is a list of [`Section`]s, each a struct that renders itself into
//! [`Markup`] (numbered figures and tables, escaped text). The replay's page is
//! [`replay_page`] ([`sections`] holds its sections, reading the [`crate::pipeline::Replay`] and its
//! [`crate::model_file::Report`]); another command builds its own page from its own sections and the same
//! pieces: [`plot::Chart`] for figures, [`Table`] for tables, [`Page::write`] to save it.
//! `heatrun predict`, `heatrun rating`, `heatrun monitor` and `heatrun fleet compare` do
//! so: [`predict_page`], [`rating_page`], [`monitor_page`], [`fleet_compare_page`].

pub mod decisions;
pub mod fleet;
#[cfg(test)]
mod hidden_tests;
pub mod markup;
pub mod monitor;
pub mod network;
pub mod plot;
pub mod predict;
pub mod rating;
pub mod sections;
mod style;

use std::fmt::Write as _;
use std::path::Path;

pub use fleet::fleet_compare_page;
pub use markup::{escape, Markup, Table};
pub use monitor::monitor_page;
pub use predict::{predict_page, PredictionView};
pub use rating::rating_page;

use crate::pipeline::ReplayOptions;
use crate::report::Replayed;

/// Why a page could not be made.
#[derive(Debug, thiserror::Error)]
pub enum HtmlError {
    /// A figure could not be drawn (the plotting library refused its data).
    #[error("cannot draw a figure of the HTML report: {0}")]
    Figure(String),
    /// The page could not be written.
    #[error(transparent)]
    Write(#[from] crate::atomic::WriteError),
}

/// One section of a page: a heading and its body.
pub trait Section {
    /// The section's anchor (`id` attribute), unique in its page.
    fn id(&self) -> &str;
    /// Its heading.
    fn title(&self) -> String;
    /// Writes the section's body (paragraphs, figures, tables) into `out`.
    fn render(&self, out: &mut Markup) -> Result<(), HtmlError>;
}

/// A page: a title, a line under it, facts shown as a header table, and its sections.
pub struct Page<'a> {
    /// The page's title (`<title>` and the heading).
    pub title: String,
    /// A line under the title (what was done, by which version).
    pub subtitle: String,
    /// Key facts shown at the top: (label, value).
    pub facts: Vec<(String, String)>,
    sections: Vec<Box<dyn Section + 'a>>,
}

impl<'a> Page<'a> {
    /// An empty page.
    pub fn new(title: impl Into<String>, subtitle: impl Into<String>) -> Page<'a> {
        Page {
            title: title.into(),
            subtitle: subtitle.into(),
            facts: Vec::new(),
            sections: Vec::new(),
        }
    }

    /// Appends a section.
    pub fn push(&mut self, section: impl Section + 'a) -> &mut Page<'a> {
        self.sections.push(Box::new(section));
        self
    }

    /// The sections' anchors and titles, in order.
    pub fn contents(&self) -> Vec<(String, String)> {
        self.sections
            .iter()
            .map(|s| (s.id().to_owned(), s.title()))
            .collect()
    }

    /// The page as one HTML document.
    pub fn render(&self) -> Result<String, HtmlError> {
        let mut out = Markup::default();
        let _ = write!(
            out,
            "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n\
             <meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n\
             <title>{}</title>\n<style>\n{}</style>\n</head>\n<body>\n<main>\n<header>\n\
             <h1>{}</h1>\n<p class=\"subtitle\">{}</p>\n",
            escape(&self.title),
            style::CSS,
            escape(&self.title),
            escape(&self.subtitle)
        );
        if !self.facts.is_empty() {
            out.raw("<dl class=\"facts\">\n");
            for (label, value) in &self.facts {
                out.raw(&format!(
                    "<div><dt>{}</dt><dd>{}</dd></div>\n",
                    escape(label),
                    escape(value)
                ));
            }
            out.raw("</dl>\n");
        }
        out.raw("<nav>\n<h2>Contents</h2>\n<ol>\n");
        for (id, title) in self.contents() {
            out.raw(&format!(
                "<li><a href=\"#{}\">{}</a></li>\n",
                escape(&id),
                escape(&title)
            ));
        }
        out.raw("</ol>\n</nav>\n</header>\n");
        for (i, s) in self.sections.iter().enumerate() {
            out.raw(&format!(
                "<section id=\"{}\">\n<h2>{}. {}</h2>\n",
                escape(s.id()),
                i + 1,
                escape(&s.title())
            ));
            s.render(&mut out)?;
            out.raw("</section>\n");
        }
        out.raw("</main>\n</body>\n</html>\n");
        Ok(out.into_string())
    }

    /// Renders the page and writes it to `path`, complete or not at all.
    pub fn write(&self, path: &Path) -> Result<(), HtmlError> {
        let html = self.render()?;
        crate::atomic::write_atomically(path, html.as_bytes())?;
        Ok(())
    }
}

/// The replay's page: the recording, the inputs and the measured against the model's
/// temperatures, the model (Φ, Γ, A_c, B_c, eigenvalues), time constants and their
/// sensitivities, the fit, the steady state, the residuals, the recursive estimate where
/// used, the thermal network and the calorimetric balance where present, validation, and
/// the estimator's settings.
pub fn replay_page<'a>(replayed: &'a Replayed, options: &'a ReplayOptions) -> Page<'a> {
    use sections::*;
    let (replay, report) = (&replayed.replay, &replayed.report);
    let mut page = Page::new(
        format!("{}: thermal model", sections::recording_title(report)),
        sections::subtitle(report),
    );
    page.facts = sections::header_facts(report);
    page.push(RecordingSection { report })
        .push(InputsSection { replay })
        .push(TemperaturesSection { replay, report })
        .push(ModelSection { report })
        .push(TimeConstantsSection { replay, report })
        .push(FitSection { report })
        .push(SteadyStateSection { report })
        .push(ResidualsSection { report });
    if replay.estimate.trajectory.is_some() {
        page.push(RecursiveSection { replay });
    }
    page.push(NetworkSection { report });
    if report.calorimetry.is_some() {
        page.push(CalorimetrySection { replay, report });
    }
    if report.validation.is_some() {
        page.push(ValidationSection { report });
    }
    if !report.decisions.is_empty() {
        page.push(decisions::DecisionsSection { report });
    }
    page.push(EstimatorSection {
        replay,
        report,
        options,
    });
    page
}
