//! Writers that turn a [`Toolpath`] into APT/CL text in the style of real CAM systems.
//!
//! Two dialects are written:
//!
//! * **Siemens NX CLSF** ([`NxClsfWriter`], [`nx_clsf`]): `TOOL PATH/…`, `TLDATA/…`,
//!   `MSYS/…`, `LOAD/TOOL…`, `SPINDL/RPM,…`, `COOLNT/FLOOD`, a one-shot `RAPID` line before every rapid
//!   `GOTO`, `FEDRAT/MMPM,f` whenever the feed changes, `GOTO/x,y,z,i,j,k` (4 and 7
//!   decimals) or, as NX does, `GOTO/x,y,z` when the printed tool axis equals the
//!   previous one, `PAINT/…` display records, and `END-OF-PATH`.
//! * **CATIA V5 APT** ([`catia_apt`]): `$$` banner, `PARTNO`, `MULTAX`, `CUTTER/` with
//!   seven values, `LOADTL`, `SPINDL/ n,RPM,CLW`, `COOLNT/ON`, `FEDRAT/ f,MMPM`, `RAPID`, and
//!   `GOTO  /` records that always carry six fixed-width values. Records longer than 72
//!   columns are wrapped the way CATIA does it: the first 71 characters, a `$` in column
//!   72, and the rest of the record on the next line — the break falls at a fixed column,
//!   even inside a number, so a reader must join the raw text without trimming.
//!
//! All output is deterministic: fixed decimals, no time stamps, `\n` line endings and a
//! final newline. Values that round to zero are printed without a minus sign.

use std::fmt::{self, Write as _};

use nalgebra::{Point3, Vector3};

use crate::toolpath::{Move, MoveKind, Toolpath, ToolpathParams};

/// Column at which CATIA wraps records; the `$` continuation mark sits in this column.
pub const CATIA_RECORD_COLUMNS: usize = 72;

/// Formats `value` with `decimals` fixed decimals, never printing a negative zero.
#[must_use]
pub fn fixed(value: f64, decimals: usize) -> String {
    let text = format!("{value:.decimals$}");
    match text.strip_prefix('-') {
        Some(rest) if rest.bytes().all(|b| b == b'0' || b == b'.') => rest.to_owned(),
        _ => text,
    }
}

/// Formats `value` with at most 4 decimals and no trailing zeros: `10`, `6.5`.
#[must_use]
pub fn short_number(value: f64) -> String {
    let text = fixed(value, 4);
    if text.contains('.') { text.trim_end_matches('0').trim_end_matches('.').to_owned() } else { text }
}

/// Appends one formatted line and a `\n` to `buf`.
fn line(buf: &mut String, args: fmt::Arguments<'_>) {
    // Formatting into a `String` cannot fail.
    let _ = buf.write_fmt(args);
    buf.push('\n');
}

/// The NX tool name of a ball-end mill, e.g. `BALL_D10` or `BALL_D6.5`.
fn nx_tool_name(diameter: f64) -> String {
    format!("BALL_D{}", short_number(diameter))
}

/// NX display colours of the motion types (the values are only for the display).
fn nx_color(kind: MoveKind) -> u32 {
    match kind {
        MoveKind::Rapid => 186,
        MoveKind::Plunge => 211,
        MoveKind::Cut => 31,
        MoveKind::Retract => 37,
    }
}

/// Streaming writer of a Siemens NX CLSF tool path.
///
/// The text is collected in an internal buffer; [`NxClsfWriter::take`] drains it (to
/// stream large files) while keeping the modal state (last feed, last tool axis).
#[derive(Debug, Clone, Default)]
pub struct NxClsfWriter {
    buf: String,
    compress_axis: bool,
    last_axis: Option<String>,
    last_feed: Option<String>,
    last_kind: Option<MoveKind>,
}

