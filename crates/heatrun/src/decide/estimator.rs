//! Which estimator a replay uses: the one asked, or, by default, `oe` or `pem` with
//! the disturbance state, chosen by what `oe`'s residuals hold beyond the sensors' noise
//! and resolution ([`super::noise::NoiseFloor`]).

use crate::error::{Error, Result};
use crate::estimate::excitation::input_dependence;
use crate::estimate::{
    Estimate, EstimationError, Estimator, IdentificationData, InstrumentalVariables, Method,
    OutputError, PredictionError, RecursiveLeastSquares, ResistanceCapacitance,
    WeightedLeastSquares,
};
use crate::model;
use crate::network;
use crate::options::ReplayOptions;
use crate::spec::ModelDescription;

use super::noise::NoiseFloor;
use super::{Candidate, Decision, Figure};

/// Which estimator a replay chose, and why: `oe`, or `pem` (with the disturbance state
/// where the model has a cooling-water node) where `oe`'s residuals are not white and the
/// likelihood ratio of `pem`'s innovations against them says the gain is real.
#[derive(Debug, Clone, serde::Serialize)]
pub struct EstimatorChoice {
    /// The method chosen.
    pub method: Method,
    /// Why, in a sentence.
    pub reason: String,
    /// Per output, the fraction of lags 1..max_lag of `oe`'s simulation residuals'
    /// autocorrelation outside the 99 % band of a white sequence (about 0.01 when white).
    pub oe_autocorrelation_outside_band: Vec<f64>,
    /// The fraction above which an output's residuals are taken as not white.
    pub threshold: f64,
    /// Per output, Ljung and Box's Q of `oe`'s simulation residuals over lags 1..max_lag,
    /// and the critical value above which the largest says they are not white ([`LjungBox`]).
    pub oe_ljung_box: LjungBox,
    /// The likelihood ratio of `pem` against `oe`, where `pem` was fitted to test it
    /// (each fit's variance floored at the rounding's r²/12: [`NoiseFloor::floored`]).
    pub likelihood_ratio: Option<crate::estimate::LikelihoodRatio>,
    /// Per output: the RMS of `oe`'s simulation residuals, K.
    pub oe_rms_k: Vec<f64>,
    /// Per output: the resolution the residuals were compared with, K.
    pub resolution_k: Vec<f64>,
    /// Per output: the state's name, for the decision's figures (the report keeps its
    /// outputs in the states' order and does not repeat them).
    #[serde(skip)]
    pub outputs: Vec<String>,
}

impl EstimatorChoice {
    /// Output `j`'s state name, or "output j+1" where the choice was made without them.
    fn output_name(&self, j: usize) -> String {
        self.outputs
            .get(j)
            .cloned()
            .unwrap_or_else(|| format!("output {}", j + 1))
    }

    /// The choice as a [`Decision`]: `oe` with its residuals' RMS, whiteness and the
    /// resolution beside them; `pem` with the likelihood ratio where it was fitted.
    pub fn decision(&self) -> Decision {
        let mut oe = Vec::new();
        for (j, ((rms, outside), r)) in self
            .oe_rms_k
            .iter()
            .zip(&self.oe_autocorrelation_outside_band)
            .zip(&self.resolution_k)
            .enumerate()
        {
            oe.push(Figure::new(
                &format!("{} residuals' RMS", self.output_name(j)),
                *rms,
                "K",
            ));
            oe.push(Figure::new(
                &format!("{} lags outside the 99 % band", self.output_name(j)),
                100.0 * outside,
                "%",
            ));
            oe.push(Figure::new(
                &format!("{} resolution", self.output_name(j)),
                *r,
                "K",
            ));
            if let Some(q) = self.oe_ljung_box.statistic.get(j) {
                oe.push(Figure::new(
                    &format!(
                        "{} Ljung–Box Q over {} lags",
                        self.output_name(j),
                        self.oe_ljung_box.degrees_of_freedom
                    ),
                    *q,
                    "",
                ));
            }
        }
        oe.push(Figure::new(
            "Ljung–Box critical value (size 1 % over the outputs)",
            self.oe_ljung_box.critical,
            "",
        ));
        let pem = match &self.likelihood_ratio {
            Some(lr) => vec![
                Figure::new("likelihood ratio", lr.statistic, ""),
                Figure::new("critical value (size 1 %)", lr.critical, ""),
                Figure::new("parameters added", lr.degrees_of_freedom as f64, ""),
            ],
            None => vec![],
        };
        Decision {
            what: "estimator".into(),
            candidates: vec![
                Candidate::new("oe", oe),
                Candidate::new("pem (disturbance state)", pem),
            ],
            chosen: self.method.to_string(),
            reason: self.reason.clone(),
        }
    }
}

