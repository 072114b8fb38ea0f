//! [`KinematicsAdapter`]: a plugin's compiled kinematics as a [`Kinematics`], checked.
//!
//! - `forward` and `inverse` call the plugin through the C ABI; `inverse` returns every
//!   branch the plugin returns. `inverse_holding` and `place` (the policy's singular holds and
//!   retracts) use the generic chain of the machine's YAML definition.
//! - That is sound only if both describe the same machine: [`KinematicsAdapter::verify`]
//!   compares them on sample axis values when the kinematics is loaded (the forward kinematics
//!   agree; the plugin's inverse returns every solution the chain finds).
//! - Every result is checked during use: finite numbers, the machine's number of axes, at most
//!   two solutions, and the forward kinematics of each solution back on the pose
//!   ([`TIP_TOLERANCE`], [`AXIS_TOLERANCE`]); no solution where the chain has one is an error.
//!
//! The [`Kinematics`] trait cannot fail, so an error met through it (a panic in the plugin, an
//! invalid solution) is kept: the adapter stops calling the plugin (`inverse` returns no
//! solution, `forward` the chain's pose, so the caller's solve ends quickly) and
//! [`KinematicsAdapter::take_error`] returns it. Callers check it after using the trait.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, Ordering};

use nalgebra::{Point3, Unit, Vector3};
use postpro_kin::{Chain, Joints, Kinematics, Pose, Solution, Solutions};
use postpro_machine::model::{AxisKind, Machine, Travel};
use postpro_plugin_api as api;

use crate::error::{CallFailure, PluginError};
use crate::ffi::{CallError, Instance};

/// The largest distance (mm) between the pose and the forward kinematics of a plugin's solution,
/// and between the plugin's and the definition's forward kinematics.
pub const TIP_TOLERANCE: f64 = 1e-6;

/// The largest angle (rad) between the tool axes in the same comparisons.
pub const AXIS_TOLERANCE: f64 = 1e-6;

/// How many sample axis vectors [`KinematicsAdapter::verify`] tries.
pub const SAMPLES: usize = 32;

/// Within this angle (rad) of a singularity the free axis is arbitrary: the samples there do not
/// compare solutions.
const NEAR_POLE: f64 = 1e-3;

/// A plugin's kinematics for one machine (and one tool length), checked against the machine's
/// definition. Holds the plugin instance, and through it the library (loaded as long as the
/// adapter lives).
pub struct KinematicsAdapter {
    chain: Chain,
    instance: Instance,
    library: PathBuf,
    error: Mutex<Option<PluginError>>,
    failed: AtomicBool,
}

impl std::fmt::Debug for KinematicsAdapter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("KinematicsAdapter")
            .field("machine", &self.chain.machine().name)
            .field("library", &self.library)
            .field("failed", &self.failed.load(Ordering::Relaxed))
            .finish()
    }
}

fn c_pose(pose: &Pose) -> api::Pose {
    let t = pose.tip;
    let a = pose.axis;
    api::Pose { tip: [t.x, t.y, t.z], axis: [a.x, a.y, a.z] }
}

/// `tip (1.000, 2.000, 3.000) mm, axis (0.000000, 0.000000, 1.000000)`
pub(crate) fn show_pose(pose: &Pose) -> String {
    let (t, a) = (pose.tip, pose.axis);
    format!("tip ({:.3}, {:.3}, {:.3}) mm, axis ({:.6}, {:.6}, {:.6})", t.x, t.y, t.z, a.x, a.y, a.z)
}

/// `X=1.000 Y=2.000 Z=3.000 B=12.0000° C=45.0000°`
pub(crate) fn show_joints(machine: &Machine, joints: &[f64]) -> String {
    let mut out = String::new();
    for (i, v) in joints.iter().enumerate() {
        if !out.is_empty() {
            out.push(' ');
        }
        match machine.axes.get(i) {
            Some(a) if a.kind == AxisKind::Rotary => {
                let _ = write!(out, "{}={:.4}°", a.letter, v.to_degrees());
            }
            Some(a) => {
                let _ = write!(out, "{}={v:.3}", a.letter);
            }
            None => {
                let _ = write!(out, "#{}={v}", i + 1);
            }
        }
    }
    out
}

