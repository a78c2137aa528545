//! Several starts for the output-error refinement of one order, the best kept.
//!
//! Output error on a short record has local minima: from the one subspace start, the
//! refinement decided TCLab's heater delay and the glass furnace's order by where it
//! happened to stop (neighbouring delays, with the same parameter count, 5–8 points apart
//! on the held-back data). So each order is refined from every start below and the model
//! with the least estimation cost
//!
//!   2J = Σ_k Σ_j w_j (y_j(k) − ŷ_j(k))²   (`refine`'s cost)
//!
//! is kept, the ordinary practice of SITB's `ssest`/`pem` (several initialisations, the
//! best kept):
//! - the subspace start (PO-MOESP) with i block rows, i = [`horizon_for`]`(largest, p)`;
//! - the subspace start with 2i block rows (the past instruments see twice as far: a
//!   different estimate of the same state space where the data are short or the noise is
//!   coloured);
//! - the refined model of one order less with a state added that no output reads
//!   ([`augmented`]): its outputs are those of the smaller model, so the best start
//!   of order n fits the data at least as well as the model of order n − 1 (the orders'
//!   costs are nested, as their model classes are).

use nalgebra::DMatrix;

use super::refine::{refine, Refined};
use super::subspace::{decompose, horizon_for, Subspace};
use super::{HiddenError, HiddenStateModel, OutputMatrix};
use crate::estimate::IdentificationData;

/// The pole given to the state [`augmented`] adds: a fast mode (τ = 1.4 samples), apart
/// from the slow ones a thermal model already has, so that Φ's eigenvectors stay distinct.
const ADDED_POLE: f64 = 0.5;

/// How strongly the added state is driven, relative to the mean magnitude of each
/// input's column of Γ: enough that its sensitivities are not zero (a state that is
/// never excited is a saddle of the cost, where the gradient in its entries vanishes),
/// and irrelevant to the start's outputs, which do not read it.
const ADDED_DRIVE: f64 = 0.1;

/// The subspace decompositions of one data set, made once for every order.
pub struct Starts {
    subspaces: Vec<Subspace>,
}

impl Starts {
    /// Decomposes `data` at i and 2i block rows for models up to `largest` states; the
    /// longer horizon is left out where the data have too few windows for it. Fails only
    /// where the first fails.
    pub fn new(data: &IdentificationData, largest: usize) -> Result<Starts, HiddenError> {
        let horizon = horizon_for(largest, data.states());
        let mut subspaces = vec![decompose(data, horizon)?];
        if let Ok(longer) = decompose(data, 2 * horizon) {
            subspaces.push(longer);
        }
        Ok(Starts { subspaces })
    }

    /// The singular values of the first decomposition (i block rows), descending.
    pub fn singular_values(&self) -> Vec<f64> {
        self.subspaces[0].singular_values.clone()
    }

    /// The order-`order` model refined from each start (the subspace ones, and
    /// `smaller` augmented where given: the refined model of order − 1 on the same
    /// data), the one with the least cost 2J kept. The first start's error where none
    /// gives a model.
    pub fn best(
        &self,
        data: &IdentificationData,
        order: usize,
        output_matrix: OutputMatrix,
        feedthrough: bool,
        smaller: Option<&HiddenStateModel>,
    ) -> Result<Refined, HiddenError> {
        let subspace_starts = self
            .subspaces
            .iter()
            .map(|s| s.model(data, order, feedthrough, output_matrix));
        let warm = smaller
            .filter(|m| m.order() + 1 == order)
            .map(|m| Ok(augmented(m)));
        // Each start refined on a thread of its own (rayon's), then compared in order: the
        // same model as one after the other, whatever the number of cores.
        use rayon::prelude::*;
        let starts: Vec<Result<HiddenStateModel, HiddenError>> =
            subspace_starts.chain(warm).collect();
        let refined: Vec<Result<Refined, HiddenError>> = starts
            .into_par_iter()
            .map(|start| start.and_then(|s| refine(data, &s, output_matrix, feedthrough)))
            .collect();
        let mut best: Option<Result<Refined, HiddenError>> = None;
        for refined in refined {
            best = Some(match (best, refined) {
                (None, r) => r,
                (Some(Err(_)), Ok(r)) => Ok(r),
                (Some(Ok(b)), Ok(r)) if r.weighted_sse < b.weighted_sse => Ok(r),
                (Some(b), _) => b,
            });
        }
        best.unwrap_or(Err(HiddenError::Order { order, largest: 0 }))
    }
}

