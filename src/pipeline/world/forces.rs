//! Forces: the pair pass (the particle data of a run of pairs gathered into a scratch,
//! then the geometry and the law vectorised over the run, which write each pair's state
//! in place), the per-particle gather with walls and body forces (and, during a step, the
//! second half kick), and the freezing decisions that need every particle's net force.
//! Small scenes run the pair pass and the gather as two passes; large ones as one sweep
//! that gathers each particle as soon as its pairs are done (`SWEEP_MIN_BYTES`).

use super::*;

/// `s[i]` without the bounds check, for the two hottest loops, which index particle
/// arrays with pair-list entries and pair arrays with incidence entries (about 8 % of
/// a step's instructions were those checks).
///
/// # Safety
/// `i < s.len()`. Holds for the indices used here because `rebuild_pairs` checks
/// (`Pairs::check_indices`) that every particle index in the pair list is below the
/// particle count and every incidence entry below the pair count, and particles are
/// never removed; debug builds check each access again.
#[inline(always)]
unsafe fn at<T: Copy>(s: &[T], i: usize) -> T {
    debug_assert!(i < s.len());
    // SAFETY: the caller guarantees i < s.len().
    unsafe { *s.get_unchecked(i) }
}

/// `&s[i]` without the bounds check, as [`at`].
///
/// # Safety
/// `i < s.len()`, as for [`at`].
#[inline(always)]
unsafe fn at_ref<T>(s: &[T], i: usize) -> &T {
    debug_assert!(i < s.len());
    // SAFETY: the caller guarantees i < s.len().
    unsafe { s.get_unchecked(i) }
}

/// Lane `l` of a block (`l` taken modulo [`BLOCK`], so a pair index serves): the
/// pair's force on j.
#[inline(always)]
fn lane_force<const D: usize>(b: &PairBlock<D>, l: usize) -> Vector<D>
where
    Dim<D>: Spatial<D>,
{
    let l = l & (BLOCK - 1);
    Vector::<D>::from_fn(|a, _| b.f[a][l])
}

/// Lane `l` of a block, as [`lane_force`], with the torque of the pair's tangential
/// force on the end of radius `r` (m): -(r - d/2) n x f_t. Until 2026-11-23 (bec5e4f) the law
/// stored this product for both ends; the gather now forms it from the same factors in
/// the same order, so the sums keep their bits; the pair record is 24 bytes smaller.
#[inline(always)]
fn lane_force_torque<const D: usize>(b: &PairBlock<D>, l: usize, r: Real) -> (Vector<D>, Ang<D>)
where
    Dim<D>: Spatial<D>,
{
    let f = lane_force(b, l);
    let l = l & (BLOCK - 1);
    let arm = -(r - 0.5 * b.d[l]);
    let mut c = [0.0; 3];
    for (a, x) in c.iter_mut().enumerate().take(<Ang<D> as AngOps>::NCOMP) {
        *x = b.t[a][l] * arm;
    }
    (f, <Ang<D> as AngOps>::from_comps(&c))
}

/// Calls `visit(block, lane)` for the pairs `range` of the list, in order, a block
/// at a time (no index arithmetic per pair).
#[inline(always)]
fn for_lanes<const D: usize>(
    blocks: &[PairBlock<D>],
    range: std::ops::Range<usize>,
    mut visit: impl FnMut(&PairBlock<D>, usize),
) {
    let (mut e, end) = (range.start, range.end);
    while e < end {
        let b = &blocks[e >> BLOCK_SHIFT];
        let l0 = e & (BLOCK - 1);
        let l1 = (l0 + (end - e)).min(BLOCK);
        for l in l0..l1 {
            visit(b, l);
        }
        e += l1 - l0;
    }
}

/// Block of pair e.
///
/// # Safety
/// `e >> BLOCK_SHIFT < blocks.len()` (see `at`).
#[inline(always)]
unsafe fn block_of<const D: usize>(blocks: &[PairBlock<D>], e: usize) -> &PairBlock<D> {
    // SAFETY: the caller guarantees the block exists.
    unsafe { at_ref(blocks, e >> BLOCK_SHIFT) }
}

/// Pair e's rolling moment on its second particle, R* n x f_r, as a spin-space
/// vector (three components in 3D, one in 2D).
///
/// # Safety
/// `e >> BLOCK_SHIFT < roll.len()`: the rolling blocks match the pair blocks
/// (`Pairs::check_indices`), whose bound holds as for [`block_of`].
#[inline(always)]
unsafe fn roll_moment<const D: usize>(roll: &[RollBlock<D>], e: usize) -> Ang<D>
where
    Dim<D>: Spatial<D>,
{
    // SAFETY: the caller's.
    let (b, l) = (unsafe { at_ref(roll, e >> BLOCK_SHIFT) }, e & (BLOCK - 1));
    let mut c = [0.0; 3];
    for (a, x) in c.iter_mut().enumerate().take(<Ang<D> as AngOps>::NCOMP) {
        *x = b.m[a][l];
    }
    <Ang<D> as AngOps>::from_comps(&c)
}

