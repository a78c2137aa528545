//! Weighted least squares (eqs. 3–7), solved by a QR factorisation of the
//! column-scaled regression matrix, updated block by block so memory does not grow
//! with the recording — not by the normal equations (FᵀF)⁻¹, whose condition number
//! is the square of F's.

use crate::estimate::Method;
use nalgebra::{DMatrix, DVector};

use super::qr::StreamingQr;
use super::{
    block_diagonal_covariance, check_enough_rows, DiscreteModel, Estimate, EstimationError,
    Estimator, IdentificationData, Result,
};

/// Smallest ratio σ_min/σ_max of the scaled regression matrix accepted as full rank.
pub const RANK_TOLERANCE: f64 = 1e-10;

/// The paper's estimator: minimises J = ½ Σ_k e(k)ᵀ W(k) e(k) (eq. 3) with the
/// equation error e(k) = y(k) − Φ y(k−1) − Γ u(k−1), W(k) = diag(w_1(k) … w_n(k)).
#[derive(Debug, Clone, Default)]
pub struct WeightedLeastSquares {
    /// Per-instant, per-output weights w_i(k) ≥ 0 (N × n); `None` weighs all equally
    /// (ordinary least squares, reported as `ls`). With weights constant in time the
    /// estimate equals ordinary least squares: each output's row of Θ is a separate problem.
    pub weights: Option<DMatrix<f64>>,
}

/// One factorisation's solution: Θ's rows for its outputs, (FᵀF)⁻¹ in the original
/// units, the residual sums of squares and the condition number.
struct GroupSolution {
    theta_rows: Vec<Vec<f64>>,
    inverse_gram: DMatrix<f64>,
    rss: Vec<f64>,
    condition_number: f64,
}

impl Estimator for WeightedLeastSquares {
    fn method(&self) -> Method {
        if self.weights.is_some() {
            Method::Wls
        } else {
            Method::Ls
        }
    }

    fn estimate(&self, data: &IdentificationData) -> Result<Estimate> {
        self.check_weights(data)?;
        let rows = data.usable_rows();
        check_enough_rows(data, rows.len())?;
        let (n, m) = (data.states(), data.input_count());
        let p = n + m;
        let scale = column_scales(data, &rows)?;
        // One factorisation for all outputs when they share the rows' weights, one each otherwise.
        let groups: Vec<Vec<usize>> = if self.weights.is_some() {
            (0..n).map(|i| vec![i]).collect()
        } else {
            vec![(0..n).collect()]
        };
        let mut theta = vec![0.0; n * p];
        let mut noise_variance = vec![0.0; n];
        let mut cores = Vec::with_capacity(groups.len());
        let mut condition_number: f64 = 0.0;
        let dof = (rows.len() - p).max(1) as f64;
        for outputs in &groups {
            let solved = self.solve_group(data, &rows, outputs, &scale)?;
            condition_number = condition_number.max(solved.condition_number);
            for (slot, &i) in outputs.iter().enumerate() {
                theta[i * p..(i + 1) * p].copy_from_slice(&solved.theta_rows[slot]);
                noise_variance[i] = solved.rss[slot] / dof;
            }
            cores.push(solved.inverse_gram);
        }
        let cores: Vec<&DMatrix<f64>> = cores.iter().collect();
        Ok(Estimate {
            model: DiscreteModel::from_theta(n, m, data.ts_s, &theta),
            method: self.method(),
            rows_used: rows.len(),
            condition_number,
            covariance: Some(block_diagonal_covariance(&cores, &noise_variance)),
            robust_covariance: None,
            noise_variance,
            iterations: 0,
            output_offset: None,
            trajectory: None,
            network: None,
            predictor: None,
        })
    }
}

impl WeightedLeastSquares {
    /// Weights must be N × n, finite and not negative.
    fn check_weights(&self, data: &IdentificationData) -> Result<()> {
        let Some(w) = &self.weights else {
            return Ok(());
        };
        if w.shape() != (data.len(), data.states()) {
            return Err(EstimationError::WeightShape {
                given_rows: w.nrows(),
                given_columns: w.ncols(),
                rows: data.len(),
                columns: data.states(),
            });
        }
        match (0..w.nrows())
            .flat_map(|k| (0..w.ncols()).map(move |i| (k, i)))
            .find(|&(k, i)| !(w[(k, i)].is_finite() && w[(k, i)] >= 0.0))
        {
            Some((k, i)) => Err(EstimationError::InvalidWeight {
                state: i,
                value: w[(k, i)],
            }),
            None => Ok(()),
        }
    }

    /// The QR solution for the outputs in `outputs`, which share each row's weight.
    fn solve_group(
        &self,
        data: &IdentificationData,
        rows: &[usize],
        outputs: &[usize],
        scale: &[f64],
    ) -> Result<GroupSolution> {
        let p = scale.len();
        let mut qr = StreamingQr::new(p, outputs.len());
        let mut f_row = vec![0.0; p];
        let mut y_row = vec![0.0; outputs.len()];
        for &k in rows {
            let sw = match (&self.weights, outputs) {
                (Some(w), [i]) => w[(k, *i)].sqrt(),
                _ => 1.0,
            };
            data.regressor_row(k, &mut f_row);
            for (f, s) in f_row.iter_mut().zip(scale) {
                *f = sw * *f * s;
            }
            for (slot, &i) in outputs.iter().enumerate() {
                y_row[slot] = sw * data.outputs[(k, i)];
            }
            qr.push(&f_row, &y_row);
        }
        let (r, qty, rss) = qr.finish();
        let sv = r.clone().singular_values();
        let (s_max, s_min) = (sv.max(), sv.min());
        let no_excitation = || EstimationError::NoExcitation {
            method: self.method().name(),
            singular_value_ratio: s_min / s_max,
        };
        if !full_rank(s_min, s_max, RANK_TOLERANCE) {
            return Err(no_excitation());
        }
        let r_inv = r.clone().try_inverse().ok_or_else(no_excitation)?;
        // (FᵀF)⁻¹ in the original units: D R⁻¹ R⁻ᵀ D.
        let d = DMatrix::from_diagonal(&DVector::from_column_slice(scale));
        let inverse_gram = &d * &r_inv * r_inv.transpose() * &d;
        let theta_rows = (0..outputs.len())
            .map(|slot| {
                let t = &r_inv * qty.column(slot);
                (0..p).map(|j| t[j] * scale[j]).collect()
            })
            .collect();
        Ok(GroupSolution {
            theta_rows,
            inverse_gram,
            rss,
            condition_number: s_max / s_min,
        })
    }
}

