//! Report stage: a [`Replay`] → the profile's JSON report and a summary table that
//! reads like the paper's results section.

use std::collections::BTreeMap;
use std::fmt::Write as _;

use nalgebra::DMatrix;
use serde::Serialize;

use crate::losses::FieldTemperatureSource;
use crate::pipeline::Replay;
use crate::recording::format_time;
use crate::spec::{ModelDescription, Scaling};

/// The profile identifier written into every report.
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

/// Fit block of the report.
#[derive(Debug, Clone, Serialize)]
pub struct FitEntry {
    /// SNR in dB (eq. 25).
    pub snr_db: Vec<f64>,
    /// NRMSE fit in %.
    pub nrmse_fit_percent: Vec<f64>,
    /// RMSE in K.
    pub rmse_k: Vec<f64>,
    /// Largest absolute error in K.
    pub max_abs_error_k: Vec<f64>,
    /// Mean squared error in K².
    pub mse_k2: Vec<f64>,
    /// Instants compared.
    pub samples: usize,
}

impl From<&crate::model::Fit> for FitEntry {
    fn from(f: &crate::model::Fit) -> Self {
        FitEntry {
            snr_db: f.snr_db.clone(),
            nrmse_fit_percent: f.nrmse_fit_percent.clone(),
            rmse_k: f.rmse_k.clone(),
            max_abs_error_k: f.max_abs_error_k.clone(),
            mse_k2: f.mse_k2.clone(),
            samples: f.samples,
        }
    }
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

/// Validation block: the fit on data not used for the estimate.
#[derive(Debug, Clone, Serialize)]
pub struct ValidationEntry {
    /// What the data were.
    pub source: String,
    /// The fit there.
    pub fit: FitEntry,
}

/// Residual analysis block.
#[derive(Debug, Clone, Serialize)]
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
#[derive(Debug, Clone, Serialize)]
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
    /// The stated reference inlet temperature, °C ([`REFERENCE_INLET_C`]).
    pub reference_inlet_c: f64,
    /// Predicted temperatures with the inlet at the reference, °C: θ_in,0 +
    /// θ_base·(−A_c⁻¹B_c u) with the inlet's entry of u at the reference.
    pub temperature_at_reference_inlet_c: Vec<f64>,
}

/// The inlet temperature the steady state is also stated at, °C: 25 °C, the water
/// inlet temperature that temperature limits of water-cooled machines are commonly stated
/// for.
pub const REFERENCE_INLET_C: f64 = 25.0;

impl InletSteadyState {
    /// The block where the states are measured from the inlet's initial level
    /// ([`crate::spec::Reference::InitialOf`]), else `None`.
    fn new(r: &Replay) -> Option<InletSteadyState> {
        use crate::spec::{InputSource, Reference};
        if !r
            .model
            .states
            .iter()
            .any(|s| matches!(s.reference, Reference::InitialOf(_)))
        {
            return None;
        }
        let (a, s) = (&r.analysis, &r.signals);
        let base = s.temperature_base_k;
        let initial_inlet_c = *s.initial_references().first()?;
        let inlet = r
            .model
            .inputs
            .iter()
            .position(|i| matches!(i.source, InputSource::BoundaryRise(_)));
        let final_rise = inlet.map_or(0.0, |j| a.steady_state_input[j]);
        let final_inlet_c = initial_inlet_c + final_rise * base;
        let rise_above_inlet_k = a
            .steady_state
            .iter()
            .map(|y| (y - final_rise) * base)
            .collect::<Vec<f64>>();
        let temperature_at_reference_inlet_c = match inlet {
            Some(j) => {
                let mut u = a.steady_state_input.clone();
                u[j] = (REFERENCE_INLET_C - initial_inlet_c) / base;
                a.continuous
                    .steady_state(&u)
                    .ok()?
                    .iter()
                    .map(|y| initial_inlet_c + y * base)
                    .collect()
            }
            // A constant inlet: the machine's rises above it, at the reference.
            None => rise_above_inlet_k
                .iter()
                .map(|x| REFERENCE_INLET_C + x)
                .collect(),
        };
        Some(InletSteadyState {
            initial_inlet_c,
            final_inlet_c,
            rise_above_inlet_k,
            reference_inlet_c: REFERENCE_INLET_C,
            temperature_at_reference_inlet_c,
        })
    }
}

/// The recording block (an extension of the profile).
#[derive(Debug, Clone, Serialize)]
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

