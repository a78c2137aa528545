//! The simulation of the discrete-time model (eq. 8) on identification data: its
//! initial state, whole-range and per-segment responses.

use std::ops::Range;

use nalgebra::{DMatrix, DVector};

use super::IdentificationData;

pub use crate::thermal::DiscreteModel;

/// The simulation of a [`DiscreteModel`] on identification data (eq. 8).
impl DiscreteModel {
    /// The state ŷ(start) a simulation over `range` starts from: the measured y(start)
    /// where observed. Outputs not observed at the start (data with a mask) are fitted:
    /// ŷ(k) = Φ^(k−start) x0 + forced response is linear in x0, so the unknown entries
    /// are the least-squares fit to the observations over the range, taken as a
    /// correction to the next observation of each (the minimum-norm correction where
    /// the observations do not determine it). Without a mask this is y(start).
    pub fn initial_state(&self, data: &IdentificationData, range: Range<usize>) -> DVector<f64> {
        let n = self.phi.nrows();
        let s = range.start;
        let mut x0 = DVector::zeros(n);
        let mut unknown = Vec::new();
        for j in 0..n {
            if data.observed(s, j) {
                x0[j] = data.outputs[(s, j)];
            } else {
                unknown.push(j);
                // Prior: the next observation of this output in the range, if any.
                if let Some(k) = range.clone().find(|&k| data.observed(k, j)) {
                    x0[j] = data.outputs[(k, j)];
                }
            }
        }
        if unknown.is_empty() {
            return x0;
        }
        let correction = self.fit_unknown_start(data, range, &x0, &unknown);
        for (c, &j) in unknown.iter().enumerate() {
            x0[j] += correction[c];
        }
        x0
    }

    /// The least-squares correction δ to the entries `unknown` of x0: the observed
    /// residuals y − ŷ(x0) regressed on S(k) = Φ^(k−start) E_unknown.
    fn fit_unknown_start(
        &self,
        data: &IdentificationData,
        range: Range<usize>,
        x0: &DVector<f64>,
        unknown: &[usize],
    ) -> DVector<f64> {
        let (n, m, q) = (self.phi.nrows(), self.gamma.ncols(), unknown.len());
        let mut sens = DMatrix::zeros(n, q);
        for (c, &j) in unknown.iter().enumerate() {
            sens[(j, c)] = 1.0;
        }
        let (mut y, mut y_next) = (x0.clone(), DVector::zeros(n));
        let (mut u, mut sens_next) = (DVector::zeros(m), DMatrix::zeros(n, q));
        let mut gram = DMatrix::<f64>::zeros(q, q);
        let mut rhs = DVector::<f64>::zeros(q);
        for k in range.start + 1..range.end {
            for l in 0..m {
                u[l] = data.inputs[(k - 1, l)];
            }
            y_next.gemv(1.0, &self.phi, &y, 0.0);
            y_next.gemv(1.0, &self.gamma, &u, 1.0);
            std::mem::swap(&mut y, &mut y_next);
            sens_next.gemm(1.0, &self.phi, &sens, 0.0);
            std::mem::swap(&mut sens, &mut sens_next);
            for j in (0..n).filter(|&j| data.observed(k, j)) {
                let r = data.outputs[(k, j)] - y[j];
                for a in 0..q {
                    rhs[a] += sens[(j, a)] * r;
                    for b in 0..q {
                        gram[(a, b)] += sens[(j, a)] * sens[(j, b)];
                    }
                }
            }
        }
        let scale = gram.diagonal().max().max(1e-300);
        gram.svd(true, true)
            .solve(&rhs, 1e-10 * scale)
            .unwrap_or_else(|_| DVector::zeros(q))
    }

    /// Simulates eq. (8), ŷ(k) = Φ ŷ(k−1) + Γ u(k−1), over `range` from
    /// [`DiscreteModel::initial_state`] (the measured y(start) where known). Returns one
    /// row per instant of the range.
    pub fn simulate(&self, data: &IdentificationData, range: Range<usize>) -> DMatrix<f64> {
        if range.is_empty() {
            return DMatrix::zeros(0, self.phi.nrows());
        }
        let x0 = self.initial_state(data, range.clone());
        self.simulate_from(data, range, x0.as_slice())
    }

    /// Simulates eq. (8) over `range` from ŷ(start) = `x0`, one row per instant.
    pub fn simulate_from(
        &self,
        data: &IdentificationData,
        range: Range<usize>,
        x0: &[f64],
    ) -> DMatrix<f64> {
        let mut out = DMatrix::zeros(range.len(), self.phi.nrows());
        self.simulate_into(data, range, x0, &mut out, 0);
        out
    }

