//! `postpro solve FILE --machine NAME`: the inverse kinematics of a CL file on one machine:
//! the axis values of every position, the decisions that are not obvious (branch switches,
//! singular holds, retracts), and the points linearization added. The IKT options are shared
//! with the commands that write NC programs.
//!
//! Machines come from the built-in definitions, machine folders, and plugins (`--plugin FILE`,
//! `POSTPRO_PLUGIN_PATH`, the `plugins` folder beside the binary); a plugin machine with
//! `solver: plugin` is solved by the plugin's compiled kinematics, checked against its
//! definition when loaded and on every call.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use postpro_cl::Source;
use postpro_kin::{Solved, StepKind};
use postpro_machine::model::{AxisKind, BranchPreference, Machine, OnDiscontinuity, PathChoice, SolverKind};
use postpro_machine::{Origin, Registry};
use postpro_plugins::{Plugins, Solver};

use crate::job::fail;
use crate::report;

/// Arguments of `postpro solve`.
#[derive(Debug, clap::Args)]
pub(crate) struct SolveArgs {
    /// The CL file.
    file: PathBuf,
    #[command(flatten)]
    machine: MachineArgs,
    #[command(flatten)]
    ikt: IktArgs,
    #[command(flatten)]
    setup: crate::setup::SetupArgs,
    /// Print every position as CSV (rotary axes in degrees) instead of the summary.
    #[arg(long)]
    csv: bool,
}

/// Which machine.
#[derive(Debug, clap::Args)]
pub(crate) struct MachineArgs {
    /// The machine: a name or alias (`postpro machines` lists them), or a machine file (.yaml).
    #[arg(long, short = 'm', value_name = "NAME|FILE")]
    machine: String,
    /// Also load the machine files of this folder (repeatable), after POSTPRO_MACHINE_PATH.
    #[arg(long = "machine-dir", value_name = "DIR")]
    dirs: Vec<PathBuf>,
    /// Also load this plugin library (repeatable), after the `plugins` folder beside postpro and
    /// the folders of POSTPRO_PLUGIN_PATH.
    #[arg(long = "plugin", value_name = "FILE")]
    plugins: Vec<PathBuf>,
}

/// The machine asked for, where it comes from, and the plugins loaded (its kinematics may be one
/// of theirs).
pub(crate) struct Chosen {
    /// The machine, as defined.
    pub(crate) machine: Machine,
    /// Where it comes from.
    pub(crate) origin: Origin,
    /// The plugins loaded.
    pub(crate) plugins: Plugins,
}

impl Chosen {
    /// The kinematics of `machine` (the chosen one, with the command line's overrides): for
    /// `solver: plugin` from a plugin the plugin's, verified against the definition; otherwise
    /// postpro's. Or the exit code after printing why not.
    pub(crate) fn solver(&self, machine: &Machine) -> Result<Solver, ExitCode> {
        if machine.solver == SolverKind::Plugin && !matches!(self.origin, Origin::Plugin { .. }) {
            eprintln!(
                "note: machine `{}` says `solver: plugin` but does not come from a plugin: solving with the generic \
                 chain of its definition",
                machine.name
            );
        }
        self.plugins.solver(machine, &self.origin).map_err(|e| fail(&report::render(&e), 1))
    }
}

/// The IKT policy options; each overrides the machine definition's default.
#[derive(Debug, clap::Args)]
pub(crate) struct IktArgs {
    /// Preferred branch: `closest`, or `+A` / `-A` to keep a rotary axis ≥ 0 or ≤ 0.
    #[arg(long, value_name = "closest|+AXIS|-AXIS", value_parser = parse_branch)]
    branch: Option<BranchPreference>,
    /// Choose point by point instead of over the whole path.
    #[arg(long)]
    greedy: bool,
    /// Half-angle of the singular cone, degrees.
    #[arg(long, value_name = "DEG", value_parser = positive)]
    singular_cone: Option<f64>,
    /// A rotary step between two feed points above this is reported as a warning, degrees.
    #[arg(long, value_name = "DEG", value_parser = positive)]
    max_rotary_step: Option<f64>,
    /// At a discontinuity: `error`, or `retract[:MM]` (retract along the tool axis, default 50 mm).
    #[arg(long, value_name = "error|retract[:MM]", value_parser = parse_discontinuity)]
    on_discontinuity: Option<OnDiscontinuity>,
    /// Largest deviation of the tool tip from the programmed segments, mm (linearization).
    #[arg(long, value_name = "MM", value_parser = positive)]
    tolerance: Option<f64>,
    /// Tool length from the spindle nose to the tip, mm.
    #[arg(long, value_name = "MM", value_parser = non_negative)]
    tool_length: Option<f64>,
}