/// Estimation details (an extension of the profile).
#[derive(Debug, Clone, Serialize)]
pub struct EstimationEntry {
    /// Grid instants.
    pub instants: usize,
    /// Equations used.
    pub equations_used: usize,
    /// Contiguous segments simulated (gaps split them).
    pub segments: usize,
    /// Condition number of the scaled regression matrix.
    pub condition_number: f64,
    /// Initial temperatures θ_0 the rises are measured from, °C.
    pub initial_temperature_c: Vec<f64>,
    /// Time of the initial temperatures, RFC 3339.
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
    /// there is this plus its initial rise (what `heatrun predict` starts from).
    pub initial_reference_c: Vec<f64>,
    /// The mean cooling-water inlet temperature over the recording, °C, where it is
    /// recorded: the coolant temperature the model's rises belong to.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub coolant_inlet_temp_c: Option<f64>,
    /// The field winding temperature as a straight line of the stator winding's
    /// (least squares over the recording), where the loss model has a field temperature:
    /// what `heatrun predict` uses for R_f when the field winding is not a state.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub field_temperature_from_stator: Option<FieldFromStator>,
}

/// θ_f ≈ intercept + slope · θ_Cu: the field winding temperature from the stator
/// winding's, fitted over the recording.
#[derive(Debug, Clone, Serialize)]
pub struct FieldFromStator {
    /// Intercept, °C.
    pub intercept_c: f64,
    /// Slope, K per K.
    pub slope: f64,
    /// RMS of the fit's residual, K.
    pub rms_residual_k: f64,
}

impl FieldFromStator {
    /// The least-squares line θ_f = a + b·θ_Cu over the instants where both are known;
    /// `None` with fewer than two such instants or no spread in θ_Cu.
    pub fn fit(stator_c: &crate::series::Series, field_c: &crate::series::Series) -> Option<Self> {
        let pairs: Vec<(f64, f64)> = stator_c
            .iter()
            .zip(field_c.iter())
            .filter_map(|(x, y)| x.zip(y))
            .collect();
        let n = pairs.len() as f64;
        let mean_x = pairs.iter().map(|p| p.0).sum::<f64>() / n;
        let mean_y = pairs.iter().map(|p| p.1).sum::<f64>() / n;
        let sxx: f64 = pairs.iter().map(|p| (p.0 - mean_x).powi(2)).sum();
        let sxy: f64 = pairs.iter().map(|p| (p.0 - mean_x) * (p.1 - mean_y)).sum();
        if pairs.len() < 2 || !(sxx > 0.0) {
            return None;
        }
        let slope = sxy / sxx;
        let intercept_c = mean_y - slope * mean_x;
        let sse: f64 = pairs
            .iter()
            .map(|p| (p.1 - intercept_c - slope * p.0).powi(2))
            .sum();
        Some(FieldFromStator {
            intercept_c,
            slope,
            rms_residual_k: (sse / n).sqrt(),
        })
    }
}

