//! The paper's own numbers (eqs. 19-34), checked against heatrun's analysis.
//!
//! The paper prints Φ and Γ (eqs. 19-20) to five significant digits, so every
//! quantity derived from them is known only to within what that rounding allows.
//! The bound used here is the first-order one: for a derived value f,
//! |Δf| ≤ Σ_pq |∂f/∂Φ_pq|·r(Φ_pq) + Σ_pq |∂f/∂Γ_pq|·r(Γ_pq), with r(x) half a unit
//! in the fifth significant digit and the derivatives by central differences,
//! plus half a unit in the last digit the paper prints for f itself.

use heatrun::estimate::DiscreteModel;
use heatrun::model::{ContinuousModel, Spectrum};
use heatrun::synth::paper_model;
use nalgebra::DMatrix;

/// Half a unit in the fifth significant digit of x.
fn radius5(x: f64) -> f64 {
    0.5 * 10f64.powi(x.abs().log10().floor() as i32 - 4)
}

/// Half a unit in the last printed decimal of a number as printed.
fn half_ulp(printed: &str) -> f64 {
    let decimals = printed.split('.').nth(1).map_or(0, |d| d.len());
    0.5 * 10f64.powi(-(decimals as i32))
}

fn parse(m: &[&[&str]]) -> (DMatrix<f64>, Vec<Vec<f64>>) {
    let n = m.len();
    let values = DMatrix::from_fn(n, m[0].len(), |i, j| m[i][j].parse().unwrap());
    let ulps = m
        .iter()
        .map(|r| r.iter().map(|s| half_ulp(s)).collect())
        .collect();
    (values, ulps)
}

/// First-order rounding bound of every output of `f` with respect to Φ and Γ.
fn rounding_bound(f: impl Fn(&DiscreteModel) -> Vec<f64>) -> Vec<f64> {
    let base = paper_model();
    let n_out = f(&base).len();
    let mut bound = vec![0.0; n_out];
    for which in 0..2 {
        for p in 0..3 {
            for q in 0..3 {
                let x = if which == 0 {
                    base.phi[(p, q)]
                } else {
                    base.gamma[(p, q)]
                };
                let r = radius5(x);
                let h = r * 1e-2;
                let mut plus = base.clone();
                let mut minus = base.clone();
                if which == 0 {
                    plus.phi[(p, q)] += h;
                    minus.phi[(p, q)] -= h;
                } else {
                    plus.gamma[(p, q)] += h;
                    minus.gamma[(p, q)] -= h;
                }
                let (fp, fm) = (f(&plus), f(&minus));
                for k in 0..n_out {
                    bound[k] += ((fp[k] - fm[k]) / (2.0 * h)).abs() * r;
                }
            }
        }
    }
    bound
}

fn flatten(m: &DMatrix<f64>) -> Vec<f64> {
    (0..m.nrows())
        .flat_map(|i| (0..m.ncols()).map(move |j| (i, j)))
        .map(|(i, j)| m[(i, j)])
        .collect()
}

#[test]
fn eigenvalues_of_phi_match_eq21_to_printed_digits() {
    let s = Spectrum::of(&paper_model()).unwrap();
    let printed = [0.95902, 0.99865, 0.99970];
    let bound = rounding_bound(|m| Spectrum::of(m).unwrap().eigenvalues_discrete);
    for i in 0..3 {
        let err = (s.eigenvalues_discrete[i] - printed[i]).abs();
        // Eq. 21 is printed to five decimals; the middle one sits 1.4e-6 past a rounding
        // edge (0.998644…), well inside what the rounding of Φ allows.
        assert!(
            err <= 0.5e-5 + bound[i],
            "λ{}: {} vs {} (bound {})",
            i + 1,
            s.eigenvalues_discrete[i],
            printed[i],
            bound[i]
        );
    }
    assert!((s.eigenvalues_discrete[0] - 0.95902).abs() < 0.5e-5);
    assert!((s.eigenvalues_discrete[2] - 0.99970).abs() < 0.5e-5);
}

/// The entries of A_c and B_c computed from `phi_13` in place of Φ(1,3) that the
/// rounding of Φ and Γ does not explain.
fn unexplained_entries(phi_13: f64) -> (Vec<String>, ContinuousModel) {
    let with = |m: &DiscreteModel| {
        let mut m = m.clone();
        m.phi[(0, 2)] += phi_13 - 0.00078830;
        m
    };
    let c = ContinuousModel::from_discrete(&with(&paper_model())).unwrap();
    let (a_printed, a_ulp) = parse(&[
        &["-0.00119970", "0.00045965", "0.0007745"],
        &["0.00019001", "-0.00057742", "0.0031408"],
        &["0.00206200", "0.00112490", "-0.041717"],
    ]);
    let (b_printed, b_ulp) = parse(&[
        &["0.0710460", "0.1160400", "-0.0612630"],
        &["-0.0027851", "-0.0106720", "-0.0066313"],
        &["0.0089894", "-0.2447000", "0.3553900"],
    ]);
    let a_bound =
        rounding_bound(|m| flatten(&ContinuousModel::from_discrete(&with(m)).unwrap().a_c));
    let b_bound =
        rounding_bound(|m| flatten(&ContinuousModel::from_discrete(&with(m)).unwrap().b_c));
    let mut unexplained = Vec::new();
    for i in 0..3 {
        for j in 0..3 {
            let k = 3 * i + j;
            // 10 % margin on the linearisation.
            if (c.a_c[(i, j)] - a_printed[(i, j)]).abs() > 1.1 * a_bound[k] + a_ulp[i][j] {
                unexplained.push(format!("A_c({},{})", i + 1, j + 1));
            }
            if (c.b_c[(i, j)] - b_printed[(i, j)]).abs() > 1.1 * b_bound[k] + b_ulp[i][j] {
                unexplained.push(format!("B_c({},{})", i + 1, j + 1));
            }
        }
    }
    (unexplained, c)
}

