//! The set-ups that point a feed direction at a polytope vertex (paper 004 §4.3, appendix A).
//!
//! Pointing the part-frame feed direction `d` at the vertex `v` means choosing the rotary angles
//! so that the machine-frame image of `d` is `w = E v / |E v|` (`E`: the linear axes'
//! directions in the base frame). That is the inverse kinematics of a **tool axis**: on a copy of
//! the machine whose spindle points along `w` (and whose head, if any, is left out of the chain,
//! since it does not turn the polytope), the pose with tool axis `d` is reached exactly at those
//! angles. The generic chain returns every branch, so a table-table machine gives up to
//! 8 vertices × 2 branches = 16 set-ups, with no formula written for one machine.
//!
//! Each set-up is then fitted into the rotary travels (at the turn nearest zero), its tool axis
//! (forward kinematics) checked against an admissible cone around a reference axis, and the
//! alignment verified by the forward kinematics of the real machine (`J v̂ = d` to 1e-9, else
//! [`OrientError::Inconsistent`]). Tool-side rotary axes, which do not turn the polytope, bring
//! the tool axis as near the reference as they can: on a head-table machine the head angle that
//! best matches it with the table held, on a head-head machine each branch of the reference
//! axis's inverse.
//!
//! The linear travels are not checked here: they depend on where the part sits, and solving the
//! program at the chosen set-up checks them.

use nalgebra::{Point3, Unit, Vector3};
use postpro_kin::{Chain, Joints, Kinematics, Pose, Solutions};
use postpro_machine::model::{Machine, Travel};

use crate::OrientError;
use crate::polytope::{JointBoxes, JointMap, Level, vertex_signs};

/// How far the forward kinematics may put the vertex from the feed direction.
const ALIGNMENT_TOLERANCE: f64 = 1e-9;

/// What to align and what is admissible.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Options {
    /// Whose vertices the feed points at: the jerk (the paper's choice: it saturates first in a
    /// jerk-limited law), the acceleration or the velocity.
    pub level: Level,
    /// The reference tool axis in the part frame (tip → spindle), e.g. the mean surface normal.
    pub reference_axis: Unit<Vector3<f64>>,
    /// Half-angle (degrees) of the admissible cone around `reference_axis`: the tool axis at a
    /// set-up must lie within it. 180° admits everything.
    pub cone_half_angle_deg: f64,
}

impl Default for Options {
    /// Jerk vertices, reference axis +z, every tool axis admitted.
    fn default() -> Options {
        Options { level: Level::Jerk, reference_axis: Vector3::z_axis(), cone_half_angle_deg: 180.0 }
    }
}

/// One set-up that points the feed direction at a vertex.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Candidate {
    /// The axis values: the rotary angles of the set-up (rad, within their travels), the linear
    /// axes at zero.
    pub joints: Joints,
    /// The vertex the feed points at (signs of the linear axes' limits, see
    /// [`crate::Polytope::vertices`]).
    pub vertex: [i8; 3],
    /// The index of that vertex (0–7).
    pub vertex_index: usize,
    /// The inverse-kinematics branch (0 or 1).
    pub branch: u8,
    /// The tool axis in the part frame at this set-up.
    pub tool_axis: Unit<Vector3<f64>>,
    /// The angle (rad) between the tool axis and the reference axis.
    pub tilt: f64,
    /// The largest tangential velocity along the feed (mm/s).
    pub velocity: f64,
    /// The largest tangential acceleration along the feed (mm/s²).
    pub acceleration: f64,
    /// The largest tangential jerk along the feed (mm/s³).
    pub jerk: f64,
    /// `|J v̂ − d|`, the forward kinematics' check of the alignment (0 for [`best_in_cone`]'s
    /// set-ups, which point at no vertex).
    pub alignment_error: f64,
    /// True when the feed points at a vertex; false for [`best_in_cone`]'s fallback.
    pub at_vertex: bool,
}

impl Candidate {
    /// The largest tangential norm of one level along the feed.
    pub fn norm(&self, level: Level) -> f64 {
        match level {
            Level::Velocity => self.velocity,
            Level::Acceleration => self.acceleration,
            Level::Jerk => self.jerk,
        }
    }

