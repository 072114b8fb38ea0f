//! What a prediction tells: per block, per sample, per operation and for the whole program.
//!
//! **Time lost** is defined once, per feed block: its predicted time (a dwell before it aside)
//! minus its time at the programmed feed (its tip length over the CL file's feed). Rapids and
//! blocks that only turn the tool lose nothing by definition: the program asks for no feed there.
//! Every other figure derives from it: the program's and each operation's time lost are sums of
//! it, the time at the programmed feed is the cycle time minus it.
//!
//! The **causes** partition it. In G1 output the program itself asks for another time than the
//! CL file's feed (F is read as the feed of the linear axes): that difference is `G1 feed on
//! the axes`. The rest, the time beyond what the program asks for, is split step by step of the
//! interpolator: each step's time minus its programmed time goes to what held the step back — a
//! corner, an exact stop, the look-ahead, an axis's velocity, the cycle time — and the steps that
//! accelerate out of a dip go to what caused the dip (the jerk that limits the acceleration only
//! says how fast the machine recovers). The steps that accelerate out of or brake into an exact
//! stop the program asks for (a rapid, a tool change, a stop, a dwell, the program's ends) are
//! `exact stop`, those around the turn at the end of a plunge or the start of a retract at feed
//! (a move along the tool axis) `plunge or retract`: no programmer can remove them by changing
//! the path, and a [`Mark`] does not count them.

use std::collections::BTreeMap;

use crate::moves::{BlockKind, Blocks};
use crate::plan::{Limit, Observer, Sample, Track};
use crate::vpop::{Curves, Segment};
use crate::window::Window;
use postpro_kin::{Joints, Kinematics};
use postpro_machine::model::Machine;

/// The prediction of one block.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BlockResult {
    /// Index of the block's end step in the solved tool path.
    pub step: usize,
    /// The CL statement of that step.
    pub span: postpro_cl::Span,
    /// Feed move, reorientation or rapid.
    pub kind: BlockKind,
    /// A block of the NC program (false: a point within one, which the prediction follows).
    pub written: bool,
    /// Tip length (mm).
    pub length: f64,
    /// Programmed feed (mm/min); 0 for rapids.
    pub programmed: f64,
    /// Lowest predicted tip feed on the block (mm/min).
    pub min_feed: f64,
    /// Mean predicted tip feed: length over time (mm/min).
    pub mean_feed: f64,
    /// Predicted time (s).
    pub time: f64,
    /// What holds the feed back where it is lowest.
    pub limit: Limit,
    /// Time lost (s): the predicted time, a dwell before the block aside, minus the time at the
    /// programmed feed; 0 for rapids and reorientations (see the module's documentation).
    pub lost: f64,
    /// The part of [`Self::lost`] spent accelerating out of or braking into an exact stop, a
    /// plunge or a retract (what the program itself asks to stop or turn at).
    pub stop_lost: f64,
    /// What lost the most time on the block apart from those (`Programmed` when nothing).
    pub cause: Limit,
    /// The operation the block is in (index into [`Prediction::operations`]).
    pub operation: usize,
    /// The lowest predicted tip feed apart from the acceleration out of and the braking into
    /// exact stops, plunges and retracts (mm/min; the programmed feed when the block is at it
    /// everywhere else).
    pub min_feed_between_stops: f64,
}

impl BlockResult {
    /// The lowest feed as a share of the programmed one (1 for rapids and reorientations).
    pub fn min_ratio(&self) -> f64 {
        if self.kind == BlockKind::Feed && self.programmed > 0.0 { self.min_feed / self.programmed } else { 1.0 }
    }

    /// [`Self::min_feed_between_stops`] as a share of the programmed feed (1 for rapids and
    /// reorientations).
    pub fn min_ratio_between_stops(&self) -> f64 {
        if self.kind == BlockKind::Feed && self.programmed > 0.0 {
            self.min_feed_between_stops / self.programmed
        } else {
            1.0
        }
    }
}

/// The samples, column-wise (one row per interpolation period). Axis values in mm and rad.
#[derive(Clone, Debug, Default)]
pub struct Samples {
    /// Number of axes.
    pub axes: usize,
    /// Time (s).
    pub time: Vec<f64>,
    /// Tip path length (mm).
    pub path: Vec<f64>,
    /// The block the sample is in (index into [`Prediction::blocks`]).
    pub block: Vec<u32>,
    /// Predicted tip feed along the programmed block (mm/min).
    pub feed: Vec<f64>,
    /// Programmed feed (mm/min).
    pub programmed: Vec<f64>,
    /// Relative tool/surface feed rebuilt from the axis positions through the forward
    /// kinematics (mm/min).
    pub relative_feed: Vec<f64>,
    /// What held the step back.
    pub limit: Vec<Limit>,
    /// Axis positions (`len × axes`).
    pub position: Vec<f64>,
    /// Axis velocities (`len × axes`, per second).
    pub velocity: Vec<f64>,
    /// Axis accelerations (`len × axes`, per second²).
    pub acceleration: Vec<f64>,
    /// Axis jerks (`len × axes`, per second³).
    pub jerk: Vec<f64>,
}

