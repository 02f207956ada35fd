//! The DEM world: particle state, walls, the Verlet pair list with tangential history,
//! and one explicit step.
//!
//! One step reads like the algorithm (rapier's `collision_pipeline`):
//! 1. half kick and drift (velocity Verlet),
//! 2. rebuild the pair list if some particle has moved more than its half skin,
//! 3. pair forces (one pass over the pair list, each pair independent; the law runs
//!    over blocks of consecutive pairs, `dynamics::block`),
//! 4. gather forces per particle (fixed order: no atomics, no order-dependent sums),
//!    plus walls and body forces,
//! 5. second half kick, with the blow-up guards.
//!
//! This file holds the state, the public API and the step; steps 3-4 are in
//! `forces.rs`, the energies and guards in `energy.rs`.
//!
//! Every parallel loop writes disjoint elements or reduces with an exact operation
//! (max, min index) or per-chunk partial sums added in chunk order, so results are
//! bit-identical on any number of threads.

use crate::dynamics::block::{
    clear_lanes, geometry_block, law_block, Geometry, LawConsts, PairBlock, PairFactors,
    PairRecord, BLOCK, BLOCK_SHIFT,
};
use crate::dynamics::{hertz_mindlin, Material, PairParams};
use crate::error::{check_range, BlowupKind, Error, Result};
use crate::geometry::grid::{bin_starts, counting_sort};
use crate::geometry::{neighbor_pairs, neighbor_pairs_active};
use crate::math::{AngOps, Dim, Real, Spatial, Vector};
use rayon::prelude::*;

mod energy;
mod forces;
mod team;

use team::{Disjoint, Team};

/// Most steps one call may ask for (1e10: hours for a handful of particles, far more
/// for a pack); beyond it a request is refused by name before any step is taken.
pub const MAX_STEPS_PER_CALL: u64 = 10_000_000_000;

/// Particles per parallel work item. Systems below this run on one thread with no
/// scheduling cost; the value does not affect results.
const CHUNK: usize = 512;
/// Pairs per parallel work item in the rebuild's merge (results do not depend on it).
const PAIR_CHUNK: usize = 4096;
/// Least particles per rayon work item in the rebuild's per-particle loops (a few
/// nanoseconds per particle: below this a hand-off to another thread costs more than
/// it saves). Results do not depend on it.
const REBUILD_MIN_PARTICLES: usize = 4096;
/// Least pair blocks per rayon work item when the rebuild fills the blocks (results
/// do not depend on it).
const REBUILD_MIN_BLOCKS: usize = 8;
/// Particles per item of the step's team loops (kick and drift, gather; see `team`).
/// Small enough that a layer of a few hundred particles splits between threads, large
/// enough that claiming an item (one atomic add) is noise. Results do not depend on it.
const TEAM_CHUNK: usize = 256;
/// Pair blocks per item of the step's pair pass on the team (results do not depend
/// on it).
const TEAM_BLOCKS: usize = 2;

/// Steps that a particle's adaptive skin lasts at its own speed (see
/// [`SimConfig::skin_ratio`]). A rebuild of a dense pack costs about as much as two or
/// three steps, and a wider skin adds pairs that are tested every step. Since only the
/// moving particles widen their skins, a long horizon is cheap: against 40 steps, 80
/// cut the rebuilds of a 3D pack by a third at 1 % more pair tests.
pub const SKIN_STEPS: Real = 80.0;
/// Smallest adaptive skin, as a fraction of the largest ([`SimConfig::skin_ratio`]).
pub const SKIN_FLOOR: Real = 0.25;
/// Most walls a box has: the floor and two per horizontal axis.
pub const MAX_WALLS: usize = 5;

/// Mass and moment of inertia of a 2D particle.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Inertia2D {
    /// A sphere confined to the plane: m = 4/3 pi r^3 rho, I = 2/5 m r^2 (default;
    /// the reading of the paper's 2D examples).
    #[default]
    Sphere,
    /// A disc of unit thickness: m = pi r^2 rho (kg per m of thickness), I = 1/2 m r^2.
    Disc,
}

/// Engine settings. SI units.
#[derive(Clone, Debug, PartialEq)]
pub struct SimConfig<const D: usize> {
    /// Particle and wall material.
    pub material: Material,
    /// Time step (s). Default 1e-4. Must not exceed the Rayleigh estimate.
    pub dt: Real,
    /// Body acceleration (m/s^2). Default 2 m/s^2 downwards (the paper's jamming force).
    pub gravity: Vector<D>,
    /// Linear drag coefficient c_D (N s/m): f = -c_D v. Default 0.
    pub drag: Real,
    /// Integrate spins and torques. Default true. When false, spins stay zero.
    pub rotations: bool,
    /// Box corners: floor at `lo[vertical]`, side walls at `lo[k]` and `hi[k]` for the
    /// horizontal axes; `hi[vertical]` is ignored (open top). None: no walls.
    pub walls: Option<(Vector<D>, Vector<D>)>,
    /// Largest Verlet skin, as a fraction of the smallest radius (-). Default 0.2.
    /// Each particle has a skin of its own, chosen at each rebuild from its speed so
    /// that it lasts about [`SKIN_STEPS`] steps, within [`SKIN_FLOOR`] of this and
    /// this: falling particles keep the wide skin while the resting bed under them
    /// tests few pairs.
    pub skin_ratio: Real,
    /// Largest overlap tolerated, as a fraction of the smaller radius, before the run
    /// stops as unstable (-). Default 0.5.
    pub max_overlap_ratio: Real,
    /// 2D mass model. Ignored in 3D.
    pub inertia_2d: Inertia2D,
}