/// Ljung and Box's portmanteau test of residuals' whiteness: per output
/// Q = N(N+2) Σ_{τ=1}^{L} r_τ²/(N−τ) ([`model::residuals::ljung_box`]), the largest over the
/// n outputs against χ²_L's (0.99)^(1/n) quantile: a test of size 1 % of the whole model
/// ([`crate::estimate::innovations_ratio::chi_square_quantile_of_largest`]). Each output
/// held to χ²_L's 0.99 quantile made it a test of size 3 % for three outputs and 4 % for
/// four, and fitted `pem` on that many white-noise runs for nothing.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct LjungBox {
    /// Q per output.
    pub statistic: Vec<f64>,
    /// L, the lags summed (the χ² distribution's degrees of freedom).
    pub degrees_of_freedom: usize,
    /// χ²_L's (0.99)^(1/n) quantile, n the outputs tested.
    pub critical: f64,
}

impl LjungBox {
    /// The test of a residual analysis.
    pub fn of(residuals: &model::residuals::ResidualAnalysis) -> Self {
        LjungBox {
            statistic: residuals.ljung_box_q.clone(),
            degrees_of_freedom: residuals.max_lag,
            critical: crate::estimate::innovations_ratio::chi_square_quantile_of_largest(
                residuals.max_lag,
                residuals.ljung_box_q.len(),
            ),
        }
    }

    /// The largest Q.
    pub fn largest(&self) -> f64 {
        self.statistic.iter().copied().fold(0.0, f64::max)
    }

    /// Whether some output's Q is beyond the critical value.
    pub fn rejects_white(&self) -> bool {
        self.largest() > self.critical
    }
}

/// Above this fraction of lags outside the 99 % band, a residual is not white: 6 of 60
/// lags, where a white sequence puts one lag in a hundred outside (P(≥ 6 of 60) ≈ 4·10⁻⁵
/// for independent lags).
pub const NOT_WHITE_FRACTION: f64 = 0.1;

/// Below this RMS (K) on every output `oe`'s simulation reproduces the data (a noise-free
/// run): there is no noise for a predictor to model, and a likelihood ratio of rounding
/// errors would be no test.
pub const EXACT_FIT_RMS_K: f64 = 1e-6;

/// The state a disturbance enters where the model has one: the cooling water's, where an
/// unmeasured heat (a valve, the air circuit, a neighbour) arrives.
pub fn disturbance_state(model: &ModelDescription) -> Option<usize> {
    let outlet =
        crate::recording::Signal::Profile(crate::recording::Quantity::CoolingWaterOutletTemp);
    model.states.iter().position(|s| s.channel == outlet)
}

/// The estimate of `options.method`, or, where the method is `oe`, the replay is to
/// choose ([`ReplayOptions::choose_estimator`]) and the model has a cooling-water state
/// ([`disturbance_state`]), the choice between `oe` and `pem` with the disturbance state:
/// `oe`'s fit; `oe` kept where it reproduces the data ([`EXACT_FIT_RMS_K`]) or its
/// simulation residuals are white (the sensors' noise is all there is; `pem` would cost
/// a second fit for nothing); else `pem` from that fit, taken where the likelihood ratio
/// of its innovations against `oe`'s residuals rejects K_a = 0 at size 1 %
/// ([`crate::estimate::LikelihoodRatio`]). The whiteness test alone is too eager (a
/// small systematic misfit of the RC unit's white-noise runs fails it); the ratio weighs
/// what the gain buys against the parameters it costs. Data stored by exception keep
/// `oe`, whose likelihood of the censored values `pem` does not have.
pub fn estimate_chosen(
    data: &IdentificationData,
    options: &ReplayOptions,
    scaling: network::Scaling,
    noise: &NoiseFloor,
) -> Result<(Estimate, Option<EstimatorChoice>)> {
    choose(data, options, scaling, noise).map_err(|e| named_dependence(e, data, options))
}

