//! Liquid water's density and specific heat from the IAPWS Industrial Formulation 1997
//! (IAPWS-IF97), region 1 (compressed liquid): W. Wagner et al., "The IAPWS Industrial
//! Formulation 1997 for the Thermodynamic Properties of Water and Steam", J. Eng. Gas
//! Turbines Power 122 (2000) 150–182. Its 34-term Gibbs free energy γ(π, τ) gives
//!
//! ```text
//! v = (R·T/p)·π·γ_π,    c_p = −R·τ²·γ_ττ,    π = p/16.53 MPa,  τ = 1386 K/T,
//! ```
//!
//! R = 461.526 J/(kg·K). Between 0 and 100 °C it reproduces the IAPWS-95 tables within
//! their printed digits (see the calorimetry tests: 10, 25 and 50 °C).

use serde::Serialize;

/// Water outside the range of the formulation.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum WaterError {
    /// A water temperature is outside the range of the water properties.
    #[error("water at {theta_c} °C is outside 0–100 °C, the range of the water properties")]
    OutOfRange {
        /// The temperature (°C).
        theta_c: f64,
    },
    /// A pressure outside region 1's (0, 100 MPa].
    #[error("water pressure {pressure_pa} Pa is outside (0, 100 MPa]")]
    Pressure {
        /// The pressure (Pa).
        pressure_pa: f64,
    },
}

/// Standard atmosphere (Pa), the pressure of the water properties unless another is given.
pub const STANDARD_PRESSURE_PA: f64 = 101_325.0;

/// The specific gas constant of IF97, J/(kg·K).
const R_J_PER_KG_K: f64 = 461.526;
/// Region 1 reducing pressure (Pa) and temperature (K).
const P_STAR_PA: f64 = 16.53e6;
const T_STAR_K: f64 = 1386.0;

/// IF97 region 1 coefficients (I_i, J_i, n_i) of γ = Σ n_i (7.1 − π)^I_i (τ − 1.222)^J_i.
const REGION1: [(i32, i32, f64); 34] = [
    (0, -2, 0.146_329_712_131_67),
    (0, -1, -0.845_481_871_691_14),
    (0, 0, -0.375_636_036_720_40e1),
    (0, 1, 0.338_551_691_683_85e1),
    (0, 2, -0.957_919_633_878_72),
    (0, 3, 0.157_720_385_132_28),
    (0, 4, -0.166_164_171_995_01e-1),
    (0, 5, 0.812_146_299_835_68e-3),
    (1, -9, 0.283_190_801_238_04e-3),
    (1, -7, -0.607_063_015_658_74e-3),
    (1, -1, -0.189_900_682_184_19e-1),
    (1, 0, -0.325_297_487_705_05e-1),
    (1, 1, -0.218_417_171_754_14e-1),
    (1, 3, -0.528_383_579_699_30e-4),
    (2, -3, -0.471_843_210_732_67e-3),
    (2, 0, -0.300_017_807_930_26e-3),
    (2, 1, 0.476_613_939_069_87e-4),
    (2, 3, -0.441_418_453_308_46e-5),
    (2, 17, -0.726_949_962_975_94e-15),
    (3, -4, -0.316_796_448_450_54e-4),
    (3, 0, -0.282_707_979_853_12e-5),
    (3, 6, -0.852_051_281_201_03e-9),
    (4, -5, -0.224_252_819_080_00e-5),
    (4, -2, -0.651_712_228_956_01e-6),
    (4, 10, -0.143_417_299_379_24e-12),
    (5, -8, -0.405_169_968_601_17e-6),
    (8, -11, -0.127_343_017_416_41e-8),
    (8, -6, -0.174_248_712_306_34e-9),
    (21, -29, -0.687_621_312_955_31e-18),
    (23, -31, 0.144_783_078_285_21e-19),
    (29, -38, 0.263_357_816_627_95e-22),
    (30, -39, -0.119_476_226_400_71e-22),
    (31, -40, 0.182_280_945_814_04e-23),
    (32, -41, -0.935_370_872_924_58e-25),
];

