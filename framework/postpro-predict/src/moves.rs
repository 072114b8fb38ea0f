//! The motion the CNC is asked for, read from the motion program: one block per position it
//! writes (a rapid, a feed move, each point a B-spline passes through, each point the controller
//! passes through on its own in TCP mode), with its programmed feed.
//!
//! A block moves the axes from the previous position to its own, linearly in the axis space
//! (that is what G1 and G93 command). Its **nominal duration** is the time the program asks for:
//! `60 / F` s in inverse time; the tip length over the feed (`L / V_f`) in TCP and B-spline
//! output; in G1 output the CNC reads F as the feed of the linear axes in the machine frame (or
//! of the rotary axes in degrees per minute when only they move), so a block that swings the
//! table lasts `|ΔXYZ| / F`, whatever the tip does. Rapids move at the axes' speed (G0). Blocks
//! are stored column-wise: a million of them is a few tens of megabytes.

use nalgebra::Vector3;
use postpro_kin::{StepKind, bspline};
use postpro_machine::model::{AxisKind, Machine};
use postpro_motion::{BlockKind as MotionKind, FeedWord, Position};

use crate::window::Window;

/// How the CNC turns the programmed feed into the duration of a block.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Timing {
    /// The tool tip moves at the feed: inverse time (G93), TCP, B-spline.
    TipFeed,
    /// G1 on axis values: the feed is that of the linear axes (or of the rotary axes in °/min).
    AxisFeed,
}

/// What a block is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum BlockKind {
    /// A feed move.
    Feed,
    /// A feed move that turns the tool about its tip (no tip motion): it has no feed to keep.
    Reorientation,
    /// Rapid traverse, retract or reorientation at the clearance.
    Rapid,
}

/// An assumption the prediction had to make about a block (a feed it could not read).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Note {
    /// The step where it happened.
    pub step: usize,
    /// Its CL statement.
    pub span: postpro_cl::Span,
    /// What was assumed.
    pub text: String,
}

/// A B-spline of the motion program and the blocks it covers: block `first + d` ends at data
/// point `d + 1` of the fit (`poses[d + 1]`).
#[derive(Clone, Debug)]
pub struct SplineRun {
    /// The first block.
    pub first: usize,
    /// The curve in the axis space; `control[0]` is the position before it.
    pub curve: bspline::Spline,
    /// The tool poses of the data points, the start first.
    pub poses: Vec<postpro_kin::Pose>,
    /// The spline's parameter at each data point.
    pub params: Vec<f64>,
}

/// The blocks of a program, column-wise, by position in the program: a streamed prediction holds
/// a window of them (see [`Window`]). Block `i` moves from `position(i)` to `position(i + 1)`.
#[derive(Clone, Debug, Default)]
pub struct Blocks {
    /// Number of axes.
    pub axes: usize,
    /// Axis values at the start and after every block (`(len + 1) × axes`; mm, rad).
    pub positions: Window<f64>,
    /// The tool tip in the part frame at the start and after every block (mm).
    pub tips: Window<nalgebra::Point3<f64>>,
    /// The tool axis in the part frame at the start and after every block.
    pub tool_axes: Window<nalgebra::Unit<Vector3<f64>>>,
    /// Tip length of each block (mm).
    pub length: Window<f64>,
    /// Programmed feed of each block (mm/s); 0 for rapids.
    pub feed: Window<f64>,
    /// Nominal duration of each block at the programmed feed (s).
    pub nominal: Window<f64>,
    /// The kind of each block.
    pub kind: Window<BlockKind>,
    /// True when the CNC stops exactly before the block (rapids, tool changes, stops, dwells).
    pub stop_before: Window<bool>,
    /// Dwell before the block (s).
    pub dwell_before: Window<f64>,
    /// Index of the block's end step in [`Solved::steps`].
    pub step: Window<usize>,
    /// The CL statement of that step.
    pub span: Window<postpro_cl::Span>,
    /// True when the block ends on a CL point (not on a point added by linearization).
    pub cl: Window<bool>,
    /// True when the block is one of the NC program's: false for the points within an arc and
    /// the linearization points a TCP program leaves to the controller (the prediction follows
    /// them all the same).
    pub written: Window<bool>,
    /// The B-splines of the program, in order, each over a run of consecutive blocks.
    pub splines: Window<SplineRun>,
    /// Where an assumption was made (a feed per revolution without a spindle speed, no feed).
    pub notes: Vec<Note>,
    /// True for a feed block that moves the tip along the tool axis (within 1°): a plunge, or a
    /// retract at feed.
    pub along_axis: Window<bool>,
    /// The operation of each block (index into [`Self::operations`]).
    pub operation: Window<u32>,
    /// The circular arc each block lies on (numbered from 1, in program order; 0: a straight
    /// block). Consecutive blocks of one arc meet without a corner.
    pub arc: Window<u32>,
    /// The radius of that arc (mm; infinite for a straight block).
    pub radius: Window<f64>,
    /// The names of the CL file's operations that have blocks, in order (`OperationStart`
    /// items: NX `TOOL PATH/`, CAMWorks `OPFEATSTART`, …); an empty name for the blocks before
    /// the first one, or of an operation without a name.
    pub operations: Vec<String>,
}

