//! The Verlet pair list: its per-pair state in blocks, the rebuild that carries the
//! tangential history of surviving pairs over, and the incidence lists the gather reads.

use super::*;

/// The pair (Verlet) list and its per-pair state in two runs, each sorted by (i, j):
/// first the pairs of two frozen particles, whose forces need no update between
/// freeze decisions and which a rebuild keeps without a search, then the pairs with at
/// least one active particle.
#[derive(Clone, Debug, Default)]
pub(super) struct Pairs<const D: usize> {
    pub(super) ij: Vec<[u32; 2]>,
    /// Length of the first run (0 when nothing is frozen).
    pub(super) n_frozen_pairs: usize,
    /// Per-pair state (history, law factors, and what the pair pass leaves for the
    /// gather: force on j, n x f_t, overlap), pair k in block
    /// `k >> BLOCK_SHIFT`, lane `k & (BLOCK - 1)`; `ceil(len / BLOCK)` blocks.
    pub(super) blocks: Vec<PairBlock<D>>,
    /// The rolling state beside each block, with rolling resistance; empty without
    /// it (no memory is spent on it then). Every move of the blocks moves it alike.
    pub(super) roll: Vec<RollBlock<D>>,
    /// Whether `roll` is kept (the material has rolling resistance).
    pub(super) roll_on: bool,
    /// Pairs whose first particle is p: `i_frozen[p]..i_frozen[p + 1]` in the frozen
    /// run and `i_active[p]..i_active[p + 1]` in the active one (both runs are sorted
    /// by i, so these are ranges: the gather reads them in order, with no index list).
    pub(super) i_frozen: Vec<u32>,
    pub(super) i_active: Vec<u32>,
    /// Pairs whose second particle is p: `j_inc[j_start[p]..j_start[p + 1]]`, in list
    /// order.
    pub(super) j_start: Vec<u32>,
    pub(super) j_inc: Vec<u32>,
}

impl<const D: usize> Pairs<D> {
    /// The state of pair k.
    #[inline]
    pub(super) fn get(&self, k: usize) -> PairRecord<D> {
        self.blocks[k >> BLOCK_SHIFT].get(k & (BLOCK - 1))
    }

