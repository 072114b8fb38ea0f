//! Linearization: between two points the CNC interpolates the axes linearly, so the tool tip
//! follows a curve in the part frame, not the programmed segment (paper 002; paper 001 Fig. 2).
//! Points are inserted (tip linear in the part frame, tool axis along the great circle) until the
//! tip stays within the tolerance of the segment. Near the pole the free axis of the points is
//! carried across the stretch of the move there (`Hold`), so that the axes stay continuous; a
//! move that cannot be brought within the tolerance is counted ([`Unsettled`]), never left
//! silently.

use nalgebra::{Point3, Unit, UnitQuaternion, Vector3};
use postpro_cl::Span;

use crate::bits::Bits;
use crate::chain::whole_turns;
use crate::policy::{Collected, Noted, Policy, Step, StepKind, StepSink, nearest_the_pole, passes_pole, pole_distance};
use crate::pose::{Joints, Pose};
use crate::solver::{Kinematics, Solutions};

/// Deepest subdivision of one segment (2¹² pieces), or of the stretch of it held near the pole.
const MAX_DEPTH: u32 = 12;
/// The most levels a held stretch adds to [`MAX_DEPTH`], for its shortness.
const MAX_HELD_DEPTH: u32 = 28;
/// Where the deviation is sampled on each piece, the middle first (where a bend is farthest out:
/// a piece found out there is split without the others).
const SAMPLES: [f64; 3] = [0.5, 0.25, 0.75];
/// Where it is sampled on the pieces of a move near the pole, the middle first.
const SAMPLES_NEAR_POLE: [f64; 7] = [0.5, 0.25, 0.75, 0.125, 0.375, 0.625, 0.875];

/// Inserts points between feed moves until the tool tip, with the axes interpolated linearly,
/// stays within the policy's tolerance (mm) of every programmed segment. Returns the number
/// inserted. Near the pole a point's free axis is carried, not taken from its pose (`Hold`).
pub fn linearize(kin: &dyn Kinematics, steps: &mut Vec<Step>, policy: &Policy) -> usize {
    linearize_noting(kin, steps, &mut Vec::new(), policy).0
}

/// [`linearize`], keeping the step indices of `decisions` pointing at the same steps; also
/// returns the segments it left out of tolerance.
pub fn linearize_noting(
    kin: &dyn Kinematics,
    steps: &mut Vec<Step>,
    decisions: &mut [Noted],
    policy: &Policy,
) -> (usize, Unsettled) {
    let mut linearizer = Linearizer::new(policy);
    let mut out = Collected { steps: Vec::with_capacity(steps.len()), decisions: Vec::new() };
    let mut d = 0;
    for (k, step) in steps.iter().enumerate() {
        while d < decisions.len() && decisions[d].step == k {
            linearizer.decision(decisions[d].clone());
            d += 1;
        }
        linearizer.step(kin, *step, &mut out);
    }
    for (slot, noted) in decisions.iter_mut().zip(out.decisions) {
        *slot = noted;
    }
    *steps = out.steps;
    (linearizer.inserted(), linearizer.unsettled())
}

/// Linearization as a stage between the policy and its reader: steps in, steps out, with the
/// points it inserts before each feed step and the decisions renumbered to the steps' new
/// indices. It keeps the previous step, nothing more.
pub struct Linearizer {
    tolerance: f64,
    cone: f64,
    /// Within this angle of the pole a move may change branch (the policy's pole passage).
    passage: f64,
    previous: Option<Step>,
    /// Decisions waiting for their step (by the index the policy gave it).
    waiting: Vec<Noted>,
    /// Steps the policy has made (the index of the next one).
    taken: usize,
    /// Steps handed on.
    given: usize,
    inserted: usize,
    sols: Solutions,
    points: Vec<Step>,
    /// The subdivisions: recorded (each deviation check's outcome) or replayed.
    shape: Shape,
    /// The segments left out of tolerance so far (all of them at once when replaying).
    unsettled: Unsettled,
}

/// The segments linearization could not bring within its tolerance: at its depth limit (2¹²
/// pieces) the tip still strays further, or a pose between has no inverse solution. Written as
/// they are, such segments leave the programmed path by up to `worst` where the controller
/// interpolates the axes.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Unsettled {
    /// Segments (from one step to the next) left out of tolerance.
    pub segments: usize,
    /// The largest deviation measured on them (mm).
    pub worst: f64,
    /// The CL statement of the first.
    pub first: Option<Span>,
    /// The tolerance (mm).
    pub tolerance: f64,
}

