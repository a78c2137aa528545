//! An input computed from channels: an arithmetic expression such as `0.01 * Q1 * 3.0`
//! or `3 * I^2 * R`, parsed and evaluated by the `exmex` crate.

use exmex::prelude::*;
use serde::{Deserialize, Deserializer, Serialize, Serializer};

use crate::recording::Signal;

/// A parsed expression of channels and constants (`+ - * / ^`, parentheses, and exmex's
/// functions: `sqrt`, `abs`, `exp`, `log`, `sin`, `cos`, …).
#[derive(Debug, Clone)]
pub struct InputExpression {
    text: String,
    parsed: FlatEx<f64>,
    /// The channels in the order exmex wants their values (alphabetical by name).
    channels: Vec<Signal>,
}

/// An expression serialises as its text, as written in the spec.
impl Serialize for InputExpression {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(&self.text)
    }
}

/// An expression reads back from its text, parsed again: a text that does not parse is
/// the report's error, with exmex's reason.
impl<'de> Deserialize<'de> for InputExpression {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<InputExpression, D::Error> {
        let text = String::deserialize(d)?;
        InputExpression::parse(&text).map_err(serde::de::Error::custom)
    }
}

impl InputExpression {
    /// Parses `text`; the error says what exmex found wrong.
    pub fn parse(text: &str) -> Result<InputExpression, String> {
        let parsed = FlatEx::<f64>::parse(text)
            .map_err(|e| format!("expression `{text}` cannot be parsed: {e}"))?;
        let channels = parsed
            .var_names()
            .iter()
            .map(|n| Signal::from_name(n))
            .collect();
        Ok(InputExpression {
            text: text.to_owned(),
            parsed,
            channels,
        })
    }

    /// The expression as written.
    pub fn text(&self) -> &str {
        &self.text
    }

    /// The channels it reads, in the order [`InputExpression::eval`] takes their values.
    pub fn channels(&self) -> &[Signal] {
        &self.channels
    }

    /// The value for the channels' values in the order of [`InputExpression::channels`];
    /// `None` where it is not a finite number (a division by zero, the log of a negative).
    pub fn eval(&self, values: &[f64]) -> Option<f64> {
        self.parsed.eval(values).ok().filter(|v| v.is_finite())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn evaluates_by_hand_worked_cases() {
        let e = InputExpression::parse("0.01 * Q1 * 3.0").unwrap();
        assert_eq!(e.channels(), [Signal::Free("Q1".into())]);
        assert!((e.eval(&[50.0]).unwrap() - 1.5).abs() < 1e-12);
        // Channels come alphabetically: I before R. 3 · 2² · 0.5 = 6.
        let e = InputExpression::parse("3 * I^2 * R").unwrap();
        let names: Vec<_> = e.channels().iter().map(|c| c.name().to_owned()).collect();
        assert_eq!(names, ["I", "R"]);
        assert!((e.eval(&[2.0, 0.5]).unwrap() - 6.0).abs() < 1e-12);
        // Integer-looking literals are real numbers: 1/2 is 0.5, not 0.
        let e = InputExpression::parse("1/2 * x").unwrap();
        assert!((e.eval(&[3.0]).unwrap() - 1.5).abs() < 1e-12);
        let e = InputExpression::parse("sqrt(x) + abs(y)").unwrap();
        assert!((e.eval(&[4.0, -1.0]).unwrap() - 3.0).abs() < 1e-12);
    }

    #[test]
    fn undefined_values_are_missing_not_numbers() {
        let e = InputExpression::parse("1 / x").unwrap();
        assert_eq!(e.eval(&[0.0]), None);
        assert!(InputExpression::parse("3 * (x").is_err());
    }
}
