//! The jerk-limited motion along a path parameter, stepped in time like the CNC's interpolator.
//!
//! Both planners reduce the path to a [`Track`]: a scalar parameter `u` cut into pieces, each with
//! constant caps on `u̇`, `ü` and `u⃛` (the axes' limits seen through the piece's geometry), and a
//! cap on `u̇` where two pieces meet (corners, exact stops). The inverse-time model of papers
//! 000/001 takes `u` = programmed time (so `u̇` is the share of the programmed feed reached);
//! VPOp (paper 003) takes `u` = tool-tip path length.
//!
//! The stepper advances one interpolation period `h` at a time. At each step it takes the
//! largest jerk such that the next state keeps every cap and can still meet every junction cap
//! ahead, within the look-ahead window (the CNC must be able to stop at the window's end: that
//! is what a look-ahead of N blocks means), with the fastest jerk-limited braking, taken with the
//! tightest limits of the pieces on the way to each junction; past a piece that tightens them,
//! from the junction into it ([`Gate`]). The braking distances are closed forms, so a step costs
//! a handful of operations plus one test per junction that braking could reach. The result
//! starts and ends at rest and keeps the caps (up to rounding) on the bundled examples; how far
//! it is from the time-optimal motion is the switching error of one period per braking. A
//! period whose braking its one step of constant jerk cannot follow (shorter than the period,
//! or built up within it: the slow blocks of inverse time) is taken in sub-steps, its last
//! sample reported ([`SPLIT`]); one that would cross a junction a hair above its cap (within
//! [`SPLIT_OVER`], or above the next piece's own) takes the jerk that meets the cap at the
//! crossing rather than the strongest braking. A deceleration above the limits of pieces ahead
//! is planned cut to theirs where they start, as the steps cut it there ([`cut_short`]), and the
//! window's end is met both as a stop and as its own cap. A motion late for a cap (no jerk meets
//! it) never eases its braking. Some corners are still crossed above their caps
//! (docs/validation.md, known limits). A step takes
//! the caps of the piece it is on, and those of every piece it may enter only where it crosses
//! into them ([`Stepper::steps`]).
//!
//! The track may be streamed: pieces are added as the program is read, and the stepper goes as
//! far as what it holds lets it decide exactly as it would on the whole track (every junction
//! within braking reach and within the window known), then waits for more ([`Stepper::go`]).

use crate::profile::speed_change;
use crate::window::Window;

/// Counters of the work done, kept in the unit tests only: linearity is tested by counting
/// work, never by timing. And a switch for the unit tests to compare the scan ahead by runs of
/// junctions with the scan of each junction.
pub(crate) mod work {
    #[cfg(test)]
    use std::cell::Cell;

    /// True when the scan ahead looks at each junction, not at runs of them: set by a unit test
    /// only ([`ONE_BY_ONE`]); false outside the unit tests.
    #[inline]
    pub(crate) fn one_by_one() -> bool {
        #[cfg(test)]
        return ONE_BY_ONE.with(Cell::get);
        #[cfg(not(test))]
        false
    }

    #[cfg(test)]
    thread_local! {
        /// The scan ahead looks at each junction ([`one_by_one`]).
        pub(crate) static ONE_BY_ONE: Cell<bool> = const { Cell::new(false) };
        /// Steps chosen (a cruise taken in one go counts once).
        pub(crate) static STEPS: Cell<u64> = const { Cell::new(0) };
        /// Junctions examined while choosing them.
        pub(crate) static JUNCTIONS: Cell<u64> = const { Cell::new(0) };
        /// B-spline track segments looked at while forgetting the splines behind the motion.
        pub(crate) static SEGMENTS: Cell<u64> = const { Cell::new(0) };
    }

    /// The counters' values, reset.
    #[cfg(test)]
    pub(crate) fn take() -> [u64; 3] {
        [STEPS.with(|c| c.replace(0)), JUNCTIONS.with(|c| c.replace(0)), SEGMENTS.with(|c| c.replace(0))]
    }
}

/// One unit of work of the `work` counter named (nothing outside the unit tests).
macro_rules! tally {
    ($counter:ident) => {
        #[cfg(test)]
        $crate::plan::work::$counter.with(|c| c.set(c.get() + 1));
    };
}
pub(crate) use tally;

/// What holds the feed back.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Limit {
    /// Nothing: the programmed feed is reached.
    Programmed,
    /// The velocity of an axis (index into the machine's axes).
    Velocity(u16),
    /// The acceleration of an axis.
    Acceleration(u16),
    /// The jerk of an axis.
    Jerk(u16),
    /// The CNC's tangential acceleration.
    TangentialAcceleration,
    /// The CNC's tangential jerk.
    TangentialJerk,
    /// A block shorter than one interpolation cycle.
    CycleTime,
    /// Corner rounding within the contour tolerance.
    Corner,
    /// The centripetal acceleration (or its jerk) on a circular arc.
    Curvature,
    /// The look-ahead window: the CNC must be able to stop at its end.
    LookAhead,
    /// An exact stop (rapid, tool change, program end).
    Stop,
    /// A rapid traverse, at the axes' speed.
    Rapid,
    /// The block runs at its programmed F, but F is the feed of the linear axes (G1 without
    /// TCP): the tool tip moves slower than the CL file's feed.
    AxisFeed,
    /// Where a move along the tool axis (a plunge, a retract at feed) meets the path: the program
    /// asks the tool to turn there, as at an exact stop.
    Plunge,
}

/// A piece of the track: constant caps on the parameter's derivatives, and why each holds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Piece {
    /// Length in `u`.
    pub length: f64,
    /// Cap on `u̇`.
    pub velocity: f64,
    /// Cap on `|ü|`.
    pub acceleration: f64,
    /// Cap on `|u⃛|`.
    pub jerk: f64,
    /// What gives the velocity cap.
    pub velocity_limit: Limit,
    /// What gives the acceleration cap.
    pub acceleration_limit: Limit,
    /// What gives the jerk cap.
    pub jerk_limit: Limit,
}

/// The end of a piece: a cap on `u̇` there, and a dwell when the motion stops.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Junction {
    /// Cap on `u̇` (0 for an exact stop).
    pub cap: f64,
    /// What gives it.
    pub limit: Limit,
    /// Time spent at rest here (s), when `cap` is 0.
    pub dwell: f64,
}

/// The path as the planner sees it. `junctions[i]` ends `pieces[i]`; the last one is a stop.
/// Pieces are added at the end while the track is built ([`TrackBuilder`]); a streamed
/// prediction forgets the ones behind the motion.
#[derive(Clone, Debug, Default)]
pub struct Track {
    /// The pieces, each of positive length.
    pub pieces: Window<Piece>,
    /// One per piece; the last one is final only once the next piece is added or the track is
    /// complete.
    pub junctions: Window<Junction>,
    /// Pieces the CNC sees ahead, the current one included (`usize::MAX`: all), counting only the
    /// pieces of [`Self::counted`].
    pub window: usize,
    /// The pieces that count towards the window, in order (each a block of the program: an arc's
    /// pieces are one block).
    pub counted: Window<usize>,
    /// Dwell before the first piece (s).
    pub dwell_at_start: f64,
    /// No piece will be added.
    pub complete: bool,
}

impl Track {
    /// A whole track (every piece counts towards the window).
    pub fn new(pieces: Vec<Piece>, junctions: Vec<Junction>, window: usize, dwell_at_start: f64) -> Track {
        let mut track = Track { window, dwell_at_start, complete: true, ..Track::default() };
        for (i, (p, j)) in pieces.into_iter().zip(junctions).enumerate() {
            track.pieces.push(p);
            track.junctions.push(j);
            track.counted.push(i);
        }
        track
    }

    /// Number of pieces (added so far).
    pub fn len(&self) -> usize {
        self.pieces.end()
    }

    /// True without pieces.
    pub fn is_empty(&self) -> bool {
        self.pieces.is_empty()
    }

    /// True when junction `i` is final: the piece after it is there, or the track is complete.
    fn known(&self, i: usize) -> bool {
        i + 1 < self.len() || (self.complete && i < self.len())
    }

    /// The cap at junction `i` with the pieces on both sides, and what gives it (a stop at the
    /// end of a complete track). Junction `i` must be [`known`](Self::known).
    fn junction_cap(&self, i: usize) -> (f64, Limit) {
        if i + 1 == self.len() {
            return (0.0, Limit::Stop);
        }
        let j = self.junctions[i];
        let mut best = (j.cap, j.limit);
        for p in [i, i + 1] {
            if self.pieces[p].velocity < best.0 {
                best = (self.pieces[p].velocity, self.pieces[p].velocity_limit);
            }
        }
        best
    }

    /// Forgets the pieces before piece `i`.
    pub fn forget_before(&mut self, i: usize) {
        self.pieces.forget_before(i);
        self.junctions.forget_before(i);
        let counted = &self.counted;
        let ordinal = counted.base() + counted.held().partition_point(|&p| p < i);
        self.counted.forget_before(ordinal);
    }
}

/// Builds a [`Track`] piece by piece for the planners: what stands between two pieces (an exact
/// stop and its dwell, or a corner's cap), and the block each piece stands for.
#[derive(Debug, Default)]
pub struct TrackBuilder {
    /// The track built so far.
    pub track: Track,
    /// The block of each piece.
    pub owner: Window<usize>,
    stop_pending: bool,
    dwell_pending: f64,
}

impl TrackBuilder {
    /// A builder of a track seeing `window` pieces ahead (of those that count).
    pub fn new(window: usize) -> TrackBuilder {
        TrackBuilder { track: Track { window, ..Track::default() }, ..TrackBuilder::default() }
    }

    /// Notes what stands before the next piece: an exact stop, a dwell (s).
    pub fn before(&mut self, stop: bool, dwell: f64) {
        self.stop_pending |= stop;
        self.dwell_pending += dwell;
    }

    /// True when the next piece follows an exact stop (its corner cap is not needed).
    pub fn stop_pending(&self) -> bool {
        self.stop_pending
    }

    /// The block of the last piece.
    pub fn last_block(&self) -> Option<usize> {
        self.owner.last().copied()
    }

    /// Pieces so far.
    pub fn len(&self) -> usize {
        self.track.len()
    }

    /// True before the first piece.
    pub fn is_empty(&self) -> bool {
        self.track.is_empty()
    }

    /// Adds `piece` for `block` (counted towards the look-ahead window when `counts`); the
    /// junction before it is an exact stop when one is pending, else capped at `corner` for the
    /// reason `why` (a corner, a plunge).
    pub fn push(&mut self, piece: Piece, block: usize, corner: f64, why: Limit, counts: bool) {
        let track = &mut self.track;
        if let Some(last) = track.junctions.last_mut() {
            *last = if self.stop_pending {
                Junction { cap: 0.0, limit: Limit::Stop, dwell: self.dwell_pending }
            } else {
                Junction { cap: corner, limit: why, dwell: 0.0 }
            };
        } else {
            track.dwell_at_start = self.dwell_pending;
        }
        self.stop_pending = false;
        self.dwell_pending = 0.0;
        if counts {
            track.counted.push(track.pieces.end());
        }
        track.pieces.push(piece);
        track.junctions.push(Junction { cap: 0.0, limit: Limit::Stop, dwell: 0.0 });
        self.owner.push(block);
    }

    /// No piece will follow: a dwell after the last piece is spent at its end; with no piece at
    /// all, it is the dwell at the start.
    pub fn complete(&mut self) {
        let track = &mut self.track;
        match track.junctions.last_mut() {
            Some(last) => last.dwell = self.dwell_pending,
            None => track.dwell_at_start = self.dwell_pending,
        }
        self.dwell_pending = 0.0;
        track.complete = true;
    }

    /// Forgets the pieces before piece `i`.
    pub fn forget_before(&mut self, i: usize) {
        self.track.forget_before(i);
        self.owner.forget_before(i);
    }
}

/// One interpolation step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    /// Time (s).
    pub t: f64,
    /// Parameter.
    pub u: f64,
    /// `u̇`.
    pub v: f64,
    /// `ü`.
    pub a: f64,
    /// `u⃛` over the step that ended here.
    pub j: f64,
    /// The piece `u` is in.
    pub piece: usize,
    /// What held the step back, as shown: the piece's speed cap once the speed is at it.
    pub limit: Limit,
    /// What bound the step's jerk.
    pub bound: Limit,
    /// True when `bound` is a cap ahead that the motion brakes for (a junction, an exact stop,
    /// the end of the look-ahead), false when it is a cap of the piece the motion is on.
    pub ahead: bool,
    /// The interpolation periods the sample stands for: 1, or more for a cruise at constant
    /// speed taken in one go ([`Observer::every_period`]).
    pub periods: u64,
}

impl Sample {
    /// A sample at rest, held by `limit` (`bound` alike).
    fn at_rest(t: f64, u: f64, j: f64, piece: usize, limit: Limit, ahead: bool) -> Sample {
        Sample { t, u, v: 0.0, a: 0.0, j, piece, limit, bound: limit, ahead, periods: 1 }
    }
}

/// What the stepper reports.
pub trait Observer {
    /// A sample, every period (and at the very end).
    fn sample(&mut self, sample: &Sample);
    /// The motion crossed the end of `piece` at time `t` with `u̇ = v`; `limit` held that step.
    fn crossing(&mut self, piece: usize, t: f64, v: f64, limit: Limit);
    /// True when it wants a sample every period; false lets a cruise at constant speed, where
    /// nothing ahead can bind, come as one sample at its end ([`Sample::periods`]), which the
    /// prediction's own observer takes whether it keeps the samples or not (its figures never
    /// depend on that).
    fn every_period(&self) -> bool {
        true
    }
}

/// Runs the motion along the whole `track` with period `h` (s), reporting to `observer`. Returns
/// the total time (s), dwells included.
pub fn run(track: &Track, h: f64, observer: &mut dyn Observer) -> f64 {
    let mut stepper = Stepper::new(h);
    stepper.go(track, observer);
    stepper.time(track)
}

/// How far [`Stepper::go`] got.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Progress {
    /// It needs more pieces to decide the next step.
    Waiting,
    /// The motion is at the end of the complete track.
    Done,
}

/// The interpolator's state along a track that may grow: where the motion is and what it has
/// computed of the pieces (their ends in the parameter, the caps at their junctions).
#[derive(Clone, Debug)]
pub struct Stepper {
    /// Where each piece ends in the parameter.
    ends: Window<f64>,
    /// Each known junction as the scan ahead reads it.
    known: Window<Ahead>,
    /// The known junctions by runs of each length of [`RUNS`], summed up for the scan to pass
    /// over at once (`runs[l][g]` holds junctions `g·n … g·n + n − 1`, `n = RUNS[l]`, once all
    /// are known).
    runs: [Window<Run>; RUNS.len()],
    /// The runs being summed up.
    run: [Run; RUNS.len()],
    h: f64,
    t: f64,
    u: f64,
    v: f64,
    a: f64,
    /// Current piece.
    k: usize,
    /// The first counted piece at or after `k`, as an ordinal of [`Track::counted`].
    counted: usize,
    /// The window's end seen from piece `.0`, once the track held it: it stays while the motion
    /// is on that piece ([`Self::window_end`]).
    window_end_from: Option<(usize, usize)>,
    /// Cruising on piece `.0` at its cap, nothing ahead within braking reach while the steps end
    /// under `.1`: the steps up to it need no scan of the junctions (the junctions before it have
    /// caps above the speed), and those into pieces of the same speed cap are taken at once
    /// ([`Self::cruise_periods`]).
    cruise: Option<(usize, f64)>,
    started: bool,
    done: bool,
    /// What the last step tried needs the track to hold before it can be decided: nothing
    /// changes until then, so the steps are not tried again (a scan ahead may be long).
    waiting: Option<Need>,
    /// The steps taken on the current piece (`.1`; a cruise taken in one go is one): more than
    /// `steps_per_piece` ([`STEPS_PER_PIECE`]), far more than any motion takes, is a loop that
    /// runs away, a bug: the piece is ended at once rather than let hang, and counted in
    /// `abandoned`.
    guard: (usize, u64),
    steps_per_piece: u64,
    abandoned: u64,
    /// A period being taken in sub-steps ([`SPLIT`]): per level, outermost first, the step it
    /// splits and the sub-steps left of it. `h` is the innermost sub-step's.
    split: Vec<(f64, u32)>,
}

