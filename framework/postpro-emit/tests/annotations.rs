//! The feed prediction in the program: the header lines of `header.prediction` and the comments
//! of `Options::annotations`, in every dialect and mode, on a small 5-axis path (an arc, a
//! reorientation the Mikron's joint interpolation must linearize, a retract). Each annotation is
//! found exactly once, in order, between the motion of the step before it and the motion of its
//! step, read back from the program text (BSPLINE: before the control points of its step's span).
//! One program per dialect is pinned whole by insta. A BSPLINE run written as G1 blocks (too short,
//! or a spline that cannot follow it) keeps its linearization points, read back through the
//! forward kinematics, with their annotations before their own blocks.

use std::collections::HashMap;

use postpro_cl::{Source, ToolPath, read};
use postpro_emit::bspline::{DEGREE, Spline};
use postpro_emit::{
    Annotation, Dialect, MarkedSlowdown, Mode, OperationPrediction, Prediction, build, builtin_template, dialect,
    render,
};
use postpro_kin::{Joints, Kinematics, Solved, Step, StepKind, linearize, solve, solver_for};
use postpro_machine::Registry;
use postpro_machine::model::{AxisKind, Machine};

mod common;

/// What a test asks for: the mode of the motion program and the emitter's options.
#[derive(Clone, Debug)]
struct Options {
    mode: Mode,
    program_name: String,
    source_name: String,
    block_numbers: bool,
    prediction: Option<Prediction>,
    annotations: Vec<Annotation>,
}

impl Options {
    fn emit(&self) -> postpro_emit::Options {
        postpro_emit::Options {
            units: postpro_machine::model::ProgramUnits::Mm,
            program_name: self.program_name.clone(),
            source_name: self.source_name.clone(),
            block_numbers: self.block_numbers,
            tcp_orientation: Default::default(),
            insert_verbatim: false,
            prediction: self.prediction.clone(),
            annotations: self.annotations.clone(),
        }
    }
}

/// Rapid in, plunge, an arc of 16 points at F2000 (one BSPLINE run), a 20° reorientation at F1000
/// (linearized on the Mikron), a short line at F2000, a rapid retract.
fn cl_text() -> String {
    let mut cl = String::from(
        "PARTNO/ANNOTATED TEST\nLOAD/TOOL,1,ADJUST,1\nSPINDL/RPM,12000,CLW\nRAPID\n\
         GOTO/20.0000,0.0000,20.0000,0.0000000,0.0000000,1.0000000\nFEDRAT/MMPM,500\nGOTO/20.0000,0.0000,0.0000\n\
         FEDRAT/MMPM,2000\n",
    );
    for i in 1..=16 {
        let t = f64::from(i) / 50.0;
        cl.push_str(&format!("GOTO/{:.4},{:.4},0.0000\n", 20.0 + 50.0 * t.sin(), 50.0 - 50.0 * t.cos()));
    }
    let (x, y) = (20.0 + 50.0 * 0.32f64.sin(), 50.0 - 50.0 * 0.32f64.cos());
    cl.push_str(&format!("FEDRAT/MMPM,1000\nGOTO/{:.4},{:.4},0.0000,0.0000000,0.3420201,0.9396926\n", x + 2.0, y));
    cl.push_str("FEDRAT/MMPM,2000\n");
    for i in 1..=5 {
        cl.push_str(&format!("GOTO/{:.4},{:.4},0.0000\n", x + 2.0 + f64::from(i), y));
    }
    cl.push_str(&format!("RAPID\nGOTO/{:.4},{:.4},30.0000\nEND\nFINI\n", x + 7.0, y));
    cl
}

fn machine() -> Machine {
    machine_named("mikron-ucp710")
}

fn machine_named(name: &str) -> Machine {
    Registry::builtin().expect("built-ins").find(name).expect("machine").machine.clone()
}

fn prediction() -> Prediction {
    Prediction {
        cycle_time: 61.23,
        time_lost: 3.456,
        threshold: 0.8,
        share_below: 0.1234,
        planner: "vpop".into(),
        slowdowns: 2,
        operations: vec![
            OperationPrediction {
                name: "ROUGH (D10)".into(),
                cycle_time: 41.23,
                programmed_time: 40.0,
                time_lost: 1.23,
                cause: "corner".into(),
            },
            OperationPrediction {
                name: String::new(),
                cycle_time: 20.0,
                programmed_time: 20.0,
                time_lost: 0.0,
                cause: "programmed".into(),
            },
        ],
        worst: vec![MarkedSlowdown {
            number: 2,
            step: 7,
            line: 12,
            nc_line: None,
            nc_block: None,
            time_lost: 0.42,
            text: "38% of F over 12 blocks, C jerk (A), 0.42 s lost".into(),
        }],
    }
}