    /// The value of the axis with this letter (rad or mm), if the machine has it.
    pub fn axis_value(&self, machine: &Machine, letter: &str) -> Option<f64> {
        machine.axis_index(letter).and_then(|i| self.joints.as_slice().get(i).copied())
    }
}

/// Every set-up that points the part-frame feed direction `d` (sign-free: the polytope is
/// symmetric, the eight vertices include both senses) at a vertex of the `options.level` box,
/// within the rotary travels and the admissible cone, best first: the largest jerk, then
/// acceleration, then velocity along `d`, then the smallest tilt.
///
/// An unreachable direction, or one whose set-ups all leave a travel or the cone, gives an
/// empty list. Errors: a `d` or reference axis that is not a direction, a cone outside
/// [0°, 180°], a machine without three linear axes, a solver that disagrees with the chain.
pub fn candidates(
    kin: &dyn Kinematics,
    boxes: &JointBoxes,
    d: &Vector3<f64>,
    options: &Options,
) -> Result<Vec<Candidate>, OrientError> {
    let d = direction("feed direction", d)?;
    let reference = direction("reference axis", &options.reference_axis)?;
    let cone = options.cone_half_angle_deg;
    if !(0.0..=180.0).contains(&cone) {
        return Err(OrientError::Cone(cone));
    }
    let cone = cone.to_radians();
    let machine = kin.machine();
    let limits = boxes.limits(options.level);
    let mut out = Vec::new();
    let mut solutions = Solutions::new();
    for vertex_index in 0..8 {
        let signs = vertex_signs(vertex_index);
        let vertex = limits.component_mul(&Vector3::from(signs.map(f64::from)));
        // The vertex's direction in the base frame: the linear axes' motion `E v`.
        let w = boxes
            .axes()
            .iter()
            .enumerate()
            .fold(Vector3::zeros(), |acc, (k, &i)| acc + machine.axes[i].direction.into_inner() * vertex[k]);
        let Some(w) = Unit::try_new(w, 1e-12) else { continue };
        let aligner = Chain::new(aligning_copy(machine, w));
        aligner.inverse(&Pose { tip: Point3::origin(), axis: d }, &mut solutions);
        for solution in solutions.iter() {
            for joints in with_tool_side(kin, &solution.joints, &reference) {
                let Some(joints) = fit_travels(machine, &joints) else { continue };
                let map = JointMap::at(kin, boxes, &joints)?;
                let image = map.to_part() * vertex;
                let alignment_error = (image.normalize() - d.into_inner()).norm();
                if alignment_error.is_nan() || alignment_error > ALIGNMENT_TOLERANCE {
                    return Err(OrientError::Inconsistent { machine: machine.name.clone(), error: alignment_error });
                }
                let tool_axis = kin.forward(&joints).axis;
                let tilt = tool_axis.dot(&reference).clamp(-1.0, 1.0).acos();
                if tilt > cone + 1e-12 {
                    continue;
                }
                let norm = |level| boxes.polytope(level, &map).norm_along(&d);
                out.push(Candidate {
                    joints,
                    vertex: signs,
                    vertex_index,
                    branch: solution.branch,
                    tool_axis,
                    tilt,
                    velocity: norm(Level::Velocity),
                    acceleration: norm(Level::Acceleration),
                    jerk: norm(Level::Jerk),
                    alignment_error,
                    at_vertex: true,
                });
            }
        }
    }
    // Quantized keys (1e-6 mm/s^k, 1e-9 rad) so that rounding noise does not order equals, and
    // a total order (`total_cmp`) so that sorting is well defined whatever the values.
    let key = |c: &Candidate| {
        [-c.jerk, -c.acceleration, -c.velocity].map(|v| (v * 1e6).round()).into_iter().chain([(c.tilt * 1e9).round()])
    };
    out.sort_by(|a, b| {
        key(a)
            .zip(key(b))
            .map(|(x, y)| x.total_cmp(&y))
            .find(|o| o.is_ne())
            .unwrap_or(std::cmp::Ordering::Equal)
            .then(a.vertex_index.cmp(&b.vertex_index))
            .then(a.branch.cmp(&b.branch))
    });
    Ok(out)
}

