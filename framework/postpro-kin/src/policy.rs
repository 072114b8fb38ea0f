//! The policy: which of the inverse solutions each point of a path takes.
//!
//! - **Ranges**: a solution whose axis values (after unwinding) leave the travel is not a
//!   candidate; rotary travels may exceed one turn.
//! - **Unwinding**: every rotary angle is taken at the turn nearest to the previous point, so an
//!   endless axis accumulates rotation and never jumps by 360°.
//! - **Choice**: by default dynamic programming over the whole path picks the sequence with the
//!   least rotary travel, then the fewest branch switches, then the preferred branch; the greedy
//!   choice takes the best next point each time.
//! - **Singularity**: within `singular_cone` of the pole the free rotary angle is not computed
//!   from the (ill-conditioned) pose but carried from the neighbours (interpolated between the
//!   last point before and the first after), the other rotary fitted to it and the linear axes
//!   placed exactly; the tool axis then deviates by less than the cone.
//! - **Discontinuity**: a rotary step larger than `max_rotary_step` on a feed move is an error
//!   naming the CL line, or, as a setting, a retract along the tool axis, a reorientation at the
//!   clearance and a re-engagement.
//!
//! Every decision that is not obvious is returned as a [`Noted`] decision.

use std::f64::consts::TAU;
use std::fmt;

use postpro_cl::Span;
use postpro_machine::model::{AxisKind, BranchPreference, OnDiscontinuity, PathChoice, PolicyDefaults, Travel};

use crate::pose::{Joints, Pose};
use crate::solver::{Kinematics, Solutions};

/// The settings of the policy: the machine's defaults with the command line's overrides.
pub type Policy = PolicyDefaults;

/// Cost of a branch switch, in radians of rotary travel: it only breaks ties.
const SWITCH_COST: f64 = 1e-3;
/// Cost of a solution off the preferred branch: used only when the preferred one is infeasible.
const OFF_PREFERENCE_COST: f64 = 100.0;

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
    /// The solution branch changes: the rotary axes before and after (degrees).
    BranchSwitch {
        /// The rotary axes before and after.
        axes: AxisMoves,
    },
    /// Near the singularity the free axis is carried from the neighbours.
    SingularHold {
        /// The free axis.
        axis: String,
        /// Its value before the singular run (degrees).
        from: f64,
        /// Its value after it (degrees).
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
            Decision::SingularHold { axis, from, to, points } => {
                write!(f, "near the singularity: {axis} carried from {from:.3}° to {to:.3}° over {points} point(s)")
            }
            Decision::OffPreference { axis } => write!(f, "the preferred branch of {axis} is out of reach here"),
            Decision::Retract { clearance, axes: a } => {
                write!(f, "retract {clearance} mm, reorient, re-engage: ")?;
                axes(f, a)
            }
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

/// Why a path cannot be solved.
#[derive(Clone, Debug, PartialEq, thiserror::Error, miette::Diagnostic)]
pub enum SolveError {
    /// The machine cannot take this tool axis at all.
    #[error("the tool axis ({i:.6}, {j:.6}, {k:.6}) is out of reach of {machine}")]
    #[diagnostic(code(kin::unreachable), help("a 3- or 4-axis machine cannot tilt the tool this way"))]
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
    },
    /// Every solution leaves an axis's travel.
    #[error("no solution within the travel of {machine}: {detail}")]
    #[diagnostic(code(kin::travel), help("move the part on the table (part_origin), or choose another machine"))]
    OutOfTravel {
        /// The CL statement.
        #[label("this pose")]
        span: Span,
        /// Which axis goes where.
        detail: String,
        /// The machine.
        machine: String,
    },
    /// No continuous sequence of solutions exists here.
    #[error("no continuous solution: {axis} would jump from {from:.3}° to {to:.3}° during a feed move")]
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
    },
}

/// A state of the dynamic programme: a solution at its unwound turn, the cost of the best path
/// to it and the state it came from. An infinite cost marks an empty state.
#[derive(Clone, Copy, Debug)]
struct Node {
    cost: f64,
    pred: u8,
    joints: Joints,
    branch: u8,
    preferred: bool,
}

impl Node {
    const EMPTY: Node = Node { cost: f64::INFINITY, pred: 0, joints: Joints::EMPTY, branch: 0, preferred: false };

