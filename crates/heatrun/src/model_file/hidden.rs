//! A report's model with hidden states read back: where the report's `hidden` block is
//! the replay's model (`hidden.replay_model`), the uses of the model run
//!
//! x(k+1) = Φ x(k) + Γ u(k),   y(k) = C x(k) + D u(k),
//!
//! with n states of which the p measured outputs y are the report's `states`, and not
//! the measured-state model (C = I, D = 0) beside it.

use std::path::Path;

use nalgebra::{DMatrix, DVector};

use super::document::{HiddenEntry, HIDDEN_COVARIANCE_LAYOUT};
use super::error::UseError;

/// How the measured outputs read a hidden-state model's states: y = C x + D u.
#[derive(Debug, Clone, PartialEq)]
pub struct OutputMap {
    /// C (p × n): output i's weights on the states.
    pub c: DMatrix<f64>,
    /// D (p × m): the inputs' feedthrough to the outputs.
    pub d: DMatrix<f64>,
    /// A name per state, n: a measured output's own name where C's row picks that state
    /// alone (C = [I 0]), else `hidden_<i>` (1-based).
    pub state_names: Vec<String>,
}

impl OutputMap {
    /// The outputs y = C x + D u.
    pub fn outputs(&self, x: &DVector<f64>, u: &DVector<f64>) -> DVector<f64> {
        &self.c * x + &self.d * u
    }

    /// The state of least norm whose outputs are `y` at input `u`: x = C⁺ (y − D u)
    /// (the minimum-norm least-squares solution by the SVD). With C = [I 0] the measured
    /// states are y − D u and the hidden ones zero, the rest a cold start implies; a
    /// measured-state model (C = I) gets y itself.
    pub fn state_from_outputs(&self, y: &DVector<f64>, u: &DVector<f64>) -> DVector<f64> {
        let rhs = y - &self.d * u;
        let svd = self.c.clone().svd(true, true);
        let tol = svd.singular_values.max() * 1e-10 * self.c.nrows().max(self.c.ncols()) as f64;
        svd.solve(&rhs, tol)
            .unwrap_or_else(|_| DVector::zeros(self.c.ncols()))
    }
}

/// A report's hidden-state model read back: Φ, Γ, the output map and, where the report
/// carries it, the covariance of θ_h = [Φ Γ; C D] row by row.
pub(super) struct HiddenRead {
    /// Φ (n × n).
    pub phi: DMatrix<f64>,
    /// Γ (n × m).
    pub gamma: DMatrix<f64>,
    /// y = C x + D u.
    pub output: OutputMap,
    /// C_θ ((n + p)(n + m) square), where the report has `parameter_covariance`.
    pub covariance: Option<DMatrix<f64>>,
}

/// The hidden-state model of a report's `hidden` block, checked against the report's p
/// outputs and m inputs, with the covariance of its parameters where the report has it
/// (its layout the one this heatrun writes, its size (n + p)(n + m)).
pub(super) fn read(
    h: &HiddenEntry,
    outputs: &[String],
    inputs: usize,
    path: &Path,
) -> Result<HiddenRead, UseError> {
    let (p, m, n) = (outputs.len(), inputs, h.order);
    let matrix = |rows: &[Vec<f64>], shape: (usize, usize), key: &'static str| {
        super::shape::matrix(rows, shape, key, path, (n, m))
    };
    let phi = matrix(&h.phi, (n, n), "hidden.phi")?;
    let gamma = matrix(&h.gamma, (n, m), "hidden.gamma")?;
    let c = matrix(&h.c, (p, n), "hidden.c")?;
    let d = matrix(&h.d, (p, m), "hidden.d")?;
    let covariance = match &h.parameter_covariance {
        Some(entry) => {
            if entry.layout != HIDDEN_COVARIANCE_LAYOUT {
                return Err(UseError::Shape {
                    path: path.to_owned(),
                    key: "hidden.parameter_covariance.layout",
                    found: format!("`{}`", entry.layout),
                    expected: format!("`{HIDDEN_COVARIANCE_LAYOUT}`"),
                    states: n,
                    inputs: m,
                });
            }
            let size = (n + p) * (n + m);
            Some(matrix(
                &entry.matrix,
                (size, size),
                "hidden.parameter_covariance.matrix",
            )?)
        }
        None => None,
    };
    let state_names = state_names(&c, outputs);
    Ok(HiddenRead {
        phi,
        gamma,
        output: OutputMap { c, d, state_names },
        covariance,
    })
}

/// Each state's name: the output that reads it alone (a unit row of C, zero elsewhere
/// in its column), else `hidden_<i>`.
pub fn state_names(c: &DMatrix<f64>, outputs: &[String]) -> Vec<String> {
    (0..c.ncols())
        .map(|j| {
            let reads = (0..c.nrows()).find(|&i| {
                c[(i, j)] == 1.0
                    && (0..c.ncols()).all(|l| l == j || c[(i, l)] == 0.0)
                    && (0..c.nrows()).all(|r| r == i || c[(r, j)] == 0.0)
            });
            match reads {
                Some(i) => outputs[i].clone(),
                None => format!("hidden_{}", j + 1),
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_measured_state_is_named_by_its_output_and_the_others_are_hidden() {
        let c = DMatrix::from_row_slice(2, 3, &[1.0, 0.0, 0.0, 0.0, 1.0, 0.0]);
        let names = state_names(&c, &["winding".into(), "core".into()]);
        assert_eq!(names, ["winding", "core", "hidden_3"]);
        // A free C mixes states: none is an output's own.
        let free = DMatrix::from_row_slice(1, 2, &[0.7, 0.3]);
        assert_eq!(state_names(&free, &["y".into()]), ["hidden_1", "hidden_2"]);
    }

    #[test]
    fn the_start_from_the_outputs_is_the_least_norm_state_that_gives_them() {
        // C = [I 0]: x = (y − D u, 0); C x + D u = y exactly.
        let map = OutputMap {
            c: DMatrix::from_row_slice(2, 3, &[1.0, 0.0, 0.0, 0.0, 1.0, 0.0]),
            d: DMatrix::from_row_slice(2, 1, &[0.5, 0.0]),
            state_names: vec![],
        };
        let (y, u) = (
            DVector::from_vec(vec![2.0, 3.0]),
            DVector::from_vec(vec![2.0]),
        );
        let x = map.state_from_outputs(&y, &u);
        assert!((x - DVector::from_vec(vec![1.0, 3.0, 0.0])).amax() < 1e-12);
    }
}
