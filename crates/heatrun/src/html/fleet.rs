//! The fleet comparison's page (`heatrun fleet compare --html`): the units that differ
//! and why, a strip per family of quantities (each unit's signed score against the
//! fleet's band ±threshold), the whole table, and how the score is made.

use super::markup::{fixed, sig, spoken};
use super::plot::{palette, Chart, Line, Panel};
use super::{HtmlError, Markup, Page, Section, Table};
use crate::fleet::compare::{FleetComparison, QuantityRow, Scored};

/// The families the strips group the quantities in: (key prefix, axis label).
const FAMILIES: [(&str, &str); 7] = [
    ("time_constant_", "time constants"),
    ("steady_state_rise_k.", "steady-state rises"),
    ("rated_rise_k.", "rises at rated load"),
    ("capacitance_j_per_k.", "capacitances"),
    ("conductance_w_per_k.", "conductances"),
    ("loss_share.", "loss shares"),
    ("fit_percent.", "fit"),
];

/// The page of a fleet comparison.
pub fn fleet_compare_page(comparison: &FleetComparison) -> Result<Page<'_>, HtmlError> {
    let mut page = Page::new(
        "Fleet comparison",
        format!(
            "{} units of one design compared by heatrun {}",
            comparison.reports.len(),
            env!("CARGO_PKG_VERSION")
        ),
    );
    let differing: Vec<&String> = comparison
        .reports
        .iter()
        .filter(|r| comparison.outliers.iter().any(|o| &o.report == *r))
        .collect();
    page.facts = vec![
        ("units".into(), comparison.reports.len().to_string()),
        ("quantities".into(), comparison.table.len().to_string()),
        (
            "units that differ".into(),
            if differing.is_empty() {
                "none".into()
            } else {
                differing
                    .iter()
                    .map(|r| r.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            },
        ),
        (
            "threshold".into(),
            format!("score > {}", comparison.options.threshold),
        ),
    ];
    page.push(OutlierSection { comparison })
        .push(StripSection { comparison })
        .push(TableSection { comparison })
        .push(MethodSection { comparison });
    Ok(page)
}

/// The signed score (x − c) / √(s² + σ²) of one unit, where it has one.
fn signed_score(s: &Scored) -> Option<f64> {
    let (x, c, spread) = (s.value?, s.centre?, s.spread?);
    let sigma = s.standard_error.unwrap_or(0.0);
    let yardstick = (spread * spread + sigma * sigma).sqrt();
    (yardstick > 0.0).then(|| (x - c) / yardstick)
}

/// The units that differ, each quantity with its value, the fleet's centre and spread.
struct OutlierSection<'a> {
    comparison: &'a FleetComparison,
}

impl Section for OutlierSection<'_> {
    fn id(&self) -> &str {
        "outliers"
    }

    fn title(&self) -> String {
        "Units that differ".into()
    }

    fn render(&self, out: &mut Markup) -> Result<(), HtmlError> {
        let c = self.comparison;
        if c.outliers.is_empty() {
            out.note(
                "note",
                "No unit differs from the fleet beyond the fleet's spread and its own uncertainty.",
            );
            return Ok(());
        }
        let mut table = Table::new(
            "Each unit beyond the fleet in a quantity: its value, the fleet's centre and \
             spread without it, its own standard error and the score.",
            [
                "report", "quantity", "value", "centre", "spread", "own σ", "score",
            ]
            .map(String::from)
            .to_vec(),
        );
        for o in &c.outliers {
            table.row(
                o.report.clone(),
                vec![
                    o.quantity.clone(),
                    sig(o.value, 4),
                    sig(o.centre, 4),
                    sig(o.spread, 3),
                    o.standard_error.map_or("–".into(), |s| sig(s, 3)),
                    fixed(o.score, 1),
                ],
            );
        }
        out.table(&table);
        Ok(())
    }
}

/// A quantity's name in its family's legend: `time_constant_2_s` → "T2",
/// `loss_share.iron_loss.core_temp` → "iron loss core temp".
fn legend(quantity: &str, prefix: &str) -> String {
    let rest = &quantity[prefix.len()..];
    match rest.strip_suffix("_s") {
        Some(index) if prefix == "time_constant_" => format!("T{index}"),
        _ => spoken(&rest.replace('.', " → ")),
    }
}

