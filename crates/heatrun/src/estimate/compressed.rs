//! Levenberg–Marquardt on a tall problem at the cost of its parameters, not its rows.
//!
//! The `levenberg_marquardt` crate factorises the whole N×p Jacobian J by a pivoted
//! Householder QR every iteration, O(2Np²) in column-at-a-time loops: on the hidden-state
//! fits (N ≈ 3,000 rows, p ≈ 60) that was two thirds of the time. Every quantity LM uses
//! is a function of JᵀJ, Jᵀr and ‖r‖ alone (the step solves (JᵀJ + λD²) δ = −Jᵀr, the
//! predicted reduction is ‖Jδ‖² + 2λ‖Dδ‖², the gradient test reads Jᵀr and the columns'
//! norms, the cost is ½‖r‖²), so LM may as well be handed any problem with the same three:
//! an orthonormal change of basis of the residual space, kept to p + 1 rows.
//!
//! With u = r/‖r‖ at the current point, the basis is u followed by an orthonormal basis of
//! the part of J's columns orthogonal to u. In it
//!
//! r̃ = (‖r‖, 0, …, 0)ᵀ,  J̃ = [ uᵀJ ; R′ ],  R′ᵀR′ = JᵀJ − Jᵀu uᵀJ,
//!
//! so J̃ᵀJ̃ = JᵀJ, J̃ᵀr̃ = Jᵀr and ‖r̃‖ = ‖r‖: LM takes the same steps, in exact arithmetic,
//! as on the full problem. The trial points' residuals cost one norm (no Jacobian at a
//! point LM refuses); the accepted point's R′ is a square root of the p×p Gram matrix of
//! J′ = J − u (uᵀJ): its Cholesky factor, Jacobi-scaled (the columns' scales out of its
//! conditioning), or where the data leave a direction free (a state basis), the root
//! from its eigendecomposition. R′ need not be triangular: LM factorises J̃ itself.

use std::cell::RefCell;

use levenberg_marquardt::LeastSquaresProblem;
use nalgebra::storage::Owned;
use nalgebra::{DMatrix, DVector, Dyn};

/// Δχ² below which one iteration's gain is no longer information: a hundredth of one
/// unit of the likelihood's χ², whatever the noise level.
pub(crate) const NEGLIGIBLE_CHI2_STEP: f64 = 0.01;

/// LM's relative cost tolerance tied to the noise: with σ² ≈ 2J/N (N residuals), a step
/// that lowers the cost J by ΔJ changes χ² = 2J/σ² by Δχ² ≈ N ΔJ/J, so LM stops where
/// ΔJ/J ≤ [`NEGLIGIBLE_CHI2_STEP`]/N (a fixed 10⁻¹⁰ had over-parameterised fits creep
/// along a flat valley to LM's evaluation cap, four tenths of the hidden-state fits'
/// evaluations, each step worth a millionth of χ²).
pub(crate) fn noise_tied_ftol(residuals: usize) -> f64 {
    (NEGLIGIBLE_CHI2_STEP / residuals.max(1) as f64).max(1e-12)
}

/// A tall least-squares problem seen by LM through p + 1 rows (module docs).
pub(crate) struct Compressed<P> {
    inner: P,
    /// u = r/‖r‖ at the point of the last residuals (None where ‖r‖ = 0 or not finite).
    direction: RefCell<Option<DVector<f64>>>,
}

impl<P> Compressed<P>
where
    P: LeastSquaresProblem<f64, Dyn, Dyn, ResidualStorage = Owned<f64, Dyn>>,
{
    /// `inner` seen through p + 1 rows.
    pub(crate) fn new(inner: P) -> Self {
        Compressed {
            inner,
            direction: RefCell::new(None),
        }
    }

    /// The full problem, at the parameters LM left it.
    pub(crate) fn into_inner(self) -> P {
        self.inner
    }

    fn parameters(&self) -> usize {
        self.inner.params().len()
    }
}

