//! Same-design units side by side (`heatrun fleet compare`): every unit's time constants,
//! steady-state rises (at the run's final load and at the nameplate's rating), network (capacitances, conductances, loss shares) and fit, each
//! held against the rest of the fleet, and the units that differ named.
//!
//! A unit differs in a quantity when its value lies beyond both the fleet's spread and
//! its own uncertainty. For unit i and quantity q, over the *other* units j ≠ i that have
//! the quantity (leave-one-out, so that a fouled unit cannot widen its own yardstick):
//!
//! ```text
//! c_i = median_j x_j                                   (the fleet's centre)
//! s_i = max(1.4826 · median_j |x_j − c_i|, f · S_q)    (the fleet's spread: the MAD, as a σ)
//! z_i = |x_i − c_i| / √(s_i² + σ_i²)                   (the score)
//! ```
//!
//! σ_i is the unit's own standard error (its report's 95 % interval / 1.96, where the
//! report has one: time constants and steady-state rises). S_q is the quantity's scale
//! (the fleet's median of |x|; for a conductance G_ij the smaller of its two nodes' total
//! conductances, since a conductance matters against what else drains its node; for a
//! loss share the whole source, 1) and f the floor ([`CompareOptions::floor`], 1 %): a
//! MAD of eight values is itself uncertain, and a chance cluster of near-equal values
//! would otherwise make a tiny yardstick. A unit is an outlier in q when z_i > the
//! threshold ([`CompareOptions::threshold`], 8). With the floor at 1 % and the threshold
//! at 8, nine healthy units of a ±3 % spread (σ ≈ 1.7 %) in 30 independent quantities
//! (a three-node report's count) raise a false alarm anywhere in the fleet in 2 fleets of
//! 2,000 (0.1 %; the test `family_wise_false_alarms_of_a_healthy_fleet` measures it and
//! fails above 1 %); correlated quantities, as a report's are, only lower it.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::model_file::{Report, ThermalModel, UseError};
use crate::rating;
use crate::thermal::Z95;

/// 1.4826: the MAD of a normal distribution times this is its σ.
pub const MAD_TO_SIGMA: f64 = 1.4826;

/// The fewest other units a score is made against (a median and a MAD of fewer say
/// little about a fleet).
pub const MIN_OTHERS: usize = 3;

/// Why a fleet cannot be compared.
#[derive(Debug, thiserror::Error)]
pub enum CompareError {
    /// A report could not be read (the message names the file and the key).
    #[error(transparent)]
    Report(#[from] UseError),
    /// A report's extended blocks (steady state, uncertainty, network, fit) are not as a
    /// replay writes them.
    #[error("{path}: {message}")]
    Block {
        /// The report.
        path: PathBuf,
        /// serde's message (it names the key and line).
        message: String,
    },
    /// Too few reports for a fleet.
    #[error("{given} report(s) given; a fleet comparison needs at least {needed}")]
    TooFew {
        /// How many were given.
        given: usize,
        /// How many it needs.
        needed: usize,
    },
    /// A report is of another design (other states, inputs or orders).
    #[error("{path}: {what} {found}, where {first} has {expected}: not a unit of the same design")]
    Design {
        /// The report that differs.
        path: PathBuf,
        /// What differs ("states", "inputs", "time constants").
        what: &'static str,
        /// What it has.
        found: String,
        /// The first report, the design's yardstick.
        first: String,
        /// What the first report has.
        expected: String,
    },
}

/// How the fleet is judged.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct CompareOptions {
    /// A unit is an outlier in a quantity whose score exceeds this.
    pub threshold: f64,
    /// The spread's floor, as a fraction of the quantity's scale S_q.
    pub floor: f64,
}

impl Default for CompareOptions {
    /// Threshold 8 and floor 1 % (see the module's documentation for the false-alarm rate
    /// they give).
    fn default() -> Self {
        CompareOptions {
            threshold: 8.0,
            floor: 0.01,
        }
    }
}

