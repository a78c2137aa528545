//! The prediction-error fit (see [`super`]): Levenberg–Marquardt over [Θ; K (where it is
//! free, not given with a disturbance state); x̂(start) of each segment], its Jacobian by
//! the predictor's forward sensitivities, two passes of weights, and the covariance of Θ
//! from the innovations' Gauss–Newton information.

use std::cell::RefCell;
use std::ops::Range;

use levenberg_marquardt::{LeastSquaresProblem, LevenbergMarquardt};
use nalgebra::{DMatrix, DVector, Dyn, Owned};

use super::{PredictionError, Predictor};
use crate::estimate::kernels::add_matrix_vector;
use crate::estimate::normal_equations::RowBlock;
use crate::estimate::oe::{
    cached, compared_instants, covariance_from_gram, normalised_inverse, Evaluation, Reporting,
    MAX_ESTIMATED_INITIAL_STATES,
};
use crate::estimate::{
    check_enough_rows, DiscreteModel, Estimate, EstimationError, Estimator, IdentificationData,
    Result,
};

/// How the predictor's gain is found.
#[derive(Debug, Clone)]
pub(super) enum GainModel {
    /// K (n × n) free among the parameters, x alone (white process noise).
    Free,
    /// K_a ((n + 1) × n) given, from the Riccati equation of a disturbance's intensity;
    /// d enters `state`.
    Disturbance {
        /// The state d enters.
        state: usize,
        /// K_a = [K; k_d].
        gain: DMatrix<f64>,
    },
}

/// The prediction-error fit of [`PredictionError::refine`] with the gain `gain_model`
/// gives: Θ and the start states (and K where it is free).
pub(super) fn fit(
    pem: &PredictionError,
    data: &IdentificationData,
    start: &Estimate,
    initial_states: &[DVector<f64>],
    gain_model: &GainModel,
) -> Result<Estimate> {
    let segments = data.segments();
    let rows_used = compared_instants(data, &segments);
    check_enough_rows(data, rows_used)?;
    let weights = match &pem.weights {
        Some(w) => w.clone(),
        None => normalised_inverse(
            &start
                .noise_variance
                .iter()
                .map(|v| v.max(1e-24))
                .collect::<Vec<_>>(),
        ),
    };
    let mut problem = Problem::new(data, segments, &start.model, initial_states, &weights);
    if let GainModel::Disturbance { state, gain } = gain_model {
        problem.fix_gain(*state, gain.clone());
    }
    problem.progress = Some(Reporting::new(&pem.progress, pem.method().name()));
    let (problem, evaluations) = minimise(problem, pem.weights.is_some())?;
    Ok(conclude(&problem, rows_used, evaluations))
}

/// The innovations' variance per output, SSE_c / N_c, of the predictor with Θ of
/// `model`, the given K_a (d entering `state`) and each segment's x̂(start) held at
/// `initial_states`: one pass of the filter, no sensitivities, the profile
/// ℓ(q | Θ) = −½ Σ_c N_c ln σ̂_c²(q, Θ) the disturbance's search runs on (a fit costs
/// hundreds of such passes). `None` where Φ or the predictor is not stable.
pub(super) fn innovation_variance(
    data: &IdentificationData,
    model: &DiscreteModel,
    initial_states: &[DVector<f64>],
    state: usize,
    gain: DMatrix<f64>,
) -> Option<Vec<f64>> {
    let n = data.states();
    let mut problem = Problem::new(data, data.segments(), model, initial_states, &vec![1.0; n]);
    problem.fix_gain(state, gain);
    if !problem.stable() {
        return None;
    }
    let sse = problem.pass(None);
    let variance: Vec<f64> = sse
        .iter()
        .zip(&problem.counts)
        .map(|(s, c)| s / (*c).max(1) as f64)
        .collect();
    variance.iter().all(|v| v.is_finite()).then_some(variance)
}

