//! One pack of the paper's example 4.3 (or 4.1 with `2d`), layer by layer, with the
//! time spent in pair-list rebuilds: where a pack's wall time goes. The last line's
//! state checksum is the pack's: a change meant to leave the arithmetic alone must
//! print the same.
//! `cargo run --release --example pack_profile -- [2d] [fast] [layers]`.
use _core::pipeline::pack::{PackConfig, Packer, RadiusLaw};
use _core::{Dim, SimConfig, Spatial, Vector};
use std::time::Instant;

fn run<const D: usize>(fast: bool, layers: usize, r: f64, phi_layer: f64)
where
    Dim<D>: Spatial<D>,
{
    // fast settings from the environment, for trying values: DEPTH=0.1 (m), SPEED=1e-3
    // (m/s), FORCE=0.1 (of the weight), TOL=1e-2 (0: the fixed settle time, with
    // freezing), FAST_DT=0.55 and SETTLE_DT=0.75 (of the Rayleigh estimate: the dt of
    // the landing and of the rest of each layer); engine settings: DT (s, overrides
    // FAST_DT), SKIN=0.2 (largest skin over r_min);
    // SETTLE=1.0 (s per layer; short ones profile the falling phase, e.g. under
    // callgrind); HEIGHT=0.5 (m, the desired pack height); SEED=1; BASE=1.0 (m, the
    // side of the square base); PERIODIC=0 (1: a periodic cell instead of the box)
    let env = |k: &str, d: f64| {
        std::env::var(k)
            .ok()
            .and_then(|s| s.parse().ok())
            .unwrap_or(d)
    };
    let depth = env("DEPTH", 0.1);
    let tol = env("TOL", 1e-2);
    let mut sim = SimConfig::<D>::paper();
    sim.drag = 0.005;
    // `fast` takes FAST_DT of the Rayleigh estimate (as `PackScene.fast()`), or the
    // paper's dt where that is larger
    let fast_dt = (env("FAST_DT", 0.55) * sim.material.rayleigh_time_step(r)).max(sim.dt);
    sim.dt = env("DT", if fast { fast_dt } else { sim.dt });
    // and, once each layer has fallen, SETTLE_DT of the estimate (as `fast()`; 0: keep dt)
    let settle_frac = env("SETTLE_DT", 0.75);
    let settle_dt = (settle_frac > 0.0)
        .then(|| settle_frac * sim.material.rayleigh_time_step(r))
        .filter(|&d| d > sim.dt);
    sim.skin_ratio = env("SKIN", sim.skin_ratio);
    if env("PERIODIC", 0.0) != 0.0 {
        sim.container = _core::scene::Container::Periodic;
    }
    let cfg = PackConfig::<D> {
        sim,
        base: Vector::<D>::from_element(env("BASE", 1.0)),
        height: env("HEIGHT", 0.5),
        radii: RadiusLaw::Constant(r),
        h_layer: 0.1,
        phi_layer,
        settle_time: env("SETTLE", 1.0),
        seed: env("SEED", 1.0) as u64,
        stream: 0,
        max_attempts: 100_000,
        max_layers: layers,
        settle_tol: (fast && tol > 0.0).then_some(tol),
        freeze_depth: fast.then_some(depth),
        freeze_speed: env("SPEED", 1e-3),
        freeze_force: env("FORCE", 0.1),
        settle_dt: settle_dt.filter(|_| fast),
    };
    let mut p = Packer::new(cfg).unwrap();
    let t0 = Instant::now();
    let mut steps = 0;
    let mut psteps = 0.0;
    while !p.done() && p.reports().len() < layers {
        let rep = p.next_layer().unwrap();
        steps += rep.steps;
        psteps += rep.steps as f64 * rep.total as f64;
        println!(
            "layer {:2}: N {:5} steps {:6} frozen {:5} {:6.2} s  rebuilds {:6} ({:.2} s)  pairs {:?}",
            rep.layer,
            rep.total,
            rep.steps,
            rep.frozen,
            rep.wall_seconds,
            p.world().rebuilds(),
            p.world().rebuild_seconds(),
            p.world().pair_counts()
        );
    }
    let t = t0.elapsed().as_secs_f64();
    println!(
        "total {t:.2} s, {steps} steps, {:.0} ns per particle-step (all particles), rebuilds {:.2} s, state checksum {:016x}",
        t * 1e9 / psteps,
        p.world().rebuild_seconds(),
        p.world().state_checksum()
    );
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let fast = args.iter().any(|a| a == "fast");
    let layers = args.iter().find_map(|a| a.parse().ok()).unwrap_or(100usize);
    if args.iter().any(|a| a == "2d") {
        run::<2>(fast, layers, 0.01, 0.4);
    } else {
        run::<3>(fast, layers, 0.02, 0.25);
    }
}