#[test]
fn continuous_matrices_match_eqs22_23_except_the_13_entries() {
    // From the printed Φ every entry of eqs. 22-23 is explained by the rounding but three:
    // ln Φ gives A_c(1,3) = 0.00080462 where the paper prints 0.0007745 (3.9 % away, the
    // rounding allows ~1e-8), B_c(1,3) = -0.0612683 where it prints -0.061263, and
    // A_c(1,2) = 0.00045963 where it prints 0.00045965 (2e-8 off, the rounding allows 1e-8).
    let (unexplained, c) = unexplained_entries(0.00078830);
    assert_eq!(
        unexplained,
        vec![
            "A_c(1,2)".to_owned(),
            "A_c(1,3)".to_owned(),
            "B_c(1,3)".to_owned()
        ]
    );
    assert!(
        (c.a_c[(0, 2)] - 0.00080462).abs() < 5e-9,
        "{}",
        c.a_c[(0, 2)]
    );
    // Conclusion: eq. 19's Φ(1,3) = 0.00078830 is a misprint of 0.00075883 (a dropped
    // digit 5). With it, ln Φ reproduces every printed entry of A_c and B_c, these three included.
    let (unexplained, c) = unexplained_entries(0.00075883);
    assert!(unexplained.is_empty(), "{unexplained:?}");
    assert!((c.a_c[(0, 2)] - 0.0007745).abs() < 5e-8);
    assert!((c.b_c[(0, 2)] + 0.061263).abs() < 1e-7);
}

#[test]
fn continuous_eigenvalues_and_time_constants_match_eqs24_26() {
    let s = Spectrum::of(&paper_model()).unwrap();
    let lc_printed = ["-0.041840", "-0.001355", "-0.000299"];
    let t_printed = ["23.901", "737.96", "3344.5"];
    let lc_bound = rounding_bound(|m| Spectrum::of(m).unwrap().eigenvalues_continuous);
    let t_bound = rounding_bound(|m| Spectrum::of(m).unwrap().time_constants_s);
    for i in 0..3 {
        let lc: f64 = lc_printed[i].parse().unwrap();
        assert!(
            (s.eigenvalues_continuous[i] - lc).abs() <= 1.1 * lc_bound[i] + half_ulp(lc_printed[i])
        );
        let t: f64 = t_printed[i].parse().unwrap();
        let err = (s.time_constants_s[i] - t).abs();
        assert!(
            err <= 1.1 * t_bound[i] + half_ulp(t_printed[i]),
            "T{}: {} vs {} (bound {})",
            i + 1,
            s.time_constants_s[i],
            t,
            t_bound[i]
        );
    }
    // The longest time constant is the least certain: 5e-6 in Φ's diagonal moves it by tens of seconds.
    assert!(t_bound[2] > 20.0 && t_bound[0] < 0.01, "{t_bound:?}");
}

#[test]
fn steady_state_from_printed_ac_bc_gives_eq32() {
    let a_c = DMatrix::from_fn(3, 3, |i, j| heatrun::synth::PAPER_A_C[i][j]);
    let b_c = DMatrix::from_fn(3, 3, |i, j| heatrun::synth::PAPER_B_C[i][j]);
    let model = ContinuousModel { a_c, b_c };
    let u = [0.0027397, 0.0024230, 0.0035920]; // eq. 30
    let rise: Vec<f64> = model
        .steady_state(&u)
        .unwrap()
        .iter()
        .map(|y| 80.0 * y)
        .collect();
    let printed = [25.707, 17.367, 3.0972]; // eq. 32
    for i in 0..3 {
        assert!((rise[i] - printed[i]).abs() < 2e-3, "{rise:?}");
    }
    // Eq. 34: add the initial temperatures [36.7, 36.3, 10.5] °C.
    let final_c: Vec<f64> = rise
        .iter()
        .zip([36.7, 36.3, 10.5])
        .map(|(r, t)| r + t)
        .collect();
    for (got, want) in final_c.iter().zip([62.407, 53.667, 13.597]) {
        assert!((got - want).abs() < 2e-3);
    }
}
