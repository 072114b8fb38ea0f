//! `postpro predict FILE.cl --machine NAME`: the feed the machine will really reach. A table in
//! the terminal (totals, time lost by cause, per operation, the worst slowdowns marked,
//! `--blocks` for every block), the samples and per-block results as CSV (`--csv`) or JSON
//! (`--json`), an SVG report (`--plot`) and an HTML report (`--report`). The main job uses the
//! same prediction to mark slowdowns in the NC program.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use postpro_emit::{Annotation, Mode};
use postpro_machine::model::{AxisKind, Machine};
use postpro_predict::{
    BlockKind, BlockResult, Cause, Limit, Mark, MarkRules, Planner, Prediction, Timing, Totals, describe,
};

use crate::emit::ModeArg;
use crate::html;
use crate::job::{Job, fail, prepare};
use crate::plot;
use crate::report;
use crate::scratch::{LinesOf, Scratch};
use crate::solve::{IktArgs, MachineArgs};

/// The prediction options, shared by `predict` and the main job.
#[derive(Debug, clap::Args)]
pub(crate) struct PredictionArgs {
    /// The CNC model: `inverse-time` (papers 000/001: block-wise limits, corner rounding, cycle
    /// time, look-ahead over the machine's N blocks) or `vpop` (paper 003: interpolation on the
    /// tool-tip path, per-axis limits through the chain rule, the whole path seen ahead).
    #[arg(long, value_enum, default_value_t = PlannerArg::InverseTime)]
    planner: PlannerArg,
    /// A block is a slowdown below this percentage of its programmed feed.
    #[arg(long, value_name = "PERCENT", default_value_t = 80.0, value_parser = percentage)]
    threshold: f64,
}

impl PredictionArgs {
    /// The threshold as a share of the programmed feed.
    pub(crate) fn threshold(&self) -> f64 {
        self.threshold / 100.0
    }

    fn planner(&self) -> Planner {
        match self.planner {
            PlannerArg::InverseTime => Planner::InverseTime,
            PlannerArg::Vpop => Planner::Vpop,
        }
    }
}

/// Which slowdowns are marked, shared by `predict` and the main job.
#[derive(Debug, clap::Args)]
pub(crate) struct MarkArgs {
    /// A run of blocks below the threshold is marked when it loses at least this many seconds,
    /// the acceleration out of and the braking into exact stops aside.
    #[arg(long, value_name = "SECONDS", default_value_t = 0.05, value_parser = seconds)]
    min_loss: f64,
    /// At most this many marks per operation, the worst kept.
    #[arg(long, value_name = "N", default_value_t = 10)]
    max_marks: usize,
}

impl MarkArgs {
    /// The rules, with the prediction's threshold.
    pub(crate) fn rules(&self, prediction: &PredictionArgs) -> MarkRules {
        MarkRules { threshold: prediction.threshold(), min_loss: self.min_loss, max_per_operation: self.max_marks }
    }
}

fn seconds(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v >= 0.0 && v.is_finite() => Ok(v),
        _ => Err(format!("expected a number of seconds (0 or more), found `{s}`")),
    }
}

/// `--planner`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
enum PlannerArg {
    InverseTime,
    Vpop,
}

fn percentage(s: &str) -> Result<f64, String> {
    match s.trim_end_matches('%').parse::<f64>() {
        Ok(v) if (0.0..=100.0).contains(&v) => Ok(v),
        _ => Err(format!("expected a percentage between 0 and 100, found `{s}`")),
    }
}

/// Arguments of `postpro predict`.
#[derive(Debug, clap::Args)]
pub(crate) struct PredictArgs {
    /// The CL file.
    file: PathBuf,
    #[command(flatten)]
    machine: MachineArgs,
    #[command(flatten)]
    ikt: IktArgs,
    #[command(flatten)]
    setup: crate::setup::SetupArgs,
    /// CL arcs as circular interpolation where they are circles of the program's frame
    /// (`native`), or as straight moves (`linear`), as the main job writes them.
    #[arg(long, value_enum, default_value_t = crate::emit::ArcsArg::Native)]
    arcs: crate::emit::ArcsArg,
    /// Canned cycles as the controller's cycles (`native`) or as moves (`expand`), as the main
    /// job writes them.
    #[arg(long, value_enum, default_value_t = crate::emit::CyclesArg::Native)]
    cycles: crate::emit::CyclesArg,
    /// 3+2 set-ups in the controller's working plane (`cycle`) or as axis values (`joints`), as
    /// the main job writes them.
    #[arg(long, value_enum, default_value_t = crate::emit::PlaneModeArg::Cycle)]
    plane_mode: crate::emit::PlaneModeArg,
    /// The output mode the prediction is for, as the main job's `--mode` (default the same,
    /// `auto`): `g1` (F is the feed of the linear axes), `inverse-time`, `tcp` or `bspline` (F is
    /// the feed of the tool tip).
    #[arg(long, value_enum, default_value_t = ModeArg::Auto)]
    mode: ModeArg,
    #[command(flatten)]
    prediction: PredictionArgs,
    #[command(flatten)]
    marks: MarkArgs,
    /// List every block (default: the totals, the time lost by cause and per operation, and the
    /// worst slowdowns marked).
    #[arg(long)]
    blocks: bool,
    /// Write the samples as CSV to FILE and the per-block results beside it (`FILE` with the
    /// extension `.blocks.csv`).
    #[arg(long, value_name = "FILE")]
    csv: Option<PathBuf>,
    /// Write the totals, the per-block results and the samples as JSON.
    #[arg(long, value_name = "FILE")]
    json: Option<PathBuf>,
    /// Draw programmed against predicted feed along the path, coloured by what limits it, and
    /// the axis velocities, as SVG.
    #[arg(long, value_name = "FILE.svg")]
    plot: Option<PathBuf>,
    /// Write an HTML report: one self-contained file with the plot, the time lost by cause and
    /// per operation, and the slowdowns marked with their CL lines.
    #[arg(long, value_name = "FILE.html")]
    report: Option<PathBuf>,
    /// Sampling period in ms (default: the CNC's interpolation cycle).
    #[arg(long, value_name = "MS", allow_negative_numbers = true)]
    period: Option<f64>,
    /// Print the time the prediction took and its throughput (blocks and samples per second)
    /// to standard error: streamed, the prediction pass's (reading and solving included); and
    /// the peak memory (where the system says it).
    #[arg(long)]
    timing: bool,
}

