//! The identification methods by name: what a command line, a spec's `method` key and a
//! report's `method` field say, parsed and printed in one place.

use std::fmt;
use std::str::FromStr;

use serde::{Deserialize, Serialize};

/// An identification method.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Method {
    /// Ordinary least squares (eq. 7), W = I: biased by sensor noise on y.
    Ls,
    /// Weighted least squares (eqs. 3–7) with per-output weights.
    Wls,
    /// Recursive least squares with a forgetting factor.
    Rls,
    /// Iterated instrumental variables.
    Iv,
    /// Output error by Levenberg–Marquardt from the IV estimate (the default).
    Oe,
    /// Grey-box output error in the thermal network's own parameters (C, G, K), passive
    /// by construction, from the OE estimate's network.
    Rc,
    /// Prediction error: Θ with the Kalman gain of a model with process noise, the
    /// innovations' likelihood maximised from the OE estimate.
    Pem,
}

impl Method {
    /// Every method, in the order the help lists them.
    pub const EVERY: [Method; 7] = [
        Method::Oe,
        Method::Pem,
        Method::Rc,
        Method::Iv,
        Method::Rls,
        Method::Wls,
        Method::Ls,
    ];

    /// Every method that identifies Φ and Γ freely (black box), for benchmarks and tests;
    /// `rc` fits a network and has its own benchmark (`benches/network.rs`).
    pub const ALL: [Method; 6] = [
        Method::Ls,
        Method::Wls,
        Method::Rls,
        Method::Iv,
        Method::Oe,
        Method::Pem,
    ];

    /// The method's name: `ls`, `wls`, `rls`, `iv`, `oe`, `pem` or `rc`.
    pub fn name(self) -> &'static str {
        match self {
            Method::Ls => "ls",
            Method::Wls => "wls",
            Method::Rls => "rls",
            Method::Iv => "iv",
            Method::Oe => "oe",
            Method::Rc => "rc",
            Method::Pem => "pem",
        }
    }

    /// One line on what the method minimises, for reports.
    pub fn description(self) -> &'static str {
        match self {
            Method::Oe => "output error: the simulation error minimised by Levenberg–Marquardt from the IV estimate",
            Method::Pem => "prediction error: the innovations of a Kalman one-step predictor (process and sensor noise) minimised with its gain, from the OE estimate",
            Method::Rc => "grey-box output error in the thermal network's own parameters (C, G, K), passive by construction",
            Method::Iv => "iterated instrumental variables, instruments from the simulated model",
            Method::Rls => "recursive least squares with a forgetting factor",
            Method::Wls => "weighted least squares (eqs. 3–7)",
            Method::Ls => "ordinary least squares (eq. 7)",
        }
    }
}

impl fmt::Display for Method {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A name that is no method.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("`{0}` is not one of oe, pem, rc, iv, rls, wls, ls")]
pub struct UnknownMethod(pub String);

impl FromStr for Method {
    type Err = UnknownMethod;

    /// Parses a method's name, ignoring ASCII case (`OE` is `oe`).
    fn from_str(s: &str) -> Result<Method, UnknownMethod> {
        Method::EVERY
            .into_iter()
            .find(|m| m.name().eq_ignore_ascii_case(s))
            .ok_or_else(|| UnknownMethod(s.to_owned()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_name_parses_back_to_its_method() {
        for m in Method::EVERY {
            assert_eq!(m.to_string().parse::<Method>(), Ok(m));
            assert_eq!(m.name().to_uppercase().parse::<Method>(), Ok(m));
        }
        assert_eq!(
            "bj".parse::<Method>().unwrap_err().to_string(),
            "`bj` is not one of oe, pem, rc, iv, rls, wls, ls"
        );
    }

    #[test]
    fn it_serialises_as_its_name() {
        assert_eq!(serde_json::to_string(&Method::Rc).unwrap(), "\"rc\"");
        assert_eq!(
            serde_json::from_str::<Method>("\"wls\"").unwrap(),
            Method::Wls
        );
    }
}
