//! Prediction throughput on programs of about a million blocks (issue "Predict": a 1 M-block
//! program in at most 2 s on one core; the cost per block and per sample).
//!
//! Two workloads, each read and solved once outside the timed loops:
//!
//! - `fine`: `postpro_examples::fine_finishing_file`, the usual CAM finishing output, short
//!   blocks at a moderate feed (the Manta of paper 004 scaled by ½, a point every 0.3 mm on
//!   passes 0.3 mm apart, 3 m/min; also `postpro-examples fine`); on the Mikron UCP 710 (3 ms
//!   cycle, look-ahead 10). A few samples per block.
//! - `coarse`: `postpro_examples::big_goto_file` (layers of the full-size Manta finishing path,
//!   about 4 mm per block at 3–5 m/min); the Manta is 600 mm wide, more than the Mikron's
//!   travels hold, so it runs on the nutating head-head example machine the emit benchmark uses
//!   (2 ms cycle, look-ahead 100). Tens of samples per block.
//!
//! For each, `blocks/<workload>` times [`postpro_predict::blocks`] (the solved tool path into
//! blocks) and `predict/<workload>` times [`postpro_predict::predict`] (inverse-time planner, no
//! samples kept); the throughput is in blocks. The setup prints the number of blocks and of
//! samples (interpolation steps) once, so the time per block and per sample follow from
//! criterion's figures.
//!
//! `cargo bench -p postpro-predict --bench predict`. Environment:
//! - `POSTPRO_BENCH_SCALE` (default 1): the size of both programs relative to about 1 M blocks;
//! - `POSTPRO_BENCH_WORKLOADS` (default `fine,coarse`): which programs to build and measure;
//! - `POSTPRO_BENCH_WRITE_CL=DIR`: also write the two programs as `DIR/predict-fine.cl` and
//!   `DIR/predict-coarse.cl`, for `postpro predict FILE --machine NAME --mode inverse-time
//!   --timing` on the same input (the coarse one is also `postpro-examples big --size-mb 58`).
//!
//! The setup also times one run of `predict` by the wall clock and by the time the thread spent
//! on a CPU (Linux): on a loaded machine the latter is the better figure.

use std::hint::black_box;
use std::path::PathBuf;
use std::time::{Duration, Instant};

use criterion::{Criterion, SamplingMode, Throughput, criterion_group, criterion_main};
use postpro_cl::{Source, read};
use postpro_kin::{Kinematics, solve, solver_for};
use postpro_machine::Registry;
use postpro_machine::model::Machine;
use postpro_predict::{Blocks, Options, Timing, blocks, predict};

/// Size of the coarse program in MiB at scale 1 (about 1 M blocks on the nutating machine).
const COARSE_MB: f64 = 58.0;

/// A program read and solved on a machine, ready to be turned into blocks and predicted.
struct Workload {
    name: &'static str,
    machine: Machine,
    kin: Box<dyn Kinematics>,
    program: postpro_motion::Program,
    blocks: Blocks,
}