/// The cases: every dialect in every mode it has (BSPLINE is Siemens's only).
const CASES: &[(&str, &[Mode])] = &[
    ("siemens-840d", &[Mode::G1, Mode::InverseTime, Mode::Tcp, Mode::Bspline]),
    ("fanuc", &[Mode::G1, Mode::InverseTime, Mode::Tcp]),
    ("heidenhain", &[Mode::G1, Mode::Tcp]),
    ("linuxcnc", &[Mode::G1, Mode::InverseTime]),
];

/// The program pinned per dialect.
const PINNED: &[(&str, Mode)] =
    &[("siemens-840d", Mode::Bspline), ("fanuc", Mode::Tcp), ("heidenhain", Mode::G1), ("linuxcnc", Mode::InverseTime)];

struct Fixture {
    path: ToolPath,
    solved: Solved,
    kin: Box<dyn Kinematics>,
    machine: Machine,
}

impl Fixture {
    /// The work offset's frame of the programs in `mode`.
    fn frame(&self, mode: Mode) -> postpro_motion::WorkFrame {
        postpro_motion::work_frame(self.kin.as_ref(), mode)
    }

    /// The solved steps with their axis values as the program writes them (the work offset's
    /// frame of `mode`).
    fn written(&self, mode: Mode) -> Vec<Step> {
        let frame = self.frame(mode);
        self.solved.steps.iter().map(|s| Step { joints: frame.apply(&s.joints), ..*s }).collect()
    }
}

fn fixture() -> Fixture {
    fixture_of(Source::new("annotated.cl", cl_text()))
}

fn fixture_of(src: Source) -> Fixture {
    fixture_on(src, machine())
}

fn fixture_on(src: Source, machine: Machine) -> Fixture {
    let path = read(&src);
    assert!(!path.has_errors(), "the test path reads");
    let kin = solver_for(&machine);
    let solved = solve(kin.as_ref(), &path, &machine.policy).expect("solves");
    Fixture { path, solved, kin, machine }
}

/// The annotations: a CL feed step inside the arc, a point added by linearization, the rapid
/// retract, and one past the last step.
fn annotations(solved: &Solved) -> Vec<Annotation> {
    let steps = &solved.steps;
    let cl: Vec<usize> = (0..steps.len()).filter(|&k| steps[k].kind == StepKind::Cl).collect();
    let feed_step = cl[7]; // the rapid, the plunge, then the arc's sixth point
    let linearized = steps.iter().position(|s| s.kind == StepKind::Linearized).expect("a linearized step");
    let retract = steps.len() - 1;
    assert!(steps[retract].rapid, "the last step is the rapid retract");
    assert!(feed_step < linearized, "the arc comes before the reorientation");
    vec![
        Annotation { step: feed_step, text: "slowdown one: 62 percent of F on the arc".into(), slowdown: None },
        Annotation {
            step: linearized,
            text: "slowdown #2: on a linearized point (A limits)".into(),
            slowdown: Some(2),
        },
        Annotation { step: retract, text: "note three: before the retract".into(), slowdown: None },
        Annotation { step: steps.len() + 3, text: "note four: past the last step".into(), slowdown: None },
    ]
}

fn options(mode: Mode, solved: &Solved, block_numbers: bool) -> Options {
    Options {
        mode,
        program_name: "ANNOTATED".into(),
        source_name: "annotated.cl".into(),
        block_numbers,
        prediction: Some(prediction()),
        annotations: annotations(solved),
    }
}

/// The program, rendered whole and streamed (they must agree).
fn program(f: &Fixture, d: &Dialect, options: &Options) -> String {
    let template = builtin_template(d.name).expect("template");
    let motion = common::motion(&f.path, &f.solved, f.kin.as_ref(), d, options.mode);
    let emit = options.emit();
    let whole = render(&build(&motion, &f.machine, d, &emit).expect("builds"), d.name, template).expect("renders");
    let mut streamed = Vec::new();
    postpro_emit::write_program(&motion, &f.machine, d, &emit, d.name, template, &mut streamed).expect("writes");
    assert!(whole == String::from_utf8(streamed).expect("UTF-8"), "{} {:?}: streamed ≠ whole", d.name, options.mode);
    if options.prediction.as_ref().is_some_and(|p| !p.worst.is_empty()) {
        assert_worst_points_at_its_comment(&whole, d, options.mode);
    }
    whole
}

