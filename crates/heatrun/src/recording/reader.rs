//! Streaming an MCAP heat run into typed samples.
//!
//! The file is read front to back through the `mcap` crate's sans-io
//! [`LinearReader`], so memory does not grow with the file: whole chunks are
//! taken one at a time, checked against their CRC and decoded, and every sample
//! is handed to a [`SampleSink`]. A file cut short (no summary, ends mid-chunk)
//! yields every complete chunk before the cut and says how much was lost.
//!
//! Nothing here depends on the order the messages are stored in: the profile lets a
//! recorder store them in any order, and every count, "first" time and verdict below is
//! the same for any order of the same messages.

use std::collections::{BTreeMap, BTreeSet, BinaryHeap, HashMap};
use std::io::Read;
use std::path::{Path, PathBuf};

use crate::store::Location;

use mcap::records::{ChunkHeader, Record};
use mcap::sans_io::linear_reader::{LinearReadEvent, LinearReader, LinearReaderOptions};
use serde::{Deserialize, Serialize};

use super::channel::{classify, ChannelKind};
pub use super::channel::{
    IgnoredChannel, SensorChannel, SAMPLE_MESSAGE_ENCODING, SAMPLE_SCHEMA_ENCODING,
    SAMPLE_SCHEMA_NAME,
};
use super::chunk::ChunkError;
use super::compact::CompactQuality;
use super::error::{RecordingError, Result};
use super::nameplate::{NameplateEntries, NAMEPLATE_RECORD};
use super::quantity::ZERO_NOISE_FRACTION;
use crate::progress::{Observer, Throttle};

/// How to read a recording.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct ReadOptions {
    /// Channel names (metadata `quantity`, else the topic's last segment) outside the
    /// profile to read as free signals ([`Signal::Free`](super::Signal::Free)), because a
    /// model spec names them. Others outside the profile are listed as ignored.
    pub free_channels: BTreeSet<String>,
    /// Told the bytes and messages read as the file streams by (per chunk, at most about
    /// ten times a second), and once more at the end.
    pub progress: Observer,
}

/// One measured value, in the signal's canonical unit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample {
    /// Index of the channel in [`RecordingSummary::channels`].
    pub channel: usize,
    /// The message's `log_time`, in nanoseconds since the Unix epoch.
    pub log_time_ns: u64,
    /// The value in the canonical unit.
    pub value: f64,
}

/// The receiver of a recording's channels and samples, in file order (which may be any
/// order in time).
pub trait SampleSink {
    /// A heat-run channel was defined; its samples follow.
    fn channel(&mut self, channel: &SensorChannel);
    /// A sample of a channel announced before.
    fn sample(&mut self, sample: Sample);
    /// Takes back a sample given before: the end of the file showed it to be a fault
    /// (a reading of a non-negative quantity far below zero, judged against the rated
    /// value, which may come after the samples). A sink that accumulates must undo it.
    fn retract(&mut self, sample: Sample);
}

/// Gives every sample to two sinks (the grid builder and the full-rate publisher), so
/// that one pass over a file feeds both.
pub struct Tee<'a> {
    /// The first sink.
    pub first: &'a mut dyn SampleSink,
    /// The second sink.
    pub also: &'a mut dyn SampleSink,
}

impl SampleSink for Tee<'_> {
    fn channel(&mut self, channel: &SensorChannel) {
        self.first.channel(channel);
        self.also.channel(channel);
    }

    fn sample(&mut self, sample: Sample) {
        self.first.sample(sample);
        self.also.sample(sample);
    }

    fn retract(&mut self, sample: Sample) {
        self.first.retract(sample);
        self.also.retract(sample);
    }
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

/// A sample message as written. `value` must be present; `null` or NaN is a dropout (`None`).
#[derive(Debug, Deserialize)]
struct SampleJson {
    #[serde(deserialize_with = "value_or_dropout")]
    value: Option<f64>,
    #[serde(default)]
    quality: SampleQuality,
}

/// A sample's `value`: a number, or `null` / `"NaN"` for a dropout.
fn value_or_dropout<'de, D: serde::Deserializer<'de>>(
    d: D,
) -> std::result::Result<Option<f64>, D::Error> {
    struct Value;
    impl serde::de::Visitor<'_> for Value {
        type Value = Option<f64>;
        fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
            f.write_str("a number, or null or NaN for a dropout")
        }
        fn visit_f64<E>(self, v: f64) -> std::result::Result<Option<f64>, E> {
            Ok(Some(v).filter(|v| !v.is_nan()))
        }
        fn visit_i64<E>(self, v: i64) -> std::result::Result<Option<f64>, E> {
            Ok(Some(v as f64))
        }
        fn visit_u64<E>(self, v: u64) -> std::result::Result<Option<f64>, E> {
            Ok(Some(v as f64))
        }
        fn visit_unit<E>(self) -> std::result::Result<Option<f64>, E> {
            Ok(None)
        }
        fn visit_none<E>(self) -> std::result::Result<Option<f64>, E> {
            Ok(None)
        }
        fn visit_str<E: serde::de::Error>(self, v: &str) -> std::result::Result<Option<f64>, E> {
            if is_nan_word(v) {
                Ok(None)
            } else {
                Err(E::invalid_value(serde::de::Unexpected::Str(v), &self))
            }
        }
    }
    d.deserialize_any(Value)
}

/// `NaN` as recorders write it (`NaN`, `nan`, `-nan`).
fn is_nan_word(text: &str) -> bool {
    text.trim_start_matches(['-', '+'])
        .eq_ignore_ascii_case("nan")
}

/// A parsed sample, compact: a chunk's worth of these waits in the reader's queues.
#[derive(Debug, Clone, Copy)]
struct SampleMessage {
    /// The value as written; NaN for a dropout.
    value: f64,
    quality: SampleQuality,
}

