//! The thermal network diagram (the paper's Fig. 9) as an SVG drawing: one node per part,
//! its capacitance C_i and its resistance R_i0 = 1/G_i0 to the coolant rail, and the
//! resistances R_ij = 1/G_ij between parts (neighbours side by side, the others as arcs
//! above). A negative conductance (a model that is no passive network there) is drawn
//! dashed in red; a zero one (no heat path) as an open circuit, its leads dotted in grey.

use std::fmt::Write as _;

use super::markup::{escape, si};
use crate::network::Network;

/// Horizontal distance between nodes, px.
const PITCH: f64 = 250.0;
/// Node box size, px.
const BOX_W: f64 = 160.0;
const BOX_H: f64 = 40.0;
/// Length of the branches from a node down to the coolant rail, px.
const BRANCH: f64 = 130.0;
/// Height of the lowest arc above the nodes, and the step between arc levels, px.
const ARC0: f64 = 46.0;
const ARC_STEP: f64 = 40.0;

/// A part's short name: up to its first parenthesis ("stator winding (copper)" →
/// "stator winding").
pub fn short_name(part: &str) -> &str {
    part.split(" (").next().unwrap_or(part)
}

/// The network as an `<svg>` element.
pub fn diagram(network: &Network) -> String {
    let n = network.states.len();
    let levels = n.saturating_sub(2) as f64;
    let top = 30.0
        + if n > 2 {
            ARC0 + ARC_STEP * (levels - 1.0) + 10.0
        } else {
            0.0
        };
    let width = 40.0 + PITCH * n as f64;
    let rail = top + BOX_H + BRANCH;
    let height = rail + 44.0;
    let x = |i: usize| 20.0 + PITCH * (i as f64 + 0.5);
    let g = &network.conductance_w_per_k;
    let mut s = String::new();
    let _ = write!(
        s,
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{width}\" height=\"{height}\" \
         viewBox=\"0 0 {width} {height}\" font-family=\"sans-serif\" font-size=\"13\">\n\
         <rect x=\"0\" y=\"0\" width=\"{width}\" height=\"{height}\" fill=\"#ffffff\"/>\n"
    );
    // The coolant rail.
    let _ = writeln!(
        s,
        "<line x1=\"20\" y1=\"{rail}\" x2=\"{}\" y2=\"{rail}\" stroke=\"#1f5fa8\" stroke-width=\"4\"/>\n\
         <text x=\"{}\" y=\"{}\" text-anchor=\"middle\" fill=\"#1f5fa8\">coolant (rise 0 K): R_i0 = 1/G_i0 to it, C_i against it</text>",
        width - 20.0,
        width / 2.0,
        rail + 26.0
    );
    let pairs = (0..n).flat_map(|i| (i + 1..n).map(move |j| (i, j)));
    for (i, j) in pairs {
        {
            let (gij, rij) = (g[i][j], network.resistance_k_per_w[i][j]);
            if j == i + 1 {
                resistor_horizontal(
                    &mut s,
                    x(i) + BOX_W / 2.0,
                    x(j) - BOX_W / 2.0,
                    top + BOX_H / 2.0,
                    gij,
                    rij,
                );
            } else {
                let h = ARC0 + ARC_STEP * (j - i - 2) as f64;
                arc(&mut s, x(i), x(j), top, h, gij, rij);
            }
        }
    }
    for (i, part) in network.states.iter().enumerate() {
        node(&mut s, x(i), top, part, crate::colour::part(i));
        let bottom = top + BOX_H;
        resistor_vertical(
            &mut s,
            x(i) - 38.0,
            bottom,
            rail,
            g[i][i],
            network.resistance_k_per_w[i][i],
        );
        capacitor(
            &mut s,
            x(i) + 38.0,
            bottom,
            rail,
            network.capacitance_j_per_k[i],
        );
    }
    s.push_str("</svg>");
    s
}

fn stroke(g: f64) -> &'static str {
    if g < 0.0 {
        "stroke=\"#c0392b\" stroke-dasharray=\"6 4\""
    } else if g == 0.0 {
        "stroke=\"#9aa0a6\" stroke-dasharray=\"2 4\""
    } else {
        "stroke=\"#1d1d1f\""
    }
}

