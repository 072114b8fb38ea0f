//! `postpro predict FILE.cl --machine NAME`: the feed the machine will really reach. A table in
//! the terminal (totals, time lost by cause, the worst slowdowns, `--blocks` for every block),
//! the samples and per-block results as CSV (`--csv`) or JSON (`--json`), and an SVG report
//! (`--plot`). The main job uses the same prediction to mark slowdowns in the NC program.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use postpro_emit::{Annotation, Mode};
use postpro_machine::model::{AxisKind, Machine};
use postpro_predict::{BlockKind, Limit, Planner, Prediction, Timing, describe};

use crate::emit::ModeArg;
use crate::job::{Job, fail, prepare};
use crate::plot;
use crate::report;
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
    /// The output mode the prediction is for, as the main job's `--mode` (default the same, g1):
    /// `g1` (F is the feed of the linear axes), `inverse-time`, `tcp` or `bspline` (F is the feed
    /// of the tool tip).
    #[arg(long, value_enum, default_value_t = ModeArg::G1)]
    mode: ModeArg,
    #[command(flatten)]
    prediction: PredictionArgs,
    /// List every block (default: the totals, the time lost by cause and the worst slowdowns).
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
    /// Sampling period in ms (default: the CNC's interpolation cycle).
    #[arg(long, value_name = "MS", allow_negative_numbers = true)]
    period: Option<f64>,
    /// Print the time the prediction took and its throughput (blocks and samples per second)
    /// to standard error.
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

fn options(
    mode: Mode,
    planner: Planner,
    threshold: f64,
    samples: bool,
    period: Option<f64>,
) -> postpro_predict::Options {
    postpro_predict::Options { planner, threshold, samples, period, splines: mode == Mode::Bspline }
}

