//! Building the motion program: the reader's items in CL order, the solved steps in between.
//!
//! Per mode: `g1` writes every step as a rapid or a feed move with the programmed feed;
//! `inverse-time` gives every feed move F = 1/Δt with Δt = tip length / feed, splitting a block
//! whose F would fall below the controller's minimum; `tcp` drops the points linearization added
//! (the controller interpolates in the part frame) and switches tool-centre-point control on at
//! the first motion; `bspline` queues each run of feed moves at one feed and writes it as one
//! B-spline through its CL points, fitted within the linearization tolerance, or as feed moves
//! through every step when it cannot be.

use postpro_cl::{CutterComp, Delay, FeedPer, ItemKind, Motion, MoveKind, Spindle, SpindleUnit, TextKind, ToolPath};
use postpro_kin::{Joints, Kinematics, Noted, Pose, Solved, Step, StepKind, bspline};
use postpro_machine::model::Machine;

use crate::block::{Block, BlockKind, FeedWord, Linear, Mode, Position, Spline, ToolCall};
use crate::{MotionError, MotionSink, Program, Summary};

/// What the motion program is built for.
#[derive(Clone, Debug, PartialEq)]
pub struct Options {
    /// How motion is written.
    pub mode: Mode,
    /// The controller's range of F in inverse time (1/min): a block whose F would fall below the
    /// minimum is split into equal parts; above the maximum F is limited, and said so.
    pub inverse_time_range: (f64, f64),
    /// The controller's range of feeds per minute (mm/min): a feed beyond it is limited, and
    /// said so.
    pub feed_range: (f64, f64),
}

impl Options {
    /// Options for `mode` with the controller's ranges unbounded: no feed limited, no block
    /// split (for studies of the motion alone, and tests).
    pub fn unbounded(mode: Mode) -> Options {
        Options { mode, inverse_time_range: (0.0, f64::INFINITY), feed_range: (0.0, f64::INFINITY) }
    }
}

/// Builds the whole motion program.
pub fn collect(
    path: &ToolPath,
    solved: &Solved,
    kin: &dyn Kinematics,
    options: &Options,
) -> Result<Program, MotionError> {
    let mut blocks = Vec::new();
    let summary = build(path, solved, kin, options, &mut blocks)?;
    Ok(Program { mode: options.mode, part: path.info.part_name.clone(), blocks, summary })
}

