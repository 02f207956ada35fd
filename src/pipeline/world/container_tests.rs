//! The containers' mechanics: the cylinder wall's contact law, containment, and the
//! periodic cell's seam.

use super::*;
use rand::{Rng, SeedableRng};

/// The paper's material, no gravity, frictionless, dt = 1e-6 s, in `container` with
/// corners 0 and (side, side, infinity).
fn quiet(container: Container, side: Real, damping: Real) -> SimConfig<3> {
    let mut c = SimConfig::<3>::paper();
    c.gravity = Vector::<3>::zeros();
    c.material.damping = damping;
    c.material.friction = 0.0;
    c.dt = 1e-6;
    c.walls = Some((
        Vector::<3>::zeros(),
        Vector::<3>::new(side, side, f64::INFINITY),
    ));
    c.container = container;
    c
}

/// Normal restitution of one sphere (radius r, speed v0 along +x) against the wall it
/// meets: the cylinder's at (2R, R), or a box's x = 2R plane. The sphere starts a
/// hair from the wall, at mid-height (no floor contact).
fn wall_restitution(container: Container, side: Real, r: Real, v0: Real, damping: Real) -> Real {
    let mut w = World::new(quiet(container, side, damping)).unwrap();
    let c = 0.5 * side;
    w.add_particles(
        &[Vector::<3>::new(side - r - 1e-9, c, 1.0)],
        &[r],
        Some(&[Vector::<3>::new(v0, 0.0, 0.0)]),
        None,
    )
    .unwrap();
    for _ in 0..200_000 {
        w.step_n(1).unwrap();
        if w.velocities()[0][0] < 0.0 && w.positions()[0][0] < side - r - 1e-9 {
            break;
        }
    }
    let v = w.velocities()[0];
    assert!(v[0] < 0.0, "the sphere did not bounce back: {v:?}");
    // a head-on hit stays radial: nothing tangential
    assert!(v[1].abs() < 1e-9 * v0 && v[2].abs() < 1e-12, "{v:?}");
    -v[0] / v0
}

/// Without damping the cylinder gives a head-on sphere its energy back (to 1e-3), and
/// with xi = 0.1 its restitution is that of a plane wall within 1 % once R >> r (the
/// curvature correction of R* is then small), and differs from it (more compliant
/// contact, same e for Hertz: e depends on xi only) by little at R = 5 r.
#[test]
fn cylinder_wall_head_on_restitution() {
    let (r, v0) = (0.02, 0.5);
    let e = wall_restitution(Container::Cylinder(0.5), 1.0, r, v0, 0.0);
    assert!((e * e - 1.0).abs() < 1e-3, "energy ratio {}", e * e);
    let plane = wall_restitution(Container::Box, 1.0, r, v0, 0.1);
    let far = wall_restitution(Container::Cylinder(50.0 * r), 100.0 * r, r, v0, 0.1);
    assert!((far - plane).abs() / plane < 0.01, "{far} vs {plane}");
    assert!(plane > 0.5 && plane < 0.95, "{plane}");
}

/// The paper's material in a cylinder of radius `rc` (m) under 9.81 m/s^2.
fn cylinder_under_gravity(rc: Real) -> SimConfig<3> {
    let mut cfg = SimConfig::<3>::paper();
    cfg.walls = Some((
        Vector::<3>::zeros(),
        Vector::<3>::new(2.0 * rc, 2.0 * rc, f64::INFINITY),
    ));
    cfg.container = Container::Cylinder(rc);
    cfg.gravity = Vector::<3>::new(0.0, 0.0, -9.81);
    cfg
}

/// A sphere that rolls around the inside of the cylinder under gravity, on the floor,
/// stays on the wall: its distance to the axis stays within a small overlap of R - r
/// for 4 s (more than a lap), and it never crosses the wall.
#[test]
fn sphere_rolling_inside_the_cylinder_stays_on_the_wall() {
    let (rc, r) = (0.2, 0.02);
    let cfg = cylinder_under_gravity(rc);
    let mut w = World::new(cfg).unwrap();
    // on the floor, touching the wall at (rc + (rc - r), rc), moving around it
    w.add_particles(
        &[Vector::<3>::new(2.0 * rc - r, rc, r)],
        &[r],
        Some(&[Vector::<3>::new(0.0, 1.2, 0.0)]),
        None,
    )
    .unwrap();
    let (mut lo, mut hi, mut turned) = (Real::INFINITY, 0.0, 0.0);
    let mut last = 0.0;
    for _ in 0..4000 {
        w.step_n(10).unwrap();
        let x = w.positions()[0];
        let (a, b) = (x[0] - rc, x[1] - rc);
        let rho = (a * a + b * b).sqrt();
        lo = Real::min(lo, rho);
        hi = Real::max(hi, rho);
        let ang = b.atan2(a);
        let mut d = ang - last;
        if d < -std::f64::consts::PI {
            d += 2.0 * std::f64::consts::PI;
        }
        turned += d;
        last = ang;
    }
    assert!(turned > 2.0 * std::f64::consts::PI, "{turned} rad");
    assert!(hi < rc, "crossed the wall: {hi}");
    assert!(lo > rc - r - 0.01 * r, "left the wall: {lo}");
}

