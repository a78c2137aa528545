//! The whole-file monitor the streamed one (`heatrun::monitor::monitor_stream`) replaced,
//! kept here as the oracle the tests check it against: the recording read and decimated whole, the
//! signals computed on the whole grid, then the model run beside it instant by instant.
//! Memory grows with the recording; nothing is shown until the file is read.

use std::path::Path;

use nalgebra::DVector;

use heatrun::decimate::DecimatedRecording;
use heatrun::grid::GridBuilder;
use heatrun::model_file::ThermalModel;
use heatrun::monitor::{
    description_of, grid_alignments, inlet_warning, Accumulator, Alarm, Band, Detector,
    MonitorOptions, MonitorResult, MonitorTraces, StateRef,
};
use heatrun::recording::{self, Quantity, ReadOptions, SampleSink};
use heatrun::series::Series;
use heatrun::signals::{self, ModelSignals};
use heatrun::spec::ModelDescription;
use heatrun::{Error, Result};

/// Monitors `recording` with `model` from the whole file at once (the test oracle).
pub fn monitor_whole_file(
    model: &ThermalModel,
    recording: &Path,
    options: &MonitorOptions,
) -> Result<MonitorResult> {
    let description = description_of(model)?;
    let in_file = |e: heatrun::signals::SignalError| Error::from(e).in_recording(recording);
    let (summary, mut decimated) = read(recording, model, &description, None)?;
    heatrun::monitor::with_model_field_line(model, &mut decimated);
    let signals =
        signals::compute(&description, &decimated, model.nameplate.as_ref()).map_err(in_file)?;
    let references = references(model, &signals, &decimated);
    let warnings = inlet_warning(model, &decimated).into_iter().collect();
    let band = Band::from_model_error(&model.error, options.band);
    let run = run_beside(model, &signals, &references, &band, options.hold_s);
    let states: Vec<String> = model.states.iter().map(|s| s.name.clone()).collect();
    let stats = run
        .stats
        .iter()
        .enumerate()
        .map(|(j, acc)| acc.finish(&states[j], &model.states[j].part, band.half_width_k[j]))
        .collect();
    Ok(MonitorResult {
        recording: recording.to_owned(),
        model: model.path.clone(),
        ts_s: model.ts_s,
        parts: model.states.iter().map(|s| s.part.clone()).collect(),
        states,
        band,
        hold_s: options.hold_s,
        alarms: run.alarms,
        stats,
        restarts: run.restarts,
        data_loss: summary.data_loss,
        warnings,
        traces: run.traces,
    })
}

/// Reads and decimates the recording on the model's grid (with the coolant inlet, for
/// the shift of initial references, where the model test recorded one).
fn read(
    path: &Path,
    model: &ThermalModel,
    description: &ModelDescription,
    also: Option<&mut dyn SampleSink>,
) -> Result<(recording::RecordingSummary, DecimatedRecording)> {
    let alignments = grid_alignments(model, description);
    let mut grid = GridBuilder::whole(model.ts_s, alignments)?;
    let options = ReadOptions {
        free_channels: description.free_channels(),
        ..ReadOptions::default()
    };
    let summary = match also {
        Some(also) => recording::read_recording_with(
            path,
            &mut heatrun::recording::Tee {
                first: &mut grid,
                also,
            },
            &options,
        )?,
        None => recording::read_recording_with(path, &mut grid, &options)?,
    };
    let decimated = grid
        .finish(&summary.channels)
        .map_err(|e| Error::from(e).in_recording(path))?;
    Ok((summary, decimated))
}

struct References {
    per_state: Vec<StateRef>,
    /// The lagged inlet shift per instant, K (0 where it does not apply).
    shift: Vec<f64>,
}

impl References {
    fn at(&self, signals: &ModelSignals, j: usize, k: usize) -> Option<f64> {
        match self.per_state[j] {
            StateRef::ModelInitial(theta_ref) => Some(theta_ref + self.shift[k]),
            StateRef::FromSignals => signals.states[j].reference_at(k),
        }
    }
}

