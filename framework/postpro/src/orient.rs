//! `postpro orient FILE.cl --machine NAME`: the 3+2 set-up that makes the machine fastest
//! (paper 004). The program is cut into paths (runs of feed moves between rapids, plunges and
//! retracts); for each path and for the whole part (the length-weighted, sign-free feed
//! direction) the rotary angles that point the feed at a vertex of the jerk polytope, within the
//! rotary travels and a cone around the program's tool axis; the tangential jerk, acceleration
//! and velocity reachable there against the original set-up; and the predicted cycle time of the
//! program re-oriented (whole part, and path by path) against the original. `--apply OUT` writes
//! the re-oriented program.

use std::fmt::Write as _;
use std::path::PathBuf;
use std::process::ExitCode;

use nalgebra::{Unit, Vector3};
use postpro_cl::{ItemKind, ToolPath};
use postpro_kin::{Kinematics, Solved};
use postpro_machine::model::{AxisKind, Machine};
use postpro_orient::{Candidate, JointBoxes, JointMap, Level, Path, Setup};

use crate::emit::{ModeArg, Writing, write_job};
use crate::job::{Job, fail, prepare};
use crate::predict::{self, MarkArgs, PredictionArgs};
use crate::report;
use crate::solve::{IktArgs, MachineArgs};

/// Arguments of `postpro orient`.
#[derive(Debug, clap::Args)]
pub(crate) struct OrientArgs {
    /// The CL file (a 3+2 program: the tool axis fixed along each path).
    file: PathBuf,
    #[command(flatten)]
    machine: MachineArgs,
    #[command(flatten)]
    ikt: IktArgs,
    #[command(flatten)]
    setup: crate::setup::SetupArgs,
    /// Half-angle (degrees) of the admissible cone of tool axes around each path's own.
    #[arg(long, value_name = "DEG", default_value_t = 30.0)]
    cone: f64,
    /// The polytope whose vertex the feed points at: `jerk` (paper 004: it saturates first),
    /// `acceleration` or `velocity`.
    #[arg(long, value_enum, default_value_t = LevelArg::Jerk)]
    level: LevelArg,
    /// The output mode the cycle times are predicted for (and `--apply` writes).
    #[arg(long, value_enum, default_value_t = ModeArg::G1)]
    mode: ModeArg,
    #[command(flatten)]
    prediction: PredictionArgs,
    /// The slowdowns `--apply` marks.
    #[command(flatten)]
    marks: MarkArgs,
    /// Print JSON instead of the table.
    #[arg(long)]
    json: bool,
    /// Write the re-oriented NC program here (the whole-part set-up; `--per-path` for one set-up
    /// per path).
    #[arg(long, value_name = "OUT")]
    apply: Option<PathBuf>,
    /// With `--apply`: one set-up per path instead of one for the whole part.
    #[arg(long, requires = "apply")]
    per_path: bool,
}

/// `--level`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
enum LevelArg {
    Jerk,
    Acceleration,
    Velocity,
}

/// What the table and the JSON say of one set-up.
struct Reach {
    /// Rotary angles (letter, degrees).
    angles: Vec<(String, f64)>,
    /// Tangential velocity, acceleration, jerk along the feed direction (mm/s, mm/s², mm/s³).
    norms: [f64; 3],
    /// Tool axis in the part frame.
    tool_axis: Unit<Vector3<f64>>,
    /// The feed points at a vertex (false: the best within the cone, paper 004 eq. 13).
    at_vertex: bool,
}

/// One path's figures.
struct PathReport {
    path: Path,
    line: usize,
    reference: Unit<Vector3<f64>>,
    /// The largest angle (degrees) between the path's tool axes: 0 on a 3+2 path.
    axis_spread: f64,
    original: Option<Reach>,
    best: Option<Reach>,
}

/// A program variant's predicted cycle time, or why there is none.
type Cycle = Result<f64, String>;

/// The program in one choice of set-ups: re-oriented, solved, predicted.
struct Variant {
    path: ToolPath,
    solved: Solved,
    cycle: f64,
    /// The predicted time of each path (s).
    path_times: Vec<f64>,
    applied: postpro_orient::Applied,
}