fn predict_program(
    program: &postpro_motion::Program,
    kin: &dyn postpro_kin::Kinematics,
    options: &postpro_predict::Options,
) -> Prediction {
    let timing = if program.mode.feeds_the_tip() { Timing::TipFeed } else { Timing::AxisFeed };
    let blocks = postpro_predict::blocks(program, kin.machine(), timing);
    postpro_predict::predict(&blocks, kin, options)
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

/// The slowdown comments for the NC program: one per run of blocks below the threshold.
pub(crate) fn annotations(prediction: &Prediction, machine: &Machine, threshold: f64) -> Vec<Annotation> {
    prediction
        .slowdowns(threshold)
        .into_iter()
        .map(|s| {
            let blocks = s.last - s.first + 1;
            let over = if blocks > 1 { format!(" over {blocks} blocks") } else { String::new() };
            let percent = (s.ratio * 100.0).floor();
            Annotation {
                step: prediction.blocks[s.first].step,
                text: format!("slowdown {percent}% of F{over}, {}", describe(s.limit, machine)),
            }
        })
        .collect()
}

/// The header summary of the NC program.
pub(crate) fn header(
    prediction: &Prediction,
    args: &PredictionArgs,
    mode: Mode,
    count: usize,
) -> postpro_emit::Prediction {
    let totals = prediction.totals();
    postpro_emit::Prediction {
        cycle_time: totals.cycle_time,
        time_lost: totals.time_lost.max(0.0),
        threshold: args.threshold(),
        share_below: totals.share_below(),
        planner: planner_name(effective(args.planner(), mode)).to_string(),
        slowdowns: count,
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
    let job = match prepare(&args.file, &chosen, &args.ikt, "nothing predicted", &|_| {}) {
        Ok(job) => job,
        Err(code) => return code,
    };
    let samples = args.csv.is_some() || args.json.is_some() || args.plot.is_some();
    let mode = args.mode.mode();
    let planner = effective(args.prediction.planner(), mode);
    let program = match job.motion(mode, crate::job::machine_dialect(&job.machine)) {
        Ok(program) => program,
        Err(code) => return code,
    };
    let started = std::time::Instant::now();
    let prediction =
        run_with(&job, &program, planner, args.prediction.threshold(), samples, args.period.map(|ms| ms / 1000.0));
    if args.timing {
        let seconds = started.elapsed().as_secs_f64();
        let (blocks, steps) = (prediction.blocks.len() as f64, prediction.totals().samples as f64);
        eprintln!(
            "predicted {blocks} blocks, {steps} samples in {seconds:.3} s: {:.2} M blocks/s, {:.2} M samples/s \
             ({:.0} ns per block, {:.0} ns per sample)",
            blocks / seconds / 1e6,
            steps / seconds / 1e6,
            seconds / blocks.max(1.0) * 1e9,
            seconds / steps.max(1.0) * 1e9
        );
    }
    let machine = &job.machine;
    // Every export is made first, then all are written together: a failure leaves none.
    let mut exports: Vec<(PathBuf, String)> = Vec::new();
    if let Some(path) = &args.csv {
        exports.push((path.clone(), samples_csv(&prediction, machine)));
        exports.push((path.with_extension("blocks.csv"), blocks_csv(&prediction, machine, &job)));
    }
    if let Some(path) = &args.json {
        exports.push((path.clone(), json(&prediction, machine, &job, planner)));
    }
    if let Some(path) = &args.plot {
        match plot::render(&plot_report(&prediction, machine, &job)) {
            Ok(svg) => exports.push((path.clone(), svg)),
            Err(e) => return fail(&format!("error: cannot draw {}: {e}\n", path.display()), 1),
        }
    }
    if let Err(message) = write_all(&exports) {
        return fail(&message, 1);
    }
    report::print_stdout(&table(&prediction, machine, &job, args, planner))
}

/// Writes every `(path, text)`: each to a temporary file beside its target, then, once all are
/// written, each renamed over its target. On an error no target is touched and the temporary
/// files are removed.
fn write_all(files: &[(PathBuf, String)]) -> Result<(), String> {
    let mut staged: Vec<(PathBuf, &Path)> = Vec::new();
    let remove = |staged: &[(PathBuf, &Path)]| {
        for (temp, _) in staged {
            let _ = std::fs::remove_file(temp);
        }
    };
    for (path, text) in files {
        let dir = path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
        let name = path.file_name().map_or_else(|| "export".into(), |n| n.to_string_lossy().into_owned());
        let temp = dir.join(format!(".{name}.postpro-{}.tmp", std::process::id()));
        if let Err(e) = std::fs::write(&temp, text) {
            remove(&staged);
            return Err(format!("error: cannot write {}: {e}\n", path.display()));
        }
        staged.push((temp, path));
    }
    for (i, (temp, path)) in staged.iter().enumerate() {
        if let Err(e) = std::fs::rename(temp, path) {
            remove(&staged[i..]);
            return Err(format!("error: cannot write {}: {e}\n", path.display()));
        }
    }
    Ok(())
}

/// The CL line of a block (1-based).
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

fn table(prediction: &Prediction, machine: &Machine, job: &Job, args: &PredictArgs, planner: Planner) -> String {
    let totals = prediction.totals();
    let mut out = String::new();
    let threshold = args.prediction.threshold;
    let _ = writeln!(
        out,
        "{} on {} ({} planner, {} mode, {} blocks)",
        job.source.name(),
        machine.name,
        planner_name(planner),
        args.mode.mode().name(),
        prediction.blocks.len()
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
    // Time lost by cause: each feed block's time beyond its programmed one, to its limit.
    let mut causes: BTreeMap<String, (usize, f64)> = BTreeMap::new();
    for b in prediction.blocks.iter().filter(|b| b.kind == BlockKind::Feed && b.programmed > 0.0) {
        let lost = b.time - b.length / b.programmed * 60.0;
        if lost > 0.0 && b.limit != Limit::Programmed {
            let e = causes.entry(describe(b.limit, machine)).or_default();
            e.0 += 1;
            e.1 += lost;
        }
    }
    if !causes.is_empty() {
        let mut causes: Vec<_> = causes.into_iter().collect();
        causes.sort_by(|a, b| b.1.1.total_cmp(&a.1.1));
        let _ = writeln!(out, "\ntime lost by cause (feed blocks, where their feed is lowest)");
        for (cause, (count, lost)) in causes {
            let _ = writeln!(out, "  {cause:<24} {lost:>9.2} s  {count:>8} blocks");
        }
    }
    for note in &prediction.notes {
        let _ = writeln!(out, "note: line {}: {}", line(job, note.step), note.text);
    }
    let header = "\n  block    line  kind            length mm  F mm/min    min mm/min  mean mm/min   time s  limit";
    let row = |out: &mut String, i: usize| {
        let b = &prediction.blocks[i];
        let _ = writeln!(
            out,
            "{:>7} {:>7}  {:<14} {:>10.3} {:>9.0} {:>12.0} {:>12.0} {:>8.4}  {}",
            i + 1,
            line(job, b.step),
            kind_name(b.kind),
            b.length,
            b.programmed,
            b.min_feed,
            b.mean_feed,
            b.time,
            describe(b.limit, machine)
        );
    };
    if args.blocks {
        let _ = writeln!(out, "{header}");
        for i in 0..prediction.blocks.len() {
            row(&mut out, i);
        }
    } else {
        let slowdowns = prediction.slowdowns(args.prediction.threshold());
        if !slowdowns.is_empty() {
            let mut worst: Vec<_> = slowdowns.iter().collect();
            worst.sort_by(|a, b| a.ratio.total_cmp(&b.ratio));
            let _ = writeln!(
                out,
                "\n{} slowdowns below {threshold}% of F; the worst {} (--blocks lists every block):",
                slowdowns.len(),
                worst.len().min(10)
            );
            let _ = writeln!(out, "{header}");
            for s in worst.iter().take(10) {
                let lowest = (s.first..=s.last)
                    .min_by(|&a, &b| prediction.blocks[a].min_ratio().total_cmp(&prediction.blocks[b].min_ratio()))
                    .unwrap_or(s.first);
                row(&mut out, lowest);
            }
        }
    }
    out
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
                postpro_emit::push_number(&mut out, nc(machine, i, column[r * n + i]), 6, false);
            }
        }
        out.push('\n');
    }
    out
}

