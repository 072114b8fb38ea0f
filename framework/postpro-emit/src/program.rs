//! The template context: the NC program as data, formatted from the motion program (its blocks
//! in program order, their axis values and F words) for one dialect: numbers written with each
//! axis's decimals, only the words that change, comments cleaned and cut to the line length, the
//! prediction's annotations placed before the motion of their steps. `docs/templates.md`
//! documents every field; templates see exactly these names.

use postpro_cl::Coolant;
use postpro_kin::Joints;
use postpro_machine::model::{AxisKind, Machine, ProgramUnits};
use postpro_motion::{AxisSet, BlockKind, FeedWord, PlaneKind, Position};
use serde::Serialize;

use crate::EmitError;
use crate::dialect::{Dialect, TcpOrientation, TcpStyle};
use crate::format::{Rounded, push_number, with_rounded};
use compact_str::CompactString;

pub use postpro_motion::Mode;

/// What the emitter is asked for.
#[derive(Clone, Debug)]
pub struct Options {
    /// The units the program is written in.
    pub units: ProgramUnits,
    /// Program name (from the file name).
    pub program_name: String,
    /// The CL file, as the user named it.
    pub source_name: String,
    /// Number the blocks (`N10`, `N20`, …).
    pub block_numbers: bool,
    /// How TCP mode gives the tool's orientation: the rotary axes' angles or the tool vector.
    pub tcp_orientation: TcpOrientation,
    /// CL `INSERT` text as blocks of the program (`--insert verbatim`); else as comments, since
    /// CAM systems write descriptions there (SOLIDWORKS CAM: the holder, the stock size) that no
    /// controller reads, or reads as axis words.
    pub insert_verbatim: bool,
    /// The prediction summary for the header (`header.prediction`); `None` without prediction.
    pub prediction: Option<Prediction>,
    /// Comments to write before the motion of given steps (a predicted slowdown, its cause),
    /// sorted by step; given out of order, they are written in the order of their steps all the
    /// same (ties keep their order). See [`Annotation`].
    pub annotations: Vec<Annotation>,
}

/// A comment written into the program before the motion of one step of the solved tool path.
///
/// It becomes a [`Block::Comment`] (cleaned and cut to the line length like every comment)
/// immediately before the first block the step writes. Where the step writes none of its own,
/// it goes where that block would stand: a linearization point in TCP mode, a feed move in a
/// `BSPLINE` run (before the first control point of the span that ends at the step; for a
/// linearization point, the span of the next CL point), a move that changes no axis. A
/// `BSPLINE` run written as `G1` blocks instead (too short, or the spline cannot follow it) has a
/// block for every step, linearization points included, each with its annotations before it. An
/// annotation whose step is past the last one is written after the last motion. None is ever
/// dropped.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Annotation {
    /// Index into `Solved::steps` (the `step` of the motion program's positions).
    pub step: usize,
    /// The comment text (without the dialect's comment characters).
    pub text: String,
    /// The number of the slowdown it marks (`slowdown #<number>`), if it marks one: the header's
    /// worst slowdowns give the NC line of that comment.
    pub slowdown: Option<usize>,
}

/// The whole template context.
#[derive(Clone, Debug, Serialize)]
pub struct Program {
    /// Facts about the program.
    pub header: Header,
    /// Tools in order of first use.
    pub tools: Vec<Tool>,
    /// The blocks.
    pub blocks: Vec<Block>,
}

/// Facts about the program for its header.
#[derive(Clone, Debug, Serialize)]
pub struct Header {
    /// Program name.
    pub name: String,
    /// PARTNO, when the CL file has one.
    pub part: Option<String>,
    /// The CL file.
    pub source: String,
    /// The machine.
    pub machine: String,
    /// Its description.
    pub machine_description: String,
    /// The dialect.
    pub dialect: Dialect,
    /// The mode.
    pub mode: Mode,
    /// How TCP mode gives the tool's orientation: `angles` or `vectors`.
    pub tcp_orientation: TcpOrientation,
    /// The generator and its version.
    pub generator: String,
    /// The axes in output order.
    pub axes: Vec<AxisInfo>,
    /// CL points solved.
    pub cl_points: usize,
    /// Points added by linearization.
    pub linearized_points: usize,
    /// Linearization tolerance, in the program's units, as written (`0.01`).
    pub tolerance: String,
    /// The machine's contour tolerance (its CNC's path smoothing), in the program's units, as
    /// written (Haas `G187 E…`).
    pub contour_tolerance: String,
    /// Decisions of the IKT policy.
    pub decisions: usize,
    /// The program's units: `mm` or `inch`.
    pub units: &'static str,
    /// The work offset the program selects.
    pub work_offset: WorkOffsetWord,
    /// Where the shop sets it: `the part zero`, `the B/C intersection`, …
    pub origin: String,
    /// The prediction (cycle time, slowdowns): filled by the prediction stage, `none` until then.
    pub prediction: Option<Prediction>,
}

/// The prediction summary a header may show.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Prediction {
    /// Predicted cycle time (s).
    pub cycle_time: f64,
    /// Time lost to slowdowns (s).
    pub time_lost: f64,
    /// The slowdown threshold, a fraction of the programmed feed (`0.8`).
    pub threshold: f64,
    /// The fraction of the feed path length (0…1) predicted below `threshold` × the programmed feed.
    pub share_below: f64,
    /// The feed planner the prediction used (`inverse-time`, `vpop`). In the header it is cleaned
    /// of the characters the dialect's comments cannot hold.
    pub planner: String,
    /// The number of slowdown comments written into the program (annotations).
    pub slowdowns: usize,
    /// Each operation of the CL file, in order.
    pub operations: Vec<OperationPrediction>,
    /// The worst slowdowns marked (the prediction gives at most five), the worst first.
    pub worst: Vec<MarkedSlowdown>,
}

/// The prediction of one operation of the CL file, for the header.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct OperationPrediction {
    /// Its name in the CL file; empty for the motion before the first operation or an operation
    /// without a name. In the header it is cleaned like comment text.
    pub name: String,
    /// Predicted time (s).
    pub cycle_time: f64,
    /// Time at the programmed feed (s).
    pub programmed_time: f64,
    /// Time lost (s): `cycle_time - programmed_time`.
    pub time_lost: f64,
    /// What lost the most time (`corner`, `C jerk`, …; `programmed` when nothing was lost).
    pub cause: String,
}

/// A slowdown marked in the program, for the header.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct MarkedSlowdown {
    /// Its number: the comment before its first block reads `slowdown #<number>: <text>`.
    pub number: usize,
    /// Index into [`Solved::steps`] of its first block (the comment stands before its motion).
    pub step: usize,
    /// The CL file's line of that step (1-based).
    pub line: usize,
    /// The program's line (1-based) of the comment `slowdown #<number>`: filled in by
    /// `write_program` and `render` before they write the header; none where no such comment is.
    pub nc_line: Option<usize>,
    /// The block number that line starts with (`N120 …`, Heidenhain's `2031 ; …`), if any.
    pub nc_block: Option<u64>,
    /// Time lost (s), exact stops aside.
    pub time_lost: f64,
    /// What the comment says after `slowdown #<number>: ` (`38% of F over 12 blocks, C jerk,
    /// 0.42 s lost`), cleaned like comment text in the header.
    pub text: String,
}

/// An axis of the machine.
#[derive(Clone, Debug, Serialize)]
pub struct AxisInfo {
    /// Address letter.
    pub letter: String,
    /// `linear` or `rotary`.
    pub kind: &'static str,
}

/// A tool.
#[derive(Clone, Debug, Serialize)]
pub struct Tool {
    /// Number.
    pub number: u32,
    /// Name, if the CL file or the tool table gives one (cleaned like comment text).
    pub name: Option<String>,
    /// Diameter in the program's units, as written, if known.
    pub diameter: Option<String>,
    /// Corner radius in the program's units, as written, if known.
    pub corner_radius: Option<String>,
    /// Length in the program's units, as written, if known.
    pub length: Option<String>,
    /// Length-offset register (`H`).
    pub length_register: u32,
    /// Radius-offset register (`D`).
    pub radius_register: u32,
}