impl<const D: usize> World<D>
where
    Dim<D>: Spatial<D>,
{
    /// Pair forces, then the per-particle gather with walls and body forces, for every
    /// particle (frozen ones included).
    pub(super) fn compute_forces(&mut self) -> Result<()> {
        Team::scoped(|team| self.compute_forces_inner(true, false, team)).map(|_| ())
    }

    /// Pair forces and the gather. With `all` false, pairs of two frozen particles
    /// keep their stored force and frozen particles are not gathered.
    ///
    /// With `kick`, each particle that is not frozen also takes the step's second half
    /// kick (v += f dt / 2m, and w += t dt / 2I when rotations and friction are on: no
    /// torque acts otherwise) as soon as its force is known, which saves a pass over the
    /// particles. Returns whether any velocity after the kick is
    /// non-finite or would carry its particle more than half its radius in one step (it
    /// could tunnel through a neighbour); always false without `kick`.
    /// The loops run on `team`, or on rayon for large scenes (the sweep: it pauses the
    /// team).
    pub(super) fn compute_forces_inner(
        &mut self,
        all: bool,
        kick: bool,
        team: &mut Team,
    ) -> Result<bool> {
        let max_ratio = self.cfg.max_overlap_ratio;
        // The pass compiled once per combination of what is switched on, so that the
        // common cases carry no tests of switches that are off, nor the frozen run's
        // bookkeeping when nothing is frozen.
        let frozen = self.n_frozen > 0 || self.pairs.n_frozen_pairs > 0;
        let (bad_pair, bad_wall, suspicious) = match (self.torques_on(), kick, frozen) {
            (false, false, false) => self.forces::<false, false, false>(all, team),
            (false, false, true) => self.forces::<false, false, true>(all, team),
            (false, true, false) => self.forces::<false, true, false>(all, team),
            (false, true, true) => self.forces::<false, true, true>(all, team),
            (true, false, false) => self.forces::<true, false, false>(all, team),
            (true, false, true) => self.forces::<true, false, true>(all, team),
            (true, true, false) => self.forces::<true, true, false>(all, team),
            (true, true, true) => self.forces::<true, true, true>(all, team),
        };
        let p = &self.p;
        if let Some(k) = bad_pair {
            let [i, j] = self.pairs.ij[k];
            let d = self.pairs.get(k).d;
            let rmin = p.r[i as usize].min(p.r[j as usize]);
            return Err(Error::Blowup {
                step: self.steps,
                time: self.time,
                particle: i as usize,
                kind: BlowupKind::Overlap,
                what: format!(
                    "overlap with particle {j} is {d:e} m = {:.3} of the smaller radius \
                     (limit max_overlap_ratio = {max_ratio}); reduce dt: the contact is not resolved",
                    d / rmin
                ),
            });
        }
        if let Some((q, wi, d)) = bad_wall {
            return Err(Error::Blowup {
                step: self.steps,
                time: self.time,
                particle: q,
                kind: BlowupKind::WallOverlap,
                what: format!(
                    "overlap with wall {} is {d:e} m = {:.3} of its radius \
                     (limit max_overlap_ratio = {max_ratio})",
                    -(wi as i64) - 1,
                    d / p.r[q]
                ),
            });
        }
        self.forces_valid = true;
        Ok(suspicious)
    }

    /// Steps 3-5 of [`compute_forces_inner`](Self::compute_forces_inner): the pair
    /// pass, the gather with walls and body forces, and with `KICK` the second half
    /// kick. `TORQUE`: rotations and friction both on (tangential torques to gather,
    /// spins to kick); `FROZEN`: some particles are frozen or the pair list has a
    /// frozen run (with it false, no particle is frozen and the list is one run).
    ///
    /// The pass is one sweep over the active run of the pair list, in (i, j) order, in
    /// which each particle is gathered as soon as its last pair has been computed:
    /// its pairs' forces are then still in the first cache levels, where two separate
    /// passes read them back from the last level or memory (half of the second level's
    /// misses were the gather's). Pairs (i, q) precede (q, j) in that order, so particle
    /// q is complete once the sweep has passed its own pairs. With several threads the
    /// run is cut into one contiguous piece per thread; a particle with a pair in an
    /// earlier piece, or with pairs in the next one, is gathered after the sweep.
    /// Either way each particle's sum runs over its pairs in the same order, so the
    /// result is the same on any thread count.
    ///
    /// Returns the first pair too deep (list index), the too-deep wall contact of the
    /// lowest particle, and whether a kicked velocity looks unsafe.
    #[allow(clippy::type_complexity)]
    fn forces<const TORQUE: bool, const KICK: bool, const FROZEN: bool>(
        &mut self,
        all: bool,
        team: &mut Team,
    ) -> (Option<usize>, Option<(usize, usize, Real)>, bool) {
        debug_assert_eq!(self.torques_on(), TORQUE);
        let skip_frozen = !all && self.n_frozen > 0;
        let mat = self.cfg.material;
        let dt = self.cfg.dt;
        let consts = match mat.law {
            ContactLaw::HertzMindlin => {
                LawConsts::new(self.e_star, self.g_star, mat.damping, mat.friction)
            }
            ContactLaw::Linear { kn, kt } => LawConsts::linear(kn, kt, mat.damping, mat.friction),
        };
        // rolling acts through spins: nothing to do without rotations
        let roll = (self.cfg.rotations && mat.has_rolling()).then(|| RollCoefs::new(&mat.rolling));
        let law = LawPass {
            consts,
            roll,
            dt,
            rot: self.cfg.rotations,
            torques: TORQUE,
            max_ratio: self.cfg.max_overlap_ratio,
        };
        let scratch = &mut self.scratch;
        let p = &mut self.p;
        let n = p.x.len();
        // Velocities and spins are read by the pair pass (of other particles) while
        // the gather kicks those of complete particles: both go through pointers.
        let out = GatherOut::<D> {
            f: SyncPtr(p.f.as_mut_ptr()),
            t: SyncPtr(p.t.as_mut_ptr()),
            wh: SyncPtr(p.wall_hist.as_mut_ptr()),
            wf: SyncPtr(p.wall_force.as_mut_ptr()),
            wm: SyncPtr(p.wall_mask.as_mut_ptr()),
            wr: SyncPtr(p.wall_roll.as_mut_ptr()),
            v: SyncPtr(p.v.as_mut_ptr()),
            w: SyncPtr(p.w.as_mut_ptr()),
        };
        let pin = PairIn::<D> {
            x: &p.x,
            r: &p.r,
            v: out.v,
            w: out.w,
            period: self.period,
        };
        let Pairs {
            ij,
            n_frozen_pairs,
            blocks,
            roll: roll_blocks,
            roll_on: _,
            i_frozen,
            i_active,
            j_start,
            j_inc,
        } = &mut self.pairs;
        let (ij, a0, len) = (&ij[..], *n_frozen_pairs, ij.len());
        let gin = GatherIn::<D> {
            x: &p.x,
            r: &p.r,
            m: &p.m,
            fz: &p.frozen,
            inv_m: &p.inv_m,
            inv_i: &p.inv_i,
            wall_near: &p.wall_near,
            i_frozen,
            i_active,
            j_start,
            j_inc,
            walls: &self.walls,
            wall_rate: &self.wall_rate,
            local_damping: self.local_damping,
            params: PairParams {
                r_eff: 0.0,
                m_eff: 0.0,
                e_star: self.e_star,
                g_star: self.g_star,
                damping: mat.damping,
                // walls only (the pairs' friction is in `law`)
                friction: self.wall_friction.unwrap_or(mat.friction),
            },
            law: mat.law,
            roll: law.roll,
            gravity: self.cfg.gravity,
            drag: self.cfg.drag,
            dt,
            half: 0.5 * dt,
            // the tunnelling guard: |v| > r / (2 dt), as v^2 > r^2 / (4 dt^2)
            guard: 0.25 / (dt * dt),
            max_ratio: law.max_ratio,
            rot: law.rot,
        };

        // Two passes (all pairs, then all particles) while the pair state fits in
        // the caches; one sweep that gathers each particle as soon as its pairs are
        // done once it does not (see `SWEEP_MIN_BYTES`). Both give the same bits.
        if len * std::mem::size_of::<PairBlock<D>>() / BLOCK < self.sweep_min_bytes {
            let first = if skip_frozen { a0 } else { 0 };
            // SAFETY: no particle is gathered during this pass.
            let bad_pair = unsafe {
                pair_pass(
                    team,
                    scratch,
                    blocks,
                    roll_blocks,
                    first..len,
                    ij,
                    &pin,
                    &law,
                )
            };
            let (blocks, roll_blocks) = (&blocks[..], &roll_blocks[..]);
            let Gathered {
                bad_wall,
                suspicious,
            } = team.map_reduce(
                n.div_ceil(TEAM_CHUNK),
                Gathered::default(),
                |c, _| {
                    let qs = c * TEAM_CHUNK..(c * TEAM_CHUNK + TEAM_CHUNK).min(n);
                    // SAFETY: every pair is computed, and each particle is gathered
                    // once, by this job.
                    unsafe {
                        gather_each::<D, TORQUE, KICK, FROZEN, _>(
                            &gin,
                            out,
                            (blocks, roll_blocks),
                            qs,
                            skip_frozen,
                        )
                    }
                },
                Gathered::merge,
            );
            return (bad_pair, bad_wall, suspicious);
        }
        // The sweep runs on rayon.
        team.pause();

        // 3a. The frozen run, when it is recomputed (freeze decisions), on its own
        // first: only frozen particles, which the sweep leaves to the end, read it.
        let mut bad_pair = None;
        if !skip_frozen && a0 > 0 {
            bad_pair = Team::scoped(|team| {
                // SAFETY: no particle is gathered during this pass.
                unsafe { pair_pass(team, scratch, blocks, roll_blocks, 0..a0, ij, &pin, &law) }
            });
        }

        // 3b-5. The sweep over the active run [a0, len), one piece per thread. Piece
        // k holds pairs [cut[k], cut[k + 1]) (cuts inside the run on block
        // boundaries, so that each piece owns its blocks) and the particles whose
        // active pairs start in it, [q_cut[k], q_cut[k + 1]).
        // (the sweep runs on large systems only; the cut is for the tests' small ones)
        let pieces = if len - a0 < 4 * BLOCK {
            1
        } else {
            rayon::current_num_threads().max(1)
        };
        let mut cut: Vec<usize> = (0..=pieces)
            .map(|k| {
                (a0 + (len - a0) * k / pieces)
                    .next_multiple_of(BLOCK)
                    .min(len)
            })
            .collect();
        (cut[0], cut[pieces]) = (a0, len);
        let starts = &gin.i_active[..n];
        let mut q_cut: Vec<usize> = cut
            .iter()
            .map(|&c| starts.partition_point(|&s| (s as usize) < c))
            .collect();
        (q_cut[0], q_cut[pieces]) = (0, n);
        // first block of each piece; the last piece ends at the last block
        let mut block_cut: Vec<usize> = cut.iter().map(|&c| c.div_ceil(BLOCK)).collect();
        block_cut[0] = a0 >> BLOCK_SHIFT;
        block_cut[pieces] = blocks.len();
        let mut owned = Vec::with_capacity(pieces);
        let mut rest = &mut blocks[block_cut[0]..];
        let rolls = !roll_blocks.is_empty();
        let mut rest_roll = if rolls {
            &mut roll_blocks[block_cut[0]..]
        } else {
            &mut roll_blocks[..]
        };
        for k in 0..pieces {
            let take = block_cut[k + 1] - block_cut[k];
            let (head, tail) = rest.split_at_mut(take);
            let (head_roll, tail_roll) = if rolls {
                rest_roll.split_at_mut(take)
            } else {
                rest_roll.split_at_mut(0)
            };
            owned.push((k, head, head_roll));
            rest = tail;
            rest_roll = tail_roll;
        }
        let swept: Vec<Sweep> = owned
            .into_par_iter()
            .map_init(
                || Box::new(Geometry::<D>::default()),
                |g, (k, own, own_roll)| {
                    let piece = Piece {
                        pairs: cut[k]..cut[k + 1],
                        particles: q_cut[k]..q_cut[k + 1],
                        b0: block_cut[k],
                        a0,
                        skip_frozen,
                    };
                    // SAFETY: the pieces' blocks and particles are disjoint, and each
                    // piece gathers a particle only once the sweep has passed its pairs.
                    unsafe {
                        sweep_piece::<D, TORQUE, KICK, FROZEN>(
                            (own, own_roll),
                            g,
                            &piece,
                            ij,
                            &pin,
                            &law,
                            &gin,
                            out,
                        )
                    }
                },
            )
            .collect();
        let bad_pair = swept
            .iter()
            .filter_map(|s| s.bad_pair)
            .chain(bad_pair)
            .min();

        // The particles left over, with every pair computed now.
        let (blocks, roll_blocks) = (&blocks[..], &roll_blocks[..]);
        let late: Vec<u32> = swept
            .iter()
            .flat_map(|s| s.deferred.iter().copied())
            .collect();
        let late = late
            .par_chunks(64)
            .map(|qs| {
                let qs = qs.iter().map(|&q| q as usize);
                // SAFETY: each particle is deferred once, and nothing else runs.
                unsafe {
                    gather_each::<D, TORQUE, KICK, FROZEN, _>(
                        &gin,
                        out,
                        (blocks, roll_blocks),
                        qs,
                        false,
                    )
                }
            })
            .reduce(Gathered::default, Gathered::merge);
        let all = swept.iter().fold(late, |a, s| a.merge(s.gathered));
        (bad_pair, all.bad_wall, all.suspicious)
    }
}

