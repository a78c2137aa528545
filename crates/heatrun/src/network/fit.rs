//! The passive network nearest the identified model: a minimum-distance fit.
//!
//! The algebraic network of [`super::Network::from_continuous`] turns small errors of
//! A_c's entries into large errors of the conductances to the coolant (each G_i0 is a row
//! sum of C·A_c, a difference of large numbers), and the free Φ, Γ have more numbers
//! (n(n+m)) than the network has parameters. Here the network's parameters p — the same
//! as `--method rc`'s (ln C_i, ln G_i0, ln G_ij, each loss column of K on the simplex) —
//! minimise the covariance-weighted distance to the identified Θ̂ = [Φ̂ Γ̂],
//!
//! ```text
//! d(p) = (θ̂ − θ(p))ᵀ Σ̂⁻¹ (θ̂ − θ(p)),     θ(p) = ZOH discretisation of the network,
//! ```
//!
//! with Σ̂ the identified model's covariance (the one behind its delta-method intervals).
//! Asymptotically this is as efficient as fitting the network to the data itself (rc), and
//! needs no new pass over the data. At the minimum d is χ² with n(n+m) − dim p degrees of
//! freedom (3 for three parts and three losses) where the identified model is a passive,
//! energy-conserving network: a large d says it is not.
//!
//! Σ̂ is whitened on its correlation matrix; eigenvalues below
//! [`RELATIVE_EIGENVALUE_FLOOR`] of the largest are raised to it (and the fit says so).
//! Where the model has no usable covariance (a noise-free fit), the distance is unweighted
//! and no χ² test is made.

use nalgebra::{DMatrix, DVector, SymmetricEigen};

use super::{MinimumDistance, Parts, Scaling};
use crate::thermal::rc::{projected, Parametrisation, LOG_RANGE};
use crate::thermal::DiscreteModel;

/// Eigenvalues of Σ̂'s correlation matrix below this share of the largest are raised to
/// it: the whitening stays finite where Σ̂ is (nearly) singular.
pub const RELATIVE_EIGENVALUE_FLOOR: f64 = 1e-10;

/// Gauss–Newton (Levenberg–Marquardt) steps at most.
const MAX_ITERATIONS: usize = 2000;

/// The fitted network (in the energy-conservation scale: each column of K sums to 1)
/// and its distance.
#[derive(Debug, Clone)]
pub(crate) struct Fitted {
    /// C, G and K at the minimum.
    pub parts: Parts,
    /// The distance and its test.
    pub distance: MinimumDistance,
    /// The largest standard error of a capacitance's logarithm (its relative standard
    /// error), max_i √[(JᵀJ)⁻¹]_ii over the capacitances, J = M·∂Θ/∂p at the minimum;
    /// `None` where the distance is unweighted or JᵀJ is singular.
    pub capacitance_standard_error: Option<f64>,
}

/// The largest standard error of ln C_i at `p`: the minimum distance d = ‖M(θ̂ − θ(p))‖² is
/// a χ² in Θ's own uncertainty, so p's covariance is (JᵀJ)⁻¹ with J = M·∂Θ/∂p (the
/// Gauss–Newton approximation; Ferguson, "A Course in Large Sample Theory", §23). Entries
/// at their floor (zero for any purpose: columns ∝ e^p ≈ 0) are left out, as fixed.
fn capacitance_standard_error(
    map: &Parametrisation,
    whitening: &DMatrix<f64>,
    p: &[f64],
) -> Option<f64> {
    let free: Vec<usize> = (0..p.len()).filter(|&q| !map.at_floor(q, p[q])).collect();
    let jacobian = (whitening * map.theta_jacobian(p)).select_columns(&free);
    let inverse = (jacobian.transpose() * &jacobian).try_inverse()?;
    let capacitances = map.capacitances();
    let largest = free
        .iter()
        .enumerate()
        .filter(|(_, &q)| q < capacitances)
        .map(|(k, _)| inverse[(k, k)].max(0.0).sqrt())
        .fold(0.0, f64::max);
    largest.is_finite().then_some(largest)
}

/// The whitening M with d = ‖M·(θ̂ − θ)‖², and how it was made.
struct Whitening {
    matrix: DMatrix<f64>,
    weighted: bool,
    note: String,
}

