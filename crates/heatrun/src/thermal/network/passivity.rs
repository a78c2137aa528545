//! How far a network fitted to an identified model is from a passive thermal network,
//! in figures and in one plain sentence.

use serde::Serialize;

use super::reciprocity::{CycleResidual, Reciprocity};
use super::Network;

/// Relative asymmetry of C·A_c above which the model is called non-reciprocal.
pub const ASYMMETRY_TOLERANCE: f64 = 0.05;
/// A loss share below −this, or a column sum further than this from 1, is called out.
pub const LOSS_SHARE_TOLERANCE: f64 = 0.05;
/// A negative conductance larger than this fraction of the largest |G| is called out.
pub const CONDUCTANCE_TOLERANCE: f64 = 0.01;

/// Below −this (for conductances: times the largest |G|) a value is negative rather than
/// a rounding error of zero.
const NUMERICAL_ZERO: f64 = 1e-9;

/// One entry of a matrix of the network, named.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Entry {
    /// Row (0-based): the part.
    pub row: usize,
    /// Column (0-based): the other part (the same part: the coolant) or the loss.
    pub column: usize,
    /// E.g. "G(stator winding, iron core)", "G(iron core, coolant)", "k_23".
    pub name: String,
    /// The value (W/K for conductances, a share for k_ij).
    pub value: f64,
}

/// The sum of one loss's shares, Σ_i k_ij.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ColumnSum {
    /// The loss (0-based).
    pub input: usize,
    /// Its name.
    pub name: String,
    /// Σ_i k_ij.
    pub sum: f64,
}

/// The passivity figures of a network fitted to a model.
#[derive(Debug, Clone, PartialEq, Serialize, Default)]
pub struct Passivity {
    /// ‖C·A_c − (C·A_c)ᵀ‖_F / ‖C·A_c‖_F at the fitted C (0 for a reciprocal model).
    pub relative_asymmetry: f64,
    /// The same over the couplings between parts only (off the diagonal):
    /// ‖off(C·A − (C·A)ᵀ)‖_F / ‖off(C·A + (C·A)ᵀ)‖_F, 0 when reciprocal, 1 when each pair
    /// couples one way only.
    pub coupling_asymmetry: f64,
    /// The cycle condition of each triangle of parts (one for three parts).
    pub cycle_residuals: Vec<CycleResidual>,
    /// Pairs of parts (0-based) whose couplings a_ij, a_ji differ in sign.
    pub sign_mismatched_pairs: Vec<[usize; 2]>,
    /// Every G_ij < 0 and G_i0 < 0 (beyond rounding); those beyond
    /// [`CONDUCTANCE_TOLERANCE`] of the largest |G| count against passivity.
    pub negative_conductances: Vec<Entry>,
    /// Every k_ij < 0 (beyond rounding); those below −[`LOSS_SHARE_TOLERANCE`] count
    /// against passivity.
    pub negative_loss_shares: Vec<Entry>,
    /// Every loss whose shares sum further than [`LOSS_SHARE_TOLERANCE`] from 1.
    pub column_sums_off: Vec<ColumnSum>,
    /// Whether the model is a passive network within the tolerances of this module.
    pub is_passive: bool,
    /// One plain sentence: where the model is not a physical network, or that it is.
    pub verdict: String,
}

impl Passivity {
    /// The figures of `network` (its C, G, K) and of the model's reciprocity.
    pub(super) fn assess(network: &Network, reciprocity: Reciprocity) -> Passivity {
        let negative_conductances = negative_conductances(network);
        let negative_loss_shares = negative_loss_shares(network);
        let column_sums_off: Vec<ColumnSum> = network
            .loss_distribution_column_sums
            .iter()
            .enumerate()
            .filter(|(_, s)| (*s - 1.0).abs() > LOSS_SHARE_TOLERANCE)
            .map(|(j, &sum)| ColumnSum {
                input: j,
                name: network.inputs[j].clone(),
                sum,
            })
            .collect();
        let mut passivity = Passivity {
            relative_asymmetry: reciprocity.relative_asymmetry,
            coupling_asymmetry: reciprocity.coupling_asymmetry,
            cycle_residuals: reciprocity.cycle_residuals,
            sign_mismatched_pairs: reciprocity.sign_mismatched_pairs,
            negative_conductances,
            negative_loss_shares,
            column_sums_off,
            is_passive: false,
            verdict: String::new(),
        };
        let clauses = passivity.clauses(network);
        passivity.is_passive = clauses.is_empty();
        passivity.verdict = if clauses.is_empty() {
            format!(
                "The identified model is a passive thermal network: reciprocal within {:.1} %, every conductance and loss share non-negative, and every loss accounted for within {LOSS_SHARE_TOLERANCE}.",
                100.0 * passivity.relative_asymmetry
            )
        } else {
            format!(
                "The identified model is not a passive thermal network: {}.",
                clauses.join("; ")
            )
        };
        passivity
    }

