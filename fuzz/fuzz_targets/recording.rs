//! Fuzz target: arbitrary bytes through the recording → grid path.
//!
//! Whatever the bytes, reading must end in a summary or an error — never a panic,
//! a hang or an unbounded allocation — and the grid builder must finish what was read.
#![no_main]

use std::path::Path;

use heatrun::grid::GridBuilder;
use heatrun::recording::read_stream;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let mut grid = GridBuilder::whole(1.0, heatrun::spec::ModelDescription::generator().alignments()).expect("a valid sample time");
    if let Ok(summary) = read_stream(data, Path::new("fuzz.mcap"), data.len() as u64, &mut grid) {
        if !summary.channels.is_empty() {
            let _ = grid.finish(&summary.channels);
        }
    }
});