/// Σ̂ = S·R·S (S its standard errors, R the correlation matrix) → M = Λ^{-1/2}·Vᵀ·S⁻¹
/// from R = V·Λ·Vᵀ, with Λ floored at [`RELATIVE_EIGENVALUE_FLOOR`] of its largest.
fn whitening(covariance: Option<&DMatrix<f64>>, len: usize) -> Whitening {
    let unweighted = |why: &str| Whitening {
        matrix: DMatrix::identity(len, len),
        weighted: false,
        note: format!("unweighted: {why}"),
    };
    let Some(cov) = covariance else {
        return unweighted("the identified model has no covariance");
    };
    let sd: Vec<f64> = (0..len).map(|i| cov[(i, i)].sqrt()).collect();
    if !sd.iter().all(|s| s.is_finite() && *s > 0.0) || !cov.iter().all(|v| v.is_finite()) {
        return unweighted(
            "the identified model's covariance is zero or not finite (a noise-free fit)",
        );
    }
    let r = DMatrix::from_fn(len, len, |i, j| cov[(i, j)] / (sd[i] * sd[j]));
    let eigen = SymmetricEigen::new((&r + r.transpose()) * 0.5);
    let largest = eigen.eigenvalues.max();
    let floor = RELATIVE_EIGENVALUE_FLOOR * largest;
    let floored = eigen.eigenvalues.iter().filter(|&&l| l < floor).count();
    let scale = DVector::from_iterator(
        len,
        eigen.eigenvalues.iter().map(|&l| 1.0 / l.max(floor).sqrt()),
    );
    let inverse_sd =
        DMatrix::from_diagonal(&DVector::from_iterator(len, sd.iter().map(|s| 1.0 / s)));
    let matrix = DMatrix::from_diagonal(&scale) * eigen.eigenvectors.transpose() * inverse_sd;
    let note = if floored == 0 {
        "the inverse covariance of the identified Φ, Γ".to_string()
    } else {
        format!(
            "the inverse covariance of the identified Φ, Γ, regularised: {floored} of its {len} \
             correlation eigenvalues were below {RELATIVE_EIGENVALUE_FLOOR:e} of the largest and raised to it"
        )
    };
    Whitening {
        matrix,
        weighted: true,
        note,
    }
}

/// The passive network nearest `model` (Φ and the columns `heat` of Γ) in the distance
/// weighted by `covariance` (of Θ laid out as [`DiscreteModel::theta`], all inputs), from
/// `start` (the algebraic network, projected onto the passive set here). `None` where
/// the fit cannot evaluate the start.
pub(crate) fn minimum_distance(
    model: &DiscreteModel,
    covariance: Option<&DMatrix<f64>>,
    heat: &[usize],
    scaling: Scaling,
    start: Parts,
) -> Option<Fitted> {
    let (n, m_all) = (model.phi.nrows(), model.gamma.ncols());
    // Θ's entries of Φ and of the heat inputs' columns of Γ, in θ(p)'s layout.
    let kept: Vec<usize> = (0..n)
        .flat_map(|i| {
            (0..n)
                .chain(heat.iter().map(|&j| n + j))
                .map(move |j| i * (n + m_all) + j)
        })
        .collect();
    let theta_all = model.theta();
    let target = DVector::from_iterator(kept.len(), kept.iter().map(|&q| theta_all[q]));
    let selected = covariance
        .filter(|c| c.nrows() == theta_all.len() && c.ncols() == theta_all.len())
        .map(|c| DMatrix::from_fn(kept.len(), kept.len(), |a, b| c[(kept[a], kept[b])]));
    let white = whitening(selected.as_ref(), kept.len());
    let map = Parametrisation::of_shape(model.ts_s, scaling, &projected(start));
    let residual = |p: &[f64]| -> Option<DVector<f64>> {
        let theta = DVector::from_vec(map.model(p).theta());
        let r = &white.matrix * (&target - theta);
        r.iter().all(|v| v.is_finite()).then_some(r)
    };
    let (p, iterations, converged) = levenberg_marquardt(&map, &white.matrix, &residual)?;
    let distance = residual(&p)?.norm_squared();
    let capacitance_standard_error = white
        .weighted
        .then(|| capacitance_standard_error(&map, &white.matrix, &p))
        .flatten();
    let degrees_of_freedom = kept.len().saturating_sub(map.len());
    let p_value = (white.weighted && degrees_of_freedom > 0)
        .then(|| chi_square_survival(distance, degrees_of_freedom));
    Some(Fitted {
        parts: map.parts(&p),
        capacitance_standard_error,
        distance: MinimumDistance {
            distance,
            degrees_of_freedom,
            p_value,
            weighting: white.note,
            iterations,
            converged,
        },
    })
}

