//! The estimators' input: sampled outputs and inputs of an n-state, m-input system,
//! with what is known where.

use std::ops::Range;

use nalgebra::DMatrix;

/// Sampled outputs y(k) (N × n) and inputs u(k) (N × m) of a system
/// x(k) = Φ x(k−1) + Γ u(k−1), y = x, with what is known where.
///
/// Two regimes of output knowledge:
/// - no mask (`output_observed: None`): all n outputs are known at instant k or none
///   are (`outputs_known[k]`); an output gap splits the simulation as an input gap does;
/// - a mask (`output_observed: Some`): each output is known at its own instants, as a
///   historian storing by exception keeps them (exact values at their own times). The
///   simulation then runs wherever the inputs are known, through the instants between
///   observations, and every comparison uses the observed entries only.
#[derive(Debug, Clone)]
pub struct IdentificationData {
    /// Sample time Ts in s.
    pub ts_s: f64,
    /// Outputs, one row per instant (unknown entries hold any value and are masked).
    pub outputs: DMatrix<f64>,
    /// Inputs, one row per instant, held over [t_k, t_k + Ts).
    pub inputs: DMatrix<f64>,
    /// Whether every output is known at instant k (with a mask: whether its row is all true).
    pub outputs_known: Vec<bool>,
    /// Whether every input is known at instant k.
    pub inputs_known: Vec<bool>,
    /// Per-entry output knowledge (N × n), or `None`: every output known wherever
    /// `outputs_known[k]`.
    pub output_observed: Option<DMatrix<bool>>,
    /// Per output, how it was stored when it was stored by exception (with a mask):
    /// then an instant without a value says the value stayed within the deadband of
    /// the last kept one. `None`: an unobserved instant says nothing.
    pub exception_storage: Vec<Option<ExceptionStorage>>,
}

/// Storage by exception, as SCADA historians keep a slow signal: a value is kept when it
/// has moved more than `deadband` from the last kept value, or `max_interval` instants
/// after it (the heartbeat). Between kept values the signal was within the deadband.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ExceptionStorage {
    /// The deadband, in the output's units (> 0).
    pub deadband: f64,
    /// The heartbeat, in instants: the longest interval between kept values. An instant
    /// without a value this long after the last kept one is a gap, not a censored value.
    pub max_interval: usize,
}

impl IdentificationData {
    /// The data from outputs and inputs with per-instant knowledge (no mask).
    pub fn new(
        ts_s: f64,
        outputs: DMatrix<f64>,
        inputs: DMatrix<f64>,
        outputs_known: Vec<bool>,
        inputs_known: Vec<bool>,
    ) -> Self {
        debug_assert_eq!(outputs.nrows(), inputs.nrows());
        debug_assert_eq!(outputs_known.len(), outputs.nrows());
        debug_assert_eq!(inputs_known.len(), inputs.nrows());
        let n = outputs.ncols();
        IdentificationData {
            ts_s,
            outputs,
            inputs,
            outputs_known,
            inputs_known,
            output_observed: None,
            exception_storage: vec![None; n],
        }
    }

    /// Builds the data from full matrices (every value known).
    pub fn complete(ts_s: f64, outputs: DMatrix<f64>, inputs: DMatrix<f64>) -> Self {
        let n = outputs.nrows();
        IdentificationData::new(ts_s, outputs, inputs, vec![true; n], vec![true; n])
    }

    /// The same data with each output known only where `observed` (N × n) says, e.g. a
    /// temperature stored by exception; `outputs_known[k]` becomes "row k all observed".
    pub fn with_output_observed(mut self, observed: DMatrix<bool>) -> Self {
        debug_assert_eq!(observed.shape(), self.outputs.shape());
        self.outputs_known = (0..observed.nrows())
            .map(|k| observed.row(k).iter().all(|&o| o))
            .collect();
        self.output_observed = Some(observed);
        self
    }

    /// The same data with each output's storage declared (one entry per output; needs
    /// a mask to mean anything).
    pub fn with_exception_storage(mut self, storage: Vec<Option<ExceptionStorage>>) -> Self {
        debug_assert_eq!(storage.len(), self.states());
        self.exception_storage = storage;
        self
    }

    /// The outputs measured from references moved by `offset` (y − d per output, where
    /// observed): the data an estimated output offset d (ŷ = x + d) leaves as ŷ = x. The
    /// instant the rises are measured from (the first segment's start, every output
    /// exactly zero there) stays zero: there the state is zero by construction, as the
    /// estimator took it, and a simulation starts from it.
    pub fn shift_outputs(&mut self, offset: &[f64]) {
        let reference = self.segments().first().map(|s| s.start).filter(|&k| {
            (0..self.states()).all(|j| self.observed(k, j) && self.outputs[(k, j)] == 0.0)
        });
        for (j, d) in offset.iter().enumerate().take(self.states()) {
            for k in 0..self.len() {
                if self.observed(k, j) && Some(k) != reference {
                    self.outputs[(k, j)] -= d;
                }
            }
        }
    }