impl Samples {
    /// Number of samples.
    pub fn len(&self) -> usize {
        self.time.len()
    }

    /// True when there is none.
    pub fn is_empty(&self) -> bool {
        self.time.is_empty()
    }

    /// Forgets every sample, keeping the room they took.
    pub(crate) fn clear(&mut self) {
        for column in [&mut self.time, &mut self.path, &mut self.feed, &mut self.programmed, &mut self.relative_feed] {
            column.clear();
        }
        for column in [&mut self.position, &mut self.velocity, &mut self.acceleration, &mut self.jerk] {
            column.clear();
        }
        self.block.clear();
        self.limit.clear();
    }
}

/// The whole-program figures.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Totals {
    /// Predicted cycle time (s), dwells included.
    pub cycle_time: f64,
    /// The time at the programmed feed: every feed block at the CL file's feed, rapids and
    /// reorientations as predicted, dwells (s); the cycle time minus the time lost.
    pub programmed_time: f64,
    /// The sum of the blocks' time lost (s).
    pub time_lost: f64,
    /// Tip length of the feed moves (mm).
    pub feed_length: f64,
    /// Tip length predicted below `threshold` × the programmed feed (mm).
    pub length_below: f64,
    /// The threshold (share of the programmed feed).
    pub threshold: f64,
    /// Interpolation steps computed.
    pub samples: u64,
    /// Pieces of the path the interpolator gave up on, ended at once: a loop that did not end,
    /// a bug; the times of their blocks are not the machine's.
    pub abandoned: u64,
}

impl Totals {
    /// The share of the feed path below the threshold.
    pub fn share_below(&self) -> f64 {
        if self.feed_length > 0.0 { self.length_below / self.feed_length } else { 0.0 }
    }
}

/// Time lost to one cause.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cause {
    /// The cause.
    pub limit: Limit,
    /// Time lost to it (s); negative where G1 output runs a block faster than the CL file's feed.
    pub seconds: f64,
    /// The feed blocks for which it is the main cause.
    pub blocks: usize,
}

/// The figures of one operation of the CL file.
#[derive(Clone, Debug, PartialEq)]
pub struct Operation {
    /// Its name (empty: the blocks before the first operation, or an operation without a name).
    pub name: String,
    /// Its first and last block (indices into [`Prediction::blocks`]).
    pub first: usize,
    /// Its last block.
    pub last: usize,
    /// Predicted time (s), dwells included.
    pub cycle_time: f64,
    /// Time at the programmed feed (s): `cycle_time - time_lost`.
    pub programmed_time: f64,
    /// The sum of its blocks' time lost (s).
    pub time_lost: f64,
    /// The time lost by cause, the largest first; the seconds add up to `time_lost`.
    pub causes: Vec<Cause>,
}

impl Operation {
    /// The cause that lost the most time (`Programmed` when none lost any).
    pub fn main_cause(&self) -> Limit {
        self.causes.first().filter(|c| c.seconds > 0.0).map_or(Limit::Programmed, |c| c.limit)
    }
}

/// What makes a slowdown worth a mark in the program.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MarkRules {
    /// A block is slow below this share of its programmed feed.
    pub threshold: f64,
    /// A run of slow blocks is marked when it loses at least this (s), exact stops aside.
    pub min_loss: f64,
    /// At most this many marks per operation, the worst kept.
    pub max_per_operation: usize,
}

impl Default for MarkRules {
    fn default() -> Self {
        MarkRules { threshold: 0.8, min_loss: 0.05, max_per_operation: 10 }
    }
}

/// A slowdown worth a programmer's look: a run of feed blocks below the threshold (apart from
/// the acceleration out of and the braking into exact stops) that loses at least the minimum.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Mark {
    /// Its number, from 1, in program order among the marks kept.
    pub number: usize,
    /// First block of the run (index into [`Prediction::blocks`]).
    pub first: usize,
    /// Last block of the run.
    pub last: usize,
    /// The feed blocks of the run that the NC program writes.
    pub blocks: usize,
    /// The lowest feed over the run as a share of the programmed one, exact stops aside.
    pub ratio: f64,
    /// What lost the most time over the run.
    pub cause: Limit,
    /// Time lost over the run apart from exact stops (s).
    pub lost: f64,
    /// Its operation (index into [`Prediction::operations`]).
    pub operation: usize,
    /// The step its first block ends at, and that step's CL statement.
    pub step: usize,
    /// The CL statement of [`Self::step`].
    pub span: postpro_cl::Span,
}

/// A prediction.
#[derive(Clone, Debug, Default)]
pub struct Prediction {
    /// One per block of the program.
    pub blocks: Vec<BlockResult>,
    /// The samples, when asked for.
    pub samples: Option<Samples>,
    /// The totals.
    pub totals: Option<Totals>,
    /// The assumptions made (a feed per revolution without a spindle speed, no feed).
    pub notes: Vec<crate::moves::Note>,
    /// The operations of the CL file that have blocks, in order.
    pub operations: Vec<Operation>,
}

