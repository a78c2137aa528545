//! Rating: the largest continuous apparent power whose steady-state temperatures keep
//! every part within its insulation class's limit, the part that limits it, the
//! margins at rated load, and short-time overload ratings.
//!
//! Input: a [`ThermalModel`] and [`RatingOptions`] (limits by class and/or per part,
//! power factor, voltage, coolant temperature). Output: a [`Rating`]. The steady state
//! of a load point is x = (I − Φ)⁻¹ Γ u(x) ([`Simulator::steady_state`]); the continuous
//! rating is found by bisection on S; an overload is simulated step by step from the
//! rated steady state until the first part reaches its limit.

use nalgebra::DVector;
use serde::Serialize;

use crate::model_file::{FieldTemperatureUse, ThermalModel, UseError};
use crate::predict::phasor::PhasorMachine;
use crate::predict::{OperatingPoint, Simulator};
use crate::recording::Quantity;

mod interval;

pub use interval::{PartLimit, DRAWS as INTERVAL_DRAWS};

/// Where the built-in limits come from.
pub const LIMIT_SOURCE: &str = "IEC 60034-1:2017, Table 7 (limits of temperature rise of windings \
     indirectly cooled by air, over a 40 °C reference coolant): stator winding item 1a (a.c. \
     windings of machines of 5 000 kVA or more) by embedded temperature detectors (ETD); field \
     winding item 3 (d.c. field windings) by resistance (R); the core held to its winding's ETD \
     limit (§8.10: a core must not reach a temperature that harms the insulation next to it). \
     Limit temperature = 40 °C + rise limit; a machine cooled through a water heat exchanger \
     may refer its rises to the cooler's water inlet at 25 °C with limits 15 K higher: the same \
     temperatures";

/// Thermal class of the insulation (IEC 60085).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum InsulationClass {
    /// 130 (B).
    B,
    /// 155 (F).
    F,
    /// 180 (H).
    H,
}

/// A part the built-in table has a limit for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum InsulatedPart {
    /// The stator (armature) winding, by ETD.
    StatorWinding,
    /// The field winding, by resistance.
    FieldWinding,
    /// The stator core, held to the stator winding's limit.
    Core,
}

/// The reference coolant temperature of IEC 60034-1's rise limits (air), °C.
pub const REFERENCE_COOLANT_C: f64 = 40.0;

/// Rise limit over the reference coolant, K (IEC 60034-1 Table 7, see [`LIMIT_SOURCE`]).
pub fn rise_limit_k(part: InsulatedPart, class: InsulationClass) -> f64 {
    use InsulationClass::*;
    match (part, class) {
        // Item 1a, ETD.
        (InsulatedPart::StatorWinding | InsulatedPart::Core, B) => 85.0,
        (InsulatedPart::StatorWinding | InsulatedPart::Core, F) => 110.0,
        (InsulatedPart::StatorWinding | InsulatedPart::Core, H) => 130.0,
        // Item 3, R.
        (InsulatedPart::FieldWinding, B) => 80.0,
        (InsulatedPart::FieldWinding, F) => 105.0,
        (InsulatedPart::FieldWinding, H) => 125.0,
    }
}

/// The temperature limit of a part, °C: 40 °C + its rise limit.
pub fn temperature_limit_c(part: InsulatedPart, class: InsulationClass) -> f64 {
    REFERENCE_COOLANT_C + rise_limit_k(part, class)
}

/// What the rating is asked for.
#[derive(Debug, Clone)]
pub struct RatingOptions {
    /// The insulation class, for the built-in limits.
    pub class: Option<InsulationClass>,
    /// Limits per state name (or `field_winding_temp` for the field winding derived from
    /// the stator winding), °C; they override the class's.
    pub limits_c: Vec<(String, f64)>,
    /// Power factor (positive lagging) [default: the nameplate's rated one].
    pub power_factor: Option<f64>,
    /// Line voltage, V [default: rated].
    pub voltage_v: Option<f64>,
    /// Coolant inlet temperature, °C (None: the model's test).
    pub coolant_c: Option<f64>,
    /// Overloads, fractions of rated current (1.1, 1.2, …).
    pub overloads: Vec<f64>,
}

