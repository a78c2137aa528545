//! The output-error fit (see [`super`]): Levenberg–Marquardt over Θ and each segment's x0,
//! its Jacobian by forward sensitivities, the start, the weights and the covariance.

use crate::estimate::Method;
use std::cell::RefCell;
use std::ops::Range;

use levenberg_marquardt::{LeastSquaresProblem, LevenbergMarquardt};
use nalgebra::{DMatrix, DVector, Dyn, Owned};

use crate::estimate::iv::InstrumentalVariables;
use crate::estimate::kernels::add_matrix_vector;
use crate::estimate::long_run::{LongRunSum, WindowChoice};
use crate::estimate::normal_equations::RowBlock;
use crate::estimate::wls::WeightedLeastSquares;
use crate::estimate::{
    check_enough_rows, DiscreteModel, Estimate, EstimationError, Estimator, IdentificationData,
    Result, RobustCovariance,
};
use crate::progress::Observer;

/// Segments beyond this many keep their start state instead of estimating it.
pub const MAX_ESTIMATED_INITIAL_STATES: usize = 50;

/// The output-error estimator.
#[derive(Debug, Clone, Default)]
pub struct OutputError {
    /// Per-output weights w_i > 0; `None` uses 1/σ_i² of the starting model's simulation
    /// error, re-estimated once from the first fit's residuals.
    pub weights: Option<Vec<f64>>,
    /// Told each evaluation of the objective (its number and J) as the fit goes.
    pub progress: Observer,
}

/// An output-error fit: the estimate and each segment's initial state.
#[derive(Debug, Clone)]
pub(crate) struct Fitted {
    /// The estimate.
    pub estimate: Estimate,
    /// ŷ(start) of each segment of the data, in order.
    pub initial_states: Vec<DVector<f64>>,
}

impl Fitted {
    /// ŷ over the segments from the fit's own initial states, NaN elsewhere: the
    /// simulation whose residuals the fit minimised. Simulated from the measured y(start)
    /// instead ([`DiscreteModel::simulate_segments`]), the first sample's noise would
    /// decay through the slow modes and correlate the residuals at every lag.
    pub(crate) fn simulate_segments(
        &self,
        data: &IdentificationData,
        segments: &[std::ops::Range<usize>],
    ) -> DMatrix<f64> {
        self.estimate
            .model
            .simulate_segments_from(data, segments, &self.initial_states)
    }
}

impl OutputError {
    /// The starting model: a rough IV estimate (LM takes it the rest of the way).
    ///
    /// With outputs known only at their own instants (a mask), few instants may have
    /// every output known twice in a row, which is what IV's regression needs. Then IV
    /// also runs on the data with the gaps interpolated (and least squares there if IV
    /// fails), and the candidate whose simulation is closest to the observations
    /// (least Σ_i ln MSE_i) is the start.
    pub fn start(&self, data: &IdentificationData) -> Result<DiscreteModel> {
        let iv = InstrumentalVariables {
            max_iterations: 10,
            tolerance: 1e-6,
        };
        let own = iv.estimate(data).map(|e| e.model);
        if !data.has_partial_outputs() {
            return match own {
                Ok(m) if m.is_stable() => Ok(m),
                // An IV start that does not settle on a stable model (e.g. where an input
                // is itself a function of the outputs) gives way to least squares.
                _ => WeightedLeastSquares::default()
                    .estimate(data)
                    .map(|e| e.model),
            };
        }
        let filled = data.interpolated();
        let from_filled = iv
            .estimate(&filled)
            .or_else(|_| WeightedLeastSquares::default().estimate(&filled))
            .map(|e| e.model);
        let segments = data.segments();
        let score = |m: &DiscreteModel| simulation_score(data, &segments, m);
        match (own, from_filled) {
            (Ok(a), Ok(b)) => Ok(if score(&b) < score(&a) { b } else { a }),
            (Ok(a), Err(_)) => Ok(a),
            (Err(_), Ok(b)) => Ok(b),
            (Err(e), Err(_)) => Err(e),
        }
    }

    /// Minimises the simulation error starting from `start` (the observed entries only;
    /// an exception-stored record is fitted as its kept values, without the censoring
    /// [`Estimator::estimate`] adds).
    pub fn refine(&self, data: &IdentificationData, start: &DiscreteModel) -> Result<Estimate> {
        Ok(self.fit(data, start)?.estimate)
    }

    /// Θ re-estimated from `start` with a constant output offset d per output (ŷ = x + d,
    /// `Problem::with_output_offset`): rises measured from one noisy first sample carry
    /// that sample's error for the whole run, which the free Φ, Γ otherwise take up. Where
    /// the data start at that sample (`starts_at_reference`) the state there is zero and
    /// d is the sample's error (negated); the estimate carries d in
    /// [`Estimate::output_offset`]. The thermal network is fitted to this Θ
    /// (`network::stage`), weighted by its Gauss–Newton covariance; it is reported nowhere
    /// else, so it carries no robust covariance (the sandwich's two passes over the
    /// scores, a third of this refit's time on W0, would go unused).
    pub fn refit_with_output_offset(
        &self,
        data: &IdentificationData,
        start: &DiscreteModel,
    ) -> Result<Estimate> {
        let (problem, rows_used, evaluations) = self.minimised(data, start, None, true)?;
        Ok(conclude(
            &problem,
            self.method(),
            (rows_used, evaluations),
            false,
        ))
    }

    /// [`OutputError::refine`], with the initial states it estimated.
    pub(crate) fn fit(&self, data: &IdentificationData, start: &DiscreteModel) -> Result<Fitted> {
        self.fit_weighted(data, start, None)
    }

    /// [`OutputError::fit`] with a factor on each entry's weight (N × n), where entries
    /// carry unequal information.
    pub(crate) fn fit_weighted(
        &self,
        data: &IdentificationData,
        start: &DiscreteModel,
        entry_weight: Option<DMatrix<f64>>,
    ) -> Result<Fitted> {
        let (problem, rows_used, evaluations) = self.minimised(data, start, entry_weight, false)?;
        Ok(Fitted {
            estimate: conclude(&problem, self.method(), (rows_used, evaluations), true),
            initial_states: problem.initial_states(),
        })
    }

    /// The problem minimised from `start`, with a constant output offset per output
    /// estimated as well where `output_offset` ([`Problem::with_output_offset`]); with the
    /// instants compared and the evaluations it took.
    fn minimised<'a>(
        &self,
        data: &'a IdentificationData,
        start: &DiscreteModel,
        entry_weight: Option<DMatrix<f64>>,
        output_offset: bool,
    ) -> Result<(Problem<'a>, usize, usize)> {
        self.check_weights(data)?;
        let segments = data.segments();
        let rows_used = compared_instants(data, &segments);
        check_enough_rows(data, rows_used)?;
        let weights = match &self.weights {
            Some(w) => w.clone(),
            // The inverse variance of the start model's simulation error.
            None => normalised_inverse(
                &simulation_error_variance(data, &segments, start)
                    .iter()
                    .map(|v| v.max(1e-24))
                    .collect::<Vec<_>>(),
            ),
        };
        let mut problem = Problem::new(data, segments, start, &weights);
        if output_offset {
            problem = problem.with_output_offset();
        }
        problem.entry_weight = entry_weight;
        problem.progress = Some(Reporting::new(&self.progress, self.method().name()));
        let (problem, evaluations) = self.minimise(problem)?;
        Ok((problem, rows_used, evaluations))
    }

    /// Weights, when given, are one finite positive number per output.
    fn check_weights(&self, data: &IdentificationData) -> Result<()> {
        let Some(w) = &self.weights else {
            return Ok(());
        };
        if w.len() != data.states() {
            return Err(EstimationError::WeightShape {
                given_rows: 1,
                given_columns: w.len(),
                rows: 1,
                columns: data.states(),
            });
        }
        match w.iter().position(|v| !(v.is_finite() && *v > 0.0)) {
            Some(state) => Err(EstimationError::InvalidWeight {
                state,
                value: w[state],
            }),
            None => Ok(()),
        }
    }

    /// Levenberg–Marquardt, in two passes when no weights are given: the second with
    /// 1/σ_i² of the first pass's residuals, which are then the sensor noise rather
    /// than the start's misfit. Returns the solved problem and the evaluations taken.
    fn minimise<'a>(&self, mut problem: Problem<'a>) -> Result<(Problem<'a>, usize)> {
        // Tolerances far below the statistical uncertainty of Θ (~1e-3 relative), and far
        // above rounding: the last evaluations of the default 30·ε would buy nothing.
        let lm = LevenbergMarquardt::new()
            .with_patience(200)
            .with_ftol(1e-10)
            .with_xtol(1e-10)
            .with_gtol(1e-10);
        let mut evaluations = 0;
        for pass in 0..2 {
            let (solved, report) = lm.minimize(problem);
            problem = solved;
            problem.end_pass();
            evaluations += report.number_of_evaluations;
            if !report.objective_function.is_finite() {
                return Err(EstimationError::MinimisationFailed {
                    termination: report.termination,
                });
            }
            if pass == 1 || self.weights.is_some() {
                break;
            }
            let next = problem.residual_weights();
            let change = largest_relative_change(&next, &problem.sqrt_w);
            // The cached evaluation at these parameters keeps the previous weights, so the
            // second pass's first step is taken on them. Clearing it (the cleaner choice)
            // moves noisy estimates by about 1e-3 relative; left as it is so that the
            // figures published so far stand, pending that decision.
            problem.sqrt_w = next;
            if change < 0.05 {
                break;
            }
        }
        Ok((problem, evaluations))
    }
}

