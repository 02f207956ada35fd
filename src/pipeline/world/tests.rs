//! The world's unit tests: two-body mechanics, the skin, freezing, the sweep and
//! the instruction-set levels.

use super::*;

fn two_body_cfg<const D: usize>(damping: Real) -> SimConfig<D>
where
    Dim<D>: Spatial<D>,
{
    let mut c = SimConfig::<D>::paper();
    c.gravity = Vector::<D>::zeros();
    c.material.damping = damping;
    c.material.friction = 0.0;
    c.dt = 1e-6;
    c
}

/// Two spheres of radius `r` on the x axis, `gap` (m) apart, closing at `v0` (m/s).
fn add_head_on_pair(w: &mut World<3>, r: Real, v0: Real, gap: Real) {
    w.add_particles(
        &[
            Vector::<3>::new(0.0, 0.0, 0.0),
            Vector::<3>::new(2.0 * r + gap, 0.0, 0.0),
        ],
        &[r, r],
        Some(&[
            Vector::<3>::new(0.5 * v0, 0.0, 0.0),
            Vector::<3>::new(-0.5 * v0, 0.0, 0.0),
        ]),
        None,
    )
    .unwrap();
}

/// A new dt is refused by name when not positive, and checked against the Rayleigh
/// step at the next step, as the configured one is.
#[test]
fn set_dt_is_checked() {
    let mut w = World::new(two_body_cfg::<3>(0.1)).unwrap();
    add_head_on_pair(&mut w, 0.01, 0.1, 1e-4);
    for bad in [0.0, -1e-5, Real::NAN] {
        let err = w.set_dt(bad).unwrap_err();
        assert!(err.to_string().contains("dt"), "{err}");
    }
    let crit = w.critical_time_step();
    w.set_dt(0.5 * crit).unwrap();
    w.step_n(3).unwrap();
    assert!((w.time() - 3.0 * 0.5 * crit).abs() < 1e-15);
    w.set_dt(2.0 * crit).unwrap();
    assert!(matches!(w.step_n(1), Err(Error::UnstableTimeStep { .. })));
}

/// Steps taken in polled chunks give the same state as one call, a poll that
/// answers false stops the run, and step counts past the bound are refused.
#[test]
fn polled_steps_equal_plain_steps_and_stop_on_request() {
    let mut a = World::new(two_body_cfg::<3>(0.1)).unwrap();
    add_head_on_pair(&mut a, 0.01, 0.1, 1e-4);
    let mut b = World::new(two_body_cfg::<3>(0.1)).unwrap();
    add_head_on_pair(&mut b, 0.01, 0.1, 1e-4);
    a.step_n(500).unwrap();
    let mut polls = 0;
    let every = std::time::Duration::from_nanos(1);
    assert!(b
        .step_n_polled(500, every, &mut || {
            polls += 1;
            true
        })
        .unwrap());
    assert!(polls > 1, "{polls}");
    assert_eq!(a.positions(), b.positions());
    assert_eq!(a.velocities(), b.velocities());
    assert_eq!(a.steps(), 500);
    assert!(!b.step_n_polled(1000, every, &mut || false).unwrap());
    assert_eq!(b.steps(), 500 + 16);
    // A stop asked for on the chunk that ends the run is still a stop.
    assert!(!b.step_n_polled(16, every, &mut || false).unwrap());
    assert!(!b.step_n_polled(3, every, &mut || false).unwrap());
    assert_eq!(b.steps(), 500 + 16 + 16 + 3);
    let err = b.step_n(MAX_STEPS_PER_CALL + 1).unwrap_err();
    assert!(err.to_string().contains("steps per call"), "{err}");
    let err = b.run(1e300).unwrap_err();
    assert!(err.to_string().contains("seconds"), "{err}");
    assert_eq!(b.steps(), 535);
}

