//! Which samples the estimation leaves out: the screen's glitches and frozen values,
//! found in the residuals of the model estimated so far, and the estimate made again
//! without them. The decision is the screen's ([`crate::screen`], judged against each
//! channel's noise and resolution); this room runs its rounds.

use std::ops::Range;

use crate::decimate::DecimatedRecording;
use crate::error::Result;
use crate::estimate::{Estimate, IdentificationData};
use crate::network;
use crate::options::ReplayOptions;
use crate::recording::Nameplate;
use crate::screen::{self, LeftOut, Screening, Why};
use crate::series::Series;
use crate::signals::{self, ModelSignals};
use crate::spec::ModelDescription;

use super::estimator::estimate_in;
use super::noise::{NoiseFloor, ResolutionSource};
use super::{Candidate, Decision, Figure};

/// What the screen reads and changes of a prepared recording: the description, the grid
/// and the nameplate it reads; the signals and the estimator's data it changes where it
/// leaves samples out.
pub struct ScreenTarget<'a> {
    /// The model description the signals follow.
    pub model: &'a ModelDescription,
    /// The decimated quantities the signals are computed from.
    pub decimated: &'a DecimatedRecording,
    /// The nameplate, where the model needs one.
    pub nameplate: Option<&'a Nameplate>,
    /// The model's states and inputs (recomputed without what is left out).
    pub signals: &'a mut ModelSignals,
    /// The estimator's input (what is left out marked unobserved).
    pub data: &'a mut IdentificationData,
}

/// Rounds of screen → estimate again at most; each leaves out only what the last
/// estimate's residuals show, so a glitch that bent the first estimate is found in the
/// first round and one it hid in the next.
const SCREEN_ROUNDS: usize = 4;

/// Screens the data against the estimate's simulation for glitches and frozen values
/// ([`screen`]); where it finds some, marks them unobserved in the data (the held-back
/// part included), gives the signals computed from those channels (a copper loss from
/// the winding's temperature) the model's predicted readings there, and estimates again;
/// once a round finds nothing new, the predictions are refreshed from that round's model
/// and the model estimated a last time. On clean data this is one simulation and one
/// screen, nothing estimated again.
pub fn screen_and_estimate_again(
    prepared: &mut ScreenTarget<'_>,
    held_back: &mut Option<IdentificationData>,
    estimation_range: &Range<usize>,
    (options, scaling, noise): (&ReplayOptions, network::Scaling, &NoiseFloor),
    mut estimate: Estimate,
) -> Result<(Estimate, Screened)> {
    let mut left_out: Vec<LeftOut> = Vec::new();
    // The states' readings as measured, taken only once something is left out: on clean
    // data (the usual case) the screen copies nothing. It copied the whole signal set
    // before, 29 MB on a week at 1 s, at the replay's peak of memory.
    let mut measured: Option<Vec<Series>> = None;
    let mut first: Option<Screening> = None;
    for _ in 0..SCREEN_ROUNDS {
        let screening = screen_once(prepared, &estimate, &mut left_out, noise)?;
        let new = screening.left_out.clone();
        first.get_or_insert(screening);
        let found = !new.is_empty();
        if !found && left_out.is_empty() {
            break;
        }
        left_out.extend(new);
        let measured = measured.get_or_insert_with(|| {
            prepared
                .signals
                .states
                .iter()
                .map(|s| s.measured.clone())
                .collect()
        });
        leave_out(prepared, measured, &left_out)?;
        if held_back.is_some() {
            *held_back = Some(prepared.data.slice(estimation_range.clone()));
        }
        options
            .progress
            .stage("estimating again without glitches and frozen values");
        // The method the replay chose (pem where the default took it), not the one asked.
        let chosen = ReplayOptions {
            method: estimate.method,
            ..options.clone()
        };
        estimate = estimate_in(
            held_back.as_ref().unwrap_or(prepared.data),
            &chosen,
            scaling,
        )?;
        if !found {
            break;
        }
    }
    left_out.sort_by_key(|l| (l.state, l.from_index));
    let first = first.unwrap_or_default();
    let names = prepared
        .signals
        .states
        .iter()
        .map(|s| s.name.clone())
        .collect();
    Ok((
        estimate,
        Screened {
            left_out,
            noise_k: first.noise_k,
            resolution_k: first.resolution_k,
            states: names,
        },
    ))
}

/// What the screen left out of the estimation, and the noise and resolution it judged
/// each state by (its first round's, against the first estimate).
#[derive(Debug, Clone, Default)]
pub struct Screened {
    /// The stretches left out, by state then time.
    pub left_out: Vec<LeftOut>,
    /// Per state: the residuals' noise σ the screen judged by, K.
    pub noise_k: Vec<f64>,
    /// Per state: the resolution it judged by, K.
    pub resolution_k: Vec<f64>,
    /// The states' names.
    pub states: Vec<String>,
}

