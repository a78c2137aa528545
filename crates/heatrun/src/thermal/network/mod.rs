//! The machine as a passive thermal network (the lumped RC scheme of the paper's Fig. 9),
//! the calorimetric balance of the cooling water (eqs. 17–18) and the equilibrium check.
//!
//! The network is
//!
//! ```text
//! C·dθ/dt = −L·θ + K·P                                   (Fig. 9)
//! L_ij = −G_ij (i ≠ j),   L_ii = G_i0 + Σ_{j≠i} G_ij
//! ```
//!
//! with θ the temperature rises of the parts (K), P the losses (W), C_i > 0 the thermal
//! capacitances (J/K), G_ij = G_ji ≥ 0 the conductances between parts and G_i0 ≥ 0 those
//! to the coolant (W/K), and K the loss-distribution matrix (k_ij, the share of loss j
//! that enters part i; each column sums to 1 when every loss is accounted for). In the
//! model's scaling (x = θ/θ_base, u = P/P_base) it is the continuous model of eq. 9 with
//!
//! ```text
//! A_c = −C⁻¹·L,        B_c = C⁻¹·K·P_base/θ_base.
//! ```
//!
//! [`Network::from_continuous`] goes from an identified (A_c, B_c) to C, G and K and says
//! how far the model is from such a network; [`Network::to_continuous`] goes back. The
//! analyses of a replay that use it (calorimetry, equilibrium, the minimum-distance fit)
//! are the `network` stage's.

mod passivity;
mod reciprocity;
#[cfg(test)]
mod tests;

use nalgebra::DMatrix;
use serde::Serialize;

pub use passivity::{
    ColumnSum, Entry, Passivity, ASYMMETRY_TOLERANCE, CONDUCTANCE_TOLERANCE, LOSS_SHARE_TOLERANCE,
};
pub use reciprocity::CycleResidual;

/// Why a model has no thermal network, or a computation of this module cannot be done.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum NetworkError {
    /// A matrix or label list has the wrong size.
    #[error("{what} is {found_rows}×{found_cols}, expected {expected_rows}×{expected_cols}")]
    Shape {
        /// Which matrix or list.
        what: &'static str,
        /// Rows expected.
        expected_rows: usize,
        /// Columns expected.
        expected_cols: usize,
        /// Rows found.
        found_rows: usize,
        /// Columns found.
        found_cols: usize,
    },
    /// An entry is NaN or infinite.
    #[error("{what}[{row}, {col}] is not a finite number")]
    NonFinite {
        /// Which matrix.
        what: &'static str,
        /// Row (0-based).
        row: usize,
        /// Column (0-based).
        col: usize,
    },
    /// A_c has complex eigenvalues: the response oscillates, which no RC network does
    /// (its A_c = −C⁻¹L is similar to a symmetric matrix, so its eigenvalues are real).
    #[error(
        "A_c has the complex eigenvalues {re:.4e} ± {im:.4e}i /s: an oscillating response, which no thermal network has"
    )]
    ComplexEigenvalues {
        /// Real part (1/s).
        re: f64,
        /// Imaginary part (1/s, positive).
        im: f64,
    },
    /// A_c has an eigenvalue ≥ 0 (not Hurwitz): a temperature that never settles.
    #[error(
        "A_c has the eigenvalue {eigenvalue:.4e} /s ≥ 0: a temperature that grows or never settles, so no network with a path to the coolant"
    )]
    NotStable {
        /// The offending eigenvalue (1/s).
        eigenvalue: f64,
    },
    /// An input heats no part: its column of B_c has no positive entry.
    #[error("the input '{input}' heats no part (its column of B_c has no positive entry): it is not a heat source")]
    NotHeat {
        /// The input's name.
        input: String,
    },
    /// The parts fall into groups with no reciprocal coupling between them, so the
    /// ratio of their capacitances is not determined by the model.
    #[error("the capacitance of '{part}' relative to '{other}' is undetermined: no pair of A_c entries of one sign couples them")]
    Uncoupled {
        /// A part of one group.
        part: String,
        /// A part of another group.
        other: String,
    },
    /// Neither the calorimetric balance nor energy conservation gives a positive scale.
    #[error("no positive scale for the capacitances: {reason}")]
    NoScale {
        /// Why each way failed.
        reason: String,
    },
    /// The scaling or the coolant link is out of range.
    #[error("{0}")]
    BadParameter(String),
    /// A capacitance given to [`Network::from_parts`] is not positive.
    #[error("the capacitance of '{part}' is {value} J/K; a capacitance must be positive")]
    NonPositiveCapacitance {
        /// The part.
        part: String,
        /// The value given.
        value: f64,
    },
    /// Water outside the range of its properties (temperature or pressure).
    #[error(transparent)]
    Water(#[from] crate::thermal::water::WaterError),
}

