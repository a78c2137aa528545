//! The screen: samples the data themselves contradict, found in a model's residuals and
//! left out of the estimation (issue 22, item 3).
//!
//! Two flaws no status marks:
//! - a **glitch**: a measured output far outside the measurement noise of the model's
//!   prediction, a jump no thermal mass allows ([`glitch`]);
//! - a **frozen** sensor: a run of identical values far longer than the channel's noise
//!   and resolution allow while the model says the value should have changed
//!   ([`frozen`]).
//!
//! The stage is given the identification data, the model's simulated outputs on them and
//! each output's measured channel; it returns the stretches to leave out. It knows nothing
//! of estimation: the pipeline marks the stretches unobserved and estimates again.

pub mod frozen;
pub mod glitch;
pub mod robust;

use nalgebra::DMatrix;
use serde::Serialize;

use crate::estimate::IdentificationData;
use crate::series::Series;

/// Why a screen cannot run: its inputs do not describe the same instants and outputs.
#[derive(Debug, thiserror::Error)]
pub enum ScreenError {
    /// The simulated outputs, the channels or the grid times do not match the data.
    #[error("the screen's inputs disagree: {what}")]
    Shape {
        /// Which input, and its size against the data's.
        what: String,
    },
}

/// The screen's result.
pub type Result<T, E = ScreenError> = std::result::Result<T, E>;

/// One output's measured channel, as the screen reads it.
#[derive(Debug, Clone, Copy)]
pub struct Channel<'a> {
    /// The channel's (state's) name, for the report.
    pub name: &'a str,
    /// The measured values θ_j(k) on the grid, in the channel's unit (°C).
    pub measured: &'a Series,
    /// Whether the channel was stored by exception: its values then repeat by design
    /// between stored samples, so a run of identical values says nothing.
    pub stored_by_exception: bool,
    /// The channel's resolution, K, where the recording declares it (metadata
    /// `resolution`); else the screen takes the one its values show.
    pub declared_resolution_k: Option<f64>,
}

/// What the screen reads.
#[derive(Debug, Clone, Copy)]
pub struct ScreenInput<'a> {
    /// The identification data (outputs y, N × n, pu; the mask of observed entries).
    pub data: &'a IdentificationData,
    /// The model's simulated outputs ŷ on the data (N × n, pu; NaN where not simulated).
    pub simulated: &'a DMatrix<f64>,
    /// Each output's measured channel, in the outputs' order.
    pub channels: &'a [Channel<'a>],
    /// The time of each grid instant, ns since the epoch.
    pub time_ns: &'a [i64],
    /// Kelvin per unit of an output (θ_base).
    pub temperature_base_k: f64,
}

/// Why a stretch was left out.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Why {
    /// Far outside the measurement noise of the model's prediction.
    Glitch,
    /// Identical values for longer than the noise and resolution allow, while the model
    /// says the value changed.
    Frozen,
}

impl Why {
    /// The word used in the report and the warnings.
    pub fn name(self) -> &'static str {
        match self {
            Why::Glitch => "glitch",
            Why::Frozen => "frozen",
        }
    }
}

/// A stretch of one output left out of the estimation.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LeftOut {
    /// The output's index (the state's).
    pub state: usize,
    /// The channel's name.
    pub channel: String,
    /// The first and last grid instants of the stretch (inclusive).
    pub from_index: usize,
    /// The last grid instant of the stretch (inclusive).
    pub to_index: usize,
    /// The time of the first instant, ns since the epoch.
    pub from_ns: i64,
    /// The time of the last instant, ns since the epoch.
    pub to_ns: i64,
    /// The measured value at the first instant, in the channel's unit (°C); for a frozen
    /// stretch, the value held.
    pub value: f64,
    /// Why it was left out.
    pub why: Why,
    /// The largest |measured − predicted| over the stretch, K (for a frozen stretch, the
    /// change the model predicted over it).
    pub deviation_k: f64,
    /// The model's predicted reading θ̂(k) at each instant of the stretch, in the
    /// channel's unit (NaN where there is none): what signals computed from the channel
    /// (a copper loss from the winding's temperature) take in its place.
    #[serde(skip)]
    pub predicted: Vec<f64>,
}

impl LeftOut {
    /// Number of grid instants in the stretch.
    pub fn instants(&self) -> usize {
        self.to_index + 1 - self.from_index
    }
}

/// What the screen found: the stretches and the per-output noise and resolution it
/// judged them by.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct Screening {
    /// The stretches left out, by output then time.
    pub left_out: Vec<LeftOut>,
    /// Per output, the noise σ of the residuals it judged by, K.
    pub noise_k: Vec<f64>,
    /// Per output, the resolution the measured values show, K (0: none seen).
    pub resolution_k: Vec<f64>,
}

impl Screening {
    /// Whether nothing was found.
    pub fn is_empty(&self) -> bool {
        self.left_out.is_empty()
    }
}

/// Screens every output for glitches and frozen runs (see the module's doc). Where the
/// run is at most [`SIDE_BY_SIDE_INSTANTS`] long the outputs are screened side by side
/// on rayon's threads; either way each output's findings are its own, in the outputs'
/// order.
pub fn screen(input: &ScreenInput<'_>) -> Result<Screening> {
    screen_with(input, input.data.len() <= SIDE_BY_SIDE_INSTANTS)
}

