//! Output-error refinement of a hidden-state model: Φ, Γ, C (where free), D (where
//! estimated) and each segment's x0 minimising the weighted simulation error
//!
//!   J = ½ Σ_k Σ_j w_j (y_j(k) − ŷ_j(k))²,   ŷ(k) = C x(k) + D u(k),
//!
//! over the observed entries only, by Levenberg–Marquardt (the crate `estimate::oe`
//! uses). w_j = 1/var(y_j): each output counts as its NRMSE fit does, whatever its
//! scale. The Jacobian is exact, from the forward sensitivities
//! ∂x(k+1)/∂θ = Φ ∂x(k)/∂θ + (∂Φ/∂θ) x(k) + (∂Γ/∂θ) u(k), ∂x(s)/∂x0 = I and
//! ∂ŷ(k)/∂θ = C ∂x(k)/∂θ + (∂C/∂θ) x(k) + (∂D/∂θ) u(k): one simulation per entry of Φ,
//! Γ and x0, none for C and D. The full parametrisation is redundant (any change of
//! basis of the hidden states gives the same outputs); LM's damping keeps the steps
//! finite along those directions, as with SITB's free parametrisation.

use std::ops::Range;

use levenberg_marquardt::{LeastSquaresProblem, LevenbergMarquardt};

use crate::estimate::compressed::{noise_tied_ftol, Compressed};
use nalgebra::{DMatrix, DVector, Dyn, Owned};

use super::subspace::{radius_limit, stabilised};
use super::{HiddenError, HiddenStateModel, OutputMatrix};
use crate::estimate::IdentificationData;

/// The residual entry of a refused step (unstable Φ, or a simulation that overflows).
const REFUSED: f64 = 1e10;

/// A refined model and what it cost.
#[derive(Debug, Clone)]
pub struct Refined {
    /// The model.
    pub model: HiddenStateModel,
    /// Each segment's initial state.
    pub initial_states: Vec<DVector<f64>>,
    /// Weighted sum of squared simulation errors 2J at the end.
    pub weighted_sse: f64,
    /// Observed output entries compared.
    pub compared: usize,
    /// Free parameters.
    pub parameters: usize,
    /// Cost evaluations LM took.
    pub evaluations: usize,
}

/// The layout of the parameter vector: Φ (row by row), Γ, C if free, D if estimated,
/// then each segment's x0.
#[derive(Debug, Clone, Copy)]
struct Layout {
    n: usize,
    m: usize,
    p: usize,
    free_c: bool,
    feedthrough: bool,
    segments: usize,
}

impl Layout {
    fn gamma(&self) -> usize {
        self.n * self.n
    }
    fn c(&self) -> usize {
        self.gamma() + self.n * self.m
    }
    fn d(&self) -> usize {
        self.c() + if self.free_c { self.p * self.n } else { 0 }
    }
    fn x0(&self, s: usize) -> usize {
        self.d() + if self.feedthrough { self.p * self.m } else { 0 } + s * self.n
    }
    fn len(&self) -> usize {
        self.x0(self.segments)
    }
}

struct Problem<'a> {
    data: &'a IdentificationData,
    segments: Vec<Range<usize>>,
    layout: Layout,
    fixed_c: DMatrix<f64>,
    sqrt_w: Vec<f64>,
    params: DVector<f64>,
    /// The largest pole modulus a step may reach (`subspace::radius_limit`).
    radius_limit: f64,
}

