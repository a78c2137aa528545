//! The network stage of a replay: the identified model's passive thermal network (the
//! lumped RC scheme of the paper's Fig. 9, [`crate::thermal::network`]) with its
//! absolute scale, the calorimetric balance of the cooling water (eqs. 17–18) and the
//! equilibrium check.
//!
//! [`calorimetry`] gives the heat the cooling water carries away (and the outlet's
//! conductance to the coolant, c·ρ·Q, that fixes the network's scale); `equilibrium`
//! checks whether the recording reached its thermal equilibrium; `fit` finds the passive
//! network nearest an identified model; `stage` runs them for a replay.

pub mod calorimetry;
pub(crate) mod equilibrium;
pub(crate) mod fit;
pub(crate) mod stage;

pub use crate::thermal::network::*;
pub use stage::{Calorimetry, NetworkAnalysis};
