//! Building the motion program: the reader's items in CL order, the solved steps in between.
//!
//! Per mode: `g1` writes every step as a rapid or a feed move with the programmed feed;
//! `inverse-time` gives every feed move F = 1/Δt with Δt = tip length / feed, splitting a block
//! whose F would fall below the controller's minimum; `tcp` drops the points linearization added
//! (the controller interpolates in the part frame) and switches tool-centre-point control on
//! before the first approach; `bspline` queues each run of feed moves at one feed and writes it as
//! one B-spline through its CL points, fitted within the linearization tolerance, or as feed moves
//! through every step when it cannot be. In every mode, a CL arc that is a circle of the program's
//! frame is written as one (`arc`), and the program is framed as a shop runs it (`clearance`): the
//! work offset, each tool's own offsets, retracts to the machine's clearance around tool changes
//! and re-orientations, the rotaries turned alone up there, the approach across then down, and at
//! the end spindle and coolant off, the retract and the rotaries home.

use postpro_cl::{
    CutterComp, Delay, FeedPer, Item, ItemKind, Motion, MoveKind, Span, Spindle, SpindleUnit, TextKind, ToolPath,
};
use postpro_kin::{Joints, Kinematics, Noted, Pose, Solved, Step, StepKind, ToolLength, Unsettled, bspline};
use postpro_machine::model::{AxisKind, Machine};
use postpro_machine::setup::WorkOffset;

use crate::block::{Arc, AxisSet, Block, BlockKind, FeedWord, Linear, Mode, Position, Rapid, Spline, ToolCall};
use crate::frame::WorkFrame;
use crate::tooling::Tooling;
use crate::{MotionError, MotionSink, Program, Summary, Warning};

/// How the program writes what the dialect can and cannot say.
#[derive(Clone, Debug, PartialEq)]
pub struct Options {
    /// How motion is written.
    pub mode: Mode,
    /// The controller's range of F in inverse time (1/min): a block whose F would fall below the
    /// minimum is split into equal parts; above the maximum F is limited, and said so.
    pub inverse_time_range: (f64, f64),
    /// The controller's range of feeds per minute (mm/min); the machine's own `feed_min` and
    /// `feed_max` narrow it. A feed beyond it is limited, and said so.
    pub feed_range: (f64, f64),
    /// How CL arcs are written.
    pub arcs: Arcs,
    /// Canned cycles as the controller's cycles where the hole axis is the spindle's (else as
    /// moves); `false`: always as moves (`--cycles expand`).
    pub cycles: bool,
    /// Frame the program as a shop runs it: retracts to the machine's clearance around tool
    /// changes, re-orientations and the end, the rotary axes turned alone there, the approach
    /// across then down, the work offset. Off only for studies of the motion alone.
    pub clearance: bool,
    /// Write each 3+2 set-up (the rotaries turned at the clearance and standing until the next
    /// re-orientation) in a working plane of this kind, where the machine's rotary axes carry
    /// the part; `None`: in the work offset's frame. The job's frame must then be the part zero
    /// ([`crate::frame::part_zero_frame`]) and no feed move may turn a rotary axis
    /// ([`simultaneous`]).
    pub planes: Option<crate::block::PlaneKind>,
}

/// How CL arcs are written.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Arcs {
    /// As circular interpolation wherever the arc is a circle in a plane of the program's frame.
    Native {
        /// The dialect writes several turns in one block (LinuxCNC `P`, Siemens `TURN`,
        /// Heidenhain `CP IPA`); otherwise a helix is split into one block per turn.
        turns: bool,
        /// The planes it has: every one, or the X–Y plane only.
        all_planes: bool,
    },
    /// Always as straight moves within the tolerance (`--arcs linear`).
    Linear,
}

impl Options {
    /// Options for `mode` with the controller's ranges unbounded (no feed limited, no block split),
    /// arcs as straight moves and no clearance moves: the motion of the CL file alone, for
    /// studies and tests.
    pub fn unbounded(mode: Mode) -> Options {
        Options {
            mode,
            inverse_time_range: (0.0, f64::INFINITY),
            feed_range: (0.0, f64::INFINITY),
            arcs: Arcs::Linear,
            cycles: false,
            clearance: false,
            planes: None,
        }
    }
}

/// What the job adds to the machine: where the program's zero is, which offset holds it, the
/// tools.
#[derive(Clone, Debug, PartialEq)]
pub struct Job {
    /// The frame the axis values are written in.
    pub frame: WorkFrame,
    /// The work offset that holds it.
    pub work_offset: WorkOffset,
    /// The tools and their changes.
    pub tooling: Tooling,
    /// The tool length the kinematics was solved with, per tool of `tooling` (mm): 0 where the
    /// controller applies the length along the spindle.
    pub kinematic_lengths: Vec<f64>,
    /// The controller applies each tool's length (false on a head machine in a joint mode: the
    /// axis values include it).
    pub length_compensation: bool,
}

impl Job {
    /// The job of a program with no set-up of its own, in `mode`: the work frame of the mode, the
    /// work offset `work_offset`, the tools the CL file loads (the tool table's entries over them)
    /// each with the length the machine needs, and the warnings about the tools. An error for a
    /// tool whose length is needed and unknown (see [`crate::tooling::kinematic_lengths`]).
    pub fn new(
        kin: &dyn Kinematics,
        path: &ToolPath,
        mode: Mode,
        table: Option<&postpro_machine::tools::ToolTable>,
        work_offset: WorkOffset,
    ) -> Result<(Job, Vec<Warning>), MotionError> {
        let (tooling, warnings) = crate::tooling::tooling(path, table);
        Ok((Job::with_tooling(kin, tooling, mode, work_offset)?, warnings))
    }