pub(crate) fn run(args: &OrientArgs) -> ExitCode {
    if !(0.0..=180.0).contains(&args.cone) {
        return fail(&format!("error: --cone must be between 0 and 180 degrees, found {}\n", args.cone), 2);
    }
    let chosen = match args.machine.choose() {
        Ok(c) => c,
        Err(code) => return code,
    };
    let dialect = crate::job::machine_dialect(&chosen.machine);
    let job = match prepare(&args.file, &chosen, &args.ikt, &args.setup, (args.mode, dialect), "nothing oriented") {
        Ok(job) => job,
        Err(code) => return code,
    };
    let kin = job.solver.kinematics();
    let machine = &job.machine;
    let level = match args.level {
        LevelArg::Jerk => Level::Jerk,
        LevelArg::Acceleration => Level::Acceleration,
        LevelArg::Velocity => Level::Velocity,
    };
    let boxes = match JointBoxes::new(machine) {
        Ok(b) => b,
        Err(e) => return fail(&report::render(&e), 1),
    };
    let paths = postpro_orient::split(&job.path, &postpro_orient::SplitOptions::default());
    if paths.is_empty() {
        return fail(&format!("error: {} has no feed path to orient\n", job.source.name()), 1);
    }
    let mode = job.mode;
    let original_program = match job.motion(crate::job::machine_dialect(machine), crate::job::Shapes::default()) {
        Ok(program) => program,
        Err(code) => return code,
    };
    let original_prediction = predict::run(&job, &original_program, &args.prediction, false);
    let original_cycle = original_prediction.totals().cycle_time;

    // Per path: the program's tool axis, the set-up it was solved in, and the best candidate:
    // the largest norm, and among equals the one nearest the previous path's set-up (the
    // rotary axes move least between paths).
    let mut reports = Vec::with_capacity(paths.len());
    let mut previous: Option<postpro_kin::Joints> = None;
    for path in paths {
        let reference = reference_axis(&job.path, &path);
        let axis_spread = axis_spread(&job.path, &path, &reference);
        let original_at = original_joints(&job.solved, &path);
        let original = original_at.and_then(|j| reach_at(kin, &boxes, &j, &path.axis));
        let options = postpro_orient::Options { level, reference_axis: reference, cone_half_angle_deg: args.cone };
        let best = match postpro_orient::candidates(kin, &boxes, &path.axis, &options) {
            // A path whose tool axis moves is 5-axis: it is not re-oriented.
            Ok(_) if axis_spread > FIVE_AXIS_DEG => None,
            Ok(found) if !found.is_empty() => {
                postpro_orient::nearest_of_the_best(machine, &found, level, previous.or(original_at).as_ref())
            }
            // No vertex within the travels and the cone: the best set-up there (eq. 13).
            Ok(_) => {
                match postpro_orient::best_in_cone(kin, &boxes, &path.axis, &options, previous.or(original_at).as_ref())
                {
                    Ok(best) => best,
                    Err(e) => return fail(&report::render(&e), 1),
                }
            }
            Err(e) => return fail(&report::render(&e), 1),
        };
        if let Some(c) = &best {
            previous = Some(c.joints);
        }
        let best = best.map(|c| reach_of(machine, &c));
        let line = job.source.line_col(path.span.start as usize).line;
        reports.push(PathReport { path, line, reference, axis_spread, original, best });
    }
    let part = postpro_orient::part_direction(&reports.iter().map(|r| r.path.clone()).collect::<Vec<_>>());
    let part_reference = mean_axis(reports.iter().map(|r| (r.reference, r.path.length)));
    let part_options =
        postpro_orient::Options { level, reference_axis: part_reference, cone_half_angle_deg: args.cone };
    let part_best = match postpro_orient::candidates(kin, &boxes, &part.axis, &part_options) {
        Ok(found) if !found.is_empty() => found.first().map(|c| reach_of(machine, c)),
        Ok(_) => match postpro_orient::best_in_cone(kin, &boxes, &part.axis, &part_options, None) {
            Ok(best) => best.map(|c| reach_of(machine, &c)),
            Err(e) => return fail(&report::render(&e), 1),
        },
        Err(e) => return fail(&report::render(&e), 1),
    };

    // The program in each set-up, solved and predicted.
    let five_axis = reports.iter().filter(|r| r.axis_spread > FIVE_AXIS_DEG).count();
    let whole = part_best
        .as_ref()
        .filter(|_| five_axis == 0)
        .map(|best| vec![Setup { items: 0..job.path.items.len(), axis: Some(best.tool_axis) }]);
    let per_path: Vec<Setup> = reports
        .iter()
        .map(|r| Setup {
            items: r.path.items.clone(),
            axis: (r.axis_spread <= FIVE_AXIS_DEG).then(|| r.best.as_ref().map_or(r.reference, |b| b.tool_axis)),
        })
        .collect();
    let spans: Vec<(usize, usize)> = reports.iter().map(|r| (r.path.span.start as usize, r.path.span.end())).collect();
    let original_times = path_times(&original_prediction, &job.solved, &spans);
    let variant = |setups: &[Setup]| -> Result<Variant, String> {
        let applied = postpro_orient::apply(&job.path, setups);
        let solved = postpro_kin::solve(kin, &applied.path, &machine.policy)
            .map_err(|e| format!("the re-oriented program does not solve: {e}"))?;
        let prediction = predict::run_solved(&applied.path, &solved, kin, mode, &args.prediction)
            .map_err(|e| format!("the re-oriented program cannot be written: {e}"))?;
        let path_times = path_times(&prediction, &solved, &spans);
        Ok(Variant { path: applied.path.clone(), solved, cycle: prediction.totals().cycle_time, path_times, applied })
    };
    let whole_variant = whole.as_deref().map(variant);
    let per_path_variant = variant(&per_path);
    let cycle_of = |v: Option<&Result<Variant, String>>| -> Cycle {
        match v {
            None => Err("no set-up reaches a vertex within the cone".into()),
            Some(Ok(v)) => Ok(v.cycle),
            Some(Err(e)) => Err(e.clone()),
        }
    };
    let whole_cycle = if five_axis > 0 {
        let (count, verb) =
            if five_axis == 1 { ("1 path".to_string(), "is") } else { (format!("{five_axis} paths"), "are") };
        Err(format!("{count} {verb} 5-axis (the tool axis moves): one set-up cannot hold them"))
    } else {
        cycle_of(whole_variant.as_ref())
    };
    let per_path_cycle = cycle_of(Some(&per_path_variant));
    let notes: Vec<String> = [whole_variant.as_ref().and_then(|v| v.as_ref().ok()), per_path_variant.as_ref().ok()]
        .into_iter()
        .flatten()
        .flat_map(|Variant { applied, .. }| {
            let mut notes: Vec<String> = applied
                .not_ball
                .iter()
                .map(|(d, r)| format!("tool D{d} R{r} is not a ball-end mill: re-oriented about its corner centre"))
                .collect();
            if applied.without_shape > 0 {
                notes.push(format!("{} moves without a tool shape: re-oriented about the tip", applied.without_shape));
            }
            notes
        })
        .fold(Vec::new(), |mut all, n| {
            if !all.contains(&n) {
                all.push(n);
            }
            all
        });

    let findings = Findings {
        level,
        original_times: &original_times,
        best_times: per_path_variant.as_ref().ok().map(|v| v.path_times.as_slice()),
        reports: &reports,
        part: &part,
        part_best: part_best.as_ref(),
        original: original_cycle,
        whole: &whole_cycle,
        per_path: &per_path_cycle,
        notes: &notes,
    };
    let text = if args.json { json(&job, machine, args, &findings) } else { table(&job, args, &findings) };
    let printed = report::print_stdout(&text);

    if let Some(out) = &args.apply {
        let chosen_variant = if args.per_path { Some(per_path_variant) } else { whole_variant };
        let (path, solved) = match chosen_variant {
            Some(Ok(Variant { path, solved, .. })) => (path, solved),
            Some(Err(e)) => return fail(&format!("error: nothing written: {e}\n"), 1),
            // No whole-part variant: the reason is the whole part's (5-axis paths, or no set-up
            // within the cone).
            None => {
                let why = whole_cycle.err().unwrap_or_else(|| "no set-up reaches a vertex within the cone".into());
                return fail(&format!("error: nothing written: {why}\n"), 1);
            }
        };
        let Some(dialect) = postpro_emit::dialect(&machine.dialect) else {
            return fail(&format!("error: unknown dialect `{}`\n", machine.dialect), 1);
        };
        let template = (
            format!("{}.j2", dialect.name),
            postpro_emit::builtin_template(dialect.name).unwrap_or_default().to_string(),
        );
        let name = args.file.file_stem().map_or_else(|| "PROGRAM".to_string(), |s| s.to_string_lossy().to_uppercase());
        let Job { source, machine, solver, setup, kinematic_lengths, mode: job_mode, strict, .. } = job;
        // The re-oriented program loads the same tools at the same items.
        let (tooling, _) = postpro_motion::tooling(&path, setup.tool_table.as_ref());
        let oriented =
            Job { source, path, machine, solver, solved, setup, tooling, kinematic_lengths, mode: job_mode, strict };
        let writing = Writing {
            mode,
            dialect,
            template: &template,
            output: out,
            program_name: name,
            block_numbers: false,
            shapes: crate::job::Shapes { planes: true, ..crate::job::Shapes::default() },
            tcp_orientation: postpro_emit::TcpOrientation::Angles,
            insert_verbatim: false,
            prediction: Some((&args.prediction, &args.marks)),
        };
        return write_job(&oriented, &writing, &|_| {});
    }
    printed
}

