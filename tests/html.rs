//! The HTML report (`replay --html`): the page is parsed with an HTML parser (`tl`) and
//! checked for its sections, its figures (each an inline `<svg>` with drawn content), the
//! shape of its tables and their numbers against the JSON report, and that it refers to
//! nothing outside itself — for the fixture, a recursive estimate with a hold-out, a
//! spec model of two states and two inputs (TCLab), and a fleet; and the pages of
//! `predict --html`, `rating --html` and `monitor --html`.

use std::path::Path;

use serde_json::Value;

use crate::common::{self, heatrun, package_root};

/// The parsed page's facts the tests look at.
struct Page {
    html: String,
}

/// A table of the page: its caption and its rows of cells (header row first).
#[derive(Debug)]
struct ParsedTable {
    caption: String,
    rows: Vec<Vec<String>>,
}

impl Page {
    fn read(path: &Path) -> Page {
        Page {
            html: std::fs::read_to_string(path).expect("the page is written"),
        }
    }

    fn dom(&self) -> tl::VDom<'_> {
        tl::parse(&self.html, tl::ParserOptions::default()).expect("the page parses")
    }

    /// Every element as (tag name, attributes).
    fn elements(&self) -> Vec<(String, Vec<(String, String)>)> {
        let dom = self.dom();
        dom.nodes()
            .iter()
            .filter_map(|n| n.as_tag())
            .map(|t| {
                let attributes = t
                    .attributes()
                    .iter()
                    .map(|(k, v)| {
                        (
                            k.to_lowercase(),
                            v.map(|v| v.into_owned()).unwrap_or_default(),
                        )
                    })
                    .collect();
                (t.name().as_utf8_str().to_lowercase(), attributes)
            })
            .collect()
    }

    /// The `id`s of the `<section>`s, in order.
    fn section_ids(&self) -> Vec<String> {
        self.elements()
            .into_iter()
            .filter(|(name, _)| name == "section")
            .filter_map(|(_, a)| a.into_iter().find(|(k, _)| k == "id").map(|(_, v)| v))
            .collect()
    }

    /// Per `<figure>`: the number of `<svg>` elements in it and of drawing elements
    /// (polylines, paths, lines, rectangles, text) in those.
    fn figures(&self) -> Vec<(usize, usize)> {
        let dom = self.dom();
        let parser = dom.parser();
        let drawing = [
            "polyline", "path", "line", "rect", "text", "circle", "polygon",
        ];
        dom.query_selector("figure")
            .expect("a selector")
            .filter_map(|h| h.get(parser).and_then(|n| n.as_tag()))
            .map(|figure| {
                let svgs = figure
                    .query_selector(parser, "svg")
                    .expect("a selector")
                    .count();
                let marks: usize = drawing
                    .iter()
                    .map(|d| {
                        figure
                            .query_selector(parser, d)
                            .expect("a selector")
                            .count()
                    })
                    .sum();
                (svgs, marks)
            })
            .collect()
    }

    /// Per `<figure>` of the section `id`: the stroke colours its drawing uses, as
    /// plotters writes them (`#RRGGBB`).
    fn figure_strokes(&self, id: &str) -> Vec<std::collections::BTreeSet<String>> {
        let start = self
            .html
            .find(&format!("<section id=\"{id}\""))
            .unwrap_or_else(|| panic!("no section {id}"));
        let section = &self.html[start..];
        let section = &section[..section.find("</section>").expect("the section ends")];
        section
            .split("<figure")
            .skip(1)
            .map(|figure| {
                figure
                    .split("stroke=\"")
                    .skip(1)
                    .filter_map(|rest| rest.split('"').next())
                    .filter(|c| c.starts_with('#'))
                    .map(str::to_owned)
                    .collect()
            })
            .collect()
    }

    fn tables(&self) -> Vec<ParsedTable> {
        let dom = self.dom();
        let parser = dom.parser();
        let text = |h: tl::NodeHandle| {
            h.get(parser)
                .map(|n| n.inner_text(parser).trim().to_owned())
                .unwrap_or_default()
        };
        dom.query_selector("table")
            .expect("a selector")
            .filter_map(|h| h.get(parser).and_then(|n| n.as_tag()))
            .map(|table| {
                let caption = table
                    .query_selector(parser, "caption")
                    .expect("a selector")
                    .next()
                    .map(text)
                    .unwrap_or_default();
                let rows = table
                    .query_selector(parser, "tr")
                    .expect("a selector")
                    .filter_map(|h| h.get(parser).and_then(|n| n.as_tag()))
                    .map(|tr| {
                        tr.children()
                            .top()
                            .iter()
                            .filter(|c| {
                                c.get(parser).and_then(|n| n.as_tag()).is_some_and(|t| {
                                    matches!(t.name().as_utf8_str().as_ref(), "th" | "td")
                                })
                            })
                            .map(|c| text(*c))
                            .collect()
                    })
                    .collect();
                ParsedTable { caption, rows }
            })
            .collect()
    }

    fn table(&self, caption_start: &str) -> ParsedTable {
        let mut found: Vec<ParsedTable> = self
            .tables()
            .into_iter()
            .filter(|t| t.caption.contains(caption_start))
            .collect();
        assert_eq!(found.len(), 1, "one table captioned {caption_start:?}");
        found.remove(0)
    }
}

