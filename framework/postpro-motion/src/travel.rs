//! The program against the machine's travels, where the check means something.
//!
//! Rotary axes are machine values whatever the work offset: always checked (the policy chose
//! within them; the rotations postpro adds are checked here). Linear axes are written in the work
//! offset's frame: their machine coordinates are known only when the set-up says where the work
//! offset is (`work_offset_at`); then each is checked, else each axis's span must fit its travel
//! (a warning: no work offset could make a wider span fit; its help asks, where the CL file says
//! inches, whether its values are millimetres, as Creo's often are, and, where the table turns
//! the part, about where the part sits on it).
//! The moves postpro adds at the clearance are not checked for their linear values: the clearance
//! is the machine definition's, already checked.

use nalgebra::Point3;
use postpro_cl::{LengthUnit, Span, UnitsInfo, UnitsOrigin};
use postpro_kin::StepKind;
use postpro_machine::model::{AxisKind, Machine, Travel};

use crate::block::{Block, BlockKind, Position};
use crate::{MotionError, Program, Warning};

/// Checks `program` on `machine`; `work_offset_at` is the work offset's position in machine
/// coordinates (X, Y, Z of the linear axes), when the set-up gives it; `units` are the CL file's
/// (the warnings' help). Returns the warnings.
pub fn check(
    program: &Program,
    machine: &Machine,
    work_offset_at: Option<&Point3<f64>>,
    units: UnitsInfo,
) -> Result<Vec<Warning>, MotionError> {
    let mut check = TravelCheck::new(machine, work_offset_at, units);
    for block in &program.blocks {
        check.block(block)?;
    }
    Ok(check.finish())
}

/// The travel check as blocks come: an error at the first block beyond a travel that can be
/// checked, the spans of the others kept for the warnings at the end.
pub struct TravelCheck<'a> {
    machine: &'a Machine,
    /// Per linear axis, the offset of the work offset in machine coordinates, when known.
    shift: Vec<Option<f64>>,
    low: Vec<(f64, Span)>,
    high: Vec<(f64, Span)>,
    /// The CL file's length unit and what decided it.
    units: UnitsInfo,
}