impl Unsettled {
    /// The largest deviation to read: in mm to 0.1 µm, in scientific notation below.
    pub fn worst_shown(&self) -> String {
        match self.worst {
            w if w >= 1e-4 => format!("{w:.4} mm"),
            w => format!("{w:.1e} mm"),
        }
    }

    /// Counts the segment ending at `span`, `deviation` (mm) off.
    fn add(&mut self, span: Span, deviation: f64) {
        self.segments += 1;
        self.worst = self.worst.max(deviation);
        self.first.get_or_insert(span);
    }
}

/// The outcome of every deviation check of a linearization, in order, a bit each: a second
/// linearization of the same steps (a later pass of a streamed job) replays it and checks no
/// deviation again. It keeps what the recording left unsettled, which a replay cannot see.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Shape {
    bits: Bits,
    unsettled: Unsettled,
    /// Replaying: the next bit to read; `None`: recording (or neither, when `off`).
    read: Option<usize>,
    off: bool,
}

impl Shape {
    /// Neither recorded nor replayed.
    fn off() -> Shape {
        Shape { off: true, ..Shape::default() }
    }

    /// The outcome of the next check: replayed, or `check()` recorded.
    fn split(&mut self, check: impl FnOnce() -> bool) -> bool {
        if self.off {
            return check();
        }
        if let Some(k) = self.read.as_mut() {
            let bit = self.bits.get(*k);
            *k += 1;
            return bit;
        }
        let bit = check();
        self.bits.push(bit);
        bit
    }
}

impl Linearizer {
    /// A linearization to `policy`'s tolerance.
    pub fn new(policy: &Policy) -> Linearizer {
        Linearizer {
            tolerance: policy.linearization_tolerance,
            cone: policy.singular_cone,
            passage: policy.pole_passage,
            previous: None,
            waiting: Vec::new(),
            taken: 0,
            given: 0,
            inserted: 0,
            sols: Solutions::new(),
            points: Vec::new(),
            shape: Shape::off(),
            unsettled: Unsettled { tolerance: policy.linearization_tolerance, ..Unsettled::default() },
        }
    }

    /// A linearization that records its subdivisions ([`Linearizer::shape`]).
    pub fn recording(policy: &Policy) -> Linearizer {
        Linearizer { shape: Shape::default(), ..Linearizer::new(policy) }
    }

    /// A linearization of the same steps again that replays `shape`, recorded by another.
    pub fn replaying(policy: &Policy, shape: Shape) -> Linearizer {
        Linearizer {
            unsettled: shape.unsettled,
            shape: Shape { read: Some(0), off: false, ..shape },
            ..Linearizer::new(policy)
        }
    }

    /// The subdivisions recorded.
    pub fn shape(self) -> Shape {
        Shape { read: None, unsettled: self.unsettled, ..self.shape }
    }

    /// Points inserted so far.
    pub fn inserted(&self) -> usize {
        self.inserted
    }

    /// The segments left out of tolerance so far; replaying, those the recording found.
    pub fn unsettled(&self) -> Unsettled {
        self.unsettled
    }

    /// Forgets the previous step: the next one starts afresh (another tool; nothing joins them).
    pub fn restart(&mut self) {
        self.previous = None;
    }

    /// A decision about a step still to come.
    pub fn decision(&mut self, noted: Noted) {
        self.waiting.push(noted);
    }

    /// The next step of the policy, solved with `kin`: the points linearization needs before it,
    /// the decisions about it, then it, go to `out`.
    pub fn step(&mut self, kin: &dyn Kinematics, step: Step, out: &mut dyn StepSink) {
        if let Some(prev) = self.previous
            && !step.rapid
            && matches!(step.kind, StepKind::Cl | StepKind::Reengage)
        {
            self.points.clear();
            let mut points = std::mem::take(&mut self.points);
            let mut split = Split {
                shape: &mut self.shape,
                sols: &mut self.sols,
                out: &mut points,
                limits: (self.tolerance, self.cone, self.passage),
                ends: (&prev, &step),
                end_poles: None,
                passes: None,
                hold: None,
                off: None,
            };
            self.inserted += split.subdivide(kin, &prev, &step, (0.0, 1.0), 0);
            if let Some(deviation) = split.off {
                self.unsettled.add(step.span, deviation);
            }
            for p in points.drain(..) {
                self.given += 1;
                out.step(p);
            }
            self.points = points;
        }
        let index = self.taken;
        self.taken += 1;
        let mut k = 0;
        while k < self.waiting.len() {
            if self.waiting[k].step == index {
                let noted = self.waiting.remove(k);
                out.decision(Noted { step: self.given, ..noted });
            } else {
                k += 1;
            }
        }
        self.previous = Some(step);
        self.given += 1;
        out.step(step);
    }
}

