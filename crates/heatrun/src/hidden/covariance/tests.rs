//! The covariance against the spread of the estimates themselves: a known system with a
//! hidden state (`testing::known_system`) identified on many seeded noise draws; the
//! standardised errors of its steady-state gain (invariant under a change of basis),
//! (Ĝ − G)/σ_G with σ_G from the covariance of each draw's own estimate, must have a
//! mean square near 1 (the Monte-Carlo reference, independent of the sandwich's
//! algebra), with white output noise and with AR(1) noise.

use super::*;
use crate::hidden::refine::refine;
use crate::hidden::testing::{known_system, simulate_known, simulate_known_coloured};
use crate::hidden::{HiddenOptions, OrderChoice};

/// The steady-state gain's entries.
fn gain(model: &HiddenStateModel) -> Vec<f64> {
    let g = model.steady_state_gain().expect("no pole at 1");
    g.iter().copied().collect()
}

/// var g ≈ ∇gᵀ C ∇g, ∇g by central differences over θ_h's entries with a variance.
fn delta_method_variance(model: &HiddenStateModel, cov: &DMatrix<f64>) -> Vec<f64> {
    let theta = parameters_of(model);
    let g0 = gain(model);
    let mut grad = DMatrix::zeros(g0.len(), theta.len());
    for q in 0..theta.len() {
        let sd = cov[(q, q)].max(0.0).sqrt();
        if sd == 0.0 {
            continue;
        }
        let h = 1e-2 * sd;
        let mut t = theta.clone();
        t[q] += h;
        let plus = gain(&with_parameters(model, &t));
        t[q] -= 2.0 * h;
        let minus = gain(&with_parameters(model, &t));
        for r in 0..g0.len() {
            grad[(r, q)] = (plus[r] - minus[r]) / (2.0 * h);
        }
    }
    let gc = &grad * cov;
    (0..g0.len()).map(|r| gc.row(r).dot(&grad.row(r))).collect()
}

/// The mean squared standardised error of the gain over `draws` seeded noise draws.
fn mean_square_z(output_matrix: OutputMatrix, draws: u64) -> f64 {
    mean_square_z_of(output_matrix, draws, &|seed| {
        simulate_known(&known_system(), 800, 0.02, seed)
    })
}

/// The same over the draws `data` makes from a seed.
fn mean_square_z_of(
    output_matrix: OutputMatrix,
    draws: u64,
    data: &dyn Fn(u64) -> IdentificationData,
) -> f64 {
    let truth = known_system();
    let true_gain = gain(&truth);
    let mut sum = 0.0;
    let mut count = 0;
    for seed in 0..draws {
        let data = data(100 + seed);
        let refined = refine(&data, &truth, output_matrix, false).unwrap();
        let estimate = HiddenEstimate {
            model: refined.model,
            singular_values: Vec::new(),
            candidates: Vec::new(),
            options: HiddenOptions {
                order: OrderChoice::Given(3),
                output_matrix,
                ..HiddenOptions::default()
            },
            evaluations: refined.evaluations,
            estimation_cost: refined.weighted_sse / refined.compared.max(1) as f64,
        };
        let cov = covariance(&data, &estimate).unwrap();
        assert_eq!(cov.covariance.nrows(), (3 + 2) * (3 + 2));
        let var = delta_method_variance(&estimate.model, &cov.covariance);
        for ((g, t), v) in gain(&estimate.model).iter().zip(&true_gain).zip(&var) {
            assert!(*v > 0.0);
            sum += (g - t).powi(2) / v;
            count += 1;
        }
    }
    sum / count as f64
}

#[test]
fn the_gains_standardised_errors_have_unit_mean_square_with_c_fixed() {
    // 25 draws × 4 entries; a σ off by a factor 1.5 gives 2.25 or 0.44.
    let z2 = mean_square_z(OutputMatrix::Measured, 25);
    println!("C = [I 0]: mean z² = {z2:.3}");
    assert!((0.6..1.6).contains(&z2), "{z2}");
}

#[test]
fn with_a_free_c_the_basis_changes_are_left_out_and_the_gain_still_calibrated() {
    let z2 = mean_square_z(OutputMatrix::Free, 25);
    println!("C free: mean z² = {z2:.3}");
    assert!((0.6..1.6).contains(&z2), "{z2}");
}

#[test]
fn with_coloured_noise_the_gain_is_still_calibrated() {
    // AR(1) noise, ρ = 0.9: the residuals are far from white (their long-run variance is
    // (1 + ρ)/(1 − ρ) = 19 times the white noise's of the same σ), which a covariance
    // taking them as white cannot hold. 25 draws of 3,000 instants.
    let z2 = mean_square_z_of(OutputMatrix::Measured, 25, &|seed| {
        simulate_known_coloured(&known_system(), 3000, 0.02, 0.9, seed)
    });
    println!("AR(1) noise, ρ = 0.9: mean z² = {z2:.3}");
    assert!((0.6..1.6).contains(&z2), "{z2}");
}

#[test]
fn the_fixed_entries_have_no_variance_and_the_basis_changes_are_counted() {
    let truth = known_system();
    let data = simulate_known(&truth, 600, 0.02, 3);
    let refined = refine(&data, &truth, OutputMatrix::Measured, false).unwrap();
    let estimate = HiddenEstimate {
        model: refined.model,
        singular_values: Vec::new(),
        candidates: Vec::new(),
        options: HiddenOptions {
            order: OrderChoice::Given(3),
            ..HiddenOptions::default()
        },
        evaluations: 0,
        estimation_cost: refined.weighted_sse / refined.compared.max(1) as f64,
    };
    let cov = covariance(&data, &estimate).unwrap();
    // (n − p)·n = 3 directions of T⁻¹'s hidden row.
    assert_eq!(cov.basis_directions, 3);
    // Parameters Φ 9 + Γ 6 + x0 3, less the 3 directions.
    assert_eq!(cov.rank, 15);
    // C's and D's rows (entries 15..25) are zero: C = [I 0] and D = 0 are held.
    for k in 15..25 {
        assert_eq!(cov.covariance.row(k).amax(), 0.0);
    }
    // White noise: Andrews' window is a few instants.
    assert!(cov.correlation_window <= 3, "{}", cov.correlation_window);
    // σ̂ is the noise's: 0.02 within 10 %.
    for v in &cov.noise_variance {
        assert!((v.sqrt() / 0.02 - 1.0).abs() < 0.1, "{v}");
    }
}