/// Pair state (bytes) from which the force pass runs as one sweep instead of two
/// passes. On the project's 2-core machine (32 MiB of last-level cache) the sweep was
/// 3-7 % slower on the 8 952-sphere pack (3 MB of pair state, which the second pass
/// finds in the last level) and 10-20 % faster on 80 568 spheres (28 MB).
pub(super) const SWEEP_MIN_BYTES: usize = 8 << 20;

/// What gathers report: the too-deep wall contact of the lowest particle (particle,
/// wall, overlap) and whether a kicked velocity looked unsafe.
#[derive(Clone, Copy, Default)]
struct Gathered {
    bad_wall: Option<(usize, usize, Real)>,
    suspicious: bool,
}

impl Gathered {
    /// Both reports together.
    fn merge(self, b: Gathered) -> Gathered {
        Gathered {
            bad_wall: [self.bad_wall, b.bad_wall]
                .into_iter()
                .flatten()
                .min_by_key(|e| e.0),
            suspicious: self.suspicious | b.suspicious,
        }
    }
}

/// The pair pass over pairs `range` of the list on the team, in items of
/// [`TEAM_PAIRS`] pairs (a run of whole [`LANES`] within one block), each thread with
/// its own scratch (`scratch[slot]`, added here when the team has more threads than
/// `scratch` has entries). Returns the first pair too deep.
///
/// # Safety
/// No thread writes a velocity or spin meanwhile (see [`pair_block`]).
#[allow(clippy::too_many_arguments)]
unsafe fn pair_pass<const D: usize>(
    team: &mut Team,
    scratch: &mut Vec<Box<Geometry<D>>>,
    blocks: &mut [PairBlock<D>],
    roll: &mut [RollBlock<D>],
    range: std::ops::Range<usize>,
    ij: &[[u32; 2]],
    pin: &PairIn<D>,
    law: &LawPass,
) -> Option<usize>
where
    Dim<D>: Spatial<D>,
{
    if scratch.len() < team.threads() {
        scratch.resize_with(team.threads(), Box::default);
    }
    assert!(range.end <= blocks.len() * BLOCK);
    let first = range.start & !(TEAM_PAIRS - 1);
    let blks = SyncPtr(blocks.as_mut_ptr());
    // (a dangling pointer without rolling: never read then)
    let rolls = SyncPtr(roll.as_mut_ptr());
    let geos = Disjoint::new(scratch);
    team.map_reduce(
        (range.end.saturating_sub(first)).div_ceil(TEAM_PAIRS),
        None,
        |c, slot| {
            // SAFETY: a slot is one thread's for the whole phase.
            let g = unsafe { geos.one(slot) };
            // an item lies within one block: BLOCK is a multiple of TEAM_PAIRS
            let k0 = first + c * TEAM_PAIRS;
            let (bi, base) = (k0 >> BLOCK_SHIFT, k0 & !(BLOCK - 1));
            let lanes = range.start.max(k0) - base..range.end.min(k0 + TEAM_PAIRS) - base;
            // SAFETY: block bi exists (asserted above); the items' lanes are disjoint,
            // and pair_block makes no reference to the whole block; the rest as the
            // caller guarantees.
            unsafe {
                let rb = if law.roll.is_some() {
                    rolls.ptr().add(bi)
                } else {
                    std::ptr::null_mut()
                };
                pair_block(blks.ptr().add(bi), rb, g, base, lanes, ij, pin, law)
            }
        },
        // the first pair too deep: items come in list order
        |a: Option<usize>, b| a.or(b),
    )
}

