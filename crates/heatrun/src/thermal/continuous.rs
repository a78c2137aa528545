//! The continuous equivalent of a discrete model and its spectrum.

use nalgebra::DMatrix;
use serde::Serialize;

use super::matrix::{eigenvalues, logm};
use super::DiscreteModel;
use super::ModelError;

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
///
/// Every list is in mode order, ascending time constant; a complex-conjugate pair is
/// two entries (positive imaginary part first) sharing one time constant −1/Re λ_c
/// and one oscillation period 2π/|Im λ_c|. Where every eigenvalue is real the imaginary
/// parts are zero and the periods `None`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Spectrum {
    /// Eigenvalues λ_d of Φ (real parts), ascending (eq. 21).
    pub eigenvalues_discrete: Vec<f64>,
    /// Imaginary parts of λ_d (zero for a real eigenvalue).
    pub eigenvalues_discrete_imag: Vec<f64>,
    /// λ_c = ln(λ_d)/Ts (principal logarithm; real parts), the eigenvalues of A_c, in the
    /// order of `eigenvalues_discrete` (eq. 24).
    pub eigenvalues_continuous: Vec<f64>,
    /// Imaginary parts of λ_c, arg(λ_d)/Ts, 1/s (zero for a real eigenvalue).
    pub eigenvalues_continuous_imag: Vec<f64>,
    /// T_i = −1/Re λ_c,i in s, ascending (eq. 26; a pair's decay time constant).
    pub time_constants_s: Vec<f64>,
    /// The oscillation period 2π/|Im λ_c,i| of a complex mode, s; `None` for a real one.
    pub oscillation_periods_s: Vec<Option<f64>>,
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
    /// system (a real eigenvalue of Φ outside (0, 1), or a pair of modulus ≥ 1) is an
    /// error naming it. A stable complex pair is an oscillating mode: its decay time
    /// constant −Ts/ln|λ_d| and period 2π·Ts/|arg λ_d| are reported.
    pub fn of(model: &DiscreteModel) -> Result<Spectrum> {
        let eig = eigenvalues(&model.phi, "Φ")?;
        if let Some(z) = eig
            .iter()
            .find(|z| (z.im == 0.0 && z.re <= 0.0) || z.norm() >= 1.0)
        {
            return Err(if z.im == 0.0 {
                ModelError::Unstable { eigenvalue: z.re }
            } else {
                ModelError::UnstablePair {
                    re: z.re,
                    im: z.im.abs(),
                    modulus: z.norm(),
                }
            });
        }
        let ts = model.ts_s;
        let continuous: Vec<(f64, f64)> = eig
            .iter()
            .map(|z| (z.norm().ln() / ts, z.im.atan2(z.re) / ts))
            .collect();
        Ok(Spectrum {
            eigenvalues_discrete: eig.iter().map(|z| z.re).collect(),
            eigenvalues_discrete_imag: eig.iter().map(|z| z.im).collect(),
            eigenvalues_continuous: continuous.iter().map(|c| c.0).collect(),
            eigenvalues_continuous_imag: continuous.iter().map(|c| c.1).collect(),
            time_constants_s: continuous.iter().map(|c| -1.0 / c.0).collect(),
            oscillation_periods_s: continuous
                .iter()
                .map(|c| (c.1 != 0.0).then(|| 2.0 * std::f64::consts::PI / c.1.abs()))
                .collect(),
        })
    }

    /// Whether any mode oscillates (a complex-conjugate pair).
    pub fn has_oscillating_modes(&self) -> bool {
        self.oscillation_periods_s.iter().any(Option::is_some)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_damped_rotation_has_one_time_constant_and_period() {
        // Φ = r·R(θ) with Ts = 2 s: λ_c = (ln r ± iθ)/Ts, T = −Ts/ln r, period 2π·Ts/θ.
        // A third, real mode 0.5 is the fastest (T = 2/ln 2).
        let (r, theta, ts) = (0.99_f64, 0.1_f64, 2.0);
        let (c, s) = (r * theta.cos(), r * theta.sin());
        let phi = DMatrix::from_row_slice(3, 3, &[c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 0.5]);
        let model = DiscreteModel {
            phi,
            gamma: DMatrix::from_element(3, 1, 0.1),
            ts_s: ts,
        };
        let sp = Spectrum::of(&model).unwrap();
        let t = -ts / r.ln();
        let p = 2.0 * std::f64::consts::PI * ts / theta;
        assert!((sp.time_constants_s[0] - ts / 2f64.ln()).abs() < 1e-12);
        assert_eq!(sp.oscillation_periods_s[0], None);
        for i in [1, 2] {
            assert!((sp.time_constants_s[i] - t).abs() < 1e-9 * t);
            assert!((sp.oscillation_periods_s[i].unwrap() - p).abs() < 1e-9 * p);
            assert!((sp.eigenvalues_discrete[i] - c).abs() < 1e-14);
        }
        assert!(sp.eigenvalues_continuous_imag[1] > 0.0 && sp.eigenvalues_continuous_imag[2] < 0.0);
        assert!((sp.eigenvalues_continuous_imag[1] - theta / ts).abs() < 1e-12);
        assert!(sp.has_oscillating_modes());
        // The continuous form exists and reproduces the pair.
        let cm = ContinuousModel::from_discrete(&model).unwrap();
        let back = crate::thermal::matrix::discretize(&cm.a_c, &cm.b_c, ts);
        assert!((back.0 - &model.phi).norm() < 1e-12);
        assert!((back.1 - &model.gamma).norm() < 1e-12);
    }

    #[test]
    fn an_unstable_pair_is_refused() {
        let (r, theta) = (1.0008_f64, 0.036_f64);
        let (c, s) = (r * theta.cos(), r * theta.sin());
        let model = DiscreteModel {
            phi: DMatrix::from_row_slice(2, 2, &[c, -s, s, c]),
            gamma: DMatrix::from_element(2, 1, 0.1),
            ts_s: 1.0,
        };
        match Spectrum::of(&model).unwrap_err() {
            ModelError::UnstablePair { modulus, .. } => assert!((modulus - r).abs() < 1e-12),
            other => panic!("{other}"),
        }
    }
}