/// A step that would cross a junction above its cap (by more than [`SPLIT_OVER`]), that carries
/// a deceleration across one the next piece cannot end ([`Stepper::carries_deceleration`]), or
/// that misses a cap ahead only because its deceleration reaches its cap within the period, is
/// taken again in this many sub-steps, and so on down [`SPLIT_LEVELS`] levels: a braking shorter
/// than a period, or of a few periods whose deceleration builds in less than one (the slow blocks
/// of inverse time, where the parameter's limits scale with 1/F and 1/F²), is then followed
/// within it, as a CNC planning in continuous time and sampling at its period does. Only the
/// period's last sample is reported.
const SPLIT: u32 = 8;
/// See [`SPLIT`]: down to a 4 096th of the period (at most 4 096 sub-steps in a period; a
/// braking needs a level or two).
const SPLIT_LEVELS: usize = 4;
/// A crossing above its cap by less than this share is the steps' rounding of the braking
/// curve, not split ([`SPLIT`]): split too, such crossings brake harder than the finer stepping
/// does (over the corpus, docs/validation.md).
const SPLIT_OVER: f64 = 1e-2;

/// The lowest jerk of a step of `h` from acceleration `a`, at most `jerk` and keeping `|ü|` at
/// most `acceleration`.
#[inline]
fn strongest_braking(jerk: f64, acceleration: f64, a: f64, h: f64) -> f64 {
    (-jerk).max((-acceleration - a) / h)
}

/// The state after `h` at constant jerk `j`.
#[inline]
fn advance(u: f64, v: f64, a: f64, j: f64, h: f64) -> (f64, f64, f64) {
    (u + v * h + a * h * h / 2.0 + j * h * h * h / 6.0, v + a * h + j * h * h / 2.0, a + j * h)
}

impl Stepper {
    /// At rest at the start of a track, with period `h` (s).
    pub fn new(h: f64) -> Stepper {
        Stepper {
            ends: Window::default(),
            known: Window::default(),
            runs: Default::default(),
            run: [Run::EMPTY; RUNS.len()],
            h,
            t: 0.0,
            u: 0.0,
            v: 0.0,
            a: 0.0,
            k: 0,
            counted: 0,
            window_end_from: None,
            cruise: None,
            started: false,
            done: false,
            waiting: None,
            guard: (0, 0),
            steps_per_piece: STEPS_PER_PIECE,
            abandoned: 0,
            split: Vec::new(),
        }
    }

    /// The pieces the stepper gave up on and ended at once: a loop that did not end, a bug. Their
    /// times are not the machine's.
    pub fn abandoned(&self) -> u64 {
        self.abandoned
    }

    /// The piece the motion is on: the pieces before it are no longer needed.
    pub fn piece(&self) -> usize {
        self.k
    }

    /// The time so far (s); at the end, the total time, dwells included.
    pub fn time(&self, track: &Track) -> f64 {
        if !self.started {
            return track.dwell_at_start;
        }
        match track.junctions.last() {
            Some(last) if self.done => self.t + last.dwell,
            _ => self.t,
        }
    }

    /// Forgets what it computed of the pieces before piece `i`.
    pub fn forget_before(&mut self, i: usize) {
        self.ends.forget_before(i);
        self.known.forget_before(i);
        for (runs, n) in self.runs.iter_mut().zip(RUNS) {
            runs.forget_before(i / n);
        }
    }

    /// Takes in the pieces and junctions added to `track` since the last call.
    fn extend(&mut self, track: &Track) {
        while self.ends.end() < track.len() {
            let i = self.ends.end();
            let before = if i == 0 { 0.0 } else { self.ends[i - 1] };
            self.ends.push(before + track.pieces[i].length);
        }
        while self.known.end() < track.len() && track.known(self.known.end()) {
            let i = self.known.end();
            let (cap, why) = track.junction_cap(i);
            let piece = &track.pieces[i];
            let ahead = Ahead { at: self.ends[i], cap, why, acceleration: piece.acceleration, jerk: piece.jerk };
            self.known.push(ahead);
            for ((run, runs), n) in self.run.iter_mut().zip(&mut self.runs).zip(RUNS) {
                run.add(&ahead, i % n);
                if i % n == n - 1 {
                    runs.push(*run);
                }
            }
        }
    }

    /// Steps the motion along `track` as far as what it holds lets it decide, reporting to
    /// `observer`.
    pub fn go(&mut self, track: &Track, observer: &mut dyn Observer) -> Progress {
        if self.done {
            return Progress::Done;
        }
        self.extend(track);
        if track.is_empty() {
            if track.complete {
                self.done = true;
                return Progress::Done;
            }
            return Progress::Waiting;
        }
        if !self.started {
            self.started = true;
            self.t = track.dwell_at_start;
            observer.sample(&Sample::at_rest(self.t, 0.0, 0.0, 0, Limit::Stop, true));
        }
        if let Some(need) = self.waiting.take()
            && let Some(need) = self.still_needs(need, track)
        {
            self.waiting = Some(need);
            return Progress::Waiting;
        }
        let progress = self.steps(track, observer);
        if progress == Progress::Done {
            self.done = true;
        }
        progress
    }

    fn steps(&mut self, track: &Track, observer: &mut dyn Observer) -> Progress {
        let skip = !observer.every_period();
        loop {
            if skip
                && self.split.is_empty()
                && let Some((n, last)) = self.cruise_periods(track)
            {
                // Cruising at the piece's cap with nothing ahead within braking reach: the next
                // `n` steps are all the same, taken at once, across the junctions they cross into
                // pieces of the same cap, up to piece `last` (each crossing reported as its step
                // would report it).
                let limit = track.pieces[self.k].velocity_limit;
                let (t0, u0) = (self.t, self.u);
                self.t += n as f64 * self.h;
                self.u += n as f64 * self.v * self.h;
                while self.k < last && self.ends[self.k] <= self.u {
                    let Ahead { at, cap, why, .. } = self.known[self.k];
                    let here = if self.v >= 0.99 * cap { why } else { limit };
                    observer.crossing(self.k, t0 + (at - u0) / self.v, self.v, here);
                    self.k += 1;
                }
                if let Some(cruise) = &mut self.cruise {
                    cruise.0 = self.k;
                }
                self.count_step();
                tally!(STEPS);
                let sample = Sample {
                    t: self.t,
                    u: self.u,
                    v: self.v,
                    a: 0.0,
                    j: 0.0,
                    piece: self.k,
                    limit,
                    bound: limit,
                    ahead: false,
                    periods: n,
                };
                observer.sample(&sample);
                continue;
            }
            // The last piece of the track, once it is complete.
            let n = track.complete.then(|| track.len());
            // A step takes the caps of the piece it is on, with which the scan ahead plans the
            // braking to the junction that ends it; only a step that crosses into a piece of
            // tighter caps takes those, for the whole period. Chosen under the caps of every
            // piece it may enter at once where even the strongest braking crosses.
            let crosses = self.k < self.ends.end() && {
                let here = &track.pieces[self.k];
                let floor = strongest_braking(here.jerk, here.acceleration, self.a, self.h);
                advance(self.u, self.v, self.a, floor, self.h).0 >= self.ends[self.k]
            };
            let Some(mut choice) = self.choose(track, crosses) else {
                return Progress::Waiting;
            };
            if !crosses && choice.tighter_ahead && choice.next.0 >= self.ends[self.k] {
                let Some(crossing) = self.choose(track, true) else {
                    return Progress::Waiting;
                };
                choice = crossing;
            }
            let Choice { j, limit, ahead, next: (u1, v1, a1), clear, shorter_steps_meet, lowest, .. } = choice;
            let crossing = self.ends.get(self.k).is_some_and(|&end| u1 >= end);
            if (shorter_steps_meet
                || (crossing
                    && (self.crosses_above_cap(j, (u1, v1, a1))
                        || self.carries_deceleration(track, (u1, v1, a1), lowest))))
                && self.split.len() < SPLIT_LEVELS
            {
                // Taken again in sub-steps ([`SPLIT`]).
                self.split.push((self.h, SPLIT));
                self.h /= f64::from(SPLIT);
                self.cruise = None;
                continue;
            }
            tally!(STEPS);
            self.count_step();
            let piece = track.pieces[self.k];
            let piece_was = self.k;
            // No stop comes sooner than the fastest braking from the state this step starts
            // from. Steps constant in jerk cannot follow the braking curve, which switches
            // within a period: a step late, they reach the stop with speed left, and a stop
            // taken there would be sooner than the machine can make it (by several periods
            // where the acceleration builds in one or two).
            let (v0, a0) = (self.v, self.a);
            let braking = || braking_time(v0, a0, piece.acceleration, piece.jerk);
            if self.known[self.k].cap <= 0.0
                && let Some(tau) = final_phase(self.a, j, self.h)
                && tau <= self.h
                && self.ends[self.k] - self.u <= self.v * tau + 1e-12
            {
                // The braking's last phase ends within this step: the stop, exactly.
                self.end_split();
                self.t += tau.max(braking());
                self.u = self.ends[self.k];
                self.v = 0.0;
                self.a = 0.0;
                observer.crossing(self.k, self.t, 0.0, Limit::Stop);
                observer.sample(&Sample::at_rest(self.t, self.u, j, self.k, Limit::Stop, true));
                self.k += 1;
                if Some(self.k) == n {
                    return Progress::Done;
                }
                self.t += track.junctions[self.k - 1].dwell;
                continue;
            }
            // Crossings of junctions within this step.
            let mut crossed_stop = false;
            while self.k < self.ends.end() && u1 >= self.ends[self.k] {
                let at = self.ends[self.k];
                let tau = time_to(self.u, self.v, self.a, j, at, self.h);
                let (_, vc, _) = advance(self.u, self.v, self.a, j, tau);
                if self.known[self.k].cap <= 0.0 {
                    // An exact stop: the motion ends at the junction, at the end of the braking's
                    // last phase, never sooner than the fastest braking (which eases the
                    // deceleration to 0 at the piece's jerk).
                    let end = final_phase(self.a, j, self.h).unwrap_or(tau).max(braking());
                    observer.crossing(self.k, self.t + end, 0.0, Limit::Stop);
                    self.t += end;
                    self.u = at;
                    self.v = 0.0;
                    self.a = 0.0;
                    crossed_stop = true;
                    self.k += 1;
                    break;
                }
                // At its cap, the junction is what holds the speed there.
                let Ahead { cap, why, .. } = self.known[self.k];
                let here = if vc >= 0.99 * cap { why } else { limit };
                observer.crossing(self.k, self.t + tau, vc.max(0.0), here);
                self.k += 1;
            }
            if crossed_stop {
                self.end_split();
                observer.sample(&Sample::at_rest(self.t, self.u, j, self.k - 1, Limit::Stop, true));
                if Some(self.k) == n {
                    return Progress::Done;
                }
                self.t += track.junctions[self.k - 1].dwell;
                continue;
            }
            let runaway = self.guard.1 > self.steps_per_piece;
            if v1 < 0.0 || (v1 == 0.0 && a1 <= 0.0) || runaway {
                // The speed reaches 0 within this step.
                let tau = if self.v > 0.0 { time_to_rest(self.v, self.a, j, self.h) } else { self.h };
                let (u_rest, _, _) = advance(self.u, self.v, self.a, j, tau);
                let tau = final_phase(self.a, j, self.h).unwrap_or(tau).max(braking());
                // From here the period's rounding judges the bit left, split or not.
                self.end_split();
                let at = self.ends[self.k];
                let rest = (at - u_rest).max(0.0);
                self.t += tau;
                self.v = 0.0;
                self.a = 0.0;
                if runaway {
                    self.abandoned += 1;
                }
                // The last bit covered as the end of a braking would: its final phase, `end`
                // long, from the speed J·end²/2 (`rest` = J·end³/6).
                let end = (6.0 * rest / piece.jerk.max(1e-12)).cbrt();
                let fits = rest <= 10.0 * piece.jerk * self.h.powi(3)
                    && piece.jerk * end * end / 2.0 <= piece.velocity
                    && piece.jerk * end <= piece.acceleration;
                if !runaway && !fits {
                    // Stopped short, more than the period's rounding (of a look-ahead window's
                    // end; or on a piece whose speed cap is far under J·h²): start again from
                    // rest.
                    self.u = u_rest;
                    observer.sample(&Sample::at_rest(self.t, self.u, j, self.k, limit, ahead));
                    continue;
                }
                // Braking ended a hair before the junction (the period's rounding): cover the
                // last bit as the end of a braking would, and stop there.
                self.t += end;
                self.u = at;
                let why = if self.known[self.k].cap <= 0.0 { Limit::Stop } else { Limit::LookAhead };
                observer.crossing(self.k, self.t, 0.0, why);
                observer.sample(&Sample::at_rest(self.t, self.u, j, self.k, limit, ahead));
                self.k += 1;
                if n.is_some_and(|n| self.k == n || self.u >= self.ends[n - 1]) {
                    return Progress::Done;
                }
                self.t += track.junctions[self.k - 1].dwell;
                continue;
            }
            self.t += self.h;
            self.u = u1;
            // Arrived at the piece's speed cap with the acceleration all but ended: cruise
            // exactly. Steps of constant jerk cannot end an acceleration under J·h exactly at
            // the cap (that takes less than a period): the largest jerk lands on the cap with
            // the acceleration reversed, step after step, the jerk chattering for dozens of
            // periods while the speed stays within a millionth of the cap. So where nothing
            // ahead can bind yet (the acceleration given up cannot be one a junction needs) and
            // the piece's jerk can end the acceleration within this step, it is ended there.
            let now = self.k.min(track.len() - 1);
            let cap = track.pieces[now];
            let ended = if clear { self.a.abs() <= cap.jerk * self.h } else { a1.abs() <= 1e-4 * cap.acceleration };
            let (v1, a1) = if limit == cap.velocity_limit && (v1 - cap.velocity).abs() <= 1e-6 * cap.velocity && ended {
                (cap.velocity, 0.0)
            } else {
                (v1, a1)
            };
            self.v = v1;
            // Across a junction the axes' accelerations jump with their directions anyway (the
            // corner is rounded within the tolerance): the next piece's caps hold from there,
            // and so does its jerk: a deceleration it could not end before the speed reaches 0,
            // or an acceleration it could not end under its speed cap, is eased at the junction.
            self.a = if now == piece_was {
                a1
            } else {
                let q = &track.pieces[now];
                let low = -(2.0 * q.jerk * v1.max(0.0)).sqrt();
                let high = (2.0 * q.jerk * (q.velocity - v1).max(0.0)).sqrt();
                a1.clamp(low.max(-q.acceleration), high.min(q.acceleration))
            };
            let shown = if v1 >= 0.999 * track.pieces[now].velocity { track.pieces[now].velocity_limit } else { limit };
            let sample = Sample {
                t: self.t,
                u: u1,
                v: v1,
                a: self.a,
                j,
                piece: now,
                limit: shown,
                bound: limit,
                ahead,
                periods: 1,
            };
            if self.split.is_empty() {
                observer.sample(&sample);
            } else {
                self.sub_step_taken(sample, observer);
            }
        }
    }

    /// True when the step to `(u1, v1, a1)` crosses into a piece whose jerk cannot end the
    /// deceleration `a1` before the speed falls under `lowest`, the lowest cap the scan ahead saw,
    /// by more than [`SPLIT_OVER`]: a braking that ends within the period, carried across the
    /// junction by a step of constant jerk into a piece a rotary axis's jerk limits, where the
    /// speed fell to nearly 0 as the CNC's does not (`hypar-5axis` on the MAHO in g1: 2 mm/min,
    /// 177 stepped at 0.5 ms; test `the_prediction_at_the_machines_period_is_near_the_converged_one`
    /// in `postpro`'s `tests/predict.rs`).
    fn carries_deceleration(&self, track: &Track, (u1, v1, a1): (f64, f64, f64), lowest: f64) -> bool {
        if a1 >= 0.0 || v1 <= 0.0 {
            return false;
        }
        let mut m = self.k;
        while m + 1 < self.ends.end() && u1 >= self.ends[m] {
            m += 1;
        }
        let end = v1 - a1 * a1 / (2.0 * track.pieces[m].jerk);
        m != self.k && end < (1.0 - SPLIT_OVER) * lowest.min(v1)
    }

