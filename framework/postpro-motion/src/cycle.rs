//! Canned cycles: the holes of a CL `CYCLE` drilled as the controller's cycle (G81…G89, Siemens
//! `CYCLE8x`, Heidenhain `CYCL DEF 20x`), or as explicit moves where the hole axis is not the
//! spindle's axis of the program's frame (or `--cycles expand`).
//!
//! The reader gives each hole's top point and the cycle's depth below it, R plane above it,
//! return level, pecks and dwell, all along the tool axis. Here they become values of the
//! spindle's linear axis in the program's frame, and the motion the controller makes at each hole
//! (across at the return level, down to the R plane at rapid, fed to the bottom peck by peck,
//! the dwell, out) is computed once: written move by move when expanded, kept for the prediction
//! when the controller's cycle is written.

use postpro_cl::{CycleKind, Delay, FeedPer, Motion, Span};
use postpro_kin::{Joints, Kinematics, Pose, Step, StepKind};

use crate::block::{BlockKind, Cycle, CycleMove, Hole, Linear, Position, Rapid};
use crate::build::Builder;
use crate::{AxisSet, MotionError};

/// How far above the last peck's depth the tool comes back down at rapid between pecks, and how
/// far a chip-breaking peck backs off (mm). Controllers set it in their parameters (LinuxCNC:
/// 0.010 in); this is for the prediction and the expanded moves.
const PECK_CLEARANCE: f64 = 0.5;

/// A canned cycle waiting for its holes.
pub(crate) struct PendingCycle {
    pub(crate) cycle: postpro_cl::Cycle,
    pub(crate) span: Span,
    /// The holes: the solved step of each, with its index.
    pub(crate) holes: Vec<(usize, Step, Motion)>,
}

