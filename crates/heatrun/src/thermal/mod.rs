//! The thermal core below estimation and analysis: what the estimators and the analyses
//! (model, network) both build on and neither owns.
//!
//! | module | owns |
//! |---|---|
//! | `discrete` | the discrete model x(k) = Φ x(k−1) + Γ u(k−1) (eq. 1) |
//! | `continuous` | its continuous equivalent A_c = ln(Φ)/Ts, B_c (eqs. 9, 22-23), the spectrum and time constants (eqs. 21, 24, 26) |
//! | [`matrix`] | the matrix logarithm and exponential, ZOH discretisation, eigenvectors |
//! | [`network`] | the passive network C·dθ/dt = −L·θ + K·P (Fig. 9): parts, scaling, passivity, reciprocity |
//! | `rc` | the network's own parameters (C, G, K in logarithms) and their discrete model |
//! | [`water`] | liquid water's c_p and ρ (IAPWS-IF97) |

pub(crate) mod continuous;
mod discrete;
mod error;
pub mod matrix;
pub mod network;
pub(crate) mod rc;
pub mod water;

pub use continuous::{ContinuousModel, Spectrum};
pub use discrete::DiscreteModel;
pub use error::ModelError;

/// The 0.975 quantile of the standard normal distribution: a 95 % two-sided interval is
/// the estimate ± Z95 standard errors.
pub const Z95: f64 = 1.959_963_984_540_054;
