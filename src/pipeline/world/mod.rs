//! The DEM world: particle state, walls, the Verlet pair list with tangential history,
//! and one explicit step.
//!
//! One step reads like the algorithm (rapier's `collision_pipeline`):
//! 1. half kick and drift (velocity Verlet),
//! 2. rebuild the pair list if it may miss a contact (two particles have together
//!    travelled more than their half skins, see `integrate::Travel`),
//! 3. pair forces (one pass over the pair list, each pair independent; the law runs
//!    over blocks of consecutive pairs, `dynamics::batched_law`),
//! 4. gather forces per particle (fixed order: no atomics, no order-dependent sums),
//!    plus walls and body forces,
//! 5. second half kick, with the blow-up guards.
//!
//! One concern a file:
//! - `particles.rs`: the particle arrays, and adding particles;
//! - `pair_list.rs`: the Verlet list, its per-pair state and its rebuild (step 2);
//! - `boundary.rs`: the container's walls;
//! - `moving_walls.rs`: the lid, walls that move, and the loads on them;
//! - `integrate.rs`: the half kick and drift (step 1);
//! - `forces.rs`: the pair pass and the gather (steps 3-5);
//! - `freeze.rs`: freezing of settled particles;
//! - `remove.rs`, `reorder.rs`: taking particles out, storing them in another order;
//! - `contacts.rs`: the contacts in force, for export;
//! - `energy.rs`: the energies and the run-time guards;
//! - `team.rs`: the step's thread team.
//!
//! This file holds the world, its public API and the step loop.
//!
//! Every parallel loop writes disjoint elements or reduces with an exact operation
//! (max, min index) or per-chunk partial sums added in chunk order, so results are
//! bit-identical on any number of threads.

use crate::dynamics::batched_law::{
    clear_lanes, clear_roll_lanes, geometry_block, law_block, roll_block, Geometry, LawConsts,
    PairBlock, PairFactors, PairRecord, RollBlock, RollRecord, BLOCK, BLOCK_ROW, BLOCK_SHIFT,
    LANES,
};
use crate::dynamics::contact_law::{linear_coefs, rolling_epsd, RollCoefs};
use crate::dynamics::material::ContactLaw;
use crate::dynamics::{hertz_mindlin, LawCoefs, PairParams};
use crate::error::{check_range, BlowupKind, Error, Result};
use crate::geometry::grid::{bin_starts, counting_sort};
use crate::geometry::{neighbor_pairs_active, neighbor_pairs_periodic};
use crate::math::{AngOps, Dim, Real, Spatial, Vector};
use crate::scene::{Container, Inertia2D, SimConfig, MAX_STEPS_PER_CALL};
use rayon::prelude::*;

mod boundary;
mod contacts;
#[cfg(test)]
mod container_tests;
mod energy;
mod forces;
mod freeze;
mod integrate;
mod moving_walls;
mod pair_list;
mod particles;
mod remove;
mod reorder;
mod team;
#[cfg(test)]
mod tests;

pub use boundary::Period;
pub(crate) use boundary::{container_walls, Wall};
pub use contacts::{geometric_contacts, Contacts, FinishedState};
pub use freeze::{FreezeConfig, FREEZE_INTERVAL};
pub use moving_walls::{ForceBalance, WallLoad};
use pair_list::Pairs;
use particles::Particles;
use team::{Disjoint, Team};

/// A raw pointer that may cross threads: the force sweep writes disjoint particles
/// through it (see `forces::gather_one`), the pair pass disjoint lanes of the pair
/// blocks (`forces::pair_pass`), the rebuild's merge disjoint pair states.
struct SyncPtr<T>(*mut T);
impl<T> Clone for SyncPtr<T> {
    fn clone(&self) -> Self {
        *self
    }
}
impl<T> Copy for SyncPtr<T> {}
impl<T> SyncPtr<T> {
    /// The pointer (a method, so that a closure captures the whole SyncPtr, which may
    /// cross threads, and not its field, which may not).
    #[inline(always)]
    fn ptr(self) -> *mut T {
        self.0
    }
}
// SAFETY: the users of a SyncPtr access disjoint elements from different threads (each
// use states why).
unsafe impl<T> Send for SyncPtr<T> {}
unsafe impl<T> Sync for SyncPtr<T> {}

