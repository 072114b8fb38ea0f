//! The blocks of a motion program: what the machine is asked to do, in program order, in the
//! machine's axis space. Plain data: the prediction reads them, the emitter renders them, neither
//! decides anything they say.

use postpro_cl::{Coolant, CycleKind, Span};
use postpro_kin::bspline;
use postpro_kin::{Joints, Pose, StepKind};
use postpro_machine::setup::WorkOffset;
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

/// A set of axes (indices into `Machine::axes`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct AxisSet(u8);

impl AxisSet {
    /// Every axis.
    pub const ALL: AxisSet = AxisSet(u8::MAX);

    /// The axes `i` for which `keep(i)` holds, among the first `count`.
    pub fn of(count: usize, keep: impl Fn(usize) -> bool) -> AxisSet {
        AxisSet((0..count.min(8)).filter(|&i| keep(i)).fold(0, |m, i| m | 1 << i))
    }

    /// True when axis `i` is in the set.
    pub fn contains(self, i: usize) -> bool {
        i < 8 && self.0 & (1 << i) != 0
    }
}

/// One position of the machine.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Position {
    /// The axis values in `Machine::axes` order, in the work-offset frame (mm, rad; rotary angles
    /// unwound).
    pub axes: Joints,
    /// The tool pose these axis values give, in the part frame.
    pub pose: Pose,
    /// The solved step it is (an index into `Solved::steps`); annotations name steps. A position
    /// postpro adds (a retract, a re-orientation, an approach) has the step it leads to.
    pub step: usize,
    /// Why the step is there: `Retract` for the retracts and approaches postpro adds at the
    /// clearance, `Reorient` for the rotation between them.
    pub kind: StepKind,
    /// The CL statement of the step.
    pub span: Span,
}

/// A rapid traverse.
#[derive(Clone, Debug, PartialEq)]
pub struct Rapid {
    /// Where it ends (every axis: those it does not move keep their values).
    pub to: Position,
    /// The axes it moves (and writes): all, or the rotaries alone at the clearance, or the axes
    /// across the spindle before the one along it on an approach.
    pub axes: AxisSet,
}

/// The plane of a circular arc, in the axis space (the program's frame).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Plane {
    /// X–Y, normal +Z (`G17`).
    Xy,
    /// Z–X, normal +Y (`G18`).
    Zx,
    /// Y–Z, normal +X (`G19`).
    Yz,
}

impl Plane {
    /// The indices (0 = X, 1 = Y, 2 = Z) of the plane's first and second axis and of its normal.
    pub fn axes(self) -> [usize; 3] {
        match self {
            Plane::Xy => [0, 1, 2],
            Plane::Zx => [2, 0, 1],
            Plane::Yz => [1, 2, 0],
        }
    }
}

/// A circular arc (or helix) in a plane of the program's frame.
#[derive(Clone, Debug, PartialEq)]
pub struct Arc {
    /// Where it ends.
    pub to: Position,
    /// The plane.
    pub plane: Plane,
    /// The centre, in the program's frame (X, Y, Z of the linear axes; mm). On a helix its
    /// coordinate along the plane's normal is that of the start.
    pub center: [f64; 3],
    /// Clockwise about the plane's normal (`G2`), else counter-clockwise (`G3`).
    pub clockwise: bool,
    /// Full turns besides the last, partial one.
    pub turns: u32,
    /// The angle swept (rad, > 0, full turns included).
    pub sweep: f64,
    /// Radius (mm).
    pub radius: f64,
    /// The F word.
    pub feed: FeedWord,
    /// A remark for the end of the line.
    pub note: Option<String>,
    /// The positions the controller passes through on the way, within the tolerance of the arc
    /// (the points the CL arc was solved at), for the prediction.
    pub via: Vec<Position>,
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

/// A canned cycle: the same motion at each of its holes, written as the controller's cycle.
#[derive(Clone, Debug, PartialEq)]
pub struct Cycle {
    /// What it does at each hole.
    pub kind: CycleKind,
    /// The holes, in order.
    pub holes: Vec<Hole>,
    /// The linear axis along the holes (the spindle's), an index into `Machine::axes`.
    pub axis: usize,
    /// Peck depths (mm): the first, and each following one.
    pub peck: Option<(f64, f64)>,
    /// Dwell at the bottom (s).
    pub dwell: Option<f64>,
    /// The F word.
    pub feed: FeedWord,
    /// A remark for the end of the line (a feed limited to the machine's range).
    pub note: Option<String>,
    /// After each hole the tool returns to the level it started the cycle at (`G98`), else to
    /// the R plane (`G99`).
    pub to_initial: bool,
    /// The spindle speed in force (rpm), for a tap's pitch.
    pub rpm: Option<f64>,
    /// The motion the controller makes, in order, for the prediction.
    pub motion: Vec<CycleMove>,
}

/// One hole of a canned cycle.
#[derive(Clone, Debug, PartialEq)]
pub struct Hole {
    /// The hole's top point (where its depth is measured from), in the program's frame.
    pub at: Position,
    /// The bottom: the value of the cycle's axis there (mm, program frame).
    pub bottom: f64,
    /// The R plane: where the feed starts (mm, program frame).
    pub r_plane: f64,
    /// The level the tool starts the hole from and returns to with `to_initial` (mm, program
    /// frame).
    pub initial: f64,
}

/// A move the controller makes in a canned cycle.
#[derive(Clone, Debug, PartialEq)]
pub struct CycleMove {
    /// Where it ends.
    pub to: Position,
    /// At rapid, else at the cycle's feed.
    pub rapid: bool,
    /// A dwell before it (s).
    pub dwell: f64,
}

/// A tool change, with the tool's own offsets.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ToolCall {
    /// Tool number.
    pub number: u32,
    /// Tool name, when known.
    pub name: Option<String>,
    /// Radius-offset register (`D`).
    pub radius_register: u32,
    /// Tool length (mm), when known.
    pub length: Option<f64>,
    /// Diameter (mm), when the CL file gives the tool's geometry before the change.
    pub diameter: Option<f64>,
    /// Corner radius (mm), likewise.
    pub corner_radius: Option<f64>,
    /// Length-offset register (`H`).
    pub length_register: u32,
    /// The CNC applies the tool length (`G43 H…`, `D…`): true when the axis values are those of
    /// the spindle nose, false when they include the tool length already (a head machine in a
    /// joint mode).
    pub length_compensation: bool,
}