/// A [`StepSink`] that linearizes, with `kin`, the steps it takes before `out` gets them.
pub struct Linearizing<'a> {
    /// The linearization.
    pub linearizer: &'a mut Linearizer,
    /// The kinematics of the tool in the spindle.
    pub kin: &'a dyn Kinematics,
    /// Where the steps go.
    pub out: &'a mut dyn StepSink,
}

impl StepSink for Linearizing<'_> {
    fn step(&mut self, step: Step) {
        self.linearizer.step(self.kin, step, self.out);
    }

    fn decision(&mut self, noted: Noted) {
        self.linearizer.decision(noted);
    }
}

/// The largest distance of the interpolated tip from the segment `a.tip → b.tip`.
pub fn deviation(kin: &dyn Kinematics, a: &Step, b: &Step) -> f64 {
    deviation_at(kin, a, b, &SAMPLES)
}

/// [`deviation`] sampled at `samples` (parameters in `0..1`); NaN if a sample is.
fn deviation_at(kin: &dyn Kinematics, a: &Step, b: &Step, samples: &[f64]) -> f64 {
    // A NaN is kept (`f64::max` would drop it): it is not within any tolerance.
    samples.iter().map(|&t| deviation_sample(kin, a, b, t)).fold(0.0, |m, d| if d > m || d.is_nan() { d } else { m })
}

/// How far the tip is off the segment `a → b` at parameter `t` of the move, the axes
/// interpolated linearly.
fn deviation_sample(kin: &dyn Kinematics, a: &Step, b: &Step, t: f64) -> f64 {
    distance_to_segment(&kin.forward(&a.joints.lerp(&b.joints, t)).tip, &a.pose.tip, &b.pose.tip)
}

/// How far a step's tip may be off its pose: the placing verifies it of the program's steps
/// (`Placer::verify`), and the points added here are solved for their own poses.
const TIP_RESIDUAL: f64 = 1e-6;

/// True when the kinematics' bound of the tip's bend keeps the move `a → b` within the tolerance
/// of its segment, its ends' residuals included: the tip is within `bend · t(1 − t)/2 ≤ bend/8`
/// of the chord of its ends (a bound, property-tested on every machine), so no sample can find
/// it out of tolerance and none is taken.
fn provably_within(kin: &dyn Kinematics, a: &Step, b: &Step, tolerance: f64) -> bool {
    kin.bend(&a.joints, &b.joints).is_some_and(|bend| bend.tip / 8.0 + TIP_RESIDUAL <= tolerance)
}

/// One subdivision: its shape, scratch and the points it inserts.
struct Split<'a> {
    shape: &'a mut Shape,
    sols: &'a mut Solutions,
    out: &'a mut Vec<Step>,
    /// `(tolerance, singular cone, pole passage)`.
    limits: (f64, f64, f64),
    /// The move split, from one step to the next: its points are at parameters in `0..1` of it.
    ends: (&'a Step, &'a Step),
    /// The end steps' branches (none within the singular cone) and distances from the pole,
    /// once a point of the move falls near the pole (within the pole passage and the move's own
    /// turn of the tool axis).
    end_poles: Option<[(Option<u8>, f64); 2]>,
    /// Whether the move passes the pole, once a point falls near it.
    passes: Option<bool>,
    /// The free axis's values near the pole, once a point falls there.
    hold: Option<Hold>,
    /// The largest deviation of the pieces left out of tolerance (checked, not replayed).
    off: Option<f64>,
}

/// Steps of the bisection that finds where a move comes within an angle of the pole, or leaves
/// it (to 2⁻⁴⁰ of the move).
const EDGE_STEPS: u32 = 40;

