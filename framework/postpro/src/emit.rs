//! The main job: `postpro --machine NAME FILE.cl [-o OUT]` reads the CL file, solves the
//! inverse kinematics and writes the NC program in the machine's dialect, atomically (a
//! temporary file renamed over the target: an error never leaves a partial program, nor
//! clobbers an existing one).

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use postpro_emit::{Dialect, EmitError, Mode, Options, builtin_template, dialect, write_program};

use crate::job::fail;
use crate::predict::{self, MarkArgs, PredictionArgs};
use crate::report;
use crate::setup::SetupArgs;
use crate::solve::{IktArgs, MachineArgs};

/// Arguments of the main job.
#[derive(Debug, clap::Args)]
pub(crate) struct EmitArgs {
    /// The CL file.
    #[arg(value_name = "FILE.cl")]
    file: Option<PathBuf>,
    #[command(flatten)]
    machine: Option<MachineArgs>,
    #[command(flatten)]
    ikt: IktArgs,
    #[command(flatten)]
    setup: SetupArgs,
    /// Output file; `-` for standard output. Default: next to the input, with the dialect's
    /// extension (`part.cl` → `part.mpf`).
    #[arg(long, short = 'o', value_name = "OUT")]
    output: Option<PathBuf>,
    /// How motion is written: `auto` (a program that turns the tool while cutting in `tcp` where
    /// the dialect has it, else `inverse-time`, so that F is the tool's feed on the part; any other
    /// in `g1`), `g1` (axis values, programmed feed), `inverse-time` (G93, F = 1/Δt on every
    /// block), `bspline` (Siemens BSPLINE through the axis positions, within tolerance) or `tcp`
    /// (tool tip and orientation; the controller solves the kinematics).
    #[arg(long, value_enum, default_value_t = ModeArg::Auto)]
    mode: ModeArg,
    /// In TCP mode, the tool's orientation as the rotary axes' angles (`G43.4`, `ORIAXES`,
    /// `M128` with `L`, `G234`) or as the tool vector (`G43.5 I J K`, `ORIVECT A3 B3 C3`, `LN …
    /// TX TY TZ`).
    #[arg(long, value_enum, default_value_t = TcpOrientationArg::Angles)]
    tcp_orientation: TcpOrientationArg,
    /// 3+2 set-ups in the controller's tilted working plane (`cycle`: `G68.2`, `G254`,
    /// `CYCLE800`, `PLANE VECTOR`), where the dialect has one and the machine's rotary axes carry
    /// the part, or as axis values (`joints`).
    #[arg(long, value_enum, default_value_t = PlaneModeArg::Cycle)]
    plane_mode: PlaneModeArg,
    /// CL `INSERT` text as comments (`comment`: CAM systems write descriptions there that no
    /// controller reads), or as blocks of the program, as is (`verbatim`).
    #[arg(long, value_enum, default_value_t = InsertArg::Comment)]
    insert: InsertArg,
    /// CL arcs as circular interpolation wherever they are circles of the program's frame
    /// (`native`), or always as straight moves within the tolerance (`linear`).
    #[arg(long, value_enum, default_value_t = ArcsArg::Native)]
    arcs: ArcsArg,
    /// Canned cycles as the controller's cycles where the hole axis is the spindle's (`native`),
    /// or always as moves (`expand`).
    #[arg(long, value_enum, default_value_t = CyclesArg::Native)]
    cycles: CyclesArg,
    #[command(flatten)]
    prediction: PredictionArgs,
    #[command(flatten)]
    marks: MarkArgs,
    /// Do not predict the feed (no slowdown comments, no predicted cycle time in the header).
    #[arg(long)]
    no_predict: bool,
    /// The controller dialect (default: the machine's): siemens-840d, fanuc, heidenhain, linuxcnc.
    #[arg(long, value_name = "NAME")]
    dialect: Option<String>,
    /// A minijinja template to use instead of the dialect's (docs/templates.md has the context).
    #[arg(long, value_name = "FILE")]
    template: Option<PathBuf>,
    /// Number the blocks (N10, N20, …).
    #[arg(long)]
    block_numbers: bool,
    /// Print on standard error how long each pass took, the throughput (CL points per second)
    /// and the peak memory (where the system says it).
    #[arg(long)]
    timing: bool,
    /// Write the program in a pass of its own even where the prediction pass can write it as it
    /// goes (the same program, more slowly: for the tests that compare the two).
    #[arg(long, hide = true)]
    three_passes: bool,
}

