//! The report document: every block of the profile's JSON report, serialised as a replay
//! writes it and read back as the uses of the model read it. Building one from a replay
//! is [`crate::report`]'s (above the pipeline); this module knows no stage.

use std::collections::BTreeMap;
use std::path::Path;

use serde::de::IgnoredAny;
use serde::{Deserialize, Serialize};

use super::error::UseError;
use crate::losses::FieldTemperatureSource;
use crate::spec::ModelDescription;

/// The profile identifier written into every report, and the one report version this
/// heatrun reads back.
pub const PROFILE: &str = "heatrun-scada/1";

/// One time constant's part, as in the profile.
#[derive(Debug, Clone, Serialize)]
pub struct AssignmentEntry {
    /// T_i in s.
    pub time_constant_s: f64,
    /// The oscillation period 2π/|Im λ_c| of a complex mode, s (absent for a real one).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub oscillation_period_s: Option<f64>,
    /// The state (profile name) it predominantly belongs to.
    pub state: String,
    /// ‖T_i ∂y/∂T_i‖ (RMS, pu) of that state.
    pub sensitivity_norm: f64,
    /// The physical part, for people.
    pub part: String,
}

/// Fit block of the report. Read back: the errors a use of the model needs (RMSE and
/// largest error; an SNR of a perfect fit is infinite, which JSON writes as null).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct FitEntry {
    /// SNR in dB (eq. 25).
    #[serde(skip_deserializing)]
    pub snr_db: Vec<f64>,
    /// NRMSE fit in %.
    #[serde(skip_deserializing)]
    pub nrmse_fit_percent: Vec<f64>,
    /// RMSE in K.
    pub rmse_k: Vec<f64>,
    /// Largest absolute error in K.
    pub max_abs_error_k: Vec<f64>,
    /// Mean squared error in K².
    #[serde(skip_deserializing)]
    pub mse_k2: Vec<f64>,
    /// Instants compared.
    #[serde(skip_deserializing)]
    pub samples: usize,
}

/// 95 % confidence intervals (half-widths), by the delta method.
#[derive(Debug, Clone, Serialize)]
pub struct UncertaintyEntry {
    /// Of each time constant, s.
    pub time_constants_ci95_s: Vec<f64>,
    /// Of each steady-state rise (and temperature), K.
    pub steady_state_ci95_k: Vec<f64>,
    /// Standard errors of Θ = [Φ Γ], row-major.
    pub theta_standard_error: Vec<Vec<f64>>,
}

/// Validation block: the fit on data not used for the estimate (the band `monitor` draws
/// and the error `predict` states).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct ValidationEntry {
    /// What the data were.
    pub source: String,
    /// The fit there.
    pub fit: FitEntry,
}

/// The hidden-state model block (`hidden`), where the spec declares hidden states:
/// x(k+1) = Φ x(k) + Γ u(k), y(k) = C x(k) + D u(k), the report's `states` the outputs y.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct HiddenEntry {
    /// Whether this is the replay's model (written by a replay of a spec with `[hidden]`):
    /// the report's time constants, assignment, sensitivities, steady state, `fit` and
    /// `validation` are then this model's, and `predict`, `rating` and `monitor` run it.
    /// False (absent) in reports before it, which kept it beside the measured-state model.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub replay_model: bool,
    /// A name per state, n: the output that reads it alone where C = [I 0] (a measured
    /// state), else `hidden_<i>` (a state no sensor reads, or a free C's basis).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub state_names: Vec<String>,
    /// Per state, whether a sensor reads it alone (C's row a unit vector on it).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub measured: Vec<bool>,
    /// States n (measured and hidden).
    pub order: usize,
    /// How the order was set: "given" or "chosen on the estimation data".
    pub order_source: String,
    /// "measured" (C = [I 0], sensor i reads state i) or "free" (C estimated).
    pub output_matrix: String,
    /// Φ (n × n), rows.
    pub phi: Vec<Vec<f64>>,
    /// Γ (n × m), rows.
    pub gamma: Vec<Vec<f64>>,
    /// C (p × n), rows.
    pub c: Vec<Vec<f64>>,
    /// D (p × m), rows.
    pub d: Vec<Vec<f64>>,
    /// τ_i = −Ts / ln|λ_i(Φ)|, ascending, s (empty where Φ is unstable).
    #[serde(default)]
    pub time_constants_s: Vec<f64>,
    /// Steady-state gain C (I − Φ)⁻¹ Γ + D (p × m), rows: y_ss = G u.
    #[serde(default)]
    pub steady_state_gain: Vec<Vec<f64>>,
    /// Singular values of the subspace step, descending (the order's evidence).
    #[serde(default)]
    pub singular_values: Vec<f64>,
    /// The orders tried, where the order was chosen.
    #[serde(default)]
    pub candidates: Vec<HiddenCandidateEntry>,
    /// Fit on the estimation instants (each segment from its fitted initial state).
    pub fit: FitEntry,
    /// Fit on held-out data or another recording, where the replay validates.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub validation: Option<ValidationEntry>,
    /// The covariance of its parameters, where the replay made one (absent in reports
    /// before it): what predict, rating and monitor carry into their 95 % bands.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub parameter_covariance: Option<HiddenCovarianceEntry>,
}

