//! The calorimetric balance of the cooling water (paper eqs. 17–18): the heat the water
//! carries away, c·ρ·(θ_out − θ_in)·Q, with c and ρ of water at its temperature
//! ([`crate::thermal::water`], IAPWS-IF97 region 1).

use serde::Serialize;

use super::NetworkError;
use crate::series::Series;
use crate::thermal::water::WaterMemo;
pub use crate::thermal::water::{Water, WaterError, STANDARD_PRESSURE_PA};

/// The heat carried away by water of `heat_per_litre_j_per_k` = c·ρ (J/(l·K)) rising
/// `delta_k` at `flow_l_per_s`: dW_cw/dt = c·ρ·Δθ·Q in W (eq. 17).
pub fn heat_flow_w(heat_per_litre_j_per_k: f64, delta_k: f64, flow_l_per_s: f64) -> f64 {
    heat_per_litre_j_per_k * delta_k * flow_l_per_s
}

/// The cooling-water outlet's conductance to the coolant, G_out,0 = c·ρ·Q in W/K
/// (eq. 17 per kelvin of outlet rise): the calorimetric scale of the network.
pub fn coolant_conductance_w_per_k(water: &Water, flow_l_per_s: f64) -> f64 {
    water.heat_per_litre_j_per_k() * flow_l_per_s
}

/// Where the flow meter sits: its volume flow is converted to mass at that temperature.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum FlowMeter {
    /// On the cold-water inlet.
    Inlet,
    /// On the outlet.
    Outlet,
}

/// The water's c and ρ in the balance.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum WaterModel {
    /// Fixed values, as the paper's eq. 18 (4183 J/(kg·K) at 25 °C, 1 kg/l).
    Constant {
        /// c in J/(kg·K).
        specific_heat_j_per_kg_k: f64,
        /// ρ in kg/l.
        density_kg_per_l: f64,
    },
    /// IF97 at the measured temperatures: c_p at the mean of inlet and outlet (the mean
    /// slope of the enthalpy between them), ρ at the flow meter.
    AtTemperature {
        /// Where the flow is measured.
        flow_meter: FlowMeter,
        /// The water's pressure (Pa).
        pressure_pa: f64,
    },
}

impl WaterModel {
    /// The paper's eq. 18: c = 4183 J/(kg·K), ρ = 1 kg/l.
    pub const PAPER: WaterModel = WaterModel::Constant {
        specific_heat_j_per_kg_k: 4183.0,
        density_kg_per_l: 1.0,
    };

    /// IF97 at standard pressure, flow metered on the inlet.
    pub const MEASURED: WaterModel = WaterModel::AtTemperature {
        flow_meter: FlowMeter::Inlet,
        pressure_pa: STANDARD_PRESSURE_PA,
    };

    /// c·ρ (J/(l·K)) for water going from `inlet_c` to `outlet_c` °C.
    pub fn heat_per_litre_j_per_k(&self, outlet_c: f64, inlet_c: f64) -> Result<f64, NetworkError> {
        match *self {
            WaterModel::Constant {
                specific_heat_j_per_kg_k,
                density_kg_per_l,
            } => Ok(specific_heat_j_per_kg_k * density_kg_per_l),
            WaterModel::AtTemperature {
                flow_meter,
                pressure_pa,
            } => mixed_heat_per_litre(flow_meter, pressure_pa, (outlet_c, inlet_c), |theta| {
                Water::at_pressure(theta, pressure_pa)
            }),
        }
    }

    /// [`WaterModel::heat_per_litre_j_per_k`] instant after instant, IF97's water
    /// remembered by temperature ([`WaterMemo`]: the same bits).
    fn per_instant(self) -> impl FnMut(f64, f64) -> Result<f64, NetworkError> {
        let mut memo = None;
        move |outlet_c, inlet_c| match self {
            WaterModel::AtTemperature {
                flow_meter,
                pressure_pa,
            } => {
                let memo = memo.get_or_insert_with(|| WaterMemo::new(pressure_pa));
                mixed_heat_per_litre(flow_meter, pressure_pa, (outlet_c, inlet_c), |theta| {
                    memo.at(theta)
                })
            }
            WaterModel::Constant { .. } => self.heat_per_litre_j_per_k(outlet_c, inlet_c),
        }
    }
}

