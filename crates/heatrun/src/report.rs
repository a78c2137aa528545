//! Report stage: a [`Replay`] → the profile's JSON report ([`Report::new`]) and a summary
//! table that reads like the paper's results section ([`Report::summary`]).
//!
//! The document itself, [`Report`] and its blocks, lives in [`crate::model_file`], below
//! every stage, where the uses of the model read it back; this module builds it from a
//! replay, and so sits above the pipeline.

use std::fmt::Write as _;

use nalgebra::DMatrix;

use crate::losses::FieldTemperatureSource;
use crate::model_file::document::{
    AssignmentEntry, BesideEntry, ChannelEntry, DisturbanceEntry, EstimationEntry,
    EstimatorChoiceEntry, FieldFromStator, FitEntry, GapsEntry, InletSteadyState, InputGapsEntry,
    LeftOutEntry, NetworkEntry, RecordingEntry, ResidualEntry, SteadyStateEntry, UncertaintyEntry,
    UnobservedEntry, ValidationEntry,
};
use crate::model_file::document::{
    HiddenCandidateEntry, HiddenCovarianceEntry, HiddenEntry, MeasuredStateEntry,
};
use crate::model_file::{Report, PROFILE};
use crate::pipeline::Replay;
use crate::recording::format_time;
use crate::spec::Scaling;

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

/// The inlet temperature the steady state is also stated at, °C: 25 °C, the water
/// inlet temperature that temperature limits of water-cooled machines are commonly stated
/// for.
pub const REFERENCE_INLET_C: f64 = 25.0;

/// A replay with its report and the report's summary: the one result view that the text
/// summary, the JSON, the HTML page and the rerun recording all read, made once.
#[derive(Debug, Clone)]
pub struct Replayed {
    /// What the pipeline found (the series on the grid, the estimate's details).
    pub replay: Replay,
    /// Its report (the figures, as written to JSON).
    pub report: Report,
    /// The report's paper-style summary, as printed and published.
    pub summary: String,
}

impl Replayed {
    /// The report and the summary of `replay`, made once.
    pub fn new(replay: Replay) -> Replayed {
        let report = Report::new(&replay);
        let summary = report.summary();
        Replayed {
            replay,
            report,
            summary,
        }
    }
}