/// The covariance of a hidden-state model's parameters at the output-error optimum:
/// Gauss–Newton's C_θ = H⁺, H = Σ J_kjᵀ J_kj / σ̂_j², or where the residuals are correlated
/// in time the sandwich H⁺ M H⁺ (`correlation_window`); the changes of basis that leave
/// the outputs unchanged left out of the pseudo-inverse (`heatrun::hidden::covariance`).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct HiddenCovarianceEntry {
    /// How the parameters are laid out: "[phi gamma; c d] row by row", entry (i, j) of
    /// that (n + p) × (n + m) matrix at index i·(n + m) + j.
    pub layout: String,
    /// C_θ, (n + p)(n + m) square, rows; model units (per unit where scaled). The rows and
    /// columns of entries held fixed (C = [I 0], D = 0) are zero.
    pub matrix: Vec<Vec<f64>>,
    /// σ̂_j² per measured output: its mean squared simulation error times N/(N − r),
    /// model units².
    pub output_noise_variance: Vec<f64>,
    /// Directions of the changes of basis left out (n² with C free, (n − p)·n with C fixed).
    pub basis_directions: usize,
    /// Where the residuals' correlation in time is taken into the covariance: the width L
    /// of the Bartlett window, instants, of the sandwich C_θ = H⁺ M H⁺
    /// (`heatrun::estimate::long_run`). Absent: Gauss–Newton's H⁺, the residuals taken
    /// as white (every report before it).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub correlation_window: Option<usize>,
}

/// The layout of [`HiddenCovarianceEntry::matrix`].
pub const HIDDEN_COVARIANCE_LAYOUT: &str = "[phi gamma; c d] row by row";

/// The measured-state model (the paper's, C = I) of a replay whose spec declares hidden
/// states: its figures, which the report's top-level keys give where the spec declares
/// none. Its Φ and Γ stay the report's `phi` and `gamma` (and its analysis `a_c`,
/// `eigenvalues_*`, `residuals`, `network`, `theta_covariance`).
#[derive(Debug, Clone, Serialize)]
pub struct MeasuredStateEntry {
    /// Time constants, ascending, s.
    pub time_constants_s: Vec<f64>,
    /// Time constant → state.
    pub assignment: Vec<AssignmentEntry>,
    /// ‖T_i ∂y_k/∂T_i‖: rows states, columns time constants.
    pub sensitivity_norms: Vec<Vec<f64>>,
    /// Fit on the estimation instants.
    pub fit: FitEntry,
    /// Steady state (eqs. 30–35).
    pub steady_state: SteadyStateEntry,
    /// 95 % intervals, where the method gives a covariance.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub uncertainty: Option<UncertaintyEntry>,
    /// Fit on held-out data or another recording.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub validation: Option<ValidationEntry>,
}

