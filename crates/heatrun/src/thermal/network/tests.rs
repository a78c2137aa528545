//! The network against hand-worked cases, known networks and the paper's model.

use nalgebra::DMatrix;

use super::*;

/// Relative difference, against the larger magnitude.
fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol * a.abs().max(b.abs()).max(f64::MIN_POSITIVE)
}

fn assert_matrix(found: &DMatrix<f64>, expected: &DMatrix<f64>, tol: f64) {
    let scale = expected.amax();
    assert_eq!(found.shape(), expected.shape());
    for (f, e) in found.iter().zip(expected.iter()) {
        assert!((f - e).abs() <= tol * scale, "{found} vs {expected}");
    }
}

fn rows(m: &[Vec<f64>]) -> DMatrix<f64> {
    DMatrix::from_fn(m.len(), m[0].len(), |i, j| m[i][j])
}

/// Two parts worked by hand: C = [1000, 4000] J/K, G_12 = 50, G_10 = 10, G_20 = 200 W/K,
/// K = [[0.8, 0.3], [0.2, 0.7]], θ_base = 80 K, P_base = 1 MW (P_base/θ_base = 12500 W/K).
/// L = [[60, −50], [−50, 250]] → A_c = −C⁻¹L = [[−0.06, 0.05], [0.0125, −0.0625]];
/// B_c = C⁻¹K·12500 = [[10, 3.75], [0.625, 2.1875]].
fn two_parts() -> (Parts, DMatrix<f64>, DMatrix<f64>, Scaling) {
    let parts = Parts {
        capacitance_j_per_k: vec![1000.0, 4000.0],
        conductance_w_per_k: DMatrix::from_row_slice(2, 2, &[10.0, 50.0, 50.0, 200.0]),
        loss_distribution: DMatrix::from_row_slice(2, 2, &[0.8, 0.3, 0.2, 0.7]),
    };
    let a = DMatrix::from_row_slice(2, 2, &[-0.06, 0.05, 0.0125, -0.0625]);
    let b = DMatrix::from_row_slice(2, 2, &[10.0, 3.75, 0.625, 2.1875]);
    let scaling = Scaling {
        theta_base_k: 80.0,
        p_base_w: 1e6,
    };
    (parts, a, b, scaling)
}

fn water_link(state: usize, g: f64) -> Option<CoolantLink> {
    Some(CoolantLink {
        state,
        conductance_w_per_k: g,
    })
}

fn assert_parts(network: &Network, parts: &Parts, tol: f64) {
    for (c, e) in network
        .capacitance_j_per_k
        .iter()
        .zip(&parts.capacitance_j_per_k)
    {
        assert!(close(*c, *e, tol), "C {c} vs {e}");
    }
    assert_matrix(
        &rows(&network.conductance_w_per_k),
        &parts.conductance_w_per_k,
        tol,
    );
    assert_matrix(
        &rows(&network.loss_distribution),
        &parts.loss_distribution,
        tol,
    );
}

#[test]
fn two_parts_to_the_model_by_hand() {
    let (parts, a, b, scaling) = two_parts();
    let labels = Labels::numbered(2, 2);
    let network = Network::from_parts(&parts, scaling, ScaleSource::Calorimetric, &labels).unwrap();
    let (a_c, b_c) = network.to_continuous();
    assert_matrix(&a_c, &a, 1e-15);
    assert_matrix(&b_c, &b, 1e-15);
    assert_eq!(network.resistance_k_per_w[0][1], Some(0.02));
    assert_eq!(network.resistance_k_per_w[1][1], Some(0.005));
    assert_eq!(network.loss_distribution_column_sums, vec![1.0, 1.0]);
    assert!(
        network.passivity.is_passive,
        "{}",
        network.passivity.verdict
    );
}

#[test]
fn heat_flows_balance_the_losses_in_steady_state() {
    // Two parts at θ = [θ1, θ2] K: q_12 = 50·(θ1 − θ2), q_10 = 10·θ1, q_20 = 200·θ2.
    let (parts, _, _, scaling) = two_parts();
    let labels = Labels::numbered(2, 2);
    let network = Network::from_parts(&parts, scaling, ScaleSource::Calorimetric, &labels).unwrap();
    let q = network.heat_flows_w(&[30.0, 10.0]).unwrap();
    assert_eq!(q, vec![vec![300.0, 1000.0], vec![-1000.0, 2000.0]]);
    // In steady state L·θ = K·P: with P = [1200, 0] W, K·P = [960, 240] W, and
    // θ = L⁻¹·K·P = [[60, −50], [−50, 250]]⁻¹·[960, 240] = [20.16, 4.992] K (det 12500);
    // the heat to the coolant is then the whole loss.
    let theta = [
        (250.0 * 960.0 + 50.0 * 240.0) / 12_500.0,
        (50.0 * 960.0 + 60.0 * 240.0) / 12_500.0,
    ];
    assert_eq!(theta, [20.16, 4.992]);
    let q = network.heat_flows_w(&theta).unwrap();
    assert!(close(q[0][0] + q[1][1], 1200.0, 1e-13));
    assert!(close(q[0][1], 960.0 - q[0][0], 1e-13));
    assert!(network.heat_flows_w(&[1.0]).is_err());
}

