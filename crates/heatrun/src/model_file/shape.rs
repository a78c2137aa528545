//! A report's matrices read back with their shapes checked: the one check the measured-state
//! model ([`super::thermal_model`]) and the hidden-state model ([`super::hidden`]) share.

use std::path::Path;

use nalgebra::DMatrix;

use super::error::UseError;

/// The `nrows × ncols` matrix of a report's `key` (rows of numbers), or the one-line
/// error naming the key, the shape found and the one expected.
pub(super) fn matrix(
    rows: &[Vec<f64>],
    (nrows, ncols): (usize, usize),
    key: &'static str,
    path: &Path,
    (n, m): (usize, usize),
) -> Result<DMatrix<f64>, UseError> {
    if rows.len() != nrows || rows.iter().any(|r| r.len() != ncols) {
        return Err(UseError::Shape {
            path: path.to_owned(),
            key,
            found: format!(
                "{} rows of [{}] entries",
                rows.len(),
                rows.iter()
                    .map(|r| r.len().to_string())
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
            expected: format!("{nrows} × {ncols}"),
            states: n,
            inputs: m,
        });
    }
    Ok(DMatrix::from_fn(nrows, ncols, |i, j| rows[i][j]))
}
