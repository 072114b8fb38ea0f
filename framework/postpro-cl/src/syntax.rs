//! The statement grammar (nom): a logical record's text to a major word and its arguments.
//!
//! ```text
//! statement := [seqno] major [ '/' body ]          | text-word blank text
//! major     := anything up to the first '/'         (`TOOL PATH`, `END-OF-PATH`, `TLON,GOFWD`)
//! body      := arg { ',' arg }                      (or raw text for the free-text words)
//! arg       := blank* [ number | 'quoted' | (group) | word ] blank*
//! number    := [+-] ( digits [ '.' digits* ] | '.' digits ) [ (E|D) [+-] digits ]
//! ```
//! Offsets are relative to the record text; the caller maps them to the source. The nom error
//! type is private: failures come out as [`SyntaxError`] with what was expected.

use nom::error::{ErrorKind, ParseError};
use nom::{IResult, Parser};
use smallvec::SmallVec;

use crate::words::Word;

/// A parsed statement, borrowing from the record text.
#[derive(Debug)]
pub(crate) struct Statement<'a> {
    /// The major word as written, trimmed.
    pub(crate) major: &'a str,
    /// The classified major word.
    pub(crate) word: Word,
    /// What follows the major word.
    pub(crate) body: Body<'a>,
    /// Recoverable oddities (missing commas).
    pub(crate) issues: SmallVec<[SyntaxIssue; 1]>,
}

impl<'a> Statement<'a> {
    /// The arguments (none for a statement without a slash or with free text).
    pub(crate) fn args(&self) -> &'a [Arg<'a>] {
        match self.body {
            Body::Args(a) => a,
            _ => &[],
        }
    }
}

/// What follows the major word.
#[derive(Debug)]
pub(crate) enum Body<'a> {
    /// No slash.
    None,
    /// Comma-separated arguments (possibly none: `RAPID/`), in the caller's buffer.
    Args(&'a [Arg<'a>]),
    /// Free text (PPRINT, INSERT, PARTNO, …), trimmed.
    Text(&'a str),
}

/// The argument buffer the caller provides: inline for up to eight arguments (every GOTO), so
/// a statement costs no heap allocation and no copy of its arguments.
pub(crate) type Args<'a> = SmallVec<[Arg<'a>; 8]>;

/// One argument with its byte range in the record text.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Arg<'a> {
    pub(crate) value: Value<'a>,
    pub(crate) start: u32,
    pub(crate) end: u32,
}

/// An argument value.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Value<'a> {
    Num(f64),
    /// A minor word (case as written).
    Word(&'a str),
    /// A quoted text, without the quotes.
    Quoted(&'a str),
    /// A parenthesised group, without the parentheses (nested APT geometry).
    Group(&'a str),
    /// Nothing between two commas, or after a trailing comma.
    Empty,
}

/// A recoverable syntax oddity, as a range in the record text.
#[derive(Clone, Copy, Debug)]
pub(crate) enum SyntaxIssue {
    /// Two arguments separated by blanks only.
    MissingComma { at: usize },
}

/// An unrecoverable syntax error: where, and what was expected there.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct SyntaxError {
    pub(crate) at: usize,
    pub(crate) expected: &'static str,
}

/// The private nom error: the remaining input and what was expected there.
#[derive(Debug)]
struct PError<'a> {
    input: &'a str,
    expected: &'static str,
}

impl<'a> ParseError<&'a str> for PError<'a> {
    fn from_error_kind(input: &'a str, kind: ErrorKind) -> Self {
        let expected = match kind {
            ErrorKind::Char => "a delimiter",
            ErrorKind::Float => "a number",
            _ => "an argument",
        };
        PError { input, expected }
    }

    fn append(_: &'a str, _: ErrorKind, other: Self) -> Self {
        other
    }
}

type PResult<'a, O> = IResult<&'a str, O, PError<'a>>;

fn fail<'a, O>(input: &'a str, expected: &'static str) -> PResult<'a, O> {
    Err(nom::Err::Error(PError { input, expected }))
}

fn blanks(i: &str) -> PResult<'_, &str> {
    nom::bytes::complete::take_while(|c| c == ' ' || c == '\t').parse(i)
}

/// A delimiter ends a bare token.
fn is_delimiter(c: char) -> bool {
    matches!(c, ',' | '/' | '(' | ')' | '\'' | ' ' | '\t')
}