impl Problem<'_> {
    fn model(&self) -> HiddenStateModel {
        let (l, x) = (self.layout, &self.params);
        let (n, m, p) = (l.n, l.m, l.p);
        HiddenStateModel {
            phi: DMatrix::from_fn(n, n, |i, j| x[i * n + j]),
            gamma: DMatrix::from_fn(n, m, |i, j| x[l.gamma() + i * m + j]),
            c: if l.free_c {
                DMatrix::from_fn(p, n, |i, j| x[l.c() + i * n + j])
            } else {
                self.fixed_c.clone()
            },
            d: if l.feedthrough {
                DMatrix::from_fn(p, m, |i, j| x[l.d() + i * m + j])
            } else {
                DMatrix::zeros(p, m)
            },
            ts_s: self.data.ts_s,
        }
    }

    fn x0(&self, s: usize) -> DVector<f64> {
        let at = self.layout.x0(s);
        DVector::from_column_slice(&self.params.as_slice()[at..at + self.layout.n])
    }

    fn compared(&self, k: usize, j: usize) -> bool {
        self.data.observed(k, j) && self.data.outputs[(k, j)].is_finite()
    }

    /// The states along segment s: column r is x(seg.start + r).
    fn states(&self, model: &HiddenStateModel, s: usize) -> DMatrix<f64> {
        let seg = &self.segments[s];
        let mut xs = DMatrix::zeros(self.layout.n, seg.len());
        let mut x = self.x0(s);
        for (r, k) in seg.clone().enumerate() {
            xs.set_column(r, &x);
            x = &model.phi * &x + &model.gamma * self.input(k);
        }
        xs
    }

    /// Residual entries: the observed outputs compared.
    fn rows(&self) -> usize {
        self.segments
            .iter()
            .flat_map(|seg| seg.clone())
            .map(|k| (0..self.layout.p).filter(|&j| self.compared(k, j)).count())
            .sum()
    }

    fn input(&self, k: usize) -> DVector<f64> {
        DVector::from_fn(self.layout.m, |l, _| self.data.inputs[(k, l)])
    }

    fn residuals_of(&self, model: &HiddenStateModel) -> Vec<f64> {
        let mut r = Vec::new();
        for (s, seg) in self.segments.iter().enumerate() {
            let xs = self.states(model, s);
            for (i, k) in seg.clone().enumerate() {
                let y = &model.c * xs.column(i) + &model.d * self.input(k);
                for j in (0..self.layout.p).filter(|&j| self.compared(k, j)) {
                    r.push(self.sqrt_w[j] * (self.data.outputs[(k, j)] - y[j]));
                }
            }
        }
        r
    }

    /// The Jacobian of the residuals (rows as [`Problem::residuals_of`]).
    fn jacobian_of(&self, model: &HiddenStateModel) -> DMatrix<f64> {
        let l = self.layout;
        let rows = self.rows();
        let mut jac = DMatrix::zeros(rows, l.len());
        let mut row0 = 0;
        for (s, seg) in self.segments.iter().enumerate() {
            let xs = self.states(model, s);
            let seg_rows: Vec<(usize, usize)> = seg
                .clone()
                .enumerate()
                .flat_map(|(i, k)| {
                    (0..l.p)
                        .filter(move |&j| self.compared(k, j))
                        .map(move |j| (i, j))
                })
                .collect();
            // Parameters acting through the states: Φ, Γ and this segment's x0, their
            // sensitivities ∂x/∂θ propagated together as one n × (n² + nm + n) matrix (one
            // product a step rather than a simulation per parameter).
            let q_state = l.c();
            let mut sens = DMatrix::zeros(l.n, q_state + l.n);
            sens.view_mut((0, q_state), (l.n, l.n)).fill_with_identity();
            let mut next = sens.clone();
            let mut dy = DMatrix::zeros(l.p, q_state + l.n);
            let mut cursor = 0;
            for (i, k) in seg.clone().enumerate() {
                dy.gemm(1.0, &model.c, &sens, 0.0);
                while cursor < seg_rows.len() && seg_rows[cursor].0 == i {
                    let j = seg_rows[cursor].1;
                    let w = -self.sqrt_w[j];
                    for q in 0..q_state {
                        jac[(row0 + cursor, q)] = w * dy[(j, q)];
                    }
                    for a in 0..l.n {
                        jac[(row0 + cursor, l.x0(s) + a)] = w * dy[(j, q_state + a)];
                    }
                    cursor += 1;
                }
                next.gemm(1.0, &model.phi, &sens, 0.0);
                for a in 0..l.n {
                    for b in 0..l.n {
                        next[(a, a * l.n + b)] += xs[(b, i)];
                    }
                    for b in 0..l.m {
                        next[(a, l.gamma() + a * l.m + b)] += self.data.inputs[(k, b)];
                    }
                }
                std::mem::swap(&mut sens, &mut next);
            }
            // C and D act on the output directly.
            for (cursor, &(i, j)) in seg_rows.iter().enumerate() {
                let k = seg.start + i;
                let w = -self.sqrt_w[j];
                if l.free_c {
                    for a in 0..l.n {
                        jac[(row0 + cursor, l.c() + j * l.n + a)] = w * xs[(a, i)];
                    }
                }
                if l.feedthrough {
                    for b in 0..l.m {
                        jac[(row0 + cursor, l.d() + j * l.m + b)] = w * self.data.inputs[(k, b)];
                    }
                }
            }
            row0 += seg_rows.len();
        }
        jac
    }
}

