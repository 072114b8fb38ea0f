//! Physical lines to logical records: line endings, `$` continuation, `$$` comments, quotes,
//! and the non-APT lines of NX Information-window listings.
//!
//! Rules (see `../shared/data/cl/VOCABULARY.md` §4):
//! - a line ends at `\n`, `\r\n` or a lone `\r`;
//! - outside quotes, `$$` starts a comment that runs to the end of the line;
//! - outside a comment, a single `$` continues the record on the next physical line; the text
//!   after it on its own line is ignored (classic APT); inside a quoted text only a `$` that is
//!   the last non-blank character continues;
//! - continuation concatenates without a separator and without trimming, because CATIA breaks
//!   records at a fixed column, even inside a number;
//! - a comment whose last non-blank character is a single `$` continues on the next line, which
//!   is then comment text too (Creo `$$-> CSYS / …,  $`).

use std::borrow::Cow;

use crate::span::Span;
use crate::syntax::{self, Args};

/// One logical unit of the file.
#[derive(Debug)]
pub(crate) enum Unit<'a> {
    /// A statement, possibly joined from several physical lines.
    Statement(Record<'a>),
    /// A whole-line comment (possibly continued); `text` is the text after the first `$$`.
    Comment { span: Span, text: &'a str },
    /// A line of an NX Information-window listing that is not APT (header or footer).
    Listing,
}

/// A logical statement record.
#[derive(Debug)]
pub(crate) struct Record<'a> {
    /// The statement text, without comments, continuation marks and line ends.
    pub(crate) text: Cow<'a, str>,
    /// Where each piece of `text` starts in the source: `(offset in text, offset in source)`,
    /// sorted. A single-line record has exactly one piece.
    pieces: Pieces,
    /// From the first to the last byte of the statement text in the source.
    pub(crate) span: Span,
    /// Text after a `$` continuation mark that classic APT ignores, if not blank.
    pub(crate) ignored: Option<Span>,
    /// The record ended inside a quoted text.
    pub(crate) open_quote: bool,
    /// The file ended while the record asked for a continuation line.
    pub(crate) dangling_continuation: bool,
    /// A plain `GOTO` line whose arguments the splitter has read into the caller's buffer
    /// ([`Splitter::next_with`]): where `GOTO` starts in `text`.
    pub(crate) goto: Option<usize>,
}

#[derive(Debug)]
struct Pieces {
    first: u32,
    more: Vec<(u32, u32)>,
}

impl Unit<'_> {
    /// The unit of a window of the text that starts at offset `base`: its spans moved into the
    /// whole text.
    pub(crate) fn shifted(mut self, base: usize) -> Self {
        if base == 0 {
            return self;
        }
        let shift = |span: &mut Span| span.start += base as u32;
        match &mut self {
            Unit::Statement(rec) => {
                shift(&mut rec.span);
                if let Some(ignored) = rec.ignored.as_mut() {
                    shift(ignored);
                }
                rec.pieces.first += base as u32;
                for piece in &mut rec.pieces.more {
                    piece.1 += base as u32;
                }
            }
            Unit::Comment { span, .. } => shift(span),
            Unit::Listing => {}
        }
        self
    }
}

impl Record<'_> {
    /// The source offset of a byte offset in `text`.
    pub(crate) fn source_offset(&self, text_offset: usize) -> usize {
        let text_offset = text_offset as u32;
        let idx = self.pieces.more.partition_point(|&(t, _)| t <= text_offset);
        let (t, s) = if idx == 0 { (0, self.pieces.first) } else { self.pieces.more[idx - 1] };
        (s + (text_offset - t)) as usize
    }

    /// The source span of a byte range in `text`.
    pub(crate) fn source_span(&self, start: usize, end: usize) -> Span {
        let s = self.source_offset(start);
        let e = if end > start { self.source_offset(end - 1) + 1 } else { s };
        Span::new(s, e.max(s))
    }
}

/// The iterator over the units of a text.
pub(crate) struct Splitter<'a> {
    src: &'a str,
    pos: usize,
    seen_statement: bool,
}

/// A physical line: `start..end` excludes the line ending; `next` is where the next line starts.
#[derive(Clone, Copy)]
struct Line {
    start: usize,
    end: usize,
}

