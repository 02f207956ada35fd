//! The layer loop of the paper's Algorithm 1: place a loose layer by random sequential
//! addition, jam it with a DEM run under gravity, measure the height, repeat until the
//! desired height.

use crate::error::{Error, Result};
use crate::geometry::{morton_order, row_major_order};
use crate::math::{Dim, Real, Spatial, Vector};
use crate::pipeline::rsa::{place_layer_polled, LayerSpec};
use crate::pipeline::world::{Contacts, FinishedState, FreezeConfig, World, FREEZE_INTERVAL};
pub use crate::scene::{PackConfig, RadiusLaw, MAX_ATTEMPTS, MAX_LAYERS, MAX_STEPS_PER_LAYER};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use std::time::{Duration, Instant};

/// Wall time between two calls of the poll of [`Packer::next_layer_polled`].
const POLL_EVERY: Duration = Duration::from_millis(100);

/// Time (s) a pack built with freezing relaxes after its last layer, all particles
/// thawed (see [`PackConfig::freeze_depth`]).
pub const FREEZE_RELAX: Real = 0.1;

/// Particles in a layer from which the layer loop re-sorts the whole pack into one order
/// after placing it (`World::reorder`), instead of appending the layer in its own
/// Morton order. The step then reads a sphere's contacts with the layer below near its
/// own instead of a layer's state away. Medians of three rounds, ns a particle-step on
/// two threads, one Morton order against bands of a layer (`studies/global_order/`):
/// 74.1 against 97.0 at 572 928 spheres in bands of 52 000, 65.9 against 75.6 at 223 800
/// (20 000), 44.9 against 47.4 at 80 568 (7 300), within the rounds' spread either way
/// below that. 4 096 is where a layer's state (about 600 bytes a sphere) outgrows 2 MiB
/// of L2. The order is [`row_major_order`], which took a further 12-21 % off the
/// settled step from 80 000 to a million spheres (`studies/row_order/`). Smaller layers
/// keep their order, and their packs their bits.
pub const RESORT_MIN_LAYER: usize = 4096;

/// Simulated time (s) between two checks of an adaptive settle: of the layer's kinetic
/// energy, and of the height while the last layer finishes its settle_time.
const SETTLE_CHECK: Real = 0.01;