/// Predicts the motion of a solved job as the program of `mode` asks for it.
pub(crate) fn run(job: &Job, program: &postpro_motion::Program, args: &PredictionArgs, samples: bool) -> Prediction {
    run_with(job, program, args.planner(), args.threshold(), samples, None)
}

fn run_with(
    job: &Job,
    program: &postpro_motion::Program,
    planner: Planner,
    threshold: f64,
    samples: bool,
    period: Option<f64>,
) -> Prediction {
    let options = options(program.mode, planner, threshold, samples, period);
    predict_program(program, job.solver.kinematics(), &options)
}

/// The prediction's options for a program in `mode`, as the command line says.
pub(crate) fn options_for(mode: Mode, args: &PredictionArgs) -> postpro_predict::Options {
    options(mode, args.planner(), args.threshold(), false, None)
}

fn options(
    mode: Mode,
    planner: Planner,
    threshold: f64,
    samples: bool,
    period: Option<f64>,
) -> postpro_predict::Options {
    postpro_predict::Options { planner, threshold, samples, period, splines: mode == Mode::Bspline }
}

/// The prediction of `program` (every in-memory one comes here; a piece the interpolator gave up
/// on is said on standard error, as the streamed passes say it).
fn predict_program(
    program: &postpro_motion::Program,
    kin: &dyn postpro_kin::Kinematics,
    options: &postpro_predict::Options,
) -> Prediction {
    let timing = if program.mode.feeds_the_tip() { Timing::TipFeed } else { Timing::AxisFeed };
    let blocks = postpro_predict::blocks(program, kin.machine(), timing);
    let prediction = postpro_predict::predict(&blocks, kin, options);
    warn_if_abandoned(&prediction.totals());
    prediction
}

/// The prediction of another solved tool path of the same machine (a re-oriented program).
pub(crate) fn run_solved(
    path: &postpro_cl::ToolPath,
    solved: &postpro_kin::Solved,
    kin: &dyn postpro_kin::Kinematics,
    mode: Mode,
    args: &PredictionArgs,
) -> Result<Prediction, postpro_motion::MotionError> {
    let program = crate::job::motion_of(path, solved, kin, mode, crate::job::machine_dialect(kin.machine()))?;
    let options = options(mode, args.planner(), args.threshold(), false, None);
    Ok(predict_program(&program, kin, &options))
}

/// What a mark says after `slowdown #N: `: `38% of F over 12 blocks, C jerk, 0.42 s lost`.
pub(crate) fn mark_text(mark: &Mark, machine: &Machine) -> String {
    let over = if mark.blocks > 1 { format!(" over {} blocks", mark.blocks) } else { String::new() };
    let percent = (mark.ratio * 100.0).floor();
    format!("{percent}% of F{over}, {}, {:.2} s lost", describe(mark.cause, machine), mark.lost)
}

/// The slowdown comments for the NC program: one before the first block of each mark.
pub(crate) fn annotations(marks: &[Mark], machine: &Machine) -> Vec<Annotation> {
    marks
        .iter()
        .map(|m| Annotation {
            step: m.step,
            text: format!("slowdown #{}: {}", m.number, mark_text(m, machine)),
            slowdown: Some(m.number),
        })
        .collect()
}

/// The worst marks, the worst first (at most `count`).
pub(crate) fn worst(marks: &[Mark], count: usize) -> Vec<&Mark> {
    let mut worst: Vec<&Mark> = marks.iter().collect();
    worst.sort_by(|a, b| b.lost.total_cmp(&a.lost).then(a.number.cmp(&b.number)));
    worst.truncate(count);
    worst
}

/// The name an operation is shown with.
pub(crate) fn operation_name(name: &str) -> &str {
    if name.is_empty() { "(unnamed)" } else { name }
}

/// The header summary of the NC program, the marks' CL lines from `source`.
pub(crate) fn header(
    (totals, operations): (&Totals, &[postpro_predict::Operation]),
    args: &PredictionArgs,
    mode: Mode,
    marks: &[Mark],
    (machine, source): (&Machine, &dyn postpro_cl::Locate),
) -> postpro_emit::Prediction {
    postpro_emit::Prediction {
        cycle_time: totals.cycle_time,
        time_lost: totals.time_lost,
        threshold: args.threshold(),
        share_below: totals.share_below(),
        planner: planner_name(effective(args.planner(), mode)).to_string(),
        slowdowns: marks.len(),
        operations: operations
            .iter()
            .map(|o| postpro_emit::OperationPrediction {
                // A name is one comment's worth: cut where a line could grow too long.
                name: o.name.chars().take(64).collect(),
                cycle_time: o.cycle_time,
                programmed_time: o.programmed_time,
                time_lost: o.time_lost,
                cause: describe(o.main_cause(), machine),
            })
            .collect(),
        worst: worst(marks, 5)
            .into_iter()
            .map(|m| postpro_emit::MarkedSlowdown {
                number: m.number,
                step: m.step,
                line: source.line_col(m.span.start as usize).line,
                nc_line: None,
                nc_block: None,
                time_lost: m.lost,
                text: mark_text(m, machine),
            })
            .collect(),
    }
}

