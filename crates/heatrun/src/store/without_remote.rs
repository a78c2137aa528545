//! The store's client in a build without the `object-store` feature: there is none, so
//! a remote URL is refused in one line saying how to build heatrun with it. [`Remote`]
//! has no values; its methods exist so that `store` reads the same either way.

use std::io::Empty;
use std::ops::Range;
use std::path::Path as LocalPath;
use std::sync::atomic::AtomicU64;
use std::sync::Arc;

use url::Url;

use super::StoreError;

/// No remote object can be opened in this build (an empty enum: no value exists).
pub(super) enum Remote {}

impl Remote {
    /// Always [`StoreError::NotBuilt`], naming the URL.
    pub(super) fn new(url: &Url) -> Result<Remote, StoreError> {
        Err(StoreError::NotBuilt {
            url: url.as_str().to_owned(),
        })
    }

    pub(super) fn fetched(&self) -> Arc<AtomicU64> {
        match *self {}
    }

    pub(super) fn size(&self) -> Result<u64, StoreError> {
        match *self {}
    }

    pub(super) fn reader(self) -> Result<(Empty, u64), StoreError> {
        match self {}
    }

    pub(super) fn read_range(&self, _range: Range<u64>) -> Result<Vec<u8>, StoreError> {
        match *self {}
    }

    pub(super) fn list_names(&self) -> Result<Vec<String>, StoreError> {
        match *self {}
    }

    pub(super) fn put(&self, _bytes: Vec<u8>) -> Result<(), StoreError> {
        match *self {}
    }

    pub(super) fn upload(&self, _local: &LocalPath) -> Result<(), StoreError> {
        match *self {}
    }
}