/// The model's scaling: x = θ/θ_base, u = P/P_base, so B_c = C⁻¹·K·P_base/θ_base.
/// For the generator θ_base = 80 K and P_base = S_n in VA; a model in physical units has 1, 1.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Scaling {
    /// Kelvin per state unit (θ_base).
    pub theta_base_k: f64,
    /// Watts per input unit (P_base).
    pub p_base_w: f64,
}

impl Scaling {
    /// States in K and inputs in W.
    pub const PHYSICAL: Scaling = Scaling {
        theta_base_k: 1.0,
        p_base_w: 1.0,
    };

    /// P_base/θ_base, the factor between K and B_c·C (W/K per input unit).
    fn watts_per_kelvin(&self) -> f64 {
        self.p_base_w / self.theta_base_k
    }

    fn check(&self) -> Result<(), NetworkError> {
        let ok = |v: f64| v.is_finite() && v > 0.0;
        if ok(self.theta_base_k) && ok(self.p_base_w) {
            Ok(())
        } else {
            Err(NetworkError::BadParameter(format!(
                "the scaling θ_base = {} K, P_base = {} W must be positive",
                self.theta_base_k, self.p_base_w
            )))
        }
    }
}

/// The one part whose conductance to the coolant is known: the cooling-water outlet,
/// G_out,0 = c·ρ·Q (eq. 17; see `network::calorimetry::coolant_conductance_w_per_k`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct CoolantLink {
    /// The state (0-based) of the outlet water.
    pub state: usize,
    /// G_out,0 in W/K.
    pub conductance_w_per_k: f64,
}

/// Names of the states (parts) and inputs (losses), in the model's order.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Labels {
    /// One name per state, e.g. "iron core".
    pub states: Vec<String>,
    /// One name per input, e.g. "iron loss".
    pub inputs: Vec<String>,
}

impl Labels {
    /// "part 1" … "part n" and "loss 1" … "loss m".
    pub fn numbered(n: usize, m: usize) -> Labels {
        Labels {
            states: (1..=n).map(|i| format!("part {i}")).collect(),
            inputs: (1..=m).map(|j| format!("loss {j}")).collect(),
        }
    }
}

/// Where the absolute scale of the capacitances comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ScaleSource {
    /// The outlet node's conductance to the coolant equals c·ρ·Q.
    Calorimetric,
    /// Each column of K sums to 1 (least squares over the columns).
    EnergyConservation,
}

/// The other scale, where both were possible.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct AlternativeScale {
    /// Its source.
    pub scale_from: ScaleSource,
    /// The capacitances it gives (J/K).
    pub capacitance_j_per_k: Vec<f64>,
    /// Its scale over the chosen one (1 where they agree; every C, G and k_ij scales by it).
    pub ratio_to_chosen: f64,
}

