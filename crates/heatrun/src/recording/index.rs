//! A recording's summary section read by ranged reads: what `heatrun info` shows of a
//! recording in object storage without fetching its data — the footer (28 bytes from the
//! end), the summary section it points to (schemas, channels, statistics, chunk and
//! metadata indexes) and the metadata records the index locates (the nameplate).

use std::collections::BTreeMap;
use std::io::SeekFrom;
use std::path::PathBuf;

use mcap::records::Record;
use mcap::sans_io::summary_reader::{SummaryReadEvent, SummaryReader, SummaryReaderOptions};
use serde::Serialize;

use super::RecordingError;
use crate::store::{Location, RangeReader};

/// Bytes fetched at least per ranged request: the summary's records are read a block at a
/// time rather than one small request each.
const BLOCK_BYTES: u64 = 64 << 10;

/// A channel as the summary section declares it.
#[derive(Debug, Clone, Serialize)]
pub struct IndexedChannel {
    /// The topic.
    pub topic: String,
    /// The channel's metadata (`quantity`, `unit`, `storage`, `sensor`, ...).
    pub metadata: BTreeMap<String, String>,
    /// Messages on it, from the Statistics record.
    pub messages: Option<u64>,
}

/// What a recording's summary section says, and what reading it cost.
#[derive(Debug, Clone, Serialize)]
pub struct RecordingIndex {
    /// The recording.
    pub path: PathBuf,
    /// The file's or object's length, bytes.
    pub object_bytes: u64,
    /// Bytes fetched to read the footer, the summary and the metadata records.
    pub fetched_bytes: u64,
    /// Ranged requests made.
    pub requests: u64,
    /// The channels, by topic.
    pub channels: Vec<IndexedChannel>,
    /// The first and last message's log time, ns (from the Statistics record).
    pub time_span_ns: Option<(u64, u64)>,
    /// Chunks in the data section.
    pub chunks: usize,
    /// The metadata records (the nameplate is `heatrun.nameplate`).
    pub metadata: BTreeMap<String, BTreeMap<String, String>>,
}

/// Reads a recording's summary section and metadata records by ranged reads (a file's
/// seeks, a store's ranged GETs), fetching none of its data section. A recording without
/// a summary section is refused, naming the file: it can only be read whole.
pub fn read_index(location: &Location) -> Result<RecordingIndex, RecordingError> {
    let path = location.to_path();
    let bad = |message: String| RecordingError::BadRecording {
        path: path.clone(),
        message,
    };
    let mut ranges = Ranges::new(RangeReader::open(location)?);
    let summary = read_summary(&mut ranges).map_err(|e| match e {
        Failure::Store(e) => RecordingError::Store(e),
        Failure::Mcap(m) => bad(format!("its summary section cannot be read: {m}")),
    })?;
    let Some(summary) = summary else {
        return Err(bad(
            "has no summary section; read it whole (a local copy) to see its channels".into(),
        ));
    };
    let counts = summary.stats.as_ref().map(|s| &s.channel_message_counts);
    let mut channels: Vec<IndexedChannel> = summary
        .channels
        .values()
        .map(|c| IndexedChannel {
            topic: c.topic.clone(),
            metadata: c.metadata.clone(),
            messages: counts.map(|m| m.get(&c.id).copied().unwrap_or(0)),
        })
        .collect();
    channels.sort_by(|a, b| a.topic.cmp(&b.topic));
    let mut metadata = BTreeMap::new();
    for index in &summary.metadata_indexes {
        let record = ranges
            .reader
            .read_range(index.offset..index.offset + index.length)?;
        metadata.insert(index.name.clone(), metadata_of(&record).map_err(bad)?);
    }
    Ok(RecordingIndex {
        path,
        object_bytes: ranges.reader.length(),
        fetched_bytes: ranges.reader.fetched(),
        requests: ranges.requests,
        channels,
        time_span_ns: summary
            .stats
            .as_ref()
            .filter(|s| s.message_count > 0)
            .map(|s| (s.message_start_time, s.message_end_time)),
        chunks: summary.chunk_indexes.len(),
        metadata,
    })
}

