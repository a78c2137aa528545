//! The parts of rerun's SDK the publisher uses, under the names the `rerun` crate gives
//! them (`rerun::Scalars`, `rerun::log::Chunk`, …).
//!
//! They come from `re_sdk` and `re_sdk_types`, the crates the `rerun` crate re-exports,
//! not from `rerun` itself: whatever its features, `rerun` always builds the viewer's
//! store and query engine (`re_entity_db`, `re_chunk_store`, `re_query`), the data
//! platform's client and its authentication (`re_redap_client`, `re_auth`: `ring`,
//! `jsonwebtoken`, OpenTelemetry), analytics and a memory profiler (`backtrace`, `gimli`):
//! 57 packages of a clean build that a recording stream never calls
//! (docs/src/contributing.md#build-timings). What an .rrd holds, and the gRPC stream to a
//! viewer, are the same: `rerun`'s `RecordingStream` is `re_sdk`'s.

pub use re_sdk::log;
pub use re_sdk::log::TimeColumn;
pub use re_sdk::{
    external, AsComponents, RecordingStream, RecordingStreamBuilder, RecordingStreamResult,
    SerializedComponentBatch, StoreKind, TimelineName,
};
/// Blueprint archetypes and components, component and data types: `rerun::external::re_sdk_types`.
pub use re_sdk_types as types;
pub use re_sdk_types::archetypes::{
    BarChart, GraphEdges, GraphNodes, Scalars, SeriesLines, TextDocument,
};
pub use re_sdk_types::components::MediaType;
