//! The stator winding's and the core's labels against the losses that heat them.
//!
//! In a generator the armature copper loss arises in the stator winding and the iron
//! loss in the core: of each, the network's loss distribution K (k_ij, the share of loss
//! j entering part i) gives the larger share to its own part. A network that puts more of
//! the copper loss into the "core" than into the "winding" **and** more of the iron loss
//! into the "winding" than into the "core" describes the two sensors with their labels
//! exchanged (tags mapped the wrong way round from the start): the time constants are
//! right, but the parts they are given to and each part's rise are not.
//!
//! The finding is said, both channels named, and the model given as recorded: the
//! evidence is the identified network's, and the map is the user's to fix.

use super::{Action, Check, Finding};
use crate::losses::HeatSource;
use crate::network::Network;
use crate::recording::{Quantity, Signal};
use crate::spec::{InputSource, ModelDescription};

/// The shares of the copper and the iron loss in the winding and the core, where the
/// model has both parts and both losses.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LossShares {
    /// Copper loss into the winding, into the core.
    pub copper: (f64, f64),
    /// Iron loss into the winding, into the core.
    pub iron: (f64, f64),
}

/// The shares of `network` for the model's winding and core states.
pub fn shares(model: &ModelDescription, network: &Network) -> Option<LossShares> {
    let state = |q: Quantity| {
        model
            .states
            .iter()
            .position(|s| s.channel == Signal::Profile(q))
    };
    let input = |h: HeatSource| {
        model
            .inputs
            .iter()
            .position(|i| matches!(i.source, InputSource::Loss(s) if s == h))
    };
    let (w, c) = (
        state(Quantity::StatorWindingTemp)?,
        state(Quantity::CoreTemp)?,
    );
    let (cu, fe) = (
        input(HeatSource::ArmatureCopperLoss)?,
        input(HeatSource::IronLoss)?,
    );
    let k = &network.loss_distribution;
    let at = |i: usize, j: usize| k.get(i).and_then(|r| r.get(j)).copied();
    Some(LossShares {
        copper: (at(w, cu)?, at(c, cu)?),
        iron: (at(w, fe)?, at(c, fe)?),
    })
}

/// A finding where the network heats the "core" mostly by the copper loss and the
/// "winding" mostly by the iron loss.
pub fn check(model: &ModelDescription, network: &Network) -> Option<Finding> {
    let s = shares(model, network)?;
    if !(s.copper.1 > s.copper.0 && s.iron.0 > s.iron.1) {
        return None;
    }
    let (w, c) = (Quantity::StatorWindingTemp, Quantity::CoreTemp);
    Some(Finding {
        check: Check::ExchangedLabels,
        channels: vec![w.name().to_owned(), c.name().to_owned()],
        time: None,
        cause: "the two channels' labels exchanged in the map or the recording".into(),
        action: Action::Said,
        message: format!(
            "{w} and {c} are likely exchanged: the network puts {:.0} % of the armature \
             copper loss into {c} (against {:.0} % into {w}) and {:.0} % of the iron loss \
             into {w} (against {:.0} % into {c}), which a generator does not do; check \
             `quantity` of both channels in the import map or the recording; the model is \
             given as recorded, its parts' time constants and rises likely exchanged",
            100.0 * s.copper.1,
            100.0 * s.copper.0,
            100.0 * s.iron.0,
            100.0 * s.iron.1
        ),
    })
}
