//! The alarm band: how far a part's measured temperature may stray from the model's
//! before it counts as outside, set from the model's own error.
//!
//! Rule: band_j = max(factor · RMSE_j, floor), RMSE_j the model's RMS simulation error
//! for state j on its validation data where the report has them (`replay --holdout`,
//! `--split-at`, `--validate`), else on its estimation data. The RMSE of a simulation
//! from a model identified on a noisy recording is about the sensor noise σ plus the
//! model's own error; a factor of 4 puts a single noisy instant well inside (4σ of
//! Gaussian noise: 6 in 100,000), and the hold time of the detector takes care of the
//! rest. The floor keeps the band from shrinking below what a sensor's calibration
//! (a class-A PT100: ±0.15 K at 0 °C, ±0.35 K at 100 °C) can vouch for between two
//! recordings made months apart.

use crate::model_file::{ModelError, ThermalModel};
use crate::spec::Reference;

/// Which band the monitor compares against.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum BandKind {
    /// One half-width per part for the whole recording: max(factor · RMSE_j, floor).
    #[default]
    Fixed,
    /// At each instant from what the model knows then ([`model_band_k`]):
    /// b_j(k) = factor · √(θ_base² var x̂_j(k) + σ_j² (+ σ_j²)), the prediction's
    /// variance from the covariance of Θ, the start's sensor noise and the process noise,
    /// σ_j the sensors' noise (twice where the state is measured from the model test's
    /// one initial sample, [`measurement_variance_k2`]); no floor. Where the report carries no covariance of Θ, the
    /// prediction's variance holds the start and the process noise only. For a model with
    /// hidden states, var ŷ_j of its outputs y = C x + D u, from the covariance of
    /// θ_h = [Φ Γ; C D] ([`crate::confidence::OpenLoopVariance`]).
    Model,
}

/// The rule that sets the band from the model's error.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BandRule {
    /// Multiple of the model's RMSE per part (fixed), or of the prediction's standard
    /// deviation (model).
    pub factor: f64,
    /// The narrowest band, K (the fixed band's).
    pub floor_k: f64,
    /// Fixed or from the model's prediction uncertainty.
    pub kind: BandKind,
}

impl Default for BandRule {
    /// 4 × RMSE, at least 0.5 K.
    fn default() -> Self {
        BandRule {
            factor: 4.0,
            floor_k: 0.5,
            kind: BandKind::Fixed,
        }
    }
}

/// The model band at an instant, K per state: factor · √(θ_base² var_j + w_j), `var`
/// the prediction's variance per state in model units², `measurement_k2` w_j what the
/// comparison adds whatever the model knows, K² ([`measurement_variance_k2`]).
pub fn model_band_k(factor: f64, base_k: f64, var: &[f64], measurement_k2: &[f64]) -> Vec<f64> {
    var.iter()
        .zip(measurement_k2)
        .map(|(v, w)| factor * (base_k * base_k * v + w).sqrt())
        .collect()
}

/// What a residual carries besides the prediction's variance, K² per state: the sensor's
/// noise σ_j² at this instant, and σ_j² again for a state measured from the model test's
/// own initial temperature ([`Reference::Initial`]): that reference was one sample, and
/// its error stays in every predicted temperature.
pub fn measurement_variance_k2(model: &ThermalModel) -> Vec<f64> {
    model
        .uncertainty
        .sensor_noise_k
        .iter()
        .zip(&model.states)
        .map(|(s, state)| {
            let reference = if state.reference == Reference::Initial {
                s * s
            } else {
                0.0
            };
            s * s + reference
        })
        .collect()
}

/// The rule a monitor runs with, and why where it is not the one asked for: a model
/// band needs a model that knows its sensors' noise. A model identified from data it
/// reproduces exactly (a noise-free synthetic run such as the shipped fixture: RMSE
/// 3·10⁻¹² K, [`crate::decide::estimator::EXACT_FIT_RMS_K`]) knows none, so its band
/// b_j = k·√(θ_base² var x̂_j + σ_j²) would be about 0 K wide and every sample of a real
/// recording an alarm (the fixture's model on a noisy run of the same machine: 100 % of
/// the instants outside). Such a monitor keeps the fixed band, whose floor is what a
/// sensor can vouch for, and says so.
pub fn rule_for(model: &ThermalModel, asked: BandRule) -> (BandRule, Option<String>) {
    let noiseless = model
        .uncertainty
        .sensor_noise_k
        .iter()
        .zip(&model.states)
        .filter(|(sigma, _)| !(**sigma >= crate::decide::estimator::EXACT_FIT_RMS_K))
        .map(|(_, state)| state.name.as_str())
        .collect::<Vec<_>>();
    if asked.kind != BandKind::Model || noiseless.is_empty() {
        return (asked, None);
    }
    let why = format!(
        "the model reproduces its own recording exactly (no sensor noise on {}), so a band \
         from what it knows would be about 0 K wide and every sample here outside it: the \
         fixed band max({} × RMSE, {} K) is used instead, as with --band fixed",
        noiseless.join(", "),
        asked.factor,
        asked.floor_k
    );
    (
        BandRule {
            kind: BandKind::Fixed,
            ..asked
        },
        Some(why),
    )
}

/// The band per state: |θ − θ̂| ≤ `half_width_k[j]` is inside.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Band {
    /// Half-width per state, K.
    pub half_width_k: Vec<f64>,
    /// The model's RMSE per state it was set from, K.
    pub model_rmse_k: Vec<f64>,
    /// What the RMSE is of (`validation on …` or `fit on the estimation data`).
    pub source: String,
    /// The factor applied.
    pub factor: f64,
    /// The floor, K.
    pub floor_k: f64,
    /// Fixed, or from the model's prediction uncertainty at each instant (then
    /// `half_width_k` is its mean over the instants compared, once the run is done).
    pub kind: BandKind,
}

impl Band {
    /// band_j = max(factor · RMSE_j, floor) (see the module's rule).
    pub fn from_model_error(error: &ModelError, rule: BandRule) -> Band {
        Band {
            half_width_k: error
                .rmse_k
                .iter()
                .map(|r| (rule.factor * r).max(rule.floor_k))
                .collect(),
            model_rmse_k: error.rmse_k.clone(),
            source: error.source.clone(),
            factor: rule.factor,
            floor_k: rule.floor_k,
            kind: rule.kind,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_band_is_a_multiple_of_the_error_above_the_floor() {
        let error = ModelError {
            source: "fit".into(),
            rmse_k: vec![0.05, 0.2, 0.5],
            max_abs_error_k: vec![0.2, 0.6, 1.5],
        };
        let band = Band::from_model_error(
            &error,
            BandRule {
                factor: 4.0,
                floor_k: 0.5,
                kind: BandKind::Fixed,
            },
        );
        // 4 × 0.05 = 0.2 < floor; 4 × 0.2 = 0.8; 4 × 0.5 = 2.0.
        assert_eq!(band.half_width_k, vec![0.5, 0.8, 2.0]);
    }
}
