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
    /// The store refused the credentials, or none were found.
    #[error("{url}: no valid credentials (the store said: {said})")]
    NoCredentials {
        /// The object's URL.
        url: String,
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

    /// Sorts `object_store`'s error for `url` by what the store said: its variants where
    /// they tell (not found, permission, authentication), else the S3 error codes in its
    /// message (`NoSuchBucket`, `AccessDenied`, `InvalidAccessKeyId`, ...).
    pub fn from_store(url: &str, error: &object_store::Error) -> StoreError {
        use object_store::Error as E;
        let full = one_line(error);
        let url = url.to_owned();
        let has = |code: &str| full.contains(code);
        // An S3-style XML error body says it best: its code and message.
        let said = s3_code_and_message(&full).unwrap_or_else(|| full.clone());
        if has("NoSuchBucket")
            || has("ContainerNotFound")
            || has("The specified bucket does not exist")
        {
            return StoreError::NoSuchBucket { url, said };
        }
        if has("InvalidAccessKeyId") || has("SignatureDoesNotMatch") || has("credential") {
            return StoreError::NoCredentials { url, said };
        }
        match error {
            E::NotFound { .. } => StoreError::NoSuchObject { url, said },
            E::PermissionDenied { .. } => StoreError::AccessDenied { url, said },
            E::Unauthenticated { .. } => StoreError::NoCredentials { url, said },
            _ if has("AccessDenied") || has("403 Forbidden") => {
                StoreError::AccessDenied { url, said }
            }
            _ => StoreError::Store { url, said },
        }
    }
}

/// `Code: Message` of an S3-style XML error body (`<Code>NoSuchBucket</Code>`), if any.
fn s3_code_and_message(text: &str) -> Option<String> {
    let element = |name: &str| {
        let open = format!("<{name}>");
        let start = text.find(&open)? + open.len();
        let end = start + text[start..].find(&format!("</{name}>"))?;
        Some(text[start..end].trim().to_owned())
    };
    let code = element("Code")?;
    Some(match element("Message") {
        Some(message) => format!("{code}: {message}"),
        None => code,
    })
}

/// An error and its causes on one line, without repeats (`object_store` often repeats its
/// source in its own message), at most 400 characters.
fn one_line(error: &dyn std::error::Error) -> String {
    let mut parts: Vec<String> = Vec::new();
    let mut next: Option<&dyn std::error::Error> = Some(error);
    while let Some(e) = next {
        let text = e
            .to_string()
            .split_whitespace()
            .collect::<Vec<_>>()
            .join(" ");
        if !parts.iter().any(|p| p.contains(&text)) {
            parts.push(text);
        }
        next = e.source();
    }
    let mut line = parts.join(": ");
    if line.len() > 400 {
        let cut = (0..=400)
            .rev()
            .find(|&i| line.is_char_boundary(i))
            .unwrap_or(0);
        line.truncate(cut);
        line.push('…');
    }
    line
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_s3_error_body_is_said_by_its_code_and_message() {
        let body = "GET http://127.0.0.1:9/b/k - 404 Not Found: <?xml version=\"1.0\"?> \
                    <Error><Code>NoSuchBucket</Code><Message>The specified bucket does not \
                    exist</Message><BucketName>b</BucketName></Error>";
        assert_eq!(
            s3_code_and_message(body).as_deref(),
            Some("NoSuchBucket: The specified bucket does not exist")
        );
        assert_eq!(s3_code_and_message("connection refused"), None);
    }
}
