//! Statements to the tool path: the modal state of a CL file (position, tool axis, feed, rapid,
//! frame, units), the multi-record constructs (arc + end GOTO, NURBS + KNOT + CNTRL, cycles),
//! and the diagnostics.
//!
//! Reading starts with a pre-scan ([`prescan`]) for what every statement needs to know: the
//! file's length unit and its CAM system (whose arc convention applies to each `CIRCLE` as it is
//! read). A file whose CAM system has no arc convention and that has arcs is read twice: the first
//! pass only collects what the moves tangent to the arcs say about their sense ([`arcs`]).
//!
//! Frames: the **part frame** is the frame in effect at the first motion (the NX `MSYS` of the
//! first operation, or the file's own frame). Points written after a later `MSYS` or a CAMWorks
//! `ROTABL` are transformed into it. SOLIDWORKS CAM writes its points in the world frame already
//! (the holes of the repeated set-ups in `manufacture3-top.apt` are where their `CSYS` matrices
//! put them), so `CSYS` does not move points; its third column is the set-up's tool axis, the
//! modal axis of the 3-value GOTOs that follow.

mod arcs;
mod cycles;
pub(crate) mod prescan;

use std::sync::Arc;

use nalgebra::{Isometry3, Point3, Translation3, Unit, UnitQuaternion, Vector3};

use self::arcs::{ArcCheck, Arrival, PendingArc, SensePlan, SenseVotes};
use self::cycles::{PendingCycle, ReturnPlane};
use self::prescan::{Prescan, unit_word};
use crate::diagnostic::{Diagnostic, Severity};
use crate::model::*;
use crate::records::{Record as RawRecord, Splitter, Unit as RawUnit};
use crate::span::{Source, Span};
use crate::syntax::{self, Arg, Body, Statement, SyntaxIssue, Value};
use crate::words::{Word, canonical};

/// Where the items of a tool path go: a `Vec` for the whole tool path, or a streaming consumer
/// (the `check` summary) that keeps no items.
pub trait ItemSink {
    /// Takes the next item.
    fn push(&mut self, item: Item);
}

impl ItemSink for Vec<Item> {
    fn push(&mut self, item: Item) {
        Vec::push(self, item);
    }
}

/// A sink that drops the items (the survey pass).
struct Discard;

impl ItemSink for Discard {
    fn push(&mut self, _: Item) {}
}

/// What the user says about a file that overrides what the file says.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ReadOptions {
    /// The sense in which CIRCLE and MOVARC arcs run about the axis vector as written
    /// (`--arc-sense cw|ccw`), replacing the CAM system's convention. Arcs whose record spells
    /// the sense out (`CLOCKWISE`) keep it. The tangency of the neighbouring moves is still
    /// checked.
    pub arc_sense: Option<ArcSense>,
    /// The length unit of the file's values (`--cl-units mm|inch`), replacing its `UNITS`
    /// statements and the unit words of its feeds.
    pub cl_units: Option<LengthUnit>,
}

/// Reads a CL text into a tool path. Never panics; problems are in `diagnostics`.
pub fn read(source: &Source) -> ToolPath {
    read_with(source, &ReadOptions::default())
}

/// Reads a CL text into a tool path, with options. Never panics; problems are in `diagnostics`.
pub fn read_with(source: &Source, options: &ReadOptions) -> ToolPath {
    let mut items = Vec::with_capacity(source.text().len() / 48);
    let (info, diagnostics) = read_into_with(source, options, &mut items);
    ToolPath { items, info, diagnostics }
}

/// Reads a CL text, handing each item to `sink` as soon as it is complete.
pub fn read_into(source: &Source, sink: &mut impl ItemSink) -> (ProgramInfo, Vec<Diagnostic>) {
    read_into_with(source, &ReadOptions::default(), sink)
}

/// Reads a CL text with options, handing each item to `sink` as soon as it is complete.
pub fn read_into_with(
    source: &Source,
    options: &ReadOptions,
    sink: &mut impl ItemSink,
) -> (ProgramInfo, Vec<Diagnostic>) {
    let text = source.shared_text();
    let whole = |each: &mut dyn FnMut(&Window, bool) -> usize| -> Result<(), std::convert::Infallible> {
        each(&Window { text: Arc::clone(&text), base: 0, lines_before: 0 }, true);
        Ok(())
    };
    match read_windows(whole, text.len(), None, options, sink) {
        Ok(read) => read,
        Err(never) => match never {},
    }
}

/// Reads a text that `windows` hands over in windows (each call of it goes over the whole text
/// from the start, every window ending at a line end; see [`crate::ClFile`]): the pre-scan
/// (unless `pre` holds it already), the arc-sense survey when the sense is not known, then the
/// reading itself.
pub(crate) fn read_windows<E>(
    mut windows: impl FnMut(&mut dyn FnMut(&Window, bool) -> usize) -> Result<(), E>,
    len: usize,
    pre: Option<Prescan>,
    options: &ReadOptions,
    sink: &mut impl ItemSink,
) -> Result<(ProgramInfo, Vec<Diagnostic>), E> {
    let pre = match pre {
        Some(pre) => pre,
        None => prescan_windows(&mut windows)?,
    };
    let known = match options.arc_sense {
        Some(s) => Some(SensePlan::Known(s, ArcSenseOrigin::Option)),
        None => pre.cam.and_then(|c| c.arc_sense().map(|s| SensePlan::Known(s, ArcSenseOrigin::CamSystem(c)))),
    };
    let plan = match known {
        Some(plan) => plan,
        None if pre.arc_records > 0 => {
            let mut discard = Discard;
            let mut survey = Pass::new(Builder::new(&mut discard, options, &pre, SensePlan::Survey));
            windows(&mut |w, last| survey.window(w, last))?;
            survey.b.finish(len).2.plan()
        }
        None => SensePlan::Unknown { ccw: 0, cw: 0 },
    };
    let mut reading = Pass::new(Builder::new(sink, options, &pre, plan));
    windows(&mut |w, last| reading.window(w, last))?;
    let (info, diagnostics, _) = reading.b.finish(len);
    Ok((info, diagnostics))
}

/// The pre-scan of a text that `windows` hands over in windows (see [`read_windows`]).
pub(crate) fn prescan_windows<E>(
    windows: &mut impl FnMut(&mut dyn FnMut(&Window, bool) -> usize) -> Result<(), E>,
) -> Result<Prescan, E> {
    let mut scan = prescan::Prescanner::default();
    windows(&mut |w, last| scan.window(&w.text, w.base, last))?;
    Ok(scan.finish())
}

/// A window of the text: its offset in the whole and the line breaks before it.
#[derive(Clone, Debug, Default)]
pub(crate) struct Window {
    pub(crate) text: Arc<String>,
    pub(crate) base: usize,
    pub(crate) lines_before: usize,
}

/// A reading pass over a text that may come in windows.
pub(crate) struct Pass<'s, S> {
    b: Builder<'s, S>,
    /// A statement has been read: no more NX listing header lines.
    seen_statement: bool,
}

impl<'s, S: ItemSink> Pass<'s, S> {
    fn new(b: Builder<'s, S>) -> Self {
        Pass { b, seen_statement: false }
    }

    /// Reads the units of `w` (`last`: it ends the text); returns where it stopped in the
    /// window: its end, or the start of a unit that runs to the end of the window and may go on
    /// in the next one (read again from there).
    pub(crate) fn window(&mut self, w: &Window, last: bool) -> usize {
        self.b.set_window(w);
        let text = w.text.as_str();
        let mut splitter = Splitter::resume(text, 0, self.seen_statement);
        // The arguments of the plain GOTO lines the splitter reads on the way.
        let mut goto = syntax::Args::new();
        loop {
            let (before, seen) = (splitter.pos(), splitter.seen_statement());
            let Some(unit) = splitter.next_with(&mut goto) else { break };
            if !last && splitter.pos() >= text.len() {
                self.seen_statement = seen;
                return before;
            }
            self.b.unit(unit.shifted(w.base), &goto);
        }
        self.seen_statement = splitter.seen_statement();
        text.len()
    }
}

/// At most this many diagnostics are kept; the rest are counted.
const MAX_DIAGNOSTICS: usize = 10_000;

