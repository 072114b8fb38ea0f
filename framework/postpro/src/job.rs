//! What every command that needs the machine's motion shares: read the CL file (errors rendered
//! with their source), take the job's set-up (the part's place on the table, the tools with their
//! lengths), solve it on the chosen machine with the command line's IKT options (each tool's
//! stretch with its own length; a plugin's failure reported first: it is why the solve went
//! wrong), and build its motion program in the work offset's frame, checked against the travels.

use std::path::Path;
use std::process::ExitCode;

use postpro_cl::{Source, ToolPath};
use postpro_emit::{Dialect, Mode};
use postpro_kin::{Kinematics, Solved, solve_with_tools};
use postpro_machine::model::{Machine, Travel};
use postpro_motion::Tooling;
use postpro_plugins::Solver;

use crate::report;
use crate::setup::{JobSetup, SetupArgs};
use crate::solve::{Chosen, IktArgs};

/// A CL file read and solved.
pub(crate) struct Job {
    /// The CL file.
    pub(crate) source: Source,
    /// Its tool path.
    pub(crate) path: ToolPath,
    /// The machine with the command line's overrides and the part placed.
    pub(crate) machine: Machine,
    /// Its kinematics.
    pub(crate) solver: Solver,
    /// The solved tool path.
    pub(crate) solved: Solved,
    /// The set-up in effect.
    pub(crate) setup: JobSetup,
    /// The tools and their changes.
    pub(crate) tooling: Tooling,
    /// The tool length each tool was solved with (mm).
    pub(crate) kinematic_lengths: Vec<f64>,
    /// The mode the job was solved for.
    pub(crate) mode: Mode,
}

/// Prints `message` and gives the exit code.
pub(crate) fn fail(message: &str, code: u8) -> ExitCode {
    eprint!("{message}");
    ExitCode::from(code)
}

/// Prints warnings about a CL file on standard error, `file:line:column` first.
pub(crate) fn warn_all<'w>(source: &Source, warnings: impl IntoIterator<Item = &'w postpro_motion::Warning>) {
    for w in warnings {
        eprintln!("warning: {}: {}", source.location(w.span.start as usize), w.message);
    }
}

/// Reads `file` and solves it on `chosen` with `ikt` and `setup`, for `mode`. `stage` is told
/// what is being done; `nothing` ends the message when the file does not read ("nothing
/// written").
#[allow(clippy::too_many_arguments)]
pub(crate) fn prepare(
    file: &Path,
    chosen: &Chosen,
    ikt: &IktArgs,
    setup: &SetupArgs,
    mode: Mode,
    nothing: &str,
    stage: &dyn Fn(&str),
) -> Result<Job, ExitCode> {
    let mut machine = chosen.machine.clone();
    if let Err(message) = ikt.apply(&mut machine) {
        return Err(fail(&format!("error: {message}\n"), 2));
    }
    let job_setup = setup.load().map_err(|message| fail(&format!("{message}error: {nothing}\n"), 1))?;
    if let Some(offset) = job_setup.part_origin
        && !postpro_motion::frame::place_part(&mut machine, offset)
    {
        eprintln!(
            "warning: {} carries no part on a rotary axis: the part origin of the set-up has no effect (the program \
             is written from the part zero)",
            machine.name
        );
    }
    let source = Source::from_path(file).map_err(|e| fail(&format!("error: {e}\n"), 1))?;
    stage("reading");
    let path = postpro_cl::read_with(&source, &setup.read.options());
    if path.has_errors() {
        stage("");
        for d in path.diagnostics.iter().filter(|d| d.is_error()) {
            eprint!("{}", d.render(&source));
        }
        return Err(fail(&format!("error: {} does not read; {nothing}\n", source.name()), 1));
    }
    // Linear travels are checked on the program, in the work offset's frame, once it is built:
    // the kinematics' machine coordinates are those of the definition's assumed part zero.
    let mut solve_machine = machine.clone();
    for a in &mut solve_machine.axes {
        if a.kind == postpro_machine::model::AxisKind::Linear {
            a.travel = Travel::Endless;
        }
    }
    let solver = chosen.solver(&solve_machine)?;
    let render = |e: postpro_motion::MotionError| report::render_with_source(e, source.name(), source.text());
    // The tools with the lengths they are solved with (the work offset is the dialect's
    // business: it is chosen when the program is written).
    let (tools, tool_warnings) = postpro_motion::Job::new(
        solver.kinematics(),
        &path,
        mode,
        job_setup.tool_table.as_ref(),
        job_setup.work_offset.unwrap_or_default(),
    )
    .map_err(|e| fail(&format!("{}error: {nothing}\n", render(e)), 1))?;
    warn_all(&source, &tool_warnings);
    stage("solving the kinematics");
    let solved = solve_with_tools(solver.kinematics(), &path, &solve_machine.policy, &tools.lengths());
    if let Some(e) = solver.take_error() {
        stage("");
        return Err(fail(&report::render(&e), 1));
    }
    let solved = solved.map_err(|e| {
        stage("");
        fail(&report::render_with_source(e, source.name(), source.text()), 1)
    })?;
    Ok(Job {
        source,
        path,
        machine,
        solver,
        solved,
        setup: job_setup,
        tooling: tools.tooling,
        kinematic_lengths: tools.kinematic_lengths,
        mode,
    })
}

