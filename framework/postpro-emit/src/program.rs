//! The template context: the NC program as data, built from the tool path (the order of the CL
//! file, its tools, spindle, coolant, texts) and the solved positions (axis values, decisions).
//! `docs/templates.md` documents every field; templates see exactly these names.

use postpro_cl::{Coolant, CutterComp, Delay, FeedPer, ItemKind, Motion, Spindle, SpindleUnit, TextKind, ToolPath};
use postpro_kin::{Joints, Kinematics, Noted, Pose, Solved, Step, StepKind};
use postpro_machine::model::{AxisKind, Machine};
use serde::Serialize;

use crate::EmitError;
use crate::dialect::{Dialect, TcpStyle};
use crate::format::push_number;

/// How motion is written.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Mode {
    /// Axis values with `G1` and the programmed feed.
    G1,
    /// Axis values with `G93` and F = 1/Δt on every block.
    InverseTime,
    /// Tool tip and tool vector in the part frame; the controller solves the kinematics.
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
}

/// What the emitter is asked for.
#[derive(Clone, Debug)]
pub struct Options {
    /// Output mode.
    pub mode: Mode,
    /// Program name (from the file name).
    pub program_name: String,
    /// The CL file, as the user named it.
    pub source_name: String,
    /// Number the blocks (`N10`, `N20`, …).
    pub block_numbers: bool,
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
    /// Index into [`Solved::steps`].
    pub step: usize,
    /// The comment text (without the dialect's comment characters).
    pub text: String,
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
    /// The generator and its version.
    pub generator: String,
    /// The axes in output order.
    pub axes: Vec<AxisInfo>,
    /// CL points solved.
    pub cl_points: usize,
    /// Points added by linearization.
    pub linearized_points: usize,
    /// Linearization tolerance (mm).
    pub tolerance: f64,
    /// Decisions of the IKT policy.
    pub decisions: usize,
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
    /// Name, if the CL file gives one.
    pub name: Option<String>,
    /// Diameter (mm), if known.
    pub diameter: Option<f64>,
    /// Corner radius (mm), if known.
    pub corner_radius: Option<f64>,
}

/// One word: an address letter and its value.
#[derive(Clone, Debug, Serialize)]
pub struct Word {
    /// The address (`X`, `A`, `A3`, `TX`).
    pub letter: String,
    /// The value (mm, degrees, or a vector component).
    pub value: f64,
    /// The value as the dialect writes it (`12.346`, `+12.346`).
    pub text: String,
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
        /// Length-offset register.
        offset: u32,
        /// The CNC applies the tool length (`G43 H…`, `D…`): true when the machine definition's
        /// tool length is 0, i.e. the axis values are those of the spindle nose. False when the
        /// axis values already include the tool length: the CNC must not add it again.
        length_compensation: bool,
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
    },
    /// Tool-centre-point control off.
    TcpOff {
        /// Block number, when numbering.
        n: Option<u32>,
    },
}

/// Where the blocks go: a `Vec` for the whole context, or a writer that renders each block as
/// it comes (the program is never held in memory).
pub trait BlockSink {
    /// Takes the next block.
    fn block(&mut self, block: Block) -> Result<(), EmitError>;
}

