//! The strain-controlled drive of a drained triaxial (biaxial in 2D) compression: the
//! lid moves in at a constant speed while the side walls hold a lateral stress with the
//! consolidation's servo ([`crate::pipeline::consolidate::servo_rate`]).
//!
//! The lateral target is either a constant confining stress sigma_3, or the one that
//! keeps the mean stress p of the wall stresses constant as the lid's stress sigma_1
//! grows: sigma_3 = (D p - sigma_1) / (D - 1), recomputed from the lid's load at every
//! step. The drive runs a given number of steps and returns; the caller measures the
//! sample between calls (`granpack.triaxial` does it at every check), so the record's
//! cadence never changes the steps themselves.

use crate::error::{check_range, Error, Result};
use crate::math::{Dim, Real, Spatial};
use crate::pipeline::consolidate::servo_rate;
use crate::pipeline::world::World;
use crate::scene::stages::{MAX_STRESS, MAX_WALL_SPEED};

/// Steps of the fastest wall's travel that the walls' near-lists reach beyond them (as
/// the consolidation's).
const WALL_STEPS: Real = 100.0;

/// What the side walls hold.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Lateral {
    /// A constant confining stress sigma_3 (Pa; N/m in 2D).
    Stress(Real),
    /// A constant mean stress p (Pa; N/m in 2D): sigma_3 = (D p - sigma_1) / (D - 1),
    /// never below zero.
    MeanStress(Real),
}

/// The drive's settings, SI units.
#[derive(Clone, Debug, PartialEq)]
pub struct ShearConfig {
    /// Index of the lid in the world's wall list.
    pub axial: usize,
    /// The lid's speed inwards (m/s), > 0: it compresses the sample.
    pub axial_speed: Real,
    /// Indices of the side walls the servo moves (the box's four, the cylinder).
    pub lateral: Vec<usize>,
    /// What they hold.
    pub target: Lateral,
    /// Largest speed of a side wall (m/s).
    pub max_wall_speed: Real,
    /// Servo gain (-), in (0, 1].
    pub gain: Real,
    /// Local non-viscous damping (-), in [0, 1).
    pub local_damping: Real,
}

impl ShearConfig {
    /// Checks every field against the world it is for; errors name the field.
    pub fn validate<const D: usize>(&self, world: &World<D>) -> Result<()>
    where
        Dim<D>: Spatial<D>,
    {
        let n = world.wall_count();
        if !world.has_lid() || self.axial != n - 1 {
            return Err(Error::invalid(
                "axial",
                self.axial,
                "the lid's index: the last wall, after World::add_lid",
            ));
        }
        if self.lateral.is_empty() {
            return Err(Error::invalid(
                "lateral",
                0,
                "at least one side wall to hold the confining stress",
            ));
        }
        for &w in &self.lateral {
            if w == 0 || w >= n - 1 {
                return Err(Error::invalid(
                    "lateral",
                    w,
                    &format!("a side wall's index in [1, {}]", n - 2),
                ));
            }
        }
        check_range(
            "axial_speed",
            self.axial_speed,
            0.0,
            false,
            MAX_WALL_SPEED,
            true,
        )?;
        match self.target {
            Lateral::Stress(s) => check_range("confining", s, 0.0, false, MAX_STRESS, true)?,
            Lateral::MeanStress(p) => check_range("mean_stress", p, 0.0, false, MAX_STRESS, true)?,
        }
        check_range(
            "max_wall_speed",
            self.max_wall_speed,
            0.0,
            false,
            MAX_WALL_SPEED,
            true,
        )?;
        check_range("gain", self.gain, 0.0, false, 1.0, true)?;
        check_range("local_damping", self.local_damping, 0.0, true, 1.0, false)
    }
}

/// How often a long drive runs `poll` (Python's signal handlers: Ctrl-C).
const POLL_EVERY: std::time::Duration = std::time::Duration::from_millis(100);