/// The planner that runs: B-spline output is always followed with VPOp (the block-wise model has
/// no splines).
fn effective(planner: Planner, mode: Mode) -> Planner {
    if mode == Mode::Bspline { Planner::Vpop } else { planner }
}

fn planner_name(p: Planner) -> &'static str {
    match p {
        Planner::InverseTime => "inverse-time",
        Planner::Vpop => "vpop",
    }
}

/// `postpro predict`.
/// What an error of `postpro predict` says was not done.
pub(crate) const PREDICTED: &str = "nothing predicted";

pub(crate) fn main(args: &PredictArgs) -> ExitCode {
    let chosen = match args.machine.choose() {
        Ok(c) => c,
        Err(code) => return code,
    };
    if let Some(ms) = args.period
        && !(ms > 0.0 && ms.is_finite())
    {
        return fail(&format!("error: --period must be a positive number of ms, found {ms}\n"), 2);
    }
    let dialect = crate::job::machine_dialect(&chosen.machine);
    let shapes = crate::job::Shapes {
        linear_arcs: args.arcs == crate::emit::ArcsArg::Linear,
        expand_cycles: args.cycles == crate::emit::CyclesArg::Expand,
        planes: args.plane_mode == crate::emit::PlaneModeArg::Cycle,
    };
    // The figures, the block rows and the CSV files stream; every block's results or samples are
    // held for the other exports, and for the CSV files where they are a device or a pipe
    // (written in place).
    let csv_whole = args.csv.as_ref().is_some_and(|path| {
        crate::emit::is_special_file(path) || crate::emit::is_special_file(&path.with_extension("blocks.csv"))
    });
    let whole =
        csv_whole || args.json.is_some() || args.plot.is_some() || args.report.is_some() || args.period.is_some();
    if !whole {
        return streamed(args, &chosen, dialect, shapes);
    }
    let job = match prepare(&args.file, &chosen, &args.ikt, &args.setup, (args.mode, dialect), PREDICTED) {
        Ok(job) => job,
        Err(code) => return code,
    };
    let samples = args.csv.is_some() || args.json.is_some() || args.plot.is_some() || args.report.is_some();
    let mode = job.mode;
    let planner = effective(args.prediction.planner(), mode);
    let program = match job.motion(crate::job::machine_dialect(&job.machine), shapes) {
        Ok(program) => program,
        Err(code) => return code,
    };
    let started = std::time::Instant::now();
    let prediction =
        run_with(&job, &program, planner, args.prediction.threshold(), samples, args.period.map(|ms| ms / 1000.0));
    if args.timing {
        print_timing(prediction.blocks.len(), prediction.totals().samples, started.elapsed().as_secs_f64());
    }
    let machine = &job.machine;
    let marks = prediction.marks(&args.marks.rules(&args.prediction));
    let run = Run { prediction: &prediction, marks: &marks, machine, job: &job, args, planner };
    // Every export is made first, then all are written together: a failure leaves none.
    let mut exports: Vec<(PathBuf, String)> = Vec::new();
    if let Some(path) = &args.csv {
        exports.push((path.clone(), samples_csv(&prediction, machine)));
        exports.push((path.with_extension("blocks.csv"), blocks_csv(&prediction, machine, &job)));
    }
    if let Some(path) = &args.json {
        exports.push((path.clone(), json(&run)));
    }
    let svg = match (&args.plot, &args.report) {
        (None, None) => None,
        (plot, report) => match plot::render(&plot_report(&run)) {
            Ok(svg) => Some(svg),
            Err(e) => {
                let path = plot.as_ref().or(report.as_ref()).map(|p| p.display().to_string()).unwrap_or_default();
                return fail(&format!("error: cannot draw {path}: {e}\n"), 1);
            }
        },
    };
    if let (Some(path), Some(svg)) = (&args.plot, &svg) {
        exports.push((path.clone(), svg.clone()));
    }
    if let (Some(path), Some(svg)) = (&args.report, &svg) {
        exports.push((path.clone(), html::report(&html_report(&run, svg))));
    }
    if let Err(message) = write_all(&exports) {
        return fail(&message, 1);
    }
    let mark_lines: Vec<usize> = marks.iter().map(|m| line(&job, prediction.blocks[m.first].step)).collect();
    let note_lines: Vec<usize> = prediction.notes.iter().map(|n| line(&job, n.step)).collect();
    let figures = Figures {
        name: job.source.name(),
        machine,
        planner,
        mode,
        blocks: prediction.blocks.len(),
        prediction: &prediction,
        marks: &marks,
        mark_lines: &mark_lines,
        note_lines: &note_lines,
        args,
        every_block: Some(&job),
    };
    report::print_stdout(&table(&figures))
}

/// `postpro predict` streamed (`stream::predict`): the figures without the exports.
fn streamed(
    args: &PredictArgs,
    chosen: &crate::solve::Chosen,
    dialect: &postpro_emit::Dialect,
    shapes: crate::job::Shapes,
) -> ExitCode {
    let request = crate::stream::Request {
        purpose: crate::stream::Purpose::Prediction { every_block: args.blocks, csv: args.csv.as_deref() },
        file: &args.file,
        chosen,
        ikt: &args.ikt,
        setup: &args.setup,
        mode: args.mode,
        dialect,
        shapes,
        prediction: Some((&args.prediction, &args.marks)),
    };
    let s = match crate::stream::predict(&request) {
        Ok(streamed) => streamed,
        Err(code) => return code,
    };
    if args.timing {
        print_timing(s.blocks, s.prediction.totals().samples, s.seconds);
    }
    if let Some(csv) = s.csv
        && let Err(message) = csv.keep()
    {
        return fail(&message, 1);
    }
    let figures = Figures {
        name: &s.name,
        machine: &s.machine,
        planner: effective(args.prediction.planner(), s.mode),
        mode: s.mode,
        blocks: s.blocks,
        prediction: &s.prediction,
        marks: &s.marks,
        mark_lines: &s.mark_lines,
        note_lines: &s.note_lines,
        args,
        every_block: None,
    };
    match s.rows {
        Some(rows) => rows.print_after(&table(&figures)),
        None => report::print_stdout(&table(&figures)),
    }
}