/// max_i |next_i / current_i − 1|: how far a reweighting pass moved the √weights (the
/// fits refit while it is 5 % or more).
pub(crate) fn largest_relative_change(next: &[f64], current: &[f64]) -> f64 {
    next.iter()
        .zip(current)
        .map(|(a, b)| (a / b - 1.0).abs())
        .fold(0.0, f64::max)
}

/// w_i = (1/v_i) / mean_j(1/v_j): inverse variances scaled to mean 1, so that J stays
/// in the units of the data whatever the noise level.
pub(crate) fn normalised_inverse(variances: &[f64]) -> Vec<f64> {
    let inv: Vec<f64> = variances.iter().map(|v| 1.0 / v).collect();
    let mean = inv.iter().sum::<f64>() / inv.len() as f64;
    inv.iter().map(|v| v / mean).collect()
}

/// Mean squared simulation error per output over the observed entries of `segments`.
pub(crate) fn simulation_error_variance(
    data: &IdentificationData,
    segments: &[Range<usize>],
    model: &DiscreteModel,
) -> Vec<f64> {
    let sim = model.simulate_segments(data, segments);
    (0..data.states())
        .map(|c| {
            let (sum, count) = segments
                .iter()
                .flat_map(|s| s.clone())
                .filter(|&k| data.observed(k, c))
                .fold((0.0, 0usize), |(a, n), k| {
                    let e = data.outputs[(k, c)] - sim[(k, c)];
                    (a + e * e, n + 1)
                });
            sum / count.max(1) as f64
        })
        .collect()
}

/// Σ_i ln MSE_i of a model's simulation: smaller is closer, whatever the outputs' scales.
fn simulation_score(
    data: &IdentificationData,
    segments: &[Range<usize>],
    model: &DiscreteModel,
) -> f64 {
    if !model.is_stable() {
        return f64::INFINITY;
    }
    let score: f64 = simulation_error_variance(data, segments, model)
        .iter()
        .map(|v| v.max(1e-300).ln())
        .sum();
    if score.is_nan() {
        f64::INFINITY
    } else {
        score
    }
}

/// Instants after each segment's start with some output observed: the equations the
/// fit compares (without a mask, the usable regression rows).
pub(crate) fn compared_instants(data: &IdentificationData, segments: &[Range<usize>]) -> usize {
    segments
        .iter()
        .flat_map(|s| s.start + 1..s.end)
        .filter(|&k| (0..data.states()).any(|c| data.observed(k, c)))
        .count()
}

/// The covariance σ² (JᵀJ)⁻¹ from the eigen-decomposition of the symmetrically scaled
/// JᵀJ (directions below 1e-14 of the largest eigenvalue left out), and the condition
/// number of the scaled J.
pub(crate) fn covariance_from_gram(gram: &DMatrix<f64>, sigma2: f64) -> (DMatrix<f64>, f64) {
    let p_all = gram.nrows();
    let scale: Vec<f64> = (0..p_all)
        .map(|i| 1.0 / gram[(i, i)].max(1e-300).sqrt())
        .collect();
    let scaled = DMatrix::from_fn(p_all, p_all, |i, j| gram[(i, j)] * scale[i] * scale[j]);
    let eig = scaled.symmetric_eigen();
    let (e_max, e_min) = (eig.eigenvalues.max(), eig.eigenvalues.min().max(0.0));
    let inv =
        DMatrix::from_diagonal(&eig.eigenvalues.map(
            |e| {
                if e > 1e-14 * e_max {
                    1.0 / e
                } else {
                    0.0
                }
            },
        ));
    let d = DMatrix::from_diagonal(&DVector::from_column_slice(&scale));
    let full = &d * &eig.eigenvectors * inv * eig.eigenvectors.transpose() * &d * sigma2;
    (full, (e_max / e_min.max(1e-300)).sqrt())
}

/// Θ's block of σ² (JᵀJ)⁻¹ and the condition number of the scaled J.
fn theta_covariance(problem: &Problem, gram: &DMatrix<f64>, sigma2: f64) -> (DMatrix<f64>, f64) {
    let (full, condition_number) = covariance_from_gram(gram, sigma2);
    let p_theta = problem.p_theta();
    (
        full.view((0, 0), (p_theta, p_theta)).into_owned(),
        condition_number,
    )
}

/// The covariance of Θ from the information of each entry: (Σ_k e_kc/σ_c² J_kᵀJ_k)⁻¹
/// over the entries of `data` at `model` and `initial_states`, with e_kc the entry's
/// share of a full observation's information (`entry_information`, N × n) and σ_c² the
/// noise variance per output. Returns it with the condition number.
pub(crate) fn information_covariance(
    data: &IdentificationData,
    model: &DiscreteModel,
    initial_states: &[DVector<f64>],
    noise_variance: &[f64],
    entry_information: DMatrix<f64>,
) -> (DMatrix<f64>, f64) {
    let weights = normalised_inverse(noise_variance);
    let mut problem = Problem::new(data, data.segments(), model, &weights);
    for (s, x0) in initial_states.iter().enumerate() {
        if let Some(at) = problem.x0_at[s] {
            problem.params.rows_mut(at, problem.n).copy_from(x0);
        }
    }
    problem.entry_weight = Some(entry_information);
    let evaluation = problem.evaluate_full();
    // The weights are (1/σ_c²)/M with M the mean of 1/σ²: σ² = 1/M scales them back.
    let mean_inverse = noise_variance.iter().map(|v| 1.0 / v).sum::<f64>() / weights.len() as f64;
    theta_covariance(&problem, &evaluation.gram, 1.0 / mean_inverse)
}

