//! The start of a hidden-state model: PO-MOESP (Verhaegen 1994; the family of SITB's
//! `n4sid`), on instants whose windows are complete.
//!
//! With i block rows, each window of 2i instants starting at t gives one column of the
//! block Hankel matrices of past inputs U_p, past outputs Y_p, future inputs U_f and
//! future outputs Y_f, e.g. U_p = [u(t); …; u(t+i−1)]. The LQ factorisation
//!
//!   [U_f; U_p; Y_p; Y_f] = L Qᵀ
//!
//! projects the future outputs orthogonally off the future inputs; its block L₃₂ is
//! Γ_i times the states as the past instruments (U_p, Y_p) see them, so that its SVD
//! L₃₂ = U S Vᵀ gives the extended observability matrix Γ_i = U₁ S₁^½ of order n (the
//! singular values S say which n the data support). Then C is Γ_i's first block row and
//! Φ the least-squares solution of the shift invariance Γ_i↑ Φ = Γ_i↓ (Γ_i less its last,
//! resp. first, block row). Given Φ and C the outputs are linear in Γ, D and each
//! segment's x0: y(k) = C Φ^(k−s) x0 + Σ_{l<k} C Φ^(k−1−l) Γ u(l) + D u(k), solved by
//! least squares over every observed output.
//!
//! A window is used only where every input and output in it is known: the columns of
//! the Hankel matrices are samples of the same linear relation, so leaving some out
//! keeps the others valid. Each channel is scaled to unit RMS for the factorisations
//! (a furnace's pre-scaled signals and a generator's pu need no care of their own).

use nalgebra::{DMatrix, DVector, SymmetricEigen};

use super::{least_squares, HiddenError, HiddenStateModel, OutputMatrix};
use crate::estimate::IdentificationData;

/// The subspace step's result: the singular values of L₃₂ and the block rows used.
#[derive(Debug, Clone)]
pub struct Subspace {
    /// The observability directions U of L₃₂ (i·p × i·p), columns by falling singular value.
    directions: DMatrix<f64>,
    /// Singular values of L₃₂, descending: the energy each state direction carries.
    pub singular_values: Vec<f64>,
    /// Block rows i.
    pub horizon: usize,
    /// Output scales (RMS) the factorisation used.
    y_scale: Vec<f64>,
}

/// Block rows for models up to `largest` states with p outputs: enough that i·p > n,
/// and at least 10 (each block row averages the noise over more past instants).
pub fn horizon_for(largest: usize, outputs: usize) -> usize {
    (largest / outputs.max(1) + 1).max(10)
}

/// Root-mean-square of each column over the rows where every entry is finite and,
/// for outputs, observed; 1 where that is zero.
fn column_rms(values: &DMatrix<f64>, used: impl Fn(usize, usize) -> bool) -> Vec<f64> {
    (0..values.ncols())
        .map(|j| {
            let (mut s, mut c) = (0.0, 0usize);
            for k in 0..values.nrows() {
                if used(k, j) && values[(k, j)].is_finite() {
                    s += values[(k, j)] * values[(k, j)];
                    c += 1;
                }
            }
            let rms = (s / c.max(1) as f64).sqrt();
            if rms > 0.0 {
                rms
            } else {
                1.0
            }
        })
        .collect()
}

/// The outputs with each unobserved entry inside a segment interpolated linearly between
/// its observed neighbours (NaN before the first and after the last): for the start
/// only, whose windows would otherwise need every output at every instant (a value
/// stored by exception, a lost sample). The refinement compares observed entries only.
fn interpolated_outputs(data: &IdentificationData) -> DMatrix<f64> {
    let mut y = DMatrix::from_element(data.len(), data.states(), f64::NAN);
    for seg in data.segments() {
        for j in 0..data.states() {
            let known: Vec<usize> = seg
                .clone()
                .filter(|&k| data.observed(k, j) && data.outputs[(k, j)].is_finite())
                .collect();
            for pair in known.windows(2) {
                let (a, b) = (pair[0], pair[1]);
                let (ya, yb) = (data.outputs[(a, j)], data.outputs[(b, j)]);
                for k in a..=b {
                    y[(k, j)] = ya + (yb - ya) * (k - a) as f64 / (b - a) as f64;
                }
            }
            if let [only] = known.as_slice() {
                y[(*only, j)] = data.outputs[(*only, j)];
            }
        }
    }
    y
}

