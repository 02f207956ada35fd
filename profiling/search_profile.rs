//! Repeats the pair search, for profilers: on the peers' settled 3D pack, or with
//! `-- ratio R` on the size-ratio benchmark's pack at size ratio R (lognormal law).
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
            let w = common::settled_world::<3>(1, 20, 1);
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
    let t = std::time::Instant::now();
    let mut n = 0;
    for _ in 0..300 {
        n += _core::geometry::neighbor_pairs(&x, &reach).len();
    }
    println!(
        "{} particles, {} pairs, {:.3} ms per search",
        x.len(),
        n / 300,
        t.elapsed().as_secs_f64() * 1e3 / 300.0
    );
}