/// Minimises ‖r(p)‖² from the map's start with the Jacobian −M·∂Θ/∂p; returns p, the
/// steps taken and whether it ended at a minimum rather than at [`MAX_ITERATIONS`].
///
/// Each step is Levenberg–Marquardt's, (JᵀJ + λ·diag JᵀJ)·δ = −Jᵀr, taken in the
/// coordinates of [`Parametrisation::stepped`] (a capacitance in its logarithm, a
/// conductance or share ratio as itself), with two guards for an entry the fit drives to
/// zero (a conductance or share that is zero in truth):
/// - an entry at its floor whose gradient still points down is held there for the step
///   (an active set), so that the step does not spend its length on a move the floor
///   undoes;
/// - the step is corrected for the valley's curve by geodesic acceleration
///   ([`accelerated`]), refused where the correction is large.
///
/// In the logarithms alone the fit never converged on the four-node machine: one
/// Gauss–Newton step threw a conductance that is zero in truth e^22 below its start, where
/// its Jacobian column ∝ e^p vanishes and it climbed back a hair per step (200 steps at
/// χ² 1,036; 20,000 steps reached χ² 13.8). With both it converges in 50–111 steps.
fn levenberg_marquardt(
    map: &Parametrisation,
    whitening: &DMatrix<f64>,
    residual: &dyn Fn(&[f64]) -> Option<DVector<f64>>,
) -> Option<(Vec<f64>, usize, bool)> {
    let mut p = map.start.clone();
    let mut r = residual(&p)?;
    let mut cost = r.norm_squared();
    let mut lambda = 1e-3;
    let at_bound = |p: &[f64], q: usize, downhill: f64| {
        let s = map.start[q];
        (downhill < 0.0 && p[q] <= s - LOG_RANGE + 1e-9)
            || (downhill > 0.0 && p[q] >= s + LOG_RANGE - 1e-9)
    };
    for iteration in 0..MAX_ITERATIONS {
        // In the coordinates the fit steps in ([`Parametrisation::stepped`]).
        let mut jacobian = -(whitening * map.theta_jacobian(&p));
        for (q, mut column) in jacobian.column_iter_mut().enumerate() {
            column *= map.step_coordinate_scale(q, p[q]);
        }
        let gradient = jacobian.transpose() * &r;
        let free: Vec<usize> = (0..p.len())
            .filter(|&q| !at_bound(&p, q, -gradient[q]))
            .collect();
        let jacobian = jacobian.select_columns(&free);
        let gradient = DVector::from_iterator(free.len(), free.iter().map(|&q| gradient[q]));
        let gram = jacobian.transpose() * &jacobian;
        // A step from a Jacobian that is not finite goes nowhere (and nalgebra's SVD of
        // such a matrix does not return): the fit ends where it is.
        if !gram.iter().all(|v| v.is_finite()) {
            return Some((p, iteration, false));
        }
        let mut accepted = false;
        while lambda < 1e16 {
            let mut damped = gram.clone();
            for q in 0..damped.nrows() {
                damped[(q, q)] += lambda * gram[(q, q)].max(1e-300);
            }
            let step = damped
                .clone()
                .cholesky()
                .map(|c| c.solve(&(-&gradient)))
                .or_else(|| {
                    damped
                        .clone()
                        .svd(true, true)
                        .solve(&(-&gradient), 1e-14)
                        .ok()
                });
            let Some(velocity) = step else { break };
            // Geodesic acceleration (Transtrum & Sethna, 2012): the step corrected for the
            // valley's curve, refused as an overshoot is where the correction is large.
            let Some(step) = accelerated(
                map,
                &p,
                &free,
                &velocity,
                (&r, &jacobian),
                &damped,
                residual,
            ) else {
                lambda *= 4.0;
                continue;
            };
            let mut trial = p.clone();
            for (k, &q) in free.iter().enumerate() {
                trial[q] = map.stepped(q, p[q], step[k]);
            }
            if let Some(r_trial) = residual(&trial) {
                let trial_cost = r_trial.norm_squared();
                if trial_cost < cost {
                    let converged = cost - trial_cost <= 1e-12 * cost || step.amax() < 1e-10;
                    (p, r, cost) = (trial, r_trial, trial_cost);
                    lambda = (lambda / 3.0).max(1e-12);
                    accepted = true;
                    if converged {
                        return Some((p, iteration + 1, true));
                    }
                    break;
                }
            }
            lambda *= 4.0;
        }
        if !accepted {
            return Some((p, iteration, true));
        }
    }
    Some((p, MAX_ITERATIONS, false))
}

