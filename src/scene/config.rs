//! The engine's scene: [`PackConfig`], everything the layer loop runs, with its
//! checks of every field.

use super::RadiusLaw;
use super::{Container, SimConfig};
use crate::error::{check_range, fmt_g, Error, Result};
use crate::math::{Dim, Real, Spatial, Vector};

/// Most DEM steps of one layer's jamming run (settle_time / dt): 1e4 in the paper;
/// beyond this bound a scene is refused before any work starts.
pub const MAX_STEPS_PER_LAYER: Real = 1e8;
/// Most consecutive failed placements of random sequential addition (`max_attempts`):
/// a saturated layer tries this many times before it gives up.
pub const MAX_ATTEMPTS: u64 = 1_000_000_000;
/// Most layers a pack may take (`max_layers`): a pack that never grows runs this many
/// jamming runs before it gives up.
pub const MAX_LAYERS: usize = 1_000_000;
/// Most particles a scene may need, by [`PackConfig::estimated_particles`].
pub const MAX_PARTICLES: Real = 5e8;

/// A packing scene. SI units.
#[derive(Clone, Debug, PartialEq)]
pub struct PackConfig<const D: usize> {
    /// Engine settings (material, dt, gravity, drag, rotations). `walls` is set from
    /// `base` by the layer loop's `Packer::new`.
    pub sim: SimConfig<D>,
    /// Box lengths along the horizontal axes (m); the vertical entry is ignored.
    /// The box spans [0, base_k] on each horizontal axis, the floor is at 0.
    pub base: Vector<D>,
    /// Desired height H_d (m): layers are added while the pack height is below it.
    pub height: Real,
    /// Radius law.
    pub radii: RadiusLaw,
    /// Layer slab thickness h_layer (m).
    pub h_layer: Real,
    /// Target solid fraction of each RSA layer phi_layer (-).
    pub phi_layer: Real,
    /// DEM time per layer (s). Default 1.0.
    pub settle_time: Real,
    /// Random seed.
    pub seed: u64,
    /// Random stream (ensembles give each pack its own stream of the same seed).
    pub stream: u64,
    /// Most consecutive failed RSA placements before declaring saturation.
    pub max_attempts: u64,
    /// Most layers before giving up (guards against a pack that never grows).
    pub max_layers: usize,
    /// End a layer's jamming run early once its kinetic energy per moving particle has
    /// fallen below `tol` times m g r (mean mass and radius); `settle_time` is then the
    /// upper bound. The last layer (the free surface) always runs the whole
    /// `settle_time`: a layer the adaptive stop leaves at or above the target height runs
    /// on, and ends there only if its height falls below the target on the way (it was
    /// not the last; the next layer lands on it). None (default): the paper's fixed
    /// `settle_time`.
    pub settle_tol: Option<Real>,
    /// Time step (s) for the rest of a layer's jamming run once the new layer has had
    /// time to fall through its slab (sqrt(2 h_layer / g) after it is placed), and for
    /// the last layer's remainder and the final relax. The landing collisions, fast
    /// (sqrt(2 g h_layer)) and short, keep `sim.dt`; the slow rolling and creep after
    /// them tolerate a coarser step. At most the Rayleigh step of r_min. None (default):
    /// `sim.dt` throughout, as the paper.
    pub settle_dt: Option<Real>,
    /// Freeze settled particles whose top lies more than this depth (m) below the pack
    /// height before the current layer. After the last layer every particle thaws and
    /// the pack relaxes for the layer loop's `FREEZE_RELAX` (at most `settle_time`), so that the frozen
    /// contacts take up the weight added above them. None (default): never freeze.
    pub freeze_depth: Option<Real>,
    /// Speed (m/s) under which a buried particle may freeze. Default 1e-3.
    pub freeze_speed: Real,
    /// Net force over weight under which a particle may freeze, and above which a
    /// frozen one thaws. Default 0.1.
    pub freeze_force: Real,
}

