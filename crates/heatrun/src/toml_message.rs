//! A TOML parser's error as one line that names where: the toml crate's own text draws
//! the line with a caret under it over several lines, which a one-line message
//! (`heatrun: FILE: …`) turned into `| 1 | x = [ | ^ …`.

/// `line L, column C: what` for an error of parsing `text` (the error's message with its
/// line breaks made spaces); the message alone where the error has no place.
pub(crate) fn located(text: &str, error: &toml::de::Error) -> String {
    let what = error.message().trim().replace('\n', ", ");
    let Some(span) = error.span() else {
        return what;
    };
    let before = &text.as_bytes()[..span.start.min(text.len())];
    let line = 1 + before.iter().filter(|&&b| b == b'\n').count();
    let line_start = before
        .iter()
        .rposition(|&b| b == b'\n')
        .map_or(0, |p| p + 1);
    let column = 1 + String::from_utf8_lossy(&before[line_start..])
        .chars()
        .count();
    format!("line {line}, column {column}: {what}")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn error_of(text: &str) -> String {
        let e = toml::from_str::<toml::Table>(text).unwrap_err();
        located(text, &e)
    }

    #[test]
    fn a_syntax_error_is_one_line_naming_its_line_and_column() {
        assert_eq!(
            error_of("x = ["),
            "line 1, column 6: invalid array, expected `]`"
        );
        let second = error_of("a = 1\nb = = 2\n");
        assert!(second.starts_with("line 2, column 5: "), "{second}");
        assert!(!second.contains('\n'), "{second}");
        // A column counts characters, not bytes.
        let after_umlaut = error_of("\"ä\" = \n");
        assert!(
            after_umlaut.starts_with("line 1, column 7: "),
            "{after_umlaut}"
        );
    }
}
