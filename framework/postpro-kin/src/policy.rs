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
use postpro_machine::model::{AxisKind, BranchPreference, OnDiscontinuity, PathChoice, PolicyDefaults, Travel};

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
    preferred: bool,
    jump: Option<Jump>,
}

impl Node {
    const EMPTY: Node = Node {
        jumps: u32::MAX,
        cost: f64::INFINITY,
        pred: 0,
        joints: Joints::EMPTY,
        branch: 0,
        preferred: false,
        jump: None,
    };

    fn is_live(&self) -> bool {
        self.cost.is_finite()
    }

    /// Fewer discontinuities first, then the lower cost.
    fn better_than(&self, other: &Node) -> bool {
        (self.jumps, self.cost) < (other.jumps, other.cost)
    }
}

/// The smallest distance (rad) from a pose's solutions to the pole of their free axis; infinite
/// when no solution has one.
fn pole_distance(sols: &Solutions) -> f64 {
    sols.iter().filter_map(|s| s.pole.map(|(_, d)| d)).fold(f64::INFINITY, f64::min)
}

/// Chooses one solution per target. `start` is where the machine is before the first target
/// (its home position when `None`).
pub fn choose(
    kin: &dyn Kinematics,
    targets: &[Target],
    policy: &Policy,
    start: Option<&Joints>,
) -> Result<Solved, SolveError> {
    let machine = kin.machine();
    let rotary: Vec<usize> = (0..machine.axes.len()).filter(|&i| machine.axes[i].kind == AxisKind::Rotary).collect();
    let linear: Vec<usize> = (0..machine.axes.len()).filter(|&i| machine.axes[i].kind == AxisKind::Linear).collect();
    let mut home = Joints::zeros(machine.axes.len());
    for (i, a) in machine.axes.iter().enumerate() {
        home[i] = a.home;
    }
    let start = start.copied().unwrap_or(home);
    let unwinding = Unwinding::new(machine, &rotary, home, policy.unwind);
    let preference = match &policy.branch {
        BranchPreference::Closest => None,
        BranchPreference::Positive(l) => machine.axis_index(l).map(|i| (i, 1.0)),
        BranchPreference::Negative(l) => machine.axis_index(l).map(|i| (i, -1.0)),
    };

    let unreachable = |t: &Target| {
        let a = t.pose.axis;
        let help = if rotary.len() < 2 {
            "a 3- or 4-axis machine cannot tilt the tool this way".to_string()
        } else {
            format!(
                "the rotary axes of {} cannot point the tool this way: choose another orientation of the part in the CAM system, or another machine",
                machine.name
            )
        };
        SolveError::Unreachable { span: t.span, i: a.x, j: a.y, k: a.z, machine: machine.name.clone(), help }
    };
    // Moving the part on the table brings a linear axis back within its travel, never a rotary one.
    let travel_help = |axes: &[usize]| {
        if axes.iter().all(|&i| machine.axes[i].kind == AxisKind::Rotary) {
            "a rotary axis beyond its travel is not fixed by moving the part: choose another orientation of the part \
             in the CAM system (a set-up from below is turned over by hand and posted apart), or another machine"
                .to_string()
        } else {
            "move the part on the table (part_origin), or choose another machine".to_string()
        }
    };
    // The linear axes of a solution within their travels (they do not change with unwinding),
    // or the axis and value that leave it.
    let linear_ok = |c: &Joints| -> Result<(), (usize, f64)> {
        match linear.iter().find(|&&l| !machine.axes[l].travel.contains(c[l])) {
            Some(&l) => Err((l, c[l])),
            None => Ok(()),
        }
    };
    // A solution with its rotary angles at the turn nearest to `prev`, within their travels; of
    // two equally near (half a turn either way), the one nearer home.
    let unwound = |c: &Joints, prev: &Joints| -> Result<Joints, (usize, f64)> {
        let mut j = *c;
        for &r in &rotary {
            let travel = &machine.axes[r].travel;
            let v = unwrap_near(c[r], prev[r], travel).ok_or((r, c[r]))?;
            let other = v - TAU * (v - prev[r]).signum();
            let tie = ((v - prev[r]).abs() - PI).abs() < 1e-9;
            j[r] =
                if tie && travel.contains(other) && (other - home[r]).abs() < (v - home[r]).abs() { other } else { v };
        }
        Ok(j)
    };
    let realize = |c: &Joints, prev: &Joints| linear_ok(c).and_then(|()| unwound(c, prev));
    let describe = |(axis, value): (usize, f64)| {
        let a = &machine.axes[axis];
        out_of_travel(&a.letter, value, &a.travel, a.kind == AxisKind::Rotary)
    };
    let preferred = |j: &Joints| preference.is_none_or(|(axis, sign)| j[axis] * sign >= -1e-9);
    let travel_cost = |a: &Joints, b: &Joints| rotary.iter().map(|&r| (a[r] - b[r]).abs()).sum::<f64>();

    // 1. Every solution of every target, and dynamic programming (or greedy) over the regular
    //    ones; the singular targets (every solution within the cone) are filled in afterwards.
    let mut regular: Vec<u32> = Vec::with_capacity(targets.len());
    let mut free_axis_of_singular: Vec<(u32, u8)> = Vec::new();
    let mut pole: Vec<f64> = Vec::with_capacity(targets.len());
    let mut dp: Vec<[Node; 2]> = Vec::with_capacity(targets.len());
    let mut sols = Solutions::new();
    let mut probe = Solutions::new();
    let origin = [
        Node { jumps: 0, cost: 0.0, pred: 0, joints: start, branch: u8::MAX, preferred: true, jump: None },
        Node::EMPTY,
    ];
    // A rapid among the targets since the previous regular one (this one included).
    let mut rapid_since = false;
    for (i, t) in targets.iter().enumerate() {
        kin.inverse(&t.pose, &mut sols);
        if sols.is_empty() {
            return Err(unreachable(t));
        }
        pole.push(pole_distance(&sols));
        rapid_since |= t.rapid;
        let free =
            |s: &crate::solver::Solution| s.pole.filter(|&(_, d)| d < policy.singular_cone).map(|(axis, _)| axis);
        if let Some(f) = sols.iter().map(free).reduce(|a, b| a.and(b)).flatten() {
            free_axis_of_singular.push((i as u32, f as u8));
            continue;
        }
        // Consecutive feed points: here a branch change away from the pole, or a turn beyond
        // the nearest one, is a discontinuity.
        let previous_target = regular.last().map(|&p| p as usize).filter(|&p| p + 1 == i && !rapid_since);
        let pole_passage = previous_target.is_some_and(|p| {
            passes_pole(kin, (&targets[p].pose, pole[p]), (&t.pose, pole[i]), policy.pole_passage, &mut probe)
        });
        let mut layer = [Node::EMPTY; 2];
        let mut reasons: [Option<(usize, f64)>; 4] = [None; 4];
        let previous = dp.last().unwrap_or(&origin);
        for (s, cand) in sols.iter().enumerate() {
            if let Err(reason) = linear_ok(&cand.joints) {
                reasons[2 * s] = Some(reason);
                continue;
            }
            for (p, node) in previous.iter().enumerate().filter(|(_, n)| n.is_live()) {
                match unwound(&cand.joints, &node.joints) {
                    Ok(mut j) => {
                        let switch = node.branch != u8::MAX && node.branch != cand.branch;
                        let jump = match previous_target {
                            None => None,
                            Some(_) if rotary.iter().any(|&r| (j[r] - node.joints[r]).abs() > HALF_TURN) => {
                                Some(Jump::TravelLimit)
                            }
                            Some(_) if switch && !pole_passage => Some(Jump::BranchChange),
                            Some(_) => None,
                        };
                        let pref = preferred(&j);
                        // The travel before unwinding: the whole turns taken off at a rapid are
                        // the policy's, and must not make the other branch look cheaper.
                        let cost = node.cost
                            + travel_cost(&node.joints, &j)
                            + if switch { SWITCH_COST } else { 0.0 }
                            + if pref { 0.0 } else { OFF_PREFERENCE_COST };
                        if rapid_since {
                            unwinding.apply(&mut j);
                        }
                        let next = Node {
                            jumps: node.jumps + u32::from(jump.is_some()),
                            cost,
                            pred: p as u8,
                            joints: j,
                            branch: cand.branch,
                            preferred: pref,
                            jump,
                        };
                        if next.better_than(&layer[s]) {
                            layer[s] = next;
                        }
                    }
                    Err(reason) => reasons[2 * s + p] = Some(reason),
                }
            }
        }
        if !layer.iter().any(Node::is_live) {
            let reasons: Vec<(usize, f64)> = reasons.into_iter().flatten().collect();
            let mut detail: Vec<String> = reasons.iter().copied().map(describe).collect();
            detail.dedup();
            return Err(SolveError::OutOfTravel {
                span: t.span,
                detail: detail.join("; "),
                machine: machine.name.clone(),
                help: travel_help(&reasons.iter().map(|r| r.0).collect::<Vec<_>>()),
            });
        }
        if policy.choice == PathChoice::Greedy {
            // Keep only the best: the next point is chosen from it alone.
            let best = best_state(&layer);
            layer[1 - best] = Node::EMPTY;
        }
        dp.push(layer);
        regular.push(i as u32);
        rapid_since = false;
    }
    // Back from the best last state: the chosen state of every regular target.
    let mut states = vec![0u8; dp.len()];
    if let Some(last) = dp.last() {
        let mut s = best_state(last);
        for k in (0..dp.len()).rev() {
            states[k] = s as u8;
            s = usize::from(dp[k][s].pred);
        }
    }
    let node = |k: usize| Some(dp[k][usize::from(states[k])]).filter(Node::is_live);

    // 2. The steps in path order: regular targets from the programme, singular runs with the
    //    free axis carried; discontinuities, branch switches and preference handled as each step
    //    is added.
    let mut out = Output {
        kin,
        rotary: &rotary,
        policy,
        // Room for a few retracts without reallocating the steps.
        steps: Vec::with_capacity(targets.len() + targets.len() / 64 + 16),
        decisions: Vec::new(),
    };
    let step =
        |t: &Target, joints: Joints| Step { joints, pose: t.pose, rapid: t.rapid, span: t.span, kind: StepKind::Cl };
    let (mut k, mut sg) = (0usize, 0usize);
    // The previous regular target: its index, chosen joints and branch.
    let mut previous_regular: Option<(usize, Joints, u8)> = None;
    let mut off_preference = false;
    let mut i = 0;
    while i < targets.len() {
        if regular.get(k).is_some_and(|&r| r as usize == i) {
            let n = node(k).ok_or_else(|| unreachable(&targets[i]))?;
            let at = out.push(step(&targets[i], n.joints), n.jump)?;
            if let Some((p, joints, b)) = previous_regular
                && b != n.branch
                && p + 1 == i
                && n.jump.is_none()
            {
                let decision = Decision::BranchSwitch { axes: out.moves(&joints, &n.joints) };
                out.decisions.push(Noted { step: at, span: targets[i].span, decision });
            }
            if !n.preferred
                && !off_preference
                && let Some((axis, _)) = preference
            {
                let decision = Decision::OffPreference { axis: machine.axes[axis].letter.clone() };
                out.decisions.push(Noted { step: at, span: targets[i].span, decision });
            }
            off_preference = !n.preferred;
            previous_regular = Some((i, n.joints, n.branch));
            i += 1;
            k += 1;
            continue;
        }
        // A singular run: targets i..end, then the regular target `end` if there is one.
        let run = i;
        while i < targets.len() && regular.get(k).is_none_or(|&r| r as usize != i) {
            i += 1;
        }
        let free = usize::from(free_axis_of_singular[sg].1);
        sg += i - run;
        let from = out.steps.last().map_or(start[free], |s| s.joints[free]);
        let after = (k < regular.len()).then(|| node(k)).flatten().map(|n| n.joints[free]);
        let fractions = swing_fractions(targets, &pole, run, i, after.is_some());
        let mut value = from;
        let mut first_step = None;
        for (t, u) in targets[run..i].iter().zip(&fractions) {
            if let Some(to) = after {
                value = from + (to - from) * u;
            }
            let prev = out.steps.last().map_or(start, |s| s.joints);
            let held = kin.inverse_holding(&t.pose, free, value).ok_or_else(|| unreachable(t))?;
            let mut j = realize(&held, &prev).map_err(|reason| SolveError::OutOfTravel {
                span: t.span,
                detail: describe(reason),
                machine: machine.name.clone(),
                help: travel_help(&[reason.0]),
            })?;
            j[free] = value;
            if after.is_none() && t.rapid {
                // No regular point follows to bring the winding back: unwind here.
                unwinding.apply(&mut j);
                value = j[free];
            }
            let at = out.push(step(t, j), None)?;
            first_step.get_or_insert(at);
        }
        out.decisions.push(Noted {
            step: first_step.unwrap_or(out.steps.len()),
            span: targets[run].span,
            decision: Decision::SingularHold {
                axis: machine.axes[free].letter.clone(),
                from: from.to_degrees(),
                to: after.unwrap_or(value).to_degrees(),
                points: i - run,
            },
        });
    }
    let Output { steps, mut decisions, .. } = out;
    decisions.sort_by_key(|d| d.step);
    Ok(Solved { steps, decisions, inserted: 0 })
}

