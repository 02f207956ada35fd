//! Cell lists.
//!
//! Cells are cubes (squares) of one side. With radii of one size the side is at least
//! the largest interaction distance (twice the largest reach, radius + half skin), so
//! every pair closer than its cutoff lies in the same or an adjacent cell (3^D cells to
//! visit, in 3^(D-1) runs of adjacent cells). At a wide size ratio the pair search
//! takes smaller cells, sized by a cost estimate: the particles whose reach fits half
//! a cell pair among themselves in 3^D cells, and the few larger ones visit the ball
//! of cells within their own reach (`search_cell`, `CellGrid::for_each_row_within`).
//! Cells are filled by a counting sort, which is stable: inside a cell particles keep
//! increasing index order. The pair list comes out sorted by (i, j) whatever the thread
//! count or the cell size.

use super::Period;
use crate::math::{Real, Vector};
use rayon::prelude::*;

/// A static cell grid over a set of positions.
#[derive(Clone, Debug)]
pub struct CellGrid<const D: usize> {
    /// Side of a cell per axis (m): one value, except on periodic axes, whose cells
    /// divide the period evenly.
    cell: [Real; D],
    dims: [usize; D],
    /// Periodic axes: the stencil wraps around them.
    wrap: [bool; D],
    /// `start[c]..start[c + 1]` indexes `members` for cell `c`.
    start: Vec<u32>,
    members: Vec<u32>,
    /// Lower corner of the grid (m).
    lo: Vector<D>,
}

impl<const D: usize> CellGrid<D> {
    /// Builds the grid with cells of side at least `min_cell` (m). When the particles
    /// are spread so thinly that the grid would exceed about 8 cells per particle, the
    /// cells grow instead (memory stays O(N); correctness is unaffected).
    pub fn build(x: &[Vector<D>], min_cell: Real) -> Self {
        Self::build_with(x, min_cell, None)
    }

    /// [`build`](Self::build) over a cell with periodic axes: on those the grid spans
    /// the period [lo, lo + L), which it divides into whole cells, and the stencil
    /// wraps around. Positions must lie in [lo, lo + L) on the periodic axes.
    pub fn build_with(x: &[Vector<D>], min_cell: Real, period: Option<&Period<D>>) -> Self {
        let n = x.len();
        let (mut lo, mut hi) = bounds(x);
        if n == 0 {
            lo = Vector::<D>::zeros();
            hi = Vector::<D>::zeros();
        }
        let mut wrap = [false; D];
        if let Some(per) = period {
            for k in 0..D {
                if per.periodic(k) {
                    wrap[k] = true;
                    lo[k] = per.lo[k];
                    hi[k] = per.lo[k] + per.len[k];
                }
            }
        }
        // cells per axis for a cell side c: a periodic axis takes whole cells of at
        // least c, the others enough cells of side c to cover the extent
        let dims_for = |c: Real, k: usize| -> Real {
            if wrap[k] {
                ((hi[k] - lo[k]) / c).floor().max(1.0)
            } else {
                ((hi[k] - lo[k]) / c).floor() + 1.0
            }
        };
        let max_cells = (8 * n + 64) as f64;
        let mut cell = min_cell.max(1e-300);
        let mut dims = [1usize; D];
        // An extent that overflows (coordinates near +-1e308) would make the cell size
        // NaN and the loop below endless: one cell then holds everything.
        let finite = (0..D).all(|k| (hi[k] - lo[k]).is_finite());
        loop {
            if !finite || !cell.is_finite() {
                cell = Real::INFINITY;
                dims = [1usize; D];
                break;
            }
            let mut total = 1.0f64;
            for k in 0..D {
                total *= dims_for(cell, k);
            }
            if total <= max_cells {
                for (k, d) in dims.iter_mut().enumerate() {
                    *d = dims_for(cell, k) as usize;
                }
                break;
            }
            cell *= (total / max_cells).powf(1.0 / D as f64) * 1.01;
        }
        let mut cells = [cell; D];
        for k in 0..D {
            if wrap[k] && cell.is_finite() {
                cells[k] = (hi[k] - lo[k]) / dims[k] as Real;
            }
        }
        let ncell: usize = dims.iter().product();
        // each particle's cell once (the sort reads its key twice)
        let cell_of: Vec<u32> = x
            .par_iter()
            .with_min_len(PAR_MIN)
            .map(|p| {
                let c = cell_coords(p, &lo, &cells, &dims);
                (0..D).rev().fold(0, |acc, k| acc * dims[k] + c[k]) as u32
            })
            .collect();
        let (start, members) = counting_sort(n, ncell, |i| cell_of[i] as usize);
        CellGrid {
            cell: cells,
            dims,
            wrap,
            start,
            members,
            lo,
        }
    }

    /// Side of a cell (m).
    pub fn cell_size(&self) -> Real {
        self.cell.iter().cloned().fold(Real::INFINITY, Real::min)
    }

    /// Particle indices in cell order: cell `c` holds those at `start[c]..start[c + 1]`.
    pub fn members(&self) -> &[u32] {
        &self.members
    }

    /// Calls `f(range)` for the 3^(D-1) runs of [`members`](Self::members) (as ranges of
    /// positions in it) that cover the 3^D cells around position `p` (its own
    /// included). Cells are numbered with the first axis fastest, so the (up to) three
    /// cells of a row along that axis are adjacent in `members`: one contiguous run per
    /// row, no per-cell bookkeeping.
    #[inline]
    pub fn for_each_row(&self, p: &Vector<D>, f: impl FnMut(std::ops::Range<usize>)) {
        self.for_each_row_in(&self.coords(p), f);
    }

    /// The cell coordinates of position `p`, clamped to the grid.
    #[inline]
    pub(crate) fn coords(&self, p: &Vector<D>) -> [usize; D] {
        cell_coords(p, &self.lo, &self.cell, &self.dims)
    }

    /// [`for_each_row`](Self::for_each_row) around cell `c` (see [`coords`](Self::coords)).
    #[inline]
    pub(crate) fn for_each_row_in(&self, c: &[usize; D], f: impl FnMut(std::ops::Range<usize>)) {
        if self.wraps_around(c) {
            return self.for_each_row_wrapped(c, f);
        }
        self.for_each_row_of(c, f);
    }

    /// Whether the stencil of 3^D cells around cell `c` crosses a periodic edge of the
    /// grid. A cell at least one cell away from the edges of every periodic axis, on an
    /// axis of five cells or more, does not: its rows are those of a bounded grid.
    #[inline]
    fn wraps_around(&self, c: &[usize; D]) -> bool {
        (0..D).any(|k| self.wrap[k] && (self.dims[k] < 5 || c[k] == 0 || c[k] + 1 >= self.dims[k]))
    }

    /// Whether every particle in the 3^D cells around cell `c` lies less than half a
    /// period from any position in `c` along each periodic axis, so that the minimum
    /// image of their separation is the separation itself, up to the sign of a zero
    /// component (each component within two cells of at most a fifth of the period;
    /// see [`Period::image`]): the stencil does not wrap. True on a grid without
    /// periodic axes.
    #[inline]
    pub(crate) fn plain_separations_at(&self, c: &[usize; D]) -> bool {
        !self.wraps_around(c)
    }

    /// [`for_each_row`](Self::for_each_row) around cell `c`, where no row wraps.
    #[inline]
    fn for_each_row_of(&self, c: &[usize; D], mut f: impl FnMut(std::ops::Range<usize>)) {
        let x_lo = c[0].saturating_sub(1);
        let x_hi = (c[0] + 1).min(self.dims[0] - 1);
        // Offsets along the other axes: 3^(D-1) rows.
        'rows: for m in 0..3usize.pow(D as u32 - 1) {
            let mut mm = m;
            let mut base = 0usize;
            let mut stride = self.dims[0];
            for (&ck, &dk) in c.iter().zip(&self.dims).skip(1) {
                let v = ck as isize + (mm % 3) as isize - 1;
                mm /= 3;
                if v < 0 || v >= dk as isize {
                    continue 'rows;
                }
                base += v as usize * stride;
                stride *= dk;
            }
            let (s, e) = (
                self.start[base + x_lo] as usize,
                self.start[base + x_hi + 1] as usize,
            );
            f(s..e);
        }
    }
}

