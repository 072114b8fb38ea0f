//! The `check` summary: computed while reading, without keeping the tool path, so memory stays
//! at the size of the source text, or (read from the file in windows, [`summarize_file`]) does
//! not grow with the file.

use std::collections::{BTreeMap, BTreeSet};

use nalgebra::Point3;
use serde::Serialize;

use crate::diagnostic::Diagnostic;
use crate::model::*;
use crate::read::{ItemSink, ReadOptions, read_into_with};
use crate::span::{LineCol, Source};
use crate::{ClFile, Error};

/// What `postpro check` reports about a CL file. Field names are the stable JSON keys.
#[derive(Clone, Debug, Serialize)]
pub struct Summary {
    /// The file name as given.
    pub file: String,
    /// CAM system, when recognisable.
    pub cam_system: Option<&'static str>,
    /// PARTNO text.
    pub part_name: Option<String>,
    /// The file's units.
    pub units: UnitsSummary,
    /// `3-axis`, `3+2`, `5-axis`, or `none` without moves.
    pub axes: &'static str,
    /// Logical statements read.
    pub statements: usize,
    /// Straight moves.
    pub moves: MoveCounts,
    /// Arcs (CIRCLE, MOVARC, evaluated APT motion).
    pub arcs: usize,
    /// NURBS curves.
    pub nurbs: usize,
    /// Tools loaded, by number.
    pub tools: Vec<ToolSummary>,
    /// Programmed feeds.
    pub feeds: FeedSummary,
    /// Spindle speeds, min and max, as written.
    pub spindle: Option<Range>,
    /// Axis-aligned box of every tool-tip position (mm, part frame).
    pub bounding_box: Option<BoundingBox>,
    /// Path length of the tool tip (mm).
    pub path_length: PathLength,
    /// Moves and curves whose tool axis differs from the previous one (by more than 1e-6).
    pub axis_changes: usize,
    /// Operations (`TOOL PATH`, `OPFEATSTART`).
    pub operations: usize,
    /// Frame changes (MSYS, CSYS, ROTABL).
    pub frames: usize,
    /// Words carried through without interpretation, with their record counts (known ones such
    /// as PAINT included).
    pub uninterpreted_words: BTreeMap<String, usize>,
    /// Words the reader does not know, with their record counts.
    pub unknown_words: BTreeMap<String, usize>,
    /// Warnings.
    pub warnings: WarningSummary,
    /// Errors.
    pub errors: usize,
    /// Non-APT listing lines skipped (NX Information window).
    pub listing_lines: usize,
    /// `FROM` statements before any tool change or move: the tool's start point, not a move
    /// ([`ProgramInfo::start_points`](crate::ProgramInfo::start_points)).
    pub start_points: usize,
}

/// Units.
#[derive(Clone, Debug, Serialize)]
pub struct UnitsSummary {
    /// `mm` or `inch`: the unit the file is written in (the summary is in mm).
    pub file: LengthUnit,
    /// `declared`, `feed word` or `assumed`.
    pub origin: &'static str,
    /// `line:column` of the statement that decided.
    pub at: Option<String>,
}

/// Move counts.
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct MoveCounts {
    /// All straight moves (GOTO, GODLTA, holes), FROM excluded.
    pub total: usize,
    /// At feed.
    pub feed: usize,
    /// At rapid.
    pub rapid: usize,
    /// Hole positions inside cycles.
    pub holes: usize,
}

/// A tool.
#[derive(Clone, Debug, Serialize)]
pub struct ToolSummary {
    /// Number.
    pub number: u32,
    /// Name, when given.
    pub name: Option<String>,
    /// Diameter, mm.
    pub diameter: Option<f64>,
    /// Corner radius, mm.
    pub corner_radius: Option<f64>,
    /// Times loaded.
    pub loads: usize,
}

