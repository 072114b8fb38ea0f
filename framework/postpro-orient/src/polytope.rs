//! Kinematic polytopes of the linear axes (paper 004 §3–4).
//!
//! Each linear axis `i` has its own limit `lᵢ` (velocity, acceleration or jerk), so the joint
//! set of a level is the box `|q̇ᵢ| ≤ lᵢ`. With the rotary axes fixed (3+2), a linear joint
//! motion `q̇` moves the tool tip in the part frame by `J q̇`, where `J` (the [`JointMap`]) is
//! read from the forward kinematics: its columns are the part-frame tip displacements for a unit
//! move of each linear axis at those rotary angles. The polytope in the part frame is `J·box`.
//!
//! Along a part-frame direction `d` the largest norm is where the ray leaves the polytope:
//! `min_i lᵢ / |(M d)ᵢ|` with `M = J⁻¹` (paper 004 eq. 7, there in joint space). It is
//! largest at the box's vertices `(±l₁, ±l₂, ±l₃)`, the *preferred directions* (Table 2), whose
//! norm `|J v|` does not depend on the rotary angles when the linear axes are orthonormal
//! (then `J` is a rotation: eq. 16–17).
//!
//! [`bounds`] gives, over every set-up, the range of the best tangential norm a feed direction
//! can get (eq. 21): the vertex norm above; below, the norm the least favourable direction gets
//! (a feed along the innermost part-side rotary axis, the "poles" of the paper's Fig. 10 and 12:
//! turning that axis does not move it, so only the outer axis can turn it towards a vertex).

use nalgebra::{Matrix3, Unit, Vector3};
use postpro_kin::{Joints, Kinematics};
use postpro_machine::model::{Axis, AxisKind, Machine};

use crate::OrientError;

/// A kinematic level.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Level {
    /// Velocity (mm/s).
    Velocity,
    /// Acceleration (mm/s²).
    Acceleration,
    /// Jerk (mm/s³).
    Jerk,
}

impl Level {
    /// The three levels, in order.
    pub const ALL: [Level; 3] = [Level::Velocity, Level::Acceleration, Level::Jerk];

    /// `velocity`, `acceleration`, `jerk`.
    pub fn name(self) -> &'static str {
        match self {
            Level::Velocity => "velocity",
            Level::Acceleration => "acceleration",
            Level::Jerk => "jerk",
        }
    }

    /// The unit of its norms: `mm/s`, `mm/s²`, `mm/s³`.
    pub fn unit(self) -> &'static str {
        match self {
            Level::Velocity => "mm/s",
            Level::Acceleration => "mm/s²",
            Level::Jerk => "mm/s³",
        }
    }

    fn index(self) -> usize {
        match self {
            Level::Velocity => 0,
            Level::Acceleration => 1,
            Level::Jerk => 2,
        }
    }

    fn limit(self, axis: &Axis) -> f64 {
        match self {
            Level::Velocity => axis.vmax,
            Level::Acceleration => axis.amax,
            Level::Jerk => axis.jmax,
        }
    }
}

/// The joint boxes of a machine's three linear axes: their velocity, acceleration and jerk
/// limits, in the order of `Machine::chain.linear`.
#[derive(Clone, Debug, PartialEq)]
pub struct JointBoxes {
    axes: [usize; 3],
    limits: [Vector3<f64>; 3],
}

impl JointBoxes {
    /// The boxes of a machine with three linear axes and positive limits.
    pub fn new(machine: &Machine) -> Result<JointBoxes, OrientError> {
        let linear = &machine.chain.linear;
        let axes: [usize; 3] = match linear.as_slice() {
            &[a, b, c] if [a, b, c].iter().all(|&i| i < machine.axes.len()) => [a, b, c],
            _ => return Err(OrientError::LinearAxes { machine: machine.name.clone(), found: linear.len() }),
        };
        let mut limits = [Vector3::zeros(); 3];
        for level in Level::ALL {
            for (k, &i) in axes.iter().enumerate() {
                let axis = &machine.axes[i];
                let value = level.limit(axis);
                if axis.kind != AxisKind::Linear || !(value.is_finite() && value > 0.0) {
                    return Err(OrientError::Limit {
                        machine: machine.name.clone(),
                        axis: axis.letter.clone(),
                        level: level.name(),
                        value,
                    });
                }
                limits[level.index()][k] = value;
            }
        }
        Ok(JointBoxes { axes, limits })
    }

