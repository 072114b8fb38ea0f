//! CL arcs as circular interpolation: where an arc of the CL file is a circle in a plane of the
//! program's frame, it is written as one (`G2`/`G3`, `C … DR±`), its sense taken from the CL
//! file's geometry (the reader's counter-clockwise normal, in each CAM system's convention) and
//! carried into the axis space through the kinematics, never guessed.
//!
//! The program's frame is the tool tip's part frame in TCP mode, and the linear axes' values in
//! the joint modes. In a joint mode the rotary axes must stand still along the arc (3-axis,
//! 3+2): the linear axes are then an affine image of the tip, read from the kinematics, and the
//! arc is a circle of the axis space if the image of its normal is one of the axes. Its sense
//! there is the part frame's sense, reversed where the image is a mirror.

use nalgebra::{Matrix3, Point3, Vector3};
use postpro_kin::{Joints, Kinematics, Pose};
use postpro_machine::model::AxisKind;

use crate::block::Plane;
use crate::frame::WorkFrame;

/// An arc's geometry in the program's frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Geometry {
    pub(crate) plane: Plane,
    pub(crate) center: [f64; 3],
    pub(crate) clockwise: bool,
    pub(crate) turns: u32,
    pub(crate) sweep: f64,
    pub(crate) radius: f64,
}

/// How far from a frame axis the image of an arc's normal may be (its sine).
const AXIS_TOLERANCE: f64 = 1e-6;

/// The arc `arc` in the program's frame, when it is a circle in one of its planes: in the part
/// frame itself (`tcp`), or in the axis space with the rotary axes at `rotaries` (the joint
/// values the arc is solved at, in the kinematics' frame). `None` when it is not.
pub(crate) fn geometry(
    arc: &postpro_cl::Arc,
    kin: &dyn Kinematics,
    frame: &WorkFrame,
    rotaries: &Joints,
    tcp: bool,
) -> Option<Geometry> {
    let machine = kin.machine();
    let linear = &machine.chain.linear;
    if !tcp && linear.len() != 3 {
        return None;
    }
    // The map from the part frame to the program's frame: identity in TCP mode; else the linear
    // axes' values for the tip at a point, with the rotaries held.
    let image = |p: Point3<f64>| -> Vector3<f64> {
        if tcp {
            return p.coords;
        }
        let axis = kin.forward(rotaries).axis;
        let joints = frame.apply(&kin.place(&Pose { tip: p, axis }, rotaries));
        Vector3::new(joints[linear[0]], joints[linear[1]], joints[linear[2]])
    };
    let origin = image(arc.center);
    let columns = [Vector3::x(), Vector3::y(), Vector3::z()].map(|e| image(arc.center + e) - origin);
    let map = Matrix3::from_columns(&columns);
    let det = map.determinant();
    if !det.is_finite() || det.abs() < 1e-9 {
        return None;
    }
    let normal = map * arc.normal.into_inner();
    let n = normal.norm();
    let (axis, along) = (0..3).map(|i| (i, normal[i] / n)).max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))?;
    if (1.0 - along.abs()) > AXIS_TOLERANCE * AXIS_TOLERANCE / 2.0 + f64::EPSILON {
        // 1 − cos θ ≈ θ²/2: the normal is more than AXIS_TOLERANCE away from the frame axis.
        return None;
    }
    let plane = match axis {
        2 => Plane::Xy,
        1 => Plane::Zx,
        _ => Plane::Yz,
    };
    // Counter-clockwise about the normal in the part frame; a mirror image turns the other way;
    // about the negative frame axis is clockwise about the positive one.
    let counter_clockwise = (along > 0.0) == (det > 0.0);
    let full = std::f64::consts::TAU;
    let turns = ((arc.sweep - 1e-9) / full).floor().max(0.0) as u32;
    Some(Geometry {
        plane,
        center: [origin.x, origin.y, origin.z],
        clockwise: !counter_clockwise,
        turns,
        sweep: arc.sweep,
        radius: arc.radius,
    })
}

/// True when the rotary axes of `a` and `b` stand at one angle: each within half a unit of the
/// last decimal the program writes it with. CAM systems write tool axes to 7 decimals, and two of
/// one 3+2 set-up may differ in the last (1e-7 rad): that is no re-orientation, no simultaneous
/// motion, no end of a set-up. Written, the two stay within one unit (0.0001°): a turn that moves
/// the tool tip by a micrometre, never a reason to retract.
pub(crate) fn same_rotaries(kin: &dyn Kinematics, a: &Joints, b: &Joints) -> bool {
    kin.machine()
        .axes
        .iter()
        .enumerate()
        .filter(|(_, x)| x.kind == AxisKind::Rotary)
        .all(|(i, axis)| (a[i] - b[i]).abs() <= half_unit(axis))
}

