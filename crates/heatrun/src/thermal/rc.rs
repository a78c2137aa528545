//! The passive network's own parameters and the discrete model they give: the map
//! p → (C, G, K) → (A_c, B_c) → Θ = [Φ Γ] and its Jacobian, shared by the grey-box
//! estimator (`estimate::rc`) and the minimum-distance network of an identified model
//! (`network::fit`).
//!
//! p = [ln C_i; ln G_i0; ln G_ij (i < j); η], each loss column of K on the simplex by the
//! additive log-ratio k_ij = e^{η_ij} / (1 + Σ_{l≠r_j} e^{η_lj}) with
//! k_{r_j j} = 1 / (1 + Σ_l e^{η_lj}) (r_j the part that takes the largest share of loss j
//! at the start); A_c = −C⁻¹·L, B_c = C⁻¹·K·P_base/θ_base, and Φ, Γ their zero-order hold.

use nalgebra::DMatrix;

use super::network::{Interval, NetworkIntervals, Parts, Scaling};
use super::{DiscreteModel, Z95};

/// Smallest share of a loss, and smallest conductance relative to the largest, that the
/// start gives an entry the identified model makes zero or negative: the logarithms
/// need a finite start, and the fit takes it from there.
const START_FLOOR: f64 = 1e-2;

/// How far (in natural logarithms) a parameter may move from its start: a factor of
/// e^25 ≈ 7·10¹⁰, far beyond any physical correction, short of overflowing the model.
pub(crate) const LOG_RANGE: f64 = 25.0;

/// The most a capacitance's logarithm moves in one step ([`Parametrisation::stepped`]): a
/// factor e^1.5 ≈ 4.5.
pub(crate) const MOST_LOG_STEP: f64 = 1.5;

/// Floors non-positive conductances and shares and renormalises K's columns.
pub(crate) fn projected(mut parts: Parts) -> Parts {
    let g_max = parts.conductance_w_per_k.amax().max(1e-300);
    parts
        .conductance_w_per_k
        .apply(|g| *g = g.max(START_FLOOR * g_max));
    let k = &mut parts.loss_distribution;
    for mut column in k.column_iter_mut() {
        column.apply(|v| *v = v.max(START_FLOOR));
        let sum = column.sum();
        column /= sum;
    }
    parts
}

/// The map p → (C, G, K) → (A_c, B_c) → Θ = [Φ Γ] and its Jacobian (also the model of
/// the minimum-distance network of an identified model, [`crate::network::fit`]).
#[derive(Debug, Clone)]
pub(crate) struct Parametrisation {
    n: usize,
    m: usize,
    ts_s: f64,
    /// The model's scaling.
    pub(crate) scaling: Scaling,
    /// P_base/θ_base, W/K per input unit.
    w: f64,
    /// Per loss: the part whose share is the reference of its log-ratios.
    pub(crate) reference: Vec<usize>,
    /// The pairs (i, j), i < j, of the conductances between parts, in p's order.
    pairs: Vec<(usize, usize)>,
    /// The start, laid out as p.
    pub(crate) start: Vec<f64>,
}

impl Parametrisation {
    /// The map for n parts and m losses (the shape of `start`) at sample time `ts_s`.
    pub(crate) fn of_shape(ts_s: f64, scaling: Scaling, start: &Parts) -> Parametrisation {
        let (n, m) = (
            start.capacitance_j_per_k.len(),
            start.loss_distribution.ncols(),
        );
        let reference = (0..m)
            .map(|j| start.loss_distribution.column(j).imax())
            .collect();
        let pairs = (0..n)
            .flat_map(|i| (i + 1..n).map(move |j| (i, j)))
            .collect();
        let mut map = Parametrisation {
            n,
            m,
            ts_s,
            scaling,
            w: scaling.p_base_w / scaling.theta_base_k,
            reference,
            pairs,
            start: Vec::new(),
        };
        map.start = map.params_of(start);
        map
    }

    /// Number of capacitances, n: p's first n entries are their logarithms.
    pub(crate) fn capacitances(&self) -> usize {
        self.n
    }

    /// Number of parameters: n + n + n(n−1)/2 + m(n−1).
    pub(crate) fn len(&self) -> usize {
        2 * self.n + self.pairs.len() + self.m * (self.n - 1)
    }

    /// Index in p of the first log-ratio of loss j.
    pub(crate) fn eta_at(&self, j: usize) -> usize {
        2 * self.n + self.pairs.len() + j * (self.n - 1)
    }

