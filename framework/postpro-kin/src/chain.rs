//! The generic serial chain: product of exponentials for the forward kinematics, and the
//! Paden–Kahan subproblems for the rotary angles of the inverse, in closed form for any axis
//! directions (orthogonal or not, such as a 45° nutating head) and any centre offsets.
//!
//! Conventions (see `postpro_machine::model`): everything in the base frame at all-zero. A rotary
//! axis is a line (point `q`, direction `ω`); turning it by θ maps `x ↦ q + R(ω, θ)(x − q)`.
//! Part side: `T_part(θ) = E(p₁, θ₁) ∘ E(p₂, θ₂) ∘ M_part` (base-most axis first).
//! Tool side: `tip = E(h₁) ∘ E(h₂)(tip₀) + Σ Lᵢ eᵢ`, `axis = R(h₁) R(h₂) k₀`.
//! Orientation: `R(p₁)R(p₂) a' = R(h₁)R(h₂) k₀` with `a' = R_part a`; the three 5-axis layouts
//! all reduce to subproblem 2, `R(ω₁, θ₁) R(ω₂, θ₂) p = q`:
//! table-table `(p₁, p₂; a' → k₀)`, head-head `(h₁, h₂; k₀ → a')`,
//! head-table `(p, h; k₀ → a')` with the table angle negated.

use nalgebra::{Isometry3, Matrix3, Point3, Unit, UnitQuaternion, Vector3};
use postpro_machine::model::{AxisKind, Machine};

use crate::pose::{Bend, Joints, Pose, PoseRate};
use crate::solver::{Kinematics, Solution, Solutions};

/// Below this, a vector is treated as zero (unit vectors; about 1e-6° of angle).
const EPS: f64 = 1e-12;

/// A rotary axis of the chain.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Rotary {
    /// Index in `Machine::axes`.
    pub(crate) index: usize,
    pub(crate) omega: Unit<Vector3<f64>>,
    pub(crate) q: Point3<f64>,
}

impl Rotary {
    fn rotation(&self, angle: f64) -> UnitQuaternion<f64> {
        UnitQuaternion::from_axis_angle(&self.omega, angle)
    }

    /// Turns `x` about this axis by the angle whose sine and cosine are `(s, c)` (Rodrigues'
    /// formula on the vector: a few dozen operations, no quaternion): `q + R(x − q)`.
    fn turn(&self, x: &Point3<f64>, (s, c): (f64, f64)) -> Point3<f64> {
        self.q + rodrigues(&self.omega, &(x - self.q), s, c)
    }
}

/// `R(ω, θ) v` for (sin θ, cos θ) = (s, c).
fn rodrigues(w: &Unit<Vector3<f64>>, v: &Vector3<f64>, s: f64, c: f64) -> Vector3<f64> {
    let w = w.as_ref();
    v * c + w.cross(v) * s + w * (w.dot(v) * (1.0 - c))
}

/// The tool tip and axis carried through the chain with their rates (forward mode).
#[derive(Default)]
struct Moving {
    tip: Point3<f64>,
    axis: Vector3<f64>,
    tip_rate: Vector3<f64>,
    axis_rate: Vector3<f64>,
}

impl Moving {
    /// Turns about `r` by the angle whose sine and cosine are `(s, c)`, turning at rate `w`: a
    /// point `x` moves to `q + R(x − q)` at `R ẋ + w ω × R(x − q)`.
    fn turn(&mut self, r: &Rotary, (s, c): (f64, f64), w: f64) {
        let arm = rodrigues(&r.omega, &(self.tip - r.q), s, c);
        self.tip_rate = rodrigues(&r.omega, &self.tip_rate, s, c) + r.omega.cross(&arm) * w;
        self.tip = r.q + arm;
        self.axis = rodrigues(&r.omega, &self.axis, s, c);
        self.axis_rate = rodrigues(&r.omega, &self.axis_rate, s, c) + r.omega.cross(&self.axis) * w;
    }
}

/// A point (or a unit vector: `reach` 1) carried through the chain's turns along a linear move
/// of the axes, `t` from 0 to 1: bounds of its distance from the centre of the next turn and of
/// its first and second derivatives.
#[derive(Clone, Copy, Debug, Default)]
struct Carried {
    reach: f64,
    rate: f64,
    bend: f64,
}