impl LeastSquaresProblem<f64, Dyn, Dyn> for Problem<'_> {
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
        // A step out of the stable region (ρ(Φ) ≥ ρ_max < 1, `subspace::radius_limit`)
        // is refused: an output-error model must simulate, and on a short record a
        // mildly unstable Φ (ρ = 1.003, the glass furnace's drift) or an integrator can
        // fit the estimation data better while it diverges or drifts on any later data.
        // A residual larger than any the start gave makes LM refuse the step and raise
        // its damping, where `None` would end the minimisation; the start is inside
        // (`subspace::stabilised`), so every accepted point is.
        let model = self.model();
        if !(model.spectral_radius() < self.radius_limit) {
            return Some(DVector::from_element(self.rows(), REFUSED));
        }
        // A step to a barely stable Φ may still overflow the simulation: the same.
        let r = self.residuals_of(&model);
        Some(DVector::from_iterator(
            r.len(),
            r.into_iter().map(|v| {
                if v.is_finite() {
                    v.clamp(-REFUSED, REFUSED)
                } else {
                    REFUSED
                }
            }),
        ))
    }

    fn jacobian(&self) -> Option<DMatrix<f64>> {
        let j = self.jacobian_of(&self.model());
        j.iter().all(|v| v.is_finite()).then_some(j)
    }
}

/// Per output, 1/var(y_j) over its observed values (1 where it does not vary).
pub(crate) fn output_weights(data: &IdentificationData) -> Vec<f64> {
    (0..data.states())
        .map(|j| {
            let v: Vec<f64> = (0..data.len())
                .filter(|&k| data.observed(k, j) && data.outputs[(k, j)].is_finite())
                .map(|k| data.outputs[(k, j)])
                .collect();
            let mean = v.iter().sum::<f64>() / v.len().max(1) as f64;
            let var = v.iter().map(|y| (y - mean).powi(2)).sum::<f64>() / v.len().max(1) as f64;
            if var > 0.0 {
                1.0 / var
            } else {
                1.0
            }
        })
        .collect()
}

/// Refines `start` on `data` by output error. C stays fixed where `output_matrix` is
/// [`OutputMatrix::Measured`] (`start` must then be in that basis); D is estimated
/// where `feedthrough`, else held at zero.
pub fn refine(
    data: &IdentificationData,
    start: &HiddenStateModel,
    output_matrix: OutputMatrix,
    feedthrough: bool,
) -> Result<Refined, HiddenError> {
    let segments = data.segments();
    let (n, m, p) = (start.order(), data.input_count(), data.states());
    let layout = Layout {
        n,
        m,
        p,
        free_c: output_matrix == OutputMatrix::Free,
        feedthrough,
        segments: segments.len(),
    };
    let mut params = DVector::zeros(layout.len());
    let put = |params: &mut DVector<f64>, at: usize, mat: &DMatrix<f64>| {
        for (i, row) in mat.row_iter().enumerate() {
            for (j, v) in row.iter().enumerate() {
                params[at + i * mat.ncols() + j] = *v;
            }
        }
    };
    // Inside the unit circle, where every step must stay (a no-op for the subspace start).
    let longest = segments.iter().map(|s| s.len()).max().unwrap_or(1);
    put(
        &mut params,
        0,
        &stabilised(start.phi.clone(), radius_limit(longest)),
    );
    put(&mut params, layout.gamma(), &start.gamma);
    if layout.free_c {
        put(&mut params, layout.c(), &start.c);
    }
    if feedthrough {
        put(&mut params, layout.d(), &start.d);
    }
    for (s, seg) in segments.iter().enumerate() {
        let x0 = start.fitted_initial_state(data, seg.clone());
        params.rows_mut(layout.x0(s), n).copy_from(&x0);
    }
    let problem = Problem {
        data,
        segments,
        layout,
        fixed_c: start.c.clone(),
        sqrt_w: output_weights(data).iter().map(|w| w.sqrt()).collect(),
        params,
        radius_limit: radius_limit(longest),
    };
    // Through p + 1 rows: the same steps at the cost of the parameters, not the rows.
    let (solved, report) = LevenbergMarquardt::new()
        .with_patience(30)
        .with_ftol(noise_tied_ftol(problem.rows()))
        .with_xtol(1e-10)
        .with_gtol(1e-10)
        .minimize(Compressed::new(problem));
    let solved = solved.into_inner();
    if !report.objective_function.is_finite() {
        return Err(HiddenError::Diverged);
    }
    let model = solved.model();
    // Refused steps keep ρ < 1 from a stable start; an unstable start stays where it was.
    let radius = model.spectral_radius();
    if !(radius < 1.0) {
        return Err(HiddenError::Unstable { order: n, radius });
    }
    let residuals = solved.residuals_of(&model);
    Ok(Refined {
        initial_states: (0..layout.segments).map(|s| solved.x0(s)).collect(),
        weighted_sse: residuals.iter().map(|r| r * r).sum(),
        compared: residuals.len(),
        parameters: layout.len(),
        evaluations: report.number_of_evaluations,
        model,
    })
}