/// Says on standard error that the interpolator gave up on pieces of the path, if it did: a
/// loop that did not end is a bug, and the times there are not the machine's.
pub(crate) fn warn_if_abandoned(totals: &postpro_predict::Totals) {
    if totals.abandoned > 0 {
        eprintln!(
            "warning: the prediction gave up on {} piece(s) of the path, where its interpolator did not come to an end \
             (a bug in postpro): the predicted times there are not the machine's; please report it with the CL file",
            totals.abandoned
        );
    }
}

/// `--timing`: the prediction's throughput and the peak memory, on standard error.
fn print_timing(blocks: usize, samples: u64, seconds: f64) {
    let (blocks, steps) = (blocks as f64, samples as f64);
    eprintln!(
        "predicted {blocks} blocks, {steps} samples in {seconds:.3} s: {:.2} M blocks/s, {:.2} M samples/s \
         ({:.0} ns per block, {:.0} ns per sample){}",
        blocks / seconds / 1e6,
        steps / seconds / 1e6,
        seconds / blocks.max(1.0) * 1e9,
        seconds / steps.max(1.0) * 1e9,
        crate::memory::peak_note()
    );
}

/// What the table shows of a prediction, whole or streamed.
struct Figures<'a> {
    /// The CL file's name.
    name: &'a str,
    machine: &'a Machine,
    planner: Planner,
    mode: Mode,
    /// The blocks predicted.
    blocks: usize,
    /// Its totals, operations and notes (and, whole, every block's results).
    prediction: &'a Prediction,
    marks: &'a [Mark],
    /// The CL line of each mark and of each note.
    mark_lines: &'a [usize],
    note_lines: &'a [usize],
    args: &'a PredictArgs,
    /// The job whose blocks `--blocks` lists (the whole-path prediction).
    every_block: Option<&'a Job>,
}

/// One prediction with what the outputs need to describe it.
struct Run<'a> {
    prediction: &'a Prediction,
    marks: &'a [Mark],
    machine: &'a Machine,
    job: &'a Job,
    args: &'a PredictArgs,
    planner: Planner,
}

/// Writes every `(path, text)`: each to a temporary file beside its target, then, once all are
/// written, each renamed over its target (a device or a pipe is written in place). On an error
/// no regular target is touched and the temporary files are removed.
fn write_all(files: &[(PathBuf, String)]) -> Result<(), String> {
    let mut staged: Vec<(PathBuf, &Path)> = Vec::new();
    let remove = |staged: &[(PathBuf, &Path)]| {
        for (temp, _) in staged {
            let _ = std::fs::remove_file(temp);
        }
    };
    for (path, text) in files {
        if crate::emit::is_special_file(path) {
            continue; // written in place below
        }
        let dir = path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
        let name = path.file_name().map_or_else(|| "export".into(), |n| n.to_string_lossy().into_owned());
        let temp = dir.join(format!(".{name}.postpro-{}.tmp", std::process::id()));
        if let Err(e) = std::fs::write(&temp, text) {
            remove(&staged);
            return Err(format!("error: cannot write {}: {e}\n", path.display()));
        }
        staged.push((temp, path));
    }
    for (path, text) in files.iter().filter(|(path, _)| crate::emit::is_special_file(path)) {
        if let Err(e) = std::fs::OpenOptions::new()
            .write(true)
            .open(path)
            .and_then(|mut f| std::io::Write::write_all(&mut f, text.as_bytes()))
        {
            remove(&staged);
            return Err(format!("error: cannot write {}: {e}\n", path.display()));
        }
    }
    for (i, (temp, path)) in staged.iter().enumerate() {
        if let Err(e) = std::fs::rename(temp, path) {
            remove(&staged[i..]);
            return Err(format!("error: cannot write {}: {e}\n", path.display()));
        }
    }
    Ok(())
}

/// The CL line (1-based) of a block: of the CL item it comes from (a program's last retract, of
/// its end), as the marks and the streamed `--blocks` say it.
fn block_line(job: &Job, b: &BlockResult) -> usize {
    job.source.line_col(b.span.start as usize).line
}

/// The CL line (1-based) of a step.
fn line(job: &Job, step: usize) -> usize {
    job.source.line_col(job.solved.steps[step].span.start as usize).line
}

/// An axis value in its NC unit (mm, degrees).
fn nc(machine: &Machine, axis: usize, v: f64) -> f64 {
    let v = if machine.axes[axis].kind == AxisKind::Rotary { v.to_degrees() } else { v };
    if v == 0.0 { 0.0 } else { v }
}

fn kind_name(kind: BlockKind) -> &'static str {
    match kind {
        BlockKind::Feed => "feed",
        BlockKind::Reorientation => "reorientation",
        BlockKind::Rapid => "rapid",
    }
}

/// The causes worth a row: those under 5 ms that are no block's main cause are left out.
fn shown_causes(causes: &[Cause]) -> impl Iterator<Item = &Cause> {
    causes.iter().filter(|c| c.blocks > 0 || c.seconds.abs() >= 0.005)
}

/// The time lost by cause as table rows (cause, seconds, blocks: those it is the main cause of),
/// then their total.
fn cause_rows(out: &mut String, causes: &[Cause], machine: &Machine) {
    for c in shown_causes(causes) {
        let _ = writeln!(out, "  {:<24} {:>9.2} s  {:>8} blocks", describe(c.limit, machine), c.seconds, c.blocks);
    }
    let _ = writeln!(out, "  {:<24} {:>9.2} s", "total", causes.iter().map(|c| c.seconds).sum::<f64>());
}

