//! The streamed prediction is the whole one (issue 15): fed the motion program block by block,
//! forgetting every block and piece its look-ahead no longer needs, it gives every block the same
//! result, and the same totals, operations and marks, on every bundled example with both planners
//! and every output mode; and what it holds does not grow with the program.

#![allow(clippy::unwrap_used)]

use std::path::PathBuf;

use postpro_machine::{Machine, Registry};
use postpro_motion::Mode;
use postpro_predict::moves::Reader;
use postpro_predict::{
    BlockResult, Blocks, Mark, MarkFinder, MarkRules, Operation, Options, Planner, Predictor, Timing, Totals,
};

const CASES: [(&str, &[&str]); 4] = [
    ("hypar-5axis.cl", &["mikron", "maho600e"]),
    ("hypar-3plus2.cl", &["mikron"]),
    ("bicubic-5axis.cl", &["maho600e"]),
    ("manta-5axis.cl", &["nutating"]),
];

fn machine(name: &str) -> Machine {
    Registry::builtin().expect("the built-ins load").find(name).expect("built in").machine.clone()
}

fn modes(machine: &Machine) -> Vec<Mode> {
    let mut modes = vec![Mode::G1, Mode::InverseTime, Mode::Tcp];
    if machine.dialect == "siemens-840d" {
        modes.push(Mode::Bspline);
    }
    modes
}

fn program(text: &str, name: &str, machine: &Machine, mode: Mode) -> postpro_motion::Program {
    let source = postpro_cl::Source::new(name, text);
    let path = postpro_cl::read(&source);
    let kin = postpro_kin::solver_for(machine);
    let solved = postpro_kin::solve(kin.as_ref(), &path, &machine.policy).expect("the program solves");
    postpro_motion::study(&path, &solved, kin.as_ref(), mode).expect("the motion program builds")
}

/// What a streamed prediction gives, and the most blocks it held at once.
struct Streamed {
    results: Vec<BlockResult>,
    totals: Totals,
    operations: Vec<Operation>,
    marks: Vec<Mark>,
    held: usize,
}

fn streamed(program: &postpro_motion::Program, machine: &Machine, options: &Options, timing: Timing) -> Streamed {
    let kin = postpro_kin::solver_for(machine);
    let mut blocks = Blocks::new(machine);
    let mut reader = Reader::new(timing);
    let mut predictor = Predictor::new(kin.as_ref(), options, blocks.axes, true);
    let mut finder = MarkFinder::new(MarkRules::default());
    let mut results = Vec::new();
    let mut held = 0;
    let mut take = |range: std::ops::Range<usize>, predictor: &Predictor<'_>, blocks: &Blocks| {
        for i in range {
            assert_eq!(i, results.len(), "the results come in order");
            let r = *predictor.result(i);
            finder.block(i, &r, blocks.operation[i] as usize);
            results.push(r);
        }
    };
    for block in &program.blocks {
        reader.block(&mut blocks, machine, block);
        let range = predictor.advance(&blocks);
        take(range, &predictor, &blocks);
        let from = predictor.needs_from(&blocks);
        blocks.forget_before(from);
        held = held.max(blocks.length.held().len());
    }
    let range = predictor.finish(&blocks);
    take(range, &predictor, &blocks);
    Streamed { results, totals: predictor.totals(), operations: predictor.operations(), marks: finder.finish(), held }
}

/// The streamed prediction of `program` gives what the whole one gives, holding fewer blocks.
fn assert_the_streamed_is_the_whole(
    case: &str,
    program: &postpro_motion::Program,
    machine: &Machine,
    (mode, planner): (Mode, Planner),
) {
    let timing = if mode.feeds_the_tip() { Timing::TipFeed } else { Timing::AxisFeed };
    let options = Options { planner, splines: mode == Mode::Bspline, ..Options::default() };
    let kin = postpro_kin::solver_for(machine);
    let whole_blocks = postpro_predict::blocks(program, machine, timing);
    let whole = postpro_predict::predict(&whole_blocks, kin.as_ref(), &options);
    let s = streamed(program, machine, &options, timing);
    assert_eq!(s.results.len(), whole.blocks.len(), "{case}: every block");
    if let Some(i) = (0..s.results.len()).find(|&i| s.results[i] != whole.blocks[i]) {
        panic!("{case}: block {i}: streamed {:?}, whole {:?}", s.results[i], whole.blocks[i]);
    }
    assert_eq!(s.totals, whole.totals(), "{case}: totals");
    assert_eq!(s.operations, whole.operations, "{case}: operations");
    assert_eq!(s.marks, whole.marks(&MarkRules::default()), "{case}: marks");
    assert!(s.held < whole_blocks.len(), "{case}: {} blocks held of {}", s.held, whole_blocks.len());
}

/// A shot-peening path on the MAHO: the motion crossed many counted pieces (stopping, cruising)
/// between two looks at the look-ahead window, and the track had forgotten them meanwhile. The
/// streamed prediction indexed a forgotten piece and panicked.
#[test]
fn the_streamed_prediction_is_the_whole_one_where_the_track_forgot_pieces_the_stepper_had_not_looked_at() {
    let file = "liubaishuo-github__peening-post-processor__peening.aptsource";
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data/cl").join(file);
    let text = std::fs::read_to_string(&path).unwrap();
    let machine = machine("maho600e");
    for mode in [Mode::G1, Mode::InverseTime] {
        let program = program(&text, file, &machine, mode);
        let case = format!("{file} on the MAHO, {mode:?}");
        assert_the_streamed_is_the_whole(&case, &program, &machine, (mode, Planner::InverseTime));
    }
}

#[test]
fn the_streamed_prediction_is_the_whole_one() {
    let examples = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../examples/cl");
    let mut checked = 0;
    for (file, machines) in CASES {
        let text = std::fs::read_to_string(examples.join(file)).unwrap();
        for name in machines {
            let machine = machine(name);
            for mode in modes(&machine) {
                let program = program(&text, file, &machine, mode);
                for planner in [Planner::InverseTime, Planner::Vpop] {
                    let case = format!("{file} on {name}, {mode:?}, {planner:?}");
                    assert_the_streamed_is_the_whole(&case, &program, &machine, (mode, planner));
                    checked += 1;
                }
            }
        }
    }
    assert_eq!(checked, 36);
}

/// A long zig-zag finishing program without an exact stop in its passes: what the streamed
/// prediction holds stays the same from 2 000 to 20 000 blocks.
#[test]
fn what_a_streamed_prediction_holds_does_not_grow_with_the_program() {
    let machine = machine("mikron");
    let held = |passes: usize| {
        let mut text = String::from("FEDRAT/MMPM,3000\nGOTO/0,0,10,0,0,1\n");
        for p in 0..passes {
            for k in 0..100 {
                let x = if p % 2 == 0 { k } else { 99 - k };
                text.push_str(&format!("GOTO/{x},{},{:.3},0,0,1\n", p, 0.01 * f64::from(k as u32)));
            }
        }
        let program = program(&text, "zigzag.cl", &machine, Mode::G1);
        let mut most = 0;
        for planner in [Planner::InverseTime, Planner::Vpop] {
            let options = Options { planner, ..Options::default() };
            let s = streamed(&program, &machine, &options, Timing::AxisFeed);
            assert!(s.totals.cycle_time > 0.0);
            most = most.max(s.held);
        }
        most
    };
    let (short, long) = (held(20), held(200));
    assert!(long <= short.max(64), "held {short} blocks of 2 000, {long} of 20 000");
}