/// A bed of 150 polydisperse spheres dropped into a cylinder of radius 0.1 m settles,
/// and over 1e5 further steps no centre ever leaves the cylinder and no sphere pokes
/// through the wall by more than the overlap guard allows.
#[test]
fn settled_bed_stays_inside_the_cylinder() {
    let rc = 0.1;
    let mut cfg = cylinder_under_gravity(rc);
    cfg.drag = 0.05;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
    let (mut x, mut r) = (Vec::new(), Vec::new());
    while x.len() < 150 {
        let rad = 0.008 + 0.004 * rng.random::<f64>();
        let (a, b) = (
            rng.random::<f64>() * 2.0 - 1.0,
            rng.random::<f64>() * 2.0 - 1.0,
        );
        if a * a + b * b > 1.0 {
            continue;
        }
        let s = rc - rad;
        let p = Vector::<3>::new(rc + a * s, rc + b * s, 0.02 + 0.5 * rng.random::<f64>());
        if x.iter()
            .zip(&r)
            .all(|(q, &rq): (&Vector<3>, &Real)| (q - p).norm() > rq + rad)
        {
            x.push(p);
            r.push(rad);
        }
    }
    let mut w = World::new(cfg).unwrap();
    w.add_particles(&x, &r, None, None).unwrap();
    w.run(1.0).unwrap();
    for _ in 0..100 {
        w.step_n(1000).unwrap();
        for (p, &rad) in w.positions().iter().zip(w.radii()) {
            let rho = ((p[0] - rc).powi(2) + (p[1] - rc).powi(2)).sqrt();
            assert!(rho < rc && rho + rad < rc + 0.05 * rad, "{p:?}");
            assert!(p[2] > 0.0);
        }
    }
}

/// The contacts of a periodic gas are exactly the brute-force minimum-image overlaps,
/// across the seam too, at every check while the gas moves through the seam many
/// times (2D and 3D); every reported centre lies in [0, L).
#[test]
fn periodic_contacts_equal_brute_force_minimum_image() {
    fn run<const D: usize>()
    where
        Dim<D>: Spatial<D>,
    {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(9);
        let side = 0.3;
        let mut cfg = SimConfig::<D>::paper();
        cfg.gravity = Vector::<D>::zeros();
        let mut hi = Vector::<D>::repeat(side);
        hi[D - 1] = f64::INFINITY;
        cfg.walls = Some((Vector::<D>::zeros(), hi));
        cfg.container = Container::Periodic;
        cfg.dt = 2e-5;
        let (mut x, mut r, mut v) = (Vec::new(), Vec::new(), Vec::new());
        let n = if D == 2 { 120 } else { 300 };
        while x.len() < n {
            let rad = 0.006 + 0.006 * rng.random::<f64>();
            let mut p = Vector::<D>::from_fn(|_, _| side * rng.random::<f64>());
            p[D - 1] = rad + 0.05 * rng.random::<f64>() * if D == 2 { 4.0 } else { 2.0 };
            let per = Period::lateral(&Vector::<D>::zeros(), &hi);
            if x.iter()
                .zip(&r)
                .all(|(q, &rq): (&Vector<D>, &Real)| per.image(q - p).norm() > rq + rad)
            {
                x.push(p);
                r.push(rad);
                let mut u = Vector::<D>::from_fn(|_, _| 2.0 * rng.random::<f64>() - 1.0);
                u[D - 1] = 0.0;
                // lateral drift (0.5 m/s: the cell is crossed every 0.6 s) plus noise
                u[0] += 0.5;
                v.push(u);
            }
        }
        let mut w = World::new(cfg).unwrap();
        w.add_particles(&x, &r, Some(&v), None).unwrap();
        let per = *w.period().unwrap();
        for _ in 0..40 {
            w.step_n(2000).unwrap();
            let c = w.contacts().unwrap();
            let got = super::tests::particle_pairs(&c);
            let xs = w.positions_in_cell();
            let expect = crate::geometry::brute_force_pairs_periodic(&xs, w.radii(), &per);
            assert_eq!(got, expect, "step {}", w.steps());
            assert!(
                c.j.iter().all(|&j| j >= -1),
                "a side wall in a periodic cell"
            );
            for p in &xs {
                for k in 0..D - 1 {
                    assert!(p[k] >= 0.0 && p[k] < side, "{p:?}");
                }
            }
        }
        let crossed = w.positions_in_cell().len();
        assert!(crossed > 0);
    }
    run::<2>();
    run::<3>();
}