/// The program's figures as a terminal table.
fn table(figures: &Figures<'_>) -> String {
    let Figures { name, machine, planner, mode, blocks, prediction, marks, args, .. } = *figures;
    let totals = prediction.totals();
    let mut out = String::new();
    let threshold = args.prediction.threshold;
    let _ = writeln!(
        out,
        "{name} on {} ({} planner, {} mode, {blocks} blocks)",
        machine.name,
        planner_name(planner),
        mode.name(),
    );
    let _ = writeln!(out, "predicted cycle time   {:>10.2} s", totals.cycle_time);
    let _ = writeln!(out, "at the programmed feed {:>10.2} s", totals.programmed_time);
    let _ = writeln!(out, "lost to slowdowns      {:>10.2} s", totals.time_lost);
    let _ = writeln!(
        out,
        "feed path below {threshold}%   {:>9.1} % of {:.1} mm",
        totals.share_below() * 100.0,
        totals.feed_length
    );
    let causes = prediction.causes();
    if !causes.is_empty() {
        let _ = writeln!(out, "\ntime lost by cause            seconds  main cause of");
        cause_rows(&mut out, &causes, machine);
    }
    if !prediction.operations.is_empty() {
        let _ = writeln!(out, "\n  operation                  predicted s  programmed s     lost s  mostly");
        for o in &prediction.operations {
            let _ = writeln!(
                out,
                "  {:<24} {:>13.2} {:>13.2} {:>10.2}  {}",
                operation_name(&o.name),
                o.cycle_time,
                o.programmed_time,
                o.time_lost,
                describe(o.main_cause(), machine)
            );
        }
    }
    for (note, line) in prediction.notes.iter().zip(figures.note_lines) {
        let _ = writeln!(out, "note: line {line}: {}", note.text);
    }
    if args.blocks {
        out.push_str(BLOCKS_HEADER);
        if let Some(job) = figures.every_block {
            for (i, b) in prediction.blocks.iter().enumerate() {
                block_row(&mut out, i, block_line(job, b), b, machine);
            }
        }
    } else if !marks.is_empty() {
        let rules = args.marks.rules(&args.prediction);
        let worst = worst(marks, 10);
        let _ = writeln!(
            out,
            "\n{} slowdowns marked (below {threshold}% of F and {} s lost, exact stops, plunges and retracts aside; \
             at most {} per operation); the worst {}:",
            marks.len(),
            rules.min_loss,
            rules.max_per_operation,
            worst.len()
        );
        let _ = writeln!(out, "   mark     line  blocks  lowest   lost s  cause                     operation");
        for m in worst {
            let at = marks.iter().position(|x| std::ptr::eq(x, m));
            let line = at.and_then(|i| figures.mark_lines.get(i)).copied().unwrap_or_default();
            let _ = writeln!(
                out,
                "{:>7} {:>8} {:>7} {:>6}% {:>8.2}  {:<24}  {}",
                format!("#{}", m.number),
                line,
                m.blocks,
                (m.ratio * 100.0).floor(),
                m.lost,
                describe(m.cause, machine),
                operation_name(&prediction.operations[m.operation].name)
            );
        }
    }
    out
}

/// The head of `--blocks`'s rows, after the table.
const BLOCKS_HEADER: &str =
    "\n  block    line  kind            length mm  F mm/min    min mm/min  mean mm/min   time s   lost s  limit\n";

/// The row of `--blocks` of block `i` (from 0), on CL line `line`.
fn block_row(out: &mut String, i: usize, line: usize, b: &BlockResult, machine: &Machine) {
    let _ = writeln!(
        out,
        "{:>7} {:>7}  {:<14} {:>10.3} {:>9.0} {:>12.0} {:>12.0} {:>8.4} {:>8.4}  {}",
        i + 1,
        line,
        kind_name(b.kind),
        b.length,
        b.programmed,
        b.min_feed,
        b.mean_feed,
        b.time,
        b.lost,
        describe(b.limit, machine)
    );
}

/// Each block's row as the prediction makes it final, in a scratch file until the prediction is
/// whole (a million blocks are a hundred megabytes of rows), its CL line read on in the CL file
/// as the blocks come: `--blocks` streamed, and the blocks' CSV of `--csv`. The first error is
/// kept and said at the end.
pub(crate) struct BlockRows<'a> {
    file: &'a postpro_cl::ClFile,
    scratch: Option<Scratch>,
    lines: LinesOf,
    /// Formats the row of block `i` (from 0) on a CL line.
    row: fn(&mut String, usize, usize, &BlockResult, &Machine),
    /// The rows written.
    count: usize,
    /// What an error says cannot be written.
    what: String,
    failed: Option<String>,
}