    /// Eq. (8) over `range` from ŷ(start) = `x0`, written into `out`'s rows from
    /// `first_row` on (one per instant of the range).
    fn simulate_into(
        &self,
        data: &IdentificationData,
        range: Range<usize>,
        x0: &[f64],
        out: &mut DMatrix<f64>,
        first_row: usize,
    ) {
        let (n, m) = (self.phi.nrows(), self.gamma.ncols());
        if range.is_empty() {
            return;
        }
        for j in 0..n {
            out[(first_row, j)] = x0[j];
        }
        // Row by row in place: this runs once per instant of a week-long recording in
        // every estimator iteration, so it must not allocate.
        for (i, k) in range.clone().enumerate().skip(1) {
            let row = first_row + i;
            for r in 0..n {
                let mut next = 0.0;
                for c in 0..n {
                    next += self.phi[(r, c)] * out[(row - 1, c)];
                }
                for c in 0..m {
                    next += self.gamma[(r, c)] * data.inputs[(k - 1, c)];
                }
                out[(row, r)] = next;
            }
        }
    }

    /// The initial state that best fits the observations over `range`: ŷ(k) =
    /// Φ^(k−start) x0 + the forced response is linear in x0, so every entry of x0 is the
    /// least-squares fit to the observed outputs, as an estimator that fits its initial
    /// states (`oe`) or the System Identification Toolbox's `resid` takes it; started
    /// from [`DiscreteModel::initial_state`].
    pub fn best_initial_state(
        &self,
        data: &IdentificationData,
        range: Range<usize>,
    ) -> DVector<f64> {
        let x0 = self.initial_state(data, range.clone());
        if range.len() < 2 {
            return x0;
        }
        let every: Vec<usize> = (0..self.phi.nrows()).collect();
        let correction = self.fit_unknown_start(data, range, &x0, &every);
        x0 + correction
    }

    /// The free response Φ^(k−start) δ of each segment's start correction δ =
    /// [`DiscreteModel::best_initial_state`] − [`DiscreteModel::initial_state`]: added to
    /// [`DiscreteModel::simulate_segments`] (eq. 8 is linear in the start) it is the
    /// simulation from the best start, held only until it has decayed, not as a second
    /// simulation (14.5 MB on a week at 1 s, at the replay's peak of memory).
    pub fn start_correction(
        &self,
        data: &IdentificationData,
        segments: &[Range<usize>],
    ) -> StartCorrection {
        let n = self.phi.nrows();
        let mut corrected = Vec::new();
        for seg in segments.iter().filter(|s| s.len() >= 2) {
            let delta =
                self.best_initial_state(data, seg.clone()) - self.initial_state(data, seg.clone());
            let size = delta.amax();
            if !(size > 0.0) {
                continue;
            }
            let mut rows: Vec<f64> = Vec::new();
            let mut x = delta;
            // Until Φ^k δ is below 10⁻¹² of δ: beyond, it moves no residual's digits
            // that matter to a correlation.
            for _ in seg.clone() {
                if x.amax() < 1e-12 * size {
                    break;
                }
                rows.extend(x.iter());
                x = &self.phi * x;
            }
            corrected.push((seg.start, DMatrix::from_row_slice(rows.len() / n, n, &rows)));
        }
        StartCorrection {
            segments: corrected,
        }
    }

    /// The simulated output over every segment, NaN outside them (eq. 8 run from the
    /// start state of each segment).
    pub fn simulate_segments(
        &self,
        data: &IdentificationData,
        segments: &[Range<usize>],
    ) -> DMatrix<f64> {
        // An empty segment simulates nothing and has no first sample to start from.
        let starts: Vec<DVector<f64>> = segments
            .iter()
            .map(|seg| match seg.is_empty() {
                true => DVector::zeros(self.phi.nrows()),
                false => self.initial_state(data, seg.clone()),
            })
            .collect();
        self.simulate_segments_from(data, segments, &starts)
    }

    /// The simulated output over every segment from its given start ŷ(start) (an
    /// estimator's fitted initial states), NaN outside them.
    pub fn simulate_segments_from(
        &self,
        data: &IdentificationData,
        segments: &[Range<usize>],
        starts: &[DVector<f64>],
    ) -> DMatrix<f64> {
        // Each segment written in place: a week at 1 s is 14.5 MB a copy, and the copy of
        // a segment's own simulation was the replay's peak of memory.
        let mut out = DMatrix::from_element(data.len(), data.states(), f64::NAN);
        for (seg, x0) in segments.iter().zip(starts) {
            self.simulate_into(data, seg.clone(), x0.as_slice(), &mut out, seg.start);
        }
        out
    }
}

/// ŷ = x + d: each output's column of a simulation shifted by its offset d (an estimator's
/// error of the first sample the rises are measured from); NaN rows stay NaN.
pub fn add_output_offset(simulated: &mut DMatrix<f64>, offset: &[f64]) {
    for (mut column, d) in simulated.column_iter_mut().zip(offset) {
        column.apply(|v| *v += d);
    }
}

