//! Output sensitivities to the time constants and the assignment of each time
//! constant to a physical part (eqs. 10–12).
//!
//! With A_c = V diag(−1/T_i) V⁻¹ and B_c held fixed, the discrete model is
//! Φ(T) = V diag(μ_i) V⁻¹, μ_i = e^{−Ts/T_i}, and Γ(T) = V diag(g_i) V⁻¹ B_c,
//! g_i = T_i (1 − μ_i). The sensitivity s_i(k) = ∂ŷ(k)/∂T_i obeys the forward
//! recursion s_i(k) = Φ s_i(k−1) + ∂Φ/∂T_i ŷ(k−1) + ∂Γ/∂T_i u(k−1), s_i(start) = 0,
//! with ∂μ_i/∂T_i = (Ts/T_i²) μ_i and ∂g_i/∂T_i = 1 − μ_i − (Ts/T_i) μ_i.
//! Each is reported relative, T_i ∂ŷ/∂T_i (pu of output per pu of T_i).

use std::ops::Range;

use nalgebra::{DMatrix, DVector};
use serde::Serialize;

use super::continuous::ContinuousModel;
use super::matrix::eigenvector;
use super::ModelError;
use crate::estimate::{DiscreteModel, IdentificationData};

type Result<T, E = ModelError> = std::result::Result<T, E>;

/// The norms of the relative sensitivity responses T_i ∂y_k/∂T_i.
///
/// The responses themselves are not kept (a week at Ts = 1 s would be n² series of
/// 604,800 instants); [`SensitivityModel::for_each_response`] regenerates them.
#[derive(Debug, Clone, Serialize)]
pub struct Sensitivities {
    /// Time constants T_i, ascending, in s.
    pub time_constants_s: Vec<f64>,
    /// `norms[k][i]`: RMS over the simulated instants of T_i ∂y_k/∂T_i, in pu (the L2
    /// norm of eq. 11 divided by √N, so that it does not grow with the length).
    pub norms: Vec<Vec<f64>>,
}

/// One time constant's assignment to a state.
#[derive(Debug, Clone, Serialize)]
pub struct Assignment {
    /// The time constant, s.
    pub time_constant_s: f64,
    /// Index of the state it predominantly belongs to.
    pub state: usize,
    /// The sensitivity norm of that state to it.
    pub sensitivity_norm: f64,
    /// Whether this differs from the plain largest-norm rule (a conflict was resolved).
    pub resolved_conflict: bool,
}

/// The model in modal form, Φ(T) = V diag(μ_i) V⁻¹ and Γ(T) = V diag(g_i) V⁻¹ B_c, with
/// the derivatives ∂Φ/∂T_i and ∂Γ/∂T_i the sensitivity recursion needs.
#[derive(Debug, Clone)]
pub struct SensitivityModel {
    time_constants_s: Vec<f64>,
    /// Φ(T) and Γ(T) at the time constants.
    discrete: DiscreteModel,
    d_phi: Vec<DMatrix<f64>>,
    d_gamma: Vec<DMatrix<f64>>,
}

impl SensitivityModel {
    /// The modal form of (A_c, B_c) with A_c's time constants `time_constants_s`
    /// (ascending, s), discretised with sample time `ts_s`.
    pub fn new(
        model: &ContinuousModel,
        time_constants_s: &[f64],
        ts_s: f64,
    ) -> Result<SensitivityModel> {
        let n = model.a_c.nrows();
        // Eigenvectors of A_c for λ_i = −1/T_i, in ascending T order.
        let mut v = DMatrix::zeros(n, n);
        for (i, t) in time_constants_s.iter().enumerate() {
            v.set_column(i, &eigenvector(&model.a_c, -1.0 / t));
        }
        let v_inv = v
            .clone()
            .try_inverse()
            .ok_or(ModelError::NotDiagonalisable)?;
        let mu: Vec<f64> = time_constants_s.iter().map(|t| (-ts_s / t).exp()).collect();
        let g: Vec<f64> = time_constants_s
            .iter()
            .zip(&mu)
            .map(|(t, m)| t * (1.0 - m))
            .collect();
        let modal =
            |d: &[f64]| &v * DMatrix::from_diagonal(&DVector::from_column_slice(d)) * &v_inv;
        let mut d_phi = Vec::with_capacity(n);
        let mut d_gamma = Vec::with_capacity(n);
        for (i, t) in time_constants_s.iter().enumerate() {
            let mut d_mu = vec![0.0; n];
            let mut d_g = vec![0.0; n];
            d_mu[i] = ts_s / (t * t) * mu[i];
            d_g[i] = 1.0 - mu[i] - ts_s / t * mu[i];
            d_phi.push(modal(&d_mu));
            d_gamma.push(modal(&d_g) * &model.b_c);
        }
        Ok(SensitivityModel {
            time_constants_s: time_constants_s.to_vec(),
            discrete: DiscreteModel {
                phi: modal(&mu),
                gamma: modal(&g) * &model.b_c,
                ts_s,
            },
            d_phi,
            d_gamma,
        })
    }

