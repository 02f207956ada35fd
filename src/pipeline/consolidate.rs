//! Consolidation: servo-controlled walls drive a pack to a target stress state and
//! hold it until it is in static equilibrium.
//!
//! The servo is PFC's (Itasca, PFC 6 manual, "wall servo"): each controlled wall moves
//! at the speed that would close `gain` of its stress error in one step if the
//! particles stayed put,
//!
//!   v_in = gain (sigma* - sigma) A / (K dt),
//!
//! where A is the wall's area and K the force its contacts gain per metre it moves in
//! one step (`WallLoad::step_stiffness`): their Hertz tangent stiffness, and their
//! dashpots' C / dt, since a wall that moves drives the dashpots too. Without the
//! dashpots' share, which at the paper's damping is about twice the springs', the
//! servo overshoots every step and settles into a two-step oscillation. The speed is
//! capped at `max_wall_speed`. The particles behind the wall
//! are more compliant than its contacts alone (the pack is a spring in series with
//! them), so the true correction is smaller than `gain`: the stress approaches its
//! target from one side, without overshoot from the servo itself. A wall with no
//! contact moves in at the cap.
//!
//! The stage is done when, for `hold` consecutive checks `check_every` steps apart,
//! every controlled stress lies within `stress_tol` of its target and YADE's
//! unbalanced-force ratio is at most `unbalanced_tol`.

use crate::error::{check_range, Error, Result};
use crate::math::{Dim, Real, Spatial};
use crate::pipeline::world::{ForceBalance, WallLoad, World};
use crate::scene::stages::{MAX_STRESS, MAX_WALL_SPEED};

/// Steps of wall travel at full speed that the walls' near-lists reach beyond them (a
/// wider reach costs one distance test per extra particle near a wall, per step).
const WALL_STEPS: Real = 100.0;

/// One controlled wall and its target.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ServoTarget {
    /// Index of the wall in the world's wall list (id = -index - 1).
    pub wall: usize,
    /// Target normal stress on it (Pa; compressive positive; in 2D N/m).
    pub stress: Real,
}

/// The stage's settings as the engine runs them, SI units. The user's settings, their
/// defaults and their checks are [`crate::scene::ConsolidateSpec`]'s; `validate` here
/// guards the engine's own callers.
#[derive(Clone, Debug, PartialEq)]
pub struct ConsolidateConfig {
    /// The controlled walls and their target stresses (none: the walls stay, and the
    /// stage runs until the balance of forces is met).
    pub targets: Vec<ServoTarget>,
    /// Largest relative stress error |sigma - sigma*| / sigma* at equilibrium (-).
    pub stress_tol: Real,
    /// Largest unbalanced-force ratio at equilibrium (-).
    pub unbalanced_tol: Real,
    /// Consecutive checks that must meet both tolerances.
    pub hold: u32,
    /// Steps between two checks.
    pub check_every: u64,
    /// Most steps the stage may take before it gives up.
    pub max_steps: u64,
    /// Largest speed of a wall (m/s).
    pub max_wall_speed: Real,
    /// Servo gain, the fraction of the stress error corrected per step (-), in (0, 1].
    pub gain: Real,
    /// Local non-viscous damping during the stage (-), in [0, 1).
    pub local_damping: Real,
}

/// One check of the stage.
#[derive(Clone, Debug, PartialEq)]
pub struct ServoCheck {
    /// Steps taken in the stage so far.
    pub step: u64,
    /// Each controlled wall's stress (Pa), in the order of the targets.
    pub stress: Vec<Real>,
    /// Largest relative stress error over the controlled walls (-).
    pub stress_error: Real,
    /// The balance of forces (unbalanced ratio, PFC's maximum ratio).
    pub balance: ForceBalance,
}

/// What the stage did.
#[derive(Clone, Debug, PartialEq)]
pub struct ConsolidateReport {
    /// Whether both tolerances held for `hold` checks.
    pub converged: bool,
    /// Steps taken.
    pub steps: u64,
    /// Every check, in order.
    pub checks: Vec<ServoCheck>,
    /// Largest speed any wall reached (m/s).
    pub max_speed: Real,
}