    /// The job of a program whose tools are `tooling` (see [`Job::new`]).
    pub fn with_tooling(
        kin: &dyn Kinematics,
        tooling: Tooling,
        mode: Mode,
        work_offset: WorkOffset,
    ) -> Result<Job, MotionError> {
        let machine = kin.machine();
        let kinematic_lengths = crate::tooling::kinematic_lengths(machine, &tooling, mode).map_err(|tool| {
            let change = tooling.changes.iter().find(|c| c.tool == tool);
            MotionError::ToolLength {
                span: change.map_or_else(Span::default, |c| c.span),
                number: tooling.tools[tool].number,
                machine: machine.name.clone(),
            }
        })?;
        Ok(Job {
            frame: crate::frame::work_frame(kin, mode),
            work_offset,
            tooling,
            kinematic_lengths,
            length_compensation: machine.chain.tool.is_empty() || mode == Mode::Tcp,
        })
    }

    /// Where each tool's stretch of the tool path starts (the CL statement of its change) and
    /// the length it is solved with.
    pub fn stretch_starts(&self) -> impl Iterator<Item = (u32, f64)> + '_ {
        self.tooling.changes.iter().map(|c| (c.span.start, self.kinematic_lengths[c.tool]))
    }

    /// Where each tool's stretch of the tool path starts and the length it is solved with (for
    /// `postpro_kin::solve_with_tools`).
    pub fn lengths(&self) -> Vec<postpro_kin::LengthFrom> {
        let t = &self.tooling;
        t.changes
            .iter()
            .map(|c| postpro_kin::LengthFrom { item: c.item, length: self.kinematic_lengths[c.tool] })
            .collect()
    }
}

/// The motion program of a solved tool path with no set-up of its own and the controller's
/// ranges unbounded: the motion alone, for studies of it (the prediction's tests and benchmarks).
/// The tool path must have been solved with the job's tool lengths (`postpro_kin::solve` gives
/// the machine definition's, which [`Job::new`] takes where the machine needs one).
pub fn study(path: &ToolPath, solved: &Solved, kin: &dyn Kinematics, mode: Mode) -> Result<Program, MotionError> {
    let (job, _) = Job::new(kin, path, mode, None, WorkOffset::default())?;
    collect(path, solved, kin, &Options::unbounded(mode), &job)
}

/// Builds the whole motion program.
pub fn collect(
    path: &ToolPath,
    solved: &Solved,
    kin: &dyn Kinematics,
    options: &Options,
    job: &Job,
) -> Result<Program, MotionError> {
    let mut blocks = Vec::new();
    let summary = build(path, solved, kin, options, job, &mut blocks)?;
    Ok(Program {
        mode: options.mode,
        part: path.info.part_name.clone(),
        work_offset: job.work_offset,
        origin: job.frame.describe(),
        tools: job.tooling.tools.clone(),
        blocks,
        summary,
    })
}

/// Builds the motion program of a solved tool path, handing each block to `sink` as it is made;
/// returns the header's counts and what had to be said.
pub fn build(
    path: &ToolPath,
    solved: &Solved,
    kin: &dyn Kinematics,
    options: &Options,
    job: &Job,
    sink: &mut dyn MotionSink,
) -> Result<Summary, MotionError> {
    let set_ups = crate::survey::Survey::of(kin, &solved.steps).set_ups;
    let mut stage = Stage::new(kin, options, job, unknown_words(path), set_ups, sink);
    let mut k = 0; // next step
    let decisions = &solved.decisions;
    let mut d = 0; // next decision
    for (i, item) in path.items.iter().enumerate() {
        // The steps of a motion item: every step up to its statement.
        let first = k;
        if matches!(item.kind, ItemKind::Move(_) | ItemKind::Arc(_) | ItemKind::Nurbs(_)) {
            while k < solved.steps.len() && solved.steps[k].span.start <= item.span.start {
                k += 1;
            }
        }
        let from = d;
        while d < decisions.len() && decisions[d].step < k {
            d += 1;
        }
        stage.item(i, item, &solved.steps[first..k], &decisions[from..d])?;
    }
    for step in &solved.steps[k..] {
        stage.trailing(step)?;
    }
    stage.finish(solved.inserted, &solved.unsettled)
}

/// The words of a tool path that the reader does not know: written as comments.
pub fn unknown_words(path: &ToolPath) -> std::collections::BTreeSet<String> {
    path.info.uninterpreted.iter().filter(|(_, u)| u.unknown).map(|(w, _)| w.clone()).collect()
}

/// The motion program as a stage of the pipeline: the reader's items in CL order, each with the
/// solved steps up to its statement, in; blocks out to a [`MotionSink`] as they are made. It
/// holds what one item needs (a B-spline run, a canned cycle's holes), not the program.
pub struct Stage<'a> {
    b: Builder<'a>,
    /// Steps taken so far (the index of the next one).
    k: usize,
    /// CL points among them (and re-engagements), and decisions.
    cl_points: usize,
    decisions: usize,
}

