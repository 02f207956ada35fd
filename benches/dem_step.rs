//! One DEM step on settled packs, in ns per particle-step (criterion reports
//! elements/s; ns per particle-step = 1e9 / that).
//!
//! Scenes: the final packs of LIGGGHTS (example 4.3, 8952 spheres) and LAMMPS
//! (example 4.1, 1397 discs) from ../shared/peers, settled under granpack's law first.

mod common;

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use std::time::Duration;

const STEPS: u64 = 20;

fn bench_step(c: &mut Criterion) {
    let max_threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    let mut threads = vec![1];
    if max_threads > 1 {
        threads.push(max_threads);
    }
    let mut g = c.benchmark_group("dem_step");
    g.sample_size(20).measurement_time(Duration::from_secs(4));
    for &t in &threads {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(t)
            .build()
            .unwrap();
        let mut w3 = common::settled_world::<3>(1, 2000, t);
        g.throughput(Throughput::Elements(w3.len() as u64 * STEPS));
        g.bench_with_input(
            BenchmarkId::new(format!("3d_{}_spheres", w3.len()), format!("{t}threads")),
            &t,
            |b, _| b.iter(|| pool.install(|| w3.step_n(STEPS).unwrap())),
        );
        let mut w2 = common::settled_world::<2>(1, 2000, t);
        g.throughput(Throughput::Elements(w2.len() as u64 * STEPS));
        g.bench_with_input(
            BenchmarkId::new(format!("2d_{}_discs", w2.len()), format!("{t}threads")),
            &t,
            |b, _| b.iter(|| pool.install(|| w2.step_n(STEPS).unwrap())),
        );
    }
    g.finish();
}

criterion_group!(benches, bench_step);
criterion_main!(benches);
