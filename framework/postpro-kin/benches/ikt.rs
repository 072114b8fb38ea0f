//! IKT plus policy throughput (CL poses per second) on a generated 5-axis path (repeated passes
//! over the Manta surface of paper 004, every point with its own tool axis), for the closed
//! forms and the generic chains. `cargo bench -p postpro-kin --bench ikt` prints Melem/s.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use postpro_cl::{Source, read};
use postpro_kin::{Chain, Target, choose, solver_for, targets};
use postpro_machine::Registry;
use postpro_machine::model::{Machine, SolverKind};

fn bench(c: &mut Criterion) {
    let source = Source::new("bench.cl", postpro_examples::big_goto_file(8 << 20));
    let path = read(&source);
    // The Manta is 600 mm wide: centre it on the table so it stays inside the travels.
    let mut poses: Vec<Target> = targets(&path, 0.01);
    for t in &mut poses {
        t.pose.tip.x -= 300.0;
        t.pose.tip.y -= 300.0;
    }
    let registry = Registry::builtin().expect("built-in machines");
    let mut group = c.benchmark_group("ikt_policy");
    group.throughput(Throughput::Elements(poses.len() as u64));
    group.sample_size(10);
    for name in ["mikron-ucp710", "maho600e", "nutating-head"] {
        let Ok(entry) = registry.find(name) else { continue };
        let machine: &Machine = &entry.machine;
        let closed = solver_for(machine);
        let policy = machine.policy.clone();
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
