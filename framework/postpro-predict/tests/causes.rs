//! Time lost and its causes (issue 16): on every bundled example (`examples/cl/*.cl`), with both
//! planners and every output mode, the causes add up to the time lost, which is the blocks', and
//! the cycle time is the time at the programmed feed plus it; the marks count no exact stop, no
//! run whose only losses are its own start and end is marked, and a plain NX facing program gets
//! at most a handful of marks.

#![allow(clippy::unwrap_used)]

use std::path::PathBuf;

use postpro_machine::{Machine, Registry};
use postpro_motion::Mode;
use postpro_predict::{BlockKind, BlockResult, Limit, MarkRules, Options, Planner, Prediction, Timing};

/// The bundled examples and the machines that reach them.
const CASES: [(&str, &[&str]); 4] = [
    ("hypar-5axis.cl", &["mikron", "maho600e"]),
    ("hypar-3plus2.cl", &["mikron", "maho600e"]),
    ("bicubic-5axis.cl", &["mikron", "maho600e"]),
    ("manta-5axis.cl", &["nutating"]),
];

/// The folder of the bundled examples.
fn examples() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../examples/cl")
}

/// The text of the bundled example `name`.
fn example(name: &str) -> String {
    std::fs::read_to_string(examples().join(name)).unwrap()
}

fn machine(name: &str) -> Machine {
    Registry::builtin().expect("the built-ins load").find(name).expect("built in").machine.clone()
}

fn read(name: &str, text: &str, machine: &Machine) -> (postpro_cl::ToolPath, postpro_kin::Solved) {
    let source = postpro_cl::Source::new(name, text);
    let path = postpro_cl::read(&source);
    assert!(!path.has_errors(), "{name} reads");
    let kin = postpro_kin::solver_for(machine);
    let solved = postpro_kin::solve(kin.as_ref(), &path, &machine.policy).expect("the program solves");
    (path, solved)
}

/// Every output mode: `g1` (F on the axes), `inverse-time` and `tcp` (F on the tip), `bspline`
/// where the machine's dialect has it (Siemens).
fn modes(machine: &Machine) -> Vec<Mode> {
    let mut modes = vec![Mode::G1, Mode::InverseTime, Mode::Tcp];
    if machine.dialect == "siemens-840d" {
        modes.push(Mode::Bspline);
    }
    modes
}

/// The prediction of the motion program of `text` in `mode` by `planner`.
fn predict(text: &str, name: &str, machine: &Machine, mode: Mode, planner: Planner) -> Prediction {
    predict_with(text, name, machine, mode, Options { planner, ..Options::default() })
}

/// The prediction of the motion program of `text` in `mode` with `options` (the spline model
/// where the mode writes splines).
fn predict_with(text: &str, name: &str, machine: &Machine, mode: Mode, options: Options) -> Prediction {
    let (path, solved) = read(name, text, machine);
    let kin = postpro_kin::solver_for(machine);
    let program = postpro_motion::study(&path, &solved, kin.as_ref(), mode).expect("the motion program builds");
    let timing = if mode.feeds_the_tip() { Timing::TipFeed } else { Timing::AxisFeed };
    let blocks = postpro_predict::blocks(&program, machine, timing);
    let options = Options { splines: mode == Mode::Bspline, ..options };
    postpro_predict::predict(&blocks, kin.as_ref(), &options)
}

/// True for a feed block that loses no time to an exact stop: its lowest feed between stops is
/// its lowest feed.
fn away_from_stops(b: &BlockResult) -> bool {
    b.kind == BlockKind::Feed && b.stop_lost == 0.0
}

