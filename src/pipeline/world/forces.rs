//! Forces: the pair pass (each pair's particle data gathered into a scratch block, then
//! the geometry and the law vectorised over the block, which write each pair's state in
//! place), the per-particle gather with walls and body forces (and, during a step, the
//! second half kick), and the freezing decisions that need every particle's net force.

use super::*;
use std::sync::atomic::{AtomicBool, Ordering};

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
/// pair's force on j and its tangential force's torque on the j end (`J`) or the i end.
#[inline(always)]
fn lane<const D: usize, const J: bool>(b: &PairBlock<D>, l: usize) -> (Vector<D>, Ang<D>)
where
    Dim<D>: Spatial<D>,
{
    let l = l & (BLOCK - 1);
    let f = Vector::<D>::from_fn(|a, _| b.f[a][l]);
    let t = if J { &b.tj } else { &b.ti };
    let mut c = [0.0; 3];
    for (a, x) in c.iter_mut().enumerate().take(<Ang<D> as AngOps>::NCOMP) {
        *x = t[a][l];
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

impl<const D: usize> World<D>
where
    Dim<D>: Spatial<D>,
{
    /// Pair forces, then the per-particle gather with walls and body forces, for every
    /// particle (frozen ones included).
    pub(super) fn compute_forces(&mut self) -> Result<()> {
        self.compute_forces_inner(true, false).map(|_| ())
    }

    /// Freezes settled particles below the freeze level and unfreezes pushed ones.
    /// Runs right after a full force evaluation; each decision is per particle, so the
    /// result does not depend on the thread count.
    pub(super) fn update_frozen(&mut self) {
        let Some(fc) = self.freeze else { return };
        let vert = <Dim<D> as Spatial<D>>::VERTICAL;
        let g = self.cfg.gravity.norm();
        let p = &mut self.p;
        let (x, f, r, m) = (&p.x, &p.f, &p.r, &p.m);
        let speed2 = fc.speed * fc.speed;
        let thawed = AtomicBool::new(false);
        p.frozen
            .par_chunks_mut(CHUNK)
            .zip(p.v.par_chunks_mut(CHUNK))
            .zip(p.w.par_chunks_mut(CHUNK))
            .enumerate()
            .for_each(|(c, ((fz, v), w))| {
                for k in 0..fz.len() {
                    let q = c * CHUNK + k;
                    let fmax = fc.force_ratio * m[q] * g;
                    let quiet = f[q].norm_squared() <= fmax * fmax;
                    if fz[k] {
                        if !quiet {
                            fz[k] = false;
                            thawed.store(true, Ordering::Relaxed);
                        }
                    } else if quiet && x[q][vert] + r[q] < fc.below && v[k].norm_squared() <= speed2
                    {
                        fz[k] = true;
                        v[k] = Vector::<D>::zeros();
                        w[k] = Ang::<D>::default();
                    }
                }
            });
        let (n_before, thawed) = (self.n_frozen, thawed.load(Ordering::Relaxed));
        self.n_frozen = self.p.frozen.iter().filter(|&&z| z).count();
        if thawed {
            // A thawed particle may move again: its pairs leave the frozen run and are
            // searched afresh at the next (partial) rebuild, which sees it as active.
            self.partition_pairs();
            self.list_valid = false;
        } else if self.n_frozen != n_before {
            self.partition_pairs();
        }
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
    pub(super) fn compute_forces_inner(&mut self, all: bool, kick: bool) -> Result<bool> {
        let skip_frozen = !all && self.n_frozen > 0;
        let dt = self.cfg.dt;
        let rot = self.cfg.rotations;
        let mat = self.cfg.material;
        let torques = self.torques_on();
        let (e_star, g_star) = (self.e_star, self.g_star);
        let consts = LawConsts::new(e_star, g_star, mat.damping, mat.friction);
        let max_ratio = self.cfg.max_overlap_ratio;
        let p = &self.p;
        let pr = &mut self.pairs;
        // Between freeze decisions only the first run (pairs with an active particle)
        // changes; the frozen pairs keep their forces.
        let first = if skip_frozen { pr.n_frozen_pairs } else { 0 };

        // 3. pair pass, over the blocks from the one holding the first active pair
        let ij = &pr.ij[..];
        let len = ij.len();
        let b0 = first >> BLOCK_SHIFT;
        let bad_pair = pr.blocks[b0..]
            .par_chunks_mut(CHUNK / BLOCK)
            .enumerate()
            .map_init(
                // one geometry buffer per rayon job, not per chunk: it is 15 KB in 3D
                || Box::new(Geometry::<D>::default()),
                |g, (c, blocks)| {
                    let g: &mut Geometry<D> = g;
                    let mut bad: Option<usize> = None;
                    for (bi, blk) in blocks.iter_mut().enumerate() {
                        let base = (b0 + c * (CHUNK / BLOCK) + bi) * BLOCK;
                        // the lanes of this block in the active run
                        let lo = first.saturating_sub(base);
                        let hi = (len - base).min(BLOCK);
                        // What each pair's geometry needs, gathered from the two
                        // particles; the arithmetic runs vectorised over the block.
                        for (l, &[i, j]) in (lo..hi).zip(&ij[base + lo..base + hi]) {
                            let (i, j) = (i as usize, j as usize);
                            // SAFETY: pair-list indices are below the particle count (see `at`).
                            let (ri, rj, xi, xj, vi, vj) = unsafe {
                                (
                                    at(&p.r, i),
                                    at(&p.r, j),
                                    at(&p.x, i),
                                    at(&p.x, j),
                                    at(&p.v, i),
                                    at(&p.v, j),
                                )
                            };
                            // l < BLOCK; the mask says so to the compiler
                            let l = l & (BLOCK - 1);
                            let (dx, dv) = (xj - xi, vj - vi);
                            for a in 0..D {
                                g.n[a][l] = dx[a];
                                g.v[a][l] = dv[a];
                            }
                            (g.r[0][l], g.r[1][l]) = (ri, rj);
                            if rot {
                                // SAFETY: as above.
                                let (wi, wj) = unsafe { (at(&p.w, i), at(&p.w, j)) };
                                for c in 0..<Ang<D> as AngOps>::NCOMP {
                                    g.tmp[c][l] = wi.comp(c);
                                    g.tmp[3 + c][l] = wj.comp(c);
                                }
                            }
                        }
                        let (contact, too_deep) = geometry_block(g, lo..hi, rot, max_ratio);
                        if too_deep && bad.is_none() {
                            // the first pair too deep (rare: the step is then refused)
                            let ratio = |l: usize| max_ratio * g.r[0][l].min(g.r[1][l]);
                            bad = (lo..hi).find(|&l| g.d[l] > ratio(l)).map(|l| base + l);
                        }
                        if contact {
                            law_block(blk, g, lo..hi, &consts, dt, torques);
                        } else {
                            clear_lanes(blk, lo..hi);
                        }
                    }
                    bad
                },
            )
            .flatten()
            .min();
        if let Some(k) = bad_pair {
            let [i, j] = pr.ij[k];
            let d = pr.get(k).d;
            let rmin = p.r[i as usize].min(p.r[j as usize]);
            return Err(Error::Blowup {
                step: self.steps,
                time: self.time,
                particle: i as usize,
                what: format!(
                    "overlap with particle {j} is {d:e} m = {:.3} of the smaller radius \
                     (limit max_overlap_ratio = {max_ratio}); reduce dt: the contact is not resolved",
                    d / rmin
                ),
            });
        }

        // 4. gather, and 5. the second half kick: the loop compiled once per
        // combination of what is switched on, so that the common cases carry no tests
        // of switches that are off, nor the frozen run's bookkeeping when nothing is
        // frozen.
        let frozen = self.n_frozen > 0 || self.pairs.n_frozen_pairs > 0;
        let (bad_wall, suspicious) = match (torques, kick, frozen) {
            (false, false, false) => self.gather::<false, false, false>(skip_frozen),
            (false, false, true) => self.gather::<false, false, true>(skip_frozen),
            (false, true, false) => self.gather::<false, true, false>(skip_frozen),
            (false, true, true) => self.gather::<false, true, true>(skip_frozen),
            (true, false, false) => self.gather::<true, false, false>(skip_frozen),
            (true, false, true) => self.gather::<true, false, true>(skip_frozen),
            (true, true, false) => self.gather::<true, true, false>(skip_frozen),
            (true, true, true) => self.gather::<true, true, true>(skip_frozen),
        };

        if let Some((q, wi, d)) = bad_wall {
            return Err(Error::Blowup {
                step: self.steps,
                time: self.time,
                particle: q,
                what: format!(
                    "overlap with wall {} is {d:e} m = {:.3} of its radius \
                     (limit max_overlap_ratio = {max_ratio})",
                    -(wi as i64) - 1,
                    d / self.p.r[q]
                ),
            });
        }
        self.forces_valid = true;
        Ok(suspicious)
    }

    /// The per-particle gather of [`compute_forces_inner`](Self::compute_forces_inner):
    /// each particle's pair forces, walls and body forces, and with `KICK` the second
    /// half kick. `TORQUE`: rotations and friction both on (tangential torques to
    /// gather, spins to kick); `FROZEN`: some particles are frozen or the pair list
    /// has a frozen run (with it false, no particle is frozen and the list is one
    /// run). Frozen particles are not gathered when `skip_frozen`. Returns the first too-deep wall contact
    /// and whether a kicked velocity looks unsafe.
    #[allow(clippy::type_complexity)]
    fn gather<const TORQUE: bool, const KICK: bool, const FROZEN: bool>(
        &mut self,
        skip_frozen: bool,
    ) -> (Option<(usize, usize, Real)>, bool) {
        let dt = self.cfg.dt;
        let rot = self.cfg.rotations;
        let mat = self.cfg.material;
        let (e_star, g_star) = (self.e_star, self.g_star);
        let max_ratio = self.cfg.max_overlap_ratio;
        // the tunnelling guard: |v| > r / (2 dt), as v^2 > r^2 / (4 dt^2)
        let guard = 0.25 / (dt * dt);
        let pr = &self.pairs;
        let walls = &self.walls;
        let gravity = self.cfg.gravity;
        let drag = self.cfg.drag;
        let half = 0.5 * dt;
        let p = &mut self.p;
        let (x, r, m, fz, inv_m, inv_i) = (&p.x, &p.r, &p.m, &p.frozen, &p.inv_m, &p.inv_i);
        p.f.par_chunks_mut(CHUNK)
            .zip(p.t.par_chunks_mut(CHUNK))
            .zip(p.wall_hist.par_chunks_mut(CHUNK))
            .zip(p.wall_force.par_chunks_mut(CHUNK))
            .zip(p.wall_mask.par_chunks_mut(CHUNK))
            .zip(p.wall_near.par_chunks(CHUNK))
            .zip(p.v.par_chunks_mut(CHUNK))
            .zip(p.w.par_chunks_mut(CHUNK))
            .enumerate()
            .map(|(c, (((((((f, t), wh), wf), wm), wn), v), w))| {
                let mut bad = None;
                let mut suspicious = false;
                // This chunk's share of the whole-particle arrays, sliced once, so
                // that the loop indexes every array by k under one length check.
                let n = f.len();
                let lo = c * CHUNK;
                let (x, r, m, fz) = (
                    &x[lo..lo + n],
                    &r[lo..lo + n],
                    &m[lo..lo + n],
                    &fz[lo..lo + n],
                );
                let (inv_m, inv_i) = (&inv_m[lo..lo + n], &inv_i[lo..lo + n]);
                let i_frozen = &pr.i_frozen[lo..=lo + n];
                let i_active = &pr.i_active[lo..=lo + n];
                let j_start = &pr.j_start[lo..=lo + n];
                let blocks = &pr.blocks[..];
                let (t, wh, wf, wm, wn) = (
                    &mut t[..n],
                    &mut wh[..n],
                    &mut wf[..n],
                    &mut wm[..n],
                    &wn[..n],
                );
                let (v, w) = (&mut v[..n], &mut w[..n]);
                let (gravity, drag, dt, half, guard) = (gravity, drag, dt, half, guard);
                let (skip_frozen, rot) = (skip_frozen, rot);
                for k in 0..n {
                    let q = lo + k;
                    if FROZEN && skip_frozen && fz[k] {
                        continue;
                    }
                    let mut fq = gravity * m[k];
                    if drag > 0.0 {
                        fq -= v[k] * drag;
                    }
                    let mut tq = Ang::<D>::default();
                    // The pairs q starts (force on q: -f), as two ranges of the list,
                    // then those it ends (+f) through their index list. The torque of
                    // the tangential force is -(r_q - d/2) n x f_t on either end.
                    let active = i_active[k] as usize..i_active[k + 1] as usize;
                    let own_frozen = i_frozen[k] as usize..i_frozen[k + 1] as usize;
                    let ends = &pr.j_inc[j_start[k] as usize..j_start[k + 1] as usize];
                    if TORQUE {
                        let mut visit = |b: &PairBlock<D>, l| {
                            let (f, t) = lane::<D, false>(b, l);
                            fq -= f;
                            tq += t;
                        };
                        if FROZEN {
                            for_lanes(blocks, own_frozen, &mut visit);
                        }
                        for_lanes(blocks, active, visit);
                        for &e in ends {
                            let e = e as usize;
                            // SAFETY: the index lists stay below the pair count (see
                            // `at`).
                            let (f, t) = lane::<D, true>(unsafe { block_of(blocks, e) }, e);
                            fq += f;
                            tq += t;
                        }
                    } else {
                        let mut visit = |b: &PairBlock<D>, l| fq -= lane::<D, false>(b, l).0;
                        if FROZEN {
                            for_lanes(blocks, own_frozen, &mut visit);
                        }
                        for_lanes(blocks, active, visit);
                        for &e in ends {
                            let e = e as usize;
                            // SAFETY: as above.
                            fq += lane::<D, true>(unsafe { block_of(blocks, e) }, e).0;
                        }
                    }
                    // visit only the walls that can touch (most particles: none)
                    let mut candidates = wn[k] | wm[k];
                    while candidates != 0 {
                        let wi = candidates.trailing_zeros() as usize;
                        candidates &= candidates - 1;
                        let wall = &walls[wi];
                        let s = wall.gap(&x[k]);
                        let d = r[k] - s;
                        if d <= 0.0 {
                            // As for pairs: clear the wall's state only when the contact
                            // just opened (the force is exactly zero otherwise).
                            if wm[k] & (1 << wi) != 0 {
                                wh[k][wi] = Vector::<D>::zeros();
                                wf[k][wi] = Vector::<D>::zeros();
                                wm[k] &= !(1 << wi);
                            }
                            continue;
                        }
                        if d > max_ratio * r[k] && bad.is_none() {
                            bad = Some((q, wi, d));
                        }
                        let n = wall.normal::<D>();
                        let arm = r[k] - 0.5 * d;
                        // wall at rest: relative velocity of the wall w.r.t. the particle
                        let mut vrel = -v[k];
                        if rot {
                            vrel -= <Dim<D>>::cross_wv(w[k], &(n * arm));
                        }
                        let params = PairParams {
                            r_eff: r[k],
                            m_eff: m[k],
                            e_star,
                            g_star,
                            damping: mat.damping,
                            friction: mat.friction,
                        };
                        let fc = hertz_mindlin(&params, d, &n, &vrel, &mut wh[k][wi], dt);
                        let on_wall = n * fc.normal + fc.tangential;
                        wf[k][wi] = on_wall;
                        wm[k] |= 1 << wi;
                        fq -= on_wall;
                        if TORQUE {
                            tq += <Dim<D>>::cross_vv(&n, &fc.tangential) * -arm;
                        }
                    }
                    f[k] = fq;
                    t[k] = tq;
                    if KICK && !(FROZEN && fz[k]) {
                        v[k] += fq * (inv_m[k] * half);
                        // written so that NaN also trips it
                        let v2 = v[k].norm_squared();
                        suspicious |= v2.is_nan() || v2 > r[k] * r[k] * guard;
                        // no torque without friction: the spin keeps its value
                        if TORQUE {
                            w[k] += tq * (inv_i[k] * half);
                        }
                    }
                }
                (bad, suspicious)
            })
            .reduce(
                || (None, false),
                // the too-deep wall contact of the lowest particle index
                |a, b| {
                    (
                        [a.0, b.0].into_iter().flatten().min_by_key(|e| e.0),
                        a.1 | b.1,
                    )
                },
            )
    }
}