    /// The instants in `range` as data of their own.
    pub fn slice(&self, range: Range<usize>) -> IdentificationData {
        IdentificationData {
            ts_s: self.ts_s,
            outputs: self.outputs.rows(range.start, range.len()).into_owned(),
            inputs: self.inputs.rows(range.start, range.len()).into_owned(),
            outputs_known: self.outputs_known[range.clone()].to_vec(),
            inputs_known: self.inputs_known[range.clone()].to_vec(),
            output_observed: self
                .output_observed
                .as_ref()
                .map(|o| o.rows(range.start, range.len()).into_owned()),
            exception_storage: self.exception_storage.clone(),
        }
    }

    /// Number of instants N.
    pub fn len(&self) -> usize {
        self.outputs.nrows()
    }

    /// Whether there are no instants.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Number of states n.
    pub fn states(&self) -> usize {
        self.outputs.ncols()
    }

    /// Number of inputs m.
    pub fn input_count(&self) -> usize {
        self.inputs.ncols()
    }

    /// Whether output j is known at instant k.
    #[inline]
    pub fn observed(&self, k: usize, j: usize) -> bool {
        match &self.output_observed {
            None => self.outputs_known[k],
            Some(o) => o[(k, j)],
        }
    }

    /// Whether some output is unknown at some instant where the mask says so (a
    /// partially observed instant); `false` without a mask.
    pub fn has_partial_outputs(&self) -> bool {
        self.output_observed.as_ref().is_some_and(|o| {
            (0..o.nrows()).any(|k| {
                let seen = o.row(k).iter().filter(|&&v| v).count();
                seen > 0 && seen < o.ncols()
            })
        })
    }

    /// Regressor j of the equation for y(k): the j-th entry of φ(k) = [y(k−1)ᵀ u(k−1)ᵀ]ᵀ.
    #[inline]
    pub fn regressor(&self, k: usize, j: usize) -> f64 {
        let n = self.states();
        if j < n {
            self.outputs[(k - 1, j)]
        } else {
            self.inputs[(k - 1, j - n)]
        }
    }

    /// Fills `row` (length n + m) with φ(k) = [y(k−1)ᵀ u(k−1)ᵀ]ᵀ.
    #[inline]
    pub fn regressor_row(&self, k: usize, row: &mut [f64]) {
        for (j, slot) in row.iter_mut().enumerate() {
            *slot = self.regressor(k, j);
        }
    }

    /// Whether the equation for y(k) can be formed: y(k), y(k−1) and u(k−1) all known.
    /// Rows that would touch missing data are left out, never bridged.
    pub fn row_usable(&self, k: usize) -> bool {
        k >= 1 && self.outputs_known[k] && self.outputs_known[k - 1] && self.inputs_known[k - 1]
    }

    /// Per output, how many of its entries within `segments` are observed: the count a
    /// per-output mean square divides by.
    pub fn observed_counts(&self, segments: &[Range<usize>]) -> Vec<usize> {
        (0..self.states())
            .map(|j| {
                segments
                    .iter()
                    .flat_map(|s| s.clone())
                    .filter(|&k| self.observed(k, j))
                    .count()
            })
            .collect()
    }

    /// The instants k ≥ 1 whose equation can be formed.
    pub fn usable_rows(&self) -> Vec<usize> {
        (1..self.len()).filter(|&k| self.row_usable(k)).collect()
    }

    /// Maximal runs of instants over which the model can be simulated without
    /// crossing missing data. Without a mask, within a run every equation k > start is
    /// usable. With a mask, a run is where the inputs are known (an output gap does not
    /// split it), trimmed to its first and last instants with some output observed.
    /// Runs of a single instant are left out.
    pub fn segments(&self) -> Vec<Range<usize>> {
        match &self.output_observed {
            None => self.segments_without_mask(),
            Some(_) => self.segments_by_inputs(),
        }
    }

    fn segments_without_mask(&self) -> Vec<Range<usize>> {
        let mut out = Vec::new();
        let mut k = 0;
        while k < self.len() {
            if !self.outputs_known[k] {
                k += 1;
                continue;
            }
            let start = k;
            while k + 1 < self.len() && self.row_usable(k + 1) {
                k += 1;
            }
            if k > start {
                out.push(start..k + 1);
            }
            k += 1;
        }
        out
    }

    fn segments_by_inputs(&self) -> Vec<Range<usize>> {
        let any_observed = |k: usize| (0..self.states()).any(|j| self.observed(k, j));
        let mut out = Vec::new();
        let mut k = 0;
        while k < self.len() {
            // A run [start, end): inputs known at start..end−1 (the last instant's input
            // is not used).
            let start = k;
            while k < self.len() && self.inputs_known[k] {
                k += 1;
            }
            let end = (k + 1).min(self.len());
            k += 1;
            let Some(first) = (start..end).find(|&i| any_observed(i)) else {
                continue;
            };
            let last = (first..end)
                .rev()
                .find(|&i| any_observed(i))
                .unwrap_or(first);
            if last > first {
                out.push(first..last + 1);
            }
        }
        out
    }

