//! Work offsets, dialect-neutral: which one the program selects, written as a shop writes it
//! (`G54`, `G54.1 P7`, `G505`, `G59.3`, `preset 3`). Whether a dialect has a given offset is the
//! emitter's business.

use std::fmt;
use std::str::FromStr;

/// The forms [`WorkOffset::from_str`] accepts, for error messages.
pub const ACCEPTED: &str = "`G54`…`G59`, `G54.1 P1`…`G54.1 P300` (Haas also `G154 P1`…), `G59.1`…`G59.3`, \
     `G505`…`G599` or `preset N`";

/// The largest `P` of `G54.1 Pn` (Fanuc's largest option has 300 additional offsets).
pub const MAX_G54_1: u16 = 300;

/// A work offset (the frame in which the program's coordinates are written).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum WorkOffset {
    /// `G54` … `G59` (the value is 54 to 59).
    G(u8),
    /// LinuxCNC's `G59.1` … `G59.3` (the value is 1 to 3).
    G59Dot(u8),
    /// Fanuc's and Haas's additional offsets `G54.1 P1` … `G54.1 P300` (Haas: `G154 Pn`).
    G54_1(u16),
    /// A Siemens settable frame `G505` … `G599`.
    Frame(u16),
    /// A row of the Heidenhain preset table.
    Preset(u32),
}

impl Default for WorkOffset {
    /// `G54`.
    fn default() -> Self {
        WorkOffset::G(54)
    }
}

impl fmt::Display for WorkOffset {
    /// The canonical text: `G54`, `G59.1`, `G54.1 P7`, `G505`, `preset 3`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            WorkOffset::G(n) => write!(f, "G{n}"),
            WorkOffset::G59Dot(k) => write!(f, "G59.{k}"),
            WorkOffset::G54_1(p) => write!(f, "G54.1 P{p}"),
            WorkOffset::Frame(n) => write!(f, "G{n}"),
            WorkOffset::Preset(n) => write!(f, "preset {n}"),
        }
    }
}

/// A text that is not a work offset.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("`{text}` is not a work offset{}: expected {ACCEPTED}", reason.as_deref().map(|r| format!(" ({r})")).unwrap_or_default())]
pub struct WorkOffsetError {
    /// The text as given (trimmed).
    pub text: String,
    /// What is wrong with it, where there is more to say than "not a work offset".
    pub reason: Option<String>,
}

/// The digits of `s`, as a number, if `s` is only ASCII digits.
fn digits<T: FromStr>(s: &str) -> Option<T> {
    if !s.is_empty() && s.bytes().all(|b| b.is_ascii_digit()) { s.parse().ok() } else { None }
}

impl FromStr for WorkOffset {
    type Err = WorkOffsetError;

    /// Without case; a space may separate `G54.1` and `P7` (or `preset` and its row), or not.
    fn from_str(s: &str) -> Result<Self, WorkOffsetError> {
        let text = s.trim();
        let fail = |reason: Option<String>| WorkOffsetError { text: text.to_string(), reason };
        let upper = text.to_ascii_uppercase();
        if let Some(row) = upper.strip_prefix("PRESET") {
            return digits(row.trim_start())
                .map(WorkOffset::Preset)
                .ok_or_else(|| fail(Some("a preset is `preset` and a row number".into())));
        }
        let Some(word) = upper.strip_prefix('G') else { return Err(fail(None)) };
        let (g, p) = match word.split_once('P') {
            Some((g, p)) => (g.trim_end(), Some(p.trim_start())),
            None => (word, None),
        };
        match (g, p) {
            ("54.1" | "154", Some(p)) => match digits::<u16>(p) {
                Some(n @ 1..=MAX_G54_1) => Ok(WorkOffset::G54_1(n)),
                _ => Err(fail(Some(format!("P must be 1 to {MAX_G54_1}")))),
            },
            ("54.1" | "154", None) => Err(fail(Some(format!("`G{g}` needs its P number, as in `G54.1 P1`")))),
            ("59.1", None) => Ok(WorkOffset::G59Dot(1)),
            ("59.2", None) => Ok(WorkOffset::G59Dot(2)),
            ("59.3", None) => Ok(WorkOffset::G59Dot(3)),
            (g, None) => match digits::<u16>(g) {
                Some(n @ 54..=59) => Ok(WorkOffset::G(n as u8)),
                Some(n @ 505..=599) => Ok(WorkOffset::Frame(n)),
                _ => Err(fail(None)),
            },
            (_, Some(_)) => Err(fail(Some("only `G54.1` and `G154` take a P number".into()))),
        }
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)] // a failed unwrap is a failed test
mod tests {
    use super::*;

    fn offset(s: &str) -> WorkOffset {
        s.parse().unwrap()
    }

    #[test]
    fn every_form_reads_and_writes_back() {
        for (text, offset_, canonical) in [
            ("G54", WorkOffset::G(54), "G54"),
            ("g59", WorkOffset::G(59), "G59"),
            (" G55 ", WorkOffset::G(55), "G55"),
            ("G54.1 P7", WorkOffset::G54_1(7), "G54.1 P7"),
            ("g54.1p48", WorkOffset::G54_1(48), "G54.1 P48"),
            ("G154 P99", WorkOffset::G54_1(99), "G54.1 P99"),
            ("G54.1 P300", WorkOffset::G54_1(300), "G54.1 P300"),
            ("G59.1", WorkOffset::G59Dot(1), "G59.1"),
            ("G59.3", WorkOffset::G59Dot(3), "G59.3"),
            ("G505", WorkOffset::Frame(505), "G505"),
            ("G599", WorkOffset::Frame(599), "G599"),
            ("preset 3", WorkOffset::Preset(3), "preset 3"),
            ("PRESET0", WorkOffset::Preset(0), "preset 0"),
        ] {
            assert_eq!(offset(text), offset_, "{text}");
            assert_eq!(offset_.to_string(), canonical);
            assert_eq!(offset(canonical), offset_, "{canonical} reads back");
        }
        assert_eq!(WorkOffset::default(), WorkOffset::G(54));
    }

    #[test]
    fn others_are_refused_with_the_accepted_forms() {
        for (text, reason) in [
            ("G53", None),
            ("G60", None),
            ("G504", None),
            ("G600", None),
            ("G59.4", None),
            ("54", None),
            ("", None),
            ("G54.1", Some("`G54.1` needs its P number, as in `G54.1 P1`")),
            ("G54.1 P0", Some("P must be 1 to 300")),
            ("G54.1 P301", Some("P must be 1 to 300")),
            ("G54.1 P-1", Some("P must be 1 to 300")),
            ("G55 P2", Some("only `G54.1` and `G154` take a P number")),
            ("preset", Some("a preset is `preset` and a row number")),
            ("preset -1", Some("a preset is `preset` and a row number")),
        ] {
            let e = text.parse::<WorkOffset>().unwrap_err();
            assert_eq!(e.reason.as_deref(), reason, "{text}");
            assert!(e.to_string().starts_with(&format!("`{text}` is not a work offset")), "{e}");
            assert!(e.to_string().ends_with(&format!("expected {ACCEPTED}")), "{e}");
        }
    }
}
