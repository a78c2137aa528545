//! Recording stage: an MCAP heat run → typed samples, units and nameplate.
//!
//! Input: a file in the heatrun SCADA MCAP profile. Output: [`Sample`]s in
//! canonical units pushed to a [`SampleSink`] as the file streams by, and a
//! [`RecordingSummary`] (channels, nameplate entries, metadata, data loss).

mod channel;
mod chunk;
mod compact;
mod error;
mod index;
mod nameplate;
mod quantity;
mod reader;

pub use channel::{ChannelError, Interpolation, Storage, CHANNEL_METADATA_KEYS};
pub use error::RecordingError;
pub use index::{read_index, IndexedChannel, RecordingIndex};
pub use nameplate::{Nameplate, NameplateEntries, NameplateKey, NAMEPLATE_KEYS, NAMEPLATE_RECORD};
pub use quantity::{Alignment, Quantity, Signal};
pub use reader::{
    format_time, read_recording, read_recording_with, read_stream, read_stream_with,
    IgnoredChannel, ReadOptions, RecordingSummary, Sample, SampleSink, SensorChannel, Tee,
    SAMPLE_MESSAGE_ENCODING, SAMPLE_SCHEMA_ENCODING, SAMPLE_SCHEMA_NAME,
};