/// Why a message is not a sample (boxed: rare, and it keeps [`Item`] small).
type NotASample = Box<String>;

/// Parses a message as a sample. JSON has no NaN, but recorders and historians write a
/// dropout as a bare `NaN`; that one token after `"value":` is read as `null`.
fn parse_sample(data: &[u8]) -> std::result::Result<SampleMessage, NotASample> {
    if let Some((value, quality)) = super::compact::parse(data) {
        let quality = match quality {
            CompactQuality::Good => SampleQuality::Good,
            CompactQuality::Uncertain => SampleQuality::Uncertain,
            CompactQuality::Bad => SampleQuality::Bad,
        };
        return Ok(SampleMessage { value, quality });
    }
    parse_json(data)
        .map(|s| SampleMessage {
            value: s.value.unwrap_or(f64::NAN),
            quality: s.quality,
        })
        .map_err(Box::new)
}

fn parse_json(data: &[u8]) -> std::result::Result<SampleJson, String> {
    serde_json::from_slice::<SampleJson>(data).or_else(|e| {
        let text = std::str::from_utf8(data).map_err(|_| e.to_string())?;
        let key = text.find("\"value\"").ok_or_else(|| e.to_string())?;
        let after = &text[key + 7..];
        let colon = after.trim_start();
        let Some(rest) = colon.strip_prefix(':') else {
            return Err(e.to_string());
        };
        let token = rest.trim_start();
        let end = token
            .find([',', '}', ' ', '\n', '\t', '\r'])
            .unwrap_or(token.len());
        if !is_nan_word(&token[..end]) {
            return Err(e.to_string());
        }
        let start = text.len() - token.len();
        let patched = format!("{}null{}", &text[..start], &token[end..]);
        serde_json::from_str::<SampleJson>(&patched).map_err(|_| e.to_string())
    })
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
    /// Samples per channel given to the sink (and not taken back).
    pub samples_per_channel: Vec<u64>,
    /// Samples marked `bad` and dropped.
    pub bad_quality_dropped: u64,
    /// Per channel: samples outside the quantity's physical range, dropped.
    pub implausible_per_channel: Vec<u64>,
    /// Per channel: the earliest implausible sample (time, value in the canonical unit).
    pub first_implausible: Vec<Option<(u64, f64)>>,
    /// Per channel: dropouts (a `value` of `null` or NaN), left out like `bad` samples.
    pub dropouts_per_channel: Vec<u64>,
    /// Per channel: the time of the earliest dropout, ns since the epoch.
    pub first_dropout: Vec<Option<u64>>,
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
#[derive(Debug, Clone, Copy)]
enum ChannelRoute {
    Sensor(usize),
    Ignored,
}

/// The route of each channel id, indexed by the id: looked up once per message, where a
/// hashed map's SipHash was a few per cent of a full-rate replay.
#[derive(Debug, Default)]
struct Routes(Vec<Option<ChannelRoute>>);

impl Routes {
    fn get(&self, id: &u16) -> Option<&ChannelRoute> {
        self.0.get(usize::from(*id)).and_then(Option::as_ref)
    }

    fn contains_key(&self, id: &u16) -> bool {
        self.get(id).is_some()
    }

    fn insert(&mut self, id: u16, route: ChannelRoute) {
        let at = usize::from(id);
        if self.0.len() <= at {
            self.0.resize(at + 1, None);
        }
        self.0[at] = Some(route);
    }
}

/// Readings below zero of one channel of a non-negative quantity, given to the sink
/// provisionally: whether they are noise or a fault is judged once the whole file (and
/// with it the nameplate's rated value) has been read.
#[derive(Debug, Default)]
struct NegativeReadings {
    /// The most negative readings, at most [`MAX_NEGATIVE_KEPT`]; the least negative on top.
    deepest: BinaryHeap<Reading>,
    /// Whether readings were left out of `deepest` because it was full.
    overflowed: bool,
    /// The channel's largest reading: the scale when the nameplate has no rated value.
    largest: f64,
}

/// Negative readings kept per channel for the final verdict.
const MAX_NEGATIVE_KEPT: usize = 1 << 16;

/// A reading ordered by value, then time: a total order, so which readings are kept
/// does not depend on the order they arrive in.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Reading {
    value: f64,
    log_time_ns: u64,
}

impl Eq for Reading {}

impl Ord for Reading {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        self.value
            .total_cmp(&other.value)
            .then(self.log_time_ns.cmp(&other.log_time_ns))
    }
}

impl PartialOrd for Reading {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}

impl NegativeReadings {
    fn keep(&mut self, reading: Reading) {
        if self.deepest.len() < MAX_NEGATIVE_KEPT {
            self.deepest.push(reading);
        } else if self.deepest.peek().is_some_and(|top| reading < *top) {
            self.deepest.pop();
            self.deepest.push(reading);
            self.overflowed = true;
        } else {
            self.overflowed = true;
        }
    }
}

struct Reader<'s, S: SampleSink> {
    path: PathBuf,
    sink: &'s mut S,
    options: ReadOptions,
    summary: RecordingSummary,
    schemas: HashMap<u16, SchemaInfo>,
    routes: Routes,
    /// Per channel, for channels of a non-negative quantity.
    negatives: Vec<Option<NegativeReadings>>,
    /// Whether the Data End record (the end of the data section) was read.
    seen_data_end: bool,
    /// Messages applied so far, and when the progress observer was last told.
    messages: u64,
    throttle: Throttle,
    /// The file offset read up to, by the last batch merged.
    bytes_done: u64,
    /// The offset at the last look at the progress clock.
    bytes_at_clock: u64,
}

