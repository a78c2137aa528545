//! Matrix functions the analysis needs: the principal logarithm, zero-order-hold
//! discretisation (nalgebra's matrix exponential) and the eigenvalues (real or in
//! complex-conjugate pairs) and eigenvectors of a general (non-symmetric) matrix.

use nalgebra::{Complex, DMatrix, DVector};

use super::ModelError;

/// Result of the model analysis.
type Result<T, E = ModelError> = std::result::Result<T, E>;

/// A matrix as a list of its rows (the layout of the report and the truth files).
pub fn rows(m: &DMatrix<f64>) -> Vec<Vec<f64>> {
    (0..m.nrows())
        .map(|i| m.row(i).iter().copied().collect())
        .collect()
}

/// Eigenvalues of a general square matrix, real or in complex-conjugate pairs, ordered
/// by ascending modulus (for Φ: ascending time constant), each pair with its positive
/// imaginary part first. An imaginary part below `1e-9·|λ|` is rounding of a real
/// eigenvalue and set to zero.
///
/// Computed from the real Schur form (nalgebra's `complex_eigenvalues`).
pub fn eigenvalues(m: &DMatrix<f64>, matrix: &'static str) -> Result<Vec<Complex<f64>>> {
    let mut out: Vec<Complex<f64>> = Vec::with_capacity(m.nrows());
    for z in m.clone().complex_eigenvalues().iter() {
        if !z.re.is_finite() || !z.im.is_finite() {
            return Err(ModelError::NonFinite { matrix });
        }
        let im = if z.im.abs() > 1e-9 * z.norm().max(1e-300) {
            z.im
        } else {
            0.0
        };
        out.push(Complex::new(z.re, im));
    }
    out.sort_by(|a, b| {
        a.norm()
            .total_cmp(&b.norm())
            .then(a.re.total_cmp(&b.re))
            .then(b.im.total_cmp(&a.im))
    });
    Ok(out)
}

/// Eigenvalues of a general square matrix, which must all be real.
///
/// Computed from the real Schur form; a pair with imaginary part above
/// `1e-9·|λ|` is reported as an error naming it, never rounded to its real part.
pub fn real_eigenvalues(m: &DMatrix<f64>, matrix: &'static str) -> Result<Vec<f64>> {
    let mut out = Vec::with_capacity(m.nrows());
    for z in eigenvalues(m, matrix)? {
        if z.im != 0.0 {
            return Err(ModelError::ComplexEigenvalues {
                matrix,
                re: z.re,
                im: z.im.abs(),
            });
        }
        out.push(z.re);
    }
    out.sort_by(f64::total_cmp);
    Ok(out)
}

/// The spectral radius ρ(M) = max |λ_i(M)|, the largest modulus of M's eigenvalues (a
/// discrete model is stable below 1); NaN where M has non-finite entries.
pub fn spectral_radius(m: &DMatrix<f64>) -> f64 {
    if !m.iter().all(|v| v.is_finite()) {
        return f64::NAN;
    }
    m.clone()
        .complex_eigenvalues()
        .iter()
        .map(|z| z.norm())
        .fold(0.0, f64::max)
}