fn references(
    model: &ThermalModel,
    signals: &ModelSignals,
    decimated: &DecimatedRecording,
) -> References {
    let per_state = StateRef::per_state(model);
    let inlet = decimated.get(Quantity::CoolingWaterInletTemp);
    let shift = match (model.coolant_inlet_temp_c, inlet) {
        (Some(test), Some(inlet)) if !model.uses_coolant_inlet() => {
            lagged_shift(&inlet.values, test, model, signals.ts_s)
        }
        _ => vec![0.0; signals.len()],
    };
    References { per_state, shift }
}

/// θ_in(k) − θ_in,test through a first-order lag of the model's fastest time constant,
/// the last value held across gaps.
fn lagged_shift(inlet: &Series, test_c: f64, model: &ThermalModel, ts_s: f64) -> Vec<f64> {
    let tau = model
        .time_constants_s
        .iter()
        .copied()
        .filter(|t| t.is_finite() && *t > 0.0)
        .fold(f64::INFINITY, f64::min);
    let alpha = if tau.is_finite() {
        1.0 - (-ts_s / tau).exp()
    } else {
        1.0
    };
    let mut state: Option<f64> = None;
    inlet
        .iter()
        .map(|v| {
            if let Some(v) = v {
                let d = v - test_c;
                state = Some(state.map_or(d, |s| s + alpha * (d - s)));
            }
            state.unwrap_or(0.0)
        })
        .collect()
}

struct Run {
    traces: MonitorTraces,
    stats: Vec<Accumulator>,
    alarms: Vec<Alarm>,
    restarts: usize,
}