/// The report of `heatrun replay --report` (profile section "Report").
#[derive(Debug, Clone, Serialize)]
pub struct Report {
    /// Always [`PROFILE`].
    pub profile: String,
    /// heatrun's version.
    pub heatrun_version: String,
    /// Ts in s.
    pub sample_time_s: f64,
    /// Identification method.
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
    pub a_c: Vec<Vec<f64>>,
    /// B_c, row-major, 1/s.
    pub b_c: Vec<Vec<f64>>,
    /// Eigenvalues of Φ, ascending.
    pub eigenvalues_discrete: Vec<f64>,
    /// Eigenvalues of A_c, 1/s.
    pub eigenvalues_continuous: Vec<f64>,
    /// Time constants, ascending, s (−1/Re λ_c; a complex pair's twice).
    pub time_constants_s: Vec<f64>,
    /// Where A_c has complex-conjugate pairs (oscillating modes): the imaginary parts
    /// of `eigenvalues_discrete`, absent where every eigenvalue is real.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub eigenvalues_discrete_imag: Option<Vec<f64>>,
    /// Imaginary parts of `eigenvalues_continuous`, 1/s, absent where all are real.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub eigenvalues_continuous_imag: Option<Vec<f64>>,
    /// Each mode's oscillation period 2π/|Im λ_c|, s (null for a real mode), absent
    /// where all are real.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub oscillation_periods_s: Option<Vec<Option<f64>>>,
    /// Time constant → state.
    pub assignment: Vec<AssignmentEntry>,
    /// `sensitivity_norms[k][i]` = ‖T_i ∂y_k/∂T_i‖ (RMS, pu): rows states, columns time constants.
    pub sensitivity_norms: Vec<Vec<f64>>,
    /// Fit quality.
    pub fit: FitEntry,
    /// Steady state.
    pub steady_state: SteadyStateEntry,
    /// The recording.
    pub recording: RecordingEntry,
    /// The nameplate used, where the model needs one (the generator's loss model).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub nameplate: Option<crate::recording::Nameplate>,
    /// The model description: states (channel, reference, part), inputs (source, unit,
    /// kind) and scaling — what later commands need to use the model.
    pub model: ModelDescription,
    /// Estimation details.
    pub estimation: EstimationEntry,
    /// 95 % intervals, where the method gives a covariance.
    pub uncertainty: Option<UncertaintyEntry>,
    /// Fit on held-out data or another recording.
    pub validation: Option<ValidationEntry>,
    /// Whiteness and input correlation of the residuals.
    pub residuals: ResidualEntry,
    /// The passive thermal network of the model (Fig. 9), or why it has none.
    pub network: NetworkEntry,
    /// The heat the cooling water carries away against the losses (eqs. 17-18), where
    /// the flow is recorded.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub calorimetry: Option<crate::network::Calorimetry>,
    /// Whether the recording reached thermal equilibrium (IEC 60034-1; five time constants).
    pub equilibrium: crate::network::equilibrium::Equilibrium,
    /// For `rc`: the black-box output-error model it started from, on the same instants.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub output_error_beside: Option<BesideEntry>,
    /// Warnings.
    pub warnings: Vec<String>,
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

fn rows(m: &DMatrix<f64>) -> Vec<Vec<f64>> {
    (0..m.nrows())
        .map(|i| m.row(i).iter().copied().collect())
        .collect()
}

impl SteadyStateEntry {
    /// The steady state of eqs. 30-35: the rise −A_c⁻¹B_c·u (eq. 31) in K, and the
    /// temperature it means over each state's reference at the end of the recording
    /// (the initial temperature in the paper, eq. 34).
    fn new(r: &Replay) -> SteadyStateEntry {
        let a = &r.analysis;
        let s = &r.signals;
        let rise_k: Vec<f64> = a
            .steady_state
            .iter()
            .map(|y| y * s.temperature_base_k)
            .collect();
        let (last, measured_final) = s.last_measured().unwrap_or_default();
        let reference_final: Vec<f64> = s
            .states
            .iter()
            .map(|st| st.reference_at(last).unwrap_or(f64::NAN))
            .collect();
        SteadyStateEntry {
            input_pu: a.steady_state_input.clone(),
            temperature_c: rise_k
                .iter()
                .zip(&reference_final)
                .map(|(r, t)| t + r)
                .collect(),
            rise_k,
            measured_final_rise_k: measured_final
                .iter()
                .zip(&reference_final)
                .map(|(m, t)| m - t)
                .collect(),
            measured_final_temperature_c: measured_final,
            coolant_inlet: InletSteadyState::new(r),
        }
    }
}

impl RecordingEntry {
    fn new(r: &Replay) -> RecordingEntry {
        RecordingEntry {
            path: r.path.display().to_string(),
            file_bytes: r.recording.file_bytes,
            start: r.recording.time_span_ns.map(|(a, _)| format_time(a)),
            end: r.recording.time_span_ns.map(|(_, b)| format_time(b)),
            channels: r
                .recording
                .channels
                .iter()
                .zip(&r.decimated.channels)
                .map(|(c, g)| ChannelEntry {
                    topic: c.topic.clone(),
                    quantity: c.signal.name().into(),
                    sensor: c.sensor.clone(),
                    unit: c.unit.clone(),
                    samples: r.recording.samples_per_channel[c.index],
                    nominal_period_s: g.nominal_period_s,
                    gaps: g.gaps,
                })
                .collect(),
            ignored_channels: r.recording.ignored_channels.clone(),
            bad_quality_dropped: r.recording.bad_quality_dropped,
            data_loss: r.recording.data_loss.clone(),
            metadata: r.recording.metadata.clone(),
        }
    }
}

impl EstimationEntry {
    fn new(r: &Replay) -> EstimationEntry {
        let s = &r.signals;
        let k0 = s.initial_index;
        EstimationEntry {
            instants: r.data.len(),
            equations_used: r.estimate.rows_used,
            segments: r.data.segments().len(),
            condition_number: r.estimate.condition_number,
            initial_temperature_c: s
                .states
                .iter()
                .map(|st| st.measured.get(k0).unwrap_or(f64::NAN))
                .collect(),
            initial_time: format_time(s.time_ns[k0].max(0) as u64),
            field_temperature: s.field_temperature.as_ref().map(|f| f.source.clone()),
            temperature_base_k: s.temperature_base_k,
            power_base_mva: (r.model.scaling == Scaling::NameplatePerUnit)
                .then(|| s.power_base / 1e6),
            initial_reference_c: s.initial_references(),
            coolant_inlet_temp_c: r
                .decimated
                .get(crate::recording::Quantity::CoolingWaterInletTemp)
                .and_then(|inlet| {
                    let known: Vec<f64> = inlet.values.iter().flatten().collect();
                    (!known.is_empty()).then(|| known.iter().sum::<f64>() / known.len() as f64)
                }),
            field_temperature_from_stator: s.field_temperature.as_ref().and_then(|f| {
                let stator = r
                    .decimated
                    .get(crate::recording::Quantity::StatorWindingTemp)?;
                FieldFromStator::fit(&stator.values, &f.values)
            }),
        }
    }
}

impl Report {
    /// Builds the report of a replay.
    pub fn new(r: &Replay) -> Report {
        let a = &r.analysis;
        let base = r.signals.temperature_base_k;
        let states = &r.signals.states;
        let oscillating = a.spectrum.has_oscillating_modes();
        Report {
            profile: PROFILE.into(),
            heatrun_version: env!("CARGO_PKG_VERSION").into(),
            sample_time_s: r.signals.ts_s,
            method: r.estimate.method.to_string(),
            states: states.iter().map(|s| s.name.clone()).collect(),
            inputs: r.signals.inputs.iter().map(|i| i.name.clone()).collect(),
            phi: rows(&r.estimate.model.phi),
            gamma: rows(&r.estimate.model.gamma),
            a_c: rows(&a.continuous.a_c),
            b_c: rows(&a.continuous.b_c),
            eigenvalues_discrete: a.spectrum.eigenvalues_discrete.clone(),
            eigenvalues_continuous: a.spectrum.eigenvalues_continuous.clone(),
            time_constants_s: a.spectrum.time_constants_s.clone(),
            eigenvalues_discrete_imag: oscillating
                .then(|| a.spectrum.eigenvalues_discrete_imag.clone()),
            eigenvalues_continuous_imag: oscillating
                .then(|| a.spectrum.eigenvalues_continuous_imag.clone()),
            oscillation_periods_s: oscillating.then(|| a.spectrum.oscillation_periods_s.clone()),
            assignment: a
                .assignment
                .iter()
                .map(|x| AssignmentEntry {
                    time_constant_s: x.time_constant_s,
                    oscillation_period_s: x.oscillation_period_s,
                    state: states[x.state].name.clone(),
                    sensitivity_norm: x.sensitivity_norm,
                    part: states[x.state].part.clone(),
                })
                .collect(),
            sensitivity_norms: a.sensitivities.norms.clone(),
            fit: FitEntry::from(&a.fit),
            steady_state: SteadyStateEntry::new(r),
            recording: RecordingEntry::new(r),
            nameplate: r.nameplate.clone(),
            model: r.model.clone(),
            estimation: EstimationEntry::new(r),
            uncertainty: a.uncertainty.as_ref().map(|u| {
                let p = r.estimate.model.phi.nrows() + r.estimate.model.gamma.ncols();
                UncertaintyEntry {
                    time_constants_ci95_s: u.time_constants_ci95_s.clone(),
                    steady_state_ci95_k: u.steady_state_ci95.iter().map(|v| v * base).collect(),
                    theta_standard_error: u
                        .theta_standard_error
                        .chunks(p)
                        .map(|c| c.to_vec())
                        .collect(),
                }
            }),
            validation: r.validation.as_ref().map(|v| ValidationEntry {
                source: v.source.clone(),
                fit: FitEntry::from(&v.fit),
            }),
            residuals: ResidualEntry {
                max_lag: a.residuals.max_lag,
                band99: a.residuals.band99,
                autocorrelation: a.residuals.autocorrelation.clone(),
                cross_correlation: a.residuals.cross_correlation.clone(),
                autocorrelation_outside_band: a.residuals.autocorrelation_outside_band.clone(),
                max_abs_cross_correlation: a
                    .residuals
                    .cross_correlation
                    .iter()
                    .map(|per_input| {
                        per_input
                            .iter()
                            .map(|c| c.iter().fold(0.0_f64, |m, v| m.max(v.abs())))
                            .collect()
                    })
                    .collect(),
            },
            network: match &r.network.network {
                Ok(n) => NetworkEntry::Defined(Box::new(n.clone())),
                Err(why) => NetworkEntry::NotDefined {
                    not_defined: why.clone(),
                },
            },
            calorimetry: r.network.calorimetry.clone(),
            equilibrium: r.network.equilibrium.clone(),
            output_error_beside: r.output_error_beside.as_ref().map(|b| BesideEntry {
                method: b.method.to_string(),
                time_constants_s: b.time_constants_s.clone(),
                fit: FitEntry::from(&b.fit),
            }),
            warnings: r.warnings.clone(),
        }
    }

