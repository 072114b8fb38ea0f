//! What a prediction tells: per block, per sample, and for the whole program.

use crate::moves::{BlockKind, Blocks};
use crate::plan::{Limit, Observer, Sample};
use crate::vpop::{Curves, Segment};
use postpro_kin::{Joints, Kinematics};
use postpro_machine::model::Machine;

/// The prediction of one block.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BlockResult {
    /// Index of the block's end step in the solved tool path.
    pub step: usize,
    /// Feed move, reorientation or rapid.
    pub kind: BlockKind,
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
}

impl BlockResult {
    /// The lowest feed as a share of the programmed one (1 for rapids and reorientations).
    pub fn min_ratio(&self) -> f64 {
        if self.kind == BlockKind::Feed && self.programmed > 0.0 { self.min_feed / self.programmed } else { 1.0 }
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
}

/// The whole-program figures.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Totals {
    /// Predicted cycle time (s), dwells included.
    pub cycle_time: f64,
    /// The time the program asks for: every block at its programmed feed, rapids at the axes'
    /// speed, dwells (s).
    pub programmed_time: f64,
    /// Predicted minus programmed time (s).
    pub time_lost: f64,
    /// Tip length of the feed moves (mm).
    pub feed_length: f64,
    /// Tip length predicted below `threshold` × the programmed feed (mm).
    pub length_below: f64,
    /// The threshold (share of the programmed feed).
    pub threshold: f64,
    /// Interpolation steps computed.
    pub samples: u64,
}

impl Totals {
    /// The share of the feed path below the threshold.
    pub fn share_below(&self) -> f64 {
        if self.feed_length > 0.0 { self.length_below / self.feed_length } else { 0.0 }
    }
}

/// A run of feed blocks predicted below the threshold.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Slowdown {
    /// First block of the run (index into [`Prediction::blocks`]).
    pub first: usize,
    /// Last block of the run.
    pub last: usize,
    /// The lowest feed over the run as a share of the programmed one.
    pub ratio: f64,
    /// What holds it there.
    pub limit: Limit,
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
        })
    }

    /// The runs of consecutive feed blocks whose lowest feed is below `threshold` × programmed.
    pub fn slowdowns(&self, threshold: f64) -> Vec<Slowdown> {
        let mut runs: Vec<Slowdown> = Vec::new();
        let mut open = false;
        for (i, b) in self.blocks.iter().enumerate() {
            // Starting from or coming to an exact stop is no slowdown a programmer can act on.
            let slow = b.kind == BlockKind::Feed && b.min_ratio() < threshold && b.limit != Limit::Stop;
            match runs.last_mut() {
                Some(run) if open && slow => {
                    run.last = i;
                    if b.min_ratio() < run.ratio {
                        run.ratio = b.min_ratio();
                        run.limit = b.limit;
                    }
                }
                _ if slow => {
                    runs.push(Slowdown { first: i, last: i, ratio: b.min_ratio(), limit: b.limit });
                }
                _ => {}
            }
            // Reorientations and zero-length blocks neither break nor extend a run.
            if b.kind != BlockKind::Reorientation {
                open = slow;
            }
        }
        runs
    }
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
        Limit::LookAhead => "look-ahead".into(),
        Limit::Stop => "exact stop".into(),
        Limit::Rapid => "rapid".into(),
        Limit::AxisFeed => "G1 feed on the axes".into(),
    }
}

/// Collects the stepper's output into block results and samples, for the inverse-time model
/// (blocks linear in the axes over their programmed time).
pub(crate) struct Collector<'a> {
    blocks: &'a Blocks,
    /// The block of each piece.
    owner: &'a [usize],
    /// Start and length of each piece in the parameter.
    piece_start: Vec<f64>,
    piece_length: Vec<f64>,
    /// Tip length per unit of the parameter, per block (the tip feed at `u̇ = 1`, mm/s, in
    /// programmed time; 1 on the tip path).
    scale: Vec<f64>,
    /// Tip path length at the start of each block.
    path_start: Vec<f64>,
    pub(crate) results: Vec<BlockResult>,
    /// Time each block was entered.
    entered: Vec<f64>,
    /// Lowest `u̇` per block.
    min_speed: Vec<f64>,
    pub(crate) samples: Option<Samples>,
    kin: Option<&'a dyn Kinematics>,
    curves: Option<&'a Curves>,
    last_tip: Option<(f64, nalgebra::Point3<f64>)>,
    last_sample: Option<(f64, usize)>,
    pub(crate) length_below: f64,
    pub(crate) count: u64,
    threshold: f64,
    scratch: Vec<f64>,
}

impl<'a> Collector<'a> {
    pub(crate) fn new(
        blocks: &'a Blocks,
        owner: &'a [usize],
        lengths: impl Iterator<Item = f64>,
        keep_samples: Option<&'a dyn Kinematics>,
        curves: Option<&'a Curves>,
        threshold: f64,
    ) -> Self {
        let mut piece_start = Vec::with_capacity(owner.len());
        let mut piece_length = Vec::with_capacity(owner.len());
        let mut scale = vec![0.0; blocks.len()];
        let mut u = 0.0;
        for (l, &b) in lengths.zip(owner) {
            piece_start.push(u);
            piece_length.push(l);
            let curve =
                curves.is_some_and(|c| matches!(c.segments.get(piece_start.len() - 1), Some(Segment::Curve { .. })));
            // On a spline the parameter is the tip's chord length: about 1 mm of tip per unit.
            scale[b] = if curve { 1.0 } else { blocks.length[b] / l };
            u += l;
        }
        let mut path_start = Vec::with_capacity(blocks.len());
        let mut s = 0.0;
        for &l in &blocks.length {
            path_start.push(s);
            s += l;
        }
        let results = (0..blocks.len())
            .map(|i| {
                let programmed = per_minute(blocks.feed[i]);
                BlockResult {
                    step: blocks.step[i],
                    kind: blocks.kind[i],
                    length: blocks.length[i],
                    programmed,
                    min_feed: programmed,
                    mean_feed: programmed,
                    time: 0.0,
                    limit: Limit::Programmed,
                }
            })
            .collect();
        Collector {
            blocks,
            owner,
            piece_start,
            piece_length,
            scale,
            path_start,
            results,
            entered: vec![0.0; blocks.len()],
            min_speed: vec![f64::INFINITY; blocks.len()],
            samples: keep_samples.map(|_| Samples { axes: blocks.axes, ..Samples::default() }),
            kin: keep_samples,
            curves,
            last_tip: None,
            last_sample: None,
            length_below: 0.0,
            count: 0,
            threshold,
            scratch: vec![0.0; blocks.axes],
        }
    }

