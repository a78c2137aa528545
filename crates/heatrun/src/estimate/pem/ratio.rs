//! The likelihood-ratio test of the predictor's gain against zero: does a process noise
//! or a wandering disturbance explain the data better than the sensors' noise alone?
//!
//! `oe` is `pem` with K_a = 0 (the predictor is then the simulation), so the two fits are
//! nested. With Gaussian innovations of a diagonal covariance, each concentrated out of
//! its output's likelihood (σ̂_c² = SSE_c / N_c), the statistic
//!
//! ```text
//! LR = 2 (ln L_pem − ln L_oe) = Σ_c N_c ln(σ̂²_oe,c / σ̂²_pem,c)
//! ```
//!
//! grows with the record where the gain is real. Where K = 0 is the truth it is χ² with as
//! many degrees of freedom as a free K has entries (Wilks); for a disturbance's
//! intensity q ≥ 0, one parameter on the boundary of its range, it is ½χ²₀ + ½χ²₁ (Self
//! and Liang 1987), whose 1 − α quantile is z²₁₋α. The gain is taken as real where LR
//! exceeds that critical value: a test of size α, whatever the run's length.

/// The test's size α: the probability of taking `pem` where the sensors' noise is all
/// there is.
pub const SIZE: f64 = 0.01;

/// The standard normal quantile of 1 − [`SIZE`], z₀.₉₉.
const Z_99: f64 = 2.326_347_874;

/// The likelihood ratio of a `pem` fit against the `oe` fit it started from.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct LikelihoodRatio {
    /// LR = Σ_c N_c ln(σ̂²_oe,c / σ̂²_pem,c).
    pub statistic: f64,
    /// The entries of K_a: the parameters `pem` adds to `oe`.
    pub degrees_of_freedom: usize,
    /// χ²'s 1 − α quantile for those degrees of freedom (α = [`SIZE`]).
    pub critical: f64,
}

impl LikelihoodRatio {
    /// LR of a free gain of `degrees_of_freedom` entries, from each output's observed
    /// entries N_c and the two fits' noise variances per output (SSE_c / N_c: `oe`'s
    /// simulation errors, `pem`'s innovations); critical value χ²'s 0.99 quantile.
    pub fn gain(
        counts: &[usize],
        oe_variance: &[f64],
        pem_variance: &[f64],
        degrees_of_freedom: usize,
    ) -> LikelihoodRatio {
        LikelihoodRatio {
            statistic: statistic(counts, oe_variance, pem_variance),
            degrees_of_freedom,
            critical: chi_square_quantile_99(degrees_of_freedom),
        }
    }

    /// LR of a disturbance's intensity q ≥ 0 against 0 (one parameter on its boundary):
    /// critical value z₀.₉₉² = 5.41.
    pub fn intensity(
        counts: &[usize],
        oe_variance: &[f64],
        pem_variance: &[f64],
    ) -> LikelihoodRatio {
        LikelihoodRatio {
            statistic: statistic(counts, oe_variance, pem_variance),
            degrees_of_freedom: 1,
            critical: Z_99 * Z_99,
        }
    }

    /// Whether the gain is real: LR above the critical value.
    pub fn rejects_zero_gain(&self) -> bool {
        self.statistic > self.critical
    }
}

/// Σ_c N_c ln(σ̂²_oe,c / σ̂²_pem,c), each variance held at or above [`exact_floor`] of
/// `oe`'s: an output without noise adds nothing either way.
fn statistic(counts: &[usize], oe_variance: &[f64], pem_variance: &[f64]) -> f64 {
    let floor = exact_floor(oe_variance);
    counts
        .iter()
        .zip(oe_variance.iter().zip(pem_variance))
        .map(|(n, (oe, pem))| *n as f64 * (oe.max(floor) / pem.max(floor)).ln())
        .sum()
}

