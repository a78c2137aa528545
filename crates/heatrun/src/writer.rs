//! Writing recordings in the profile: one writer for every command that makes an
//! MCAP file (`synth`, `import`).
//!
//! The file is written as it goes: the `mcap` crate holds one chunk (1 MiB by
//! default) in memory and appends it to the file when full, so memory does not grow
//! with the recording. Everything goes under a temporary name beside the destination
//! and is renamed into place by [`RecordingWriter::finish`]; a writer dropped before
//! that (an error on the way) leaves no file behind.
//!
//! What the writer puts in a file, as the profile asks: the `heatrun.Sample` schema
//! (`schemas/sample.schema.json`), one channel per sensor with the metadata `quantity`,
//! `unit`, `sensor` and the optional storage keys (`storage`, `deadband`,
//! `max_interval_s`), the `heatrun.nameplate` record and other metadata records,
//! messages `{"value": …}` with an optional `quality`, zstd chunks, the summary
//! section with chunk indexes and statistics.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};

use crate::atomic::PendingOutput;
use crate::atomic::WriteError;

type Result<T> = std::result::Result<T, WriteError>;
use crate::recording::{
    NAMEPLATE_RECORD, SAMPLE_MESSAGE_ENCODING, SAMPLE_SCHEMA_ENCODING, SAMPLE_SCHEMA_NAME,
};

/// The JSON Schema of a sample message (also `schemas/sample.schema.json`).
pub const SAMPLE_SCHEMA: &str = include_str!("../../../schemas/sample.schema.json");

/// The profile a written file declares in its MCAP header.
pub const PROFILE: &str = "heatrun-scada/1";

/// How the file is laid out.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct WriterOptions {
    /// zstd-compress the chunks (else they are stored uncompressed).
    pub compress: bool,
    /// Target size of a chunk before compression, bytes.
    pub chunk_size: u64,
}

impl Default for WriterOptions {
    fn default() -> Self {
        WriterOptions {
            compress: true,
            chunk_size: 1 << 20,
        }
    }
}

/// How a channel's samples were stored (profile: channel metadata `storage`): the
/// reader's own type, so what is written is what is read.
pub use crate::recording::{Interpolation, Storage};

/// A channel to add to a recording.
#[derive(Debug, Clone, PartialEq)]
pub struct ChannelSpec {
    /// The MCAP topic.
    pub topic: String,
    /// The channel's name: a profile quantity (`stator_winding_temp`) or a free name
    /// (`T1`); written as the `quantity` metadata.
    pub name: String,
    /// The unit as it is to be written (`degC`, `kA`, `%`).
    pub unit: String,
    /// Tells several sensors of one quantity apart (metadata `sensor`).
    pub sensor: Option<String>,
    /// How the samples were stored.
    pub storage: Storage,
    /// How the value runs between samples (metadata `interpolation`, written where `step`).
    pub interpolation: Interpolation,
    /// The sensor's resolution in `unit` (metadata `resolution`), where it is known.
    pub resolution: Option<f64>,
}

impl ChannelSpec {
    /// A sampled channel on the topic `/scada/<name>` (`/scada/<name>/<sensor>` once
    /// [`ChannelSpec::with_sensor`] names a sensor).
    pub fn new(name: &str, unit: &str) -> ChannelSpec {
        ChannelSpec {
            topic: format!("/scada/{name}"),
            name: name.to_owned(),
            unit: unit.to_owned(),
            sensor: None,
            storage: Storage::Sampled,
            interpolation: Interpolation::Linear,
            resolution: None,
        }
    }

    /// The same channel as one sensor of several, on its own topic.
    pub fn with_sensor(mut self, sensor: &str) -> ChannelSpec {
        self.topic = format!("/scada/{}/{sensor}", self.name);
        self.sensor = Some(sensor.to_owned());
        self
    }

