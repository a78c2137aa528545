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

    /// D = ∂Θ/∂p (Θ laid out as [`DiscreteModel::theta`]): the Fréchet derivative of
    /// e^M, M = [[A_c, B_c], [0, 0]]·Ts, along each parameter's direction
    /// E = [[∂A_c, ∂B_c], [0, 0]]·Ts, whose top rows are [dΦ dΓ]. From M's eigenvectors
    /// where A_c has them ([`Spectrum`], one symmetric eigenproblem for all directions),
    /// else from one exponential of a block matrix per direction.
    pub(crate) fn theta_jacobian(&self, p: &[f64]) -> DMatrix<f64> {
        let derivatives = self.continuous_derivatives(p);
        let spectral = self
            .spectrum(p)
            .map(|spectrum| self.jacobian_of(&derivatives, |e| spectrum.derivative(e)))
            .filter(|d| d.iter().all(|v| v.is_finite()));
        spectral.unwrap_or_else(|| {
            let (a, b) = self.continuous(p);
            let m = crate::thermal::matrix::hold_block(&a, &b, self.ts_s);
            self.jacobian_of(&derivatives, |e| by_block_exponential(&m, e))
        })
    }

    /// D from each direction's derivative [dΦ dΓ] (n × (n + m)) by `derivative`.
    fn jacobian_of(
        &self,
        derivatives: &[(DMatrix<f64>, DMatrix<f64>)],
        derivative: impl Fn(&DMatrix<f64>) -> DMatrix<f64>,
    ) -> DMatrix<f64> {
        let (n, m) = (self.n, self.m);
        let s = n + m;
        let mut d = DMatrix::zeros(n * s, derivatives.len());
        let mut e = DMatrix::zeros(n, s);
        for (q, (da, db)) in derivatives.iter().enumerate() {
            e.view_mut((0, 0), (n, n)).copy_from(&(da * self.ts_s));
            e.view_mut((0, n), (n, m)).copy_from(&(db * self.ts_s));
            let x = derivative(&e);
            for i in 0..n {
                for j in 0..s {
                    d[(i * s + j, q)] = x[(i, j)];
                }
            }
        }
        d
    }

    /// M's eigenvectors at p: A_c = −C⁻¹L is similar to the symmetric −C^{−½}LC^{−½}
    /// (L the conductances' symmetric Laplacian), so A_c = VΛV⁻¹ with V = C^{−½}U,
    /// V⁻¹ = UᵀC^{½} (U orthonormal); `None` where A_c is singular (a part with no path
    /// to the coolant: M then has no full set of eigenvectors) or not finite.
    fn spectrum(&self, p: &[f64]) -> Option<Spectrum> {
        let parts = self.parts(p);
        let l = laplacian(&parts.conductance_w_per_k);
        let c = &parts.capacitance_j_per_k;
        let root: Vec<f64> = c.iter().map(|c| c.sqrt()).collect();
        let n = self.n;
        let symmetric = DMatrix::from_fn(n, n, |i, j| -l[(i, j)] / (root[i] * root[j]));
        if !symmetric.iter().all(|v| v.is_finite()) {
            return None;
        }
        let eigen = nalgebra::SymmetricEigen::new(symmetric);
        let largest = eigen.eigenvalues.amax();
        if eigen.eigenvalues.iter().any(|l| l.abs() <= 1e-12 * largest) {
            return None;
        }
        let u = &eigen.eigenvectors;
        let v = DMatrix::from_fn(n, n, |i, k| u[(i, k)] / root[i]);
        let v_inverse = DMatrix::from_fn(n, n, |k, i| u[(i, k)] * root[i]);
        let (_, b) = self.continuous(p);
        // M's eigenvectors of the eigenvalue 0: [−A_c⁻¹B_c e_j; e_j], A_c⁻¹ = VΛ⁻¹V⁻¹.
        let mut inverse_b = &v_inverse * &b;
        for (k, mut row) in inverse_b.row_iter_mut().enumerate() {
            row /= -eigen.eigenvalues[k];
        }
        let null = &v * inverse_b;
        let mu: Vec<f64> = eigen
            .eigenvalues
            .iter()
            .map(|l| l * self.ts_s)
            .chain(std::iter::repeat_n(0.0, self.m))
            .collect();
        let s = n + self.m;
        // e^{max}·(e^{min−max} − 1)/(min − max): no exponential of a positive difference
        // (at a start far from the data the modes are e^25 apart).
        let divided = DMatrix::from_fn(n, s, |i, j| {
            let (low, high) = (mu[i].min(mu[j]), mu[i].max(mu[j]));
            high.exp() * relative_exp_m1(low - high)
        });
        let null_in_modes = &v_inverse * &null;
        Some(Spectrum {
            v,
            v_inverse,
            null,
            null_in_modes,
            divided,
        })
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
/// The top n rows of the Fréchet derivative of e^M along [[E], [0]] (E the top n rows):
/// the upper-right block of exp([[M, E'], [0, M]]) (E' = E with zero rows below).
fn by_block_exponential(m: &DMatrix<f64>, e: &DMatrix<f64>) -> DMatrix<f64> {
    let (s, n) = (m.nrows(), e.nrows());
    let mut big = DMatrix::zeros(2 * s, 2 * s);
    big.view_mut((0, 0), (s, s)).copy_from(m);
    big.view_mut((s, s), (s, s)).copy_from(m);
    big.view_mut((0, s), (n, s)).copy_from(e);
    let x = crate::thermal::matrix::exponential(big);
    x.view((0, s), (n, s)).into_owned()
}

/// (eˣ − 1)/x, 1 at x = 0, without the cancellation of either form near 0.
fn relative_exp_m1(x: f64) -> f64 {
    if x == 0.0 {
        1.0
    } else {
        x.exp_m1() / x
    }
}

/// M = Ts·[[A_c, B_c], [0, 0]] diagonalised: M = W·diag(μ)·W⁻¹ with
/// W = [[V, X], [0, I]], W⁻¹ = [[V⁻¹, −V⁻¹X], [0, I]], μ = [λ·Ts; 0], X = −A_c⁻¹B_c.
/// The Fréchet derivative of e^M along E is then (Daleckii and Krein)
/// W·(F ∘ (W⁻¹EW))·W⁻¹ with F_ij = (e^{μ_i} − e^{μ_j})/(μ_i − μ_j), e^{μ_i} where
/// μ_i = μ_j: a few n × (n + m) products per direction instead of an
/// exponential of a 2(n + m) square matrix.
struct Spectrum {
    /// V, A_c's eigenvectors (columns).
    v: DMatrix<f64>,
    /// V⁻¹.
    v_inverse: DMatrix<f64>,
    /// X = −A_c⁻¹B_c, n × m.
    null: DMatrix<f64>,
    /// V⁻¹X.
    null_in_modes: DMatrix<f64>,
    /// F's top n rows, n × (n + m).
    divided: DMatrix<f64>,
}

impl Spectrum {
    /// [dΦ dΓ] along the direction whose top rows are `e` = Ts·[∂A_c ∂B_c] (its bottom
    /// rows are zero): with Z = F ∘ (V⁻¹·E·W) = [Z₁ Z₂], dΦ = V·Z₁·V⁻¹ and
    /// dΓ = V·(Z₂ − Z₁·V⁻¹X).
    fn derivative(&self, e: &DMatrix<f64>) -> DMatrix<f64> {
        let (n, s) = (e.nrows(), e.ncols());
        let m = s - n;
        let e_a = e.view((0, 0), (n, n));
        let e_b = e.view((0, n), (n, m));
        // E·W = [E_A·V, E_A·X + E_B].
        let mut ew = DMatrix::zeros(n, s);
        ew.view_mut((0, 0), (n, n)).copy_from(&(e_a * &self.v));
        ew.view_mut((0, n), (n, m))
            .copy_from(&(e_a * &self.null + e_b));
        let z = (&self.v_inverse * ew).component_mul(&self.divided);
        let z1 = z.view((0, 0), (n, n));
        let z2 = z.view((0, n), (n, m));
        let mut out = DMatrix::zeros(n, s);
        out.view_mut((0, 0), (n, n))
            .copy_from(&(&self.v * z1 * &self.v_inverse));
        out.view_mut((0, n), (n, m))
            .copy_from(&(&self.v * (z2 - z1 * &self.null_in_modes)));
        out
    }
}

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

#[cfg(test)]
mod tests {
    use super::*;

    /// The four-node unit of issue 33 (stator winding, core, cooling water, field
    /// winding), per unit of 100 MW and 80 K.
    fn four_node() -> (Parts, Scaling) {
        let g = DMatrix::from_row_slice(
            4,
            4,
            &[
                0.0, 22000.0, 9000.0, 1000.0, //
                22000.0, 0.0, 35000.0, 1000.0, //
                9000.0, 35000.0, 202114.6, 3000.0, //
                1000.0, 1000.0, 3000.0, 0.0,
            ],
        );
        let k = DMatrix::from_row_slice(
            4,
            3,
            &[
                0.8, 0.03, 0.05, 0.15, 0.02, 0.75, 0.05, 0.15, 0.15, 0.0, 0.8, 0.05,
            ],
        );
        let parts = projected(Parts {
            capacitance_j_per_k: vec![24.5e6, 137e6, 17.5e6, 8e6],
            conductance_w_per_k: g,
            loss_distribution: k,
        });
        let scaling = Scaling {
            theta_base_k: 80.0,
            p_base_w: 1e8,
        };
        (parts, scaling)
    }

    /// Each column of D by the block exponential, the reference.
    fn by_blocks(map: &Parametrisation, p: &[f64]) -> DMatrix<f64> {
        let (a, b) = map.continuous(p);
        let m = crate::thermal::matrix::hold_block(&a, &b, map.ts_s);
        map.jacobian_of(&map.continuous_derivatives(p), |e| {
            by_block_exponential(&m, e)
        })
    }

    /// max over columns of max |d − reference| / max |reference| (columns below 10⁻¹²
    /// of the largest entry measured against that).
    fn largest_column_error(d: &DMatrix<f64>, reference: &DMatrix<f64>) -> f64 {
        let floor = 1e-12 * reference.amax();
        (0..d.ncols())
            .map(|q| {
                (d.column(q) - reference.column(q)).amax() / reference.column(q).amax().max(floor)
            })
            .fold(0.0, f64::max)
    }

    #[test]
    fn the_spectral_jacobian_is_the_block_exponentials() {
        let (parts, scaling) = four_node();
        for ts_s in [1.0, 10.0, 600.0] {
            let map = Parametrisation::of_shape(ts_s, scaling, &parts);
            let p = &map.start;
            assert!(map.spectrum(p).is_some());
            let error = largest_column_error(&map.theta_jacobian(p), &by_blocks(&map, p));
            assert!(error < 1e-11, "Ts {ts_s} s: {error:e}");
        }
    }

    #[test]
    fn a_repeated_time_constant_takes_the_limit_of_the_divided_difference() {
        // Three equal parts, each to the coolant by g0 and to each other by g: L has the
        // eigenvalue g0 + 3g twice (any vector summing to zero).
        let g = DMatrix::from_fn(3, 3, |i, j| if i == j { 500.0 } else { 2000.0 });
        let parts = Parts {
            capacitance_j_per_k: vec![1e6; 3],
            conductance_w_per_k: g,
            loss_distribution: DMatrix::from_row_slice(3, 2, &[0.5, 0.2, 0.3, 0.3, 0.2, 0.5]),
        };
        let scaling = Scaling {
            theta_base_k: 50.0,
            p_base_w: 1e6,
        };
        let map = Parametrisation::of_shape(1.0, scaling, &parts);
        let p = &map.start;
        let error = largest_column_error(&map.theta_jacobian(p), &by_blocks(&map, p));
        assert!(error < 1e-11, "{error:e}");
    }

    #[test]
    fn modes_far_apart_give_the_block_exponentials_jacobian() {
        // The stator winding's capacitance e^20 below its start (as a fit may probe): its
        // mode decays in picoseconds, e^{μ_i − μ_j} overflows, e^{μ_i} is 0.
        let (parts, scaling) = four_node();
        let map = Parametrisation::of_shape(1.0, scaling, &parts);
        let mut p = map.start.clone();
        p[0] -= 20.0;
        // The spectral route itself, not the fallback a non-finite entry would take.
        let spectrum = map.spectrum(&p).expect("A_c is invertible");
        let d = map.jacobian_of(&map.continuous_derivatives(&p), |e| spectrum.derivative(e));
        assert!(d.iter().all(|v| v.is_finite()));
        // Both are exact to rounding in the largest entries (3·10⁻¹¹); a column of the
        // stiff mode itself (10⁻⁸ here) carries the rounding of the others.
        let reference = by_blocks(&map, &p);
        let error = (&d - &reference).amax() / reference.amax();
        assert!(error < 1e-10, "{error:e}");
    }

    #[test]
    fn a_part_with_no_path_to_the_coolant_falls_back_to_the_block_exponential() {
        // No conductance to the coolant anywhere: L is singular, A_c has the eigenvalue 0
        // and M no full set of eigenvectors.
        let (parts, scaling) = four_node();
        let map = Parametrisation::of_shape(1.0, scaling, &parts);
        let mut p = map.start.clone();
        for i in 0..4 {
            p[4 + i] = f64::NEG_INFINITY;
        }
        assert!(map.spectrum(&p).is_none());
        let d = map.theta_jacobian(&p);
        assert!(d.iter().all(|v| v.is_finite()));
        assert_eq!(d, by_blocks(&map, &p));
    }
}
