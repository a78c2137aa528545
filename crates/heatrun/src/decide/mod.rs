//! The default's decisions, in one room: what a replay chooses for the user where the
//! user did not say — the grid's sample time, the estimator, the samples the estimation
//! leaves out, the network printed beside the model — each made once, against a noise
//! model that holds the sensors' resolution ([`noise`]), and kept as a [`Decision`]: the
//! candidates, the figures compared and the verdict. The summary, the report, the HTML
//! page and the rerun recording print the decisions from these records; none of them
//! knows how a decision was reached.
//!
//! [`crate::pipeline`] orders the stages and calls each decision where its inputs are
//! ready; nothing here knows the stages after it.

pub mod estimator;
pub mod network;
pub mod noise;
pub mod sample_time;
pub mod screening;

use serde::{Deserialize, Serialize};

pub use estimator::{estimate, estimate_chosen, estimate_in, EstimatorChoice};
pub use noise::NoiseFloor;

/// One of the default's choices, as the user reads it back.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Decision {
    /// What was decided: `sample time`, `estimator`, `screen`, `network`.
    pub what: String,
    /// The candidates weighed, each with the figures it was judged by.
    pub candidates: Vec<Candidate>,
    /// The candidate taken (one of `candidates`' names).
    pub chosen: String,
    /// Why, in a sentence, with the figures that decided it.
    pub reason: String,
}

/// A candidate of a [`Decision`] and its figures.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Candidate {
    /// Its name (`oe`, `pem`, `the nearest passive network`, `10 s`).
    pub name: String,
    /// The figures it was judged by.
    pub figures: Vec<Figure>,
}

/// A named figure of a candidate.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Figure {
    /// What it is (`likelihood ratio`, `residuals' RMS`).
    pub name: String,
    /// Its value.
    pub value: f64,
    /// Its unit (`K`, `s`, `` for a pure number).
    pub unit: String,
}

impl Figure {
    /// The figure as text: `name value unit`, the value whole where it is a count and
    /// with four significant digits otherwise.
    pub fn text(&self) -> String {
        let unit = if self.unit.is_empty() {
            String::new()
        } else {
            format!(" {}", self.unit)
        };
        format!("{} {}{unit}", self.name, significant(self.value))
    }

    /// A figure `name` = `value` `unit`.
    pub fn new(name: &str, value: f64, unit: &str) -> Figure {
        Figure {
            name: name.to_owned(),
            value,
            unit: unit.to_owned(),
        }
    }
}

impl Candidate {
    /// A candidate `name` with its `figures`.
    pub fn new(name: &str, figures: Vec<Figure>) -> Candidate {
        Candidate {
            name: name.to_owned(),
            figures,
        }
    }
}

impl Decision {
    /// The decision as lines of text: `what: chosen (reason)` then a line per candidate
    /// with its figures.
    pub fn lines(&self) -> Vec<String> {
        let mut lines = vec![format!("{}: {} ({})", self.what, self.chosen, self.reason)];
        for c in &self.candidates {
            if c.figures.is_empty() {
                continue;
            }
            let figures: Vec<String> = c.figures.iter().map(Figure::text).collect();
            lines.push(format!("  {}: {}", c.name, figures.join(", ")));
        }
        lines
    }
}

/// `v` with four significant digits, in plain or scientific notation by size.
fn significant(v: f64) -> String {
    let a = v.abs();
    if v == 0.0 || !v.is_finite() || (v.fract() == 0.0 && a < 1e9) {
        format!("{v}")
    } else if (1e-3..1e5).contains(&a) {
        // The exponent of v rounded to four digits (0.00999999 is 1.000e-2, not 9.99…e-3).
        let exponent: i32 = format!("{a:.3e}")
            .split('e')
            .nth(1)
            .and_then(|e| e.parse().ok())
            .unwrap_or(0);
        let digits = (3 - exponent).clamp(0, 6) as usize;
        format!("{v:.digits$}")
    } else {
        format!("{v:.3e}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_decision_prints_its_verdict_and_each_candidates_figures() {
        let d = Decision {
            what: "estimator".into(),
            candidates: vec![
                Candidate::new("oe", vec![Figure::new("residuals' RMS", 0.002887, "K")]),
                Candidate::new("pem", vec![]),
            ],
            chosen: "oe".into(),
            reason: "rounding explains the residuals".into(),
        };
        assert_eq!(
            d.lines(),
            vec![
                "estimator: oe (rounding explains the residuals)".to_owned(),
                "  oe: residuals' RMS 0.002887 K".to_owned(),
            ]
        );
        assert_eq!(significant(23592.0), "23592");
        assert_eq!(significant(3.0), "3");
        assert_eq!(significant(0.1), "0.1000");
        assert_eq!(significant(1.5e-7), "1.500e-7");
        assert_eq!(significant(0.01 - 1e-12), "0.01000");
        assert_eq!(significant(99.996), "100.0");
    }
}

#[cfg(test)]
mod replays;