/// One panel per family: each quantity's signed scores as a tick per unit, over the band
/// ±threshold.
struct StripSection<'a> {
    comparison: &'a FleetComparison,
}

impl StripSection<'_> {
    fn panel(&self, prefix: &str, label: &str) -> Option<Panel> {
        let rows: Vec<&QuantityRow> = self
            .comparison
            .table
            .iter()
            .filter(|r| r.quantity.starts_with(prefix))
            .collect();
        let lines: Vec<Line> = rows
            .iter()
            .enumerate()
            .map(|(k, row)| {
                // A short horizontal tick at each unit, so that no line joins two units.
                let ticks = row
                    .units
                    .iter()
                    .enumerate()
                    .filter_map(|(i, s)| {
                        let z = signed_score(s)?.clamp(-1e3, 1e3);
                        let x = (i + 1) as f64 + 0.25 * (k as f64 / rows.len() as f64 - 0.5);
                        Some(vec![(x - 0.12, z), (x + 0.12, z)])
                    })
                    .collect();
                Line::new(legend(&row.quantity, prefix), palette(k), ticks)
            })
            .collect();
        let threshold = self.comparison.options.threshold;
        let mut panel = Panel::new(format!("{label}, score"), lines);
        panel.band = Some((-threshold, threshold));
        panel.has_points().then_some(panel)
    }
}

impl Section for StripSection<'_> {
    fn id(&self) -> &str {
        "strips"
    }

    fn title(&self) -> String {
        "The fleet, quantity by quantity".into()
    }

    fn render(&self, out: &mut Markup) -> Result<(), HtmlError> {
        let c = self.comparison;
        for (prefix, label) in FAMILIES {
            let Some(panel) = self.panel(prefix, label) else {
                continue;
            };
            let mut chart = Chart::new("unit", vec![panel]);
            chart.height = 300;
            out.figure(
                &chart.to_svg()?,
                &format!(
                    "{label}: each unit's signed score (value − centre) / √(spread² + σ²) \
                     against the rest of the fleet; the grey band is ±{} (units U1…U{} as in \
                     the table).",
                    c.options.threshold,
                    c.reports.len()
                ),
            );
        }
        Ok(())
    }
}

/// Every quantity of every unit, outliers emphasised.
struct TableSection<'a> {
    comparison: &'a FleetComparison,
}

impl Section for TableSection<'_> {
    fn id(&self) -> &str {
        "table"
    }

    fn title(&self) -> String {
        "The table".into()
    }

    fn render(&self, out: &mut Markup) -> Result<(), HtmlError> {
        let c = self.comparison;
        let units: Vec<String> = c
            .reports
            .iter()
            .enumerate()
            .map(|(i, r)| format!("U{} = {r}", i + 1))
            .collect();
        out.list(&units);
        let mut columns = vec!["quantity".to_owned()];
        columns.extend((1..=c.reports.len()).map(|i| format!("U{i}")));
        let mut table = Table::new(
            "Each unit's value; emphasised where it is beyond the fleet.",
            columns,
        );
        for (r, row) in c.table.iter().enumerate() {
            let cells = row
                .units
                .iter()
                .map(|s| s.value.map_or("–".into(), |v| sig(v, 4)));
            table.row(row.quantity.clone(), cells.collect());
            for (i, s) in row.units.iter().enumerate() {
                if s.outlier {
                    table.emphasised.push((r, i));
                }
            }
        }
        out.table(&table);
        Ok(())
    }
}

/// How the score is made.
struct MethodSection<'a> {
    comparison: &'a FleetComparison,
}

impl Section for MethodSection<'_> {
    fn id(&self) -> &str {
        "method"
    }

    fn title(&self) -> String {
        "How a unit is judged".into()
    }

    fn render(&self, out: &mut Markup) -> Result<(), HtmlError> {
        let o = self.comparison.options;
        out.paragraph(&format!(
            "Each unit is held against the other units (leave-one-out): the fleet's centre is \
             their median, its spread 1.4826 × their median absolute deviation, at least {} % \
             of the quantity's scale. The score is |value − centre| / √(spread² + σ²), σ the \
             unit's own standard error from its report's 95 % interval (time constants and \
             steady-state rises). A unit differs where the score exceeds {}.",
            o.floor * 100.0,
            o.threshold
        ));
        Ok(())
    }
}