impl<'a> Stage<'a> {
    /// A stage writing for `kin` (the machine with its definition's tool length) with `options`
    /// for `job`; `unknown` are the words the reader does not know (written as comments),
    /// `set_ups` which steps stand in a 3+2 set-up.
    pub fn new(
        kin: &'a dyn Kinematics,
        options: &'a Options,
        job: &'a Job,
        unknown: std::collections::BTreeSet<String>,
        set_ups: crate::survey::SetUps,
        sink: &'a mut dyn MotionSink,
    ) -> Stage<'a> {
        let mut b = Builder::new(kin, options, job, set_ups, sink);
        b.unknown = unknown;
        Stage { b, k: 0, cl_points: 0, decisions: 0 }
    }

    /// The answers the program took from guessed set-ups ([`SetUps::guessed`]), `(step,
    /// answer)`: none from surveyed ones.
    ///
    /// [`SetUps::guessed`]: crate::SetUps::guessed
    pub fn guessed_answers(&self) -> &[(usize, bool)] {
        &self.b.guessed
    }

    /// Item `index` of the tool path, with `steps` (every step up to its statement not given
    /// before, numbered from the steps given so far) and `decisions` (those about these steps).
    pub fn item(&mut self, index: usize, item: &Item, steps: &[Step], decisions: &[Noted]) -> Result<(), MotionError> {
        let b = &mut self.b;
        let first = self.k;
        self.k += steps.len();
        self.cl_points += steps.iter().filter(|s| matches!(s.kind, StepKind::Cl | StepKind::Reengage)).count();
        self.decisions += decisions.len();
        let hole = matches!(&item.kind, ItemKind::Move(m) if m.kind == MoveKind::Hole);
        // A cycle's holes end at anything but another hole (or a comment).
        if !hole && !matches!(item.kind, ItemKind::Comment(_) | ItemKind::Record(_)) {
            b.flush_cycle()?;
        }
        if let Some(change) = b.job.tooling.change_at(index) {
            b.tool_change(item.span, change.tool)?;
        }
        if let ItemKind::CycleOn(c) = &item.kind {
            return b.cycle_on(item.span, c);
        }
        let (motion, arc) = match &item.kind {
            ItemKind::Move(m) => (m.motion, None),
            ItemKind::Arc(a) => (a.motion, Some(a.as_ref())),
            ItemKind::Nurbs(n) => (n.motion, None),
            ItemKind::ToolChange(_) => return Ok(()),
            _ => {
                b.item(item.span, &item.kind);
                return Ok(());
            }
        };
        if let Some(arc) = arc
            && b.arc(arc, item.span, first, steps, motion, decisions)?.is_some()
        {
            return Ok(());
        }
        let mut d = 0; // next decision
        for (j, step) in steps.iter().enumerate() {
            while d < decisions.len() && decisions[d].step == first + j {
                b.decision(&decisions[d]);
                d += 1;
            }
            if hole && b.hole(first + j, step, motion) {
                continue;
            }
            b.step(first + j, step, motion, hole)?;
        }
        Ok(())
    }

    /// A step after the last item (written as a rapid).
    pub fn trailing(&mut self, step: &Step) -> Result<(), MotionError> {
        self.b.flush_cycle()?;
        let k = self.k;
        self.k += 1;
        self.cl_points += usize::from(matches!(step.kind, StepKind::Cl | StepKind::Reengage));
        self.b.step(k, step, Motion::Rapid, false)
    }

    /// The end of the program (spindle and coolant off, retract, rotaries home): the header's
    /// counts, with `linearized` the points linearization added, and what had to be said, the
    /// segments linearization left out of tolerance (`unsettled`) among it.
    pub fn finish(mut self, linearized: usize, unsettled: &Unsettled) -> Result<Summary, MotionError> {
        self.b.flush_cycle()?;
        self.b.finish();
        let mut warnings = std::mem::take(&mut self.b.warnings);
        if let Some(w) = unsettled_warning(unsettled, self.b.options.mode) {
            let at = warnings.partition_point(|v| v.span.start <= w.span.start);
            warnings.insert(at, w);
        }
        Ok(Summary { cl_points: self.cl_points, linearized_points: linearized, decisions: self.decisions, warnings })
    }
}

/// The warning about the feed moves linearization left out of tolerance, at the first; none in
/// TCP mode, where the controller keeps the tip on the path and its points are not written.
fn unsettled_warning(unsettled: &Unsettled, mode: Mode) -> Option<Warning> {
    let span = unsettled.first?;
    if mode == Mode::Tcp {
        return None;
    }
    let (segments, worst, tolerance) = (unsettled.segments, unsettled.worst_shown(), unsettled.tolerance);
    Some(Warning {
        span,
        message: format!(
            "{segments} feed move(s), the first here, stray up to {worst} from the programmed path \
             as the controller interpolates the axes, over the linearization tolerance of {tolerance} mm: \
             linearization could not bring them within it (at most 4096 points a move, or a point between \
             has no solution); check the machine definition and the tool's length, or write the program in \
             TCP mode (--mode tcp), or raise the tolerance (--tolerance)"
        ),
    })
}

/// A feed move queued in a B-spline run.
struct Queued {
    step: Step,
    index: usize,
    /// mm/min.
    feed: f64,
    /// A point added by linearization: not fitted, written only when the run is written as G1.
    linearized: bool,
}

/// An IKT decision's comment held while linearization points carried from the run before wait
/// for their CL point: it goes before that point (or before the spline it starts).
struct Held {
    /// The run position of the block it goes before.
    at: usize,
    text: String,
    span: Span,
}

