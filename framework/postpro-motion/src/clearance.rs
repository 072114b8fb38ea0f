//! The moves postpro adds at the machine's clearance: the retract before a tool change, a
//! re-orientation and the end of the program; the rotary axes turned alone up there; the approach
//! back, across the spindle first, then along it.
//!
//! The clearance is the machine definition's: a safe height of the spindle axis in machine
//! coordinates (written with the dialect's machine-frame word: `G53`, `SUPA`, `M91`), or a
//! retract by a distance along the tool axis. Every rapid that turns a rotary axis, and the first
//! rapid after a tool change, goes this way: **retract, rotate, approach**, never at once.
//! Tool-centre-point control and working planes come on only after the move across, so that
//! every move at the clearance is one of the machine's own axes; rotary brakes are released
//! before an axis turns and locked while a 3+2 set-up stands.

use postpro_kin::{Joints, Kinematics, Pose, Step, StepKind};
use postpro_machine::model::Clearance;

use crate::block::{AxisSet, BlockKind, MachineRetract, Mode, Position, Rapid, WorkPlane};
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

    /// Goes to solved step `k` by the clearance: retract, the rotary axes alone (their brakes
    /// released before, locked after where the set-up stands until the next re-orientation),
    /// across, then down (with a retract distance instead of a safe height: above the step along
    /// its tool axis, then to it). Tool-centre-point control or the working plane comes on after
    /// the move across, which is written in the work offset's frame: the approach along the
    /// spindle is the first position the controller transforms. With `feed_after`, the last move
    /// (down to the step) is left to the feed move that follows.
    pub(crate) fn reposition(&mut self, k: usize, step: &Step, feed_after: bool) {
        let span = step.span;
        let tcp = self.options.mode == Mode::Tcp;
        self.frame_off(span);
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
        let indexed = self.indexed_from(k, span);
        if (0..count).any(|i| rotaries.contains(i)) {
            for i in (0..count).filter(|&i| rotaries.contains(i)) {
                at[i] = target[i];
            }
            self.release(span, &at);
            let to = self.added(at, k, StepKind::Reorient);
            self.push(span, BlockKind::Rapid(Rapid { to, axes: rotaries }));
            self.current = Some(at);
            if indexed {
                self.lock(span);
            }
        }
        let plane = if indexed && !tcp { self.plane_at(&target) } else { None };
        match (spindle, machine.clearance) {
            (Some(axis), _) => {
                // Across the spindle at the safe height, then along it.
                let across = AxisSet::of(count, |i| !rotaries.contains(i) && i != axis);
                for i in (0..count).filter(|&i| across.contains(i)) {
                    at[i] = target[i];
                }
                let to = self.added(at, k, StepKind::Retract);
                self.push(span, BlockKind::Rapid(Rapid { to, axes: across }));
                self.current = Some(at);
                self.frame_on(span, tcp, plane);
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
                self.frame_on(span, tcp, plane);
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

    /// Tool-centre-point control (`tcp`) or the working plane `plane` on, where asked.
    fn frame_on(&mut self, span: postpro_cl::Span, tcp: bool, plane: Option<WorkPlane>) {
        if tcp {
            self.tcp_on = true;
            let length_register = self.tool.map_or(0, |t| self.job.tooling.tools[t].length_register);
            self.push(span, BlockKind::TcpOn { length_register });
        } else if let Some(plane) = plane {
            self.plane = Some(plane.kind);
            self.push(span, BlockKind::PlaneOn(Box::new(plane)));
        }
    }

    /// Tool-centre-point control or the working plane off, where on: before a retract in
    /// machine coordinates, a re-orientation, a tool change and the end.
    pub(crate) fn frame_off(&mut self, span: postpro_cl::Span) {
        if self.tcp_on {
            self.tcp_on = false;
            self.push(span, BlockKind::TcpOff);
        }
        if self.plane.take().is_some() {
            self.push(span, BlockKind::PlaneOff);
        }
    }

    /// True when the rotary axes of step `k` (of the CL statement at `span`) stand until the next
    /// rapid that turns them (or the end): a 3+2 set-up, not simultaneous motion. A guessed
    /// answer is kept, to be checked.
    pub(crate) fn indexed_from(&mut self, k: usize, span: postpro_cl::Span) -> bool {
        match self.set_ups.guess_at(span.start) {
            Some(answer) => {
                self.guessed.push((k, answer));
                answer
            }
            None => self.set_ups.indexed_from(k),
        }
    }

    /// The working plane of the set-up with the rotary axes at `joints` (the kinematics'
    /// values), when the options ask for planes and it is tilted (none with the rotaries at
    /// their zero, where the plane is the work offset's frame).
    fn plane_at(&self, joints: &Joints) -> Option<WorkPlane> {
        let kind = self.options.planes?;
        let machine = self.machine;
        let linear = &machine.chain.linear;
        if linear.len() != 3 || !machine.chain.tool.is_empty() {
            return None;
        }
        // The linear axes' values for the tip at a point of the part frame, the rotaries held.
        let axis = self.kin.forward(joints).axis;
        let image = |p: nalgebra::Point3<f64>| self.job.frame.apply(&self.kin.place(&Pose { tip: p, axis }, joints));
        let zero = image(nalgebra::Point3::origin());
        let columns = [nalgebra::Vector3::x(), nalgebra::Vector3::y(), nalgebra::Vector3::z()].map(|e| {
            let v = image(nalgebra::Point3::from(e));
            nalgebra::Vector3::new(
                v[linear[0]] - zero[linear[0]],
                v[linear[1]] - zero[linear[1]],
                v[linear[2]] - zero[linear[2]],
            )
        });
        let map = nalgebra::Matrix3::from_columns(&columns);
        // A rotation (the linear axes a right-handed orthonormal frame), and not the identity.
        if (map.transpose() * map - nalgebra::Matrix3::identity()).norm() > 1e-9 || map.determinant() < 0.0 {
            return None;
        }
        // Turned by less than the rotaries can be written to (their noise): the plane's angles
        // would be written as zero, and it is the work offset's frame.
        let finest = (0..machine.axes.len())
            .filter(|&i| is_rotary(machine, i))
            .map(|i| crate::arc::half_unit(&machine.axes[i]))
            .fold(f64::INFINITY, f64::min);
        if (map - nalgebra::Matrix3::identity()).norm() <= finest {
            return None;
        }
        let mut shift = Joints::zeros(machine.axes.len());
        for &i in linear {
            shift[i] = zero[i];
        }
        let mut rotaries = self.job.frame.apply(joints);
        for &i in linear {
            rotaries[i] = 0.0;
        }
        let row = |r: usize| map.row(r).transpose();
        Some(WorkPlane { kind, axes: [row(0), row(1), row(2)], shift, rotaries })
    }

    /// Unlocks the brake of every clamped rotary axis that `to` turns (or whose state is not
    /// known).
    pub(crate) fn release(&mut self, span: postpro_cl::Span, to: &Joints) {
        let machine = self.machine;
        for i in 0..machine.axes.len() {
            if machine.axes[i].clamp.is_none() || self.locked[i] == Some(false) {
                continue;
            }
            let turns = self.current.is_none_or(|c| self.turns_as_written(i, &c, to)) || self.locked[i].is_none();
            if turns {
                self.locked[i] = Some(false);
                self.push(span, BlockKind::Clamp { axis: i, lock: false });
            }
        }
    }

    /// True when the machine turns rotary axis `i` from `from` to `to` as the program writes them:
    /// its written value (to its last decimal) changes. In TCP mode the controller may find the
    /// angles from the tool vector itself: there, any change turns it.
    fn turns_as_written(&self, i: usize, from: &Joints, to: &Joints) -> bool {
        if (from[i] - to[i]).abs() <= 1e-9 {
            return false;
        }
        if self.options.mode == Mode::Tcp {
            return true;
        }
        // As the emitter writes it: degrees in the job's frame, rounded half away from zero.
        let scale = 10f64.powi(i32::from(self.machine.axes[i].decimals));
        let written = |j: &Joints| (self.job.frame.apply(j)[i].to_degrees() * scale).round();
        written(from) != written(to)
    }

    /// Locks the brake of every clamped rotary axis not locked.
    pub(crate) fn lock(&mut self, span: postpro_cl::Span) {
        for i in 0..self.machine.axes.len() {
            if self.machine.axes[i].clamp.is_some() && self.locked[i] != Some(true) {
                self.locked[i] = Some(true);
                self.push(span, BlockKind::Clamp { axis: i, lock: true });
            }
        }
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
        self.release(span, &at);
        let step = self.next_step();
        let to = self.added(at, step, StepKind::Reorient);
        self.push(span, BlockKind::Rapid(Rapid { to, axes: rotaries }));
        self.current = Some(at);
        // The machine is left with its brakes on.
        self.lock(span);
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
