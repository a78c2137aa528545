//! Chunk records, decoded here rather than by the `mcap` crate's chunk reader so that
//! a damaged size never turns into an allocation: the decompressed size is bounded
//! before anything is reserved, every record length is checked against what is left,
//! and the CRC is checked before any record is used.

use mcap::records::ChunkHeader;

/// Largest decompressed chunk accepted, bytes.
pub const MAX_CHUNK_BYTES: u64 = 1 << 30;
/// Largest expansion accepted from a compressed chunk (no real data compress 1000:1).
pub const MAX_EXPANSION: u64 = 1000;

/// Why a chunk cannot be used. A damaged chunk is dropped whole and named in the
/// recording's data-loss list.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ChunkError {
    /// The header claims more decompressed bytes than the stored ones can hold.
    #[error("it claims {claimed} bytes from {stored} stored ones (a damaged header)")]
    ImplausibleSize {
        /// Decompressed size in the header.
        claimed: u64,
        /// Compressed bytes stored.
        stored: u64,
    },
    /// The compression is not one MCAP defines.
    #[error("its compression `{0}` is not one MCAP defines")]
    UnknownCompression(String),
    /// The compressed stream is broken.
    #[error("{compression}: {message}")]
    Decompression {
        /// `zstd` or `lz4`.
        compression: &'static str,
        /// The decompressor's message.
        message: String,
    },
    /// The decompressed size differs from the header's.
    #[error("it holds {actual} bytes where its header says {declared}")]
    SizeMismatch {
        /// Size in the header.
        declared: u64,
        /// Size decompressed.
        actual: u64,
    },
    /// The CRC of the decompressed records differs from the header's.
    #[error("its CRC is {calculated:#010x}, its header says {saved:#010x}")]
    BadChunkCrc {
        /// CRC in the header.
        saved: u32,
        /// CRC of the records as read.
        calculated: u32,
    },
    /// The records end inside a record header.
    #[error("a record header is cut short")]
    RecordHeaderCut,
    /// A record claims more bytes than the chunk has left.
    #[error("a record claims {claimed} bytes, more than the {left} the chunk has left")]
    RecordTooLong {
        /// The record's length field.
        claimed: u64,
        /// Bytes left in the chunk.
        left: u64,
    },
    /// A record inside the chunk cannot be parsed.
    #[error("a damaged record (opcode {opcode:#04x}): {message}")]
    BadRecord {
        /// The record's opcode.
        opcode: u8,
        /// The parser's message.
        message: String,
    },
}

/// Decompresses a chunk's records field and checks its size and CRC.
#[cfg(test)]
fn decompress(header: &ChunkHeader, data: &[u8]) -> Result<Vec<u8>, ChunkError> {
    let mut decoder = ChunkDecoder::default();
    decoder.decompress(header, data)?;
    Ok(decoder.plain)
}

/// Decompresses chunk after chunk into one buffer and one zstd context, so that a reader
/// thread allocates nothing per chunk once its buffer has grown to the largest chunk.
#[derive(Default)]
pub struct ChunkDecoder {
    zstd: Option<zstd::bulk::Decompressor<'static>>,
    plain: Vec<u8>,
}

impl ChunkDecoder {
    /// Decompresses a chunk's records field, checks its size and CRC, and returns the
    /// records (valid until the next call).
    pub fn decompress(&mut self, header: &ChunkHeader, data: &[u8]) -> Result<&[u8], ChunkError> {
        let size = header.uncompressed_size;
        let limit = (data.len() as u64)
            .saturating_mul(MAX_EXPANSION)
            .saturating_add(1 << 20)
            .min(MAX_CHUNK_BYTES);
        if size > limit {
            return Err(ChunkError::ImplausibleSize {
                claimed: size,
                stored: data.len() as u64,
            });
        }
        let broken = |compression: &'static str| {
            move |e: std::io::Error| ChunkError::Decompression {
                compression,
                message: e.to_string(),
            }
        };
        let out = &mut self.plain;
        out.clear();
        match header.compression.as_str() {
            "" => out.extend_from_slice(data),
            "zstd" => {
                out.reserve(size as usize);
                let zstd = match &mut self.zstd {
                    Some(z) => z,
                    None => self
                        .zstd
                        .insert(zstd::bulk::Decompressor::new().map_err(broken("zstd"))?),
                };
                zstd.decompress_to_buffer(data, out)
                    .map_err(broken("zstd"))?;
            }
            "lz4" => {
                use std::io::Read;
                let decoder = lz4::Decoder::new(data).map_err(broken("lz4"))?;
                out.reserve(size as usize);
                decoder
                    .take(size + 1)
                    .read_to_end(out)
                    .map_err(broken("lz4"))?;
            }
            other => return Err(ChunkError::UnknownCompression(other.to_owned())),
        }
        if out.len() as u64 != size {
            return Err(ChunkError::SizeMismatch {
                declared: size,
                actual: out.len() as u64,
            });
        }
        if header.uncompressed_crc != 0 {
            let calculated = crc32fast::hash(out);
            if calculated != header.uncompressed_crc {
                return Err(ChunkError::BadChunkCrc {
                    saved: header.uncompressed_crc,
                    calculated,
                });
            }
        }
        Ok(&self.plain)
    }
}

/// The records (opcode, body) of a decompressed chunk, each length checked.
pub fn records(mut buf: &[u8]) -> impl Iterator<Item = Result<(u8, &[u8]), ChunkError>> {
    std::iter::from_fn(move || {
        if buf.is_empty() {
            return None;
        }
        if buf.len() < 9 {
            buf = &[];
            return Some(Err(ChunkError::RecordHeaderCut));
        }
        let opcode = buf[0];
        let len = u64::from_le_bytes(buf[1..9].try_into().unwrap_or([0; 8]));
        let left = (buf.len() - 9) as u64;
        if len > left {
            buf = &[];
            return Some(Err(ChunkError::RecordTooLong { claimed: len, left }));
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
        assert_eq!(
            decompress(&h, &packed).unwrap_err(),
            ChunkError::BadChunkCrc {
                saved: crc32fast::hash(&plain) ^ 1,
                calculated: crc32fast::hash(&plain)
            }
        );
        let recs: Vec<_> = records(&plain).collect();
        assert_eq!(recs, vec![Ok((5u8, &b"abc"[..]))]);
    }

    #[test]
    fn damaged_sizes_are_refused_before_allocating() {
        let plain = vec![0u8; 100];
        let mut h = header("zstd", &plain, &plain);
        h.uncompressed_size = 244_038_804_808_138_844;
        assert_eq!(
            decompress(&h, &plain).unwrap_err(),
            ChunkError::ImplausibleSize {
                claimed: 244_038_804_808_138_844,
                stored: 100
            }
        );
        let bad = [1u8, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0x7f, 1, 2];
        assert_eq!(
            records(&bad).next().unwrap(),
            Err(ChunkError::RecordTooLong {
                claimed: 0x7fff_ffff_ffff_ffff,
                left: 2
            })
        );
        assert_eq!(
            records(&bad[..5]).next().unwrap(),
            Err(ChunkError::RecordHeaderCut)
        );
        let mut h = header("brotli", &plain, &plain);
        assert_eq!(
            decompress(&h, &plain).unwrap_err().to_string(),
            "its compression `brotli` is not one MCAP defines"
        );
        h.compression = String::new();
        h.uncompressed_size = 99;
        assert_eq!(
            decompress(&h, &plain).unwrap_err(),
            ChunkError::SizeMismatch {
                declared: 99,
                actual: 100
            }
        );
    }
}