/// Asserts the page refers to nothing outside itself: no `src`, no `<link>`, `<script>`,
/// `<img>`, `<iframe>`, `<object>` or `<embed>`, links only to its own anchors, and no
/// address in it but the SVG namespace names.
fn assert_self_contained(page: &Page) {
    let elements = page.elements();
    for (name, attributes) in &elements {
        assert!(
            !matches!(
                name.as_str(),
                "link" | "script" | "img" | "iframe" | "object" | "embed" | "base"
            ),
            "a <{name}> element"
        );
        for (key, value) in attributes {
            assert_ne!(key, "src", "<{name} src={value:?}>");
            if key == "href" || key == "xlink:href" || key == "action" {
                assert!(
                    value.starts_with('#'),
                    "<{name} {key}={value:?}> leaves the page"
                );
            }
        }
    }
    let anchors: Vec<&str> = elements
        .iter()
        .flat_map(|(_, a)| a.iter())
        .filter(|(k, _)| k == "href")
        .map(|(_, v)| v.trim_start_matches('#'))
        .collect();
    let ids = page.section_ids();
    for a in &anchors {
        assert!(
            ids.iter().any(|id| id == a),
            "a link to #{a}, which is not on the page"
        );
    }
    let html = page.html.to_lowercase();
    for needle in ["url(", "@import"] {
        assert!(
            !html.contains(needle),
            "the page's CSS fetches something: {needle}"
        );
    }
    let outside = html
        .match_indices("http")
        .filter(|(i, _)| !html[..*i].ends_with("xmlns=\""))
        .count();
    assert_eq!(outside, 0, "an address other than a namespace name");
}

/// Asserts every figure is one inline `<svg>` with drawn content.
fn assert_figures_drawn(page: &Page, expected: usize) {
    let figures = page.figures();
    assert_eq!(figures.len(), expected, "figures: {figures:?}");
    for (i, (svgs, marks)) in figures.iter().enumerate() {
        assert_eq!(*svgs, 1, "figure {} holds {svgs} <svg>", i + 1);
        assert!(*marks >= 10, "figure {} draws only {marks} marks", i + 1);
    }
}

fn numbers(v: &Value) -> Vec<f64> {
    v.as_array()
        .expect("an array")
        .iter()
        .map(|x| x.as_f64().expect("a number"))
        .collect()
}