/// The model beside the recording, instant by instant (see the module).
fn run_beside(
    model: &ThermalModel,
    signals: &ModelSignals,
    refs: &References,
    band: &Band,
    hold_s: f64,
) -> Run {
    let (n, len) = (model.state_count(), signals.len());
    let base = model.temperature_base_k;
    let names = model.states.iter().map(|s| s.name.clone()).collect();
    let mut detector = Detector::new(names, band.half_width_k.clone(), hold_s);
    let mut stats = vec![Accumulator::default(); n];
    let mut predicted = vec![Series::unknown(len); n];
    let (mut x_hat, mut starts) = (None::<DVector<f64>>, 0usize);
    let t0 = signals.time_ns.first().copied().unwrap_or(0);
    let mut residuals = vec![None; n];
    for k in 0..len {
        let measured: Vec<Option<f64>> = signals.states.iter().map(|s| s.measured.get(k)).collect();
        let reference: Vec<Option<f64>> = (0..n).map(|j| refs.at(signals, j, k)).collect();
        if x_hat.is_none() {
            let rises: Option<Vec<f64>> = (0..n)
                .map(|j| Some((measured[j]? - reference[j]?) / base))
                .collect();
            if let Some(r) = rises {
                x_hat = Some(DVector::from_vec(r));
                starts += 1;
            }
        }
        let t_s = (signals.time_ns[k] - t0) as f64 / 1e9;
        for j in 0..n {
            let theta_hat = x_hat
                .as_ref()
                .and_then(|x| Some(reference[j]? + base * x[j]));
            predicted[j].set(k, theta_hat);
            residuals[j] = measured[j].zip(theta_hat).map(|(m, p)| m - p);
            if let Some(r) = residuals[j] {
                stats[j].add(r, t_s, band.half_width_k[j]);
            }
        }
        detector.observe(signals.time_ns[k], &residuals);
        let u: Option<Vec<f64>> = signals.inputs.iter().map(|i| i.values.get(k)).collect();
        x_hat = match (x_hat, u) {
            (Some(x), Some(u)) => Some(&model.phi * x + &model.gamma * DVector::from_vec(u)),
            _ => None,
        };
    }
    let last = signals.time_ns.last().copied().unwrap_or(0);
    Run {
        traces: MonitorTraces {
            time_ns: signals.time_ns.clone(),
            measured: signals.states.iter().map(|s| s.measured.clone()).collect(),
            predicted,
        },
        stats,
        alarms: detector.finish(last),
        restarts: starts.saturating_sub(1),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use heatrun::monitor::BandRule;
    use heatrun::signals::{InputSignal, ReferenceValues, StateSignal};
    use heatrun::spec::InputKind;

    /// One state, one input, as recorded: x(k+1) = 0.9 x(k) + 0.05 u(k), rises above
    /// the test's initial 20 °C; the model's validation RMSE 0.1 K.
    fn model() -> ThermalModel {
        let report = serde_json::json!({
            "profile": heatrun::model_file::PROFILE,
            "sample_time_s": 1.0,
            "states": ["part"],
            "inputs": ["heater"],
            "phi": [[0.9]],
            "gamma": [[0.05]],
            "time_constants_s": [9.49],
            "fit": {"rmse_k": [0.1], "max_abs_error_k": [0.3]},
            "model": {
                "name": "one node",
                "states": [{"name": "part", "channel": "part_temp", "reference": "initial",
                            "part": "the part"}],
                "inputs": [{"name": "heater", "source": {"channel": "heater_w"},
                            "unit": "W", "kind": "heat"}],
                "scaling": "as_recorded"
            },
            "estimation": {"initial_temperature_c": [20.0], "temperature_base_k": 1.0}
        });
        let path = Path::new("model.json");
        let report = heatrun::model_file::Report::from_json(&report.to_string(), path).unwrap();
        ThermalModel::from_report(&report, path).unwrap()
    }

    /// The model by hand from rise x0 under u = 2 W: x(k) = 0.9^k x0 + (1 − 0.9^k).
    fn by_hand(x0: f64, k: i32) -> f64 {
        0.9f64.powi(k) * x0 + (1.0 - 0.9f64.powi(k))
    }

    #[test]
    fn the_model_runs_beside_the_recording_restarts_after_a_gap_and_alarms() {
        let model = model();
        let len: usize = 20;
        // Measured: the model's own path from 25 °C, 2 K above it from instant 5; after
        // the input's gap at instant 10, the model's path from 30 °C.
        let measured: Series = (0..len)
            .map(|k| {
                Some(match k {
                    0..5 => 20.0 + by_hand(5.0, k as i32),
                    5..=10 => 22.0 + by_hand(5.0, k as i32),
                    _ => 20.0 + by_hand(10.0, k as i32 - 11),
                })
            })
            .collect();
        let heater: Series = (0..len).map(|k| (k != 10).then_some(2.0)).collect();
        let signals = ModelSignals {
            ts_s: 1.0,
            time_ns: (0..len as i64).map(|k| k * 1_000_000_000).collect(),
            states: vec![StateSignal {
                name: "part".into(),
                part: "the part".into(),
                measured,
                reference: ReferenceValues::Constant(0.0),
                observed: None,
                exception: None,
            }],
            inputs: vec![InputSignal {
                name: "heater".into(),
                unit: "W".into(),
                kind: InputKind::Heat,
                values: heater,
                outlet_feedback: None,
                gaps: signals::InputGaps::none(signals::Bridge::Hold),
            }],
            initial_index: 0,
            temperature_base_k: 1.0,
            power_base: 1.0,
            field_temperature: None,
        };
        let refs = References {
            per_state: vec![StateRef::ModelInitial(20.0)],
            shift: vec![0.0; len],
        };
        let band = Band::from_model_error(&model.error, BandRule::default());
        assert_eq!(band.half_width_k, vec![0.5]);
        let run = run_beside(&model, &signals, &refs, &band, 3.0);
        let predicted = |k: usize| run.traces.predicted[0].get(k).unwrap();
        for k in 0..=10 {
            let expected = 20.0 + by_hand(5.0, k as i32);
            assert!((predicted(k) - expected).abs() < 1e-12, "instant {k}");
        }
        // No input at 10: restarted at 11 from the measured 30 °C (a rise of 10 K).
        assert_eq!(run.restarts, 1);
        assert!((predicted(11) - 30.0).abs() < 1e-12);
        assert!((predicted(12) - (20.0 + by_hand(10.0, 1))).abs() < 1e-12);
        // 2 K above from 5 s to 10 s, back inside at 11 s: 6 s outside > 3 s hold.
        let alarms = &run.alarms;
        assert_eq!(alarms.len(), 1, "{alarms:?}");
        let s = 1_000_000_000;
        assert_eq!(
            (alarms[0].start_ns, alarms[0].end_ns),
            (5 * s, Some(11 * s))
        );
        assert!((alarms[0].peak_deviation_k - 2.0).abs() < 1e-12);
    }
}