#[test]
fn two_parts_from_the_model_calorimetric_and_energy_scales_agree() {
    let (parts, a, b, scaling) = two_parts();
    let labels = Labels::numbered(2, 2);
    let network = Network::from_continuous(&a, &b, scaling, water_link(1, 200.0), &labels).unwrap();
    assert_eq!(network.scale_from, ScaleSource::Calorimetric);
    assert_parts(&network, &parts, 1e-13);
    let alt = network.alternative_scale.as_ref().unwrap();
    assert_eq!(alt.scale_from, ScaleSource::EnergyConservation);
    assert!(close(alt.ratio_to_chosen, 1.0, 1e-13));
    assert!(close(alt.capacitance_j_per_k[1], 4000.0, 1e-13));
    assert!(network.passivity.is_passive);
    assert!(network.passivity.relative_asymmetry < 1e-15);

    let network = Network::from_continuous(&a, &b, scaling, None, &labels).unwrap();
    assert_eq!(network.scale_from, ScaleSource::EnergyConservation);
    assert!(network.alternative_scale.is_none());
    assert_parts(&network, &parts, 1e-13);
}

#[test]
fn lost_heat_separates_the_two_scales() {
    // 10 % of each loss enters no modelled part: K columns sum to 0.9, B_c = 0.9·B_c.
    // Calorimetry still gives C; energy conservation makes the columns sum to 1 by
    // inflating everything by 1/0.9.
    let (mut parts, a, b, scaling) = two_parts();
    parts.loss_distribution *= 0.9;
    let labels = Labels::numbered(2, 2);
    let network =
        Network::from_continuous(&a, &(b * 0.9), scaling, water_link(1, 200.0), &labels).unwrap();
    assert_parts(&network, &parts, 1e-13);
    for s in &network.loss_distribution_column_sums {
        assert!(close(*s, 0.9, 1e-13));
    }
    let alt = network.alternative_scale.as_ref().unwrap();
    assert!(close(alt.ratio_to_chosen, 1.0 / 0.9, 1e-13));
    assert!(close(alt.capacitance_j_per_k[0], 1000.0 / 0.9, 1e-13));
    assert!(!network.passivity.is_passive);
    assert_eq!(network.passivity.column_sums_off.len(), 2);
    let verdict = &network.passivity.verdict;
    assert!(
        verdict.contains(
            "the shares of the losses sum to 0.90 (loss 1) and 0.90 (loss 2) instead of 1"
        ),
        "{verdict}"
    );
}

/// A generator-like network: copper, iron, outlet water.
fn three_parts() -> (Parts, Scaling) {
    let g = DMatrix::from_row_slice(
        3,
        3,
        &[0.0, 20e3, 15e3, 20e3, 2e3, 60e3, 15e3, 60e3, 201.6e3],
    );
    let parts = Parts {
        capacitance_j_per_k: vec![6e6, 45e6, 5e6],
        conductance_w_per_k: g,
        loss_distribution: DMatrix::from_row_slice(
            3,
            3,
            &[0.9, 0.0, 0.05, 0.05, 0.3, 0.9, 0.05, 0.7, 0.05],
        ),
    };
    let scaling = Scaling {
        theta_base_k: 80.0,
        p_base_w: 100e6,
    };
    (parts, scaling)
}