    /// The report as pretty-printed JSON.
    pub fn to_json(&self) -> String {
        // Serialising plain numbers, strings and maps cannot fail.
        serde_json::to_string_pretty(self).unwrap_or_else(|e| format!("{{\"error\": \"{e}\"}}"))
    }

    /// A summary that reads like the paper's results section.
    pub fn summary(&self) -> String {
        let mut s = String::new();
        self.summary_recording(&mut s);
        self.summary_model(&mut s);
        self.summary_time_constants(&mut s);
        self.summary_fit(&mut s);
        self.summary_steady_state(&mut s);
        self.summary_residuals(&mut s);
        self.summary_network(&mut s);
        for w in &self.warnings {
            let _ = writeln!(s, "warning: {w}");
        }
        s
    }

    /// Short labels of the states for table columns: the part up to a parenthesis
    /// ("stator winding (copper)" → "stator winding").
    fn state_labels(&self) -> Vec<&str> {
        self.model
            .states
            .iter()
            .map(|st| st.part.split(" (").next().unwrap_or(&st.part))
            .collect()
    }

    fn summary_recording(&self, s: &mut String) {
        let rec = &self.recording;
        let duration = self.estimation.instants as f64 * self.sample_time_s;
        let what = match self.model.scaling {
            Scaling::NameplatePerUnit => "heat run",
            Scaling::AsRecorded => self.model.name.as_str(),
        };
        let _ = writeln!(s, "{what} {}", rec.path);
        let _ = writeln!(
            s,
            "  {} to {} ({:.0} s, {:.1} h), {} channels, Ts = {} s: {} instants, {} equations, {} segment(s)",
            rec.start.as_deref().unwrap_or("?"),
            rec.end.as_deref().unwrap_or("?"),
            duration,
            duration / 3600.0,
            rec.channels.len(),
            self.sample_time_s,
            self.estimation.instants,
            self.estimation.equations_used,
            self.estimation.segments
        );
        let field = match &self.estimation.field_temperature {
            None => String::new(),
            Some(FieldTemperatureSource::Measured) => "; field temperature: measured".to_owned(),
            Some(FieldTemperatureSource::ResistanceMethod) => {
                "; field temperature: resistance method U_f/I_f".to_owned()
            }
            Some(FieldTemperatureSource::ScaledArmatureRise {
                scale,
                final_temp_c,
            }) => {
                format!("; field temperature: armature rise × {scale:.4} (final {final_temp_c} °C)")
            }
        };
        let _ = writeln!(
            s,
            "  method {} (condition number {:.3e}); θ_0 = [{}] °C{field}",
            self.method,
            self.estimation.condition_number,
            join(&self.estimation.initial_temperature_c, |v| format!(
                "{v:.2}"
            )),
        );
        let _ = writeln!(s);
    }

