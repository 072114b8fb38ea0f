//! Hand-derived closed forms for table-table machines whose tilt is about ±x (Mikron UCP 710,
//! CAXYZ, paper 000) or ±y (MAHO 600E, TTTRR, paper 002) and whose rotary table is about ±z,
//! with a tool along +z. They are faster than the generic chain and check it: a test shows both
//! agree to 1e-9.
//!
//! With α = s₁·θ₁ (tilt) and γ = s₂·θ₂ (table), s = ±1 the axis senses, the tool axis in the
//! part frame (turned into the base frame at all-zero) is
//! - tilt about x: `a' = (sin α sin γ, sin α cos γ, cos α)` (paper 000: i = sin C sin A, …);
//! - tilt about y: `a' = (−sin α cos γ, sin α sin γ, cos α)` (paper 002: i = sin b cos a, …).
//!
//! So α = ±acos(k'), and γ from atan2 on the branch's sign of sin α; at k' = ±1 (the pole) γ is
//! free.
//!
//! The forward kinematics and its rate are the chain's (`crate::chain`), with each rotation
//! about a coordinate axis written out: a turn about x, y or z moves two coordinates, where the
//! generic chain's Rodrigues formula moves three about any direction.

use nalgebra::{Matrix3, Point3, Unit, Vector3};
use postpro_machine::model::{ClosedForm, Machine};

use crate::chain::{Chain, wrap};
use crate::pose::{Bend, Joints, Pose, PoseRate};
use crate::solver::{Kinematics, Solution, Solutions};

/// Which machine axis the tilt turns about.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Tilt {
    AboutX,
    AboutY,
}

/// The closed form of a table-table machine with orthogonal axes.
#[derive(Clone, Debug)]
pub struct TableTableClosedForm {
    chain: Chain,
    tilt: Tilt,
    first: usize,
    second: usize,
    s1: f64,
    s2: f64,
    forward: Forward,
}

/// What the forward kinematics needs, read once from the chain: the tool tip with every axis at
/// zero, the linear axes' directions, the rotary axes' centres, and the part frame's inverse as
/// a matrix and a translation.
#[derive(Clone, Debug)]
struct Forward {
    tip0: Point3<f64>,
    k0: Vector3<f64>,
    linear: Vec<(usize, Vector3<f64>)>,
    q1: Point3<f64>,
    q2: Point3<f64>,
    rotation: Matrix3<f64>,
    translation: Vector3<f64>,
}

impl TableTableClosedForm {
    /// The closed form for a machine; `None` when the machine does not have the shape the
    /// closed form assumes (validation prevents that for the built-in definitions).
    pub fn new(machine: Machine, form: ClosedForm) -> Option<TableTableClosedForm> {
        let (&[first, second], &[]) = (machine.chain.part.as_slice(), machine.chain.tool.as_slice()) else {
            return None;
        };
        let d1 = machine.axes[first].direction.into_inner();
        let d2 = machine.axes[second].direction.into_inner();
        let along = |d: Vector3<f64>, e: Vector3<f64>| {
            let c = d.dot(&e);
            ((c.abs() - 1.0).abs() < 1e-12).then_some(c.signum())
        };
        let (tilt, s1) = match form {
            ClosedForm::MikronUcp710 => (Tilt::AboutX, along(d1, Vector3::x())?),
            ClosedForm::Maho600e => (Tilt::AboutY, along(d1, Vector3::y())?),
        };
        let s2 = along(d2, Vector3::z())?;
        along(machine.chain.tool_direction.into_inner(), Vector3::z()).filter(|s| *s > 0.0)?;
        let inverse = machine.chain.part_origin.inverse();
        let forward = Forward {
            tip0: machine.chain.tool_tip(),
            k0: machine.chain.tool_direction.into_inner(),
            linear: machine.chain.linear.iter().take(3).map(|&i| (i, machine.axes[i].direction.into_inner())).collect(),
            q1: machine.axes[first].center,
            q2: machine.axes[second].center,
            rotation: inverse.rotation.to_rotation_matrix().into_inner(),
            translation: inverse.translation.vector,
        };
        Some(TableTableClosedForm { chain: Chain::new(machine), tilt, first, second, s1, s2, forward })
    }