/// c_p at the mean of inlet and outlet times ρ at the flow meter, IF97's water at
/// `pressure_pa` from `at`.
fn mixed_heat_per_litre(
    flow_meter: FlowMeter,
    pressure_pa: f64,
    (outlet_c, inlet_c): (f64, f64),
    mut at: impl FnMut(f64) -> Result<Water, WaterError>,
) -> Result<f64, NetworkError> {
    // Both ends must be liquid water for the mean c_p to stand for the enthalpy rise.
    // (Only checked: evaluated, as they were, IF97's 34 terms four times an instant made
    // 3 % of W0's CPU, and two of the four only checked this.)
    Water::check(outlet_c, pressure_pa)?;
    Water::check(inlet_c, pressure_pa)?;
    let mean = at(0.5 * (outlet_c + inlet_c))?;
    let metered = match flow_meter {
        FlowMeter::Inlet => inlet_c,
        FlowMeter::Outlet => outlet_c,
    };
    let rho = at(metered)?.density_kg_per_l();
    Ok(mean.specific_heat_j_per_kg_k * rho)
}

/// The heat the cooling water carries away on the grid (eq. 17), and per unit of S_n (eq. 18).
#[derive(Debug, Clone)]
pub struct CoolantHeat {
    /// P_cw(k) in W, unknown where an input is unknown or the water is outside 0–100 °C.
    pub watts: Series,
    /// S_n in VA.
    pub s_n_va: f64,
    /// Instants left unknown because a water temperature was outside 0–100 °C.
    pub instants_out_of_range: usize,
}

/// The balance averaged over the end of the run.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct EndOfRun {
    /// Mean P_cw in W.
    pub watts: f64,
    /// Mean P_cw in pu of S_n (eq. 18).
    pub pu: f64,
    /// Known instants averaged.
    pub instants: usize,
}

/// P_cw(k) = c·ρ·(θ_out(k) − θ_in(k))·Q(k) (eq. 17) from the outlet and inlet temperatures
/// (°C) and the flow (l/s) on the grid, `None` where unknown. Where the inlet is not
/// recorded, pass the outlet's initial temperature for every instant.
pub fn heat_carried_away<O, I, Q>(
    outlet_c: O,
    inlet_c: I,
    flow_l_per_s: Q,
    water: WaterModel,
    s_n_va: f64,
) -> Result<CoolantHeat, NetworkError>
where
    O: IntoIterator<Item = Option<f64>>,
    O::IntoIter: ExactSizeIterator,
    I: IntoIterator<Item = Option<f64>>,
    I::IntoIter: ExactSizeIterator,
    Q: IntoIterator<Item = Option<f64>>,
    Q::IntoIter: ExactSizeIterator,
{
    if !(s_n_va.is_finite() && s_n_va > 0.0) {
        return Err(NetworkError::BadParameter(format!(
            "S_n = {s_n_va} VA must be positive"
        )));
    }
    let (outlet, inlet, flow) = (
        outlet_c.into_iter(),
        inlet_c.into_iter(),
        flow_l_per_s.into_iter(),
    );
    let len = outlet.len();
    for (what, found) in [
        ("the inlet series", inlet.len()),
        ("the flow series", flow.len()),
    ] {
        if found != len {
            return Err(NetworkError::Shape {
                what,
                expected_rows: len,
                expected_cols: 1,
                found_rows: found,
                found_cols: 1,
            });
        }
    }
    let mut watts = Series::unknown(len);
    let mut instants_out_of_range = 0;
    let mut heat_per_litre = water.per_instant();
    for (k, ((out, inl), q)) in outlet.zip(inlet).zip(flow).enumerate() {
        let (Some(out), Some(inl), Some(q)) = (out, inl, q) else {
            continue;
        };
        match heat_per_litre(out, inl) {
            Ok(c_rho) => watts.set(k, Some(heat_flow_w(c_rho, out - inl, q))),
            Err(NetworkError::Water(WaterError::OutOfRange { .. })) => instants_out_of_range += 1,
            Err(e) => return Err(e),
        }
    }
    Ok(CoolantHeat {
        watts,
        s_n_va,
        instants_out_of_range,
    })
}