/// Reads the heat-run recording at `path`, giving its samples to `sink`; channels
/// outside the profile are skipped ([`read_recording_with`] reads named ones too).
///
/// Fails with a one-line error naming the file (and the channel and time where
/// they apply) when the file is not MCAP, a heat-run channel is malformed, or a
/// message is not a sample. Damage after the start (a cut, a corrupt chunk) is
/// recovered from and listed in [`RecordingSummary::data_loss`].
pub fn read_recording<S: SampleSink>(path: &Path, sink: &mut S) -> Result<RecordingSummary> {
    read_recording_with(path, sink, &ReadOptions::default())
}

/// [`read_recording`] with options (free channels to read).
pub fn read_recording_with<S: SampleSink>(
    path: &Path,
    sink: &mut S,
    options: &ReadOptions,
) -> Result<RecordingSummary> {
    // A URL (s3://, gs://, az://, https://) is streamed from its store by one GET: the
    // same single pass as a local file, through the same reader.
    let location = Location::from_path(path)?;
    if location.is_remote() {
        let opened = crate::store::open(&location)?;
        return read_stream_with(opened.reader, path, opened.bytes, sink, options);
    }
    let file = std::fs::File::open(path).map_err(|source| RecordingError::ReadInput {
        path: path.to_owned(),
        source,
    })?;
    let file_bytes = file.metadata().map(|m| m.len()).unwrap_or(0);
    read_stream_with(file, path, file_bytes, sink, options)
}

/// Reads a recording from any byte stream (a file, memory); `path` names it in
/// messages and `stream_bytes` is its length, when known, for the data-loss report.
pub fn read_stream<S: SampleSink>(
    file: impl Read + Send,
    path: &Path,
    stream_bytes: u64,
    sink: &mut S,
) -> Result<RecordingSummary> {
    read_stream_with(file, path, stream_bytes, sink, &ReadOptions::default())
}

/// Checks the start of the stream: MCAP magic, or a named refusal (empty, Git LFS pointer).
fn check_magic(file: &mut impl Read, path: &Path) -> Result<()> {
    let bad = |message: &str| RecordingError::BadRecording {
        path: path.to_owned(),
        message: message.to_owned(),
    };
    let mut magic = [0u8; 8];
    let got = read_full(file, &mut magic).map_err(|source| RecordingError::ReadInput {
        path: path.to_owned(),
        source,
    })?;
    if got == 0 {
        return Err(bad("the file is empty, not an MCAP recording"));
    }
    if magic.starts_with(b"version ") {
        let mut head = vec![0u8; 64];
        let n = read_full(file, &mut head).unwrap_or(0);
        if [&magic[..], &head[..n]]
            .concat()
            .starts_with(b"version https://git-lfs")
        {
            return Err(bad(
                "is a Git LFS pointer, not the MCAP data it stands for; fetch the data with `git lfs pull`",
            ));
        }
    }
    if got < 8 || magic != *mcap::MAGIC {
        return Err(bad(
            "not an MCAP file (it does not start with the MCAP magic bytes)",
        ));
    }
    Ok(())
}

/// [`read_stream`] with options.
pub fn read_stream_with<S: SampleSink>(
    mut file: impl Read + Send,
    path: &Path,
    stream_bytes: u64,
    sink: &mut S,
    options: &ReadOptions,
) -> Result<RecordingSummary> {
    check_magic(&mut file, path)?;
    let mut merger = Reader {
        path: path.to_owned(),
        sink,
        options: options.clone(),
        summary: RecordingSummary {
            path: path.to_owned(),
            file_bytes: stream_bytes,
            ..Default::default()
        },
        schemas: HashMap::new(),
        routes: Routes::default(),
        negatives: Vec::new(),
        seen_data_end: false,
        messages: 0,
        throttle: Throttle::default(),
        bytes_done: 0,
        bytes_at_clock: 0,
    };
    // Three stages, so that both cores work: this thread's scan reads the file and
    // cuts it into records and whole chunks; workers decompress chunks and parse their
    // messages; the merger (the calling thread) takes the results back in file order and
    // feeds the sink. Bounded queues keep memory constant whatever the file's length.
    let workers = std::thread::available_parallelism()
        .map_or(2, |n| n.get())
        .clamp(1, 4);
    // Buffers go back for reuse (compressed chunks to the scan, item lists to the
    // workers), so that reading allocates nothing per chunk once it runs.
    let (work_tx, work_rx) = crossbeam_channel::bounded::<ChunkWork>(workers);
    let (done_tx, done_rx) = crossbeam_channel::bounded::<DecodedBatch>(workers);
    let (spare_data_tx, spare_data_rx) = crossbeam_channel::bounded::<Vec<u8>>(2 * workers);
    let (spare_items_tx, spare_items_rx) = crossbeam_channel::bounded::<Vec<Item>>(2 * workers);
    std::thread::scope(|scope| {
        for _ in 0..workers {
            let queues = (work_rx.clone(), done_tx.clone());
            let spares = (spare_data_tx.clone(), spare_items_rx.clone());
            scope.spawn(move || decode_chunks(queues, spares));
        }
        drop((work_rx, spare_data_tx, spare_items_rx));
        let scan_done = done_tx.clone();
        drop(done_tx);
        scope.spawn(move || scan(file, work_tx, scan_done, spare_data_rx));
        merger.merge(done_rx, spare_items_tx)
    })?;
    Ok(merger.summary)
}

/// How far the file must advance between two looks at the progress clock, bytes.
const PROGRESS_GRAIN_BYTES: u64 = 1 << 16;

/// A chunk to decode: its number in file order, the file offset where it ends, its
/// header and its compressed records.
type ChunkWork = (u64, u64, ChunkHeader, Vec<u8>);