/// Liquid water at one temperature and pressure.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Water {
    /// c_p in J/(kg·K).
    pub specific_heat_j_per_kg_k: f64,
    /// ρ in kg/m³.
    pub density_kg_per_m3: f64,
}

impl Water {
    /// Water at `theta_c` °C (0–100) and standard atmospheric pressure (IF97 region 1).
    pub fn at(theta_c: f64) -> Result<Water, WaterError> {
        Water::at_pressure(theta_c, STANDARD_PRESSURE_PA)
    }

    /// Water at `theta_c` °C (0–100) and `pressure_pa` (up to 100 MPa): IF97 region 1,
    /// ρ = p/(R·T·π·γ_π), c_p = −R·τ²·γ_ττ.
    pub fn at_pressure(theta_c: f64, pressure_pa: f64) -> Result<Water, WaterError> {
        Water::check(theta_c, pressure_pa)?;
        Ok(region1(pressure_pa, theta_c + 273.15))
    }

    /// Whether [`Water::at_pressure`] holds at `theta_c` °C and `pressure_pa`: liquid water
    /// (0–100 °C) at up to 100 MPa; the error it would give otherwise.
    pub fn check(theta_c: f64, pressure_pa: f64) -> Result<(), WaterError> {
        if !(0.0..=100.0).contains(&theta_c) {
            return Err(WaterError::OutOfRange { theta_c });
        }
        if !(pressure_pa > 0.0 && pressure_pa <= 100e6) {
            return Err(WaterError::Pressure { pressure_pa });
        }
        Ok(())
    }

    /// ρ in kg/l.
    pub fn density_kg_per_l(&self) -> f64 {
        self.density_kg_per_m3 / 1000.0
    }

    /// c·ρ in J/(l·K): the heat one litre carries per kelvin of rise.
    pub fn heat_per_litre_j_per_k(&self) -> f64 {
        self.specific_heat_j_per_kg_k * self.density_kg_per_l()
    }
}

/// Water at one pressure, each temperature computed once: a heat run's water temperatures
/// are stored to a resolution (0.01 K, 0.1 K), so most instants repeat a temperature seen
/// before, and a repeat costs a lookup instead of IF97's 34 terms. The value is the one
/// computed, so the same bits as [`Water::at_pressure`]. Direct-mapped: a slot keeps the
/// last temperature that fell in it.
#[derive(Debug, Clone)]
pub struct WaterMemo {
    pressure_pa: f64,
    /// (°C as bits, its water); a NaN's bits where empty (a NaN is never looked up: it is
    /// outside 0–100 °C).
    slots: Box<[(u64, Water)]>,
}

/// log2 of [`WaterMemo`]'s slots: 4,096 (96 kB) hold a run's distinct temperatures at
/// 0.01 K over 40 K.
const MEMO_BITS: u32 = 12;

impl WaterMemo {
    /// An empty memo of water at `pressure_pa`.
    pub fn new(pressure_pa: f64) -> WaterMemo {
        let empty = Water {
            specific_heat_j_per_kg_k: f64::NAN,
            density_kg_per_m3: f64::NAN,
        };
        WaterMemo {
            pressure_pa,
            slots: vec![(f64::NAN.to_bits(), empty); 1 << MEMO_BITS].into_boxed_slice(),
        }
    }

    /// [`Water::at_pressure`] at `theta_c` and the memo's pressure.
    pub fn at(&mut self, theta_c: f64) -> Result<Water, WaterError> {
        Water::check(theta_c, self.pressure_pa)?;
        let key = theta_c.to_bits();
        // Fibonacci hashing: the top bits of the key times 2^64/φ.
        let slot =
            &mut self.slots[(key.wrapping_mul(0x9E37_79B9_7F4A_7C15) >> (64 - MEMO_BITS)) as usize];
        if slot.0 != key {
            *slot = (key, region1(self.pressure_pa, theta_c + 273.15));
        }
        Ok(slot.1)
    }
}

