//! The template context: the NC program as data, formatted from the motion program (its blocks
//! in program order, their axis values and F words) for one dialect: numbers written with each
//! axis's decimals, only the words that change, comments cleaned and cut to the line length, the
//! prediction's annotations placed before the motion of their steps. `docs/templates.md`
//! documents every field; templates see exactly these names.

use postpro_cl::Coolant;
use postpro_kin::{Joints, Pose};
use postpro_machine::model::{AxisKind, Machine};
use postpro_motion::{BlockKind, FeedWord, Position};
use serde::Serialize;

use crate::EmitError;
use crate::dialect::{Dialect, TcpStyle};
use crate::format::push_number;

pub use postpro_motion::Mode;

/// What the emitter is asked for.
#[derive(Clone, Debug)]
pub struct Options {
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
    /// Index into `Solved::steps` (the `step` of the motion program's positions).
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

/// The motion program's options for a dialect and mode: the controller's feed ranges.
pub fn motion_options(dialect: &Dialect, mode: Mode) -> postpro_motion::Options {
    postpro_motion::Options {
        mode,
        inverse_time_range: dialect.inverse_time_range.unwrap_or((0.001, 99_999.0)),
        feed_range: dialect.feed_range,
    }
}

/// Builds the whole program (the template context).
pub fn build(
    motion: &postpro_motion::Program,
    machine: &Machine,
    dialect: &Dialect,
    options: &Options,
) -> Result<Program, EmitError> {
    let header = header(motion, machine, dialect, options);
    let tools = tools(motion);
    let mut blocks = Vec::new();
    build_blocks(motion, machine, dialect, options, &mut blocks)?;
    Ok(Program { header, tools, blocks })
}

/// The header of the program.
pub fn header(motion: &postpro_motion::Program, machine: &Machine, dialect: &Dialect, options: &Options) -> Header {
    Header {
        name: options.program_name.clone(),
        part: motion.part.clone(),
        source: options.source_name.clone(),
        machine: machine.name.clone(),
        machine_description: machine.description.clone(),
        dialect: dialect.clone(),
        mode: motion.mode,
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
        tolerance: machine.policy.linearization_tolerance,
        decisions: motion.summary.decisions,
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
pub fn tools(motion: &postpro_motion::Program) -> Vec<Tool> {
    let mut tools: Vec<Tool> = Vec::new();
    for block in &motion.blocks {
        if let BlockKind::ToolChange(t) = &block.kind
            && !tools.iter().any(|x| x.number == t.number)
        {
            tools.push(Tool {
                number: t.number,
                name: t.name.clone(),
                diameter: t.diameter,
                corner_radius: t.corner_radius,
            });
        }
    }
    tools
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
    let mut f = Formatter::new(machine, motion.mode, dialect, options, sink);
    for block in &motion.blocks {
        f.block(&block.kind);
    }
    f.finish()
}

/// The dialect's words for the motion program's blocks, with the modal state of what was
/// written last (axis texts, F, feed mode) and the annotations still to place.
struct Formatter<'a> {
    machine: &'a Machine,
    mode: Mode,
    dialect: &'a Dialect,
    options: &'a Options,
    sink: &'a mut dyn BlockSink,
    /// The first error of the sink (a failed write); later blocks are dropped.
    failed: Option<EmitError>,
    next_n: u32,
    /// The texts last written, per axis (or per TCP word).
    written: Vec<Option<String>>,
    last_feed: Option<String>,
    feed_mode: &'static str,
    /// The annotations, as indices into `options.annotations` in order of step.
    notes: Vec<usize>,
    /// The next one of `notes` to write.
    next_note: usize,
}

impl<'a> Formatter<'a> {
    fn new(
        machine: &'a Machine,
        mode: Mode,
        dialect: &'a Dialect,
        options: &'a Options,
        sink: &'a mut dyn BlockSink,
    ) -> Self {
        let mut notes: Vec<usize> = (0..options.annotations.len()).collect();
        notes.sort_by_key(|&i| options.annotations[i].step);
        Formatter {
            machine,
            mode,
            dialect,
            options,
            sink,
            failed: None,
            next_n: 10,
            written: vec![None; machine.axes.len().max(6)],
            last_feed: None,
            feed_mode: "per-minute",
            notes,
            next_note: 0,
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

    fn comment(&mut self, text: &str) {
        let mut clean = clean_comment(self.dialect, text);
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
            self.comment(&a.text);
        }
    }

    /// Writes the annotations of the steps up to `k` not yet written.
    fn notes_upto(&mut self, k: usize) {
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

    /// The axis words of a position that differ from what was last written (all with `all`).
    fn axis_words(&mut self, joints: &Joints, all: bool) -> Vec<Word> {
        let mut words = Vec::with_capacity(self.machine.axes.len());
        for (i, axis) in self.machine.axes.iter().enumerate() {
            let value = match axis.kind {
                AxisKind::Linear => joints[i],
                AxisKind::Rotary => joints[i].to_degrees(),
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
    fn tcp_words(&mut self, pose: &Pose) -> Vec<Word> {
        let (i, j, k) = match self.dialect.tcp {
            TcpStyle::Traori => ("A3", "B3", "C3"),
            TcpStyle::G43_5 => ("I", "J", "K"),
            _ => ("TX", "TY", "TZ"),
        };
        let p = pose.tip;
        let a = pose.axis;
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
                if self.dialect.tcp == TcpStyle::M128 && slot == 3 {
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

    /// The words of a position in this mode: the tip and vector in TCP mode, else the axes.
    fn position_words(&mut self, to: &Position, all: bool) -> Vec<Word> {
        if self.mode == Mode::Tcp { self.tcp_words(&to.pose) } else { self.axis_words(&to.axes, all) }
    }

    fn block(&mut self, kind: &BlockKind) {
        match kind {
            BlockKind::Comment(text) => self.comment(text),
            BlockKind::Insert(text) => {
                let n = self.n();
                self.push(Block::Insert { n, text: text.clone() });
            }
            BlockKind::Operation(name) if !name.is_empty() => self.comment(&format!("operation: {name}")),
            BlockKind::Operation(_) => {}
            BlockKind::Rapid(to) => {
                // Before anything the step writes (or where it would, when it writes nothing).
                self.notes_upto(to.step);
                let words = self.position_words(to, false);
                if !words.is_empty() {
                    let n = self.n();
                    self.push(Block::Rapid { n, words });
                }
            }
            BlockKind::Linear(linear) => self.linear(linear),
            BlockKind::Spline(spline) => self.spline(spline),
            BlockKind::ToolChange(t) => {
                let n = self.n();
                self.push(Block::ToolChange {
                    n,
                    number: t.number,
                    name: t.name.clone(),
                    offset: t.length_register,
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
                self.push(Block::Stop { n, text: text.clone() });
            }
            BlockKind::OptionalStop => {
                let n = self.n();
                self.push(Block::OptionalStop { n });
            }
            BlockKind::TcpOn => {
                self.written.iter_mut().for_each(|w| *w = None);
                let n = self.n();
                self.push(Block::TcpOn { n });
            }
            BlockKind::TcpOff => {
                let n = self.n();
                self.push(Block::TcpOff { n });
            }
        }
    }

    fn linear(&mut self, linear: &postpro_motion::Linear) {
        self.notes_upto(linear.to.step);
        match linear.feed {
            FeedWord::InverseTime(f) => {
                self.set_feed_mode("inverse-time");
                let words = self.axis_words(&linear.to.axes, true);
                let mut text = String::new();
                push_number(&mut text, f, self.dialect.feed_decimals.max(3), false);
                let note = linear.note.as_deref().map(|t| clean_comment(self.dialect, t));
                let n = self.n();
                self.push(Block::Linear { n, words, feed: Some(text), note });
            }
            FeedWord::PerMinute(value) | FeedWord::PerRevolution(value) => {
                let mode = if matches!(linear.feed, FeedWord::PerMinute(_)) { "per-minute" } else { "per-revolution" };
                self.set_feed_mode(mode);
                let mut text = String::new();
                push_number(&mut text, value, self.dialect.feed_decimals, false);
                let mut note = None;
                let feed = (self.last_feed.as_deref() != Some(text.as_str())).then(|| {
                    self.last_feed = Some(text.clone());
                    note = linear.note.as_deref().map(|t| clean_comment(self.dialect, t));
                    text
                });
                let words = self.position_words(&linear.to, false);
                if words.is_empty() && feed.is_none() {
                    return;
                }
                let n = self.n();
                self.push(Block::Linear { n, words, feed, note });
            }
        }
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
        let mut next = 0;
        let mut upto = |f: &mut Self, place: usize| {
            while let Some(&(p, at)) = placed.get(next).filter(|(p, _)| *p <= place) {
                let _ = p;
                f.note(at);
                next += 1;
            }
        };
        upto(self, 0);
        let mut feed = String::new();
        push_number(&mut feed, spline.feed, self.dialect.feed_decimals, false);
        let n = self.n();
        self.push(Block::BsplineOn { n, degree: postpro_kin::bspline::DEGREE, feed });
        for (k, control) in spline.curve.control.iter().enumerate().skip(1) {
            upto(self, k);
            let words = self.axis_words(control, true);
            let mut pl = String::new();
            push_number(&mut pl, spline.curve.pl(k), 4, false);
            let n = self.n();
            self.push(Block::ControlPoint { n, words, pl });
        }
        upto(self, usize::MAX);
        let n = self.n();
        self.push(Block::BsplineOff { n });
        self.last_feed = None;
    }

    fn finish(mut self) -> Result<(), EmitError> {
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
