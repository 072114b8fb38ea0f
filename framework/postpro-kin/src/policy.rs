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

/// A decision that is not obvious, for the log and the NC program.
#[derive(Clone, Debug, PartialEq)]
pub enum Decision {
    /// The solution branch changes: the rotary axes before and after (degrees).
    BranchSwitch {
        /// `(letter, from, to)` of each rotary axis.
        axes: Vec<(String, f64, f64)>,
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
        /// The rotary axes before and after (degrees).
        axes: Vec<(String, f64, f64)>,
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

#[derive(Clone, Copy, Debug)]
struct Cand {
    joints: Joints,
    branch: u8,
    free: Option<usize>,
}

#[derive(Clone, Copy, Debug)]
struct Node {
    cost: f64,
    pred: u8,
    joints: Joints,
    branch: u8,
    preferred: bool,
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

    // 1. Every solution of every target.
    let mut cands: Vec<[Option<Cand>; 2]> = Vec::with_capacity(targets.len());
    let mut sols = Solutions::new();
    for t in targets {
        kin.inverse(&t.pose, &mut sols);
        if sols.is_empty() {
            let a = t.pose.axis;
            return Err(SolveError::Unreachable {
                span: t.span,
                i: a.x,
                j: a.y,
                k: a.z,
                machine: machine.name.clone(),
            });
        }
        let mut c = [None, None];
        for (slot, s) in c.iter_mut().zip(sols.iter()) {
            let free = s.pole.filter(|&(_, d)| d < policy.singular_cone).map(|(axis, _)| axis);
            *slot = Some(Cand { joints: s.joints, branch: s.branch, free });
        }
        cands.push(c);
    }
    let singular = |i: usize| cands[i].iter().flatten().all(|c| c.free.is_some());

    // 2. Dynamic programming (or greedy) over the regular targets.
    // A candidate at the turn nearest to `prev`, or the axis and value that leave the travel.
    let realize = |c: &Cand, prev: &Joints| -> Result<Joints, (usize, f64)> {
        let mut j = c.joints;
        for &r in &rotary {
            j[r] = unwrap_near(c.joints[r], prev[r], &machine.axes[r].travel).ok_or((r, c.joints[r]))?;
        }
        match linear.iter().find(|&&l| !machine.axes[l].travel.contains(j[l])) {
            Some(&l) => Err((l, j[l])),
            None => Ok(j),
        }
    };
    let describe = |(axis, value): (usize, f64)| {
        let a = &machine.axes[axis];
        out_of_travel(&a.letter, value, &a.travel, a.kind == AxisKind::Rotary)
    };
    let preferred = |j: &Joints| preference.is_none_or(|(axis, sign)| j[axis] * sign >= -1e-9);
    let travel_cost = |a: &Joints, b: &Joints| rotary.iter().map(|&r| (a[r] - b[r]).abs()).sum::<f64>();

    let regular: Vec<usize> = (0..targets.len()).filter(|&i| !singular(i)).collect();
    let mut dp: Vec<[Option<Node>; 2]> = Vec::with_capacity(regular.len());
    for (k, &i) in regular.iter().enumerate() {
        let mut layer: [Option<Node>; 2] = [None, None];
        let mut reasons = Vec::new();
        for (s, cand) in cands[i].iter().enumerate() {
            let Some(cand) = cand else { continue };
            // The predecessors: the start for the first point, else the previous layer.
            let start = [Some(Node { cost: 0.0, pred: 0, joints: home, branch: u8::MAX, preferred: true }), None];
            let previous = if k == 0 { &start } else { &dp[k - 1] };
            for (p, node) in previous.iter().enumerate() {
                let Some(node) = node else { continue };
                let (p, base, prev) = (p as u8, node.cost, node.joints);
                let prev_branch = (k > 0).then_some(node.branch);
                match realize(cand, &prev) {
                    Ok(j) => {
                        let pref = preferred(&j);
                        let switch = prev_branch.is_some_and(|b| b != cand.branch);
                        let cost = base
                            + travel_cost(&prev, &j)
                            + if switch { SWITCH_COST } else { 0.0 }
                            + if pref { 0.0 } else { OFF_PREFERENCE_COST };
                        if layer[s].is_none_or(|n| cost < n.cost) {
                            layer[s] = Some(Node { cost, pred: p, joints: j, branch: cand.branch, preferred: pref });
                        }
                    }
                    Err(reason) => reasons.push(reason),
                }
            }
        }
        if layer.iter().all(Option::is_none) {
            let mut detail: Vec<String> = reasons.into_iter().map(describe).collect();
            detail.dedup();
            return Err(SolveError::OutOfTravel {
                span: targets[i].span,
                detail: detail.join("; "),
                machine: machine.name.clone(),
            });
        }
        if policy.choice == PathChoice::Greedy {
            // Keep only the best: the next point is chosen from it alone.
            let best = best_state(&layer);
            for (s, n) in layer.iter_mut().enumerate() {
                if s != best {
                    *n = None;
                }
            }
        }
        dp.push(layer);
    }
    let mut chosen: Vec<Option<(Joints, u8, bool)>> = vec![None; targets.len()];
    if let Some(last) = dp.last() {
        let mut s = best_state(last);
        for k in (0..dp.len()).rev() {
            let Some(n) = dp[k][s] else { break };
            chosen[regular[k]] = Some((n.joints, n.branch, n.preferred));
            s = usize::from(n.pred);
        }
    }

    // 3. Singular runs: the free axis from the neighbours.
    let mut decisions = Vec::new();
    let mut joints: Vec<Joints> = Vec::with_capacity(targets.len());
    let mut i = 0;
    while i < targets.len() {
        if let Some((j, ..)) = chosen[i] {
            joints.push(j);
            i += 1;
            continue;
        }
        let start_run = i;
        while i < targets.len() && chosen[i].is_none() {
            i += 1;
        }
        let before = joints.last().copied();
        let after = chosen.get(i).copied().flatten().map(|(j, ..)| j);
        let free = cands[start_run].iter().flatten().find_map(|c| c.free).unwrap_or(rotary[0]);
        let from = before.unwrap_or(home)[free];
        let to = after.map_or(from, |a| unwrap_near(a[free], from, &Travel::Endless).unwrap_or(from));
        let count = i - start_run;
        // Spread the free axis over the run, unless that makes every step a discontinuity:
        // then hold it, and the one jump (if any) comes after the run.
        let spread = after.is_some() && (to - from).abs() / (count + 1) as f64 <= policy.max_rotary_step;
        for (n, t) in targets[start_run..i].iter().enumerate() {
            let u = if spread { (n + 1) as f64 / (count + 1) as f64 } else { 0.0 };
            let value = from + (to - from) * u;
            let prev = joints.last().copied().unwrap_or(home);
            let held = kin.inverse_holding(&t.pose, free, value).map(|j| Cand { joints: j, branch: 0, free: None });
            let Some(held) = held else {
                let a = t.pose.axis;
                return Err(SolveError::Unreachable {
                    span: t.span,
                    i: a.x,
                    j: a.y,
                    k: a.z,
                    machine: machine.name.clone(),
                });
            };
            let mut j = realize(&held, &prev).map_err(|reason| SolveError::OutOfTravel {
                span: t.span,
                detail: describe(reason),
                machine: machine.name.clone(),
            })?;
            j[free] = value;
            joints.push(j);
        }
        let to = if spread { to } else { from };
        decisions.push(Noted {
            step: start_run,
            span: targets[start_run].span,
            decision: Decision::SingularHold {
                axis: machine.axes[free].letter.clone(),
                from: from.to_degrees(),
                to: to.to_degrees(),
                points: count,
            },
        });
    }

    // 4. Branch switches and preference, then discontinuities.
    let letters = |a: &Joints, b: &Joints| -> Vec<(String, f64, f64)> {
        rotary.iter().map(|&r| (machine.axes[r].letter.clone(), a[r].to_degrees(), b[r].to_degrees())).collect()
    };
    let mut last_regular: Option<(usize, u8)> = None;
    let mut off_pref_reported = false;
    for (i, c) in chosen.iter().enumerate() {
        let Some((_, branch, pref)) = *c else { continue };
        if let Some((p, b)) = last_regular
            && b != branch
            && p + 1 == i
        {
            decisions.push(Noted {
                step: i,
                span: targets[i].span,
                decision: Decision::BranchSwitch { axes: letters(&joints[p], &joints[i]) },
            });
        }
        if !pref && !off_pref_reported {
            if let Some((axis, _)) = preference {
                decisions.push(Noted {
                    step: i,
                    span: targets[i].span,
                    decision: Decision::OffPreference { axis: machine.axes[axis].letter.clone() },
                });
            }
            off_pref_reported = true;
        }
        off_pref_reported &= !pref;
        last_regular = Some((i, branch));
    }
    decisions.sort_by_key(|d| d.step);

    let mut steps: Vec<Step> = targets
        .iter()
        .zip(&joints)
        .map(|(t, j)| Step { joints: *j, pose: t.pose, rapid: t.rapid, span: t.span, kind: StepKind::Cl })
        .collect();
    let jumps: Vec<usize> = (1..steps.len())
        .filter(|&i| !steps[i].rapid)
        .filter(|&i| {
            rotary.iter().any(|&r| (steps[i].joints[r] - steps[i - 1].joints[r]).abs() > policy.max_rotary_step)
        })
        .collect();
    match policy.on_discontinuity {
        OnDiscontinuity::Error => {
            if let Some(&i) = jumps.first() {
                let (a, b) = (&steps[i - 1].joints, &steps[i].joints);
                let r = rotary
                    .iter()
                    .copied()
                    .max_by(|&x, &y| (b[x] - a[x]).abs().total_cmp(&(b[y] - a[y]).abs()))
                    .unwrap_or(0);
                return Err(SolveError::Discontinuity {
                    span: steps[i].span,
                    axis: machine.axes[r].letter.clone(),
                    from: a[r].to_degrees(),
                    to: b[r].to_degrees(),
                });
            }
        }
        OnDiscontinuity::Retract { clearance } => {
            for &i in jumps.iter().rev() {
                let (prev, next) = (steps[i - 1], steps[i]);
                let up = |s: &Step| Pose { tip: s.pose.tip + s.pose.axis.into_inner() * clearance, axis: s.pose.axis };
                let retract = Step {
                    joints: kin.place(&up(&prev), &prev.joints),
                    pose: up(&prev),
                    rapid: true,
                    kind: StepKind::Retract,
                    ..prev
                };
                let reorient = Step {
                    joints: kin.place(&up(&next), &next.joints),
                    pose: up(&next),
                    rapid: true,
                    kind: StepKind::Reorient,
                    ..next
                };
                steps[i].kind = StepKind::Reengage;
                steps.splice(i..i, [retract, reorient]);
                for d in decisions.iter_mut().filter(|d| d.step >= i) {
                    d.step += 2;
                }
                decisions.push(Noted {
                    step: i,
                    span: next.span,
                    decision: Decision::Retract { clearance, axes: letters(&prev.joints, &next.joints) },
                });
            }
            decisions.sort_by_key(|d| d.step);
        }
    }
    Ok(Solved { steps, decisions, inserted: 0 })
}

fn best_state(layer: &[Option<Node>; 2]) -> usize {
    match layer {
        [Some(a), Some(b)] if b.cost < a.cost => 1,
        [None, Some(_)] => 1,
        _ => 0,
    }
}

/// `value` plus whole turns: the one nearest to `near` within the travel.
fn unwrap_near(value: f64, near: f64, travel: &Travel) -> Option<f64> {
    let v = value + TAU * ((near - value) / TAU).round();
    match *travel {
        Travel::Endless => Some(v),
        Travel::Limited { .. } => [0.0, -1.0, 1.0, -2.0, 2.0]
            .into_iter()
            .map(|k| v + k * TAU)
            .filter(|w| travel.contains(*w))
            .min_by(|a, b| (a - near).abs().total_cmp(&(b - near).abs())),
    }
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