    /// The same channel with another storage.
    pub fn with_storage(mut self, storage: Storage) -> ChannelSpec {
        self.storage = storage;
        self
    }

    /// The same channel with another way between samples.
    pub fn with_interpolation(mut self, interpolation: Interpolation) -> ChannelSpec {
        self.interpolation = interpolation;
        self
    }

    /// The same channel with its sensor's resolution, in its unit.
    pub fn with_resolution(mut self, resolution: f64) -> ChannelSpec {
        self.resolution = Some(resolution);
        self
    }

    /// The channel metadata the profile reads.
    pub fn metadata(&self) -> BTreeMap<String, String> {
        let mut m = BTreeMap::new();
        m.insert("quantity".to_owned(), self.name.clone());
        m.insert("unit".to_owned(), self.unit.clone());
        if let Some(sensor) = &self.sensor {
            m.insert("sensor".to_owned(), sensor.clone());
        }
        if let Storage::Exception {
            deadband,
            max_interval_s,
        } = self.storage
        {
            m.insert("storage".to_owned(), "exception".to_owned());
            m.insert("deadband".to_owned(), format!("{deadband}"));
            if let Some(h) = max_interval_s {
                m.insert("max_interval_s".to_owned(), format!("{h}"));
            }
        }
        if self.interpolation == Interpolation::Step {
            m.insert("interpolation".to_owned(), "step".to_owned());
        }
        if let Some(r) = self.resolution {
            m.insert("resolution".to_owned(), format!("{r}"));
        }
        m
    }
}

/// The quality flag of a sample (profile: absent means good).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Quality {
    /// A good sample (no `quality` key is written).
    #[default]
    Good,
    /// Kept by readers, but flagged.
    Uncertain,
    /// Dropped by readers.
    Bad,
}

impl Quality {
    /// The profile's name of the flag.
    pub fn name(self) -> &'static str {
        match self {
            Quality::Good => "good",
            Quality::Uncertain => "uncertain",
            Quality::Bad => "bad",
        }
    }
}

/// A channel added to a [`RecordingWriter`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ChannelId(u16);

/// What a finished recording holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Written {
    /// Messages written.
    pub messages: u64,
    /// Earliest and latest `log_time`, ns since the epoch (none without messages).
    pub time_span_ns: Option<(u64, u64)>,
}

/// A profile recording being written, message by message.
pub struct RecordingWriter {
    mcap: mcap::Writer<BufWriter<File>>,
    pending: PendingOutput,
    destination: PathBuf,
    schema: u16,
    sequence: u32,
    message: String,
    written: Written,
}

impl RecordingWriter {
    /// Starts the recording that [`RecordingWriter::finish`] will put at `destination`.
    pub fn create(destination: &Path, options: WriterOptions) -> Result<RecordingWriter> {
        let pending = PendingOutput::new(destination);
        let file = File::create(pending.path()).map_err(|e| WriteError::new(destination, e))?;
        let mut mcap = mcap::WriteOptions::new()
            .profile(PROFILE)
            .library(concat!("heatrun ", env!("CARGO_PKG_VERSION")))
            .compression(options.compress.then_some(mcap::Compression::Zstd))
            .chunk_size(Some(options.chunk_size))
            .create(BufWriter::new(file))
            .map_err(|e| write_error(destination, e))?;
        let schema = mcap
            .add_schema(
                SAMPLE_SCHEMA_NAME,
                SAMPLE_SCHEMA_ENCODING,
                SAMPLE_SCHEMA.as_bytes(),
            )
            .map_err(|e| write_error(destination, e))?;
        Ok(RecordingWriter {
            mcap,
            pending,
            destination: destination.to_owned(),
            schema,
            sequence: 0,
            message: String::new(),
            written: Written::default(),
        })
    }

