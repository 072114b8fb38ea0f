//! The policy: which of the inverse solutions each point of a path takes.
//!
//! - **Ranges**: a solution whose axis values (after unwinding) leave the travel is not a
//!   candidate; rotary travels may exceed one turn.
//! - **Shortest turns**: every rotary angle is taken at the turn nearest to the previous point, so
//!   an endless axis never turns more than half a turn in one block; it accumulates rotation.
//! - **Bounded winding**: an endless axis that has wound more than `unwind` turns from its home
//!   position takes, at the next rapid, the equivalent angle nearest home.
//! - **Choice**: by default dynamic programming over the whole path picks the sequence with the
//!   fewest discontinuities, then the least rotary travel, then the fewest branch switches, then
//!   the preferred branch; the greedy choice takes the best next point each time.
//! - **Singularity**: within `singular_cone` of the pole the free rotary angle is not computed
//!   from the (ill-conditioned) pose but carried: a run reached through a rapid (a 3-axis or
//!   vertical 3+2 pass) keeps its value and turns at the last rapid; a run at feed (a 5-axis pass
//!   through the cone) turns where the tool axis is nearest the pole; the other rotary is fitted
//!   to it and the linear axes placed exactly; the tool axis then deviates by less than the cone.
//! - **Discontinuity**: only a branch change away from the pole or a travel limit during a feed
//!   move; it is an error naming the CL line or, as a setting, a retract along the tool axis, a
//!   reorientation at the clearance and a re-engagement. A large rotary step on one branch is
//!   motion (linearization keeps the tip on the segment); above `max_rotary_step` it is reported.
//!
//! Every decision that is not obvious is returned as a [`Noted`] decision.

use std::f64::consts::{PI, TAU};
use std::fmt;

use postpro_cl::Span;
use postpro_machine::model::{AxisKind, BranchPreference, PolicyDefaults, Travel};

use crate::bits::Bits;
use crate::chain::whole_turns;
use crate::linearize::slerp;
use crate::pose::{Joints, Pose};
use crate::solver::{Kinematics, Solutions};

/// The settings of the policy: the machine's defaults with the command line's overrides.
pub type Policy = PolicyDefaults;

/// Cost of a branch switch, in radians of rotary travel: it only breaks ties.
const SWITCH_COST: f64 = 1e-3;
/// Cost of a solution off the preferred branch: used only when the preferred one is infeasible.
const OFF_PREFERENCE_COST: f64 = 100.0;
/// Half a turn and a rounding margin: a step on an endless axis never exceeds it.
const HALF_TURN: f64 = PI + 1e-9;

/// A pose to reach, and where it came from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Target {
    /// The pose in the part frame.
    pub pose: Pose,
    /// Reached at rapid traverse.
    pub rapid: bool,
    /// The CL statement.
    pub span: Span,
}

/// Why a step is there.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StepKind {
    /// A CL point.
    Cl,
    /// A point inserted by linearization.
    Linearized,
    /// Retract along the tool axis before a reorientation.
    Retract,
    /// Reorientation at the clearance.
    Reorient,
    /// Back to the CL point after a reorientation (the CL point itself).
    Reengage,
}

/// One position of the machine.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Step {
    /// Axis values (mm, rad; rotary angles unwound).
    pub joints: Joints,
    /// The pose it reaches in the part frame.
    pub pose: Pose,
    /// Rapid traverse.
    pub rapid: bool,
    /// The CL statement.
    pub span: Span,
    /// Why it is there.
    pub kind: StepKind,
}

/// `(letter, from, to)` of each rotary axis, in degrees.
pub type AxisMoves = Vec<(String, f64, f64)>;

