//! Fleets: many recordings of a utility's units, replayed apart (threads on one machine,
//! or tasks of a cluster), reduced into one table, and compared.
//!
//! [`summary`] is the one reduction: the fleet replay (`heatrun replay DIR`) and
//! `heatrun fleet summary PREFIX` (reports written by a Slurm array or a Kubernetes
//! Indexed Job) both build [`FleetRow`]s from reports and write the same
//! `fleet-summary.csv`. [`compare`] lays same-design units side by side and names those
//! that differ from the fleet beyond its spread and their own uncertainty.

pub mod compare;
pub mod summary;

pub use summary::{
    csv_header, fleet_csv, short_name, table_text, FleetError, FleetFigures, FleetRow, FleetTally,
    ReportRow, SUMMARY_FILE,
};