/// The estimate at the minimum: Θ's block of the covariance (and of the sandwich
/// H⁻¹MH⁻¹ robust to correlated residuals where `robust`), the noise variance per output
/// from the unweighted residuals.
fn conclude(
    problem: &Problem,
    method: Method,
    (rows_used, evaluations): (usize, usize),
    robust: bool,
) -> Estimate {
    let n = problem.n;
    let w: Vec<f64> = problem.sqrt_w.iter().map(|v| v * v).collect();
    let (evaluation, first_pass) = if robust {
        let (evaluation, first) = problem.evaluate_full_with_scores();
        (evaluation, Some(first))
    } else {
        (problem.evaluate_full(), None)
    };
    let entries: usize = problem.counts.iter().sum();
    let dof = entries.saturating_sub(problem.params.len()).max(1) as f64;
    let sigma2 = evaluation.sse.iter().sum::<f64>() / dof;
    // H⁻¹ once: Gauss–Newton's covariance is σ² H⁻¹, the sandwich's bread H⁻¹.
    let (bread_inverse, condition_number) = covariance_from_gram(&evaluation.gram, 1.0);
    let p_theta = problem.p_theta();
    let theta_block = |m: &DMatrix<f64>| m.view((0, 0), (p_theta, p_theta)).into_owned();
    let covariance = theta_block(&bread_inverse) * sigma2;
    let robust_covariance = first_pass.map(|first| {
        let (sandwich, correlation_window) =
            problem.sandwich(&evaluation.gram, &bread_inverse, first);
        RobustCovariance {
            covariance: theta_block(&sandwich),
            correlation_window,
        }
    });
    let noise_variance: Vec<f64> = (0..n)
        .map(|c| evaluation.sse[c] / problem.counts[c].max(1) as f64 / w[c].max(1e-300))
        .collect();
    Estimate {
        model: problem.model(),
        method,
        rows_used,
        condition_number,
        covariance: Some(covariance),
        robust_covariance,
        noise_variance,
        iterations: evaluations,
        output_offset: problem.output_offset(),
        trajectory: None,
        network: None,
        predictor: None,
    }
}

/// Whether the data's first segment starts at the instant the rises are measured from:
/// every output observed there and exactly zero (a rise above its own first sample).
pub fn starts_at_reference(data: &IdentificationData) -> bool {
    data.segments()
        .first()
        .is_some_and(|s| is_reference_instant(data, s.start))
}

/// Whether every output is observed at `k` and exactly zero there.
fn is_reference_instant(data: &IdentificationData, k: usize) -> bool {
    (0..data.states()).all(|c| data.observed(k, c) && data.outputs[(k, c)] == 0.0)
}

/// The least-squares problem LM sees: parameters [Θ; x0 of each segment].
pub(crate) struct Problem<'a> {
    data: &'a IdentificationData,
    segments: Vec<Range<usize>>,
    /// Where each segment's start state is in the parameters, where it is estimated.
    x0_at: Vec<Option<usize>>,
    /// Each segment's start state from the start model (used where it is not estimated).
    fixed_x0: Vec<DVector<f64>>,
    /// Observed entries per output over the segments.
    pub(crate) counts: Vec<usize>,
    pub(crate) sqrt_w: Vec<f64>,
    /// A factor on each entry's weight (N × n), where entries count unequally.
    entry_weight: Option<DMatrix<f64>>,
    /// Where in the parameters the constant output offset d (ŷ = x + d, one per output)
    /// starts, when it is estimated ([`Problem::with_output_offset`]).
    offset_at: Option<usize>,
    pub(crate) n: usize,
    m: usize,
    pub(crate) params: DVector<f64>,
    cache: RefCell<Option<(DVector<f64>, Evaluation)>>,
    /// Where each full evaluation is reported, if anywhere.
    pub(crate) progress: Option<Reporting>,
    /// The pass's progress, for its noise-tied end ([`Stall`]).
    stall: Stall,
}

/// Evaluations in a window over which a pass must lower J by more than one noise
/// variance (σ² = J/N, χ² units) to go on, as rc's fits do
/// (`estimate::rc`): less is a walk the data cannot tell from standing still. Fits that
/// converge take fewer evaluations than one window and never meet it; a fit of data that
/// still hold a frozen hour (before the screen leaves it out) spent 138 of its 338
/// evaluations gaining less than that.
pub(crate) const STALL_WINDOW: usize = 20;

/// The best J of the pass so far and where it was, and its window ([`StallWindow`]).
#[derive(Debug, Default)]
struct Stall {
    window: StallWindow,
    best: RefCell<Option<(f64, DVector<f64>)>>,
}

/// The most bytes of scores the sandwich's first pass keeps for its second
/// ([`Problem::sandwich`]): a heat run of hours at 1 s with a dozen or two parameters
/// (W0: 3.5 MB), so that it is summed from memory rather than propagated again; a week's
/// scores (about 100 MB) are propagated twice, to keep the replay's peak of memory.
const KEPT_SCORES_BYTES: usize = 8 << 20;

/// The sandwich's first pass over the scores ([`Problem::sandwich`]): the sums that
/// choose the window and, where they fit in [`KEPT_SCORES_BYTES`], the scores themselves
/// (row after row, segment after segment) for the second.
pub(crate) struct FirstPass {
    choice: WindowChoice,
    kept: Option<Vec<f64>>,
}

/// Where a pass over the data gives each instant's score ([`Problem::pass_scored`]).
trait ScoreSink {
    /// Whether it takes them at all (a pass that gives none skips their sums).
    const TAKES: bool;
    /// The next instant's score, or the end of a segment (`None`).
    fn take(&mut self, score: Option<&DVector<f64>>);
}

/// The scores of a pass that needs none.
struct NoScores;

impl ScoreSink for NoScores {
    const TAKES: bool = false;
    fn take(&mut self, _: Option<&DVector<f64>>) {}
}

impl ScoreSink for FirstPass {
    const TAKES: bool = true;
    fn take(&mut self, score: Option<&DVector<f64>>) {
        match score {
            Some(s) => {
                self.choice.push(s);
                if let Some(kept) = &mut self.kept {
                    kept.extend_from_slice(s.as_slice());
                }
            }
            None => self.choice.end_segment(),
        }
    }
}

impl FirstPass {
    /// Nothing seen yet of `problem`'s scores.
    fn new(problem: &Problem) -> FirstPass {
        let cols = problem.params.len();
        let instants: usize = problem.segments.iter().map(|s| s.len()).sum();
        let values = instants.saturating_mul(cols);
        FirstPass {
            choice: WindowChoice::new(cols),
            kept: (values <= KEPT_SCORES_BYTES / size_of::<f64>())
                .then(|| Vec::with_capacity(values)),
        }
    }
}

/// A pass's evaluations counted in windows of [`STALL_WINDOW`], for its noise-tied end
/// (`oe`'s passes and rc's).
#[derive(Debug, Clone, Default)]
pub(crate) struct StallWindow {
    /// Evaluations so far in this pass.
    evaluations: std::cell::Cell<usize>,
    /// The best J at the start of the current window.
    window_start: std::cell::Cell<f64>,
    /// Whether the pass was ended for want of progress.
    pub(crate) stalled: std::cell::Cell<bool>,
}

impl StallWindow {
    /// Counts one evaluation with the best J so far, `lowest`, of a fit over `entries`
    /// entries; true where the window that ends here lowered it by less than
    /// `negligible_chi2` noise variances σ² = J/N.
    pub(crate) fn counted(&self, lowest: f64, entries: usize, negligible_chi2: f64) -> bool {
        self.counted_in(lowest, entries, (negligible_chi2, STALL_WINDOW))
    }

    /// [`StallWindow::counted`] in windows of `window` evaluations.
    pub(crate) fn counted_in(
        &self,
        lowest: f64,
        entries: usize,
        (negligible_chi2, window): (f64, usize),
    ) -> bool {
        let k = self.evaluations.get() + 1;
        self.evaluations.set(k);
        if k == 1 {
            self.window_start.set(lowest);
        }
        if !k.is_multiple_of(window) {
            return false;
        }
        let sigma2 = lowest / entries.max(1) as f64;
        let gained = self.window_start.get() - lowest;
        self.window_start.set(lowest);
        let stalled = gained < negligible_chi2 * sigma2;
        self.stalled.set(stalled);
        stalled
    }
}

/// A fit's progress observer, the fit's name and its evaluations so far.
pub(crate) struct Reporting {
    observer: Observer,
    method: &'static str,
    evaluations: std::cell::Cell<usize>,
}

impl Reporting {
    /// Reports for the fit `method` to `observer`, counting from 1.
    pub(crate) fn new(observer: &Observer, method: &'static str) -> Reporting {
        Reporting {
            observer: observer.clone(),
            method,
            evaluations: std::cell::Cell::new(0),
        }
    }