/// An output's variance below 10⁻⁶ of the noisiest output's (an RMS a thousandth of it)
/// is taken as exact: ε² max_c σ_c², ε = 10⁻³. Such an output (the field winding's
/// temperature read from U_f / I_f without noise) carries no noise the Gaussian
/// likelihood can weigh: ln σ̂² → −∞ as a fit reproduces it to rounding, so that
/// 21,000 samples of it swing −½ Σ N_c ln σ̂_c² by 10⁵ to 10⁷ and drown what the noisy
/// outputs say. Held at the floor, its term is constant wherever the fit reproduces it.
pub(crate) fn exact_floor(variances: &[f64]) -> f64 {
    const EPSILON: f64 = 1e-3;
    let largest = variances.iter().copied().fold(0.0_f64, f64::max);
    (EPSILON * EPSILON * largest).max(1e-300)
}

/// χ²_ν's 0.99 quantile by Wilson and Hilferty's cube-root normal approximation,
/// ν (1 − 2/(9ν) + z √(2/(9ν)))³ (within 0.2 % of the exact quantile from ν = 3 up:
/// 26.245 against 26.217 at ν = 12).
pub fn chi_square_quantile_99(degrees_of_freedom: usize) -> f64 {
    wilson_hilferty(degrees_of_freedom, Z_99)
}

/// χ²_ν's quantile of `probability` (in (0, 1)) by the same approximation as
/// [`chi_square_quantile_99`], z the standard normal quantile of `probability`
/// ([`standard_normal_quantile`]).
pub fn chi_square_quantile(degrees_of_freedom: usize, probability: f64) -> f64 {
    wilson_hilferty(degrees_of_freedom, standard_normal_quantile(probability))
}

/// χ²_ν's quantile where the standard normal's is z: ν (1 − 2/(9ν) + z √(2/(9ν)))³.
fn wilson_hilferty(degrees_of_freedom: usize, z: f64) -> f64 {
    let nu = degrees_of_freedom.max(1) as f64;
    let a = 2.0 / (9.0 * nu);
    nu * (1.0 - a + z * a.sqrt()).powi(3)
}

/// The critical value c of a test of size [`SIZE`] on the largest of `tests` independent
/// statistics each χ²_ν where the null holds: P(max > c) = 1 − F(c)^n = α, so c is χ²_ν's
/// (1 − α)^(1/n) quantile (Šidák). Each statistic alone against χ²_ν's 1 − α quantile
/// would reject somewhere with probability 1 − (1 − α)^n: 3.9 % for four outputs.
pub fn chi_square_quantile_of_largest(degrees_of_freedom: usize, tests: usize) -> f64 {
    let tests = tests.max(1) as f64;
    chi_square_quantile(degrees_of_freedom, (1.0 - SIZE).powf(1.0 / tests))
}

