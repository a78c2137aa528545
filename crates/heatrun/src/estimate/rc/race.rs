//! Fits of one network from several starts, run beside each other, and the rule that
//! drops a start far behind another; or fits called off outright where their result is no
//! longer needed ([`StartRace::call_off`]: rc's free fit, once the score test at the held
//! fit has kept the held network without it).
//!
//! Each fit publishes the deviance of the points Levenberg–Marquardt accepts,
//!
//! ```text
//! D = Σ_i N_i·ln max(σ̂²_i, floor)      (−2 ln L up to a constant, as estimate::deviance)
//! ```
//!
//! which, unlike the weighted squared error J, does not depend on the weights each fit
//! chose, so fits from different starts compare. The fit kept is the one of lowest D, so a
//! fit whose D stands above the lowest published by more than it can still gain is only
//! spending time: it is dropped where
//!
//! ```text
//! D − D_best > 2·p + 2·ΔD_GN
//! ```
//!
//! with p its free parameters (two fits at minima of the same model differ by about a
//! χ²_p, mean p and spread √(2p), where the noise alone separates them) and ΔD_GN the
//! decrease in D the Gauss–Newton step from its point predicts (‖z‖²/σ², twice over
//! for the quadratic model's error far from the minimum). A start walking towards a
//! conductance of zero gains a few χ² units per fifty evaluations: the paper's model left
//! one walking to the evaluation cap, 950 evaluations, for a network never chosen.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Mutex;

/// The lowest deviance any fit in a race has reached.
#[derive(Debug)]
pub struct StartRace {
    /// The least variance taken as real when a deviance is formed (as
    /// [`crate::estimate::deviance`]'s `floor`, in the outputs' units squared).
    floor: f64,
    lowest: Mutex<f64>,
    /// Whether the fits were called off: their result is no longer needed
    /// ([`StartRace::call_off`]).
    called_off: AtomicBool,
}

/// What a fit tells a race at a point it accepted.
pub(crate) struct Standing {
    /// Its deviance there.
    pub(crate) deviance: f64,
    /// The decrease in deviance its Gauss–Newton step predicts.
    pub(crate) predicted_gain: f64,
    /// Its free parameters.
    pub(crate) parameters: usize,
}

impl StartRace {
    /// A race whose deviances floor each output's variance at `floor`.
    pub fn new(floor: f64) -> StartRace {
        StartRace {
            floor,
            lowest: Mutex::new(f64::INFINITY),
            called_off: AtomicBool::new(false),
        }
    }

    /// Calls off every fit in the race: each ends at its next evaluation with
    /// [`crate::estimate::EstimationError::CalledOff`] (rc's free fit where the score
    /// test has kept the held network without it).
    pub fn call_off(&self) {
        self.called_off.store(true, Ordering::Relaxed);
    }

    /// Whether the race was called off ([`StartRace::call_off`]).
    pub(crate) fn is_called_off(&self) -> bool {
        self.called_off.load(Ordering::Relaxed)
    }

    /// The floor deviances are formed with.
    pub(crate) fn floor(&self) -> f64 {
        self.floor
    }

    /// Publishes `standing`; the gap D − D_best where it is too far behind the lowest
    /// deviance published to catch up (module documentation), `None` otherwise.
    pub(crate) fn behind(&self, standing: &Standing) -> Option<f64> {
        if !standing.deviance.is_finite() {
            return None;
        }
        let mut lowest = self.lowest.lock().unwrap_or_else(|p| p.into_inner());
        if standing.deviance < *lowest {
            *lowest = standing.deviance;
            return None;
        }
        let gap = standing.deviance - *lowest;
        let allowed = 2.0 * standing.parameters as f64 + 2.0 * standing.predicted_gain.max(0.0);
        (gap > allowed).then_some(gap)
    }
}

/// Σ_i N_i·ln max(σ̂²_i, `floor`), σ̂²_i = sse_i/(N_i·w_i) from the weighted squared error
/// `sse_i` of N_i entries at weight w_i = `sqrt_w_i`².
pub(crate) fn deviance(sse: &[f64], counts: &[usize], sqrt_w: &[f64], floor: f64) -> f64 {
    sse.iter()
        .zip(counts)
        .zip(sqrt_w)
        .map(|((s, &n), w)| {
            let variance = s / (n.max(1) as f64 * w.powi(2).max(1e-300));
            n as f64 * variance.max(floor).max(1e-300).ln()
        })
        .sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_start_is_dropped_only_when_further_behind_than_noise_and_its_own_gain_allow() {
        let race = StartRace::new(0.0);
        let at = |deviance, predicted_gain| Standing {
            deviance,
            predicted_gain,
            parameters: 10,
        };
        assert_eq!(race.behind(&at(-1000.0, 0.0)), None);
        // 15 behind: within 2·p = 20.
        assert_eq!(race.behind(&at(-985.0, 0.0)), None);
        // 30 behind with little left to gain: dropped.
        assert_eq!(race.behind(&at(-970.0, 1.0)), Some(30.0));
        // 30 behind but a step predicted to gain 10: kept.
        assert_eq!(race.behind(&at(-970.0, 10.0)), None);
        // The leader improves: it is never behind itself.
        assert_eq!(race.behind(&at(-1100.0, 0.0)), None);
    }

    #[test]
    fn the_deviance_takes_each_output_at_its_own_variance_floored() {
        // Two outputs, 100 entries each: σ̂² = 0.04 and 10⁻¹² (floored at 10⁻⁴).
        let d = deviance(&[4.0 * 2.0, 1e-10], &[100, 100], &[2f64.sqrt(), 1.0], 1e-4);
        let want = 100.0 * 0.04f64.ln() + 100.0 * 1e-4f64.ln();
        assert!((d - want).abs() < 1e-9, "{d} against {want}");
    }
}
