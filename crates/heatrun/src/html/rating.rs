//! The rating's page (`heatrun rating --html`): the limits and where they come from, the
//! largest continuous apparent power and the part that limits it, the temperatures and
//! margins, and the short-time overloads with a plot of time to limit against current.

use super::markup::{fixed, sig, spoken};
use super::plot::{palette, Chart, Line, Panel};
use super::{HtmlError, Markup, Page, Section, Table};
use crate::rating::{Overload, Rating};

/// The rating's page for the machine `machine` (the model's name). `curve`: overloads on
/// a finer grid than the table's, for the plot of time to limit against current (the
/// table's own where `None`).
pub fn rating_page<'a>(
    rating: &'a Rating,
    machine: &str,
    curve: Option<&'a [Overload]>,
) -> Page<'a> {
    let mut page = Page::new(
        format!("{machine}: thermal rating"),
        format!(
            "Rated by heatrun {} from the model {}",
            env!("CARGO_PKG_VERSION"),
            rating.model
        ),
    );
    page.facts = vec![
        (
            "largest continuous power".into(),
            format!(
                "{} MVA ({} × rated)",
                fixed(rating.max_continuous_apparent_power_mva, 2),
                fixed(rating.max_continuous_per_rated, 3)
            ),
        ),
        ("limited by".into(), spoken(&rating.limiting_state)),
    ];
    if let Some([lo, hi]) = rating.max_continuous_apparent_power_mva_95 {
        page.facts.push((
            "95 % interval".into(),
            format!(
                "{} to {} MVA; another part limits with probability {}",
                fixed(lo, 2),
                fixed(hi, 2),
                fixed(rating.probability_another_part_limits.unwrap_or(0.0), 3)
            ),
        ));
    }
    page.facts.extend([
        ("power factor".into(), rating.power_factor.to_string()),
        (
            "voltage".into(),
            format!("{} kV", fixed(rating.voltage_kv, 3)),
        ),
        (
            "coolant inlet".into(),
            rating
                .coolant_inlet_temp_c
                .map_or("as in the model's test".into(), |c| format!("{c} °C")),
        ),
    ]);
    page.push(LimitsSection { rating })
        .push(ContinuousSection { rating })
        .push(OverloadSection {
            rating,
            curve: curve.unwrap_or(&rating.overloads),
        });
    page
}

/// The limits per part and their source.
struct LimitsSection<'a> {
    rating: &'a Rating,
}

impl Section for LimitsSection<'_> {
    fn id(&self) -> &str {
        "limits"
    }

    fn title(&self) -> String {
        "Limits".into()
    }

    fn render(&self, out: &mut Markup) -> Result<(), HtmlError> {
        let r = self.rating;
        let mut table = Table::new(
            "The temperature limit of each part and where it comes from.",
            ["part", "limit, °C", "from"].map(String::from).to_vec(),
        );
        for p in &r.limits {
            table.row(
                spoken(&p.name),
                vec![fixed(p.limit_c, 1), p.limit_from.clone()],
            );
        }
        out.table(&table);
        out.note("note", &format!("Limits of a class: {}.", r.limit_source));
        out.note(
            "warning",
            "The class limits were entered from IEC 60034-1 as remembered, not checked \
             against a copy of the standard: verify them before relying on a rating.",
        );
        Ok(())
    }
}

/// The largest continuous power, the temperatures there and at rated load, the margins.
struct ContinuousSection<'a> {
    rating: &'a Rating,
}