/// Whether instant k's inputs and (interpolated) outputs are all finite.
fn complete(data: &IdentificationData, outputs: &DMatrix<f64>, k: usize) -> bool {
    (0..data.input_count()).all(|l| data.inputs[(k, l)].is_finite())
        && outputs.row(k).iter().all(|v| v.is_finite())
}

/// The first window instants t of complete windows of 2i instants inside one segment.
fn window_starts(data: &IdentificationData, outputs: &DMatrix<f64>, horizon: usize) -> Vec<usize> {
    let span = 2 * horizon;
    let mut starts = Vec::new();
    for seg in data.segments() {
        let ok: Vec<bool> = seg.clone().map(|k| complete(data, outputs, k)).collect();
        let mut run = 0usize;
        for (r, &good) in ok.iter().enumerate() {
            run = if good { run + 1 } else { 0 };
            if run >= span {
                starts.push(seg.start + r + 1 - span);
            }
        }
    }
    starts
}

/// The LQ factorisation's L₃₂ and the SVD of it: the state directions of the data.
pub fn decompose(data: &IdentificationData, horizon: usize) -> Result<Subspace, HiddenError> {
    let (p, m, i) = (data.states(), data.input_count(), horizon);
    let outputs = interpolated_outputs(data);
    let starts = window_starts(data, &outputs, i);
    let rows = 2 * i * (m + p);
    // At least as many windows as rows, so that L is square and the projection has
    // as many samples as instruments.
    if starts.len() < rows {
        return Err(HiddenError::TooFewWindows {
            windows: starts.len(),
            horizon: 2 * i,
            needed: rows,
        });
    }
    let u_scale = column_rms(&data.inputs, |_, _| true);
    let y_scale = column_rms(&outputs, |_, _| true);
    let u = |k: usize, l: usize| data.inputs[(k, l)] / u_scale[l];
    let y = |k: usize, j: usize| outputs[(k, j)] / y_scale[j];
    // Hᵀ, one row per window: [U_f, U_p, Y_p, Y_f] (the LQ of H is the QR of Hᵀ).
    let ht = DMatrix::from_fn(starts.len(), rows, |w, c| {
        let t = starts[w];
        let (mi, pi) = (m * i, p * i);
        if c < mi {
            u(t + i + c / m, c % m)
        } else if c < 2 * mi {
            u(t + (c - mi) / m, (c - mi) % m)
        } else if c < 2 * mi + pi {
            y(t + (c - 2 * mi) / p, (c - 2 * mi) % p)
        } else {
            y(t + i + (c - 2 * mi - pi) / p, (c - 2 * mi - pi) % p)
        }
    });
    let l = ht.qr().r().transpose();
    let (r1, r2) = (m * i, m * i + p * i);
    let l32 = l.view((r1 + r2, r1), (p * i, r2)).into_owned();
    let svd = l32.svd(true, false);
    let u_mat = svd.u.ok_or(HiddenError::Singular {
        what: "SVD of L₃₂"
    })?;
    let mut order: Vec<usize> = (0..svd.singular_values.len()).collect();
    order.sort_by(|&a, &b| svd.singular_values[b].total_cmp(&svd.singular_values[a]));
    let directions = DMatrix::from_fn(u_mat.nrows(), order.len(), |r, c| {
        u_mat[(r, order[c])] * svd.singular_values[order[c]].sqrt()
    });
    Ok(Subspace {
        directions,
        singular_values: order.iter().map(|&c| svd.singular_values[c]).collect(),
        horizon: i,
        y_scale,
    })
}

impl Subspace {
    /// The largest order these block rows can give: (i − 1)·p (the shift invariance
    /// needs one block row to spare).
    pub fn largest_order(&self) -> usize {
        self.directions.nrows() - self.directions.nrows() / self.horizon
    }

