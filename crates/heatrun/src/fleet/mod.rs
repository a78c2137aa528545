//! Fleets of units: what is learnt from many reports of one design at once.
//! [`compare`] lays same-design units side by side and names those that differ from the
//! fleet beyond its spread and their own uncertainty.

pub mod compare;