    /// One more evaluation, with J = Σ sse.
    pub(crate) fn evaluated(&self, sse: &[f64]) {
        let n = self.evaluations.get() + 1;
        self.evaluations.set(n);
        self.observer.iteration(self.method, n, sse.iter().sum());
    }
}

impl<'a> Problem<'a> {
    pub(crate) fn new(
        data: &'a IdentificationData,
        segments: Vec<Range<usize>>,
        start: &DiscreteModel,
        weights: &[f64],
    ) -> Problem<'a> {
        let (n, m) = (data.states(), data.input_count());
        let estimate_x0 = segments.len() <= MAX_ESTIMATED_INITIAL_STATES;
        let x0: Vec<DVector<f64>> = segments
            .iter()
            .map(|s| start.initial_state(data, s.clone()))
            .collect();
        let mut params: Vec<f64> = start.theta();
        let p_theta = params.len();
        if estimate_x0 {
            params.extend(x0.iter().flat_map(|x| x.iter().copied()));
        }
        let x0_at = (0..segments.len())
            .map(|s| estimate_x0.then_some(p_theta + s * n))
            .collect();
        let counts = data.observed_counts(&segments);
        Problem {
            data,
            segments,
            x0_at,
            fixed_x0: x0,
            counts,
            sqrt_w: weights.iter().map(|v| v.max(0.0).sqrt()).collect(),
            entry_weight: None,
            offset_at: None,
            n,
            m,
            params: DVector::from_vec(params),
            cache: RefCell::new(None),
            progress: None,
            stall: Stall::default(),
        }
    }

    /// The problem with a constant offset per output as n more parameters (last, from
    /// zero): ŷ(k) = x(k) + d. A rise measured from one noisy first sample is offset by
    /// that sample's noise for the whole run, which no initial state (it decays) and no
    /// Γ (it follows the losses) can take up.
    ///
    /// A segment whose outputs are all exactly zero at its start begins at the instant the
    /// rises are measured from: that sample's noise is −d, so its state there is the zero
    /// itself, not a parameter (estimated too, the start state and d trade against each
    /// other wherever the model misses the data).
    pub(crate) fn with_output_offset(mut self) -> Problem<'a> {
        if self.offset_at.is_some() {
            return self;
        }
        let (n, p_theta) = (self.n, self.p_theta());
        let mut params: Vec<f64> = self.params.as_slice()[..p_theta].to_vec();
        for s in 0..self.segments.len() {
            let start = self.segments[s].start;
            let reference = is_reference_instant(self.data, start);
            self.x0_at[s] = match self.x0_at[s] {
                Some(at) if !reference => {
                    params.extend_from_slice(&self.params.as_slice()[at..at + n]);
                    Some(params.len() - n)
                }
                _ => {
                    if reference {
                        self.fixed_x0[s] = DVector::zeros(n);
                    }
                    None
                }
            };
        }
        self.offset_at = Some(params.len());
        params.extend(std::iter::repeat_n(0.0, n));
        self.params = DVector::from_vec(params);
        *self.cache.borrow_mut() = None;
        self
    }

    /// The estimated output offset d, when it is estimated.
    pub(crate) fn output_offset(&self) -> Option<Vec<f64>> {
        self.offset_at
            .map(|at| self.params.rows(at, self.n).iter().copied().collect())
    }

    pub(crate) fn p_theta(&self) -> usize {
        self.n * (self.n + self.m)
    }

    pub(crate) fn model(&self) -> DiscreteModel {
        DiscreteModel::from_theta(
            self.n,
            self.m,
            self.data.ts_s,
            &self.params.as_slice()[..self.p_theta()],
        )
    }

    fn x0(&self, s: usize) -> &[f64] {
        match self.x0_at[s] {
            Some(at) => &self.params.as_slice()[at..at + self.n],
            None => self.fixed_x0[s].as_slice(),
        }
    }

    /// ŷ(start) of each segment at the current parameters.
    pub(crate) fn initial_states(&self) -> Vec<DVector<f64>> {
        (0..self.segments.len())
            .map(|s| DVector::from_column_slice(self.x0(s)))
            .collect()
    }

    /// √w_i from 1/σ_i² of the current residuals (normalised to mean 1).
    pub(crate) fn residual_weights(&self) -> Vec<f64> {
        let sse = self.evaluate_sse();
        let variances: Vec<f64> = (0..self.n)
            .map(|c| (sse[c] / self.sqrt_w[c].powi(2) / self.counts[c].max(1) as f64).max(1e-30))
            .collect();
        normalised_inverse(&variances)
            .iter()
            .map(|v| v.sqrt())
            .collect()
    }

    /// The weighted squared error per output.
    fn evaluate_sse(&self) -> Vec<f64> {
        self.pass(None)
    }

    /// The weighted squared error per output, reported as one evaluation: a simulation
    /// without the sensitivities (n² + n·m products an instant against the normal
    /// equations' thousands), for a trial point that may be rejected.
    pub(crate) fn evaluate_objective(&self) -> Vec<f64> {
        let sse = self.pass(None);
        if let Some(reporting) = &self.progress {
            reporting.evaluated(&sse);
        }
        sse
    }

    /// The weighted squared error per output and the normal equations JᵀJ, Jᵀr.
    pub(crate) fn evaluate_full(&self) -> Evaluation {
        let evaluation = self.normal_equations();
        if let Some(reporting) = &self.progress {
            reporting.evaluated(&evaluation.sse);
        }
        evaluation
    }

    /// [`Problem::evaluate_full`] and the first of the sandwich's passes over the scores
    /// ([`Problem::sandwich`]) in one propagation of the sensitivities.
    pub(crate) fn evaluate_full_with_scores(&self) -> (Evaluation, FirstPass) {
        let cols = self.params.len();
        let mut gram = DMatrix::<f64>::zeros(cols, cols);
        let mut grad = DVector::<f64>::zeros(cols);
        let mut first = FirstPass::new(self);
        let sse = self.pass_scored(Some((&mut gram, &mut grad)), &mut first);
        if let Some(reporting) = &self.progress {
            reporting.evaluated(&sse);
        }
        (Evaluation { sse, gram, grad }, first)
    }

    /// [`Problem::evaluate_full`] without reporting it (a point already reported by
    /// [`Problem::evaluate_objective`]).
    pub(crate) fn normal_equations(&self) -> Evaluation {
        let cols = self.params.len();
        let mut gram = DMatrix::<f64>::zeros(cols, cols);
        let mut grad = DVector::<f64>::zeros(cols);
        let sse = self.pass(Some((&mut gram, &mut grad)));
        Evaluation { sse, gram, grad }
    }

    /// One pass over the data: the weighted squared error per output and, when asked,
    /// the normal equations of the weighted residuals. The Jacobian itself is never
    /// stored (a week at 1 s would be 1.8 million rows); the sensitivities live in flat
    /// buffers.
    fn pass(&self, normal: Option<(&mut DMatrix<f64>, &mut DVector<f64>)>) -> Vec<f64> {
        self.pass_scored(normal, &mut NoScores)
    }

    /// [`Problem::pass`], giving each instant's score to `scores` as
    /// [`Problem::for_each_score`] does, from the Jacobian rows the normal equations are
    /// summed from (where they are asked for: the scores are read off their rows).
    /// Compiled once per kind of `scores`: a pass that takes none is the loop it was.
    #[inline(always)]
    fn pass_scored<S: ScoreSink>(
        &self,
        mut normal: Option<(&mut DMatrix<f64>, &mut DVector<f64>)>,
        scores: &mut S,
    ) -> Vec<f64> {
        let n = self.n;
        let mut state = Propagation::new(&self.model());
        let mut block = RowBlock::new();
        let mut sse = vec![0.0; n];
        let mut score = DVector::zeros(if S::TAKES { self.params.len() } else { 0 });
        for (s, seg) in self.segments.iter().enumerate() {
            state.reset(self.x0(s));
            let x0_at = self.x0_at[s];
            if let Some((gram, grad)) = normal.as_mut() {
                block.set_columns(self.segment_columns(x0_at), gram, grad);
            }
            let columns: Vec<usize> = if S::TAKES {
                self.segment_columns(x0_at).collect()
            } else {
                Vec::new()
            };
            for k in seg.clone() {
                if k > seg.start {
                    state.load_input(self.data, k - 1);
                    if normal.is_some() {
                        state.propagate_sensitivities();
                    }
                    state.step();
                }
                if S::TAKES {
                    score.fill(0.0);
                }
                for c in (0..n).filter(|&c| self.data.observed(k, c)) {
                    let (sqrt_w, r) = self.weighted_residual(&state, k, c);
                    sse[c] += r * r;
                    if let Some((gram, grad)) = normal.as_mut() {
                        let row = block.push(r, gram, grad);
                        state.jacobian_row(c, sqrt_w, x0_at.is_some(), self.offset_at, row);
                        if S::TAKES {
                            for (&q, v) in columns.iter().zip(row.iter()) {
                                score[q] += v * r;
                            }
                        }
                    }
                }
                if S::TAKES {
                    scores.take(Some(&score));
                }
            }
            if S::TAKES {
                scores.take(None);
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

    /// √w of entry (k, c) and its weighted residual r = √w (y_c(k) − ŷ_c(k) − d_c) at the
    /// propagated `state`.
    fn weighted_residual(&self, state: &Propagation, k: usize, c: usize) -> (f64, f64) {
        let sqrt_w = match &self.entry_weight {
            None => self.sqrt_w[c],
            Some(e) => self.sqrt_w[c] * e[(k, c)].max(0.0).sqrt(),
        };
        let offset = self.offset_at.map_or(0.0, |at| self.params[at + c]);
        (
            sqrt_w,
            sqrt_w * (self.data.outputs[(k, c)] - state.y[c] - offset),
        )
    }

    /// Each instant's score s_k = Σ_c J_kcᵀ r_kc of the weighted residuals at the current
    /// parameters, in time order, `None` at the end of each segment (an instant with no
    /// output compared gives s_k = 0 and keeps its place). One pass with the
    /// sensitivities, like [`Problem::evaluate_full`]; nothing kept.
    fn for_each_score(&self, mut each: impl FnMut(Option<&DVector<f64>>)) {
        let (n, cols) = (self.n, self.params.len());
        let mut state = Propagation::new(&self.model());
        let mut row = Vec::new();
        let mut score = DVector::zeros(cols);
        for (s, seg) in self.segments.iter().enumerate() {
            state.reset(self.x0(s));
            let x0_at = self.x0_at[s];
            let columns: Vec<usize> = self.segment_columns(x0_at).collect();
            row.resize(columns.len(), 0.0);
            for k in seg.clone() {
                if k > seg.start {
                    state.load_input(self.data, k - 1);
                    state.propagate_sensitivities();
                    state.step();
                }
                score.fill(0.0);
                for c in (0..n).filter(|&c| self.data.observed(k, c)) {
                    let (sqrt_w, r) = self.weighted_residual(&state, k, c);
                    state.jacobian_row(c, sqrt_w, x0_at.is_some(), self.offset_at, &mut row);
                    for (&q, v) in columns.iter().zip(&row) {
                        score[q] += v * r;
                    }
                }
                each(Some(&score));
            }
            each(None);
        }
    }

    /// The sandwich covariance of all the parameters at the current ones,
    /// C = H⁻¹ M H⁻¹ · N/(N − r) with H = JᵀWJ (`gram`) and M the long-run covariance of
    /// the weighted residuals' scores with Bartlett's window of Andrews' width
    /// ([`crate::estimate::long_run`]): `first`, the first pass over the scores (taken
    /// with the evaluation, [`Problem::evaluate_full_with_scores`]), chose the window; the
    /// second sums with it, from the scores the first kept where it kept them, else
    /// propagating the sensitivities again (the same scores either way). `bread_inverse`
    /// is H⁻¹ ([`covariance_from_gram`] with σ² = 1). Returns it with the window's width.
    pub(crate) fn sandwich(
        &self,
        gram: &DMatrix<f64>,
        bread_inverse: &DMatrix<f64>,
        first: FirstPass,
    ) -> (DMatrix<f64>, usize) {
        let cols = self.params.len();
        let width = first.choice.width(gram);
        let mut sum = LongRunSum::new(cols, width);
        match first.kept {
            Some(kept) => {
                let mut rows = kept.chunks_exact(cols);
                let mut score = DVector::zeros(cols);
                for segment in &self.segments {
                    for row in rows.by_ref().take(segment.len()) {
                        score.copy_from_slice(row);
                        sum.push(&score);
                    }
                    sum.end_segment();
                }
            }
            None => self.for_each_score(|score| match score {
                Some(s) => sum.push(s),
                None => sum.end_segment(),
            }),
        }
        let entries: usize = self.counts.iter().sum();
        let dof = entries as f64 / entries.saturating_sub(cols).max(1) as f64;
        (bread_inverse * sum.finish() * bread_inverse * dof, width)
    }

    /// The columns of J a segment's rows can touch, increasing: Θ, the segment's x0
    /// where it is estimated (at `x0_at`), the output offsets where they are.
    fn segment_columns(&self, x0_at: Option<usize>) -> impl Iterator<Item = usize> {
        let n = self.n;
        (0..self.p_theta())
            .chain(x0_at.into_iter().flat_map(move |at| at..at + n))
            .chain(self.offset_at.into_iter().flat_map(move |at| at..at + n))
    }

    /// Counts one evaluation at J = `objective`, keeping the best point; true where the
    /// window of [`STALL_WINDOW`] evaluations that ends here lowered the best J by less
    /// than one noise variance J/N.
    fn stalled_at(&self, objective: f64) -> bool {
        let stall = &self.stall;
        let lowest = {
            let mut best = stall.best.borrow_mut();
            if best.as_ref().is_none_or(|(b, _)| objective < *b) {
                *best = Some((objective, self.params.clone()));
            }
            best.as_ref().map_or(objective, |(b, _)| *b)
        };
        let entries: usize = self.counts.iter().sum();
        stall.window.counted(lowest, entries, 1.0)
    }

    /// Ends a pass: where [`Stall`] stopped it, the parameters go back to its best point
    /// (LM stops at the trial point it was evaluating). The next pass counts afresh.
    fn end_pass(&mut self) {
        let stall = std::mem::take(&mut self.stall);
        if stall.window.stalled.get() {
            if let Some((_, best)) = stall.best.into_inner() {
                self.params = best;
            }
        }
    }

    /// The evaluation at the current parameters, computed once per parameter vector.
    fn evaluated(&self) -> std::cell::Ref<'_, Evaluation> {
        cached(&self.cache, &self.params, || self.evaluate_full())
    }
}

/// The value `compute` gives at `params`, kept in `cache` so that the residuals, the
/// Jacobian and the gradient of one Levenberg-Marquardt step share one simulation.
pub(crate) fn cached<'c, T>(
    cache: &'c RefCell<Option<(DVector<f64>, T)>>,
    params: &DVector<f64>,
    compute: impl FnOnce() -> T,
) -> std::cell::Ref<'c, T> {
    let stale = cache.borrow().as_ref().is_none_or(|(at, _)| at != params);
    if stale {
        let value = compute();
        *cache.borrow_mut() = Some((params.clone(), value));
    }
    std::cell::Ref::map(cache.borrow(), |c| &c.as_ref().expect("just filled").1)
}

