//! Prediction of the feed the machine really reaches (`../shared/DOMAIN.md` §4–5).
//!
//! From a solved tool path: [`moves::blocks`] gives the blocks the CNC is asked for (axis
//! displacements, programmed feed, nominal duration); a planner turns them into a
//! [`plan::Track`] (caps on a path parameter, corner caps, exact stops), and [`plan::run`] steps
//! the jerk-limited motion through it at the CNC's interpolation period. The result
//! ([`Prediction`]) gives each block's lowest and mean feed, what holds it back and its time,
//! the whole program's cycle time and slowdowns, and, when asked, every sample with each axis's
//! position, velocity, acceleration and jerk and the relative tool/surface feed rebuilt through
//! the forward kinematics.
//!
//! Two planners: [`Planner::InverseTime`], the model of papers 000 and 001 (block-wise caps in
//! inverse time, corner rounding, cycle time, look-ahead over N blocks), and [`Planner::Vpop`],
//! paper 003's interpolation on the tool-tip path with per-axis constraints through the chain
//! rule and the CNC's tangential limits.

pub mod block;
pub mod corner;
pub mod model;
pub mod moves;
pub mod plan;
pub mod profile;
mod report;
pub mod vpop;
pub mod window;

pub use block::{BlockLimits, Limiter, block_limits};
pub use corner::{blend_radius, corner_speed, interior_angle};
pub use moves::{BlockKind, Blocks, Timing, blocks};
pub use plan::Limit;
pub use profile::{Profile, State, speed_change};
pub use report::{BlockResult, Cause, Mark, MarkFinder, MarkRules, Operation, Prediction, Samples, Totals, describe};

use crate::plan::TrackBuilder;

use postpro_kin::Kinematics;

/// Which model of the CNC's interpolator.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Planner {
    /// Papers 000/001: inverse time, block-wise caps, look-ahead over the machine's N blocks.
    #[default]
    InverseTime,
    /// Paper 003 (VPOp): the tool-tip path, per-axis constraints through the chain rule,
    /// tangential limits, the whole path seen ahead.
    Vpop,
}

/// What to predict.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Options {
    /// The model.
    pub planner: Planner,
    /// A block is a slowdown below this share of its programmed feed.
    pub threshold: f64,
    /// Keep every sample (for plots and exports), with the relative feed through the forward
    /// kinematics.
    pub samples: bool,
    /// The sampling period (s); the CNC's interpolation cycle when `None`.
    pub period: Option<f64>,
    /// The program is written as B-splines (`bspline` output): VPOp follows the splines the
    /// emitter fits (whatever `planner` says: the block-wise model has no splines).
    pub splines: bool,
}

impl Default for Options {
    fn default() -> Self {
        Options { planner: Planner::InverseTime, threshold: 0.8, samples: false, period: None, splines: false }
    }
}

/// Predicts the motion of `blocks` (the whole program) on the machine of `kin`.
pub fn predict(blocks: &Blocks, kin: &dyn Kinematics, options: &Options) -> Prediction {
    let mut predictor = Predictor::new(kin, options, blocks.axes, false);
    predictor.advance(blocks);
    predictor.finish(blocks);
    predictor.into_prediction(blocks)
}

/// The prediction as the blocks of a program come: [`Predictor::advance`] after blocks are
/// added to a [`Blocks`], [`Predictor::finish`] after the last; the results of the blocks the
/// motion has left are final ([`Predictor::result`]). Streamed, it holds only what its
/// look-ahead needs: the caller forgets the blocks before [`Predictor::needs_from`].
pub struct Predictor<'k> {
    kin: &'k dyn Kinematics,
    options: Options,
    maker: Maker,
    track: TrackBuilder,
    stepper: plan::Stepper,
    collector: report::Collector,
    /// Per operation so far, its figures summed from the final results.
    operations: Vec<Operation>,
    time_lost: f64,
    feed_length: f64,
    /// Forget what the motion has left behind.
    forget: bool,
}

/// The planner's maker of pieces.
enum Maker {
    Model(model::Maker),
    Vpop(vpop::Maker),
}

