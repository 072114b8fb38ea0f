//! What the motion program must know of the whole path before it writes its first block, read
//! from the solved steps as they come (a first pass of a streamed job): which steps stand in a
//! 3+2 set-up (their rotary axes stand until a rapid turns them) and which are simultaneous
//! motion, whether any feed move turns a rotary axis, whether any step tilts.

use postpro_kin::{Joints, Kinematics, Step, StepKind};
use postpro_machine::model::AxisKind;

/// For every step, whether its rotary axes stand until the next step that turns them is a rapid
/// (or the end): a 3+2 set-up, where the brakes may lock and a working plane may stand; else
/// simultaneous motion. Held run-length encoded: a few entries per set-up, none per step.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct SetUps {
    /// From step `.0` on (until the next entry), the answer is `.1`.
    changes: Vec<(usize, bool)>,
}

impl SetUps {
    /// True when the rotary axes of step `k` stand until the next rapid that turns them.
    pub fn indexed_from(&self, k: usize) -> bool {
        let i = self.changes.partition_point(|c| c.0 <= k);
        i.checked_sub(1).is_none_or(|i| self.changes[i].1)
    }

    fn record(&mut self, from: usize, indexed: bool) {
        if self.changes.last().map(|c| c.1) != Some(indexed) {
            self.changes.push((from, indexed));
        }
    }
}

/// What the steps of a whole path say (see the module's documentation).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Survey {
    /// Which steps stand in a 3+2 set-up.
    pub set_ups: SetUps,
    /// A feed move turns a rotary axis (simultaneous 4- or 5-axis motion).
    pub simultaneous: bool,
    /// A step has a rotary axis away from its zero.
    pub tilted: bool,
}

impl Survey {
    /// The survey of `steps`.
    pub fn of(kin: &dyn Kinematics, steps: &[Step]) -> Survey {
        let mut surveyor = Surveyor::new(kin);
        for s in steps {
            surveyor.step(s);
        }
        surveyor.finish()
    }
}

/// Takes the steps one at a time and makes the [`Survey`].
pub struct Surveyor<'a> {
    kin: &'a dyn Kinematics,
    rotary: Vec<usize>,
    /// Steps so far.
    count: usize,
    /// The first step of the stretch whose rotary axes stand, and their values.
    stretch: Option<(usize, Joints)>,
    /// The previous step's rotary values.
    previous: Option<Joints>,
    survey: Survey,
}

impl<'a> Surveyor<'a> {
    /// A survey of a path on the machine of `kin`.
    pub fn new(kin: &'a dyn Kinematics) -> Surveyor<'a> {
        let machine = kin.machine();
        let rotary = (0..machine.axes.len()).filter(|&i| machine.axes[i].kind == AxisKind::Rotary).collect();
        Surveyor { kin, rotary, count: 0, stretch: None, previous: None, survey: Survey::default() }
    }

    /// The next step.
    pub fn step(&mut self, step: &Step) {
        let k = self.count;
        self.count += 1;
        let rapid = step.rapid || matches!(step.kind, StepKind::Retract | StepKind::Reorient);
        if let Some(previous) = self.previous
            && !rapid
            && !crate::arc::same_rotaries(self.kin, &previous, &step.joints)
        {
            self.survey.simultaneous = true;
        }
        self.previous = Some(step.joints);
        self.survey.tilted |= self.rotary.iter().any(|&i| step.joints[i].abs() > 1e-9);
        match self.stretch {
            Some((_, joints)) if crate::arc::same_rotaries(self.kin, &joints, &step.joints) => {}
            Some((first, _)) => {
                // The stretch ends here: by a rapid, a set-up; at feed, simultaneous motion.
                self.survey.set_ups.record(first, rapid);
                self.stretch = Some((k, step.joints));
            }
            None => self.stretch = Some((k, step.joints)),
        }
    }

    /// The survey of the steps taken.
    pub fn finish(mut self) -> Survey {
        if let Some((first, _)) = self.stretch {
            self.survey.set_ups.record(first, true);
        }
        self.survey
    }
}