/// A part with its limit.
#[derive(Debug, Clone, Serialize)]
pub struct LimitedPart {
    /// The state's name, or `field_winding_temp` for the derived field winding.
    pub name: String,
    /// Its limit, °C.
    pub limit_c: f64,
    /// Where the limit comes from (`class F`, `--limit`).
    pub limit_from: String,
    /// The state index, or `None` for the derived field winding.
    #[serde(skip)]
    state: Option<usize>,
}

/// One short-time rating.
#[derive(Debug, Clone, Serialize)]
pub struct Overload {
    /// Armature current, % of rated.
    pub current_percent: f64,
    /// Time from the rated steady state to the first limit, s (`None`: not within ten
    /// slowest time constants).
    pub time_to_limit_s: Option<f64>,
    /// The part that reaches its limit first.
    pub limiting_part: Option<String>,
    /// The 95 % interval of the time to the limit, s, [low, high]: T ± 1.96·σ_T with
    /// σ_T² = ∇Tᵀ C_Θ ∇T, the low end at least 0 (absent without C_Θ or a limit).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub time_to_limit_s_95: Option<[f64; 2]>,
}

/// The machine's thermal rating.
#[derive(Debug, Clone, Serialize)]
pub struct Rating {
    /// The model report.
    pub model: String,
    /// The largest continuous apparent power, MVA.
    pub max_continuous_apparent_power_mva: f64,
    /// Its ratio to the rated apparent power.
    pub max_continuous_per_rated: f64,
    /// The part that limits it.
    pub limiting_state: String,
    /// The 95 % interval of the largest continuous apparent power, MVA, [low, high]: the
    /// 2.5 % and 97.5 % quantiles of min_j S_j over draws of the parts' own limits S_j
    /// (linearised in Θ, see [`PartLimit`]); absent where the report carries no C_Θ.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_continuous_apparent_power_mva_95: Option<[f64; 2]>,
    /// The probability that a part other than `limiting_state` limits the continuous
    /// rating (the share of those draws whose least S_j is another part's).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub probability_another_part_limits: Option<f64>,
    /// Each part's own continuous limit with its uncertainty (as `limits`; empty without
    /// C_Θ).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub part_limits: Vec<PartLimit>,
    /// Power factor, voltage (kV) and coolant (°C) of the rating.
    pub power_factor: f64,
    /// Line voltage, kV.
    pub voltage_kv: f64,
    /// Coolant inlet temperature, °C (None: the model's test temperatures as recorded).
    pub coolant_inlet_temp_c: Option<f64>,
    /// The parts and their limits.
    pub limits: Vec<LimitedPart>,
    /// Steady temperatures at the maximum, °C, per part (as `limits`).
    pub temperatures_at_max_c: Vec<f64>,
    /// Steady temperatures at rated apparent power, °C.
    pub temperatures_at_rated_c: Vec<f64>,
    /// Margins at rated load (limit − temperature), K.
    pub margins_at_rated_k: Vec<f64>,
    /// Short-time ratings from the rated steady state.
    pub overloads: Vec<Overload>,
    /// Where the built-in limits come from.
    pub limit_source: &'static str,
    /// What was assumed.
    pub warnings: Vec<String>,
}

/// The rating's load points: S at the power factor, voltage and coolant asked for.
struct Loading<'a> {
    sim: Simulator<'a>,
    phasor: PhasorMachine,
    rated_mva: f64,
    rated_current_a: f64,
    voltage_v: f64,
    rated_voltage_v: f64,
    power_factor: f64,
    coolant_c: Option<f64>,
    parts: Vec<LimitedPart>,
}