    fn summary_model(&self, s: &mut String) {
        matrix(s, "Φ (eq. 19)", &self.phi, 8);
        matrix(s, "Γ (eq. 20)", &self.gamma, 7);
        let delayed: Vec<String> = self
            .model
            .inputs
            .iter()
            .filter(|i| i.delay_s > 0.0)
            .map(|i| {
                let d = (i.delay_s / self.sample_time_s).round();
                format!("{} {} s (d = {d})", i.name, i.delay_s)
            })
            .collect();
        if !delayed.is_empty() {
            let _ = writeln!(
                s,
                "input dead times, x(k+1) = Φx(k) + Γu(k − d): {}",
                delayed.join(", ")
            );
        }
        let advanced: Vec<String> = self
            .model
            .inputs
            .iter()
            .filter(|i| i.delay_s < 0.0)
            .map(|i| format!("{} {} s", i.name, -i.delay_s))
            .collect();
        if !advanced.is_empty() {
            let _ = writeln!(
                s,
                "inputs advanced one sample (an interval's mean stamped at its end; non-causal in the recorded series), x(k+1) = Φx(k) + Γu(k + 1): {}",
                advanced.join(", ")
            );
        }
        let _ = writeln!(
            s,
            "eigenvalues of Φ (eq. 21): [{}]",
            complex_list(
                &self.eigenvalues_discrete,
                self.eigenvalues_discrete_imag.as_deref(),
                5
            )
        );
        matrix(s, "A_c (eq. 22), 1/s", &self.a_c, 8);
        matrix(s, "B_c (eq. 23), 1/s", &self.b_c, 7);
        let _ = writeln!(
            s,
            "eigenvalues of A_c (eq. 24): [{}] 1/s",
            complex_list(
                &self.eigenvalues_continuous,
                self.eigenvalues_continuous_imag.as_deref(),
                6
            )
        );
    }