impl<const D: usize> CellGrid<D> {
    /// Calls `f(range)` for runs of [`members`](Self::members) that cover every cell
    /// within `reach` (m) of `p`: the rows along the first axis whose cells come
    /// within `reach` of `p` across the other axes, each trimmed to the cells within
    /// the reach left along it (a ball's stencil, not its bounding cube). A row is one
    /// run, or two where a periodic seam splits it; a row out of reach comes as an
    /// empty run (so the walk needs no test per row). On periodic axes each cell is
    /// visited once, however far the reach spans.
    pub fn for_each_row_within(
        &self,
        p: &Vector<D>,
        reach: Real,
        mut f: impl FnMut(std::ops::Range<usize>),
    ) {
        // Squared gaps from p to the cells at each offset are tabulated per axis for
        // up to this many cells; a wider span is visited whole (no pruning there).
        const TAB: usize = 32;
        // a hair wider than asked, so that rounding in the gaps never drops a cell
        // that holds a partner
        let reach = reach * (1.0 + 1e-9);
        let reach2 = reach * reach;
        let c = cell_coords(p, &self.lo, &self.cell, &self.dims);
        // Per axis: the first cell (possibly past a periodic edge) and how many, and
        // the squared gap from p to each of them (0 where not tabulated).
        let mut first = [0isize; D];
        let mut count = [0usize; D];
        let mut gap2 = [[0.0 as Real; TAB]; D];
        for k in 0..D {
            let d = self.dims[k];
            // cells beyond the own one: ceil(reach / cell), or one more where that
            // is whole (truncation: `ceil` is a libm call on plain x86-64)
            let w = ((reach / self.cell[k]).clamp(0.0, d as Real) as usize + 1).min(d);
            if self.wrap[k] && 2 * w + 1 >= d {
                // the whole period, once
                (first[k], count[k]) = (0, d);
                continue;
            }
            if self.wrap[k] {
                (first[k], count[k]) = (c[k] as isize - w as isize, 2 * w + 1);
            } else {
                let a = c[k].saturating_sub(w);
                (first[k], count[k]) = (a as isize, (c[k] + w).min(d - 1) - a + 1);
            }
            if count[k] <= TAB {
                // where p lies in its own cell, in cells (past 1 at a clamped edge)
                let frac = (p[k] - self.lo[k]) / self.cell[k] - c[k] as Real;
                for (m, g2) in gap2[k][..count[k]].iter_mut().enumerate() {
                    let o = (first[k] + m as isize - c[k] as isize) as Real;
                    let gap = if o > 0.0 {
                        (o - frac).max(0.0)
                    } else if o < 0.0 {
                        (frac - 1.0 - o).max(0.0)
                    } else {
                        0.0
                    } * self.cell[k];
                    *g2 = gap * gap;
                }
            }
        }
        let gap_of = |k: usize, m: usize| if m < TAB { gap2[k][m] } else { 0.0 };
        let d0 = self.dims[0] as isize;
        let own = (c[0] as isize - first[0]) as usize;
        let trim = count[0] <= TAB;
        // The rows across the other axes, in one flat loop whose odometer carries
        // without branches: a per-axis loop, or a test per row, would mispredict at
        // every turn, since the counts and which rows fall within the reach change
        // from particle to particle. A row out of reach becomes an empty run.
        let mut idx = [0usize; D];
        let mut first_cell = [0usize; D];
        let mut rows = 1usize;
        for k in 1..D {
            first_cell[k] = first[k].rem_euclid(self.dims[k] as isize) as usize;
            rows *= count[k];
        }
        for _ in 0..rows {
            let mut base = 0usize;
            let mut stride = self.dims[0];
            let mut across = 0.0;
            for k in 1..D {
                across += gap_of(k, idx[k]);
                let mut cur = first_cell[k] + idx[k];
                cur -= if cur >= self.dims[k] { self.dims[k] } else { 0 };
                base += cur * stride;
                stride *= self.dims[k];
            }
            // the row, trimmed to the cells within the reach left along it (the gaps
            // fall to the cell of p and rise after it)
            let left = reach2 - across;
            let (mut m0, mut m1) = (0usize, count[0] - 1);
            if trim {
                let row = &gap2[0][..count[0]];
                m0 += row[..own].iter().filter(|&&g| g >= left).count();
                m1 -= row[own + 1..].iter().filter(|&&g| g >= left).count();
            }
            let inside = across < reach2;
            let (a, b) = (first[0] + m0 as isize, first[0] + m1 as isize);
            let ra = if a < 0 { a + d0 } else { a } as usize;
            let rb = if b >= d0 { b - d0 } else { b } as usize;
            if a >= 0 && b < d0 {
                let s = self.start[base + ra] as usize;
                let e = self.start[base + rb + 1] as usize;
                f(s..if inside { e } else { s });
            } else if inside {
                // split by the seam of a periodic first axis
                f(self.start[base + ra] as usize..self.start[base + d0 as usize] as usize);
                f(self.start[base] as usize..self.start[base + rb + 1] as usize);
            }
            let mut carry = 1usize;
            for k in 1..D {
                idx[k] += carry;
                carry = (idx[k] == count[k]) as usize;
                idx[k] -= carry * count[k];
            }
        }
    }
}

impl<const D: usize> CellGrid<D> {
    /// [`for_each_row`](Self::for_each_row) on a grid with periodic axes: rows and
    /// cells beyond a periodic edge wrap to the other side, and each cell is visited
    /// once even where an axis has fewer than three cells (the stencil's -1 and +1
    /// would then meet).
    fn for_each_row_wrapped(&self, c: &[usize; D], mut f: impl FnMut(std::ops::Range<usize>)) {
        // the distinct neighbouring coordinates along axis k (at most three)
        let around = |k: usize| -> ([usize; 3], usize) {
            let (ck, dk) = (c[k] as isize, self.dims[k] as isize);
            let mut out = [0usize; 3];
            let mut m = 0;
            for off in -1..=1isize {
                let mut v = ck + off;
                if self.wrap[k] {
                    v = v.rem_euclid(dk);
                } else if v < 0 || v >= dk {
                    continue;
                }
                let v = v as usize;
                if !out[..m].contains(&v) {
                    out[m] = v;
                    m += 1;
                }
            }
            (out, m)
        };
        let mut rows: [([usize; 3], usize); D] = [([0; 3], 0); D];
        for (k, row) in rows.iter_mut().enumerate().skip(1) {
            *row = around(k);
        }
        // runs of adjacent cells along the first axis: wrapped ones split in two
        let (xs, nx) = around(0);
        let mut xs = xs;
        xs[..nx].sort_unstable();
        let mut runs = [(0usize, 0usize); 3];
        let mut nr = 0;
        for &v in &xs[..nx] {
            if nr > 0 && runs[nr - 1].1 + 1 == v {
                runs[nr - 1].1 = v;
            } else {
                runs[nr] = (v, v);
                nr += 1;
            }
        }
        let total: usize = rows.iter().skip(1).map(|r| r.1).product();
        for m in 0..total {
            let mut mm = m;
            let mut base = 0usize;
            let mut stride = self.dims[0];
            for (&(vals, cnt), &dk) in rows.iter().zip(&self.dims).skip(1) {
                base += vals[mm % cnt] * stride;
                mm /= cnt;
                stride *= dk;
            }
            for &(a, b) in &runs[..nr] {
                f(self.start[base + a] as usize..self.start[base + b + 1] as usize);
            }
        }
    }
}

/// Particles per work item of the grid's light parallel passes (bounds, cells,
/// gathers; the results do not depend on it). Each costs a few nanoseconds a particle,
/// less below some 60 000 particles than handing it to the thread pool from outside:
/// with 4 096, the search of 8 952 spheres on one thread took 19 % longer than serial
/// passes (`studies/periodic_search/`).
const PAR_MIN: usize = 32_768;

/// The componentwise least and greatest of `x` (infinite bounds, inverted, for none).
/// Min and max are exact, so the parallel reduction gives the serial result.
fn bounds<const D: usize>(x: &[Vector<D>]) -> (Vector<D>, Vector<D>) {
    x.par_iter()
        .with_min_len(PAR_MIN)
        .fold(
            || {
                (
                    Vector::<D>::repeat(Real::INFINITY),
                    Vector::<D>::repeat(Real::NEG_INFINITY),
                )
            },
            |(lo, hi), p| (lo.inf(p), hi.sup(p)),
        )
        .reduce(
            || {
                (
                    Vector::<D>::repeat(Real::INFINITY),
                    Vector::<D>::repeat(Real::NEG_INFINITY),
                )
            },
            |(l1, h1), (l2, h2)| (l1.inf(&l2), h1.sup(&h2)),
        )
}

/// The cell coordinates of position `p` in a grid with lower corner `lo`, cells of side
/// `cell` and `dims` cells per axis, clamped to the grid. The one formula both the
/// binning and the search use, so that they agree on every particle's cell.
#[inline]
fn cell_coords<const D: usize>(
    p: &Vector<D>,
    lo: &Vector<D>,
    cell: &[Real; D],
    dims: &[usize; D],
) -> [usize; D] {
    let mut c = [0usize; D];
    for (k, ck) in c.iter_mut().enumerate() {
        *ck = (((p[k] - lo[k]) / cell[k]) as usize).min(dims[k] - 1);
    }
    c
}

/// Where the bins of a counting sort start: item `k` (of `n_items`) falls in bin
/// `key(k)` (< `n_bins`), and bin `b` takes positions `start[b]..start[b + 1]`, counted
/// from `base`. Returns `start` (`n_bins + 1` entries).
pub(crate) fn bin_starts(
    n_items: usize,
    n_bins: usize,
    key: impl Fn(usize) -> usize,
    base: usize,
) -> Vec<u32> {
    let mut start = vec![0u32; n_bins + 1];
    for k in 0..n_items {
        start[key(k) + 1] += 1;
    }
    start[0] = base as u32;
    for b in 0..n_bins {
        start[b + 1] += start[b];
    }
    start
}