fn blocks_csv(prediction: &Prediction, machine: &Machine, job: &Job) -> String {
    let mut out =
        String::from("block,line,kind,length_mm,programmed_mm_min,min_feed_mm_min,mean_feed_mm_min,time_s,limit\n");
    for (i, b) in prediction.blocks.iter().enumerate() {
        let _ = writeln!(
            out,
            "{},{},{},{:.4},{:.1},{:.2},{:.2},{:.6},{}",
            i + 1,
            line(job, b.step),
            kind_name(b.kind),
            b.length,
            b.programmed,
            b.min_feed,
            b.mean_feed,
            b.time,
            describe(b.limit, machine)
        );
    }
    out
}

fn json(prediction: &Prediction, machine: &Machine, job: &Job, planner: Planner) -> String {
    use serde_json::{Value, json};
    let t = prediction.totals();
    let blocks: Vec<Value> = prediction
        .blocks
        .iter()
        .enumerate()
        .map(|(i, b)| {
            json!({
                "block": i + 1, "line": line(job, b.step), "kind": kind_name(b.kind), "length_mm": b.length,
                "programmed_mm_min": b.programmed, "min_feed_mm_min": b.min_feed, "mean_feed_mm_min": b.mean_feed,
                "time_s": b.time, "limit": describe(b.limit, machine),
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
            "share_below": t.share_below(),
        },
        "notes": prediction.notes.iter().map(|n| json!({ "line": line(job, n.step), "text": n.text })).collect::<Vec<_>>(),
        "blocks": blocks,
        "samples": samples,
    });
    let mut text = serde_json::to_string(&doc).unwrap_or_default();
    text.push('\n');
    text
}

fn plot_report(prediction: &Prediction, machine: &Machine, job: &Job) -> plot::Report {
    let empty = postpro_predict::Samples::default();
    let samples = prediction.samples.as_ref().unwrap_or(&empty);
    let feed_only = |column: &Vec<f64>| -> Vec<f64> {
        column
            .iter()
            .zip(&samples.block)
            .map(|(v, b)| if prediction.blocks[*b as usize].kind == BlockKind::Rapid { f64::NAN } else { *v })
            .collect()
    };
    let names = limit_names(prediction);
    let empty = postpro_predict::Samples::default();
    let s = prediction.samples.as_ref().unwrap_or(&empty);
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
            "predicted cycle time {:.2} s ({:.2} s at the programmed feed), {:.1} % of the feed path below {:.0} %",
            t.cycle_time,
            t.programmed_time,
            t.share_below() * 100.0,
            t.threshold * 100.0
        ),
        path_mm: s.path.clone(),
        // Rapids would squash the feeds to the bottom of the chart: left out of the feed panel.
        programmed: feed_only(&s.programmed),
        predicted: feed_only(&s.feed),
        relative: Some(feed_only(&s.relative_feed)),
        limiter: s.limit.iter().map(|l| names.iter().position(|x| x == l).unwrap_or(0) as u16).collect(),
        limiter_names: names.iter().map(|l| describe(*l, machine)).collect(),
        axes,
    }
}