/// Particle q in the force sweep's piece whose pairs start at `plo` (`a0`: the
/// active run's start) and whose blocks `own` start at block `b0`: gathered now if all
/// its pairs lie in the piece, else left for after the sweep.
///
/// # Safety
/// Every pair of q before the sweep's position has been computed, and the sweep has
/// passed q's last pair when `q`'s pairs all lie in the piece.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
unsafe fn visit<const D: usize, const TORQUE: bool, const KICK: bool, const FROZEN: bool>(
    gin: &GatherIn<D>,
    out: GatherOut<D>,
    own: (&[PairBlock<D>], &[RollBlock<D>]),
    b0: usize,
    (a0, plo): (usize, usize),
    skip_frozen: bool,
    q: usize,
    s: &mut Sweep,
) where
    Dim<D>: Spatial<D>,
{
    if FROZEN && gin.fz[q] {
        // frozen particles read the frozen run, which no piece owns
        if !skip_frozen {
            s.deferred.push(q as u32);
        }
        return;
    }
    // SAFETY: q < n, and j_start has n + 1 entries.
    let (e_lo, e_hi) = unsafe { (at(gin.j_start, q) as usize, at(gin.j_start, q + 1) as usize) };
    let ends = &gin.j_inc[e_lo..e_hi];
    // the first of q's pairs in the active run (they come in order)
    let first = if FROZEN {
        ends.iter().map(|&e| e as usize).find(|&e| e >= a0)
    } else {
        ends.first().map(|&e| e as usize)
    };
    if first.is_some_and(|e| e < plo) {
        s.deferred.push(q as u32);
        return;
    }
    // SAFETY: all of q's pairs are in this piece and computed, so no other piece
    // reads or writes q's velocity, spin or force, and this piece reads q's no more.
    unsafe { gather_one::<D, TORQUE, KICK, FROZEN>(gin, out, own, b0 * BLOCK, q, &mut s.gathered) };
}