/// `--arcs`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub(crate) enum ArcsArg {
    Native,
    Linear,
}

/// `--cycles`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub(crate) enum CyclesArg {
    Native,
    Expand,
}

/// `--tcp-orientation`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub(crate) enum TcpOrientationArg {
    Angles,
    Vectors,
}

/// `--insert`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub(crate) enum InsertArg {
    Comment,
    Verbatim,
}

/// `--plane-mode`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub(crate) enum PlaneModeArg {
    Cycle,
    Joints,
}

/// `--mode`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub(crate) enum ModeArg {
    Auto,
    G1,
    InverseTime,
    Bspline,
    Tcp,
}

impl ModeArg {
    /// The mode for the tool path `path` on `machine` in `dialect`: the one asked for, or for
    /// `auto` the one whose F is the tool's feed on the part where the tool turns while cutting
    /// (TCP where the dialect has it, else inverse time), `g1` otherwise.
    pub(crate) fn resolve(
        self,
        path: &postpro_cl::ToolPath,
        machine: &postpro_machine::model::Machine,
        dialect: &Dialect,
    ) -> Mode {
        self.resolve_turning(path.turns_tool_while_cutting(), machine, dialect)
    }

    /// [`ModeArg::resolve`] for a tool path that turns the tool while cutting or not.
    pub(crate) fn resolve_turning(
        self,
        turns_tool: bool,
        machine: &postpro_machine::model::Machine,
        dialect: &Dialect,
    ) -> Mode {
        match self {
            ModeArg::G1 => Mode::G1,
            ModeArg::InverseTime => Mode::InverseTime,
            ModeArg::Bspline => Mode::Bspline,
            ModeArg::Tcp => Mode::Tcp,
            ModeArg::Auto => {
                let rotary = machine.axes.iter().any(|a| a.kind == postpro_machine::model::AxisKind::Rotary);
                if !rotary || !turns_tool {
                    Mode::G1
                } else if dialect.tcp != postpro_emit::TcpStyle::None {
                    Mode::Tcp
                } else if dialect.inverse_time_range.is_some() {
                    Mode::InverseTime
                } else {
                    Mode::G1
                }
            }
        }
    }
}

impl EmitArgs {
    /// True when the main job was asked for (a file or a machine on the command line).
    pub(crate) fn given(&self) -> bool {
        self.file.is_some() || self.machine.is_some()
    }
}