impl<const D: usize> SimConfig<D>
where
    Dim<D>: Spatial<D>,
{
    /// The paper's settings: its material, dt = 1e-4 s, g = 2 m/s^2 down, no drag,
    /// rotations on, no walls.
    pub fn paper() -> Self {
        let mut g = Vector::<D>::zeros();
        g[<Dim<D> as Spatial<D>>::VERTICAL] = -2.0;
        SimConfig {
            material: Material::default(),
            dt: 1e-4,
            gravity: g,
            drag: 0.0,
            rotations: true,
            walls: None,
            skin_ratio: 0.2,
            max_overlap_ratio: 0.5,
            inertia_2d: Inertia2D::Sphere,
        }
    }

    /// Checks every field; the error names the field and the allowed range.
    pub fn validate(&self) -> Result<()> {
        self.material.validate()?;
        check_range("dt", self.dt, 0.0, false, f64::INFINITY, false)?;
        for k in 0..D {
            check_range("gravity", self.gravity[k], -f64::MAX, true, f64::MAX, true)?;
        }
        check_range("drag", self.drag, 0.0, true, f64::INFINITY, false)?;
        check_range("skin_ratio", self.skin_ratio, 0.0, true, 10.0, true)?;
        check_range(
            "max_overlap_ratio",
            self.max_overlap_ratio,
            0.0,
            false,
            1.0,
            true,
        )?;
        if let Some((lo, hi)) = &self.walls {
            let vert = <Dim<D> as Spatial<D>>::VERTICAL;
            for k in 0..D {
                if !lo[k].is_finite() {
                    return Err(Error::invalid("box", lo[k], "lower corner must be finite"));
                }
                if k != vert && !(hi[k].is_finite() && hi[k] > lo[k]) {
                    return Err(Error::invalid(
                        "box",
                        format!("[{}, {}] on axis {k}", lo[k], hi[k]),
                        "side walls must be finite with hi > lo",
                    ));
                }
            }
        }
        Ok(())
    }
}

/// Freezing of settled particles (skip what a settled pack does not need).
///
/// Every `interval` steps the world evaluates the net force on every particle. A
/// particle whose top lies below `below` (m, along the vertical), whose speed is under
/// `speed` and whose net force is under `force_ratio` times its weight is frozen: it is
/// no longer integrated (velocity and spin set to zero) and its contacts with other
/// frozen particles keep their last force instead of being recomputed; they still act
/// on the active particles above. A frozen particle whose net force grows beyond
/// `force_ratio` times its weight (something above pushes it) is unfrozen.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FreezeConfig {
    /// Vertical coordinate (m) below which (z + r < below) particles may freeze.
    pub below: Real,
    /// Speed (m/s) under which a particle counts as at rest.
    pub speed: Real,
    /// Net force over weight under which a particle counts as in equilibrium (-).
    pub force_ratio: Real,
    /// Steps between freeze/unfreeze decisions.
    pub interval: u64,
}

/// The contacts in force, in the column layout of `granpack.Contacts` (docs/microstructure.md).
#[derive(Clone, Debug, Default)]
pub struct Contacts<const D: usize> {
    /// First particle.
    pub i: Vec<i64>,
    /// Second particle, or a wall: -1 floor, -2 x = lo, -3 x = hi, -4 y = lo, -5 y = hi.
    pub j: Vec<i64>,
    /// Unit normal from i to j (to the wall).
    pub normal: Vec<Vector<D>>,
    /// Overlap r_i + r_j - |x_j - x_i| (m), > 0.
    pub overlap: Vec<Real>,
    /// Normal force magnitude (N) >= 0, pushing j away from i.
    pub force_normal: Vec<Real>,
    /// Tangential force on j (N), perpendicular to the normal.
    pub force_tangential: Vec<Vector<D>>,
    /// Branch vector from centre i to centre j, or to the contact point for walls (m).
    pub branch: Vec<Vector<D>>,
}

/// Particle state, structure of arrays.
#[derive(Clone, Debug, Default)]
struct Particles<const D: usize, A> {
    x: Vec<Vector<D>>,
    v: Vec<Vector<D>>,
    f: Vec<Vector<D>>,
    w: Vec<A>,
    t: Vec<A>,
    r: Vec<Real>,
    m: Vec<Real>,
    inv_m: Vec<Real>,
    inv_i: Vec<Real>,
    /// Position at the last pair-list rebuild (skin check).
    x_ref: Vec<Vector<D>>,
    /// Half skin h (m) chosen at the last rebuild: the list holds every pair within
    /// h_i + h_j of contact, so it stays valid while no particle has moved more than
    /// its own h.
    half_skin: Vec<Real>,
    /// Tangential history and last force on each wall.
    wall_hist: Vec<[Vector<D>; MAX_WALLS]>,
    wall_force: Vec<[Vector<D>; MAX_WALLS]>,
    /// Frozen particles are not integrated (see [`FreezeConfig`]).
    frozen: Vec<bool>,
    /// Bit w set: wall w was in contact at the last evaluation (its state is nonzero).
    wall_mask: Vec<u8>,
    /// Bit w set: wall w lies within r + 2 h of the particle at the last pair-list
    /// rebuild, so a contact with it is possible until the next rebuild.
    wall_near: Vec<u8>,
}