/// A rank-deficient regression whose cause lies in the inputs, said with their names (two
/// proportional inputs, or two constant ones: [`input_dependence`]); any other error as it
/// is.
fn named_dependence(e: Error, data: &IdentificationData, options: &ReplayOptions) -> Error {
    let Error::Estimation(EstimationError::NoExcitation { method, .. }) = &e else {
        return e;
    };
    let Some(dependence) = input_dependence(data) else {
        return e;
    };
    let names: Vec<String> = options
        .model
        .inputs
        .iter()
        .map(|i| i.name.clone())
        .collect();
    Error::Estimation(EstimationError::DependentInputs {
        method,
        which: dependence.describe(&names),
        constant: dependence.constant.is_some(),
    })
}

/// [`estimate_chosen`] before its error is named.
fn choose(
    data: &IdentificationData,
    options: &ReplayOptions,
    scaling: network::Scaling,
    noise: &NoiseFloor,
) -> Result<(Estimate, Option<EstimatorChoice>)> {
    // Without a cooling-water state there is no disturbance state to offer: a free gain
    // (white process noise) was measured worse than `oe` on a wandering heat, so such a
    // model keeps `oe`.
    let Some(state) = disturbance_state(&options.model) else {
        return Ok((estimate_in(data, options, scaling)?, None));
    };
    if !options.choose_estimator
        || options.method != Method::Oe
        || crate::estimate::oe::censored::applies(data)
        || state >= data.states()
    {
        return Ok((estimate_in(data, options, scaling)?, None));
    }
    let oe = OutputError {
        weights: options.weights.clone(),
        progress: options.progress.clone(),
    };
    let start = oe.start(data).map_err(Error::from)?;
    let fitted = oe.fit(data, &start).map_err(Error::from)?;
    let segments = data.segments();
    // oe's own residuals: from the initial states it fitted, not the measured first
    // sample, whose noise would decay through the slow modes and fail the whiteness
    // test on every noisy run.
    let simulated = fitted.simulate_segments(data, &segments);
    let residuals = model::residuals::analyse_whiteness(data, &simulated, model::RESIDUAL_MAX_LAG);
    let ljung_box = LjungBox::of(&residuals);
    let outside = residuals.autocorrelation_outside_band;
    let worst = outside.iter().copied().fold(0.0, f64::max);
    // The band judges each lag alone and misses a small correlation held over many (a
    // slow heat into the water that `oe` half follows); Q sums them.
    let not_white = worst > NOT_WHITE_FRACTION || ljung_box.rejects_white();
    let whiteness = format!(
        "worst output's: {:.0} % of lags outside the 99 % band, Ljung–Box Q {:.1} {} {:.1}, \
         χ²'s quantile over {} lags for a size of 1 % over {} outputs",
        100.0 * worst,
        ljung_box.largest(),
        if ljung_box.rejects_white() {
            ">"
        } else {
            "≤"
        },
        ljung_box.critical,
        ljung_box.degrees_of_freedom,
        ljung_box.statistic.len()
    );
    let rms_per_output_k: Vec<f64> = fitted
        .estimate
        .noise_variance
        .iter()
        .map(|v| v.sqrt() * scaling.theta_base_k)
        .collect();
    let choice = |method, reason, likelihood_ratio| EstimatorChoice {
        method,
        reason,
        oe_autocorrelation_outside_band: outside.clone(),
        threshold: NOT_WHITE_FRACTION,
        oe_ljung_box: ljung_box.clone(),
        likelihood_ratio,
        oe_rms_k: rms_per_output_k.clone(),
        resolution_k: noise.resolution_k.clone(),
        outputs: options
            .model
            .states
            .iter()
            .map(|s| s.name.clone())
            .collect(),
    };
    let rms_k = rms_per_output_k.iter().copied().fold(0.0_f64, f64::max);
    if rms_k < EXACT_FIT_RMS_K {
        let reason = format!(
            "oe reproduces the data (residuals' RMS {rms_k:.1e} K): there is no noise for a predictor to model"
        );
        return Ok((fitted.estimate, Some(choice(Method::Oe, reason, None))));
    }
    // Residuals no larger than the rounding's are the rounding, white or not (a staircase
    // on a slow signal is not): a predictor would follow the staircase one step ahead
    // and its likelihood would call that a disturbance.
    if noise.explains(&fitted.estimate.noise_variance) {
        let reason = format!(
            "oe's residuals (RMS at most {rms_k:.2e} K) are what the sensors' resolution makes \
             (rounding's RMS r/√12 ≤ {:.2e} K, r the resolution): rounding is no disturbance",
            noise
                .resolution_k
                .iter()
                .fold(0.0_f64, |m, r| m.max(r / 12f64.sqrt()))
        );
        return Ok((fitted.estimate, Some(choice(Method::Oe, reason, None))));
    }
    if !not_white {
        let reason =
            format!("oe's residuals are white ({whiteness}): the sensors' noise is all there is");
        return Ok((fitted.estimate, Some(choice(Method::Oe, reason, None))));
    }
    let pem = PredictionError {
        weights: options.weights.clone(),
        progress: options.progress.clone(),
        disturbance_state: Some(state),
    };
    // Where no predictor with the disturbance state can be fitted (no intensity gives a
    // stable Kalman filter: a frozen stretch makes the residuals far from white, and the
    // data offer the filter nothing to follow), the default keeps `oe` and says why:
    // the choice is the default's, not the user's, so its failure is not theirs either.
    let estimate = match pem.refine(data, &fitted.estimate, &fitted.initial_states) {
        Ok(estimate) => estimate,
        Err(e) => {
            let reason = format!(
                "oe's residuals are not white, but no predictor with a disturbance state could be fitted ({e}): oe kept"
            );
            return Ok((fitted.estimate, Some(choice(Method::Oe, reason, None))));
        }
    };
    let counts = data.observed_counts(&segments);
    // The likelihood holds the resolution: neither fit's variance is taken below the
    // rounding's r²/12, so innovations that follow the rounding's staircase gain nothing.
    let (oe_variance, pem_variance) = (
        noise.floored(&fitted.estimate.noise_variance),
        noise.floored(&estimate.noise_variance),
    );
    let lr = match estimate.predictor.as_ref() {
        Some(p) if p.disturbance.is_some() => {
            crate::estimate::LikelihoodRatio::intensity(&counts, &oe_variance, &pem_variance)
        }
        _ => crate::estimate::LikelihoodRatio::gain(
            &counts,
            &oe_variance,
            &pem_variance,
            data.states() * data.states(),
        ),
    };
    let what = if estimate
        .predictor
        .as_ref()
        .is_some_and(|p| p.disturbance.is_some())
    {
        "a random-walk heat into the cooling water"
    } else {
        "a process noise"
    };
    if lr.rejects_zero_gain() {
        let reason = format!(
            "oe's residuals are not white ({whiteness}) and pem's innovations explain them: likelihood ratio {:.1} > {:.1} ({} parameter(s), size 1 %): {what} the inputs do not explain",
            lr.statistic,
            lr.critical,
            lr.degrees_of_freedom
        );
        return Ok((estimate, Some(choice(Method::Pem, reason, Some(lr)))));
    }
    let reason = format!(
        "oe's residuals are not white ({whiteness}), but pem's gain does not pay for its {} parameter(s): likelihood ratio {:.1} ≤ {:.1} (size 1 %)",
        lr.degrees_of_freedom,
        lr.statistic,
        lr.critical
    );
    Ok((fitted.estimate, Some(choice(Method::Oe, reason, Some(lr)))))
}

