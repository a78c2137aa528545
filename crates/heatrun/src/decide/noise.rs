//! The noise model every decision compares residuals with: per temperature, the white
//! noise the residuals show and the rounding of its stored values. A sensor stored to a
//! resolution r adds e uniform on [−r/2, r/2] to each reading, of variance r²/12, and on
//! a slow signal that error is a staircase, not white: a test that compares residuals with
//! white noise alone reads it as a disturbance (the whiteness test, `pem`'s likelihood
//! ratio) or as a frozen sensor. The floor below holds it, so that rounding alone never
//! moves a decision.

use serde::Serialize;

use crate::recording::SensorChannel;
use crate::screen;
use crate::signals::ModelSignals;
use crate::spec::ModelDescription;

/// Residuals whose variance is at most this multiple of the rounding's r²/12 on every
/// output are what the resolution makes: whatever they hold beyond the rounding is at
/// most as large as the rounding itself, which no sensor of that resolution can tell
/// from it.
pub const EXPLAINED_BY_ROUNDING: f64 = 2.0;

/// A model whose residual RMS on some state is more than this multiple of that
/// sensor's white noise misses the data by a course of its own, not by noise: refinements
/// sized to the noise (the first sample's offset) buy nothing there. The models that fit
/// leave 1.0 to 1.3 times the noise (the RC unit's and the paper's noisy runs); the
/// paper's formulation on a run whose flow is cut leaves 9 times (its outlet).
pub const MISFIT_BEYOND_NOISE: f64 = 3.0;

/// Where a temperature's resolution comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ResolutionSource {
    /// The recording's channel metadata `resolution`.
    Declared,
    /// The smallest common step of its values on the grid ([`screen::robust::resolution`]).
    Estimated,
}

/// Each state's resolution and the floor it sets under any noise variance.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct NoiseFloor {
    /// Per state: the resolution r_j, K (0 where the values show none).
    pub resolution_k: Vec<f64>,
    /// Per state: where r_j comes from.
    pub source: Vec<ResolutionSource>,
    /// θ_base, K: the states' unit in the model (x = θ/θ_base).
    pub temperature_base_k: f64,
    /// Per state: the sensor's white noise σ_j, K, as the screen measured it
    /// (1.4826·MAD of the residuals' first differences / √2, which a slow misfit does not
    /// reach: [`crate::screen::glitch::noise_scale_k`]); empty before the screen.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub white_noise_k: Vec<f64>,
}

impl NoiseFloor {
    /// The floor of a replay's states: each state's channel's declared resolution (the
    /// finest of its sensors), else the one its values on the grid show.
    pub fn of(
        model: &ModelDescription,
        signals: &ModelSignals,
        channels: &[SensorChannel],
    ) -> NoiseFloor {
        let (resolution_k, source) = model
            .states
            .iter()
            .zip(&signals.states)
            .map(|(state, signal)| {
                let declared = channels
                    .iter()
                    .filter(|c| c.signal == state.channel)
                    .filter_map(|c| c.resolution)
                    .reduce(f64::min);
                match declared {
                    Some(r) => (r, ResolutionSource::Declared),
                    None => (
                        screen::robust::resolution(&signal.measured),
                        ResolutionSource::Estimated,
                    ),
                }
            })
            .unzip();
        NoiseFloor {
            resolution_k,
            source,
            temperature_base_k: signals.temperature_base_k,
            white_noise_k: Vec::new(),
        }
    }

    /// A floor of known resolutions (K) at base θ_base, for tests and callers with data
    /// that are not a replay's.
    pub fn from_resolutions(resolution_k: Vec<f64>, temperature_base_k: f64) -> NoiseFloor {
        let source = vec![ResolutionSource::Declared; resolution_k.len()];
        NoiseFloor {
            resolution_k,
            source,
            temperature_base_k,
            white_noise_k: Vec::new(),
        }
    }

    /// The floor with the sensors' white noise σ_j (K) the screen measured.
    pub fn with_white_noise(self, white_noise_k: Vec<f64>) -> NoiseFloor {
        NoiseFloor {
            white_noise_k,
            ..self
        }
    }

    /// Whether a model whose residuals have these variances (model units, per state)
    /// misses the data by far more than the sensors' noise on some state: its residual
    /// RMS above [`MISFIT_BEYOND_NOISE`] × max(σ_j, r_j/√12). False where the screen
    /// measured no noise.
    pub fn misfit_beyond_noise(&self, residual_variance: &[f64]) -> bool {
        residual_variance
            .iter()
            .zip(&self.white_noise_k)
            .enumerate()
            .any(|(j, (v, sigma_k))| {
                let noise = (sigma_k / self.temperature_base_k)
                    .powi(2)
                    .max(self.variance(j));
                noise > 0.0 && *v > MISFIT_BEYOND_NOISE.powi(2) * noise
            })
    }

