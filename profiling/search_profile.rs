//! Repeats the pair search, for profilers: on the peers' settled 3D pack (`TILES=k`:
//! tiled k x k, as `profile_step`'s; `PERIODIC=1`: searched as a periodic cell over its
//! horizontal extent, as a periodic pack's pair list is), or with `-- ratio R` on the size-ratio
//! benchmark's pack at size ratio R (lognormal law).
#[path = "../benches/common/mod.rs"]
mod common;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let ratio: Option<f64> = match args.as_slice() {
        [flag, r] if flag == "ratio" => Some(r.parse().expect("ratio R: a number >= 1")),
        _ => None,
    };
    let (x, reach) = match ratio {
        None => {
            let tiles = std::env::var("TILES")
                .ok()
                .and_then(|s| s.parse().ok())
                .unwrap_or(1);
            let w = common::settled_world::<3>(tiles, 20, 1);
            // reach: radius plus a half skin of 0.5 mm
            let reach: Vec<f64> = w.radii().iter().map(|r| r + 0.0005).collect();
            (w.positions().to_vec(), reach)
        }
        Some(ratio) => {
            let mut p = common::ratio_packer(ratio, 4000, common::RatioLaw::Lognormal);
            p.run(|_| {}).unwrap();
            let w = p.world();
            // the engine's widest half skin: skin_ratio r_min / 2
            let reach: Vec<f64> = w.radii().iter().map(|r| r + 0.001).collect();
            (w.positions().to_vec(), reach)
        }
    };
    let periodic = std::env::var("PERIODIC").is_ok_and(|v| v == "1");
    let period = periodic.then(|| {
        let mut lo = x[0];
        let mut hi = x[0];
        for p in &x {
            lo = lo.inf(p);
            hi = hi.sup(p);
        }
        // a period a little wider than the extent, so that every centre lies inside
        _core::geometry::Period::lateral(&lo, &hi.add_scalar(1e-3))
    });
    // about 3e6 particle-searches, at least 3
    let reps = (3_000_000 / x.len()).max(3);
    let t = std::time::Instant::now();
    let mut n = 0;
    for _ in 0..reps {
        n += _core::geometry::neighbor_pairs_periodic(&x, &reach, period.as_ref()).len();
    }
    println!(
        "{} particles, {} pairs, {:.3} ms per search, {:.1} ns a particle",
        x.len(),
        n / reps,
        t.elapsed().as_secs_f64() * 1e3 / reps as f64,
        t.elapsed().as_secs_f64() * 1e9 / (reps * x.len()) as f64
    );
}