/// The header's worst slowdown #2 names the line (or, in Heidenhain, the block) of the comment
/// `slowdown #2: …`.
fn assert_worst_points_at_its_comment(program: &str, d: &Dialect, mode: Mode) {
    let lines: Vec<&str> = program.lines().collect();
    let header = lines.iter().find(|l| l.contains("worst slowdown #2 at ")).expect("the worst slowdown in the header");
    let place = header.split_once("worst slowdown #2 at ").map(|(_, r)| r.split_once(", CL line").map_or(r, |p| p.0));
    let comment = match place.and_then(|p| p.split_once(' ')) {
        Some(("CL", _)) => {
            // No place named: there must be no such comment.
            assert!(!program.contains("slowdown #2:"), "{} {mode:?}: `{header}` names no line", d.name);
            return;
        }
        Some(("line", l)) => {
            let n: usize = l.split_whitespace().next().and_then(|n| n.parse().ok()).expect("a line number");
            lines[n - 1]
        }
        Some(("block", b)) => {
            lines.iter().find(|l| l.split_whitespace().next() == Some(b)).expect("a line of that block number")
        }
        _ => panic!("{} {mode:?}: `{header}` names no line", d.name),
    };
    assert!(
        comment.contains("slowdown #2: on a linearized point"),
        "{} {mode:?}: `{header}` points at `{comment}`",
        d.name
    );
}

/// The position words a mode writes for a step: the axis values, or the tool tip in TCP mode.
fn position(step: &Step, mode: Mode, machine: &Machine) -> Vec<(String, f64)> {
    if mode == Mode::Tcp {
        let t = step.pose.tip;
        return vec![("X".into(), t.x), ("Y".into(), t.y), ("Z".into(), t.z)];
    }
    machine
        .axes
        .iter()
        .enumerate()
        .map(|(i, a)| {
            let v = if a.kind == AxisKind::Rotary { step.joints[i].to_degrees() } else { step.joints[i] };
            (a.letter.clone(), v)
        })
        .collect()
}

/// Whether the mode writes a block for each step (in a spline: a point of it). TCP skips the
/// linearization points; BSPLINE too, but for those of a run written as G1 blocks: those whose
/// point (the next step that is not one) is reached by a `G1` block outside the splines.
fn written_steps(steps: &[Step], mode: Mode, machine: &Machine, back: &ReadBack) -> Vec<bool> {
    (0..steps.len())
        .map(|j| {
            if steps[j].kind != StepKind::Linearized {
                return true;
            }
            match mode {
                Mode::G1 | Mode::InverseTime => true,
                Mode::Tcp => false,
                Mode::Bspline => {
                    let target = (j..steps.len()).find(|&b| steps[b].kind != StepKind::Linearized).unwrap_or(j);
                    let words = position(&steps[target], mode, machine);
                    (0..back.state.len()).any(|i| back.g1[i] && at(&back.state[i], &words))
                }
            }
        })
        .collect()
}

/// The program read back: the position words in force after each line, and which lines move.
struct ReadBack {
    /// `state[i]`: the words in force after line `i`.
    state: Vec<HashMap<String, f64>>,
    motion: Vec<bool>,
    /// `G1` blocks with position words outside the splines.
    g1: Vec<bool>,
}

fn read_back(text: &str, letters: &[String]) -> ReadBack {
    let mut current: HashMap<String, f64> = HashMap::new();
    let (mut state, mut motion, mut g1) = (Vec::new(), Vec::new(), Vec::new());
    let mut spline = false;
    for line in text.lines() {
        let code = line.split(['(', ';']).next().unwrap_or("");
        let mut moved = false;
        // A retract in machine coordinates is not a position of the program's frame.
        let machine_frame = code.split_whitespace().any(|t| matches!(t, "G53" | "SUPA" | "M91"));
        for token in code.split_whitespace().filter(|_| !machine_frame) {
            let (letter, number) = match token.split_once('=') {
                Some((l, n)) => (l, n),
                None => token.split_at(token.find(|c: char| !c.is_ascii_alphabetic()).unwrap_or(token.len())),
            };
            if let (true, Ok(v)) = (letters.iter().any(|l| l == letter), number.parse::<f64>()) {
                current.insert(letter.to_string(), v);
                moved = true;
            }
        }
        // The words of the block, its number aside.
        let words: Vec<&str> = code
            .split_whitespace()
            .skip_while(|t| t.strip_prefix('N').is_some_and(|n| n.parse::<u32>().is_ok()))
            .collect();
        if words.first() == Some(&"BSPLINE") {
            spline = true;
        } else if spline && words == ["G1"] {
            spline = false;
        }
        state.push(current.clone());
        g1.push(moved && !spline && words.first() == Some(&"G1"));
        motion.push(moved);
    }
    ReadBack { state, motion, g1 }
}

