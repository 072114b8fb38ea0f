//! The program against the machine's travels, where the check means something.
//!
//! Rotary axes are machine values whatever the work offset: always checked (the policy chose
//! within them; the rotations postpro adds are checked here). Linear axes are written in the work
//! offset's frame: their machine coordinates are known only when the set-up says where the work
//! offset is (`work_offset_at`); then each is checked, else each axis's span must fit its travel
//! (a warning: the part may still not fit where the shop clamps it, but no offset could make it).
//! The moves postpro adds at the clearance are not checked for their linear values: the clearance
//! is the machine definition's, already checked.

use nalgebra::Point3;
use postpro_cl::Span;
use postpro_kin::StepKind;
use postpro_machine::model::{AxisKind, Machine, Travel};

use crate::block::{BlockKind, Position};
use crate::{MotionError, Program, Warning};

/// Checks `program` on `machine`; `work_offset_at` is the work offset's position in machine
/// coordinates (X, Y, Z of the linear axes), when the set-up gives it. Returns the warnings.
pub fn check(
    program: &Program,
    machine: &Machine,
    work_offset_at: Option<&Point3<f64>>,
) -> Result<Vec<Warning>, MotionError> {
    let count = machine.axes.len();
    let mut low = vec![(f64::INFINITY, Span::default()); count];
    let mut high = vec![(f64::NEG_INFINITY, Span::default()); count];
    let shift = |i: usize| {
        let c = machine.chain.linear.iter().position(|&l| l == i)?;
        work_offset_at.map(|p| p[c.min(2)])
    };
    let mut visit = |p: &Position, span: Span| -> Result<(), MotionError> {
        let added = matches!(p.kind, StepKind::Retract | StepKind::Reorient);
        for (i, axis) in machine.axes.iter().enumerate() {
            let rotary = axis.kind == AxisKind::Rotary;
            if !rotary && added {
                continue;
            }
            let value = p.axes[i] + if rotary { 0.0 } else { shift(i).unwrap_or(0.0) };
            if (rotary || shift(i).is_some()) && !axis.travel.contains(value) {
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
                if value < low[i].0 {
                    low[i] = (value, span);
                }
                if value > high[i].0 {
                    high[i] = (value, span);
                }
            }
        }
        Ok(())
    };
    for block in &program.blocks {
        let span = block.span;
        match &block.kind {
            BlockKind::Rapid(r) => visit(&r.to, span)?,
            BlockKind::Linear(l) => {
                for p in l.via.iter().chain(std::iter::once(&l.to)) {
                    visit(p, span)?;
                }
            }
            BlockKind::Arc(a) => {
                for p in a.via.iter().chain(std::iter::once(&a.to)) {
                    visit(p, span)?;
                }
            }
            BlockKind::Spline(s) => {
                for p in &s.points {
                    visit(p, span)?;
                }
            }
            _ => {}
        }
    }
    let mut warnings = Vec::new();
    for (i, axis) in machine.axes.iter().enumerate() {
        if axis.kind != AxisKind::Linear || shift(i).is_some() || !low[i].0.is_finite() {
            continue;
        }
        if let Travel::Limited { min, max } = axis.travel {
            let span = high[i].0 - low[i].0;
            if span > max - min + 1e-9 {
                warnings.push(Warning {
                    span: high[i].1,
                    message: format!(
                        "the program spans {} mm in {} but its travel is {} mm: no work offset holds it (set \
                         `work_offset_at` in the set-up to check the travels exactly)",
                        crate::number((span * 1000.0).round() / 1000.0),
                        axis.letter,
                        crate::number(((max - min) * 1000.0).round() / 1000.0)
                    ),
                });
            }
        }
    }
    Ok(warnings)
}