/// A stable counting sort of the items `0..n_items` by `key` (< `n_bins`): returns
/// `(start, order)` with the items of bin `b` at `order[start[b]..start[b + 1]]`, in
/// increasing item order.
pub(crate) fn counting_sort(
    n_items: usize,
    n_bins: usize,
    key: impl Fn(usize) -> usize,
) -> (Vec<u32>, Vec<u32>) {
    let start = bin_starts(n_items, n_bins, &key, 0);
    let mut fill = start.clone();
    let mut order = vec![0u32; n_items];
    for k in 0..n_items {
        let b = key(k);
        order[fill[b] as usize] = k as u32;
        fill[b] += 1;
    }
    (start, order)
}

/// The pairs of [`neighbor_pairs`] that have at least one particle `i` with `active(i)`,
/// sorted by (i, j). Pairs of two inactive particles are not searched at all: the
/// engine keeps those of frozen particles from an earlier search.
///
/// The work follows the active particles, not the whole set: an inactive particle
/// that lies farther than the largest cutoff from the active ones' bounding box (on the
/// axes that are not periodic) cannot pair with any of them, so the grid is built over
/// the active particles and the inactive ones near that box only. A settling bed whose
/// lower layers are frozen is then searched in a band at its top, whatever its depth.
/// The pairs are the same either way.
pub fn neighbor_pairs_active<const D: usize>(
    x: &[Vector<D>],
    reach: &[Real],
    period: Option<&Period<D>>,
    active: impl Fn(usize) -> bool + Sync,
) -> Vec<[u32; 2]> {
    let n = x.len();
    // below three quarters of the set, the search over the subset pays for its copies
    if let Some(near) = near_active(x, reach, period, &active).filter(|v| v.len() * 4 <= n * 3) {
        let xs: Vec<Vector<D>> = near.iter().map(|&i| x[i as usize]).collect();
        let rs: Vec<Real> = near.iter().map(|&i| reach[i as usize]).collect();
        // `near` is increasing, so the pairs mapped back stay sorted by (i, j)
        let mut pairs = active_pairs_of(&xs, &rs, period, |k| active(near[k] as usize));
        for pair in pairs.iter_mut() {
            *pair = [near[pair[0] as usize], near[pair[1] as usize]];
        }
        return pairs;
    }
    active_pairs_of(x, reach, period, active)
}

/// The particles, in increasing index, that are active or share a cell or a
/// neighbouring cell with an active one, in a coarse grid whose cells are wider than
/// the largest cutoff (2 reach_max). Every pair with an active particle has both ends
/// among them: along each axis its ends lie less than a cell apart, so their cells
/// differ by at most one (around the period on a periodic axis). None where more than
/// three quarters of the particles are active (the whole search is then cheaper), or
/// the extent is not finite.
fn near_active<const D: usize>(
    x: &[Vector<D>],
    reach: &[Real],
    period: Option<&Period<D>>,
    active: &(impl Fn(usize) -> bool + Sync),
) -> Option<Vec<u32>> {
    let n = x.len();
    let n_active = (0..n).filter(|&i| active(i)).count();
    if n_active * 4 > n * 3 {
        return None;
    }
    let reach_max = reach.iter().cloned().fold(0.0, Real::max);
    let (mut lo, hi) = bounds(x);
    let mut span = hi - lo;
    let mut wrap = [false; D];
    if let Some(per) = period {
        for k in (0..D).filter(|&k| per.periodic(k)) {
            wrap[k] = true;
            lo[k] = per.lo[k];
            span[k] = per.len[k];
        }
    }
    // (with no reach, nothing pairs; an extent that overflowed has no grid)
    let usable = reach_max > 0.0 && (0..D).all(|k| span[k].is_finite() && span[k] >= 0.0);
    if !usable {
        return None;
    }
    // The cell side: the cutoff with a margin for the rounding of the cell index (a
    // wider cell only lets more particles in), grown until the grid holds at most
    // about 8 cells a particle.
    let max_cells = (8 * n + 64) as f64;
    let mut c = 2.0 * reach_max * (1.0 + 1e-6);
    let dims_for = |c: Real, k: usize| -> Real {
        if wrap[k] {
            (span[k] / c).floor().max(1.0)
        } else {
            (span[k] / c).floor() + 1.0
        }
    };
    let dims: [usize; D] = loop {
        let total: f64 = (0..D).map(|k| dims_for(c, k)).product();
        if total <= max_cells {
            break std::array::from_fn(|k| dims_for(c, k) as usize);
        }
        c *= (total / max_cells).powf(1.0 / D as f64) * 1.01;
    };
    let side: [Real; D] = std::array::from_fn(|k| {
        if wrap[k] {
            span[k] / dims[k] as Real
        } else {
            c
        }
    });
    let ncell: usize = dims.iter().product();
    let cell: Vec<u32> = x
        .par_iter()
        .with_min_len(4096)
        .map(|p| {
            (0..D).rev().fold(0, |acc, k| {
                let t = ((p[k] - lo[k]) / side[k]).floor();
                acc * dims[k] + (t.max(0.0) as usize).min(dims[k] - 1)
            }) as u32
        })
        .collect();
    // the active particles' cells, grown by one cell along each axis in turn (around
    // the period on a periodic axis): the 3^D cells around each
    let mut marked = vec![false; ncell];
    for i in (0..n).filter(|&i| active(i)) {
        marked[cell[i] as usize] = true;
    }
    let mut grown = vec![false; ncell];
    let mut stride = 1;
    for k in 0..D {
        let d = dims[k];
        for (c, g) in grown.iter_mut().enumerate() {
            let a = (c / stride) % d;
            let below = if a > 0 {
                marked[c - stride]
            } else {
                wrap[k] && marked[c + (d - 1) * stride]
            };
            let above = if a + 1 < d {
                marked[c + stride]
            } else {
                wrap[k] && marked[c - (d - 1) * stride]
            };
            *g = marked[c] | below | above;
        }
        std::mem::swap(&mut marked, &mut grown);
        stride *= d;
    }
    Some(
        (0..n)
            .into_par_iter()
            .with_min_len(4096)
            .filter(|&i| marked[cell[i] as usize] || active(i))
            .map(|i| i as u32)
            .collect(),
    )
}

/// [`neighbor_pairs_active`] over the whole set.
fn active_pairs_of<const D: usize>(
    x: &[Vector<D>],
    reach: &[Real],
    period: Option<&Period<D>>,
    active: impl Fn(usize) -> bool + Sync,
) -> Vec<[u32; 2]> {
    // Only active particles are visited: a pair with an inactive partner of lower
    // index is met from its active side only, and taken there.
    match period {
        None => search(x, reach, None, |d| d, &active, |j| !active(j)),
        Some(per) => search(
            x,
            reach,
            Some(per),
            |d| per.image(d),
            &active,
            |j| !active(j),
        ),
    }
}

/// Every pair (i < j) with |x_i - x_j| < reach_i + reach_j, sorted by (i, j).
///
/// `reach` (m) is each particle's radius plus its half skin h_i >= 0: the list stays
/// valid while no particle has moved more than its own h_i, since a pair left out has a
/// gap of at least h_i + h_j (a Verlet list with a skin per particle; reach = r gives
/// the contacts). Parallel over particles; the output does not depend on the thread
/// count.
pub fn neighbor_pairs<const D: usize>(x: &[Vector<D>], reach: &[Real]) -> Vec<[u32; 2]> {
    search(x, reach, None, |d| d, |_| true, |_| false)
}

/// [`neighbor_pairs`] in a cell with periodic axes (None: none): distances by minimum
/// image, so pairs across the seam are found. Positions must lie in [lo, lo + L) on
/// the periodic axes, and each period must exceed twice the largest cutoff
/// reach_i + reach_j (a pair then has one nearest image).
pub fn neighbor_pairs_periodic<const D: usize>(
    x: &[Vector<D>],
    reach: &[Real],
    period: Option<&Period<D>>,
) -> Vec<[u32; 2]> {
    match period {
        None => neighbor_pairs(x, reach),
        Some(per) => search(x, reach, Some(per), |d| per.image(d), |_| true, |_| false),
    }
}

