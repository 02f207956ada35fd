//! The layer loop of the paper's Algorithm 1: place a loose layer by random sequential
//! addition, jam it with a DEM run under gravity, measure the height, repeat until the
//! desired height.

use crate::error::{check_range, Error, Result};
use crate::geometry::morton_order;
use crate::math::{Dim, Real, Spatial, Vector};
pub use crate::pipeline::rsa::RadiusLaw;
use crate::pipeline::rsa::{place_layer, LayerSpec};
use crate::pipeline::world::{FreezeConfig, SimConfig, World};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use std::time::Instant;

/// Time (s) a pack built with freezing relaxes after its last layer, all particles
/// thawed (see [`PackConfig::freeze_depth`]).
pub const FREEZE_RELAX: Real = 0.1;

/// A packing scene. SI units.
#[derive(Clone, Debug, PartialEq)]
pub struct PackConfig<const D: usize> {
    /// Engine settings (material, dt, gravity, drag, rotations). `walls` is set from
    /// `base` by [`Packer::new`].
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
    /// `settle_time`. None (default): the paper's fixed `settle_time`.
    pub adaptive_settle: Option<Real>,
    /// Freeze settled particles whose top lies more than this depth (m) below the pack
    /// height before the current layer. After the last layer every particle thaws and
    /// the pack relaxes for [`FREEZE_RELAX`] (at most `settle_time`), so that the frozen
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
    /// Checks every field; the error names the field and its allowed range.
    pub fn validate(&self) -> Result<()> {
        self.radii.validate()?;
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
        if self.max_attempts == 0 {
            return Err(Error::invalid("max_attempts", 0, "must be >= 1"));
        }
        if self.max_layers == 0 {
            return Err(Error::invalid("max_layers", 0, "must be >= 1"));
        }
        if let Some(tol) = self.adaptive_settle {
            check_range("settle_tol", tol, 0.0, false, f64::INFINITY, false)?;
        }
        if let Some(depth) = self.freeze_depth {
            check_range("freeze_depth", depth, 0.0, true, f64::INFINITY, false)?;
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
        let mut sim = self.sim.clone();
        sim.walls = None;
        sim.validate()?;
        let crit = sim.material.rayleigh_time_step(self.radii.r_min());
        if sim.dt > crit {
            return Err(Error::UnstableTimeStep {
                dt: sim.dt,
                critical: crit,
                r_min: self.radii.r_min(),
            });
        }
        Ok(())
    }
}

/// What one layer did.
#[derive(Clone, Debug, PartialEq)]
pub struct LayerReport {
    /// Layer index (0-based).
    pub layer: usize,
    /// Particles placed in this layer.
    pub added: usize,
    /// Particles in the pack after it.
    pub total: usize,
    /// Solid fraction of the RSA slab (-).
    pub phi_rsa: Real,
    /// Pack height max(z + r) after settling (m).
    pub height: Real,
    /// DEM steps run for this layer.
    pub steps: u64,
    /// Kinetic energy at the end of the settle (J).
    pub kinetic_energy: Real,
    /// Wall-clock seconds for the layer.
    pub wall_seconds: Real,
    /// Particles frozen at the end of the layer.
    pub frozen: usize,
}

/// Builds a pack layer by layer.
pub struct Packer<const D: usize>
where
    Dim<D>: Spatial<D>,
{
    cfg: PackConfig<D>,
    world: World<D>,
    rng: ChaCha8Rng,
    height: Real,
    layer_of: Vec<u32>,
    reports: Vec<LayerReport>,
}

impl<const D: usize> Packer<D>
where
    Dim<D>: Spatial<D>,
{
    /// Validates the scene and prepares an empty box.
    pub fn new(cfg: PackConfig<D>) -> Result<Self> {
        cfg.validate()?;
        let v = <Dim<D> as Spatial<D>>::VERTICAL;
        let mut sim = cfg.sim.clone();
        let mut hi = cfg.base;
        hi[v] = Real::INFINITY;
        sim.walls = Some((Vector::<D>::zeros(), hi));
        let world = World::new(sim)?;
        let mut rng = ChaCha8Rng::seed_from_u64(cfg.seed);
        rng.set_stream(cfg.stream);
        Ok(Packer {
            cfg,
            world,
            rng,
            height: 0.0,
            layer_of: Vec::new(),
            reports: Vec::new(),
        })
    }

    /// True once the pack height has reached the desired height.
    pub fn done(&self) -> bool {
        self.height >= self.cfg.height
    }

    /// Current pack height max(z + r) (m).
    pub fn height(&self) -> Real {
        self.height
    }

    /// The world (state, contacts).
    pub fn world(&self) -> &World<D> {
        &self.world
    }

    /// Mutable world (for contacts()).
    pub fn world_mut(&mut self) -> &mut World<D> {
        &mut self.world
    }

    /// Layer index of each particle.
    pub fn layers(&self) -> &[u32] {
        &self.layer_of
    }

    /// Reports of the layers so far.
    pub fn reports(&self) -> &[LayerReport] {
        &self.reports
    }

    /// Places and settles one layer.
    pub fn next_layer(&mut self) -> Result<LayerReport> {
        let start = Instant::now();
        let layer = self.reports.len();
        if layer >= self.cfg.max_layers {
            return Err(Error::invalid(
                "max_layers",
                self.cfg.max_layers,
                &format!(
                    "reached before the pack grew to height = {} m (now {:.4} m)",
                    self.cfg.height, self.height
                ),
            ));
        }
        let v = <Dim<D> as Spatial<D>>::VERTICAL;
        let mut hi = self.cfg.base;
        hi[v] = Real::INFINITY;
        let spec = LayerSpec {
            lo: Vector::<D>::zeros(),
            hi,
            vertical: v,
            height: self.height,
            h_layer: self.cfg.h_layer,
            phi_layer: self.cfg.phi_layer,
            radii: self.cfg.radii,
            max_attempts: self.cfg.max_attempts,
            existing: (self.world.positions(), self.world.radii()),
            layer,
        };
        let (x, r) = place_layer(&spec, &mut self.rng)?;
        // Store the layer in Morton order: neighbours in space become neighbours in
        // memory, which keeps the pair loop in cache. Particle ids follow this order.
        let order = morton_order(&x, 2.0 * self.cfg.radii.r_max());
        let x: Vec<Vector<D>> = order.iter().map(|&k| x[k]).collect();
        let r: Vec<Real> = order.iter().map(|&k| r[k]).collect();
        let added = x.len();
        let vol: Real = r
            .iter()
            .map(|&r| crate::math::particle_volume::<D>(r))
            .sum();
        let mut slab = self.cfg.h_layer;
        for k in (0..D).filter(|&k| k != v) {
            slab *= self.cfg.base[k];
        }
        self.world.add_particles(&x, &r, None, None)?;
        self.layer_of
            .extend(std::iter::repeat_n(layer as u32, added));
        if let Some(depth) = self.cfg.freeze_depth {
            self.world.set_freeze(Some(FreezeConfig {
                below: self.height - depth,
                speed: self.cfg.freeze_speed,
                force_ratio: self.cfg.freeze_force,
                interval: 100,
            }))?;
        }
        let mut steps = self.settle()?;
        self.height = self.measure_height();
        let dt = self.cfg.sim.dt;
        let full = (self.cfg.settle_time / dt).round() as u64;
        if self.done() && steps < full {
            // An adaptive settle may stop a layer while its top particles still roll:
            // harmless below, where the next layer lands on them anyway, but the last
            // layer is the pack's free surface, so it gets the whole settle_time.
            self.world.step_n(full - steps)?;
            steps = full;
            self.height = self.measure_height();
        }
        if self.done() && self.world.n_frozen() > 0 {
            // Frozen contacts kept the forces they had when they froze, before the
            // layers above added their weight: thaw everything and let the load spread.
            self.world.set_freeze(None)?;
            let relax = ((FREEZE_RELAX.min(self.cfg.settle_time)) / dt).round() as u64;
            self.world.step_n(relax)?;
            steps += relax;
            self.height = self.measure_height();
        }
        let rep = LayerReport {
            layer,
            added,
            total: self.world.len(),
            phi_rsa: vol / slab,
            height: self.height,
            steps,
            kinetic_energy: self.world.kinetic_energy(),
            wall_seconds: start.elapsed().as_secs_f64(),
            frozen: self.world.n_frozen(),
        };
        self.reports.push(rep.clone());
        Ok(rep)
    }

    /// Pack height max(z + r) (m).
    fn measure_height(&self) -> Real {
        let v = <Dim<D> as Spatial<D>>::VERTICAL;
        self.world
            .positions()
            .iter()
            .zip(self.world.radii())
            .map(|(p, r)| p[v] + r)
            .fold(0.0, Real::max)
    }

    /// Runs the jamming stage of one layer; returns the steps taken.
    fn settle(&mut self) -> Result<u64> {
        let dt = self.cfg.sim.dt;
        let max_steps = (self.cfg.settle_time / dt).round() as u64;
        let Some(tol) = self.cfg.adaptive_settle else {
            self.world.step_n(max_steps)?;
            return Ok(max_steps);
        };
        // Energy scale m g r of a mean particle, and the time the new layer needs to fall
        // through its slab: the run never stops before that.
        let g = self.cfg.sim.gravity.norm();
        let r_mean = self.cfg.radii.r_mean();
        let m_mean = self.cfg.sim.material.density * crate::math::particle_volume::<3>(r_mean);
        let scale = m_mean * g.max(1e-12) * r_mean;
        let t_fall = if g > 0.0 {
            (2.0 * self.cfg.h_layer / g).sqrt()
        } else {
            0.0
        };
        let chunk = ((0.01 / dt).round() as u64).max(1);
        let mut done = 0u64;
        while done < max_steps {
            let n = chunk.min(max_steps - done);
            self.world.step_n(n)?;
            done += n;
            let moving = (self.world.len() - self.world.n_frozen()).max(1);
            let e = self.world.kinetic_energy() / moving as Real;
            if done as Real * dt >= t_fall && e < tol * scale {
                break;
            }
        }
        Ok(done)
    }

    /// Runs the whole loop, calling `progress` after every layer.
    pub fn run(&mut self, mut progress: impl FnMut(&LayerReport)) -> Result<()> {
        while !self.done() {
            let rep = self.next_layer()?;
            progress(&rep);
        }
        Ok(())
    }
}