/// Levenberg–Marquardt, in two passes when no weights are given: the second with Λ⁻¹ of
/// the first pass's innovations.
fn minimise(mut problem: Problem<'_>, weights_given: bool) -> Result<(Problem<'_>, usize)> {
    let lm = LevenbergMarquardt::new()
        .with_patience(200)
        .with_ftol(1e-10)
        .with_xtol(1e-10)
        .with_gtol(1e-10);
    let mut evaluations = 0;
    for pass in 0..2 {
        let (solved, report) = lm.minimize(problem);
        problem = solved;
        evaluations += report.number_of_evaluations;
        if !report.objective_function.is_finite() || problem.evaluated().diverged() {
            return Err(EstimationError::MinimisationFailed {
                termination: report.termination,
            });
        }
        if pass == 1 || weights_given {
            break;
        }
        let next = problem.innovation_weights();
        let change = crate::estimate::oe::largest_relative_change(&next, &problem.sqrt_w);
        problem.sqrt_w = next;
        *problem.cache.borrow_mut() = None;
        if change < 0.05 {
            break;
        }
    }
    Ok((problem, evaluations))
}

/// The estimate at the minimum: Θ's block of σ² (JᵀJ)⁻¹ (the innovations' Gauss–Newton
/// information, K and the start states among the nuisance parameters), the innovations'
/// variance per output as the noise variance, and the predictor.
fn conclude(problem: &Problem, rows_used: usize, evaluations: usize) -> Estimate {
    let n = problem.n;
    let evaluation = problem.evaluate_full();
    let entries: usize = problem.counts.iter().sum();
    let dof = entries.saturating_sub(problem.params.len()).max(1) as f64;
    let sigma2 = evaluation.sse.iter().sum::<f64>() / dof;
    let (full, condition_number) = covariance_from_gram(&evaluation.gram, sigma2);
    let p_theta = problem.p_theta();
    let noise_variance: Vec<f64> = (0..n)
        .map(|c| {
            let w = problem.sqrt_w[c].powi(2).max(1e-300);
            evaluation.sse[c] / problem.counts[c].max(1) as f64 / w
        })
        .collect();
    Estimate {
        model: problem.model(),
        method: crate::estimate::Method::Pem,
        rows_used,
        condition_number,
        covariance: Some(full.view((0, 0), (p_theta, p_theta)).into_owned()),
        robust_covariance: None,
        noise_variance: noise_variance.clone(),
        iterations: evaluations,
        output_offset: None,
        trajectory: None,
        network: None,
        predictor: Some(Box::new(Predictor {
            gain: problem.gain(),
            disturbance: problem.disturbance.map(|state| super::Disturbance {
                state,
                gain: problem.disturbance_gain().unwrap_or_default(),
                increment_sd: 0.0,
            }),
            innovation_variance: noise_variance,
            initial_states: (0..problem.segments.len())
                .map(|s| DVector::from_column_slice(problem.x0(s)))
                .collect(),
        })),
    }
}

/// The least-squares problem LM sees: parameters [Θ; K (row-major) where it is free;
/// x̂(start) of each segment, where estimated]. A given K_a ([`GainModel::Disturbance`])
/// is held apart.
struct Problem<'a> {
    data: &'a IdentificationData,
    segments: Vec<Range<usize>>,
    /// Where each segment's start state is in the parameters, where it is estimated.
    x0_at: Vec<Option<usize>>,
    /// Each segment's start state as given (used where it is not estimated).
    fixed_x0: Vec<DVector<f64>>,
    /// Observed entries per output over the segments.
    counts: Vec<usize>,
    sqrt_w: Vec<f64>,
    n: usize,
    /// The state the disturbance d enters, where the predictor has one.
    disturbance: Option<usize>,
    /// K_a where it is given, not fitted.
    fixed_gain: Option<DMatrix<f64>>,
    m: usize,
    params: DVector<f64>,
    cache: RefCell<Option<(DVector<f64>, Evaluation)>>,
    progress: Option<Reporting>,
}