/// Reads and solves `text` on `machine`, builds its blocks and predicts them once, printing the
/// sizes (and the time of that one run, for a first figure).
fn prepare(name: &'static str, text: String, machine: &str, registry: &Registry) -> Workload {
    if let Some(dir) = std::env::var_os("POSTPRO_BENCH_WRITE_CL") {
        let file = PathBuf::from(dir).join(format!("predict-{name}.cl"));
        std::fs::write(&file, &text).expect("writes the CL file");
        eprintln!("{name}: wrote {}", file.display());
    }
    let bytes = text.len();
    let source = Source::new(format!("{name}.cl"), text);
    let path = read(&source);
    assert!(!path.has_errors(), "{name}: the generated CL file reads without errors");
    let machine = registry.find(machine).expect("built-in machine").machine.clone();
    let kin = solver_for(&machine);
    let solved = solve(kin.as_ref(), &path, &machine.policy).unwrap_or_else(|e| panic!("{name}: does not solve: {e}"));
    let program = postpro_motion::study(&path, &solved, kin.as_ref(), postpro_motion::Mode::G1)
        .unwrap_or_else(|e| panic!("{name}: no motion program: {e}"));
    let blocks = blocks(&program, &machine, Timing::TipFeed);
    let (started, cpu_before) = (Instant::now(), thread_cpu_time());
    let prediction = predict(&blocks, kin.as_ref(), &options());
    let (seconds, cpu) = (started.elapsed().as_secs_f64(), thread_cpu_time().zip(cpu_before).map(|(a, b)| a - b));
    let totals = prediction.totals();
    let (n, samples) = (prediction.blocks.len(), totals.samples);
    let tip_length: f64 = blocks.length.iter().sum();
    eprintln!(
        "{name}: {} on {}: {bytes} bytes of CL, {} moves, {} steps ({} inserted by linearization), {n} blocks \
         ({:.3} mm mean tip length), {samples} samples ({:.1} per block), predicted cycle time {:.1} s",
        source.name(),
        machine.name,
        path.moves().count(),
        solved.steps.len(),
        solved.inserted,
        tip_length / n.max(1) as f64,
        samples as f64 / n.max(1) as f64,
        totals.cycle_time,
    );
    // The time on the CPU does not count the time other processes took the core from this one.
    for (what, t) in [("wall", Some(seconds)), ("on-CPU", cpu)] {
        let Some(t) = t else { continue };
        eprintln!(
            "{name}: one run of predict outside criterion, {what} time: {t:.3} s, {:.0} ns per block, {:.1} ns per sample",
            t / n.max(1) as f64 * 1e9,
            t / samples.max(1) as f64 * 1e9,
        );
    }
    Workload { name, machine, kin, program, blocks }
}

/// What the benchmark predicts with: the inverse-time planner, no samples kept, the CNC's cycle.
fn options() -> Options {
    Options::default()
}

/// The time this thread has spent on a CPU (s), from Linux's `/proc/thread-self/schedstat`;
/// `None` elsewhere.
fn thread_cpu_time() -> Option<f64> {
    let text = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
    let ns: f64 = text.split_whitespace().next()?.parse().ok()?;
    Some(ns * 1e-9)
}

fn bench(c: &mut Criterion) {
    let scale: f64 = std::env::var("POSTPRO_BENCH_SCALE").ok().and_then(|v| v.parse().ok()).unwrap_or(1.0);
    let registry = Registry::builtin().expect("built-in machines");
    // Only the workloads asked for are built (reading and solving a million points takes a while).
    let only = std::env::var("POSTPRO_BENCH_WORKLOADS").unwrap_or_else(|_| "fine,coarse".into());
    let wanted = |name: &str| only.split(',').any(|w| w.trim() == name);
    let mut workloads = Vec::new();
    if wanted("fine") {
        let passes = (postpro_examples::FINE_PASSES_1M as f64 * scale).round() as usize;
        workloads.push(prepare("fine", postpro_examples::fine_finishing_file(passes), "mikron-ucp710", &registry));
    }
    if wanted("coarse") {
        let text = postpro_examples::big_goto_file((COARSE_MB * scale * 1_048_576.0).round() as usize);
        workloads.push(prepare("coarse", text, "example-head-head-nutating", &registry));
    }
    let options = options();
    let mut group = c.benchmark_group("predict");
    // A run of `predict` on a million blocks takes seconds: ten samples of the same number of
    // iterations (one each at this size), not criterion's linear ramp of 1 + 2 + … + 10.
    group
        .sample_size(10)
        .sampling_mode(SamplingMode::Flat)
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(5));
    for w in &workloads {
        group.throughput(Throughput::Elements(w.blocks.len() as u64));
        group.bench_function(format!("blocks/{}", w.name), |b| {
            b.iter_with_large_drop(|| blocks(black_box(&w.program), &w.machine, Timing::TipFeed))
        });
        group.bench_function(format!("predict/{}", w.name), |b| {
            b.iter_with_large_drop(|| predict(black_box(&w.blocks), w.kin.as_ref(), &options))
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
