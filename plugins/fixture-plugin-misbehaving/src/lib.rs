//! Test fixture: a plugin whose machines misbehave, one way each, chosen by the machine (not by
//! the environment), so one library shows that each problem stays with its machine:
//!
//! | machine | kinematics |
//! |---|---|
//! | `fixture-good` | works (the next call after another machine's failure) |
//! | `fixture-panics` | `inverse` panics |
//! | `fixture-error` | `inverse` returns an error |
//! | `fixture-no-solution` | `inverse` returns no solution |
//! | `fixture-invalid-solution` | `inverse` returns solutions whose B is 0.1 rad off |
//! | `fixture-disagrees` | `forward` and `inverse` agree with each other, not with the definition (0.5 mm off in x) |
//! | `fixture-one-branch` | `inverse` returns one of the two branches |
//! | `fixture-broken` | its definition does not validate |
//! | `fixture-undefined` | kinematics without a definition |
//!
//! The machines are head-head 5-axis (C about +z carrying B about +y, both through the spindle
//! nose at the origin): `tip = L − tool_length · a`, `a = (sin B cos C, sin B sin C, cos B)`.

use postpro_plugin_api::{Error, KinematicsConfig, PluginKinematics, Pose, Solution, Solutions, export_plugin};

/// How a machine's kinematics behaves.
const GOOD: u8 = 0;
const PANICS: u8 = 1;
const ERROR: u8 = 2;
const NO_SOLUTION: u8 = 3;
const INVALID_SOLUTION: u8 = 4;
const DISAGREES: u8 = 5;
const UNDEFINED: u8 = 6;
const ONE_BRANCH: u8 = 7;

/// The machine of each behaviour.
const NAMES: [&str; 8] = [
    "fixture-good",
    "fixture-panics",
    "fixture-error",
    "fixture-no-solution",
    "fixture-invalid-solution",
    "fixture-disagrees",
    "fixture-undefined",
    "fixture-one-branch",
];

/// The kinematics of the machine with behaviour `KIND`.
#[derive(Debug)]
pub struct Fixture<const KIND: u8> {
    tool_length: f64,
}

fn axis(b: f64, c: f64) -> [f64; 3] {
    let (sb, cb) = b.sin_cos();
    let (sc, cc) = c.sin_cos();
    [sb * cc, sb * sc, cb]
}

impl<const KIND: u8> Fixture<KIND> {
    /// How far `forward` puts the tip from the definition's chain, in x.
    const SHIFT: f64 = if KIND == DISAGREES { 0.5 } else { 0.0 };

    fn solution(&self, pose: &Pose, b: f64, c: f64, branch: u32) -> Solution {
        let a = axis(b, c);
        let l = [
            pose.tip[0] + self.tool_length * a[0] - Self::SHIFT,
            pose.tip[1] + self.tool_length * a[1],
            pose.tip[2] + self.tool_length * a[2],
        ];
        let b = if KIND == INVALID_SOLUTION { b + 0.1 } else { b };
        Solution::new(&[l[0], l[1], l[2], b, c], branch)
    }
}

impl<const KIND: u8> PluginKinematics for Fixture<KIND> {
    const MACHINE: &'static str = NAMES[KIND as usize];
    const AXES: usize = 5;

    fn new(config: &KinematicsConfig) -> Result<Self, Error> {
        Ok(Fixture { tool_length: config.tool_length })
    }

    fn forward(&self, j: &[f64]) -> Result<Pose, Error> {
        let a = axis(j[3], j[4]);
        let tip = [
            j[0] - self.tool_length * a[0] + Self::SHIFT,
            j[1] - self.tool_length * a[1],
            j[2] - self.tool_length * a[2],
        ];
        Ok(Pose { tip, axis: a })
    }

    fn inverse(&self, pose: &Pose, out: &mut Solutions) -> Result<(), Error> {
        match KIND {
            PANICS => panic!("fixture-panics: a bug in the inverse kinematics"),
            ERROR => return Err(Error::new("fixture-error: the head is not referenced")),
            NO_SOLUTION => return Ok(()),
            _ => {}
        }
        let [i, j, k] = pose.axis;
        let tilt = k.clamp(-1.0, 1.0).acos();
        let pole = tilt.min(std::f64::consts::PI - tilt);
        if i.hypot(j) < 1e-12 {
            out.push(self.solution(pose, tilt, 0.0, 0).with_pole(4, pole));
        } else {
            out.push(self.solution(pose, tilt, j.atan2(i), 0).with_pole(4, pole));
            if KIND != ONE_BRANCH {
                out.push(self.solution(pose, -tilt, (-j).atan2(-i), 1).with_pole(4, pole));
            }
        }
        Ok(())
    }
}

export_plugin! {
    name: "fixture-plugin-misbehaving",
    machines: [
        "machines/fixture-good.yaml",
        "machines/fixture-panics.yaml",
        "machines/fixture-error.yaml",
        "machines/fixture-no-solution.yaml",
        "machines/fixture-invalid-solution.yaml",
        "machines/fixture-disagrees.yaml",
        "machines/fixture-one-branch.yaml",
        "machines/fixture-broken.yaml",
    ],
    kinematics: [
        Fixture<GOOD>,
        Fixture<PANICS>,
        Fixture<ERROR>,
        Fixture<NO_SOLUTION>,
        Fixture<INVALID_SOLUTION>,
        Fixture<DISAGREES>,
        Fixture<UNDEFINED>,
        Fixture<ONE_BRANCH>,
    ],
}
