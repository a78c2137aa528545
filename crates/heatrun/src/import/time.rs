//! Reading a row's time: seconds (exactly, as decimals), RFC 3339 / ISO 8601
//! timestamps, or the row's index times a sample time; and [`RowClock`], which puts a
//! row's wall-clock time on the time line across a zone's clock changes.

use jiff::civil::DateTime;
use jiff::tz::{AmbiguousOffset, Offset, TimeZone};
use jiff::Timestamp;

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
/// in ns since the Unix epoch. A timestamp without an offset is read in `zone` (a
/// repeated wall-clock time as its earlier instant: rows use [`RowClock`] instead);
/// without a zone it is an error.
pub fn parse_timestamp(
    text: &str,
    zone: Option<&TimeZone>,
    pattern: Option<&str>,
) -> Result<i128, String> {
    match parse_stamp(text, pattern)? {
        Stamp::Instant(ns) => Ok(ns),
        Stamp::Civil(civil) => zone
            .ok_or_else(|| {
                "it has no offset (Z, +01:00) and the map gives no zone; add `zone` under [time]"
                    .to_owned()
            })?
            .to_timestamp(civil)
            .map(|t| t.as_nanosecond())
            .map_err(|e| e.to_string()),
    }
}

/// A row's time as the table writes it: an instant (an offset was given, or the
/// column is seconds or a UTC timestamp), or a wall-clock time for the map's zone.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stamp {
    /// ns since the Unix epoch.
    Instant(i128),
    /// A civil date and time without an offset.
    Civil(DateTime),
}

/// A timestamp cell as a [`Stamp`]: RFC 3339 / ISO 8601 (or `pattern`'s layout);
/// without an offset it stays civil, for [`RowClock`] to place.
pub fn parse_stamp(text: &str, pattern: Option<&str>) -> Result<Stamp, String> {
    if let Some(pattern) = pattern {
        let tm = jiff::fmt::strtime::parse(pattern, text)
            .map_err(|e| format!("it does not match the pattern `{pattern}`: {e}"))?;
        if tm.offset().is_some() {
            return tm
                .to_timestamp()
                .map(|t| Stamp::Instant(t.as_nanosecond()))
                .map_err(|e| e.to_string());
        }
        return tm
            .to_datetime()
            .map(Stamp::Civil)
            .map_err(|e| e.to_string());
    }
    if let Ok(t) = text.parse::<Timestamp>() {
        return Ok(Stamp::Instant(t.as_nanosecond()));
    }
    text.parse::<DateTime>().map(Stamp::Civil).map_err(|e| {
        format!(
            "not an RFC 3339 / ISO 8601 timestamp ({e}); give `pattern` under [time] for another layout"
        )
    })
}

/// A change of the zone's offset that the rows of a clock crossed, and how the rows
/// around it were placed.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ClockChange {
    /// The instant of the change, ns since the Unix epoch.
    pub at_ns: i128,
    /// The offset before it, seconds east of UTC.
    pub from_s: i32,
    /// The offset after it, seconds east of UTC.
    pub to_s: i32,
    /// Rows whose wall-clock time occurs twice and that fell in the first pass
    /// (the earlier instant, at `from_s`).
    pub first_pass_rows: u64,
    /// Rows whose wall-clock time occurs twice and that came after a later row's
    /// instant, so fell in the second pass (at `to_s`): the row order decides.
    pub second_pass_rows: u64,
}

impl ClockChange {
    /// Whether the clock went back (an hour repeated) rather than forward (an hour
    /// skipped).
    pub fn repeated(&self) -> bool {
        self.to_s < self.from_s
    }

    /// One line: `2023-10-29T01:00:00Z, +02:00 to +01:00: the repeated hour resolved
    /// by row order (3600 rows in its first pass, 3600 in its second)`.
    pub fn describe(&self) -> String {
        let at = Timestamp::from_nanosecond(self.at_ns)
            .map(|t| t.to_string())
            .unwrap_or_default();
        let how = if self.repeated() {
            format!(
                "the repeated hour resolved by row order ({} rows in its first pass, {} in its second)",
                self.first_pass_rows, self.second_pass_rows
            )
        } else {
            "the skipped hour holds no row".to_owned()
        };
        format!(
            "{at}, {} to {}: {how}",
            offset_text(self.from_s),
            offset_text(self.to_s)
        )
    }
}

/// `+02:00`.
pub fn offset_text(seconds: i32) -> String {
    let sign = if seconds < 0 { '-' } else { '+' };
    let m = seconds.unsigned_abs() / 60;
    format!("{sign}{:02}:{:02}", m / 60, m % 60)
}