    /// True when the step to `(u1, v1, a1)` at jerk `j` crosses a junction (not a stop) above its
    /// cap, by more than [`SPLIT_OVER`].
    #[inline(never)]
    fn crosses_above_cap(&self, j: f64, (u1, v1, a1): (f64, f64, f64)) -> bool {
        let (u, v, a, h) = (self.u, self.v, self.a, self.h);
        // The highest speed over the step, at an end or where the acceleration changes sign: a
        // junction capped above it needs no crossing speed.
        let turn = if a > 0.0 && j < 0.0 { -a / j } else { h };
        let highest = if turn < h { v + a * turn / 2.0 } else { v.max(v1) };
        let mut m = self.k;
        while m < self.ends.end() && u1 >= self.ends[m] {
            let cap = self.known[m].cap;
            if cap <= 0.0 {
                return false;
            }
            let allowed = cap * (1.0 + SPLIT_OVER) + 1e-12;
            if highest > allowed && !crossed_within((allowed, f64::INFINITY), self.ends[m], (u, v, a), j, h, (v1, a1)) {
                return true;
            }
            m += 1;
        }
        false
    }

    /// A sub-step of a split period is taken: the period's sample, the last sub-step's, is
    /// reported once that is.
    fn sub_step_taken(&mut self, sample: Sample, observer: &mut dyn Observer) {
        while let Some((h, left)) = self.split.last_mut() {
            *left -= 1;
            if *left > 0 {
                return;
            }
            self.h = *h;
            self.split.pop();
        }
        // A cruise set by a sub-step holds for sub-steps.
        self.cruise = None;
        observer.sample(&sample);
    }

    /// The interpolation period: the step's, or the one it splits ([`SPLIT`]).
    fn period(&self) -> f64 {
        self.split.first().map_or(self.h, |&(h, _)| h)
    }

    /// Ends a split period where the motion comes to rest within it (the sample at rest is the
    /// period's): the steps go on from there at the period.
    fn end_split(&mut self) {
        if let Some(&(h, _)) = self.split.first() {
            self.h = h;
            self.split.clear();
            self.cruise = None;
        }
    }

    /// Counts a step on the current piece ([`Self::guard`]).
    fn count_step(&mut self) {
        if self.guard.0 != self.k {
            self.guard = (self.k, 0);
        }
        self.guard.1 += 1;
    }

    /// The periods of a cruise the next steps would take one at a time with nothing to decide (at
    /// least two), if the motion cruises, and the piece they end on.
    ///
    /// They cross the junctions into pieces of the same speed cap (and cause): every junction
    /// before the cruise's end has a cap above the speed, and a scan from any of those pieces
    /// would find nothing to bind sooner (it sees the same junctions, up to a window's end no
    /// nearer; the limits on the way to them are no tighter; and at no acceleration the
    /// braking's reach does not depend on the piece's jerk), so each of those steps would cruise
    /// too. The step that crosses into a piece of another cap is taken alone.
    fn cruise_periods(&self, track: &Track) -> Option<(u64, usize)> {
        let here = track.pieces.get(self.k)?;
        let beyond = self.cruising(here)?;
        if self.v <= 0.0 {
            return None;
        }
        let step = self.v * self.h;
        let mut last = self.k;
        while self.ends[last] < beyond
            && last + 1 < self.ends.end()
            && let Some(junction) = self.known.get(last)
            && junction.cap >= self.v
            && same_cap(here, &track.pieces[last + 1])
        {
            last += 1;
        }
        // The steps m = 1, 2, … while u + m·v·h < until, before the last piece's end.
        let until = beyond.min(self.ends[last] - step);
        let room = (until - self.u) / step;
        let n = if room.is_finite() && room > 0.0 { room.ceil() as u64 - 1 } else { 0 };
        (n >= 2).then_some((n, last))
    }

    /// Where the cruise ends (the parameter the steps stay under, see [`Self::cruise`]), when the
    /// motion cruises at the cap of the piece it is on (`here`) with nothing ahead within
    /// braking reach.
    fn cruising(&self, here: &Piece) -> Option<f64> {
        let (piece, beyond) = self.cruise?;
        (piece == self.k && self.a == 0.0 && self.v == here.velocity).then_some(beyond)
    }

    /// Where a cruise at speed `v` (no acceleration, nothing within reach that could bind) may
    /// go on to: where junction `m`, the first beyond the `reach` (the limits of the path to it
    /// `a_path`, `j_path`; `jnow` the piece's jerk), comes into it, or later where a junction on
    /// from it comes into its own reach, as long as the junctions before it have caps above the
    /// speed and lead into pieces of the same speed cap (whose steps are taken at once, see
    /// [`Self::cruise_periods`]), up to the first that could bind (a cap under the speed, a stop,
    /// the window's end `last`) or [`CRUISE_SCAN`] of them. A scan from any point of the cruise
    /// before there finds nothing to bind: it stops at that junction at the latest, still beyond
    /// reach, and the junctions before it never bind at this speed. `None` when the track does
    /// not hold them yet: what is looked at never depends on how much of the track has come (a
    /// streamed prediction is the whole one).
    #[inline(never)]
    fn cruise_end(
        &mut self,
        track: &Track,
        m: usize,
        last: Option<usize>,
        (v, jnow): (f64, f64),
        (mut reach, mut a_path, mut j_path): (f64, f64, f64),
    ) -> Option<f64> {
        let here = &track.pieces[self.k];
        let mut x = m;
        let mut end = self.known[m].at - reach;
        while self.known[x].cap >= v && !(Some(x) == last && x + 1 < track.len()) && x - m < CRUISE_SCAN {
            let Some(next) = self.known.get(x + 1) else {
                return self.wait(Need::Through(m + CRUISE_SCAN));
            };
            if !same_cap(here, &track.pieces[x + 1]) {
                break;
            }
            x += 1;
            if next.acceleration < a_path || next.jerk < j_path {
                a_path = a_path.min(next.acceleration);
                j_path = j_path.min(next.jerk);
                reach = scan_reach(v, 0.0, a_path, j_path, jnow);
            }
            end = end.max(next.at - reach);
        }
        Some(end)
    }

    /// The last piece the CNC sees from the current one (the window's end; the track's end), if
    /// the track holds it yet; `Some(None)`: no window, the scan goes on to the end.
    fn window_end(&mut self, track: &Track) -> Option<Option<usize>> {
        if track.window == usize::MAX {
            return Some(track.complete.then(|| track.len() - 1));
        }
        if let Some((from, end)) = self.window_end_from
            && from == self.k
        {
            return Some(Some(end));
        }
        let counted = &track.counted;
        // The counted pieces the track forgot are behind the motion: past them at once (the
        // motion may have crossed many since the last look, cruising or stopping).
        self.counted = self.counted.max(counted.base());
        while self.counted < counted.end() && counted[self.counted] < self.k {
            self.counted += 1;
        }
        let ordinal = self.counted + track.window - 1;
        let end = match counted.get(ordinal) {
            Some(&end) => end,
            None if track.complete => track.len() - 1,
            None => return self.wait(Need::Counted(ordinal)),
        };
        self.window_end_from = Some((self.k, end));
        Some(Some(end))
    }

    /// What of `need` the track does not hold yet (`None`: all of it), the junctions taken in
    /// ([`Self::extend`]) looked at once each.
    fn still_needs(&self, need: Need, track: &Track) -> Option<Need> {
        let known = &self.known;
        match need {
            Need::Junction(i) => (!track.known(i)).then_some(need),
            Need::Through(i) => (!track.complete && !track.known(i)).then_some(need),
            Need::Counted(ordinal) => (!track.complete && ordinal >= track.counted.end()).then_some(need),
            Need::Beyond { next, at, gate_at, last } => {
                let ends_scan = |i: usize| {
                    let ahead = known[i];
                    ahead.cap <= 0.0
                        || ahead.at > at
                        || Some(i) == last
                        || ((i + 1).is_multiple_of(GATE_STRIDE) && ahead.at > gate_at)
                };
                let met = track.complete || (next..known.end()).any(ends_scan);
                (!met).then_some(Need::Beyond { next: known.end(), at, gate_at, last })
            }
        }
    }

    /// Notes what the track must hold before the step can be decided, and says it cannot yet.
    fn wait<T>(&mut self, need: Need) -> Option<T> {
        self.waiting = Some(need);
        None
    }

