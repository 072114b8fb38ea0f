//! Byte spans into the source text, and the source text itself with a lazily built line index.

use std::ops::Range;
use std::sync::{Arc, OnceLock};

/// A byte range in the source text. `u32` keeps the tool path compact; sources are capped at
/// [`Source::MAX_LEN`] bytes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct Span {
    /// Offset of the first byte.
    pub start: u32,
    /// Length in bytes.
    pub len: u32,
}

impl Span {
    /// The span of `start..end` (byte offsets).
    pub fn new(start: usize, end: usize) -> Span {
        debug_assert!(start <= end);
        Span { start: start as u32, len: (end - start) as u32 }
    }

    /// Offset one past the last byte.
    pub fn end(self) -> usize {
        self.start as usize + self.len as usize
    }

    /// The byte range.
    pub fn range(self) -> Range<usize> {
        self.start as usize..self.end()
    }

    /// The smallest span covering both.
    pub fn to(self, other: Span) -> Span {
        Span::new(self.start.min(other.start) as usize, self.end().max(other.end()))
    }
}

impl From<Span> for miette::SourceSpan {
    fn from(span: Span) -> Self {
        (span.start as usize, span.len as usize).into()
    }
}

/// A 1-based line and column (column counted in characters).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub struct LineCol {
    /// Line number, from 1.
    pub line: usize,
    /// Column number in characters, from 1.
    pub column: usize,
}

/// A named CL text. The text is shared (`Arc`) so diagnostics can render it without copies;
/// it is an `Arc<String>` rather than `Arc<str>` so that taking a `String` never copies it.
#[derive(Clone, Debug)]
pub struct Source {
    name: String,
    text: Arc<String>,
    latin1: bool,
    line_starts: Arc<OnceLock<Vec<u32>>>,
}

impl Source {
    /// The largest source the reader accepts (spans are `u32`).
    pub const MAX_LEN: usize = u32::MAX as usize;

    /// A source from text.
    pub fn new(name: impl Into<String>, text: impl Into<String>) -> Source {
        Source { name: name.into(), text: Arc::new(text.into()), latin1: false, line_starts: Arc::default() }
    }

    /// A source from raw bytes: UTF-8 if valid, otherwise decoded as Latin-1 (every byte is a
    /// character), which is what old CAM systems write for national characters.
    pub fn from_bytes(name: impl Into<String>, bytes: Vec<u8>) -> Source {
        match String::from_utf8(bytes) {
            Ok(text) => Source::new(name, text),
            Err(err) => {
                let text: String = err.into_bytes().iter().map(|&b| char::from(b)).collect();
                Source { latin1: true, ..Source::new(name, text) }
            }
        }
    }

    /// The name shown in diagnostics (usually the path).
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The text.
    pub fn text(&self) -> &str {
        &self.text
    }

    /// The shared text.
    pub fn shared_text(&self) -> Arc<String> {
        Arc::clone(&self.text)
    }

    /// True when the bytes were not UTF-8 and were decoded as Latin-1.
    pub fn is_latin1(&self) -> bool {
        self.latin1
    }

    /// Line and column of a byte offset (1-based). A line ends at `\n`, `\r\n` or a lone `\r`.
    pub fn line_col(&self, offset: usize) -> LineCol {
        let starts = self.line_starts.get_or_init(|| line_starts(self.text.as_bytes()));
        let offset = offset.min(self.text.len());
        let line = starts.partition_point(|&s| s as usize <= offset) - 1;
        let start = starts[line] as usize;
        let column = self.text.get(start..offset).map_or(offset - start, |s| s.chars().count()) + 1;
        LineCol { line: line + 1, column }
    }

    /// [`Source::line_col`] by one scan of the text up to `offset`, without building the line
    /// index: for a single look-up when no diagnostic is shown (the summary's units origin).
    pub(crate) fn line_col_scan(&self, offset: usize) -> LineCol {
        if self.line_starts.get().is_some() {
            return self.line_col(offset);
        }
        let offset = offset.min(self.text.len());
        let bytes = &self.text.as_bytes()[..offset];
        let (mut line, mut start, mut pos) = (1, 0, 0);
        while let Some(k) = memchr::memchr2(b'\n', b'\r', &bytes[pos..]) {
            let i = pos + k;
            // A `\r\n` whose `\n` is at `offset` ends the line before it too.
            pos = if bytes[i] == b'\r' && self.text.as_bytes().get(i + 1) == Some(&b'\n') { i + 2 } else { i + 1 };
            if pos > offset {
                break;
            }
            line += 1;
            start = pos;
        }
        let column = self.text.get(start..offset).map_or(offset - start, |s| s.chars().count()) + 1;
        LineCol { line, column }
    }

    /// `name:line:column` of a byte offset.
    pub fn location(&self, offset: usize) -> String {
        let lc = self.line_col(offset);
        format!("{}:{}:{}", self.name, lc.line, lc.column)
    }
}

/// A named CL text that says where its offsets are: a [`Source`] (held whole) or a
/// [`crate::ClFile`] (read from disk).
pub trait Locate {
    /// The name shown in messages (the path).
    fn name(&self) -> &str;
    /// Line and column of an offset of the text (1-based).
    fn line_col(&self, offset: usize) -> LineCol;
    /// `name:line:column` of an offset of the text.
    fn location(&self, offset: usize) -> String {
        let lc = self.line_col(offset);
        format!("{}:{}:{}", self.name(), lc.line, lc.column)
    }
}

impl Locate for Source {
    fn name(&self) -> &str {
        Source::name(self)
    }

    fn line_col(&self, offset: usize) -> LineCol {
        Source::line_col(self, offset)
    }
}

fn line_starts(text: &[u8]) -> Vec<u32> {
    let mut starts = vec![0u32];
    let mut pos = 0;
    while let Some(k) = memchr::memchr2(b'\n', b'\r', &text[pos..]) {
        let i = pos + k;
        pos = if text[i] == b'\r' && text.get(i + 1) == Some(&b'\n') { i + 2 } else { i + 1 };
        starts.push(pos as u32);
    }
    starts
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn line_col_handles_every_line_ending() {
        let src = Source::new("t", "ab\ncd\r\nef\rgh");
        assert_eq!(src.line_col(0), LineCol { line: 1, column: 1 });
        assert_eq!(src.line_col(4), LineCol { line: 2, column: 2 });
        assert_eq!(src.line_col(7), LineCol { line: 3, column: 1 });
        assert_eq!(src.line_col(10), LineCol { line: 4, column: 1 });
        assert_eq!(src.location(11), "t:4:2");
    }

    #[test]
    fn line_col_by_a_scan_is_line_col() {
        let text = "ab\ncd\r\nef\rgh\r\n\n\u{e9}x";
        for offset in 0..=text.len() + 1 {
            let scanned = Source::new("t", text).line_col_scan(offset);
            assert_eq!(scanned, Source::new("t", text).line_col(offset), "offset {offset}");
        }
    }

    #[test]
    fn latin1_fallback_keeps_every_byte() {
        let src = Source::from_bytes("t", b"PPRINT/zabu\xb9ivanje".to_vec());
        assert!(src.is_latin1());
        assert_eq!(src.text().chars().count(), 18);
    }
}