pub(crate) fn run(args: &EmitArgs) -> ExitCode {
    let (Some(file), Some(machine_args)) = (&args.file, &args.machine) else {
        return fail("error: the main job needs a CL file and --machine NAME (see postpro --help)\n", 2);
    };
    let chosen = match machine_args.choose() {
        Ok(c) => c,
        Err(code) => return code,
    };
    let dialect_name = args.dialect.clone().unwrap_or_else(|| chosen.machine.dialect.clone());
    let Some(dialect) = dialect(&dialect_name) else {
        let known: Vec<&str> = postpro_emit::DIALECTS.iter().map(|d| d.name).collect();
        return fail(&format!("error: unknown dialect `{dialect_name}`; known: {}\n", known.join(", ")), 2);
    };
    let template = match &args.template {
        Some(path) => match std::fs::read_to_string(path) {
            Ok(t) => (path.display().to_string(), t),
            Err(e) => return fail(&format!("error: cannot read the template {}: {e}\n", path.display()), 1),
        },
        None => match plugin_template(&chosen, args.dialect.is_none()) {
            // The machine's plugin ships a template for it: used unless --dialect asks otherwise.
            Some(t) => t,
            None => (format!("{}.j2", dialect.name), builtin_template(dialect.name).unwrap_or_default().to_string()),
        },
    };
    let output = match &args.output {
        Some(o) => o.clone(),
        None => file.with_extension(dialect.extension),
    };
    if output != Path::new("-") && same_file(&output, file) {
        return fail(
            &format!("error: the output {} is the CL file itself: choose another with -o\n", output.display()),
            2,
        );
    }
    let tcp_orientation = match args.tcp_orientation {
        TcpOrientationArg::Angles => postpro_emit::TcpOrientation::Angles,
        TcpOrientationArg::Vectors => postpro_emit::TcpOrientation::Vectors,
    };

    let program_name = file.file_stem().map_or_else(|| "PROGRAM".to_string(), |s| s.to_string_lossy().to_uppercase());
    let program = crate::stream::Program {
        template: &template,
        output: &output,
        name: program_name,
        block_numbers: args.block_numbers,
        tcp_orientation,
        insert_verbatim: args.insert == InsertArg::Verbatim,
        timing: args.timing,
        three_passes: args.three_passes,
    };
    let request = crate::stream::Request {
        purpose: crate::stream::Purpose::Program(program),
        file,
        chosen: &chosen,
        ikt: &args.ikt,
        setup: &args.setup,
        mode: args.mode,
        dialect,
        shapes: crate::job::Shapes {
            linear_arcs: args.arcs == ArcsArg::Linear,
            expand_cycles: args.cycles == CyclesArg::Expand,
            planes: args.plane_mode == PlaneModeArg::Cycle,
        },
        prediction: (!args.no_predict).then_some((&args.prediction, &args.marks)),
    };
    crate::stream::run(&request)
}

/// The dialect can write `mode` (and, in TCP mode, the orientation as asked), or the rendered
/// error.
pub(crate) fn check_writing(
    dialect: &Dialect,
    mode: Mode,
    orientation: postpro_emit::TcpOrientation,
) -> Result<(), ExitCode> {
    let checked = postpro_emit::check_mode(dialect, mode)
        .and_then(|()| if mode == Mode::Tcp { postpro_emit::check_orientation(dialect, orientation) } else { Ok(()) });
    checked.map_err(|e| fail(&report::render(&e), 1))
}

/// How a solved job is written.
pub(crate) struct Writing<'a> {
    /// Output mode.
    pub(crate) mode: Mode,
    /// Controller dialect.
    pub(crate) dialect: &'a Dialect,
    /// The template's name and text.
    pub(crate) template: &'a (String, String),
    /// Where (`-` for standard output).
    pub(crate) output: &'a Path,
    /// The program's name.
    pub(crate) program_name: String,
    /// Number the blocks.
    pub(crate) block_numbers: bool,
    /// How arcs, cycles and 3+2 set-ups are written.
    pub(crate) shapes: crate::job::Shapes,
    /// How TCP mode gives the tool's orientation.
    pub(crate) tcp_orientation: postpro_emit::TcpOrientation,
    /// CL `INSERT` text as blocks (else as comments).
    pub(crate) insert_verbatim: bool,
    /// Predict the feed and mark the slowdowns, with these options (`None`: `--no-predict`).
    pub(crate) prediction: Option<(&'a PredictionArgs, &'a MarkArgs)>,
}

