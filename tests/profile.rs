//! The recording profile's reference page (docs/src/reference/recording-format.md) against
//! the code's own lists: the quantities with their units and whether a heat run needs them,
//! the nameplate keys (required or optional, unit), the channel metadata keys, and the
//! report's top-level keys in its JSON Schema. A quantity, key or unit added to one and not
//! the other fails here.

use std::collections::BTreeMap;

use heatrun::recording::{Quantity, CHANNEL_METADATA_KEYS, NAMEPLATE_KEYS};

use crate::common::{self, package_root};

fn page() -> String {
    std::fs::read_to_string(package_root().join("docs/src/reference/recording-format.md"))
        .expect("the profile's page")
}

/// The rows of the Markdown table whose header row starts with `| first |`: each row's
/// cells, trimmed, keyed by its first cell with the backticks taken off.
fn table(page: &str, first: &str) -> BTreeMap<String, Vec<String>> {
    let header = format!("| {first} |");
    let mut lines = page.lines().skip_while(|l| !l.starts_with(&header));
    assert!(lines.next().is_some(), "no table headed `{header}`");
    lines
        .skip(1) // the |---| row
        .take_while(|l| l.starts_with('|'))
        .map(|l| {
            let cells: Vec<String> = l
                .trim_matches('|')
                .split(" | ")
                .map(|c| c.trim().to_owned())
                .collect();
            (cells[0].trim_matches('`').to_owned(), cells[1..].to_vec())
        })
        .collect()
}

/// `` `A`, `kA` `` → [A, kA].
fn ticked(cell: &str) -> Vec<String> {
    cell.split('`')
        .skip(1)
        .step_by(2)
        .map(str::to_owned)
        .collect()
}

#[test]
fn the_page_lists_every_quantity_with_its_units() {
    let rows = table(&page(), "quantity");
    assert_eq!(rows.len(), Quantity::ALL.len(), "{rows:?}");
    for q in Quantity::ALL {
        let row = rows
            .get(q.name())
            .unwrap_or_else(|| panic!("{} not on the page", q.name()));
        let required = Quantity::REQUIRED.contains(&q);
        assert_eq!(row[0], if required { "yes" } else { "no" }, "{}", q.name());
        assert_eq!(ticked(&row[2]), q.accepted_units(), "{}", q.name());
        // The first unit listed is the one values are converted to.
        assert_eq!(ticked(&row[2])[0], q.canonical_unit(), "{}", q.name());
    }
}

#[test]
fn the_page_lists_every_nameplate_key_with_its_unit() {
    let rows = table(&page(), "key | required | unit");
    assert_eq!(rows.len(), NAMEPLATE_KEYS.len(), "{rows:?}");
    for k in NAMEPLATE_KEYS {
        let row = rows
            .get(k.key)
            .unwrap_or_else(|| panic!("{} not on the page", k.key));
        assert_eq!(row[0], if k.required { "yes" } else { "no" }, "{}", k.key);
        assert_eq!(row[1], k.unit, "{}", k.key);
    }
}

#[test]
fn the_page_lists_every_channel_metadata_key() {
    let rows = table(&page(), "key | values");
    let mut page_keys: Vec<&str> = rows.keys().map(String::as_str).collect();
    let mut code_keys = CHANNEL_METADATA_KEYS.to_vec();
    page_keys.sort_unstable();
    code_keys.sort_unstable();
    assert_eq!(page_keys, code_keys);
}

#[test]
fn the_page_lists_every_section_of_the_report() {
    let schema: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(package_root().join("schemas/report.schema.json")).unwrap(),
    )
    .unwrap();
    let rows = table(&page(), "key | what it holds");
    let listed: Vec<String> = rows
        .keys()
        .flat_map(|k| ticked(&format!("`{k}`")))
        .collect();
    let properties = schema["properties"].as_object().expect("properties");
    for key in properties.keys() {
        assert!(
            listed.contains(key),
            "the report's `{key}` is not on the page"
        );
    }
    for key in &listed {
        assert!(
            properties.contains_key(key),
            "`{key}` is on the page, not in the schema"
        );
    }
}

/// The page names no file outside the repository, as a clone has none.
#[test]
fn the_pages_name_nothing_outside_the_repository() {
    let root = package_root();
    let mut offenders = Vec::new();
    let mut stack = vec![
        root.join("docs"),
        root.join("examples"),
        root.join("scripts"),
        root.join("datasets"),
        root.join("README.md"),
    ];
    while let Some(path) = stack.pop() {
        if path.is_dir() {
            for entry in std::fs::read_dir(&path).unwrap() {
                stack.push(entry.unwrap().path());
            }
        } else if let Ok(text) = std::fs::read_to_string(&path) {
            for (i, line) in text.lines().enumerate() {
                if line.contains("../shared") || line.contains("/work/") {
                    offenders.push(format!("{}:{}: {line}", path.display(), i + 1));
                }
            }
        }
    }
    assert!(offenders.is_empty(), "{}", offenders.join("\n"));
}

/// `scripts/fetch-datasets` keeps only a file whose SHA-256 is the pinned one: a copy
/// that differs is refused and nothing is left behind, a file in place that differs is
/// refused and kept, an unknown set is a usage error. Where the DaISy files are at hand
/// (fetched once into `datasets/`), a copy of them is taken and checked.
#[test]
fn the_fetch_script_keeps_only_files_of_the_pinned_checksum() {
    let dir = common::tempdir();
    let d = dir.path();
    let script = package_root().join("scripts/fetch-datasets");
    let fetch = |args: &[&str]| {
        std::process::Command::new("bash")
            .arg(&script)
            .args(args)
            .env("HEATRUN_DATASETS", d.join("out"))
            .output()
            .unwrap()
    };
    let source = d.join("src/daisy_heating_system");
    std::fs::create_dir_all(&source).unwrap();
    std::fs::write(
        source.join("heating_system.dat"),
        "   0.00   9.000  129.320\n",
    )
    .unwrap();
    let src = d.join("src");
    let from = src.to_str().unwrap();
    let wrong = fetch(&["--from", from, "daisy_heating_system"]);
    assert_eq!(wrong.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&wrong.stderr).contains("SHA-256"));
    let out = d.join("out/daisy_heating_system");
    assert_eq!(std::fs::read_dir(&out).unwrap().count(), 0, "nothing left");
    std::fs::write(out.join("heating_system.dat"), "edited").unwrap();
    assert_eq!(
        fetch(&["--from", from, "daisy_heating_system"])
            .status
            .code(),
        Some(1)
    );
    assert_eq!(
        std::fs::read(out.join("heating_system.dat")).unwrap(),
        b"edited"
    );
    assert_eq!(fetch(&["--from", from, "nope"]).status.code(), Some(2));

    let fetched = package_root().join("datasets");
    if fetched
        .join("daisy_heating_system/heating_system.dat")
        .is_file()
    {
        std::fs::remove_file(out.join("heating_system.dat")).unwrap();
        let ok = fetch(&["--from", fetched.to_str().unwrap(), "daisy_heating_system"]);
        assert!(
            ok.status.success(),
            "{}",
            String::from_utf8_lossy(&ok.stderr)
        );
        assert_eq!(
            std::fs::read(out.join("heating_system.dat")).unwrap(),
            std::fs::read(fetched.join("daisy_heating_system/heating_system.dat")).unwrap()
        );
    }
}
