//! Cell lists.
//!
//! Cells are cubes of side `cell` >= the largest interaction distance
//! (largest diameter + skin), so every pair closer than its cutoff lies in the same or
//! an adjacent cell (3^D cells to visit). Cells are filled by a counting sort, which is
//! stable: inside a cell particles keep increasing index order, and the pair list comes
//! out sorted by (i, j) whatever the thread count.

use crate::math::{Real, Vector};
use rayon::prelude::*;

/// A static cell grid over a set of positions.
#[derive(Clone, Debug)]
pub struct CellGrid<const D: usize> {
    cell: Real,
    dims: [usize; D],
    /// `start[c]..start[c + 1]` indexes `members` for cell `c`.
    start: Vec<u32>,
    members: Vec<u32>,
    /// Cell of each particle.
    cell_of: Vec<u32>,
}

impl<const D: usize> CellGrid<D> {
    /// Builds the grid with cells of side at least `min_cell` (m). When the particles
    /// are spread so thinly that the grid would exceed about 8 cells per particle, the
    /// cells grow instead (memory stays O(N); correctness is unaffected).
    pub fn build(x: &[Vector<D>], min_cell: Real) -> Self {
        let n = x.len();
        let mut lo = Vector::<D>::repeat(Real::INFINITY);
        let mut hi = Vector::<D>::repeat(Real::NEG_INFINITY);
        for p in x {
            lo = lo.inf(p);
            hi = hi.sup(p);
        }
        if n == 0 {
            lo = Vector::<D>::zeros();
            hi = Vector::<D>::zeros();
        }
        let max_cells = (8 * n + 64) as f64;
        let mut cell = min_cell.max(1e-300);
        let mut dims = [1usize; D];
        loop {
            let mut total = 1.0f64;
            for k in 0..D {
                let m = ((hi[k] - lo[k]) / cell).floor() + 1.0;
                total *= m;
            }
            if total <= max_cells {
                for k in 0..D {
                    dims[k] = (((hi[k] - lo[k]) / cell).floor() as usize) + 1;
                }
                break;
            }
            cell *= (total / max_cells).powf(1.0 / D as f64) * 1.01;
        }
        let ncell: usize = dims.iter().product();
        let cell_of: Vec<u32> = x
            .iter()
            .map(|p| {
                let mut c = 0usize;
                for k in (0..D).rev() {
                    let ik = (((p[k] - lo[k]) / cell) as usize).min(dims[k] - 1);
                    c = c * dims[k] + ik;
                }
                c as u32
            })
            .collect();
        let mut start = vec![0u32; ncell + 1];
        for &c in &cell_of {
            start[c as usize + 1] += 1;
        }
        for c in 0..ncell {
            start[c + 1] += start[c];
        }
        let mut fill = start.clone();
        let mut members = vec![0u32; n];
        for (i, &c) in cell_of.iter().enumerate() {
            members[fill[c as usize] as usize] = i as u32;
            fill[c as usize] += 1;
        }
        CellGrid {
            cell,
            dims,
            start,
            members,
            cell_of,
        }
    }

    /// Side of a cell (m).
    pub fn cell_size(&self) -> Real {
        self.cell
    }

    fn coords(&self, c: usize) -> [usize; D] {
        let mut out = [0usize; D];
        let mut c = c;
        for (o, &m) in out.iter_mut().zip(&self.dims) {
            *o = c % m;
            c /= m;
        }
        out
    }