impl Builder<'_> {
    /// A cycle starts: its holes follow.
    pub(crate) fn cycle_on(&mut self, span: Span, cycle: &postpro_cl::Cycle) -> Result<(), MotionError> {
        self.flush_cycle()?;
        self.cycle = Some(PendingCycle { cycle: cycle.clone(), span, holes: Vec::new() });
        Ok(())
    }

    /// A hole of the cycle in force (`false` when there is none: the move is an ordinary one).
    pub(crate) fn hole(&mut self, k: usize, step: &Step, motion: Motion) -> bool {
        match self.cycle.as_mut() {
            Some(pending) if step.kind == StepKind::Cl => {
                pending.holes.push((k, *step, motion));
                true
            }
            // A point linearization added between holes: the holes are not a path.
            Some(_) => true,
            None => false,
        }
    }

    /// Writes the cycle in force, if any.
    pub(crate) fn flush_cycle(&mut self) -> Result<(), MotionError> {
        let Some(pending) = self.cycle.take() else { return Ok(()) };
        let Some((_, first, motion)) = pending.holes.first().copied() else { return Ok(()) };
        let c = &pending.cycle;
        let span = pending.span;
        // Come to the first hole as any rapid does (by the clearance where the rotaries turn).
        let feed = c.feed.or(match motion {
            Motion::Feed(f) => Some(f),
            _ => None,
        });
        let Some(feed) = feed else {
            return Err(MotionError::Cycle {
                span,
                what: format!("the {} cycle has no feed: none in its CYCLE record, none programmed before it", c.word),
                help: "give the cycle's feed (MMPM) or program a FEDRAT before it".into(),
            });
        };
        let dwell = match c.dwell {
            None => None,
            Some(Delay::Seconds(s)) => Some(s),
            Some(Delay::Revolutions(r)) => match self.spindle_rpm.filter(|rpm| *rpm > 0.0) {
                Some(rpm) => Some(r * 60.0 / rpm),
                None => {
                    return Err(MotionError::Cycle {
                        span,
                        what: "the cycle's dwell is in spindle revolutions, and no spindle speed is programmed".into(),
                        help: "program the spindle speed (SPINDL) before the cycle".into(),
                    });
                }
            },
        }
        .filter(|s| *s > 0.0);
        let (feed_word, note) = self.feed_word(feed, span);
        if feed.per == FeedPer::Revolution && self.spindle_rpm.is_none() {
            return Err(MotionError::Cycle {
                span,
                what: "the cycle's feed is per revolution, and no spindle speed is programmed".into(),
                help: "program the spindle speed (SPINDL) before the cycle".into(),
            });
        }
        // The level the cycle starts at: where the tool is, above the first hole, at least the
        // return level the CL file asks for.
        let axis = first.pose.axis.into_inner();
        let above = |s: &Step, joints: &Joints| (self.kin.forward(joints).tip - s.pose.tip).dot(&axis);
        let asked = c.retract.unwrap_or(c.clearance);
        let start = self.current.map_or(asked, |q| above(&first, &q).max(asked));
        // To the first hole's start level as any rapid goes: by the clearance where the rotary
        // axes turn or the position is not known.
        let (first_k, _, _) = pending.holes[0];
        if self.options.clearance
            && self.current.is_none_or(|q| !crate::arc::same_rotaries(self.base, &q, &first.joints))
        {
            let tip = first.pose.tip + axis * start;
            let joints = self.kin.place(&Pose { tip, axis: first.pose.axis }, &first.joints);
            let approach = Step { joints, pose: Pose { tip, axis: first.pose.axis }, rapid: true, ..first };
            self.reposition(first_k, &approach, false);
        }
        // Every hole on the same rotaries, and its axis the spindle axis of the frame, for the
        // controller's cycle.
        let spindle = self.machine.spindle_linear_axis();
        let mut holes = Vec::with_capacity(pending.holes.len());
        // In a dynamic work offset the coordinates are the part's: the hole axis is none of them.
        let dynamic = self.plane == Some(crate::block::PlaneKind::Dynamic);
        let mut native = self.options.cycles && spindle.is_some() && !dynamic;
        let mut motion_out: Vec<CycleMove> = Vec::new();
        let mut level = start;
        for (n, &(k, step, _)) in pending.holes.iter().enumerate() {
            if !crate::arc::same_rotaries(self.base, &first.joints, &step.joints) {
                native = false;
            }
            let at = |h: f64| {
                let tip = step.pose.tip + step.pose.axis.into_inner() * h;
                let joints = self.kin.place(&Pose { tip, axis: step.pose.axis }, &step.joints);
                self.added(joints, k, StepKind::Cl)
            };
            let (top, bottom, r, initial) = (at(0.0), at(-c.depth), at(c.clearance), at(start));
            if let Some(axis) = spindle {
                let along = |p: &Position, q: &Position| {
                    (0..self.machine.axes.len()).all(|i| i == axis || (p.axes[i] - q.axes[i]).abs() <= 1e-6)
                };
                if !(along(&top, &bottom) && along(&top, &r) && bottom.axes[axis] < top.axes[axis] - 1e-9) {
                    native = false;
                }
                holes.push(Hole {
                    at: Position { kind: StepKind::Cl, ..top },
                    bottom: bottom.axes[axis],
                    r_plane: r.axes[axis],
                    initial: initial.axes[axis],
                });
            }
            // Across at the level the tool is at, down to the R plane, in, out.
            let rapid = |to: Position| CycleMove { to, rapid: true, dwell: 0.0 };
            let fed = |to: Position| CycleMove { to, rapid: false, dwell: 0.0 };
            motion_out.push(rapid(at(level)));
            if (level - c.clearance).abs() > 1e-9 {
                motion_out.push(rapid(at(c.clearance)));
            }
            let mut depth = 0.0; // below the R plane
            let total = c.depth + c.clearance;
            let mut pecks = 0;
            loop {
                let step_down = match (c.kind, c.peck) {
                    (CycleKind::Deep | CycleKind::ChipBreak, Some(p)) => {
                        if pecks == 0 {
                            p.first
                        } else {
                            p.next
                        }
                    }
                    _ => total,
                };
                let target = (depth + step_down.max(1e-3)).min(total);
                if pecks > 0 {
                    // Back down near the last depth at rapid (G83), or on from the back-off (G73).
                    if c.kind == CycleKind::Deep {
                        motion_out.push(rapid(at(c.clearance - (depth - PECK_CLEARANCE).max(0.0))));
                    }
                }
                motion_out.push(fed(at(c.clearance - target)));
                pecks += 1;
                if target >= total - 1e-9 {
                    break;
                }
                match c.kind {
                    CycleKind::Deep => motion_out.push(rapid(at(c.clearance))),
                    _ => motion_out.push(rapid(at(c.clearance - target + PECK_CLEARANCE))),
                }
                depth = target;
            }
            let back = if c.retract.is_some() { start } else { c.clearance };
            let dwell_at_bottom = dwell.unwrap_or(0.0);
            match c.kind {
                CycleKind::Bore | CycleKind::Tap => {
                    motion_out.push(CycleMove { to: at(c.clearance), rapid: false, dwell: dwell_at_bottom });
                    if (back - c.clearance).abs() > 1e-9 {
                        motion_out.push(rapid(at(back)));
                    }
                }
                _ => motion_out.push(CycleMove { to: at(back), rapid: true, dwell: dwell_at_bottom }),
            }
            level = back;
            if n == 0 && c.kind == CycleKind::Tap && !native {
                return Err(MotionError::Cycle {
                    span,
                    what: "a tapping cycle whose hole axis is not the spindle's axis of the program".into(),
                    help: "a tap cannot be written as moves (the spindle reverses in step with the feed): drill \
                           the holes in an orientation where the tool is along the spindle axis"
                        .into(),
                });
            }
        }
        let Some(axis) = spindle.filter(|_| native) else {
            // As moves.
            let last = motion_out.last().map(|m| m.to);
            self.push(span, BlockKind::Comment(format!("CYCLE/{} {}: written as moves", c.word, c.args)));
            for m in motion_out {
                if m.dwell > 0.0 {
                    self.push(span, BlockKind::Dwell(m.dwell));
                }
                let kind = if m.rapid {
                    BlockKind::Rapid(Rapid { to: m.to, axes: AxisSet::ALL })
                } else {
                    BlockKind::Linear(Linear { to: m.to, feed: feed_word, note: note.clone(), via: Vec::new() })
                };
                self.push(span, kind);
            }
            self.finish_cycle(&pending.holes, last.as_ref());
            return Ok(());
        };
        let last = motion_out.last().map(|m| m.to);
        let cycle = Cycle {
            kind: c.kind,
            holes,
            axis,
            peck: c.peck.map(|p| (p.first, p.next)),
            dwell,
            feed: feed_word,
            note,
            to_initial: c.retract.is_some(),
            rpm: self.spindle_rpm,
            motion: motion_out,
        };
        self.push(span, BlockKind::Cycle(Box::new(cycle)));
        self.finish_cycle(&pending.holes, last.as_ref());
        Ok(())
    }

    /// Where the machine is after the cycle: at the return level above the last hole.
    fn finish_cycle(&mut self, holes: &[(usize, Step, Motion)], last: Option<&Position>) {
        if let Some(&(k, step, _)) = holes.last() {
            self.last_step = Some((step, k));
        }
        if let Some(p) = last {
            self.current = Some(self.job.frame.unapply(&p.axes));
            self.last_tip = Some(p.pose.tip);
        }
        self.at_clearance = false;
    }
}
