//! VPOp (paper 003, `DOMAIN.md` §5): jerk-limited interpolation on the tool-tip path.
//!
//! The parameter is the tip path length `s`; the axes follow `q(s)`, so
//! `q̇ = q_s ṡ`, `q̈ = q_ss ṡ² + q_s s̈`, `q⃛ = q_sss ṡ³ + 3 q_ss ṡ s̈ + q_s s⃛`. Constraints:
//! `ṡ ≤ F`, the CNC's tangential `|s̈| ≤ A_t`, `|s⃛| ≤ J_t`, and every axis's V, A, J.
//!
//! - On G1 blocks `q` is linear in `s` (`q_ss = q_sss = 0`); block corners are rounded within
//!   the contour tolerance as in the inverse-time model.
//! - On B-spline output ([`Maker`] with curves) each run of feed moves is the spline the emitter
//!   writes (the same fit, [`postpro_kin::bspline`]), its parameter the tip's chord length. Each
//!   knot span is cut into pieces whose caps take the derivatives at their exact worst over the
//!   piece (the span's cubic: the first derivative's peak at an end or its vertex):
//!   the speed at 0.8 × paper 003's quick bound
//!   `ṡ ≤ min(F, Vmax/|q_s|, sqrt(Amax/|q_ss|), cbrt(Jmax/|q_sss|))`, then the acceleration and
//!   jerk of `s` left to each axis once the curvature terms at that speed are paid. These caps
//!   are sufficient, so no axis exceeds its limits; they are conservative where the
//!   derivatives vary fast within a piece.
//!
//! Unlike the block-wise model, nothing ties a block to one interpolation cycle, and the whole
//! path is seen ahead.

use crate::moves::{BlockKind, Blocks, SplineRun};
use crate::plan::{Limit, Piece, TrackBuilder};
use crate::window::Window;
use postpro_kin::Kinematics;
use postpro_kin::bspline::{Cursor, Spline};
use postpro_machine::model::{Axis, Machine};

/// What a piece of a track is, for rebuilding the axis motion from the parameter.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Segment {
    /// A straight block in the axis space, parameter proportional to its progress.
    Line,
    /// A stretch of spline `spline` starting at its parameter `from` (the track parameter and
    /// the spline's run at the same rate).
    Curve {
        /// Index into [`Curves::splines`].
        spline: usize,
        /// Spline parameter at the piece's start.
        from: f64,
    },
}

/// The splines of a B-spline track and what each piece is.
#[derive(Clone, Debug, Default)]
pub struct Curves {
    /// The fitted splines, one per run written as `BSPLINE`.
    pub splines: Window<Spline>,
    /// One per piece.
    pub segments: Window<Segment>,
    /// The block each spline starts at (its parameter is 0 there).
    pub start_block: Window<usize>,
    /// No segment before this one is a curve (from the window's base): where the search for
    /// the first spline still needed goes on.
    straight_until: usize,
}

impl Curves {
    /// The pieces up to `pieces` that have no segment yet are straight.
    fn pad_to(&mut self, pieces: usize) {
        while self.segments.end() < pieces {
            self.segments.push(Segment::Line);
        }
    }

    /// Forgets the pieces before piece `i`, and the splines that end before it.
    pub fn forget_before(&mut self, i: usize) {
        self.segments.forget_before(i);
        // Each segment is looked at once: segments are only added at the end.
        let mut p = self.straight_until.max(self.segments.base());
        let first_kept = loop {
            crate::plan::tally!(SEGMENTS);
            match self.segments.get(p) {
                Some(Segment::Curve { spline, .. }) => break *spline,
                Some(Segment::Line) => p += 1,
                None => break self.splines.end(),
            }
        };
        self.straight_until = p;
        self.splines.forget_before(first_kept);
        self.start_block.forget_before(first_kept);
    }
}

/// The tip speed block `i` asks for: its feed, or less in G1 timing (F on the axes). The feed
/// itself where the two differ by rounding only (`L / (L / F)`): a cap one ulp under the next
/// block's makes the interpolator brake for nothing.
fn programmed_tip_feed(blocks: &Blocks, i: usize) -> f64 {
    let (nominal, feed) = (blocks.nominal_tip_feed(i), blocks.feed[i]);
    if (nominal - feed).abs() <= 1e-9 * feed { feed } else { nominal.max(1e-9) }
}