/// What breaks the accounting of one prediction (empty when nothing does).
fn accounting(p: &Prediction, period: f64, splines: bool, case: &str) -> Vec<String> {
    let mut failures = Vec::new();
    let t = p.totals();
    let mut fail = |what: String| failures.push(format!("{case}: {what}"));
    let blocks: f64 = p.blocks.iter().map(|b| b.lost).sum();
    if (blocks - t.time_lost).abs() > 1e-9 {
        fail(format!("the blocks lose {blocks} s, the total says {} s", t.time_lost));
    }
    if (t.cycle_time - t.programmed_time - t.time_lost).abs() > 1e-9 {
        fail(format!("{} s ≠ {} s + {} s", t.cycle_time, t.programmed_time, t.time_lost));
    }
    let causes: f64 = p.causes().iter().map(|c| c.seconds).sum();
    if (causes - t.time_lost).abs() > period {
        fail(format!("the causes add up to {causes} s, the time lost is {} s", t.time_lost));
    }
    for op in &p.operations {
        let sum: f64 = op.causes.iter().map(|c| c.seconds).sum();
        if (sum - op.time_lost).abs() > period {
            fail(format!("operation {}: causes {sum} s, time lost {} s", op.name, op.time_lost));
        }
    }
    let cycle: f64 = p.operations.iter().map(|o| o.cycle_time).sum();
    if (cycle - t.cycle_time).abs() > 1e-6 {
        fail(format!("the operations last {cycle} s, the program {} s", t.cycle_time));
    }
    for (i, b) in p.blocks.iter().enumerate() {
        if b.kind != BlockKind::Feed && b.lost != 0.0 {
            fail(format!("block {i} is no feed move and loses {} s", b.lost));
        }
        // Per block: the predicted time minus the tip length at the CL file's feed (the examples
        // have no dwell; a spline's block stands for the points the fit passes through).
        if !splines && b.kind == BlockKind::Feed {
            let at_feed = b.length / b.programmed * 60.0;
            if (b.time - b.lost - at_feed).abs() > 1e-9 {
                fail(format!("block {i}: {} s, {} s lost, {at_feed} s at the feed", b.time, b.lost));
            }
        }
        // The slowdown marks quote the lowest feed apart from the braking into and the
        // acceleration out of exact stops: on a block where no time goes to one, every step of
        // it counts (those within a piece as well as those that cross a junction).
        if away_from_stops(b) && b.min_feed_between_stops != b.min_feed {
            fail(format!("block {i}: {} mm/min between stops, {} mm/min lowest", b.min_feed_between_stops, b.min_feed));
        }
    }
    failures
}

#[test]
fn the_causes_add_up_to_the_time_lost_on_every_example_planner_and_mode() {
    let dir = examples();
    let mut files: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".cl"))
        .collect();
    files.sort();
    let mut covered: Vec<String> = CASES.iter().map(|(f, _)| f.to_string()).collect();
    covered.sort();
    assert_eq!(files, covered, "every bundled example has its machines");
    let mut failures = Vec::new();
    let (mut runs, mut blocks, mut checked) = (0, 0, 0);
    for (file, machines) in CASES {
        let text = example(file);
        for name in machines {
            let machine = machine(name);
            for mode in modes(&machine) {
                let splines = mode == Mode::Bspline;
                for planner in [Planner::InverseTime, Planner::Vpop] {
                    let p = predict(&text, file, &machine, mode, planner);
                    let case = format!("{file} on {name}, {}, {planner:?}", mode.name());
                    assert!(p.totals().time_lost > 0.0, "{case}: the examples all lose time");
                    failures.extend(accounting(&p, machine.cnc.cycle_time, splines, &case));
                    runs += 1;
                    blocks += p.blocks.len();
                    checked += p.blocks.iter().filter(|b| away_from_stops(b)).count();
                }
            }
        }
    }
    assert!(runs >= 24, "{runs} predictions");
    assert!(checked * 2 > blocks, "{checked} of {blocks} blocks lose nothing to an exact stop");
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn g1_output_on_a_five_axis_machine_loses_what_f_on_the_axes_costs() {
    // In G1 the CNC reads F as the feed of the linear axes: the program itself asks for another
    // time than the CL file's feed, and that difference is a cause of its own.
    let text = example("hypar-5axis.cl");
    let mikron = machine("mikron");
    let g1 = predict(&text, "hypar-5axis.cl", &mikron, Mode::G1, Planner::InverseTime);
    let tip = predict(&text, "hypar-5axis.cl", &mikron, Mode::InverseTime, Planner::InverseTime);
    let axis_feed = |p: &Prediction| p.causes().iter().find(|c| c.limit == Limit::AxisFeed).map_or(0.0, |c| c.seconds);
    assert!(axis_feed(&g1) > 1.0, "G1 on the Mikron: {:?}", g1.causes());
    assert_eq!(axis_feed(&tip), 0.0, "F on the tip: {:?}", tip.causes());
    // The time at the programmed feed is the CL file's, whatever the mode.
    let at_feed = |p: &Prediction| p.totals().programmed_time;
    assert!((at_feed(&g1) - at_feed(&tip)).abs() < 1e-6, "{} s and {} s", at_feed(&g1), at_feed(&tip));
}