/// What one physical line holds, as offsets relative to the line start.
struct Lexed {
    /// End of the statement part.
    stmt_end: usize,
    /// `$$` comment: start of the `$$` and end of the line.
    comment: Option<(usize, usize)>,
    /// The record continues on the next line.
    continues: bool,
    /// A continued comment.
    comment_continues: bool,
    /// Still inside a quote at the end of the statement part.
    in_quote: bool,
    /// Non-blank text after a continuation `$`.
    ignored: Option<(usize, usize)>,
}

impl<'a> Splitter<'a> {
    /// A splitter at the start of `src`.
    #[cfg(test)]
    pub(crate) fn new(src: &'a str) -> Self {
        Splitter { src, pos: 0, seen_statement: false }
    }

    /// The next unit, like [`Iterator::next`], except that a physical line that is a whole plain
    /// `GOTO/x,y,z[,i,j,k]` statement (numbers only, no `$`, no quote: most of a CL file) is read
    /// in one go, its arguments into `goto` ([`syntax::goto_args`]): the line's end is where its
    /// last number ends, so the line is scanned once. Any other line goes the general way.
    pub(crate) fn next_with(&mut self, goto: &mut Args<'_>) -> Option<Unit<'a>> {
        // Before the first statement a line may be an NX listing line (`Key<TAB>value`).
        if self.seen_statement {
            goto.clear();
            let start = self.pos;
            let bytes = self.src.as_bytes();
            if let Some((major, end)) = syntax::goto_args(bytes, start, true, goto) {
                self.pos = match bytes.get(end) {
                    Some(b'\r') if bytes.get(end + 1) == Some(&b'\n') => end + 2,
                    Some(_) => end + 1,
                    None => end,
                };
                return Some(Unit::Statement(Record {
                    text: Cow::Borrowed(&self.src[start..end]),
                    pieces: Pieces { first: start as u32, more: Vec::new() },
                    span: Span::new(start, end),
                    ignored: None,
                    open_quote: false,
                    dangling_continuation: false,
                    goto: Some(major),
                }));
            }
        }
        self.next()
    }

    /// A splitter that starts at a line start (used by the unit pre-scan).
    pub(crate) fn at(src: &'a str, pos: usize) -> Self {
        Splitter { src, pos, seen_statement: true }
    }

    /// A splitter over a window of the text, at offset `pos` of it, a statement seen before or
    /// not (the state carried from the window before).
    pub(crate) fn resume(src: &'a str, pos: usize, seen_statement: bool) -> Self {
        Splitter { src, pos, seen_statement }
    }

    /// Where the next unit starts looking, in the text.
    pub(crate) fn pos(&self) -> usize {
        self.pos
    }

    /// True once a statement has been read (no more NX listing header lines).
    pub(crate) fn seen_statement(&self) -> bool {
        self.seen_statement
    }

    fn next_line(&mut self) -> Option<Line> {
        let bytes = self.src.as_bytes();
        if self.pos >= bytes.len() {
            return None;
        }
        let start = self.pos;
        let (end, next) = match memchr::memchr2(b'\n', b'\r', &bytes[start..]) {
            None => (bytes.len(), bytes.len()),
            Some(k) => {
                let i = start + k;
                if bytes[i] == b'\r' && bytes.get(i + 1) == Some(&b'\n') { (i, i + 2) } else { (i, i + 1) }
            }
        };
        self.pos = next;
        Some(Line { start, end })
    }

    /// Skips the comment continuation lines after a comment that ends with a single `$`;
    /// returns the end of the last one.
    fn skip_continued_comment(&mut self, mut end: usize) -> usize {
        while let Some(line) = self.next_line() {
            end = line.end;
            if !ends_with_single_dollar(&self.src.as_bytes()[line.start..line.end]) {
                break;
            }
        }
        end
    }
}

impl<'a> Iterator for Splitter<'a> {
    type Item = Unit<'a>;

    fn next(&mut self) -> Option<Unit<'a>> {
        loop {
            let line = self.next_line()?;
            let src = self.src;
            let text = &src[line.start..line.end];
            if text.bytes().all(|b| b == b' ' || b == b'\t') {
                continue;
            }
            if is_listing_line(text, self.seen_statement) {
                return Some(Unit::Listing);
            }
            let lexed = lex_line(text.as_bytes(), false);
            let stmt = &text[..lexed.stmt_end];
            if stmt.trim().is_empty() && !lexed.continues {
                let Some((c, _)) = lexed.comment else {
                    // Only a `$…` continuation mark with nothing before it: an empty record.
                    continue;
                };
                let mut end = line.end;
                if lexed.comment_continues {
                    end = self.skip_continued_comment(end);
                }
                return Some(Unit::Comment { span: Span::new(line.start + c, end), text: &text[c + 2..] });
            }
            self.seen_statement = true;
            return Some(Unit::Statement(self.record(line, lexed)));
        }
    }
}

