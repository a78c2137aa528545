//! What to do next, for the errors the user can fix from the command line: the library's
//! errors name what is wrong; the CLI edge names the flag or file that mends it.

use heatrun::Error;

/// A one-line hint for an error, where the command line can mend it.
pub fn for_error(err: &anyhow::Error) -> Option<String> {
    let e = err.downcast_ref::<Error>()?;
    let e = match e {
        Error::InRecording { error, .. } => error.as_ref(),
        other => other,
    };
    Some(match e {
        Error::NoFieldTemperature | Error::FieldScalingRise { .. } => {
            "give `field_winding_final_temp_c` in a machine file with --machine FILE.toml".into()
        }
        Error::NoFieldState => {
            "replay it without --field-state, or record the field winding's temperature or voltage"
                .into()
        }
        Error::MissingNameplateKey { .. } | Error::BadNameplateValue { .. } => {
            "give the key in a machine file with --machine FILE.toml".into()
        }
        Error::Decimate(heatrun::decimate::DecimateError::SampleTime { .. }) => {
            "give --ts a sample time between 0.001 s and 3600 s".into()
        }
        Error::Decimate(heatrun::decimate::DecimateError::SparseSpan { .. }) => {
            "`heatrun info FILE` shows each channel's span; a longer --ts shrinks the grid".into()
        }
        Error::MissingChannel { .. } => {
            "`heatrun info FILE` lists the channels; a recording of another system needs \
             --spec SPEC.toml naming its channels"
                .into()
        }
        Error::HoldOutFraction { .. } => "give --holdout a fraction such as 0.3".into(),
        Error::SplitOutside { .. } => {
            "give --split-at a time inside the recording, in seconds from its start".into()
        }
        Error::Weights { .. } => "give --weights one positive number per state".into(),
        Error::Estimation(heatrun::estimate::EstimationError::InputNotHeat { .. }) => {
            "identify it with --method oe (a black-box model takes any input)".into()
        }
        Error::BadSpec { .. } => "the README's \"Any thermal system\" shows the spec's keys".into(),
        _ => return None,
    })
}