/// Builds the motion program of a solved tool path, handing each block to `sink` as it is made;
/// returns the header's counts.
pub fn build(
    path: &ToolPath,
    solved: &Solved,
    kin: &dyn Kinematics,
    options: &Options,
    sink: &mut dyn MotionSink,
) -> Result<Summary, MotionError> {
    let mut b = Builder::new(kin, options, sink);
    b.unknown = path.info.uninterpreted.iter().filter(|(_, u)| u.unknown).map(|(w, _)| w.clone()).collect();
    let mut k = 0; // next step
    let decisions = &solved.decisions;
    let mut d = 0; // next decision
    for item in &path.items {
        let motion = match &item.kind {
            ItemKind::Move(m) => Some((m.motion, m.kind == MoveKind::Hole)),
            ItemKind::Arc(a) => Some((a.motion, false)),
            ItemKind::Nurbs(n) => Some((n.motion, false)),
            _ => None,
        };
        match motion {
            Some((motion, hole)) => {
                // The steps of this item: every step up to its statement.
                while k < solved.steps.len() && solved.steps[k].span.start <= item.span.start {
                    while d < decisions.len() && decisions[d].step == k {
                        b.decision(&decisions[d]);
                        d += 1;
                    }
                    b.step(k, &solved.steps[k], motion, hole)?;
                    k += 1;
                }
            }
            None => b.item(item.span, &item.kind),
        }
    }
    while k < solved.steps.len() {
        b.step(k, &solved.steps[k], Motion::Rapid, false)?;
        k += 1;
    }
    b.finish();
    Ok(Summary {
        cl_points: solved.steps.iter().filter(|s| matches!(s.kind, StepKind::Cl | StepKind::Reengage)).count(),
        linearized_points: solved.inserted,
        decisions: decisions.len(),
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
    span: postpro_cl::Span,
}

struct Builder<'a> {
    kin: &'a dyn Kinematics,
    machine: &'a Machine,
    options: &'a Options,
    sink: &'a mut dyn MotionSink,
    last_tip: Option<nalgebra::Point3<f64>>,
    previous: Option<Joints>,
    tcp_on: bool,
    spindle_rpm: Option<f64>,
    /// Bspline mode: the feed moves waiting to be fitted, linearization points included.
    run: Vec<Queued>,
    /// The position before the run: the last step written or queued that is not a
    /// linearization point.
    run_start: Option<(Step, usize)>,
    /// The last step written or queued, linearization points aside.
    last_step: Option<(Step, usize)>,
    /// Decisions held for the run.
    held: Vec<Held>,
    /// Words the reader does not know: carried as comments.
    unknown: std::collections::BTreeSet<String>,
    /// The span of the item being written (for blocks that have no step of their own).
    span: postpro_cl::Span,
    /// The tool geometry given since the last tool change, for the next one.
    shape: Option<postpro_cl::ToolShape>,
    /// TCP mode: the linearization points since the last position written.
    via: Vec<Position>,
}

impl<'a> Builder<'a> {
    fn new(kin: &'a dyn Kinematics, options: &'a Options, sink: &'a mut dyn MotionSink) -> Self {
        Builder {
            kin,
            machine: kin.machine(),
            options,
            sink,
            last_tip: None,
            previous: None,
            tcp_on: false,
            spindle_rpm: None,
            run: Vec::new(),
            run_start: None,
            last_step: None,
            held: Vec::new(),
            unknown: std::collections::BTreeSet::new(),
            span: postpro_cl::Span::default(),
            shape: None,
            via: Vec::new(),
        }
    }

    fn push(&mut self, span: postpro_cl::Span, kind: BlockKind) {
        self.sink.block(Block { span, kind });
    }

    fn position(step: &Step, index: usize) -> Position {
        Position { axes: step.joints, pose: step.pose, step: index, kind: step.kind }
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

    fn step(&mut self, k: usize, step: &Step, motion: Motion, hole: bool) -> Result<(), MotionError> {
        self.span = step.span;
        let rapid =
            step.rapid || matches!(step.kind, StepKind::Retract | StepKind::Reorient) || motion == Motion::Rapid;
        if self.options.mode == Mode::Bspline {
            match motion {
                Motion::Feed(f) if f.per == FeedPer::Minute && !rapid => {
                    // The spline goes through the CL points (it is checked against the
                    // tolerance itself); the linearization points are queued for a run written
                    // as G1.
                    let linearized = step.kind == StepKind::Linearized;
                    // A point at another feed ends the run; the linearization points queued for
                    // it (at its feed) go on into the next.
                    if !linearized && self.run.iter().rev().find(|q| !q.linearized).is_some_and(|q| q.feed != f.value) {
                        self.flush_run(true);
                    }
                    if self.run.is_empty() {
                        self.run_start = self.last_step;
                    }
                    self.run.push(Queued { step: *step, index: k, feed: f.value, linearized });
                    if !linearized {
                        self.last_step = Some((*step, k));
                    }
                    return Ok(());
                }
                _ => self.flush_run(false),
            }
        }
        self.last_step = Some((*step, k));
        let tcp = self.options.mode == Mode::Tcp;
        // In TCP mode the controller interpolates in the part frame: no linearization points
        // (the prediction still follows them).
        if tcp && step.kind == StepKind::Linearized {
            self.via.push(Self::position(step, k));
            return Ok(());
        }
        if tcp && !self.tcp_on {
            self.tcp_on = true;
            self.push(step.span, BlockKind::TcpOn);
        }
        let tip = step.pose.tip;
        let length = self.last_tip.map_or(0.0, |t| (tip - t).norm());
        self.last_tip = Some(tip);
        let previous = self.previous.replace(step.joints).unwrap_or(step.joints);
        if rapid {
            self.via.clear();
            self.push(step.span, BlockKind::Rapid(Self::position(step, k)));
            return Ok(());
        }
        let feed = match motion {
            Motion::Feed(f) => f,
            // Hole positions of a canned cycle are written as moves (with the modal feed).
            Motion::Unset if hole => {
                self.push(step.span, BlockKind::Rapid(Self::position(step, k)));
                return Ok(());
            }
            Motion::Unset | Motion::Rapid => return Err(MotionError::NoFeed { span: step.span }),
        };
        match (self.options.mode, feed.per) {
            (Mode::InverseTime, FeedPer::Minute) if feed.value > 0.0 => {
                let (lo, hi) = self.options.inverse_time_range;
                // Δt = L / feed; F = 1/Δt. Too long a block is split so that F ≥ the minimum.
                let f_inverse = if length > 0.0 { feed.value / length } else { hi };
                let pieces = if f_inverse < lo { (lo / f_inverse).ceil().min(1e6) as usize } else { 1 };
                let (f_piece, note) = if f_inverse * pieces as f64 > hi {
                    (hi, Some(format!("F limited to {hi} (block of {length:.4} mm)")))
                } else {
                    (f_inverse * pieces as f64, None)
                };
                for p in 1..=pieces {
                    let to = if pieces == 1 {
                        Self::position(step, k)
                    } else {
                        let axes = previous.lerp(&step.joints, p as f64 / pieces as f64);
                        let pose = if p == pieces { step.pose } else { self.kin.forward(&axes) };
                        Position { axes, pose, step: k, kind: step.kind }
                    };
                    let linear =
                        Linear { to, feed: FeedWord::InverseTime(f_piece), note: note.clone(), via: Vec::new() };
                    self.push(step.span, BlockKind::Linear(linear));
                }
            }
            (_, per) => {
                let (word, note) = match per {
                    FeedPer::Minute => {
                        let (lo, hi) = self.options.feed_range;
                        let limited = feed.value.clamp(lo, hi);
                        // Out of the controller's range: written at the limit, and said so.
                        let note = (limited != feed.value)
                            .then(|| format!("feed {} mm/min out of the controller's range {lo}…{hi}", feed.value));
                        (FeedWord::PerMinute(limited), note)
                    }
                    FeedPer::Revolution => (FeedWord::PerRevolution(feed.value), None),
                };
                let via = std::mem::take(&mut self.via);
                let linear = Linear { to: Self::position(step, k), feed: word, note, via };
                self.push(step.span, BlockKind::Linear(linear));
            }
        }
        Ok(())
    }

    fn item(&mut self, span: postpro_cl::Span, kind: &ItemKind) {
        self.span = span;
        if !matches!(kind, ItemKind::Comment(_) | ItemKind::Frame(_) | ItemKind::Multax(_) | ItemKind::ToolShape(_)) {
            self.flush_run(false);
        }
        let block = match kind {
            ItemKind::ToolChange(t) => {
                if self.tcp_on {
                    self.tcp_on = false;
                    self.push(span, BlockKind::TcpOff);
                }
                let shape = self.shape.take();
                BlockKind::ToolChange(ToolCall {
                    number: t.number,
                    name: t.name.clone(),
                    diameter: shape.map(|s| s.diameter),
                    corner_radius: shape.map(|s| s.corner_radius),
                    length_register: t.adjust.unwrap_or(t.number),
                    length_compensation: self.machine.chain.tool_length == 0.0,
                })
            }
            ItemKind::Spindle(Spindle::On { speed, unit, clockwise }) => {
                self.spindle_rpm = (*unit == SpindleUnit::Rpm).then_some(*speed);
                BlockKind::SpindleOn {
                    speed: *speed,
                    clockwise: *clockwise,
                    surface_speed: *unit == SpindleUnit::SurfaceSpeed,
                }
            }
            ItemKind::Spindle(Spindle::Off) => BlockKind::SpindleOff,
            ItemKind::Coolant(postpro_cl::Coolant::Off) => BlockKind::CoolantOff,
            ItemKind::Coolant(c) => BlockKind::CoolantOn(*c),
            ItemKind::CutterComp(c) => {
                let side = match c {
                    CutterComp::Left => "LEFT",
                    CutterComp::Right => "RIGHT",
                    CutterComp::On => "ON",
                    CutterComp::Off => "OFF",
                };
                BlockKind::Comment(format!("CUTCOM/{side}: the CL points are tool-centre points; not applied"))
            }
            ItemKind::CycleOn(c) => {
                BlockKind::Comment(format!("CYCLE/{} {}: hole positions follow as moves", c.word, c.args))
            }
            ItemKind::CycleOff => BlockKind::Comment("CYCLE/OFF".into()),
            ItemKind::Delay(d) => {
                let seconds = match *d {
                    Delay::Seconds(s) => Some(s),
                    Delay::Revolutions(r) => self.spindle_rpm.filter(|rpm| *rpm > 0.0).map(|rpm| r * 60.0 / rpm),
                };
                match seconds {
                    Some(s) => BlockKind::Dwell(s),
                    None => BlockKind::Comment("DELAY in revolutions without a spindle speed: not written".into()),
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
            ItemKind::ToolShape(shape) => {
                self.shape = Some(*shape);
                return;
            }
            ItemKind::Record(_)
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
        let points: Vec<&Queued> = run.iter().filter(|q| !q.linearized).collect();
        let fitted = start.filter(|_| !points.is_empty()).and_then(|(start, _)| {
            let joints: Vec<Joints> =
                std::iter::once(start.joints).chain(points.iter().map(|q| q.step.joints)).collect();
            let poses: Vec<Pose> = std::iter::once(start.pose).chain(points.iter().map(|q| q.step.pose)).collect();
            let policy = &self.machine.policy;
            bspline::fit_indexed(
                self.kin,
                &bspline::Run { joints: &joints, poses: &poses },
                policy.linearization_tolerance,
                policy.singular_cone,
            )
        });
        let mut next_held = 0;
        let mut g1_from = 0;
        if let Some(bspline::Fit { spline: curve, poses, params, index }) = fitted {
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
                        Self::position(&q.step, q.index)
                    } else {
                        Position {
                            axes: curve.at(params[d]),
                            pose: poses[d],
                            step: q.index,
                            kind: StepKind::Linearized,
                        }
                    }
                })
                .collect();
            let spline = Spline { feed: last.feed, curve, poses, params, points: data, steps };
            let span = run[0].step.span;
            self.push(span, BlockKind::Spline(Box::new(spline)));
            self.last_tip = Some(last.step.pose.tip);
            self.previous = Some(last.step.joints);
            // Linearization points after the last CL point (a run ended without it): G1.
            g1_from = split;
        }
        for (p, q) in run.iter().enumerate().skip(g1_from) {
            while let Some(h) = held.get(next_held).filter(|h| h.at <= p) {
                self.push(h.span, BlockKind::Comment(h.text.clone()));
                next_held += 1;
            }
            let linear = Linear {
                to: Self::position(&q.step, q.index),
                feed: FeedWord::PerMinute(q.feed.clamp(self.options.feed_range.0, self.options.feed_range.1)),
                note: None,
                via: Vec::new(),
            };
            self.push(q.step.span, BlockKind::Linear(linear));
            self.last_tip = Some(q.step.pose.tip);
            self.previous = Some(q.step.joints);
        }
        for h in &held[next_held..] {
            self.push(h.span, BlockKind::Comment(h.text.clone()));
        }
    }

    fn finish(mut self) {
        self.flush_run(false);
        if self.tcp_on {
            let span = self.span;
            self.push(span, BlockKind::TcpOff);
        }
    }
}