/// The passive thermal network C·dθ/dt = −L·θ + K·P of an identified model (Fig. 9).
/// Matrices are lists of rows, states and inputs in the model's order.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Network {
    /// The states' names.
    pub states: Vec<String>,
    /// The inputs' names.
    pub inputs: Vec<String>,
    /// The model's scaling.
    pub scaling: Scaling,
    /// C_i in J/K.
    pub capacitance_j_per_k: Vec<f64>,
    /// n × n: G_ij between parts off the diagonal, G_i0 to the coolant on it (W/K).
    pub conductance_w_per_k: Vec<Vec<f64>>,
    /// 1/G in the layout of `conductance_w_per_k`, `None` where G = 0 (K/W).
    pub resistance_k_per_w: Vec<Vec<Option<f64>>>,
    /// n × m: k_ij, the share of loss j that enters part i.
    pub loss_distribution: Vec<Vec<f64>>,
    /// Σ_i k_ij per loss (1 when all of loss j enters the modelled parts).
    pub loss_distribution_column_sums: Vec<f64>,
    /// Where the capacitances' scale comes from.
    pub scale_from: ScaleSource,
    /// Why the calorimetric scale was given but not used, if so.
    pub scale_note: Option<String>,
    /// The other scale, where both were possible.
    pub alternative_scale: Option<AlternativeScale>,
    /// How far the identified model is from this network.
    pub passivity: Passivity,
    /// 95 % intervals of C, G and K, where the network's parameters were estimated
    /// themselves (`--method rc`); absent for a network derived from an identified model.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub intervals_95: Option<NetworkIntervals>,
    /// Which network this is, where it is not the algebraic network of the identified
    /// model: rc's fit to the data from the nearest passive network (a replay's default),
    /// or the "minimum distance to the identified model" and why rc did not apply; the
    /// passivity figures then still describe the identified model itself.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub fitted_from: Option<String>,
    /// The weighted distance of the fitted network to the identified model, and its χ² test.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub minimum_distance: Option<MinimumDistance>,
    /// Where the network was fitted to Θ̂ re-estimated with the first sample's offset: that
    /// offset d per state, K (ŷ = x + d; d is minus the error of the sample the rises are
    /// measured from), in the states' order.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub first_sample_offset_k: Option<Vec<f64>>,
}

/// What the minimum-distance fit found besides the network.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MinimumDistance {
    /// d at the minimum: (θ̂ − θ(p))ᵀ Σ̂⁻¹ (θ̂ − θ(p)).
    pub distance: f64,
    /// n(n+m) − dim p: the χ² degrees of freedom of d where the model is a network.
    pub degrees_of_freedom: usize,
    /// P(χ² ≥ d): small where the identified model is no passive, energy-conserving
    /// network; `None` where the distance is unweighted or has no degrees of freedom.
    pub p_value: Option<f64>,
    /// How Σ̂ was used: regularised, or not at all, and why.
    pub weighting: String,
    /// Steps taken.
    pub iterations: usize,
    /// Whether the fit ended at its minimum (a step no longer lowered d) rather than at
    /// its cap of steps: d from a fit stopped at the cap is only an upper bound, and its
    /// χ² test may reject a network the model is consistent with (the four-node machine's
    /// runs: χ² 1,036 at the cap on one, 7.4 where the fit is run to its end).
    pub converged: bool,
}

/// The fraction of the largest capacitance below which a part of a fitted network has
/// collapsed ([`Network::collapsed_parts`]): its own time constant is then a millionth of
/// the network's, far below any sample time.
pub const COLLAPSED_CAPACITANCE: f64 = 1e-6;

impl MinimumDistance {
    /// What a distance from a fit stopped at its cap is, in words, for the summary, the
    /// decision and the HTML report alike; `None` where the fit reached its minimum.
    pub fn unconverged(&self) -> Option<String> {
        (!self.converged).then(|| {
            format!(
                "its fit stopped at its cap of {} steps short of the minimum: χ² is an upper bound",
                self.iterations
            )
        })
    }
}

/// A 95 % interval of one network parameter, with its standard error (delta method).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Interval {
    /// Lower end.
    pub low: f64,
    /// Upper end.
    pub high: f64,
    /// Standard error (first order).
    pub standard_error: f64,
}

/// 95 % intervals of every C, G and k_ij of a network estimated in its own parameters,
/// laid out as the network's tables; `None` (null) where the fit does not bound the
/// entry (an interval that does not fit in a number).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct NetworkIntervals {
    /// How the intervals were made.
    pub method: String,
    /// Of C_i, J/K.
    pub capacitance_j_per_k: Vec<Option<Interval>>,
    /// Of G_ij (off the diagonal) and G_i0 (on it), W/K.
    pub conductance_w_per_k: Vec<Vec<Option<Interval>>>,
    /// Of k_ij.
    pub loss_distribution: Vec<Vec<Option<Interval>>>,
}

