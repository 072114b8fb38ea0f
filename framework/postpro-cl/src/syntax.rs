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
    let Some((value, used)) = number_at(b, 0) else {
        return fail(i, "a number");
    };
    // A number must end at a delimiter, otherwise the token is a word such as `1STPECK`
    // (a byte ≥ 0x80 starts a character that is no delimiter).
    match b.get(used) {
        Some(&c) if !c.is_ascii() || !is_delimiter(char::from(c)) => fail(i, "a number"),
        _ => Ok((&i[used..], value)),
    }
}

/// The number that starts at `b[k]`, if one does, and where it ends; what follows it is not
/// looked at (the caller checks for a delimiter).
fn number_at(b: &[u8], k: usize) -> Option<(f64, usize)> {
    short_decimal(b, k).or_else(|| number_not_short(b, k))
}

/// [`number_at`] where [`short_decimal`] did not decide.
fn number_not_short(b: &[u8], k: usize) -> Option<(f64, usize)> {
    if let Some(long) = long_decimal(b, k) {
        return Some(long);
    }
    let s = b.get(k..)?;
    let digits_at = usize::from(matches!(s.first(), Some(b'+' | b'-')));
    match s.get(digits_at) {
        Some(c) if c.is_ascii_digit() => {}
        Some(b'.') if s.get(digits_at + 1).is_some_and(u8::is_ascii_digit) => {}
        _ => return None,
    }
    let (value, used) = plain_decimal(s).or_else(|| general_number(s))?;
    Some((value, k + used))
}

/// Any number `fast_float2` reads (exponents, many digits), and the Fortran `D` exponent.
fn general_number(b: &[u8]) -> Option<(f64, usize)> {
    let (mut value, mut used) = fast_float2::parse_partial::<f64, _>(b).ok()?;
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
    Some((value, used))
}

/// Exact powers of ten as `f64` (10²² is the largest).
const POW10: [f64; 23] = [
    1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16, 1e17, 1e18, 1e19, 1e20,
    1e21, 1e22,
];

/// Powers of ten as `u64`, up to 10¹⁹.
const POW10_U64: [u64; 20] = {
    let mut p = [1u64; 20];
    let mut k = 1;
    while k < 20 {
        p[k] = p[k - 1] * 10;
        k += 1;
    }
    p
};

/// The most digits [`plain_decimal`] reads: their value stays below 2⁶⁴.
const MAX_PLAIN_DIGITS: usize = 19;

/// The number CAM systems write almost always, `[+-]digits[.digits]` without an exponent, with
/// at most 19 digits and a value of at most 2⁵³ units of its last digit: its value and length.
/// Both the digits and the power of ten are then exact doubles, so one correctly rounded
/// division gives the correctly rounded value (Clinger's fast path), the same double the general
/// parser returns. `None` for anything else (an exponent, more digits), which the general parser
/// reads. The caller has checked that a digit comes first, or a point and a digit.
fn plain_decimal(b: &[u8]) -> Option<(f64, usize)> {
    let negative = b.first() == Some(&b'-');
    let mut k = usize::from(matches!(b.first(), Some(b'+' | b'-')));
    let (mut mantissa, digits) = digit_run(b.get(k..)?)?;
    k += digits;
    let mut decimals = 0;
    if b.get(k) == Some(&b'.') {
        k += 1;
        let (fraction, n) = digit_run(b.get(k..)?)?;
        if digits + n > MAX_PLAIN_DIGITS {
            return None;
        }
        // Below 10¹⁹: no overflow.
        mantissa = mantissa * POW10_U64[n] + fraction;
        decimals = n;
        k += n;
    }
    if mantissa > 1 << 53 || matches!(b.get(k), Some(b'e' | b'E' | b'd' | b'D')) {
        return None;
    }
    // At most 19 decimals: within the exact powers of ten.
    let magnitude = mantissa as f64 / POW10[decimals];
    Some((if negative { -magnitude } else { magnitude }, k))
}

/// The run of ASCII digits that starts `b`: its value and length, eight digits at a time (SWAR);
/// `None` past [`MAX_PLAIN_DIGITS`] digits.
fn digit_run(b: &[u8]) -> Option<(u64, usize)> {
    let mut value: u64 = 0;
    let mut n = 0;
    loop {
        let Some(chunk) = load8(b, n) else {
            // Fewer than eight bytes left: one digit at a time.
            for &c in b.get(n..)? {
                if !c.is_ascii_digit() {
                    break;
                }
                value = value.wrapping_mul(10).wrapping_add(u64::from(c - b'0'));
                n += 1;
            }
            return (n <= MAX_PLAIN_DIGITS).then_some((value, n));
        };
        let count = leading_digits(chunk);
        if count > 0 {
            value = value.wrapping_mul(POW10_U64[count]).wrapping_add(first_digits(chunk, count));
        }
        n += count;
        if n > MAX_PLAIN_DIGITS {
            return None;
        }
        if count < 8 {
            return Some((value, n));
        }
    }
}

