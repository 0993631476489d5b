//! The engine's own overhead: 1000 trivial nodes as a chain and as a wide fan, computed with no
//! cache, computed while storing into a cache, and a fully cached rerun.
//!
//!     cargo bench --bench engine_overhead
//!
//! Each node is `Exposure` of a 1x1 image, so the time is the engine's: validation not
//! included (it is measured separately as `parse_validate`), keys, planning, scheduling,
//! cache reads and writes.

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion};
use hdrflow::engine::cache::CacheStore;
use hdrflow::engine::scheduler::{self, RunOptions, Silent};
use hdrflow::Pipeline;

const NODES: usize = 1000;

fn chain() -> String {
    let mut s = String::from("(nodes: {\n\"n0\": Constant(width: 1, height: 1, color: (1.0, 1.0, 1.0)),\n");
    for i in 1..NODES {
        s.push_str(&format!("\"n{i}\": Exposure(image: \"n{}\", stops: 0.001),\n", i - 1));
    }
    s.push_str("})");
    s
}

fn fan() -> String {
    let mut s = String::from("(nodes: {\n\"root\": Constant(width: 1, height: 1, color: (1.0, 1.0, 1.0)),\n");
    for i in 1..NODES {
        s.push_str(&format!("\"n{i}\": Exposure(image: \"root\", stops: {}.0),\n", i % 100));
    }
    s.push_str("})");
    s
}

fn bench(c: &mut Criterion) {
    let registry = hdrflow::builtin_registry();
    let out = tempfile::tempdir().expect("tempdir");
    for (name, text) in [("chain", chain()), ("fan", fan())] {
        let mut group = c.benchmark_group(format!("engine_{name}_{NODES}"));
        group.sample_size(20);
        group.bench_function("parse_validate", |b| {
            b.iter(|| black_box(Pipeline::parse(&text, "bench.ron", ".".as_ref(), &registry, &[]).expect("valid")))
        });
        let p = Pipeline::parse(&text, "bench.ron", ".".as_ref(), &registry, &[]).expect("valid");
        group.bench_function("run_no_cache", |b| {
            b.iter(|| {
                let o = RunOptions {
                    targets: vec![],
                    out_dir: out.path().into(),
                    cache: None,
                    jobs: None,
                    observer: &Silent,
                };
                black_box(scheduler::run(&p, &o).expect("runs"))
            })
        });
        group.bench_function("run_storing_into_empty_cache", |b| {
            b.iter_batched(
                || tempfile::tempdir().expect("tempdir"),
                |dir| {
                    let o = RunOptions {
                        targets: vec![],
                        out_dir: out.path().into(),
                        cache: Some(CacheStore::new(dir.path(), u64::MAX)),
                        jobs: None,
                        observer: &Silent,
                    };
                    black_box(scheduler::run(&p, &o).expect("runs"));
                    dir
                },
                criterion::BatchSize::PerIteration,
            )
        });
        let cache_dir = tempfile::tempdir().expect("tempdir");
        let cached = || RunOptions {
            targets: vec![],
            out_dir: out.path().into(),
            cache: Some(CacheStore::new(cache_dir.path(), u64::MAX)),
            jobs: None,
            observer: &Silent,
        };
        scheduler::run(&p, &cached()).expect("warm-up run");
        group.bench_function("rerun_fully_cached", |b| {
            b.iter(|| black_box(scheduler::run(&p, &cached()).expect("runs")))
        });
        group.finish();
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
