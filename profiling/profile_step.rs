//! Runs a short stretch of DEM steps on the peers' 3D pack (or, with a second argument
//! `2d`, their 2D pack), for profilers
//! (`valgrind --tool=callgrind target/release/examples/profile_step [STEPS] [2d]`).
//!
//! Prints a checksum of the final positions, velocities and spins: a change that is
//! meant to leave the arithmetic alone (a refactor, a fused loop) must print the same;
//! and, on stderr, the wall time of the STEPS steps in nanoseconds a particle-step.
//!
//! `TILES=k` steps k x k tiled copies of the 3D pack instead (`common::settled_world`:
//! 3 gives 80 568 spheres, 8 gives 572 928), settled 20 steps on one thread: the step
//! once its state no longer fits the last-level cache. `PERIODIC=1` puts the tiles in a
//! cell periodic over their horizontal extent (an even `TILES` meets its mirror images
//! across the cell's edges). The tiles are stored in one row-major order over the whole
//! pack, as the layer loop stores a large pack; `ORDER=morton` stores them in one Morton
//! order instead, `LAYERS=h` in bands of h (m), each in its own Morton order.
//! `ROLLING=mu_r` adds rolling resistance (the elastic-plastic spring-dashpot model with
//! its derived spring), `LINEAR=k_n` runs the linear law with k_n (N/m).
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
    let tiles = std::env::var("TILES")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(1);
    // LAYERS=h stores the particles as a layer-by-layer pack does: bands of h (m) from
    // the bottom up, each in its own Morton order.
    let order = std::env::var("LAYERS")
        .ok()
        .and_then(|s| s.parse().ok())
        .map_or(common::StoreOrder::RowMajor, common::StoreOrder::Layers);
    // ORDER=morton: one Morton order over the whole pack instead of the row-major one
    let order = if std::env::var("ORDER").is_ok_and(|v| v == "morton") {
        common::StoreOrder::Morton
    } else {
        order
    };
    // PERIODIC=1: the tiles in a cell periodic over their horizontal extent, no side walls
    let container = if std::env::var("PERIODIC").is_ok_and(|v| v == "1") {
        _core::scene::Container::Periodic
    } else {
        _core::scene::Container::Box
    };
    let mut w = common::settled_world_with::<D>(tiles, 20, 1, order, container);
    let start = std::time::Instant::now();
    w.step_n(steps).unwrap();
    let particle_steps = (steps * w.len() as u64).max(1) as f64;
    eprintln!(
        "{:.1} ns a particle-step",
        start.elapsed().as_secs_f64() * 1e9 / particle_steps
    );
    let h = w.state_checksum();
    println!(
        "{} particles, {} steps, state checksum {h:016x}",
        w.len(),
        w.steps()
    );
}
