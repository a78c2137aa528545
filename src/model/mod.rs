//! Model analysis stage: an estimated discrete model → its continuous form,
//! spectrum and time constants, simulated response and fit, output sensitivities
//! and time-constant assignment, and steady state.
//!
//! Input: an [`Estimate`] and the [`IdentificationData`] it came from. Output: a
//! [`ModelAnalysis`].

pub mod continuous;
pub mod error;
pub mod fit;
pub mod matrix;
pub mod residuals;
pub mod sensitivity;
pub mod uncertainty;

use nalgebra::DMatrix;
use serde::Serialize;

pub use continuous::{ContinuousModel, Spectrum};
pub use error::ModelError;
pub use fit::Fit;
pub use residuals::ResidualAnalysis;
pub use sensitivity::{Assignment, Sensitivities};
pub use uncertainty::Uncertainty;

use crate::estimate::{Estimate, IdentificationData};

/// Everything the analysis derives from one estimate.
#[derive(Debug, Clone, Serialize)]
pub struct ModelAnalysis {
    /// A_c and B_c.
    pub continuous: ContinuousModel,
    /// Eigenvalues and time constants.
    pub spectrum: Spectrum,
    /// Simulated outputs ŷ (eq. 8) over the data analysed, N × n, NaN outside the
    /// simulated segments.
    #[serde(skip)]
    pub simulated: DMatrix<f64>,
    /// Fit of ŷ to y.
    pub fit: Fit,
    /// Sensitivities of ŷ to the time constants.
    pub sensitivities: Sensitivities,
    /// Each time constant's state.
    pub assignment: Vec<Assignment>,
    /// The constant input the steady state is computed for (pu).
    pub steady_state_input: Vec<f64>,
    /// Steady-state outputs −A_c⁻¹ B_c u (pu).
    pub steady_state: Vec<f64>,
    /// 95 % intervals of the time constants and the steady state, where the method
    /// gives a covariance.
    pub uncertainty: Option<Uncertainty>,
    /// Whiteness of the residuals and their correlation with the inputs.
    pub residuals: ResidualAnalysis,
}

/// Largest lag of the residual correlations.
pub const RESIDUAL_MAX_LAG: usize = 60;

/// Analyses an estimate against its data; `steady_state_input` is the input
/// (normally the last measured one, eq. 30) whose steady state is wanted.
pub fn analyse(
    estimate: &Estimate,
    data: &IdentificationData,
    temperature_base_k: f64,
    steady_state_input: &[f64],
) -> Result<ModelAnalysis, ModelError> {
    let model = &estimate.model;
    let spectrum = Spectrum::of(model)?;
    let continuous = ContinuousModel::from_discrete(model)?;
    let segments = data.segments();
    let simulated = fit::simulate(model, data, &segments);
    let fit = fit::fit(data, &simulated, temperature_base_k);
    let sensitivities = sensitivity::sensitivities(
        &continuous,
        &spectrum.time_constants_s,
        model.ts_s,
        data,
        &segments,
    )?;
    let assignment = sensitivity::assign(&sensitivities);
    let steady_state = continuous.steady_state(steady_state_input)?;
    let uncertainty = uncertainty::propagate(estimate, steady_state_input);
    let residuals = residuals::analyse(data, &simulated, RESIDUAL_MAX_LAG);
    Ok(ModelAnalysis {
        continuous,
        spectrum,
        simulated,
        fit,
        sensitivities,
        assignment,
        steady_state_input: steady_state_input.to_vec(),
        steady_state,
        uncertainty,
        residuals,
    })
}
