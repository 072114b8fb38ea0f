//! Controller dialects: the facts a template cannot decide (file extension, comment syntax, how
//! numbers are written, line length, feed ranges, which output modes exist). The layout of the
//! program is the template's (`templates/<name>.j2`).

use postpro_machine::setup::WorkOffset;

use postpro_motion::PlaneKind;

use crate::EmitError;
use crate::program::WorkOffsetWord;

/// The controller's tool-centre-point control: the tool tip in the part frame, the orientation
/// as the rotary axes' angles or as the tool vector ([`TcpOrientation`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum TcpStyle {
    /// Siemens `TRAORI`: the rotary axes (`ORIAXES`) or the vector in `A3 B3 C3` (`ORIVECT`).
    Traori,
    /// Fanuc `G43.4 H…` with the rotary axes, `G43.5 H…` with the vector in `I J K`.
    G43_4,
    /// Haas `G234 H…` with the rotary axes (no vector form).
    G234,
    /// Heidenhain `M128`: `L` blocks with the rotary axes, `LN` blocks with the vector in
    /// `TX TY TZ`.
    M128,
    /// No tool-centre-point control.
    None,
}

impl TcpStyle {
    /// The words of the tool vector, when the controller takes one.
    pub fn vector_words(self) -> Option<[&'static str; 3]> {
        match self {
            TcpStyle::Traori => Some(["A3", "B3", "C3"]),
            TcpStyle::G43_4 => Some(["I", "J", "K"]),
            TcpStyle::M128 => Some(["TX", "TY", "TZ"]),
            TcpStyle::G234 | TcpStyle::None => None,
        }
    }
}

/// How a TCP program gives the tool's orientation.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum TcpOrientation {
    /// The rotary axes' angles, as controllers are mostly programmed (the solver's branch).
    #[default]
    Angles,
    /// The tool vector in the part frame (the controller picks the branch).
    Vectors,
}

/// A controller dialect.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Dialect {
    /// The name machine definitions use (`siemens-840d`).
    pub name: &'static str,
    /// File extension of the NC program, without the dot.
    pub extension: &'static str,
    /// Comment opening and closing.
    pub comment_open: &'static str,
    /// Comment closing (empty for line comments).
    pub comment_close: &'static str,
    /// Characters a comment must not contain (replaced by a blank).
    pub comment_forbidden: &'static str,
    /// Numbers carry an explicit `+` (Heidenhain).
    pub explicit_plus: bool,
    /// Longest line the controller accepts.
    pub max_line: usize,
    /// Feed range for feeds per minute (mm/min).
    pub feed_range: (f64, f64),
    /// F range in inverse-time mode (1/min); `None` without inverse time.
    pub inverse_time_range: Option<(f64, f64)>,
    /// Siemens `BSPLINE`.
    pub bspline: bool,
    /// Tool-centre-point control.
    pub tcp: TcpStyle,
    /// Decimals of F words.
    pub feed_decimals: usize,
    /// Circular interpolation of several turns in one block (LinuxCNC `P`, Siemens `TURN`,
    /// Heidenhain `CP IPA`).
    pub arc_turns: bool,
    /// Circular interpolation in the three principal planes (`G17`/`G18`/`G19`); else X–Y only.
    pub arc_all_planes: bool,
    /// A retract in machine coordinates cancels the tool length offset (Siemens `SUPA … D0`):
    /// it is switched on again before the next motion.
    pub machine_retract_cancels_length: bool,
    /// The work offsets it selects.
    pub work_offsets: WorkOffsets,
    /// Its working planes for 3+2 set-ups (`G68.2`, `G254`, `CYCLE800`, `PLANE`), if any.
    pub planes: Option<PlaneKind>,
    /// F per minute in an inch program is in inches per minute times this (Heidenhain: 10, its
    /// F being in 1/10 in/min in `INCH` programs).
    pub inch_feed_scale: f64,
    /// Every block starts with its number, from 0 (Heidenhain), written by the renderer, not the
    /// template: a line that continues the block before it (which ends with `~`) has none.
    pub numbered_blocks: bool,
}

/// Which work offsets a dialect selects.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum WorkOffsets {
    /// Fanuc: `G54`…`G59`, `G54.1 P1`…`P48`.
    Fanuc,
    /// Haas: `G54`…`G59`, `G154 P1`…`P99` (written `G154 Pn`).
    Haas,
    /// Siemens: `G54`…`G57`, settable frames `G505`…`G599`.
    Siemens,
    /// Heidenhain: a row of the preset table.
    Heidenhain,
    /// LinuxCNC: `G54`…`G59`, `G59.1`…`G59.3`.
    LinuxCnc,
}