/// `model` with one state added that no output reads and that drives no other state:
///
///   Φ' = [Φ 0; 0 λ],  Γ' = [Γ; g],  C' = [C 0],  D' = D,
///
/// with λ = `ADDED_POLE` and g_l = `ADDED_DRIVE` · mean_i |Γ_il|. Its outputs are
/// `model`'s exactly for any x0 (the added state is invisible), so its cost is the smaller
/// model's; the cost's gradient in C's new column (free C) or Φ's new column (C = [I 0])
/// is not zero, so the refinement can use the state. In the measured basis C' is still
/// [I 0].
pub fn augmented(model: &HiddenStateModel) -> HiddenStateModel {
    let (n, m, p) = (model.order(), model.gamma.ncols(), model.c.nrows());
    let mut phi = DMatrix::zeros(n + 1, n + 1);
    phi.view_mut((0, 0), (n, n)).copy_from(&model.phi);
    phi[(n, n)] = ADDED_POLE;
    let mut gamma = DMatrix::zeros(n + 1, m);
    gamma.view_mut((0, 0), (n, m)).copy_from(&model.gamma);
    for l in 0..m {
        let mean = model.gamma.column(l).abs().sum() / n.max(1) as f64;
        gamma[(n, l)] = ADDED_DRIVE * if mean > 0.0 { mean } else { 1.0 };
    }
    let mut c = DMatrix::zeros(p, n + 1);
    c.view_mut((0, 0), (p, n)).copy_from(&model.c);
    HiddenStateModel {
        phi,
        gamma,
        c,
        d: model.d.clone(),
        ts_s: model.ts_s,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::hidden::testing::{known_system, simulate_known};
    use nalgebra::DVector;

    #[test]
    fn the_augmented_model_has_the_smaller_models_outputs() {
        let truth = known_system();
        let data = simulate_known(&truth, 200, 0.0, 2);
        let big = augmented(&truth);
        assert_eq!(big.order(), 4);
        let x0 = DVector::from_vec(vec![0.3, -0.2, 0.1]);
        let x0_big = DVector::from_vec(vec![0.3, -0.2, 0.1, 5.0]);
        let (a, b) = (
            truth.simulate(&data, 0..200, &x0),
            big.simulate(&data, 0..200, &x0_big),
        );
        assert!((a - b).abs().max() < 1e-12);
        // Its time constants are the smaller model's and the added fast one.
        let tau = big.time_constants_s().unwrap();
        assert!((tau[0] - 1.0 / 2f64.ln()).abs() < 1e-9, "{tau:?}");
    }

    #[test]
    fn the_best_start_is_no_worse_than_the_order_below() {
        // Order 2 of the three-state system is wrong; order 3 from its warm start and
        // from the subspace starts must fit at least as well, and as well as refining
        // the truth itself (the global minimum, up to the noise).
        let truth = known_system();
        let data = simulate_known(&truth, 1500, 0.01, 21);
        let starts = Starts::new(&data, 4).unwrap();
        let two = starts
            .best(&data, 2, OutputMatrix::Measured, false, None)
            .unwrap();
        let three = starts
            .best(&data, 3, OutputMatrix::Measured, false, Some(&two.model))
            .unwrap();
        assert!(three.weighted_sse <= two.weighted_sse);
        let from_truth = refine(&data, &truth, OutputMatrix::Measured, false).unwrap();
        assert!(
            three.weighted_sse <= from_truth.weighted_sse * (1.0 + 1e-3),
            "{} vs {}",
            three.weighted_sse,
            from_truth.weighted_sse
        );
    }
}
