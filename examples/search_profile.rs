//! Repeats the pair search on the peers' settled 3D pack, for profilers.
#[path = "../benches/common/mod.rs"]
mod common;

fn main() {
    let w = common::settled_world::<3>(1, 20, 1);
    let (x, r) = (w.positions().to_vec(), w.radii().to_vec());
    // reach: radius plus a half skin of 0.5 mm
    let reach: Vec<f64> = r.iter().map(|r| r + 0.0005).collect();
    let t = std::time::Instant::now();
    let mut n = 0;
    for _ in 0..300 {
        n += _core::geometry::neighbor_pairs(&x, &reach).len();
    }
    println!(
        "{} pairs, {:.3} ms per search",
        n / 300,
        t.elapsed().as_secs_f64() * 1e3 / 300.0
    );
}