/// The finite-difference step along the velocity for the directional second derivative.
const GEODESIC_H: f64 = 0.1;

/// The largest ratio 2‖a‖/‖v‖ (in the damped metric) at which an accelerated step is taken.
const GEODESIC_ALPHA: f64 = 0.75;

/// The step v + a/2 with geodesic acceleration (Transtrum & Sethna 2012, "Improvements to
/// the Levenberg–Marquardt algorithm for nonlinear least-squares minimization"): a solves
/// (JᵀJ + λD)·a = −Jᵀ·r_vv, r_vv ≈ (2/h)·((r(p + h·v) − r(p))/h − J·v), the residuals'
/// second derivative along the velocity v; `None` where 2‖a‖ > α‖v‖ (the valley curves more
/// than the step can follow: the caller raises λ) or the probe leaves the domain.
fn accelerated(
    map: &Parametrisation,
    p: &[f64],
    free: &[usize],
    velocity: &DVector<f64>,
    (r, jacobian): (&DVector<f64>, &DMatrix<f64>),
    damped: &DMatrix<f64>,
    residual: &dyn Fn(&[f64]) -> Option<DVector<f64>>,
) -> Option<DVector<f64>> {
    let mut probe = p.to_vec();
    for (k, &q) in free.iter().enumerate() {
        let s = map.start[q];
        // y + h·v in the fit's coordinates, unbounded (a probe, not a step).
        probe[q] = if q < map.capacitances() {
            p[q] + GEODESIC_H * velocity[k]
        } else {
            let y = map.step_coordinate(q, p[q]) + GEODESIC_H * velocity[k];
            if y <= 0.0 {
                return None;
            }
            s + y.ln()
        };
    }
    let r_h = residual(&probe)?;
    let second = ((r_h - r) / GEODESIC_H - jacobian * velocity) * (2.0 / GEODESIC_H);
    let rhs = -(jacobian.transpose() * second);
    let acceleration = damped.clone().cholesky().map(|c| c.solve(&rhs))?;
    let metric = |x: &DVector<f64>| {
        (0..x.len())
            .map(|k| damped[(k, k)] * x[k] * x[k])
            .sum::<f64>()
            .sqrt()
    };
    (2.0 * metric(&acceleration) <= GEODESIC_ALPHA * metric(velocity))
        .then(|| velocity + acceleration * 0.5)
}

