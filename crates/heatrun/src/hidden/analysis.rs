//! The analysis of a hidden-state model as the replay's model: its time constants (the
//! eigenvalues of A_c = ln(Φ)/Ts, eq. 26), the sensitivities of the *measured* outputs
//! to them (eqs. 27–29 with y = C x: ∂y/∂T_i = C ∂x/∂T_i), each time constant's output
//! (the largest norm), and the steady state y_ss = (C (I − Φ)⁻¹ Γ + D) u of each
//! measured output.

use nalgebra::DVector;
use serde::Serialize;

use super::HiddenStateModel;
use crate::estimate::{DiscreteModel, IdentificationData};
use crate::model::sensitivity::SensitivityModel;
use crate::model::{ContinuousModel, ModelError, Spectrum};

/// What the report says of a hidden-state model that is the replay's model.
#[derive(Debug, Clone, Serialize)]
pub struct HiddenAnalysis {
    /// Eigenvalues and time constants (ascending, s) of its n states.
    pub spectrum: Spectrum,
    /// `norms[j][i]`: RMS over the estimation instants of T_i ∂y_j/∂T_i (pu), rows the p
    /// measured outputs, columns the n time constants.
    pub norms: Vec<Vec<f64>>,
    /// Per time constant, the output whose response it changes most (index into the
    /// outputs), and that norm.
    pub assignment: Vec<(usize, f64)>,
    /// y_ss = (C (I − Φ)⁻¹ Γ + D) u_ss per measured output (pu), at `steady_input`.
    pub steady_state: Vec<f64>,
}

/// Analyses `model` on the estimation `data` (each segment from its fitted initial
/// state) at the steady input `steady_input`. Errors where Φ has no real logarithm or
/// I − Φ is singular.
pub fn analyse(
    model: &HiddenStateModel,
    data: &IdentificationData,
    steady_input: &[f64],
) -> Result<HiddenAnalysis, ModelError> {
    let discrete = DiscreteModel {
        phi: model.phi.clone(),
        gamma: model.gamma.clone(),
        ts_s: model.ts_s,
    };
    let spectrum = Spectrum::of(&discrete)?;
    let continuous = ContinuousModel::from_discrete(&discrete)?;
    let recursion = SensitivityModel::new(&continuous, &spectrum.time_constants_s, model.ts_s)?;
    let (p, n) = (model.c.nrows(), model.order());
    let segments = data.segments();
    let simulated: usize = segments.iter().map(|s| s.len()).sum();
    let mut norms = vec![vec![0.0; n]; p];
    for i in 0..n {
        if let Some(partner) = recursion.earlier_partner(i) {
            for row in norms.iter_mut() {
                row[i] = row[partner];
            }
            continue;
        }
        let mut sum_sq = vec![0.0; p];
        let start = |seg| model.fitted_initial_state(data, seg);
        recursion.for_each_response_from(i, data, &segments, start, |_, rel| {
            let y = &model.c * rel;
            for (acc, v) in sum_sq.iter_mut().zip(y.iter()) {
                *acc += v * v;
            }
        });
        for (row, sum) in norms.iter_mut().zip(&sum_sq) {
            row[i] = (sum / simulated.max(1) as f64).sqrt();
        }
    }
    // n time constants on p ≤ n outputs: each to its most sensitive output (several may
    // share one: a hidden state's mode shows in the outputs it feeds).
    let assignment = (0..n)
        .map(|i| {
            (0..p)
                .map(|j| (j, norms[j][i]))
                .fold((0, f64::NEG_INFINITY), |m, v| if v.1 > m.1 { v } else { m })
        })
        .collect();
    let gain = model.steady_state_gain().ok_or(ModelError::Integrator)?;
    let steady_state = (gain * DVector::from_column_slice(steady_input))
        .iter()
        .copied()
        .collect();
    Ok(HiddenAnalysis {
        spectrum,
        norms,
        assignment,
        steady_state,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::hidden::testing::{known_system, simulate_known};

    #[test]
    fn the_known_systems_time_constants_and_steady_state_come_out_exactly() {
        // Φ = V diag(0.6, 0.92, 0.985) V⁻¹ at Ts = 1 s: T_i = −1/ln λ_i.
        let model = known_system();
        let data = simulate_known(&model, 400, 0.0, 3);
        let a = analyse(&model, &data, &[1.0, 0.5]).unwrap();
        for (t, l) in a
            .spectrum
            .time_constants_s
            .iter()
            .zip([0.6f64, 0.92, 0.985])
        {
            assert!((t + 1.0 / l.ln()).abs() < 1e-6 * t, "{t}");
        }
        // y_ss = C (I − Φ)⁻¹ Γ u, solved here apart from the analysis's gain.
        let n = 3;
        let x = (nalgebra::DMatrix::identity(n, n) - &model.phi)
            .try_inverse()
            .unwrap()
            * &model.gamma
            * DVector::from_vec(vec![1.0, 0.5]);
        for j in 0..2 {
            assert!((a.steady_state[j] - x[j]).abs() < 1e-9);
        }
        // Every mode moves some output: each has a positive norm on its output.
        assert_eq!(a.norms.len(), 2);
        assert!(a.assignment.iter().all(|&(j, norm)| j < 2 && norm > 0.0));
    }
}