impl Carried {
    /// After a turn by `Δθ = ±w` about a centre at most `reach` away: `(q + R(x − q))'' =
    /// R''(x − q) + 2R'ẋ + Rẍ`, with `|R'v| ≤ w|v|` and `|R''v| ≤ w²|v|`. The distance from the
    /// centre stays.
    fn turned(self, w: f64) -> Carried {
        Carried {
            reach: self.reach,
            rate: self.rate + w * self.reach,
            bend: self.bend + w * w * self.reach + 2.0 * w * self.rate,
        }
    }
}

/// Where the rotary axes sit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Layout {
    Three,
    Table1,
    Head1,
    TableTable,
    HeadHead,
    HeadTable,
}

/// The generic serial-chain solver.
#[derive(Clone, Debug)]
pub struct Chain {
    machine: Machine,
    layout: Layout,
    part: Vec<Rotary>,
    tool: Vec<Rotary>,
    linear: Vec<usize>,
    /// Linear axis directions as columns, and the (pseudo-)inverse that maps a displacement to
    /// the axis values.
    linear_inverse: Matrix3<f64>,
    part_origin: Isometry3<f64>,
    part_origin_inverse: Isometry3<f64>,
    tip0: Point3<f64>,
    k0: Unit<Vector3<f64>>,
}

impl Chain {
    /// The solver of a machine.
    pub fn new(machine: Machine) -> Chain {
        let rotary = |&i: &usize| {
            let a = &machine.axes[i];
            Rotary { index: i, omega: a.direction, q: a.center }
        };
        let part: Vec<Rotary> = machine.chain.part.iter().map(rotary).collect();
        let tool: Vec<Rotary> = machine.chain.tool.iter().map(rotary).collect();
        let layout = match (part.len(), tool.len()) {
            (0, 0) => Layout::Three,
            (1, 0) => Layout::Table1,
            (0, 1) => Layout::Head1,
            (2, 0) => Layout::TableTable,
            (0, 2) => Layout::HeadHead,
            _ => Layout::HeadTable,
        };
        let linear = machine.chain.linear.clone();
        let mut e = Matrix3::zeros();
        for (col, &i) in linear.iter().enumerate().take(3) {
            e.set_column(col, &machine.axes[i].direction.into_inner());
        }
        // Fewer than three linear axes: a least-squares inverse over the axes present.
        let linear_inverse = e.pseudo_inverse(1e-12).unwrap_or_else(|_| Matrix3::zeros());
        Chain {
            part_origin: machine.chain.part_origin,
            part_origin_inverse: machine.chain.part_origin.inverse(),
            tip0: machine.chain.tool_tip(),
            k0: machine.chain.tool_direction,
            machine,
            layout,
            part,
            tool,
            linear,
            linear_inverse,
        }
    }

    /// The part point `p` in the base frame: `E(p₁)∘E(p₂)∘M_part (p)`.
    fn part_to_base(&self, joints: &Joints, p: &Point3<f64>) -> Point3<f64> {
        let mut x = self.part_origin * p;
        for r in self.part.iter().rev() {
            x = r.turn(&x, joints[r.index].sin_cos());
        }
        x
    }

    /// The tool tip in the base frame, its linear axes at zero, and the tool axis there.
    fn tool_in_base(&self, joints: &Joints) -> (Point3<f64>, Vector3<f64>) {
        let (mut tip, mut axis) = (self.tip0, self.k0.into_inner());
        for r in self.tool.iter().rev() {
            let (s, c) = joints[r.index].sin_cos();
            tip = r.turn(&tip, (s, c));
            axis = rodrigues(&r.omega, &axis, s, c);
        }
        (tip, axis)
    }

    /// The rotation from the part frame to the base frame at all-zero.
    pub(crate) fn part_rotation(&self) -> UnitQuaternion<f64> {
        self.part_origin.rotation
    }

    /// The part-side rotary axes, base first.
    pub(crate) fn part_axes(&self) -> &[Rotary] {
        &self.part
    }

    /// The part frame at all-zero, in the base frame.
    pub(crate) fn part_origin(&self) -> &Isometry3<f64> {
        &self.part_origin
    }

    /// The linear axes that bring the tool tip (no tool-side rotaries) to `tip_base`.
    pub(crate) fn place_tip_without_head(&self, tip_base: &Point3<f64>, joints: &mut Joints) {
        let values = self.linear_inverse * (tip_base - self.tip0);
        for (k, &i) in self.linear.iter().enumerate().take(3) {
            joints[i] = values[k];
        }
    }

