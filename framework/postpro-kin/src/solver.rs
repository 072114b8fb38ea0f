//! The solver interface: forward kinematics and **every** inverse solution. Choosing among the
//! solutions is the policy's job (`crate::policy`), never the solver's.

use postpro_machine::model::{Machine, SolverKind};

use crate::chain::Chain;
use crate::closed::TableTableClosedForm;
use crate::pose::{Bend, Joints, Pose, PoseRate};

/// One inverse solution.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Solution {
    /// Axis values; rotary angles in (−π, π] (the policy unwraps them).
    pub joints: Joints,
    /// The branch: 0 or 1 for the two solutions of a 5-axis machine, 0 otherwise.
    pub branch: u8,
    /// The rotary axis that becomes free at the singularity and the angle (rad) between the
    /// pose and that singularity. At the singularity itself the free angle is arbitrary (0).
    pub pole: Option<(usize, f64)>,
}

/// Up to two solutions (5-axis machines have two branches away from the singularity).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Solutions {
    items: [Option<Solution>; 2],
}

impl Solutions {
    /// No solution.
    pub fn new() -> Solutions {
        Solutions::default()
    }

    /// Adds a solution (at most two are kept).
    pub fn push(&mut self, s: Solution) {
        if let Some(slot) = self.items.iter_mut().find(|s| s.is_none()) {
            *slot = Some(s);
        }
    }

    /// Removes every solution.
    pub fn clear(&mut self) {
        self.items = [None, None];
    }

    /// The solutions.
    pub fn iter(&self) -> impl Iterator<Item = &Solution> {
        self.items.iter().flatten()
    }

    /// Number of solutions.
    pub fn len(&self) -> usize {
        self.items.iter().flatten().count()
    }

    /// True without solutions.
    pub fn is_empty(&self) -> bool {
        self.items[0].is_none()
    }
}

/// A machine's kinematics: an open set (closed forms, the generic chain, plugins).
pub trait Kinematics: Send + Sync {
    /// The machine.
    fn machine(&self) -> &Machine;

    /// The pose of the tool in the part frame for the given axis values.
    fn forward(&self, joints: &Joints) -> Pose;

    /// Every solution for a pose, without range checks; empty when the orientation cannot be
    /// reached at all (a 3- or 4-axis machine and a tool axis it cannot take).
    fn inverse(&self, pose: &Pose, out: &mut Solutions);

    /// The solution with the free rotary axis of a singularity held at `value`: the other
    /// rotary angle that best matches the tool axis, and the linear axes that put the tip
    /// exactly on the pose. `None` if the machine has no such axis.
    fn inverse_holding(&self, pose: &Pose, free_axis: usize, value: f64) -> Option<Joints>;

    /// The axis values that put the tip on `pose.tip` with the rotary angles of `rotaries`
    /// (their tool axis is whatever those angles give): the linear axes from the forward
    /// kinematics.
    fn place(&self, pose: &Pose, rotaries: &Joints) -> Joints;

    /// Upper bounds of how the tool bends in the part frame while the axes move linearly from
    /// `a` to `b`: what proves a move straight enough to need no check. `None` (the default)
    /// where the kinematics gives none; the moves are then checked point by point.
    fn bend(&self, a: &Joints, b: &Joints) -> Option<Bend> {
        let _ = (a, b);
        None
    }

    /// How fast the tool tip and the tool axis move in the part frame when the axes move from
    /// `joints` at `rates`: the derivative of [`Self::forward`] along `rates`. By default a
    /// central difference of it (steps of 1e-5 mm or rad on the fastest axis); the generic chain
    /// differentiates exactly.
    fn forward_rate(&self, joints: &Joints, rates: &Joints) -> PoseRate {
        let fastest = rates.as_slice().iter().fold(0.0_f64, |m, r| m.max(r.abs()));
        if fastest == 0.0 || !fastest.is_finite() {
            return PoseRate::default();
        }
        let h = 1e-5 / fastest;
        let along = |t: f64| {
            let mut j = *joints;
            for (x, r) in j.as_mut_slice().iter_mut().zip(rates.as_slice()) {
                *x += t * r;
            }
            self.forward(&j)
        };
        let (before, after) = (along(-h), along(h));
        PoseRate {
            tip: (after.tip - before.tip) / (2.0 * h),
            axis: (after.axis.into_inner() - before.axis.into_inner()) / (2.0 * h),
        }
    }
}

/// The solver a machine definition asks for. `solver: plugin` gets the generic chain of the
/// definition here: a plugin's compiled kinematics is loaded by the plugin host
/// (`postpro-plugins`), which checks it against this same chain.
pub fn solver_for(machine: &Machine) -> Box<dyn Kinematics> {
    match machine.solver {
        SolverKind::Generic | SolverKind::Plugin => Box::new(Chain::new(machine.clone())),
        SolverKind::ClosedForm(form) => match TableTableClosedForm::new(machine.clone(), form) {
            Some(closed) => Box::new(closed),
            // Validation rejects closed forms on other shapes; the generic chain is still right.
            None => Box::new(Chain::new(machine.clone())),
        },
    }
}
