//! Rao's score test of parameters held at a bound (conductances held at zero), taken at
//! the held fit alone: what freeing them would gain, from the Gauss–Newton model there.
//!
//! With the weighted residuals r(θ) (each output's weight 1/σ̂²_i, so that J = ‖r‖² is in
//! χ² units), their Jacobian's normal equations G = JᵀJ and g = Jᵀr at the held fit, the
//! decrease of J a Gauss–Newton step in the parameters X predicts is
//!
//! ```text
//! gain(X) = g_Xᵀ G_XX⁻¹ g_X,      its step δ_X = −G_XX⁻¹ g_X
//! ```
//!
//! The statistic is what freeing the held parameters T adds to the fit's own parameters B,
//! with every freed parameter moving only up from its bound (a conductance cannot go below
//! zero):
//!
//! ```text
//! S = max { gain(B ∪ T′) : T′ ⊆ T, δ_T′ ≥ 0 } − gain(B)
//! ```
//!
//! the largest decrease of the Gauss–Newton model on the feasible side (each T′ whose step
//! keeps its own parameters at or above the bound is a feasible point of the convex
//! quadratic, and its constrained minimum is one of them). Subtracting gain(B) makes S
//! Neyman's C(α) form: a held fit stopped short of its own minimum does not count as
//! evidence for the freed parameters. Under the held model S is asymptotically χ̄²,
//! bounded in its tail by χ²_|T|; the likelihood-ratio statistic of a free fit is the same
//! statistic to first order (a free fit not needed to take it).

use nalgebra::{DMatrix, DVector};

/// The score test's figures at a held fit
/// ([`crate::estimate::ResistanceCapacitance::held_score`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HeldScore {
    /// S: what freeing the held parameters would gain beyond the held fit's own step, in
    /// χ² units.
    pub statistic: f64,
    /// gain(B): what the held fit's own Gauss–Newton step would still gain, in χ² units
    /// (a fit stopped short of its minimum leaves more than a fraction of one).
    pub short_of_minimum: f64,
}

/// S of the module documentation: `gram` = JᵀJ and `grad` = Jᵀr of the weighted residuals
/// over every parameter, `base` the parameters the held fit estimated, `freed` those it
/// held at their lower bound; with gain(B), what the held fit's own step would still gain
/// (a held fit stopped short of its minimum). `None` where a normal-equation block cannot
/// be factorised.
pub(crate) fn constrained_gain(
    gram: &DMatrix<f64>,
    grad: &DVector<f64>,
    base: &[usize],
    freed: &[usize],
) -> Option<(f64, f64)> {
    let (held_gain, _) = gain_and_step(gram, grad, base)?;
    let mut best = held_gain;
    // Every subset of the freed parameters (three conductances: eight subsets).
    for mask in 1usize..(1 << freed.len()) {
        let chosen: Vec<usize> = (0..freed.len())
            .filter(|b| mask & (1 << b) != 0)
            .map(|b| freed[b])
            .collect();
        let columns: Vec<usize> = base.iter().chain(&chosen).copied().collect();
        let (gain, step) = gain_and_step(gram, grad, &columns)?;
        let feasible = step.iter().skip(base.len()).all(|d| *d >= 0.0);
        if feasible && gain > best {
            best = gain;
        }
    }
    Some(((best - held_gain).max(0.0), held_gain))
}

