//! The screen against data simulated from a known model with known flaws: seeded
//! Gaussian noise at a known resolution, glitches and a freeze laid at known instants.

use nalgebra::DMatrix;
use rand::SeedableRng;
use rand_distr::{Distribution, Normal};

use super::*;
use crate::thermal::DiscreteModel;

/// A two-state model at 1 s (time constants of about 50 s and 2,000 s).
fn model() -> DiscreteModel {
    DiscreteModel {
        phi: DMatrix::from_row_slice(2, 2, &[0.975, 0.005, 0.0004, 0.9991]),
        gamma: DMatrix::from_row_slice(2, 1, &[0.5, 0.02]),
        ts_s: 1.0,
    }
}

/// Noise-free outputs (K) of `len` instants under a stepped input, and the input.
fn truth(len: usize) -> (DMatrix<f64>, DMatrix<f64>) {
    let inputs = DMatrix::from_fn(len, 1, |k, _| if (k / 900) % 3 == 2 { 0.3 } else { 1.0 });
    let data = IdentificationData::complete(1.0, DMatrix::zeros(len, 2), inputs.clone());
    (model().simulate(&data, 0..len), inputs)
}

/// The truth measured with noise σ at resolution r (K), from `seed`.
fn measured(y: &DMatrix<f64>, sigma: f64, r: f64, seed: u64) -> DMatrix<f64> {
    let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
    let noise = Normal::new(0.0, sigma).unwrap();
    DMatrix::from_fn(y.nrows(), y.ncols(), |k, j| {
        let v = y[(k, j)] + if k == 0 { 0.0 } else { noise.sample(&mut rng) };
        if r > 0.0 {
            (v / r).round() * r
        } else {
            v
        }
    })
}

/// The screen of `outputs` against the true model's simulation (θ_base = 1 K).
fn screen_of(outputs: &DMatrix<f64>, inputs: &DMatrix<f64>) -> Screening {
    screen_of_with(outputs, inputs, |input| screen(input).unwrap())
}