/// A number as CAM systems write it: `25.`, `.005`, `-0.000`, `1.5E-3`, `.5773503D+00`.
fn number(i: &str) -> PResult<'_, f64> {
    let b = i.as_bytes();
    let digits_at = usize::from(matches!(b.first(), Some(b'+' | b'-')));
    match b.get(digits_at) {
        Some(c) if c.is_ascii_digit() => {}
        Some(b'.') if b.get(digits_at + 1).is_some_and(u8::is_ascii_digit) => {}
        _ => return fail(i, "a number"),
    }
    let Ok((mut value, mut used)) = fast_float2::parse_partial::<f64, _>(b) else {
        return fail(i, "a number");
    };
    // Fortran `D` exponent: rare, so re-parse through a small buffer.
    if matches!(b.get(used), Some(b'D' | b'd')) {
        let exp_digits = used + 1 + usize::from(matches!(b.get(used + 1), Some(b'+' | b'-')));
        if b.get(exp_digits).is_some_and(u8::is_ascii_digit) {
            let end = exp_digits + b[exp_digits..].iter().take_while(|c| c.is_ascii_digit()).count();
            let mut buf = b[..end].to_vec();
            buf[used] = b'E';
            if let Ok(v) = fast_float2::parse::<f64, _>(&buf) {
                value = v;
                used = end;
            }
        }
    }
    // A number must end at a delimiter, otherwise the token is a word such as `1STPECK`.
    match i[used..].chars().next() {
        Some(c) if !is_delimiter(c) => fail(i, "a number"),
        _ => Ok((&i[used..], value)),
    }
}

fn word(i: &str) -> PResult<'_, &str> {
    nom::bytes::complete::take_while1(|c| !is_delimiter(c)).parse(i)
}

fn quoted(i: &str) -> PResult<'_, &str> {
    let (rest, _) = nom::character::complete::char('\'').parse(i)?;
    match rest.find('\'') {
        Some(k) => Ok((&rest[k + 1..], &rest[..k])),
        None => fail(i, "a closing `'` for this quote"),
    }
}

fn group(i: &str) -> PResult<'_, &str> {
    let (rest, _) = nom::character::complete::char('(').parse(i)?;
    let mut depth = 1usize;
    for (k, c) in rest.char_indices() {
        match c {
            '(' => depth += 1,
            ')' => {
                depth -= 1;
                if depth == 0 {
                    return Ok((&rest[k + 1..], &rest[..k]));
                }
            }
            _ => {}
        }
    }
    fail(i, "a closing `)` for this `(`")
}

fn value(i: &str) -> PResult<'_, Value<'_>> {
    match i.as_bytes().first() {
        Some(b'\'') => quoted.map(Value::Quoted).parse(i),
        Some(b'(') => group.map(Value::Group).parse(i),
        Some(b')') => fail(i, "an argument (unbalanced `)`)"),
        Some(b'/') => fail(i, "`,` or the end of the statement (a second `/`)"),
        _ => number.map(Value::Num).or(word.map(Value::Word)).parse(i),
    }
}

/// The argument list after the slash. `base` is the offset of `i` in the record text.
fn args<'a>(i: &'a str, base: usize, out: &mut Args<'a>, issues: &mut SmallVec<[SyntaxIssue; 1]>) -> PResult<'a, ()> {
    let at = |rest: &str| base + (i.len() - rest.len());
    let (mut rest, _) = blanks(i)?;
    if rest.is_empty() {
        return Ok((rest, ()));
    }
    loop {
        let start = at(rest);
        let (r, v) = if rest.is_empty() || rest.starts_with(',') { (rest, Value::Empty) } else { value(rest)? };
        out.push(Arg { value: v, start: start as u32, end: at(r) as u32 });
        let (r, _) = blanks(r)?;
        rest = r;
        match rest.as_bytes().first() {
            None => return Ok((rest, ())),
            Some(b',') => {
                let (r, _) = blanks(&rest[1..])?;
                rest = r;
            }
            Some(_) if v != Value::Empty => issues.push(SyntaxIssue::MissingComma { at: at(rest) }),
            Some(_) => return fail(rest, "`,` or the end of the statement"),
        }
    }
}

/// Parses one record text into a statement; the arguments go into `buf` (cleared first).
pub(crate) fn statement<'t: 'b, 'b>(text: &'t str, buf: &'b mut Args<'t>) -> Result<Statement<'b>, SyntaxError> {
    buf.clear();
    let err = |e: nom::Err<PError<'_>>| match e {
        nom::Err::Error(e) | nom::Err::Failure(e) => {
            SyntaxError { at: text.len() - e.input.len(), expected: e.expected }
        }
        nom::Err::Incomplete(_) => SyntaxError { at: text.len(), expected: "more input" },
    };
    let lead = text.len() - text.trim_start().len();
    let mut start = lead;
    // A leading sequence number (`N10 GOTO/…`) from card images.
    if let Some(n) = sequence_number_len(&text[start..]) {
        start += n;
    }
    let body_text = &text[start..];
    let mut issues = SmallVec::new();

    // Slash-less free text: `PARTNO PART TO BE MACHINED`, `PPRINT TOOL: D 2,5`.
    let first_token_len = memchr::memchr3(b' ', b'\t', b'/', body_text.as_bytes()).unwrap_or(body_text.len());
    let first = &body_text[..first_token_len];
    if Word::from_major(first).is_text() && !body_text[first_token_len..].trim_start().starts_with('/') {
        let rest = &body_text[first_token_len..];
        return Ok(Statement { major: first, word: Word::from_major(first), body: Body::Text(rest.trim()), issues });
    }

    let (major, after) = match memchr::memchr(b'/', body_text.as_bytes()) {
        Some(k) => (&body_text[..k], Some(k + 1)),
        None => (body_text, None),
    };
    let major = major.trim_end();
    if major.is_empty() {
        return Err(SyntaxError { at: start, expected: "a major word before `/`" });
    }
    let word = Word::from_major(major);
    let body = match after {
        None => Body::None,
        Some(k) if word.is_text() => Body::Text(body_text[k..].trim()),
        Some(k) => {
            let (rest, ()) = args(&body_text[k..], start + k, buf, &mut issues).map_err(err)?;
            debug_assert!(rest.is_empty());
            Body::Args(buf.as_slice())
        }
    };
    Ok(Statement { major, word, body, issues })
}