impl<'a> Splitter<'a> {
    fn record(&mut self, first: Line, lexed: Lexed) -> Record<'a> {
        let src = self.src;
        let abs = |line: Line, (a, b): (usize, usize)| Span::new(line.start + a, line.start + b);
        let mut ignored = lexed.ignored.map(|c| abs(first, c));
        let first_text = &src[first.start..first.start + lexed.stmt_end];
        let mut span_end = first.start + lexed.stmt_end;
        if !lexed.continues {
            if lexed.comment_continues {
                self.skip_continued_comment(first.end);
            }
            return Record {
                text: Cow::Borrowed(first_text),
                pieces: Pieces { first: first.start as u32, more: Vec::new() },
                span: Span::new(first.start, span_end),
                ignored,
                open_quote: lexed.in_quote,
                dangling_continuation: false,
                goto: None,
            };
        }
        let mut text = String::from(first_text);
        let mut more = Vec::new();
        let mut in_quote = lexed.in_quote;
        let mut continues = true;
        let mut dangling = false;
        while continues {
            let Some(line) = self.next_line() else {
                dangling = true;
                break;
            };
            let bytes = &src.as_bytes()[line.start..line.end];
            let lx = lex_line(bytes, in_quote);
            // A whole-line comment inside a continued statement is skipped: the statement goes
            // on with the next line.
            if !in_quote
                && lx.comment.is_some()
                && !lx.continues
                && src[line.start..line.start + lx.stmt_end].trim().is_empty()
            {
                if lx.comment_continues {
                    self.skip_continued_comment(line.end);
                }
                continue;
            }
            more.push((text.len() as u32, line.start as u32));
            text.push_str(&src[line.start..line.start + lx.stmt_end]);
            span_end = line.start + lx.stmt_end;
            ignored = ignored.or(lx.ignored.map(|c| abs(line, c)));
            in_quote = lx.in_quote;
            continues = lx.continues;
            if !continues && lx.comment_continues {
                self.skip_continued_comment(line.end);
            }
        }
        Record {
            text: Cow::Owned(text),
            pieces: Pieces { first: first.start as u32, more },
            span: Span::new(first.start, span_end.max(first.start)),
            ignored,
            open_quote: in_quote,
            dangling_continuation: dangling,
            goto: None,
        }
    }
}

fn lex_line(b: &[u8], mut in_quote: bool) -> Lexed {
    let mut i = 0;
    loop {
        if in_quote {
            match memchr::memchr(b'\'', &b[i..]) {
                Some(k) => {
                    i += k + 1;
                    in_quote = false;
                    continue;
                }
                None => {
                    let t = trim_end(b);
                    let continues = t.last() == Some(&b'$');
                    let stmt_end = if continues { t.len() - 1 } else { b.len() };
                    return Lexed {
                        stmt_end,
                        comment: None,
                        continues,
                        comment_continues: false,
                        in_quote,
                        ignored: None,
                    };
                }
            }
        }
        match memchr::memchr2(b'$', b'\'', &b[i..]) {
            None => {
                return Lexed {
                    stmt_end: b.len(),
                    comment: None,
                    continues: false,
                    comment_continues: false,
                    in_quote: false,
                    ignored: None,
                };
            }
            Some(k) if b[i + k] == b'\'' => {
                i += k + 1;
                in_quote = true;
            }
            Some(k) => {
                let j = i + k;
                if b.get(j + 1) == Some(&b'$') {
                    return Lexed {
                        stmt_end: j,
                        comment: Some((j, b.len())),
                        continues: false,
                        comment_continues: ends_with_single_dollar(&b[j + 2..]),
                        in_quote: false,
                        ignored: None,
                    };
                }
                let rest = &b[j + 1..];
                let ignored = (!trim_end(rest).is_empty()).then(|| (j + 1, j + 1 + trim_end(rest).len()));
                return Lexed {
                    stmt_end: j,
                    comment: None,
                    continues: true,
                    comment_continues: false,
                    in_quote: false,
                    ignored,
                };
            }
        }
    }
}

