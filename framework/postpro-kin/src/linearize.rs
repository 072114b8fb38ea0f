//! Linearization: between two points the CNC interpolates the axes linearly, so the tool tip
//! follows a curve in the part frame, not the programmed segment (paper 002; paper 001 Fig. 2).
//! Points are inserted (tip linear in the part frame, tool axis along the great circle) until the
//! tip stays within the tolerance of the segment.

use nalgebra::{Point3, Unit, UnitQuaternion, Vector3};

use crate::bits::Bits;
use crate::policy::{Collected, Noted, Policy, Step, StepKind, StepSink};
use crate::pose::{Joints, Pose};
use crate::solver::{Kinematics, Solutions};

/// Deepest subdivision of one segment (2¹² pieces).
const MAX_DEPTH: u32 = 12;
/// Where the deviation is sampled on each piece.
const SAMPLES: [f64; 3] = [0.25, 0.5, 0.75];

/// Inserts points between feed moves until the tool tip, with the axes interpolated linearly,
/// stays within the policy's tolerance (mm) of every programmed segment. Returns the number
/// inserted. A point within the singular cone takes its free axis from the interpolation.
pub fn linearize(kin: &dyn Kinematics, steps: &mut Vec<Step>, policy: &Policy) -> usize {
    linearize_noting(kin, steps, &mut Vec::new(), policy)
}

/// [`linearize`], keeping the step indices of `decisions` pointing at the same steps.
pub fn linearize_noting(
    kin: &dyn Kinematics,
    steps: &mut Vec<Step>,
    decisions: &mut [Noted],
    policy: &Policy,
) -> usize {
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
    linearizer.inserted()
}

/// Linearization as a stage between the policy and its reader: steps in, steps out, with the
/// points it inserts before each feed step and the decisions renumbered to the steps' new
/// indices. It keeps the previous step, nothing more.
pub struct Linearizer {
    tolerance: f64,
    cone: f64,
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
}

/// The outcome of every deviation check of a linearization, in order, a bit each: a second
/// linearization of the same steps (a later pass of a streamed job) replays it and checks no
/// deviation again.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Shape {
    bits: Bits,
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
            previous: None,
            waiting: Vec::new(),
            taken: 0,
            given: 0,
            inserted: 0,
            sols: Solutions::new(),
            points: Vec::new(),
            shape: Shape::off(),
        }
    }

    /// A linearization that records its subdivisions ([`Linearizer::shape`]).
    pub fn recording(policy: &Policy) -> Linearizer {
        Linearizer { shape: Shape::default(), ..Linearizer::new(policy) }
    }

    /// A linearization of the same steps again that replays `shape`, recorded by another.
    pub fn replaying(policy: &Policy, shape: Shape) -> Linearizer {
        Linearizer { shape: Shape { read: Some(0), off: false, ..shape }, ..Linearizer::new(policy) }
    }

    /// The subdivisions recorded.
    pub fn shape(self) -> Shape {
        Shape { read: None, ..self.shape }
    }

    /// Points inserted so far.
    pub fn inserted(&self) -> usize {
        self.inserted
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
            let mut split = Split { shape: &mut self.shape, sols: &mut self.sols, out: &mut points };
            self.inserted += split.subdivide(kin, &prev, &step, (self.tolerance, self.cone), 0);
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
    SAMPLES
        .iter()
        .map(|&t| distance_to_segment(&kin.forward(&a.joints.lerp(&b.joints, t)).tip, &a.pose.tip, &b.pose.tip))
        .fold(0.0, f64::max)
}

/// One subdivision: its shape, scratch and the points it inserts.
struct Split<'a> {
    shape: &'a mut Shape,
    sols: &'a mut Solutions,
    out: &'a mut Vec<Step>,
}

impl Split<'_> {
    fn subdivide(
        &mut self,
        kin: &dyn Kinematics,
        a: &Step,
        b: &Step,
        (tolerance, cone): (f64, f64),
        depth: u32,
    ) -> usize {
        // Anything but "within tolerance" splits, a NaN deviation too.
        let within = |d: f64| d.partial_cmp(&tolerance).is_some_and(|o| o != std::cmp::Ordering::Greater);
        if !self.shape.split(|| depth < MAX_DEPTH && !within(deviation(kin, a, b))) {
            return 0;
        }
        let pose =
            Pose { tip: a.pose.tip + (b.pose.tip - a.pose.tip) * 0.5, axis: slerp(&a.pose.axis, &b.pose.axis, 0.5) };
        let Some(joints) = nearest_solution(kin, &pose, &a.joints.lerp(&b.joints, 0.5), cone, self.sols) else {
            return 0;
        };
        let mid = Step { joints, pose, rapid: false, span: b.span, kind: StepKind::Linearized };
        let left = self.subdivide(kin, a, &mid, (tolerance, cone), depth + 1);
        self.out.push(mid);
        left + 1 + self.subdivide(kin, &mid, b, (tolerance, cone), depth + 1)
    }
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
    let machine = kin.machine();
    if let Some((free, _)) = sols.iter().find_map(|s| s.pole.filter(|&(_, d)| d < singular_cone)) {
        let mut j = kin.inverse_holding(pose, free, near[free])?;
        for (i, axis) in machine.axes.iter().enumerate() {
            if axis.kind == postpro_machine::model::AxisKind::Rotary && i != free {
                j[i] += std::f64::consts::TAU * ((near[i] - j[i]) / std::f64::consts::TAU).round();
            }
        }
        j[free] = near[free];
        return Some(j);
    }
    sols.iter()
        .map(|s| {
            let mut j = s.joints;
            for (i, axis) in machine.axes.iter().enumerate() {
                if axis.kind == postpro_machine::model::AxisKind::Rotary {
                    j[i] += std::f64::consts::TAU * ((near[i] - j[i]) / std::f64::consts::TAU).round();
                }
            }
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