/// The resistor's zigzag through `points`; none for G = 0: no heat path, an open
/// circuit between the leads (a conductance rc holds at zero, or one the model has not).
fn body(g: f64, points: String) -> String {
    if g == 0.0 {
        String::new()
    } else {
        format!("<polyline points=\"{points}\"/>")
    }
}

fn resistance_label(g: f64, r: Option<f64>) -> String {
    match r {
        Some(r) if g > 0.0 => format!("R {}", si(r, "K/W")),
        _ if g == 0.0 => "open: G = 0".into(),
        _ => format!("G {} < 0", si(g, "W/K")),
    }
}

/// A part's node, outlined and tinted in the part's colour (as in the figures and the
/// rerun recording's graph of the network).
fn node(s: &mut String, cx: f64, top: f64, part: &str, rgb: crate::colour::Rgb) {
    let hex = |c: crate::colour::Rgb| format!("#{:02X}{:02X}{:02X}", c[0], c[1], c[2]);
    let _ = writeln!(
        s,
        "<g><title>{}</title><rect x=\"{}\" y=\"{top}\" width=\"{BOX_W}\" height=\"{BOX_H}\" rx=\"8\" \
         fill=\"{}\" stroke=\"{}\" stroke-width=\"3\"/>\
         <text x=\"{cx}\" y=\"{}\" text-anchor=\"middle\" font-weight=\"600\">{}</text></g>",
        escape(part),
        cx - BOX_W / 2.0,
        hex(crate::colour::lightened(rgb, 0.88)),
        hex(rgb),
        top + BOX_H / 2.0 + 5.0,
        escape(short_name(part))
    );
}

/// A zigzag of `teeth` between two points along one axis.
fn zigzag(from: (f64, f64), to: (f64, f64), amplitude: f64) -> String {
    let teeth = 6;
    let (dx, dy) = (to.0 - from.0, to.1 - from.1);
    let len = (dx * dx + dy * dy).sqrt().max(1e-9);
    let (nx, ny) = (-dy / len * amplitude, dx / len * amplitude);
    let mut points = format!("{:.1},{:.1}", from.0, from.1);
    for k in 0..teeth {
        let t = (k as f64 + 0.5) / teeth as f64;
        let side = if k % 2 == 0 { 1.0 } else { -1.0 };
        let _ = write!(
            points,
            " {:.1},{:.1}",
            from.0 + dx * t + nx * side,
            from.1 + dy * t + ny * side
        );
    }
    let _ = write!(points, " {:.1},{:.1}", to.0, to.1);
    points
}

fn resistor_horizontal(s: &mut String, x0: f64, x1: f64, y: f64, g: f64, r: Option<f64>) {
    let (a, b) = (x0 + (x1 - x0) * 0.3, x0 + (x1 - x0) * 0.7);
    let _ = writeln!(
        s,
        "<g fill=\"none\" stroke-width=\"2\" {}><line x1=\"{x0}\" y1=\"{y}\" x2=\"{a}\" y2=\"{y}\"/>\
         {}<line x1=\"{b}\" y1=\"{y}\" x2=\"{x1}\" y2=\"{y}\"/></g>\
         <text x=\"{}\" y=\"{}\" text-anchor=\"middle\" font-size=\"12\">{}</text>",
        stroke(g),
        body(g, zigzag((a, y), (b, y), 7.0)),
        (x0 + x1) / 2.0,
        y - 13.0,
        escape(&resistance_label(g, r))
    );
}

fn resistor_vertical(s: &mut String, x: f64, y0: f64, y1: f64, g: f64, r: Option<f64>) {
    let (a, b) = (y0 + (y1 - y0) * 0.3, y0 + (y1 - y0) * 0.7);
    let _ = writeln!(
        s,
        "<g fill=\"none\" stroke-width=\"2\" {}><line x1=\"{x}\" y1=\"{y0}\" x2=\"{x}\" y2=\"{a}\"/>\
         {}<line x1=\"{x}\" y1=\"{b}\" x2=\"{x}\" y2=\"{y1}\"/></g>\
         <text x=\"{}\" y=\"{}\" text-anchor=\"end\" font-size=\"12\">{}</text>",
        stroke(g),
        body(g, zigzag((x, a), (x, b), 7.0)),
        x - 11.0,
        (a + b) / 2.0 + 4.0,
        escape(&resistance_label(g, r))
    );
}

