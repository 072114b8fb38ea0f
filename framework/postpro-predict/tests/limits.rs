//! No sample exceeds an axis limit (issue "Predict", item 3, point 2): every bundled example
//! (`examples/cl/*.cl`) on a machine that reaches it, with both planners. The largest ratios
//! found are printed (`cargo test -p postpro-predict --test limits -- --nocapture`) and given in
//! `docs/validation-prediction.draft.md`.

#![allow(clippy::unwrap_used, clippy::print_stdout)]

use std::fmt::Write as _;
use std::path::PathBuf;

use postpro_machine::{Machine, Registry};
use postpro_motion::Mode;
use postpro_predict::{Options, Planner, Prediction, Samples, Timing};

/// The bundled examples and the machines that reach them.
const CASES: [(&str, &str); 5] = [
    ("hypar-5axis.cl", "mikron"),
    ("hypar-5axis.cl", "maho600e"),
    ("bicubic-5axis.cl", "mikron"),
    ("bicubic-5axis.cl", "maho600e"),
    ("manta-5axis.cl", "nutating"),
];

const PLANNERS: [Planner; 2] = [Planner::InverseTime, Planner::Vpop];

fn example(file: &str) -> String {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../examples/cl").join(file);
    std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// The prediction of `file` in `mode` (B-spline output is predicted along the spline the program
/// writes), samples kept.
fn predict_in(file: &str, machine: &Machine, planner: Planner, mode: Mode) -> Prediction {
    let text = example(file);
    let source = postpro_cl::Source::new(file, text.as_str());
    let path = postpro_cl::read(&source);
    assert!(!path.has_errors(), "{file} reads");
    let kin = postpro_kin::solver_for(machine);
    let solved = postpro_kin::solve(kin.as_ref(), &path, &machine.policy).expect("the example solves");
    let program = postpro_motion::study(&path, &solved, kin.as_ref(), mode).expect("the motion program builds");
    let blocks = postpro_predict::blocks(&program, machine, Timing::TipFeed);
    let splines = mode == Mode::Bspline;
    let options = Options { planner, threshold: 0.8, samples: true, splines, ..Options::default() };
    postpro_predict::predict(&blocks, kin.as_ref(), &options)
}

/// The largest ratios to the limits over the samples of one prediction.
#[derive(Debug, Default, Clone, Copy)]
struct Worst {
    /// Per axis: |v| / Vmax, |a| / Amax, |j| / Jmax, finite difference of the position / Vmax.
    velocity: [f64; 5],
    acceleration: [f64; 5],
    jerk: [f64; 5],
    position_difference: [f64; 5],
    /// Within one block: finite differences of the velocity / Amax and of the acceleration / Jmax.
    velocity_difference: [f64; 5],
    acceleration_difference: [f64; 5],
    /// Predicted over programmed feed, on feed samples.
    feed: f64,
    /// Samples, and time steps that do not increase.
    samples: usize,
    not_increasing: usize,
    /// |v| of any axis at the first and last sample, over Vmax.
    start_speed: f64,
    end_speed: f64,
    /// Samples at rest strictly inside a block (the samples before and after are in the same
    /// block): the motion stopped where nothing asks it to and started again.
    rests_within_a_block: usize,
}

fn worst(s: &Samples, machine: &Machine) -> Worst {
    let n = s.axes;
    assert!(n <= 5);
    let mut w = Worst { samples: s.len(), ..Worst::default() };
    for k in 0..s.len() {
        for (i, axis) in machine.axes.iter().enumerate() {
            let at = k * n + i;
            w.velocity[i] = w.velocity[i].max(s.velocity[at].abs() / axis.vmax);
            w.acceleration[i] = w.acceleration[i].max(s.acceleration[at].abs() / axis.amax);
            w.jerk[i] = w.jerk[i].max(s.jerk[at].abs() / axis.jmax);
            if k + 1 < s.len() {
                let dt = s.time[k + 1] - s.time[k];
                if dt > 0.0 {
                    let next = at + n;
                    let fd = (s.position[next] - s.position[at]).abs() / dt;
                    w.position_difference[i] = w.position_difference[i].max(fd / axis.vmax);
                    if s.block[k + 1] == s.block[k] {
                        let dv = (s.velocity[next] - s.velocity[at]).abs() / dt;
                        let da = (s.acceleration[next] - s.acceleration[at]).abs() / dt;
                        w.velocity_difference[i] = w.velocity_difference[i].max(dv / axis.amax);
                        w.acceleration_difference[i] = w.acceleration_difference[i].max(da / axis.jmax);
                    }
                }
            }
        }
        if s.programmed[k] > 0.0 {
            w.feed = w.feed.max(s.feed[k] / s.programmed[k]);
        }
        if k + 1 < s.len() && s.time[k + 1] <= s.time[k] {
            w.not_increasing += 1;
        }
    }
    let speed = |k: usize| (0..n).map(|i| s.velocity[k * n + i].abs() / machine.axes[i].vmax).fold(0.0, f64::max);
    w.start_speed = speed(0);
    w.end_speed = speed(s.len() - 1);
    w.rests_within_a_block = (1..s.len() - 1)
        .filter(|&k| speed(k) == 0.0 && s.block[k - 1] == s.block[k] && s.block[k + 1] == s.block[k])
        .count();
    w
}

fn max(xs: &[f64]) -> f64 {
    xs.iter().copied().fold(0.0, f64::max)
}

fn table(machine: &Machine, name: &str, values: &[f64; 5]) -> String {
    let mut line = format!("    {name:<22}");
    for (axis, v) in machine.axes.iter().zip(values) {
        write!(line, " {}={v:.6}", axis.letter).unwrap();
    }
    line
}

/// What [`check`] asserts.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Checks {
    /// |v|, |a|, |j| ≤ limit × (1 + 1e-6) per axis, time strictly increasing, at rest at both
    /// ends, finite differences of the positions ≤ Vmax × (1 + 1e-3).
    Axes,
    /// The feed ≤ the programmed feed × (1 + 1e-3): the discretisation of one period (the speed
    /// cap is met at the end of a step, the feed of the samples in between may pass it by that).
    Feed,
    /// Within a block, the finite differences of the velocities ≤ Amax × (1 + 1e-3) and of the
    /// accelerations ≤ Jmax × (1 + 1e-2) (a jump of the acceleration is a jerk the jerk column
    /// does not show; the cruise snaps to its cap by at most 1e-4 of Amax in one period), and no
    /// rest inside a block.
    WithinBlocks,
}