    /// The data with every unobserved output entry inside a segment filled by linear
    /// interpolation between its neighbouring observations (held flat beyond the
    /// first and last), and no mask. A crude stand-in, good enough to start an
    /// iterative method from; the data themselves are unchanged.
    pub fn interpolated(&self) -> IdentificationData {
        let mut outputs = self.outputs.clone();
        // Known exactly inside the segments: adjacent segments stay apart, since an
        // instant between them is unknown or its input is.
        let mut outputs_known = vec![false; self.len()];
        for seg in self.segments() {
            let mut filled = true;
            for j in 0..self.states() {
                let seen: Vec<usize> = seg.clone().filter(|&k| self.observed(k, j)).collect();
                filled &= !seen.is_empty();
                fill_between(&mut outputs, j, seg.clone(), &seen);
            }
            // A segment where some output is never seen cannot be filled: left unknown.
            if filled {
                outputs_known[seg].iter_mut().for_each(|v| *v = true);
            }
        }
        IdentificationData::new(
            self.ts_s,
            outputs,
            self.inputs.clone(),
            outputs_known,
            self.inputs_known.clone(),
        )
    }
}

/// Linear interpolation of column j over `range` through the instants `seen`.
fn fill_between(outputs: &mut DMatrix<f64>, j: usize, range: Range<usize>, seen: &[usize]) {
    let (Some(&first), Some(&last)) = (seen.first(), seen.last()) else {
        return;
    };
    for k in range.start..first {
        outputs[(k, j)] = outputs[(first, j)];
    }
    for k in last + 1..range.end {
        outputs[(k, j)] = outputs[(last, j)];
    }
    for pair in seen.windows(2) {
        let (a, b) = (pair[0], pair[1]);
        let (ya, yb) = (outputs[(a, j)], outputs[(b, j)]);
        for k in a + 1..b {
            let f = (k - a) as f64 / (b - a) as f64;
            outputs[(k, j)] = ya + f * (yb - ya);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn masked(n: usize, observed: impl Fn(usize, usize) -> bool) -> IdentificationData {
        let outputs = DMatrix::from_fn(n, 2, |k, j| (k * (j + 1)) as f64);
        let inputs = DMatrix::from_element(n, 1, 1.0);
        IdentificationData::complete(1.0, outputs, inputs)
            .with_output_observed(DMatrix::from_fn(n, 2, observed))
    }

    #[test]
    fn shifting_the_outputs_moves_the_observed_entries_only() {
        let mut data = masked(4, |k, j| !(k == 2 && j == 1));
        data.shift_outputs(&[1.0, -0.5]);
        // Output 0 is k − 1, output 1 is 2k + 0.5 where observed, 4 (unchanged) where not;
        // the first instant, where every output is zero (the rises' reference), stays zero.
        assert_eq!(data.outputs.column(0).as_slice(), &[0.0, 0.0, 1.0, 2.0]);
        assert_eq!(data.outputs.column(1).as_slice(), &[0.0, 2.5, 4.0, 6.5]);
        // Where the first instant is not all zero, it moves too.
        let mut later = IdentificationData::complete(
            1.0,
            DMatrix::from_fn(3, 1, |k, _| k as f64 + 1.0),
            DMatrix::from_element(3, 1, 1.0),
        );
        later.shift_outputs(&[1.0]);
        assert_eq!(later.outputs.column(0).as_slice(), &[0.0, 1.0, 2.0]);
    }

    #[test]
    fn an_output_gap_splits_without_a_mask_and_not_with_one() {
        let mut plain = IdentificationData::complete(
            1.0,
            DMatrix::zeros(20, 2),
            DMatrix::from_element(20, 1, 1.0),
        );
        plain.outputs_known[8] = false;
        assert_eq!(plain.segments(), vec![0..8, 9..20]);
        // The same gap in a mask: the inputs are known throughout, one segment.
        let data = masked(20, |k, _| k != 8);
        assert_eq!(data.segments(), vec![0..20]);
        assert!(!data.outputs_known[8] && data.outputs_known[7]);
        // Rows needing instant 8 are not usable for a regression.
        assert_eq!(data.usable_rows().len(), 19 - 2);
    }

    #[test]
    fn masked_segments_follow_the_inputs_and_trim_to_observations() {
        let mut data = masked(30, |k, j| (k % 5 == 2 && j == 0) || (k == 13 && j == 1));
        data.inputs_known[20] = false;
        // Inputs known over 0..20 (instant 20's input unknown): the run is 0..21, trimmed to
        // the first (2) and last (17) observations; then 21..30, observations at 22 and 27.
        assert_eq!(data.segments(), vec![2..18, 22..28]);
        assert!(data.has_partial_outputs());
    }

    #[test]
    fn interpolation_fills_between_observations() {
        let data = masked(11, |k, j| j == 1 || k % 5 == 0);
        let filled = data.interpolated();
        assert!(filled.output_observed.is_none());
        // Column 0 is k·1, observed at 0, 5, 10: linear, so interpolation is exact.
        for k in 0..11 {
            assert_eq!(filled.outputs[(k, 0)], k as f64);
        }
        assert_eq!(filled.segments(), vec![0..11]);
    }
}
