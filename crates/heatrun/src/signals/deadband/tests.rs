use super::*;
use crate::writer::ExceptionFilter;
use std::f64::consts::TAU;

/// A seeded Gaussian stream (Box–Muller on a small LCG), the same everywhere.
fn gaussian(seed: u64) -> impl FnMut() -> f64 {
    let mut state = seed;
    let mut uniform = move || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((state >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    };
    move || {
        let (a, b) = (uniform(), uniform());
        (-2.0 * a.ln()).sqrt() * (2.0 * std::f64::consts::PI * b).cos()
    }
}

/// A course read every second with noise `sigma`, stored by exception (the writer's
/// historian filter: deadband `d`, heartbeat `heartbeat_s`) and laid on the 1 s grid as
/// the decimator lays it (each stored value at its instant, held between).
fn stored_by_exception(
    course: &dyn Fn(f64) -> f64,
    n: usize,
    (d, heartbeat_s): (f64, f64),
    sigma: f64,
) -> (Series, Vec<bool>) {
    let mut noise = gaussian(11);
    let mut filter = ExceptionFilter::new(d, heartbeat_s);
    let mut held = f64::NAN;
    let mut stored = vec![false; n];
    let values = (0..n)
        .map(|k| {
            let v = course(k as f64) + sigma * noise();
            if filter.keep(k as u64 * 1_000_000_000, v) {
                held = v;
                stored[k] = true;
            }
            Some(held)
        })
        .collect();
    (values, stored)
}

/// Largest and RMS error against the course.
fn errors(got: &Series, course: &dyn Fn(f64) -> f64) -> (f64, f64) {
    let e: Vec<f64> = got
        .iter()
        .enumerate()
        .map(|(k, v)| v.unwrap() - course(k as f64))
        .collect();
    let worst = e.iter().fold(0.0f64, |m, e| m.max(e.abs()));
    let rms = (e.iter().map(|e| e * e).sum::<f64>() / e.len() as f64).sqrt();
    (worst, rms)
}

const RUN: usize = 20_880; // 5.8 h at 1 s

/// An inlet's course in time, °C at t s.
type Course = dyn Fn(f64) -> f64;

/// Three courses an inlet takes (a slow wave, a ramp, the synthetic runs' ramp and daily
/// swing), stored without noise: the course is reconstructed within the band everywhere
/// and, being smooth, well inside it; the staircase of held values is not.
#[test]
fn a_course_stored_by_exception_comes_back_within_its_band() {
    let wave = |t: f64| 12.0 + 0.5 * (1.0 - (TAU * t / 7200.0).cos());
    let ramp = |t: f64| 12.0 + t / RUN as f64;
    let river = |t: f64| 12.0 + 0.6 * 3.0 * t / RUN as f64 + 0.4 * 3.0 * (TAU * t / 86_400.0).sin();
    let courses: [(&str, &Course, (f64, f64)); 4] = [
        ("slow wave, 0.05 K, 600 s", &wave, (0.05, 600.0)),
        ("slow wave, 0.1 K, 300 s", &wave, (0.1, 300.0)),
        ("ramp, 0.05 K, 600 s", &ramp, (0.05, 600.0)),
        ("river, 0.1 K, 600 s", &river, (0.1, 600.0)),
    ];
    for (name, course, (d, heartbeat)) in courses {
        let (values, stored) = stored_by_exception(course, RUN, (d, heartbeat), 0.0);
        let record = ExceptionRecord {
            values: &values,
            stored: &stored,
            deadband: d,
        };
        let got = super::course(record, 1.0).unwrap();
        let (worst, rms) = errors(&got, course);
        let (_, staircase) = errors(&values, course);
        eprintln!("{name}: worst {worst:.4} K, RMS {rms:.5} K (held values {staircase:.4} K)");
        assert!(worst <= d + 1e-9, "{name}: {worst} beyond the band {d}");
        assert!(rms < 0.1 * d, "{name}: RMS {rms}");
        assert!(
            staircase > 0.2 * d,
            "{name}: the held values are no test ({staircase})"
        );
    }
}

/// With a PT100's noise the stored points are where noise carried the reading past the
/// band: the record's censored likelihood takes the course to within a quarter of the
/// noise (measured 0.12–0.19 σ; the hard band alone left 0.13–0.37 σ).
#[test]
fn a_noisy_course_stored_by_exception_is_smoothed_to_its_course() {
    let wave = |t: f64| 12.0 + 0.5 * (1.0 - (TAU * t / 7200.0).cos());
    for (d, sigma) in [(0.05, 0.02), (0.1, 0.05), (0.05, 0.05)] {
        let (values, stored) = stored_by_exception(&wave, RUN, (d, 600.0), sigma);
        let record = ExceptionRecord {
            values: &values,
            stored: &stored,
            deadband: d,
        };
        let got = super::course(record, 1.0).unwrap();
        let (worst, rms) = errors(&got, &wave);
        eprintln!("d {d} σ {sigma}: worst {worst:.4} K, RMS {rms:.5} K");
        // The sampled inlet's quadratic leaves 0.14 σ of white noise when every reading
        // is kept; here most are not.
        assert!(
            rms < 0.25 * sigma && worst < d + 3.0 * sigma,
            "{rms} {worst}"
        );
    }
}

/// A value held on every row with no deadband declared: the deadband is the median
/// change, at least the band the historian used.
#[test]
fn the_deadband_of_a_held_value_is_its_usual_change() {
    let ramp = |t: f64| 12.0 + t / RUN as f64;
    let (values, _) = stored_by_exception(&ramp, RUN, (0.05, f64::INFINITY), 0.0);
    let d = estimated_deadband(&values, 4).unwrap();
    assert!((0.05..0.0501).contains(&d), "{d}");
    assert_eq!(estimated_deadband(&values, 100), None);
}

/// The banded LDLᵀ against nalgebra's dense LU on a smoothing system with stiff rows.
#[test]
fn the_banded_solve_is_the_dense_solve() {
    let n = 40;
    let stored: Vec<Option<f64>> = (0..n)
        .map(|k| (k % 7 == 0).then_some((k as f64 * 0.3).sin()))
        .collect();
    let lambda = 37.0;
    let held = [(9usize, 0.7), (20usize, -0.2)];
    let got = Smoother::new(&stored, lambda).solve(&held);
    let mut m = nalgebra::DMatrix::<f64>::zeros(n, n);
    let mut b = nalgebra::DVector::<f64>::zeros(n);
    for c in 1..n - 1 {
        let row = [(c - 1, 1.0), (c, -2.0), (c + 1, 1.0)];
        for &(i, a) in &row {
            for &(j, bb) in &row {
                m[(i, j)] += lambda * a * bb;
            }
        }
    }
    for (k, v) in stored.iter().enumerate() {
        if let Some(v) = v {
            m[(k, k)] += 1.0;
            b[k] += v;
        }
    }
    let stiff = 1e6 * (16.0 * lambda + 1.0);
    for &(k, t) in &held {
        m[(k, k)] += stiff;
        b[k] += stiff * t;
    }
    let want = m.lu().solve(&b).unwrap();
    for (k, (got, want)) in got.iter().zip(want.iter()).enumerate() {
        assert!((got - want).abs() < 1e-8, "{k}: {got} {want}");
    }
}

#[test]
fn a_record_of_other_lengths_or_a_bad_deadband_is_refused() {
    let values: Series = vec![Some(1.0); 5].into_iter().collect();
    let record = ExceptionRecord {
        values: &values,
        stored: &[true; 4],
        deadband: 0.1,
    };
    assert!(matches!(
        super::course(record, 1.0),
        Err(DeadbandError::Lengths { .. })
    ));
    let record = ExceptionRecord {
        values: &values,
        stored: &[true; 5],
        deadband: f64::NAN,
    };
    assert!(matches!(
        super::course(record, 1.0),
        Err(DeadbandError::Deadband(_))
    ));
}