/// One order tried for the hidden-state model.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct HiddenCandidateEntry {
    /// The order n.
    pub order: usize,
    /// The five-fold cross-validated NRMSE fit (%) on the estimation data (each fifth
    /// simulated by the model of the rest, x0 fitted to its outputs; errors pooled per
    /// output, averaged over the outputs).
    pub hold_back_fit_percent: Option<f64>,
    /// Akaike's criterion on all the estimation data.
    pub aic: Option<f64>,
    /// Why the order gave no model, where it gave none.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub refused: Option<String>,
}

/// Residual analysis block.
#[derive(Debug, Clone, Default, Serialize)]
pub struct ResidualEntry {
    /// Largest lag, samples.
    pub max_lag: usize,
    /// 99 % band of a white sequence: ±this.
    pub band99: f64,
    /// `[state][lag]` autocorrelation of the simulation residuals, lags 0..max_lag.
    pub autocorrelation: Vec<Vec<f64>>,
    /// `[state][input][lag + max_lag]` cross-correlation residual × input, lags −max_lag..max_lag.
    pub cross_correlation: Vec<Vec<Vec<f64>>>,
    /// Per state: fraction of lags 1..max_lag outside the band.
    pub autocorrelation_outside_band: Vec<f64>,
    /// Per state × input: largest |cross-correlation| over the lags.
    pub max_abs_cross_correlation: Vec<Vec<f64>>,
}

/// Steady-state block of the report (eqs. 30–35).
#[derive(Debug, Clone, Default, Serialize)]
pub struct SteadyStateEntry {
    /// The input u the steady state is for (the last measured one), pu.
    pub input_pu: Vec<f64>,
    /// Predicted final rises −θ_base·A_c⁻¹B_c u, K.
    pub rise_k: Vec<f64>,
    /// Predicted final temperatures θ_0 + rise, °C.
    pub temperature_c: Vec<f64>,
    /// Measured temperatures at the end of the recording, °C.
    pub measured_final_temperature_c: Vec<f64>,
    /// Measured rises at the end of the recording, K.
    pub measured_final_rise_k: Vec<f64>,
    /// Where the rises are measured from the coolant inlet: the steady state at the final
    /// inlet temperature and at a stated reference inlet temperature.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub coolant_inlet: Option<InletSteadyState>,
}

/// The steady state against the coolant inlet (the network's reference node).
#[derive(Debug, Clone, Serialize)]
pub struct InletSteadyState {
    /// θ_in,0: the inlet's initial level the rises are measured from, °C.
    pub initial_inlet_c: f64,
    /// The inlet temperature of the steady-state input (the last measured), °C.
    pub final_inlet_c: f64,
    /// Predicted rise above the final inlet temperature, K.
    pub rise_above_inlet_k: Vec<f64>,
    /// The stated reference inlet temperature, °C ([`crate::report::REFERENCE_INLET_C`]).
    pub reference_inlet_c: f64,
    /// Predicted temperatures with the inlet at the reference, °C: θ_in,0 +
    /// θ_base·(−A_c⁻¹B_c u) with the inlet's entry of u at the reference.
    pub temperature_at_reference_inlet_c: Vec<f64>,
}

/// The recording block (an extension of the profile).
#[derive(Debug, Clone, Default, Serialize)]
pub struct RecordingEntry {
    /// The file replayed.
    pub path: String,
    /// Its size in bytes.
    pub file_bytes: u64,
    /// First and last sample time, RFC 3339.
    pub start: Option<String>,
    /// Last sample time, RFC 3339.
    pub end: Option<String>,
    /// Heat-run channels: topic, quantity, unit, samples, nominal period, gaps.
    pub channels: Vec<ChannelEntry>,
    /// Channels not read, with the reason.
    pub ignored_channels: Vec<crate::recording::IgnoredChannel>,
    /// Samples marked `bad` and dropped.
    pub bad_quality_dropped: u64,
    /// What was lost to damage in the file.
    pub data_loss: Vec<String>,
    /// Other metadata records of the file.
    pub metadata: BTreeMap<String, BTreeMap<String, String>>,
}