    /// The model of order n: Φ and C from Γ_i, then Γ, D (where `feedthrough`) and x0
    /// by least squares on `data`, in the basis `output_matrix` asks for.
    pub fn model(
        &self,
        data: &IdentificationData,
        order: usize,
        feedthrough: bool,
        output_matrix: OutputMatrix,
    ) -> Result<HiddenStateModel, HiddenError> {
        let p = data.states();
        if order == 0 || order > self.largest_order() {
            return Err(HiddenError::Order {
                order,
                largest: self.largest_order(),
            });
        }
        let obs = self.directions.columns(0, order);
        let rows = obs.nrows();
        let upper = obs.rows(0, rows - p).into_owned();
        let lower = obs.rows(p, rows - p).into_owned();
        let pinv = upper
            .pseudo_inverse(1e-12)
            .map_err(|_| HiddenError::Singular {
                what: "shift invariance",
            })?;
        let longest = data.segments().iter().map(|s| s.len()).max().unwrap_or(1);
        let phi = stabilised(pinv * lower, radius_limit(longest));
        // C in data units: the factorisation saw y/σ_y.
        let c = DMatrix::from_fn(p, order, |j, s| obs[(j, s)] * self.y_scale[j]);
        let model = fit_input_matrices(data, phi, c, feedthrough)?;
        match output_matrix {
            OutputMatrix::Free => Ok(model),
            OutputMatrix::Measured => measured_basis(model),
        }
    }
}

/// How far inside a radius limit a pulled-in start is put: ρ = limit · (1 − 10⁻³).
const START_MARGIN: f64 = 1e-3;

/// The largest pole modulus a model identified on segments of at most `longest`
/// instants may have: ρ_max = exp(−1/N), a time constant no longer than the record
/// (τ = −Ts / ln ρ ≤ N·Ts). A slower mode is a drift the record cannot tell from an
/// integrator or an offset: output error on a short record otherwise ends at ρ → 1 (the
/// glass furnace and TCLab at τ ≈ 10⁹ s), with a meaningless steady-state gain.
pub fn radius_limit(longest: usize) -> f64 {
    (-1.0 / longest.max(1) as f64).exp()
}

/// Φ pulled inside the circle of radius `limit` where the shift invariance left it on
/// or outside (noise, or a drift the data cannot tell from an integrator): Φ' = Φ · r/ρ(Φ)
/// with r = limit · (1 − 10⁻³), which scales every pole by the same factor and keeps the
/// eigenvectors, as SITB's `n4sid` enforces stability of its estimate. Φ inside is
/// returned unchanged. Γ, D and x0 are then fitted to the data given Φ'.
pub fn stabilised(phi: DMatrix<f64>, limit: f64) -> DMatrix<f64> {
    let radius = crate::thermal::matrix::spectral_radius(&phi);
    if radius.is_finite() && radius >= limit {
        phi * (limit * (1.0 - START_MARGIN) / radius)
    } else {
        phi
    }
}

/// Γ and D (zero unless `feedthrough`) by least squares given Φ and C: each output's
/// response to each entry of Γ, D and each segment's x0 is simulated, and the observed
/// outputs regressed on them.
fn fit_input_matrices(
    data: &IdentificationData,
    phi: DMatrix<f64>,
    c: DMatrix<f64>,
    feedthrough: bool,
) -> Result<HiddenStateModel, HiddenError> {
    let (p, n, m) = (c.nrows(), phi.nrows(), data.input_count());
    let segments = data.segments();
    let n_d = if feedthrough { p * m } else { 0 };
    let cols = n * m + n_d + n * segments.len();
    let mut regressors: Vec<f64> = Vec::new();
    let mut targets = Vec::new();
    for (s, seg) in segments.iter().enumerate() {
        // x-responses: one n-vector per column of Γ's entries and of x0.
        let mut xb = DMatrix::<f64>::zeros(n, n * m);
        let mut x0 = DMatrix::<f64>::identity(n, n);
        for k in seg.clone() {
            let u: Vec<f64> = (0..m).map(|l| data.inputs[(k, l)]).collect();
            for j in 0..p {
                if data.observed(k, j) && data.outputs[(k, j)].is_finite() {
                    let mut row = vec![0.0; cols];
                    let cb = c.row(j) * &xb;
                    row[..n * m].copy_from_slice(cb.as_slice());
                    if feedthrough {
                        row[n * m + j * m..n * m + (j + 1) * m].copy_from_slice(&u);
                    }
                    let cx = c.row(j) * &x0;
                    let at = n * m + n_d + s * n;
                    row[at..at + n].copy_from_slice(cx.as_slice());
                    regressors.extend(row);
                    targets.push(data.outputs[(k, j)]);
                }
            }
            xb = &phi * xb;
            x0 = &phi * x0;
            // Γ's entry (a, l), column a·m + l, adds e_a u_l(k).
            for a in 0..n {
                for (l, ul) in u.iter().enumerate() {
                    xb[(a, a * m + l)] += ul;
                }
            }
        }
    }
    let a = DMatrix::from_row_slice(targets.len(), cols, &regressors);
    let theta = least_squares(&a, &DVector::from_vec(targets)).ok_or(HiddenError::Singular {
        what: "least squares for Γ, D",
    })?;
    let gamma = DMatrix::from_fn(n, m, |r, l| theta[r * m + l]);
    let d = if feedthrough {
        DMatrix::from_fn(p, m, |j, l| theta[n * m + j * m + l])
    } else {
        DMatrix::zeros(p, m)
    };
    Ok(HiddenStateModel {
        phi,
        gamma,
        c,
        d,
        ts_s: data.ts_s,
    })
}