/// The steady state against the coolant inlet where the states are measured from the
/// inlet's initial level ([`crate::spec::Reference::InitialOf`]), else `None`.
fn inlet_steady_state(
    r: &Replay,
    steady_state: &[f64],
    solve: &dyn Fn(&[f64]) -> Option<Vec<f64>>,
) -> Option<InletSteadyState> {
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
    let rise_above_inlet_k = steady_state
        .iter()
        .map(|y| (y - final_rise) * base)
        .collect::<Vec<f64>>();
    let temperature_at_reference_inlet_c = match inlet {
        Some(j) => {
            let mut u = a.steady_state_input.clone();
            u[j] = (REFERENCE_INLET_C - initial_inlet_c) / base;
            solve(&u)?
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

/// The least-squares line θ_f = a + b·θ_Cu over the instants where both are known;
/// `None` with fewer than two such instants or no spread in θ_Cu.
fn field_from_stator(
    stator_c: &crate::series::Series,
    field_c: &crate::series::Series,
) -> Option<FieldFromStator> {
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

fn rows(m: &DMatrix<f64>) -> Vec<Vec<f64>> {
    (0..m.nrows())
        .map(|i| m.row(i).iter().copied().collect())
        .collect()
}

/// The state names of a replay, in model order.
fn report_states(r: &Replay) -> Vec<String> {
    r.signals.states.iter().map(|s| s.name.clone()).collect()
}

/// The hidden-state model's block: its matrices, time constants, steady-state gain, the
/// orders tried and its fits.
fn hidden_entry(h: &crate::pipeline::HiddenReplay, outputs: &[String]) -> HiddenEntry {
    let e = &h.estimate;
    let m = &e.model;
    let state_names = crate::model_file::hidden::state_names(&m.c, outputs);
    HiddenEntry {
        // The spec declares it: it is the replay's model (`hidden_as_the_model`).
        replay_model: true,
        measured: state_names.iter().map(|n| outputs.contains(n)).collect(),
        state_names,
        order: m.order(),
        order_source: match e.options.order {
            crate::hidden::OrderChoice::Given(_) => "given".into(),
            crate::hidden::OrderChoice::Chosen { .. } => "chosen on the estimation data".into(),
        },
        output_matrix: match e.options.output_matrix {
            crate::hidden::OutputMatrix::Measured => "measured".into(),
            crate::hidden::OutputMatrix::Free => "free".into(),
        },
        phi: rows(&m.phi),
        gamma: rows(&m.gamma),
        c: rows(&m.c),
        d: rows(&m.d),
        time_constants_s: m.time_constants_s().unwrap_or_default(),
        steady_state_gain: m.steady_state_gain().as_ref().map(rows).unwrap_or_default(),
        singular_values: e.singular_values.clone(),
        candidates: e
            .candidates
            .iter()
            .map(|c| HiddenCandidateEntry {
                order: c.order,
                hold_back_fit_percent: c.hold_back_fit_percent,
                aic: c.aic,
                refused: c.refused.clone(),
            })
            .collect(),
        fit: FitEntry::from(&h.fit),
        validation: h.validation.as_ref().map(|v| ValidationEntry {
            source: v.source.clone(),
            fit: FitEntry::from(&v.fit),
        }),
        parameter_covariance: h.covariance.as_ref().map(|c| HiddenCovarianceEntry {
            layout: crate::model_file::HIDDEN_COVARIANCE_LAYOUT.into(),
            matrix: rows(&c.covariance),
            output_noise_variance: c.noise_variance.clone(),
            basis_directions: c.basis_directions,
            correlation_window: Some(c.correlation_window),
        }),
    }
}

/// The steady state of eqs. 30-35: the rise −A_c⁻¹B_c·u (eq. 31) in K, and the
/// temperature it means over each state's reference at the end of the recording (the
/// initial temperature in the paper, eq. 34).
fn steady_state_entry(
    r: &Replay,
    steady_state: &[f64],
    solve: &dyn Fn(&[f64]) -> Option<Vec<f64>>,
) -> SteadyStateEntry {
    let a = &r.analysis;
    let s = &r.signals;
    let rise_k: Vec<f64> = steady_state
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
        coolant_inlet: inlet_steady_state(r, steady_state, solve),
    }
}

/// The measured-state model's steady state (eqs. 30–35): −A_c⁻¹B_c u.
fn measured_steady_state_entry(r: &Replay) -> SteadyStateEntry {
    let c = &r.analysis.continuous;
    steady_state_entry(r, &r.analysis.steady_state, &|u| c.steady_state(u).ok())
}

/// Makes the hidden-state model the report's model (the spec declares `[hidden]`): its
/// time constants, assignment (to the measured output each changes most), sensitivity
/// norms, steady state y_ss = (C (I − Φ)⁻¹ Γ + D) u, fit and validation take the
/// top-level keys, and the measured-state model's figures move to `measured_state`.
/// Φ, Γ and the measured-state model's analysis (A_c, eigenvalues, residuals, network,
/// `theta_covariance`) stay where they were.
fn hidden_as_the_model(report: &mut Report, r: &Replay, h: &crate::pipeline::HiddenReplay) {
    use std::mem::take;
    report.measured_state = Some(MeasuredStateEntry {
        time_constants_s: take(&mut report.time_constants_s),
        assignment: take(&mut report.assignment),
        sensitivity_norms: take(&mut report.sensitivity_norms),
        fit: report.fit.clone(),
        steady_state: take(&mut report.steady_state),
        uncertainty: report.uncertainty.take(),
        validation: report.validation.take(),
    });
    let states = &r.signals.states;
    let model = &h.estimate.model;
    let gain = model.steady_state_gain();
    let solve = |u: &[f64]| {
        gain.as_ref().map(|g| {
            (g * nalgebra::DVector::from_column_slice(u))
                .iter()
                .copied()
                .collect()
        })
    };
    match &h.analysis {
        Some(a) => {
            let sp = &a.spectrum;
            report.time_constants_s = sp.time_constants_s.clone();
            report.assignment = (a.assignment.iter().zip(&sp.time_constants_s))
                .zip(&sp.oscillation_periods_s)
                .map(|((&(j, norm), &t), &period)| AssignmentEntry {
                    time_constant_s: t,
                    oscillation_period_s: period,
                    state: states[j].name.clone(),
                    sensitivity_norm: norm,
                    part: states[j].part.clone(),
                })
                .collect();
            report.sensitivity_norms = a.norms.clone();
            report.steady_state = steady_state_entry(r, &a.steady_state, &solve);
        }
        None => {
            report.time_constants_s = model.time_constants_s().unwrap_or_default();
            if let Some(y) = solve(&r.analysis.steady_state_input) {
                report.steady_state = steady_state_entry(r, &y, &solve);
            }
        }
    }
    report.fit = FitEntry::from(&h.fit);
    report.validation = h.validation.as_ref().map(|v| ValidationEntry {
        source: v.source.clone(),
        fit: FitEntry::from(&v.fit),
    });
}

/// The recording block: the file, its channels and what was lost or ignored.
fn recording_entry(r: &Replay) -> RecordingEntry {
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

/// The estimation block: the grid, the regression, and what a use of the model starts
/// from (initial temperatures and references, bases, coolant, field winding).
fn estimation_entry(r: &Replay) -> EstimationEntry {
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
        power_base_mva: (r.model.scaling == Scaling::NameplatePerUnit).then(|| s.power_base / 1e6),
        initial_reference_c: Some(s.initial_references()),
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
            field_from_stator(&stator.values, &f.values)
        }),
        gaps: gaps_entry(s),
    }
}

/// What the replay did with missing samples, in a line: each input's gaps bridged or
/// cut, each state's unobserved instants.
fn gaps_line(gaps: &GapsEntry) -> String {
    let mut parts: Vec<String> = gaps
        .unobserved
        .iter()
        .map(|u| {
            format!(
                "{} {} instant(s) unobserved (simulated through)",
                u.state, u.instants
            )
        })
        .collect();
    for i in &gaps.inputs {
        let g = &i.gaps;
        let how = match g.bridge {
            crate::signals::Bridge::Hold => "held",
            crate::signals::Bridge::Interpolate => "interpolated",
        };
        if g.bridged > 0 {
            parts.push(format!(
                "input {} {} gap(s) bridged ({how}, longest {} s)",
                i.input, g.bridged, g.longest_bridged_s
            ));
        }
        if g.cut > 0 {
            parts.push(format!(
                "input {} {} gap(s) longer than {} s cut the data ({} instants; each next segment's initial state estimated)",
                i.input, g.cut, gaps.bridge_limit_s, g.cut_instants
            ));
        }
    }
    parts.join("; ")
}

/// The inputs' gaps and the states' unobserved instants, where there are any.
fn gaps_entry(s: &crate::signals::ModelSignals) -> Option<GapsEntry> {
    let inputs: Vec<InputGapsEntry> = s
        .inputs
        .iter()
        .filter(|i| i.gaps.any())
        .map(|i| InputGapsEntry {
            input: i.name.clone(),
            gaps: i.gaps.clone(),
        })
        .collect();
    let unobserved: Vec<UnobservedEntry> = s
        .states
        .iter()
        .enumerate()
        .filter(|(_, st)| st.observed.is_none())
        .map(|(j, st)| UnobservedEntry {
            state: st.name.clone(),
            instants: (s.initial_index..s.len())
                .filter(|&k| s.rise_pu(j, k).is_none())
                .count(),
        })
        .filter(|u| u.instants > 0)
        .collect();
    (!inputs.is_empty() || !unobserved.is_empty()).then_some(GapsEntry {
        bridge_limit_s: crate::signals::INPUT_GAP_BRIDGED_S,
        inputs,
        unobserved,
    })
}

/// The report's block of a residual analysis (the simulation's or the predictor's).
fn residual_entry(res: &crate::model::ResidualAnalysis) -> ResidualEntry {
    ResidualEntry {
        max_lag: res.max_lag,
        band99: res.band99,
        autocorrelation: res.autocorrelation.clone(),
        cross_correlation: res.cross_correlation.clone(),
        autocorrelation_outside_band: res.autocorrelation_outside_band.clone(),
        max_abs_cross_correlation: res
            .cross_correlation
            .iter()
            .map(|per_input| {
                per_input
                    .iter()
                    .map(|c| c.iter().fold(0.0_f64, |m, v| m.max(v.abs())))
                    .collect()
            })
            .collect(),
    }
}

impl Report {
    /// Builds the report of a replay.
    pub fn new(r: &Replay) -> Report {
        let a = &r.analysis;
        let base = r.signals.temperature_base_k;
        let states = &r.signals.states;
        let oscillating = a.spectrum.has_oscillating_modes();
        let mut report = Report {
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
            steady_state: measured_steady_state_entry(r),
            recording: recording_entry(r),
            nameplate: r.nameplate.clone(),
            model: r.model.clone(),
            estimation: estimation_entry(r),
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
            residuals: residual_entry(&a.residuals),
            innovations: a.innovations.as_ref().map(residual_entry),
            estimator_choice: r.estimator_choice.as_ref().map(|c| EstimatorChoiceEntry {
                method: c.method.to_string(),
                reason: c.reason.clone(),
                oe_autocorrelation_outside_band: c.oe_autocorrelation_outside_band.clone(),
                threshold: c.threshold,
                oe_ljung_box: c.oe_ljung_box.clone(),
                likelihood_ratio: c.likelihood_ratio,
            }),
            decisions: r.decisions.clone(),
            kalman_gain: r.estimate.predictor.as_ref().map(|p| rows(&p.gain)),
            disturbance: r
                .estimate
                .predictor
                .as_ref()
                .and_then(|p| p.disturbance.as_ref())
                .map(|d| DisturbanceEntry {
                    state: r
                        .signals
                        .states
                        .get(d.state)
                        .map_or_else(String::new, |s| s.name.clone()),
                    gain: d.gain.clone(),
                    increment_sd_k: d.increment_sd * r.signals.temperature_base_k,
                }),
            innovation_variance: r
                .estimate
                .predictor
                .as_ref()
                .map(|p| p.innovation_variance.clone()),
            // Only where the analysis propagated it: the covariance of the report's Φ, Γ.
            theta_covariance: a
                .uncertainty
                .as_ref()
                .and(r.estimate.interval_covariance())
                .map(rows),
            theta_covariance_window: a
                .uncertainty
                .as_ref()
                .and(r.estimate.robust_covariance.as_ref())
                .map(|c| c.correlation_window),
            network: Some(match &r.network.network {
                Ok(n) => NetworkEntry::Defined(Box::new(n.clone())),
                Err(why) => NetworkEntry::NotDefined {
                    not_defined: why.clone(),
                },
            }),
            calorimetry: r.network.calorimetry.clone(),
            equilibrium: Some(r.network.equilibrium.clone()),
            output_error_beside: r.output_error_beside.as_ref().map(|b| BesideEntry {
                method: b.method.to_string(),
                time_constants_s: b.time_constants_s.clone(),
                fit: FitEntry::from(&b.fit),
            }),
            left_out: left_out_entries(r),
            hidden: r
                .hidden
                .as_ref()
                .map(|h| hidden_entry(h, &report_states(r))),
            measured_state: None,
            plausibility: r.plausibility.findings.clone(),
            warnings: r.warnings.clone(),
        };
        if let Some(h) = &r.hidden {
            hidden_as_the_model(&mut report, r, h);
        }
        report
    }

    /// A summary that reads like the paper's results section.
    pub fn summary(&self) -> String {
        let mut s = String::new();
        self.summary_recording(&mut s);
        self.summary_model(&mut s);
        self.summary_hidden(&mut s);
        self.summary_time_constants(&mut s);
        self.summary_fit(&mut s);
        self.summary_steady_state(&mut s);
        self.summary_residuals(&mut s);
        self.summary_network(&mut s);
        self.summary_left_out(&mut s);
        self.summary_decisions(&mut s);
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
        if let Some(gaps) = &self.estimation.gaps {
            let _ = writeln!(s, "  missing samples: {}", gaps_line(gaps));
        }
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

    /// Whether the report's model is a hidden-state one (the spec declares `[hidden]`):
    /// then Φ, Γ, A_c, B_c, the residuals and the network are the measured-state model's,
    /// and the summary says so where it prints them.
    fn hidden_is_the_model(&self) -> bool {
        self.hidden.as_ref().is_some_and(|h| h.replay_model)
    }

    /// " of the measured-state model" where the report's model is a hidden-state one (the
    /// figure so labelled is not the replay's model's), else nothing.
    fn of_the_measured_state_model(&self) -> &'static str {
        if self.hidden_is_the_model() {
            " of the measured-state model"
        } else {
            ""
        }
    }

    fn summary_model(&self, s: &mut String) {
        let whose = self.of_the_measured_state_model();
        matrix(s, &format!("Φ (eq. 19){whose}"), &self.phi, 8);
        matrix(s, &format!("Γ (eq. 20){whose}"), &self.gamma, 7);
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
            "eigenvalues of Φ (eq. 21){whose}: [{}]",
            complex_list(
                &self.eigenvalues_discrete,
                self.eigenvalues_discrete_imag.as_deref(),
                5
            )
        );
        matrix(s, &format!("A_c (eq. 22){whose}, 1/s"), &self.a_c, 8);
        matrix(s, &format!("B_c (eq. 23){whose}, 1/s"), &self.b_c, 7);
        let _ = writeln!(
            s,
            "eigenvalues of A_c (eq. 24){whose}: [{}] 1/s",
            complex_list(
                &self.eigenvalues_continuous,
                self.eigenvalues_continuous_imag.as_deref(),
                6
            )
        );
    }

    /// Where the spec declares hidden states: the hidden-state model, which the time
    /// constants, fit and steady state below describe, and the measured-state model's
    /// figures beside it (Φ and Γ above are the measured-state model's).
    fn summary_hidden(&self, s: &mut String) {
        let Some(h) = self.hidden.as_ref().filter(|h| h.replay_model) else {
            return;
        };
        let hidden: Vec<&str> = (h.state_names.iter().zip(&h.measured))
            .filter(|(_, &m)| !m)
            .map(|(n, _)| n.as_str())
            .collect();
        let _ = writeln!(
            s,
            "the replay's model has hidden states (spec `[hidden]`): x(k+1) = Φx(k) + Γu(k), \
             y = Cx + Du, {} states ({}), {} measured outputs; C {}; order {}",
            h.order,
            h.state_names.join(", "),
            self.states.len(),
            h.output_matrix,
            h.order_source
        );
        if !hidden.is_empty() {
            let _ = writeln!(s, "  states no sensor reads: {}", hidden.join(", "));
        }
        for c in &h.candidates {
            let fit = c
                .hold_back_fit_percent
                .map_or("–".into(), |f| format!("{f:.2} %"));
            let why = c
                .refused
                .as_deref()
                .map(|r| format!(" (refused: {r})"))
                .unwrap_or_default();
            let _ = writeln!(s, "  order {}: cross-validated fit {fit}{why}", c.order);
        }
        matrix(s, "hidden-state Φ", &h.phi, 8);
        matrix(s, "hidden-state Γ", &h.gamma, 7);
        matrix(s, "hidden-state C", &h.c, 7);
        if h.d.iter().flatten().any(|v| *v != 0.0) {
            matrix(s, "hidden-state D", &h.d, 7);
        }
        if let Some(c) = &h.parameter_covariance {
            let how = match c.correlation_window {
                Some(w) => format!(
                    "the sandwich H⁺ M H⁺, the residuals' correlation taken over a Bartlett \
                     window of {w} instants"
                ),
                None => "Gauss–Newton's, the residuals taken as white".into(),
            };
            let _ = writeln!(
                s,
                "  its parameters' covariance (predict's band, rating's intervals): {how}"
            );
        }
        if let Some(m) = &self.measured_state {
            let _ = writeln!(
                s,
                "the time constants, fit and steady state below are the hidden-state model's; \
                 the measured-state model (Φ, Γ above): time constants [{}] s, NRMSE fit [{}] %",
                join(&m.time_constants_s, |v| format!("{v:.2}")),
                join(&m.fit.nrmse_fit_percent, |v| format!("{v:.2}"))
            );
        }
        let _ = writeln!(s);
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
        if let (Some(_), Some(window)) = (&self.uncertainty, self.theta_covariance_window) {
            if !self.hidden_is_the_model() {
                let _ = writeln!(
                    s,
                    "  (the intervals take the residuals' correlation in time over a Bartlett \
                     window of {window} instants: the sandwich covariance)"
                );
            }
        }
        let rows = if self.hidden_is_the_model() {
            "rows: the measured outputs, T_i C ∂x/∂T_i"
        } else {
            "rows: states"
        };
        let _ = writeln!(
            s,
            "sensitivity norms ‖T_i ∂y_k/∂T_i‖, {} ({rows}; columns: T1..Tn):",
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
        let title = if self.hidden_is_the_model() {
            "fit of the hidden-state model, x0 fitted"
        } else {
            "fit of the simulated model (eq. 8)"
        };
        let _ = writeln!(s, "{title:<35}{header}");
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
        let how = if self.hidden_is_the_model() {
            "y_ss = (C (I − Φ)⁻¹ Γ + D) u of the hidden-state model"
        } else {
            "eqs. 30-35"
        };
        let _ = writeln!(
            s,
            "steady state for u = [{}] {unit} ({how})",
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

    /// One line counting what the screen left out (the warnings name each stretch).
    /// The default's decisions: each verdict with its reason, then each candidate's
    /// figures.
    fn summary_decisions(&self, s: &mut String) {
        if self.decisions.is_empty() {
            return;
        }
        let _ = writeln!(s);
        let _ = writeln!(
            s,
            "the default's decisions (candidates, figures compared, verdict):"
        );
        for d in &self.decisions {
            for line in d.lines() {
                let _ = writeln!(s, "  {line}");
            }
        }
    }

    fn summary_left_out(&self, s: &mut String) {
        if self.left_out.is_empty() {
            return;
        }
        let count = |why: crate::screen::Why| {
            let of: Vec<&LeftOutEntry> = self.left_out.iter().filter(|l| l.why == why).collect();
            (of.len(), of.iter().map(|l| l.samples).sum::<usize>())
        };
        let (glitches, glitch_samples) = count(crate::screen::Why::Glitch);
        let (frozen, frozen_samples) = count(crate::screen::Why::Frozen);
        let _ = writeln!(
            s,
            "left out of the estimation (the data contradict them): {glitches} glitch(es), {glitch_samples} sample(s); {frozen} frozen stretch(es), {frozen_samples} sample(s); each named below"
        );
    }

    fn summary_network(&self, s: &mut String) {
        let _ = writeln!(s);
        // A report read back has no network or equilibrium (`Report`: not read); one a
        // replay built always has both.
        match &self.network {
            None => {}
            Some(NetworkEntry::NotDefined { not_defined }) => {
                let _ = writeln!(
                    s,
                    "thermal network (Fig. 9){}: none: {not_defined}",
                    self.of_the_measured_state_model()
                );
            }
            Some(NetworkEntry::Defined(n)) => {
                let scale = match n.scale_from {
                    crate::network::ScaleSource::Calorimetric => "calorimetric, c·ρ·Q",
                    crate::network::ScaleSource::EnergyConservation => {
                        "energy conservation, Σ_i k_ij = 1"
                    }
                };
                let _ = writeln!(
                    s,
                    "thermal network (Fig. 9){}, scale from {scale}:",
                    self.of_the_measured_state_model()
                );
                if let Some(note) = &n.scale_note {
                    let _ = writeln!(s, "  ({note})");
                }
                match (&n.fitted_from, &n.minimum_distance) {
                    (Some(from), Some(d)) => {
                        let collapsed = n
                            .collapsed_parts()
                            .map(|c| format!("; {c}"))
                            .unwrap_or_default();
                        let _ = writeln!(s, "  ({}{collapsed})", minimum_distance_line(from, d));
                    }
                    // Which network this is (rc's fit to the data): the reader must know.
                    (Some(from), None) => {
                        let _ = writeln!(s, "  ({from})");
                    }
                    _ => {}
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
        let Some(e) = &self.equilibrium else {
            return;
        };
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
            "residuals (simulation error){}: lags 1-{} outside the 99 % band ±{:.4}, % of lags",
            self.of_the_measured_state_model(),
            res.max_lag,
            res.band99
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
        if let Some(inn) = &self.innovations {
            let outside: Vec<f64> = inn
                .autocorrelation_outside_band
                .iter()
                .map(|v| v * 100.0)
                .collect();
            row(s, "  innovations (one-step predictor)", &outside, 1);
        }
        // The decisions' block prints the choice with its figures where there is one.
        if let (Some(c), true) = (&self.estimator_choice, self.decisions.is_empty()) {
            let _ = writeln!(s, "estimator: {} ({})", c.method, c.reason);
        }
        if let Some(d) = &self.disturbance {
            let _ = writeln!(
                s,
                "disturbance: a random walk of heat into {}, its increment's σ {:.2e} K per sample per sample",
                d.state, d.increment_sd_k
            );
        }
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
                "the passive network nearest the identified model: {from}, χ² = {chi2} on {} degrees of freedom, p = {p:.2e}: {meaning}{}",
                d.degrees_of_freedom,
                unconverged_note(d)
            )
        }
        None => format!(
            "the passive network nearest the identified model: {from}, distance {:.3e} ({}){}",
            d.distance,
            d.weighting,
            unconverged_note(d)
        ),
    }
}

/// [`crate::network::MinimumDistance::unconverged`] in parentheses, or nothing.
fn unconverged_note(d: &crate::network::MinimumDistance) -> String {
    d.unconverged()
        .map(|c| format!(" ({c})"))
        .unwrap_or_default()
}

/// The screen's stretches, their times as the recording's (RFC 3339).
fn left_out_entries(r: &Replay) -> Vec<LeftOutEntry> {
    let at = |ns: i64| format_time(ns.max(0) as u64);
    r.left_out
        .iter()
        .map(|l| LeftOutEntry {
            channel: l.channel.clone(),
            from: at(l.from_ns),
            to: at(l.to_ns),
            value: l.value,
            why: l.why,
            samples: l.instants(),
            deviation_k: l.deviation_k,
        })
        .collect()
}
