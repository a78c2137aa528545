//! Names and colours of the series: each part (state) keeps one colour in every plot —
//! its measured and model temperatures, its residual, its sensitivity responses — and
//! each input another, so a reader matches lines across plots without a legend.

use crate::paced::PacedStream;
use crate::sdk::SeriesLines;

use crate::Result;

use super::publish_err;

pub use heatrun::colour::{input, lightened, measured, part, REFERENCE};

/// Width of a measured trace (drawn wide and light, under the model).
pub const MEASURED_WIDTH: f32 = 4.0;
/// Width of a line drawn through every instant of a series (residuals, inputs, the
/// decimated quantities).
pub const LINE_WIDTH: f32 = 1.5;
/// Width of a smooth curve sent as its polyline ([`crate::curve`]: the model's
/// temperatures, the sensitivity responses). Drawn through every instant, such a curve's
/// thousands of short segments overlapped at their ends and looked about this wide at
/// [`LINE_WIDTH`]; this keeps that look with the few long segments the polyline has.
pub const CURVE_WIDTH: f32 = 2.0;

/// Logs a series' name, colour and width (static: they hold for the whole recording).
pub fn series(rec: &PacedStream, entity: &str, name: &str, rgb: [u8; 3], width: f32) -> Result<()> {
    rec.log_static(
        entity,
        &SeriesLines::new()
            .with_names([name])
            .with_colors([rgb])
            .with_widths([width]),
    )
    .map_err(publish_err)
}