/// Makes the VPOp pieces of the blocks as they come (with `curves`, B-spline runs as the
/// spline the program writes).
#[derive(Clone, Debug)]
pub struct Maker {
    /// The next block.
    next: usize,
    /// The last feed seen (mm/s): the pace of a block that only turns the tool.
    reference_feed: f64,
    delta: Vec<f64>,
    other: Vec<f64>,
    /// The block and parameter length of the last line piece, for the next corner.
    last_line: Option<(usize, f64)>,
    /// The first B-spline run not yet made into pieces.
    next_spline: usize,
    /// The splines of a B-spline program and what each piece is.
    pub curves: Option<Curves>,
}

impl Maker {
    /// Before the first block, on `machine` (with `axes` axes); `splines`: the runs the
    /// program writes as B-splines follow them.
    pub fn new(axes: usize, machine: &Machine, splines: bool) -> Maker {
        Maker {
            next: 0,
            reference_feed: machine.cnc.feed_max / 60.0,
            delta: vec![0.0; axes],
            other: vec![0.0; axes],
            last_line: None,
            next_spline: 0,
            curves: splines.then(Curves::default),
        }
    }

    /// The block it needs next.
    pub fn next_block(&self) -> usize {
        self.next
    }

    /// Adds the pieces of the blocks added to `blocks` since the last call (a B-spline run
    /// comes whole).
    pub fn extend(&mut self, blocks: &Blocks, kin: &dyn Kinematics, track: &mut TrackBuilder) {
        let machine = kin.machine();
        while self.next < blocks.len() {
            let i = self.next;
            let splines = &blocks.splines;
            while self.next_spline < splines.end() && splines[self.next_spline].first < i {
                self.next_spline += 1;
            }
            match splines.get(self.next_spline).filter(|r| r.first == i && self.curves.is_some()) {
                Some(run) => {
                    self.curve(blocks, machine, run, kin, track);
                    self.next += run.poses.len() - 1;
                }
                None => {
                    self.line(blocks, machine, i, track);
                    self.next += 1;
                }
            }
            if let Some(curves) = self.curves.as_mut() {
                curves.pad_to(track.len());
            }
        }
    }

