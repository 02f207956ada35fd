//! Cost per particle against the size ratio r_max / r_min (1, 2, 4, 8) at about the
//! same N (3D): one RSA layer, the pair search (cell grid and Verlet list with the
//! engine's skin) and one DEM step, each in ns per particle. With one cell size for
//! all particles the cost of a small particle grows with the number of small
//! neighbours in the cells sized for the largest; the target is a cost within a factor
//! of 2 of the monodisperse one at every ratio.
//!
//! `cargo bench --bench size_ratio [-- N] [gaussian]` (default N = 4000). The packs are
//! graded by the lognormal of `common::ratio_law`, whose layers are placed largest
//! first; `gaussian` takes the half-Gaussian instead, which keeps the paper's order.

mod common;

use _core::pipeline::rsa::{place_layer, LayerSpec};
use _core::pipeline::Container;
use _core::Vector;
use rand::SeedableRng;

/// CPU time of the calling thread (s): unlike wall time it does not count the time
/// the thread waited for a core, which on a shared machine is most of the noise.
fn thread_cpu() -> f64 {
    let mut t = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: clock_gettime writes the timespec it is given, which lives on the stack.
    unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut t) };
    t.tv_sec as f64 + 1e-9 * t.tv_nsec as f64
}

/// The minimum over `reps` runs of `f`, each run repeated until it has taken 50 ms of
/// CPU, in CPU seconds per call.
fn best(reps: usize, mut f: impl FnMut()) -> f64 {
    (0..reps)
        .map(|_| {
            let t = thread_cpu();
            let mut calls = 0;
            while calls == 0 || thread_cpu() - t < 0.05 {
                f();
                calls += 1;
            }
            (thread_cpu() - t) / calls as f64
        })
        .fold(f64::INFINITY, f64::min)
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let n: usize = args.iter().find_map(|a| a.parse().ok()).unwrap_or(4000);
    let law = if args.iter().any(|a| a == "gaussian") {
        common::RatioLaw::HalfGaussian
    } else {
        common::RatioLaw::Lognormal
    };
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    println!("{law:?} law; one thread; CPU ns per particle (minimum of repeated runs)");
    println!("ratio      N   rsa_layer   pair_search   step   pairs/particle");
    for ratio in [1.0, 2.0, 4.0, 8.0] {
        pool.install(|| {
            let mut p = common::ratio_packer(ratio, n, law);
            if let Err(e) = p.run(|_| {}) {
                // the paper's order at a wide ratio: a large sphere drawn late in a
                // layer may find no hole
                println!("{ratio:5}  the pack did not complete: {e}");
                return;
            }
            let cfg = p.config().clone();
            let w = p.world();
            let (x, r) = (w.positions().to_vec(), w.radii().to_vec());
            let n = x.len();
            // the engine's widest half skin: skin_ratio r_min / 2
            let reach: Vec<f64> = r.iter().map(|r| r + 0.1 * 0.01).collect();
            let mut pairs = 0;
            let t_search = best(5, || {
                pairs = _core::geometry::neighbor_pairs(&x, &reach).len()
            });
            let height = x.iter().zip(&r).map(|(q, r)| q[2] + r).fold(0.0, f64::max);
            let mut added = 0;
            let t_rsa = best(5, || {
                let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
                let spec = LayerSpec::<3> {
                    container: Container::Box,
                    lo: Vector::<3>::zeros(),
                    hi: Vector::<3>::new(cfg.base[0], cfg.base[1], f64::INFINITY),
                    vertical: 2,
                    height,
                    h_layer: cfg.h_layer,
                    phi_layer: cfg.phi_layer,
                    radii: cfg.radii.clone(),
                    max_attempts: 1_000_000,
                    existing: (&x, &r),
                    layer: 0,
                };
                added = place_layer(&spec, &mut rng).unwrap().0.len();
            });
            let mut w = p.world().clone();
            let t_step = best(5, || w.step_n(10).unwrap()) / 10.0;
            println!(
                "{ratio:5}  {n:6}  {:9.0}  {:12.0}  {:6.1}   {:.1}",
                1e9 * t_rsa / added as f64,
                1e9 * t_search / n as f64,
                1e9 * t_step / n as f64,
                pairs as f64 / n as f64
            );
        });
    }
}