fn capacitor(s: &mut String, x: f64, y0: f64, y1: f64, c: f64) {
    let mid = (y0 + y1) / 2.0;
    let _ = writeln!(
        s,
        "<g stroke=\"#1d1d1f\" stroke-width=\"2\"><line x1=\"{x}\" y1=\"{y0}\" x2=\"{x}\" y2=\"{}\"/>\
         <line x1=\"{}\" y1=\"{}\" x2=\"{}\" y2=\"{}\" stroke-width=\"3\"/>\
         <line x1=\"{}\" y1=\"{}\" x2=\"{}\" y2=\"{}\" stroke-width=\"3\"/>\
         <line x1=\"{x}\" y1=\"{}\" x2=\"{x}\" y2=\"{y1}\"/></g>\
         <text x=\"{}\" y=\"{}\" font-size=\"12\">C {}</text>",
        mid - 5.0,
        x - 14.0,
        mid - 5.0,
        x + 14.0,
        mid - 5.0,
        x - 14.0,
        mid + 5.0,
        x + 14.0,
        mid + 5.0,
        mid + 5.0,
        x + 20.0,
        mid + 4.0,
        escape(&si(c, "J/K"))
    );
}

/// A resistance between non-neighbours: an arc from the top of one node to the other's,
/// `h` above them, with a zigzag at its peak.
fn arc(s: &mut String, xa: f64, xb: f64, top: f64, h: f64, g: f64, r: Option<f64>) {
    let peak = top - h;
    let (a, b) = ((xa + xb) / 2.0 - 30.0, (xa + xb) / 2.0 + 30.0);
    let _ = writeln!(
        s,
        "<g fill=\"none\" stroke-width=\"2\" {}><polyline points=\"{xa},{top} {xa},{peak} {a},{peak}\"/>\
         {}<polyline points=\"{b},{peak} {xb},{peak} {xb},{top}\"/></g>\
         <text x=\"{}\" y=\"{}\" text-anchor=\"start\" font-size=\"12\">{}</text>",
        stroke(g),
        body(g, zigzag((a, peak), (b, peak), 6.0)),
        b + 8.0,
        peak - 6.0,
        escape(&resistance_label(g, r))
    );
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::network::{Labels, Network, Parts, ScaleSource, Scaling};
    use nalgebra::DMatrix;

    fn three_parts() -> Network {
        let parts = Parts {
            capacitance_j_per_k: vec![2.0e6, 9.0e6, 0.5e6],
            conductance_w_per_k: DMatrix::from_row_slice(
                3,
                3,
                &[
                    1000.0, 4000.0, 0.0, 4000.0, 500.0, 2500.0, 0.0, 2500.0, 30_000.0,
                ],
            ),
            loss_distribution: DMatrix::identity(3, 3),
        };
        let labels = Labels {
            states: vec![
                "stator winding (copper)".into(),
                "iron core".into(),
                "cooling water <outlet>".into(),
            ],
            inputs: vec!["a".into(), "b".into(), "c".into()],
        };
        Network::from_parts(
            &parts,
            Scaling::PHYSICAL,
            ScaleSource::EnergyConservation,
            &labels,
        )
        .unwrap()
    }

    #[test]
    fn the_diagram_draws_every_part_capacitance_and_resistance() {
        let svg = diagram(&three_parts());
        assert!(svg.starts_with("<svg") && svg.ends_with("</svg>"));
        // Names shortened on the node, whole (escaped) in its tooltip.
        assert!(svg.contains(">stator winding</text>"));
        assert!(svg.contains("<title>cooling water &lt;outlet&gt;</title>"));
        // Three capacitances, three resistances to the coolant, two between neighbours;
        // the zero conductance between the outer parts is labelled as such.
        assert_eq!(svg.matches(">C ").count(), 3);
        assert!(svg.contains("C 9.00 MJ/K"), "{svg}");
        assert!(svg.contains("R 250 µK/W"), "{svg}");
        assert!(svg.contains("R 1.00 mK/W"), "{svg}");
        // …and drawn open: its arc's two leads, no zigzag between them.
        assert!(svg.contains("open: G = 0"), "{svg}");
        assert_eq!(svg.matches("<polyline").count(), 3 + 2 + 2);
    }
}