/// An angle in (−π, π].
fn wrap(angle: f64) -> f64 {
    let t = std::f64::consts::TAU;
    let w = angle - t * (angle / t).round();
    if w <= -std::f64::consts::PI { w + t } else { w }
}

/// The angle between two unit vectors, accurate for small angles.
fn angle_between(a: &Vector3<f64>, b: &Vector3<f64>) -> f64 {
    a.cross(b).norm().atan2(a.dot(b))
}

/// Deterministic sample axis vectors within the travels (rotary axes within one turn).
pub(crate) fn samples(machine: &Machine, count: usize) -> Vec<Joints> {
    let mut state: u64 = 0x9e37_79b9_7f4a_7c15;
    let mut next = || {
        // SplitMix64.
        state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    };
    let pi = std::f64::consts::PI;
    (0..count)
        .map(|_| {
            let mut j = Joints::zeros(machine.axes.len());
            for (i, a) in machine.axes.iter().enumerate() {
                let (lo, hi) = match (a.travel, a.kind) {
                    (Travel::Limited { min, max }, AxisKind::Linear) => (min, max),
                    (Travel::Limited { min, max }, AxisKind::Rotary) if min.max(-pi) < max.min(pi) => {
                        (min.max(-pi), max.min(pi))
                    }
                    (Travel::Limited { min, max }, AxisKind::Rotary) => (min, max),
                    (Travel::Endless, _) => (-pi, pi),
                };
                j[i] = lo + (hi - lo) * next();
            }
            j
        })
        .collect()
}

impl KinematicsAdapter {
    /// The adapter over a live instance, for this machine (as the caller will use it: its tool
    /// length is the instance's).
    pub(crate) fn new(machine: Machine, instance: Instance, library: &Path) -> KinematicsAdapter {
        KinematicsAdapter {
            chain: Chain::new(machine),
            instance,
            library: library.to_path_buf(),
            error: Mutex::new(None),
            failed: AtomicBool::new(false),
        }
    }

    /// The plugin library.
    pub fn library(&self) -> &Path {
        &self.library
    }

    /// The generic chain of the machine's definition (the reference and the fallback).
    pub fn chain(&self) -> &Chain {
        &self.chain
    }

    /// The first error met through the [`Kinematics`] trait since the last call, if any; the
    /// adapter calls the plugin again afterwards.
    pub fn take_error(&self) -> Option<PluginError> {
        let e = self.error.lock().unwrap_or_else(std::sync::PoisonError::into_inner).take();
        self.failed.store(false, Ordering::SeqCst);
        e
    }

    /// True when an error was met through the [`Kinematics`] trait and not taken yet.
    pub fn has_failed(&self) -> bool {
        self.failed.load(Ordering::SeqCst)
    }

    fn fail(&self, e: PluginError) {
        let mut slot = self.error.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        if slot.is_none() {
            *slot = Some(e);
        }
        self.failed.store(true, Ordering::SeqCst);
    }

    fn machine_name(&self) -> String {
        self.chain.machine().name.clone()
    }

    fn call_error(&self, call: &'static str, e: CallError) -> PluginError {
        PluginError::Call {
            library: self.library.clone(),
            machine: self.machine_name(),
            call,
            failure: CallFailure::of(e.status),
            message: e.message,
        }
    }