/// Why a row's time could not be placed.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum ClockError {
    /// No zone is given for a time without an offset, or the instant is out of range.
    Bad(String),
    /// The wall-clock time falls in a skipped hour (offsets as `+01:00`).
    Skipped {
        /// The zone's name.
        zone: String,
        /// The offset before the gap.
        before: String,
        /// The offset after it.
        after: String,
    },
    /// Earlier than the row before (ns since the epoch).
    Backwards {
        /// The row before.
        previous: u64,
        /// This row.
        current: u64,
    },
}

/// The time line of a sequence of rows (a wide table's rows, or one tag's rows of a
/// long table): each row's instant, never earlier than the row before.
///
/// A wall-clock time in the map's zone is placed by the zone's rules; where it occurs
/// twice (the hour repeated when summer time ends) the row order decides: the earlier
/// instant t₁ = civil − before, unless t₁ < the previous row's instant, and then the
/// later t₂ = civil − after (the second pass). A time in a skipped hour is an error
/// only when a row falls in it. Every change of offset between consecutive rows is
/// kept as a [`ClockChange`].
#[derive(Debug, Clone)]
pub struct RowClock {
    zone: Option<TimeZone>,
    previous: Option<u64>,
    first: Option<u64>,
    offset: Option<Offset>,
    changes: Vec<ClockChange>,
    /// Rows in the first pass of a repeated hour, before its change is crossed.
    pending_first: u64,
}

/// Where a wall-clock time fell.
enum Pass {
    Once,
    First,
    Second,
}

impl RowClock {
    /// A clock for times without an offset read in `zone`.
    pub fn new(zone: Option<TimeZone>) -> RowClock {
        RowClock {
            zone,
            previous: None,
            first: None,
            offset: None,
            changes: Vec::new(),
            pending_first: 0,
        }
    }

    /// The instant of the next row, ns since the epoch.
    pub fn place(&mut self, stamp: Stamp) -> Result<u64, ClockError> {
        let ns = match stamp {
            Stamp::Instant(ns) => ns,
            Stamp::Civil(civil) => self.place_civil(civil)?,
        };
        let t = u64::try_from(ns).map_err(|_| {
            ClockError::Bad(if ns < 0 {
                "it is before 1970-01-01T00:00:00Z, where recording times start; give `start` under [time]".into()
            } else {
                "it is after 2554, beyond what a recording can hold".into()
            })
        })?;
        if let Some(previous) = self.previous.filter(|p| t < *p) {
            return Err(ClockError::Backwards {
                previous,
                current: t,
            });
        }
        self.first.get_or_insert(t);
        self.previous = Some(t);
        Ok(t)
    }

    /// The first and last instants placed.
    pub fn span(&self) -> Option<(u64, u64)> {
        Some((self.first?, self.previous?))
    }

    /// The changes of offset crossed, in order.
    pub fn changes(&self) -> &[ClockChange] {
        &self.changes
    }

    fn place_civil(&mut self, civil: DateTime) -> Result<i128, ClockError> {
        let zone = self.zone.clone().ok_or_else(|| {
            ClockError::Bad(
                "it has no offset (Z, +01:00) and the map gives no zone; add `zone` under [time]"
                    .into(),
            )
        })?;
        let at = |offset: Offset| {
            offset
                .to_timestamp(civil)
                .map(|t| t.as_nanosecond())
                .map_err(|e| ClockError::Bad(e.to_string()))
        };
        let (ns, offset, pass) = match zone.to_ambiguous_timestamp(civil).offset() {
            AmbiguousOffset::Unambiguous { offset } => (at(offset)?, offset, Pass::Once),
            AmbiguousOffset::Gap { before, after } => {
                return Err(ClockError::Skipped {
                    zone: zone.iana_name().unwrap_or("the map's zone").to_owned(),
                    before: offset_text(before.seconds()),
                    after: offset_text(after.seconds()),
                })
            }
            AmbiguousOffset::Fold { before, after } => {
                let earlier = at(before)?;
                if self.previous.is_some_and(|p| earlier < i128::from(p)) {
                    (at(after)?, after, Pass::Second)
                } else {
                    (earlier, before, Pass::First)
                }
            }
        };
        self.note(&zone, ns, offset, pass);
        Ok(ns)
    }

