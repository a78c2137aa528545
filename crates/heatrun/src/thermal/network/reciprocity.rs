//! Reciprocity: the capacitances that make C·A_c symmetric, and what is left over.
//!
//! In a network C·A_c = −L with L symmetric, so c_i·a_ij = c_j·a_ji for every pair:
//! each pair fixes one ratio c_i/c_j = a_ji/a_ij. With three or more parts the pairs
//! over-determine the ratios, and around each cycle the product of the ratios must be 1:
//! a_12·a_23·a_31 = a_21·a_32·a_13. An identified model meets that only approximately;
//! the least-squares ratios and the residual asymmetry say how far off it is.

use nalgebra::{DMatrix, DVector};
use serde::Serialize;

use super::{Labels, NetworkError};

/// The cycle condition of one triangle of parts (i, j, k): a_ij·a_jk·a_ki against
/// a_ji·a_kj·a_ik, equal (ratio 1, residual 0) in a reciprocal network.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CycleResidual {
    /// The parts i < j < k (0-based).
    pub parts: [usize; 3],
    /// a_ij·a_jk·a_ki (1/s³).
    pub forward: f64,
    /// a_ji·a_kj·a_ik (1/s³).
    pub backward: f64,
    /// forward − backward (0 for a reciprocal network).
    pub residual: f64,
    /// forward / backward (1 for a reciprocal network); `None` where backward is 0.
    pub ratio: Option<f64>,
}

/// The capacitance ratios and the reciprocity figures of a model.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Reciprocity {
    /// c_i at geometric mean 1.
    pub ratios: Vec<f64>,
    /// ‖C·A − (C·A)ᵀ‖_F / ‖C·A‖_F at the fitted C.
    pub relative_asymmetry: f64,
    /// The same over the off-diagonal couplings: ‖off(C·A − (C·A)ᵀ)‖ / ‖off(C·A + (C·A)ᵀ)‖.
    pub coupling_asymmetry: f64,
    /// One per triangle of parts.
    pub cycle_residuals: Vec<CycleResidual>,
    /// Pairs (i < j) whose a_ij and a_ji differ in sign or where only one is zero:
    /// no positive capacitances make them symmetric.
    pub sign_mismatched_pairs: Vec<[usize; 2]>,
}

/// The least-squares capacitance ratios: ln c_i − ln c_j = ln(a_ji/a_ij) over every pair
/// with a_ij·a_ji > 0, and Σ ln c_i = 0; pairs of opposite sign (or one zero) cannot be
/// made symmetric and are left out and listed. An error where the pairs used do not
/// connect every part (some ratio undetermined).
pub(super) fn fit_capacitance_ratios(
    a_c: &DMatrix<f64>,
    labels: &Labels,
) -> Result<Reciprocity, NetworkError> {
    let n = a_c.nrows();
    let mut equations = Vec::new();
    let mut sign_mismatched_pairs = Vec::new();
    for i in 0..n {
        for j in i + 1..n {
            let (a_ij, a_ji) = (a_c[(i, j)], a_c[(j, i)]);
            if a_ij * a_ji > 0.0 {
                equations.push((i, j, (a_ji / a_ij).ln()));
            } else if a_ij != 0.0 || a_ji != 0.0 {
                sign_mismatched_pairs.push([i, j]);
            }
        }
    }
    check_connected(n, &equations, labels)?;
    let mut design = DMatrix::zeros(equations.len() + 1, n);
    let mut rhs = DVector::zeros(equations.len() + 1);
    for (row, &(i, j, d)) in equations.iter().enumerate() {
        design[(row, i)] = 1.0;
        design[(row, j)] = -1.0;
        rhs[row] = d;
    }
    design.row_mut(equations.len()).fill(1.0);
    // Connected pairs plus the normalisation give full column rank: the solution is unique.
    let logs = design
        .svd(true, true)
        .solve(&rhs, 1e-12)
        .map_err(|e| NetworkError::BadParameter(format!("capacitance ratios: {e}")))?;
    let ratios: Vec<f64> = logs.iter().map(|l| l.exp()).collect();
    let mut fit = Reciprocity::of(a_c, &ratios);
    fit.sign_mismatched_pairs = sign_mismatched_pairs;
    Ok(fit)
}

impl Reciprocity {
    /// The figures of `a_c` at the capacitances `c` (any scale).
    pub fn of(a_c: &DMatrix<f64>, c: &[f64]) -> Reciprocity {
        let ca = DMatrix::from_fn(a_c.nrows(), a_c.ncols(), |i, j| c[i] * a_c[(i, j)]);
        let norm = ca.norm();
        let relative_asymmetry = if norm > 0.0 {
            (&ca - ca.transpose()).norm() / norm
        } else {
            0.0
        };
        let (mut diff, mut sum) = (0.0, 0.0);
        for i in 0..ca.nrows() {
            for j in (0..ca.ncols()).filter(|&j| j != i) {
                diff += (ca[(i, j)] - ca[(j, i)]).powi(2);
                sum += (ca[(i, j)] + ca[(j, i)]).powi(2);
            }
        }
        let coupling_asymmetry = if sum > 0.0 { (diff / sum).sqrt() } else { 0.0 };
        Reciprocity {
            ratios: c.to_vec(),
            relative_asymmetry,
            coupling_asymmetry,
            cycle_residuals: cycle_residuals(a_c),
            sign_mismatched_pairs: Vec::new(),
        }
    }
}