/// A decision that is not obvious, for the log and the NC program.
#[derive(Clone, Debug, PartialEq)]
pub enum Decision {
    /// The solution branch changes (at the pole, or at a rapid): the rotary axes before and after
    /// (degrees).
    BranchSwitch {
        /// The rotary axes before and after.
        axes: AxisMoves,
    },
    /// Within the singular cone the free axis is carried, not computed from the pose.
    SingularHold {
        /// The free axis.
        axis: String,
        /// Its value before the singular run (degrees).
        from: f64,
        /// Its value after the run: at the next regular point, or at the run's last point at
        /// the end of the path (degrees).
        to: f64,
        /// Points in the run.
        points: usize,
    },
    /// The preferred branch is infeasible here: another is used.
    OffPreference {
        /// The axis of the preference.
        axis: String,
    },
    /// Retract, reorient and re-engage at a discontinuity.
    Retract {
        /// The clearance (mm).
        clearance: f64,
        /// The rotary axes before and after.
        axes: AxisMoves,
    },
    /// A warning: a rotary axis turns by more than `max_rotary_step` in one feed block (it is
    /// still one continuous motion, linearised to the tolerance).
    LargeRotaryStep {
        /// The axis that turns most.
        axis: String,
        /// Its value before (degrees).
        from: f64,
        /// Its value after (degrees).
        to: f64,
    },
    /// An endless axis wound beyond `unwind` turns takes, at a rapid, the equivalent angle
    /// nearest its home position.
    Unwind {
        /// The axis.
        axis: String,
        /// Its value before (degrees).
        from: f64,
        /// Its value after (degrees).
        to: f64,
    },
}

/// A decision with the step it applies to.
#[derive(Clone, Debug, PartialEq)]
pub struct Noted {
    /// Index into `Solved::steps`.
    pub step: usize,
    /// The CL statement.
    pub span: Span,
    /// What was decided.
    pub decision: Decision,
}

impl fmt::Display for Decision {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let axes = |f: &mut fmt::Formatter<'_>, axes: &[(String, f64, f64)]| {
            let parts: Vec<String> = axes.iter().map(|(a, x, y)| format!("{a} {x:.3}° → {y:.3}°")).collect();
            f.write_str(&parts.join(", "))
        };
        match self {
            Decision::BranchSwitch { axes: a } => {
                f.write_str("branch switch: ")?;
                axes(f, a)
            }
            Decision::SingularHold { axis, from, to, points } if (to - from).abs() < 5e-4 => {
                write!(f, "near the singularity: {axis} held at {from:.3}° over {points} point(s)")
            }
            Decision::SingularHold { axis, from, to, points } => {
                write!(f, "near the singularity: {axis} carried from {from:.3}° to {to:.3}° over {points} point(s)")
            }
            Decision::OffPreference { axis } => write!(f, "the preferred branch of {axis} is out of reach here"),
            Decision::Retract { clearance, axes: a } => {
                write!(f, "retract {clearance} mm, reorient, re-engage: ")?;
                axes(f, a)
            }
            Decision::LargeRotaryStep { axis, from, to } => {
                write!(f, "large rotary step: {axis} {from:.3}° → {to:.3}° ({:.3}° in one block)", (to - from).abs())
            }
            Decision::Unwind { axis, from, to } => write!(f, "{axis} unwound at a rapid: {from:.3}° → {to:.3}°"),
        }
    }
}

/// The chosen positions and the decisions.
#[derive(Clone, Debug, PartialEq)]
pub struct Solved {
    /// One step per target, plus any retract moves.
    pub steps: Vec<Step>,
    /// Decisions that are not obvious, in path order.
    pub decisions: Vec<Noted>,
    /// Points added by linearization.
    pub inserted: usize,
    /// The segments linearization left out of tolerance.
    pub unsettled: crate::linearize::Unsettled,
}

/// Why two consecutive feed points cannot be joined by one continuous motion.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Jump {
    /// The other solution branch, away from the pole: the table would turn by about half a turn
    /// while the tool barely moves on the part.
    BranchChange,
    /// A rotary axis reaches the end of its travel: the equivalent angle nearest the previous
    /// one lies outside it.
    TravelLimit,
}

impl fmt::Display for Jump {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Jump::BranchChange => "the solution branch changes away from the pole",
            Jump::TravelLimit => "a rotary axis reaches the end of its travel",
        })
    }
}

