//! The typed tool path in the part frame: what the later stages (IKT, prediction, emission)
//! consume. All lengths are millimetres, angles radians, feeds mm/min or mm/rev, whatever the
//! file's units were; every item keeps the span of the statement it came from.

use std::collections::BTreeMap;

use nalgebra::{Isometry3, Point3, Unit, Vector3};

use crate::diagnostic::Diagnostic;
use crate::span::Span;

/// A unit tool-axis vector, pointing from the tool tip towards the spindle.
pub type ToolAxis = Unit<Vector3<f64>>;

/// A tool path read from one CL file.
#[derive(Clone, Debug, Default)]
pub struct ToolPath {
    /// The items in file order.
    pub items: Vec<Item>,
    /// Program-level facts.
    pub info: ProgramInfo,
    /// Warnings and errors, in file order.
    pub diagnostics: Vec<Diagnostic>,
}

impl ToolPath {
    /// True when at least one diagnostic is an error.
    pub fn has_errors(&self) -> bool {
        self.diagnostics.iter().any(Diagnostic::is_error)
    }

    /// True when a feed move turns the tool axis (simultaneous 4- or 5-axis cutting), false for
    /// 3-axis and 3+2 programs, whose tool axis changes only at rapids.
    pub fn turns_tool_while_cutting(&self) -> bool {
        let mut axis: Option<ToolAxis> = None;
        for item in &self.items {
            if let ItemKind::Move(m) = &item.kind {
                let turned = axis.is_some_and(|a| (a.into_inner() - m.axis.into_inner()).norm() > 1e-6);
                if turned && matches!(m.motion, Motion::Feed(_)) {
                    return true;
                }
                axis = Some(m.axis);
            }
        }
        false
    }

    /// The linear moves, in order.
    pub fn moves(&self) -> impl Iterator<Item = (&Move, Span)> {
        self.items.iter().filter_map(|i| match &i.kind {
            ItemKind::Move(m) => Some((m, i.span)),
            _ => None,
        })
    }
}

/// Program-level facts gathered while reading.
#[derive(Clone, Debug, Default)]
pub struct ProgramInfo {
    /// The CAM system, when the file says or its vocabulary gives it away.
    pub cam_system: Option<CamSystem>,
    /// The length unit the file was written in (values are converted to mm).
    pub units: UnitsInfo,
    /// PARTNO text.
    pub part_name: Option<String>,
    /// Words carried through without interpretation, with their counts and first use.
    pub uninterpreted: BTreeMap<String, WordUse>,
    /// Lines that are not APT (NX listing header and footer).
    pub listing_lines: usize,
    /// `FROM` statements before the first tool change and the first move: where the tool starts,
    /// read for the position and the tool axis but not a move (no tool is known to move yet,
    /// and the machine moves to the first position after the tool change anyway).
    pub start_points: Option<Occurrences>,
    /// Statements read.
    pub statements: usize,
    /// The file is an APT part program (source language), not CL data.
    pub apt_source: bool,
    /// The sense applied to CIRCLE and MOVARC arcs, where it came from, and how it agreed with
    /// the moves tangent to the arcs.
    pub arc_sense: ArcSenseInfo,
}

/// How often something occurs and where first.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Occurrences {
    /// How many.
    pub count: usize,
    /// The first.
    pub first: Span,
}

/// How often a word occurs and where first.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct WordUse {
    /// Number of records.
    pub count: usize,
    /// The first record.
    pub first: Span,
    /// False for words the reader knows but that have no effect on the tool path (`PAINT`).
    pub unknown: bool,
}

/// A CAM system recognised from the file.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub enum CamSystem {
    /// Siemens NX (CLSF or Information-window listing).
    #[serde(rename = "Siemens NX")]
    SiemensNx,
    /// Dassault CATIA V5.
    #[serde(rename = "CATIA V5")]
    CatiaV5,
    /// PTC Creo.
    #[serde(rename = "PTC Creo")]
    Creo,
    /// SOLIDWORKS CAM (`.apt`).
    #[serde(rename = "SOLIDWORKS CAM")]
    SolidworksCam,
    /// CAMWorks (`.clt`).
    #[serde(rename = "CAMWorks")]
    CamWorks,
    /// Makino FFCAM.
    #[serde(rename = "Makino FFCAM")]
    MakinoFfcam,
    /// Autodesk Fusion (HSM APT post).
    #[serde(rename = "Autodesk Fusion")]
    Fusion,
    /// The postpro example generator.
    #[serde(rename = "postpro example generator")]
    PostproExamples,
}