pub(crate) struct Builder<'a> {
    /// The machine's kinematics (with its definition's tool length).
    pub(crate) base: &'a dyn Kinematics,
    /// The kinematics of the tool in the spindle.
    pub(crate) kin: ToolLength<'a>,
    pub(crate) machine: &'a Machine,
    pub(crate) options: &'a Options,
    pub(crate) job: &'a Job,
    sink: &'a mut dyn MotionSink,
    pub(crate) last_tip: Option<nalgebra::Point3<f64>>,
    /// Where the machine is (the kinematics' values); `None` where it is not known (at the start,
    /// after a tool change: the linear axes at the tool change position).
    pub(crate) current: Option<Joints>,
    /// The spindle axis is at the clearance (after a retract or a tool change).
    pub(crate) at_clearance: bool,
    pub(crate) tcp_on: bool,
    /// The tool in the spindle (an index into the job's tools).
    pub(crate) tool: Option<usize>,
    work_offset_written: bool,
    pub(crate) spindle_rpm: Option<f64>,
    spindle_on: bool,
    coolant_on: bool,
    spindle_seen: bool,
    coolant_seen: bool,
    /// The canned cycle in force, waiting for its holes.
    pub(crate) cycle: Option<crate::cycle::PendingCycle>,
    /// The first feed move, for the warnings about what the CL file never says.
    first_feed: Option<Span>,
    /// Spindle speeds limited to the machine's largest, each said once.
    limited_spindle: Vec<f64>,
    /// Feeds limited to the machine's range, each said once.
    limited: Vec<f64>,
    /// Bspline mode: the feed moves waiting to be fitted, linearization points included.
    run: Vec<Queued>,
    /// The position before the run: the last step written or queued that is not a
    /// linearization point.
    run_start: Option<(Step, usize)>,
    /// The last step written or queued, linearization points aside.
    pub(crate) last_step: Option<(Step, usize)>,
    /// Decisions held for the run.
    held: Vec<Held>,
    /// Words the reader does not know: carried as comments.
    unknown: std::collections::BTreeSet<String>,
    /// The span of the item being written (for blocks that have no step of their own).
    pub(crate) span: Span,
    /// TCP mode: the linearization points since the last position written.
    via: Vec<Position>,
    pub(crate) warnings: Vec<Warning>,
    /// Which steps stand in a 3+2 set-up.
    pub(crate) set_ups: crate::survey::SetUps,
    /// The answers taken from guessed set-ups, `(step, answer)`.
    pub(crate) guessed: Vec<(usize, bool)>,
    /// The working plane in force.
    pub(crate) plane: Option<crate::block::PlaneKind>,
    /// Per axis, its brake: locked, unlocked, or not known (at the start: unlocked before the axis
    /// first turns).
    pub(crate) locked: Vec<Option<bool>>,
}

impl<'a> Builder<'a> {
    fn new(
        kin: &'a dyn Kinematics,
        options: &'a Options,
        job: &'a Job,
        set_ups: crate::survey::SetUps,
        sink: &'a mut dyn MotionSink,
    ) -> Self {
        Builder {
            base: kin,
            kin: ToolLength::new(kin, kin.machine().chain.tool_length),
            machine: kin.machine(),
            options,
            job,
            sink,
            last_tip: None,
            current: None,
            at_clearance: false,
            tcp_on: false,
            tool: None,
            work_offset_written: false,
            spindle_rpm: None,
            spindle_on: false,
            coolant_on: false,
            spindle_seen: false,
            coolant_seen: false,
            first_feed: None,
            cycle: None,
            limited: Vec::new(),
            limited_spindle: Vec::new(),
            run: Vec::new(),
            run_start: None,
            last_step: None,
            held: Vec::new(),
            unknown: std::collections::BTreeSet::new(),
            span: Span::default(),
            via: Vec::new(),
            warnings: Vec::new(),
            set_ups,
            guessed: Vec::new(),
            plane: None,
            locked: vec![None; kin.machine().axes.len()],
        }
    }

    pub(crate) fn push(&mut self, span: Span, kind: BlockKind) {
        self.sink.block(Block { span, kind });
    }

    pub(crate) fn warn(&mut self, span: Span, message: impl Into<String>) {
        self.warnings.push(Warning { span, message: message.into() });
    }

    /// The position of solved step `index`, in the program's frame.
    pub(crate) fn position(&self, step: &Step, index: usize) -> Position {
        Position {
            axes: self.job.frame.apply(&step.joints),
            pose: step.pose,
            step: index,
            kind: step.kind,
            span: step.span,
        }
    }

    /// A position postpro adds: the kinematics' values `joints`, the pose they give.
    pub(crate) fn added(&self, joints: Joints, step: usize, kind: StepKind) -> Position {
        Position { axes: self.job.frame.apply(&joints), pose: self.kin.forward(&joints), step, kind, span: self.span }
    }

    /// Tool-centre-point control on before the first motion in TCP mode (where no approach at the
    /// clearance switched it on).
    pub(crate) fn ensure_tcp(&mut self, span: Span) {
        if self.options.mode == Mode::Tcp && !self.tcp_on {
            self.tcp_on = true;
            let length_register = self.tool.map_or(0, |t| self.job.tooling.tools[t].length_register);
            self.push(span, BlockKind::TcpOn { length_register });
        }
    }

    /// The step a position postpro adds between steps is annotated with: the last one written.
    pub(crate) fn next_step(&self) -> usize {
        self.last_step.map_or(0, |(_, i)| i)
    }

    /// The work offset, before the first motion.
    pub(crate) fn work_offset_once(&mut self, span: Span) {
        if !self.work_offset_written {
            self.work_offset_written = true;
            self.push(span, BlockKind::WorkOffset(self.job.work_offset));
        }
    }

    fn decision(&mut self, noted: &Noted) {
        self.flush_run(true);
        let text = format!("postpro: {}", noted.decision);
        if self.run.is_empty() {
            self.push(noted.span, BlockKind::Comment(text));
        } else {
            // Linearization points wait for their CL point: the comment goes before it.
            self.held.push(Held { at: self.run.len(), text, span: noted.span });
        }
    }