fn trim_end(b: &[u8]) -> &[u8] {
    let n = b.iter().rposition(|&c| c != b' ' && c != b'\t').map_or(0, |p| p + 1);
    &b[..n]
}

/// A comment continues when its last non-blank character is a `$` that is not part of `$$`.
fn ends_with_single_dollar(b: &[u8]) -> bool {
    let t = trim_end(b);
    t.last() == Some(&b'$') && (t.len() < 2 || t[t.len() - 2] != b'$')
}

/// NX Information-window lines: `Key<TAB>value` header lines before the first statement, and
/// the `Tool Path Listing has N lines.` footer.
pub(crate) fn is_listing_line(line: &str, seen_statement: bool) -> bool {
    // Past the header only the footer can occur: a line that starts with `Tool` (a quick look
    // at the first byte that is no blank first; any other white space is trimmed below).
    if seen_statement {
        let first = line.bytes().find(|&c| c != b' ' && c != b'\t');
        if first.is_some_and(|c| c.is_ascii_graphic() && c != b'T') {
            return false;
        }
        if !line.trim_start().starts_with("Tool Path Listing") {
            return false;
        }
    }
    let t = line.trim();
    if let Some(rest) = t.strip_prefix("Tool Path Listing has ") {
        return rest
            .trim_end_matches('.')
            .strip_suffix(" lines")
            .is_some_and(|n| n.bytes().all(|b| b.is_ascii_digit()));
    }
    if seen_statement {
        return false;
    }
    if t.starts_with("Information listing created by") {
        return true;
    }
    match t.split_once('\t') {
        Some((key, value)) => !key.contains('/') && !key.contains('$') && !value.trim().is_empty(),
        None => false,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn statements(src: &str) -> Vec<String> {
        Splitter::new(src)
            .filter_map(|u| match u {
                Unit::Statement(r) => Some(r.text.into_owned()),
                _ => None,
            })
            .collect()
    }

    #[test]
    fn continuation_joins_inside_a_number_without_separator() {
        let src = "GOTO  /  -5.67,  -1.31,  13.47,  -0.65,   0.05,   0$\r\n.752602\r\nRAPID";
        assert_eq!(statements(src), ["GOTO  /  -5.67,  -1.31,  13.47,  -0.65,   0.05,   0.752602", "RAPID"]);
    }

    #[test]
    fn comments_after_statements_and_inside_quotes() {
        let src = "GOTO/1,2,3 $$ 1.9,0.07\nSYN/'TLAXIS','$$*TLAXIS'\n$$ whole line\n";
        assert_eq!(statements(src), ["GOTO/1,2,3 ", "SYN/'TLAXIS','$$*TLAXIS'"]);
        let units: Vec<_> = Splitter::new(src).collect();
        assert!(matches!(units[0], Unit::Statement(_)));
        assert!(matches!(units[2], Unit::Comment { .. }));
    }

    #[test]
    fn continued_comment_swallows_its_bare_lines() {
        let src = "$$-> CSYS / 1.0, 0.0,  $\n            0.0, 1.0,  $\n            0.0, 0.0\nSPINDL / RPM, 100,  CLW\n";
        assert_eq!(statements(src), ["SPINDL / RPM, 100,  CLW"]);
    }

    #[test]
    fn comment_lines_inside_a_continued_statement_are_skipped() {
        assert_eq!(statements("GOTO/1,$\n$$ note\n2,3\n"), ["GOTO/1,2,3"]);
    }

    #[test]
    fn continuation_inside_quoted_text() {
        assert_eq!(statements("PPRINT/'ab$\ncd'\n"), ["PPRINT/'abcd'"]);
    }

    #[test]
    fn pieces_map_back_to_the_source() {
        let src = "GOTO/1,$\n2,3\n";
        let Some(Unit::Statement(r)) = Splitter::new(src).next() else { panic!("no record") };
        assert_eq!(r.text, "GOTO/1,2,3");
        assert_eq!(r.source_offset(7), 9); // the `2` on line 2
        assert_eq!(r.source_offset(5), 5);
        assert_eq!(r.span, Span::new(0, 12));
    }

    #[test]
    fn nx_listing_header_and_footer() {
        let src = "\nInformation listing created by\tphill\nDate\t18-Dec-2021\nTOOL PATH/X,TOOL,Y\nTool Path Listing has 2 lines.";
        let kinds: Vec<_> = Splitter::new(src).map(|u| matches!(u, Unit::Listing)).collect();
        assert_eq!(kinds, [true, true, false, true]);
    }

    #[test]
    fn text_after_continuation_is_ignored_and_reported() {
        let Some(Unit::Statement(r)) = Splitter::new("GOTO/1,2,$ junk\n3").next() else { panic!("no record") };
        assert_eq!(r.text, "GOTO/1,2,3");
        assert!(r.ignored.is_some());
    }

    /// The units of `src` through [`Splitter::next_with`], each statement parsed as the reader
    /// does, against the general way: record texts, spans and arguments (numbers by their bits).
    fn both_ways(src: &str) -> (Vec<String>, Vec<String>) {
        let describe = |rec: &Record<'_>, st: Result<syntax::Statement<'_>, syntax::SyntaxError>| {
            let st = st.map(|st| {
                let args: Vec<_> = st
                    .args()
                    .iter()
                    .map(|a| match a.value {
                        syntax::Value::Num(n) => format!("{:#x}@{}..{}", n.to_bits(), a.start, a.end),
                        v => format!("{v:?}@{}..{}", a.start, a.end),
                    })
                    .collect();
                (st.major, st.word, args, st.issues.len())
            });
            format!(
                "{:?} {:?} {:?} {:?} {} {}",
                rec.text, rec.span, rec.ignored, st, rec.open_quote, rec.dangling_continuation
            )
        };
        let mut fast = Vec::new();
        let mut goto = Args::new();
        let mut splitter = Splitter::new(src);
        while let Some(unit) = splitter.next_with(&mut goto) {
            fast.push(match unit {
                Unit::Statement(rec) => {
                    let mut buf = Args::new();
                    let st = match rec.goto {
                        Some(major) => Ok(syntax::goto(&rec.text, major, &goto)),
                        None => syntax::statement(&rec.text, &mut buf),
                    };
                    describe(&rec, st)
                }
                other => format!("{other:?}"),
            });
        }
        let slow = Splitter::new(src)
            .map(|unit| match unit {
                Unit::Statement(rec) => describe(&rec, syntax::statement(&rec.text, &mut Args::new())),
                other => format!("{other:?}"),
            })
            .collect();
        (fast, slow)
    }

    #[test]
    fn plain_goto_lines_read_in_one_go_as_the_general_way() {
        let src = "TOOL PATH/A,TOOL,B\nGOTO/1,2,3\r\nGOTO / -1.5 , 2. ,3  \rGOTO/1,2,3,$\n4,5,6\ngoto/.5,1E3,2D1\nGOTO/1,2,3 $$ c\nGOTO/1,,3\nGOTO/1,2,3";
        let (fast, slow) = both_ways(src);
        assert_eq!(fast, slow);
        assert_eq!(fast.len(), 8);
    }

    proptest::proptest! {
        /// Lines of GOTOs and their near misses read the same both ways.
        #[test]
        fn plain_goto_lines_read_as_the_general_way(
            lines in proptest::collection::vec(
                "[ \t]?(GOTO|goto|TLAXIS|N1 GOTO)[ \t]?/[ \t]?([+-]?[0-9]{0,10}(\\.[0-9]{0,9})?([eEdD][+-]?[0-9])?[ \t]?[,$'x(]?){0,7}( \\$\\$ c|\\$)?",
                0..8,
            ),
            ends in proptest::collection::vec("(\n|\r\n|\r)", 8),
        ) {
            let src: String = lines.iter().zip(&ends).map(|(l, e)| format!("{l}{e}")).collect();
            let (fast, slow) = both_ways(&src);
            proptest::prop_assert_eq!(fast, slow);
            let src = lines.join("\n");
            let (fast, slow) = both_ways(&src);
            proptest::prop_assert_eq!(fast, slow);
        }
    }

    #[test]
    fn dangling_continuation_at_end_of_file() {
        let Some(Unit::Statement(r)) = Splitter::new("GOTO/1,2,$").next() else { panic!("no record") };
        assert!(r.dangling_continuation);
    }
}