/// A work offset as the dialect selects it.
#[derive(Clone, Debug, Serialize)]
pub struct WorkOffsetWord {
    /// The code (`G54`, `G54.1 P7`, `G505`, `G59.1`; `preset 3` on Heidenhain).
    pub code: String,
    /// The preset-table row (Heidenhain), else none.
    pub preset: Option<u32>,
}

/// One word: an address letter and its value. Its texts are short and held inline (a motion
/// block's words cost no allocation).
#[derive(Clone, Debug, Serialize)]
pub struct Word {
    /// The address (`X`, `A`, `A3`, `TX`).
    pub letter: CompactString,
    /// The value (mm, degrees, or a vector component).
    pub value: f64,
    /// The value as the dialect writes it (`12.346`, `+12.346`).
    pub text: CompactString,
}

/// A hole of a canned cycle, for the template (`kind` = `cycle_hole`).
#[derive(Clone, Debug, Serialize)]
pub struct CycleHole {
    /// Block number, when numbering.
    n: Option<u32>,
    /// The first hole of the cycle: its block defines the cycle.
    first: bool,
    /// `drill`, `deep`, `chip_break`, `tap` or `bore`.
    cycle: postpro_cl::CycleKind,
    /// The ISO code: `G81`, `G82` (drill with a dwell), `G83`, `G73`, `G84`, `G85`, `G89`
    /// (bore with a dwell).
    code: &'static str,
    /// The hole's position words across the hole axis that change (all on the first hole).
    words: Vec<Word>,
    /// The bottom (`Z…`), absolute.
    bottom: Word,
    /// The R plane, absolute, as written.
    r_plane: String,
    /// The hole's top (Siemens `RFP`, Heidenhain `Q203`), absolute, as written.
    top: String,
    /// The level the tool starts at and returns to with `to_initial` (Siemens `RTP`),
    /// absolute, as written.
    initial: String,
    /// The R plane above the top (Siemens `SDIS`, Heidenhain `Q200`), as written.
    clearance: String,
    /// The depth below the top (Heidenhain `Q201` negated), as written.
    depth: String,
    /// The return level above the top (Heidenhain `Q204`), as written.
    return_height: String,
    /// The hole's bottom or R plane differs from the hole before: written again.
    planes_change: bool,
    /// Return to the start level after each hole (`G98`), else to the R plane (`G99`).
    to_initial: bool,
    /// The first peck, as written (and the following ones: `peck_next`).
    peck: Option<String>,
    /// Each following peck, as written.
    peck_next: Option<String>,
    /// The dwell at the bottom in seconds, as written.
    dwell: Option<String>,
    /// The dwell in milliseconds (Fanuc `P`), as written.
    dwell_ms: Option<String>,
    /// The F word's value as written.
    feed: String,
    /// A tap's pitch (feed per spindle revolution), as written, when the spindle speed is known.
    pitch: Option<String>,
    /// A note for the end of the line.
    note: Option<String>,
}

/// One block of the program. `kind` tells the template which one.
#[derive(Clone, Debug, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Block {
    /// A comment line.
    Comment {
        /// Block number, when numbering.
        n: Option<u32>,
        /// The text, cleaned of characters the dialect cannot hold in a comment.
        text: String,
        /// The number of the slowdown this comment marks (`slowdown #<number>: …`), if any.
        slowdown: Option<usize>,
    },
    /// Text passed to the program as is (`INSERT`).
    Insert {
        /// Block number, when numbering.
        n: Option<u32>,
        /// The text.
        text: String,
    },
    /// Rapid traverse.
    Rapid {
        /// Block number, when numbering.
        n: Option<u32>,
        /// The axis words that change.
        words: Vec<Word>,
    },
    /// Feed move.
    Linear {
        /// Block number, when numbering.
        n: Option<u32>,
        /// The axis words that change (or all, in inverse time).
        words: Vec<Word>,
        /// The F word's value as written, when it is written.
        feed: Option<String>,
        /// A note for the end of the line (a decision, a clamped F).
        note: Option<String>,
    },
    /// The feed mode changes.
    FeedMode {
        /// Block number, when numbering.
        n: Option<u32>,
        /// `per-minute`, `per-revolution` or `inverse-time`.
        mode: &'static str,
    },
    /// Tool change.
    ToolChange {
        /// Block number, when numbering.
        n: Option<u32>,
        /// Tool number.
        number: u32,
        /// Tool name.
        name: Option<String>,
        /// Length-offset register (`H`).
        offset: u32,
        /// Radius-offset register (`D`).
        radius_register: u32,
        /// The tool's length in the program's units, as written, when known.
        length: Option<String>,
        /// The CNC applies the tool length (`G43 H…`, `D…`): true when the axis values are those
        /// of the spindle nose. False when they already include the tool length (a head machine
        /// in a joint mode): the CNC must not add it again.
        length_compensation: bool,
    },
    /// The work offset is selected.
    WorkOffset {
        /// Block number, when numbering.
        n: Option<u32>,
        /// The code (`G54`…) or preset row.
        #[serde(flatten)]
        offset: WorkOffsetWord,
    },
    /// A retract of the spindle axis in machine coordinates (`G53`, `SUPA`, `M91`).
    MachineRetract {
        /// Block number, when numbering.
        n: Option<u32>,
        /// The axis word, its value in machine coordinates.
        words: Vec<Word>,
    },
    /// A circular arc (or helix).
    Arc {
        /// Block number, when numbering.
        n: Option<u32>,
        /// `xy` (`G17`), `zx` (`G18`) or `yz` (`G19`).
        plane: postpro_motion::Plane,
        /// Clockwise about the plane's normal (`G2`), else counter-clockwise (`G3`).
        clockwise: bool,
        /// The end point's words that change (the helix axis included).
        words: Vec<Word>,
        /// The centre relative to the start, in the plane (`I J`, `K I`, `J K`).
        center: Vec<Word>,
        /// The centre in absolute coordinates, in the plane (Heidenhain `CC`).
        center_absolute: Vec<Word>,
        /// Full turns besides the last (LinuxCNC `P` = turns + 1, Siemens `TURN`).
        turns: u32,
        /// The swept angle (degrees, as written; Heidenhain `CP IPA`).
        sweep: String,
        /// The rise along the normal (helix), as written; none for a flat arc.
        rise: Option<Word>,
        /// The F word's value as written, when it is written.
        feed: Option<String>,
        /// A note for the end of the line.
        note: Option<String>,
    },
    /// A hole of a canned cycle: the first defines the cycle (`G81 … R… Z…`, `MCALL CYCLE81(…)`,
    /// `CYCL DEF 200`), each one is drilled where its block stands.
    CycleHole(Box<CycleHole>),
    /// The canned cycle ends (`G80`, `MCALL`).
    CycleOff {
        /// Block number, when numbering.
        n: Option<u32>,
    },
    /// The tool's length offset, on again after a machine-coordinate retract cancelled it
    /// (Siemens `D…`).
    LengthOn {
        /// Block number, when numbering.
        n: Option<u32>,
        /// The register.
        register: u32,
    },
    /// Spindle on.
    SpindleOn {
        /// Block number, when numbering.
        n: Option<u32>,
        /// Speed as written (rpm, or surface speed).
        speed: String,
        /// Clockwise.
        clockwise: bool,
        /// Constant surface speed.
        surface_speed: bool,
    },
    /// Spindle off.
    SpindleOff {
        /// Block number, when numbering.
        n: Option<u32>,
    },
    /// Coolant on (`flood`, `mist`, `through`, `air`, `on`).
    CoolantOn {
        /// Block number, when numbering.
        n: Option<u32>,
        /// Which coolant.
        coolant: &'static str,
    },
    /// Coolant off.
    CoolantOff {
        /// Block number, when numbering.
        n: Option<u32>,
    },
    /// Dwell.
    Dwell {
        /// Block number, when numbering.
        n: Option<u32>,
        /// Seconds, as written.
        seconds: String,
    },
    /// Program stop.
    Stop {
        /// Block number, when numbering.
        n: Option<u32>,
        /// The operator message.
        text: Option<String>,
    },
    /// Optional stop.
    OptionalStop {
        /// Block number, when numbering.
        n: Option<u32>,
    },
    /// B-spline interpolation starts (`BSPLINE SD=3 F…`).
    BsplineOn {
        /// Block number, when numbering.
        n: Option<u32>,
        /// Degree.
        degree: usize,
        /// The F word's value as written.
        feed: String,
    },
    /// A B-spline control point with its knot interval.
    ControlPoint {
        /// Block number, when numbering.
        n: Option<u32>,
        /// Every axis word.
        words: Vec<Word>,
        /// The knot interval (`PL`) as written.
        pl: String,
    },
    /// B-spline interpolation ends (back to `G1`).
    BsplineOff {
        /// Block number, when numbering.
        n: Option<u32>,
    },
    /// Tool-centre-point control on.
    TcpOn {
        /// Block number, when numbering.
        n: Option<u32>,
        /// The length-offset register of the tool in the spindle.
        length_register: u32,
        /// `angles` (the rotary axes follow as words) or `vectors` (the tool vector does).
        orientation: TcpOrientation,
    },
    /// Tool-centre-point control off.
    TcpOff {
        /// Block number, when numbering.
        n: Option<u32>,
    },
    /// A working plane for a 3+2 set-up comes into force (`G68.2 … G53.1`, `G254`,
    /// `CYCLE800(…)`, `PLANE VECTOR … STAY`). The rotary axes stand at the set-up already
    /// (turned at the clearance by the block before); the coordinates that follow are the
    /// plane's (`tilted`) or the part's (`dynamic`).
    PlaneOn(Box<PlaneOn>),
    /// The working plane is reset (`G69`, `G255`, `CYCLE800()`, `PLANE RESET STAY`).
    PlaneOff {
        /// Block number, when numbering.
        n: Option<u32>,
        /// `tilted` or `dynamic`.
        plane: PlaneKind,
    },
    /// A rotary axis's brake locked or unlocked (the machine definition's M code).
    Clamp {
        /// Block number, when numbering.
        n: Option<u32>,
        /// The M code (`M10`).
        code: String,
        /// Locked, else unlocked.
        lock: bool,
        /// The axis's letter.
        axis: String,
    },
}