    /// The tilt's turn `v ↦ R(ω₁, θ) v` for (sin θ, cos θ) = (s, c), ω₁ = ±x or ±y.
    fn tilt(&self, v: Vector3<f64>, s: f64, c: f64) -> Vector3<f64> {
        match self.tilt {
            Tilt::AboutX => rotate_x(v, self.s1 * s, c),
            Tilt::AboutY => rotate_y(v, self.s1 * s, c),
        }
    }

    /// `ω₁ × v`.
    fn tilt_cross(&self, v: Vector3<f64>) -> Vector3<f64> {
        match self.tilt {
            Tilt::AboutX => Vector3::new(0.0, -v.z, v.y) * self.s1,
            Tilt::AboutY => Vector3::new(v.z, 0.0, -v.x) * self.s1,
        }
    }

    /// The tool tip in the base frame with the rotaries at zero: `tip₀ + Σ Lᵢ eᵢ` (the tool stands
    /// on no rotary axis), and the rate of the given linear axis rates.
    fn tip_in_base(&self, joints: &Joints, rates: Option<&Joints>) -> (Point3<f64>, Vector3<f64>) {
        let f = &self.forward;
        let (mut tip, mut rate) = (f.tip0, Vector3::zeros());
        for &(i, direction) in &f.linear {
            tip += direction * joints[i];
            if let Some(rates) = rates {
                rate += direction * rates[i];
            }
        }
        (tip, rate)
    }
}

/// `Rx(θ) v` from (sin θ, cos θ).
fn rotate_x(v: Vector3<f64>, s: f64, c: f64) -> Vector3<f64> {
    Vector3::new(v.x, c * v.y - s * v.z, s * v.y + c * v.z)
}

/// `Ry(θ) v` from (sin θ, cos θ).
fn rotate_y(v: Vector3<f64>, s: f64, c: f64) -> Vector3<f64> {
    Vector3::new(c * v.x + s * v.z, v.y, -s * v.x + c * v.z)
}

/// `Rz(θ) v` from (sin θ, cos θ).
fn rotate_z(v: Vector3<f64>, s: f64, c: f64) -> Vector3<f64> {
    Vector3::new(c * v.x - s * v.y, s * v.x + c * v.y, v.z)
}

impl Kinematics for TableTableClosedForm {
    fn machine(&self) -> &postpro_machine::model::Machine {
        self.chain.machine()
    }

    fn forward(&self, joints: &Joints) -> Pose {
        // The chain's order: the tilt turned back (E(p₁)⁻¹), then the table (E(p₂)⁻¹), then the
        // part frame's inverse.
        let f = &self.forward;
        let (tip, _) = self.tip_in_base(joints, None);
        let (s1, c1) = joints[self.first].sin_cos();
        let (s2, c2) = joints[self.second].sin_cos();
        let tip = f.q1 + self.tilt(tip - f.q1, -s1, c1);
        let axis = self.tilt(f.k0, -s1, c1);
        let tip = f.q2 + rotate_z(tip - f.q2, -self.s2 * s2, c2);
        let axis = rotate_z(axis, -self.s2 * s2, c2);
        Pose {
            tip: Point3::from(f.rotation * tip.coords + f.translation),
            axis: Unit::new_normalize(f.rotation * axis),
        }
    }

    fn bend(&self, a: &Joints, b: &Joints) -> Option<Bend> {
        // The same forward kinematics as the chain's.
        self.chain.bend(a, b)
    }