    /// Calls `f(j)` for the particles that can pair with `i` without counting a pair
    /// twice: those after `i` in its own cell and all those in the "forward" half of
    /// the adjacent cells (offsets whose first nonzero component, from the last axis
    /// down, is positive: 13 of 26 in 3D, 4 of 8 in 2D).
    #[inline]
    pub fn for_each_half_candidate(&self, i: usize, mut f: impl FnMut(usize)) {
        let own = self.cell_of[i] as usize;
        let members = &self.members[self.start[own] as usize..self.start[own + 1] as usize];
        // members are in increasing index order (stable counting sort)
        let pos = members.partition_point(|&m| (m as usize) <= i);
        for &j in &members[pos..] {
            f(j as usize);
        }
        let ci = self.coords(own);
        let nb = 3usize.pow(D as u32);
        'outer: for m in 0..nb {
            let mut off = [0isize; D];
            let mut mm = m;
            for o in off.iter_mut() {
                *o = (mm % 3) as isize - 1;
                mm /= 3;
            }
            // forward half: the last nonzero offset component (highest axis) is +1
            match off.iter().rev().find(|&&o| o != 0) {
                Some(&1) => {}
                _ => continue,
            }
            let mut c = 0usize;
            for k in (0..D).rev() {
                let v = ci[k] as isize + off[k];
                if v < 0 || v >= self.dims[k] as isize {
                    continue 'outer;
                }
                c = c * self.dims[k] + v as usize;
            }
            for &j in &self.members[self.start[c] as usize..self.start[c + 1] as usize] {
                f(j as usize);
            }
        }
    }
}

impl<const D: usize> CellGrid<D> {
    /// Calls `f(j)` for every particle in the 3^D cells around `i`'s (`i` included).
    #[inline]
    pub fn for_each_candidate(&self, i: usize, mut f: impl FnMut(usize)) {
        let ci = self.coords(self.cell_of[i] as usize);
        'outer: for m in 0..3usize.pow(D as u32) {
            let mut mm = m;
            let mut c = 0usize;
            let mut stride = 1usize;
            for (&ck, &dk) in ci.iter().zip(&self.dims) {
                let v = ck as isize + (mm % 3) as isize - 1;
                mm /= 3;
                if v < 0 || v >= dk as isize {
                    continue 'outer;
                }
                c += v as usize * stride;
                stride *= dk;
            }
            for &j in &self.members[self.start[c] as usize..self.start[c + 1] as usize] {
                f(j as usize);
            }
        }
    }
}

/// The pairs of [`neighbor_pairs`] that have at least one particle `i` with `active(i)`,
/// sorted by (i, j). Pairs of two inactive particles are not searched at all: the
/// engine keeps those of frozen particles from an earlier search.
pub fn neighbor_pairs_active<const D: usize>(
    x: &[Vector<D>],
    r: &[Real],
    skin: Real,
    active: impl Fn(usize) -> bool + Sync,
) -> Vec<[u32; 2]> {
    // Every cell around an active particle is visited (a mixed pair is met only from its
    // active side); an active pair is taken from its lower index.
    search(x, r, skin, false, &active, |i, j| {
        j == i || (active(j) && j < i)
    })
}

/// Every pair (i < j) with |x_i - x_j| < r_i + r_j + skin, sorted by (i, j).
///
/// `skin` >= 0 (m) widens the cutoff so that the list stays valid while no particle has
/// moved more than skin / 2 (a Verlet list). Parallel over particles; the output does
/// not depend on the thread count.
pub fn neighbor_pairs<const D: usize>(x: &[Vector<D>], r: &[Real], skin: Real) -> Vec<[u32; 2]> {
    // Each pair is met once, from the particle whose cell is "behind" (half shell).
    search(x, r, skin, true, |_| true, |_, _| false)
}

/// The search behind both: a grid with cells of one cutoff, the particles `i` with
/// `from(i)` visited in parallel chunks, their candidates (the half shell or all 3^D
/// cells) tested unless `skip(i, j)`. Pairs are stored as (min, max) and sorted at the
/// end, which fixes the order whatever the thread count.
fn search<const D: usize>(
    x: &[Vector<D>],
    r: &[Real],
    skin: Real,
    half: bool,
    from: impl Fn(usize) -> bool + Sync,
    skip: impl Fn(usize, usize) -> bool + Sync,
) -> Vec<[u32; 2]> {
    let n = x.len();
    if n < 2 {
        return Vec::new();
    }
    let r_max = r.iter().cloned().fold(0.0, Real::max);
    let grid = CellGrid::build(x, 2.0 * r_max + skin);
    const CHUNK: usize = 1024;
    let chunks: Vec<Vec<[u32; 2]>> = (0..n.div_ceil(CHUNK))
        .into_par_iter()
        .map(|c| {
            let mut out = Vec::new();
            for i in (c * CHUNK..((c + 1) * CHUNK).min(n)).filter(|&i| from(i)) {
                let xi = x[i];
                let ri = r[i];
                let mut test = |j: usize| {
                    if skip(i, j) {
                        return;
                    }
                    let cut = ri + r[j] + skin;
                    if (x[j] - xi).norm_squared() < cut * cut {
                        out.push([i.min(j) as u32, i.max(j) as u32]);
                    }
                };
                if half {
                    grid.for_each_half_candidate(i, &mut test);
                } else {
                    grid.for_each_candidate(i, &mut test);
                }
            }
            out
        })
        .collect();
    let mut pairs = chunks.concat();
    pairs.par_sort_unstable();
    pairs
}