/// The largest magnitude of a number in an interpreted statement, after conversion to mm
/// (a million metres; also mm/min, rpm, s, rad): beyond it sums and lengths could overflow.
const MAX_MAGNITUDE: f64 = 1e9;

/// The help of the warnings about contradicting unit words.
const UNITS_HELP: &str = "if the CAM post wrote the wrong unit, read the file with --cl-units mm|inch";

/// Tolerance on a unit vector's length before a warning.
const UNIT_TOLERANCE: f64 = 1e-3;

struct PendingNurbs {
    /// False after an error at `NURBS/`: its records are swallowed without more errors.
    valid: bool,
    knots: Vec<f64>,
    control: Vec<Point3<f64>>,
    span: Span,
}

struct Builder<'s, S> {
    sink: &'s mut S,
    diags: Vec<Diagnostic>,
    suppressed: usize,
    info: ProgramInfo,
    unit: LengthUnit,
    scale: f64,
    /// Local (the frame points are written in) to part.
    to_part: Isometry3<f64>,
    identity_frame: bool,
    /// The latest MSYS (local to world) and the world-to-part transform fixed at the first motion.
    msys: Isometry3<f64>,
    world_to_part: Option<Isometry3<f64>>,
    table: UnitQuaternion<f64>,
    axis: ToolAxis,
    position: Option<Point3<f64>>,
    rapid: bool,
    feed: Motion,
    in_cycle: bool,
    indirv: Option<Vector3<f64>>,
    arc: Option<PendingArc>,
    nurbs: Option<PendingNurbs>,
    tool_name: Option<String>,
    last_spindle: Option<(f64, SpindleUnit)>,
    camworks_vocabulary: bool,
    options: ReadOptions,
    /// How arcs get their sense.
    sense: SensePlan,
    sense_error_reported: bool,
    arc_info: ArcSenseInfo,
    /// Survey votes.
    votes: SenseVotes,
    /// How the tool arrived at the current position, for the next arc's check.
    arrival: Option<Arrival>,
    /// The last arc, until the move after it is known.
    arc_check: Option<ArcCheck>,
    /// A cycle whose retract height waits for its first hole (Creo/CATIA `RETURN,0`).
    cycle_pending: Option<PendingCycle>,
    /// Where a `RETURN,0` cycle returns to between its holes.
    cycle_return: Option<ReturnPlane>,
    fini_at: Option<Span>,
    warned_after_fini: bool,
    /// The window of the text being read, and the one before it (for the lines of messages).
    window: Window,
    previous_window: Option<Window>,
    feed_unit_conflicts: usize,
    apt_source_statements: usize,
    first_apt_source: Option<Span>,
    /// A lathe statement was reported (once per file).
    turning_reported: bool,
    /// A tool change or a move was emitted: a `FROM` is no longer the start point.
    started: bool,
}

impl<'s, S: ItemSink> Builder<'s, S> {
    fn new(sink: &'s mut S, options: &ReadOptions, pre: &Prescan, sense: SensePlan) -> Self {
        let mut b = Builder {
            sink,
            diags: Vec::new(),
            suppressed: 0,
            info: ProgramInfo::default(),
            unit: LengthUnit::Mm,
            scale: 1.0,
            to_part: Isometry3::identity(),
            identity_frame: true,
            msys: Isometry3::identity(),
            world_to_part: None,
            table: UnitQuaternion::identity(),
            axis: Vector3::z_axis(),
            position: None,
            rapid: false,
            feed: Motion::Unset,
            in_cycle: false,
            indirv: None,
            arc: None,
            nurbs: None,
            tool_name: None,
            last_spindle: None,
            camworks_vocabulary: pre.cam == Some(CamSystem::CamWorks),
            options: *options,
            sense,
            sense_error_reported: false,
            arc_info: ArcSenseInfo::default(),
            votes: SenseVotes::default(),
            arrival: None,
            arc_check: None,
            cycle_pending: None,
            cycle_return: None,
            fini_at: None,
            warned_after_fini: false,
            window: Window::default(),
            previous_window: None,
            feed_unit_conflicts: 0,
            apt_source_statements: 0,
            first_apt_source: None,
            turning_reported: false,
            started: false,
        };
        b.info.cam_system = pre.cam;
        b.info.units = match options.cl_units {
            Some(unit) => UnitsInfo { unit, origin: UnitsOrigin::Option },
            None => pre.units,
        };
        b.unit = b.info.units.unit;
        b.scale = b.unit.to_mm();
        b
    }

    // ----- diagnostics -------------------------------------------------------------------

    fn diag(&mut self, d: Diagnostic) {
        if self.diags.len() >= MAX_DIAGNOSTICS {
            self.suppressed += 1;
            return;
        }
        self.diags.push(d);
    }

    fn error(&mut self, st: &Ctx<'_>, span: Span, message: impl Into<String>, expected: impl Into<String>) {
        let word = Some(st.word_name());
        self.diag(
            Diagnostic::new(Severity::Error, "cl::statement", span, message.into(), expected.into()).with_word(word),
        );
    }

    fn warn(
        &mut self,
        st: &Ctx<'_>,
        span: Span,
        message: impl Into<String>,
        label: impl Into<String>,
        help: Option<String>,
    ) {
        let word = Some(st.word_name());
        let mut d =
            Diagnostic::new(Severity::Warning, "cl::statement", span, message.into(), label.into()).with_word(word);
        d.help = help;
        self.diag(d);
    }

    fn emit(&mut self, span: Span, kind: ItemKind) {
        self.started |=
            matches!(kind, ItemKind::Move(_) | ItemKind::Arc(_) | ItemKind::Nurbs(_) | ItemKind::ToolChange(_));
        self.sink.push(Item { span, kind });
    }

    // ----- units of the file ---------------------------------------------------------------