fn run(args: &[&str], dir: &Path) {
    let out = heatrun(args, dir);
    assert!(
        out.status.success(),
        "heatrun {args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// The fixture's page: every section, ten figures, the tables' shapes and numbers.
#[test]
fn the_fixtures_page_has_every_section_figure_and_table() {
    let root = package_root();
    let dir = common::tempdir();
    let fixture = root.join("fixtures/paper_heat_run.mcap");
    run(
        &[
            "replay",
            fixture.to_str().unwrap(),
            "--rrd",
            "run.rrd",
            "--report",
            "report.json",
            "--html",
            "report.html",
            "--quiet",
        ],
        dir.path(),
    );
    let page = Page::read(&dir.path().join("report.html"));
    let report: Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("report.json")).unwrap())
            .unwrap();
    // The fixture records the cooling-water flow: the calorimetric balance is always there.
    assert!(
        report["calorimetry"].is_object(),
        "{}",
        report["calorimetry"]
    );
    assert_eq!(
        page.section_ids(),
        [
            "recording",
            "inputs",
            "temperatures",
            "model",
            "time-constants",
            "fit",
            "steady-state",
            "residuals",
            "network",
            "calorimetry",
            "decisions",
            "estimator",
        ]
    );
    // The default's decisions: a table per decision of the report, its verdict in the
    // caption and a row per candidate.
    let decisions = report["decisions"].as_array().expect("the default decided");
    assert!(decisions.len() >= 3, "{decisions:?}");
    for d in decisions {
        let caption = format!(
            "{}: {}",
            d["what"].as_str().unwrap(),
            d["chosen"].as_str().unwrap()
        );
        let table = page.table(&caption);
        assert_eq!(
            table.rows.len(),
            1 + d["candidates"].as_array().unwrap().len()
        );
    }
    // Inputs, three temperatures, three sensitivity responses, the autocorrelation, the
    // network and the calorimetric balance.
    assert_figures_drawn(&page, 10);
    assert_self_contained(&page);

    let square = |t: &ParsedTable| (t.rows.len(), t.rows.iter().map(Vec::len).max().unwrap());
    assert_eq!(square(&page.table("Φ (eq. 19)")), (4, 4));
    assert_eq!(square(&page.table("Γ (eq. 20)")), (4, 4));
    assert_eq!(square(&page.table("A_c (eq. 22)")), (4, 4));
    assert_eq!(square(&page.table("B_c (eq. 23)")), (4, 4));
    assert_eq!(square(&page.table("Sensitivity norms")), (4, 4));
    assert_eq!(square(&page.table("Fit per part")), (6, 4));

    // The time constants and the fit on the page are the report's, to their printed digits.
    let constants = page.table("Time constants T_i");
    assert_eq!(constants.rows.len(), 4);
    for (row, t) in constants.rows[1..]
        .iter()
        .zip(numbers(&report["time_constants_s"]))
    {
        let shown: f64 = row[1].parse().unwrap();
        assert!((shown - t).abs() <= 0.005 + 1e-9, "{shown} against {t}");
    }
    assert_eq!(constants.rows[2][4], "stator winding (copper)");
    let fit = page.table("Fit per part");
    let nrmse = fit.rows.iter().find(|r| r[0].starts_with("NRMSE")).unwrap();
    for (cell, v) in nrmse[1..]
        .iter()
        .zip(numbers(&report["fit"]["nrmse_fit_percent"]))
    {
        assert_eq!(*cell, format!("{v:.2}"));
    }
    let steady = page.table("Steady state");
    let measured = steady
        .rows
        .iter()
        .find(|r| r[0].starts_with("measured final temperature"))
        .unwrap();
    for (cell, v) in measured[1..].iter().zip(numbers(
        &report["steady_state"]["measured_final_temperature_c"],
    )) {
        assert_eq!(*cell, format!("{v:.3}"));
    }
    // Each part keeps the rerun recording's colour (`heatrun::colour`): a temperature
    // figure draws the measured trace lightened and the model in the part's colour, and
    // every sensitivity figure draws each part's response in that part's colour.
    let hex = |c: heatrun::colour::Rgb| format!("#{:02X}{:02X}{:02X}", c[0], c[1], c[2]);
    let temperatures = page.figure_strokes("temperatures");
    assert_eq!(temperatures.len(), 3);
    for (j, strokes) in temperatures.iter().enumerate() {
        for c in [heatrun::colour::measured(j), heatrun::colour::part(j)] {
            assert!(strokes.contains(&hex(c)), "figure {j}: {strokes:?}");
        }
    }
    // The network's nodes too (the paper's Fig. 9), outlined in their parts' colours.
    let network = page.figure_strokes("network");
    for j in 0..3 {
        assert!(
            network
                .iter()
                .any(|f| f.contains(&hex(heatrun::colour::part(j)))),
            "{network:?}"
        );
    }
    let sensitivities = page.figure_strokes("time-constants");
    assert_eq!(sensitivities.len(), 3);
    for strokes in &sensitivities {
        for j in 0..3 {
            assert!(
                strokes.contains(&hex(heatrun::colour::part(j))),
                "{strokes:?}"
            );
        }
    }
    // The recording's metadata and the version.
    assert!(page.html.contains("synthetic-seed-1"));
    let version = report["heatrun_version"].as_str().unwrap();
    let settings = page.table("Estimator and settings");
    assert!(settings
        .rows
        .iter()
        .any(|r| r[0] == "heatrun version" && r[1] == version));
    // No leftover temporary file beside the page.
    let leftovers: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".partial"))
        .collect();
    assert!(leftovers.is_empty(), "{leftovers:?}");
}

