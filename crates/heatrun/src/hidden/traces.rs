//! What the outputs a person looks at (the .rrd, the HTML page) draw of a hidden-state
//! model that is the replay's model: its simulated measured outputs ŷ = C x + D u over
//! the recording, each segment from the initial state the replay fitted to it, and the
//! measured outputs' sensitivity responses T_i ∂ŷ/∂T_i = T_i C ∂x/∂T_i (eqs. 27–29
//! through C) whose RMS norms [`super::analysis`] ranks. Both are made on demand from the
//! model and the replay's data: a replay keeps neither.

use std::borrow::Cow;
use std::ops::Range;

use super::HiddenStateModel;
use crate::estimate::{DiscreteModel, IdentificationData};
use crate::model::sensitivity::SensitivityModel;
use crate::model::{ContinuousModel, ModelError, Spectrum};

use nalgebra::DMatrix;

/// The rows `range` of `data`, borrowed where they are all of it (a week's data are not
/// copied for nothing).
fn rows_of(data: &IdentificationData, range: Range<usize>) -> Cow<'_, IdentificationData> {
    if range == (0..data.len()) {
        Cow::Borrowed(data)
    } else {
        Cow::Owned(data.slice(range))
    }
}

/// ŷ(k) = C x(k) + D u(k) over the whole of `data` (N × p, NaN where nothing is
/// simulated), as the replay compared it with the measurement: the instants of
/// `estimation` segment by segment from the initial states fitted to their outputs (the
/// report's `fit`), the instants after it (a hold-out or a split: the report's
/// `validation`) likewise from states fitted to their own outputs. The instants before
/// `estimation.start` are NaN.
pub fn simulated_outputs(
    model: &HiddenStateModel,
    data: &IdentificationData,
    estimation: Range<usize>,
) -> DMatrix<f64> {
    let mut out = DMatrix::from_element(data.len(), model.c.nrows(), f64::NAN);
    let rest = estimation.end.min(data.len())..data.len();
    for range in [estimation, rest] {
        if range.is_empty() {
            continue;
        }
        let sim = model.simulate_segments(&rows_of(data, range.clone()));
        out.rows_mut(range.start, range.len()).copy_from(&sim);
    }
    out
}

/// The measured outputs' relative sensitivities to the hidden-state model's time
/// constants, T_i ∂ŷ(k)/∂T_i = T_i C s_i(k) with s_i the state sensitivity of the
/// forward recursion (eqs. 27–29; [`SensitivityModel`]), over the estimation instants,
/// each segment from the initial state fitted to it: the responses behind the report's
/// `sensitivity_norms` and `assignment` of a hidden replay.
pub struct OutputSensitivities<'a> {
    model: &'a HiddenStateModel,
    recursion: SensitivityModel,
    time_constants_s: Vec<f64>,
}