    /// A unit of the text.
    fn unit(&mut self, unit: RawUnit<'_>, goto: &[Arg<'_>]) {
        match unit {
            RawUnit::Statement(rec) => self.record(&rec, goto),
            RawUnit::Comment { span, text } => {
                let kind = match comment_operation(text) {
                    Some(name) => ItemKind::OperationStart(name),
                    None => ItemKind::Comment(text.trim_end().to_string()),
                };
                self.emit(span, kind);
            }
            RawUnit::Listing => self.info.listing_lines += 1,
        }
    }

    /// The 1-based line of an offset of the text read so far (for messages: in the window being
    /// read or the one before it; 0 beyond them).
    fn line_of(&self, offset: usize) -> usize {
        [Some(&self.window), self.previous_window.as_ref()]
            .into_iter()
            .flatten()
            .find(|w| offset >= w.base && offset <= w.base + w.text.len())
            .map_or(0, |w| w.lines_before + line_of(&w.text, offset - w.base))
    }

    /// The next window of the text.
    fn set_window(&mut self, w: &Window) {
        let previous = std::mem::replace(&mut self.window, w.clone());
        if previous.base != w.base || previous.text.len() != w.text.len() {
            self.previous_window = Some(previous);
        }
    }

    /// A record; `goto`: its arguments when the splitter has read them (`rec.goto`).
    fn record(&mut self, rec: &RawRecord<'_>, goto: &[Arg<'_>]) {
        self.info.statements += 1;
        if let Some(fini) = self.fini_at
            && !self.warned_after_fini
        {
            self.warned_after_fini = true;
            let span = rec.span;
            self.diag(
                Diagnostic::new(
                    Severity::Warning,
                    "cl::after-fini",
                    span,
                    "statements after FINI".into(),
                    "read as part of the program".into(),
                )
                .with_help(format!(
                    "FINI is at line {}; everything after it is read too",
                    self.line_of(fini.start as usize)
                )),
            );
        }
        if let Some(ign) = rec.ignored {
            self.diag(
                Diagnostic::new(
                    Severity::Warning,
                    "cl::continuation",
                    ign,
                    "text after a `$` continuation mark is ignored".into(),
                    "ignored (classic APT)".into(),
                )
                .with_help("write `$$` to start a comment"),
            );
        }
        if rec.dangling_continuation {
            let end = rec.span.end();
            self.diag(Diagnostic::new(
                Severity::Warning,
                "cl::continuation",
                Span::new(end, end),
                "the file ends inside a continued statement".into(),
                "expected a continuation line after `$`".into(),
            ));
        }
        let mut args = syntax::Args::new();
        let parsed = match rec.goto {
            Some(major) => Ok(syntax::goto(&rec.text, major, goto)),
            None => syntax::statement(&rec.text, &mut args),
        };
        let stmt = match parsed {
            Ok(s) => s,
            Err(e) => {
                let at = rec.source_offset(e.at.min(rec.text.len().saturating_sub(1)));
                let span = if e.at >= rec.text.len() {
                    Span::new(rec.span.end(), rec.span.end())
                } else {
                    Span::new(at, at + 1)
                };
                let word = rec.text.split('/').next().map(canonical);
                self.diag(
                    Diagnostic::new(
                        Severity::Error,
                        "cl::syntax",
                        span,
                        "malformed statement".into(),
                        format!("expected {}", e.expected),
                    )
                    .with_word(word.clone()),
                );
                self.finish_nurbs();
                self.emit(
                    rec.span,
                    ItemKind::Record(Record {
                        word: word.unwrap_or_default(),
                        args: rec.text.split_once('/').map_or("", |(_, a)| a).trim().to_string(),
                    }),
                );
                return;
            }
        };
        let ctx = Ctx { rec, major: stmt.major, word: stmt.word };
        if rec.open_quote {
            let end = rec.span.end();
            self.warn(&ctx, Span::new(end, end), "unterminated quoted text", "expected a closing `'`", None);
        }
        for issue in &stmt.issues {
            let SyntaxIssue::MissingComma { at } = *issue;
            let span = rec.source_span(at, at + 1);
            self.warn(
                &ctx,
                span,
                "arguments separated by blanks only",
                "expected `,` here; read as a separate argument",
                None,
            );
        }
        self.statement(&ctx, &stmt);
    }

    fn statement(&mut self, cx: &Ctx<'_>, st: &Statement<'_>) {
        let span = cx.rec.span;
        if self.nurbs.is_some() && !matches!(st.word, Word::Knot | Word::Cntrl) {
            self.finish_nurbs();
        }
        if self.arc.is_some() && is_motion(st.word) && st.word != Word::Goto {
            self.abandon_arc();
        }
        if st.word.is_interpreted()
            && let Some(a) = st.args().iter().find(|a| matches!(a.value, Value::Num(v) if (v * self.scale).is_nan() || (v * self.scale).abs() > MAX_MAGNITUDE))
        {
            let span = arg_span(cx, a);
            return self.error(
                cx,
                span,
                "number out of range",
                "expected a number within ±1e9 (mm, mm/min, s, rpm, rad)",
            );
        }
        match st.word {
            Word::Goto => self.goto(cx, st),
            Word::From => self.from(cx, st),
            Word::Godlta => self.godlta(cx, st),
            Word::Rapid => {
                if let Body::Args(a) = &st.body
                    && !a.is_empty()
                {
                    self.warn(cx, arg_span(cx, &a[0]), "RAPID takes no arguments", "ignored", None);
                }
                self.rapid = true;
            }
            Word::Fedrat => self.fedrat(cx, st),
            Word::Circle => self.circle(cx, st),
            Word::Movarc => self.movarc(cx, st),
            Word::Nurbs => self.nurbs_start(cx),
            Word::Knot | Word::Cntrl => self.nurbs_part(cx, st),
            Word::Multax => {
                let on = !first_word(st).is_some_and(|w| w.eq_ignore_ascii_case("OFF"));
                self.emit(span, ItemKind::Multax(on));
            }
            Word::Tlaxis => self.tlaxis(cx, st),
            Word::Indirv => {
                if let Some(v) = self.vector_args(cx, st, "INDIRV/i,j,k") {
                    self.indirv = Some(self.to_part.rotation * v);
                }
            }
            Word::GoMotion => self.go_motion(cx, st),
            Word::Loadtl | Word::Load | Word::Select | Word::Toolno | Word::Turret => self.tool(cx, st),
            Word::Tldata | Word::Cutter => self.tool_shape(cx, st),
            Word::Spindl => self.spindle(cx, st),
            Word::Coolnt => self.coolant(cx, st),
            Word::Cutcom => self.cutcom(cx, st),
            Word::Cycle => self.cycle(cx, st),
            Word::Delay => self.delay(cx, st),
            Word::Stop | Word::Opstop => {
                let text = text_of(st).filter(|t| !t.is_empty()).map(str::to_string);
                let kind = if st.word == Word::Stop { ItemKind::Stop(text) } else { ItemKind::OptionalStop };
                self.emit(span, kind);
            }
            Word::Pprint | Word::Insert | Word::Tprint | Word::Partno | Word::Remark => self.text(cx, st),
            Word::OpFeatStart => {
                self.camworks_vocabulary = true;
                self.emit(span, ItemKind::OperationStart(text_of(st).unwrap_or_default().to_string()));
            }
            Word::OpFeatEnd => self.emit(span, ItemKind::OperationEnd),
            Word::ToolPath => {
                let (op, tool) = tool_path_names(st);
                self.tool_name = tool;
                self.emit(span, ItemKind::OperationStart(op));
            }
            Word::EndOfPath => self.emit(span, ItemKind::OperationEnd),
            Word::Msys => self.msys(cx, st),
            Word::Csys => self.csys(cx, st),
            Word::Rotabl => self.rotabl(cx, st),
            Word::Units => self.units(cx, st),
            Word::Trntyp => self.passive(cx, st),
            Word::End => self.emit(span, ItemKind::End),
            Word::Fini => {
                self.fini_at = Some(span);
                self.emit(span, ItemKind::Fini);
            }
            Word::Passive => self.passive(cx, st),
            Word::AptSource => self.apt_source(cx, st),
            Word::Other => self.carry(cx, st, true),
        }
    }

    // ----- motion ---------------------------------------------------------------------------

    /// Numbers of a statement; `None` (after a diagnostic) when an argument is not a number.
    /// Trailing empty arguments are dropped with a warning.
    fn numbers(&mut self, cx: &Ctx<'_>, st: &Statement<'_>, form: &str) -> Option<smallvec::SmallVec<[f64; 8]>> {
        let args = st.args();
        let mut n = args.len();
        while n > 0 && args[n - 1].value == Value::Empty {
            n -= 1;
        }
        if n < args.len() {
            self.warn(cx, arg_span(cx, &args[n]), "trailing comma", "empty argument ignored", None);
        }
        if let Some(a) = args[..n].iter().find(|a| !matches!(a.value, Value::Num(_))) {
            self.error(
                cx,
                arg_span(cx, a),
                format!("{} expects numbers", cx.word_name()),
                format!("expected a number ({form})"),
            );
            return None;
        }
        // Magnitudes were checked for every interpreted statement in `statement`.
        let value = |a: &Arg<'_>| if let Value::Num(v) = a.value { v } else { f64::NAN };
        if n <= 8 {
            // Up to eight (every GOTO): filled in place, no growth checks.
            let mut buf = [0.0; 8];
            for (slot, a) in buf.iter_mut().zip(&args[..n]) {
                *slot = value(a);
            }
            return Some(smallvec::SmallVec::from_buf_and_len(buf, n));
        }
        Some(args[..n].iter().map(value).collect())
    }

    /// APT source refers to named geometry: `goto/setpt2`, `goto/pb,-1,0,1`, `tlaxis/atangl,2,45`.
    /// Only in a file that already showed APT source statements; in CL data a word where a number
    /// belongs is an error.
    fn is_symbolic(&self, st: &Statement<'_>) -> bool {
        self.first_apt_source.is_some() && st.args().first().is_some_and(|a| matches!(a.value, Value::Word(_)))
    }

    fn point(&self, x: f64, y: f64, z: f64) -> Point3<f64> {
        let p = Point3::new(x * self.scale, y * self.scale, z * self.scale);
        if self.identity_frame { p } else { self.to_part * p }
    }

    fn direction(&mut self, cx: &Ctx<'_>, span: Span, i: f64, j: f64, k: f64) -> Option<ToolAxis> {
        self.direction_at(cx, || span, i, j, k)
    }

    /// [`Self::direction`] with the span computed only for a diagnostic.
    fn direction_at(&mut self, cx: &Ctx<'_>, span: impl FnOnce() -> Span, i: f64, j: f64, k: f64) -> Option<ToolAxis> {
        let v = Vector3::new(i, j, k);
        let (unit, norm) = Unit::new_and_get(v);
        if norm.is_nan() || norm <= 1e-9 {
            self.error(cx, span(), "zero direction vector", "expected a unit vector (i,j,k)");
            return None;
        }
        if (norm - 1.0).abs() > UNIT_TOLERANCE {
            self.warn(cx, span(), format!("direction vector has length {norm:.6}"), "normalised to unit length", None);
        }
        Some(if self.identity_frame { unit } else { Unit::new_normalize(self.to_part.rotation * v) })
    }

    fn fix_part_frame(&mut self) {
        if self.world_to_part.is_none() {
            self.world_to_part = Some(self.msys.inverse());
            self.update_frame();
        }
    }

    fn update_frame(&mut self) {
        let world_to_part = self.world_to_part.unwrap_or_else(|| self.msys.inverse());
        self.to_part = world_to_part * self.msys * Isometry3::from_parts(Translation3::identity(), self.table);
        self.identity_frame = self.to_part.translation.vector.norm() < 1e-12 && self.to_part.rotation.angle() < 1e-12;
    }

    /// A straight move to `to` (not a hole): its direction concludes the last arc's check and
    /// is the arrival direction for the next arc. A move of no length changes neither.
    fn straight(&mut self, span: Span, to: Point3<f64>) {
        if let Some(from) = self.position
            && to != from
        {
            let arrival = Arrival { direction: to - from, span };
            self.arc_arrival(Some(arrival));
            self.arrival = Some(arrival);
        }
        self.position = Some(to);
    }

    fn motion(&mut self) -> Motion {
        if std::mem::take(&mut self.rapid) { Motion::Rapid } else { self.feed }
    }

    fn goto(&mut self, cx: &Ctx<'_>, st: &Statement<'_>) {
        if self.is_symbolic(st) {
            return self.apt_source(cx, st);
        }
        // RAPID applies to this statement even when it fails.
        let motion = self.motion();
        let Some(to) = self.position_args(cx, st, "GOTO/x,y,z[,i,j,k]") else { return };
        if self.arc.is_some() {
            return self.finish_arc(cx, to, motion);
        }
        if self.in_cycle {
            return self.hole(cx, to, motion);
        }
        self.straight(cx.rec.span, to);
        self.emit(cx.rec.span, ItemKind::Move(Move { to, axis: self.axis, motion, kind: MoveKind::Goto }));
    }

    /// `form` = `WORD/x,y,z[,i,j,k]`: the point in the part frame; a tool axis given becomes the
    /// modal one. `None` after a diagnostic.
    fn position_args(&mut self, cx: &Ctx<'_>, st: &Statement<'_>, form: &str) -> Option<Point3<f64>> {
        // The usual 3 or 6 numbers are copied straight; anything else goes through `numbers`
        // (trailing commas, words).
        let args = st.args();
        let mut plain = [0.0; 6];
        let all_numbers = args.len() <= 6
            && args.iter().zip(plain.iter_mut()).all(|(a, slot)| match a.value {
                Value::Num(v) => {
                    *slot = v;
                    true
                }
                _ => false,
            });
        let numbers;
        let v: &[f64] = if all_numbers {
            &plain[..args.len()]
        } else {
            numbers = self.numbers(cx, st, form)?;
            &numbers
        };
        if v.len() != 3 && v.len() != 6 {
            let word = form.split('/').next().unwrap_or(form);
            let span = body_span(cx, st);
            self.error(
                cx,
                span,
                format!("{word} has {} values", v.len()),
                "expected 3 values (x,y,z) or 6 (x,y,z,i,j,k)",
            );
            return None;
        }
        self.fix_part_frame();
        if v.len() == 6 {
            self.axis = self.direction_at(cx, || args_span(cx, st, 3, 6), v[3], v[4], v[5])?;
        }
        Some(self.point(v[0], v[1], v[2]))
    }

    fn from(&mut self, cx: &Ctx<'_>, st: &Statement<'_>) {
        if self.is_symbolic(st) {
            return self.apt_source(cx, st);
        }
        // FROM is a positioning: it takes a pending RAPID with it.
        self.rapid = false;
        let Some(to) = self.position_args(cx, st, "FROM/x,y,z[,i,j,k]") else { return };
        // A start point, not a move: no direction for an arc's check.
        self.arc_arrival(None);
        self.arrival = None;
        self.position = Some(to);
        if !self.started {
            // Before any tool change and any move: where the tool starts, not a move to write.
            let span = cx.rec.span;
            self.info.start_points.get_or_insert(Occurrences { count: 0, first: span }).count += 1;
            return;
        }
        self.emit(
            cx.rec.span,
            ItemKind::Move(Move { to, axis: self.axis, motion: Motion::Rapid, kind: MoveKind::From }),
        );
    }

    fn godlta(&mut self, cx: &Ctx<'_>, st: &Statement<'_>) {
        let Some(v) = self.numbers(cx, st, "GODLTA/dz or GODLTA/dx,dy,dz") else { return };
        let Some(from) = self.position else {
            if self.first_apt_source.is_some() {
                return self.apt_source(cx, st);
            }
            let span = cx.rec.span;
            return self.error(
                cx,
                span,
                "GODLTA with no current position",
                "expected a GOTO or FROM before an incremental move",
            );
        };
        let delta = match v.len() {
            1 => self.axis.into_inner() * (v[0] * self.scale),
            3 => {
                let d = Vector3::new(v[0], v[1], v[2]) * self.scale;
                if self.identity_frame { d } else { self.to_part.rotation * d }
            }
            n => {
                let span = body_span(cx, st);
                return self.error(
                    cx,
                    span,
                    format!("GODLTA has {n} values"),
                    "expected 1 value (along the tool axis) or 3 (dx,dy,dz)",
                );
            }
        };
        let to = from + delta;
        let motion = self.motion();
        self.straight(cx.rec.span, to);
        self.emit(cx.rec.span, ItemKind::Move(Move { to, axis: self.axis, motion, kind: MoveKind::Godlta }));
    }

    fn fedrat(&mut self, cx: &Ctx<'_>, st: &Statement<'_>) {
        let Body::Args(args) = st.body else {
            let span = cx.rec.span;
            return self.error(cx, span, "FEDRAT without a value", "expected FEDRAT/f[,MMPM|IPM|MMPR|IPR]");
        };
        let mut value = None;
        let mut unit: Option<(FeedPer, Option<LengthUnit>, Span)> = None;
        for a in args {
            match a.value {
                Value::Num(v) if value.is_none() => value = Some((v, arg_span(cx, a))),
                Value::Word(w) => {
                    let Some(u) = feed_word(w) else {
                        self.warn(
                            cx,
                            arg_span(cx, a),
                            format!("unknown feed word `{w}`"),
                            "ignored",
                            Some("known: MMPM, IPM, MMPR, IPR, PERMIN, PERREV".into()),
                        );
                        continue;
                    };
                    unit = Some((u.0, u.1, arg_span(cx, a)));
                }
                Value::Empty => {}
                _ => self.warn(cx, arg_span(cx, a), "unexpected FEDRAT argument", "ignored", None),
            }
        }
        let Some((v, vspan)) = value else {
            let span = body_span(cx, st);
            return self.error(cx, span, "FEDRAT without a value", "expected a feed value");
        };
        if v < 0.0 {
            return self.error(cx, vspan, "negative feed", "expected a feed ≥ 0");
        }
        let (per, length) = unit.map_or((FeedPer::Minute, None), |(p, l, _)| (p, l));
        if let (Some(len), Some((_, _, uspan))) = (length, unit) {
            self.check_feed_unit(cx, len, per, uspan);
        }
        if v == 0.0 {
            self.warn(cx, vspan, "zero feed", "the moves that follow do not progress", None);
        }
        self.feed = Motion::Feed(Feed { value: v * self.scale, per });
    }

    /// A feed's unit word against the file's unit: the value is read in the file's unit, so that
    /// feeds stay consistent with the coordinates; one warning per file. Silent with
    /// `--cl-units`, which says what unit the values are in.
    fn check_feed_unit(&mut self, cx: &Ctx<'_>, written: LengthUnit, per: FeedPer, span: Span) {
        if written == self.unit || self.options.cl_units.is_some() {
            return;
        }
        self.feed_unit_conflicts += 1;
        if self.feed_unit_conflicts > 1 {
            return;
        }
        let file = self.unit.name();
        let origin = match self.info.units.origin {
            UnitsOrigin::Declared(_) => "the UNITS statement",
            UnitsOrigin::FeedWord(_) => "the first FEDRAT",
            UnitsOrigin::Assumed => "the default",
            UnitsOrigin::Option => "--cl-units",
        };
        self.warn(
            cx,
            span,
            format!("feed unit contradicts the file's units ({file}, from {origin})"),
            format!(
                "read as {file} per {} to stay consistent with the coordinates",
                if per == FeedPer::Minute { "minute" } else { "revolution" }
            ),
            Some(format!("{UNITS_HELP}; reported once per file")),
        );
    }

    // ----- NURBS ----------------------------------------------------------------------------

    fn nurbs_start(&mut self, cx: &Ctx<'_>) {
        let span = cx.rec.span;
        match self.position {
            Some(p) => self.nurbs = Some(PendingNurbs { valid: true, knots: Vec::new(), control: vec![p], span }),
            None => {
                self.error(cx, span, "NURBS with no start point", "expected a GOTO before NURBS/");
                self.nurbs = Some(PendingNurbs { valid: false, knots: Vec::new(), control: Vec::new(), span });
            }
        }
    }

    fn nurbs_part(&mut self, cx: &Ctx<'_>, st: &Statement<'_>) {
        let form = if st.word == Word::Knot { "KNOT/k1,k2,…" } else { "CNTRL/x,y,z" };
        let Some(v) = self.numbers(cx, st, form) else { return };
        let span = cx.rec.span;
        if self.nurbs.is_none() {
            return self.error(cx, span, format!("{} outside a NURBS", cx.word_name()), "expected NURBS/ first");
        }
        if st.word == Word::Cntrl {
            if v.len() != 3 && v.len() != 4 {
                return self.error(cx, span, format!("CNTRL has {} values", v.len()), "expected x,y,z");
            }
            if v.len() == 4 && v[3] != 1.0 {
                if let Some(n) = self.nurbs.as_mut() {
                    n.valid = false;
                }
                let span = args_span(cx, st, 3, 4);
                return self.error(
                    cx,
                    span,
                    "rational NURBS weight",
                    "expected weight 1 (rational NURBS are not supported)",
                );
            }
            let p = self.point(v[0], v[1], v[2]);
            if let Some(n) = self.nurbs.as_mut() {
                n.control.push(p);
                n.span = n.span.to(span);
            }
        } else if let Some(n) = self.nurbs.as_mut() {
            n.knots.extend_from_slice(&v);
            n.span = n.span.to(span);
        }
    }

    fn finish_nurbs(&mut self) {
        let Some(n) = self.nurbs.take() else { return };
        if !n.valid {
            return;
        }
        let ctx_word = String::from("NURBS");
        let count = n.control.len();
        // NX writes the knots after the leading `degree + 1` zeros and before the last `degree`
        // ones: full = [0; p+1] ++ given ++ [end; p], so p = controls − given.
        let given = n.knots.len();
        let degree = count.checked_sub(given).filter(|p| (1..=MAX_NURBS_DEGREE).contains(p));
        let sorted = n.knots.windows(2).all(|w| w[0] <= w[1]) && n.knots.iter().all(|k| k.is_finite());
        let (Some(degree), true, Some(&last)) = (degree, sorted, n.knots.last()) else {
            self.diag(Diagnostic::new(Severity::Error, "cl::nurbs", n.span, format!("NURBS with {count} control points and {given} knots"), "expected the NX form: n control points (start point included) and n − degree knots, non-decreasing"
                    .into()).with_word(Some(ctx_word)));
            return;
        };
        let first = 0.0_f64.min(n.knots[0]);
        let mut knots = vec![first; degree + 1];
        knots.extend_from_slice(&n.knots);
        knots.extend(std::iter::repeat_n(last, degree));
        let end = n.control[count - 1];
        let motion = self.motion();
        // A clamped spline leaves its first control point towards the second and arrives at the
        // last from the one before.
        self.arc_arrival(Some(Arrival { direction: n.control[1] - n.control[0], span: n.span }));
        self.arrival = Some(Arrival { direction: end - n.control[count - 2], span: n.span });
        self.position = Some(end);
        let nurbs = Nurbs { degree, knots, control: n.control, axis: self.axis, motion };
        self.emit(n.span, ItemKind::Nurbs(Box::new(nurbs)));
    }

    // ----- tools, spindle, coolant, compensation, cycles ---------------------------------------

    fn tool(&mut self, cx: &Ctx<'_>, st: &Statement<'_>) {
        let span = cx.rec.span;
        let args = st.args();
        self.turning(cx, st);
        let mut number = None;
        let mut adjust = None;
        let mut k = 0;
        while k < args.len() {
            match args[k].value {
                Value::Word(w) if w.eq_ignore_ascii_case("ADJUST") || w.eq_ignore_ascii_case("OSETNO") => {
                    if let Some(Value::Num(v)) = args.get(k + 1).map(|a| a.value) {
                        adjust = whole(v);
                        k += 1;
                    }
                }
                Value::Num(v) if number.is_none() => number = Some((v, arg_span(cx, &args[k]))),
                _ => {}
            }
            k += 1;
        }
        let Some((n, nspan)) = number else {
            return self.error(
                cx,
                body_span(cx, st),
                format!("{} without a tool number", cx.word_name()),
                "expected a tool number",
            );
        };
        let Some(number) = whole(n) else {
            return self.error(cx, nspan, "tool number is not a whole number", "expected a tool number ≥ 0");
        };
        match st.word {
            Word::Select | Word::Toolno => self.emit(span, ItemKind::ToolSelect(number)),
            _ => {
                let name = self.tool_name.take();
                self.emit(span, ItemKind::ToolChange(ToolChange { number, adjust, name }));
            }
        }
    }

    /// A lathe's statement (CATIA's `TURRET/n,OSETNO,…` and `TOOLNO/n,TURN,…`): the file is a
    /// turning program, which a milling machine cannot run. Said once per file, as an error.
    fn turning(&mut self, cx: &Ctx<'_>, st: &Statement<'_>) {
        let what = match st.word {
            Word::Turret => "TURRET indexes a lathe's turret",
            Word::Toolno
                if st.args().iter().any(|a| matches!(a.value, Value::Word(w) if w.eq_ignore_ascii_case("TURN"))) =>
            {
                "TOOLNO/…,TURN defines a turning tool"
            }
            _ => return,
        };
        if std::mem::replace(&mut self.turning_reported, true) {
            return;
        }
        self.diag(
            Diagnostic::new(
                Severity::Error,
                "cl::turning",
                cx.rec.span,
                format!("this is a turning program, not a milling one: {what}"),
                "a lathe statement".into(),
            )
            .with_help(
                "postpro writes programs for milling machines; post this file with a lathe post-processor (its X \
                 is the radius of a turned part, not a position on a table)",
            )
            .with_word(Some(cx.word_name())),
        );
    }

    fn tool_shape(&mut self, cx: &Ctx<'_>, st: &Statement<'_>) {
        let args = st.args();
        let kind =
            args.first().and_then(|a| if let Value::Word(w) = a.value { Some(w.to_ascii_uppercase()) } else { None });
        let nums: Vec<f64> =
            args.iter().filter_map(|a| if let Value::Num(v) = a.value { Some(v * self.scale) } else { None }).collect();
        let Some(&diameter) = nums.first() else {
            return self.error(
                cx,
                body_span(cx, st),
                format!("{} without a diameter", cx.word_name()),
                "expected the tool diameter first",
            );
        };
        if diameter < 0.0 {
            return self.error(cx, body_span(cx, st), "negative tool diameter", "expected a diameter ≥ 0");
        }
        let shape = match (st.word, kind.as_deref()) {
            // TLDATA/MILL,d,r,length,taper,tip
            (Word::Tldata, Some("MILL")) => {
                ToolShape { diameter, corner_radius: nums.get(1).copied().unwrap_or(0.0), length: nums.get(2).copied() }
            }
            // TLDATA/DRILL,d,point angle,length,…
            (Word::Tldata, _) => ToolShape { diameter, corner_radius: 0.0, length: nums.get(2).copied() },
            // CUTTER/d,r,e,f,a,b,h
            _ => {
                ToolShape { diameter, corner_radius: nums.get(1).copied().unwrap_or(0.0), length: nums.get(6).copied() }
            }
        };
        self.emit(cx.rec.span, ItemKind::ToolShape(shape));
    }

    fn spindle(&mut self, cx: &Ctx<'_>, st: &Statement<'_>) {
        let args = st.args();
        let mut speed = None;
        let mut unit = SpindleUnit::Rpm;
        let mut clockwise = true;
        let mut off = false;
        for a in args {
            match a.value {
                Value::Num(v) => speed = Some(v),
                Value::Word(w) => match w.to_ascii_uppercase().as_str() {
                    "RPM" => unit = SpindleUnit::Rpm,
                    "SFM" | "SMM" => unit = SpindleUnit::SurfaceSpeed,
                    "CLW" => clockwise = true,
                    "CCLW" => clockwise = false,
                    "OFF" | "STOP" => off = true,
                    "ON" | "MAXRPM" | "RANGE" => {}
                    _ => self.warn(cx, arg_span(cx, a), format!("unknown spindle word `{w}`"), "ignored", None),
                },
                _ => {}
            }
        }
        let span = cx.rec.span;
        if off {
            return self.emit(span, ItemKind::Spindle(Spindle::Off));
        }
        let Some((speed, unit)) = speed.map(|s| (s, unit)).or(self.last_spindle) else {
            return self.error(
                cx,
                body_span(cx, st),
                "SPINDL without a speed",
                "expected SPINDL/RPM,n[,CLW|CCLW] or SPINDL/OFF",
            );
        };
        if speed < 0.0 {
            return self.error(
                cx,
                body_span(cx, st),
                "negative spindle speed",
                "expected a speed ≥ 0 (direction is CLW or CCLW)",
            );
        }
        self.last_spindle = Some((speed, unit));
        self.emit(span, ItemKind::Spindle(Spindle::On { speed, unit, clockwise }));
    }

    fn coolant(&mut self, cx: &Ctx<'_>, st: &Statement<'_>) {
        let span = cx.rec.span;
        let Some(w) = first_word(st) else {
            self.warn(cx, span, "COOLNT without a minor word", "read as COOLNT/ON", None);
            return self.emit(span, ItemKind::Coolant(Coolant::On));
        };
        let c = match w.to_ascii_uppercase().as_str() {
            "ON" => Coolant::On,
            "FLOOD" => Coolant::Flood,
            "MIST" => Coolant::Mist,
            "THRU" | "THRUST" | "TAP" => Coolant::Through,
            "AIR" => Coolant::Air,
            "OFF" => Coolant::Off,
            other => {
                let label = format!("`{other}` is not a coolant word; read as ON");
                self.warn(
                    cx,
                    body_span(cx, st),
                    "unknown coolant word",
                    label,
                    Some("known: ON, FLOOD, MIST, THRU, AIR, OFF".into()),
                );
                Coolant::On
            }
        };
        self.emit(span, ItemKind::Coolant(c));
    }

    fn cutcom(&mut self, cx: &Ctx<'_>, st: &Statement<'_>) {
        let mut state = None;
        if let Body::Args(a) = st.body {
            for a in a {
                if let Value::Word(w) = a.value {
                    match w.to_ascii_uppercase().as_str() {
                        "LEFT" => state = Some(CutterComp::Left),
                        "RIGHT" => state = Some(CutterComp::Right),
                        "OFF" => state = Some(CutterComp::Off),
                        "ON" => state = state.or(Some(CutterComp::On)),
                        _ => {}
                    }
                }
            }
        }
        match state {
            Some(s) => self.emit(cx.rec.span, ItemKind::CutterComp(s)),
            None => {
                self.error(cx, body_span(cx, st), "CUTCOM without a side", "expected CUTCOM/LEFT, RIGHT, ON or OFF")
            }
        }
    }

    fn delay(&mut self, cx: &Ctx<'_>, st: &Statement<'_>) {
        let args = st.args();
        let rev = args.iter().any(|a| matches!(a.value, Value::Word(w) if w.eq_ignore_ascii_case("REV")));
        let value = args.iter().find_map(|a| if let Value::Num(v) = a.value { Some(v) } else { None });
        match value {
            Some(v) if v >= 0.0 => {
                let d = if rev { Delay::Revolutions(v) } else { Delay::Seconds(v) };
                self.emit(cx.rec.span, ItemKind::Delay(d));
            }
            Some(_) => self.error(cx, body_span(cx, st), "negative dwell", "expected a duration ≥ 0"),
            None => {
                self.error(cx, body_span(cx, st), "DELAY without a duration", "expected DELAY/seconds or DELAY/REV,n")
            }
        }
    }

    fn text(&mut self, cx: &Ctx<'_>, st: &Statement<'_>) {
        let text = text_of(st).unwrap_or_default();
        let kind = match st.word {
            Word::Pprint => TextKind::Pprint,
            Word::Insert => TextKind::Insert,
            Word::Tprint => TextKind::Tprint,
            Word::Partno => TextKind::Partno,
            _ => TextKind::Remark,
        };
        if kind == TextKind::Partno && self.info.part_name.is_none() {
            self.info.part_name = Some(text.trim_matches('\'').to_string());
        }
        if let Some(name) = text_operation(kind, text) {
            return self.emit(cx.rec.span, ItemKind::OperationStart(name));
        }
        // Creo writes its comments as REMARK in one output style; elsewhere REMARK is APT source.
        if kind == TextKind::Remark && self.info.cam_system != Some(CamSystem::Creo) {
            self.note_apt_source(cx.rec.span);
        }
        self.emit(cx.rec.span, ItemKind::Text(kind, text.to_string()));
    }

    // ----- frames and units -----------------------------------------------------------------

    fn vector_args(&mut self, cx: &Ctx<'_>, st: &Statement<'_>, form: &str) -> Option<Vector3<f64>> {
        let v = self.numbers(cx, st, form)?;
        if v.len() != 3 {
            let span = body_span(cx, st);
            self.error(cx, span, format!("{} has {} values", cx.word_name(), v.len()), format!("expected {form}"));
            return None;
        }
        let d = Vector3::new(v[0], v[1], v[2]);
        if d.norm() < 1e-9 {
            let span = body_span(cx, st);
            self.error(cx, span, "zero direction vector", "expected a unit vector (i,j,k)");
            return None;
        }
        Some(d.normalize())
    }

    fn tlaxis(&mut self, cx: &Ctx<'_>, st: &Statement<'_>) {
        if self.is_symbolic(st) {
            return self.apt_source(cx, st);
        }
        let Some(v) = self.numbers(cx, st, "TLAXIS/i,j,k") else { return };
        let span = body_span(cx, st);
        if v.len() != 3 {
            return self.error(cx, span, format!("TLAXIS has {} values", v.len()), "expected TLAXIS/i,j,k");
        }
        if let Some(axis) = self.direction(cx, span, v[0], v[1], v[2]) {
            self.axis = axis;
        }
    }

    fn msys(&mut self, cx: &Ctx<'_>, st: &Statement<'_>) {
        let Some(v) = self.numbers(cx, st, "MSYS/x,y,z,xi,xj,xk,yi,yj,yk") else { return };
        let span = body_span(cx, st);
        if v.len() != 9 {
            return self.error(
                cx,
                span,
                format!("MSYS has {} values", v.len()),
                "expected MSYS/origin x,y,z, X axis i,j,k, Y axis i,j,k",
            );
        }
        let x = Vector3::new(v[3], v[4], v[5]);
        let y = Vector3::new(v[6], v[7], v[8]);
        let (Some(xu), true) = (Unit::try_new(x, 1e-9), y.norm() > 1e-9) else {
            return self.error(cx, span, "MSYS axis of zero length", "expected unit X and Y axes");
        };
        let Some(z) = Unit::try_new(xu.cross(&y), 1e-9) else {
            return self.error(cx, span, "MSYS X and Y axes are parallel", "expected perpendicular X and Y axes");
        };
        if xu.dot(&y.normalize()).abs() > UNIT_TOLERANCE
            || (x.norm() - 1.0).abs() > UNIT_TOLERANCE
            || (y.norm() - 1.0).abs() > UNIT_TOLERANCE
        {
            self.warn(
                cx,
                span,
                "MSYS axes are not orthonormal",
                "orthonormalised (X kept, Y made perpendicular)",
                None,
            );
        }
        let yu = z.cross(&xu);
        let rot = nalgebra::Rotation3::from_matrix_unchecked(nalgebra::Matrix3::from_columns(&[
            xu.into_inner(),
            yu,
            z.into_inner(),
        ]));
        let origin = Vector3::new(v[0], v[1], v[2]) * self.scale;
        self.msys = Isometry3::from_parts(Translation3::from(origin), UnitQuaternion::from_rotation_matrix(&rot));
        self.update_frame();
        let change = FrameChange { source: FrameSource::Msys, to_part: self.to_part };
        self.emit(cx.rec.span, ItemKind::Frame(Box::new(change)));
    }

    fn csys(&mut self, cx: &Ctx<'_>, st: &Statement<'_>) {
        let Some(v) = self.numbers(cx, st, "CSYS/ 3×4 matrix, row by row") else { return };
        let Ok(m) = <[f64; 12]>::try_from(v.as_slice()) else {
            let span = body_span(cx, st);
            return self.error(
                cx,
                span,
                format!("CSYS has {} values", v.len()),
                "expected 12 values: a 3×4 matrix, row by row",
            );
        };
        // The rotation's third column is the set-up's tool axis, in the frame the points are
        // written in: the modal axis of the 3-value GOTOs that follow (6-value GOTOs, TLAXIS and
        // FROM still set their own).
        let span = args_span(cx, st, 2, 11);
        if Vector3::new(m[2], m[6], m[10]).norm() <= 1e-9 {
            return self.error(
                cx,
                span,
                "CSYS gives no tool axis: its third column is zero",
                "expected the set-up's Z axis in values 3, 7 and 11",
            );
        }
        let Some(axis) = self.direction(cx, span, m[2], m[6], m[10]) else { return };
        self.axis = axis;
        let change = FrameChange { source: FrameSource::Csys(m), to_part: self.to_part };
        self.emit(cx.rec.span, ItemKind::Frame(Box::new(change)));
    }

    fn rotabl(&mut self, cx: &Ctx<'_>, st: &Statement<'_>) {
        let args = st.args();
        let mut angle = None;
        let mut axis = None;
        let mut sign = 1.0;
        let mut absolute = false;
        let mut empty = None;
        for a in args {
            match a.value {
                Value::Num(v) if angle.is_none() => angle = Some(v),
                Value::Word(w) => match w.to_ascii_uppercase().as_str() {
                    "AAXIS" => axis = Some('A'),
                    "BAXIS" => axis = Some('B'),
                    "CAXIS" => axis = Some('C'),
                    "CLW" => sign = -1.0,
                    "CCLW" => sign = 1.0,
                    "ABSOL" => absolute = true,
                    "INCR" | "TABLE" | "HEAD" => {}
                    _ => self.warn(cx, arg_span(cx, a), format!("unknown ROTABL word `{w}`"), "ignored", None),
                },
                Value::Empty => empty = Some(arg_span(cx, a)),
                _ => {}
            }
        }
        let Some(angle) = angle else {
            return self.error(
                cx,
                body_span(cx, st),
                "ROTABL without an angle",
                "expected ROTABL/angle,AAXIS|BAXIS|CAXIS[,CLW|CCLW]",
            );
        };
        if let Some(e) = empty {
            self.warn(cx, e, "empty ROTABL argument", "ignored", None);
        }
        if angle == 0.0 {
            return self.passive(cx, st);
        }
        let Some(letter) = axis else {
            return self.error(
                cx,
                body_span(cx, st),
                "ROTABL turns about no named axis",
                "expected AAXIS, BAXIS or CAXIS",
            );
        };
        if absolute {
            return self.error(
                cx,
                body_span(cx, st),
                "absolute ROTABL is not supported",
                "expected an incremental ROTABL (the CAMWorks form)",
            );
        }
        // CAMWorks writes radians; ISO 4343 degrees.
        let radians = if self.camworks_vocabulary { angle } else { angle.to_radians() };
        let axis_vec = match letter {
            'A' => Vector3::x_axis(),
            'B' => Vector3::y_axis(),
            _ => Vector3::z_axis(),
        };
        if !self.camworks_vocabulary {
            self.warn(
                cx,
                body_span(cx, st),
                "ROTABL angle read in degrees",
                "degrees (ISO 4343); CAMWorks files are read in radians",
                None,
            );
        }
        // Rotations of the table about fixed machine axes compose on the left.
        self.table = UnitQuaternion::from_axis_angle(&axis_vec, sign * radians) * self.table;
        self.update_frame();
        let change = FrameChange { source: FrameSource::Rotabl(letter, sign * radians), to_part: self.to_part };
        self.emit(cx.rec.span, ItemKind::Frame(Box::new(change)));
    }

    fn units(&mut self, cx: &Ctx<'_>, st: &Statement<'_>) {
        let Some(unit) = first_word(st).and_then(unit_word) else {
            return self.error(cx, body_span(cx, st), "unknown unit", "expected UNITS/MM or UNITS/INCHES");
        };
        // `--cl-units` replaces what the file declares.
        if self.options.cl_units.is_some() {
            return;
        }
        if unit != self.unit {
            let (old, new) = (self.unit.name(), unit.name());
            self.warn(
                cx,
                cx.rec.span,
                format!("units change from {old} to {new}"),
                format!("values from here on read in {new}"),
                Some(UNITS_HELP.into()),
            );
            self.unit = unit;
            self.scale = unit.to_mm();
        }
    }

    // ----- records carried through ----------------------------------------------------------

    fn passive(&mut self, cx: &Ctx<'_>, st: &Statement<'_>) {
        self.carry(cx, st, false);
    }

    fn carry(&mut self, cx: &Ctx<'_>, st: &Statement<'_>, unknown: bool) {
        let word = cx.word_name();
        if matches!(word.as_str(), "MOVE_ATTRIB" | "BOX") {
            self.camworks_vocabulary = true;
        }
        let span = cx.rec.span;
        let args = match st.body {
            Body::None => String::new(),
            _ => cx.rec.text.split_once('/').map_or(String::new(), |(_, a)| a.trim().to_string()),
        };
        // Counted without cloning the word for each record (a BTreeMap's entry takes its key).
        match self.info.uninterpreted.get_mut(&word) {
            Some(entry) => entry.count += 1,
            None => {
                self.info.uninterpreted.insert(word.clone(), WordUse { count: 1, first: span, unknown });
            }
        }
        self.emit(span, ItemKind::Record(Record { word, args }));
    }

    fn note_apt_source(&mut self, span: Span) {
        self.apt_source_statements += 1;
        self.first_apt_source.get_or_insert(span);
    }

    /// APT source-language statements (`pl1=plane/…`, `goto/setpt2`): carried, counted, and
    /// reported once for the file.
    fn apt_source(&mut self, cx: &Ctx<'_>, st: &Statement<'_>) {
        self.note_apt_source(cx.rec.span);
        self.carry(cx, st, false);
    }

    /// The end of the text, `len` bytes long.
    fn finish(mut self, len: usize) -> (ProgramInfo, Vec<Diagnostic>, SenseVotes) {
        self.finish_nurbs();
        self.arc_arrival(None);
        self.flush_cycle();
        if let Some(arc) = self.arc.take() {
            self.diag(
                Diagnostic::new(
                    Severity::Error,
                    "cl::statement",
                    arc.span,
                    format!("{} is not followed by its end point", arc.word),
                    "expected a GOTO to the arc's end point next".into(),
                )
                .with_word(Some(arc.word.to_string())),
            );
        }
        if let Some(first) = self.first_apt_source {
            self.info.apt_source = true;
            let n = self.apt_source_statements;
            self.diag(
                Diagnostic::new(
                    Severity::Warning,
                    "cl::apt-source",
                    first,
                    format!(
                        "this looks like an APT part program (source language), not CL data: {n} symbolic statement(s)"
                    ),
                    "geometry definitions and symbolic motion are carried as records, not evaluated".into(),
                )
                .with_help("run the part program through an APT processor and read its CL output"),
            );
        }
        for (word, usage) in &self.info.uninterpreted {
            if usage.unknown {
                let n = usage.count;
                self.diags.push(Diagnostic {
                    severity: Severity::Warning,
                    code: "cl::unknown-word",
                    message: format!("unknown word `{word}` ({n} record{})", if n == 1 { "" } else { "s" }),
                    span: usage.first,
                    label: "carried through unchanged".into(),
                    help: Some("kept in place as a record for the later stages; check the CAM post-processor settings if it should not be there".into()),
                    word: Some(word.clone()),
                });
            }
        }
        if self.suppressed > 0 {
            let n = self.suppressed;
            self.diags.push(Diagnostic {
                severity: if self.diags.iter().any(Diagnostic::is_error) { Severity::Error } else { Severity::Warning },
                code: "cl::too-many",
                message: format!("{n} more diagnostics not kept"),
                span: Span::new(len, len),
                label: "limit reached".into(),
                help: None,
                word: None,
            });
        }
        self.arc_info.sense = match self.sense {
            SensePlan::Known(s, origin) => {
                self.arc_info.origin = origin;
                Some(s)
            }
            SensePlan::Survey | SensePlan::Unknown { .. } => None,
        };
        self.info.arc_sense = self.arc_info;
        self.diags.sort_by_key(|d| d.span.start);
        (self.info, self.diags, self.votes)
    }
}