/// Where the retracts to the clearance go: the spindle axis to a machine coordinate.
#[derive(Clone, Debug, PartialEq)]
pub struct MachineRetract {
    /// Where the machine is afterwards, in the program's frame.
    pub to: Position,
    /// The axis (the linear axis along the spindle).
    pub axis: usize,
    /// Its value in machine coordinates (mm).
    pub value: f64,
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
    /// The work offset the program's coordinates are in.
    WorkOffset(WorkOffset),
    /// Rapid traverse.
    Rapid(Rapid),
    /// A retract of the spindle axis in machine coordinates (`G53`, `SUPA`, `M91`).
    MachineRetract(MachineRetract),
    /// A feed move.
    Linear(Linear),
    /// A circular arc.
    Arc(Box<Arc>),
    /// A run of feed moves as one B-spline.
    Spline(Box<Spline>),
    /// A canned cycle.
    Cycle(Box<Cycle>),
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
    /// Tool-centre-point control on, with the length register of the tool in the spindle.
    TcpOn {
        /// Length-offset register (`H`).
        length_register: u32,
    },
    /// Tool-centre-point control off.
    TcpOff,
    /// A tilted working plane (3+2) comes into force: the rotary axes stand at its set-up and
    /// the coordinates that follow are the plane's, until [`BlockKind::PlaneOff`].
    PlaneOn(Box<WorkPlane>),
    /// The working plane is reset: coordinates in the work offset's frame again.
    PlaneOff,
    /// A rotary axis's brake is locked (`lock`) or unlocked: the machine definition's M codes.
    Clamp {
        /// The axis (an index into `Machine::axes`).
        axis: usize,
        /// Lock, else unlock.
        lock: bool,
    },
}

/// How the controller takes the coordinates of a 3+2 set-up.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum PlaneKind {
    /// In a tilted frame whose z axis is the tool axis (Fanuc `G68.2`, Siemens `CYCLE800`,
    /// Heidenhain `PLANE`): the plane's coordinates.
    Tilted,
    /// In the part frame, the controller turning them with the rotaries (Haas `G254`, the
    /// dynamic work offset): the tool tip's part coordinates.
    Dynamic,
}

/// A working plane of a 3+2 set-up, on a machine whose rotary axes carry the part. Its axes are
/// the machine's linear axes as the part sees them with the rotaries at the set-up: its z axis is
/// the tool axis, and its coordinates are the axis values less those of the part zero. The work
/// offset is the part zero (the controller knows the rotary axes' place).
#[derive(Clone, Debug, PartialEq)]
pub struct WorkPlane {
    /// How the controller takes the coordinates.
    pub kind: PlaneKind,
    /// The plane's x, y and z axes in the part frame (rows of the rotation from the part frame to
    /// the plane's; z is the tool axis).
    pub axes: [nalgebra::Vector3<f64>; 3],
    /// The written axis values (work-offset frame) of the part zero at this set-up: subtracted
    /// from the linear axes' values, they give the plane's coordinates (`Tilted`).
    pub shift: Joints,
    /// The rotary axes' values (work-offset frame) of the set-up.
    pub rotaries: Joints,
}

impl WorkPlane {
    /// The rotation from the part frame to the plane's (rows: the plane's axes).
    pub fn rotation(&self) -> nalgebra::Matrix3<f64> {
        nalgebra::Matrix3::from_rows(&[self.axes[0].transpose(), self.axes[1].transpose(), self.axes[2].transpose()])
    }
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
            BlockKind::Rapid(r) => Some(&r.to),
            BlockKind::MachineRetract(r) => Some(&r.to),
            BlockKind::Linear(l) => Some(&l.to),
            BlockKind::Arc(a) => Some(&a.to),
            BlockKind::Spline(s) => s.points.last(),
            BlockKind::Cycle(c) => c.motion.last().map(|m| &m.to),
            _ => None,
        }
    }
}
