//! The first two stages every command that needs the machine's motion shares: read the CL file
//! (errors rendered with their source), and solve it on the chosen machine with the command
//! line's IKT options (a plugin's failure reported first: it is why the solve went wrong).

use std::path::Path;
use std::process::ExitCode;

use postpro_cl::{Source, ToolPath};
use postpro_emit::{Dialect, Mode};
use postpro_kin::{Kinematics, Solved, solve};
use postpro_machine::model::Machine;
use postpro_plugins::Solver;

use crate::report;
use crate::solve::{Chosen, IktArgs};

/// A CL file read and solved.
pub(crate) struct Job {
    /// The CL file.
    pub(crate) source: Source,
    /// Its tool path.
    pub(crate) path: ToolPath,
    /// The machine with the command line's overrides.
    pub(crate) machine: Machine,
    /// Its kinematics.
    pub(crate) solver: Solver,
    /// The solved tool path.
    pub(crate) solved: Solved,
}

/// Prints `message` and gives the exit code.
pub(crate) fn fail(message: &str, code: u8) -> ExitCode {
    eprint!("{message}");
    ExitCode::from(code)
}

/// Reads `file` and solves it on `chosen` with `ikt`. `stage` is told what is being done;
/// `nothing` ends the message when the file does not read ("nothing written").
pub(crate) fn prepare(
    file: &Path,
    chosen: &Chosen,
    ikt: &IktArgs,
    nothing: &str,
    stage: &dyn Fn(&str),
) -> Result<Job, ExitCode> {
    let mut machine = chosen.machine.clone();
    if let Err(message) = ikt.apply(&mut machine) {
        return Err(fail(&format!("error: {message}\n"), 2));
    }
    let source = Source::from_path(file).map_err(|e| fail(&format!("error: {e}\n"), 1))?;
    stage("reading");
    let path = postpro_cl::read(&source);
    if path.has_errors() {
        stage("");
        for d in path.diagnostics.iter().filter(|d| d.is_error()) {
            eprint!("{}", d.render(&source));
        }
        return Err(fail(&format!("error: {} does not read; {nothing}\n", source.name()), 1));
    }
    stage("solving the kinematics");
    let solver = chosen.solver(&machine)?;
    let solved = solve(solver.kinematics(), &path, &machine.policy);
    if let Some(e) = solver.take_error() {
        stage("");
        return Err(fail(&report::render(&e), 1));
    }
    let solved = solved.map_err(|e| {
        stage("");
        fail(&report::render_with_source(e, source.name(), source.text()), 1)
    })?;
    Ok(Job { source, path, machine, solver, solved })
}

impl Job {
    /// The motion program of this job in `mode`, for `dialect`'s feed ranges; an error is
    /// printed with the CL source.
    pub(crate) fn motion(&self, mode: Mode, dialect: &Dialect) -> Result<postpro_motion::Program, ExitCode> {
        motion_of(&self.path, &self.solved, self.solver.kinematics(), mode, dialect)
            .map_err(|e| fail(&report::render_with_source(e, self.source.name(), self.source.text()), 1))
    }
}

/// The motion program of a solved tool path in `mode`, for `dialect`'s feed ranges.
pub(crate) fn motion_of(
    path: &ToolPath,
    solved: &Solved,
    kin: &dyn Kinematics,
    mode: Mode,
    dialect: &Dialect,
) -> Result<postpro_motion::Program, postpro_motion::MotionError> {
    postpro_motion::collect(path, solved, kin, &postpro_emit::motion_options(dialect, mode))
}

/// The dialect of a machine, or the first one postpro knows when the machine names none it
/// knows (its feed ranges are only needed for the prediction's motion program).
pub(crate) fn machine_dialect(machine: &Machine) -> &'static Dialect {
    postpro_emit::dialect(&machine.dialect).unwrap_or(&postpro_emit::DIALECTS[0])
}