/// A worker: decodes the chunks it is given until the scan ends or the merger stops.
fn decode_chunks(
    (work, done): (
        crossbeam_channel::Receiver<ChunkWork>,
        crossbeam_channel::Sender<DecodedBatch>,
    ),
    (spare_data, spare_items): (
        crossbeam_channel::Sender<Vec<u8>>,
        crossbeam_channel::Receiver<Vec<Item>>,
    ),
) {
    let mut decoder = super::chunk::ChunkDecoder::default();
    for (seq, bytes_end, header, data) in work {
        let mut items = spare_items.try_recv().unwrap_or_default();
        let decoded = decode_chunk(&mut decoder, &header, &data, &mut items);
        let _ = spare_data.try_send(data);
        let batch = DecodedBatch::Records {
            seq,
            chunk_start: header.message_start_time,
            bytes_end,
            items: decoded.map(|()| items),
        };
        if done.send(batch).is_err() {
            break;
        }
    }
}

/// The decoded records of one piece of the file (a chunk, or a record outside chunks),
/// numbered in file order by `seq`, or the end of the scan.
enum DecodedBatch {
    /// The records of a chunk (`Err`: the chunk is damaged) or one record outside chunks.
    Records {
        seq: u64,
        /// The chunk's declared start time (0 outside chunks), to name a damaged chunk.
        chunk_start: u64,
        /// The file offset just after the record: how far the file has been read.
        bytes_end: u64,
        items: std::result::Result<Vec<Item>, ChunkError>,
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

/// One record's content, owned, as the merger needs it. Messages are nearly all of
/// them, so the rare records are boxed and an item stays at 32 bytes.
enum Item {
    Schema(Box<(u16, SchemaInfo)>),
    Channel(Box<mcap::records::Channel>),
    /// A message with its payload parsed as a sample (or why not); `stray` when its time
    /// lies outside the time range its chunk declares (a damaged timestamp).
    Message {
        channel_id: u16,
        log_time: u64,
        sample: std::result::Result<SampleMessage, NotASample>,
        stray: bool,
    },
    Metadata(Box<mcap::records::Metadata>),
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
        Record::Schema { header, .. } => Item::Schema(Box::new((
            header.id,
            SchemaInfo {
                name: header.name,
                encoding: header.encoding,
            },
        ))),
        Record::Channel(c) => Item::Channel(Box::new(c)),
        Record::Message { header, data } => Item::Message {
            channel_id: header.channel_id,
            log_time: header.log_time,
            sample: parse_sample(&data),
            stray: false,
        },
        Record::Metadata(m) => Item::Metadata(Box::new(m)),
        Record::DataEnd(_) => Item::DataEnd,
        _ => return None,
    })
}

/// Decompresses a chunk and parses its records into `items` (emptied first); any damage
/// drops the whole chunk.
fn decode_chunk(
    decoder: &mut super::chunk::ChunkDecoder,
    header: &ChunkHeader,
    data: &[u8],
    items: &mut Vec<Item>,
) -> std::result::Result<(), ChunkError> {
    items.clear();
    let plain = decoder.decompress(header, data)?;
    for record in super::chunk::records(plain) {
        let (opcode, body) = record?;
        if !wanted(opcode) {
            continue;
        }
        if let Some((channel_id, log_time, data)) = message_fields(opcode, body) {
            items.push(Item::Message {
                channel_id,
                log_time,
                sample: parse_sample(data),
                stray: log_time < header.message_start_time || log_time > header.message_end_time,
            });
            continue;
        }
        let record = mcap::parse_record(opcode, body).map_err(|e| ChunkError::BadRecord {
            opcode,
            message: e.to_string(),
        })?;
        let mut it = item(record);
        if let Some(Item::Message {
            log_time, stray, ..
        }) = it.as_mut()
        {
            *stray = *log_time < header.message_start_time || *log_time > header.message_end_time;
        }
        items.extend(it);
    }
    Ok(())
}

/// A message record's channel id, log time and payload, read from its fixed layout
/// (channel id u16, sequence u32, log time u64, publish time u64, little-endian, then
/// the payload): nine in ten records of a recording are messages, and the general record
/// parser (binrw) cost more than the sample's own reading. `None` for any other record.
fn message_fields(opcode: u8, body: &[u8]) -> Option<(u16, u64, &[u8])> {
    const HEADER: usize = 2 + 4 + 8 + 8;
    if opcode != mcap::records::op::MESSAGE || body.len() < HEADER {
        return None;
    }
    let channel_id = u16::from_le_bytes([body[0], body[1]]);
    let log_time = u64::from_le_bytes(body[6..14].try_into().ok()?);
    Some((channel_id, log_time, &body[HEADER..]))
}

