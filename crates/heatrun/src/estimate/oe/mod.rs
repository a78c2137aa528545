//! Output error: Θ = [Φ Γ] and each segment's initial state x0 minimising the
//! simulation error J = ½ Σ_k e(k)ᵀ W e(k) of eqs. 3–4 with ŷ from eq. 8, by
//! Levenberg–Marquardt (the `levenberg-marquardt` crate), started from the iterated
//! IV estimate. The Jacobian comes from the forward sensitivities
//! ∂ŷ(k)/∂θ_ij = Φ ∂ŷ(k−1)/∂θ_ij + e_i φ_j(k−1), φ = [ŷᵀ uᵀ]ᵀ, and
//! ∂ŷ(k)/∂x0 = Φ^(k−start): exact, and one simulation's cost per parameter.
//! Sensor noise on y enters only the residual, not the regressors, so the estimate
//! is consistent where least squares is not.
//!
//! Only observed output entries enter J: with outputs stored by exception (a mask in
//! [`IdentificationData`]) the simulation runs through the instants between them and
//! is compared where a value was kept. A segment may start where outputs are unknown:
//! its x0 is estimated. Where the storage is declared (a deadband), the instants between
//! kept values are censored observations as well, and [`Estimator::estimate`] maximises
//! their likelihood too ([`super::censored`], which refines this module's fit).

pub(crate) mod censored;
mod fit;

pub use fit::*;

use super::{Estimate, Estimator, IdentificationData, Result};
use crate::estimate::Method;

impl Estimator for OutputError {
    fn method(&self) -> Method {
        Method::Oe
    }

    fn estimate(&self, data: &IdentificationData) -> Result<Estimate> {
        let start = self.start(data)?;
        let fitted = self.fit(data, &start)?;
        if censored::applies(data) {
            censored::maximise_likelihood(self, data, fitted)
        } else {
            Ok(fitted.estimate)
        }
    }
}