/// Why a path cannot be solved.
#[derive(Clone, Debug, PartialEq, thiserror::Error, miette::Diagnostic)]
pub enum SolveError {
    /// The machine cannot take this tool axis at all.
    #[error("the tool axis ({i:.6}, {j:.6}, {k:.6}) is out of reach of {machine}")]
    #[diagnostic(code(kin::unreachable), help("{help}"))]
    Unreachable {
        /// The CL statement.
        #[label("this pose")]
        span: Span,
        /// Tool axis.
        i: f64,
        /// Tool axis.
        j: f64,
        /// Tool axis.
        k: f64,
        /// The machine.
        machine: String,
        /// What can be done.
        help: String,
    },
    /// Every solution leaves an axis's travel.
    #[error("no solution within the travel of {machine}: {detail}")]
    #[diagnostic(code(kin::travel), help("{help}"))]
    OutOfTravel {
        /// The CL statement.
        #[label("this pose")]
        span: Span,
        /// Which axis goes where.
        detail: String,
        /// The machine.
        machine: String,
        /// What can be done: moving the part helps only where a linear axis leaves its travel.
        help: String,
    },
    /// No continuous sequence of solutions exists here.
    #[error("no continuous solution ({cause}): {axis} would jump from {from:.3}° to {to:.3}° during a feed move")]
    #[diagnostic(
        code(kin::discontinuity),
        help(
            "a retract–reorient–re-engage is possible: `--on-discontinuity retract` (or `on_discontinuity: {{retract: 50 mm}}` in the machine)"
        )
    )]
    Discontinuity {
        /// The CL statement of the move.
        #[label("this move")]
        span: Span,
        /// The axis.
        axis: String,
        /// From (degrees).
        from: f64,
        /// To (degrees).
        to: f64,
        /// Why the motion cannot be continuous.
        cause: Jump,
    },
    /// The axis values solved for a pose do not put the tool tip on it: an error of the
    /// kinematics, never written as motion.
    #[error("the axis values solved for this pose put the tool tip {off:.6} mm away from it on {machine}")]
    #[diagnostic(
        code(kin::tip_off),
        help(
            "nothing is written: the machine's kinematics (a plugin's, or postpro's own) solved this pose wrongly; please report it with the CL file and the machine"
        )
    )]
    TipOff {
        /// The CL statement.
        #[label("this pose")]
        span: Span,
        /// How far the tip is from the pose (mm).
        off: f64,
        /// The machine.
        machine: String,
    },
}

/// The policy in two passes over the targets, so that a path of any length is solved with memory
/// that does not grow with it beyond a few bits per target:
///
/// 1. [`BranchGraph`] solves every target and runs the dynamic programme forward, keeping of the
///    whole path only the branch graph (for each regular target, which state each of its states
///    came from) and a summary of each singular run; [`BranchGraph::finish`] walks it back into a
///    [`Choice`]: the state of every regular target.
/// 2. [`Placer`] solves the targets again, in the same order, and turns each into its step with
///    the chosen state, handing steps and decisions on as they are made (to the linearization,
///    the motion program).
///
/// [`choose`] runs both over a slice of targets.
pub fn choose(
    kin: &dyn Kinematics,
    targets: &[Target],
    policy: &Policy,
    start: Option<&Joints>,
) -> Result<Solved, SolveError> {
    let mut graph = BranchGraph::new(kin, policy, start);
    for t in targets {
        graph.push(t)?;
    }
    let mut placer = Placer::new(kin, policy, start, graph.finish());
    let mut out = Collected::default();
    for t in targets {
        placer.push(kin, t, &mut out)?;
    }
    Ok(Solved { steps: out.steps, decisions: out.decisions, inserted: 0, unsettled: Default::default() })
}

/// Where the steps of the policy (or of the linearization) go, in path order: each decision
/// before the step it concerns.
pub trait StepSink {
    /// The next step.
    fn step(&mut self, step: Step);
    /// A decision about the step with index `noted.step` (the next one, or one of the next).
    fn decision(&mut self, noted: Noted);
}