/// The spline between the lines `open` (`BSPLINE`) and `close` (`G1`), in the written units,
/// rebuilt as `bspline_stays_within_tolerance_of_the_cl_points` does in `programs.rs`.
fn spline_of(lines: &[&str], back: &ReadBack, letters: &[String], open: usize, close: usize) -> Spline {
    let joints = |i: usize| Joints::from_slice(&letters.iter().map(|l| back.state[i][l]).collect::<Vec<_>>());
    let mut control = vec![joints(open - 1)];
    let mut pls = Vec::new();
    for (i, line) in lines.iter().enumerate().take(close).skip(open + 1) {
        if let Some(pl) = line.split_whitespace().find_map(|t| t.strip_prefix("PL=")) {
            control.push(joints(i));
            pls.push(pl.parse::<f64>().expect("PL"));
        }
    }
    Spline::from_written(control, &pls)
}

/// The control point whose Greville abscissa is nearest to the parameter where the spline comes
/// nearest to `point`.
fn nearest_control(spline: &Spline, point: &Joints) -> usize {
    let (lo, hi) = spline.domain();
    let samples = 50 * spline.control.len();
    let distance = |u: f64| {
        let q = spline.at(u);
        q.as_slice().iter().zip(point.as_slice()).map(|(a, b)| (a - b) * (a - b)).sum::<f64>().sqrt()
    };
    let u = (0..=samples)
        .map(|s| lo + (hi - lo) * s as f64 / samples as f64)
        .min_by(|a, b| distance(*a).total_cmp(&distance(*b)))
        .unwrap_or(lo);
    // Refined between the neighbouring samples.
    let (mut a, mut b) = (u - (hi - lo) / samples as f64, u + (hi - lo) / samples as f64);
    for _ in 0..60 {
        let (m1, m2) = (a + (b - a) / 3.0, b - (b - a) / 3.0);
        if distance(m1) < distance(m2) { b = m2 } else { a = m1 }
    }
    let u = (a + b) / 2.0;
    assert!(distance(u) < 1e-2, "the spline passes the point ({} off)", distance(u));
    let greville = |j: usize| spline.knots[j + 1..=j + DEGREE].iter().sum::<f64>() / DEGREE as f64;
    (0..spline.control.len()).min_by(|&a, &b| (greville(a) - u).abs().total_cmp(&(greville(b) - u).abs())).unwrap_or(0)
}

fn at(state: &HashMap<String, f64>, words: &[(String, f64)]) -> bool {
    words.iter().all(|(l, v)| state.get(l).is_some_and(|s| (s - v).abs() < 2e-3))
}

