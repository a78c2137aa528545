//! A plant's export as a new user brings it: written by hand in a historian's German
//! layout (`;`, decimal commas, `dd.mm.yyyy HH:MM:SS` local times in Europe/Berlin,
//! column names such as `Statorstrom [kA]`, `Temp Statorwicklung [°C]` and `KW Austritt`
//! without a unit, 10 s rows), made here from a `heatrun synth` run. `import --guess`
//! must give a map that imports and replays with only the nameplate's values and the time
//! zone filled in by hand, and the replay must give the run's own model back.

use std::collections::BTreeMap;
use std::path::Path;

use heatrun::recording::NAMEPLATE_KEYS;
use serde_json::Value;

use crate::common::{self, heatrun, heatrun_ok};
use crate::historian::samples;

const S: u64 = 1_000_000_000;

/// The export's columns: the profile quantity, the header, and the factor from the
/// synthetic recording's unit (kA, A, kV, V, °C, l/s as `heatrun synth` writes them) to the
/// header's. (A factor of 10⁻³ on kA and kV once passed here unseen, since time constants
/// do not move with the inputs' scale: the plausibility check now refuses such a current.)
const COLUMNS: [(&str, &str, f64); 9] = [
    ("armature_current", "Statorstrom [kA]", 1.0),
    ("field_current", "Erregerstrom [A]", 1.0),
    ("line_voltage", "Generatorspannung [kV]", 1.0),
    ("field_voltage", "Erregerspannung [V]", 1.0),
    ("stator_winding_temp", "Temp Statorwicklung [°C]", 1.0),
    ("core_temp", "Temp Blechpaket [°C]", 1.0),
    ("cooling_water_outlet_temp", "KW Austritt", 1.0),
    ("cooling_water_inlet_temp", "Kühlwasser Eintritt [°C]", 1.0),
    ("cooling_water_flow", "KW Durchfluss [l/s]", 1.0),
];

/// The civil date of a day count since 1970-01-01 (H. Hinnant's `civil_from_days`).
fn civil(days: i64) -> (i64, u32, u32) {
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = (doy - (153 * mp + 2) / 5 + 1) as u32;
    let m = if mp < 10 { mp + 3 } else { mp - 9 } as u32;
    (yoe + era * 400 + i64::from(m <= 2), m, d)
}

/// An instant as Berlin's summer wall clock writes it (`03.06.2019 08:00:00`): the run lies
/// within one summer day, at UTC+2.
fn berlin_summer(t_ns: u64) -> String {
    let s = (t_ns / S) as i64 + 2 * 3600;
    let (y, m, d) = civil(s.div_euclid(86_400));
    let r = s.rem_euclid(86_400);
    format!(
        "{d:02}.{m:02}.{y} {:02}:{:02}:{:02}",
        r / 3600,
        r / 60 % 60,
        r % 60
    )
}

/// The recording's `heatrun.nameplate` record.
fn nameplate(path: &Path) -> BTreeMap<String, String> {
    for record in mcap::read::LinearReader::new(&std::fs::read(path).unwrap()).unwrap() {
        if let mcap::records::Record::Metadata(m) = record.unwrap() {
            if m.name == "heatrun.nameplate" {
                return m.metadata;
            }
        }
    }
    panic!("no nameplate in {}", path.display())
}

/// The export: a row per 10 s, the columns above and an active power the profile has no
/// quantity for.
fn export(run: &Path) -> String {
    let channels = samples(run);
    let mut rows: BTreeMap<u64, Vec<String>> = BTreeMap::new();
    for (j, (quantity, _, factor)) in COLUMNS.iter().enumerate() {
        let topic = format!("/scada/{quantity}");
        for &(t, v) in &channels[&topic] {
            let row = rows
                .entry(t)
                .or_insert_with(|| vec![String::new(); COLUMNS.len() + 1]);
            row[j] = v.map_or(String::new(), |v| {
                format!("{}", v * factor).replace('.', ",")
            });
        }
    }
    let mut text = String::from("Datum/Zeit");
    for (_, header, _) in COLUMNS {
        text.push(';');
        text.push_str(header);
    }
    text.push_str(";Wirkleistung [MW]\r\n");
    for (i, (t, cells)) in rows.iter_mut().enumerate() {
        cells[COLUMNS.len()] = format!("{},{}", 80 + i % 7, i % 10);
        text.push_str(&format!("{};{}\r\n", berlin_summer(*t), cells.join(";")));
    }
    text
}

/// The replay's time constants, ascending.
fn time_constants(dir: &Path, mcap: &str) -> Vec<f64> {
    let report = format!("{mcap}.json");
    heatrun_ok(&["replay", mcap, "--report", &report, "-q"], dir);
    let r: Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join(report)).unwrap()).unwrap();
    r["time_constants_s"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect()
}

