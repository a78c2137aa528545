//! Robust statistics the screen judges by: the median, the median absolute deviation
//! and the resolution a channel's values show.

use crate::series::Series;

/// σ = 1.4826 · MAD for Gaussian noise (1 / Φ⁻¹(3/4)).
pub const MAD_TO_SIGMA: f64 = 1.4826;

/// The median of `values` (reordered in place); NaN for none.
pub fn median(values: &mut [f64]) -> f64 {
    if values.is_empty() {
        return f64::NAN;
    }
    let mid = values.len() / 2;
    let (_, m, _) = values.select_nth_unstable_by(mid, f64::total_cmp);
    let upper = *m;
    if values.len() % 2 == 1 {
        return upper;
    }
    let lower = values[..mid]
        .iter()
        .copied()
        .fold(f64::NEG_INFINITY, f64::max);
    0.5 * (lower + upper)
}

/// σ̂ = 1.4826 · median(|v − median(v)|): the standard deviation of Gaussian noise,
/// unmoved by up to half the values being outliers.
pub fn sigma_mad(values: &[f64]) -> f64 {
    let mut v = values.to_vec();
    let m = median(&mut v);
    for x in v.iter_mut() {
        *x = (*x - m).abs();
    }
    MAD_TO_SIGMA * median(&mut v)
}

/// The resolution the channel's values show, in its unit: the 2nd percentile of the
/// nonzero steps |θ(k) − θ(k−1)| between known neighbours. A quantised channel steps by
/// whole multiples of its resolution, the smallest (one step) being common; an
/// unquantised one gives a small fraction of its noise, which only makes the frozen test
/// more cautious. Steps below 10⁻⁹ of the value are rounding, not steps. 0 when the
/// channel never moves.
pub fn resolution(measured: &Series) -> f64 {
    let mut steps: Vec<f64> = measured
        .iter()
        .zip(measured.iter().skip(1))
        .filter_map(|(a, b)| {
            let (a, b) = (a?, b?);
            let step = (b - a).abs();
            (step > 1e-9 * a.abs().max(1.0)).then_some(step)
        })
        .collect();
    if steps.is_empty() {
        return 0.0;
    }
    let at = (steps.len() as f64 * 0.02) as usize;
    let (_, p, _) = steps.select_nth_unstable_by(at, f64::total_cmp);
    *p
}

/// Φ(x), the standard normal distribution function (Abramowitz & Stegun 7.1.26 for
/// erf, |error| < 1.5·10⁻⁷: ample for a probability that is compared on a log scale).
pub fn normal_cdf(x: f64) -> f64 {
    let z = x.abs() / std::f64::consts::SQRT_2;
    let t = 1.0 / (1.0 + 0.327_591_1 * z);
    let poly = t
        * (0.254_829_592
            + t * (-0.284_496_736
                + t * (1.421_413_741 + t * (-1.453_152_027 + t * 1.061_405_429))));
    let erf = 1.0 - poly * (-z * z).exp();
    if x >= 0.0 {
        0.5 * (1.0 + erf)
    } else {
        0.5 * (1.0 - erf)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn median_and_mad_of_known_sets() {
        assert_eq!(median(&mut [3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(&mut [4.0, 1.0, 3.0, 2.0]), 2.5);
        // |v − 3| = 2, 1, 0, 1, 97: MAD 1.
        assert!((sigma_mad(&[1.0, 2.0, 3.0, 4.0, 100.0]) - MAD_TO_SIGMA).abs() < 1e-12);
    }

    #[test]
    fn the_normal_cdf_at_known_points() {
        for (x, p) in [
            (0.0, 0.5),
            (1.0, 0.841_344_746),
            (-2.0, 0.022_750_132),
            (3.0, 0.998_650_102),
        ] {
            assert!((normal_cdf(x) - p).abs() < 2e-7, "{x}");
        }
    }

    #[test]
    fn the_resolution_of_a_quantised_noisy_channel_is_its_step() {
        use rand::SeedableRng;
        use rand_distr::{Distribution, Normal};
        let mut rng = rand::rngs::StdRng::seed_from_u64(7);
        let noise = Normal::new(0.0, 0.05).unwrap();
        let mut s = Series::unknown(0);
        for k in 0..5000 {
            let v: f64 = 40.0 + 1e-3 * k as f64 + noise.sample(&mut rng);
            s.push(Some((v / 0.01).round() * 0.01));
        }
        assert!((resolution(&s) - 0.01).abs() < 1e-9, "{}", resolution(&s));
    }
}