/// Hertz (1882): for F = K d^{3/2}, K = 4/3 E* sqrt(R*), the maximum overlap is
/// (5 m* v^2 / (4 K))^{2/5} and the duration 2 * 1.47164 d_max / v.
#[test]
fn hertz_contact_duration_and_max_overlap() {
    let cfg = two_body_cfg::<3>(0.0);
    let mut w = World::new(cfg.clone()).unwrap();
    let r = 0.01;
    let v0 = 1.0;
    add_head_on_pair(&mut w, r, v0, 1e-9);
    let m = w.masses()[0];
    let (m_eff, r_eff) = (0.5 * m, 0.5 * r);
    let k = 4.0 / 3.0 * cfg.material.e_star() * r_eff.sqrt();
    let d_max = (5.0 * m_eff * v0 * v0 / (4.0 * k)).powf(0.4);
    let t_c = 2.0 * 1.471_64 * d_max / v0;
    let e0 = w.kinetic_energy();
    let mut max_d: Real = 0.0;
    let mut t_in = None;
    let mut t_out = None;
    for _ in 0..200_000 {
        w.step_n(1).unwrap();
        let d = 2.0 * r - (w.positions()[1] - w.positions()[0]).norm();
        if d > 0.0 && t_in.is_none() {
            t_in = Some(w.time());
        }
        if d <= 0.0 && t_in.is_some() {
            t_out = Some(w.time());
            break;
        }
        max_d = max_d.max(d);
    }
    let dur = t_out.unwrap() - t_in.unwrap();
    assert!((dur - t_c).abs() / t_c < 0.01, "{dur} vs {t_c}");
    assert!((max_d - d_max).abs() / d_max < 0.01, "{max_d} vs {d_max}");
    let e1 = w.kinetic_energy();
    assert!((e1 - e0).abs() / e0 < 1e-3);
}

/// Normal restitution of a head-on collision of two equal spheres (r = 0.02 m at
/// 0.63 m/s: a 4.3 sphere landing after falling through its slab), by RK4 with a
/// step of 1e-8 s on the relative coordinate: m* d'' = -max(0, K d^{3/2} +
/// c_n(d) d'), c_n = 2 xi sqrt(m* k_n(d)). The oracle for the test below.
fn restitution_oracle(cfg: &SimConfig<3>, r: Real, v0: Real) -> Real {
    let m = cfg.material.density * 4.0 / 3.0 * std::f64::consts::PI * r.powi(3);
    let (m_eff, r_eff) = (0.5 * m, 0.5 * r);
    let (e_star, xi) = (cfg.material.e_star(), cfg.material.damping);
    let acc = |d: Real, u: Real| -> Real {
        if d <= 0.0 {
            return 0.0;
        }
        let kn = 2.0 * e_star * (r_eff * d).sqrt();
        let f =
            4.0 / 3.0 * e_star * r_eff.sqrt() * d.powf(1.5) + 2.0 * xi * (m_eff * kn).sqrt() * u;
        -f.max(0.0) / m_eff
    };
    // d: overlap (m), u = d' (m/s), from first touch until the spheres part
    let (mut d, mut u, h) = (0.0, v0, 1e-8);
    while d >= 0.0 {
        let (k1d, k1u) = (u, acc(d, u));
        let (k2d, k2u) = (u + 0.5 * h * k1u, acc(d + 0.5 * h * k1d, u + 0.5 * h * k1u));
        let (k3d, k3u) = (u + 0.5 * h * k2u, acc(d + 0.5 * h * k2d, u + 0.5 * h * k2u));
        let (k4d, k4u) = (u + h * k3u, acc(d + h * k3d, u + h * k3u));
        d += h / 6.0 * (k1d + 2.0 * k2d + 2.0 * k3d + k4d);
        u += h / 6.0 * (k1u + 2.0 * k2u + 2.0 * k3u + k4u);
    }
    -u / v0
}

/// The engine's restitution of the same collision at time step `dt`, the first
/// touch `phase` (in [0, 1)) of a step after the start.
fn restitution(cfg: &SimConfig<3>, dt: Real, r: Real, v0: Real, phase: Real) -> Real {
    let mut cfg = cfg.clone();
    cfg.dt = dt;
    let mut w = World::new(cfg).unwrap();
    add_head_on_pair(&mut w, r, v0, 1e-12 + phase * v0 * dt);
    let mut touched = false;
    for _ in 0..100_000 {
        w.step_n(1).unwrap();
        let d = 2.0 * r - (w.positions()[1] - w.positions()[0]).norm();
        touched |= d > 0.0;
        if touched && d <= 0.0 {
            break;
        }
    }
    assert!(touched);
    (w.velocities()[1][0] - w.velocities()[0][0]) / v0
}

