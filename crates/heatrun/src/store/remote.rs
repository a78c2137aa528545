//! The object-store client behind a blocking API: each operation builds the cloud's
//! client from its standard environment variables and drives it on a small
//! current-thread tokio runtime of its own, so the rest of the library stays synchronous.

use std::io::Read;
use std::ops::Range;
use std::path::Path as LocalPath;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

use bytes::Bytes;
use futures::stream::{BoxStream, StreamExt};
use object_store::path::Path;
use object_store::{ObjectStore, ObjectStoreScheme, PutPayload, WriteMultipart};
use tokio::runtime::Runtime;
use url::Url;

use super::StoreError;

/// Parts of a multipart upload: S3's smallest but the last is 5 MiB; 8 MiB keeps a
/// fleet's .rrd files at a few parts each.
const PART_BYTES: usize = 8 << 20;

/// One object (or prefix) in its store, with the runtime that drives the client.
pub(super) struct Remote {
    runtime: Arc<Runtime>,
    store: Arc<dyn ObjectStore>,
    key: Path,
    url: String,
    /// Bytes received from the store by this handle and the readers it opened.
    fetched: Arc<AtomicU64>,
}

impl Remote {
    /// The client for `url`'s store, configured from the environment: `AWS_*` for S3
    /// (`AWS_ENDPOINT_URL`, `AWS_ALLOW_HTTP` for a local server), `GOOGLE_*` for GCS,
    /// `AZURE_*` for Azure; plain HTTP(S) servers need none.
    pub(super) fn new(url: &Url) -> Result<Remote, StoreError> {
        let text = url.as_str();
        let bad = |reason: String| StoreError::BadUrl {
            url: text.to_owned(),
            reason,
        };
        let (scheme, key) = ObjectStoreScheme::parse(url).map_err(|e| bad(e.to_string()))?;
        let store = client(scheme, url).map_err(|e| StoreError::from_store(text, &e))?;
        let runtime = tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()
            .map_err(|e| bad(format!("cannot start the storage client: {e}")))?;
        Ok(Remote {
            runtime: Arc::new(runtime),
            store,
            key,
            url: text.to_owned(),
            fetched: Arc::new(AtomicU64::new(0)),
        })
    }

    /// Bytes received so far by this handle and its readers.
    pub(super) fn fetched(&self) -> Arc<AtomicU64> {
        self.fetched.clone()
    }

    /// The store's error for this URL. A missing object is told from a missing bucket
    /// by one listing of the key (a HEAD's 404 has no body to say which).
    fn error(&self, e: &object_store::Error) -> StoreError {
        let error = StoreError::from_store(&self.url, e);
        if !matches!(error, StoreError::NoSuchObject { .. }) {
            return error;
        }
        match self
            .runtime
            .block_on(self.store.list_with_delimiter(Some(&self.key)))
        {
            Err(listing) => match StoreError::from_store(&self.url, &listing) {
                bucket @ StoreError::NoSuchBucket { .. } => bucket,
                _ => error,
            },
            Ok(_) => error,
        }
    }

    /// The object's length, by a HEAD request.
    pub(super) fn size(&self) -> Result<u64, StoreError> {
        let meta = self.runtime.block_on(self.store.head(&self.key));
        meta.map(|m| m.size).map_err(|e| self.error(&e))
    }

    /// The object as a stream, one GET read as it arrives; its length too.
    pub(super) fn reader(self) -> Result<(StreamReader, u64), StoreError> {
        let got = self.runtime.block_on(self.store.get(&self.key));
        let got = got.map_err(|e| self.error(&e))?;
        let bytes = got.meta.size;
        let reader = StreamReader {
            stream: got.into_stream(),
            current: Bytes::new(),
            runtime: self.runtime,
            url: self.url,
            fetched: self.fetched,
        };
        Ok((reader, bytes))
    }

    /// Bytes `range` of the object, by one ranged GET.
    pub(super) fn read_range(&self, range: Range<u64>) -> Result<Bytes, StoreError> {
        let got = self
            .runtime
            .block_on(self.store.get_range(&self.key, range));
        let got = got.map_err(|e| self.error(&e))?;
        self.fetched.fetch_add(got.len() as u64, Ordering::Relaxed);
        Ok(got)
    }

