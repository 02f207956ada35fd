//! The pair search of two versions of src/geometry/grid.rs in one binary, called
//! alternately on the size-ratio benchmark's packs, so that the machine's drift hits
//! both alike. To run it: copy this file to examples/, the two grid.rs versions to
//! /tmp/ab/old.rs and /tmp/ab/new.rs, then
//! `cargo run --release --example search_ab -- CALLS` (default 300 calls of each
//! version per ratio). The packs are made once by the benchmark's packer and cached in
//! /tmp/ratio_pack_RATIO.txt. It asserts that both versions give the same pairs, and
//! prints per ratio the minimum, 10th percentile and median time of each, in CPU ns
//! per particle, their 10th percentiles over ratio 1, and new over old.
#[path = "../benches/common/mod.rs"]
mod common;
mod math {
    pub use _core::math::*;
}
mod geometry {
    pub use _core::geometry::Period;
    #[path = "/tmp/ab/old.rs"]
    pub mod old;
    #[path = "/tmp/ab/new.rs"]
    pub mod new;
}
use _core::Vector;

fn now() -> f64 {
    let mut t = libc::timespec { tv_sec: 0, tv_nsec: 0 };
    unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut t) };
    t.tv_sec as f64 + 1e-9 * t.tv_nsec as f64
}

/// The benchmark's pack at `ratio`: positions and reaches (radius + the engine's
/// widest half skin, 0.001 m).
fn load(ratio: f64) -> (Vec<Vector<3>>, Vec<f64>) {
    use std::io::Write;
    let path = format!("/tmp/ratio_pack_{ratio}.txt");
    if std::fs::metadata(&path).is_err() {
        let mut p = common::ratio_packer(ratio, 4000, common::RatioLaw::Lognormal);
        p.run(|_| {}).unwrap();
        let w = p.world();
        let mut f = std::fs::File::create(&path).unwrap();
        for (q, r) in w.positions().iter().zip(w.radii()) {
            writeln!(f, "{:e} {:e} {:e} {:e}", q[0], q[1], q[2], r).unwrap();
        }
    }
    let t = std::fs::read_to_string(&path).unwrap();
    let mut x = Vec::new();
    let mut r = Vec::new();
    for l in t.lines() {
        let v: Vec<f64> = l.split_whitespace().map(|s| s.parse().unwrap()).collect();
        x.push(Vector::<3>::new(v[0], v[1], v[2]));
        r.push(v[3] + 0.001);
    }
    (x, r)
}

fn main() {
    let calls: usize = std::env::args().nth(1).and_then(|a| a.parse().ok()).unwrap_or(300);
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
    pool.install(|| {
        let data: Vec<_> = [1.0, 2.0, 4.0, 8.0].iter().map(|&r| load(r)).collect();
        // per ratio, per version: every call's time (ns per particle)
        let mut t = vec![[Vec::new(), Vec::new()]; 4];
        for (x, reach) in &data {
            assert_eq!(geometry::old::neighbor_pairs(x, reach), geometry::new::neighbor_pairs(x, reach));
        }
        for c in 0..calls {
            for (k, (x, reach)) in data.iter().enumerate() {
                for v in [c % 2, 1 - c % 2] {
                    let s = now();
                    let p = if v == 0 { geometry::old::neighbor_pairs(x, reach) } else { geometry::new::neighbor_pairs(x, reach) };
                    std::hint::black_box(p);
                    t[k][v].push((now() - s) * 1e9 / x.len() as f64);
                }
            }
        }
        let q = |v: &Vec<f64>, f: f64| { let mut v = v.clone(); v.sort_by(|a, b| a.partial_cmp(b).unwrap()); v[((v.len() - 1) as f64 * f) as usize] };
        println!("ratio  old: min p10 median (ns)  new: min p10 median   old/r1(p10) new/r1(p10)  new/old(p10)");
        for k in 0..4 {
            let (o, n) = (&t[k][0], &t[k][1]);
            println!("{}  {:.0} {:.0} {:.0}   {:.0} {:.0} {:.0}   {:.2} {:.2}   {:.3}", [1, 2, 4, 8][k],
                q(o, 0.0), q(o, 0.1), q(o, 0.5), q(n, 0.0), q(n, 0.1), q(n, 0.5),
                q(o, 0.1) / q(&t[0][0], 0.1), q(n, 0.1) / q(&t[0][1], 0.1), q(n, 0.1) / q(o, 0.1));
        }
    });
}