/// One quantity of one unit, as read from its report.
#[derive(Debug, Clone, PartialEq)]
pub struct Measured {
    /// The quantity's key (e.g. `time_constant_1_s`,
    /// `conductance_w_per_k.cooling_water_outlet_temp.coolant`).
    pub quantity: String,
    /// Its value, in the unit its key names.
    pub value: f64,
    /// The unit's own standard error of it, where its report gives one.
    pub standard_error: Option<f64>,
    /// Its scale (S_q before the fleet's median): |value|, a node's total conductance, or 1.
    pub scale: f64,
}

/// One unit of the fleet: its label (the report's path as given) and its quantities.
#[derive(Debug, Clone)]
pub struct Unit {
    /// The report's path exactly as given.
    pub label: String,
    /// State names, in model order (the design's check).
    pub states: Vec<String>,
    /// Input names, in model order.
    pub inputs: Vec<String>,
    /// Its quantities.
    pub quantities: Vec<Measured>,
}

/// One unit's entry for one quantity.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Scored {
    /// The unit's value (absent where its report lacks the quantity).
    pub value: Option<f64>,
    /// The unit's standard error σ_i, where its report gives one.
    pub standard_error: Option<f64>,
    /// The fleet's centre c_i without the unit.
    pub centre: Option<f64>,
    /// The fleet's spread s_i without the unit.
    pub spread: Option<f64>,
    /// z_i = |x_i − c_i| / √(s_i² + σ_i²).
    pub score: Option<f64>,
    /// z_i > the threshold.
    pub outlier: bool,
}

/// One quantity across the fleet: a row of the table.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct QuantityRow {
    /// The quantity's key.
    pub quantity: String,
    /// Per unit, in the order the reports were given.
    pub units: Vec<Scored>,
}

/// A unit beyond the fleet in one quantity.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Outlier {
    /// The report's path exactly as given.
    pub report: String,
    /// The quantity's key.
    pub quantity: String,
    /// The unit's value.
    pub value: f64,
    /// The fleet's centre without the unit.
    pub centre: f64,
    /// The fleet's spread without the unit.
    pub spread: f64,
    /// The unit's standard error, where its report gives one.
    pub standard_error: Option<f64>,
    /// The score.
    pub score: f64,
}

/// The comparison of a fleet: the table and the outliers.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FleetComparison {
    /// The reports, as given: the table's columns.
    pub reports: Vec<String>,
    /// The options the fleet was judged by.
    pub options: CompareOptions,
    /// How the score is made, for people reading the JSON.
    pub method: &'static str,
    /// Every quantity, each unit scored.
    pub table: Vec<QuantityRow>,
    /// Every unit beyond the threshold in a quantity, by report then score (largest first).
    pub outliers: Vec<Outlier>,
}

/// The score's definition, as written into the JSON.
pub const METHOD: &str = "leave-one-out: centre = median of the other units, spread = \
max(1.4826 * MAD of the other units, floor * scale), score = |value - centre| / \
sqrt(spread^2 + standard_error^2); an outlier where score > threshold";

/// The blocks a comparison reads beyond what [`Report`] reads back (a replay's account,
/// which [`Report`] skips): each optional, so that a report without one still compares
/// on the rest. A figure JSON could not hold is null, hence `Option<f64>`.
#[derive(Debug, Default, Deserialize)]
struct Extended {
    #[serde(default)]
    steady_state: Option<SteadyBlock>,
    #[serde(default)]
    uncertainty: Option<UncertaintyBlock>,
    #[serde(default)]
    network: Option<NetworkBlock>,
    #[serde(default)]
    fit: Option<FitBlock>,
}

#[derive(Debug, Default, Deserialize)]
struct SteadyBlock {
    #[serde(default)]
    rise_k: Vec<Option<f64>>,
}

#[derive(Debug, Default, Deserialize)]
struct UncertaintyBlock {
    #[serde(default)]
    time_constants_ci95_s: Vec<Option<f64>>,
    #[serde(default)]
    steady_state_ci95_k: Vec<Option<f64>>,
}

/// The network block; a model without one (`{"not_defined": …}`) leaves it empty.
#[derive(Debug, Default, Deserialize)]
struct NetworkBlock {
    #[serde(default)]
    capacitance_j_per_k: Vec<Option<f64>>,
    #[serde(default)]
    conductance_w_per_k: Vec<Vec<Option<f64>>>,
    #[serde(default)]
    loss_distribution: Vec<Vec<Option<f64>>>,
}

