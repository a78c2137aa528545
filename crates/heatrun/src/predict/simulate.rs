//! The model run forward: temperatures from rises, the inputs of an operating point at
//! the predicted temperatures, one step x(k+1) = Φ x(k) + Γ u(k), and the steady state;
//! the temperatures are the measured outputs y = C x + D u of a model with hidden states.

use std::collections::VecDeque;

use nalgebra::{DMatrix, DVector};

use super::load::OperatingPoint;
use crate::losses::{self, HeatSource};
use crate::model_file::{FieldTemperatureUse, ThermalModel, UseError};
use crate::recording::{Nameplate, Quantity, Signal};
use crate::spec::{InputSource, Reference};

/// The model ready to run: the checks that every input can be computed are done once.
#[derive(Debug, Clone)]
pub struct Simulator<'a> {
    /// The model.
    pub model: &'a ThermalModel,
    /// (I − Φ)⁻¹ Γ: the steady state per unit input (eq. 31 in discrete form).
    steady_gain: DMatrix<f64>,
    /// The stator winding state, where the loss model needs its temperature.
    stator: Option<usize>,
}

impl<'a> Simulator<'a> {
    /// Checks that the model's inputs can be computed from operating points.
    pub fn new(model: &'a ThermalModel) -> Result<Simulator<'a>, UseError> {
        let n = model.order();
        let losses = model
            .inputs
            .iter()
            .any(|i| matches!(i.source, InputSource::Loss(_)));
        if losses && model.nameplate.is_none() {
            return Err(model.missing("nameplate", "the loss model's inputs need"));
        }
        let stator = model.state_of(Quantity::StatorWindingTemp);
        let copper = model.inputs.iter().any(|i| {
            matches!(
                i.source,
                InputSource::Loss(HeatSource::ArmatureCopperLoss | HeatSource::FieldCopperLoss)
            )
        });
        if copper && stator.is_none() {
            return Err(model.missing(
                "model.states[stator_winding_temp]",
                "the copper losses need (R_a and R_f at the stator winding's temperature)",
            ));
        }
        let i_minus_phi = DMatrix::identity(n, n) - &model.phi;
        let steady_gain = i_minus_phi.lu().solve(&model.gamma).ok_or_else(|| {
            UseError::Request(format!(
                "{}: I − Φ is singular: the model has no steady state",
                model.path.display()
            ))
        })?;
        Ok(Simulator {
            model,
            steady_gain,
            stator,
        })
    }

    fn nameplate(&self) -> &Nameplate {
        // Checked in `new` wherever a loss input needs it.
        self.model
            .nameplate
            .as_ref()
            .expect("Simulator::new checked the nameplate")
    }

    /// The coolant shift Δ = θ_in − θ_in,test added to the rises measured from the
    /// initial temperatures, where the schedule gives a coolant inlet temperature, the
    /// model's recording had one, and the model does not carry the coolant itself.
    pub fn coolant_shift(&self, p: &OperatingPoint) -> f64 {
        match (p.coolant_inlet_c, self.model.coolant_inlet_temp_c) {
            (Some(now), Some(test)) if !self.model.uses_coolant_inlet() => now - test,
            _ => 0.0,
        }
    }

    /// Whether the schedule's coolant temperature can be used (see [`Self::coolant_shift`]).
    pub fn coolant_applies(&self) -> bool {
        self.model.uses_coolant_inlet() || self.model.coolant_inlet_temp_c.is_some()
    }

    /// θ_ref,j + (shift for rises from the initial temperatures) at `p`, °C.
    fn offset(&self, j: usize, p: &OperatingPoint) -> f64 {
        // The reference at the start of the model's recording.
        let r0 = self.model.initial_reference_c[j];
        match &self.model.states[j].reference {
            Reference::Initial => r0 + self.coolant_shift(p),
            Reference::Absolute => 0.0,
            Reference::Channel(Signal::Profile(Quantity::CoolingWaterInletTemp)) => p
                .coolant_inlet_c
                .or(self.model.coolant_inlet_temp_c)
                .unwrap_or(r0),
            Reference::Channel(c) => p.channels.get(c.name()).copied().unwrap_or(r0),
            // A constant: the inlet's drift from it is an input, not an offset.
            Reference::InitialOf(_) => r0,
        }
    }

    /// Temperatures θ_j = θ_ref,j + θ_base · x_j, °C, of the measured rises `x` (pu) at
    /// `p` (a model with hidden states: its outputs y, [`ThermalModel::outputs`]).
    pub fn temperatures(&self, x: &DVector<f64>, p: &OperatingPoint) -> Vec<f64> {
        (0..x.len())
            .map(|j| self.offset(j, p) + self.model.temperature_base_k * x[j])
            .collect()
    }

    /// The rises of temperatures `theta` (°C) at `p`: the inverse of [`Self::temperatures`].
    pub fn rises(&self, theta: &[f64], p: &OperatingPoint) -> DVector<f64> {
        DVector::from_fn(theta.len(), |j, _| {
            (theta[j] - self.offset(j, p)) / self.model.temperature_base_k
        })
    }

    /// The field winding temperature for R_f, °C, where the loss model needs one.
    pub fn field_temperature_c(&self, theta: &[f64], p: &OperatingPoint) -> Option<f64> {
        match self.model.field_temperature {
            FieldTemperatureUse::State(j) => Some(theta[j]),
            FieldTemperatureUse::FromStator { intercept_c, slope } => {
                let shift = self.coolant_shift(p);
                let stator = theta[self.stator?];
                Some(shift + intercept_c + slope * (stator - shift))
            }
            FieldTemperatureUse::NotNeeded => None,
        }
    }

    /// The inputs u (model scaling) of operating point `p` at temperatures `theta` (°C):
    /// the loss model with R_a at the stator winding's and R_f at the field winding's
    /// temperature, channels from the schedule's columns.
    pub fn inputs(&self, p: &OperatingPoint, theta: &[f64]) -> Result<DVector<f64>, UseError> {
        let base = self.model.power_base_w;
        let inlet = Quantity::CoolingWaterInletTemp.name();
        let channel = |c: &str| -> f64 {
            if c == inlet {
                p.coolant_inlet_c
                    .or(self.model.coolant_inlet_temp_c)
                    .unwrap_or(f64::NAN)
            } else {
                p.channels.get(c).copied().unwrap_or(f64::NAN)
            }
        };
        let mut u = DVector::zeros(self.model.inputs.len());
        for (i, input) in self.model.inputs.iter().enumerate() {
            u[i] = match &input.source {
                InputSource::Loss(h) => self.loss_w(*h, p, theta) / base,
                InputSource::Channel(c) => channel(c.name()) / base,
                InputSource::Expression(e) => {
                    let args: Vec<f64> = e.channels().iter().map(|c| channel(c.name())).collect();
                    e.eval(&args).unwrap_or(f64::NAN) / base
                }
                // (θ_in − θ_in,0) / θ_base: the schedule's inlet, else the model test's
                // level (no drift).
                InputSource::BoundaryRise(c) => {
                    let level = self.model.initial_level_of(c).unwrap_or(f64::NAN);
                    let now = if c.name() == inlet {
                        p.coolant_inlet_c.unwrap_or(level)
                    } else {
                        p.channels.get(c.name()).copied().unwrap_or(level)
                    };
                    (now - level) / self.model.temperature_base_k
                }
                // A schedule holds the cooling-water flow at the test's Q₀ (predict warns),
                // where the flow change carries no heat of its own: u_Q = 0.
                InputSource::CoolantFlow { .. } => 0.0,
            };
            if !u[i].is_finite() {
                return Err(UseError::Request(format!(
                    "input `{}` is not a number at this operating point (a channel it reads is \
                     missing, or its expression is undefined there)",
                    input.name
                )));
            }
        }
        Ok(u)
    }

    fn loss_w(&self, h: HeatSource, p: &OperatingPoint, theta: &[f64]) -> f64 {
        let np = self.nameplate();
        let stator = self.stator.map_or(f64::NAN, |j| theta[j]);
        match h {
            HeatSource::ArmatureCopperLoss => {
                losses::armature_copper_loss_w(np, p.armature_current_a, stator)
            }
            HeatSource::FieldCopperLoss => losses::field_copper_loss_w(
                np,
                p.field_current_a,
                self.field_temperature_c(theta, p).unwrap_or(f64::NAN),
            ),
            HeatSource::IronLoss => losses::iron_loss_w(np, p.line_voltage_v),
        }
    }

    /// One step: x(k+1) = Φ x(k) + Γ u(k).
    pub fn step(&self, x: &DVector<f64>, u: &DVector<f64>) -> DVector<f64> {
        &self.model.phi * x + &self.model.gamma * u
    }

    /// The steady rises of the measured temperatures at `p`: y = C (I − Φ)⁻¹ Γ u(y) + D u(y)
    /// (y = x = (I − Φ)⁻¹ Γ u(x) for a measured-state model), iterated because the
    /// copper losses grow with the temperatures they cause (a contraction: R changes by
    /// 1/(235 + θ) per kelvin).
    pub fn steady_state(&self, p: &OperatingPoint) -> Result<DVector<f64>, UseError> {
        Ok(self.steady_state_with_states(p)?.1)
    }

    /// The steady state of `p` as (the model's states x, the measured rises y): for a
    /// model with hidden states, the hidden ones too (see [`Self::steady_state`]).
    pub fn steady_state_with_states(
        &self,
        p: &OperatingPoint,
    ) -> Result<(DVector<f64>, DVector<f64>), UseError> {
        let mut x = DVector::zeros(self.model.order());
        let mut y = DVector::zeros(self.model.state_count());
        for _ in 0..200 {
            let u = self.inputs(p, &self.temperatures(&y, p))?;
            x = &self.steady_gain * &u;
            let next = self.model.outputs(&x, &u);
            let change = (&next - &y).amax();
            y = next;
            if change < 1e-13 {
                break;
            }
        }
        Ok((x, y))
    }
}

/// The inputs' dead times on the model's grid: the input applied at step k is the one
/// computed at step k − d_i (d_i = delay_s / Ts whole samples, input by input), so a
/// step is x(k+1) = Φ x(k) + Γ u(k − d). Before the first step each input is taken to
/// have held its first value (the schedule's first row, or the state a step starts
/// from) for its whole dead time. An advanced input (the report's `advance_s`, one
/// sample) is applied as u(k + 1): non-causal in the recorded series, so the caller reads
/// it from the schedule one sample ahead ([`DelayLine::apply_ahead`]).
#[derive(Debug, Clone)]
pub struct DelayLine {
    /// d_i, samples, per input (0 for an advanced one).
    delays: Vec<usize>,
    /// Whether input i is advanced one sample.
    advanced: Vec<bool>,
    /// The inputs computed at the last max(d) + 1 steps, the newest last.
    past: VecDeque<DVector<f64>>,
}

impl DelayLine {
    /// The model's shifts in whole samples of its Ts; one off the grid (or an advance
    /// beyond one sample) is refused by name (the report was written by a spec whose
    /// shifts sat on its own grid).
    pub fn new(model: &ThermalModel) -> Result<DelayLine, UseError> {
        let shifts = model
            .inputs
            .iter()
            .map(|i| {
                crate::spec::delay::shift_samples(i.delay_s, model.ts_s).ok_or_else(|| {
                    let what = if i.delay_s < 0.0 {
                        format!("an advance of {} s is not one sample", -i.delay_s)
                    } else {
                        format!(
                            "a dead time of {} s is not a whole number of samples",
                            i.delay_s
                        )
                    };
                    UseError::Request(format!(
                        "input `{}`: {what} of Ts = {} s",
                        i.name, model.ts_s
                    ))
                })
            })
            .collect::<Result<Vec<_>, _>>()?;
        Ok(DelayLine {
            delays: shifts.iter().map(|&s| s.max(0).unsigned_abs()).collect(),
            advanced: shifts.iter().map(|&s| s < 0).collect(),
            past: VecDeque::new(),
        })
    }

