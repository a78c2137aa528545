//! Output sensitivities to the time constants and the assignment of each time
//! constant to a physical part (eqs. 10–12).
//!
//! With A_c = V diag(−1/T_i) V⁻¹ and B_c held fixed, the discrete model is
//! Φ(T) = V diag(μ_i) V⁻¹, μ_i = e^{−Ts/T_i}, and Γ(T) = V diag(g_i) V⁻¹ B_c,
//! g_i = T_i (1 − μ_i). The sensitivity s_i(k) = ∂ŷ(k)/∂T_i obeys the forward
//! recursion s_i(k) = Φ s_i(k−1) + ∂Φ/∂T_i ŷ(k−1) + ∂Γ/∂T_i u(k−1), s_i(start) = 0,
//! with ∂μ_i/∂T_i = (Ts/T_i²) μ_i and ∂g_i/∂T_i = 1 − μ_i − (Ts/T_i) μ_i.
//! Each is reported relative, T_i ∂ŷ/∂T_i (pu of output per pu of T_i).
//!
//! A complex-conjugate pair λ = −1/T ± iω (an oscillating mode) is one mode: its decay
//! constant T is perturbed with the frequency held, both entries together, and the
//! pair is assigned to its two most sensitive states ([`SensitivityModel`] has the
//! complex μ and g).

use std::ops::Range;

use nalgebra::{Complex, DMatrix, DVector};
use serde::Serialize;

use crate::estimate::{DiscreteModel, IdentificationData};
use crate::thermal::matrix::{complex_eigenvector, eigenvalues, eigenvector};
use crate::thermal::{ContinuousModel, ModelError};

type Result<T, E = ModelError> = std::result::Result<T, E>;

/// The norms of the relative sensitivity responses T_i ∂y_k/∂T_i, and the responses.
#[derive(Debug, Clone, Serialize)]
pub struct Sensitivities {
    /// Time constants T_i, ascending, in s (a complex pair's decay constant twice).
    pub time_constants_s: Vec<f64>,
    /// `norms[k][i]`: RMS over the simulated instants of T_i ∂y_k/∂T_i, in pu (the L2
    /// norm of eq. 11 divided by √N, so that it does not grow with the length). The two
    /// entries of a complex pair share one response (the pair's decay perturbed together).
    pub norms: Vec<Vec<f64>>,
    /// The oscillation period of each complex mode, s; `None` for a real one.
    pub oscillation_periods_s: Vec<Option<f64>>,
    /// For each entry of a complex pair, the index of its conjugate partner.
    #[serde(skip)]
    pub partners: Vec<Option<usize>>,
    /// The responses the norms are taken of, for the plots (rerun's and the HTML
    /// report's): their recursion, run again on the data for each.
    #[serde(skip)]
    pub responses: SensitivityResponses,
}

/// The relative sensitivity responses T_i ∂ŷ(k)/∂T_i over the simulated instants, for
/// the plots (rerun's and the HTML report's): the recursion the norms were taken with
/// ([`sensitivities`]), run again on the replay's data for each plot.
///
/// Kept as values they were n² series of the analysed length, 8 bytes a value: 43.5 MB
/// of a week at 1 s, the largest part of that replay's peak (211 MB of heap, over the
/// 200 MB of issue 33's bar). Running the recursion again costs n² + n·m products an
/// instant for each response drawn.
#[derive(Debug, Clone, Default)]
pub struct SensitivityResponses {
    /// The instants, in order: the simulation segments, as instants of the replay's data.
    segments: Vec<Range<usize>>,
    /// The recursion (`None` before [`sensitivities`] made one).
    recursion: Option<SensitivityModel>,
}

impl SensitivityResponses {
    /// The instants the responses cover: runs of the data, in order.
    pub fn segments(&self) -> &[Range<usize>] {
        &self.segments
    }