impl<'a> Problem<'a> {
    fn new(
        data: &'a IdentificationData,
        segments: Vec<Range<usize>>,
        start: &DiscreteModel,
        initial_states: &[DVector<f64>],
        weights: &[f64],
    ) -> Problem<'a> {
        let (n, m) = (data.states(), data.input_count());
        let estimate_x0 = segments.len() <= MAX_ESTIMATED_INITIAL_STATES;
        let fixed_x0: Vec<DVector<f64>> = segments
            .iter()
            .enumerate()
            .map(|(s, seg)| {
                initial_states
                    .get(s)
                    .cloned()
                    .unwrap_or_else(|| start.initial_state(data, seg.clone()))
            })
            .collect();
        let mut params = start.theta();
        // K = 0: the predictor starts as the simulation.
        params.extend(std::iter::repeat_n(0.0, n * n));
        let p_fixed = params.len();
        if estimate_x0 {
            params.extend(fixed_x0.iter().flat_map(|x| x.iter().copied()));
        }
        let x0_at = (0..segments.len())
            .map(|s| estimate_x0.then_some(p_fixed + s * n))
            .collect();
        let counts = data.observed_counts(&segments);
        Problem {
            data,
            segments,
            x0_at,
            fixed_x0,
            counts,
            sqrt_w: weights.iter().map(|v| v.max(0.0).sqrt()).collect(),
            n,
            disturbance: None,
            fixed_gain: None,
            m,
            params: DVector::from_vec(params),
            cache: RefCell::new(None),
            progress: None,
        }
    }

    /// Holds K_a as given (d entering `state`): K leaves the parameters.
    fn fix_gain(&mut self, state: usize, gain: DMatrix<f64>) {
        let n = self.n;
        let at = self.p_theta();
        let mut params: Vec<f64> = self.params.iter().copied().collect();
        params.drain(at..at + n * n);
        self.params = DVector::from_vec(params);
        for x0 in self.x0_at.iter_mut().flatten() {
            *x0 -= n * n;
        }
        self.disturbance = Some(state);
        self.fixed_gain = Some(gain);
    }

    /// The columns of K among the parameters: n² where it is free, 0 where given.
    fn gain_columns(&self) -> usize {
        if self.fixed_gain.is_some() {
            0
        } else {
            self.n * self.n
        }
    }

    fn p_theta(&self) -> usize {
        self.n * (self.n + self.m)
    }

    /// K_a: (n + 1) × n as given with a disturbance (its last row d's), else K, n × n,
    /// from the parameters.
    fn augmented_gain(&self) -> DMatrix<f64> {
        match &self.fixed_gain {
            Some(k) => k.clone(),
            None => {
                let at = self.p_theta();
                DMatrix::from_row_slice(
                    self.n,
                    self.n,
                    &self.params.as_slice()[at..at + self.n * self.n],
                )
            }
        }
    }

    /// d's row of K_a, where there is a disturbance.
    fn disturbance_gain(&self) -> Option<Vec<f64>> {
        let k = self.fixed_gain.as_ref()?;
        Some(k.row(self.n).iter().copied().collect())
    }

    fn model(&self) -> DiscreteModel {
        DiscreteModel::from_theta(
            self.n,
            self.m,
            self.data.ts_s,
            &self.params.as_slice()[..self.p_theta()],
        )
    }

    /// K, n × n: x's rows of the gain.
    fn gain(&self) -> DMatrix<f64> {
        self.augmented_gain().rows(0, self.n).into_owned()
    }

    fn x0(&self, s: usize) -> &[f64] {
        match self.x0_at[s] {
            Some(at) => &self.params.as_slice()[at..at + self.n],
            None => self.fixed_x0[s].as_slice(),
        }
    }

    /// √w_i from Λ⁻¹ of the current innovations (normalised to mean 1).
    fn innovation_weights(&self) -> Vec<f64> {
        let sse = self.pass(None);
        let variances: Vec<f64> = (0..self.n)
            .map(|c| (sse[c] / self.sqrt_w[c].powi(2) / self.counts[c].max(1) as f64).max(1e-30))
            .collect();
        normalised_inverse(&variances)
            .iter()
            .map(|v| v.sqrt())
            .collect()
    }

    /// The weighted squared innovations per output and the normal equations JᵀJ, Jᵀr.
    fn evaluate_full(&self) -> Evaluation {
        let cols = self.params.len();
        let mut gram = DMatrix::<f64>::zeros(cols, cols);
        let mut grad = DVector::<f64>::zeros(cols);
        let sse = self.pass(Some((&mut gram, &mut grad)));
        if let Some(reporting) = &self.progress {
            reporting.evaluated(&sse);
        }
        Evaluation { sse, gram, grad }
    }

    /// One pass of the predictor over the data: the weighted squared innovations per
    /// output and, when asked, the normal equations (J never stored).
    fn pass(&self, mut normal: Option<(&mut DMatrix<f64>, &mut DVector<f64>)>) -> Vec<f64> {
        let n = self.n;
        let mut state = Filter::new(
            &self.model(),
            (&self.augmented_gain(), self.fixed_gain.is_none()),
            self.disturbance,
            self.x0_at.iter().any(Option::is_some),
        );
        let mut block = RowBlock::new();
        let mut sse = vec![0.0; n];
        for (s, seg) in self.segments.iter().enumerate() {
            state.reset(self.x0(s));
            let x0_at = self.x0_at[s];
            if let Some((gram, grad)) = normal.as_mut() {
                block.set_columns(self.segment_columns(x0_at), gram, grad);
            }
            for k in seg.clone() {
                state.innovate(self.data, k);
                for c in (0..n).filter(|&c| self.data.observed(k, c)) {
                    let r = self.sqrt_w[c] * state.e[c];
                    sse[c] += r * r;
                    if let Some((gram, grad)) = normal.as_mut() {
                        let row = block.push(r, gram, grad);
                        state.jacobian_row(c, self.sqrt_w[c], x0_at.is_some(), row);
                    }
                }
                if k + 1 < seg.end {
                    if normal.is_some() {
                        state.propagate_sensitivities(x0_at.is_some());
                    }
                    state.step();
                }
            }
        }
        if let Some((gram, grad)) = normal {
            block.flush(gram, grad);
            let cols = gram.nrows();
            for a in 0..cols {
                for b in 0..a {
                    gram[(a, b)] = gram[(b, a)];
                }
            }
        }
        sse
    }

    /// The columns of J a segment's rows touch, increasing: Θ, K where it is free, the
    /// segment's x̂(start) where it is estimated.
    fn segment_columns(&self, x0_at: Option<usize>) -> impl Iterator<Item = usize> {
        let n = self.n;
        (0..self.p_theta() + self.gain_columns())
            .chain(x0_at.into_iter().flat_map(move |at| at..at + n))
    }

    /// Whether Φ and the predictor's Φ_a − K_a C_a (every output observed) are stable.
    fn stable(&self) -> bool {
        use crate::thermal::matrix::spectral_radius;
        let model = self.model();
        let n = self.n;
        let k = self.augmented_gain();
        let predictor = match self.disturbance {
            Some(state) => {
                let mut a = augmented_phi(&model.phi, state);
                let mut kc = DMatrix::zeros(n + 1, n + 1);
                kc.view_mut((0, 0), (n + 1, n)).copy_from(&k);
                a -= kc;
                a
            }
            None => &model.phi - k,
        };
        model.is_stable() && spectral_radius(&predictor) < 1.0
    }

    /// The evaluation at the current parameters, computed once per parameter vector.
    fn evaluated(&self) -> std::cell::Ref<'_, Evaluation> {
        cached(&self.cache, &self.params, || self.evaluate_full())
    }
}

