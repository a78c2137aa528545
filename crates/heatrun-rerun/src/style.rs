//! Names and colours of the series: each part (state) keeps one colour in every plot —
//! its measured and model temperatures, its residual, its sensitivity responses — and
//! each input another, so a reader matches lines across plots without a legend.

use crate::paced::PacedStream;
use crate::sdk::SeriesLines;

use crate::Result;

use super::publish_err;

/// Colours of the states, in model order (the generator: stator winding red, core blue,
/// cooling water green).
const PARTS: [[u8; 3]; 5] = [
    [214, 39, 40],
    [31, 119, 180],
    [44, 160, 44],
    [148, 103, 189],
    [140, 86, 75],
];

/// Colours of the inputs (heat sources), distinct from the parts'.
const INPUTS: [[u8; 3]; 5] = [
    [255, 127, 14],
    [188, 189, 34],
    [23, 190, 207],
    [227, 119, 194],
    [127, 127, 127],
];

/// Grey, for reference lines (a confidence band).
pub const REFERENCE: [u8; 3] = [128, 128, 128];

/// The colour of state `j`.
pub fn part(j: usize) -> [u8; 3] {
    PARTS[j % PARTS.len()]
}

/// The colour of input `j`.
pub fn input(j: usize) -> [u8; 3] {
    INPUTS[j % INPUTS.len()]
}

/// A colour mixed with white: `share` 0 keeps it, 1 is white. Measured traces are the
/// part's colour lightened, under the model's line in the full colour.
pub fn lightened(rgb: [u8; 3], share: f32) -> [u8; 3] {
    rgb.map(|c| (c as f32 + (255.0 - c as f32) * share).round() as u8)
}

/// Width of a measured trace (drawn wide and light, under the model).
pub const MEASURED_WIDTH: f32 = 4.0;
/// Width of a model trace and of other lines.
pub const LINE_WIDTH: f32 = 1.5;

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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lightening_moves_towards_white() {
        assert_eq!(lightened([214, 39, 40], 0.0), [214, 39, 40]);
        assert_eq!(lightened([214, 39, 40], 1.0), [255, 255, 255]);
        assert_eq!(lightened([0, 100, 255], 0.5), [128, 178, 255]);
    }

    #[test]
    fn parts_and_inputs_never_share_a_colour() {
        for j in 0..PARTS.len() {
            for k in 0..INPUTS.len() {
                assert_ne!(part(j), input(k));
            }
        }
    }
}