/// Steps and decisions collected in vectors.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Collected {
    /// The steps.
    pub steps: Vec<Step>,
    /// The decisions.
    pub decisions: Vec<Noted>,
}

impl StepSink for Collected {
    fn step(&mut self, step: Step) {
        self.steps.push(step);
    }

    fn decision(&mut self, noted: Noted) {
        self.decisions.push(noted);
    }
}

/// What both passes know of the machine and the policy.
struct Rules<'a> {
    machine: &'a postpro_machine::model::Machine,
    policy: &'a Policy,
    rotary: Vec<usize>,
    linear: Vec<usize>,
    home: Joints,
    unwinding: Unwinding,
    /// The preferred sign of an axis.
    preference: Option<(usize, f64)>,
}

impl<'a> Rules<'a> {
    fn new(machine: &'a postpro_machine::model::Machine, policy: &'a Policy) -> Rules<'a> {
        let rotary: Vec<usize> =
            (0..machine.axes.len()).filter(|&i| machine.axes[i].kind == AxisKind::Rotary).collect();
        let linear: Vec<usize> =
            (0..machine.axes.len()).filter(|&i| machine.axes[i].kind == AxisKind::Linear).collect();
        let mut home = Joints::zeros(machine.axes.len());
        for (i, a) in machine.axes.iter().enumerate() {
            home[i] = a.home;
        }
        let unwinding = Unwinding::new(machine, &rotary, home, policy.unwind);
        let preference = match &policy.branch {
            BranchPreference::Closest => None,
            BranchPreference::Positive(l) => machine.axis_index(l).map(|i| (i, 1.0)),
            BranchPreference::Negative(l) => machine.axis_index(l).map(|i| (i, -1.0)),
        };
        Rules { machine, policy, rotary, linear, home, unwinding, preference }
    }

    fn unreachable(&self, t: &Target) -> SolveError {
        let a = t.pose.axis;
        let help = if self.rotary.len() < 2 {
            "a 3- or 4-axis machine cannot tilt the tool this way".to_string()
        } else {
            format!(
                "the rotary axes of {} cannot point the tool this way: choose another orientation of the part in the CAM system, or another machine",
                self.machine.name
            )
        };
        SolveError::Unreachable { span: t.span, i: a.x, j: a.y, k: a.z, machine: self.machine.name.clone(), help }
    }

    /// Moving the part on the table brings a linear axis back within its travel, never a rotary
    /// one.
    fn travel_help(&self, axes: &[usize]) -> String {
        if axes.iter().all(|&i| self.machine.axes[i].kind == AxisKind::Rotary) {
            "a rotary axis beyond its travel is not fixed by moving the part: choose another orientation of the part \
             in the CAM system (a set-up from below is turned over by hand and posted apart), or another machine"
                .to_string()
        } else {
            "move the part on the table (part_origin), or choose another machine".to_string()
        }
    }

    fn out_of_travel(&self, t: &Target, reasons: &[(usize, f64)]) -> SolveError {
        let mut detail: Vec<String> = reasons.iter().map(|&r| self.describe(r)).collect();
        detail.dedup();
        SolveError::OutOfTravel {
            span: t.span,
            detail: detail.join("; "),
            machine: self.machine.name.clone(),
            help: self.travel_help(&reasons.iter().map(|r| r.0).collect::<Vec<_>>()),
        }
    }

    /// The linear axes of a solution within their travels (they do not change with unwinding),
    /// or the axis and value that leave it.
    fn linear_ok(&self, c: &Joints) -> Result<(), (usize, f64)> {
        match self.linear.iter().find(|&&l| !self.machine.axes[l].travel.contains(c[l])) {
            Some(&l) => Err((l, c[l])),
            None => Ok(()),
        }
    }

    /// A solution with its rotary angles at the turn nearest to `prev`, within their travels; of
    /// two equally near (half a turn either way), the one nearer home.
    fn unwound(&self, c: &Joints, prev: &Joints) -> Result<Joints, (usize, f64)> {
        let mut j = *c;
        for &r in &self.rotary {
            let travel = &self.machine.axes[r].travel;
            let v = unwrap_near(c[r], prev[r], travel).ok_or((r, c[r]))?;
            let other = v - TAU * (v - prev[r]).signum();
            let tie = ((v - prev[r]).abs() - PI).abs() < 1e-9;
            let home = self.home[r];
            j[r] = if tie && travel.contains(other) && (other - home).abs() < (v - home).abs() { other } else { v };
        }
        Ok(j)
    }

    fn realize(&self, c: &Joints, prev: &Joints) -> Result<Joints, (usize, f64)> {
        self.linear_ok(c).and_then(|()| self.unwound(c, prev))
    }

    fn describe(&self, (axis, value): (usize, f64)) -> String {
        let a = &self.machine.axes[axis];
        out_of_travel(&a.letter, value, &a.travel, a.kind == AxisKind::Rotary)
    }

    fn preferred(&self, j: &Joints) -> bool {
        self.preference.is_none_or(|(axis, sign)| j[axis] * sign >= -1e-9)
    }

    fn travel_cost(&self, a: &Joints, b: &Joints) -> f64 {
        self.rotary.iter().map(|&r| (a[r] - b[r]).abs()).sum::<f64>()
    }

    /// The free axis when every solution lies within the singular cone (the target is singular).
    fn free_axis(&self, sols: &Solutions) -> Option<usize> {
        let cone = self.policy.singular_cone;
        let free = |s: &crate::solver::Solution| s.pole.filter(|&(_, d)| d < cone).map(|(axis, _)| axis);
        sols.iter().map(free).reduce(|a, b| a.and(b)).flatten()
    }

    /// The jump from the state `from` (joints, branch; `u8::MAX` at the start) to `j` on branch
    /// `branch`, where the move between them is a feed move between consecutive regular targets
    /// (`consecutive`) that passes the pole or not.
    fn jump(
        &self,
        from: (&Joints, u8),
        (j, branch): (&Joints, u8),
        consecutive: bool,
        pole_passage: bool,
    ) -> Option<Jump> {
        let switch = from.1 != u8::MAX && from.1 != branch;
        if !consecutive {
            None
        } else if self.rotary.iter().any(|&r| (j[r] - from.0[r]).abs() > HALF_TURN) {
            Some(Jump::TravelLimit)
        } else if switch && !pole_passage {
            Some(Jump::BranchChange)
        } else {
            None
        }
    }

    /// The value of endless axis `axis` after the unwinding at a rapid.
    fn unwound_at_rapid(&self, axis: usize, value: f64) -> f64 {
        let mut j = self.home;
        j[axis] = value;
        self.unwinding.apply(&mut j);
        j[axis]
    }
}

