//! Where inputs and outputs live: local paths, or objects in S3, Google Cloud Storage,
//! Azure Blob Storage or on an HTTP(S) server (the `object_store` crate).
//!
//! Every command's input goes through here — recordings (replay, info, monitor,
//! validation) and reports (predict, rating, monitor, HTML) — so a URL works wherever a
//! path does. The recording reader is unchanged: [`open`] gives it a byte stream, one GET
//! read as it arrives, exactly as a local file is read. Outputs to a store are written
//! whole (one PUT) or by a multipart upload the store shows only once complete: complete
//! or absent, as [`crate::atomic`] makes them locally.
//!
//! Credentials, region and endpoint come from each cloud's standard environment variables
//! (for S3: `AWS_ACCESS_KEY_ID`, `AWS_SECRET_ACCESS_KEY`, `AWS_REGION`, `AWS_ENDPOINT_URL`,
//! and `AWS_ALLOW_HTTP=true` for a plain-http endpoint). Errors name the URL and what the
//! store said ([`StoreError`]).
//!
//! The stores' clients are the `object-store` feature (off by default, to keep a clean
//! build of the README's commands within their budget); a build without it reads and
//! writes local paths alike and refuses a URL in one line ([`StoreError::NotBuilt`]).

mod error;
mod location;
#[cfg(feature = "object-store")]
mod remote;
#[cfg(not(feature = "object-store"))]
#[path = "without_remote.rs"]
mod remote;
#[cfg(feature = "object-store")]
mod said;

use std::io::{Read, Seek, SeekFrom};
use std::ops::Range;
use std::path::Path;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

pub use error::StoreError;
pub use location::{Location, REMOTE_SCHEMES};
use remote::Remote;

/// The store's result.
pub type Result<T, E = StoreError> = std::result::Result<T, E>;

/// An input opened for reading: its bytes as a stream, and its length.
pub struct Opened {
    /// The bytes, from the start.
    pub reader: Box<dyn Read + Send>,
    /// The length in bytes (0 where unknown).
    pub bytes: u64,
}

/// Opens a file or an object for one pass from its start (remote: a single streamed GET).
pub fn open(location: &Location) -> Result<Opened> {
    match location {
        Location::Local(path) => {
            let file = std::fs::File::open(path).map_err(|source| StoreError::Local {
                path: path.clone(),
                source,
            })?;
            let bytes = file.metadata().map(|m| m.len()).unwrap_or(0);
            Ok(Opened {
                reader: Box::new(file),
                bytes,
            })
        }
        Location::Remote(url) => {
            let (reader, bytes) = Remote::new(url)?.reader()?;
            Ok(Opened {
                reader: Box::new(reader),
                bytes,
            })
        }
    }
}

/// A whole file or object (a report: small).
pub fn read_all(location: &Location) -> Result<Vec<u8>> {
    let mut opened = open(location)?;
    let mut bytes = Vec::with_capacity(opened.bytes as usize);
    opened
        .reader
        .read_to_end(&mut bytes)
        .map_err(|e| read_error(location, e))?;
    Ok(bytes)
}

/// A whole file or object as UTF-8 text.
pub fn read_to_string(location: &Location) -> Result<String> {
    String::from_utf8(read_all(location)?).map_err(|e| {
        read_error(
            location,
            std::io::Error::new(std::io::ErrorKind::InvalidData, e),
        )
    })
}

/// A read failure of a location, as the store's error.
fn read_error(location: &Location, source: std::io::Error) -> StoreError {
    match location {
        Location::Local(path) => StoreError::Local {
            path: path.clone(),
            source,
        },
        Location::Remote(url) => StoreError::Store {
            url: url.to_string(),
            said: source.to_string(),
        },
    }
}

/// Random access to one file or object: its length, and byte ranges by ranged GETs
/// (for an MCAP file's footer, summary and index without the data between). Counts the
/// bytes it fetched.
pub struct RangeReader {
    source: RangeSource,
    length: u64,
    fetched: Arc<AtomicU64>,
}

enum RangeSource {
    Local(std::fs::File, std::path::PathBuf),
    Remote(Remote),
}