    /// Calls `visit(k, T_i ∂ŷ(k)/∂T_i)` (n values, one per state) for every instant k
    /// of [`Self::segments`], in order, with ŷ and the inputs read from `data` (the data
    /// the analysis was made on, whose instants the segments name); nothing for a time
    /// constant out of range. A complex pair's second entry gives its first's response
    /// (one decay parameter).
    pub fn for_each(
        &self,
        i: usize,
        data: &IdentificationData,
        mut visit: impl FnMut(usize, &[f64]),
    ) {
        let Some(recursion) = &self.recursion else {
            return;
        };
        if i >= recursion.time_constants_s.len() {
            return;
        }
        let i = recursion.earlier_partner(i).unwrap_or(i);
        recursion.for_each_response(i, data, &self.segments, |k, rel| visit(k, rel.as_slice()));
    }

    /// Moves the instants `by` later: the data they were computed on start at instant
    /// `by` of the recording.
    pub(crate) fn shift(&mut self, by: usize) {
        for s in &mut self.segments {
            *s = s.start + by..s.end + by;
        }
    }
}

/// One time constant's assignment to a state.
#[derive(Debug, Clone, Serialize)]
pub struct Assignment {
    /// The time constant, s.
    pub time_constant_s: f64,
    /// The oscillation period of a complex mode, s (`None` for a real one).
    pub oscillation_period_s: Option<f64>,
    /// Index of the state it predominantly belongs to.
    pub state: usize,
    /// The sensitivity norm of that state to it.
    pub sensitivity_norm: f64,
    /// Whether this differs from the plain largest-norm rule (a conflict was resolved).
    pub resolved_conflict: bool,
}

/// The model in modal form, Φ(T) = V diag(μ_i) V⁻¹ and Γ(T) = V diag(g_i) V⁻¹ B_c, with
/// the derivatives ∂Φ/∂T_i and ∂Γ/∂T_i the sensitivity recursion needs.
///
/// A mode is λ_i = −1/T_i + iω_i (ω_i = 0 for a real one): μ_i = e^{λ_i Ts},
/// g_i = (μ_i − 1)/λ_i (= T_i (1 − μ_i) when real), and with ∂λ_i/∂T_i = 1/T_i² (the
/// frequency held), ∂μ_i/∂T_i = (Ts/T_i²) μ_i and
/// ∂g_i/∂T_i = (Ts μ_i λ_i − (μ_i − 1))/(λ_i² T_i²). A complex pair's decay is one
/// parameter: its derivative moves both conjugate entries, so the matrices stay real.
#[derive(Debug, Clone)]
pub struct SensitivityModel {
    time_constants_s: Vec<f64>,
    /// The oscillation period of each mode (`None` where real).
    periods_s: Vec<Option<f64>>,
    /// The conjugate partner of each entry of a complex pair.
    partners: Vec<Option<usize>>,
    /// Φ(T) and Γ(T) at the time constants.
    discrete: DiscreteModel,
    d_phi: Vec<DMatrix<f64>>,
    d_gamma: Vec<DMatrix<f64>>,
}

/// The modes of A_c in the order of its time constants `time_constants_s` (ascending):
/// λ_i = −1/T_i + iω_i, with ω_i read from A_c's eigenvalues (ascending real part,
/// a pair's positive imaginary part first), and each pair entry's partner.
fn modes(a_c: &DMatrix<f64>, time_constants_s: &[f64]) -> Result<Modes> {
    let mut eig = eigenvalues(a_c, "A_c")?;
    // Ascending real part (ascending T); a pair's conjugates adjacent, +i first.
    eig.sort_by(|a, b| {
        a.re.total_cmp(&b.re)
            .then(b.im.abs().total_cmp(&a.im.abs()))
            .then(b.im.total_cmp(&a.im))
    });
    let mut lambda = Vec::with_capacity(eig.len());
    let mut partners = vec![None; eig.len()];
    for (i, (z, t)) in eig.iter().zip(time_constants_s).enumerate() {
        lambda.push(Complex::new(-1.0 / t, z.im));
        if z.im > 0.0 && i + 1 < eig.len() {
            partners[i] = Some(i + 1);
            partners[i + 1] = Some(i);
        }
    }
    Ok((lambda, partners))
}

