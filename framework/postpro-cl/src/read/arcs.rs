//! Arcs: `CIRCLE` and `MOVARC` records completed by their end `GOTO`, evaluated APT
//! `TLON,GOFWD` motion, and the **sense** of arcs.
//!
//! The axis vector a `CIRCLE` or `MOVARC` record writes does not mean the same in every CAM
//! system: NX and Makino FFCAM arcs run clockwise about it, SOLIDWORKS CAM, Creo and Fusion
//! counter-clockwise ([`CamSystem::arc_sense`]); CAMWorks spells the sense out
//! (`CLOCKWISE`/`COUNTERCLOCKWISE`). The sense of an arc whose record does not spell it out is,
//! in order: `ReadOptions::arc_sense`, the CAM system's convention, or (CAM system unknown) the
//! majority of what the tangent moves of the file's arcs say, found by a first reading pass
//! (`SensePlan::Survey`). When nothing decides, the first such arc is an error.
//!
//! Every arc is checked against its neighbours: the straight move (or NURBS end) before it must
//! arrive, and the one after it leave, along the arc's direction of motion, where that move is
//! tangent to the circle within [`TANGENT_DEGREES`]. A neighbour against the sense read is a
//! warning naming the arc's line; the arc keeps its sense. The counts are in
//! [`ArcChecks`](crate::ArcChecks).

use nalgebra::{Point3, Unit, Vector3};

use super::{Builder, Ctx, ItemSink, MAX_MAGNITUDE, arg_span, args_span, body_span, line_word};
use crate::diagnostic::{Diagnostic, Severity};
use crate::model::*;
use crate::span::Span;
use crate::syntax::{self, Arg, Body, Statement, Value};
use crate::words::Word;

/// A neighbour is tangent when its direction is within this angle of the arc's tangent line.
pub(super) const TANGENT_DEGREES: f64 = 5.0;

/// Moves shorter than this (mm) give no direction: printed coordinates are rounded.
const MIN_NEIGHBOUR: f64 = 0.01;

/// Arcs of a smaller radius (mm) give no tangent direction.
const MIN_RADIUS: f64 = 0.01;

/// How the sense of the file's arcs is decided while reading.
#[derive(Clone, Copy, Debug)]
pub(super) enum SensePlan {
    /// Arcs whose record does not spell the sense out run in this sense about their axis.
    Known(ArcSense, ArcSenseOrigin),
    /// First pass of a file whose CAM system has no convention: arcs are read counter-clockwise
    /// and the tangent moves vote.
    Survey,
    /// Nothing decided (the tangent moves of the survey: counter-clockwise and clockwise votes):
    /// the first arc that needs a sense is an error.
    Unknown { ccw: usize, cw: usize },
}

impl SensePlan {
    /// The sense applied to arcs that do not spell it out (counter-clockwise where none is known:
    /// the survey's provisional reading, or after the error).
    fn sense(self) -> ArcSense {
        match self {
            SensePlan::Known(s, _) => s,
            SensePlan::Survey | SensePlan::Unknown { .. } => ArcSense::Ccw,
        }
    }
}

/// Votes of the survey pass: arcs whose tangent neighbours all say one sense about the axis as
/// written.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct SenseVotes {
    pub(super) ccw: usize,
    pub(super) cw: usize,
}

impl SenseVotes {
    /// The plan for the reading pass.
    pub(super) fn plan(self) -> SensePlan {
        let origin = ArcSenseOrigin::Tangency { ccw: self.ccw, cw: self.cw };
        match self.ccw.cmp(&self.cw) {
            std::cmp::Ordering::Greater => SensePlan::Known(ArcSense::Ccw, origin),
            std::cmp::Ordering::Less => SensePlan::Known(ArcSense::Cw, origin),
            std::cmp::Ordering::Equal => SensePlan::Unknown { ccw: self.ccw, cw: self.cw },
        }
    }
}

pub(super) struct PendingArc {
    center: Point3<f64>,
    /// The axis the motion is counter-clockwise about.
    normal: Unit<Vector3<f64>>,
    /// The axis as written.
    written: Unit<Vector3<f64>>,
    radius: Option<f64>,
    /// Extra full turns (NX `TIMES,n`).
    turns: u32,
    /// The sweep in radians (MOVARC).
    sweep: Option<f64>,
    pub(super) span: Span,
    pub(super) word: &'static str,
    /// The sense word of the record (`CLOCKWISE`, …), when it spells the sense out.
    explicit: Option<&'static str>,
}