impl Blocks {
    /// Number of blocks (of the whole program so far, held or not).
    pub fn len(&self) -> usize {
        self.length.end()
    }

    /// True when there is no block.
    pub fn is_empty(&self) -> bool {
        self.length.is_empty()
    }

    /// The axis values before block `i` (after block `i - 1`).
    pub fn position(&self, i: usize) -> &[f64] {
        self.positions.slice(i * self.axes..(i + 1) * self.axes)
    }

    /// Forgets the blocks before block `i` (their positions too; block `i`'s start is kept).
    pub fn forget_before(&mut self, i: usize) {
        self.positions.forget_before(i * self.axes);
        self.tips.forget_before(i);
        self.tool_axes.forget_before(i);
        self.length.forget_before(i);
        self.feed.forget_before(i);
        self.nominal.forget_before(i);
        self.kind.forget_before(i);
        self.stop_before.forget_before(i);
        self.dwell_before.forget_before(i);
        self.step.forget_before(i);
        self.span.forget_before(i);
        self.cl.forget_before(i);
        self.written.forget_before(i);
        self.along_axis.forget_before(i);
        self.operation.forget_before(i);
        self.arc.forget_before(i);
        self.radius.forget_before(i);
        let runs = (self.splines.base()..self.splines.end()).take_while(|&r| {
            let run = &self.splines[r];
            run.first + run.poses.len() - 1 <= i
        });
        if let Some(r) = runs.last() {
            self.splines.forget_before(r + 1);
        }
    }

    /// The axis displacement of block `i`.
    pub fn delta(&self, i: usize, out: &mut [f64]) {
        let (a, b) = (self.position(i), self.position(i + 1));
        for ((o, x), y) in out.iter_mut().zip(a).zip(b) {
            *o = y - x;
        }
    }

    /// The unit direction of the tip on block `i`, zero when the tip does not move.
    pub fn direction(&self, i: usize) -> Vector3<f64> {
        let d = self.tips[i + 1] - self.tips[i];
        let n = d.norm();
        if n > 0.0 { d / n } else { Vector3::zeros() }
    }

    /// The tip feed the nominal duration stands for (mm/s): `L / nominal`.
    pub fn nominal_tip_feed(&self, i: usize) -> f64 {
        if self.nominal[i] > 0.0 { self.length[i] / self.nominal[i] } else { 0.0 }
    }

    /// True when blocks `a` and `b` lie on one arc (they meet without a corner).
    pub fn same_arc(&self, a: usize, b: usize) -> bool {
        self.arc[a] != 0 && self.arc[a] == self.arc[b]
    }

    /// What caps the junction from block `previous` into block `i`: `Plunge` where either moves
    /// the tip along the tool axis (a plunge, a retract at feed: the program asks the tool to
    /// turn there), else `Corner`.
    pub fn junction_limit(&self, previous: Option<usize>, i: usize) -> crate::plan::Limit {
        if self.along_axis[i] || previous.is_some_and(|p| self.along_axis[p]) {
            crate::plan::Limit::Plunge
        } else {
            crate::plan::Limit::Corner
        }
    }

    /// The programmed pose before block `i` (after block `i - 1`).
    pub fn pose(&self, i: usize) -> postpro_kin::Pose {
        postpro_kin::Pose { tip: self.tips[i], axis: self.tool_axes[i] }
    }

    fn push_position(&mut self, joints: &[f64], pose: &postpro_kin::Pose) {
        self.positions.extend_from_slice(joints);
        self.tips.push(pose.tip);
        self.tool_axes.push(pose.axis);
    }
}

/// The blocks of a motion program, each with its programmed feed, timed as `timing` says for
/// feeds per minute.
pub fn blocks(program: &postpro_motion::Program, machine: &Machine, timing: Timing) -> Blocks {
    let mut out = Blocks::new(machine);
    let mut reader = Reader::new(timing);
    for block in &program.blocks {
        reader.block(&mut out, machine, block);
    }
    out
}

impl Blocks {
    /// No blocks yet, for `machine`.
    pub fn new(machine: &Machine) -> Blocks {
        Blocks { axes: machine.axes.len(), ..Blocks::default() }
    }
}

