//! The work-offset frame: where the program's zero is, and the axis values written in it.
//!
//! The kinematics computes axis values in the machine definition's frame; a program is written in
//! the frame of a work offset (G54…), whose position in machine coordinates the shop sets on the
//! machine. Where that zero is depends on the machine and the mode:
//!
//! - **the part zero** for 3-axis machines, for machines whose rotary axes all carry the tool
//!   (the head), and in TCP mode (the controller carries the part zero through the rotations):
//!   the linear axis values are then the CL coordinates (shifted by the tool's geometry on a head);
//! - **the rotation reference** for machines whose rotary axes carry the part, in joint modes: the
//!   part turns about the table's axes, so the offset must sit on them (the intersection of the two
//!   axes of a table-table machine; the point of a single table axis level with the part zero).
//!
//! Every offset is taken with a zero-length tool (the spindle nose at the zero, as a shop sets a
//! work offset for tool length compensation).

use nalgebra::{Point3, Vector3};
use postpro_kin::{Joints, Kinematics, Pose, ToolLength};
use postpro_machine::model::{AxisKind, Machine};

use crate::block::Mode;

/// Where the work offset's zero is.
#[derive(Clone, Debug, PartialEq)]
pub enum Origin {
    /// The part zero of the CL file.
    PartZero,
    /// On the axes of the rotary table(s) that carry the part.
    RotationReference {
        /// `B/C intersection`, `A axis, level with the part zero`…
        description: String,
    },
}

/// The frame the program's axis values are written in.
#[derive(Clone, Debug, PartialEq)]
pub struct WorkFrame {
    /// Subtracted from the kinematics' linear axis values (rotary entries are 0).
    pub offset: Joints,
    /// Where its zero is.
    pub origin: Origin,
}

impl WorkFrame {
    /// A frame whose values are the kinematics' own (no offset: for tests and studies).
    pub fn machine(axes: usize) -> WorkFrame {
        WorkFrame { offset: Joints::zeros(axes), origin: Origin::PartZero }
    }

    /// The axis values written for the kinematics' `joints`.
    pub fn apply(&self, joints: &Joints) -> Joints {
        let mut out = *joints;
        for (v, o) in out.as_mut_slice().iter_mut().zip(self.offset.as_slice()) {
            *v -= o;
        }
        out
    }

    /// The kinematics' values for axis values written in this frame.
    pub fn unapply(&self, written: &Joints) -> Joints {
        let mut out = *written;
        for (v, o) in out.as_mut_slice().iter_mut().zip(self.offset.as_slice()) {
            *v += o;
        }
        out
    }

    /// Where the shop sets the offset, for the program's header.
    pub fn describe(&self) -> String {
        match &self.origin {
            Origin::PartZero => "the part zero".to_string(),
            Origin::RotationReference { description } => format!("the {description}"),
        }
    }
}

/// The work frame of `kin`'s machine in `mode`.
pub fn work_frame(kin: &dyn Kinematics, mode: Mode) -> WorkFrame {
    frame(kin, mode == Mode::Tcp)
}

/// The frame whose zero is the part zero, with the rotary axes at zero, whatever the machine:
/// for controllers that carry the part zero through the rotations (TCP, working planes).
pub fn part_zero_frame(kin: &dyn Kinematics) -> WorkFrame {
    frame(kin, true)
}

fn frame(kin: &dyn Kinematics, part_zero: bool) -> WorkFrame {
    let machine = kin.machine();
    let nose = ToolLength::new(kin, 0.0);
    let rotaries = Joints::zeros(machine.axes.len());
    let (tip, origin) = match (part_zero, rotation_reference(machine)) {
        (true, _) | (_, None) => (Point3::origin(), Origin::PartZero),
        (_, Some((point, description))) => {
            (machine.chain.part_origin.inverse_transform_point(&point), Origin::RotationReference { description })
        }
    };
    let axis = nose.forward(&rotaries).axis;
    let mut offset = nose.place(&Pose { tip, axis }, &rotaries);
    for (i, a) in machine.axes.iter().enumerate() {
        if a.kind == AxisKind::Rotary {
            offset[i] = 0.0;
        }
    }
    WorkFrame { offset, origin }
}

/// The point (in the machine's base frame, every axis at zero) the part turns about, and its
/// description, for a machine whose rotary axes carry the part; `None` when none does.
pub fn rotation_reference(machine: &Machine) -> Option<(Point3<f64>, String)> {
    let line = |i: usize| (machine.axes[i].center, machine.axes[i].direction.into_inner(), &machine.axes[i].letter);
    match machine.chain.part.as_slice() {
        [] => None,
        [only] => {
            let (c, d, letter) = line(*only);
            let zero = Point3::from(machine.chain.part_origin.translation.vector);
            let on_axis = c + d * (zero - c).dot(&d);
            Some((on_axis, format!("{letter} axis, level with the part zero")))
        }
        [first, second, ..] => {
            let ((c1, d1, l1), (c2, d2, l2)) = (line(*first), line(*second));
            let (p1, p2) = closest_points(c1, d1, c2, d2);
            if (p1 - p2).norm() < 1e-6 {
                Some((p1, format!("{l1}/{l2} intersection")))
            } else {
                Some((p1, format!("{l1} axis, at its closest point to the {l2} axis")))
            }
        }
    }
}