/// The standard normal quantile z with Φ(z) = `probability` (in (0, 1)): Φ(z) =
/// ½ erfc(−z/√2) solved by bisection on [−40, 40] to the last bit of z (the quantile
/// is needed a few times a replay).
pub fn standard_normal_quantile(probability: f64) -> f64 {
    let cdf = |z: f64| 0.5 * libm::erfc(-z * std::f64::consts::FRAC_1_SQRT_2);
    let (mut low, mut high) = (-40.0_f64, 40.0_f64);
    for _ in 0..200 {
        let mid = 0.5 * (low + high);
        if mid == low || mid == high {
            break;
        }
        if cdf(mid) < probability {
            low = mid;
        } else {
            high = mid;
        }
    }
    0.5 * (low + high)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Published normal quantiles (Abramowitz & Stegun, table 26.5).
    #[test]
    fn the_normal_quantile_is_the_tables() {
        for (p, table) in [
            (0.5, 0.0),
            (0.975, 1.959_963_985),
            (0.99, Z_99),
            (0.995, 2.575_829_304),
            (0.999, 3.090_232_306),
            (0.01, -Z_99),
        ] {
            let z = standard_normal_quantile(p);
            assert!((z - table).abs() < 1e-8, "{p}: {z} against {table}");
        }
    }

    /// Published χ² quantiles at 0.995 and 0.999 (Abramowitz & Stegun, table 26.8), and
    /// the largest of one statistic is the statistic's own 0.99 quantile.
    #[test]
    fn the_quantiles_of_other_probabilities_are_the_tables_within_half_a_percent() {
        for (nu, p, table) in [
            (30, 0.995, 53.672),
            (60, 0.995, 91.952),
            (60, 0.999, 99.607),
            (100, 0.995, 140.169),
        ] {
            let q = chi_square_quantile(nu, p);
            assert!(
                (q / table - 1.0).abs() < 0.005,
                "ν {nu}, {p}: {q} against {table}"
            );
        }
        let one = chi_square_quantile_of_largest(60, 1);
        assert!((one / chi_square_quantile_99(60) - 1.0).abs() < 1e-9);
    }

    /// The largest of four: (0.99)^(1/4) = 0.997490; its quantile of χ²₆₀ lies between the
    /// tables' 0.995 and 0.999 ones (91.952, 99.607), and a family of four independent
    /// χ²₆₀ held to it rejects somewhere at 1 − (1 − Q(c))⁴ = 1 %, Q χ²'s survival
    /// function (the network's, by the regularised incomplete gamma function), within
    /// the approximation's 0.2 %.
    #[test]
    fn the_largest_of_four_is_held_to_a_family_size_of_one_percent() {
        let c = chi_square_quantile_of_largest(60, 4);
        assert!(c > 91.952 && c < 99.607, "{c}");
        let family =
            |c: f64, n: i32| 1.0 - (1.0 - crate::network::fit::chi_square_survival(c, 60)).powi(n);
        assert!((family(c, 4) - SIZE).abs() < 0.0005, "{}", family(c, 4));
        let three = chi_square_quantile_of_largest(60, 3);
        assert!(
            (family(three, 3) - SIZE).abs() < 0.0005,
            "{}",
            family(three, 3)
        );
        // Each held to the 0.99 quantile instead: a family of four at 3.9 %.
        let each = chi_square_quantile_99(60);
        assert!(
            (family(each, 4) - 0.0394).abs() < 0.001,
            "{}",
            family(each, 4)
        );
    }

    /// Published χ² 0.99 quantiles (Abramowitz & Stegun, table 26.8).
    #[test]
    fn the_quantile_is_the_tables_within_half_a_percent() {
        for (nu, table) in [
            (3, 11.345),
            (6, 16.812),
            (12, 26.217),
            (20, 37.566),
            (30, 50.892),
        ] {
            let q = chi_square_quantile_99(nu);
            assert!(
                (q / table - 1.0).abs() < 0.005,
                "ν {nu}: {q} against {table}"
            );
        }
    }

    #[test]
    fn equal_fits_give_zero_and_a_better_predictor_a_large_ratio() {
        let lr = LikelihoodRatio::gain(&[1000, 1000], &[1.0, 2.0], &[1.0, 2.0], 6);
        assert_eq!(lr.statistic, 0.0);
        assert!(!lr.rejects_zero_gain());
        // 1 % less variance on 10,000 entries: 10⁴·ln(1/0.99) ≈ 100.5.
        let lr = LikelihoodRatio::gain(&[10_000], &[1.0], &[0.99], 6);
        assert!((lr.statistic - 100.503).abs() < 0.01, "{}", lr.statistic);
        assert!(lr.rejects_zero_gain());
        // The boundary's critical value: P(½χ²₁ > 5.41) = 0.01 (χ²₁'s 0.98 quantile 5.412).
        let lr = LikelihoodRatio::intensity(&[10_000], &[1.0], &[0.9995]);
        assert!((lr.critical - 5.412).abs() < 0.001);
        assert!(lr.rejects_zero_gain() == (lr.statistic > 5.412));
    }

    #[test]
    fn an_output_without_noise_does_not_decide_the_ratio() {
        // A noisy output 1 % worse under pem, an exact one reproduced 10⁷ times closer:
        // unfloored, 10⁴·ln 10⁷ ≈ 1.6·10⁵ would take pem; the noisy output says oe.
        let lr = LikelihoodRatio::intensity(&[10_000, 10_000], &[1.0, 1e-15], &[1.01, 1e-22]);
        assert!((lr.statistic - 10_000.0 * (1.0_f64 / 1.01).ln()).abs() < 1e-6);
        assert!(!lr.rejects_zero_gain());
    }
}
