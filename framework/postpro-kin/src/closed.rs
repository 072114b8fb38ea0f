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

use nalgebra::Vector3;
use postpro_machine::model::{ClosedForm, Machine};

use crate::chain::{Chain, wrap};
use crate::pose::{Joints, Pose, PoseRate};
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
        Some(TableTableClosedForm { chain: Chain::new(machine), tilt, first, second, s1, s2 })
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
        self.chain.forward(joints)
    }

    fn forward_rate(&self, joints: &Joints, rates: &Joints) -> PoseRate {
        self.chain.forward_rate(joints, rates)
    }

    fn inverse(&self, pose: &Pose, out: &mut Solutions) {
        out.clear();
        let a = self.chain.part_rotation() * pose.axis.into_inner();
        let k = a.z.clamp(-1.0, 1.0);
        let alpha = k.acos();
        let pole = (self.second, k.abs().min(1.0).acos());
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