#[derive(Debug, Default, Deserialize)]
struct FitBlock {
    #[serde(default)]
    nrmse_fit_percent: Vec<Option<f64>>,
}

/// Reads one unit's report; `label` is its path as given (what the outputs name it by).
pub fn read_unit(path: &Path, label: &str) -> Result<Unit, CompareError> {
    let text = Report::read_text(path)?;
    unit_from_json(&text, path, label)
}

/// One unit from its report's text (a report gathered from a cluster's worker rather
/// than read from a file); `path` names the report in messages, `label` is what the
/// outputs name the unit by.
pub fn unit_from_json(text: &str, path: &Path, label: &str) -> Result<Unit, CompareError> {
    let report = Report::from_json(text, path)?;
    let extended: Extended = serde_json::from_str(text).map_err(|e| CompareError::Block {
        path: path.to_owned(),
        message: e.to_string(),
    })?;
    let mut unit = unit_of(label, &report, &extended);
    // A model the rating cannot load (no nameplate, a spec model's own inputs) compares
    // on the rest.
    let rated = ThermalModel::from_report(&report, path)
        .and_then(|model| rating::rises_at_rated(&model))
        .ok();
    if let Some(rated) = rated {
        rated_rises(&mut unit.quantities, &report.states, &rated, &extended);
    }
    Ok(unit)
}

/// The steady-state rises at the nameplate's rating, `rated_rise_k.<state>`, each with
/// the report's own relative uncertainty of its steady state: σ_rated = σ_ss ·
/// rated / rise_ss (exact where the rated load scales the final load's inputs
/// together, since the steady state is linear in them).
fn rated_rises(out: &mut Vec<Measured>, states: &[String], rated: &[f64], extended: &Extended) {
    let at = |v: Option<&Vec<Option<f64>>>, i: usize| v.and_then(|v| v.get(i).copied().flatten());
    let steady = extended.steady_state.as_ref().map(|s| &s.rise_k);
    let ci = extended
        .uncertainty
        .as_ref()
        .map(|u| &u.steady_state_ci95_k);
    for (i, (state, &rise)) in states.iter().zip(rated).enumerate() {
        let sigma = match (at(ci, i), at(steady, i)) {
            (Some(ci), Some(ss)) if ss.abs() > 0.0 => Some(ci / Z95 * (rise / ss).abs()),
            _ => None,
        };
        push(
            out,
            format!("rated_rise_k.{state}"),
            Some(rise),
            sigma.filter(|s| s.is_finite()),
            None,
        );
    }
}

/// A unit's quantities from its report: time constants, steady-state rises, network, fit.
fn unit_of(label: &str, report: &Report, extended: &Extended) -> Unit {
    let se = |ci: Option<&Vec<Option<f64>>>, i: usize| {
        ci.and_then(|v| v.get(i).copied().flatten())
            .filter(|c| c.is_finite())
            .map(|c| c / Z95)
    };
    let mut quantities = Vec::new();
    let unc = extended.uncertainty.as_ref();
    for (i, &t) in report.time_constants_s.iter().enumerate() {
        let sigma = se(unc.map(|u| &u.time_constants_ci95_s), i);
        push(
            &mut quantities,
            format!("time_constant_{}_s", i + 1),
            Some(t),
            sigma,
            None,
        );
    }
    if let Some(steady) = &extended.steady_state {
        for (i, (state, &rise)) in report.states.iter().zip(&steady.rise_k).enumerate() {
            let sigma = se(unc.map(|u| &u.steady_state_ci95_k), i);
            push(
                &mut quantities,
                format!("steady_state_rise_k.{state}"),
                rise,
                sigma,
                None,
            );
        }
    }
    if let Some(network) = &extended.network {
        network_quantities(&mut quantities, report, network);
    }
    if let Some(fit) = &extended.fit {
        for (state, &f) in report.states.iter().zip(&fit.nrmse_fit_percent) {
            push(
                &mut quantities,
                format!("fit_percent.{state}"),
                f,
                None,
                None,
            );
        }
    }
    Unit {
        label: label.to_owned(),
        states: report.states.clone(),
        inputs: report.inputs.clone(),
        quantities,
    }
}

