//! Long tables: one row per stored sample (`Tag;Zeitstempel;Wert;Status`), as PI
//! "recorded values", Ignition's tag history and WinCC archives export them.
//!
//! Each row is read as it comes: its tag picks the map's `[[column]]` (rows of
//! other tags are counted and passed over), its time is placed on that tag's own
//! [`RowClock`], and its value (and flag) becomes one message, exactly what the wide
//! import writes for that signal's cell. Rows may come sorted by time or grouped by
//! tag: a recording's messages need not be in time order, and each tag's own times
//! must not go backwards. Memory holds the map's tags, never the rows.

use std::collections::HashMap;

use super::error::ImportError;
use super::map::{ColumnSource, ImportMap, LongColumns};
use super::row_time::{time_error, RowTime};
use super::source::RowSource;
use super::time::{ClockChange, ClockError, RowClock};
use super::{parse_value_cell, ImportedChannel, QualityPlan, Read, Shape};
use crate::writer::{ChannelId, Quality, RecordingWriter};

/// One signal of a long table: its channel and its own clock.
struct TagPlan {
    channel: ChannelId,
    clock: RowClock,
    samples: u64,
    missing: u64,
}

/// The conversion of a long table's rows into messages.
pub(super) struct LongRows<'a> {
    shape: &'a Shape<'a>,
    time: RowTime,
    tag: (usize, String),
    value: (usize, String),
    quality: Option<QualityPlan>,
    /// The map's tags → their index in `tags`.
    by_tag: HashMap<String, usize>,
    tags: Vec<TagPlan>,
    decimal_comma: bool,
    count: u64,
    unlisted: u64,
}

impl<'a> LongRows<'a> {
    /// Resolves the tag, value, quality and time columns and adds a channel per
    /// mapped tag.
    pub(super) fn plan(
        shape: &'a Shape<'a>,
        columns: &LongColumns,
        decimal_comma: bool,
        writer: &mut RecordingWriter,
    ) -> Result<LongRows<'a>, ImportError> {
        let map = shape.map;
        let time = RowTime::plan(&map.time, decimal_comma, |c| shape.find(c))?;
        let quality = columns
            .quality
            .as_ref()
            .map(|q| QualityPlan::new(shape, q))
            .transpose()?;
        let mut by_tag = HashMap::new();
        let mut tags = Vec::new();
        for c in &map.columns {
            // A map read from a file is checked for this; one built in code may not be.
            let ColumnSource::Tag(tag) = &c.source else {
                return Err(ImportError::MapValue {
                    path: map.path.clone(),
                    key: format!("[[column]] {}", c.source),
                    message: "a long table's signals are picked by `tag`, not `column`".into(),
                });
            };
            by_tag.insert(tag.clone(), tags.len());
            tags.push(TagPlan {
                channel: writer.add_channel(&c.channel)?,
                clock: RowClock::new(map.time.zone.clone()),
                samples: 0,
                missing: 0,
            });
        }
        Ok(LongRows {
            shape,
            time,
            tag: shape.find(&columns.tag)?,
            value: shape.find(&columns.value)?,
            quality,
            by_tag,
            tags,
            decimal_comma,
            count: 0,
            unlisted: 0,
        })
    }

    /// Writes the message of the table's current row, if its tag is mapped.
    pub(super) fn convert(
        &mut self,
        row: &dyn RowSource,
        writer: &mut RecordingWriter,
    ) -> Result<(), ImportError> {
        self.shape.check_width(row)?;
        let row_index = self.count;
        self.count += 1;
        let tag = row.cell(self.tag.0).text();
        let Some(&i) = self.by_tag.get(tag.trim()) else {
            self.unlisted += 1;
            return Ok(());
        };
        let path = self.shape.input;
        let plan = &mut self.tags[i];
        let (stamp, text) = self.time.stamp(row, row_index);
        let t = stamp
            .map_err(ClockError::Bad)
            .and_then(|s| plan.clock.place(s))
            .map_err(|e| {
                let before = format!("on the tag `{}`'s row before", tag.trim());
                time_error(path, row.place(), self.time.label(), text, e, &before)
            })?;
        let cell = row.cell(self.value.0);
        let missing = &self.shape.map.input.missing;
        let value = parse_value_cell(&cell, self.decimal_comma, missing).ok_or_else(|| {
            ImportError::BadNumber {
                path: path.to_owned(),
                line: row.place(),
                column: self.value.1.clone(),
                text: cell.text(),
            }
        })?;
        let Some(value) = value else {
            plan.missing += 1;
            return Ok(());
        };
        let quality = match &self.quality {
            Some(q) => q.read(row, path)?,
            None => Quality::Good,
        };
        writer.write_flagged(plan.channel, t, Some(value), quality)?;
        plan.samples += 1;
        Ok(())
    }

    /// What the rows gave: each tag's counts, the span over all tags, and the clock
    /// changes the tags crossed, one per instant of change (rows summed over tags).
    pub(super) fn finish(self, map: &ImportMap) -> Read {
        let spans = self.tags.iter().filter_map(|t| t.clock.span());
        let span = spans.fold(None, |acc: Option<(u64, u64)>, (a, b)| {
            Some(acc.map_or((a, b), |(x, y)| (x.min(a), y.max(b))))
        });
        let mut changes: Vec<ClockChange> = Vec::new();
        for c in self.tags.iter().flat_map(|t| t.clock.changes()) {
            match changes.iter_mut().find(|k| k.at_ns == c.at_ns) {
                Some(k) => {
                    k.first_pass_rows += c.first_pass_rows;
                    k.second_pass_rows += c.second_pass_rows;
                }
                None => changes.push(c.clone()),
            }
        }
        changes.sort_by_key(|c| c.at_ns);
        Read {
            rows: self.count,
            channels: self
                .tags
                .iter()
                .zip(&map.columns)
                .map(|(t, m)| ImportedChannel {
                    topic: m.channel.topic.clone(),
                    unit: m.channel.unit.clone(),
                    samples: t.samples,
                    missing: t.missing,
                })
                .collect(),
            span,
            clock_changes: changes,
            unlisted_rows: self.unlisted,
        }
    }
}