impl<const D: usize> PackConfig<D>
where
    Dim<D>: Spatial<D>,
{
    /// The container's horizontal cross-section (m^2 in 3D, m in 2D): the base, or
    /// pi R^2 for a cylinder.
    pub fn cross_section(&self) -> Real {
        match self.sim.container {
            Container::Cylinder(radius) => std::f64::consts::PI * radius * radius,
            _ => {
                let v = <Dim<D> as Spatial<D>>::VERTICAL;
                (0..D).filter(|&k| k != v).map(|k| self.base[k]).product()
            }
        }
    }

    /// Rough particle count: layers of phi_layer filling about 1.5 H_d / h_layer slabs
    /// of the cross-section, particles of the law's mean radius by number.
    pub fn estimated_particles(&self) -> Real {
        let layers = (self.height / self.h_layer).max(1.0) * 1.5;
        let volume = crate::math::particle_volume::<D>(self.radii.number_moments().0);
        if volume == 0.0 {
            // the radius underflows: too many particles by any measure
            return Real::INFINITY;
        }
        layers * self.phi_layer * self.cross_section() * self.h_layer / volume
    }

    /// The container's corners: 0 and (base, infinity), the floor at 0, the top open.
    pub fn corners(&self) -> (Vector<D>, Vector<D>) {
        let mut hi = self.base;
        hi[<Dim<D> as Spatial<D>>::VERTICAL] = Real::INFINITY;
        (Vector::<D>::zeros(), hi)
    }

    /// Checks every field; the error names the field and its allowed range.
    pub fn validate(&self) -> Result<()> {
        // the step first: the checks below divide by it
        check_range("dt", self.sim.dt, 0.0, false, Real::INFINITY, false)?;
        self.radii.validate()?;
        let r_max = self.radii.r_max();
        match self.sim.container {
            Container::Cylinder(radius) if radius < 2.0 * r_max || radius.is_nan() => {
                return Err(Error::invalid(
                    "cylinder_radius",
                    radius,
                    &format!("must be at least 2 r_max = {} (m)", 2.0 * r_max),
                ));
            }
            Container::Periodic => {
                // one nearest image per listed pair: a period above twice the largest
                // cutoff, 2 (r_max + half skin) <= r_max (2 + skin_ratio)
                let least = 4.0 * r_max * (1.0 + self.sim.skin_ratio);
                let v = <Dim<D> as Spatial<D>>::VERTICAL;
                for k in (0..D).filter(|&k| k != v) {
                    if self.base[k] < least || self.base[k].is_nan() {
                        return Err(Error::invalid(
                            "base",
                            self.base[k],
                            &format!(
                                "a periodic cell needs every period >= 4 r_max (1 + skin_ratio) = {least} (m)"
                            ),
                        ));
                    }
                }
            }
            _ => {}
        }
        let v = <Dim<D> as Spatial<D>>::VERTICAL;
        for k in (0..D).filter(|&k| k != v) {
            check_range("base", self.base[k], 0.0, false, f64::INFINITY, false)?;
            if self.base[k] < 2.0 * self.radii.r_max() {
                return Err(Error::invalid(
                    "base",
                    self.base[k],
                    &format!(
                        "must be at least one particle diameter 2 r_max = {} (m)",
                        2.0 * self.radii.r_max()
                    ),
                ));
            }
        }
        check_range("height", self.height, 0.0, false, f64::INFINITY, false)?;
        check_range("h_layer", self.h_layer, 0.0, false, f64::INFINITY, false)?;
        check_range("phi_layer", self.phi_layer, 0.0, false, 1.0, false)?;
        check_range(
            "settle_time",
            self.settle_time,
            0.0,
            true,
            f64::INFINITY,
            false,
        )?;
        if !(1..=MAX_ATTEMPTS).contains(&self.max_attempts) {
            return Err(Error::invalid(
                "max_attempts",
                self.max_attempts,
                &format!("must lie in [1, {MAX_ATTEMPTS}]"),
            ));
        }
        if !(1..=MAX_LAYERS).contains(&self.max_layers) {
            return Err(Error::invalid(
                "max_layers",
                self.max_layers,
                &format!("must lie in [1, {MAX_LAYERS}]"),
            ));
        }
        if let Some(tol) = self.settle_tol {
            check_range("settle_tol", tol, 0.0, false, f64::INFINITY, false)?;
        }
        if let Some(depth) = self.freeze_depth {
            check_range("freeze_depth", depth, 0.0, true, f64::INFINITY, false)?;
        }
        if let Some(dt) = self.settle_dt {
            let crit = self.sim.material.critical_time_step(self.radii.r_min());
            if !(dt > 0.0 && dt <= crit) {
                return Err(Error::invalid(
                    "settle_dt",
                    format!("{} s", fmt_g(dt)),
                    &format!(
                        "must lie in (0, {crit}] (s; at most the Rayleigh step {} s for \
                         r_min = {} m)",
                        fmt_g(crit),
                        fmt_g(self.radii.r_min())
                    ),
                ));
            }
        }
        check_range(
            "freeze_speed",
            self.freeze_speed,
            0.0,
            true,
            f64::INFINITY,
            false,
        )?;
        check_range(
            "freeze_force",
            self.freeze_force,
            0.0,
            true,
            f64::INFINITY,
            false,
        )?;
        // the walls are the box that `base` spans (set by Packer::new)
        let mut sim = self.sim.clone();
        sim.walls = Some(self.corners());
        sim.validate()?;
        let crit = sim.material.critical_time_step(self.radii.r_min());
        if sim.dt > crit {
            return Err(Error::UnstableTimeStep {
                dt: sim.dt,
                critical: crit,
                r_min: self.radii.r_min(),
            });
        }
        // A scene whose layers alone would exceed memory is refused up front (NaN, from
        // inf / inf, too) ...
        let estimated = self.estimated_particles();
        if estimated.is_nan() || estimated > MAX_PARTICLES {
            return Err(Error::invalid(
                "scene",
                "",
                &format!(
                    "about {} particles would be needed (limit {}); shrink base/height or \
                     grow the radii",
                    fmt_g(estimated),
                    fmt_g(MAX_PARTICLES)
                ),
            ));
        }
        // ... and then one whose layers take too many steps: both grow without bound
        // as the radii and dt shrink, and the count is the more basic of the two.
        if self.settle_time / self.sim.dt > MAX_STEPS_PER_LAYER {
            return Err(Error::invalid(
                "settle_time",
                format!("{} s", fmt_g(self.settle_time)),
                &format!(
                    "with dt = {} s that is {} steps per layer; at most {} \
                     (settle_time <= {} s)",
                    fmt_g(self.sim.dt),
                    fmt_g(self.settle_time / self.sim.dt),
                    fmt_g(MAX_STEPS_PER_LAYER),
                    fmt_g(MAX_STEPS_PER_LAYER * self.sim.dt)
                ),
            ));
        }
        Ok(())
    }
}