/// The restitution the time steps of the paper (12 steps in contact) and of
/// `PackScene.fast()` (0.55 of the Rayleigh estimate, 6 steps) give a landing
/// collision: averaged over where in a step the contact begins, within 0.5 % of the
/// RK4 oracle; single collisions scatter by a few per cent with that phase. At
/// 1e-6 s the engine converges to the oracle.
#[test]
fn restitution_at_the_paper_and_fast_time_steps() {
    let (r, v0) = (0.02, 0.63);
    let cfg = two_body_cfg::<3>(0.1);
    let e = restitution_oracle(&cfg, r, v0);
    assert!((0.70..0.75).contains(&e), "oracle {e}");
    let fine = restitution(&cfg, 1e-6, r, v0, 0.0) / e - 1.0;
    assert!(fine.abs() < 2e-4, "dt 1e-6: {fine}");
    let rayleigh = cfg.material.rayleigh_time_step(r);
    for dt in [1e-4, 0.55 * rayleigh] {
        let errs: Vec<Real> = (0..8)
            .map(|k| restitution(&cfg, dt, r, v0, k as Real / 8.0) / e - 1.0)
            .collect();
        let mean = errs.iter().sum::<Real>() / 8.0;
        let spread = errs.iter().fold(0.0, |a: Real, x| a.max(x.abs()));
        assert!(mean.abs() < 0.005, "dt {dt}: mean error {mean}");
        assert!(
            (0.005..0.06).contains(&spread),
            "dt {dt}: largest error {spread}"
        );
    }
}

#[test]
fn energy_gained_without_a_source_stops_the_run() {
    let mut cfg = SimConfig::<3>::paper();
    cfg.walls = Some((
        Vector::<3>::zeros(),
        Vector::<3>::new(1.0, 1.0, f64::INFINITY),
    ));
    let mut w = World::new(cfg).unwrap();
    let x: Vec<Vector<3>> = (0..10)
        .map(|k| Vector::<3>::new(0.1 + 0.05 * k as f64, 0.5, 0.3))
        .collect();
    w.add_particles(&x, &[0.02; 10], None, None).unwrap();
    w.step_n(2000).unwrap(); // falling converts potential into kinetic energy: fine
                             // Inject energy behind the engine's back, as a numerical instability would.
    for v in w.p.v.iter_mut() {
        *v += Vector::<3>::new(3.0, 0.0, 0.0);
    }
    let e = w.check_energy().unwrap_err().to_string();
    assert!(e.contains("energy grew") && e.contains("step 2000"), "{e}");
}

#[test]
fn unstable_dt_is_refused_with_the_estimate() {
    let mut cfg = SimConfig::<2>::paper();
    cfg.dt = 1e-3;
    let mut w = World::new(cfg).unwrap();
    w.add_particles(&[Vector::<2>::zeros()], &[0.01], None, None)
        .unwrap();
    let e = w.step_n(1).unwrap_err().to_string();
    assert!(e.contains("dt") && e.contains("1.712"), "{e}");
}

#[test]
fn rotations_off_keeps_spins_zero() {
    let mut cfg = SimConfig::<3>::paper();
    cfg.rotations = false;
    cfg.walls = Some((
        Vector::<3>::zeros(),
        Vector::<3>::new(1.0, 1.0, f64::INFINITY),
    ));
    let mut w = World::new(cfg).unwrap();
    w.add_particles(
        &[Vector::<3>::new(0.5, 0.5, 0.0099)],
        &[0.01],
        Some(&[Vector::<3>::new(0.3, 0.0, 0.0)]),
        None,
    )
    .unwrap();
    w.step_n(2000).unwrap();
    assert_eq!(w.spins()[0], Vector::<3>::zeros());
    // Friction still decelerates the sliding sphere.
    assert!(w.velocities()[0][0] < 0.3);
}

/// The particle-particle pairs (i, j) of a contact list, sorted.
pub(super) fn particle_pairs<const D: usize>(c: &Contacts<D>) -> Vec<[u32; 2]> {
    let mut got: Vec<[u32; 2]> =
        c.i.iter()
            .zip(&c.j)
            .filter(|(_, &j)| j >= 0)
            .map(|(&i, &j)| [i as u32, j as u32])
            .collect();
    got.sort();
    got
}

/// The particle pairs `contacts()` reports are exactly the overlapping pairs of a
/// brute-force search on the current positions (the pair list lost none).
fn assert_contacts_are_the_overlaps<const D: usize>(w: &mut World<D>)
where
    Dim<D>: Spatial<D>,
{
    let c = w.contacts().unwrap();
    let got = particle_pairs(&c);
    let expect = crate::geometry::brute_force_pairs(w.positions(), w.radii());
    assert_eq!(got, expect, "step {}", w.steps());
}