    fn is_live(&self) -> bool {
        self.cost.is_finite()
    }
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
    let home = start.copied().unwrap_or_else(|| {
        let mut j = Joints::zeros(machine.axes.len());
        for (i, a) in machine.axes.iter().enumerate() {
            j[i] = a.home;
        }
        j
    });
    let preference = match &policy.branch {
        BranchPreference::Closest => None,
        BranchPreference::Positive(l) => machine.axis_index(l).map(|i| (i, 1.0)),
        BranchPreference::Negative(l) => machine.axis_index(l).map(|i| (i, -1.0)),
    };

    let unreachable = |t: &Target| {
        let a = t.pose.axis;
        SolveError::Unreachable { span: t.span, i: a.x, j: a.y, k: a.z, machine: machine.name.clone() }
    };
    // The linear axes of a solution within their travels (they do not change with unwinding),
    // or the axis and value that leave it.
    let linear_ok = |c: &Joints| -> Result<(), (usize, f64)> {
        match linear.iter().find(|&&l| !machine.axes[l].travel.contains(c[l])) {
            Some(&l) => Err((l, c[l])),
            None => Ok(()),
        }
    };
    // A solution with its rotary angles at the turn nearest to `prev`, within their travels.
    let unwound = |c: &Joints, prev: &Joints| -> Result<Joints, (usize, f64)> {
        let mut j = *c;
        for &r in &rotary {
            j[r] = unwrap_near(c[r], prev[r], &machine.axes[r].travel).ok_or((r, c[r]))?;
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
    let mut dp: Vec<[Node; 2]> = Vec::with_capacity(targets.len());
    let mut sols = Solutions::new();
    let start = [Node { cost: 0.0, pred: 0, joints: home, branch: u8::MAX, preferred: true }, Node::EMPTY];
    for (i, t) in targets.iter().enumerate() {
        kin.inverse(&t.pose, &mut sols);
        if sols.is_empty() {
            return Err(unreachable(t));
        }
        let free =
            |s: &crate::solver::Solution| s.pole.filter(|&(_, d)| d < policy.singular_cone).map(|(axis, _)| axis);
        if let Some(f) = sols.iter().map(free).reduce(|a, b| a.and(b)).flatten() {
            free_axis_of_singular.push((i as u32, f as u8));
            continue;
        }
        let mut layer = [Node::EMPTY; 2];
        let mut reasons: [Option<(usize, f64)>; 4] = [None; 4];
        let previous = dp.last().unwrap_or(&start);
        for (s, cand) in sols.iter().enumerate() {
            if let Err(reason) = linear_ok(&cand.joints) {
                reasons[2 * s] = Some(reason);
                continue;
            }
            for (p, node) in previous.iter().enumerate().filter(|(_, n)| n.is_live()) {
                match unwound(&cand.joints, &node.joints) {
                    Ok(j) => {
                        let pref = preferred(&j);
                        let switch = node.branch != u8::MAX && node.branch != cand.branch;
                        let cost = node.cost
                            + travel_cost(&node.joints, &j)
                            + if switch { SWITCH_COST } else { 0.0 }
                            + if pref { 0.0 } else { OFF_PREFERENCE_COST };
                        if cost < layer[s].cost {
                            layer[s] = Node { cost, pred: p as u8, joints: j, branch: cand.branch, preferred: pref };
                        }
                    }
                    Err(reason) => reasons[2 * s + p] = Some(reason),
                }
            }
        }
        if !layer.iter().any(Node::is_live) {
            let mut detail: Vec<String> = reasons.into_iter().flatten().map(describe).collect();
            detail.dedup();
            return Err(SolveError::OutOfTravel {
                span: t.span,
                detail: detail.join("; "),
                machine: machine.name.clone(),
            });
        }
        if policy.choice == PathChoice::Greedy {
            // Keep only the best: the next point is chosen from it alone.
            let best = best_state(&layer);
            layer[1 - best] = Node::EMPTY;
        }
        dp.push(layer);
        regular.push(i as u32);
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
    //    free axis carried from their neighbours; branch switches, preference and
    //    discontinuities handled as each step is added.
    let letters = |a: &Joints, b: &Joints| -> AxisMoves {
        rotary.iter().map(|&r| (machine.axes[r].letter.clone(), a[r].to_degrees(), b[r].to_degrees())).collect()
    };
    // Room for a few retracts without reallocating the steps.
    let mut out = Output { steps: Vec::with_capacity(targets.len() + targets.len() / 64 + 16), decisions: Vec::new() };
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
            let at = out.push(kin, &rotary, policy, step(&targets[i], n.joints), &letters)?;
            if let Some((p, joints, b)) = previous_regular
                && b != n.branch
                && p + 1 == i
            {
                let decision = Decision::BranchSwitch { axes: letters(&joints, &n.joints) };
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
        // A singular run: targets i..end.
        let start_run = i;
        while i < targets.len() && regular.get(k).is_none_or(|&r| r as usize != i) {
            i += 1;
        }
        let before = out.steps.last().map(|s| s.joints);
        let after = (k < regular.len()).then(|| node(k)).flatten().map(|n| n.joints);
        let free = usize::from(free_axis_of_singular[sg].1);
        sg += i - start_run;
        let from = before.unwrap_or(home)[free];
        let to = after.map_or(from, |a| unwrap_near(a[free], from, &Travel::Endless).unwrap_or(from));
        let count = i - start_run;
        // Spread the free axis over the run, unless that makes every step a discontinuity:
        // then hold it, and the one jump (if any) comes after the run.
        let spread = after.is_some() && (to - from).abs() / (count + 1) as f64 <= policy.max_rotary_step;
        let mut first_step = None;
        for (n, t) in targets[start_run..i].iter().enumerate() {
            let u = if spread { (n + 1) as f64 / (count + 1) as f64 } else { 0.0 };
            let value = from + (to - from) * u;
            let prev = out.steps.last().map_or(home, |s| s.joints);
            let held = kin.inverse_holding(&t.pose, free, value).ok_or_else(|| unreachable(t))?;
            let mut j = realize(&held, &prev).map_err(|reason| SolveError::OutOfTravel {
                span: t.span,
                detail: describe(reason),
                machine: machine.name.clone(),
            })?;
            j[free] = value;
            let at = out.push(kin, &rotary, policy, step(t, j), &letters)?;
            first_step.get_or_insert(at);
        }
        let to = if spread { to } else { from };
        out.decisions.push(Noted {
            step: first_step.unwrap_or(out.steps.len()),
            span: targets[start_run].span,
            decision: Decision::SingularHold {
                axis: machine.axes[free].letter.clone(),
                from: from.to_degrees(),
                to: to.to_degrees(),
                points: count,
            },
        });
    }
    let Output { steps, mut decisions } = out;
    decisions.sort_by_key(|d| d.step);
    Ok(Solved { steps, decisions, inserted: 0 })
}

/// The steps being built, and the decisions about them.
struct Output {
    steps: Vec<Step>,
    decisions: Vec<Noted>,
}

impl Output {
    /// Adds a step and returns its index. A rotary step larger than the policy allows on a feed
    /// move is an error, or is preceded by a retract above the previous point and a
    /// reorientation above this one (this step then re-engages).
    fn push(
        &mut self,
        kin: &dyn Kinematics,
        rotary: &[usize],
        policy: &Policy,
        mut step: Step,
        letters: &dyn Fn(&Joints, &Joints) -> AxisMoves,
    ) -> Result<usize, SolveError> {
        if let Some(&prev) = self.steps.last()
            && !step.rapid
            && let Some(&r) = rotary.iter().find(|&&r| (step.joints[r] - prev.joints[r]).abs() > policy.max_rotary_step)
        {
            match policy.on_discontinuity {
                OnDiscontinuity::Error => {
                    let r = rotary
                        .iter()
                        .copied()
                        .max_by(|&x, &y| {
                            (step.joints[x] - prev.joints[x]).abs().total_cmp(&(step.joints[y] - prev.joints[y]).abs())
                        })
                        .unwrap_or(r);
                    return Err(SolveError::Discontinuity {
                        span: step.span,
                        axis: kin.machine().axes[r].letter.clone(),
                        from: prev.joints[r].to_degrees(),
                        to: step.joints[r].to_degrees(),
                    });
                }
                OnDiscontinuity::Retract { clearance } => {
                    let up =
                        |s: &Step| Pose { tip: s.pose.tip + s.pose.axis.into_inner() * clearance, axis: s.pose.axis };
                    let (a, b) = (up(&prev), up(&step));
                    self.steps.push(Step {
                        joints: kin.place(&a, &prev.joints),
                        pose: a,
                        rapid: true,
                        kind: StepKind::Retract,
                        ..prev
                    });
                    self.steps.push(Step {
                        joints: kin.place(&b, &step.joints),
                        pose: b,
                        rapid: true,
                        kind: StepKind::Reorient,
                        ..step
                    });
                    step.kind = StepKind::Reengage;
                    let decision = Decision::Retract { clearance, axes: letters(&prev.joints, &step.joints) };
                    self.decisions.push(Noted { step: self.steps.len(), span: step.span, decision });
                }
            }
        }
        self.steps.push(step);
        Ok(self.steps.len() - 1)
    }
}

fn best_state(layer: &[Node; 2]) -> usize {
    usize::from(layer[1].cost < layer[0].cost)
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
