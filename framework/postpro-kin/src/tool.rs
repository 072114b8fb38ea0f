//! Tool lengths: a machine's kinematics for another tool, and the solve of a program whose tools
//! differ in length.
//!
//! A machine definition places the tool tip `tool_length` from the spindle nose along the tool
//! axis. A tool `L` long has its tip `L − tool_length` further along the axis, away from the
//! spindle: [`ToolLength`] solves and evaluates the machine for that tool, exactly, for any
//! solver (closed form, generic chain, plugin), by moving the poses along their own tool axis.

use postpro_cl::{ItemKind, ToolPath};
use postpro_machine::model::Machine;

use crate::linearize::{Linearizer, Linearizing, Shape};
use crate::policy::{BranchGraph, Collected, Placer, Policy, SolveError, Solved, StepSink, Target};
use crate::pose::{Bend, Joints, Pose, PoseRate};
use crate::solver::{Kinematics, Solutions};
use crate::targets;

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

    fn bend(&self, a: &Joints, b: &Joints) -> Option<Bend> {
        // The tip is `extra` along the axis from the inner tip.
        let inner = self.inner.bend(a, b)?;
        Some(Bend { tip: inner.tip + self.extra.abs() * inner.axis, axis: inner.axis })
    }

    fn forward_rate(&self, joints: &Joints, rates: &Joints) -> PoseRate {
        let r = self.inner.forward_rate(joints, rates);
        PoseRate { tip: r.tip - r.axis * self.extra, axis: r.axis }
    }

    fn inverse(&self, pose: &Pose, out: &mut Solutions) {
        self.inner.inverse(&self.inner_pose(pose), out);
    }

    fn inverse_holding(&self, pose: &Pose, free_axis: usize, value: f64) -> Option<Joints> {
        // The axis reached is off the pose's (the free axis is held, not solved): the tip is put
        // on the pose along the axis reached, as `place` does, not along the pose's.
        let held = self.inner.inverse_holding(&self.inner_pose(pose), free_axis, value)?;
        Some(self.place(pose, &held))
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

/// Solves a tool path whose tools differ in length: one choice over the whole path (the rotary
/// angles it is about do not depend on the tool), then each stretch of items from one entry of
/// `lengths` to the next placed with the kinematics of its tool and linearized with it. Items
/// before the first entry use the machine definition's tool length.
pub fn solve_with_tools(
    kin: &dyn Kinematics,
    path: &ToolPath,
    policy: &Policy,
    lengths: &[LengthFrom],
) -> Result<Solved, SolveError> {
    let all = targets(path, policy.linearization_tolerance);
    let mut graph = BranchGraph::new(kin, policy, None);
    for t in &all {
        graph.push(t)?;
    }
    let placer = Placer::new(kin, policy, None, graph.finish());
    let mut placing = ToolPlacer::new(placer, Linearizer::new(policy), Stretches::new(kin, path, lengths));
    let mut out = Collected { steps: Vec::with_capacity(all.len()), decisions: Vec::new() };
    for t in &all {
        placing.push(t, &mut out)?;
    }
    Ok(Solved {
        steps: out.steps,
        decisions: out.decisions,
        inserted: placing.inserted(),
        unsettled: placing.unsettled(),
    })
}

/// The policy's second pass with the tools' lengths: each target placed with the kinematics of
/// the tool in the spindle, then linearized with them (afresh at each change of tool).
pub struct ToolPlacer<'a> {
    placer: Placer<'a>,
    linearizer: Linearizer,
    stretches: Stretches<'a>,
}