/// The pair (Verlet) list and its per-pair state in two runs, each sorted by (i, j):
/// first the pairs of two frozen particles, whose forces need no update between
/// freeze decisions and which a rebuild keeps without a search, then the pairs with at
/// least one active particle.
#[derive(Clone, Debug, Default)]
struct Pairs<const D: usize> {
    ij: Vec<[u32; 2]>,
    /// Length of the first run (0 when nothing is frozen).
    n_frozen_pairs: usize,
    /// Per-pair state (history, law factors, and what the pair pass leaves for the
    /// gather: force on j, n x f_t, overlap), pair k in block
    /// `k >> BLOCK_SHIFT`, lane `k & (BLOCK - 1)`; `ceil(len / BLOCK)` blocks.
    blocks: Vec<PairBlock<D>>,
    /// Pairs whose first particle is p: `i_frozen[p]..i_frozen[p + 1]` in the frozen
    /// run and `i_active[p]..i_active[p + 1]` in the active one (both runs are sorted
    /// by i, so these are ranges: the gather reads them in order, with no index list).
    i_frozen: Vec<u32>,
    i_active: Vec<u32>,
    /// Pairs whose second particle is p: `j_inc[j_start[p]..j_start[p + 1]]`, in list
    /// order.
    j_start: Vec<u32>,
    j_inc: Vec<u32>,
}

impl<const D: usize> Pairs<D> {
    /// The state of pair k.
    #[inline]
    fn get(&self, k: usize) -> PairRecord<D> {
        self.blocks[k >> BLOCK_SHIFT].get(k & (BLOCK - 1))
    }

    /// Blocks for `len` pairs, pair k set to `fill(k)`, built in parallel: each
    /// block is zeroed and filled by the thread that owns it. (Zeroed memory from the
    /// allocator is no cheaper: the allocator reuses freed memory, which it then
    /// clears on one thread. That took a third of a rebuild's block time on two
    /// threads in a 4.3 pack.)
    fn build_blocks(len: usize, fill: impl Fn(usize) -> PairRecord<D> + Sync) -> Vec<PairBlock<D>> {
        let n = len.div_ceil(BLOCK);
        let mut blocks: Vec<PairBlock<D>> = Vec::with_capacity(n);
        blocks.spare_capacity_mut()[..n]
            .par_iter_mut()
            .with_min_len(REBUILD_MIN_BLOCKS)
            .enumerate()
            .for_each(|(b, slot)| {
                // SAFETY: a PairBlock is arrays of f64 only (no padding, no pointers),
                // and the all-zero bit pattern is 0.0, so the zeroed slot is a valid
                // block.
                let blk = unsafe {
                    std::ptr::write_bytes(slot.as_mut_ptr(), 0, 1);
                    slot.assume_init_mut()
                };
                let base = b * BLOCK;
                for l in 0..BLOCK.min(len - base) {
                    blk.set(l, &fill(base + l));
                }
            });
        // SAFETY: the first n slots were initialised above, and n <= capacity.
        unsafe { blocks.set_len(n) };
        blocks
    }

    /// Reorders every per-pair array: entry k takes the old entry `order[k]`.
    fn permute(&mut self, order: &[u32]) {
        self.ij = order.iter().map(|&k| self.ij[k as usize]).collect();
        self.blocks = Self::build_blocks(order.len(), |k| self.get(order[k] as usize));
    }

    /// Checks the invariant that the unchecked indexing of the force loops relies on:
    /// every particle index in the list is below `n`, every incidence entry below the
    /// pair count, and the per-pair arrays have one entry per pair. Panics otherwise (a
    /// bug in the list's construction, never a user error).
    fn check_indices(&self, n: usize) {
        let m = self.ij.len();
        assert!(self
            .ij
            .iter()
            .all(|&[i, j]| (i as usize) < n && (j as usize) < n));
        assert!(self.j_inc.iter().all(|&k| (k as usize) < m));
        assert!(self.j_start.len() == n + 1 && self.j_inc.len() == m);
        assert!(self.i_frozen.len() == n + 1 && self.i_active.len() == n + 1);
        assert!(self.i_frozen[n] as usize == self.n_frozen_pairs && self.i_active[n] as usize == m);
        assert!(self.i_frozen.windows(2).all(|w| w[0] <= w[1]));
        assert!(self.i_active.windows(2).all(|w| w[0] <= w[1]));
        assert!(self.blocks.len() == m.div_ceil(BLOCK));
    }

