//! Streaming an MCAP heat run into typed samples.
//!
//! The file is read front to back through the `mcap` crate's sans-io
//! [`LinearReader`], so memory does not grow with the file: whole chunks are
//! taken one at a time, checked against their CRC and decoded, and every sample
//! is handed to a [`SampleSink`]. A file cut short (no summary, ends mid-chunk)
//! yields every complete chunk before the cut and says how much was lost.

use std::collections::{BTreeMap, HashMap};
use std::io::Read;
use std::path::{Path, PathBuf};

use mcap::records::{ChunkHeader, Record};
use mcap::sans_io::linear_reader::{LinearReadEvent, LinearReader, LinearReaderOptions};
use serde::{Deserialize, Serialize};

use super::nameplate::{NameplateEntries, NAMEPLATE_RECORD};
use super::quantity::Quantity;
use crate::error::{Error, Result};

/// Schema name of a heat-run sample channel.
pub const SAMPLE_SCHEMA_NAME: &str = "heatrun.Sample";
/// Schema encoding of a heat-run sample channel.
pub const SAMPLE_SCHEMA_ENCODING: &str = "jsonschema";
/// Message encoding of a heat-run sample channel.
pub const SAMPLE_MESSAGE_ENCODING: &str = "json";

/// A heat-run channel: one sensor of one quantity.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SensorChannel {
    /// Index of the channel in [`RecordingSummary::channels`] (and in [`Sample::channel`]).
    pub index: usize,
    /// The MCAP topic.
    pub topic: String,
    /// The quantity it measures.
    pub quantity: Quantity,
    /// The `sensor` metadata value that tells several sensors of one quantity apart.
    pub sensor: Option<String>,
    /// The unit as written in the recording.
    pub unit: String,
    /// Factor from `unit` to the quantity's canonical unit.
    #[serde(skip)]
    pub unit_scale: f64,
}

/// One measured value, in the quantity's canonical unit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample {
    /// Index of the channel in [`RecordingSummary::channels`].
    pub channel: usize,
    /// The message's `log_time`, in nanoseconds since the Unix epoch.
    pub log_time_ns: u64,
    /// The value in the canonical unit.
    pub value: f64,
}

/// The receiver of a recording's channels and samples, in file order.
pub trait SampleSink {
    /// A heat-run channel was defined; its samples follow.
    fn channel(&mut self, channel: &SensorChannel);
    /// A sample of a channel announced before.
    fn sample(&mut self, sample: Sample);
}

/// Quality flag of a sample (absent means good).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
enum SampleQuality {
    #[default]
    Good,
    Uncertain,
    Bad,
}

#[derive(Deserialize)]
struct SampleMessage {
    value: f64,
    #[serde(default)]
    quality: SampleQuality,
}

/// A channel of the file that is not read as heat-run data, and why.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct IgnoredChannel {
    /// The MCAP topic.
    pub topic: String,
    /// Why it is not a heat-run channel.
    pub reason: String,
}

/// What reading a recording found, besides the samples given to the sink.
#[derive(Debug, Clone, Default, Serialize)]
pub struct RecordingSummary {
    /// The file.
    pub path: PathBuf,
    /// The heat-run channels, indexed by [`Sample::channel`].
    pub channels: Vec<SensorChannel>,
    /// Channels that are not heat-run data.
    pub ignored_channels: Vec<IgnoredChannel>,
    /// The nameplate entries of the `heatrun.nameplate` record (empty when absent).
    #[serde(skip)]
    pub nameplate: NameplateEntries,
    /// Other metadata records (test id, site, operator), carried into the report.
    pub metadata: BTreeMap<String, BTreeMap<String, String>>,
    /// Samples per channel given to the sink.
    pub samples_per_channel: Vec<u64>,
    /// Samples marked `bad` and dropped.
    pub bad_quality_dropped: u64,
    /// Per channel: samples outside the quantity's physical range, dropped.
    pub implausible_per_channel: Vec<u64>,
    /// Per channel: the first implausible sample (time, value in the canonical unit).
    pub first_implausible: Vec<Option<(u64, f64)>>,
    /// Samples marked `uncertain` (kept).
    pub uncertain_kept: u64,
    /// Earliest and latest sample time, in ns since the epoch.
    pub time_span_ns: Option<(u64, u64)>,
    /// What was lost to damage (a truncated file, a corrupt chunk); empty when nothing.
    pub data_loss: Vec<String>,
    /// Bytes in the file.
    pub file_bytes: u64,
    /// Remarks on the file that are not data loss (a cut summary section).
    pub notes: Vec<String>,
}

