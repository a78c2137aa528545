//! The thermal network (Fig. 9) as a graph: a node per part labelled with its
//! capacitance, the coolant, and a node per conductance labelled with its resistance and
//! the heat through it at the end of the run (sized and coloured by that heat); edges in
//! the direction the heat flows.

use crate::paced::PacedStream;
use crate::sdk::{GraphEdges, GraphNodes};

use crate::Result;
use heatrun::network::Network;
use heatrun::pipeline::Replay;

use super::{publish_err, style};

/// Entity of the network graph.
pub const GRAPH: &str = "network/graph";

/// A point on a circle of radius `r` at step `i` of `n`, starting at the top.
fn on_circle(i: usize, n: usize, r: f32) -> (f32, f32) {
    let a = -std::f32::consts::FRAC_PI_2 + std::f32::consts::TAU * i as f32 / n.max(1) as f32;
    (r * a.cos(), r * a.sin())
}

/// Radius of the circle the parts stand on.
const RADIUS: f32 = 300.0;

/// Where the node of the conductance between parts `i` and `j` (of `n`) stands: halfway
/// between them, except on a chord through the centre (opposite parts of four or six),
/// whose halfway point is the coolant's: there it stands a third of the radius out, in
/// the sector after part `i`, so that neither hides the coolant or the other chords.
fn between(i: usize, j: usize, n: usize) -> (f32, f32) {
    let (a, b) = (on_circle(i, n, RADIUS), on_circle(j, n, RADIUS));
    let mid = ((a.0 + b.0) / 2.0, (a.1 + b.1) / 2.0);
    if mid.0.hypot(mid.1) > RADIUS / 4.0 {
        return mid;
    }
    let angle =
        -std::f32::consts::FRAC_PI_2 + std::f32::consts::TAU * (i as f32 + 0.5) / n.max(1) as f32;
    let r = RADIUS / 3.0;
    (r * angle.cos(), r * angle.sin())
}

/// Measured rises at the end of the run, K (model order).
fn final_rises(replay: &Replay) -> Option<Vec<f64>> {
    let s = &replay.signals;
    let (k, measured) = s.last_measured()?;
    Some(
        s.states
            .iter()
            .zip(measured)
            .map(|(st, m)| m - st.reference_at(k).unwrap_or(f64::NAN))
            .collect(),
    )
}

/// Logs the graph where the model has a network; does nothing otherwise.
pub(super) fn log_network(rec: &PacedStream, replay: &Replay) -> Result<()> {
    let (Ok(network), Some(rises)) = (&replay.network.network, final_rises(replay)) else {
        return Ok(());
    };
    let Ok(flows) = network.heat_flows_w(&rises) else {
        return Ok(());
    };
    let (nodes, edges) = graph(network, &flows);
    rec.log_static(GRAPH, &nodes).map_err(publish_err)?;
    rec.log_static(GRAPH, &edges).map_err(publish_err)
}

/// Engineering notation: 1.23e4 → "12.3 k".
fn eng(v: f64) -> String {
    let (scale, prefix) = match v.abs() {
        a if a >= 1e6 => (1e6, "M"),
        a if a >= 1e3 => (1e3, "k"),
        a if a >= 1.0 || a == 0.0 => (1.0, ""),
        a if a >= 1e-3 => (1e-3, "m"),
        _ => (1e-6, "µ"),
    };
    format!("{:.3} {prefix}", v / scale)
}

/// The nodes and directed edges of `network` with the heat `flows` (W) of
/// [`Network::heat_flows_w`].
pub fn graph(network: &Network, flows: &[Vec<f64>]) -> (GraphNodes, GraphEdges) {
    let n = network.capacitance_j_per_k.len();
    let largest = flows.iter().flatten().fold(0.0_f64, |m, q| m.max(q.abs()));
    let mut ids = Vec::new();
    let mut positions = Vec::new();
    let mut labels = Vec::new();
    let mut colours = Vec::new();
    let mut radii = Vec::new();
    let mut edges: Vec<(String, String)> = Vec::new();
    for i in 0..n {
        ids.push(format!("part{i}"));
        positions.push(on_circle(i, n, RADIUS));
        labels.push(format!(
            "{}\nC = {}J/K",
            network.states[i],
            eng(network.capacitance_j_per_k[i])
        ));
        colours.push(style::part(i));
        radii.push(30.0);
    }
    ids.push("coolant".into());
    positions.push((0.0, 0.0));
    labels.push("coolant".into());
    colours.push([120, 170, 230]);
    radii.push(30.0);
    // Each pair once, and each part with the coolant (i = j).
    let pairs = (0..n).flat_map(|i| (i..n).map(move |j| (i, j)));
    for (i, j) in pairs {
        let g = network.conductance_w_per_k[i][j];
        if g == 0.0 {
            continue;
        }
        let (to, at) = if i == j {
            (
                "coolant".to_owned(),
                (positions[i].0 / 2.0, positions[i].1 / 2.0),
            )
        } else {
            (format!("part{j}"), between(i, j, n))
        };
        let q = flows[i][j];
        let id = format!("G{i}{j}");
        let share = if largest > 0.0 {
            (q.abs() / largest) as f32
        } else {
            0.0
        };
        ids.push(id.clone());
        positions.push(at);
        labels.push(format!("R = {}K/W\nq = {}W", eng(1.0 / g), eng(q.abs())));
        colours.push(if g < 0.0 {
            [200, 0, 200] // not passive
        } else {
            [255, (200.0 * (1.0 - share)) as u8, 0]
        });
        radii.push(6.0 + 20.0 * share);
        let from = format!("part{i}");
        if q >= 0.0 {
            edges.push((from, id.clone()));
            edges.push((id, to));
        } else {
            edges.push((to, id.clone()));
            edges.push((id, from));
        }
    }
    let nodes = GraphNodes::new(ids)
        .with_positions(positions)
        .with_labels(labels)
        .with_colors(colours)
        .with_radii(radii)
        .with_show_labels(true);
    let edges = GraphEdges::new(edges).with_directed_edges();
    (nodes, edges)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn no_conductance_of_four_parts_stands_on_the_coolant_or_another() {
        // Four parts: the chords 0–2 and 1–3 cross at the coolant (the centre).
        let mut at = vec![(0.0_f32, 0.0_f32)];
        for i in 0..4 {
            at.push((
                on_circle(i, 4, RADIUS).0 / 2.0,
                on_circle(i, 4, RADIUS).1 / 2.0,
            ));
            for j in i + 1..4 {
                at.push(between(i, j, 4));
            }
        }
        for (k, p) in at.iter().enumerate() {
            for q in &at[k + 1..] {
                let d = (p.0 - q.0).hypot(p.1 - q.1);
                assert!(d > RADIUS / 4.0, "{p:?} and {q:?} are {d} apart");
            }
        }
        // Neighbours keep the halfway point.
        let (a, b) = (on_circle(0, 4, RADIUS), on_circle(1, 4, RADIUS));
        assert_eq!(between(0, 1, 4), ((a.0 + b.0) / 2.0, (a.1 + b.1) / 2.0));
    }

    #[test]
    fn engineering_notation_picks_the_prefix() {
        assert_eq!(eng(12_300.0), "12.300 k");
        assert_eq!(eng(2.5e6), "2.500 M");
        assert_eq!(eng(0.0042), "4.200 m");
        assert_eq!(eng(3.0e-5), "30.000 µ");
    }
}