crate::cpu::multiversion! {
/// The gather of particles `qs` (all pairs computed, in `blocks` from pair 0 on),
/// skipping frozen ones when `skip_frozen`; compiled for each instruction-set level
/// (see [`crate::cpu`]).
///
/// # Safety
/// As for [`gather_one`], for every particle of `qs`.
unsafe fn gather_each [
    const D: usize, const TORQUE: bool, const KICK: bool, const FROZEN: bool,
    I: Iterator<Item = usize>
] (
    gin: &GatherIn<D>,
    out: GatherOut<D>,
    blocks: (&[PairBlock<D>], &[RollBlock<D>]),
    qs: I,
    skip_frozen: bool,
) -> Gathered where [Dim<D>: Spatial<D>] [D, TORQUE, KICK, FROZEN, I] {
    let mut acc = Gathered::default();
    for q in qs {
        if FROZEN && skip_frozen && gin.fz[q] {
            continue;
        }
        // SAFETY: as the caller guarantees.
        unsafe { gather_one::<D, TORQUE, KICK, FROZEN>(gin, out, blocks, 0, q, &mut acc) };
    }
    acc
}
}

/// What one piece of the force sweep leaves: the first pair too deep, the first
/// too-deep wall contact, whether a kick looked unsafe, and the particles to gather
/// after the sweep.
#[derive(Default)]
struct Sweep {
    bad_pair: Option<usize>,
    gathered: Gathered,
    deferred: Vec<u32>,
}

/// One piece of the force sweep: its pairs, its particles (those whose active pairs
/// start in it), its first block, the active run's start and whether frozen particles
/// are skipped.
struct Piece {
    pairs: std::ops::Range<usize>,
    particles: std::ops::Range<usize>,
    b0: usize,
    a0: usize,
    skip_frozen: bool,
}

crate::cpu::multiversion! {
/// The sweep over one piece (see [`World::forces`]): each block's pairs, then the
/// particles whose pairs all lie before the sweep's position; the rest are deferred.
/// Compiled for each instruction-set level (see [`crate::cpu`]).
///
/// # Safety
/// The piece owns `own` (its blocks); no other piece gathers a particle with a pair in
/// this piece before the sweep has passed it.
unsafe fn sweep_piece [const D: usize, const TORQUE: bool, const KICK: bool, const FROZEN: bool] (
    owned: (&mut [PairBlock<D>], &mut [RollBlock<D>]),
    g: &mut Geometry<D>,
    piece: &Piece,
    ij: &[[u32; 2]],
    pin: &PairIn<D>,
    law: &LawPass,
    gin: &GatherIn<D>,
    out: GatherOut<D>,
) -> Sweep where [Dim<D>: Spatial<D>] [D, TORQUE, KICK, FROZEN] {
    let (own, own_roll) = owned;
    let (plo, phi) = (piece.pairs.start, piece.pairs.end);
    let (b0, a0, skip_frozen) = (piece.b0, piece.a0, piece.skip_frozen);
    let mut s = Sweep::default();
    let mut q = piece.particles.start;
    let q_end = piece.particles.end;
    // After block bi, the particles whose pairs all lie before the sweep's position; a
    // piece without blocks takes its particles (none with pairs) in one go.
    for bi in 0..own.len().max(1) {
        let done = if bi < own.len() {
            let base = (b0 + bi) * BLOCK;
            let lanes = plo.saturating_sub(base)..(phi - base).min(BLOCK);
            let done = base + lanes.end;
            if !lanes.is_empty() {
                // SAFETY: the pairs of this piece involve no particle gathered before
                // the sweep has passed them (below).
                let rb = if law.roll.is_some() {
                    &raw mut own_roll[bi]
                } else {
                    std::ptr::null_mut()
                };
                let b = unsafe { pair_block(&raw mut own[bi], rb, g, base, lanes, ij, pin, law) };
                s.bad_pair = s.bad_pair.or(b);
            }
            done
        } else {
            phi
        };
        // SAFETY (at): q < q_end <= n, and i_active has n + 1 entries.
        while q < q_end && unsafe { at(gin.i_active, q + 1) } as usize <= done {
            // SAFETY: q's pairs up to the sweep's position are computed.
            unsafe {
                visit::<D, TORQUE, KICK, FROZEN>(
                    gin,
                    out,
                    (own, own_roll),
                    b0,
                    (a0, plo),
                    skip_frozen,
                    q,
                    &mut s,
                )
            };
            q += 1;
        }
    }
    // the last block ends at phi: these have pairs in the next piece
    s.deferred.extend(q as u32..q_end as u32);
    s
}
}