    fn summary_time_constants(&self, s: &mut String) {
        let _ = writeln!(
            s,
            "time constants (eq. 26), 95 % intervals, and the part each belongs to (eqs. 27-29):"
        );
        for (i, a) in self.assignment.iter().enumerate() {
            let ci = self
                .uncertainty
                .as_ref()
                .map(|u| format!("± {:<8.2}", u.time_constants_ci95_s[i]))
                .unwrap_or_else(|| " ".repeat(10));
            let period = a
                .oscillation_period_s
                .map(|p| format!(" (oscillating mode, period {p:.1} s)"))
                .unwrap_or_default();
            let _ = writeln!(
                s,
                "  T{} = {:>9.2} s {ci} -> {:<24} ‖T ∂y/∂T‖ = {:.3e} {}{period}",
                i + 1,
                a.time_constant_s,
                a.part,
                a.sensitivity_norm,
                self.state_unit()
            );
        }
        let _ = writeln!(
            s,
            "sensitivity norms ‖T_i ∂y_k/∂T_i‖, {} (rows: states; columns: T1..Tn):",
            self.state_unit()
        );
        for (label, row) in self.state_labels().iter().zip(&self.sensitivity_norms) {
            let _ = writeln!(s, "  {label:<16}{}", join(row, |v| format!("{v:>11.3e}")));
        }
        let _ = writeln!(s);
    }

    /// The unit of the states in the model's scaling.
    fn state_unit(&self) -> &'static str {
        match self.model.scaling {
            Scaling::NameplatePerUnit => "pu",
            Scaling::AsRecorded => "K",
        }
    }

    fn summary_fit(&self, s: &mut String) {
        let header: String = self
            .state_labels()
            .iter()
            .map(|l| format!("{l:>16}"))
            .collect();
        let _ = writeln!(s, "fit of the simulated model (eq. 8) {header}");
        row(s, "  SNR, dB (eq. 25)", &self.fit.snr_db, 3);
        row(s, "  NRMSE fit, %", &self.fit.nrmse_fit_percent, 2);
        row(s, "  RMSE, K", &self.fit.rmse_k, 3);
        row(s, "  largest error, K", &self.fit.max_abs_error_k, 3);
        if let Some(b) = &self.output_error_beside {
            let _ = writeln!(
                s,
                "beside it, {} (black box, the start of {}): time constants [{}] s",
                b.method,
                self.method,
                join(&b.time_constants_s, |v| format!("{v:.2}"))
            );
            row(s, "  NRMSE fit, %", &b.fit.nrmse_fit_percent, 2);
            row(s, "  RMSE, K", &b.fit.rmse_k, 3);
        }
    }

    fn summary_steady_state(&self, s: &mut String) {
        let ss = &self.steady_state;
        let units: Vec<&str> = self.model.inputs.iter().map(|i| i.unit.as_str()).collect();
        let unit = if units.iter().all(|u| *u == units[0]) {
            units[0].to_owned()
        } else {
            format!("({})", units.join(", "))
        };
        let _ = writeln!(s);
        let _ = writeln!(
            s,
            "steady state for u = [{}] {unit} (eqs. 30-35)",
            join(&ss.input_pu, |v| format!("{v:.7}"))
        );
        row(s, "  predicted rise, K (eq. 32)", &ss.rise_k, 3);
        if let Some(u) = &self.uncertainty {
            row(s, "    95 % interval, ± K", &u.steady_state_ci95_k, 3);
        }
        row(
            s,
            "  measured final rise, K (eq. 33)",
            &ss.measured_final_rise_k,
            3,
        );
        row(
            s,
            "  predicted temperature, °C (eq. 34)",
            &ss.temperature_c,
            3,
        );
        row(
            s,
            "  measured final temperature, °C (35)",
            &ss.measured_final_temperature_c,
            3,
        );
        if let Some(c) = &ss.coolant_inlet {
            row(
                s,
                &format!("  rise above the inlet ({:.2} °C), K", c.final_inlet_c),
                &c.rise_above_inlet_k,
                3,
            );
            row(
                s,
                &format!("  temperature at inlet {:.1} °C, °C", c.reference_inlet_c),
                &c.temperature_at_reference_inlet_c,
                3,
            );
        }
    }