    /// The linear axes that put the tip on `pose` once the rotary angles in `joints` are set.
    pub(crate) fn place_linear(&self, pose: &Pose, joints: &mut Joints) {
        let tip_base = self.part_to_base(joints, &pose.tip);
        let (tool_tip, _) = self.tool_in_base(joints);
        let values = self.linear_inverse * (tip_base - tool_tip);
        for (k, &i) in self.linear.iter().enumerate().take(3) {
            joints[i] = values[k];
        }
    }

    fn rotary_only(&self, pose: &Pose, out: &mut Solutions) {
        let a = self.part_origin.rotation * pose.axis.into_inner();
        let k0 = self.k0.into_inner();
        let n = self.machine.axes.len();
        let tol = 1e-9;
        let mut push = |angles: &[(usize, f64)], branch: u8, pole: Option<(usize, f64)>| {
            let mut j = Joints::zeros(n);
            for &(i, v) in angles {
                j[i] = wrap(v);
            }
            self.place_linear(pose, &mut j);
            out.push(Solution { joints: j, branch, pole });
        };
        match self.layout {
            Layout::Three => {
                if (a - k0).norm() < tol {
                    push(&[], 0, None);
                }
            }
            Layout::Table1 => {
                let r = self.part[0];
                if let Some(t) = subproblem1_exact(&r.omega, &a, &k0, tol) {
                    push(&[(r.index, t)], 0, pole_of(&r, &a).map(|d| (r.index, d)));
                }
            }
            Layout::Head1 => {
                let r = self.tool[0];
                if let Some(t) = subproblem1_exact(&r.omega, &k0, &a, tol) {
                    push(&[(r.index, t)], 0, pole_of(&r, &a).map(|d| (r.index, d)));
                }
            }
            Layout::TableTable | Layout::HeadHead | Layout::HeadTable => {
                let (r1, r2, p, q, negate1) = match self.layout {
                    Layout::TableTable => (self.part[0], self.part[1], a, k0, false),
                    Layout::HeadHead => (self.tool[0], self.tool[1], k0, a, false),
                    _ => (self.part[0], self.tool[0], k0, a, true),
                };
                for (branch, (t1, t2, pole1, pole2)) in
                    subproblem2(&r1.omega, &r2.omega, &p, &q).into_iter().enumerate()
                {
                    let t1 = if negate1 { -t1 } else { t1 };
                    // The axis that may become free, and how far the pose is from that.
                    let pole = match (pole1, pole2) {
                        (Some(d1), Some(d2)) if d2 < d1 => Some((r2.index, d2)),
                        (Some(d1), _) => Some((r1.index, d1)),
                        (None, Some(d2)) => Some((r2.index, d2)),
                        (None, None) => None,
                    };
                    push(&[(r1.index, t1), (r2.index, t2)], branch as u8, pole);
                }
            }
        }
    }
}

impl Kinematics for Chain {
    fn machine(&self) -> &Machine {
        &self.machine
    }

    fn forward(&self, joints: &Joints) -> Pose {
        let (mut tip, mut axis) = self.tool_in_base(joints);
        for &i in &self.linear {
            tip += self.machine.axes[i].direction.into_inner() * joints[i];
        }
        // Back through the part side: E(p₁)⁻¹ first, then E(p₂)⁻¹, then M_part⁻¹.
        for r in &self.part {
            let (s, c) = joints[r.index].sin_cos();
            tip = r.turn(&tip, (-s, c));
            axis = rodrigues(&r.omega, &axis, -s, c);
        }
        let inverse = &self.part_origin_inverse;
        Pose { tip: inverse * tip, axis: Unit::new_normalize(inverse.rotation * axis) }
    }