/// Principal matrix logarithm ln Φ of a real matrix with no eigenvalue on the closed
/// negative real axis (real positive eigenvalues, or complex-conjugate pairs, whose
/// logarithms ln|λ| ± i·arg λ keep ln Φ real).
///
/// Inverse scaling and squaring: take square roots (Denman–Beavers iteration)
/// until ‖X − I‖ < 0.1, sum the series ln(I + E) = Σ (−1)^{j+1} E^j / j to
/// machine precision, and multiply by 2^s. Errors where Φ has no real logarithm:
/// a real eigenvalue ≤ 0.
pub fn logm(phi: &DMatrix<f64>) -> Result<DMatrix<f64>> {
    let eig = eigenvalues(phi, "Φ")?;
    if let Some(z) = eig.iter().find(|z| z.im == 0.0 && z.re <= 0.0) {
        return Err(ModelError::NoRealLogarithm { eigenvalue: z.re });
    }
    let n = phi.nrows();
    let id = DMatrix::<f64>::identity(n, n);
    let mut x = phi.clone();
    let mut squarings = 0;
    while (&x - &id).norm() >= 0.1 {
        x = sqrtm_denman_beavers(&x)?;
        squarings += 1;
        if squarings > 60 {
            return Err(ModelError::LogarithmDiverged {
                square_roots: squarings as usize,
            });
        }
    }
    let e = &x - &id;
    let mut term = e.clone();
    let mut sum = e.clone();
    for j in 2..200 {
        term = &term * &e;
        let add = &term * ((if j % 2 == 0 { -1.0 } else { 1.0 }) / j as f64);
        sum += &add;
        if add.norm() <= 1e-18 * sum.norm().max(1e-300) {
            break;
        }
    }
    Ok(sum * 2f64.powi(squarings))
}

/// Principal square root by the Denman–Beavers iteration Y ← (Y + Z⁻¹)/2, Z ← (Z + Y⁻¹)/2.
fn sqrtm_denman_beavers(a: &DMatrix<f64>) -> Result<DMatrix<f64>> {
    let n = a.nrows();
    let mut y = a.clone();
    let mut z = DMatrix::<f64>::identity(n, n);
    for _ in 0..100 {
        let singular = ModelError::Singular { matrix: "Φ" };
        let y_inv = y.clone().try_inverse().ok_or(singular.clone())?;
        let z_inv = z.clone().try_inverse().ok_or(singular)?;
        let y_next = (&y + z_inv) * 0.5;
        let z_next = (&z + y_inv) * 0.5;
        let change = (&y_next - &y).norm();
        y = y_next;
        z = z_next;
        if change <= 1e-15 * y.norm() {
            break;
        }
    }
    Ok(y)
}

/// e^M, or a matrix of NaN where M has an entry that is not finite.
///
/// Where ‖M‖₁ > `LARGE_NORM`, e^M = (e^{M/2^k})^{2^k} with 2^k ≥ ‖M‖₁ (scaling and
/// squaring done here): nalgebra's own choice of squarings takes the 1-norm of |M|²⁷,
/// which overflows for ‖M‖₁ beyond about 10¹¹, and then asks for u64::MAX squarings, a
/// loop that never ends. A fit that probes a network with a capacitance e^−20 below its
/// start gives such an M: a replay of the paper's model hung in the nearest network's fit
/// (issue 33). NaN entries make the caller's residuals not finite, which every fit treats
/// as a point it cannot evaluate.
pub fn exponential(m: DMatrix<f64>) -> DMatrix<f64> {
    if !m.iter().all(|v| v.is_finite()) {
        return DMatrix::from_element(m.nrows(), m.ncols(), f64::NAN);
    }
    let norm = m
        .column_iter()
        .map(|c| c.iter().map(|v| v.abs()).sum::<f64>())
        .fold(0.0, f64::max);
    if norm <= LARGE_NORM {
        return m.exp();
    }
    let squarings = norm.log2().ceil() as i32;
    let mut x = (m * 2f64.powi(-squarings)).exp();
    for _ in 0..squarings {
        x = &x * &x;
    }
    x
}

/// The 1-norm above which [`exponential`] scales M itself before nalgebra's exponential
/// (far above any physical A·Ts: the paper's fastest mode at Ts = 1 s has ‖A·Ts‖ ≈ 0.1).
const LARGE_NORM: f64 = 1e6;

