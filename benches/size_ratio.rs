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
//! The four packs are made first; then each kernel is called in turn on every ratio,
//! for about 4 s of CPU per kernel, each call timed on its own (thread CPU time), and
//! the 10th percentile of a ratio's calls kept: drift and bursts of other load on a
//! shared machine hit all four ratios alike.

mod common;

use _core::pipeline::rsa::{place_layer, LayerSpec};
use _core::scene::Container;
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

/// The `q` quantile of `v` (nearest rank, 0 <= q <= 1).
fn quantile(mut v: Vec<f64>, q: f64) -> f64 {
    v.sort_by(f64::total_cmp);
    v[((v.len() - 1) as f64 * q).round() as usize]
}

/// One ratio's pack and what its kernels need.
struct Case {
    ratio: f64,
    x: Vec<Vector<3>>,
    r: Vec<f64>,
    reach: Vec<f64>,
    /// top of the pack (m): the RSA layer goes above it
    height: f64,
    cfg: _core::PackConfig<3>,
    world: _core::World<3>,
    pairs: usize,
    added: usize,
}

impl Case {
    /// Runs kernel `k` (0 RSA of one layer, 1 the pair search, 2 ten steps) once.
    fn run(&mut self, k: usize) {
        match k {
            0 => {
                let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
                let spec = LayerSpec::<3> {
                    container: Container::Box,
                    lo: Vector::<3>::zeros(),
                    hi: Vector::<3>::new(self.cfg.base[0], self.cfg.base[1], f64::INFINITY),
                    vertical: 2,
                    height: self.height,
                    h_layer: self.cfg.h_layer,
                    phi_layer: self.cfg.phi_layer,
                    radii: self.cfg.radii.clone(),
                    max_attempts: 1_000_000,
                    existing: (&self.x, &self.r),
                    layer: 0,
                };
                self.added = place_layer(&spec, &mut rng).unwrap().0.len();
            }
            1 => self.pairs = _core::geometry::neighbor_pairs(&self.x, &self.reach).len(),
            _ => self.world.step_n(10).unwrap(),
        }
    }
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
    // CPU seconds per kernel, over all ratios
    const BUDGET: f64 = 4.0;
    pool.install(|| {
        // the packs first
        let mut cases: Vec<Case> = Vec::new();
        for ratio in [1.0, 2.0, 4.0, 8.0] {
            let mut p = common::ratio_packer(ratio, n, law);
            if let Err(e) = p.run(|_| {}) {
                // the paper's order at a wide ratio: a large sphere drawn late in a
                // layer may find no hole
                println!("{ratio:5}  the pack did not complete: {e}");
                continue;
            }
            let w = p.world();
            let (x, r) = (w.positions().to_vec(), w.radii().to_vec());
            cases.push(Case {
                ratio,
                // the engine's widest half skin: skin_ratio r_min / 2
                reach: r.iter().map(|r| r + 0.1 * 0.01).collect(),
                height: x.iter().zip(&r).map(|(q, r)| q[2] + r).fold(0.0, f64::max),
                x,
                r,
                cfg: p.config().clone(),
                world: w.clone(),
                pairs: 0,
                added: 0,
            });
        }
        // Per kernel, the ratios in turn, call by call, each call timed on its own:
        // the machine's drift and bursts of other load then hit every ratio alike.
        // The 10th percentile of a ratio's calls stands for its cost.
        let mut t: [Vec<f64>; 3] = Default::default();
        for (k, tk) in t.iter_mut().enumerate() {
            let mut samples = vec![Vec::new(); cases.len()];
            let start = thread_cpu();
            while samples[0].len() < 5 || thread_cpu() - start < BUDGET {
                for (c, s) in cases.iter_mut().zip(&mut samples) {
                    let t0 = thread_cpu();
                    c.run(k);
                    s.push(thread_cpu() - t0);
                }
            }
            for (c, s) in samples.into_iter().enumerate() {
                let per = match k {
                    0 => cases[c].added as f64,
                    1 => cases[c].x.len() as f64,
                    _ => 10.0 * cases[c].x.len() as f64,
                };
                tk.push(1e9 * quantile(s, 0.1) / per);
            }
        }
        println!(
            "{law:?} law; one thread; CPU ns per particle, 10th percentile of single calls \
             made in turn over the ratios; in brackets the cost over ratio 1"
        );
        println!("ratio      N   rsa_layer       pair_search     step           pairs/particle");
        for (c, case) in cases.iter().enumerate() {
            let cols: Vec<String> = (0..3)
                .map(|k| format!("{:7.1} ({:.2})", t[k][c], t[k][c] / t[k][0]))
                .collect();
            println!(
                "{:5}  {:6}  {}   {:.1}",
                case.ratio,
                case.x.len(),
                cols.join("  "),
                case.pairs as f64 / case.x.len() as f64
            );
        }
    });
}