impl CamSystem {
    /// The sense in which this CAM system's CIRCLE (or MOVARC) arcs run about the axis vector it
    /// writes, measured on real files (`docs/cl-reader.md`): clockwise for Siemens NX and Makino
    /// FFCAM, counter-clockwise for SOLIDWORKS CAM, PTC Creo and Autodesk Fusion. `None` where
    /// the records spell it out (CAMWorks: `CLOCKWISE`/`COUNTERCLOCKWISE`) or where no file
    /// showed it (CATIA V5 writes arcs as `TLON,GOFWD` motion, which is geometric; the example
    /// generator writes no arcs): there the tangency of the neighbouring moves decides.
    pub fn arc_sense(self) -> Option<ArcSense> {
        match self {
            CamSystem::SiemensNx | CamSystem::MakinoFfcam => Some(ArcSense::Cw),
            CamSystem::SolidworksCam | CamSystem::Creo | CamSystem::Fusion => Some(ArcSense::Ccw),
            CamSystem::CamWorks | CamSystem::CatiaV5 | CamSystem::PostproExamples => None,
        }
    }

    /// Every CAM system, in declaration order (`CamSystem as usize` indexes it).
    pub const ALL: [CamSystem; 8] = [
        CamSystem::SiemensNx,
        CamSystem::CatiaV5,
        CamSystem::Creo,
        CamSystem::SolidworksCam,
        CamSystem::CamWorks,
        CamSystem::MakinoFfcam,
        CamSystem::Fusion,
        CamSystem::PostproExamples,
    ];

    /// Display name.
    pub fn name(self) -> &'static str {
        match self {
            CamSystem::SiemensNx => "Siemens NX",
            CamSystem::CatiaV5 => "CATIA V5",
            CamSystem::Creo => "PTC Creo",
            CamSystem::SolidworksCam => "SOLIDWORKS CAM",
            CamSystem::CamWorks => "CAMWorks",
            CamSystem::MakinoFfcam => "Makino FFCAM",
            CamSystem::Fusion => "Autodesk Fusion",
            CamSystem::PostproExamples => "postpro example generator",
        }
    }
}

/// A length unit.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum LengthUnit {
    /// Millimetres.
    #[default]
    Mm,
    /// Inches (converted to mm at 25.4).
    Inch,
}

impl LengthUnit {
    /// Millimetres per unit.
    pub fn to_mm(self) -> f64 {
        match self {
            LengthUnit::Mm => 1.0,
            LengthUnit::Inch => 25.4,
        }
    }

    /// Short name.
    pub fn name(self) -> &'static str {
        match self {
            LengthUnit::Mm => "mm",
            LengthUnit::Inch => "inch",
        }
    }
}

/// The sense in which an arc runs about the axis vector written in its `CIRCLE` or `MOVARC`
/// record (a negative MOVARC `ANGLE` reverses it).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum ArcSense {
    /// Clockwise about the axis vector, seen from its tip (left-handed).
    Cw,
    /// Counter-clockwise about the axis vector, seen from its tip (right-hand rule).
    Ccw,
}

impl ArcSense {
    /// `cw` or `ccw`.
    pub fn name(self) -> &'static str {
        match self {
            ArcSense::Cw => "cw",
            ArcSense::Ccw => "ccw",
        }
    }

    /// The other sense.
    pub fn reversed(self) -> ArcSense {
        match self {
            ArcSense::Cw => ArcSense::Ccw,
            ArcSense::Ccw => ArcSense::Cw,
        }
    }
}

/// The sense applied to the arcs of a file whose records do not spell it out.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ArcSenseInfo {
    /// The sense; `None` when nothing decided it (an error at the first such arc) or no arc
    /// needed one.
    pub sense: Option<ArcSense>,
    /// What decided it.
    pub origin: ArcSenseOrigin,
    /// How the arcs agreed with the moves tangent to them.
    pub checks: ArcChecks,
}

/// What decided the sense of a file's arcs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ArcSenseOrigin {
    /// Nothing: no arc needed it, or nothing decided it.
    #[default]
    None,
    /// The recognised CAM system's convention ([`CamSystem::arc_sense`]).
    CamSystem(CamSystem),
    /// [`ReadOptions::arc_sense`](crate::ReadOptions::arc_sense) (`--arc-sense`).
    Option,
    /// The moves tangent to the arcs, CAM system unknown: arcs whose neighbours say
    /// counter-clockwise and clockwise about the axis as written.
    Tangency {
        /// Arcs whose tangent neighbours say counter-clockwise.
        ccw: usize,
        /// Arcs whose tangent neighbours say clockwise.
        cw: usize,
    },
}