/// Feeds.
#[derive(Clone, Debug, Default, Serialize)]
pub struct FeedSummary {
    /// mm/min.
    pub per_minute: Option<Range>,
    /// mm/rev.
    pub per_revolution: Option<Range>,
    /// Number of distinct feed values.
    pub distinct: usize,
}

/// A closed range.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Range {
    /// Smallest.
    pub min: f64,
    /// Largest.
    pub max: f64,
}

/// A box.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct BoundingBox {
    /// Smallest x, y, z.
    pub min: [f64; 3],
    /// Largest x, y, z.
    pub max: [f64; 3],
}

/// Lengths.
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct PathLength {
    /// At feed.
    pub feed: f64,
    /// At rapid.
    pub rapid: f64,
}

/// Warnings.
#[derive(Clone, Debug, Default, Serialize)]
pub struct WarningSummary {
    /// Count.
    pub total: usize,
    /// Count by the major word of the statement (`-` for file-level warnings).
    pub by_word: BTreeMap<String, usize>,
}

/// Reads a source and summarises it without keeping the tool path.
pub fn summarize(source: &Source) -> (Summary, Vec<Diagnostic>) {
    summarize_with(source, &ReadOptions::default())
}

/// Reads a source with options and summarises it without keeping the tool path.
pub fn summarize_with(source: &Source, options: &ReadOptions) -> (Summary, Vec<Diagnostic>) {
    let mut acc = Accumulator::default();
    let (info, diagnostics) = read_into_with(source, options, &mut acc);
    (acc.finish(source.name(), |offset| source.line_col_scan(offset), &info, &diagnostics), diagnostics)
}

/// Reads a CL file in windows with options and summarises it: what [`summarize_with`] gives for
/// its text, in memory that does not grow with the file.
pub fn summarize_file(file: &ClFile, options: &ReadOptions) -> Result<(Summary, Vec<Diagnostic>), Error> {
    let mut acc = Accumulator::default();
    let (info, diagnostics) = file.read_into_with(options, &mut acc)?;
    // The summary locates an offset or two (where the units are set): read from the start up to
    // them rather than indexing the whole file's lines.
    let mut lines = file.lines()?;
    let line_col = |offset| lines.line_col(offset).unwrap_or(LineCol { line: 0, column: 0 });
    let summary = acc.finish(file.name(), line_col, &info, &diagnostics);
    Ok((summary, diagnostics))
}

/// Summarises a tool path already read.
pub fn summarize_tool_path(source: &Source, path: &ToolPath) -> Summary {
    let mut acc = Accumulator::default();
    for item in &path.items {
        acc.push(item.clone());
    }
    acc.finish(source.name(), |offset| source.line_col_scan(offset), &path.info, &path.diagnostics)
}

#[derive(Default)]
struct Accumulator {
    moves: MoveCounts,
    arcs: usize,
    nurbs: usize,
    tools: BTreeMap<u32, ToolSummary>,
    current_tool: Option<u32>,
    pending_shape: Option<ToolShape>,
    feed_min: [f64; 2],
    feed_max: [f64; 2],
    feed_seen: [bool; 2],
    feeds: BTreeSet<u64>,
    last_feed: Option<Feed>,
    spindle: Option<Range>,
    lo: Option<Point3<f64>>,
    hi: Option<Point3<f64>>,
    length: PathLength,
    position: Option<Point3<f64>>,
    last_cut_axis: Option<ToolAxis>,
    last_was_feed: bool,
    simultaneous: bool,
    tilted: bool,
    last_axis: Option<ToolAxis>,
    axis_changes: usize,
    operations: usize,
    frames: usize,
}