/// The law's settings for one pass.
struct LawPass {
    consts: LawConsts,
    /// Rolling resistance, when on and spins move.
    roll: Option<RollCoefs>,
    dt: Real,
    rot: bool,
    torques: bool,
    max_ratio: Real,
}

/// What the pair pass reads of the particles; velocities and spins through pointers,
/// as the gather writes them in the same sweep.
struct PairIn<'a, const D: usize>
where
    Dim<D>: Spatial<D>,
{
    x: &'a [Vector<D>],
    r: &'a [Real],
    v: SyncPtr<Vector<D>>,
    w: SyncPtr<Ang<D>>,
    /// Periodic axes: separations by minimum image.
    period: Option<Period<D>>,
}

crate::cpu::multiversion! {
/// The pair pass over lanes `lanes` of one block (pairs `base + lanes` of the list),
/// [`LANES`] at a time: each pair's particle data gathered into the scratch `g`, then
/// the geometry and the law vectorised over the lanes, which write the pairs' state in
/// place. Returns the first pair too deep (list index). Compiled for each
/// instruction-set level (see [`crate::cpu`]).
///
/// # Safety
/// `blk` points to a block whose lanes `lanes` nothing else reads or writes meanwhile
/// (no reference to the whole block is made: other threads may own its other lanes),
/// and no thread writes the velocity or spin of a particle of these pairs.
unsafe fn pair_block [const D: usize] (
    blk: *mut PairBlock<D>,
    rblk: *mut RollBlock<D>,
    g: &mut Geometry<D>,
    base: usize,
    lanes: std::ops::Range<usize>,
    ij: &[[u32; 2]],
    p: &PairIn<D>,
    law: &LawPass,
) -> Option<usize> where [Dim<D>: Spatial<D>] [D] {
    let mut bad = None;
    let mut off = lanes.start & !(LANES - 1);
    while off < lanes.end {
        let lo = lanes.start.max(off) - off;
        let hi = (lanes.end - off).min(LANES);
        // SAFETY: as the caller guarantees.
        let b = unsafe { pair_lanes(blk, rblk, g, base, off, lo..hi, ij, p, law) };
        bad = bad.or(b);
        off += LANES;
    }
    bad
}
}

/// [`pair_block`] for the scratch's lanes `lanes`, which are the block's lanes `off +
/// lanes` (`off`: a multiple of [`LANES`]).
///
/// # Safety
/// As for [`pair_block`].
#[allow(clippy::too_many_arguments)]
#[inline(always)]
unsafe fn pair_lanes<const D: usize>(
    blk: *mut PairBlock<D>,
    rblk: *mut RollBlock<D>,
    g: &mut Geometry<D>,
    base: usize,
    off: usize,
    lanes: std::ops::Range<usize>,
    ij: &[[u32; 2]],
    p: &PairIn<D>,
    law: &LawPass,
) -> Option<usize>
where
    Dim<D>: Spatial<D>,
{
    let (lo, hi) = (lanes.start, lanes.end);
    let rot = law.rot;
    let first = base + off;
    // What each pair's geometry needs, gathered from the two particles; the arithmetic
    // runs vectorised over the lanes.
    for (l, &[i, j]) in (lo..hi).zip(&ij[first + lo..first + hi]) {
        let (i, j) = (i as usize, j as usize);
        // SAFETY: pair-list indices are below the particle count (see `at`); the
        // caller guarantees that nobody writes v and w of i and j now.
        let (ri, rj, xi, xj, vi, vj) = unsafe {
            (
                at(p.r, i),
                at(p.r, j),
                at(p.x, i),
                at(p.x, j),
                *p.v.0.add(i),
                *p.v.0.add(j),
            )
        };
        // l < LANES; the mask says so to the compiler
        let l = l & (LANES - 1);
        let (mut dx, dv) = (xj - xi, vj - vi);
        if let Some(per) = &p.period {
            dx = per.image(dx);
        }
        for a in 0..D {
            g.n[a][l] = dx[a];
            g.v[a][l] = dv[a];
        }
        (g.r[0][l], g.r[1][l]) = (ri, rj);
        if rot {
            // SAFETY: as above.
            let (wi, wj) = unsafe { (*p.w.0.add(i), *p.w.0.add(j)) };
            for c in 0..<Ang<D> as AngOps>::NCOMP {
                g.tmp[c][l] = wi.comp(c);
                g.tmp[3 + c][l] = wj.comp(c);
            }
        }
    }
    if law.roll.is_some() {
        // the relative spins w_j - w_i, for the rolling law, from the spins just
        // gathered (rolling runs only with rotations), before the geometry reuses them
        for c in 0..<Ang<D> as AngOps>::NCOMP {
            for l in lo..hi {
                g.wr[c][l] = g.tmp[3 + c][l] - g.tmp[c][l];
            }
        }
    }
    let (contact, too_deep) = geometry_block(g, lo..hi, rot, law.max_ratio);
    let mut bad = None;
    if too_deep {
        // the first pair too deep (rare: the step is then refused)
        let ratio = |l: usize| law.max_ratio * g.r[0][l].min(g.r[1][l]);
        bad = (lo..hi).find(|&l| g.d[l] > ratio(l)).map(|l| first + l);
    }
    // SAFETY: these lanes of blk are ours (caller).
    unsafe {
        if contact {
            law_block(blk, g, lo..hi, off, &law.consts, law.dt, law.torques);
        } else {
            clear_lanes(blk, off + lo..off + hi);
        }
        if let Some(rc) = &law.roll {
            if contact {
                roll_block(rblk, blk, g, lo..hi, off, &law.consts, rc, law.dt);
            } else {
                clear_roll_lanes(rblk, off + lo..off + hi);
            }
        }
    }
    bad
}