/// The cell side (m) of the pair search, chosen among 2 reach_max / s for a few
/// divisors s >= 1 by the cost it predicts: each particle tests every candidate in the
/// cells it visits, 3^D cells for a particle whose reach fits half a cell ("small"),
/// (2 ceil((reach_i + reach_max) / cell) + 1)^D for the others ("large"), plus a fixed
/// cost per row of cells visited and per cell built. With radii of one size s = 1
/// wins (every particle is small, the classic grid); at a wide size ratio the cells
/// shrink towards the fines, whose stencils then hold a few fines each instead of
/// hundreds, and the few large particles pay for wide stencils. The choice changes
/// only the work, never the pairs found.
fn search_cell<const D: usize>(
    x: &[Vector<D>],
    reach: &[Real],
    reach_max: Real,
    period: Option<&Period<D>>,
) -> Real {
    let coarse = 2.0 * reach_max;
    let reach_min = reach.iter().cloned().fold(Real::INFINITY, Real::min);
    // (reach_min > 0.0 is false for a NaN too)
    let positive = reach_min > 0.0;
    if !positive || !coarse.is_finite() || reach_max < 1.5 * reach_min {
        return coarse;
    }
    if coarse / 16.0 >= 2.0 * reach_min {
        // beyond the divisors below (size ratios of 16 and more)
        return search_cell_wide(x, reach, reach_max, reach_min, period);
    }
    // candidates per unit volume: the particles over their bounding box
    let (lo, hi) = bounds(x);
    let mut volume = 1.0;
    for k in 0..D {
        volume *= (hi[k] - lo[k]).max(coarse);
    }
    let density = x.len() as Real / volume;
    // Costs relative to a small particle's candidate test, fitted by least squares to
    // the pair search's times on the size-ratio benchmark's packs (ratios 1 to 8,
    // divisors 1 to 6; studies/HISTORY.md, commit a630553): a small particle's row of
    // cells (a loop that exits at a different count each time), a large particle's
    // candidate (it also keeps its partners of lower index), its row of cells (no
    // test per row, an empty run where the row is out of reach), its fixed cost (the
    // ball's gap tables, a longer list to sort), a cell built.
    const ROW: Real = 10.0;
    const LARGE: Real = 3.0;
    const LARGE_ROW: Real = 4.0;
    const LARGE_FIXED: Real = 300.0;
    const CELL: Real = 1.0;
    // the reaches of at most about 1024 particles, evenly strided, stand for all:
    // the estimate then costs little beside the search at any N
    let stride = (reach.len() / 1024).max(1);
    let sample = reach.len().div_ceil(stride) as Real;
    let scale = reach.len() as Real / sample;
    let cost = |cell: Real| -> Real {
        let cells_per_particle = volume / cell.powi(D as i32) / x.len() as Real;
        let small_cost = density * (3.0 * cell).powi(D as i32) + ROW * 3.0_f64.powi(D as i32 - 1);
        // a ball's stencil: about pi/6 (3D) or pi/4 (2D) of its bounding cube's cells,
        // and pi/4 of its rows (3D)
        let (ball, rows) = if D == 3 { (0.52, 0.79) } else { (0.79, 1.0) };
        let mut total = 0.0;
        for &r in reach.iter().step_by(stride) {
            total += if r <= 0.5 * cell {
                small_cost
            } else {
                let side = (2.0 * ((r + reach_max) / cell).ceil() + 1.0).min(1e9);
                LARGE * ball * density * (side * cell).powi(D as i32)
                    + LARGE_ROW * rows * side.powi(D as i32 - 1)
                    + LARGE_FIXED
            };
        }
        total *= scale;
        total + CELL * cells_per_particle.min(8.0) * x.len() as Real
    };
    let mut best = (cost(coarse), coarse);
    for s in [1.5, 2.0, 3.0, 4.0, 6.0, 8.0, 12.0, 16.0] {
        let cell = coarse / s;
        if cell < 2.0 * reach_min {
            break;
        }
        let c = cost(cell);
        if c < best.0 {
            best = (c, cell);
        }
    }
    best.1
}

/// [`search_cell`] at size ratios of 16 and more (a few large particles among fines
/// 16 to 1000s of times smaller), where the divisors 1 to 16 leave cells that hold
/// hundreds or thousands of fines. The divisors go on (1.5, 2, 3, 4, 6, 8, 12, ...) down
/// to the finest cell, 2 reach_min, or to the smallest cell the grid allows (about 8
/// cells a particle: the grid then grows its cells itself), and the cost model of
/// [`search_cell`] reads the density where the particles are:
///
/// - a small particle's candidates: the density of the centres around it (a histogram
///   of about N/4 cells over the centres' bounding box, read at about 1024 sampled
///   particles) times its 3^D cells, at most N: a cluster of fines beside one large
///   particle far away is dense, though the bounding box of all centres is not;
/// - a large particle's stencil: clamped to the grid (a ball wider than the pack visits
///   every cell once, its candidates at most N).
fn search_cell_wide<const D: usize>(
    x: &[Vector<D>],
    reach: &[Real],
    reach_max: Real,
    reach_min: Real,
    period: Option<&Period<D>>,
) -> Real {
    let n = x.len();
    let nr = n as Real;
    let coarse = 2.0 * reach_max;
    let (lo, hi) = bounds(x);
    // the grid's extent per axis: the centres', or the whole period on a periodic axis
    let mut ext = [0.0 as Real; D];
    let mut wrap = [false; D];
    for k in 0..D {
        ext[k] = hi[k] - lo[k];
        if let Some(per) = period.filter(|per| per.periodic(k)) {
            ext[k] = per.len[k];
            wrap[k] = true;
        }
        if !ext[k].is_finite() {
            return coarse;
        }
    }
    // the local density: a histogram of about N/4 cells over the centres' bounding box
    let mut bbox = 1.0;
    for k in 0..D {
        bbox *= (hi[k] - lo[k]).max(2.0 * reach_min);
    }
    let mut side_h = (bbox / (0.25 * nr).max(1.0))
        .powf(1.0 / D as Real)
        .max(2.0 * reach_min);
    let mut dims_h = [1usize; D];
    // (a long thin spread of centres: coarser bins, at most about 4 a particle)
    let limit = (4 * n + 64) as Real;
    for _ in 0..64 {
        let mut total = 1.0;
        for k in 0..D {
            total *= ((hi[k] - lo[k]) / side_h).floor() + 1.0;
        }
        if total <= limit || !total.is_finite() {
            break;
        }
        side_h *= (total / limit).powf(1.0 / D as Real) * 1.01;
    }
    if !side_h.is_finite() {
        return coarse;
    }
    for k in 0..D {
        dims_h[k] = (((hi[k] - lo[k]) / side_h).floor() as usize).saturating_add(1);
    }
    let cells_h = dims_h.iter().product::<usize>();
    if cells_h > 4 * n + 64 {
        return coarse;
    }
    let cell_h = |p: &Vector<D>| -> usize {
        (0..D).rev().fold(0usize, |acc, k| {
            let c = (((p[k] - lo[k]) / side_h) as usize).min(dims_h[k] - 1);
            acc * dims_h[k] + c
        })
    };
    let mut counts = vec![0u32; cells_h];
    for p in x {
        counts[cell_h(p)] += 1;
    }
    let vol_h = side_h.powi(D as i32);
    // as in search_cell (fitted at ratios 1 to 8)
    const ROW: Real = 10.0;
    const LARGE: Real = 3.0;
    const LARGE_ROW: Real = 4.0;
    const LARGE_FIXED: Real = 300.0;
    const CELL: Real = 1.0;
    let stride = (n / 1024).max(1);
    let sample: Vec<(Real, Real)> = (0..n)
        .step_by(stride)
        .map(|i| (reach[i], counts[cell_h(&x[i])] as Real / vol_h))
        .collect();
    let scale = nr / sample.len() as Real;
    let max_cells = (8 * n + 64) as Real;
    let dims_at = |cell: Real| -> [Real; D] {
        let mut d = [1.0; D];
        for k in 0..D {
            d[k] = if wrap[k] {
                (ext[k] / cell).floor().max(1.0)
            } else {
                (ext[k] / cell).floor() + 1.0
            };
        }
        d
    };
    let (ball, rows_frac) = if D == 3 { (0.52, 0.79) } else { (0.79, 1.0) };
    let cost = |cell: Real| -> Real {
        let dims = dims_at(cell);
        let cells: Real = dims.iter().product();
        let mut volume = 1.0;
        for e in ext {
            volume *= e.max(cell);
        }
        let density = nr / volume;
        let small_rows = ROW * 3.0_f64.powi(D as i32 - 1);
        let mut total = 0.0;
        for &(r, local) in &sample {
            total += if r <= 0.5 * cell {
                (local * (3.0 * cell).powi(D as i32)).min(nr) + small_rows
            } else {
                let side = 2.0 * ((r + reach_max) / cell).ceil() + 1.0;
                let mut span = 1.0;
                let mut rows = 1.0;
                for (k, &dk) in dims.iter().enumerate() {
                    let v = side.min(dk);
                    span *= v * cell;
                    if k > 0 {
                        rows *= v;
                    }
                }
                LARGE * (ball * density * span).min(nr) + LARGE_ROW * rows_frac * rows + LARGE_FIXED
            };
        }
        total * scale + CELL * cells.min(max_cells)
    };
    let mut best = (cost(coarse), coarse);
    let mut s = 1.0;
    let mut step = 1.5;
    loop {
        s *= step;
        step = if step == 1.5 { 4.0 / 3.0 } else { 1.5 };
        let mut cell = coarse / s;
        if cell < 2.0 * reach_min || !cell.is_finite() {
            break;
        }
        // below the grid's smallest cell the grid grows its cells: that cell, then stop
        let cells: Real = dims_at(cell).iter().product();
        let capped = cells > max_cells;
        if capped {
            cell *= (cells / max_cells).powf(1.0 / D as Real) * 1.01;
        }
        let c = cost(cell);
        if c < best.0 {
            best = (c, cell);
        }
        if capped {
            break;
        }
    }
    best.1
}