impl ItemSink for Accumulator {
    fn push(&mut self, item: Item) {
        match item.kind {
            ItemKind::Move(m) => self.straight(&m),
            ItemKind::Arc(a) => {
                self.arcs += 1;
                let (lo, hi) = a.bounds();
                self.extend(lo);
                self.extend(hi);
                self.motion(a.motion, a.length(), a.axis);
                self.position = Some(a.end);
            }
            ItemKind::Nurbs(n) => {
                self.nurbs += 1;
                let mut points = n.even_points(16 * n.control.len());
                let mut prev = points.next().unwrap_or_else(|| n.end());
                let mut len = 0.0;
                for p in points {
                    len += (p - prev).norm();
                    self.extend(p);
                    prev = p;
                }
                self.motion(n.motion, len, n.axis);
                self.position = Some(n.end());
            }
            ItemKind::ToolChange(t) => {
                let shape = self.pending_shape.take();
                let entry = self.tools.entry(t.number).or_insert(ToolSummary {
                    number: t.number,
                    name: None,
                    diameter: None,
                    corner_radius: None,
                    loads: 0,
                });
                entry.loads += 1;
                if entry.name.is_none() {
                    entry.name = t.name;
                }
                if let Some(s) = shape {
                    entry.diameter.get_or_insert(round(s.diameter));
                    entry.corner_radius.get_or_insert(round(s.corner_radius));
                }
                self.current_tool = Some(t.number);
                // A new tool may come with a new (indexed) axis: not simultaneous motion.
                self.last_was_feed = false;
            }
            ItemKind::ToolShape(s) => {
                match self.current_tool.and_then(|n| self.tools.get_mut(&n)).filter(|t| t.diameter.is_none()) {
                    Some(t) => {
                        t.diameter = Some(round(s.diameter));
                        t.corner_radius = Some(round(s.corner_radius));
                    }
                    None => self.pending_shape = Some(s),
                }
            }
            ItemKind::Spindle(Spindle::On { speed, .. }) => {
                let r = self.spindle.get_or_insert(Range { min: speed, max: speed });
                r.min = r.min.min(speed);
                r.max = r.max.max(speed);
            }
            ItemKind::OperationStart(_) => {
                self.operations += 1;
                self.last_was_feed = false;
            }
            ItemKind::Frame(_) => {
                self.frames += 1;
                self.last_was_feed = false;
            }
            _ => {}
        }
    }
}

impl Accumulator {
    fn extend(&mut self, p: Point3<f64>) {
        self.lo = Some(self.lo.map_or(p, |l| l.inf(&p)));
        self.hi = Some(self.hi.map_or(p, |h| h.sup(&p)));
    }

    fn straight(&mut self, m: &Move) {
        self.extend(m.to);
        if m.kind == MoveKind::From {
            self.position = Some(m.to);
            self.note_axis(m.axis);
            return;
        }
        self.moves.total += 1;
        if m.kind == MoveKind::Hole {
            self.moves.holes += 1;
        }
        match m.motion {
            Motion::Rapid => self.moves.rapid += 1,
            _ => self.moves.feed += 1,
        }
        let len = self.position.map_or(0.0, |p| (m.to - p).norm());
        self.motion(m.motion, len, m.axis);
        self.position = Some(m.to);
    }

    fn note_axis(&mut self, axis: ToolAxis) {
        if self.last_axis.is_some_and(|a| (a.into_inner() - axis.into_inner()).norm() > 1e-6) {
            self.axis_changes += 1;
        }
        self.last_axis = Some(axis);
        if (axis.z - 1.0).abs() > 1e-6 {
            self.tilted = true;
        }
    }