/// Straight passes between rapids in 1 mm blocks on a 3-axis machine, each block's feed reached
/// but near its ends.
fn passes(feed: f64) -> String {
    let mut text = String::from("TOOL PATH/PASSES,TOOL,MILL\nLOAD/TOOL,1\nSPINDL/RPM,10000,CLW\n");
    for pass in 0..3 {
        let y = 20.0 * f64::from(pass);
        text.push_str(&format!("RAPID\nGOTO/0,{y},5\nRAPID\nGOTO/0,{y},0\nFEDRAT/MMPM,{feed}\n"));
        for x in 1..=120 {
            text.push_str(&format!("GOTO/{x},{y},0\n"));
        }
        text.push_str(&format!("RAPID\nGOTO/120,{y},5\n"));
    }
    text
}

#[test]
fn no_mark_on_a_run_whose_only_losses_are_its_own_start_and_end() {
    let vmc = machine("example-3axis-vmc");
    for planner in [Planner::InverseTime, Planner::Vpop] {
        let p = predict(&passes(6000.0), "passes.cl", &vmc, Mode::G1, planner);
        let t = p.totals();
        // The passes do lose time, and it is all the exact stops'.
        assert!(t.time_lost > 0.05, "{planner:?}: {} s", t.time_lost);
        let stops: f64 = p.blocks.iter().map(|b| b.stop_lost).sum();
        // (The interpolator settling on the feed after a stop loses a hair more: 1 ms per pass.)
        assert!(stops >= 0.98 * t.time_lost, "{planner:?}: {stops} s of {} s to the stops", t.time_lost);
        let slow = p.blocks.iter().filter(|b| b.kind == BlockKind::Feed && b.min_ratio() < 0.8).count();
        assert!(slow >= 6, "{planner:?}: the blocks at the passes' ends are slow ({slow})");
        // Whatever the minimum, nothing is marked.
        let rules = MarkRules { min_loss: 0.0, ..MarkRules::default() };
        assert_eq!(p.marks(&rules), [], "{planner:?}");
    }
}

#[test]
fn a_corner_in_the_middle_of_a_pass_is_marked_with_what_it_costs() {
    // The same passes with a sharp turn half way: that one is the programmer's.
    let vmc = machine("example-3axis-vmc");
    let mut text = String::from("LOAD/TOOL,1\nRAPID\nGOTO/0,0,0\nFEDRAT/MMPM,6000\n");
    for x in 1..=60 {
        text.push_str(&format!("GOTO/{x},0,0\n"));
    }
    for y in 1..=60 {
        text.push_str(&format!("GOTO/60,{y},0\n"));
    }
    text.push_str("RAPID\nGOTO/60,60,5\n");
    let p = predict(&text, "corner.cl", &vmc, Mode::G1, Planner::InverseTime);
    let marks = p.marks(&MarkRules { min_loss: 0.0, ..MarkRules::default() });
    assert_eq!(marks.len(), 1, "{marks:?}");
    let m = marks[0];
    assert_eq!((m.number, m.cause), (1, Limit::Corner), "{m:?}");
    assert!(m.first <= 61 && 61 <= m.last + 1, "around the turn: {m:?}");
    let own: f64 = (m.first..=m.last).map(|i| p.blocks[i].lost - p.blocks[i].stop_lost).sum();
    assert!((m.lost - own).abs() < 1e-12 && m.lost > 0.0, "{m:?}");
    // Above its loss it is not marked.
    assert_eq!(p.marks(&MarkRules { min_loss: m.lost * 1.01, ..MarkRules::default() }), []);
}