    /// The indices of the linear axes in `Machine::axes`, in the order of the limits.
    pub fn axes(&self) -> [usize; 3] {
        self.axes
    }

    /// The limits of one level (mm/s, mm/s² or mm/s³), one per linear axis.
    pub fn limits(&self, level: Level) -> Vector3<f64> {
        self.limits[level.index()]
    }

    /// The polytope of one level in the part frame, for the set-up of `map`.
    pub fn polytope(&self, level: Level, map: &JointMap) -> Polytope {
        Polytope { level, limits: self.limits(level), to_part: map.to_part, to_joint: map.to_joint }
    }
}

/// The linear map between the linear axes' motion and the tool tip's motion in the part frame,
/// at fixed rotary angles, read from the forward kinematics.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JointMap {
    joints: Joints,
    to_part: Matrix3<f64>,
    to_joint: Matrix3<f64>,
}

impl JointMap {
    /// The map at the rotary angles of `joints` (its linear values are ignored): column `k` is
    /// the part-frame tip displacement for a unit move of linear axis `boxes.axes()[k]`.
    pub fn at(kin: &dyn Kinematics, boxes: &JointBoxes, joints: &Joints) -> Result<JointMap, OrientError> {
        let machine = kin.machine();
        let n = machine.axes.len();
        if joints.len() != n || joints.as_slice().iter().any(|v| !v.is_finite()) {
            return Err(OrientError::Joints { machine: machine.name.clone(), expected: n, found: joints.len() });
        }
        let mut base = *joints;
        for &i in &boxes.axes {
            base[i] = 0.0;
        }
        let origin = kin.forward(&base).tip;
        let mut to_part = Matrix3::zeros();
        for (k, &i) in boxes.axes.iter().enumerate() {
            let mut moved = base;
            moved[i] = 1.0;
            to_part.set_column(k, &(kin.forward(&moved).tip - origin));
        }
        let singular = || OrientError::Singular { machine: machine.name.clone() };
        // Well conditioned: the determinant against the product of the column lengths.
        let scale: f64 = (0..3).map(|k| to_part.column(k).norm()).product();
        let det = to_part.determinant();
        if !(det.is_finite() && scale.is_finite() && det.abs() > 1e-9 * scale) {
            return Err(singular());
        }
        let to_joint = to_part.try_inverse().ok_or_else(singular)?;
        base.as_mut_slice().copy_from_slice(joints.as_slice());
        Ok(JointMap { joints: base, to_part, to_joint })
    }

    /// The axis values of the set-up.
    pub fn joints(&self) -> &Joints {
        &self.joints
    }

    /// `J`: linear joint motion (in the order of [`JointBoxes::axes`]) → part-frame tip motion.
    pub fn to_part(&self) -> &Matrix3<f64> {
        &self.to_part
    }

    /// `M = J⁻¹`: part-frame tip motion → linear joint motion.
    pub fn to_joint(&self) -> &Matrix3<f64> {
        &self.to_joint
    }
}

/// One vertex of a joint box and its image in the part frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Vertex {
    /// The sign of each linear axis's limit (`+1` or `-1`), in the order of
    /// [`JointBoxes::axes`].
    pub signs: [i8; 3],
    /// The vertex in joint space `(±l₁, ±l₂, ±l₃)` (mm/s, mm/s² or mm/s³).
    pub joint: Vector3<f64>,
    /// Its direction in the part frame: a preferred direction.
    pub direction: Unit<Vector3<f64>>,
    /// Its norm in the part frame, `|J v|`: the largest tangential norm along `direction`.
    pub norm: f64,
}

/// The signs of vertex `k` (bit `i` set: axis `i` at its negative limit).
pub(crate) fn vertex_signs(k: usize) -> [i8; 3] {
    std::array::from_fn(|i| if k >> i & 1 == 0 { 1 } else { -1 })
}

/// The polytope of one level in the part frame at one set-up: the image of the joint box.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Polytope {
    level: Level,
    limits: Vector3<f64>,
    to_part: Matrix3<f64>,
    to_joint: Matrix3<f64>,
}

impl Polytope {
    /// Its level.
    pub fn level(&self) -> Level {
        self.level
    }