/// Formats a `log_time` for messages: RFC 3339, UTC.
pub fn format_time(log_time_ns: u64) -> String {
    match jiff::Timestamp::from_nanosecond(log_time_ns as i128) {
        Ok(ts) => ts.to_string(),
        Err(_) => format!("{log_time_ns} ns"),
    }
}

struct SchemaInfo {
    name: String,
    encoding: String,
}

/// Where an MCAP channel id leads.
enum ChannelRoute {
    Sensor(usize),
    Ignored,
}

struct Reader<'s, S: SampleSink> {
    path: PathBuf,
    sink: &'s mut S,
    summary: RecordingSummary,
    schemas: HashMap<u16, SchemaInfo>,
    routes: HashMap<u16, ChannelRoute>,
    /// Whether the Data End record (the end of the data section) was read.
    seen_data_end: bool,
}

/// Reads the heat-run recording at `path`, giving its samples to `sink`.
///
/// Fails with a one-line error naming the file (and the channel and time where
/// they apply) when the file is not MCAP, a heat-run channel is malformed, or a
/// message is not a sample. Damage after the start (a cut, a corrupt chunk) is
/// recovered from and listed in [`RecordingSummary::data_loss`].
pub fn read_recording<S: SampleSink>(path: &Path, sink: &mut S) -> Result<RecordingSummary> {
    let file = std::fs::File::open(path).map_err(|source| Error::ReadInput {
        path: path.to_owned(),
        source,
    })?;
    let file_bytes = file.metadata().map(|m| m.len()).unwrap_or(0);
    read_stream(file, path, file_bytes, sink)
}

/// Reads a recording from any byte stream (a file, memory); `path` names it in
/// messages and `stream_bytes` is its length, when known, for the data-loss report.
pub fn read_stream<S: SampleSink>(
    mut file: impl Read + Send,
    path: &Path,
    stream_bytes: u64,
    sink: &mut S,
) -> Result<RecordingSummary> {
    let file_bytes = stream_bytes;
    let bad = |message: String| Error::BadRecording {
        path: path.to_owned(),
        message,
    };
    let mut magic = [0u8; 8];
    let got = read_full(&mut file, &mut magic).map_err(|source| Error::ReadInput {
        path: path.to_owned(),
        source,
    })?;
    if got == 0 {
        return Err(bad("the file is empty, not an MCAP recording".into()));
    }
    if magic.starts_with(b"version ") {
        let mut head = vec![0u8; 64];
        let n = read_full(&mut file, &mut head).unwrap_or(0);
        if [&magic[..], &head[..n]]
            .concat()
            .starts_with(b"version https://git-lfs")
        {
            return Err(bad(
                "is a Git LFS pointer, not the MCAP data it stands for; fetch the data with `git lfs pull`".into(),
            ));
        }
    }
    if got < 8 || magic != *mcap::MAGIC {
        return Err(bad(
            "not an MCAP file (it does not start with the MCAP magic bytes)".into(),
        ));
    }

    let mut merger = Reader {
        path: path.to_owned(),
        sink,
        summary: RecordingSummary {
            path: path.to_owned(),
            file_bytes,
            ..Default::default()
        },
        schemas: HashMap::new(),
        routes: HashMap::new(),
        seen_data_end: false,
    };
    // Three stages, so that both cores work: this thread's scan reads the file and
    // cuts it into records and whole chunks; workers decompress chunks and parse their
    // messages; the merger (the calling thread) takes the results back in file order and
    // feeds the sink. Bounded queues keep memory constant whatever the file's length.
    let workers = std::thread::available_parallelism()
        .map_or(2, |n| n.get())
        .clamp(1, 4);
    let (work_tx, work_rx) = crossbeam_channel::bounded::<(u64, ChunkHeader, Vec<u8>)>(2 * workers);
    let (done_tx, done_rx) = crossbeam_channel::bounded::<Unit>(4 * workers);
    std::thread::scope(|scope| {
        for _ in 0..workers {
            let (work_rx, done_tx) = (work_rx.clone(), done_tx.clone());
            scope.spawn(move || {
                for (seq, header, data) in work_rx {
                    let start = header.message_start_time;
                    let unit = Unit::Decoded {
                        seq,
                        start,
                        items: decode_chunk(&header, &data),
                    };
                    if done_tx.send(unit).is_err() {
                        break;
                    }
                }
            });
        }
        drop(work_rx);
        let scan_done = done_tx.clone();
        drop(done_tx);
        scope.spawn(move || scan(file, work_tx, scan_done));
        let result = merger.merge(done_rx);
        result
    })?;
    Ok(merger.summary)
}

