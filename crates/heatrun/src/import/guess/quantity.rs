//! The profile quantity a column's name and unit say, in English or German
//! (`Statorstrom [kA]`, `Temp Statorwicklung [°C]`, `KW Austritt`, `Field current (A)`),
//! and names made of ASCII letters (`Kühlwasser` → `Kuehlwasser`).
//!
//! A guess is words found in the name and a unit that fits: the map marks every one for
//! review. German compounds (`Kühlwasseraustritt`) are read by finding the words inside the
//! name, not only between its separators; short words that would match inside others
//! (`KW`, `in`, `out`) count only standing alone.

use crate::recording::Quantity;

/// What a column is guessed to carry.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct QuantityGuess {
    /// The quantity.
    pub quantity: Quantity,
    /// Its unit: the header's, or (where the header gives none) the quantity's canonical
    /// unit, assumed.
    pub unit: String,
    /// Whether the unit was assumed rather than read.
    pub unit_assumed: bool,
}

/// The name folded for matching: lower case, German letters written out (ä → ae, ß → ss),
/// other accented Latin letters without their accents.
pub fn fold(name: &str) -> String {
    let mut out = String::with_capacity(name.len());
    for c in name.chars() {
        match transliterate(c) {
            Some(t) => out.push_str(&t.to_lowercase()),
            None => out.extend(c.to_lowercase()),
        }
    }
    out
}

/// A non-ASCII letter in ASCII: German's as German writes them without umlauts, others
/// without their accent. `None` for a character that is ASCII or not a known letter.
pub fn transliterate(c: char) -> Option<&'static str> {
    Some(match c {
        'ä' => "ae",
        'ö' => "oe",
        'ü' => "ue",
        'Ä' => "Ae",
        'Ö' => "Oe",
        'Ü' => "Ue",
        'ß' => "ss",
        'à' | 'á' | 'â' | 'ã' | 'å' => "a",
        'À' | 'Á' | 'Â' | 'Ã' | 'Å' => "A",
        'æ' => "ae",
        'Æ' => "Ae",
        'ç' => "c",
        'Ç' => "C",
        'è' | 'é' | 'ê' | 'ë' => "e",
        'È' | 'É' | 'Ê' | 'Ë' => "E",
        'ì' | 'í' | 'î' | 'ï' => "i",
        'Ì' | 'Í' | 'Î' | 'Ï' => "I",
        'ñ' => "n",
        'Ñ' => "N",
        'ò' | 'ó' | 'ô' | 'õ' | 'ø' => "o",
        'Ò' | 'Ó' | 'Ô' | 'Õ' | 'Ø' => "O",
        'œ' => "oe",
        'Œ' => "Oe",
        'ù' | 'ú' | 'û' => "u",
        'Ù' | 'Ú' | 'Û' => "U",
        'ý' | 'ÿ' => "y",
        'Ý' => "Y",
        _ => return None,
    })
}

/// The words that say what a column is. Long words match anywhere in the folded name
/// (German compounds); short ones only as a whole word.
struct Words<'a> {
    folded: &'a str,
    tokens: Vec<&'a str>,
}

impl Words<'_> {
    fn any(&self, words: &[&str]) -> bool {
        words.iter().any(|w| {
            if w.len() <= 3 {
                self.tokens.contains(w)
            } else {
                self.folded.contains(w)
            }
        })
    }
}

const CURRENT: [&str; 3] = ["current", "strom", "amps"];
const VOLTAGE: [&str; 2] = ["voltage", "spannung"];
const FIELD: [&str; 5] = ["field", "erreger", "rotor", "excitation", "feld"];
const TEMPERATURE: [&str; 3] = ["temp", "tmp", "rtd"];
const WINDING: [&str; 3] = ["winding", "wicklung", "copper"];
const STATOR: [&str; 4] = ["stator", "armature", "staender", "anker"];
const CORE: [&str; 6] = ["core", "blechpaket", "iron", "eisen", "kern", "blech"];
const WATER: [&str; 7] = [
    "coolingwater",
    "cooling water",
    "kuehlwasser",
    "kw",
    "coolant",
    "water",
    "wasser",
];
const INLET: [&str; 7] = [
    "inlet", "eintritt", "vorlauf", "zulauf", "in", "ein", "supply",
];
const OUTLET: [&str; 8] = [
    "outlet",
    "austritt",
    "ruecklauf",
    "ablauf",
    "out",
    "aus",
    "return",
    "discharge",
];
const FLOW: [&str; 4] = ["flow", "durchfluss", "menge", "flowrate"];