impl Job {
    /// The motion program of this job for `dialect` (arcs and canned cycles as the controller's
    /// unless `how` says otherwise), checked against the travels; an error is printed with the CL
    /// source, warnings are printed.
    pub(crate) fn motion(&self, dialect: &Dialect, how: Shapes) -> Result<postpro_motion::Program, ExitCode> {
        let kin = self.solver.kinematics();
        let job = postpro_motion::Job {
            frame: postpro_motion::work_frame(kin, self.mode),
            work_offset: self.setup.work_offset.unwrap_or_else(|| dialect.default_work_offset()),
            tooling: self.tooling.clone(),
            kinematic_lengths: self.kinematic_lengths.clone(),
            length_compensation: self.machine.chain.tool.is_empty() || self.mode == Mode::Tcp,
        };
        let mut options = postpro_emit::motion_options(dialect, self.mode, !how.linear_arcs);
        options.cycles = !how.expand_cycles;
        let render =
            |e: postpro_motion::MotionError| report::render_with_source(e, self.source.name(), self.source.text());
        let program =
            postpro_motion::collect(&self.path, &self.solved, kin, &options, &job).map_err(|e| fail(&render(e), 1))?;
        let travel = postpro_motion::travel::check(&program, &self.machine, self.setup.work_offset_at.as_ref())
            .map_err(|e| fail(&render(e), 1))?;
        warn_all(&self.source, program.summary.warnings.iter().chain(&travel));
        Ok(program)
    }
}

/// The motion program of another solved tool path of the same machine (a re-oriented program),
/// for `dialect`, with its tools as the CL file loads them.
pub(crate) fn motion_of(
    path: &ToolPath,
    solved: &Solved,
    kin: &dyn Kinematics,
    mode: Mode,
    dialect: &Dialect,
) -> Result<postpro_motion::Program, postpro_motion::MotionError> {
    let (job, _) = postpro_motion::Job::new(kin, path, mode, None, dialect.default_work_offset())?;
    postpro_motion::collect(path, solved, kin, &postpro_emit::motion_options(dialect, mode, true), &job)
}

/// How arcs and canned cycles are written.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct Shapes {
    /// Every arc as straight moves (`--arcs linear`).
    pub(crate) linear_arcs: bool,
    /// Every canned cycle as moves (`--cycles expand`).
    pub(crate) expand_cycles: bool,
}

/// The dialect of a machine, or the first one postpro knows when the machine names none it
/// knows (its feed ranges are only needed for the prediction's motion program).
pub(crate) fn machine_dialect(machine: &Machine) -> &'static Dialect {
    postpro_emit::dialect(&machine.dialect).unwrap_or(&postpro_emit::DIALECTS[0])
}