impl<P> LeastSquaresProblem<f64, Dyn, Dyn> for Compressed<P>
where
    P: LeastSquaresProblem<
        f64,
        Dyn,
        Dyn,
        ResidualStorage = Owned<f64, Dyn>,
        JacobianStorage = Owned<f64, Dyn, Dyn>,
        ParameterStorage = Owned<f64, Dyn>,
    >,
{
    type ResidualStorage = Owned<f64, Dyn>;
    type JacobianStorage = Owned<f64, Dyn, Dyn>;
    type ParameterStorage = Owned<f64, Dyn>;

    fn set_params(&mut self, x: &DVector<f64>) {
        self.inner.set_params(x);
    }

    fn params(&self) -> DVector<f64> {
        self.inner.params()
    }

    /// r̃ = (‖r‖, 0, …, 0)ᵀ, remembering u = r/‖r‖ for the Jacobian at the same point.
    fn residuals(&self) -> Option<DVector<f64>> {
        let r = self.inner.residuals()?;
        let norm = r.norm();
        let mut compressed = DVector::zeros(self.parameters() + 1);
        compressed[0] = norm;
        *self.direction.borrow_mut() = (norm.is_finite() && norm > 0.0).then(|| r / norm);
        Some(compressed)
    }

    /// J̃ = [uᵀJ ; R′] with R′ᵀR′ = J′ᵀJ′, J′ = J − u uᵀJ (module docs).
    fn jacobian(&self) -> Option<DMatrix<f64>> {
        let j = self.inner.jacobian()?;
        let p = j.ncols();
        let direction = self.direction.borrow();
        let (along, across) = match direction.as_ref() {
            Some(u) if u.len() == j.nrows() => {
                let along = j.tr_mul(u); // Jᵀu, p entries
                let mut across = j;
                across.ger(-1.0, u, &along, 1.0); // J − u (Jᵀu)ᵀ
                (along, across)
            }
            // r = 0: any basis will do, and uᵀJ = 0.
            _ => (DVector::zeros(p), j),
        };
        let triangle = root_of(&across)?;
        let mut compressed = DMatrix::zeros(p + 1, p);
        compressed.row_mut(0).copy_from(&along.transpose());
        compressed.rows_mut(1, p).copy_from(&triangle);
        Some(compressed)
    }
}

/// A square root R (p×p) of the Gram matrix, RᵀR = AᵀA: from the Cholesky factor of the
/// Jacobi-scaled Gram matrix S⁻¹AᵀAS⁻¹ = LLᵀ (S the columns' norms), R = LᵀS; where that
/// matrix is not numerically positive definite (a direction the data do not fix, as a
/// state basis left free), from its eigendecomposition VΛVᵀ, R = Λ^½VᵀS (eigenvalues
/// below rounding taken as zero: LM's damping holds those directions).
fn root_of(a: &DMatrix<f64>) -> Option<DMatrix<f64>> {
    let p = a.ncols();
    // Half the products of AᵀA: columns are contiguous, each entry one dot product.
    let mut gram = DMatrix::zeros(p, p);
    for i in 0..p {
        for k in i..p {
            let v = a.column(i).dot(&a.column(k));
            gram[(i, k)] = v;
            gram[(k, i)] = v;
        }
    }
    if !gram.iter().all(|v| v.is_finite()) {
        return None;
    }
    // A column of zeros keeps a unit scale: its row of R is zero either way.
    let scale = DVector::from_iterator(p, (0..p).map(|i| gram[(i, i)].sqrt())).map(|s| {
        if s > 0.0 {
            s
        } else {
            1.0
        }
    });
    let scaled = DMatrix::from_fn(p, p, |i, k| gram[(i, k)] / (scale[i] * scale[k]));
    let mut root = match scaled.clone().cholesky() {
        // A pivot below √ε of the unit diagonal has lost every digit to rounding.
        Some(cholesky) if (0..p).all(|i| cholesky.l_dirty()[(i, i)] > 1e-7) => {
            cholesky.l().transpose()
        }
        _ => {
            let eigen = scaled.symmetric_eigen();
            let mut root = eigen.eigenvectors.transpose();
            for (i, lambda) in eigen.eigenvalues.iter().enumerate() {
                root.row_mut(i).scale_mut(lambda.max(0.0).sqrt());
            }
            root
        }
    };
    for k in 0..p {
        root.column_mut(k).scale_mut(scale[k]);
    }
    Some(root)
}

