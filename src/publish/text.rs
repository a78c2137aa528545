//! The model's figures as a text panel beside the plots: time constants with their
//! 95 % intervals and parts, and the fit per part.

use std::fmt::Write as _;

use crate::report::Report;

/// Markdown: the time constants (eq. 26) and their parts, and the fit (eq. 25) per part.
pub fn model_figures(report: &Report) -> String {
    let mut s = String::from("**Time constants** (eq. 26)\n\n| | T, s | part |\n|---|---:|---|\n");
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
    let _ = writeln!(
        s,
        "\nmethod `{}`, Ts = {} s, {} instants",
        report.method, report.sample_time_s, fit.samples
    );
    s
}