impl Loading<'_> {
    fn point(&self, s_mva: f64) -> OperatingPoint {
        let i = s_mva * 1e6 / (3f64.sqrt() * self.voltage_v);
        OperatingPoint {
            armature_current_a: i,
            field_current_a: self.phasor.field_current_a(
                self.voltage_v / self.rated_voltage_v,
                i / self.rated_current_a,
                self.power_factor,
            ),
            line_voltage_v: self.voltage_v,
            coolant_inlet_c: self.coolant_c,
            channels: Default::default(),
        }
    }

    /// Each part's temperature for rises `x` at `p`, °C.
    fn part_temperatures(&self, x: &nalgebra::DVector<f64>, p: &OperatingPoint) -> Vec<f64> {
        let theta = self.sim.temperatures(x, p);
        self.parts
            .iter()
            .map(|part| match part.state {
                Some(j) => theta[j],
                None => self.sim.field_temperature_c(&theta, p).unwrap_or(f64::NAN),
            })
            .collect()
    }

    fn steady(&self, s_mva: f64) -> Result<Vec<f64>, UseError> {
        let p = self.point(s_mva);
        let x = self.sim.steady_state(&p)?;
        Ok(self.part_temperatures(&x, &p))
    }

    /// The smallest margin (limit − temperature) and its part.
    fn margin(&self, theta: &[f64]) -> (f64, usize) {
        self.parts
            .iter()
            .zip(theta)
            .enumerate()
            .map(|(i, (p, t))| (p.limit_c - t, i))
            .fold((f64::INFINITY, 0), |m, v| if v.0 < m.0 { v } else { m })
    }
}

/// Each state's steady-state rise at the nameplate's rating, K: θ_base · x with
/// x = (I − Φ)⁻¹ Γ u(x) (eqs. 30–35, iterated as the copper losses follow the
/// temperatures) at rated current and voltage, the field current of the rated power
/// factor (the phasor diagram) and the coolant of the model's test: what units of one
/// design compare on, whatever load their heat runs ended at.
pub fn rises_at_rated(model: &ThermalModel) -> Result<Vec<f64>, UseError> {
    let sim = Simulator::new(model)?;
    let np = model
        .nameplate
        .as_ref()
        .ok_or_else(|| model.missing("nameplate", "the rated load needs"))?;
    let (phasor, _) = PhasorMachine::from_nameplate(np).ok_or_else(|| {
        model.missing(
            "nameplate.rated_field_current_a",
            "the field current of the rated load needs",
        )
    })?;
    let rated = OperatingPoint {
        armature_current_a: np.rated_current_a,
        field_current_a: phasor.field_current_a(1.0, 1.0, phasor.rated_power_factor),
        line_voltage_v: np.rated_voltage_v,
        coolant_inlet_c: None,
        channels: Default::default(),
    };
    let x = sim.steady_state(&rated)?;
    Ok(x.iter().map(|r| r * model.temperature_base_k).collect())
}

/// Rates the machine the model describes, with the 95 % intervals of the continuous
/// rating and the overload times where the report carries the covariance of Θ (of
/// θ_h = [Φ Γ; C D] for a model with hidden states, its parts' temperatures the outputs
/// y = C x + D u; the propagation is `interval`'s, see [`PartLimit`]).
pub fn rate(model: &ThermalModel, o: &RatingOptions) -> Result<Rating, UseError> {
    let mut rating = rate_nominal(model, o)?;
    match &model.uncertainty.theta_covariance {
        Some(c) => interval::add_intervals(&mut rating, model, o, c)?,
        None if model.output.is_some() => rating.warnings.push(
            "the model has hidden states and the report carries no covariance of their \
             parameters (`hidden.parameter_covariance`): the rating has no intervals"
                .into(),
        ),
        None => rating.warnings.push(
            "the report carries no covariance of Θ (`theta_covariance`): the rating has no \
             intervals"
                .into(),
        ),
    }
    Ok(rating)
}

/// The short-time overloads alone, without intervals (the page's curve of many).
pub fn overload_curve(model: &ThermalModel, o: &RatingOptions) -> Result<Vec<Overload>, UseError> {
    Ok(rate_nominal(model, o)?.overloads)
}

