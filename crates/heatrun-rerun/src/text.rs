//! The model's figures as a text panel beside the plots: time constants with their
//! 95 % intervals and parts, and the fit per part; plain-text tables in a fixed-width font.

use std::fmt::Write as _;

use heatrun::model_file::Report;

/// Markdown: the time constants (eq. 26) and their parts, and the fit (eq. 25) per part,
/// of the report's model (with `[hidden]` the hidden-state model's, which the panel names).
pub fn model_figures(report: &Report) -> String {
    let hidden = report.hidden.as_ref().filter(|h| h.replay_model);
    let mut s = String::new();
    if let Some(h) = hidden {
        let _ = writeln!(
            s,
            "**Hidden-state model** y = Cx + Du: {} states, {} measured (C {}; order {})\n",
            h.order,
            h.measured.iter().filter(|m| **m).count(),
            h.output_matrix,
            h.order_source
        );
    }
    s.push_str("**Time constants** (eq. 26)\n\n| | T, s | part |\n|---|---:|---|\n");
    let ci = report
        .uncertainty
        .as_ref()
        .map(|u| &u.time_constants_ci95_s);
    for (i, a) in report.assignment.iter().enumerate() {
        let interval = ci
            .and_then(|c| c.get(i))
            .map(|c| format!(" ± {c:.1}"))
            .unwrap_or_default();
        let _ = writeln!(
            s,
            "| T{} | {:.1}{interval} | {} |",
            i + 1,
            a.time_constant_s,
            a.part
        );
    }
    s.push_str("\n**Fit** (eq. 25)\n\n| part | NRMSE fit, % | RMSE, K | largest, K |\n|---|---:|---:|---:|\n");
    let fit = &report.fit;
    for (j, part) in report.model.states.iter().map(|s| &s.part).enumerate() {
        let _ = writeln!(
            s,
            "| {} | {:.2} | {:.3} | {:.3} |",
            part, fit.nrmse_fit_percent[j], fit.rmse_k[j], fit.max_abs_error_k[j]
        );
    }
    match hidden {
        // The method names the measured-state model's estimator, not the hidden model's.
        Some(_) => {
            let _ = writeln!(
                s,
                "\nsubspace start and output error, each segment from its fitted state; \
                 the measured-state model (grey) by `{}`; Ts = {} s, {} instants",
                report.method, report.sample_time_s, fit.samples
            );
        }
        None => {
            let _ = writeln!(
                s,
                "\nmethod `{}`, Ts = {} s, {} instants",
                report.method, report.sample_time_s, fit.samples
            );
        }
    }
    s
}

/// The default's decisions as text: each verdict with its reason, then each candidate's
/// figures ([`heatrun::decide::Decision::lines`], as the summary prints them).
pub fn decisions(report: &Report) -> String {
    report
        .decisions
        .iter()
        .flat_map(|d| d.lines())
        .collect::<Vec<_>>()
        .join("\n")
}

/// A plain-text table (the terminal summary, the monitor's) as a document the viewer shows
/// in a fixed-width font: Markdown, the text in one fenced block, so its columns line up
/// as they do on a terminal (rerun draws plain text proportionally).
pub fn preformatted(text: &str) -> crate::sdk::TextDocument {
    crate::sdk::TextDocument::new(format!("```text\n{}\n```\n", text.trim_end()))
        .with_media_type(crate::sdk::MediaType::markdown())
}