/// A working plane, for the template (`kind` = `plane_on`). Angles in degrees, vectors as unit
/// vectors in the part frame, each as written.
#[derive(Clone, Debug, Serialize)]
pub struct PlaneOn {
    /// Block number, when numbering.
    n: Option<u32>,
    /// `tilted` (coordinates in the plane) or `dynamic` (in the part frame).
    plane: PlaneKind,
    /// Euler angles z, x′, z″ (Fanuc `G68.2 I J K`): the plane = Rz(I)·Rx(J)·Rz(K).
    euler_zxz: [String; 3],
    /// Rotations about x, then the new y, then the new z (Siemens `CYCLE800` mode 57):
    /// the plane = Rx(A)·Ry(B)·Rz(C).
    euler_xyz: [String; 3],
    /// The plane's x axis in the part frame (Heidenhain `BX BY BZ`).
    x: [String; 3],
    /// Its z axis, the tool axis (Heidenhain `NX NY NZ`).
    z: [String; 3],
    /// The rotary axes at the set-up, as written.
    rotaries: Vec<Word>,
    /// The direction the first rotary axis turns to reach it: `1` (its value ≥ 0) or `-1`
    /// (Siemens `_DIR`).
    direction: i8,
}

/// Where the blocks go: a `Vec` for the whole context, or a writer that renders each block as
/// it comes (the program is never held in memory).
pub trait BlockSink {
    /// Takes the next block.
    fn block(&mut self, block: Block) -> Result<(), EmitError>;

    /// The annotations of the steps up to `step` not written yet would be written here, before
    /// the blocks that follow. A sink that writes the body before the annotations are known
    /// notes where; the others need not.
    fn place(&mut self, _step: usize) -> Result<(), EmitError> {
        Ok(())
    }

    /// The annotations of some steps would not stand where [`place`](Self::place) says (a
    /// B-spline run whose steps' places do not follow the steps): they cannot be put in
    /// afterwards.
    fn unplaceable(&mut self) {}
}

impl Block {
    /// Its block number (`N`), when numbering.
    pub fn number(&self) -> Option<u32> {
        match self {
            Block::CycleHole(hole) => hole.n,
            Block::PlaneOn(plane) => plane.n,
            Block::Comment { n, .. }
            | Block::Insert { n, .. }
            | Block::Rapid { n, .. }
            | Block::Linear { n, .. }
            | Block::FeedMode { n, .. }
            | Block::ToolChange { n, .. }
            | Block::WorkOffset { n, .. }
            | Block::MachineRetract { n, .. }
            | Block::Arc { n, .. }
            | Block::CycleOff { n, .. }
            | Block::LengthOn { n, .. }
            | Block::SpindleOn { n, .. }
            | Block::SpindleOff { n, .. }
            | Block::CoolantOn { n, .. }
            | Block::CoolantOff { n, .. }
            | Block::Dwell { n, .. }
            | Block::Stop { n, .. }
            | Block::OptionalStop { n, .. }
            | Block::BsplineOn { n, .. }
            | Block::ControlPoint { n, .. }
            | Block::BsplineOff { n, .. }
            | Block::TcpOn { n, .. }
            | Block::TcpOff { n, .. }
            | Block::PlaneOff { n, .. }
            | Block::Clamp { n, .. } => *n,
        }
    }
}

/// The `N` word of the first block (`--block-numbers`); each next block's is one step more. A
/// block of several lines numbers them `n`, `n + 1`, … within its step.
pub(crate) const FIRST_NUMBER: u32 = 10;
/// See [`FIRST_NUMBER`].
pub(crate) const NUMBER_STEP: u32 = 10;

impl BlockSink for Vec<Block> {
    fn block(&mut self, block: Block) -> Result<(), EmitError> {
        self.push(block);
        Ok(())
    }
}

/// A comment block of `text` (numbered `n`, marking slowdown `slowdown` if given): cleaned
/// ([`clean_comment`]) and cut to the dialect's line length.
pub(crate) fn comment_block(dialect: &Dialect, text: &str, n: Option<u32>, slowdown: Option<usize>) -> Block {
    let mut clean = clean_comment(dialect, text);
    let room = dialect.max_line.saturating_sub(dialect.comment_open.len() + dialect.comment_close.len() + 8);
    if clean.len() > room {
        let cut = (0..=room).rev().find(|&i| clean.is_char_boundary(i)).unwrap_or(0);
        clean.truncate(cut);
    }
    Block::Comment { n, text: clean.trim_end().to_string(), slowdown }
}

/// Text made fit for a comment of the dialect: parentheses become brackets where the dialect's
/// comments are parenthesised, other forbidden and control characters blanks.
pub fn clean_comment(dialect: &Dialect, text: &str) -> String {
    text.chars()
        .map(|c| match c {
            '(' if dialect.comment_forbidden.contains(c) => '[',
            ')' if dialect.comment_forbidden.contains(c) => ']',
            c if dialect.comment_forbidden.contains(c) || c.is_control() => ' ',
            c => c,
        })
        .collect()
}

/// Checks that the dialect gives the tool's orientation so in TCP mode.
pub fn check_orientation(dialect: &Dialect, orientation: TcpOrientation) -> Result<(), EmitError> {
    if orientation == TcpOrientation::Vectors && dialect.tcp != TcpStyle::None && dialect.tcp.vector_words().is_none() {
        return Err(EmitError::TcpOrientation { dialect: dialect.name });
    }
    Ok(())
}

