//! Convergence order of the integrator, measured on a Hertz impact (sphere on the
//! floor): the state at a fixed time after the impact, against a run at dt / 64.
//! Prints error and observed order for each dt; not a timing benchmark.

use _core::{SimConfig, Vector, World};

fn final_state(dt: f64, damping: f64, friction: f64) -> (f64, f64) {
    let mut cfg = SimConfig::<3>::paper();
    cfg.gravity = Vector::<3>::zeros();
    cfg.material.damping = damping;
    cfg.material.friction = friction;
    cfg.dt = dt;
    cfg.walls = Some((
        Vector::<3>::zeros(),
        Vector::<3>::new(1.0, 1.0, f64::INFINITY),
    ));
    let mut w = World::new(cfg).unwrap();
    let r = 0.01;
    w.add_particles(
        &[Vector::<3>::new(0.5, 0.5, r + 2e-4)],
        &[r],
        Some(&[Vector::<3>::new(1.0, 0.0, -1.0)]),
        None,
    )
    .unwrap();
    // 1.6 ms: through the ~0.6 ms contact and out again
    let t_end = 1.6e-3;
    w.step_n((t_end / dt).round() as u64).unwrap();
    (w.positions()[0][2], w.velocities()[0][0])
}

fn main() {
    // `cargo bench` passes --bench; nothing to parse.
    for (label, damping, friction) in [
        ("elastic, frictionless (xi = 0, mu = 0)", 0.0, 0.0),
        ("damped, frictionless (xi = 0.1, mu = 0)", 0.1, 0.0),
        // stick-slip transitions make the frictional case non-smooth in time
        ("damped, frictional (xi = 0.1, mu = 0.2)", 0.1, 0.2),
    ] {
        println!("\nconvergence: {label}");
        println!(
            "{:>10} {:>14} {:>8} {:>14} {:>8}",
            "dt (s)", "err z (m)", "order", "err vx (m/s)", "order"
        );
        let dts: Vec<f64> = (0..6).map(|k| 3.2e-5 / 2f64.powi(k)).collect();
        let (z_ref, v_ref) = final_state(dts[dts.len() - 1] / 64.0, damping, friction);
        let mut prev: Option<(f64, f64)> = None;
        for &dt in &dts {
            let (z, v) = final_state(dt, damping, friction);
            let (ez, ev) = ((z - z_ref).abs(), (v - v_ref).abs());
            let (oz, ov) = prev.map_or((f64::NAN, f64::NAN), |(pz, pv)| {
                ((pz / ez).log2(), (pv / ev).log2())
            });
            println!("{dt:>10.3e} {ez:>14.3e} {oz:>8.2} {ev:>14.3e} {ov:>8.2}");
            prev = Some((ez, ev));
        }
    }
}
