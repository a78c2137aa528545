//! Why an estimated model cannot be analysed, with the figures that decided it.

/// A model that is not a stable thermal system, or has no continuous form.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ModelError {
    /// A matrix holds NaN or infinite entries.
    #[error("{matrix} has non-finite entries")]
    NonFinite {
        /// The matrix (`Φ`, `A_c`, …).
        matrix: &'static str,
    },
    /// A complex eigenvalue pair where only real ones are allowed.
    #[error(
        "{matrix} has the complex eigenvalue pair {re:.6} ± {im:.6}i: an oscillating model is \
         not a thermal system of decaying time constants"
    )]
    ComplexEigenvalues {
        /// The matrix.
        matrix: &'static str,
        /// Real part.
        re: f64,
        /// Imaginary part (positive).
        im: f64,
    },
    /// Φ has an eigenvalue ≤ 0 and so no real logarithm.
    #[error(
        "Φ has the eigenvalue {eigenvalue:.6} ≤ 0, so it has no real logarithm and no continuous \
         equivalent (the sample time is too long for the fastest dynamics, or the estimate is poor)"
    )]
    NoRealLogarithm {
        /// The eigenvalue.
        eigenvalue: f64,
    },
    /// The inverse scaling and squaring of ln Φ did not reach the identity.
    #[error("the matrix logarithm of Φ did not converge after {square_roots} square roots")]
    LogarithmDiverged {
        /// Square roots taken.
        square_roots: usize,
    },
    /// A matrix that must be inverted is singular.
    #[error("{matrix} is singular")]
    Singular {
        /// The matrix.
        matrix: &'static str,
    },
    /// Φ − I is singular: an integrator.
    #[error("Φ − I is singular: Φ has an eigenvalue 1 (an integrator, no time constant)")]
    Integrator,
    /// A_c is singular: no steady state.
    #[error("A_c is singular: the model has no steady state")]
    NoSteadyState,
    /// An eigenvalue of Φ outside (0, 1).
    #[error(
        "the estimate is not a stable thermal system: Φ has the eigenvalue {eigenvalue:.6}, \
         outside (0, 1)"
    )]
    Unstable {
        /// The eigenvalue.
        eigenvalue: f64,
    },
    /// A complex-conjugate pair of Φ on or outside the unit circle: a growing oscillation.
    #[error(
        "the estimate is not a stable thermal system: Φ has the complex eigenvalue pair \
         {re:.6} ± {im:.6}i of modulus {modulus:.6} ≥ 1 (a growing oscillation)"
    )]
    UnstablePair {
        /// Real part.
        re: f64,
        /// Imaginary part (positive).
        im: f64,
        /// |λ|.
        modulus: f64,
    },
    /// A_c's eigenvectors do not span the space (repeated time constants).
    #[error("A_c is not diagonalisable (repeated time constants)")]
    NotDiagonalisable,
}