impl<'a> BlockRows<'a> {
    /// The rows of `--blocks` for the program of `file`, in the temporary folder.
    pub(crate) fn table(file: &'a postpro_cl::ClFile) -> BlockRows<'a> {
        let made = Scratch::new("predict.blocks")
            .map_err(|e| format!("error: cannot make a scratch file for the block rows: {e}\n"));
        BlockRows::with(file, made, block_row, "the block rows".into())
    }

    /// The blocks' CSV of the program of `file`, beside `target`.
    fn csv(file: &'a postpro_cl::ClFile, target: &Path) -> BlockRows<'a> {
        let what = target.display().to_string();
        let made = Scratch::beside(target)
            .map(|mut scratch| {
                scratch.text.push_str(BLOCKS_CSV_HEADER);
                scratch
            })
            .map_err(|e| format!("error: cannot write {what}: {e}\n"));
        BlockRows::with(file, made, block_csv_row, what)
    }

    fn with(
        file: &'a postpro_cl::ClFile,
        made: Result<Scratch, String>,
        row: fn(&mut String, usize, usize, &BlockResult, &Machine),
        what: String,
    ) -> BlockRows<'a> {
        let (scratch, failed) = match made {
            Ok(scratch) => (Some(scratch), None),
            Err(e) => (None, Some(e)),
        };
        BlockRows { file, scratch, lines: LinesOf::default(), row, count: 0, what, failed }
    }

    /// The row of the next block, final.
    pub(crate) fn push(&mut self, b: &BlockResult, machine: &Machine) {
        let Some(scratch) = self.scratch.as_mut().filter(|_| self.failed.is_none()) else { return };
        let written = self.lines.line_col(self.file, b.span.start).and_then(|at| {
            (self.row)(&mut scratch.text, self.count, at.line, b, machine);
            self.count += 1;
            flush_now_and_then(scratch)
        });
        if let Err(e) = written {
            self.failed = Some(format!("error: cannot write {}: {e}\n", self.what));
        }
    }

    /// The rows, or the first error.
    pub(crate) fn finish(self) -> Result<Scratch, String> {
        match (self.failed, self.scratch) {
            (None, Some(scratch)) => Ok(scratch),
            (failed, _) => Err(failed.unwrap_or_default()),
        }
    }
}

/// Writes a scratch file's rows on once they are some 64 kB.
fn flush_now_and_then(scratch: &mut Scratch) -> std::io::Result<()> {
    if scratch.text.len() < 1 << 16 { Ok(()) } else { scratch.flush_text() }
}

/// `--csv` streamed: the samples' rows as the prediction takes them and the blocks' as it makes
/// them final ([`BlockRows`]), each in a file beside its target, renamed over it once the
/// prediction is whole ([`CsvFiles::keep`]): an error leaves neither. The first error is kept and
/// said at the end.
pub(crate) struct CsvRows<'a> {
    samples: Option<Scratch>,
    samples_path: PathBuf,
    blocks: BlockRows<'a>,
    blocks_path: PathBuf,
    failed: Option<String>,
}

/// The two CSV files of `--csv`, written, to be put in place.
pub(crate) struct CsvFiles {
    samples: (Scratch, PathBuf),
    blocks: (Scratch, PathBuf),
}

impl CsvFiles {
    /// Renames both over their targets.
    pub(crate) fn keep(self) -> Result<(), String> {
        for (scratch, target) in [self.samples, self.blocks] {
            scratch.keep_as(&target).map_err(|e| format!("error: cannot write {}: {e}\n", target.display()))?;
        }
        Ok(())
    }
}