    /// Blocks for `len` pairs, pair k set to `fill(k)`, built beside any other list:
    /// the tests' oracle for the moves the engine makes in place. Each block is zeroed
    /// and filled by the thread that owns it.
    #[cfg(test)]
    pub(super) fn build_blocks(
        len: usize,
        fill: impl Fn(usize) -> PairRecord<D> + Sync,
    ) -> Vec<PairBlock<D>> {
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

    /// Sets the state of pair k.
    #[inline]
    pub(super) fn set(&mut self, k: usize, rec: &PairRecord<D>) {
        self.blocks[k >> BLOCK_SHIFT].set(k & (BLOCK - 1), rec);
    }

    /// Whether the list keeps rolling state.
    #[inline]
    pub(super) fn rolls(&self) -> bool {
        self.roll_on
    }

    /// The rolling state of pair k (with rolling resistance).
    #[inline]
    pub(super) fn get_roll(&self, k: usize) -> RollRecord<D> {
        self.roll[k >> BLOCK_SHIFT].get(k & (BLOCK - 1))
    }

    /// Sets the rolling state of pair k (with rolling resistance).
    #[inline]
    pub(super) fn set_roll(&mut self, k: usize, rec: &RollRecord<D>) {
        self.roll[k >> BLOCK_SHIFT].set(k & (BLOCK - 1), rec);
    }

    /// Switches the rolling state on (zero for every pair) or off (freed).
    pub(super) fn keep_roll(&mut self, on: bool) {
        self.roll_on = on;
        self.roll = if on {
            zeroed_blocks(self.blocks.len())
        } else {
            Vec::new()
        };
    }

    /// Reorders every per-pair array in place: entry k takes the old entry
    /// `order[k]` (a permutation of `0..len`). Each cycle of the permutation is
    /// followed once, holding one record aside, so the pair state is never copied
    /// whole: at a million spheres a second copy of the blocks is 300 bytes a particle,
    /// and it set the peak resident set of a pack.
    pub(super) fn permute(&mut self, order: &[u32]) {
        debug_assert_eq!(order.len(), self.ij.len());
        let mut done = vec![0u64; order.len().div_ceil(64)];
        for s in 0..order.len() {
            if done[s / 64] >> (s % 64) & 1 == 1 || order[s] as usize == s {
                continue;
            }
            let (held, held_ij) = (self.get(s), self.ij[s]);
            let rolls = self.rolls();
            let held_roll = if rolls {
                self.get_roll(s)
            } else {
                RollRecord::default()
            };
            let mut k = s;
            loop {
                done[k / 64] |= 1 << (k % 64);
                let o = order[k] as usize;
                if o == s {
                    self.set(k, &held);
                    self.ij[k] = held_ij;
                    if rolls {
                        self.set_roll(k, &held_roll);
                    }
                    break;
                }
                let rec = self.get(o);
                self.set(k, &rec);
                self.ij[k] = self.ij[o];
                if rolls {
                    let rr = self.get_roll(o);
                    self.set_roll(k, &rr);
                }
                k = o;
            }
        }
    }

    /// Replaces the pairs from `keep` on by `ij`, in place: new pair `keep + t`
    /// continues the old pair `src[t]` (its state moves over), or starts afresh
    /// (`src[t] == u32::MAX`: state `fresh(ij[t])`). The first `keep` pairs stay.
    ///
    /// `src` must increase over the continued pairs (both lists sorted by (i, j)).
    /// Then a pair that moves to a lower index is moved in increasing order, one that
    /// moves to a higher index in decreasing order, and neither overwrites a state that
    /// is still to be read: the new list takes the old one's memory, and no second copy
    /// of the pair state is ever held (see `permute`). Fresh pairs are written last,
    /// in parallel by block. The blocks grow by `spare` more than they need when they
    /// must grow.
    pub(super) fn merge_in_place(
        &mut self,
        keep: usize,
        ij: &[[u32; 2]],
        src: &[u32],
        spare: usize,
        fresh: impl Fn([u32; 2]) -> PairRecord<D> + Sync,
    ) {
        let total = keep + ij.len();
        let n = total.div_ceil(BLOCK);
        let had = self.blocks.len();
        if n > had {
            self.blocks.reserve_exact(n - had + spare);
            // SAFETY: a PairBlock is arrays of f64 only (no padding, no pointers), so the
            // all-zero pattern is a valid block (0.0); n <= capacity after the reserve.
            unsafe {
                let tail = &mut self.blocks.spare_capacity_mut()[..n - had];
                std::ptr::write_bytes(tail.as_mut_ptr(), 0, n - had);
                self.blocks.set_len(n);
            }
        }
        // The continued pairs move in runs of one shift (a rebuild changes a few pairs
        // here and there, and all the others shift together between them), copied a
        // block's lane range at a time, row by row: several times faster than a
        // record a pair.
        let runs = shift_runs(keep, src);
        let groups = if src.len() < MERGE_PAR_MIN {
            1
        } else {
            // (the tests take three groups, to cover the buffers on any machine)
            rayon::current_num_threads().max(if cfg!(test) { 3 } else { 1 })
        };
        let groups = run_groups(&runs, groups);
        // The moves run in groups of runs, one a thread. A group's sources that lie
        // among another group's destinations are read first, into a buffer: beyond
        // that, each group reads and writes only its own destinations. In a rebuild
        // they are the few pairs by which the list grew or shrank before the group's
        // end; a buffer larger than an eighth of the list falls back to one group.
        let buffered: Vec<Vec<(usize, PairRecord<D>)>> = if groups.len() > 1 {
            groups
                .par_iter()
                .map(|g| {
                    let (lo, hi) = group_span(&runs[g.clone()]);
                    let mut buf = Vec::new();
                    for run in &runs[g.clone()] {
                        // the run's sources before and after the part among the group's
                        // destinations
                        let (k, o, end) =
                            (run.0 as usize, run.1 as usize, (run.1 + run.2) as usize);
                        let (_, a, len) = inside(run, lo, hi);
                        for s in (o..a.min(end)).chain((a + len).max(o)..end) {
                            buf.push((k + (s - o), self.get(s)));
                        }
                    }
                    buf
                })
                .collect()
        } else {
            Vec::new()
        };
        let (groups, buffered) = if buffered.iter().map(Vec::len).sum::<usize>() > src.len() / 8 {
            (run_groups(&runs, 1), Vec::new())
        } else {
            (groups, buffered)
        };
        let one = groups.len() == 1;
        let base = SyncPtr(self.blocks.as_mut_ptr());
        groups.par_iter().enumerate().for_each(|(gi, g)| {
            let runs = &runs[g.clone()];
            // one group reads every source in place
            let (lo, hi) = if one {
                (0, usize::MAX)
            } else {
                group_span(runs)
            };
            for run in runs {
                let (k, o, len) = inside(run, lo, hi);
                if o > k {
                    // SAFETY: the blocks hold both ranges (n blocks, grown above; the old
                    // pairs below `had` blocks); the order reads every state of the group
                    // before it is overwritten, and no other group reads or writes these
                    // destinations, nor (buffered) these sources.
                    unsafe { move_run(base.ptr(), o, k, len) };
                }
            }
            for run in runs.iter().rev() {
                let (k, o, len) = inside(run, lo, hi);
                if o < k {
                    // SAFETY: as above.
                    unsafe { move_run(base.ptr(), o, k, len) };
                }
            }
            if let Some(buf) = buffered.get(gi) {
                for (k, rec) in buf {
                    // SAFETY: k is among this group's destinations, which only it writes.
                    unsafe { set_lane(base.ptr(), *k, rec) };
                }
            }
        });
        drop(buffered);
        if self.rolls() {
            self.merge_roll(&runs, n);
        }
        drop(runs);
        let first = keep >> BLOCK_SHIFT;
        self.blocks[first..n]
            .par_iter_mut()
            .with_min_len(REBUILD_MIN_BLOCKS)
            .enumerate()
            .for_each(|(b, blk)| {
                let base = (first + b) * BLOCK;
                for l in 0..BLOCK {
                    let k = base + l;
                    if k < keep {
                        continue;
                    }
                    if k >= total {
                        // lanes past the end hold zeros, as a block built anew
                        blk.set(l, &PairRecord::default());
                    } else if src[k - keep] == u32::MAX {
                        blk.set(l, &fresh(ij[k - keep]));
                    }
                }
            });
        if self.rolls() {
            // fresh pairs and lanes past the end start from zero
            for k in keep..(n * BLOCK) {
                if k >= total || src[k - keep] == u32::MAX {
                    self.set_roll(k, &RollRecord::default());
                }
            }
            self.roll.truncate(n);
            trim(&mut self.roll);
        }
        self.blocks.truncate(n);
        trim(&mut self.blocks);
        self.ij.truncate(keep);
        self.ij.extend_from_slice(ij);
        trim(&mut self.ij);
    }

    /// The rolling state's share of [`merge_in_place`](Self::merge_in_place): the same
    /// runs moved in the same safe order, on one thread, into `n` blocks.
    fn merge_roll(&mut self, runs: &[(u32, u32, u32)], n: usize) {
        if self.roll.len() < n {
            // grown as the pair blocks grow, not doubled
            let more = n - self.roll.len();
            self.roll
                .reserve_exact(more + self.blocks.capacity().saturating_sub(n));
            self.roll.resize_with(n, RollBlock::default);
        }
        let base = self.roll.as_mut_ptr();
        for &(k, o, len) in runs {
            if o > k {
                // SAFETY: both ranges lie in the n blocks; runs that move down are
                // moved in increasing order, so none overwrites a state still to read.
                unsafe { move_run(base, o as usize, k as usize, len as usize) };
            }
        }
        for &(k, o, len) in runs.iter().rev() {
            if o < k {
                // SAFETY: as above, runs that move up in decreasing order.
                unsafe { move_run(base, o as usize, k as usize, len as usize) };
            }
        }
    }

    /// Sorts the two runs into one run in (i, j) order, in place (see `permute`).
    pub(super) fn merge_runs(&mut self) {
        if self.n_frozen_pairs > 0 {
            let order = self.sorted_order();
            self.permute(&order);
            self.n_frozen_pairs = 0;
        }
    }

    /// Keeps the pairs for which `renumber` gives new indices, in order, with their
    /// state, in place: a kept pair only moves down, so moving them in increasing order
    /// overwrites no state still to be read. The list must be one run; the incidence
    /// lists are left to the next rebuild, which the caller forces.
    pub(super) fn retain_in_place(&mut self, renumber: impl Fn([u32; 2]) -> Option<[u32; 2]>) {
        debug_assert_eq!(self.n_frozen_pairs, 0);
        let mut out = 0;
        for k in 0..self.ij.len() {
            if let Some(ij) = renumber(self.ij[k]) {
                if out != k {
                    let rec = self.get(k);
                    self.set(out, &rec);
                    if self.rolls() {
                        let rr = self.get_roll(k);
                        self.set_roll(out, &rr);
                    }
                }
                self.ij[out] = ij;
                out += 1;
            }
        }
        let n = out.div_ceil(BLOCK);
        for k in out..(n * BLOCK).min(self.ij.len()) {
            // lanes past the end hold zeros, as a block built anew
            self.set(k, &PairRecord::default());
            if self.rolls() {
                self.set_roll(k, &RollRecord::default());
            }
        }
        if self.rolls() {
            self.roll.truncate(n);
            trim(&mut self.roll);
        }
        self.blocks.truncate(n);
        trim(&mut self.blocks);
        self.ij.truncate(out);
        trim(&mut self.ij);
        self.drop_incidence();
    }

    /// Frees the incidence lists, which serve the gather alone (a rebuild makes them
    /// again).
    pub(super) fn drop_incidence(&mut self) {
        self.i_frozen = Vec::new();
        self.i_active = Vec::new();
        self.j_start = Vec::new();
        self.j_inc = Vec::new();
    }

    /// Checks the invariant that the unchecked indexing of the force loops relies on:
    /// every particle index in the list is below `n`, every incidence entry below the
    /// pair count, and the per-pair arrays have one entry per pair. Panics otherwise (a
    /// bug in the list's construction, never a user error).
    pub(super) fn check_indices(&self, n: usize) {
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
        assert!(self.roll.len() == if self.roll_on { self.blocks.len() } else { 0 });
    }

    /// Pair indices in (i, j) order: the merge of the two sorted runs.
    pub(super) fn sorted_order(&self) -> Vec<u32> {
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

/// The continued pairs of a merge as runs `(k, o, len)`: new pairs `k..k + len`
/// continue old pairs `o..o + len`, one shift for the whole run; in increasing k.
fn shift_runs(keep: usize, src: &[u32]) -> Vec<(u32, u32, u32)> {
    let mut runs: Vec<(u32, u32, u32)> = Vec::new();
    for (t, &o) in src.iter().enumerate() {
        if o == u32::MAX {
            continue;
        }
        let k = (keep + t) as u32;
        match runs.last_mut() {
            Some((k0, o0, len)) if *k0 + *len == k && *o0 + *len == o => *len += 1,
            _ => runs.push((k, o, 1)),
        }
    }
    runs
}

/// Least pairs in a merge for its moves to run on several threads (results do not
/// depend on it; the tests take a small one, to cover the threaded moves).
const MERGE_PAR_MIN: usize = if cfg!(test) { 256 } else { 1 << 16 };

/// `runs` cut into at most `groups` ranges of runs, with about as many pairs each.
fn run_groups(runs: &[(u32, u32, u32)], groups: usize) -> Vec<std::ops::Range<usize>> {
    let total: usize = runs.iter().map(|r| r.2 as usize).sum();
    let mut out = Vec::with_capacity(groups);
    let (mut start, mut acc) = (0, 0);
    for (r, run) in runs.iter().enumerate() {
        acc += run.2 as usize;
        if acc * groups >= total * (out.len() + 1) && out.len() + 1 < groups {
            out.push(start..r + 1);
            start = r + 1;
        }
    }
    out.push(start..runs.len());
    out
}

/// The part of run `(k, o, len)` whose sources lie in `lo..hi` (a group's destinations),
/// as `(k', o', len')`: new pairs `k'..k' + len'` continue old pairs `o'..o' + len'`.
fn inside(&(k, o, len): &(u32, u32, u32), lo: usize, hi: usize) -> (usize, usize, usize) {
    let (o, len) = (o as usize, len as usize);
    let (a, b) = (o.clamp(lo, hi), (o + len).clamp(lo, hi));
    (k as usize + (a - o), a, b - a)
}

/// The destinations `lo..hi` of a group of runs (empty: `0..0`).
fn group_span(runs: &[(u32, u32, u32)]) -> (usize, usize) {
    match (runs.first(), runs.last()) {
        (Some(a), Some(b)) => (a.0 as usize, (b.0 + b.2) as usize),
        _ => (0, 0),
    }
}

/// Writes the state of pair `k` in the blocks at `base` through raw pointers, lane by
/// lane: another thread may be writing other lanes of the same block.
///
/// # Safety
/// Block `k >> BLOCK_SHIFT` exists, and nothing else reads or writes pair k's lanes.
unsafe fn set_lane<const D: usize>(base: *mut PairBlock<D>, k: usize, rec: &PairRecord<D>) {
    let (b, l) = (base.wrapping_add(k >> BLOCK_SHIFT), k & (BLOCK - 1));
    // SAFETY: the caller's; each place is one f64 of the block, no reference is made.
    unsafe {
        for a in 0..D {
            std::ptr::addr_of_mut!((*b).h[a][l]).write(rec.h[a]);
            std::ptr::addr_of_mut!((*b).f[a][l]).write(rec.f[a]);
            std::ptr::addr_of_mut!((*b).t[a][l]).write(rec.t[a]);
        }
        std::ptr::addr_of_mut!((*b).d[l]).write(rec.d);
        std::ptr::addr_of_mut!((*b).sr[l]).write(rec.coefs.sr);
        std::ptr::addr_of_mut!((*b).sm[l]).write(rec.coefs.sm);
    }
}

/// Rows of [`BLOCK_ROW`] lanes in a block of pair state (a [`PairBlock`] or a
/// [`RollBlock`]): every field is one or more rows of f64, so a lane range moves as
/// the same range of each row (the spare lanes past [`BLOCK`] never move).
const fn block_rows<B>() -> usize {
    std::mem::size_of::<B>() / std::mem::size_of::<[Real; BLOCK_ROW]>()
}

/// `n` blocks of pair state, all zero.
fn zeroed_blocks<B: Default>(n: usize) -> Vec<B> {
    let mut v: Vec<B> = Vec::with_capacity(n);
    v.resize_with(n, B::default);
    v
}

/// Moves the states of pairs `from..from + len` to `to..to + len` (pair indices in the
/// blocks at `base`), one block's lane range at a time: from the first lane up when
/// the run moves down (`from > to`), from the last lane down when it moves up, so that
/// a range overlapping its own destination is read before it is overwritten.
///
/// # Safety
/// Both ranges lie within the blocks at `base`, and nothing else reads or writes them.
unsafe fn move_run<B>(base: *mut B, from: usize, to: usize, len: usize) {
    const MASK: usize = BLOCK - 1;
    // a block is rows of f64 and nothing else: no padding, no other field
    const {
        assert!(
            block_rows::<B>() * std::mem::size_of::<[Real; BLOCK_ROW]>()
                == std::mem::size_of::<B>()
        )
    };
    let rows = block_rows::<B>();
    let lanes = |from: usize, to: usize, n: usize| {
        // SAFETY: the caller's ranges; std::ptr::copy allows the two to overlap (a run
        // that moves within one block).
        unsafe {
            let s = base
                .add(from >> BLOCK_SHIFT)
                .cast::<Real>()
                .add(from & MASK);
            let d = base.add(to >> BLOCK_SHIFT).cast::<Real>().add(to & MASK);
            for r in 0..rows {
                std::ptr::copy(s.add(r * BLOCK_ROW), d.add(r * BLOCK_ROW), n);
            }
        }
    };
    if from > to {
        let (mut from, mut to, mut len) = (from, to, len);
        while len > 0 {
            let n = len.min(BLOCK - (from & MASK)).min(BLOCK - (to & MASK));
            lanes(from, to, n);
            (from, to, len) = (from + n, to + n, len - n);
        }
    } else {
        let (mut from_end, mut to_end, mut len) = (from + len, to + len, len);
        while len > 0 {
            let n = len
                .min(((from_end - 1) & MASK) + 1)
                .min(((to_end - 1) & MASK) + 1);
            lanes(from_end - n, to_end - n, n);
            (from_end, to_end, len) = (from_end - n, to_end - n, len - n);
        }
    }
}

/// Returns spare capacity beyond a quarter of the length (a list that shrank a lot),
/// without reallocating on every small fluctuation.
fn trim<T>(v: &mut Vec<T>) {
    if v.capacity() > v.len() + v.len() / 4 {
        v.shrink_to_fit();
    }
}

impl<const D: usize> World<D>
where
    Dim<D>: Spatial<D>,
{
    /// Rebuilds the Verlet list and carries the tangential history of surviving pairs
    /// over (old and new runs are sorted by (i, j), so a merge suffices).
    ///
    /// With particles frozen only the pairs with an active particle are searched: the
    /// frozen run is kept as it is. Its pairs stay valid for good, because frozen
    /// particles do not move; a thaw moves the thawed particle's pairs out of the frozen
    /// run (`partition_pairs`) and asks for a rebuild, which searches them afresh.
    pub(super) fn rebuild_pairs(&mut self) {
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
        if let Some(per) = &self.period {
            // Positions are wrapped into the cell by the drift that takes them out
            // (`integrate`); this catches those set or added outside it.
            p.x.par_iter_mut()
                .with_min_len(REBUILD_MIN_PARTICLES)
                .for_each(|x| *x = per.wrap(*x));
        }
        let reach: Vec<Real> =
            p.r.par_iter()
                .zip(p.half_skin.par_iter())
                .with_min_len(REBUILD_MIN_PARTICLES)
                .map(|(r, h)| r + h)
                .collect();
        let partial = self.n_frozen > 0;
        let mut pr = std::mem::take(&mut self.pairs);
        let period = self.period.as_ref();
        let (ij, keep) = if partial {
            let fz = &self.p.frozen;
            let ij = neighbor_pairs_active(&self.p.x, &reach, period, |i| !fz[i]);
            (ij, pr.n_frozen_pairs)
        } else {
            (neighbor_pairs_periodic(&self.p.x, &reach, period), 0)
        };
        drop(reach);
        if !partial {
            // Everything thawed at once (freezing switched off): the old list's two
            // runs become one run in (i, j) order, in place, so that it merges in place.
            pr.merge_runs();
        }
        // Old pairs that may survive, one run in (i, j) order from `base` on: the
        // active run, or the whole list.
        let base = pr.n_frozen_pairs;
        // For each new pair, the old pair it continues (u32::MAX: a new contact): a
        // merge of the two sorted lists, in parallel chunks of the new one, each
        // starting where a binary search puts its first pair among the old ones.
        let mut src = vec![u32::MAX; ij.len()];
        let old = &pr.ij[base..];
        src.par_chunks_mut(PAIR_CHUNK)
            .zip(ij.par_chunks(PAIR_CHUNK))
            .for_each(|(src, new)| {
                let mut a = old.partition_point(|o| *o < new[0]);
                for (s, pair) in src.iter_mut().zip(new) {
                    while a < old.len() && old[a] < *pair {
                        a += 1;
                    }
                    if a < old.len() && old[a] == *pair {
                        *s = (base + a) as u32;
                    }
                }
            });
        // The kept frozen run stays in front; the other pairs carry their state over,
        // or start from zero with fresh law factors.
        let r = &self.p.r;
        let mass = &self.p.m;
        let mat = self.cfg.material;
        let (e_star, g_star) = (self.e_star, self.g_star);
        let fresh = |[i, j]: [u32; 2]| {
            let mut rec = PairRecord::default();
            let (ri, rj) = (r[i as usize], r[j as usize]);
            let (mi, mj) = (mass[i as usize], mass[j as usize]);
            let params = PairParams {
                r_eff: ri * rj / (ri + rj),
                m_eff: mi * mj / (mi + mj),
                e_star,
                g_star,
                damping: mat.damping,
                friction: mat.friction,
            };
            rec.coefs = match mat.law {
                ContactLaw::HertzMindlin => PairFactors::new(&params),
                ContactLaw::Linear { .. } => PairFactors::linear(&params),
            };
            rec
        };
        // With part of the list frozen, a list that grows a little at each rebuild
        // finds room the next time: an eighth to spare when the blocks must grow.
        let total = keep + ij.len();
        let spare = if partial {
            total.div_ceil(BLOCK) / 8
        } else {
            0
        };
        // The old pairs that may survive are one run sorted by (i, j), as the new ones
        // are: the new list is merged into the old one's memory.
        pr.merge_in_place(keep, &ij, &src, spare, fresh);
        drop((src, ij));
        pr.n_frozen_pairs = keep;
        self.pairs = pr;
        if partial {
            self.build_incidence();
        } else {
            self.partition_pairs();
        }
        self.p.x_ref.copy_from_slice(&self.p.x);
        // No particle moves more than 2 h before the next rebuild (`Travel`), so only
        // walls within r + 2 h can be touched meanwhile (r + 3 h for margin): the
        // gather skips the others.
        // While walls move, their reach grows by `wall_margin`, and a wall that has
        // moved that far since this rebuild asks for the next one (`moving_walls`).
        let (p, walls, margin) = (&mut self.p, &self.walls, self.wall_margin);
        self.wall_travel = 0.0;
        p.wall_near
            .par_iter_mut()
            .zip(p.x.par_iter())
            .zip(p.r.par_iter().zip(p.half_skin.par_iter()))
            .with_min_len(REBUILD_MIN_PARTICLES)
            .for_each(|((near, x), (r, h))| {
                *near = 0;
                for (wi, wall) in walls.iter().enumerate() {
                    let reach = if margin > 0.0 {
                        r + 3.0 * h + margin
                    } else {
                        r + 3.0 * h
                    };
                    if wall.gap(x) < reach {
                        *near |= 1 << wi;
                    }
                }
            });
        self.list_valid = true;
        self.rebuilds += 1;
        self.rebuild_seconds += start.elapsed().as_secs_f64();
    }

    /// Incidence: for each particle the ranges of the pairs it starts (one per run)
    /// and the list of those it ends, in list order.
    pub(super) fn build_incidence(&mut self) {
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
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use rand::seq::SliceRandom;
    use rand::{Rng, SeedableRng};

    /// A record that names its pair: every field differs between pairs.
    fn tagged(tag: u32) -> PairRecord<3> {
        let t = tag as Real;
        let mut rec = PairRecord::<3> {
            h: [t, t + 0.1, t + 0.2],
            f: [t + 0.3, t + 0.4, t + 0.5],
            t: [t + 0.6, t + 0.7, t + 0.8],
            d: t + 0.9,
            ..Default::default()
        };
        rec.coefs.sr = t + 0.01;
        rec.coefs.sm = t + 0.02;
        rec
    }

    /// A rolling state that names its pair.
    fn tagged_roll(tag: u32) -> RollRecord<3> {
        let t = tag as Real;
        RollRecord {
            h: [t + 0.05, t + 0.15, t + 0.25],
            m: [t + 0.35, t + 0.45, t + 0.55],
        }
    }

    /// Rolling blocks for `len` pairs, pair k set to `fill(k)`, the rest zero.
    fn build_roll(len: usize, fill: impl Fn(usize) -> RollRecord<3>) -> Vec<RollBlock<3>> {
        let mut v = zeroed_blocks::<RollBlock<3>>(len.div_ceil(BLOCK));
        for k in 0..len {
            v[k >> BLOCK_SHIFT].set(k & (BLOCK - 1), &fill(k));
        }
        v
    }

    /// Every lane of every rolling block, the lanes past the end included.
    fn roll_lanes(v: &[RollBlock<3>]) -> Vec<RollRecord<3>> {
        v.iter()
            .flat_map(|b| (0..BLOCK).map(|l| b.get(l)))
            .collect()
    }

    /// A list of `m` pairs, pair k tagged `k` and named (k, k + 1), with rolling
    /// state, so that every move is checked on both.
    fn tagged_list(m: usize) -> Pairs<3> {
        Pairs {
            ij: (0..m as u32).map(|k| [k, k + 1]).collect(),
            blocks: Pairs::<3>::build_blocks(m, |k| tagged(k as u32)),
            roll: build_roll(m, |k| tagged_roll(k as u32)),
            roll_on: true,
            ..Default::default()
        }
    }

    /// Every lane of every block, the lanes past the end included.
    fn lanes(p: &Pairs<3>) -> Vec<PairRecord<3>> {
        p.blocks
            .iter()
            .flat_map(|b| (0..BLOCK).map(|l| b.get(l)))
            .collect()
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]
        /// The in-place permutation gives what gathering into a new list gives.
        #[test]
        fn permute_in_place_equals_a_gather(seed in 0u64..10_000, m in 0usize..700) {
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
            let mut order: Vec<u32> = (0..m as u32).collect();
            order.shuffle(&mut rng);
            // half the cases keep most pairs in place, as a partition of the list does
            if seed % 2 == 0 {
                order.sort_by_key(|&k| (k % 7 == 0, k));
            }
            let mut p = tagged_list(m);
            p.permute(&order);
            let want = Pairs::<3> {
                ij: order.iter().map(|&k| [k, k + 1]).collect(),
                blocks: Pairs::<3>::build_blocks(m, |k| tagged(order[k])),
                ..Default::default()
            };
            prop_assert_eq!(&p.ij, &want.ij);
            prop_assert_eq!(lanes(&p), lanes(&want));
            let want_roll = build_roll(m, |k| tagged_roll(order[k]));
            prop_assert_eq!(roll_lanes(&p.roll), roll_lanes(&want_roll));
        }

        /// The in-place merge gives what a list built beside the old one gives: the
        /// kept run, the continued pairs' states, the fresh ones, and zeros past the
        /// end, whether the list grows or shrinks.
        #[test]
        fn merge_in_place_equals_a_build_beside(seed in 0u64..10_000, m in 0usize..3000,
                                                keep_frac in 0.0f64..1.0,
                                                survive in 0.0f64..1.0,
                                                grow in 0.0f64..3.0, sparse in 0.3f64..1.0) {
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
            let keep = (keep_frac * m as f64) as usize;
            // the continued pairs: an increasing choice among the old ones past `keep`,
            // with fresh ones (tagged from 10 000 on) among and around them; a share
            // `sparse` of the old pairs simply continue, as in a rebuild of a pack at
            // rest, where the list's few changes shift long runs of pairs together
            let mut src = Vec::new();
            for o in keep..m {
                if rng.random::<f64>() < sparse {
                    src.push(o as u32);
                    continue;
                }
                while rng.random::<f64>() < grow / (1.0 + grow) {
                    src.push(u32::MAX);
                }
                if rng.random::<f64>() < survive {
                    src.push(o as u32);
                }
            }
            let ij: Vec<[u32; 2]> = (0..src.len() as u32).map(|t| [t, 10_000 + t]).collect();
            let fresh = |[_, j]: [u32; 2]| tagged(j);
            let mut p = tagged_list(m);
            p.merge_in_place(keep, &ij, &src, 3, fresh);
            let total = keep + ij.len();
            let mut want_ij: Vec<[u32; 2]> = (0..keep as u32).map(|k| [k, k + 1]).collect();
            want_ij.extend_from_slice(&ij);
            let want = Pairs::<3>::build_blocks(total, |k| match k {
                k if k < keep => tagged(k as u32),
                k => match src[k - keep] {
                    u32::MAX => fresh(ij[k - keep]),
                    o => tagged(o),
                },
            });
            let want = Pairs::<3> { ij: want_ij, blocks: want, ..Default::default() };
            prop_assert_eq!(&p.ij, &want.ij);
            prop_assert_eq!(lanes(&p), lanes(&want));
            // the rolling state moves alike; fresh pairs start from zero
            let want_roll = build_roll(total, |k| match k {
                k if k < keep => tagged_roll(k as u32),
                k => match src[k - keep] {
                    u32::MAX => RollRecord::default(),
                    o => tagged_roll(o),
                },
            });
            prop_assert_eq!(roll_lanes(&p.roll), roll_lanes(&want_roll));
        }

        /// Keeping some pairs in place gives what a list built beside the old one of
        /// the kept pairs gives: their states in order, renumbered, and zeros past the
        /// end.
        #[test]
        fn retain_in_place_equals_a_build_beside(seed in 0u64..10_000, m in 0usize..900,
                                                 survive in 0.0f64..1.0) {
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
            let kept: Vec<bool> = (0..m).map(|_| rng.random::<f64>() < survive).collect();
            let mut p = tagged_list(m);
            p.retain_in_place(|[i, j]| kept[i as usize].then_some([j, i]));
            let old: Vec<u32> = (0..m as u32).filter(|&k| kept[k as usize]).collect();
            let want = Pairs::<3> {
                ij: old.iter().map(|&k| [k + 1, k]).collect(),
                blocks: Pairs::<3>::build_blocks(old.len(), |k| tagged(old[k])),
                ..Default::default()
            };
            prop_assert_eq!(&p.ij, &want.ij);
            prop_assert_eq!(lanes(&p), lanes(&want));
            let want_roll = build_roll(old.len(), |k| tagged_roll(old[k]));
            prop_assert_eq!(roll_lanes(&p.roll), roll_lanes(&want_roll));
            prop_assert!(p.j_inc.is_empty() && p.i_active.is_empty());
        }
    }
}