fn sequence_number_len(t: &str) -> Option<usize> {
    let b = t.as_bytes();
    if !matches!(b.first(), Some(b'N' | b'n')) {
        return None;
    }
    let digits = b[1..].iter().take_while(|c| c.is_ascii_digit()).count();
    let blanks = b[1 + digits..].iter().take_while(|&&c| c == b' ' || c == b'\t').count();
    (digits > 0 && blanks > 0 && 1 + digits + blanks < b.len()).then_some(1 + digits + blanks)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Parses with a leaked buffer: fine in tests.
    fn statement(text: &str) -> Result<Statement<'_>, SyntaxError> {
        super::statement(text, Box::leak(Box::new(Args::new())))
    }

    fn nums(s: &Statement<'_>) -> Vec<f64> {
        match &s.body {
            Body::Args(a) => {
                a.iter().filter_map(|a| if let Value::Num(n) = a.value { Some(n) } else { None }).collect()
            }
            _ => vec![],
        }
    }

    #[test]
    fn numbers_in_every_form() {
        let s = statement("GOTO/25.,.005,-0.000,1.5E-3,.5773503D+00,-7").expect("parses");
        assert_eq!(nums(&s), [25.0, 0.005, -0.0, 1.5e-3, 0.5773503, -7.0]);
        assert_eq!(s.word, Word::Goto);
    }

    #[test]
    fn blanks_around_slash_and_commas() {
        let s = statement("GOTO  /  -7.2,  -23.0 , 2.0 ").expect("parses");
        assert_eq!(s.major, "GOTO");
        assert_eq!(nums(&s), [-7.2, -23.0, 2.0]);
    }

    #[test]
    fn words_starting_with_digits_and_empty_arguments() {
        let s = statement("CYCLE/DEEP2,1STPECK,5.,,X,").expect("parses");
        let Body::Args(a) = &s.body else { panic!("args") };
        let v: Vec<_> = a.iter().map(|a| a.value).collect();
        assert_eq!(
            v,
            [
                Value::Word("DEEP2"),
                Value::Word("1STPECK"),
                Value::Num(5.0),
                Value::Empty,
                Value::Word("X"),
                Value::Empty
            ]
        );
    }

    #[test]
    fn missing_comma_is_recovered() {
        let s = statement("CYCLE/ DRILL,3.0,46.9 46.9 DWELL,0.0").expect("parses");
        assert_eq!(s.issues.len(), 2);
        assert_eq!(nums(&s), [3.0, 46.9, 46.9, 0.0]);
    }

    #[test]
    fn free_text_with_and_without_slash() {
        let s = statement("PPRINT TOOL: zabusivac D 2,5").expect("parses");
        assert!(matches!(s.body, Body::Text("TOOL: zabusivac D 2,5")));
        let s = statement("INSERT/[HOLDER=C40] 10.0mm, DRILL ").expect("parses");
        assert!(matches!(s.body, Body::Text("[HOLDER=C40] 10.0mm, DRILL")));
        let s = statement("PARTNO/'1001'").expect("parses");
        assert!(matches!(s.body, Body::Text("'1001'")));
    }

    #[test]
    fn major_words_with_blanks_hyphens_and_commas() {
        assert_eq!(statement("TOOL PATH/CAVITY_MILL,TOOL,M").expect("parses").word, Word::ToolPath);
        assert_eq!(statement("END-OF-PATH").expect("parses").word, Word::EndOfPath);
        let s = statement("TLON,GOFWD/ (CIRCLE/ 25, 0, -30, 4.6),ON,(LINE/ 1,2,3,4,5,6)").expect("parses");
        assert_eq!(s.word, Word::GoMotion);
        let Body::Args(a) = &s.body else { panic!("args") };
        assert_eq!(a[0].value, Value::Group("CIRCLE/ 25, 0, -30, 4.6"));
    }

    #[test]
    fn errors_say_what_was_expected() {
        assert_eq!(
            statement("GOTO/1,2,(3").map(|_| ()),
            Err(SyntaxError { at: 9, expected: "a closing `)` for this `(`" })
        );
        assert_eq!(statement("/1,2").map(|_| ()), Err(SyntaxError { at: 0, expected: "a major word before `/`" }));
        assert_eq!(
            statement("GOTO/1,2/3").map(|_| ()),
            Err(SyntaxError { at: 8, expected: "`,` or the end of the statement (a second `/`)" })
        );
    }

    #[test]
    fn lower_case_and_sequence_numbers() {
        let s = statement("N10 goto/1,2,3").expect("parses");
        assert_eq!(s.word, Word::Goto);
        assert_eq!(s.major, "goto");
    }
}