/// Neither the skin nor when the list is rebuilt changes a bit: a frictional bed
/// settling under gravity, in a box and in a periodic cell that its particles cross
/// (positions wrap on the drift that takes them out, not at a rebuild), steps to the
/// same state with skins of 0.05 and 0.6 radii, through different numbers of
/// rebuilds; every contact is found in both (brute force, minimum image).
#[test]
fn neither_the_skin_nor_the_rebuilds_change_a_bit() {
    for container in [Container::Box, Container::Periodic] {
        let side = 0.2;
        let run = |skin: Real| {
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
            let mut cfg = SimConfig::<3>::paper();
            cfg.dt = 2e-5;
            cfg.skin_ratio = skin;
            cfg.walls = Some((
                Vector::<3>::zeros(),
                Vector::<3>::new(side, side, f64::INFINITY),
            ));
            cfg.container = container;
            let per = Period::lateral(&Vector::<3>::zeros(), &Vector::<3>::repeat(side));
            let (mut x, mut r, mut v) = (Vec::new(), Vec::new(), Vec::new());
            while x.len() < 150 {
                let rad = 0.008 + 0.004 * rng.random::<f64>();
                let p = Vector::<3>::new(
                    rad + (side - 2.0 * rad) * rng.random::<f64>(),
                    rad + (side - 2.0 * rad) * rng.random::<f64>(),
                    rad + 0.15 * rng.random::<f64>(),
                );
                if x.iter()
                    .zip(&r)
                    .all(|(q, &rq): (&Vector<3>, &Real)| per.image(q - p).norm() > rq + rad)
                {
                    x.push(p);
                    r.push(rad);
                    // a lateral drift that carries the periodic bed across its seam
                    v.push(Vector::<3>::new(
                        0.3 + 0.2 * rng.random::<f64>(),
                        0.2 * rng.random::<f64>() - 0.1,
                        0.0,
                    ));
                }
            }
            let mut w = World::new(cfg).unwrap();
            w.add_particles(&x, &r, Some(&v), None).unwrap();
            for _ in 0..20 {
                w.step_n(500).unwrap();
                let c = w.contacts().unwrap();
                let got = super::tests::particle_pairs(&c);
                let xs = w.positions_in_cell();
                let expect = match w.period() {
                    Some(per) => crate::geometry::brute_force_pairs_periodic(&xs, w.radii(), per),
                    None => crate::geometry::brute_force_pairs(&xs, w.radii()),
                };
                assert_eq!(got, expect, "{container:?} skin {skin} step {}", w.steps());
            }
            w
        };
        let (narrow, wide) = (run(0.05), run(0.6));
        assert!(
            narrow.rebuilds() > 2 * wide.rebuilds(),
            "{container:?}: {} and {} rebuilds",
            narrow.rebuilds(),
            wide.rebuilds()
        );
        let differ =
            |a: &[Vector<3>], b: &[Vector<3>]| a.iter().zip(b).filter(|(p, q)| p != q).count();
        assert_eq!(
            differ(narrow.positions(), wide.positions()),
            0,
            "{container:?}: positions"
        );
        assert_eq!(
            differ(narrow.velocities(), wide.velocities()),
            0,
            "{container:?}: velocities"
        );
        assert_eq!(
            differ(narrow.spins(), wide.spins()),
            0,
            "{container:?}: spins"
        );
        assert_eq!(narrow.state_checksum(), wide.state_checksum());
    }
}