    /// Notes the parameter speed `v` reached on `block` with `limit` holding it.
    fn reach(&mut self, block: usize, v: f64, limit: Limit) {
        if v < self.min_speed[block] {
            self.min_speed[block] = v;
            self.results[block].limit = self.shown(block, v, limit);
        }
    }

    /// What to report for parameter speed `v` on `block` held by `limit`: `Programmed` when
    /// the tip reaches the programmed feed, `AxisFeed` when the CNC is at its F but the tip is
    /// not (G1 timing).
    fn shown(&self, block: usize, v: f64, limit: Limit) -> Limit {
        let feed = self.blocks.feed[block];
        let tip = v * self.scale[block];
        if feed > 0.0 && tip >= 0.999 * feed {
            Limit::Programmed
        } else if limit == Limit::Programmed && self.blocks.kind[block] == BlockKind::Feed {
            Limit::AxisFeed
        } else {
            limit
        }
    }

    /// Ends the results: feeds from the shares, mean feeds from the times.
    pub(crate) fn finish(&mut self) {
        for (i, r) in self.results.iter_mut().enumerate() {
            if self.min_speed[i].is_finite() {
                let lowest = self.min_speed[i] * self.scale[i] * 60.0;
                r.min_feed = if r.kind == BlockKind::Feed { lowest.min(r.programmed) } else { lowest };
            }
            r.mean_feed = if r.time > 0.0 { r.length / r.time * 60.0 } else { 0.0 };
            if r.kind != BlockKind::Feed {
                r.programmed = 0.0;
            }
        }
    }
}

impl Observer for Collector<'_> {
    fn sample(&mut self, s: &Sample) {
        self.count += 1;
        let block = self.owner[s.piece];
        self.reach(block, s.v, s.limit);
        // The tip length covered since the last sample, below the threshold or not.
        let length = self.piece_length[s.piece];
        let tip_feed = self.scale[block];
        if let Some((u0, p0)) = self.last_sample
            && p0 == s.piece
            && self.blocks.kind[block] == BlockKind::Feed
        {
            let share = s.v * tip_feed / self.blocks.feed[block];
            if share < self.threshold {
                self.length_below += (s.u - u0) * tip_feed;
            }
        }
        self.last_sample = Some((s.u, s.piece));
        let shown = self.shown(block, s.v, s.limit);
        let Some(samples) = self.samples.as_mut() else { return };
        let fraction = ((s.u - self.piece_start[s.piece]) / length).clamp(0.0, 1.0);
        match self.curves.and_then(|c| c.segments.get(s.piece).map(|g| (c, *g))) {
            Some((curves, Segment::Curve { spline, from })) => {
                // q̇ = q_s ṡ, q̈ = q_ss ṡ² + q_s s̈, q⃛ = q_sss ṡ³ + 3 q_ss ṡ s̈ + q_s s⃛.
                let sigma = from + (s.u - self.piece_start[s.piece]).clamp(0.0, length);
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
                samples.path.push(self.path_start[curves.start_block[spline]] + sigma);
            }
            _ => {
                self.blocks.delta(block, &mut self.scratch);
                let start = self.blocks.position(block);
                for (d, p) in self.scratch.iter().zip(start) {
                    samples.position.push(p + d * fraction);
                    samples.velocity.push(d / length * s.v);
                    samples.acceleration.push(d / length * s.a);
                    samples.jerk.push(d / length * s.j);
                }
                samples.path.push(self.path_start[block] + self.blocks.length[block] * fraction);
            }
        }
        samples.time.push(s.t);
        samples.block.push(block as u32);
        samples.feed.push(s.v * tip_feed * 60.0);
        samples.programmed.push(per_minute(self.blocks.feed[block]));
        samples.limit.push(shown);
        let relative = match self.kin {
            Some(kin) => {
                let n = samples.position.len();
                let tip = kin.forward(&Joints::from_slice(&samples.position[n - samples.axes..])).tip;
                let feed = match self.last_tip {
                    Some((t0, p0)) if s.t > t0 => (tip - p0).norm() / (s.t - t0) * 60.0,
                    _ => 0.0,
                };
                self.last_tip = Some((s.t, tip));
                feed
            }
            None => 0.0,
        };
        samples.relative_feed.push(relative);
    }

    fn crossing(&mut self, piece: usize, t: f64, v: f64, limit: Limit) {
        let block = self.owner[piece];
        self.reach(block, v, limit);
        self.results[block].time = t - self.entered[block];
        if let Some(&next) = self.owner.get(piece + 1) {
            // The blocks in between have no duration.
            for b in block + 1..=next {
                self.entered[b] = t;
            }
            self.reach(next, v, limit);
        }
    }
}