/// Whether an evaluation ran away: a non-finite sum, an unstable predictor's mark.
trait Diverged {
    fn diverged(&self) -> bool;
}

impl Diverged for Evaluation {
    fn diverged(&self) -> bool {
        !self.sse.iter().all(|v| v.is_finite())
    }
}

/// Φ_a = [Φ e_j; 0 1]: x with the disturbance d, a random walk, entering state j.
pub(super) fn augmented_phi(phi: &DMatrix<f64>, state: usize) -> DMatrix<f64> {
    let n = phi.nrows();
    let mut a = DMatrix::zeros(n + 1, n + 1);
    a.view_mut((0, 0), (n, n)).copy_from(phi);
    a[(state, n)] = 1.0;
    a[(n, n)] = 1.0;
    a
}

/// The predictor x̂_a (x̂, and d̂ where there is a disturbance: na states), its n
/// innovations and its sensitivities, stepped through one segment in flat, reused
/// buffers: no allocation per instant.
struct Filter {
    n: usize,
    na: usize,
    m: usize,
    /// Φ_a (na × na), Γ_a (na × m, d's row 0), K_a (na × n), row-major.
    phi: Vec<f64>,
    gamma: Vec<f64>,
    gain: Vec<f64>,
    /// Φ_a − K_a M_k C_a of the current instant, row-major.
    a: Vec<f64>,
    x: Vec<f64>,
    x_next: Vec<f64>,
    u: Vec<f64>,
    /// M_k e(k): the innovation where observed, 0 where not.
    e: Vec<f64>,
    observed: Vec<bool>,
    /// The columns of K among the parameters (n² where it is free, 0 where given).
    gain_cols: usize,
    /// sens[c·stride + q] = ∂x̂_c/∂param_q over the segment's columns (Θ, K, x̂(start)):
    /// a state's sensitivities side by side, so that a step propagates them a vector of
    /// parameters at a time and J's row is one slice.
    sens: Vec<f64>,
    sens_next: Vec<f64>,
    /// Entries of a state's row of `sens`: every column a segment can have.
    stride: usize,
}

