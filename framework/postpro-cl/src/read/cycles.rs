//! Canned cycles: `CYCLE/word,…` to a typed [`Cycle`], in each vendor's argument form. The
//! `GOTO`s that follow, until `CYCLE/OFF`, are hole positions at the top of each hole.
//!
//! Two forms (`docs/cl-reader.md` has the evidence per vendor):
//!
//! - **keyword/value** (NX, SOLIDWORKS CAM, Creo, CATIA): `DEPTH,d` or `FEDTO,f` (the depth
//!   below the hole point; NX writes it negative, SOLIDWORKS positive: its magnitude counts),
//!   `CLEAR,c` (Creo, CATIA: the R plane; a Creo `RAPTO,r` advances it by r towards the hole) or
//!   `RAPTO,r` (NX, SOLIDWORKS: the R plane), `RTRCTO,h[,AUTO|MANUAL]` or `RETURN,h` (the retract
//!   height; `RTRCTO,AUTO`: the R plane; `RETURN,0`: the height the tool had before the first
//!   hole), `STEP,s`, `INCR,s`, `1STPECK,a`, `SUBPECK,b` (pecks), `DWELL,t` or `DWELL,REV,n`
//!   or `REV,n`, and the cycle's feed `MMPM|IPM|MMPR|IPR,f`;
//! - **positional** (CAMWorks): `DRILL,G98|G99,depth[,PECKING,first,next],MMPM,feed,clearance,
//!   retract[,retract],DWELL,t`.
//!
//! `CYCLE/INIT`, `CYCLE/ON` and `CYCLE/CLEAR` announce the cycle record that follows; they are
//! kept as records.

use nalgebra::Point3;

use super::{Builder, Ctx, ItemSink, arg_span, body_span, feed_word};
use crate::diagnostic::{Diagnostic, Severity};
use crate::model::*;
use crate::span::Span;
use crate::syntax::{Arg, Statement, Value};

/// The cycle words, by the motion they make.
const KINDS: [(&str, CycleKind); 9] = [
    ("DRILL", CycleKind::Drill),
    ("FACE", CycleKind::Drill),
    ("CSINK", CycleKind::Drill),
    ("DEEP", CycleKind::Deep),
    ("DEEP2", CycleKind::Deep),
    ("BRKCHP", CycleKind::ChipBreak),
    ("TAP", CycleKind::Tap),
    ("BORE", CycleKind::Bore),
    ("REAM", CycleKind::Bore),
];

/// Every word `CYCLE/` takes, for the error on an unknown one.
const KNOWN: &str = "DRILL, FACE, CSINK, DEEP, DEEP2, BRKCHP, TAP, BORE, REAM; OFF; INIT, ON, CLEAR";

/// Lengths are equal within this (mm).
const SAME_LENGTH: f64 = 1e-6;

/// A cycle waiting for its first hole (`RETURN,0`: it returns to the height the tool has before
/// the first hole).
pub(super) struct PendingCycle {
    cycle: Box<Cycle>,
    span: Span,
}

/// Where the tool returns between the holes of a `RETURN,0` cycle: the height along the tool
/// axis (absolute) and whether a hole at another height was reported.
pub(super) struct ReturnPlane {
    height: f64,
    relative: f64,
    warned: bool,
}

/// Parameters as read, in the file's unit (lengths) with the spans of their values.
#[derive(Default)]
struct Params {
    depth: Option<(f64, Span)>,
    fedto: Option<(f64, Span)>,
    clear: Option<(f64, Span)>,
    rapto: Option<(f64, Span)>,
    retract: Option<(f64, Span)>,
    /// `RTRCTO,AUTO`, `RTRCTO` without a value, CAMWorks `G99`: to the R plane (a height given
    /// wins).
    retract_auto: bool,
    /// `RETURN,0`: to the height before the first hole.
    return_to_start: bool,
    step: Option<(f64, Span)>,
    first_peck: Option<(f64, Span)>,
    next_peck: Option<(f64, Span)>,
    dwell: Option<(Delay, Span)>,
    feed: Option<(f64, FeedPer, Option<LengthUnit>, Span)>,
    /// NX `CYCLE/DRILL,DEEP|BRKCHP,…`.
    sub_kind: Option<CycleKind>,
}

/// A problem at a CYCLE statement: where, what, what was expected.
struct Problem {
    span: Span,
    message: String,
    expected: String,
}