/// The modes' eigenvalues and the conjugate partner of each pair entry.
type Modes = (Vec<Complex<f64>>, Vec<Option<usize>>);

impl SensitivityModel {
    /// The modal form of (A_c, B_c) with A_c's time constants `time_constants_s`
    /// (ascending, s; a complex pair's decay constant twice), discretised with sample
    /// time `ts_s`.
    pub fn new(
        model: &ContinuousModel,
        time_constants_s: &[f64],
        ts_s: f64,
    ) -> Result<SensitivityModel> {
        let n = model.a_c.nrows();
        let (lambda, partners) = modes(&model.a_c, time_constants_s)?;
        // Eigenvectors of A_c, one per mode; a pair's second is the conjugate of its
        // first, so V diag(d) V⁻¹ is real for conjugate-symmetric d.
        let mut v = DMatrix::<Complex<f64>>::zeros(n, n);
        for i in 0..n {
            let column = match partners[i] {
                Some(p) if p < i => v.column(p).map(|z| z.conj()),
                Some(_) => complex_eigenvector(&model.a_c, lambda[i]),
                None => eigenvector(&model.a_c, lambda[i].re).map(|x| Complex::new(x, 0.0)),
            };
            v.set_column(i, &column);
        }
        let v_inv = v
            .clone()
            .try_inverse()
            .ok_or(ModelError::NotDiagonalisable)?;
        let ts = Complex::new(ts_s, 0.0);
        let mu: Vec<Complex<f64>> = lambda.iter().map(|l| (l * ts).exp()).collect();
        let g: Vec<Complex<f64>> = lambda.iter().zip(&mu).map(|(l, m)| (m - 1.0) / l).collect();
        let modal = |d: &[Complex<f64>]| -> DMatrix<f64> {
            let diag = DMatrix::from_diagonal(&DVector::from_column_slice(d));
            (&v * diag * &v_inv).map(|z| z.re)
        };
        let zero = Complex::new(0.0, 0.0);
        let mut d_phi = Vec::with_capacity(n);
        let mut d_gamma = Vec::with_capacity(n);
        for (i, t) in time_constants_s.iter().enumerate() {
            let mut d_mu = vec![zero; n];
            let mut d_g = vec![zero; n];
            for j in std::iter::once(i).chain(partners[i]) {
                let (l, m) = (lambda[j], mu[j]);
                d_mu[j] = m * ts_s / (t * t);
                d_g[j] = (m * l * ts - (m - 1.0)) / (l * l * t * t);
            }
            d_phi.push(modal(&d_mu));
            d_gamma.push(modal(&d_g) * &model.b_c);
        }
        Ok(SensitivityModel {
            time_constants_s: time_constants_s.to_vec(),
            periods_s: lambda
                .iter()
                .map(|l| (l.im != 0.0).then(|| 2.0 * std::f64::consts::PI / l.im.abs()))
                .collect(),
            partners,
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
        visit: impl FnMut(usize, &DVector<f64>),
    ) {
        let start = |seg: Range<usize>| self.discrete.initial_state(data, seg);
        self.for_each_response_from(i, data, segments, start, visit);
    }

    /// The conjugate partner of entry `i` where it is a complex pair's second entry (its
    /// response is its partner's: one decay parameter).
    pub fn earlier_partner(&self, i: usize) -> Option<usize> {
        self.partners.get(i).copied().flatten().filter(|&p| p < i)
    }

    /// [`Self::for_each_response`] with each segment's initial state given by `start`
    /// (a model with hidden states fits its own: its states are not the data's outputs).
    /// The responses are of the states; the outputs' are C times them.
    pub fn for_each_response_from(
        &self,
        i: usize,
        data: &IdentificationData,
        segments: &[Range<usize>],
        start: impl Fn(Range<usize>) -> DVector<f64>,
        mut visit: impl FnMut(usize, &DVector<f64>),
    ) {
        let n = self.discrete.phi.nrows();
        let mut rel = DVector::zeros(n);
        for seg in segments {
            rel.fill(0.0);
            visit(seg.start, &rel);
            let y0 = start(seg.clone());
            let mut each = |k: usize, relative: &[f64]| {
                rel.as_mut_slice().copy_from_slice(relative);
                visit(k, &rel);
            };
            match n {
                3 => self.respond::<3>(i, data, seg, y0.as_slice(), &mut each),
                4 => self.respond::<4>(i, data, seg, y0.as_slice(), &mut each),
                _ => self.respond_any(i, data, seg, &y0, &mut each),
            }
        }
    }

    /// One segment's responses after its first instant for N states, known when
    /// compiled: the recursion of [`Self::respond_any`] with its sums in registers, each
    /// term added in the order nalgebra's `gemv` adds it (Φ's columns, then ∂Φ/∂T_i's,
    /// then ∂Γ/∂T_i's; Rust fuses no multiply into an add), so every value is the same to
    /// the bit. The analysis and each plot run it once per time constant: with
    /// `gemv`'s general loops it was 6 ms of W0's replay, a fifth of the rerun thread's.
    fn respond<const N: usize>(
        &self,
        i: usize,
        data: &IdentificationData,
        seg: &Range<usize>,
        y0: &[f64],
        visit: &mut impl FnMut(usize, &[f64]),
    ) {
        let m = self.discrete.gamma.ncols();
        let row_major = |a: &DMatrix<f64>| -> Vec<f64> {
            (0..a.nrows())
                .flat_map(|r| (0..a.ncols()).map(move |c| (r, c)))
                .map(|(r, c)| a[(r, c)])
                .collect()
        };
        let (phi, gamma) = (
            row_major(&self.discrete.phi),
            row_major(&self.discrete.gamma),
        );
        let (d_phi, d_gamma) = (row_major(&self.d_phi[i]), row_major(&self.d_gamma[i]));
        let t = self.time_constants_s[i];
        let mut y: [f64; N] = std::array::from_fn(|c| y0[c]);
        let mut s = [0.0; N];
        let mut u = vec![0.0; m];
        for k in seg.start + 1..seg.end {
            for (j, u) in u.iter_mut().enumerate() {
                *u = data.inputs[(k - 1, j)];
            }
            // s ← Φ s + ∂Φ/∂T_i y + ∂Γ/∂T_i u, then y ← Φ y + Γ u (old y in both).
            let s_next: [f64; N] = std::array::from_fn(|c| {
                let acc = row_times(&phi[c * N..][..N], &s);
                let acc = plus_row_times(acc, &d_phi[c * N..][..N], &y);
                plus_row_times(acc, &d_gamma[c * m..][..m], &u)
            });
            let y_next: [f64; N] = std::array::from_fn(|c| {
                let acc = row_times(&phi[c * N..][..N], &y);
                plus_row_times(acc, &gamma[c * m..][..m], &u)
            });
            (s, y) = (s_next, y_next);
            visit(k, &s.map(|v| v * t));
        }
    }

    /// One segment's responses after its first instant, for any number of states.
    fn respond_any(
        &self,
        i: usize,
        data: &IdentificationData,
        seg: &Range<usize>,
        y0: &DVector<f64>,
        visit: &mut impl FnMut(usize, &[f64]),
    ) {
        let (n, m) = (self.discrete.phi.nrows(), self.discrete.gamma.ncols());
        let t = self.time_constants_s[i];
        let (d_phi, d_gamma) = (&self.d_phi[i], &self.d_gamma[i]);
        // Buffers reused across instants: no allocation per step.
        let mut y = y0.clone();
        let mut s = DVector::zeros(n);
        let mut u = DVector::zeros(m);
        let mut rel = DVector::zeros(n);
        let (phi, gamma) = (&self.discrete.phi, &self.discrete.gamma);
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
            visit(k, rel.as_slice());
        }
    }
}

/// Σ_l row_l·x_l, in order from l = 0, as nalgebra's `gemv` with β = 0 sums it: started
/// from the first product, since 0 + (−0) would not keep a negative zero.
#[inline(always)]
fn row_times<const N: usize>(row: &[f64], x: &[f64; N]) -> f64 {
    let mut acc = row[0] * x[0];
    for l in 1..N {
        acc += row[l] * x[l];
    }
    acc
}

/// `acc` + Σ_l row_l·x_l, each product added in order, as `gemv` with β = 1 adds them.
#[inline(always)]
fn plus_row_times(mut acc: f64, row: &[f64], x: &[f64]) -> f64 {
    for (r, x) in row.iter().zip(x) {
        acc += r * x;
    }
    acc
}

/// Computes the sensitivity responses over the simulation segments of `data` and their
/// norms, ‖T_i ∂y_k/∂T_i‖ / √N (eq. 11 over the N simulated instants).
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
        // A pair's second entry has its first's response (one decay parameter).
        if let Some(p) = recursion.earlier_partner(i) {
            for row in norms.iter_mut() {
                row[i] = row[p];
            }
            continue;
        }
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
        oscillation_periods_s: recursion.periods_s.clone(),
        partners: recursion.partners.clone(),
        responses: SensitivityResponses {
            segments: segments.to_vec(),
            recursion: Some(recursion),
        },
    })
}