/// The statement being processed.
struct Ctx<'r> {
    rec: &'r RawRecord<'r>,
    major: &'r str,
    word: Word,
}

impl Ctx<'_> {
    /// The canonical major word, for diagnostics and records (allocates: not on the hot path).
    fn word_name(&self) -> String {
        match self.word {
            Word::Goto => String::from("GOTO"),
            Word::AptSource if self.major.contains('=') => String::from("APT ASSIGNMENT"),
            _ => canonical(self.major),
        }
    }
}

fn is_motion(w: Word) -> bool {
    matches!(
        w,
        Word::Goto
            | Word::From
            | Word::Godlta
            | Word::Circle
            | Word::Movarc
            | Word::GoMotion
            | Word::Nurbs
            | Word::End
            | Word::Fini
    )
}

fn arg_span(cx: &Ctx<'_>, a: &Arg<'_>) -> Span {
    cx.rec.source_span(a.start as usize, (a.end as usize).max(a.start as usize + 1).min(cx.rec.text.len().max(1)))
}

fn body_span(cx: &Ctx<'_>, st: &Statement<'_>) -> Span {
    match &st.body {
        Body::Args(a) if !a.is_empty() => {
            let (s, e) = (a[0].start as usize, a[a.len() - 1].end as usize);
            cx.rec.source_span(s, e.max(s + 1).min(cx.rec.text.len()))
        }
        _ => cx.rec.span,
    }
}

