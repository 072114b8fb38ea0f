//! # plugin-head-head: an example postpro plugin with its own kinematics
//!
//! A gantry 5-axis machine with a **fork head**: C turns the head about the vertical, B tilts
//! the fork about +y (`machines/fork-head-bc.yaml`). The plugin ships that definition, a
//! closed-form inverse kinematics ([`ForkHead`]) and a Heidenhain template for the machine.
//!
//! Build it with `cargo build -p plugin-head-head`; the library lands in `target/debug`
//! (`libplugin_head_head.so` on Linux) and is loaded with
//! `postpro machines --plugin target/debug/libplugin_head_head.so`.
//!
//! ## The closed form
//!
//! With the tool axis `a = (i, j, k)` in the part frame (whose axes are parallel to the base
//! frame's), C carrying B gives `a = Rz(C) Ry(B) ẑ = (sin B cos C, sin B sin C, cos B)`, so
//! `B = ±acos k` and `C = atan2(±j, ±i)`: two branches, one per sign of B, that meet at the
//! pole `k = ±1` where C is free. The tool tip hangs `d` below the pivot `P` along `−a`
//! (`d` = pivot to nose + tool length), and `P` stays on the C axis whatever C is, so
//! `tip = L + P − d·a` and the linear axes are `L = tip − P + d·a`: no iteration anywhere.

use std::f64::consts::PI;

use postpro_plugin_api::{Error, KinematicsConfig, PluginKinematics, Pose, Solution, Solutions, export_plugin};

/// The height of the B axis line (the pivot) at all-zero, mm (`axes[3].center`).
const PIVOT_Z: f64 = 320.0;
/// The height of the spindle nose at all-zero, mm (`chain.spindle.nose`).
const NOSE_Z: f64 = 150.0;
/// The part zero in the base frame, mm (`chain.part_origin.position`; axes parallel).
const PART_ORIGIN: [f64; 3] = [0.0, 0.0, -600.0];

/// The axis indices, in the order of the definition's `axes`.
const X: usize = 0;
const Y: usize = 1;
const Z: usize = 2;
const B: usize = 3;
const C: usize = 4;

/// Below this the tool axis is along the C axis: the pole, where C is free.
const POLE: f64 = 1e-12;

/// The fork head's kinematics for one tool length.
#[derive(Clone, Copy, Debug)]
pub struct ForkHead {
    /// From the pivot to the tool tip, mm.
    pivot_to_tip: f64,
}

/// The tool axis for B and C (rad): `Rz(C) Ry(B) ẑ`.
fn tool_axis(b: f64, c: f64) -> [f64; 3] {
    let (sb, cb) = b.sin_cos();
    let (sc, cc) = c.sin_cos();
    [sb * cc, sb * sc, cb]
}

impl ForkHead {
    /// The solution with these rotary angles: the linear axes put the tip on the pose.
    fn solution(&self, pose: &Pose, b: f64, c: f64, branch: u32) -> Solution {
        let a = tool_axis(b, c);
        let d = self.pivot_to_tip;
        let l = [
            pose.tip[0] + PART_ORIGIN[0] + d * a[0],
            pose.tip[1] + PART_ORIGIN[1] + d * a[1],
            pose.tip[2] + PART_ORIGIN[2] - PIVOT_Z + d * a[2],
        ];
        let mut joints = [0.0; 5];
        joints[X] = l[0];
        joints[Y] = l[1];
        joints[Z] = l[2];
        joints[B] = b;
        joints[C] = c;
        Solution::new(&joints, branch)
    }
}

impl PluginKinematics for ForkHead {
    const MACHINE: &'static str = "fork-head-bc";
    const AXES: usize = 5;

    fn new(config: &KinematicsConfig) -> Result<Self, Error> {
        Ok(ForkHead { pivot_to_tip: PIVOT_Z - NOSE_Z + config.tool_length })
    }

    fn forward(&self, joints: &[f64]) -> Result<Pose, Error> {
        let a = tool_axis(joints[B], joints[C]);
        let d = self.pivot_to_tip;
        let tip = [
            joints[X] - d * a[0] - PART_ORIGIN[0],
            joints[Y] - d * a[1] - PART_ORIGIN[1],
            joints[Z] + PIVOT_Z - d * a[2] - PART_ORIGIN[2],
        ];
        Ok(Pose { tip, axis: a })
    }

    fn inverse(&self, pose: &Pose, out: &mut Solutions) -> Result<(), Error> {
        let [i, j, k] = pose.axis;
        let norm = (i * i + j * j + k * k).sqrt();
        if !(norm.is_finite() && norm > 0.5) {
            return Err(Error::new(format!("the tool axis {:?} is not a unit vector", pose.axis)));
        }
        let (i, j, k) = (i / norm, j / norm, k / norm);
        let tilt = k.clamp(-1.0, 1.0).acos();
        // The angle between the tool axis and the C axis line: how far the pole is.
        let pole = tilt.min(PI - tilt);
        if i.hypot(j) <= POLE {
            out.push(self.solution(pose, tilt, 0.0, 0).with_pole(C, pole));
            return Ok(());
        }
        out.push(self.solution(pose, tilt, j.atan2(i), 0).with_pole(C, pole));
        out.push(self.solution(pose, -tilt, (-j).atan2(-i), 1).with_pole(C, pole));
        Ok(())
    }
}

export_plugin! {
    name: "plugin-head-head",
    machines: ["machines/fork-head-bc.yaml"],
    kinematics: [ForkHead],
    templates: ["fork-head-bc" => "templates/fork-head-bc.j2"],
}

#[cfg(test)]
#[allow(clippy::unwrap_used)] // a failed unwrap is a failed test
mod tests {
    use super::*;

    fn head() -> ForkHead {
        ForkHead::new(&KinematicsConfig { tool_length: 100.0 }).unwrap()
    }

    #[test]
    fn every_branch_returns_to_the_pose() {
        let head = head();
        for n in 0..200 {
            let t = f64::from(n) * 0.731;
            let axis = {
                let v = [t.sin() * 0.8, (1.7 * t).cos() * 0.7, (0.3 * t).cos()];
                let len = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
                [v[0] / len, v[1] / len, v[2] / len]
            };
            let pose = Pose { tip: [40.0 * t.cos(), -25.0 + t, 3.0 * t.sin()], axis };
            let mut out = Solutions::new();
            head.inverse(&pose, &mut out).unwrap();
            assert_eq!(out.len(), 2);
            for s in out.as_slice() {
                let back = head.forward(s.joints()).unwrap();
                for a in 0..3 {
                    assert!((back.tip[a] - pose.tip[a]).abs() < 1e-9, "{back:?} {pose:?}");
                    assert!((back.axis[a] - pose.axis[a]).abs() < 1e-12, "{back:?} {pose:?}");
                }
            }
        }
    }

    #[test]
    fn the_pole_has_one_solution_with_c_free() {
        let mut out = Solutions::new();
        head().inverse(&Pose { tip: [1.0, 2.0, 3.0], axis: [0.0, 0.0, 1.0] }, &mut out).unwrap();
        assert_eq!(out.len(), 1);
        let s = out.as_slice()[0];
        assert_eq!(s.pole(), Some((C, 0.0)));
        // At all-zero rotaries the tip sits d = 270 mm below the pivot, 600 mm above the part zero.
        assert_eq!(s.joints(), &[1.0, 2.0, 3.0 - 600.0 - 320.0 + 270.0, 0.0, 0.0]);
    }
}