/// A recursive estimate shows its convergence; a hold-out its validation table.
#[test]
fn a_recursive_estimate_with_a_hold_out_shows_convergence_and_validation() {
    let root = package_root();
    let dir = common::tempdir();
    let fixture = root.join("fixtures/paper_heat_run.mcap");
    run(
        &[
            "replay",
            fixture.to_str().unwrap(),
            "--method",
            "rls",
            "--holdout",
            "0.3",
            "--rrd",
            "run.rrd",
            "--html",
            "rls.html",
            "--quiet",
        ],
        dir.path(),
    );
    let page = Page::read(&dir.path().join("rls.html"));
    let ids = page.section_ids();
    for id in ["recursive", "validation"] {
        assert!(ids.iter().any(|i| i == id), "no section {id} in {ids:?}");
    }
    let figures = page.figures();
    assert!(figures
        .iter()
        .all(|&(svgs, marks)| svgs == 1 && marks >= 10));
    let validation = page.table("Fit on the validation data");
    assert_eq!(validation.rows[0].len(), 4);
    let settings = page.table("Estimator and settings");
    assert!(settings
        .rows
        .iter()
        .any(|r| r[0] == "forgetting factor λ" && r[1].parse::<f64>() == Ok(1.0)));
    assert_self_contained(&page);
}