    /// Adds a channel; its samples may follow.
    pub fn add_channel(&mut self, spec: &ChannelSpec) -> Result<ChannelId> {
        let id = self
            .mcap
            .add_channel(
                self.schema,
                &spec.topic,
                SAMPLE_MESSAGE_ENCODING,
                &spec.metadata(),
            )
            .map_err(|e| write_error(&self.destination, e))?;
        Ok(ChannelId(id))
    }

    /// Writes the `heatrun.nameplate` record (values are decimal strings).
    pub fn write_nameplate(&mut self, entries: &BTreeMap<String, String>) -> Result<()> {
        self.write_metadata(NAMEPLATE_RECORD, entries)
    }

    /// Writes a metadata record (test id, site, operator: carried into the report).
    pub fn write_metadata(&mut self, name: &str, entries: &BTreeMap<String, String>) -> Result<()> {
        self.mcap
            .write_metadata(&mcap::records::Metadata {
                name: name.to_owned(),
                metadata: entries.clone(),
            })
            .map_err(|e| write_error(&self.destination, e))
    }

    /// Writes a good sample `{"value": v}` at `log_time_ns` (ns since the epoch).
    /// The value is written in its shortest form that reads back as the same `f64`;
    /// a value that is not finite is written as a dropout.
    pub fn write_sample(&mut self, channel: ChannelId, log_time_ns: u64, value: f64) -> Result<()> {
        self.write_flagged(channel, log_time_ns, Some(value), Quality::Good)
    }

    /// Writes a dropout `{"value": null}`: a sample that was due but is missing.
    pub fn write_dropout(&mut self, channel: ChannelId, log_time_ns: u64) -> Result<()> {
        self.write_flagged(channel, log_time_ns, None, Quality::Good)
    }

    /// Writes a dropout as a bare `{"value":NaN}`, as recorders and historians write
    /// one (not JSON, but the profile reads it as `null`).
    pub fn write_nan_dropout(&mut self, channel: ChannelId, log_time_ns: u64) -> Result<()> {
        self.message.clear();
        self.message.push_str("{\"value\":NaN}");
        self.write_message(channel, log_time_ns)
    }

    /// Writes a sample with a quality flag; `None` (or a value that is not finite)
    /// is a dropout.
    pub fn write_flagged(
        &mut self,
        channel: ChannelId,
        log_time_ns: u64,
        value: Option<f64>,
        quality: Quality,
    ) -> Result<()> {
        use std::fmt::Write;
        self.message.clear();
        match value.filter(|v| v.is_finite()) {
            Some(v) => write!(self.message, "{{\"value\":{v}").unwrap_or(()),
            None => self.message.push_str("{\"value\":null"),
        }
        if quality != Quality::Good {
            write!(self.message, ",\"quality\":\"{}\"", quality.name()).unwrap_or(());
        }
        self.message.push('}');
        self.write_message(channel, log_time_ns)
    }

    /// Writes the message text built in `self.message` at `log_time_ns`.
    fn write_message(&mut self, channel: ChannelId, log_time_ns: u64) -> Result<()> {
        self.mcap
            .write_to_known_channel(
                &mcap::records::MessageHeader {
                    channel_id: channel.0,
                    sequence: self.sequence,
                    log_time: log_time_ns,
                    publish_time: log_time_ns,
                },
                self.message.as_bytes(),
            )
            .map_err(|e| write_error(&self.destination, e))?;
        self.sequence = self.sequence.wrapping_add(1);
        self.written.messages += 1;
        self.written.time_span_ns = Some(match self.written.time_span_ns {
            None => (log_time_ns, log_time_ns),
            Some((a, b)) => (a.min(log_time_ns), b.max(log_time_ns)),
        });
        Ok(())
    }

    /// Messages written so far.
    pub fn messages(&self) -> u64 {
        self.written.messages
    }