/// Arcs checked against the straight moves (or NURBS ends) tangent to them: the move before an
/// arc must arrive, and the move after it leave, along the arc's direction of motion.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct ArcChecks {
    /// `CIRCLE` and `MOVARC` arcs read (evaluated APT motion excluded: its sense is geometric).
    pub arcs: usize,
    /// Arcs with at least one neighbour tangent to the circle (within a few degrees).
    pub checkable: usize,
    /// Checkable arcs whose every tangent neighbour agrees with the sense read.
    pub agree: usize,
    /// Checkable arcs with a tangent neighbour against the sense read (each has a warning).
    pub contradict: usize,
}

/// The file's length unit and where it came from.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct UnitsInfo {
    /// The unit.
    pub unit: LengthUnit,
    /// What decided it.
    pub origin: UnitsOrigin,
}

/// What decided the file's length unit.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum UnitsOrigin {
    /// A `UNITS`/`UNIT` statement.
    Declared(Span),
    /// The unit word of a `FEDRAT` (NX writes no UNITS statement).
    FeedWord(Span),
    /// Nothing in the file: millimetres assumed.
    #[default]
    Assumed,
    /// [`ReadOptions::cl_units`](crate::ReadOptions::cl_units) (`--cl-units`), whatever the
    /// file declares.
    Option,
}

/// One item of the tool path with the span of its statement.
#[derive(Clone, Debug, PartialEq)]
pub struct Item {
    /// The statement (or statements, for an arc with its end GOTO).
    pub span: Span,
    /// What it is.
    pub kind: ItemKind,
}

/// What a tool-path item is.
#[derive(Clone, Debug, PartialEq)]
pub enum ItemKind {
    /// A straight move (GOTO, FROM, GODLTA, a hole position in a cycle).
    Move(Move),
    /// A circular or helical arc (CIRCLE or MOVARC with its end GOTO, or evaluated APT motion).
    Arc(Box<Arc>),
    /// A NURBS curve (NX `NURBS`/`KNOT`/`CNTRL`).
    Nurbs(Box<Nurbs>),
    /// A tool change.
    ToolChange(ToolChange),
    /// A tool pre-selection (`SELECT/TOOL,n`).
    ToolSelect(u32),
    /// Tool geometry (`CUTTER`, `TLDATA`).
    ToolShape(ToolShape),
    /// Spindle state.
    Spindle(Spindle),
    /// Coolant state.
    Coolant(Coolant),
    /// Cutter radius compensation.
    CutterComp(CutterComp),
    /// A canned cycle starts (`CYCLE/…`); the following moves are hole positions
    /// ([`MoveKind::Hole`], each at the top of its hole) until [`ItemKind::CycleOff`].
    CycleOn(Box<Cycle>),
    /// The canned cycle ends (`CYCLE/OFF`).
    CycleOff,
    /// A dwell, in seconds or spindle revolutions.
    Delay(Delay),
    /// Program stop, with an optional message.
    Stop(Option<String>),
    /// Optional stop.
    OptionalStop,
    /// Operator or program text (PPRINT, INSERT, TPRINT, PARTNO, REMARK, operation names).
    Text(TextKind, String),
    /// A whole-line `$$` comment.
    Comment(String),
    /// An operation starts, with its name: NX `TOOL PATH/name,…`, CAMWorks `OPFEATSTART/name`,
    /// CATIA `$$ OPERATION NAME : name`, Creo `$$-> FEATNO / n` (named `FEATNO n`), Makino
    /// `PPRINT/BEGIN-SECTION,MACHINING` (named `MACHINING`).
    OperationStart(String),
    /// An operation ends (`END-OF-PATH`, `OPFEATEND/…`).
    OperationEnd,
    /// The frame the following points are written in changed.
    Frame(Box<FrameChange>),
    /// `MULTAX` on or off.
    Multax(bool),
    /// End of program (`END`).
    End,
    /// End of file (`FINI`).
    Fini,
    /// A record carried through without interpretation (unknown or passive word).
    Record(Record),
}

/// How a move is made.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Motion {
    /// At rapid traverse (the one-shot `RAPID`).
    Rapid,
    /// At the programmed feed.
    Feed(Feed),
    /// No feed programmed yet.
    Unset,
}

/// A programmed feed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Feed {
    /// mm/min or mm/rev.
    pub value: f64,
    /// Per minute or per revolution.
    pub per: FeedPer,
}

/// The time base of a feed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum FeedPer {
    /// mm/min.
    Minute,
    /// mm/rev.
    Revolution,
}