/// Appends a quantity where its value is a finite number; `scale` defaults to |value|.
fn push(
    out: &mut Vec<Measured>,
    quantity: String,
    value: Option<f64>,
    standard_error: Option<f64>,
    scale: Option<f64>,
) {
    if let Some(value) = value.filter(|v| v.is_finite()) {
        out.push(Measured {
            quantity,
            value,
            standard_error,
            scale: scale.unwrap_or(value.abs()),
        });
    }
}

/// The network's capacitances C_i, conductances G_ij (i < j) and G_i0 to the coolant
/// (the diagonal), and loss shares k_ij. A conductance's scale is the smaller total
/// conductance L_ii = Σ_j G_ij of its two nodes; a loss share's is 1, the whole source.
fn network_quantities(out: &mut Vec<Measured>, report: &Report, network: &NetworkBlock) {
    let states = &report.states;
    let g = &network.conductance_w_per_k;
    let at = |i: usize, j: usize| g.get(i).and_then(|r| r.get(j).copied().flatten());
    let total =
        |i: usize| -> Option<f64> { (0..states.len()).map(|j| at(i, j).map(f64::abs)).sum() };
    for (state, &c) in states.iter().zip(&network.capacitance_j_per_k) {
        push(out, format!("capacitance_j_per_k.{state}"), c, None, None);
    }
    for i in 0..states.len() {
        for j in i..states.len() {
            let other = if i == j {
                "coolant"
            } else {
                states[j].as_str()
            };
            let scale = match (total(i), total(j)) {
                (Some(a), Some(b)) => Some(a.min(b)),
                _ => None,
            };
            let key = format!("conductance_w_per_k.{}.{other}", states[i]);
            push(out, key, at(i, j), None, scale);
        }
    }
    for (state, row) in states.iter().zip(&network.loss_distribution) {
        for (input, &k) in report.inputs.iter().zip(row) {
            push(
                out,
                format!("loss_share.{input}.{state}"),
                k,
                None,
                Some(1.0),
            );
        }
    }
}