/// The adaptive skin never loses a contact: a 2D gas whose speeds span three
/// orders of magnitude (so the particles' skins differ, and change from rebuild to
/// rebuild) has, at every check, exactly the overlapping pairs of a brute-force
/// search.
#[test]
fn adaptive_skin_keeps_every_contact() {
    use rand::{Rng, SeedableRng};
    let mut cfg = SimConfig::<2>::paper();
    cfg.gravity = Vector::<2>::zeros();
    cfg.walls = Some((Vector::<2>::zeros(), Vector::<2>::new(0.5, 0.5)));
    cfg.dt = 2e-5;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
    let mut x = Vec::new();
    let mut v = Vec::new();
    for a in 0..15 {
        for b in 0..15 {
            x.push(Vector::<2>::new(
                0.03 + 0.03 * a as f64 + 0.004 * rng.random::<f64>(),
                0.03 + 0.03 * b as f64 + 0.004 * rng.random::<f64>(),
            ));
            // speeds from 1 mm/s to 1 m/s, random directions
            let speed = 10f64.powf(-3.0 + 3.0 * rng.random::<f64>());
            let phi = std::f64::consts::TAU * rng.random::<f64>();
            v.push(Vector::<2>::new(phi.cos(), phi.sin()) * speed);
        }
    }
    let r: Vec<Real> = (0..x.len())
        .map(|_| 0.008 + 0.006 * rng.random::<f64>())
        .collect();
    let mut w = World::new(cfg).unwrap();
    w.add_particles(&x, &r, Some(&v), None).unwrap();
    let mut spread = 0.0 as Real;
    for _ in 0..400 {
        w.step_n(5).unwrap();
        // the skins differ between particles, within their bounds
        let skins = w.p.half_skin.iter().map(|h| 2.0 * h);
        let (lo, hi) = skins.fold((Real::MAX, 0.0 as Real), |(a, b), s| (a.min(s), b.max(s)));
        let widest = 0.2 * 0.008;
        assert!(
            lo >= SKIN_FLOOR * widest * 0.99 && hi <= widest * 1.01,
            "{lo} {hi}"
        );
        spread = spread.max(hi / lo);
        assert_contacts_are_the_overlaps(&mut w);
    }
    assert!(
        spread > 3.0,
        "skins nearly equal: largest / smallest {spread}"
    );
}

/// A loose side x side x high lattice of spheres from height z0 (m), pitch 32 mm,
/// with horizontal jitter and radii 8-12 mm.
fn lattice(
    rng: &mut rand_chacha::ChaCha8Rng,
    side: usize,
    high: usize,
    z0: f64,
) -> (Vec<Vector<3>>, Vec<Real>) {
    use rand::Rng;
    let mut x = Vec::new();
    for a in 0..side {
        for b in 0..side {
            for c in 0..high {
                x.push(Vector::<3>::new(
                    0.02 + 0.032 * a as f64 + 0.004 * rng.random::<f64>(),
                    0.02 + 0.032 * b as f64 + 0.004 * rng.random::<f64>(),
                    z0 + 0.032 * c as f64,
                ));
            }
        }
    }
    let r = (0..x.len())
        .map(|_| 0.008 + 0.004 * rng.random::<f64>())
        .collect();
    (x, r)
}

/// The paper's material in an open-topped side x side box (m) under 9.81 m/s^2, with
/// drag (time constant about 0.2 s) so that a bed comes to rest quickly.
fn falling_box(side: f64) -> SimConfig<3> {
    let mut cfg = SimConfig::<3>::paper();
    cfg.walls = Some((
        Vector::<3>::zeros(),
        Vector::<3>::new(side, side, f64::INFINITY),
    ));
    cfg.gravity = Vector::<3>::new(0.0, 0.0, -9.81);
    cfg.drag = 0.05;
    cfg
}

/// Freezing for a bed of `lattice` spheres in `falling_box`: below 0.1 m, slower than
/// 1 cm/s, net force under 0.3 of the weight, checked every 10 steps.
const BED_FREEZE: FreezeConfig = FreezeConfig {
    below: 0.1,
    speed: 1e-2,
    force_ratio: 0.3,
    interval: 10,
};