/// The source span of arguments `from..to` (clamped to the arguments present).
fn args_span(cx: &Ctx<'_>, st: &Statement<'_>, from: usize, to: usize) -> Span {
    let a = st.args();
    match (a.get(from), a.get(to.min(a.len()).saturating_sub(1))) {
        (Some(first), Some(last)) if last.end >= first.start => {
            cx.rec.source_span(first.start as usize, (last.end as usize).max(first.start as usize + 1))
        }
        _ => body_span(cx, st),
    }
}

/// The 1-based line of a byte offset (for messages; not on a hot path).
fn line_of(src: &str, offset: usize) -> usize {
    let bytes = &src.as_bytes()[..offset.min(src.len())];
    let lone_cr = memchr::memchr_iter(b'\r', bytes).filter(|&k| bytes.get(k + 1) != Some(&b'\n')).count();
    1 + memchr::memchr_iter(b'\n', bytes).count() + lone_cr
}

fn first_word<'a>(st: &Statement<'a>) -> Option<&'a str> {
    match &st.body {
        Body::Args(a) => a.iter().find_map(|a| if let Value::Word(w) = a.value { Some(w) } else { None }),
        _ => None,
    }
}

fn text_of<'a>(st: &Statement<'a>) -> Option<&'a str> {
    match st.body {
        Body::Text(t) => Some(t),
        _ => None,
    }
}