/// A state of the dynamic programme: a solution at its unwound turn, the discontinuities and the
/// cost of the best path to it, the state it came from and the jump (if any) on the way from it.
/// An infinite cost marks an empty state.
#[derive(Clone, Copy, Debug)]
struct Node {
    jumps: u32,
    cost: f64,
    pred: u8,
    joints: Joints,
    branch: u8,
}

impl Node {
    const EMPTY: Node = Node { jumps: u32::MAX, cost: f64::INFINITY, pred: 0, joints: Joints::EMPTY, branch: 0 };

    fn is_live(&self) -> bool {
        self.cost.is_finite()
    }

    /// Fewer discontinuities first, then the lower cost.
    fn better_than(&self, other: &Node) -> bool {
        (self.jumps, self.cost) < (other.jumps, other.cost)
    }
}

fn best_state(layer: &[Node; 2]) -> usize {
    usize::from(layer[1].better_than(&layer[0]))
}

/// The smallest distance (rad) from a pose's solutions to the pole of their free axis; infinite
/// when no solution has one.
pub(crate) fn pole_distance(sols: &Solutions) -> f64 {
    sols.iter().filter_map(|s| s.pole.map(|(_, d)| d)).fold(f64::INFINITY, f64::min)
}

/// Below this distance from the pole (rad) a tool axis is on it.
const ON_POLE: f64 = 1e-9;