    fn motion(&mut self, motion: Motion, len: f64, axis: ToolAxis) {
        self.note_axis(axis);
        match motion {
            Motion::Rapid => {
                self.length.rapid += len;
                self.last_was_feed = false;
            }
            Motion::Feed(_) | Motion::Unset => {
                let f = if let Motion::Feed(f) = motion { Some(f) } else { None };
                self.length.feed += len;
                if let Some(f) = f {
                    let k = usize::from(f.per == FeedPer::Revolution);
                    if !self.feed_seen[k] {
                        (self.feed_min[k], self.feed_max[k], self.feed_seen[k]) = (f.value, f.value, true);
                    }
                    self.feed_min[k] = self.feed_min[k].min(f.value);
                    self.feed_max[k] = self.feed_max[k].max(f.value);
                    if self.last_feed != Some(f) {
                        self.feeds.insert(f.value.to_bits() ^ k as u64);
                        self.last_feed = Some(f);
                    }
                }
                if self.last_was_feed
                    && self.last_cut_axis.is_some_and(|a| (a.into_inner() - axis.into_inner()).norm() > 1e-5)
                {
                    self.simultaneous = true;
                }
                self.last_cut_axis = Some(axis);
                self.last_was_feed = true;
            }
        }
    }

    /// The summary of the file `name`, `line_col` locating an offset of its text.
    fn finish(
        self,
        name: &str,
        mut line_col: impl FnMut(usize) -> LineCol,
        info: &ProgramInfo,
        diagnostics: &[Diagnostic],
    ) -> Summary {
        let mut at = |span: crate::span::Span| {
            let lc = line_col(span.start as usize);
            Some(format!("{}:{}", lc.line, lc.column))
        };
        let (origin, at) = match info.units.origin {
            UnitsOrigin::Declared(s) => ("declared", at(s)),
            UnitsOrigin::FeedWord(s) => ("feed word", at(s)),
            UnitsOrigin::Assumed => ("assumed", None),
            UnitsOrigin::Option => ("option", None),
        };
        let mut warnings = WarningSummary::default();
        for d in diagnostics.iter().filter(|d| !d.is_error()) {
            warnings.total += 1;
            *warnings.by_word.entry(d.word.clone().unwrap_or_else(|| "-".into())).or_default() += 1;
        }
        let range =
            |k: usize| self.feed_seen[k].then(|| Range { min: round(self.feed_min[k]), max: round(self.feed_max[k]) });
        let any_motion = self.moves.total + self.arcs + self.nurbs > 0;
        Summary {
            file: name.to_string(),
            cam_system: info.cam_system.map(CamSystem::name),
            part_name: info.part_name.clone(),
            units: UnitsSummary { file: info.units.unit, origin, at },
            axes: match (any_motion, self.simultaneous, self.tilted) {
                (false, ..) => "none",
                (true, true, _) => "5-axis",
                (true, false, true) => "3+2",
                (true, false, false) => "3-axis",
            },
            statements: info.statements,
            moves: self.moves,
            arcs: self.arcs,
            nurbs: self.nurbs,
            tools: self.tools.into_values().collect(),
            feeds: FeedSummary { per_minute: range(0), per_revolution: range(1), distinct: self.feeds.len() },
            spindle: self.spindle.map(|r| Range { min: round(r.min), max: round(r.max) }),
            bounding_box: self.lo.zip(self.hi).map(|(l, h)| BoundingBox {
                min: [round(l.x), round(l.y), round(l.z)],
                max: [round(h.x), round(h.y), round(h.z)],
            }),
            path_length: PathLength { feed: round(self.length.feed), rapid: round(self.length.rapid) },
            axis_changes: self.axis_changes,
            operations: self.operations,
            frames: self.frames,
            uninterpreted_words: info.uninterpreted.iter().map(|(w, u)| (w.clone(), u.count)).collect(),
            unknown_words: info
                .uninterpreted
                .iter()
                .filter(|(_, u)| u.unknown)
                .map(|(w, u)| (w.clone(), u.count))
                .collect(),
            warnings,
            errors: diagnostics.iter().filter(|d| d.is_error()).count(),
            listing_lines: info.listing_lines,
            start_points: info.start_points.map_or(0, |s| s.count),
        }
    }
}

/// Rounds to 1e-4 (and folds −0 to 0) so the JSON is stable across platforms.
fn round(v: f64) -> f64 {
    let r = (v * 1e4).round() / 1e4;
    if r == 0.0 { 0.0 } else { r }
}