/// The O(N^2) reference for [`neighbor_pairs`] (tests and oracles only).
pub fn brute_force_pairs<const D: usize>(x: &[Vector<D>], r: &[Real], skin: Real) -> Vec<[u32; 2]> {
    let mut out = Vec::new();
    for i in 0..x.len() {
        for j in i + 1..x.len() {
            let cut = r[i] + r[j] + skin;
            if (x[j] - x[i]).norm_squared() < cut * cut {
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

    fn cloud<const D: usize>(seed: u64, n: usize, ratio: f64) -> (Vec<Vector<D>>, Vec<Real>) {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let x = (0..n)
            .map(|_| Vector::<D>::from_fn(|_, _| rng.random::<f64>()))
            .collect();
        let r = (0..n)
            .map(|_| 0.01 * (1.0 + (ratio - 1.0) * rng.random::<f64>()))
            .collect();
        (x, r)
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(48))]
        #[test]
        fn grid_pairs_equal_brute_force_3d(seed in 0u64..10_000, n in 0usize..600,
                                           ratio in 1.0f64..4.0, skin in 0.0f64..0.01) {
            let (x, r) = cloud::<3>(seed, n, ratio);
            prop_assert_eq!(neighbor_pairs(&x, &r, skin), brute_force_pairs(&x, &r, skin));
        }

        /// The active-only search returns exactly the brute-force pairs that touch
        /// an active particle.
        #[test]
        fn active_pairs_equal_filtered_brute_force(seed in 0u64..10_000, n in 0usize..400,
                                                   ratio in 1.0f64..4.0, skin in 0.0f64..0.01,
                                                   frac in 0.0f64..1.0) {
            let (x, r) = cloud::<3>(seed, n, ratio);
            let active: Vec<bool> = (0..n).map(|k| ((k * 7919) % 100) as f64 >= 100.0 * frac).collect();
            let expect: Vec<[u32; 2]> = brute_force_pairs(&x, &r, skin)
                .into_iter()
                .filter(|&[i, j]| active[i as usize] || active[j as usize])
                .collect();
            prop_assert_eq!(neighbor_pairs_active(&x, &r, skin, |i| active[i]), expect);
        }

        #[test]
        fn grid_pairs_equal_brute_force_2d(seed in 0u64..10_000, n in 0usize..600,
                                           ratio in 1.0f64..4.0, skin in 0.0f64..0.01) {
            let (x, r) = cloud::<2>(seed, n, ratio);
            prop_assert_eq!(neighbor_pairs(&x, &r, skin), brute_force_pairs(&x, &r, skin));
        }
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
        assert_eq!(neighbor_pairs(&x, &r, 0.0), vec![[1, 2]]);
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

/// A permutation that visits the points in Morton (Z-curve) order of cells of side
/// `cell` (m), ties broken by index. Particles stored in this order are neighbours in
/// memory when they are neighbours in space, which keeps the pair loop in cache.
pub fn morton_order<const D: usize>(x: &[Vector<D>], cell: Real) -> Vec<usize> {
    if x.is_empty() {
        return Vec::new();
    }
    let mut lo = x[0];
    for p in x {
        lo = lo.inf(p);
    }
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

#[cfg(test)]
mod morton_tests {
    use super::*;

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
}
