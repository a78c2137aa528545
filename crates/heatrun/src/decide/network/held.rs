//! The two tests of the held network, in which heat leaves the machine only through the
//! cooling water (every other part's conductance to the coolant held at zero), against
//! the free network that contains it: Rao's score test at the held fit alone
//! ([`ScoreTest`]), and the likelihood ratio against the free fit ([`HeldTest`]).

use crate::decide::Figure;
use crate::estimate::{Estimate, IdentificationData, ResistanceCapacitance};
use crate::network;

/// The level of the tests (score and likelihood ratio) that every part but the cooling
/// water has no conductance to the coolant: above it, the data cannot tell those
/// conductances from zero and the network holds them there.
pub(super) const THROUGH_COOLANT_LEVEL: f64 = 0.05;

/// The likelihood-ratio test of the held network (heat leaving only through the cooling
/// water) against the free one whose model contains it.
#[derive(Debug, Clone, Copy)]
pub(super) struct HeldTest {
    /// Λ = deviance(held) − deviance(free), at least 0 ([`nested_ratio`]).
    pub(super) ratio: f64,
    /// By how much the free fit ended above the held one, where it did.
    pub(super) free_short_by: Option<f64>,
    /// The conductances held at zero: Λ's degrees of freedom.
    pub(super) held_parts: usize,
    /// P(χ²_held_parts > Λ).
    pub(super) p: f64,
}

impl HeldTest {
    pub(super) fn of(
        data: &IdentificationData,
        free: &Estimate,
        held: &Estimate,
        floor: f64,
    ) -> HeldTest {
        let held_parts = held
            .network
            .as_ref()
            .map_or(0, |n| n.parts.capacitance_j_per_k.len().saturating_sub(1));
        let (ratio, free_short_by) =
            nested_ratio(crate::estimate::likelihood_ratio(data, free, held, floor));
        HeldTest {
            ratio,
            free_short_by,
            held_parts,
            p: network::fit::chi_square_survival(ratio, held_parts),
        }
    }

    /// Whether the data tell the held network from the free one ([`THROUGH_COOLANT_LEVEL`]).
    pub(super) fn rejects(&self) -> bool {
        self.p < THROUGH_COOLANT_LEVEL
    }

    /// The figures the decision names: Λ, its degrees of freedom and p.
    pub(super) fn figures(&self) -> Vec<Figure> {
        figures(
            "likelihood ratio of heat through the cooling water alone against the free fit",
            self.ratio,
            self.held_parts,
            self.p,
        )
    }
}

/// A test of the held network (heat leaving through the cooling water alone) as a
/// decision's figures: the statistic `what`, its degrees of freedom and its p.
fn figures(what: &str, statistic: f64, held_parts: usize, p: f64) -> Vec<Figure> {
    vec![
        Figure::new(what, statistic, ""),
        Figure::new("its degrees of freedom", held_parts as f64, ""),
        Figure::new("its p", p, ""),
    ]
}

/// Rao's score test of the held network (heat leaving only through the cooling water)
/// against the free one, at the held fit alone ([`ResistanceCapacitance::held_score`]).
#[derive(Debug, Clone, Copy)]
pub(super) struct ScoreTest {
    /// S, in χ² units.
    pub(super) statistic: f64,
    /// The conductances held at zero: S's degrees of freedom.
    pub(super) held_parts: usize,
    /// P(χ²_held_parts > S): for a statistic whose freed conductances move only upwards
    /// (a χ̄² under the held network), a bound above its own p-value, so the test keeps
    /// the held network at least as often as its level says.
    pub(super) p: f64,
    /// What the held fit's own Gauss–Newton step would still gain, in χ² units: the
    /// squared length of its step to its minimum in its standard errors.
    pub(super) short_of_minimum: f64,
}

/// The most the held fit's own step may still gain (χ² units) for its network to be kept
/// on the score test alone: 2² (its minimum within two standard errors along the step).
/// On forty seeds of the four-node machine the held fits stood 0–1.75 from theirs, but
/// seed 23's coarse start 6.4 (its network 2.3 % off in the winding's C, where the held
/// fit at the full rate, then continued from where it stopped ([`held_from_nearest`](super::grey_box)), is
/// 0.4 % off).
pub(super) const HELD_SHORT_OF_MINIMUM: f64 = 4.0;