    /// The rounding's variance of state j in the model's units: (r_j/θ_base)²/12.
    pub fn variance(&self, j: usize) -> f64 {
        let r = self.resolution_k.get(j).copied().unwrap_or(0.0) / self.temperature_base_k;
        r * r / 12.0
    }

    /// Each variance raised to its state's rounding variance at least: no fit can leave
    /// less unexplained than the rounding, so a likelihood compares nothing below it.
    pub fn floored(&self, variance: &[f64]) -> Vec<f64> {
        variance
            .iter()
            .enumerate()
            .map(|(j, v)| v.max(self.variance(j)))
            .collect()
    }

    /// The largest rounding variance of the states, in the model's units.
    pub fn largest_variance(&self) -> f64 {
        (0..self.resolution_k.len())
            .map(|j| self.variance(j))
            .fold(0.0, f64::max)
    }

    /// Whether residuals of these variances (model units, per state) are the rounding's:
    /// each at most [`EXPLAINED_BY_ROUNDING`] × r_j²/12, with some rounding to explain.
    pub fn explains(&self, residual_variance: &[f64]) -> bool {
        !residual_variance.is_empty()
            && residual_variance.iter().enumerate().all(|(j, v)| {
                let q = self.variance(j);
                q > 0.0 && *v <= EXPLAINED_BY_ROUNDING * q
            })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rounding_to_r_has_the_variance_of_a_uniform_error_r_squared_over_12() {
        // Independent reference: the variance of a fine ramp rounded to 0.01 K, counted.
        let r = 0.01;
        let n = 100_000;
        let errors: Vec<f64> = (0..n)
            .map(|k| {
                let v = 40.0 + 0.3 * k as f64 / n as f64 + 1e-7 * k as f64;
                (v / r).round() * r - v
            })
            .collect();
        let counted = errors.iter().map(|e| e * e).sum::<f64>() / n as f64;
        let floor = NoiseFloor::from_resolutions(vec![r], 1.0);
        assert!(
            (floor.variance(0) / counted - 1.0).abs() < 0.02,
            "{counted}"
        );
        // Residuals that are the rounding are explained; twice its σ is not.
        assert!(floor.explains(&[counted]));
        assert!(!floor.explains(&[4.0 * counted]));
        // In per unit (θ_base 100 K) the same.
        let pu = NoiseFloor::from_resolutions(vec![r], 100.0);
        assert!(pu.explains(&[counted / 1e4]));
    }

    #[test]
    fn a_misfit_is_told_from_the_noise_against_each_sensors_white_noise() {
        // θ_base 80 K; white noise 0.05 K on both outputs, the second rounded to 0.01 K.
        let floor =
            NoiseFloor::from_resolutions(vec![0.0, 0.01], 80.0).with_white_noise(vec![0.05, 0.05]);
        let variance = |rms_k: f64| (rms_k / 80.0f64).powi(2);
        // Residuals at the noise (a model that fits), and up to three times it: no misfit.
        assert!(!floor.misfit_beyond_noise(&[variance(0.05), variance(0.06)]));
        assert!(!floor.misfit_beyond_noise(&[variance(0.149), variance(0.149)]));
        // One output nine times its noise (the paper's formulation on a flow cut: the
        // outlet's 0.47 K against 0.052 K) is a misfit.
        assert!(floor.misfit_beyond_noise(&[variance(0.05), variance(0.47)]));
        // Before the screen measured any noise nothing is told.
        let unscreened = NoiseFloor::from_resolutions(vec![0.0, 0.01], 80.0);
        assert!(!unscreened.misfit_beyond_noise(&[variance(0.05), variance(0.47)]));
        // A noise below the rounding's r/√12 is taken at the rounding's.
        let rounded = NoiseFloor::from_resolutions(vec![0.1], 1.0).with_white_noise(vec![1e-6]);
        assert!(!rounded.misfit_beyond_noise(&[(0.08f64).powi(2)]));
        assert!(rounded.misfit_beyond_noise(&[(0.1f64).powi(2)]));
    }

    #[test]
    fn no_resolution_explains_nothing_and_floors_nothing() {
        let floor = NoiseFloor::from_resolutions(vec![0.0, 0.1], 1.0);
        assert!(!floor.explains(&[0.0, 1e-4]));
        let floored = floor.floored(&[1e-9, 1e-9]);
        assert_eq!(floored[0], 1e-9);
        assert!((floored[1] - 0.01 / 12.0).abs() < 1e-15, "{floored:?}");
    }
}
