//! Rewrites a recording with its messages stored in another order, as recorders, merge
//! tools and historian exports write them. Shared by `tests/corpus.rs` and
//! `benches/replay.rs` (which includes this file by path).
#![allow(dead_code)]

use std::collections::BTreeMap;
use std::io::BufWriter;
use std::path::Path;

/// An order of storing a recording's messages. The times, payloads, sequence numbers and
/// metadata stay as they are; only where each message sits in the file changes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Order {
    /// Time order, in chunks of about 1 MiB (the reference).
    Time,
    /// A seeded random permutation of all messages; the metadata records at the end
    /// (as a recorder writes them when it closes the file).
    Shuffled(u64),
    /// Time order cut into chunks of `n` messages, the chunks written last first.
    ReversedChunks(usize),
    /// Two recorders merged: the channels split into two groups (alternate channels),
    /// each group in time order in chunks of its own size (`a` and `b` messages), the
    /// chunks of the two written alternately, so neighbouring chunks overlap in time.
    MergedRecorders(usize, usize),
    /// Each channel in its own chunks of `n` messages, one channel after another (a
    /// recorder that buffers per channel).
    ChannelByChannel(usize),
}

impl Order {
    /// A short name for file names and messages.
    pub fn name(self) -> &'static str {
        match self {
            Order::Time => "time",
            Order::Shuffled(_) => "shuffled",
            Order::ReversedChunks(_) => "reversed-chunks",
            Order::MergedRecorders(..) => "merged-recorders",
            Order::ChannelByChannel(_) => "channel-by-channel",
        }
    }
}

/// One message, its payload in the arena.
#[derive(Debug, Clone, Copy)]
struct Stored {
    /// Index into the channel list.
    channel: usize,
    sequence: u32,
    log_time: u64,
    publish_time: u64,
    /// Payload's range in the arena.
    start: usize,
    end: usize,
}

/// A channel as the writer needs it: schema (name, encoding, data), topic, encoding, metadata.
type ChannelDef = (
    Option<(String, String, Vec<u8>)>,
    String,
    String,
    BTreeMap<String, String>,
);

/// A recording read into memory: channels, metadata records, messages in time order.
struct Recording {
    channels: Vec<ChannelDef>,
    metadata: Vec<mcap::records::Metadata>,
    messages: Vec<Stored>,
    arena: Vec<u8>,
}

fn read(path: &Path) -> Recording {
    let bytes = std::fs::read(path).expect("the source recording");
    let mut metadata = Vec::new();
    for record in mcap::read::LinearReader::new(&bytes).expect("an MCAP file") {
        if let mcap::records::Record::Metadata(m) = record.expect("a valid record") {
            metadata.push(m);
        }
    }
    let mut index_of: BTreeMap<u16, usize> = BTreeMap::new();
    let mut channels = Vec::new();
    let (mut messages, mut arena) = (Vec::new(), Vec::new());
    for message in mcap::MessageStream::new(&bytes).expect("an MCAP file") {
        let message = message.expect("a valid message");
        let ch = &message.channel;
        let channel = *index_of.entry(ch.id).or_insert_with(|| {
            let schema = ch
                .schema
                .as_ref()
                .map(|s| (s.name.clone(), s.encoding.clone(), s.data.to_vec()));
            channels.push((
                schema,
                ch.topic.clone(),
                ch.message_encoding.clone(),
                ch.metadata.clone(),
            ));
            channels.len() - 1
        });
        let start = arena.len();
        arena.extend_from_slice(&message.data);
        messages.push(Stored {
            channel,
            sequence: message.sequence,
            log_time: message.log_time,
            publish_time: message.publish_time,
            start,
            end: arena.len(),
        });
    }
    // Time order, ties in the source's order: the reference every order starts from.
    messages.sort_by_key(|m| m.log_time);
    Recording {
        channels,
        metadata,
        messages,
        arena,
    }
}

/// A seeded permutation (Fisher–Yates on a 64-bit LCG): the same on every machine.
pub fn shuffle<T>(items: &mut [T], seed: u64) {
    let mut state = seed
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    for i in (1..items.len()).rev() {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        items.swap(i, (state >> 33) as usize % (i + 1));
    }
}