    /// The largest norm along a part-frame direction `d` (its length does not matter; the sign
    /// neither, the polytope is symmetric): `min_i lᵢ / |(M d̂)ᵢ|`. Zero for a zero or
    /// non-finite `d`.
    pub fn norm_along(&self, d: &Vector3<f64>) -> f64 {
        let len = d.norm();
        if !(len.is_finite() && len > 0.0) {
            return 0.0;
        }
        let u = self.to_joint * (d / len);
        let mut best = f64::INFINITY;
        for i in 0..3 {
            let c = u[i].abs();
            if c > 0.0 {
                best = best.min(self.limits[i] / c);
            }
        }
        if best.is_finite() { best } else { 0.0 }
    }

    /// The eight vertices: vertex `k` has axis `i` at its negative limit when bit `i` of `k` is
    /// set, so `k` and `7 − k` are opposite.
    pub fn vertices(&self) -> [Vertex; 8] {
        std::array::from_fn(|k| {
            let signs = vertex_signs(k);
            let joint = self.limits.component_mul(&Vector3::from(signs.map(f64::from)));
            let image = self.to_part * joint;
            Vertex { signs, joint, direction: Unit::new_normalize(image), norm: image.norm() }
        })
    }

    /// The longest vertex (the first of the longest on ties, within 1e-12 relative): the
    /// preferred direction of this level, and the largest norm of the polytope.
    pub fn preferred(&self) -> Vertex {
        let vertices = self.vertices();
        let mut best = vertices[0];
        for v in &vertices[1..] {
            if v.norm > best.norm * (1.0 + 1e-12) {
                best = *v;
            }
        }
        best
    }

    /// The radius of the largest ball inside the polytope: the smallest norm over all
    /// directions, `min_i lᵢ / |Mᵢ|` (rows of `M`).
    pub fn inradius(&self) -> f64 {
        (0..3).map(|i| self.limits[i] / self.to_joint.row(i).norm()).fold(f64::INFINITY, f64::min)
    }
}

/// The range of the best tangential norm of one level over all set-ups (paper 004 eq. 21).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bounds {
    /// The level.
    pub level: Level,
    /// The least any feed direction gets at its best set-up: the norm along [`Bounds::pole`]
    /// at [`Bounds::lower_at`] (eq. 21's `√(J_Y² + J_Z²)` on an AC table).
    pub lower: f64,
    /// The most: the longest vertex (eq. 21's `√(J_X² + J_Y² + J_Z²)`).
    pub upper: f64,
    /// The least favourable feed direction in the part frame: along the innermost part-side
    /// rotary axis. `None` when no rotary axis carries the part (the polytope does not turn;
    /// `lower` is then its inradius).
    pub pole: Option<Unit<Vector3<f64>>>,
    /// The set-up that gives `lower` along the pole (the other axes at zero).
    pub lower_at: Joints,
}

/// The bounds of eq. 21 for one level, over every set-up of the part-side rotary axes,
/// **without** their travel limits (as in the paper).
///
/// With two or more part-side rotary axes, the pole (innermost axis) is turned by the next
/// axis outwards only; its best norm is found over a full turn of that axis (sampled every
/// 0.25°, then refined by golden section).
pub fn bounds(kin: &dyn Kinematics, boxes: &JointBoxes, level: Level) -> Result<Bounds, OrientError> {
    let machine = kin.machine();
    let zero = Joints::zeros(machine.axes.len());
    let at_zero = boxes.polytope(level, &JointMap::at(kin, boxes, &zero)?);
    let upper = at_zero.preferred().norm;
    let part = &machine.chain.part;
    let Some(&inner) = part.last() else {
        return Ok(Bounds { level, lower: at_zero.inradius(), upper, pole: None, lower_at: zero });
    };
    let pole = machine.chain.part_origin.rotation.inverse() * machine.axes[inner].direction;
    let Some(&outer) = part.len().checked_sub(2).and_then(|k| part.get(k)) else {
        return Ok(Bounds { level, lower: at_zero.norm_along(&pole), upper, pole: Some(pole), lower_at: zero });
    };
    let norm_at = |angle: f64| -> Result<f64, OrientError> {
        let mut j = zero;
        j[outer] = angle;
        Ok(boxes.polytope(level, &JointMap::at(kin, boxes, &j)?).norm_along(&pole))
    };
    let (angle, lower) = maximize_on_turn(norm_at)?;
    let mut lower_at = zero;
    lower_at[outer] = angle;
    Ok(Bounds { level, lower, upper, pole: Some(pole), lower_at })
}

