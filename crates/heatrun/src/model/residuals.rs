//! Residual analysis: whiteness of the simulation residuals and their independence
//! of the inputs, with the 99 % band ±2.576/√N of a white sequence.

use nalgebra::DMatrix;
use serde::Serialize;

use crate::estimate::IdentificationData;

/// z of the two-sided 99 % normal band.
pub const Z99: f64 = 2.575_829_303_548_901;

/// Autocorrelations and cross-correlations of the residuals e = y − ŷ.
#[derive(Debug, Clone, Serialize)]
pub struct ResidualAnalysis {
    /// Largest lag.
    pub max_lag: usize,
    /// `autocorrelation[i][τ]`: normalised autocorrelation of e_i at lag τ = 0..max_lag.
    pub autocorrelation: Vec<Vec<f64>>,
    /// `cross_correlation[i][j][τ + max_lag]`: normalised correlation of e_i(k) with
    /// u_j(k − τ), τ = −max_lag..max_lag.
    pub cross_correlation: Vec<Vec<Vec<f64>>>,
    /// The 99 % band of a white sequence of this length.
    pub band99: f64,
    /// Samples used.
    pub samples: usize,
    /// Per output: the fraction of lags 1..max_lag outside the band (about 1 % for white residuals).
    pub autocorrelation_outside_band: Vec<f64>,
}

/// Correlation analysis of the residuals over the observed entries where `simulated`
/// exists; a product at lag τ counts where both of its factors are known.
pub fn analyse(
    data: &IdentificationData,
    simulated: &DMatrix<f64>,
    max_lag: usize,
) -> ResidualAnalysis {
    let (n, m, len) = (data.states(), data.input_count(), data.len());
    let centred = Centred::new(data, simulated);
    let samples = (0..len)
        .filter(|&k| (0..n).any(|i| centred.valid(k, i)))
        .count();
    let residual_energy: Vec<f64> = (0..n)
        .map(|i| energy(len, &|k| centred.residual(i, k)))
        .collect();
    let input_energy: Vec<f64> = (0..m)
        .map(|j| energy(len, &|k| centred.input(j, k)))
        .collect();
    let autocorrelation: Vec<Vec<f64>> = (0..n)
        .map(|i| {
            let e = |k: usize| centred.residual(i, k);
            let energies = residual_energy[i] * residual_energy[i];
            (0..=max_lag)
                .map(|lag| correlate(len, &e, &e, energies, lag as i64))
                .collect()
        })
        .collect();
    let cross_correlation = (0..n)
        .map(|i| {
            let e = |k: usize| centred.residual(i, k);
            (0..m)
                .map(|j| {
                    let u = |k: usize| centred.input(j, k);
                    let energies = residual_energy[i] * input_energy[j];
                    (-(max_lag as i64)..=max_lag as i64)
                        .map(|lag| correlate(len, &e, &u, energies, lag))
                        .collect()
                })
                .collect()
        })
        .collect();
    let band99 = Z99 / (samples.max(1) as f64).sqrt();
    let autocorrelation_outside_band = autocorrelation
        .iter()
        .map(|r| r[1..].iter().filter(|v| v.abs() > band99).count() as f64 / max_lag.max(1) as f64)
        .collect();
    ResidualAnalysis {
        max_lag,
        autocorrelation,
        cross_correlation,
        band99,
        samples,
        autocorrelation_outside_band,
    }
}

/// The residuals and inputs with their means removed, read on the fly rather than
/// stored: a week at Ts = 1 s would otherwise hold n + m more series of 604,800 instants.
struct Centred<'a> {
    data: &'a IdentificationData,
    simulated: &'a DMatrix<f64>,
    residual_means: Vec<f64>,
    input_means: Vec<f64>,
}

impl<'a> Centred<'a> {
    fn new(data: &'a IdentificationData, simulated: &'a DMatrix<f64>) -> Centred<'a> {
        let len = data.len();
        let mut centred = Centred {
            data,
            simulated,
            residual_means: vec![0.0; data.states()],
            input_means: vec![0.0; data.input_count()],
        };
        centred.residual_means = (0..data.states())
            .map(|i| mean(len, &|k| centred.residual(i, k)))
            .collect();
        centred.input_means = (0..data.input_count())
            .map(|j| mean(len, &|k| centred.input(j, k)))
            .collect();
        centred
    }

    /// An observed entry where the simulation exists (without a mask: every output of
    /// an instant whose outputs are known).
    fn valid(&self, k: usize, i: usize) -> bool {
        self.data.observed(k, i) && self.simulated[(k, 0)].is_finite()
    }

    /// e_i(k) − mean, where known.
    fn residual(&self, i: usize, k: usize) -> Option<f64> {
        self.valid(k, i)
            .then(|| self.data.outputs[(k, i)] - self.simulated[(k, i)] - self.residual_means[i])
    }

    /// u_j(k) − mean, where known.
    fn input(&self, j: usize, k: usize) -> Option<f64> {
        self.data.inputs_known[k].then(|| self.data.inputs[(k, j)] - self.input_means[j])
    }
}