impl BlockSink for Vec<Block> {
    fn block(&mut self, block: Block) -> Result<(), EmitError> {
        self.push(block);
        Ok(())
    }
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

/// Builds the whole program (the template context).
pub fn build(
    path: &ToolPath,
    solved: &Solved,
    kin: &dyn Kinematics,
    dialect: &Dialect,
    options: &Options,
) -> Result<Program, EmitError> {
    let machine = kin.machine();
    let header = header(path, solved, machine, dialect, options);
    let tools = tools(path);
    let mut blocks = Vec::new();
    build_blocks(path, solved, kin, dialect, options, &mut blocks)?;
    Ok(Program { header, tools, blocks })
}

/// The header of the program.
pub fn header(path: &ToolPath, solved: &Solved, machine: &Machine, dialect: &Dialect, options: &Options) -> Header {
    let cl_points = solved.steps.iter().filter(|s| matches!(s.kind, StepKind::Cl | StepKind::Reengage)).count();
    Header {
        name: options.program_name.clone(),
        part: path.info.part_name.clone(),
        source: options.source_name.clone(),
        machine: machine.name.clone(),
        machine_description: machine.description.clone(),
        dialect: dialect.clone(),
        mode: options.mode,
        generator: format!("postpro {}", env!("CARGO_PKG_VERSION")),
        axes: machine
            .axes
            .iter()
            .map(|a| AxisInfo {
                letter: a.letter.clone(),
                kind: if a.kind == AxisKind::Rotary { "rotary" } else { "linear" },
            })
            .collect(),
        cl_points,
        linearized_points: solved.inserted,
        tolerance: machine.policy.linearization_tolerance,
        decisions: solved.decisions.len(),
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
    }
}

/// The tools of the program in order of first use, with the geometry given before each change.
pub fn tools(path: &ToolPath) -> Vec<Tool> {
    let mut tools: Vec<Tool> = Vec::new();
    let mut shape = None;
    for item in &path.items {
        match &item.kind {
            ItemKind::ToolShape(s) => shape = Some((s.diameter, s.corner_radius)),
            ItemKind::ToolChange(t) => {
                let (diameter, corner_radius) = shape.take().map_or((None, None), |(d, r)| (Some(d), Some(r)));
                if !tools.iter().any(|x| x.number == t.number) {
                    tools.push(Tool { number: t.number, name: t.name.clone(), diameter, corner_radius });
                }
            }
            _ => {}
        }
    }
    tools
}

/// The blocks of the program, in order, handed to `sink`.
pub fn build_blocks(
    path: &ToolPath,
    solved: &Solved,
    kin: &dyn Kinematics,
    dialect: &Dialect,
    options: &Options,
    sink: &mut dyn BlockSink,
) -> Result<(), EmitError> {
    check_mode(dialect, options.mode)?;
    let mut b = Builder::new(kin, dialect, options, sink);
    b.unknown = path.info.uninterpreted.iter().filter(|(_, u)| u.unknown).map(|(w, _)| w.clone()).collect();
    let mut k = 0; // next step
    let decisions = &solved.decisions;
    let mut d = 0; // next decision
    for item in &path.items {
        let motion = match &item.kind {
            ItemKind::Move(m) => Some(m.motion),
            ItemKind::Arc(a) => Some(a.motion),
            ItemKind::Nurbs(n) => Some(n.motion),
            _ => None,
        };
        match motion {
            Some(motion) => {
                // The steps of this item: every step up to its statement.
                while k < solved.steps.len() && solved.steps[k].span.start <= item.span.start {
                    while d < decisions.len() && decisions[d].step == k {
                        b.decision(&decisions[d]);
                        d += 1;
                    }
                    b.step(k, &solved.steps[k], motion)?;
                    k += 1;
                }
            }
            None => b.item(&item.kind),
        }
    }
    while k < solved.steps.len() {
        b.step(k, &solved.steps[k], Motion::Rapid)?;
        k += 1;
    }
    b.finish()
}

struct Builder<'a> {
    kin: &'a dyn Kinematics,
    machine: &'a Machine,
    dialect: &'a Dialect,
    options: &'a Options,
    sink: &'a mut dyn BlockSink,
    /// The first error of the sink (a failed write); later blocks are dropped.
    failed: Option<EmitError>,
    next_n: u32,
    /// The axis texts last written, per axis.
    written: Vec<Option<String>>,
    last_feed: Option<String>,
    feed_mode: &'static str,
    last_tip: Option<nalgebra::Point3<f64>>,
    previous: Option<postpro_kin::Joints>,
    tcp_on: bool,
    spindle_rpm: Option<f64>,
    clamped: usize,
    /// BSPLINE mode: the feed moves waiting to be fitted, linearization points included (the
    /// spline goes through the others; written as G1, the run has a block for each).
    run: Vec<Queued>,
    /// The position before the run (its start point): the last step written or queued that is
    /// not a linearization point.
    run_start: Option<Step>,
    /// The last step written or queued, linearization points aside.
    last_step: Option<Step>,
    /// Words the reader does not know: carried as comments.
    unknown: std::collections::BTreeSet<String>,
    /// The annotations, as indices into `options.annotations` in order of step.
    notes: Vec<usize>,
    /// The next one of `notes` to write.
    next_note: usize,
    /// BSPLINE mode: the comments held for the run, in order of their run positions.
    run_notes: Vec<Held>,
}

/// A feed move queued in a `BSPLINE` run.
struct Queued {
    step: Step,
    /// The F value as written.
    feed: String,
    /// A point added by linearization: not fitted, written only when the run is written as G1.
    linearized: bool,
}

