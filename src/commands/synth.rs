//! `heatrun synth`: a synthetic heat run, written with its truth beside it.

use heatrun::synth;

use super::Outcome;
use crate::cli::Synth;

/// Simulates and writes the recording, then prints what its true model is.
pub fn run(request: &Synth) -> anyhow::Result<Outcome> {
    let truth = synth::write(&request.out, &request.options).map_err(heatrun::Error::from)?;
    println!(
        "wrote {} ({:.0} s, {}; true time constants [{}] s; true steady-state rise [{}] K) and {}",
        request.out.display(),
        request.options.duration_s,
        truth.machine,
        truth
            .time_constants_s
            .iter()
            .map(|t| format!("{t:.2}"))
            .collect::<Vec<_>>()
            .join(", "),
        truth
            .steady_state_rise_k
            .iter()
            .map(|t| format!("{t:.3}"))
            .collect::<Vec<_>>()
            .join(", "),
        synth::truth_path(&request.out).display()
    );
    Ok(Outcome::Complete)
}