/// C, G and K given directly (e.g. a synthetic machine or a grey-box estimate).
#[derive(Debug, Clone, PartialEq)]
pub struct Parts {
    /// C_i in J/K, all positive.
    pub capacitance_j_per_k: Vec<f64>,
    /// n × n: G_ij off the diagonal (symmetric), G_i0 on it (W/K).
    pub conductance_w_per_k: DMatrix<f64>,
    /// n × m: k_ij.
    pub loss_distribution: DMatrix<f64>,
}

impl Parts {
    /// The network at another absolute scale: every C_i, G_ij and k_ij times `r`, so that
    /// A_c = −C⁻¹·L and B_c = C⁻¹·K·S_n/θ_base stay as they are (the model fixes the
    /// network only up to this factor; a calorimetric or energy balance sets it).
    pub fn scaled(&self, r: f64) -> Parts {
        Parts {
            capacitance_j_per_k: self.capacitance_j_per_k.iter().map(|c| c * r).collect(),
            conductance_w_per_k: &self.conductance_w_per_k * r,
            loss_distribution: &self.loss_distribution * r,
        }
    }
}

/// A network at capacitance ratios r (scale 1): C = diag(r), G from the symmetric part
/// of C·A_c, K = C·B_c·θ_base/P_base. Every quantity is linear in the scale.
struct UnitNetwork {
    capacitance: Vec<f64>,
    conductance: DMatrix<f64>,
    loss_distribution: DMatrix<f64>,
}

impl UnitNetwork {
    /// S = ½(C·A_c + (C·A_c)ᵀ) = −L: G_ij = S_ij (i ≠ j), G_i0 = −Σ_j S_ij (the row sum of L).
    fn at_ratios(a_c: &DMatrix<f64>, b_c: &DMatrix<f64>, ratios: &[f64], scaling: Scaling) -> Self {
        let n = a_c.nrows();
        let c = DMatrix::from_diagonal(&nalgebra::DVector::from_column_slice(ratios));
        let ca = &c * a_c;
        let s = (&ca + ca.transpose()) * 0.5;
        let mut conductance = s.clone();
        for i in 0..n {
            conductance[(i, i)] = -s.row(i).sum();
        }
        let loss_distribution = &c * b_c / scaling.watts_per_kelvin();
        UnitNetwork {
            capacitance: ratios.to_vec(),
            conductance,
            loss_distribution,
        }
    }

    /// Energy conservation: the s minimising Σ_j (s·w_j − 1)², w_j the column sums of K
    /// at scale 1, i.e. s = Σw / Σw². `None` where that is not positive.
    fn energy_scale(&self) -> Option<f64> {
        let w: Vec<f64> = self
            .loss_distribution
            .column_iter()
            .map(|c| c.sum())
            .collect();
        let (sum, sum_sq) = w.iter().fold((0.0, 0.0), |(s, q), x| (s + x, q + x * x));
        (sum > 0.0 && sum_sq > 0.0).then(|| sum / sum_sq)
    }

    /// Calorimetry: s = G_out,0 / G_out,0(scale 1); an error naming why where the model's
    /// outlet node does not lose heat to the coolant.
    fn calorimetric_scale(&self, link: CoolantLink, labels: &Labels) -> Result<f64, String> {
        let g = self.conductance[(link.state, link.state)];
        if g > 0.0 {
            Ok(link.conductance_w_per_k / g)
        } else {
            Err(format!(
                "the model's '{}' does not lose heat to the coolant (it gives that part a {} conductance to it), so c·ρ·Q cannot fix the scale",
                labels.states[link.state],
                if g == 0.0 { "zero" } else { "negative" }
            ))
        }
    }
}