/// Predicts `file` on the machine `name` with both planners, prints the largest ratios to the
/// limits and returns what breaks `checks` (empty when nothing does).
fn check(file: &str, name: &str, checks: Checks) -> String {
    check_in(file, name, checks, Mode::G1)
}

/// [`check`] on the motion program of `mode`; B-spline output is predicted along its spline,
/// with VPOp only (the block-wise model has no splines).
fn check_in(file: &str, name: &str, checks: Checks, mode: Mode) -> String {
    let machine = Registry::builtin().expect("the built-ins load").find(name).expect("built in").machine.clone();
    let mut failures = String::new();
    let planners: &[Planner] = if mode == Mode::Bspline { &[Planner::Vpop] } else { &PLANNERS };
    for &planner in planners {
        let p = predict_in(file, &machine, planner, mode);
        let w = worst(p.samples.as_ref().expect("samples kept"), &machine);
        let case = format!("{file} on {} ({planner:?}, {mode:?})", machine.name);
        println!("{case}: {} samples, cycle time {:.3} s", w.samples, p.totals().cycle_time);
        println!("{}", table(&machine, "|v| / Vmax", &w.velocity));
        println!("{}", table(&machine, "|a| / Amax", &w.acceleration));
        println!("{}", table(&machine, "|j| / Jmax", &w.jerk));
        println!("{}", table(&machine, "Δpos/Δt / Vmax", &w.position_difference));
        println!("{}", table(&machine, "Δv/Δt / Amax (block)", &w.velocity_difference));
        println!("{}", table(&machine, "Δa/Δt / Jmax (block)", &w.acceleration_difference));
        println!("    feed / programmed      {:.9}", w.feed);
        println!("    speed at start, end    {:.3e}, {:.3e}", w.start_speed, w.end_speed);
        println!("    rests within a block   {}", w.rests_within_a_block);
        let mut fail = |what: &str, ok: bool| {
            if !ok {
                writeln!(failures, "{case}: {what}").unwrap();
            }
        };
        match checks {
            Checks::Axes => {
                fail("velocity", max(&w.velocity) <= 1.0 + 1e-6);
                fail("acceleration", max(&w.acceleration) <= 1.0 + 1e-6);
                fail("jerk", max(&w.jerk) <= 1.0 + 1e-6);
                fail("time not strictly increasing", w.not_increasing == 0);
                fail("not at rest at the start", w.start_speed == 0.0);
                fail("not at rest at the end", w.end_speed == 0.0);
                fail("finite differences of the positions", max(&w.position_difference) <= 1.0 + 1e-3);
            }
            Checks::Feed => fail(&format!("feed {} × the programmed feed", w.feed), w.feed <= 1.0 + 1e-3),
            Checks::WithinBlocks => {
                fail("finite differences of the velocities", max(&w.velocity_difference) <= 1.0 + 1e-3);
                fail("finite differences of the accelerations", max(&w.acceleration_difference) <= 1.0 + 1e-2);
                fail(&format!("{} rests within a block", w.rests_within_a_block), w.rests_within_a_block == 0);
            }
        }
    }
    failures
}