/// The free axis's values along the stretch of the move split that lies within `angle` of the
/// pole: the singular cone, or the pole passage where the move changes branch. There they are
/// not taken from the pose but carried, linearly in the move's parameter, from the value the axis
/// has where the move comes within the angle to the value where it leaves (the pose's own just
/// outside, on the branch of the end step beyond; or the end step's, within); the other axes are
/// fitted to them, the tip exact. So the axes are continuous where the stretch begins and ends,
/// and a change of branch goes through the pole, as the policy's passage means: a value carried
/// from farther away, or the other branch's, would jump, and no subdivision narrows a jump.
#[derive(Clone, Copy, Debug)]
struct Hold {
    free: usize,
    angle: f64,
    /// `(parameter, value)` where the stretch begins, and where it ends.
    enter: (f64, f64),
    leave: (f64, f64),
}

impl Hold {
    fn covers(&self, s: f64) -> bool {
        (self.enter.0..=self.leave.0).contains(&s)
    }

    fn at(&self, s: f64) -> f64 {
        let ((s0, v0), (s1, v1)) = (self.enter, self.leave);
        if s1 > s0 { v0 + (v1 - v0) * (s - s0) / (s1 - s0) } else { v0 }
    }
}

impl Split<'_> {
    /// Splits `a → b` (at parameters `sa`, `sb` of the move) until the tip stays within the
    /// tolerance; returns the points inserted (also pushed to `out`, in order).
    fn subdivide(&mut self, kin: &dyn Kinematics, a: &Step, b: &Step, (sa, sb): (f64, f64), depth: u32) -> usize {
        let tolerance = self.limits.0;
        // Anything but "within tolerance" splits, a NaN deviation too (`NaN <= t` is false).
        let within = |d: f64| d <= tolerance;
        let (mut over, mut found_out) = (None, false);
        let max_depth = self.max_depth((sa, sb));
        // Near the pole the axes turn unevenly along a piece: its deviation is sampled finer.
        let samples: &[f64] = if self.end_poles.is_some() { &SAMPLES_NEAR_POLE } else { &SAMPLES };
        let split = self.shape.split(|| {
            if provably_within(kin, a, b, tolerance) {
                return false;
            }
            if depth < max_depth {
                // The first sample out of tolerance splits: the others need not be taken (the
                // deviation is measured whole only if the piece cannot be split after all).
                found_out = samples.iter().any(|&t| !within(deviation_sample(kin, a, b, t)));
                return found_out;
            }
            let d = deviation_at(kin, a, b, samples);
            if within(d) {
                return false;
            }
            // At the deepest subdivision: left, out of tolerance by `d`.
            over = Some(d);
            false
        });
        if !split {
            return self.left(over);
        }
        // The pose at the middle parameter of the piece (`pose_at`, to rounding).
        let pose =
            Pose { tip: a.pose.tip + (b.pose.tip - a.pose.tip) * 0.5, axis: slerp(&a.pose.axis, &b.pose.axis, 0.5) };
        let s = 0.5 * (sa + sb);
        let Some(joints) = self.solve(kin, &pose, a.joints.lerp(&b.joints, 0.5), s) else {
            return self.left(found_out.then(|| deviation_at(kin, a, b, samples)));
        };
        let mid = Step { joints, pose, rapid: false, span: b.span, kind: StepKind::Linearized };
        let left = self.subdivide(kin, a, &mid, (sa, s), depth + 1);
        self.out.push(mid);
        left + 1 + self.subdivide(kin, &mid, b, (s, sb), depth + 1)
    }

    /// The deepest subdivision of the piece `sa..sb`: [`MAX_DEPTH`] below the move, or below the
    /// held stretch near the pole it reaches into (a short stretch where the free axis may turn
    /// far).
    fn max_depth(&self, (sa, sb): (f64, f64)) -> u32 {
        match self.hold {
            Some(h) if sa < h.leave.0 && h.enter.0 < sb && h.leave.0 > h.enter.0 => {
                MAX_DEPTH + (1.0 / (h.leave.0 - h.enter.0)).log2().ceil().clamp(0.0, f64::from(MAX_HELD_DEPTH)) as u32
            }
            _ => MAX_DEPTH,
        }
    }

    /// A piece left as it is, `over` (mm) out of tolerance if checked so; inserts nothing.
    fn left(&mut self, over: Option<f64>) -> usize {
        if let Some(d) = over {
            self.off = Some(self.off.map_or(d, |o| o.max(d)));
        }
        0
    }

    /// The pose at parameter `s` of the move: the tip on the segment, the tool axis on the great
    /// circle.
    fn pose_at(&self, s: f64) -> Pose {
        let (a, b) = self.ends;
        Pose { tip: a.pose.tip + (b.pose.tip - a.pose.tip) * s, axis: slerp(&a.pose.axis, &b.pose.axis, s) }
    }

    /// The axis values for `pose`, at parameter `s` of the move, nearest to `near`. Near the pole
    /// (within the pole passage and the move's own turn of the tool axis) the free axis is held
    /// as [`Hold`] says where the move is within the singular cone (an end step within it
    /// included), or within the pole passage on a move between branches that passes the pole;
    /// elsewhere the point is on the branch of the end step on its side: there the nearest
    /// solution may be the other branch's, the free axis swinging fast.
    fn solve(&mut self, kin: &dyn Kinematics, pose: &Pose, mut near: Joints, s: f64) -> Option<Joints> {
        let (_, cone, passage) = self.limits;
        let (a, b) = self.ends;
        kin.inverse(pose, self.sols);
        let Some((free, distance)) = pole(self.sols).filter(|&(_, d)| d < passage + a.pose.axis.angle(&b.pose.axis))
        else {
            return nearest_of(kin, pose, self.sols, &near, cone);
        };
        let (from, to) = self.branches(kin);
        let hold = match (from, to) {
            // Branches that meet away from the pole (at the edge of a head's reach): as far.
            (Some(x), Some(y)) if x != y && !self.passes_pole(kin) => {
                return nearest_of(kin, pose, self.sols, &near, cone);
            }
            (Some(x), Some(y)) if x != y => Some(self.hold(kin, (free, passage), None)?),
            _ if distance < cone => Some(self.hold(kin, (free, cone), Some(s))?),
            // An end within the cone: the stretch from it to the cone's edge is held, however
            // short.
            (None, _) => Some(self.hold(kin, (free, cone), Some(0.0))?),
            (_, None) => Some(self.hold(kin, (free, cone), Some(1.0))?),
            _ => None,
        };
        match hold {
            Some(hold) if hold.covers(s) => {
                near[free] = hold.at(s);
                holding(kin, pose, free, &near)
            }
            Some(hold) => {
                let side = if s < hold.enter.0 { from } else { to };
                on_branch(kin, pose, self.sols, side, &near, cone)
            }
            None => on_branch(kin, pose, self.sols, from.or(to), &near, cone),
        }
    }

    /// Whether the move's tool axis comes within the pole passage of the pole (as the policy
    /// decides a passage; an end within the singular cone included).
    fn passes_pole(&mut self, kin: &dyn Kinematics) -> bool {
        if let Some(passes) = self.passes {
            return passes;
        }
        let [(_, da), (_, db)] = self.end_poles(kin);
        let (a, b) = self.ends;
        let passes = passes_pole(kin, (&a.pose, da), (&b.pose, db), self.limits.2, &mut Solutions::new());
        self.passes = Some(passes);
        passes
    }

    /// The branches of the move's end steps (none for one within the singular cone).
    fn branches(&mut self, kin: &dyn Kinematics) -> (Option<u8>, Option<u8>) {
        let [(from, _), (to, _)] = self.end_poles(kin);
        (from, to)
    }

    /// The end steps' branches and distances from the pole, found once a move.
    fn end_poles(&mut self, kin: &dyn Kinematics) -> [(Option<u8>, f64); 2] {
        let (a, b) = self.ends;
        let (cone, mut sols) = (self.limits.1, Solutions::new());
        *self.end_poles.get_or_insert_with(|| [a, b].map(|end| branch_of(kin, end, cone, &mut sols)))
    }

    /// The stretch of the move within `angle` of the pole (`free` the axis it frees) around the
    /// parameter `inside`, or, without it, around where the move comes nearest the pole; the one
    /// found before if it is that.
    fn hold(&mut self, kin: &dyn Kinematics, (free, angle): (usize, f64), inside: Option<f64>) -> Option<Hold> {
        if let Some(hold) = self.hold
            && hold.free == free
            && hold.angle == angle
            && inside.is_none_or(|s| hold.covers(s))
        {
            return Some(hold);
        }
        let (a, b) = self.ends;
        let inside = match inside {
            Some(s) => s,
            None => nearest_the_pole(kin, (&a.pose, &b.pose), angle, &mut Solutions::new()).0,
        };
        let (from, to) = self.branches(kin);
        let hold = Hold {
            free,
            angle,
            enter: self.edge(kin, (free, angle), (a, 0.0, from), inside)?,
            leave: self.edge(kin, (free, angle), (b, 1.0, to), inside)?,
        };
        self.hold = Some(hold);
        Some(hold)
    }

    /// Where the move, from the end step `end` (at parameter `at`, on `branch`) towards `inside`
    /// (a parameter within `angle` of the pole), comes within the angle, and the free axis's
    /// value there: the end step's own if it is within, else the pose's just outside, followed
    /// from the end step on its branch.
    fn edge(
        &self,
        kin: &dyn Kinematics,
        (free, angle): (usize, f64),
        (end, at, branch): (&Step, f64, Option<u8>),
        inside: f64,
    ) -> Option<(f64, f64)> {
        let cone = self.limits.1;
        let mut sols = Solutions::new();
        let near_pole = |sols: &Solutions| pole(sols).is_some_and(|(_, d)| d < angle);
        kin.inverse(&self.pose_at(at), &mut sols);
        if near_pole(&sols) {
            return Some((at, end.joints[free]));
        }
        let (mut outside, mut joints, mut inside) = (at, end.joints, inside);
        for _ in 0..EDGE_STEPS {
            let s = 0.5 * (outside + inside);
            let pose = self.pose_at(s);
            kin.inverse(&pose, &mut sols);
            if near_pole(&sols) {
                inside = s;
            } else {
                joints = on_branch(kin, &pose, &sols, branch, &joints, cone)?;
                outside = s;
            }
        }
        Some((outside, joints[free]))
    }
}