/// Checks that the dialect has the mode.
pub fn check_mode(dialect: &Dialect, mode: Mode) -> Result<(), EmitError> {
    let supported = match mode {
        Mode::G1 => true,
        Mode::Tcp => dialect.tcp != TcpStyle::None,
        Mode::InverseTime => dialect.inverse_time_range.is_some(),
        Mode::Bspline => dialect.bspline,
    };
    if supported { Ok(()) } else { Err(EmitError::Unsupported { dialect: dialect.name, mode: mode.name() }) }
}

/// The motion program's options for a dialect and mode: the controller's feed ranges and what
/// it can say of arcs (`native_arcs` false: every arc as straight moves).
pub fn motion_options(dialect: &Dialect, mode: Mode, native_arcs: bool) -> postpro_motion::Options {
    postpro_motion::Options {
        mode,
        inverse_time_range: dialect.inverse_time_range.unwrap_or((0.001, 99_999.0)),
        feed_range: dialect.feed_range,
        arcs: if native_arcs {
            postpro_motion::Arcs::Native { turns: dialect.arc_turns, all_planes: dialect.arc_all_planes }
        } else {
            postpro_motion::Arcs::Linear
        },
        cycles: true,
        clearance: true,
        planes: None,
    }
}

/// Millimetres per unit of the program.
fn unit_length(units: ProgramUnits) -> f64 {
    match units {
        ProgramUnits::Mm => 1.0,
        ProgramUnits::Inch => 25.4,
    }
}

/// A length (mm) in the program's units, as written with `decimals` (mm) — one more in inches.
fn length_text(value: f64, units: ProgramUnits, decimals: usize) -> String {
    let decimals = if units == ProgramUnits::Inch { decimals + 1 } else { decimals };
    crate::format::number_trimmed(value / unit_length(units), decimals)
}

/// Builds the whole program (the template context).
pub fn build(
    motion: &postpro_motion::Program,
    machine: &Machine,
    dialect: &Dialect,
    options: &Options,
) -> Result<Program, EmitError> {
    let header = header(motion, machine, dialect, options)?;
    let tools = tools(motion, dialect, options.units);
    let mut blocks = Vec::new();
    build_blocks(motion, machine, dialect, options, &mut blocks)?;
    Ok(Program { header, tools, blocks })
}

/// The header of the program (an error when the dialect has no such work offset).
pub fn header(
    motion: &postpro_motion::Program,
    machine: &Machine,
    dialect: &Dialect,
    options: &Options,
) -> Result<Header, EmitError> {
    let work_offset = dialect.work_offset(&motion.work_offset)?;
    Ok(Header {
        name: options.program_name.clone(),
        part: motion.part.clone(),
        source: options.source_name.clone(),
        machine: machine.name.clone(),
        machine_description: machine.description.clone(),
        dialect: dialect.clone(),
        mode: motion.mode,
        tcp_orientation: options.tcp_orientation,
        generator: format!("postpro {}", env!("CARGO_PKG_VERSION")),
        axes: machine
            .axes
            .iter()
            .map(|a| AxisInfo {
                letter: a.letter.clone(),
                kind: if a.kind == AxisKind::Rotary { "rotary" } else { "linear" },
            })
            .collect(),
        cl_points: motion.summary.cl_points,
        linearized_points: motion.summary.linearized_points,
        tolerance: length_text(machine.policy.linearization_tolerance, options.units, 4),
        contour_tolerance: length_text(machine.cnc.contour_tolerance, options.units, 4),
        decisions: motion.summary.decisions,
        units: options.units.as_str(),
        work_offset,
        origin: clean_comment(dialect, &motion.origin),
        prediction: options.prediction.as_ref().map(|p| Prediction {
            planner: clean_comment(dialect, &p.planner),
            operations: p
                .operations
                .iter()
                .map(|o| OperationPrediction {
                    name: clean_comment(dialect, &o.name),
                    cause: clean_comment(dialect, &o.cause),
                    ..o.clone()
                })
                .collect(),
            worst: p
                .worst
                .iter()
                .map(|m| MarkedSlowdown { text: clean_comment(dialect, &m.text), ..m.clone() })
                .collect(),
            ..p.clone()
        }),
    })
}

/// The tools of the program in order of first use, their numbers in the program's units.
pub fn tools(motion: &postpro_motion::Program, dialect: &Dialect, units: ProgramUnits) -> Vec<Tool> {
    motion
        .tools
        .iter()
        .map(|t| Tool {
            number: t.number,
            name: t.name.as_deref().map(|n| clean_comment(dialect, n)),
            diameter: t.diameter.map(|d| length_text(d, units, 3)),
            corner_radius: t.corner_radius.map(|r| length_text(r, units, 3)),
            length: t.length.map(|l| length_text(l, units, 3)),
            length_register: t.length_register,
            radius_register: t.radius_register,
        })
        .collect()
}

/// The blocks of the program, in order, handed to `sink`.
pub fn build_blocks(
    motion: &postpro_motion::Program,
    machine: &Machine,
    dialect: &Dialect,
    options: &Options,
    sink: &mut dyn BlockSink,
) -> Result<(), EmitError> {
    check_mode(dialect, motion.mode)?;
    let mut f = Formatter::new(machine, dialect, options, sink);
    for block in &motion.blocks {
        f.block(block);
    }
    f.finish()
}

/// A word as last written: its text, and its rounding where the text was made from one (a word
/// rounded alike has the same text, known without making it).
#[derive(Clone, Debug)]
struct LastWord {
    text: CompactString,
    rounded: Option<Rounded>,
}

impl LastWord {
    /// A word known by its text only.
    fn text(text: &str) -> LastWord {
        LastWord { text: text.into(), rounded: None }
    }

    /// `value` as the word of a slot whose last word is `last`, unless it would be written as
    /// that was (known by its rounding, else by its text, looked at on the stack) and not `all`.
    fn replacing(last: Option<&LastWord>, value: f64, decimals: usize, plus: bool, all: bool) -> Option<LastWord> {
        let rounded = Rounded::of(value, decimals, plus);
        if !all && rounded.is_some() && last.is_some_and(|w| w.rounded == rounded) {
            return None;
        }
        with_rounded(value, decimals, rounded, |text| {
            (all || last.map(|w| w.text.as_str()) != Some(text)).then(|| LastWord { text: text.into(), rounded })
        })
    }
}

/// The dialect's words for the motion program's blocks, with the modal state of what was
/// written last (axis texts, F, feed mode) and the annotations still to place.
pub(crate) struct Formatter<'a> {
    machine: &'a Machine,
    dialect: &'a Dialect,
    options: &'a Options,
    sink: &'a mut dyn BlockSink,
    /// The first error of the sink (a failed write); later blocks are dropped.
    failed: Option<EmitError>,
    next_n: u32,
    /// The words last written, per axis (or per TCP word).
    written: Vec<Option<LastWord>>,
    last_feed: Option<LastWord>,
    feed_mode: &'static str,
    /// The annotations, as indices into `options.annotations` in order of step.
    notes: Vec<usize>,
    /// The next one of `notes` to write.
    next_note: usize,
    /// Millimetres per program unit.
    unit: f64,
    /// The length register of the tool in the spindle.
    length_register: u32,
    /// A machine-coordinate retract cancelled the length offset (Siemens `D0`): the next motion
    /// switches it on again.
    length_off: bool,
    /// Where the last motion block ended.
    previous: Option<Position>,
    /// Tool-centre-point control is on: positions are the tip and the tool's orientation.
    tcp_active: bool,
    /// The working plane in force, with the axis values its zero has (subtracted from the linear
    /// axes' values in a tilted plane).
    plane: Option<(PlaneKind, Joints)>,
}

