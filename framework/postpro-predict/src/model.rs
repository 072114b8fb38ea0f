//! The inverse-time model of papers 000 and 001 (`DOMAIN.md` §4) as a [`Track`].
//!
//! The parameter is the programmed time: block `i` spans its nominal duration `T_i`, so the
//! parameter's speed is the share of the programmed feed reached, and every axis moves at
//! `ΔP_j / T_i` times it. A block's caps are those of [`block_limits`] scaled by `T_i` (axis
//! velocity, acceleration and jerk over `|ΔP_j|`, one interpolation cycle per block at least), and
//! the CNC's tangential acceleration and jerk over the nominal tip feed. Where two blocks meet,
//! the CNC rounds the corner within the contour tolerance: the tip crosses it at
//! `sqrt(R · A · (1 − share))`, and each axis's velocity may jump by no more than
//! `sqrt(e · Amax_j)` (paper 001's per-axis deviation `e = Δv² / Amax`, with `e` read in the
//! axis's NC unit: mm, or degrees for a rotary axis). Rapids, tool changes, spindle changes,
//! dwells and stops are exact stops. The look-ahead sees the current block and `cnc.look_ahead`
//! more: the motion can always stop at the end of the last one.

use crate::block::{Limiter, block_limits};
use crate::corner::junction_cap;
use crate::moves::{BlockKind, Blocks};
use crate::plan::{Limit, Piece, TrackBuilder};
use postpro_machine::model::Machine;

/// Paper 000: "to generate the profile on block N, the geometry of the trajectory until block
/// N + 10 is taken into account": the current block and `look_ahead` more — blocks of the
/// program, not the pieces the prediction cuts an arc or a TCP move into.
pub fn window(machine: &Machine) -> usize {
    machine.cnc.look_ahead.saturating_add(1)
}

/// Makes the pieces of the blocks as they come.
#[derive(Clone, Debug)]
pub struct Maker {
    /// The next block.
    next: usize,
    delta: Vec<f64>,
    previous_delta: Vec<f64>,
}

impl Maker {
    /// Before the first block, on a machine of `axes` axes.
    pub fn new(axes: usize) -> Maker {
        Maker { next: 0, delta: vec![0.0; axes], previous_delta: vec![0.0; axes] }
    }

    /// The block it needs next: the ones before the last block with a piece are done with.
    pub fn next_block(&self) -> usize {
        self.next
    }

    /// Adds the pieces of the blocks added to `blocks` since the last call.
    pub fn extend(&mut self, blocks: &Blocks, machine: &Machine, track: &mut TrackBuilder) {
        while self.next < blocks.len() {
            let i = self.next;
            self.next += 1;
            track.before(blocks.stop_before[i], blocks.dwell_before[i]);
            let nominal = blocks.nominal[i];
            if nominal <= 0.0 {
                continue; // nothing moves
            }
            blocks.delta(i, &mut self.delta);
            let piece = piece(blocks, machine, i, &self.delta, nominal);
            let previous = track.last_block();
            let mut why = blocks.junction_limit(previous, i);
            let corner = match previous {
                // Two blocks of one arc meet without a corner: at the arc's own speed, as a share
                // of the feed.
                Some(previous) if !track.stop_pending() && blocks.same_arc(previous, i) => {
                    why = Limit::Curvature;
                    crate::corner::arc_speed(machine, blocks.radius[i]) / blocks.nominal_tip_feed(i).max(1e-12)
                }
                Some(previous) if !track.stop_pending() => {
                    blocks.delta(previous, &mut self.previous_delta);
                    // In programmed time a block's axis rates are ΔP / T and its tip covers its
                    // nominal tip feed per unit.
                    let tip = blocks.nominal_tip_feed(previous).max(blocks.nominal_tip_feed(i));
                    junction_cap(
                        machine,
                        &blocks.direction(previous),
                        &blocks.direction(i),
                        tip,
                        (&self.previous_delta, blocks.nominal[previous]),
                        (&self.delta, nominal),
                    )
                }
                _ => f64::INFINITY,
            };
            track.push(piece, i, corner, why, blocks.written[i]);
        }
    }
}

/// The caps of block `i`, in programmed time.
fn piece(blocks: &Blocks, machine: &Machine, i: usize, delta: &[f64], nominal: f64) -> Piece {
    let cnc = &machine.cnc;
    let rapid = blocks.kind[i] == BlockKind::Rapid;
    // In programmed time the block's "feed" is 1/T and its length 1: the limits of the unit
    // parameter α, times T, are the caps on the share of the feed.
    let limits = block_limits(&machine.axes, delta, 1.0, 1.0 / nominal, cnc.cycle_time);
    let axis_limit = |axis: Option<usize>, make: fn(u16) -> Limit| axis.map_or(Limit::Programmed, |a| make(a as u16));
    let (mut velocity, mut velocity_limit) = (
        (limits.velocity * nominal).min(1.0),
        match limits.limiter {
            Limiter::Programmed if rapid => Limit::Rapid,
            Limiter::Programmed => Limit::Programmed,
            Limiter::Axis(a) => Limit::Velocity(a as u16),
            Limiter::CycleTime => Limit::CycleTime,
        },
    );
    if rapid && velocity_limit != Limit::CycleTime {
        velocity_limit = Limit::Rapid;
    }
    // At the programmed feed the share is 1 exactly: (1 / T) · T may round below it, and a cap
    // one ulp under the next block's makes the interpolator brake for nothing.
    if velocity >= 1.0 || limits.limiter == Limiter::Programmed {
        velocity = 1.0;
    }
    let mut acceleration = limits.acceleration.0 * nominal;
    let mut acceleration_limit = axis_limit(limits.acceleration.1, Limit::Acceleration);
    let mut jerk = limits.jerk.0 * nominal;
    let mut jerk_limit = axis_limit(limits.jerk.1, Limit::Jerk);
    let tip_feed = blocks.nominal_tip_feed(i);
    if !rapid && tip_feed > 0.0 {
        // On a circular arc the centripetal acceleration and its jerk cap the tip speed.
        let arc = crate::corner::arc_speed(machine, blocks.radius[i]) / tip_feed;
        if arc < velocity {
            velocity = arc;
            velocity_limit = Limit::Curvature;
        }
        if let Some(at) = cnc.tangential_accel
            && at / tip_feed < acceleration
        {
            acceleration = at / tip_feed;
            acceleration_limit = Limit::TangentialAcceleration;
        }
        if let Some(jt) = cnc.tangential_jerk
            && jt / tip_feed < jerk
        {
            jerk = jt / tip_feed;
            jerk_limit = Limit::TangentialJerk;
        }
    }
    Piece {
        length: nominal,
        velocity,
        acceleration: finite_or(acceleration, 1e12),
        jerk: finite_or(jerk, 1e15),
        velocity_limit,
        acceleration_limit,
        jerk_limit,
    }
}

fn finite_or(x: f64, big: f64) -> f64 {
    if x.is_finite() { x } else { big }
}
