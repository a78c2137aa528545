use nalgebra::{DMatrix, DVector};
use rand::{Rng, SeedableRng};
use rand_distr::{Distribution, Normal};

use super::*;
use crate::estimate::testing::{simulate, step_inputs, two_state_model, with_noise};

/// Outputs of x(k+1) = Φ x(k) + Γ u(k) + w(k), y = x + v, w ~ N(0, σ_w² I),
/// v ~ N(0, σ_v² I), from x(0) = [0.5, 0.2].
fn stochastic_run(len: usize, sigma_w: f64, sigma_v: f64, seed: u64) -> IdentificationData {
    let truth = two_state_model();
    let u = step_inputs(len, 2, seed);
    let mut rng = rand::rngs::StdRng::seed_from_u64(seed + 1000);
    let (w, v) = (
        Normal::new(0.0, sigma_w).unwrap(),
        Normal::new(0.0, sigma_v).unwrap(),
    );
    let mut x = DVector::from_column_slice(&[0.5, 0.2]);
    let mut y = DMatrix::zeros(len, 2);
    for k in 0..len {
        for c in 0..2 {
            y[(k, c)] = x[c] + v.sample(&mut rng);
        }
        let noise = DVector::from_fn(2, |_, _| w.sample(&mut rng));
        x = &truth.phi * &x + &truth.gamma * u.row(k).transpose() + noise;
    }
    IdentificationData::complete(1.0, y, u)
}

/// The steady-state Kalman gain of x(k+1) = Φ x + w, y = x + v (Q = σ_w² I, R = σ_v² I)
/// in the predictor's form K = Φ P (P + R)⁻¹, P by iterating the Riccati recursion
/// P ← Φ P Φᵀ + Q − Φ P (P + R)⁻¹ P Φᵀ to its fixed point: an independent reference.
/// Returns K and the innovations' covariance P + R.
fn kalman_gain(phi: &DMatrix<f64>, sigma_w: f64, sigma_v: f64) -> (DMatrix<f64>, DMatrix<f64>) {
    let n = phi.nrows();
    let q = DMatrix::identity(n, n) * sigma_w.powi(2);
    let r = DMatrix::identity(n, n) * sigma_v.powi(2);
    let mut p = q.clone();
    for _ in 0..100_000 {
        let s = (&p + &r).try_inverse().unwrap();
        let next = phi * &p * phi.transpose() + &q - phi * &p * &s * &p * phi.transpose();
        if (&next - &p).amax() < 1e-18 {
            p = next;
            break;
        }
        p = next;
    }
    (phi * &p * (&p + &r).try_inverse().unwrap(), p + r)
}

/// How many of Θ's entries lie outside ±z σ of their estimate.
fn outside(e: &Estimate, truth: &DiscreteModel, z: f64) -> usize {
    let cov = e.covariance.as_ref().unwrap();
    let theta = e.model.theta();
    truth
        .theta()
        .iter()
        .enumerate()
        .filter(|(q, t)| (theta[*q] - **t).abs() > z * cov[(*q, *q)].sqrt())
        .count()
}

#[test]
fn process_and_sensor_noise_of_known_covariances_give_the_matrices_and_the_kalman_gain() {
    let truth = two_state_model();
    let (sigma_w, sigma_v) = (0.01, 0.02);
    let data = stochastic_run(20_000, sigma_w, sigma_v, 31);
    let e = PredictionError::default().estimate(&data).unwrap();
    assert_eq!(e.method, Method::Pem);
    let (k_true, innovations) = kalman_gain(&truth.phi, sigma_w, sigma_v);
    let k = &e.predictor.as_ref().unwrap().gain;
    // K's entries have standard errors of about 1/√N ≈ 0.007.
    assert!((k - &k_true).amax() < 0.03, "K {k} against {k_true}");
    assert!(k_true.amax() > 0.2, "the process noise matters: {k_true}");
    // Θ within 3σ of the truth on every entry, the intervals honest.
    assert!(outside(&e, &truth, 3.0) == 0, "{:?}", e.model);
    // The innovations' variance is the filter's P + R (to its standard error of about
    // √(2/N) ≈ 1 % and K's small error).
    for (c, v) in e.noise_variance.iter().enumerate() {
        let want = innovations[(c, c)];
        assert!(
            (v / want - 1.0).abs() < 0.05,
            "output {c}: {v} against {want}"
        );
    }
}

