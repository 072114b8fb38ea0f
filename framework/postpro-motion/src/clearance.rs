//! The moves postpro adds at the machine's clearance: the retract before a tool change, a
//! re-orientation and the end of the program; the rotary axes turned alone up there; the approach
//! back, across the spindle first, then along it.
//!
//! The clearance is the machine definition's: a safe height of the spindle axis in machine
//! coordinates (written with the dialect's machine-frame word: `G53`, `SUPA`, `M91`), or a
//! retract by a distance along the tool axis. Every rapid that turns a rotary axis, and the first
//! rapid after a tool change, goes this way: **retract, rotate, approach**, never at once.

use postpro_kin::{Joints, Kinematics, Pose, Step, StepKind};
use postpro_machine::model::Clearance;

use crate::block::{AxisSet, BlockKind, MachineRetract, Mode, Position, Rapid};
use crate::build::{Builder, is_rotary};

impl Builder<'_> {
    /// Retracts to the clearance from where the machine is (nothing when it is there already or
    /// its position is not known: at the start the program retracts before its first tool change
    /// all the same, the spindle axis alone in machine coordinates).
    pub(crate) fn retract_to_clearance(&mut self, span: postpro_cl::Span) {
        if self.at_clearance {
            return;
        }
        let machine = self.machine;
        match (machine.clearance, machine.spindle_linear_axis()) {
            (Clearance::SafeZ(z), Some(axis)) => {
                // The kinematics' frame stands for machine coordinates: the retract's position is
                // the spindle axis at the safe height, the others where they are.
                let mut joints = self.current.unwrap_or_else(|| self.home());
                joints[axis] = z;
                let step = self.next_step();
                let to = self.added(joints, step, StepKind::Retract);
                self.push(span, BlockKind::MachineRetract(MachineRetract { to, axis, value: z }));
                self.current = self.current.map(|_| joints);
            }
            (Clearance::Retract(distance), _) | (Clearance::SafeZ(distance), None) => {
                let Some(current) = self.current else { return };
                let pose = self.kin.forward(&current);
                let up = Pose { tip: pose.tip + pose.axis.into_inner() * distance, axis: pose.axis };
                let joints = self.kin.place(&up, &current);
                let step = self.next_step();
                let to = self.added(joints, step, StepKind::Retract);
                self.push(span, BlockKind::Rapid(Rapid { to, axes: AxisSet::ALL }));
                self.current = Some(joints);
            }
        }
        self.at_clearance = true;
    }

    /// Goes to solved step `k` by the clearance: retract, the rotary axes alone, across, then
    /// down (with a retract distance instead of a safe height: above the step along its tool
    /// axis, then to it). With `feed_after`, the last move (down to the step) is left to the feed
    /// move that follows.
    pub(crate) fn reposition(&mut self, k: usize, step: &Step, feed_after: bool) {
        let span = step.span;
        let tcp = self.options.mode == Mode::Tcp;
        if self.tcp_on {
            self.tcp_on = false;
            self.push(span, BlockKind::TcpOff);
        }
        self.retract_to_clearance(span);
        self.work_offset_once(span);
        let machine = self.machine;
        let count = machine.axes.len();
        let target = step.joints;
        let rotaries = AxisSet::of(count, |i| is_rotary(machine, i));
        let spindle = match machine.clearance {
            Clearance::SafeZ(_) => machine.spindle_linear_axis(),
            Clearance::Retract(_) => None,
        };
        // Where the machine is up there: its known position, or (after a tool change) above
        // the target at the safe height.
        let mut at = self.current.unwrap_or_else(|| {
            let mut j = target;
            if let (Some(axis), Clearance::SafeZ(z)) = (spindle, machine.clearance) {
                j[axis] = z;
            }
            j
        });
        if (0..count).any(|i| rotaries.contains(i)) {
            for i in (0..count).filter(|&i| rotaries.contains(i)) {
                at[i] = target[i];
            }
            let to = self.added(at, k, StepKind::Reorient);
            self.push(span, BlockKind::Rapid(Rapid { to, axes: rotaries }));
        }
        if tcp {
            self.tcp_on = true;
            let length_register = self.tool.map_or(0, |t| self.job.tooling.tools[t].length_register);
            self.push(span, BlockKind::TcpOn { length_register });
        }
        match (spindle, machine.clearance) {
            (Some(axis), _) => {
                // Across the spindle at the safe height, then along it.
                let across = AxisSet::of(count, |i| !rotaries.contains(i) && i != axis);
                if tcp {
                    // In TCP mode the approach is the tool tip's: across at its height.
                    let height = self.kin.forward(&at).tip;
                    let tip = nalgebra::Point3::new(step.pose.tip.x, step.pose.tip.y, height.z);
                    at = self.kin.place(&Pose { tip, axis: step.pose.axis }, &target);
                } else {
                    for i in (0..count).filter(|&i| across.contains(i)) {
                        at[i] = target[i];
                    }
                }
                let to = self.added(at, k, StepKind::Retract);
                self.push(span, BlockKind::Rapid(Rapid { to, axes: across }));
                self.current = Some(at);
                if !feed_after {
                    let to = Position { step: k, ..self.position(step, k) };
                    self.push(span, BlockKind::Rapid(Rapid { to, axes: AxisSet::of(count, |i| i == axis) }));
                    self.current = Some(target);
                }
            }
            (None, clearance) => {
                // Above the target along its own tool axis, then to it.
                let distance = match clearance {
                    Clearance::Retract(d) | Clearance::SafeZ(d) => d,
                };
                let above = Pose { tip: step.pose.tip + step.pose.axis.into_inner() * distance, axis: step.pose.axis };
                let joints = self.kin.place(&above, &target);
                let to = self.added(joints, k, StepKind::Retract);
                self.push(span, BlockKind::Rapid(Rapid { to, axes: AxisSet::ALL }));
                self.current = Some(joints);
                if !feed_after {
                    let to = self.position(step, k);
                    self.push(span, BlockKind::Rapid(Rapid { to, axes: AxisSet::ALL }));
                    self.current = Some(target);
                }
            }
        }
        self.at_clearance = false;
        self.last_tip =
            Some(if feed_after { self.kin.forward(&self.current.unwrap_or(target)).tip } else { step.pose.tip });
    }

    /// At the end: the rotary axes back home, at the clearance.
    pub(crate) fn home_rotaries(&mut self, span: postpro_cl::Span) {
        let machine = self.machine;
        let Some(mut at) = self.current else { return };
        let count = machine.axes.len();
        let rotaries = AxisSet::of(count, |i| is_rotary(machine, i));
        let home: Vec<(usize, f64)> =
            (0..count).filter(|&i| rotaries.contains(i)).map(|i| (i, machine.axes[i].home)).collect();
        if home.iter().all(|&(i, h)| (at[i] - h).abs() <= 1e-9) {
            return;
        }
        for (i, h) in home {
            at[i] = h;
        }
        let step = self.next_step();
        let to = self.added(at, step, StepKind::Reorient);
        self.push(span, BlockKind::Rapid(Rapid { to, axes: rotaries }));
        self.current = Some(at);
    }

    /// Every axis at its home position (the kinematics' values).
    fn home(&self) -> Joints {
        let mut j = Joints::zeros(self.machine.axes.len());
        for (i, a) in self.machine.axes.iter().enumerate() {
            j[i] = a.home;
        }
        j
    }
}