/// A pair that overlaps across the seam gets the same forces, step by step, as the
/// same pair moved into the interior of the cell, and keeps its tangential history
/// while its particles wrap. The two runs differ only by the rounding of positions
/// near 0 and near L/2 (about 1e-17 m), which moves the forces by far less than 1e-9
/// of their size.
#[test]
fn the_seam_changes_nothing() {
    let side = 0.3;
    let make = |shift: Real| {
        let mut cfg = SimConfig::<3>::paper();
        cfg.gravity = Vector::<3>::zeros();
        cfg.walls = Some((
            Vector::<3>::zeros(),
            Vector::<3>::new(side, side, f64::INFINITY),
        ));
        cfg.container = Container::Periodic;
        cfg.dt = 1e-6;
        let mut w = World::new(cfg).unwrap();
        let wrap = |a: Real| (a + shift).rem_euclid(side);
        // an oblique contact (normal and tangential forces) drifting at 1 m/s along
        // x, so that the second sphere crosses the seam x = 0 after 0.6 ms
        w.add_particles(
            &[
                Vector::<3>::new(wrap(-0.0204), wrap(0.0005), 0.5),
                Vector::<3>::new(wrap(-0.0006), wrap(-0.0005), 0.5),
            ],
            &[0.01, 0.01],
            Some(&[
                Vector::<3>::new(1.0, 0.05, 0.0),
                Vector::<3>::new(1.0, -0.05, 0.0),
            ]),
            None,
        )
        .unwrap();
        w
    };
    let (mut seam, mut inside) = (make(0.0), make(0.5 * side));
    let (mut saw_force, mut wrapped) = (false, false);
    for _ in 0..300 {
        seam.step_n(10).unwrap();
        inside.step_n(10).unwrap();
        let (a, b) = (seam.contacts().unwrap(), inside.contacts().unwrap());
        assert_eq!(a.i.len(), b.i.len(), "step {}", seam.steps());
        for k in 0..a.i.len() {
            let scale = 1e-9 * a.force_normal[k].abs();
            assert!((a.force_normal[k] - b.force_normal[k]).abs() <= scale);
            assert!((a.force_tangential[k] - b.force_tangential[k]).norm() <= scale);
            assert!((a.branch[k] - b.branch[k]).norm() < 1e-12);
            saw_force |= a.force_tangential[k].norm() > 0.0;
        }
        wrapped |= seam.positions_in_cell()[1][0] < 0.1;
    }
    assert!(saw_force, "the pair never carried a tangential force");
    assert!(wrapped, "the second sphere never crossed the seam");
}

/// A sphere sliding on the floor keeps its speed without friction; once the friction
/// is set to mu it slows at mu g (Coulomb sliding, before it rolls), and a copy of the
/// world steps on to the same bits as the original. A negative or NaN friction is
/// refused by name.
#[test]
fn friction_set_between_steps_slows_a_sliding_sphere_at_mu_g() {
    let r = 0.02;
    let mut cfg = SimConfig::<3>::paper();
    cfg.walls = Some((
        Vector::<3>::zeros(),
        Vector::<3>::new(10.0, 10.0, f64::INFINITY),
    ));
    cfg.container = Container::Box;
    cfg.gravity = Vector::<3>::new(0.0, 0.0, -9.81);
    cfg.material.friction = 0.0;
    cfg.drag = 0.0;
    cfg.dt = 1e-5;
    let mut w = World::new(cfg).unwrap();
    // resting on the floor at its static overlap after a short settle
    w.add_particles(&[Vector::<3>::new(1.0, 5.0, r)], &[r], None, None)
        .unwrap();
    w.step_n(20_000).unwrap();
    w.set_velocities(&[Vector::<3>::new(1.0, 0.0, w.velocities()[0][2])])
        .unwrap();
    w.step_n(2000).unwrap();
    assert!(
        (w.velocities()[0][0] - 1.0).abs() < 1e-12,
        "{}",
        w.velocities()[0][0]
    );
    let mu = 0.4;
    w.set_friction(mu).unwrap();
    let mut copy = w.clone();
    let t = 0.02; // sliding lasts 2 v / (7 mu g) = 0.036 s
    w.step_n((t / 1e-5) as u64).unwrap();
    let dv = 1.0 - w.velocities()[0][0];
    assert!((dv / (mu * 9.81 * t) - 1.0).abs() < 0.02, "{dv}");
    copy.step_n((t / 1e-5) as u64).unwrap();
    assert_eq!(copy.positions()[0], w.positions()[0]);
    assert_eq!(copy.spins()[0], w.spins()[0]);
    for bad in [-0.1, Real::NAN, Real::INFINITY] {
        let err = w.set_friction(bad).unwrap_err();
        assert!(err.to_string().contains("friction"), "{err}");
    }
}
