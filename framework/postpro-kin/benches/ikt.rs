//! IKT plus policy throughput (CL poses per second) on a generated 5-axis path (repeated passes
//! over the Manta surface of paper 004, every point with its own tool axis), for the closed
//! forms and the generic chains. `cargo bench -p postpro-kin --bench ikt` prints Melem/s.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use postpro_cl::{Source, read};
use postpro_kin::{Chain, Policy, Target, choose, solver_for, targets};
use postpro_machine::Registry;
use postpro_machine::model::{Machine, OnDiscontinuity, SolverKind};

fn bench(c: &mut Criterion) {
    let source = Source::new("bench.cl", postpro_examples::big_goto_file(8 << 20));
    let path = read(&source);
    // The Manta is 600 mm wide: centre it on the table and halve it so it stays inside the
    // travels of every machine (the tool axes are the Manta's).
    let mut poses: Vec<Target> = targets(&path, 0.01);
    for t in &mut poses {
        t.pose.tip.x = (t.pose.tip.x - 300.0) * 0.5;
        t.pose.tip.y = (t.pose.tip.y - 300.0) * 0.5;
        t.pose.tip.z *= 0.5;
    }
    let registry = Registry::builtin().expect("built-in machines");
    let mut group = c.benchmark_group("ikt_policy");
    group.throughput(Throughput::Elements(poses.len() as u64));
    group.sample_size(10);
    for name in ["mikron-ucp710", "maho600e", "nutating-head"] {
        let Ok(entry) = registry.find(name) else { continue };
        let machine: &Machine = &entry.machine;
        let closed = solver_for(machine);
        // A retract wherever a discontinuity remains, so that the whole path solves on every machine.
        let policy =
            Policy { on_discontinuity: OnDiscontinuity::Retract { clearance: 20.0 }, ..machine.policy.clone() };
        // Measure the path solved, not an early error.
        match choose(closed.as_ref(), &poses, &policy, None) {
            Ok(solved) => eprintln!(
                "{name}: {} poses, {} steps, {} decisions",
                poses.len(),
                solved.steps.len(),
                solved.decisions.len()
            ),
            Err(e) => panic!("{name}: the benchmark path does not solve: {e}"),
        }
        if matches!(machine.solver, SolverKind::ClosedForm(_)) {
            group.bench_function(format!("{name}/closed_form"), |b| {
                b.iter(|| choose(closed.as_ref(), &poses, &policy, None).map(|s| s.steps.len()))
            });
        }
        let generic = Chain::new(Machine { solver: SolverKind::Generic, ..machine.clone() });
        group.bench_function(format!("{name}/generic"), |b| {
            b.iter(|| choose(&generic, &poses, &policy, None).map(|s| s.steps.len()))
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