    fn tool_change(&mut self, span: Span, tool: usize) -> Result<(), MotionError> {
        self.flush_run(false);
        self.span = span;
        self.frame_off(span);
        if self.options.clearance {
            self.retract_to_clearance(span);
        }
        let t = &self.job.tooling.tools[tool];
        let length = self.job.kinematic_lengths.get(tool).copied().unwrap_or(self.machine.chain.tool_length);
        let call = ToolCall {
            number: t.number,
            name: t.name.clone(),
            radius_register: t.radius_register,
            // Where the axis values include the length, the one they include.
            length: if self.job.length_compensation { t.length } else { Some(length) },
            diameter: t.diameter,
            corner_radius: t.corner_radius,
            length_register: t.length_register,
            length_compensation: self.job.length_compensation,
        };
        self.push(span, BlockKind::ToolChange(call));
        self.tool = Some(tool);
        self.kin = ToolLength::new(self.base, length);
        // The spindle is at the tool change position: up, somewhere.
        self.current = None;
        self.at_clearance = true;
        self.last_tip = None;
        Ok(())
    }

    /// A spindle speed (rpm) within the machine's largest, said once per speed where it is not:
    /// the controller would run it at that, and the feeds made for the speed asked would load each
    /// tooth more.
    fn spindle_speed(&mut self, rpm: f64, span: Span) -> f64 {
        let Some(max) = self.machine.cnc.spindle_max.filter(|max| rpm > *max) else { return rpm };
        if !self.limited_spindle.contains(&rpm) {
            self.limited_spindle.push(rpm);
            self.warn(
                span,
                format!(
                    "spindle speed {} rpm limited to {} rpm, the machine's largest: at the programmed feeds each \
                     tooth cuts {:.1} times the chip the CAM system planned; choose a tool and speeds for this machine",
                    crate::number(rpm),
                    crate::number(max),
                    rpm / max
                ),
            );
        }
        max
    }

    /// The feed word of a programmed feed (per minute: within the controller's and the
    /// machine's range, said once per value where it is not).
    pub(crate) fn feed_word(&mut self, feed: postpro_cl::Feed, span: Span) -> (FeedWord, Option<String>) {
        match feed.per {
            FeedPer::Revolution => (FeedWord::PerRevolution(feed.value), None),
            FeedPer::Minute => {
                let cnc = &self.machine.cnc;
                let (lo, hi) = self.options.feed_range;
                let (lo, hi) = (lo.max(cnc.feed_min), hi.min(cnc.feed_max));
                let limited = feed.value.clamp(lo, hi);
                if limited == feed.value {
                    return (FeedWord::PerMinute(limited), None);
                }
                let text = format!(
                    "feed {} mm/min limited to {} mm/min (the machine's range {}…{} mm/min)",
                    crate::number(feed.value),
                    crate::number(limited),
                    crate::number(lo),
                    crate::number(hi)
                );
                if !self.limited.contains(&feed.value) {
                    self.limited.push(feed.value);
                    self.warn(span, text.clone());
                }
                (FeedWord::PerMinute(limited), Some(text))
            }
        }
    }

    fn step(&mut self, k: usize, step: &Step, motion: Motion, hole: bool) -> Result<(), MotionError> {
        self.span = step.span;
        let rapid =
            step.rapid || matches!(step.kind, StepKind::Retract | StepKind::Reorient) || motion == Motion::Rapid;
        let feed = match motion {
            Motion::Feed(f) => Some(f),
            // Hole positions of a canned cycle are reached at rapid.
            Motion::Unset if hole => None,
            Motion::Unset if !rapid => {
                return match self.machine.policy.missing_feed {
                    postpro_machine::model::MissingFeed::Error => Err(MotionError::NoFeed { span: step.span }),
                    postpro_machine::model::MissingFeed::Rapid => {
                        self.warn(step.span, "a feed move with no feed programmed before it: written as a rapid (the machine's policy `missing_feed: rapid`)");
                        self.rapid(k, step);
                        Ok(())
                    }
                };
            }
            Motion::Unset | Motion::Rapid => None,
        };
        if rapid || feed.is_none() {
            self.flush_run(false);
            self.last_step = Some((*step, k));
            self.rapid(k, step);
            return Ok(());
        }
        let Some(feed) = feed else { return Ok(()) };
        if self.current.is_none() && self.options.clearance {
            // A feed move with no position to start from (the first move after a tool change):
            // approached at the clearance above it, then fed down to it.
            self.flush_run(false);
            self.warn(
                step.span,
                "a feed move with no position before it (after a tool change): the tool is brought above it at the \
                 clearance and fed down to it",
            );
            self.reposition(k, step, true);
        }
        self.first_feed.get_or_insert(step.span);
        self.ensure_tcp(step.span);
        self.release(step.span, &step.joints);
        if self.options.mode == Mode::Bspline && feed.per == FeedPer::Minute {
            // The spline goes through the CL points (it is checked against the tolerance
            // itself); the linearization points are queued for a run written as G1.
            let linearized = step.kind == StepKind::Linearized;
            // A point at another feed ends the run; the linearization points queued for it (at
            // its feed) go on into the next.
            if !linearized && self.run.iter().rev().find(|q| !q.linearized).is_some_and(|q| q.feed != feed.value) {
                self.flush_run(true);
            }
            if self.run.is_empty() {
                self.run_start = self.last_step;
            }
            self.run.push(Queued { step: *step, index: k, feed: feed.value, linearized });
            if !linearized {
                self.last_step = Some((*step, k));
            }
            self.current = Some(step.joints);
            return Ok(());
        }
        self.flush_run(false);
        self.last_step = Some((*step, k));
        // In TCP mode the controller interpolates in the part frame: no linearization points
        // (the prediction still follows them).
        if self.options.mode == Mode::Tcp && step.kind == StepKind::Linearized {
            let at = self.position(step, k);
            self.via.push(at);
            self.current = Some(step.joints);
            return Ok(());
        }
        let tip = step.pose.tip;
        let length = self.last_tip.map_or(0.0, |t| (tip - t).norm());
        self.last_tip = Some(tip);
        let previous = self.current.replace(step.joints).unwrap_or(step.joints);
        self.at_clearance = false;
        match (self.options.mode, feed.per) {
            (Mode::InverseTime, FeedPer::Minute) if feed.value > 0.0 => {
                let (lo, hi) = self.options.inverse_time_range;
                // Δt = L / feed; F = 1/Δt. Too long a block is split so that F ≥ the minimum.
                let f_inverse = if length > 0.0 { feed.value / length } else { hi };
                let pieces = if f_inverse < lo { (lo / f_inverse).ceil().min(1e6) as usize } else { 1 };
                let (f_piece, note) = if f_inverse * pieces as f64 > hi {
                    (hi, Some(format!("F limited to {} (block of {length:.4} mm)", crate::number(hi))))
                } else {
                    (f_inverse * pieces as f64, None)
                };
                for p in 1..=pieces {
                    let to = if pieces == 1 {
                        self.position(step, k)
                    } else {
                        let joints = previous.lerp(&step.joints, p as f64 / pieces as f64);
                        let mut at = self.added(joints, k, step.kind);
                        if p == pieces {
                            at.pose = step.pose;
                        }
                        at
                    };
                    let linear =
                        Linear { to, feed: FeedWord::InverseTime(f_piece), note: note.clone(), via: Vec::new() };
                    self.push(step.span, BlockKind::Linear(linear));
                }
            }
            _ => {
                let (word, note) = self.feed_word(feed, step.span);
                let via = std::mem::take(&mut self.via);
                let linear = Linear { to: self.position(step, k), feed: word, note, via };
                self.push(step.span, BlockKind::Linear(linear));
            }
        }
        Ok(())
    }

