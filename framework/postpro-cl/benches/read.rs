//! Reading throughput on a generated GOTO-dominated 5-axis file (`postpro-examples`), into the
//! whole tool path and through the `check` summary: of the text in memory, and of the file on
//! disk read in windows from opening it (what `postpro check` does). Criterion prints MiB/s.
//!
//! `cargo bench -p postpro-cl --bench read` (size: `POSTPRO_BENCH_MB`, default 32).

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use postpro_cl::{ClFile, ReadOptions, Source, read, summarize, summarize_file};

fn bench(c: &mut Criterion) {
    let mb: f64 = std::env::var("POSTPRO_BENCH_MB").ok().and_then(|v| v.parse().ok()).unwrap_or(32.0);
    let text = postpro_examples::big_goto_file((mb * 1_048_576.0) as usize);
    let source = Source::new("big.cl", text);
    let mut group = c.benchmark_group("read");
    group.throughput(Throughput::Bytes(source.text().len() as u64));
    group.sample_size(10);
    group.bench_function("tool_path", |b| b.iter(|| read(&source).items.len()));
    group.bench_function("check_summary", |b| b.iter(|| summarize(&source).0.moves.total));
    let path = std::env::temp_dir().join(format!("postpro-bench-read-{}.cl", std::process::id()));
    std::fs::write(&path, source.text()).expect("a scratch file");
    let options = ReadOptions::default();
    group.bench_function("check_file", |b| {
        b.iter(|| {
            let file = ClFile::open(&path).expect("the scratch file opens");
            summarize_file(&file, &options).expect("the scratch file reads").0.moves.total
        })
    });
    group.finish();
    let _ = std::fs::remove_file(&path);
}

criterion_group!(benches, bench);
criterion_main!(benches);