/// The simulation ŷ and its sensitivities, stepped through one segment in flat,
/// reused buffers: no allocation per instant.
struct Propagation {
    n: usize,
    m: usize,
    /// Φ row-major.
    phi: Vec<f64>,
    /// Γ row-major.
    gamma: Vec<f64>,
    u: Vec<f64>,
    y: Vec<f64>,
    y_next: Vec<f64>,
    /// sens[c·n(n+m) + q] = ∂ŷ_c/∂θ_q: an output's sensitivities side by side, so that
    /// a step propagates them a vector of θ at a time and J's row is one slice.
    sens: Vec<f64>,
    sens_next: Vec<f64>,
    /// sens_x0[c·n + q] = ∂ŷ_c/∂x0_q.
    sens_x0: Vec<f64>,
    sens_x0_next: Vec<f64>,
}

impl Propagation {
    fn new(model: &DiscreteModel) -> Propagation {
        let (n, m) = (model.phi.nrows(), model.gamma.ncols());
        let pt = n * (n + m);
        Propagation {
            n,
            m,
            phi: (0..n * n).map(|q| model.phi[(q / n, q % n)]).collect(),
            gamma: (0..n * m).map(|q| model.gamma[(q / m, q % m)]).collect(),
            u: vec![0.0; m],
            y: vec![0.0; n],
            y_next: vec![0.0; n],
            sens: vec![0.0; pt * n],
            sens_next: vec![0.0; pt * n],
            sens_x0: vec![0.0; n * n],
            sens_x0_next: vec![0.0; n * n],
        }
    }