    /// A rapid to solved step `k`: straight, unless it turns a rotary axis or the position is
    /// not known: then by the clearance.
    fn rapid(&mut self, k: usize, step: &Step) {
        self.via.clear();
        let turns = match &self.current {
            None => true,
            Some(current) => !crate::arc::same_rotaries(self.base, current, &step.joints),
        };
        if turns && self.options.clearance {
            self.reposition(k, step, false);
            return;
        }
        self.ensure_tcp(step.span);
        self.release(step.span, &step.joints);
        let to = self.position(step, k);
        self.last_tip = Some(step.pose.tip);
        self.current = Some(step.joints);
        self.at_clearance = false;
        self.push(step.span, BlockKind::Rapid(Rapid { to, axes: AxisSet::ALL }));
    }

    /// A CL arc whose steps are `steps` (from step `first`), written as one circular block when
    /// it is a circle of the program's frame; returns the number of `decisions` written for it,
    /// or `None` when it is to be written step by step.
    fn arc(
        &mut self,
        arc: &postpro_cl::Arc,
        span: Span,
        first: usize,
        steps: &[Step],
        motion: Motion,
        decisions: &[Noted],
    ) -> Result<Option<usize>, MotionError> {
        let crate::build::Arcs::Native { turns: many_turns, all_planes } = self.options.arcs else { return Ok(None) };
        let Motion::Feed(feed) = motion else { return Ok(None) };
        let (Some(current), Some(last)) = (self.current, steps.last()) else { return Ok(None) };
        let own = |s: &Step| s.span == span && matches!(s.kind, StepKind::Cl | StepKind::Linearized);
        let tcp = self.options.mode == Mode::Tcp;
        if self.plane == Some(crate::block::PlaneKind::Dynamic) {
            // In the part frame the controller turns: a circle about the tilted tool axis is no
            // circle of its planes.
            return Ok(None);
        }
        let steady = steps.iter().all(|s| crate::arc::same_rotaries(self.base, &current, &s.joints));
        if !steps.iter().all(own) || !steady || (tcp && !axis_steady(arc, steps)) {
            return Ok(None);
        }
        let Some(geometry) = crate::arc::geometry(arc, &self.kin, &self.job.frame, &current, tcp) else {
            return Ok(None);
        };
        if !all_planes && geometry.plane != crate::block::Plane::Xy {
            return Ok(None);
        }
        self.flush_run(false);
        self.ensure_tcp(span);
        // Decisions of its steps (a hold of the free axis at its start) go before it.
        let mut written = 0;
        while written < decisions.len() && decisions[written].step < first + steps.len() {
            let text = format!("postpro: {}", decisions[written].decision);
            self.push(decisions[written].span, BlockKind::Comment(text));
            written += 1;
        }
        self.first_feed.get_or_insert(span);
        self.at_clearance = false;
        let index = first + steps.len() - 1;
        // A helix of several turns, where the dialect writes one turn per block: split at every
        // full turn; each step on the way goes with the piece it lies on (by its share of the
        // path).
        let pieces = if many_turns || geometry.turns == 0 { 1 } else { geometry.turns as usize + 1 };
        let full = std::f64::consts::TAU;
        let length = arc.length();
        let mut travelled = 0.0;
        let mut previous_tip = arc.start;
        let share: Vec<f64> = steps
            .iter()
            .map(|s| {
                travelled += (s.pose.tip - previous_tip).norm();
                previous_tip = s.pose.tip;
                travelled
            })
            .collect();
        let total = travelled.max(f64::MIN_POSITIVE);
        let mut from = 0;
        for p in 1..=pieces {
            let last_piece = p == pieces;
            let sweep = if last_piece { arc.sweep - full * (pieces - 1) as f64 } else { full };
            let end_share = if last_piece { f64::INFINITY } else { full * p as f64 / arc.sweep };
            let upto = from + share[from..].partition_point(|&l| l / total < end_share - 1e-9);
            let to = if last_piece {
                self.position(last, index)
            } else {
                let tip = arc.point_at(end_share);
                let joints = self.kin.place(&Pose { tip, axis: last.pose.axis }, &current);
                self.added(joints, first + upto.saturating_sub(1).max(from), StepKind::Cl)
            };
            let via_end = if last_piece { steps.len() - 1 } else { upto };
            let via: Vec<Position> = (from..via_end.max(from)).map(|j| self.position(&steps[j], first + j)).collect();
            from = upto.max(from);
            let piece_length = length * sweep / arc.sweep;
            let (feed_word, note) = match (self.options.mode, feed.per) {
                (Mode::InverseTime, FeedPer::Minute) if feed.value > 0.0 && piece_length > 0.0 => {
                    let (lo, hi) = self.options.inverse_time_range;
                    (FeedWord::InverseTime((feed.value / piece_length).clamp(lo, hi)), None)
                }
                _ => self.feed_word(feed, span),
            };
            let block = Arc {
                to,
                plane: geometry.plane,
                center: geometry.center,
                clockwise: geometry.clockwise,
                turns: if pieces == 1 { geometry.turns } else { 0 },
                sweep,
                radius: geometry.radius,
                feed: feed_word,
                note,
                via,
            };
            self.push(span, BlockKind::Arc(Box::new(block)));
        }
        self.current = Some(last.joints);
        self.last_tip = Some(last.pose.tip);
        self.last_step = Some((*last, index));
        Ok(Some(written))
    }