#[test]
fn three_parts_round_trip_and_cycle_residual() {
    let (parts, scaling) = three_parts();
    let labels = Labels::numbered(3, 3);
    let known = Network::from_parts(&parts, scaling, ScaleSource::Calorimetric, &labels).unwrap();
    // G_10 = 0: no resistance to the coolant.
    assert_eq!(known.resistance_k_per_w[0][0], None);
    let (a, b) = known.to_continuous();
    // Hand check of two entries: a_12 = G_12/C_1, b_33 = k_33·(P_base/θ_base)/C_3.
    assert!(close(a[(0, 1)], 20e3 / 6e6, 1e-15));
    assert!(close(b[(2, 2)], 0.05 * 100e6 / 80.0 / 5e6, 1e-15));
    let cycle = &known.passivity.cycle_residuals[0];
    assert_eq!(cycle.parts, [0, 1, 2]);
    assert!(close(cycle.ratio.unwrap(), 1.0, 1e-14));
    assert!(cycle.residual.abs() < 1e-14 * cycle.forward.abs());

    for coolant in [water_link(2, 201.6e3), None] {
        let network = Network::from_continuous(&a, &b, scaling, coolant, &labels).unwrap();
        assert_parts(&network, &parts, 1e-10);
        assert!(
            network.passivity.is_passive,
            "{}",
            network.passivity.verdict
        );
    }

    // Perturb a_12 by 10 %: the cycle no longer closes, by exactly that factor.
    let mut perturbed = a.clone();
    perturbed[(0, 1)] *= 1.1;
    let network = Network::from_continuous(&perturbed, &b, scaling, None, &labels).unwrap();
    let cycle = &network.passivity.cycle_residuals[0];
    assert!(close(cycle.ratio.unwrap(), 1.1, 1e-13));
    assert!(cycle.residual.abs() > 0.09 * cycle.forward.abs());
    assert!(network.passivity.relative_asymmetry > 1e-4);
}

#[test]
fn models_without_a_network_say_why() {
    let labels = Labels::numbered(2, 1);
    let b = DMatrix::from_row_slice(2, 1, &[1.0, 0.5]);
    let scaling = Scaling::PHYSICAL;
    let oscillating = DMatrix::from_row_slice(2, 2, &[-0.01, 0.02, -0.02, -0.01]);
    assert!(matches!(
        Network::from_continuous(&oscillating, &b, scaling, None, &labels),
        Err(NetworkError::ComplexEigenvalues { im, .. }) if close(im, 0.02, 1e-9)
    ));
    let growing = DMatrix::from_row_slice(2, 2, &[0.001, 0.0, 0.0, -0.01]);
    assert!(matches!(
        Network::from_continuous(&growing, &b, scaling, None, &labels),
        Err(NetworkError::NotStable { eigenvalue }) if close(eigenvalue, 0.001, 1e-9)
    ));
    let a = DMatrix::from_row_slice(2, 2, &[-0.02, 0.01, 0.01, -0.03]);
    let cooling = DMatrix::from_row_slice(2, 1, &[-1.0, 0.0]);
    let err = Network::from_continuous(&a, &cooling, scaling, None, &labels).unwrap_err();
    assert_eq!(
        err,
        NetworkError::NotHeat {
            input: "loss 1".into()
        }
    );
    assert!(err.to_string().contains("heats no part"));
    let mut nan = a.clone();
    nan[(1, 0)] = f64::NAN;
    assert!(matches!(
        Network::from_continuous(&nan, &b, scaling, None, &labels),
        Err(NetworkError::NonFinite {
            what: "A_c",
            row: 1,
            col: 0
        })
    ));
    let wide = DMatrix::from_row_slice(1, 2, &[1.0, 1.0]);
    assert!(matches!(
        Network::from_continuous(&a, &wide, scaling, None, &labels),
        Err(NetworkError::Shape { what: "B_c", .. })
    ));
    assert!(matches!(
        Network::from_continuous(&a, &b, scaling, water_link(2, 100.0), &labels),
        Err(NetworkError::BadParameter(_))
    ));
}

#[test]
fn outlet_that_gains_heat_falls_back_to_energy_conservation() {
    // Row sums of C·A_c positive for part 2: its conductance to the coolant would be < 0.
    let a = DMatrix::from_row_slice(2, 2, &[-0.05, 0.02, 0.03, -0.02]);
    let b = DMatrix::from_row_slice(2, 1, &[1.0, 1.0]);
    let labels = Labels::numbered(2, 1);
    let network =
        Network::from_continuous(&a, &b, Scaling::PHYSICAL, water_link(1, 100.0), &labels).unwrap();
    assert_eq!(network.scale_from, ScaleSource::EnergyConservation);
    assert!(network
        .scale_note
        .as_deref()
        .unwrap()
        .contains("'part 2' does not lose heat"));
    // Energy conservation: C = [0.6, 0.4] (Σ C_i·b_i = 1 with c1/c2 = a21/a12 = 1.5).
    assert!(close(network.capacitance_j_per_k[0], 0.6, 1e-13));
    let g = &network.passivity.negative_conductances;
    assert_eq!((g.len(), g[0].row, g[0].column), (1, 1, 1));
    let verdict = &network.passivity.verdict;
    assert!(
        verdict.contains("that part would draw heat from the coolant, the more the hotter it gets"),
        "{verdict}"
    );
}