/// Reads the file front to back: records outside chunks are parsed here, chunks go to
/// the workers whole. Ends with a [`DecodedBatch::End`].
fn scan(
    mut file: impl Read,
    work: crossbeam_channel::Sender<ChunkWork>,
    done: crossbeam_channel::Sender<DecodedBatch>,
    spare_data: crossbeam_channel::Receiver<Vec<u8>>,
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
                let at = (seq, last_record_end + 9 + len);
                let sent = match forward(opcode, data, at, &work, &done, &spare_data) {
                    Ok(sent) => sent,
                    Err(what) => {
                        break ScanEnd::Damaged {
                            last_record_end,
                            what,
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
    let _ = done.send(DecodedBatch::End { seq, end });
}

/// Hands a wanted record on: a chunk to the workers (copied into a recycled buffer), any
/// other record, parsed, to the merger; `at` is its number in file order and the offset
/// where it ends. `Ok(false)`: the merger stopped; `Err`: the record is damaged.
fn forward(
    opcode: u8,
    data: &[u8],
    (seq, bytes_end): (u64, u64),
    work: &crossbeam_channel::Sender<ChunkWork>,
    done: &crossbeam_channel::Sender<DecodedBatch>,
    spare_data: &crossbeam_channel::Receiver<Vec<u8>>,
) -> std::result::Result<bool, String> {
    match mcap::parse_record(opcode, data) {
        Ok(Record::Chunk { header, data }) => {
            let mut buf = spare_data.try_recv().unwrap_or_default();
            buf.clear();
            buf.extend_from_slice(&data);
            Ok(work.send((seq, bytes_end, header, buf)).is_ok())
        }
        Ok(record) => Ok(done
            .send(DecodedBatch::Records {
                seq,
                chunk_start: 0,
                bytes_end,
                items: Ok(item(record).into_iter().collect()),
            })
            .is_ok()),
        Err(e) => Err(format!("a damaged record (opcode {opcode:#04x}): {e}")),
    }
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
    fn bad(&self, message: String) -> RecordingError {
        RecordingError::BadRecording {
            path: self.path.clone(),
            message,
        }
    }

    /// Takes the decoded batches back in file order and applies them; their emptied item
    /// lists go back to the workers.
    fn merge(
        &mut self,
        done: crossbeam_channel::Receiver<DecodedBatch>,
        spare_items: crossbeam_channel::Sender<Vec<Item>>,
    ) -> Result<()> {
        let mut waiting: BTreeMap<u64, DecodedBatch> = BTreeMap::new();
        let mut next = 0u64;
        for batch in done.iter() {
            let seq = match &batch {
                DecodedBatch::Records { seq, .. } | DecodedBatch::End { seq, .. } => *seq,
            };
            waiting.insert(seq, batch);
            while let Some(batch) = waiting.remove(&next) {
                next += 1;
                match batch {
                    DecodedBatch::Records {
                        chunk_start,
                        bytes_end,
                        items,
                        ..
                    } => {
                        match items {
                            Ok(mut items) => {
                                for item in items.drain(..) {
                                    self.apply(item)?;
                                }
                                let _ = spare_items.try_send(items);
                            }
                            Err(why) => self.summary.data_loss.push(format!(
                                "the chunk starting at {} is damaged ({why}); its messages were dropped",
                                format_time(chunk_start)
                            )),
                        }
                        // The clock is read once per 64 KiB at most: a file of records
                        // outside chunks is a batch per message.
                        self.bytes_done = bytes_end;
                        let at = &mut self.bytes_at_clock;
                        if bytes_end >= *at + PROGRESS_GRAIN_BYTES || *at == 0 {
                            *at = bytes_end;
                            if self.throttle.due() {
                                self.report_progress(bytes_end);
                            }
                        }
                    }
                    DecodedBatch::End { end, .. } => {
                        // The whole stream was taken in, whether or not its end was usable.
                        self.report_progress(self.summary.file_bytes.max(self.bytes_done));
                        self.finish(end)?;
                        self.judge_negative_readings();
                        return Ok(());
                    }
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
                return Err(RecordingError::ReadInput {
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
                // A stream (standard input) has no size up front: what arrived is its size.
                let total = file_bytes.max(consumed);
                self.summary.data_loss.push(format!(
                    "the file is cut short: it ends mid-record after byte {last_record_end} of {total}, \
                     with no summary; the last {} bytes were not usable (last complete sample: {last})",
                    total.saturating_sub(last_record_end)
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

    /// Tells the observer how far the file has been read.
    fn report_progress(&self, bytes_done: u64) {
        self.options
            .progress
            .reading(bytes_done, self.summary.file_bytes, self.messages);
    }

    fn apply(&mut self, item: Item) -> Result<()> {
        match item {
            Item::Schema(schema) => {
                let (id, info) = *schema;
                self.schemas.insert(id, info);
            }
            Item::Channel(channel) => self.channel(*channel)?,
            Item::Message {
                channel_id,
                log_time,
                sample,
                stray,
            } => {
                self.messages += 1;
                if stray {
                    if let Some(ChannelRoute::Sensor(i)) = self.routes.get(&channel_id) {
                        let value = sample.as_ref().map_or(f64::NAN, |s| s.value);
                        self.implausible(*i, log_time, value);
                    }
                    return Ok(());
                }
                if let Some(sample) = self.message(channel_id, log_time, sample)? {
                    self.deliver(sample);
                }
            }
            Item::Metadata(meta) => {
                let meta = *meta;
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
        if let Some(watch) = self.negatives[sample.channel].as_mut() {
            watch.largest = watch.largest.max(sample.value);
            if sample.value < 0.0 {
                watch.keep(Reading {
                    value: sample.value,
                    log_time_ns: t,
                });
            }
        }
        self.sink.sample(sample);
    }

    /// Counts an implausible sample; the channel's first is the earliest in time.
    fn implausible(&mut self, channel: usize, log_time: u64, value: f64) {
        self.summary.implausible_per_channel[channel] += 1;
        let first = &mut self.summary.first_implausible[channel];
        let earlier = |(t, v): (u64, f64)| log_time.cmp(&t).then(value.total_cmp(&v)).is_lt();
        if first.is_none_or(earlier) {
            *first = Some((log_time, value));
        }
    }

    fn channel(&mut self, channel: mcap::records::Channel) -> Result<()> {
        if self.routes.contains_key(&channel.id) {
            // A repeated channel record (the summary repeats them): already known.
            return Ok(());
        }
        let schema = self
            .schemas
            .get(&channel.schema_id)
            .map(|s| (s.name.as_str(), s.encoding.as_str()));
        let index = self.summary.channels.len();
        let kind =
            classify(&channel, schema, index, &self.options.free_channels).map_err(|source| {
                RecordingError::Channel {
                    path: self.path.clone(),
                    source,
                }
            })?;
        let sensor = match kind {
            ChannelKind::Ignored(ignored) => {
                self.summary.ignored_channels.push(ignored);
                self.routes.insert(channel.id, ChannelRoute::Ignored);
                return Ok(());
            }
            ChannelKind::Sensor(sensor) => sensor,
        };
        self.sink.channel(&sensor);
        let non_negative = sensor.quantity().is_some_and(|q| q.is_non_negative());
        self.negatives
            .push(non_negative.then(NegativeReadings::default));
        self.summary.channels.push(sensor);
        self.summary.samples_per_channel.push(0);
        self.summary.implausible_per_channel.push(0);
        self.summary.first_implausible.push(None);
        self.summary.dropouts_per_channel.push(0);
        self.summary.first_dropout.push(None);
        self.routes.insert(channel.id, ChannelRoute::Sensor(index));
        Ok(())
    }

    fn message(
        &mut self,
        channel_id: u16,
        log_time: u64,
        sample: std::result::Result<SampleMessage, NotASample>,
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
        let raw = parsed.value;
        if raw.is_nan() {
            self.summary.dropouts_per_channel[index] += 1;
            let first = &mut self.summary.first_dropout[index];
            *first = Some(first.map_or(log_time, |t| t.min(log_time)));
            return Ok(None);
        }
        let ch = &self.summary.channels[index];
        let value = raw * ch.unit_scale;
        if let Some(quantity) = ch.quantity() {
            let (lo, hi) = quantity.plausible_range();
            // Below zero but within the range's size: kept for now, judged at the end.
            let provisional = quantity.is_non_negative() && value < lo && value >= -hi;
            if !provisional && !(lo..=hi).contains(&value) {
                self.implausible(index, log_time, value);
                return Ok(None);
            }
        }
        Ok(Some(Sample {
            channel: index,
            log_time_ns: log_time,
            value,
        }))
    }

    /// Judges the negative readings of non-negative quantities once the file is read:
    /// down to −[`ZERO_NOISE_FRACTION`] of the rated value (from the nameplate record;
    /// without one, of the channel's largest reading) they are transducer noise around
    /// zero and stay; below, they are faults, taken back from the sink and counted as
    /// implausible.
    fn judge_negative_readings(&mut self) {
        for index in 0..self.negatives.len() {
            let Some(watch) = self.negatives[index].take() else {
                continue;
            };
            let ch = &self.summary.channels[index];
            let rated = ch
                .quantity()
                .and_then(|q| q.rated_key())
                .and_then(|(key, factor)| self.summary.nameplate.value(key).map(|v| v * factor))
                .filter(|v| *v > 0.0);
            let scale = rated.unwrap_or(watch.largest.max(0.0));
            let floor = -ZERO_NOISE_FRACTION * scale;
            let least_kept = watch.deepest.peek().map(|r| r.value);
            let mut taken = 0u64;
            for reading in watch.deepest.into_vec() {
                if reading.value < floor {
                    let sample = Sample {
                        channel: index,
                        log_time_ns: reading.log_time_ns,
                        value: reading.value,
                    };
                    self.sink.retract(sample);
                    self.summary.samples_per_channel[index] -= 1;
                    self.implausible(index, reading.log_time_ns, reading.value);
                    taken += 1;
                }
            }
            if watch.overflowed && least_kept.is_some_and(|v| v < floor) {
                let ch = &self.summary.channels[index];
                self.summary.notes.push(format!(
                    "channel {}: more than {taken} readings lie below {floor} {} (far below zero); \
                     the {taken} lowest were dropped, the others kept",
                    ch.topic,
                    ch.canonical_unit()
                ));
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::recording::{Quantity, Signal};

    /// Records what it is given.
    #[derive(Default)]
    struct Collect {
        channels: Vec<SensorChannel>,
        samples: Vec<Sample>,
    }

    impl SampleSink for Collect {
        fn channel(&mut self, channel: &SensorChannel) {
            self.channels.push(channel.clone());
        }
        fn sample(&mut self, sample: Sample) {
            self.samples.push(sample);
        }
        fn retract(&mut self, sample: Sample) {
            let at = self.samples.iter().position(|s| *s == sample).unwrap();
            self.samples.remove(at);
        }
    }

    const T0: u64 = 1_600_000_000_000_000_000;

    /// A recording of channels `(topic, unit, payloads)`, one message a second each, stored
    /// in the order `order` gives (channel, message) pairs; a nameplate record at the end.
    fn recording(
        channels: &[(&str, &str, Vec<&str>)],
        order: &[(usize, usize)],
        nameplate: &[(&str, &str)],
    ) -> Vec<u8> {
        let mut w = mcap::Writer::new(std::io::Cursor::new(Vec::new())).unwrap();
        let schema = w
            .add_schema(SAMPLE_SCHEMA_NAME, SAMPLE_SCHEMA_ENCODING, b"{}")
            .unwrap();
        let ids: Vec<u16> = channels
            .iter()
            .map(|(topic, unit, _)| {
                let meta = BTreeMap::from([("unit".to_owned(), unit.to_string())]);
                w.add_channel(schema, topic, "json", &meta).unwrap()
            })
            .collect();
        for &(c, i) in order {
            let t = T0 + i as u64 * 1_000_000_000;
            let header = mcap::records::MessageHeader {
                channel_id: ids[c],
                sequence: i as u32,
                log_time: t,
                publish_time: t,
            };
            w.write_to_known_channel(&header, channels[c].2[i].as_bytes())
                .unwrap();
        }
        let metadata = nameplate
            .iter()
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect();
        w.write_metadata(&mcap::records::Metadata {
            name: NAMEPLATE_RECORD.into(),
            metadata,
        })
        .unwrap();
        w.finish().unwrap();
        w.into_inner().into_inner()
    }

    fn in_order(channels: &[(&str, &str, Vec<&str>)]) -> Vec<(usize, usize)> {
        let n = channels.iter().map(|c| c.2.len()).max().unwrap_or(0);
        (0..n)
            .flat_map(|i| (0..channels.len()).map(move |c| (c, i)))
            .filter(|&(c, i)| i < channels[c].2.len())
            .collect()
    }

    fn read(bytes: &[u8], options: &ReadOptions) -> Result<(RecordingSummary, Collect)> {
        let mut sink = Collect::default();
        let summary = read_stream_with(
            bytes,
            Path::new("r.mcap"),
            bytes.len() as u64,
            &mut sink,
            options,
        )?;
        Ok((summary, sink))
    }

    /// The paper's rated current and voltage, as the nameplate record holds them.
    const RATED: [(&str, &str); 2] = [
        ("rated_current_a", "3689.14"),
        ("rated_voltage_kv", "15.65"),
    ];

    /// A stream of unknown size (standard input) cut short: the line counts the bytes
    /// that arrived, not "of 0".
    #[test]
    fn a_stream_of_unknown_size_cut_short_names_the_bytes_that_arrived() {
        let values: Vec<String> = (0..400).map(|i| format!("{{\"value\": {i}.5}}")).collect();
        let payloads: Vec<&str> = values.iter().map(String::as_str).collect();
        let channels = [("/scada/core_temp", "degC", payloads)];
        let bytes = recording(&channels, &in_order(&channels), &RATED);
        let cut = &bytes[..bytes.len() * 2 / 3];
        let mut sink = Collect::default();
        let options = ReadOptions::default();
        let summary = read_stream_with(cut, Path::new("-"), 0, &mut sink, &options).unwrap();
        let line = summary.data_loss.join("\n");
        let arrived = cut.len();
        assert!(line.contains(&format!(" of {arrived},")), "{line}");
        let unusable: u64 = line
            .split("the last ")
            .nth(1)
            .and_then(|rest| rest.split(' ').next())
            .and_then(|n| n.parse().ok())
            .unwrap_or_else(|| panic!("{line}"));
        assert!(unusable > 0 && unusable < arrived as u64, "{line}");
    }

    #[test]
    fn a_decoded_message_is_small() {
        // A chunk's decoded messages wait in the reader's queues: 32 bytes each keeps a
        // 1 MiB chunk of 20,000 messages under 1 MB.
        assert!(
            std::mem::size_of::<Item>() <= 32,
            "{}",
            std::mem::size_of::<Item>()
        );
    }

    #[test]
    fn a_message_records_fields_are_read_as_the_record_parser_reads_them() {
        let mut body = Vec::new();
        body.extend_from_slice(&7u16.to_le_bytes());
        body.extend_from_slice(&42u32.to_le_bytes());
        body.extend_from_slice(&1_559_541_600_123_456_789u64.to_le_bytes());
        body.extend_from_slice(&9u64.to_le_bytes());
        body.extend_from_slice(b"{\"value\":25.5}");
        let op = mcap::records::op::MESSAGE;
        let Ok(Record::Message { header, data }) = mcap::parse_record(op, &body) else {
            panic!("a message record");
        };
        assert_eq!(
            message_fields(op, &body),
            Some((header.channel_id, header.log_time, &data[..]))
        );
        assert_eq!(message_fields(op, &body[..21]), None);
        assert_eq!(message_fields(mcap::records::op::METADATA, &body), None);
    }

    /// Every `reading` call the reader makes.
    #[derive(Default)]
    struct ProgressLog(std::sync::Mutex<Vec<(u64, u64, u64)>>);

    impl crate::progress::Progress for ProgressLog {
        fn reading(&self, done: u64, total: u64, messages: u64) {
            self.0.lock().unwrap().push((done, total, messages));
        }
    }

    #[test]
    fn progress_ends_at_the_whole_file_and_every_message() {
        let payloads: Vec<&str> = vec![r#"{"value": 40.0}"#; 500];
        let channels = [
            ("/scada/core_temp", "degC", payloads.clone()),
            ("/scada/stator_winding_temp", "degC", payloads),
        ];
        let bytes = recording(&channels, &in_order(&channels), &RATED);
        let log = std::sync::Arc::new(ProgressLog::default());
        let options = ReadOptions {
            progress: Observer::shared(log.clone()),
            ..ReadOptions::default()
        };
        read(&bytes, &options).unwrap();
        let calls = log.0.lock().unwrap().clone();
        // The first batch (a record before the chunks) is reported at once, the end
        // always; in between at most ten a second.
        assert!(calls.len() >= 2, "{calls:?}");
        let total = bytes.len() as u64;
        assert_eq!(*calls.last().unwrap(), (total, total, 1000));
        assert!(calls
            .iter()
            .all(|&(done, t, _)| t == total && done <= total));
        assert!(calls
            .windows(2)
            .all(|w| w[0].0 <= w[1].0 && w[0].2 <= w[1].2));
    }

    #[test]
    fn dropouts_are_counted_and_left_out() {
        let payloads = vec![
            r#"{"value": 40.0}"#,
            r#"{"value": null}"#,
            r#"{"value":NaN}"#,
            r#"{ "value" : -nan , "quality": "good"}"#,
            r#"{"value": "NaN"}"#,
            r#"{"value": 41.5, "quality": "uncertain"}"#,
        ];
        let channels = [("/scada/core_temp", "degC", payloads)];
        let bytes = recording(&channels, &in_order(&channels), &RATED);
        let (summary, sink) = read(&bytes, &ReadOptions::default()).unwrap();
        assert_eq!(summary.dropouts_per_channel, vec![4]);
        assert_eq!(summary.first_dropout, vec![Some(T0 + 1_000_000_000)]);
        let values: Vec<f64> = sink.samples.iter().map(|s| s.value).collect();
        assert_eq!(values, vec![40.0, 41.5]);
        assert_eq!(summary.samples_per_channel, vec![2]);
        // Reversed storage: the same count, the same earliest dropout.
        let reversed: Vec<_> = in_order(&channels).into_iter().rev().collect();
        let (summary, _) = read(
            &recording(&channels, &reversed, &RATED),
            &ReadOptions::default(),
        )
        .unwrap();
        assert_eq!(summary.first_dropout, vec![Some(T0 + 1_000_000_000)]);
    }

    #[test]
    fn a_message_that_is_not_a_sample_is_an_error() {
        for payload in [
            r#"{"quality": "good"}"#,
            r#"{"value": "hot"}"#,
            r#"{"value": 1e999}"#,
            r#"[1, 2]"#,
            r#"NaN"#,
            r#"{"value": NaNa}"#,
        ] {
            let channels = [("/scada/core_temp", "degC", vec![r#"{"value": 1}"#, payload])];
            let bytes = recording(&channels, &in_order(&channels), &RATED);
            let msg = match read(&bytes, &ReadOptions::default()) {
                Err(e) => e.to_string(),
                Ok(_) => panic!("{payload} was read"),
            };
            assert!(
                msg.contains("/scada/core_temp") && msg.contains("2020-09-13T12:26:41Z"),
                "{payload}: {msg}"
            );
        }
    }

    /// An armature current around zero load: noise of ±0.3 % of the rated 3689 A, and one
    /// reading of −3 kA (a fault), in kA.
    fn zero_load() -> Vec<String> {
        let mut v: Vec<String> = (0..200)
            .map(|i| format!(r#"{{"value": {}}}"#, 0.011 * ((i as f64) * 0.7).sin()))
            .collect();
        v[120] = r#"{"value": -3.0}"#.into();
        v[40] = r#"{"value": -2.5}"#.into();
        v[199] = r#"{"value": 3.5}"#.into(); // and once at load
        v
    }

    #[test]
    fn negative_noise_around_zero_is_kept_and_faults_are_dropped() {
        let payloads = zero_load();
        let channels = [(
            "/scada/armature_current",
            "kA",
            payloads.iter().map(String::as_str).collect::<Vec<_>>(),
        )];
        let expect_mean: f64 = ((0..199)
            .filter(|i| *i != 120 && *i != 40)
            .map(|i| 11.0 * ((i as f64) * 0.7).sin())
            .sum::<f64>()
            + 3500.0)
            / 198.0;
        let forward = in_order(&channels);
        let backward: Vec<_> = forward.iter().rev().copied().collect();
        for (order, nameplate) in [
            (&forward, &RATED[..]),
            (&backward, &RATED[..]),
            (&forward, &[][..]),
        ] {
            let bytes = recording(&channels, order, nameplate);
            let (summary, sink) = read(&bytes, &ReadOptions::default()).unwrap();
            // Without a nameplate the scale is the channel's largest reading (3.5 kA).
            assert_eq!(summary.implausible_per_channel, vec![2]);
            assert_eq!(
                summary.first_implausible,
                vec![Some((T0 + 40_000_000_000, -2500.0))]
            );
            assert_eq!(summary.samples_per_channel, vec![198]);
            assert_eq!(sink.samples.len(), 198);
            let mean = sink.samples.iter().map(|s| s.value).sum::<f64>() / 198.0;
            assert!((mean - expect_mean).abs() < 1e-9, "{mean} vs {expect_mean}");
            assert!(sink.samples.iter().filter(|s| s.value < 0.0).count() > 80);
        }
    }

    #[test]
    fn temperatures_out_of_range_are_dropped() {
        let channels = [(
            "/scada/core_temp",
            "degC",
            vec![r#"{"value": 40}"#, r#"{"value": 1e9}"#, r#"{"value": -61}"#],
        )];
        let (summary, sink) = read(
            &recording(&channels, &in_order(&channels), &RATED),
            &ReadOptions::default(),
        )
        .unwrap();
        assert_eq!(summary.implausible_per_channel, vec![2]);
        assert_eq!(
            summary.first_implausible,
            vec![Some((T0 + 1_000_000_000, 1e9))]
        );
        assert_eq!(sink.samples.len(), 1);
    }

    #[test]
    fn free_channels_are_read_when_named() {
        let channels = [
            (
                "/lab/T1",
                "degC",
                vec![r#"{"value": 21.5}"#, r#"{"value": 500}"#],
            ),
            ("/lab/Q1", "%", vec![r#"{"value": -5}"#]),
            ("/scada/core_temp", "degC", vec![r#"{"value": 40}"#]),
        ];
        let bytes = recording(&channels, &in_order(&channels), &RATED);
        let (summary, sink) = read(&bytes, &ReadOptions::default()).unwrap();
        assert_eq!(summary.channels.len(), 1);
        assert_eq!(summary.ignored_channels.len(), 2);
        let options = ReadOptions {
            free_channels: ["T1".to_owned(), "Q1".to_owned()].into(),
            ..ReadOptions::default()
        };
        let (summary, sink2) = read(&bytes, &options).unwrap();
        let signals: Vec<&Signal> = summary.channels.iter().map(|c| &c.signal).collect();
        assert_eq!(
            signals,
            vec![
                &Signal::Free("T1".into()),
                &Signal::Free("Q1".into()),
                &Signal::Profile(Quantity::CoreTemp)
            ]
        );
        assert_eq!(sink2.channels.len(), 3);
        // No unit conversion and no plausibility range for a free channel.
        let values: Vec<f64> = sink2
            .samples
            .iter()
            .filter(|s| s.channel < 2)
            .map(|s| s.value)
            .collect();
        assert_eq!(values, vec![21.5, -5.0, 500.0]);
        assert_eq!(summary.channels[1].unit, "%");
        assert_eq!(sink.samples.len(), 1);
    }
}
