//! The pre-scan: what the reader must know before the first statement, found in one quick pass
//! over the physical lines.
//!
//! - The **length unit**: the first `UNITS`/`UNIT` statement; else the unit word of the first
//!   `FEDRAT` that has one (NX writes no UNITS); else millimetres.
//! - The **CAM system**, whose arc convention applies to every `CIRCLE` as it is read: a header
//!   wins (`$$* Pro/CLfile` or `REMARK * PRO/CLFILE` for Creo, a comment naming CATIA,
//!   `PPRINT/APTCL-SPEC,MAKINO…`, the example generator's comment); otherwise the vocabulary
//!   votes, one vote per record: `TOOL PATH`, `PAINT` and NX listing lines for NX; `OPFEATSTART`, `MOVE_ATTRIB`, `BOX` for CAMWorks;
//!   `CSYS`, `TRNTYP`, `CSI_SET_FLUTE_LENGTH` for SOLIDWORKS CAM; `MOVARC`, `MODE` for Fusion.
//!   The most votes win; a tie goes to the system listed first in [`CamSystem::ALL`].
//! - The number of arc records (`CIRCLE`, `MOVARC`): whether the arc sense matters at all.
//!
//! Only lines that start like one of these words are looked at. A line whose major word and
//! text are on the line itself (no `$`) is classified from the line; a line holding a `$`
//! (a continued record, possibly cut inside the major word) goes through the record splitter,
//! exactly as the reader will see it. A record is classified by its major word as the statement
//! grammar classifies it ([`syntax::head`]) without reading its arguments, but for `UNITS` and
//! `FEDRAT`, whose unit words are arguments: a record whose arguments do not read still counts
//! here (an arc record, a vote), and the reader reports it.

use crate::model::{CamSystem, LengthUnit, UnitsInfo, UnitsOrigin};
use crate::records::{Splitter, Unit as RawUnit, is_listing_line};
use crate::span::Span;
use crate::syntax::{self, Arg, Body, Head, HeadBody, Value};
use crate::words::Word;

/// What the pre-scan found.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Prescan {
    /// The file's length unit and what decided it.
    pub(super) units: UnitsInfo,
    /// The CAM system, when recognised.
    pub(super) cam: Option<CamSystem>,
    /// `CIRCLE` and `MOVARC` records.
    pub(super) arc_records: usize,
}

/// Scans `src` once.
#[cfg(test)]
pub(super) fn prescan(src: &str) -> Prescan {
    let mut scan = Prescanner::default();
    scan.window(src, 0, true);
    scan.finish()
}

/// The pre-scan over a text that comes in windows (each ending at a line end; see
/// [`crate::ClFile`]).
#[derive(Default)]
pub(crate) struct Prescanner {
    units: Option<UnitsInfo>,
    feed_hint: Option<UnitsInfo>,
    cam: CamEvidence,
    arc_records: usize,
    seen_statement: bool,
    /// The line before ends with a continuation `$`.
    continued: bool,
}

impl Prescanner {
    /// Scans the lines of `src`, the window of the text at offset `base` (`last`: it ends the
    /// text); returns where it stopped in `src`: the end, or the start of a continued record
    /// that runs past the window, which comes again at the start of the next one.
    pub(crate) fn window(&mut self, src: &str, base: usize, last: bool) -> usize {
        let bytes = src.as_bytes();
        let mut pos = 0;
        while pos < bytes.len() {
            // A line ends at `\n`, `\r\n` or a lone `\r`, as for the reader.
            let start = pos;
            let line_end = memchr::memchr2(b'\n', b'\r', &bytes[pos..]).map_or(bytes.len(), |k| pos + k);
            pos = match bytes.get(line_end) {
                Some(b'\r') if bytes.get(line_end + 1) == Some(&b'\n') => line_end + 2,
                Some(_) => line_end + 1,
                None => line_end,
            };
            let line = &bytes[start..line_end];
            // A continuation line belongs to the record (or comment) before it.
            let was_continued = std::mem::replace(&mut self.continued, ends_with_single_dollar(line));
            let Some(lead) = line.iter().position(|&c| c != b' ' && c != b'\t') else { continue };
            if was_continued {
                continue;
            }
            let first = line[lead];
            if first == b'$' && line.get(lead + 1) == Some(&b'$') {
                self.cam.comment(&src[start + lead..line_end]);
                continue;
            }
            let upper = first.to_ascii_uppercase();
            let units_open = self.units.is_none();
            let wanted_units = units_open && (upper == b'U' || upper == b'F' && self.feed_hint.is_none());
            let wanted = wanted_units || matches!(upper, b'B' | b'C' | b'M' | b'O' | b'P' | b'R' | b'T');
            // Past the header, a line that starts with a character no word of interest (nor the
            // listing footer) starts with is passed at once: most lines, GOTOs.
            if self.seen_statement && !wanted && first.is_ascii_graphic() {
                continue;
            }
            let line = &src[start..line_end];
            if is_listing_line(line, self.seen_statement) {
                self.cam.vote(CamSystem::SiemensNx);
                continue;
            }
            if !wanted {
                self.seen_statement = true;
                continue;
            }
            let Some(seen) = (match classify(src, start, line, last) {
                Classified::Seen(seen) => Some(seen),
                Classified::Nothing => None,
                // The record runs past the window: this line again, with the next window.
                Classified::PastWindow => {
                    self.continued = was_continued;
                    return start;
                }
            }) else {
                self.seen_statement = true;
                continue;
            };
            self.seen_statement = true;
            let span = Span { start: seen.span.start + base as u32, ..seen.span };
            match seen.word {
                Word::Units => {
                    if let Some(unit) = seen.unit {
                        self.units.get_or_insert(UnitsInfo { unit, origin: UnitsOrigin::Declared(span) });
                    }
                }
                Word::Fedrat if self.feed_hint.is_none() => {
                    self.feed_hint = seen.unit.map(|unit| UnitsInfo { unit, origin: UnitsOrigin::FeedWord(span) });
                }
                Word::Circle => self.arc_records += 1,
                Word::Movarc => self.arc_records += 1,
                _ => {}
            }
            match seen.cam {
                Some(Evidence::Header(c)) => self.cam.header(c),
                Some(Evidence::Vote(c)) => self.cam.vote(c),
                None => {}
            }
        }
        bytes.len()
    }