    /// What makes the model non-passive, most striking first, beyond the tolerances.
    fn clauses(&self, network: &Network) -> Vec<String> {
        let mut clauses = Vec::new();
        let shares: Vec<&Entry> = self
            .negative_loss_shares
            .iter()
            .filter(|e| e.value < -LOSS_SHARE_TOLERANCE)
            .collect();
        if !shares.is_empty() {
            clauses.push(loss_share_clause(&shares, network));
        }
        let g_max = max_abs_conductance(network);
        let (to_coolant, between): (Vec<&Entry>, Vec<&Entry>) = self
            .negative_conductances
            .iter()
            .filter(|e| -e.value > CONDUCTANCE_TOLERANCE * g_max)
            .partition(|e| e.row == e.column);
        if !to_coolant.is_empty() {
            clauses.push(format!(
                "{}: {}",
                listed(&to_coolant, |e| format!(
                    "{} = {}",
                    e.name,
                    si(e.value, "W/K")
                )),
                if to_coolant.len() == 1 {
                    "that part would draw heat from the coolant, the more the hotter it gets"
                } else {
                    "those parts would draw heat from the coolant, the more the hotter they get"
                },
            ));
        }
        if !between.is_empty() {
            clauses.push(format!(
                "{}: heat would flow from the colder part to the hotter",
                listed(&between, |e| format!("{} = {}", e.name, si(e.value, "W/K")))
            ));
        }
        if !self.column_sums_off.is_empty() {
            clauses.push(column_sums_clause(&self.column_sums_off));
        }
        if self.relative_asymmetry > ASYMMETRY_TOLERANCE || !self.sign_mismatched_pairs.is_empty() {
            clauses.push(self.asymmetry_clause());
        }
        clauses
    }

    fn asymmetry_clause(&self) -> String {
        let worst = self
            .cycle_residuals
            .iter()
            .filter(|c| c.ratio.is_some_and(|r| r > 0.0))
            .max_by(|a, b| {
                let dev = |c: &CycleResidual| c.ratio.unwrap_or(1.0).ln().abs();
                dev(a).total_cmp(&dev(b))
            });
        let mut s = format!(
            "no capacitances make C·A_c symmetric ({:.0} % of it stays asymmetric, {:.0} % of the couplings between parts",
            100.0 * self.relative_asymmetry,
            100.0 * self.coupling_asymmetry
        );
        if let Some(c) = worst {
            let [i, j, k] = c.parts.map(|p| p + 1);
            s += &format!(
                "; a_{i}{j}·a_{j}{k}·a_{k}{i} is {} times a_{j}{i}·a_{k}{j}·a_{i}{k}, equal in a network",
                number(c.ratio.unwrap_or(1.0), 3)
            );
        }
        s += "), so the parts do not exchange heat through shared resistances";
        s
    }
}

/// "k_13 = −0.26: the iron loss appears to cool the stator winding, which no passive
/// network does", or the list of several.
fn loss_share_clause(shares: &[&Entry], network: &Network) -> String {
    if let [e] = shares {
        format!(
            "{} = {}: the {} appears to cool the {}, which no passive network does",
            e.name,
            number(e.value, 2),
            network.inputs[e.column],
            network.states[e.row]
        )
    } else {
        let each = |e: &&Entry| {
            format!(
                "{} = {} ({} into {})",
                e.name,
                number(e.value, 2),
                network.inputs[e.column],
                network.states[e.row]
            )
        };
        format!(
            "{}: each of those losses appears to cool that part, which no passive network does",
            listed(shares, each)
        )
    }
}