/// For each target of the singular run `run..end`, the share of the free axis's swing (from its
/// value before the run to its value at `end`) done on reaching it:
/// - if a move into `run..=end` is a rapid, all of it at the last such rapid (the tool is away
///   from the part): a 3-axis or vertical 3+2 pass between rapids keeps the free axis;
/// - otherwise turning by Δ on a move whose tool axes lie at most ε from the pole moves the tool
///   axis off the programmed one by about ε·Δ, so each move turns in inverse proportion to its ε
///   (the largest deviation is then least): moves on the pole itself (ε = 0, a vertical pass
///   reached at feed) take it all, in proportion to their length, and leave the tool axis exact;
///   the tilting moves into and out of such a pass keep the free axis.
///
/// The move into the first target of the path (from wherever the machine is) is not counted.
/// Without a regular target after the run (`has_after` false) nothing turns.
fn swing_fractions(targets: &[Target], pole: &[f64], run: usize, end: usize, has_after: bool) -> Vec<f64> {
    /// Below this distance from the pole (rad) a tool axis is on it.
    const ON_POLE: f64 = 1e-9;
    let count = end - run;
    if !has_after {
        return vec![0.0; count];
    }
    let moves = run.max(1)..=end;
    if let Some(m) = moves.clone().rev().find(|&m| targets[m].rapid) {
        return (run..end).map(|n| if n >= m { 1.0 } else { 0.0 }).collect();
    }
    let eps = |m: usize| pole[m - 1].max(pole[m]);
    let on_pole = moves.clone().any(|m| eps(m) < ON_POLE);
    let weight = |m: usize| match (moves.contains(&m), on_pole) {
        (false, _) => 0.0,
        (true, true) if eps(m) < ON_POLE => (targets[m].pose.tip - targets[m - 1].pose.tip).norm() + 1e-9,
        (true, true) => 0.0,
        (true, false) => 1.0 / eps(m),
    };
    let weights: Vec<f64> = (run..=end).map(weight).collect();
    let total: f64 = weights.iter().sum();
    let mut done = 0.0;
    weights[..count]
        .iter()
        .map(|w| {
            done += w;
            if total > 0.0 { done / total } else { 0.0 }
        })
        .collect()
}

