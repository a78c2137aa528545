//! The viewer's layout: a first tab that tells the story (per part measured against
//! model, the residuals, the inputs, the time constants and fit as text), and tabs for
//! the rest (sensitivities, residual analysis, the recursive estimate, raw channels, the
//! full summary). Every time-series view shows the whole recording.

use heatrun::pipeline::Replay;

use super::layout::{Layout, Node, View, ViewKind};
use super::traces::{input_title, rise_unit, short_part, state_unit, temperature_entity};

/// The viewer layout of a replay (`full_rate`: the raw channels were published).
pub fn blueprint(replay: &Replay, full_rate: bool) -> Layout {
    let mut tabs = vec![overview(replay)];
    tabs.extend(sensitivities(replay));
    tabs.push(residual_analysis(replay));
    if replay.estimate.trajectory.is_some() {
        tabs.push(recursive_estimate());
    }
    if replay.network.network.is_ok() {
        tabs.push(
            View::new(
                ViewKind::Graph,
                "thermal network at the end of the run (Fig. 9)",
                super::network::GRAPH,
            )
            .into(),
        );
    }
    if replay.network.calorimetry.is_some() {
        tabs.push(
            View::time_series(
                "calorimetric balance (eqs. 17-18), kW",
                super::traces::CALORIMETRY,
            )
            .into(),
        );
    }
    tabs.push(raw_channels(full_rate));
    tabs.push(View::new(ViewKind::TextDocument, "summary", "summary").into());
    if !replay.decisions.is_empty() {
        tabs.push(View::new(ViewKind::TextDocument, "decisions", "decisions").into());
    }
    let open = std::env::var(OPEN_TAB).ok();
    let mut root = Node::tabs("heatrun", tabs);
    if let Some(i) = open.as_deref().and_then(|want| tab_titled(&root, want)) {
        root = root.with_active(i);
    }
    Layout { root }
}

/// The environment variable naming the tab the viewer opens on (the start of its title,
/// any case: `HEATRUN_OPEN_TAB="thermal network"`); unset or matching no tab, the first.
/// For recordings made to show one thing, and for screenshots, which cannot click.
pub const OPEN_TAB: &str = "HEATRUN_OPEN_TAB";

/// The index of the first child of `tabs` whose title starts with `want` (any case).
fn tab_titled(tabs: &Node, want: &str) -> Option<usize> {
    let Node::Container { children, .. } = tabs else {
        return None;
    };
    let want = want.trim().to_lowercase();
    if want.is_empty() {
        return None;
    }
    children
        .iter()
        .position(|c| c.title().to_lowercase().starts_with(&want))
}

/// The first screen: a plot per part, then residuals, inputs and the model's figures.
/// With `[hidden]` the model drawn is the hidden-state one (the replay's), the
/// measured-state model thin and grey beside it, and the titles say so.
fn overview(replay: &Replay) -> Node {
    let hidden = replay.hidden.is_some();
    let compared = if hidden {
        "measured, hidden-state model ŷ = Cx + Du (grey: measured-state model)"
    } else {
        "measured and model"
    };
    let per_part: Vec<Node> = replay
        .signals
        .states
        .iter()
        .enumerate()
        .map(|(j, s)| {
            View::time_series(
                format!(
                    "{}: {compared}, {}",
                    short_part(&s.part),
                    state_unit(&replay.model, j)
                ),
                temperature_entity(&s.name),
            )
            .into()
        })
        .collect();
    let residual_unit = rise_unit(&replay.model, 0);
    let whose = if hidden {
        " of the hidden-state model"
    } else {
        ""
    };
    let bottom = Node::horizontal(
        "residuals, inputs, model",
        vec![
            View::time_series(
                format!("residual y − ŷ{whose}, {residual_unit}"),
                "residual",
            )
            .into(),
            View::time_series(input_title(replay), "loss").into(),
            View::new(ViewKind::TextDocument, "time constants and fit", "model").into(),
        ],
    )
    .with_shares([2.0, 2.0, 1.5]);
    Node::vertical(
        "overview",
        vec![Node::horizontal("temperatures", per_part), bottom],
    )
    .with_shares([3.0, 2.0])
}

/// T_i ∂y/∂T_i per time constant: the responses behind the assignment, the replay's
/// model's (with `[hidden]`, the measured outputs' T_i C ∂x/∂T_i of the hidden-state
/// model; none where its Φ has no real logarithm, as the report has no assignment then).
fn sensitivities(replay: &Replay) -> Option<Node> {
    let (time_constants_s, what) = match &replay.hidden {
        Some(h) => (
            &h.analysis.as_ref()?.spectrum.time_constants_s,
            "T ∂ŷ/∂T (hidden-state model)",
        ),
        None => (&replay.analysis.spectrum.time_constants_s, "T ∂y/∂T"),
    };
    let unit = super::traces::sensitivity_unit(&replay.model);
    let views = time_constants_s
        .iter()
        .enumerate()
        .map(|(i, t)| {
            View::time_series(
                format!("T{} = {:.1} s: {what}, {unit}", i + 1, t),
                format!("sensitivity/T{}", i + 1),
            )
            .into()
        })
        .collect();
    Some(Node::horizontal("sensitivities", views))
}

