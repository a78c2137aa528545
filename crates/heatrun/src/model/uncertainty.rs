//! Uncertainty of the derived quantities, by first-order propagation of the
//! parameter covariance (the delta method): for a derived g(Θ),
//! var g ≈ ∇gᵀ C ∇g, with ∇g by central differences, and a 95 % interval
//! ±1.96·√(var g) (normal approximation).

use nalgebra::DVector;
use serde::Serialize;

use crate::estimate::Estimate;
use crate::thermal::{ContinuousModel, Spectrum};

pub use crate::thermal::Z95;

/// 95 % confidence half-widths.
#[derive(Debug, Clone, Serialize)]
pub struct Uncertainty {
    /// Half-width of the 95 % interval of each time constant (ascending order), s.
    pub time_constants_ci95_s: Vec<f64>,
    /// Half-width of the 95 % interval of each steady-state output, pu.
    pub steady_state_ci95: Vec<f64>,
    /// Standard error of each entry of Θ laid out as [`crate::estimate::DiscreteModel::theta`].
    pub theta_standard_error: Vec<f64>,
}

/// Propagates the estimate's covariance ([`Estimate::interval_covariance`]: the robust
/// one where the method gives it) to the time constants and the steady state for input
/// `u`; `None` when the method gives no covariance.
pub fn propagate(estimate: &Estimate, u: &[f64]) -> Option<Uncertainty> {
    let cov = estimate.interval_covariance()?;
    let theta = estimate.model.theta();
    let derived = |t: &[f64]| -> Option<Vec<f64>> {
        let model = estimate.model.with_theta(t);
        let spectrum = Spectrum::of(&model).ok()?;
        let steady = ContinuousModel::from_discrete(&model)
            .ok()?
            .steady_state(u)
            .ok()?;
        Some(
            spectrum
                .time_constants_s
                .into_iter()
                .chain(steady)
                .collect(),
        )
    };
    let base = derived(&theta)?;
    let k = base.len();
    let mut grads = vec![DVector::zeros(theta.len()); k];
    for j in 0..theta.len() {
        let sd = cov[(j, j)].max(0.0).sqrt();
        let h = (1e-3 * sd).max(1e-9 * theta[j].abs()).max(1e-14);
        let mut plus = theta.clone();
        let mut minus = theta.clone();
        plus[j] += h;
        minus[j] -= h;
        let (gp, gm) = (derived(&plus)?, derived(&minus)?);
        for (q, g) in grads.iter_mut().enumerate() {
            g[j] = (gp[q] - gm[q]) / (2.0 * h);
        }
    }
    let half: Vec<f64> = grads
        .iter()
        .map(|g| Z95 * (g.transpose() * cov * g)[(0, 0)].max(0.0).sqrt())
        .collect();
    let n = estimate.model.phi.nrows();
    Some(Uncertainty {
        time_constants_ci95_s: half[..n].to_vec(),
        steady_state_ci95: half[n..].to_vec(),
        theta_standard_error: (0..theta.len())
            .map(|j| cov[(j, j)].max(0.0).sqrt())
            .collect(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::estimate::DiscreteModel;
    use nalgebra::DMatrix;

    #[test]
    fn a_scalar_model_worked_by_hand() {
        // x(k) = a x(k−1) + b u(k−1), Ts = 2 s: T = −Ts/ln a, so ∂T/∂a = Ts/(a ln²a),
        // ∂T/∂b = 0; y(∞) = b u/(1 − a), so ∂y/∂a = b u/(1 − a)², ∂y/∂b = u/(1 − a).
        let (a, b, u, ts) = (0.98_f64, 0.05_f64, 0.5_f64, 2.0_f64);
        let (sa, sb, rho) = (1e-4_f64, 2e-4_f64, 0.3_f64);
        let cov = DMatrix::from_row_slice(2, 2, &[sa * sa, rho * sa * sb, rho * sa * sb, sb * sb]);
        let estimate = Estimate {
            model: DiscreteModel {
                phi: DMatrix::from_element(1, 1, a),
                gamma: DMatrix::from_element(1, 1, b),
                ts_s: ts,
            },
            method: crate::estimate::Method::Oe,
            rows_used: 0,
            condition_number: 1.0,
            covariance: Some(cov),
            robust_covariance: None,
            noise_variance: vec![0.0],
            iterations: 0,
            output_offset: None,
            trajectory: None,
            network: None,
            predictor: None,
        };
        let got = propagate(&estimate, &[u]).unwrap();
        let dt_da = ts / (a * a.ln().powi(2));
        let t_half = Z95 * dt_da * sa;
        let (gy_a, gy_b) = (b * u / (1.0 - a).powi(2), u / (1.0 - a));
        let y_var =
            gy_a * gy_a * sa * sa + 2.0 * gy_a * gy_b * rho * sa * sb + gy_b * gy_b * sb * sb;
        let y_half = Z95 * y_var.sqrt();
        let rel = |x: f64, want: f64| ((x - want) / want).abs();
        assert!(
            rel(got.time_constants_ci95_s[0], t_half) < 1e-6,
            "{got:?} vs {t_half}"
        );
        assert!(
            rel(got.steady_state_ci95[0], y_half) < 1e-6,
            "{got:?} vs {y_half}"
        );
        assert_eq!(got.theta_standard_error, vec![sa, sb]);
    }

    #[test]
    fn no_covariance_no_intervals() {
        let estimate = Estimate {
            model: DiscreteModel {
                phi: DMatrix::from_element(1, 1, 0.9),
                gamma: DMatrix::from_element(1, 1, 0.1),
                ts_s: 1.0,
            },
            method: crate::estimate::Method::Oe,
            rows_used: 0,
            condition_number: 1.0,
            covariance: None,
            robust_covariance: None,
            noise_variance: vec![0.0],
            iterations: 0,
            output_offset: None,
            trajectory: None,
            network: None,
            predictor: None,
        };
        assert!(propagate(&estimate, &[1.0]).is_none());
    }
}