    /// The caps of block `i` as one straight piece of parameter length `length`.
    fn line_piece(&mut self, blocks: &Blocks, machine: &Machine, i: usize, length: f64) -> Piece {
        let cnc = &machine.cnc;
        let kind = blocks.kind[i];
        let mut piece = Piece {
            length,
            // The tip speed the program asks for: the feed, or less in G1 timing (F on the axes).
            velocity: if kind == BlockKind::Rapid { f64::INFINITY } else { programmed_tip_feed(blocks, i) },
            acceleration: f64::INFINITY,
            jerk: f64::INFINITY,
            velocity_limit: if kind == BlockKind::Rapid { Limit::Rapid } else { Limit::Programmed },
            acceleration_limit: Limit::TangentialAcceleration,
            jerk_limit: Limit::TangentialJerk,
        };
        if kind == BlockKind::Reorientation {
            piece.velocity = self.reference_feed;
        }
        if kind != BlockKind::Rapid {
            piece.acceleration = cnc.tangential_accel.unwrap_or(f64::INFINITY);
            piece.jerk = cnc.tangential_jerk.unwrap_or(f64::INFINITY);
        }
        for (index, (axis, d)) in machine.axes.iter().zip(&self.delta).enumerate() {
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
        finite(piece)
    }

    /// Block `i` as one straight piece.
    fn line(&mut self, blocks: &Blocks, machine: &Machine, i: usize, track: &mut TrackBuilder) {
        track.before(blocks.stop_before[i], blocks.dwell_before[i]);
        if blocks.nominal[i] <= 0.0 {
            return;
        }
        if blocks.kind[i] == BlockKind::Feed {
            self.reference_feed = blocks.feed[i];
        }
        blocks.delta(i, &mut self.delta);
        let length = if blocks.length[i] > 1e-9 { blocks.length[i] } else { blocks.nominal[i] * self.reference_feed };
        let mut piece = self.line_piece(blocks, machine, i, length);
        let arc = crate::corner::arc_speed(machine, blocks.radius[i]);
        if blocks.kind[i] != BlockKind::Rapid {
            tighten(&mut piece.velocity, &mut piece.velocity_limit, arc, Limit::Curvature);
        }
        let mut why = blocks.junction_limit(track.last_block(), i);
        let corner = match self.last_line {
            // Two blocks of one arc meet without a corner: at the arc's own speed.
            Some((previous, _)) if track.last_block() == Some(previous) && blocks.same_arc(previous, i) => {
                why = Limit::Curvature;
                arc
            }
            Some((previous, previous_length)) if track.last_block() == Some(previous) => {
                blocks.delta(previous, &mut self.other);
                // On the tip path a block's tip covers L / ℓ mm per unit (1 unless it only turns).
                let tip = (blocks.length[previous] / previous_length).max(blocks.length[i] / length);
                crate::corner::junction_cap(
                    machine,
                    &blocks.direction(previous),
                    &blocks.direction(i),
                    tip,
                    (&self.other, previous_length),
                    (&self.delta, length),
                )
            }
            // After a curve: the tip's direction changes within the tolerance's rounding.
            _ => f64::INFINITY,
        };
        track.push(piece, i, corner, why, true);
        self.last_line = Some((i, length));
    }

    /// The blocks of a spline run, along the spline the motion program wrote.
    fn curve(
        &mut self,
        blocks: &Blocks,
        machine: &Machine,
        run: &SplineRun,
        kin: &dyn Kinematics,
        track: &mut TrackBuilder,
    ) {
        let start = run.first;
        let count = run.poses.len() - 1;
        for b in start..start + count {
            track.before(blocks.stop_before[b] && b == start, blocks.dwell_before[b]);
        }
        let feed = blocks.feed[start];
        if blocks.kind[start] == BlockKind::Feed {
            self.reference_feed = feed;
        }
        let (spline, poses, params) = (&run.curve, &run.poses, &run.params);
        let Some(curves) = self.curves.as_mut() else { return };
        let which = curves.splines.end();
        let why = blocks.junction_limit(track.last_block(), start);
        let mut corner = match self.last_line {
            Some((previous, _)) if track.last_block() == Some(previous) => {
                let tangent = poses.get(1).map_or(nalgebra::Vector3::zeros(), |p| p.tip - poses[0].tip);
                crate::corner::corner_speed(
                    &blocks.direction(previous),
                    &tangent,
                    machine.cnc.contour_tolerance,
                    crate::corner::path_acceleration(machine),
                    machine.cnc.curvature_accel_share,
                )
            }
            _ => f64::INFINITY,
        };
        // The first knot past the start of the data interval (the knots increase, so do the intervals).
        let mut knot = 0;
        let mut cursor = spline.cursor();
        // The tip's rate at the end of the last piece: the next one starts there.
        let mut end_rate = None;
        let mut cuts = Vec::new();
        // Data interval `d` ends at data point d + 1: block start + d.
        for d in 0..params.len() - 1 {
            let block = start + d;
            // A few pieces per data interval ([`PIECES_PER_INTERVAL`]), also cut at the knots:
            // within a knot span each axis is one cubic, whose derivatives' largest magnitudes
            // over a piece are exact (`Cursor::derivative_bounds`).
            let pieces = pieces_per_interval();
            let (s0, s1) = (params[d], params[d + 1]);
            cuts.clear();
            cuts.extend((0..=pieces).map(|k| s0 + (s1 - s0) * k as f64 / pieces as f64));
            while knot < spline.knots.len() && spline.knots[knot] <= s0 {
                knot += 1;
            }
            cuts.extend(spline.knots[knot..].iter().copied().take_while(|&k| k < s1));
            cuts.sort_by(f64::total_cmp);
            cuts.dedup_by(|a, b| (*a - *b).abs() <= 1e-9 * (s1 - s0).max(1e-9));
            for w in cuts.windows(2) {
                let (from, to) = (w[0], w[1]);
                let (piece, rate_at_end) = curve_piece(machine, &mut cursor, kin, from, to, feed, end_rate);
                end_rate = Some(rate_at_end);
                track.push(piece, block, corner, why, true);
                curves.pad_to(track.len() - 1);
                curves.segments.push(Segment::Curve { spline: which, from });
                corner = f64::INFINITY;
            }
        }
        curves.splines.push(spline.clone());
        curves.start_block.push(start);
        self.last_line = None;
    }
}

/// The pieces each data interval of a spline is cut into. A piece's caps are the worst over it,
/// so finer pieces predict a little less time (test
/// `finer_pieces_never_lengthen_the_predicted_time`); four are within 0.4 % of sixteen on the
/// bundled examples.
const PIECES_PER_INTERVAL: usize = 4;

/// [`PIECES_PER_INTERVAL`], or what a unit test sets.
fn pieces_per_interval() -> usize {
    #[cfg(test)]
    if let Some(pieces) = tests::PIECES.with(std::cell::Cell::get) {
        return pieces;
    }
    PIECES_PER_INTERVAL
}

/// The caps of the spline between parameters `from` and `to`, and the tip's rate at `to`;
/// `start_rate` is the rate at `from` where the last piece, which ended there, found it.
fn curve_piece(
    machine: &Machine,
    cursor: &mut Cursor<'_>,
    kin: &dyn Kinematics,
    from: f64,
    to: f64,
    feed: f64,
    start_rate: Option<f64>,
) -> (Piece, f64) {
    let axes = &machine.axes;
    let cnc = &machine.cnc;
    // The largest |q_s|, |q_ss|, |q_sss| of each axis over the piece.
    let worst = cursor.derivative_bounds(from, to);
    let worst = &worst[..axes.len()];
    // The tip's rate along the parameter (the forward kinematics' derivative along `q_s`) at the
    // ends and the middle: the parameter is the tip's chord length, so the rate is near 1 and
    // varies slowly. The ends just inside: the span the piece lies in. The rate at the start is
    // the last piece's at its end where there was one: `q` and `q_s` are continuous across the
    // fit's knots, which are simple (a cubic spline is C² there).
    let inset = 1e-9 * (to - from);
    let mut rate_at = |s: f64| {
        let [q, q_s] = cursor.tangent(s);
        kin.forward_rate(&q, &q_s).tip.norm()
    };
    let start = start_rate.unwrap_or_else(|| rate_at(from + inset));
    let middle = rate_at(0.5 * (from + to));
    let end = rate_at(to - inset);
    let tip_rate = 0f64.max(start).max(middle).max(end);
    let mut piece = Piece {
        length: to - from,
        velocity: if tip_rate > 0.0 { feed / tip_rate } else { feed },
        acceleration: cnc.tangential_accel.map_or(f64::INFINITY, |a| a / tip_rate.max(1e-9)),
        jerk: cnc.tangential_jerk.map_or(f64::INFINITY, |j| j / tip_rate.max(1e-9)),
        velocity_limit: Limit::Programmed,
        acceleration_limit: Limit::TangentialAcceleration,
        jerk_limit: Limit::TangentialJerk,
    };
    quick_bound(axes, worst, &mut piece.velocity, &mut piece.velocity_limit);
    let v = piece.velocity;
    for (index, (axis, [q1, q2, _])) in axes.iter().zip(worst).enumerate() {
        if *q1 <= 0.0 {
            continue;
        }
        let index = index as u16;
        let a_cap = (axis.amax - q2 * v * v) / q1;
        tighten(&mut piece.acceleration, &mut piece.acceleration_limit, a_cap, Limit::Acceleration(index));
    }
    let a = piece.acceleration.min(1e12);
    for (index, (axis, [q1, q2, q3])) in axes.iter().zip(worst).enumerate() {
        if *q1 <= 0.0 {
            continue;
        }
        let index = index as u16;
        // What the jerk of the parameter may use once the curvature terms at (v, a) are paid;
        // where they leave little, the acceleration is lowered instead.
        let mut j_cap = (axis.jmax - q3 * v * v * v - 3.0 * q2 * v * a) / q1;
        if j_cap < 0.1 * axis.jmax / q1 {
            j_cap = 0.1 * axis.jmax / q1;
            let a_room = (0.9 * axis.jmax - q3 * v * v * v).max(0.0) / (3.0 * q2 * v).max(1e-12);
            tighten(&mut piece.acceleration, &mut piece.acceleration_limit, a_room, Limit::Jerk(index));
        }
        tighten(&mut piece.jerk, &mut piece.jerk_limit, j_cap, Limit::Jerk(index));
    }
    (finite(piece), end)
}

/// Tightens `velocity` to paper 003's quick bound, at 0.8 of it so that the curvature terms
/// leave room: each axis's least of `vmax/|q_s|`, `sqrt(amax/|q_ss|)` and `cbrt(jmax/|q_sss|)`
/// (`worst` holds each axis's largest `|q_s|, |q_ss|, |q_sss|`), the first of a tie.
///
/// The cube root is monotone, so only an axis whose jerk ratio is the least (to well within
/// rounding) can give the lowest of the jerk bounds, and only the lowest can tighten the speed
/// to where it ends: the roots of the others are not taken (they stand at infinity, above every
/// bound that wins, so the speed and its cause are those of every root taken).
fn quick_bound(axes: &[Axis], worst: &[[f64; 3]], velocity: &mut f64, why_velocity: &mut Limit) {
    let jerk_ratio = |axis: &Axis, q3: f64| axis.jmax / q3;
    let least = axes.iter().zip(worst).map(|(axis, [_, _, q3])| jerk_ratio(axis, *q3)).fold(f64::INFINITY, f64::min);
    for (index, (axis, [q1, q2, q3])) in axes.iter().zip(worst).enumerate() {
        let index = index as u16;
        let ratio = jerk_ratio(axis, *q3);
        let jerk_bound = if ratio <= least * (1.0 + 1e-12) { ratio.cbrt() } else { f64::INFINITY };
        let mut bound = f64::INFINITY;
        let mut why = Limit::Velocity(index);
        for (cap, limit) in [
            (axis.vmax / q1, Limit::Velocity(index)),
            ((axis.amax / q2).sqrt(), Limit::Acceleration(index)),
            (jerk_bound, Limit::Jerk(index)),
        ] {
            if cap < bound {
                bound = cap;
                why = limit;
            }
        }
        tighten(velocity, why_velocity, 0.8 * bound, why);
    }
}

fn finite(mut piece: Piece) -> Piece {
    if !piece.acceleration.is_finite() || piece.acceleration <= 0.0 {
        piece.acceleration = if piece.acceleration <= 0.0 { 1e-6 } else { 1e12 };
    }
    if !piece.jerk.is_finite() {
        piece.jerk = 1e15;
    }
    piece
}

fn tighten(cap: &mut f64, why: &mut Limit, candidate: f64, limit: Limit) {
    if candidate < *cap {
        *cap = candidate;
        *why = limit;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    thread_local! {
        /// The pieces a data interval is cut into, when a test sets them.
        pub(super) static PIECES: std::cell::Cell<Option<usize>> = const { std::cell::Cell::new(None) };
    }

    /// The predicted time of a bundled example in B-spline mode, with `pieces` a data interval.
    fn predicted(file: &str, machine: &str, pieces: usize) -> f64 {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/cl").join(file);
        let text = std::fs::read_to_string(&path).expect("the example");
        let source = postpro_cl::Source::new(file, text.as_str());
        let cl = postpro_cl::read(&source);
        let registry = postpro_machine::Registry::builtin().expect("the built-ins load");
        let machine = registry.find(machine).expect("built in").machine.clone();
        let kin = postpro_kin::solver_for(&machine);
        let solved = postpro_kin::solve(kin.as_ref(), &cl, &machine.policy).expect("the example solves");
        let mode = postpro_motion::Mode::Bspline;
        let program = postpro_motion::study(&cl, &solved, kin.as_ref(), mode).expect("the motion program");
        let blocks = crate::blocks(&program, &machine, crate::Timing::TipFeed);
        let options = crate::Options { planner: crate::Planner::Vpop, splines: true, ..crate::Options::default() };
        PIECES.with(|p| p.set(Some(pieces)));
        let time = crate::predict(&blocks, kin.as_ref(), &options).totals().cycle_time;
        PIECES.with(|p| p.set(None));
        time
    }

    /// The quick bound as paper 003 writes it, every root taken.
    fn quick_bound_every_root(axes: &[Axis], worst: &[[f64; 3]], velocity: &mut f64, why_velocity: &mut Limit) {
        for (index, (axis, [q1, q2, q3])) in axes.iter().zip(worst).enumerate() {
            let index = index as u16;
            let (mut bound, mut why) = (f64::INFINITY, Limit::Velocity(index));
            for (cap, limit) in [
                (axis.vmax / q1, Limit::Velocity(index)),
                ((axis.amax / q2).sqrt(), Limit::Acceleration(index)),
                ((axis.jmax / q3).cbrt(), Limit::Jerk(index)),
            ] {
                if cap < bound {
                    (bound, why) = (cap, limit);
                }
            }
            tighten(velocity, why_velocity, 0.8 * bound, why);
        }
    }

    proptest::proptest! {
        /// Skipping the cube roots that cannot win changes neither the speed nor its cause: on
        /// the Mikron's five axes with random limits and derivatives, zeros (an axis that does
        /// not move) and exact ties (axes alike) among them.
        #[test]
        fn the_quick_bound_is_the_one_with_every_root(
            limits in proptest::collection::vec((0.1f64..1e3, 1.0f64..1e5, 10.0f64..1e7), 5),
            derivatives in proptest::collection::vec((0usize..4, 0.0f64..1e3, 0.0f64..1e4, 0.0f64..1e6), 5),
            alike in proptest::collection::vec((0usize..5, 0u64..4), 5),
            feed in 0.1f64..1e4,
        ) {
            let registry = postpro_machine::Registry::builtin().expect("the built-ins load");
            let mut axes = registry.find("mikron").expect("built in").machine.axes.clone();
            let mut worst = Vec::new();
            for (i, ((vmax, amax, jmax), (zeros, q1, q2, q3))) in limits.iter().zip(&derivatives).enumerate() {
                (axes[i].vmax, axes[i].amax, axes[i].jmax) = (*vmax, *amax, *jmax);
                // Some derivatives zero: the first `zeros` of the three.
                let q = [*q1, *q2, *q3];
                worst.push(std::array::from_fn(|k| if k < *zeros { 0.0 } else { q[k] }));
            }
            // Axes made alike another one: ties between them, or near ties (a jerk derivative a
            // few units of the last place apart, its ratio within rounding of the other's).
            for (i, &(like, ulps)) in alike.iter().enumerate() {
                if like < i {
                    let (limits, mut derivatives) = ((axes[like].vmax, axes[like].amax, axes[like].jmax), worst[like]);
                    derivatives[2] = f64::from_bits(derivatives[2].to_bits() + ulps);
                    (axes[i].vmax, axes[i].amax, axes[i].jmax) = limits;
                    worst[i] = derivatives;
                }
            }
            let (mut fast, mut fast_why) = (feed, Limit::Programmed);
            quick_bound(&axes, &worst, &mut fast, &mut fast_why);
            let (mut every, mut every_why) = (feed, Limit::Programmed);
            quick_bound_every_root(&axes, &worst, &mut every, &mut every_why);
            proptest::prop_assert_eq!((fast.to_bits(), fast_why), (every.to_bits(), every_why));
        }
    }

    /// Cutting a spline into finer pieces never lengthens the predicted time: each piece's caps
    /// are its worst, so finer ones allow as much or more. On the MAHO (8 ms), where a step
    /// crosses several short pieces, the junctions it crossed used to brake it: bicubic took
    /// 585.09 s with four pieces and 589.69 s with sixteen.
    #[test]
    fn finer_pieces_never_lengthen_the_predicted_time() {
        for (file, machine) in
            [("bicubic-5axis.cl", "maho600e"), ("hypar-5axis.cl", "maho600e"), ("hypar-5axis.cl", "mikron")]
        {
            let time = predicted(file, machine, PIECES_PER_INTERVAL);
            let finer = predicted(file, machine, 4 * PIECES_PER_INTERVAL);
            assert!(finer <= time * (1.0 + 1e-4), "{file} on {machine}: {time} s, {finer} s with finer pieces");
            assert!(finer >= time * (1.0 - 5e-3), "{file} on {machine}: {time} s, {finer} s with finer pieces");
        }
    }

    #[test]
    fn forgetting_looks_at_each_segment_once() {
        // A long straight stretch (G1 blocks between B-spline runs): the search for the first
        // spline still needed must not go over the whole window at each forgetting.
        crate::plan::work::take();
        let mut curves = Curves::default();
        let n: usize = 20_000;
        for piece in 0..n {
            curves.segments.push(Segment::Line);
            curves.forget_before(piece.saturating_sub(5_000));
        }
        let [_, _, looked_at] = crate::plan::work::take();
        assert!(looked_at <= 2 * n as u64, "{looked_at} segments looked at for {n}");
        assert!(curves.splines.is_empty());
    }
}
