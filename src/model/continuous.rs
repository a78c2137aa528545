//! The continuous equivalent of a discrete model and its spectrum.

use nalgebra::DMatrix;
use serde::Serialize;

use super::matrix::{logm, real_eigenvalues};
use super::ModelError;
use crate::estimate::DiscreteModel;

type Result<T, E = ModelError> = std::result::Result<T, E>;

/// dy/dt = A_c y + B_c u (eq. 9), the zero-order-hold equivalent of a [`DiscreteModel`].
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ContinuousModel {
    /// A_c = ln(Φ)/Ts.
    pub a_c: DMatrix<f64>,
    /// B_c = (Φ − I)⁻¹ A_c Γ.
    pub b_c: DMatrix<f64>,
}

/// The discrete and continuous spectrum and the time constants (eqs. 21, 24, 26).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Spectrum {
    /// Eigenvalues λ_d of Φ, ascending (eq. 21).
    pub eigenvalues_discrete: Vec<f64>,
    /// λ_c = ln(λ_d)/Ts, the eigenvalues of A_c, in the order of `eigenvalues_discrete` (eq. 24).
    pub eigenvalues_continuous: Vec<f64>,
    /// T_i = −1/λ_c,i in s, ascending (eq. 26).
    pub time_constants_s: Vec<f64>,
}

impl ContinuousModel {
    /// The continuous equivalent by the matrix logarithm: A_c = ln(Φ)/Ts,
    /// B_c = (Φ − I)⁻¹ A_c Γ. Errors where Φ has no real logarithm or Φ − I is singular.
    pub fn from_discrete(model: &DiscreteModel) -> Result<ContinuousModel> {
        let a_c = logm(&model.phi)? / model.ts_s;
        let n = model.phi.nrows();
        let phi_minus_i = &model.phi - DMatrix::<f64>::identity(n, n);
        let inv = phi_minus_i.try_inverse().ok_or(ModelError::Integrator)?;
        let b_c = inv * &a_c * &model.gamma;
        Ok(ContinuousModel { a_c, b_c })
    }

    /// Steady state y(∞) = −A_c⁻¹ B_c u for a constant input u (eq. 31).
    pub fn steady_state(&self, u: &[f64]) -> Result<Vec<f64>> {
        let inv = self
            .a_c
            .clone()
            .try_inverse()
            .ok_or(ModelError::NoSteadyState)?;
        let u = nalgebra::DVector::from_column_slice(u);
        Ok((-(inv * &self.b_c * u)).iter().copied().collect())
    }
}

impl Spectrum {
    /// Eigenvalues of Φ and time constants; a model that is not a stable thermal
    /// system (an eigenvalue of Φ outside (0, 1), or complex) is an error naming it.
    pub fn of(model: &DiscreteModel) -> Result<Spectrum> {
        let eigenvalues_discrete = real_eigenvalues(&model.phi, "Φ")?;
        if let Some(&eigenvalue) = eigenvalues_discrete.iter().find(|&&l| l <= 0.0 || l >= 1.0) {
            return Err(ModelError::Unstable { eigenvalue });
        }
        let eigenvalues_continuous: Vec<f64> = eigenvalues_discrete
            .iter()
            .map(|l| l.ln() / model.ts_s)
            .collect();
        let mut time_constants_s: Vec<f64> =
            eigenvalues_continuous.iter().map(|l| -1.0 / l).collect();
        time_constants_s.sort_by(f64::total_cmp);
        Ok(Spectrum {
            eigenvalues_discrete,
            eigenvalues_continuous,
            time_constants_s,
        })
    }
}