/// Freezing, thawing and the partial rebuilds that skip frozen pairs never lose a
/// contact: after every few steps the contacts the world reports are exactly the
/// overlapping pairs of a brute-force search, while a second batch of spheres lands
/// on a frozen bed (which thaws part of it).
#[test]
fn frozen_runs_keep_every_contact() {
    use rand::SeedableRng;
    let mut w = World::new(falling_box(0.2)).unwrap();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
    let mut batch = |z0: f64| lattice(&mut rng, 6, 3, z0);
    let (x, r) = batch(0.015);
    w.add_particles(&x, &r, None, None).unwrap();
    w.set_freeze(Some(BED_FREEZE)).unwrap();
    for _ in 0..1000 {
        w.step_n(10).unwrap();
        assert_contacts_are_the_overlaps(&mut w);
    }
    let frozen_before = w.n_frozen();
    assert!(frozen_before > 20, "the bed froze: {frozen_before}");
    let (x, r) = batch(0.15);
    w.add_particles(&x, &r, None, None).unwrap();
    let mut min_frozen = usize::MAX;
    for _ in 0..300 {
        w.step_n(10).unwrap();
        min_frozen = min_frozen.min(w.n_frozen());
        assert_contacts_are_the_overlaps(&mut w);
    }
    assert!(
        min_frozen < frozen_before,
        "the impact thawed part of the bed"
    );
    assert!(w.rebuilds() > 10);
}

/// A world spent for its finished pack gives the contacts `contacts()` gives and its
/// own particle arrays, to the bit: with a frozen and an active run in the pair list
/// and with one, in a box (wall contacts) and in a periodic cell (centres wrapped),
/// the list's tail freed at every block.
#[test]
fn a_finished_world_gives_its_contacts_and_arrays() {
    use rand::SeedableRng;
    for periodic in [false, true] {
        let mut cfg = falling_box(0.2);
        if periodic {
            cfg.container = Container::Periodic;
        }
        let mut w = World::new(cfg).unwrap();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(12);
        let (x, r) = lattice(&mut rng, 6, 4, 0.015);
        w.add_particles(&x, &r, None, None).unwrap();
        w.set_freeze(Some(BED_FREEZE)).unwrap();
        let mut runs = [false; 2];
        for _ in 0..150 {
            w.step_n(100).unwrap();
            let (m, frozen) = w.pair_counts();
            let two_runs = frozen > 0 && frozen < m;
            let mut spent = w.clone();
            let expect = spent.contacts().unwrap();
            // more contacts than a block, so that the tail is freed midway
            if runs[two_runs as usize] || expect.len() <= BLOCK {
                continue;
            }
            runs[two_runs as usize] = true;
            let (got, state) = spent.into_finished_freeing(BLOCK).unwrap();
            assert_eq!(got.i, expect.i);
            assert_eq!(got.j, expect.j);
            assert_eq!(got.normal, expect.normal);
            assert_eq!(got.overlap, expect.overlap);
            assert_eq!(got.force_normal, expect.force_normal);
            assert_eq!(got.force_tangential, expect.force_tangential);
            assert_eq!(got.branch, expect.branch);
            assert!(got.j.iter().any(|&j| j < 0), "the floor's contacts");
            assert_eq!(state.positions, w.positions_in_cell());
            assert_eq!(state.velocities, w.velocities());
            assert_eq!(state.spins, w.spins());
            assert_eq!(state.radii, w.radii());
            assert_eq!(state.time, w.time());
        }
        assert_eq!(runs, [true, true], "both list layouts were checked");
    }
}

