//! A spec's hidden states: the `[hidden]` table, and the report's `model.hidden` block.
//!
//! ```toml
//! [hidden]
//! order = 4                 # states in all (≥ the outputs where C = [I 0]); absent: chosen
//! largest = 8               # the largest order tried when it is chosen (default 8)
//! output_matrix = "free"    # "measured" (default): sensor i reads state i, C = [I 0]
//! feedthrough = true        # D estimated (an input acting within the sample); default false
//! ```
//!
//! The spec's states are then the measured outputs y = C x + D u of a model of `order`
//! states (`crate::hidden`).

use serde::{Deserialize, Serialize};

/// How the outputs read the states, as a spec names it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum OutputMatrixSpec {
    /// C = [I_p 0]: sensor i reads state i, the other states are hidden.
    #[default]
    Measured,
    /// C estimated.
    Free,
}

/// A model with hidden states: its order (or how to choose it), C and D.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HiddenSpec {
    /// States in all; `None`: chosen on the estimation data among 1 ..= `largest`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub order: Option<usize>,
    /// The largest order tried when the order is chosen.
    #[serde(default = "default_largest")]
    pub largest: usize,
    /// How the outputs read the states.
    #[serde(default)]
    pub output_matrix: OutputMatrixSpec,
    /// Whether the feedthrough D is estimated (else zero).
    #[serde(default)]
    pub feedthrough: bool,
}

fn default_largest() -> usize {
    8
}

impl HiddenSpec {
    /// `order` states, given (no order search), the measured ones read as they are
    /// (C = [I 0]) and no feedthrough: `[hidden] order = n, largest = n`.
    pub fn given(order: usize) -> HiddenSpec {
        HiddenSpec {
            order: Some(order),
            largest: order,
            output_matrix: OutputMatrixSpec::Measured,
            feedthrough: false,
        }
    }

    /// What is wrong with it, if anything: an order of 0, or a largest of 0.
    pub fn problem(&self) -> Option<String> {
        match (self.order, self.largest) {
            (Some(0), _) => Some("order = 0: a model has at least one state".into()),
            (None, 0) => Some("largest = 0: a model has at least one state".into()),
            _ => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use crate::spec::ModelDescription;

    const SPEC: &str = r#"
[[state]]
name = "T1"
[[input]]
name = "q"
expression = "Q1"
"#;

    #[test]
    fn a_hidden_table_is_read_and_round_trips_through_the_report_form() {
        let spec = format!("{SPEC}[hidden]\norder = 3\noutput_matrix = \"free\"\n");
        let model = ModelDescription::from_toml(&spec).unwrap();
        let hidden = model.hidden.unwrap();
        assert_eq!(hidden.order, Some(3));
        assert_eq!(hidden.output_matrix, super::OutputMatrixSpec::Free);
        assert!(!hidden.feedthrough);
        let json = serde_json::to_string(&model).unwrap();
        let back: ModelDescription = serde_json::from_str(&json).unwrap();
        assert_eq!(back.hidden, Some(hidden));
        // Without the table the report's model block is as before.
        let plain = ModelDescription::from_toml(SPEC).unwrap();
        assert!(!serde_json::to_string(&plain).unwrap().contains("hidden"));
    }

    #[test]
    fn an_order_of_zero_or_an_unknown_key_is_refused() {
        for bad in ["order = 0", "largest = 0", "states = 4"] {
            let spec = format!("{SPEC}[hidden]\n{bad}\n");
            assert!(ModelDescription::from_toml(&spec).is_err(), "{bad}");
        }
    }
}
