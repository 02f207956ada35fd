//! Runs a short stretch of DEM steps on the peers' 3D pack (or, with a second argument
//! `2d`, their 2D pack), for profilers
//! (`valgrind --tool=callgrind target/release/examples/profile_step [STEPS] [2d]`).
//!
//! Prints a checksum of the final positions, velocities and spins: a change that is
//! meant to leave the arithmetic alone (a refactor, a fused loop) must print the same.
#[path = "../benches/common/mod.rs"]
mod common;

use _core::math::{Dim, Spatial};

fn main() {
    let steps: u64 = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(50);
    if std::env::args().nth(2).as_deref() == Some("2d") {
        run::<2>(steps)
    } else {
        run::<3>(steps)
    }
}

fn run<const D: usize>(steps: u64)
where
    Dim<D>: Spatial<D>,
{
    let mut w = common::settled_world::<D>(1, 20, 1);
    w.step_n(steps).unwrap();
    let h = w.state_checksum();
    println!(
        "{} particles, {} steps, state checksum {h:016x}",
        w.len(),
        w.steps()
    );
}
