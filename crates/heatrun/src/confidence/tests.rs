use super::*;
use crate::model_file::Report;
use std::path::Path;

/// One part heated by one channel, as recorded: x(k+1) = a x(k) + b u(k), Ts = 1 s,
/// C_Θ = diag(σ_a², σ_b²), the model's RMSE 0.05 K.
pub(crate) fn one_state(a: f64, b: f64, sd: [f64; 2]) -> ThermalModel {
    let report = serde_json::json!({
        "profile": crate::model_file::PROFILE,
        "sample_time_s": 1.0,
        "states": ["part"],
        "inputs": ["heater"],
        "phi": [[a]],
        "gamma": [[b]],
        "time_constants_s": [-1.0 / a.ln()],
        "fit": {"rmse_k": [0.05], "max_abs_error_k": [0.2]},
        "model": {
            "name": "one node",
            "states": [{"name": "part", "channel": "part_temp", "reference": "initial",
                        "part": "the part"}],
            "inputs": [{"name": "heater", "source": {"channel": "heater_w"},
                        "unit": "W", "kind": "heat"}],
            "scaling": "as_recorded"
        },
        "estimation": {"initial_temperature_c": [20.0], "temperature_base_k": 1.0},
        "theta_covariance": [[sd[0] * sd[0], 0.0], [0.0, sd[1] * sd[1]]]
    });
    let path = Path::new("model.json");
    ThermalModel::from_report(&Report::from_json(&report.to_string(), path).unwrap(), path).unwrap()
}

#[test]
fn theta_is_laid_out_row_by_row_and_read_back() {
    let mut model = one_state(0.9, 0.05, [1e-4, 1e-4]);
    model.phi = DMatrix::from_row_slice(2, 2, &[0.9, 0.05, 0.02, 0.95]);
    model.gamma = DMatrix::from_row_slice(2, 1, &[0.1, 0.2]);
    let theta = theta_of(&model);
    assert_eq!(theta, vec![0.9, 0.05, 0.1, 0.02, 0.95, 0.2]);
    let back = with_theta(&model, &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0]);
    assert_eq!(
        back.phi,
        DMatrix::from_row_slice(2, 2, &[1.0, 2.0, 4.0, 5.0])
    );
    assert_eq!(back.gamma, DMatrix::from_row_slice(2, 1, &[3.0, 6.0]));
}

#[test]
fn the_steady_state_of_a_scalar_model_linearised_as_by_hand() {
    // y = b u/(1 − a): ∂y/∂a = b u/(1 − a)², ∂y/∂b = u/(1 − a), var y = Σ (∂y/∂θ)² σ².
    let (a, b, u) = (0.98, 0.05, 2.0);
    let sd = [2e-4, 3e-4];
    let model = one_state(a, b, sd);
    let c = model.uncertainty.theta_covariance.clone().unwrap();
    let lin = linearise(&model, &c, |m| {
        Ok(vec![m.gamma[(0, 0)] * u / (1.0 - m.phi[(0, 0)])])
    })
    .unwrap();
    let (ga, gb) = (b * u / (1.0 - a).powi(2), u / (1.0 - a));
    assert!(
        (lin.jacobian[(0, 0)] / ga - 1.0).abs() < 1e-6,
        "{}",
        lin.jacobian
    );
    assert!(
        (lin.jacobian[(0, 1)] / gb - 1.0).abs() < 1e-9,
        "{}",
        lin.jacobian
    );
    let var = (ga * sd[0]).powi(2) + (gb * sd[1]).powi(2);
    assert!((lin.variances(&c)[0] / var - 1.0).abs() < 1e-5);
    assert!((lin.covariance(&c)[(0, 0)] / var - 1.0).abs() < 1e-5);
}

#[test]
fn the_open_loop_variance_follows_the_closed_form_of_a_scalar_model() {
    // From x(0) = 0 under constant u: x(k) = b u (1 − a^k)/(1 − a), so
    // ∂x/∂b = u (1 − a^k)/(1 − a) and ∂x/∂a = b u (1 − a^k − k a^(k−1) (1 − a))/(1 − a)²;
    // the start's variance p0 decays as a^(2k); no process noise.
    let (a, b, u, p0) = (0.95, 0.1, 3.0, 0.0025);
    let sd = [1e-3, 2e-3];
    let model = one_state(a, b, sd);
    let mut v = OpenLoopVariance::start(&model, &[p0]);
    let mut x = DVector::zeros(1);
    let uu = DVector::from_element(1, u);
    for k in 1..=60 {
        v.step(&model, &model.uncertainty, &x, &uu);
        x = &model.phi * &x + &model.gamma * &uu;
        let kf = k as f64;
        let dxdb = u * (1.0 - a.powi(k)) / (1.0 - a);
        let dxda = b * u * (1.0 - a.powi(k) - kf * a.powi(k - 1) * (1.0 - a)) / (1.0 - a).powi(2);
        let want = (dxda * sd[0]).powi(2) + (dxdb * sd[1]).powi(2) + a.powi(2 * k) * p0;
        let got = v.variances(&model, &model.uncertainty, &x, &uu)[0];
        assert!((got / want - 1.0).abs() < 1e-10, "k {k}: {got} vs {want}");
    }
}

#[test]
fn process_noise_accumulates_to_its_stationary_variance() {
    // P(k+1) = a² P(k) + q → q/(1 − a²).
    let mut model = one_state(0.9, 0.1, [0.0, 0.0]);
    model.uncertainty.theta_covariance = None;
    model.uncertainty.process_noise = Some(DMatrix::from_element(1, 1, 0.01));
    let mut v = OpenLoopVariance::start(&model, &[0.0]);
    let (x, u) = (DVector::zeros(1), DVector::zeros(1));
    for _ in 0..400 {
        v.step(&model, &model.uncertainty, &x, &u);
    }
    let want = 0.01 / (1.0 - 0.81);
    assert!((v.variances(&model, &model.uncertainty, &x, &u)[0] / want - 1.0).abs() < 1e-12);
}