/// The predicted time of each path (`spans`: its byte range in the CL file): the time of the
/// blocks that end on one of its steps.
fn path_times(prediction: &postpro_predict::Prediction, solved: &Solved, spans: &[(usize, usize)]) -> Vec<f64> {
    let mut times = vec![0.0; spans.len()];
    for b in &prediction.blocks {
        let at = solved.steps[b.step].span.start as usize;
        // The paths are in file order: the last one starting at or before `at`.
        let i = spans.partition_point(|&(start, _)| start <= at);
        if i > 0 && at < spans[i - 1].1 {
            times[i - 1] += b.time;
        }
    }
    times
}

/// A path whose tool axes spread wider than this (degrees) is 5-axis.
const FIVE_AXIS_DEG: f64 = 0.01;

/// The largest angle (degrees) between a move's tool axis on the path and `reference`.
fn axis_spread(path: &ToolPath, p: &Path, reference: &Unit<Vector3<f64>>) -> f64 {
    path.items[p.items.clone()]
        .iter()
        .filter_map(|item| match &item.kind {
            ItemKind::Move(m) => Some(m.axis),
            ItemKind::Arc(a) => Some(a.axis),
            ItemKind::Nurbs(n) => Some(n.axis),
            _ => None,
        })
        .map(|a| a.dot(reference).clamp(-1.0, 1.0).acos().to_degrees())
        .fold(0.0, f64::max)
}