    /// The parts (rows) of loss j's log-ratios, in p's order.
    pub(crate) fn eta_parts(&self, j: usize) -> impl Iterator<Item = usize> + '_ {
        (0..self.n).filter(move |&i| i != self.reference[j])
    }

    /// p of a network (positive C and G, K with positive entries).
    pub(crate) fn params_of(&self, parts: &Parts) -> Vec<f64> {
        let g = &parts.conductance_w_per_k;
        let k = &parts.loss_distribution;
        let mut p: Vec<f64> = parts.capacitance_j_per_k.iter().map(|c| c.ln()).collect();
        p.extend((0..self.n).map(|i| g[(i, i)].ln()));
        p.extend(self.pairs.iter().map(|&(i, j)| g[(i, j)].ln()));
        for j in 0..self.m {
            let r = self.reference[j];
            p.extend(self.eta_parts(j).map(|i| (k[(i, j)] / k[(r, j)]).ln()));
        }
        p
    }

    /// C, G (G_i0 on the diagonal) and K of p.
    pub(crate) fn parts(&self, p: &[f64]) -> Parts {
        let n = self.n;
        let mut g = DMatrix::zeros(n, n);
        for i in 0..n {
            g[(i, i)] = p[n + i].exp();
        }
        for (q, &(i, j)) in self.pairs.iter().enumerate() {
            let v = p[2 * n + q].exp();
            g[(i, j)] = v;
            g[(j, i)] = v;
        }
        let mut k = DMatrix::zeros(n, self.m);
        for j in 0..self.m {
            let at = self.eta_at(j);
            k[(self.reference[j], j)] = 1.0;
            for (q, i) in self.eta_parts(j).enumerate() {
                k[(i, j)] = p[at + q].exp();
            }
            let sum = k.column(j).sum();
            k.column_mut(j).apply(|v| *v /= sum);
        }
        Parts {
            capacitance_j_per_k: p[..n].iter().map(|v| v.exp()).collect(),
            conductance_w_per_k: g,
            loss_distribution: k,
        }
    }

    /// A_c = −C⁻¹L and B_c = C⁻¹·K·w of p.
    pub(crate) fn continuous(&self, p: &[f64]) -> (DMatrix<f64>, DMatrix<f64>) {
        let parts = self.parts(p);
        let l = laplacian(&parts.conductance_w_per_k);
        let c = &parts.capacitance_j_per_k;
        let a = DMatrix::from_fn(self.n, self.n, |i, j| -l[(i, j)] / c[i]);
        let b = DMatrix::from_fn(self.n, self.m, |i, j| {
            parts.loss_distribution[(i, j)] * self.w / c[i]
        });
        (a, b)
    }

    /// ∂A_c/∂p_q and ∂B_c/∂p_q for every q.
    pub(crate) fn continuous_derivatives(&self, p: &[f64]) -> Vec<(DMatrix<f64>, DMatrix<f64>)> {
        let (n, m) = (self.n, self.m);
        let parts = self.parts(p);
        let c = &parts.capacitance_j_per_k;
        let g = &parts.conductance_w_per_k;
        let k = &parts.loss_distribution;
        let (a, b) = self.continuous(p);
        let mut out = Vec::with_capacity(self.len());
        // ln C_i: A_ij = −L_ij/C_i, B_ij = k_ij·w/C_i, so both rows scale by −1.
        for i in 0..n {
            let mut da = DMatrix::zeros(n, n);
            let mut db = DMatrix::zeros(n, m);
            da.row_mut(i).copy_from(&(-a.row(i)));
            db.row_mut(i).copy_from(&(-b.row(i)));
            out.push((da, db));
        }
        // ln G_i0: dL_ii = G_i0.
        for i in 0..n {
            let mut da = DMatrix::zeros(n, n);
            da[(i, i)] = -g[(i, i)] / c[i];
            out.push((da, DMatrix::zeros(n, m)));
        }
        // ln G_ij: dL_ii = dL_jj = G_ij, dL_ij = dL_ji = −G_ij.
        for &(i, j) in &self.pairs {
            let v = g[(i, j)];
            let mut da = DMatrix::zeros(n, n);
            da[(i, i)] = -v / c[i];
            da[(j, j)] = -v / c[j];
            da[(i, j)] = v / c[i];
            da[(j, i)] = v / c[j];
            out.push((da, DMatrix::zeros(n, m)));
        }
        // η_ij: ∂k_lj/∂η_ij = k_lj·(δ_li − k_ij).
        for j in 0..m {
            for i in self.eta_parts(j) {
                let mut db = DMatrix::zeros(n, m);
                for l in 0..n {
                    let delta = if l == i { 1.0 } else { 0.0 };
                    db[(l, j)] = k[(l, j)] * (delta - k[(i, j)]) * self.w / c[l];
                }
                out.push((DMatrix::zeros(n, n), db));
            }
        }
        out
    }

    /// y_q, the coordinate a fit steps p_q in: a capacitance's logarithm as it is, a
    /// conductance or share ratio as itself relative to its start s, y_q = e^{p_q − s_q}.
    ///
    /// Why: in its logarithm, a Gauss–Newton step throws an entry the data drive to zero
    /// e^20 below its start, where its Jacobian column ∝ e^p vanishes and it climbs back a
    /// hair per step; as itself the entry meets zero (the floor e^−LOG_RANGE, where the
    /// fit holds it while its gradient points down) and leaves it by a step of the size
    /// its gradient asks for (the nearest network of the four-node machine: 20,000 steps
    /// in the logarithms, unconverged; 50–111 in these coordinates).
    pub(crate) fn step_coordinate(&self, q: usize, p_q: f64) -> f64 {
        if q < self.n {
            p_q
        } else {
            (p_q - self.start[q]).exp()
        }
    }

    /// p_q of a step coordinate y_q ([`Parametrisation::step_coordinate`]), within
    /// e^±[`LOG_RANGE`] of the start.
    pub(crate) fn param_of_step_coordinate(&self, q: usize, y_q: f64) -> f64 {
        let s = self.start[q];
        let p_q = if q < self.n {
            y_q
        } else {
            s + y_q.max((-LOG_RANGE).exp()).ln()
        };
        p_q.clamp(s - LOG_RANGE, s + LOG_RANGE)
    }

    /// ∂p_q/∂y_q at p_q, y the coordinates a fit steps in ([`Parametrisation::step_coordinate`]):
    /// 1 for a capacitance's logarithm, e^{s_q − p_q} for a conductance or share ratio.
    pub(crate) fn step_coordinate_scale(&self, q: usize, p_q: f64) -> f64 {
        if q < self.n {
            1.0
        } else {
            (self.start[q] - p_q).exp()
        }
    }

    /// p_q moved by a step δ in the fit's coordinates y, within e^±[`LOG_RANGE`] of the start.
    /// A capacitance moves as its logarithm, at most [`MOST_LOG_STEP`]. A conductance or
    /// share ratio moves as itself relative to its start, y_q = e^{p_q − s_q} → y_q + δ,
    /// floored at e^−LOG_RANGE (zero for any purpose): in its logarithm, a Gauss–Newton
    /// step throws an entry the data drive to zero e^20 below its start, where its
    /// Jacobian column ∝ e^p vanishes and it climbs back a hair per step (the four-node
    /// machine's nearest network: 20,000 steps, unconverged); as itself the entry meets
    /// zero and leaves it with a step of the size its own gradient asks for, and the
    /// model, linear in G and K for a given C, has no curve in it for the step to miss.
    pub(crate) fn stepped(&self, q: usize, p_q: f64, step: f64) -> f64 {
        let step = if q < self.n {
            step.clamp(-MOST_LOG_STEP, MOST_LOG_STEP)
        } else {
            step
        };
        self.param_of_step_coordinate(q, self.step_coordinate(q, p_q) + step)
    }

    /// Whether p_q sits at its floor start − [`LOG_RANGE`] (its entry zero for any purpose).
    pub(crate) fn at_floor(&self, q: usize, p_q: f64) -> bool {
        q >= self.n && p_q <= self.start[q] - LOG_RANGE + 1e-9
    }

    /// The discrete model (zero-order hold) of p.
    pub(crate) fn model(&self, p: &[f64]) -> DiscreteModel {
        let (a, b) = self.continuous(p);
        let (phi, gamma) = crate::thermal::matrix::discretize(&a, &b, self.ts_s);
        DiscreteModel {
            phi,
            gamma,
            ts_s: self.ts_s,
        }
    }

    /// D = ∂Θ/∂p (Θ laid out as [`DiscreteModel::theta`]): for each direction E of
    /// M = [[A_c, B_c], [0, 0]]·Ts, the upper-right block of exp([[M, E], [0, M]]) is
    /// the Fréchet derivative of e^M along E, whose top rows are [dΦ dΓ].
    pub(crate) fn theta_jacobian(&self, p: &[f64]) -> DMatrix<f64> {
        let (n, m) = (self.n, self.m);
        let s = n + m;
        let (a, b) = self.continuous(p);
        let mut big = DMatrix::zeros(2 * s, 2 * s);
        for block in [0, s] {
            big.view_mut((block, block), (n, n))
                .copy_from(&(&a * self.ts_s));
            big.view_mut((block, block + n), (n, m))
                .copy_from(&(&b * self.ts_s));
        }
        let derivatives = self.continuous_derivatives(p);
        let mut d = DMatrix::zeros(n * s, derivatives.len());
        for (q, (da, db)) in derivatives.iter().enumerate() {
            let mut e = big.clone();
            e.view_mut((0, s), (n, n)).copy_from(&(da * self.ts_s));
            e.view_mut((0, s + n), (n, m)).copy_from(&(db * self.ts_s));
            let x = crate::thermal::matrix::exponential(e);
            for i in 0..n {
                for j in 0..s {
                    d[(i * s + j, q)] = x[(i, s + j)];
                }
            }
        }
        d
    }

    /// 95 % intervals of C, G (log-normal) and K (delta method) from cov(p).
    pub(crate) fn intervals(&self, p: &[f64], cov: &DMatrix<f64>) -> NetworkIntervals {
        let (n, m) = (self.n, self.m);
        let parts = self.parts(p);
        let log_normal = |value: f64, q: usize| -> Option<Interval> {
            let sd = cov[(q, q)].max(0.0).sqrt();
            let (low, high) = (value * (-Z95 * sd).exp(), value * (Z95 * sd).exp());
            (low.is_finite() && high.is_finite()).then_some(Interval {
                low,
                high,
                standard_error: value * sd,
            })
        };
        let mut conductance = vec![vec![None; n]; n];
        for (i, row) in conductance.iter_mut().enumerate() {
            row[i] = log_normal(parts.conductance_w_per_k[(i, i)], n + i);
        }
        for (q, &(i, j)) in self.pairs.iter().enumerate() {
            let interval = log_normal(parts.conductance_w_per_k[(i, j)], 2 * n + q);
            conductance[i][j] = interval;
            conductance[j][i] = interval;
        }
        let k = &parts.loss_distribution;
        let loss = (0..n)
            .map(|l| {
                (0..m)
                    .map(|j| {
                        let at = self.eta_at(j);
                        let grad: Vec<(usize, f64)> = self
                            .eta_parts(j)
                            .enumerate()
                            .map(|(q, i)| {
                                let delta = if l == i { 1.0 } else { 0.0 };
                                (at + q, k[(l, j)] * (delta - k[(i, j)]))
                            })
                            .collect();
                        let var: f64 = grad
                            .iter()
                            .flat_map(|&(a, ga)| grad.iter().map(move |&(b, gb)| (a, ga, b, gb)))
                            .map(|(a, ga, b, gb)| ga * cov[(a, b)] * gb)
                            .sum();
                        let se = var.max(0.0).sqrt();
                        se.is_finite().then_some(Interval {
                            low: (k[(l, j)] - Z95 * se).max(0.0),
                            high: (k[(l, j)] + Z95 * se).min(1.0),
                            standard_error: se,
                        })
                    })
                    .collect()
            })
            .collect();
        NetworkIntervals {
            method: "grey-box output error (--method rc): C and G log-normal, exp(ln x ± 1.96 σ); \
                     k_ij ± 1.96 σ by the delta method, within [0, 1]"
                .into(),
            capacitance_j_per_k: (0..n)
                .map(|i| log_normal(parts.capacitance_j_per_k[i], i))
                .collect(),
            conductance_w_per_k: conductance,
            loss_distribution: loss,
        }
    }
}

/// L of eq. (Fig. 9): L_ij = −G_ij, L_ii = G_i0 + Σ_{j≠i} G_ij.
fn laplacian(g: &DMatrix<f64>) -> DMatrix<f64> {
    let n = g.nrows();
    DMatrix::from_fn(n, n, |i, j| {
        if i == j {
            g[(i, i)] + (0..n).filter(|&l| l != i).map(|l| g[(i, l)]).sum::<f64>()
        } else {
            -g[(i, j)]
        }
    })
}