/// Checks the place of every annotation of `options` in its program; returns how many stand in
/// a spline the fit refined (more control points than points).
fn check(text: &str, f: &Fixture, d: &Dialect, options: &Options, label: &str) -> usize {
    let written = f.written(options.mode);
    let (steps, mode) = (&written, options.mode);
    let letters: Vec<String> = position(&steps[0], mode, &f.machine).into_iter().map(|(l, _)| l).collect();
    let back = read_back(text, &letters);
    let lines: Vec<&str> = text.lines().collect();
    let pos = |k: usize| position(&steps[k], mode, &f.machine);
    let w = written_steps(steps, mode, &f.machine, &back);
    let written = |j: usize| w[j];
    let mut last = 0;
    let mut refined = 0;
    for a in &options.annotations {
        // As the dialect writes it (Fanuc and LinuxCNC: brackets for parentheses).
        let clean = postpro_emit::clean_comment(d, &a.text);
        let found: Vec<usize> = (0..lines.len()).filter(|&i| lines[i].contains(clean.as_str())).collect();
        assert_eq!(found.len(), 1, "{label}: `{}` is written once\n{text}", a.text);
        let c = found[0];
        assert!(c > last, "{label}: `{}` comes after the annotations of the steps before it\n{text}", a.text);
        last = c;
        if a.step >= steps.len() {
            // After the last motion, before the end of the program.
            assert!(back.motion[c..].iter().all(|m| !m), "{label}: `{}` after every motion\n{text}", a.text);
            continue;
        }
        let k = a.step;
        // The motion the comment precedes: its own step's, or the next written step's.
        let next = (k..steps.len()).find(|&j| written(j)).expect("a written step after");
        let prev = (0..k).rev().find(|&j| written(j));
        let spline = (mode == Mode::Bspline)
            .then(|| {
                let open = (0..c).rev().find(|&i| lines[i].contains("BSPLINE") || lines[i].ends_with("G1"))?;
                lines[open].contains("BSPLINE").then_some(open)
            })
            .flatten();
        if let Some(open) = spline {
            // Inside a spline: after the control points of the run's points before the step.
            let close = (c..lines.len()).find(|&i| lines[i].ends_with("G1")).expect("the spline ends");
            let before = &back.state[open - 1];
            let start = (0..k).rev().find(|&j| written(j) && at(before, &pos(j))).expect("run start");
            let end =
                (start..steps.len()).rev().find(|&j| written(j) && at(&back.state[close], &pos(j))).expect("run end");
            assert!(start < k && k <= end, "{label}: step {k} in the run {start}..={end}");
            let points = (start + 1..=end).filter(|&j| written(j)).count();
            let controls = (open + 1..close).filter(|&i| back.motion[i]).count();
            let r = (start + 1..k).filter(|&j| written(j)).count();
            let ahead = (open + 1..c).filter(|&i| back.motion[i]).count();
            // One control point per point of the run, and one per midpoint the fit adds.
            assert!(controls >= points, "{label}: {controls} control points for {points} points");
            assert!(
                r <= ahead && ahead <= r + controls - points,
                "{label}: `{}` after {ahead} control points, {r} points of the run before it\n{text}",
                a.text
            );
            // Exactly: before the control point after the one of the run's point before the step
            // (the start, or a CL point), found on the spline rebuilt from the program: the one
            // whose Greville abscissa is nearest to the parameter where the spline passes it.
            let spline = spline_of(&lines, &back, &letters, open, close);
            let previous = (start..k).rev().find(|&j| written(j)).unwrap_or(start);
            let values: Vec<f64> = pos(previous).into_iter().map(|(_, v)| v).collect();
            let own = nearest_control(&spline, &Joints::from_slice(&values));
            assert_eq!(ahead, own, "{label}: `{}` right after the control point of step {previous}\n{text}", a.text);
            refined += usize::from(controls > points);
            continue;
        }
        // After the previous step's motion: the position in force is that step's (none before the first)…
        match prev {
            Some(prev) => {
                assert!(at(&back.state[c], &pos(prev)), "{label}: `{}` after step {prev}'s motion\n{text}", a.text);
            }
            None => assert!(back.motion[..c].iter().all(|m| !m), "{label}: `{}` before any motion\n{text}", a.text),
        }
        // …and the next position reached is the step's (or, when it writes none, the next one's).
        let reached = (c + 1..lines.len()).find(|&i| back.motion[i] && at(&back.state[i], &pos(next)));
        let reached = reached.unwrap_or_else(|| panic!("{label}: step {next} reached after `{}`\n{text}", a.text));
        for i in c + 1..reached {
            let other = (0..steps.len()).find(|&j| j != next && Some(j) != prev && at(&back.state[i], &pos(j)));
            assert!(other.is_none(), "{label}: step {other:?} reached between `{}` and step {next}\n{text}", a.text);
        }
    }
    refined
}

