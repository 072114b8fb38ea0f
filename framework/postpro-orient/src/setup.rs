//! A 3+2 set-up applied to a CL program: every move of a path gets the set-up's tool axis, and
//! its tool tip moves so that the ball's centre stays where the CAM system put it
//! (`tip' = tip + r (a − a')` for a ball-end tool of radius `r`): the same surface is cut, with
//! the tool held differently. Between two paths the retract keeps the axis of the path it leaves
//! and, from the first rapid on, the moves take the axis of the path that follows (the machine
//! turns during the rapid); moves after the last path keep its axis.

use std::ops::Range;

use nalgebra::{Unit, Vector3};
use postpro_cl::{ItemKind, ToolPath};

/// The tool axis for a run of items.
#[derive(Clone, Debug, PartialEq)]
pub struct Setup {
    /// Items of the tool path (indices into `ToolPath::items`).
    pub items: Range<usize>,
    /// The tool axis in the part frame; `None` keeps the program's (a 5-axis path).
    pub axis: Option<Unit<Vector3<f64>>>,
}

/// What the re-orientation assumed.
#[derive(Clone, Debug)]
pub struct Applied {
    /// The re-oriented tool path.
    pub path: ToolPath,
    /// Tools that are not ball-end mills (corner radius below half the diameter): the centre of
    /// their corner radius is kept, which is not the same cut. Their diameters and corner radii.
    pub not_ball: Vec<(f64, f64)>,
    /// Moves made without a known tool shape (ball centre = tip: no shift).
    pub without_shape: usize,
}

/// `path` with every move re-oriented by `setups` (sorted, not overlapping). With no set-up the
/// path is returned as it is.
pub fn apply(path: &ToolPath, setups: &[Setup]) -> Applied {
    let mut out = path.clone();
    let mut not_ball: Vec<(f64, f64)> = Vec::new();
    let mut without_shape = 0;
    if setups.is_empty() {
        return Applied { path: out, not_ball, without_shape };
    }
    let mut radius: Option<f64> = None;
    let mut next = 0; // the set-up that the current item belongs to or precedes
    let mut rapid_since = true; // a rapid since the end of the set-up before `next`
    for (index, item) in out.items.iter_mut().enumerate() {
        while next + 1 < setups.len() && index >= setups[next].items.end {
            next += 1;
            rapid_since = false;
        }
        if matches!(&item.kind, ItemKind::Move(m) if m.motion == postpro_cl::Motion::Rapid) {
            rapid_since = true;
        }
        // Between two paths: the retract keeps the path's axis; from the first rapid on, the
        // machine turns to the next path's.
        let inside = setups[next].items.contains(&index) || index >= setups[next].items.end;
        let axis = if inside || rapid_since || next == 0 { setups[next].axis } else { setups[next - 1].axis };
        let Some(axis) = axis else {
            if let ItemKind::ToolShape(shape) = &item.kind {
                radius = Some(shape.corner_radius.max(0.0));
            }
            continue;
        };
        let r = radius.unwrap_or(0.0);
        let shift = |old: &Unit<Vector3<f64>>| (old.into_inner() - axis.into_inner()) * r;
        let moved = match &mut item.kind {
            ItemKind::ToolShape(shape) => {
                radius = Some(shape.corner_radius.max(0.0));
                if shape.corner_radius + 1e-6 < shape.diameter / 2.0
                    && !not_ball.contains(&(shape.diameter, shape.corner_radius))
                {
                    not_ball.push((shape.diameter, shape.corner_radius));
                }
                false
            }
            ItemKind::Move(m) => {
                m.to += shift(&m.axis);
                m.axis = axis;
                true
            }
            ItemKind::Arc(a) => {
                let d = shift(&a.axis);
                a.start += d;
                a.center += d;
                a.end += d;
                a.axis = axis;
                true
            }
            ItemKind::Nurbs(n) => {
                let d = shift(&n.axis);
                for p in &mut n.control {
                    *p += d;
                }
                n.axis = axis;
                true
            }
            _ => false,
        };
        if moved && radius.is_none() {
            without_shape += 1;
        }
    }
    Applied { path: out, not_ball, without_shape }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn read(text: &str) -> ToolPath {
        let path = postpro_cl::read(&postpro_cl::Source::new("t.cl", text));
        assert!(!path.has_errors(), "{:?}", path.diagnostics);
        path
    }

    #[test]
    fn the_ball_centre_stays_where_it_was() {
        let path = read(
            "CUTTER/10,5\nMULTAX\nFEDRAT/MMPM,1000\nGOTO/0,0,0,0,0,1\nGOTO/10,0,0,0,0,1\nRAPID\nGOTO/10,0,50,0,0,1\n",
        );
        let axis = Unit::new_normalize(Vector3::new(1.0, 0.0, 1.0));
        let applied = apply(&path, &[Setup { items: 0..path.items.len(), axis: Some(axis) }]);
        assert!(applied.not_ball.is_empty());
        let (old, new): (Vec<_>, Vec<_>) = path
            .items
            .iter()
            .zip(&applied.path.items)
            .filter_map(|(a, b)| match (&a.kind, &b.kind) {
                (ItemKind::Move(a), ItemKind::Move(b)) => Some((*a, *b)),
                _ => None,
            })
            .unzip();
        assert_eq!(old.len(), 3);
        for (a, b) in old.iter().zip(&new) {
            let centre_before = a.to + a.axis.into_inner() * 5.0;
            let centre_after = b.to + b.axis.into_inner() * 5.0;
            assert!((centre_before - centre_after).norm() < 1e-12);
            assert!((b.axis.into_inner() - axis.into_inner()).norm() < 1e-12);
        }
    }

    #[test]
    fn a_flat_end_mill_is_reported() {
        let path = read("CUTTER/10,0\nMULTAX\nFEDRAT/MMPM,1000\nGOTO/0,0,0,0,0,1\n");
        let axis = Unit::new_normalize(Vector3::new(0.0, 1.0, 1.0));
        let applied = apply(&path, &[Setup { items: 0..path.items.len(), axis: Some(axis) }]);
        assert_eq!(applied.not_ball, vec![(10.0, 0.0)]);
    }
}