/// `ZEROS` subtracted from eight ASCII digits leaves their values.
const ZEROS: u64 = 0x3030_3030_3030_3030;

/// How many of the eight bytes of `chunk` (the first in the lowest byte) are ASCII digits before
/// the first that is not: the high bit of each byte below `0` (the subtraction borrows) or above
/// `9` (the addition reaches 0x80) is set. Borrows and carries only move to later bytes, so the
/// first byte flagged is the first non-digit.
fn leading_digits(chunk: u64) -> usize {
    let flags = (chunk.wrapping_sub(ZEROS) | chunk.wrapping_add(0x4646_4646_4646_4646)) & 0x8080_8080_8080_8080;
    (flags.trailing_zeros() / 8) as usize
}

/// The value of the first `n` digits of `chunk` (1 ≤ `n` ≤ 8, all digits).
fn first_digits(chunk: u64, n: usize) -> u64 {
    eight_digits(chunk.wrapping_sub(ZEROS) << (8 * (8 - n)))
}

/// The eight bytes of `b` from `k`, the first in the lowest byte, when there are eight.
fn load8(b: &[u8], k: usize) -> Option<u64> {
    Some(u64::from_le_bytes(b.get(k..k + 8)?.try_into().ok()?))
}

/// The short number that nearly every CL value is, `[+-]ddd[.ddd]` with at most seven digits
/// before the point and seven after, read with one 8-byte load for each part: its value and end,
/// as [`plain_decimal`] gives them (at most 14 digits: the exact fast path). `None` when it is
/// not that (more digits, an exponent, fewer than eight bytes left to load): not decided.
#[inline(always)]
fn short_decimal(b: &[u8], k: usize) -> Option<(f64, usize)> {
    let first = *b.get(k)?;
    let start = k + usize::from(first == b'-' || first == b'+');
    let chunk = load8(b, start)?;
    let whole = leading_digits(chunk);
    if whole == 8 {
        return None;
    }
    // The byte after the digits, from the chunk.
    let after = (chunk >> (8 * whole)) as u8;
    let (mantissa, decimals, end, next) = if after == b'.' {
        let fraction = load8(b, start + whole + 1)?;
        let decimals = leading_digits(fraction);
        let digits = whole + decimals;
        if decimals == 8 || digits == 0 {
            return None;
        }
        let mantissa = if digits <= 8 {
            // The whole digits, then the fraction's above them: one conversion of all of them.
            let whole_values = chunk.wrapping_sub(ZEROS) & ((1 << (8 * whole)) - 1);
            let values = whole_values | (fraction.wrapping_sub(ZEROS) << (8 * whole));
            eight_digits(values << (8 * (8 - digits)))
        } else {
            first_digits(chunk, whole) * POW10_U64[decimals] + first_digits(fraction, decimals)
        };
        (mantissa, decimals, start + digits + 1, (fraction >> (8 * decimals)) as u8)
    } else if whole == 0 {
        return None;
    } else {
        (first_digits(chunk, whole), 0, start + whole, after)
    };
    if matches!(next, b'e' | b'E' | b'd' | b'D') {
        return None;
    }
    // Below 10¹⁴: the signed conversion is exact and one instruction.
    let magnitude = mantissa as i64 as f64 / POW10[decimals];
    Some((if first == b'-' { -magnitude } else { magnitude }, end))
}