/// Particles per parallel work item. Systems below this run on one thread with no
/// scheduling cost; the value does not affect results.
const CHUNK: usize = 512;
/// Pairs per parallel work item in the rebuild's merge (results do not depend on it).
const PAIR_CHUNK: usize = 4096;
/// Least particles per rayon work item in the rebuild's per-particle loops (a few
/// nanoseconds per particle: below this a hand-off to another thread costs more than
/// it saves). Results do not depend on it.
const REBUILD_MIN_PARTICLES: usize = 4096;
/// Least pair blocks per rayon work item when the rebuild fills the blocks: 1 024
/// pairs or more (results do not depend on it).
const REBUILD_MIN_BLOCKS: usize = 1024_usize.div_ceil(BLOCK);
/// Particles per item of the step's team loops (kick and drift, gather; see `team`).
/// Small enough that a layer of a few hundred particles splits between threads, large
/// enough that claiming an item (one atomic add) is noise. Results do not depend on it.
const TEAM_CHUNK: usize = 256;
/// Pairs per item of the step's pair pass on the team: a power of two, a multiple of
/// [`LANES`] that divides [`BLOCK`] (results do not depend on it).
const TEAM_PAIRS: usize = if BLOCK < 256 { BLOCK } else { 256 };
const _: () = assert!(TEAM_PAIRS.is_power_of_two() && TEAM_PAIRS.is_multiple_of(LANES));
const _: () = assert!(BLOCK.is_multiple_of(TEAM_PAIRS));

/// Steps that a particle's adaptive skin lasts at its own speed (see
/// [`SimConfig::skin_ratio`]). A rebuild of a dense pack costs about as much as two or
/// three steps, and a wider skin adds pairs that are tested every step. Since only the
/// moving particles widen their skins, a long horizon is cheap: against 40 steps, 80
/// cut the rebuilds of a 3D pack by a third at 1 % more pair tests.
pub const SKIN_STEPS: Real = 80.0;
/// Smallest adaptive skin, as a fraction of the largest ([`SimConfig::skin_ratio`]).
pub const SKIN_FLOOR: Real = 0.25;
/// Most walls a world has: the box's floor and two per horizontal axis, and a lid
/// (see [`World::add_lid`]).
pub const MAX_WALLS: usize = 6;

/// The DEM world in `D` dimensions.
#[derive(Clone, Debug)]
pub struct World<const D: usize>
where
    Dim<D>: Spatial<D>,
{
    cfg: SimConfig<D>,
    p: Particles<D, <Dim<D> as Spatial<D>>::Ang>,
    pairs: Pairs<D>,
    walls: Vec<Wall>,
    /// The periodic axes (a periodic container), None otherwise.
    period: Option<Period<D>>,
    e_star: Real,
    g_star: Real,
    time: Real,
    steps: u64,
    forces_valid: bool,
    list_valid: bool,
    dt_checked: bool,
    /// Number of pair-list rebuilds so far (diagnostics).
    rebuilds: u64,
    /// Wall-clock seconds spent in pair-list rebuilds (diagnostics).
    rebuild_seconds: Real,
    freeze: Option<FreezeConfig>,
    n_frozen: usize,
    /// Kinetic plus potential energy when the state was last set by the user (J): with
    /// gravity the only source, the total may not rise above it (see `check_energy`).
    energy_ref: Option<Real>,
    /// Pair state (bytes) from which the force pass runs as one sweep (see
    /// `forces::SWEEP_MIN_BYTES`; the tests lower it to check that both ways agree).
    sweep_min_bytes: usize,
    /// The pair pass's scratch ([`LANES`] pairs), one per team slot (see `team`), kept
    /// between steps: 15 KB each in 3D.
    scratch: Vec<Box<Geometry<D>>>,
    /// Speed of each wall along its outward normal (m/s), seen by the contact law:
    /// zero for walls at rest (see `moving_walls`).
    wall_rate: Vec<Real>,
    /// Extra reach (m) of the walls' near-lists while walls move, and the largest
    /// distance a wall has moved since the last rebuild (m): beyond the margin the
    /// pair list is rebuilt (see `moving_walls`).
    wall_margin: Real,
    wall_travel: Real,
    /// Work done on the particles by moving walls since the energy reference was set
    /// (J): the energy guard's budget grows by it.
    wall_work: Real,
    /// Local non-viscous damping coefficient (-), 0 (off) unless a stage sets it.
    local_damping: Real,
    /// The walls' Coulomb friction (-) where it differs from the particles' (the
    /// element tests' smooth platens); None: the material's friction.
    wall_friction: Option<Real>,
}