/// The solutions' singularity: the rotary axis it frees and the nearest solution's distance (rad).
fn pole(sols: &Solutions) -> Option<(usize, f64)> {
    sols.iter().filter_map(|s| s.pole).min_by(|x, y| x.1.total_cmp(&y.1))
}

/// The rotary axis left free by a solution within `cone` of its singularity.
fn free_axis(sols: &Solutions, cone: f64) -> Option<usize> {
    pole(sols).filter(|&(_, d)| d < cone).map(|(free, _)| free)
}

/// The branch of the solution `step` is at (its rotary axes equal to one's, to a turn), none
/// within the singular cone, where the free axis is carried; and its distance from the pole.
fn branch_of(kin: &dyn Kinematics, step: &Step, cone: f64, sols: &mut Solutions) -> (Option<u8>, f64) {
    kin.inverse(&step.pose, sols);
    let distance = pole_distance(sols);
    if distance < cone {
        return (None, distance);
    }
    let axes = &kin.machine().axes;
    let rotary = || (0..axes.len()).filter(|&i| axes[i].kind == postpro_machine::model::AxisKind::Rotary);
    let turn = |d: f64| (d - whole_turns(d)).abs();
    (sols.iter().find(|s| rotary().all(|i| turn(s.joints[i] - step.joints[i]) < 1e-6)).map(|s| s.branch), distance)
}