/// Predicts (unless told not to) and writes the program of a solved job, atomically; prints
/// what it wrote. `stage` is told what is being done (`""` when done).
pub(crate) fn write_job(job: &crate::job::Job, how: &Writing<'_>, stage: &dyn Fn(&str)) -> ExitCode {
    let (mode, dialect, template, output) = (how.mode, how.dialect, how.template, how.output);
    let (solved, machine, source) = (&job.solved, &job.machine, &job.source);
    let program = match job.motion(dialect, how.shapes) {
        Ok(program) => program,
        Err(code) => {
            stage("");
            return code;
        }
    };
    let (prediction, annotations) = match how.prediction {
        None => (None, Vec::new()),
        Some((args, marking)) => {
            stage("predicting the feed");
            let predicted = predict::run(job, &program, args, false);
            for note in &predicted.notes {
                let at = job.solved.steps[note.step].span.start as usize;
                eprintln!("note: {}: prediction: {}", source.location(at), note.text);
            }
            let marks = predicted.marks(&marking.rules(args));
            let annotations = predict::annotations(&marks, machine);
            let summary = predict::header(
                (&predicted.totals(), &predicted.operations),
                args,
                mode,
                &marks,
                (machine, &job.source),
            );
            (Some(summary), annotations)
        }
    };
    stage("writing the program");
    let predicted_time = prediction.as_ref().map(|p| (p.cycle_time, p.time_lost, p.slowdowns));
    let options = Options {
        units: job.setup.units(machine),
        program_name: how.program_name.clone(),
        source_name: source.name().to_string(),
        block_numbers: how.block_numbers,
        tcp_orientation: how.tcp_orientation,
        insert_verbatim: how.insert_verbatim,
        prediction,
        annotations,
    };
    let write =
        |out: &mut dyn Write| write_program(&program, machine, dialect, &options, &template.0, &template.1, out);
    let written = if output == Path::new("-") {
        let stdout = std::io::stdout();
        let mut out = std::io::BufWriter::new(stdout.lock());
        write(&mut out).and_then(|()| out.flush().map_err(|e| EmitError::Io { message: e.to_string() }))
    } else {
        write_atomically(output, write)
    };
    stage("");
    if let Err(e) = written {
        let message = match e {
            EmitError::Io { message } => format!("error: cannot write {}: {message}\n", output.display()),
            e => report::render(&e),
        };
        return fail(&message, 1);
    }
    let inserts: Vec<&postpro_cl::Item> = job
        .path
        .items
        .iter()
        .filter(|i| matches!(i.kind, postpro_cl::ItemKind::Text(postpro_cl::TextKind::Insert, _)))
        .collect();
    let first_insert = inserts.first().filter(|_| !how.insert_verbatim).map(|i| source.location(i.span.start as usize));
    let counts = (solved.steps.len() - solved.inserted, solved.inserted, solved.decisions.len());
    crate::job::said_written(
        output,
        &machine.name,
        (inserts.len(), first_insert.map(|l| l.to_string())),
        counts,
        mode == Mode::Tcp,
        predicted_time,
    );
    ExitCode::SUCCESS
}

/// The template named after the machine (`<machine>` or `<machine>.j2`) that the machine's own
/// plugin ships, if any.
fn plugin_template(chosen: &crate::solve::Chosen, wanted: bool) -> Option<(String, String)> {
    let postpro_machine::Origin::Plugin { library } = &chosen.origin else { return None };
    let name = chosen.machine.name.as_str();
    let plugin = chosen.plugins.plugins().iter().find(|p| p.path() == library.as_path())?;
    let template =
        plugin.templates().find(|t| t.name == name || t.name.strip_suffix(".j2") == Some(name)).filter(|_| wanted)?;
    Some((format!("plugin {}: {}", library.display(), template.name), template.text.clone()))
}

fn same_file(a: &Path, b: &Path) -> bool {
    match (a.canonicalize(), b.canonicalize()) {
        (Ok(x), Ok(y)) => x == y,
        _ => a == b,
    }
}

/// True when `path` exists and is not a regular file (`/dev/null`, a named pipe): it is written
/// in place, since renaming a file over it would replace the device or the pipe.
pub(crate) fn is_special_file(path: &Path) -> bool {
    std::fs::metadata(path).is_ok_and(|m| !m.is_file() && !m.is_dir())
}

