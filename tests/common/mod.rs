//! Helpers shared by the integration tests.
#![allow(dead_code)]

use std::collections::BTreeMap;
use std::io::BufWriter;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use heatrun::recording::Nameplate;

pub mod oracle;
pub mod s3;

/// The package root, read when the test runs: a test binary built from another
/// clone sharing the target directory must not look in that clone's folder.
pub fn package_root() -> PathBuf {
    std::env::var_os("CARGO_MANIFEST_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")))
}

/// Runs the heatrun binary.
pub fn heatrun(args: &[&str], cwd: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_heatrun"))
        .args(args)
        .current_dir(cwd)
        .output()
        .expect("heatrun runs")
}

/// Runs the heatrun binary and fails the test, with the arguments and heatrun's stderr,
/// unless it succeeded.
pub fn heatrun_ok(args: &[&str], cwd: &Path) -> Output {
    let out = heatrun(args, cwd);
    assert!(
        out.status.success(),
        "heatrun {args:?} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

/// One channel of a hand-built recording: topic, metadata, and its samples as
/// (log time in ns, message bytes as text).
pub type Channel = (String, BTreeMap<String, String>, Vec<(u64, String)>);

/// A hand-built recording: channels with metadata and samples.
pub struct RecordingBuilder {
    /// The channels, in the order they are added to the file.
    pub channels: Vec<Channel>,
    /// The `heatrun.nameplate` metadata record, if any.
    pub nameplate: Option<BTreeMap<String, String>>,
    /// The schema name every channel gets (`heatrun.Sample` in the profile).
    pub schema_name: String,
    /// The message encoding every channel gets (`json` in the profile).
    pub message_encoding: String,
}

/// A signal of time in seconds.
type Signal<'a> = Box<dyn Fn(f64) -> f64 + 'a>;

/// The start of hand-built recordings, ns since the Unix epoch (September 2020).
pub const T0: u64 = 1_600_000_000_000_000_000;

impl RecordingBuilder {
    /// No channels yet; the paper's Table 1 nameplate; the profile's schema and encoding.
    pub fn new() -> Self {
        RecordingBuilder {
            channels: Vec::new(),
            nameplate: Some(Nameplate::paper_table1().to_record()),
            schema_name: "heatrun.Sample".into(),
            message_encoding: "json".into(),
        }
    }

    /// Adds a channel `/scada/<quantity>` with samples `value(t_s)` every `period_s` for `duration_s`.
    pub fn channel(
        mut self,
        quantity: &str,
        unit: &str,
        period_s: f64,
        duration_s: f64,
        value: impl Fn(f64) -> f64,
    ) -> Self {
        let meta: BTreeMap<String, String> = [
            ("quantity".to_owned(), quantity.to_owned()),
            ("unit".to_owned(), unit.to_owned()),
        ]
        .into();
        let n = (duration_s / period_s) as u64;
        let samples = (0..n)
            .map(|i| {
                let t = i as f64 * period_s;
                (T0 + (t * 1e9) as u64, format!("{{\"value\":{}}}", value(t)))
            })
            .collect();
        self.channels
            .push((format!("/scada/{quantity}"), meta, samples));
        self
    }

    /// A complete plausible heat run of `duration_s` with load steps, without `skip`.
    pub fn heat_run(duration_s: f64, skip: &str) -> Self {
        let step = |t: f64, a: f64, b: f64| if t < duration_s / 2.0 { a } else { b };
        let mut r = RecordingBuilder::new();
        let rise = |t: f64, tau: f64, k: f64| k * (1.0 - (-t / tau).exp());
        let all: Vec<(&str, &str, Signal<'_>)> = vec![
            (
                "armature_current",
                "A",
                Box::new(move |t| step(t, 2000.0, 3400.0) + 50.0 * (t / 300.0).sin()),
            ),
            (
                "field_current",
                "A",
                Box::new(move |t| step(t, 900.0, 1150.0) + 30.0 * (t / 170.0).cos()),
            ),
            (
                "line_voltage",
                "kV",
                Box::new(move |t| step(t, 15.6, 16.4) + 0.2 * (t / 230.0).sin()),
            ),
            (
                "field_voltage",
                "V",
                Box::new(move |t| step(t, 140.0, 190.0)),
            ),
            (
                "stator_winding_temp",
                "degC",
                Box::new(move |t| 30.0 + rise(t, 700.0, 25.0) + 0.3 * (t / 400.0).sin()),
            ),
            (
                "core_temp",
                "degC",
                Box::new(move |t| 30.0 + rise(t, 3000.0, 17.0) + 0.2 * (t / 500.0).cos()),
            ),
            (
                "cooling_water_outlet_temp",
                "degC",
                Box::new(move |t| 10.0 + rise(t, 30.0, 3.0) + 0.1 * (t / 90.0).sin()),
            ),
        ];
        for (q, unit, f) in all {
            if q != skip {
                r = r.channel(q, unit, 1.0, duration_s, f);
            }
        }
        r
    }

    /// The channels and samples of a synthetic heat run of the paper's model (a real
    /// thermal system, so the estimate stays meaningful after the test edits it).
    pub fn from_synth(duration_s: f64) -> Self {
        let dir = tempdir();
        let path = dir.path().join("synth.mcap");
        heatrun::synth::write(
            &path,
            &heatrun::synth::SynthOptions {
                duration_s,
                ..Default::default()
            },
        )
        .unwrap();
        let bytes = std::fs::read(&path).unwrap();
        let mut r = RecordingBuilder::new();
        let mut index: BTreeMap<String, usize> = BTreeMap::new();
        for msg in mcap::MessageStream::new(&bytes).unwrap() {
            let msg = msg.unwrap();
            let topic = msg.channel.topic.clone();
            let i = *index.entry(topic.clone()).or_insert_with(|| {
                r.channels
                    .push((topic.clone(), msg.channel.metadata.clone(), Vec::new()));
                r.channels.len() - 1
            });
            r.channels[i]
                .2
                .push((msg.log_time, String::from_utf8(msg.data.to_vec()).unwrap()));
        }
        // Synthetic runs start at their own epoch: rebase onto T0.
        let start = r
            .channels
            .iter()
            .flat_map(|c| c.2.iter().map(|s| s.0))
            .min()
            .unwrap();
        for c in r.channels.iter_mut() {
            for s in c.2.iter_mut() {
                s.0 = s.0 - start + T0;
            }
        }
        r
    }

    /// The channels, samples and nameplate record of a recording as they are in the file
    /// (times unchanged), for a test to edit and write again.
    pub fn from_file(path: &Path) -> Self {
        let bytes = std::fs::read(path).unwrap();
        let mut r = RecordingBuilder::new();
        let summary = mcap::Summary::read(&bytes).unwrap();
        if let Some(summary) = summary {
            for index in &summary.metadata_indexes {
                let m = mcap::read::metadata(&bytes, index).unwrap();
                if m.name == "heatrun.nameplate" {
                    r.nameplate = Some(m.metadata);
                }
            }
        }
        let mut index: BTreeMap<String, usize> = BTreeMap::new();
        for msg in mcap::MessageStream::new(&bytes).unwrap() {
            let msg = msg.unwrap();
            let topic = msg.channel.topic.clone();
            let i = *index.entry(topic.clone()).or_insert_with(|| {
                r.channels
                    .push((topic.clone(), msg.channel.metadata.clone(), Vec::new()));
                r.channels.len() - 1
            });
            r.channels[i]
                .2
                .push((msg.log_time, String::from_utf8(msg.data.to_vec()).unwrap()));
        }
        r
    }

    /// Index of the channel of a quantity.
    pub fn channel_of(&self, quantity: &str) -> usize {
        self.channels
            .iter()
            .position(|c| c.0.ends_with(&format!("/{quantity}")))
            .unwrap()
    }

    /// Writes the messages in the given order (arrival order, as a recorder would):
    /// `(channel, sample index, log time)` each.
    pub fn write_in_order(&self, path: &Path, order: &[(usize, usize, u64)]) {
        self.write_ordered(path, mcap::WriteOptions::new(), order);
    }

    fn write_ordered(
        &self,
        path: &Path,
        options: mcap::WriteOptions,
        order: &[(usize, usize, u64)],
    ) {
        let file = std::fs::File::create(path).unwrap();
        let mut w = options.create(BufWriter::new(file)).unwrap();
        let schema = w
            .add_schema(
                &self.schema_name,
                "jsonschema",
                heatrun::synth::SAMPLE_SCHEMA.as_bytes(),
            )
            .unwrap();
        let ids: Vec<u16> = self
            .channels
            .iter()
            .map(|(topic, meta, _)| {
                w.add_channel(schema, topic, &self.message_encoding, meta)
                    .unwrap()
            })
            .collect();
        if let Some(np) = &self.nameplate {
            w.write_metadata(&mcap::records::Metadata {
                name: "heatrun.nameplate".into(),
                metadata: np.clone(),
            })
            .unwrap();
        }
        for (seq, &(c, i, log_time)) in order.iter().enumerate() {
            w.write_to_known_channel(
                &mcap::records::MessageHeader {
                    channel_id: ids[c],
                    sequence: seq as u32,
                    log_time,
                    publish_time: log_time,
                },
                self.channels[c].2[i].1.as_bytes(),
            )
            .unwrap();
        }
        w.finish().unwrap();
    }

    /// Writes the recording with `mcap`'s default options, messages in time order.
    pub fn write(&self, path: &Path) {
        self.write_with(path, mcap::WriteOptions::new(), None);
    }

    /// Writes with the given MCAP options, messages in time order; `shuffle` stores
    /// them in a seeded random order instead.
    pub fn write_with(&self, path: &Path, options: mcap::WriteOptions, shuffle: Option<u64>) {
        let mut order: Vec<(usize, usize, u64)> = Vec::new();
        for (c, (_, _, samples)) in self.channels.iter().enumerate() {
            for (i, (t, _)) in samples.iter().enumerate() {
                order.push((c, i, *t));
            }
        }
        order.sort_by_key(|x| x.2);
        if let Some(seed) = shuffle {
            // Fisher–Yates with a small LCG: deterministic without another dependency.
            let mut state = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            for i in (1..order.len()).rev() {
                state = state
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                let j = (state >> 33) as usize % (i + 1);
                order.swap(i, j);
            }
        }
        self.write_ordered(path, options, &order);
    }
}

/// A fresh temporary directory.
pub fn tempdir() -> tempfile::TempDir {
    tempfile::tempdir().unwrap()
}

/// The files in a directory.
pub fn files_in(dir: &Path) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    v.sort();
    v
}
