//! The motion the CNC is asked for: one block per solved step, with its programmed feed.
//!
//! A block moves the axes from the previous step's values to its own, linearly in the axis
//! space (that is what G1 and G93 command). Its **nominal duration** is the time the program
//! asks for: in inverse time, TCP and B-spline output the tip length over the feed (`L / V_f`);
//! in G1 output the CNC reads F as the feed of the linear axes in the machine frame (or of the
//! rotary axes in degrees per minute when only they move), so a block that swings the table lasts
//! `|ΔXYZ| / F`, whatever the tip does. Rapids move at the axes' speed (G0). Blocks are stored
//! column-wise: a million of them is a few tens of megabytes.

use nalgebra::Vector3;
use postpro_cl::{FeedPer, ItemKind, Motion, ToolPath};
use postpro_kin::{Solved, StepKind};
use postpro_machine::model::{AxisKind, Machine};

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
    /// What was assumed.
    pub text: String,
}

/// The blocks of a program, column-wise. Block `i` moves from `position(i)` to `position(i + 1)`.
#[derive(Clone, Debug, Default)]
pub struct Blocks {
    /// Number of axes.
    pub axes: usize,
    /// Axis values at the start and after every block (`(len + 1) × axes`; mm, rad).
    pub positions: Vec<f64>,
    /// The tool tip in the part frame at the start and after every block (mm).
    pub tips: Vec<nalgebra::Point3<f64>>,
    /// The tool axis in the part frame at the start and after every block.
    pub tool_axes: Vec<nalgebra::Unit<Vector3<f64>>>,
    /// Tip length of each block (mm).
    pub length: Vec<f64>,
    /// Programmed feed of each block (mm/s); 0 for rapids.
    pub feed: Vec<f64>,
    /// Nominal duration of each block at the programmed feed (s).
    pub nominal: Vec<f64>,
    /// The kind of each block.
    pub kind: Vec<BlockKind>,
    /// True when the CNC stops exactly before the block (rapids, tool changes, stops, dwells).
    pub stop_before: Vec<bool>,
    /// Dwell before the block (s).
    pub dwell_before: Vec<f64>,
    /// Index of the block's end step in [`Solved::steps`].
    pub step: Vec<usize>,
    /// True when the block ends on a CL point (not on a point added by linearization).
    pub cl: Vec<bool>,
    /// True when an item of the CL file stands between this block and the previous one (the
    /// emitter ends a B-spline run there: anything but comments, frames, MULTAX, tool shapes).
    pub run_break: Vec<bool>,
    /// Where an assumption was made (a feed per revolution without a spindle speed, no feed).
    pub notes: Vec<Note>,
    /// True for a feed block that moves the tip along the tool axis (within 1°): a plunge, or a
    /// retract at feed.
    pub along_axis: Vec<bool>,
    /// The operation of each block (index into [`Self::operations`]).
    pub operation: Vec<u32>,
    /// The names of the CL file's operations that have blocks, in order (`OperationStart`
    /// items: NX `TOOL PATH/`, CAMWorks `OPFEATSTART`, …); an empty name for the blocks before
    /// the first one, or of an operation without a name.
    pub operations: Vec<String>,
}

impl Blocks {
    /// Number of blocks.
    pub fn len(&self) -> usize {
        self.length.len()
    }

    /// True when there is no block.
    pub fn is_empty(&self) -> bool {
        self.length.is_empty()
    }