impl<'a> OutputSensitivities<'a> {
    /// The modal form of `model` (A_c = ln(Φ)/Ts, its time constants ascending, as the
    /// analysis takes them). Errors where Φ has no real logarithm.
    pub fn new(model: &'a HiddenStateModel) -> Result<OutputSensitivities<'a>, ModelError> {
        let discrete = DiscreteModel {
            phi: model.phi.clone(),
            gamma: model.gamma.clone(),
            ts_s: model.ts_s,
        };
        let spectrum = Spectrum::of(&discrete)?;
        let continuous = ContinuousModel::from_discrete(&discrete)?;
        let recursion = SensitivityModel::new(&continuous, &spectrum.time_constants_s, model.ts_s)?;
        Ok(OutputSensitivities {
            model,
            recursion,
            time_constants_s: spectrum.time_constants_s,
        })
    }

    /// The time constants T_i, ascending, s (the report's `time_constants_s`).
    pub fn time_constants_s(&self) -> &[f64] {
        &self.time_constants_s
    }

    /// Calls `visit(k, T_i ∂ŷ(k)/∂T_i)` (p values, one per measured output) for every
    /// instant k of `data` in the segments of `estimation`, in order; k counts from the
    /// start of `data`. A complex pair's second entry has its first's response (one decay
    /// parameter). Nothing for a time constant out of range.
    pub fn for_each(
        &self,
        i: usize,
        data: &IdentificationData,
        estimation: Range<usize>,
        mut visit: impl FnMut(usize, &[f64]),
    ) {
        if i >= self.time_constants_s.len() {
            return;
        }
        let i = self.recursion.earlier_partner(i).unwrap_or(i);
        let offset = estimation.start;
        let estimation = rows_of(data, estimation);
        let segments = estimation.segments();
        let start = |seg| self.model.fitted_initial_state(&estimation, seg);
        let c = &self.model.c;
        let mut y = vec![0.0; c.nrows()];
        self.recursion
            .for_each_response_from(i, &estimation, &segments, start, |k, rel| {
                for (j, v) in y.iter_mut().enumerate() {
                    *v = c.row(j).dot(&rel.transpose());
                }
                visit(k + offset, &y);
            });
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::hidden::analysis::analyse;
    use crate::hidden::testing::{known_system, simulate_known};

    #[test]
    fn the_responses_rms_are_the_analysis_norms_and_the_simulation_is_the_replays() {
        let model = known_system();
        let data = simulate_known(&model, 300, 0.01, 5);
        let a = analyse(&model, &data, &[1.0, 0.5]).unwrap();
        let s = OutputSensitivities::new(&model).unwrap();
        assert_eq!(s.time_constants_s(), a.spectrum.time_constants_s.as_slice());
        for i in 0..3 {
            let mut sum_sq = [0.0; 2];
            let mut count = 0;
            s.for_each(i, &data, 0..data.len(), |_, y| {
                count += 1;
                for j in 0..2 {
                    sum_sq[j] += y[j] * y[j];
                }
            });
            for (j, sum) in sum_sq.iter().enumerate() {
                let rms = (sum / count as f64).sqrt();
                assert!(
                    (rms - a.norms[j][i]).abs() <= 1e-12 * rms.max(1e-300),
                    "{i} {j}"
                );
            }
        }
        // Estimated on the first 200 instants, the rest held out: each part from its
        // own fitted start, as the replay's fit and validation take them.
        let sim = simulated_outputs(&model, &data, 0..200);
        let head = model.simulate_segments(&data.slice(0..200));
        let tail = model.simulate_segments(&data.slice(200..300));
        for j in 0..2 {
            for k in 0..300 {
                let want = if k < 200 {
                    head[(k, j)]
                } else {
                    tail[(k - 200, j)]
                };
                assert_eq!(sim[(k, j)], want);
            }
        }
    }

    #[test]
    fn the_responses_are_the_central_differences_of_the_simulated_outputs() {
        // The known system's modal form, rebuilt here apart from the recursion's own
        // eigendecomposition: Φ = V diag(μ) V⁻¹ (testing::known_system), A_c = V diag(λ)
        // V⁻¹ with λ = ln μ / Ts, B_c = A_c (Φ − I)⁻¹ Γ held fixed. Moving T_i alone,
        // Φ(T) = V diag(e^{λ Ts}) V⁻¹, Γ(T) = V diag((e^{λ Ts} − 1)/λ) V⁻¹ B_c, and the
        // outputs from the same x0 (the recursion's s(start) = 0).
        let model = known_system();
        let v = DMatrix::from_row_slice(3, 3, &[1.0, 0.4, 0.3, -0.5, 1.0, 0.6, 0.2, -0.7, 1.0]);
        let v_inv = v.clone().try_inverse().unwrap();
        let mu = [0.6f64, 0.92, 0.985];
        let diag = |d: &[f64]| DMatrix::from_diagonal(&nalgebra::DVector::from_column_slice(d));
        assert!((&v * diag(&mu) * &v_inv - &model.phi).amax() < 1e-12);
        let lambda: Vec<f64> = mu.iter().map(|m| m.ln() / model.ts_s).collect();
        let a_c = &v * diag(&lambda) * &v_inv;
        let b_c = &a_c
            * (&model.phi - DMatrix::identity(3, 3))
                .try_inverse()
                .unwrap()
            * &model.gamma;
        let data = simulate_known(&model, 300, 0.01, 9);
        let x0 = model.fitted_initial_state(&data, 0..300);
        let at = |i: usize, t: f64| {
            let mut l = lambda.clone();
            l[i] = -1.0 / t;
            let m: Vec<f64> = l.iter().map(|l| (l * model.ts_s).exp()).collect();
            let g: Vec<f64> = l.iter().zip(&m).map(|(l, m)| (m - 1.0) / l).collect();
            let moved = HiddenStateModel {
                phi: &v * diag(&m) * &v_inv,
                gamma: &v * diag(&g) * &v_inv * &b_c,
                ..model.clone()
            };
            moved.simulate(&data, 0..300, &x0)
        };
        let s = OutputSensitivities::new(&model).unwrap();
        for (i, l) in lambda.iter().enumerate() {
            let t = -1.0 / l;
            assert!((s.time_constants_s()[i] - t).abs() < 1e-9 * t);
            let h = 1e-5 * t;
            let difference = (at(i, t + h) - at(i, t - h)) * (t / (2.0 * h));
            let scale = difference.amax();
            assert!(scale > 1e-3, "T{} moves the outputs", i + 1);
            let mut worst = 0.0f64;
            s.for_each(i, &data, 0..300, |k, y| {
                for j in 0..2 {
                    worst = worst.max((y[j] - difference[(k, j)]).abs());
                }
            });
            assert!(
                worst < 1e-6 * scale,
                "T{}: {worst:e} against {scale:e}",
                i + 1
            );
        }
    }
}