/// Where a straight move came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MoveKind {
    /// `GOTO`.
    Goto,
    /// `FROM` (the start point).
    From,
    /// `GODLTA` (incremental).
    Godlta,
    /// A hole position between `CYCLE/…` and `CYCLE/OFF`: `to` is the top of the hole, where
    /// the cycle's depth is measured from, whatever the CAM system writes.
    Hole,
}

/// A straight move to a tool-tip position with a tool axis, in the part frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Move {
    /// Tool-tip position.
    pub to: Point3<f64>,
    /// Tool axis at the end point.
    pub axis: ToolAxis,
    /// Rapid or feed.
    pub motion: Motion,
    /// The statement.
    pub kind: MoveKind,
}

/// A circular arc (or helix) from the current point.
#[derive(Clone, Debug, PartialEq)]
pub struct Arc {
    /// Start point (the current point before the arc).
    pub start: Point3<f64>,
    /// Centre.
    pub center: Point3<f64>,
    /// Unit axis; the motion is counter-clockwise about it (right-hand rule).
    pub normal: Unit<Vector3<f64>>,
    /// Radius.
    pub radius: f64,
    /// End point (from the GOTO after the arc record).
    pub end: Point3<f64>,
    /// Swept angle, positive, full turns included.
    pub sweep: f64,
    /// Tool axis at the end.
    pub axis: ToolAxis,
    /// Rapid or feed.
    pub motion: Motion,
}

impl Arc {
    /// Length along the helix.
    pub fn length(&self) -> f64 {
        let rise = (self.end - self.start).dot(&self.normal);
        (self.radius * self.sweep).hypot(rise)
    }

    /// The smallest box that holds the arc, as its lowest and highest corners: its ends, and
    /// each point where a coordinate turns back, found exactly (not by sampling).
    pub fn bounds(&self) -> (Point3<f64>, Point3<f64>) {
        let (mut lo, mut hi) = (self.start, self.start);
        let mut take = |t: f64| {
            let p = self.point_at(t);
            (lo, hi) = (lo.inf(&p), hi.sup(&p));
        };
        take(1.0);
        if !(self.sweep > 0.0 && self.sweep.is_finite()) {
            return (lo, hi);
        }
        let n = self.normal.into_inner();
        let u = self.start - self.center;
        let rise = u.dot(&n);
        let radial = u - n * rise;
        let across = n.cross(&radial);
        // The rise along the normal per radian of the sweep (a helix).
        let climb = ((self.end - self.center).dot(&n) - rise) / self.sweep;
        for i in 0..3 {
            // Coordinate i at angle θ: c + cos θ·radial + sin θ·across + n·(rise + climb·θ). It
            // turns back where across·cos θ − radial·sin θ = −n·climb, that is where
            // R·cos(θ + φ) = −n·climb with R = |(radial, across)|, φ = atan2(radial, across).
            let reach = radial[i].hypot(across[i]);
            let cosine = -n[i] * climb / reach;
            if !(reach > 0.0 && (-1.0..=1.0).contains(&cosine)) {
                continue;
            }
            let phi = radial[i].atan2(across[i]);
            let turn = cosine.acos();
            for first in [turn - phi, -turn - phi] {
                // In every turn of the sweep.
                let mut theta = first.rem_euclid(std::f64::consts::TAU);
                while theta < self.sweep {
                    take(theta / self.sweep);
                    theta += std::f64::consts::TAU;
                }
            }
        }
        (lo, hi)
    }

    /// The point at fraction `t` ∈ [0, 1] of the sweep.
    pub fn point_at(&self, t: f64) -> Point3<f64> {
        let u = self.start - self.center;
        let rise = u.dot(&self.normal);
        let radial = u - self.normal.into_inner() * rise;
        let end_rise = (self.end - self.center).dot(&self.normal);
        let rotation = nalgebra::UnitQuaternion::from_axis_angle(&self.normal, self.sweep * t);
        self.center + rotation * radial + self.normal.into_inner() * (rise + (end_rise - rise) * t)
    }
}

/// The highest degree of a NURBS the reader takes.
pub const MAX_NURBS_DEGREE: usize = 9;

/// A NURBS curve, clamped at both ends: it starts at the current point.
#[derive(Clone, Debug, PartialEq)]
pub struct Nurbs {
    /// Degree.
    pub degree: usize,
    /// The full (clamped) knot vector.
    pub knots: Vec<f64>,
    /// Control points; the first is the start point.
    pub control: Vec<Point3<f64>>,
    /// Tool axis along the curve.
    pub axis: ToolAxis,
    /// Rapid or feed.
    pub motion: Motion,
}