    /// Calls `visit(k, T_i ∂ŷ(k)/∂T_i)` for every instant k of every segment, in
    /// order: s_i(k) = Φ s_i(k−1) + ∂Φ/∂T_i ŷ(k−1) + ∂Γ/∂T_i u(k−1), s_i(start) = 0,
    /// with ŷ simulated from [`DiscreteModel::initial_state`] (the measured start where known).
    pub fn for_each_response(
        &self,
        i: usize,
        data: &IdentificationData,
        segments: &[Range<usize>],
        mut visit: impl FnMut(usize, &DVector<f64>),
    ) {
        let (n, m) = (self.discrete.phi.nrows(), self.discrete.gamma.ncols());
        let t = self.time_constants_s[i];
        let (d_phi, d_gamma) = (&self.d_phi[i], &self.d_gamma[i]);
        // Buffers reused across instants: no allocation per step.
        let mut y = DVector::zeros(n);
        let mut s = DVector::zeros(n);
        let mut u = DVector::zeros(m);
        let mut rel = DVector::zeros(n);
        let (phi, gamma) = (&self.discrete.phi, &self.discrete.gamma);
        for seg in segments {
            y.copy_from(&self.discrete.initial_state(data, seg.clone()));
            s.fill(0.0);
            rel.fill(0.0);
            visit(seg.start, &rel);
            for k in seg.start + 1..seg.end {
                for j in 0..m {
                    u[j] = data.inputs[(k - 1, j)];
                }
                // s ← Φ s + ∂Φ/∂T_i y + ∂Γ/∂T_i u, then y ← Φ y + Γ u (old y in both).
                rel.copy_from(&s);
                s.gemv(1.0, phi, &rel, 0.0);
                s.gemv(1.0, d_phi, &y, 1.0);
                s.gemv(1.0, d_gamma, &u, 1.0);
                rel.copy_from(&y);
                y.gemv(1.0, phi, &rel, 0.0);
                y.gemv(1.0, gamma, &u, 1.0);
                rel.copy_from(&s);
                rel *= t;
                visit(k, &rel);
            }
        }
    }
}

/// Computes the sensitivity norms over the simulation segments of `data`.
pub fn sensitivities(
    model: &ContinuousModel,
    time_constants_s: &[f64],
    ts_s: f64,
    data: &IdentificationData,
    segments: &[Range<usize>],
) -> Result<Sensitivities> {
    let n = model.a_c.nrows();
    let recursion = SensitivityModel::new(model, time_constants_s, ts_s)?;
    let simulated: usize = segments.iter().map(|s| s.len()).sum();
    let mut norms = vec![vec![0.0; n]; n];
    for i in 0..n {
        let mut sum_sq = vec![0.0; n];
        recursion.for_each_response(i, data, segments, |_, rel| {
            for (kk, acc) in sum_sq.iter_mut().enumerate() {
                *acc += rel[kk] * rel[kk];
            }
        });
        for (row, sum) in norms.iter_mut().zip(&sum_sq) {
            row[i] = (sum / simulated.max(1) as f64).sqrt();
        }
    }
    Ok(Sensitivities {
        time_constants_s: time_constants_s.to_vec(),
        norms,
    })
}