/// What the gather reads: particle data, the pair list's index ranges, walls and
/// the step's constants.
struct GatherIn<'a, const D: usize>
where
    Dim<D>: Spatial<D>,
{
    x: &'a [Vector<D>],
    r: &'a [Real],
    m: &'a [Real],
    fz: &'a [bool],
    inv_m: &'a [Real],
    inv_i: &'a [Real],
    wall_near: &'a [u8],
    i_frozen: &'a [u32],
    i_active: &'a [u32],
    j_start: &'a [u32],
    j_inc: &'a [u32],
    walls: &'a [Wall],
    /// Each wall's speed along its outward normal (m/s).
    wall_rate: &'a [Real],
    /// Local non-viscous damping coefficient (-), 0: off.
    local_damping: Real,
    /// The wall law's material (the radius and mass are set per particle).
    params: PairParams,
    /// The contact law (the wall's as the pairs').
    law: ContactLaw,
    /// Rolling resistance, when on and spins move.
    roll: Option<RollCoefs>,
    gravity: Vector<D>,
    drag: Real,
    dt: Real,
    half: Real,
    guard: Real,
    max_ratio: Real,
    rot: bool,
}

/// What the gather writes, per particle.
struct GatherOut<const D: usize>
where
    Dim<D>: Spatial<D>,
{
    f: SyncPtr<Vector<D>>,
    t: SyncPtr<Ang<D>>,
    /// Each particle's wall state, `walls` entries a particle.
    wh: SyncPtr<Vector<D>>,
    wf: SyncPtr<Vector<D>>,
    wm: SyncPtr<u8>,
    /// Each particle's rolling displacement on each wall (with rolling resistance).
    wr: SyncPtr<Vector<D>>,
    v: SyncPtr<Vector<D>>,
    w: SyncPtr<Ang<D>>,
}
impl<const D: usize> Clone for GatherOut<D>
where
    Dim<D>: Spatial<D>,
{
    fn clone(&self) -> Self {
        *self
    }
}
impl<const D: usize> Copy for GatherOut<D> where Dim<D>: Spatial<D> {}