impl<'k> Predictor<'k> {
    /// A prediction on the machine of `kin` (with `axes` axes) as `options` say; `forget`: hold
    /// only what the look-ahead needs (the per-block results are then final and gone once read).
    pub fn new(kin: &'k dyn Kinematics, options: &Options, axes: usize, forget: bool) -> Predictor<'k> {
        let machine = kin.machine();
        let (maker, window) = match (options.splines, options.planner) {
            (true, _) => (Maker::Vpop(vpop::Maker::new(axes, machine, true)), usize::MAX),
            (false, Planner::InverseTime) => (Maker::Model(model::Maker::new(axes)), model::window(machine)),
            (false, Planner::Vpop) => (Maker::Vpop(vpop::Maker::new(axes, machine, false)), usize::MAX),
        };
        let period = options.period.unwrap_or(machine.cnc.cycle_time);
        Predictor {
            kin,
            options: *options,
            maker,
            track: TrackBuilder::new(window),
            stepper: plan::Stepper::new(period),
            collector: report::Collector::new(axes, options.samples, options.threshold),
            operations: Vec::new(),
            time_lost: 0.0,
            feed_length: 0.0,
            forget,
        }
    }

    /// Takes in the blocks added to `blocks` and moves the motion as far as they let it decide;
    /// returns the blocks whose results became final.
    pub fn advance(&mut self, blocks: &Blocks) -> std::ops::Range<usize> {
        self.step(blocks, false)
    }

    /// No block follows: the motion goes to the end; returns the blocks whose results became
    /// final.
    pub fn finish(&mut self, blocks: &Blocks) -> std::ops::Range<usize> {
        self.step(blocks, true)
    }

    fn step(&mut self, blocks: &Blocks, last: bool) -> std::ops::Range<usize> {
        let machine = self.kin.machine();
        // Every block given is then taken in (a B-spline run comes whole).
        match &mut self.maker {
            Maker::Model(m) => m.extend(blocks, machine, &mut self.track),
            Maker::Vpop(m) => m.extend(blocks, self.kin, &mut self.track),
        }
        if last {
            self.track.complete();
        }
        let curves = match &self.maker {
            Maker::Vpop(m) => m.curves.as_ref(),
            Maker::Model(_) => None,
        };
        let seen = report::Seen {
            blocks,
            track: &self.track.track,
            owner: &self.track.owner,
            curves,
            kin: self.options.samples.then_some(self.kin),
        };
        self.collector.prepare(&seen);
        let progress = self.stepper.go(&self.track.track, &mut self.collector.observing(&seen));
        let done = progress == plan::Progress::Done;
        let at = self.track.owner.get(self.stepper.piece()).copied().unwrap_or(blocks.len());
        // An empty complete track is `Done` too.
        let range = self.collector.finalize(blocks, at, done);
        for i in range.clone() {
            let r = &self.collector.results[i];
            let op = blocks.operation[i] as usize;
            while self.operations.len() <= op {
                let name = blocks.operations.get(self.operations.len()).cloned().unwrap_or_default();
                self.operations.push(Operation {
                    name,
                    first: usize::MAX,
                    last: 0,
                    cycle_time: 0.0,
                    programmed_time: 0.0,
                    time_lost: 0.0,
                    causes: Vec::new(),
                });
            }
            let o = &mut self.operations[op];
            o.first = o.first.min(i);
            o.last = i;
            o.cycle_time += r.time;
            o.time_lost += r.lost;
            self.time_lost += r.lost;
            if r.kind == BlockKind::Feed {
                self.feed_length += r.length;
            }
        }
        range
    }

    /// Hands the samples taken since the last call to `each`, then forgets them (nothing without
    /// [`Options::samples`]): a streamed caller writes them out as they come and holds none.
    pub fn drain_samples(&mut self, each: impl FnOnce(&Samples)) {
        if let Some(samples) = self.collector.samples.as_mut() {
            each(samples);
            samples.clear();
        }
    }

    /// The result of block `i`, once final (and, streamed, until the next call).
    pub fn result(&self, i: usize) -> &BlockResult {
        &self.collector.results[i]
    }

    /// The first block the prediction still needs: a streamed caller forgets the blocks before
    /// it ([`Blocks::forget_before`]), and the prediction forgets what it held of them.
    pub fn needs_from(&mut self, blocks: &Blocks) -> usize {
        let piece = self.stepper.piece().saturating_sub(1);
        let at = self.track.owner.get(piece).copied().unwrap_or(blocks.len());
        let maker = match &self.maker {
            Maker::Model(m) => m.next_block(),
            Maker::Vpop(m) => m.next_block(),
        };
        let from = at.min(self.collector.finalized).min(self.track.last_block().unwrap_or(maker)).min(maker);
        if self.forget {
            self.track.forget_before(piece);
            self.stepper.forget_before(piece);
            // A sample's path length on a spline counts from the spline's first block: that
            // block's start is kept while the spline is.
            let mut spline_from = usize::MAX;
            if let Maker::Vpop(m) = &mut self.maker
                && let Some(curves) = m.curves.as_mut()
            {
                curves.forget_before(piece);
                spline_from = curves.start_block.get(curves.start_block.base()).copied().unwrap_or(usize::MAX);
            }
            self.collector.forget_before(from, piece, spline_from);
        }
        from
    }

    /// The whole-program figures (final once [`Predictor::finish`] has run).
    pub fn totals(&self) -> Totals {
        let cycle_time = self.stepper.time(&self.track.track);
        Totals {
            cycle_time,
            programmed_time: cycle_time - self.time_lost,
            time_lost: self.time_lost,
            feed_length: self.feed_length,
            length_below: self.collector.length_below,
            threshold: self.options.threshold,
            samples: self.collector.count,
            abandoned: self.stepper.abandoned(),
        }
    }

    /// The operations with their figures (final once [`Predictor::finish`] has run).
    pub fn operations(&self) -> Vec<Operation> {
        let mut out = self.operations.clone();
        for (op, o) in out.iter_mut().enumerate() {
            o.programmed_time = o.cycle_time - o.time_lost;
            o.causes = self.collector.causes_of(op);
        }
        out
    }

    /// The prediction of the whole program (not streamed: every block's result is held).
    pub fn into_prediction(self, blocks: &Blocks) -> Prediction {
        let totals = self.totals();
        let operations = self.operations();
        let mut collector = self.collector;
        Prediction {
            samples: collector.samples.take(),
            blocks: std::mem::take(&mut collector.results).into_vec(),
            totals: Some(totals),
            notes: blocks.notes.clone(),
            operations,
        }
    }
}

#[cfg(test)]
mod tests {
    use postpro_motion::Mode;