#[test]
fn white_sensor_noise_alone_gives_a_gain_near_zero_and_the_output_error_estimate() {
    let truth = two_state_model();
    let u = step_inputs(20_000, 2, 15);
    let y = simulate(&truth, &u, &[0.5, 0.2]);
    let data = IdentificationData::complete(1.0, with_noise(&y, 0.02, 16), u);
    let pem = PredictionError::default().estimate(&data).unwrap();
    let oe = OutputError::default().estimate(&data).unwrap();
    let k = &pem.predictor.as_ref().unwrap().gain;
    // The optimal K is 0: the estimate's is within its statistical error (≈ 1/√N).
    assert!(k.amax() < 4.0 / (20_000f64).sqrt(), "K = {k}");
    // Θ moves by a small part of its own standard error.
    let cov = oe.covariance.as_ref().unwrap();
    for (q, (a, b)) in pem.model.theta().iter().zip(oe.model.theta()).enumerate() {
        let sd = cov[(q, q)].sqrt();
        assert!(
            (a - b).abs() < 0.5 * sd,
            "entry {q}: pem {a} oe {b} (σ {sd})"
        );
    }
    assert!(outside(&pem, &truth, 3.0) == 0);
    // Its intervals are oe's within a few percent.
    let pem_cov = pem.covariance.as_ref().unwrap();
    for q in 0..cov.nrows() {
        let ratio = (pem_cov[(q, q)] / cov[(q, q)]).sqrt();
        assert!((ratio - 1.0).abs() < 0.1, "entry {q}: σ ratio {ratio}");
    }
}

#[test]
fn missing_outputs_are_skipped_in_the_filters_update() {
    // Output 1 missing at a third of the instants at random, both missing over a stretch:
    // the filter runs through them with the time update (partial where output 0 is seen).
    let truth = two_state_model();
    let (sigma_w, sigma_v) = (0.01, 0.02);
    let full = stochastic_run(20_000, sigma_w, sigma_v, 41);
    let mut rng = rand::rngs::StdRng::seed_from_u64(42);
    let kept = DMatrix::from_fn(20_000, 2, |k, j| {
        !(5_000..5_200).contains(&k) && (j == 0 || rng.random_range(0.0..1.0) > 0.33)
    });
    let data = full.with_output_observed(kept.clone());
    assert!(data.has_partial_outputs());
    let e = PredictionError::default().estimate(&data).unwrap();
    let (k_true, _) = kalman_gain(&truth.phi, sigma_w, sigma_v);
    let k = &e.predictor.as_ref().unwrap().gain;
    assert!((k - &k_true).amax() < 0.05, "K {k} against {k_true}");
    assert!(outside(&e, &truth, 3.0) == 0, "{:?}", e.model);
    // The predictions exist through the gap, and the missing entries' values (garbage
    // here) never enter them: the same data with other values there predict the same.
    let predictor = e.predictor.as_ref().unwrap();
    let a = predictor.predict(&e.model, &data);
    let mut other = data.clone();
    for k in 0..20_000 {
        for j in 0..2 {
            if !kept[(k, j)] {
                other.outputs[(k, j)] = 1e3;
            }
        }
    }
    let b = predictor.predict(&e.model, &other);
    assert!(a.iter().all(|v| v.is_finite()));
    assert_eq!(a, b);
}

#[test]
fn the_innovations_of_the_true_predictor_are_white() {
    // The residual analysis of the predictions: with the true K, the innovations of the
    // stochastic run are white (about 1 % of lags outside the 99 % band).
    let truth = two_state_model();
    let (sigma_w, sigma_v) = (0.01, 0.02);
    let data = stochastic_run(20_000, sigma_w, sigma_v, 51);
    let (gain, _) = kalman_gain(&truth.phi, sigma_w, sigma_v);
    let predictor = Predictor {
        gain,
        disturbance: None,
        innovation_variance: vec![0.0; 2],
        initial_states: Vec::new(),
    };
    let predicted = predictor.predict(&truth, &data);
    let res = crate::model::residuals::analyse(&data, &predicted, 60);
    for (c, v) in res.autocorrelation_outside_band.iter().enumerate() {
        assert!(*v <= 0.05, "output {c}: {v} of lags outside");
    }
    // The simulation's residuals are not white.
    let simulated = truth.simulate_segments(&data, &data.segments());
    let res = crate::model::residuals::analyse(&data, &simulated, 60);
    assert!(res.autocorrelation_outside_band.iter().all(|v| *v > 0.5));
}