#[test]
fn annotations_stand_before_the_motion_of_their_step_in_every_dialect_and_mode() {
    let f = fixture();
    assert!(f.solved.inserted > 0, "the reorientation is linearized");
    for (dialect_name, modes) in CASES {
        let d = dialect(dialect_name).expect("dialect");
        for &mode in *modes {
            for block_numbers in [false, true] {
                let label = format!("{dialect_name} {} {}", mode.name(), if block_numbers { "N" } else { "-" });
                let options = options(mode, &f.solved, block_numbers);
                let text = program(&f, d, &options);
                assert_eq!(text.lines().position(|l| l.trim().is_empty()), None, "{label}: a blank line\n{text}");
                for line in text.lines() {
                    assert!(line.len() <= d.max_line, "{label}: line too long");
                }
                let header = (text.find("predicted cycle time: 61.2 s, lost to slowdowns: 3.5 s, planner: vpop"), text
                    .find(
                        "below 80.0 percent of the programmed feed on 12.3 percent of the feed path, 2 slowdowns marked",
                    ));
                let (Some(first), Some(second)) = header else { panic!("{label}: the prediction header\n{text}") };
                assert!(first < second && second < text.find("slowdown one").unwrap_or(0), "{label}: header first");
                if mode == Mode::Bspline {
                    // The arc is a spline, and the comment on its CL point stands among its control points.
                    let lines: Vec<&str> = text.lines().collect();
                    let note = lines.iter().position(|l| l.contains("slowdown one")).unwrap_or(0);
                    let open = lines[..note].iter().rposition(|l| l.contains("BSPLINE") || l.ends_with("G1"));
                    assert!(open.is_some_and(|o| lines[o].contains("BSPLINE")), "{label}: in the spline\n{text}");
                }
                check(&text, &f, d, &options, &label);
            }
        }
    }
}

#[test]
fn one_annotated_program_per_dialect() {
    let f = fixture();
    for &(dialect_name, mode) in PINNED {
        let d = dialect(dialect_name).expect("dialect");
        let text = program(&f, d, &options(mode, &f.solved, false));
        insta::assert_snapshot!(format!("annotated_{dialect_name}__{}", mode.name()), text);
    }
}

/// Comment characters the dialect cannot hold are cleaned (Fanuc: brackets for parentheses, no
/// line breaks), an overlong annotation is cut to the line length, annotations given out of order
/// are written in the order of their steps, and a prediction of NaN still renders.
#[test]
fn annotations_are_cleaned_cut_and_ordered() {
    let f = fixture();
    let d = dialect("fanuc").expect("dialect");
    let last = f.solved.steps.len() - 1;
    let mut options = options(Mode::G1, &f.solved, false);
    options.annotations = vec![
        Annotation { step: last, text: "late".into(), slowdown: None },
        Annotation { step: 3, text: "slow (B acc)\nnext".into(), slowdown: None },
        Annotation { step: 3, text: "x".repeat(1000), slowdown: None },
        Annotation { step: usize::MAX, text: String::new(), slowdown: None },
    ];
    options.prediction =
        Some(Prediction { cycle_time: f64::NAN, planner: "inverse-time (fallback)".into(), ..prediction() });
    let text = program(&f, d, &options);
    let lines: Vec<&str> = text.lines().collect();
    let slow = lines.iter().position(|l| *l == "(slow [B acc] next)").expect("cleaned");
    let long = lines.iter().position(|l| l.starts_with("(xxxx")).expect("cut");
    let late = lines.iter().position(|l| *l == "(late)").expect("late");
    assert!(slow < long && long < late, "{text}");
    assert!(lines[long].len() <= d.max_line);
    assert_eq!(lines.iter().filter(|l| **l == "()").count(), 1, "the empty annotation is kept");
    assert!(text.contains("planner: inverse-time [fallback])"), "{text}");
    assert!(text.contains("predicted cycle time: NaN s"), "{text}");
    // Per operation and the worst slowdowns, cleaned like every comment.
    let header = [
        "(operation ROUGH [D10]: predicted 41.2 s, at the programmed feed 40.0 s, lost 1.2 s, mostly corner)",
        "(operation [unnamed]: predicted 20.0 s, at the programmed feed 20.0 s, lost 0.0 s)",
        "(worst slowdown #2 at CL line 12: 38% of F over 12 blocks, C jerk [A], 0.42 s lost)",
    ];
    for line in header {
        assert!(lines.contains(&line), "`{line}` in\n{text}");
    }
    let first_motion = lines.iter().position(|l| l.starts_with("G0") || l.starts_with("G1")).expect("motion");
    assert!(lines.iter().position(|l| *l == header[2]).is_some_and(|i| i < first_motion), "in the header");
}