/// Zero-order-hold discretisation of dx/dt = A x + B u over Ts:
/// Φ = e^{A·Ts}, Γ = ∫₀^Ts e^{A s} ds · B, from one exponential of the block
/// matrix [[A, B], [0, 0]]·Ts (nalgebra's Padé scaling and squaring).
pub fn discretize(a: &DMatrix<f64>, b: &DMatrix<f64>, ts: f64) -> (DMatrix<f64>, DMatrix<f64>) {
    let n = a.nrows();
    let e = exponential(hold_block(a, b, ts));
    (
        e.view((0, 0), (n, n)).into_owned(),
        e.view((0, n), (n, b.ncols())).into_owned(),
    )
}

/// M = [[A, B], [0, 0]]·Ts, whose exponential is [[Φ, Γ], [0, I]] (the zero-order hold).
pub(crate) fn hold_block(a: &DMatrix<f64>, b: &DMatrix<f64>, ts: f64) -> DMatrix<f64> {
    let (n, m) = (a.nrows(), b.ncols());
    let mut block = DMatrix::zeros(n + m, n + m);
    block.view_mut((0, 0), (n, n)).copy_from(&(a * ts));
    block.view_mut((0, n), (n, m)).copy_from(&(b * ts));
    block
}

/// A unit eigenvector of `a` for the real eigenvalue `lambda`: the right singular
/// vector of A − λI with the smallest singular value.
pub fn eigenvector(a: &DMatrix<f64>, lambda: f64) -> DVector<f64> {
    let n = a.nrows();
    let shifted = a - DMatrix::<f64>::identity(n, n) * lambda;
    let svd = shifted.svd(false, true);
    let (imin, _) = svd.singular_values.argmin();
    let v_t = svd.v_t.expect("v_t was requested");
    v_t.row(imin).transpose()
}