/// [`screen`], the outputs side by side or one after the other.
fn screen_with(input: &ScreenInput<'_>, side_by_side: bool) -> Result<Screening> {
    check_shapes(input)?;
    let n = input.data.states();
    let per_output: Vec<OutputScreen> = if side_by_side {
        use rayon::prelude::*;
        (0..n)
            .into_par_iter()
            .map(|j| screen_output(input, j))
            .collect()
    } else {
        (0..n).map(|j| screen_output(input, j)).collect()
    };
    let mut out = Screening::default();
    for output in per_output {
        out.left_out.extend(output.found);
        out.noise_k.push(output.noise_k);
        out.resolution_k.push(output.resolution_k);
    }
    Ok(out)
}

/// The longest run whose outputs are screened side by side: each output in flight holds
/// its residuals and readings (32 bytes an instant), so a heat run of a day and a half
/// at 1 s adds 4 MB, where a week at 1 s would add 19 MB at the replay's peak of memory.
pub const SIDE_BY_SIDE_INSTANTS: usize = 1 << 17;

/// One output's screen: its stretches (by time), and the noise and resolution it judged
/// them by.
struct OutputScreen {
    found: Vec<LeftOut>,
    noise_k: f64,
    resolution_k: f64,
}

/// Output j's screen.
fn screen_output(input: &ScreenInput<'_>, j: usize) -> OutputScreen {
    let residuals = residuals_k(input, j);
    let channel = &input.channels[j];
    let resolution = channel
        .declared_resolution_k
        .unwrap_or_else(|| robust::resolution(channel.measured));
    let noise = glitch::noise_scale_k(&residuals, resolution);
    let readings: Vec<Option<f64>> = (0..input.data.len())
        .map(|k| {
            channel
                .measured
                .get(k)
                .filter(|_| input.data.observed(k, j))
        })
        .collect();
    let mut found = glitch::find(input, j, (&residuals, &readings), noise);
    if !channel.stored_by_exception {
        found.extend(frozen::find(input, j, noise, resolution));
    }
    found.sort_by_key(|s| s.from_index);
    OutputScreen {
        found,
        noise_k: noise,
        resolution_k: resolution,
    }
}

/// Sets each stretch's [`LeftOut::predicted`] to the readings `input`'s model predicts
/// (a later, better model than the one that found it).
pub fn predict(input: &ScreenInput<'_>, stretches: &mut [LeftOut]) -> Result<()> {
    check_shapes(input)?;
    for l in stretches.iter_mut() {
        l.predicted = (l.from_index..=l.to_index)
            .map(|k| predicted_reading(input, l.state, k))
            .collect();
    }
    Ok(())
}

/// The model's predicted reading of output j at instant k, in the channel's unit:
/// θ̂(k) = θ(k) − (y(k) − ŷ(k))·θ_base = θ_ref(k) + ŷ(k)·θ_base (the reading less the
/// residual, so that a reference that moves is included). An entry left out still holds
/// its reading's rise, so this holds there too; NaN where the channel has no reading or
/// the model no simulation.
pub(crate) fn predicted_reading(input: &ScreenInput<'_>, j: usize, k: usize) -> f64 {
    let Some(theta) = input.channels[j].measured.get(k) else {
        return f64::NAN;
    };
    let r = input.data.outputs[(k, j)] - input.simulated[(k, j)];
    theta - r * input.temperature_base_k
}

/// Output j's residuals y − ŷ in K, `None` where it is not observed or not simulated.
fn residuals_k(input: &ScreenInput<'_>, j: usize) -> Vec<Option<f64>> {
    let (data, sim) = (input.data, input.simulated);
    (0..data.len())
        .map(|k| {
            let r = data.outputs[(k, j)] - sim[(k, j)];
            (data.observed(k, j) && r.is_finite()).then_some(r * input.temperature_base_k)
        })
        .collect()
}

fn check_shapes(input: &ScreenInput<'_>) -> Result<()> {
    let (n_rows, n) = input.data.outputs.shape();
    let mismatch = |what: &str, got: String| {
        Err(ScreenError::Shape {
            what: format!("{what} is {got}, the data {n_rows} × {n}"),
        })
    };
    if input.simulated.shape() != (n_rows, n) {
        let (r, c) = input.simulated.shape();
        return mismatch("the simulation", format!("{r} × {c}"));
    }
    if input.channels.len() != n {
        return mismatch("the channel list", format!("{} long", input.channels.len()));
    }
    if input.time_ns.len() != n_rows || input.channels.iter().any(|c| c.measured.len() != n_rows) {
        return mismatch("a channel's grid or the times", "of another length".into());
    }
    Ok(())
}

/// The data with every entry of `left_out` unobserved: a mask is made if the data had
/// none (every output known where its row was), so that the simulation runs through
/// the entries left out instead of being cut there.
pub fn mark_unobserved(data: &IdentificationData, left_out: &[LeftOut]) -> IdentificationData {
    let mut observed = match &data.output_observed {
        Some(o) => o.clone(),
        None => DMatrix::from_fn(data.len(), data.states(), |k, _| data.outputs_known[k]),
    };
    for s in left_out {
        for k in s.from_index..=s.to_index.min(data.len().saturating_sub(1)) {
            observed[(k, s.state)] = false;
        }
    }
    data.clone().with_output_observed(observed)
}

#[cfg(test)]
mod tests;