    fn item(&mut self, span: Span, kind: &ItemKind) {
        self.span = span;
        if !matches!(kind, ItemKind::Comment(_) | ItemKind::Frame(_) | ItemKind::Multax(_) | ItemKind::ToolShape(_)) {
            self.flush_run(false);
        }
        let block = match kind {
            ItemKind::Spindle(Spindle::On { speed, unit, clockwise }) => {
                let rpm = *unit == SpindleUnit::Rpm;
                let speed = if rpm { self.spindle_speed(*speed, span) } else { *speed };
                self.spindle_rpm = rpm.then_some(speed);
                self.spindle_on = true;
                self.spindle_seen = true;
                BlockKind::SpindleOn { speed, clockwise: *clockwise, surface_speed: *unit == SpindleUnit::SurfaceSpeed }
            }
            ItemKind::Spindle(Spindle::Off) => {
                self.spindle_on = false;
                self.spindle_seen = true;
                BlockKind::SpindleOff
            }
            ItemKind::Coolant(postpro_cl::Coolant::Off) => {
                self.coolant_on = false;
                self.coolant_seen = true;
                BlockKind::CoolantOff
            }
            ItemKind::Coolant(c) => {
                self.coolant_on = true;
                self.coolant_seen = true;
                BlockKind::CoolantOn(*c)
            }
            ItemKind::CutterComp(c) => {
                let side = match c {
                    CutterComp::Left => "LEFT",
                    CutterComp::Right => "RIGHT",
                    CutterComp::On => "ON",
                    CutterComp::Off => "OFF",
                };
                BlockKind::Comment(format!("CUTCOM/{side}: the CL points are tool-centre points; not applied"))
            }
            ItemKind::CycleOn(_) | ItemKind::CycleOff => return,
            ItemKind::Delay(d) => {
                let seconds = match *d {
                    Delay::Seconds(s) => Some(s),
                    Delay::Revolutions(r) => self.spindle_rpm.filter(|rpm| *rpm > 0.0).map(|rpm| r * 60.0 / rpm),
                };
                match seconds {
                    Some(s) => BlockKind::Dwell(s),
                    None => {
                        self.warn(span, "a dwell in spindle revolutions with no spindle speed: not written");
                        BlockKind::Comment("DELAY in revolutions without a spindle speed: not written".into())
                    }
                }
            }
            ItemKind::Stop(text) => BlockKind::Stop(text.clone()),
            ItemKind::OptionalStop => BlockKind::OptionalStop,
            ItemKind::Text(TextKind::Insert, text) => BlockKind::Insert(text.clone()),
            ItemKind::Text(TextKind::Partno, _) => return,
            ItemKind::Text(_, text) => BlockKind::Comment(text.clone()),
            ItemKind::OperationStart(name) => BlockKind::Operation(name.clone()),
            // Unknown words go to the program as comments; known passive ones (PAINT) do not.
            ItemKind::Record(r) if self.unknown.contains(&r.word) => {
                let args = if r.args.is_empty() { String::new() } else { format!("/{}", r.args) };
                BlockKind::Comment(format!("CL {}{args}: unknown word, not interpreted", r.word))
            }
            ItemKind::ToolShape(_)
            | ItemKind::Record(_)
            | ItemKind::ToolChange(_)
            | ItemKind::ToolSelect(_)
            | ItemKind::Move(_)
            | ItemKind::Arc(_)
            | ItemKind::Nurbs(_)
            | ItemKind::Comment(_)
            | ItemKind::OperationEnd
            | ItemKind::Frame(_)
            | ItemKind::Multax(_)
            | ItemKind::End
            | ItemKind::Fini => return,
        };
        self.push(span, block);
    }