/// How far apart two set-ups are: the sum of their rotary axes' differences (rad).
pub fn rotary_distance(machine: &Machine, a: &Joints, b: &Joints) -> f64 {
    machine.chain.part.iter().chain(&machine.chain.tool).map(|&i| (a[i] - b[i]).abs()).sum()
}

/// Among `found` (best first, as [`candidates`] gives them), those whose `level` norm is the
/// best (within a millionth), the one nearest `near` (the previous path's set-up: the rotary
/// axes move least); the first when `near` is unknown.
pub fn nearest_of_the_best(
    machine: &Machine,
    found: &[Candidate],
    level: Level,
    near: Option<&Joints>,
) -> Option<Candidate> {
    let best = found.first()?.norm(level);
    let distance = |c: &Candidate| near.map_or(0.0, |n| rotary_distance(machine, &c.joints, n));
    found
        .iter()
        .filter(|c| c.norm(level) >= best * (1.0 - 1e-6))
        .min_by(|a, b| distance(a).total_cmp(&distance(b)))
        .copied()
}

/// When no set-up points `d` at a vertex within the travels and the cone: the set-up within them
/// whose `options.level` norm along `d` is the largest (paper 004 eq. 13), by a search over the
/// rotary axes (3° steps over their travels, then two finer passes around the best); among
/// set-ups within a thousandth of the best, the one nearest `near` (the previous path's: the
/// rotary axes move least; the home position when `None`). `None` when no rotary angle puts
/// the tool axis within the cone.
pub fn best_in_cone(
    kin: &dyn Kinematics,
    boxes: &JointBoxes,
    d: &Vector3<f64>,
    options: &Options,
    near: Option<&Joints>,
) -> Result<Option<Candidate>, OrientError> {
    let d = direction("feed direction", d)?;
    let reference = direction("reference axis", &options.reference_axis)?;
    if !(0.0..=180.0).contains(&options.cone_half_angle_deg) {
        return Err(OrientError::Cone(options.cone_half_angle_deg));
    }
    let cone = options.cone_half_angle_deg.to_radians();
    let machine = kin.machine();
    let rotary: Vec<usize> = machine.chain.part.iter().chain(&machine.chain.tool).copied().collect();
    let range = |i: usize| match machine.axes[i].travel {
        Travel::Limited { min, max } => (min.max(-std::f64::consts::PI * 4.0), max.min(std::f64::consts::PI * 4.0)),
        Travel::Endless => (-std::f64::consts::PI, std::f64::consts::PI),
    };
    let evaluate = |joints: &Joints| -> Result<Option<Candidate>, OrientError> {
        let tool_axis = kin.forward(joints).axis;
        let tilt = tool_axis.dot(&reference).clamp(-1.0, 1.0).acos();
        if tilt > cone + 1e-12 {
            return Ok(None);
        }
        let map = JointMap::at(kin, boxes, joints)?;
        let norm = |level| boxes.polytope(level, &map).norm_along(&d);
        Ok(Some(Candidate {
            joints: *joints,
            vertex: [0, 0, 0],
            vertex_index: usize::MAX,
            branch: 0,
            tool_axis,
            tilt,
            velocity: norm(Level::Velocity),
            acceleration: norm(Level::Acceleration),
            jerk: norm(Level::Jerk),
            alignment_error: 0.0,
            at_vertex: false,
        }))
    };
    // Nearest `near`, or the machine's home (all rotary axes at 0) when there is none.
    let home = Joints::zeros(machine.axes.len());
    let near = near.unwrap_or(&home);
    let distance = |c: &Candidate| rotary_distance(machine, &c.joints, near);
    let better = |a: &Candidate, b: &Candidate| {
        let (x, y) = (a.norm(options.level), b.norm(options.level));
        x > y * (1.0 + 1e-3) || (x >= y * (1.0 - 1e-3) && distance(a) < distance(b))
    };
    let mut best: Option<Candidate> = None;
    // A grid over the rotary axes (at most two are searched; others stay at 0).
    let search = |centre: Option<&Joints>, step: f64, best: &mut Option<Candidate>| -> Result<(), OrientError> {
        let axes: Vec<(usize, Vec<f64>)> = rotary
            .iter()
            .take(2)
            .map(|&i| {
                let (lo, hi) = range(i);
                let (lo, hi) = match centre {
                    Some(c) => ((c[i] - 5.0 * step).max(lo), (c[i] + 5.0 * step).min(hi)),
                    None => (lo, hi),
                };
                let n = ((hi - lo) / step).floor() as usize;
                (i, (0..=n).map(|k| lo + step * k as f64).collect())
            })
            .collect();
        let base = centre.copied().unwrap_or_else(|| Joints::zeros(machine.axes.len()));
        let first = axes.first().map_or(vec![0.0], |a| a.1.clone());
        let second = axes.get(1).map_or(vec![0.0], |a| a.1.clone());
        for &x in &first {
            for &y in &second {
                let mut joints = base;
                if let Some((i, _)) = axes.first() {
                    joints[*i] = x;
                }
                if let Some((i, _)) = axes.get(1) {
                    joints[*i] = y;
                }
                if let Some(c) = evaluate(&joints)?
                    && best.as_ref().is_none_or(|b| better(&c, b))
                {
                    *best = Some(c);
                }
            }
        }
        Ok(())
    };
    search(None, 3f64.to_radians(), &mut best)?;
    for step in [0.5f64, 0.1] {
        let Some(centre) = best.as_ref().map(|b| b.joints) else { break };
        search(Some(&centre), step.to_radians(), &mut best)?;
    }
    Ok(best)
}