type Ang<const D: usize> = <Dim<D> as Spatial<D>>::Ang;

impl<const D: usize> World<D>
where
    Dim<D>: Spatial<D>,
{
    /// A world with no particles. Fails if the configuration is invalid.
    pub fn new(cfg: SimConfig<D>) -> Result<Self> {
        cfg.validate()?;
        // box_walls takes the last axis as vertical, as Spatial does
        debug_assert_eq!(<Dim<D> as Spatial<D>>::VERTICAL, D - 1);
        let (walls, period) = cfg.walls.as_ref().map_or_else(
            || (Vec::new(), None),
            |(lo, hi)| container_walls(cfg.container, lo, hi),
        );
        let mut pairs = Pairs::default();
        pairs.keep_roll(cfg.material.has_rolling());
        Ok(World {
            e_star: cfg.material.e_star(),
            g_star: cfg.material.g_star(),
            cfg,
            p: Particles::default(),
            pairs,
            walls,
            period,
            time: 0.0,
            steps: 0,
            forces_valid: false,
            list_valid: false,
            dt_checked: false,
            rebuilds: 0,
            rebuild_seconds: 0.0,
            freeze: None,
            n_frozen: 0,
            energy_ref: None,
            sweep_min_bytes: forces::SWEEP_MIN_BYTES,
            scratch: Vec::new(),
            wall_rate: vec![0.0; MAX_WALLS],
            wall_margin: 0.0,
            wall_travel: 0.0,
            wall_work: 0.0,
            local_damping: 0.0,
            wall_friction: None,
        })
    }

    /// The configuration.
    pub fn config(&self) -> &SimConfig<D> {
        &self.cfg
    }

    /// Number of particles.
    pub fn len(&self) -> usize {
        self.p.x.len()
    }

    /// True when there are no particles.
    pub fn is_empty(&self) -> bool {
        self.p.x.is_empty()
    }

    /// Simulated time (s).
    pub fn time(&self) -> Real {
        self.time
    }

    /// Steps taken.
    pub fn steps(&self) -> u64 {
        self.steps
    }

    /// Pair-list rebuilds so far.
    pub fn rebuilds(&self) -> u64 {
        self.rebuilds
    }

    /// Bytes of engine state in use: particle arrays, the pair list with its per-pair
    /// state and the incidence lists (lengths; spare capacity that was never touched
    /// costs address space, not memory).
    pub fn state_bytes(&self) -> usize {
        self.memory().iter().map(|(_, bytes)| bytes).sum()
    }

    /// Where [`World::state_bytes`] goes, by group: `particles` (position, velocity,
    /// force, spin, torque, radius, mass and inverse mass and inertia, the rebuild's
    /// reference position and skin, the flags), `wall_contacts` (each particle's
    /// tangential history and force against every wall), `pair_list` (the pairs' indices
    /// and their state: history, force, torque, overlap, law factors) and `incidence`
    /// (each particle's pairs, for the gather). Bytes in use (lengths).
    pub fn memory(&self) -> [(&'static str, usize); 4] {
        fn b<T>(v: &[T]) -> usize {
            std::mem::size_of_val(v)
        }
        let p = &self.p;
        let pr = &self.pairs;
        let particles = b(&p.x)
            + b(&p.v)
            + b(&p.f)
            + b(&p.w)
            + b(&p.t)
            + b(&p.r)
            + b(&p.m)
            + b(&p.inv_m)
            + b(&p.inv_i)
            + b(&p.x_ref)
            + b(&p.half_skin)
            + b(&p.frozen)
            + b(&p.wall_mask)
            + b(&p.wall_near);
        [
            ("particles", particles),
            (
                "wall_contacts",
                b(&p.wall_hist) + b(&p.wall_force) + b(&p.wall_roll),
            ),
            ("pair_list", b(&pr.ij) + b(&pr.blocks) + b(&pr.roll)),
            (
                "incidence",
                b(&pr.i_frozen) + b(&pr.i_active) + b(&pr.j_start) + b(&pr.j_inc),
            ),
        ]
    }

    /// Pairs in the Verlet list, and how many of them join two frozen particles.
    pub fn pair_counts(&self) -> (usize, usize) {
        (self.pairs.ij.len(), self.pairs.n_frozen_pairs)
    }

    /// Wall-clock seconds spent rebuilding the pair list so far (s).
    pub fn rebuild_seconds(&self) -> Real {
        self.rebuild_seconds
    }

    /// Positions (m).
    pub fn positions(&self) -> &[Vector<D>] {
        &self.p.x
    }
    /// Positions (m) with the periodic axes wrapped into the cell [lo, hi) (a copy;
    /// between rebuilds the engine's own may stray a half skin beyond it). The same
    /// as [`positions`](Self::positions) in a box or a cylinder.
    pub fn positions_in_cell(&self) -> Vec<Vector<D>> {
        match &self.period {
            Some(per) => self.p.x.iter().map(|x| per.wrap(*x)).collect(),
            None => self.p.x.clone(),
        }
    }

    /// The periodic axes, None outside a periodic container.
    pub fn period(&self) -> Option<&Period<D>> {
        self.period.as_ref()
    }

    /// Velocities (m/s).
    pub fn velocities(&self) -> &[Vector<D>] {
        &self.p.v
    }
    /// Angular velocities (rad/s).
    pub fn spins(&self) -> &[Ang<D>] {
        &self.p.w
    }
    /// Radii (m).
    pub fn radii(&self) -> &[Real] {
        &self.p.r
    }
    /// Masses (kg).
    pub fn masses(&self) -> &[Real] {
        &self.p.m
    }

    /// FNV-1a hash of the bit patterns of every position, velocity and spin: equal
    /// checksums mean bit-identical states (the determinism checks compare them across
    /// thread counts and CPU levels).
    pub fn state_checksum(&self) -> u64 {
        let mut h: u64 = 0xcbf2_9ce4_8422_2325;
        let words = self
            .positions()
            .iter()
            .chain(self.velocities())
            .flat_map(|v| v.iter().map(|c| c.to_bits()))
            .chain(
                self.spins()
                    .iter()
                    .flat_map(|s| (0..<Ang<D> as AngOps>::NCOMP).map(|k| s.comp(k).to_bits())),
            );
        for b in words {
            h = (h ^ b).wrapping_mul(0x0100_0000_01b3);
        }
        h
    }

    /// Smallest radius (m), infinity when empty.
    pub fn r_min(&self) -> Real {
        self.p.r.iter().cloned().fold(Real::INFINITY, Real::min)
    }

    /// The critical step for the current particles (s): the Rayleigh step, or the
    /// linear law's (see [`Material::critical_time_step`]).
    pub fn critical_time_step(&self) -> Real {
        self.cfg.material.critical_time_step(self.r_min())
    }

    fn check_dt(&mut self) -> Result<()> {
        if !self.dt_checked {
            if !self.is_empty() {
                let crit = self.critical_time_step();
                if self.cfg.dt > crit {
                    return Err(Error::UnstableTimeStep {
                        dt: self.cfg.dt,
                        critical: crit,
                        r_min: self.r_min(),
                    });
                }
            }
            self.dt_checked = true;
        }
        Ok(())
    }

    /// Changes the time step (s) between steps. It must be positive (checked here) and
    /// at most the Rayleigh step of the particles present (checked at the next step,
    /// as for the configured dt).
    pub fn set_dt(&mut self, dt: Real) -> Result<()> {
        check_range("dt", dt, 0.0, false, f64::INFINITY, false)?;
        if dt != self.cfg.dt {
            self.cfg.dt = dt;
            self.dt_checked = false;
        }
        Ok(())
    }

    /// Changes the Coulomb friction coefficient mu (-), particle-particle and
    /// particle-wall, from the next step on: a density target lowers it under the
    /// servo and restores it (see `granpack.density`). It must be finite and >= 0.
    /// Contacts whose tangential spring now lies outside the smaller Coulomb cone slip
    /// back onto it at the next step, as in any step where the normal force drops.
    pub fn set_friction(&mut self, mu: Real) -> Result<()> {
        check_range("friction", mu, 0.0, true, f64::INFINITY, false)?;
        self.cfg.material.friction = mu;
        Ok(())
    }

    /// Gives the walls their own Coulomb friction coefficient (-) from the next step
    /// on (finite, >= 0), or the material's again with None. The particles' friction
    /// stays; a wall contact's spring keeps its history and slides at the new cap.
    pub fn set_wall_friction(&mut self, mu: Option<Real>) -> Result<()> {
        if let Some(m) = mu {
            check_range("wall_friction", m, 0.0, true, f64::INFINITY, false)?;
        }
        self.wall_friction = mu;
        Ok(())
    }

    /// Changes the rolling friction coefficient mu_r (-) from the next step on, as
    /// [`set_friction`](Self::set_friction) does mu; a derived rolling spring
    /// (2.25 mu_r^2 k_n) follows it. Refused without a rolling model.
    pub fn set_rolling_friction(&mut self, mu_r: Real) -> Result<()> {
        check_range("rolling_friction", mu_r, 0.0, true, f64::INFINITY, false)?;
        match &mut self.cfg.material.rolling {
            crate::dynamics::material::Rolling::Epsd { mu_r: m, .. } => {
                *m = mu_r;
                Ok(())
            }
            crate::dynamics::material::Rolling::None => Err(Error::invalid(
                "rolling_friction",
                format!("{mu_r}"),
                "needs a rolling model (the material's rolling is 'none')",
            )),
        }
    }

    /// Advances `n` steps (at most [`MAX_STEPS_PER_CALL`]). Stops with an error at the
    /// first sign of blow-up.
    pub fn step_n(&mut self, n: u64) -> Result<()> {
        if n > MAX_STEPS_PER_CALL {
            return Err(Error::invalid(
                "n",
                n,
                &format!("must lie in [0, {MAX_STEPS_PER_CALL}] steps per call"),
            ));
        }
        self.check_dt()?;
        if self.is_empty() {
            self.steps += n;
            self.time += n as Real * self.cfg.dt;
            return Ok(());
        }
        // Run the loop on a pool worker, with a team of the pool's threads for the
        // step's loops (see `team`): cheaper than a rayon loop per phase.
        Team::scoped(|team| {
            for _ in 0..n {
                self.step_once(team)?;
            }
            Ok(())
        })
    }

    /// Advances `n` steps like [`World::step_n`], in chunks of about `every` of wall
    /// time, and calls `poll` after each chunk: a caller that must react to an
    /// interrupt (Ctrl-C) while a long run is under way returns false from it, and the
    /// run stops there. Returns true when the run went to its end with every poll
    /// answering true, and false as soon as a poll answered false, even after the
    /// chunk that ended the run: a stop asked for is a stop, and a caller that took
    /// `true` for "go on" would otherwise run on into its next call (the adaptive
    /// settle's many short runs end most of their polls on their last chunk).
    /// Chunking changes nothing in the results: a step depends on the step counter,
    /// never on where a call began.
    pub fn step_n_polled(
        &mut self,
        n: u64,
        every: std::time::Duration,
        poll: &mut dyn FnMut() -> bool,
    ) -> Result<bool> {
        if n > MAX_STEPS_PER_CALL {
            return self.step_n(n).map(|_| true);
        }
        let mut left = n;
        // A first short chunk measures the step's cost; later chunks aim at `every`.
        let mut chunk = 16u64;
        while left > 0 {
            let k = chunk.min(left);
            let start = std::time::Instant::now();
            self.step_n(k)?;
            left -= k;
            if !poll() {
                return Ok(false);
            }
            let took = start.elapsed().as_secs_f64().max(1e-9);
            let aim = (k as f64 * every.as_secs_f64() / took).clamp(1.0, 4.0 * k as f64);
            chunk = aim as u64;
        }
        Ok(true)
    }

    /// The number of steps in `seconds` of simulated time (rounded), refused by name
    /// when it is beyond [`MAX_STEPS_PER_CALL`] (a tiny dt would otherwise saturate the
    /// count and run for ever).
    pub fn steps_for(&self, seconds: Real) -> Result<u64> {
        check_range("seconds", seconds, 0.0, true, f64::INFINITY, false)?;
        let n = (seconds / self.cfg.dt).round();
        if n > MAX_STEPS_PER_CALL as Real {
            return Err(Error::invalid(
                "seconds",
                seconds,
                &format!(
                    "with dt = {:e} s that is {n:.3e} steps; at most {MAX_STEPS_PER_CALL} \
                     steps per call (seconds <= {:e})",
                    self.cfg.dt,
                    MAX_STEPS_PER_CALL as Real * self.cfg.dt
                ),
            ));
        }
        Ok(n as u64)
    }

    /// Advances by `seconds` of simulated time (rounded to whole steps).
    pub fn run(&mut self, seconds: Real) -> Result<()> {
        let n = self.steps_for(seconds)?;
        self.step_n(n)
    }

    /// One step, its loops on `team`. Everything that calls into rayon (rebuilds,
    /// freeze decisions, checks) pauses the team first (see `team`).
    fn step_once(&mut self, team: &mut Team) -> Result<()> {
        if !self.list_valid {
            team.pause();
            self.rebuild_pairs();
        }
        if !self.forces_valid {
            team.pause();
            self.compute_forces()?;
        }
        if self.energy_ref.is_none() {
            team.pause();
            self.check_energy()?;
        }
        let dt = self.cfg.dt;
        // 1. half kick + drift, compiled once per combination of spin kicks (only with
        // rotations and friction: otherwise no torque acts) and frozen particles to skip.
        let moved = match (self.torques_on(), self.n_frozen > 0) {
            (false, false) => self.kick_drift::<false, false>(team),
            (false, true) => self.kick_drift::<false, true>(team),
            (true, false) => self.kick_drift::<true, false>(team),
            (true, true) => self.kick_drift::<true, true>(team),
        };
        // 2. pair list
        if moved {
            team.pause();
            self.rebuild_pairs();
        }
        // 3-5. forces and the second half kick; on freeze-decision steps every
        // particle's net force is needed.
        let decide = self
            .freeze
            .is_some_and(|f| (self.steps + 1).is_multiple_of(f.interval));
        let suspicious = self.compute_forces_inner(decide, true, team)?;
        if decide {
            team.pause();
            self.update_frozen();
        }
        self.steps += 1;
        self.time += dt;
        // Positions leave the box or turn non-finite only after a large or non-finite
        // velocity, which the cheap flag catches; the full check runs then, and at
        // intervals.
        if suspicious || self.steps.is_multiple_of(1024) {
            team.pause();
            self.check_state()?;
            self.check_energy()?;
        }
        Ok(())
    }

    /// Whether contacts exert torques: rotations and friction both on. Without them no
    /// torque acts, and the steps neither gather torques nor kick spins.
    fn torques_on(&self) -> bool {
        self.cfg.rotations && (self.cfg.material.friction > 0.0 || self.cfg.material.has_rolling())
    }
}