/// The search behind all three: each particle `i` with `from(i)` (and each large one)
/// tests the candidates in the cells around it and takes its pairs with j > i, and
/// those with j < i when `lower(j)` (the partner is never visited itself).
///
/// The grid's cells are chosen by [`search_cell`]. A small particle (reach at most half
/// a cell) visits the 3^D cells around its own and pairs only with small ones there; a
/// large one visits every cell within reach_i + reach_max and takes all its pairs with
/// small particles, and those with larger indices among the large ones. A pair is thus
/// taken once, from its large end if it has one.
///
/// Visiting the whole shell (instead of a half shell) doubles the distance tests, but
/// every `i` then finds all its partners j > i itself: sorting those few per `i` and
/// concatenating the parallel chunks in order gives the list sorted by (i, j) without
/// a global sort, which cost more than the extra tests. Only the pairs taken from their
/// upper end (the active particles next to frozen ones, and a large particle's smaller
/// partners of lower index) need a sort and a merge.
fn search<const D: usize>(
    x: &[Vector<D>],
    reach: &[Real],
    period: Option<&Period<D>>,
    sep: impl Fn(Vector<D>) -> Vector<D> + Sync,
    from: impl Fn(usize) -> bool + Sync,
    lower: impl Fn(usize) -> bool + Sync,
) -> Vec<[u32; 2]> {
    if x.len() < 2 {
        return Vec::new();
    }
    let reach_max = reach
        .par_iter()
        .with_min_len(PAR_MIN)
        .cloned()
        .reduce(|| 0.0, Real::max);
    if let Some(per) = period {
        let reach_min = reach
            .par_iter()
            .with_min_len(PAR_MIN)
            .cloned()
            .reduce(|| Real::INFINITY, Real::min);
        if let Some((xg, left)) = unwrap_gaps(x, per, 2.0 * reach_max, reach_min) {
            let cell = search_cell(&xg, reach, reach_max, left.as_ref());
            return search_in(
                x,
                &xg,
                reach,
                reach_max,
                cell,
                left.as_ref(),
                sep,
                from,
                lower,
            );
        }
    }
    let cell = search_cell(x, reach, reach_max, period);
    search_in(x, x, reach, reach_max, cell, period, sep, from, lower)
}

/// The periodic axes of `per` along which the centres leave an empty stretch of at
/// least `cut` (the largest cutoff, 2 reach_max): no pair crosses that stretch, so the
/// axis can be searched as a bounded one whose ends lie in the stretch. A cluster in a
/// wide periodic cell (a period above 4 reach_max around one large particle holds few
/// small ones) then gets a grid over the centres instead of a few coarse cells over the
/// whole period, capped at about 8 cells a particle.
///
/// Returns the positions for the grid, shifted by one period below the middle of each
/// stretch (so that the occupied part of the axis is one interval), and the axes left
/// periodic (None: none); None where no axis has such a stretch. The pair distances stay
/// those of the given positions: the shift only places particles in cells.
fn unwrap_gaps<const D: usize>(
    x: &[Vector<D>],
    per: &Period<D>,
    cut: Real,
    reach_min: Real,
) -> Option<(Vec<Vector<D>>, Option<Period<D>>)> {
    // bins of a histogram of the centres along the axis; a stretch is its empty bins
    const BINS: usize = 4096;
    let mut left = *per;
    let mut split = [Real::NAN; D];
    let mut any = false;
    for k in 0..D {
        if !per.periodic(k) {
            continue;
        }
        let (lo, len) = (per.lo[k], per.len[k]);
        // the shift by one period must stay far below a cell (rounding of x + L)
        if !(len.is_finite() && cut > 0.0 && (lo.abs() + 2.0 * len) < 1e6 * reach_min) {
            continue;
        }
        let w = len / BINS as Real;
        let occupied = x
            .par_chunks(PAR_MIN)
            .map(|chunk| {
                let mut occ = vec![false; BINS];
                for p in chunk {
                    let b = ((p[k] - lo) / w).clamp(0.0, (BINS - 1) as Real) as usize;
                    occ[b] = true;
                }
                occ
            })
            .reduce(
                || vec![false; BINS],
                |mut a, b| {
                    a.iter_mut().zip(&b).for_each(|(a, b)| *a |= b);
                    a
                },
            );
        // the longest circular run of empty bins, from just after an occupied one
        let Some(first) = occupied.iter().position(|&o| o) else {
            continue;
        };
        let (mut best, mut best_start, mut run, mut start) = (0usize, 0usize, 0usize, 0usize);
        for m in 1..=BINS {
            let b = (first + m) % BINS;
            if occupied[b] {
                if run > best {
                    (best, best_start) = (run, start);
                }
                run = 0;
            } else {
                if run == 0 {
                    start = b;
                }
                run += 1;
            }
        }
        // a centre on a bin's edge may be counted in the bin beside: two bins spare
        if best < 3 || ((best - 2) as Real) * w < cut {
            continue;
        }
        let mid = (best_start + best / 2) % BINS;
        split[k] = lo + mid as Real * w;
        left = left.without_axis(k);
        any = true;
    }
    if !any {
        return None;
    }
    let xg = x
        .iter()
        .map(|p| {
            let mut q = *p;
            for k in 0..D {
                // (false for the NaN of an axis left as it is)
                if q[k] < split[k] {
                    q[k] += per.len[k];
                }
            }
            q
        })
        .collect();
    let still = (0..D).any(|k| left.periodic(k));
    Some((xg, still.then_some(left)))
}

/// [`search`] on a grid with cells of side at least `cell` (m); any cell gives the
/// same pairs. `reach_max` (m) is the largest of `reach`. `xg` places the particles in
/// the grid (`x` itself, or `x` shifted by a period along axes searched as bounded, see
/// [`unwrap_gaps`]); distances are those of `x`.
#[allow(clippy::too_many_arguments)]
fn search_in<const D: usize>(
    x: &[Vector<D>],
    xg: &[Vector<D>],
    reach: &[Real],
    reach_max: Real,
    cell: Real,
    period: Option<&Period<D>>,
    sep: impl Fn(Vector<D>) -> Vector<D> + Sync,
    from: impl Fn(usize) -> bool + Sync,
    lower: impl Fn(usize) -> bool + Sync,
) -> Vec<[u32; 2]> {
    let n = x.len();
    if n < 2 {
        return Vec::new();
    }
    let grid = CellGrid::build_with(xg, cell, period);
    // a small particle's pairs with small ones lie in the 3^D cells around it; with
    // shifted positions, a hair less, so that the shift's rounding never moves a partner
    // beyond the next cell
    let shifted = !std::ptr::eq(x, xg);
    let half_cell = if shifted {
        0.5 * grid.cell_size() * (1.0 - 1e-9)
    } else {
        0.5 * grid.cell_size()
    };
    // Positions and reaches copied in cell order: a row of cells is then one contiguous
    // stretch of each, read in sequence instead of gathered through the indices.
    let members = grid.members();
    // A separation is its own minimum image away from the grid's periodic edges
    // (`CellGrid::plain_separations_at`), where the grid's positions are the particles'
    // own: positions shifted by a period (`unwrap_gaps`) keep `sep`'s image everywhere.
    let plain_near = !shifted;
    let xs: Vec<Vector<D>> = members
        .par_iter()
        .with_min_len(PAR_MIN)
        .map(|&j| x[j as usize])
        .collect();
    let reach_s: Vec<Real> = members
        .par_iter()
        .with_min_len(PAR_MIN)
        .map(|&j| reach[j as usize])
        .collect();
    const CHUNK: usize = 1024;
    // per chunk: the pairs taken from their lower end, and from their upper end
    type Found = (Vec<[u32; 2]>, Vec<[u32; 2]>);
    let chunks: Vec<Found> = (0..n.div_ceil(CHUNK))
        .into_par_iter()
        .map(|c| {
            let mut up = Vec::new();
            let mut down = Vec::new();
            let mut mine: Vec<u32> = Vec::new();
            let mut below: Vec<u32> = Vec::new();
            for i in c * CHUNK..((c + 1) * CHUNK).min(n) {
                let (xi, reach_i) = (x[i], reach[i]);
                let gi = xg[i];
                let mut w = 0usize;
                if reach_i > half_cell {
                    // large: every partner within reach; a pair with another large
                    // one is taken from its lower index, a pair with a small one here
                    // with an active filter: a pair with an active particle
                    let active_i = from(i);
                    let mut wb = 0usize;
                    grid.for_each_row_within(&gi, reach_i + reach_max, |run| {
                        if mine.len() < w + run.len() {
                            mine.resize(w + run.len(), 0);
                        }
                        if below.len() < wb + run.len() {
                            below.resize(wb + run.len(), 0);
                        }
                        // branch-free as below, the partners of lower index too (a
                        // branch there mispredicts for about half the small partners);
                        // i itself is not near (ju > i and ju < i fail)
                        for ((&j, xj), &reach_j) in members[run.clone()]
                            .iter()
                            .zip(&xs[run.clone()])
                            .zip(&reach_s[run])
                        {
                            let ju = j as usize;
                            let cut = reach_i + reach_j;
                            let near =
                                (sep(xj - xi).norm_squared() < cut * cut) & (active_i | !lower(ju));
                            mine[w] = j;
                            w += (near & (ju > i)) as usize;
                            below[wb] = j;
                            wb += (near & (ju < i) & (reach_j <= half_cell)) as usize;
                        }
                    });
                    down.extend(below[..wb].iter().map(|&j| [j, i as u32]));
                } else if from(i) {
                    let mut small = Partners {
                        i,
                        xi,
                        reach_i,
                        half_cell,
                        members,
                        xs: &xs,
                        reach_s: &reach_s,
                        mine: &mut mine,
                        w,
                        down: &mut down,
                    };
                    // Away from the periodic edges the image's rounding per
                    // component is skipped, with the same squared distances bit for
                    // bit (the bounded rows and the plain separation cost about half
                    // of the wrapped ones).
                    let c = grid.coords(&gi);
                    if plain_near && grid.plain_separations_at(&c) {
                        grid.for_each_row_in(&c, |run| small.visit(run, |d| d, &lower));
                    } else {
                        grid.for_each_row_in(&c, |run| small.visit(run, &sep, &lower));
                    }
                    w = small.w;
                }
                let mine = &mut mine[..w];
                mine.sort_unstable();
                up.extend(mine.iter().map(|&j| [i as u32, j]));
            }
            (up, down)
        })
        .collect();
    let mut up = Vec::with_capacity(chunks.iter().map(|c| c.0.len()).sum());
    let mut down = Vec::new();
    for (u, d) in chunks {
        up.extend_from_slice(&u);
        down.extend_from_slice(&d);
    }
    if down.is_empty() {
        return up;
    }
    down.sort_unstable();
    // merge the two sorted runs (they share no pair: each is taken from one end only)
    let mut out = Vec::with_capacity(up.len() + down.len());
    let (mut a, mut b) = (0, 0);
    while a < up.len() || b < down.len() {
        if b == down.len() || (a < up.len() && up[a] < down[b]) {
            out.push(up[a]);
            a += 1;
        } else {
            out.push(down[b]);
            b += 1;
        }
    }
    out
}