    fn bend(&self, a: &Joints, b: &Joints) -> Option<Bend> {
        let turn = |i: usize| (b[i] - a[i]).abs();
        // The tip stays within `tip.reach` of `centre`; the tool axis is a unit vector.
        let (mut centre, mut tip, mut axis) =
            (self.tip0, Carried::default(), Carried { reach: 1.0, ..Carried::default() });
        for r in self.tool.iter().rev() {
            tip.reach += (centre - r.q).norm();
            centre = r.q;
            (tip, axis) = (tip.turned(turn(r.index)), axis.turned(turn(r.index)));
        }
        // The linear axes carry the tip along a line, `start + t·step`.
        let (mut start, mut step) = (Vector3::zeros(), Vector3::zeros());
        for &i in &self.linear {
            let direction = self.machine.axes[i].direction.into_inner();
            start += direction * a[i];
            step += direction * (b[i] - a[i]);
        }
        tip.rate += step.norm();
        let mut line = Some((start, step));
        for r in &self.part {
            tip.reach += match line.take() {
                // A segment's farthest point from `q` is one of its ends.
                Some((start, step)) => (centre + start - r.q).norm().max((centre + start + step - r.q).norm()),
                None => (centre - r.q).norm(),
            };
            centre = r.q;
            (tip, axis) = (tip.turned(turn(r.index)), axis.turned(turn(r.index)));
        }
        // The part frame's isometry keeps every length.
        Some(Bend { tip: tip.bend, axis: axis.bend })
    }

    fn forward_rate(&self, joints: &Joints, rates: &Joints) -> PoseRate {
        let mut m = Moving { tip: self.tip0, axis: self.k0.into_inner(), ..Moving::default() };
        for r in self.tool.iter().rev() {
            m.turn(r, joints[r.index].sin_cos(), rates[r.index]);
        }
        for &i in &self.linear {
            let direction = self.machine.axes[i].direction.into_inner();
            m.tip += direction * joints[i];
            m.tip_rate += direction * rates[i];
        }
        // The part side turns the other way (E(p)⁻¹).
        for r in &self.part {
            let (s, c) = joints[r.index].sin_cos();
            m.turn(r, (-s, c), -rates[r.index]);
        }
        let rotation = &self.part_origin_inverse.rotation;
        PoseRate { tip: rotation * m.tip_rate, axis: rotation * m.axis_rate }
    }

    fn inverse(&self, pose: &Pose, out: &mut Solutions) {
        out.clear();
        self.rotary_only(pose, out);
    }

    fn inverse_holding(&self, pose: &Pose, free_axis: usize, value: f64) -> Option<Joints> {
        let a = self.part_origin.rotation * pose.axis.into_inner();
        let k0 = self.k0.into_inner();
        let mut j = Joints::zeros(self.machine.axes.len());
        j[free_axis] = value;
        match self.layout {
            Layout::TableTable if self.part[1].index == free_axis => {
                let (r1, r2) = (self.part[0], self.part[1]);
                j[r1.index] = wrap(subproblem1(&r1.omega, &(r2.rotation(value) * a), &k0)?);
            }
            Layout::TableTable if self.part[0].index == free_axis => {
                let (r1, r2) = (self.part[0], self.part[1]);
                j[r2.index] = wrap(subproblem1(&r2.omega, &a, &(r1.rotation(-value) * k0))?);
            }
            Layout::HeadHead if self.tool[0].index == free_axis => {
                let (r1, r2) = (self.tool[0], self.tool[1]);
                j[r2.index] = wrap(subproblem1(&r2.omega, &k0, &(r1.rotation(-value) * a))?);
            }
            Layout::HeadHead if self.tool[1].index == free_axis => {
                let (r1, r2) = (self.tool[0], self.tool[1]);
                j[r1.index] = wrap(subproblem1(&r1.omega, &(r2.rotation(value) * k0), &a)?);
            }
            Layout::HeadTable if self.part[0].index == free_axis => {
                let (rp, rh) = (self.part[0], self.tool[0]);
                j[rh.index] = wrap(subproblem1(&rh.omega, &k0, &(rp.rotation(value) * a))?);
            }
            Layout::HeadTable if self.tool[0].index == free_axis => {
                let (rp, rh) = (self.part[0], self.tool[0]);
                j[rp.index] = wrap(subproblem1(&rp.omega, &a, &(rh.rotation(value) * k0))?);
            }
            Layout::Table1 | Layout::Head1 if self.machine.axes[free_axis].kind == AxisKind::Rotary => {}
            _ => return None,
        }
        self.place_linear(pose, &mut j);
        Some(j)
    }

    fn place(&self, pose: &Pose, rotaries: &Joints) -> Joints {
        let mut j = *rotaries;
        self.place_linear(pose, &mut j);
        j
    }
}

/// An angle in (−π, π].
pub(crate) fn wrap(angle: f64) -> f64 {
    let w = angle - whole_turns(angle);
    if w <= -std::f64::consts::PI { w + std::f64::consts::TAU } else { w }
}