/// Steps of `dt` (s) between two checks of an adaptive settle ([`SETTLE_CHECK`]).
fn settle_chunk(dt: Real) -> u64 {
    ((SETTLE_CHECK / dt).round() as u64).max(1)
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

/// What [`Packer::finish`] gives: the pack's arrays and its contacts in force.
#[derive(Clone, Debug)]
pub struct FinishedPack<const D: usize>
where
    Dim<D>: Spatial<D>,
{
    /// Positions (wrapped into the periodic cell), velocities, spins, radii, time.
    pub state: FinishedState<D>,
    /// Layer index of each particle.
    pub layer: Vec<u32>,
    /// The contacts in force, as [`World::contacts`] gives them.
    pub contacts: Contacts<D>,
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
    /// A layer was stopped midway by the poll: the state is no pack any more.
    stopped: bool,
}

impl<const D: usize> Packer<D>
where
    Dim<D>: Spatial<D>,
{
    /// Validates the scene and prepares an empty box.
    pub fn new(cfg: PackConfig<D>) -> Result<Self> {
        cfg.validate()?;
        let mut sim = cfg.sim.clone();
        sim.walls = Some(cfg.corners());
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
            stopped: false,
        })
    }

    /// The scene.
    pub fn config(&self) -> &PackConfig<D> {
        &self.cfg
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

    /// The finished pack: its contacts in force and its particle arrays, with each
    /// particle's layer, the packer spent to make them (see [`World::into_finished`]:
    /// the engine's state is freed as the contact table is written).
    pub fn finish(self) -> Result<FinishedPack<D>> {
        let (contacts, state) = self.world.into_finished()?;
        Ok(FinishedPack {
            state,
            layer: self.layer_of,
            contacts,
        })
    }

    /// Places and settles one layer.
    pub fn next_layer(&mut self) -> Result<LayerReport> {
        Ok(self
            .next_layer_polled(&mut || true)?
            .expect("a poll that never stops"))
    }

    /// Places and settles one layer like [`Packer::next_layer`], calling `poll` about
    /// every 0.1 s of wall time during the DEM run; when it returns false the layer
    /// stops midway and None is returned. The packer then refuses further layers: its
    /// last layer is neither settled nor reported.
    pub fn next_layer_polled(
        &mut self,
        poll: &mut dyn FnMut() -> bool,
    ) -> Result<Option<LayerReport>> {
        if self.stopped {
            return Err(Error::invalid(
                "packer",
                "stopped",
                "a layer was interrupted midway; start a new pack",
            ));
        }
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
        // in a periodic cell the placement needs the positions wrapped into the cell
        let existing = self.world.positions_in_cell();
        let spec = layer_spec(
            &self.cfg,
            (&existing, self.world.radii()),
            self.height,
            layer,
        );
        // The placement polls on every few thousand failed attempts; Python is asked
        // only every POLL_EVERY of wall time.
        let mut last = Instant::now();
        let mut gated = || {
            if last.elapsed() < POLL_EVERY {
                return true;
            }
            last = Instant::now();
            poll()
        };
        let Some((x, r)) = place_layer_polled(&spec, &mut self.rng, &mut gated)? else {
            return self.stop();
        };
        // Store the layer in Morton order: neighbours in space become neighbours in
        // memory, which keeps the pair loop in cache. Particle ids follow this order
        // (and, from RESORT_MIN_LAYER particles a layer, the whole pack's below).
        let (x, r) = in_morton_order(x, r, self.cfg.radii.r_max());
        let added = x.len();
        let vol: Real = r
            .iter()
            .map(|&r| crate::math::particle_volume::<D>(r))
            .sum();
        let slab = self.cfg.h_layer * self.cfg.cross_section();
        self.world.add_particles(&x, &r, None, None)?;
        self.layer_of
            .extend(std::iter::repeat_n(layer as u32, added));
        if added >= RESORT_MIN_LAYER {
            // Stored layer by layer, a sphere's contacts with the layer below sit a whole
            // layer's state away from its own, beyond the caches once a layer is this
            // large: one order over the whole pack keeps them near.
            let order = row_major_order(
                &self.world.positions_in_cell(),
                2.0 * self.cfg.radii.r_max(),
            );
            self.world.reorder(&order)?;
            self.layer_of = order.iter().map(|&k| self.layer_of[k]).collect();
        }
        if let Some(depth) = self.cfg.freeze_depth {
            self.world.set_freeze(Some(FreezeConfig {
                below: self.height - depth,
                speed: self.cfg.freeze_speed,
                force_ratio: self.cfg.freeze_force,
                interval: FREEZE_INTERVAL,
            }))?;
        }
        // Each layer lands at the scene's dt (the last one may have ended at settle_dt).
        self.world.set_dt(self.cfg.sim.dt)?;
        let Some((mut steps, t_layer)) = self.settle(poll)? else {
            return self.stop();
        };
        self.height = self.measure_height();
        let dt = self.world.config().dt;
        // The steps left of settle_time at the step the settle ended with; in whole steps
        // when that is the scene's dt, so that the paper's settings never round.
        let rest = if dt == self.cfg.sim.dt {
            ((self.cfg.settle_time / dt).round() as u64).saturating_sub(steps)
        } else {
            ((self.cfg.settle_time - t_layer) / dt).round().max(0.0) as u64
        };
        if self.done() && rest > 0 {
            // An adaptive settle may stop a layer while its top particles still roll:
            // harmless below, where the next layer lands on them anyway, but the last
            // layer is the pack's free surface, so it gets the whole settle_time. The
            // height the settle saw may be a sphere still in flight: once the height
            // falls below the target the layer is not the last after all, and the rest
            // ends there, as every layer below the last ends at its adaptive stop.
            let below_target = |p: &mut Self| {
                p.height = p.measure_height();
                !p.done()
            };
            let Some(ran) = self.step_until(rest, poll, below_target)? else {
                return self.stop();
            };
            steps += ran;
        }
        if self.done() && self.world.n_frozen() > 0 {
            // Frozen contacts kept the forces they had when they froze, before the
            // layers above added their weight: thaw everything and let the load spread.
            self.world.set_freeze(None)?;
            let relax = ((FREEZE_RELAX.min(self.cfg.settle_time)) / dt).round() as u64;
            if !self.world.step_n_polled(relax, POLL_EVERY, poll)? {
                return self.stop();
            }
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
        Ok(Some(rep))
    }

    /// The flat top: removes every particle whose top (z + r) lies above `h` (m), then
    /// relaxes the rest as the final relax does (every particle thawed, for
    /// [`FREEZE_RELAX`], at most `settle_time`, at the current step), calling `poll` as
    /// [`Packer::next_layer_polled`] does. Returns the particles removed and the steps
    /// run, or None when `poll` stopped the relax. Refused before the last layer.
    pub fn trim_polled(
        &mut self,
        h: Real,
        poll: &mut dyn FnMut() -> bool,
    ) -> Result<Option<(usize, u64)>> {
        if self.stopped || !self.done() {
            return Err(Error::invalid(
                "trim",
                h,
                "applies to a finished pack (after the last layer)",
            ));
        }
        if !(h.is_finite() && h > 0.0) {
            return Err(Error::invalid("trim", h, "must be a height > 0 (m)"));
        }
        let v = <Dim<D> as Spatial<D>>::VERTICAL;
        let keep: Vec<bool> = self
            .world
            .positions()
            .iter()
            .zip(self.world.radii())
            .map(|(x, r)| x[v] + r <= h)
            .collect();
        let removed = keep.iter().filter(|&&k| !k).count();
        self.world.remove_particles(&keep)?;
        let mut k = 0;
        self.layer_of.retain(|_| {
            k += 1;
            keep[k - 1]
        });
        let dt = self.world.config().dt;
        let relax = ((FREEZE_RELAX.min(self.cfg.settle_time)) / dt).round() as u64;
        if !self.world.step_n_polled(relax, POLL_EVERY, poll)? {
            self.stopped = true;
            return Ok(None);
        }
        self.height = self.measure_height();
        Ok(Some((removed, relax)))
    }

    fn stop(&mut self) -> Result<Option<LayerReport>> {
        self.stopped = true;
        Ok(None)
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

    /// Runs up to `total` steps at the world's dt in pieces of [`SETTLE_CHECK`] of
    /// simulated time, ending after the first piece for which `stop` answers true.
    /// Returns the steps run, or None when `poll` stopped them.
    fn step_until(
        &mut self,
        total: u64,
        poll: &mut dyn FnMut() -> bool,
        mut stop: impl FnMut(&mut Self) -> bool,
    ) -> Result<Option<u64>> {
        let chunk = settle_chunk(self.world.config().dt);
        let mut ran = 0u64;
        while ran < total {
            let n = chunk.min(total - ran);
            if !self.world.step_n_polled(n, POLL_EVERY, poll)? {
                return Ok(None);
            }
            ran += n;
            if stop(self) {
                break;
            }
        }
        Ok(Some(ran))
    }

    /// Runs the jamming stage of one layer: at `sim.dt` until the new layer has had time
    /// to fall through its slab, then at `settle_dt` (when set) for the rest of
    /// `settle_time`, ending early once the layer is quiet (`settle_tol`). Returns
    /// the steps taken and the simulated time (s), or None when `poll` stopped it.
    fn settle(&mut self, poll: &mut dyn FnMut() -> bool) -> Result<Option<(u64, Real)>> {
        let dt = self.cfg.sim.dt;
        let total = (self.cfg.settle_time / dt).round() as u64;
        let tol = self.cfg.settle_tol;
        let dt2 = self.cfg.settle_dt.filter(|&d| d != dt);
        if tol.is_none() && dt2.is_none() {
            if !self.world.step_n_polled(total, POLL_EVERY, poll)? {
                return Ok(None);
            }
            return Ok(Some((total, total as Real * dt)));
        }
        // The energy scale m g r of a mean particle, and the time the new layer needs to
        // fall through its slab: the run neither stops nor coarsens its step before that.
        let g = self.cfg.sim.gravity.norm();
        let r_mean = self.cfg.radii.r_mean();
        let m_mean = self.cfg.sim.material.density * crate::math::particle_volume::<3>(r_mean);
        let scale = m_mean * g.max(1e-12) * r_mean;
        let t_fall = if g > 0.0 {
            (2.0 * self.cfg.h_layer / g).sqrt()
        } else {
            0.0
        };
        let quiet = |w: &World<D>| {
            tol.is_some_and(|tol| {
                let moving = (w.len() - w.n_frozen()).max(1);
                w.kinetic_energy() / (moving as Real) < tol * scale
            })
        };
        let mut steps = 0u64;
        while steps < total {
            let n = settle_chunk(dt).min(total - steps);
            if !self.world.step_n_polled(n, POLL_EVERY, poll)? {
                return Ok(None);
            }
            steps += n;
            let fallen = steps as Real * dt >= t_fall;
            if fallen && quiet(&self.world) {
                return Ok(Some((steps, steps as Real * dt)));
            }
            if fallen && dt2.is_some() {
                break;
            }
        }
        let t = steps as Real * dt;
        let Some(dt2) = dt2.filter(|_| steps < total) else {
            return Ok(Some((steps, t)));
        };
        self.world.set_dt(dt2)?;
        let total2 = ((self.cfg.settle_time - t) / dt2).round() as u64;
        let Some(steps2) = self.step_until(total2, poll, |p| quiet(&p.world))? else {
            return Ok(None);
        };
        Ok(Some((steps + steps2, t + steps2 as Real * dt2)))
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

/// The RSA inputs of layer `layer` on top of `existing` (positions wrapped into a
/// periodic cell, radii), whose height is `height` (m): the layer loop's, for either
/// engine.
fn layer_spec<'a, const D: usize>(
    cfg: &PackConfig<D>,
    existing: (&'a [Vector<D>], &'a [Real]),
    height: Real,
    layer: usize,
) -> LayerSpec<'a, D>
where
    Dim<D>: Spatial<D>,
{
    let v = <Dim<D> as Spatial<D>>::VERTICAL;
    let mut hi = cfg.base;
    hi[v] = Real::INFINITY;
    LayerSpec {
        container: cfg.sim.container,
        lo: Vector::<D>::zeros(),
        hi,
        vertical: v,
        height,
        h_layer: cfg.h_layer,
        phi_layer: cfg.phi_layer,
        radii: cfg.radii.clone(),
        max_attempts: cfg.max_attempts,
        existing,
        layer,
    }
}

/// A layer's centres and radii in Morton order (cells of one diameter 2 `r_max`).
fn in_morton_order<const D: usize>(
    x: Vec<Vector<D>>,
    r: Vec<Real>,
    r_max: Real,
) -> (Vec<Vector<D>>, Vec<Real>) {
    let order = morton_order(&x, 2.0 * r_max);
    (
        order.iter().map(|&k| x[k]).collect(),
        order.iter().map(|&k| r[k]).collect(),
    )
}

/// The layer loop's placement without its DEM: for another engine that jams each layer
/// itself (granpack's LAMMPS path). Seeded as [`Packer`] is, it draws the same random
/// numbers: given the same particles beneath, each layer is the one [`Packer`] places,
/// in the same order.
pub struct LayerPlacer<const D: usize>
where
    Dim<D>: Spatial<D>,
{
    cfg: PackConfig<D>,
    rng: ChaCha8Rng,
    layer: usize,
    /// A placement was stopped midway by the poll.
    stopped: bool,
}

impl<const D: usize> LayerPlacer<D>
where
    Dim<D>: Spatial<D>,
{
    /// Validates the scene as [`Packer::new`] does and seeds the generator as it does.
    pub fn new(cfg: PackConfig<D>) -> Result<Self> {
        cfg.validate()?;
        let mut rng = ChaCha8Rng::seed_from_u64(cfg.seed);
        rng.set_stream(cfg.stream);
        Ok(LayerPlacer {
            cfg,
            rng,
            layer: 0,
            stopped: false,
        })
    }

    /// The scene.
    pub fn config(&self) -> &PackConfig<D> {
        &self.cfg
    }

    /// Layers placed so far.
    pub fn layers(&self) -> usize {
        self.layer
    }

    /// Places the next layer on top of `existing` (positions, radii; positions outside a
    /// periodic cell are wrapped into it), whose height max(z + r) is `height` (m).
    /// Returns the new centres and radii in Morton order, or None when `poll` stopped
    /// the placement (the placer then refuses further layers). Refused once
    /// `max_layers` layers were placed.
    pub fn place_polled(
        &mut self,
        existing: (&[Vector<D>], &[Real]),
        height: Real,
        poll: &mut dyn FnMut() -> bool,
    ) -> Result<Option<(Vec<Vector<D>>, Vec<Real>)>> {
        if self.stopped {
            return Err(Error::invalid(
                "placer",
                "stopped",
                "a placement was interrupted midway; start a new pack",
            ));
        }
        if self.layer >= self.cfg.max_layers {
            return Err(Error::invalid(
                "max_layers",
                self.cfg.max_layers,
                &format!(
                    "reached before the pack grew to height = {} m (now {:.4} m)",
                    self.cfg.height, height
                ),
            ));
        }
        if existing.0.len() != existing.1.len() {
            return Err(Error::invalid(
                "radii",
                existing.1.len(),
                &format!("must have one radius per position ({})", existing.0.len()),
            ));
        }
        if !height.is_finite() || height < 0.0 {
            return Err(Error::invalid(
                "height",
                height,
                "must be finite and >= 0 (m)",
            ));
        }
        let wrapped: Vec<Vector<D>>;
        let positions = match self.cfg.sim.container {
            crate::scene::Container::Periodic => {
                let (lo, hi) = self.cfg.corners();
                let per = crate::geometry::Period::lateral(&lo, &hi);
                wrapped = existing.0.iter().map(|x| per.wrap(*x)).collect();
                &wrapped[..]
            }
            _ => existing.0,
        };
        let spec = layer_spec(&self.cfg, (positions, existing.1), height, self.layer);
        let mut last = Instant::now();
        let mut gated = || {
            if last.elapsed() < POLL_EVERY {
                return true;
            }
            last = Instant::now();
            poll()
        };
        let Some((x, r)) = place_layer_polled(&spec, &mut self.rng, &mut gated)? else {
            self.stopped = true;
            return Ok(None);
        };
        self.layer += 1;
        Ok(Some(in_morton_order(x, r, self.cfg.radii.r_max())))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::SimConfig;

    fn small_2d() -> PackConfig<2> {
        let mut sim = SimConfig::<2>::paper();
        sim.drag = 0.005;
        PackConfig {
            sim,
            base: Vector::<2>::new(0.2, 0.0),
            height: 0.05,
            radii: RadiusLaw::Constant(0.01),
            h_layer: 0.04,
            phi_layer: 0.4,
            settle_time: 0.3,
            seed: 5,
            stream: 0,
            max_attempts: 100_000,
            max_layers: 100,
            settle_tol: None,
            freeze_depth: None,
            freeze_speed: 1e-3,
            freeze_force: 0.1,
            settle_dt: None,
        }
    }

    /// Layers of at least RESORT_MIN_LAYER discs re-sort the whole pack into one row-major
    /// order (the layers interleave in memory), and the pack is the same bit for bit on
    /// one and two threads, freezing and thawing included.
    #[test]
    fn a_resorted_pack_is_the_same_on_one_and_two_threads() {
        let cfg = PackConfig {
            base: Vector::<2>::new(84.0, 0.0),
            height: 0.09,
            settle_time: 0.1,
            freeze_depth: Some(0.02),
            ..small_2d()
        };
        let run = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            pool.install(|| {
                let mut p = Packer::new(cfg.clone()).unwrap();
                p.run(|_| {}).unwrap();
                p
            })
        };
        let (a, b) = (run(1), run(2));
        let reps = a.reports();
        assert!(reps.len() >= 2, "{} layers", reps.len());
        assert!(reps.iter().all(|r| r.added >= RESORT_MIN_LAYER), "{reps:?}");
        assert!(reps.iter().any(|r| r.frozen > 0), "{reps:?}");
        for (k, r) in reps.iter().enumerate() {
            let n = a.layers().iter().filter(|&&l| l as usize == k).count();
            assert_eq!(n, r.added);
        }
        assert!(
            a.layers().windows(2).any(|w| w[0] > w[1]),
            "layers not interleaved"
        );
        assert_eq!(a.layers(), b.layers());
        assert_eq!(a.world().state_checksum(), b.world().state_checksum());
        assert_eq!(reps.len(), b.reports().len());
    }

    /// A settle_time of more steps per layer than the bound is refused by name.
    #[test]
    fn settle_steps_past_the_bound_are_refused_by_name() {
        let cfg = PackConfig {
            settle_time: 1e12,
            ..small_2d()
        };
        let err = Packer::new(cfg)
            .err()
            .expect("accepted 1e16 steps per layer");
        assert!(err.to_string().contains("settle_time"), "{err}");
        assert!(err.to_string().contains("steps per layer"), "{err}");
    }

    /// A polled layer is the plain layer; a poll that answers false stops the layer
    /// midway, and the packer refuses to go on.
    #[test]
    fn polled_layer_equals_plain_layer_and_a_stop_is_final() {
        let mut a = Packer::new(small_2d()).unwrap();
        let mut b = Packer::new(small_2d()).unwrap();
        let ra = a.next_layer().unwrap();
        let rb = b.next_layer_polled(&mut || true).unwrap().unwrap();
        assert_eq!(ra.steps, rb.steps);
        assert_eq!(a.world().positions(), b.world().positions());
        assert!(b.next_layer_polled(&mut || false).unwrap().is_none());
        assert!(b.world().steps() < a.world().steps() + ra.steps);
        let err = b.next_layer().unwrap_err();
        assert!(err.to_string().contains("interrupted"), "{err}");
    }

    /// settle_dt must be positive and at most the Rayleigh step; the error names it.
    #[test]
    fn settle_dt_out_of_range_is_refused_by_name() {
        let crit = small_2d().sim.material.rayleigh_time_step(0.01);
        for bad in [0.0, -1e-4, 1.01 * crit, Real::NAN] {
            let cfg = PackConfig {
                settle_dt: Some(bad),
                ..small_2d()
            };
            let err = Packer::new(cfg).err().expect("accepted a bad settle_dt");
            assert!(err.to_string().contains("settle_dt"), "{err}");
        }
        let ok = PackConfig {
            settle_dt: Some(crit),
            ..small_2d()
        };
        assert!(Packer::new(ok).is_ok());
    }

    /// Every layer's simulated time is settle_time whatever its two steps: t_fall at
    /// dt (to the next 0.01 s), the rest at settle_dt. The world's clock, which adds
    /// each step's own dt, shows it.
    #[test]
    fn settle_dt_keeps_each_layer_at_settle_time() {
        let cfg = PackConfig {
            settle_dt: Some(1.6e-4),
            ..small_2d()
        };
        let (settle, dt2) = (cfg.settle_time, 1.6e-4);
        let mut p = Packer::new(cfg).unwrap();
        let mut t0 = 0.0;
        while !p.done() {
            let rep = p.next_layer().unwrap();
            let t = p.world().time() - t0;
            t0 = p.world().time();
            assert!(
                (t - settle).abs() <= 0.5 * dt2 + 1e-12,
                "layer {}: {t} s",
                rep.layer
            );
            // fewer steps than at dt = 1e-4 throughout
            assert!(rep.steps < (settle / 1e-4).round() as u64, "{}", rep.steps);
        }
        assert!(p.world().config().dt == dt2);
    }
}