/// P(χ²_k ≥ x) = Q(k/2, x/2), the regularised upper incomplete gamma function (series
/// below a + 1, Lentz's continued fraction above; Numerical Recipes §6.2).
pub fn chi_square_survival(x: f64, k: usize) -> f64 {
    let (a, x) = (k as f64 / 2.0, x / 2.0);
    if x <= 0.0 {
        return 1.0;
    }
    let log_prefactor = a * x.ln() - x - libm::lgamma(a);
    if x < a + 1.0 {
        let (mut term, mut sum, mut ap) = (1.0 / a, 1.0 / a, a);
        for _ in 0..1000 {
            ap += 1.0;
            term *= x / ap;
            sum += term;
            if term.abs() < sum.abs() * 1e-16 {
                break;
            }
        }
        (1.0 - sum * log_prefactor.exp()).clamp(0.0, 1.0)
    } else {
        let tiny = 1e-300;
        let mut b = x + 1.0 - a;
        let (mut c, mut d) = (1.0 / tiny, 1.0 / b);
        let mut h = d;
        for i in 1..1000 {
            let an = -(i as f64) * (i as f64 - a);
            b += 2.0;
            d = an * d + b;
            if d.abs() < tiny {
                d = tiny;
            }
            c = b + an / c;
            if c.abs() < tiny {
                c = tiny;
            }
            d = 1.0 / d;
            let delta = d * c;
            h *= delta;
            if (delta - 1.0).abs() < 1e-16 {
                break;
            }
        }
        (log_prefactor.exp() * h).clamp(0.0, 1.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synth::example::generator_like;

    /// The generator-like machine's scaling (θ_base 80 K, P_base 300 MW).
    fn scaling() -> Scaling {
        Scaling {
            theta_base_k: 80.0,
            p_base_w: 300e6,
        }
    }

    fn model_of(parts: &Parts, scaling: Scaling) -> DiscreteModel {
        let map = Parametrisation::of_shape(1.0, scaling, parts);
        map.model(&map.start)
    }

    #[test]
    fn chi_square_survival_against_closed_forms() {
        // k = 2: e^{−x/2}; k = 3: erfc(√(x/2)) + √(2x/π)·e^{−x/2}; k = 1: erfc(√(x/2)).
        for x in [0.1, 1.0, 3.0, 7.81, 20.0] {
            let want2 = (-x / 2.0_f64).exp();
            let want3 = libm::erfc((x / 2.0_f64).sqrt())
                + (2.0 * x / std::f64::consts::PI).sqrt() * (-x / 2.0_f64).exp();
            let want1 = libm::erfc((x / 2.0_f64).sqrt());
            assert!((chi_square_survival(x, 2) - want2).abs() < 1e-12, "{x}");
            assert!((chi_square_survival(x, 3) - want3).abs() < 1e-12, "{x}");
            assert!((chi_square_survival(x, 1) - want1).abs() < 1e-12, "{x}");
        }
        // The 95 % point of χ²_3 is 7.815.
        assert!((chi_square_survival(7.8147, 3) - 0.05).abs() < 1e-4);
    }

    #[test]
    fn a_network_is_found_again_from_its_own_model_and_a_perturbed_start() {
        let (truth, _) = generator_like();
        let scaling = scaling();
        let model = model_of(&truth, scaling);
        // A start 30 % off in every C and G, and shares moved by 0.1.
        let mut start = truth.clone();
        start.capacitance_j_per_k.iter_mut().for_each(|c| *c *= 1.3);
        start.conductance_w_per_k *= 0.7;
        start.loss_distribution.apply(|k| *k = (*k + 0.1) / 1.3);
        // A covariance with unequal variances and correlations.
        let len = 18;
        let a = DMatrix::from_fn(len, len, |i, j| ((i * 7 + j * 3) % 11) as f64 / 11.0);
        let cov = (&a * a.transpose() + DMatrix::identity(len, len)) * 1e-8;
        let fitted = minimum_distance(&model, Some(&cov), &[0, 1, 2], scaling, start).unwrap();
        let rel = |x: f64, t: f64| ((x - t) / t).abs();
        for i in 0..3 {
            assert!(
                rel(
                    fitted.parts.capacitance_j_per_k[i],
                    truth.capacitance_j_per_k[i]
                ) < 1e-6
            );
            for j in 0..3 {
                let (g, t) = (
                    fitted.parts.conductance_w_per_k[(i, j)],
                    truth.conductance_w_per_k[(i, j)],
                );
                assert!(rel(g, t) < 1e-6, "G[{i},{j}] = {g} vs {t}");
                let (k, t) = (
                    fitted.parts.loss_distribution[(i, j)],
                    truth.loss_distribution[(i, j)],
                );
                assert!((k - t).abs() < 1e-7);
            }
        }
        let d = &fitted.distance;
        assert!(d.distance < 1e-10, "{d:?}");
        assert_eq!(d.degrees_of_freedom, 3);
        assert!(d.p_value.unwrap() > 0.99);
        assert!(!d.weighting.contains("regularised"), "{}", d.weighting);
    }

    #[test]
    fn a_model_that_is_no_network_has_a_large_distance_and_a_singular_covariance_is_regularised() {
        let (truth, _) = generator_like();
        let scaling = scaling();
        let mut model = model_of(&truth, scaling);
        // Make one share negative in Γ (a loss that cools a part): no passive network.
        let g = model.gamma[(0, 2)];
        model.gamma[(0, 2)] = -3.0 * g.abs();
        let len = 18;
        // Rank 17: one direction of Θ with no variance.
        let v = DVector::from_fn(len, |i, _| (i as f64 + 1.0).sin());
        let cov = (DMatrix::identity(len, len) - &v * v.transpose() / v.norm_squared()) * 1e-10;
        let fitted =
            minimum_distance(&model, Some(&cov), &[0, 1, 2], scaling, truth.clone()).unwrap();
        let d = &fitted.distance;
        assert!(d.weighting.contains("regularised"), "{}", d.weighting);
        assert!(d.distance > 100.0, "{d:?}");
        assert!(d.p_value.unwrap() < 1e-6, "{d:?}");
        assert!(fitted.parts.loss_distribution.iter().all(|&k| k > 0.0));
        // No covariance: unweighted, no test.
        let plain = minimum_distance(&model, None, &[0, 1, 2], scaling, truth).unwrap();
        assert!(plain.distance.p_value.is_none());
        assert!(plain.distance.weighting.starts_with("unweighted"));
    }
    /// The capacitances' standard error of the distance's linearisation against the spread
    /// of the fitted ln C over Θ̂ drawn from the covariance it is computed from (seeded), and
    /// its scaling: a covariance four times smaller halves it exactly.
    #[test]
    fn the_capacitances_standard_error_is_the_spread_of_their_fits_over_draws_of_theta() {
        use rand::SeedableRng;
        use rand_distr::{Distribution, Normal};
        let (truth, _) = generator_like();
        let scaling = scaling();
        let model = model_of(&truth, scaling);
        let len = 18;
        let a = DMatrix::from_fn(len, len, |i, j| ((i * 7 + j * 3) % 11) as f64 / 11.0);
        let shape = &a * a.transpose() + DMatrix::identity(len, len);
        let se_of = |cov: &DMatrix<f64>| {
            minimum_distance(&model, Some(cov), &[0, 1, 2], scaling, truth.clone())
                .unwrap()
                .capacitance_standard_error
                .unwrap()
        };
        let unit = se_of(&(&shape * 1e-8));
        // Scaled to a standard error of 2 %, where the linearisation is to hold.
        let cov = &shape * (1e-8 * (0.02 / unit).powi(2));
        let se = se_of(&cov);
        assert!((se / 0.02 - 1.0).abs() < 1e-6, "{se}");
        assert!((se_of(&(&cov / 4.0)) / (se / 2.0) - 1.0).abs() < 1e-6);
        let root = cov.clone().cholesky().unwrap().l();
        let theta = DVector::from_vec(model.theta());
        let normal = Normal::new(0.0, 1.0).unwrap();
        let mut rng = rand::rngs::StdRng::seed_from_u64(17);
        let draws = 300;
        let mut logs = vec![Vec::new(); 3];
        for _ in 0..draws {
            let z = DVector::from_fn(len, |_, _| normal.sample(&mut rng));
            let drawn = &theta + &root * z;
            let noisy = model.with_theta(drawn.as_slice());
            let fitted =
                minimum_distance(&noisy, Some(&cov), &[0, 1, 2], scaling, truth.clone()).unwrap();
            for (i, c) in fitted.parts.capacitance_j_per_k.iter().enumerate() {
                logs[i].push(c.ln());
            }
        }
        let spread = logs
            .iter()
            .map(|l| {
                let mean = l.iter().sum::<f64>() / l.len() as f64;
                (l.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (l.len() - 1) as f64).sqrt()
            })
            .fold(0.0, f64::max);
        // 300 draws: the sample standard deviation within about ±4 % (1σ) of its own.
        assert!(
            (spread / se - 1.0).abs() < 0.15,
            "spread {spread} against {se}"
        );
    }
}
