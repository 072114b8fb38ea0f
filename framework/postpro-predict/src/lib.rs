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

pub use block::{BlockLimits, Limiter, block_limits};
pub use corner::{blend_radius, corner_speed, interior_angle};
pub use moves::{BlockKind, Blocks, Timing, blocks};
pub use plan::Limit;
pub use profile::{Profile, State, speed_change};
pub use report::{BlockResult, Cause, Mark, MarkRules, Operation, Prediction, Samples, Totals, describe};

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

/// Predicts the motion of `blocks` on the machine of `kin`.
pub fn predict(blocks: &Blocks, kin: &dyn Kinematics, options: &Options) -> Prediction {
    let machine = kin.machine();
    let (track, owner, curves) = match (options.splines, options.planner) {
        (true, _) => {
            let (track, owner, curves) = vpop::track_bspline(blocks, kin, machine);
            (track, owner, Some(curves))
        }
        (false, Planner::InverseTime) => {
            let (track, owner) = model::track(blocks, machine);
            (track, owner, None)
        }
        (false, Planner::Vpop) => {
            let (track, owner) = vpop::track(blocks, machine);
            (track, owner, None)
        }
    };
    let period = options.period.unwrap_or(machine.cnc.cycle_time);
    let keep = options.samples.then_some(kin);
    let mut collector = report::Collector::new(blocks, &track, &owner, keep, curves.as_ref(), options.threshold);
    let cycle_time = plan::run(&track, period, &mut collector);
    collector.finish();
    let operations = collector.operations();
    // Time lost is the blocks'; the time at the programmed feed is what remains of the cycle.
    let time_lost: f64 = collector.results.iter().map(|b| b.lost).sum();
    let feed_length =
        blocks.length.iter().zip(&blocks.kind).filter(|(_, k)| **k == BlockKind::Feed).map(|(l, _)| l).sum();
    let totals = Totals {
        cycle_time,
        programmed_time: cycle_time - time_lost,
        time_lost,
        feed_length,
        length_below: collector.length_below,
        threshold: options.threshold,
        samples: collector.count,
    };
    Prediction {
        blocks: collector.results,
        samples: collector.samples,
        totals: Some(totals),
        notes: blocks.notes.clone(),
        operations,
    }
}