impl NxClsfWriter {
    /// A writer that, as NX does, writes `GOTO/x,y,z` when the tool axis is unchanged.
    #[must_use]
    pub fn new() -> Self {
        Self { compress_axis: true, ..Self::default() }
    }

    /// A writer that always writes the six values `GOTO/x,y,z,i,j,k`.
    #[must_use]
    pub fn always_full_goto() -> Self {
        Self { compress_axis: false, ..Self::default() }
    }

    /// Writes a comment line `$$ text` (or `$$` for an empty text).
    pub fn comment(&mut self, text: &str) {
        if text.is_empty() {
            self.buf.push_str("$$\n");
        } else {
            line(&mut self.buf, format_args!("$$ {text}"));
        }
    }

    /// Writes the start of a variable-contour tool path with a ball-end mill: `TOOL PATH`,
    /// `TLDATA`, `MSYS`, `PAINT`, `LOAD/TOOL`, `SPINDL` and `COOLNT` records.
    pub fn begin_path(&mut self, params: &ToolpathParams) {
        let b = &mut self.buf;
        line(b, format_args!("TOOL PATH/VARIABLE_CONTOUR,TOOL,{}", nx_tool_name(params.tool_diameter())));
        line(
            b,
            format_args!(
                "TLDATA/MILL,{},{},{},0.0000,0.0000",
                fixed(params.tool_diameter(), 4),
                fixed(params.tool_radius, 4),
                fixed(params.tool_length, 4)
            ),
        );
        b.push_str("MSYS/0.0000,0.0000,0.0000,1.0000000,0.0000000,0.0000000,0.0000000,1.0000000,0.0000000\n");
        b.push_str("$$ centerline data\n");
        b.push_str("PAINT/PATH\n");
        b.push_str("PAINT/SPEED,10\n");
        b.push_str("LOAD/TOOL,1,ADJUST,1\n");
        line(b, format_args!("SPINDL/RPM,{},CLW", params.spindle_rpm));
        b.push_str("COOLNT/FLOOD\n");
    }

    /// Writes one move: `PAINT/COLOR` when the motion type changes, `RAPID` before a rapid
    /// move, `FEDRAT/MMPM,f` when the feed changes, then the `GOTO`.
    pub fn motion(&mut self, mv: &Move) {
        if self.last_kind != Some(mv.kind) {
            line(&mut self.buf, format_args!("PAINT/COLOR,{}", nx_color(mv.kind)));
            self.last_kind = Some(mv.kind);
        }
        match mv.feed {
            None => self.buf.push_str("RAPID\n"),
            Some(feed) => {
                let feed = fixed(feed, 4);
                if self.last_feed.as_deref() != Some(feed.as_str()) {
                    line(&mut self.buf, format_args!("FEDRAT/MMPM,{feed}"));
                    self.last_feed = Some(feed);
                }
            }
        }
        self.goto(&mv.tip, &mv.axis);
    }

    /// Writes `GOTO/x,y,z,i,j,k`, or `GOTO/x,y,z` if the axis prints as the previous one
    /// and axis compression is on.
    pub fn goto(&mut self, tip: &Point3<f64>, axis: &Vector3<f64>) {
        let axis_text = format!("{},{},{}", fixed(axis.x, 7), fixed(axis.y, 7), fixed(axis.z, 7));
        let xyz = format!("{},{},{}", fixed(tip.x, 4), fixed(tip.y, 4), fixed(tip.z, 4));
        if self.compress_axis && self.last_axis.as_deref() == Some(axis_text.as_str()) {
            line(&mut self.buf, format_args!("GOTO/{xyz}"));
        } else {
            line(&mut self.buf, format_args!("GOTO/{xyz},{axis_text}"));
            self.last_axis = Some(axis_text);
        }
    }

    /// Writes `END-OF-PATH`.
    pub fn end_path(&mut self) {
        self.buf.push_str("END-OF-PATH\n");
    }

    /// Number of bytes in the buffer.
    #[must_use]
    pub fn buffered_len(&self) -> usize {
        self.buf.len()
    }