/// A number [`short_decimal`] leaves for its fraction's length, `[+-]ddd.dddddddd[ddddddd]` with
/// at most seven digits before the point, eight to fifteen after (Creo writes ten) and fifteen
/// in all, read with three 8-byte loads: its value and end, as [`plain_decimal`] gives them (below
/// 10¹⁵ < 2⁵³: the exact fast path). `None` when it is not that.
fn long_decimal(b: &[u8], k: usize) -> Option<(f64, usize)> {
    let first = *b.get(k)?;
    let start = k + usize::from(first == b'-' || first == b'+');
    let chunk = load8(b, start)?;
    let whole = leading_digits(chunk);
    if whole == 8 || (chunk >> (8 * whole)) as u8 != b'.' {
        return None;
    }
    let fraction = load8(b, start + whole + 1)?;
    let more = load8(b, start + whole + 9)?;
    let extra = leading_digits(more);
    let decimals = 8 + extra;
    if leading_digits(fraction) < 8 || whole + decimals > 15 {
        return None;
    }
    if matches!((more >> (8 * extra)) as u8, b'e' | b'E' | b'd' | b'D') {
        return None;
    }
    let digits = |chunk: u64, n: usize| if n == 0 { 0 } else { first_digits(chunk, n) };
    let mantissa =
        (digits(chunk, whole) * POW10_U64[8] + first_digits(fraction, 8)) * POW10_U64[extra] + digits(more, extra);
    // Below 10¹⁵: the signed conversion is exact and one instruction.
    let magnitude = mantissa as i64 as f64 / POW10[decimals];
    Some((if first == b'-' { -magnitude } else { magnitude }, start + whole + 1 + decimals))
}

/// The value of eight digits given as byte values 0–9, the first digit in the lowest byte.
fn eight_digits(v: u64) -> u64 {
    const MASK: u64 = 0x0000_00FF_0000_00FF;
    const MUL1: u64 = 100 + (1_000_000 << 32);
    const MUL2: u64 = 1 + (10_000 << 32);
    // Pairs of digits, then groups of four, then the eight.
    let v = v.wrapping_mul(10).wrapping_add(v >> 8);
    let high = (v & MASK).wrapping_mul(MUL1);
    let low = ((v >> 16) & MASK).wrapping_mul(MUL2);
    u64::from((high.wrapping_add(low) >> 32) as u32)
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
    if let Some((major, _)) = goto_args(text.as_bytes(), 0, false, buf) {
        return Ok(goto(text, major, buf));
    }
    buf.clear();
    grammar(text, buf, true)
}

/// The statement grammar itself (every record the GOTO fast path does not take); `fast_numbers`:
/// an argument list of numbers only is read by [`numbers`] rather than by the combinators.
fn grammar<'t: 'b, 'b>(text: &'t str, buf: &'b mut Args<'t>, fast_numbers: bool) -> Result<Statement<'b>, SyntaxError> {
    let err = |e: nom::Err<PError<'_>>| match e {
        nom::Err::Error(e) | nom::Err::Failure(e) => {
            SyntaxError { at: text.len() - e.input.len(), expected: e.expected }
        }
        nom::Err::Incomplete(_) => SyntaxError { at: text.len(), expected: "more input" },
    };
    let Head { major, word, body } = head(text)?;
    let mut issues = SmallVec::new();
    let body = match body {
        HeadBody::None => Body::None,
        HeadBody::Text(t) => Body::Text(t),
        HeadBody::Args(k) => {
            let b = text.as_bytes();
            if !(fast_numbers && numbers(b, skip_blanks(b, k), 0, false, buf).is_some()) {
                buf.clear();
                let (rest, ()) = args(&text[k..], k, buf, &mut issues).map_err(err)?;
                debug_assert!(rest.is_empty());
            }
            Body::Args(buf.as_slice())
        }
    };
    Ok(Statement { major, word, body, issues })
}

/// A statement's major word and what follows it, its arguments not read yet ([`head`]).
pub(crate) struct Head<'t> {
    /// The major word as written, trimmed.
    pub(crate) major: &'t str,
    /// The classified major word.
    pub(crate) word: Word,
    /// What follows the major word.
    pub(crate) body: HeadBody<'t>,
}

/// What follows a major word ([`Head`]).
pub(crate) enum HeadBody<'t> {
    /// No slash.
    None,
    /// Free text (PPRINT, INSERT, PARTNO, …), trimmed.
    Text(&'t str),
    /// Arguments, from this offset in the text on.
    Args(usize),
}

