//! The blocks of a motion program: what the machine is asked to do, in program order, in the
//! machine's axis space. Plain data: the prediction reads them, the emitter renders them, neither
//! decides anything they say.

use postpro_cl::{Coolant, Span};
use postpro_kin::bspline;
use postpro_kin::{Joints, Pose, StepKind};
use serde::Serialize;

/// How motion is written.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Mode {
    /// Axis values with `G1` and the programmed feed.
    G1,
    /// Axis values with `G93` and F = 1/Δt on every block.
    InverseTime,
    /// Tool tip and tool orientation in the part frame; the controller solves the kinematics.
    Tcp,
    /// Siemens `BSPLINE SD=3`: a cubic B-spline through the axis positions of each run of feed
    /// moves, within the linearization tolerance.
    Bspline,
}

impl Mode {
    /// The command-line name.
    pub fn name(self) -> &'static str {
        match self {
            Mode::G1 => "g1",
            Mode::InverseTime => "inverse-time",
            Mode::Tcp => "tcp",
            Mode::Bspline => "bspline",
        }
    }

    /// True when F is the tool tip's feed along the path (inverse time, TCP, B-spline); false
    /// when it is the feed of the axes (G1 on axis values).
    pub fn feeds_the_tip(self) -> bool {
        self != Mode::G1
    }
}

/// One position of the machine.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Position {
    /// The axis values in `Machine::axes` order (mm, rad; rotary angles unwound).
    pub axes: Joints,
    /// The tool pose these axis values give, in the part frame.
    pub pose: Pose,
    /// The solved step it is (an index into `Solved::steps`); annotations name steps.
    pub step: usize,
    /// Why the step is there.
    pub kind: StepKind,
}

/// The F word of a feed move.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FeedWord {
    /// mm/min: the tip's feed in TCP mode, the axes' feed on axis values (`G94`).
    PerMinute(f64),
    /// mm per spindle revolution (`G95`).
    PerRevolution(f64),
    /// 1/min: the block lasts 1/F minutes (`G93`).
    InverseTime(f64),
}

/// A feed move, straight in the axis space (or along the part frame's straight line in TCP
/// mode).
#[derive(Clone, Debug, PartialEq)]
pub struct Linear {
    /// Where it ends.
    pub to: Position,
    /// The F word.
    pub feed: FeedWord,
    /// A remark for the end of the line (a feed limited to the controller's range).
    pub note: Option<String>,
    /// Positions the controller passes through on its own before `to`, not written (in TCP mode,
    /// the points linearization added: the axes' path the controller's interpolation takes), for
    /// the prediction.
    pub via: Vec<Position>,
}

/// A run of feed moves written as one B-spline through the axis positions of its CL points.
#[derive(Clone, Debug, PartialEq)]
pub struct Spline {
    /// The feed along the tool tip's path (mm/min).
    pub feed: f64,
    /// The curve in the axis space: `control[0]` is the position before the spline.
    pub curve: bspline::Spline,
    /// The tool poses of the points the spline was fitted through, the start first (the CL
    /// points of the run and any midpoints the fit added): the prediction's parameter.
    pub poses: Vec<Pose>,
    /// The curve's parameter at each of those points.
    pub params: Vec<f64>,
    /// The points it passes through after the start (`poses[1..]`): the CL points of the run, and
    /// the midpoints the fit added (of kind `Linearized`, with the step of the CL point they lead
    /// to). The last is the end of the run.
    pub points: Vec<Position>,
    /// Every step of the run (CL points and the linearization points leading to them), with the
    /// control point (1-based, as written after `BSPLINE`) their annotations go before: the first
    /// of the span that ends at the step's CL point.
    pub steps: Vec<(usize, usize)>,
}

/// A tool change, with the tool's own offsets.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ToolCall {
    /// Tool number.
    pub number: u32,
    /// Tool name, when known.
    pub name: Option<String>,
    /// Diameter (mm), when the CL file gives the tool's geometry before the change.
    pub diameter: Option<f64>,
    /// Corner radius (mm), likewise.
    pub corner_radius: Option<f64>,
    /// Length-offset register (`H`).
    pub length_register: u32,
    /// The CNC applies the tool length (`G43 H…`, `D…`): true when the axis values are those of
    /// the spindle nose, false when they include the tool length already.
    pub length_compensation: bool,
}

/// What a block is.
#[derive(Clone, Debug, PartialEq)]
pub enum BlockKind {
    /// A comment (IKT decisions, CL text, words carried without interpretation).
    Comment(String),
    /// Text for the program as is (CL `INSERT`).
    Insert(String),
    /// An operation of the CL file starts (its name, possibly empty).
    Operation(String),
    /// Rapid traverse to a position.
    Rapid(Position),
    /// A feed move.
    Linear(Linear),
    /// A run of feed moves as one B-spline.
    Spline(Box<Spline>),
    /// A tool change.
    ToolChange(ToolCall),
    /// Spindle on.
    SpindleOn {
        /// rpm, or the surface speed as the CL file gives it.
        speed: f64,
        /// Clockwise.
        clockwise: bool,
        /// Constant surface speed.
        surface_speed: bool,
    },
    /// Spindle off.
    SpindleOff,
    /// Coolant on (never [`Coolant::Off`]).
    CoolantOn(Coolant),
    /// Coolant off.
    CoolantOff,
    /// Dwell (s).
    Dwell(f64),
    /// Program stop, with an optional message.
    Stop(Option<String>),
    /// Optional stop.
    OptionalStop,
    /// Tool-centre-point control on.
    TcpOn,
    /// Tool-centre-point control off.
    TcpOff,
}

/// One block, with the CL statement it comes from.
#[derive(Clone, Debug, PartialEq)]
pub struct Block {
    /// The CL statement (for a block postpro adds, the statement it is added for).
    pub span: Span,
    /// What it is.
    pub kind: BlockKind,
}

impl Block {
    /// The position the machine is at after this block, when it moves.
    pub fn end(&self) -> Option<&Position> {
        match &self.kind {
            BlockKind::Rapid(p) => Some(p),
            BlockKind::Linear(l) => Some(&l.to),
            BlockKind::Spline(s) => s.points.last(),
            _ => None,
        }
    }
}