impl ScoreTest {
    /// The test of `held`, heat leaving through `water` alone; `None` where its score
    /// cannot be taken.
    pub(super) fn of(
        rc: &ResistanceCapacitance,
        data: &IdentificationData,
        held: &Estimate,
        water: usize,
        floor: f64,
    ) -> Option<ScoreTest> {
        let score = rc.held_score(data, held, water, floor)?;
        let held_parts = held
            .network
            .as_ref()
            .map_or(0, |n| n.parts.capacitance_j_per_k.len().saturating_sub(1));
        Some(ScoreTest {
            statistic: score.statistic,
            held_parts,
            p: network::fit::chi_square_survival(score.statistic, held_parts),
            short_of_minimum: score.short_of_minimum,
        })
    }

    /// Whether the data cannot tell the held network from the free one
    /// ([`THROUGH_COOLANT_LEVEL`]).
    pub(super) fn accepts(&self) -> bool {
        self.p >= THROUGH_COOLANT_LEVEL
    }

    /// Whether the held network is kept without the free fit: the test accepts it, and
    /// the held fit stands at its own minimum ([`HELD_SHORT_OF_MINIMUM`]).
    pub(super) fn keeps_held(&self) -> bool {
        self.accepts() && self.short_of_minimum <= HELD_SHORT_OF_MINIMUM
    }

    /// The figures the decision names: S, its degrees of freedom and p.
    pub(super) fn figures(&self) -> Vec<Figure> {
        figures(
            "score test of heat through the cooling water alone, at the held fit",
            self.statistic,
            self.held_parts,
            self.p,
        )
    }

    /// What the text says of the held network it kept.
    pub(super) fn said(&self) -> String {
        let ScoreTest {
            statistic,
            held_parts,
            p,
            ..
        } = self;
        format!(
            "; heat leaves only through the cooling water: the other parts' conductances to the \
             coolant are held at zero, which fits the data as well (score test {statistic:.2} on \
             {held_parts} degrees of freedom, p = {p:.2}, at the held fit)"
        )
    }
}

/// The likelihood ratio of a held fit against the free fit whose model contains it, and by
/// how much the free fit ended above the held one where it did. The free model's minimum
/// lies at or below the held one's, so the ratio is at least 0; a negative difference says
/// the free fit stopped short of its minimum (its stopping rule ends a walk along a valley
/// the data hardly see: the four-node machine's seed 5 ended 8.67 above), and 0 is then
/// the one value both fits bound.
pub(super) fn nested_ratio(ratio: f64) -> (f64, Option<f64>) {
    if ratio < 0.0 {
        (0.0, Some(-ratio))
    } else {
        (ratio, None)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_free_fit_that_stopped_above_the_held_one_gives_a_ratio_of_zero_and_says_by_how_much() {
        assert_eq!(nested_ratio(-8.67), (0.0, Some(8.67)));
        assert_eq!(nested_ratio(2.14), (2.14, None));
        assert_eq!(nested_ratio(0.0), (0.0, None));
    }

    fn score(statistic: f64, short_of_minimum: f64) -> ScoreTest {
        ScoreTest {
            statistic,
            held_parts: 3,
            p: network::fit::chi_square_survival(statistic, 3),
            short_of_minimum,
        }
    }

    /// χ²_3's 0.95 quantile is 7.81: below it the held network is accepted, and kept
    /// without the free fit only where the held fit stands within two standard errors of
    /// its own minimum (seed 23's coarse start: 4.72 accepted, 6.4 short).
    #[test]
    fn the_score_test_keeps_the_held_network_only_where_it_accepts_it_at_its_minimum() {
        assert!(score(4.72, 0.0).keeps_held());
        assert!(score(4.72, 6.4).accepts() && !score(4.72, 6.4).keeps_held());
        assert!(!score(7.9, 0.0).accepts() && !score(7.9, 0.0).keeps_held());
        assert!(score(7.7, 3.9).keeps_held());
    }
}
