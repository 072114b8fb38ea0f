//! What the emitter's tests share: the motion program of a solved tool path for a dialect, as
//! the command line builds it.

use postpro_cl::ToolPath;
use postpro_emit::{Dialect, Mode, motion_options};
use postpro_kin::{Kinematics, Solved};

/// The motion program of `solved` in `mode` with `dialect`'s feed ranges.
pub(crate) fn motion(
    path: &ToolPath,
    solved: &Solved,
    kin: &dyn Kinematics,
    d: &Dialect,
    mode: Mode,
) -> postpro_motion::Program {
    postpro_motion::collect(path, solved, kin, &motion_options(d, mode)).expect("the motion program builds")
}
