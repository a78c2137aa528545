//! Where an input or output lives: a local path, or an object-store URL.

use std::fmt;
use std::path::{Path, PathBuf};

use url::Url;

use super::StoreError;

/// The URL schemes read through object storage: Amazon S3 (and S3-compatible stores),
/// Google Cloud Storage, Azure Blob Storage, and plain HTTP(S) servers.
pub const REMOTE_SCHEMES: [&str; 9] = [
    "s3", "s3a", "gs", "az", "azure", "abfs", "abfss", "http", "https",
];

/// A recording's, report's or output's place: a file on this machine, or an object (or a
/// prefix of objects, written with a trailing `/`) in a store named by its URL.
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Location {
    /// A local path (a `file://` URL becomes one too).
    Local(PathBuf),
    /// An object-store URL, `s3://bucket/key`.
    Remote(Url),
}

impl Location {
    /// Reads a location as typed: a string with one of [`REMOTE_SCHEMES`] followed by
    /// `://` is a URL (refused if malformed), `file://…` its path, anything else a path.
    pub fn parse(text: &str) -> Result<Location, StoreError> {
        let Some((scheme, _)) = text.split_once("://") else {
            return Ok(Location::Local(PathBuf::from(text)));
        };
        let scheme = scheme.to_ascii_lowercase();
        if scheme == "file" {
            let url = parse_url(text)?;
            return url
                .to_file_path()
                .map(Location::Local)
                .map_err(|()| StoreError::BadUrl {
                    url: text.to_owned(),
                    reason: "not a local file path".into(),
                });
        }
        if !REMOTE_SCHEMES.contains(&scheme.as_str()) {
            return Ok(Location::Local(PathBuf::from(text)));
        }
        let url = parse_url(text)?;
        if url.host_str().is_none_or(str::is_empty) {
            return Err(StoreError::BadUrl {
                url: text.to_owned(),
                reason: "no bucket or host after the scheme".into(),
            });
        }
        Ok(Location::Remote(url))
    }

    /// The location a command-line path names (a URL survives as a `PathBuf`'s text).
    pub fn from_path(path: &Path) -> Result<Location, StoreError> {
        match path.to_str() {
            Some(text) => Location::parse(text),
            None => Ok(Location::Local(path.to_owned())),
        }
    }

    /// Whether this is an object-store URL.
    pub fn is_remote(&self) -> bool {
        matches!(self, Location::Remote(_))
    }

    /// Whether the text names a prefix rather than an object: a remote URL ending in `/`.
    /// (A local folder is found by looking at the file system.)
    pub fn is_remote_prefix(&self) -> bool {
        matches!(self, Location::Remote(url) if url.path().ends_with('/') || url.path().is_empty())
    }

    /// The last segment of the path (`run.mcap` of `s3://b/2024/run.mcap`).
    pub fn file_name(&self) -> Option<String> {
        match self {
            Location::Local(p) => p.file_name().map(|n| n.to_string_lossy().into_owned()),
            Location::Remote(url) => url
                .path_segments()
                .and_then(|mut s| s.next_back())
                .filter(|s| !s.is_empty())
                .map(percent_decoded),
        }
    }

    /// The location of `name` inside this folder or prefix.
    pub fn join(&self, name: &str) -> Location {
        match self {
            Location::Local(p) => Location::Local(p.join(name)),
            Location::Remote(url) => {
                let mut joined = url.clone();
                let path = url.path();
                let base = if path.ends_with('/') {
                    path.to_owned()
                } else {
                    format!("{path}/")
                };
                joined.set_path(&format!("{base}{name}"));
                Location::Remote(joined)
            }
        }
    }

    /// The location as a path for the library's messages and `&Path` arguments: the local
    /// path, or the URL's text (which [`Location::from_path`] reads back).
    pub fn to_path(&self) -> PathBuf {
        match self {
            Location::Local(p) => p.clone(),
            Location::Remote(url) => PathBuf::from(url.as_str()),
        }
    }
}

impl fmt::Display for Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Location::Local(p) => write!(f, "{}", p.display()),
            Location::Remote(url) => f.write_str(url.as_str()),
        }
    }
}

/// A URL, or the one-line reason it is not one.
fn parse_url(text: &str) -> Result<Url, StoreError> {
    Url::parse(text).map_err(|e| StoreError::BadUrl {
        url: text.to_owned(),
        reason: e.to_string(),
    })
}

/// A URL path segment as its object's name (`%20` → space).
fn percent_decoded(segment: &str) -> String {
    percent_encoding::percent_decode_str(segment)
        .decode_utf8()
        .map(|name| name.into_owned())
        .unwrap_or_else(|_| segment.to_owned())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paths_and_urls_are_told_apart() {
        assert_eq!(
            Location::parse("runs/a.mcap").unwrap(),
            Location::Local("runs/a.mcap".into())
        );
        assert_eq!(
            Location::parse("file:///tmp/a.mcap").unwrap(),
            Location::Local("/tmp/a.mcap".into())
        );
        let s3 = Location::parse("s3://bucket/heatruns/2024/").unwrap();
        assert!(s3.is_remote() && s3.is_remote_prefix());
        assert!(!Location::parse("gs://b/x.mcap").unwrap().is_remote_prefix());
        // A colon in a local name is not a scheme.
        assert!(!Location::parse("C:/runs/a.mcap").unwrap().is_remote());
        assert!(matches!(
            Location::parse("s3:///key"),
            Err(StoreError::BadUrl { .. })
        ));
    }

    #[test]
    fn names_and_joins_follow_the_prefix() {
        let prefix = Location::parse("s3://bucket/out").unwrap();
        assert_eq!(
            prefix.join("a.report.json").to_string(),
            "s3://bucket/out/a.report.json"
        );
        let slash = Location::parse("s3://bucket/out/").unwrap();
        assert_eq!(slash.join("a.rrd").to_string(), "s3://bucket/out/a.rrd");
        let object = Location::parse("az://acct/container/unit%203.mcap").unwrap();
        assert_eq!(object.file_name().as_deref(), Some("unit 3.mcap"));
        assert_eq!(
            Location::from_path(&object.to_path()).unwrap(),
            object,
            "a URL survives the trip through a PathBuf"
        );
    }
}