fn column_sums_clause(sums: &[ColumnSum]) -> String {
    if let [c] = sums {
        let tail = if c.sum <= 0.0 {
            "it removes heat from the machine as a whole".to_string()
        } else if c.sum < 1.0 {
            format!(
                "{:.0} % of it enters no modelled part",
                100.0 * (1.0 - c.sum)
            )
        } else {
            format!(
                "the model heats the parts {:.0} % more than the loss",
                100.0 * (c.sum - 1.0)
            )
        };
        format!(
            "the shares of the {} sum to {}: {tail}",
            c.name,
            number(c.sum, 2)
        )
    } else {
        format!(
            "the shares of the losses sum to {} instead of 1: energy is not conserved",
            listed(sums, |c| format!("{} ({})", number(c.sum, 2), c.name))
        )
    }
}

/// "a, b and c".
fn listed<T>(items: &[T], show: impl Fn(&T) -> String) -> String {
    let shown: Vec<String> = items.iter().map(show).collect();
    match shown.split_last() {
        None => String::new(),
        Some((last, [])) => last.clone(),
        Some((last, rest)) => format!("{} and {last}", rest.join(", ")),
    }
}

/// `value` with `decimals` decimals and a typographic minus.
fn number(value: f64, decimals: usize) -> String {
    format!("{value:.decimals$}").replace('-', "−")
}

fn negative_conductances(network: &Network) -> Vec<Entry> {
    let floor = NUMERICAL_ZERO * max_abs_conductance(network);
    let mut out = Vec::new();
    for (i, row) in network.conductance_w_per_k.iter().enumerate() {
        for (j, &g) in row.iter().enumerate().skip(i) {
            if g < -floor {
                let other = if i == j {
                    "coolant"
                } else {
                    &network.states[j]
                };
                out.push(Entry {
                    row: i,
                    column: j,
                    name: format!("G({}, {other})", network.states[i]),
                    value: g,
                });
            }
        }
    }
    out
}

fn negative_loss_shares(network: &Network) -> Vec<Entry> {
    let mut out = Vec::new();
    for (i, row) in network.loss_distribution.iter().enumerate() {
        for (j, &k) in row.iter().enumerate() {
            if k < -NUMERICAL_ZERO {
                out.push(Entry {
                    row: i,
                    column: j,
                    name: format!("k_{}{}", i + 1, j + 1),
                    value: k,
                });
            }
        }
    }
    out
}

fn max_abs_conductance(network: &Network) -> f64 {
    network
        .conductance_w_per_k
        .iter()
        .flatten()
        .fold(0.0_f64, |m, g| m.max(g.abs()))
}

/// `value` with three significant digits and a k/M/G prefix: "−1.23 kW/K".
pub(super) fn si(value: f64, unit: &str) -> String {
    let a = value.abs();
    let (scale, prefix) = if a >= 1e9 {
        (1e9, "G")
    } else if a >= 1e6 {
        (1e6, "M")
    } else if a >= 1e3 {
        (1e3, "k")
    } else {
        (1.0, "")
    };
    let v = value / scale;
    let decimals = if v.abs() >= 100.0 {
        0
    } else if v.abs() >= 10.0 {
        1
    } else {
        2
    };
    format!("{v:.decimals$} {prefix}{unit}").replace('-', "−")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn si_prefixes_and_digits() {
        assert_eq!(si(-1234.0, "W/K"), "−1.23 kW/K");
        assert_eq!(si(45_600_000.0, "J/K"), "45.6 MJ/K");
        assert_eq!(si(201_616.0, "W/K"), "202 kW/K");
        assert_eq!(si(0.5, "W/K"), "0.50 W/K");
    }

    #[test]
    fn column_sum_clauses_say_which_way() {
        let c = |sum, name: &str| ColumnSum {
            input: 0,
            name: name.into(),
            sum,
        };
        let one = |sum| column_sums_clause(&[c(sum, "iron loss")]);
        assert!(one(0.7).ends_with("sum to 0.70: 30 % of it enters no modelled part"));
        assert!(one(1.2).ends_with("the model heats the parts 20 % more than the loss"));
        assert!(one(-0.1).contains("sum to −0.10: it removes heat"));
        let two = column_sums_clause(&[c(0.5, "a"), c(-0.5, "b")]);
        assert_eq!(
            two,
            "the shares of the losses sum to 0.50 (a) and −0.50 (b) instead of 1: energy is not conserved"
        );
    }

    #[test]
    fn lists_read_as_prose() {
        let show = |s: &&str| s.to_string();
        assert_eq!(listed(&["a"], show), "a");
        assert_eq!(listed(&["a", "b", "c"], show), "a, b and c");
        assert_eq!(listed::<&str>(&[], show), "");
    }
}