/// Assigns each time constant T_i to the state whose response it changes most,
/// max_k ‖T_i ∂y_k/∂T_i‖ (eq. 11). When two time constants would claim one state,
/// the one-to-one assignment is chosen that maximises Σ_i log(share of T_i's
/// influence on its state); it equals the plain rule whenever that is one-to-one.
pub fn assign(s: &Sensitivities) -> Vec<Assignment> {
    let n = s.time_constants_s.len();
    let plain: Vec<usize> = (0..n)
        .map(|i| {
            (0..n)
                .max_by(|&a, &b| s.norms[a][i].total_cmp(&s.norms[b][i]))
                .unwrap_or(0)
        })
        .collect();
    let share = |k: usize, i: usize| {
        let total: f64 = (0..n).map(|kk| s.norms[kk][i]).sum();
        (s.norms[k][i] / total.max(1e-300)).max(1e-300).ln()
    };
    let mut best: Vec<usize> = plain.clone();
    let mut distinct = plain.clone();
    distinct.sort_unstable();
    distinct.dedup();
    if distinct.len() != n && n <= 8 {
        let mut perm: Vec<usize> = (0..n).collect();
        let mut best_score = f64::NEG_INFINITY;
        permutations(&mut perm, 0, &mut |p| {
            let score: f64 = (0..n).map(|i| share(p[i], i)).sum();
            if score > best_score {
                best_score = score;
                best = p.to_vec();
            }
        });
    }
    (0..n)
        .map(|i| Assignment {
            time_constant_s: s.time_constants_s[i],
            state: best[i],
            sensitivity_norm: s.norms[best[i]][i],
            resolved_conflict: best[i] != plain[i],
        })
        .collect()
}

fn permutations(p: &mut Vec<usize>, k: usize, f: &mut impl FnMut(&[usize])) {
    if k == p.len() {
        f(p);
        return;
    }
    for i in k..p.len() {
        p.swap(k, i);
        permutations(p, k + 1, f);
        p.swap(k, i);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn first_order_sensitivity_matches_closed_form() {
        // dy/dt = −y/T + b u, y(0) = 0, u = 1: y = bT(1 − e^{−t/T});
        // ∂y/∂T = b[(1 − e^{−t/T}) − (t/T) e^{−t/T}]. The ZOH-discrete model reproduces y exactly
        // at the instants, so the recursion must match the closed form to rounding.
        let (t_c, b, ts, n) = (50.0_f64, 0.02, 1.0, 400);
        let model = ContinuousModel {
            a_c: DMatrix::from_element(1, 1, -1.0 / t_c),
            b_c: DMatrix::from_element(1, 1, b),
        };
        let data = IdentificationData::complete(
            ts,
            DMatrix::zeros(n, 1),
            DMatrix::from_element(n, 1, 1.0),
        );
        let closed_form = |k: usize| {
            let t = k as f64 * ts;
            let e = (-t / t_c).exp();
            t_c * b * ((1.0 - e) - t / t_c * e)
        };
        let recursion = SensitivityModel::new(&model, &[t_c], ts).unwrap();
        let mut visited = 0;
        let whole: Vec<Range<usize>> = std::iter::once(0..n).collect();
        recursion.for_each_response(0, &data, &whole, |k, rel| {
            assert_eq!(k, visited);
            let expect = closed_form(k);
            assert!(
                (rel[0] - expect).abs() < 1e-12,
                "k={k}: {} vs {expect}",
                rel[0]
            );
            visited += 1;
        });
        assert_eq!(visited, n);
        // The norm is the RMS of the response over the simulated instants.
        let rms = ((0..n).map(|k| closed_form(k).powi(2)).sum::<f64>() / n as f64).sqrt();
        let s = sensitivities(&model, &[t_c], ts, &data, &whole).unwrap();
        assert!((s.norms[0][0] - rms).abs() < 1e-12 * rms);
    }

    #[test]
    fn assignment_resolves_a_conflict_one_to_one() {
        let s = Sensitivities {
            time_constants_s: vec![1.0, 2.0],
            norms: vec![vec![0.9, 0.6], vec![0.1, 0.4]],
        };
        let a = assign(&s);
        assert_eq!(a[0].state, 0);
        assert_eq!(a[1].state, 1);
        assert!(a[1].resolved_conflict && !a[0].resolved_conflict);
    }
}