/// One channel in the report.
#[derive(Debug, Clone, Serialize)]
pub struct ChannelEntry {
    /// MCAP topic.
    pub topic: String,
    /// Quantity.
    pub quantity: String,
    /// Sensor tag.
    pub sensor: Option<String>,
    /// Unit as recorded.
    pub unit: String,
    /// Samples read.
    pub samples: u64,
    /// Median sample period, s.
    pub nominal_period_s: f64,
    /// Gaps found.
    pub gaps: usize,
}

/// Estimation details (an extension of the profile). Read back: the initial temperatures
/// and references, the bases, the coolant and the field winding's temperature, which a
/// use of the model starts from.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct EstimationEntry {
    /// Grid instants.
    #[serde(skip_deserializing)]
    pub instants: usize,
    /// Equations used.
    #[serde(skip_deserializing)]
    pub equations_used: usize,
    /// Contiguous segments simulated (gaps split them).
    #[serde(skip_deserializing)]
    pub segments: usize,
    /// Condition number of the scaled regression matrix.
    #[serde(skip_deserializing)]
    pub condition_number: f64,
    /// Initial temperatures θ_0 the rises are measured from, °C.
    pub initial_temperature_c: Vec<f64>,
    /// Time of the initial temperatures, RFC 3339.
    #[serde(skip_deserializing)]
    pub initial_time: String,
    /// Source of the field winding temperature.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub field_temperature: Option<FieldTemperatureSource>,
    /// Temperature base, K.
    pub temperature_base_k: f64,
    /// Power base, MVA.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub power_base_mva: Option<f64>,
    /// Each state's reference θ_ref,j at the initial instant, °C: a state's temperature
    /// there is this plus its initial rise (what `heatrun predict` starts from). Always
    /// written; absent in reports before it, whose references were the initial
    /// temperatures themselves.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub initial_reference_c: Option<Vec<f64>>,
    /// The mean cooling-water inlet temperature over the recording, °C, where it is
    /// recorded: the coolant temperature the model's rises belong to.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub coolant_inlet_temp_c: Option<f64>,
    /// The field winding temperature as a straight line of the stator winding's
    /// (least squares over the recording), where the loss model has a field temperature:
    /// what `heatrun predict` uses for R_f when the field winding is not a state.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub field_temperature_from_stator: Option<FieldFromStator>,
    /// What was done with missing samples, where there were any: the inputs' gaps
    /// bridged or cut, the states' unobserved instants.
    #[serde(default, skip_deserializing, skip_serializing_if = "Option::is_none")]
    pub gaps: Option<GapsEntry>,
}

/// Missing samples and what the replay did with them: an input's gap of at most
/// `bridge_limit_s` is bridged (held, or interpolated for a slow quantity), a longer one
/// cuts the data (the next segment's initial state is estimated); a state's missing
/// sample is an unobserved instant the model is simulated through.
#[derive(Debug, Clone, Serialize)]
pub struct GapsEntry {
    /// The longest input gap bridged, s.
    pub bridge_limit_s: f64,
    /// Per input with a gap.
    pub inputs: Vec<InputGapsEntry>,
    /// Per state with unobserved instants after the initial one.
    pub unobserved: Vec<UnobservedEntry>,
}

/// One input's gaps.
#[derive(Debug, Clone, Serialize)]
pub struct InputGapsEntry {
    /// The input's name.
    pub input: String,
    /// What was done with them.
    #[serde(flatten)]
    pub gaps: crate::signals::InputGaps,
}

/// One state's unobserved instants.
#[derive(Debug, Clone, Serialize)]
pub struct UnobservedEntry {
    /// The state's name.
    pub state: String,
    /// Instants after the initial one without a value (not counting the instants a
    /// historian storing by exception kept no value at).
    pub instants: usize,
}

