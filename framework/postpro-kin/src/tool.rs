//! Tool lengths: a machine's kinematics for another tool, and the solve of a program whose tools
//! differ in length.
//!
//! A machine definition places the tool tip `tool_length` from the spindle nose along the tool
//! axis. A tool `L` long has its tip `L − tool_length` further along the axis, away from the
//! spindle: [`ToolLength`] solves and evaluates the machine for that tool, exactly, for any
//! solver (closed form, generic chain, plugin), by moving the poses along their own tool axis.

use postpro_cl::{ItemKind, ToolPath};
use postpro_machine::model::Machine;

use crate::policy::{Policy, SolveError, Solved, choose};
use crate::pose::{Joints, Pose};
use crate::solver::{Kinematics, Solutions};
use crate::{linearize, targets};

/// A machine's kinematics with the tool tip `extra` mm further from the spindle nose than the
/// machine definition's tool length.
pub struct ToolLength<'a> {
    inner: &'a dyn Kinematics,
    extra: f64,
}

impl<'a> ToolLength<'a> {
    /// `inner` with a tool of `length` mm (the machine definition's own length is `inner`'s).
    pub fn new(inner: &'a dyn Kinematics, length: f64) -> Self {
        ToolLength { inner, extra: length - inner.machine().chain.tool_length }
    }

    /// Where the definition's tool tip must be for this tool's tip to be on `pose`.
    fn inner_pose(&self, pose: &Pose) -> Pose {
        Pose { tip: pose.tip + pose.axis.into_inner() * self.extra, axis: pose.axis }
    }
}

impl Kinematics for ToolLength<'_> {
    fn machine(&self) -> &Machine {
        self.inner.machine()
    }

    fn forward(&self, joints: &Joints) -> Pose {
        let p = self.inner.forward(joints);
        Pose { tip: p.tip - p.axis.into_inner() * self.extra, axis: p.axis }
    }

    fn inverse(&self, pose: &Pose, out: &mut Solutions) {
        self.inner.inverse(&self.inner_pose(pose), out);
    }

    fn inverse_holding(&self, pose: &Pose, free_axis: usize, value: f64) -> Option<Joints> {
        self.inner.inverse_holding(&self.inner_pose(pose), free_axis, value)
    }

    fn place(&self, pose: &Pose, rotaries: &Joints) -> Joints {
        // The tip reached is on `pose.tip`; its axis is what `rotaries` give, so the inner tip
        // is moved along that axis, not along `pose.axis`.
        let axis = self.inner.forward(rotaries).axis;
        let inner = Pose { tip: pose.tip + axis.into_inner() * self.extra, axis };
        self.inner.place(&inner, rotaries)
    }
}

/// The tool length in effect from one item of a tool path on.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LengthFrom {
    /// The index of the first item (in `ToolPath::items`) the length applies to.
    pub item: usize,
    /// The tool length (mm, spindle nose to tip).
    pub length: f64,
}

/// Solves a tool path whose tools differ in length: each stretch of items from one entry of
/// `lengths` to the next is solved with the kinematics of its tool (continuing from the position
/// the stretch before ended at) and linearized with it. Items before the first entry use the
/// machine definition's tool length. The step indices of the decisions are those of the whole.
pub fn solve_with_tools(
    kin: &dyn Kinematics,
    path: &ToolPath,
    policy: &Policy,
    lengths: &[LengthFrom],
) -> Result<Solved, SolveError> {
    let all = targets(path, policy.linearization_tolerance);
    let mut solved = Solved { steps: Vec::with_capacity(all.len()), decisions: Vec::new(), inserted: 0 };
    // Where each stretch starts, as a byte offset of the CL text: targets carry their item's span.
    let mut bounds: Vec<(u32, f64)> = Vec::with_capacity(lengths.len() + 1);
    bounds.push((0, kin.machine().chain.tool_length));
    for l in lengths {
        let at = path.items.get(l.item).map_or(u32::MAX, |i| i.span.start);
        match bounds.last_mut() {
            Some(last) if last.0 == at => last.1 = l.length,
            _ => bounds.push((at, l.length)),
        }
    }
    let mut from = 0;
    for (b, &(_, length)) in bounds.iter().enumerate() {
        let end =
            bounds.get(b + 1).map_or(all.len(), |&(at, _)| from + all[from..].partition_point(|t| t.span.start < at));
        if end == from {
            continue;
        }
        let tool = ToolLength::new(kin, length);
        let start = solved.steps.last().map(|s| s.joints);
        let mut part = choose(&tool, &all[from..end], policy, start.as_ref())?;
        part.inserted = linearize::linearize_noting(&tool, &mut part.steps, &mut part.decisions, policy);
        let offset = solved.steps.len();
        solved.steps.extend(part.steps);
        solved.decisions.extend(part.decisions.into_iter().map(|mut d| {
            d.step += offset;
            d
        }));
        solved.inserted += part.inserted;
        from = end;
    }
    Ok(solved)
}

/// The item index of every tool change of a tool path, in order.
pub fn tool_changes(path: &ToolPath) -> impl Iterator<Item = usize> + '_ {
    path.items.iter().enumerate().filter(|(_, i)| matches!(i.kind, ItemKind::ToolChange(_))).map(|(k, _)| k)
}

#[cfg(test)]
mod tests {
    use nalgebra::{Point3, Unit, Vector3};
    use postpro_machine::model::SolverKind;

    use super::*;
    use crate::{Chain, testing};

    #[test]
    fn a_longer_tool_puts_its_own_tip_on_the_pose() {
        let machine = testing::nutating();
        let chain = Chain::new(machine);
        let tool = ToolLength::new(&chain, chain.machine().chain.tool_length + 37.5);
        let pose = Pose { tip: Point3::new(12.0, -8.0, 3.0), axis: Unit::new_normalize(Vector3::new(0.3, 0.2, 0.9)) };
        let mut sols = Solutions::new();
        tool.inverse(&pose, &mut sols);
        assert!(!sols.is_empty());
        for s in sols.iter() {
            let back = tool.forward(&s.joints);
            assert!((back.tip - pose.tip).norm() < 1e-9);
            // The machine's own tip is 37.5 mm further up the tool axis.
            let own = chain.forward(&s.joints);
            assert!((own.tip - (pose.tip + pose.axis.into_inner() * 37.5)).norm() < 1e-9);
            let placed = tool.place(&pose, &s.joints);
            assert!((tool.forward(&placed).tip - pose.tip).norm() < 1e-9);
        }
    }

    #[test]
    fn on_a_table_table_machine_the_tool_length_only_shifts_the_spindle_axis() {
        let chain = Chain::new(testing::maho(SolverKind::Generic));
        let tool = ToolLength::new(&chain, chain.machine().chain.tool_length + 80.0);
        let pose = Pose { tip: Point3::new(5.0, 6.0, 7.0), axis: Unit::new_normalize(Vector3::new(0.2, 0.1, 0.9)) };
        let (mut a, mut b) = (Solutions::new(), Solutions::new());
        chain.inverse(&pose, &mut a);
        tool.inverse(&pose, &mut b);
        for (x, y) in a.iter().zip(b.iter()) {
            let d: Vec<f64> = x.joints.as_slice().iter().zip(y.joints.as_slice()).map(|(p, q)| q - p).collect();
            assert!(d[0].abs() < 1e-9 && d[1].abs() < 1e-9 && (d[2] - 80.0).abs() < 1e-9, "{d:?}");
            assert!(d[3].abs() < 1e-12 && d[4].abs() < 1e-12);
        }
    }
}
