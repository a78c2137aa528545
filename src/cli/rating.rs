//! `heatrun rating`: its flags, and the [`Rating`] they are turned into (the library's
//! options, in its units); the insulation class and `STATE=°C` limits `predict` shares.

use std::path::PathBuf;

use clap::{Args, ValueEnum};
use heatrun::rating::{InsulationClass, RatingOptions};

use super::outputs::{distinct, NamedFile};
use super::Usage;

/// Insulation thermal class.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum ClassArg {
    /// Class 130 (B).
    #[value(name = "B")]
    B,
    /// Class 155 (F).
    #[value(name = "F")]
    F,
    /// Class 180 (H).
    #[value(name = "H")]
    H,
}

impl From<ClassArg> for InsulationClass {
    /// The library's class of the same name.
    fn from(class: ClassArg) -> InsulationClass {
        match class {
            ClassArg::B => InsulationClass::B,
            ClassArg::F => InsulationClass::F,
            ClassArg::H => InsulationClass::H,
        }
    }
}

/// Arguments of `heatrun rating`.
#[derive(Debug, Args)]
pub struct RatingArgs {
    /// The model: a report written by `heatrun replay --report`.
    #[arg(long, value_name = "REPORT.json")]
    pub model: PathBuf,
    /// Insulation class: the built-in limits (IEC 60034-1, Table 7) for the stator
    /// winding, the field winding and the core.
    #[arg(long, value_enum)]
    pub class: Option<ClassArg>,
    /// A part's limit, °C (repeatable; overrides the class's): STATE=°C.
    #[arg(long, value_name = "STATE=°C", value_parser = parse_limit)]
    pub limit: Vec<(String, f64)>,
    /// Power factor of the rating (negative: leading) [default: the nameplate's rated one].
    #[arg(long, allow_hyphen_values = true)]
    pub power_factor: Option<f64>,
    /// Line voltage, kV [default: rated].
    #[arg(long, value_name = "KV")]
    pub voltage: Option<f64>,
    /// Coolant (cooling-water inlet) temperature of the rating, °C [default: the model's test].
    #[arg(long, value_name = "°C", allow_hyphen_values = true)]
    pub coolant: Option<f64>,
    /// Overloads for the short-time ratings, % of rated current.
    #[arg(long, value_delimiter = ',', default_value = "110,120,130,140,150")]
    pub overloads: Vec<f64>,
    /// Write the rating as JSON to this file.
    #[arg(long, value_name = "OUT.json")]
    pub json: Option<PathBuf>,
    /// Also write the rating as one self-contained HTML page (limits, continuous rating,
    /// margins, overloads).
    #[arg(long, value_name = "PAGE.html")]
    pub html: Option<PathBuf>,
}

/// `STATE=°C`.
pub fn parse_limit(text: &str) -> Result<(String, f64), String> {
    let (name, value) = text
        .split_once('=')
        .ok_or_else(|| format!("`{text}` is not STATE=°C"))?;
    let value: f64 = value
        .trim()
        .parse()
        .ok()
        // Above absolute zero: a limit of −300 °C gave a rating of 0 MVA, as if it held.
        .filter(|v: &f64| v.is_finite() && *v > -273.15)
        .ok_or_else(|| format!("`{value}` is not a temperature in °C (above −273.15)"))?;
    Ok((name.trim().to_owned(), value))
}

/// The limits of `--class` and `--limit` alone, as the library takes them; `None` where
/// neither is given (a prediction then draws no limit).
pub fn limits_only(class: Option<ClassArg>, limits: Vec<(String, f64)>) -> Option<RatingOptions> {
    (class.is_some() || !limits.is_empty()).then(|| RatingOptions {
        class: class.map(InsulationClass::from),
        limits_c: limits,
        power_factor: None,
        voltage_v: None,
        coolant_c: None,
        overloads: Vec::new(),
    })
}

/// `heatrun rating` as the library takes it: kV in V, percentages as fractions.
#[derive(Debug)]
pub struct Rating {
    /// The model report.
    pub model: PathBuf,
    /// What the rating is asked for.
    pub options: RatingOptions,
    /// The rating as JSON, if asked for.
    pub json: Option<PathBuf>,
    /// The HTML page, if asked for.
    pub html: Option<PathBuf>,
}

impl TryFrom<RatingArgs> for Rating {
    type Error = Usage;

    /// The rating's options in the library's units; outputs that would replace the model
    /// or each other are refused.
    fn try_from(args: RatingArgs) -> Result<Rating, Usage> {
        let rating = Rating {
            model: args.model,
            options: RatingOptions {
                class: args.class.map(InsulationClass::from),
                limits_c: args.limit,
                power_factor: args.power_factor,
                voltage_v: args.voltage.map(|kv| kv * 1e3),
                coolant_c: args.coolant,
                overloads: args.overloads.iter().map(|p| p / 100.0).collect(),
            },
            json: args.json,
            html: args.html,
        };
        let writes: Vec<NamedFile> = [("--json", &rating.json), ("--html", &rating.html)]
            .into_iter()
            .filter_map(|(what, p)| p.as_deref().map(|p| NamedFile::new(what, p)))
            .collect();
        distinct(&[NamedFile::new("--model", &rating.model)], &writes)?;
        Ok(rating)
    }
}