    /// Writes the summary section, flushes, and renames the file into place.
    pub fn finish(mut self) -> Result<Written> {
        self.mcap
            .finish()
            .map_err(|e| write_error(&self.destination, e))?;
        let RecordingWriter {
            mcap,
            pending,
            destination,
            written,
            ..
        } = self;
        // The buffered writer flushes into the file here; a failure must not pass
        // unnoticed, so it is flushed explicitly before the rename.
        let mut inner = mcap.into_inner();
        std::io::Write::flush(&mut inner).map_err(|e| WriteError::new(&destination, e))?;
        drop(inner);
        pending.commit()?;
        Ok(written)
    }
}

fn write_error(path: &Path, e: mcap::McapError) -> WriteError {
    WriteError::new(path, e)
}

/// Storage by exception, as a historian does it: a sample is kept when it moved by
/// more than the deadband since the last kept one (|v − v_kept| > deadband), or
/// when the heartbeat passed since then (t − t_kept ≥ max_interval); the first
/// sample is always kept.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ExceptionFilter {
    deadband: f64,
    max_interval_ns: u64,
    last_kept: Option<(u64, f64)>,
}

impl ExceptionFilter {
    /// A filter with a deadband (in the channel's unit) and a heartbeat in seconds.
    pub fn new(deadband: f64, max_interval_s: f64) -> ExceptionFilter {
        ExceptionFilter {
            deadband,
            // No heartbeat: never forced (an infinite interval saturates).
            max_interval_ns: (max_interval_s * 1e9).round() as u64,
            last_kept: None,
        }
    }

    /// The storage a channel filtered this way declares.
    pub fn storage(&self) -> Storage {
        Storage::Exception {
            deadband: self.deadband,
            max_interval_s: (self.max_interval_ns < u64::MAX)
                .then_some(self.max_interval_ns as f64 * 1e-9),
        }
    }

    /// Whether the historian stores the sample `value` at `log_time_ns`.
    pub fn keep(&mut self, log_time_ns: u64, value: f64) -> bool {
        let keep = match self.last_kept {
            None => true,
            Some((t, v)) => {
                (value - v).abs() > self.deadband
                    || log_time_ns.saturating_sub(t) >= self.max_interval_ns
            }
        };
        if keep {
            self.last_kept = Some((log_time_ns, value));
        }
        keep
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exception_filter_keeps_moves_beyond_the_deadband_and_heartbeats() {
        let mut f = ExceptionFilter::new(0.1, 10.0);
        let s = 1_000_000_000u64;
        // Hand-worked: 20.0 kept (first); 20.05 (moved 0.05) dropped; 20.11 (0.11 from
        // 20.0) kept; 20.2 (0.09 from 20.11) dropped; at t = 12 s, 20.2 is 0.09 from
        // 20.11 but the heartbeat (10 s since t = 2 s) has passed: kept.
        let kept: Vec<bool> = [(0, 20.0), (1, 20.05), (2, 20.11), (3, 20.2), (12, 20.2)]
            .iter()
            .map(|&(t, v)| f.keep(t * s, v))
            .collect();
        assert_eq!(kept, [true, false, true, false, true]);
        assert_eq!(
            f.storage(),
            Storage::Exception {
                deadband: 0.1,
                max_interval_s: Some(10.0)
            }
        );
    }

    #[test]
    fn channel_metadata_carries_the_storage_keys_only_for_exception() {
        let sampled = ChannelSpec::new("T1", "degC");
        assert_eq!(sampled.topic, "/scada/T1");
        assert_eq!(sampled.metadata().len(), 2);
        let m = ChannelSpec::new("core_temp", "degC")
            .with_sensor("rtd2")
            .with_storage(Storage::Exception {
                deadband: 0.1,
                max_interval_s: Some(600.0),
            })
            .metadata();
        assert_eq!(m["quantity"], "core_temp");
        assert_eq!(m["sensor"], "rtd2");
        assert_eq!(m["storage"], "exception");
        assert_eq!(m["deadband"], "0.1");
        assert_eq!(m["max_interval_s"], "600");
    }
}