/// Outputs of the two-state model with a random walk d entering state `state`,
/// x(k+1) = Φ x + Γ u + e_state d(k), d(k+1) = d(k) + σ_d ε, and white sensor noise σ_v.
fn walk_run(len: usize, sigma_d: f64, sigma_v: f64, state: usize, seed: u64) -> IdentificationData {
    let truth = two_state_model();
    let u = step_inputs(len, 2, seed);
    let mut rng = rand::rngs::StdRng::seed_from_u64(seed + 2000);
    let (w, v) = (
        Normal::new(0.0, sigma_d).unwrap(),
        Normal::new(0.0, sigma_v).unwrap(),
    );
    let mut x = DVector::from_column_slice(&[0.5, 0.2]);
    let mut d = 0.0;
    let mut y = DMatrix::zeros(len, 2);
    for k in 0..len {
        for c in 0..2 {
            y[(k, c)] = x[c] + v.sample(&mut rng);
        }
        x = &truth.phi * &x + &truth.gamma * u.row(k).transpose();
        x[state] += d;
        d += w.sample(&mut rng);
    }
    IdentificationData::complete(1.0, y, u)
}

#[test]
fn a_random_walk_disturbance_is_taken_up_by_its_state_where_oe_is_biased() {
    let truth = two_state_model();
    // d wanders ~1.4·10⁻³ over the run, moving state 1 by ~0.14 (1/(1 − 0.99) times):
    // seven times the sensors' noise, slow against it.
    let (sigma_d, sigma_v) = (1e-5, 0.02);
    let data = walk_run(20_000, sigma_d, sigma_v, 1, 61);
    let oe = OutputError::default().estimate(&data).unwrap();
    let pem = PredictionError {
        disturbance_state: Some(1),
        ..PredictionError::default()
    }
    .estimate(&data)
    .unwrap();
    // oe attributes the walk to Θ: entries outside Gauss–Newton's 3σ intervals, which
    // take its residuals as white (all eight, 4 to 12 σ off, when written) ...
    assert!(outside(&oe, &truth, 3.0) >= 2, "oe {:?}", oe.model);
    // ... while its robust covariance, the sandwich over the residuals the walk leaves
    // correlated, holds every entry within 3σ.
    let robust = Estimate {
        covariance: oe.interval_covariance().cloned(),
        ..oe.clone()
    };
    assert!(oe.robust_covariance.is_some());
    assert_eq!(outside(&robust, &truth, 3.0), 0, "oe {:?}", oe.model);
    // The predictor with the disturbance state finds Θ within 3σ on every entry.
    assert_eq!(outside(&pem, &truth, 3.0), 0, "pem {:?}", pem.model);
    let predictor = pem.predictor.as_ref().unwrap();
    let d = predictor.disturbance.as_ref().expect("a disturbance state");
    assert_eq!(d.state, 1);
    // The intensity within a factor of two (a decade's grid refined by golden section,
    // from one realisation of the walk).
    assert!(
        (d.increment_sd / sigma_d).ln().abs() < 2f64.ln(),
        "√q {} against {sigma_d}",
        d.increment_sd
    );
    // The innovations are the sensors' noise, no longer the walk.
    for v in &pem.noise_variance {
        assert!((v.sqrt() / sigma_v - 1.0) < 0.1, "σ_e {}", v.sqrt());
    }
}

#[test]
fn the_doubling_solves_the_filters_riccati_equation_as_its_recursion_does() {
    // A fast model (the plain recursion settles in a few thousand steps) with the walk
    // into state 0: K_a from the doubling against K_a from iterating
    // P ← Φ_a P Φ_aᵀ + Q − Φ_a P Cᵀ (C P Cᵀ + R)⁻¹ C P Φ_aᵀ.
    let phi = DMatrix::from_row_slice(2, 2, &[0.8, 0.1, 0.05, 0.7]);
    let (q, r) = (1e-3, [0.04, 0.09]);
    let k = super::disturbance::kalman_gain(&phi, 0, q, &r).unwrap();
    let phi_a = DMatrix::from_row_slice(3, 3, &[0.8, 0.1, 1.0, 0.05, 0.7, 0.0, 0.0, 0.0, 1.0]);
    let c = DMatrix::from_row_slice(2, 3, &[1.0, 0.0, 0.0, 0.0, 1.0, 0.0]);
    let rm = DMatrix::from_diagonal(&DVector::from_column_slice(&r));
    let mut qm = DMatrix::zeros(3, 3);
    qm[(2, 2)] = q;
    let mut p = qm.clone();
    for _ in 0..200_000 {
        let s = (&c * &p * c.transpose() + &rm).try_inverse().unwrap();
        p = &phi_a * &p * phi_a.transpose() + &qm
            - &phi_a * &p * c.transpose() * s * &c * &p * phi_a.transpose();
    }
    let s = (&c * &p * c.transpose() + &rm).try_inverse().unwrap();
    let reference = &phi_a * &p * c.transpose() * s;
    assert!((&k - &reference).amax() < 1e-9, "{k} against {reference}");
    assert!(
        reference[(2, 0)] > 0.01,
        "the walk's gain matters: {reference}"
    );
}