/// The whole turns nearest to `angle` (rad): `2π · round(angle / 2π)`, the same value, without
/// the library call where it is none (the baseline x86-64 has no rounding instruction; nearly
/// every angle is within half a turn).
pub(crate) fn whole_turns(angle: f64) -> f64 {
    let turns = angle / std::f64::consts::TAU;
    let nearest = if turns.abs() < 0.5 { 0.0_f64.copysign(turns) } else { turns.round() };
    std::f64::consts::TAU * nearest
}

/// The angle between a vector and the nearer direction of an axis line, if it is defined.
fn pole_of(r: &Rotary, v: &Vector3<f64>) -> Option<f64> {
    let n = v.norm();
    (n > EPS).then(|| (r.omega.dot(v).abs() / n).clamp(0.0, 1.0).acos())
}

/// Subproblem 1: the angle θ about `omega` that turns `p` closest to `q` (exactly onto it when
/// their components along `omega` agree). `None` when `p` or `q` lies on the axis: the angle is
/// free.
pub(crate) fn subproblem1(omega: &Unit<Vector3<f64>>, p: &Vector3<f64>, q: &Vector3<f64>) -> Option<f64> {
    let u = p - omega.into_inner() * omega.dot(p);
    let v = q - omega.into_inner() * omega.dot(q);
    if u.norm_squared() < EPS || v.norm_squared() < EPS {
        return None;
    }
    Some(omega.dot(&u.cross(&v)).atan2(u.dot(&v)))
}

/// Subproblem 1 when the rotation must be exact: `None` if `p` cannot be turned onto `q`.
/// On the axis (free angle) the angle is 0.
fn subproblem1_exact(omega: &Unit<Vector3<f64>>, p: &Vector3<f64>, q: &Vector3<f64>, tol: f64) -> Option<f64> {
    if (omega.dot(p) - omega.dot(q)).abs() > tol {
        return None;
    }
    Some(subproblem1(omega, p, q).unwrap_or(0.0))
}

/// Subproblem 2: every (θ₁, θ₂) with `R(ω₁, θ₁) R(ω₂, θ₂) p = q`, for unit `p` and `q`, each with
/// the distance (rad) from the pose to the singularity of θ₁ and of θ₂ when one can occur
/// (θ₂ is free when `p` is on ω₂; θ₁ when the intermediate vector is on ω₁).
#[allow(clippy::type_complexity)]
pub(crate) fn subproblem2(
    w1: &Unit<Vector3<f64>>,
    w2: &Unit<Vector3<f64>>,
    p: &Vector3<f64>,
    q: &Vector3<f64>,
) -> Vec<(f64, f64, Option<f64>, Option<f64>)> {
    let (w1v, w2v) = (w1.into_inner(), w2.into_inner());
    let c = w1.dot(w2);
    let cross = w1v.cross(&w2v);
    let s2 = cross.norm_squared();
    let mut out = Vec::with_capacity(2);
    if s2 < EPS {
        // Parallel axes: only the sum of the angles matters; θ₂ = 0.
        if let Some(t) = subproblem1_exact(w1, p, q, 1e-9) {
            out.push((t, 0.0, None, None));
        }
        return out;
    }
    let den = c * c - 1.0;
    let alpha = (c * w2.dot(p) - w1.dot(q)) / den;
    let beta = (c * w1.dot(q) - w2.dot(p)) / den;
    let g2 = (p.norm_squared() - alpha * alpha - beta * beta - 2.0 * alpha * beta * c) / s2;
    if g2 < -1e-9 {
        return out;
    }
    let g = g2.max(0.0).sqrt();
    let gammas: &[f64] = if g < 1e-9 { &[0.0] } else { &[g, -g] };
    for &gamma in gammas {
        let z = w1v * alpha + w2v * beta + cross * gamma;
        let pole2 = angle_to_line(w2, p);
        let pole1 = angle_to_line(w1, &z);
        let t2 = subproblem1(w2, p, &z).unwrap_or(0.0);
        let t1 = subproblem1(w1, &z, q).unwrap_or(0.0);
        out.push((t1, t2, pole1, pole2));
    }
    out
}

/// The angle between a vector and the nearer direction of an axis.
fn angle_to_line(w: &Unit<Vector3<f64>>, v: &Vector3<f64>) -> Option<f64> {
    let n = v.norm();
    (n > EPS).then(|| (w.dot(v).abs() / n).clamp(0.0, 1.0).acos())
}