    /// Keeps a change of offset from the row before, and counts the passes.
    fn note(&mut self, zone: &TimeZone, ns: i128, offset: Offset, pass: Pass) {
        if let Some(from) = self.offset.filter(|o| *o != offset) {
            // The transition is the last one at or before this row's instant.
            let at_ns = Timestamp::from_nanosecond(ns + 1)
                .ok()
                .and_then(|t| zone.preceding(t).next())
                .map_or(ns, |tr| tr.timestamp().as_nanosecond());
            self.changes.push(ClockChange {
                at_ns,
                from_s: from.seconds(),
                to_s: offset.seconds(),
                first_pass_rows: std::mem::take(&mut self.pending_first),
                second_pass_rows: 0,
            });
        }
        self.offset = Some(offset);
        match pass {
            Pass::Once => self.pending_first = 0,
            // A first pass belongs to the change still to come: counted there.
            Pass::First => self.pending_first += 1,
            Pass::Second => {
                if let Some(c) = self.changes.last_mut() {
                    c.second_pass_rows += 1;
                }
            }
        }
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

    fn zurich() -> RowClock {
        RowClock::new(Some(TimeZone::get("Europe/Zurich").unwrap()))
    }

    fn civil(text: &str) -> Stamp {
        parse_stamp(text, None).unwrap()
    }

    /// ns of an RFC 3339 instant, the independent reference.
    fn utc(text: &str) -> u64 {
        text.parse::<Timestamp>().unwrap().as_nanosecond() as u64
    }

    #[test]
    fn a_repeated_hour_is_resolved_by_row_order() {
        // 2023-10-29 in Zurich: 03:00 +02:00 (01:00Z) became 02:00 +01:00.
        let mut clock = zurich();
        let rows = [
            ("2023-10-29T01:59:00", "2023-10-28T23:59:00Z"),
            ("2023-10-29T02:00:00", "2023-10-29T00:00:00Z"),
            ("2023-10-29T02:59:00", "2023-10-29T00:59:00Z"),
            // The second pass: the same wall-clock times, an hour later.
            ("2023-10-29T02:00:00", "2023-10-29T01:00:00Z"),
            ("2023-10-29T02:30:00", "2023-10-29T01:30:00Z"),
            ("2023-10-29T02:59:00", "2023-10-29T01:59:00Z"),
            ("2023-10-29T03:00:00", "2023-10-29T02:00:00Z"),
        ];
        for (text, want) in rows {
            assert_eq!(clock.place(civil(text)), Ok(utc(want)), "{text}");
        }
        let changes = clock.changes();
        assert_eq!(changes.len(), 1);
        let c = &changes[0];
        assert_eq!(c.at_ns, utc("2023-10-29T01:00:00Z") as i128);
        assert_eq!((c.from_s, c.to_s), (7200, 3600));
        assert_eq!((c.first_pass_rows, c.second_pass_rows), (2, 3));
        assert!(c.repeated());
        assert!(c
            .describe()
            .starts_with("2023-10-29T01:00:00Z, +02:00 to +01:00"));
    }

    #[test]
    fn a_skipped_hour_is_an_error_only_with_a_row_in_it() {
        // 2023-03-26 in Zurich: 02:00 +01:00 became 03:00 +02:00.
        let mut clock = zurich();
        assert_eq!(
            clock.place(civil("2023-03-26T01:59:59")),
            Ok(utc("2023-03-26T00:59:59Z"))
        );
        assert_eq!(
            clock.place(civil("2023-03-26T03:00:00")),
            Ok(utc("2023-03-26T01:00:00Z"))
        );
        let c = &clock.changes()[0];
        assert_eq!((c.from_s, c.to_s, c.repeated()), (3600, 7200, false));
        assert_eq!(c.at_ns, utc("2023-03-26T01:00:00Z") as i128);
        let mut clock = zurich();
        assert_eq!(
            clock.place(civil("2023-03-26T02:30:00")),
            Err(ClockError::Skipped {
                zone: "Europe/Zurich".into(),
                before: "+01:00".into(),
                after: "+02:00".into()
            })
        );
    }

    #[test]
    fn times_going_back_beyond_the_repeat_are_still_backwards() {
        let mut clock = zurich();
        clock.place(civil("2023-10-29T02:30:00")).unwrap();
        clock.place(civil("2023-10-29T02:40:00")).unwrap();
        // Into the second pass at 02:10, then back to 02:05: backwards within it.
        assert_eq!(
            clock.place(civil("2023-10-29T02:10:00")),
            Ok(utc("2023-10-29T01:10:00Z"))
        );
        assert!(matches!(
            clock.place(civil("2023-10-29T02:05:00")),
            Err(ClockError::Backwards { .. })
        ));
        // A summer day has no change.
        let mut clock = zurich();
        clock.place(civil("2023-07-01T02:30:00")).unwrap();
        clock.place(civil("2023-07-01T03:30:00")).unwrap();
        assert!(clock.changes().is_empty());
    }
}