    /// The largest jerk for the next step and what comes with it; `None` when the track does not
    /// hold enough yet to say. Under the caps of the piece the motion is on; with `crossing`,
    /// under those of every piece the step may enter too.
    fn choose(&mut self, track: &Track, crossing: bool) -> Option<Choice> {
        let (h, period) = (self.h, self.period());
        let (u, v, a) = (self.u, self.v, self.a);
        if !track.known(self.k) {
            return self.wait(Need::Junction(self.k));
        }
        let here = &track.pieces[self.k];
        // Cruising where nothing can bind yet: the same step again, up to the one that crosses
        // into the next piece (the scan then sets the cruise there).
        if let Some(beyond) = self.cruising(here)
            && u + v * h < beyond
        {
            let next = advance(u, v, a, 0.0, h);
            return Some(Choice {
                j: 0.0,
                limit: here.velocity_limit,
                ahead: false,
                tighter_ahead: false,
                next,
                clear: true,
                shorter_steps_meet: false,
                lowest: f64::INFINITY,
            });
        }
        // With `crossing`, the caps of every piece this step may enter: the jerk and acceleration
        // chosen hold for the whole step, on whichever piece it ends.
        let mut p = track.pieces[self.k];
        let mut tighter_ahead = false;
        let reach = u + v * h + a.max(0.0) * h * h / 2.0 + p.jerk * h * h * h / 6.0;
        let mut m = self.k;
        loop {
            // Every junction this step may cross must be known.
            if !track.known(m) {
                return self.wait(Need::Junction(m));
            }
            if m + 1 >= track.len() || self.ends[m] >= reach {
                break;
            }
            m += 1;
            let q = &track.pieces[m];
            tighter_ahead |= q.jerk < p.jerk || q.acceleration < p.acceleration;
            if !crossing {
                continue;
            }
            if q.jerk < p.jerk {
                p.jerk = q.jerk;
                p.jerk_limit = q.jerk_limit;
            }
            if q.acceleration < p.acceleration {
                p.acceleration = q.acceleration;
                p.acceleration_limit = q.acceleration_limit;
            }
        }
        let last = self.window_end(track)?;
        // Where the first piece of limits tighter than the current one's starts, the scan ahead
        // once it has found it: a deceleration above the path's cap is cut there, as the steps
        // cut it at a junction ([`reach_distance_cut`]). With `crossing`, where the step may
        // enter the pieces whose caps it took.
        let here_piece = &track.pieces[self.k];
        let mut cut_at = if p.acceleration < here_piece.acceleration || p.jerk < here_piece.jerk {
            self.ends[self.k]
        } else {
            f64::INFINITY
        };
        let p = &p;
        let mut j = p.jerk;
        let mut lowest = f64::INFINITY;
        let mut limit = p.jerk_limit;
        let mut ahead = false;
        // Acceleration cap.
        let ja = (p.acceleration - a) / h;
        if ja < j {
            j = ja;
            limit = p.acceleration_limit;
        }
        // Velocity cap: the speed once the acceleration is brought back to 0 stays under it.
        let jv = velocity_cap_jerk(v, a, p.velocity, p.jerk, h);
        if jv < j {
            j = jv;
            limit = p.velocity_limit;
        }
        // The strongest braking: the jerk, and the current piece's acceleration (a junction
        // into a piece with less clamps the acceleration there, see `steps`).
        let floor = strongest_braking(p.jerk, track.pieces[self.k].acceleration, a, h);
        if j <= floor {
            self.cruise = None;
            let next = advance(u, v, a, floor, h);
            return Some(Choice {
                j: floor,
                limit,
                ahead: false,
                tighter_ahead,
                next,
                clear: false,
                shorter_steps_meet: false,
                lowest: 0.0,
            });
        }
        // Junctions ahead, within the window and within braking reach: decided on a copy of the
        // state, committed once the track held all it needed.
        let (mut u1, mut v1, mut a1) = advance(u, v, a, j, h);
        // The limits of the pieces up to junction m: the braking happens on them. The piece after
        // the junction only asks that the acceleration be within its own when the motion gets
        // there (the speed carries over too: the junction's cap has it).
        let (mut a_path, mut j_path) = (p.acceleration, p.jerk);
        let mut reach = scan_reach_cut(v1, a1, (a_path, j_path, p.jerk), cut_at - u1);
        // The reach only grows as the limits tighten along the scan: computed (with the state and
        // limits of the last tightening) only where it decides whether the scan goes on.
        let mut stale: Option<(f64, f64, f64, f64, f64)> = None;
        // The first junction beyond reach, with the reach and the path's limits there, and
        // whether any junction could bind: what a cruise may skip.
        let mut beyond_reach = None;
        let mut could_bind = false;
        // A cap ahead only shorter steps meet.
        let mut shorter_steps_meet = false;
        // The highest speed the state reaches, once its acceleration is ended along the path: a
        // cap above it is no constraint. Computed again when the state or the path's jerk changes.
        let peak_of = |v1: f64, a1: f64, j_path: f64| v1 + a1.max(0.0).powi(2) / (2.0 * j_path);
        let mut peak = peak_of(v1, a1, j_path);
        // The junction into the last piece whose limits tightened the path's ([`Gate`]).
        let mut gate: Option<Gate> = None;
        // The scan ended beyond the gate's reach.
        let mut gated = false;
        let mut m = self.k;
        'scan: loop {
            tally!(JUNCTIONS);
            if last.is_some_and(|last| m > last) {
                break;
            }
            // Beyond the gate's reach nothing binds yet either: tested where a run may start, so
            // that the scan ends at the same junction whether it passes over runs or not.
            if m.is_multiple_of(GATE_STRIDE)
                && let Some(gate) = &mut gate
                && gate.out_of_reach(self.known[m - 1].at)
            {
                gated = true;
                break;
            }
            // The scan needs a junction the track does not hold yet.
            let Some(&junction) = self.known.get(m) else {
                // The scan goes on at least to a stop, the window's end, or a junction beyond the
                // reach it has now (the reach only grows), or beyond the gate's.
                let gate_at = gate.as_mut().map_or(f64::INFINITY, |gate| gate.at + gate.refresh());
                return self.wait(Need::Beyond { next: m, at: u1 + reach, gate_at, last });
            };
            // The longest run starting here whose junctions would each be passed over, at once:
            // no stop, not the window's end, within the reach, and no cap the speed reaches or
            // else every such cap surely reached in time.
            for (runs, n) in self.runs.iter().zip(RUNS) {
                if m.is_multiple_of(n)
                    && !work::one_by_one()
                    && let Some(run) = runs.get(m / n)
                    && last.is_none_or(|last| m + n <= last)
                    && run.cap > 0.0
                    && run.last_at - u1 <= reach
                {
                    // The limits along the path once past the run (a junction that tightens them
                    // raises the peak for those after it: the test takes the run's end, the
                    // worst).
                    let (a_run, j_run) = (a_path.min(run.acceleration), j_path.min(run.jerk));
                    let tightens = a_run < a_path || j_run < j_path;
                    let peak_run = if tightens { peak_of(v1, a1, j_run) } else { peak };
                    // No cap the speed reaches, or every such cap reached in time (and, where the
                    // run tightens the limits, one cap under the peak from the start: whether a
                    // junction could bind must not depend on where in the run they tighten).
                    let passed = run.cap >= peak_run
                        || ((!tightens || run.cap < peak)
                            && surely_reached(run.first_at - u1, v1, a1, run.cap, a_run, j_run, p.jerk));
                    if passed {
                        could_bind |= run.cap < peak_run;
                        lowest = lowest.min(run.cap);
                        if tightens {
                            // The first piece of tighter limits may be in the run: the cut at
                            // the junction into it, as the scan of each junction finds it.
                            if cut_at == f64::INFINITY
                                && let Some(i) = (m.max(self.k + 1)..m + n)
                                    .find(|&i| self.known[i].acceleration < a_path || self.known[i].jerk < j_path)
                            {
                                cut_at = self.known[i - 1].at;
                            }
                            // The gate the scan of each junction would have come to: into the
                            // run's last piece that tightens the path's limits.
                            let a_first = if run.acceleration < a_path { run.lowest.0 } else { 0 };
                            let j_first = if run.jerk < j_path { run.lowest.1 } else { 0 };
                            let tight = m + a_first.max(j_first);
                            let mut new = Gate::new(&self.known[tight - 1], &track.pieces[tight]);
                            for after in tight + 1..m + n {
                                new.tighten(self.known[after].acceleration, self.known[after].jerk);
                            }
                            gate = Some(new);
                            (a_path, j_path) = (a_run, j_run);
                            stale = Some((v1, a1, a_path, j_path, cut_at - u1));
                            peak = peak_run;
                        } else if let Some(gate) = &mut gate {
                            gate.tighten(run.acceleration, run.jerk);
                        }
                        m += n;
                        continue 'scan;
                    }
                }
            }
            if m > self.k && (junction.acceleration < a_path || junction.jerk < j_path) {
                // A piece with a limit tighter than the path's: the junction into it is the gate.
                gate = Some(Gate::new(&self.known[m - 1], &track.pieces[m]));
                cut_at = cut_at.min(self.known[m - 1].at);
                a_path = a_path.min(junction.acceleration);
                j_path = j_path.min(junction.jerk);
                stale = Some((v1, a1, a_path, j_path, cut_at - u1));
                peak = peak_of(v1, a1, j_path);
            } else if let Some(gate) = &mut gate {
                gate.tighten(junction.acceleration, junction.jerk);
            }
            let at = junction.at;
            // Beyond the reach ([`scan_reach`]) nothing binds yet: a junction must be seen
            // before its braking begins.
            if at - u1 > reach {
                if let Some((v, a, a_limit, j_limit, cut)) = stale.take() {
                    reach = scan_reach_cut(v, a, (a_limit, j_limit, p.jerk), cut);
                }
                if at - u1 > reach {
                    beyond_reach = Some((m, reach, a_path, j_path));
                    break;
                }
            }
            // The window's end, unless the program stops there anyway; its own cap is met too
            // (`window_cap`): a braking to a cap near a third of the speed, its deceleration
            // ended there, takes up to 9 % more room than a stop ([`scan_reach`]), so a motion
            // that can stop at the window's end may not meet that cap once the window moves on.
            let window_end = Some(m) == last && m + 1 < track.len() && junction.cap > 0.0;
            let (cap, why) = if window_end { (0.0, Limit::LookAhead) } else { (junction.cap, junction.why) };
            let window_cap = window_end.then_some(junction.cap);
            lowest = lowest.min(junction.cap);
            // The motion stops at a junction capped at 0: nothing after it matters.
            let stop = cap <= 0.0;
            // A cap the speed cannot reach is no constraint.
            if cap >= peak {
                if stop {
                    break;
                }
                m += 1;
                continue;
            }
            could_bind = true;
            // At the strongest braking already (the jerk cannot go lower), held by a cap ahead
            // of the same kind: this junction can change neither the step nor what it reports.
            let settled = j == floor && ahead && limit == why;
            // The room left at the junction once the speed is within its cap, from the state
            // after jerk `jj`.
            // A state on the braking curve itself fits: the rounding of one step must not push it
            // off (it would brake too hard, stop short and creep to the end). Nor must a step
            // that ends a hair beyond it: the deceleration may still be easing at the junction
            // if the next piece's jerk ends it within a period (the CNC's, in a split one).
            let next = track.pieces.get(m + 1);
            let late = next.map_or(0.0, |next| period * (next.jerk / j_path).min(1.0));
            let slack_of = |(u1, v1, a1): (f64, f64, f64)| {
                let room = at - u1;
                // Mostly no deceleration above the path's cap, nothing to cut.
                let reach_to = |w: f64| {
                    if -a1 <= a_path {
                        reach_distance(v1, a1, w, a_path, j_path, p.jerk, late)
                    } else {
                        reach_distance_cut(v1, a1, w, (a_path, j_path, p.jerk), late, cut_at - u1)
                    }
                };
                let reach = match window_cap {
                    Some(w) => reach_to(cap).max(reach_to(w)),
                    None => reach_to(cap),
                };
                room - reach + 1e-9 * (1.0 + room.abs())
            };
            let slack = |jj: f64| slack_of(advance(u, v, a, jj, h));
            // A junction the step itself crosses has no room left after it, so its slack is
            // negative whatever the speed. Where its cap is the next piece's own, the step keeps
            // the speed under it as it keeps the current piece's ([`velocity_cap_jerk`]), from
            // the crossing to the step's end; a cap under the next piece's (a corner's) holds at
            // the crossing, and the next piece's from there.
            let mut crossed_within_cap = false;
            if at < u1 && !settled {
                // Whether the next piece's own cap, if this is it, holds at the jerk taken.
                let mut kept = true;
                if next.is_some_and(|next| next.velocity <= cap) {
                    let jv = velocity_cap_jerk(v, a, cap, j_path, h);
                    if jv < j && jv > floor {
                        j = jv;
                        limit = why;
                        ahead = true;
                        (u1, v1, a1) = advance(u, v, a, j, h);
                        peak = peak_of(v1, a1, j_path);
                    }
                    kept = jv >= j;
                }
                // Past the junction the next piece's caps hold: a corner's cap only where the
                // motion crosses it.
                let beyond = next.map_or(cap, |next| next.velocity.max(cap));
                crossed_within_cap = kept && crossed_within((cap, beyond), at, (u, v, a), j, h, (v1, a1));
                if kept && !crossed_within_cap && cap > 0.0 {
                    // The step ends under the cap but crosses the junction above it, earlier in
                    // the step (a cap a hair under the speed: a spline's pieces at the feed,
                    // their tip rates a few 1e-10 apart). The jerk that brings the speed at the
                    // crossing down to the cap meets it, as the CNC's braking begun a moment
                    // before the junction does, where the strongest braking would dip by J·h²/2
                    // and more. So for the next piece's own cap; a corner's, under the next
                    // piece's, only where the crossing is within the steps' rounding
                    // ([`SPLIT_OVER`]): beyond it the sub-steps follow the braking, and a step
                    // braking to the corner would go on braking past it.
                    let tau = time_to(u, v, a, j, at, h);
                    let crossing = advance(u, v, a, j, tau).1;
                    let jc = 2.0 * (cap - v - a * tau) / (tau * tau);
                    if (beyond <= cap || crossing <= cap * (1.0 + SPLIT_OVER)) && tau > 0.0 && jc < j && jc > floor {
                        let next_state = advance(u, v, a, jc, h);
                        if crossed_within((cap, beyond), at, (u, v, a), jc, h, (next_state.1, next_state.2)) {
                            j = jc;
                            limit = why;
                            ahead = true;
                            (u1, v1, a1) = next_state;
                            peak = peak_of(v1, a1, j_path);
                            crossed_within_cap = true;
                        }
                    }
                }
            }
            if !settled
                && !crossed_within_cap
                && !surely_reached(at - u1, v1, a1, cap, a_path, j_path, p.jerk)
                && let at_j = slack_of((u1, v1, a1))
                && at_j < 0.0
                // Not a cap met from wherever the motion crosses the gate: its braking does not
                // begin before the gate.
                && gate.as_ref().is_none_or(|gate| !gate.dominates(at, cap, h))
            {
                limit = why;
                ahead = true;
                // At the strongest braking already, nothing lower to take.
                if j != floor {
                    let at_floor = slack(floor);
                    j = if at_floor >= 0.0 {
                        // A cap the motion would pass as its acceleration ends: the slack jumps
                        // where the speed that acceleration ends at meets the cap (below it,
                        // nothing to brake; above, the braking and the end of the acceleration
                        // before it), and the largest jerk that fits is there.
                        let jump = velocity_cap_jerk(v, a, cap, j_path.min(p.jerk), h);
                        let jump = (a + jump * h > 0.0).then_some(jump);
                        largest_fitting_near(&slack, jump, (floor, at_floor), (j, at_j))
                    } else {
                        // The strongest braking does not fit either: the state braked too hard
                        // already, and easing is what helps, or the braking from now is shorter
                        // than a period. The best in the interval.
                        let (best, fits) = largest_fitting_unimodal(&slack, (floor, at_floor), (j, at_j));
                        // Steps shorter than the period brake harder only where this one's
                        // deceleration reaches its cap within the period (the braking holds it
                        // there for the rest).
                        shorter_steps_meet |= !fits
                            && floor > -p.jerk
                            && a > -track.pieces[self.k].acceleration
                            && slack_of((u, v, a)) >= 0.0;
                        // But where the deceleration, eased as fast as this step can ease it,
                        // would leave the speed above the cap, the motion is late and needs more
                        // braking, not less: the best without easing (a jerk of at most 0). The
                        // slack may rise with the jerk there where the path's jerk is far under
                        // the piece's (the braking planned must end a deceleration at the path's
                        // jerk before the junction), but the motion brakes here at the piece's
                        // jerk, and the pieces ahead end what they can of it past the junction:
                        // easing for that plan, step after step, the motion crossed a corner of
                        // `kuka-fdm/1001` (Mikron, B-spline) at 1.063 times its cap. (The
                        // strongest braking there brakes harder than the motion needs: 0.56 %
                        // longer on `manta-5axis`, no cap crossed before, where holding the
                        // deceleration is 0.26 %.)
                        let late_for_cap = v - a.min(0.0).powi(2) / (2.0 * p.jerk) > cap;
                        if fits || !late_for_cap { best } else { best.min(0.0).max(floor) }
                    };
                    (u1, v1, a1) = advance(u, v, a, j, h);
                    peak = peak_of(v1, a1, j_path);
                }
            }
            if stop {
                break;
            }
            m += 1;
        }
        self.cruise = if j == 0.0 && a == 0.0 && v == p.velocity && !could_bind && !gated {
            let beyond = match beyond_reach {
                Some((m, reach, a_path, j_path)) => {
                    self.cruise_end(track, m, last, (v, p.jerk), (reach, a_path, j_path))?
                }
                None => f64::NEG_INFINITY,
            };
            Some((self.k, beyond - v * h))
        } else {
            None
        };
        Some(Choice {
            j,
            limit,
            ahead,
            tighter_ahead,
            next: (u1, v1, a1),
            clear: !could_bind,
            shorter_steps_meet,
            lowest,
        })
    }
}

/// True when `next` has the speed cap of `here`, and the same cause: a cruise at that cap goes on
/// into it as it was (its steps taken at once, [`Stepper::cruise_periods`]).
fn same_cap(here: &Piece, next: &Piece) -> bool {
    next.velocity == here.velocity && next.velocity_limit == here.velocity_limit
}

/// The next step as [`Stepper::choose`] decides it.
struct Choice {
    /// The jerk over the step.
    j: f64,
    /// What bounds it.
    limit: Limit,
    /// True when that is a cap ahead.
    ahead: bool,
    /// True when a piece the step may enter has a tighter cap on `ü` or `u⃛` than the one it
    /// is on.
    tighter_ahead: bool,
    /// The parameter, its speed and acceleration after the step.
    next: (f64, f64, f64),
    /// True when no junction within reach has a cap under the speed the motion reaches:
    /// nothing ahead can bind yet.
    clear: bool,
    /// True when a cap ahead is met by the braking from the state now but by no step of
    /// constant jerk over the period: steps shorter than it would ([`SPLIT`]).
    shorter_steps_meet: bool,
    /// The lowest cap of the junctions the scan looked at, the window's end at its own cap (the
    /// window moves on with the motion); 0 for the strongest braking taken without a scan.
    lowest: f64,
}

/// Far more steps on one piece than any motion takes (a cruise taken in one go counts once):
/// 100 M periods of 1 ms stepped one by one are more than a day in one block.
const STEPS_PER_PIECE: u64 = 100_000_000;

/// What the track must hold before a step can be decided.
#[derive(Clone, Copy, Debug)]
enum Need {
    /// Junction `i`, final ([`Track::known`]).
    Junction(usize),
    /// The junctions up to `i`, or the whole track, whichever is shorter.
    Through(usize),
    /// The counted piece of this ordinal (the look-ahead window's end).
    Counted(usize),
    /// The scan of the junctions ahead, out of known ones at junction `next`: a stop, junction
    /// `last` (the window's end), a junction beyond parameter `at`, or one beyond `gate_at`
    /// where the scan tests the gate's reach ([`GATE_STRIDE`]).
    Beyond { next: usize, at: f64, gate_at: f64, last: Option<usize> },
}

/// The most junctions beyond the reach a cruise looks at to see how far it goes on
/// ([`Stepper::cruise_end`]).
const CRUISE_SCAN: usize = 256;

/// The lengths of the runs of junctions the scan ahead may pass over at once, longest first.
const RUNS: [usize; 2] = [16, 4];

/// The scan ahead tests whether it is beyond the gate's reach ([`Gate`]) where a run of any
/// length may start: each junction of this index ends the one before it.
const GATE_STRIDE: usize = RUNS[0];

/// What the scan ahead needs of a run of junctions to pass over it at once: the lowest of their
/// caps and of their pieces' limits, where the run starts and ends, and where its gate is
/// ([`Gate`]).
#[derive(Clone, Copy, Debug)]
struct Run {
    first_at: f64,
    last_at: f64,
    cap: f64,
    acceleration: f64,
    jerk: f64,
    /// The first of the run's pieces with its lowest acceleration, and with its lowest jerk (as
    /// offsets in the run): the last that tighten the path's limits, where they do.
    lowest: (usize, usize),
}

impl Run {
    /// Before any junction.
    const EMPTY: Run = Run {
        first_at: 0.0,
        last_at: 0.0,
        cap: f64::INFINITY,
        acceleration: f64::INFINITY,
        jerk: f64::INFINITY,
        lowest: (0, 0),
    };

    /// Takes in `junction`, at `offset` in the run (0: the first of a new run).
    fn add(&mut self, junction: &Ahead, offset: usize) {
        if offset == 0 {
            *self = Run { first_at: junction.at, ..Run::EMPTY };
        }
        self.last_at = junction.at;
        self.cap = self.cap.min(junction.cap);
        if junction.acceleration < self.acceleration {
            self.acceleration = junction.acceleration;
            self.lowest.0 = offset;
        }
        if junction.jerk < self.jerk {
            self.jerk = junction.jerk;
            self.lowest.1 = offset;
        }
    }
}

/// The junction into the last piece the scan ahead passed whose acceleration or jerk is tighter
/// than those of every piece before it (from the motion on).
///
/// The scan checks each junction with the tightest limits of the path to it, as if the whole
/// braking happened on them. Past a piece of far tighter limits (a rotary linking move, whose
/// path acceleration may be a fraction of a mm/s²), a braking from the speed now would reach
/// over metres; but the motion crosses the gate under its cap (the tight piece's speed cap among
/// them) and with an acceleration the piece after it allows ([`Stepper::steps`] clamps it there),
/// and needs to brake only from there, on the pieces after it. So a junction beyond the gate
/// whose cap is met from any such crossing, with the limits of the pieces from the gate to it,
/// does not bind yet: once the motion is past the gate, the scan checks it with those very
/// limits, and it can be met. Nor does a junction beyond the gate's reach (braking to rest from
/// the worst crossing), as beyond the scan's own. Which junction is the gate depends on the
/// pieces between it and the motion only through the tightest of them, which the gate's piece
/// undercuts: from every state before it, the same junction is the gate for the junctions beyond
/// it, with the same limits, so a junction passed over as met from the gate is not found
/// binding too late (the step that crosses the gate scans from past it: the pieces it may enter
/// are the path's from the start).
#[derive(Clone, Copy, Debug)]
struct Gate {
    /// Where it is, in the parameter.
    at: f64,
    /// Its cap on `u̇`.
    cap: f64,
    /// The most `|ü|` the motion crosses it with: the next piece's cap on it, and what its jerk
    /// can end under its speed cap.
    entry: f64,
    /// The tightest `|ü|` of the pieces from it to the junction scanned.
    acceleration: f64,
    /// The tightest `|u⃛|` of those pieces.
    jerk: f64,
    /// How far beyond it a junction can bind ([`scan_reach`] from the worst crossing), or less
    /// while [`Self::stale`] (it only grows as the limits tighten).
    reach: f64,
    /// The reach is not computed for the limits now.
    stale: bool,
}

impl Gate {
    /// Junction `gate`, into piece `next`.
    fn new(gate: &Ahead, next: &Piece) -> Gate {
        let entry = next.acceleration.min((2.0 * next.jerk * next.velocity).sqrt());
        let mut gate = Gate {
            at: gate.at,
            cap: gate.cap,
            entry,
            acceleration: next.acceleration,
            jerk: next.jerk,
            reach: 0.0,
            stale: true,
        };
        gate.reach = gate.least_reach();
        gate
    }

    /// Takes in the limits of the next pieces scanned.
    fn tighten(&mut self, acceleration: f64, jerk: f64) {
        if acceleration < self.acceleration || jerk < self.jerk {
            self.acceleration = self.acceleration.min(acceleration);
            self.jerk = self.jerk.min(jerk);
            self.reach = self.reach.max(self.least_reach());
            self.stale = true;
        }
    }

    /// No more than the reach, whatever the jerk: braking from the cap at the tightest
    /// acceleration, where a test need not compute the reach itself.
    fn least_reach(&self) -> f64 {
        self.cap * self.cap / (2.0 * self.acceleration)
    }