    /// Writes the queued run as a B-spline through its points that are not linearization
    /// points, or as feed moves through all of them when it is too short or the spline cannot
    /// follow it within the tolerance.
    ///
    /// With `carry`, the linearization points after the run's last CL point (those of a point
    /// still to come, which starts the next run) stay queued, with the decisions held for them,
    /// for the next run.
    fn flush_run(&mut self, carry: bool) {
        let mut run = std::mem::take(&mut self.run);
        let mut held = std::mem::take(&mut self.held);
        let start = self.run_start.take();
        // The run up to its last point that is not a linearization point.
        let split = run.iter().rposition(|q| !q.linearized).map_or(0, |i| i + 1);
        if carry && split < run.len() {
            self.run = run.split_off(split);
            self.run_start = if split > 0 { Some((run[split - 1].step, run[split - 1].index)) } else { start };
            let from = held.partition_point(|h| h.at < split);
            self.held = held.split_off(from).into_iter().map(|h| Held { at: h.at - split, ..h }).collect();
        }
        if run.is_empty() && held.is_empty() {
            return;
        }
        self.at_clearance = false;
        let points: Vec<&Queued> = run.iter().filter(|q| !q.linearized).collect();
        let fitted = start.filter(|_| !points.is_empty()).and_then(|(start, _)| {
            let joints: Vec<Joints> =
                std::iter::once(start.joints).chain(points.iter().map(|q| q.step.joints)).collect();
            let poses: Vec<Pose> = std::iter::once(start.pose).chain(points.iter().map(|q| q.step.pose)).collect();
            let policy = &self.machine.policy;
            bspline::fit_indexed(
                &self.kin,
                &bspline::Run { joints: &joints, poses: &poses },
                policy.linearization_tolerance,
                policy.singular_cone,
            )
        });
        let mut next_held = 0;
        let mut g1_from = 0;
        if let Some(bspline::Fit { spline: mut curve, poses, params, index }) = fitted {
            // Decisions are held only while carried points wait for their CL point, which
            // this spline reaches: they go before it.
            for h in &held {
                self.push(h.span, BlockKind::Comment(h.text.clone()));
            }
            next_held = held.len();
            // A point of rank r (r CL points of the run before it) ends the span that begins
            // with the control point after that of the point before it; a linearization point
            // goes with the CL point it leads to.
            let mut rank = 0;
            let steps = run[..split]
                .iter()
                .map(|q| {
                    let control = index[rank] + 1;
                    rank += usize::from(!q.linearized);
                    (q.index, control)
                })
                .collect();
            let last = points[points.len() - 1];
            // Data point d (after the start) belongs to the first CL point r with index[r] ≥ d.
            let mut r = 1;
            let data = (1..poses.len())
                .map(|d| {
                    while r + 1 < index.len() && index[r] < d {
                        r += 1;
                    }
                    let q = points[r - 1];
                    if index[r] == d {
                        self.position(&q.step, q.index)
                    } else {
                        let joints = curve.at(params[d]);
                        Position {
                            axes: self.job.frame.apply(&joints),
                            pose: poses[d],
                            step: q.index,
                            kind: StepKind::Linearized,
                            span: q.step.span,
                        }
                    }
                })
                .collect();
            // The curve in the program's frame (a B-spline is affine-invariant).
            for c in &mut curve.control {
                *c = self.job.frame.apply(c);
            }
            let spline = Spline { feed: last.feed, curve, poses, params, points: data, steps };
            let span = run[0].step.span;
            self.push(span, BlockKind::Spline(Box::new(spline)));
            self.last_tip = Some(last.step.pose.tip);
            // Linearization points after the last CL point (a run ended without it): G1.
            g1_from = split;
        }
        for (p, q) in run.iter().enumerate().skip(g1_from) {
            while let Some(h) = held.get(next_held).filter(|h| h.at <= p) {
                self.push(h.span, BlockKind::Comment(h.text.clone()));
                next_held += 1;
            }
            let (feed, note) = self.feed_word(postpro_cl::Feed { value: q.feed, per: FeedPer::Minute }, q.step.span);
            let linear = Linear { to: self.position(&q.step, q.index), feed, note, via: Vec::new() };
            self.push(q.step.span, BlockKind::Linear(linear));
            self.last_tip = Some(q.step.pose.tip);
        }
        for h in &held[next_held..] {
            self.push(h.span, BlockKind::Comment(h.text.clone()));
        }
    }

    fn finish(&mut self) {
        self.flush_run(false);
        let span = self.span;
        self.frame_off(span);
        if self.spindle_on {
            self.push(span, BlockKind::SpindleOff);
        }
        if self.coolant_on {
            self.push(span, BlockKind::CoolantOff);
        }
        if self.options.clearance {
            self.retract_to_clearance(span);
            self.home_rotaries(span);
        }
        let at = self.first_feed.unwrap_or(span);
        if !self.spindle_seen && self.first_feed.is_some() {
            self.warn(at, "the CL file never starts the spindle (no SPINDL): the program writes no spindle speed");
        }
        if !self.coolant_seen && self.first_feed.is_some() {
            self.warn(at, "the CL file says nothing of the coolant (no COOLNT): the program switches none on");
        }
    }
}

/// True when the tool axis is the same at every step of an arc (TCP mode writes one vector).
fn axis_steady(arc: &postpro_cl::Arc, steps: &[Step]) -> bool {
    steps.iter().all(|s| (s.pose.axis.into_inner() - arc.axis.into_inner()).norm() <= 1e-9)
}

/// True when axis `i` of `machine` is rotary.
pub(crate) fn is_rotary(machine: &Machine, i: usize) -> bool {
    machine.axes[i].kind == AxisKind::Rotary
}