/// An arc waiting for the move after it.
pub(super) struct ArcCheck {
    span: Span,
    word: &'static str,
    explicit: Option<&'static str>,
    normal: Unit<Vector3<f64>>,
    written: Unit<Vector3<f64>>,
    center: Point3<f64>,
    end: Point3<f64>,
    before: Option<Neighbour>,
}

/// What a tangent neighbour says.
#[derive(Clone, Copy)]
struct Neighbour {
    /// It runs along the arc's motion.
    agrees: bool,
    /// Its statement.
    span: Span,
}

/// The direction of the last motion that ended at the current position, with its statement:
/// a straight move, or the end of a NURBS (arcs give none: their direction is what is checked).
#[derive(Clone, Copy)]
pub(super) struct Arrival {
    pub(super) direction: Vector3<f64>,
    pub(super) span: Span,
}

/// Whether `direction`, at `point` of the circle about `center` in the plane normal to `normal`,
/// runs along the motion counter-clockwise about `normal` (`Some(true)`), against it
/// (`Some(false)`), or is not tangent to the circle within [`TANGENT_DEGREES`] (`None`).
fn tangency(
    normal: &Vector3<f64>,
    center: &Point3<f64>,
    point: &Point3<f64>,
    direction: &Vector3<f64>,
) -> Option<bool> {
    let d = point - center;
    let radial = d - normal * d.dot(normal);
    let tangent = normal.cross(&radial);
    let (t, n) = (tangent.norm(), direction.norm());
    if radial.norm() < MIN_RADIUS || t == 0.0 || n < MIN_NEIGHBOUR {
        return None;
    }
    let cos = tangent.dot(direction) / (t * n);
    let limit = TANGENT_DEGREES.to_radians().cos();
    if cos >= limit {
        Some(true)
    } else if cos <= -limit {
        Some(false)
    } else {
        None
    }
}

/// `clockwise` or `counter-clockwise`.
fn sense_words(s: ArcSense) -> &'static str {
    match s {
        ArcSense::Cw => "clockwise",
        ArcSense::Ccw => "counter-clockwise",
    }
}