/// A singular run: consecutive targets whose every solution lies within the singular cone, where
/// the free axis is carried, not computed. What the second pass needs to carry it.
#[derive(Clone, Debug, PartialEq)]
struct Run {
    /// Targets in the run.
    points: usize,
    /// The free axis (of the run's first target).
    free: u8,
    /// The free axis's value at the regular target after the run, in each of its states
    /// (`None`: the run ends the path).
    after: Option<[f64; 2]>,
    /// A target of the run is reached at rapid.
    has_rapid: bool,
    /// How the swing to `after` is shared among the moves.
    swing: Swing,
}

/// How the free axis's swing over a singular run is shared among the moves into `run..=end` (the
/// run and the regular target after it; the move into the first target of the path does not
/// count): see [`Placer`].
#[derive(Clone, Copy, Debug, PartialEq)]
enum Swing {
    /// A move into the run is a rapid: all of it at the last one (target index), away from the
    /// part.
    AtRapid(usize),
    /// Turning by Δ on a move whose tool axes lie at most ε from the pole moves the tool axis
    /// off the programmed one by about ε·Δ, so each move turns in inverse proportion to its ε
    /// (the largest deviation is then least): moves on the pole itself (ε = 0) take it all, in
    /// proportion to their length, and leave the tool axis exact.
    Weighted {
        /// Some move lies on the pole.
        on_pole: bool,
        /// The sum of the weights.
        total: f64,
    },
}

/// The move into target `index` of a singular run that starts at target `start`, from
/// `previous` (its tip and pole distance) to `tip` (at pole distance `pole`), as the swing counts
/// it: the larger pole distance of its two ends and its tip length. `None` for the move into the
/// first target of the path, which does not count.
fn run_move(
    start: usize,
    index: usize,
    previous: Option<(nalgebra::Point3<f64>, f64)>,
    tip: nalgebra::Point3<f64>,
    pole: f64,
) -> Option<(f64, f64)> {
    let (from, from_pole) = previous.filter(|_| index >= start.max(1))?;
    Some((from_pole.max(pole), (tip - from).norm()))
}

/// The weight of a move of a singular run in [`Swing::Weighted`]: `eps` the larger pole
/// distance of its two ends, `length` its tip length.
fn swing_weight(eps: f64, length: f64, on_pole: bool) -> f64 {
    match (on_pole, eps < ON_POLE) {
        (true, true) => length + 1e-9,
        (true, false) => 0.0,
        (false, _) => 1.0 / eps,
    }
}

/// The first pass's choice: the state of every regular target and how each singular run is
/// carried.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Choice {
    /// Per target, whether it is regular.
    regular: Bits,
    /// Per regular target, its state (0 or 1).
    states: Bits,
    /// Per regular target, whether the move into it passes the pole (a branch change there is
    /// then no discontinuity): found once, by the first pass.
    pole_passages: Bits,
    runs: Vec<Run>,
}

mod graph;
mod place;

pub use graph::BranchGraph;
pub use place::Placer;

/// Whether the tool axis, moving along the great circle from pose `a` to pose `b` (each given
/// with its distance from the pole), passes within `cone` of the pole: a branch change between
/// them is then a pole passage, not a discontinuity. The distance changes by at most the angle
/// moved, so most pairs are decided at once; otherwise [`nearest_the_pole`] searches the arc.
pub(crate) fn passes_pole(
    kin: &dyn Kinematics,
    a: (&Pose, f64),
    b: (&Pose, f64),
    cone: f64,
    probe: &mut Solutions,
) -> bool {
    let ((pa, da), (pb, db)) = (a, b);
    if da < cone || db < cone {
        return true;
    }
    let span = pa.axis.angle(&pb.axis);
    if (da + db - span) / 2.0 >= cone {
        return false;
    }
    nearest_the_pole(kin, (pa, pb), cone, probe).1 < cone
}