/// A unit vector, or the error naming what it should have been.
fn direction(what: &'static str, v: &Vector3<f64>) -> Result<Unit<Vector3<f64>>, OrientError> {
    let err = || OrientError::Direction { what, x: v.x, y: v.y, z: v.z };
    if !v.iter().all(|c| c.is_finite()) {
        return Err(err());
    }
    Unit::try_new(*v, 1e-12).ok_or_else(err)
}

/// The machine whose tool axis, at the set-up that points `d` at `w`, reads `d` in the part
/// frame: the spindle along `w`, the head's rotary axes left out of the chain.
fn aligning_copy(machine: &Machine, w: Unit<Vector3<f64>>) -> Machine {
    let mut copy = machine.clone();
    copy.chain.tool.clear();
    copy.chain.tool_direction = w;
    copy.chain.tool_length = 0.0;
    copy
}

/// The set-ups with the tool-side rotary axes chosen for the reference axis (one per head
/// branch on a head-head machine), from the part-side angles of `joints`.
fn with_tool_side(kin: &dyn Kinematics, joints: &Joints, reference: &Unit<Vector3<f64>>) -> Vec<Joints> {
    let machine = kin.machine();
    let (part, tool) = (&machine.chain.part, &machine.chain.tool);
    let mut base = Joints::zeros(machine.axes.len());
    for &i in part {
        base[i] = joints[i];
    }
    if tool.is_empty() {
        return vec![base];
    }
    let pose = Pose { tip: Point3::origin(), axis: *reference };
    if let &[table] = part.as_slice() {
        if let Some(j) = kin.inverse_holding(&pose, table, base[table]) {
            for &i in tool {
                base[i] = j[i];
            }
        }
        return vec![base];
    }
    if part.is_empty() {
        let mut solutions = Solutions::new();
        kin.inverse(&pose, &mut solutions);
        let heads: Vec<Joints> = solutions
            .iter()
            .map(|s| {
                let mut j = base;
                for &i in tool {
                    j[i] = s.joints[i];
                }
                j
            })
            .collect();
        if !heads.is_empty() {
            return heads;
        }
    }
    vec![base]
}

/// The set-up with every rotary angle moved by whole turns into its travel (the turn nearest
/// zero), or `None` if an angle fits in no turn.
fn fit_travels(machine: &Machine, joints: &Joints) -> Option<Joints> {
    let mut out = *joints;
    for &i in machine.chain.part.iter().chain(&machine.chain.tool) {
        out[i] = fit_travel(joints[i], machine.axes[i].travel)?;
    }
    Some(out)
}