impl Nurbs {
    /// The point at parameter `u` (de Boor): O(log n + degree²), without allocating up to the
    /// highest degree the reader takes.
    pub fn point_at(&self, u: f64) -> Point3<f64> {
        let p = self.degree;
        let n = self.control.len();
        let lo = self.knots[p];
        let hi = self.knots[n];
        let u = u.clamp(lo, hi);
        // The span of `u`: the last `k` below `n` with `knots[k] <= u` (the knots never
        // decrease: the reader checks it).
        let k = p + self.knots[p + 1..n].partition_point(|&x| x <= u);
        let mut stack = [Vector3::zeros(); MAX_NURBS_DEGREE + 1];
        let mut heap = Vec::new();
        let d: &mut [Vector3<f64>] = if p <= MAX_NURBS_DEGREE {
            &mut stack[..=p]
        } else {
            heap.resize(p + 1, Vector3::zeros());
            &mut heap
        };
        self.de_boor(k, u, d)
    }

    /// De Boor's triangle at `u` in span `k`, in `d` (`degree + 1` points).
    fn de_boor(&self, k: usize, u: f64, d: &mut [Vector3<f64>]) -> Point3<f64> {
        Point3::from(self.blossom(k, |_| u, d))
    }

    /// De Boor's triangle in span `k`, in `d` (`degree + 1` points), level `r` (from 1) at
    /// parameter `at(r)`: the blossom of the curve at those parameters (the point, where they
    /// are all one).
    fn blossom(&self, k: usize, at: impl Fn(usize) -> f64, d: &mut [Vector3<f64>]) -> Vector3<f64> {
        let p = self.degree;
        for (j, d) in d.iter_mut().enumerate() {
            *d = self.control[j + k - p].coords;
        }
        for r in 1..=p {
            let u = at(r);
            for j in (r..=p).rev() {
                let i = j + k - p;
                let den = self.knots[i + p + 1 - r] - self.knots[i];
                let a = if den > 0.0 { (u - self.knots[i]) / den } else { 0.0 };
                d[j] = d[j - 1] * (1.0 - a) + d[j] * a;
            }
        }
        d[p]
    }

    /// The points at `samples + 1` parameters spread evenly over the domain, in order
    /// (`samples` 0: the start only): [`Self::point_at`] at each, its ends exactly and the rest
    /// to rounding (a few 1e-11 of the control points' size at degree 9), at a fraction of its
    /// cost. The spans are walked rather than searched, and each is turned once into a
    /// polynomial, which Horner's rule evaluates without a division.
    pub fn even_points(&self, samples: usize) -> EvenPoints<'_> {
        EvenPoints { curve: self, samples, next: 0, span: None, powers: [Vector3::zeros(); MAX_NURBS_DEGREE + 1] }
    }

    /// Span `k` as a polynomial in its own parameter s ∈ [0, 1], the coefficient of sʲ in
    /// `powers[j]`, by way of its Bézier points (`d` is room for [`Self::blossom`]).
    fn span_powers(&self, k: usize, powers: &mut [Vector3<f64>], d: &mut [Vector3<f64>]) {
        let p = self.degree;
        let (a, b) = (self.knots[k], self.knots[k + 1]);
        // Bézier point i is the blossom of the curve at a repeated p − i times and b i times.
        for (i, point) in powers.iter_mut().enumerate() {
            *point = self.blossom(k, |r| if r <= i { b } else { a }, d);
        }
        // The coefficient of sʲ is C(p, j)·Δʲb₀.
        for r in 1..p + 1 {
            for j in (r..p + 1).rev() {
                powers[j] -= powers[j - 1];
            }
        }
        let mut binomial = 1.0;
        for (j, c) in powers.iter_mut().enumerate().skip(1) {
            binomial = binomial * (p + 1 - j) as f64 / j as f64;
            *c *= binomial;
        }
    }

    /// The parameter range.
    pub fn domain(&self) -> (f64, f64) {
        (self.knots[self.degree], self.knots[self.control.len()])
    }

    /// The end point.
    pub fn end(&self) -> Point3<f64> {
        self.control.last().copied().unwrap_or_else(Point3::origin)
    }
}

/// The points of a NURBS at evenly spread parameters ([`Nurbs::even_points`]).
#[derive(Clone, Debug)]
pub struct EvenPoints<'a> {
    curve: &'a Nurbs,
    samples: usize,
    /// The ordinal of the next point.
    next: usize,
    /// The span whose polynomial `powers` holds.
    span: Option<usize>,
    /// Its coefficients ([`Nurbs::span_powers`]; the first `degree + 1`).
    powers: [Vector3<f64>; MAX_NURBS_DEGREE + 1],
}