    /// What the scan found.
    pub(crate) fn finish(self) -> Prescan {
        Prescan {
            units: self.units.or(self.feed_hint).unwrap_or_default(),
            cam: self.cam.decide(),
            arc_records: self.arc_records,
        }
    }
}

/// What one statement tells the pre-scan.
struct Seen {
    word: Word,
    /// `UNITS`: the declared unit; `FEDRAT`: the unit of its feed word.
    unit: Option<LengthUnit>,
    /// Evidence of the CAM system.
    cam: Option<Evidence>,
    span: Span,
}

enum Evidence {
    Header(CamSystem),
    Vote(CamSystem),
}

/// The statement that starts on the physical line `line` (at `start` in `src`).
/// What a line of interest is.
enum Classified {
    Seen(Seen),
    Nothing,
    /// A continued record that runs to the end of the window: it may go on in the next one.
    PastWindow,
}

fn classify(src: &str, start: usize, line: &str, last: bool) -> Classified {
    let units_word =
        line.trim_start().as_bytes().first().is_some_and(|c| matches!(c.to_ascii_uppercase(), b'U' | b'F'));
    // UNITS and FEDRAT go through the splitter for the exact span the summary reports.
    if !line.contains('$') && !units_word {
        // The whole record is on this line.
        return match syntax::head(line) {
            Ok(head) => Classified::Seen(seen(&head, &[], Span::new(start, start + line.len()))),
            Err(_) => Classified::Nothing,
        };
    }
    // A continued record (or one with a trailing comment): as the reader will join it.
    let mut splitter = Splitter::at(src, start);
    let unit = splitter.next();
    if !last && splitter.pos() >= src.len() {
        return Classified::PastWindow;
    }
    let Some(RawUnit::Statement(rec)) = unit else { return Classified::Nothing };
    if !units_word {
        return match syntax::head(&rec.text) {
            Ok(head) => Classified::Seen(seen(&head, &[], rec.span)),
            Err(_) => Classified::Nothing,
        };
    }
    // The unit words are arguments.
    let mut buf = syntax::Args::new();
    match syntax::statement(&rec.text, &mut buf) {
        Ok(st) => {
            let text = if let Body::Text(t) = st.body { HeadBody::Text(t) } else { HeadBody::None };
            Classified::Seen(seen(&Head { major: st.major, word: st.word, body: text }, st.args(), rec.span))
        }
        Err(_) => Classified::Nothing,
    }
}

/// What the statement of `head`, with arguments `args` where they were read, tells.
fn seen(head: &Head<'_>, args: &[Arg<'_>], span: Span) -> Seen {
    let words = || args.iter().filter_map(|a| if let Value::Word(w) = a.value { Some(w) } else { None });
    let text = if let HeadBody::Text(t) = head.body { t } else { "" };
    let unit = match head.word {
        Word::Units => words().next().and_then(unit_word),
        Word::Fedrat => words().find_map(feed_unit_word),
        _ => None,
    };
    let is = |w: &str| head.major.trim().eq_ignore_ascii_case(w);
    let cam = match head.word {
        Word::Movarc => Some(Evidence::Vote(CamSystem::Fusion)),
        Word::ToolPath => Some(Evidence::Vote(CamSystem::SiemensNx)),
        Word::OpFeatStart => Some(Evidence::Vote(CamSystem::CamWorks)),
        Word::Csys | Word::Trntyp => Some(Evidence::Vote(CamSystem::SolidworksCam)),
        Word::Pprint if starts_with_ignore_case(text, "APTCL-SPEC,MAKINO") => {
            Some(Evidence::Header(CamSystem::MakinoFfcam))
        }
        Word::Remark if contains_ignore_case(text, "PRO/CLFILE") => Some(Evidence::Header(CamSystem::Creo)),
        Word::Passive if is("PAINT") => Some(Evidence::Vote(CamSystem::SiemensNx)),
        Word::Passive if is("MOVE_ATTRIB") || is("BOX") => Some(Evidence::Vote(CamSystem::CamWorks)),
        Word::Passive if is("CSI_SET_FLUTE_LENGTH") => Some(Evidence::Vote(CamSystem::SolidworksCam)),
        Word::Passive if is("MODE") => Some(Evidence::Vote(CamSystem::Fusion)),
        _ => None,
    };
    Seen { word: head.word, unit, cam, span }
}