/// The lowest exponent of (7.1 − π) the terms of γ_π and γ_ττ take (I − 1 of I = 0),
/// and how many exponents from it to the highest (I = 32).
const X_LOWEST: i32 = -1;
const X_SPAN: usize = 34;
/// The same for (τ − 1.222): J − 2 of J = −41 up to J = 17.
const Y_LOWEST: i32 = -43;
const Y_SPAN: usize = 61;

/// Which exponents of (7.1 − π) the terms take: I − 1 and I.
const X_USED: [bool; X_SPAN] = exponents_used(0, 1, X_LOWEST);

/// Which exponents of (τ − 1.222) the terms take: J − 2 and J.
const Y_USED: [bool; Y_SPAN] = exponents_used(1, 2, Y_LOWEST);

/// Which exponents from `lowest` on the terms take of one factor: its exponent in the
/// terms' `column` (0: I, 1: J) and that less `less` (its derivative's).
const fn exponents_used<const N: usize>(column: usize, less: i32, lowest: i32) -> [bool; N] {
    let mut used = [false; N];
    let mut t = 0;
    while t < REGION1.len() {
        let e = if column == 0 {
            REGION1[t].0
        } else {
            REGION1[t].1
        };
        used[(e - less - lowest) as usize] = true;
        used[(e - lowest) as usize] = true;
        t += 1;
    }
    used
}

/// `base` to each used power from `lowest` on (0 where unused), with `powi`'s bits: its
/// algorithm (compiler-builtins' `__powidf2`) multiplies 1 by base^(2^k) for each set bit
/// k of |e|, lowest first, the squares made by squaring in turn, then takes the reciprocal
/// for e < 0. The squares are made once here for every power, and each power is the same
/// products in the same order, without a call per power (IF97 was 3 % of W0's replay,
/// evaluated twice an instant by the calorimetric balance).
fn powers<const N: usize>(base: f64, lowest: i32, used: &[bool; N]) -> [f64; N] {
    let mut squares = [base; 7];
    for k in 1..squares.len() {
        squares[k] = squares[k - 1] * squares[k - 1];
    }
    let mut power = [0.0; N];
    for (e, (p, &u)) in power.iter_mut().zip(used).enumerate() {
        if u {
            let e = lowest + e as i32;
            let mut bits = e.unsigned_abs();
            debug_assert!(bits < 1 << squares.len());
            let mut product = 1.0;
            for square in squares {
                if bits & 1 != 0 {
                    product *= square;
                }
                bits >>= 1;
                if bits == 0 {
                    break;
                }
            }
            *p = if e < 0 { 1.0 / product } else { product };
        }
    }
    power
}