impl Iterator for EvenPoints<'_> {
    type Item = Point3<f64>;

    fn next(&mut self) -> Option<Point3<f64>> {
        if self.next > self.samples {
            return None;
        }
        let c = self.curve;
        let (p, n) = (c.degree, c.control.len());
        let (lo, hi) = c.domain();
        let k = self.next;
        self.next += 1;
        let u = match k {
            0 => lo,
            k if k == self.samples => hi,
            k => (lo + (hi - lo) * k as f64 / self.samples as f64).clamp(lo, hi),
        };
        // The ends exactly; and a degree the reader does not take.
        if p > MAX_NURBS_DEGREE || k == 0 || k == self.samples {
            return Some(c.point_at(u));
        }
        // The span of `u` as `point_at` finds it, walked from the last one (the points come in
        // order).
        let mut span = self.span.unwrap_or(p);
        while span + 1 < n && c.knots[span + 1] <= u {
            span += 1;
        }
        if self.span != Some(span) {
            let mut d = [Vector3::zeros(); MAX_NURBS_DEGREE + 1];
            c.span_powers(span, &mut self.powers[..p + 1], &mut d[..p + 1]);
            self.span = Some(span);
        }
        let (a, b) = (c.knots[span], c.knots[span + 1]);
        let s = if b > a { (u - a) / (b - a) } else { 0.0 };
        let mut point = self.powers[p];
        for c in self.powers[..p].iter().rev() {
            point = point * s + c;
        }
        Some(Point3::from(point))
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        let left = (self.samples + 1).saturating_sub(self.next);
        (left, Some(left))
    }
}

impl ExactSizeIterator for EvenPoints<'_> {}

/// A tool change.
#[derive(Clone, Debug, PartialEq)]
pub struct ToolChange {
    /// Tool number.
    pub number: u32,
    /// Length-offset register, when given (`LOAD/TOOL,1,ADJUST,1`).
    pub adjust: Option<u32>,
    /// Tool name, when the file gives one.
    pub name: Option<String>,
}

/// Tool geometry.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct ToolShape {
    /// Diameter, mm.
    pub diameter: f64,
    /// Corner (lower) radius, mm.
    pub corner_radius: f64,
    /// Length (height), mm, when given.
    pub length: Option<f64>,
}

/// Spindle state.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Spindle {
    /// On, with a speed and direction.
    On {
        /// Speed.
        speed: f64,
        /// RPM or surface speed.
        unit: SpindleUnit,
        /// Direction.
        clockwise: bool,
    },
    /// Off.
    Off,
}

/// The unit of a spindle speed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum SpindleUnit {
    /// Revolutions per minute.
    Rpm,
    /// Constant surface speed as written (`SFM`/`SMM`): per minute, in the file's convention
    /// (m/min in metric files, ft/min in inch files).
    SurfaceSpeed,
}

/// Coolant state.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Coolant {
    /// On (unspecified kind).
    On,
    /// Flood.
    Flood,
    /// Mist.
    Mist,
    /// Through the tool.
    Through,
    /// Air blast.
    Air,
    /// Off.
    Off,
}

/// Cutter radius compensation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CutterComp {
    /// Tool left of the path.
    Left,
    /// Tool right of the path.
    Right,
    /// On, side given later (CAMWorks writes `CUTCOM/ON` then `CUTCOM/LEFT`).
    On,
    /// Off.
    Off,
}

/// A canned cycle: what the machine does at each hole position that follows.
///
/// Lengths are millimetres along the tool axis, measured from the hole's top point (the `to` of
/// each [`MoveKind::Hole`] move): the depth below it, the R plane and the retract height above
/// it. `docs/cl-reader.md` says how each vendor's form maps to these fields.
#[derive(Clone, Debug, PartialEq)]
pub struct Cycle {
    /// The motion at each hole.
    pub kind: CycleKind,
    /// Depth of the hole bottom below the hole point, mm (> 0).
    pub depth: f64,
    /// The R plane: where the rapid approach ends and the feed starts, mm above the hole point
    /// (≥ 0).
    pub clearance: f64,
    /// Where the tool returns after each hole, mm above the hole point (above the R plane);
    /// `None`: to the R plane.
    pub retract: Option<f64>,
    /// Peck depths, for pecking cycles.
    pub peck: Option<Peck>,
    /// Dwell at the bottom of the hole.
    pub dwell: Option<Delay>,
    /// The cycle's own feed; `None`: the programmed (modal) feed.
    pub feed: Option<Feed>,
    /// The vendor's cycle word, upper case (`DRILL`, `DEEP2`, …).
    pub word: String,
    /// The arguments after the cycle word as written (for comments).
    pub args: String,
}

