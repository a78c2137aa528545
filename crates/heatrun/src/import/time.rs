//! Reading a row's time: seconds (exactly, as decimals), RFC 3339 / ISO 8601
//! timestamps, or the row's index times a sample time.

use jiff::tz::TimeZone;

/// Nanoseconds of a decimal number of units (`unit_ns` ns each), computed from the
/// decimal digits so that `0.1` s is exactly 100,000,000 ns and epoch seconds keep
/// their nanoseconds (an `f64` would lose them above 2^53 ns, about 104 days).
/// `None` when the text is not a decimal number or is out of range.
pub fn parse_decimal_ns(text: &str, unit_ns: i128) -> Option<i128> {
    let (mantissa, exponent) = parse_decimal(text)?;
    let scaled = mantissa.checked_mul(unit_ns)?;
    if exponent >= 0 {
        scaled.checked_mul(10i128.checked_pow(exponent as u32)?)
    } else {
        let divisor = 10i128.checked_pow(exponent.unsigned_abs())?;
        // Round half away from zero.
        let q = scaled / divisor;
        let r = scaled % divisor;
        Some(if 2 * r.abs() >= divisor {
            q + scaled.signum()
        } else {
            q
        })
    }
}

/// A decimal number `[+-]digits[.digits][e[+-]digits]` as mantissa × 10^exponent;
/// digits beyond the 24th significant one are dropped (far below a nanosecond).
fn parse_decimal(text: &str) -> Option<(i128, i32)> {
    let bytes = text.as_bytes();
    let (negative, mut i) = match bytes.first()? {
        b'-' => (true, 1),
        b'+' => (false, 1),
        _ => (false, 0),
    };
    let (mut mantissa, mut exponent, mut digits, mut significant) = (0i128, 0i32, 0, 0);
    let mut seen_point = false;
    while i < bytes.len() {
        match bytes[i] {
            b'0'..=b'9' => {
                digits += 1;
                if significant < 24 {
                    mantissa = mantissa * 10 + i128::from(bytes[i] - b'0');
                    if mantissa != 0 {
                        significant += 1;
                    }
                    if seen_point {
                        exponent -= 1;
                    }
                } else if !seen_point {
                    exponent += 1;
                }
            }
            b'.' if !seen_point => seen_point = true,
            b'e' | b'E' => break,
            _ => return None,
        }
        i += 1;
    }
    if digits == 0 {
        return None;
    }
    if i < bytes.len() {
        let e: i32 = text[i + 1..].parse().ok()?;
        exponent = exponent.checked_add(e)?;
    }
    Some((if negative { -mantissa } else { mantissa }, exponent))
}

/// The instant of an RFC 3339 / ISO 8601 timestamp (or one in a strftime `pattern`),
/// in ns since the Unix epoch. A timestamp without an offset is read in `zone`;
/// without a zone it is an error.
pub fn parse_timestamp(
    text: &str,
    zone: Option<&TimeZone>,
    pattern: Option<&str>,
) -> Result<i128, String> {
    let no_zone = || {
        "it has no offset (Z, +01:00) and the map gives no zone; add `zone` under [time]".to_owned()
    };
    if let Some(pattern) = pattern {
        let tm = jiff::fmt::strtime::parse(pattern, text)
            .map_err(|e| format!("it does not match the pattern `{pattern}`: {e}"))?;
        if tm.offset().is_some() {
            return tm
                .to_timestamp()
                .map(|t| t.as_nanosecond())
                .map_err(|e| e.to_string());
        }
        let civil = tm.to_datetime().map_err(|e| e.to_string())?;
        let zone = zone.ok_or_else(no_zone)?;
        return zone
            .to_timestamp(civil)
            .map(|t| t.as_nanosecond())
            .map_err(|e| e.to_string());
    }
    if let Ok(t) = text.parse::<jiff::Timestamp>() {
        return Ok(t.as_nanosecond());
    }
    match text.parse::<jiff::civil::DateTime>() {
        Ok(civil) => {
            let zone = zone.ok_or_else(no_zone)?;
            zone.to_timestamp(civil)
                .map(|t| t.as_nanosecond())
                .map_err(|e| e.to_string())
        }
        Err(e) => Err(format!(
            "not an RFC 3339 / ISO 8601 timestamp ({e}); give `pattern` under [time] for another layout"
        )),
    }
}

/// Whether a cell looks like a number rather than a timestamp (for the format `Auto`).
pub fn looks_like_seconds(text: &str) -> bool {
    parse_decimal(text).is_some()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decimals_are_exact() {
        let s = 1_000_000_000;
        assert_eq!(parse_decimal_ns("0.1", s), Some(100_000_000));
        assert_eq!(parse_decimal_ns("1.5", s), Some(1_500_000_000));
        assert_eq!(parse_decimal_ns("-2", s), Some(-2_000_000_000));
        assert_eq!(parse_decimal_ns("+3.", s), Some(3_000_000_000));
        assert_eq!(parse_decimal_ns(".25", s), Some(250_000_000));
        // TCLab writes %.18e: 1.001284599304199219e+00 s.
        assert_eq!(
            parse_decimal_ns("1.001284599304199219e+00", s),
            Some(1_001_284_599)
        );
        // Epoch seconds keep their nanoseconds.
        assert_eq!(
            parse_decimal_ns("1559541600.000000001", s),
            Some(1_559_541_600_000_000_001)
        );
        assert_eq!(parse_decimal_ns("2.5e3", 1_000_000), Some(2_500_000_000));
        assert_eq!(parse_decimal_ns("1.5", 60 * s), Some(90_000_000_000));
        // Half a nanosecond rounds away from zero.
        assert_eq!(parse_decimal_ns("0.0000000005", s), Some(1));
        assert_eq!(parse_decimal_ns("-0.0000000005", s), Some(-1));
        for bad in [
            "", "-", ".", "1.2.3", "abc", "1e", "1e999999", "NaN", "12:00",
        ] {
            assert_eq!(parse_decimal_ns(bad, s), None, "{bad}");
        }
    }

    #[test]
    fn timestamps_with_and_without_zones() {
        // 2024-01-01T00:00:00Z = 1704067200 s.
        let t0 = 1_704_067_200_000_000_000i128;
        assert_eq!(parse_timestamp("2024-01-01T00:00:00Z", None, None), Ok(t0));
        assert_eq!(
            parse_timestamp("2024-01-01T01:00:00.5+01:00", None, None),
            Ok(t0 + 500_000_000)
        );
        let plus_two = TimeZone::fixed(jiff::tz::Offset::from_hours(2).unwrap());
        assert_eq!(
            parse_timestamp("2024-01-01T02:00:00", Some(&plus_two), None),
            Ok(t0)
        );
        assert_eq!(
            parse_timestamp("2024-01-01 02:00:00", Some(&plus_two), None),
            Ok(t0)
        );
        assert!(parse_timestamp("2024-01-01T02:00:00", None, None)
            .unwrap_err()
            .contains("no offset"));
        assert!(parse_timestamp("yesterday", None, None).is_err());
        assert_eq!(
            parse_timestamp(
                "01.01.2024 02:00:00",
                Some(&plus_two),
                Some("%d.%m.%Y %H:%M:%S")
            ),
            Ok(t0)
        );
    }
}