/// Per part: the residual's autocorrelation and cross-correlations against the lag (the
/// report's `residuals`: the measured-state model's, which the title says with `[hidden]`).
fn residual_analysis(replay: &Replay) -> Node {
    let whose = if replay.hidden.is_some() {
        " of the measured-state model"
    } else {
        ""
    };
    let band = replay.analysis.residuals.band99;
    let views = replay
        .signals
        .states
        .iter()
        .map(|st| {
            let part = short_part(&st.part);
            Node::vertical(
                part,
                vec![
                    View::new(
                        ViewKind::BarChart,
                        format!(
                            "{part}: residual autocorrelation{whose} by lag (99 % band ±{band:.4})"
                        ),
                        format!("{}/{}", crate::analysis::AUTOCORRELATION_BY_LAG, st.name),
                    )
                    .into(),
                    View::time_series(
                        format!(
                            "{part}: correlations with the band and the inputs (pick the `lag` timeline)"
                        ),
                        format!("residual_correlation/{}", st.name),
                    )
                    .into(),
                ],
            )
        })
        .collect();
    Node::horizontal(format!("residual analysis{whose}"), views)
}

/// `--method rls`: the running estimate.
fn recursive_estimate() -> Node {
    Node::horizontal(
        "recursive estimate",
        vec![
            View::time_series("RLS time constants, s", "rls/time_constant").into(),
            View::time_series("RLS Φ", "rls/phi").into(),
            View::time_series("RLS Γ", "rls/gamma").into(),
        ],
    )
}

/// The decimated quantities, and the channels at full rate where published (`--raw`).
fn raw_channels(full_rate: bool) -> Node {
    let mut views: Vec<Node> =
        vec![View::time_series("decimated quantities (units in the legend)", "decimated").into()];
    if full_rate {
        views.push(View::time_series("full-rate channels", "full_rate").into());
    }
    Node::vertical("raw channels", views)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_time_series_view_of_the_fixture_layout_shows_the_whole_recording() {
        let fixture = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../fixtures/paper_heat_run.mcap");
        let replay =
            heatrun::pipeline::replay(&fixture, &heatrun::pipeline::ReplayOptions::default())
                .unwrap();
        let layout = blueprint(&replay, true);
        let views = layout.root.views();
        let series: Vec<_> = views
            .iter()
            .filter(|v| v.kind == ViewKind::TimeSeries)
            .collect();
        // 3 parts, residual, inputs, 3 sensitivities, 3 correlations, decimated, full
        // rate, and the calorimetric balance (the fixture records the flow).
        assert_eq!(series.len(), 14);
        assert!(series.iter().all(|v| v.shows_whole_range()));
        assert_eq!(views[0].origin, "temperature/stator_winding_temp");
        assert!(views[0].name.ends_with("°C"), "{}", views[0].name);
    }

    /// The residual tab opens on something drawn: per part a bar chart of the
    /// autocorrelation (static, on any timeline) whose entity the .rrd holds, above the
    /// series on the `lag` timeline.
    #[test]
    fn the_residual_tab_draws_each_parts_correlogram_on_any_timeline() {
        let dir = tempfile::tempdir().unwrap();
        let mcap = dir.path().join("run.mcap");
        heatrun::synth::write(
            &mcap,
            &heatrun::synth::SynthOptions::default().with_noise_level(1.0),
        )
        .unwrap();
        let options = heatrun::pipeline::ReplayOptions {
            ts_s: 10.0,
            ..heatrun::pipeline::ReplayOptions::default()
        };
        let (replayed, _) = crate::rrd_testing::replayed_and_drawn(&mcap, &options);
        let replay = &replayed.replay;
        let layout = blueprint(replay, true);
        let bars: Vec<String> = layout
            .root
            .views()
            .iter()
            .filter(|v| v.kind == ViewKind::BarChart)
            .map(|v| format!("/{}", v.origin))
            .collect();
        let states: Vec<String> = replay
            .signals
            .states
            .iter()
            .map(|s| format!("/{}/{}", crate::analysis::AUTOCORRELATION_BY_LAG, s.name))
            .collect();
        assert_eq!(bars, states);
        let stored = crate::rrd_testing::static_bar_charts(&mcap.with_extension("rrd"));
        assert_eq!(stored, states.into_iter().collect());
    }

    #[test]
    fn the_tab_to_open_is_found_by_the_start_of_its_title() {
        let tabs = Node::tabs(
            "heatrun",
            vec![
                View::time_series("overview", "a").into(),
                View::new(ViewKind::Graph, "thermal network at the end", "b").into(),
                View::new(ViewKind::TextDocument, "summary", "c").into(),
            ],
        );
        assert_eq!(tab_titled(&tabs, "Thermal Network"), Some(1));
        assert_eq!(tab_titled(&tabs, " summary"), Some(2));
        assert_eq!(tab_titled(&tabs, "residuals"), None);
        assert_eq!(tab_titled(&tabs, ""), None);
        let Node::Container { active, .. } = tabs.with_active(1) else {
            panic!("a container")
        };
        assert_eq!(active, Some(1));
    }
}