/// A whole 5-axis example (its splines refined by the fit, decisions, retracts), an annotation on
/// every 37th step (CL points and linearization points alike) and one past the end.
#[test]
fn annotations_on_a_whole_example() {
    let relative = "examples/cl/hypar-5axis.cl";
    let file = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..").join(relative);
    let f = fixture_of(Source::from_bytes(relative, std::fs::read(&file).expect("the example")));
    let n = f.solved.steps.len();
    let mut annotations: Vec<Annotation> = (0..n)
        .step_by(37)
        .map(|k| Annotation { step: k, text: format!("note at step {k} of {n}"), slowdown: None })
        .collect();
    annotations.push(Annotation { step: n, text: "note past the end".into(), slowdown: None });
    assert!(annotations.iter().any(|a| a.step < n && f.solved.steps[a.step].kind == StepKind::Linearized));
    let d = dialect("siemens-840d").expect("dialect");
    for mode in [Mode::G1, Mode::InverseTime, Mode::Tcp, Mode::Bspline] {
        let options = Options {
            mode,
            program_name: "HYPAR".into(),
            source_name: relative.into(),
            block_numbers: false,
            prediction: None,
            annotations: annotations.clone(),
        };
        let text = program(&f, d, &options);
        let refined = check(&text, &f, d, &options, &format!("hypar {}", mode.name()));
        if mode == Mode::Bspline {
            assert!(refined > 0, "some annotations stand in splines the fit refined");
        }
    }
}

/// Rapid in, plunge at F500, then two moves at F1500 tilting the tool by 20° each (the Mikron
/// linearizes both): with the point before them, three points, too few for a spline.
fn two_tilts_text() -> String {
    let (s20, c20) = (20f64.to_radians().sin(), 20f64.to_radians().cos());
    let (s40, c40) = (40f64.to_radians().sin(), 40f64.to_radians().cos());
    format!(
        "PARTNO/TWO TILTS\nLOAD/TOOL,1,ADJUST,1\nSPINDL/RPM,12000,CLW\nRAPID\n\
         GOTO/10.0000,5.0000,20.0000,0.0000000,0.0000000,1.0000000\nFEDRAT/MMPM,500\nGOTO/10.0000,5.0000,0.0000\n\
         FEDRAT/MMPM,1500\nGOTO/13.0000,5.0000,0.0000,0.0000000,{s20:.7},{c20:.7}\n\
         GOTO/16.0000,5.0000,0.0000,0.0000000,{s40:.7},{c40:.7}\nRAPID\nGOTO/16.0000,5.0000,30.0000\nEND\nFINI\n"
    )
}

/// The programs where a BSPLINE run is written as G1 blocks with linearization points in it: the
/// annotated path (the reorientation: one point, its linearization point carried over from the
/// spline before it by the change of feed), two tilting moves (too few points), and the hypar on
/// the MAHO (near the singularity the spline cannot follow the C swing; a decision on the run's
/// first point, after linearization points).
fn fallback_cases() -> Vec<(&'static str, Fixture)> {
    let hypar = "examples/cl/hypar-5axis.cl";
    let file = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..").join(hypar);
    vec![
        ("annotated", fixture()),
        ("two tilts", fixture_of(Source::new("tilts.cl", two_tilts_text()))),
        (
            "hypar on the MAHO",
            fixture_on(
                Source::from_bytes(hypar, std::fs::read(&file).expect("the example")),
                machine_named("maho600e"),
            ),
        ),
    ]
}