/// Whether the tool axis, moving along the great circle from pose `a` to pose `b` (each given
/// with its distance from the pole), passes within `cone` of the pole: a branch change between
/// them is then a pole passage, not a discontinuity. The distance changes by at most the angle
/// moved, so most pairs are decided at once; otherwise the arc is sampled at steps of the cone
/// and the smallest distance refined by golden-section search.
fn passes_pole(kin: &dyn Kinematics, a: (&Pose, f64), b: (&Pose, f64), cone: f64, probe: &mut Solutions) -> bool {
    let ((pa, da), (pb, db)) = (a, b);
    if da < cone || db < cone {
        return true;
    }
    let span = pa.axis.angle(&pb.axis);
    if (da + db - span) / 2.0 >= cone {
        return false;
    }
    let mut distance = |t: f64| {
        let pose = Pose { tip: pa.tip, axis: slerp(&pa.axis, &pb.axis, t) };
        kin.inverse(&pose, probe);
        pole_distance(probe)
    };
    let n = ((span / cone).ceil() as usize).clamp(2, 4096);
    let (mut best, mut best_t) = (f64::INFINITY, 0.0);
    for k in 1..n {
        let t = k as f64 / n as f64;
        let d = distance(t);
        if d < best {
            (best, best_t) = (d, t);
        }
    }
    if best < cone {
        return true;
    }
    // Golden-section search between the neighbours of the best sample.
    let g = (5f64.sqrt() - 1.0) / 2.0;
    let (mut lo, mut hi) = ((best_t - 1.0 / n as f64).max(0.0), (best_t + 1.0 / n as f64).min(1.0));
    while hi - lo > 1e-9 {
        let (x1, x2) = (hi - g * (hi - lo), lo + g * (hi - lo));
        let (d1, d2) = (distance(x1), distance(x2));
        best = best.min(d1).min(d2);
        if d1 < d2 { hi = x2 } else { lo = x1 }
    }
    best < cone
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

/// The steps being built, and the decisions about them.
struct Output<'a> {
    kin: &'a dyn Kinematics,
    rotary: &'a [usize],
    policy: &'a Policy,
    steps: Vec<Step>,
    decisions: Vec<Noted>,
}