    /// ŷ(start) = x0, ∂ŷ/∂θ = 0, ∂ŷ/∂x0 = I.
    fn reset(&mut self, x0: &[f64]) {
        self.y.copy_from_slice(x0);
        self.sens.iter_mut().for_each(|v| *v = 0.0);
        self.sens_x0.iter_mut().for_each(|v| *v = 0.0);
        for q in 0..self.n {
            self.sens_x0[q * self.n + q] = 1.0;
        }
    }

    fn load_input(&mut self, data: &IdentificationData, k: usize) {
        for (l, u) in self.u.iter_mut().enumerate() {
            *u = data.inputs[(k, l)];
        }
    }

    /// ∂ŷ(k)/∂θ_q = Φ ∂ŷ(k−1)/∂θ_q + e_i φ_j(k−1) (q = i·p + j), ∂ŷ(k)/∂x0 = Φ ∂ŷ(k−1)/∂x0;
    /// from ŷ(k−1), so before [`Propagation::step`].
    ///
    /// Output c's row of sensitivities is its regressor block, then Φ_cl times output
    /// l's row added for l = 0…n−1: whole rows at a time, a vector of θ to an
    /// instruction, in the order the sum Σ_l Φ_cl ∂ŷ_l/∂θ_q is written, so every entry is
    /// the same to the bit as one summed on its own. The models heatrun fits have three
    /// or four states: for them n is known when compiled
    /// ([`Propagation::propagate_with`]); every oe fit's evaluation spends about a third
    /// of its time here.
    fn propagate_sensitivities(&mut self) {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the processor has AVX2, checked just above.
            unsafe { self.propagate_avx2() };
            return;
        }
        self.propagate_portable();
    }

    /// [`Propagation::propagate_sensitivities`] compiled for AVX2: four sensitivities to
    /// an instruction where the portable x86-64 build has two. The same products are
    /// added in the same order (Rust fuses no multiply into an add): the same bits.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn propagate_avx2(&mut self) {
        self.propagate_portable();
    }

    /// [`Propagation::propagate_sensitivities`] for any processor; inlined into each
    /// compiled variant.
    #[inline(always)]
    fn propagate_portable(&mut self) {
        match self.n {
            3 => self.propagate_with::<3>(),
            4 => self.propagate_with::<4>(),
            _ => self.propagate_any(self.n),
        }
    }

    /// [`Propagation::propagate_sensitivities`] for N states, known when compiled.
    ///
    /// Each sensitivity is summed in a register through the n rows it depends on
    /// (Φ_c0 ∂ŷ_0/∂θ_q + … in that order), a vector of θ at a time: where n is known the
    /// rows' loop unrolls, and no row of the sum is stored and read back between its
    /// terms.
    #[inline(always)]
    fn propagate_with<const N: usize>(&mut self) {
        let p = N + self.m;
        let pt = N * p;
        let phi = &self.phi[..N * N];
        let sens: [&[f64]; N] = std::array::from_fn(|l| &self.sens[l * pt..][..pt]);
        let sens_x0: [&[f64]; N] = std::array::from_fn(|l| &self.sens_x0[l * N..][..N]);
        for c in 0..N {
            let factors: [f64; N] = std::array::from_fn(|l| phi[c * N + l]);
            let next = &mut self.sens_next[c * pt..][..pt];
            next.iter_mut().for_each(|v| *v = 0.0);
            next[c * p..c * p + N].copy_from_slice(&self.y[..N]);
            next[c * p + N..(c + 1) * p].copy_from_slice(&self.u);
            for (q, slot) in next.iter_mut().enumerate() {
                let mut acc = *slot;
                for (f, row) in factors.iter().zip(&sens) {
                    acc += f * row[q];
                }
                *slot = acc;
            }
            let next = &mut self.sens_x0_next[c * N..][..N];
            for (q, slot) in next.iter_mut().enumerate() {
                let mut acc = 0.0;
                for (f, row) in factors.iter().zip(&sens_x0) {
                    acc += f * row[q];
                }
                *slot = acc;
            }
        }
        std::mem::swap(&mut self.sens, &mut self.sens_next);
        std::mem::swap(&mut self.sens_x0, &mut self.sens_x0_next);
    }

    /// [`Propagation::propagate_sensitivities`] for `n` states (`self.n`); inlined
    /// into [`Propagation::propagate_with`], where `n` is a constant.
    #[inline(always)]
    fn propagate_any(&mut self, n: usize) {
        let p = n + self.m;
        let pt = n * p;
        let phi = &self.phi[..n * n];
        for c in 0..n {
            let next = &mut self.sens_next[c * pt..(c + 1) * pt];
            next.iter_mut().for_each(|v| *v = 0.0);
            next[c * p..c * p + n].copy_from_slice(&self.y[..n]);
            next[c * p + n..(c + 1) * p].copy_from_slice(&self.u);
            for (l, &f) in phi[c * n..c * n + n].iter().enumerate() {
                let row = &self.sens[l * pt..(l + 1) * pt];
                for (slot, v) in next.iter_mut().zip(row) {
                    *slot += f * v;
                }
            }
        }
        std::mem::swap(&mut self.sens, &mut self.sens_next);
        for c in 0..n {
            let next = &mut self.sens_x0_next[c * n..c * n + n];
            next.iter_mut().for_each(|v| *v = 0.0);
            for (l, &f) in phi[c * n..c * n + n].iter().enumerate() {
                let row = &self.sens_x0[l * n..l * n + n];
                for (slot, v) in next.iter_mut().zip(row) {
                    *slot += f * v;
                }
            }
        }
        std::mem::swap(&mut self.sens_x0, &mut self.sens_x0_next);
    }

    /// ŷ(k) = Φ ŷ(k−1) + Γ u(k−1) (eq. 8).
    ///
    /// Every output's sum is carried at once, term by term in the order written (Φ's,
    /// then Γ's): with n known for three and four states the sums stay in registers.
    /// Each sum is the same to the bit.
    fn step(&mut self) {
        match self.n {
            3 => self.step_with::<3>(),
            4 => self.step_with::<4>(),
            _ => self.step_any(),
        }
        std::mem::swap(&mut self.y, &mut self.y_next);
    }

    /// [`Propagation::step`] for N states, known when compiled.
    #[inline(always)]
    fn step_with<const N: usize>(&mut self) {
        let mut acc = [0.0; N];
        add_matrix_vector(&mut acc, &self.phi, &self.y[..N]);
        add_matrix_vector(&mut acc, &self.gamma, &self.u);
        self.y_next[..N].copy_from_slice(&acc);
    }

    /// [`Propagation::step`] for any number of states.
    fn step_any(&mut self) {
        let (n, m) = (self.n, self.m);
        for c in 0..n {
            let mut acc = 0.0;
            for l in 0..n {
                acc += self.phi[c * n + l] * self.y[l];
            }
            for l in 0..m {
                acc += self.gamma[c * m + l] * self.u[l];
            }
            self.y_next[c] = acc;
        }
    }

    /// The row of J for output c over a segment's columns ([`Problem::segment_columns`]):
    /// −√w_c ∂ŷ_c/∂θ, then −√w_c ∂ŷ_c/∂x0 where the segment's x0 is estimated, then
    /// −√w_c ∂ŷ_c/∂d (one output's offset) where the offsets are.
    fn jacobian_row(
        &self,
        c: usize,
        sqrt_w: f64,
        x0: bool,
        offset_at: Option<usize>,
        row: &mut [f64],
    ) {
        let n = self.n;
        let pt = n * (n + self.m);
        for (slot, v) in row[..pt].iter_mut().zip(&self.sens[c * pt..(c + 1) * pt]) {
            *slot = -sqrt_w * v;
        }
        let mut at = pt;
        if x0 {
            let sens_x0 = &self.sens_x0[c * n..(c + 1) * n];
            for (slot, v) in row[at..at + n].iter_mut().zip(sens_x0) {
                *slot = -sqrt_w * v;
            }
            at += n;
        }
        if offset_at.is_some() {
            let offsets = &mut row[at..at + n];
            offsets.iter_mut().for_each(|v| *v = 0.0);
            offsets[c] = -sqrt_w;
        }
    }
}