/// A comment held for a `BSPLINE` run.
struct Held {
    /// The run position of the block it goes before; `run.len()` or more: after the run.
    at: usize,
    /// Carried over from the run before, with the linearization points it ended with (they lead
    /// to this run's first point): when this run is a spline, written before its `BSPLINE`, right
    /// after that run.
    carried: bool,
    text: HeldText,
}

enum HeldText {
    /// An index into `options.annotations`.
    Note(usize),
    /// An IKT decision's comment.
    Decision(String),
}

impl<'a> Builder<'a> {
    fn new(kin: &'a dyn Kinematics, dialect: &'a Dialect, options: &'a Options, sink: &'a mut dyn BlockSink) -> Self {
        Builder {
            kin,
            machine: kin.machine(),
            dialect,
            options,
            sink,
            failed: None,
            next_n: 10,
            written: vec![None; kin.machine().axes.len().max(6)],
            last_feed: None,
            feed_mode: "per-minute",
            last_tip: None,
            previous: None,
            tcp_on: false,
            spindle_rpm: None,
            clamped: 0,
            run: Vec::new(),
            run_start: None,
            last_step: None,
            unknown: std::collections::BTreeSet::new(),
            notes: {
                let mut notes: Vec<usize> = (0..options.annotations.len()).collect();
                notes.sort_by_key(|&i| options.annotations[i].step);
                notes
            },
            next_note: 0,
            run_notes: Vec::new(),
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
            self.next_n += 10;
            n
        })
    }

    /// Text made fit for a comment of the dialect (see [`clean_comment`]).
    fn clean(&self, text: &str) -> String {
        clean_comment(self.dialect, text)
    }

    fn comment(&mut self, text: &str) {
        let mut clean = self.clean(text);
        let room = self
            .dialect
            .max_line
            .saturating_sub(self.dialect.comment_open.len() + self.dialect.comment_close.len() + 8);
        if clean.len() > room {
            let cut = (0..=room).rev().find(|&i| clean.is_char_boundary(i)).unwrap_or(0);
            clean.truncate(cut);
        }
        let n = self.n();
        self.push(Block::Comment { n, text: clean.trim_end().to_string() });
    }

    /// The annotations of the steps up to `k` not yet written.
    fn take_notes(&mut self, k: usize) -> std::ops::Range<usize> {
        let annotations = &self.options.annotations;
        let start = self.next_note;
        let end = start + self.notes[start..].partition_point(|&i| annotations[i].step <= k);
        self.next_note = end;
        start..end
    }

    /// Writes annotation `i` as a comment.
    fn note(&mut self, i: usize) {
        let options = self.options;
        if let Some(a) = options.annotations.get(i) {
            self.comment(&a.text);
        }
    }

    /// Writes the annotations of the steps up to `k` not yet written.
    fn notes_upto(&mut self, k: usize) {
        for at in self.take_notes(k) {
            self.note(self.notes[at]);
        }
    }

    /// Holds the annotations of the steps up to `k` for the run, before its position `at`.
    fn hold_notes(&mut self, k: usize, at: usize) {
        for n in self.take_notes(k) {
            let i = self.notes[n];
            self.run_notes.push(Held { at, carried: false, text: HeldText::Note(i) });
        }
    }

    /// Writes the comments `held` for a run from `*next` on, while `upto` accepts them.
    fn held_upto(&mut self, held: &[Held], next: &mut usize, upto: impl Fn(&Held) -> bool) {
        while let Some(h) = held.get(*next) {
            if !upto(h) {
                break;
            }
            *next += 1;
            match &h.text {
                HeldText::Note(i) => self.note(*i),
                HeldText::Decision(text) => self.comment(text),
            }
        }
    }

    fn decision(&mut self, noted: &Noted) {
        self.flush_run(true);
        let text = format!("postpro: {}", noted.decision);
        if self.run.is_empty() {
            self.comment(&text);
        } else {
            // Linearization points wait for their step: the comment goes before it.
            self.run_notes.push(Held { at: self.run.len(), carried: true, text: HeldText::Decision(text) });
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

    /// The axis words of a step that differ from what was last written (all with `all`).
    fn axis_words(&mut self, step: &Step, all: bool) -> Vec<Word> {
        let mut words = Vec::with_capacity(self.machine.axes.len());
        for (i, axis) in self.machine.axes.iter().enumerate() {
            let value = match axis.kind {
                AxisKind::Linear => step.joints[i],
                AxisKind::Rotary => step.joints[i].to_degrees(),
            };
            let mut text = String::with_capacity(12);
            push_number(&mut text, value, usize::from(axis.decimals), self.dialect.explicit_plus);
            if all || self.written[i].as_deref() != Some(text.as_str()) {
                self.written[i] = Some(text.clone());
                words.push(Word { letter: axis.letter.clone(), value, text });
            }
        }
        words
    }

    /// Tool tip and vector in the part frame (TCP mode).
    fn tcp_words(&mut self, step: &Step) -> Vec<Word> {
        let (i, j, k) = match self.dialect.tcp {
            TcpStyle::Traori => ("A3", "B3", "C3"),
            TcpStyle::G43_5 => ("I", "J", "K"),
            _ => ("TX", "TY", "TZ"),
        };
        let p = step.pose.tip;
        let a = step.pose.axis;
        let entries = [("X", p.x, 4usize), ("Y", p.y, 4), ("Z", p.z, 4), (i, a.x, 7), (j, a.y, 7), (k, a.z, 7)];
        let texts: Vec<String> = entries
            .iter()
            .map(|&(_, value, decimals)| {
                let mut text = String::with_capacity(12);
                push_number(&mut text, value, decimals, self.dialect.explicit_plus);
                text
            })
            .collect();
        // Positions are modal; the vector is written whole whenever it changes.
        let vector_changed = (3..6).any(|s| self.written[s].as_deref() != Some(texts[s].as_str()));
        let mut words = Vec::with_capacity(9);
        for (slot, ((letter, value, _), text)) in entries.into_iter().zip(texts).enumerate() {
            let changed = if slot < 3 { self.written[slot].as_deref() != Some(text.as_str()) } else { vector_changed };
            if changed {
                if slot >= 3 && self.dialect.tcp == TcpStyle::M128 && slot == 3 {
                    // Heidenhain LN blocks carry a normal vector too: the tool vector (no 3D compensation).
                    for (n, v) in [("NX", a.x), ("NY", a.y), ("NZ", a.z)] {
                        let mut t = String::with_capacity(12);
                        push_number(&mut t, v, 7, true);
                        words.push(Word { letter: n.to_string(), value: v, text: t });
                    }
                }
                self.written[slot] = Some(text.clone());
                words.push(Word { letter: letter.to_string(), value, text });
            }
        }
        words
    }

    fn step(&mut self, k: usize, step: &Step, motion: Motion) -> Result<(), EmitError> {
        if self.options.mode == Mode::Bspline {
            let feed = match motion {
                Motion::Feed(f)
                    if f.per == FeedPer::Minute
                        && !step.rapid
                        && step.kind != StepKind::Retract
                        && step.kind != StepKind::Reorient =>
                {
                    Some(f)
                }
                _ => None,
            };
            match feed {
                // The spline goes through the CL points (it is checked against the tolerance
                // itself); the linearization points are queued for a run written as G1.
                Some(f) => {
                    let mut text = String::new();
                    push_number(&mut text, f.value, self.dialect.feed_decimals, false);
                    let linearized = step.kind == StepKind::Linearized;
                    // A point at another feed ends the run; the linearization points queued for it
                    // (at its feed) go on into the next.
                    if !linearized && self.run.iter().rev().find(|q| !q.linearized).is_some_and(|q| q.feed != text) {
                        self.flush_run(true);
                    }
                    if self.run.is_empty() {
                        self.run_start = self.last_step;
                    }
                    self.hold_notes(k, self.run.len());
                    self.run.push(Queued { step: *step, feed: text, linearized });
                    if !linearized {
                        self.last_step = Some(*step);
                    }
                    return Ok(());
                }
                None => self.flush_run(false),
            }
        }
        self.last_step = Some(*step);
        // Before anything the step writes (or where it would, when it writes nothing).
        self.notes_upto(k);
        // In TCP mode the controller interpolates in the part frame: no linearization points.
        if self.options.mode == Mode::Tcp && step.kind == StepKind::Linearized {
            return Ok(());
        }
        if self.options.mode == Mode::Tcp && !self.tcp_on {
            self.tcp_on = true;
            self.written.iter_mut().for_each(|w| *w = None);
            let n = self.n();
            self.push(Block::TcpOn { n });
        }
        let rapid =
            step.rapid || matches!(step.kind, StepKind::Retract | StepKind::Reorient) || motion == Motion::Rapid;
        let tip = step.pose.tip;
        let length = self.last_tip.map_or(0.0, |t| (tip - t).norm());
        self.last_tip = Some(tip);
        let previous = self.previous.replace(step.joints).unwrap_or(step.joints);
        let tcp = self.options.mode == Mode::Tcp;
        if rapid {
            let words = if tcp { self.tcp_words(step) } else { self.axis_words(step, false) };
            if !words.is_empty() {
                let n = self.n();
                self.push(Block::Rapid { n, words });
            }
            return Ok(());
        }
        let feed = match motion {
            Motion::Feed(f) => Some(f),
            _ => None,
        };
        match (self.options.mode, feed) {
            (Mode::InverseTime, Some(f)) if f.per == FeedPer::Minute && f.value > 0.0 => {
                self.set_feed_mode("inverse-time");
                let (lo, hi) = self.dialect.inverse_time_range.unwrap_or((0.001, 99_999.0));
                // Δt = L / feed; F = 1/Δt. Too long a block is split so that F ≥ the minimum.
                let f_inverse = if length > 0.0 { f.value / length } else { hi };
                let pieces = if f_inverse < lo { (lo / f_inverse).ceil().min(1e6) as usize } else { 1 };
                let (f_piece, note) = if f_inverse * pieces as f64 > hi {
                    self.clamped += 1;
                    (hi, Some(self.clean(&format!("F limited to {hi} (block of {length:.4} mm)"))))
                } else {
                    (f_inverse * pieces as f64, None)
                };
                for p in 1..=pieces {
                    let part = if pieces == 1 {
                        *step
                    } else {
                        Step { joints: previous.lerp(&step.joints, p as f64 / pieces as f64), ..*step }
                    };
                    let words = self.axis_words(&part, true);
                    let mut text = String::new();
                    push_number(&mut text, f_piece, self.dialect.feed_decimals.max(3), false);
                    let n = self.n();
                    self.push(Block::Linear { n, words, feed: Some(text), note: note.clone() });
                }
            }
            _ => {
                let mut note = None;
                let feed_text = match feed {
                    Some(f) => {
                        let (value, mode) = match f.per {
                            FeedPer::Minute => (f.value, "per-minute"),
                            FeedPer::Revolution => (f.value, "per-revolution"),
                        };
                        self.set_feed_mode(mode);
                        let (lo, hi) = self.dialect.feed_range;
                        let limited = if mode == "per-minute" { value.clamp(lo, hi) } else { value };
                        let mut text = String::new();
                        push_number(&mut text, limited, self.dialect.feed_decimals, false);
                        (self.last_feed.as_deref() != Some(text.as_str())).then(|| {
                            self.last_feed = Some(text.clone());
                            if limited != value {
                                // Out of the controller's range: written at the limit, and said so.
                                note = Some(
                                    self.clean(&format!("feed {value} mm/min out of the controller's range {lo}…{hi}")),
                                );
                            }
                            text
                        })
                    }
                    None => None,
                };
                let words = if tcp { self.tcp_words(step) } else { self.axis_words(step, false) };
                if words.is_empty() && feed_text.is_none() {
                    return Ok(());
                }
                let n = self.n();
                self.push(Block::Linear { n, words, feed: feed_text, note });
            }
        }
        Ok(())
    }

    fn item(&mut self, kind: &ItemKind) {
        if !matches!(kind, ItemKind::Comment(_) | ItemKind::Frame(_) | ItemKind::Multax(_) | ItemKind::ToolShape(_)) {
            self.flush_run(false);
        }
        match kind {
            ItemKind::ToolChange(t) => {
                if self.tcp_on {
                    self.tcp_on = false;
                    let n = self.n();
                    self.push(Block::TcpOff { n });
                }
                let n = self.n();
                self.push(Block::ToolChange {
                    n,
                    number: t.number,
                    name: t.name.clone(),
                    offset: t.adjust.unwrap_or(t.number),
                    length_compensation: self.machine.chain.tool_length == 0.0,
                });
                // After a tool change every axis is written again.
                self.written.iter_mut().for_each(|w| *w = None);
                self.last_feed = None;
            }
            ItemKind::ToolShape(_) | ItemKind::ToolSelect(_) => {}
            ItemKind::Spindle(Spindle::On { speed, unit, clockwise }) => {
                self.spindle_rpm = (*unit == SpindleUnit::Rpm).then_some(*speed);
                let mut text = String::new();
                push_number(&mut text, *speed, 0, false);
                let n = self.n();
                self.push(Block::SpindleOn {
                    n,
                    speed: text,
                    clockwise: *clockwise,
                    surface_speed: *unit == SpindleUnit::SurfaceSpeed,
                });
            }
            ItemKind::Spindle(Spindle::Off) => {
                let n = self.n();
                self.push(Block::SpindleOff { n });
            }
            ItemKind::Coolant(c) => {
                let n = self.n();
                self.push(match c {
                    Coolant::Off => Block::CoolantOff { n },
                    Coolant::On => Block::CoolantOn { n, coolant: "on" },
                    Coolant::Flood => Block::CoolantOn { n, coolant: "flood" },
                    Coolant::Mist => Block::CoolantOn { n, coolant: "mist" },
                    Coolant::Through => Block::CoolantOn { n, coolant: "through" },
                    Coolant::Air => Block::CoolantOn { n, coolant: "air" },
                });
            }
            ItemKind::CutterComp(c) => {
                let side = match c {
                    CutterComp::Left => "LEFT",
                    CutterComp::Right => "RIGHT",
                    CutterComp::On => "ON",
                    CutterComp::Off => "OFF",
                };
                self.comment(&format!("CUTCOM/{side}: the CL points are tool-centre points; not applied"));
            }
            ItemKind::CycleOn(c) => {
                let params: Vec<String> = c
                    .params
                    .iter()
                    .map(|(k, v)| match k {
                        Some(k) if v.is_nan() => k.clone(),
                        Some(k) => format!("{k} {v}"),
                        None => v.to_string(),
                    })
                    .collect();
                self.comment(&format!("CYCLE/{} {}: hole positions follow as moves", c.kind, params.join(" ")));
            }
            ItemKind::CycleOff => self.comment("CYCLE/OFF"),
            ItemKind::Delay(d) => {
                let seconds = match *d {
                    Delay::Seconds(s) => Some(s),
                    Delay::Revolutions(r) => self.spindle_rpm.filter(|rpm| *rpm > 0.0).map(|rpm| r * 60.0 / rpm),
                };
                match seconds {
                    Some(s) => {
                        let mut text = String::new();
                        push_number(&mut text, s, 3, false);
                        let n = self.n();
                        self.push(Block::Dwell { n, seconds: text });
                    }
                    None => self.comment("DELAY in revolutions without a spindle speed: not written"),
                }
            }
            ItemKind::Stop(text) => {
                let n = self.n();
                self.push(Block::Stop { n, text: text.clone() });
            }
            ItemKind::OptionalStop => {
                let n = self.n();
                self.push(Block::OptionalStop { n });
            }
            ItemKind::Text(TextKind::Insert, text) => {
                let n = self.n();
                self.push(Block::Insert { n, text: text.clone() });
            }
            ItemKind::Text(TextKind::Partno, _) => {}
            ItemKind::Text(_, text) => self.comment(text),
            ItemKind::OperationStart(name) if !name.is_empty() => self.comment(&format!("operation: {name}")),
            // Unknown words go to the program as comments; known passive ones (PAINT) do not.
            ItemKind::Record(r) if self.unknown.contains(&r.word) => {
                let args = if r.args.is_empty() { String::new() } else { format!("/{}", r.args) };
                self.comment(&format!("CL {}{args}: unknown word, not interpreted", r.word));
            }
            ItemKind::Record(_) => {}
            ItemKind::Move(_)
            | ItemKind::Arc(_)
            | ItemKind::Nurbs(_)
            | ItemKind::Comment(_)
            | ItemKind::OperationStart(_)
            | ItemKind::OperationEnd
            | ItemKind::Frame(_)
            | ItemKind::Multax(_)
            | ItemKind::End
            | ItemKind::Fini => {}
        }
    }

    /// Writes the queued run of feed moves as a B-spline through its points that are not
    /// linearization points, or as G1 moves through all of them when it is too short or the
    /// spline cannot follow it within the tolerance.
    ///
    /// With `carry`, the linearization points after the run's last other point (those of a point
    /// still to come, which starts the next run) stay queued, with the comments held for them and
    /// after them, for the next run.
    ///
    /// The annotations held for the run go before the first control point of the span that ends
    /// at their point (after `BSPLINE`; a linearization point's: at the next point of the spline),
    /// or before their point's block when written as G1; those held past the run's last point go
    /// after it. Comments carried from the run before go before `BSPLINE`.
    fn flush_run(&mut self, carry: bool) {
        let mut run = std::mem::take(&mut self.run);
        let mut held = std::mem::take(&mut self.run_notes);
        let start = self.run_start.take();
        // The run up to its last point that is not a linearization point.
        let split = run.iter().rposition(|q| !q.linearized).map_or(0, |i| i + 1);
        if carry && split < run.len() {
            self.run = run.split_off(split);
            self.run_start = if split > 0 { Some(run[split - 1].step) } else { start };
            let from = held.partition_point(|h| h.at < split);
            self.run_notes =
                held.split_off(from).into_iter().map(|h| Held { at: h.at - split, carried: true, ..h }).collect();
        }
        let mut next = 0;
        // The points the spline goes through, after the start (point 0 of the fit).
        let points: Vec<&Step> = run.iter().filter(|q| !q.linearized).map(|q| &q.step).collect();
        let fitted = start.filter(|_| !points.is_empty()).and_then(|start| {
            let joints: Vec<Joints> = std::iter::once(start.joints).chain(points.iter().map(|s| s.joints)).collect();
            let poses: Vec<Pose> = std::iter::once(start.pose).chain(points.iter().map(|s| s.pose)).collect();
            let tolerance = self.machine.policy.linearization_tolerance;
            let cone = self.machine.policy.singular_cone;
            crate::bspline::fit_indexed(
                self.kin,
                &crate::bspline::Run { joints: &joints, poses: &poses },
                tolerance,
                cone,
            )
        });
        let mut g1_from = 0;
        if let Some((spline, _, index)) = fitted {
            let last = *points[points.len() - 1];
            let feed = run.iter().find(|q| !q.linearized).map(|q| q.feed.clone()).unwrap_or_default();
            self.held_upto(&held, &mut next, |h| h.carried);
            let n = self.n();
            self.push(Block::BsplineOn { n, degree: crate::bspline::DEGREE, feed });
            // `rank[p]`: the points before run position `p`. A comment held before position `p`
            // goes with point `rank[p]`; point `r` is point `r + 1` of the fit (the start is point
            // 0): its span begins with the control point after that of the point before it.
            let rank: Vec<usize> = std::iter::once(0)
                .chain(run[..split].iter().scan(0, |r, q| {
                    *r += usize::from(!q.linearized);
                    Some(*r)
                }))
                .collect();
            let mut r = 0;
            for (k, control) in spline.control.iter().enumerate().skip(1) {
                while r < points.len() && index.get(r).is_some_and(|&before| k > before) {
                    self.held_upto(&held, &mut next, |h| h.at < split && rank[h.at] <= r);
                    r += 1;
                }
                let step = Step { joints: *control, ..last };
                let words = self.axis_words(&step, true);
                let mut pl = String::new();
                push_number(&mut pl, spline.pl(k), 4, false);
                let n = self.n();
                self.push(Block::ControlPoint { n, words, pl });
            }
            let n = self.n();
            self.push(Block::BsplineOff { n });
            self.last_feed = None;
            // Linearization points after the last point (a run ended without their point): G1.
            g1_from = split;
        }
        for (p, q) in run.iter().enumerate().skip(g1_from) {
            self.held_upto(&held, &mut next, |h| h.at <= p);
            let words = self.axis_words(&q.step, false);
            let feed = (self.last_feed.as_deref() != Some(q.feed.as_str())).then(|| q.feed.clone());
            if let Some(f) = &feed {
                self.last_feed = Some(f.clone());
            }
            let n = self.n();
            self.push(Block::Linear { n, words, feed, note: None });
        }
        self.held_upto(&held, &mut next, |_| true);
    }

    fn finish(mut self) -> Result<(), EmitError> {
        self.flush_run(false);
        // Annotations of steps past the last one: after the last motion, never dropped.
        self.notes_upto(usize::MAX);
        if self.tcp_on {
            let n = self.n();
            self.push(Block::TcpOff { n });
        }
        if self.feed_mode != "per-minute" {
            self.set_feed_mode("per-minute");
        }
        match self.failed {
            Some(e) => Err(e),
            None => Ok(()),
        }
    }
}
