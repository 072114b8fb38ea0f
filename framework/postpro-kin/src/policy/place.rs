//! The policy's second pass: each target again, in the same order, turned into its step with the
//! state the first pass chose, the singular runs carried, discontinuities, branch switches and
//! preferences handled as each step is made.

use nalgebra::Point3;
use postpro_machine::model::{OnDiscontinuity, Travel};

use super::{Choice, HALF_TURN, Jump, Rules, StepSink, Swing, Target, pole_distance, run_move, swing_weight};
use crate::policy::{AxisMoves, Decision, Noted, Policy, SolveError, Step, StepKind};
use crate::pose::{Joints, Pose};
use crate::solver::{Kinematics, Solutions};

/// The second pass of the policy (see [`super::choose`]): push the targets of the first pass
/// again, in the same order; the steps and decisions go to a [`StepSink`] as they are made, each
/// decision before the step it concerns. The kinematics may change between targets (the tool in
/// the spindle): that moves the axes that place the tip, not the rotary angles the choice is
/// about.
pub struct Placer<'a> {
    rules: Rules<'a>,
    choice: Choice,
    sols: Solutions,
    start: Joints,
    /// Targets so far.
    index: usize,
    /// Regular targets so far.
    regulars: usize,
    /// Singular runs begun so far.
    runs: usize,
    /// Steps made so far.
    steps: usize,
    last_step: Option<Step>,
    /// The previous regular target: its index, joints and branch.
    previous_regular: Option<(usize, Joints, u8)>,
    /// The previous target: its tip and pole distance.
    previous: Option<(Point3<f64>, f64)>,
    rapid_since: bool,
    off_preference: bool,
    run: Option<Carried>,
}

/// A singular run being placed: the free axis is carried from its value before the run to its
/// value at the regular target after it (if any), as [`Swing`] shares the turn among the moves.
struct Carried {
    /// The run's first target.
    start: usize,
    free: usize,
    /// The free axis's value before the run.
    from: f64,
    /// Its value at the regular target after the run (`None`: the run ends the path).
    after: Option<f64>,
    /// Its value where nothing follows the run (unwound at the run's rapids).
    held: f64,
    swing: Swing,
    /// The weights of the moves so far ([`Swing::Weighted`]).
    done: f64,
    /// Targets of the run still to come.
    left: usize,
    /// The decision that goes before the run's first step.
    hold: Option<Noted>,
}

