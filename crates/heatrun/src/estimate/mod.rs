//! Estimation stage: measured states and inputs → the discrete model Θ = [Φ Γ].
//!
//! Input: [`IdentificationData`], generic in the number of states n and inputs m
//! (the generator's 3 × 3 is one configuration). Output: an [`Estimate`]. Each
//! method lives in its own module behind the [`Estimator`] interface.

use nalgebra::DMatrix;
use serde::Serialize;

pub(crate) mod compressed;
mod data;
mod discrete;
mod error;
pub mod excitation;
mod iv;
pub(crate) mod kernels;
pub mod long_run;
mod method;
pub(crate) mod normal_equations;
pub(crate) mod oe;
mod pem;
mod qr;
mod rc;
mod rls;
#[cfg(test)]
pub(crate) mod testing;
mod wls;

pub use data::{ExceptionStorage, IdentificationData};
pub use discrete::{add_output_offset, DiscreteModel, StartCorrection};
pub use error::EstimationError;
pub use iv::InstrumentalVariables;
pub use method::{Method, UnknownMethod};
pub use oe::OutputError;
pub use pem::ratio::{self as innovations_ratio, LikelihoodRatio};
pub use pem::{Disturbance, PredictionError, Predictor};
pub(crate) use rc::start_parts;
pub use rc::{
    deviance, likelihood_ratio, HeldScore, NetworkEstimate, ResistanceCapacitance, StartRace,
    StepCoordinates,
};
pub use rls::{RecursiveLeastSquares, TrajectoryPoint};
pub use wls::WeightedLeastSquares;

/// Result of an estimator.
pub type Result<T, E = EstimationError> = std::result::Result<T, E>;

/// An estimator's result.
#[derive(Debug, Clone, Serialize)]
pub struct Estimate {
    /// The model.
    pub model: DiscreteModel,
    /// The method, set by the estimator.
    pub method: Method,
    /// Number of equations used: regression rows, or for output error the instants after
    /// each segment's start where some output is compared.
    pub rows_used: usize,
    /// 2-norm condition number of the column-scaled regression (or Jacobian) matrix.
    pub condition_number: f64,
    /// Covariance of Θ laid out as [`DiscreteModel::theta`], when the method gives one:
    /// the method's own (for the output-error fits Gauss–Newton's σ² (JᵀWJ)⁻¹, which
    /// takes the residuals as white). The nearest network takes it as its metric.
    #[serde(skip)]
    pub covariance: Option<DMatrix<f64>>,
    /// The covariance of Θ that holds where the residuals are correlated in time (the
    /// sandwich H⁻¹ M H⁻¹, [`long_run`]), where the method gives one (`oe`): what the
    /// intervals of the uses of the model take ([`Estimate::interval_covariance`]).
    #[serde(skip)]
    pub robust_covariance: Option<RobustCovariance>,
    /// Estimated noise variance per output (pu²): of the equation error for ls/wls/iv,
    /// of the simulation error for oe.
    pub noise_variance: Vec<f64>,
    /// Iterations taken (IV re-estimations, LM evaluations), 0 for closed-form methods.
    pub iterations: usize,
    /// Estimated constant output offset c (y = x + c, pu), where the method estimates one:
    /// the error of the initial values the rises are measured from.
    pub output_offset: Option<Vec<f64>>,
    /// Θ along the way, for methods that move through the data (recursive least squares).
    #[serde(skip)]
    pub trajectory: Option<Vec<TrajectoryPoint>>,
    /// The thermal network itself, for the method that estimates it (`rc`).
    #[serde(skip)]
    pub network: Option<Box<NetworkEstimate>>,
    /// The one-step predictor (the Kalman gain), for the method that estimates one
    /// (`pem`); the others' predictor is the simulation.
    #[serde(skip)]
    pub predictor: Option<Box<Predictor>>,
}

impl Estimate {
    /// The covariance the intervals take: the robust one where the method gives it, else
    /// [`Estimate::covariance`].
    pub fn interval_covariance(&self) -> Option<&DMatrix<f64>> {
        (self.robust_covariance.as_ref())
            .map(|r| &r.covariance)
            .or(self.covariance.as_ref())
    }
}

/// A covariance of Θ robust to residuals correlated in time: C = H⁻¹ M H⁻¹ · N/(N − r),
/// H = JᵀWJ, M the long-run covariance of the weighted residuals' scores with Bartlett's
/// window of Andrews' width ([`long_run`]).
#[derive(Debug, Clone, PartialEq)]
pub struct RobustCovariance {
    /// C, laid out as [`DiscreteModel::theta`].
    pub covariance: DMatrix<f64>,
    /// L, the Bartlett window's width, instants (a few where the residuals are white).
    pub correlation_window: usize,
}

/// An identification method.
pub trait Estimator {
    /// The method, as it appears in [`Estimate::method`].
    fn method(&self) -> Method;
    /// Estimates Φ and Γ from the data.
    fn estimate(&self, data: &IdentificationData) -> Result<Estimate>;
}

/// Fewest usable equations per unknown parameter before an estimate is attempted.
pub const MIN_ROWS_PER_PARAMETER: usize = 10;

/// Checks there are enough usable rows for n + m parameters per output.
pub(crate) fn check_enough_rows(data: &IdentificationData, rows: usize) -> Result<()> {
    let parameters = data.states() + data.input_count();
    let needed = MIN_ROWS_PER_PARAMETER * parameters;
    if rows < needed {
        return Err(EstimationError::TooFewRows {
            rows,
            needed,
            parameters,
        });
    }
    Ok(())
}

/// The covariance of Θ when each output's row is its own problem: block-diagonal,
/// block i = σ_i² C_i (p × p), laid out as [`DiscreteModel::theta`]. `cores` holds one
/// C shared by every output (the same regressors and weights), or one per output.
pub(crate) fn block_diagonal_covariance(
    cores: &[&DMatrix<f64>],
    noise_variance: &[f64],
) -> DMatrix<f64> {
    let p = cores.first().map_or(0, |c| c.nrows());
    let n = noise_variance.len();
    let mut covariance = DMatrix::zeros(n * p, n * p);
    for (i, var) in noise_variance.iter().enumerate() {
        let core = if cores.len() == 1 { cores[0] } else { cores[i] };
        covariance
            .view_mut((i * p, i * p), (p, p))
            .copy_from(&(core * *var));
    }
    covariance
}

/// Sum of squared equation errors y_i(k) − θ_iᵀ φ(k) per output over `rows`
/// (Θ laid out as [`DiscreteModel::theta`]).
pub(crate) fn equation_error_sse(
    data: &IdentificationData,
    rows: &[usize],
    theta: &[f64],
) -> Vec<f64> {
    let (n, p) = (data.states(), data.states() + data.input_count());
    let mut phi = vec![0.0; p];
    let mut sse = vec![0.0; n];
    for &k in rows {
        data.regressor_row(k, &mut phi);
        for (i, acc) in sse.iter_mut().enumerate() {
            let mut e = data.outputs[(k, i)];
            for (f, t) in phi.iter().zip(&theta[i * p..(i + 1) * p]) {
                e -= t * f;
            }
            *acc += e * e;
        }
    }
    sse
}