impl<'a> Formatter<'a> {
    pub(crate) fn new(
        machine: &'a Machine,
        dialect: &'a Dialect,
        options: &'a Options,
        sink: &'a mut dyn BlockSink,
    ) -> Self {
        let mut notes: Vec<usize> = (0..options.annotations.len()).collect();
        notes.sort_by_key(|&i| options.annotations[i].step);
        Formatter {
            machine,
            dialect,
            options,
            sink,
            failed: None,
            next_n: FIRST_NUMBER,
            written: vec![None; machine.axes.len().max(6)],
            last_feed: None,
            feed_mode: "per-minute",
            notes,
            next_note: 0,
            unit: unit_length(options.units),
            length_register: 0,
            length_off: false,
            previous: None,
            tcp_active: false,
            plane: None,
        }
    }

    fn push(&mut self, block: Block) {
        if self.failed.is_none()
            && let Err(e) = self.sink.block(block)
        {
            self.failed = Some(e);
        }
    }

    fn n(&mut self) -> Option<u32> {
        self.options.block_numbers.then(|| {
            let n = self.next_n;
            self.next_n += NUMBER_STEP;
            n
        })
    }

    fn comment(&mut self, text: &str) {
        self.comment_of(text, None);
    }

    /// A comment, marking slowdown `slowdown` if given.
    fn comment_of(&mut self, text: &str, slowdown: Option<usize>) {
        let n = self.n();
        self.push(comment_block(self.dialect, text, n, slowdown));
    }

    /// The annotations of the steps up to `k` not yet written, as positions in `notes`.
    fn take_notes(&mut self, k: usize) -> std::ops::Range<usize> {
        let annotations = &self.options.annotations;
        let start = self.next_note;
        let end = start + self.notes[start..].partition_point(|&i| annotations[i].step <= k);
        self.next_note = end;
        start..end
    }

    /// Writes annotation `notes[at]` as a comment.
    fn note(&mut self, at: usize) {
        let options = self.options;
        if let Some(a) = self.notes.get(at).and_then(|&i| options.annotations.get(i)) {
            self.comment_of(&a.text, a.slowdown);
        }
    }

    /// Tells the sink that the annotations of the steps up to `step` not yet written go here.
    fn place(&mut self, step: usize) {
        if self.failed.is_none()
            && let Err(e) = self.sink.place(step)
        {
            self.failed = Some(e);
        }
    }

    /// Writes the annotations of the steps up to `k` not yet written.
    fn notes_upto(&mut self, k: usize) {
        self.place(k);
        for at in self.take_notes(k) {
            self.note(at);
        }
    }

    fn set_feed_mode(&mut self, mode: &'static str) {
        if self.feed_mode != mode {
            self.feed_mode = mode;
            self.last_feed = None;
            let n = self.n();
            self.push(Block::FeedMode { n, mode });
        }
    }

    /// The decimals of axis `i` in the program's units (an axis's decimals are for the machine's
    /// units: one more from mm to inch, one fewer the other way).
    fn decimals(&self, i: usize) -> usize {
        let d = usize::from(self.machine.axes[i].decimals);
        match (self.machine.axes[i].kind, self.machine.units, self.options.units) {
            (AxisKind::Linear, ProgramUnits::Mm, ProgramUnits::Inch) => d + 1,
            (AxisKind::Linear, ProgramUnits::Inch, ProgramUnits::Mm) => d.saturating_sub(1),
            _ => d,
        }
    }

    /// Axis `i`'s value as written: a length in the program's units (in a tilted working plane,
    /// from the plane's zero), an angle in degrees.
    fn axis_value(&self, i: usize, value: f64) -> f64 {
        match self.machine.axes[i].kind {
            AxisKind::Linear => (value - self.shift(i)) / self.unit,
            AxisKind::Rotary => value.to_degrees(),
        }
    }

    /// The factor of F per minute in an inch program: Heidenhain takes it in 1/10 in/min.
    fn inch_feed_scale(&self) -> f64 {
        if self.options.units == ProgramUnits::Inch { self.dialect.inch_feed_scale } else { 1.0 }
    }

    /// What a tilted working plane takes from axis `i`'s values (mm): the value of its zero.
    fn shift(&self, i: usize) -> f64 {
        match &self.plane {
            Some((PlaneKind::Tilted, shift)) => shift.as_slice().get(i).copied().unwrap_or(0.0),
            _ => 0.0,
        }
    }

    /// A word of axis `i`.
    fn word(&self, letter: &str, value: f64, decimals: usize) -> Word {
        let mut text = CompactString::default();
        push_number(&mut text, value, decimals, self.dialect.explicit_plus);
        Word { letter: letter.into(), value, text }
    }

    /// The text last written in word slot `slot`.
    fn written_text(&self, slot: usize) -> Option<&str> {
        self.written[slot].as_ref().map(|w| w.text.as_str())
    }

    /// The words of the axes in `axes` whose text differs from what was last written (all of
    /// them with `all`).
    fn axis_words(&mut self, joints: &Joints, axes: AxisSet, all: bool) -> Vec<Word> {
        let mut words = Vec::with_capacity(self.machine.axes.len());
        for i in (0..self.machine.axes.len()).filter(|&i| axes.contains(i)) {
            let value = self.axis_value(i, joints[i]);
            // A word only where it changed (the rotary axes of a 3+2 program never do).
            let plus = self.dialect.explicit_plus;
            if let Some(word) = LastWord::replacing(self.written[i].as_ref(), value, self.decimals(i), plus, all) {
                let letter = self.machine.axes[i].letter.as_str().into();
                words.push(Word { letter, value, text: word.text.clone() });
                self.written[i] = Some(word);
            }
        }
        words
    }

    /// The tool tip in the part frame (TCP mode, a dynamic work offset), with the tool's
    /// orientation as `orientation` says (none: the arcs, which keep it, and the dynamic work
    /// offset, where the rotaries stand): the words whose text changed, or all of them with
    /// `all`. The orientation is written whole whenever any of it changes. Heidenhain's `LN`
    /// blocks (the tool vector) carry every coordinate and both vectors whenever anything
    /// changes: the TNC wants them all in each one.
    fn tip_words(&mut self, to: &Position, orientation: Option<TcpOrientation>, all: bool) -> Vec<Word> {
        let p = to.pose.tip / self.unit;
        let tip_decimals = if self.options.units == ProgramUnits::Inch { 5 } else { 4 };
        let tip = [("X", p.x), ("Y", p.y), ("Z", p.z)].map(|(letter, value)| self.word(letter, value, tip_decimals));
        let a = to.pose.axis;
        let vector = (orientation == Some(TcpOrientation::Vectors)).then(|| {
            let letters = self.dialect.tcp.vector_words().unwrap_or(["I", "J", "K"]);
            [0, 1, 2].map(|c| self.word(letters[c], [a.x, a.y, a.z][c], 7))
        });
        let changed = |f: &Self, slot: usize, w: &Word| f.written_text(slot) != Some(w.text.as_str());
        let vector_changed = vector.as_ref().is_some_and(|v| (0..3).any(|c| changed(self, 3 + c, &v[c])));
        let whole = self.dialect.tcp == TcpStyle::M128 && vector.is_some();
        let all = all || (whole && (vector_changed || (0..3).any(|slot| changed(self, slot, &tip[slot]))));
        let mut words = Vec::with_capacity(9);
        for (slot, word) in tip.into_iter().enumerate() {
            if all || changed(self, slot, &word) {
                self.written[slot] = Some(LastWord::text(&word.text));
                words.push(word);
            }
        }
        match (orientation, vector) {
            (Some(TcpOrientation::Angles), _) => {
                let rotaries = AxisSet::of(self.machine.axes.len(), |i| self.machine.axes[i].kind == AxisKind::Rotary);
                words.extend(self.axis_words(&to.axes, rotaries, all));
            }
            (Some(TcpOrientation::Vectors), Some(vector)) if all || vector_changed => {
                if self.dialect.tcp == TcpStyle::M128 {
                    // Heidenhain LN blocks carry a normal vector too: the tool vector (no 3D
                    // compensation).
                    for (n, v) in [("NX", a.x), ("NY", a.y), ("NZ", a.z)] {
                        let mut t = CompactString::default();
                        push_number(&mut t, v, 7, true);
                        words.push(Word { letter: n.into(), value: v, text: t });
                    }
                }
                for (c, w) in vector.into_iter().enumerate() {
                    self.written[3 + c] = Some(LastWord::text(&w.text));
                    words.push(w);
                }
            }
            _ => {}
        }
        words
    }