fn positive(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v > 0.0 && v.is_finite() => Ok(v),
        _ => Err(format!("expected a number > 0, found `{s}`")),
    }
}

fn non_negative(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v >= 0.0 && v.is_finite() => Ok(v),
        _ => Err(format!("expected a number ≥ 0, found `{s}`")),
    }
}

fn parse_branch(s: &str) -> Result<BranchPreference, String> {
    match s.as_bytes().first() {
        _ if s.eq_ignore_ascii_case("closest") => Ok(BranchPreference::Closest),
        Some(b'+') if s.len() > 1 => Ok(BranchPreference::Positive(s[1..].to_uppercase())),
        Some(b'-') if s.len() > 1 => Ok(BranchPreference::Negative(s[1..].to_uppercase())),
        _ => Err(format!("expected `closest`, `+AXIS` or `-AXIS`, found `{s}`")),
    }
}

fn parse_discontinuity(s: &str) -> Result<OnDiscontinuity, String> {
    match s.split_once(':') {
        None if s == "error" => Ok(OnDiscontinuity::Error),
        None if s == "retract" => Ok(OnDiscontinuity::Retract { clearance: 50.0 }),
        Some(("retract", mm)) => positive(mm).map(|clearance| OnDiscontinuity::Retract { clearance }),
        _ => Err(format!("expected `error`, `retract` or `retract:MM`, found `{s}`")),
    }
}

impl IktArgs {
    /// The machine with these overrides, or a message for a usage error.
    pub(crate) fn apply(&self, machine: &mut Machine) -> Result<(), String> {
        let p = &mut machine.policy;
        if let Some(b) = &self.branch {
            if let BranchPreference::Positive(axis) | BranchPreference::Negative(axis) = b {
                let rotary =
                    machine.axes.iter().any(|a| a.kind == AxisKind::Rotary && a.letter.eq_ignore_ascii_case(axis));
                if !rotary {
                    return Err(format!("--branch: {} has no rotary axis `{axis}`", machine.name));
                }
            }
            p.branch = b.clone();
        }
        if self.greedy {
            p.choice = PathChoice::Greedy;
        }
        if let Some(v) = self.singular_cone {
            p.singular_cone = v.to_radians();
            // A pole passage is at least the singular cone.
            p.pole_passage = p.pole_passage.max(p.singular_cone);
        }
        if let Some(v) = self.max_rotary_step {
            p.max_rotary_step = v.to_radians();
        }
        if let Some(v) = self.on_discontinuity {
            p.on_discontinuity = v;
        }
        if let Some(v) = self.tolerance {
            p.linearization_tolerance = v;
        }
        if let Some(v) = self.tool_length {
            machine.chain.tool_length = v;
        }
        Ok(())
    }
}

impl MachineArgs {
    /// The machine with its origin and the plugins loaded, or the exit code after printing why
    /// not: 2 for an unknown name, 1 for a machine file or a `--plugin` library that does not
    /// load. Problems with the other folders and plugins are printed and passed over.
    pub(crate) fn choose(&self) -> Result<Chosen, ExitCode> {
        let mut dirs: Vec<PathBuf> = std::env::var_os("POSTPRO_MACHINE_PATH")
            .map(|v| std::env::split_paths(&v).filter(|p| !p.as_os_str().is_empty()).collect())
            .unwrap_or_default();
        dirs.extend(self.dirs.iter().cloned());
        let (mut registry, skipped) = Registry::with_dirs(&dirs).map_err(|e| fail(&report::render(&e), 1))?;
        // Files that do not load are warnings: the other machines work.
        for s in &skipped {
            eprint!("{}", report::render(s));
        }
        let mut plugins = Plugins::new();
        for e in plugins.discover(&[]) {
            eprint!("{}", report::render(&e));
        }
        let mut refused = false;
        for file in &self.plugins {
            if let Err(e) = plugins.load(file) {
                eprint!("{}", report::render(&e));
                refused = true;
            }
        }
        for e in plugins.register(&mut registry) {
            eprint!("{}", report::render(&e));
        }
        if refused {
            return Err(fail("error: a plugin given with --plugin does not load\n", 1));
        }
        let as_file = Path::new(&self.machine);
        let is_file = as_file.extension().is_some_and(|e| e == "yaml" || e == "yml") || as_file.is_file();
        let entry = if is_file {
            registry.load_file(as_file).map_err(|e| fail(&report::render(&e), 1))?
        } else {
            registry.find(&self.machine).map_err(|e| fail(&report::render(&e), 2))?
        };
        Ok(Chosen { machine: entry.machine.clone(), origin: entry.origin.clone(), plugins })
    }
}