/// A small particle's search: its partners of higher index (`mine`, `w` of them so
/// far) and the pairs it takes from their upper end (`down`).
struct Partners<'a, const D: usize> {
    i: usize,
    xi: Vector<D>,
    reach_i: Real,
    half_cell: Real,
    members: &'a [u32],
    xs: &'a [Vector<D>],
    reach_s: &'a [Real],
    mine: &'a mut Vec<u32>,
    w: usize,
    down: &'a mut Vec<[u32; 2]>,
}

impl<const D: usize> Partners<'_, D> {
    /// Tests the candidates of one run of cells, with separations `sep(x_j - x_i)`.
    /// Branch-free: every candidate is written to the next slot, and the count
    /// advances only for a small partner above i within the cutoff (a branch there went
    /// either way and mispredicted).
    #[inline(always)]
    fn visit(
        &mut self,
        run: std::ops::Range<usize>,
        sep: impl Fn(Vector<D>) -> Vector<D>,
        lower: impl Fn(usize) -> bool,
    ) {
        let (i, xi, reach_i, half_cell) = (self.i, self.xi, self.reach_i, self.half_cell);
        let mut w = self.w;
        if self.mine.len() < w + run.len() {
            self.mine.resize(w + run.len(), 0);
        }
        for ((&j, xj), &reach_j) in self.members[run.clone()]
            .iter()
            .zip(&self.xs[run.clone()])
            .zip(&self.reach_s[run])
        {
            let ju = j as usize;
            let cut = reach_i + reach_j;
            let near = (sep(xj - xi).norm_squared() < cut * cut) & (reach_j <= half_cell);
            self.mine[w] = j;
            w += (near & (ju > i)) as usize;
            if near & (ju < i) && lower(ju) {
                self.down.push([j, i as u32]);
            }
        }
        self.w = w;
    }
}

/// The O(N^2) reference for [`neighbor_pairs`] (tests and oracles only).
pub fn brute_force_pairs<const D: usize>(x: &[Vector<D>], reach: &[Real]) -> Vec<[u32; 2]> {
    let mut out = Vec::new();
    for i in 0..x.len() {
        for j in i + 1..x.len() {
            let cut = reach[i] + reach[j];
            if (x[j] - x[i]).norm_squared() < cut * cut {
                out.push([i as u32, j as u32]);
            }
        }
    }
    out
}