impl Prediction {
    /// The totals (zero for an empty program).
    pub fn totals(&self) -> Totals {
        self.totals.unwrap_or(Totals {
            cycle_time: 0.0,
            programmed_time: 0.0,
            time_lost: 0.0,
            feed_length: 0.0,
            length_below: 0.0,
            threshold: 0.0,
            samples: 0,
            abandoned: 0,
        })
    }

    /// The time lost by cause over the whole program, the largest first; the seconds add up to
    /// the time lost.
    pub fn causes(&self) -> Vec<Cause> {
        merge(self.operations.iter().flat_map(|o| o.causes.iter().copied()))
    }

    /// The slowdowns worth a mark, in program order, numbered from 1: the runs of consecutive
    /// feed blocks whose lowest feed apart from exact stops is below the threshold, within one
    /// operation, that lose at least `min_loss` apart from exact stops; at most
    /// `max_per_operation` per operation, the worst kept.
    pub fn marks(&self, rules: &MarkRules) -> Vec<Mark> {
        let mut finder = MarkFinder::new(*rules);
        for (op, o) in self.operations.iter().enumerate() {
            for i in o.first..=o.last {
                finder.block(i, &self.blocks[i], op);
            }
        }
        finder.finish()
    }
}

/// Finds the marks of [`Prediction::marks`] as block results come, in program order: it holds
/// the run being read and the worst runs of each operation, not the blocks.
#[derive(Clone, Debug)]
pub struct MarkFinder {
    rules: MarkRules,
    /// The run being read, and the time it lost by each block's main cause.
    open: Option<(Mark, BTreeMap<Limit, f64>)>,
    /// Per operation, the runs kept so far, the worst first (ties in program order).
    kept: Vec<Vec<Mark>>,
}

impl MarkFinder {
    /// No block yet.
    pub fn new(rules: MarkRules) -> MarkFinder {
        MarkFinder { rules, open: None, kept: Vec::new() }
    }

    /// Block `i`, of operation `op`, predicted as `b`.
    pub fn block(&mut self, i: usize, b: &BlockResult, op: usize) {
        if self.open.as_ref().is_some_and(|(run, _)| run.operation != op) {
            self.close();
        }
        if b.kind == BlockKind::Reorientation {
            return; // neither breaks nor extends a run
        }
        let ratio = b.min_ratio_between_stops();
        if b.kind != BlockKind::Feed || ratio >= self.rules.threshold {
            self.close();
            return;
        }
        let own = b.lost - b.stop_lost;
        let (run, causes) = self.open.get_or_insert_with(|| {
            let run = Mark {
                number: 0,
                first: i,
                last: i,
                blocks: 0,
                ratio,
                cause: b.cause,
                lost: 0.0,
                operation: op,
                step: b.step,
                span: b.span,
            };
            (run, BTreeMap::new())
        });
        run.last = i;
        run.blocks += usize::from(b.written);
        run.ratio = run.ratio.min(ratio);
        run.lost += own;
        *causes.entry(b.cause).or_default() += own;
    }

    /// Ends the run being read, and keeps it if it is among the worst of its operation.
    fn close(&mut self) {
        let Some((mut run, causes)) = self.open.take() else { return };
        if let Some((limit, _)) = causes.iter().max_by(|a, b| a.1.total_cmp(b.1)) {
            run.cause = *limit;
        }
        if run.lost < self.rules.min_loss {
            return;
        }
        if self.kept.len() <= run.operation {
            self.kept.resize(run.operation + 1, Vec::new());
        }
        let kept = &mut self.kept[run.operation];
        let at = kept.partition_point(|k| k.lost.total_cmp(&run.lost) != std::cmp::Ordering::Less);
        if at < self.rules.max_per_operation {
            kept.insert(at, run);
            kept.truncate(self.rules.max_per_operation);
        }
    }

    /// The marks, in program order, numbered from 1.
    pub fn finish(mut self) -> Vec<Mark> {
        self.close();
        let mut marks: Vec<Mark> = self.kept.into_iter().flatten().collect();
        marks.sort_by_key(|m| m.first);
        for (n, m) in marks.iter_mut().enumerate() {
            m.number = n + 1;
        }
        marks
    }
}

/// Sums the seconds and blocks per cause, the largest first.
fn merge(causes: impl Iterator<Item = Cause>) -> Vec<Cause> {
    let mut sum: BTreeMap<Limit, (f64, usize)> = BTreeMap::new();
    for c in causes {
        let e = sum.entry(c.limit).or_default();
        e.0 += c.seconds;
        e.1 += c.blocks;
    }
    let mut out: Vec<Cause> =
        sum.into_iter().map(|(limit, (seconds, blocks))| Cause { limit, seconds, blocks }).collect();
    out.sort_by(|a, b| b.seconds.total_cmp(&a.seconds).then(a.limit.cmp(&b.limit)));
    out
}

/// mm/s → mm/min, rounded to a millionth (a feed read as 500 mm/min stays 500).
fn per_minute(feed: f64) -> f64 {
    (feed * 60.0 * 1e6).round() / 1e6
}

