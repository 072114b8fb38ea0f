//! From the tool path of the reader to the poses the kinematics reaches: moves as they are,
//! arcs and NURBS as points within a chord tolerance.

use postpro_cl::{Item, ItemKind, Motion, MoveKind, ToolPath};

use crate::policy::Target;
use crate::pose::Pose;

/// The targets of a tool path: one per move, arcs and NURBS cut into points whose chords stay
/// within `chord_tolerance` (mm) of the curve.
pub fn targets(path: &ToolPath, chord_tolerance: f64) -> Vec<Target> {
    let mut out = Vec::with_capacity(path.items.len());
    for item in &path.items {
        targets_of(item, chord_tolerance, &mut out);
    }
    out
}

/// The targets of one item of a tool path (none but for moves, arcs and NURBS), added to `out`.
pub fn targets_of(item: &Item, chord_tolerance: f64, out: &mut Vec<Target>) {
    let tol = chord_tolerance.max(1e-6);
    match &item.kind {
        ItemKind::Move(m) => out.push(Target {
            pose: Pose { tip: m.to, axis: m.axis },
            rapid: m.motion == Motion::Rapid || m.kind == MoveKind::From,
            span: item.span,
        }),
        ItemKind::Arc(a) => {
            // Chord error r(1 − cos(φ/2)) ≤ tol.
            let step = 2.0 * (1.0 - (tol / a.radius).min(1.0)).acos();
            let n = ((a.sweep / step.max(1e-6)).ceil() as usize).clamp(1, 100_000);
            for k in 1..=n {
                let tip = a.point_at(k as f64 / n as f64);
                out.push(Target {
                    pose: Pose { tip, axis: a.axis },
                    rapid: a.motion == Motion::Rapid,
                    span: item.span,
                });
            }
        }
        ItemKind::Nurbs(c) => {
            for tip in c.even_points((16 * c.control.len()).max(2)).skip(1) {
                out.push(Target {
                    pose: Pose { tip, axis: c.axis },
                    rapid: c.motion == Motion::Rapid,
                    span: item.span,
                });
            }
        }
        _ => {}
    }
}