    /// The plugin's forward kinematics, checked: finite numbers and a unit tool axis.
    pub fn try_forward(&self, joints: &Joints) -> Result<Pose, PluginError> {
        let p = self.instance.forward(joints.as_slice()).map_err(|e| self.call_error("forward", e))?;
        let invalid = |problem: String| PluginError::InvalidPose {
            library: self.library.clone(),
            machine: self.machine_name(),
            joints: show_joints(self.chain.machine(), joints.as_slice()),
            problem,
        };
        if !p.tip.iter().chain(&p.axis).all(|v| v.is_finite()) {
            return Err(invalid(format!("tip {:?}, axis {:?}", p.tip, p.axis)));
        }
        let axis = Vector3::from(p.axis);
        let norm = axis.norm();
        if (norm - 1.0).abs() > 1e-6 {
            return Err(invalid(format!("the tool axis {:?} has a length of {norm}, not 1", p.axis)));
        }
        Ok(Pose { tip: Point3::from(p.tip), axis: Unit::new_normalize(axis) })
    }

    /// The plugin's inverse kinematics, checked: every solution valid and back on the pose, and
    /// none only where the definition's chain has none either.
    pub fn try_inverse(&self, pose: &Pose, out: &mut Solutions) -> Result<(), PluginError> {
        out.clear();
        let mut raw = [api::Solution::EMPTY; api::MAX_SOLUTIONS];
        let count = self.instance.inverse(&c_pose(pose), &mut raw).map_err(|e| self.call_error("inverse", e))?;
        let invalid = |problem: String| PluginError::InvalidSolution {
            library: self.library.clone(),
            machine: self.machine_name(),
            pose: show_pose(pose),
            problem,
        };
        if count > 2 {
            return Err(invalid(format!(
                "{count} solutions, where postpro takes at most 2 (the two branches of a 5-axis machine)"
            )));
        }
        for (k, s) in raw[..count].iter().enumerate() {
            out.push(self.check_solution(pose, k + 1, s).map_err(invalid)?);
        }
        if count == 0 {
            let mut reference = Solutions::new();
            self.chain.inverse(pose, &mut reference);
            if let Some(r) = reference.iter().next() {
                return Err(PluginError::NoSolution {
                    library: self.library.clone(),
                    machine: self.machine_name(),
                    pose: show_pose(pose),
                    reached: show_joints(self.chain.machine(), r.joints.as_slice()),
                });
            }
        }
        Ok(())
    }

    /// One solution of the plugin as postpro's, or what is wrong with it.
    fn check_solution(&self, pose: &Pose, k: usize, s: &api::Solution) -> Result<Solution, String> {
        let machine = self.chain.machine();
        let Solution { joints, branch, pole } = check_values(machine, k, s)?;
        let back = self.try_forward(&joints).map_err(|e| format!("its forward kinematics fails: {e}"))?;
        let tip = (back.tip - pose.tip).norm();
        let axis = angle_between(&back.axis, &pose.axis);
        let shown = || show_joints(machine, joints.as_slice());
        if tip > TIP_TOLERANCE {
            return Err(format!("solution {k} ({}) puts the tool tip {tip:.6} mm from the pose", shown()));
        }
        if axis > AXIS_TOLERANCE {
            return Err(format!(
                "solution {k} ({}) turns the tool axis {:.6}° away from the pose",
                shown(),
                axis.to_degrees()
            ));
        }
        Ok(Solution { joints, branch, pole })
    }