/// The largest value of `f` over one turn: sampled, then refined by golden section around the
/// best sample. Returns the angle in (−π, π] and the value. Of maxima equal but for rounding
/// (a symmetric polytope has several), the one nearest 0.
pub(crate) fn maximize_on_turn(mut f: impl FnMut(f64) -> Result<f64, OrientError>) -> Result<(f64, f64), OrientError> {
    const SAMPLES: usize = 1440;
    let step = std::f64::consts::TAU / SAMPLES as f64;
    let mut best: (f64, f64) = (0.0, f64::NEG_INFINITY);
    for k in 0..SAMPLES {
        let a = -std::f64::consts::PI + step * (k as f64 + 1.0);
        let v = f(a)?;
        let tie = (v - best.1).abs() <= 1e-9 * v.abs().max(1.0);
        if (v > best.1 && !tie) || (tie && a.abs() < best.0.abs()) {
            best = (a, v);
        }
    }
    let (mut lo, mut hi) = (best.0 - step, best.0 + step);
    let g = (5f64.sqrt() - 1.0) / 2.0;
    let (mut x1, mut x2) = (hi - g * (hi - lo), lo + g * (hi - lo));
    let (mut f1, mut f2) = (f(x1)?, f(x2)?);
    for _ in 0..80 {
        if f1 < f2 {
            lo = x1;
            (x1, f1) = (x2, f2);
            x2 = lo + g * (hi - lo);
            f2 = f(x2)?;
        } else {
            hi = x2;
            (x2, f2) = (x1, f1);
            x1 = hi - g * (hi - lo);
            f1 = f(x1)?;
        }
    }
    for (x, v) in [(x1, f1), (x2, f2)] {
        if v > best.1 {
            best = (x, v);
        }
    }
    Ok((crate::wrap(best.0), best.1))
}

#[cfg(test)]
mod tests {
    use nalgebra::{Matrix3, Rotation3, Vector3};
    use postpro_kin::{Chain, Joints, Kinematics, solver_for};
    use postpro_machine::Registry;

    use super::*;

    fn machine(name: &str) -> Machine {
        Registry::builtin().expect("built-ins").find(name).expect("machine").machine.clone()
    }

    /// `../shared/DOMAIN.md` §2: paper 004's eq. 16, printed garbled, is `Rz(C)·Rx(A)`.
    fn rz_rx(a: f64, c: f64) -> Matrix3<f64> {
        (Rotation3::from_axis_angle(&Vector3::z_axis(), c) * Rotation3::from_axis_angle(&Vector3::x_axis(), a))
            .into_inner()
    }

    #[test]
    fn the_mikron_map_from_forward_kinematics_is_rz_c_rx_a() {
        let mikron = machine("mikron");
        let boxes = JointBoxes::new(&mikron).expect("three linear axes");
        let kins: [Box<dyn Kinematics>; 2] = [solver_for(&mikron), Box::new(Chain::new(mikron.clone()))];
        for kin in &kins {
            for (a, c) in [(0.0, 0.0), (30.0, -20.0), (-75.0, 130.0), (-120.0, 359.0), (10.0, -400.0)] {
                let (a, c) = (f64::to_radians(a), f64::to_radians(c));
                let joints = Joints::from_slice(&[12.0, -3.0, 40.0, a, c]);
                let map = JointMap::at(kin.as_ref(), &boxes, &joints).expect("regular");
                assert!((map.to_part() - rz_rx(a, c)).abs().max() < 1e-12, "{a} {c}: {}", map.to_part());
                assert!((map.to_joint() * map.to_part() - Matrix3::identity()).abs().max() < 1e-12);
                assert_eq!(map.joints().as_slice(), joints.as_slice());
            }
        }
    }

