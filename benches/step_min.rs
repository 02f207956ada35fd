//! Quick, interference-robust timing of one DEM step: the minimum (and median) over
//! repeated batches of steps, in ns per particle-step. Used for before/after
//! comparisons on a shared machine, where criterion's means drift with background load.
//! `cargo bench --bench step_min [-- THREADS] [sizes | tiles3]`: `sizes` adds the tiled
//! packs (3D: 8 952, 80 568 and 572 928 spheres; 2D: 1 397 and 100 584 discs), to check
//! that the cost per particle-step stays flat with size; `tiles3` runs the 80 568-sphere
//! pack alone; `containers` compares packs made in the box, the periodic cell and the
//! cylinder at the same N.

mod common;

use std::time::Instant;

/// CPU seconds used by this process so far (user + system, from /proc; 10 ms ticks).
/// On a shared machine CPU time is far steadier than wall time.
fn cpu_seconds() -> f64 {
    let stat = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    let after = stat.rsplit(')').next().unwrap_or("");
    let f: Vec<&str> = after.split_whitespace().collect();
    let ticks: f64 = f.get(11).and_then(|u| u.parse().ok()).unwrap_or(0.0)
        + f.get(12).and_then(|s| s.parse().ok()).unwrap_or(0.0);
    ticks / 100.0
}

fn measure<const D: usize>(label: &str, tiles: usize, threads: usize)
where
    _core::Dim<D>: _core::Spatial<D>,
{
    // The peers' packs are already settled; the tiled copies get a short settle only
    // (2000 steps of half a million spheres would take minutes).
    let settle = if tiles == 1 { 2000 } else { 50 };
    let w = common::settled_world::<D>(tiles, settle, threads);
    time_steps(label, w, threads);
}

/// Steps `w` in 7 batches and prints the minimum and median cost per particle-step.
fn time_steps<const D: usize>(label: &str, mut w: _core::World<D>, threads: usize)
where
    _core::Dim<D>: _core::Spatial<D>,
{
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    let n = w.len();
    // batches of about 4e6 particle-steps (~1 s), so 10 ms CPU ticks resolve 1 %
    let steps = (4_000_000 / n).max(5) as u64;
    let per = 1e9 / (steps as f64 * n as f64);
    let mut wall = Vec::new();
    let mut cpu = Vec::new();
    let rebuilds0 = w.rebuilds();
    for _ in 0..7 {
        let (t0, c0) = (Instant::now(), cpu_seconds());
        pool.install(|| w.step_n(steps).unwrap());
        wall.push(t0.elapsed().as_secs_f64() * per);
        cpu.push((cpu_seconds() - c0) * per / threads as f64);
    }
    wall.sort_by(|a, b| a.partial_cmp(b).unwrap());
    cpu.sort_by(|a, b| a.partial_cmp(b).unwrap());
    println!(
        "{label:<22} N = {n:>7}  threads = {threads}  ns/particle-step: wall min {:6.1} median {:6.1} | cpu/thread min {:6.1} median {:6.1} | {} rebuilds in {} steps",
        wall[0], wall[wall.len() / 2], cpu[0], cpu[cpu.len() / 2], w.rebuilds() - rebuilds0, 7 * steps
    );
}

fn main() {
    let threads: usize = std::env::args()
        .skip(1)
        .find_map(|a| a.parse().ok())
        .unwrap_or(1);
    // `containers`: packs of about 4 000 spheres made in the box, the periodic cell and
    // the cylinder, over the same cross-section
    if std::env::args().any(|a| a == "containers") {
        use _core::scene::Container;
        for (label, c) in [
            ("3d box", Container::Box),
            ("3d periodic", Container::Periodic),
            ("3d cylinder", Container::Cylinder(0.0)),
        ] {
            time_steps::<3>(label, common::container_world(c), threads);
        }
        return;
    }
    // `tiles3` measures the 80 568-sphere pack alone (a memory-bound case, quickly)
    if std::env::args().any(|a| a == "tiles3") {
        measure::<3>("3d 3x3 tiles", 3, threads);
        return;
    }
    measure::<3>("3d peer pack (4.3)", 1, threads);
    measure::<2>("2d peer pack (4.1)", 1, threads);
    if std::env::args().any(|a| a == "sizes") {
        measure::<3>("3d 3x3 tiles", 3, threads);
        measure::<3>("3d 8x8 tiles", 8, threads);
        measure::<2>("2d 72 tiles", 72, threads);
    }
}
