//! Machines built in code for the unit tests (the YAML definitions are tested elsewhere).

use nalgebra::{Isometry3, Point3, Translation3, Unit, UnitQuaternion, Vector3};
use postpro_machine::model::*;

use crate::{Joints, Kinematics, Pose, Solutions};

fn axis(letter: &str, kind: AxisKind, dir: [f64; 3], center: [f64; 3], travel: Travel) -> Axis {
    Axis {
        letter: letter.into(),
        kind,
        direction: Unit::new_normalize(Vector3::from(dir)),
        center: Point3::from(center),
        travel,
        home: 0.0,
        vmax: 500.0,
        amax: 2500.0,
        jmax: 5000.0,
        decimals: 4,
        clamp: None,
    }
}

fn linear(letter: &str, dir: [f64; 3]) -> Axis {
    axis(letter, AxisKind::Linear, dir, [0.0; 3], Travel::Limited { min: -2000.0, max: 2000.0 })
}

/// A machine with X Y Z and the given rotaries (letter, direction, centre, part side?).
pub(crate) fn machine(rotaries: &[(&str, [f64; 3], [f64; 3], bool)], solver: SolverKind) -> Machine {
    let mut axes = vec![linear("X", [1.0, 0.0, 0.0]), linear("Y", [0.0, 1.0, 0.0]), linear("Z", [0.0, 0.0, 1.0])];
    let (mut part, mut tool) = (Vec::new(), Vec::new());
    for &(l, d, c, on_part) in rotaries {
        let travel = Travel::Limited { min: -20.0, max: 20.0 };
        axes.push(axis(l, AxisKind::Rotary, d, c, travel));
        if on_part { part.push(axes.len() - 1) } else { tool.push(axes.len() - 1) }
    }
    Machine {
        name: "test".into(),
        aliases: vec![],
        description: String::new(),
        dialect: "siemens-840d".into(),
        axes,
        chain: Chain {
            linear: vec![0, 1, 2],
            part,
            tool,
            part_origin: Isometry3::from_parts(
                Translation3::new(12.0, -7.0, 35.0),
                UnitQuaternion::from_euler_angles(0.1, -0.05, 0.3),
            ),
            spindle_nose: Point3::new(3.0, 4.0, 250.0),
            tool_direction: Vector3::z_axis(),
            tool_length: 80.0,
        },
        cnc: CncParams {
            cycle_time: 0.003,
            look_ahead: 10,
            contour_tolerance: 0.01,
            curvature_accel_share: 0.5,
            tangential_accel: None,
            tangential_jerk: None,
            feed_min: 1.0,
            feed_max: 30000.0,
            spindle_max: None,
        },
        policy: PolicyDefaults {
            branch: BranchPreference::Closest,
            choice: PathChoice::WholePath,
            singular_cone: 0.5_f64.to_radians(),
            pole_passage: 0.5_f64.to_radians(),
            max_rotary_step: 30_f64.to_radians(),
            on_discontinuity: OnDiscontinuity::Error,
            linearization_tolerance: 0.01,
            unwind: Some(2.0),
            missing_feed: postpro_machine::model::MissingFeed::Error,
        },
        solver,
        clearance: Clearance::SafeZ(2000.0),
        units: ProgramUnits::Mm,
    }
}

/// Mikron-like CAXYZ with offsets.
pub(crate) fn mikron(solver: SolverKind) -> Machine {
    machine(
        &[("A", [-1.0, 0.0, 0.0], [0.0, 10.0, -40.0], true), ("C", [0.0, 0.0, -1.0], [5.0, -3.0, 60.0], true)],
        solver,
    )
}

/// MAHO-like TTTRR with offsets.
pub(crate) fn maho(solver: SolverKind) -> Machine {
    machine(
        &[("B", [0.0, -1.0, 0.0], [0.0, 0.0, 0.0], true), ("C", [0.0, 0.0, 1.0], [0.0, 0.0, -250.314], true)],
        solver,
    )
}

/// Head-head with a 45° nutating B on a C.
pub(crate) fn nutating() -> Machine {
    let s = std::f64::consts::FRAC_1_SQRT_2;
    machine(
        &[("C", [0.0, 0.0, 1.0], [0.0, 0.0, 400.0], false), ("B", [0.0, s, s], [0.0, 0.0, 320.0], false)],
        SolverKind::Generic,
    )
}

/// Head-table: C on the table, B on the head.
pub(crate) fn head_table() -> Machine {
    machine(
        &[("C", [0.0, 0.0, 1.0], [20.0, 30.0, 0.0], true), ("B", [0.0, 1.0, 0.0], [0.0, 0.0, 300.0], false)],
        SolverKind::Generic,
    )
}

/// A machine's kinematics as another solver would give it: the trait's own default methods
/// (`forward_rate` by central difference, as for a plugin), and the solutions held at a
/// singularity `held_error` mm off in the first axis (0: none), as a solver with an error.
pub(crate) struct Wrapped<'a> {
    pub(crate) inner: &'a dyn Kinematics,
    pub(crate) held_error: f64,
}

impl Kinematics for Wrapped<'_> {
    fn machine(&self) -> &Machine {
        self.inner.machine()
    }
    fn forward(&self, joints: &Joints) -> Pose {
        self.inner.forward(joints)
    }
    fn inverse(&self, pose: &Pose, out: &mut Solutions) {
        self.inner.inverse(pose, out);
    }
    fn inverse_holding(&self, pose: &Pose, free_axis: usize, value: f64) -> Option<Joints> {
        let mut j = self.inner.inverse_holding(pose, free_axis, value)?;
        j[0] += self.held_error;
        Some(j)
    }
    fn place(&self, pose: &Pose, rotaries: &Joints) -> Joints {
        self.inner.place(pose, rotaries)
    }
}