impl ConsolidateConfig {
    /// Checks every field against the world it is for; errors name the field.
    pub fn validate<const D: usize>(&self, world: &World<D>) -> Result<()>
    where
        Dim<D>: Spatial<D>,
    {
        for t in &self.targets {
            if t.wall >= world.wall_count() {
                return Err(Error::invalid(
                    "targets",
                    t.wall,
                    &format!("a wall index below {}", world.wall_count()),
                ));
            }
            check_range("stress", t.stress, 0.0, false, MAX_STRESS, true)?;
        }
        check_range("stress_tol", self.stress_tol, 1e-9, true, 1.0, false)?;
        check_range(
            "unbalanced_tol",
            self.unbalanced_tol,
            1e-9,
            true,
            1.0,
            false,
        )?;
        if self.hold == 0 || self.hold > 1000 {
            return Err(Error::invalid(
                "hold",
                self.hold,
                "must lie in [1, 1000] checks",
            ));
        }
        if self.check_every == 0 || self.check_every > 1_000_000 {
            return Err(Error::invalid(
                "check_every",
                self.check_every,
                "must lie in [1, 1000000] steps",
            ));
        }
        if self.max_steps == 0 || self.max_steps > crate::scene::MAX_STEPS_PER_CALL {
            return Err(Error::invalid(
                "max_steps",
                self.max_steps,
                &format!(
                    "must lie in [1, {}] steps",
                    crate::scene::MAX_STEPS_PER_CALL
                ),
            ));
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
        check_range("local_damping", self.local_damping, 0.0, true, 1.0, false)?;
        Ok(())
    }
}

/// The speed along the outward normal (m/s) that the servo gives a wall with this
/// load and area, for a target stress (see the module's notes).
pub fn servo_rate(
    load: &WallLoad,
    area: Real,
    target: Real,
    gain: Real,
    max_speed: Real,
    dt: Real,
) -> Real {
    let error = target - load.force / area;
    let k = load.step_stiffness(dt);
    let inward = if k > 0.0 {
        gain * error * area / (k * dt)
    } else {
        max_speed
    };
    -inward.clamp(-max_speed, max_speed)
}

/// Runs the stage on `world` (which must have its lid, see [`World::add_lid`], if a
/// target needs a wall's area). With no target the walls stay where they are and the
/// stage runs until the balance of forces is met: a deposit settled to rest.
/// `poll` runs after each check; returning false stops the stage there (not
/// converged). The walls stop when the stage ends.
pub fn consolidate<const D: usize>(
    world: &mut World<D>,
    cfg: &ConsolidateConfig,
    poll: &mut dyn FnMut() -> bool,
) -> Result<ConsolidateReport>
where
    Dim<D>: Spatial<D>,
{
    cfg.validate(world)?;
    if world.is_empty() {
        return Err(Error::invalid(
            "pack",
            0,
            "at least one particle to consolidate",
        ));
    }
    // A wall moves at most max_wall_speed dt per step: the near-lists reach WALL_STEPS
    // steps of that further, so a rebuild for the walls' sake comes every WALL_STEPS
    // steps at most (at every 10, the rebuilds cost a fifth of the stage).
    world.set_wall_margin(WALL_STEPS * cfg.max_wall_speed * world.config().dt)?;
    world.set_local_damping(cfg.local_damping)?;
    world.refresh_forces()?;
    let n_walls = world.wall_count();
    let dt = world.config().dt;
    let mut report = ConsolidateReport {
        converged: false,
        steps: 0,
        checks: Vec::new(),
        max_speed: 0.0,
    };
    let mut held = 0u32;
    let result = loop {
        if report.steps >= cfg.max_steps {
            break Ok(());
        }
        let chunk = cfg.check_every.min(cfg.max_steps - report.steps);
        let mut max_speed = report.max_speed;
        let mut servo = |w: &mut World<D>| -> Result<bool> {
            let loads = w.wall_loads();
            let mut rates = vec![0.0; n_walls];
            for t in &cfg.targets {
                let area = w.wall_area(t.wall)?;
                let rate = servo_rate(
                    &loads[t.wall],
                    area,
                    t.stress,
                    cfg.gain,
                    cfg.max_wall_speed,
                    dt,
                );
                rates[t.wall] = rate;
                max_speed = max_speed.max(rate.abs());
            }
            w.move_walls(&rates, &loads)?;
            Ok(true)
        };
        if let Err(e) = world.step_n_with(chunk, &mut servo) {
            break Err(e);
        }
        report.max_speed = max_speed;
        report.steps += chunk;
        let check = measure(world, cfg, report.steps)?;
        let ok = check.stress_error <= cfg.stress_tol
            && check.balance.unbalanced() <= cfg.unbalanced_tol;
        report.checks.push(check);
        held = if ok { held + 1 } else { 0 };
        if held >= cfg.hold {
            report.converged = true;
            break Ok(());
        }
        if !poll() {
            break Ok(());
        }
    };
    world.stop_walls();
    world.set_local_damping(0.0)?;
    result.map(|_| report)
}

/// The stresses and the balance of the current state, `step` steps into the stage.
fn measure<const D: usize>(
    world: &World<D>,
    cfg: &ConsolidateConfig,
    step: u64,
) -> Result<ServoCheck>
where
    Dim<D>: Spatial<D>,
{
    let loads = world.wall_loads();
    let mut stress = Vec::with_capacity(cfg.targets.len());
    let mut worst: Real = 0.0;
    for t in &cfg.targets {
        let s = loads[t.wall].force / world.wall_area(t.wall)?;
        worst = worst.max((s - t.stress).abs() / t.stress);
        stress.push(s);
    }
    Ok(ServoCheck {
        step,
        stress,
        stress_error: worst,
        balance: world.force_balance(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Vector;
    use crate::scene::{Container, SimConfig};

    /// The paper's material, gravity off, a box of side `side` (or a periodic cell).
    fn world(side: Real, container: Container, friction: Real) -> World<3> {
        let mut c = SimConfig::<3>::paper();
        c.gravity = Vector::<3>::zeros();
        c.material.friction = friction;
        c.walls = Some((
            Vector::<3>::zeros(),
            Vector::<3>::new(side, side, f64::INFINITY),
        ));
        c.container = container;
        World::new(c).unwrap()
    }

    fn settings(wall: usize, stress: Real, vmax: Real) -> ConsolidateConfig {
        ConsolidateConfig {
            targets: vec![ServoTarget { wall, stress }],
            stress_tol: 1e-6,
            unbalanced_tol: 1e-7,
            hold: 5,
            check_every: 50,
            max_steps: 400_000,
            max_wall_speed: vmax,
            gain: 0.5,
            local_damping: 0.4,
        }
    }

    /// The overlap at which a Hertz contact of effective radius `r_eff` carries `f`:
    /// f = 4/3 E* sqrt(R*) d^(3/2).
    fn hertz_overlap(f: Real, r_eff: Real, e_star: Real) -> Real {
        (3.0 * f / (4.0 * e_star * r_eff.sqrt())).powf(2.0 / 3.0)
    }

    /// One sphere between the floor and the lid at force F = sigma A: both contacts
    /// carry F with the Hertz overlap of a sphere on a plane.
    #[test]
    fn one_sphere_under_the_lid_has_the_hertz_overlap() {
        let (r, side, sigma) = (0.05, 1.0, 100.0);
        let mut w = world(side, Container::Box, 0.2);
        w.add_particles(&[Vector::<3>::new(0.5, 0.5, r)], &[r], None, None)
            .unwrap();
        let lid = w.add_lid(2.0 * r + 1e-3).unwrap();
        let rep = consolidate(&mut w, &settings(lid, sigma, 0.05), &mut || true).unwrap();
        assert!(rep.converged, "{:?}", rep.checks.last());
        let e_star = w.config().material.e_star();
        let want = hertz_overlap(sigma * side * side, r, e_star);
        let c = w.contacts().unwrap();
        assert_eq!(c.j.len(), 2, "{:?}", c.j);
        for (&d, &f) in c.overlap.iter().zip(&c.force_normal) {
            assert!(
                (d - want).abs() < 1e-6 * want,
                "overlap {d} vs Hertz {want}"
            );
            assert!((f - sigma).abs() < 1e-5 * sigma, "force {f} vs {sigma}");
        }
    }

    /// A simple-cubic lattice of equal spheres (n x n columns of m, a hair apart
    /// sideways) under the lid at stress sigma: every column carries F = sigma (2r)^2,
    /// so every contact has the Hertz overlap for F, pairs (R* = r/2) and walls (R* =
    /// r) alike.
    #[test]
    fn simple_cubic_lattice_under_the_lid_has_the_hertz_overlaps() {
        let (r, n, m, sigma) = (0.05, 3usize, 4usize, 1e4);
        let cell = 2.0 * r * (1.0 + 1e-4);
        let side = cell * n as Real;
        let mut w = world(side, Container::Box, 0.2);
        let mut x = Vec::new();
        for i in 0..n {
            for j in 0..n {
                for k in 0..m {
                    x.push(Vector::<3>::new(
                        (i as Real + 0.5) * cell,
                        (j as Real + 0.5) * cell,
                        r + 2.0 * r * k as Real,
                    ));
                }
            }
        }
        let radii = vec![r; x.len()];
        w.add_particles(&x, &radii, None, None).unwrap();
        let lid = w.add_lid(2.0 * r * m as Real + 1e-4).unwrap();
        let rep = consolidate(&mut w, &settings(lid, sigma, 0.05), &mut || true).unwrap();
        assert!(rep.converged, "{:?}", rep.checks.last());
        let e_star = w.config().material.e_star();
        let f = sigma * cell * cell;
        let (pair, wall) = (
            hertz_overlap(f, 0.5 * r, e_star),
            hertz_overlap(f, r, e_star),
        );
        let c = w.contacts().unwrap();
        // m - 1 pairs and 2 walls per column, nothing sideways
        assert_eq!(c.j.len(), n * n * (m + 1));
        for (&j, &d) in c.j.iter().zip(&c.overlap) {
            let want = if j >= 0 { pair } else { wall };
            assert!(
                (d - want).abs() < 1e-6 * want,
                "contact with {j}: {d} vs {want}"
            );
        }
    }

    /// The servo's speed: in at the cap without contact, in proportion to the error
    /// with contacts, out when the stress is too high, and never beyond the cap.
    #[test]
    fn servo_rate_follows_the_error_within_the_cap() {
        let free = WallLoad::default();
        assert_eq!(servo_rate(&free, 1.0, 1e3, 0.5, 0.1, 1e-4), -0.1);
        let load = WallLoad {
            force: 900.0,
            stiffness: 1e7,
            viscosity: 0.0,
            contacts: 3,
        };
        // error 100 Pa over 1 m^2: half of it is 50 N, 5e-6 m at 1e7 N/m, in 1e-4 s
        let v = servo_rate(&load, 1.0, 1e3, 0.5, 1.0, 1e-4);
        assert!((v + 0.05).abs() < 1e-12, "{v}");
        let over = WallLoad {
            force: 2000.0,
            ..load
        };
        assert!(servo_rate(&over, 1.0, 1e3, 0.5, 1.0, 1e-4) > 0.0);
        assert_eq!(servo_rate(&over, 1.0, 1e3, 0.5, 0.01, 1e-4), 0.01);
    }

    /// Bad settings are refused by name.
    #[test]
    fn bad_settings_name_their_field() {
        let mut w = world(1.0, Container::Box, 0.2);
        w.add_particles(&[Vector::<3>::new(0.5, 0.5, 0.05)], &[0.05], None, None)
            .unwrap();
        let lid = w.add_lid(0.2).unwrap();
        let base = settings(lid, 1e3, 0.1);
        let cases: Vec<(&str, ConsolidateConfig)> = vec![
            (
                "stress",
                ConsolidateConfig {
                    targets: vec![ServoTarget {
                        wall: lid,
                        stress: 0.0,
                    }],
                    ..base.clone()
                },
            ),
            (
                "stress",
                ConsolidateConfig {
                    targets: vec![ServoTarget {
                        wall: lid,
                        stress: f64::NAN,
                    }],
                    ..base.clone()
                },
            ),
            (
                "targets",
                ConsolidateConfig {
                    targets: vec![ServoTarget {
                        wall: 9,
                        stress: 1.0,
                    }],
                    ..base.clone()
                },
            ),
            (
                "stress_tol",
                ConsolidateConfig {
                    stress_tol: 0.0,
                    ..base.clone()
                },
            ),
            (
                "stress_tol",
                ConsolidateConfig {
                    stress_tol: 1e-12,
                    ..base.clone()
                },
            ),
            (
                "unbalanced_tol",
                ConsolidateConfig {
                    unbalanced_tol: -1.0,
                    ..base.clone()
                },
            ),
            (
                "hold",
                ConsolidateConfig {
                    hold: 0,
                    ..base.clone()
                },
            ),
            (
                "max_steps",
                ConsolidateConfig {
                    max_steps: 0,
                    ..base.clone()
                },
            ),
            (
                "max_wall_speed",
                ConsolidateConfig {
                    max_wall_speed: 0.0,
                    ..base.clone()
                },
            ),
            (
                "gain",
                ConsolidateConfig {
                    gain: 1.5,
                    ..base.clone()
                },
            ),
            (
                "local_damping",
                ConsolidateConfig {
                    local_damping: 1.0,
                    ..base.clone()
                },
            ),
        ];
        for (name, cfg) in cases {
            match consolidate(&mut w, &cfg, &mut || true) {
                Err(Error::InvalidParameter { name: got, .. }) => assert_eq!(got, name),
                other => panic!("{name}: {other:?}"),
            }
        }
        let mut empty = world(1.0, Container::Periodic, 0.2);
        let lid = empty.add_lid(0.2).unwrap();
        assert!(consolidate(&mut empty, &settings(lid, 1e3, 0.1), &mut || true).is_err());
    }
}