/// A spec model of two states and two inputs gets its own names, 2 × 2 matrices and two
/// temperature and sensitivity figures.
#[test]
fn a_spec_model_of_two_states_gets_its_own_page() {
    let root = package_root();
    let dir = common::tempdir();
    let mcap = dir.path().join("tclab.mcap");
    run(
        &[
            "import",
            root.join("datasets/tclab_mimo_heaters/tclab_mimo_data.csv")
                .to_str()
                .unwrap(),
            "--map",
            root.join("examples/tclab_mimo_heaters/map.toml")
                .to_str()
                .unwrap(),
            "--out",
            mcap.to_str().unwrap(),
        ],
        dir.path(),
    );
    let spec = root.join("examples/tclab_mimo_heaters/spec.toml");
    run(
        &[
            "replay",
            mcap.to_str().unwrap(),
            "--spec",
            spec.to_str().unwrap(),
            "--rrd",
            "tclab.rrd",
            "--report",
            "tclab.json",
            "--html",
            "--quiet",
        ],
        dir.path(),
    );
    // A bare --html writes <stem>.html here.
    let page = Page::read(&dir.path().join("tclab.html"));
    assert!(page.html.contains("<title>TCLab MIMO heaters (tclab.mcap)"));
    let square = |t: &ParsedTable| (t.rows.len(), t.rows.iter().map(Vec::len).max().unwrap());
    assert_eq!(square(&page.table("Φ (eq. 19)")), (3, 3));
    assert_eq!(square(&page.table("B_c (eq. 23)")), (3, 3));
    let gamma = page.table("Γ (eq. 20)");
    assert_eq!(gamma.rows[0][1..], ["heater 1 power", "heater 2 power"]);
    assert_eq!(gamma.rows[1][0], "heater 1");
    // Inputs, two temperatures, two sensitivity responses, autocorrelation, and the network
    // diagram: with heater 1's dead time (the example spec's delay_s) TCLab's model has a
    // network, though not a passive one (negative loss shares; the page says so).
    assert_figures_drawn(&page, 7);
    assert_self_contained(&page);

    // Its prediction's page: the schedule by the channels the spec reads, its inputs (not
    // the generator's losses), the two states, no limits.
    std::fs::write(
        dir.path().join("heaters.csv"),
        "time_s,Q1,Q2\n0,50,0\n600,50,80\n1200,0,0\n1800,0,0\n",
    )
    .unwrap();
    run(
        &[
            "predict",
            "--model",
            "tclab.json",
            "--load",
            "heaters.csv",
            "--out",
            "p.csv",
            "--html",
            "p.html",
            "--quiet",
        ],
        dir.path(),
    );
    let page = Page::read(&dir.path().join("p.html"));
    assert!(page
        .html
        .contains("<title>TCLab MIMO heaters: predicted temperatures"));
    assert_figures_drawn(&page, 2);
    assert_self_contained(&page);
    let schedule = page.table("channels, as given");
    assert_eq!(schedule.rows[0], ["from s", "Q1", "Q2"]);
    assert_eq!(schedule.rows[2], ["600", "50.00", "80.00"]);
    assert!(page.html.contains("<h2>2. Inputs</h2>"));
    let peaks = page.table("peak temperature");
    assert_eq!(peaks.rows.len(), 1 + 2);
    assert_eq!(peaks.rows[1][4], "–", "no limit given");
}

/// In fleet mode a bare --html writes one page beside each report; a named page is refused.
#[test]
fn a_fleet_writes_one_page_per_recording() {
    let root = package_root();
    let dir = common::tempdir();
    let runs = dir.path().join("runs");
    std::fs::create_dir(&runs).unwrap();
    for name in ["unit1.mcap", "unit2.mcap"] {
        std::fs::copy(root.join("fixtures/paper_heat_run.mcap"), runs.join(name)).unwrap();
    }
    run(
        &[
            "replay",
            "runs",
            "--out-dir",
            "out",
            "--jobs",
            "2",
            "--html",
        ],
        dir.path(),
    );
    for stem in ["unit1", "unit2"] {
        let page = Page::read(&dir.path().join(format!("out/{stem}.report.html")));
        assert!(page.html.contains(&format!("{stem}.mcap")));
        assert_self_contained(&page);
    }
    let refused = heatrun(
        &["replay", "runs", "--out-dir", "out2", "--html", "one.html"],
        dir.path(),
    );
    assert_eq!(refused.status.code(), Some(2));
    assert!(!dir.path().join("one.html").exists());
    // A page path that names a recording is the option taking the recording by mistake.
    let mistaken = heatrun(&["replay", "--html", "runs/unit1.mcap"], dir.path());
    assert_eq!(mistaken.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&mistaken.stderr).contains("--html=PAGE.html"));
}

