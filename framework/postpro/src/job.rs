//! What every command that needs the machine's motion shares: read the CL file (errors rendered
//! with their source), take the job's set-up (the part's place on the table, the tools with their
//! lengths), solve it on the chosen machine with the command line's IKT options (each tool's
//! stretch with its own length; a plugin's failure reported first: it is why the solve went
//! wrong), and build its motion program in the work offset's frame, checked against the travels.

use std::path::Path;
use std::process::ExitCode;

use postpro_cl::{Locate, Source, ToolPath};
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
    /// Every warning is an error (`--strict`).
    pub(crate) strict: bool,
}

/// The end of the main job's error messages: its `nothing` argument of [`prepare`].
pub(crate) const WRITTEN: &str = "nothing written";

/// Prints `message` and gives the exit code.
pub(crate) fn fail(message: &str, code: u8) -> ExitCode {
    eprint!("{message}");
    ExitCode::from(code)
}

/// Prints warnings about a CL file on standard error, `file:line:column` first (as errors with
/// `strict`); returns how many.
pub(crate) fn warn_all<'w>(
    source: &dyn Locate,
    warnings: impl IntoIterator<Item = &'w postpro_motion::Warning>,
    strict: bool,
) -> usize {
    let what = if strict { "error" } else { "warning" };
    let mut count = 0;
    for w in warnings {
        eprintln!("{what}: {}: {}", source.location(w.span.start as usize), w.message);
        count += 1;
    }
    count
}

/// How many of a CL file's diagnostics are printed in full (one line each); the rest are
/// counted.
const PRINTED_WARNINGS: usize = 20;

/// Says on standard error what the reader warned about and what it did not interpret (each word
/// with its count, as `check` does), with `notes` also what it passed over; returns the number
/// of warnings.
pub(crate) fn report_reading(
    source: &dyn Locate,
    (info, diagnostics): (&postpro_cl::ProgramInfo, &[postpro_cl::Diagnostic]),
    strict: bool,
    notes: bool,
) -> usize {
    let what = if strict { "error" } else { "warning" };
    let warnings: Vec<_> = diagnostics.iter().filter(|d| !d.is_error()).collect();
    for d in warnings.iter().take(PRINTED_WARNINGS) {
        eprintln!("{what}: {}: {}", source.location(d.span.start as usize), d.message);
    }
    if warnings.len() > PRINTED_WARNINGS {
        eprintln!(
            "{what}: … and {} more (`postpro check {}` lists them all)",
            warnings.len() - PRINTED_WARNINGS,
            source.name()
        );
    }
    let words = |unknown: bool| -> Vec<String> {
        info.uninterpreted
            .iter()
            .filter(|(_, u)| u.unknown == unknown)
            .map(|(w, u)| format!("{w} ×{} (first at {})", u.count, source.location(u.first.start as usize)))
            .collect()
    };
    let (unknown, passive) = (words(true), words(false));
    if !unknown.is_empty() {
        eprintln!("{what}: words not interpreted (written as comments): {}", unknown.join(", "));
    }
    if notes && !passive.is_empty() {
        eprintln!("note: known words without effect on the path, passed over: {}", passive.join(", "));
    }
    if notes && let Some(from) = info.start_points {
        eprintln!(
            "note: FROM before any tool change or move, read as the tool's start point, not a move: ×{} (first at {})",
            from.count,
            source.location(from.first.start as usize)
        );
    }
    if notes && info.listing_lines > 0 {
        eprintln!("note: {} lines of the file are not APT (a listing's header and footer)", info.listing_lines);
    }
    warnings.len() + usize::from(!unknown.is_empty())
}

/// The machine of `chosen` with the policy options of `ikt`, its part placed as the set-up says,
/// and the set-up; `nothing` ends the message when the set-up does not load.
pub(crate) fn machine_and_setup(
    chosen: &Chosen,
    ikt: &IktArgs,
    setup: &SetupArgs,
    nothing: &str,
) -> Result<(Machine, JobSetup), ExitCode> {
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
    Ok((machine, job_setup))
}

