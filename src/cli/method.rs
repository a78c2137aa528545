//! `--method`: parsed straight into the library's [`Method`]. The values come from
//! [`Method::EVERY`], so `--help`, the completions and the man page list every method the
//! library has; what the help says of each is the command line's wording, kept here.

use clap::builder::{PossibleValue, PossibleValuesParser, TypedValueParser};
use heatrun::estimate::Method;

/// The value parser of `--method`: a method's name as listed, in its case (`OE` is
/// refused, as clap refuses any value it does not list).
pub fn parser() -> impl TypedValueParser<Value = Method> {
    PossibleValuesParser::new(
        Method::EVERY.map(|method| PossibleValue::new(method.name()).help(method_help(method))),
    )
    // Only listed names get here, and each is a method's: the parse cannot fail, but its
    // error is passed on rather than assumed away.
    .try_map(|name| name.parse::<Method>())
}

/// What `--help` says of a method: when to choose it, in the command line's terms (its
/// flags), where the library's [`Method::description`] says what it minimises.
pub fn method_help(method: Method) -> &'static str {
    match method {
        Method::Ls => "Ordinary least squares (eq. 7); biased when the temperatures are noisy",
        Method::Wls => "Weighted least squares (eqs. 3-7) with --weights",
        Method::Rls => "Recursive least squares with --forgetting; its trajectory goes to rerun",
        Method::Iv => "Iterated instrumental variables (instruments from the simulated model)",
        Method::Oe => "Output error: minimises the simulation error by Levenberg-Marquardt from IV",
        Method::Pem => {
            "Prediction error: a Kalman one-step predictor's gain fitted with the model from oe; \
             for unmeasured heat or drift the sensors do not explain (K = 0 is oe)"
        }
        Method::Rc => {
            "Grey-box output error in the thermal network's C, G and K (passive by \
             construction, 95 % intervals on each), started from oe's network; heat inputs only"
        }
    }
}