/// The rating at the estimate Θ̂, without intervals.
fn rate_nominal(model: &ThermalModel, o: &RatingOptions) -> Result<Rating, UseError> {
    let loading = loading(model, o)?;
    let mut warnings = loading_warnings(model, o)?;
    // A continuous rating is a steady state: say where the model's recording never reached
    // the one it rests on.
    warnings.extend(model.steady_state_extrapolation.as_ref().map(|why| {
        format!("the continuous rating rests on a steady state that is an extrapolation beyond the model's recording: {why}")
    }));
    if o.coolant_c.is_some() && !loading.sim.coolant_applies() {
        warnings.push(
            "the model's recording has no coolant inlet temperature: the coolant temperature \
             asked for cannot be applied; the temperatures are those of the model's test"
                .into(),
        );
    }
    let rated = loading.rated_mva;
    let (s_max, limiting) = max_continuous(&loading)?;
    let at_max = loading.steady(s_max)?;
    let at_rated = loading.steady(rated)?;
    let (rated_state, _) = loading
        .sim
        .steady_state_with_states(&loading.point(rated))?;
    let overloads = o
        .overloads
        .iter()
        .map(|&f| overload(&loading, model, &rated_state, f))
        .collect::<Result<Vec<_>, _>>()?;
    Ok(Rating {
        model: model.path.display().to_string(),
        max_continuous_apparent_power_mva: s_max,
        max_continuous_per_rated: s_max / rated,
        limiting_state: loading.parts[limiting].name.clone(),
        max_continuous_apparent_power_mva_95: None,
        probability_another_part_limits: None,
        part_limits: Vec::new(),
        power_factor: loading.power_factor,
        voltage_kv: loading.voltage_v / 1e3,
        coolant_inlet_temp_c: o.coolant_c.filter(|_| loading.sim.coolant_applies()),
        margins_at_rated_k: loading
            .parts
            .iter()
            .zip(&at_rated)
            .map(|(p, t)| p.limit_c - t)
            .collect(),
        limits: loading.parts.clone(),
        temperatures_at_max_c: at_max,
        temperatures_at_rated_c: at_rated,
        overloads,
        limit_source: LIMIT_SOURCE,
        warnings,
    })
}

fn loading_warnings(model: &ThermalModel, o: &RatingOptions) -> Result<Vec<String>, UseError> {
    let np = model
        .nameplate
        .as_ref()
        .ok_or_else(|| model.missing("nameplate", "the rating needs"))?;
    let mut warnings = PhasorMachine::from_nameplate(np)
        .map(|m| m.1)
        .unwrap_or_default();
    if o.power_factor.is_some() {
        warnings.retain(|w| !w.contains("rated_power_factor"));
    }
    Ok(warnings)
}

fn loading<'a>(model: &'a ThermalModel, o: &RatingOptions) -> Result<Loading<'a>, UseError> {
    let sim = Simulator::new(model)?;
    let np = model
        .nameplate
        .as_ref()
        .ok_or_else(|| model.missing("nameplate", "the rating needs"))?;
    let (phasor, _) = PhasorMachine::from_nameplate(np).ok_or_else(|| {
        model.missing(
            "nameplate.rated_field_current_a",
            "the field current of a load point needs",
        )
    })?;
    let power_factor = o.power_factor.unwrap_or(phasor.rated_power_factor);
    if !(power_factor.abs() > 0.0 && power_factor.abs() <= 1.0) {
        return Err(UseError::Request(format!(
            "the power factor {power_factor} is not in (0, 1] (negative: leading)"
        )));
    }
    let voltage_v = o.voltage_v.unwrap_or(np.rated_voltage_v);
    if !(voltage_v > 0.0) {
        return Err(UseError::Request(format!(
            "the voltage {voltage_v} V is not positive"
        )));
    }
    Ok(Loading {
        parts: parts(model, o)?,
        sim,
        phasor,
        rated_mva: np.rated_apparent_power_va / 1e6,
        rated_current_a: np.rated_current_a,
        voltage_v,
        rated_voltage_v: np.rated_voltage_v,
        power_factor,
        coolant_c: o.coolant_c,
    })
}