/// Runs the chosen estimator on the data; `rc`'s network is then in the data's own units
/// (states in K, inputs in W): [`estimate_in`] gives it the model's scaling.
pub fn estimate(data: &IdentificationData, options: &ReplayOptions) -> Result<Estimate> {
    estimate_in(data, options, network::Scaling::PHYSICAL)
}

/// Runs the chosen estimator on data in `scaling` (x = θ/θ_base, u = P/P_base), which
/// `rc` needs to put its network in J/K and W/K. `rc` refuses a model with an input that
/// is not heat: a thermal network has no place for it.
pub fn estimate_in(
    data: &IdentificationData,
    options: &ReplayOptions,
    scaling: network::Scaling,
) -> Result<Estimate> {
    if let Some(w) = &options.weights {
        if w.len() != data.states() || w.iter().any(|x| !(x.is_finite() && *x > 0.0)) {
            return Err(Error::Weights {
                states: data.states(),
                given: w.len(),
            });
        }
    }
    let per_instant =
        |w: &Vec<f64>| nalgebra::DMatrix::from_fn(data.len(), data.states(), |_, j| w[j]);
    let estimator: Box<dyn Estimator> = match options.method {
        Method::Ls => Box::new(WeightedLeastSquares::default()),
        Method::Wls => Box::new(WeightedLeastSquares {
            weights: options.weights.as_ref().map(per_instant),
        }),
        Method::Rls => Box::new(RecursiveLeastSquares {
            forgetting: options.forgetting,
            keep_every: 10,
        }),
        Method::Iv => Box::new(InstrumentalVariables::default()),
        Method::Oe => Box::new(OutputError {
            weights: options.weights.clone(),
            progress: options.progress.clone(),
        }),
        Method::Pem => Box::new(PredictionError {
            weights: options.weights.clone(),
            progress: options.progress.clone(),
            disturbance_state: disturbance_state(&options.model),
        }),
        Method::Rc => {
            if let Some(input) = options
                .model
                .inputs
                .iter()
                .find(|i| i.kind != crate::spec::InputKind::Heat)
            {
                return Err(EstimationError::InputNotHeat {
                    input: input.name.clone(),
                }
                .into());
            }
            Box::new(ResistanceCapacitance {
                weights: options.weights.clone(),
                scaling,
                progress: options.progress.clone(),
                coordinates: crate::estimate::StepCoordinates::Logarithms,
            })
        }
    };
    let estimate = estimator.estimate(data)?;
    // rc's fit ending on a model that is no network (an eigenvalue of Φ at 0: a part's
    // capacitance gone to zero) is the data's answer, said so in one line, not an analysis
    // that fails after it.
    if options.method == Method::Rc {
        if let Err(e) = crate::model::ContinuousModel::from_discrete(&estimate.model) {
            return Err(EstimationError::NoNetworkFits {
                reason: e.to_string(),
            }
            .into());
        }
        if let Some(reason) = misfit_beyond_free_model(&estimate, scaling.theta_base_k) {
            return Err(EstimationError::NoNetworkFits { reason }.into());
        }
    }
    Ok(estimate)
}