/// Decoded pieces of the file, in file order by `seq`.
enum Unit {
    /// Records outside chunks, or a chunk's records (`Err`: the chunk is damaged).
    Decoded {
        seq: u64,
        start: u64,
        items: std::result::Result<Vec<Item>, String>,
    },
    /// The end of the scan, and why it ended.
    End { seq: u64, end: ScanEnd },
}

/// How the scan of the file ended.
enum ScanEnd {
    /// The file ended where a file may end.
    Clean,
    /// The file ended mid-record.
    Cut { consumed: u64, last_record_end: u64 },
    /// A record could not be read; nothing after it was.
    Damaged { last_record_end: u64, what: String },
    /// Reading the file failed.
    Io(std::io::Error),
}

/// One record's content, owned, as the merger needs it.
enum Item {
    Schema {
        id: u16,
        name: String,
        encoding: String,
    },
    Channel(mcap::records::Channel),
    /// A message with its payload parsed as a sample (or why not); `stray` when its time
    /// lies outside the time range its chunk declares (a damaged timestamp).
    Message {
        channel_id: u16,
        log_time: u64,
        sample: std::result::Result<SampleMessage, String>,
        stray: bool,
    },
    Metadata(mcap::records::Metadata),
    DataEnd,
}

/// Whether heatrun reads records of this opcode. The others (attachments, indexes,
/// statistics, summary offsets, header, footer) are skipped unparsed: they carry
/// nothing a replay needs, and mcap 0.26's `parse_record` panics on a truncated
/// attachment body (found by fuzzing), so they are never handed to it.
fn wanted(opcode: u8) -> bool {
    use mcap::records::op;
    matches!(
        opcode,
        op::SCHEMA | op::CHANNEL | op::MESSAGE | op::CHUNK | op::METADATA | op::DATA_END
    )
}

/// The item of one parsed record outside or inside a chunk (`None`: not needed).
fn item(record: Record<'_>) -> Option<Item> {
    Some(match record {
        Record::Schema { header, .. } => Item::Schema {
            id: header.id,
            name: header.name,
            encoding: header.encoding,
        },
        Record::Channel(c) => Item::Channel(c),
        Record::Message { header, data } => Item::Message {
            channel_id: header.channel_id,
            log_time: header.log_time,
            sample: serde_json::from_slice::<SampleMessage>(&data).map_err(|e| e.to_string()),
            stray: false,
        },
        Record::Metadata(m) => Item::Metadata(m),
        Record::DataEnd(_) => Item::DataEnd,
        _ => return None,
    })
}

/// Decompresses a chunk and parses its records; any damage drops the whole chunk.
fn decode_chunk(header: &ChunkHeader, data: &[u8]) -> std::result::Result<Vec<Item>, String> {
    let plain = super::chunk::decompress(header, data)?;
    let mut items = Vec::new();
    for record in super::chunk::records(&plain) {
        let (opcode, body) = record?;
        if !wanted(opcode) {
            continue;
        }
        let record = mcap::parse_record(opcode, body).map_err(|e| e.to_string())?;
        let mut it = item(record);
        if let Some(Item::Message {
            log_time, stray, ..
        }) = it.as_mut()
        {
            *stray = *log_time < header.message_start_time || *log_time > header.message_end_time;
        }
        items.extend(it);
    }
    Ok(items)
}

