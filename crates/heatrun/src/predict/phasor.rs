//! The field current of a load point from the salient-pole phasor diagram.
//!
//! With the armature resistance neglected and the machine unsaturated (per unit, the
//! generator convention, φ > 0 lagging = over-excited):
//!
//! E_Q = U + j·x_q·I (I = I·(cos φ − j sin φ)), δ = arg E_Q,
//! I_d = I·sin(δ + φ), E_0 = |E_Q| + (x_d − x_q)·I_d,
//!
//! and the field current is proportional to E_0, scaled so that the rated point
//! (U = 1, I = 1, cos φ_n) gives the rated field current: I_f = I_fn · E_0 / E_0,n.

use crate::recording::Nameplate;

/// Typical unsaturated x_d of a salient-pole hydro generator, pu (used where the
/// nameplate has none, with a warning).
pub const TYPICAL_X_D_PU: f64 = 1.0;
/// Typical x_q of a salient-pole hydro generator, pu.
pub const TYPICAL_X_Q_PU: f64 = 0.65;
/// Typical rated power factor of a hydro generator.
pub const TYPICAL_POWER_FACTOR: f64 = 0.9;

/// The machine's reactances and rated point for the phasor diagram.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PhasorMachine {
    /// x_d, pu.
    pub x_d_pu: f64,
    /// x_q, pu.
    pub x_q_pu: f64,
    /// cos φ_n.
    pub rated_power_factor: f64,
    /// I_fn, A.
    pub rated_field_current_a: f64,
}

impl PhasorMachine {
    /// From a nameplate, with typical values where keys are absent; the warnings name
    /// each value taken as typical. `None` without a rated field current.
    pub fn from_nameplate(np: &Nameplate) -> Option<(PhasorMachine, Vec<String>)> {
        let mut warnings = Vec::new();
        let mut or_typical = |v: Option<f64>, key: &str, typical: f64| {
            v.unwrap_or_else(|| {
                warnings.push(format!(
                    "nameplate key `{key}` is absent: the phasor diagram takes the typical \
                     salient-pole hydro-generator value {typical}"
                ));
                typical
            })
        };
        let machine = PhasorMachine {
            x_d_pu: or_typical(
                np.direct_axis_reactance_pu,
                "direct_axis_reactance_pu",
                TYPICAL_X_D_PU,
            ),
            x_q_pu: or_typical(
                np.quadrature_axis_reactance_pu,
                "quadrature_axis_reactance_pu",
                TYPICAL_X_Q_PU,
            ),
            rated_power_factor: or_typical(
                np.rated_power_factor,
                "rated_power_factor",
                TYPICAL_POWER_FACTOR,
            ),
            rated_field_current_a: np.rated_field_current_a?,
        };
        Some((machine, warnings))
    }

    /// E_0 in pu for terminal voltage `u_pu`, current `i_pu` and power factor `cos_phi`
    /// (positive lagging, negative leading).
    pub fn excitation_emf_pu(&self, u_pu: f64, i_pu: f64, cos_phi: f64) -> f64 {
        let phi = cos_phi.abs().clamp(0.0, 1.0).acos() * cos_phi.signum();
        let (re, im) = (
            u_pu + self.x_q_pu * i_pu * phi.sin(),
            self.x_q_pu * i_pu * phi.cos(),
        );
        let delta = im.atan2(re);
        let i_d = i_pu * (delta + phi).sin();
        re.hypot(im) + (self.x_d_pu - self.x_q_pu) * i_d
    }

    /// The field current, A, of a load point; scaled so that the rated point gives I_fn.
    pub fn field_current_a(&self, u_pu: f64, i_pu: f64, cos_phi: f64) -> f64 {
        let rated = self.excitation_emf_pu(1.0, 1.0, self.rated_power_factor);
        self.rated_field_current_a * self.excitation_emf_pu(u_pu, i_pu, cos_phi) / rated
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn machine(x_d: f64, x_q: f64) -> PhasorMachine {
        PhasorMachine {
            x_d_pu: x_d,
            x_q_pu: x_q,
            rated_power_factor: 0.9,
            rated_field_current_a: 1000.0,
        }
    }

    #[test]
    fn unity_power_factor_by_hand() {
        // U = 1, I = 1, cos φ = 1, x_q = 0.6, x_d = 1.0: E_Q = 1 + j0.6, |E_Q| = 1.166190,
        // δ = atan 0.6 = 30.964°, I_d = sin δ = 0.514496, E_0 = 1.166190 + 0.4·0.514496.
        let e = machine(1.0, 0.6).excitation_emf_pu(1.0, 1.0, 1.0);
        let expect = 1.36f64.sqrt() + 0.4 * (0.6f64.atan()).sin();
        assert!((e - expect).abs() < 1e-12, "{e} vs {expect}");
        assert!((e - 1.371989).abs() < 1e-6);
    }

    #[test]
    fn round_rotor_is_the_magnitude_of_u_plus_jxi() {
        // x_d = x_q = 1, cos φ = 0.8 lagging: E = |1 + j(0.8 − j0.6)| = |1.6 + j0.8|.
        let e = machine(1.0, 1.0).excitation_emf_pu(1.0, 1.0, 0.8);
        assert!((e - (1.6f64.powi(2) + 0.8f64.powi(2)).sqrt()).abs() < 1e-12);
        // Leading (under-excited) 0.8: |1 − 0.6 + j0.8|.
        let e = machine(1.0, 1.0).excitation_emf_pu(1.0, 1.0, -0.8);
        assert!((e - (0.4f64.powi(2) + 0.8f64.powi(2)).sqrt()).abs() < 1e-12);
    }

    #[test]
    fn rated_point_gives_rated_field_current_and_no_load_less() {
        let m = machine(1.1, 0.7);
        assert!((m.field_current_a(1.0, 1.0, 0.9) - 1000.0).abs() < 1e-9);
        // No load at rated voltage: E_0 = 1.
        let no_load = m.field_current_a(1.0, 0.0, 0.9);
        assert!((no_load - 1000.0 / m.excitation_emf_pu(1.0, 1.0, 0.9)).abs() < 1e-9);
        assert!(m.field_current_a(1.0, 1.1, 0.9) > 1000.0);
    }
}