/// θ_f ≈ intercept + slope · θ_Cu: the field winding temperature from the stator
/// winding's, fitted over the recording.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct FieldFromStator {
    /// Intercept, °C.
    pub intercept_c: f64,
    /// Slope, K per K.
    pub slope: f64,
    /// RMS of the fit's residual, K (read back as the derived temperature's spread;
    /// 0 from a report without it).
    #[serde(default)]
    pub rms_residual_k: f64,
}

/// The report of `heatrun replay --report` (profile section "Report"): what a replay
/// writes, and the model file `predict`, `rating` and `monitor` read back.
///
/// Read back ([`Report::from_json`]), a report holds what the uses of the model need: the
/// fields marked `skip_deserializing` are the replay's account for people and other
/// tools (the analysis, the network, the recording, the warnings); they are not read, so
/// they keep their defaults (empty, zero, `None`). That keeps a model usable from a
/// report of an older heatrun, which lacks some of them, and from one whose figures JSON
/// could not hold (a NaN or an infinity is written as null).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Report {
    /// Always [`PROFILE`].
    pub profile: String,
    /// heatrun's version.
    #[serde(skip_deserializing)]
    pub heatrun_version: String,
    /// Ts in s.
    pub sample_time_s: f64,
    /// Identification method.
    #[serde(skip_deserializing)]
    pub method: String,
    /// State names in model order.
    pub states: Vec<String>,
    /// Input names in model order.
    pub inputs: Vec<String>,
    /// Φ, row-major.
    pub phi: Vec<Vec<f64>>,
    /// Γ, row-major.
    pub gamma: Vec<Vec<f64>>,
    /// A_c, row-major, 1/s.
    #[serde(skip_deserializing)]
    pub a_c: Vec<Vec<f64>>,
    /// B_c, row-major, 1/s.
    #[serde(skip_deserializing)]
    pub b_c: Vec<Vec<f64>>,
    /// Eigenvalues of Φ, ascending.
    #[serde(skip_deserializing)]
    pub eigenvalues_discrete: Vec<f64>,
    /// Eigenvalues of A_c, 1/s.
    #[serde(skip_deserializing)]
    pub eigenvalues_continuous: Vec<f64>,
    /// Time constants, ascending, s (−1/Re λ_c; a complex pair's twice).
    pub time_constants_s: Vec<f64>,
    /// Where A_c has complex-conjugate pairs (oscillating modes): the imaginary parts
    /// of `eigenvalues_discrete`, absent where every eigenvalue is real.
    #[serde(skip_serializing_if = "Option::is_none", skip_deserializing)]
    pub eigenvalues_discrete_imag: Option<Vec<f64>>,
    /// Imaginary parts of `eigenvalues_continuous`, 1/s, absent where all are real.
    #[serde(skip_serializing_if = "Option::is_none", skip_deserializing)]
    pub eigenvalues_continuous_imag: Option<Vec<f64>>,
    /// Each mode's oscillation period 2π/|Im λ_c|, s (null for a real mode), absent
    /// where all are real.
    #[serde(skip_serializing_if = "Option::is_none", skip_deserializing)]
    pub oscillation_periods_s: Option<Vec<Option<f64>>>,
    /// Time constant → state.
    #[serde(skip_deserializing)]
    pub assignment: Vec<AssignmentEntry>,
    /// `sensitivity_norms[k][i]` = ‖T_i ∂y_k/∂T_i‖ (RMS, pu): rows states, columns time constants.
    #[serde(skip_deserializing)]
    pub sensitivity_norms: Vec<Vec<f64>>,
    /// Fit quality.
    pub fit: FitEntry,
    /// Steady state.
    #[serde(skip_deserializing)]
    pub steady_state: SteadyStateEntry,
    /// The recording.
    #[serde(skip_deserializing)]
    pub recording: RecordingEntry,
    /// The nameplate used, where the model needs one (the generator's loss model).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub nameplate: Option<crate::recording::Nameplate>,
    /// The model description: states (channel, reference, part), inputs (source, unit,
    /// kind, shift) and scaling — what later commands need to use the model.
    pub model: ModelDescription,
    /// Estimation details.
    pub estimation: EstimationEntry,
    /// 95 % intervals, where the method gives a covariance.
    #[serde(skip_deserializing)]
    pub uncertainty: Option<UncertaintyEntry>,
    /// Fit on held-out data or another recording.
    pub validation: Option<ValidationEntry>,
    /// Whiteness and input correlation of the residuals.
    #[serde(skip_deserializing)]
    pub residuals: ResidualEntry,
    /// The same analysis of the innovations y(k) − ŷ(k|k−1), where the method has a
    /// one-step predictor (`pem`).
    #[serde(skip_serializing_if = "Option::is_none", skip_deserializing)]
    pub innovations: Option<ResidualEntry>,
    /// Which estimator a replay chose and why, where the method was not given.
    #[serde(skip_serializing_if = "Option::is_none", skip_deserializing)]
    pub estimator_choice: Option<EstimatorChoiceEntry>,
    /// The default's decisions ([`crate::decide`]: the sample time, the estimator, the
    /// screen, the network), each with its candidates, the figures compared and the
    /// verdict, in the order they were made. Absent where the replay made none (every
    /// report before them).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub decisions: Vec<crate::decide::Decision>,
    /// The one-step predictor's gain K (n × n: x̂(k+1) = Φ x̂(k) + Γ u(k) + K (y(k) − x̂(k))),
    /// where the method estimated one (`pem`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub kalman_gain: Option<Vec<Vec<f64>>>,
    /// The predictor's disturbance state, where `pem` had one: a random walk d of heat
    /// entering a state, d(k+1) = d(k) + k_d (y(k) − x̂(k)).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub disturbance: Option<DisturbanceEntry>,
    /// The innovations' variance Λ_i per output, in the model's units (pu² where per
    /// unit), beside `kalman_gain`: with it the process noise an open-loop prediction
    /// accumulates, P(k+1) = Φ P(k) Φᵀ + K Λ Kᵀ.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub innovation_variance: Option<Vec<f64>>,
    /// The covariance of Θ = [Φ Γ] laid out row by row (state i's row of Φ, then of Γ:
    /// n(n+m) entries), where the method gives one: what `rating`, `predict` and
    /// `monitor` propagate into their intervals (var g ≈ ∇gᵀ C_Θ ∇g).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub theta_covariance: Option<Vec<Vec<f64>>>,
    /// Where `theta_covariance` takes the residuals' correlation in time (`oe`'s sandwich
    /// H⁻¹ M H⁻¹): the width L of its Bartlett window, instants. Absent: the method's
    /// own covariance (every report before it).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub theta_covariance_window: Option<usize>,
    /// The passive thermal network of the model (Fig. 9), or why it has none: always
    /// written by a replay, `None` in a report read back.
    #[serde(skip_serializing_if = "Option::is_none", skip_deserializing)]
    pub network: Option<NetworkEntry>,
    /// The heat the cooling water carries away against the losses (eqs. 17-18), where
    /// the flow is recorded.
    #[serde(skip_serializing_if = "Option::is_none", skip_deserializing)]
    pub calorimetry: Option<crate::network::Calorimetry>,
    /// Whether the recording reached thermal equilibrium (IEC 60034-1; five time
    /// constants): always written by a replay; read back where it is whole (`predict` and
    /// `rating` say when the steady state is an extrapolation), `None` where a report
    /// lacks it or holds it in another form.
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "read_equilibrium"
    )]
    pub equilibrium: Option<crate::network::equilibrium::Equilibrium>,
    /// For `rc`: the black-box output-error model it started from, on the same instants.
    #[serde(skip_serializing_if = "Option::is_none", skip_deserializing)]
    pub output_error_beside: Option<BesideEntry>,
    /// The stretches left out of the estimation as glitches or frozen values (absent
    /// when none).
    #[serde(default, skip_serializing_if = "Vec::is_empty", skip_deserializing)]
    pub left_out: Vec<LeftOutEntry>,
    /// The model with hidden states, where the spec declares one (`[hidden]`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub hidden: Option<HiddenEntry>,
    /// The measured-state model's figures where the hidden-state model is the replay's
    /// (`hidden.replay_model`): what the top-level keys held before.
    #[serde(default, skip_serializing_if = "Option::is_none", skip_deserializing)]
    pub measured_state: Option<MeasuredStateEntry>,
    /// Where the data contradicted physics and what was done (channels exchanged mid-run
    /// swapped back, a calorimetric balance or parts' labels said): absent when nothing
    /// was found, and in a report read back.
    #[serde(default, skip_serializing_if = "Vec::is_empty", skip_deserializing)]
    pub plausibility: Vec<crate::plausibility::Finding>,
    /// Warnings.
    #[serde(skip_deserializing)]
    pub warnings: Vec<String>,
}