/// Mean of a series over the instants where it is known.
fn mean(len: usize, f: &dyn Fn(usize) -> Option<f64>) -> f64 {
    let (sum, count) = (0..len)
        .filter_map(f)
        .fold((0.0, 0usize), |(s, c), v| (s + v, c + 1));
    sum / count.max(1) as f64
}

/// Σ x² over the instants where x is known.
fn energy(len: usize, f: &dyn Fn(usize) -> Option<f64>) -> f64 {
    (0..len).filter_map(f).map(|x| x * x).sum::<f64>()
}

/// r_ab(lag) = Σ_k a(k) b(k − lag) / √(Σ a² Σ b²) over the instants where both are
/// known; `energies` is Σ a² Σ b².
fn correlate(
    len: usize,
    a: &dyn Fn(usize) -> Option<f64>,
    b: &dyn Fn(usize) -> Option<f64>,
    energies: f64,
    lag: i64,
) -> f64 {
    let from = lag.max(0) as usize;
    let to = (len as i64 + lag.min(0)).max(0) as usize;
    let sab: f64 = (from..to)
        .filter_map(|k| Some(a(k)? * b((k as i64 - lag) as usize)?))
        .sum();
    sab / energies.sqrt().max(1e-300)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};

    #[test]
    fn white_residuals_stay_in_the_band_and_a_random_walk_does_not() {
        let n = 5000;
        let mut rng = rand::rngs::StdRng::seed_from_u64(3);
        let normal = Normal::new(0.0, 1.0).unwrap();
        let white: Vec<f64> = (0..n).map(|_| normal.sample(&mut rng)).collect();
        let mut walk = vec![0.0; n];
        for k in 1..n {
            walk[k] = walk[k - 1] + white[k];
        }
        let outputs = DMatrix::from_fn(n, 2, |k, j| if j == 0 { white[k] } else { walk[k] });
        let inputs = DMatrix::from_fn(n, 1, |k, _| (k as f64 * 0.01).sin());
        let data = IdentificationData::complete(1.0, outputs, inputs);
        let a = analyse(&data, &DMatrix::zeros(n, 2), 20);
        assert!((a.autocorrelation[0][0] - 1.0).abs() < 1e-12);
        assert!(
            a.autocorrelation_outside_band[0] <= 0.1,
            "{:?}",
            a.autocorrelation_outside_band
        );
        assert_eq!(a.autocorrelation_outside_band[1], 1.0);
        assert!((a.band99 - 2.5758 / (n as f64).sqrt()).abs() < 1e-4);
    }

    #[test]
    fn a_delayed_input_shows_at_its_positive_lag() {
        // e(k) = u(k − 5): the cross-correlation of e with u(k − τ) is 1 at τ = +5 and
        // near zero elsewhere (u white), whatever the sign convention of the lag axis is
        // taken to be elsewhere.
        let (n, delay, max_lag) = (4000, 5usize, 20usize);
        let mut rng = rand::rngs::StdRng::seed_from_u64(8);
        let normal = Normal::new(0.0, 1.0).unwrap();
        let u: Vec<f64> = (0..n).map(|_| normal.sample(&mut rng)).collect();
        let e = DMatrix::from_fn(n, 1, |k, _| if k >= delay { u[k - delay] } else { 0.0 });
        let data = IdentificationData::complete(1.0, e, DMatrix::from_column_slice(n, 1, &u));
        let a = analyse(&data, &DMatrix::zeros(n, 1), max_lag);
        let r = &a.cross_correlation[0][0];
        let peak = (0..r.len()).max_by(|&i, &j| r[i].total_cmp(&r[j])).unwrap();
        assert_eq!(peak as i64 - max_lag as i64, delay as i64);
        assert!(r[peak] > 0.99, "{}", r[peak]);
        assert!(
            r[max_lag - delay].abs() < 0.1,
            "the mirrored lag: {}",
            r[max_lag - delay]
        );
    }
}