/// The simulation errors of `model` on `data` linearised in its parameters: what
/// the covariance of a refined model is made from (`super::covariance`).
#[derive(Debug, Clone)]
pub(crate) struct Linearised {
    /// ∂(y − ŷ)/∂θ, one row per observed output entry (segment by segment, instant by
    /// instant, output by output), unweighted; the columns θ laid out as `refine` lays
    /// them out: Φ row by row (n²), Γ row by row (n·m), C row by row (p·n) where free,
    /// D row by row (p·m) where estimated, then each segment's x0 (n each).
    pub jacobian: DMatrix<f64>,
    /// y − ŷ per row.
    pub residuals: Vec<f64>,
    /// The output each row compares.
    pub outputs: Vec<usize>,
    /// The instant of each row: (its segment's place in `data.segments()`, the row index
    /// k of the data), for the residuals' correlation in time.
    pub instants: Vec<(usize, usize)>,
}

/// [`Linearised`] at `model` with each segment's initial state `initial_states` (one per
/// `data.segments()`), the parameters free as `refine` frees them (`output_matrix`,
/// `feedthrough`). The same exact sensitivities LM used, with unit weights.
pub(crate) fn linearised_at(
    data: &IdentificationData,
    model: &HiddenStateModel,
    initial_states: &[DVector<f64>],
    output_matrix: OutputMatrix,
    feedthrough: bool,
) -> Linearised {
    let segments = data.segments();
    let (n, m, p) = (model.order(), model.gamma.ncols(), model.c.nrows());
    let layout = Layout {
        n,
        m,
        p,
        free_c: output_matrix == OutputMatrix::Free,
        feedthrough,
        segments: segments.len(),
    };
    let mut params = DVector::zeros(layout.len());
    let mut put = |at: usize, mat: &DMatrix<f64>| {
        for (i, row) in mat.row_iter().enumerate() {
            for (j, v) in row.iter().enumerate() {
                params[at + i * mat.ncols() + j] = *v;
            }
        }
    };
    put(0, &model.phi);
    put(layout.gamma(), &model.gamma);
    if layout.free_c {
        put(layout.c(), &model.c);
    }
    if feedthrough {
        put(layout.d(), &model.d);
    }
    for (s, x0) in initial_states.iter().enumerate().take(layout.segments) {
        params.rows_mut(layout.x0(s), n).copy_from(x0);
    }
    let problem = Problem {
        data,
        segments,
        layout,
        fixed_c: model.c.clone(),
        sqrt_w: vec![1.0; p],
        params,
        radius_limit: 1.0,
    };
    let at = &problem;
    let (instants, outputs) = at
        .segments
        .iter()
        .enumerate()
        .flat_map(|(s, seg)| seg.clone().map(move |k| (s, k)))
        .flat_map(|(s, k)| {
            (0..p)
                .filter(move |&j| at.compared(k, j))
                .map(move |j| ((s, k), j))
        })
        .unzip();
    Linearised {
        jacobian: problem.jacobian_of(model),
        residuals: problem.residuals_of(model),
        outputs,
        instants,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::hidden::subspace::{decompose, horizon_for};
    use crate::hidden::testing::{known_system, simulate_known};

    fn perturbed(model: &HiddenStateModel) -> HiddenStateModel {
        HiddenStateModel {
            phi: model.phi.map(|v| v * 1.01),
            gamma: model.gamma.map(|v| v * 0.9),
            ..model.clone()
        }
    }

    #[test]
    fn the_jacobian_is_the_residuals_derivative() {
        let truth = known_system();
        let data = simulate_known(&truth, 300, 0.01, 3);
        let start = perturbed(&truth);
        for (output_matrix, feedthrough) in
            [(OutputMatrix::Free, true), (OutputMatrix::Measured, false)]
        {
            let layout = Layout {
                n: 3,
                m: 2,
                p: 2,
                free_c: output_matrix == OutputMatrix::Free,
                feedthrough,
                segments: 1,
            };
            let mut problem = Problem {
                data: &data,
                segments: data.segments(),
                layout,
                fixed_c: start.c.clone(),
                sqrt_w: vec![1.0, 2.0],
                params: DVector::from_fn(layout.len(), |i, _| 0.01 * (i % 7) as f64),
                radius_limit: 1.0,
            };
            problem
                .params
                .rows_mut(0, 9)
                .copy_from_slice(start.phi.transpose().as_slice());
            let jac = problem.jacobian().unwrap();
            let r0 = problem.residuals().unwrap();
            for q in 0..layout.len() {
                let h = 1e-6;
                let mut moved = problem.params.clone();
                moved[q] += h;
                problem.set_params(&moved);
                let numeric = (problem.residuals().unwrap() - &r0) / h;
                moved[q] -= h;
                problem.set_params(&moved);
                let err = (numeric - jac.column(q)).abs().max();
                assert!(
                    err < 1e-4 * (1.0 + jac.column(q).abs().max()),
                    "param {q}: {err}"
                );
            }
        }
    }

    #[test]
    fn an_unstable_start_is_pulled_inside_and_the_refinement_stays_there() {
        // Φ scaled by 1.03: its slowest pole at 1.0146, outside the unit circle.
        let truth = known_system();
        let data = simulate_known(&truth, 1500, 0.01, 11);
        let start = HiddenStateModel {
            phi: truth.phi.map(|v| v * 1.03),
            ..truth.clone()
        };
        assert!(start.spectral_radius() > 1.0);
        let refined = refine(&data, &start, OutputMatrix::Measured, false).unwrap();
        // The same minimum as from the truth itself (the noise moves both alike).
        let reference = refine(&data, &truth, OutputMatrix::Measured, false).unwrap();
        let got = refined.model.time_constants_s().unwrap();
        let want = reference.model.time_constants_s().unwrap();
        for (g, w) in got.iter().zip(&want) {
            assert!((g / w - 1.0).abs() < 0.01, "{got:?} vs {want:?}");
        }
        assert!(refined.weighted_sse <= reference.weighted_sse * (1.0 + 1e-6));
    }

    #[test]
    fn a_step_out_of_the_stable_region_is_refused() {
        let truth = known_system();
        let data = simulate_known(&truth, 300, 0.01, 3);
        let layout = Layout {
            n: 3,
            m: 2,
            p: 2,
            free_c: false,
            feedthrough: false,
            segments: 1,
        };
        // Outside the unit circle (ρ = 1.0047), and inside it but past the record's bound
        // (ρ = 0.9990 > exp(−1/300) = 0.9967, τ = 1000 s on a 300 s record): both refused;
        // the truth (ρ = 0.985) is not.
        for (scale, refused) in [(1.02, true), (0.999 / 0.985, true), (1.0, false)] {
            let mut params = DVector::zeros(layout.len());
            let phi = truth.phi.map(|v| v * scale);
            for (i, row) in phi.row_iter().enumerate() {
                for (j, v) in row.iter().enumerate() {
                    params[i * 3 + j] = *v;
                }
            }
            let problem = Problem {
                data: &data,
                segments: data.segments(),
                layout,
                fixed_c: truth.c.clone(),
                sqrt_w: vec![1.0, 1.0],
                params,
                radius_limit: radius_limit(300),
            };
            let r = problem.residuals().unwrap();
            assert_eq!(r.len(), 600);
            assert_eq!(r.iter().all(|&v| v == REFUSED), refused, "scale {scale}");
        }
    }

    #[test]
    fn noisy_data_give_the_time_constants_of_the_hidden_state_system() {
        let truth = known_system();
        let data = simulate_known(&truth, 3000, 0.01, 5);
        let start = decompose(&data, horizon_for(6, 2))
            .unwrap()
            .model(&data, 3, false, OutputMatrix::Measured)
            .unwrap();
        let refined = refine(&data, &start, OutputMatrix::Measured, false).unwrap();
        let got = refined.model.time_constants_s().unwrap();
        let want = truth.time_constants_s().unwrap();
        for (g, w) in got.iter().zip(&want) {
            assert!((g / w - 1.0).abs() < 0.03, "{got:?} vs {want:?}");
        }
        // The weighted residual is the noise: σ² w_j per entry, summed.
        assert!(refined.weighted_sse / (refined.compared as f64) < 1.0);
    }
}