/// A BSPLINE run written as G1 blocks (too short, or a spline that cannot follow it) writes every
/// step of the run in order, linearization points included: read back, each G1 block keeps the
/// tool tip, through the forward kinematics, within the linearization tolerance of its programmed
/// segment, where the straight move between the CL points would not. An annotation on a
/// linearization point of such a run stands right before that point's own block. The header's
/// count of points added by linearization is that of the solution, as in G1 mode.
#[test]
fn a_bspline_run_written_as_g1_keeps_its_linearization_points() {
    let d = dialect("siemens-840d").expect("dialect");
    for (name, f) in fallback_cases() {
        let steps = &f.solved.steps;
        let tolerance = f.machine.policy.linearization_tolerance;
        let plain = Options {
            mode: Mode::Bspline,
            program_name: "FALLBACK".into(),
            source_name: name.into(),
            block_numbers: false,
            prediction: None,
            annotations: Vec::new(),
        };
        let text = program(&f, d, &plain);
        // The header counts the points linearization added, whatever the mode writes of them.
        let count = format!("added by linearization: {} ", f.solved.inserted);
        let g1 = program(&f, d, &Options { mode: Mode::G1, ..plain.clone() });
        let header = |t: &str| t.lines().find(|l| l.contains("CL points: ")).map(str::to_string);
        assert!(text.contains(&count), "{name}: {count}\n{text}");
        assert_eq!(header(&text), header(&g1), "{name}: the header as in G1 mode");

        let letters: Vec<String> = f.machine.axes.iter().map(|a| a.letter.clone()).collect();
        let back = read_back(&text, &letters);
        let written = f.written(Mode::Bspline);
        let frame = f.frame(Mode::Bspline);
        let pos = |k: usize| position(&written[k], Mode::Bspline, &f.machine);
        let joints = |i: usize| {
            let values: Vec<f64> = f
                .machine
                .axes
                .iter()
                .map(|a| {
                    let v = back.state[i][&a.letter];
                    if a.kind == AxisKind::Rotary { v.to_radians() } else { v }
                })
                .collect();
            frame.unapply(&Joints::from_slice(&values))
        };
        // Each G1 block outside the splines is the block of the next step at its position.
        let mut next = 0;
        let mut blocks: Vec<(usize, usize)> = Vec::new(); // (line, step)
        for i in (0..back.g1.len()).filter(|&i| back.g1[i]) {
            let Some(s) = (next..steps.len()).find(|&s| at(&back.state[i], &pos(s))) else {
                panic!("{name}: line {} is no step's block\n{text}", i + 1)
            };
            blocks.push((i, s));
            next = s + 1;
        }
        // The linearization points of the runs written as G1: those of a CL point reached by a G1
        // block. Each has its block, in order, and the straight move to the CL point leaves the band.
        let mut fallback = 0;
        for &(_, b) in blocks.iter().filter(|&&(_, s)| steps[s].kind != StepKind::Linearized) {
            let first = (0..b).rev().take_while(|&j| steps[j].kind == StepKind::Linearized).last();
            let Some(first) = first else { continue };
            for j in first..b {
                assert!(
                    blocks.iter().any(|&(_, s)| s == j),
                    "{name}: linearization point {j} of step {b} written\n{text}"
                );
            }
            let straight = linearize::deviation(f.kin.as_ref(), &steps[first - 1], &steps[b]);
            assert!(straight > tolerance, "{name}: step {b}'s straight move is {straight} mm off");
            fallback += b - first;
        }
        assert!(fallback > 0, "{name}: a run written as G1 with linearization points\n{text}");
        // Read back: the tip between consecutive positions stays within the tolerance of the
        // programmed segment (from the step before the CL point to the CL point).
        for &(i, s) in &blocks {
            let b = (s..steps.len()).find(|&b| steps[b].kind != StepKind::Linearized).unwrap_or(s);
            let a = (0..b).rev().find(|&a| steps[a].kind != StepKind::Linearized).expect("a step before");
            let (from, to) = (joints(i - 1), joints(i));
            let (p, q) = (steps[a].pose.tip, steps[b].pose.tip);
            for t in 0..=16 {
                let tip = f.kin.forward(&from.lerp(&to, f64::from(t) / 16.0)).tip;
                let pq = q - p;
                let u = ((tip - p).dot(&pq) / pq.norm_squared().max(1e-12)).clamp(0.0, 1.0);
                let off = (tip - (p + pq * u)).norm();
                assert!(
                    off < tolerance + 0.005,
                    "{name}: line {} (step {s}) is {off} mm off the segment of step {b}\n{text}",
                    i + 1
                );
            }
        }

        // Annotations on every linearization point written, on their CL points, on every 37th step.
        let lin: Vec<usize> =
            blocks.iter().map(|&(_, s)| s).filter(|&s| steps[s].kind == StepKind::Linearized).collect();
        let mut marked: Vec<usize> = lin.iter().flat_map(|&j| [j, j + 1]).chain((0..steps.len()).step_by(37)).collect();
        marked.sort_unstable();
        marked.dedup();
        let n = steps.len();
        let annotations: Vec<Annotation> = marked
            .iter()
            .map(|&k| Annotation { step: k, text: format!("note at step {k} of {n}"), slowdown: None })
            .collect();
        for block_numbers in [false, true] {
            let options = Options { annotations: annotations.clone(), block_numbers, ..plain.clone() };
            let text = program(&f, d, &options);
            check(&text, &f, d, &options, &format!("{name} {block_numbers}"));
            // Right before the point's own G1 block: the next line that moves.
            let lines: Vec<&str> = text.lines().collect();
            let back = read_back(&text, &letters);
            for &j in &lin {
                let note = format!("note at step {j} of {n}");
                let c = lines.iter().position(|l| l.contains(note.as_str())).expect("written");
                let own = (c + 1..lines.len()).find(|&i| back.motion[i]).expect("a block after");
                assert!(back.g1[own] && at(&back.state[own], &pos(j)), "{name}: `{note}` before its block\n{text}");
            }
        }
    }
}