    /// True when a junction at `at` is beyond the reach, which is computed only where the bound
    /// under it does not tell.
    fn out_of_reach(&mut self, at: f64) -> bool {
        at - self.at > self.reach && at - self.at > self.refresh()
    }

    /// The reach for the limits now (computed where [`Self::reach`] is only a bound under it).
    fn refresh(&mut self) -> f64 {
        if self.stale {
            let (amax, jmax) = (self.acceleration, self.jerk);
            let from = |a: f64| scan_reach_cut(self.cap, a, (amax, jmax, jmax), 0.0);
            self.reach = from(self.entry).max(from(-self.entry));
            self.stale = false;
        }
        self.reach
    }

    /// True when a junction at `at` with cap `cap` (on the pieces scanned so far) is met from any
    /// crossing of the gate, with a period's travel to spare for the steps' rounding (`h`).
    fn dominates(&self, at: f64, cap: f64, h: f64) -> bool {
        let (amax, jmax) = (self.acceleration, self.jerk);
        let from = |a: f64| {
            if -a <= amax {
                reach_distance(self.cap, a, cap, amax, jmax, jmax, 0.0)
            } else {
                reach_distance_cut(self.cap, a, cap, (amax, jmax, jmax), 0.0, 0.0)
            }
        };
        let room = at - self.at;
        let room = room - self.cap * h - 1e-9 * (1.0 + room.abs());
        room >= from(self.entry) && room >= from(-self.entry)
    }
}

/// A known junction as the scan of the junctions ahead reads it ([`Stepper::choose`]): where it
/// is, its cap, and the limits of the piece it ends, in one record.
#[derive(Clone, Copy, Debug)]
struct Ahead {
    /// Where the piece it ends ends, in the parameter.
    at: f64,
    /// The cap on `u̇` there ([`Track::junction_cap`]).
    cap: f64,
    /// What gives the cap.
    why: Limit,
    /// The piece's cap on `|ü|`.
    acceleration: f64,
    /// The piece's cap on `|u⃛|`.
    jerk: f64,
}

/// How near the largest jerk that fits in `[lo, hi]` is found: the bracket of the answer at the
/// end ([`largest_fitting`]).
fn fitting_tolerance(lo: f64, hi: f64) -> f64 {
    1e-9 * (hi - lo).abs().max(1e-12)
}

/// The largest jerk in `[lo, hi]` whose `slack` is not negative, knowing `slack(hi) < 0` and
/// `slack` falling with the jerk (`lo` when even it does not fit): regula falsi (Illinois), which
/// converges in a few steps on these smooth curves, ending on the safe side. Each end comes with
/// its slack, evaluated already.
fn largest_fitting(slack: &dyn Fn(f64) -> f64, (mut lo, mut f_lo): (f64, f64), (mut hi, mut f_hi): (f64, f64)) -> f64 {
    if f_lo < 0.0 {
        return lo; // nothing fits: the strongest braking
    }
    let tolerance = fitting_tolerance(lo, hi);
    let mut side = 0;
    for _ in 0..60 {
        if hi - lo <= tolerance {
            break;
        }
        let mut x = (lo * f_hi - hi * f_lo) / (f_hi - f_lo);
        if !(x > lo && x < hi) {
            x = 0.5 * (lo + hi);
        }
        let f = slack(x);
        if f >= 0.0 {
            lo = x;
            f_lo = f;
            if side == 1 {
                f_hi /= 2.0;
            }
            side = 1;
        } else {
            hi = x;
            f_hi = f;
            if side == -1 {
                f_lo /= 2.0;
            }
            side = -1;
        }
        if f == 0.0 {
            break;
        }
    }
    lo
}

/// [`largest_fitting`], where the slack may drop below 0 at a jump rather than cross it: `jump`,
/// where one may be, is taken when it fits and a hair above it does not, since the largest jerk
/// that fits is then within the search's tolerance above it, where the search would end only
/// after halving the interval some thirty times.
fn largest_fitting_near(
    slack: &dyn Fn(f64) -> f64,
    jump: Option<f64>,
    (lo, f_lo): (f64, f64),
    (hi, f_hi): (f64, f64),
) -> f64 {
    if let Some(jump) = jump
        && f_lo >= 0.0
        && let above = jump + fitting_tolerance(lo, hi)
        && jump > lo
        && above < hi
        && slack(jump) >= 0.0
        && slack(above) < 0.0
    {
        return jump;
    }
    largest_fitting(slack, (lo, f_lo), (hi, f_hi))
}

/// The largest jerk in `[lo, hi]` whose `slack` is not negative when `slack` may rise then fall
/// over the interval: a scan down from `hi`, then regula falsi between the first safe point and
/// the unsafe one above it; with no safe point, the safest one (and `false`). Each end comes with
/// its slack, evaluated already (and not evaluated again).
fn largest_fitting_unimodal(slack: &dyn Fn(f64) -> f64, (lo, f_lo): (f64, f64), (hi, f_hi): (f64, f64)) -> (f64, bool) {
    const STEPS: usize = 4;
    let mut above = (hi, f_hi);
    let mut best = (f64::NEG_INFINITY, lo);
    for i in 0..=STEPS {
        let x = hi - (hi - lo) * i as f64 / STEPS as f64;
        let f = match x {
            _ if x == hi => f_hi,
            _ if x == lo => f_lo,
            _ => slack(x),
        };
        if f >= 0.0 {
            return (if i == 0 { x } else { largest_fitting(slack, (x, f), above) }, true);
        }
        if f > best.0 {
            best = (f, x);
        }
        above = (x, f);
    }
    (best.1, false)
}

/// The time left in a braking's last phase (the deceleration `a` eased to 0 at jerk `j`), when
/// the motion is in it: it depends on the acceleration only, where the distance left would be
/// ill-conditioned.
fn final_phase(a: f64, j: f64, h: f64) -> Option<f64> {
    (a < 0.0 && j > 0.0 && -a / j <= 2.0 * h).then(|| -a / j)
}

/// The largest jerk over `h` that keeps the speed, once the acceleration is brought back to 0 at
/// `jmax`, under `vmax`.
fn velocity_cap_jerk(v: f64, a: f64, vmax: f64, jmax: f64, h: f64) -> f64 {
    // Ending with a' ≤ 0: v' = v + a h + j h²/2 ≤ vmax.
    let linear = 2.0 * (vmax - v - a * h) / (h * h);
    if a + linear * h <= 0.0 {
        return linear;
    }
    // Ending with a' > 0: v' + a'²/(2 jmax) ≤ vmax, a quadratic in j.
    let qa = h * h / (2.0 * jmax);
    let qb = h * h / 2.0 + a * h / jmax;
    let qc = v + a * h + a * a / (2.0 * jmax) - vmax;
    let disc = qb * qb - 4.0 * qa * qc;
    if disc < 0.0 {
        return -a / h; // bring the acceleration to 0 as fast as possible
    }
    (-qb + disc.sqrt()) / (2.0 * qa)
}

/// Where a deceleration above `amax` (the path's cap, from pieces of tighter limits ahead), eased
/// at `jr` from speed `v` and acceleration `a`, is cut to `amax` at `cut` ahead because the
/// easing has not ended there: the distance to there and the speed there. The steps cut it so
/// where the motion enters such a piece ([`Stepper::steps`]); eased beyond, as [`reach_distance`]
/// eases it, it would count a deceleration those pieces do not allow: a braking planned so
/// reached a corner of `manta-5axis` (MAHO, B-spline) at 43 times its cap, past pieces that
/// allow a fifth of the acceleration of those before. `None` where the easing ends before the
/// cut, or the speed reaches 0 before it.
fn cut_short(v: f64, a: f64, amax: f64, jr: f64, cut: f64) -> Option<(f64, f64)> {
    let d = -a;
    // At rest or going back (a step's rounding), nothing to cut.
    if !(d > amax && cut.is_finite() && v > 0.0) {
        return None;
    }
    // The easing ends, or the speed reaches 0 first (v − d·t + jr·t²/2 = 0); either way within
    // `v·eased_in` (the speed only falls), mostly short of the cut: nothing more to compute.
    let eased_in = (d - amax) / jr;
    if v * eased_in <= cut {
        return None;
    }
    let disc = d * d - 2.0 * jr * v;
    let t = if disc >= 0.0 { eased_in.min((d - disc.sqrt()) / jr) } else { eased_in };
    let eased = v * t + a * t * t / 2.0 + jr * t * t * t / 6.0;
    if !(t >= 0.0 && eased > cut) {
        return None;
    }
    let tau = if cut > 0.0 { time_to(0.0, v, a, jr, cut, t) } else { 0.0 };
    let v_cut = advance(0.0, v, a, jr, tau).1;
    (v_cut > 0.0).then_some((cut.max(0.0), v_cut))
}

/// [`reach_distance`] with the limits `(amax, jmax, jnow)`, where a deceleration above `amax` is
/// cut to it `cut` ahead at the latest ([`cut_short`]). Rare: the callers test `−a > amax` first
/// and call [`reach_distance`] otherwise (1–2 % of the whole job's instructions, inlined).
#[cold]
#[inline(never)]
fn reach_distance_cut(v: f64, a: f64, w: f64, (amax, jmax, jnow): (f64, f64, f64), late: f64, cut: f64) -> f64 {
    match cut_short(v, a, amax, jmax.min(jnow), cut) {
        Some((to_cut, v_cut)) => to_cut + reach_distance(v_cut, -amax, w, amax, jmax, jnow, late),
        None => reach_distance(v, a, w, amax, jmax, jnow, late),
    }
}

/// [`scan_reach`] for [`reach_distance_cut`]: no cap it finds binding is beyond.
#[inline(always)]
fn scan_reach_cut(v: f64, a: f64, (amax, jmax, jnow): (f64, f64, f64), cut: f64) -> f64 {
    if -a <= amax {
        return scan_reach(v, a, amax, jmax, jnow);
    }
    match cut_short(v, a, amax, jmax.min(jnow), cut) {
        Some((to_cut, v_cut)) => to_cut + scan_reach(v_cut, -amax, amax, jmax, jnow),
        None => scan_reach(v, a, amax, jmax, jnow),
    }
}

/// The shortest distance in which the speed `v` with acceleration `a` can be brought to at most
/// `w`, with `|ü| ≤ amax` and `|u⃛| ≤ jmax` (and `jnow` the jerk available to end an ongoing
/// acceleration). 0 when the speed never exceeds `w`.
pub(crate) fn reach_distance(v: f64, a: f64, w: f64, amax: f64, jmax: f64, jnow: f64, late: f64) -> f64 {
    let jr = jmax.min(jnow);
    if a > 0.0 {
        // End the acceleration first.
        let t = a / jr;
        let v1 = v + a * t - jr * t * t / 2.0;
        if v1 <= w {
            return 0.0;
        }
        let d1 = v * t + a * t * t / 2.0 - jr * t * t * t / 6.0;
        return d1 + speed_change(v1, w, amax, jmax).0;
    }
    if v <= w {
        return 0.0;
    }
    let d = -a; // deceleration already under way
    if d > amax {
        // More deceleration than the next piece allows: ease it to amax first.
        let t = (d - amax) / jr;
        let v1 = v + a * t + jr * t * t / 2.0;
        let d1 = v * t + a * t * t / 2.0 + jr * t * t * t / 6.0;
        return d1 + reach_distance(v1, -amax, w, amax, jmax, jnow, late);
    }
    let v_end = v - d * d / (2.0 * jmax);
    if v_end >= w {
        // The braking from rest acceleration at `virtual_v` passes through (v, a): subtract the
        // part before it.
        let virtual_v = v + d * d / (2.0 * jmax);
        let t = d / jmax;
        let before = virtual_v * t - jmax * t * t * t / 6.0;
        (speed_change(virtual_v, w, amax, jmax).0 - before).max(0.0)
    } else if v_end >= -1e-9 * (1.0 + v) {
        // Easing the deceleration now already ends below the cap: the braking ends there, its
        // acceleration back to 0 (a junction is never crossed still braking hard for it, which
        // the next block's jerk may not be able to end), or up to `late` after that, but not
        // before the speed meets the cap (the first root of v − d t + J t²/2 = w).
        let ended = d / jmax;
        let meets = (d - (d * d - 2.0 * jmax * (v - w)).max(0.0).sqrt()) / jmax;
        let t = (ended - late).max(meets);
        v * t + a * t * t / 2.0 + jmax * t * t * t / 6.0
    } else {
        // Braked too hard already: the speed reaches 0 before the deceleration can be ended.
        // Safe (slow: the motion stops short and starts again): the distance to that halt.
        let disc = (a * a - 2.0 * jmax * v).max(0.0);
        let tau = (-a - disc.sqrt()) / jmax;
        v * tau + a * tau * tau / 2.0 + jmax * tau * tau * tau / 6.0
    }
}

/// How far ahead of the state a junction can bind: at least [`reach_distance`] to any cap
/// `w ≥ 0` (the other arguments the same), so the scan ahead stops beyond it.
///
/// A jerk-limited speed change to `w` takes at most 9/8 of the distance of stopping from the same
/// speed (the most, (4/3)·√(2/3) ≈ 1.089 times, is to a third of it). But where a deceleration
/// is under way, the reach is the braking curve through the state less the part of it already
/// behind, and that ratio does not hold for what is left: with the curve mostly behind, reaching
/// a cap can take far more than stopping (1.29 times on a retract of `schruppen_1` on the
/// Mikron: the scan, stopping at a quarter more, missed the cap, and the steps chattered between
/// braking and easing). So the bound adds an eighth of the whole curve's distance to the reach
/// of stopping (at a constant speed, 9/8 of it).
pub(crate) fn scan_reach(v: f64, a: f64, amax: f64, jmax: f64, jnow: f64) -> f64 {
    let stop = reach_distance(v, a, 0.0, amax, jmax, jnow, 0.0);
    stop + braking_curve_distance(v, a, amax, jmax, jnow) / 8.0
}

/// How the fastest braking to rest from speed `v` and acceleration `a` ends (`|ü| ≤ amax`,
/// `|u⃛| ≤ jmax`, and `jnow` the jerk available to end an ongoing acceleration or ease a
/// deceleration above `amax`): the cases [`reach_distance`] to 0 walks.
enum Braking {
    /// With the whole speed change to rest from `top` at no acceleration, which starts `ahead`
    /// from now: after an acceleration is ended or a deceleration eased to `amax`, or before now
    /// (negative) where a deceleration under way is on its way down that change.
    Curve { top: f64, ahead: f64 },
    /// The speed reaches 0 while the deceleration eases, after `time`.
    Eased { time: f64 },
}

fn braking_curve(v: f64, a: f64, amax: f64, jmax: f64, jnow: f64) -> Braking {
    let jr = jmax.min(jnow);
    if a > 0.0 {
        let t = a / jr;
        return Braking::Curve { top: (v + a * t - jr * t * t / 2.0).max(0.0), ahead: t };
    }
    let d = -a;
    if d > amax {
        let t = (d - amax) / jr;
        return match braking_curve(v + a * t + jr * t * t / 2.0, -amax, amax, jmax, jnow) {
            Braking::Curve { top, ahead } => Braking::Curve { top, ahead: t + ahead },
            Braking::Eased { time } => Braking::Eased { time: t + time },
        };
    }
    if v - d * d / (2.0 * jmax) < 0.0 {
        return Braking::Eased { time: d / jmax };
    }
    Braking::Curve { top: v + d * d / (2.0 * jmax), ahead: -d / jmax }
}

/// The distance of the whole speed change to 0 that [`reach_distance`] to 0 ends with (for a
/// deceleration under way, the braking curve through the state, the part behind included);
/// 0 where it ends with none (the speed reaches 0 while the deceleration eases).
fn braking_curve_distance(v: f64, a: f64, amax: f64, jmax: f64, jnow: f64) -> f64 {
    match braking_curve(v, a, amax, jmax, jnow) {
        Braking::Curve { top, .. } => speed_change(top, 0.0, amax, jmax).0,
        Braking::Eased { .. } => 0.0,
    }
}

/// The time of the fastest jerk-limited braking from speed `v` and acceleration `a` to rest
/// (`|ü| ≤ amax`, `|u⃛| ≤ jmax`), wherever it ends: no motion from that state comes to rest
/// sooner. Where the speed reaches 0 before a deceleration can be eased, the easing's time.
fn braking_time(v: f64, a: f64, amax: f64, jmax: f64) -> f64 {
    match braking_curve(v, a, amax, jmax, jmax) {
        Braking::Curve { top, ahead } => ahead + speed_change(top, 0.0, amax, jmax).1,
        Braking::Eased { time } => time,
    }
}