    use super::*;

    /// The motion program of a zig-zag finishing path of `points` points on the Mikron.
    fn zigzag(points: usize) -> (postpro_machine::model::Machine, postpro_motion::Program) {
        let machine =
            postpro_machine::Registry::builtin().expect("built-ins").find("mikron").expect("built in").machine.clone();
        let mut text = String::from("FEDRAT/MMPM,3000\nGOTO/0,0,10,0,0,1\n");
        for k in 0..points {
            let (pass, i) = (k / 100, k % 100);
            let x = if pass % 2 == 0 { i } else { 99 - i };
            let tilt = 0.2 * (k as f64 * 0.01).sin();
            let y = 0.5 * pass as f64;
            text.push_str(&format!("GOTO/{x},{y},{:.3},{:.6},0,{:.6}\n", 0.01 * i as f64, tilt.sin(), tilt.cos()));
        }
        let path = postpro_cl::read(&postpro_cl::Source::new("zigzag.cl", text));
        let kin = postpro_kin::solver_for(&machine);
        let solved = postpro_kin::solve(kin.as_ref(), &path, &machine.policy).expect("solves");
        let program = postpro_motion::study(&path, &solved, kin.as_ref(), Mode::InverseTime).expect("builds");
        (machine, program)
    }

    /// Linearity, by counting work: the streamed prediction of a program four times as long
    /// chooses at most ~4.5 times the steps and examines at most ~4.5 times the junctions, with
    /// both planners.
    #[test]
    fn the_prediction_works_in_linear_time() {
        for planner in [Planner::InverseTime, Planner::Vpop] {
            let mut work = Vec::new();
            for n in [10_000, 40_000] {
                let (machine, program) = zigzag(n);
                let kin = postpro_kin::solver_for(&machine);
                let options = Options { planner, ..Options::default() };
                plan::work::take();
                let mut blocks = Blocks::new(&machine);
                let mut reader = moves::Reader::new(Timing::TipFeed);
                let mut predictor = Predictor::new(kin.as_ref(), &options, blocks.axes, true);
                for block in &program.blocks {
                    reader.block(&mut blocks, &machine, block);
                    predictor.advance(&blocks);
                    let from = predictor.needs_from(&blocks);
                    blocks.forget_before(from);
                }
                predictor.finish(&blocks);
                assert!(predictor.totals().cycle_time > 0.0);
                work.push(plan::work::take());
            }
            for (what, k) in [("steps", 0), ("junctions examined", 1)] {
                let ratio = work[1][k] as f64 / work[0][k] as f64;
                assert!(
                    ratio <= 4.5,
                    "{planner:?}: {what}: {} for 10 k points, {} for 40 k ({ratio:.2}×)",
                    work[0][k],
                    work[1][k]
                );
            }
        }
    }
}
