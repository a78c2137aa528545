//! When the data contradict physics, say so: plausibility checks on what a replay reads.
//!
//! Four ordinary mistakes of plant data pass every check of the profile (the units are
//! accepted ones, the values within their physical ranges) and yet describe no machine:
//!
//! | check | module | evidence | what is done |
//! |---|---|---|---|
//! | two temperature channels exchanged mid-run (a terminal block re-wired) | [`exchange`] | both step at one instant by the same amount in opposite directions, each then at the other's level | **corrected**: swapped back from that instant, said |
//! | a temperature recorded in °F or K, declared °C | [`units`] | at a cold start its first value is far from every other temperature and the converted one among them; or its values are no temperature in °C at all | **refused** (exit 2): the channel and the unit to fix |
//! | a current or voltage recorded in A or V, declared kA or kV (or the other way round) | [`units`] | its level is orders of magnitude from the nameplate's rated value | **refused** (exit 2) |
//! | the cooling water carrying more heat than the losses over the run, or far less with the flow measured | [`balance`] | the energy balance ∫c·ρ·Q·(θ_out − θ_in) dt / ∫Σ P_loss dt outside [0.2, 1.5] | **refused** where another unit of one water channel brings it back (the channel named); else **said** |
//! | the stator winding's and the core's labels exchanged for the whole run | [`labels`] | the network puts most of the armature copper loss into the "core" and most of the iron loss into the "winding" | **said**: both channels named, the model given as recorded |
//!
//! Each check is a pure function of a stage's output; the pipeline calls them and carries
//! their [`Finding`]s into the warnings and the report (`plausibility`). A refusal is a
//! [`PlausibilityError`]: one line naming the channel and what to fix.

pub mod balance;
pub mod exchange;
pub mod labels;
pub mod units;

use serde::Serialize;

use crate::decimate::DecimatedRecording;
use crate::recording::{format_time, Nameplate, RecordingSummary};
use crate::signals::ModelSignals;
use crate::spec::ModelDescription;

/// Which physical check a finding is of.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Check {
    /// Two temperature channels carry each other's values from an instant on.
    ExchangedMidRun,
    /// A temperature channel's values fit another unit far better than °C.
    TemperatureUnit,
    /// An electrical channel's level is orders of magnitude from the nameplate's.
    ElectricalUnit,
    /// The cooling water's heat against the losses, over the run.
    CalorimetricBalance,
    /// The winding's and the core's labels, against the losses that heat them.
    ExchangedLabels,
}

/// What was done about a finding.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Action {
    /// The data were corrected before the estimate (the correction said).
    Corrected,
    /// The data were used as recorded; the finding is a warning.
    Said,
    /// The replay was refused (exit status 2).
    Refused,
}

/// One contradiction between the data and physics.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Finding {
    /// The check that found it.
    pub check: Check,
    /// The channels concerned (quantity or channel names).
    pub channels: Vec<String>,
    /// When, RFC 3339 UTC, where the finding has an instant.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub time: Option<String>,
    /// The likely cause, in a few words (`recorded in °F`, `terminal block re-wired`).
    pub cause: String,
    /// What was done.
    pub action: Action,
    /// The one line the user reads: channel, time, evidence, cause and what was done.
    pub message: String,
}

/// A replay refused because its data contradict physics in a way a correction cannot
/// be trusted to undo: the message names the channel, and the unit or key to fix in the
/// import map or the recording.
#[derive(Debug, Clone, thiserror::Error)]
#[error("{}", .0.message)]
pub struct PlausibilityError(pub Box<Finding>);

impl PlausibilityError {
    /// The finding behind the refusal.
    pub fn finding(&self) -> &Finding {
        &self.0
    }
}

/// What the plausibility checks found in one replay, in the order the checks ran.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
#[serde(transparent)]
pub struct Plausibility {
    /// The findings (none on data a machine can produce).
    pub findings: Vec<Finding>,
}

impl Plausibility {
    /// Each finding's message, as a warning line.
    pub fn warnings(&self) -> impl Iterator<Item = String> + '_ {
        self.findings.iter().map(|f| f.message.clone())
    }

    /// Whether nothing was found.
    pub fn is_empty(&self) -> bool {
        self.findings.is_empty()
    }
}

/// The checks on the grid before the signals are made: channels exchanged mid-run are
/// swapped back in `decimated` ([`exchange::undo`]), then the units of the temperature
/// and electrical channels ([`units`]) are judged; a wrong unit refuses the replay.
pub fn before_signals(
    summary: &RecordingSummary,
    decimated: &mut DecimatedRecording,
    nameplate: Option<&Nameplate>,
) -> Result<Plausibility, PlausibilityError> {
    let mut findings = exchange::undo(decimated);
    findings.extend(units::temperatures(summary, decimated)?);
    if let Some(nameplate) = nameplate {
        findings.extend(units::electrical(summary, decimated, nameplate)?);
    }
    Ok(Plausibility { findings })
}

/// The checks on the model's signals: the calorimetric balance over the run
/// ([`balance::check`]), for the generator's loss model with the flow recorded.
pub fn of_signals(
    model: &ModelDescription,
    decimated: &DecimatedRecording,
    signals: &ModelSignals,
) -> Result<Vec<Finding>, PlausibilityError> {
    Ok(balance::check(model, decimated, signals)?
        .into_iter()
        .collect())
}

/// The time of grid instant `k` of `decimated`, RFC 3339.
fn grid_time(decimated: &DecimatedRecording, k: usize) -> String {
    format_time(decimated.time_ns(k).max(0) as u64)
}