/// What the main job says once the program is written: the INSERT texts it wrote as comments
/// (`inserts`: how many, and where the first is), and, unless the program went to standard
/// output, where it went with its counts (`counts`: CL points, points added by linearization,
/// IKT decisions; TCP mode writes no added point) and the predicted time.
pub(crate) fn said_written(
    output: &Path,
    machine: &str,
    (inserts, first_insert): (usize, Option<String>),
    (cl_points, linearized, decisions): (usize, usize, usize),
    tcp: bool,
    predicted_time: Option<(f64, f64, usize)>,
) {
    if let Some(first) = first_insert {
        eprintln!(
            "note: {inserts} INSERT text(s) written as comments (first at {first}); `--insert verbatim` passes them to \
             the controller as blocks"
        );
    }
    if output == Path::new("-") {
        return;
    }
    let unwritten = if tcp && linearized > 0 { " (not written: TCP keeps the tip on the path)" } else { "" };
    eprintln!(
        "wrote {} for {machine} ({cl_points} CL points, {linearized} added by linearization{unwritten}, {decisions} IKT \
         decisions)",
        output.display()
    );
    if let Some((cycle, lost, slowdowns)) = predicted_time {
        eprintln!("predicted cycle time {cycle:.1} s, {lost:.1} s lost to slowdowns, {slowdowns} slowdowns marked");
    }
}

/// The error message for a CL file without motion (`apt_source`: it is an APT part program).
pub(crate) fn no_motion(name: &str, apt_source: bool, nothing: &str) -> String {
    let why = if apt_source {
        "it is an APT part program (source language: geometry and motion statements for an APT processor), \
         not CL data; run it through an APT processor first"
    } else {
        "it has no GOTO, arc or NURBS"
    };
    format!("error: {name} has no motion: {why}; {nothing}\n")
}

/// The machine the kinematics are solved on: its linear travels are checked on the program, in
/// the work offset's frame, once it is built (the kinematics' machine coordinates are those of
/// the definition's assumed part zero), so they are endless here.
pub(crate) fn solving_machine(machine: &Machine) -> Machine {
    let mut solving = machine.clone();
    for a in &mut solving.axes {
        if a.kind == postpro_machine::model::AxisKind::Linear {
            a.travel = Travel::Endless;
        }
    }
    solving
}

/// Reads `file` and solves it on `chosen` with `ikt` and `setup`, for the mode asked for in
/// the dialect (`auto` decided on the tool path); `nothing` ends the message when the file does
/// not read ("nothing solved"). The whole-path commands' job; the main job is `stream`'s.
pub(crate) fn prepare(
    file: &Path,
    chosen: &Chosen,
    ikt: &IktArgs,
    setup: &SetupArgs,
    (mode, dialect): (crate::emit::ModeArg, &Dialect),
    nothing: &str,
) -> Result<Job, ExitCode> {
    let (machine, job_setup) = machine_and_setup(chosen, ikt, setup, nothing)?;
    let source = Source::from_path(file).map_err(|e| fail(&format!("error: {e}\n"), 1))?;
    let path = postpro_cl::read_with(&source, &setup.read.options());
    if path.has_errors() {
        for d in path.diagnostics.iter().filter(|d| d.is_error()) {
            eprint!("{}", d.render(&source));
        }
        return Err(fail(&format!("error: {} does not read; {nothing}\n", source.name()), 1));
    }
    // Only what may matter: what is passed over is the main job's to say.
    let mut warnings = report_reading(&source, (&path.info, &path.diagnostics), setup.strict, false);
    let moves = path.items.iter().any(|i| {
        matches!(i.kind, postpro_cl::ItemKind::Move(_) | postpro_cl::ItemKind::Arc(_) | postpro_cl::ItemKind::Nurbs(_))
    });
    if !moves {
        return Err(fail(&no_motion(source.name(), path.info.apt_source, nothing), 1));
    }
    let mode = mode.resolve(&path, &machine, dialect);
    let solve_machine = solving_machine(&machine);
    let solver = chosen.solver(&solve_machine)?;
    let render = |e: postpro_motion::MotionError| report::render_with_source(e, &source);
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
    warnings += warn_all(&source, &tool_warnings, setup.strict);
    if setup.strict && warnings > 0 {
        return Err(fail(&format!("error: {warnings} warning(s), and --strict makes them errors; {nothing}\n"), 1));
    }
    let solved = solve_with_tools(solver.kinematics(), &path, &solve_machine.policy, &tools.lengths());
    if let Some(e) = solver.take_error() {
        return Err(fail(&report::render(&e), 1));
    }
    let solved = solved.map_err(|e| fail(&report::render_with_source(e, &source), 1))?;
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
        strict: setup.strict,
    })
}