/// The words a programmer reads for a limit: `C jerk`, `corner`, `cycle time`.
pub fn describe(limit: Limit, machine: &Machine) -> String {
    let letter = |a: u16| machine.axes.get(a as usize).map_or_else(|| format!("axis {a}"), |x| x.letter.clone());
    match limit {
        Limit::Programmed => "programmed".into(),
        Limit::Velocity(a) => format!("{} velocity", letter(a)),
        Limit::Acceleration(a) => format!("{} acceleration", letter(a)),
        Limit::Jerk(a) => format!("{} jerk", letter(a)),
        Limit::TangentialAcceleration => "path acceleration".into(),
        Limit::TangentialJerk => "path jerk".into(),
        Limit::CycleTime => "cycle time".into(),
        Limit::Corner => "corner".into(),
        Limit::Curvature => "arc curvature".into(),
        Limit::LookAhead => "look-ahead".into(),
        Limit::Stop => "exact stop".into(),
        Limit::Rapid => "rapid".into(),
        Limit::AxisFeed => "G1 feed on the axes".into(),
        Limit::Plunge => "plunge or retract".into(),
    }
}

/// Collects the stepper's output into block results, time lost by cause and samples, as the
/// track grows: what it knows of each piece and block is held in windows, and a block's result
/// is final once the motion has left it ([`Collector::finalized`]).
pub(crate) struct Collector {
    /// Start and length of each piece in the parameter.
    piece_start: Window<f64>,
    piece_length: Window<f64>,
    /// The parameter at the end of the pieces so far.
    u_end: f64,
    /// Tip length per unit of the parameter, per block (the tip feed at `u̇ = 1`, mm/s, in
    /// programmed time; 1 on the tip path).
    scale: Window<f64>,
    /// Parameter length of each block's pieces.
    span: Window<f64>,
    /// Tip path length at the start of each block.
    path_start: Window<f64>,
    /// The tip path length at the end of the blocks so far.
    path_end: f64,
    /// Per block, its result (final before [`Self::finalized`]).
    pub(crate) results: Window<BlockResult>,
    /// Blocks whose results are final.
    pub(crate) finalized: usize,
    /// Blocks whose pieces are all made and whose figures are set up.
    prepared: usize,
    /// Time each block was entered.
    entered: Window<f64>,
    /// Lowest `u̇` per block, and lowest apart from exact stops.
    min_speed: Window<f64>,
    min_speed_between_stops: Window<f64>,
    pub(crate) samples: Option<Samples>,
    last_tip: Option<(f64, nalgebra::Point3<f64>)>,
    /// The parameter of the last sample.
    last_sample: Option<f64>,
    /// Where the tip length not yet compared with the threshold starts: the last sample, or
    /// the last junction crossed since (its parameter, and the piece after it).
    below_from: Option<(f64, usize)>,
    /// The time of the last sample.
    last_time: f64,
    pub(crate) length_below: f64,
    pub(crate) count: u64,
    threshold: f64,
    scratch: Vec<f64>,
    /// Per block with pieces: the time the program asks for (its nominal duration and those of
    /// the blocks of no piece before it, which it stands for), its time at the CL file's feed,
    /// and the programmed time per unit of the parameter.
    asked: Window<f64>,
    at_feed: Window<f64>,
    rate: Window<f64>,
    /// The same, summed over the blocks of no piece since the last block with pieces.
    asked_before: f64,
    at_feed_before: f64,
    /// The dwell spent at the start of each block.
    dwell_in: Window<f64>,
    split: Split,
    /// Per operation, the time lost and the blocks held back, by cause (a few causes each: a
    /// list, in the order they first came).
    causes: Vec<Vec<(Limit, (f64, usize))>>,
}

/// The seconds and blocks of `limit` in an operation's list of causes, added at its end when new.
fn cause_entry(causes: &mut Vec<(Limit, (f64, usize))>, limit: Limit) -> &mut (f64, usize) {
    let at = match causes.iter().position(|(l, _)| *l == limit) {
        Some(at) => at,
        None => {
            causes.push((limit, (0.0, 0)));
            causes.len() - 1
        }
    };
    &mut causes[at].1
}

/// True for what the program itself asks the motion to stop or turn at: an exact stop, a plunge
/// or a retract. A mark does not count the time lost to it.
fn asked_for(cause: Limit) -> bool {
    matches!(cause, Limit::Stop | Limit::Plunge)
}

/// Less than this (s) is no block's main cause: the rounding of the steps.
const MAIN_CAUSE_FLOOR: f64 = 1e-6;

/// The step-by-step split of the time lost among its causes.
struct Split {
    /// Time, parameter and piece of the last point accounted for.
    t: f64,
    u: f64,
    piece: usize,
    started: bool,
    /// The current step's parts in the blocks it crossed: (block, time beyond the programmed
    /// time), and the speeds at its crossings: (block, `u̇`).
    parts: Vec<(usize, f64)>,
    speeds: Vec<(usize, f64)>,
    /// What caused the dip the motion is in (accelerating out of it inherits it).
    dip: Option<Limit>,
    /// The block being accumulated and its time lost by cause.
    block: Option<usize>,
    shares: Vec<(Limit, f64)>,
}