/// The result of one pass over the data.
#[derive(Debug, Clone)]
pub(crate) struct Evaluation {
    /// Σ_k (√w_c (y_c − ŷ_c))² per output, over the observed entries.
    pub(crate) sse: Vec<f64>,
    /// JᵀJ of the weighted residuals.
    pub(crate) gram: DMatrix<f64>,
    /// Jᵀr of the weighted residuals.
    pub(crate) grad: DVector<f64>,
}

impl Evaluation {
    /// The least-squares problem in square-root form: R with RᵀR = JᵀJ, and the reduced
    /// residual [R⁻ᵀJᵀr; √(‖r‖² − ‖R⁻ᵀJᵀr‖²)], whose norm is ‖r‖. Levenberg–Marquardt
    /// sees the same JᵀJ, Jᵀr and objective as with the full Jacobian, at p + 1 rows.
    pub(crate) fn square_root_form(&self) -> Option<(DVector<f64>, DMatrix<f64>)> {
        let (gram, grad) = (&self.gram, &self.grad);
        let p = gram.nrows();
        // Symmetric scaling keeps the factorisation accurate; a whisper of ridge keeps it
        // defined where a parameter is not seen (a segment too short for its x0).
        let d: Vec<f64> = (0..p)
            .map(|i| 1.0 / gram[(i, i)].max(1e-300).sqrt())
            .collect();
        let scaled = DMatrix::from_fn(p, p, |i, j| {
            gram[(i, j)] * d[i] * d[j] + if i == j { 1e-13 } else { 0.0 }
        });
        let chol = scaled.cholesky()?;
        // R = L_sᵀ D⁻¹ (JᵀJ = D⁻¹ L_s L_sᵀ D⁻¹).
        let l = chol.l();
        let r_mat = DMatrix::from_fn(p, p, |i, j| l[(j, i)] / d[j]);
        let z = r_mat.transpose().solve_lower_triangular(grad)?;
        let total: f64 = self.sse.iter().sum();
        let rest = (total - z.norm_squared()).max(0.0).sqrt();
        let mut residual = DVector::zeros(p + 1);
        residual.rows_mut(0, p).copy_from(&z);
        residual[p] = rest;
        let mut jacobian = DMatrix::zeros(p + 1, p);
        jacobian.view_mut((0, 0), (p, p)).copy_from(&r_mat);
        Some((residual, jacobian))
    }
}

impl Evaluation {
    /// The square-root form whose residual is [0; …; 0; ρ], ρ = √J, whatever the
    /// Jacobian: Ĵ = [R'; gᵀ/ρ] with R'ᵀR' = JᵀJ − g gᵀ/ρ² (g = Jᵀr), which is
    /// Jᵀ(I − r rᵀ/‖r‖²)J, positive semi-definite. Then ĴᵀĴ = JᵀJ, Ĵᵀ[0; ρ] = g and
    /// the norm is ‖r‖: Levenberg–Marquardt's subproblem and objective are those of the
    /// full Jacobian. Why: a trial point's residuals then need J alone (a simulation
    /// without sensitivities, [`Problem::evaluate_objective`]), and the normal equations
    /// are made only at the points LM accepts. `None` where R' cannot be factored.
    pub(crate) fn residual_last_form(&self) -> Option<DMatrix<f64>> {
        let (gram, grad) = (&self.gram, &self.grad);
        let p = gram.nrows();
        let rho2: f64 = self.sse.iter().sum();
        if !(rho2 > 0.0 && rho2.is_finite()) {
            return None;
        }
        let rho = rho2.sqrt();
        let d: Vec<f64> = (0..p)
            .map(|i| 1.0 / gram[(i, i)].max(1e-300).sqrt())
            .collect();
        let projected = DMatrix::from_fn(p, p, |i, j| {
            (gram[(i, j)] - grad[i] * grad[j] / rho2) * d[i] * d[j]
        });
        // A whisper of ridge, raised where rounding leaves the projection a hair below
        // semi-definite (the residual almost within J's span) or a parameter is not seen:
        // the point was accepted already, and a Jacobian refused here would end the fit.
        let l = [1e-13, 1e-10, 1e-7, 1e-4].into_iter().find_map(|ridge| {
            let mut m = projected.clone();
            for i in 0..p {
                m[(i, i)] += ridge;
            }
            m.cholesky().map(|c| c.l())
        })?;
        let mut jacobian = DMatrix::zeros(p + 1, p);
        for i in 0..p {
            for j in 0..p {
                // R' = L_sᵀ D⁻¹.
                jacobian[(i, j)] = l[(j, i)] / d[j];
            }
        }
        for j in 0..p {
            jacobian[(p, j)] = grad[j] / rho;
        }
        Some(jacobian)
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
        let (r, _) = self.evaluated().square_root_form()?;
        if !r.iter().all(|v| v.is_finite()) {
            return None;
        }
        if self.stalled_at(r.norm_squared()) {
            // No residuals: LM stops here; the pass takes its best point ([`Stall`]).
            return None;
        }
        Some(r)
    }