/// A unit eigenvector of the real matrix `a` for the eigenvalue `lambda`, real or
/// complex: the right singular vector of A − λI (complex) with the smallest singular
/// value, v = (row of Vᴴ)ᴴ.
pub fn complex_eigenvector(a: &DMatrix<f64>, lambda: Complex<f64>) -> DVector<Complex<f64>> {
    let n = a.nrows();
    let shifted =
        a.map(|v| Complex::new(v, 0.0)) - DMatrix::<Complex<f64>>::identity(n, n) * lambda;
    let svd = shifted.svd(false, true);
    let (imin, _) = svd.singular_values.argmin();
    let v_t = svd.v_t.expect("v_t was requested");
    v_t.row(imin).adjoint()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Beyond nalgebra's reach (‖M‖₁ ≈ 10¹², where its own exponential never returns):
    /// a rotation generator by θ against cos θ and sin θ worked by hand, a stiff decay to
    /// zero, and a non-finite M to NaN.
    #[test]
    fn the_exponential_of_a_matrix_of_huge_norm_returns_and_is_right() {
        let theta = 1e12_f64;
        let rotation = DMatrix::from_row_slice(2, 2, &[0.0, theta, -theta, 0.0]);
        let e = exponential(rotation);
        // 2^40 squarings of the scaled rotation: each step's rounding (≈10⁻¹⁶) grows
        // with their number, so ≈10⁻⁴ is what double precision can give here.
        let (c, s) = (theta.cos(), theta.sin());
        assert!((e[(0, 0)] - c).abs() < 1e-3, "{} vs {c}", e[(0, 0)]);
        assert!((e[(0, 1)] - s).abs() < 1e-3, "{} vs {s}", e[(0, 1)]);
        let decay = DMatrix::from_row_slice(2, 2, &[-1e12, 1e12, 0.0, -2e12]);
        assert!(exponential(decay).iter().all(|v| v.abs() < 1e-300));
        let small = DMatrix::from_row_slice(2, 2, &[-0.1, 0.05, 0.0, -0.2]);
        assert_eq!(exponential(small.clone()), small.exp());
        let broken = DMatrix::from_row_slice(2, 2, &[f64::INFINITY, 0.0, 0.0, 1.0]);
        assert!(exponential(broken).iter().all(|v| v.is_nan()));
    }

    #[test]
    fn logm_of_upper_triangular_matches_closed_form() {
        // ln [[a, b], [0, c]] = [[ln a, b (ln a − ln c)/(a − c)], [0, ln c]].
        let (a, b, c) = (0.95_f64, 0.03_f64, 0.999_f64);
        let m = DMatrix::from_row_slice(2, 2, &[a, b, 0.0, c]);
        let l = logm(&m).unwrap();
        let expect = DMatrix::from_row_slice(
            2,
            2,
            &[a.ln(), b * (a.ln() - c.ln()) / (a - c), 0.0, c.ln()],
        );
        assert!((l - expect).norm() < 1e-14);
    }

    #[test]
    fn logm_far_from_identity_uses_square_roots() {
        // ln of diag(0.02, 5) rotated by an orthogonal similarity.
        let q = DMatrix::from_row_slice(2, 2, &[0.6, -0.8, 0.8, 0.6]);
        let d = DMatrix::from_diagonal(&DVector::from_vec(vec![0.02, 5.0]));
        let m = &q * d * q.transpose();
        let l = logm(&m).unwrap();
        let ld = DMatrix::from_diagonal(&DVector::from_vec(vec![0.02f64.ln(), 5f64.ln()]));
        assert!((l - &q * ld * q.transpose()).norm() < 1e-12);
    }

    #[test]
    fn expm_inverts_logm() {
        let a = DMatrix::from_row_slice(
            3,
            3,
            &[
                -0.0012, 0.00046, 0.00077, 0.00019, -0.00058, 0.0031, 0.0021, 0.0011, -0.0417,
            ],
        );
        let phi = a.exp();
        assert!((logm(&phi).unwrap() - a).norm() < 1e-15);
    }

    /// The hand-written exponential nalgebra's replaced (scaling and squaring of a
    /// Taylor series), kept as the reference it is checked against.
    fn taylor_expm(a: &DMatrix<f64>) -> DMatrix<f64> {
        let n = a.nrows();
        let norm = a.norm();
        let squarings = if norm > 0.5 {
            (norm / 0.5).log2().ceil() as i32
        } else {
            0
        };
        let scaled = a / 2f64.powi(squarings);
        let mut sum = DMatrix::<f64>::identity(n, n);
        let mut term = DMatrix::<f64>::identity(n, n);
        for j in 1..40 {
            term = &term * &scaled / j as f64;
            sum += &term;
            if term.norm() <= 1e-18 * sum.norm() {
                break;
            }
        }
        for _ in 0..squarings {
            sum = &sum * &sum;
        }
        sum
    }

    #[test]
    fn exp_of_a_diagonalisable_matrix_matches_the_hand_worked_value() {
        // A = V diag(−0.5, −3) V⁻¹ with V = [[1, 1], [1, 2]], V⁻¹ = [[2, −1], [−1, 1]].
        // For any D = diag(d1, d2), V D V⁻¹ = [[2d1 − d2, d2 − d1], [2d1 − 2d2, 2d2 − d1]]:
        // A = [[2, −2.5], [5, −5.5]], and e^A is the same with (d1, d2) = (e^−0.5, e^−3).
        let a = DMatrix::from_row_slice(2, 2, &[2.0, -2.5, 5.0, -5.5]);
        let (ea, eb) = ((-0.5f64).exp(), (-3.0f64).exp());
        let expect = DMatrix::from_row_slice(
            2,
            2,
            &[2.0 * ea - eb, -ea + eb, 2.0 * ea - 2.0 * eb, -ea + 2.0 * eb],
        );
        let new = (a.exp() - &expect).norm() / expect.norm();
        let old = (taylor_expm(&a) - &expect).norm() / expect.norm();
        assert!(new < 1e-14, "nalgebra's exp: relative error {new:.1e}");
        assert!(
            old < 1e-14,
            "the Taylor reference: relative error {old:.1e}"
        );
        // The discretisation block of the paper's model at Ts = 1 s and of a stiff one.
        for ts in [1.0, 600.0] {
            let a_c = DMatrix::from_row_slice(
                3,
                3,
                &[
                    -0.0012, 0.00046, 0.00077, 0.00019, -0.00058, 0.0031, 0.0021, 0.0011, -0.0417,
                ],
            ) * ts;
            let diff = (a_c.exp() - taylor_expm(&a_c)).norm() / taylor_expm(&a_c).norm();
            assert!(diff < 1e-13, "Ts = {ts}: {diff:.1e}");
        }
    }

    #[test]
    fn logm_refuses_nonpositive_eigenvalues() {
        let neg = DMatrix::from_row_slice(2, 2, &[0.9, 0.0, 0.0, -0.2]);
        assert_eq!(
            logm(&neg).unwrap_err(),
            ModelError::NoRealLogarithm { eigenvalue: -0.2 }
        );
        let rot = DMatrix::from_row_slice(2, 2, &[0.9, -0.3, 0.3, 0.9]);
        match real_eigenvalues(&rot, "Φ").unwrap_err() {
            ModelError::ComplexEigenvalues { matrix, re, im } => {
                assert_eq!(matrix, "Φ");
                assert!((re - 0.9).abs() < 1e-12 && (im - 0.3).abs() < 1e-12);
            }
            other => panic!("{other}"),
        }
    }

    #[test]
    fn logm_of_a_rotation_matches_the_closed_form() {
        // r·[[cos θ, −sin θ], [sin θ, cos θ]] = exp([[ln r, −θ], [θ, ln r]]) for |θ| < π.
        let (r, theta) = (0.97_f64, 0.3_f64);
        let (c, s) = (r * theta.cos(), r * theta.sin());
        let m = DMatrix::from_row_slice(2, 2, &[c, -s, s, c]);
        let expect = DMatrix::from_row_slice(2, 2, &[r.ln(), -theta, theta, r.ln()]);
        assert!((logm(&m).unwrap() - expect).norm() < 1e-13);
        let eig = eigenvalues(&m, "Φ").unwrap();
        assert!((eig[0].re - c).abs() < 1e-14 && (eig[0].im - s).abs() < 1e-14);
        assert!((eig[1].im + s).abs() < 1e-14);
    }

    #[test]
    fn a_complex_eigenvector_satisfies_its_equation() {
        // A mode pair −0.01 ± 0.05i coupled to a real mode −0.2, mixed by a similarity.
        let block =
            DMatrix::from_row_slice(3, 3, &[-0.01, -0.05, 0.0, 0.05, -0.01, 0.0, 0.0, 0.0, -0.2]);
        let p = DMatrix::from_row_slice(3, 3, &[1.0, 0.5, 0.2, 0.0, 1.0, -0.3, 0.4, 0.0, 1.0]);
        let a = &p * block * p.clone().try_inverse().unwrap();
        let lambda = Complex::new(-0.01, 0.05);
        let v = complex_eigenvector(&a, lambda);
        let av = a.map(|x| Complex::new(x, 0.0)) * &v;
        assert!((av - v.clone() * lambda).norm() < 1e-12);
        assert!((v.norm() - 1.0).abs() < 1e-12);
    }

    #[test]
    fn discretize_scalar_matches_closed_form() {
        // dx/dt = −x/τ + b u: Φ = e^{−Ts/τ}, Γ = b τ (1 − e^{−Ts/τ}).
        let (tau, b, ts) = (24.0, 0.07, 1.0);
        let (phi, gamma) = discretize(
            &DMatrix::from_element(1, 1, -1.0 / tau),
            &DMatrix::from_element(1, 1, b),
            ts,
        );
        assert!((phi[(0, 0)] - (-ts / tau).exp()).abs() < 1e-16);
        assert!((gamma[(0, 0)] - b * tau * (1.0 - (-ts / tau).exp())).abs() < 1e-16);
    }
}