/// The same model in the basis where sensor i reads state i (C = [I_p 0]): x' = T x with
/// T = [C; N], N spanning the null space of C (so T is invertible when C has full row
/// rank); Φ' = T Φ T⁻¹, Γ' = T Γ, C' = C T⁻¹ = [I 0].
pub fn measured_basis(model: HiddenStateModel) -> Result<HiddenStateModel, HiddenError> {
    let (p, n) = model.c.shape();
    if p > n {
        return Err(HiddenError::FewerStatesThanOutputs {
            outputs: p,
            order: n,
        });
    }
    let eig = SymmetricEigen::new(model.c.transpose() * &model.c);
    let mut idx: Vec<usize> = (0..n).collect();
    idx.sort_by(|&a, &b| eig.eigenvalues[a].total_cmp(&eig.eigenvalues[b]));
    let mut t = DMatrix::zeros(n, n);
    t.rows_mut(0, p).copy_from(&model.c);
    for (r, &col) in idx.iter().take(n - p).enumerate() {
        t.row_mut(p + r)
            .copy_from(&eig.eigenvectors.column(col).transpose());
    }
    let t_inv = t.clone().try_inverse().ok_or(HiddenError::Singular {
        what: "output matrix C",
    })?;
    let mut c = DMatrix::zeros(p, n);
    c.view_mut((0, 0), (p, p)).fill_with_identity();
    Ok(HiddenStateModel {
        phi: &t * &model.phi * t_inv,
        gamma: &t * &model.gamma,
        c,
        d: model.d,
        ts_s: model.ts_s,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::hidden::testing::{known_system, simulate_known};

    #[test]
    fn noise_free_data_give_the_true_order_and_poles() {
        let truth = known_system();
        let data = simulate_known(&truth, 1500, 0.0, 1);
        let sub = decompose(&data, horizon_for(6, 2)).unwrap();
        // Three states: the fourth singular value is rounding, far below the third.
        let s = &sub.singular_values;
        assert!(s[3] < 1e-8 * s[2], "singular values {s:?}");
        let model = sub.model(&data, 3, false, OutputMatrix::Free).unwrap();
        let (mut got, mut want) = (
            model.time_constants_s().unwrap(),
            truth.time_constants_s().unwrap(),
        );
        got.sort_by(f64::total_cmp);
        want.sort_by(f64::total_cmp);
        for (g, w) in got.iter().zip(&want) {
            assert!((g / w - 1.0).abs() < 1e-6, "{got:?} vs {want:?}");
        }
        let (g, w) = (
            model.steady_state_gain().unwrap(),
            truth.steady_state_gain().unwrap(),
        );
        assert!((g - &w).abs().max() < 1e-6 * w.abs().max());
    }

    #[test]
    fn the_measured_basis_reads_the_sensors_and_keeps_the_response() {
        let truth = known_system();
        let data = simulate_known(&truth, 1500, 0.0, 1);
        let sub = decompose(&data, horizon_for(6, 2)).unwrap();
        let model = sub.model(&data, 3, false, OutputMatrix::Measured).unwrap();
        let mut c = DMatrix::zeros(2, 3);
        c.view_mut((0, 0), (2, 2)).fill_with_identity();
        assert!((&model.c - c).abs().max() < 1e-12);
        let (g, w) = (
            model.steady_state_gain().unwrap(),
            truth.steady_state_gain().unwrap(),
        );
        assert!((g - &w).abs().max() < 1e-6 * w.abs().max());
    }

    #[test]
    fn an_order_beyond_the_block_rows_is_refused() {
        let truth = known_system();
        let data = simulate_known(&truth, 1500, 0.0, 1);
        let sub = decompose(&data, 10).unwrap();
        assert_eq!(
            sub.model(&data, 19, false, OutputMatrix::Free),
            Err(HiddenError::Order {
                order: 19,
                largest: 18
            })
        );
    }
}