#[test]
fn json_block_has_the_report_keys() {
    let (parts, scaling) = three_parts();
    let labels = Labels::numbered(3, 3);
    let (a, b) = Network::from_parts(&parts, scaling, ScaleSource::Calorimetric, &labels)
        .unwrap()
        .to_continuous();
    let network =
        Network::from_continuous(&a, &b, scaling, water_link(2, 201.6e3), &labels).unwrap();
    let json = serde_json::to_value(&network).unwrap();
    assert_eq!(json["capacitance_j_per_k"].as_array().unwrap().len(), 3);
    assert_eq!(json["conductance_w_per_k"][2].as_array().unwrap().len(), 3);
    assert_eq!(json["loss_distribution"][0].as_array().unwrap().len(), 3);
    assert_eq!(json["scale_from"], "calorimetric");
    assert_eq!(
        json["alternative_scale"]["scale_from"],
        "energy_conservation"
    );
    assert_eq!(
        json["alternative_scale"]["capacitance_j_per_k"]
            .as_array()
            .unwrap()
            .len(),
        3
    );
    assert!(json["passivity"]["relative_asymmetry"].is_number());
    assert!(json["passivity"]["verdict"].is_string());
    assert!(json["resistance_k_per_w"][0][1].is_number());
}

/// The paper's A_c and B_c (eqs. 22–23), S_n = 100 MVA, θ_base = 80 K, and the cooling
/// water's c·ρ·Q = 4183 J/(kg·K) · 1 kg/l · 48.2 l/s (eq. 17).
fn paper_network() -> Network {
    let a = DMatrix::from_fn(3, 3, |i, j| crate::synth::PAPER_A_C[i][j]);
    let b = DMatrix::from_fn(3, 3, |i, j| crate::synth::PAPER_B_C[i][j]);
    let labels = crate::synth::example::generator_labels();
    let scaling = Scaling {
        theta_base_k: 80.0,
        p_base_w: 100e6,
    };
    let g_out = crate::network::calorimetry::heat_flow_w(4183.0 * 1.0, 1.0, 48.2);
    Network::from_continuous(&a, &b, scaling, water_link(2, g_out), &labels).unwrap()
}

#[test]
fn paper_model_is_not_a_passive_network() {
    let network = paper_network();
    println!("{}", serde_json::to_string_pretty(&network).unwrap());
    let p = &network.passivity;
    // a12·a23·a31 = 2.9769e-9 against a21·a32·a13 = 1.6554e-10 (by hand): 17.98.
    let cycle = &p.cycle_residuals[0];
    assert!(close(cycle.forward, 2.9769e-9, 1e-4));
    assert!(close(cycle.backward, 1.6554e-10, 1e-4));
    assert!((cycle.ratio.unwrap() - 17.98).abs() < 0.01);
    // The outlet's conductance to the coolant is c·ρ·Q by construction.
    assert!(close(network.conductance_w_per_k[2][2], 201_620.6, 1e-12));
    assert_eq!(network.scale_from, ScaleSource::Calorimetric);
    assert!(!p.is_passive);
    // B_c's negative entries stay negative shares (C > 0 keeps signs): k_21, k_22, k_13, k_23, k_32.
    let negative: Vec<&str> = p
        .negative_loss_shares
        .iter()
        .map(|e| e.name.as_str())
        .collect();
    assert_eq!(negative, ["k_13", "k_21", "k_22", "k_23", "k_32"]);
    assert!(p
        .verdict
        .starts_with("The identified model is not a passive thermal network: "));
    assert!(
        p.verdict
            .contains("k_32 = −1.03 (field copper loss into cooling water)"),
        "{}",
        p.verdict
    );
    // The couplings: each pair off by 17.98^(1/3) = 2.62 in the log fit.
    assert!((p.coupling_asymmetry - 0.45).abs() < 0.01);
}

/// A distance from a fit stopped at its cap is called an upper bound, naming the cap; one
/// from a fit that reached its minimum is called nothing.
#[test]
fn a_distance_stopped_at_the_cap_is_said_to_be_an_upper_bound() {
    let mut d = MinimumDistance {
        distance: 1036.0,
        degrees_of_freedom: 5,
        p_value: Some(1e-200),
        weighting: String::new(),
        iterations: 200,
        converged: false,
    };
    let said = d.unconverged().expect("stopped at the cap");
    assert!(
        said.contains("cap of 200 steps") && said.contains("upper bound"),
        "{said}"
    );
    d.converged = true;
    assert_eq!(d.unconverged(), None);
}