/// The motion of a canned cycle at each hole, named by the ISO code it maps to.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum CycleKind {
    /// Feed to depth, rapid out: G81; G82 with a dwell at the bottom. (`DRILL`, Creo `FACE` and
    /// `CSINK`.)
    Drill,
    /// Peck drilling, rapid out to the R plane after each peck: G83. (`DEEP`, `DEEP2`, CAMWorks
    /// `DRILL,…,PECKING`.)
    Deep,
    /// Peck drilling with a short retract to break the chip: G73. (`BRKCHP`.)
    ChipBreak,
    /// Tapping, the spindle reversing at the bottom: G84. (`TAP`.)
    Tap,
    /// Boring, feed in and feed out: G85; G89 with a dwell at the bottom. (`BORE`, `REAM`.)
    Bore,
}

impl CycleKind {
    /// The ISO G code (without the dwell variant).
    pub fn iso_code(self) -> &'static str {
        match self {
            CycleKind::Drill => "G81",
            CycleKind::Deep => "G83",
            CycleKind::ChipBreak => "G73",
            CycleKind::Tap => "G84",
            CycleKind::Bore => "G85",
        }
    }
}

/// Peck depths of a pecking cycle, mm.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Peck {
    /// The first peck.
    pub first: f64,
    /// Each following peck.
    pub next: f64,
}

/// A dwell.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Delay {
    /// Seconds.
    Seconds(f64),
    /// Spindle revolutions.
    Revolutions(f64),
}

/// The kind of a text item.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TextKind {
    /// `PPRINT`: operator message.
    Pprint,
    /// `INSERT`: text passed straight to the NC program.
    Insert,
    /// `TPRINT`: tool text.
    Tprint,
    /// `PARTNO`.
    Partno,
    /// `REMARK` (APT source).
    Remark,
}

/// A change of the frame the CL points are written in.
#[derive(Clone, Debug, PartialEq)]
pub struct FrameChange {
    /// The statement that changed it.
    pub source: FrameSource,
    /// The transform from the frame the next points are written in to the part frame.
    pub to_part: Isometry3<f64>,
}

/// The statement behind a frame change.
#[derive(Clone, Debug, PartialEq)]
pub enum FrameSource {
    /// NX `MSYS`: the machine coordinate system (origin, X axis, Y axis).
    Msys,
    /// CAMWorks `ROTABL`: an incremental table rotation (axis letter, angle in radians).
    Rotabl(char, f64),
    /// SOLIDWORKS CAM `CSYS`: the set-up frame (row-major 3×4, as written; the rotation's columns
    /// are the set-up's axes in the world frame). The points are written in the world frame
    /// already, so the points are not moved; the third column is the set-up's tool axis.
    Csys([f64; 12]),
}

/// A record carried through without interpretation.
#[derive(Clone, Debug, PartialEq)]
pub struct Record {
    /// The major word, canonical (upper case).
    pub word: String,
    /// The text after the slash, as written.
    pub args: String,
}

#[cfg(test)]
mod tests {
    use super::*;

    /// De Boor with the span searched one knot at a time, in a fresh vector.
    fn point_at_by_walking(c: &Nurbs, u: f64) -> Point3<f64> {
        let (p, n) = (c.degree, c.control.len());
        let u = u.clamp(c.knots[p], c.knots[n]);
        let mut k = p;
        while k + 1 < n && c.knots[k + 1] <= u {
            k += 1;
        }
        c.de_boor(k, u, &mut vec![Vector3::zeros(); p + 1])
    }

    /// A clamped curve of `degree + 1 + extra` control points from `coords`: `degree + 1` equal
    /// knots at each end, `steps` (some of them 0) between the inner ones, the last a step of 1.
    fn clamped(degree: usize, extra: usize, steps: &[f64], coords: &[f64]) -> Nurbs {
        let n = degree + 1 + extra;
        let control = (0..n).map(|i| Point3::new(coords[3 * i], coords[3 * i + 1], coords[3 * i + 2])).collect();
        let mut knots = vec![0.0; degree + 1];
        let mut x = 0.0;
        for step in steps.iter().take(n - degree - 1) {
            x += step;
            knots.push(x);
        }
        knots.extend(std::iter::repeat_n(x + 1.0, degree + 1));
        Nurbs { degree, knots, control, axis: Vector3::z_axis(), motion: Motion::Unset }
    }