/// The tool axis of the path's first move: the program's set-up for it.
fn reference_axis(path: &ToolPath, p: &Path) -> Unit<Vector3<f64>> {
    path.items[p.items.clone()]
        .iter()
        .find_map(|item| match &item.kind {
            ItemKind::Move(m) => Some(m.axis),
            ItemKind::Arc(a) => Some(a.axis),
            ItemKind::Nurbs(n) => Some(n.axis),
            _ => None,
        })
        .unwrap_or_else(Vector3::z_axis)
}

/// The length-weighted mean of unit axes.
fn mean_axis(axes: impl Iterator<Item = (Unit<Vector3<f64>>, f64)>) -> Unit<Vector3<f64>> {
    let sum: Vector3<f64> = axes.map(|(a, l)| a.into_inner() * l.max(1e-9)).sum();
    Unit::try_new(sum, 1e-12).unwrap_or_else(Vector3::z_axis)
}

/// The axis values the program was solved at on the path's first point.
fn original_joints(solved: &Solved, p: &Path) -> Option<postpro_kin::Joints> {
    let (start, end) = (p.span.start as usize, p.span.end());
    solved
        .steps
        .iter()
        .find(|s| (s.span.start as usize) >= start && (s.span.start as usize) < end.max(start + 1))
        .map(|s| s.joints)
}