/// a_ij·a_jk·a_ki against a_ji·a_kj·a_ik for every triangle i < j < k.
pub(super) fn cycle_residuals(a: &DMatrix<f64>) -> Vec<CycleResidual> {
    let n = a.nrows();
    let mut out = Vec::new();
    for i in 0..n {
        for j in i + 1..n {
            for k in j + 1..n {
                let forward = a[(i, j)] * a[(j, k)] * a[(k, i)];
                let backward = a[(j, i)] * a[(k, j)] * a[(i, k)];
                out.push(CycleResidual {
                    parts: [i, j, k],
                    forward,
                    backward,
                    residual: forward - backward,
                    ratio: (backward != 0.0).then(|| forward / backward),
                });
            }
        }
    }
    out
}

/// Every part reachable from part 0 through the pairs used, else the first that is not.
fn check_connected(
    n: usize,
    equations: &[(usize, usize, f64)],
    labels: &Labels,
) -> Result<(), NetworkError> {
    if n == 0 {
        return Ok(());
    }
    let mut reached = vec![false; n];
    reached[0] = true;
    let mut grew = true;
    while grew {
        grew = false;
        for &(i, j, _) in equations {
            if reached[i] != reached[j] {
                reached[i] = true;
                reached[j] = true;
                grew = true;
            }
        }
    }
    match reached.iter().position(|r| !r) {
        None => Ok(()),
        Some(k) => Err(NetworkError::Uncoupled {
            part: labels.states[0].clone(),
            other: labels.states[k].clone(),
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn labels(n: usize) -> Labels {
        Labels::numbered(n, 0)
    }

    #[test]
    fn two_parts_ratio_is_the_ratio_of_the_couplings() {
        // c1·a12 = c2·a21 → c1/c2 = a21/a12 = 0.0125/0.05 = 1/4.
        let a = DMatrix::from_row_slice(2, 2, &[-0.06, 0.05, 0.0125, -0.0625]);
        let fit = fit_capacitance_ratios(&a, &labels(2)).unwrap();
        assert!((fit.ratios[0] / fit.ratios[1] - 0.25).abs() < 1e-14);
        // Geometric mean 1: c1·c2 = 1 → c1 = 1/2, c2 = 2.
        assert!((fit.ratios[0] - 0.5).abs() < 1e-14);
        assert!(fit.relative_asymmetry < 1e-15);
        assert!(fit.cycle_residuals.is_empty());
    }

    #[test]
    fn log_least_squares_spreads_the_cycle_evenly_over_the_pairs() {
        // A non-reciprocal 3-part model: each pair's log misfit is ±ln(ratio)/3.
        let a = DMatrix::from_row_slice(
            3,
            3,
            &[
                -0.003, 0.001, 0.002, 0.0005, -0.004, 0.003, 0.004, 0.0015, -0.01,
            ],
        );
        let fit = fit_capacitance_ratios(&a, &labels(3)).unwrap();
        let cycle = &fit.cycle_residuals[0];
        let ln_ratio = cycle.ratio.unwrap().ln();
        let r = &fit.ratios;
        for (i, j) in [(0, 1), (1, 2), (2, 0)] {
            let misfit = (r[i] * a[(i, j)] / (r[j] * a[(j, i)])).ln();
            assert!((misfit - ln_ratio / 3.0).abs() < 1e-12, "{i}{j}: {misfit}");
        }
    }

    #[test]
    fn opposite_signs_are_listed_and_a_lone_part_is_an_error() {
        let a = DMatrix::from_row_slice(
            3,
            3,
            &[-0.01, 0.002, -0.001, 0.003, -0.02, 0.0, 0.001, 0.0, -0.05],
        );
        // 1–3 have opposite signs, 2–3 are zero: part 3 is coupled to nothing usable.
        let err = fit_capacitance_ratios(&a, &labels(3)).unwrap_err();
        assert_eq!(
            err,
            NetworkError::Uncoupled {
                part: "part 1".into(),
                other: "part 3".into()
            }
        );
        let mut b = a.clone();
        b[(1, 2)] = 0.004;
        b[(2, 1)] = 0.002;
        let fit = fit_capacitance_ratios(&b, &labels(3)).unwrap();
        assert_eq!(fit.sign_mismatched_pairs, vec![[0, 2]]);
    }
}