/// What the collector reads while it observes: the blocks, the track and what each piece is.
pub(crate) struct Seen<'a> {
    pub(crate) blocks: &'a Blocks,
    pub(crate) track: &'a Track,
    pub(crate) owner: &'a Window<usize>,
    pub(crate) curves: Option<&'a Curves>,
    /// The kinematics, when samples are kept.
    pub(crate) kin: Option<&'a dyn Kinematics>,
}

impl Collector {
    /// Before the first block; `samples` keeps every sample (of a machine of `axes` axes).
    pub(crate) fn new(axes: usize, samples: bool, threshold: f64) -> Self {
        Collector {
            piece_start: Window::default(),
            piece_length: Window::default(),
            u_end: 0.0,
            scale: Window::default(),
            span: Window::default(),
            path_start: Window::default(),
            path_end: 0.0,
            results: Window::default(),
            finalized: 0,
            prepared: 0,
            entered: Window::default(),
            min_speed: Window::default(),
            min_speed_between_stops: Window::default(),
            samples: samples.then(|| Samples { axes, ..Samples::default() }),
            last_tip: None,
            last_sample: None,
            below_from: None,
            last_time: 0.0,
            length_below: 0.0,
            count: 0,
            threshold,
            scratch: vec![0.0; axes],
            asked: Window::default(),
            at_feed: Window::default(),
            rate: Window::default(),
            asked_before: 0.0,
            at_feed_before: 0.0,
            dwell_in: Window::default(),
            split: Split::empty(),
            causes: Vec::new(),
        }
    }

    /// Takes in the pieces made so far, and the blocks before `ready` (whose pieces are all
    /// made).
    pub(crate) fn prepare(&mut self, seen: &Seen<'_>) {
        let (blocks, track, owner) = (seen.blocks, seen.track, seen.owner);
        while self.results.end() < blocks.len() {
            let i = self.results.end();
            let programmed = per_minute(blocks.feed[i]);
            self.results.push(BlockResult {
                step: blocks.step[i],
                span: blocks.span[i],
                kind: blocks.kind[i],
                written: blocks.written.get(i).copied().unwrap_or(true),
                length: blocks.length[i],
                programmed,
                min_feed: programmed,
                mean_feed: programmed,
                time: 0.0,
                limit: Limit::Programmed,
                lost: 0.0,
                stop_lost: 0.0,
                cause: Limit::Programmed,
                operation: blocks.operation[i] as usize,
                min_feed_between_stops: programmed,
            });
            self.entered.push(0.0);
            self.min_speed.push(f64::INFINITY);
            self.min_speed_between_stops.push(f64::INFINITY);
            self.scale.push(0.0);
            self.span.push(0.0);
            self.dwell_in.push(0.0);
            self.path_start.push(self.path_end);
            self.path_end += blocks.length[i];
        }
        while self.causes.len() < blocks.operations.len() {
            self.causes.push(Vec::new());
        }
        while self.piece_start.end() < track.len() {
            let p = self.piece_start.end();
            let (l, b) = (track.pieces[p].length, owner[p]);
            self.piece_start.push(self.u_end);
            self.piece_length.push(l);
            let curve = seen.curves.is_some_and(|c| matches!(c.segments.get(p), Some(Segment::Curve { .. })));
            // On a spline the parameter is the tip's chord length: about 1 mm of tip per unit.
            self.scale[b] = if curve { 1.0 } else { blocks.length[b] / l };
            if p == 0 || owner[p - 1] != b {
                self.dwell_in[b] = if p == 0 { track.dwell_at_start } else { track.junctions[p - 1].dwell };
            }
            self.span[b] += l;
            self.u_end += l;
        }
        // A block of no piece is covered by the next block that has one.
        while self.prepared < blocks.len() {
            let b = self.prepared;
            self.prepared += 1;
            self.asked_before += blocks.nominal[b];
            self.at_feed_before += match blocks.kind[b] {
                BlockKind::Feed if blocks.feed[b] > 0.0 => blocks.length[b] / blocks.feed[b],
                _ => blocks.nominal[b],
            };
            let (asked, at_feed, rate) = if self.span[b] > 0.0 {
                let figures = (self.asked_before, self.at_feed_before, self.asked_before / self.span[b]);
                (self.asked_before, self.at_feed_before) = (0.0, 0.0);
                figures
            } else {
                (0.0, 0.0, 0.0)
            };
            self.asked.push(asked);
            self.at_feed.push(at_feed);
            self.rate.push(rate);
        }
    }

    /// Notes the parameter speed `v` reached on `block` with `limit` holding it.
    fn reach(&mut self, blocks: &Blocks, block: usize, v: f64, limit: Limit) {
        if v < self.min_speed[block] {
            self.min_speed[block] = v;
            self.results[block].limit = self.shown(blocks, block, v, limit);
        }
    }