impl Job {
    /// The motion program of this job for `dialect` (arcs, canned cycles and 3+2 set-ups as the
    /// controller's unless `how` says otherwise), checked against the travels; an error is printed
    /// with the CL source, warnings are printed.
    pub(crate) fn motion(&self, dialect: &Dialect, how: Shapes) -> Result<postpro_motion::Program, ExitCode> {
        let kin = self.solver.kinematics();
        let planes = if how.planes { self.planes(dialect) } else { None };
        let job = postpro_motion::Job {
            frame: if planes.is_some() {
                postpro_motion::part_zero_frame(kin)
            } else {
                postpro_motion::work_frame(kin, self.mode)
            },
            work_offset: self.setup.work_offset.unwrap_or_else(|| dialect.default_work_offset()),
            tooling: self.tooling.clone(),
            kinematic_lengths: self.kinematic_lengths.clone(),
            length_compensation: self.machine.chain.tool.is_empty() || self.mode == Mode::Tcp,
        };
        let mut options = postpro_emit::motion_options(dialect, self.mode, !how.linear_arcs);
        options.cycles = !how.expand_cycles;
        options.planes = planes;
        let render = |e: postpro_motion::MotionError| report::render_with_source(e, &self.source);
        let program =
            postpro_motion::collect(&self.path, &self.solved, kin, &options, &job).map_err(|e| fail(&render(e), 1))?;
        let travel = postpro_motion::travel::check(
            &program,
            &self.machine,
            self.setup.work_offset_at.as_ref(),
            self.path.info.units,
        )
        .map_err(|e| fail(&render(e), 1))?;
        let warnings = warn_all(&self.source, program.summary.warnings.iter().chain(&travel), self.strict);
        if self.strict && warnings > 0 {
            return Err(fail(&format!("error: {warnings} warning(s), and --strict makes them errors\n"), 1));
        }
        Ok(program)
    }
}

impl Job {
    /// The working planes the program's 3+2 set-ups are written in (see [`planes_for`]).
    fn planes(&self, dialect: &Dialect) -> Option<postpro_motion::PlaneKind> {
        let survey = postpro_motion::Survey::of(self.solver.kinematics(), &self.solved.steps);
        planes_for(&self.machine, self.mode, dialect, &survey)
    }
}

/// The working planes the 3+2 set-ups of a program whose steps `survey` describes are written
/// in, in `dialect` on `machine`: its own, where it has them, the mode writes axis values (`g1`,
/// `inverse-time`), the machine's rotary axes carry the part and no feed move turns them. Where
/// the program has tilted set-ups and no plane can be used, a note says why.
pub(crate) fn planes_for(
    machine: &Machine,
    mode: Mode,
    dialect: &Dialect,
    survey: &postpro_motion::Survey,
) -> Option<postpro_motion::PlaneKind> {
    match plane_kind(machine, mode, dialect) {
        // Simultaneous motion: there is no set-up to speak of.
        Some(Ok(_)) if survey.simultaneous => None,
        Some(Ok(kind)) => Some(kind),
        Some(Err(why)) => {
            if survey.tilted && mode != Mode::Tcp {
                eprintln!("note: the 3+2 set-ups are written as axis values, not in working planes: {why}");
            }
            None
        }
        None => None,
    }
}

/// The working planes a program's 3+2 set-ups can stand in, in `dialect` on `machine` in `mode`
/// (whatever its steps): `Err` says why none can, `None` when the machine has no rotary axis
/// carrying the part.
pub(crate) fn plane_kind(
    machine: &Machine,
    mode: Mode,
    dialect: &Dialect,
) -> Option<Result<postpro_motion::PlaneKind, String>> {
    let chain = &machine.chain;
    let why = if dialect.planes.is_none() {
        format!("the {} dialect has no working planes", dialect.name)
    } else if !matches!(mode, Mode::G1 | Mode::InverseTime) {
        format!("{} mode writes no working planes", mode.name())
    } else if !chain.tool.is_empty() {
        format!("working planes are written for machines whose rotary axes carry the part, not {}", machine.name)
    } else {
        return dialect.planes.filter(|_| !chain.part.is_empty()).map(Ok);
    };
    Some(Err(why))
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
    /// 3+2 set-ups in the controller's working planes where it can (`--plane-mode cycle`).
    pub(crate) planes: bool,
}

/// The dialect of a machine, or the first one postpro knows when the machine names none it
/// knows (its feed ranges are only needed for the prediction's motion program).
pub(crate) fn machine_dialect(machine: &Machine) -> &'static Dialect {
    postpro_emit::dialect(&machine.dialect).unwrap_or(&postpro_emit::DIALECTS[0])
}