impl<S: ItemSink> Builder<'_, S> {
    pub(super) fn circle(&mut self, cx: &Ctx<'_>, st: &Statement<'_>) {
        let Body::Args(args) = st.body else {
            let span = cx.rec.span;
            return self.error(cx, span, "CIRCLE without arguments", "expected CIRCLE/cx,cy,cz,i,j,k[,r,…]");
        };
        let mut nums: smallvec::SmallVec<[f64; 16]> = smallvec::SmallVec::new();
        let mut explicit = None;
        let mut turns = 0u32;
        let mut i = 0;
        while i < args.len() {
            let a = &args[i];
            match a.value {
                Value::Num(v) => nums.push(v),
                Value::Word(w) if w.eq_ignore_ascii_case("CLOCKWISE") || w.eq_ignore_ascii_case("CLW") => {
                    explicit = Some((ArcSense::Cw, "CLOCKWISE"));
                }
                Value::Word(w) if w.eq_ignore_ascii_case("COUNTERCLOCKWISE") || w.eq_ignore_ascii_case("CCLW") => {
                    explicit = Some((ArcSense::Ccw, "COUNTERCLOCKWISE"));
                }
                Value::Word(w) if w.eq_ignore_ascii_case("TIMES") => {
                    match args.get(i + 1).map(|a| a.value) {
                        Some(Value::Num(n)) if n >= 1.0 && n.fract() == 0.0 && n < 1e6 => turns = n as u32,
                        _ => {
                            return self.error(
                                cx,
                                arg_span(cx, a),
                                "TIMES needs a whole number of turns",
                                "expected TIMES,n with n ≥ 1",
                            );
                        }
                    }
                    i += 1;
                }
                Value::Empty => {}
                _ => {
                    return self.error(
                        cx,
                        arg_span(cx, a),
                        "unexpected CIRCLE argument",
                        "expected a number, CLOCKWISE, COUNTERCLOCKWISE or TIMES,n",
                    );
                }
            }
            i += 1;
        }
        if nums.len() < 6 || nums.iter().any(|v| !v.is_finite()) {
            let span = body_span(cx, st);
            return self.error(
                cx,
                span,
                format!("CIRCLE has {} numbers", nums.len()),
                "expected at least the centre and axis: cx,cy,cz,i,j,k[,r]",
            );
        }
        let span = body_span(cx, st);
        let Some(written) = self.direction(cx, args_span(cx, st, 3, 6), nums[3], nums[4], nums[5]) else { return };
        let radius = nums.get(6).map(|r| r * self.scale);
        if radius.is_some_and(|r| r <= 0.0) {
            return self.error(cx, span, "CIRCLE radius is not positive", "expected a radius > 0");
        }
        let sense = match explicit {
            Some((s, _)) => s,
            None => self.sense.sense(),
        };
        let normal = if sense == ArcSense::Cw { -written } else { written };
        // NX TIMES,n: n turns in all, i.e. n-1 full turns besides the final partial one.
        let turns = turns.saturating_sub(1);
        let center = self.point(nums[0], nums[1], nums[2]);
        self.arc = Some(PendingArc {
            center,
            normal,
            written,
            radius,
            turns,
            sweep: None,
            span: cx.rec.span,
            word: "CIRCLE",
            explicit: explicit.map(|(_, w)| w),
        });
    }

    pub(super) fn movarc(&mut self, cx: &Ctx<'_>, st: &Statement<'_>) {
        let Body::Args(args) = st.body else {
            let span = cx.rec.span;
            return self.error(cx, span, "MOVARC without arguments", "expected MOVARC/cx,cy,cz,i,j,k,r,ANGLE,deg");
        };
        let mut nums: smallvec::SmallVec<[f64; 8]> = smallvec::SmallVec::new();
        let mut angle = None;
        let mut k = 0;
        while k < args.len() {
            match args[k].value {
                Value::Num(v) => nums.push(v),
                Value::Word(w) if w.eq_ignore_ascii_case("ANGLE") => {
                    if let Some(Value::Num(a)) = args.get(k + 1).map(|a| a.value) {
                        angle = Some(a);
                        k += 1;
                    }
                }
                _ => {}
            }
            k += 1;
        }
        let span = body_span(cx, st);
        let (Some(angle), 7) = (angle, nums.len()) else {
            return self.error(cx, span, "malformed MOVARC", "expected MOVARC/cx,cy,cz,i,j,k,r,ANGLE,deg");
        };
        let Some(written) = self.direction(cx, span, nums[3], nums[4], nums[5]) else { return };
        // A negative ANGLE turns the other way.
        let forward = (self.sense.sense() == ArcSense::Ccw) == (angle >= 0.0);
        let normal = if forward { written } else { -written };
        let sweep = angle.abs().to_radians();
        let center = self.point(nums[0], nums[1], nums[2]);
        let radius = Some(nums[6] * self.scale);
        self.arc = Some(PendingArc {
            center,
            normal,
            written,
            radius,
            turns: 0,
            sweep: Some(sweep),
            span: cx.rec.span,
            word: "MOVARC",
            explicit: None,
        });
    }

    pub(super) fn abandon_arc(&mut self) {
        if let Some(arc) = self.arc.take() {
            let message = format!("{} is not followed by its end point", arc.word);
            self.arc_error(&arc, arc.span, message, "expected a GOTO to the arc's end point next");
        }
    }

    /// A diagnostic about an arc, counted under the arc's word (not the GOTO that ends it).
    fn arc_error(&mut self, arc: &PendingArc, span: Span, message: String, label: &str) {
        let d = Diagnostic::new(Severity::Error, "cl::statement", span, message, label.into());
        self.diag(d.with_word(Some(arc.word.into())));
    }

    pub(super) fn finish_arc(&mut self, cx: &Ctx<'_>, end: Point3<f64>, motion: Motion) {
        let Some(arc) = self.arc.take() else { return };
        let span = arc.span.to(cx.rec.span);
        let Some(start) = self.position else {
            let message = format!("{} with no start point", arc.word);
            return self.arc_error(&arc, arc.span, message, "expected a GOTO or FROM before the arc");
        };
        let n = arc.normal.into_inner();
        let radial = |p: Point3<f64>| {
            let d = p - arc.center;
            d - n * d.dot(&n)
        };
        let (rs, re) = (radial(start), radial(end));
        let radius = arc.radius.unwrap_or_else(|| rs.norm());
        // Files print 4 to 6 decimals: allow for their rounding, in the file's unit.
        let tol = (radius * 1e-3).max(0.005 * self.scale);
        if (rs.norm() - radius).abs() > tol || (re.norm() - radius).abs() > tol {
            let (ds, de) = (rs.norm() - radius, re.norm() - radius);
            let message = format!(
                "{} end points are off the circle (start {ds:+.4} mm, end {de:+.4} mm from r = {radius:.4})",
                arc.word
            );
            let d = Diagnostic::new(Severity::Warning, "cl::statement", span, message, "arc kept as written".into());
            self.diag(d.with_word(Some(arc.word.into())));
        }
        if rs.norm() < 1e-9 || re.norm() < 1e-9 {
            let message = format!("{} starts or ends at its centre", arc.word);
            return self.arc_error(&arc, span, message, "expected end points on the circle");
        }
        let mut sweep = rs.cross(&re).dot(&n).atan2(rs.dot(&re));
        if sweep <= 1e-12 {
            sweep += std::f64::consts::TAU;
        }
        sweep += f64::from(arc.turns) * std::f64::consts::TAU;
        if let Some(given) = arc.sweep {
            let full = (given / std::f64::consts::TAU).floor();
            let candidate = sweep % std::f64::consts::TAU + full * std::f64::consts::TAU;
            sweep = if (candidate - given).abs() < 1e-3 { candidate } else { given.max(sweep) };
        }
        // The move after the previous arc is this arc: no evidence for it.
        self.arc_arrival(None);
        if arc.explicit.is_none() {
            self.need_sense(span, arc.word);
        }
        let before = self.arrival.take().and_then(|a| {
            tangency(&n, &arc.center, &start, &a.direction).map(|agrees| Neighbour { agrees, span: a.span })
        });
        self.arc_info.checks.arcs += 1;
        self.arc_check = Some(ArcCheck {
            span,
            word: arc.word,
            explicit: arc.explicit,
            normal: arc.normal,
            written: arc.written,
            center: arc.center,
            end,
            before,
        });
        self.position = Some(end);
        let arc = Arc { start, center: arc.center, normal: arc.normal, radius, end, sweep, axis: self.axis, motion };
        self.emit(span, ItemKind::Arc(Box::new(arc)));
    }

    /// The first arc that needs a sense when nothing decided it is an error.
    fn need_sense(&mut self, span: Span, word: &'static str) {
        let SensePlan::Unknown { ccw, cw } = self.sense else { return };
        if std::mem::replace(&mut self.sense_error_reported, true) {
            return;
        }
        let why = if ccw + cw == 0 {
            "the CAM system is not recognised and no arc has a straight move tangent to it".to_string()
        } else {
            format!(
                "the CAM system is not recognised and the moves tangent to the arcs disagree ({ccw} arcs counter-clockwise, {cw} clockwise about their axis)"
            )
        };
        let d = Diagnostic::new(
            Severity::Error,
            "cl::arc-sense",
            span,
            format!("the sense of this file's arcs is unknown: {why}"),
            "expected a sense for this arc".into(),
        )
        .with_word(Some(word.into()))
        .with_help(
            "set --arc-sense cw|ccw: the sense in which the CAM system's arcs run about the axis vector written in \
             CIRCLE/MOVARC (NX and Makino FFCAM: cw; SOLIDWORKS CAM, Creo and Fusion: ccw)",
        );
        self.diag(d);
    }

    /// The next motion after an arc: a straight move or NURBS leaving the arc's end point in
    /// `direction` (its statement), or anything else (`None`). Concludes the arc's check.
    pub(super) fn arc_arrival(&mut self, leaving: Option<Arrival>) {
        let Some(check) = self.arc_check.take() else { return };
        let after = leaving.and_then(|a| {
            tangency(&check.normal, &check.center, &check.end, &a.direction)
                .map(|agrees| Neighbour { agrees, span: a.span })
        });
        self.conclude(&check, after);
    }

    /// Counts, votes and warns for an arc whose neighbours are known.
    fn conclude(&mut self, check: &ArcCheck, after: Option<Neighbour>) {
        let said: smallvec::SmallVec<[(Neighbour, &str); 2]> =
            [(check.before, "before"), (after, "after")].into_iter().filter_map(|(n, w)| n.map(|n| (n, w))).collect();
        if said.is_empty() {
            return;
        }
        let checks = &mut self.arc_info.checks;
        checks.checkable += 1;
        let against: smallvec::SmallVec<[(Neighbour, &str); 2]> =
            said.iter().copied().filter(|(n, _)| !n.agrees).collect();
        if against.is_empty() {
            checks.agree += 1;
        } else {
            checks.contradict += 1;
        }
        if check.explicit.is_none() && (against.is_empty() || against.len() == said.len()) {
            // Survey: the provisional reading is counter-clockwise about the axis as written.
            if against.is_empty() { self.votes.ccw += 1 } else { self.votes.cw += 1 }
        }
        if against.is_empty() || matches!(self.sense, SensePlan::Survey) {
            return;
        }
        let read = if check.normal.dot(&check.written) > 0.0 { ArcSense::Ccw } else { ArcSense::Cw };
        let moves: Vec<String> = against
            .iter()
            .map(|(n, w)| format!("the move {w} it (line {})", self.line_of(n.span.start as usize)))
            .collect();
        let (a, b) = (sense_words(read), sense_words(read.reversed()));
        let why = match (check.explicit, self.sense) {
            (Some(word), _) => format!("the record says {word}"),
            (None, SensePlan::Known(s, ArcSenseOrigin::CamSystem(c))) => format!(
                "{} arcs run {} about the axis vector they write; if this file's do not, read it with --arc-sense {}",
                c.name(),
                sense_words(s),
                s.reversed().name()
            ),
            (None, SensePlan::Known(s, ArcSenseOrigin::Option)) => {
                format!("--arc-sense {} says so; check that it fits this file", s.name())
            }
            (None, SensePlan::Known(s, ArcSenseOrigin::Tangency { ccw, cw })) => format!(
                "the CAM system is not recognised; the moves tangent to this file's arcs say {} ({ccw} arcs counter-clockwise, {cw} clockwise); set --arc-sense to decide otherwise",
                sense_words(s)
            ),
            _ => "no sense was decided for this file".into(),
        };
        let d = Diagnostic::new(
            Severity::Warning,
            "cl::arc-sense",
            check.span,
            format!(
                "{} arc read {a} about its axis vector, but {} {} {b} along it",
                check.word,
                moves.join(" and "),
                if moves.len() > 1 { "run" } else { "runs" }
            ),
            format!("kept {a}"),
        )
        .with_word(Some(check.word.into()))
        .with_help(why);
        self.diag(d);
    }

    /// `TLON,GOFWD/(CIRCLE/cx,cy,cz,r),ON,(LINE/x1,y1,z1,x2,y2,z2)`: the arc from the current point
    /// around the circle, leaving in the INDIRV direction, ending on the line.
    pub(super) fn go_motion(&mut self, cx: &Ctx<'_>, st: &Statement<'_>) {
        let span = cx.rec.span;
        let expected = "expected TLON,GOFWD/(CIRCLE/cx,cy,cz,r),ON,(LINE/x1,y1,z1,x2,y2,z2)";
        let Body::Args(args) = st.body else { return self.apt_source(cx, st) };
        let groups: smallvec::SmallVec<[(&str, &Arg<'_>); 2]> =
            args.iter().filter_map(|a| if let Value::Group(g) = a.value { Some((g, a)) } else { None }).collect();
        let modifier_on = args.iter().any(|a| matches!(a.value, Value::Word(w) if w.eq_ignore_ascii_case("ON")));
        if groups.len() != 2 || !modifier_on || !st.major.to_ascii_uppercase().ends_with("GOFWD") {
            return self.apt_source(cx, st);
        }
        let parse_group = |(g, a): (&str, &Arg<'_>)| -> Option<(Word, Vec<f64>, Span)> {
            let mut buf = syntax::Args::new();
            let s = syntax::statement(g, &mut buf).ok()?;
            let nums = match &s.body {
                Body::Args(x) => x
                    .iter()
                    .map(|x| if let Value::Num(v) = x.value { Some(v) } else { None })
                    .collect::<Option<Vec<_>>>()?,
                _ => return None,
            };
            Some((s.word, nums, arg_span(cx, a)))
        };
        let (Some(circle), Some(line)) = (parse_group(groups[0]), parse_group(groups[1])) else {
            return self.error(cx, span, "cannot evaluate APT motion", expected);
        };
        // The groups' numbers, as any interpreted statement's (`2.E40000` is infinite).
        let out_of_range = |v: &f64| (v * self.scale).is_nan() || (v * self.scale).abs() > MAX_MAGNITUDE;
        if let Some(group) = [&circle, &line].into_iter().find(|g| g.1.iter().any(out_of_range)) {
            return self.error(
                cx,
                group.2,
                "number out of range",
                "expected a number within ±1e9 (mm, mm/min, s, rpm, rad)",
            );
        }
        if circle.0 != Word::Circle || circle.1.len() != 4 || line.1.len() != 6 || !line_word(groups[1].0) {
            return self.error(cx, circle.2.to(line.2), "cannot evaluate APT motion", expected);
        }
        let Some(start) = self.position else {
            return self.error(cx, span, "APT motion with no start point", "expected a GOTO or FROM before it");
        };
        let Some(dir) = self.indirv else {
            return self.error(cx, span, "APT motion without a direction", "expected INDIRV/i,j,k before GOFWD");
        };
        let c = self.point(circle.1[0], circle.1[1], circle.1[2]);
        let r = circle.1[3] * self.scale;
        let p1 = self.point(line.1[0], line.1[1], line.1[2]);
        let p2 = self.point(line.1[3], line.1[4], line.1[5]);
        let radial = start - c;
        let Some(normal) = Unit::try_new(radial.cross(&dir), 1e-9) else {
            return self.error(
                cx,
                span,
                "INDIRV is along the radius",
                "expected a direction that leaves the circle tangentially",
            );
        };
        if (radial.norm() - r).abs() > (r * 1e-3).max(0.002) {
            self.warn(
                cx,
                circle.2,
                format!("the start point is {:+.4} mm off the circle", radial.norm() - r),
                "arc kept as written",
                None,
            );
        }
        // Intersections of the circle (centre c, radius r, plane ⟂ normal) with the line.
        let d = p2 - p1;
        let (u, v) = (radial.normalize(), normal.cross(&radial).normalize());
        let mut best: Option<(f64, Point3<f64>)> = None;
        for k in 0..720 {
            // Coarse scan of the sweep, then refine by bisection on the distance to the line.
            let a0 = f64::from(k) * std::f64::consts::TAU / 720.0;
            let a1 = a0 + std::f64::consts::TAU / 720.0;
            let f = |a: f64| {
                let p = c + (u * a.cos() + v * a.sin()) * r;
                let w = p - p1;
                // Signed distance in the circle's plane, across the line.
                w.cross(&d).dot(&normal)
            };
            let (f0, f1) = (f(a0), f(a1));
            if f0.signum() != f1.signum() {
                let (mut lo, mut hi) = (a0, a1);
                for _ in 0..60 {
                    let mid = 0.5 * (lo + hi);
                    if f(lo).signum() == f(mid).signum() { lo = mid } else { hi = mid }
                }
                let a = 0.5 * (lo + hi);
                if a > 1e-9 {
                    best = Some((a, c + (u * a.cos() + v * a.sin()) * r));
                    break;
                }
            }
        }
        let Some((sweep, end)) = best else {
            return self.error(
                cx,
                line.2,
                "the circle does not meet the LINE",
                "expected a LINE that crosses the CIRCLE",
            );
        };
        let motion = self.motion();
        // Geometric: its sense comes from INDIRV, nothing to check.
        self.arc_arrival(None);
        self.arrival = None;
        self.position = Some(end);
        let arc = Arc { start, center: c, normal, radius: r, end, sweep, axis: self.axis, motion };
        self.indirv = Some(normal.cross(&(end - c)).normalize());
        self.emit(span, ItemKind::Arc(Box::new(arc)));
    }
}