impl Filter {
    /// The filter of `model` with the gain `gain.0` (K_a), a parameter where `gain.1`.
    fn new(
        model: &DiscreteModel,
        gain: (&DMatrix<f64>, bool),
        disturbance: Option<usize>,
        with_x0: bool,
    ) -> Filter {
        let (gain, free) = gain;
        let (n, m) = (model.phi.nrows(), model.gamma.ncols());
        let phi = match disturbance {
            Some(state) => augmented_phi(&model.phi, state),
            None => model.phi.clone(),
        };
        let na = phi.nrows();
        let gain_cols = if free { n * n } else { 0 };
        let cols = n * (n + m) + gain_cols + if with_x0 { n } else { 0 };
        let gamma = |r: usize, l: usize| if r < n { model.gamma[(r, l)] } else { 0.0 };
        Filter {
            n,
            na,
            m,
            phi: (0..na * na).map(|q| phi[(q / na, q % na)]).collect(),
            gamma: (0..na * m).map(|q| gamma(q / m, q % m)).collect(),
            gain: (0..na * n).map(|q| gain[(q / n, q % n)]).collect(),
            a: vec![0.0; na * na],
            x: vec![0.0; na],
            x_next: vec![0.0; na],
            u: vec![0.0; m],
            e: vec![0.0; n],
            observed: vec![false; n],
            gain_cols,
            sens: vec![0.0; cols * na],
            sens_next: vec![0.0; cols * na],
            stride: cols,
        }
    }

    /// x̂(start) = x0 and d̂(start) = 0 (the disturbance is what moved since the start;
    /// a constant part would be a heat the inputs miss throughout), ∂x̂_a/∂(Θ, K_a) = 0,
    /// ∂x̂/∂x0 = I.
    fn reset(&mut self, x0: &[f64]) {
        self.x.iter_mut().for_each(|v| *v = 0.0);
        self.x[..self.n].copy_from_slice(x0);
        self.sens.iter_mut().for_each(|v| *v = 0.0);
        let at = self.x0_column();
        if at + self.n <= self.stride {
            for q in 0..self.n {
                self.sens[q * self.stride + at + q] = 1.0;
            }
        }
    }

    /// The first column of x̂(start) among the segment's columns.
    fn x0_column(&self) -> usize {
        self.n * (self.n + self.m) + self.gain_cols
    }