/// The fixture's model as a report, and the day of docs/src/guide/predict-and-rating.md (60 % load, rated, a 115 %
/// hour), in a fresh folder.
fn fixture_model_and_day() -> tempfile::TempDir {
    let dir = common::tempdir();
    let fixture = package_root().join("fixtures/paper_heat_run.mcap");
    run(
        &[
            "replay",
            fixture.to_str().unwrap(),
            "--rrd",
            "run.rrd",
            "--report",
            "model.json",
            "--quiet",
        ],
        dir.path(),
    );
    std::fs::write(
        dir.path().join("day.csv"),
        "time_s,apparent_power_mva,power_factor\n0,60,0.9\n21600,100,0.9\n43200,115,0.9\n\
         46800,80,0.9\n86400,80,0.9\n",
    )
    .unwrap();
    dir
}

/// A cell of a parsed table as a number.
fn cell(t: &ParsedTable, row: usize, column: usize) -> f64 {
    t.rows[row][column]
        .parse()
        .unwrap_or_else(|_| panic!("{:?} is not a number", t.rows[row][column]))
}

/// `predict --html`: schedule, losses, temperatures against the class's limits, peaks
/// (the CSV's own maxima), the model; one figure of losses and one of temperatures.
#[test]
fn the_prediction_page_shows_the_schedule_temperatures_limits_and_peaks() {
    let dir = fixture_model_and_day();
    run(
        &[
            "predict",
            "--model",
            "model.json",
            "--load",
            "day.csv",
            "--out",
            "pred.csv",
            "--html",
            "pred.html",
            "--class",
            "F",
            "--quiet",
        ],
        dir.path(),
    );
    let page = Page::read(&dir.path().join("pred.html"));
    assert_eq!(
        page.section_ids(),
        ["schedule", "losses", "temperatures", "peaks", "model"]
    );
    assert_figures_drawn(&page, 2);
    assert_self_contained(&page);
    assert_eq!(page.table("operating points").rows.len(), 1 + 5);
    // The peaks are the CSV's maxima; the limits class F's (IEC 60034-1: 40 °C + 110 K
    // for the stator winding and core, + 105 K for the field winding by resistance).
    let csv = std::fs::read_to_string(dir.path().join("pred.csv")).unwrap();
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    let peaks = page.table("peak temperature");
    assert_eq!(
        peaks.rows.len(),
        1 + 4,
        "three states and the derived field winding"
    );
    for (row, column) in [(1, "stator_winding_temp_c"), (4, "field_winding_temp_c")] {
        let j = header.iter().position(|h| *h == column).unwrap();
        let max = rows.iter().map(|r| r[j]).fold(f64::NEG_INFINITY, f64::max);
        assert!(
            (cell(&peaks, row, 2) - max).abs() <= 0.005 + 1e-6,
            "{column}"
        );
    }
    assert_eq!(cell(&peaks, 1, 4), 150.0);
    assert_eq!(cell(&peaks, 4, 4), 145.0);
    assert_eq!(peaks.rows[3][4], "–", "the cooling water has no limit");
    assert!((cell(&peaks, 1, 5) - (150.0 - cell(&peaks, 1, 2))).abs() < 0.011);
    // The limit is drawn: a dashed line named after its class in the temperatures' figure.
    assert!(page.html.contains("limit (class F)"));
}