/// The parts with a limit: states by their channel (the class's table) or by name
/// (`--limit`), and the field winding derived from the stator winding.
pub fn parts(model: &ThermalModel, o: &RatingOptions) -> Result<Vec<LimitedPart>, UseError> {
    let field = Quantity::FieldWindingTemp.name();
    let derived_field = matches!(
        model.field_temperature,
        FieldTemperatureUse::FromStator { .. }
    );
    for (name, _) in &o.limits_c {
        let known =
            model.states.iter().any(|s| &s.name == name) || (derived_field && name == field);
        if !known {
            let mut names: Vec<&str> = model.states.iter().map(|s| s.name.as_str()).collect();
            if derived_field {
                names.push(field);
            }
            return Err(UseError::Request(format!(
                "a limit for `{name}`, which is no part of the model (its parts: {})",
                names.join(", ")
            )));
        }
    }
    let limit = |name: &str, part: Option<InsulatedPart>| -> Option<(f64, String)> {
        if let Some((_, v)) = o.limits_c.iter().rev().find(|(n, _)| n == name) {
            return Some((*v, "--limit".into()));
        }
        let class = o.class?;
        Some((
            temperature_limit_c(part?, class),
            format!("class {class:?}"),
        ))
    };
    let table_part = |channel: &str| match Quantity::from_name(channel) {
        Some(Quantity::StatorWindingTemp) => Some(InsulatedPart::StatorWinding),
        Some(Quantity::CoreTemp) => Some(InsulatedPart::Core),
        Some(Quantity::FieldWindingTemp) => Some(InsulatedPart::FieldWinding),
        _ => None,
    };
    let mut parts: Vec<LimitedPart> = model
        .states
        .iter()
        .enumerate()
        .filter_map(|(j, s)| {
            let (limit_c, limit_from) = limit(&s.name, table_part(s.channel.name()))?;
            Some(LimitedPart {
                name: s.name.clone(),
                limit_c,
                limit_from,
                state: Some(j),
            })
        })
        .collect();
    if derived_field {
        if let Some((limit_c, limit_from)) = limit(field, Some(InsulatedPart::FieldWinding)) {
            parts.push(LimitedPart {
                name: field.into(),
                limit_c,
                limit_from: format!("{limit_from} (from the stator winding's temperature)"),
                state: None,
            });
        }
    }
    if parts.is_empty() {
        return Err(UseError::Request(
            "no part has a limit: give an insulation class or a limit per part".into(),
        ));
    }
    Ok(parts)
}

