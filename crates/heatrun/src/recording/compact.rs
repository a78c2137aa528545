//! The sample message as the profile's writer (and most recorders) write it, read
//! without a JSON parser: `{"value":25.13}`, `{"value":null}`, or either with
//! `,"quality":"good|uncertain|bad"` before the closing brace, no whitespace.
//!
//! Nearly every message of a recording has this one form, and reading it through
//! serde_json's general deserializer (a struct visitor, key matching, the number's
//! digits accumulated twice) was a fifth of a full-rate replay's time. Anything else
//! (whitespace, other keys or their order, a bare `NaN`) is `None` here and goes to the
//! JSON parser, which stays the definition of what a sample is.

/// The quality flag a compact message may carry.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum CompactQuality {
    Good,
    Uncertain,
    Bad,
}

/// A compact message's value (NaN for `null`, a dropout) and quality; `None` where the
/// message is not in the compact form.
///
/// The number must be a JSON number, `-?(0|[1-9][0-9]*)(.[0-9]+)?([eE][+-]?[0-9]+)?`,
/// and is read by the standard library's correctly rounded `f64` parser: the value the
/// writer's shortest round-trip form was made from, to the last bit (serde_json without
/// its `float_roundtrip` feature reads some such forms one unit in the last place off).
pub(super) fn parse(data: &[u8]) -> Option<(f64, CompactQuality)> {
    let rest = data.strip_prefix(b"{\"value\":")?;
    let rest = rest.strip_suffix(b"}")?;
    let (value, rest) = match rest.strip_prefix(b"null") {
        Some(after) => (f64::NAN, after),
        None => {
            let end = number_end(rest)?;
            (number(&rest[..end])?, &rest[end..])
        }
    };
    let quality = match rest {
        b"" => CompactQuality::Good,
        _ => match rest.strip_prefix(b",\"quality\":\"")?.strip_suffix(b"\"")? {
            b"good" => CompactQuality::Good,
            b"uncertain" => CompactQuality::Uncertain,
            b"bad" => CompactQuality::Bad,
            _ => return None,
        },
    };
    Some((value, quality))
}

/// The length of the JSON number at the start of `text` (`None`: it is not one).
fn number_end(text: &[u8]) -> Option<usize> {
    let mut at = usize::from(text.first() == Some(&b'-'));
    let digits = |from: usize| {
        text[from..]
            .iter()
            .take_while(|b| b.is_ascii_digit())
            .count()
    };
    let whole = digits(at);
    // No leading zeros: "0" alone, or a digit 1-9 first.
    if whole == 0 || (whole > 1 && text[at] == b'0') {
        return None;
    }
    at += whole;
    if text.get(at) == Some(&b'.') {
        let fraction = digits(at + 1);
        if fraction == 0 {
            return None;
        }
        at += 1 + fraction;
    }
    if matches!(text.get(at), Some(b'e' | b'E')) {
        at += 1;
        if matches!(text.get(at), Some(b'+' | b'-')) {
            at += 1;
        }
        let exponent = digits(at);
        if exponent == 0 {
            return None;
        }
        at += exponent;
    }
    Some(at)
}

/// A JSON number's value. A number without fraction or exponent is an integer to the
/// JSON parser, whose `-0` is 0: kept so, so both readings give the same value.
fn number(text: &[u8]) -> Option<f64> {
    let value: f64 = match short_decimal(text) {
        Some(v) => v,
        None => std::str::from_utf8(text).ok()?.parse().ok()?,
    };
    let integer = !text.iter().any(|b| matches!(b, b'.' | b'e' | b'E'));
    Some(if integer && value == 0.0 { 0.0 } else { value })
}

/// 10^k for k = 0..=15, each exact in an `f64`.
const POWERS_OF_TEN: [f64; 16] = [
    1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15,
];