/// Reads the blocks of a motion program one at a time (see [`blocks`]).
#[derive(Debug)]
pub struct Reader {
    timing: Timing,
    state: State,
    /// Arcs so far.
    arcs: u32,
}

impl Reader {
    /// A reader timing feeds per minute as `timing` says.
    pub fn new(timing: Timing) -> Reader {
        let state = State {
            stop: true,
            dwell: 0.0,
            rpm: None,
            feed: None,
            started: false,
            operation: None,
            arc: (0, f64::INFINITY),
            via: false,
        };
        Reader { timing, state, arcs: 0 }
    }

    /// The blocks of the next block of the motion program, added to `out`.
    pub fn block(&mut self, out: &mut Blocks, machine: &Machine, block: &postpro_motion::Block) {
        let (timing, state) = (self.timing, &mut self.state);
        match &block.kind {
            MotionKind::Rapid(rapid) => push_block(out, machine, timing, &rapid.to, Feed::Rapid, state),
            MotionKind::MachineRetract(retract) => {
                state.stop = true;
                push_block(out, machine, timing, &retract.to, Feed::Rapid, state);
            }
            MotionKind::Arc(arc) => {
                let feed = match arc.feed {
                    FeedWord::PerMinute(f) => Feed::PerMinute(f),
                    FeedWord::PerRevolution(f) => Feed::PerRevolution(f),
                    FeedWord::InverseTime(f) => Feed::InverseTime(f, 1 + arc.via.len()),
                };
                self.arcs += 1;
                state.arc = (self.arcs, arc.radius);
                state.via = true;
                for via in &arc.via {
                    push_block(out, machine, timing, via, feed, state);
                }
                state.via = false;
                push_block(out, machine, timing, &arc.to, feed, state);
                state.arc = (0, f64::INFINITY);
            }
            MotionKind::Linear(linear) => {
                let feed = match linear.feed {
                    FeedWord::PerMinute(f) => Feed::PerMinute(f),
                    FeedWord::PerRevolution(f) => Feed::PerRevolution(f),
                    FeedWord::InverseTime(f) => Feed::InverseTime(f, 1 + linear.via.len()),
                };
                state.via = true;
                for via in &linear.via {
                    push_block(out, machine, timing, via, feed, state);
                }
                state.via = false;
                push_block(out, machine, timing, &linear.to, feed, state);
            }
            MotionKind::Cycle(cycle) => {
                let feed = match cycle.feed {
                    FeedWord::PerMinute(f) => Feed::PerMinute(f),
                    FeedWord::PerRevolution(f) => Feed::PerRevolution(f),
                    FeedWord::InverseTime(f) => Feed::InverseTime(f, 1),
                };
                for m in &cycle.motion {
                    if m.dwell > 0.0 {
                        state.stop = true;
                        state.dwell += m.dwell;
                    }
                    let feed = if m.rapid { Feed::Rapid } else { feed };
                    push_block(out, machine, Timing::TipFeed, &m.to, feed, state);
                }
            }
            MotionKind::Spline(spline) => {
                let first = out.len();
                for at in &spline.points {
                    push_block(out, machine, Timing::TipFeed, at, Feed::PerMinute(spline.feed), state);
                }
                if out.len() > first {
                    out.splines.push(SplineRun {
                        first,
                        curve: spline.curve.clone(),
                        poses: spline.poses.clone(),
                        params: spline.params.clone(),
                    });
                }
            }
            other => state.item(other),
        }
    }
}

/// The feed of a block as the motion program gives it.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Feed {
    Rapid,
    /// mm/min.
    PerMinute(f64),
    /// mm/rev.
    PerRevolution(f64),
    /// 1/min, for a block written as this many positions.
    InverseTime(f64, usize),
}

/// What the blocks between moves leave for the next block.
#[derive(Debug)]
struct State {
    stop: bool,
    dwell: f64,
    rpm: Option<f64>,
    feed: Option<f64>,
    /// The first position is known: the machine starts there.
    started: bool,
    /// An operation started since the last block: the next block opens it.
    operation: Option<String>,
    /// The arc the next blocks lie on, and its radius.
    arc: (u32, f64),
    /// The next blocks are points within a block of the program (its `via`).
    via: bool,
}

impl State {
    fn item(&mut self, kind: &MotionKind) {
        match kind {
            MotionKind::Operation(name) => self.operation = Some(name.clone()),
            MotionKind::ToolChange(_) | MotionKind::Stop(_) | MotionKind::OptionalStop => self.stop = true,
            MotionKind::SpindleOn { speed, surface_speed, .. } => {
                self.stop = true;
                self.rpm = (!surface_speed).then_some(*speed);
            }
            MotionKind::SpindleOff => {
                self.stop = true;
                self.rpm = None;
            }
            MotionKind::Dwell(seconds) => {
                self.stop = true;
                self.dwell += seconds;
            }
            _ => {}
        }
    }
}