impl Network {
    /// The parts whose capacitance fell below [`COLLAPSED_CAPACITANCE`] of the largest, in
    /// words, for the summary and the HTML report alike; `None` where every part keeps one.
    ///
    /// Why: the passive network nearest a model that is no network can merge parts into
    /// another (the paper's model: the stator winding's and the iron core's capacitances fall
    /// to 0.7 and 0.5 J/K beside the cooling water's 143.7 MJ/K); printed without a word,
    /// it reads as a network of three parts.
    pub fn collapsed_parts(&self) -> Option<String> {
        let largest = self.capacitance_j_per_k.iter().copied().fold(0.0, f64::max);
        let collapsed: Vec<&str> = self
            .states
            .iter()
            .zip(&self.capacitance_j_per_k)
            .filter(|(_, c)| **c < COLLAPSED_CAPACITANCE * largest)
            .map(|(name, _)| name.as_str())
            .collect();
        (!collapsed.is_empty()).then(|| {
            format!(
                "{} {} into the other parts (capacitance below {COLLAPSED_CAPACITANCE:e} of the \
                 largest): no network of these parts lies near the model",
                collapsed.join(" and "),
                if collapsed.len() == 1 {
                    "collapses"
                } else {
                    "collapse"
                },
            )
        })
    }

    /// The network of an identified continuous model (A_c, B_c of eq. 9, in the model's
    /// `scaling`): C·A_c = −L symmetric gives the ratios of C (least squares over all
    /// pairs, in logarithms: ln c_i − ln c_j = ln(a_ji/a_ij)); the scale comes from the
    /// calorimetric balance G_out,0 = c·ρ·Q where `coolant` is given, else from energy
    /// conservation (Σ_i k_ij = 1, least squares over the losses); where both are possible
    /// the other is kept beside. Then G from the symmetric part of C·A_c and
    /// K = C·B_c·θ_base/P_base, and the passivity figures. A model with complex or
    /// non-negative eigenvalues, or an input that heats no part, is an error saying why.
    pub fn from_continuous(
        a_c: &DMatrix<f64>,
        b_c: &DMatrix<f64>,
        scaling: Scaling,
        coolant: Option<CoolantLink>,
        labels: &Labels,
    ) -> Result<Network, NetworkError> {
        check_model(a_c, b_c, scaling, coolant, labels)?;
        let fit = reciprocity::fit_capacitance_ratios(a_c, labels)?;
        let unit = UnitNetwork::at_ratios(a_c, b_c, &fit.ratios, scaling);
        let energy = unit.energy_scale();
        let calorimetric = coolant.map(|link| unit.calorimetric_scale(link, labels));
        let (scale, scale_from, scale_note, alternative) = match (calorimetric, energy) {
            (Some(Ok(cal)), energy) => (
                cal,
                ScaleSource::Calorimetric,
                None,
                energy.map(|e| (e, ScaleSource::EnergyConservation)),
            ),
            (Some(Err(why)), Some(e)) => (e, ScaleSource::EnergyConservation, Some(why), None),
            (None, Some(e)) => (e, ScaleSource::EnergyConservation, None, None),
            (cal, None) => {
                let mut reason =
                    "the losses' columns of C·B_c do not sum to a positive total (energy conservation)"
                        .to_string();
                if let Some(Err(why)) = cal {
                    reason = format!("{why}; and {reason}");
                }
                return Err(NetworkError::NoScale { reason });
            }
        };
        let alternative_scale = alternative.map(|(s, from)| AlternativeScale {
            scale_from: from,
            capacitance_j_per_k: unit.capacitance.iter().map(|c| c * s).collect(),
            ratio_to_chosen: s / scale,
        });
        let mut network = Network::assemble(
            &unit
                .capacitance
                .iter()
                .map(|c| c * scale)
                .collect::<Vec<_>>(),
            &(&unit.conductance * scale),
            &(&unit.loss_distribution * scale),
            scaling,
            scale_from,
            labels,
        );
        network.scale_note = scale_note;
        network.alternative_scale = alternative_scale;
        network.passivity = Passivity::assess(&network, fit);
        Ok(network)
    }