/// Reads the file front to back: records outside chunks are parsed here, chunks go to
/// the workers whole. Ends with a [`Unit::End`].
fn scan(
    mut file: impl Read,
    work: crossbeam_channel::Sender<(u64, ChunkHeader, Vec<u8>)>,
    done: crossbeam_channel::Sender<Unit>,
) {
    let options = LinearReaderOptions::default()
        .with_skip_start_magic(true)
        .with_emit_chunks(true)
        // A corrupt length must not make the reader allocate the machine's memory.
        .with_record_length_limit(1 << 30);
    let mut linear = LinearReader::new_with_options(options);
    let mut consumed: u64 = 8;
    let mut last_record_end: u64 = 8;
    let mut seq = 0u64;
    let end = loop {
        let Some(event) = linear.next_event() else {
            break ScanEnd::Clean;
        };
        match event {
            Ok(LinearReadEvent::ReadRequest(need)) => {
                // Read in pieces of at most 1 MiB: a damaged length must not make us
                // allocate what the file does not hold.
                let buf = linear.insert(need.clamp(1 << 12, 1 << 20));
                match read_full(&mut file, buf) {
                    Ok(n) => {
                        consumed += n as u64;
                        linear.notify_read(n);
                    }
                    Err(e) => break ScanEnd::Io(e),
                }
            }
            Ok(LinearReadEvent::Record { opcode, data }) => {
                let len = data.len() as u64;
                if !wanted(opcode) {
                    last_record_end += 9 + len;
                    continue;
                }
                let sent = match mcap::parse_record(opcode, data) {
                    Ok(Record::Chunk { header, data }) => {
                        work.send((seq, header, data.into_owned())).is_ok()
                    }
                    Ok(record) => done
                        .send(Unit::Decoded {
                            seq,
                            start: 0,
                            items: Ok(item(record).into_iter().collect()),
                        })
                        .is_ok(),
                    Err(e) => {
                        break ScanEnd::Damaged {
                            last_record_end,
                            what: format!("a damaged record (opcode {opcode:#04x}): {e}"),
                        }
                    }
                };
                if !sent {
                    return; // the merger stopped: nothing more is wanted
                }
                seq += 1;
                last_record_end += 9 + len;
            }
            Err(mcap::McapError::UnexpectedEof) => {
                break ScanEnd::Cut {
                    consumed,
                    last_record_end,
                }
            }
            Err(e) => {
                break ScanEnd::Damaged {
                    last_record_end,
                    what: e.to_string(),
                }
            }
        }
    };
    let _ = done.send(Unit::End { seq, end });
}