/// The solution among `sols` (of `pose`) on `branch`, its rotary axes at the turn nearest `near`;
/// without a branch, or none on it, [`nearest_of`].
fn on_branch(
    kin: &dyn Kinematics,
    pose: &Pose,
    sols: &Solutions,
    branch: Option<u8>,
    near: &Joints,
    singular_cone: f64,
) -> Option<Joints> {
    let Some(on) = sols.iter().find(|s| Some(s.branch) == branch) else {
        return nearest_of(kin, pose, sols, near, singular_cone);
    };
    Some(turned_near(kin, on.joints, near, None))
}

/// `joints` with each rotary axis but `except` at the turn nearest its value in `near`.
fn turned_near(kin: &dyn Kinematics, mut joints: Joints, near: &Joints, except: Option<usize>) -> Joints {
    for (i, axis) in kin.machine().axes.iter().enumerate() {
        if axis.kind == postpro_machine::model::AxisKind::Rotary && Some(i) != except {
            joints[i] += whole_turns(near[i] - joints[i]);
        }
    }
    joints
}

/// The solution for `pose` with the free axis at `near[free]`, the other rotary axes at the turn
/// nearest `near`.
fn holding(kin: &dyn Kinematics, pose: &Pose, free: usize, near: &Joints) -> Option<Joints> {
    let mut j = turned_near(kin, kin.inverse_holding(pose, free, near[free])?, near, Some(free));
    j[free] = near[free];
    Some(j)
}