    /// The words of a position in this mode: the tip (and the orientation, with `orientation`)
    /// in TCP mode, the tip in a dynamic work offset, else the axes of `axes`.
    fn position_words(&mut self, to: &Position, axes: AxisSet, all: bool, orientation: bool) -> Vec<Word> {
        if self.tcp_active {
            let how = orientation.then_some(self.options.tcp_orientation);
            self.tip_words(to, how, all)
        } else if matches!(self.plane, Some((PlaneKind::Dynamic, _))) {
            self.tip_words(to, None, all)
        } else if self.plane.is_some() {
            // In a working plane the rotary axes stand (a controller may refuse their words).
            let linear = AxisSet::of(self.machine.axes.len(), |i| {
                axes.contains(i) && self.machine.axes[i].kind == AxisKind::Linear
            });
            self.axis_words(&to.axes, linear, all)
        } else {
            self.axis_words(&to.axes, axes, all)
        }
    }

    /// The length offset on again before motion, where a machine-coordinate retract cancelled it.
    fn length_on(&mut self) {
        if self.length_off {
            self.length_off = false;
            let n = self.n();
            let register = self.length_register;
            self.push(Block::LengthOn { n, register });
        }
    }

    /// The F word of a feed per minute or revolution, when it changes (with its note), after
    /// the feed mode.
    fn feed(&mut self, feed: FeedWord, note: Option<&str>, always: bool) -> (Option<String>, Option<String>) {
        let (mode, value, decimals) = match feed {
            FeedWord::InverseTime(f) => ("inverse-time", f, self.dialect.feed_decimals.max(3)),
            FeedWord::PerMinute(f) => {
                ("per-minute", f / self.unit * self.inch_feed_scale(), self.dialect.feed_decimals)
            }
            FeedWord::PerRevolution(f) => ("per-revolution", f / self.unit, self.dialect.feed_decimals.max(4)),
        };
        self.set_feed_mode(mode);
        // The F word of most blocks is the last one's.
        let Some(word) = LastWord::replacing(self.last_feed.as_ref(), value, decimals, false, always) else {
            return (None, None);
        };
        let text = word.text.to_string();
        self.last_feed = Some(word);
        (Some(text), note.map(|t| clean_comment(self.dialect, t)))
    }

    pub(crate) fn block(&mut self, block: &postpro_motion::Block) {
        self.kind(&block.kind);
        if let Some(end) = block.end() {
            self.previous = Some(*end);
        }
    }

    fn kind(&mut self, kind: &BlockKind) {
        match kind {
            BlockKind::Comment(text) => self.comment(text),
            BlockKind::Insert(text) if self.options.insert_verbatim => {
                let n = self.n();
                self.push(Block::Insert { n, text: text.clone() });
            }
            BlockKind::Insert(text) => self.comment(&format!("INSERT {}", text.trim())),
            BlockKind::Operation(name) if !name.is_empty() => self.comment(&format!("operation: {name}")),
            BlockKind::Operation(_) => {}
            BlockKind::WorkOffset(offset) => match self.dialect.work_offset(offset) {
                Ok(offset) => {
                    let n = self.n();
                    self.push(Block::WorkOffset { n, offset });
                }
                Err(e) => {
                    if self.failed.is_none() {
                        self.failed = Some(e);
                    }
                }
            },
            BlockKind::Rapid(rapid) => {
                // Before anything the step writes (or where it would, when it writes nothing).
                self.notes_upto(rapid.to.step);
                self.length_on();
                let words = self.position_words(&rapid.to, rapid.axes, false, true);
                if !words.is_empty() {
                    let n = self.n();
                    self.push(Block::Rapid { n, words });
                }
            }
            BlockKind::MachineRetract(retract) => {
                let i = retract.axis;
                let word = self.word(&self.machine.axes[i].letter, retract.value / self.unit, self.decimals(i));
                // Where the axis is now, in the program's frame, is not what was written.
                self.written[i] = None;
                if self.tcp_active {
                    self.written.iter_mut().take(3).for_each(|w| *w = None);
                }
                self.length_off = self.dialect.machine_retract_cancels_length;
                let n = self.n();
                self.push(Block::MachineRetract { n, words: vec![word] });
            }
            BlockKind::Linear(linear) => self.linear(linear),
            BlockKind::Arc(arc) => self.arc(arc),
            BlockKind::Spline(spline) => self.spline(spline),
            BlockKind::Cycle(cycle) => self.cycle(cycle),
            BlockKind::ToolChange(t) => {
                let n = self.n();
                self.length_register = t.length_register;
                self.length_off = false;
                self.push(Block::ToolChange {
                    n,
                    number: t.number,
                    name: t.name.as_deref().map(|name| clean_comment(self.dialect, name)),
                    offset: t.length_register,
                    radius_register: t.radius_register,
                    length: t.length.map(|l| length_text(l, self.options.units, 3)),
                    length_compensation: t.length_compensation,
                });
                // After a tool change every axis is written again.
                self.written.iter_mut().for_each(|w| *w = None);
                self.last_feed = None;
            }
            BlockKind::SpindleOn { speed, clockwise, surface_speed } => {
                let mut text = String::new();
                push_number(&mut text, *speed, 0, false);
                let n = self.n();
                self.push(Block::SpindleOn { n, speed: text, clockwise: *clockwise, surface_speed: *surface_speed });
            }
            BlockKind::SpindleOff => {
                let n = self.n();
                self.push(Block::SpindleOff { n });
            }
            BlockKind::CoolantOn(c) => {
                let coolant = match c {
                    Coolant::Flood => "flood",
                    Coolant::Mist => "mist",
                    Coolant::Through => "through",
                    Coolant::Air => "air",
                    Coolant::On | Coolant::Off => "on",
                };
                let n = self.n();
                self.push(Block::CoolantOn { n, coolant });
            }
            BlockKind::CoolantOff => {
                let n = self.n();
                self.push(Block::CoolantOff { n });
            }
            BlockKind::Dwell(seconds) => {
                let mut text = String::new();
                push_number(&mut text, *seconds, 3, false);
                let n = self.n();
                self.push(Block::Dwell { n, seconds: text });
            }
            BlockKind::Stop(text) => {
                let n = self.n();
                // The operator message is a comment: `STOP/(TURN THE PART)` must not nest one.
                let text = text.as_deref().map(|t| clean_comment(self.dialect, t));
                self.push(Block::Stop { n, text });
            }
            BlockKind::OptionalStop => {
                let n = self.n();
                self.push(Block::OptionalStop { n });
            }
            BlockKind::TcpOn { length_register } => {
                self.tcp_active = true;
                self.written.iter_mut().for_each(|w| *w = None);
                self.length_off = false;
                let n = self.n();
                let orientation = self.options.tcp_orientation;
                self.push(Block::TcpOn { n, length_register: *length_register, orientation });
            }
            BlockKind::PlaneOn(plane) => self.plane_on(plane),
            BlockKind::PlaneOff => {
                if let Some((plane, _)) = self.plane.take() {
                    self.written.iter_mut().for_each(|w| *w = None);
                    let n = self.n();
                    self.push(Block::PlaneOff { n, plane });
                }
            }
            BlockKind::Clamp { axis, lock } => {
                let a = &self.machine.axes[*axis];
                if let Some(clamp) = &a.clamp {
                    let code = if *lock { clamp.lock.clone() } else { clamp.unlock.clone() };
                    let (axis, n) = (a.letter.clone(), self.n());
                    self.push(Block::Clamp { n, code, lock: *lock, axis });
                }
            }
            BlockKind::TcpOff => {
                self.tcp_active = false;
                self.written.iter_mut().for_each(|w| *w = None);
                let n = self.n();
                self.push(Block::TcpOff { n });
            }
        }
    }