/// The major word of the statement in `text`, classified as [`statement`] classifies it, without
/// reading its arguments: what the pre-scan needs of most records. An error only where the
/// major word is missing; arguments that would not read are the reader's to report.
pub(crate) fn head(text: &str) -> Result<Head<'_>, SyntaxError> {
    let lead = text.len() - text.trim_start().len();
    let mut start = lead;
    // A leading sequence number (`N10 GOTO/…`) from card images.
    if let Some(n) = sequence_number_len(&text[start..]) {
        start += n;
    }
    let body_text = &text[start..];

    // Slash-less free text: `PARTNO PART TO BE MACHINED`, `PPRINT TOOL: D 2,5`.
    let first_token_len = memchr::memchr3(b' ', b'\t', b'/', body_text.as_bytes()).unwrap_or(body_text.len());
    let first = &body_text[..first_token_len];
    let first_word = Word::from_major(first);
    if first_word.is_text() && !body_text[first_token_len..].trim_start().starts_with('/') {
        let rest = &body_text[first_token_len..];
        return Ok(Head { major: first, word: first_word, body: HeadBody::Text(rest.trim()) });
    }

    let (major, after) = match memchr::memchr(b'/', body_text.as_bytes()) {
        Some(k) => (&body_text[..k], Some(k + 1)),
        None => (body_text, None),
    };
    let major = major.trim_end();
    if major.is_empty() {
        return Err(SyntaxError { at: start, expected: "a major word before `/`" });
    }
    // Usually the first token is the major word (`PAINT/…`): classified once.
    let word = if major.len() == first.len() { first_word } else { Word::from_major(major) };
    let body = match after {
        None => HeadBody::None,
        Some(k) if word.is_text() => HeadBody::Text(body_text[k..].trim()),
        Some(k) => HeadBody::Args(start + k),
    };
    Ok(Head { major, word, body })
}

/// The statement of a record whose arguments [`goto_args`] has read: `GOTO` at `major` in `text`.
pub(crate) fn goto<'b>(text: &'b str, major: usize, args: &'b [Arg<'b>]) -> Statement<'b> {
    let major = text.get(major..major + 4).unwrap_or("GOTO");
    Statement { major, word: Word::Goto, body: Body::Args(args), issues: SmallVec::new() }
}

/// The dominant statement, `GOTO/x,y,z[,i,j,k]` with numbers only (blanks around the slash and
/// the commas allowed), read from `b[from]` straight into `buf`: the arguments, offsets (from
/// `from`) and numbers the grammar would give, without its combinators. It ends at the end of `b`
/// or, when `line` is set, at the first line end (`\n` or `\r`), so that a whole physical line
/// can be read in one go. Returns where `GOTO` starts and where the statement ends. `None` for
/// anything else (a word, an empty argument, a missing comma, a `$`, a sequence number…),
/// which the record splitter and the grammar then read; `buf` may hold a part of the arguments.
pub(crate) fn goto_args(b: &[u8], from: usize, line: bool, buf: &mut Args<'_>) -> Option<(usize, usize)> {
    let major = skip_blanks(b, from);
    if !b.get(major..major + 4)?.eq_ignore_ascii_case(b"GOTO") {
        return None;
    }
    let k = skip_blanks(b, major + 4);
    if b.get(k) != Some(&b'/') {
        return None;
    }
    let end = numbers(b, skip_blanks(b, k + 1), from, line, buf)?;
    Some((major - from, end))
}

/// An argument list of numbers only (blanks around the commas allowed), from `b[k]` (not a
/// blank) straight into `buf`, offsets from `from`: the arguments the grammar would give, without
/// its combinators. It ends at the end of `b` or, when `line` is set, at the first line end;
/// returns where. `None` for anything else (a word, an empty argument, a missing comma, a `$`…);
/// `buf` may then hold a part of the arguments.
fn numbers(b: &[u8], mut k: usize, from: usize, line: bool, buf: &mut Args<'_>) -> Option<usize> {
    loop {
        // The short path inlined in this loop: through `number_at` every file reads 6 to 12 %
        // slower (callgrind, `check`).
        let (value, end) = short_decimal(b, k).or_else(|| number_not_short(b, k))?;
        buf.push(Arg { value: Value::Num(value), start: (k - from) as u32, end: (end - from) as u32 });
        // Mostly a comma right after the number, and the next number right after it.
        if b.get(end) == Some(&b',') && !matches!(b.get(end + 1), Some(b' ' | b'\t')) {
            k = end + 1;
            continue;
        }
        k = skip_blanks(b, end);
        match b.get(k) {
            None => return Some(k),
            Some(b'\n' | b'\r') if line => return Some(k),
            Some(b',') => k = skip_blanks(b, k + 1),
            Some(_) => return None,
        }
    }
}