#[test]
fn a_german_export_imports_and_replays_from_its_guessed_map() {
    let dir = common::tempdir();
    let d = dir.path();
    heatrun_ok(
        &[
            "synth",
            "run.mcap",
            "--electrical-rate",
            "0.1",
            "--temperature-rate",
            "0.1",
            "--temperature-noise",
            "0.05",
            "--seed",
            "11",
        ],
        d,
    );
    std::fs::write(d.join("Export G1.csv"), export(&d.join("run.mcap"))).unwrap();

    let guessed = heatrun_ok(&["import", "--guess", "Export G1.csv"], d);
    let map = String::from_utf8(guessed.stdout).unwrap();
    eprintln!("{map}");
    for line in [
        "delimiter = \";\"",
        "decimal_comma = true",
        "pattern = \"%d.%m.%Y %H:%M:%S%.f\"   # EDIT",
        "zone = \"UTC\"   # EDIT",
        "quantity = \"armature_current\"   # EDIT: guessed from the name \"Statorstrom [kA]\"",
        "quantity = \"cooling_water_outlet_temp\"   # EDIT",
        "unit = \"degC\"   # EDIT: the header gives no unit",
        "channel = \"Kuehlwasser_Eintritt\"",
        "channel = \"Wirkleistung\"",
    ] {
        assert!(map.contains(line), "the map lacks `{line}`");
    }
    assert!(!map.contains("K_hlwasser"), "{map}");
    for (quantity, _, _) in COLUMNS {
        assert!(
            map.contains(&format!("quantity = \"{quantity}\"")),
            "{quantity} not guessed"
        );
    }
    // The nameplate's template: every key with its unit.
    for k in NAMEPLATE_KEYS {
        let line = map
            .lines()
            .find(|l| l.starts_with(&format!("# {} ", k.key)))
            .unwrap_or_else(|| panic!("{} not in the template", k.key));
        assert!(line.contains(&format!("# {}, ", k.unit)), "{line}");
    }

    // As guessed, the import runs; the replay names every nameplate key it lacks at once.
    std::fs::write(d.join("as-guessed.toml"), &map).unwrap();
    heatrun_ok(
        &[
            "import",
            "Export G1.csv",
            "--map",
            "as-guessed.toml",
            "--out",
            "as-guessed.mcap",
        ],
        d,
    );
    let refused = heatrun(&["replay", "as-guessed.mcap", "-q"], d);
    assert_eq!(refused.status.code(), Some(2));
    let message = String::from_utf8_lossy(&refused.stderr);
    for k in NAMEPLATE_KEYS.iter().filter(|k| k.required) {
        assert!(message.contains(k.key), "{} not named in {message}", k.key);
    }
    let info = heatrun_ok(&["info", "as-guessed.mcap"], d);
    let info = String::from_utf8_lossy(&info.stdout);
    assert!(
        info.contains("nameplate keys a generator replay needs") && info.contains("iron_losses_kw"),
        "{info}"
    );

    // By hand: the zone, and the nameplate's values.
    let values = nameplate(&d.join("run.mcap"));
    let mut edited = map.replace("zone = \"UTC\"", "zone = \"Europe/Berlin\"");
    edited = edited.replace("# [nameplate]", "[nameplate]");
    for k in NAMEPLATE_KEYS {
        if let Some(v) = values.get(k.key) {
            let prefix = format!("# {} ", k.key);
            let line = edited
                .lines()
                .find(|l| l.starts_with(&prefix))
                .unwrap()
                .to_owned();
            let filled = line[2..].replacen("=    #", &format!("= {v}   #"), 1);
            edited = edited.replace(&line, &filled);
        }
    }
    std::fs::write(d.join("map.toml"), &edited).unwrap();
    heatrun_ok(
        &[
            "import",
            "Export G1.csv",
            "--map",
            "map.toml",
            "--out",
            "imported.mcap",
        ],
        d,
    );

    // The local times are the run's instants.
    let original = samples(&d.join("run.mcap"));
    let imported = samples(&d.join("imported.mcap"));
    let first = |c: &BTreeMap<String, Vec<(u64, Option<f64>)>>, topic: &str| c[topic][0].0;
    let topic = "/scada/stator_winding_temp";
    let topics: Vec<&String> = imported.keys().collect();
    let stator = topics
        .iter()
        .find(|t| t.ends_with("stator_winding_temp"))
        .unwrap_or_else(|| panic!("{topics:?}"));
    assert_eq!(first(&imported, stator), first(&original, topic));
    assert_eq!(imported[*stator].len(), original[topic].len());

    // The replay finds the run's own model.
    let want = time_constants(d, "run.mcap");
    let got = time_constants(d, "imported.mcap");
    eprintln!("from the synth run {want:?}, from the export {got:?}");
    assert_eq!(got.len(), want.len());
    for (g, w) in got.iter().zip(&want) {
        assert!((g / w - 1.0).abs() < 0.005, "{got:?} against {want:?}");
    }
}

#[test]
fn the_local_times_are_written_as_berlin_reads_them() {
    // 2019-06-03T06:00:00Z, the synth run's start, is 08:00 in Berlin's summer.
    assert_eq!(berlin_summer(1_559_541_600 * S), "03.06.2019 08:00:00");
    assert_eq!(civil(0), (1970, 1, 1));
    assert_eq!(civil(19_358), (2023, 1, 1));
}
