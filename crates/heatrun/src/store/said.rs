//! What an object store said, sorted into [`StoreError`]'s variants (the `object-store`
//! feature): a bucket or object missing, credentials missing or refused, access denied,
//! each with the store's own words on one line.

use super::StoreError;

impl StoreError {
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
        let hint = credentials_hint(&url);
        // Without credentials in the environment the builders ask the cloud's instance
        // metadata service (a link-local address); off that cloud it refuses or does not
        // answer, and its refusal ("403 Forbidden") is not the bucket's.
        let metadata_service = has("169.254.169.254") || has("metadata.google.internal");
        if has("InvalidAccessKeyId")
            || has("SignatureDoesNotMatch")
            || has("credential")
            || metadata_service
        {
            return StoreError::NoCredentials { url, hint, said };
        }
        match error {
            E::NotFound { .. } => StoreError::NoSuchObject { url, said },
            E::PermissionDenied { .. } => StoreError::AccessDenied { url, said },
            E::Unauthenticated { .. } => StoreError::NoCredentials { url, hint, said },
            _ if has("AccessDenied") || has("403 Forbidden") => {
                StoreError::AccessDenied { url, said }
            }
            _ => StoreError::Store { url, said },
        }
    }
}

/// What to set so that the store of `url` finds credentials: each cloud's standard
/// environment variables, which the builders read (`from_env`).
pub fn credentials_hint(url: &str) -> &'static str {
    let scheme = url.split("://").next().unwrap_or_default();
    match scheme {
        "s3" | "s3a" => {
            "set AWS_ACCESS_KEY_ID and AWS_SECRET_ACCESS_KEY (and AWS_ENDPOINT for a store \
             other than AWS), or run where an instance role provides them"
        }
        "gs" => "set GOOGLE_SERVICE_ACCOUNT (a key file's path) or GOOGLE_APPLICATION_CREDENTIALS",
        "az" | "abfs" | "abfss" | "azure" | "adl" => {
            "set AZURE_STORAGE_ACCOUNT_NAME and AZURE_STORAGE_ACCOUNT_KEY (or a SAS token)"
        }
        _ => "check the URL's credentials",
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

    #[test]
    fn a_metadata_service_refusal_is_missing_credentials_not_a_denied_bucket() {
        // What an S3 read says on a machine with no AWS variables, off AWS (measured).
        let said = "Error performing PUT http://169.254.169.254/latest/api/token in 12ms - \
                    Server returned non-2xx status code: 403 Forbidden";
        let error = object_store::Error::Generic {
            store: "S3",
            source: said.into(),
        };
        let e = StoreError::from_store("s3://bucket/run.mcap", &error);
        assert!(matches!(e, StoreError::NoCredentials { .. }), "{e}");
        let line = e.to_string();
        assert!(
            line.starts_with("s3://bucket/run.mcap: no valid credentials; set AWS_ACCESS_KEY_ID"),
            "{line}"
        );
        assert!(e.is_bad_input());
    }

    #[test]
    fn a_bucket_that_refuses_valid_credentials_is_access_denied() {
        let error = object_store::Error::Generic {
            store: "S3",
            source: "GET http://127.0.0.1:9/b/k - 403 Forbidden: <Error><Code>AccessDenied</Code>\
                     <Message>Access Denied</Message></Error>"
                .into(),
        };
        let e = StoreError::from_store("s3://b/k", &error);
        assert!(matches!(e, StoreError::AccessDenied { .. }), "{e}");
        assert_eq!(
            e.to_string(),
            "s3://b/k: access denied (the store said: AccessDenied: Access Denied)"
        );
    }

    #[test]
    fn each_store_names_its_own_variables() {
        assert!(credentials_hint("gs://b/k").contains("GOOGLE_"));
        assert!(credentials_hint("az://c/k").contains("AZURE_STORAGE_ACCOUNT_NAME"));
        assert!(credentials_hint("s3://b/k").contains("AWS_SECRET_ACCESS_KEY"));
    }
}
