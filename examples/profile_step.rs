//! Runs a short stretch of DEM steps on the peers' 3D pack, for profilers
//! (`valgrind --tool=callgrind target/release/examples/profile_step`).
#[path = "../benches/common/mod.rs"]
mod common;

fn main() {
    let steps: u64 = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(50);
    let mut w = common::settled_world::<3>(1, 20, 1);
    w.step_n(steps).unwrap();
    println!("{} particles, {} steps", w.len(), w.steps());
}
