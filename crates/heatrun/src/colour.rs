//! The colour of each part and each input in every view of a model: the HTML pages and
//! the rerun recording draw a part's measured and model temperatures, its residual, its
//! sensitivity responses and its autocorrelation in one colour, so that a reader who has
//! learnt it in one view finds the part by it in the other without a legend.

/// An sRGB colour.
pub type Rgb = [u8; 3];

/// Colours of the states, in model order (the generator: stator winding red, iron core
/// blue, cooling water green; a fourth part, the field winding, purple).
pub const PARTS: [Rgb; 5] = [
    [214, 39, 40],
    [31, 119, 180],
    [44, 160, 44],
    [148, 103, 189],
    [140, 86, 75],
];

/// Colours of the inputs (the heat sources), none of them a part's.
pub const INPUTS: [Rgb; 5] = [
    [255, 127, 14],
    [188, 189, 34],
    [23, 190, 207],
    [227, 119, 194],
    [127, 127, 127],
];

/// Grey, for reference lines (a confidence band, another model drawn for comparison).
pub const REFERENCE: Rgb = [128, 128, 128];

/// How far a measured trace is lightened towards white: it is drawn wide and light, under
/// the model's line in the part's full colour.
pub const MEASURED_LIGHTENING: f32 = 0.55;

/// The colour of state (part) `j`.
pub fn part(j: usize) -> Rgb {
    PARTS[j % PARTS.len()]
}

/// The colour of input `j`.
pub fn input(j: usize) -> Rgb {
    INPUTS[j % INPUTS.len()]
}

/// A colour mixed with white, channel by channel c + (255 − c)·`share`: `share` 0 keeps
/// it, 1 is white.
pub fn lightened(rgb: Rgb, share: f32) -> Rgb {
    rgb.map(|c| (c as f32 + (255.0 - c as f32) * share).round() as u8)
}

/// The colour of part `j`'s measured trace: [`part`] lightened by [`MEASURED_LIGHTENING`].
pub fn measured(j: usize) -> Rgb {
    lightened(part(j), MEASURED_LIGHTENING)
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
    fn parts_inputs_and_reference_never_share_a_colour() {
        for j in 0..PARTS.len() {
            assert_ne!(part(j), REFERENCE);
            for k in 0..INPUTS.len() {
                assert_ne!(part(j), input(k));
            }
        }
    }
}