/// Where the tool axis, moving along the great circle from pose `a` to pose `b`, comes nearest the
/// pole: `(t, distance)`, `t` in `0..=1` along the arc. The arc is sampled at steps of `step`
/// (at most 4096) and the smallest distance refined by golden-section search between the
/// neighbours of the best sample.
pub(crate) fn nearest_the_pole(
    kin: &dyn Kinematics,
    (pa, pb): (&Pose, &Pose),
    step: f64,
    probe: &mut Solutions,
) -> (f64, f64) {
    let mut distance = |t: f64| {
        let pose = Pose { tip: pa.tip, axis: slerp(&pa.axis, &pb.axis, t) };
        kin.inverse(&pose, probe);
        pole_distance(probe)
    };
    let n = ((pa.axis.angle(&pb.axis) / step).ceil() as usize).clamp(2, 4096);
    let (mut best, mut best_t) = (f64::INFINITY, 0.0);
    for k in 0..=n {
        let t = k as f64 / n as f64;
        let d = distance(t);
        if d < best {
            (best, best_t) = (d, t);
        }
    }
    let g = (5f64.sqrt() - 1.0) / 2.0;
    let (mut lo, mut hi) = ((best_t - 1.0 / n as f64).max(0.0), (best_t + 1.0 / n as f64).min(1.0));
    while hi - lo > 1e-9 {
        let (x1, x2) = (hi - g * (hi - lo), lo + g * (hi - lo));
        let (d1, d2) = (distance(x1), distance(x2));
        if d1 < best {
            (best, best_t) = (d1, x1);
        }
        if d2 < best {
            (best, best_t) = (d2, x2);
        }
        if d1 < d2 { hi = x2 } else { lo = x1 }
    }
    (best_t, best)
}

/// The unwinding of endless axes at rapids: beyond the allowed winding from home, the
/// equivalent angle nearest home.
struct Unwinding {
    /// Endless rotary axes and their home values.
    axes: Vec<(usize, f64)>,
    /// The winding allowed (rad); `None`: never unwound.
    limit: Option<f64>,
}

impl Unwinding {
    fn new(machine: &postpro_machine::model::Machine, rotary: &[usize], home: Joints, turns: Option<f64>) -> Unwinding {
        let axes =
            rotary.iter().filter(|&&r| machine.axes[r].travel == Travel::Endless).map(|&r| (r, home[r])).collect();
        Unwinding { axes, limit: turns.map(|t| t * TAU) }
    }

    /// Unwinds the axes of `joints` wound beyond the limit.
    fn apply(&self, joints: &mut Joints) {
        let Some(limit) = self.limit else { return };
        for &(r, home) in &self.axes {
            if (joints[r] - home).abs() > limit {
                joints[r] = unwrap_near(joints[r], home, &Travel::Endless).unwrap_or(joints[r]);
            }
        }
    }
}

/// `value` plus whole turns: the one nearest to `near` within the travel.
fn unwrap_near(value: f64, near: f64, travel: &Travel) -> Option<f64> {
    let v = value + whole_turns(near - value);
    if travel.contains(v) {
        return Some(v);
    }
    // The nearest turn is outside: the next nearer one inside, if any (`v` is within π of `near`).
    let (first, second) = if v < near { (v + TAU, v - TAU) } else { (v - TAU, v + TAU) };
    [first, second, first + (first - v), second + (second - v)].into_iter().find(|w| travel.contains(*w))
}

fn out_of_travel(letter: &str, value: f64, travel: &Travel, rotary: bool) -> String {
    match (*travel, rotary) {
        (Travel::Limited { min, max }, true) => {
            format!("{letter} {:.3}° (travel {:.3}°…{:.3}°)", value.to_degrees(), min.to_degrees(), max.to_degrees())
        }
        (Travel::Limited { min, max }, false) => format!("{letter} {value:.3} mm (travel {min:.3}…{max:.3} mm)"),
        (Travel::Endless, _) => format!("{letter} {value:.3}"),
    }
}

#[cfg(test)]
mod tests;