    fn summary_network(&self, s: &mut String) {
        let _ = writeln!(s);
        match &self.network {
            NetworkEntry::NotDefined { not_defined } => {
                let _ = writeln!(s, "thermal network (Fig. 9): none: {not_defined}");
            }
            NetworkEntry::Defined(n) => {
                let scale = match n.scale_from {
                    crate::network::ScaleSource::Calorimetric => "calorimetric, c·ρ·Q",
                    crate::network::ScaleSource::EnergyConservation => {
                        "energy conservation, Σ_i k_ij = 1"
                    }
                };
                let _ = writeln!(s, "thermal network (Fig. 9), scale from {scale}:");
                if let Some(note) = &n.scale_note {
                    let _ = writeln!(s, "  ({note})");
                }
                if let (Some(from), Some(d)) = (&n.fitted_from, &n.minimum_distance) {
                    let _ = writeln!(s, "  ({})", minimum_distance_line(from, d));
                }
                let labels = self.state_labels();
                row(
                    s,
                    "  capacitance C, MJ/K",
                    &scaled(&n.capacitance_j_per_k, 1e-6),
                    3,
                );
                if let Some(iv) = &n.intervals_95 {
                    interval_row(s, "    95 % interval", &iv.capacitance_j_per_k, 1e-6);
                }
                let to_coolant: Vec<f64> = (0..labels.len())
                    .map(|i| n.conductance_w_per_k[i][i] * 1e-3)
                    .collect();
                row(s, "  conductance to coolant G_i0, kW/K", &to_coolant, 3);
                let iv = n.intervals_95.as_ref();
                if let Some(iv) = iv {
                    let diagonal: Vec<_> = (0..labels.len())
                        .map(|i| iv.conductance_w_per_k[i][i])
                        .collect();
                    interval_row(s, "    95 % interval", &diagonal, 1e-3);
                }
                for (i, a) in labels.iter().enumerate() {
                    for (j, b) in labels.iter().enumerate().skip(i + 1) {
                        let ci = iv
                            .map(|iv| {
                                format!(" ({})", interval(iv.conductance_w_per_k[i][j], 1e-3, 3))
                            })
                            .unwrap_or_default();
                        let _ = writeln!(
                            s,
                            "  G between {a} and {b}: {:.3} kW/K{ci}",
                            n.conductance_w_per_k[i][j] * 1e-3
                        );
                    }
                }
                for (j, input) in n.inputs.iter().enumerate() {
                    let k: Vec<f64> = n.loss_distribution.iter().map(|r| r[j]).collect();
                    row(s, &format!("  share of {input}"), &k, 3);
                    if let Some(iv) = iv {
                        let column: Vec<_> = iv.loss_distribution.iter().map(|r| r[j]).collect();
                        interval_row(s, "    95 % interval", &column, 1.0);
                    }
                }
                if let Some(alt) = &n.alternative_scale {
                    let _ = writeln!(
                        s,
                        "  the other scale gives {:.3} times these capacitances",
                        alt.ratio_to_chosen
                    );
                }
                let _ = writeln!(s, "  {}", n.passivity.verdict);
            }
        }
        if let Some(c) = &self.calorimetry {
            if let (Some(e), Some(l)) = (c.end_of_run, c.losses_end_of_run_pu) {
                let _ = writeln!(
                    s,
                    "calorimetric balance (eqs. 17-18), end of run: the water carries away {:.1} kW = {:.5} pu \
                     against losses of {l:.5} pu ({:.0} %; Q = {:.1} l/s, inlet {})",
                    e.watts * 1e-3,
                    e.pu,
                    100.0 * e.pu / l,
                    c.mean_flow_l_per_s,
                    c.inlet.replace('_', " ")
                );
            }
        }
        let e = &self.equilibrium;
        let rates: Vec<String> = e
            .rate_of_rise
            .iter()
            .map(|r| r.map_or("?".into(), |r| format!("{:+.2}", r.k_per_h)))
            .collect();
        let _ = writeln!(
            s,
            "equilibrium: rise over the last hour [{}] K/h (IEC 60034-1: within ±{} K/h: {}); \
             final load held {:.1} × the slowest time constant ({:.1} % of its rise)",
            rates.join(" "),
            e.iec_limit_k_per_h,
            if e.iec_equilibrium { "yes" } else { "no" },
            e.held_over_slowest,
            100.0 * e.fraction_of_final_rise_reached
        );
    }