/// `outputs` screened by `screen` against the true model's simulation (θ_base = 1 K).
fn screen_of_with(
    outputs: &DMatrix<f64>,
    inputs: &DMatrix<f64>,
    screen: impl Fn(&ScreenInput<'_>) -> Screening,
) -> Screening {
    let data = IdentificationData::complete(1.0, outputs.clone(), inputs.clone());
    let sim = model().simulate_segments(&data, &data.segments());
    let series: Vec<Series> = (0..2)
        .map(|j| {
            let mut s = Series::unknown(0);
            for k in 0..outputs.nrows() {
                s.push(Some(outputs[(k, j)] + 40.0));
            }
            s
        })
        .collect();
    let names = ["stator", "core"];
    let channels: Vec<Channel> = (0..2)
        .map(|j| Channel {
            name: names[j],
            measured: &series[j],
            stored_by_exception: false,
            declared_resolution_k: None,
        })
        .collect();
    let time_ns: Vec<i64> = (0..outputs.nrows() as i64)
        .map(|k| k * 1_000_000_000)
        .collect();
    screen(&ScreenInput {
        data: &data,
        simulated: &sim,
        channels: &channels,
        time_ns: &time_ns,
        temperature_base_k: 1.0,
    })
}

#[test]
fn clean_noisy_runs_leave_nothing_out_over_many_seeds() {
    let (y, u) = truth(6000);
    for seed in 0..40 {
        for (sigma, r) in [(0.05, 0.01), (0.2, 0.1), (0.01, 0.0)] {
            let s = screen_of(&measured(&y, sigma, r, seed), &u);
            assert!(
                s.is_empty(),
                "seed {seed}, σ {sigma}, r {r}: {:?}",
                s.left_out
            );
            assert!(
                (s.noise_k[0] - sigma.max(r / 12f64.sqrt())).abs() < 0.2 * sigma,
                "{:?}",
                s.noise_k
            );
        }
    }
}

#[test]
fn noise_free_data_leave_nothing_out() {
    let (y, u) = truth(6000);
    assert!(screen_of(&y, &u).is_empty());
    assert!(screen_of(&measured(&y, 0.0, 0.01, 1), &u).is_empty());
}

/// Outputs screened side by side find what they find one after the other, in the same
/// order, with the same noise and resolution (a frozen stretch and glitches on both).
#[test]
fn side_by_side_and_one_after_the_other_find_the_same() {
    let (y, u) = truth(6000);
    let mut outputs = measured(&y, 0.05, 0.01, 5);
    outputs[(700, 0)] += 2.0;
    outputs[(3100, 1)] -= 1.5;
    for k in 2000..2400 {
        outputs[(k, 1)] = outputs[(2000, 1)];
    }
    let side_by_side = screen_of_with(&outputs, &u, |input| screen_with(input, true).unwrap());
    let in_turn = screen_of_with(&outputs, &u, |input| screen_with(input, false).unwrap());
    assert_eq!(side_by_side, in_turn);
    let states: Vec<usize> = in_turn.left_out.iter().map(|l| l.state).collect();
    assert!(states.contains(&0) && states.contains(&1), "{states:?}");
}

#[test]
fn glitches_are_found_at_their_instants_and_nowhere_else() {
    let (y, u) = truth(6000);
    let mut outputs = measured(&y, 0.05, 0.01, 3);
    // Single glitches, a pair, one at a load step (instant 1800 is the input's step).
    let glitches = [
        (1, 500, 15.0),
        (1, 1801, -2.0),
        (0, 2500, 1.0),
        (0, 2501, 1.2),
        (1, 4000, 0.6),
    ];
    for &(j, k, d) in &glitches {
        outputs[(k, j)] += d;
    }
    let s = screen_of(&outputs, &u);
    let found: Vec<(usize, usize, usize)> = s
        .left_out
        .iter()
        .map(|l| (l.state, l.from_index, l.to_index))
        .collect();
    assert_eq!(
        found,
        vec![
            (0, 2500, 2501),
            (1, 500, 500),
            (1, 1801, 1801),
            (1, 4000, 4000)
        ]
    );
    assert!(s.left_out.iter().all(|l| l.why == Why::Glitch));
    assert_eq!(s.left_out[1].value, outputs[(500, 1)] + 40.0);
    // 0.2 K (4 σ) is noise-like enough to stay.
    outputs[(3000, 0)] += 0.2;
    assert_eq!(screen_of(&outputs, &u).left_out.len(), 4);
}

#[test]
fn a_model_wrong_for_a_few_samples_is_not_a_glitch() {
    // The data of the model with its input 5 s late (a dead time the screen's model
    // lacks): the residual bumps at every step while the readings move smoothly.
    let (y, u) = truth(6000);
    let late = DMatrix::from_fn(6000, 1, |k, _| u[(k.saturating_sub(5), 0)]);
    let data = IdentificationData::complete(1.0, y.clone(), late.clone());
    let delayed = model().simulate(&data, 0..6000);
    let outputs = measured(&delayed, 0.01, 0.0, 9);
    let s = screen_of(&outputs, &u);
    assert!(s.is_empty(), "{:?}", s.left_out);
}

#[test]
fn a_frozen_stretch_is_found_whole_and_a_true_steady_value_is_not() {
    let (y, u) = truth(6000);
    let mut outputs = measured(&y, 0.05, 0.01, 5);
    let held = outputs[(2000, 0)];
    for k in 2000..2600 {
        outputs[(k, 0)] = held;
    }
    let s = screen_of(&outputs, &u);
    assert_eq!(s.left_out.len(), 1, "{:?}", s.left_out);
    let l = &s.left_out[0];
    assert_eq!(
        (l.state, l.from_index, l.to_index, l.why),
        (0, 2000, 2599, Why::Frozen)
    );
    assert_eq!(l.value, held + 40.0);
    assert!(l.deviation_k > 1.0, "the model's change {}", l.deviation_k);

    // The same freeze where the model predicts no change (the state at a steady value).
    let steady_u = DMatrix::from_element(6000, 1, 0.0);
    let mut still = measured(&DMatrix::zeros(6000, 2), 0.05, 0.01, 5);
    for k in 2000..2600 {
        still[(k, 0)] = 0.0;
    }
    assert!(screen_of(&still, &steady_u).is_empty());
}

#[test]
fn the_probability_of_equal_readings_matches_a_count_of_simulated_ones() {
    let mut rng = rand::rngs::StdRng::seed_from_u64(11);
    for (sigma, r) in [(0.05, 0.01), (0.05, 0.05), (0.01, 0.05), (0.2, 0.01)] {
        let noise = Normal::new(0.0, sigma).unwrap();
        let q = |v: f64| (v / r).round();
        let trials = 200_000;
        let mut equal = 0;
        for i in 0..trials {
            // A slowly moving true value, so that every offset from the steps is met.
            let t = 0.37 * r * i as f64 / 97.0;
            if q(t + noise.sample(&mut rng)) == q(t + noise.sample(&mut rng)) {
                equal += 1;
            }
        }
        let counted = equal as f64 / trials as f64;
        let p = frozen::probability_equal(sigma, r);
        assert!(
            (p - counted).abs() < 0.005,
            "σ {sigma}, r {r}: {p} against {counted}"
        );
    }
    assert_eq!(frozen::shortest_implausible_run(21_000, 0.0), 2);
    assert_eq!(frozen::shortest_implausible_run(21_000, 1.0), usize::MAX);
    // 21,000·0.056^(L−1) < 10⁻³ first at L = 7.
    assert_eq!(frozen::shortest_implausible_run(21_000, 0.056), 7);
}

#[test]
fn entries_left_out_become_unobserved_and_the_rest_stay() {
    let (y, u) = truth(100);
    let data = IdentificationData::complete(1.0, y, u);
    let left = LeftOut {
        state: 1,
        channel: "core".into(),
        from_index: 10,
        to_index: 12,
        from_ns: 0,
        to_ns: 0,
        value: 0.0,
        why: Why::Glitch,
        deviation_k: 1.0,
        predicted: vec![40.0; 3],
    };
    let marked = mark_unobserved(&data, &[left]);
    for k in 0..100 {
        assert!(marked.observed(k, 0));
        assert_eq!(marked.observed(k, 1), !(10..=12).contains(&k), "{k}");
    }
    // The simulation runs through them: one segment.
    assert_eq!(marked.segments(), vec![0..100]);
}