fn problem(span: Span, message: impl Into<String>, expected: impl Into<String>) -> Problem {
    Problem { span, message: message.into(), expected: expected.into() }
}

/// A cursor over the arguments after the cycle word.
struct Cursor<'c, 'a> {
    cx: &'c Ctx<'c>,
    args: &'a [Arg<'a>],
    at: usize,
}

impl<'a> Cursor<'_, 'a> {
    fn peek(&self) -> Option<&'a Arg<'a>> {
        self.args.get(self.at..)?.iter().find(|a| a.value != Value::Empty)
    }

    fn next(&mut self) -> Option<&'a Arg<'a>> {
        while let Some(a) = self.args.get(self.at) {
            self.at += 1;
            if a.value != Value::Empty {
                return Some(a);
            }
        }
        None
    }

    /// The next argument when it is a number.
    fn number(&mut self) -> Option<(f64, Span)> {
        match self.peek()?.value {
            Value::Num(v) => {
                let a = self.next()?;
                Some((v, arg_span(self.cx, a)))
            }
            _ => None,
        }
    }

    /// The number after `key` (at `key_span`), or a problem.
    fn value_of(&mut self, key: &str, key_span: Span) -> Result<(f64, Span), Problem> {
        self.number()
            .ok_or_else(|| problem(key_span, format!("{key} without a value"), format!("expected {key},value")))
    }

    /// The next argument when it is the word `w`.
    fn word(&mut self, w: &str) -> bool {
        let is = self.peek().is_some_and(|a| matches!(a.value, Value::Word(x) if x.eq_ignore_ascii_case(w)));
        if is {
            self.next();
        }
        is
    }

    /// A span at the end of the statement, for what is missing there.
    fn end(&self) -> Span {
        let e = self.cx.rec.span.end();
        Span::new(e, e)
    }
}