/// gain(X) and δ_X for the parameters `columns` (module documentation), by a Cholesky
/// factor of G_XX scaled to a unit diagonal (a parameter's scale, a conductance at 10⁻⁹
/// of the largest, does not enter the factorisation's accuracy).
pub(crate) fn gain_and_step(
    gram: &DMatrix<f64>,
    grad: &DVector<f64>,
    columns: &[usize],
) -> Option<(f64, DVector<f64>)> {
    let p = columns.len();
    let scale: Vec<f64> = columns
        .iter()
        .map(|&c| 1.0 / gram[(c, c)].max(1e-300).sqrt())
        .collect();
    let scaled = DMatrix::from_fn(p, p, |i, j| {
        gram[(columns[i], columns[j])] * scale[i] * scale[j] + if i == j { 1e-13 } else { 0.0 }
    });
    let g = DVector::from_fn(p, |i, _| grad[columns[i]] * scale[i]);
    let chol = scaled.cholesky()?;
    let solved = chol.solve(&g);
    let gain = g.dot(&solved);
    let step = DVector::from_fn(p, |i, _| -solved[i] * scale[i]);
    Some((gain, step))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// J = ‖Aθ − y‖² near θ = 0, worked by hand: G = AᵀA, g = Jᵀr = −Aᵀy.
    fn normal_equations(a: &DMatrix<f64>, y: &DVector<f64>) -> (DMatrix<f64>, DVector<f64>) {
        (a.transpose() * a, -(a.transpose() * y))
    }

    #[test]
    fn a_freed_parameter_that_would_go_up_gains_its_whole_decrease() {
        // Orthogonal columns: y = (1, 2): θ_0 alone gains 1, θ_1 freed gains 4 (δ = +2).
        let a = DMatrix::from_row_slice(2, 2, &[1.0, 0.0, 0.0, 1.0]);
        let y = DVector::from_vec(vec![1.0, 2.0]);
        let (gram, grad) = normal_equations(&a, &y);
        let s = constrained_gain(&gram, &grad, &[0], &[1]).unwrap().0;
        assert!((s - 4.0).abs() < 1e-9, "{s}");
    }

    #[test]
    fn a_freed_parameter_that_would_go_below_its_bound_gains_nothing() {
        // y = (1, −2): θ_1's step is −2, below its bound: S = 0.
        let a = DMatrix::from_row_slice(2, 2, &[1.0, 0.0, 0.0, 1.0]);
        let y = DVector::from_vec(vec![1.0, -2.0]);
        let (gram, grad) = normal_equations(&a, &y);
        let s = constrained_gain(&gram, &grad, &[0], &[1]).unwrap().0;
        assert_eq!(s, 0.0);
    }

    #[test]
    fn correlated_columns_take_the_gain_beyond_what_the_held_fit_already_has() {
        // A = [1 1; 0 1], y = (1, 1). θ_0 alone: gain = (Aᵀy)_0² / (AᵀA)_00 = 1. Both: y
        // is fitted exactly, gain ‖y‖² = 2, with θ = (0, 1): δ_1 = 1 ≥ 0. S = 2 − 1 = 1.
        let a = DMatrix::from_row_slice(2, 2, &[1.0, 1.0, 0.0, 1.0]);
        let y = DVector::from_vec(vec![1.0, 1.0]);
        let (gram, grad) = normal_equations(&a, &y);
        let (s, held) = constrained_gain(&gram, &grad, &[0], &[1]).unwrap();
        assert!((s - 1.0).abs() < 1e-9, "{s}");
        // The held fit at θ = 0 is itself short of its minimum (θ_0 = 1): gain(B) = 1.
        assert!((held - 1.0).abs() < 1e-9, "{held}");
    }

    #[test]
    fn of_two_freed_parameters_only_the_one_that_stays_above_its_bound_counts() {
        // Orthogonal: y = (1, 3, −2) over θ_0 (held fit's), θ_1, θ_2 (freed). θ_1 gains 9
        // (δ = +3); θ_2 would go to −2: the feasible best frees θ_1 alone, S = 9.
        let a = DMatrix::<f64>::identity(3, 3);
        let y = DVector::from_vec(vec![1.0, 3.0, -2.0]);
        let (gram, grad) = normal_equations(&a, &y);
        let s = constrained_gain(&gram, &grad, &[0], &[1, 2]).unwrap().0;
        assert!((s - 9.0).abs() < 1e-9, "{s}");
    }

    #[test]
    fn a_tiny_parameter_scale_changes_nothing() {
        // The same as the correlated case with θ_1 measured in units 10⁹ times larger
        // (its column 10⁻⁹ times smaller): the gain is invariant, the step's sign too.
        let a = DMatrix::from_row_slice(2, 2, &[1.0, 1e-9, 0.0, 1e-9]);
        let y = DVector::from_vec(vec![1.0, 1.0]);
        let (gram, grad) = normal_equations(&a, &y);
        let s = constrained_gain(&gram, &grad, &[0], &[1]).unwrap().0;
        assert!((s - 1.0).abs() < 1e-6, "{s}");
    }
}