pub(crate) fn run(args: &SolveArgs) -> ExitCode {
    let chosen = match args.machine.choose() {
        Ok(c) => c,
        Err(code) => return code,
    };
    let mode = postpro_emit::Mode::G1;
    let how = (crate::emit::ModeArg::G1, crate::job::machine_dialect(&chosen.machine));
    let job = match crate::job::prepare(&args.file, &chosen, &args.ikt, &args.setup, how, "nothing solved") {
        Ok(job) => job,
        Err(code) => return code,
    };
    let frame = postpro_motion::work_frame(job.solver.kinematics(), mode);
    let crate::job::Job { source, machine, solver, mut solved, .. } = job;
    // The axis values as the program writes them: in the work offset's frame.
    for s in &mut solved.steps {
        s.joints = frame.apply(&s.joints);
    }
    let kinematics = match &solver {
        Solver::Plugin(a) => Some(format!("plugin {} (checked against the definition)", a.library().display())),
        Solver::Built(_) => None,
    };
    let text = if args.csv {
        csv(&machine, &source, &solved)
    } else {
        summary(&machine, &source, &solved, kinematics.as_deref(), &frame.describe())
    };
    report::print_stdout(&text)
}

fn value(machine: &Machine, axis: usize, v: f64) -> f64 {
    if machine.axes[axis].kind == AxisKind::Rotary { v.to_degrees() } else { v }
}

fn kind(k: StepKind) -> &'static str {
    match k {
        StepKind::Cl => "cl",
        StepKind::Linearized => "linearized",
        StepKind::Retract => "retract",
        StepKind::Reorient => "reorient",
        StepKind::Reengage => "reengage",
    }
}

fn csv(machine: &Machine, source: &Source, solved: &Solved) -> String {
    let mut out = String::from("step,line,kind,rapid");
    for a in &machine.axes {
        let unit = if a.kind == AxisKind::Rotary { "deg" } else { "mm" };
        let _ = write!(out, ",{}_{unit}", a.letter);
    }
    out.push('\n');
    for (k, s) in solved.steps.iter().enumerate() {
        let line = source.line_col(s.span.start as usize).line;
        let _ = write!(out, "{k},{line},{},{}", kind(s.kind), u8::from(s.rapid));
        for (i, a) in machine.axes.iter().enumerate() {
            out.push(',');
            postpro_emit::push_number(&mut out, value(machine, i, s.joints[i]), usize::from(a.decimals), false);
        }
        out.push('\n');
    }
    out
}

fn summary(machine: &Machine, source: &Source, solved: &Solved, kinematics: Option<&str>, origin: &str) -> String {
    let mut out = String::new();
    let cl = solved.steps.iter().filter(|s| matches!(s.kind, StepKind::Cl | StepKind::Reengage)).count();
    let _ = writeln!(out, "machine     {} ({})", machine.name, machine.topology().label());
    if let Some(k) = kinematics {
        let _ = writeln!(out, "kinematics  {k}");
    }
    let _ = writeln!(out, "file        {}", source.name());
    let _ = writeln!(out, "frame       the work offset, set on {origin}");
    let _ = writeln!(
        out,
        "positions   {} ({cl} from the CL file, {} added by linearization within {} mm)",
        solved.steps.len(),
        solved.inserted,
        machine.policy.linearization_tolerance
    );
    for (i, a) in machine.axes.iter().enumerate() {
        let (lo, hi) = solved
            .steps
            .iter()
            .map(|s| value(machine, i, s.joints[i]))
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| (lo.min(v), hi.max(v)));
        let unit = if a.kind == AxisKind::Rotary { "°" } else { " mm" };
        let d = usize::from(a.decimals);
        let _ = writeln!(out, "axis {:<6} {lo:.d$} … {hi:.d$}{unit}", a.letter);
    }
    let _ = writeln!(out, "decisions   {}", solved.decisions.len());
    for d in &solved.decisions {
        let _ = writeln!(out, "  {}: {}", source.location(d.span.start as usize), d.decision);
    }
    out
}