impl Screened {
    /// The screen as a decision: every sample kept, or the stretches left out, with each
    /// state's noise and resolution beside the count.
    pub fn decision(&self) -> Decision {
        let count = |why: Why| {
            let of: Vec<&LeftOut> = self.left_out.iter().filter(|l| l.why == why).collect();
            (of.len(), of.iter().map(|l| l.instants()).sum::<usize>())
        };
        let (glitches, glitch_samples) = count(Why::Glitch);
        let (frozen, frozen_samples) = count(Why::Frozen);
        let judged_by: Vec<Figure> = self
            .states
            .iter()
            .zip(self.noise_k.iter().zip(&self.resolution_k))
            .flat_map(|(name, (noise, resolution))| {
                [
                    Figure::new(&format!("{name} noise σ"), *noise, "K"),
                    Figure::new(&format!("{name} resolution"), *resolution, "K"),
                ]
            })
            .collect();
        let keep = Candidate::new("keep every sample", judged_by);
        let leave = Candidate::new(
            "leave out glitches and frozen stretches",
            vec![
                Figure::new("glitches", glitches as f64, ""),
                Figure::new("glitch samples", glitch_samples as f64, ""),
                Figure::new("frozen stretches", frozen as f64, ""),
                Figure::new("frozen samples", frozen_samples as f64, ""),
            ],
        );
        let (chosen, reason) = if self.left_out.is_empty() {
            (
                keep.name.clone(),
                "no residual stands apart from the noise, and no run of equal values outlasts \
                 what noise and resolution allow while the model predicts a change"
                    .to_owned(),
            )
        } else {
            (
                leave.name.clone(),
                format!(
                    "{glitches} glitch(es) ({glitch_samples} samples) and {frozen} frozen \
                     stretch(es) ({frozen_samples} samples) the noise and resolution do not \
                     explain: left out and the model estimated again"
                ),
            )
        };
        Decision {
            what: "screen".into(),
            candidates: vec![keep, leave],
            chosen,
            reason,
        }
    }
}

/// One screen of the whole data against the estimate's simulation ŷ = x + d (d its
/// output offset, where it has one): returns the new stretches, and sets the readings
/// of those already left out to this model's predictions.
fn screen_once(
    prepared: &ScreenTarget<'_>,
    estimate: &Estimate,
    left_out: &mut [LeftOut],
    noise: &NoiseFloor,
) -> Result<Screening> {
    let data: &IdentificationData = prepared.data;
    let mut simulated = estimate.model.simulate_segments(data, &data.segments());
    if let Some(offset) = &estimate.output_offset {
        for (j, d) in offset.iter().enumerate().take(data.states()) {
            simulated.column_mut(j).add_scalar_mut(*d);
        }
    }
    let signals: &ModelSignals = prepared.signals;
    let channels: Vec<screen::Channel> = signals
        .states
        .iter()
        .enumerate()
        .map(|(j, s)| screen::Channel {
            name: &s.name,
            declared_resolution_k: (noise.source.get(j) == Some(&ResolutionSource::Declared))
                .then(|| noise.resolution_k[j]),
            measured: &s.measured,
            stored_by_exception: s.exception.is_some() || s.observed.is_some(),
        })
        .collect();
    let input = screen::ScreenInput {
        data,
        simulated: &simulated,
        channels: &channels,
        time_ns: &signals.time_ns,
        temperature_base_k: signals.temperature_base_k,
    };
    screen::predict(&input, left_out)?;
    Ok(screen::screen(&input)?)
}

/// The signals and data without the stretches left out: the grid's channels take the
/// model's predicted readings there, the signal stage runs again on them (the inputs
/// computed from those channels follow), the states keep what was `measured` (each
/// state's readings before the screen), and the entries left out are unobserved.
fn leave_out(
    prepared: &mut ScreenTarget<'_>,
    measured: &[Series],
    left_out: &[LeftOut],
) -> Result<()> {
    let mut grid = prepared.decimated.clone();
    for l in left_out {
        let channel = &prepared.model.states[l.state].channel;
        let Some(series) = grid.series.get_mut(channel) else {
            continue;
        };
        for (k, v) in (l.from_index..=l.to_index).zip(&l.predicted) {
            if v.is_finite() {
                series.values.set(k, Some(*v));
            }
        }
    }
    let mut signals = signals::compute(prepared.model, &grid, prepared.nameplate)?;
    for (state, was) in signals.states.iter_mut().zip(measured) {
        state.measured = was.clone();
    }
    *prepared.data = screen::mark_unobserved(&signals.identification_data(), left_out);
    *prepared.signals = signals;
    Ok(())
}