    /// Whether some input is advanced: the caller must give the next instant's inputs.
    pub fn reads_ahead(&self) -> bool {
        self.advanced.iter().any(|&a| a)
    }

    /// Records the inputs computed now and returns those to apply now, u_i(k − d_i)
    /// (an advanced input as computed now: see [`DelayLine::apply_ahead`]).
    pub fn apply(&mut self, u: DVector<f64>) -> DVector<f64> {
        let longest = self.delays.iter().copied().max().unwrap_or(0);
        if longest == 0 {
            return u;
        }
        if self.past.is_empty() {
            self.past.extend(std::iter::repeat_n(u.clone(), longest));
        }
        self.past.push_back(u);
        if self.past.len() > longest + 1 {
            self.past.pop_front();
        }
        let newest = self.past.len() - 1;
        DVector::from_fn(self.delays.len(), |i, _| {
            self.past[newest - self.delays[i]][i]
        })
    }

    /// [`DelayLine::apply`] with the inputs computed for the next instant, `next`: an
    /// advanced input is applied as u_i(k + 1), the others as u_i(k − d_i).
    pub fn apply_ahead(&mut self, u: DVector<f64>, next: &DVector<f64>) -> DVector<f64> {
        let mut applied = self.apply(u);
        for (i, _) in self.advanced.iter().enumerate().filter(|(_, &a)| a) {
            applied[i] = next[i];
        }
        applied
    }
}

#[cfg(test)]
mod delay_tests {
    use super::*;