/// The gather of particle q: its pair forces (those it starts with -f, as ranges of
/// the list, then those it ends with +f through their index list; the torque of the
/// tangential force is -(r_q - d/2) n x f_t on either end), walls and body forces,
/// and with `KICK` the second half kick. `blocks` holds pairs from `pair_base` on
/// (a multiple of [`BLOCK`]). Returns a too-deep wall contact and whether the kicked
/// velocity looks unsafe.
///
/// # Safety
/// q < the particle count; every pair of q lies at or after `pair_base` in `blocks`
/// and has been computed; no other thread reads or writes q's outputs meanwhile.
#[inline(always)]
unsafe fn gather_one<const D: usize, const TORQUE: bool, const KICK: bool, const FROZEN: bool>(
    c: &GatherIn<D>,
    out: GatherOut<D>,
    (blocks, roll): (&[PairBlock<D>], &[RollBlock<D>]),
    pair_base: usize,
    q: usize,
    acc: &mut Gathered,
) where
    Dim<D>: Spatial<D>,
{
    // SAFETY: q is below the particle count and q's outputs are ours (caller); its wall
    // state is the run of `walls` entries at q * walls, which no other q's overlaps.
    let (v, w, wh, wf, wm) = unsafe {
        (
            &mut *out.v.0.add(q),
            &mut *out.w.0.add(q),
            std::slice::from_raw_parts_mut(out.wh.0.add(q * c.walls.len()), c.walls.len()),
            std::slice::from_raw_parts_mut(out.wf.0.add(q * c.walls.len()), c.walls.len()),
            &mut *out.wm.0.add(q),
        )
    };
    // SAFETY: q is below the particle count, so below the length of every
    // per-particle array, and q + 1 below that of the range starts (caller).
    let (frozen_q, m, x, r, near, inv_m, inv_i) = unsafe {
        (
            FROZEN && at(c.fz, q),
            at(c.m, q),
            at_ref(c.x, q),
            at(c.r, q),
            at(c.wall_near, q),
            at(c.inv_m, q),
            at(c.inv_i, q),
        )
    };
    // SAFETY: as above.
    let (a_lo, a_hi, e_lo, e_hi) = unsafe {
        (
            at(c.i_active, q) as usize,
            at(c.i_active, q + 1) as usize,
            at(c.j_start, q) as usize,
            at(c.j_start, q + 1) as usize,
        )
    };
    let mut fq = c.gravity * m;
    if c.drag > 0.0 {
        fq -= *v * c.drag;
    }
    let mut tq = Ang::<D>::default();
    let active = a_lo - pair_base..a_hi - pair_base;
    // only frozen particles have pairs in the frozen run (at pair_base 0)
    let own_frozen = if frozen_q {
        c.i_frozen[q] as usize..c.i_frozen[q + 1] as usize
    } else {
        0..0
    };
    let ends = &c.j_inc[e_lo..e_hi];
    if TORQUE {
        let mut visit = |b: &PairBlock<D>, l| {
            let (f, t) = lane_force_torque::<D>(b, l, r);
            fq -= f;
            tq += t;
        };
        if frozen_q {
            for_lanes(blocks, own_frozen.clone(), &mut visit);
        }
        for_lanes(blocks, active.clone(), visit);
        for &e in ends {
            let e = e as usize - pair_base;
            // SAFETY: the index lists stay below the pair count (see `at`), and q's
            // pairs lie in `blocks` (caller).
            let (f, t) = lane_force_torque::<D>(unsafe { block_of(blocks, e) }, e, r);
            fq += f;
            tq += t;
        }
        if c.roll.is_some() {
            // the rolling moments, after the tangential ones: -R* n x f_r on the
            // pair's first particle, +R* n x f_r on its second
            // (own_frozen is empty unless q is frozen)
            for range in [own_frozen, active] {
                for e in range {
                    // SAFETY: q's pairs lie in `blocks`, and `roll` beside them (caller).
                    tq += unsafe { roll_moment::<D>(roll, e) } * -1.0;
                }
            }
            for &e in ends {
                // SAFETY: as above.
                tq += unsafe { roll_moment::<D>(roll, e as usize - pair_base) };
            }
        }
    } else {
        let mut visit = |b: &PairBlock<D>, l| fq -= lane_force::<D>(b, l);
        if frozen_q {
            for_lanes(blocks, own_frozen, &mut visit);
        }
        for_lanes(blocks, active, visit);
        for &e in ends {
            let e = e as usize - pair_base;
            // SAFETY: as above.
            fq += lane_force::<D>(unsafe { block_of(blocks, e) }, e);
        }
    }
    // visit only the walls that can touch (most particles: none)
    let mut candidates = near | *wm;
    while candidates != 0 {
        let wi = candidates.trailing_zeros() as usize;
        candidates &= candidates - 1;
        let wall = &c.walls[wi];
        let s = wall.gap(x);
        let d = r - s;
        if d <= 0.0 {
            // As for pairs: clear the wall's state only when the contact just opened
            // (the force is exactly zero otherwise).
            if *wm & (1 << wi) != 0 {
                wh[wi] = Vector::<D>::zeros();
                wf[wi] = Vector::<D>::zeros();
                if c.roll.is_some() {
                    // SAFETY: q's wall state is ours (above).
                    unsafe { *out.wr.0.add(q * c.walls.len() + wi) = Vector::<D>::zeros() };
                }
                *wm &= !(1 << wi);
            }
            continue;
        }
        if d > c.max_ratio * r && acc.bad_wall.is_none() {
            // the first of this job's particles, which come in increasing order
            acc.bad_wall = Some((q, wi, d));
        }
        let n = wall.normal(x);
        let arm = r - 0.5 * d;
        // relative velocity of the wall w.r.t. the particle; a moving wall's surface
        // moves along its normal (a wall at rest adds nothing, not even a signed zero)
        let mut vrel = -*v;
        let rate = c.wall_rate[wi];
        if rate != 0.0 {
            vrel += n * rate;
        }
        if c.rot {
            vrel -= <Dim<D>>::cross_wv(*w, &(n * arm));
        }
        let params = PairParams {
            r_eff: wall.r_eff(r),
            m_eff: m,
            ..c.params
        };
        let (fc, k_n) = match c.law {
            ContactLaw::HertzMindlin => (
                hertz_mindlin(&params, d, &n, &vrel, &mut wh[wi], c.dt),
                2.0 * params.e_star * (params.r_eff * d).sqrt(),
            ),
            ContactLaw::Linear { kn, kt } => (
                linear_coefs(
                    &LawCoefs::linear(&params, kn, kt),
                    d,
                    &n,
                    &vrel,
                    &mut wh[wi],
                    c.dt,
                ),
                kn,
            ),
        };
        let on_wall = n * fc.normal + fc.tangential;
        wf[wi] = on_wall;
        *wm |= 1 << wi;
        fq -= on_wall;
        if TORQUE {
            tq += <Dim<D>>::cross_vv(&n, &fc.tangential) * -arm;
            if let Some(rc) = &c.roll {
                // the wall does not spin: v_r = R* (0 - w) x n
                let v_r = -<Dim<D>>::cross_wv(*w, &n) * params.r_eff;
                // SAFETY: q's wall state is ours (above).
                let hist = unsafe { &mut *out.wr.0.add(q * c.walls.len() + wi) };
                let f_r = rolling_epsd(rc, fc.normal, k_n, &n, &v_r, hist, c.dt);
                tq += <Dim<D>>::cross_vv(&n, &f_r) * -params.r_eff;
            }
        }
    }
    // SAFETY: as for v above.
    unsafe {
        *out.f.0.add(q) = fq;
        *out.t.0.add(q) = tq;
    }
    if KICK && !frozen_q {
        if c.local_damping > 0.0 {
            *v += local_damped(fq, v, c.local_damping) * (inv_m * c.half);
        } else {
            *v += fq * (inv_m * c.half);
        }
        // written so that NaN also trips it
        let v2 = v.norm_squared();
        acc.suspicious |= v2.is_nan() || v2 > r * r * c.guard;
        // no torque without friction: the spin keeps its value
        if TORQUE {
            *w += tq * (inv_i * c.half);
        }
    }
}

/// Local non-viscous damping (Cundall's, as in PFC and YADE's `NewtonIntegrator`):
/// each component of the force loses `alpha` times its magnitude against the
/// velocity's sign, f_k - alpha |f_k| sign(v_k). It removes kinetic energy in
/// proportion to the unbalanced force, so it vanishes at equilibrium and does not
/// change the static state a quasi-static stage converges to.
#[inline(always)]
pub(super) fn local_damped<const D: usize>(f: Vector<D>, v: &Vector<D>, alpha: Real) -> Vector<D> {
    let mut out = f;
    for k in 0..D {
        let s = if v[k] > 0.0 {
            1.0
        } else if v[k] < 0.0 {
            -1.0
        } else {
            0.0
        };
        out[k] -= alpha * f[k].abs() * s;
    }
    out
}