    /// Compares the plugin with the definition's chain on [`SAMPLES`] axis vectors within the
    /// travels: the forward kinematics agree, and the plugin's inverse returns (checked) every
    /// solution the chain finds. Called when the kinematics is loaded.
    pub fn verify(&self) -> Result<(), PluginError> {
        let machine = self.chain.machine();
        let disagree = |detail: String| PluginError::Disagrees {
            library: self.library.clone(),
            machine: self.machine_name(),
            detail,
        };
        let samples = samples(machine, SAMPLES);
        for j in &samples {
            let expected = self.chain.forward(j);
            let got = self.try_forward(j)?;
            let tip = (got.tip - expected.tip).norm();
            let axis = angle_between(&got.axis, &expected.axis);
            if tip > TIP_TOLERANCE || axis > AXIS_TOLERANCE {
                return Err(disagree(format!(
                    "at {} the plugin's forward kinematics gives {}, the definition {} ({tip:.6} mm, {:.6}° apart)",
                    show_joints(machine, j.as_slice()),
                    show_pose(&got),
                    show_pose(&expected),
                    axis.to_degrees()
                )));
            }
        }
        let (mut mine, mut reference) = (Solutions::new(), Solutions::new());
        for j in &samples {
            let pose = self.chain.forward(j);
            self.try_inverse(&pose, &mut mine)?;
            self.chain.inverse(&pose, &mut reference);
            if reference.iter().any(|s| s.pole.is_some_and(|(_, d)| d < NEAR_POLE)) {
                continue;
            }
            for r in reference.iter() {
                if !mine.iter().any(|m| same(machine, &m.joints, &r.joints)) {
                    return Err(PluginError::MissingBranch {
                        library: self.library.clone(),
                        machine: self.machine_name(),
                        detail: format!(
                            "at {} the definition's chain finds {}, the plugin returns {}",
                            show_pose(&pose),
                            show_joints(machine, r.joints.as_slice()),
                            mine.iter()
                                .map(|m| show_joints(machine, m.joints.as_slice()))
                                .collect::<Vec<_>>()
                                .join("; ")
                        ),
                    });
                }
            }
        }
        Ok(())
    }
}

/// The values of one solution of the plugin (the `k`-th) as postpro's, rotary angles in
/// (−π, π], or what is wrong with them: their number, a value that is not finite, the branch,
/// the pole.
pub(crate) fn check_values(machine: &Machine, k: usize, s: &api::Solution) -> Result<Solution, String> {
    let n = machine.axes.len();
    if s.axis_count as usize != n {
        return Err(format!("solution {k} has {} axis values, the machine {n}", s.axis_count));
    }
    let mut joints = Joints::from_slice(&s.joints[..n]);
    if let Some(i) = joints.as_slice().iter().position(|v| !v.is_finite()) {
        return Err(format!("solution {k}: axis {} is {}", machine.axes[i].letter, joints[i]));
    }
    let branch = u8::try_from(s.branch).map_err(|_| format!("solution {k}: branch {} (expected 0 or 1)", s.branch))?;
    let pole = match s.pole_axis {
        api::NO_POLE => None,
        a => {
            let rotary = usize::try_from(a).ok().filter(|&i| i < n && machine.axes[i].kind == AxisKind::Rotary);
            let Some(axis) = rotary else {
                return Err(format!("solution {k}: pole axis {a} is not the index of a rotary axis"));
            };
            if !(s.pole_angle.is_finite() && (0.0..=std::f64::consts::PI).contains(&s.pole_angle)) {
                return Err(format!("solution {k}: pole angle {} (expected 0 to π)", s.pole_angle));
            }
            Some((axis, s.pole_angle))
        }
    };
    for (i, a) in machine.axes.iter().enumerate() {
        if a.kind == AxisKind::Rotary {
            joints[i] = wrap(joints[i]);
        }
    }
    Ok(Solution { joints, branch, pole })
}

/// The same axis values: linear within [`TIP_TOLERANCE`], rotary within [`AXIS_TOLERANCE`] turn
/// for turn.
fn same(machine: &Machine, a: &Joints, b: &Joints) -> bool {
    machine.axes.iter().enumerate().all(|(i, axis)| match axis.kind {
        AxisKind::Linear => (a[i] - b[i]).abs() <= TIP_TOLERANCE,
        AxisKind::Rotary => wrap(a[i] - b[i]).abs() <= AXIS_TOLERANCE,
    })
}

impl Kinematics for KinematicsAdapter {
    fn machine(&self) -> &Machine {
        self.chain.machine()
    }

    fn forward(&self, joints: &Joints) -> Pose {
        if !self.has_failed() {
            match self.try_forward(joints) {
                Ok(p) => return p,
                Err(e) => self.fail(e),
            }
        }
        self.chain.forward(joints)
    }