/// Reads until `buf` is full or the file ends; returns the bytes read.
fn read_full(file: &mut impl Read, buf: &mut [u8]) -> std::io::Result<usize> {
    let mut filled = 0;
    while filled < buf.len() {
        match file.read(&mut buf[filled..]) {
            Ok(0) => break,
            Ok(n) => filled += n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(filled)
}

impl<S: SampleSink> Reader<'_, S> {
    fn bad(&self, message: String) -> Error {
        Error::BadRecording {
            path: self.path.clone(),
            message,
        }
    }

    /// Takes the decoded units back in file order and applies them.
    fn merge(&mut self, done: crossbeam_channel::Receiver<Unit>) -> Result<()> {
        let mut waiting: std::collections::BTreeMap<u64, Unit> = std::collections::BTreeMap::new();
        let mut next = 0u64;
        for unit in done.iter() {
            let seq = match &unit {
                Unit::Decoded { seq, .. } | Unit::End { seq, .. } => *seq,
            };
            waiting.insert(seq, unit);
            while let Some(unit) = waiting.remove(&next) {
                next += 1;
                match unit {
                    Unit::Decoded { start, items, .. } => match items {
                        Ok(items) => {
                            for item in items {
                                self.apply(item)?;
                            }
                        }
                        Err(why) => self.summary.data_loss.push(format!(
                            "the chunk starting at {} is damaged ({why}); its messages were dropped",
                            format_time(start)
                        )),
                    },
                    Unit::End { end, .. } => return self.finish(end),
                }
            }
        }
        Ok(())
    }

    fn finish(&mut self, end: ScanEnd) -> Result<()> {
        let file_bytes = self.summary.file_bytes;
        match end {
            ScanEnd::Clean => {}
            ScanEnd::Io(source) => {
                return Err(Error::ReadInput {
                    path: self.path.clone(),
                    source,
                })
            }
            ScanEnd::Cut {
                last_record_end, ..
            } if self.seen_data_end => {
                // Only the summary (indexes, statistics) is cut: every message was read.
                self.summary.notes.push(format!(
                    "the summary section is cut short after byte {last_record_end}; no data were lost"
                ));
            }
            ScanEnd::Cut {
                consumed,
                last_record_end,
            } => {
                if self.summary.channels.is_empty() && self.summary.ignored_channels.is_empty() {
                    return Err(self.bad(format!(
                        "the file ends after {consumed} bytes, before any channel was defined"
                    )));
                }
                let last = self
                    .summary
                    .time_span_ns
                    .map(|(_, b)| format_time(b))
                    .unwrap_or_else(|| "none".into());
                self.summary.data_loss.push(format!(
                    "the file is cut short: it ends mid-record after byte {last_record_end} of {file_bytes}, \
                     with no summary; the last {} bytes were not usable (last complete sample: {last})",
                    file_bytes.saturating_sub(last_record_end)
                ));
            }
            ScanEnd::Damaged {
                last_record_end,
                what,
            } => {
                if last_record_end <= 8 {
                    return Err(self.bad(format!("not a readable MCAP file: {what}")));
                }
                self.summary.data_loss.push(format!(
                    "the file is damaged after byte {last_record_end}: {what}; the rest was not read"
                ));
            }
        }
        Ok(())
    }

    fn apply(&mut self, item: Item) -> Result<()> {
        match item {
            Item::Schema { id, name, encoding } => {
                self.schemas.insert(id, SchemaInfo { name, encoding });
            }
            Item::Channel(channel) => self.channel(channel)?,
            Item::Message {
                channel_id,
                log_time,
                sample,
                stray,
            } => {
                if stray {
                    if let Some(ChannelRoute::Sensor(i)) = self.routes.get(&channel_id) {
                        let i = *i;
                        self.summary.implausible_per_channel[i] += 1;
                        let value = sample.as_ref().map(|s| s.value).unwrap_or(f64::NAN);
                        self.summary.first_implausible[i].get_or_insert((log_time, value));
                    }
                    return Ok(());
                }
                if let Some(sample) = self.message(channel_id, log_time, sample)? {
                    self.deliver(sample);
                }
            }
            Item::Metadata(meta) => {
                if meta.name == NAMEPLATE_RECORD {
                    self.summary.nameplate = NameplateEntries::from_map(
                        &meta.metadata,
                        &self.path.display().to_string(),
                    );
                } else {
                    self.summary.metadata.insert(meta.name, meta.metadata);
                }
            }
            Item::DataEnd => self.seen_data_end = true,
        }
        Ok(())
    }

    fn deliver(&mut self, sample: Sample) {
        self.summary.samples_per_channel[sample.channel] += 1;
        let t = sample.log_time_ns;
        self.summary.time_span_ns = Some(match self.summary.time_span_ns {
            None => (t, t),
            Some((a, b)) => (a.min(t), b.max(t)),
        });
        self.sink.sample(sample);
    }

    fn channel(&mut self, channel: mcap::records::Channel) -> Result<()> {
        if self.routes.contains_key(&channel.id) {
            // A repeated channel record (the summary repeats them): already known.
            return Ok(());
        }
        let quantity_name = channel
            .metadata
            .get("quantity")
            .cloned()
            .unwrap_or_else(|| channel.topic.rsplit('/').next().unwrap_or("").to_owned());
        let Some(quantity) = Quantity::from_name(&quantity_name) else {
            let reason = if channel.metadata.contains_key("quantity") {
                format!("quantity `{quantity_name}` is not one of the profile's")
            } else {
                "no `quantity` metadata and the topic names no quantity".to_owned()
            };
            self.summary.ignored_channels.push(IgnoredChannel {
                topic: channel.topic,
                reason,
            });
            self.routes.insert(channel.id, ChannelRoute::Ignored);
            return Ok(());
        };
        let topic = &channel.topic;
        let schema = self.schemas.get(&channel.schema_id);
        let schema_ok = schema
            .is_some_and(|s| s.name == SAMPLE_SCHEMA_NAME && s.encoding == SAMPLE_SCHEMA_ENCODING);
        if !schema_ok {
            let found = match schema {
                Some(s) => format!("schema `{}` ({})", s.name, s.encoding),
                None => "no schema".to_owned(),
            };
            return Err(self.bad(format!(
                "channel {topic} carries {quantity} but has {found}; the profile wants schema \
                 `{SAMPLE_SCHEMA_NAME}` with encoding `{SAMPLE_SCHEMA_ENCODING}`"
            )));
        }
        if channel.message_encoding != SAMPLE_MESSAGE_ENCODING {
            return Err(self.bad(format!(
                "channel {topic} has message encoding `{}`; the profile wants `{SAMPLE_MESSAGE_ENCODING}`",
                channel.message_encoding
            )));
        }
        let Some(unit) = channel.metadata.get("unit").cloned() else {
            return Err(self.bad(format!(
                "channel {topic} ({quantity}) has no `unit` metadata; one of {} is required",
                quantity.accepted_units().join(", ")
            )));
        };
        let Some(unit_scale) = quantity.unit_scale(&unit) else {
            return Err(self.bad(format!(
                "channel {topic} ({quantity}) has unit `{unit}`, which the profile does not accept \
                 for {quantity}; use one of {}",
                quantity.accepted_units().join(", ")
            )));
        };
        let index = self.summary.channels.len();
        let sensor_channel = SensorChannel {
            index,
            topic: channel.topic.clone(),
            quantity,
            sensor: channel.metadata.get("sensor").cloned(),
            unit,
            unit_scale,
        };
        self.sink.channel(&sensor_channel);
        self.summary.channels.push(sensor_channel);
        self.summary.samples_per_channel.push(0);
        self.summary.implausible_per_channel.push(0);
        self.summary.first_implausible.push(None);
        self.routes.insert(channel.id, ChannelRoute::Sensor(index));
        Ok(())
    }

    fn message(
        &mut self,
        channel_id: u16,
        log_time: u64,
        sample: std::result::Result<SampleMessage, String>,
    ) -> Result<Option<Sample>> {
        let index = match self.routes.get(&channel_id) {
            Some(ChannelRoute::Sensor(i)) => *i,
            Some(ChannelRoute::Ignored) => return Ok(None),
            None => {
                return Err(self.bad(format!(
                    "a message at {} is on channel id {channel_id}, which was never defined",
                    format_time(log_time)
                )))
            }
        };
        let parsed: SampleMessage = sample.map_err(|e| {
            let ch = &self.summary.channels[index];
            self.bad(format!(
                "channel {} at {}: the message is not a sample {{\"value\": <number>}}: {e}",
                ch.topic,
                format_time(log_time)
            ))
        })?;
        match parsed.quality {
            SampleQuality::Bad => {
                self.summary.bad_quality_dropped += 1;
                return Ok(None);
            }
            SampleQuality::Uncertain => self.summary.uncertain_kept += 1,
            SampleQuality::Good => {}
        }
        let ch = &self.summary.channels[index];
        let value = parsed.value * ch.unit_scale;
        let (lo, hi) = ch.quantity.plausible_range();
        if !(value >= lo && value <= hi) {
            self.summary.implausible_per_channel[index] += 1;
            if self.summary.first_implausible[index].is_none() {
                self.summary.first_implausible[index] = Some((log_time, value));
            }
            return Ok(None);
        }
        Ok(Some(Sample {
            channel: index,
            log_time_ns: log_time,
            value,
        }))
    }
}