/// The O(N^2) reference for [`neighbor_pairs_periodic`]: distances by minimum image
/// (tests and oracles only).
pub fn brute_force_pairs_periodic<const D: usize>(
    x: &[Vector<D>],
    reach: &[Real],
    period: &Period<D>,
) -> Vec<[u32; 2]> {
    let mut out = Vec::new();
    for i in 0..x.len() {
        for j in i + 1..x.len() {
            let cut = reach[i] + reach[j];
            if period.image(x[j] - x[i]).norm_squared() < cut * cut {
                out.push([i as u32, j as u32]);
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// n particles in the unit box with radii in 0.01 x [1, ratio], and their reaches:
    /// the radius plus a half skin of its own in [0, skin / 2] (m).
    fn cloud<const D: usize>(
        seed: u64,
        n: usize,
        ratio: f64,
        skin: f64,
    ) -> (Vec<Vector<D>>, Vec<Real>) {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let x = (0..n)
            .map(|_| Vector::<D>::from_fn(|_, _| rng.random::<f64>()))
            .collect();
        let reach = (0..n)
            .map(|_| {
                let r = 0.01 * (1.0 + (ratio - 1.0) * rng.random::<f64>());
                r + 0.5 * skin * rng.random::<f64>()
            })
            .collect();
        (x, reach)
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(48))]
        #[test]
        fn grid_pairs_equal_brute_force_3d(seed in 0u64..10_000, n in 0usize..600,
                                           ratio in 1.0f64..4.0, skin in 0.0f64..0.01) {
            let (x, reach) = cloud::<3>(seed, n, ratio, skin);
            prop_assert_eq!(neighbor_pairs(&x, &reach), brute_force_pairs(&x, &reach));
        }

        /// The active-only search returns exactly the brute-force pairs that touch
        /// an active particle.
        #[test]
        fn active_pairs_equal_filtered_brute_force(seed in 0u64..10_000, n in 0usize..400,
                                                   ratio in 1.0f64..4.0, skin in 0.0f64..0.01,
                                                   frac in 0.0f64..1.0) {
            let (x, reach) = cloud::<3>(seed, n, ratio, skin);
            let active: Vec<bool> = (0..n).map(|k| ((k * 7919) % 100) as f64 >= 100.0 * frac).collect();
            let expect: Vec<[u32; 2]> = brute_force_pairs(&x, &reach)
                .into_iter()
                .filter(|&[i, j]| active[i as usize] || active[j as usize])
                .collect();
            prop_assert_eq!(neighbor_pairs_active(&x, &reach, None, |i| active[i]), expect);
        }

        /// An active top over an inactive bed (a settling deposit whose lower layers
        /// froze), with a few active particles deep in the bed: the search over the
        /// top's band finds exactly the brute-force pairs with an active particle, in
        /// a box and in a cell periodic in x and y.
        #[test]
        fn active_top_pairs_equal_filtered_brute_force(seed in 0u64..10_000, n in 0usize..500,
                                                       ratio in 1.0f64..4.0, skin in 0.0f64..0.01,
                                                       level in 0.0f64..1.0, thawed in 0usize..4,
                                                       periodic: bool) {
            let (x, reach) = cloud::<3>(seed, n, ratio, skin);
            let active: Vec<bool> = (0..n)
                .map(|k| x[k][2] > level || (thawed > 0 && k % 97 < thawed))
                .collect();
            let per = Period::new(&Vector::<3>::zeros(), &Vector::<3>::repeat(1.0), &[true, true, false]);
            let all = if periodic {
                brute_force_pairs_periodic(&x, &reach, &per)
            } else {
                brute_force_pairs(&x, &reach)
            };
            let expect: Vec<[u32; 2]> = all
                .into_iter()
                .filter(|&[i, j]| active[i as usize] || active[j as usize])
                .collect();
            let got = neighbor_pairs_active(&x, &reach, periodic.then_some(&per), |i| active[i]);
            prop_assert_eq!(got, expect);
        }

        /// Periodic in x and y (3D) with a free z: the grid's pairs, across the seam
        /// too, equal the brute-force minimum-image pairs, for polydisperse reaches
        /// and periods down to a few cells (the wrapped stencil then meets itself).
        #[test]
        fn periodic_pairs_equal_brute_force_3d(seed in 0u64..10_000, n in 0usize..500,
                                               ratio in 1.0f64..4.0, skin in 0.0f64..0.01,
                                               frac in 0.0f64..1.0) {
            let (x, reach) = cloud::<3>(seed, n, ratio, skin);
            let per = Period::new(&Vector::<3>::zeros(), &Vector::<3>::repeat(1.0), &[true, true, false]);
            prop_assert_eq!(neighbor_pairs_periodic(&x, &reach, Some(&per)), brute_force_pairs_periodic(&x, &reach, &per));
            let active: Vec<bool> = (0..n).map(|k| ((k * 7919) % 100) as f64 >= 100.0 * frac).collect();
            let expect: Vec<[u32; 2]> = brute_force_pairs_periodic(&x, &reach, &per)
                .into_iter()
                .filter(|&[i, j]| active[i as usize] || active[j as usize])
                .collect();
            prop_assert_eq!(neighbor_pairs_active(&x, &reach, Some(&per), |i| active[i]), expect);
        }

        /// The same in 2D, periodic in x, in cells of 0.2 to 1 m: down to 2 cells a period.
        #[test]
        fn periodic_pairs_equal_brute_force_2d(seed in 0u64..10_000, n in 0usize..500,
                                               ratio in 1.0f64..4.0, skin in 0.0f64..0.01,
                                               side in 0.2f64..1.0) {
            let (x, reach) = cloud::<2>(seed, n, ratio, skin);
            let x: Vec<Vector<2>> = x.iter().map(|p| Vector::<2>::new(p[0] * side, p[1])).collect();
            let per = Period::new(&Vector::<2>::zeros(), &Vector::<2>::new(side, 1.0), &[true, false]);
            prop_assert_eq!(neighbor_pairs_periodic(&x, &reach, Some(&per)), brute_force_pairs_periodic(&x, &reach, &per));
        }

        /// Size ratios up to 20 (cells sized for the largest reach hold hundreds of
        /// the smallest): the search finds exactly the brute-force pairs, in a box and
        /// in a periodic cell, 2D and 3D, and from the active particles only.
        #[test]
        fn wide_size_ratios_equal_brute_force(seed in 0u64..10_000, n in 0usize..500,
                                              ratio in 1.0f64..20.0, skin in 0.0f64..0.01,
                                              periodic in proptest::bool::ANY) {
            let (x, reach) = cloud::<3>(seed, n, ratio, skin);
            let reach: Vec<Real> = reach.iter().map(|r| 0.5 * r).collect();
            let per = Period::new(&Vector::<3>::zeros(), &Vector::<3>::repeat(1.0), &[true, true, false]);
            if periodic {
                prop_assert_eq!(neighbor_pairs_periodic(&x, &reach, Some(&per)), brute_force_pairs_periodic(&x, &reach, &per));
            } else {
                prop_assert_eq!(neighbor_pairs(&x, &reach), brute_force_pairs(&x, &reach));
            }
            let (x2, reach2) = cloud::<2>(seed, n, ratio, skin);
            prop_assert_eq!(neighbor_pairs(&x2, &reach2), brute_force_pairs(&x2, &reach2));
            let active: Vec<bool> = (0..n).map(|k| k % 3 != 0).collect();
            let expect: Vec<[u32; 2]> = brute_force_pairs(&x, &reach)
                .into_iter()
                .filter(|&[i, j]| active[i as usize] || active[j as usize])
                .collect();
            prop_assert_eq!(neighbor_pairs_active(&x, &reach, None, |i| active[i]), expect);
        }

        /// Cells smaller than the largest cutoff (2 reach_max / s, down to s = 12,
        /// whatever the cost model would choose): small particles pair among
        /// themselves in 3^D cells, large ones through their wide stencils, and the
        /// pairs are exactly the brute-force ones, in a box and in a periodic cell
        /// (periods of a few cells to many), 2D and 3D, from all particles or from the
        /// active ones.
        #[test]
        fn any_cell_gives_the_brute_force_pairs(seed in 0u64..10_000, n in 0usize..400,
                                                ratio in 1.0f64..12.0, skin in 0.0f64..0.01,
                                                s in 1.0f64..12.0, side in 0.3f64..1.0,
                                                periodic in proptest::bool::ANY) {
            let active: Vec<bool> = (0..n).map(|k| k % 3 != 0).collect();
            let (x, reach) = cloud::<3>(seed, n, ratio, skin);
            let x: Vec<Vector<3>> = x.iter().map(|p| Vector::<3>::new(p[0] * side, p[1], p[2])).collect();
            let reach: Vec<Real> = reach.iter().map(|r| 0.5 * r).collect();
            let reach_max = reach.iter().cloned().fold(0.0, Real::max);
            let cell = 2.0 * reach_max / s;
            let per = Period::new(&Vector::<3>::zeros(), &Vector::<3>::new(side, 1.0, 1.0), &[true, true, false]);
            let (pairs, expect) = if periodic {
                (search_in(&x, &x, &reach, reach_max, cell, Some(&per), |d| per.image(d), |_| true, |_| false),
                 brute_force_pairs_periodic(&x, &reach, &per))
            } else {
                (search_in(&x, &x, &reach, reach_max, cell, None, |d| d, |_| true, |_| false),
                 brute_force_pairs(&x, &reach))
            };
            prop_assert_eq!(&pairs, &expect);
            let expect: Vec<[u32; 2]> = expect
                .into_iter()
                .filter(|&[i, j]| active[i as usize] || active[j as usize])
                .collect();
            let sep = |d| if periodic { per.image(d) } else { d };
            let pairs = search_in(&x, &x, &reach, reach_max, cell, periodic.then_some(&per), sep,
                                  |i| active[i], |j| !active[j]);
            prop_assert_eq!(pairs, expect);
            let (x2, reach2) = cloud::<2>(seed, n, ratio, skin);
            let reach_max2 = reach2.iter().cloned().fold(0.0, Real::max);
            let cell2 = 2.0 * reach_max2 / s;
            let per2 = Period::new(&Vector::<2>::zeros(), &Vector::<2>::repeat(1.0), &[true, false]);
            prop_assert_eq!(search_in(&x2, &x2, &reach2, reach_max2, cell2, Some(&per2), |d| per2.image(d), |_| true, |_| false),
                            brute_force_pairs_periodic(&x2, &reach2, &per2));
        }

        /// One particle 16 to 1000 times larger than a cluster of fines that touches it
        /// (the fines' cells a few of their diameters, the large one's stencil clamped
        /// to the grid): the brute-force pairs, in a box and in a periodic cell wider than
        /// 4 large radii, where the fines leave most of the period empty (the search
        /// then treats the axis as bounded) and may straddle the seam; 3D and 2D.
        #[test]
        fn one_large_particle_among_fines_gives_the_brute_force_pairs(
            seed in 0u64..10_000, n in 2usize..400, ratio in 16.0f64..1000.0,
            periodic in proptest::bool::ANY, at in 0.0f64..1.0, skin in 0.0f64..0.004) {
            use rand::{Rng, SeedableRng};
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
            let big = 0.01 * ratio;
            let period = 4.5 * big;
            let side = 0.02 * (n as f64).cbrt().max(1.0);
            // the cluster's corner: anywhere along the period (across the seam too)
            let corner = at * period;
            let mut x3: Vec<Vector<3>> = (0..n)
                .map(|_| Vector::<3>::new(
                    corner + side * rng.random::<f64>(),
                    corner + side * rng.random::<f64>(),
                    big + side * rng.random::<f64>(),
                ))
                .collect();
            x3.push(Vector::<3>::new(corner + 0.5 * side, corner + 0.5 * side, 0.0));
            let mut reach: Vec<Real> = (0..n).map(|_| 0.01 + skin * rng.random::<f64>()).collect();
            reach.push(big);
            let per3 = Period::new(&Vector::<3>::zeros(), &Vector::<3>::new(period, period, 1.0), &[true, true, false]);
            if periodic {
                let xw: Vec<Vector<3>> = x3.iter().map(|p| per3.wrap(*p)).collect();
                prop_assert_eq!(neighbor_pairs_periodic(&xw, &reach, Some(&per3)),
                                brute_force_pairs_periodic(&xw, &reach, &per3));
                let active: Vec<bool> = (0..=n).map(|k| k % 3 != 0).collect();
                let expect: Vec<[u32; 2]> = brute_force_pairs_periodic(&xw, &reach, &per3)
                    .into_iter()
                    .filter(|&[i, j]| active[i as usize] || active[j as usize])
                    .collect();
                prop_assert_eq!(neighbor_pairs_active(&xw, &reach, Some(&per3), |i| active[i]), expect);
            } else {
                prop_assert_eq!(neighbor_pairs(&x3, &reach), brute_force_pairs(&x3, &reach));
            }
            let x2: Vec<Vector<2>> = x3.iter().map(|p| Vector::<2>::new(p[0], p[2])).collect();
            let per2 = Period::new(&Vector::<2>::zeros(), &Vector::<2>::new(period, 1.0), &[true, false]);
            if periodic {
                let xw: Vec<Vector<2>> = x2.iter().map(|p| per2.wrap(*p)).collect();
                prop_assert_eq!(neighbor_pairs_periodic(&xw, &reach, Some(&per2)),
                                brute_force_pairs_periodic(&xw, &reach, &per2));
            } else {
                prop_assert_eq!(neighbor_pairs(&x2, &reach), brute_force_pairs(&x2, &reach));
            }
        }

        #[test]
        fn grid_pairs_equal_brute_force_2d(seed in 0u64..10_000, n in 0usize..600,
                                           ratio in 1.0f64..4.0, skin in 0.0f64..0.01) {
            let (x, reach) = cloud::<2>(seed, n, ratio, skin);
            prop_assert_eq!(neighbor_pairs(&x, &reach), brute_force_pairs(&x, &reach));
        }
    }

    #[test]
    fn a_cluster_in_a_wide_periodic_cell_is_searched_as_bounded() {
        // a cluster across the seam of x, spread over the whole period along y
        let per = Period::new(
            &Vector::<3>::zeros(),
            &Vector::<3>::new(10.0, 1.0, 1.0),
            &[true, true, false],
        );
        let x: Vec<Vector<3>> = (0..50)
            .map(|k| Vector::<3>::new(if k % 2 == 0 { 0.01 } else { 9.99 }, k as f64 / 50.0, 0.5))
            .collect();
        let (xg, left) = unwrap_gaps(&x, &per, 0.5, 0.01).expect("a gap along x");
        let left = left.expect("y stays periodic");
        assert!(!left.periodic(0) && left.periodic(1) && !left.periodic(2));
        // one interval along x: the particles below the gap moved up by the period
        let (lo, hi) = xg
            .iter()
            .fold((Real::INFINITY, Real::NEG_INFINITY), |(l, h), p| {
                (l.min(p[0]), h.max(p[0]))
            });
        assert!(hi - lo < 0.05, "{lo} {hi}");
        assert!(unwrap_gaps(&x, &per, 9.99, 0.01).is_none());
        let r = vec![0.011; 50];
        assert_eq!(
            neighbor_pairs_periodic(&x, &r, Some(&per)),
            brute_force_pairs_periodic(&x, &r, &per)
        );
    }

    #[test]
    fn sparse_far_apart_particles_do_not_blow_up_the_grid() {
        let x = vec![
            Vector::<3>::new(0.0, 0.0, 0.0),
            Vector::<3>::new(1e6, 0.0, 0.0),
            Vector::<3>::new(1e6 + 0.015, 0.0, 0.0),
        ];
        let r = vec![0.01; 3];
        let g = CellGrid::build(&x, 0.02);
        assert!(g.start.len() < 200);
        assert_eq!(neighbor_pairs(&x, &r), vec![[1, 2]]);
    }
}

/// Spreads the low 21 bits of `v` so that two zero bits separate each (3D Morton).
fn spread3(v: u64) -> u64 {
    let mut x = v & 0x1f_ffff;
    x = (x | (x << 32)) & 0x1f00000000ffff;
    x = (x | (x << 16)) & 0x1f0000ff0000ff;
    x = (x | (x << 8)) & 0x100f00f00f00f00f;
    x = (x | (x << 4)) & 0x10c30c30c30c30c3;
    x = (x | (x << 2)) & 0x1249249249249249;
    x
}

/// The componentwise minimum of the points, None for none: the origin of the storage
/// orders' cells.
fn lower_corner<const D: usize>(x: &[Vector<D>]) -> Option<Vector<D>> {
    x.iter().copied().reduce(|lo, p| lo.inf(&p))
}

/// A permutation that visits the points in Morton (Z-curve) order of cells of side
/// `cell` (m), ties broken by index. Particles stored in this order are neighbours in
/// memory when they are neighbours in space, which keeps the pair loop in cache.
pub fn morton_order<const D: usize>(x: &[Vector<D>], cell: Real) -> Vec<usize> {
    let Some(lo) = lower_corner(x) else {
        return Vec::new();
    };
    let mut keys: Vec<(u64, usize)> = x
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let mut key = 0u64;
            for k in 0..D {
                let c = ((p[k] - lo[k]) / cell).clamp(0.0, 2_097_151.0) as u64;
                key |= spread3(c) << k;
            }
            (key, i)
        })
        .collect();
    keys.sort_unstable();
    keys.into_iter().map(|(_, i)| i).collect()
}