/// Whether σ_min > tolerance·σ_max (false where either is NaN).
pub(crate) fn full_rank(s_min: f64, s_max: f64, tolerance: f64) -> bool {
    s_min.partial_cmp(&(tolerance * s_max)) == Some(std::cmp::Ordering::Greater)
}

/// 1/‖column j‖ of the regression matrix over `rows`. Columns scaled to unit norm make
/// the condition number measure excitation, not the units (states ~0.3 pu, losses
/// ~0.003 pu).
fn column_scales(data: &IdentificationData, rows: &[usize]) -> Result<Vec<f64>> {
    let p = data.states() + data.input_count();
    let mut norm2 = vec![0.0; p];
    for &k in rows {
        for (j, acc) in norm2.iter_mut().enumerate() {
            *acc += data.regressor(k, j).powi(2);
        }
    }
    if let Some(column) = norm2.iter().position(|v| !(*v > 0.0 && v.is_finite())) {
        return Err(EstimationError::ZeroRegressor { column });
    }
    Ok(norm2.iter().map(|v| 1.0 / v.sqrt()).collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    /// A 2-state, 1-input system simulated from known matrices with random inputs.
    fn simulated(n: usize, seed: u64) -> (IdentificationData, DMatrix<f64>, DMatrix<f64>) {
        let phi = DMatrix::from_row_slice(2, 2, &[0.95, 0.02, 0.01, 0.99]);
        let gamma = DMatrix::from_row_slice(2, 1, &[0.3, 0.05]);
        let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
        let u = DMatrix::from_fn(n, 1, |_, _| rng.random_range(0.0..1.0));
        let mut y = DMatrix::zeros(n, 2);
        for k in 1..n {
            let next = &phi * y.row(k - 1).transpose() + &gamma * u.row(k - 1).transpose();
            y.set_row(k, &next.transpose());
        }
        (IdentificationData::complete(1.0, y, u), phi, gamma)
    }

    #[test]
    fn exact_data_give_the_true_matrices() {
        let (data, phi, gamma) = simulated(500, 7);
        let e = WeightedLeastSquares::default().estimate(&data).unwrap();
        assert!((e.model.phi - phi).norm() < 1e-12);
        assert!((e.model.gamma - gamma).norm() < 1e-12);
        assert_eq!(e.rows_used, 499);
    }

    #[test]
    fn rows_touching_missing_data_are_left_out() {
        let (mut data, phi, _) = simulated(500, 8);
        // Corrupt instant 200 and mark it unknown: rows 200 and 201 must be skipped.
        data.outputs[(200, 0)] = 1e6;
        data.outputs_known[200] = false;
        let e = WeightedLeastSquares::default().estimate(&data).unwrap();
        assert_eq!(e.rows_used, 497);
        assert!((e.model.phi - phi).norm() < 1e-12);
        assert_eq!(data.segments(), vec![0..200, 201..500]);
    }

    #[test]
    fn time_varying_weights_discount_a_disturbed_stretch() {
        let (mut data, phi, _) = simulated(600, 9);
        for k in 300..320 {
            data.outputs[(k, 1)] += 5.0; // a disturbance on state 2
        }
        let plain = WeightedLeastSquares::default().estimate(&data).unwrap();
        let mut w = DMatrix::from_element(600, 2, 1.0);
        // The disturbed values are regressors of both states' equations at k + 1.
        for k in 300..322 {
            w[(k, 0)] = 1e-12;
            w[(k, 1)] = 1e-12;
        }
        let weighted = WeightedLeastSquares { weights: Some(w) }
            .estimate(&data)
            .unwrap();
        assert!((plain.model.phi.clone() - &phi).norm() > 1e-3);
        assert!((weighted.model.phi - phi).norm() < 1e-5);
    }

    #[test]
    fn the_method_is_named_by_whether_it_is_weighted() {
        let (data, _, _) = simulated(300, 10);
        let plain = WeightedLeastSquares::default().estimate(&data).unwrap();
        assert_eq!(plain.method, Method::Ls);
        let weighted = WeightedLeastSquares {
            weights: Some(DMatrix::from_element(300, 2, 1.0)),
        }
        .estimate(&data)
        .unwrap();
        assert_eq!(weighted.method, Method::Wls);
        assert!(plain.trajectory.is_none());
        let wrong = WeightedLeastSquares {
            weights: Some(DMatrix::from_element(299, 2, 1.0)),
        };
        assert!(matches!(
            wrong.estimate(&data),
            Err(EstimationError::WeightShape {
                given_rows: 299,
                rows: 300,
                ..
            })
        ));
    }

    #[test]
    fn too_few_rows_are_named_with_the_figures() {
        let (data, _, _) = simulated(25, 11);
        assert_eq!(
            WeightedLeastSquares::default().estimate(&data).unwrap_err(),
            EstimationError::TooFewRows {
                rows: 24,
                needed: 30,
                parameters: 3
            }
        );
    }
}