impl CoolantHeat {
    /// P_cw(k)/S_n, `None` where unknown (eq. 18).
    pub fn pu(&self) -> impl Iterator<Item = Option<f64>> + '_ {
        self.watts.iter().map(|w| w.map(|w| w / self.s_n_va))
    }

    /// The mean over the known instants of the last `window_s` seconds of a grid of `ts_s`;
    /// `None` where none is known.
    pub fn end_of_run(&self, ts_s: f64, window_s: f64) -> Option<EndOfRun> {
        let take = ((window_s / ts_s).floor() as usize + 1).min(self.watts.len());
        let (sum, instants) = self
            .watts
            .iter()
            .rev()
            .take(take)
            .flatten()
            .fold((0.0, 0usize), |(s, n), w| (s + w, n + 1));
        (instants > 0).then(|| EndOfRun {
            watts: sum / instants as f64,
            pu: sum / instants as f64 / self.s_n_va,
            instants,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rel(a: f64, b: f64) -> f64 {
        (a - b).abs() / b.abs()
    }

    #[test]
    fn water_at_10_25_50_c_matches_the_tables() {
        // Density at 1 atm: CRC Handbook (Kell, ITS-90) 999.7026, 997.0479, 988.04 kg/m³.
        // c_p at 0.1 MPa from IAPWS-95: 75.57 and 75.33 J/(mol·K) at 10 and 50 °C (London
        // South Bank University water data, M = 18.015268 g/mol: 4194.8, 4181.5) and
        // 4181.3 J/(kg·K) at 25 °C (NIST Webbook). IF97 is the industrial approximation of
        // IAPWS-95: here within 0.01 % in density and 0.1 % in c_p (measured: +0.015 %,
        // +0.014 %, −0.045 % in c_p; the bound is what the balance can use, not a tuning).
        let m = 18.015_268;
        for (theta, rho, cp) in [
            (10.0, 999.7026, 75.57 / m * 1000.0),
            (25.0, 997.0479, 4181.3),
            (50.0, 988.04, 75.33 / m * 1000.0),
        ] {
            let w = Water::at(theta).unwrap();
            let (found_rho, found_cp) = (w.density_kg_per_m3, w.specific_heat_j_per_kg_k);
            assert!(rel(found_rho, rho) < 1e-4, "ρ({theta}) = {found_rho}");
            assert!(rel(found_cp, cp) < 1e-3, "c_p({theta}) = {found_cp}");
        }
    }

    #[test]
    fn out_of_range_water_is_an_error() {
        assert_eq!(
            Water::at(-1.0),
            Err(WaterError::OutOfRange { theta_c: -1.0 })
        );
        assert!(Water::at(100.5).is_err());
        assert!(Water::at(f64::NAN).is_err());
    }

    #[test]
    fn paper_eq_18_is_0_00625_pu() {
        // c·ρ·Δθ·Q / S_n = 4183 · 1 · 3.1 · 48.2 / 1e8 = 625,023.86 W / 1e8 = 0.006250 pu.
        let w = heat_flow_w(4183.0 * 1.0, 3.1, 48.2);
        assert!((w - 625_023.86).abs() < 1e-6, "{w}");
        assert!((w / 100e6 - 0.00625).abs() < 5e-7);
        // Through the series path, the paper's constants.
        let n = 5;
        let heat = heat_carried_away(
            vec![Some(13.6); n],
            vec![Some(10.5); n],
            vec![Some(48.2); n],
            WaterModel::PAPER,
            100e6,
        )
        .unwrap();
        let end = heat.end_of_run(1.0, 3600.0).unwrap();
        assert_eq!(end.instants, n);
        assert!((end.pu - 0.00625).abs() < 5e-7, "{}", end.pu);
    }

    #[test]
    fn paper_balance_with_water_at_its_temperature() {
        // Inlet 10.5 °C, outlet 13.6 °C: c_p at 12.05 °C and ρ at 10.5 °C give about
        // 4191 J/(l·K), 0.2 % above the paper's 4183 at 25 °C and 1 kg/l.
        let c_rho = WaterModel::MEASURED
            .heat_per_litre_j_per_k(13.6, 10.5)
            .unwrap();
        let cp = Water::at(12.05).unwrap().specific_heat_j_per_kg_k;
        let rho = Water::at(10.5).unwrap().density_kg_per_l();
        assert!(rel(c_rho, cp * rho) < 1e-15);
        assert!((4185.0..4197.0).contains(&c_rho), "{c_rho}");
        let pu = heat_flow_w(c_rho, 3.1, 48.2) / 100e6;
        assert!((pu - 0.00625).abs() / 0.00625 < 0.005, "{pu}");
    }

    #[test]
    fn unknown_and_out_of_range_instants_stay_unknown() {
        let heat = heat_carried_away(
            vec![Some(14.0), None, Some(14.0), Some(120.0), Some(13.0)],
            vec![Some(10.0), Some(10.0), Some(10.0), Some(10.0), Some(10.0)],
            vec![Some(50.0), Some(50.0), None, Some(50.0), Some(50.0)],
            WaterModel::Constant {
                specific_heat_j_per_kg_k: 4000.0,
                density_kg_per_l: 1.0,
            },
            1e6,
        );
        // Constant properties need no range: 120 °C is used as given.
        let heat = heat.unwrap();
        assert_eq!(heat.watts.get(0), Some(4000.0 * 4.0 * 50.0));
        assert_eq!(heat.watts.get(1), None);
        assert_eq!(heat.watts.get(2), None);
        assert_eq!(heat.watts.get(4), Some(4000.0 * 3.0 * 50.0));
        let measured = heat_carried_away(
            vec![Some(14.0), Some(120.0)],
            vec![Some(10.0), Some(10.0)],
            vec![Some(50.0), Some(50.0)],
            WaterModel::MEASURED,
            1e6,
        )
        .unwrap();
        assert!(measured.watts.get(0).is_some());
        assert_eq!(measured.watts.get(1), None);
        assert_eq!(measured.instants_out_of_range, 1);
        let pu: Vec<_> = measured.pu().collect();
        assert_eq!(pu[0], measured.watts.get(0).map(|w| w / 1e6));
        // The last 1 s of a 1 s grid is two instants; only one is known.
        assert_eq!(measured.end_of_run(1.0, 1.0).unwrap().instants, 1);
    }

    #[test]
    fn series_of_other_lengths_are_an_error() {
        let err = heat_carried_away(
            vec![Some(14.0); 3],
            vec![Some(10.0); 2],
            vec![Some(50.0); 3],
            WaterModel::PAPER,
            1e6,
        )
        .unwrap_err();
        assert!(matches!(
            err,
            NetworkError::Shape {
                what: "the inlet series",
                ..
            }
        ));
    }

    #[test]
    fn outlet_conductance_is_c_rho_q() {
        let w = Water {
            specific_heat_j_per_kg_k: 4183.0,
            density_kg_per_m3: 1000.0,
        };
        assert!((coolant_conductance_w_per_k(&w, 48.2) - 201_620.6).abs() < 1e-6);
    }
}
