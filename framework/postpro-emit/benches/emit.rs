//! End-to-end throughput (CL points per second): read a generated 5-axis CL file, solve it on a
//! machine, build its motion program, write the NC program (to a sink), in G1, in inverse time and as BSPLINE.
//! `cargo bench -p postpro-emit --bench emit` (size: `POSTPRO_BENCH_MB`, default 16).

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use postpro_cl::{Source, read};
use postpro_emit::{Mode, Options, builtin_template, dialect, motion_options, write_program};
use postpro_kin::{solve, solver_for};
use postpro_machine::Registry;

fn bench(c: &mut Criterion) {
    let mb: f64 = std::env::var("POSTPRO_BENCH_MB").ok().and_then(|v| v.parse().ok()).unwrap_or(16.0);
    let source = Source::new("big.cl", postpro_examples::big_goto_file((mb * 1_048_576.0) as usize));
    let points = read(&source).moves().count();
    // The generated path is the 600 mm Manta: the nutating head-head example's travels hold it.
    let registry = Registry::builtin().expect("built-in machines");
    let machine = registry.find("example-head-head-nutating").expect("example machine").machine.clone();
    let d = dialect("siemens-840d").expect("dialect");
    let template = builtin_template(d.name).expect("template");
    let mut group = c.benchmark_group("end_to_end");
    group.throughput(Throughput::Elements(points as u64));
    group.sample_size(10);
    for (mode, label) in [(Mode::G1, "g1"), (Mode::InverseTime, "inverse_time"), (Mode::Bspline, "bspline")] {
        let options = Options {
            units: postpro_machine::model::ProgramUnits::Mm,
            program_name: "BENCH".into(),
            source_name: "big.cl".into(),
            block_numbers: false,
            tcp_orientation: Default::default(),
            insert_verbatim: false,
            prediction: None,
            annotations: Vec::new(),
        };
        group.bench_function(label, |b| {
            b.iter(|| {
                let path = read(&source);
                let kin = solver_for(&machine);
                let solved = solve(kin.as_ref(), &path, &machine.policy).expect("solves");
                let (job, _) = postpro_motion::Job::new(kin.as_ref(), &path, mode, None, d.default_work_offset())
                    .expect("the tools");
                let motion =
                    postpro_motion::collect(&path, &solved, kin.as_ref(), &motion_options(d, mode, true), &job)
                        .expect("the motion program builds");
                let mut out = std::io::BufWriter::new(std::io::sink());
                write_program(&motion, &machine, d, &options, d.name, template, &mut out).expect("writes");
                solved.steps.len()
            })
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