impl<S: ItemSink> Builder<'_, S> {
    pub(super) fn cycle(&mut self, cx: &Ctx<'_>, st: &Statement<'_>) {
        let span = cx.rec.span;
        let args = st.args();
        let Some(at) = args.iter().position(|a| a.value != Value::Empty) else {
            return self.error(cx, body_span(cx, st), "CYCLE without a kind", format!("expected one of {KNOWN}"));
        };
        let first = &args[at];
        let Value::Word(word) = first.value else {
            return self.error(cx, arg_span(cx, first), "CYCLE without a kind", format!("expected one of {KNOWN}"));
        };
        let word = word.to_ascii_uppercase();
        match word.as_str() {
            "OFF" => {
                self.flush_cycle();
                self.in_cycle = false;
                self.cycle_return = None;
                return self.emit(span, ItemKind::CycleOff);
            }
            // Announcements: the parameters follow in the next CYCLE record.
            "INIT" | "ON" | "CLEAR" => {
                let args = cx.rec.text.split_once('/').map_or("", |(_, a)| a).trim().to_string();
                return self.emit(span, ItemKind::Record(Record { word: "CYCLE".into(), args }));
            }
            _ => {}
        }
        // A new cycle: its holes follow, whether or not it reads.
        self.flush_cycle();
        self.in_cycle = true;
        self.cycle_return = None;
        let Some(&(_, kind)) = KINDS.iter().find(|(w, _)| *w == word) else {
            return self.error(
                cx,
                arg_span(cx, first),
                format!("unknown cycle `{word}`"),
                format!("expected one of {KNOWN}"),
            );
        };
        let mut cur = Cursor { cx, args, at: at + 1 };
        let positional = match cur.peek().map(|a| a.value) {
            Some(Value::Word(w)) => w.eq_ignore_ascii_case("G98") || w.eq_ignore_ascii_case("G99"),
            Some(Value::Num(_)) => self.info.cam_system == Some(CamSystem::CamWorks),
            _ => false,
        };
        let params = if positional { self.camworks_params(&mut cur) } else { self.keyword_params(&mut cur) };
        let (mut cycle, return_to_start) = match params.and_then(|p| self.typed_cycle(cx, &cur, kind, &word, p)) {
            Ok(c) => c,
            Err(p) => return self.error(cx, p.span, p.message, p.expected),
        };
        let args = cx.rec.text.split_once('/').map_or("", |(_, a)| a);
        cycle.args = args.trim().split_once(',').map_or("", |(_, a)| a).trim().to_string();
        if return_to_start {
            self.cycle_pending = Some(PendingCycle { cycle: Box::new(cycle), span });
        } else {
            self.emit(span, ItemKind::CycleOn(Box::new(cycle)));
        }
    }

    /// `KEYWORD,value` pairs (NX, SOLIDWORKS CAM, Creo, CATIA).
    fn keyword_params(&mut self, cur: &mut Cursor<'_, '_>) -> Result<Params, Problem> {
        let mut p = Params::default();
        while let Some(a) = cur.next() {
            let key_span = arg_span(cur.cx, a);
            let key = match a.value {
                Value::Word(w) => w.to_ascii_uppercase(),
                Value::Num(_) => {
                    return Err(problem(
                        key_span,
                        "cycle value without a keyword",
                        "expected KEYWORD,value (DEPTH, FEDTO, CLEAR, RAPTO, RTRCTO, …); positional values are read in the CAMWorks form only (G98|G99,depth,…)",
                    ));
                }
                _ => return Err(problem(key_span, "unexpected cycle argument", "expected KEYWORD,value")),
            };
            match key.as_str() {
                "DEPTH" => p.depth = Some(cur.value_of(&key, key_span)?),
                "FEDTO" => p.fedto = Some(cur.value_of(&key, key_span)?),
                "CLEAR" => p.clear = Some(cur.value_of(&key, key_span)?),
                "RAPTO" => p.rapto = Some(cur.value_of(&key, key_span)?),
                "STEP" | "INCR" => p.step = Some(cur.value_of(&key, key_span)?),
                "1STPECK" => p.first_peck = Some(cur.value_of(&key, key_span)?),
                "SUBPECK" => p.next_peck = Some(cur.value_of(&key, key_span)?),
                "RTRCTO" => match cur.number() {
                    Some(v) => p.retract = Some(v),
                    None => p.retract_auto = true,
                },
                "AUTO" => p.retract_auto = true,
                "MANUAL" => {}
                "RETURN" => {
                    let (v, s) = cur.value_of(&key, key_span)?;
                    if v == 0.0 {
                        p.return_to_start = true;
                    } else {
                        p.retract = Some((v, s));
                    }
                }
                "DWELL" => {
                    let rev = cur.word("REV");
                    let (v, s) = cur.value_of(if rev { "DWELL,REV" } else { "DWELL" }, key_span)?;
                    p.dwell = Some((if rev { Delay::Revolutions(v) } else { Delay::Seconds(v) }, s));
                }
                "REV" => {
                    let (v, s) = cur.value_of(&key, key_span)?;
                    p.dwell = Some((Delay::Revolutions(v), s));
                }
                "DEEP" => p.sub_kind = Some(CycleKind::Deep),
                "BRKCHP" => p.sub_kind = Some(CycleKind::ChipBreak),
                k => match feed_word(k) {
                    Some((per, unit)) => {
                        let (v, s) = cur.value_of(&key, key_span)?;
                        p.feed = Some((v, per, unit, s));
                    }
                    None => {
                        let value = cur.number();
                        let d = Diagnostic::new(
                            Severity::Warning,
                            "cl::statement",
                            value.map_or(key_span, |(_, s)| key_span.to(s)),
                            format!("unknown cycle word `{key}`"),
                            "ignored; kept in the cycle's text".into(),
                        )
                        .with_word(Some("CYCLE".into()))
                        .with_help("known: DEPTH, FEDTO, CLEAR, RAPTO, RTRCTO, RETURN, STEP, INCR, 1STPECK, SUBPECK, DWELL, REV, MMPM, IPM, MMPR, IPR".to_string());
                        self.diag(d);
                    }
                },
            }
        }
        Ok(p)
    }

    /// CAMWorks: `G98|G99, depth [, PECKING, first, next], MMPM|…, feed, clearance, retract
    /// [, retract] [, DWELL, t]`. The retract height is the initial plane's above the hole
    /// (`G98`); `G99` returns to the R plane.
    fn camworks_params(&mut self, cur: &mut Cursor<'_, '_>) -> Result<Params, Problem> {
        let mut p = Params::default();
        let g99 = cur.word("G99");
        let g98 = !g99 && cur.word("G98");
        p.depth = Some(cur.number().ok_or_else(|| {
            problem(
                cur.peek().map_or(cur.end(), |a| arg_span(cur.cx, a)),
                "CAMWorks cycle without a depth",
                "expected G98|G99,depth,…",
            )
        })?);
        if cur.word("PECKING") {
            let at = cur.end();
            p.first_peck =
                Some(cur.number().ok_or_else(|| problem(at, "PECKING without depths", "expected PECKING,first,next"))?);
            p.next_peck = cur.number();
        }
        if let Some(a) = cur.peek()
            && let Value::Word(w) = a.value
            && let Some((per, unit)) = feed_word(w)
        {
            let key_span = arg_span(cur.cx, a);
            cur.next();
            let (v, s) = cur.value_of(&w.to_ascii_uppercase(), key_span)?;
            p.feed = Some((v, per, unit, s));
        }
        p.rapto = cur.number();
        let first = cur.number();
        if let (Some((a, _)), Some((b, span))) = (first, cur.number())
            && (a - b).abs() > SAME_LENGTH
        {
            let d = Diagnostic::new(
                Severity::Warning,
                "cl::statement",
                span,
                format!("two retract heights ({a} and {b})"),
                "the first is the return height".into(),
            )
            .with_word(Some("CYCLE".into()));
            self.diag(d);
        }
        match (g99, first) {
            (true, _) => p.retract_auto = true,
            (false, Some(r)) => p.retract = Some(r),
            (false, None) if g98 => {
                return Err(problem(
                    cur.end(),
                    "G98 cycle without its return height",
                    "expected the initial plane's height above the hole after the clearance",
                ));
            }
            (false, None) => {}
        }
        if cur.word("DWELL") {
            let at = cur.end();
            let (v, s) = cur.number().ok_or_else(|| problem(at, "DWELL without a value", "expected DWELL,seconds"))?;
            p.dwell = Some((Delay::Seconds(v), s));
        }
        if let Some(a) = cur.next() {
            return Err(problem(
                arg_span(cur.cx, a),
                "unexpected argument in a CAMWorks cycle",
                "expected the end of the statement after DWELL,t",
            ));
        }
        Ok(p)
    }

    /// The typed cycle from its parameters (lengths converted to mm), and whether its retract
    /// height waits for the first hole.
    fn typed_cycle(
        &mut self,
        cx: &Ctx<'_>,
        cur: &Cursor<'_, '_>,
        kind: CycleKind,
        word: &str,
        p: Params,
    ) -> Result<(Cycle, bool), Problem> {
        let mm = self.scale;
        let length = |v: (f64, Span)| (v.0 * mm, v.1);
        let (depth, depth_span) = p.depth.map(length).or(p.fedto.map(|(v, s)| (v.abs() * mm, s))).ok_or_else(|| {
            problem(cur.end(), format!("CYCLE/{word} without a depth"), "expected DEPTH,d or FEDTO,f")
        })?;
        if depth <= 0.0 {
            return Err(problem(
                depth_span,
                "cycle depth is zero or negative",
                "expected a depth > 0 below the hole point",
            ));
        }
        let clearance = match (p.clear.map(length), p.rapto.map(length)) {
            // Creo: RAPTO advances the rapid from the CLEAR plane towards the hole.
            (Some((c, cs)), rapto) => {
                let r = rapto.map_or(0.0, |r| r.0);
                if r > c {
                    return Err(problem(cs, "RAPTO goes below the hole point", "expected RAPTO ≤ CLEAR"));
                }
                (c - r, cs)
            }
            (None, Some(r)) => r,
            (None, None) => {
                return Err(problem(
                    cur.end(),
                    format!("CYCLE/{word} without a clearance (R plane)"),
                    "expected CLEAR,c or RAPTO,r",
                ));
            }
        };
        let (clearance, clearance_span) = clearance;
        if clearance < 0.0 {
            return Err(problem(clearance_span, "the R plane is below the hole point", "expected a clearance ≥ 0"));
        }
        let retract = match p.retract.map(length) {
            Some((r, span)) if r < clearance - SAME_LENGTH => {
                return Err(problem(
                    span,
                    "the retract height is below the R plane",
                    format!("expected a retract height ≥ the clearance ({clearance})"),
                ));
            }
            // A height given wins over AUTO; AUTO or nothing: the R plane.
            Some((r, _)) if (r - clearance).abs() <= SAME_LENGTH => None,
            Some((r, _)) => Some(r),
            None => None,
        };
        let peck = match (p.first_peck.or(p.step).map(length), p.next_peck.map(length)) {
            (Some((a, s)), next) => {
                let b = next.unwrap_or((a, s));
                if a <= 0.0 || b.0 <= 0.0 {
                    return Err(problem(
                        if a <= 0.0 { s } else { b.1 },
                        "peck depth is zero or negative",
                        "expected a peck > 0",
                    ));
                }
                Some(Peck { first: a, next: b.0 })
            }
            (None, Some((_, s))) => {
                return Err(problem(s, "SUBPECK without 1STPECK", "expected 1STPECK,a before SUBPECK,b"));
            }
            (None, None) => None,
        };
        let kind = match (p.sub_kind, kind, peck.is_some()) {
            (Some(sub), CycleKind::Drill, _) => sub,
            // CAMWorks writes a peck drilling as DRILL,…,PECKING.
            (None, CycleKind::Drill, true) => CycleKind::Deep,
            (_, k, _) => k,
        };
        if matches!(kind, CycleKind::Deep | CycleKind::ChipBreak) && peck.is_none() {
            return Err(problem(
                cur.end(),
                format!("CYCLE/{word} without a peck depth"),
                "expected STEP,s, INCR,s or 1STPECK,a[,SUBPECK,b]",
            ));
        }
        let dwell = match p.dwell {
            Some((Delay::Seconds(t) | Delay::Revolutions(t), s)) if t < 0.0 => {
                return Err(problem(s, "negative dwell", "expected a dwell ≥ 0"));
            }
            Some((Delay::Seconds(t) | Delay::Revolutions(t), _)) if t == 0.0 => None,
            Some((d, _)) => Some(d),
            None => None,
        };
        let feed = match p.feed {
            Some((v, _, _, s)) if v <= 0.0 => {
                return Err(problem(s, "the cycle's feed is not positive", "expected a feed > 0"));
            }
            Some((v, per, unit, s)) => {
                if let Some(u) = unit {
                    self.check_feed_unit(cx, u, per, s);
                }
                Some(Feed { value: v * mm, per })
            }
            None => None,
        };
        let cycle =
            Cycle { kind, depth, clearance, retract, peck, dwell, feed, word: word.to_string(), args: String::new() };
        Ok((cycle, p.return_to_start && !p.retract_auto))
    }

    /// A hole position at `to`, the top of the hole.
    pub(super) fn hole(&mut self, cx: &Ctx<'_>, to: Point3<f64>, motion: Motion) {
        // Holes are not a path: no direction for an arc's check.
        self.arc_arrival(None);
        self.arrival = None;
        let axis = self.axis.into_inner();
        if let Some(mut pending) = self.cycle_pending.take() {
            // RETURN,0: back to the height the tool had before the first hole.
            let height = self.position.map(|p| p.coords.dot(&axis));
            let above = height.map(|h| h - to.coords.dot(&axis));
            if let (Some(h), Some(a)) = (height, above) {
                if a > pending.cycle.clearance + SAME_LENGTH {
                    pending.cycle.retract = Some(a);
                }
                self.cycle_return =
                    Some(ReturnPlane { height: h, relative: a.max(pending.cycle.clearance), warned: false });
            }
            self.emit(pending.span, ItemKind::CycleOn(pending.cycle));
        } else if let Some(plane) = self.cycle_return.as_mut()
            && !plane.warned
            && (plane.height - to.coords.dot(&axis) - plane.relative).abs() > 1e-3
        {
            plane.warned = true;
            let relative = plane.relative;
            self.diag(
                Diagnostic::new(
                    Severity::Warning,
                    "cl::statement",
                    cx.rec.span,
                    "this hole is at another height than the cycle's first".into(),
                    format!("the tool returns {relative:.4} mm above each hole, as measured at the first (RETURN,0)"),
                )
                .with_word(Some("GOTO".into()))
                .with_help(
                    "RETURN,0 returns to the height the tool had before the cycle; check the clearance over this hole",
                ),
            );
        }
        self.position = Some(to);
        self.emit(cx.rec.span, ItemKind::Move(Move { to, axis: self.axis, motion, kind: MoveKind::Hole }));
    }

    /// Emits a cycle still waiting for its first hole (none came).
    pub(super) fn flush_cycle(&mut self) {
        if let Some(pending) = self.cycle_pending.take() {
            self.emit(pending.span, ItemKind::CycleOn(pending.cycle));
        }
    }
}
