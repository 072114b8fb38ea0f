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

use postpro_kin::{Collected, StepKind};
use postpro_machine::model::{AxisKind, BranchPreference, Machine, OnDiscontinuity, PathChoice, SolverKind};
use postpro_machine::{Origin, Registry};
use postpro_motion::WorkFrame;
use postpro_plugins::{Plugins, Solver};

use crate::job::fail;
use crate::report;
use crate::scratch::{LinesOf, Scratch};

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

/// What an error of `postpro solve` says was not done.
pub(crate) const SOLVED: &str = "nothing solved";

/// Solves the file as the main job reads it (`stream::solve`): the summary (ranges, counts and
/// decisions) is gathered as the steps come and the CSV rows wait in a scratch file, so nothing
/// proportional to the file is held in memory and nothing is printed before the end.
pub(crate) fn run(args: &SolveArgs) -> ExitCode {
    let chosen = match args.machine.choose() {
        Ok(c) => c,
        Err(code) => return code,
    };
    let dialect = crate::job::machine_dialect(&chosen.machine);
    let request = crate::stream::Request {
        purpose: crate::stream::Purpose::Solution,
        file: &args.file,
        chosen: &chosen,
        ikt: &args.ikt,
        setup: &args.setup,
        mode: crate::emit::ModeArg::G1,
        dialect,
        shapes: crate::job::Shapes::default(),
        prediction: None,
    };
    let mut rows = match args.csv.then(|| Rows::new(&chosen.machine)).transpose() {
        Ok(rows) => rows,
        Err(e) => return fail(&format!("error: cannot make a scratch file for the rows: {e}\n"), 1),
    };
    let mut seen = Seen::new(&chosen.machine);
    let mut failed = None;
    // The rows, or what the summary says: never both.
    let mut each = |collected: &Collected, file: &postpro_cl::ClFile, frame: &WorkFrame| {
        let machine = &chosen.machine;
        let taken = match rows.as_mut() {
            Some(rows) => rows.push(machine, collected, file, frame),
            None => seen.steps(machine, collected, file, frame),
        };
        if let Err(e) = taken {
            failed.get_or_insert(e);
        }
    };
    let solution = match crate::stream::solve(&request, &mut each) {
        Ok(solution) => solution,
        Err(code) => return code,
    };
    if let Some(e) = failed {
        let what = if rows.is_some() { "write the scratch file" } else { "read the CL file again" };
        return fail(&format!("error: cannot {what}: {e}\n"), 1);
    }
    match rows {
        Some(rows) => rows.scratch.print_after(""),
        None => report::print_stdout(&summary(&solution, &seen)),
    }
}

/// What the summary says of the steps, gathered as they come.
struct Seen {
    positions: usize,
    /// The positions of CL points (re-engagements included).
    cl: usize,
    /// Each axis's lowest and highest value, in its NC unit.
    ranges: Vec<(f64, f64)>,
    /// Each decision: where, and what.
    decisions: Vec<String>,
    /// Where the decisions are, read on as they come (opened with the first).
    lines: LinesOf,
}

impl Seen {
    fn new(machine: &Machine) -> Seen {
        let ranges = vec![(f64::INFINITY, f64::NEG_INFINITY); machine.axes.len()];
        Seen { positions: 0, cl: 0, ranges, decisions: Vec::new(), lines: LinesOf::default() }
    }

    /// Takes in one CL item's steps and decisions.
    fn steps(
        &mut self,
        machine: &Machine,
        collected: &Collected,
        file: &postpro_cl::ClFile,
        frame: &WorkFrame,
    ) -> std::io::Result<()> {
        for s in &collected.steps {
            self.positions += 1;
            self.cl += usize::from(matches!(s.kind, StepKind::Cl | StepKind::Reengage));
            let joints = frame.apply(&s.joints);
            for (i, (lo, hi)) in self.ranges.iter_mut().enumerate() {
                let v = value(machine, i, joints[i]);
                (*lo, *hi) = (lo.min(v), hi.max(v));
            }
        }
        for d in &collected.decisions {
            let at = self.lines.line_col(file, d.span.start)?;
            self.decisions.push(format!("  {}:{}:{}: {}", file.name(), at.line, at.column, d.decision));
        }
        Ok(())
    }
}

/// The CSV rows, waiting in a scratch file until the solution is whole (an error prints none).
struct Rows {
    scratch: Scratch,
    index: usize,
    /// The CL lines of the steps, read on as they come (opened with the first).
    lines: LinesOf,
}

impl Rows {
    /// A scratch file in the temporary folder, with the header row.
    fn new(machine: &Machine) -> std::io::Result<Rows> {
        let mut rows = Rows { scratch: Scratch::new("solve.csv")?, index: 0, lines: LinesOf::default() };
        let text = &mut rows.scratch.text;
        text.push_str("step,line,kind,rapid");
        for a in &machine.axes {
            let unit = if a.kind == AxisKind::Rotary { "deg" } else { "mm" };
            let _ = write!(text, ",{}_{unit}", a.letter);
        }
        text.push('\n');
        rows.scratch.flush_text()?;
        Ok(rows)
    }

    /// Writes one CL item's steps of `file`, their axis values in `frame`.
    fn push(
        &mut self,
        machine: &Machine,
        collected: &Collected,
        file: &postpro_cl::ClFile,
        frame: &WorkFrame,
    ) -> std::io::Result<()> {
        for s in &collected.steps {
            let line = self.lines.line_col(file, s.span.start)?.line;
            let joints = frame.apply(&s.joints);
            let text = &mut self.scratch.text;
            let _ = write!(text, "{},{line},{},{}", self.index, kind(s.kind), u8::from(s.rapid));
            self.index += 1;
            for (i, a) in machine.axes.iter().enumerate() {
                text.push(',');
                postpro_emit::push_number(text, value(machine, i, joints[i]), usize::from(a.decimals), false);
            }
            text.push('\n');
        }
        self.scratch.flush_text()
    }
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

fn summary(solution: &crate::stream::Solution, seen: &Seen) -> String {
    let machine = &solution.machine;
    let mut out = String::new();
    let _ = writeln!(out, "machine     {} ({})", machine.name, machine.topology().label());
    if let Some(library) = &solution.plugin {
        let _ = writeln!(out, "kinematics  plugin {} (checked against the definition)", library.display());
    }
    let _ = writeln!(out, "file        {}", solution.name);
    let _ = writeln!(out, "frame       the work offset, set on {}", solution.frame.describe());
    let _ = writeln!(
        out,
        "positions   {} ({} from the CL file, {} added by linearization within {} mm)",
        seen.positions, seen.cl, solution.inserted, machine.policy.linearization_tolerance
    );
    if let (unsettled, Some(first)) = &solution.unsettled {
        let _ = writeln!(
            out,
            "off path    {} feed move(s) stray up to {}, over the tolerance: linearization could not bring \
             them within it (first at {first})",
            unsettled.segments,
            unsettled.worst_shown()
        );
    }
    for (a, (lo, hi)) in machine.axes.iter().zip(&seen.ranges) {
        let unit = if a.kind == AxisKind::Rotary { "°" } else { " mm" };
        let d = usize::from(a.decimals);
        let _ = writeln!(out, "axis {:<6} {lo:.d$} … {hi:.d$}{unit}", a.letter);
    }
    let _ = writeln!(out, "decisions   {}", seen.decisions.len());
    for d in &seen.decisions {
        out.push_str(d);
        out.push('\n');
    }
    out
}