impl RangeReader {
    /// Opens a file, or asks a store for an object's length (HEAD).
    pub fn open(location: &Location) -> Result<RangeReader> {
        match location {
            Location::Local(path) => {
                let local = |source| StoreError::Local {
                    path: path.clone(),
                    source,
                };
                let file = std::fs::File::open(path).map_err(local)?;
                let length = file.metadata().map_err(local)?.len();
                Ok(RangeReader {
                    source: RangeSource::Local(file, path.clone()),
                    length,
                    fetched: Arc::default(),
                })
            }
            Location::Remote(url) => {
                let remote = Remote::new(url)?;
                Ok(RangeReader {
                    length: remote.size()?,
                    fetched: remote.fetched(),
                    source: RangeSource::Remote(remote),
                })
            }
        }
    }

    /// The object's length, bytes.
    pub fn length(&self) -> u64 {
        self.length
    }

    /// Bytes fetched so far by [`RangeReader::read_range`].
    pub fn fetched(&self) -> u64 {
        self.fetched.load(Ordering::Relaxed)
    }

    /// Bytes `range` (clipped to the object's end).
    pub fn read_range(&mut self, range: Range<u64>) -> Result<Vec<u8>> {
        let range = range.start.min(self.length)..range.end.min(self.length);
        match &mut self.source {
            RangeSource::Local(file, path) => {
                let mut bytes = vec![0u8; (range.end - range.start) as usize];
                let local = |source| StoreError::Local {
                    path: path.clone(),
                    source,
                };
                file.seek(SeekFrom::Start(range.start)).map_err(local)?;
                file.read_exact(&mut bytes).map_err(local)?;
                self.fetched
                    .fetch_add(bytes.len() as u64, Ordering::Relaxed);
                Ok(bytes)
            }
            RangeSource::Remote(remote) => Ok(remote.read_range(range)?.to_vec()),
        }
    }
}

/// The files of a folder or the objects directly under a prefix whose names end with
/// `suffix`, sorted by name (a folder's sub-folders, a prefix's deeper keys, are not read).
pub fn list(prefix: &Location, suffix: &str) -> Result<Vec<Location>> {
    let mut names = match prefix {
        Location::Local(folder) => local_names(folder)?,
        Location::Remote(url) => Remote::new(url)?.list_names()?,
    };
    names.retain(|n| n.ends_with(suffix));
    names.sort();
    Ok(names.iter().map(|n| prefix.join(n)).collect())
}

/// The names of a folder's files.
fn local_names(folder: &Path) -> Result<Vec<String>> {
    let local = |source| StoreError::Local {
        path: folder.to_owned(),
        source,
    };
    let mut names = Vec::new();
    for entry in std::fs::read_dir(folder).map_err(local)? {
        let entry = entry.map_err(local)?;
        if entry.file_type().is_ok_and(|t| t.is_file()) {
            names.push(entry.file_name().to_string_lossy().into_owned());
        }
    }
    Ok(names)
}

/// Whether a location names a folder or prefix rather than one file or object: a local
/// folder, or a URL ending in `/`.
pub fn is_folder(location: &Location) -> bool {
    match location {
        Location::Local(path) => path.is_dir(),
        Location::Remote(_) => location.is_remote_prefix(),
    }
}

/// Writes `bytes` to a file (atomically, [`crate::atomic`]) or an object (one PUT).
pub fn put(location: &Location, bytes: &[u8]) -> Result<()> {
    match location {
        Location::Local(path) => {
            crate::atomic::write_atomically(path, bytes).map_err(|e| StoreError::Local {
                path: path.clone(),
                source: std::io::Error::other(e.message),
            })
        }
        Location::Remote(url) => Remote::new(url)?.put(bytes.to_vec()),
    }
}

/// Copies a complete local file to a location: a store gets it whole or not at all (one
/// PUT, or a multipart upload completed only at its end); a local destination is written
/// atomically.
pub fn upload(local: &Path, to: &Location) -> Result<()> {
    match to {
        Location::Local(_) => {
            let bytes = std::fs::read(local).map_err(|source| StoreError::Local {
                path: local.to_owned(),
                source,
            })?;
            put(to, &bytes)
        }
        Location::Remote(url) => Remote::new(url)?.upload(local),
    }
}