/// A number of at most 15 digits with no exponent (`-?[0-9]+(.[0-9]+)?`, as
/// [`number_end`] admits it: what a writer's shortest form of a reading is) read as
/// m / 10^f, with m its digits as an integer and f how many follow the point; `None` for
/// any other form. Clinger's fast path: m < 10¹⁵ < 2⁵³ and 10^f are exact in an `f64`,
/// so the one division rounds the exact quotient once, correctly, and gives the bits the
/// standard library's correctly rounded parser gives (which takes the same path for such a
/// number, after a UTF-8 check and a general scan that were a tenth of W0's read).
fn short_decimal(text: &[u8]) -> Option<f64> {
    let (negative, digits) = match text.split_first() {
        Some((b'-', rest)) => (true, rest),
        _ => (false, text),
    };
    if digits.len() > 16 {
        return None;
    }
    let (mut mantissa, mut count, mut fraction) = (0u64, 0usize, None::<usize>);
    for &b in digits {
        match b {
            b'0'..=b'9' => {
                mantissa = 10 * mantissa + u64::from(b - b'0');
                count += 1;
                fraction = fraction.map(|f| f + 1);
            }
            b'.' if fraction.is_none() => fraction = Some(0),
            _ => return None,
        }
    }
    if count > 15 {
        return None;
    }
    let magnitude = mantissa as f64 / POWERS_OF_TEN[fraction.unwrap_or(0)];
    Some(if negative { -magnitude } else { magnitude })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_writers_forms_are_read_and_others_are_left_to_the_json_parser() {
        assert_eq!(
            parse(b"{\"value\":25.13}"),
            Some((25.13, CompactQuality::Good))
        );
        assert_eq!(parse(b"{\"value\":-3}"), Some((-3.0, CompactQuality::Good)));
        assert_eq!(
            parse(b"{\"value\":1.5e-3}"),
            Some((1.5e-3, CompactQuality::Good))
        );
        assert_eq!(
            parse(b"{\"value\":7,\"quality\":\"uncertain\"}"),
            Some((7.0, CompactQuality::Uncertain))
        );
        assert_eq!(
            parse(b"{\"value\":0.1,\"quality\":\"bad\"}"),
            Some((0.1, CompactQuality::Bad))
        );
        let (v, q) = parse(b"{\"value\":null}").unwrap();
        assert!(v.is_nan() && q == CompactQuality::Good);
        assert_eq!(
            parse(b"{\"value\":-0}").unwrap().0.to_bits(),
            0f64.to_bits()
        );
        // Not the compact form, or not JSON: for the parser to read or refuse.
        for other in [
            &b"{\"value\": 25.13}"[..],
            b"{\"value\":NaN}",
            b"{\"value\":01}",
            b"{\"value\":1.}",
            b"{\"value\":.5}",
            b"{\"value\":+1}",
            b"{\"value\":inf}",
            b"{\"value\":1e}",
            b"{\"value\":1,\"quality\":\"fine\"}",
            b"{\"quality\":\"bad\",\"value\":1}",
            b"{\"value\":1,\"unit\":\"K\"}",
            b"{\"value\":1",
        ] {
            assert_eq!(parse(other), None, "{}", String::from_utf8_lossy(other));
        }
    }

    #[test]
    fn every_writers_value_reads_back_as_written() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand::rngs::StdRng::seed_from_u64(33);
        for _ in 0..20_000 {
            let v: f64 = rng.random_range(-200.0..200.0) * 10f64.powi(rng.random_range(-6..6));
            let text = format!("{{\"value\":{v}}}");
            let (read, _) = parse(text.as_bytes()).expect("compact");
            #[derive(serde::Deserialize)]
            struct Json {
                value: f64,
            }
            let json: Json = serde_json::from_str(&text).unwrap();
            // Exactly the value written; serde_json's fast reading (without its
            // `float_roundtrip` feature) is at most one unit in the last place off it.
            assert_eq!(read.to_bits(), v.to_bits(), "{text}");
            assert!(read.to_bits().abs_diff(json.value.to_bits()) <= 1, "{text}");
        }
    }

    #[test]
    fn short_decimals_are_read_to_the_bit_the_standard_parser_reads() {
        // Random readings of every length the fast path takes and a little beyond (the
        // standard parser then reads them), with and without a fraction and a sign, and
        // the edges: zeros, a lone point's neighbours, 15 and 16 digits.
        use rand::{Rng, SeedableRng};
        let mut rng = rand::rngs::StdRng::seed_from_u64(11);
        let mut forms: Vec<String> = [
            "0",
            "-0",
            "0.0",
            "-0.0",
            "0.1",
            "0.3",
            "25.13",
            "999999999999999",
            "9999999999999999",
            "0.000000000000001",
            "1.0000000000000001",
            "123456789012345.6",
            "-7.000",
        ]
        .iter()
        .map(|s| s.to_string())
        .collect();
        for _ in 0..200_000 {
            let digits = rng.random_range(1..=17);
            let text: String = (0..digits)
                .map(|_| char::from(b'0' + rng.random_range(0..10u8)))
                .collect();
            let point = rng.random_range(0..=digits);
            let mut form = if point == 0 || point == digits {
                text.clone()
            } else {
                format!("{}.{}", &text[..point], &text[point..])
            };
            // A JSON number has no leading zero before more digits.
            if form.len() > 1 && form.starts_with('0') && !form.starts_with("0.") {
                form = form.trim_start_matches('0').to_string();
                if form.is_empty() || form.starts_with('.') {
                    form.insert(0, '0');
                }
            }
            if rng.random_bool(0.3) {
                form.insert(0, '-');
            }
            forms.push(form);
        }
        for form in &forms {
            let bytes = form.as_bytes();
            assert_eq!(number_end(bytes), Some(bytes.len()), "{form}");
            let want: f64 = form.parse().unwrap();
            if let Some(got) = short_decimal(bytes) {
                assert_eq!(got.to_bits(), want.to_bits(), "{form}");
            }
            assert_eq!(
                number(bytes).map(f64::to_bits),
                Some(if form.contains('.') {
                    want.to_bits()
                } else {
                    (want + 0.0).to_bits()
                }),
                "{form}"
            );
        }
        assert!(short_decimal(b"25.13").is_some() && short_decimal(b"1e3").is_none());
    }
}