    #[test]
    fn each_input_is_applied_its_own_dead_time_later_after_holding_its_first_value() {
        // Two inputs, dead times 0 and 2 samples: computed (1, 10), (2, 20), (3, 30),
        // (4, 40) → applied (1, 10), (2, 10), (3, 10), (4, 20), worked by hand.
        let mut line = DelayLine {
            delays: vec![0, 2],
            advanced: vec![false, false],
            past: VecDeque::new(),
        };
        let applied: Vec<(f64, f64)> = (1..=4)
            .map(|k| {
                let u = line.apply(DVector::from_vec(vec![k as f64, 10.0 * k as f64]));
                (u[0], u[1])
            })
            .collect();
        assert_eq!(
            applied,
            vec![(1.0, 10.0), (2.0, 10.0), (3.0, 10.0), (4.0, 20.0)]
        );
    }

    #[test]
    fn an_advanced_input_is_applied_from_the_next_instant() {
        // Inputs delayed 1, advanced 1, as is: computed (1, 10, 100), (2, 20, 200), (3, 30,
        // 300), next instant's inputs (k + 1) → applied (1, 20, 100), (1, 30, 200),
        // (2, 40, 300), worked by hand.
        let mut line = DelayLine {
            delays: vec![1, 0, 0],
            advanced: vec![false, true, false],
            past: VecDeque::new(),
        };
        assert!(line.reads_ahead());
        let at = |k: f64| DVector::from_vec(vec![k, 10.0 * k, 100.0 * k]);
        let applied: Vec<Vec<f64>> = (1..=3)
            .map(|k| {
                let k = k as f64;
                line.apply_ahead(at(k), &at(k + 1.0))
                    .iter()
                    .copied()
                    .collect()
            })
            .collect();
        assert_eq!(
            applied,
            vec![
                vec![1.0, 20.0, 100.0],
                vec![1.0, 30.0, 200.0],
                vec![2.0, 40.0, 300.0]
            ]
        );
    }

    #[test]
    fn without_dead_times_the_inputs_pass_through() {
        let mut line = DelayLine {
            delays: vec![0, 0],
            advanced: vec![false, false],
            past: VecDeque::new(),
        };
        let u = DVector::from_vec(vec![3.0, 4.0]);
        assert_eq!(line.apply(u.clone()), u);
        assert!(line.past.is_empty());
    }
}