#[cfg(test)]
mod tests {
    use super::*;
    use levenberg_marquardt::LevenbergMarquardt;

    /// y = a·exp(−t/τ) + b sampled at 400 instants with a fixed wiggle: a tall problem
    /// whose minimiser is found the same through both views.
    struct Decay {
        t: Vec<f64>,
        y: Vec<f64>,
        params: DVector<f64>,
    }

    impl Decay {
        fn new() -> Self {
            let t: Vec<f64> = (0..400).map(|k| k as f64 * 0.05).collect();
            let y = t
                .iter()
                .enumerate()
                .map(|(k, t)| 3.0 * (-t / 4.0).exp() + 0.5 + 0.01 * ((k * 7919 % 13) as f64 - 6.0))
                .collect();
            Decay {
                t,
                y,
                params: DVector::from_vec(vec![1.0, 1.0, 0.0]),
            }
        }
    }

    impl LeastSquaresProblem<f64, Dyn, Dyn> for Decay {
        type ResidualStorage = Owned<f64, Dyn>;
        type JacobianStorage = Owned<f64, Dyn, Dyn>;
        type ParameterStorage = Owned<f64, Dyn>;
        fn set_params(&mut self, x: &DVector<f64>) {
            self.params.copy_from(x);
        }
        fn params(&self) -> DVector<f64> {
            self.params.clone()
        }
        fn residuals(&self) -> Option<DVector<f64>> {
            let (a, tau, b) = (self.params[0], self.params[1], self.params[2]);
            Some(DVector::from_iterator(
                self.t.len(),
                self.t
                    .iter()
                    .zip(&self.y)
                    .map(|(t, y)| a * (-t / tau).exp() + b - y),
            ))
        }
        fn jacobian(&self) -> Option<DMatrix<f64>> {
            let (a, tau) = (self.params[0], self.params[1]);
            Some(DMatrix::from_fn(self.t.len(), 3, |k, i| {
                let e = (-self.t[k] / tau).exp();
                match i {
                    0 => e,
                    1 => a * e * self.t[k] / (tau * tau),
                    _ => 1.0,
                }
            }))
        }
    }

    #[test]
    fn the_compressed_view_keeps_the_gram_matrix_the_gradient_and_the_cost() {
        let mut full = Decay::new();
        full.set_params(&DVector::from_vec(vec![2.0, 3.0, 0.2]));
        let (r, j) = (full.residuals().unwrap(), full.jacobian().unwrap());
        let view = Compressed::new(full);
        let (rc, jc) = (view.residuals().unwrap(), view.jacobian().unwrap());
        assert_eq!((rc.len(), jc.nrows()), (4, 4));
        assert!((rc.norm() - r.norm()).abs() < 1e-12 * r.norm());
        let gram = j.tr_mul(&j);
        assert!((jc.tr_mul(&jc) - &gram).norm() < 1e-10 * gram.norm());
        let gradient = j.tr_mul(&r);
        assert!((jc.tr_mul(&rc) - &gradient).norm() < 1e-10 * gradient.norm());
    }

    #[test]
    fn lm_finds_the_same_minimum_through_either_view() {
        let lm = LevenbergMarquardt::new().with_ftol(1e-14).with_xtol(1e-14);
        let (full, _) = lm.minimize(Decay::new());
        let (view, report) = lm.minimize(Compressed::new(Decay::new()));
        assert!(
            report.termination.was_successful(),
            "{:?}",
            report.termination
        );
        let (a, b) = (full.params, view.into_inner().params);
        assert!((&a - &b).norm() < 1e-8, "{a} against {b}");
        assert!((a[1] - 4.0).abs() < 0.05, "τ = {}", a[1]);
    }

    #[test]
    fn a_column_the_data_do_not_fix_still_gives_a_root_of_the_gram_matrix() {
        // Two equal columns: the scaled Gram matrix is singular, R from its eigenvectors.
        let a = DMatrix::from_fn(50, 2, |k, _| (k as f64).sin());
        let r = root_of(&a).unwrap();
        assert!((r.tr_mul(&r) - a.tr_mul(&a)).norm() < 1e-10 * a.norm_squared());
    }
}
