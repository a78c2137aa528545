//! The store's error: the URL, and what the store said, in one line.

use std::path::PathBuf;

/// Why an object could not be read, listed or written. Every variant names the URL (or
/// local path); all are the input's fault (exit status 2) but [`StoreError::Store`],
/// which may be the network's.
#[derive(Debug, thiserror::Error)]
pub enum StoreError {
    /// The text has a storage scheme but is not a URL heatrun can use.
    #[error("{url}: not a usable storage URL: {reason}")]
    BadUrl {
        /// The text as given.
        url: String,
        /// Why.
        reason: String,
    },
    /// The bucket (or container) does not exist.
    #[error("{url}: no such bucket (the store said: {said})")]
    NoSuchBucket {
        /// The object's URL.
        url: String,
        /// The store's own words.
        said: String,
    },
    /// No object at this key.
    #[error("{url}: no such object (the store said: {said})")]
    NoSuchObject {
        /// The object's URL.
        url: String,
        /// The store's own words.
        said: String,
    },
    /// The store refused the credentials, or none were found (none in the environment,
    /// and no instance metadata service answered).
    #[error("{url}: no valid credentials; {hint} (the store said: {said})")]
    NoCredentials {
        /// The object's URL.
        url: String,
        /// What to set, for this URL's store (`credentials_hint`).
        hint: &'static str,
        /// The store's own words.
        said: String,
    },
    /// The credentials are valid but may not do this.
    #[error("{url}: access denied (the store said: {said})")]
    AccessDenied {
        /// The object's URL.
        url: String,
        /// The store's own words.
        said: String,
    },
    /// Anything else the store or the network said.
    #[error("{url}: {said}")]
    Store {
        /// The object's URL.
        url: String,
        /// The store's own words.
        said: String,
    },
    /// A storage URL, given to a build without the `object-store` feature.
    #[error(
        "{url}: this heatrun was built without object storage; build it with \
         `cargo build --release --features object-store` (or copy the object to a local file)"
    )]
    NotBuilt {
        /// The URL as given.
        url: String,
    },
    /// A local file or folder could not be read or written.
    #[error("{path}: {source}")]
    Local {
        /// The file.
        path: PathBuf,
        /// The operating system's error.
        source: std::io::Error,
    },
}

impl StoreError {
    /// Whether the input (a URL, a bucket, a key, the credentials) is at fault rather than
    /// the network or the store: every variant but [`StoreError::Store`].
    pub fn is_bad_input(&self) -> bool {
        !matches!(self, StoreError::Store { .. })
    }
}