    /// Pair indices in (i, j) order: the merge of the two sorted runs.
    fn sorted_order(&self) -> Vec<u32> {
        let (m, na) = (self.ij.len(), self.n_frozen_pairs);
        let mut out = Vec::with_capacity(m);
        let (mut a, mut b) = (0, na);
        while a < na || b < m {
            if b == m || (a < na && self.ij[a] < self.ij[b]) {
                out.push(a as u32);
                a += 1;
            } else {
                out.push(b as u32);
                b += 1;
            }
        }
        out
    }
}

/// Returns spare capacity beyond a quarter of the length (a list that shrank a lot),
/// without reallocating on every small fluctuation.
fn trim<T>(v: &mut Vec<T>) {
    if v.capacity() > v.len() + v.len() / 4 {
        v.shrink_to_fit();
    }
}

/// A wall plane: axis, position, outward normal sign (normal points from the particle
/// to the wall).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Wall {
    axis: usize,
    pos: Real,
    sign: Real,
}

impl Wall {
    /// Distance from `x` to the plane, positive on the box side (m).
    #[inline(always)]
    pub(crate) fn gap<const D: usize>(&self, x: &Vector<D>) -> Real {
        (self.pos - x[self.axis]) * self.sign
    }

    /// Unit normal from a particle towards the wall.
    #[inline(always)]
    pub(crate) fn normal<const D: usize>(&self) -> Vector<D> {
        let mut n = Vector::<D>::zeros();
        n[self.axis] = self.sign;
        n
    }
}

