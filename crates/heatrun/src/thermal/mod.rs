//! The thermal core below estimation and analysis: what both the estimators and the
//! network analysis build on, and neither owns. `water`: liquid water's c_p and ρ
//! (IAPWS-IF97).

pub mod water;