/// A stretch of a state's channel left out of the estimation (the screen's
/// [`crate::screen::LeftOut`], its times in RFC 3339).
#[derive(Debug, Clone, Serialize)]
pub struct LeftOutEntry {
    /// The state's channel.
    pub channel: String,
    /// The first grid instant left out, RFC 3339.
    pub from: String,
    /// The last grid instant left out, RFC 3339.
    pub to: String,
    /// The measured value at the first instant (a frozen run's held value), in the
    /// channel's unit.
    pub value: f64,
    /// `glitch` or `frozen`.
    pub why: crate::screen::Why,
    /// Grid instants left out.
    pub samples: usize,
    /// A glitch's largest departure from the model's prediction, or the change the
    /// model predicts over a frozen run, K.
    pub deviation_k: f64,
}

/// Which estimator a replay chose and why.
#[derive(Debug, Clone, Serialize)]
pub struct EstimatorChoiceEntry {
    /// `oe` or `pem`.
    pub method: String,
    /// Why, in a sentence.
    pub reason: String,
    /// Per state: the fraction of lags of `oe`'s simulation residuals' autocorrelation
    /// outside the 99 % band (about 0.01 when white).
    pub oe_autocorrelation_outside_band: Vec<f64>,
    /// The fraction above which a residual is taken as not white.
    pub threshold: f64,
    /// Ljung and Box's Q per state over lags 1..L of the same residuals, and χ²_L's 0.99
    /// quantile above which a residual is taken as not white (either test suffices).
    pub oe_ljung_box: crate::decide::estimator::LjungBox,
    /// The likelihood ratio of `pem` against `oe`, where `pem` was fitted to test it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub likelihood_ratio: Option<crate::estimate::LikelihoodRatio>,
}