impl<'a> CsvRows<'a> {
    /// The rows of the program of `file` on `machine`, for the samples' CSV `path` (the blocks'
    /// beside it, `.blocks.csv`).
    pub(crate) fn new(file: &'a postpro_cl::ClFile, path: &Path, machine: &Machine) -> CsvRows<'a> {
        let blocks_path = path.with_extension("blocks.csv");
        let (samples, failed) = match Scratch::beside(path) {
            Ok(mut scratch) => {
                scratch.text = samples_header(machine);
                (Some(scratch), None)
            }
            Err(e) => (None, Some(format!("error: cannot write {}: {e}\n", path.display()))),
        };
        let blocks = BlockRows::csv(file, &blocks_path);
        CsvRows { samples, samples_path: path.to_path_buf(), blocks, blocks_path, failed }
    }

    /// The rows of the samples taken since the last call.
    pub(crate) fn samples(&mut self, samples: &postpro_predict::Samples, machine: &Machine) {
        let Some(scratch) = self.samples.as_mut().filter(|_| self.failed.is_none()) else { return };
        sample_rows(&mut scratch.text, samples, machine);
        if let Err(e) = flush_now_and_then(scratch) {
            self.failed = Some(format!("error: cannot write {}: {e}\n", self.samples_path.display()));
        }
    }

    /// The row of the next block, final.
    pub(crate) fn block(&mut self, b: &BlockResult, machine: &Machine) {
        self.blocks.push(b, machine);
    }

    /// The files, or the first error.
    pub(crate) fn finish(self) -> Result<CsvFiles, String> {
        let blocks = self.blocks.finish();
        match (self.failed, self.samples) {
            (None, Some(samples)) => {
                Ok(CsvFiles { samples: (samples, self.samples_path), blocks: (blocks?, self.blocks_path) })
            }
            (failed, _) => Err(failed.unwrap_or_default()),
        }
    }
}

fn limit_names(prediction: &Prediction) -> Vec<Limit> {
    let mut seen: Vec<Limit> = Vec::new();
    if let Some(s) = &prediction.samples {
        for l in &s.limit {
            if !seen.contains(l) {
                seen.push(*l);
            }
        }
    }
    seen.sort();
    seen
}

fn samples_csv(prediction: &Prediction, machine: &Machine) -> String {
    let Some(s) = &prediction.samples else { return String::new() };
    let mut out = samples_header(machine);
    sample_rows(&mut out, s, machine);
    out
}

/// The header row of the samples' CSV.
fn samples_header(machine: &Machine) -> String {
    let mut out = String::from("time_s,path_mm,block,programmed_mm_min,feed_mm_min,relative_feed_mm_min,limit");
    let unit = |i: usize| if machine.axes[i].kind == AxisKind::Rotary { "deg" } else { "mm" };
    for what in ["", "_per_s", "_per_s2", "_per_s3"] {
        for (i, a) in machine.axes.iter().enumerate() {
            let name = match what {
                "" => "pos",
                "_per_s" => "vel",
                "_per_s2" => "acc",
                _ => "jerk",
            };
            let _ = write!(out, ",{}_{name}_{}{what}", a.letter, unit(i));
        }
    }
    out.push('\n');
    out
}

/// The CSV rows of samples `s`.
fn sample_rows(out: &mut String, s: &postpro_predict::Samples, machine: &Machine) {
    let n = s.axes;
    for r in 0..s.len() {
        let _ = write!(
            out,
            "{:.6},{:.4},{},{:.1},{:.2},{:.2},{}",
            s.time[r],
            s.path[r],
            s.block[r] + 1,
            s.programmed[r],
            s.feed[r],
            s.relative_feed[r],
            describe(s.limit[r], machine)
        );
        for column in [&s.position, &s.velocity, &s.acceleration, &s.jerk] {
            for i in 0..n {
                out.push(',');
                postpro_emit::push_number(out, nc(machine, i, column[r * n + i]), 6, false);
            }
        }
        out.push('\n');
    }
}

fn blocks_csv(prediction: &Prediction, machine: &Machine, job: &Job) -> String {
    let mut out = String::from(BLOCKS_CSV_HEADER);
    for (i, b) in prediction.blocks.iter().enumerate() {
        block_csv_row(&mut out, i, block_line(job, b), b, machine);
    }
    out
}

/// The header row of the blocks' CSV.
const BLOCKS_CSV_HEADER: &str = "block,line,kind,length_mm,programmed_mm_min,min_feed_mm_min,mean_feed_mm_min,time_s,\
                                 limit,time_lost_s,stop_lost_s,cause,operation\n";

/// The CSV row of block `i` (from 0), on CL line `line`.
fn block_csv_row(out: &mut String, i: usize, line: usize, b: &BlockResult, machine: &Machine) {
    let _ = writeln!(
        out,
        "{},{},{},{:.4},{:.1},{:.2},{:.2},{:.6},{},{:.6},{:.6},{},{}",
        i + 1,
        line,
        kind_name(b.kind),
        b.length,
        b.programmed,
        b.min_feed,
        b.mean_feed,
        b.time,
        describe(b.limit, machine),
        b.lost,
        b.stop_lost,
        describe(b.cause, machine),
        b.operation + 1
    );
}

fn causes_json(causes: &[Cause], machine: &Machine) -> Vec<serde_json::Value> {
    causes
        .iter()
        .map(|c| serde_json::json!({ "cause": describe(c.limit, machine), "time_lost_s": c.seconds, "blocks": c.blocks }))
        .collect()
}

fn json(run: &Run<'_>) -> String {
    use serde_json::{Value, json};
    let Run { prediction, marks, machine, job, planner, .. } = *run;
    let t = prediction.totals();
    let blocks: Vec<Value> = prediction
        .blocks
        .iter()
        .enumerate()
        .map(|(i, b)| {
            json!({
                "block": i + 1, "line": block_line(job, b), "kind": kind_name(b.kind), "length_mm": b.length,
                "programmed_mm_min": b.programmed, "min_feed_mm_min": b.min_feed, "mean_feed_mm_min": b.mean_feed,
                "time_s": b.time, "limit": describe(b.limit, machine), "time_lost_s": b.lost,
                "stop_lost_s": b.stop_lost, "cause": describe(b.cause, machine),
                "min_feed_between_stops_mm_min": b.min_feed_between_stops,
                "operation": b.operation + 1,
            })
        })
        .collect();
    let operations: Vec<Value> = prediction
        .operations
        .iter()
        .enumerate()
        .map(|(i, o)| {
            json!({
                "operation": i + 1, "name": o.name, "first_block": o.first + 1, "last_block": o.last + 1,
                "cycle_time_s": o.cycle_time, "programmed_time_s": o.programmed_time, "time_lost_s": o.time_lost,
                "cause": describe(o.main_cause(), machine), "causes": causes_json(&o.causes, machine),
            })
        })
        .collect();
    let marks: Vec<Value> = marks
        .iter()
        .map(|m| {
            json!({
                "number": m.number, "first_block": m.first + 1, "last_block": m.last + 1,
                "line": line(job, prediction.blocks[m.first].step), "blocks": m.blocks, "lowest_share": m.ratio,
                "cause": describe(m.cause, machine), "time_lost_s": m.lost, "operation": m.operation + 1,
                "text": format!("slowdown #{}: {}", m.number, mark_text(m, machine)),
            })
        })
        .collect();
    let samples = prediction.samples.as_ref().map(|s| {
        let n = s.axes;
        let column =
            |data: &Vec<f64>, i: usize| -> Vec<f64> { (0..s.len()).map(|r| nc(machine, i, data[r * n + i])).collect() };
        let axes: Vec<Value> = machine
            .axes
            .iter()
            .enumerate()
            .map(|(i, a)| {
                json!({
                    "letter": a.letter, "unit": if a.kind == AxisKind::Rotary { "deg" } else { "mm" },
                    "position": column(&s.position, i), "velocity": column(&s.velocity, i),
                    "acceleration": column(&s.acceleration, i), "jerk": column(&s.jerk, i),
                })
            })
            .collect();
        json!({
            "time_s": s.time, "path_mm": s.path, "block": s.block.iter().map(|b| b + 1).collect::<Vec<_>>(),
            "programmed_mm_min": s.programmed, "feed_mm_min": s.feed, "relative_feed_mm_min": s.relative_feed,
            "limit": s.limit.iter().map(|l| describe(*l, machine)).collect::<Vec<_>>(),
            "axes": axes,
        })
    });
    let doc = json!({
        "file": job.source.name(), "machine": machine.name, "planner": planner_name(planner),
        "totals": {
            "cycle_time_s": t.cycle_time, "programmed_time_s": t.programmed_time, "time_lost_s": t.time_lost,
            "feed_length_mm": t.feed_length, "length_below_mm": t.length_below, "threshold": t.threshold,
            "share_below": t.share_below(), "causes": causes_json(&prediction.causes(), machine),
        },
        "operations": operations,
        "marks": marks,
        "notes": prediction.notes.iter().map(|n| json!({ "line": line(job, n.step), "text": n.text })).collect::<Vec<_>>(),
        "blocks": blocks,
        "samples": samples,
    });
    let mut text = serde_json::to_string(&doc).unwrap_or_default();
    text.push('\n');
    text
}

/// The plot: along the feed path (rapids take no room: each is a tick where it was left out),
/// the operations where they start, the worst slowdowns with their numbers.
fn plot_report(run: &Run<'_>) -> plot::Report {
    let Run { prediction, marks, machine, job, .. } = *run;
    let empty = postpro_predict::Samples::default();
    let s = prediction.samples.as_ref().unwrap_or(&empty);
    // The feed path length at the start of each block: rapids left out.
    let mut feed_start = Vec::with_capacity(prediction.blocks.len());
    let mut x = 0.0;
    for b in &prediction.blocks {
        feed_start.push(x);
        if b.kind != BlockKind::Rapid {
            x += b.length;
        }
    }
    let path_start: Vec<f64> = prediction
        .blocks
        .iter()
        .scan(0.0, |at, b| {
            let start = *at;
            *at += b.length;
            Some(start)
        })
        .collect();
    let rapid = |r: usize| prediction.blocks[s.block[r] as usize].kind == BlockKind::Rapid;
    let path_mm: Vec<f64> = (0..s.len())
        .map(|r| {
            let b = s.block[r] as usize;
            if rapid(r) { f64::NAN } else { feed_start[b] + (s.path[r] - path_start[b]) }
        })
        .collect();
    // A tick per run of rapids, where the feed path goes on.
    let mut rapids = Vec::new();
    for (i, b) in prediction.blocks.iter().enumerate() {
        if b.kind == BlockKind::Rapid && (i == 0 || prediction.blocks[i - 1].kind != BlockKind::Rapid) {
            rapids.push(feed_start[i]);
        }
    }
    let operations =
        prediction.operations.iter().map(|o| (feed_start[o.first], operation_name(&o.name).to_string())).collect();
    // The worst marks at their lowest feed.
    let marked = worst(marks, 10)
        .into_iter()
        .map(|m| {
            let lowest = (m.first..=m.last)
                .filter(|&i| prediction.blocks[i].kind == BlockKind::Feed)
                .min_by(|&a, &b| {
                    let ratio = |i: usize| prediction.blocks[i].min_ratio_between_stops();
                    ratio(a).total_cmp(&ratio(b))
                })
                .unwrap_or(m.first);
            let b = &prediction.blocks[lowest];
            (feed_start[lowest] + b.length / 2.0, b.min_feed_between_stops, m.number)
        })
        .collect();
    let names = limit_names(prediction);
    let n = s.axes;
    let axes = machine
        .axes
        .iter()
        .enumerate()
        .map(|(i, a)| plot::AxisSeries {
            letter: a.letter.clone(),
            rotary: a.kind == AxisKind::Rotary,
            velocity: (0..s.len()).map(|r| nc(machine, i, s.velocity[r * n + i]) * 60.0).collect(),
        })
        .collect();
    let t = prediction.totals();
    plot::Report {
        title: format!("{} on {}", job.source.name(), machine.name),
        subtitle: format!(
            "predicted cycle time {:.2} s ({:.2} s at the programmed feed, {:.2} s lost), {:.1} % of the feed path \
             below {:.0} %",
            t.cycle_time,
            t.programmed_time,
            t.time_lost,
            t.share_below() * 100.0,
            t.threshold * 100.0
        ),
        path_mm,
        programmed: s.programmed.clone(),
        predicted: s.feed.clone(),
        relative: Some(s.relative_feed.clone()),
        limiter: s.limit.iter().map(|l| names.iter().position(|x| x == l).unwrap_or(0) as u16).collect(),
        limiter_names: names.iter().map(|l| describe(*l, machine)).collect(),
        axes,
        rapids,
        operations,
        marks: marked,
    }
}

/// The HTML report's content.
fn html_report(run: &Run<'_>, svg: &str) -> html::Report {
    let Run { prediction, marks, machine, job, args, planner } = *run;
    let t = prediction.totals();
    let rules = args.marks.rules(&args.prediction);
    html::Report {
        title: format!("{} on {}", job.source.name(), machine.name),
        setup: format!(
            "{} planner, {} mode, {} blocks; a slowdown is marked below {}% of F with at least {} s lost, exact \
             stops, plunges and retracts aside, at most {} per operation",
            planner_name(planner),
            job.mode.name(),
            prediction.blocks.len(),
            args.prediction.threshold,
            rules.min_loss,
            rules.max_per_operation
        ),
        totals: vec![
            ("predicted cycle time".into(), format!("{:.2} s", t.cycle_time)),
            ("at the programmed feed".into(), format!("{:.2} s", t.programmed_time)),
            ("lost to slowdowns".into(), format!("{:.2} s", t.time_lost)),
            (
                format!("feed path below {}%", args.prediction.threshold),
                format!("{:.1} % of {:.1} mm", t.share_below() * 100.0, t.feed_length),
            ),
            ("slowdowns marked".into(), marks.len().to_string()),
        ],
        causes: shown_causes(&prediction.causes()).map(|c| (describe(c.limit, machine), c.seconds, c.blocks)).collect(),
        operations: prediction
            .operations
            .iter()
            .map(|o| html::OperationRow {
                name: operation_name(&o.name).to_string(),
                cycle_time: o.cycle_time,
                programmed_time: o.programmed_time,
                time_lost: o.time_lost,
                cause: describe(o.main_cause(), machine),
            })
            .collect(),
        marks: worst(marks, marks.len())
            .into_iter()
            .map(|m| html::MarkRow {
                number: m.number,
                line: line(job, prediction.blocks[m.first].step),
                operation: operation_name(&prediction.operations[m.operation].name).to_string(),
                text: mark_text(m, machine),
                time_lost: m.lost,
            })
            .collect(),
        notes: prediction.notes.iter().map(|n| format!("line {}: {}", line(job, n.step), n.text)).collect(),
        svg: svg.to_string(),
    }
}