impl Section for ContinuousSection<'_> {
    fn id(&self) -> &str {
        "continuous"
    }

    fn title(&self) -> String {
        "Continuous rating".into()
    }

    fn render(&self, out: &mut Markup) -> Result<(), HtmlError> {
        let r = self.rating;
        out.paragraph(&format!(
            "At cos φ = {} and U = {} kV, the largest apparent power whose steady state keeps \
             every part within its limit is {} MVA ({} × rated), limited by the {}.",
            r.power_factor,
            fixed(r.voltage_kv, 3),
            fixed(r.max_continuous_apparent_power_mva, 2),
            fixed(r.max_continuous_per_rated, 3),
            spoken(&r.limiting_state)
        ));
        if let Some([lo, hi]) = r.max_continuous_apparent_power_mva_95 {
            out.paragraph(&format!(
                "Carried from the identification's covariance (each part's own limit \
                 linearised in Φ and Γ, the least of them drawn {} times), its 95 % interval \
                 is {} to {} MVA; the probability that another part limits instead is {}.",
                crate::rating::INTERVAL_DRAWS,
                fixed(lo, 2),
                fixed(hi, 2),
                fixed(r.probability_another_part_limits.unwrap_or(0.0), 3)
            ));
        }
        let mut table = Table::new(
            "Steady temperatures at the largest continuous power and at rated power, and \
             each part's margin at rated power (limit − temperature); the limiting part's \
             temperature and the smallest margin emphasised.",
            [
                "part",
                "limit, °C",
                "at max, °C",
                "at rated, °C",
                "margin at rated, K",
            ]
            .map(String::from)
            .to_vec(),
        );
        for (i, p) in r.limits.iter().enumerate() {
            table.row(
                spoken(&p.name),
                vec![
                    fixed(p.limit_c, 1),
                    fixed(r.temperatures_at_max_c[i], 2),
                    fixed(r.temperatures_at_rated_c[i], 2),
                    fixed(r.margins_at_rated_k[i], 2),
                ],
            );
            if p.name == r.limiting_state {
                table.emphasised.push((i, 1));
            }
        }
        let least = r.margins_at_rated_k.iter().enumerate().fold(
            None,
            |m: Option<(usize, f64)>, (i, &v)| match m {
                Some((_, b)) if b <= v => m,
                _ => Some((i, v)),
            },
        );
        if let Some((i, _)) = least {
            table.emphasised.push((i, 3));
        }
        out.table(&table);
        for w in &r.warnings {
            out.note("warning", w);
        }
        Ok(())
    }
}

/// Short-time overloads from the rated steady state.
struct OverloadSection<'a> {
    rating: &'a Rating,
    curve: &'a [Overload],
}

impl Section for OverloadSection<'_> {
    fn id(&self) -> &str {
        "overloads"
    }

    fn title(&self) -> String {
        "Short-time overloads".into()
    }

    fn render(&self, out: &mut Markup) -> Result<(), HtmlError> {
        let r = self.rating;
        let mut table = Table::new(
            "Time from the rated steady state until the first part reaches its limit, per \
             armature current (none: not within ten slowest time constants).",
            [
                "current, % of rated",
                "time to limit, s",
                "time to limit, min",
                "first part",
                "95 % interval, s",
            ]
            .map(String::from)
            .to_vec(),
        );
        for o in &r.overloads {
            table.row(
                fixed(o.current_percent, 0),
                vec![
                    o.time_to_limit_s.map_or("none".into(), |t| fixed(t, 0)),
                    o.time_to_limit_s.map_or("–".into(), |t| sig(t / 60.0, 3)),
                    o.limiting_part.as_deref().map_or("–".into(), spoken),
                    o.time_to_limit_s_95.map_or("–".into(), |[a, b]| {
                        format!("{} to {}", fixed(a, 0), fixed(b, 0))
                    }),
                ],
            );
        }
        out.table(&table);
        let points: Vec<(f64, f64)> = self
            .curve
            .iter()
            .filter_map(|o| o.time_to_limit_s.map(|t| (o.current_percent, t / 60.0)))
            .collect();
        if points.len() < 2 {
            out.note(
                "note",
                "Fewer than two overloads reach a limit: there is no curve to draw.",
            );
            return Ok(());
        }
        let chart = Chart::new(
            "armature current, % of rated",
            vec![Panel::new(
                "time to the first limit, min",
                vec![Line::new("time to limit", palette(0), vec![points])],
            )],
        );
        out.paragraph(&format!(
            "Figure {} shows how long each overload may be held from the rated steady state.",
            out.next_figure()
        ));
        out.figure(
            &chart.to_svg()?,
            "Time to the first limit against the armature current, from the rated steady state.",
        );
        Ok(())
    }
}