    proptest::proptest! {
        /// The span found by bisection is the one a walk finds, at the knots themselves (repeated
        /// ones too), between them and outside the domain: the same points, bit for bit.
        #[test]
        fn a_nurbs_point_is_found_in_its_span(
            degree in 1..=MAX_NURBS_DEGREE,
            extra in 0..30_usize,
            steps in proptest::collection::vec(proptest::prop_oneof![proptest::strategy::Just(0.0), 0.0..2.0_f64], 40),
            coords in proptest::collection::vec(-100.0..100.0_f64, 3 * 40),
            at in proptest::collection::vec(-0.2..1.2_f64, 20),
        ) {
            let curve = clamped(degree, extra, &steps, &coords);
            let end = curve.domain().1;
            let us = at.iter().map(|t| t * end).chain(curve.knots.iter().copied());
            for u in us {
                proptest::prop_assert_eq!(curve.point_at(u), point_at_by_walking(&curve, u), "u = {}", u);
            }
        }
    }

    proptest::proptest! {
        /// The points at evenly spread parameters are the curve's, as `point_at` gives them, to
        /// rounding (knots repeated inside the domain too, degrees above the reader's too), and
        /// its ends exactly.
        #[test]
        fn a_nurbs_s_even_points_are_its_points(
            degree in 0..=MAX_NURBS_DEGREE + 2,
            extra in 0..30_usize,
            steps in proptest::collection::vec(proptest::prop_oneof![proptest::strategy::Just(0.0), 0.0..2.0_f64], 45),
            coords in proptest::collection::vec(-100.0..100.0_f64, 3 * 45),
            samples in 0..200_usize,
        ) {
            let curve = clamped(degree, extra, &steps, &coords);
            let (lo, hi) = curve.domain();
            let points: Vec<Point3<f64>> = curve.even_points(samples).collect();
            proptest::prop_assert_eq!(points.len(), samples + 1);
            for (k, point) in points.iter().enumerate() {
                let u = match k {
                    0 => lo,
                    k if k == samples => hi,
                    k => lo + (hi - lo) * k as f64 / samples as f64,
                };
                let exact = curve.point_at(u);
                proptest::prop_assert!((point - exact).norm() <= 1e-9, "u = {}: {} against {}", u, point, exact);
            }
            proptest::prop_assert_eq!(points[0], curve.point_at(lo));
            if samples > 0 {
                proptest::prop_assert_eq!(points[samples], curve.point_at(hi));
            }
        }
    }

    proptest::proptest! {
        /// The box of an arc or helix, of any sweep up to three turns, holds every point of it
        /// and no more: against 4 000 points along it.
        #[test]
        fn an_arc_s_bounds_are_its_box(
            center in proptest::array::uniform3(-100.0..100.0_f64),
            normal in proptest::array::uniform3(-1.0..1.0_f64),
            toward in proptest::array::uniform3(-1.0..1.0_f64),
            radius in 0.1..200.0_f64,
            sweep in 0.001..(6.0 * std::f64::consts::PI),
            rise in proptest::prop_oneof![proptest::strategy::Just(0.0), -50.0..50.0_f64],
        ) {
            let Some(normal) = Unit::try_new(Vector3::from(normal), 1e-3) else { return Ok(()) };
            let toward = Vector3::from(toward);
            let Some(radial) = (toward - normal.into_inner() * toward.dot(&normal)).try_normalize(1e-3) else {
                return Ok(());
            };
            let center = Point3::from(center);
            let start = center + radial * radius;
            let turned = nalgebra::UnitQuaternion::from_axis_angle(&normal, sweep) * (radial * radius);
            let end = center + turned + normal.into_inner() * rise;
            let arc = Arc { start, center, normal, radius, end, sweep, axis: Vector3::z_axis(), motion: Motion::Unset };
            let (lo, hi) = arc.bounds();
            let samples = 4_000;
            let (mut slo, mut shi) = (start, start);
            for k in 0..=samples {
                let p = arc.point_at(f64::from(k) / f64::from(samples));
                (slo, shi) = (slo.inf(&p), shi.sup(&p));
            }
            // Between samples an arc bulges at most r·(1 − cos(Δθ/2)) out of their box.
            let bulge = radius * (1.0 - (sweep / f64::from(samples) / 2.0).cos()) + 1e-9;
            for i in 0..3 {
                proptest::prop_assert!(lo[i] <= slo[i] + 1e-9 && hi[i] >= shi[i] - 1e-9, "{i}: {lo} {hi} against {slo} {shi}");
                proptest::prop_assert!(lo[i] >= slo[i] - bulge && hi[i] <= shi[i] + bulge, "{i}: {lo} {hi} against {slo} {shi}");
            }
        }
    }
}
