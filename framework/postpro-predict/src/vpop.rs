//! VPOp (paper 003, `DOMAIN.md` §5): jerk-limited interpolation on the tool-tip path.
//!
//! The parameter is the tip path length `s`; the axes follow `q(s)`, so
//! `q̇ = q_s ṡ`, `q̈ = q_ss ṡ² + q_s s̈`, `q⃛ = q_sss ṡ³ + 3 q_ss ṡ s̈ + q_s s⃛`. Constraints:
//! `ṡ ≤ F`, the CNC's tangential `|s̈| ≤ A_t`, `|s⃛| ≤ J_t`, and every axis's V, A, J. On G1
//! blocks `q` is linear in `s` (`q_ss = q_sss = 0`) and the block corners are rounded within the
//! contour tolerance as in the inverse-time model; on a B-spline (the `bspline` output) each
//! knot span is cut into pieces whose caps take the curvature terms at their worst over the
//! piece, with the speed bounded by paper 003's quick bound
//! `ṡ ≤ min(F, Vmax/|q_s|, sqrt(Amax/|q_ss|), cbrt(Jmax/|q_sss|))`. Unlike the block-wise
//! model, nothing ties a block to one interpolation cycle, and the whole path is seen ahead.

use crate::moves::{BlockKind, Blocks};
use crate::plan::{Junction, Limit, Piece, Track};
use postpro_machine::model::{AxisKind, Machine};

/// The VPOp track of G1 `blocks`: one piece per block, in tip path length (a block that only
/// turns the tool gets the length it would have at its feed over its axis-speed duration).
pub fn track(blocks: &Blocks, machine: &Machine) -> (Track, Vec<usize>) {
    let cnc = &machine.cnc;
    let mut delta = vec![0.0; blocks.axes];
    let mut other = vec![0.0; blocks.axes];
    let mut pieces: Vec<Piece> = Vec::with_capacity(blocks.len());
    let mut junctions: Vec<Junction> = Vec::with_capacity(blocks.len());
    let mut owner: Vec<usize> = Vec::with_capacity(blocks.len());
    let path_accel = cnc.tangential_accel.unwrap_or_else(|| {
        machine.axes.iter().filter(|a| a.kind == AxisKind::Linear).map(|a| a.amax).fold(f64::INFINITY, f64::min)
    });
    let (mut pending_stop, mut pending_dwell, mut dwell_at_start) = (false, 0.0, 0.0);
    let mut reference_feed = cnc.feed_max / 60.0;
    for i in 0..blocks.len() {
        pending_stop |= blocks.stop_before[i];
        pending_dwell += blocks.dwell_before[i];
        if blocks.nominal[i] <= 0.0 {
            continue;
        }
        blocks.delta(i, &mut delta);
        let kind = blocks.kind[i];
        if kind == BlockKind::Feed {
            reference_feed = blocks.feed[i];
        }
        let length = if blocks.length[i] > 1e-9 { blocks.length[i] } else { blocks.nominal[i] * reference_feed };
        let feed = if kind == BlockKind::Rapid { f64::INFINITY } else { blocks.feed[i].max(reference_feed) };
        let feed = if kind == BlockKind::Feed { blocks.feed[i] } else { feed };
        let mut piece = Piece {
            length,
            velocity: feed,
            acceleration: f64::INFINITY,
            jerk: f64::INFINITY,
            velocity_limit: if kind == BlockKind::Rapid { Limit::Rapid } else { Limit::Programmed },
            acceleration_limit: Limit::TangentialAcceleration,
            jerk_limit: Limit::TangentialJerk,
        };
        if kind != BlockKind::Rapid {
            piece.acceleration = cnc.tangential_accel.unwrap_or(f64::INFINITY);
            piece.jerk = cnc.tangential_jerk.unwrap_or(f64::INFINITY);
        }
        for (index, (axis, d)) in machine.axes.iter().zip(&delta).enumerate() {
            let qs = d.abs() / length;
            if qs > 0.0 {
                let index = index as u16;
                tighten(&mut piece.velocity, &mut piece.velocity_limit, axis.vmax / qs, Limit::Velocity(index));
                tighten(
                    &mut piece.acceleration,
                    &mut piece.acceleration_limit,
                    axis.amax / qs,
                    Limit::Acceleration(index),
                );
                tighten(&mut piece.jerk, &mut piece.jerk_limit, axis.jmax / qs, Limit::Jerk(index));
            }
        }
        if !piece.acceleration.is_finite() {
            piece.acceleration = 1e12;
        }
        if !piece.jerk.is_finite() {
            piece.jerk = 1e15;
        }
        if let Some(last) = junctions.last_mut() {
            *last = if pending_stop {
                Junction { cap: 0.0, limit: Limit::Stop, dwell: pending_dwell }
            } else {
                let previous = owner[owner.len() - 1];
                blocks.delta(previous, &mut other);
                let cap = corner_cap(
                    blocks,
                    machine,
                    previous,
                    i,
                    &other,
                    &delta,
                    pieces[pieces.len() - 1].length,
                    length,
                    path_accel,
                );
                Junction { cap, limit: Limit::Corner, dwell: 0.0 }
            };
        } else {
            dwell_at_start = pending_dwell;
        }
        pending_stop = false;
        pending_dwell = 0.0;
        pieces.push(piece);
        junctions.push(Junction { cap: 0.0, limit: Limit::Stop, dwell: 0.0 });
        owner.push(i);
    }
    if let Some(last) = junctions.last_mut() {
        last.dwell = pending_dwell;
    }
    (Track { pieces, junctions, window: usize::MAX, dwell_at_start }, owner)
}

fn tighten(cap: &mut f64, why: &mut Limit, candidate: f64, limit: Limit) {
    if candidate < *cap {
        *cap = candidate;
        *why = limit;
    }
}

/// The cap on the tip speed where block `a` (parameter length `la`) meets block `b`.
#[allow(clippy::too_many_arguments)]
fn corner_cap(
    blocks: &Blocks,
    machine: &Machine,
    a: usize,
    b: usize,
    da: &[f64],
    db: &[f64],
    la: f64,
    lb: f64,
    path_accel: f64,
) -> f64 {
    let cnc = &machine.cnc;
    let mut cap = crate::corner::corner_speed(
        &blocks.direction(a),
        &blocks.direction(b),
        cnc.contour_tolerance,
        path_accel,
        cnc.curvature_accel_share,
    );
    for (axis, (x, y)) in machine.axes.iter().zip(da.iter().zip(db)) {
        let jump = (y / lb - x / la).abs();
        if jump > 0.0 {
            let tolerance = match axis.kind {
                AxisKind::Linear => cnc.contour_tolerance,
                AxisKind::Rotary => cnc.contour_tolerance.to_radians(),
            };
            cap = cap.min((tolerance * axis.amax).sqrt() / jump);
        }
    }
    cap
}