impl<'a> ToolPlacer<'a> {
    /// Places with `placer`, linearizes with `linearizer`, the tools as `stretches` say.
    pub fn new(placer: Placer<'a>, linearizer: Linearizer, stretches: Stretches<'a>) -> ToolPlacer<'a> {
        ToolPlacer { placer, linearizer, stretches }
    }

    /// The next target: its steps and decisions go to `out`.
    pub fn push(&mut self, t: &Target, out: &mut dyn StepSink) -> Result<(), SolveError> {
        if self.stretches.enter(t.span.start) {
            self.linearizer.restart();
        }
        let tool = self.stretches.tool();
        self.placer.push(&tool, t, &mut Linearizing { linearizer: &mut self.linearizer, kin: &tool, out })
    }

    /// Points linearization inserted so far.
    pub fn inserted(&self) -> usize {
        self.linearizer.inserted()
    }

    /// The segments linearization left out of tolerance so far ([`Linearizer::unsettled`]).
    pub fn unsettled(&self) -> crate::linearize::Unsettled {
        self.linearizer.unsettled()
    }

    /// The linearization's subdivisions ([`Linearizer::shape`]).
    pub fn shape(self) -> Shape {
        self.linearizer.shape()
    }
}

/// The stretches of a tool path that each tool's length applies to, walked in path order.
pub struct Stretches<'a> {
    kin: &'a dyn Kinematics,
    /// Where each stretch starts (a byte offset of the CL text) and its tool length.
    bounds: Vec<(u32, f64)>,
    /// The stretch walked.
    current: usize,
}

impl<'a> Stretches<'a> {
    /// The stretches of `path` for `lengths`, before its first item.
    pub fn new(kin: &'a dyn Kinematics, path: &ToolPath, lengths: &[LengthFrom]) -> Stretches<'a> {
        let starts = lengths.iter().map(|l| (path.items.get(l.item).map_or(u32::MAX, |i| i.span.start), l.length));
        Stretches::starting(kin, starts)
    }

    /// The stretches that start at the CL statements at `starts` (byte offsets, in path order)
    /// with their tool lengths, before the first statement.
    pub fn starting(kin: &'a dyn Kinematics, starts: impl IntoIterator<Item = (u32, f64)>) -> Stretches<'a> {
        let mut bounds: Vec<(u32, f64)> = vec![(0, kin.machine().chain.tool_length)];
        for (at, length) in starts {
            match bounds.last_mut() {
                Some(last) if last.0 == at => last.1 = length,
                _ => bounds.push((at, length)),
            }
        }
        Stretches { kin, bounds, current: 0 }
    }

    /// Moves to the stretch of the statement at byte offset `at` (offsets in path order); true
    /// when that is another stretch.
    pub fn enter(&mut self, at: u32) -> bool {
        let before = self.current;
        while self.current + 1 < self.bounds.len() && at >= self.bounds[self.current + 1].0 {
            self.current += 1;
        }
        self.current != before
    }

    /// The kinematics of the current stretch's tool.
    pub fn tool(&self) -> ToolLength<'a> {
        ToolLength::new(self.kin, self.bounds[self.current].1)
    }
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
    fn a_longer_tool_held_at_the_singularity_keeps_its_tip_on_the_pose() {
        // Near the nutating head's pole, with C held where the path carries it: the tool axis
        // reached is off the pose's (within the singular cone); the tip must not be, whatever
        // the tool's length.
        let chain = Chain::new(testing::nutating());
        let (c, b) = (3, 4);
        assert_eq!(chain.machine().axes[c].letter, "C");
        for extra in [-25.0, 37.5] {
            let tool = ToolLength::new(&chain, chain.machine().chain.tool_length + extra);
            let tilt = 0.3_f64.to_radians();
            let pose =
                Pose { tip: Point3::new(12.0, -8.0, 3.0), axis: Unit::new_normalize(Vector3::new(tilt, 0.0, 1.0)) };
            let mut sols = Solutions::new();
            tool.inverse(&pose, &mut sols);
            let pole = sols.iter().find_map(|s| s.pole).map(|(free, _)| free);
            assert_eq!(pole, Some(c), "C is free at the pole");
            for held in [0.5, 2.0] {
                let joints = tool.inverse_holding(&pose, c, held).expect("held");
                assert_eq!(joints[c], held);
                let back = tool.forward(&joints);
                let off = back.axis.angle(&pose.axis);
                assert!(off > 1e-4, "the axis reached is off the pose's ({off} rad), B = {}", joints[b]);
                assert!((back.tip - pose.tip).norm() < 1e-9, "tip {:?} for {:?} ({extra} mm)", back.tip, pose.tip);
            }
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