    #[test]
    fn norms_along_axes_faces_and_vertices() {
        let mikron = machine("mikron");
        let kin = solver_for(&mikron);
        let boxes = JointBoxes::new(&mikron).expect("boxes");
        assert_eq!(boxes.axes(), [0, 1, 2]);
        assert_eq!(boxes.limits(Level::Acceleration), Vector3::new(2500.0, 3000.0, 2100.0));
        let joints = Joints::from_slice(&[0.0, 0.0, 0.0, 0.4, -1.1]);
        let map = JointMap::at(kin.as_ref(), &boxes, &joints).expect("map");
        let acc = boxes.polytope(Level::Acceleration, &map);
        assert_eq!(acc.level(), Level::Acceleration);
        // Along a joint axis: its limit; the polytope is symmetric, the length of d irrelevant.
        for k in 0..3 {
            let d = map.to_part().column(k).into_owned();
            assert!((acc.norm_along(&d) - boxes.limits(Level::Acceleration)[k]).abs() < 1e-9);
            assert!((acc.norm_along(&(-3.0 * d)) - boxes.limits(Level::Acceleration)[k]).abs() < 1e-9);
        }
        let vertices = acc.vertices();
        for (k, v) in vertices.iter().enumerate() {
            assert!((v.norm - 4433.959855479073).abs() < 1e-9);
            assert!((acc.norm_along(&v.direction) - v.norm).abs() < 1e-9);
            // Opposite vertices.
            assert!((v.direction.into_inner() + vertices[7 - k].direction.into_inner()).norm() < 1e-12);
            assert!((map.to_part() * v.joint - v.direction.into_inner() * v.norm).norm() < 1e-9);
        }
        assert_eq!(acc.preferred().signs, [1, 1, 1]);
        assert!((acc.inradius() - 2100.0).abs() < 1e-9);
        for bad in [Vector3::zeros(), Vector3::new(f64::NAN, 0.0, 1.0), Vector3::new(f64::INFINITY, 0.0, 0.0)] {
            assert_eq!(acc.norm_along(&bad), 0.0);
        }
    }

    #[test]
    fn bad_machines_and_set_ups_are_errors() {
        let mut mikron = machine("mikron");
        let kin = solver_for(&mikron);
        let boxes = JointBoxes::new(&mikron).expect("boxes");
        for joints in [Joints::from_slice(&[0.0; 4]), Joints::from_slice(&[0.0, 0.0, 0.0, f64::NAN, 0.0])] {
            assert!(matches!(JointMap::at(kin.as_ref(), &boxes, &joints), Err(OrientError::Joints { .. })));
        }
        mikron.axes[1].jmax = 0.0;
        let err = JointBoxes::new(&mikron).expect_err("zero jerk");
        assert!(err.to_string().contains("axis Y") && err.to_string().contains("jerk"), "{err}");
        mikron.axes[1].jmax = 5000.0;
        mikron.chain.linear.pop();
        assert!(matches!(JointBoxes::new(&mikron), Err(OrientError::LinearAxes { found: 2, .. })));
        // Two linear axes along the same line do not span space.
        let mut flat = machine("mikron");
        flat.axes[1].direction = flat.axes[0].direction;
        let kin = Chain::new(flat.clone());
        let boxes = JointBoxes::new(&flat).expect("limits are fine");
        let zero = Joints::zeros(5);
        assert!(matches!(JointMap::at(&kin, &boxes, &zero), Err(OrientError::Singular { .. })));
    }

    #[test]
    fn bounds_without_rotary_axes_or_with_one() {
        let three = machine("3axis");
        let kin = solver_for(&three);
        let boxes = JointBoxes::new(&three).expect("boxes");
        let b = bounds(kin.as_ref(), &boxes, Level::Jerk).expect("bounds");
        let l = boxes.limits(Level::Jerk);
        assert!(b.pole.is_none());
        assert!((b.lower - l.min()).abs() < 1e-9 && (b.upper - l.norm()).abs() < 1e-9, "{b:?}");
        let four = machine("4axis");
        let kin = solver_for(&four);
        let boxes = JointBoxes::new(&four).expect("boxes");
        let b = bounds(kin.as_ref(), &boxes, Level::Jerk).expect("bounds");
        // The A axis is along x: a feed along x cannot be turned, it gets the X limit.
        let pole = b.pole.expect("a pole");
        assert!(pole.x.abs() > 1.0 - 1e-12, "{pole:?}");
        assert!((b.lower - boxes.limits(Level::Jerk).x).abs() < 1e-9, "{b:?}");
    }

    #[test]
    fn the_turn_maximizer_finds_a_kink() {
        let (angle, value) = maximize_on_turn(|a| Ok(1.0 - (crate::wrap(a - 0.123_456_7)).abs())).expect("no error");
        assert!((angle - 0.123_456_7).abs() < 1e-9 && (value - 1.0).abs() < 1e-9, "{angle} {value}");
    }
}