/// `rating --html`: limits with their source, the continuous rating as the JSON has it,
/// margins, the overload table and its curve.
#[test]
fn the_rating_page_shows_limits_continuous_rating_and_overloads() {
    let dir = fixture_model_and_day();
    run(
        &[
            "rating",
            "--model",
            "model.json",
            "--class",
            "F",
            "--json",
            "rating.json",
            "--html",
            "rating.html",
        ],
        dir.path(),
    );
    // The table on stdout, its warnings on stderr (as predict and monitor print theirs).
    let printed = heatrun(
        &["rating", "--model", "model.json", "--class", "F"],
        dir.path(),
    );
    let (stdout, stderr) = (
        String::from_utf8_lossy(&printed.stdout),
        String::from_utf8_lossy(&printed.stderr),
    );
    assert!(
        stdout.contains("largest continuous") && !stdout.contains("warning"),
        "{stdout}"
    );
    assert!(
        stderr.lines().all(|l| l.starts_with("warning: ")),
        "{stderr}"
    );
    let page = Page::read(&dir.path().join("rating.html"));
    let rating: Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("rating.json")).unwrap())
            .unwrap();
    assert_eq!(
        stderr.lines().count(),
        rating["warnings"].as_array().map_or(0, Vec::len),
        "{stderr}"
    );
    assert_eq!(page.section_ids(), ["limits", "continuous", "overloads"]);
    assert_figures_drawn(&page, 1);
    assert_self_contained(&page);
    assert!(page.html.contains("IEC 60034-1:2017, Table 7"));
    let limits = page.table("temperature limit of each part");
    assert_eq!(
        limits.rows.len(),
        1 + rating["limits"].as_array().unwrap().len()
    );
    let continuous = page.table("Steady temperatures");
    for (i, t) in numbers(&rating["temperatures_at_max_c"]).iter().enumerate() {
        assert_eq!(continuous.rows[1 + i][2], format!("{t:.2}"));
    }
    for (i, m) in numbers(&rating["margins_at_rated_k"]).iter().enumerate() {
        assert_eq!(continuous.rows[1 + i][4], format!("{m:.2}"));
    }
    let mva = rating["max_continuous_apparent_power_mva"]
        .as_f64()
        .unwrap();
    assert!(page.html.contains(&format!("{mva:.2} MVA")));
    let overloads = page.table("Time from the rated steady state");
    assert_eq!(overloads.rows.len(), 1 + 5);
    for (row, o) in overloads.rows[1..]
        .iter()
        .zip(rating["overloads"].as_array().unwrap())
    {
        let shown = match o["time_to_limit_s"].as_f64() {
            Some(t) => format!("{t:.0}"),
            None => "none".into(),
        };
        assert_eq!(row[1], shown);
    }
}

/// Synthesises `name` of the RC machine (PT100-like noise) for `monitor`, 7200 s long.
fn synth_rc(dir: &Path, name: &str, extra: &[&str]) {
    let mut args = vec![
        "synth",
        name,
        "--machine",
        "rc-unit",
        "--temperature-noise",
        "0.05",
        "--resolution",
        "0.01",
        "--electrical-noise",
        "0.0005",
        "--duration",
        "7200",
    ];
    args.extend_from_slice(extra);
    run(&args, dir);
}

/// The number of alarm stretches shaded per figure (rectangles in the alarm colour).
fn alarm_shading_per_figure(page: &Page) -> Vec<usize> {
    page.html
        .split("<figure")
        .skip(1)
        .map(|f| {
            let f = &f[..f.find("</figure>").unwrap_or(f.len())];
            f.matches("fill=\"#D62728\" stroke=\"none\"").count()
        })
        .collect()
}