    /// Adds to [`Self::length_below`] the tip length from where it was last compared to parameter
    /// `u` on `piece` (of `block`), when the parameter speed `v` reached there is below the
    /// threshold (a feed block's; nothing when the motion is on another piece than that start: a
    /// junction between is compared as it is crossed).
    fn below(&mut self, blocks: &Blocks, block: usize, u: f64, piece: usize, v: f64) {
        let Some((u0, p0)) = self.below_from else { return };
        if p0 == piece && blocks.kind[block] == BlockKind::Feed {
            let tip_feed = self.scale[block];
            if v * tip_feed / blocks.feed[block] < self.threshold {
                self.length_below += (u - u0) * tip_feed;
            }
        }
    }

    /// What to report for parameter speed `v` on `block` held by `limit`: `Programmed` when
    /// the tip reaches the programmed feed, `AxisFeed` when the CNC is at its F but the tip is
    /// not (G1 timing: the nominal tip feed is below the programmed one).
    fn shown(&self, blocks: &Blocks, block: usize, v: f64, limit: Limit) -> Limit {
        let feed = blocks.feed[block];
        let tip = v * self.scale[block];
        if feed > 0.0 && tip >= 0.999 * feed {
            Limit::Programmed
        } else if limit == Limit::Programmed
            && blocks.kind[block] == BlockKind::Feed
            && blocks.nominal_tip_feed(block) < 0.999 * feed
        {
            Limit::AxisFeed
        } else {
            limit
        }
    }

    /// What the step that ends with `s` lost its time to (see the module's documentation).
    fn cause(&mut self, track: &Track, s: &Sample) -> Limit {
        let piece = &track.pieces[s.piece];
        let dip = &mut self.split.dip;
        if s.ahead {
            // Braking for what is ahead: the dip is its.
            *dip = Some(s.bound);
            s.bound
        } else if s.v >= piece.velocity * (1.0 - 1e-6) {
            // At the piece's cap (the cruise snaps to it): the dip is over, or is the cap's.
            let cap = piece.velocity_limit;
            *dip = (cap != Limit::Programmed).then_some(cap);
            cap
        } else {
            // Accelerating: still the dip's.
            dip.unwrap_or(s.bound)
        }
    }

    /// The part of the current step from the last point accounted for to parameter `u` at time
    /// `t`, in the piece the motion is in.
    fn part(&mut self, owner: &Window<usize>, t: f64, u: f64) {
        let block = owner[self.split.piece];
        let beyond = self.beyond(block, t, u);
        self.split.parts.push((block, beyond));
    }

    /// The time beyond the programmed one from the last point accounted for to parameter `u` at
    /// time `t`, on `block`.
    fn beyond(&self, block: usize, t: f64, u: f64) -> f64 {
        (t - self.split.t) - (u - self.split.u) * self.rate[block]
    }

    /// Gives the parts of the step that ends with `s` (on `block`) to its cause.
    fn account(&mut self, seen: &Seen<'_>, s: &Sample, block: usize) {
        if !self.split.started {
            (self.split.t, self.split.u, self.split.piece, self.split.started) = (s.t, s.u, s.piece, true);
            return;
        }
        if self.split.parts.is_empty() && self.split.piece == s.piece {
            // Most steps: no junction crossed since the last sample, the step is one part on the
            // piece it ends on (the same sums as below, without the lists).
            let beyond = self.beyond(block, s.t, s.u);
            (self.split.t, self.split.u) = (s.t, s.u);
            let cause = self.cause(seen.track, s);
            self.share(seen.blocks, block, cause, beyond);
            if !asked_for(cause) {
                let low = &mut self.min_speed_between_stops[block];
                *low = low.min(s.v);
            }
            return;
        }
        self.part(seen.owner, s.t, s.u);
        (self.split.t, self.split.u) = (s.t, s.u);
        let cause = self.cause(seen.track, s);
        let owner = seen.owner[s.piece];
        self.split.speeds.push((owner, s.v));
        let parts = std::mem::take(&mut self.split.parts);
        for &(block, beyond) in &parts {
            self.share(seen.blocks, block, cause, beyond);
        }
        self.split.parts = parts;
        self.split.parts.clear();
        if !asked_for(cause) {
            for &(block, v) in &self.split.speeds {
                let low = &mut self.min_speed_between_stops[block];
                *low = low.min(v);
            }
        }
        self.split.speeds.clear();
    }

    /// Adds `seconds` lost to `cause` on `block`.
    fn share(&mut self, blocks: &Blocks, block: usize, cause: Limit, seconds: f64) {
        if self.split.block != Some(block) {
            if let Some(done) = self.split.block {
                self.close(blocks, done);
            }
            self.split.block = Some(block);
        }
        match self.split.shares.iter_mut().find(|(l, _)| *l == cause) {
            Some(share) => share.1 += seconds,
            None => self.split.shares.push((cause, seconds)),
        }
    }