/// The inverse solution closest to `near` (rotary angles unwound next to it). Within the
/// singular cone the free axis is not taken from the (ill-conditioned) pose but from `near`,
/// as the policy does for the CL points.
pub fn nearest_solution(
    kin: &dyn Kinematics,
    pose: &Pose,
    near: &Joints,
    singular_cone: f64,
    sols: &mut Solutions,
) -> Option<Joints> {
    kin.inverse(pose, sols);
    nearest_of(kin, pose, sols, near, singular_cone)
}

/// [`nearest_solution`] among `sols`, the inverse solutions of `pose`.
fn nearest_of(
    kin: &dyn Kinematics,
    pose: &Pose,
    sols: &Solutions,
    near: &Joints,
    singular_cone: f64,
) -> Option<Joints> {
    if let Some(free) = free_axis(sols, singular_cone) {
        return holding(kin, pose, free, near);
    }
    sols.iter()
        .map(|s| {
            let j = turned_near(kin, s.joints, near, None);
            let d: f64 = j.as_slice().iter().zip(near.as_slice()).map(|(x, y)| (x - y).abs()).sum();
            (d, j)
        })
        .min_by(|x, y| x.0.total_cmp(&y.0))
        .map(|(_, j)| j)
}

/// The great-circle interpolation of two unit vectors.
pub fn slerp(a: &Unit<Vector3<f64>>, b: &Unit<Vector3<f64>>, t: f64) -> Unit<Vector3<f64>> {
    match UnitQuaternion::rotation_between(a, b) {
        Some(q) => UnitQuaternion::identity().slerp(&q, t) * *a,
        // Opposite vectors: no unique great circle; keep the first.
        None => *a,
    }
}

/// The distance of `p` from the segment `a → b`.
pub(crate) fn distance_to_segment(p: &Point3<f64>, a: &Point3<f64>, b: &Point3<f64>) -> f64 {
    let ab = b - a;
    let len2 = ab.norm_squared();
    let t = if len2 > 0.0 { ((p - a).dot(&ab) / len2).clamp(0.0, 1.0) } else { 0.0 };
    (p - (a + ab * t)).norm()
}

#[cfg(test)]
mod tests {
    use nalgebra::{Point3, Vector3};
    use postpro_cl::Span;
    use postpro_machine::model::SolverKind;

    use super::*;
    use crate::chain::Chain;
    use crate::testing;