/// A metadata record's key-value pairs, from its bytes (opcode, length, body).
fn metadata_of(record: &[u8]) -> Result<BTreeMap<String, String>, String> {
    let (&op, rest) = record.split_first().ok_or("an empty metadata record")?;
    let body = rest.get(8..).ok_or("a metadata record cut short")?;
    match mcap::parse_record(op, body) {
        Ok(Record::Metadata(m)) => Ok(m.metadata),
        Ok(_) => Err("the metadata index points at another kind of record".into()),
        Err(e) => Err(format!("a metadata record cannot be parsed: {e}")),
    }
}

/// Why the summary could not be read.
enum Failure {
    Store(crate::store::StoreError),
    Mcap(String),
}

/// Drives mcap's sans-IO summary reader over ranged reads.
fn read_summary(ranges: &mut Ranges) -> Result<Option<mcap::Summary>, Failure> {
    let length = ranges.reader.length();
    let options = SummaryReaderOptions::default().with_file_size(length);
    let mut summary = SummaryReader::new_with_options(options);
    let mut position = 0u64;
    while let Some(event) = summary.next_event() {
        match event.map_err(|e| Failure::Mcap(e.to_string()))? {
            SummaryReadEvent::SeekRequest(to) => {
                position = match to {
                    SeekFrom::Start(p) => p,
                    SeekFrom::End(d) => length.saturating_add_signed(d),
                    SeekFrom::Current(d) => position.saturating_add_signed(d),
                };
                summary.notify_seeked(position);
            }
            SummaryReadEvent::ReadRequest(n) => {
                let got = ranges
                    .read_at(position, summary.insert(n))
                    .map_err(Failure::Store)?;
                position += got as u64;
                summary.notify_read(got);
            }
        }
    }
    Ok(summary.finish())
}

/// Ranged reads through a window of at least [`BLOCK_BYTES`], counting requests.
struct Ranges {
    reader: RangeReader,
    start: u64,
    window: Vec<u8>,
    requests: u64,
}

impl Ranges {
    fn new(reader: RangeReader) -> Ranges {
        Ranges {
            reader,
            start: 0,
            window: Vec::new(),
            requests: 0,
        }
    }

    /// Fills `out` from `position` as far as the object goes; the bytes read.
    fn read_at(
        &mut self,
        position: u64,
        out: &mut [u8],
    ) -> Result<usize, crate::store::StoreError> {
        let end = position + out.len() as u64;
        let window_end = self.start + self.window.len() as u64;
        if position < self.start || end > window_end {
            let want = (out.len() as u64).max(BLOCK_BYTES);
            self.window = self.reader.read_range(position..position + want)?;
            self.start = position;
            self.requests += 1;
        }
        let from = (position - self.start) as usize;
        let n = out.len().min(self.window.len().saturating_sub(from));
        out[..n].copy_from_slice(&self.window[from..from + n]);
        Ok(n)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::recording::{read_recording, Sample, SampleSink, SensorChannel};

    /// A sink that keeps nothing: the full read's summary counts the samples.
    struct Count;
    impl SampleSink for Count {
        fn channel(&mut self, _: &SensorChannel) {}
        fn sample(&mut self, _: Sample) {}
        fn retract(&mut self, _: Sample) {}
    }

    fn fixture() -> PathBuf {
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/paper_heat_run.mcap")
    }

    #[test]
    fn the_index_agrees_with_a_full_read_and_fetches_a_small_part() {
        let index = read_index(&Location::Local(fixture())).unwrap();
        let full = read_recording(&fixture(), &mut Count).unwrap();
        assert_eq!(index.object_bytes, full.file_bytes);
        for (i, channel) in full.channels.iter().enumerate() {
            let indexed = index
                .channels
                .iter()
                .find(|c| c.topic == channel.topic)
                .unwrap_or_else(|| panic!("{} not in the index", channel.topic));
            assert_eq!(
                indexed.messages,
                Some(full.samples_per_channel[i]),
                "{}",
                channel.topic
            );
        }
        assert_eq!(index.time_span_ns, full.time_span_ns);
        let nameplate = &index.metadata["heatrun.nameplate"];
        assert_eq!(nameplate.len(), full.nameplate.iter().count());
        println!(
            "index of the fixture: {} of {} bytes fetched ({:.2} %) in {} requests",
            index.fetched_bytes,
            index.object_bytes,
            100.0 * index.fetched_bytes as f64 / index.object_bytes as f64,
            index.requests
        );
        assert!(index.fetched_bytes * 10 < index.object_bytes);
    }
}