/// The part zero `offset` (mm) from the machine's rotation reference: the set-up's
/// `part_origin`. On a machine whose rotary axes carry no part it has no meaning: `false`.
pub fn place_part(machine: &mut Machine, offset: Vector3<f64>) -> bool {
    let Some((reference, _)) = rotation_reference(machine) else { return false };
    machine.chain.part_origin.translation.vector = reference.coords + offset;
    true
}

/// The part zero of `machine` from its rotation reference (the set-up's `part_origin` that the
/// machine definition gives), when its rotary axes carry the part.
pub fn part_offset(machine: &Machine) -> Option<Vector3<f64>> {
    let (reference, _) = rotation_reference(machine)?;
    Some(machine.chain.part_origin.translation.vector - reference.coords)
}

/// The closest points of two lines `c1 + s d1` and `c2 + t d2` (unit directions).
fn closest_points(c1: Point3<f64>, d1: Vector3<f64>, c2: Point3<f64>, d2: Vector3<f64>) -> (Point3<f64>, Point3<f64>) {
    let w = c1 - c2;
    let b = d1.dot(&d2);
    let (d, e) = (d1.dot(&w), d2.dot(&w));
    let denominator = 1.0 - b * b;
    if denominator.abs() < 1e-12 {
        // Parallel: any point of the first, the foot of the perpendicular on the second.
        return (c1, c2 + d2 * e);
    }
    let s = (b * e - d) / denominator;
    let t = (e - b * d) / denominator;
    (c1 + d1 * s, c2 + d2 * t)
}

#[cfg(test)]
mod tests {
    use postpro_machine::Registry;

    use super::*;

    fn machine(name: &str) -> Machine {
        Registry::builtin().expect("built-ins").find(name).expect("machine").machine.clone()
    }

    #[test]
    fn a_table_table_machine_is_offset_on_its_axes_intersection() {
        let maho = machine("maho600e-generic");
        let (point, what) = rotation_reference(&maho).expect("the part turns");
        // B through the origin along y, C along z through (0, 0, -250.314): they meet at the origin.
        assert!((point - Point3::origin()).norm() < 1e-9, "{point}");
        assert_eq!(what, "B/C intersection");
        let kin = postpro_kin::solver_for(&maho);
        let frame = work_frame(kin.as_ref(), Mode::G1);
        // The part zero is 85.314 mm below the intersection: with the rotaries at zero the tip on
        // the part zero is written Z-85.314, X and Y 0.
        let nose = ToolLength::new(kin.as_ref(), 0.0);
        let at_zero =
            nose.place(&Pose { tip: Point3::origin(), axis: Vector3::z_axis() }, &Joints::zeros(maho.axes.len()));
        let written = frame.apply(&at_zero);
        assert!((written[0]).abs() < 1e-9 && written[1].abs() < 1e-9, "{written:?}");
        assert!((written[2] + 85.314).abs() < 1e-9, "{written:?}");
        // In TCP mode the offset is the part zero itself.
        let tcp = work_frame(kin.as_ref(), Mode::Tcp);
        assert!(tcp.apply(&at_zero).as_slice()[..3].iter().all(|v| v.abs() < 1e-9));
    }

    #[test]
    fn a_single_table_axis_is_offset_level_with_the_part_zero() {
        let mut m = machine("example-4axis-a-table");
        let (point, what) = rotation_reference(&m).expect("the part turns");
        assert!(what.starts_with("A axis"));
        // The part origin moved along the A axis moves the reference with it.
        let before = part_offset(&m).expect("offset");
        assert!(place_part(&mut m, before + Vector3::new(0.0, 0.0, 25.0)));
        let (after, _) = rotation_reference(&m).expect("the part turns");
        assert!((after - point).norm() < 1e-9, "the reference stays on the axis");
        assert!((part_offset(&m).expect("offset") - before - Vector3::new(0.0, 0.0, 25.0)).norm() < 1e-9);
    }

    #[test]
    fn a_three_axis_machine_writes_the_cl_coordinates() {
        let m = machine("example-3axis-vmc");
        assert!(rotation_reference(&m).is_none());
        let kin = postpro_kin::solver_for(&m);
        let frame = work_frame(kin.as_ref(), Mode::G1);
        // Solved with a zero-length tool: the tool length is the controller's business (G43).
        let nose = ToolLength::new(kin.as_ref(), 0.0);
        let pose = Pose { tip: Point3::new(-272.5, 172.5, 100.0), axis: Vector3::z_axis() };
        let written = frame.apply(&nose.place(&pose, &Joints::zeros(3)));
        assert!((written[0] + 272.5).abs() < 1e-9 && (written[1] - 172.5).abs() < 1e-9, "{written:?}");
        assert!((written[2] - 100.0).abs() < 1e-9, "{written:?}");
    }
}