    /// A network from C, G and K given directly, in the model's `scaling`; its passivity
    /// figures are those of the parts themselves (reciprocal by construction).
    pub fn from_parts(
        parts: &Parts,
        scaling: Scaling,
        scale_from: ScaleSource,
        labels: &Labels,
    ) -> Result<Network, NetworkError> {
        scaling.check()?;
        let n = parts.capacitance_j_per_k.len();
        let m = parts.loss_distribution.ncols();
        let g = &parts.conductance_w_per_k;
        check_shape("the conductance matrix", g, n, n)?;
        check_shape("the loss distribution", &parts.loss_distribution, n, m)?;
        check_labels(labels, n, m)?;
        check_finite("the conductance matrix", g)?;
        check_finite("the loss distribution", &parts.loss_distribution)?;
        if let Some((i, &c)) = parts
            .capacitance_j_per_k
            .iter()
            .enumerate()
            .find(|(_, c)| !(c.is_finite() && **c > 0.0))
        {
            return Err(NetworkError::NonPositiveCapacitance {
                part: labels.states[i].clone(),
                value: c,
            });
        }
        let symmetric = (g - g.transpose()).amax() <= 1e-12 * g.amax();
        if !symmetric {
            return Err(NetworkError::BadParameter(
                "the conductance matrix is not symmetric: G_ij must equal G_ji".into(),
            ));
        }
        let mut network = Network::assemble(
            &parts.capacitance_j_per_k,
            g,
            &parts.loss_distribution,
            scaling,
            scale_from,
            labels,
        );
        let (a_c, _) = network.to_continuous();
        let reciprocity = reciprocity::Reciprocity::of(&a_c, &parts.capacitance_j_per_k);
        network.passivity = Passivity::assess(&network, reciprocity);
        Ok(network)
    }

    /// The model of eq. 9 in the network's scaling: A_c = −C⁻¹·L,
    /// B_c = C⁻¹·K·P_base/θ_base, with L_ij = −G_ij and L_ii = G_i0 + Σ_{j≠i} G_ij.
    pub fn to_continuous(&self) -> (DMatrix<f64>, DMatrix<f64>) {
        let n = self.capacitance_j_per_k.len();
        let m = self.inputs.len();
        let g = DMatrix::from_fn(n, n, |i, j| self.conductance_w_per_k[i][j]);
        let mut l = -&g;
        for i in 0..n {
            l[(i, i)] = g[(i, i)] + (0..n).filter(|&j| j != i).map(|j| g[(i, j)]).sum::<f64>();
        }
        let a_c = DMatrix::from_fn(n, n, |i, j| -l[(i, j)] / self.capacitance_j_per_k[i]);
        let b_c = DMatrix::from_fn(n, m, |i, j| {
            self.loss_distribution[i][j] / self.capacitance_j_per_k[i]
                * self.scaling.watts_per_kelvin()
        });
        (a_c, b_c)
    }

    /// The heat flows (W) at the rises `rises_k` (K, one per part): q_ij = G_ij·(θ_i − θ_j)
    /// from part i to part j off the diagonal, q_i0 = G_i0·θ_i from part i to the coolant
    /// on it (the currents of Fig. 9's resistances).
    pub fn heat_flows_w(&self, rises_k: &[f64]) -> Result<Vec<Vec<f64>>, NetworkError> {
        let n = self.capacitance_j_per_k.len();
        if rises_k.len() != n {
            return Err(NetworkError::Shape {
                what: "the temperature rises",
                expected_rows: n,
                expected_cols: 1,
                found_rows: rises_k.len(),
                found_cols: 1,
            });
        }
        Ok((0..n)
            .map(|i| {
                (0..n)
                    .map(|j| {
                        let g = self.conductance_w_per_k[i][j];
                        if i == j {
                            g * rises_k[i]
                        } else {
                            g * (rises_k[i] - rises_k[j])
                        }
                    })
                    .collect()
            })
            .collect())
    }

    /// The network's tables from C, G (diagonal G_i0) and K; passivity left empty.
    fn assemble(
        capacitance: &[f64],
        conductance: &DMatrix<f64>,
        loss_distribution: &DMatrix<f64>,
        scaling: Scaling,
        scale_from: ScaleSource,
        labels: &Labels,
    ) -> Network {
        let rows = |m: &DMatrix<f64>| -> Vec<Vec<f64>> {
            m.row_iter().map(|r| r.iter().copied().collect()).collect()
        };
        let conductance_w_per_k = rows(conductance);
        let resistance_k_per_w = conductance_w_per_k
            .iter()
            .map(|r| r.iter().map(|&g| (g != 0.0).then(|| 1.0 / g)).collect())
            .collect();
        Network {
            states: labels.states.clone(),
            inputs: labels.inputs.clone(),
            scaling,
            capacitance_j_per_k: capacitance.to_vec(),
            conductance_w_per_k,
            resistance_k_per_w,
            loss_distribution: rows(loss_distribution),
            loss_distribution_column_sums: loss_distribution
                .column_iter()
                .map(|c| c.sum())
                .collect(),
            scale_from,
            scale_note: None,
            alternative_scale: None,
            passivity: Passivity::default(),
            intervals_95: None,
            fitted_from: None,
            minimum_distance: None,
            first_sample_offset_k: None,
        }
    }
}