fn reach_at(
    kin: &dyn Kinematics,
    boxes: &JointBoxes,
    joints: &postpro_kin::Joints,
    d: &Unit<Vector3<f64>>,
) -> Option<Reach> {
    let map = JointMap::at(kin, boxes, joints).ok()?;
    let norms = Level::ALL.map(|level| boxes.polytope(level, &map).norm_along(d));
    Some(Reach {
        angles: rotary_angles(kin.machine(), joints),
        norms,
        tool_axis: kin.forward(joints).axis,
        at_vertex: false,
    })
}

fn reach_of(machine: &Machine, c: &Candidate) -> Reach {
    Reach {
        angles: rotary_angles(machine, &c.joints),
        norms: [c.velocity, c.acceleration, c.jerk],
        tool_axis: c.tool_axis,
        at_vertex: c.at_vertex,
    }
}

fn rotary_angles(machine: &Machine, joints: &postpro_kin::Joints) -> Vec<(String, f64)> {
    machine
        .axes
        .iter()
        .zip(joints.as_slice())
        .filter(|(a, _)| a.kind == AxisKind::Rotary)
        .map(|(a, v)| (a.letter.clone(), v.to_degrees()))
        .collect()
}

fn angles_text(r: &Reach) -> String {
    r.angles.iter().map(|(l, v)| format!("{l}{v:>8.3}")).collect::<Vec<_>>().join(" ")
}

fn norms_text(r: &Reach) -> String {
    format!("{:>7.2} {:>7.2} {:>6.3}", r.norms[2] / 1000.0, r.norms[1] / 1000.0, r.norms[0] / 1000.0)
}

fn vector(v: &Vector3<f64>) -> String {
    let c = |x: f64| postpro_emit::number(x, 3, false);
    format!("({}, {}, {})", c(v.x), c(v.y), c(v.z))
}

fn cycle_text(c: &Cycle, original: f64) -> String {
    match c {
        Ok(t) => format!("{t:.2} s ({:+.1} %)", (t / original - 1.0) * 100.0),
        Err(e) => format!("— ({e})"),
    }
}

/// What `orient` found, for the table and the JSON.
struct Findings<'a> {
    level: Level,
    /// Each path's predicted time in the original set-up (s).
    original_times: &'a [f64],
    /// Each path's predicted time with one set-up per path (s), when that program solves.
    best_times: Option<&'a [f64]>,
    reports: &'a [PathReport],
    part: &'a postpro_orient::PartDirection,
    part_best: Option<&'a Reach>,
    original: f64,
    whole: &'a Cycle,
    per_path: &'a Cycle,
    notes: &'a [String],
}