/// Runs `steps` steps of the drive on `world`. The walls keep their speeds when it
/// returns, so that consecutive calls make one continuous test. `poll` runs about every
/// 0.1 s of stepping; returning false stops the drive there (the result: false).
pub fn shear<const D: usize>(
    world: &mut World<D>,
    cfg: &ShearConfig,
    steps: u64,
    poll: &mut dyn FnMut() -> bool,
) -> Result<bool>
where
    Dim<D>: Spatial<D>,
{
    cfg.validate(world)?;
    if world.is_empty() {
        return Err(Error::invalid("pack", 0, "at least one particle to load"));
    }
    let dt = world.config().dt;
    let fastest = cfg.axial_speed.max(cfg.max_wall_speed);
    let margin = WALL_STEPS * fastest * dt;
    // set once: a new margin invalidates the near-lists, and a call per check must not
    // rebuild them at every check
    if world.wall_margin() != margin {
        world.set_wall_margin(margin)?;
    }
    world.set_local_damping(cfg.local_damping)?;
    world.refresh_forces()?;
    let n_walls = world.wall_count();
    let mut drive = |w: &mut World<D>| -> Result<bool> {
        let loads = w.wall_loads();
        let mut rates = vec![0.0; n_walls];
        rates[cfg.axial] = -cfg.axial_speed;
        let sigma_3 = match cfg.target {
            Lateral::Stress(s) => s,
            Lateral::MeanStress(p) => {
                let sigma_1 = loads[cfg.axial].force / w.wall_area(cfg.axial)?;
                ((D as Real) * p - sigma_1).max(0.0) / (D as Real - 1.0)
            }
        };
        for &k in &cfg.lateral {
            let area = w.wall_area(k)?;
            rates[k] = servo_rate(&loads[k], area, sigma_3, cfg.gain, cfg.max_wall_speed, dt);
        }
        w.move_walls(&rates, &loads)?;
        Ok(true)
    };
    // In chunks of about POLL_EVERY, polling between them on the caller's thread (the
    // step's team may run the drive elsewhere, where Python sees no signal); the first
    // short chunk measures the step's cost. The chunks change no bit: the drive runs
    // before every step either way.
    let (mut left, mut chunk) = (steps, 16u64);
    while left > 0 {
        let k = chunk.min(left);
        let start = std::time::Instant::now();
        world.step_n_with(k, &mut drive)?;
        left -= k;
        if left > 0 && !poll() {
            return Ok(false);
        }
        let took = start.elapsed().as_secs_f64().max(1e-9);
        chunk = (k as f64 * POLL_EVERY.as_secs_f64() / took).clamp(1.0, 4.0 * k as f64) as u64;
    }
    Ok(true)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Vector;
    use crate::scene::{Container, SimConfig};

    /// A simple-cubic lattice of equal frictionless spheres, n x n columns of m, in a
    /// box of side n (2 r): every sphere touches its neighbours and the walls.
    fn lattice(n: usize, m: usize, r: Real) -> World<3> {
        let mut c = SimConfig::<3>::paper();
        c.gravity = Vector::<3>::zeros();
        c.material.friction = 0.0;
        let side = 2.0 * r * n as Real;
        c.walls = Some((
            Vector::<3>::zeros(),
            Vector::<3>::new(side, side, f64::INFINITY),
        ));
        c.container = Container::Box;
        let mut w = World::new(c).unwrap();
        let mut x = Vec::new();
        for i in 0..n {
            for j in 0..n {
                for k in 0..m {
                    x.push(Vector::<3>::new(
                        (2 * i + 1) as Real * r,
                        (2 * j + 1) as Real * r,
                        (2 * k + 1) as Real * r,
                    ));
                }
            }
        }
        w.add_particles(&x, &vec![r; x.len()], None, None).unwrap();
        w
    }

    fn config(lid: usize, speed: Real, target: Lateral) -> ShearConfig {
        ShearConfig {
            axial: lid,
            axial_speed: speed,
            lateral: vec![1, 2, 3, 4],
            target,
            max_wall_speed: 0.05,
            gain: 0.5,
            local_damping: 0.4,
        }
    }

    /// The lid travels exactly steps x speed x dt, whatever the calls' split: two calls
    /// of 300 steps leave the same bits as one of 600.
    #[test]
    fn the_lid_travels_at_its_speed_and_calls_split_the_path_exactly() {
        let r = 0.01;
        let make = || {
            let mut w = lattice(3, 4, r);
            w.add_lid(8.0 * r).unwrap();
            w
        };
        let (mut a, mut b) = (make(), make());
        let lid = a.wall_count() - 1;
        let cfg = config(lid, 0.01, Lateral::Stress(1e3));
        let dt = a.config().dt;
        shear(&mut a, &cfg, 600, &mut || true).unwrap();
        shear(&mut b, &cfg, 300, &mut || true).unwrap();
        shear(&mut b, &cfg, 300, &mut || true).unwrap();
        let travel = 8.0 * r - a.wall_position(lid);
        assert!((travel - 600.0 * 0.01 * dt).abs() < 1e-12, "{travel}");
        assert_eq!(
            a.wall_position(lid).to_bits(),
            b.wall_position(lid).to_bits()
        );
        for (p, q) in a.positions().iter().zip(b.positions()) {
            for k in 0..3 {
                assert_eq!(p[k].to_bits(), q[k].to_bits());
            }
        }
    }

    /// Without any load on the sides the servo moves them in at its cap; with the
    /// mean-stress target and a lid that carries D p, the lateral target is zero and
    /// the side walls move out at the cap.
    #[test]
    fn the_mean_stress_target_follows_the_lid() {
        let r = 0.01;
        let mut w = lattice(2, 2, r);
        let lid = w.add_lid(4.0 * r).unwrap();
        // a small push: the lid compresses, the sides carry a little
        shear(
            &mut w,
            &config(lid, 0.01, Lateral::Stress(10.0)),
            200,
            &mut || true,
        )
        .unwrap();
        let loads = w.wall_loads();
        let s1 = loads[lid].force / w.wall_area(lid).unwrap();
        assert!(s1 > 0.0, "the lid carries no load: {s1}");
        // p set to a third of the lid's stress: the target (3p - s1)/2 is zero
        let before = w.wall_position(2);
        let cfg = ShearConfig {
            axial_speed: 1e-9,
            ..config(lid, 0.01, Lateral::MeanStress(s1 / 3.0))
        };
        shear(&mut w, &cfg, 1, &mut || true).unwrap();
        let after = w.wall_position(2);
        assert!(after > before, "x_hi moved in: {before} -> {after}");
    }

    /// A sphere sliding on the floor under gravity: on a smooth floor (wall friction
    /// 0) its horizontal velocity stays exactly; at the material's friction it slows.
    #[test]
    fn a_smooth_wall_exerts_no_friction() {
        let slide = |mu_wall: Option<Real>| {
            let mut c = SimConfig::<3>::paper();
            c.walls = Some((
                Vector::<3>::zeros(),
                Vector::<3>::new(1.0, 1.0, f64::INFINITY),
            ));
            c.container = Container::Box;
            let mut w = World::new(c).unwrap();
            let r = 0.01;
            let v0 = Vector::<3>::new(0.1, 0.0, 0.0);
            w.add_particles(&[Vector::<3>::new(0.5, 0.5, r)], &[r], Some(&[v0]), None)
                .unwrap();
            w.set_wall_friction(mu_wall).unwrap();
            w.step_n(2000).unwrap();
            w.velocities()[0][0]
        };
        assert_eq!(slide(Some(0.0)), 0.1);
        assert!(slide(None) < 0.09, "{}", slide(None));
    }

    #[test]
    fn bad_settings_name_their_field() {
        let mut w = lattice(2, 2, 0.01);
        let cfg = config(5, 0.01, Lateral::Stress(1e3));
        let e = shear(&mut w, &cfg, 1, &mut || true)
            .unwrap_err()
            .to_string();
        assert!(e.contains("axial"), "{e}");
        let lid = w.add_lid(0.04).unwrap();
        for (cfg, key) in [
            (config(lid, 0.0, Lateral::Stress(1e3)), "axial_speed"),
            (config(lid, 0.01, Lateral::Stress(-1.0)), "confining"),
            (
                config(lid, 0.01, Lateral::MeanStress(f64::NAN)),
                "mean_stress",
            ),
            (
                ShearConfig {
                    lateral: vec![lid],
                    ..config(lid, 0.01, Lateral::Stress(1e3))
                },
                "lateral",
            ),
        ] {
            let e = shear(&mut w, &cfg, 1, &mut || true)
                .unwrap_err()
                .to_string();
            assert!(e.contains(key), "{key}: {e}");
        }
    }
}
