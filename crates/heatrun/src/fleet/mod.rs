//! Fleets: many recordings of a utility's units, replayed apart (threads on one machine,
//! or tasks of a cluster) and reduced into one table.
//!
//! [`summary`] is the one reduction: the fleet replay (`heatrun replay DIR`) and
//! `heatrun fleet summary PREFIX` (reports written by a Slurm array or a Kubernetes
//! Indexed Job) both build [`FleetRow`]s from reports and write the same
//! `fleet-summary.csv`.

pub mod summary;

pub use summary::{
    csv_header, fleet_csv, short_name, table_text, FleetError, FleetFigures, FleetRow, FleetTally,
    ReportRow, SUMMARY_FILE,
};