    fn jacobian(&self) -> Option<DMatrix<f64>> {
        let (_, j) = self.evaluated().square_root_form()?;
        j.iter().all(|v| v.is_finite()).then_some(j)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    use crate::estimate::testing::{
        exact_data, simulate, step_inputs, theta_error, two_state_model, with_noise,
    };

    /// The model with every entry of Θ 3 % off, alternately up and down.
    fn perturbed(truth: &DiscreteModel) -> DiscreteModel {
        truth.with_theta(
            &truth
                .theta()
                .iter()
                .enumerate()
                .map(|(q, t)| t * if q % 2 == 0 { 1.03 } else { 0.97 })
                .collect::<Vec<_>>(),
        )
    }

    #[test]
    fn from_a_perturbed_start_noise_free_data_give_the_true_matrices() {
        let truth = two_state_model();
        let data = exact_data(&truth, 1500, 11);
        let start = perturbed(&truth);
        assert!(theta_error(&start, &truth) > 0.02);
        let e = OutputError::default().refine(&data, &start).unwrap();
        assert!(theta_error(&e.model, &truth) < 1e-8, "{:?}", e.model);
        assert_eq!(e.method, Method::Oe);
        assert_eq!(e.rows_used, 1499);
        // The residuals are zero, so is the covariance.
        assert!(e.covariance.unwrap().amax() < 1e-12);
    }

    #[test]
    fn the_first_samples_error_is_estimated_as_an_output_offset() {
        // Rises from rest (x0 = 0) measured from a first sample that is c off: the rise is
        // 0 at the first instant and x(k) − c after it, for the whole run.
        let truth = two_state_model();
        let u = step_inputs(1500, 2, 13);
        let c = [0.05, -0.03];
        let mut y = simulate(&truth, &u, &[0.0, 0.0]);
        for k in 1..y.nrows() {
            for (j, cj) in c.iter().enumerate() {
                y[(k, j)] -= cj;
            }
        }
        let data = IdentificationData::complete(1.0, y, u);
        assert!(starts_at_reference(&data));
        let start = perturbed(&truth);
        let oe = OutputError::default();
        let e = oe.refit_with_output_offset(&data, &start).unwrap();
        // The first sample itself is zero where the model says d: its residual is that
        // sample's error, the one misfit left (1 entry of 1500 per output).
        let with = theta_error(&e.model, &truth);
        assert!(with < 5e-4, "{with}: {:?}", e.model);
        let d = e.output_offset.expect("the offset is estimated");
        for (dj, cj) in d.iter().zip(&c) {
            assert!((dj + cj).abs() < 1e-3, "d {d:?} against −c {c:?}");
        }
        // Without it, Φ and Γ take the offset up.
        let plain = oe.refine(&data, &start).unwrap();
        assert!(plain.output_offset.is_none());
        let without = theta_error(&plain.model, &truth);
        assert!(without > 10.0 * with, "{without} against {with}");
    }

    #[test]
    fn an_unobserved_start_state_is_estimated() {
        // Output 1 is not kept over the first 50 instants: its part of x0 is a parameter.
        // From a perturbed Θ the start's fill of it is wrong; the minimum is the truth.
        let truth = two_state_model();
        let full = exact_data(&truth, 1500, 12);
        let x0_true = full.outputs[(0, 1)];
        let data = full.with_output_observed(DMatrix::from_fn(1500, 2, |k, j| j == 0 || k >= 50));
        let start = perturbed(&truth);
        let filled = start.initial_state(&data, 0..1500)[1];
        assert!((filled - x0_true).abs() > 1e-3, "{filled} vs {x0_true}");
        let e = OutputError::default().refine(&data, &start).unwrap();
        assert!(theta_error(&e.model, &truth) < 1e-8, "{:?}", e.model);
    }

    #[test]
    fn outputs_observed_at_their_own_instants_give_the_true_matrices() {
        // Output 0 kept every 7th instant, output 1 at 13 % of them at random: almost
        // no instant has both known twice in a row, so IV on the data's own rows cannot
        // start; OE starts from the interpolated data and fits the kept values.
        let truth = two_state_model();
        let full = exact_data(&truth, 3000, 13);
        let mut rng = rand::rngs::StdRng::seed_from_u64(14);
        let kept = DMatrix::from_fn(3000, 2, |k, j| {
            if j == 0 {
                k % 7 == 3
            } else {
                rng.random_range(0.0..1.0) < 0.13
            }
        });
        let data = full.with_output_observed(kept);
        assert!(matches!(
            InstrumentalVariables::default().estimate(&data),
            Err(EstimationError::TooFewRows { .. })
        ));
        let e = OutputError::default().estimate(&data).unwrap();
        assert!(theta_error(&e.model, &truth) < 1e-7, "{:?}", e.model);
    }

    #[test]
    fn output_noise_leaves_the_estimate_unbiased() {
        // σ = 0.02 on outputs of about 0.5: least squares is far off, OE within its
        // statistical error (the 95 % interval of each entry of Θ).
        let truth = two_state_model();
        let u = step_inputs(20000, 2, 15);
        let y = simulate(&truth, &u, &[0.5, 0.2]);
        let data = IdentificationData::complete(1.0, with_noise(&y, 0.02, 16), u);
        let e = OutputError::default().estimate(&data).unwrap();
        let cov = e.covariance.as_ref().unwrap();
        let theta = e.model.theta();
        let mut outside = 0;
        for (q, t) in truth.theta().iter().enumerate() {
            let half = 1.96 * cov[(q, q)].sqrt();
            assert!(
                half > 0.0 && half < 0.05 * t.abs().max(0.01),
                "entry {q}: ±{half}"
            );
            if (theta[q] - t).abs() > half {
                outside += 1;
            }
        }
        assert!(
            outside <= 1,
            "{outside} of 8 entries outside their 95 % interval"
        );
        // The noise variance is the sensor's.
        for v in &e.noise_variance {
            assert!((v.sqrt() / 0.02 - 1.0).abs() < 0.05, "σ = {}", v.sqrt());
        }
    }

    /// The sandwich's second pass sums the same scores whether it reads them from its
    /// first pass or propagates the sensitivities again (a week's are not kept), to the
    /// bit, over two segments of noisy data whose residuals are correlated (a model 3 %
    /// off) so that the window is wide.
    #[test]
    fn the_kept_scores_give_the_sandwich_the_propagated_ones_give() {
        let truth = two_state_model();
        let u = step_inputs(3000, 2, 17);
        let y = with_noise(&simulate(&truth, &u, &[0.5, 0.2]), 0.01, 18);
        let mut outputs_known = vec![true; 3000];
        outputs_known[1200..1210].fill(false);
        let data = IdentificationData::new(1.0, y, u, outputs_known, vec![true; 3000]);
        let segments = data.segments();
        assert_eq!(segments.len(), 2, "{segments:?}");
        let start = perturbed(&truth);
        let weights = vec![1.0, 1.0];
        let problem = Problem::new(&data, segments, &start, &weights);
        let (evaluation, kept) = problem.evaluate_full_with_scores();
        assert!(kept.kept.is_some());
        let mut propagated = FirstPass {
            choice: WindowChoice::new(problem.params.len()),
            kept: None,
        };
        problem.for_each_score(|score| propagated.take(score));
        let (bread, _) = covariance_from_gram(&evaluation.gram, 1.0);
        let (from_kept, width) = problem.sandwich(&evaluation.gram, &bread, kept);
        let (again, width_again) = problem.sandwich(&evaluation.gram, &bread, propagated);
        assert!(width > 2, "window {width}");
        assert_eq!(width, width_again);
        assert_eq!(from_kept, again);
        // And the first pass taken with the evaluation is the evaluation's own.
        assert_eq!(evaluation.gram, problem.evaluate_full().gram);
    }

    /// Every `iteration` call a fit makes.
    #[derive(Default)]
    struct IterationLog(std::sync::Mutex<Vec<(String, usize, f64)>>);

    impl crate::progress::Progress for IterationLog {
        fn iteration(&self, method: &str, evaluation: usize, cost: f64) {
            self.0
                .lock()
                .unwrap()
                .push((method.to_owned(), evaluation, cost));
        }
    }

    #[test]
    fn a_fit_reports_each_evaluation_and_its_falling_cost() {
        let truth = two_state_model();
        let data = exact_data(&truth, 1500, 11);
        let log = std::sync::Arc::new(IterationLog::default());
        let oe = OutputError {
            weights: Some(vec![1.0, 1.0]),
            progress: Observer::shared(log.clone()),
        };
        let fitted = oe.refine(&data, &perturbed(&truth)).unwrap();
        let calls = log.0.lock().unwrap().clone();
        assert!(calls.len() >= 3, "{} evaluations", calls.len());
        assert!(
            calls.len() <= fitted.iterations + 1,
            "{} > {}",
            calls.len(),
            fitted.iterations
        );
        for (i, (method, n, _)) in calls.iter().enumerate() {
            assert_eq!((method.as_str(), *n), ("oe", i + 1));
        }
        // From a 3 % error to noise-free truth: J falls by orders of magnitude.
        let (first, last) = (calls[0].2, calls.last().unwrap().2);
        assert!(last < 1e-6 * first, "J {first} -> {last}");
    }

    #[test]
    fn weights_are_one_positive_number_per_output() {
        let data = exact_data(&two_state_model(), 500, 17);
        let wrong = OutputError {
            weights: Some(vec![1.0]),
            ..OutputError::default()
        };
        assert!(matches!(
            wrong.estimate(&data),
            Err(EstimationError::WeightShape {
                given_columns: 1,
                columns: 2,
                ..
            })
        ));
        let negative = OutputError {
            weights: Some(vec![1.0, -2.0]),
            ..OutputError::default()
        };
        assert_eq!(
            negative.estimate(&data).unwrap_err(),
            EstimationError::InvalidWeight {
                state: 1,
                value: -2.0
            }
        );
    }
}