fn assert_all(checks: Checks) {
    let failures: String = CASES.iter().map(|(file, name)| check(file, name, checks)).collect();
    assert!(failures.is_empty(), "{failures}");
}

#[test]
fn hypar_on_the_mikron_keeps_the_axis_limits() {
    let failures = check("hypar-5axis.cl", "mikron", Checks::Axes);
    assert!(failures.is_empty(), "{failures}");
}

#[test]
fn hypar_on_the_maho_keeps_the_axis_limits() {
    let failures = check("hypar-5axis.cl", "maho600e", Checks::Axes);
    assert!(failures.is_empty(), "{failures}");
}

#[test]
fn bicubic_on_the_mikron_keeps_the_axis_limits() {
    let failures = check("bicubic-5axis.cl", "mikron", Checks::Axes);
    assert!(failures.is_empty(), "{failures}");
}

#[test]
fn bicubic_on_the_maho_keeps_the_axis_limits() {
    let failures = check("bicubic-5axis.cl", "maho600e", Checks::Axes);
    assert!(failures.is_empty(), "{failures}");
}

#[test]
fn manta_on_the_nutating_head_keeps_the_axis_limits() {
    let failures = check("manta-5axis.cl", "nutating", Checks::Axes);
    assert!(failures.is_empty(), "{failures}");
}

#[test]
fn no_example_exceeds_its_programmed_feed() {
    assert_all(Checks::Feed);
}

#[test]
fn within_a_block_the_accelerations_and_jerks_are_those_of_the_samples() {
    assert_all(Checks::WithinBlocks);
}

/// B-spline output, predicted along the spline the program writes (pieces whose caps bound the
/// spline's derivatives): no sample of any example exceeds an axis's velocity, acceleration or
/// jerk, and the motion starts and ends at rest.
#[test]
fn every_example_in_b_spline_mode_keeps_the_axis_limits() {
    let failures: String = CASES.iter().map(|(file, name)| check_in(file, name, Checks::Axes, Mode::Bspline)).collect();
    assert!(failures.is_empty(), "{failures}");
}