impl<'a> Placer<'a> {
    /// The second pass for the targets of `choice`, on the machine of `kin` under `policy`, the
    /// machine at `start` before the first target (its home when `None`).
    pub fn new(kin: &'a dyn Kinematics, policy: &'a Policy, start: Option<&Joints>, choice: Choice) -> Placer<'a> {
        let rules = Rules::new(kin.machine(), policy);
        let start = start.copied().unwrap_or(rules.home);
        Placer {
            rules,
            choice,
            sols: Solutions::new(),
            start,
            index: 0,
            regulars: 0,
            runs: 0,
            steps: 0,
            last_step: None,
            previous_regular: None,
            previous: None,
            rapid_since: false,
            off_preference: false,
            run: None,
        }
    }

    /// The next target, solved with `kin` (the machine of the first pass, with the tool in the
    /// spindle); its steps and decisions go to `out`.
    pub fn push(&mut self, kin: &dyn Kinematics, t: &Target, out: &mut dyn StepSink) -> Result<(), SolveError> {
        let i = self.index;
        self.index += 1;
        kin.inverse(&t.pose, &mut self.sols);
        if self.sols.is_empty() {
            return Err(self.rules.unreachable(t));
        }
        let pole = pole_distance(&self.sols);
        let previous = self.previous.replace((t.pose.tip, pole));
        self.rapid_since |= t.rapid;
        if self.choice.regular.get(i) {
            self.regular(kin, i, t, out)
        } else {
            self.singular(kin, i, t, pole, previous, out)
        }
    }

    fn regular(
        &mut self,
        kin: &dyn Kinematics,
        i: usize,
        t: &Target,
        out: &mut dyn StepSink,
    ) -> Result<(), SolveError> {
        let state = usize::from(self.choice.states.get(self.regulars));
        let pole_passage = self.choice.pole_passages.get(self.regulars);
        self.regulars += 1;
        let Some(cand) = self.sols.iter().nth(state).copied() else { return Err(self.rules.unreachable(t)) };
        let (from, from_branch) = self.previous_regular.map_or((self.start, u8::MAX), |p| (p.1, p.2));
        // Consecutive feed points: here a branch change away from the pole, or a turn beyond the
        // nearest one, is a discontinuity.
        let previous_target = self.previous_regular.filter(|p| p.0 + 1 == i && !self.rapid_since);
        let mut j = self.rules.unwound(&cand.joints, &from).map_err(|reason| self.rules.out_of_travel(t, &[reason]))?;
        let jump = self.rules.jump((&from, from_branch), (&j, cand.branch), previous_target.is_some(), pole_passage);
        let preferred = self.rules.preferred(&j);
        if self.rapid_since {
            self.rules.unwinding.apply(&mut j);
        }
        let mut made = step(t, j);
        let at = self.prepare(kin, &mut made, jump, out)?;
        if let Some((_, joints, branch)) = self.previous_regular.filter(|p| p.0 + 1 == i)
            && branch != cand.branch
            && jump.is_none()
        {
            let decision = Decision::BranchSwitch { axes: self.moves(&joints, &j) };
            out.decision(Noted { step: at, span: t.span, decision });
        }
        if !preferred
            && !self.off_preference
            && let Some((axis, _)) = self.rules.preference
        {
            let decision = Decision::OffPreference { axis: self.rules.machine.axes[axis].letter.clone() };
            out.decision(Noted { step: at, span: t.span, decision });
        }
        self.off_preference = !preferred;
        self.previous_regular = Some((i, j, cand.branch));
        self.rapid_since = false;
        self.verify(kin, t, &made.joints)?;
        self.emit(made, out);
        Ok(())
    }

    fn singular(
        &mut self,
        kin: &dyn Kinematics,
        i: usize,
        t: &Target,
        pole: f64,
        previous: Option<(Point3<f64>, f64)>,
        out: &mut dyn StepSink,
    ) -> Result<(), SolveError> {
        if self.run.is_none() {
            self.open_run(i, t);
        }
        let Some(run) = self.run.as_mut() else { return Err(self.rules.unreachable(t)) };
        let value = match run.after {
            None => run.held,
            Some(to) => {
                // The share of the swing done on reaching this target.
                let share = match run.swing {
                    Swing::AtRapid(m) => f64::from(u8::from(i >= m)),
                    Swing::Weighted { on_pole, total } => {
                        if let Some((eps, length)) = run_move(run.start, i, previous, t.pose.tip, pole) {
                            run.done += swing_weight(eps, length, on_pole);
                        }
                        if total > 0.0 { run.done / total } else { 0.0 }
                    }
                };
                run.from + (to - run.from) * share
            }
        };
        let free = run.free;
        let rules = &self.rules;
        let prev = self.last_step.map_or(self.start, |s| s.joints);
        let held = kin.inverse_holding(&t.pose, free, value).ok_or_else(|| rules.unreachable(t))?;
        let mut j = rules.realize(&held, &prev).map_err(|reason| rules.out_of_travel(t, &[reason]))?;
        j[free] = value;
        if run.after.is_none() && t.rapid {
            // No regular point follows to bring the winding back: unwind here.
            rules.unwinding.apply(&mut j);
            run.held = j[free];
        }
        run.left -= 1;
        let hold = run.hold.take();
        if run.left == 0 {
            self.run = None;
        }
        let mut made = step(t, j);
        let at = self.prepare(kin, &mut made, None, out)?;
        if let Some(noted) = hold {
            out.decision(Noted { step: at, ..noted });
        }
        self.verify(kin, t, &made.joints)?;
        self.emit(made, out);
        Ok(())
    }

    /// Opens the singular run that starts at target `i`, `t`.
    fn open_run(&mut self, i: usize, t: &Target) {
        let run = &self.choice.runs[self.runs];
        self.runs += 1;
        let free = usize::from(run.free);
        let from = self.last_step.map_or(self.start[free], |s| s.joints[free]);
        // The state of the regular target after the run.
        let after = run.after.map(|a| a[usize::from(self.choice.states.get(self.regulars))]);
        // Where nothing follows, the value is held, and unwound at the run's first rapid.
        let to = match after {
            Some(to) => to,
            None if run.has_rapid && self.rules.machine.axes[free].travel == Travel::Endless => {
                self.rules.unwound_at_rapid(free, from)
            }
            None => from,
        };
        let decision = Decision::SingularHold {
            axis: self.rules.machine.axes[free].letter.clone(),
            from: from.to_degrees(),
            to: to.to_degrees(),
            points: run.points,
        };
        self.run = Some(Carried {
            start: i,
            free,
            from,
            after,
            held: from,
            swing: run.swing,
            done: 0.0,
            left: run.points,
            hold: Some(Noted { step: 0, span: t.span, decision }),
        });
    }

    /// Gets `step` ready to be the next step: a `jump` (a discontinuity from the previous step) is
    /// an error, or is preceded by a retract above the previous point and a reorientation above
    /// this one (made here; this step then re-engages). A feed step that turns a rotary axis by
    /// more than `max_rotary_step` is noted as a warning; a rapid that unwinds an endless axis is
    /// noted. Returns the index `step` will have.
    fn prepare(
        &mut self,
        kin: &dyn Kinematics,
        step: &mut Step,
        jump: Option<Jump>,
        out: &mut dyn StepSink,
    ) -> Result<usize, SolveError> {
        let Some(prev) = self.last_step else { return Ok(self.steps) };
        let axes = &self.rules.machine.axes;
        if let Some(cause) = jump {
            match self.rules.policy.on_discontinuity {
                OnDiscontinuity::Error => {
                    let r = match cause {
                        Jump::TravelLimit => self
                            .rules
                            .rotary
                            .iter()
                            .copied()
                            .find(|&r| (step.joints[r] - prev.joints[r]).abs() > HALF_TURN),
                        Jump::BranchChange => self.largest_turn(&prev.joints, &step.joints).map(|(r, _)| r),
                    }
                    .unwrap_or(self.rules.rotary[0]);
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
                    let (a, b) = (up(&prev), up(step));
                    let retract = Step {
                        joints: kin.place(&a, &prev.joints),
                        pose: a,
                        rapid: true,
                        kind: StepKind::Retract,
                        ..prev
                    };
                    let reorient = Step {
                        joints: kin.place(&b, &step.joints),
                        pose: b,
                        rapid: true,
                        kind: StepKind::Reorient,
                        ..*step
                    };
                    self.emit(retract, out);
                    self.emit(reorient, out);
                    step.kind = StepKind::Reengage;
                    let decision = Decision::Retract { clearance, axes: self.moves(&prev.joints, &step.joints) };
                    out.decision(Noted { step: self.steps, span: step.span, decision });
                }
            }
        } else if !step.rapid {
            if let Some((r, turn)) = self.largest_turn(&prev.joints, &step.joints)
                && turn > self.rules.policy.max_rotary_step
            {
                let decision = Decision::LargeRotaryStep {
                    axis: axes[r].letter.clone(),
                    from: prev.joints[r].to_degrees(),
                    to: step.joints[r].to_degrees(),
                };
                out.decision(Noted { step: self.steps, span: step.span, decision });
            }
        } else {
            for &r in &self.rules.rotary {
                if axes[r].travel == Travel::Endless && (step.joints[r] - prev.joints[r]).abs() > HALF_TURN {
                    let decision = Decision::Unwind {
                        axis: axes[r].letter.clone(),
                        from: prev.joints[r].to_degrees(),
                        to: step.joints[r].to_degrees(),
                    };
                    out.decision(Noted { step: self.steps, span: step.span, decision });
                }
            }
        }
        Ok(self.steps)
    }

    /// The axis values put the tool tip on the target's pose (within 1e-6 mm, far above the
    /// rounding): a solver that does not is an error, never motion.
    fn verify(&self, kin: &dyn Kinematics, t: &Target, joints: &Joints) -> Result<(), SolveError> {
        let off = (kin.forward(joints).tip - t.pose.tip).norm();
        if off <= 1e-6 {
            return Ok(());
        }
        Err(SolveError::TipOff { span: t.span, off, machine: self.rules.machine.name.clone() })
    }

    /// Hands `step` on as the next step.
    fn emit(&mut self, step: Step, out: &mut dyn StepSink) {
        self.last_step = Some(step);
        self.steps += 1;
        out.step(step);
    }

    /// The rotary axes from `a` to `b`, in degrees.
    fn moves(&self, a: &Joints, b: &Joints) -> AxisMoves {
        let axes = &self.rules.machine.axes;
        self.rules.rotary.iter().map(|&r| (axes[r].letter.clone(), a[r].to_degrees(), b[r].to_degrees())).collect()
    }

    /// The rotary axis that changes most from `a` to `b`, and by how much (rad).
    fn largest_turn(&self, a: &Joints, b: &Joints) -> Option<(usize, f64)> {
        self.rules.rotary.iter().map(|&r| (r, (b[r] - a[r]).abs())).max_by(|x, y| x.1.total_cmp(&y.1))
    }
}

fn step(t: &Target, joints: Joints) -> Step {
    Step { joints, pose: t.pose, rapid: t.rapid, span: t.span, kind: StepKind::Cl }
}