/// The report's `disturbance`: a predictor's random-walk state (see
/// [`crate::estimate::Disturbance`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DisturbanceEntry {
    /// The state d enters, by name.
    pub state: String,
    /// k_d per output (pu of the state per pu of the innovation): d's row of the gain.
    pub gain: Vec<f64>,
    /// √q θ_base: the standard deviation of d's increment, K per sample per sample.
    pub increment_sd_k: f64,
}

/// Another method's figures beside the report's own (`rc` beside `oe`).
#[derive(Debug, Clone, Serialize)]
pub struct BesideEntry {
    /// Its method.
    pub method: String,
    /// Its time constants, ascending, s.
    pub time_constants_s: Vec<f64>,
    /// Its fit on the estimation instants.
    pub fit: FitEntry,
}

/// The report's `network` block: the network, or why the model has none.
#[derive(Debug, Clone, Serialize)]
#[serde(untagged)]
pub enum NetworkEntry {
    /// The network of the identified model.
    Defined(Box<crate::network::Network>),
    /// The model has no network.
    NotDefined {
        /// Why.
        not_defined: String,
    },
}

/// The keys looked at before the report is read whole: its version, and the blocks every
/// use of the model needs, so that a report of another version or an older one is named
/// as such rather than by the first key it lacks.
#[derive(Deserialize)]
#[serde(expecting = "a JSON object")]
struct Head {
    profile: Option<Tag>,
    model: Option<IgnoredAny>,
    estimation: Option<IgnoredAny>,
}