/// `monitor --html`: a fouled cooler's page (written although the alarms exit 4) has the
/// verdict, one figure per part with the alarm stretches shaded on the alarmed parts,
/// the alarm and residual tables as the JSON has them, the band rule; a healthy
/// recording's page says so and shades nothing.
#[test]
fn the_monitoring_page_shows_parts_alarms_residuals_and_the_band() {
    let dir = common::tempdir();
    let d = dir.path();
    synth_rc(d, "model.mcap", &["--seed", "1"]);
    run(
        &[
            "replay",
            "model.mcap",
            "--report",
            "model.json",
            "--holdout",
            "0.3",
            "-q",
        ],
        d,
    );
    synth_rc(
        d,
        "fault.mcap",
        &[
            "--seed",
            "2",
            "--fault-at",
            "1800",
            "--fault-conductance-drop",
            "0.5",
        ],
    );
    let out = heatrun(
        &[
            "monitor",
            "--model",
            "model.json",
            "fault.mcap",
            "--json",
            "fault.json",
            "--html",
            "fault.html",
            "-q",
        ],
        d,
    );
    assert_eq!(
        out.status.code(),
        Some(4),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let doc: Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("fault.json")).unwrap()).unwrap();
    let alarms = doc["alarms"].as_array().unwrap();
    let parts = doc["parts"].as_array().unwrap();
    assert!(!alarms.is_empty());
    let page = Page::read(&d.join("fault.html"));
    assert_eq!(
        page.section_ids(),
        [
            "verdict",
            "parts",
            "alarms",
            "residuals",
            "band",
            "warnings"
        ]
    );
    assert_figures_drawn(&page, parts.len());
    assert_self_contained(&page);
    let verdict = match alarms.len() {
        1 => "1 alarm".to_owned(),
        n => format!("{n} alarms"),
    };
    assert!(page.html.contains(&format!("<dd>{verdict}</dd>")));
    // Each alarmed part's figure shades its stretches in both panels; the others none.
    let shading = alarm_shading_per_figure(&page);
    for (j, p) in parts.iter().enumerate() {
        let stretches = alarms.iter().filter(|a| a["state"] == p["state"]).count();
        // Two panels, and the legend's swatch once per panel.
        let expected = if stretches == 0 {
            0
        } else {
            2 * (stretches + 1)
        };
        assert_eq!(shading[j], expected, "figure of {}", p["state"]);
    }
    let table = page.table("The alarms in the order raised");
    assert_eq!(table.rows.len(), 1 + alarms.len());
    for (row, a) in table.rows[1..].iter().zip(alarms) {
        assert_eq!(row[0], a["part"].as_str().unwrap());
        assert_eq!(row[1], format!("{:.0}", a["start_s"].as_f64().unwrap()));
        let end = match a["end_s"].as_f64() {
            Some(t) => format!("{t:.0}"),
            None => "still outside at the end".into(),
        };
        assert_eq!(row[2], end);
        assert_eq!(row[3], format!("{:.0}", a["raised_s"].as_f64().unwrap()));
        assert_eq!(
            row[4],
            format!("{:+.2}", a["peak_deviation_k"].as_f64().unwrap())
        );
    }
    let residuals = page.table("residual θ − θ̂ over the recording");
    assert_eq!(residuals.rows.len(), 1 + parts.len());
    for (row, p) in residuals.rows[1..].iter().zip(parts) {
        assert_eq!(row[0], p["part"].as_str().unwrap());
        assert_eq!(row[1], format!("{:.2}", p["band_k"].as_f64().unwrap()));
        assert_eq!(row[4], format!("{:.3}", p["rms_k"].as_f64().unwrap()));
        let outside = p["outside_fraction"].as_f64().unwrap() * 100.0;
        assert_eq!(row[7], format!("{outside:.1}"));
    }
    let band = page.table("and the band set from it");
    assert_eq!(band.rows.len(), 1 + parts.len());
    // The default band: from the model's prediction variance at each instant.
    assert!(page.html.contains("b(k) = 4 × √(var θ̂(k) + σ²)"));
    // A healthy recording: exit 0, the page says so, nothing shaded, no alarm table.
    synth_rc(d, "healthy.mcap", &["--seed", "3"]);
    run(
        &[
            "monitor",
            "--model",
            "model.json",
            "healthy.mcap",
            "--html",
            "healthy.html",
            "-q",
        ],
        d,
    );
    let page = Page::read(&d.join("healthy.html"));
    assert!(page.html.contains("<dd>healthy, no alarm</dd>"));
    assert!(page.html.contains("No alarm was raised."));
    assert_figures_drawn(&page, parts.len());
    assert!(alarm_shading_per_figure(&page).iter().all(|&n| n == 0));
    assert!(page
        .tables()
        .iter()
        .all(|t| !t.caption.contains("alarms in the order")));
}
