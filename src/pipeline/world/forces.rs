//! Forces: the pair pass (geometry per pair, contacts compacted into batches for the
//! vectorised law, results scattered back), the per-particle gather with walls and
//! body forces, and the freezing decisions that need every particle's net force.

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

/// Writes a batch's results back to its pairs: history, then total force on j,
/// n x f_t (for the torques) and overlap.
#[inline]
fn scatter<const D: usize>(
    b: &Batch<D>,
    torques: bool,
    hist: &mut [Vector<D>],
    out: &mut [PairOut<D, Ang<D>>],
) where
    Dim<D>: Spatial<D>,
{
    for m in 0..b.len {
        let k = b.pair[m] as usize;
        let n = Vector::<D>::from_fn(|a, _| b.n[a][m]);
        let ft = Vector::<D>::from_fn(|a, _| b.ft[a][m]);
        hist[k] = Vector::<D>::from_fn(|a, _| b.h[a][m]);
        let o = &mut out[k];
        o.f = n * b.fnorm[m] + ft;
        if torques {
            o.nxf = <Dim<D>>::cross_vv(&n, &ft);
        }
        o.d = b.d[m];
    }
}

impl<const D: usize> World<D>
where
    Dim<D>: Spatial<D>,
{
    /// Pair forces, then the per-particle gather with walls and body forces, for every
    /// particle (frozen ones included).
    pub(super) fn compute_forces(&mut self) -> Result<()> {
        self.compute_forces_inner(true)
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
    pub(super) fn compute_forces_inner(&mut self, all: bool) -> Result<()> {
        let skip_frozen = !all && self.n_frozen > 0;
        let dt = self.cfg.dt;
        let rot = self.cfg.rotations;
        let mat = self.cfg.material;
        let friction_on = mat.friction > 0.0;
        let (e_star, g_star) = (self.e_star, self.g_star);
        let consts = LawConsts::new(e_star, g_star, mat.damping, mat.friction);
        let max_ratio = self.cfg.max_overlap_ratio;
        let p = &self.p;
        let pr = &mut self.pairs;
        // Between freeze decisions only the first run (pairs with an active particle)
        // changes; the frozen pairs keep their forces.
        let first = if skip_frozen { pr.n_frozen_pairs } else { 0 };

        // 3. pair pass
        let bad_pair = pr.ij[first..]
            .par_chunks(CHUNK)
            .zip(pr.coefs[first..].par_chunks(CHUNK))
            .zip(pr.hist[first..].par_chunks_mut(CHUNK))
            .zip(pr.out[first..].par_chunks_mut(CHUNK))
            .enumerate()
            .map_init(
                // one batch buffer per rayon job, not per chunk: it is 16 KB in 3D
                || Box::new(Batch::<D>::default()),
                |b, (c, (((ij, coefs), hist), out))| {
                    let b: &mut Batch<D> = b;
                    b.len = 0;
                    // Equal lengths, stated once, let the compiler drop the per-pair
                    // bounds checks on these chunk slices.
                    let m = ij.len();
                    assert!(coefs.len() == m && hist.len() == m && out.len() == m);
                    let mut bad: Option<usize> = None;
                    // Geometry per pair; contacts are compacted into a batch whose law
                    // runs vectorised (see `dynamics::batch`), then scattered back.
                    let flush = |b: &mut Batch<D>,
                                 hist: &mut [Vector<D>],
                                 out: &mut [PairOut<D, Ang<D>>]| {
                        law_batch(b, &consts, dt);
                        scatter::<D>(b, rot && friction_on, hist, out);
                        b.len = 0;
                    };
                    for k in 0..ij.len() {
                        let i = ij[k][0] as usize;
                        let j = ij[k][1] as usize;
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
                        let dx = xj - xi;
                        let dist2 = dx.norm_squared();
                        let cut = ri + rj;
                        let contact = dist2 < cut * cut;
                        // Zero the pair only when it just separated: most pairs inside the
                        // skin stay apart for many steps, and rewriting them is pure traffic.
                        // (`&`, not `&&`: one rarely taken branch instead of one per pair
                        // that goes either way.)
                        if !contact & (out[k].d != 0.0) {
                            hist[k] = Vector::<D>::zeros();
                            out[k] = PairOut::default();
                        }
                        // Every pair is written to the next batch slot, but only a contact
                        // advances the count: compaction without a data-dependent branch.
                        // dist > 0 always (two centres never coincide within the overlap
                        // limit); a separated pair's values are overwritten unused.
                        let dist = dist2.sqrt();
                        let d = cut - dist;
                        if contact & (d > max_ratio * ri.min(rj)) && bad.is_none() {
                            bad = Some(first + c * CHUNK + k);
                        }
                        let n = dx / dist;
                        let mut vrel = vj - vi;
                        if rot {
                            // w_j x (-(r_j - d/2) n) - w_i x ((r_i - d/2) n)
                            // SAFETY: as above.
                            let (wi, wj) = unsafe { (at(&p.w, i), at(&p.w, j)) };
                            let w = wi * (ri - 0.5 * d) + wj * (rj - 0.5 * d);
                            vrel -= <Dim<D>>::cross_wv(w, &n);
                        }
                        // b.len < BATCH always (a full batch is flushed at once); the mask
                        // says so to the compiler, which then drops the bounds checks.
                        let m = b.len & (BATCH - 1);
                        b.pair[m] = k as u32;
                        for a in 0..D {
                            b.n[a][m] = n[a];
                            b.v[a][m] = vrel[a];
                            b.h[a][m] = hist[k][a];
                        }
                        b.d[m] = d;
                        (b.sr[m], b.sm[m]) = (coefs[k].sr, coefs[k].sm);
                        b.len += contact as usize;
                        if b.len == BATCH {
                            flush(b, hist, out);
                        }
                    }
                    if b.len > 0 {
                        flush(b, hist, out);
                    }
                    bad
                },
            )
            .flatten()
            .min();
        if let Some(k) = bad_pair {
            let [i, j] = pr.ij[k];
            let d = pr.out[k].d;
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

        // 4. gather
        let pr = &self.pairs;
        let walls = &self.walls;
        let gravity = self.cfg.gravity;
        let drag = self.cfg.drag;
        let p = &mut self.p;
        let (x, v, w, r, m, fz) = (&p.x, &p.v, &p.w, &p.r, &p.m, &p.frozen);
        let bad_wall =
            p.f.par_chunks_mut(CHUNK)
                .zip(p.t.par_chunks_mut(CHUNK))
                .zip(p.wall_hist.par_chunks_mut(CHUNK))
                .zip(p.wall_force.par_chunks_mut(CHUNK))
                .zip(p.wall_mask.par_chunks_mut(CHUNK))
                .zip(p.wall_near.par_chunks(CHUNK))
                .enumerate()
                .filter_map(|(c, (((((f, t), wh), wf), wm), wn))| {
                    let mut bad = None;
                    for k in 0..f.len() {
                        let q = c * CHUNK + k;
                        if skip_frozen && fz[q] {
                            continue;
                        }
                        let mut fq = gravity * m[q];
                        if drag > 0.0 {
                            fq -= v[q] * drag;
                        }
                        let mut tq = Ang::<D>::default();
                        let pout = &pr.out[..];
                        // The pairs q starts (force on q: -f), as two ranges of the list,
                        // then those it ends (+f) through their index list. The torque of
                        // the tangential force is -(r_q - d/2) n x f_t on either end.
                        let own = [
                            pr.i_frozen[q] as usize..pr.i_frozen[q + 1] as usize,
                            pr.i_active[q] as usize..pr.i_active[q + 1] as usize,
                        ];
                        let ends = &pr.j_inc[pr.j_start[q] as usize..pr.j_start[q + 1] as usize];
                        if rot && friction_on {
                            let rq = r[q];
                            for k in own.into_iter().flatten() {
                                // SAFETY: the ranges and index lists stay below the pair
                                // count (see `at`).
                                let o = unsafe { at(pout, k) };
                                fq -= o.f;
                                tq += o.nxf * -(rq - 0.5 * o.d);
                            }
                            for &k in ends {
                                // SAFETY: as above.
                                let o = unsafe { at(pout, k as usize) };
                                fq += o.f;
                                tq += o.nxf * -(rq - 0.5 * o.d);
                            }
                        } else {
                            for k in own.into_iter().flatten() {
                                // SAFETY: as above.
                                fq -= unsafe { at(pout, k) }.f;
                            }
                            for &k in ends {
                                // SAFETY: as above.
                                fq += unsafe { at(pout, k as usize) }.f;
                            }
                        }
                        // visit only the walls that can touch (most particles: none)
                        let mut candidates = wn[k] | wm[k];
                        while candidates != 0 {
                            let wi = candidates.trailing_zeros() as usize;
                            candidates &= candidates - 1;
                            let wall = &walls[wi];
                            let s = wall.gap(&x[q]);
                            let d = r[q] - s;
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
                            if d > max_ratio * r[q] && bad.is_none() {
                                bad = Some((q, wi, d));
                            }
                            let n = wall.normal::<D>();
                            let arm = r[q] - 0.5 * d;
                            // wall at rest: relative velocity of the wall w.r.t. the particle
                            let mut vrel = -v[q];
                            if rot {
                                vrel -= <Dim<D>>::cross_wv(w[q], &(n * arm));
                            }
                            let params = PairParams {
                                r_eff: r[q],
                                m_eff: m[q],
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
                            if rot && friction_on {
                                tq += <Dim<D>>::cross_vv(&n, &fc.tangential) * -arm;
                            }
                        }
                        f[k] = fq;
                        t[k] = tq;
                    }
                    bad
                })
                .min_by_key(|b| b.0);
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
        Ok(())
    }
}