    /// e(k) = y(k) − x̂(k) where observed (0 where not), and u(k).
    fn innovate(&mut self, data: &IdentificationData, k: usize) {
        for c in 0..self.n {
            self.observed[c] = data.observed(k, c);
            self.e[c] = if self.observed[c] {
                data.outputs[(k, c)] - self.x[c]
            } else {
                0.0
            };
        }
        for (l, u) in self.u.iter_mut().enumerate() {
            *u = data.inputs[(k, l)];
        }
    }

    /// ∂x̂_a(k+1)/∂θ = (Φ_a − K_a M_k C_a) ∂x̂_a(k)/∂θ + the direct terms: φ_j(k) in row
    /// i for Θ_ij (φ = [x̂ᵀ uᵀ]ᵀ), (M_k e)_j in row i for a free K_ij, none for
    /// x̂(start); before [`Filter::step`].
    ///
    /// Each entry is summed in a register through the na rows it depends on (A_c0
    /// ∂x̂_0/∂θ_q + … in that order, then its direct term), a vector of parameters at a
    /// time: every entry the same to the bit as one summed on its own. Compiled for AVX2
    /// where the processor has it, with na known for the usual three to five states.
    fn propagate_sensitivities(&mut self, with_x0: bool) {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the processor has AVX2, checked just above.
            unsafe { self.propagate_avx2(with_x0) };
            return;
        }
        self.propagate_portable(with_x0);
    }

    /// [`Filter::propagate_sensitivities`] compiled for AVX2 (the same operations in the
    /// same order: the same bits).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn propagate_avx2(&mut self, with_x0: bool) {
        self.propagate_portable(with_x0);
    }

    /// [`Filter::propagate_sensitivities`] for any processor; inlined into each
    /// compiled variant.
    #[inline(always)]
    fn propagate_portable(&mut self, with_x0: bool) {
        let (n, na) = (self.n, self.na);
        for c in 0..na {
            for l in 0..na {
                let k = if l < n && self.observed[l] {
                    self.gain[c * n + l]
                } else {
                    0.0
                };
                self.a[c * na + l] = self.phi[c * na + l] - k;
            }
        }
        let cols = self.x0_column() + if with_x0 { n } else { 0 };
        match na {
            3 => self.transition_with::<3>(cols),
            4 => self.transition_with::<4>(cols),
            5 => self.transition_with::<5>(cols),
            _ => self.transition_any(cols),
        }
        self.add_direct_terms();
        std::mem::swap(&mut self.sens, &mut self.sens_next);
    }

    /// sens_next = (Φ_a − K_a M_k C_a) sens over the first `cols` columns, for NA states
    /// known when compiled: the rows' loop unrolls and each entry's sum stays in a
    /// register.
    #[inline(always)]
    fn transition_with<const NA: usize>(&mut self, cols: usize) {
        let stride = self.stride;
        let rows: [&[f64]; NA] = std::array::from_fn(|l| &self.sens[l * stride..][..cols]);
        for c in 0..NA {
            let factors: [f64; NA] = std::array::from_fn(|l| self.a[c * NA + l]);
            let next = &mut self.sens_next[c * stride..][..cols];
            for (q, slot) in next.iter_mut().enumerate() {
                let mut acc = 0.0;
                for (f, row) in factors.iter().zip(&rows) {
                    acc += f * row[q];
                }
                *slot = acc;
            }
        }
    }

    /// [`Filter::transition_with`] for any number of states.
    #[inline(always)]
    fn transition_any(&mut self, cols: usize) {
        let (na, stride) = (self.na, self.stride);
        for c in 0..na {
            let next = &mut self.sens_next[c * stride..][..cols];
            for (q, slot) in next.iter_mut().enumerate() {
                let mut acc = 0.0;
                for l in 0..na {
                    acc += self.a[c * na + l] * self.sens[l * stride + q];
                }
                *slot = acc;
            }
        }
    }

    /// The direct terms of [`Filter::propagate_sensitivities`], added after the
    /// transition: φ_j(k) in row i for Θ_ij, (M_k e)_j in row i for a free K_ij.
    #[inline(always)]
    fn add_direct_terms(&mut self) {
        let (n, p, stride) = (self.n, self.n + self.m, self.stride);
        let p_theta = n * p;
        for q in 0..p_theta {
            let (i, j) = (q / p, q % p);
            self.sens_next[i * stride + q] += if j < n { self.x[j] } else { self.u[j - n] };
        }
        for q in p_theta..p_theta + self.gain_cols {
            let (i, j) = ((q - p_theta) / n, (q - p_theta) % n);
            self.sens_next[i * stride + q] += self.e[j];
        }
    }

    /// x̂_a(k+1) = Φ_a x̂_a(k) + Γ_a u(k) + K_a M_k e(k).
    ///
    /// Every state's sum is carried at once, term by term in the order written (Φ_a's,
    /// then K_a's, then Γ_a's): with na known for the usual three to five states the
    /// sums stay in registers and no add waits on the one before it in the same state's
    /// chain alone. Each sum is the same to the bit.
    fn step(&mut self) {
        match self.na {
            3 => self.step_with::<3>(),
            4 => self.step_with::<4>(),
            5 => self.step_with::<5>(),
            _ => self.step_any(),
        }
        std::mem::swap(&mut self.x, &mut self.x_next);
    }

    /// [`Filter::step`] for NA states, known when compiled.
    #[inline(always)]
    fn step_with<const NA: usize>(&mut self) {
        let mut acc = [0.0; NA];
        add_matrix_vector(&mut acc, &self.phi, &self.x[..NA]);
        add_matrix_vector(&mut acc, &self.gain, &self.e);
        add_matrix_vector(&mut acc, &self.gamma, &self.u);
        self.x_next[..NA].copy_from_slice(&acc);
    }

    /// [`Filter::step`] for any number of states.
    fn step_any(&mut self) {
        let (n, na, m) = (self.n, self.na, self.m);
        for c in 0..na {
            let mut acc = 0.0;
            for l in 0..na {
                acc += self.phi[c * na + l] * self.x[l];
            }
            for l in 0..n {
                acc += self.gain[c * n + l] * self.e[l];
            }
            for l in 0..m {
                acc += self.gamma[c * m + l] * self.u[l];
            }
            self.x_next[c] = acc;
        }
    }

    /// The row of J for output c over the segment's columns: −√w_c ∂x̂_c/∂param.
    fn jacobian_row(&self, c: usize, sqrt_w: f64, with_x0: bool, row: &mut [f64]) {
        let cols = self.x0_column() + if with_x0 { self.n } else { 0 };
        let sens = &self.sens[c * self.stride..][..cols];
        for (slot, v) in row[..cols].iter_mut().zip(sens) {
            *slot = -sqrt_w * v;
        }
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

    /// The square-root form's residual. A model or a predictor that is not stable (Φ or
    /// Φ − K with a spectral radius ≥ 1) is a step LM must refuse: it costs an enormous but
    /// finite J rather than ending the minimisation. An unstable predictor is no
    /// predictor (the criterion is only defined for stable ones), and its growing mode,
    /// held down by a finely tuned x̂(start), would otherwise take up slow trends.
    fn residuals(&self) -> Option<DVector<f64>> {
        let p = self.params.len();
        if !self.stable() {
            let mut r = DVector::zeros(p + 1);
            r[p] = 1e100;
            return Some(r);
        }
        let evaluation = self.evaluated();
        if evaluation.diverged() {
            let mut r = DVector::zeros(p + 1);
            r[p] = 1e100;
            return Some(r);
        }
        let (r, _) = evaluation.square_root_form()?;
        r.iter().all(|v| v.is_finite()).then_some(r)
    }

    fn jacobian(&self) -> Option<DMatrix<f64>> {
        let (_, j) = self.evaluated().square_root_form()?;
        j.iter().all(|v| v.is_finite()).then_some(j)
    }
}