    fn forward_rate(&self, joints: &Joints, rates: &Joints) -> PoseRate {
        // Forward mode through the same turns: a point x turned to q + R(x − q) at rate w about
        // ω moves at R ẋ + w ω × R(x − q) (the part side turns the other way: −w).
        let f = &self.forward;
        let (tip, tip_rate) = self.tip_in_base(joints, Some(rates));
        let (s1, c1) = joints[self.first].sin_cos();
        let (s2, c2) = joints[self.second].sin_cos();
        let (w1, w2) = (-rates[self.first], -rates[self.second]);
        let arm = self.tilt(tip - f.q1, -s1, c1);
        let tip_rate = self.tilt(tip_rate, -s1, c1) + self.tilt_cross(arm) * w1;
        let axis = self.tilt(f.k0, -s1, c1);
        let axis_rate = self.tilt_cross(axis) * w1;
        let tip = f.q1 + arm;
        // About ±z: ω₂ × v = s₂ (−v_y, v_x, 0).
        let z_cross = |v: Vector3<f64>| Vector3::new(-v.y, v.x, 0.0) * self.s2;
        let (s, c) = (-self.s2 * s2, c2);
        let arm = rotate_z(tip - f.q2, s, c);
        let tip_rate = rotate_z(tip_rate, s, c) + z_cross(arm) * w2;
        let axis = rotate_z(axis, s, c);
        let axis_rate = rotate_z(axis_rate, s, c) + z_cross(axis) * w2;
        PoseRate { tip: f.rotation * tip_rate, axis: f.rotation * axis_rate }
    }

    fn inverse(&self, pose: &Pose, out: &mut Solutions) {
        out.clear();
        let a = self.chain.part_rotation() * pose.axis.into_inner();
        let k = a.z.clamp(-1.0, 1.0);
        let alpha = k.acos();
        // The angle from the pole's nearer end: α itself where k ≥ 0 (the same value, computed once).
        let pole = (self.second, if k >= 0.0 { alpha } else { k.abs().min(1.0).acos() });
        let n = self.chain.machine().axes.len();
        // sin α ≥ 0 on branch 0; (sin γ, cos γ) from the tool axis, no further trigonometry.
        let sin_alpha = (1.0 - k * k).max(0.0).sqrt();
        let (sg, cg) = match self.tilt {
            Tilt::AboutX => (a.x, a.y),
            Tilt::AboutY => (a.y, -a.x),
        };
        let r = sg.hypot(cg);
        let (sg, cg) = if r < 1e-15 { (0.0, 1.0) } else { (sg / r, cg / r) };
        let gamma = sg.atan2(cg);
        // The part point turned into the base frame: q₁ + R₁(q₂ − q₁ + R₂(M p − q₂)).
        let [first, second] = [self.chain.part_axes()[0], self.chain.part_axes()[1]];
        let p0 = self.chain.part_origin() * pose.tip;
        for branch in 0..2u8 {
            let sign = if branch == 0 { 1.0 } else { -1.0 };
            if branch == 1 && sin_alpha == 0.0 {
                break;
            }
            // Branch 1: α → −α, γ → γ + π.
            let (sa, ca) = (sign * sin_alpha, k);
            let (sgb, cgb) = (sign * sg, sign * cg);
            let v = rotate_z(p0 - second.q, sgb, cgb) + (second.q - first.q);
            let v = match self.tilt {
                Tilt::AboutX => rotate_x(v, sa, ca),
                Tilt::AboutY => rotate_y(v, sa, ca),
            };
            let mut j = Joints::zeros(n);
            j[self.first] = wrap(self.s1 * sign * alpha);
            j[self.second] = wrap(self.s2 * (gamma + if branch == 0 { 0.0 } else { std::f64::consts::PI }));
            self.chain.place_tip_without_head(&(first.q + v), &mut j);
            out.push(Solution { joints: j, branch, pole: Some(pole) });
        }
    }

    fn inverse_holding(&self, pose: &Pose, free_axis: usize, value: f64) -> Option<Joints> {
        self.chain.inverse_holding(pose, free_axis, value)
    }

    fn place(&self, pose: &Pose, rotaries: &Joints) -> Joints {
        self.chain.place(pose, rotaries)
    }
}