    /// A working plane comes into force: its angles and vectors for the dialects' commands.
    fn plane_on(&mut self, plane: &postpro_motion::WorkPlane) {
        self.plane = Some((plane.kind, plane.shift));
        self.written.iter_mut().for_each(|w| *w = None);
        // The plane's axes as columns: the rotation from the plane's frame to the part's.
        let m = plane.rotation().transpose();
        // Trimmed: a plane's axis is often a machine axis (`BX+1 BY+0`).
        let plus = self.dialect.explicit_plus;
        let trimmed = |v: f64, decimals: usize| {
            let text = crate::format::number_trimmed(v, decimals);
            if plus && !text.starts_with('-') { format!("+{text}") } else { text }
        };
        let degrees = |v: f64| trimmed(v.to_degrees(), 4);
        let unit = |v: f64| trimmed(v, 7);
        let zxz = euler_zxz(&m).map(degrees);
        let xyz = euler_xyz(&m).map(degrees);
        let column = |c: usize| [m[(0, c)], m[(1, c)], m[(2, c)]].map(unit);
        let rotaries = AxisSet::of(self.machine.axes.len(), |i| self.machine.axes[i].kind == AxisKind::Rotary);
        let mut scratch = vec![None; self.written.len()];
        std::mem::swap(&mut scratch, &mut self.written);
        let words = self.axis_words(&plane.rotaries, rotaries, true);
        std::mem::swap(&mut scratch, &mut self.written);
        let direction = if words.first().is_some_and(|w| w.value < 0.0) { -1 } else { 1 };
        let n = self.n();
        self.push(Block::PlaneOn(Box::new(PlaneOn {
            n,
            plane: plane.kind,
            euler_zxz: zxz,
            euler_xyz: xyz,
            x: column(0),
            z: column(2),
            rotaries: words,
            direction,
        })));
    }

    fn linear(&mut self, linear: &postpro_motion::Linear) {
        self.notes_upto(linear.to.step);
        self.length_on();
        let inverse = matches!(linear.feed, FeedWord::InverseTime(_));
        let (feed, note) = self.feed(linear.feed, linear.note.as_deref(), inverse);
        let words = self.position_words(&linear.to, AxisSet::ALL, inverse, true);
        if words.is_empty() && feed.is_none() {
            return;
        }
        let n = self.n();
        self.push(Block::Linear { n, words, feed, note });
    }

    /// A circular arc: the end point's words, the centre relative to the start (and absolute,
    /// for Heidenhain), the sense, the turns.
    fn arc(&mut self, arc: &postpro_motion::Arc) {
        self.notes_upto(arc.to.step);
        self.length_on();
        let [a, b, normal] = arc.plane.axes();
        let letters = ["X", "Y", "Z"];
        let offsets = ["I", "J", "K"];
        // The start and the end in the program's frame (the tip in TCP mode), program units.
        let linear = self.machine.chain.linear.clone();
        let tcp = self.tcp_active;
        let shift = |f: &Self, c: usize| if tcp { 0.0 } else { linear.get(c).map_or(0.0, |&i| f.shift(i)) };
        let frame_point = |f: &Self, p: &Position| -> [f64; 3] {
            let v = |c: usize| {
                if tcp { p.pose.tip[c] } else { linear.get(c).map_or(0.0, |&i| p.axes[i]) - shift(f, c) }
            };
            [v(0) / f.unit, v(1) / f.unit, v(2) / f.unit]
        };
        let start = self.previous.map_or([0.0; 3], |p| frame_point(self, &p));
        let end = frame_point(self, &arc.to);
        let decimals = |f: &Self, c: usize| {
            if tcp {
                if f.options.units == ProgramUnits::Inch { 5 } else { 4 }
            } else {
                f.decimals(linear.get(c).copied().unwrap_or(c))
            }
        };
        let center = [0, 1, 2].map(|c| (arc.center[c] - shift(self, c)) / self.unit);
        let center_words =
            [a, b].iter().map(|&c| self.word(offsets[c], center[c] - start[c], decimals(self, c))).collect();
        let center_absolute = [a, b].iter().map(|&c| self.word(letters[c], center[c], decimals(self, c))).collect();
        let rise = Some(self.word(letters[normal], end[normal] - start[normal], decimals(self, normal)))
            .filter(|w| w.text.trim_start_matches(['+', '-']).chars().any(|c| c != '0' && c != '.'));
        let inverse = matches!(arc.feed, FeedWord::InverseTime(_));
        let (feed, note) = self.feed(arc.feed, arc.note.as_deref(), inverse);
        // The end point in the linear axes only: a rotary word in a G2 block would make it a
        // helix about that axis.
        let count = self.machine.axes.len();
        let linear_axes = AxisSet::of(count, |i| self.machine.axes[i].kind == AxisKind::Linear);
        let words = self.position_words(&arc.to, linear_axes, true, false);
        let mut sweep = String::new();
        push_number(&mut sweep, arc.sweep.to_degrees(), 3, false);
        let n = self.n();
        self.push(Block::Arc {
            n,
            plane: arc.plane,
            clockwise: arc.clockwise,
            words,
            center: center_words,
            center_absolute,
            turns: arc.turns,
            sweep,
            rise,
            feed,
            note,
        });
    }
    /// A canned cycle: a block per hole (the first defines the cycle), then its end.
    fn cycle(&mut self, cycle: &postpro_motion::Cycle) {
        use postpro_cl::CycleKind;
        self.length_on();
        let axis = cycle.axis;
        let decimals = self.decimals(axis);
        // Absolute values along the hole axis, from a tilted plane's zero where one is in force.
        let text = |f: &Self, v: f64| {
            let mut t = String::new();
            push_number(&mut t, (v - f.shift(axis)) / f.unit, decimals, f.dialect.explicit_plus);
            t
        };
        // Relative values and pecks with their decimal point always (an integer Q on a Fanuc is
        // read in thousandths).
        let plain = |f: &Self, v: f64| crate::format::number(v / f.unit, decimals, false);
        let code = match (cycle.kind, cycle.dwell.is_some()) {
            (CycleKind::Drill, false) => "G81",
            (CycleKind::Drill, true) => "G82",
            (CycleKind::Deep, _) => "G83",
            (CycleKind::ChipBreak, _) => "G73",
            (CycleKind::Tap, _) => "G84",
            (CycleKind::Bore, false) => "G85",
            (CycleKind::Bore, true) => "G89",
        };
        let across =
            AxisSet::of(self.machine.axes.len(), |i| i != axis && self.machine.axes[i].kind == AxisKind::Linear);
        let mut previous: Option<(f64, f64)> = None;
        for (h, hole) in cycle.holes.iter().enumerate() {
            self.notes_upto(hole.at.step);
            let first = h == 0;
            let (feed, note) = if first { self.feed(cycle.feed, cycle.note.as_deref(), true) } else { (None, None) };
            let words = self.axis_words(&hole.at.axes, across, first);
            let top = hole.at.axes[axis];
            let planes_change =
                previous.is_some_and(|(b, r)| (b - hole.bottom).abs() > 1e-9 || (r - hole.r_plane).abs() > 1e-9);
            previous = Some((hole.bottom, hole.r_plane));
            let letter = self.machine.axes[axis].letter.as_str().into();
            let value = (hole.bottom - self.shift(axis)) / self.unit;
            let bottom = Word { letter, value, text: text(self, hole.bottom).into() };
            let pitch = match (cycle.kind, cycle.feed, cycle.rpm) {
                (CycleKind::Tap, FeedWord::PerMinute(f), Some(rpm)) if rpm > 0.0 => Some(plain(self, f / rpm)),
                (CycleKind::Tap, FeedWord::PerRevolution(p), _) => Some(plain(self, p)),
                _ => None,
            };
            let n = self.n();
            self.push(Block::CycleHole(Box::new(CycleHole {
                n,
                first,
                cycle: cycle.kind,
                code,
                words,
                bottom,
                r_plane: text(self, hole.r_plane),
                top: text(self, top),
                initial: text(self, hole.initial),
                clearance: plain(self, hole.r_plane - top),
                depth: plain(self, top - hole.bottom),
                return_height: plain(self, hole.initial - top),
                planes_change,
                to_initial: cycle.to_initial,
                peck: cycle.peck.map(|(first, _)| plain(self, first)),
                peck_next: cycle.peck.map(|(_, next)| plain(self, next)),
                dwell: cycle.dwell.map(|d| crate::format::number_trimmed(d, 3)),
                dwell_ms: cycle.dwell.map(|d| crate::format::number_trimmed((d * 1000.0).round(), 0)),
                feed: feed.or_else(|| self.last_feed.as_ref().map(|w| w.text.to_string())).unwrap_or_default(),
                pitch,
                note,
            })));
        }
        // The cycle leaves the spindle axis at the return level: written again before the next
        // move along it.
        self.written[axis] = None;
        let n = self.n();
        self.push(Block::CycleOff { n });
    }

