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

/// The pair search (cell grid + Verlet list with the engine's skin) on the settled 3D
/// pack, and one RSA layer of example 4.3 (746 spheres) on top of it.
fn bench_grid_and_rsa(c: &mut Criterion) {
    use _core::pipeline::rsa::{place_layer, LayerSpec};
    use _core::{RadiusLaw, Vector};
    use rand::SeedableRng;
    let w = common::settled_world::<3>(1, 200, 1);
    let (x, r) = (w.positions().to_vec(), w.radii().to_vec());
    // reach: radius plus a half skin of 2 mm
    let reach: Vec<f64> = r.iter().map(|r| r + 0.002).collect();
    let mut g = c.benchmark_group("search");
    g.sample_size(20);
    g.throughput(Throughput::Elements(x.len() as u64));
    g.bench_function(BenchmarkId::new("grid_rebuild", x.len()), |b| {
        b.iter(|| _core::geometry::neighbor_pairs(&x, &reach))
    });
    let height = x.iter().zip(&r).map(|(p, r)| p[2] + r).fold(0.0, f64::max);
    g.throughput(Throughput::Elements(746));
    g.bench_function("rsa_layer_4.3", |b| {
        b.iter(|| {
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
            let spec = LayerSpec::<3> {
                container: _core::scene::Container::Box,
                lo: Vector::<3>::zeros(),
                hi: Vector::<3>::new(1.0, 1.0, f64::INFINITY),
                vertical: 2,
                height,
                h_layer: 0.1,
                phi_layer: 0.25,
                radii: RadiusLaw::Constant(0.02),
                max_attempts: 1_000_000,
                existing: (&x, &r),
                layer: 0,
            };
            place_layer(&spec, &mut rng).unwrap()
        })
    });
    g.finish();
}

/// The step on the peers' 3D pack and tiled copies of it: 8 952 (about 1e4), x 9 =
/// 80 568 (about 1e5) and x 64 = 572 928 spheres, and x 121 = 1 083 192 (about 1e6) with
/// `GRANPACK_BENCH_1E6=1`; the 2D pack x 72 = 100 584 discs; on 1 and all threads. The
/// cost per particle-step should stay flat with size.
fn bench_sizes(c: &mut Criterion) {
    let max_threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    let mut g = c.benchmark_group("dem_step_sizes");
    g.sample_size(10).measurement_time(Duration::from_secs(8));
    for t in [1, max_threads] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(t)
            .build()
            .unwrap();
        // about 1e4, 1e5 and 5.7e5 spheres; GRANPACK_BENCH_1E6=1 adds 1.08e6 (about 2 GB)
        let mut sizes = vec![1, 3, 8];
        if std::env::var_os("GRANPACK_BENCH_1E6").is_some() {
            sizes.push(11);
        }
        for &tiles in &sizes {
            let mut w = common::settled_world::<3>(tiles, 20, t);
            g.throughput(Throughput::Elements(w.len() as u64 * 2));
            g.bench_with_input(
                BenchmarkId::new(format!("3d_{}_spheres", w.len()), format!("{t}threads")),
                &t,
                |b, _| b.iter(|| pool.install(|| w.step_n(2).unwrap())),
            );
        }
        let mut w = common::settled_world::<2>(72, 20, t);
        g.throughput(Throughput::Elements(w.len() as u64 * 2));
        g.bench_with_input(
            BenchmarkId::new(format!("2d_{}_discs", w.len()), format!("{t}threads")),
            &t,
            |b, _| b.iter(|| pool.install(|| w.step_n(2).unwrap())),
        );
        if max_threads == 1 {
            break;
        }
    }
    g.finish();
}

/// The step in the three containers, on packs of about 4 000 spheres made by granpack
/// over the same cross-section (`common::container_world`), on one thread: the
/// periodic cell's minimum image and the cylinder's curved wall should cost little.
fn bench_containers(c: &mut Criterion) {
    use _core::scene::Container;
    let mut g = c.benchmark_group("container_step");
    g.sample_size(20).measurement_time(Duration::from_secs(4));
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    for (name, container) in [
        ("box", Container::Box),
        ("periodic", Container::Periodic),
        ("cylinder", Container::Cylinder(0.0)),
    ] {
        let mut w = common::container_world(container);
        g.throughput(Throughput::Elements(w.len() as u64 * STEPS));
        g.bench_function(BenchmarkId::new(name, w.len()), |b| {
            b.iter(|| pool.install(|| w.step_n(STEPS).unwrap()))
        });
    }
    g.finish();
}

criterion_group!(
    benches,
    bench_step,
    bench_grid_and_rsa,
    bench_sizes,
    bench_containers
);
criterion_main!(benches);