/// An angle moved by whole turns into a travel, at the turn nearest zero.
pub(crate) fn fit_travel(angle: f64, travel: Travel) -> Option<f64> {
    if !angle.is_finite() {
        return None;
    }
    let tau = std::f64::consts::TAU;
    let wrapped = crate::wrap(angle);
    match travel {
        Travel::Endless => Some(wrapped),
        Travel::Limited { min, max } => {
            let tol = 1e-9;
            let lo = ((min - tol - wrapped) / tau).ceil();
            let hi = ((max + tol - wrapped) / tau).floor();
            // NaN limits give NaN bounds: no turn fits.
            if lo.is_nan() || hi.is_nan() || lo > hi {
                return None;
            }
            let k = (-wrapped / tau).round().clamp(lo, hi);
            Some(wrapped + k * tau)
        }
    }
}

#[cfg(test)]
mod tests {
    use std::f64::consts::PI;

    use super::*;

    #[test]
    fn without_a_vertex_in_the_cone_the_best_set_up_within_it() {
        let registry = postpro_machine::Registry::builtin().expect("built-ins");
        let mikron = &registry.find("mikron").expect("mikron").machine;
        let kin = postpro_kin::solver_for(mikron);
        let boxes = JointBoxes::new(mikron).expect("boxes");
        // A horizontal feed along a hypar ruling: a vertex needs 35° of tilt; the cone allows 30°.
        let d = Vector3::new(1.0, 1.0, 0.0);
        let options = Options { cone_half_angle_deg: 30.0, ..Options::default() };
        assert!(candidates(kin.as_ref(), &boxes, &d, &options).expect("candidates").is_empty());
        let best = best_in_cone(kin.as_ref(), &boxes, &d, &options, None).expect("search").expect("a set-up");
        assert!(!best.at_vertex && best.tilt <= 30f64.to_radians() + 1e-9);
        // Better than the edge (5·√2) at the top, below the vertex (5·√3), and no 1° grid point
        // within the cone does better.
        assert!(best.jerk > 5000.0 * 2f64.sqrt() && best.jerk < 5000.0 * 3f64.sqrt(), "{}", best.jerk);
        let unit = Unit::new_normalize(d);
        for a in -30..=0 {
            for c in -180..180 {
                let mut joints = Joints::zeros(mikron.axes.len());
                joints[3] = f64::from(a).to_radians();
                joints[4] = f64::from(c).to_radians();
                let map = JointMap::at(kin.as_ref(), &boxes, &joints).expect("map");
                let jerk = boxes.polytope(Level::Jerk, &map).norm_along(&unit);
                assert!(jerk <= best.jerk * (1.0 + 1e-3), "A {a}° C {c}°: {jerk} > {}", best.jerk);
            }
        }
    }

    #[test]
    fn angles_fit_into_travels_at_the_turn_nearest_zero() {
        let deg = f64::to_radians;
        let limited = |a: f64, b: f64| Travel::Limited { min: deg(a), max: deg(b) };
        let close = |x: Option<f64>, y: f64| x.is_some_and(|x| (x - deg(y)).abs() < 1e-12);
        assert!(close(fit_travel(deg(350.0), Travel::Endless), -10.0));
        assert!(close(fit_travel(deg(-190.0), Travel::Endless), 170.0));
        assert_eq!(fit_travel(deg(200.0), limited(-120.0, 30.0)), None);
        assert!(close(fit_travel(deg(-100.0), limited(-120.0, 30.0)), -100.0));
        assert!(close(fit_travel(deg(300.0), limited(-120.0, 30.0)), -60.0));
        // A travel beyond one turn: the turn nearest zero.
        assert!(close(fit_travel(deg(10.0), limited(-360.0, 360.0)), 10.0));
        assert!(close(fit_travel(deg(-170.0), limited(100.0, 400.0)), 190.0));
        assert!(close(fit_travel(deg(30.0) + 1e-12, limited(-120.0, 30.0)), 30.0));
        assert_eq!(fit_travel(f64::NAN, Travel::Endless), None);
        assert_eq!(fit_travel(PI, Travel::Limited { min: f64::NAN, max: 1.0 }), None);
    }
}