    /// Ends the split of `block`: its main cause, its time lost to exact stops, and its shares
    /// added to its operation's.
    fn close(&mut self, blocks: &Blocks, block: usize) {
        let mut shares = std::mem::take(&mut self.split.shares);
        if blocks.kind[block] == BlockKind::Feed {
            // Rounding aside (on a 3-axis machine both are the same sum).
            let g1 = self.asked[block] - self.at_feed[block];
            if g1.abs() > 1e-9 * self.asked[block] {
                shares.push((Limit::AxisFeed, g1));
            }
            let result = &mut self.results[block];
            result.stop_lost = shares.iter().filter(|(l, _)| asked_for(*l)).map(|(_, s)| s).sum();
            result.cause = shares
                .iter()
                .filter(|(l, s)| !asked_for(*l) && *s > MAIN_CAUSE_FLOOR)
                .max_by(|a, b| a.1.total_cmp(&b.1))
                .map_or(Limit::Programmed, |(l, _)| *l);
            let causes = &mut self.causes[blocks.operation[block] as usize];
            for &(limit, seconds) in &shares {
                cause_entry(causes, limit).0 += seconds;
            }
            if result.cause != Limit::Programmed {
                cause_entry(causes, result.cause).1 += 1;
            }
        }
        shares.clear();
        self.split.shares = shares;
    }

    /// Makes final the results of the blocks before `end` (the motion has left them; at the end of
    /// the program, every block): feeds from the shares, mean feeds from the times, the time
    /// lost. Returns the range of blocks made final.
    pub(crate) fn finalize(&mut self, blocks: &Blocks, end: usize, done: bool) -> std::ops::Range<usize> {
        if done && let Some(block) = self.split.block.take() {
            self.close(blocks, block);
        }
        let end = if done { self.results.end() } else { end.min(self.split.block.unwrap_or(0)) };
        let from = self.finalized;
        for i in from..end.max(from) {
            let r = &mut self.results[i];
            if self.min_speed[i].is_finite() {
                let lowest = self.min_speed[i] * self.scale[i] * 60.0;
                r.min_feed = if r.kind == BlockKind::Feed { lowest.min(r.programmed) } else { lowest };
            }
            if self.min_speed_between_stops[i].is_finite() {
                let lowest = self.min_speed_between_stops[i] * self.scale[i] * 60.0;
                r.min_feed_between_stops = if r.kind == BlockKind::Feed { lowest.min(r.programmed) } else { lowest };
            }
            r.mean_feed = if r.time > 0.0 { r.length / r.time * 60.0 } else { 0.0 };
            if r.kind == BlockKind::Feed && self.asked.get(i).is_some_and(|&a| a > 0.0) {
                r.lost = r.time - self.dwell_in[i] - self.at_feed[i];
            }
            if r.kind != BlockKind::Feed {
                r.programmed = 0.0;
            }
        }
        self.finalized = end.max(from);
        from..self.finalized
    }

    /// The time lost by cause of operation `op` so far.
    pub(crate) fn causes_of(&self, op: usize) -> Vec<Cause> {
        self.causes.get(op).map_or_else(Vec::new, |causes| {
            merge(causes.iter().map(|&(limit, (seconds, blocks))| Cause { limit, seconds, blocks }))
        })
    }

    /// Forgets what it holds of the blocks before block `b` and the pieces before piece `p`, but
    /// where the blocks start along the path from block `path_from` on (the first block of the
    /// spline the motion is on, whose samples count their path length from it).
    pub(crate) fn forget_before(&mut self, b: usize, p: usize, path_from: usize) {
        let b = b.min(self.finalized);
        self.piece_start.forget_before(p);
        self.piece_length.forget_before(p);
        for w in [&mut self.scale, &mut self.span, &mut self.entered] {
            w.forget_before(b);
        }
        self.path_start.forget_before(b.min(path_from));
        for w in [&mut self.min_speed, &mut self.min_speed_between_stops, &mut self.asked, &mut self.at_feed] {
            w.forget_before(b);
        }
        self.rate.forget_before(b);
        self.dwell_in.forget_before(b);
        self.results.forget_before(b);
    }

    /// The observer of the stepper, reading `seen`.
    pub(crate) fn observing<'s>(&'s mut self, seen: &'s Seen<'s>) -> Observing<'s> {
        Observing { collector: self, seen }
    }
}

impl Split {
    /// Before the first sample: the program starts at rest.
    fn empty() -> Split {
        Split {
            t: 0.0,
            u: 0.0,
            piece: 0,
            started: false,
            parts: Vec::new(),
            speeds: Vec::new(),
            dip: Some(Limit::Stop),
            block: None,
            shares: Vec::new(),
        }
    }
}

/// The collector observing the stepper.
pub(crate) struct Observing<'s> {
    collector: &'s mut Collector,
    seen: &'s Seen<'s>,
}