impl Output<'_> {
    /// The rotary axes from `a` to `b`, in degrees.
    fn moves(&self, a: &Joints, b: &Joints) -> AxisMoves {
        let axes = &self.kin.machine().axes;
        self.rotary.iter().map(|&r| (axes[r].letter.clone(), a[r].to_degrees(), b[r].to_degrees())).collect()
    }

    /// The rotary axis that changes most from `a` to `b`, and by how much (rad).
    fn largest_turn(&self, a: &Joints, b: &Joints) -> Option<(usize, f64)> {
        self.rotary.iter().map(|&r| (r, (b[r] - a[r]).abs())).max_by(|x, y| x.1.total_cmp(&y.1))
    }

    /// Adds a step and returns its index. A `jump` (a discontinuity from the previous step) is an
    /// error, or is preceded by a retract above the previous point and a reorientation above this
    /// one (this step then re-engages). A feed step that turns a rotary axis by more than
    /// `max_rotary_step` is noted as a warning; a rapid that unwinds an endless axis is noted.
    fn push(&mut self, mut step: Step, jump: Option<Jump>) -> Result<usize, SolveError> {
        let Some(&prev) = self.steps.last() else {
            self.steps.push(step);
            return Ok(0);
        };
        let axes = &self.kin.machine().axes;
        if let Some(cause) = jump {
            match self.policy.on_discontinuity {
                OnDiscontinuity::Error => {
                    let r = match cause {
                        Jump::TravelLimit => {
                            self.rotary.iter().copied().find(|&r| (step.joints[r] - prev.joints[r]).abs() > HALF_TURN)
                        }
                        Jump::BranchChange => self.largest_turn(&prev.joints, &step.joints).map(|(r, _)| r),
                    }
                    .unwrap_or(self.rotary[0]);
                    return Err(SolveError::Discontinuity {
                        span: step.span,
                        axis: axes[r].letter.clone(),
                        from: prev.joints[r].to_degrees(),
                        to: step.joints[r].to_degrees(),
                        cause,
                    });
                }
                OnDiscontinuity::Retract { clearance } => {
                    let up =
                        |s: &Step| Pose { tip: s.pose.tip + s.pose.axis.into_inner() * clearance, axis: s.pose.axis };
                    let (a, b) = (up(&prev), up(&step));
                    self.steps.push(Step {
                        joints: self.kin.place(&a, &prev.joints),
                        pose: a,
                        rapid: true,
                        kind: StepKind::Retract,
                        ..prev
                    });
                    self.steps.push(Step {
                        joints: self.kin.place(&b, &step.joints),
                        pose: b,
                        rapid: true,
                        kind: StepKind::Reorient,
                        ..step
                    });
                    step.kind = StepKind::Reengage;
                    let decision = Decision::Retract { clearance, axes: self.moves(&prev.joints, &step.joints) };
                    self.decisions.push(Noted { step: self.steps.len(), span: step.span, decision });
                }
            }
        } else if !step.rapid {
            if let Some((r, turn)) = self.largest_turn(&prev.joints, &step.joints)
                && turn > self.policy.max_rotary_step
            {
                let decision = Decision::LargeRotaryStep {
                    axis: axes[r].letter.clone(),
                    from: prev.joints[r].to_degrees(),
                    to: step.joints[r].to_degrees(),
                };
                self.decisions.push(Noted { step: self.steps.len(), span: step.span, decision });
            }
        } else {
            for &r in self.rotary {
                if axes[r].travel == Travel::Endless && (step.joints[r] - prev.joints[r]).abs() > HALF_TURN {
                    let decision = Decision::Unwind {
                        axis: axes[r].letter.clone(),
                        from: prev.joints[r].to_degrees(),
                        to: step.joints[r].to_degrees(),
                    };
                    self.decisions.push(Noted { step: self.steps.len(), span: step.span, decision });
                }
            }
        }
        self.steps.push(step);
        Ok(self.steps.len() - 1)
    }
}

fn best_state(layer: &[Node; 2]) -> usize {
    usize::from(layer[1].better_than(&layer[0]))
}

/// `value` plus whole turns: the one nearest to `near` within the travel.
fn unwrap_near(value: f64, near: f64, travel: &Travel) -> Option<f64> {
    let v = value + TAU * ((near - value) / TAU).round();
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