/// True only where [`reach_distance`] (same arguments) is at most `room`: a test without a root,
/// so that the scan ahead (where most junctions are far from binding) rarely computes the reach
/// itself. The reach is bounded by the top speed of the motion it measures, `v + a²/2J` (what
/// ending a positive acceleration reaches; the speed the braking curve through a deceleration
/// started from), times its duration: ending `|a|` (at most `|a|/J`), then a speed change from
/// the top speed to `w`, whose duration ([`speed_change`]) is inverted into the largest drop of
/// speed the time left allows.
fn surely_reached(room: f64, v: f64, a: f64, w: f64, amax: f64, jmax: f64, jnow: f64) -> bool {
    let jr = jmax.min(jnow);
    let top = v + a * a / (2.0 * jr);
    // The time the room leaves for the speed change, at the top speed throughout.
    let left = room * (1.0 - 1e-9) / top - a.abs() / jr;
    if !(top > 0.0 && left > 0.0) {
        return false;
    }
    // The drop of speed a jerk-limited change covers in `left`: A(t − A/J) once it reaches the
    // acceleration (t ≥ 2A/J), J t²/4 before.
    let drop = if left >= 2.0 * amax / jmax { amax * (left - amax / jmax) } else { jmax * left * left / 4.0 };
    (top - w) * (1.0 + 1e-9) < drop * (1.0 - 1e-9)
}

/// True when a step from `(u, v, a)` at jerk `j` over `h` (ending at speed `v1` and
/// acceleration `a1`) crosses parameter `at` at a speed at most `cap` and stays at most `beyond`
/// (≥ `cap`) from there to its end: the largest speed over that stretch is at one of its ends or
/// where the acceleration passes through 0.
fn crossed_within(
    (cap, beyond): (f64, f64),
    at: f64,
    (u, v, a): (f64, f64, f64),
    j: f64,
    h: f64,
    (v1, a1): (f64, f64),
) -> bool {
    let tau = time_to(u, v, a, j, at, h);
    let speed = |t: f64| advance(u, v, a, j, t).1;
    let crossing = speed(tau);
    let mut top = crossing.max(v1);
    if j < 0.0 && a + j * tau > 0.0 && a1 < 0.0 {
        top = top.max(speed(-a / j));
    }
    crossing <= cap && top <= beyond
}

/// The time within `(0, h]` at which the parameter reaches `target`: Newton on the cubic,
/// kept inside a shrinking bracket (bisection where Newton would leave it).
fn time_to(u: f64, v: f64, a: f64, j: f64, target: f64, h: f64) -> f64 {
    let (mut lo, mut hi) = (0.0, h);
    let mut t = if v > 0.0 { ((target - u) / v).clamp(0.0, h) } else { 0.5 * h };
    for _ in 0..50 {
        let (x, speed, _) = advance(u, v, a, j, t);
        let error = x - target;
        if error < 0.0 {
            lo = t;
        } else {
            hi = t;
        }
        if error.abs() <= 1e-13 * target.abs().max(1.0) || hi - lo <= 1e-15 {
            break;
        }
        let next = t - error / speed;
        t = if speed > 0.0 && next > lo && next < hi { next } else { 0.5 * (lo + hi) };
    }
    t.clamp(0.0, h)
}