#[test]
fn marks_are_capped_per_operation_keeping_the_worst() {
    let text = example("hypar-5axis.cl");
    let maho = machine("maho600e");
    let p = predict(&text, "hypar-5axis.cl", &maho, Mode::G1, Planner::InverseTime);
    let all = p.marks(&MarkRules { max_per_operation: usize::MAX, ..MarkRules::default() });
    let five = p.marks(&MarkRules { max_per_operation: 5, ..MarkRules::default() });
    assert!(all.len() > 5, "{} marks", all.len());
    assert_eq!(five.len(), 5);
    let mut losses: Vec<f64> = all.iter().map(|m| m.lost).collect();
    losses.sort_by(|a, b| b.total_cmp(a));
    let kept: f64 = five.iter().map(|m| m.lost).sum();
    assert!((kept - losses[..5].iter().sum::<f64>()).abs() < 1e-12, "the worst five kept");
    assert!(five.windows(2).all(|w| w[0].first < w[1].first), "in program order");
    assert_eq!(five.iter().map(|m| m.number).collect::<Vec<_>>(), [1, 2, 3, 4, 5]);
    for m in &all {
        assert!(m.lost >= 0.05 && m.ratio < 0.8, "{m:?}");
        assert!(m.cause != Limit::Stop && m.cause != Limit::Plunge, "{m:?}");
    }
}

#[test]
fn a_plain_nx_facing_program_gets_at_most_a_handful_of_marks() {
    // NX FLOOR_FACING, zig with rapids between the passes, 37 minutes at 250 mm/min: before
    // issue 16, 134 marks for 1.3 s lost.
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/data/peers/userFour__MECH491-postprocessor/SimpleMillPlane_ZIG/input/APT_SimpleMillPlane_ZIG.txt");
    let text = std::fs::read_to_string(&path)
        .unwrap_or_else(|e| panic!("{}: {e} (../shared must sit beside the repository)", path.display()));
    let vmc = machine("example-3axis-vmc");
    for planner in [Planner::InverseTime, Planner::Vpop] {
        let p = predict(&text, "APT_SimpleMillPlane_ZIG.txt", &vmc, Mode::G1, planner);
        assert!(p.totals().cycle_time > 2000.0, "{planner:?}: {}", p.totals().cycle_time);
        assert_eq!(p.operations.len(), 1);
        assert_eq!(p.operations[0].name, "FLOOR_FACING");
        let marks = p.marks(&MarkRules::default());
        assert!(marks.len() <= 5, "{planner:?}: {} marks: {marks:?}", marks.len());
        failures_are_none(accounting(&p, vmc.cnc.cycle_time, false, &format!("facing, {planner:?}")));
    }
}

/// The tip length of the feed blocks between consecutive samples whose feed is below `threshold`
/// × the programmed feed at the later sample: the share of the feed path below it, read from the
/// samples themselves.
fn length_below_from_samples(p: &Prediction, threshold: f64) -> f64 {
    let s = p.samples.as_ref().expect("samples kept");
    (1..s.len())
        .filter(|&i| p.blocks[s.block[i] as usize].kind == BlockKind::Feed && s.feed[i] < threshold * s.programmed[i])
        .map(|i| s.path[i] - s.path[i - 1])
        .sum()
}

#[test]
fn the_feed_path_below_the_threshold_counts_the_steps_that_cross_junctions() {
    // Blocks of a few interpolation periods, many of whose steps cross a junction (nearly all on
    // a spline's short pieces): the share of the feed path below the threshold is the samples'
    // (it left out every step that crossed one: 67.6 % of a G1 finishing path was 97 %, 5.0 % of
    // its B-spline program 41.7 %).
    for (name, machines) in CASES {
        let text = example(name);
        for m in machines {
            let machine = machine(m);
            for mode in modes(&machine) {
                let p = predict_with(&text, name, &machine, mode, Options { samples: true, ..Options::default() });
                let t = p.totals();
                let expected = length_below_from_samples(&p, t.threshold);
                // A step across a junction is compared at the speeds of both its ends; the samples
                // compare it at its end only.
                assert!(
                    (t.length_below - expected).abs() <= 0.001 * t.feed_length,
                    "{name} on {m}, {mode:?}: {:.1} mm below, the samples say {expected:.1} mm of {:.1} mm",
                    t.length_below,
                    t.feed_length
                );
            }
        }
    }
}

fn failures_are_none(failures: Vec<String>) {
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