/// The one-sweep force pass gives the same bits as the two passes, on one and on
/// three threads (three pieces, so particles with pairs in two pieces are gathered
/// after the sweep), with a frozen bed that a second batch lands on and thaws.
#[test]
fn force_sweep_equals_two_passes() {
    use rand::SeedableRng;
    let cfg = falling_box(0.4);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
    let (x1, r1) = lattice(&mut rng, 12, 8, 0.015);
    let (x2, r2) = lattice(&mut rng, 12, 4, 0.35);
    let run = |sweep: bool, threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let mut w = World::new(cfg.clone()).unwrap();
            if sweep {
                w.sweep_min_bytes = 0;
            }
            w.add_particles(&x1, &r1, None, None).unwrap();
            w.set_freeze(Some(FreezeConfig {
                below: 0.15,
                ..BED_FREEZE
            }))
            .unwrap();
            w.step_n(6000).unwrap();
            let frozen = w.n_frozen();
            w.add_particles(&x2, &r2, None, None).unwrap();
            w.step_n(1500).unwrap();
            let bits = |v: &[Vector<3>]| -> Vec<u64> {
                v.iter()
                    .flat_map(|a| a.iter().map(|c| c.to_bits()))
                    .collect()
            };
            let state = [bits(w.positions()), bits(w.velocities()), bits(w.spins())];
            (frozen, w.pairs.ij.len(), state)
        })
    };
    let two = run(false, 1);
    assert!(two.0 > 100, "the bed froze: {}", two.0);
    assert!(
        two.1 > 8 * BLOCK,
        "pairs enough for three pieces: {}",
        two.1
    );
    assert!(run(true, 1) == two, "sweep, one thread");
    assert!(run(true, 3) == two, "sweep, three threads");
}

/// Every instruction-set level the CPU runs gives the same bits, in 3D (two passes
/// and the sweep, walls, spins, friction) and in 2D. The level is process-wide, and
/// no other test sets it, so each run below runs at the level it names.
#[test]
fn every_level_gives_the_same_bits() {
    use crate::cpu;
    use rand::SeedableRng;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
    let (x3, r3) = lattice(&mut rng, 6, 3, 0.015);
    // the lattice's first vertical plane (y < 30 mm), as discs in (x, z)
    let (x2, r2): (Vec<Vector<2>>, Vec<Real>) = x3
        .iter()
        .zip(&r3)
        .filter(|(x, _)| x[1] < 0.03)
        .map(|(x, &r)| (Vector::<2>::new(x[0], x[2]), r))
        .unzip();
    let run3 = |sweep: bool| {
        let mut w = World::new(falling_box(0.2)).unwrap();
        if sweep {
            w.sweep_min_bytes = 0;
        }
        w.add_particles(&x3, &r3, None, None).unwrap();
        w.step_n(4000).unwrap();
        let n = w.contacts().unwrap().i.len();
        assert!(n > 100, "the bed is in contact: {n}");
        w.state_checksum()
    };
    let run2 = || {
        let mut cfg = SimConfig::<2>::paper();
        cfg.walls = Some((Vector::<2>::zeros(), Vector::<2>::new(0.2, f64::INFINITY)));
        cfg.gravity = Vector::<2>::new(0.0, -9.81);
        cfg.drag = 0.05;
        let mut w = World::new(cfg).unwrap();
        w.add_particles(&x2, &r2, None, None).unwrap();
        w.step_n(4000).unwrap();
        let n = w.contacts().unwrap().i.len();
        assert!(n > 15, "the 2D bed is in contact: {n}");
        w.state_checksum()
    };
    // the same bed in a periodic cell (the minimum image) and in a cylinder of radius
    // 0.2 m (the curved wall)
    let run_in = |container: Container| {
        // the periodic cell 0.19 m wide, so that the bed meets its images across the
        // seam; the cylinder's box 0.4 m, the bed moved to its middle
        let (side, shift) = match container {
            Container::Periodic => (0.19, 0.0),
            _ => (0.4, 0.1),
        };
        let mut cfg = falling_box(side);
        cfg.container = container;
        let mut w = World::new(cfg).unwrap();
        let x: Vec<Vector<3>> = x3
            .iter()
            .map(|p| p + Vector::<3>::new(shift, shift, 0.0))
            .collect();
        w.add_particles(&x, &r3, None, None).unwrap();
        w.step_n(4000).unwrap();
        w.state_checksum()
    };
    let before = cpu::level();
    let mut seen = Vec::new();
    for l in cpu::available() {
        cpu::set_level(l).unwrap();
        assert_eq!(cpu::level(), l);
        let containers = (
            run_in(Container::Periodic),
            run_in(Container::Cylinder(0.2)),
        );
        seen.push((l, run3(false), run3(true), run2(), containers));
    }
    cpu::set_level(before).unwrap();
    let first = seen[0];
    for s in &seen {
        assert_eq!(
            (s.1, s.2, s.3, s.4),
            (first.1, first.2, first.3, first.4),
            "{} against {}",
            s.0.name(),
            first.0.name()
        );
    }
    // the sweep and the two passes agree too
    assert_eq!(first.1, first.2);
}