/// Two states, one of them hidden, read through y = [1 0.4] x + 0.2 u (C and D free),
/// one input; C_θ over θ_h = [Φ Γ; C D] row by row (3 × 3 + 3 = 9 entries) a seeded
/// positive definite matrix.
fn hidden_two_state() -> ThermalModel {
    let mut model = one_state(0.9, 0.1, [0.0, 0.0]);
    model.phi = DMatrix::from_row_slice(2, 2, &[0.92, 0.05, 0.03, 0.97]);
    model.gamma = DMatrix::from_row_slice(2, 1, &[0.08, 0.02]);
    model.output = Some(crate::model_file::OutputMap {
        c: DMatrix::from_row_slice(1, 2, &[1.0, 0.4]),
        d: DMatrix::from_row_slice(1, 1, &[0.2]),
        state_names: vec!["hidden_1".into(), "hidden_2".into()],
    });
    let a = DMatrix::from_fn(9, 9, |i, j| ((i * 7 + j * 3) % 11) as f64 / 11.0 - 0.45);
    model.uncertainty.theta_covariance =
        Some((&a * a.transpose() + DMatrix::identity(9, 9)) * 1e-6);
    model
}

#[test]
fn a_hidden_models_layout_adds_the_rows_of_c_and_d() {
    let model = hidden_two_state();
    assert_eq!(
        theta_of(&model),
        vec![0.92, 0.05, 0.08, 0.03, 0.97, 0.02, 1.0, 0.4, 0.2]
    );
    let back = with_theta(&model, &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0]);
    let o = back.output.as_ref().unwrap();
    assert_eq!(o.c, DMatrix::from_row_slice(1, 2, &[7.0, 8.0]));
    assert_eq!(o.d, DMatrix::from_row_slice(1, 1, &[9.0]));
    assert_eq!(back.gamma, DMatrix::from_row_slice(2, 1, &[3.0, 6.0]));
}

#[test]
fn a_hidden_models_output_variance_is_the_delta_method_of_its_simulation() {
    // The recursion's exact sensitivities against central differences of the whole
    // open-loop simulation y(k) = C x(k) + D u(k) from x(0) = C⁺ (y0 − D u(0)), over a
    // varying input; no start noise (its share is checked apart below).
    let model = hidden_two_state();
    let cov = model.uncertainty.theta_covariance.clone().unwrap();
    let input = |k: usize| DVector::from_element(1, if k % 20 < 10 { 3.0 } else { 0.5 });
    let y0 = DVector::from_element(1, 0.7);
    let simulate = |m: &ThermalModel| -> Result<Vec<f64>, UseError> {
        let mut x = m.state_from_outputs(&y0, &input(0));
        let mut out = Vec::new();
        for k in 0..50 {
            out.push(m.outputs(&x, &input(k))[0]);
            x = &m.phi * &x + &m.gamma * input(k);
        }
        Ok(out)
    };
    let want = linearise(&model, &cov, simulate).unwrap().variances(&cov);
    let mut v =
        OpenLoopVariance::start(&model, &[0.0]).with_start_sensitivity(&model, &y0, &input(0));
    let mut x = model.state_from_outputs(&y0, &input(0));
    for (k, want) in want.iter().enumerate() {
        let got = v.variances(&model, &model.uncertainty, &x, &input(k))[0];
        assert!(
            (got - want).abs() < 1e-4 * want + 1e-15,
            "k {k}: {got} vs {want}"
        );
        v.step(&model, &model.uncertainty, &x, &input(k));
        x = &model.phi * &x + &model.gamma * input(k);
    }
    // The start's share: C C⁺ σ² C⁺ᵀ Cᵀ = σ² at the start, the outputs read back.
    let mut start = OpenLoopVariance::start(&model, &[0.0025]);
    let mut none = model.clone();
    none.uncertainty.theta_covariance = None;
    let at0 = start.variances(&none, &none.uncertainty, &x, &input(0))[0];
    assert!((at0 / 0.0025 - 1.0).abs() < 1e-12, "{at0}");
    start.step(&none, &none.uncertainty, &x, &input(0));
}

#[test]
fn draws_have_the_mean_and_covariance_asked_for() {
    let mean = DVector::from_vec(vec![1.0, -2.0]);
    let cov = DMatrix::from_row_slice(2, 2, &[4.0, 1.2, 1.2, 1.0]);
    let draws = gaussian_draws(&mean, &cov, 20_000, 7);
    let n = draws.len() as f64;
    let m: DVector<f64> = draws.iter().fold(DVector::zeros(2), |s, d| s + d) / n;
    let c = draws.iter().fold(DMatrix::zeros(2, 2), |s, d| {
        s + (d - &m) * (d - &m).transpose()
    }) / (n - 1.0);
    // Sampling errors of 20,000 draws: about 1 % of each entry's scale; 4 % allowed.
    assert!((&m - &mean).amax() < 0.06, "{m}");
    assert!((&c - &cov).amax() < 0.16, "{c}");
    // Seeded: the same draws again.
    assert_eq!(
        gaussian_draws(&mean, &cov, 3, 7),
        gaussian_draws(&mean, &cov, 3, 7)
    );
    let mut v = vec![3.0, 1.0, 2.0, 5.0, 4.0];
    assert_eq!(quantile(&mut v, 0.5), 3.0);
    assert_eq!(quantile(&mut v, 1.0), 5.0);
}
