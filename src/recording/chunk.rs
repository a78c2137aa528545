//! Chunk records, decoded here rather than by the `mcap` crate's chunk reader so that
//! a damaged size never turns into an allocation: the decompressed size is bounded
//! before anything is reserved, every record length is checked against what is left,
//! and the CRC is checked before any record is used.

use mcap::records::ChunkHeader;

/// Largest decompressed chunk accepted, bytes.
pub const MAX_CHUNK_BYTES: u64 = 1 << 30;
/// Largest expansion accepted from a compressed chunk (no real data compress 1000:1).
pub const MAX_EXPANSION: u64 = 1000;

/// Decompresses a chunk's records field and checks its size and CRC.
pub fn decompress(header: &ChunkHeader, data: &[u8]) -> Result<Vec<u8>, String> {
    let size = header.uncompressed_size;
    let limit = (data.len() as u64)
        .saturating_mul(MAX_EXPANSION)
        .saturating_add(1 << 20)
        .min(MAX_CHUNK_BYTES);
    if size > limit {
        return Err(format!(
            "it claims {size} bytes from {} stored ones (a damaged header)",
            data.len()
        ));
    }
    let out = match header.compression.as_str() {
        "" => data.to_vec(),
        "zstd" => zstd::bulk::decompress(data, size as usize).map_err(|e| format!("zstd: {e}"))?,
        "lz4" => {
            use std::io::Read;
            let decoder = lz4::Decoder::new(data).map_err(|e| format!("lz4: {e}"))?;
            let mut out = Vec::with_capacity(size as usize);
            decoder
                .take(size + 1)
                .read_to_end(&mut out)
                .map_err(|e| format!("lz4: {e}"))?;
            out
        }
        other => return Err(format!("its compression `{other}` is not one MCAP defines")),
    };
    if out.len() as u64 != size {
        return Err(format!(
            "it holds {} bytes where its header says {size}",
            out.len()
        ));
    }
    if header.uncompressed_crc != 0 {
        let crc = crc32fast::hash(&out);
        if crc != header.uncompressed_crc {
            return Err(format!(
                "its CRC is {crc:#010x}, its header says {:#010x}",
                header.uncompressed_crc
            ));
        }
    }
    Ok(out)
}

/// The records (opcode, body) of a decompressed chunk, each length checked.
pub fn records(mut buf: &[u8]) -> impl Iterator<Item = Result<(u8, &[u8]), String>> {
    std::iter::from_fn(move || {
        if buf.is_empty() {
            return None;
        }
        if buf.len() < 9 {
            buf = &[];
            return Some(Err("a record header is cut short".into()));
        }
        let opcode = buf[0];
        let len = u64::from_le_bytes(buf[1..9].try_into().unwrap_or([0; 8]));
        if len > (buf.len() - 9) as u64 {
            buf = &[];
            return Some(Err(format!(
                "a record claims {len} bytes, more than the chunk holds"
            )));
        }
        let body = &buf[9..9 + len as usize];
        buf = &buf[9 + len as usize..];
        Some(Ok((opcode, body)))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn header(compression: &str, data: &[u8], plain: &[u8]) -> ChunkHeader {
        ChunkHeader {
            message_start_time: 0,
            message_end_time: 0,
            uncompressed_size: plain.len() as u64,
            uncompressed_crc: crc32fast::hash(plain),
            compression: compression.into(),
            compressed_size: data.len() as u64,
        }
    }

    #[test]
    fn zstd_and_plain_round_trip_and_crc_is_checked() {
        let plain = b"\x05\x03\x00\x00\x00\x00\x00\x00\x00abc".to_vec();
        let packed = zstd::bulk::compress(&plain, 3).unwrap();
        assert_eq!(
            decompress(&header("zstd", &packed, &plain), &packed).unwrap(),
            plain
        );
        assert_eq!(
            decompress(&header("", &plain, &plain), &plain).unwrap(),
            plain
        );
        let mut h = header("zstd", &packed, &plain);
        h.uncompressed_crc ^= 1;
        assert!(decompress(&h, &packed).unwrap_err().contains("CRC"));
        let recs: Vec<_> = records(&plain).collect();
        assert_eq!(recs, vec![Ok((5u8, &b"abc"[..]))]);
    }

    #[test]
    fn damaged_sizes_are_refused_before_allocating() {
        let plain = vec![0u8; 100];
        let mut h = header("zstd", &plain, &plain);
        h.uncompressed_size = 244_038_804_808_138_844;
        assert!(decompress(&h, &plain)
            .unwrap_err()
            .contains("damaged header"));
        let bad = [1u8, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0x7f, 1, 2];
        assert!(records(&bad).next().unwrap().is_err());
    }
}