    fn inverse(&self, pose: &Pose, out: &mut Solutions) {
        if !self.has_failed() {
            match self.try_inverse(pose, out) {
                Ok(()) => return,
                Err(e) => self.fail(e),
            }
        }
        out.clear();
    }

    fn inverse_holding(&self, pose: &Pose, free_axis: usize, value: f64) -> Option<Joints> {
        self.chain.inverse_holding(pose, free_axis, value)
    }

    fn place(&self, pose: &Pose, rotaries: &Joints) -> Joints {
        self.chain.place(pose, rotaries)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wrapping_and_angles() {
        assert!((wrap(3.0 * std::f64::consts::PI) - std::f64::consts::PI).abs() < 1e-12);
        assert!((wrap(-0.5) + 0.5).abs() < 1e-15);
        let (x, y) = (Vector3::x(), Vector3::new(1.0, 1e-9, 0.0).normalize());
        assert!((angle_between(&x, &y) - 1e-9).abs() < 1e-18);
    }

    #[test]
    fn samples_stay_within_the_travels() {
        let registry = postpro_machine::Registry::builtin().expect("built-ins");
        for e in registry.entries() {
            let m = &e.machine;
            let s = samples(m, 50);
            assert_eq!(s.len(), 50);
            for j in &s {
                for (i, a) in m.axes.iter().enumerate() {
                    assert!(a.travel.contains(j[i]), "{} {}: {}", m.name, a.letter, j[i]);
                }
            }
            // Deterministic.
            assert_eq!(samples(m, 3), s[..3].to_vec());
        }
    }

    #[test]
    fn solution_values_are_checked() {
        let registry = postpro_machine::Registry::builtin().expect("built-ins");
        let m = &registry.find("mikron").expect("mikron").machine;
        let good = api::Solution::new(&[1.0, 2.0, 3.0, 0.5, 7.0], 1).with_pole(4, 0.25);
        let s = check_values(m, 1, &good).expect("valid");
        assert_eq!(s.branch, 1);
        assert_eq!(s.pole, Some((4, 0.25)));
        assert!((s.joints[4] - (7.0 - std::f64::consts::TAU)).abs() < 1e-12, "wrapped: {:?}", s.joints);
        let fails = |s: api::Solution| check_values(m, 2, &s).expect_err("invalid");
        assert_eq!(fails(api::Solution::new(&[0.0; 4], 0)), "solution 2 has 4 axis values, the machine 5");
        assert_eq!(fails(api::Solution::new(&[0.0, f64::NAN, 0.0, 0.0, 0.0], 0)), "solution 2: axis Y is NaN");
        assert_eq!(fails(api::Solution::new(&[0.0; 5], 300)), "solution 2: branch 300 (expected 0 or 1)");
        assert_eq!(
            fails(api::Solution::new(&[0.0; 5], 0).with_pole(1, 0.1)),
            "solution 2: pole axis 1 is not the index of a rotary axis"
        );
        assert_eq!(
            fails(api::Solution::new(&[0.0; 5], 0).with_pole(3, -1.0)),
            "solution 2: pole angle -1 (expected 0 to π)"
        );
    }

    #[test]
    fn shown_values_read_well() {
        let registry = postpro_machine::Registry::builtin().expect("built-ins");
        let m = &registry.find("mikron").expect("mikron").machine;
        let text = show_joints(m, &[1.0, 2.0, 3.0, std::f64::consts::FRAC_PI_2, 0.0]);
        assert_eq!(text, "X=1.000 Y=2.000 Z=3.000 A=90.0000° C=0.0000°");
        let pose = Pose { tip: Point3::new(1.0, 2.0, 3.0), axis: Vector3::z_axis() };
        assert_eq!(show_pose(&pose), "tip (1.000, 2.000, 3.000) mm, axis (0.000000, 0.000000, 1.000000)");
    }
}