impl Observer for Observing<'_> {
    fn sample(&mut self, s: &Sample) {
        let (c, seen) = (&mut *self.collector, self.seen);
        let blocks = seen.blocks;
        c.count += s.periods;
        let block = seen.owner[s.piece];
        c.account(seen, s, block);
        c.reach(blocks, block, s.v, s.limit);
        // The tip length covered since the last sample or junction, below the threshold or not.
        c.below(blocks, block, s.u, s.piece, s.v);
        c.below_from = Some((s.u, s.piece));
        let (u0, t0) = (c.last_sample.unwrap_or(s.u), c.last_time);
        c.last_sample = Some(s.u);
        c.last_time = s.t;
        if c.samples.is_none() {
            return;
        }
        // A cruise taken in one go stands for a sample every period: kept each, on the piece
        // it is on (the cruise may cross junctions into pieces of the same cap).
        let periods = s.periods.max(1);
        let mut piece = s.piece;
        for k in 1..=periods {
            let at = if k == periods {
                *s
            } else {
                let share = k as f64 / periods as f64;
                let u = u0 + (s.u - u0) * share;
                let (start, length) = (&self.collector.piece_start, &self.collector.piece_length);
                while piece > start.base() && u < start[piece] {
                    piece -= 1;
                }
                while piece < s.piece && u >= start[piece] + length[piece] {
                    piece += 1;
                }
                Sample { t: t0 + (s.t - t0) * share, u, piece, periods: 1, ..*s }
            };
            self.record(&at, seen.owner[at.piece]);
        }
    }

    fn every_period(&self) -> bool {
        false
    }

    fn crossing(&mut self, piece: usize, t: f64, v: f64, limit: Limit) {
        let (c, seen) = (&mut *self.collector, self.seen);
        let block = seen.owner[piece];
        c.reach(seen.blocks, block, v, limit);
        let end = c.piece_start[piece] + c.piece_length[piece];
        c.below(seen.blocks, block, end, piece, v);
        c.below_from = Some((end, piece + 1));
        c.results[block].time = t - c.entered[block];
        // The step's part in the piece it leaves; a dwell after it belongs to no step.
        c.split.piece = piece;
        c.part(seen.owner, t, end);
        c.split.speeds.push((block, v));
        c.split.u = end;
        c.split.t = t;
        if piece + 1 < seen.track.len() {
            c.split.t += seen.track.junctions[piece].dwell;
            c.split.piece = piece + 1;
        }
        if let Some(&next) = seen.owner.get(piece + 1) {
            c.split.speeds.push((next, v));
            // The blocks in between have no duration.
            for b in block + 1..=next {
                c.entered[b] = t;
            }
            c.reach(seen.blocks, next, v, limit);
        }
    }
}

impl Observing<'_> {
    /// Keeps sample `s` of `block`: the axes' positions to jerk, the feeds and what held them.
    fn record(&mut self, s: &Sample, block: usize) {
        let (c, seen) = (&mut *self.collector, self.seen);
        let blocks = seen.blocks;
        let length = c.piece_length[s.piece];
        let tip_feed = c.scale[block];
        let shown = c.shown(blocks, block, s.v, s.limit);
        let Some(samples) = c.samples.as_mut() else { return };
        let fraction = ((s.u - c.piece_start[s.piece]) / length).clamp(0.0, 1.0);
        match seen.curves.and_then(|cv| cv.segments.get(s.piece).map(|g| (cv, *g))) {
            Some((curves, Segment::Curve { spline, from })) => {
                // q̇ = q_s ṡ, q̈ = q_ss ṡ² + q_s s̈, q⃛ = q_sss ṡ³ + 3 q_ss ṡ s̈ + q_s s⃛.
                let sigma = from + (s.u - c.piece_start[s.piece]).clamp(0.0, length);
                let d = curves.splines[spline].derivatives(sigma);
                let [q, qs, qss, qsss] = &d;
                for (((q, qs), qss), qsss) in
                    q.as_slice().iter().zip(qs.as_slice()).zip(qss.as_slice()).zip(qsss.as_slice())
                {
                    samples.position.push(*q);
                    samples.velocity.push(qs * s.v);
                    samples.acceleration.push(qss * s.v * s.v + qs * s.a);
                    samples.jerk.push(qsss * s.v.powi(3) + 3.0 * qss * s.v * s.a + qs * s.j);
                }
                samples.path.push(c.path_start[curves.start_block[spline]] + sigma);
            }
            _ => {
                blocks.delta(block, &mut c.scratch);
                let start = blocks.position(block);
                for (d, p) in c.scratch.iter().zip(start) {
                    samples.position.push(p + d * fraction);
                    samples.velocity.push(d / length * s.v);
                    samples.acceleration.push(d / length * s.a);
                    samples.jerk.push(d / length * s.j);
                }
                samples.path.push(c.path_start[block] + blocks.length[block] * fraction);
            }
        }
        samples.time.push(s.t);
        samples.block.push(block as u32);
        samples.feed.push(s.v * tip_feed * 60.0);
        samples.programmed.push(per_minute(blocks.feed[block]));
        samples.limit.push(shown);
        let relative = match seen.kin {
            Some(kin) => {
                let n = samples.position.len();
                let tip = kin.forward(&Joints::from_slice(&samples.position[n - samples.axes..])).tip;
                let feed = match c.last_tip {
                    Some((t0, p0)) if s.t > t0 => (tip - p0).norm() / (s.t - t0) * 60.0,
                    _ => 0.0,
                };
                c.last_tip = Some((s.t, tip));
                feed
            }
            None => 0.0,
        };
        samples.relative_feed.push(relative);
    }
}