    /// Drains the buffer, keeping the modal state.
    pub fn take(&mut self) -> String {
        std::mem::take(&mut self.buf)
    }

    /// The buffered text.
    #[must_use]
    pub fn finish(self) -> String {
        self.buf
    }
}

/// A complete NX CLSF file of `toolpath`: the `$$ comments` first, then one tool path.
#[must_use]
pub fn nx_clsf(toolpath: &Toolpath, comments: &[String]) -> String {
    let mut w = NxClsfWriter::new();
    for c in comments {
        w.comment(c);
    }
    w.begin_path(&toolpath.params);
    for mv in toolpath.moves() {
        w.motion(&mv);
    }
    w.end_path();
    w.finish()
}

/// Texts of the CATIA V5 APT header.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CatiaHeader {
    /// Text of the `PARTNO` record.
    pub partno: String,
    /// Operation name, e.g. `Multi-Axis Sweeping.1`.
    pub operation: String,
    /// Extra `$$` comment lines after the banner (keep them within 72 columns).
    pub comments: Vec<String>,
}

/// Appends `record` to `buf`, wrapped at [`CATIA_RECORD_COLUMNS`] as CATIA does: while
/// the rest is longer than 72 columns, its first 71 characters and a `$` make a line.
pub fn push_catia_record(buf: &mut String, record: &str) {
    let mut rest = record;
    while rest.chars().count() > CATIA_RECORD_COLUMNS {
        let cut = rest.char_indices().nth(CATIA_RECORD_COLUMNS - 1).map_or(rest.len(), |(i, _)| i);
        buf.push_str(&rest[..cut]);
        buf.push_str("$\n");
        rest = &rest[cut..];
    }
    buf.push_str(rest);
    buf.push('\n');
}

/// A `GOTO  /` record: `x, y, z` in `{:>12.6}` fields and `i, j, k` in `{:>10.6}`
/// fields, 78 columns in all, so that the wrap at column 72 falls inside `k`, right
/// after its units digit.
fn catia_goto(tip: &Point3<f64>, axis: &Vector3<f64>) -> String {
    let mut record = String::with_capacity(80);
    // Formatting into a `String` cannot fail.
    let _ = write!(
        record,
        "GOTO  /{:>12},{:>12},{:>12},{:>10},{:>10},{:>10}",
        fixed(tip.x, 6),
        fixed(tip.y, 6),
        fixed(tip.z, 6),
        fixed(axis.x, 6),
        fixed(axis.y, 6),
        fixed(axis.z, 6)
    );
    record
}