/// The least residual RMS, in kelvin, an output is taken to carry when rc's network is
/// judged against the free model: a PT100 transducer's resolution (noise-free data leave
/// the free model 10⁻¹² K, against which any network's rounding would count as a misfit).
const JUDGED_NOISE_FLOOR_K: f64 = 0.01;

/// Why rc's best passive network is no network of these data, where it is: on some output
/// it leaves √(σ̂²_rc − σ̂²_oe) more than [`super::noise::MISFIT_BEYOND_NOISE`] times the
/// free model's (`oe`'s, fitted beside it) residual RMS σ̂_oe (at least
/// [`JUDGED_NOISE_FLOOR_K`]) unexplained beyond those residuals. The paper's model is no
/// passive network: on its noisy run rc's best network leaves 0.40 K beyond `oe`'s 0.05 K
/// on the stator winding (its T1 278 % off); a network's own data leave rc within the
/// noise of `oe` (the RC unit: 0.050 K against 0.050 K).
fn misfit_beyond_free_model(estimate: &Estimate, theta_base_k: f64) -> Option<String> {
    let free = &estimate.network.as_ref()?.output_error;
    let base2 = theta_base_k * theta_base_k;
    estimate
        .noise_variance
        .iter()
        .zip(&free.noise_variance)
        .enumerate()
        .map(|(j, (rc, oe))| {
            let noise_k = (oe * base2).sqrt().max(JUDGED_NOISE_FLOOR_K);
            let beyond_k = ((rc - oe) * base2).max(0.0).sqrt();
            (j, beyond_k, noise_k)
        })
        .filter(|(_, beyond_k, noise_k)| *beyond_k > super::noise::MISFIT_BEYOND_NOISE * noise_k)
        .max_by(|a, b| (a.1 / a.2).total_cmp(&(b.1 / b.2)))
        .map(|(j, beyond_k, noise_k)| {
            format!(
                "its best network leaves {beyond_k:.3} K RMS unexplained on output {} beyond \
                 the free model's {noise_k:.3} K, more than {} times them",
                j + 1,
                super::noise::MISFIT_BEYOND_NOISE
            )
        })
}