impl Dialect {
    /// The work offset as this dialect selects it, or why it cannot.
    pub fn work_offset(&self, offset: &WorkOffset) -> Result<WorkOffsetWord, EmitError> {
        let code = |code: String| Ok(WorkOffsetWord { code, preset: None });
        let (ok, accepted): (Option<Result<WorkOffsetWord, EmitError>>, &str) = match self.work_offsets {
            WorkOffsets::Fanuc => (
                match *offset {
                    WorkOffset::G(54..=59) => Some(code(offset.to_string())),
                    WorkOffset::G54_1(p @ 1..=48) => Some(code(format!("G54.1 P{p}"))),
                    _ => None,
                },
                "G54…G59 or G54.1 P1…P48",
            ),
            WorkOffsets::Haas => (
                match *offset {
                    WorkOffset::G(54..=59) => Some(code(offset.to_string())),
                    WorkOffset::G54_1(p @ 1..=99) => Some(code(format!("G154 P{p}"))),
                    _ => None,
                },
                "G54…G59 or G154 P1…P99 (G54.1 Pn)",
            ),
            WorkOffsets::Siemens => (
                match *offset {
                    WorkOffset::G(54..=57) | WorkOffset::Frame(505..=599) => Some(code(offset.to_string())),
                    _ => None,
                },
                "G54…G57 or G505…G599",
            ),
            WorkOffsets::Heidenhain => (
                match *offset {
                    WorkOffset::Preset(row) => Some(Ok(WorkOffsetWord { code: offset.to_string(), preset: Some(row) })),
                    _ => None,
                },
                "a preset-table row (`preset 1`)",
            ),
            WorkOffsets::LinuxCnc => (
                match *offset {
                    WorkOffset::G(54..=59) | WorkOffset::G59Dot(1..=3) => Some(code(offset.to_string())),
                    _ => None,
                },
                "G54…G59 or G59.1…G59.3",
            ),
        };
        ok.unwrap_or_else(|| {
            Err(EmitError::WorkOffset {
                dialect: self.name,
                offset: offset.to_string(),
                accepted: accepted.to_string(),
            })
        })
    }

    /// The work offset a program selects when the set-up names none: `G54`, or the first row of
    /// the preset table on Heidenhain.
    pub fn default_work_offset(&self) -> WorkOffset {
        match self.work_offsets {
            WorkOffsets::Heidenhain => WorkOffset::Preset(1),
            _ => WorkOffset::G(54),
        }
    }
}

/// Every dialect postpro writes.
pub const DIALECTS: &[Dialect] = &[
    Dialect {
        name: "siemens-840d",
        extension: "mpf",
        comment_open: "; ",
        comment_close: "",
        comment_forbidden: "",
        explicit_plus: false,
        max_line: 512,
        feed_range: (0.001, 999_999.999),
        inverse_time_range: Some((0.001, 999_999.999)),
        bspline: true,
        tcp: TcpStyle::Traori,
        feed_decimals: 3,
        arc_turns: true,
        arc_all_planes: true,
        machine_retract_cancels_length: true,
        work_offsets: WorkOffsets::Siemens,
        planes: Some(PlaneKind::Tilted),
        inch_feed_scale: 1.0,
        numbered_blocks: false,
    },
    Dialect {
        name: "fanuc",
        extension: "nc",
        comment_open: "(",
        comment_close: ")",
        comment_forbidden: "()",
        explicit_plus: false,
        max_line: 256,
        feed_range: (0.001, 99_999.0),
        inverse_time_range: Some((0.001, 99_999.0)),
        bspline: false,
        tcp: TcpStyle::G43_4,
        feed_decimals: 3,
        arc_turns: false,
        arc_all_planes: true,
        machine_retract_cancels_length: false,
        work_offsets: WorkOffsets::Fanuc,
        planes: Some(PlaneKind::Tilted),
        inch_feed_scale: 1.0,
        numbered_blocks: false,
    },
    Dialect {
        name: "haas",
        extension: "nc",
        comment_open: "(",
        comment_close: ")",
        comment_forbidden: "()",
        explicit_plus: false,
        max_line: 256,
        feed_range: (0.001, 99_999.0),
        inverse_time_range: Some((0.001, 99_999.0)),
        bspline: false,
        tcp: TcpStyle::G234,
        feed_decimals: 3,
        arc_turns: false,
        arc_all_planes: true,
        machine_retract_cancels_length: false,
        work_offsets: WorkOffsets::Haas,
        planes: Some(PlaneKind::Dynamic),
        inch_feed_scale: 1.0,
        numbered_blocks: false,
    },
    Dialect {
        name: "heidenhain",
        extension: "h",
        comment_open: "; ",
        comment_close: "",
        comment_forbidden: "",
        explicit_plus: true,
        max_line: 254,
        feed_range: (0.001, 99_999.0),
        inverse_time_range: None,
        bspline: false,
        tcp: TcpStyle::M128,
        feed_decimals: 0,
        arc_turns: true,
        arc_all_planes: false,
        machine_retract_cancels_length: false,
        work_offsets: WorkOffsets::Heidenhain,
        planes: Some(PlaneKind::Tilted),
        inch_feed_scale: 10.0,
        numbered_blocks: true,
    },
    Dialect {
        name: "linuxcnc",
        extension: "ngc",
        comment_open: "(",
        comment_close: ")",
        comment_forbidden: "()",
        explicit_plus: false,
        max_line: 255,
        feed_range: (0.001, 99_999.0),
        inverse_time_range: Some((0.001, 99_999.0)),
        bspline: false,
        tcp: TcpStyle::None,
        feed_decimals: 3,
        arc_turns: true,
        arc_all_planes: true,
        machine_retract_cancels_length: false,
        work_offsets: WorkOffsets::LinuxCnc,
        planes: None,
        inch_feed_scale: 1.0,
        numbered_blocks: false,
    },
];

/// The dialect of this name.
pub fn dialect(name: &str) -> Option<&'static Dialect> {
    DIALECTS.iter().find(|d| d.name.eq_ignore_ascii_case(name))
}
