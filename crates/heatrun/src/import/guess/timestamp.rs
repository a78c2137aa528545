//! The layout of a time column's timestamps, guessed from its first cells: RFC 3339 /
//! ISO 8601 as they are, or one of the layouts plant historians write (day-first with
//! dots, slashes either way round, 12-hour clocks), as the map's strftime `pattern`.

use super::super::time;

/// The layouts tried, in order: the first that reads every cell wins. Day-first before
/// month-first where both read (`01/02/2025`): European exports outnumber the others in
/// the plants this serves, and the map marks the guess for review.
const PATTERNS: [&str; 15] = [
    // Two-digit years first: `%Y` would read `25` as the year 25, `%y` reads no more than
    // two digits and so fails on `2025`.
    "%d.%m.%y %H:%M:%S%.f",
    "%d.%m.%y %H:%M",
    "%d.%m.%Y %H:%M:%S%.f",
    "%d.%m.%Y %H:%M",
    "%d/%m/%Y %H:%M:%S%.f",
    "%m/%d/%Y %H:%M:%S%.f",
    "%m/%d/%Y %I:%M:%S%.f %p",
    "%d/%m/%Y %H:%M",
    "%m/%d/%Y %H:%M",
    "%m/%d/%Y %I:%M %p",
    "%d-%m-%Y %H:%M:%S%.f",
    "%Y/%m/%d %H:%M:%S%.f",
    "%Y.%m.%d %H:%M:%S%.f",
    "%d-%b-%Y %H:%M:%S%.f",
    "%d-%b-%y %H:%M:%S%.f",
];

/// How a column's timestamps read.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum TimestampLayout {
    /// RFC 3339 / ISO 8601: no `pattern` needed.
    Iso,
    /// Another layout: the map's `pattern`. `ambiguous` when the cells read in another
    /// layout too (day and month both ≤ 12 in every cell).
    Pattern {
        /// The strftime pattern.
        pattern: &'static str,
        /// Another pattern that reads the same cells (the day and month swapped).
        ambiguous: Option<&'static str>,
    },
}

impl TimestampLayout {
    /// The pattern, if the layout needs one.
    pub fn pattern(&self) -> Option<&'static str> {
        match self {
            TimestampLayout::Iso => None,
            TimestampLayout::Pattern { pattern, .. } => Some(pattern),
        }
    }
}

/// The layout every non-empty cell of `cells` reads in, if there is one (and at least
/// one cell).
pub fn guess_layout(cells: &[String]) -> Option<TimestampLayout> {
    let cells: Vec<&str> = cells
        .iter()
        .map(|c| c.trim())
        .filter(|c| !c.is_empty())
        .collect();
    if cells.is_empty() {
        return None;
    }
    let reads = |pattern: Option<&str>| cells.iter().all(|c| time::parse_stamp(c, pattern).is_ok());
    if reads(None) {
        return Some(TimestampLayout::Iso);
    }
    let mut fits = PATTERNS.iter().copied().filter(|p| reads(Some(p)));
    let pattern = fits.next()?;
    let swapped = pattern
        .replace("%d", "\u{0}")
        .replace("%m", "%d")
        .replace('\u{0}', "%m");
    let ambiguous = fits.find(|p| *p == swapped);
    Some(TimestampLayout::Pattern { pattern, ambiguous })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn of(cells: &[&str]) -> Option<TimestampLayout> {
        guess_layout(&cells.iter().map(|c| (*c).to_owned()).collect::<Vec<_>>())
    }

    fn pattern(cells: &[&str]) -> Option<&'static str> {
        of(cells).and_then(|l| l.pattern())
    }

    #[test]
    fn day_first_and_other_historian_layouts() {
        assert_eq!(
            pattern(&["27.11.2025 08:00:00", "27.11.2025 08:00:10"]),
            Some("%d.%m.%Y %H:%M:%S%.f")
        );
        assert_eq!(
            pattern(&["27.11.2025 08:00:00.5"]),
            Some("%d.%m.%Y %H:%M:%S%.f")
        );
        assert_eq!(pattern(&["27.11.25 08:00"]), Some("%d.%m.%y %H:%M"));
        assert_eq!(
            pattern(&["11/27/2025 08:00:00 AM", "11/27/2025 01:00:00 PM"]),
            Some("%m/%d/%Y %I:%M:%S%.f %p")
        );
        assert_eq!(
            pattern(&["27/11/2025 08:00:00"]),
            Some("%d/%m/%Y %H:%M:%S%.f")
        );
        assert_eq!(
            pattern(&["11/27/2025 08:00:00"]),
            Some("%m/%d/%Y %H:%M:%S%.f")
        );
        assert_eq!(
            pattern(&["2025/11/27 08:00:00"]),
            Some("%Y/%m/%d %H:%M:%S%.f")
        );
        assert_eq!(
            pattern(&["27-Nov-2025 08:00:00"]),
            Some("%d-%b-%Y %H:%M:%S%.f")
        );
        assert_eq!(of(&["2025-11-27T08:00:00Z"]), Some(TimestampLayout::Iso));
        assert_eq!(of(&["2025-11-27 08:00:00"]), Some(TimestampLayout::Iso));
        assert_eq!(of(&["12.5", "13"]), None);
        assert_eq!(of(&[]), None);
    }

    #[test]
    fn a_layout_that_reads_both_ways_is_marked() {
        assert_eq!(
            of(&["01/02/2025 08:00:00"]),
            Some(TimestampLayout::Pattern {
                pattern: "%d/%m/%Y %H:%M:%S%.f",
                ambiguous: Some("%m/%d/%Y %H:%M:%S%.f"),
            })
        );
        assert!(matches!(
            of(&["27.11.2025 08:00:00"]),
            Some(TimestampLayout::Pattern {
                ambiguous: None,
                ..
            })
        ));
    }
}
