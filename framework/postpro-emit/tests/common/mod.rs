//! What the emitter's tests share: the motion program of a solved tool path for a dialect, as
//! the command line builds it.

use postpro_cl::ToolPath;
use postpro_emit::{Dialect, Mode, motion_options};
use postpro_kin::{Kinematics, Solved};

/// The motion program of `solved` in `mode` for `dialect`, with no set-up of its own (the work
/// frame of the mode, the dialect's default work offset, the CL file's tools), arcs native.
pub(crate) fn motion(
    path: &ToolPath,
    solved: &Solved,
    kin: &dyn Kinematics,
    d: &Dialect,
    mode: Mode,
) -> postpro_motion::Program {
    let (job, _) = postpro_motion::Job::new(kin, path, mode, None, d.default_work_offset()).expect("the tools");
    postpro_motion::collect(path, solved, kin, &motion_options(d, mode, true), &job).expect("the motion program builds")
}