fn push_block(out: &mut Blocks, machine: &Machine, timing: Timing, to: &Position, feed: Feed, state: &mut State) {
    if !state.started {
        // The first position is where the machine starts.
        state.started = true;
        out.push_position(to.axes.as_slice(), &to.pose);
        return;
    }
    let i = out.len();
    let from_tip = out.tips[i];
    let length = (to.pose.tip - from_tip).norm();
    let rapid = feed == Feed::Rapid || matches!(to.kind, StepKind::Retract | StepKind::Reorient);
    let speed = match feed {
        Feed::Rapid => 0.0,
        Feed::PerMinute(f) if f > 0.0 => f / 60.0,
        Feed::PerRevolution(f) if f > 0.0 => match state.rpm {
            Some(rpm) => f * rpm / 60.0,
            None => {
                out.notes.push(Note {
                    step: to.step,
                    span: to.span,
                    text: "feed per revolution without a spindle speed: predicted at the largest feed".into(),
                });
                machine.cnc.feed_max / 60.0
            }
        },
        Feed::InverseTime(f, _) if f > 0.0 => 0.0,
        _ => {
            if state.feed.is_none() {
                out.notes.push(Note {
                    step: to.step,
                    span: to.span,
                    text: "no feed programmed: predicted at the largest feed".into(),
                });
            }
            machine.cnc.feed_max / 60.0
        }
    };
    let mut a = [0.0; postpro_kin::MAX_AXES];
    a[..out.axes].copy_from_slice(out.position(i));
    let (a, b) = (&a[..out.axes], to.axes.as_slice());
    // The time at the axes' own speeds: a rapid's duration, and the floor of every block.
    let at_axis_speed =
        machine.axes.iter().zip(a.iter().zip(b)).map(|(ax, (x, y))| (y - x).abs() / ax.vmax).fold(0.0, f64::max);
    let kind = if rapid {
        BlockKind::Rapid
    } else if length <= 1e-9 {
        BlockKind::Reorientation
    } else {
        BlockKind::Feed
    };
    let nominal = match (kind, feed, timing) {
        (BlockKind::Rapid, ..) => at_axis_speed,
        // The program asks for the block to last 1/F min, wherever the tip goes.
        (_, Feed::InverseTime(f, parts), _) if f > 0.0 => 60.0 / f / parts as f64,
        // The program asks for no particular duration: as fast as the axes go.
        (BlockKind::Reorientation, _, Timing::TipFeed) => at_axis_speed,
        (BlockKind::Feed, _, Timing::TipFeed) => length / speed,
        (_, _, Timing::AxisFeed) => {
            let sum = |rotary: bool| {
                machine
                    .axes
                    .iter()
                    .zip(a.iter().zip(b))
                    .filter(|(ax, _)| (ax.kind == AxisKind::Rotary) == rotary)
                    .map(|(_, (x, y))| (y - x).powi(2))
                    .sum::<f64>()
                    .sqrt()
            };
            let linear = sum(false);
            if linear > 0.0 { linear / speed } else { sum(true).to_degrees() / speed }
        }
    };
    // In inverse time the feed is what the duration gives the tip.
    let speed = match feed {
        Feed::InverseTime(f, _) if f > 0.0 && nominal > 0.0 => length / nominal,
        _ => speed,
    };
    state.feed = Some(speed);
    let previous_rapid = out.kind.last().is_some_and(|k| *k == BlockKind::Rapid);
    out.stop_before.push(state.stop || rapid || previous_rapid);
    out.dwell_before.push(state.dwell);
    out.cl.push(matches!(to.kind, StepKind::Cl | StepKind::Reengage));
    out.written.push(!state.via);
    state.stop = false;
    state.dwell = 0.0;
    let direction = to.pose.tip - from_tip;
    let cos = if length > 1e-9 { (direction / length).dot(&to.pose.axis).abs() } else { 0.0 };
    out.along_axis.push(kind == BlockKind::Feed && cos >= 1f64.to_radians().cos());
    out.arc.push(state.arc.0);
    out.radius.push(state.arc.1);
    out.length.push(length);
    out.feed.push(speed);
    out.nominal.push(nominal);
    out.kind.push(kind);
    out.step.push(to.step);
    out.span.push(to.span);
    // The one place blocks get their operation: an operation opens with its first block.
    if let Some(name) = state.operation.take() {
        out.operations.push(name);
    } else if out.operations.is_empty() {
        out.operations.push(String::new());
    }
    out.operation.push((out.operations.len() - 1) as u32);
    out.push_position(b, &to.pose);
}