/// The profile quantity a column's name (without its unit) and unit say, if they say one
/// plainly. A unit the quantity does not accept (`MW`, `%`) rules it out; without a unit,
/// a quantity of one accepted unit (the temperatures' °C) is assumed in it, and one of
/// several (A or kA) is not guessed.
pub fn guess_quantity(name: &str, unit: Option<&str>) -> Option<QuantityGuess> {
    let folded = fold(name);
    let tokens: Vec<&str> = folded
        .split(|c: char| !c.is_ascii_alphanumeric())
        .filter(|t| !t.is_empty())
        .collect();
    let w = Words {
        folded: &folded,
        tokens,
    };
    /// What the column measures, before which part says which quantity.
    #[derive(PartialEq)]
    enum Kind {
        Current,
        Voltage,
        Temperature,
        Flow,
    }
    // A unit says the kind outright; the words only where there is none.
    let kind = match unit {
        Some("A" | "kA") => Kind::Current,
        Some("V" | "kV") => Kind::Voltage,
        Some("degC") => Kind::Temperature,
        Some("l/s" | "l/min" | "m3/h") => Kind::Flow,
        Some(_) => return None,
        None if w.any(&FLOW) => Kind::Flow,
        None if w.any(&CURRENT) => Kind::Current,
        None if w.any(&VOLTAGE) => Kind::Voltage,
        None if w.any(&TEMPERATURE) || w.any(&WATER) => Kind::Temperature,
        None => return None,
    };
    let field = w.any(&FIELD);
    let quantity = match kind {
        Kind::Flow => Quantity::CoolingWaterFlow,
        Kind::Current if field => Quantity::FieldCurrent,
        Kind::Current => Quantity::ArmatureCurrent,
        Kind::Voltage if field => Quantity::FieldVoltage,
        Kind::Voltage => Quantity::LineVoltage,
        Kind::Temperature if w.any(&WATER) => match (w.any(&INLET), w.any(&OUTLET)) {
            (true, false) => Quantity::CoolingWaterInletTemp,
            (false, true) => Quantity::CoolingWaterOutletTemp,
            _ => return None,
        },
        Kind::Temperature if field && !w.any(&STATOR) && !w.any(&CORE) => {
            Quantity::FieldWindingTemp
        }
        Kind::Temperature if w.any(&CORE) => Quantity::CoreTemp,
        Kind::Temperature if w.any(&WINDING) || w.any(&STATOR) => Quantity::StatorWindingTemp,
        Kind::Temperature => return None,
    };
    match unit {
        Some(u) if quantity.accepted_units().contains(&u) => Some(QuantityGuess {
            quantity,
            unit: u.to_owned(),
            unit_assumed: false,
        }),
        Some(_) => None,
        // Without a unit, only a quantity of one unit is placed (a temperature in °C):
        // A or kA, l/s or m³/h would be a guess at the scale.
        None if quantity.accepted_units().len() > 1 => None,
        None => Some(QuantityGuess {
            quantity,
            unit: quantity.canonical_unit().to_owned(),
            unit_assumed: true,
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn q(name: &str, unit: Option<&str>) -> Option<Quantity> {
        guess_quantity(name, unit).map(|g| g.quantity)
    }

    #[test]
    fn german_and_english_names() {
        use Quantity::*;
        let cases: [(&str, Option<&str>, Option<Quantity>); 26] = [
            ("Statorstrom", Some("kA"), Some(ArmatureCurrent)),
            ("G1 Strom", Some("kA"), Some(ArmatureCurrent)),
            ("Stator current", Some("A"), Some(ArmatureCurrent)),
            ("Erregerstrom", Some("A"), Some(FieldCurrent)),
            ("Field current", Some("A"), Some(FieldCurrent)),
            ("Generatorspannung", Some("kV"), Some(LineVoltage)),
            ("Line voltage", Some("kV"), Some(LineVoltage)),
            ("Erregerspannung", Some("V"), Some(FieldVoltage)),
            ("Temp Statorwicklung", Some("degC"), Some(StatorWindingTemp)),
            ("Stator winding temperature", None, Some(StatorWindingTemp)),
            // No unit for a quantity of several: the scale is not guessed.
            ("Statorstrom", None, None),
            ("Flow", None, None),
            ("Temp Blechpaket", Some("degC"), Some(CoreTemp)),
            ("Core temp", Some("degC"), Some(CoreTemp)),
            ("KW Austritt", None, Some(CoolingWaterOutletTemp)),
            (
                "Kühlwasser Austritt",
                Some("degC"),
                Some(CoolingWaterOutletTemp),
            ),
            (
                "Kühlwassereintritt",
                Some("degC"),
                Some(CoolingWaterInletTemp),
            ),
            (
                "Cooling water inlet temp",
                Some("degC"),
                Some(CoolingWaterInletTemp),
            ),
            (
                "Cooling water outlet",
                Some("degC"),
                Some(CoolingWaterOutletTemp),
            ),
            ("KW Durchfluss", Some("l/s"), Some(CoolingWaterFlow)),
            ("Cooling water flow", Some("m3/h"), Some(CoolingWaterFlow)),
            ("Temp Erregerwicklung", Some("degC"), Some(FieldWindingTemp)),
            ("Rotor winding temp", None, Some(FieldWindingTemp)),
            // A unit that no quantity of the name accepts, or a name that says nothing.
            ("Wirkleistung", Some("MW"), None),
            ("Statorstrom", Some("MW"), None),
            ("Kühlwasser", Some("degC"), None),
        ];
        for (name, unit, want) in cases {
            assert_eq!(q(name, unit), want, "{name} [{unit:?}]");
        }
        // The short words stand alone: `in` inside `Wicklung`, `kw` inside a word are no
        // inlet or cooling water.
        assert_eq!(
            q("Temp Statorwicklung Nut 3", None),
            Some(StatorWindingTemp)
        );
        assert_eq!(q("Ankerstrom", Some("A")), Some(ArmatureCurrent));
        // The unit says the kind before the words: a phase letter is no voltage.
        assert_eq!(q("Temp Wicklung U", Some("degC")), Some(StatorWindingTemp));
    }

    #[test]
    fn an_assumed_unit_is_said() {
        let g = guess_quantity("KW Austritt", None).unwrap();
        assert_eq!((g.unit.as_str(), g.unit_assumed), ("degC", true));
        let g = guess_quantity("Statorstrom", Some("kA")).unwrap();
        assert_eq!((g.unit.as_str(), g.unit_assumed), ("kA", false));
    }

    #[test]
    fn letters_are_written_out() {
        assert_eq!(fold("Kühlwasser Größe"), "kuehlwasser groesse");
        assert_eq!(fold("Température"), "temperature");
    }
}