fn table(job: &Job, args: &OrientArgs, f: &Findings<'_>) -> String {
    let Findings { level, reports, part, part_best, original, whole, per_path, notes, .. } = *f;
    let mut out = String::new();
    let _ = writeln!(
        out,
        "{} on {}: {} paths, {:.1} mm of feed; {} vertices, tool axes within {}° of the program's",
        job.source.name(),
        job.machine.name,
        reports.len(),
        part.length,
        level.name(),
        args.cone
    );
    let _ = writeln!(out, "whole part: feed direction {} (straightness {:.2})", vector(&part.axis), part.straightness);
    match part_best {
        Some(b) => {
            let _ = writeln!(
                out,
                "  set-up {}   jerk {:.2} m/s³, acceleration {:.2} m/s², velocity {:.3} m/s; tool axis {}{}",
                angles_text(b),
                b.norms[2] / 1000.0,
                b.norms[1] / 1000.0,
                b.norms[0] / 1000.0,
                vector(&b.tool_axis),
                if b.at_vertex { "" } else { " (no vertex in the cone: the best within it)" }
            );
        }
        None => {
            let _ = writeln!(out, "  no set-up puts the tool axis within the cone");
        }
    }
    let _ = writeln!(out, "\npredicted cycle time ({} mode)", job.mode.name());
    let _ = writeln!(out, "  original set-up          {original:.2} s");
    let _ = writeln!(out, "  one set-up, whole part   {}", cycle_text(whole, original));
    let _ = writeln!(out, "  one set-up per path      {}", cycle_text(per_path, original));
    let _ = writeln!(
        out,
        "\n path   line  length mm  feed direction              time s (per path)    original set-up / reach (jerk m/s³, acc m/s², vel m/s)   best set-up / reach"
    );
    for (i, r) in reports.iter().enumerate() {
        let original =
            r.original.as_ref().map_or_else(|| "—".to_string(), |o| format!("{} {}", angles_text(o), norms_text(o)));
        let best = match &r.best {
            Some(b) => format!(
                "{} {}{}",
                angles_text(b),
                norms_text(b),
                if b.at_vertex { "" } else { "  (no vertex in the cone)" }
            ),
            None if r.axis_spread > FIVE_AXIS_DEG => {
                format!("5-axis (tool axis moves {:.1}°): left as programmed", r.axis_spread)
            }
            None => "none within the cone".to_string(),
        };
        let times = match f.best_times.and_then(|t| t.get(i)) {
            Some(best) if r.best.is_some() => format!("{:>7.3} → {:>7.3}", f.original_times[i], best),
            _ => format!("{:>7.3}", f.original_times[i]),
        };
        let _ = writeln!(
            out,
            "{:>5} {:>6} {:>10.1}  {:<26}  {:<19}  {:<56}  {}",
            i + 1,
            r.line,
            r.path.length,
            vector(&r.path.axis),
            times,
            original,
            best
        );
    }
    for n in notes {
        let _ = writeln!(out, "note: {n}");
    }
    out
}

fn json(job: &Job, machine: &Machine, args: &OrientArgs, f: &Findings<'_>) -> String {
    let Findings { level, reports, part, part_best, original, whole, per_path, notes, .. } = *f;
    use serde_json::{Value, json};
    let v3 = |v: &Vector3<f64>| json!([v.x, v.y, v.z]);
    let reach = |r: Option<&Reach>| -> Value {
        r.map_or(Value::Null, |r| {
            json!({
                "angles_deg": r.angles.iter().map(|(l, v)| (l.clone(), json!(v))).collect::<serde_json::Map<_, _>>(),
                "jerk_mm_s3": r.norms[2], "acceleration_mm_s2": r.norms[1], "velocity_mm_s": r.norms[0],
                "tool_axis": v3(&r.tool_axis), "at_vertex": r.at_vertex,
            })
        })
    };
    let cycle = |c: &Cycle| match c {
        Ok(t) => json!({ "cycle_time_s": t }),
        Err(e) => json!({ "cycle_time_s": Value::Null, "why": e }),
    };
    let paths: Vec<Value> = reports
        .iter()
        .enumerate()
        .map(|(i, r)| {
            json!({
                "path": i + 1, "line": r.line, "length_mm": r.path.length, "moves": r.path.moves,
                "direction": v3(&r.path.axis), "straightness": r.path.straightness,
                "program_tool_axis": v3(&r.reference), "tool_axis_spread_deg": r.axis_spread,
                "original": reach(r.original.as_ref()), "best": reach(r.best.as_ref()),
                "time_s": { "original": f.original_times[i], "per_path_set_up": f.best_times.and_then(|t| t.get(i)) },
            })
        })
        .collect();
    let doc = json!({
        "file": job.source.name(), "machine": machine.name, "level": level.name(), "cone_deg": args.cone,
        "mode": job.mode.name(),
        "original": { "cycle_time_s": original },
        "whole_part": { "direction": v3(&part.axis), "length_mm": part.length, "best": reach(part_best), "prediction": cycle(whole) },
        "per_path": { "prediction": cycle(per_path), "paths": paths },
        "notes": notes,
    });
    let mut text = serde_json::to_string_pretty(&doc).unwrap_or_default();
    text.push('\n');
    text
}