/// Shapes, finiteness, scaling, the coolant link, the spectrum and the inputs.
fn check_model(
    a_c: &DMatrix<f64>,
    b_c: &DMatrix<f64>,
    scaling: Scaling,
    coolant: Option<CoolantLink>,
    labels: &Labels,
) -> Result<(), NetworkError> {
    let n = a_c.nrows();
    check_shape("A_c", a_c, n, n)?;
    check_shape("B_c", b_c, n, b_c.ncols())?;
    check_labels(labels, n, b_c.ncols())?;
    check_finite("A_c", a_c)?;
    check_finite("B_c", b_c)?;
    scaling.check()?;
    if let Some(link) = coolant {
        if link.state >= n {
            return Err(NetworkError::BadParameter(format!(
                "the cooling-water outlet is state {} of a model with {n} states",
                link.state + 1
            )));
        }
        let g = link.conductance_w_per_k;
        if !(g.is_finite() && g > 0.0) {
            return Err(NetworkError::BadParameter(format!(
                "the outlet's conductance to the coolant c·ρ·Q = {g} W/K must be positive"
            )));
        }
    }
    check_spectrum(a_c)?;
    for (j, column) in b_c.column_iter().enumerate() {
        if column.iter().all(|&b| b <= 0.0) {
            return Err(NetworkError::NotHeat {
                input: labels.inputs[j].clone(),
            });
        }
    }
    Ok(())
}

/// Real, negative eigenvalues (a Hurwitz A_c with no oscillation).
fn check_spectrum(a_c: &DMatrix<f64>) -> Result<(), NetworkError> {
    if a_c.nrows() == 0 {
        return Ok(());
    }
    let eigenvalues = a_c.clone().complex_eigenvalues();
    let scale = eigenvalues.iter().map(|l| l.norm()).fold(0.0, f64::max);
    for l in eigenvalues.iter() {
        if l.im.abs() > 1e-9 * scale {
            return Err(NetworkError::ComplexEigenvalues {
                re: l.re,
                im: l.im.abs(),
            });
        }
    }
    if let Some(l) = eigenvalues.iter().find(|l| l.re >= 0.0) {
        return Err(NetworkError::NotStable { eigenvalue: l.re });
    }
    Ok(())
}

fn check_shape(
    what: &'static str,
    m: &DMatrix<f64>,
    rows: usize,
    cols: usize,
) -> Result<(), NetworkError> {
    if m.nrows() == rows && m.ncols() == cols {
        Ok(())
    } else {
        Err(NetworkError::Shape {
            what,
            expected_rows: rows,
            expected_cols: cols,
            found_rows: m.nrows(),
            found_cols: m.ncols(),
        })
    }
}

fn check_labels(labels: &Labels, n: usize, m: usize) -> Result<(), NetworkError> {
    let shape = |what, expected: usize, found: usize| NetworkError::Shape {
        what,
        expected_rows: expected,
        expected_cols: 1,
        found_rows: found,
        found_cols: 1,
    };
    if labels.states.len() != n {
        return Err(shape("the state names", n, labels.states.len()));
    }
    if labels.inputs.len() != m {
        return Err(shape("the input names", m, labels.inputs.len()));
    }
    Ok(())
}

fn check_finite(what: &'static str, m: &DMatrix<f64>) -> Result<(), NetworkError> {
    for i in 0..m.nrows() {
        for j in 0..m.ncols() {
            if !m[(i, j)].is_finite() {
                return Err(NetworkError::NonFinite {
                    what,
                    row: i,
                    col: j,
                });
            }
        }
    }
    Ok(())
}
