//! What the motion program must know of the whole path before it writes its first block, read
//! from the solved steps as they come (a first pass of a streamed job): which steps stand in a
//! 3+2 set-up (their rotary axes stand until a rapid turns them) and which are simultaneous
//! motion, whether any feed move turns a rotary axis, whether any step tilts.

use nalgebra::Vector3;
use postpro_kin::{Joints, Kinematics, Step, StepKind};
use postpro_machine::model::AxisKind;

/// For every step, whether its rotary axes stand until the next step that turns them is a rapid
/// (or the end): a 3+2 set-up, where the brakes may lock and a working plane may stand; else
/// simultaneous motion. Held run-length encoded: a few entries per set-up, none per step. Or,
/// before the steps exist, guessed from the CL file's tool axes ([`SetUps::guessed`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SetUps {
    /// From step `.0` on (until the next entry), the answer is `.1`.
    changes: Vec<(usize, bool)>,
    /// The guess the answers come from instead.
    guess: Option<AxisStretches>,
}

impl SetUps {
    /// The set-ups guessed from the tool axes of the CL statements (see [`AxisStretches`]).
    pub fn guessed(guess: AxisStretches) -> SetUps {
        SetUps { changes: Vec::new(), guess: Some(guess) }
    }

    /// True when the rotary axes of step `k` stand until the next rapid that turns them.
    pub fn indexed_from(&self, k: usize) -> bool {
        indexed(&self.changes, k)
    }

    /// The guessed answer for the step of the CL statement at `offset`, when guessed.
    pub(crate) fn guess_at(&self, offset: u32) -> Option<bool> {
        self.guess.as_ref().map(|g| indexed(&g.changes, offset))
    }

    /// True when every answer a motion program took from a guess, `(step, answer)`, is the one
    /// these set-ups (surveyed from the steps) give: the program is then the one they build.
    pub fn agrees(&self, answers: &[(usize, bool)]) -> bool {
        answers.iter().all(|&(k, answer)| self.indexed_from(k) == answer)
    }

    fn record(&mut self, from: usize, indexed: bool) {
        record(&mut self.changes, from, indexed);
    }
}

/// The answer at `key` of run-length encoded answers (none recorded: standing).
fn indexed<K: Ord + Copy>(changes: &[(K, bool)], key: K) -> bool {
    let i = changes.partition_point(|c| c.0 <= key);
    i.checked_sub(1).is_none_or(|i| changes[i].1)
}

/// Appends `indexed` from `from` on, where the answer changes.
fn record<K>(changes: &mut Vec<(K, bool)>, from: K, indexed: bool) {
    if changes.last().map(|c| c.1) != Some(indexed) {
        changes.push((from, indexed));
    }
}

/// How far two tool axes of one stretch may differ, for the guess: the noise of a CAM system's
/// seven decimals (a unit of the last, rounded, in each component), below the half unit of a
/// rotary axis written to four decimals (`crate::arc::same_rotaries`, which the survey applies).
const AXIS_NOISE: f64 = 5e-7;

/// The 3+2 set-ups guessed before the steps exist, from the CL file's tool axes (the survey pass
/// of a streamed job reads them): a stretch of one tool axis that a rapid (or the end) ends
/// stands, as [`SetUps`] says of the rotary axes' values; keyed by the CL statements' offsets.
/// A motion program built from the guess keeps the answers it took
/// ([`crate::Stage::guessed_answers`]): it is the program of the surveyed set-ups where they
/// agree ([`SetUps::agrees`]); else it must be built again.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct AxisStretches {
    /// From the statement at offset `.0` on, the answer is `.1`.
    changes: Vec<(u32, bool)>,
    /// The current stretch: its first statement's offset and its tool axis.
    stretch: Option<(u32, Vector3<f64>)>,
}