/// The first index from `k` on that is not a blank.
fn skip_blanks(b: &[u8], mut k: usize) -> usize {
    while matches!(b.get(k), Some(b' ' | b'\t')) {
        k += 1;
    }
    k
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

    /// The head of a record is the statement's major word, classified the same, and its free
    /// text; its arguments are not read, so a record whose arguments do not read has a head.
    #[test]
    fn a_record_s_head_is_its_statement_s_major_word() {
        let records = [
            "GOTO/1,2,3",
            "N10 GOTO/1,2,3",
            "  paint/COLOR,37",
            "TOOL PATH/VARIABLE_CONTOUR,TOOL,BPR-SNR-323S32",
            "CIRCLE/115.6198,82.7726,110.0,0.0,0.0,1.0,207.8614,0.06,0.5,30.0,0.0",
            "RAPID",
            "END-OF-PATH",
            "PPRINT/APTCL-SPEC,MAKINO",
            "PPRINT TOOL: D 2,5",
            "PARTNO PART TO BE MACHINED",
            "REMARK * PRO/CLFILE",
            "MOVE_ATTRIB/ON",
            "FEDRAT/MMPM,250.0",
        ];
        for text in records {
            let st = statement(text).expect("a statement");
            let head = head(text).expect("a head");
            assert_eq!((head.major, head.word), (st.major, st.word), "{text}");
            match (head.body, st.body) {
                (HeadBody::None, Body::None) => {}
                (HeadBody::Text(h), Body::Text(t)) => assert_eq!(h, t, "{text}"),
                (HeadBody::Args(k), Body::Args(_)) => assert_eq!(&text[k - 1..k], "/", "{text}"),
                _ => panic!("{text}: another body"),
            }
        }
        let head = head("CIRCLE/1,2,(3").expect("a head");
        assert_eq!(head.word, Word::Circle);
        assert!(statement("CIRCLE/1,2,(3").is_err());
        assert!(super::head("/1,2,3").is_err());
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

    /// The arguments of a statement, comparable: value (numbers by their bits), start, end.
    fn shape(s: &Statement<'_>) -> (String, Word, Vec<(String, u32, u32)>, usize) {
        let args = s
            .args()
            .iter()
            .map(|a| {
                let v = match a.value {
                    Value::Num(n) => format!("num {:#x}", n.to_bits()),
                    other => format!("{other:?}"),
                };
                (v, a.start, a.end)
            })
            .collect();
        (s.major.to_string(), s.word, args, s.issues.len())
    }

    #[test]
    fn digit_runs_of_every_length() {
        for text in [
            "",
            "x",
            "7",
            "12",
            "0000",
            "1234567",
            "12345678",
            "123456789,",
            "1234567890123456789",
            "99999999999999999999",
        ] {
            let digits = text.bytes().take_while(u8::is_ascii_digit).count();
            let expected = (digits <= MAX_PLAIN_DIGITS).then(|| (text[..digits].parse::<u64>().unwrap_or(0), digits));
            assert_eq!(digit_run(text.as_bytes()), expected, "{text}");
        }
        assert_eq!(plain_decimal(b"-12.5,"), Some((-12.5, 5)));
        assert_eq!(plain_decimal(b"0.9859323"), Some((0.9859323, 9)));
        assert_eq!(plain_decimal(b"25."), Some((25.0, 3)));
        assert_eq!(plain_decimal(b"1.5E-3"), None);
        assert_eq!(short_decimal(b"GOTO/-1.7365,0.1736482\n", 5), Some((-1.7365, 12)));
        assert_eq!(short_decimal(b"GOTO/-1.7365,0.1736482\nGOTO/", 13), Some((0.1736482, 22)));
        assert_eq!(short_decimal(b"x,25.,.005,7\n\n\n\n\n\n\n", 2), Some((25.0, 5)));
        assert_eq!(short_decimal(b"x,25.,.005,7\n\n\n\n\n\n\n", 6), Some((0.005, 10)));
        assert_eq!(short_decimal(b"x,25.,.005,7\n\n\n\n\n\n\n", 11), Some((7.0, 12)));
        assert_eq!(short_decimal(b"0.1736482", 0), None, "fewer than eight bytes after the point");
        assert_eq!(short_decimal(b"-.,0000000000", 0), None);
        assert_eq!(short_decimal(b"1.5E-3,00000000", 0), None);
        // Creo's ten decimals: past the short path, read by the long one.
        let creo = b"GOTO / -16.1677728056, -23.6363664797, 2.0000000000\n";
        assert_eq!(short_decimal(creo, 7), None);
        assert_eq!(long_decimal(creo, 7), Some((-16.1677728056, 21)));
        assert_eq!(long_decimal(b"0.000000000000000,0000000", 0), None, "sixteen digits");
        assert_eq!(long_decimal(b"-1.7365,0.1736482,0000000", 0), None, "a short number");
    }

    #[test]
    fn the_goto_fast_path_reads_what_the_grammar_reads() {
        for text in [
            "GOTO/2.2487,0.0000,0.1536,0.1671454,0.0000000,0.9859323",
            "  goto  /  -7.2,  -23.0 , 2.0 ",
            "GOTO/-0.000,+.5,25.",
            "GOTO/1.5E-3,.5773503D+00,12345678901234567890.5",
            "GOTO/1,2,3,4,5,6,7,8,9,10",
        ] {
            let mut fast = Args::new();
            assert!(goto_args(text.as_bytes(), 0, false, &mut fast).is_some(), "{text}");
            let slow = grammar(text, Box::leak(Box::new(Args::new())), false).expect("parses");
            assert_eq!(shape(&statement(text).expect("parses")), shape(&slow), "{text}");
        }
        for text in ["GOTO/1,2,3,", "GOTO/1 2,3", "GOTO/1,,3", "GOTO/SETPT2", "N10 GOTO/1,2,3", "GOTOX/1", "GOTO/"] {
            assert!(goto_args(text.as_bytes(), 0, false, &mut Args::new()).is_none(), "{text}");
        }
    }

    proptest::proptest! {
        /// Any text reads the same through the fast paths (GOTO's, and any record's list of
        /// numbers) as through the grammar's combinators alone, errors included.
        #[test]
        fn the_fast_paths_agree_with_the_grammar(
            lead in "[ \t]{0,2}",
            word in "(GOTO|goto|GoTo|CIRCLE|circle|TLAXIS|CUTTER|CYCLE/DRILL,)",
            slash in "[ \t]{0,2}/[ \t]{0,2}",
            args in proptest::collection::vec("[+-]?[0-9]{0,22}(\\.[0-9]{0,22})?([eEdD][+-]?[0-9]{1,3})?[ \t]{0,2}", 0..13),
            sep in "[ \t]{0,2},",
            tail in "([ \t,x]|\\$)?",
        ) {
            let text = format!("{lead}{word}{slash}{}{tail}", args.join(&sep));
            let fast = statement(&text).map(|s| shape(&s));
            let slow = grammar(&text, Box::leak(Box::new(Args::new())), false).map(|s| shape(&s));
            proptest::prop_assert_eq!(fast, slow);
        }

        /// The short- and long-number paths read what the plain-decimal path reads, wherever
        /// they decide.
        #[test]
        fn short_decimals_read_as_plain_decimals(
            lead in "[0-9,]{0,3}",
            text in "[+-]?[0-9]{0,9}(\\.[0-9]{0,17})?[eEdD,\n x]?",
            tail in "[0-9,\n]{0,18}",
        ) {
            let all = format!("{lead}{text}{tail}");
            let b = all.as_bytes();
            let k = lead.len();
            for (value, end) in [short_decimal(b, k), long_decimal(b, k)].into_iter().flatten() {
                let s = &b[k..];
                let digits_at = usize::from(matches!(s.first(), Some(b'+' | b'-')));
                proptest::prop_assert!(
                    s.get(digits_at).is_some_and(u8::is_ascii_digit)
                        || s.get(digits_at) == Some(&b'.') && s.get(digits_at + 1).is_some_and(u8::is_ascii_digit),
                    "{all:?}: not a number's start"
                );
                let (expected, used) = plain_decimal(s).expect("a plain decimal");
                proptest::prop_assert_eq!((value.to_bits(), end), (expected.to_bits(), k + used), "{:?}", all);
            }
        }

        /// The plain-decimal fast path gives the correctly rounded double, as the general parser.
        #[test]
        fn plain_decimals_are_correctly_rounded(text in "[+-]?([0-9]{1,20}(\\.[0-9]{0,20})?|\\.[0-9]{1,20})") {
            if let Some((value, used)) = plain_decimal(text.as_bytes()) {
                let (expected, n) = fast_float2::parse_partial::<f64, _>(text.as_bytes()).expect("a number");
                proptest::prop_assert_eq!((value.to_bits(), used), (expected.to_bits(), n));
                let std: f64 = text[..used].parse().expect("std parses it");
                proptest::prop_assert_eq!(value.to_bits(), std.to_bits());
            }
        }
    }

    #[test]
    fn lower_case_and_sequence_numbers() {
        let s = statement("N10 goto/1,2,3").expect("parses");
        assert_eq!(s.word, Word::Goto);
        assert_eq!(s.major, "goto");
    }
}