/// Per segment, the free response of its start correction
/// ([`DiscreteModel::start_correction`]): the rows from the segment's first instant until
/// the response has decayed; zero beyond them and outside the segments.
#[derive(Debug, Clone, Default)]
pub struct StartCorrection {
    /// (first instant, rows of the free response from there), by instant.
    segments: Vec<(usize, DMatrix<f64>)>,
}

impl StartCorrection {
    /// The correction to output `i` at instant `k`.
    pub fn at(&self, k: usize, i: usize) -> f64 {
        let after = self.segments.partition_point(|(start, _)| *start <= k);
        match after.checked_sub(1).map(|s| &self.segments[s]) {
            Some((start, rows)) => rows.get((k - start, i)).copied().unwrap_or(0.0),
            None => 0.0,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn two_state() -> DiscreteModel {
        DiscreteModel {
            phi: DMatrix::from_row_slice(2, 2, &[0.9, 0.05, 0.02, 0.97]),
            gamma: DMatrix::from_row_slice(2, 1, &[0.2, 0.03]),
            ts_s: 1.0,
        }
    }

    #[test]
    fn theta_round_trips_row_by_row() {
        let model = two_state();
        assert_eq!(model.theta(), vec![0.9, 0.05, 0.2, 0.02, 0.97, 0.03]);
        assert_eq!(DiscreteModel::from_theta(2, 1, 1.0, &model.theta()), model);
    }

    #[test]
    fn an_unobserved_start_is_fitted_to_the_later_observations() {
        let model = two_state();
        let n = 60;
        let inputs = DMatrix::from_fn(n, 1, |k, _| ((k / 7) % 2) as f64);
        let truth = IdentificationData::complete(1.0, DMatrix::zeros(n, 2), inputs.clone());
        let mut start = truth.clone();
        start.outputs[(0, 0)] = 0.7;
        start.outputs[(0, 1)] = -0.4;
        let y = model.simulate(&start, 0..n);
        // Output 0 seen only every 9th instant from 4, output 1 every 5th from 0.
        let data = IdentificationData::complete(1.0, y.clone(), inputs).with_output_observed(
            DMatrix::from_fn(n, 2, |k, j| if j == 0 { k % 9 == 4 } else { k % 5 == 0 }),
        );
        let x0 = model.initial_state(&data, 0..n);
        assert!((x0[0] - 0.7).abs() < 1e-12, "{x0}");
        assert_eq!(x0[1], -0.4);
        assert!((model.simulate(&data, 0..n) - y).norm() < 1e-11);
    }

    /// A first reading off by (+0.3, −0.2) (a noisy sample) on data the model made from
    /// x0 = (0.7, −0.4): the measured start is the reading, the best start is the truth
    /// (every later instant says so), and the simulation from it reproduces every other
    /// instant (as the measured start's simulation plus the start correction), in two
    /// segments alike.
    #[test]
    fn the_best_start_is_the_truth_under_a_noisy_first_reading() {
        let model = two_state();
        let n = 80;
        let inputs = DMatrix::from_fn(n, 1, |k, _| ((k / 7) % 2) as f64);
        let mut start = IdentificationData::complete(1.0, DMatrix::zeros(n, 2), inputs.clone());
        start.outputs[(0, 0)] = 0.7;
        start.outputs[(0, 1)] = -0.4;
        let first = model.simulate(&start, 0..40);
        start.outputs[(40, 0)] = 0.7;
        start.outputs[(40, 1)] = -0.4;
        let second = model.simulate(&start, 40..n);
        let mut y = DMatrix::zeros(n, 2);
        y.rows_mut(0, 40).copy_from(&first);
        y.rows_mut(40, 40).copy_from(&second);
        let mut measured = y.clone();
        for k in [0, 40] {
            measured[(k, 0)] += 0.3;
            measured[(k, 1)] -= 0.2;
        }
        let data = IdentificationData::complete(1.0, measured, inputs);
        let measured_start = model.initial_state(&data, 0..40);
        assert!((measured_start[0] - 1.0).abs() < 1e-12 && (measured_start[1] + 0.6).abs() < 1e-12);
        let x0 = model.best_initial_state(&data, 0..40);
        assert!(
            (x0[0] - 0.7).abs() < 1e-9 && (x0[1] + 0.4).abs() < 1e-9,
            "{x0}"
        );
        let segments = [0..40, 40..n];
        let from_measured = model.simulate_segments(&data, &segments);
        let correction = model.start_correction(&data, &segments);
        for k in (0..n).filter(|k| k % 40 != 0) {
            for j in 0..2 {
                let own = from_measured[(k, j)] + correction.at(k, j);
                assert!((own - y[(k, j)]).abs() < 1e-9, "instant {k}, output {j}");
            }
        }
        // Off the segments and past the response's decay, nothing is corrected.
        assert_eq!(correction.at(n + 5, 0), 0.0);
    }
}