/// A permutation that visits the points row by row through cells of side `cell` (m):
/// in 3D the cells ordered by (y, z, x), x fastest; in 2D by (y, x), x fastest (y is
/// vertical in 2D, z in 3D); ties broken by index.
///
/// Why not [`morton_order`]: the settled step streams each sphere's pairs and reads its
/// partners' state where they lie. In this order a sphere's partners lie in its own row
/// of cells and in the rows beside it, a few runs that move through memory in step with
/// it, which the hardware prefetchers follow; a Z-curve puts some partners across its
/// coarse boundaries, far from the sphere in memory. At 0.57 and 1.08 million spheres
/// the step took 20 % less on one core in this order and 23 % less on two
/// (`studies/row_order/`). The axis order is measured: a horizontal axis fastest (the
/// longest runs), the vertical in the middle in 3D (at 0.9 million spheres in a cell
/// 11 m wide and 0.5 m high, (y, z, x) 125-128 ns a particle-step, (z, y, x) 135, (y,
/// x, z) with z fastest 134-136, Morton 155).
pub fn row_major_order<const D: usize>(x: &[Vector<D>], cell: Real) -> Vec<usize> {
    let Some(lo) = lower_corner(x) else {
        return Vec::new();
    };
    // slowest to fastest
    let axes: &[usize] = if D == 3 { &[1, 2, 0] } else { &[1, 0] };
    let mut keys: Vec<(u64, usize)> = x
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let key = axes.iter().fold(0u64, |key, &k| {
                let c = ((p[k] - lo[k]) / cell).clamp(0.0, 2_097_151.0) as u64;
                (key << 21) | c
            });
            (key, i)
        })
        .collect();
    keys.sort_unstable();
    keys.into_iter().map(|(_, i)| i).collect()
}

#[cfg(test)]
mod morton_tests {
    use super::*;

    /// Coordinates whose extent overflows (+-1e308) end in one cell, not in an endless
    /// search for a cell size.
    #[test]
    fn overflowing_extent_gives_one_cell() {
        let x = vec![Vector::<2>::new(1e308, 1.0), Vector::<2>::new(-1e308, 1.0)];
        assert!(neighbor_pairs(&x, &[0.1, 0.1]).is_empty());
        let g = CellGrid::build(&x, 0.2);
        assert_eq!(g.members().len(), 2);
    }

    #[test]
    fn morton_order_is_a_permutation_grouping_cells() {
        let x: Vec<Vector<2>> = (0..64)
            .map(|i| Vector::<2>::new((i % 8) as f64, (i / 8) as f64))
            .collect();
        let p = morton_order(&x, 1.0);
        let mut s = p.clone();
        s.sort();
        assert_eq!(s, (0..64).collect::<Vec<_>>());
        // the first four visited points form the 2x2 block at the origin
        let mut first: Vec<usize> = p[..4].to_vec();
        first.sort();
        assert_eq!(first, vec![0, 1, 8, 9]);
    }

    /// A 3D lattice of 4 x 3 x 2 cells, shuffled: the order visits it by (y, z, x), x
    /// fastest, whatever the input order; points sharing a cell keep their index order.
    #[test]
    fn row_major_order_visits_y_then_z_then_x() {
        let mut pts = Vec::new();
        for k in 0..24 {
            let (xi, yi, zi) = (k % 4, (k / 4) % 3, k / 12);
            pts.push(Vector::<3>::new(
                xi as f64 + 0.5,
                yi as f64 + 0.5,
                zi as f64 + 0.5,
            ));
        }
        // a fixed shuffle (a stride coprime to 24) and one twin of point 0's cell
        let mut x: Vec<Vector<3>> = (0..24).map(|k| pts[(k * 7) % 24]).collect();
        x.push(pts[0] + Vector::<3>::new(0.1, 0.1, 0.1));
        let order = row_major_order(&x, 1.0);
        let cells: Vec<(i64, i64, i64)> = order
            .iter()
            .map(|&i| (x[i][1] as i64, x[i][2] as i64, x[i][0] as i64))
            .collect();
        let mut sorted = cells.clone();
        sorted.sort();
        assert_eq!(cells, sorted);
        // the twin (index 24) follows the original of its cell (index 0)
        assert_eq!(order[..2], [0, 24]);
        let mut s = order.clone();
        s.sort();
        assert_eq!(s, (0..25).collect::<Vec<_>>());
        // 2D: y (vertical) slowest, x fastest
        let x2: Vec<Vector<2>> = [(1.5, 0.5), (0.5, 1.5), (0.5, 0.5), (1.5, 1.5)]
            .iter()
            .map(|&(a, b)| Vector::<2>::new(a, b))
            .collect();
        assert_eq!(row_major_order(&x2, 1.0), vec![2, 0, 1, 3]);
        assert!(row_major_order::<3>(&[], 1.0).is_empty());
    }
}