fn feed_unit_word(w: &str) -> Option<LengthUnit> {
    match w.to_ascii_uppercase().as_str() {
        "IPM" | "IPR" => Some(LengthUnit::Inch),
        "MMPM" | "MMPR" => Some(LengthUnit::Mm),
        _ => None,
    }
}

/// The unit of a `UNITS` minor word.
pub(super) fn unit_word(w: &str) -> Option<LengthUnit> {
    match w.to_ascii_uppercase().as_str() {
        "MM" | "MILLIMETERS" | "MILLIMETRES" | "METRIC" => Some(LengthUnit::Mm),
        "INCHES" | "INCH" | "IN" => Some(LengthUnit::Inch),
        _ => None,
    }
}

/// The line ends with a single `$` (not `$$`): the next line continues its record or comment.
fn ends_with_single_dollar(line: &[u8]) -> bool {
    let n = line.iter().rposition(|&c| c != b' ' && c != b'\t').map_or(0, |p| p + 1);
    line[..n].ends_with(b"$") && !line[..n].ends_with(b"$$")
}

fn starts_with_ignore_case(text: &str, prefix: &str) -> bool {
    text.get(..prefix.len()).is_some_and(|p| p.eq_ignore_ascii_case(prefix))
}

/// ASCII case-insensitive substring search (`needle` upper case).
fn contains_ignore_case(hay: &str, needle: &str) -> bool {
    let (h, n) = (hay.as_bytes(), needle.as_bytes());
    n.is_empty() || h.windows(n.len()).any(|w| w.eq_ignore_ascii_case(n))
}

/// Evidence of the CAM system: an explicit header wins, otherwise the most frequent vocabulary.
#[derive(Default)]
struct CamEvidence {
    header: Option<CamSystem>,
    votes: [u32; CamSystem::ALL.len()],
}

impl CamEvidence {
    fn header(&mut self, cam: CamSystem) {
        self.header.get_or_insert(cam);
    }

    fn vote(&mut self, cam: CamSystem) {
        self.votes[cam as usize] += 1;
    }

    /// A whole-line comment: the headers of Creo, CATIA and the example generator.
    fn comment(&mut self, text: &str) {
        if contains_ignore_case(text, "PRO/CLFILE") {
            self.header(CamSystem::Creo);
        } else if contains_ignore_case(text, "CATIA") {
            self.header(CamSystem::CatiaV5);
        } else if contains_ignore_case(text, "POSTPRO-EXAMPLES") {
            self.header(CamSystem::PostproExamples);
        }
    }

    fn decide(&self) -> Option<CamSystem> {
        let (best, &n) = self.votes.iter().enumerate().max_by_key(|&(k, n)| (n, std::cmp::Reverse(k)))?;
        self.header.or((n > 0).then(|| CamSystem::ALL[best]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Records count by their major word, continued ones too: an arc record whose arguments do
    /// not read (the reader reports it) is an arc record, and the vocabulary votes.
    #[test]
    fn records_count_by_their_major_word() {
        let src = "TOOL PATH/ZLEVEL,TOOL,MILL\nPAINT/COLOR,3\nGOTO/1,2,3\nCIRCLE/0,0,0,0,0,1,5,(0.06\nCIRCLE/0,0,0,$\n0,0,1,5\nGOTO/1,2,3\n";
        let pre = prescan(src);
        assert_eq!(pre.arc_records, 2);
        assert_eq!(pre.cam, Some(CamSystem::SiemensNx));
    }

    /// A continuation line is part of the record before it, whatever the line ends: with CRLF
    /// too (it used to be read as a line of its own there, after the empty "line" between `\r`
    /// and `\n`).
    #[test]
    fn continuation_lines_are_not_statements_with_any_line_end() {
        for end in ["\n", "\r\n", "\r"] {
            let src = format!("PPRINT/SEE$ {end}UNITS/INCHES{end}FEDRAT/10,MMPM{end}GOTO/1,2,3{end}");
            let pre = prescan(&src);
            assert_eq!(pre.units.unit, LengthUnit::Mm, "{end:?}");
            assert!(matches!(pre.units.origin, UnitsOrigin::FeedWord(_)), "{end:?}");
        }
    }
}