/// Assigns each time constant T_i to the state whose response it changes most,
/// max_k ‖T_i ∂y_k/∂T_i‖ (eq. 11); a complex pair, one mode of two dimensions, claims its
/// two most sensitive states (its first entry the most). When two time constants would
/// claim one state, the one-to-one assignment is chosen that maximises
/// Σ_i log(share of T_i's influence on its state); it equals the plain rule whenever
/// that is one-to-one.
pub fn assign(s: &Sensitivities) -> Vec<Assignment> {
    let n = s.time_constants_s.len();
    let ranked = |i: usize| {
        let mut states: Vec<usize> = (0..n).collect();
        states.sort_by(|&a, &b| s.norms[b][i].total_cmp(&s.norms[a][i]));
        states
    };
    let partner = |i: usize| s.partners.get(i).copied().flatten();
    let plain: Vec<usize> = (0..n)
        .map(|i| match partner(i) {
            Some(p) if p < i => ranked(i).get(1).copied().unwrap_or(0),
            _ => ranked(i).first().copied().unwrap_or(0),
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
        // A pair's entries are interchangeable: keep its more sensitive state first.
        for i in 0..n {
            if let Some(p) = partner(i).filter(|&p| p > i) {
                if s.norms[best[p]][i] > s.norms[best[i]][i] {
                    best.swap(i, p);
                }
            }
        }
    }
    (0..n)
        .map(|i| Assignment {
            time_constant_s: s.time_constants_s[i],
            oscillation_period_s: s.oscillation_periods_s.get(i).copied().flatten(),
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

    /// The recursion compiled for three and four states gives the general one's bits
    /// (nalgebra's `gemv`), on models with real and complex modes, over two segments
    /// with inputs that change sign and pass through zero.
    #[test]
    fn the_recursion_for_three_and_four_states_has_the_general_ones_bits() {
        let four = ContinuousModel {
            a_c: DMatrix::from_row_slice(
                4,
                4,
                &[
                    -0.011, 0.004, 0.0, 0.002, 0.003, -0.02, 0.006, 0.0, 0.0, 0.005, -0.009, 0.001,
                    0.004, 0.0, 0.002, -0.05,
                ],
            ),
            b_c: DMatrix::from_row_slice(
                4,
                3,
                &[
                    0.02, 0.0, 0.001, 0.0, 0.03, 0.0, 0.005, 0.0, 0.01, 0.0, 0.002, 0.04,
                ],
            ),
        };
        for model in [oscillating_model(300.0, 0.01, 80.0), four] {
            let (n, m) = (model.a_c.nrows(), model.b_c.ncols());
            let continuous_t: Vec<f64> = {
                let mut t: Vec<f64> = crate::thermal::matrix::eigenvalues(&model.a_c, "A_c")
                    .unwrap()
                    .iter()
                    .map(|l| -1.0 / l.re)
                    .collect();
                t.sort_by(f64::total_cmp);
                t
            };
            let recursion = SensitivityModel::new(&model, &continuous_t, 2.0).unwrap();
            let len = 700;
            let inputs = DMatrix::from_fn(len, m, |k, j| {
                ((k as f64) * 0.013 * (j + 1) as f64).sin() * (1.0 + j as f64)
            });
            let outputs = DMatrix::from_fn(len, n, |k, c| 0.001 * (k * (c + 1)) as f64);
            let data = IdentificationData::complete(2.0, outputs, inputs);
            let segments = [0..300, 310..len];
            for i in 0..n {
                let mut fast = Vec::new();
                recursion.for_each_response(i, &data, &segments, |k, rel| {
                    fast.push((k, rel.iter().map(|v| v.to_bits()).collect::<Vec<_>>()));
                });
                let mut general = Vec::new();
                for seg in &segments {
                    general.push((seg.start, vec![0.0f64.to_bits(); n]));
                    let y0 = recursion.discrete.initial_state(&data, seg.clone());
                    recursion.respond_any(i, &data, seg, &y0, &mut |k, rel| {
                        general.push((k, rel.iter().map(|v| v.to_bits()).collect()));
                    });
                }
                assert_eq!(fast.len(), 300 + len - 310);
                assert_eq!(fast, general, "{n} states, time constant {i}");
            }
        }
    }

    #[test]
    fn assignment_resolves_a_conflict_one_to_one() {
        let s = Sensitivities {
            time_constants_s: vec![1.0, 2.0],
            norms: vec![vec![0.9, 0.6], vec![0.1, 0.4]],
            oscillation_periods_s: vec![None, None],
            partners: vec![None, None],
            responses: SensitivityResponses::default(),
        };
        let a = assign(&s);
        assert_eq!(a[0].state, 0);
        assert_eq!(a[1].state, 1);
        assert!(a[1].resolved_conflict && !a[0].resolved_conflict);
    }

    /// A model with the mode pair −1/T ± iω and a real mode, as A_c = P·blocks·P⁻¹.
    fn oscillating_model(t_pair: f64, omega: f64, t_real: f64) -> ContinuousModel {
        let blocks = DMatrix::from_row_slice(
            3,
            3,
            &[
                -1.0 / t_pair,
                -omega,
                0.0,
                omega,
                -1.0 / t_pair,
                0.0,
                0.0,
                0.0,
                -1.0 / t_real,
            ],
        );
        let p = DMatrix::from_row_slice(3, 3, &[1.0, 0.3, 0.1, -0.2, 1.0, 0.4, 0.5, 0.0, 1.0]);
        ContinuousModel {
            a_c: &p * blocks * p.clone().try_inverse().unwrap(),
            b_c: DMatrix::from_row_slice(3, 2, &[0.02, 0.0, 0.01, 0.015, 0.0, 0.03]),
        }
    }

    #[test]
    fn a_complex_pair_sensitivity_matches_finite_differences() {
        // Reference: rebuild A_c with the pair's decay constant T ± h (frequency held),
        // discretise, simulate, and difference; the recursion must agree.
        let (t_pair, omega, t_real, ts, n) = (80.0_f64, 0.03, 20.0, 1.0, 300);
        let model = oscillating_model(t_pair, omega, t_real);
        let mut inputs = DMatrix::zeros(n, 2);
        for k in 0..n {
            inputs[(k, 0)] = if (k / 40) % 2 == 0 { 1.0 } else { 0.0 };
            inputs[(k, 1)] = if (k / 70) % 2 == 0 { 0.0 } else { 1.0 };
        }
        let data = IdentificationData::complete(ts, DMatrix::zeros(n, 3), inputs.clone());
        let simulate = |t: f64| {
            let m = oscillating_model(t, omega, t_real);
            let (phi, gamma) = crate::thermal::matrix::discretize(&m.a_c, &m.b_c, ts);
            let mut y = DVector::zeros(3);
            let mut out = vec![y.clone()];
            for k in 1..n {
                y = &phi * &y + &gamma * inputs.row(k - 1).transpose();
                out.push(y.clone());
            }
            out
        };
        let h = 1e-4 * t_pair;
        let (plus, minus) = (simulate(t_pair + h), simulate(t_pair - h));
        let spectrum_t = [t_real, t_pair, t_pair];
        let recursion = SensitivityModel::new(&model, &spectrum_t, ts).unwrap();
        assert_eq!(recursion.partners, vec![None, Some(2), Some(1)]);
        let period = recursion.periods_s[1].unwrap();
        assert!((period - 2.0 * std::f64::consts::PI / omega).abs() < 1e-9 * period);
        let whole: Vec<std::ops::Range<usize>> = std::iter::once(0..n).collect();
        let mut largest: f64 = 0.0;
        for i in [1, 2] {
            recursion.for_each_response(i, &data, &whole, |k, rel| {
                let fd = (&plus[k] - &minus[k]) * (t_pair / (2.0 * h));
                largest = largest.max(fd.amax());
                assert!((rel - &fd).amax() < 1e-6, "k={k}: {rel} vs {fd}");
            });
        }
        assert!(largest > 1e-2, "the pair moves the outputs: {largest}");
        // The responses the plots get are the recursion's, bit for bit, the pair's
        // entries one.
        let kept = sensitivities(&model, &spectrum_t, ts, &data, &whole).unwrap();
        let response = |i: usize| {
            let mut values = Vec::new();
            kept.responses.for_each(i, &data, |k, rel| {
                values.push((k, rel.iter().map(|v| v.to_bits()).collect::<Vec<_>>()));
            });
            values
        };
        assert_eq!(response(1), response(2));
        assert!(response(3).is_empty());
        for i in 0..3 {
            let mut fresh = Vec::new();
            recursion.for_each_response(i, &data, &whole, |k, rel| {
                fresh.push((k, rel.iter().map(|v| v.to_bits()).collect::<Vec<_>>()));
            });
            let mut stored = Vec::new();
            kept.responses.for_each(i, &data, |k, rel| {
                stored.push((k, rel.iter().map(|v| v.to_bits()).collect::<Vec<_>>()));
            });
            assert_eq!(fresh, stored, "T{}", i + 1);
        }
        // The modal Φ is the model's own.
        let (phi, _) = crate::thermal::matrix::discretize(&model.a_c, &model.b_c, ts);
        assert!((&recursion.discrete.phi - phi).norm() < 1e-12);
    }

    #[test]
    fn a_pair_is_assigned_to_its_two_most_sensitive_states() {
        // Columns 1 and 2 are one pair (identical); state 0 is most sensitive to the real
        // mode and to the pair, so the pair takes states 0 and 1 only if the real mode can
        // go elsewhere: the one-to-one rule gives the real mode state 2.
        let pair = [0.5, 0.4, 0.1];
        let real = [0.6, 0.1, 0.3];
        let norms = (0..3).map(|k| vec![real[k], pair[k], pair[k]]).collect();
        let s = Sensitivities {
            time_constants_s: vec![10.0, 50.0, 50.0],
            norms,
            oscillation_periods_s: vec![None, Some(200.0), Some(200.0)],
            partners: vec![None, Some(2), Some(1)],
            responses: SensitivityResponses::default(),
        };
        let a = assign(&s);
        assert_eq!(a.iter().map(|x| x.state).collect::<Vec<_>>(), vec![2, 0, 1]);
        assert_eq!(a[1].oscillation_period_s, Some(200.0));
        assert!(a[0].resolved_conflict && !a[1].resolved_conflict && !a[2].resolved_conflict);
    }
}