impl AxisStretches {
    /// The next target: at the statement at `offset`, the tool along `axis`, reached at rapid
    /// traverse or not.
    pub fn target(&mut self, offset: u32, axis: &Vector3<f64>, rapid: bool) {
        match self.stretch {
            Some((_, standing)) if (standing - axis).norm() <= AXIS_NOISE => {}
            Some((first, _)) => {
                // The stretch ends here: by a rapid, a set-up; at feed, simultaneous motion.
                record(&mut self.changes, first, rapid);
                self.stretch = Some((offset, *axis));
            }
            None => self.stretch = Some((offset, *axis)),
        }
    }

    /// The guess, once every target is in.
    pub fn finish(mut self) -> AxisStretches {
        if let Some((first, _)) = self.stretch.take() {
            record(&mut self.changes, first, true);
        }
        self
    }
}

/// What the steps of a whole path say (see the module's documentation).
#[derive(Clone, Debug, Default, PartialEq)]
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
                // The stretch ends here: by a rapid, a set-up; at feed, simultaneous motion (also
                // where each feed move turned the rotaries by less than `same_rotaries` tells
                // apart, and they drifted away from the stretch's start).
                self.survey.set_ups.record(first, rapid);
                self.survey.simultaneous |= !rapid;
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

#[cfg(test)]
mod tests {
    use nalgebra::Vector3;

    use super::{AxisStretches, SetUps};

    #[test]
    fn a_tool_axis_a_rapid_changes_stands_and_one_a_feed_changes_does_not() {
        let (z, tilted, turning) = (Vector3::z(), Vector3::new(0.0, 0.5, 0.75_f64.sqrt()), Vector3::new(0.1, 0.0, 1.0));
        let mut guess = AxisStretches::default();
        // Statements at offsets 0, 10, 20: along Z (a set-up: a rapid ends it); 30 at rapid, 40
        // at feed: tilted (simultaneous: a feed move turns it); 50 at feed: turning, a set-up of
        // one point (a rapid ends it); 60 at rapid: along Z to the end.
        for (offset, axis, rapid) in [
            (0, z, true),
            (10, z, false),
            (20, z, false),
            (30, tilted, true),
            (40, tilted, false),
            (50, turning, false),
        ] {
            guess.target(offset, &axis, rapid);
        }
        guess.target(60, &z, true);
        let set_ups = SetUps::guessed(guess.finish());
        let answers: Vec<bool> =
            [0, 20, 30, 45, 50, 60, 70].iter().map(|&o| set_ups.guess_at(o) == Some(true)).collect();
        assert_eq!(answers, [true, true, false, false, true, true, true]);
        // Surveyed set-ups answer by step, and guess nothing.
        assert_eq!(SetUps::default().guess_at(0), None);
    }

    #[test]
    fn the_guess_takes_a_cam_systems_rounding_of_a_tool_axis_for_one_axis() {
        let z = Vector3::z();
        let noisy = Vector3::new(1e-7, -1e-7, 1.0).normalize();
        let turned = Vector3::new(1e-5, 0.0, 1.0).normalize();
        let guess_of = |second: Vector3<f64>| {
            let mut guess = AxisStretches::default();
            guess.target(0, &z, true);
            guess.target(10, &z, false);
            guess.target(20, &second, false);
            guess.target(30, &z, true);
            SetUps::guessed(guess.finish())
        };
        assert_eq!(guess_of(noisy).guess_at(20), Some(true), "rounding noise: one set-up");
        assert_eq!(guess_of(turned).guess_at(10), Some(false), "a turn at feed: simultaneous");
    }

    #[test]
    fn guessed_answers_agree_only_with_the_set_ups_that_give_them() {
        let mut surveyed = SetUps::default();
        surveyed.record(0, true);
        surveyed.record(5, false);
        surveyed.record(9, true);
        assert!(surveyed.agrees(&[]));
        assert!(surveyed.agrees(&[(0, true), (6, false), (12, true)]));
        assert!(!surveyed.agrees(&[(0, true), (7, true)]));
    }
}