fn whole(v: f64) -> Option<u32> {
    (v >= 0.0 && v.fract() == 0.0 && v <= f64::from(u32::MAX)).then_some(v as u32)
}

fn line_word(group: &str) -> bool {
    group.trim_start().get(..4).is_some_and(|w| w.eq_ignore_ascii_case("LINE"))
}

/// `TOOL PATH/operation,TOOL,tool name`.
fn tool_path_names(st: &Statement<'_>) -> (String, Option<String>) {
    let Body::Args(a) = &st.body else { return (String::new(), None) };
    let text = |a: &Arg<'_>| match a.value {
        Value::Word(w) | Value::Quoted(w) => w.to_string(),
        Value::Num(v) => v.to_string(),
        _ => String::new(),
    };
    let op = a.first().map(text).unwrap_or_default();
    let tool = a
        .iter()
        .position(|x| matches!(x.value, Value::Word(w) if w.eq_ignore_ascii_case("TOOL")))
        .and_then(|k| a.get(k + 1))
        .map(text);
    (op, tool)
}

/// The time base and length unit of a feed word.
fn feed_word(w: &str) -> Option<(FeedPer, Option<LengthUnit>)> {
    Some(match w.to_ascii_uppercase().as_str() {
        "MMPM" => (FeedPer::Minute, Some(LengthUnit::Mm)),
        "IPM" => (FeedPer::Minute, Some(LengthUnit::Inch)),
        "MMPR" => (FeedPer::Revolution, Some(LengthUnit::Mm)),
        "IPR" => (FeedPer::Revolution, Some(LengthUnit::Inch)),
        "PERMIN" | "FPM" => (FeedPer::Minute, None),
        "PERREV" | "FPR" => (FeedPer::Revolution, None),
        _ => return None,
    })
}