/// A complete CATIA V5 APT file of `toolpath` (multi-axis, ball-end mill, every `GOTO`
/// with six values, records wrapped at column 72).
#[must_use]
pub fn catia_apt(toolpath: &Toolpath, header: &CatiaHeader) -> String {
    let p = &toolpath.params;
    let mut b = String::new();
    let rule = "$$ -----------------------------------------------------------------";
    line(&mut b, format_args!("{rule}"));
    b.push_str("$$     Generated by postpro-examples (deterministic, no date)\n");
    b.push_str("$$     CATIA APT VERSION 1.0\n");
    line(&mut b, format_args!("{rule}"));
    for c in &header.comments {
        line(&mut b, format_args!("$$ {c}"));
    }
    b.push_str("$$ Manufacturing Program.1\n");
    b.push_str("$$ Part Operation.1\n");
    b.push_str("$$*CATIA0\n");
    b.push_str("$$ Manufacturing Program.1\n");
    b.push_str("$$     1.00000     0.00000     0.00000     0.00000\n");
    b.push_str("$$     0.00000     1.00000     0.00000     0.00000\n");
    b.push_str("$$     0.00000     0.00000     1.00000     0.00000\n");
    line(&mut b, format_args!("PARTNO {}", header.partno));
    line(&mut b, format_args!("$$ OPERATION NAME : {}", header.operation));
    line(&mut b, format_args!("$$ Start generation of : {}", header.operation));
    b.push_str("MULTAX\n");
    b.push_str("$$ TOOLCHANGEBEGINNING\n");
    let d = p.tool_diameter();
    let r = p.tool_radius;
    let cutter = [d, r, 0.0, r, 0.0, 0.0, p.tool_length].iter().map(|v| fixed(*v, 6)).collect::<Vec<_>>().join(", ");
    push_catia_record(&mut b, &format!("CUTTER/ {cutter}"));
    let diameter = fixed(d, 4);
    let diameter = diameter.trim_end_matches('0').trim_end_matches('.');
    line(&mut b, format_args!("$$ TOOL : T1 Ball-end Mill D {diameter}"));
    b.push_str("LOADTL/1\n");
    b.push_str("$$ TOOLCHANGEEND\n");
    line(&mut b, format_args!("SPINDL/{:>11},RPM,CLW", fixed(f64::from(p.spindle_rpm), 4)));
    b.push_str("COOLNT/ON\n");
    let mut last_feed: Option<String> = None;
    for mv in toolpath.moves() {
        match mv.feed {
            None => b.push_str("RAPID\n"),
            Some(feed) => {
                let feed = fixed(feed, 4);
                if last_feed.as_deref() != Some(feed.as_str()) {
                    line(&mut b, format_args!("FEDRAT/{feed:>10},MMPM"));
                    last_feed = Some(feed);
                }
            }
        }
        push_catia_record(&mut b, &catia_goto(&mv.tip, &mv.axis));
    }
    b.push_str("COOLNT/OFF\n");
    b.push_str("SPINDL/OFF\n");
    line(&mut b, format_args!("$$ End of generation of : {}", header.operation));
    b.push_str("END\n");
    b.push_str("FINI\n");
    b
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::surface::BezierPatch;
    use crate::toolpath::{ToolpathParams, generate};

    #[test]
    fn fixed_never_prints_negative_zero() {
        assert_eq!(fixed(-0.0, 4), "0.0000");
        assert_eq!(fixed(-0.00004, 4), "0.0000");
        assert_eq!(fixed(-0.00005001, 4), "-0.0001");
        assert_eq!(fixed(12.5, 4), "12.5000");
        assert_eq!(fixed(-3.25, 6), "-3.250000");
        assert_eq!(short_number(10.0), "10");
        assert_eq!(short_number(100.0), "100");
        assert_eq!(short_number(0.5), "0.5");
        assert_eq!(short_number(-0.0), "0");
    }

    #[test]
    fn tool_names() {
        assert_eq!(nx_tool_name(10.0), "BALL_D10");
        assert_eq!(nx_tool_name(6.0), "BALL_D6");
        assert_eq!(nx_tool_name(6.5), "BALL_D6.5");
    }

    #[test]
    fn catia_wrapping_breaks_at_column_72_inside_numbers() {
        let record = catia_goto(&Point3::new(600.0, -12.345678, 100.0), &Vector3::new(-0.173648, 0.0, 0.984808));
        assert_eq!(record.len(), 7 + 3 * 12 + 3 * 10 + 5);
        let mut b = String::new();
        push_catia_record(&mut b, &record);
        let lines: Vec<&str> = b.lines().collect();
        assert_eq!(lines.len(), 2);
        assert_eq!(lines[0].len(), 72);
        assert!(lines[0].ends_with('$'));
        assert_eq!(format!("{}{}", &lines[0][..71], lines[1]), record);
        assert_eq!(b, "GOTO  /  600.000000,  -12.345678,  100.000000, -0.173648,  0.000000,  0$\n.984808\n");
        // Exactly 72 columns: no wrap; 150 columns: two continuation marks.
        let mut b = String::new();
        push_catia_record(&mut b, &"x".repeat(72));
        assert_eq!(b, format!("{}\n", "x".repeat(72)));
        let mut b = String::new();
        push_catia_record(&mut b, &"y".repeat(150));
        let expected = format!("{}$\n{}$\n{}\n", "y".repeat(71), "y".repeat(71), "y".repeat(8));
        assert_eq!(b, expected);
    }

    #[test]
    fn nx_axis_compression_and_feeds() {
        let params = ToolpathParams::bicubic();
        let path = generate(&BezierPatch::bicubic(), &params).expect("valid");
        let text = nx_clsf(&path, &["test".to_owned()]);
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines[0], "$$ test");
        assert_eq!(lines[1], "TOOL PATH/VARIABLE_CONTOUR,TOOL,BALL_D6");
        assert_eq!(lines[2], "TLDATA/MILL,6.0000,3.0000,50.0000,0.0000,0.0000");
        assert_eq!(*lines.last().expect("lines"), "END-OF-PATH");
        assert!(text.ends_with("END-OF-PATH\n") && !text.contains('\r'));
        // The plunge keeps the axis of the clearance point: a three-value GOTO after the
        // plunge feed.
        let plunge = lines.iter().position(|l| *l == "FEDRAT/MMPM,300.0000").expect("plunge feed");
        assert_eq!(lines[plunge + 1].split(',').count(), 3, "{}", lines[plunge + 1]);
        assert_eq!(lines[plunge + 2], "PAINT/COLOR,31");
        assert_eq!(lines[plunge + 3], "FEDRAT/MMPM,1000.0000");
        assert_eq!(lines[plunge + 4].split(',').count(), 6);
        // Every RAPID is followed by a GOTO; GOTOs have 3 or 6 values.
        for (k, l) in lines.iter().enumerate() {
            if *l == "RAPID" {
                assert!(lines[k + 1].starts_with("GOTO/"));
            }
            if let Some(values) = l.strip_prefix("GOTO/") {
                let n = values.split(',').count();
                assert!(n == 3 || n == 6, "{l}");
            }
        }
    }

    #[test]
    fn catia_records() {
        let params = ToolpathParams::manta();
        let path = generate(&BezierPatch::manta(), &params).expect("valid");
        let header = CatiaHeader {
            partno: "MANTA FINISHING".to_owned(),
            operation: "Multi-Axis Sweeping.1".to_owned(),
            comments: vec![],
        };
        let text = catia_apt(&path, &header);
        assert!(text.ends_with("END\nFINI\n"));
        assert!(text.contains("\nPARTNO MANTA FINISHING\n"));
        assert!(text.contains("\nSPINDL/  8000.0000,RPM,CLW\n"));
        assert!(text.contains("\nFEDRAT/ 5000.0000,MMPM\n"));
        assert!(text.contains("\nFEDRAT/ 1500.0000,MMPM\n"));
        assert!(
            text.contains("\nCUTTER/ 20.000000, 10.000000, 0.000000, 10.000000, 0.000000, 0.000000, $\n100.000000\n")
        );
        // Join continuation lines and check every GOTO has six values.
        let mut joined = Vec::new();
        let mut pending = String::new();
        for l in text.lines() {
            assert!(l.len() <= 72, "{l}");
            if !l.starts_with("$$") && l.ends_with('$') {
                pending.push_str(&l[..l.len() - 1]);
            } else {
                pending.push_str(l);
                joined.push(std::mem::take(&mut pending));
            }
        }
        let gotos: Vec<&String> = joined.iter().filter(|l| l.starts_with("GOTO  /")).collect();
        assert_eq!(gotos.len(), path.moves().len());
        for g in gotos {
            let values: Vec<f64> = g["GOTO  /".len()..].split(',').map(|v| v.trim().parse().expect("number")).collect();
            assert_eq!(values.len(), 6);
            let axis = Vector3::new(values[3], values[4], values[5]);
            assert!((axis.norm() - 1.0).abs() < 2e-6);
        }
    }
}