#[cfg(test)]
mod tests {
    use nalgebra::DMatrix;
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};

    use super::*;
    use crate::estimate::testing::{simulate, step_inputs, two_state_model, with_noise};
    use crate::options::NetworkChoice;
    use crate::pipeline::{replay, Replay};

    /// The two-state model's outputs with white sensor noise, and with a random-walk heat
    /// into state 0 as well (the disturbance the inputs do not explain).
    fn runs() -> (IdentificationData, IdentificationData) {
        let truth = two_state_model();
        let u = step_inputs(20_000, 2, 5);
        let y = simulate(&truth, &u, &[0.5, 0.2]);
        let white = IdentificationData::complete(1.0, with_noise(&y, 0.02, 6), u.clone());
        let mut rng = rand::rngs::StdRng::seed_from_u64(7);
        let step = Normal::new(0.0, 0.002).unwrap();
        let (mut heat, mut walked) = (0.0, DMatrix::zeros(20_000, 2));
        let mut x = nalgebra::DVector::from_column_slice(&[0.5, 0.2]);
        for k in 0..20_000 {
            walked.set_row(k, &x.transpose());
            heat += step.sample(&mut rng);
            x = &truth.phi * &x + &truth.gamma * u.row(k).transpose();
            x[0] += heat;
        }
        let disturbed = IdentificationData::complete(1.0, with_noise(&walked, 0.02, 6), u);
        (white, disturbed)
    }

    #[test]
    fn the_default_keeps_oe_on_white_residuals_and_takes_pem_where_they_are_not() {
        let (white, disturbed) = runs();
        // Two states, the first the cooling water's (where the walk enters).
        let mut model = ModelDescription::generator();
        model.states = vec![model.states[2].clone(), model.states[1].clone()];
        let options = ReplayOptions {
            choose_estimator: true,
            model: model.clone(),
            ..ReplayOptions::default()
        };
        let (e, choice) = estimate_chosen(
            &white,
            &options,
            network::Scaling::PHYSICAL,
            &NoiseFloor::from_resolutions(vec![], 1.0),
        )
        .unwrap();
        let choice = choice.expect("the replay chooses");
        assert_eq!(
            (e.method, choice.method),
            (Method::Oe, Method::Oe),
            "{}",
            choice.reason
        );
        assert!(choice
            .oe_autocorrelation_outside_band
            .iter()
            .all(|v| *v <= NOT_WHITE_FRACTION));
        let (e, choice) = estimate_chosen(
            &disturbed,
            &options,
            network::Scaling::PHYSICAL,
            &NoiseFloor::from_resolutions(vec![], 1.0),
        )
        .unwrap();
        let choice = choice.unwrap();
        assert_eq!(
            (e.method, choice.method),
            (Method::Pem, Method::Pem),
            "{}",
            choice.reason
        );
        let d = e.predictor.as_ref().and_then(|p| p.disturbance.as_ref());
        assert_eq!(d.map(|d| d.state), Some(0), "the walk's state");
        let lr = choice.likelihood_ratio.expect("pem was tested against oe");
        assert!(lr.rejects_zero_gain() && lr.statistic > lr.critical);
        // Without a cooling-water state the default keeps oe and does not choose.
        let mut dry = ModelDescription::generator();
        dry.states.truncate(2);
        let no_water = ReplayOptions {
            choose_estimator: true,
            model: dry,
            ..ReplayOptions::default()
        };
        let (e, choice) = estimate_chosen(
            &disturbed,
            &no_water,
            network::Scaling::PHYSICAL,
            &NoiseFloor::from_resolutions(vec![], 1.0),
        )
        .unwrap();
        assert_eq!(e.method, Method::Oe);
        assert!(choice.is_none());
        // A method given is run as given, whatever the residuals.
        let given = ReplayOptions {
            model,
            ..ReplayOptions::default()
        };
        let (e, choice) = estimate_chosen(
            &disturbed,
            &given,
            network::Scaling::PHYSICAL,
            &NoiseFloor::from_resolutions(vec![], 1.0),
        )
        .unwrap();
        assert_eq!(e.method, Method::Oe);
        assert!(choice.is_none());
    }

    /// A noisy heat run of the RC unit with 30 kW/√h of unmeasured heat into the cooling
    /// water (its outlet wanders 0.4 K, seed 1): the default takes pem with the
    /// disturbance state, whose time constants lie within three of their reported
    /// standard errors of the truth and whose steady state is within 1 K (the issue's
    /// bar); `oe` on the same run misses the slowest constant by more than its three σ.
    #[test]
    fn the_default_recovers_a_heat_run_with_a_wandering_heat_into_the_cooling_water() {
        use crate::synth::{self, Disturbances, Machine, NetworkMachine, SynthOptions};
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("walk.mcap");
        let truth = synth::write(
            &path,
            &SynthOptions {
                machine: Machine::Network(NetworkMachine::rc_unit()),
                disturbances: Disturbances {
                    coolant_heat_walk_kw_per_sqrt_h: 30.0,
                    ..Disturbances::default()
                },
                temperature_noise_k: 0.05,
                temperature_resolution_k: 0.01,
                seed: 1,
                ..SynthOptions::default()
            },
        )
        .unwrap();
        let run = |choose| {
            replay(
                &path,
                &ReplayOptions {
                    choose_estimator: choose,
                    // The estimator's bars only: rc's network fit has no part in them.
                    network: NetworkChoice::Nearest,
                    ..ReplayOptions::default()
                },
            )
            .unwrap()
        };
        let off_by_sigmas = |r: &Replay| -> Vec<f64> {
            let u = r.analysis.uncertainty.as_ref().unwrap();
            (0..3)
                .map(|i| {
                    let t = truth.time_constants_s[i];
                    let sigma = u.time_constants_ci95_s[i] / 1.96;
                    (r.analysis.spectrum.time_constants_s[i] - t).abs() / sigma
                })
                .collect()
        };
        let chosen = run(true);
        assert_eq!(chosen.estimate.method, Method::Pem);
        let d = chosen
            .estimate
            .predictor
            .as_ref()
            .unwrap()
            .disturbance
            .as_ref();
        assert_eq!(d.map(|d| d.state), Some(2), "the cooling water's node");
        let z = off_by_sigmas(&chosen);
        assert!(z.iter().all(|z| *z < 3.0), "pem: {z:?} σ");
        let base = chosen.signals.temperature_base_k;
        let refs = chosen.signals.initial_references();
        for (j, rise) in truth.steady_state_rise_k.iter().enumerate() {
            let predicted = refs[j] + base * chosen.analysis.steady_state[j];
            let error = predicted - truth.coolant.inlet_initial_c - rise;
            assert!(
                error.abs() < 1.0,
                "state {j}: steady state off by {error} K"
            );
        }
        let oe = run(false);
        assert_eq!(oe.estimate.method, Method::Oe);
        assert!(
            off_by_sigmas(&oe)[2] > 3.0,
            "oe: {:?} σ",
            off_by_sigmas(&oe)
        );
    }

    /// rc on a two-part network's own noisy data leaves no more than the free model
    /// does; the same estimate with ten times the residual RMS is refused, naming the
    /// output and both figures.
    #[test]
    fn rc_is_refused_where_its_network_misses_the_data_far_beyond_the_free_model() {
        use crate::estimate::ResistanceCapacitance;
        use crate::network::{Parts, Scaling};
        let parts = Parts {
            capacitance_j_per_k: vec![200.0, 1000.0],
            conductance_w_per_k: DMatrix::from_row_slice(2, 2, &[1.0, 3.0, 3.0, 2.0]),
            loss_distribution: DMatrix::from_row_slice(2, 2, &[0.8, 0.3, 0.2, 0.7]),
        };
        let scaling = Scaling {
            theta_base_k: 1.0,
            p_base_w: 20.0,
        };
        let map = crate::thermal::rc::Parametrisation::of_shape(1.0, scaling, &parts);
        let u = step_inputs(3000, 2, 21);
        let y = with_noise(&simulate(&map.model(&map.start), &u, &[1.0, 0.5]), 0.01, 22);
        let data = IdentificationData::complete(1.0, y, u);
        let rc = ResistanceCapacitance {
            weights: None,
            scaling,
            progress: Default::default(),
            coordinates: crate::estimate::StepCoordinates::Logarithms,
        }
        .estimate(&data)
        .unwrap();
        assert_eq!(misfit_beyond_free_model(&rc, 1.0), None);
        let mut far = rc.clone();
        far.noise_variance.iter_mut().for_each(|v| *v *= 100.0);
        let why = misfit_beyond_free_model(&far, 1.0).expect("ten times the noise");
        assert!(
            why.contains("on output") && why.contains("beyond the free model's"),
            "{why}"
        );
    }
}