/// Density and c_p of IF97 region 1 at p (Pa) and T (K).
fn region1(p_pa: f64, t_k: f64) -> Water {
    let pi = p_pa / P_STAR_PA;
    let tau = T_STAR_K / t_k;
    let (x, y) = (
        powers(7.1 - pi, X_LOWEST, &X_USED),
        powers(tau - 1.222, Y_LOWEST, &Y_USED),
    );
    let x = |e: i32| x[(e - X_LOWEST) as usize];
    let y = |e: i32| y[(e - Y_LOWEST) as usize];
    let (mut gamma_pi, mut gamma_tau_tau) = (0.0, 0.0);
    for &(i, j, n) in &REGION1 {
        gamma_pi -= n * f64::from(i) * x(i - 1) * y(j);
        gamma_tau_tau += n * x(i) * f64::from(j * (j - 1)) * y(j - 2);
    }
    Water {
        specific_heat_j_per_kg_k: -R_J_PER_KG_K * tau * tau * gamma_tau_tau,
        density_kg_per_m3: p_pa / (R_J_PER_KG_K * t_k * pi * gamma_pi),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rel(a: f64, b: f64) -> f64 {
        (a - b).abs() / b.abs()
    }

    /// Every power from −43 to 20, of bases near IF97's and far from them, has `powi`'s
    /// bits.
    #[test]
    fn powers_from_shared_squares_have_powis_bits() {
        const SPAN: usize = 64;
        let every = [true; SPAN];
        let mut base = 0.013_f64;
        while base < 40.0 {
            for b in [base, -base] {
                let p = powers(b, -43, &every);
                for (i, &v) in p.iter().enumerate() {
                    let e = -43 + i as i32;
                    assert_eq!(v.to_bits(), b.powi(e).to_bits(), "{b}^{e}");
                }
            }
            base *= 1.0137;
        }
    }

    /// Each power taken once gives the bits each term's own `powi` gave, from 0 to 100 °C
    /// at pressures from 0.1 to 100 MPa.
    #[test]
    fn powers_taken_once_give_each_terms_own() {
        let by_term = |p_pa: f64, t_k: f64| {
            let pi = p_pa / P_STAR_PA;
            let tau = T_STAR_K / t_k;
            let (x, y) = (7.1 - pi, tau - 1.222);
            let (mut gamma_pi, mut gamma_tau_tau) = (0.0, 0.0);
            for &(i, j, n) in &REGION1 {
                gamma_pi -= n * f64::from(i) * x.powi(i - 1) * y.powi(j);
                gamma_tau_tau += n * x.powi(i) * f64::from(j * (j - 1)) * y.powi(j - 2);
            }
            Water {
                specific_heat_j_per_kg_k: -R_J_PER_KG_K * tau * tau * gamma_tau_tau,
                density_kg_per_m3: p_pa / (R_J_PER_KG_K * t_k * pi * gamma_pi),
            }
        };
        for p_pa in [1e5, STANDARD_PRESSURE_PA, 3e6, 100e6] {
            for step in 0..=10_000 {
                let t_k = 273.15 + 0.01 * f64::from(step);
                assert_eq!(region1(p_pa, t_k), by_term(p_pa, t_k), "{p_pa} Pa, {t_k} K");
            }
        }
    }

    /// The memo gives [`Water::at_pressure`]'s bits and errors, whether a temperature is
    /// new, repeated, or has evicted another from its slot.
    #[test]
    fn the_memo_gives_the_computed_water() {
        let mut memo = WaterMemo::new(3e6);
        for round in 0..3 {
            for step in (0..=10_000).rev().step_by(7 + round) {
                let theta = 0.01 * f64::from(step);
                assert_eq!(memo.at(theta), Water::at_pressure(theta, 3e6), "{theta} °C");
            }
        }
        for theta in [-0.5, 100.5, f64::NAN] {
            // As text: a NaN in the error is not equal to itself.
            assert_eq!(
                format!("{:?}", memo.at(theta)),
                format!("{:?}", Water::at_pressure(theta, 3e6))
            );
        }
        assert!(WaterMemo::new(0.0).at(20.0).is_err());
    }

    #[test]
    fn if97_reproduces_its_own_verification_values() {
        // IF97 (Wagner et al. 2000), Table 5: v in m³/kg, c_p in kJ/(kg·K).
        for (t_k, p_pa, v, cp) in [
            (300.0, 3e6, 0.100_215_168e-2, 0.417_301_218e1),
            (300.0, 80e6, 0.971_180_894e-3, 0.401_008_987e1),
            (500.0, 3e6, 0.120_241_800e-2, 0.465_580_682e1),
        ] {
            let w = region1(p_pa, t_k);
            assert!(rel(1.0 / w.density_kg_per_m3, v) < 1e-8, "v at {t_k} K");
            assert!(
                rel(w.specific_heat_j_per_kg_k / 1000.0, cp) < 1e-8,
                "cp at {t_k} K"
            );
        }
    }
}