    /// A machine's kinematics whose forward kinematics puts the tip `shift` off where the
    /// inverse places it (no subdivision brings such a tip onto the path), and which has no
    /// solution for a tip with `x` in `gap`.
    struct Askew<'a> {
        inner: &'a dyn Kinematics,
        shift: Vector3<f64>,
        gap: (f64, f64),
    }

    impl Kinematics for Askew<'_> {
        fn machine(&self) -> &postpro_machine::model::Machine {
            self.inner.machine()
        }
        fn forward(&self, joints: &Joints) -> Pose {
            let pose = self.inner.forward(joints);
            Pose { tip: pose.tip + self.shift, ..pose }
        }
        fn inverse(&self, pose: &Pose, out: &mut Solutions) {
            out.clear();
            if !(self.gap.0..self.gap.1).contains(&pose.tip.x) {
                self.inner.inverse(pose, out);
            }
        }
        fn inverse_holding(&self, pose: &Pose, free_axis: usize, value: f64) -> Option<Joints> {
            self.inner.inverse_holding(pose, free_axis, value)
        }
        fn place(&self, pose: &Pose, rotaries: &Joints) -> Joints {
            self.inner.place(pose, rotaries)
        }
    }

    /// Feed steps through `tips` with the tool axis tilted by `tilts` (degrees about X), each
    /// statement 10 bytes long.
    fn steps(kin: &dyn Kinematics, tips: &[[f64; 3]], tilts: &[f64]) -> Vec<Step> {
        let mut sols = Solutions::new();
        let mut out: Vec<Step> = Vec::new();
        for (k, (tip, tilt)) in tips.iter().zip(tilts).enumerate() {
            let t = tilt.to_radians();
            let pose =
                Pose { tip: Point3::from(*tip), axis: Unit::new_normalize(Vector3::new(0.0, -t.sin(), t.cos())) };
            let near = out.last().map_or(Joints::zeros(kin.machine().axes.len()), |s| s.joints);
            let joints = nearest_solution(kin, &pose, &near, 1e-3, &mut sols).expect("reachable");
            let span = Span { start: 10 * k as u32, len: 10 };
            out.push(Step { joints, pose, rapid: false, span, kind: StepKind::Cl });
        }
        out
    }

    fn run(kin: &dyn Kinematics, linearizer: &mut Linearizer, steps: &[Step]) -> Vec<Step> {
        let mut out = Collected::default();
        for step in steps {
            linearizer.step(kin, *step, &mut out);
        }
        out.steps
    }

    #[test]
    fn a_segment_that_cannot_be_brought_within_tolerance_is_counted_with_its_deviation() {
        let machine = testing::mikron(SolverKind::Generic);
        let chain = Chain::new(machine);
        let askew = Askew { inner: &chain, shift: Vector3::new(0.0, 0.0, 0.05), gap: (f64::MAX, f64::MAX) };
        let policy = chain.machine().policy.clone();
        let path = steps(&chain, &[[0.0, 0.0, 0.0], [30.0, 0.0, 0.0], [60.0, 0.0, 0.0]], &[0.0, 0.0, 0.0]);

        let mut recording = Linearizer::recording(&policy);
        let written = run(&askew, &mut recording, &path);
        let unsettled = recording.unsettled();
        assert_eq!(unsettled.segments, 2, "{unsettled:?}");
        assert!((unsettled.worst - 0.05).abs() < 1e-9, "{unsettled:?}");
        assert_eq!(unsettled.first, Some(path[1].span));
        assert_eq!(unsettled.tolerance, policy.linearization_tolerance);
        // Down to the depth limit: 2¹² pieces a segment.
        assert_eq!(recording.inserted(), 2 * ((1 << MAX_DEPTH) - 1));

        // A later pass replays the subdivisions without checking: it says the same.
        let mut replaying = Linearizer::replaying(&policy, recording.shape());
        assert_eq!(run(&askew, &mut replaying, &path), written);
        assert_eq!(replaying.unsettled(), unsettled);

        // With the kinematics right, nothing is left.
        let mut right = Linearizer::new(&policy);
        run(&chain, &mut right, &path);
        assert_eq!(right.unsettled().segments, 0);
    }

    #[test]
    fn a_deviation_that_cannot_be_measured_is_not_taken_for_none() {
        let chain = Chain::new(testing::mikron(SolverKind::Generic));
        let mut path = steps(&chain, &[[0.0, 0.0, 0.0], [40.0, 0.0, 0.0]], &[0.0, 15.0]);
        assert!(deviation(&chain, &path[0], &path[1]) > 0.0);
        // An axis value that is not a number: every sample's tip is NaN, whichever is first.
        path[1].joints[0] = f64::NAN;
        assert!(deviation(&chain, &path[0], &path[1]).is_nan());
    }

    #[test]
    fn a_segment_whose_midpoint_has_no_solution_is_counted() {
        let machine = testing::mikron(SolverKind::Generic);
        let chain = Chain::new(machine);
        let policy = chain.machine().policy.clone();
        // A tilt from 0° to 15° over 40 mm: far off the segment with the axes interpolated.
        let path = steps(&chain, &[[0.0, 0.0, 0.0], [40.0, 0.0, 0.0]], &[0.0, 15.0]);
        let before = deviation(&chain, &path[0], &path[1]);
        assert!(before > 10.0 * policy.linearization_tolerance, "{before}");
        let gapped = Askew { inner: &chain, shift: Vector3::zeros(), gap: (19.0, 21.0) };

        let mut linearizer = Linearizer::new(&policy);
        assert_eq!(run(&gapped, &mut linearizer, &path).len(), 2);
        let unsettled = linearizer.unsettled();
        assert_eq!(unsettled.segments, 1, "{unsettled:?}");
        assert_eq!(unsettled.worst, before);
        assert_eq!(unsettled.first, Some(path[1].span));
    }
}