/// Writes to a temporary file beside `path`, then renames it over `path`: readers see the old
/// file or the whole new one, never a part; on an error the temporary file is removed. A device
/// or a pipe ([`is_special_file`]) is written directly.
pub(crate) fn write_atomically(
    path: &Path,
    write: impl FnOnce(&mut dyn Write) -> Result<(), EmitError>,
) -> Result<(), EmitError> {
    write_atomically_with(path, write, |e| EmitError::Io { message: e.to_string() })
}

/// [`write_atomically`] with the error type of `write` (`io` makes one of an I/O error).
pub(crate) fn write_atomically_with<E>(
    path: &Path,
    write: impl FnOnce(&mut dyn Write) -> Result<(), E>,
    io: impl Fn(std::io::Error) -> E,
) -> Result<(), E> {
    if is_special_file(path) {
        let file = std::fs::OpenOptions::new().write(true).open(path).map_err(&io)?;
        let mut out = std::io::BufWriter::with_capacity(1 << 20, file);
        write(&mut out)?;
        return out.flush().map_err(io);
    }
    let temp = beside(path, "tmp");
    let result = create_scratch(&temp).map_err(&io).and_then(|file| {
        let mut out = std::io::BufWriter::with_capacity(1 << 20, file);
        write(&mut out)?;
        let file = out.into_inner().map_err(|e| io(e.into_error()))?;
        file.sync_all().map_err(&io)?;
        std::fs::rename(&temp, path).map_err(&io)
    });
    if result.is_err() {
        let _ = std::fs::remove_file(&temp);
    }
    result
}

/// Creates the scratch file `path` (one of [`beside`], or in the temporary folder), for reading
/// and writing. It is created new: whatever stands at `path` is never opened, so that a link
/// someone left there under the name (predictable: the process id) cannot make postpro truncate
/// the file it points to. A file left by an earlier process of the same id is removed first.
pub(crate) fn create_scratch(path: &Path) -> std::io::Result<std::fs::File> {
    let create = || std::fs::OpenOptions::new().read(true).write(true).create_new(true).open(path);
    match create() {
        Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {
            std::fs::remove_file(path)?;
            create()
        }
        created => created,
    }
}

/// A file of postpro's own beside `path` (hidden, with this process's id and `suffix`): in the
/// same folder, so that a rename over `path` is atomic.
pub(crate) fn beside(path: &Path, suffix: &str) -> PathBuf {
    let dir = path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    let name = path.file_name().map_or_else(|| "program".into(), |n| n.to_string_lossy().into_owned());
    dir.join(format!(".{name}.postpro-{}.{suffix}", std::process::id()))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A link planted under the scratch file's name (it is predictable) is replaced, never
    /// followed: the file it points to keeps its contents.
    #[test]
    #[cfg(unix)]
    fn a_link_under_the_scratch_name_is_not_followed() {
        let dir = std::env::temp_dir().join(format!("postpro-scratch-link-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("scratch folder");
        let victim = dir.join("victim.txt");
        std::fs::write(&victim, "keep me\n").expect("write");
        let output = dir.join("part.nc");
        std::os::unix::fs::symlink(&victim, beside(&output, "tmp")).expect("link");
        write_atomically(&output, |out| {
            out.write_all(b"%\nM30\n%\n").map_err(|e| EmitError::Io { message: e.to_string() })
        })
        .expect("written");
        assert_eq!(std::fs::read_to_string(&victim).expect("read"), "keep me\n");
        assert_eq!(std::fs::read_to_string(&output).expect("read"), "%\nM30\n%\n");
        assert!(std::fs::symlink_metadata(&output).expect("there").file_type().is_file());
        // A file of an earlier process of the same id goes too.
        let scratch = dir.join("left.body");
        std::os::unix::fs::symlink(&victim, &scratch).expect("link");
        let mut file = create_scratch(&scratch).expect("created");
        file.write_all(b"body").expect("write");
        assert_eq!(std::fs::read_to_string(&victim).expect("read"), "keep me\n");
        assert!(std::fs::symlink_metadata(&scratch).expect("there").file_type().is_file());
        std::fs::remove_dir_all(&dir).expect("clean up");
    }
}