/// The operation a whole-line comment starts: CATIA `$$ OPERATION NAME : name`, Creo
/// `$$-> FEATNO / n` (the NC sequence's feature number).
fn comment_operation(text: &str) -> Option<String> {
    let t = text.trim();
    if let Some(rest) = strip_prefix_ignore_case(t, "OPERATION NAME")
        && let Some(name) = rest.trim_start().strip_prefix(':')
    {
        return Some(name.trim().to_string());
    }
    creo_feature(t)
}

/// Creo's `-> FEATNO / n` (in a `$$` comment or a `REMARK`): the operation `FEATNO n`.
fn creo_feature(text: &str) -> Option<String> {
    let rest = text.trim().strip_prefix("->")?.trim_start();
    let number = strip_prefix_ignore_case(rest, "FEATNO")?.trim_start().strip_prefix('/')?.trim();
    (!number.is_empty()).then(|| format!("FEATNO {number}"))
}

/// The operation a text statement starts: Makino `PPRINT/BEGIN-SECTION,MACHINING`, Creo
/// `REMARK -> FEATNO / n`.
fn text_operation(kind: TextKind, text: &str) -> Option<String> {
    match kind {
        TextKind::Pprint => {
            let rest = strip_prefix_ignore_case(text.trim(), "BEGIN-SECTION")?.trim_start().strip_prefix(',')?;
            rest.trim().eq_ignore_ascii_case("MACHINING").then(|| rest.trim().to_string())
        }
        TextKind::Remark => creo_feature(text),
        _ => None,
    }
}

fn strip_prefix_ignore_case<'a>(text: &'a str, prefix: &str) -> Option<&'a str> {
    text.get(..prefix.len()).filter(|p| p.eq_ignore_ascii_case(prefix)).map(|_| &text[prefix.len()..])
}