    fn summary_residuals(&self, s: &mut String) {
        let res = &self.residuals;
        let _ = writeln!(s);
        let _ = writeln!(
            s,
            "residuals (simulation error): lags 1-{} outside the 99 % band ±{:.4}, % of lags",
            res.max_lag, res.band99
        );
        let outside: Vec<f64> = res
            .autocorrelation_outside_band
            .iter()
            .map(|v| v * 100.0)
            .collect();
        row(s, "  autocorrelation", &outside, 1);
        let worst: Vec<f64> = res
            .max_abs_cross_correlation
            .iter()
            .map(|r| r.iter().fold(0.0_f64, |m, v| m.max(*v)))
            .collect();
        row(s, "  largest |cross-correlation| with u", &worst, 3);
        if let Some(v) = &self.validation {
            let _ = writeln!(s);
            let _ = writeln!(s, "validation on {} ({} instants)", v.source, v.fit.samples);
            row(s, "  NRMSE fit, %", &v.fit.nrmse_fit_percent, 2);
            row(s, "  MSE, K²", &v.fit.mse_k2, 4);
            row(s, "  largest error, K", &v.fit.max_abs_error_k, 3);
        }
    }
}

/// "low–high" of an interval times `factor`, or "unbounded".
fn interval(i: Option<crate::network::Interval>, factor: f64, digits: usize) -> String {
    match i {
        Some(i) => format!("{:.digits$}–{:.digits$}", i.low * factor, i.high * factor),
        None => "unbounded".into(),
    }
}

/// A row of intervals in the columns of [`row`].
fn interval_row(s: &mut String, label: &str, v: &[Option<crate::network::Interval>], factor: f64) {
    let cells: String = v
        .iter()
        .map(|i| format!("{:>16}", interval(*i, factor, 3)))
        .collect();
    let _ = writeln!(s, "{label:<37}{cells}");
}

fn scaled(v: &[f64], factor: f64) -> Vec<f64> {
    v.iter().map(|x| x * factor).collect()
}

fn join(v: &[f64], f: impl Fn(f64) -> String) -> String {
    v.iter().map(|x| f(*x)).collect::<Vec<_>>().join(" ")
}

fn matrix(s: &mut String, title: &str, m: &[Vec<f64>], digits: usize) {
    let _ = writeln!(s, "{title}:");
    for r in m {
        let _ = writeln!(
            s,
            "  [{}]",
            join(r, |v| format!("{v:>width$.digits$}", width = digits + 5))
        );
    }
}

fn row(s: &mut String, label: &str, v: &[f64], digits: usize) {
    let _ = writeln!(s, "{label:<37}{}", join(v, |x| format!("{x:>16.digits$}")));
}

/// Eigenvalues as `re` or `re±imi` (a complex pair), `digits` decimals, space-separated.
fn complex_list(re: &[f64], im: Option<&[f64]>, digits: usize) -> String {
    re.iter()
        .enumerate()
        .map(|(i, r)| match im.map(|im| im[i]).filter(|v| *v != 0.0) {
            Some(v) => format!("{r:.digits$}{v:+.digits$}i"),
            None => format!("{r:.digits$}"),
        })
        .collect::<Vec<_>>()
        .join(" ")
}

/// What the network was fitted from, with its distance and χ² test, in one line.
fn minimum_distance_line(from: &str, d: &crate::network::MinimumDistance) -> String {
    match d.p_value {
        Some(p) => {
            // A χ² test of Θ̂ against the network family: it also flags a Θ̂ biased by
            // anything its covariance does not hold (e.g. the first sample's offset).
            let meaning = if p < 0.01 {
                "the identified model is farther from a passive, energy-conserving network than its covariance explains"
            } else {
                "within what the identified model's covariance explains"
            };
            let chi2 = if d.distance < 1e4 {
                format!("{:.2}", d.distance)
            } else {
                format!("{:.2e}", d.distance)
            };
            format!(
                "the passive network nearest the identified model: {from}, χ² = {chi2} on {} degrees of freedom, p = {p:.2e}: {meaning}",
                d.degrees_of_freedom
            )
        }
        None => format!(
            "the passive network nearest the identified model: {from}, distance {:.3e} ({})",
            d.distance, d.weighting
        ),
    }
}