    /// The axis values before block `i` (after block `i - 1`).
    pub fn position(&self, i: usize) -> &[f64] {
        &self.positions[i * self.axes..(i + 1) * self.axes]
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

/// The blocks of a solved tool path, each with the feed of the CL statement it comes from,
/// timed as `timing` says.
pub fn blocks(path: &ToolPath, solved: &Solved, machine: &Machine, timing: Timing) -> Blocks {
    let mut out = Blocks { axes: machine.axes.len(), ..Blocks::default() };
    let Some(first) = solved.steps.first() else { return out };
    out.push_position(first.joints.as_slice(), &first.pose);
    let mut state = State { stop: true, run_break: true, dwell: 0.0, rpm: None, feed: None, operation: None };
    let mut k = 1; // next step; the first one is where the machine starts
    for item in &path.items {
        let motion = match &item.kind {
            ItemKind::Move(m) => m.motion,
            ItemKind::Arc(a) => a.motion,
            ItemKind::Nurbs(n) => n.motion,
            other => {
                state.item(other);
                continue;
            }
        };
        while k < solved.steps.len() && solved.steps[k].span.start <= item.span.start {
            push_block(&mut out, solved, machine, timing, k, motion, &mut state);
            k += 1;
        }
    }
    while k < solved.steps.len() {
        push_block(&mut out, solved, machine, timing, k, Motion::Rapid, &mut state);
        k += 1;
    }
    out
}

/// What the items between moves leave for the next block.
struct State {
    stop: bool,
    run_break: bool,
    dwell: f64,
    rpm: Option<f64>,
    feed: Option<f64>,
    /// An operation started since the last block: the next block opens it.
    operation: Option<String>,
}

impl State {
    fn item(&mut self, kind: &ItemKind) {
        if !matches!(kind, ItemKind::Comment(_) | ItemKind::Frame(_) | ItemKind::Multax(_) | ItemKind::ToolShape(_)) {
            self.run_break = true;
        }
        match kind {
            ItemKind::OperationStart(name) => self.operation = Some(name.clone()),
            ItemKind::ToolChange(_) | ItemKind::Stop(_) | ItemKind::OptionalStop | ItemKind::End => self.stop = true,
            ItemKind::Spindle(s) => {
                self.stop = true;
                self.rpm = match s {
                    postpro_cl::Spindle::On { speed, unit: postpro_cl::SpindleUnit::Rpm, .. } => Some(*speed),
                    _ => None,
                };
            }
            ItemKind::Delay(d) => {
                self.stop = true;
                self.dwell += match d {
                    postpro_cl::Delay::Seconds(s) => *s,
                    postpro_cl::Delay::Revolutions(r) => self.rpm.map_or(0.0, |rpm| r / rpm * 60.0),
                };
            }
            _ => {}
        }
    }
}

fn push_block(
    out: &mut Blocks,
    solved: &Solved,
    machine: &Machine,
    timing: Timing,
    k: usize,
    motion: Motion,
    state: &mut State,
) {
    let step = &solved.steps[k];
    let from = &solved.steps[k - 1];
    let rapid = step.rapid || matches!(step.kind, StepKind::Retract | StepKind::Reorient) || motion == Motion::Rapid;
    let length = (step.pose.tip - from.pose.tip).norm();
    let feed = if rapid {
        0.0
    } else {
        match motion {
            Motion::Feed(f) if f.per == FeedPer::Minute && f.value > 0.0 => f.value / 60.0,
            Motion::Feed(f) if f.per == FeedPer::Revolution && f.value > 0.0 => match state.rpm {
                Some(rpm) => f.value * rpm / 60.0,
                None => {
                    out.notes.push(Note {
                        step: k,
                        text: "feed per revolution without a spindle speed: predicted at the largest feed".into(),
                    });
                    machine.cnc.feed_max / 60.0
                }
            },
            _ => {
                if state.feed.is_none() {
                    out.notes.push(Note { step: k, text: "no feed programmed: predicted at the largest feed".into() });
                }
                machine.cnc.feed_max / 60.0
            }
        }
    };
    state.feed = Some(feed);
    let (a, b) = (from.joints.as_slice(), step.joints.as_slice());
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
    let nominal = match (kind, timing) {
        (BlockKind::Rapid, _) => at_axis_speed,
        // The program asks for no particular duration: as fast as the axes go.
        (BlockKind::Reorientation, Timing::TipFeed) => at_axis_speed,
        (BlockKind::Feed, Timing::TipFeed) => length / feed,
        (_, Timing::AxisFeed) => {
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
            if linear > 0.0 { linear / feed } else { sum(true).to_degrees() / feed }
        }
    };
    let previous_rapid = out.kind.last().is_some_and(|k| *k == BlockKind::Rapid);
    out.stop_before.push(state.stop || rapid || previous_rapid);
    out.dwell_before.push(state.dwell);
    out.cl.push(matches!(step.kind, StepKind::Cl | StepKind::Reengage));
    out.run_break.push(state.run_break);
    state.run_break = false;
    state.stop = false;
    state.dwell = 0.0;
    let direction = step.pose.tip - from.pose.tip;
    let cos = if length > 1e-9 { (direction / length).dot(&step.pose.axis).abs() } else { 0.0 };
    out.along_axis.push(kind == BlockKind::Feed && cos >= 1f64.to_radians().cos());
    out.length.push(length);
    out.feed.push(feed);
    out.nominal.push(nominal);
    out.kind.push(kind);
    out.step.push(k);
    // The one place blocks get their operation: an operation opens with its first block.
    if let Some(name) = state.operation.take() {
        out.operations.push(name);
    } else if out.operations.is_empty() {
        out.operations.push(String::new());
    }
    out.operation.push((out.operations.len() - 1) as u32);
    out.push_position(b, &step.pose);
}