impl<'a> TravelCheck<'a> {
    /// A check on `machine`, the work offset at `work_offset_at` in machine coordinates if known,
    /// of a CL file in `units`.
    pub fn new(machine: &'a Machine, work_offset_at: Option<&Point3<f64>>, units: UnitsInfo) -> TravelCheck<'a> {
        let count = machine.axes.len();
        let shift = (0..count)
            .map(|i| {
                let c = machine.chain.linear.iter().position(|&l| l == i)?;
                work_offset_at.map(|p| p[c.min(2)])
            })
            .collect();
        TravelCheck {
            machine,
            shift,
            low: vec![(f64::INFINITY, Span::default()); count],
            high: vec![(f64::NEG_INFINITY, Span::default()); count],
            units,
        }
    }

    /// The next block of the program.
    pub fn block(&mut self, block: &Block) -> Result<(), MotionError> {
        let span = block.span;
        match &block.kind {
            BlockKind::Rapid(r) => self.visit(&r.to, span),
            BlockKind::Linear(l) => l.via.iter().chain(std::iter::once(&l.to)).try_for_each(|p| self.visit(p, span)),
            BlockKind::Arc(a) => a.via.iter().chain(std::iter::once(&a.to)).try_for_each(|p| self.visit(p, span)),
            BlockKind::Spline(s) => s.points.iter().try_for_each(|p| self.visit(p, span)),
            _ => Ok(()),
        }
    }

    fn visit(&mut self, p: &Position, span: Span) -> Result<(), MotionError> {
        let added = matches!(p.kind, StepKind::Retract | StepKind::Reorient);
        for (i, axis) in self.machine.axes.iter().enumerate() {
            let rotary = axis.kind == AxisKind::Rotary;
            if !rotary && added {
                continue;
            }
            let shift = if rotary { None } else { self.shift[i] };
            let value = p.axes[i] + shift.unwrap_or(0.0);
            if (rotary || shift.is_some()) && !axis.travel.contains(value) {
                let Travel::Limited { min, max } = axis.travel else { continue };
                let (unit, show) =
                    if rotary { ("°", f64::to_degrees as fn(f64) -> f64) } else { (" mm", (|v| v) as fn(f64) -> f64) };
                return Err(MotionError::Travel {
                    span,
                    axis: axis.letter.clone(),
                    value: format!("{:.3}{unit}", show(value)),
                    travel: format!("{:.3}{unit} … {:.3}{unit}", show(min), show(max)),
                    help: if rotary {
                        "a rotary axis beyond its travel is not fixed by moving the part: choose another orientation \
                         of the part in the CAM system, or another machine"
                            .into()
                    } else {
                        "move the part (or the work offset: `work_offset_at` in the set-up) so that it lies within the \
                         travel, or choose another machine"
                            .into()
                    },
                });
            }
            if !rotary {
                if value < self.low[i].0 {
                    self.low[i] = (value, span);
                }
                if value > self.high[i].0 {
                    self.high[i] = (value, span);
                }
            }
        }
        Ok(())
    }

    /// The warnings: each linear axis whose span exceeds its travel, where the work offset's
    /// place is not known.
    pub fn finish(self) -> Vec<Warning> {
        let hint = span_hint(self.units, !self.machine.chain.part.is_empty());
        let mut warnings = Vec::new();
        for (i, axis) in self.machine.axes.iter().enumerate() {
            if axis.kind != AxisKind::Linear || self.shift[i].is_some() || !self.low[i].0.is_finite() {
                continue;
            }
            if let Travel::Limited { min, max } = axis.travel {
                let span = self.high[i].0 - self.low[i].0;
                if span > max - min + 1e-9 {
                    warnings.push(Warning {
                        span: self.high[i].1,
                        message: format!(
                            "the program spans {} mm in {} but its travel is {} mm: no work offset holds it ({hint})",
                            crate::number((span * 1000.0).round() / 1000.0),
                            axis.letter,
                            crate::number(((max - min) * 1000.0).round() / 1000.0)
                        ),
                    });
                }
            }
        }
        warnings
    }
}

/// What the span warning suggests: the unit first where the CL file's own says inches (Creo
/// writes `UNITS / INCHES` over millimetre values); on a machine whose table turns the part, where
/// the part sits on it (the spans depend on it); else setting the work offset's place.
fn span_hint(units: UnitsInfo, part_turns: bool) -> String {
    let said = match units {
        UnitsInfo { unit: LengthUnit::Inch, origin: UnitsOrigin::Declared(_) } => "its UNITS statement",
        UnitsInfo { unit: LengthUnit::Inch, origin: UnitsOrigin::FeedWord(_) } => "the unit word of its feeds",
        _ if part_turns => {
            return "the table turns the part: the spans depend on where the part zero sits from the rotation \
                    reference, `part_origin` in the set-up; `work_offset_at` checks the travels exactly"
                .into();
        }
        _ => return "set `work_offset_at` in the set-up to check the travels exactly".into(),
    };
    format!(
        "the CL file's values are read as inches, as {said} says: if they are millimetres, post it with \
         `--cl-units mm`"
    )
}

#[cfg(test)]
mod tests {
    use super::span_hint;
    use postpro_cl::{LengthUnit, Span, UnitsInfo, UnitsOrigin};

    #[test]
    fn the_span_warning_asks_about_the_unit_where_the_file_says_inches_then_about_the_part_origin() {
        for part_turns in [false, true] {
            let inch = |origin| span_hint(UnitsInfo { unit: LengthUnit::Inch, origin }, part_turns);
            assert!(inch(UnitsOrigin::Declared(Span::default())).contains("as its UNITS statement says"));
            assert!(inch(UnitsOrigin::FeedWord(Span::default())).contains("--cl-units mm"));
        }
        // The user said the unit, or the file said millimetres or nothing.
        for units in [
            UnitsInfo { unit: LengthUnit::Inch, origin: UnitsOrigin::Option },
            UnitsInfo { unit: LengthUnit::Mm, origin: UnitsOrigin::Declared(Span::default()) },
            UnitsInfo { unit: LengthUnit::Mm, origin: UnitsOrigin::Assumed },
        ] {
            assert!(span_hint(units, true).contains("`part_origin`"), "{units:?}");
            assert!(span_hint(units, false).starts_with("set `work_offset_at`"), "{units:?}");
        }
    }
}