    /// A B-spline run: `BSPLINE`, its control points with their `PL`, back to `G1`; the
    /// annotations of its steps where the motion program places them.
    fn spline(&mut self, spline: &postpro_motion::Spline) {
        let end = spline.points.last().map_or(0, |p| p.step);
        let last_step = spline.steps.last().map_or(end, |s| s.0).max(end);
        let first_step = spline.steps.first().map_or(end, |s| s.0);
        // Annotations of earlier steps not yet written, then those of the run, by place.
        self.notes_upto(first_step.saturating_sub(1));
        let taken = self.take_notes(last_step);
        let annotations = &self.options.annotations;
        let mut placed: Vec<(usize, usize)> = taken
            .map(|at| {
                let step = annotations[self.notes[at]].step;
                // A step the run does not list (none should be) goes before the spline.
                let place = spline.steps.binary_search_by_key(&step, |s| s.0).map_or(0, |i| spline.steps[i].1);
                (place, at)
            })
            .collect();
        placed.sort_by_key(|&(place, _)| place);
        // For a sink that puts the annotations in afterwards: before control point `k` go those
        // of the steps placed at `k` or before, when the places follow the steps.
        if !spline.steps.windows(2).all(|w| w[0].0 < w[1].0 && w[0].1 <= w[1].1) {
            self.sink.unplaceable();
        }
        let mut listed = 0;
        let mut next = 0;
        let mut upto = |f: &mut Self, place: usize| {
            while spline.steps.get(listed).is_some_and(|s| s.1 <= place) {
                listed += 1;
            }
            if let Some(&(step, _)) = listed.checked_sub(1).and_then(|i| spline.steps.get(i)) {
                f.place(step);
            }
            while let Some(&(p, at)) = placed.get(next).filter(|(p, _)| *p <= place) {
                let _ = p;
                f.note(at);
                next += 1;
            }
        };
        upto(self, 0);
        self.length_on();
        let mut feed = String::new();
        push_number(&mut feed, spline.feed / self.unit, self.dialect.feed_decimals, false);
        let n = self.n();
        self.push(Block::BsplineOn { n, degree: postpro_kin::bspline::DEGREE, feed });
        for (k, control) in spline.curve.control.iter().enumerate().skip(1) {
            upto(self, k);
            let words = self.axis_words(control, AxisSet::ALL, true);
            let mut pl = String::new();
            // The knot intervals are lengths of the tool tip's path: in the program's units.
            push_number(&mut pl, spline.curve.pl(k) / self.unit, 4, false);
            let n = self.n();
            self.push(Block::ControlPoint { n, words, pl });
        }
        upto(self, usize::MAX);
        let n = self.n();
        self.push(Block::BsplineOff { n });
        self.last_feed = None;
    }

    pub(crate) fn finish(mut self) -> Result<(), EmitError> {
        // Annotations of steps past the last one: after the last motion, never dropped.
        self.notes_upto(usize::MAX);
        if self.feed_mode != "per-minute" {
            self.set_feed_mode("per-minute");
        }
        match self.failed {
            Some(e) => Err(e),
            None => Ok(()),
        }
    }
}

/// The formatter takes the motion program's blocks as they are made.
impl postpro_motion::MotionSink for Formatter<'_> {
    fn block(&mut self, block: postpro_motion::Block) {
        Formatter::block(self, &block);
    }
}

/// Euler angles (α, β, γ) with `m` = Rz(α)·Rx(β)·Rz(γ) (rad); β in [0, π]. At β = 0 or π the
/// whole turn about z is α (γ = 0).
pub(crate) fn euler_zxz(m: &nalgebra::Matrix3<f64>) -> [f64; 3] {
    let beta = m[(2, 2)].clamp(-1.0, 1.0).acos();
    if beta.sin().abs() < 1e-9 {
        // Rz(α)·Rx(0 or π): the first column is (cos α, sin α, 0).
        return [m[(1, 0)].atan2(m[(0, 0)]), beta, 0.0];
    }
    [m[(0, 2)].atan2(-m[(1, 2)]), beta, m[(2, 0)].atan2(m[(2, 1)])]
}

/// Angles (a, b, c) with `m` = Rx(a)·Ry(b)·Rz(c) (rad): about x, then the new y, then the new z.
/// At b = ±90° the turn about x and z is one: c = 0.
pub(crate) fn euler_xyz(m: &nalgebra::Matrix3<f64>) -> [f64; 3] {
    let b = m[(0, 2)].clamp(-1.0, 1.0).asin();
    if b.cos().abs() < 1e-9 {
        // Rx(a)·Ry(±90°): the second row of the last column is 0, the first column (0, ±sin a…).
        return [m[(2, 1)].atan2(m[(1, 1)]), b, 0.0];
    }
    [(-m[(1, 2)]).atan2(m[(2, 2)]), b, (-m[(0, 1)]).atan2(m[(0, 0)])]
}

#[cfg(test)]
mod euler_tests {
    use nalgebra::{Matrix3, Rotation3, Vector3};

    use super::{euler_xyz, euler_zxz};

    fn rz(a: f64) -> Matrix3<f64> {
        *Rotation3::from_axis_angle(&Vector3::z_axis(), a).matrix()
    }
    fn rx(a: f64) -> Matrix3<f64> {
        *Rotation3::from_axis_angle(&Vector3::x_axis(), a).matrix()
    }
    fn ry(a: f64) -> Matrix3<f64> {
        *Rotation3::from_axis_angle(&Vector3::y_axis(), a).matrix()
    }

    #[test]
    fn the_angles_give_the_rotation_back() {
        let angles = [-2.5, -1.2, -0.3, 0.0, 0.4, 1.1, 2.9];
        for &a in &angles {
            for &b in &angles {
                for &c in &angles {
                    let m = rz(a) * rx(b) * rz(c);
                    let [p, q, r] = euler_zxz(&m);
                    assert!((rz(p) * rx(q) * rz(r) - m).norm() < 1e-9, "zxz {a} {b} {c}");
                    let m = rx(a) * ry(b) * rz(c);
                    let [p, q, r] = euler_xyz(&m);
                    assert!((rx(p) * ry(q) * rz(r) - m).norm() < 1e-9, "xyz {a} {b} {c}");
                }
            }
        }
        // The degenerate ones.
        for m in [rz(0.7), rz(0.7) * rx(std::f64::consts::PI), rx(0.3) * ry(std::f64::consts::FRAC_PI_2)] {
            let [p, q, r] = euler_zxz(&m);
            let [a, b, c] = euler_xyz(&m);
            assert!((rz(p) * rx(q) * rz(r) - m).norm() < 1e-9);
            assert!((rx(a) * ry(b) * rz(c) - m).norm() < 1e-9);
        }
    }
}
