//! CSV tool tables: a header row naming the columns (any order, without case), then one tool
//! per row; `#` starts a comment line, rows whose cells are all empty are passed over, an empty
//! cell is a value left out. The `csv` crate reads the cells (quotes, doubled quotes, line
//! breaks inside quotes); the place of each cell in the text, for errors, is found by walking
//! the record's text from where the crate says it starts.

use super::raw::{POSITIVE, Positive, Tool};
use crate::error::{Doc, MachineError, line_column};
use crate::locate::Span;
use crate::quantity::{self, Dimension, Length};

/// The columns a tool table may have.
const COLUMNS: &[&str] = &["number", "name", "length", "radius", "diameter", "h", "d"];

/// A header row, for messages.
const EXAMPLE: &str = "`number,name,length,radius,h,d`";

/// One row: its tool and where its cells are.
pub(super) struct Row {
    pub(super) tool: Tool,
    /// The column and place of each cell that is not empty.
    cells: Vec<(&'static str, Span)>,
    /// The row's first cell, for values left out.
    first: Span,
}

impl Row {
    /// Where the value of `column` is (the row's first cell when it is empty).
    pub(super) fn span(&self, column: &str) -> Span {
        self.cells.iter().find(|(c, _)| *c == column).map_or(self.first, |&(_, s)| s)
    }
}

/// Reads the rows of a CSV tool table, each cell parsed (numbers, lengths) and checked against
/// its column; the checks across tools are the caller's.
pub(super) fn read(doc: &Doc) -> Result<Vec<Row>, MachineError> {
    let text: &str = &doc.text;
    let mut reader =
        csv::ReaderBuilder::new().has_headers(false).flexible(true).comment(Some(b'#')).from_reader(text.as_bytes());
    let mut records = reader.byte_records();
    let Some(header) = records.next() else {
        return Err(doc.error_at(
            Span { offset: 0, len: 0 },
            "the tool table is empty".into(),
            format!("expected a header row such as {EXAMPLE}, then one tool per row"),
            None,
        ));
    };
    let header = header.map_err(|e| csv_error(doc, &e))?;
    let spans = cell_spans(text, start(&header));
    let mut columns: Vec<&'static str> = Vec::with_capacity(header.len());
    for (k, name) in header.iter().enumerate() {
        let name = String::from_utf8_lossy(name);
        let name = name.trim();
        let at = spans.get(k).copied().unwrap_or(spans[0]);
        let Some(&column) = COLUMNS.iter().find(|c| c.eq_ignore_ascii_case(name)) else {
            let quoted: Vec<String> = COLUMNS.iter().map(|c| format!("`{c}`")).collect();
            let help =
                name.contains([';', '\t']).then(|| "the columns of a tool table are separated by commas".to_string());
            let what =
                if name.is_empty() { "a column without a name".into() } else { format!("unknown column `{name}`") };
            return Err(doc.error_at(at, what, format!("expected one of {}", quoted.join(", ")), help));
        };
        if columns.contains(&column) {
            return Err(doc.error_at(
                at,
                format!("column `{column}` appears twice"),
                "expected each column once".into(),
                None,
            ));
        }
        columns.push(column);
    }
    if !columns.contains(&"number") {
        let line =
            Span { offset: spans[0].offset, len: spans.last().map_or(0, |s| s.offset + s.len - spans[0].offset) };
        return Err(doc.error_at(
            line,
            "the header has no `number` column".into(),
            format!("expected a `number` column (the tool numbers), as in {EXAMPLE}"),
            None,
        ));
    }
    let mut rows = Vec::new();
    for record in records {
        let record = record.map_err(|e| csv_error(doc, &e))?;
        let spans = cell_spans(text, start(&record));
        let values: Vec<String> = record.iter().map(|v| String::from_utf8_lossy(v).trim().to_string()).collect();
        if values.iter().all(String::is_empty) {
            continue;
        }
        let at = |k: usize| spans.get(k).copied().unwrap_or(spans[0]);
        if values.len() != columns.len() {
            let span = if values.len() > columns.len() {
                at(columns.len())
            } else {
                let last = at(values.len() - 1);
                Span { offset: last.offset + last.len, len: 0 }
            };
            return Err(doc.error_at(
                span,
                format!("a row of {} cells under a header of {}", values.len(), columns.len()),
                format!("expected one cell per column: {}", columns.join(",")),
                None,
            ));
        }
        let mut row = Row { tool: Tool::default(), cells: Vec::new(), first: at(0) };
        for (k, (&column, value)) in columns.iter().zip(&values).enumerate() {
            if value.is_empty() {
                continue;
            }
            let span = at(k);
            row.cells.push((column, span));
            let fail = |message: String, expected: String| {
                doc.error_at(span, format!("column `{column}`: {message}"), expected, None)
            };
            let positive = || {
                Positive::parse(value)
                    .ok_or_else(|| fail(format!("`{value}` is not a whole number"), format!("expected {POSITIVE}")))
            };
            let length = || {
                quantity::parse(value, Dimension::Length)
                    .map(|l| Some(Length(l)))
                    .map_err(|e| fail(e.message(), Dimension::Length.expected()))
            };
            let tool = &mut row.tool;
            match column {
                "number" => tool.number = positive()?,
                "name" => tool.name = Some(value.clone()),
                "length" => tool.length = length()?,
                "radius" => tool.radius = length()?,
                "diameter" => tool.diameter = length()?,
                "h" => tool.h = Some(positive()?),
                _ => tool.d = Some(positive()?),
            }
        }
        if row.tool.number.0 == 0 {
            let line = line_column(text, row.first.offset).0;
            return Err(doc.error_at(
                at(columns.iter().position(|&c| c == "number").unwrap_or(0)),
                format!("the tool on line {line} has no number"),
                "expected a tool number in the `number` column".into(),
                None,
            ));
        }
        rows.push(row);
    }
    Ok(rows)
}

/// Where a record starts in the text.
fn start(record: &csv::ByteRecord) -> usize {
    record.position().map_or(0, |p| usize::try_from(p.byte()).unwrap_or(usize::MAX))
}

/// The places of the cells of the record that starts at `start`: split at commas outside
/// quotes, up to the line break outside quotes, each without its surrounding blanks (quotes
/// included).
fn cell_spans(text: &str, start: usize) -> Vec<Span> {
    let bytes = text.as_bytes();
    let mut spans = Vec::new();
    let mut i = start.min(bytes.len());
    loop {
        let cell = i;
        let mut quoted = false;
        while i < bytes.len() {
            match bytes[i] {
                b'"' => quoted = !quoted,
                b',' | b'\n' | b'\r' if !quoted => break,
                _ => {}
            }
            i += 1;
        }
        let raw = &text[cell..i];
        let lead = raw.len() - raw.trim_start_matches([' ', '\t']).len();
        spans.push(Span { offset: cell + lead, len: raw.trim_matches([' ', '\t']).len() });
        if bytes.get(i) == Some(&b',') {
            i += 1;
        } else {
            return spans;
        }
    }
}

/// An error of the `csv` crate, at the record it names.
fn csv_error(doc: &Doc, e: &csv::Error) -> MachineError {
    let offset = e.position().map_or(0, |p| usize::try_from(p.byte()).unwrap_or(0));
    doc.error_at(Span { offset: offset.min(doc.text.len()), len: 0 }, e.to_string(), "expected a CSV row".into(), None)
}

#[cfg(test)]
#[allow(clippy::unwrap_used)] // a failed unwrap is a failed test
mod tests {
    use super::*;

    fn cells(text: &str, start: usize) -> Vec<&str> {
        cell_spans(text, start).iter().map(|s| &text[s.offset..s.offset + s.len]).collect()
    }

    #[test]
    fn cells_are_found_in_the_text() {
        assert_eq!(cells("a, b ,c\nd", 0), ["a", "b", "c"]);
        assert_eq!(cells("a,\"x, \"\"y\"\"\",\n", 0), ["a", "\"x, \"\"y\"\"\"", ""]);
        assert_eq!(cells("h\n1,\"two\nlines\",3\r\n", 2), ["1", "\"two\nlines\"", "3"]);
        assert_eq!(cells("", 0), [""]);
    }
}
