//! Fuzz target: arbitrary bytes through the recording → decimator path.
//!
//! Whatever the bytes, reading must end in a summary or an error — never a panic,
//! a hang or an unbounded allocation — and the decimator must finish what was read.
#![no_main]

use std::path::Path;

use heatrun::decimate::Decimator;
use heatrun::recording::read_stream;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let mut decimator = Decimator::new(1.0, heatrun::spec::ModelDescription::generator().alignments()).expect("a valid sample time");
    if let Ok(summary) = read_stream(data, Path::new("fuzz.mcap"), data.len() as u64, &mut decimator) {
        if !summary.channels.is_empty() {
            let _ = decimator.finish(&summary.channels);
        }
    }
});