/// A `profile` key: the version's name, or something that is none.
#[derive(Deserialize)]
#[serde(untagged)]
enum Tag {
    Name(String),
    Other(IgnoredAny),
}

impl Report {
    /// Reads a report (`heatrun replay --report`).
    pub fn read(path: &Path) -> Result<Report, UseError> {
        // A URL (s3://, gs://, az://, https://) is read from its store, whole.
        let location = crate::store::Location::from_path(path)?;
        if location.is_remote() {
            let text = crate::store::read_to_string(&location)?;
            return Report::from_json(&text, path);
        }
        Report::from_json(&Report::read_text(path)?, path)
    }

    /// The text of a local report file. A recording given for its report (`--model
    /// run.mcap`) or any file that is not text is named as such, not as text that is not
    /// UTF-8.
    pub(crate) fn read_text(path: &Path) -> Result<String, UseError> {
        let bytes = std::fs::read(path).map_err(|source| UseError::Read {
            path: path.to_owned(),
            source,
        })?;
        let not_text = |message: &str| UseError::NotAReport {
            path: path.to_owned(),
            message: message.into(),
        };
        if bytes.starts_with(mcap::MAGIC) {
            return Err(not_text("it is an MCAP recording, not the report of one"));
        }
        String::from_utf8(bytes).map_err(|_| not_text("it is not text (JSON)"))
    }

    /// Parses a report's text; `path` names it in messages. The profile is checked first
    /// (a report of another version may not parse as this one), then the presence of the
    /// `model` and `estimation` blocks (reports before them cannot be used), then the
    /// whole.
    pub fn from_json(text: &str, path: &Path) -> Result<Report, UseError> {
        let not_a_report = |e: serde_json::Error| UseError::NotAReport {
            path: path.to_owned(),
            message: e.to_string(),
        };
        let head: Head = serde_json::from_str(text).map_err(not_a_report)?;
        match head.profile {
            Some(Tag::Name(p)) if p == PROFILE => {}
            Some(Tag::Name(found)) => {
                return Err(UseError::ProfileVersion {
                    path: path.to_owned(),
                    found,
                    expected: PROFILE,
                })
            }
            // `heatrun synth`'s truth beside a recording (`run.mcap.truth.json`) is met
            // where a folder's `*.json` is given: its `profile` is the load schedule.
            _ if path.to_string_lossy().ends_with(".truth.json") => {
                return Err(UseError::NotAReport {
                    path: path.to_owned(),
                    message: "it is the true model `heatrun synth` writes beside a recording, \
                              not the report of a replay"
                        .into(),
                })
            }
            Some(Tag::Other(_)) => {
                return Err(UseError::NotAReport {
                    path: path.to_owned(),
                    message: "its `profile` is not the name of a heatrun profile".into(),
                })
            }
            None => {
                return Err(UseError::NotAReport {
                    path: path.to_owned(),
                    message: "no `profile` key".into(),
                })
            }
        }
        for (key, present) in [
            ("model", head.model.is_some()),
            ("estimation", head.estimation.is_some()),
        ] {
            if !present {
                return Err(UseError::MissingBlock {
                    path: path.to_owned(),
                    key: key.into(),
                    needed_for: "every use of the model needs".into(),
                });
            }
        }
        serde_json::from_str(text).map_err(not_a_report)
    }

    /// The report as pretty-printed JSON.
    pub fn to_json(&self) -> String {
        // Serialising plain numbers, strings and maps cannot fail.
        serde_json::to_string_pretty(self).unwrap_or_else(|e| format!("{{\"error\": \"{e}\"}}"))
    }
}

/// A report's `equilibrium` block where it reads as one, else `None`: a report written
/// before the block was read back (or edited by hand) is still a model.
fn read_equilibrium<'de, D>(
    deserializer: D,
) -> Result<Option<crate::network::equilibrium::Equilibrium>, D::Error>
where
    D: serde::Deserializer<'de>,
{
    let value = <serde_json::Value as serde::Deserialize>::deserialize(deserializer)?;
    Ok(serde_json::from_value(value).ok())
}