/// The median of `values` (not empty), the mean of the middle two for an even count.
fn median(values: &[f64]) -> f64 {
    let mut v = values.to_vec();
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// The fleet's centre and spread without the unit: c = median(others),
/// s = max(1.4826 · median|others − c|, `floor_abs`); `None` with fewer than
/// [`MIN_OTHERS`] others.
pub fn centre_and_spread(others: &[f64], floor_abs: f64) -> Option<(f64, f64)> {
    if others.len() < MIN_OTHERS {
        return None;
    }
    let centre = median(others);
    let deviations: Vec<f64> = others.iter().map(|x| (x - centre).abs()).collect();
    Some((centre, (MAD_TO_SIGMA * median(&deviations)).max(floor_abs)))
}

/// z = |x − c| / √(s² + σ²): how far the unit lies from the fleet, in the fleet's spread
/// and its own standard error combined. A zero yardstick (s = σ = 0, a fleet of
/// identical values and a floor of 0) scores an equal value 0 and any other as infinite.
pub fn score(value: f64, centre: f64, spread: f64, standard_error: Option<f64>) -> f64 {
    let sigma = standard_error.unwrap_or(0.0);
    let yardstick = (spread * spread + sigma * sigma).sqrt();
    let distance = (value - centre).abs();
    if yardstick > 0.0 {
        distance / yardstick
    } else if distance == 0.0 {
        0.0
    } else {
        f64::INFINITY
    }
}

/// Checks that every unit is of the first one's design: the same states and inputs, in
/// the same order, and as many time constants.
fn check_design(units: &[Unit]) -> Result<(), CompareError> {
    let Some(first) = units.first() else {
        return Ok(());
    };
    let order = |u: &Unit| {
        u.quantities
            .iter()
            .filter(|q| q.quantity.starts_with("time_constant_"))
            .count()
    };
    for unit in &units[1..] {
        let differ = |what, found: String, expected: String| CompareError::Design {
            path: PathBuf::from(&unit.label),
            what,
            found,
            first: first.label.clone(),
            expected,
        };
        if unit.states != first.states {
            return Err(differ(
                "states",
                unit.states.join(", "),
                first.states.join(", "),
            ));
        }
        if unit.inputs != first.inputs {
            return Err(differ(
                "inputs",
                unit.inputs.join(", "),
                first.inputs.join(", "),
            ));
        }
        if order(unit) != order(first) {
            let n = |u| format!("{} time constants", order(u));
            return Err(differ("the model has", n(unit), n(first)));
        }
    }
    Ok(())
}

/// Compares the fleet: every quantity any unit has, each unit scored against the others.
pub fn compare(units: &[Unit], options: &CompareOptions) -> Result<FleetComparison, CompareError> {
    let needed = MIN_OTHERS + 1;
    if units.len() < needed {
        return Err(CompareError::TooFew {
            given: units.len(),
            needed,
        });
    }
    check_design(units)?;
    let mut keys: Vec<&str> = Vec::new();
    for q in units.iter().flat_map(|u| &u.quantities) {
        if !keys.contains(&q.quantity.as_str()) {
            keys.push(&q.quantity);
        }
    }
    let table: Vec<QuantityRow> = keys.iter().map(|k| row(units, k, options)).collect();
    let mut outliers: Vec<Outlier> = Vec::new();
    for (i, unit) in units.iter().enumerate() {
        let mut own: Vec<Outlier> = table
            .iter()
            .filter_map(|row| outlier_of(&unit.label, row, i))
            .collect();
        own.sort_by(|a, b| b.score.total_cmp(&a.score));
        outliers.extend(own);
    }
    Ok(FleetComparison {
        reports: units.iter().map(|u| u.label.clone()).collect(),
        options: *options,
        method: METHOD,
        table,
        outliers,
    })
}

/// One quantity's row: each unit against the others that have it.
fn row(units: &[Unit], key: &str, options: &CompareOptions) -> QuantityRow {
    let found: Vec<Option<&Measured>> = units
        .iter()
        .map(|u| u.quantities.iter().find(|q| q.quantity == key))
        .collect();
    let scales: Vec<f64> = found.iter().flatten().map(|m| m.scale).collect();
    let floor_abs = options.floor * median(&scales);
    let scored = (0..units.len())
        .map(|i| {
            let Some(m) = found[i] else {
                return Scored {
                    value: None,
                    standard_error: None,
                    centre: None,
                    spread: None,
                    score: None,
                    outlier: false,
                };
            };
            let others: Vec<f64> = (0..units.len())
                .filter(|&j| j != i)
                .filter_map(|j| found[j].map(|o| o.value))
                .collect();
            let judged = centre_and_spread(&others, floor_abs);
            let z = judged.map(|(c, s)| score(m.value, c, s, m.standard_error));
            Scored {
                value: Some(m.value),
                standard_error: m.standard_error,
                centre: judged.map(|j| j.0),
                spread: judged.map(|j| j.1),
                score: z,
                outlier: z.is_some_and(|z| z > options.threshold),
            }
        })
        .collect();
    QuantityRow {
        quantity: key.to_owned(),
        units: scored,
    }
}

/// Unit `i`'s outlier entry in `row`, where it is one.
fn outlier_of(label: &str, row: &QuantityRow, i: usize) -> Option<Outlier> {
    let s = &row.units[i];
    if !s.outlier {
        return None;
    }
    Some(Outlier {
        report: label.to_owned(),
        quantity: row.quantity.clone(),
        value: s.value?,
        centre: s.centre?,
        spread: s.spread?,
        standard_error: s.standard_error,
        score: s.score?,
    })
}

impl FleetComparison {
    /// The text summary: a table of quantities (rows) × units (columns, U1… in the order
    /// given, named under the table) with outliers marked `*`, then one line per unit
    /// that differs, naming it and why.
    pub fn summary(&self) -> String {
        let mut out = String::new();
        let width = self
            .table
            .iter()
            .map(|r| r.quantity.len())
            .max()
            .unwrap_or(8);
        out.push_str(&format!("{:width$}", "quantity"));
        for i in 0..self.reports.len() {
            out.push_str(&format!(" {:>11}", format!("U{}", i + 1)));
        }
        out.push('\n');
        for row in &self.table {
            out.push_str(&format!("{:width$}", row.quantity));
            for s in &row.units {
                let cell = s.value.map_or("-".to_owned(), |v| {
                    format!("{}{}", significant(v), if s.outlier { "*" } else { " " })
                });
                out.push_str(&format!(" {cell:>11}"));
            }
            out.push('\n');
        }
        for (i, report) in self.reports.iter().enumerate() {
            out.push_str(&format!("U{} = {report}\n", i + 1));
        }
        out.push_str(&format!(
            "* beyond the fleet: score |value − centre| / √(spread² + σ²) > {} (leave-one-out median and MAD)\n",
            self.options.threshold
        ));
        out.push_str(&self.verdicts());
        out
    }

    /// One line per unit with outliers (its quantities, largest score first), or one
    /// line saying there are none.
    fn verdicts(&self) -> String {
        if self.outliers.is_empty() {
            return format!(
                "no unit differs from the fleet beyond its spread and its own uncertainty ({} units, threshold {})\n",
                self.reports.len(),
                self.options.threshold
            );
        }
        let mut out = String::new();
        for report in &self.reports {
            let own: Vec<&Outlier> = self
                .outliers
                .iter()
                .filter(|o| &o.report == report)
                .collect();
            if own.is_empty() {
                continue;
            }
            let why: Vec<String> = own
                .iter()
                .map(|o| {
                    format!(
                        "{} {} against {} ± {} (score {:.1})",
                        o.quantity,
                        significant(o.value),
                        significant(o.centre),
                        significant(o.spread),
                        o.score
                    )
                })
                .collect();
            out.push_str(&format!(
                "{report} differs from the fleet in {} quantities: {}\n",
                own.len(),
                why.join("; ")
            ));
        }
        out
    }
}

/// Four significant figures, in exponent form outside 0.001…100 000.
fn significant(v: f64) -> String {
    let a = v.abs();
    if a != 0.0 && !(1e-3..1e5).contains(&a) {
        format!("{v:.3e}")
    } else {
        let decimals = if a == 0.0 {
            0
        } else {
            (3 - a.log10().floor() as i64).max(0) as usize
        };
        format!("{v:.decimals$}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};

    /// A unit with one quantity `x` (scale |value|).
    fn unit(label: &str, value: f64, standard_error: Option<f64>) -> Unit {
        Unit {
            label: label.into(),
            states: vec!["stator_winding_temp".into()],
            inputs: vec!["armature_copper_loss".into()],
            quantities: vec![Measured {
                quantity: "x".into(),
                value,
                standard_error,
                scale: value.abs(),
            }],
        }
    }

    fn fleet(values: &[(f64, Option<f64>)]) -> Vec<Unit> {
        values
            .iter()
            .enumerate()
            .map(|(i, &(v, s))| unit(&format!("u{i}.json"), v, s))
            .collect()
    }

    const NO_FLOOR: CompareOptions = CompareOptions {
        threshold: 8.0,
        floor: 0.0,
    };

    #[test]
    fn centre_spread_and_score_by_hand() {
        // Deviations from the median 3 are 2, 1, 0, 1, 97: their median is 1.
        let (c, s) = centre_and_spread(&[1.0, 2.0, 3.0, 4.0, 100.0], 0.0).unwrap();
        assert_eq!(c, 3.0);
        assert!((s - 1.4826).abs() < 1e-12);
        assert!((score(10.0, c, s, None) - 7.0 / 1.4826).abs() < 1e-12);
        // √(3² + 4²) = 5.
        assert!((score(13.0, 10.0, 3.0, Some(4.0)) - 0.6).abs() < 1e-12);
        // The floor holds the spread up; too few others give nothing.
        assert_eq!(centre_and_spread(&[1.0, 1.0, 1.0], 0.01), Some((1.0, 0.01)));
        assert_eq!(centre_and_spread(&[1.0, 1.0], 0.01), None);
        assert_eq!(score(1.0, 1.0, 0.0, None), 0.0);
        assert_eq!(score(2.0, 1.0, 0.0, None), f64::INFINITY);
    }

    #[test]
    fn the_unit_apart_is_named_and_no_other() {
        let units = fleet(&[
            (10.0, None),
            (10.1, None),
            (9.9, None),
            (10.05, None),
            (20.0, None),
        ]);
        let c = compare(&units, &NO_FLOOR).unwrap();
        assert_eq!(c.outliers.len(), 1);
        let o = &c.outliers[0];
        assert_eq!((o.report.as_str(), o.quantity.as_str()), ("u4.json", "x"));
        // Others 10, 10.1, 9.9, 10.05: median 10.025, deviations' median 0.05.
        assert!((o.centre - 10.025).abs() < 1e-12);
        assert!((o.spread - 0.05 * 1.4826).abs() < 1e-12);
        assert!((o.score - 9.975 / (0.05 * 1.4826)).abs() < 1e-9);
        // u0 against 10.1, 9.9, 10.05, 20: median 10.075, deviations' median 0.1.
        let u0 = &c.table[0].units[0];
        assert!((u0.score.unwrap() - 0.075 / 0.14826).abs() < 1e-9);
        assert!(!u0.outlier);
    }

    #[test]
    fn a_difference_within_the_units_own_uncertainty_is_none() {
        // The same fleet, the far unit's own standard error 5: z = 9.975 / √(0.0741² + 25).
        let units = fleet(&[
            (10.0, None),
            (10.1, None),
            (9.9, None),
            (10.05, None),
            (20.0, Some(5.0)),
        ]);
        let c = compare(&units, &NO_FLOOR).unwrap();
        assert!(c.outliers.is_empty(), "{:?}", c.outliers);
        let z = c.table[0].units[4].score.unwrap();
        assert!((z - 9.975 / (0.0741_3_f64.powi(2) + 25.0).sqrt()).abs() < 1e-3);
    }

    #[test]
    fn the_floor_keeps_identical_units_from_a_zero_yardstick() {
        // Four identical others: MAD 0; the floor 1 % of the scale (1) makes s = 0.01.
        let units = fleet(&[
            (1.0, None),
            (1.0, None),
            (1.0, None),
            (1.0, None),
            (1.005, None),
        ]);
        let c = compare(&units, &CompareOptions::default()).unwrap();
        assert!(c.outliers.is_empty());
        assert!((c.table[0].units[4].score.unwrap() - 0.5).abs() < 1e-6);
    }

    #[test]
    fn too_few_units_and_another_design_are_refused() {
        let three = fleet(&[(1.0, None), (1.0, None), (1.0, None)]);
        assert!(matches!(
            compare(&three, &NO_FLOOR),
            Err(CompareError::TooFew {
                given: 3,
                needed: 4
            })
        ));
        let mut four = fleet(&[(1.0, None), (1.0, None), (1.0, None), (1.0, None)]);
        four[2].states = vec!["core_temp".into()];
        let err = compare(&four, &NO_FLOOR).unwrap_err().to_string();
        assert!(err.starts_with("u2.json: states core_temp"), "{err}");
    }

    /// The stated false-alarm rate: fleets of nine healthy units, each of 30 independent
    /// quantities drawn about 1 with σ = 3 %/√3 (a uniform ±3 % spread's), judged with
    /// the default options; the share of fleets with any alarm is the family-wise rate.
    #[test]
    fn family_wise_false_alarms_of_a_healthy_fleet() {
        let mut rng = rand::rngs::StdRng::seed_from_u64(24);
        let spread = Normal::new(1.0, 0.03 / 3f64.sqrt()).unwrap();
        let fleets = 2000;
        let mut alarmed = 0;
        for _ in 0..fleets {
            let units: Vec<Unit> = (0..9)
                .map(|i| Unit {
                    label: format!("u{i}"),
                    states: Vec::new(),
                    inputs: Vec::new(),
                    quantities: (0..30)
                        .map(|q| {
                            let value = spread.sample(&mut rng);
                            Measured {
                                quantity: format!("q{q}"),
                                value,
                                standard_error: None,
                                scale: value,
                            }
                        })
                        .collect(),
                })
                .collect();
            let c = compare(&units, &CompareOptions::default()).unwrap();
            alarmed += usize::from(!c.outliers.is_empty());
        }
        let rate = alarmed as f64 / fleets as f64;
        println!("family-wise false-alarm rate: {rate:.4} ({alarmed} of {fleets} fleets)");
        assert!(rate < 0.01, "{rate}");
    }

    #[test]
    fn significant_figures() {
        assert_eq!(significant(71.998), "72.00");
        assert_eq!(significant(2.4652e7), "2.465e7");
        assert_eq!(significant(0.0745), "0.07450");
    }
}