/// The messages (indices into the time-ordered list) grouped into the chunks to write,
/// in file order. `None` for the chunks: let the writer cut them by size.
fn chunks(order: Order, rec: &Recording) -> (Vec<Vec<usize>>, bool) {
    let all: Vec<usize> = (0..rec.messages.len()).collect();
    let cut = |ids: &[usize], n: usize| ids.chunks(n.max(1)).map(<[usize]>::to_vec).collect();
    match order {
        Order::Time => (vec![all], false),
        Order::Shuffled(seed) => {
            let mut ids = all;
            shuffle(&mut ids, seed);
            (vec![ids], false)
        }
        Order::ReversedChunks(n) => {
            let mut c: Vec<Vec<usize>> = cut(&all, n);
            c.reverse();
            (c, true)
        }
        Order::MergedRecorders(a, b) => {
            let group = |g: usize| -> Vec<usize> {
                all.iter()
                    .copied()
                    .filter(|&i| rec.messages[i].channel % 2 == g)
                    .collect()
            };
            let (first, second): (Vec<Vec<usize>>, Vec<Vec<usize>>) =
                (cut(&group(0), a), cut(&group(1), b));
            let mut merged = Vec::new();
            for i in 0..first.len().max(second.len()) {
                merged.extend(first.get(i).cloned());
                merged.extend(second.get(i).cloned());
            }
            (merged, true)
        }
        Order::ChannelByChannel(n) => {
            let c = (0..rec.channels.len())
                .flat_map(|ch| {
                    let ids: Vec<usize> = all
                        .iter()
                        .copied()
                        .filter(|&i| rec.messages[i].channel == ch)
                        .collect();
                    cut(&ids, n)
                })
                .collect();
            (c, true)
        }
    }
}

/// Writes the recording at `src` to `dst` with its messages stored in `order`, zstd
/// chunks (each chunk one group of the order where the order cuts them).
pub fn rewrite(src: &Path, dst: &Path, order: Order) {
    let rec = read(src);
    let (groups, cut_by_order) = chunks(order, &rec);
    let options = mcap::WriteOptions::new()
        .compression(Some(mcap::Compression::Zstd))
        .chunk_size(if cut_by_order { None } else { Some(1 << 20) });
    let file = std::fs::File::create(dst).expect("the rewritten recording");
    let mut w = options.create(BufWriter::new(file)).expect("a writer");
    let ids: Vec<u16> = rec
        .channels
        .iter()
        .map(|(schema, topic, encoding, meta)| {
            let schema_id = match schema {
                Some((name, enc, data)) => w.add_schema(name, enc, data).expect("schema"),
                None => 0,
            };
            w.add_channel(schema_id, topic, encoding, meta)
                .expect("channel")
        })
        .collect();
    let metadata_last = matches!(order, Order::Shuffled(_));
    if !metadata_last {
        for m in &rec.metadata {
            w.write_metadata(m).expect("metadata");
        }
    }
    for group in groups {
        for i in group {
            let m = rec.messages[i];
            let header = mcap::records::MessageHeader {
                channel_id: ids[m.channel],
                sequence: m.sequence,
                log_time: m.log_time,
                publish_time: m.publish_time,
            };
            w.write_to_known_channel(&header, &rec.arena[m.start..m.end])
                .expect("message");
        }
        if cut_by_order {
            w.flush().expect("a chunk");
        }
    }
    if metadata_last {
        for m in &rec.metadata {
            w.write_metadata(m).expect("metadata");
        }
    }
    w.finish().expect("the summary");
}

/// The chunks of a file that hold messages, as (start, end) log times, in file order, from
/// its chunk indexes.
pub fn chunk_ranges(path: &Path) -> Vec<(u64, u64)> {
    let bytes = std::fs::read(path).expect("a recording");
    let summary = mcap::Summary::read(&bytes)
        .expect("a summary")
        .expect("a summary section");
    let mut ranges: Vec<(u64, u64, u64)> = summary
        .chunk_indexes
        .iter()
        // A chunk of channel records alone declares the time range (0, 0).
        .filter(|c| (c.message_start_time, c.message_end_time) != (0, 0))
        .map(|c| {
            (
                c.chunk_start_offset,
                c.message_start_time,
                c.message_end_time,
            )
        })
        .collect();
    ranges.sort_unstable();
    ranges.into_iter().map(|(_, a, b)| (a, b)).collect()
}