    /// The names of the objects directly under this prefix (not in deeper "folders").
    pub(super) fn list_names(&self) -> Result<Vec<String>, StoreError> {
        let prefix = (!self.key.as_ref().is_empty()).then_some(&self.key);
        let listed = self
            .runtime
            .block_on(self.store.list_with_delimiter(prefix));
        let listed = listed.map_err(|e| self.error(&e))?;
        Ok(listed
            .objects
            .into_iter()
            .filter_map(|o| o.location.filename().map(str::to_owned))
            .collect())
    }

    /// Writes the object whole, by one PUT: it exists complete or not at all.
    pub(super) fn put(&self, bytes: Vec<u8>) -> Result<(), StoreError> {
        let put = self.store.put(&self.key, PutPayload::from(bytes));
        self.runtime
            .block_on(put)
            .map(|_| ())
            .map_err(|e| self.error(&e))
    }

    /// Uploads a local file: one PUT when small, else a multipart upload, which the store
    /// shows only once completed (and which is aborted on failure): complete or absent.
    pub(super) fn upload(&self, local: &LocalPath) -> Result<(), StoreError> {
        let local_error = |source| StoreError::Local {
            path: local.to_owned(),
            source,
        };
        let mut file = std::fs::File::open(local).map_err(local_error)?;
        let length = file.metadata().map_err(local_error)?.len();
        if length <= PART_BYTES as u64 {
            let mut bytes = Vec::with_capacity(length as usize);
            file.read_to_end(&mut bytes).map_err(local_error)?;
            return self.put(bytes);
        }
        let result = self.runtime.block_on(async {
            let upload = self.store.put_multipart(&self.key).await?;
            let mut writer = WriteMultipart::new_with_chunk_size(upload, PART_BYTES);
            let mut buffer = vec![0u8; PART_BYTES];
            loop {
                let n = match file.read(&mut buffer) {
                    Ok(0) => break,
                    Ok(n) => n,
                    Err(e) => {
                        writer.abort().await?;
                        return Ok(Err(local_error(e)));
                    }
                };
                writer.wait_for_capacity(2).await?;
                writer.write(&buffer[..n]);
            }
            writer.finish().await.map(|_| Ok(()))
        });
        result.map_err(|e| self.error(&e))?
    }
}

/// The cloud's client for a URL of its scheme, from its standard environment variables.
fn client(scheme: ObjectStoreScheme, url: &Url) -> object_store::Result<Arc<dyn ObjectStore>> {
    use object_store::aws::AmazonS3Builder;
    use object_store::azure::MicrosoftAzureBuilder;
    use object_store::gcp::GoogleCloudStorageBuilder;
    use object_store::http::HttpBuilder;
    let text = url.as_str();
    Ok(match scheme {
        ObjectStoreScheme::AmazonS3 => {
            Arc::new(AmazonS3Builder::from_env().with_url(text).build()?)
        }
        ObjectStoreScheme::GoogleCloudStorage => Arc::new(
            GoogleCloudStorageBuilder::from_env()
                .with_url(text)
                .build()?,
        ),
        ObjectStoreScheme::MicrosoftAzure => {
            Arc::new(MicrosoftAzureBuilder::from_env().with_url(text).build()?)
        }
        ObjectStoreScheme::Http => {
            // The server's root; the object's path is the key.
            let root = &url[..url::Position::BeforePath];
            Arc::new(HttpBuilder::new().with_url(root).build()?)
        }
        _ => {
            return Err(object_store::Error::NotSupported {
                source: format!("{} is not a remote store", url.scheme()).into(),
            })
        }
    })
}

/// An object read as a stream of its GET response's chunks: `Read` for the recording
/// reader, each chunk awaited on the handle's runtime.
pub(super) struct StreamReader {
    stream: BoxStream<'static, object_store::Result<Bytes>>,
    current: Bytes,
    runtime: Arc<Runtime>,
    url: String,
    fetched: Arc<AtomicU64>,
}

impl Read for StreamReader {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        while self.current.is_empty() {
            match self.runtime.block_on(self.stream.next()) {
                None => return Ok(0),
                Some(Ok(chunk)) => {
                    self.fetched
                        .fetch_add(chunk.len() as u64, Ordering::Relaxed);
                    self.current = chunk;
                }
                Some(Err(e)) => {
                    let said = StoreError::from_store(&self.url, &e);
                    return Err(std::io::Error::other(said.to_string()));
                }
            }
        }
        let n = buf.len().min(self.current.len());
        buf[..n].copy_from_slice(&self.current.split_to(n));
        Ok(n)
    }
}