/// The time within `(0, h]` at which the speed reaches 0.
fn time_to_rest(v: f64, a: f64, j: f64, h: f64) -> f64 {
    let (mut lo, mut hi) = (0.0, h);
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if advance(0.0, v, a, j, mid).1 > 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    hi
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::profile::Profile;

    /// The samples and the crossings of junctions ((piece, time, speed)) of a motion.
    #[derive(Default)]
    struct Record(Vec<Sample>, Vec<(usize, f64, f64)>);

    impl Observer for Record {
        fn sample(&mut self, sample: &Sample) {
            self.0.push(*sample);
        }
        fn crossing(&mut self, piece: usize, t: f64, v: f64, _: Limit) {
            self.1.push((piece, t, v));
        }
    }

    /// The total time of the motion along `pieces` with the junctions capped at `caps` (the
    /// last an exact stop), and its record.
    fn stepped(pieces: Vec<Piece>, caps: &[f64], h: f64) -> (f64, Record) {
        let limit = |cap: f64| if cap > 0.0 { Limit::Corner } else { Limit::Stop };
        let junctions = caps.iter().map(|&cap| Junction { cap, limit: limit(cap), dwell: 0.0 }).collect();
        let mut record = Record::default();
        let t = run(&Track::new(pieces, junctions, 10, 0.0), h, &mut record);
        (t, record)
    }

    fn piece(length: f64, v: f64, a: f64, j: f64) -> Piece {
        Piece {
            length,
            velocity: v,
            acceleration: a,
            jerk: j,
            velocity_limit: Limit::Programmed,
            acceleration_limit: Limit::Acceleration(0),
            jerk_limit: Limit::Jerk(0),
        }
    }

    fn single(length: f64, v: f64, a: f64, j: f64, h: f64) -> (f64, Vec<Sample>) {
        let (t, record) = stepped(vec![piece(length, v, a, j)], &[0.0], h);
        (t, record.0)
    }

    /// A program of a fortnight at 3 ms (400 M periods, 4 000 blocks of 5 min each, crossed at
    /// speed): the motion is timed whole, not cut short once it has run for a given number of
    /// periods.
    #[test]
    fn a_program_of_many_days_is_timed_whole() {
        /// Takes the cruises in one go and keeps the last sample only.
        struct Last(Option<Sample>);
        impl Observer for Last {
            fn sample(&mut self, sample: &Sample) {
                self.0 = Some(*sample);
            }
            fn crossing(&mut self, _: usize, _: f64, _: f64, _: Limit) {}
            fn every_period(&self) -> bool {
                false
            }
        }
        let (n, length, v, a, j, h) = (4000, 0.3, 0.001, 0.01, 0.1, 0.003);
        let mut junctions = vec![Junction { cap: f64::INFINITY, limit: Limit::Corner, dwell: 0.0 }; n];
        junctions[n - 1] = Junction { cap: 0.0, limit: Limit::Stop, dwell: 0.0 };
        let track = Track::new(vec![piece(length, v, a, j); n], junctions, usize::MAX, 0.0);
        let mut last = Last(None);
        let t = run(&track, h, &mut last);
        let exact = Profile::rest_to_rest(n as f64 * length, v, a, j).duration();
        assert!(exact / h > 4e8, "{} periods", exact / h);
        assert!((t - exact).abs() < 1e-6 * exact, "{t} s against {exact} s");
        assert!(last.0.is_some_and(|s| (s.u - n as f64 * length).abs() < 1e-6), "{:?}", last.0);
    }

    /// A piece that takes more steps than the guard allows (here lowered to 1 000; 10 000
    /// periods taken one by one) is ended at once and counted, not stepped for ever; at the
    /// guard's own bound it is timed.
    #[test]
    fn a_piece_the_stepper_gives_up_on_is_counted() {
        let h = 0.003;
        let (d, v, a, j) = (30.0, 1.0, 100.0, 1000.0);
        let track = || {
            Track::new(vec![piece(d, v, a, j)], vec![Junction { cap: 0.0, limit: Limit::Stop, dwell: 0.0 }], 10, 0.0)
        };
        let exact = Profile::rest_to_rest(d, v, a, j).duration();
        let mut stepper = Stepper::new(h);
        stepper.go(&track(), &mut Record::default());
        assert_eq!(stepper.abandoned(), 0);
        assert!((stepper.time(&track()) - exact).abs() < 1e-3 * exact);
        let mut stepper = Stepper { steps_per_piece: 1000, ..Stepper::new(h) };
        assert_eq!(stepper.go(&track(), &mut Record::default()), Progress::Done);
        assert_eq!(stepper.abandoned(), 1);
        assert!(stepper.time(&track()) < 0.5 * exact);
    }

    #[test]
    fn arrived_at_its_speed_cap_the_motion_cruises_without_chattering() {
        // A drilling feed on the MAHO (50 mm/min on Z: 10 m/s³, 8 ms): the acceleration, under
        // J·h, cannot be ended exactly at the cap by steps of constant jerk. The jerk used to
        // chatter from one step to the next all along the cruise, never settling.
        let (t, samples) = single(1.0, 50.0 / 60.0, 1000.0, 10_000.0, 0.008);
        let jerks: Vec<f64> = samples.iter().map(|s| s.j).filter(|j| *j != 0.0).collect();
        let changes = jerks.windows(2).filter(|w| w[0] * w[1] < 0.0).count();
        assert!(changes <= 3, "{changes} changes of sign of the jerk: {jerks:?}");
        // The time-optimal motion, within the switching error of one period.
        let exact = Profile::rest_to_rest(1.0, 50.0 / 60.0, 1000.0, 10_000.0).duration();
        assert!((t - exact).abs() < 0.008, "{t} s against {exact} s");
    }

    #[test]
    fn one_piece_takes_the_time_optimal_rest_to_rest_motion() {
        // Within 0.1 %, or within one period for a motion of a few periods (a CNC's motion
        // lasts a whole number of them anyway).
        let h = 0.003;
        for &(d, v, a, j) in &[
            (100.0, 500.0, 2500.0, 5000.0),
            (1000.0, 500.0, 2500.0, 5000.0),
            (3.0, 100.0, 10_000.0, 100_000.0),
            (50.0, 83.3, 10_000.0, 100_000.0),
        ] {
            let exact = Profile::rest_to_rest(d, v, a, j).duration();
            let (t, samples) = single(d, v, a, j, h);
            assert!((t - exact).abs() < (1e-3 * exact).max(h), "{d} mm: {t} s against {exact} s");
            let last = samples.last().map_or(0.0, |s| s.u);
            assert!((last - d).abs() < 1e-9);
            for s in &samples {
                assert!(s.v <= v * (1.0 + 1e-9) && s.a.abs() <= a * (1.0 + 1e-9) && s.j.abs() <= j * (1.0 + 1e-9));
            }
        }
    }

    #[test]
    fn the_reach_distance_from_rest_is_the_speed_change() {
        let (amax, jmax) = (2500.0, 5000.0);
        for &(v, w) in &[(500.0, 0.0), (100.0, 20.0), (2000.0, 0.0)] {
            let d = reach_distance(v, 0.0, w, amax, jmax, jmax, 0.0);
            assert!((d - speed_change(v, w, amax, jmax).0).abs() < 1e-9);
        }
    }

    #[test]
    fn braking_under_way_needs_less_distance_than_braking_from_cruise() {
        let (amax, jmax) = (2500.0, 5000.0);
        let from_cruise = reach_distance(400.0, 0.0, 0.0, amax, jmax, jmax, 0.0);
        let under_way = reach_distance(400.0, -1000.0, 0.0, amax, jmax, jmax, 0.0);
        assert!(under_way < from_cruise);
        // Following a braking profile (reaching the acceleration cap), the remaining distance
        // and time are what they say.
        let p = Profile::rest_to_rest(1000.0, 400.0, amax, jmax);
        let t_end = p.duration();
        for k in 1..40 {
            let t = t_end - 0.01 * k as f64;
            let s = p.at(t);
            if s.a < 0.0 {
                let d = reach_distance(s.v, s.a, 0.0, amax, jmax, jmax, 0.0);
                assert!((d - (1000.0 - s.s)).abs() < 1e-6, "at {t}: {d} vs {}", 1000.0 - s.s);
                let left = braking_time(s.v, s.a, amax, jmax);
                assert!((left - (t_end - t)).abs() < 1e-9, "at {t}: {left} s vs {}", t_end - t);
            }
        }
    }

    #[test]
    fn the_braking_time_ends_an_acceleration_first_and_eases_a_braking_too_hard() {
        let (amax, jmax) = (2500.0, 5000.0);
        // Accelerating, it ends the acceleration first; braked too hard, it eases the deceleration.
        assert!((braking_time(0.0, 100.0, amax, jmax) - (0.02 + speed_change(1.0, 0.0, amax, jmax).1)).abs() < 1e-12);
        assert!((braking_time(0.1, -1000.0, amax, jmax) - 0.2).abs() < 1e-12);
    }

    /// A drilling feed's move on the MAHO (and the worst case of the proptest below, the
    /// acceleration built in one period): steps constant in jerk, a step late in the braking,
    /// reached the stop with speed left and took it at once, 2.7 ms (and 20.6 ms, 6.9 periods)
    /// sooner than the time-optimal motion.
    #[test]
    fn a_stop_comes_no_sooner_than_the_time_optimal_motion() {
        for (d, v, a, j, h) in
            [(1.0, 50.0 / 60.0, 1000.0, 10_000.0, 0.008), (29.438_545, 426.049_419, 110.657_546, 36_885.848_582, 0.003)]
        {
            let exact = Profile::rest_to_rest(d, v, a, j).duration();
            let (t, _) = single(d, v, a, j, h);
            assert!(t >= exact - 1e-9 && t < exact + h, "{t} s against {exact} s");
        }
    }

    /// Crossings of a two-piece track with a corner capped at `w` ((piece, time, speed)), and
    /// its total time.
    fn corner(d: f64, v: f64, a: f64, j: f64, w: f64, h: f64) -> (f64, Vec<(usize, f64, f64)>) {
        let (t, record) = stepped(vec![piece(d, v, a, j); 2], &[w, 0.0], h);
        (t, record.1)
    }

    /// A braking that halts short of a stop takes the rest as a braking's final phase only where
    /// that phase keeps the piece's caps, and starts again from rest elsewhere. Here (the
    /// acceleration built in one period, a corner crossed above its cap) the halt came 0.09 mm
    /// short, the whole second piece, under 10 J h³ (0.3 mm): taken as the end of a braking, it
    /// was covered in 7.9 ms at 11 mm/s, the cap 1.7 mm/s.
    #[test]
    fn a_motion_halted_short_of_a_stop_covers_the_rest_within_its_caps() {
        let (d, v, a, j, w, h) = (0.090_127_53, 1.695_949, 3_325.128_5, 1_108_376.2, 0.832_057_8, 0.003);
        let (t, crossings) = corner(d, v, a, j, w, h);
        let (_, at_corner, _) = crossings[0];
        assert!(t - at_corner >= d / v, "{} s for {d} mm at {v} mm/s at most", t - at_corner);
        // Against the same track stepped at a 64th of the period (1.2 % slower).
        let (fine, _) = corner(d, v, a, j, w, h / 64.0);
        assert!((t - fine).abs() < h, "{t} s against {fine} s");
    }

    /// A corner's cap holds where the motion crosses it; past it the next piece's caps do. The
    /// step that crossed a corner used to keep the speed under its cap to the step's end, so the
    /// motion out of it began a period late: at 8 ms about two periods over the same track
    /// stepped at a 64th of the period (0.3492 s against 0.3333 s, 0.4369 s against 0.4240 s).
    #[test]
    fn a_corners_cap_holds_at_the_corner_and_the_next_pieces_caps_beyond() {
        let h = 0.008;
        for (d, v, a, j, w) in [(10.0, 100.0, 2500.0, 41_667.0, 50.0), (5.0, 200.0, 1000.0, 10_000.0, 20.0)] {
            let (t, crossings) = corner(d, v, a, j, w, h);
            let (fine, _) = corner(d, v, a, j, w, h / 64.0);
            assert!((t - fine).abs() < 0.5 * h, "{t} s against {fine} s");
            assert!(crossings[0].2 <= w, "crossed at {} for a cap of {w}", crossings[0].2);
        }
    }

    /// A fixed pseudo-random sequence in [0, 1) from `seed` (xorshift).
    fn uniform(mut seed: u64) -> impl FnMut() -> f64 {
        move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64
        }
    }

    /// Pieces as a spline's: short, their limits each different (their speed caps in every
    /// other stretch of 300, else a few), a corner or a stop now and then (a fixed
    /// pseudo-random sequence).
    fn uneven_track(n: usize, window: usize) -> Track {
        let mut next = uniform(0x2545_f491_4f6c_dd1d);
        let mut pieces = Vec::with_capacity(n);
        let mut junctions = Vec::with_capacity(n);
        for i in 0..n {
            // Stretches where the pieces have the same speed cap but a few a hair under it (the
            // motion cruises, then eases a little), and stretches where each has its own.
            let speed = match next() {
                _ if (i / 300) % 2 == 1 => 50.0 * (0.97 + 0.03 * next()),
                x if x < 0.003 => 49.5 + 0.5 * next(),
                _ => 50.0,
            };
            let length = if (i / 300) % 2 == 1 { 0.01 + 0.04 * next() } else { 0.05 + 0.1 * next() };
            let mut p = piece(length, speed, 0.0, 0.0);
            p.acceleration = 200.0 + 2300.0 * next();
            p.jerk = 1000.0 + 4000.0 * next();
            pieces.push(p);
            let cap = match next() {
                x if x < 0.0005 || i + 1 == n => 0.0,
                x if x < 0.003 => 20.0 + 25.0 * next(),
                _ => f64::INFINITY,
            };
            let limit = if cap == 0.0 { Limit::Stop } else { Limit::Corner };
            junctions.push(Junction { cap, limit, dwell: 0.0 });
        }
        Track::new(pieces, junctions, window, 0.0)
    }

    /// Every sample and crossing, as they come.
    #[derive(Default, PartialEq, Debug)]
    struct Everything(Vec<Sample>, Vec<(usize, f64, f64, Limit)>);

    impl Observer for Everything {
        fn sample(&mut self, sample: &Sample) {
            self.0.push(*sample);
        }
        fn crossing(&mut self, piece: usize, t: f64, v: f64, limit: Limit) {
            self.1.push((piece, t, v, limit));
        }
        fn every_period(&self) -> bool {
            false
        }
    }

    #[test]
    fn passing_over_runs_of_junctions_changes_no_step_and_saves_most_of_the_scan() {
        // The runs are a shortcut of the scan ahead: the motion must be the one the scan of each
        // junction chooses, to the last bit, with or without a look-ahead window.
        // A period short enough for the motion to cruise over a piece.
        const H: f64 = 0.0002;
        for window in [usize::MAX, 200] {
            let track = uneven_track(6000, window);
            let mut by_runs = Everything::default();
            work::take();
            let time = run(&track, H, &mut by_runs);
            let [_, scanned_by_runs, _] = work::take();
            work::ONE_BY_ONE.with(|c| c.set(true));
            let mut one_by_one = Everything::default();
            let time_one_by_one = run(&track, H, &mut one_by_one);
            work::ONE_BY_ONE.with(|c| c.set(false));
            let [_, scanned_one_by_one, _] = work::take();
            assert_eq!(time, time_one_by_one);
            assert!(by_runs == one_by_one, "window {window}: the motions differ");
            assert!(
                scanned_by_runs * 3 < scanned_one_by_one,
                "window {window}: {scanned_by_runs} junctions and runs examined, {scanned_one_by_one} one by one"
            );
        }
    }

    /// A finishing pass without a stop before its end (pieces of 0.1 at 50, limits in the
    /// thousands, a corner now and then) with, every 500 pieces, a rotary linking move: a few
    /// pieces whose caps tighten step by step to a fraction of a unit/s² (a fixed pseudo-random
    /// sequence).
    fn linked_track(n: usize, window: usize) -> Track {
        let mut next = uniform(0x1234_5678_9abc_def1);
        let mut pieces = Vec::with_capacity(n);
        let mut junctions = Vec::with_capacity(n);
        for i in 0..n {
            let link = i % 500;
            let p = if (200..208).contains(&link) {
                let tight = 1.0 + (207 - link) as f64;
                piece(0.05, 0.3 * tight, 0.5 * tight, 3.0 * tight)
            } else {
                piece(0.1, 50.0, 2000.0 + 500.0 * next(), 4000.0 + 1000.0 * next())
            };
            pieces.push(p);
            let cap = match next() {
                _ if i + 1 == n => 0.0,
                x if x < 0.01 => 20.0 + 25.0 * next(),
                _ => f64::INFINITY,
            };
            let limit = if cap == 0.0 { Limit::Stop } else { Limit::Corner };
            junctions.push(Junction { cap, limit, dwell: 0.0 });
        }
        Track::new(pieces, junctions, window, 0.0)
    }

    #[test]
    fn past_a_piece_of_tight_limits_the_motion_needs_the_track_only_a_little_ahead() {
        // Without a window, the scan ahead used to take the tight pieces' limits for the braking
        // from the speed before them: a reach of metres, and a streamed prediction held the
        // whole track to its end. The motion is the same streamed and whole, by runs and one
        // by one.
        const H: f64 = 0.001;
        let n = 5000;
        let whole = linked_track(n, usize::MAX);
        let mut by_runs = Everything::default();
        let time = run(&whole, H, &mut by_runs);
        work::ONE_BY_ONE.with(|c| c.set(true));
        let mut one_by_one = Everything::default();
        let time_one_by_one = run(&whole, H, &mut one_by_one);
        work::ONE_BY_ONE.with(|c| c.set(false));
        assert_eq!(time, time_one_by_one);
        assert!(by_runs == one_by_one, "the motions differ");
        let mut builder = TrackBuilder::new(usize::MAX);
        let mut stepper = Stepper::new(H);
        let mut streamed = Everything::default();
        let mut held = 0;
        for block in 0..n {
            // The junction before the piece.
            let j = block.checked_sub(1).map_or(whole.junctions[0], |before| whole.junctions[before]);
            builder.push(whole.pieces[block], block, j.cap, j.limit, true);
            assert_eq!(stepper.go(&builder.track, &mut streamed), Progress::Waiting);
            held = held.max(builder.len() - stepper.piece());
        }
        builder.complete();
        assert_eq!(stepper.go(&builder.track, &mut streamed), Progress::Done);
        assert_eq!(stepper.time(&builder.track), time);
        assert!(streamed == by_runs, "streamed, the motion differs");
        // Fewer than the 500 pieces from one link to the next (the old scan: 4 864).
        assert!(held < 500, "{held} pieces held ahead of the motion, of {n}");
    }

    /// Steps the track of `pieces` ending in corners capped at `caps` (a look-ahead of `window`
    /// pieces) at period `h`, and asserts that every junction is crossed at most `over` above its
    /// cap.
    fn every_corner_cap_holds(pieces: Vec<Piece>, caps: &[f64], window: usize, h: f64, over: f64) {
        let junctions = caps.iter().map(|&cap| Junction { cap, limit: Limit::Corner, dwell: 0.0 }).collect();
        let track = Track::new(pieces, junctions, window, 0.0);
        let mut motion = Everything::default();
        run(&track, h, &mut motion);
        for &(junction, _, v, _) in &motion.1 {
            let (cap, _) = track.junction_cap(junction);
            assert!(v <= cap * (1.0 + over), "junction {junction} crossed at {v} for a cap of {cap}");
        }
    }

    /// `manta-5axis` on the MAHO in B-spline mode, the corner at 9.81 s: loose pieces (1 083 of
    /// acceleration, 10 700 of jerk) end in a corner capped at 41.7, then one piece of a fifth of
    /// their acceleration and jerk ends in a corner capped at 0.467. The motion comes to that
    /// piece still braking harder than it allows; the braking planned as if it could ease that
    /// deceleration there at leisure crossed the corner at 20.1, 43 times its cap. Cut where the
    /// piece starts, as the steps cut it, every cap holds.
    #[test]
    fn a_deceleration_is_planned_cut_where_pieces_of_tighter_limits_start() {
        let mut pieces = vec![piece(0.996, 120.0, 1083.0, 10_700.0); 20];
        let mut caps = vec![115.0; 20];
        caps[19] = 41.7;
        pieces.push(piece(0.996, 120.0, 198.2, 1982.5));
        caps.push(0.467);
        pieces.extend([piece(0.498, 120.0, 74.0, 739.8); 6]);
        caps.extend([6.85, 6.81, 6.78, 6.76, 6.75, 0.0]);
        every_corner_cap_holds(pieces, &caps, usize::MAX, 0.008, 1e-2);
    }

    /// `kuka-fdm/1001` on the Mikron in B-spline mode, the corner at 49.59 s: pieces of 2 500 of
    /// acceleration and 5 000 of jerk, then 0.33 mm of pieces of a twentieth of that (132 to 390,
    /// 530) and a short one ending in a corner capped at 9.23. The braking planned for that
    /// corner with the tight pieces' limits throughout found no jerk that fits, and the best of
    /// them eased the deceleration step after step: the corner was crossed at 9.81, 1.063 times
    /// its cap. Late, the motion now never eases, and every cap holds.
    #[test]
    fn a_motion_late_for_a_cap_never_eases_its_braking() {
        let mut pieces = vec![piece(0.392, 29.6, 2524.0, 5049.0); 10];
        let mut caps = vec![14.82; 10];
        pieces.extend(
            [132.1, 150.4, 174.5, 207.8, 256.9, 283.0, 309.8, 345.5, 390.3].map(|a| piece(0.037, 14.01, a, 530.0)),
        );
        caps.extend([14.01; 9]);
        pieces.push(piece(0.006, 14.01, 1154.0, 1609.6));
        caps.push(9.234);
        pieces.extend([
            piece(0.08, 9.234, 319.0, 525.6),
            piece(0.084, 9.234, 142.1, 527.1),
            piece(0.044, 9.234, 110.3, 533.2),
        ]);
        caps.extend([9.234, 9.234, 14.43]);
        pieces.extend([piece(0.4, 29.6, 2524.0, 5049.0); 4]);
        caps.extend([14.82, 14.82, 14.82, 0.0]);
        every_corner_cap_holds(pieces, &caps, usize::MAX, 0.003, 1e-3);
    }

    /// `finition2.ncl` on the Mikron in inverse time, the corner of block 31 901: pieces of
    /// 0.0084 (programmed seconds) at 0.30 of the feed, a look-ahead of ten blocks, and a corner
    /// capped at 0.092, near a third of the speed, where braking with the deceleration ended takes
    /// up to 9 % more room than stopping. Met as the window's end by a stop alone, the corner was
    /// crossed at 1.094 times its cap once the window moved past it; now the window's end meets
    /// its own cap too.
    #[test]
    fn the_window_s_end_meets_its_own_cap_as_well_as_a_stop() {
        let n = 40;
        let pieces = vec![piece(0.0084, 0.30, 1.81, 3.02); n];
        let mut caps = vec![f64::INFINITY; n];
        caps[20] = 0.0924;
        caps[n - 1] = 0.0;
        every_corner_cap_holds(pieces, &caps, 10, 0.003, 1e-3);
    }

    /// Into pieces of far tighter limits (a rotary linking move), the motion comes still braking
    /// harder than they allow. Planned as if that deceleration could be eased on them at leisure,
    /// the second link's first tight corner was crossed at 2.25 for a cap of 2.1, and the fifth
    /// link's last at 1.98 for a cap of 0.3; cut where they start ([`cut_short`]), every cap
    /// holds.
    #[test]
    fn past_pieces_of_far_tighter_limits_every_cap_holds() {
        let track = linked_track(5000, usize::MAX);
        let mut motion = Everything::default();
        run(&track, 0.001, &mut motion);
        for &(junction, _, v, _) in &motion.1 {
            let (cap, _) = track.junction_cap(junction);
            assert!(v <= cap * (1.0 + 1e-5), "junction {junction} crossed at {v} for a cap of {cap}");
        }
    }

    /// A step that stays on its piece brakes with that piece's jerk, as the scan ahead plans the
    /// braking to the corner; only the step that crosses takes the next piece's. Every step that
    /// might cross into a piece of tighter jerk used to take it for the whole period, and a
    /// braking planned to end within the last periods could not: the corner was crossed above
    /// its cap (here at 0.355, 0.289 and 0.224 for caps of 0.043, 0.1 and 0.05), and the first
    /// track, modelled on a plunge in `shimemcunha.apt` on the MAHO (inverse time), took 45 ms
    /// more than stepped at a 64th of the period (now 6 ms). Where the braking's last phase is
    /// shorter than a period the motion may still halt at the corner and start again (3 of the
    /// 5 tracks; 5 to 96 ms more than the finer stepping): the known limit of steps that cannot
    /// switch their jerk within the period (docs/validation.md).
    #[test]
    fn into_a_piece_of_tighter_jerk_the_corner_is_crossed_within_its_cap() {
        let (h, a, j) = (0.008, 480.0, 4800.0);
        let tracks = [(0.043_403, 35.0), (0.2, 10.0), (0.1, 30.0), (0.3, 100.0), (0.05, 5.0)];
        for (i, (w, tighter)) in tracks.into_iter().enumerate() {
            let pieces = vec![piece(1.679, 1.0, a, j), piece(0.72, 1.0, a / tighter, j / tighter)];
            let (t, record) = stepped(pieces.clone(), &[w, 0.0], h);
            let (fine, _) = stepped(pieces, &[w, 0.0], h / 64.0);
            let (_, _, crossed) = record.1[0];
            assert!(crossed <= w * (1.0 + 1e-9), "cap {w}: crossed at {crossed}");
            assert!(t >= fine, "cap {w}: {t} s against {fine} s stepped finer");
            // The plunge it is modelled on: within two periods of the finer stepping.
            if i == 0 {
                assert!(t - fine < 2.0 * h, "cap {w}: {t} s against {fine} s stepped finer");
            }
        }
    }

    /// Inverse time (`u` = programmed time): a plunge at F1.5 into a block at F2000, modelled on
    /// `peening.aptsource` on the MAHO (8 ms). On the plunge the parameter's limits are those of
    /// a crawl: braking to the corner takes well under a millisecond (the first three tracks), or
    /// a few periods with the deceleration built in a fraction of one (the last). Steps of
    /// constant jerk over the period could not follow either: the corner was crossed at 0.98
    /// for caps of 0.005, 0.05 and 0.0005 (for the first two 80 ms sooner than the finer
    /// stepping; at a 64th of the period the third crossed its corner so too), and at 0.20 for
    /// 0.01. Taken in sub-steps ([`SPLIT`]), the motion meets each cap, 2 to 6 ms slower
    /// than stepped at a 64th of the period (it halts at the corner where the finer stepping
    /// crosses it slowly).
    #[test]
    fn out_of_a_slow_block_a_braking_shorter_than_a_period_meets_the_corner() {
        let h = 0.008;
        for (w, a, j) in [(0.005, 1e4, 1e7), (0.05, 1e3, 1e6), (0.0005, 1e5, 1e9), (0.01, 50.0, 1e5)] {
            let pieces = vec![piece(1.0, 1.0, a, j), piece(0.01, 0.1, 50.0, 5000.0)];
            let (t, record) = stepped(pieces.clone(), &[w, 0.0], h);
            let (fine, _) = stepped(pieces, &[w, 0.0], h / 64.0);
            let (_, _, crossed) = record.1[0];
            assert!(crossed <= w * (1.0 + 1e-2), "cap {w}: crossed at {crossed}");
            assert!(t >= fine, "cap {w}: {t} s against {fine} s stepped finer");
            assert!(t - fine < 2.0 * h, "cap {w}: {t} s against {fine} s stepped finer");
        }
    }

    /// A spline's pieces at the programmed feed have speed caps a few 1e-10 apart (the tip's
    /// rate along the parameter, near 1). A step that crosses into a piece whose cap is a hair
    /// under the speed ends under it but crosses above it, earlier in the step: it took the
    /// strongest braking, a dip of J·h²/2 and more (`nurbs.clsf` on the MAHO, 8 ms, in B-spline
    /// mode: 2 933.65 s, +3.6 % on the same stepped at 0.5 ms, 2 830.67 s). So did a corner
    /// whose cap is a hair under the speed (Creo's `schruppen_1` on the MAHO: +2.65 %). It now
    /// takes the jerk that meets the cap at the crossing (with this alone, `nurbs.clsf` 2 830.88 s
    /// and Creo +0.5 %). Here, on pieces' own caps, the speed dipped 19 % and the time was 3.3 %
    /// over the finer stepping's; now the speed stays within a millionth of the caps and the time
    /// within a period. Past corners
    /// up to 0.5 % under the speed it dipped 24 % and took 6.2 % longer; now the step that
    /// crosses a corner goes on braking past it (constant jerk over the period) and dips up to
    /// 4.4 %, 0.4 % longer than the finer stepping.
    #[test]
    fn a_cap_a_hair_under_the_speed_is_met_without_a_dip() {
        let h = 0.008;
        let mut next = uniform(7);
        let feed = 250.0 / 60.0;
        let n = 200;
        // The pieces' own caps 5e-10 apart, no corners; then pieces at the feed and corners up
        // to 0.5 % under it (within the steps' rounding, [`SPLIT_OVER`]). The largest dip under
        // the lowest cap and the largest difference of time from the finer stepping's allowed.
        let own: Vec<f64> = (0..n).map(|_| feed * (1.0 + 5e-10 * (2.0 * next() - 1.0))).collect();
        let corners: Vec<f64> = (0..n - 1).map(|_| feed * (1.0 - 5e-3 * next())).collect();
        for (speeds, caps, dip_within, time_within) in
            [(own, vec![f64::INFINITY; n - 1], 1e-6, h), (vec![feed; n], corners, 0.05, 0.005 * 8.68)]
        {
            let pieces: Vec<Piece> = speeds.iter().map(|&v| piece(0.18, v, 1263.0, 12_600.0)).collect();
            let lowest = speeds.iter().chain(&caps).fold(f64::INFINITY, |m, &c| m.min(c));
            let caps = [caps, vec![0.0]].concat();
            let (t, record) = stepped(pieces.clone(), &caps, h);
            let (fine, _) = stepped(pieces, &caps, h / 16.0);
            // Past the acceleration from rest, before the braking into the stop.
            let cruise = record.0.iter().filter(|s| s.t > 0.2 && s.t < t - 0.2);
            let dip = cruise.map(|s| s.v).fold(f64::INFINITY, f64::min);
            assert!(dip >= lowest * (1.0 - dip_within), "dipped to {dip} under caps down to {lowest}");
            assert!((t - fine).abs() < time_within, "{t} s against {fine} s stepped finer");
        }
    }

    /// At a jump of the slack (a cap the motion would pass as its acceleration ends), the
    /// largest jerk that fits is the jump, found in two evaluations where the search halves the
    /// interval to its tolerance; elsewhere (no jump there, a jump that does not fit, a slope)
    /// the search's own answer.
    #[test]
    fn the_largest_jerk_that_fits_is_found_at_a_jump_in_two_evaluations() {
        fn counted(slack: fn(f64) -> f64, evaluations: &std::cell::Cell<u32>) -> impl Fn(f64) -> f64 + '_ {
            move |j: f64| {
                evaluations.set(evaluations.get() + 1);
                slack(j)
            }
        }
        let step: fn(f64) -> f64 = |j| if j <= 1234.5 { 0.8 - 1e-4 * j } else { -9.0 };
        let slope: fn(f64) -> f64 = |j| 0.5 - 1e-3 * j;
        let (lo, hi) = (-4000.0, 4000.0);
        let tolerance = fitting_tolerance(lo, hi);
        for (name, slack, jump, at_jump) in [
            ("the jump", step, Some(1234.5), true),
            ("a point under the jump", step, Some(1000.0), false),
            ("a point above the jump", step, Some(2000.0), false),
            ("a slope", slope, Some(300.0), false),
            ("no jump", step, None, false),
        ] {
            let (searched, near) = (std::cell::Cell::new(0), std::cell::Cell::new(0));
            let search = counted(slack, &searched);
            let expected = largest_fitting(&search, (lo, slack(lo)), (hi, slack(hi)));
            let found = largest_fitting_near(&counted(slack, &near), jump, (lo, slack(lo)), (hi, slack(hi)));
            assert!(slack(found) >= 0.0, "{name}: {found} does not fit");
            if at_jump {
                assert_eq!((found, near.get()), (1234.5, 2), "{name}");
                assert!(expected <= found && found - expected <= tolerance, "{name}: {expected} against {found}");
                assert!(searched.get() >= 25, "{name}: the search took {} evaluations", searched.get());
            } else {
                assert_eq!(found.to_bits(), expected.to_bits(), "{name}");
            }
        }
    }

    #[test]
    fn a_cap_far_ahead_is_surely_reached_and_a_near_one_is_not_taken_for_it() {
        // Cruising at 50 towards caps a little lower: the reach itself is a fraction of a
        // millimetre; the test is conservative, but not by more than half of it.
        let (amax, jmax) = (2500.0, 5000.0);
        for w in [40.0, 45.0, 49.0, 49.9] {
            let reach = reach_distance(50.0, 0.0, w, amax, jmax, jmax, 0.0);
            assert!(surely_reached(1.5 * reach, 50.0, 0.0, w, amax, jmax, jmax), "cap {w}: reach {reach}");
            assert!(!surely_reached(0.99 * reach, 50.0, 0.0, w, amax, jmax, jmax), "cap {w}: reach {reach}");
        }
    }

    proptest::proptest! {
        /// The test without a root never says a cap is reached in time with less room than the
        /// reach (it grows with the room, so this is every room it could be wrong about).
        #[test]
        fn surely_reached_is_never_wrong(
            v in 0.0..2000.0_f64,
            a in proptest::prop_oneof![proptest::strategy::Just(0.0), -5000.0..5000.0_f64],
            lower in proptest::prop_oneof![0.0..1.0_f64, 0.99..1.0_f64],
            amax in 1.0..10_000.0_f64,
            jmax in 1.0..1e6_f64,
            jnow in 1.0..1e6_f64,
            short in proptest::prop_oneof![0.0..0.999_999_f64, 0.99..0.999_999_f64],
        ) {
            // A cap under the speed: one above it needs no room.
            let w = v * lower;
            let reach = reach_distance(v, a, w, amax, jmax, jnow, 0.0);
            proptest::prop_assert!(!surely_reached(reach * short, v, a, w, amax, jmax, jnow), "reach {}", reach);
        }

        /// No single move ends sooner than the time-optimal motion, wherever the acceleration
        /// builds in one period or in fifty.
        #[test]
        fn no_move_ends_sooner_than_the_time_optimal_motion(
            length in 0.01..50.0_f64,
            v in 1.0..500.0_f64,
            amax in 100.0..5000.0_f64,
            ramp in proptest::prop_oneof![1.0..2.0_f64, 2.0..10.0_f64, 10.0..50.0_f64],
        ) {
            let h = 0.003;
            let jmax = amax / (ramp * h);
            let exact = Profile::rest_to_rest(length, v, amax, jmax).duration();
            let (t, _) = single(length, v, amax, jmax, h);
            proptest::prop_assert!(t >= exact * (1.0 - 1e-12), "{} s against {} s", t, exact);
        }

        /// No piece of a track with a corner is covered faster than its speed cap allows,
        /// wherever the acceleration builds in one period or in fifty.
        #[test]
        fn no_piece_is_covered_faster_than_its_speed_cap(
            length in proptest::prop_oneof![0.01..0.2_f64, 0.2..20.0_f64],
            v in proptest::prop_oneof![1.0..10.0_f64, 10.0..500.0_f64],
            amax in 100.0..5000.0_f64,
            ramp in proptest::prop_oneof![1.0..2.0_f64, 2.0..10.0_f64, 10.0..50.0_f64],
            share in 0.0..1.0_f64,
        ) {
            let h = 0.003;
            let (t, crossings) = corner(length, v, amax, amax / (ramp * h), v * share, h);
            let at_corner = crossings[0].1;
            let least = length / v * (1.0 - 1e-9);
            proptest::prop_assert!(at_corner >= least && t - at_corner >= least, "{} and {} s, {} s at least", at_corner, t - at_corner, least);
        }

        /// No cap is reached farther ahead than where the scan ahead stops looking.
        #[test]
        fn no_cap_binds_beyond_the_scan(
            v in 0.0..2000.0_f64,
            a in proptest::prop_oneof![proptest::strategy::Just(0.0), -5000.0..5000.0_f64],
            lower in proptest::prop_oneof![0.0..1.0_f64, 0.2..0.5_f64],
            amax in 1.0..10_000.0_f64,
            jmax in 1.0..1e6_f64,
            jnow in 1.0..1e6_f64,
        ) {
            let w = v * lower;
            let reach = reach_distance(v, a, w, amax, jmax, jnow, 0.0);
            let scanned = scan_reach(v, a, amax, jmax, jnow);
            proptest::prop_assert!(reach <= scanned + 1e-12 * scanned.abs(), "reach {} beyond the scan's {}", reach, scanned);
        }

        /// No cap is reached farther ahead than where the scan ahead stops looking, with a
        /// deceleration cut where pieces of tighter limits start ([`cut_short`]) too.
        #[test]
        fn a_cut_deceleration_binds_within_the_scan(
            v in proptest::prop_oneof![-1.0..0.0_f64, 0.0..2000.0_f64],
            a in -5000.0..0.0_f64,
            lower in proptest::prop_oneof![0.0..1.0_f64, 0.2..0.5_f64],
            amax in 1.0..10_000.0_f64,
            jmax in 1.0..1e6_f64,
            jnow in 1.0..1e6_f64,
            cut in proptest::prop_oneof![0.0..0.1_f64, 0.0..100.0_f64],
        ) {
            let w = v * lower;
            let reach = reach_distance_cut(v, a, w, (amax, jmax, jnow), 0.0, cut);
            let scanned = scan_reach_cut(v, a, (amax, jmax, jnow), cut);
            proptest::prop_assert!(reach <= scanned + 1e-12 * scanned.abs(), "reach {} beyond the scan's {}", reach, scanned);
        }
    }

    #[test]
    fn a_cap_reached_late_in_a_braking_under_way_is_in_the_scan() {
        // The retract of `schruppen_1` on the Mikron, in programmed time (block 3007 and its
        // junction into the retract): half way down a braking, reaching the cap needs 1.29 times
        // the room of stopping.
        let (v, a, amax, jmax, w) = (0.539_658, -11.155_729, 136.122_294, 272.244_587, 0.272_245);
        let stop = reach_distance(v, a, 0.0, amax, jmax, jmax, 0.0);
        let to_cap = reach_distance(v, a, w, amax, jmax, jmax, 0.0);
        assert!(to_cap > 1.25 * stop, "{to_cap} against {stop}");
        assert!(to_cap <= scan_reach(v, a, amax, jmax, jmax));
    }

    #[test]
    fn a_braking_for_a_cap_eases_into_it_without_chattering() {
        // The end of the same pass as a track (Mikron, 3 ms, programmed time): a corner at 0.78
        // of the feed, two short blocks, the second ending in a cap of 0.272 where the retract
        // starts, the retract to a stop. The motion comes out of the corner still braking.
        let pieces = vec![
            piece(0.3, 1.0, 148.459_424, 296.918_849),
            piece(0.030_703, 1.0, 148.459_424, 296.918_849),
            piece(0.027_077, 1.0, 136.122_294, 272.244_587),
            piece(0.338_789, 1.0, 105.557_424, 251.327_200),
        ];
        let junction = |cap, limit| Junction { cap, limit, dwell: 0.0 };
        let junctions = vec![
            junction(0.777_697, Limit::Corner),
            junction(0.777_697, Limit::Corner),
            junction(0.272_245, Limit::Plunge),
            junction(0.0, Limit::Stop),
        ];
        let mut record = Record::default();
        run(&Track::new(pieces, junctions, 10, 0.0), 0.003, &mut record);
        // Into the retract at its cap, not far under it (a braking that had to end its easing
        // before the junction crossed at 0.143: overshooting the braking curve by a step, it
        // braked harder and harder to ease in ever less room).
        let into_retract = record.1.iter().find(|c| c.0 == 2).map(|c| c.2);
        assert!(into_retract.is_some_and(|v| v > 0.9 * 0.272_245), "crossed at {into_retract:?}");
        // On the block before the retract the jerk brakes, then eases: it changes sign at
        // most twice.
        let jerks: Vec<f64> = record.0.iter().filter(|s| s.piece == 2).map(|s| s.j).collect();
        let changes = jerks.windows(2).filter(|w| w[0] * w[1] < 0.0).count();
        assert!(changes <= 2, "{changes} changes of sign: {jerks:?}");
    }

    #[test]
    fn a_streamed_track_is_scanned_no_more_than_a_whole_one() {
        // 4000 pieces of 0.01: braking from 50 reaches over about a thousand of them. Streamed one
        // piece at a time, a step waiting for the junctions ahead must not scan them all again
        // at each piece added (once again at most, when the step waited).
        let (n, h) = (4000, 0.003);
        let p = piece(0.01, 50.0, 2500.0, 5000.0);
        let mut junctions = vec![Junction { cap: f64::INFINITY, limit: Limit::Corner, dwell: 0.0 }; n];
        junctions[n - 1] = Junction { cap: 0.0, limit: Limit::Stop, dwell: 0.0 };
        work::take();
        let whole = run(&Track::new(vec![p; n], junctions, usize::MAX, 0.0), h, &mut Record::default());
        let [_, whole_work, _] = work::take();
        let mut builder = TrackBuilder::new(usize::MAX);
        let mut stepper = Stepper::new(h);
        let mut record = Record::default();
        for block in 0..n {
            builder.push(p, block, f64::INFINITY, Limit::Corner, true);
            assert_eq!(stepper.go(&builder.track, &mut record), Progress::Waiting);
        }
        builder.complete();
        assert_eq!(stepper.go(&builder.track, &mut record), Progress::Done);
        let [_, streamed_work, _] = work::take();
        assert_eq!(stepper.time(&builder.track), whole);
        assert!(
            streamed_work as f64 <= 2.0 * whole_work as f64,
            "{streamed_work} junctions examined streamed, {whole_work} whole"
        );
    }

    #[test]
    fn a_cruise_over_pieces_of_one_cap_is_taken_at_once_as_its_steps_would_go() {
        // 3000 pieces of 1.5 to 3 at one speed cap (a few periods each), their other limits each
        // different, a corner every thousand: the cruises between the corners cross hundreds of
        // junctions (a handful at a time with a look-ahead of 10 pieces). Taken at once they must
        // be the motion of the steps taken one by one (the crossings the same, their times to
        // the rounding), in fewer steps than half the pieces (two a piece at least, were each
        // crossing a step of its own).
        let (n, h) = (3000, 0.003);
        let mut next = uniform(0x9e37_79b9_7f4a_7c15);
        let mut pieces = Vec::with_capacity(n);
        let mut junctions = Vec::with_capacity(n);
        for i in 0..n {
            pieces.push(piece(1.5 + 1.5 * next(), 50.0, 2000.0 + 500.0 * next(), 4000.0 + 2000.0 * next()));
            let cap = match i {
                _ if i + 1 == n => 0.0,
                _ if i % 1000 == 999 => 20.0,
                _ => f64::INFINITY,
            };
            let limit = if cap == 0.0 { Limit::Stop } else { Limit::Corner };
            junctions.push(Junction { cap, limit, dwell: 0.0 });
        }
        for window in [usize::MAX, 10] {
            let track = Track::new(pieces.clone(), junctions.clone(), window, 0.0);
            work::take();
            let mut each_period = Record::default();
            let time_each_period = run(&track, h, &mut each_period);
            let [steps_each_period, _, _] = work::take();
            let mut at_once = Everything::default();
            let time_at_once = run(&track, h, &mut at_once);
            let [steps_at_once, _, _] = work::take();
            assert!(
                (time_at_once - time_each_period).abs() < 1e-9,
                "window {window}: {time_at_once} s, {time_each_period} s"
            );
            assert_eq!(at_once.1.len(), each_period.1.len(), "window {window}: crossings");
            for (once, each) in at_once.1.iter().zip(&each_period.1) {
                assert_eq!(once.0, each.0);
                assert!(
                    (once.1 - each.1).abs() < 1e-9 && (once.2 - each.2).abs() < 1e-9 * (1.0 + each.2),
                    "{once:?} against {each:?}"
                );
            }
            assert!(
                2 * steps_at_once < n as u64 && 10 * steps_at_once < steps_each_period,
                "window {window}: {steps_at_once} steps at once, {steps_each_period} one by one"
            );
        }
    }

    #[test]
    fn a_corner_cap_is_met_and_the_look_ahead_slows_short_pieces() {
        let p = piece(1.0, 500.0, 2500.0, 5000.0);
        let corner = Junction { cap: 50.0, limit: Limit::Corner, dwell: 0.0 };
        let stop = Junction { cap: 0.0, limit: Limit::Stop, dwell: 0.0 };
        let mut pieces = vec![p; 200];
        pieces[100].length = 1.0;
        let mut junctions = vec![Junction { cap: f64::INFINITY, limit: Limit::Corner, dwell: 0.0 }; 200];
        junctions[99] = corner;
        junctions[199] = stop;
        let wide = Track::new(pieces.clone(), junctions.clone(), usize::MAX, 0.0);
        let narrow = Track::new(pieces, junctions, 5, 0.0);
        let mut record = Record::default();
        let t_wide = run(&wide, 0.003, &mut record);
        let at_corner = record.1.iter().find(|c| c.0 == 99).map(|c| c.2);
        assert!(at_corner.is_some_and(|v| v <= 50.0 * 1.001), "{at_corner:?}");
        let t_narrow = run(&narrow, 0.003, &mut Record::default());
        assert!(t_narrow > t_wide * 1.2, "a 5-piece look-ahead on 1 mm pieces: {t_narrow} s vs {t_wide} s");
    }
}