/// The walls of a box in wall-id order (-1 floor, then -2 lo and -3 hi on the first
/// horizontal axis, -4 and -5 on the second): floor at `lo[vertical]`, side walls at
/// `lo[k]` and `hi[k]`; the top is open.
pub(crate) fn box_walls<const D: usize>(lo: &Vector<D>, hi: &Vector<D>) -> Vec<Wall> {
    let vert = D - 1;
    let mut walls = vec![Wall {
        axis: vert,
        pos: lo[vert],
        sign: -1.0,
    }];
    for k in 0..vert {
        walls.push(Wall {
            axis: k,
            pos: lo[k],
            sign: -1.0,
        });
        walls.push(Wall {
            axis: k,
            pos: hi[k],
            sign: 1.0,
        });
    }
    walls
}

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
    /// The pair pass's scratch block, one per team slot (see `team`), kept between
    /// steps: 15 KB each in 3D.
    scratch: Vec<Box<Geometry<D>>>,
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
        let walls = cfg
            .walls
            .as_ref()
            .map_or_else(Vec::new, |(lo, hi)| box_walls(lo, hi));
        Ok(World {
            e_star: cfg.material.e_star(),
            g_star: cfg.material.g_star(),
            cfg,
            p: Particles::default(),
            pairs: Pairs::default(),
            walls,
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
        fn b<T>(v: &[T]) -> usize {
            std::mem::size_of_val(v)
        }
        let p = &self.p;
        let pr = &self.pairs;
        b(&p.x)
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
            + b(&p.wall_hist)
            + b(&p.wall_force)
            + b(&p.frozen)
            + b(&p.wall_mask)
            + b(&p.wall_near)
            + b(&pr.ij)
            + b(&pr.blocks)
            + b(&pr.i_frozen)
            + b(&pr.i_active)
            + b(&pr.j_start)
            + b(&pr.j_inc)
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

    /// Sets (or clears) the freezing of settled particles. Clearing it unfreezes all.
    pub fn set_freeze(&mut self, freeze: Option<FreezeConfig>) -> Result<()> {
        if let Some(f) = &freeze {
            check_range("freeze.speed", f.speed, 0.0, true, f64::INFINITY, false)?;
            check_range(
                "freeze.force_ratio",
                f.force_ratio,
                0.0,
                true,
                f64::INFINITY,
                false,
            )?;
            if f.below.is_nan() {
                return Err(Error::invalid(
                    "freeze.below",
                    f.below,
                    "must not be NaN (m)",
                ));
            }
            if f.interval == 0 {
                return Err(Error::invalid("freeze.interval", 0, "must be >= 1 step"));
            }
        } else if self.n_frozen > 0 {
            self.p.frozen.iter_mut().for_each(|z| *z = false);
            self.n_frozen = 0;
            self.forces_valid = false;
            self.list_valid = false;
        }
        self.freeze = freeze;
        Ok(())
    }

    /// Number of frozen particles.
    pub fn n_frozen(&self) -> usize {
        self.n_frozen
    }

    /// Which particles are frozen.
    pub fn frozen(&self) -> &[bool] {
        &self.p.frozen
    }

    /// Smallest radius (m), infinity when empty.
    pub fn r_min(&self) -> Real {
        self.p.r.iter().cloned().fold(Real::INFINITY, Real::min)
    }

    /// The Rayleigh critical step for the current particles (s).
    pub fn critical_time_step(&self) -> Real {
        self.cfg.material.rayleigh_time_step(self.r_min())
    }

    /// Adds particles. `v` and `w` default to zero. Validates shapes and values (radius
    /// > 0 and finite, finite positions and velocities, inside the box's walls).
    pub fn add_particles(
        &mut self,
        x: &[Vector<D>],
        r: &[Real],
        v: Option<&[Vector<D>]>,
        w: Option<&[Ang<D>]>,
    ) -> Result<()> {
        let n = x.len();
        if r.len() != n {
            return Err(Error::invalid(
                "radii",
                format!("length {}", r.len()),
                &format!("must have one entry per position ({n})"),
            ));
        }
        if let Some(v) = v {
            if v.len() != n {
                return Err(Error::invalid(
                    "velocities",
                    format!("length {}", v.len()),
                    &format!("must have one row per position ({n})"),
                ));
            }
        }
        if let Some(w) = w {
            if w.len() != n {
                return Err(Error::invalid(
                    "spins",
                    format!("length {}", w.len()),
                    &format!("must have one row per position ({n})"),
                ));
            }
        }
        for (k, &rk) in r.iter().enumerate() {
            if !(rk.is_finite() && rk > 0.0) {
                return Err(Error::invalid(
                    &format!("radii[{k}]"),
                    rk,
                    "must be finite and > 0 (m)",
                ));
            }
        }
        for (k, xk) in x.iter().enumerate() {
            if !xk.iter().all(|c| c.is_finite()) {
                return Err(Error::invalid(
                    &format!("positions[{k}]"),
                    format!("{:?}", xk.as_slice()),
                    "must be finite (m)",
                ));
            }
            for wall in &self.walls {
                let s = wall.gap(xk);
                if s < 0.0 {
                    return Err(Error::invalid(
                        &format!("positions[{k}]"),
                        format!("{:?}", xk.as_slice()),
                        "centre lies outside the box's walls",
                    ));
                }
            }
        }
        if let Some(v) = v {
            for (k, vk) in v.iter().enumerate() {
                if !vk.iter().all(|c| c.is_finite()) {
                    return Err(Error::invalid(
                        &format!("velocities[{k}]"),
                        format!("{:?}", vk.as_slice()),
                        "must be finite (m/s)",
                    ));
                }
            }
        }
        if let Some(w) = w {
            for (k, wk) in w.iter().enumerate() {
                if !wk.finite() {
                    return Err(Error::invalid(
                        &format!("spins[{k}]"),
                        format!("{wk:?}"),
                        "must be finite (rad/s)",
                    ));
                }
            }
        }
        let rho = self.cfg.material.density;
        for k in 0..n {
            let rk = r[k];
            let (m, inertia) = if D == 2 && self.cfg.inertia_2d == Inertia2D::Disc {
                let m = std::f64::consts::PI * rk * rk * rho;
                (m, 0.5 * m * rk * rk)
            } else {
                let m = 4.0 / 3.0 * std::f64::consts::PI * rk * rk * rk * rho;
                (m, 0.4 * m * rk * rk)
            };
            self.p.x.push(x[k]);
            self.p.x_ref.push(x[k]);
            self.p.half_skin.push(0.0);
            self.p.v.push(v.map_or(Vector::<D>::zeros(), |v| v[k]));
            self.p.f.push(Vector::<D>::zeros());
            let wk = if self.cfg.rotations {
                w.map_or(Ang::<D>::default(), |w| w[k])
            } else {
                Ang::<D>::default()
            };
            self.p.w.push(wk);
            self.p.t.push(Ang::<D>::default());
            self.p.r.push(rk);
            self.p.m.push(m);
            self.p.inv_m.push(1.0 / m);
            self.p.inv_i.push(1.0 / inertia);
            self.p.wall_hist.push([Vector::<D>::zeros(); MAX_WALLS]);
            self.p.wall_force.push([Vector::<D>::zeros(); MAX_WALLS]);
            self.p.frozen.push(false);
            self.p.wall_mask.push(0);
            self.p.wall_near.push(0);
        }
        self.forces_valid = false;
        self.list_valid = false;
        self.dt_checked = false;
        self.energy_ref = None;
        Ok(())
    }

    /// Overwrites velocities (m/s) of all particles.
    pub fn set_velocities(&mut self, v: &[Vector<D>]) -> Result<()> {
        if v.len() != self.len() || !v.iter().all(|x| x.iter().all(|c| c.is_finite())) {
            return Err(Error::invalid(
                "velocities",
                format!("{} rows", v.len()),
                &format!("must be {} finite rows", self.len()),
            ));
        }
        self.p.v.copy_from_slice(v);
        self.forces_valid = false;
        self.energy_ref = None;
        Ok(())
    }

    /// Overwrites spins (rad/s) of all particles (ignored when rotations are off).
    pub fn set_spins(&mut self, w: &[Ang<D>]) -> Result<()> {
        if w.len() != self.len() || !w.iter().all(|x| x.finite()) {
            return Err(Error::invalid(
                "spins",
                format!("{} rows", w.len()),
                &format!("must be {} finite rows", self.len()),
            ));
        }
        if self.cfg.rotations {
            self.p.w.copy_from_slice(w);
        }
        self.forces_valid = false;
        self.energy_ref = None;
        Ok(())
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
    /// run stops there. Returns whether all `n` steps were taken. Chunking changes
    /// nothing in the results: a step depends on the step counter, never on where a
    /// call began.
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
                return Ok(left == 0);
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
        self.cfg.rotations && self.cfg.material.friction > 0.0
    }

    /// Step part 1: the first half kick and the drift of every particle that is not
    /// frozen (`FROZEN`: some are), and of the spins with `TORQUE` (rotations and
    /// friction on). Returns whether a particle has moved more than its half skin since
    /// the last rebuild (or turned non-finite).
    fn kick_drift<const TORQUE: bool, const FROZEN: bool>(&mut self, team: &mut Team) -> bool {
        let dt = self.cfg.dt;
        let half = 0.5 * dt;
        let p = &mut self.p;
        let len = p.x.len();
        let (xs, vs, ws) = (
            Disjoint::new(&mut p.x),
            Disjoint::new(&mut p.v),
            Disjoint::new(&mut p.w),
        );
        let (fs, ims, xrs, hs, fzs, ts, iis) = (
            &p.f,
            &p.inv_m,
            &p.x_ref,
            &p.half_skin,
            &p.frozen,
            &p.t,
            &p.inv_i,
        );
        team.map_reduce(
            len.div_ceil(TEAM_CHUNK),
            false,
            |c, _| {
                let r = c * TEAM_CHUNK..(c * TEAM_CHUNK + TEAM_CHUNK).min(len);
                // SAFETY: the items' ranges are disjoint.
                let (x, v, w) = unsafe {
                    (
                        xs.range(r.clone()),
                        vs.range(r.clone()),
                        ws.range(r.clone()),
                    )
                };
                let (f, im, xr, h) = (
                    &fs[r.clone()],
                    &ims[r.clone()],
                    &xrs[r.clone()],
                    &hs[r.clone()],
                );
                let (fz, t, ii) = (&fzs[r.clone()], &ts[r.clone()], &iis[r]);
                kick_drift_chunk::<D, TORQUE, FROZEN>(
                    KickDrift { x, v, w },
                    f,
                    im,
                    xr,
                    h,
                    fz,
                    t,
                    ii,
                    dt,
                    half,
                )
            },
            |a, b| a | b,
        )
    }

    /// Rebuilds the Verlet list and carries the tangential history of surviving pairs
    /// over (old and new runs are sorted by (i, j), so a merge suffices).
    ///
    /// With particles frozen only the pairs with an active particle are searched: the
    /// frozen run is kept as it is. Its pairs stay valid for good, because frozen
    /// particles do not move; a thaw moves the thawed particle's pairs out of the frozen
    /// run (`partition_pairs`) and asks for a rebuild, which searches them afresh.
    fn rebuild_pairs(&mut self) {
        let start = std::time::Instant::now();
        let r_min = self.r_min();
        // Each particle's half skin lasts about SKIN_STEPS steps at its own speed,
        // within [floor, largest] / 2: the falling layer keeps a wide skin, the resting
        // bed a narrow one (fewer pairs to test every step). A pair is listed within
        // h_i + h_j of contact, i.e. within reach r_i + h_i + r_j + h_j.
        let widest = if r_min.is_finite() {
            self.cfg.skin_ratio * r_min
        } else {
            0.0
        };
        let (lo, hi) = (0.5 * SKIN_FLOOR * widest, 0.5 * widest);
        let steps = self.cfg.dt * SKIN_STEPS;
        let p = &mut self.p;
        p.half_skin
            .par_iter_mut()
            .zip(p.v.par_iter())
            .with_min_len(REBUILD_MIN_PARTICLES)
            .for_each(|(h, v)| *h = (v.norm() * steps).clamp(lo, hi));
        let reach: Vec<Real> = p.r.iter().zip(&p.half_skin).map(|(r, h)| r + h).collect();
        let partial = self.n_frozen > 0;
        let mut pr = std::mem::take(&mut self.pairs);
        let (ij, keep) = if partial {
            let fz = &self.p.frozen;
            let ij = neighbor_pairs_active(&self.p.x, &reach, |i| !fz[i]);
            (ij, pr.n_frozen_pairs)
        } else {
            (neighbor_pairs(&self.p.x, &reach), 0)
        };
        drop(reach);
        // Old pairs that may survive, in (i, j) order: the active run, or everything.
        let old_order: Vec<u32> = if partial {
            (pr.n_frozen_pairs as u32..pr.ij.len() as u32).collect()
        } else {
            pr.sorted_order()
        };
        // For each new pair, the old pair it continues (u32::MAX: a new contact): a
        // merge of the two sorted lists, in parallel chunks of the new one, each
        // starting where a binary search puts its first pair among the old ones.
        let mut src = vec![u32::MAX; ij.len()];
        let old_ij = &pr.ij;
        src.par_chunks_mut(PAIR_CHUNK)
            .zip(ij.par_chunks(PAIR_CHUNK))
            .for_each(|(src, new)| {
                let mut a = old_order.partition_point(|&o| old_ij[o as usize] < new[0]);
                for (s, pair) in src.iter_mut().zip(new) {
                    while a < old_order.len() && old_ij[old_order[a] as usize] < *pair {
                        a += 1;
                    }
                    if a < old_order.len() && old_ij[old_order[a] as usize] == *pair {
                        *s = old_order[a];
                    }
                }
            });
        drop(old_order);
        // The kept frozen run stays in front; the other pairs carry their state over,
        // or start from zero with fresh law factors.
        let r = &self.p.r;
        let mass = &self.p.m;
        let mat = self.cfg.material;
        let (e_star, g_star) = (self.e_star, self.g_star);
        let old = &pr;
        let blocks = Pairs::<D>::build_blocks(keep + ij.len(), |k| {
            if k < keep {
                return old.get(k);
            }
            let o = src[k - keep];
            if o != u32::MAX {
                // a surviving pair: its history, and its factors (radii and masses
                // never change)
                return old.get(o as usize);
            }
            let mut rec = PairRecord::default();
            let [i, j] = ij[k - keep];
            let (ri, rj) = (r[i as usize], r[j as usize]);
            let (mi, mj) = (mass[i as usize], mass[j as usize]);
            rec.coefs = PairFactors::new(&PairParams {
                r_eff: ri * rj / (ri + rj),
                m_eff: mi * mj / (mi + mj),
                e_star,
                g_star,
                damping: mat.damping,
                friction: mat.friction,
            });
            rec
        });
        pr.blocks = blocks;
        drop(src);
        pr.ij.truncate(keep);
        pr.ij.extend_from_slice(&ij);
        trim(&mut pr.ij);
        drop(ij);
        pr.n_frozen_pairs = keep;
        self.pairs = pr;
        if partial {
            self.build_incidence();
        } else {
            self.partition_pairs();
        }
        self.p.x_ref.copy_from_slice(&self.p.x);
        // No particle moves more than its h before the next rebuild, so only walls
        // within r + h can be touched meanwhile (r + 2h for margin): the gather skips
        // the others.
        let (p, walls) = (&mut self.p, &self.walls);
        p.wall_near
            .par_iter_mut()
            .zip(p.x.par_iter())
            .zip(p.r.par_iter().zip(p.half_skin.par_iter()))
            .with_min_len(REBUILD_MIN_PARTICLES)
            .for_each(|((near, x), (r, h))| {
                *near = 0;
                for (wi, wall) in walls.iter().enumerate() {
                    if wall.gap(x) < r + 2.0 * h {
                        *near |= 1 << wi;
                    }
                }
            });
        self.list_valid = true;
        self.rebuilds += 1;
        self.rebuild_seconds += start.elapsed().as_secs_f64();
    }

    /// Puts the pairs of two frozen particles in front of the others (both runs in
    /// (i, j) order) and rebuilds the incidence lists. Runs after every full rebuild and
    /// whenever particles freeze or thaw.
    fn partition_pairs(&mut self) {
        let fz = &self.p.frozen;
        let pr = &mut self.pairs;
        // Nothing frozen now or before: the list is already one sorted run.
        if self.n_frozen > 0 || pr.n_frozen_pairs > 0 {
            let both = |k: &u32| {
                let [i, j] = pr.ij[*k as usize];
                fz[i as usize] && fz[j as usize]
            };
            let (frozen, active): (Vec<u32>, Vec<u32>) =
                pr.sorted_order().into_iter().partition(both);
            pr.n_frozen_pairs = frozen.len();
            pr.permute(&[frozen, active].concat());
        }
        self.build_incidence();
    }

    /// Incidence: for each particle the ranges of the pairs it starts (one per run)
    /// and the list of those it ends, in list order.
    fn build_incidence(&mut self) {
        let pr = &mut self.pairs;
        let n = self.p.x.len();
        let nf = pr.n_frozen_pairs;
        // Runs sorted by i: the range of particle p in a run is its bin in a counting
        // sort of the run by i (the run is already in that order).
        let (run_f, run_a) = pr.ij.split_at(nf);
        pr.i_frozen = bin_starts(nf, n, |k| run_f[k][0] as usize, 0);
        pr.i_active = bin_starts(run_a.len(), n, |k| run_a[k][0] as usize, nf);
        let ij = &pr.ij;
        let (j_start, j_inc) = counting_sort(ij.len(), n, |k| ij[k][1] as usize);
        pr.j_start = j_start;
        pr.j_inc = j_inc;
        pr.check_indices(n);
    }

    /// The contacts in force at the last force evaluation (overlap > 0), pairs first in
    /// (i, j) order, then wall contacts by particle and wall.
    pub fn contacts(&mut self) -> Result<Contacts<D>> {
        if !self.list_valid {
            self.rebuild_pairs();
        }
        if !self.forces_valid && !self.is_empty() {
            self.compute_forces()?;
        }
        let mut out = Contacts::<D>::default();
        let pr = &self.pairs;
        for k in pr.sorted_order() {
            let k = k as usize;
            let rec = pr.get(k);
            if rec.d <= 0.0 {
                continue;
            }
            let [i, j] = pr.ij[k];
            let dx = self.p.x[j as usize] - self.p.x[i as usize];
            // the engine's normal, to the bit (see `geometry_block`)
            let n = dx * (1.0 / dx.norm());
            let fv = Vector::<D>::from(rec.f);
            let fn_ = fv.dot(&n);
            out.i.push(i as i64);
            out.j.push(j as i64);
            out.normal.push(n);
            out.overlap.push(rec.d);
            out.force_normal.push(fn_.max(0.0));
            out.force_tangential.push(fv - n * fn_);
            out.branch.push(dx);
        }
        for q in 0..self.len() {
            for (wi, wall) in self.walls.iter().enumerate() {
                let s = wall.gap(&self.p.x[q]);
                let d = self.p.r[q] - s;
                if d <= 0.0 {
                    continue;
                }
                let n = wall.normal::<D>();
                let fv = self.p.wall_force[q][wi];
                let fn_ = fv.dot(&n);
                out.i.push(q as i64);
                out.j.push(-(wi as i64) - 1);
                out.normal.push(n);
                out.overlap.push(d);
                out.force_normal.push(fn_.max(0.0));
                out.force_tangential.push(fv - n * fn_);
                out.branch.push(n * (self.p.r[q] - 0.5 * d));
            }
        }
        Ok(out)
    }
}

/// What kick/drift changes in one chunk of particles.
struct KickDrift<'a, const D: usize>
where
    Dim<D>: Spatial<D>,
{
    x: &'a mut [Vector<D>],
    v: &'a mut [Vector<D>],
    w: &'a mut [Ang<D>],
}

crate::cpu::multiversion! {
/// Kick/drift of one chunk (see [`World::kick_drift`]); compiled for each
/// instruction-set level (see [`crate::cpu`]).
fn kick_drift_chunk [const D: usize, const TORQUE: bool, const FROZEN: bool] (
    s: KickDrift<D>,
    f: &[Vector<D>],
    im: &[Real],
    xr: &[Vector<D>],
    h: &[Real],
    fz: &[bool],
    t: &[Ang<D>],
    ii: &[Real],
    dt: Real,
    half: Real,
) -> bool where [Dim<D>: Spatial<D>] [D, TORQUE, FROZEN] {
    let mut moved = false;
    // Every chunk slice cut to one length: the loop then runs without bounds checks.
    let n = s.x.len();
    let (x, v, w) = (&mut s.x[..n], &mut s.v[..n], &mut s.w[..n]);
    let (f, im, xr, h, fz) = (&f[..n], &im[..n], &xr[..n], &h[..n], &fz[..n]);
    let (t, ii) = (&t[..n], &ii[..n]);
    for k in 0..n {
        if FROZEN && fz[k] {
            continue;
        }
        v[k] += f[k] * (im[k] * half);
        x[k] += v[k] * dt;
        // written so that NaN also trips it
        let d2 = (x[k] - xr[k]).norm_squared();
        moved |= d2.is_nan() | (d2 > h[k] * h[k]);
        if TORQUE {
            w[k] += t[k] * (ii[k] * half);
        }
    }
    moved
}
}

#[cfg(test)]
mod tests {
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
        let err = b.step_n(MAX_STEPS_PER_CALL + 1).unwrap_err();
        assert!(err.to_string().contains("steps per call"), "{err}");
        let err = b.run(1e300).unwrap_err();
        assert!(err.to_string().contains("seconds"), "{err}");
        assert_eq!(b.steps(), 516);
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
            let f = 4.0 / 3.0 * e_star * r_eff.sqrt() * d.powf(1.5)
                + 2.0 * xi * (m_eff * kn).sqrt() * u;
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

    /// The particle pairs `contacts()` reports are exactly the overlapping pairs of a
    /// brute-force search on the current positions (the pair list lost none).
    fn assert_contacts_are_the_overlaps<const D: usize>(w: &mut World<D>)
    where
        Dim<D>: Spatial<D>,
    {
        let c = w.contacts().unwrap();
        let mut got: Vec<[u32; 2]> =
            c.i.iter()
                .zip(&c.j)
                .filter(|(_, &j)| j >= 0)
                .map(|(&i, &j)| [i as u32, j as u32])
                .collect();
        got.sort();
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
        w.set_freeze(Some(FreezeConfig {
            below: 0.1,
            speed: 1e-2,
            force_ratio: 0.3,
            interval: 10,
        }))
        .unwrap();
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

    /// The one-sweep force pass gives the same bits as the two passes, on one and on
    /// three threads (three pieces, so particles with pairs in two pieces are gathered
    /// after the sweep), with a frozen bed that a second batch lands on and thaws.
    #[test]
    fn force_sweep_equals_two_passes() {
        use rand::SeedableRng;
        let cfg = falling_box(0.4);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let (x1, r1) = lattice(&mut rng, 12, 4, 0.015);
        let (x2, r2) = lattice(&mut rng, 12, 4, 0.2);
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
                    speed: 1e-2,
                    force_ratio: 0.3,
                    interval: 10,
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
        let before = cpu::level();
        let mut seen = Vec::new();
        for l in cpu::available() {
            cpu::set_level(l).unwrap();
            assert_eq!(cpu::level(), l);
            seen.push((l, run3(false), run3(true), run2()));
        }
        cpu::set_level(before).unwrap();
        let first = seen[0];
        for s in &seen {
            assert_eq!(
                (s.1, s.2, s.3),
                (first.1, first.2, first.3),
                "{} against {}",
                s.0.name(),
                first.0.name()
            );
        }
        // the sweep and the two passes agree too
        assert_eq!(first.1, first.2);
    }
}