/// Half a unit of the last decimal rotary axis `axis` is written with (rad; at least 1e-9): the
/// angles it cannot tell apart.
pub(crate) fn half_unit(axis: &postpro_machine::model::Axis) -> f64 {
    (0.5 * 10f64.powi(-i32::from(axis.decimals))).to_radians().max(1e-9)
}

#[cfg(test)]
mod tests {
    use nalgebra::Unit;
    use postpro_cl::Motion;
    use postpro_machine::Registry;

    use super::*;
    use crate::block::Mode;
    use crate::frame::work_frame;

    fn arc(normal: Vector3<f64>, center: Point3<f64>) -> postpro_cl::Arc {
        let n = Unit::new_normalize(normal);
        let radial = n.cross(&Vector3::x()).try_normalize(1e-9).unwrap_or_else(|| n.cross(&Vector3::y()).normalize());
        let start = center + radial * 5.0;
        postpro_cl::Arc {
            start,
            center,
            normal: n,
            radius: 5.0,
            end: start,
            sweep: std::f64::consts::FRAC_PI_2,
            axis: Vector3::z_axis(),
            motion: Motion::Rapid,
        }
    }

    fn kin(name: &str) -> Box<dyn Kinematics> {
        postpro_kin::solver_for(&Registry::builtin().expect("built-ins").find(name).expect("machine").machine)
    }

    #[test]
    fn on_a_three_axis_machine_the_sense_is_the_part_frames() {
        let k = kin("example-3axis-vmc");
        let frame = work_frame(k.as_ref(), Mode::G1);
        let zero = Joints::zeros(3);
        let up = geometry(&arc(Vector3::z(), Point3::new(1.0, 2.0, 3.0)), k.as_ref(), &frame, &zero, false);
        let up = up.expect("an XY arc");
        assert_eq!((up.plane, up.clockwise), (Plane::Xy, false));
        assert!((up.center[0] - 1.0).abs() < 1e-9 && (up.center[1] - 2.0).abs() < 1e-9);
        let down = geometry(&arc(-Vector3::z(), Point3::origin()), k.as_ref(), &frame, &zero, false);
        assert_eq!(down.map(|g| (g.plane, g.clockwise)), Some((Plane::Xy, true)));
        let side = geometry(&arc(Vector3::y(), Point3::origin()), k.as_ref(), &frame, &zero, false);
        assert_eq!(side.map(|g| (g.plane, g.clockwise)), Some((Plane::Zx, false)));
        let front = geometry(&arc(-Vector3::x(), Point3::origin()), k.as_ref(), &frame, &zero, false);
        assert_eq!(front.map(|g| (g.plane, g.clockwise)), Some((Plane::Yz, true)));
        let tilted = geometry(&arc(Vector3::new(0.0, 0.1, 1.0), Point3::origin()), k.as_ref(), &frame, &zero, false);
        assert_eq!(tilted, None, "an arc in a tilted plane is not a circle of the frame");
    }

    #[test]
    fn a_tilted_table_turns_the_arc_into_another_plane() {
        // The MAHO tilted by B = 90°: the part's z axis lies along the machine's x axis, so an
        // arc about the part's z is an arc of the Y–Z plane of the axis space.
        let k = kin("maho600e");
        let frame = work_frame(k.as_ref(), Mode::G1);
        let mut rotaries = Joints::zeros(5);
        rotaries[3] = std::f64::consts::FRAC_PI_2;
        let g = geometry(&arc(Vector3::z(), Point3::new(10.0, 0.0, 0.0)), k.as_ref(), &frame, &rotaries, false)
            .expect("a plane of the frame");
        assert_eq!(g.plane, Plane::Yz);
        // The sense follows the image of the normal: checked against the motion itself.
        let a = arc(Vector3::z(), Point3::new(10.0, 0.0, 0.0));
        let axis = k.forward(&rotaries).axis;
        let at = |p: Point3<f64>| frame.apply(&k.place(&Pose { tip: p, axis }, &rotaries));
        let (s, m) = (at(a.start), at(a.point_at(0.25)));
        let c = Vector3::new(g.center[0], g.center[1], g.center[2]);
        let (u, v) = (Vector3::new(s[0], s[1], s[2]) - c, Vector3::new(m[0], m[1], m[2]) - c);
        let turn = u.cross(&v).x; // about +X, the normal of Y–Z
        assert_eq!(g.clockwise, turn < 0.0, "sense {turn}");
    }
}