/// The largest S whose steady state keeps every margin ≥ 0, by bisection, and its
/// limiting part.
fn max_continuous(l: &Loading) -> Result<(f64, usize), UseError> {
    let (m0, part0) = l.margin(&l.steady(0.0)?);
    if m0 < 0.0 {
        return Ok((0.0, part0));
    }
    let mut lo = 0.0;
    let mut hi = l.rated_mva;
    let mut doublings = 0;
    while l.margin(&l.steady(hi)?).0 >= 0.0 {
        lo = hi;
        hi *= 2.0;
        doublings += 1;
        if doublings > 12 {
            return Err(UseError::Request(format!(
                "no limit is reached below {hi:.0} MVA: the model's losses do not heat the limited parts"
            )));
        }
    }
    while hi - lo > 1e-9 * l.rated_mva {
        let mid = 0.5 * (lo + hi);
        if l.margin(&l.steady(mid)?).0 >= 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    Ok((lo, l.margin(&l.steady(hi)?).1))
}

/// The time from the rated steady state, after a step to `fraction` × rated current,
/// until the first part reaches its limit (linear between the steps that straddle it).
/// `rated_state` is the rated point's steady state, the same for every fraction.
fn overload(
    l: &Loading,
    model: &ThermalModel,
    rated_state: &DVector<f64>,
    fraction: f64,
) -> Result<Overload, UseError> {
    let rated = l.point(l.rated_mva);
    let mut x = rated_state.clone();
    let p = l.point(fraction * l.rated_mva);
    let slowest = model.time_constants_s.iter().copied().fold(0.0, f64::max);
    let steps = (10.0 * slowest / model.ts_s).ceil() as usize;
    // The measured rises y = C x + D u (x itself for a measured-state model): the rated
    // steady state's, its inputs at its own temperatures.
    let rated_u = steady_input(l, model, &x, &rated)?;
    let mut y = model.outputs(&x, &rated_u);
    let mut theta = l.part_temperatures(&y, &p);
    let (mut margin, part) = l.margin(&theta);
    let mut result = Overload {
        current_percent: 100.0 * fraction,
        time_to_limit_s: None,
        limiting_part: None,
        time_to_limit_s_95: None,
    };
    if margin <= 0.0 {
        result.time_to_limit_s = Some(0.0);
        result.limiting_part = Some(l.parts[part].name.clone());
        return Ok(result);
    }
    // Before the step the machine held the rated steady state: a dead time delays the
    // overload's inputs behind the rated ones.
    let mut delays = crate::predict::DelayLine::new(model)?;
    delays.apply(rated_u);
    for k in 0..steps {
        let u = delays.apply(l.sim.inputs(&p, &l.sim.temperatures(&y, &p))?);
        x = l.sim.step(&x, &u);
        // The feedthrough D u of the input just applied (none in a measured-state model).
        y = model.outputs(&x, &u);
        theta = l.part_temperatures(&y, &p);
        let (next, next_part) = l.margin(&theta);
        if next <= 0.0 {
            let fraction_of_step = margin / (margin - next);
            result.time_to_limit_s = Some((k as f64 + fraction_of_step) * model.ts_s);
            result.limiting_part = Some(l.parts[next_part].name.clone());
            return Ok(result);
        }
        margin = next;
    }
    Ok(result)
}

/// The inputs of the steady state `x` at `p`, at its own measured temperatures: a
/// fixed point of y = C x + D u(y) (y = x without hidden states), iterated as
/// [`crate::predict::Simulator::steady_state`] is.
fn steady_input(
    l: &Loading,
    model: &ThermalModel,
    x: &DVector<f64>,
    p: &OperatingPoint,
) -> Result<DVector<f64>, UseError> {
    let mut y = model.outputs(x, &DVector::zeros(model.inputs.len()));
    let mut u = l.sim.inputs(p, &l.sim.temperatures(&y, p))?;
    if model.output.is_some() {
        for _ in 0..50 {
            let next = model.outputs(x, &u);
            let change = (&next - &y).amax();
            y = next;
            u = l.sim.inputs(p, &l.sim.temperatures(&y, p))?;
            if change < 1e-13 {
                break;
            }
        }
    }
    Ok(u)
}

impl Rating {
    /// The rating as a table for people.
    pub fn table(&self) -> String {
        use std::fmt::Write as _;
        let mut s = String::new();
        let _ = writeln!(
            s,
            "continuous rating at cos φ = {}, U = {:.3} kV, coolant inlet {}:",
            self.power_factor,
            self.voltage_kv,
            self.coolant_inlet_temp_c
                .map_or("as in the model's test".into(), |c| format!("{c} °C"))
        );
        let _ = writeln!(
            s,
            "  largest continuous apparent power {:.2} MVA ({:.3} × rated), limited by {}",
            self.max_continuous_apparent_power_mva,
            self.max_continuous_per_rated,
            self.limiting_state
        );
        if let Some([lo, hi]) = self.max_continuous_apparent_power_mva_95 {
            let _ = writeln!(
                s,
                "  95 % interval {lo:.2} to {hi:.2} MVA (from the identification's covariance); \
                 probability another part limits {:.1} %",
                100.0 * self.probability_another_part_limits.unwrap_or(0.0)
            );
        }
        let _ = writeln!(
            s,
            "  {:<28}{:>10}{:>14}{:>14}{:>12}  limit from",
            "part", "limit °C", "at max °C", "at rated °C", "margin K"
        );
        for (i, p) in self.limits.iter().enumerate() {
            let _ = writeln!(
                s,
                "  {:<28}{:>10.1}{:>14.2}{:>14.2}{:>12.2}  {}",
                p.name,
                p.limit_c,
                self.temperatures_at_max_c[i],
                self.temperatures_at_rated_c[i],
                self.margins_at_rated_k[i],
                p.limit_from
            );
        }
        let _ = writeln!(s, "short-time overloads from the rated steady state:");
        let _ = writeln!(
            s,
            "  {:>10}  {:>24}  first to reach its limit",
            "current", "time to limit"
        );
        for o in &self.overloads {
            let time = match (o.time_to_limit_s, o.time_to_limit_s_95) {
                (Some(t), Some([lo, hi])) => format!("{t:.0} s ({lo:.0} to {hi:.0})"),
                (Some(t), None) => format!("{t:.0} s"),
                (None, _) => "none".into(),
            };
            let _ = writeln!(
                s,
                "  {:>9.0} %  {:>24}  {}",
                o.current_percent,
                time,
                o.limiting_part.as_deref().unwrap_or("-")
            );
        }
        let _ = writeln!(s, "limits: {}", self.limit_source);
        // The warnings are the caller's to print (`heatrun rating` writes them on stderr).
        s
    }
}
